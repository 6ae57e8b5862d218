//! The scene's surface materials on the GPU (binding 31) for the near field on live objects
//! (`near_field.wgsl`): a live surface within a probe spacing of a scene surface gets the light
//! that surface sends, from its own material, instead of the irradiance probes' light from its
//! direction. Each scene triangle carries its material's index plus one in the hierarchy
//! (`FlatBvh::build_tagged`); this is the table the index reads.

use crate::occluders::{SceneMaterial, SceneMaterials};
use wgpu::util::DeviceExt;

/// vec4s per material in the table, after one vec4 of header.
pub(super) const MATERIAL_VEC4S: usize = 4;

/// The table's words: a header vec4 (x: the material count as f32; 0 turns the near field off)
/// and per material `MATERIAL_VEC4S` vec4s, laid out as `near_field.wgsl`'s
/// `near_surface_radiance` and `specular_chain.wgsl` read them: the diffuse reflectance and the
/// Blinn exponent, the glossy reflectance and the kind (0 lobes, 1 mirror, 2 glass), the
/// ambient term and `emission_cos2`, the emission and `emission_flat`. A mirror or glass has no
/// lobes, so its first vec4 holds `eta` in w (glass), its second a mirror's weight.
pub(super) fn material_table(materials: Option<&SceneMaterials>) -> Vec<[f32; 4]> {
    let list: &[SceneMaterial] = materials.map_or(&[], |m| &m.materials);
    let mut table = Vec::with_capacity(1 + MATERIAL_VEC4S * list.len());
    table.push([list.len() as f32, 0.0, 0.0, 0.0]);
    for m in list {
        if m.specular {
            let kind = if m.eta > 0.0 { 2.0 } else { 1.0 };
            table.push([0.0, 0.0, 0.0, m.eta]);
            table.push([m.reflect.x, m.reflect.y, m.reflect.z, kind]);
            table.push([m.ambient.x, m.ambient.y, m.ambient.z, m.emission_cos2]);
            table.push([m.emission.x, m.emission.y, m.emission.z, m.emission_flat]);
            continue;
        }
        table.push([m.diffuse.x, m.diffuse.y, m.diffuse.z, m.exponent]);
        table.push([m.glossy.x, m.glossy.y, m.glossy.z, 0.0]);
        table.push([m.ambient.x, m.ambient.y, m.ambient.z, m.emission_cos2]);
        table.push([m.emission.x, m.emission.y, m.emission.z, m.emission_flat]);
    }
    table
}

/// Uploads the table (a header alone without materials: the near field is then off).
pub(super) fn upload(device: &wgpu::Device, materials: Option<&SceneMaterials>) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("scene materials"),
        contents: bytemuck::cast_slice(&material_table(materials)),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_table_has_a_header_and_four_vec4s_per_material_and_tells_mirrors_from_glass() {
        assert_eq!(material_table(None), vec![[0.0; 4]]);
        let plastic = SceneMaterial {
            diffuse: Vec3::new(0.1, 0.2, 0.3),
            glossy: Vec3::splat(0.5),
            exponent: 10.0,
            ..SceneMaterial::default()
        };
        let mirror = SceneMaterial { specular: true, reflect: Vec3::splat(0.9), ..SceneMaterial::default() };
        let glass = SceneMaterial { specular: true, eta: 1.5, ..SceneMaterial::default() };
        let table = material_table(Some(&SceneMaterials {
            materials: vec![plastic, mirror, glass],
            of_triangle: vec![1],
        }));
        assert_eq!(table.len(), 1 + 3 * MATERIAL_VEC4S);
        assert_eq!(table[0][0], 3.0);
        assert_eq!(table[1], [0.1, 0.2, 0.3, 10.0]);
        assert_eq!(table[2], [0.5, 0.5, 0.5, 0.0]);
        assert_eq!(table[1 + MATERIAL_VEC4S], [0.0, 0.0, 0.0, 0.0]);
        assert_eq!(table[2 + MATERIAL_VEC4S], [0.9, 0.9, 0.9, 1.0]);
        assert_eq!(table[1 + 2 * MATERIAL_VEC4S], [0.0, 0.0, 0.0, 1.5]);
        assert_eq!(table[2 + 2 * MATERIAL_VEC4S], [0.0, 0.0, 0.0, 2.0]);
    }
}

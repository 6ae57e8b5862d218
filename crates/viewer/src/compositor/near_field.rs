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
/// `scene_material` reads them.
pub(super) fn material_table(materials: Option<&SceneMaterials>) -> Vec<[f32; 4]> {
    let list: &[SceneMaterial] = materials.map_or(&[], |m| &m.materials);
    let mut table = Vec::with_capacity(1 + MATERIAL_VEC4S * list.len());
    table.push([list.len() as f32, 0.0, 0.0, 0.0]);
    for m in list {
        let kind = if m.specular { 1.0 } else { 0.0 };
        table.push([m.diffuse.x, m.diffuse.y, m.diffuse.z, m.exponent]);
        table.push([m.glossy.x, m.glossy.y, m.glossy.z, kind]);
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
    fn the_table_has_a_header_and_four_vec4s_per_material() {
        assert_eq!(material_table(None), vec![[0.0; 4]]);
        let m = SceneMaterial {
            diffuse: Vec3::new(0.1, 0.2, 0.3),
            glossy: Vec3::splat(0.5),
            exponent: 10.0,
            specular: true,
            ..SceneMaterial::default()
        };
        let table = material_table(Some(&SceneMaterials { materials: vec![m; 2], of_triangle: vec![1] }));
        assert_eq!(table.len(), 1 + 2 * MATERIAL_VEC4S);
        assert_eq!(table[0][0], 2.0);
        assert_eq!(table[1], [0.1, 0.2, 0.3, 10.0]);
        assert_eq!(table[2], [0.5, 0.5, 0.5, 1.0]);
    }
}

//! `--live LIVE.rib` (CONTRACTS.md §6, docs/live-scene.md): a RIB fragment of world-space
//! objects read by the project's own parser, as `ReadArchive "LIVE.rib"` inside a world block,
//! so the fragment means exactly what it means to the ray tracer.

use glam::{DVec3, Vec3};
use rib_parser::scene::{Attributes, FileLoc, ParamList, Scene, Shape, ShapeEntity};
use std::path::Path;
use std::sync::Arc;
use viewer::{LiveMaterial, LiveMesh, LiveScene, LiveSphere, LiveSurface, Mesh};

/// Reads the fragment at `path`; errors are `file:line:col: error: ...` with the source line.
pub fn read_live_rib(path: &Path) -> Result<LiveScene, String> {
    let absolute = std::path::absolute(path).map_err(|e| format!("{}: error: {e}", path.display()))?;
    if !absolute.is_file() {
        return Err(format!("{}: error: cannot read the live objects' file", path.display()));
    }
    // The same lines inside a world block: the fragment's own requests keep their own file,
    // line and column in every diagnostic.
    let quoted = absolute.to_string_lossy().replace('\\', "\\\\").replace('"', "\\\"");
    let wrapper = format!("WorldBegin\nReadArchive \"{quoted}\"\nWorldEnd\n");
    let loaded = rib_parser::load_bytes("--live", wrapper.into_bytes(), &rib_parser::LoadOptions::default())
        .map_err(|e| e.render().trim_end().to_string())?;
    let warnings = loaded.render_warnings();
    if !warnings.trim().is_empty() {
        eprint!("{warnings}");
    }
    live_scene(&loaded.scene, &path.display().to_string())
}

/// The spheres and meshes of a scene built from a fragment; anything the live scene cannot
/// hold is an error at its request.
pub fn live_scene(scene: &Scene, file: &str) -> Result<LiveScene, String> {
    let mut live = LiveScene::default();
    if !scene.lights.is_empty() {
        return Err(format!("{file}: error: live objects cannot hold lights ({} found)", scene.lights.len()));
    }
    if let Some(instance) = scene.instances.first() {
        return Err(format!("{}: error: live objects cannot use ObjectInstance", instance.loc));
    }
    for entity in &scene.shapes {
        let material = live_material(scene.attributes_of(entity.attributes), &entity.loc)?;
        if let Some(sphere) = whole_sphere(entity) {
            live.spheres.push(LiveSphere { centre: sphere.0, radius: sphere.1, material });
            continue;
        }
        if !tessellate::is_surface(&entity.shape) {
            let kind = tessellate::shape_kind(&entity.shape);
            return Err(format!("{}: error: {kind} is not a surface a live object can have", entity.loc));
        }
        let triangles = tessellate::tessellate(&entity.shape, &tessellate::Tolerance::relative(1e-3))
            .map_err(|e| format!("{}: error: {e}", entity.loc))?;
        let mesh = mesh_of(&triangles, scene.attributes_of(entity.attributes).reverse_orientation);
        mesh.validate().map_err(|e| format!("{}: error: {e}", entity.loc))?;
        if !mesh.indices.is_empty() {
            live.meshes.push(LiveMesh {
                mesh: Arc::new(mesh),
                world_from_object: entity.world_from_object,
                material,
            });
        }
    }
    Ok(live)
}

/// Centre and radius of a full `Sphere` under a transform that keeps it a sphere.
fn whole_sphere(entity: &ShapeEntity) -> Option<(DVec3, f64)> {
    let Shape::Sphere { radius, z_min, z_max, theta_max_degrees } = *entity.shape else {
        return None;
    };
    let r = radius.abs();
    if z_min > -r || z_max < r || theta_max_degrees.abs() < 360.0 {
        return None;
    }
    let m = entity.world_from_object;
    let scales = [m.x_axis.truncate().length(), m.y_axis.truncate().length(), m.z_axis.truncate().length()];
    let orthogonal = m.x_axis.truncate().dot(m.y_axis.truncate()).abs() <= 1e-9 * scales[0] * scales[1]
        && m.y_axis.truncate().dot(m.z_axis.truncate()).abs() <= 1e-9 * scales[1] * scales[2]
        && m.x_axis.truncate().dot(m.z_axis.truncate()).abs() <= 1e-9 * scales[0] * scales[2];
    let uniform = (scales[0] - scales[1]).abs() <= 1e-9 * scales[0]
        && (scales[0] - scales[2]).abs() <= 1e-9 * scales[0];
    let affine = m.row(3) == glam::DVec4::new(0.0, 0.0, 0.0, 1.0);
    (orthogonal && uniform && affine).then(|| (m.transform_point3(DVec3::ZERO), f64::from(r) * scales[0]))
}

/// The viewer's mesh: smooth normals where the surface has them, flat ones (vertices split per
/// triangle) for polygons without `N`, flipped with `ReverseOrientation`.
fn mesh_of(triangles: &tessellate::TriangleMesh, reverse: bool) -> Mesh {
    let mut mesh = Mesh { positions: Vec::new(), normals: Vec::new(), indices: Vec::new() };
    let sign = if reverse { -1.0 } else { 1.0 };
    match &triangles.normals {
        Some(normals) => {
            mesh.positions = triangles.positions.clone();
            mesh.normals = normals.iter().map(|n| *n * sign).collect();
            mesh.indices = triangles.indices.as_flattened().to_vec();
        }
        None => {
            for [a, b, c] in &triangles.indices {
                let [pa, pb, pc] = [*a, *b, *c].map(|i| triangles.positions[i as usize]);
                let normal = (pb - pa).cross(pc - pa).normalize_or_zero() * sign;
                let base = mesh.positions.len() as u32;
                mesh.positions.extend_from_slice(&[pa, pb, pc]);
                mesh.normals.extend_from_slice(&[normal; 3]);
                mesh.indices.extend_from_slice(&[base, base + 1, base + 2]);
            }
        }
    }
    if reverse {
        for t in mesh.indices.chunks_mut(3) {
            t.swap(1, 2);
        }
    }
    mesh
}

fn param(params: &ParamList, name: &str, default: f32) -> f32 {
    params.float(name).filter(|v| v.is_finite()).unwrap_or(default)
}

fn non_negative(c: Vec3) -> Vec3 {
    Vec3::select(c.cmpge(Vec3::ZERO), c, Vec3::ZERO)
}

/// The surface shader with the ray tracer's defaults (`raytracer::materials`).
fn live_material(attributes: &Attributes, shape_loc: &FileLoc) -> Result<LiveMaterial, String> {
    let colour = non_negative(attributes.color);
    let opacity = non_negative(attributes.opacity).min(Vec3::ONE);
    let Some(call) = &attributes.surface else {
        // Inside the scene the fragment would take the world block's current shader, which the
        // fragment alone cannot know.
        return Err(format!(
            "{}: error: live objects need a Surface (matte, plastic, paintedplastic, metal or shinymetal)",
            shape_loc
        ));
    };
    let p = |n: &str, d: f32| param(&call.params, n, d);
    let roughness = p("roughness", 0.1).max(1e-4);
    let surface = match call.name.as_str() {
        "matte" => LiveSurface::Matte { ka: p("Ka", 1.0), kd: p("Kd", 1.0) },
        "plastic" | "paintedplastic" if call.params.string("texturename").is_none_or(str::is_empty) => {
            LiveSurface::Plastic {
                ka: p("Ka", 1.0),
                kd: p("Kd", 0.5),
                ks: p("Ks", 0.5),
                roughness,
                specular_colour: call.params.vec3("specularcolor").map(non_negative).unwrap_or(Vec3::ONE),
            }
        }
        "metal" => LiveSurface::Metal { ka: p("Ka", 1.0), ks: p("Ks", 1.0), roughness },
        "shinymetal" if call.params.string("texturename").is_none_or(str::is_empty) => {
            LiveSurface::ShinyMetal { ka: p("Ka", 1.0), ks: p("Ks", 1.0), kr: p("Kr", 1.0), roughness }
        }
        "paintedplastic" | "shinymetal" => {
            return Err(format!("{}: error: live objects cannot be textured (texturename)", call.loc));
        }
        other => {
            return Err(format!(
                "{}: error: Surface \"{other}\" is not a live shader (matte, plastic, paintedplastic, metal, shinymetal)",
                call.loc
            ));
        }
    };
    Ok(LiveMaterial { surface, colour, opacity })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<LiveScene, String> {
        let dir = tempfile::TempDir::new().unwrap();
        let path = dir.path().join("live.rib");
        std::fs::write(&path, text).unwrap();
        read_live_rib(&path)
    }

    #[test]
    fn spheres_and_polygons_in_world_space_with_the_ray_tracers_defaults() {
        let live = read(
            "AttributeBegin\n Translate 1 2 3\n Scale 2 2 2\n Color [0.5 0.25 1]\n Surface \"plastic\" \"roughness\" 0.2\n Sphere 0.5 -0.5 0.5 360\nAttributeEnd\n\
             AttributeBegin\n Surface \"matte\"\n Polygon \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]\nAttributeEnd\n",
        )
        .unwrap();
        assert_eq!(live.spheres.len(), 1);
        let s = live.spheres[0];
        assert!((s.centre - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12 && (s.radius - 1.0).abs() < 1e-12);
        assert_eq!(s.material.colour, Vec3::new(0.5, 0.25, 1.0));
        assert_eq!(
            s.material.surface,
            LiveSurface::Plastic { ka: 1.0, kd: 0.5, ks: 0.5, roughness: 0.2, specular_colour: Vec3::ONE }
        );
        assert_eq!(live.meshes.len(), 1);
        assert_eq!(live.meshes[0].mesh.indices.len(), 6);
        assert_eq!(live.meshes[0].material.surface, LiveSurface::Matte { ka: 1.0, kd: 1.0 });
        assert!(live.meshes[0].mesh.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    }

    #[test]
    fn errors_name_the_fragments_file_line_and_column() {
        let err =
            read("AttributeBegin\n  Surface \"glass\"\n  Sphere 1 -1 1 360\nAttributeEnd\n").unwrap_err();
        assert!(err.contains("live.rib:2:3: error:") && err.contains("glass"), "{err}");
        let err = read("AttributeBegin\n  Sphere 1 -1 1 360\n").unwrap_err();
        assert!(err.contains("live.rib:") && err.contains("error"), "{err}");
    }
}

//! The RIB scene tessellated for the viewer's shadow rays: the scene's own shadows on live
//! objects (docs/viewer-lighting.md, "The scene's shadows on live objects"). With haptics the same
//! tessellation is shared with them (at theirs, the finer tolerance), so the scene is
//! tessellated once at startup. Each triangle also carries its shape's material, for the near
//! field on live objects (docs/viewer-lighting.md, "Near a large scene surface").

use glam::Vec3;
use rib_parser::scene::{Attributes, AttributesId, ParamList, Scene};
use std::collections::HashMap;
use std::time::Instant;
use tessellate::{SceneMeshes, Tolerance, tessellate_scene};
use viewer::occluders::{MAX_SCENE_OCCLUDER_TRIANGLES, SceneMaterial, SceneMaterials, SceneOccluders};

/// The tolerance of the shadow rays' triangles without haptics: 1e-3 of each shape's size, as
/// the haptics' own (`haptics::scene::tessellation_tolerance`, which also bounds it by the
/// proxy's radius, so it is never coarser than this one).
pub fn viewer_tolerance() -> Tolerance {
    Tolerance::relative(1e-3)
}

/// Tessellates `scene` once at `tolerance` for the viewer's shadow rays (and whoever shares
/// the meshes); with `stats`, says on stderr how long it took.
pub fn tessellate_once(scene: &rib_parser::scene::Scene, tolerance: &Tolerance, stats: bool) -> SceneMeshes {
    let start = Instant::now();
    let meshes = tessellate_scene(scene, tolerance);
    for name in &meshes.unreadable_textures {
        eprintln!(
            "warning: bumpy's texture \"{name}\" cannot be read: the surface is displaced as if it read 0"
        );
    }
    if stats {
        eprintln!(
            "scene tessellated once: {} triangles in {:.1} ms",
            meshes.triangle_count(),
            start.elapsed().as_secs_f64() * 1e3
        );
    }
    meshes
}

/// Every surface of `meshes` as world-space triangles. Says on stderr what is left out:
/// shapes that gave no triangles, and triangles over the viewer's budget.
pub fn scene_occluders(meshes: &SceneMeshes) -> SceneOccluders {
    let mut triangles = Vec::with_capacity(meshes.triangle_count().min(1 << 24) as usize);
    for m in &meshes.meshes {
        let p = &m.mesh.positions;
        for t in &m.mesh.indices {
            let corner = |i: u32| p.get(i as usize).map(|v| v.as_dvec3());
            if let (Some(a), Some(b), Some(c)) = (corner(t[0]), corner(t[1]), corner(t[2])) {
                triangles.push([a, b, c]);
            }
        }
    }
    // Points and curves give no triangles (thin, they hide little light): left out quietly.
    let failed = meshes.skipped.iter().filter(|s| !s.error.is_not_a_surface()).count();
    if failed > 0 {
        eprintln!("note: {failed} shape(s) could not be tessellated and cast no shadow on live objects");
    }
    if triangles.len() > MAX_SCENE_OCCLUDER_TRIANGLES {
        eprintln!(
            "note: the scene's {} triangles exceed the viewer's budget of {MAX_SCENE_OCCLUDER_TRIANGLES}: only the largest shadow live objects",
            triangles.len()
        );
    }
    SceneOccluders { triangles }
}

/// The material of each triangle [`scene_occluders`] gives (in its order), one per attribute
/// state the shapes use.
pub fn scene_materials(scene: &Scene, meshes: &SceneMeshes) -> SceneMaterials {
    let mut index: HashMap<AttributesId, u32> = HashMap::new();
    let mut materials = SceneMaterials::default();
    for m in &meshes.meshes {
        let k = *index.entry(m.attributes).or_insert_with(|| {
            materials.materials.push(scene_material(scene.attributes_of(m.attributes)));
            materials.materials.len() as u32 - 1
        });
        let valid =
            m.mesh.indices.iter().filter(|t| t.iter().all(|&i| (i as usize) < m.mesh.positions.len()));
        materials.of_triangle.extend(valid.map(|_| k));
    }
    materials
}

fn param(params: &ParamList, name: &str, default: f32) -> f32 {
    params.float(name).filter(|v| v.is_finite()).unwrap_or(default)
}

/// Each channel finite and at least 0 (the ray tracer's `clamp_color`).
fn clamp_colour(c: Vec3) -> Vec3 {
    Vec3::select(c.is_finite_mask(), c, Vec3::ZERO).max(Vec3::ZERO)
}

/// Two reflectances scaled down together so that their sum is at most one in every channel
/// (the ray tracer's `conserve`).
fn conserve(a: Vec3, b: Vec3) -> (Vec3, Vec3) {
    let sum = (a + b).max_element();
    if sum > 1.0 { (a / sum, b / sum) } else { (a, b) }
}

/// A shape's surface shader as the ray tracer's BSDF has it (`raytracer::materials`): the
/// Lambertian and Blinn lobes' reflectances, `Ka * Cs`, and `constant`'s and
/// `defaultsurface`'s own emission; `mirror` and `glass` are marked specular, a mirror with
/// its reflection's weight and glass with its `eta`, as the ray tracer has them. Textures
/// (`paintedplastic`, `shinymetal`'s environment) are left out: the colour is `Cs` alone, and
/// `shinymetal`'s mirror lobe too. Unknown shaders are `matte` with their `Kd` and `Ka`, as the
/// ray tracer takes them.
pub fn scene_material(attributes: &Attributes) -> SceneMaterial {
    let cs = clamp_colour(attributes.color);
    let empty = ParamList::default();
    let (name, params) = match &attributes.surface {
        Some(call) => (call.name.as_str(), &call.params),
        None => ("defaultsurface", &empty),
    };
    let p = |n: &str, d: f32| param(params, n, d);
    let exponent = (1.0 / p("roughness", 0.1).max(1e-4)).clamp(1.0, 10_000.0);
    let ambient = |ka: f32| if ka > 0.0 { cs * ka } else { Vec3::ZERO };
    let matte = |kd: f32, ka: f32| SceneMaterial {
        diffuse: (cs * kd.max(0.0)).min(Vec3::ONE),
        ambient: ambient(ka),
        ..SceneMaterial::default()
    };
    match name {
        "constant" => SceneMaterial { emission: cs, emission_flat: 1.0, ..SceneMaterial::default() },
        "defaultsurface" => SceneMaterial {
            emission: cs,
            emission_flat: p("Ka", 0.2),
            emission_cos2: p("Kd", 0.8),
            ..SceneMaterial::default()
        },
        "plastic" | "paintedplastic" => {
            let specular = params.vec3("specularcolor").map(clamp_colour).unwrap_or(Vec3::ONE);
            let (diffuse, glossy) = conserve(cs * p("Kd", 0.5).max(0.0), specular * p("Ks", 0.5).max(0.0));
            SceneMaterial {
                diffuse,
                glossy,
                exponent,
                ambient: ambient(p("Ka", 1.0)),
                ..SceneMaterial::default()
            }
        }
        "metal" => SceneMaterial {
            glossy: (cs * p("Ks", 1.0).max(0.0)).min(Vec3::ONE),
            exponent,
            ambient: ambient(p("Ka", 1.0)),
            ..SceneMaterial::default()
        },
        "shinymetal" => {
            let (glossy, _mirror) = conserve(cs * p("Ks", 1.0).max(0.0), cs * p("Kr", 1.0).max(0.0));
            SceneMaterial { glossy, exponent, ambient: ambient(p("Ka", 1.0)), ..SceneMaterial::default() }
        }
        "mirror" => SceneMaterial {
            specular: true,
            reflect: (cs * p("Kr", 1.0).max(0.0)).min(Vec3::ONE),
            ..SceneMaterial::default()
        },
        "glass" => {
            let eta =
                params.float("eta").or_else(|| params.float("index")).filter(|e| e.is_finite() && *e > 0.0);
            SceneMaterial { specular: true, eta: eta.unwrap_or(1.5), ..SceneMaterial::default() }
        }
        _ => matte(p("Kd", 1.0), p("Ka", 1.0)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raytracer::bsdf::Lobe;
    use raytracer::materials::Material;
    use rib_parser::scene::{FileLoc, Param, ParamDecl, ParamType, ParamValues, ShaderCall, StorageClass};

    /// A parameter's name and values.
    type Float<'a> = (&'a str, &'a [f32]);

    fn call(name: &str, floats: &[Float<'_>]) -> ShaderCall {
        let params = floats
            .iter()
            .map(|(n, v)| Param {
                name: n.to_string(),
                decl: ParamDecl {
                    class: StorageClass::Uniform,
                    ty: if v.len() == 3 { ParamType::Color } else { ParamType::Float },
                    array_len: 1,
                },
                values: ParamValues::Floats(v.to_vec()),
                loc: FileLoc::new("t.rib", 1, 1),
            })
            .collect();
        ShaderCall { name: name.to_string(), params: ParamList(params), loc: FileLoc::new("t.rib", 1, 1) }
    }

    /// The lobes' reflectances and `Ka * Cs` equal the ray tracer's for each shader.
    #[test]
    fn the_materials_are_the_ray_tracers() {
        let cases: [(&str, &[Float<'_>]); 9] = [
            ("matte", &[("Kd", &[0.9])]),
            ("plastic", &[("Kd", &[0.7]), ("Ks", &[0.3]), ("roughness", &[0.1])]),
            ("plastic", &[("Kd", &[1.0]), ("Ks", &[1.0]), ("specularcolor", &[1.0, 0.5, 0.25])]),
            ("metal", &[("roughness", &[0.15]), ("Ka", &[0.5])]),
            ("shinymetal", &[("Ks", &[0.6]), ("Kr", &[0.8])]),
            ("wood", &[("Kd", &[0.4])]),
            ("mirror", &[]),
            ("mirror", &[("Kr", &[0.7])]),
            ("glass", &[("Kr", &[0.9]), ("Kt", &[0.8]), ("eta", &[1.33])]),
        ];
        for (name, floats) in cases {
            let attributes = Attributes {
                color: Vec3::new(0.8, 0.2, 0.15),
                surface: Some(call(name, floats)),
                ..Attributes::default()
            };
            let ours = scene_material(&attributes);
            let theirs = Material::from_attributes(&attributes, &mut |_| Err(String::new()), &mut Vec::new());
            let bsdf = theirs.bsdf(Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Z, Vec3::X, glam::Vec2::ZERO, 0.0);
            let (mut diffuse, mut glossy, mut exponent, mut specular) = (Vec3::ZERO, Vec3::ZERO, 0.0, false);
            let (mut reflect, mut eta) = (Vec3::ZERO, 0.0);
            for lobe in bsdf.lobes() {
                match *lobe {
                    Lobe::Lambert { r } => diffuse = r,
                    Lobe::Blinn { ks, exponent: e } => (glossy, exponent) = (ks, e),
                    Lobe::SpecularReflection { r } => (specular, reflect) = (true, r),
                    Lobe::Dielectric { eta: e, .. } => (specular, eta) = (true, e),
                }
            }
            assert!(
                (ours.diffuse - diffuse).abs().max_element() < 1e-6,
                "{name}: {} {diffuse}",
                ours.diffuse
            );
            assert!((ours.glossy - glossy).abs().max_element() < 1e-6, "{name}: {} {glossy}", ours.glossy);
            if glossy != Vec3::ZERO {
                assert_eq!(ours.exponent, exponent, "{name}");
            }
            let ambient = theirs.ambient_reflectance(glam::Vec2::ZERO, 0.0);
            assert!((ours.ambient - ambient).abs().max_element() < 1e-6, "{name}");
            // shinymetal's mirror lobe is left out; mirror and glass have only specular lobes.
            let specular_shader = name == "mirror" || name == "glass";
            assert_eq!(ours.specular, specular && specular_shader, "{name}");
            if name == "mirror" {
                assert!(
                    (ours.reflect - reflect).abs().max_element() < 1e-6,
                    "{name}: {} {reflect}",
                    ours.reflect
                );
            }
            if name == "glass" {
                assert_eq!(ours.eta, eta, "{name}");
            }
        }
    }

    /// Every triangle gets its shape's material; shapes under one attribute state share it.
    #[test]
    fn each_triangle_has_its_shapes_material() {
        let text = "WorldBegin\n\
            AttributeBegin\n Color [1 0 0]\n Surface \"matte\"\n Polygon \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]\nAttributeEnd\n\
            AttributeBegin\n Surface \"metal\"\n Polygon \"P\" [0 0 1 1 0 1 1 1 1]\nAttributeEnd\n\
            WorldEnd\n";
        let dir = tempfile::TempDir::new().unwrap();
        let path = dir.path().join("scene.rib");
        std::fs::write(&path, text).unwrap();
        let scene = rib_parser::load_scene(&path, &rib_parser::LoadOptions::default()).unwrap().scene;
        let meshes = tessellate_once(&scene, &viewer_tolerance(), false);
        let occluders = scene_occluders(&meshes);
        let materials = scene_materials(&scene, &meshes);
        assert_eq!(materials.of_triangle.len(), occluders.triangles.len());
        assert_eq!(materials.materials.len(), 2);
        for (t, &m) in occluders.triangles.iter().zip(&materials.of_triangle) {
            let material = materials.materials[m as usize];
            if t[0].z == 0.0 {
                assert_eq!(material.diffuse, Vec3::new(1.0, 0.0, 0.0));
            } else {
                assert_eq!(material.glossy, Vec3::ONE);
            }
        }
    }
}

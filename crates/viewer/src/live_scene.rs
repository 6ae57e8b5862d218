//! The live objects a `--live LIVE.rib` fragment describes (CONTRACTS.md §6, docs/live-scene.md):
//! world-space spheres and triangle meshes with RenderMan's standard surface shaders, their
//! parameters and defaults exactly as the ray tracer reads them (`raytracer::materials`), so a
//! compositor can shade them as the ray trace of `ReadArchive "LIVE.rib"` does.
//!
//! `hybrid-view` builds a [`LiveScene`] from the RIB (the viewer library does not depend on the
//! parser); [`LiveScene::add_to`] is the simplest drawing hook: every object as a mesh
//! with the viewer's plastic-like [`Material`].

use crate::live::{LiveObjects, Material, Mesh, MeshInstance};
use glam::{DMat4, DVec3, Vec3};
use std::sync::Arc;

/// A standard surface shader with RenderMan's parameters (defaults in brackets):
/// `matte` (`Ka` 1, `Kd` 1), `plastic` and `paintedplastic` without a texture (`Ka` 1, `Kd` .5,
/// `Ks` .5, `roughness` .1, `specularcolor` 1), `metal` (`Ka` 1, `Ks` 1, `roughness` .1),
/// `shinymetal` (`Ka` 1, `Ks` 1, `Kr` 1, `roughness` .1). Roughness is at least `1e-4`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LiveSurface {
    Matte { ka: f32, kd: f32 },
    Plastic { ka: f32, kd: f32, ks: f32, roughness: f32, specular_colour: Vec3 },
    Metal { ka: f32, ks: f32, roughness: f32 },
    ShinyMetal { ka: f32, ks: f32, kr: f32, roughness: f32 },
}

/// A surface shader with the attribute state it is used with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveMaterial {
    pub surface: LiveSurface,
    /// `Color` (Cs), clamped to be non-negative.
    pub colour: Vec3,
    /// `Opacity` (Os), clamped to `[0, 1]`.
    pub opacity: Vec3,
}

/// A whole sphere in world space (the RIB's `Sphere` with its full sweep under a similarity
/// transform).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveSphere {
    pub centre: DVec3,
    pub radius: f64,
    pub material: LiveMaterial,
}

/// A triangle mesh in its object space, placed by `world_from_object`; wound counter-clockwise
/// around the front-side normals, which are per vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveMesh {
    pub mesh: Arc<Mesh>,
    pub world_from_object: DMat4,
    pub material: LiveMaterial,
}

/// Everything a `--live` fragment describes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LiveScene {
    pub spheres: Vec<LiveSphere>,
    pub meshes: Vec<LiveMesh>,
}

impl LiveMaterial {
    /// The nearest of the viewer's plastic-like materials: the diffuse and glossy lobes with
    /// the same weights (metal's glossy lobe is tinted by `Cs`; shinymetal's mirror lobe is
    /// left out until probes can light it).
    pub fn to_viewer_material(&self) -> Material {
        let base = Material { colour: self.colour, unlit: false, ..Material::default() };
        match self.surface {
            LiveSurface::Matte { ka, kd } => Material { ka, kd, ks: 0.0, ..base },
            LiveSurface::Plastic { ka, kd, ks, roughness, specular_colour } => {
                Material { ka, kd, ks, roughness, specular_colour, ..base }
            }
            LiveSurface::Metal { ka, ks, roughness } | LiveSurface::ShinyMetal { ka, ks, roughness, .. } => {
                Material { ka, kd: 0.0, ks, roughness, specular_colour: self.colour, ..base }
            }
        }
    }
}

impl LiveScene {
    /// True when the fragment described nothing to draw.
    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty() && self.meshes.is_empty()
    }

    /// Adds every object to `live` as a mesh instance (spheres as a shared unit sphere of
    /// `sphere_mesh`), with [`LiveMaterial::to_viewer_material`].
    pub fn add_to(&self, live: &mut LiveObjects, sphere_mesh: &Arc<Mesh>) {
        for s in &self.spheres {
            live.meshes.push(MeshInstance {
                mesh: sphere_mesh.clone(),
                world_from_object: DMat4::from_translation(s.centre)
                    * DMat4::from_scale(DVec3::splat(s.radius)),
                material: s.material.to_viewer_material(),
                exact_sphere: Some((s.centre, s.radius)),
            });
        }
        for m in &self.meshes {
            live.meshes.push(MeshInstance {
                mesh: m.mesh.clone(),
                world_from_object: m.world_from_object,
                material: m.material.to_viewer_material(),
                exact_sphere: None,
            });
        }
    }
}

impl Mesh {
    /// A unit sphere about the origin as a latitude-longitude mesh of `rings` x `segments`
    /// quads (at least 2 x 3) with exact normals, wound counter-clockwise seen from outside.
    pub fn unit_sphere(rings: u32, segments: u32) -> Mesh {
        let (rings, segments) = (rings.max(2), segments.max(3));
        let mut mesh = Mesh { positions: Vec::new(), normals: Vec::new(), indices: Vec::new() };
        for i in 0..=rings {
            let polar = i as f32 / rings as f32 * std::f32::consts::PI;
            for k in 0..=segments {
                let a = k as f32 / segments as f32 * std::f32::consts::TAU;
                let p = Vec3::new(polar.sin() * a.cos(), polar.sin() * a.sin(), polar.cos());
                mesh.positions.push(p);
                mesh.normals.push(p);
            }
        }
        let row = segments + 1;
        for i in 0..rings {
            for k in 0..segments {
                let (a, b) = (i * row + k, i * row + k + 1);
                let (c, d) = (a + row, b + row);
                mesh.indices.extend_from_slice(&[a, c, b, b, c, d]);
            }
        }
        mesh
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_unit_sphere_is_valid_and_wound_outward() {
        let m = Mesh::unit_sphere(8, 12);
        m.validate().unwrap();
        for t in m.indices.chunks(3) {
            let [a, b, c] = [0, 1, 2].map(|j| m.positions[t[j] as usize]);
            let n = (b - a).cross(c - a);
            if n.length() > 1e-6 {
                assert!(n.dot(a + b + c) > 0.0, "triangle {t:?} faces inward");
            }
        }
    }

    #[test]
    fn metal_is_a_tinted_glossy_lobe_and_matte_has_none() {
        let colour = Vec3::new(0.8, 0.5, 0.2);
        let metal = LiveMaterial {
            surface: LiveSurface::Metal { ka: 1.0, ks: 1.0, roughness: 0.1 },
            colour,
            opacity: Vec3::ONE,
        };
        let m = metal.to_viewer_material();
        assert_eq!((m.kd, m.ks, m.specular_colour), (0.0, 1.0, colour));
        let matte = LiveMaterial { surface: LiveSurface::Matte { ka: 1.0, kd: 0.7 }, ..metal };
        assert_eq!(matte.to_viewer_material().ks, 0.0);
    }
}

//! Live (real-time) objects, their materials and the lights that shade them.
//!
//! Everything here is in world space, in `f64` where it is a position, exactly as the RIB and
//! the haptics give it; the compositor moves it to camera space on the CPU each frame, so live
//! objects keep their precision however far the scene sits from the world origin.

use glam::{DMat4, DVec3, Vec3};
use std::sync::Arc;

/// A light of the RIB, as the live objects see it. Colours are `intensity * lightcolor`.
/// Point-like lights fall off as `1 / d^2` (the standard light shaders).
#[derive(Clone, Debug, PartialEq)]
pub enum LiveLight {
    /// `ambientlight`: adds `Ka * Cs * colour` to every live surface.
    Ambient { colour: Vec3 },
    /// `distantlight`: light travelling along the unit vector `direction` with irradiance
    /// `colour` on a surface facing it.
    Distant { direction: DVec3, colour: Vec3 },
    /// `pointlight`: radiant intensity `colour` at `position`.
    Point { position: DVec3, colour: Vec3 },
    /// `spotlight`: apex `position`, unit `axis`; the standard shader's fall-off
    /// `cos^beam_distribution * smoothstep(cos(cone), cos(cone - delta), cos)` over `d^2`.
    Spot {
        position: DVec3,
        axis: DVec3,
        colour: Vec3,
        cone_angle: f32,
        cone_delta_angle: f32,
        beam_distribution: f32,
    },
    /// An area emitter seen from afar: a representative point at its `centroid` emitting the
    /// emitter's whole power, with a Lambertian lobe about `normal` (radiant intensity
    /// `radiance * area * cos`; both sides when `two_sided`; isotropic `radiance * area / 4`
    /// when `normal` is `None`, as for a sphere). `radius` is the emitter's size (the radius of a
    /// disc of the same area), used for soft shadows.
    Area { centroid: DVec3, normal: Option<DVec3>, two_sided: bool, radiance: Vec3, area: f64, radius: f64 },
}

impl LiveLight {
    /// Power-like weight of the light at `point` (irradiance on a surface facing the light),
    /// used to pick the light that casts the live objects' shadows.
    pub fn irradiance_at(&self, point: DVec3) -> f64 {
        let lum = |c: Vec3| f64::from(c.x + c.y + c.z) / 3.0;
        match self {
            LiveLight::Ambient { .. } => 0.0,
            LiveLight::Distant { colour, .. } => lum(*colour),
            LiveLight::Point { position, colour } => {
                lum(*colour) / (point - *position).length_squared().max(1e-30)
            }
            LiveLight::Spot { position, axis, colour, cone_angle, .. } => {
                let d = point - *position;
                let inside = d.normalize_or_zero().dot(*axis) >= f64::from(*cone_angle).cos();
                if inside { lum(*colour) / d.length_squared().max(1e-30) } else { 0.0 }
            }
            LiveLight::Area { centroid, normal, two_sided, radiance, area, .. } => {
                let d = point - *centroid;
                let dist2 = d.length_squared().max(1e-30);
                let cos = match normal {
                    Some(n) if *two_sided => n.dot(d.normalize_or_zero()).abs(),
                    Some(n) => n.dot(d.normalize_or_zero()).max(0.0),
                    None => 0.25,
                };
                lum(*radiance) * area * cos / dist2
            }
        }
    }

    /// Where the light is, for shadows: a position, or a direction the light travels along.
    pub(crate) fn shadow_source(&self) -> Option<ShadowSource> {
        match self {
            LiveLight::Ambient { .. } => None,
            LiveLight::Distant { direction, .. } => Some(ShadowSource::Direction(*direction)),
            LiveLight::Point { position, .. } | LiveLight::Spot { position, .. } => {
                Some(ShadowSource::Point { position: *position, radius: 0.0 })
            }
            LiveLight::Area { centroid, radius, .. } => {
                Some(ShadowSource::Point { position: *centroid, radius: *radius })
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum ShadowSource {
    Point { position: DVec3, radius: f64 },
    Direction(DVec3),
}

/// A small plastic-like material (RenderMan's `plastic` parameters), evaluated physically:
/// `Cs * (Ka * ambient + Kd / pi * E) + specular_colour * Ks * (n + 8) / (8 pi) * (N.H)^n * E`
/// with `n = 1 / roughness` (energy-normalised Blinn-Phong) and `E` each light's irradiance, so
/// a live surface with the scene's albedo is exactly as bright as the pre-rendered ones under
/// direct light. `unlit` shows `colour` as is (for masks and ground-truth tests).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub colour: Vec3,
    pub ka: f32,
    pub kd: f32,
    pub ks: f32,
    pub roughness: f32,
    pub specular_colour: Vec3,
    pub unlit: bool,
}

impl Default for Material {
    /// A blue plastic cursor, like the paper's.
    fn default() -> Self {
        Material {
            colour: Vec3::new(0.1, 0.25, 0.9),
            ka: 1.0,
            kd: 0.8,
            ks: 0.5,
            roughness: 0.05,
            specular_colour: Vec3::ONE,
            unlit: false,
        }
    }
}

impl Material {
    /// A constant, unlit colour.
    pub fn unlit(colour: Vec3) -> Material {
        Material { colour, unlit: true, ..Material::default() }
    }
}

/// The cursor sphere, drawn as an exact ray-cast impostor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre in world (scene) space.
    pub centre: DVec3,
    /// Radius in scene units.
    pub radius: f64,
    pub material: Material,
}

/// A triangle mesh in its object space, with per-vertex normals.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub indices: Vec<u32>,
}

impl Mesh {
    /// A closed cylinder of `radius` along object `+z` from `z = 0` to `z = length`, with
    /// `segments` sides (at least 3): a tool shaft.
    pub fn cylinder(radius: f32, length: f32, segments: u32) -> Mesh {
        let segments = segments.max(3);
        let mut mesh = Mesh { positions: Vec::new(), normals: Vec::new(), indices: Vec::new() };
        let ring = |k: u32| {
            let a = k as f32 / segments as f32 * std::f32::consts::TAU;
            Vec3::new(a.cos(), a.sin(), 0.0)
        };
        // Side: two vertices per segment edge, smooth normals.
        for k in 0..=segments {
            let n = ring(k);
            mesh.positions.push(n * radius);
            mesh.normals.push(n);
            mesh.positions.push(n * radius + Vec3::Z * length);
            mesh.normals.push(n);
        }
        for k in 0..segments {
            let (a, b, c, d) = (2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 3);
            mesh.indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
        // Caps: a centre vertex and a flat-shaded ring each.
        for (z, normal) in [(0.0, -Vec3::Z), (length, Vec3::Z)] {
            let centre = mesh.positions.len() as u32;
            mesh.positions.push(Vec3::Z * z);
            mesh.normals.push(normal);
            for k in 0..segments {
                mesh.positions.push(ring(k) * radius + Vec3::Z * z);
                mesh.normals.push(normal);
            }
            for k in 0..segments {
                let (a, b) = (centre + 1 + k, centre + 1 + (k + 1) % segments);
                if normal.z > 0.0 {
                    mesh.indices.extend_from_slice(&[centre, a, b]);
                } else {
                    mesh.indices.extend_from_slice(&[centre, b, a]);
                }
            }
        }
        mesh
    }

    /// An axis-aligned box `[-half, half]` in object space, flat-shaded (four vertices per
    /// face), wound counter-clockwise around its outward normals.
    pub fn cuboid(half: Vec3) -> Mesh {
        let mut mesh = Mesh { positions: Vec::new(), normals: Vec::new(), indices: Vec::new() };
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut normal = Vec3::ZERO;
                normal[axis] = sign;
                // Two tangents with u x v = normal.
                let (u, v) = {
                    let mut u = Vec3::ZERO;
                    u[(axis + 1) % 3] = 1.0;
                    let v = normal.cross(u);
                    (u, v)
                };
                let base = mesh.positions.len() as u32;
                for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    mesh.positions.push((normal + u * a + v * b) * half);
                    mesh.normals.push(normal);
                }
                mesh.indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
            }
        }
        mesh
    }

    /// Checks the mesh is drawable: matching positions and normals, indices in range, whole
    /// triangles, finite values.
    pub fn validate(&self) -> Result<(), String> {
        if self.positions.len() != self.normals.len() {
            return Err(format!("{} positions but {} normals", self.positions.len(), self.normals.len()));
        }
        if !self.indices.len().is_multiple_of(3) {
            return Err(format!("{} indices is not a whole number of triangles", self.indices.len()));
        }
        if let Some(i) = self.indices.iter().find(|&&i| i as usize >= self.positions.len()) {
            return Err(format!("index {i} is out of range ({} vertices)", self.positions.len()));
        }
        if !self.positions.iter().chain(&self.normals).all(|v| v.is_finite()) {
            return Err("a position or normal is not finite".into());
        }
        Ok(())
    }
}

/// A registered mesh placed in the world for this frame.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshInstance {
    pub mesh: Arc<Mesh>,
    pub world_from_object: DMat4,
    pub material: Material,
    /// The exact sphere (world centre, radius) this mesh draws, if it draws one: shadows with
    /// light layers are cast by the sphere itself.
    pub exact_sphere: Option<(DVec3, f64)>,
}

/// The live objects of one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LiveObjects {
    pub sphere: Option<Sphere>,
    pub meshes: Vec<MeshInstance>,
}

/// Frame timing given to a [`LiveUpdate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameInfo {
    /// 0 for the first frame.
    pub index: u64,
    /// Seconds since the first frame: wall-clock time in a window, `index / frame_rate` of
    /// simulated time when headless (so headless runs are deterministic).
    pub time_s: f64,
}

/// Moves live objects once per frame, before the frame is drawn: the haptic thread's shared
/// state (read without blocking), a recorded trajectory, or anything else. It must not block.
pub trait LiveUpdate {
    fn update(&mut self, live: &mut LiveObjects, frame: &FrameInfo);

    /// True when the window's keyboard and mouse should still move the sphere while this
    /// updater runs: the updater then reads where they put it (e.g. as the input of a simulated
    /// haptic device) and may move it elsewhere (to the haptic proxy).
    fn keyboard_moves_sphere(&self) -> bool {
        false
    }

    /// True when the window should close after this frame (e.g. the haptic device was
    /// unplugged; the caller reports why).
    fn wants_exit(&self) -> bool {
        false
    }
}

impl<F: FnMut(&mut LiveObjects, &FrameInfo)> LiveUpdate for F {
    fn update(&mut self, live: &mut LiveObjects, frame: &FrameInfo) {
        self(live, frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylinder_is_valid_and_closed() {
        let m = Mesh::cylinder(0.1, 2.0, 12);
        m.validate().unwrap();
        // Every edge of a closed, consistently wound mesh appears once in each direction
        // (the side's seam duplicates vertices, so compare positions).
        let key = |i: u32| {
            let p = m.positions[i as usize];
            ((p.x * 1e4).round() as i64, (p.y * 1e4).round() as i64, (p.z * 1e4).round() as i64)
        };
        let mut edges = std::collections::HashMap::new();
        for t in m.indices.chunks(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((key(a), key(b))).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(edges.get(&(b, a)), Some(&n), "edge {a:?}-{b:?} is not matched");
        }
    }

    #[test]
    fn cuboid_faces_point_outwards() {
        let m = Mesh::cuboid(Vec3::new(1.0, 2.0, 3.0));
        m.validate().unwrap();
        for t in m.indices.chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot(a) > 0.0, "triangle {t:?} faces inwards");
            assert!(n.normalize().dot(m.normals[t[0] as usize]) > 0.999);
        }
    }

    #[test]
    fn area_light_weight_follows_its_lobe() {
        let l = LiveLight::Area {
            centroid: DVec3::new(0.0, 1.0, 0.0),
            normal: Some(DVec3::NEG_Y),
            two_sided: false,
            radiance: Vec3::splat(10.0),
            area: 0.1,
            radius: 0.18,
        };
        assert!((l.irradiance_at(DVec3::ZERO) - 1.0).abs() < 1e-12);
        assert_eq!(l.irradiance_at(DVec3::new(0.0, 2.0, 0.0)), 0.0);
    }
}

//! The god-object (virtual proxy) with a radius: Zilles & Salisbury (1995), Ruspini, Kolarov &
//! Khatib (1997), and CHAI3D's `cAlgorithmFingerProxy`.
//!
//! Each tick the proxy, a sphere of radius `r`, moves from where it is towards the goal (the
//! device position mapped into the scene). The motion is swept against the triangles: at the
//! first contact the proxy stops, the contact becomes a constraint plane (tangent to the set of
//! centres within `r` of the touched face, edge or vertex), and the goal is projected onto the
//! constraints. Up to three planes are collected, so the proxy slides along a face, along the
//! crease of two faces, and stops in a corner. Because every motion is swept from the **proxy**
//! (never from the last device sample), thin sheets and fast strikes cannot be passed through.
//!
//! Contacts with edges and vertices have normals that turn continuously (the proxy rolls over a
//! convex edge on a cylinder of radius `r`), so the force is smooth across shared edges without
//! any knowledge of mesh connectivity.
//!
//! Friction follows CHAI3D: a friction cone of half angle `atan(mu)` around the contact normal.
//! While the goal stays inside the static cone the proxy sticks; once it leaves, the proxy
//! slides and trails the goal on the edge of the dynamic cone until it falls inside again.

use crate::bvh::{Bvh, MeshContact};
use crate::geometry::{CollisionMesh, Feature, SweepTolerance};
use crate::material::MaterialTable;
use glam::DVec3;
use std::time::Duration;

/// Triangles and their BVH, built once and shared (read-only) with the haptic thread.
#[derive(Clone, Debug)]
pub struct CollisionWorld {
    mesh: CollisionMesh,
    bvh: Bvh,
}

impl CollisionWorld {
    /// Builds the BVH over `mesh`.
    pub fn new(mesh: CollisionMesh) -> CollisionWorld {
        let bvh = Bvh::build(&mesh);
        CollisionWorld { mesh, bvh }
    }

    pub fn mesh(&self) -> &CollisionMesh {
        &self.mesh
    }

    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// How long building the BVH took.
    pub fn build_time(&self) -> Duration {
        self.bvh.build_time()
    }
}

/// A constraint `normal . x >= offset` on the proxy's centre (local frame), from one contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactPlane {
    pub normal: DVec3,
    pub offset: f64,
    /// The touched point of the surface.
    pub surface_point: DVec3,
    /// The touched triangle (index in the mesh).
    pub triangle: u32,
    pub feature: Feature,
    /// Barycentric coordinates of `surface_point` in the triangle.
    pub barycentric: DVec3,
}

impl ContactPlane {
    /// The plane of a contact met with the proxy's centre at `centre`. It runs at the radius
    /// from the touched point, or through the centre when the contact was met within the
    /// sweep's skin (slightly further out): the proxy then slides exactly tangentially instead
    /// of being pulled in by the skin's width and meeting the same contact again.
    fn from_contact(hit: &MeshContact, radius: f64, centre: DVec3) -> ContactPlane {
        let c = &hit.contact;
        let height = (centre - c.surface_point).dot(c.normal).max(radius);
        ContactPlane {
            normal: c.normal,
            offset: c.normal.dot(c.surface_point) + height,
            surface_point: c.surface_point,
            triangle: hit.triangle,
            feature: c.feature,
            barycentric: c.barycentric,
        }
    }

    /// Signed distance of `x` from the plane (positive on the free side).
    pub fn signed_distance(&self, x: DVec3) -> f64 {
        self.normal.dot(x) - self.offset
    }
}

/// Settings of the proxy algorithm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProxySettings {
    /// Radius of the proxy sphere, in scene units.
    pub radius: f64,
    /// Apply static and dynamic friction from the materials.
    pub friction: bool,
}

/// What one proxy update found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProxyUpdate {
    /// The new proxy position (local frame).
    pub position: DVec3,
    /// The constraint planes met this tick, in the order they were met (the first is the
    /// primary contact whose material sets stiffness and friction).
    pub planes: [Option<ContactPlane>; 3],
    /// Sweeps performed (at most [`MAX_SWEEPS`]).
    pub sweeps: u32,
    /// The proxy was held by static friction this tick.
    pub sticking: bool,
}

impl ProxyUpdate {
    pub fn contact_count(&self) -> usize {
        self.planes.iter().filter(|p| p.is_some()).count()
    }

    pub fn primary(&self) -> Option<&ContactPlane> {
        self.planes[0].as_ref()
    }

    pub fn in_contact(&self) -> bool {
        self.planes[0].is_some()
    }
}

/// Sweeps per tick: one free motion plus one per constraint (CHAI3D uses the same bound).
pub const MAX_SWEEPS: u32 = 4;

/// The proxy's state between ticks.
#[derive(Clone, Debug)]
pub struct GodObject {
    settings: ProxySettings,
    tolerance: SweepTolerance,
    position: DVec3,
    slipping: bool,
    initialised: bool,
}

impl GodObject {
    pub fn new(settings: ProxySettings) -> GodObject {
        GodObject {
            tolerance: SweepTolerance::for_radius(settings.radius),
            settings,
            position: DVec3::ZERO,
            slipping: false,
            initialised: false,
        }
    }

    pub fn settings(&self) -> &ProxySettings {
        &self.settings
    }

    /// The proxy's centre (local frame).
    pub fn position(&self) -> DVec3 {
        self.position
    }

    pub fn is_initialised(&self) -> bool {
        self.initialised
    }

    /// Places the proxy at `goal`, pushed out of any triangle it overlaps (along the normal of
    /// the closest contact, a few times for creases). Returns whether it ended free of overlap;
    /// a goal deep inside a crevice narrower than the proxy may not be resolvable.
    pub fn reset(&mut self, world: &CollisionWorld, goal: DVec3) -> bool {
        self.slipping = false;
        self.initialised = true;
        let r = self.settings.radius;
        let mut p = goal;
        for _ in 0..16 {
            let Some(closest) = world.bvh().closest_point(p, r) else {
                self.position = p;
                return true;
            };
            let offset = p - closest.point;
            let normal = if closest.distance > r * 1e-9 {
                offset / closest.distance
            } else {
                // Exactly on the surface: leave along the face normal.
                let [a, b, c] = world.mesh().triangle_local(closest.triangle as usize);
                (b - a).cross(c - a).normalize_or(DVec3::Z)
            };
            p = closest.point + normal * r;
        }
        self.position = p;
        world.bvh().closest_point(p, r).is_none()
    }

    /// Moves the proxy towards `goal` (local frame) as far as the triangles allow.
    pub fn update(&mut self, world: &CollisionWorld, materials: &MaterialTable, goal: DVec3) -> ProxyUpdate {
        if !self.initialised {
            self.reset(world, goal);
        }
        let r = self.settings.radius;
        let mut pos = self.position;
        let mut planes: [Option<ContactPlane>; 3] = [None; 3];
        let mut count = 0usize;
        let mut effective_goal = goal;
        let mut target = goal;
        let mut sweeps = 0;
        let mut sticking = false;
        while sweeps < MAX_SWEEPS {
            let d = target - pos;
            if d == DVec3::ZERO {
                break;
            }
            sweeps += 1;
            let Some(hit) = world.bvh().sweep_sphere(pos, d, r, self.tolerance) else {
                pos = target;
                break;
            };
            pos += d * hit.contact.t;
            if count == 3 {
                // A fourth constraint: the proxy is in a corner; stop where it touched.
                break;
            }
            let plane = ContactPlane::from_contact(&hit, r, pos);
            let repeated = planes[..count].iter().flatten().any(|p| {
                p.normal.dot(plane.normal) > 1.0 - 1e-12
                    && (p.offset - plane.offset).abs() <= self.tolerance.skin
            });
            if repeated {
                // The same constraint again (rounding): nothing more to gain this tick.
                break;
            }
            planes[count] = Some(plane);
            count += 1;
            if count == 1 && self.settings.friction {
                let material = materials.get(world.mesh().material(plane.triangle as usize));
                let (goal_after_friction, stuck) =
                    self.friction(&plane, goal, pos, material.static_friction, material.dynamic_friction);
                effective_goal = goal_after_friction;
                sticking = stuck;
            }
            let active: Vec3Planes = collect_planes(&planes[..count]);
            target = project_onto_planes(effective_goal, &active, r * 1e-9).unwrap_or(pos);
        }
        if count == 0 {
            self.slipping = false;
        }
        self.position = pos;
        ProxyUpdate { position: pos, planes, sweeps, sticking }
    }

    /// CHAI3D's friction cone on the first contact plane: returns the goal with its tangential
    /// part pulled back towards the proxy, and whether the proxy sticks.
    fn friction(
        &mut self,
        plane: &ContactPlane,
        goal: DVec3,
        pos: DVec3,
        static_friction: f64,
        dynamic_friction: f64,
    ) -> (DVec3, bool) {
        if static_friction <= 0.0 && dynamic_friction <= 0.0 {
            self.slipping = false;
            return (goal, false);
        }
        let depth = -plane.signed_distance(goal);
        if !(depth > 0.0) {
            return (goal, false);
        }
        let n = plane.normal;
        let pos_on_plane = pos - n * plane.signed_distance(pos);
        let goal_on_plane = goal + n * depth;
        let slide = goal_on_plane - pos_on_plane;
        let slide_len = slide.length();
        let mu = if self.slipping { dynamic_friction } else { static_friction };
        if slide_len <= mu * depth {
            self.slipping = false;
            return (pos_on_plane - n * depth, true);
        }
        self.slipping = true;
        let lag = (dynamic_friction * depth).min(slide_len);
        (goal - slide * (lag / slide_len), false)
    }
}

type Vec3Planes = ([DVec3; 3], [f64; 3], usize);

fn collect_planes(planes: &[Option<ContactPlane>]) -> Vec3Planes {
    let mut normals = [DVec3::ZERO; 3];
    let mut offsets = [0.0; 3];
    let mut n = 0;
    for p in planes.iter().flatten() {
        normals[n] = p.normal;
        offsets[n] = p.offset;
        n += 1;
    }
    (normals, offsets, n)
}

/// The point closest to `goal` that satisfies `normal_i . x >= offset_i` for every plane: the
/// exact solution of the small quadratic program, found by trying every subset of planes as
/// the active set (at most 7 for three planes) and keeping the closest feasible projection.
/// `None` when no subset gives a feasible point (degenerate, e.g. opposing parallel planes).
pub fn project_onto_planes(goal: DVec3, planes: &Vec3Planes, tolerance: f64) -> Option<DVec3> {
    let (normals, offsets, n) = *planes;
    let feasible = |x: DVec3| (0..n).all(|i| normals[i].dot(x) >= offsets[i] - tolerance);
    let mut best: Option<(f64, DVec3)> = None;
    let mut consider = |x: DVec3| {
        if x.is_finite() && feasible(x) {
            let d = (x - goal).length_squared();
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, x));
            }
        }
    };
    consider(goal);
    for i in 0..n {
        let gap = offsets[i] - normals[i].dot(goal);
        consider(goal + normals[i] * gap);
    }
    for i in 0..n {
        for j in i + 1..n {
            if let Some(x) = project_onto_line(goal, normals[i], offsets[i], normals[j], offsets[j]) {
                consider(x);
            }
        }
    }
    if n == 3
        && let Some(x) = intersect_three(normals, offsets)
    {
        consider(x);
    }
    best.map(|(_, x)| x)
}

/// Projection of `goal` onto the line where two planes meet; `None` when they are parallel.
fn project_onto_line(goal: DVec3, n1: DVec3, o1: f64, n2: DVec3, o2: f64) -> Option<DVec3> {
    let c = n1.dot(n2);
    let det = 1.0 - c * c;
    if det < 1e-10 {
        return None;
    }
    let r1 = o1 - n1.dot(goal);
    let r2 = o2 - n2.dot(goal);
    let l1 = (r1 - c * r2) / det;
    let l2 = (r2 - c * r1) / det;
    Some(goal + n1 * l1 + n2 * l2)
}

/// The point where three planes meet; `None` when they do not meet in one point.
fn intersect_three(n: [DVec3; 3], o: [f64; 3]) -> Option<DVec3> {
    let c12 = n[1].cross(n[2]);
    let det = n[0].dot(c12);
    if det.abs() < 1e-8 {
        return None;
    }
    Some((c12 * o[0] + n[2].cross(n[0]) * o[1] + n[0].cross(n[1]) * o[2]) / det)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::MaterialId;
    use crate::material::Material;

    fn floor_world() -> CollisionWorld {
        let mut mesh = CollisionMesh::new(DVec3::ZERO);
        let p = [
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-1.0, 1.0, 0.0),
        ];
        mesh.push_indexed(&p, &[[0, 1, 2], [0, 2, 3]], None, MaterialId(0)).unwrap();
        CollisionWorld::new(mesh)
    }

    fn frictionless() -> MaterialTable {
        MaterialTable::uniform(Material { stiffness: 1000.0, static_friction: 0.0, dynamic_friction: 0.0 })
    }

    #[test]
    fn free_proxy_follows_the_goal() {
        let world = floor_world();
        let mut proxy = GodObject::new(ProxySettings { radius: 0.01, friction: false });
        let goal = DVec3::new(0.1, 0.2, 0.5);
        let up = proxy.update(&world, &frictionless(), goal);
        assert_eq!(up.position, goal);
        assert!(!up.in_contact());
    }

    #[test]
    fn proxy_slides_on_the_floor() {
        let world = floor_world();
        let mut proxy = GodObject::new(ProxySettings { radius: 0.01, friction: false });
        proxy.update(&world, &frictionless(), DVec3::new(0.0, 0.0, 0.1));
        let up = proxy.update(&world, &frictionless(), DVec3::new(0.05, 0.02, -0.03));
        assert!(up.in_contact());
        assert!((up.position - DVec3::new(0.05, 0.02, 0.01)).length() < 1e-12, "{}", up.position);
    }

    #[test]
    fn projection_handles_inactive_constraints() {
        // Floor z >= 0 and a wall x >= 0; a goal behind the wall but above the floor only needs
        // the wall.
        let planes = ([DVec3::Z, DVec3::X, DVec3::ZERO], [0.0, 0.0, 0.0], 2);
        let x = project_onto_planes(DVec3::new(-1.0, 0.0, 2.0), &planes, 1e-12).unwrap();
        assert!((x - DVec3::new(0.0, 0.0, 2.0)).length() < 1e-15);
        let x = project_onto_planes(DVec3::new(-1.0, 3.0, -2.0), &planes, 1e-12).unwrap();
        assert!((x - DVec3::new(0.0, 3.0, 0.0)).length() < 1e-15);
        // Obtuse crease: floor and a wall leaning away; the goal below the floor but in front
        // of the leaning wall's plane projects onto the floor only.
        let lean = DVec3::new(1.0, 0.0, 1.0).normalize();
        let planes = ([DVec3::Z, lean, DVec3::ZERO], [0.0, 0.0, 0.0], 2);
        let x = project_onto_planes(DVec3::new(2.0, 0.0, -1.0), &planes, 1e-12).unwrap();
        assert!((x - DVec3::new(2.0, 0.0, 0.0)).length() < 1e-15);
    }

    #[test]
    fn three_planes_meet_in_the_corner() {
        let planes = ([DVec3::X, DVec3::Y, DVec3::Z], [1.0, 2.0, 3.0], 3);
        let x = project_onto_planes(DVec3::new(-5.0, -5.0, -5.0), &planes, 1e-12).unwrap();
        assert!((x - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
    }
}

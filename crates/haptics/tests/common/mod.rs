//! Shared helpers for the scripted-trajectory tests.
#![allow(dead_code)]

use glam::DVec3;
use haptics::*;
use std::sync::Arc;

pub const RADIUS: f64 = 0.005;
pub const STIFFNESS: f64 = 1000.0;

/// Two triangles of the quad `a b c d` (counter-clockwise seen from the front).
pub fn quad(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> [[DVec3; 3]; 2] {
    [[a, b, c], [a, c, d]]
}

/// A square of half-size `h` at height `z`, facing +z.
pub fn floor(h: f64, z: f64) -> Vec<[DVec3; 3]> {
    quad(DVec3::new(-h, -h, z), DVec3::new(h, -h, z), DVec3::new(h, h, z), DVec3::new(-h, h, z)).to_vec()
}

/// The six faces of the box `[lo, hi]`, facing outwards.
pub fn cuboid(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
    let c = |x: usize, y: usize, z: usize| {
        DVec3::new(
            if x == 0 { lo.x } else { hi.x },
            if y == 0 { lo.y } else { hi.y },
            if z == 0 { lo.z } else { hi.z },
        )
    };
    let faces = [
        quad(c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)), // -z
        quad(c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)), // +z
        quad(c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)), // -y
        quad(c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)), // +y
        quad(c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)), // -x
        quad(c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)), // +x
    ];
    faces.iter().flatten().copied().collect()
}

pub fn world(triangles: &[[DVec3; 3]], origin: DVec3) -> Arc<CollisionWorld> {
    let mut mesh = CollisionMesh::new(origin);
    for t in triangles {
        mesh.push_world_triangle(*t, MaterialId(0)).unwrap();
    }
    Arc::new(CollisionWorld::new(mesh))
}

pub fn frictionless(stiffness: f64) -> MaterialTable {
    MaterialTable::uniform(Material { stiffness, static_friction: 0.0, dynamic_friction: 0.0 })
}

pub struct Run {
    pub ticks: Vec<TickOutput>,
    pub max_force: f64,
}

/// Settings without a ramp, so forces can be compared with closed forms from the first tick.
pub fn settings(radius: f64) -> RenderSettings {
    let mut s = RenderSettings::new(radius);
    s.ramp_time = 0.0;
    s
}

/// Replays `samples` (device frame) at 1 kHz against `world` and returns every tick.
pub fn run(
    world: &Arc<CollisionWorld>,
    materials: MaterialTable,
    mapping: WorkspaceMapping,
    settings: RenderSettings,
    samples: &[(f64, DVec3)],
) -> Run {
    let trajectory = Trajectory::from_samples(samples).unwrap();
    let end = trajectory.end_time();
    let mut device = SimulatedDevice::replay(trajectory);
    let mut renderer = HapticRenderer::new(Arc::clone(world), materials, device.specs(), mapping, settings);
    let mut ticks = Vec::new();
    let config = ReplayConfig { rate_hz: 1000.0, start: 0.0, end };
    replay(&mut device, &mut renderer, &config, |t| {
        ticks.push(*t);
        Ok(())
    })
    .unwrap();
    Run { ticks, max_force: renderer.max_force() }
}

/// Distance from a world point to the closest triangle.
pub fn distance_to_mesh(world: &CollisionWorld, p_world: DVec3) -> f64 {
    let local = world.mesh().local_from_world(p_world);
    world.bvh().closest_point(local, f64::INFINITY).map_or(f64::INFINITY, |c| c.distance)
}

/// The invariants every tick must keep: no penetration, a bounded finite force, and a free
/// proxy sitting on the device.
pub fn check_invariants(world: &CollisionWorld, run: &Run, radius: f64) {
    // The sweep lets no motion end closer than `radius - skin` (skin = 1e-8 radius).
    let eps = radius * 1.5e-8;
    for t in &run.ticks {
        let d = distance_to_mesh(world, t.proxy_scene);
        assert!(
            d >= radius - eps,
            "t = {}: proxy {} is {d} from the surface (radius {radius})",
            t.time,
            t.proxy_scene
        );
        let f = t.force.get();
        assert!(f.is_finite() && f.length() <= run.max_force, "t = {}: force {f}", t.time);
        let goal_clear = distance_to_mesh(world, t.goal_scene) > radius * (1.0 + 1e-6);
        if goal_clear && t.contacts == 0 {
            assert_eq!(t.proxy_scene, t.goal_scene, "t = {}: a free proxy must sit on the device", t.time);
            assert_eq!(f, DVec3::ZERO);
        }
    }
}

/// Linear segments through `points` at `speed` (m/s), sampled every `step` seconds.
pub fn path(points: &[DVec3], speed: f64) -> Vec<(f64, DVec3)> {
    let mut out = vec![(0.0, points[0])];
    let mut t = 0.0;
    for w in points.windows(2) {
        let length = (w[1] - w[0]).length();
        let duration = (length / speed).max(1e-3);
        t += duration;
        out.push((t, w[1]));
    }
    // Hold the last point for 50 ms so the proxy settles.
    out.push((t + 0.05, *points.last().unwrap()));
    out
}

/// Deterministic uniform numbers in [0, 1).
pub struct Lcg(pub u64);

impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

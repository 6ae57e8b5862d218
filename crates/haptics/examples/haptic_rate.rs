//! Runs the real-time haptic thread for a few seconds and reports its rate, period jitter and
//! per-tick work (p50/p99/max): a simulated device strokes a 1e5-triangle bumpy surface.
//!
//! `cargo run --release -p haptics --example haptic_rate -- [SECONDS] [TRIANGLES] [RATE_HZ]`

use glam::DVec3;
use haptics::*;
use std::sync::Arc;
use std::time::Duration;

fn height(x: f64, y: f64) -> f64 {
    0.02 * (std::f64::consts::TAU * 3.0 * x).sin() * (std::f64::consts::TAU * 2.0 * y).cos()
}

fn main() -> Result<(), HapticError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds: f64 = args.first().and_then(|s| s.parse().ok()).unwrap_or(5.0);
    let triangles: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let rate_hz: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1000.0);

    let n = ((triangles as f64 / 2.0).sqrt().round() as usize).max(1);
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (-0.5 + i as f64 / n as f64, -0.5 + j as f64 / n as f64);
            positions.push(DVec3::new(x, y, height(x, y)));
        }
    }
    let row = n as u32 + 1;
    let mut tris = Vec::new();
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let a = j * row + i;
            tris.push([a, a + 1, a + row + 1]);
            tris.push([a, a + row + 1, a + row]);
        }
    }
    let mut mesh = CollisionMesh::new(DVec3::ZERO);
    mesh.push_indexed(&positions, &tris, None, MaterialId(0))?;
    let world = Arc::new(CollisionWorld::new(mesh));
    println!(
        "{} triangles, BVH built in {:.1} ms",
        world.mesh().triangle_count(),
        world.build_time().as_secs_f64() * 1e3
    );

    // Stroke a circle of radius 0.2 m at 0.2 m/s, pressing 2 mm into the surface.
    let radius = 0.005;
    let samples: Vec<(f64, DVec3)> = (0..=((seconds + 1.0) * 100.0) as usize)
        .map(|k| {
            let t = k as f64 / 100.0;
            let a = t * 0.2 / 0.2;
            let (x, y) = (0.2 * a.cos(), 0.2 * a.sin());
            (t, DVec3::new(x, y, height(x, y) + radius - 0.002))
        })
        .collect();
    let device = SimulatedDevice::replay(Trajectory::from_samples(&samples)?);
    let materials =
        MaterialTable::uniform(Material { stiffness: 1000.0, static_friction: 0.3, dynamic_friction: 0.2 });
    let renderer = HapticRenderer::new(
        world,
        materials,
        device.specs(),
        WorkspaceMapping::new(DVec3::ZERO, 1.0)?,
        RenderSettings::new(radius),
    );
    let config = ThreadConfig { rate_hz, ..ThreadConfig::default() };
    let mut thread = HapticThread::spawn(Box::new(device), renderer, config)?;
    std::thread::sleep(Duration::from_secs_f64(seconds));
    let state = thread.state();
    let report = thread.stop()?;
    println!("{report}");
    println!("last state: proxy {} force {} N, {} contacts", state.proxy_scene, state.force, state.contacts);
    Ok(())
}

//! Scripted-trajectory tests of the proxy on the simulated device: planes, edges, vertices,
//! corners, thin sheets and fast strikes, friction, ramps, passivity.

mod common;

use common::*;
use glam::DVec3;
use haptics::device::{Dynamics, SimulatedDevice};
use haptics::*;
use std::sync::Arc;

fn identity() -> WorkspaceMapping {
    WorkspaceMapping::new(DVec3::ZERO, 1.0).unwrap()
}

#[test]
fn pressing_into_a_plane_at_several_speeds() {
    let world = world(&floor(0.1, 0.0), DVec3::ZERO);
    for speed in [0.01, 0.1, 0.5, 2.0, 8.0] {
        let depth = 0.004;
        let samples = path(&[DVec3::new(0.01, 0.02, 0.03), DVec3::new(0.01, 0.02, RADIUS - depth)], speed);
        let run = run(&world, frictionless(STIFFNESS), identity(), settings(RADIUS), &samples);
        check_invariants(&world, &run, RADIUS);
        let last = run.ticks.last().unwrap();
        // Spring from device to proxy: k * depth straight up, the proxy resting on the plane.
        let expected = DVec3::new(0.0, 0.0, STIFFNESS * depth);
        assert!((last.force.get() - expected).length() < 1e-9, "speed {speed}: {}", last.force.get());
        assert!((last.proxy_scene - DVec3::new(0.01, 0.02, RADIUS)).length() < 1e-12);
        // While the device moved down, the proxy never went below the surface and the force
        // only grew.
        let mut previous = 0.0;
        for t in &run.ticks {
            let f = t.force.get().z;
            assert!(f >= previous - 1e-9, "speed {speed}: force fell from {previous} to {f}");
            previous = f;
        }
    }
}

#[test]
fn a_tessellated_plane_gives_the_analytic_force() {
    // A 40 x 40 grid with alternating diagonals, so contacts land on faces, edges and vertices.
    let n = 40;
    let h = 0.1;
    let mut tris = Vec::new();
    let at = |i: usize, j: usize| {
        DVec3::new(-h + 2.0 * h * i as f64 / n as f64, -h + 2.0 * h * j as f64 / n as f64, 0.0)
    };
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            if (i + j) % 2 == 0 {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            } else {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            }
        }
    }
    let tessellated = world(&tris, DVec3::ZERO);
    let mut rng = Lcg(3);
    let mut worst: f64 = 0.0;
    let step = 2.0 * h / n as f64;
    for k in 0..60 {
        // Every fourth point sits exactly above a grid vertex, every fourth above an edge.
        let (mut x, mut y) = (-0.08 + 0.16 * rng.next(), -0.08 + 0.16 * rng.next());
        if k % 4 == 0 {
            x = (x / step).round() * step;
            y = (y / step).round() * step;
        } else if k % 4 == 1 {
            x = (x / step).round() * step;
        }
        let depth = 0.006 * rng.next();
        // Press, then slide across the grid (over faces, edges and vertices) at that depth.
        let angle = std::f64::consts::TAU * rng.next();
        let slide = DVec3::new(angle.cos(), angle.sin(), 0.0) * 0.03;
        let pressed = DVec3::new(x, y, RADIUS - depth);
        let end = (pressed + slide).clamp(DVec3::new(-0.09, -0.09, -1.0), DVec3::new(0.09, 0.09, 1.0));
        let samples = path(&[DVec3::new(x, y, 0.02), pressed, end], 0.2);
        let run = run(&tessellated, frictionless(STIFFNESS), identity(), settings(RADIUS), &samples);
        check_invariants(&tessellated, &run, RADIUS);
        for t in &run.ticks {
            // The analytic plane z = 0 with a proxy of radius r: F = k * max(0, r - z) up.
            let analytic = DVec3::new(0.0, 0.0, STIFFNESS * (RADIUS - t.device.z).max(0.0));
            worst = worst.max((t.force.get() - analytic).length());
            // Measured: agreement to about 1e-14 N; 1e-9 N leaves room for other platforms.
            assert!(
                (t.force.get() - analytic).length() < 1e-9,
                "at ({x}, {y}) depth {depth}: {} vs {analytic}",
                t.force.get()
            );
        }
    }
    eprintln!("tessellated plane: largest difference from the analytic force {worst:e} N");
}

#[test]
fn sliding_over_a_convex_edge_is_smooth_and_never_penetrates() {
    // A box whose top is z = 0 and whose +x side is x = 0.0625.
    let world =
        world(&cuboid(DVec3::new(-0.0625, -0.0625, -0.125), DVec3::new(0.0625, 0.0625, 0.0)), DVec3::ZERO);
    let depth = 0.002;
    let points = [
        DVec3::new(-0.03, 0.0, 0.03),
        DVec3::new(-0.03, 0.0, RADIUS - depth),
        // Along the top, over the edge...
        DVec3::new(0.0625 + RADIUS - depth, 0.0, RADIUS - depth),
        // ...and down the side, pressing into it.
        DVec3::new(0.0625 + RADIUS - depth, 0.0, -0.05),
    ];
    for speed in [0.02, 0.2] {
        let run = run(&world, frictionless(STIFFNESS), identity(), settings(RADIUS), &path(&points, speed));
        check_invariants(&world, &run, RADIUS);
        let mut max_jump: f64 = 0.0;
        for w in run.ticks.windows(2) {
            let df = (w[1].force.get() - w[0].force.get()).length();
            let dx = (w[1].device - w[0].device).length();
            // The proxy's projection is non-expansive around a convex edge: the force changes
            // no faster than the spring over the device's own motion.
            assert!(
                df <= STIFFNESS * dx * (1.0 + 1e-6) + 1e-9,
                "speed {speed}: jump {df} N over {dx} m at t = {}",
                w[1].time
            );
            max_jump = max_jump.max(df);
        }
        // While rolling over the edge the force turns from +z to +x through the diagonal.
        let diagonal = run.ticks.iter().any(|t| {
            let f = t.force.get();
            f.x > 0.5 && f.z > 0.5
        });
        assert!(diagonal, "speed {speed}: the force never pointed diagonally over the edge");
        let last = run.ticks.last().unwrap();
        assert!(
            (last.force.get() - DVec3::new(STIFFNESS * depth, 0.0, 0.0)).length() < 1e-9,
            "{}",
            last.force.get()
        );
    }
}

#[test]
fn sliding_over_a_convex_vertex_never_penetrates() {
    let world =
        world(&cuboid(DVec3::new(-0.0625, -0.0625, -0.125), DVec3::new(0.0625, 0.0625, 0.0)), DVec3::ZERO);
    // Around the corner (0.0625, 0.0625, 0) at a constant 2 mm inside the proxy's reach: over
    // the top, round the vertex, down the vertical edge and along the side.
    let reach = RADIUS - 0.002;
    let c = 0.0625;
    let diagonal = reach / 2f64.sqrt();
    let points = [
        DVec3::new(0.0, 0.0, 0.02),
        DVec3::new(0.0, 0.0, reach),
        DVec3::new(c, c, reach),
        DVec3::new(c + diagonal, c + diagonal, 0.0),
        DVec3::new(c + diagonal, c + diagonal, -0.03),
        DVec3::new(c + reach, 0.0, -0.03),
    ];
    let run = run(&world, frictionless(STIFFNESS), identity(), settings(RADIUS), &path(&points, 0.1));
    check_invariants(&world, &run, RADIUS);
    let mut worst: f64 = 0.0;
    for w in run.ticks.windows(2) {
        let df = (w[1].force.get() - w[0].force.get()).length();
        let dx = (w[1].device - w[0].device).length();
        // No pops: the force changes by at most twice the spring over the device's motion (the
        // proxy never moves further than the device between ticks).
        assert!(
            df <= 2.0 * STIFFNESS * dx * (1.0 + 1e-6) + 1e-9,
            "jump {df} N over {dx} m at t = {}: {:?}\n{:?}",
            w[1].time,
            w[0],
            w[1]
        );
        if dx > 0.0 {
            worst = worst.max(df / (STIFFNESS * dx));
        }
    }
    eprintln!("vertex: worst force change {worst:.3} k |dx|");
    // The same corner with the device driven deep inside (force saturated): no penetration.
    let deep = [
        DVec3::new(0.0, 0.0, 0.02),
        DVec3::new(0.0, 0.0, reach),
        DVec3::new(0.06, 0.06, reach),
        DVec3::new(0.06, 0.06, -0.03),
        DVec3::new(0.0, 0.1, -0.03),
    ];
    let run = common::run(&world, frictionless(STIFFNESS), identity(), settings(RADIUS), &path(&deep, 0.1));
    check_invariants(&world, &run, RADIUS);
}

#[test]
fn concave_crease_and_two_plane_corner() {
    // Floor z = 0 and a wall x = 0.0625 facing -x.
    let mut tris = floor(0.1, 0.0);
    tris.extend(quad(
        DVec3::new(0.0625, -0.1, 0.0),
        DVec3::new(0.0625, 0.1, 0.0),
        DVec3::new(0.0625, 0.1, 0.1),
        DVec3::new(0.0625, -0.1, 0.1),
    ));
    let world = world(&tris, DVec3::ZERO);
    let goal = DVec3::new(0.0625 - RADIUS + 0.003, 0.01, RADIUS - 0.002);
    for speed in [0.05, 1.0] {
        let points = [DVec3::new(0.0, 0.0, 0.03), DVec3::new(0.0, 0.0, RADIUS - 0.002), goal];
        let run = run(&world, frictionless(STIFFNESS), identity(), settings(RADIUS), &path(&points, speed));
        check_invariants(&world, &run, RADIUS);
        let last = run.ticks.last().unwrap();
        // In the crease: the proxy touches both planes, and slides freely along y.
        assert!(
            (last.proxy_scene - DVec3::new(0.0625 - RADIUS, 0.01, RADIUS)).length() < 1e-9,
            "{}",
            last.proxy_scene
        );
        assert_eq!(last.contacts, 2);
        let expected = DVec3::new(-STIFFNESS * 0.003, 0.0, STIFFNESS * 0.002);
        assert!((last.force.get() - expected).length() < 1e-9, "{}", last.force.get());
    }
}

#[test]
fn three_plane_corner_stops_the_proxy() {
    // Floor z = 0, wall x = 0.0625 (facing -x), wall y = 0.0625 (facing -y).
    let mut tris = floor(0.1, 0.0);
    tris.extend(quad(
        DVec3::new(0.0625, -0.1, 0.0),
        DVec3::new(0.0625, 0.1, 0.0),
        DVec3::new(0.0625, 0.1, 0.1),
        DVec3::new(0.0625, -0.1, 0.1),
    ));
    tris.extend(quad(
        DVec3::new(-0.1, 0.0625, 0.0),
        DVec3::new(0.1, 0.0625, 0.0),
        DVec3::new(0.1, 0.0625, 0.1),
        DVec3::new(-0.1, 0.0625, 0.1),
    ));
    let world = world(&tris, DVec3::ZERO);
    let corner = DVec3::new(0.0625 - RADIUS, 0.0625 - RADIUS, RADIUS);
    let goal = corner + DVec3::new(0.002, 0.003, -0.001);
    let points = [DVec3::new(0.0, 0.0, 0.03), goal];
    for speed in [0.05, 0.5, 3.0] {
        let run = run(&world, frictionless(STIFFNESS), identity(), settings(RADIUS), &path(&points, speed));
        check_invariants(&world, &run, RADIUS);
        let last = run.ticks.last().unwrap();
        assert!((last.proxy_scene - corner).length() < 1e-9, "speed {speed}: {}", last.proxy_scene);
        // Within a nanometre of the exact corner (the walls are f32 geometry).
        assert!(
            (last.force.get() - (corner - goal) * STIFFNESS).length() < 1e-6,
            "speed {speed}: {} {} {}",
            last.force.get(),
            last.contacts,
            last.device
        );
    }
}

#[test]
fn a_strike_through_a_slab_thinner_than_one_tick_is_stopped() {
    // A 0.5 mm slab, and a bare sheet (zero thickness), struck at 10 m/s: 10 mm per tick.
    let slab =
        world(&cuboid(DVec3::new(-0.0625, -0.0625, -0.0005), DVec3::new(0.0625, 0.0625, 0.0)), DVec3::ZERO);
    let sheet = world(&floor(0.05, 0.0), DVec3::ZERO);
    for world in [slab, sheet] {
        let samples = [
            (0.0, DVec3::new(0.001, 0.002, 0.05)),
            (0.01, DVec3::new(0.001, 0.002, -0.05)),
            (0.05, DVec3::new(0.001, 0.002, -0.05)),
        ];
        let run = run(&world, frictionless(STIFFNESS), identity(), settings(RADIUS), &samples);
        check_invariants(&world, &run, RADIUS);
        let last = run.ticks.last().unwrap();
        assert!((last.proxy_scene.z - RADIUS).abs() < 1e-12, "the proxy went through: {}", last.proxy_scene);
        // 55 mm deep: the force is at the device's limit, pointing back up.
        assert!(
            (last.force.get() - DVec3::new(0.0, 0.0, run.max_force)).length() < 1e-6,
            "{}",
            last.force.get()
        );
        // Pulling back out releases the proxy on the same side.
    }
}

#[test]
fn static_and_dynamic_friction_follow_the_cones() {
    let world = world(&floor(0.1, 0.0), DVec3::ZERO);
    let (mu_s, mu_d) = (0.5, 0.3);
    let materials = MaterialTable::uniform(Material {
        stiffness: STIFFNESS,
        static_friction: mu_s,
        dynamic_friction: mu_d,
    });
    let depth = 0.003;
    let z = RADIUS - depth;
    // Press, push sideways 1 mm (inside the static cone: 1 < 0.5 * 3), then drag 20 mm.
    let samples = [
        (0.0, DVec3::new(0.0, 0.0, 0.02)),
        (0.05, DVec3::new(0.0, 0.0, z)),
        (0.1, DVec3::new(0.0, 0.0, z)),
        (0.2, DVec3::new(0.001, 0.0, z)),
        (0.3, DVec3::new(0.001, 0.0, z)),
        (0.5, DVec3::new(0.021, 0.0, z)),
    ];
    let run = run(&world, materials, identity(), settings(RADIUS), &samples);
    check_invariants(&world, &run, RADIUS);
    let at = |time: f64| run.ticks.iter().find(|t| (t.time - time).abs() < 1e-9).unwrap();
    // Sticking: the proxy has not moved, the tangential force resists the push.
    let stuck = at(0.3);
    assert!((stuck.proxy_scene.x).abs() < 1e-12, "{}", stuck.proxy_scene);
    assert!((stuck.force.get() - DVec3::new(-STIFFNESS * 0.001, 0.0, STIFFNESS * depth)).length() < 1e-9);
    // Sliding: the proxy trails the device by mu_d * depth; the force sits on the dynamic cone.
    let sliding = at(0.45);
    let f = sliding.force.get();
    assert!((-f.x / f.z - mu_d).abs() < 1e-9, "tangential/normal = {}", -f.x / f.z);
    assert!((sliding.device.x - sliding.proxy_scene.x - mu_d * depth).abs() < 1e-9);
}

#[test]
fn force_ramps_in_at_start_and_when_contact_begins_deep() {
    let world = world(&floor(0.1, 0.0), DVec3::ZERO);
    // The device starts 5 mm into the proxy's contact; the proxy is pushed out to the surface.
    let mut s = settings(RADIUS);
    s.ramp_time = 0.1;
    let samples = [(0.0, DVec3::new(0.0, 0.0, 0.0)), (0.3, DVec3::new(0.0, 0.0, 0.0))];
    let run = run(&world, frictionless(STIFFNESS), identity(), s, &samples);
    check_invariants(&world, &run, RADIUS);
    assert_eq!(run.ticks[0].force.get(), DVec3::ZERO);
    let full = STIFFNESS * RADIUS;
    let at_50ms = run.ticks[50].force.get().z;
    assert!((at_50ms - 0.5 * full).abs() < 1e-9, "{at_50ms}");
    assert!((run.ticks[200].force.get().z - full).abs() < 1e-9);
    for w in run.ticks.windows(2) {
        assert!(w[1].force.get().z >= w[0].force.get().z - 1e-12);
    }

    // A strike that would start at more than half the force limit ramps in instead of kicking.
    // The device jumps 80 mm in one tick (a glitch, or a gain change): contact begins deep.
    let samples = [
        (0.0, DVec3::new(0.0, 0.0, 0.02)),
        (0.001, DVec3::new(0.0, 0.0, -0.06)),
        (0.5, DVec3::new(0.0, 0.0, -0.06)),
    ];
    let run2 = common::run(&world, frictionless(STIFFNESS), identity(), s, &samples);
    let first_contact = run2.ticks.iter().position(|t| t.contacts > 0).unwrap();
    assert_eq!(run2.ticks[first_contact].force.get(), DVec3::ZERO, "a deep contact began with a kick");
    let f = |i: usize| run2.ticks[first_contact + i].force.get().z;
    assert!(f(10) > 0.0 && f(10) < f(50) && f(50) <= run2.max_force);
}

#[test]
fn gain_and_centre_map_device_to_scene() {
    // A scene in centimetres far from the origin; the device in metres.
    let origin = DVec3::new(1.0e6, -2.0e6, 5.0e5);
    let world = world(&floor(10.0, 0.0).iter().map(|t| t.map(|v| v + origin)).collect::<Vec<_>>(), origin);
    let radius_cm = 0.5;
    let mapping = WorkspaceMapping::new(origin + DVec3::new(0.0, 0.0, 5.0), 100.0).unwrap();
    // Device 5 cm down from its centre puts the goal at the floor, 5 mm into the proxy radius.
    let samples = path(&[DVec3::new(0.001, 0.0, 0.0), DVec3::new(0.001, 0.0, -0.05)], 0.1);
    let run = run(&world, frictionless(STIFFNESS), mapping, settings(radius_cm), &samples);
    check_invariants(&world, &run, radius_cm);
    let last = run.ticks.last().unwrap();
    // 0.5 cm of scene penetration is 5 mm of device travel: 1000 N/m * 0.005 m = 5 N.
    assert!((last.force.get() - DVec3::new(0.0, 0.0, 5.0)).length() < 1e-6, "{}", last.force.get());
    assert!((last.proxy_scene - (origin + DVec3::new(0.1, 0.0, radius_cm))).length() < 1e-6);
    assert!((last.proxy_device - DVec3::new(0.001, 0.0, -0.045)).length() < 1e-9);
}

/// Press a mass-damper device held by a hand `hand_depth` into a plane (past the proxy's first
/// contact) and back out; return its energy ledger.
fn press_cycle(
    stiffness: f64,
    device_damping: f64,
    press_time: f64,
    hand_depth: f64,
) -> haptics::device::EnergyLedger {
    let world = world(&floor(0.1, 0.0), DVec3::ZERO);
    let above = DVec3::new(0.0, 0.0, 0.02);
    let below = DVec3::new(0.0, 0.0, RADIUS - hand_depth);
    let trajectory = Trajectory::from_samples(&[
        (0.0, above),
        (0.05, above),
        (0.05 + press_time, below),
        (0.1 + press_time, below),
        (0.1 + 2.0 * press_time, above),
        (0.4 + 2.0 * press_time, above),
    ])
    .unwrap();
    let end = trajectory.end_time();
    let dynamics = Dynamics { damping: device_damping, ..Dynamics::default() };
    let mut device = SimulatedDevice::replay(trajectory).with_dynamics(dynamics);
    let mut specs = SimulatedDevice::default_specs();
    specs.max_stiffness = stiffness;
    let mut renderer =
        HapticRenderer::new(world, frictionless(stiffness), &specs, identity(), settings(RADIUS));
    let config = ReplayConfig { rate_hz: 1000.0, start: 0.0, end };
    let mut contact = 0;
    replay(&mut device, &mut renderer, &config, |t| {
        contact += (t.contacts > 0) as u32;
        Ok(())
    })
    .unwrap();
    assert!(contact > 10, "the press never reached the plane");
    device.energy()
}

#[test]
fn a_closed_press_cycle_is_passive() {
    // The simulated device's damping (1 N s/m) and maximum stiffness (2000 N/m) meet Colgate's
    // bound b > k T / 2 at 1 kHz. The sampled spring returns more energy than it stored (its
    // work over the cycle is positive), but less than the device dissipates while in contact,
    // and the display as a whole delivers no energy to the hand.
    // Shallow presses keep the force below its limit (where the spring's lag matters most);
    // deep ones saturate it.
    for hand_depth in [0.004, 0.015] {
        for press_time in [0.02, 0.1, 0.5] {
            for stiffness in [500.0, 1000.0, 1900.0] {
                let e = press_cycle(stiffness, 1.0, press_time, hand_depth);
                eprintln!(
                    "passivity: depth {hand_depth} m, k {stiffness} N/m, press {press_time} s: spring work {:.3e} J, dissipated in contact {:.3e} J, delivered to the hand {:.3e} J",
                    e.by_rendered_force,
                    e.dissipated_in_contact,
                    e.delivered_to_user()
                );
                assert!(e.contact_surplus() <= 0.0, "k {stiffness}, press {press_time} s: {e:?}");
                assert!(e.delivered_to_user() <= 0.0, "k {stiffness}, press {press_time} s: {e:?}");
            }
        }
    }
}

#[test]
fn passivity_check_detects_an_active_display() {
    // Above the bound (k = 6000 N/m > 2 b / T) or without device damping, the same measurement
    // must find the contact active, or the passing test above proves nothing.
    for (stiffness, damping) in [(6000.0, 1.0), (1900.0, 0.0)] {
        let e = press_cycle(stiffness, damping, 0.5, 0.004);
        eprintln!(
            "passivity, k {stiffness} N/m, b {damping} N s/m: spring work {:.3e} J, dissipated in contact {:.3e} J",
            e.by_rendered_force, e.dissipated_in_contact
        );
        assert!(e.contact_surplus() > 0.0, "k {stiffness}, b {damping}: {e:?}");
    }
}

#[test]
fn replay_is_deterministic_and_the_log_is_atomic() {
    let world =
        world(&cuboid(DVec3::new(-0.0625, -0.0625, -0.125), DVec3::new(0.0625, 0.0625, 0.0)), DVec3::ZERO);
    let scratch = tempfile::Builder::new().prefix("haptics-replay-").tempdir().unwrap();
    let dir = scratch.path();
    let points = [
        DVec3::new(-0.03, 0.01, 0.03),
        DVec3::new(-0.03, 0.01, 0.001),
        DVec3::new(0.06, 0.02, 0.001),
        DVec3::new(0.052, 0.0, -0.05),
    ];
    let samples = path(&points, 0.3);
    let mut logs = Vec::new();
    for i in 0..2 {
        let log_path = dir.join(format!("force-{i}.csv"));
        let mut log = ForceLogWriter::create(&log_path).unwrap();
        let trajectory = Trajectory::from_samples(&samples).unwrap();
        let end = trajectory.end_time();
        let mut device = SimulatedDevice::replay(trajectory);
        let materials = MaterialTable::uniform(Material {
            stiffness: 800.0,
            static_friction: 0.4,
            dynamic_friction: 0.2,
        });
        let mut renderer = HapticRenderer::new(
            Arc::clone(&world),
            materials,
            device.specs(),
            identity(),
            RenderSettings::new(RADIUS),
        );
        replay(&mut device, &mut renderer, &ReplayConfig { rate_hz: 1000.0, start: 0.0, end }, |t| {
            log.write(t)
        })
        .unwrap();
        assert!(!log_path.exists(), "the log appeared before it was finished");
        log.finish().unwrap();
        logs.push(std::fs::read(&log_path).unwrap());
    }
    assert_eq!(logs[0], logs[1]);
    let text = String::from_utf8(logs[0].clone()).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,device_x,device_y,device_z,proxy_x,proxy_y,proxy_z,fx,fy,fz"));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len() as f64, (samples.last().unwrap().0 * 1000.0 + 1e-9).floor() + 1.0);
    assert!(rows[1].starts_with("0.001,"));
    assert!(
        rows.iter().all(|r| r.split(',').count() == 10 && r.split(',').all(|v| v.parse::<f64>().is_ok()))
    );
}

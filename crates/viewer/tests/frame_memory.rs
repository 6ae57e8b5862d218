//! GPU test that drawing frames does not grow the process: after a first round has compiled
//! every pipeline, a round of moving, stopping and settling frames with everything on (shadows
//! from layers and a live mesh, the near field, bounce light and second bounce, glossy lobes and
//! reflections, antialiased edges) leaves the resident memory where it was.
//!
//! Lavapipe of Mesa 22.3 compiles a pipeline specialised on its uniform buffers' values again
//! at every bind and keeps each copy: about 20 MB a frame for the cursor sphere's draw alone
//! (ARCHITECTURE.md, "No uniform buffers"). Its own binary, so no other test's allocations
//! count.

#![cfg(target_os = "linux")]

#[allow(dead_code)]
#[path = "../benches/rooms/mod.rs"]
mod rooms;

mod common;

use glam::{DMat4, DVec3, Vec3};
use std::sync::Arc;
use viewer::{Compositor, CompositorSettings, LiveObjects, Material, MeshInstance};

/// Frames the sphere moves in a round before it stops.
const MOVES: u32 = 6;
/// What the process may grow over a measured round. One pipeline compiled at every bind grows
/// it by about 20 MB a frame on lavapipe.
const GROWTH_LIMIT_KB: u64 = 48 * 1024;

/// The process's resident memory, in kB.
fn resident_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .expect("VmRSS in /proc/self/status")
}

/// The bench's sphere at `frame` of its path, and a live box beside it (its own bind group
/// offset, material and shadow).
fn objects(frame: u32, cube: &Arc<viewer::Mesh>) -> LiveObjects {
    let mut live = rooms::sphere_at(frame);
    live.meshes.push(MeshInstance {
        mesh: cube.clone(),
        world_from_object: DMat4::from_translation(DVec3::new(0.45, -0.8, 0.1)),
        material: Material::default(),
        exact_sphere: None,
    });
    live
}

/// Draws rounds of frames in the glossy room at 128^2 with `settings`: the sphere moves, then
/// stays where it stopped for `at_rest` frames. After a first round, which compiles every
/// pipeline (and lavapipe's variants of them) and fills the allocators' pools, a second may not
/// grow the process.
fn assert_rounds_hold_memory(settings: CompositorSettings, at_rest: u32) {
    let gpu = common::gpu();
    let mut scene = rooms::lit_room(128, true);
    rooms::bind_room_scene(&mut scene, true, true);
    let cube = Arc::new(viewer::Mesh::cuboid(Vec3::splat(0.15)));
    let mut compositor = Compositor::new(&gpu, &scene, settings).expect("compositor");
    let mut round = || {
        for frame in 0..MOVES {
            compositor.render(&objects(frame, &cube)).expect("moving frame");
        }
        for _ in 0..at_rest {
            compositor.render(&objects(MOVES - 1, &cube)).expect("frame at rest");
            compositor.wait_idle().expect("wait");
        }
    };
    round();
    let before = resident_kb();
    round();
    let after = resident_kb();
    assert!(
        after <= before + GROWTH_LIMIT_KB,
        "{} frames grew the process from {before} kB to {after} kB: a pipeline compiled per frame?",
        MOVES + at_rest
    );
}

/// hybrid-view's frames (moving ones amortised, then the frames at rest settle a band at a time,
/// 23 frames in this room at 128^2, until the frame is kept), then every frame drawn exactly and
/// in full, none kept. One test, so that the two never run at once.
#[test]
fn frames_do_not_grow_the_process() {
    let amortised =
        CompositorSettings { amortise_while_moving: true, settle_at_rest: true, ..Default::default() };
    assert_rounds_hold_memory(amortised, 30);
    let exact =
        CompositorSettings { amortise_while_moving: false, keep_frame_at_rest: false, ..Default::default() };
    assert_rounds_hold_memory(exact, 4);
}

//! GPU tests of the frame kept at rest (`compositor/frame.rs`): a frame at rest with the inputs
//! and compositing mode of the last exact frame draws nothing, its targets still holding that
//! frame. In the Cornell room lit by its area light, with the walls bound as the scene's
//! triangles and materials (the scene's shadow rays on the sphere, the near field), the kept
//! frame equals, bit for bit, the frame a fresh compositor draws, and a move of the sphere or a
//! change of the compositing mode draws the frame again.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::occluders::{SceneMaterial, SceneMaterials, SceneOccluders};
use viewer::{CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, Sphere, ViewerScene};

const HERE: DVec3 = DVec3::new(-0.3, -0.6, 0.3);
const THERE: DVec3 = DVec3::new(0.3, -0.6, -0.2);

/// The flat Cornell backdrop lit by the Cornell area light (its layer holds all of it, its 64
/// samples), a uniform irradiance probe, and the room's five walls as the scene's matte
/// triangles.
fn scene() -> ViewerScene {
    let level = 0.5;
    let mut s = flat_cornell(level, vec![cornell_light()]);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers =
        sidecar::LightLayers::new(512, 512, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    layers.light[0].iter_mut().for_each(|v| *v = [level; 3]);
    layers.normal.iter_mut().for_each(|v| *v = [0.0, 1.0, 0.0]);
    layers.albedo.iter_mut().for_each(|v| *v = [0.7; 3]);
    s.set_light_layers(viewer::SceneLayers {
        layers,
        layer_of_light: vec![Some(0)],
        area_samples: vec![cornell_emitter_samples()],
    })
    .unwrap();
    s.set_probes(sidecar::ProbeGrid { depth_fingerprint: fingerprint, ..uniform_probe([0.2; 3]) });
    let v = DVec3::new;
    let quads = [
        [v(-1.0, -1.0, -1.0), v(1.0, -1.0, -1.0), v(1.0, -1.0, 1.0), v(-1.0, -1.0, 1.0)],
        [v(-1.0, 1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(-1.0, 1.0, 1.0)],
        [v(-1.0, -1.0, -1.0), v(1.0, -1.0, -1.0), v(1.0, 1.0, -1.0), v(-1.0, 1.0, -1.0)],
        [v(-1.0, -1.0, -1.0), v(-1.0, 1.0, -1.0), v(-1.0, 1.0, 1.0), v(-1.0, -1.0, 1.0)],
        [v(1.0, -1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(1.0, -1.0, 1.0)],
    ];
    let triangles: Vec<[DVec3; 3]> =
        quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    let of_triangle = vec![0; triangles.len()];
    s.set_occluders(SceneOccluders { triangles });
    let wall = SceneMaterial { diffuse: Vec3::splat(0.7), ..Default::default() };
    s.set_occluder_materials(SceneMaterials { materials: vec![wall], of_triangle });
    s
}

/// A glossy sphere at `centre`.
fn sphere(centre: DVec3) -> LiveObjects {
    LiveObjects {
        sphere: Some(Sphere { centre, radius: 0.25, material: Material::default() }),
        meshes: Vec::new(),
    }
}

/// Every pass on, in `mode`, a moving frame amortised and reduced as `hybrid-view` draws it.
fn settings(mode: CompositeMode) -> CompositorSettings {
    CompositorSettings { mode, amortise_while_moving: true, ..CompositorSettings::default() }
}

/// A frame's linear colour and mask.
type Frame = (Vec<f32>, Vec<u8>);

/// `c`'s last frame.
fn frame_of(c: &Compositor) -> Frame {
    (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
}

/// The frame a fresh compositor in `mode` draws of `live`.
fn fresh(scene: &ViewerScene, mode: CompositeMode, live: &LiveObjects) -> Frame {
    let mut c = Compositor::new(&gpu(), scene, settings(mode)).unwrap();
    c.render(live).unwrap();
    frame_of(&c)
}

/// Renders `live` with its passes timed: whether the frame was the one kept at rest (it timed
/// that alone), and the frame.
fn render_timed(c: &mut Compositor, live: &LiveObjects) -> (bool, Frame) {
    let (before, _) = c.pass_times();
    c.set_pass_timing(true);
    c.render(live).unwrap();
    c.set_pass_timing(false);
    let (after, _) = c.pass_times();
    let drew = |pass: &str| {
        let frames = |times: &[viewer::compositor::PassTime]| {
            times.iter().find(|t| t.pass == pass).map_or(0, |t| t.frames)
        };
        frames(&after) > frames(&before)
    };
    let kept = drew("the frame kept at rest");
    assert!(kept != drew("live objects"), "a frame both kept and drew its live objects, or neither");
    (kept, frame_of(c))
}

/// The second frame at rest is the kept one, and it equals the first and a fresh compositor's
/// frame bit for bit, colour and mask.
#[test]
fn the_frame_kept_at_rest_equals_a_fresh_one() {
    let scene = scene();
    let want = fresh(&scene, CompositeMode::Fullscreen, &sphere(HERE));
    let mut c = Compositor::new(&gpu(), &scene, settings(CompositeMode::Fullscreen)).unwrap();
    let (kept, first) = render_timed(&mut c, &sphere(HERE));
    assert!(!kept, "the first frame was kept from nothing");
    assert!(first == want, "the first frame differs from a fresh compositor's");
    let (kept, second) = render_timed(&mut c, &sphere(HERE));
    assert!(kept, "the second frame at rest was drawn again");
    assert!(second == want, "the kept frame differs from a fresh compositor's");
}

/// A moving frame is not kept, nor is the frame after it, which draws the exact frame again;
/// the frame after that is kept. A change of compositing mode draws the frame again, which
/// then equals a fresh compositor's in that mode.
#[test]
fn a_move_or_a_new_mode_draws_the_frame_again() {
    let scene = scene();
    let mut c = Compositor::new(&gpu(), &scene, settings(CompositeMode::Fullscreen)).unwrap();
    let drawn: Vec<(bool, Frame)> =
        [HERE, HERE, THERE, THERE, THERE].iter().map(|&at| render_timed(&mut c, &sphere(at))).collect();
    let kept: Vec<bool> = drawn.iter().map(|d| d.0).collect();
    assert_eq!(kept, [false, true, false, false, true], "which frames were kept");
    let there = fresh(&scene, CompositeMode::Fullscreen, &sphere(THERE));
    assert!(drawn[2].1 != there, "the moving frame is the exact one: the move tests nothing");
    assert!(drawn[3].1 == there && drawn[4].1 == there, "the frames at rest differ from a fresh one");
    c.set_mode(CompositeMode::Points);
    let (kept, points) = render_timed(&mut c, &sphere(THERE));
    assert!(!kept, "the frame in the new mode was kept from the old one");
    assert!(points == fresh(&scene, CompositeMode::Points, &sphere(THERE)), "the new mode's frame differs");
    assert!(render_timed(&mut c, &sphere(THERE)).0, "the next frame in the new mode was drawn again");
}

/// With the sphere gone after frames at rest, the frame is the input again.
#[test]
fn without_the_sphere_the_kept_frame_gives_way_to_the_input() {
    let scene = scene();
    let mut c = Compositor::new(&gpu(), &scene, settings(CompositeMode::Fullscreen)).unwrap();
    for live in [sphere(HERE), sphere(HERE), LiveObjects::default()] {
        c.render(&live).unwrap();
    }
    let (rgba, mask) = frame_of(&c);
    assert!(rgba.chunks(4).all(|p| p[..3] == [0.5; 3]), "the input changed with no live object");
    assert!(mask.iter().all(|&m| m == 0), "a live object's mask stayed");
}

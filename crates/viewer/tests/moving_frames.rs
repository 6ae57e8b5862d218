//! GPU tests of the frames of a moving sphere with `CompositorSettings::amortise_while_moving`:
//! while the sphere moves, the bounce light and the shadows' second bounce are gathered at
//! reduced resolution (`compositor/reduced_gather.rs`), or, with `reduce_while_moving` off, what
//! each pixel loses to the second bounce is drawn in one band of the frame per frame
//! (`compositor/shadow_bounce.rs`); either way the second frame at rest is, bit for bit, the
//! frame a fresh compositor draws, in both compositing modes.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::{CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, Sphere};

const LEVEL: f32 = 0.5;
const HERE: DVec3 = DVec3::new(-0.5, -0.55, 0.55);
const THERE: DVec3 = DVec3::new(0.3, -0.6, -0.2);

/// The Cornell camera and depth, a flat backdrop of `LEVEL` lit by one point light (its layer
/// holds all of it), each side's normal and an albedo of 0.8: the ceiling and the walls receive
/// what the sphere's shadow on the floor no longer reflects.
fn scene() -> viewer::ViewerScene {
    with_sides(layered_cornell(DVec3::new(-0.3, 0.6, 0.5), false, LEVEL))
}

/// The same lit by the Cornell box's area light (its layer holds all of `LEVEL`): soft shadows.
fn area_lit_scene() -> viewer::ViewerScene {
    let mut s = flat_cornell(LEVEL, vec![cornell_light()]);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers =
        sidecar::LightLayers::new(512, 512, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    layers.light[0].iter_mut().for_each(|v| *v = [LEVEL; 3]);
    s.set_light_layers(viewer::SceneLayers {
        layers,
        layer_of_light: vec![Some(0)],
        area_samples: vec![cornell_emitter_samples()],
    })
    .unwrap();
    with_sides(s)
}

/// `s` with each side's normal and an albedo of 0.8 in its light layers.
fn with_sides(mut s: viewer::ViewerScene) -> viewer::ViewerScene {
    let camera = s.camera().clone();
    let mut layers = s.light_layers().expect("layers").clone();
    for (k, (normal, albedo)) in layers.layers.normal.iter_mut().zip(&mut layers.layers.albedo).enumerate() {
        let (i, j) = (k as u32 % 512, k as u32 / 512);
        let Some(r) = s.depth().get(i, j).filter(|r| r.is_finite()) else { continue };
        let ray = camera.pixel_centre_ray(i, j);
        let p = camera.world_from_camera().transform_point3(ray.origin + ray.direction * f64::from(r));
        // The side the point lies on (the boxes' faces keep the floor's normal).
        let near = |a: f64, b: f64| (a - b).abs() < 1e-3;
        *normal = match () {
            _ if near(p.y, 1.0) => [0.0, -1.0, 0.0],
            _ if near(p.x, -1.0) => [1.0, 0.0, 0.0],
            _ if near(p.x, 1.0) => [-1.0, 0.0, 0.0],
            _ if near(p.z, -1.0) => [0.0, 0.0, 1.0],
            _ => [0.0, 1.0, 0.0],
        };
        *albedo = [0.8; 3];
    }
    s.set_light_layers(layers).unwrap();
    s
}

fn sphere(centre: DVec3) -> LiveObjects {
    LiveObjects {
        sphere: Some(Sphere { centre, radius: 0.2, material: Material::unlit(Vec3::new(0.0, 0.0, 1.0)) }),
        meshes: Vec::new(),
    }
}

/// The bands' settings: no bounce light, the second bounce in bands while moving.
fn settings(mode: CompositeMode, amortise_while_moving: bool) -> CompositorSettings {
    CompositorSettings {
        mode,
        bounce_light: false,
        amortise_while_moving,
        reduce_while_moving: false,
        ..Default::default()
    }
}

/// The frame a fresh compositor with `settings` draws of `live`.
fn fresh_with(settings: CompositorSettings, live: &LiveObjects) -> Vec<f32> {
    fresh_in(&scene(), settings, live)
}

/// The frame a fresh compositor with `settings` draws of `live` in `scene`.
fn fresh_in(scene: &viewer::ViewerScene, settings: CompositorSettings, live: &LiveObjects) -> Vec<f32> {
    let mut c = Compositor::new(&gpu(), scene, settings).unwrap();
    c.render(live).unwrap();
    c.read_back_linear().unwrap().rgba
}

/// The frame a fresh compositor draws of `live` with the bands' settings.
fn fresh(mode: CompositeMode, live: &LiveObjects) -> Vec<f32> {
    fresh_with(settings(mode, false), live)
}

/// A white matte sphere: it sends the scene bounce light.
fn matte_sphere(centre: DVec3) -> LiveObjects {
    let material = Material { colour: Vec3::splat(0.8), ks: 0.0, ..Material::default() };
    LiveObjects { sphere: Some(Sphere { centre, radius: 0.2, material }), meshes: Vec::new() }
}

/// relMSE `(x - r)^2 / (r^2 + 0.01)` of `image` against `reference` (RGBA), over the pixels
/// where `region` holds, and how many there are.
fn rel_mse(image: &[f32], reference: &[f32], region: impl Fn(usize) -> bool) -> (f64, usize) {
    let (mut sum, mut n) = (0.0, 0);
    for (k, (a, b)) in image.chunks(4).zip(reference.chunks(4)).enumerate() {
        if !region(k) {
            continue;
        }
        for c in 0..3 {
            let (x, t) = (f64::from(a[c]), f64::from(b[c]));
            sum += (x - t) * (x - t) / (t * t + 0.01);
        }
        n += 1;
    }
    (sum / (3 * n.max(1)) as f64, n)
}

/// The rows of `a` and `b` (RGBA rows of 512 pixels) that differ.
fn differing_rows(a: &[f32], b: &[f32]) -> Vec<usize> {
    let row = 512 * 4;
    (0..a.len() / row).filter(|&j| a[j * row..(j + 1) * row] != b[j * row..(j + 1) * row]).collect()
}

/// The four frames one compositor draws for `live` at `HERE`, then at `THERE` three times (a
/// moving frame, the first frame at rest, a still one), checked to be the same in both
/// compositing modes.
fn moved_then_resting(
    settings: impl Fn(CompositeMode) -> CompositorSettings,
    live: impl Fn(DVec3) -> LiveObjects,
) -> Vec<Vec<f32>> {
    let mut frames = Vec::new();
    for mode in [CompositeMode::Fullscreen, CompositeMode::Points] {
        let mut c = Compositor::new(&gpu(), &scene(), settings(mode)).unwrap();
        let mut seen = Vec::new();
        for centre in [HERE, THERE, THERE, THERE] {
            c.render(&live(centre)).unwrap();
            seen.push(c.read_back_linear().unwrap().rgba);
        }
        frames.push(seen);
    }
    assert!(frames[0] == frames[1], "the two compositing paths differ");
    frames.swap_remove(0)
}

/// The first frame is exact; the frame after a move differs from the exact one only outside the
/// band it redrew (the top rows, the first band); the next frame at rest is exact again, and the
/// two compositing modes stay bit-identical throughout.
#[test]
fn a_moving_frame_redraws_one_band_and_the_frame_at_rest_is_exact() {
    let exact_here = fresh(CompositeMode::Fullscreen, &sphere(HERE));
    let exact_there = fresh(CompositeMode::Fullscreen, &sphere(THERE));
    let moved_rows = differing_rows(&exact_here, &exact_there);
    let band = 512 / viewer::compositor::SHADOW_BOUNCE_BANDS as usize;
    assert!(moved_rows.iter().any(|&j| j < band), "the move changes nothing in the first band");
    let frames = moved_then_resting(|mode| settings(mode, true), sphere);
    let [first, moving, resting, still] = &frames[..] else { unreachable!() };
    assert!(*first == exact_here, "the first frame is not the exact one");
    let stale = differing_rows(moving, &exact_there);
    assert!(!stale.is_empty(), "the moving frame redrew everything");
    assert!(
        stale.iter().all(|&j| j >= band),
        "rows {stale:?} of the redrawn band differ from the exact frame"
    );
    assert!(*resting == exact_there, "the frame at rest differs from a fresh compositor's");
    assert!(*still == exact_there, "the backdrop kept from the frame before differs from a fresh one");
}

/// A frame with the inputs of the one before copies the backdrop after shadows, bounce light and
/// second bounce that frame drew instead of drawing them again: with every pass on, it equals a
/// fresh compositor's frame, also after the sphere left the view and came back.
#[test]
fn a_frame_at_rest_equals_a_fresh_one() {
    let all_on = CompositorSettings::default();
    let mut c = Compositor::new(&gpu(), &scene(), all_on).unwrap();
    let mut fresh = Compositor::new(&gpu(), &scene(), all_on).unwrap();
    fresh.render(&sphere(THERE)).unwrap();
    let want = fresh.read_back_linear().unwrap();
    for live in [sphere(THERE), sphere(THERE), LiveObjects::default(), sphere(THERE)] {
        c.render(&live).unwrap();
    }
    let got = c.read_back_linear().unwrap();
    assert!(got.rgba == want.rgba, "a frame at rest differs from a fresh compositor's");
}

/// With the sphere gone the frame is the input, amortised or not, after any move.
#[test]
fn without_a_live_object_the_frame_is_the_input() {
    let mut c = Compositor::new(&gpu(), &scene(), settings(CompositeMode::Fullscreen, true)).unwrap();
    for live in [sphere(HERE), sphere(THERE), LiveObjects::default()] {
        c.render(&live).unwrap();
    }
    let empty = c.read_back_linear().unwrap().rgba;
    assert!(empty.chunks(4).all(|c| c[..3] == [LEVEL; 3]), "the input changed with no live object");
}

/// With every pass on and the bounce light and second bounce gathered at reduced resolution
/// while moving: the first frame is exact; the frame after a move differs from the exact one
/// (it is smoothed) but within a relMSE of 1e-6 over the pixels the sphere changes, a hundredth
/// of the bands' error at most (1.7e-8 against 2.3e-4 when written, 3.9e-8 since the moving
/// sphere is shaded from its radiosity map: the gathered terms are smooth; a loss left from the
/// sphere's old place, as the bands leave it, is not); the next frame at rest and the one after
/// are exact; both compositing modes stay bit-identical throughout. (The point light's hard
/// shadows are drawn in full while moving.)
#[test]
fn a_moving_frame_at_reduced_resolution_is_near_the_exact_one_and_the_frame_at_rest_is_exact() {
    let all_on = |mode| CompositorSettings { mode, amortise_while_moving: true, ..Default::default() };
    let exact = |live: &LiveObjects| {
        fresh_with(
            CompositorSettings { amortise_while_moving: false, ..all_on(CompositeMode::Fullscreen) },
            live,
        )
    };
    let (exact_here, exact_there) = (exact(&matte_sphere(HERE)), exact(&matte_sphere(THERE)));
    let frames = moved_then_resting(all_on, matte_sphere);
    let [first, moving, resting, still] = &frames[..] else { unreachable!() };
    assert!(*first == exact_here, "the first frame is not the exact one");
    // The pixels the sphere changes at its new place, its own included.
    let changed = |k: usize| exact_there[4 * k..4 * k + 3] != [LEVEL; 3];
    let (error, pixels) = rel_mse(moving, &exact_there, changed);
    // The same move with the second bounce in bands, most of them left from the sphere's old
    // place.
    let mut bands = Compositor::new(
        &gpu(),
        &scene(),
        CompositorSettings { reduce_while_moving: false, ..all_on(CompositeMode::Fullscreen) },
    )
    .unwrap();
    for live in [matte_sphere(HERE), matte_sphere(THERE)] {
        bands.render(&live).unwrap();
    }
    let (bands_error, _) = rel_mse(&bands.read_back_linear().unwrap().rgba, &exact_there, changed);
    eprintln!(
        "moving frame against the exact one, relMSE over the {pixels} pixels the sphere changes: \
         {error:.3e} reduced, {bands_error:.3e} in bands"
    );
    assert!(*moving != exact_there, "the moving frame was drawn exactly");
    assert!(pixels > 10_000, "the sphere changes only {pixels} pixels");
    assert!(error <= 1e-6, "relMSE {error:.3e} over the pixels the sphere changes");
    assert!(error * 100.0 <= bands_error, "reduced {error:.3e}, in bands {bands_error:.3e}");
    assert!(*resting == exact_there, "the frame at rest differs from a fresh compositor's");
    assert!(*still == exact_there, "the backdrop kept from the frame before differs from a fresh one");
}

/// A timed frame (`Compositor::set_pass_timing`: a submit and a wait after each pass) has the
/// pixels of an untimed one, moving and at rest, and the times name the passes drawn.
#[test]
fn a_timed_frame_equals_an_untimed_one() {
    let moves = [sphere(HERE), sphere(THERE), sphere(THERE), sphere(THERE)];
    let frames = |timed: bool| {
        let mut c = Compositor::new(&gpu(), &scene(), settings(CompositeMode::Fullscreen, true)).unwrap();
        c.set_pass_timing(timed);
        let seen: Vec<Vec<f32>> = moves
            .iter()
            .map(|live| {
                c.render(live).unwrap();
                c.read_back_linear().unwrap().rgba
            })
            .collect();
        (seen, c.pass_times())
    };
    let (untimed, (no_times, no_frames)) = frames(false);
    let (timed, (times, timed_frames)) = frames(true);
    assert!(timed == untimed, "timing the passes changed the frames");
    assert!(no_times.is_empty() && no_frames == 0, "untimed frames were timed");
    assert_eq!(timed_frames, 4);
    let names: Vec<&str> = times.iter().map(|t| t.pass).collect();
    for pass in ["backdrop", "layered shadows", "second bounce: what each pixel loses", "live objects"] {
        assert!(names.contains(&pass), "no time for {pass}: {names:?}");
    }
    let layered = times.iter().find(|t| t.pass == "layered shadows").unwrap();
    // The first frame, the move and the first frame at rest draw them; the second at rest copies.
    assert_eq!(layered.frames, 3, "the layered shadows are drawn while moving, copied at rest");
}

/// A plastic sphere (the default material: a Blinn highlight besides its diffuse lobe).
fn plastic_sphere(centre: DVec3) -> LiveObjects {
    LiveObjects {
        sphere: Some(Sphere { centre, radius: 0.2, material: Material::default() }),
        meshes: Vec::new(),
    }
}

/// A moving frame shades the cursor sphere from its radiosity map (its diffuse radiance; its
/// highlight without the scene's shadow rays, scaled by the map's share of light let through):
/// over the sphere's pixels the moving frame differs from the exact one, within a relMSE of
/// 1e-4 (1.7e-5 when written: the map's bilinear texels against per-pixel shading); the next
/// frame at rest shades it exactly again, bit for bit.
#[test]
fn a_moving_sphere_is_shaded_from_its_radiosity_map_and_exactly_at_rest() {
    let amortised = CompositorSettings { amortise_while_moving: true, ..Default::default() };
    let exact = CompositorSettings { amortise_while_moving: false, ..amortised };
    let mut reference = Compositor::new(&gpu(), &scene(), exact).unwrap();
    reference.render(&plastic_sphere(HERE)).unwrap();
    let (exact_here, mask) =
        (reference.read_back_linear().unwrap().rgba, reference.read_back().unwrap().mask);
    let mut c = Compositor::new(&gpu(), &scene(), amortised).unwrap();
    let mut frames = Vec::new();
    for centre in [THERE, HERE, HERE] {
        c.render(&plastic_sphere(centre)).unwrap();
        frames.push(c.read_back_linear().unwrap().rgba);
    }
    // The sphere's own pixels (the centre-sampled mask: its edges are blended with the backdrop).
    let on_sphere = |k: usize| mask[k] == 255;
    let (error, pixels) = rel_mse(&frames[1], &exact_here, on_sphere);
    let differing = (0..mask.len())
        .filter(|&k| on_sphere(k) && frames[1][4 * k..4 * k + 3] != exact_here[4 * k..4 * k + 3])
        .count();
    eprintln!(
        "moving sphere against the exact one: relMSE {error:.3e} over its {pixels} pixels, {differing} differ"
    );
    assert!(pixels > 1_000, "the sphere covers only {pixels} pixels");
    // (The half the light does not reach is black either way.)
    assert!(
        differing * 4 > pixels,
        "the moving sphere was shaded exactly ({differing} of {pixels} pixels differ)"
    );
    assert!(error <= 1e-4, "relMSE {error:.3e} over the sphere's pixels");
    assert!(frames[2] == exact_here, "the frame at rest differs from a fresh compositor's");
}

/// A moving frame gathers an area light's layered shadows at reduced resolution (the share of
/// the light the sphere hides, spread along each surface and applied to each pixel's own
/// layer): with the bounce light and the second bounce off, the moving frame differs from the
/// exact one only there, within a relMSE of 5e-3 over the pixels the sphere changes (issue 10's
/// bound for that region; 3.2e-3 at one sample per 4x4 pixels, 1.1e-3 at 2x2 before: the worst
/// case for relMSE, a light layer that holds all of the pixel, so the umbra is black, and the
/// interpolation's error is largest where it meets the penumbra; in the Cornell sweep the whole
/// moving frame's relMSE over the region the sphere changes is 2.1e-4, docs/viewer-frame-time.md);
/// the next frame at rest is exact.
#[test]
fn a_moving_frame_gathers_the_shadows_at_reduced_resolution_and_the_frame_at_rest_is_exact() {
    let shadows_only = CompositorSettings {
        amortise_while_moving: true,
        bounce_light: false,
        shadow_bounce: false,
        ..Default::default()
    };
    let exact_here = fresh_in(
        &area_lit_scene(),
        CompositorSettings { amortise_while_moving: false, ..shadows_only },
        &sphere(HERE),
    );
    let mut c = Compositor::new(&gpu(), &area_lit_scene(), shadows_only).unwrap();
    let mut frames = Vec::new();
    for centre in [THERE, HERE, HERE] {
        c.render(&sphere(centre)).unwrap();
        frames.push(c.read_back_linear().unwrap().rgba);
    }
    let changed = |k: usize| exact_here[4 * k..4 * k + 3] != [LEVEL; 3];
    let (error, pixels) = rel_mse(&frames[1], &exact_here, changed);
    eprintln!(
        "moving shadows against the exact ones: relMSE {error:.3e} over the {pixels} pixels the sphere changes"
    );
    assert!(frames[1] != exact_here, "the moving frame's shadows were drawn exactly");
    assert!(error <= 5e-3, "relMSE {error:.3e} over the pixels the sphere changes");
    assert!(frames[2] == exact_here, "the frame at rest differs from a fresh compositor's");
}

/// A point light's hard shadows, whose edges a block would spread, are drawn in full in a
/// moving frame: with the bounce light and the second bounce off, the moving frame is the exact
/// one.
#[test]
fn a_point_light_s_shadows_stay_exact_while_moving() {
    let shadows_only = CompositorSettings {
        amortise_while_moving: true,
        bounce_light: false,
        shadow_bounce: false,
        ..Default::default()
    };
    let exact_here =
        fresh_with(CompositorSettings { amortise_while_moving: false, ..shadows_only }, &sphere(HERE));
    let mut c = Compositor::new(&gpu(), &scene(), shadows_only).unwrap();
    for centre in [THERE, HERE] {
        c.render(&sphere(centre)).unwrap();
    }
    assert!(c.read_back_linear().unwrap().rgba == exact_here, "the moving frame's hard shadows differ");
}

/// The settling frames that draw the backdrop's rows exactly at 512^2 (`compositor/settle.rs`).
fn settling_rows_steps() -> usize {
    512usize.div_ceil((viewer::compositor::SETTLE_PIXELS / 512).max(1) as usize)
}

/// With `settle_at_rest`, the frames at rest after a move draw the exact layered shadows a band
/// of their rows at a time, then the maps, then the exact bounce light and second bounce a band
/// of the frame's rows at a time (`compositor/settle.rs`; `SETTLE_PIXELS` a frame), then the
/// sphere's exact shading a band of its rows at a time: every frame while it settles stays
/// within the moving frame's error bound (relMSE 1e-6 over the pixels the sphere changes; the
/// rows not yet exact are as the moving frame drew them), the first is not yet the exact one, and
/// from a frame after the backdrop's rows' steps on every frame is, bit for bit, the frame a
/// fresh compositor draws.
#[test]
fn the_frames_at_rest_settle_band_by_band_into_the_exact_frame() {
    let settling =
        CompositorSettings { amortise_while_moving: true, settle_at_rest: true, ..Default::default() };
    let exact_there =
        fresh_with(CompositorSettings { amortise_while_moving: false, ..settling }, &matte_sphere(THERE));
    let changed = |k: usize| exact_there[4 * k..4 * k + 3] != [LEVEL; 3];
    let bands = settling_rows_steps();
    let mut c = Compositor::new(&gpu(), &scene(), settling).unwrap();
    c.render(&matte_sphere(HERE)).unwrap();
    c.render(&matte_sphere(THERE)).unwrap();
    let (mut errors, mut first_exact) = (Vec::new(), None);
    // The layered shadows take a few frames before the rows, and the sphere's rows settle after
    // them, a few a frame: fewer than 32 frames in all here.
    for frame in 1..=bands + 32 {
        if first_exact.is_some_and(|exact| frame > exact + 1) {
            break;
        }
        c.render(&matte_sphere(THERE)).unwrap();
        let image = c.read_back_linear().unwrap().rgba;
        let (error, pixels) = rel_mse(&image, &exact_there, changed);
        errors.push(format!("{error:.2e}"));
        assert!(pixels > 10_000, "the sphere changes only {pixels} pixels");
        if frame == 1 {
            assert!(image != exact_there, "the first frame at rest was drawn exactly, all of it");
        }
        if image == exact_there {
            first_exact.get_or_insert(frame);
        } else {
            assert!(first_exact.is_none(), "frame {frame} at rest differs after an exact one");
            assert!(
                error <= 1e-6,
                "frame {frame} at rest: relMSE {error:.3e} over the pixels the sphere changes"
            );
        }
    }
    eprintln!(
        "the frames at rest against the exact one, relMSE over the pixels the sphere changes: {errors:?}"
    );
    let first_exact = first_exact.expect("the frames at rest never became the exact frame");
    assert!(first_exact > bands, "frame {first_exact} at rest was exact before the sphere settled");
}

/// With `settle_at_rest`, the cursor sphere's exact shading (a plastic sphere under the Cornell
/// area light: its highlight integrated over the light's samples) settles after a move a band of
/// its rows a frame (`compositor/settle.rs`): until then it is the last moving frame's, read from
/// its radiance map, so no frame at rest is further from the exact frame than the moving frame
/// was from its own exact frame (relMSE over the sphere and the pixels next to it; 1.01e-5 for
/// the moving frame, then falling to 1.4e-9 as the sphere's rows settle, when written); the
/// sphere takes more than one band, and once its last band is drawn the frame is, bit for bit, a
/// fresh compositor's and stays so (kept at rest).
#[test]
fn the_cursor_sphere_settles_row_band_by_row_band_into_its_exact_shading() {
    let settling =
        CompositorSettings { amortise_while_moving: true, settle_at_rest: true, ..Default::default() };
    let exact = CompositorSettings { amortise_while_moving: false, ..settling };
    let scene = area_lit_scene();
    let mut reference = Compositor::new(&gpu(), &scene, exact).unwrap();
    reference.render(&plastic_sphere(HERE)).unwrap();
    let (exact_here, mask) =
        (reference.read_back_linear().unwrap().rgba, reference.read_back().unwrap().mask);
    let near_sphere = |k: usize| mask[k] > 0 || next_to_mask(&mask, 512, k);
    let mut c = Compositor::new(&gpu(), &scene, settling).unwrap();
    c.render(&plastic_sphere(THERE)).unwrap();
    c.render(&plastic_sphere(HERE)).unwrap();
    let (moving_error, pixels) = rel_mse(&c.read_back_linear().unwrap().rgba, &exact_here, near_sphere);
    assert!(pixels > 1_000 && moving_error > 0.0, "the moving frame is exact ({pixels} pixels)");
    let bands = settling_rows_steps();
    let (mut errors, mut first_exact) = (Vec::new(), None);
    for frame in 1..=bands + 32 {
        if first_exact.is_some_and(|exact| frame > exact + 1) {
            break;
        }
        c.render(&plastic_sphere(HERE)).unwrap();
        let image = c.read_back_linear().unwrap().rgba;
        let error = rel_mse(&image, &exact_here, near_sphere).0;
        errors.push(format!("{error:.2e}"));
        if image == exact_here {
            first_exact.get_or_insert(frame);
        } else {
            assert!(first_exact.is_none(), "frame {frame} at rest differs after an exact one");
            // Within 1e-5 of it: a frame whose band of exact rows ends at the sphere's outline
            // mixes exact and moving rows in its blended edges (3.5e-6 above the moving frame
            // with bands of 4 rows, 2026-11-29).
            assert!(
                error <= moving_error * (1.0 + 1e-5),
                "frame {frame} at rest: relMSE {error:.3e} near the sphere, the moving frame's {moving_error:.3e}"
            );
        }
    }
    eprintln!("the moving frame's relMSE near the sphere {moving_error:.3e}, the frames at rest: {errors:?}");
    let first_exact = first_exact.expect("the frames at rest never became the exact frame");
    // The backdrop settles in more than `bands` frames (its rows after the shadows and the maps);
    // the sphere's rows take two frames or more.
    assert!(first_exact > bands + 1, "the sphere settled in one frame (frames at rest: {errors:?})");
}

/// With `cursor_map_while_moving`, a moving frame shades the cursor sphere once per texel of a
/// map over its half facing the eye and its fragments and edge samples read it bilinearly
/// (`compositor/cursor_radiance_map.rs`), instead of shading each fragment the same way: a
/// plastic sphere under the Cornell area light (its highlight integrated over the light's
/// samples), against the same moving frame shaded per fragment, within a relMSE of 2e-5 over
/// the sphere and the pixels next to it (its blended edges) and of 3e-3 at the worst pixel
/// (6.1e-6 and 1.0e-3 when written, the worst at the outline); the next frame at rest is exact,
/// bit for bit.
#[test]
fn a_moving_sphere_read_from_its_radiance_map_is_near_its_shading_per_fragment() {
    let mapped = CompositorSettings { amortise_while_moving: true, ..Default::default() };
    let per_fragment = CompositorSettings { cursor_map_while_moving: false, ..mapped };
    let exact = CompositorSettings { amortise_while_moving: false, ..mapped };
    let scene = area_lit_scene();
    let mut reference = Compositor::new(&gpu(), &scene, exact).unwrap();
    reference.render(&plastic_sphere(HERE)).unwrap();
    let (exact_here, mask) =
        (reference.read_back_linear().unwrap().rgba, reference.read_back().unwrap().mask);
    let mut frames = Vec::new();
    for settings in [mapped, per_fragment] {
        let mut c = Compositor::new(&gpu(), &scene, settings).unwrap();
        let mut seen = Vec::new();
        for centre in [THERE, HERE, HERE] {
            c.render(&plastic_sphere(centre)).unwrap();
            seen.push(c.read_back_linear().unwrap().rgba);
        }
        frames.push(seen);
    }
    let (from_map, per_pixel) = (&frames[0][1], &frames[1][1]);
    let near_sphere = |k: usize| mask[k] > 0 || next_to_mask(&mask, 512, k);
    let (error, pixels) = rel_mse(from_map, per_pixel, near_sphere);
    let worst = (0..mask.len())
        .filter(|&k| near_sphere(k))
        .map(|k| rel_mse(&from_map[4 * k..4 * k + 4], &per_pixel[4 * k..4 * k + 4], |_| true).0)
        .fold(0.0, f64::max);
    let outside = (0..mask.len())
        .filter(|&k| !near_sphere(k) && from_map[4 * k..4 * k + 3] != per_pixel[4 * k..4 * k + 3])
        .count();
    eprintln!(
        "moving sphere from its radiance map against per fragment: relMSE {error:.3e} over {pixels} pixels, worst {worst:.3e}"
    );
    assert!(pixels > 1_000, "the sphere covers only {pixels} pixels");
    assert!(from_map != per_pixel, "the moving sphere was not read from its radiance map");
    assert!(outside == 0, "{outside} pixels away from the sphere differ");
    assert!(error <= 2e-5, "relMSE {error:.3e} over the sphere's pixels");
    assert!(worst <= 3e-3, "relMSE {worst:.3e} at the worst pixel");
    assert!(frames[0][2] == exact_here, "the frame at rest differs from a fresh compositor's");
    assert!(frames[1][2] == exact_here, "the frame at rest (per fragment) differs from a fresh compositor's");
}

//! GPU test of the frames at rest after a move (`CompositorSettings::settle_at_rest`, as
//! `hybrid-view`'s window draws them) in a scene with a mirror and a glossy floor: the spheres
//! seen in the mirror and in the glossy lobes read the backdrop after the exact shadows and bounce
//! light, so the settling frames must not keep reflections drawn from a backdrop that was not yet
//! exact (`compositor/settle.rs`).

mod common;

use common::*;
use depth_remap::{Camera, DepthTable};
use glam::{DMat4, DVec3, Vec3};
use std::sync::Arc;
use viewer::compositor::SETTLE_REFLECTION_PIXELS;
use viewer::{
    Backdrop, Compositor, CompositorSettings, LiveObjects, Material, Mesh, MeshInstance, SceneLayers, Sphere,
    ToneMap, ViewerScene,
};

const LEVEL: f32 = 0.5;
/// The frame's side: small, so that the test costs little on a software rasteriser.
const SIZE: u32 = 128;

/// The depth of the empty Cornell box (the cube [-1, 1]^3 open toward the eye) along each
/// pixel's centre ray, in the ray's parameter as `common::floor_point` reads it.
fn empty_box_depth(camera: &Camera) -> DepthTable {
    let world_from_camera = camera.world_from_camera();
    let mut values = Vec::with_capacity((SIZE * SIZE) as usize);
    for j in 0..SIZE {
        for i in 0..SIZE {
            let ray = camera.pixel_centre_ray(i, j);
            let o = world_from_camera.transform_point3(ray.origin);
            let d = world_from_camera.transform_point3(ray.origin + ray.direction) - o;
            let inside = |p: DVec3| p.abs().max_element() <= 1.0 + 1e-9;
            let hit = [(0, -1.0), (0, 1.0), (1, -1.0), (1, 1.0), (2, -1.0)]
                .into_iter()
                .filter(|&(axis, _)| d[axis] != 0.0)
                .map(|(axis, plane)| (plane - o[axis]) / d[axis])
                .filter(|&t| t > 0.0 && inside(o + d * t))
                .fold(f64::INFINITY, f64::min);
            values.push(hit as f32);
        }
    }
    DepthTable::new(SIZE, SIZE, values).unwrap()
}

/// The empty Cornell box at `SIZE`^2 over a flat backdrop of `LEVEL`, lit by the Cornell area
/// light (its layer holds the backdrop, soft shadows), in a uniform probe field: the walls and
/// ceiling matte (albedo 0.8, so the sphere sends them bounce light and the shadow's second
/// bounce is taken from them), the floor's left half plastic (albedo 0.5 and a Blinn lobe of Ks
/// 0.8, exponent 20) and its right half a mirror (reflectance 0.8, all its light reflected); with
/// `glossy_back_wall`, the back wall plastic as the floor's left half.
fn mirror_and_glossy_box(glossy_back_wall: bool) -> ViewerScene {
    let camera = cornell_camera_of_size(SIZE);
    let depth = empty_box_depth(&camera);
    let n = (SIZE * SIZE) as usize;
    let backdrop = Backdrop::from_linear(SIZE, SIZE, [LEVEL, LEVEL, LEVEL, 1.0].repeat(n), 1.0).unwrap();
    let mut s =
        ViewerScene::with_backdrop(camera, backdrop, depth, vec![cornell_light()], ToneMap::default())
            .unwrap();
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers =
        sidecar::LightLayers::new(SIZE, SIZE, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    let world_from_camera = s.camera().world_from_camera();
    for j in 0..SIZE {
        for i in 0..SIZE {
            let k = (j * SIZE + i) as usize;
            let Some(r) = s.depth().get(i, j).filter(|r| r.is_finite()) else { continue };
            let ray = s.camera().pixel_centre_ray(i, j);
            let p = world_from_camera.transform_point3(ray.origin + ray.direction * f64::from(r));
            let near = |a: f64, b: f64| (a - b).abs() < 1e-3;
            layers.normal[k] = match () {
                _ if near(p.y, 1.0) => [0.0, -1.0, 0.0],
                _ if near(p.x, -1.0) => [1.0, 0.0, 0.0],
                _ if near(p.x, 1.0) => [-1.0, 0.0, 0.0],
                _ if near(p.z, -1.0) => [0.0, 0.0, 1.0],
                _ => [0.0, 1.0, 0.0],
            };
            layers.light[0][k] = [LEVEL; 3];
            let plastic = if near(p.y, -1.0) { p.x < 0.0 } else { glossy_back_wall && near(p.z, -1.0) };
            if !near(p.y, -1.0) && !plastic {
                layers.albedo[k] = [0.8; 3];
            } else if plastic {
                layers.albedo[k] = [0.5; 3];
                layers.glossy[k] = [0.8; 3];
                layers.glossy_exponent[k] = [20.0; 3];
            } else {
                layers.light[0][k] = [0.0; 3];
                layers.reflectance[k] = [0.8; 3];
                layers.reflected[k] = [LEVEL; 3];
                layers.indirect[k] = [LEVEL; 3];
            }
        }
    }
    s.set_light_layers(SceneLayers {
        layers,
        layer_of_light: vec![Some(0)],
        area_samples: vec![cornell_emitter_samples()],
    })
    .unwrap();
    s.set_probes(uniform_probe([0.9; 3]));
    s
}

/// A white matte sphere over the middle of the floor, seen in the mirror and the glossy half.
fn sphere_at(centre: DVec3) -> LiveObjects {
    let material = Material { colour: Vec3::splat(0.8), ks: 0.0, ..Material::default() };
    LiveObjects { sphere: Some(Sphere { centre, radius: 0.3, material }), meshes: Vec::new() }
}

/// The pixels of two RGBA frames that differ, the largest difference of a channel, and the
/// relMSE `(x - r)^2 / (r^2 + 0.01)` of `image` against `reference` over all pixels.
fn difference(image: &[f32], reference: &[f32]) -> (usize, f32, f64) {
    let (mut pixels, mut largest, mut sum) = (0, 0.0f32, 0.0);
    for (a, b) in image.chunks(4).zip(reference.chunks(4)) {
        if a != b {
            pixels += 1;
        }
        for c in 0..3 {
            largest = largest.max((a[c] - b[c]).abs());
            let (x, t) = (f64::from(a[c]), f64::from(b[c]));
            sum += (x - t) * (x - t) / (t * t + 0.01);
        }
    }
    (pixels, largest, sum / (image.len() / 4 * 3) as f64)
}

/// Moves the cursor sphere of `live_at` (the live objects with the cursor sphere at a centre) to
/// `centre` over four frames, then renders frames at rest with `settle_at_rest`, and checks that
/// they settle into the frame a fresh compositor draws of the same inputs, bit for bit, within
/// 64 frames, and stay so, none of them further from it than the last moving frame was (relMSE
/// over the frame); the first frame that is exact.
fn settles_into_the_exact_frame(
    scene: &ViewerScene,
    centre: DVec3,
    live_at: impl Fn(DVec3) -> LiveObjects,
) -> usize {
    let settling =
        CompositorSettings { amortise_while_moving: true, settle_at_rest: true, ..Default::default() };
    let gpu = gpu();
    let mut fresh = Compositor::new(&gpu, scene, settling).unwrap();
    fresh.render(&live_at(centre)).unwrap();
    let exact = fresh.read_back_linear().unwrap().rgba;
    let mut c = Compositor::new(&gpu, scene, settling).unwrap();
    for step in [3.0, 2.0, 1.0, 0.0] {
        c.render(&live_at(centre + DVec3::new(0.04 * step, 0.0, 0.0))).unwrap();
    }
    let moving = c.read_back_linear().unwrap().rgba;
    let (pixels, _, moving_error) = difference(&moving, &exact);
    assert!(pixels > 100 && moving_error > 0.0, "the moving frame differs in {pixels} pixels only");
    let (mut errors, mut first_exact) = (Vec::new(), None);
    for frame in 1..=64 {
        if first_exact.is_some_and(|exact| frame > exact + 1) {
            break;
        }
        c.render(&live_at(centre)).unwrap();
        let image = c.read_back_linear().unwrap().rgba;
        let (pixels, largest, error) = difference(&image, &exact);
        errors.push(format!("{pixels} px, {largest:.2e}, {error:.2e}"));
        if pixels == 0 {
            first_exact.get_or_insert(frame);
        } else {
            assert!(first_exact.is_none(), "frame {frame} at rest differs after an exact one: {errors:?}");
            assert!(
                error <= moving_error * (1.0 + 1e-6),
                "frame {frame} at rest: relMSE {error:.3e}, the moving frame's {moving_error:.3e}"
            );
        }
    }
    eprintln!(
        "moving frame: relMSE {moving_error:.3e}; frames at rest (differing pixels, largest \
         difference, relMSE): {errors:?}"
    );
    let first_exact = first_exact
        .unwrap_or_else(|| panic!("the frames at rest never became the exact frame: {:?}", errors.last()));
    assert!(first_exact > 1, "the first frame at rest was drawn exactly, all of it");
    first_exact
}

/// The frame's rows with a glossy lobe or a mirror in `scene`: the specular pass's rectangle's.
fn reflecting_rows(scene: &ViewerScene) -> u32 {
    let layers = &scene.light_layers().expect("light layers").layers;
    let reflects = |k: usize| layers.glossy[k] != [0.0; 3] || layers.reflectance[k] != [0.0; 3];
    (0..SIZE).filter(|&j| (0..SIZE).any(|i| reflects((j * SIZE + i) as usize))).count() as u32
}

/// After the sphere moved over a mirror and a plastic floor, with `settle_at_rest`, the frames
/// at rest settle into the frame a fresh compositor draws of the same inputs, bit for bit, within
/// a bounded number of frames, and stay so; none of them is further from it than the last moving
/// frame was (relMSE over the frame). Before the settling frames drew the reflections again
/// from the exact backdrop, they kept the mirror's and the lobes' draws made from the first
/// settling frame's backdrop, whose bounce light was drawn in its first rows only, and the frame
/// never became exact. The glossy lobes settle in several bands of rows
/// (`SETTLE_REFLECTION_PIXELS`), each read from the mirror's complete draw.
#[test]
fn the_frames_at_rest_settle_into_the_exact_frame_with_mirror_and_glossy_reflections() {
    let scene = mirror_and_glossy_box(false);
    let band = SETTLE_REFLECTION_PIXELS / SIZE;
    let rows = reflecting_rows(&scene);
    assert!(rows > band, "the floor's {rows} rows are not two bands of {band}");
    settles_into_the_exact_frame(&scene, DVec3::new(0.05, -0.6, 0.1), sphere_at);
}

/// As above with the back wall glossy too, so that each sphere's glossy draw takes several
/// bands, and a second sphere on the floor (a live mesh drawn as an exact sphere): its glossy
/// draw reads the backdrop the first sphere's glossy draw left, complete, in each of its bands,
/// and the frame settles bit for bit into the exact one all the same.
#[test]
fn two_spheres_glossy_reflections_settle_band_by_band_into_the_exact_frame() {
    let scene = mirror_and_glossy_box(true);
    let band = SETTLE_REFLECTION_PIXELS / SIZE;
    let rows = reflecting_rows(&scene);
    assert!(rows > 3 * band, "the floor's and back wall's {rows} rows are not four bands of {band}");
    let (still, radius) = (DVec3::new(-0.55, -0.8, -0.2), 0.2);
    let mesh = MeshInstance {
        mesh: Arc::new(Mesh::unit_sphere(24, 48)),
        world_from_object: DMat4::from_translation(still) * DMat4::from_scale(DVec3::splat(radius)),
        material: Material { colour: Vec3::new(0.9, 0.3, 0.2), ks: 0.0, ..Material::default() },
        exact_sphere: Some((still, radius)),
    };
    let two_spheres = |centre| LiveObjects { meshes: vec![mesh.clone()], ..sphere_at(centre) };
    settles_into_the_exact_frame(&scene, DVec3::new(0.05, -0.6, 0.1), two_spheres);
}

/// The index of the glass sphere `with_glass_sphere` puts before the box's floor.
const GLASS_ETA: f64 = 1.5;

/// `scene` with a glass sphere `glass` in it as the renderer's transmission layers show one:
/// every pixel whose camera ray meets it transmits 0.8 along its exit ray (f64 refraction), all
/// its light (`LEVEL`) came through the glass, and it reflects nothing. Returns the scene and
/// each pixel's exit ray.
fn with_glass_sphere(
    mut scene: ViewerScene,
    glass: (DVec3, f64),
) -> (ViewerScene, Vec<Option<(DVec3, DVec3)>>) {
    let mut scene_layers = scene.light_layers().expect("light layers").clone();
    let layers = &mut scene_layers.layers;
    let mut exits = vec![None; (SIZE * SIZE) as usize];
    for (k, origin, dir) in world_pixel_rays(scene.camera(), SIZE, SIZE) {
        let Some((o, d)) = glass_exit_ray(origin, dir, glass, GLASS_ETA) else { continue };
        exits[k] = Some((o, d));
        layers.light[0][k] = [0.0; 3];
        layers.albedo[k] = [0.0; 3];
        layers.glossy[k] = [0.0; 3];
        layers.reflectance[k] = [0.0; 3];
        layers.reflected[k] = [0.0; 3];
        layers.transmittance[k] = [0.8; 3];
        layers.transmitted[k] = [LEVEL; 3];
        layers.indirect[k] = [LEVEL; 3];
        layers.transmission_origin[k] = o.as_vec3().to_array();
        layers.transmission_direction[k] = d.as_vec3().to_array();
        layers.transmission_distance[k] = [to_the_box_walls(o, d) as f32; 3];
    }
    scene.set_light_layers(scene_layers).unwrap();
    (scene, exits)
}

/// The mirror and plastic floor seen partly through a glass sphere before the live sphere: the
/// glass pixels show the live sphere along their exit rays, and the live objects' change where
/// the other exit rays meet the scene, read from the backdrop at other pixels
/// (`transmission.wgsl`). The frames at rest settle bit for bit into the exact frame all the
/// same, none of them further from it than the last moving frame. When the rows' steps drew the
/// glass, 25 glass pixels read the loss's removal in the rows finished before theirs and the
/// frame never became exact (largest difference 2.4e-3).
#[test]
fn a_sphere_seen_through_glass_settles_into_the_exact_frame() {
    let centre = DVec3::new(0.05, -0.6, 0.1);
    let (scene, exits) =
        with_glass_sphere(mirror_and_glossy_box(false), (DVec3::new(-0.15, -0.35, 0.75), 0.22));
    let through_glass = exits
        .iter()
        .flatten()
        .filter(|(o, d)| ray_sphere(*o, *d, centre, 0.3).is_some_and(|t| t < to_the_box_walls(*o, *d)))
        .count();
    assert!(through_glass > 100, "the live sphere is seen through the glass in {through_glass} pixels only");
    settles_into_the_exact_frame(&scene, centre, sphere_at);
}

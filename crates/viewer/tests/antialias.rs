//! Antialiased edges of live objects: each pixel near a live object holds the share of the
//! image's pixel filter its live samples cover, blended with the backdrop, as the ray tracer
//! filters its own objects' edges.

mod common;

use common::*;
use glam::{DVec2, DVec3, Vec3};
use viewer::pixel_filter::SAMPLE_POSITIONS;
use viewer::{
    CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, PixelFilter, Sphere, ViewerScene,
};

const COLOUR: Vec3 = Vec3::new(1.0, 0.5, 0.25);

/// A floating sphere, unlit, over the Cornell depth with a black image, composited with
/// `filter`; returns the scene, the sphere's camera-space centre, its radius and the linear
/// frame.
fn render(filter: PixelFilter, antialias: bool) -> (ViewerScene, DVec3, f64, Vec<f32>, Vec<u8>) {
    let mut scene = grey_cornell(vec![], 0);
    scene.set_pixel_filter(filter);
    let (centre, radius) = (DVec3::new(0.1, 0.05, 0.2), 0.31);
    let live = LiveObjects {
        sphere: Some(Sphere { centre, radius, material: Material::unlit(COLOUR) }),
        meshes: Vec::new(),
    };
    let gpu = gpu();
    let mut c = Compositor::new(
        &gpu,
        &scene,
        CompositorSettings {
            mode: CompositeMode::Fullscreen,
            shadows: None,
            antialias,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(c.antialias_off().is_none(), antialias, "{:?}", c.antialias_off());
    c.render(&live).unwrap();
    let linear = c.read_back_linear().unwrap().rgba;
    let mask = c.read_back().unwrap().mask;
    let centre_camera = scene.camera().camera_from_world().transform_point3(centre);
    (scene, centre_camera, radius, linear, mask)
}

/// Whether the ray through `raster` hits the sphere in front of the pre-rendered surface of
/// the pixel it lies in.
fn live_at(scene: &ViewerScene, centre: DVec3, radius: f64, raster: DVec2) -> bool {
    let ray = scene.camera().ray_through_raster(raster);
    let (i, j) = (raster.x.floor() as u32, raster.y.floor() as u32);
    let depth = f64::from(scene.depth().get(i, j).unwrap());
    ray_sphere(ray.origin, ray.direction, centre, radius).is_some_and(|t| t < depth)
}

/// The filter's live share at pixel `(i, j)` over the four standard samples of each pixel in
/// its reach (what the compositor computes), in f64.
fn sampled_share(
    scene: &ViewerScene,
    filter: &PixelFilter,
    centre: DVec3,
    radius: f64,
    i: u32,
    j: u32,
) -> f64 {
    let (w, h) = scene.size();
    let (mx, my) = filter.pixel_margin();
    let (mut total, mut live) = (0.0, 0.0);
    for dy in -(my as i64)..=my as i64 {
        for dx in -(mx as i64)..=mx as i64 {
            let (x, y) = (i64::from(i) + dx, i64::from(j) + dy);
            if x < 0 || y < 0 || x >= i64::from(w) || y >= i64::from(h) {
                continue;
            }
            for [sx, sy] in SAMPLE_POSITIONS {
                let offset = (dx as f32 + sx - 0.5, dy as f32 + sy - 0.5);
                let weight = f64::from(filter.weight(offset.0, offset.1));
                total += weight;
                let raster = DVec2::new(x as f64 + f64::from(sx), y as f64 + f64::from(sy));
                if weight != 0.0 && live_at(scene, centre, radius, raster) {
                    live += weight;
                }
            }
        }
    }
    live / total
}

/// The exact share of a pixel the sphere covers, by 32x32 stratified rays.
fn covered_area(scene: &ViewerScene, centre: DVec3, radius: f64, i: u32, j: u32) -> f64 {
    let n = 32;
    let hits = (0..n * n)
        .filter(|k| {
            let raster = DVec2::new(
                f64::from(i) + (f64::from(k % n) + 0.5) / f64::from(n),
                f64::from(j) + (f64::from(k / n) + 0.5) / f64::from(n),
            );
            live_at(scene, centre, radius, raster)
        })
        .count();
    hits as f64 / f64::from(n * n)
}

/// With a box filter each pixel holds the sphere's colour times the share of its four samples
/// the sphere covers; that share is closer to the pixel's true coverage than the centre sample
/// alone, by at least 40% in mean absolute error over the silhouette's pixels.
#[test]
fn a_box_filter_gives_each_edge_pixel_its_sampled_coverage() {
    let filter = PixelFilter::BOX;
    let near = PixelFilter::from_rib("box", 3.0, 3.0).unwrap();
    let (scene, centre, radius, linear, mask) = render(filter, true);
    let (w, h) = scene.size();
    let (mut edge, mut wrong, mut error_aa, mut error_centre) = (0, 0, 0.0, 0.0);
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            let share = sampled_share(&scene, &filter, centre, radius, i, j);
            for ch in 0..3 {
                let want = share as f32 * COLOUR[ch];
                // Half-float samples, and a sample grazing the silhouette may fall either way.
                if (linear[4 * k + ch] - want).abs() > 2e-3 {
                    wrong += 1;
                }
            }
            // Only pixels within a pixel of a sample on each side can be partly covered.
            let wide = sampled_share(&scene, &near, centre, radius, i, j);
            if wide == 0.0 || wide == 1.0 {
                continue;
            }
            let area = covered_area(&scene, centre, radius, i, j);
            if area > 0.0 && area < 1.0 {
                edge += 1;
                let got = f64::from(linear[4 * k]) / f64::from(COLOUR.x);
                error_aa += (got - area).abs();
                error_centre += (if mask[k] == 255 { 1.0 } else { 0.0 } - area).abs();
            }
        }
    }
    eprintln!("{edge} edge pixels; coverage error: antialiased {error_aa}, centre only {error_centre}");
    assert!(edge > 300, "edge pixels {edge}");
    assert!(wrong * 100 <= edge, "{wrong} channels of {edge} edge pixels off the sampled share");
    assert!(
        error_aa < 0.6 * error_centre,
        "coverage error: antialiased {error_aa}, centre only {error_centre}"
    );
}

/// RenderMan's default filter (gaussian 2 2) reaches a pixel's neighbours: the sphere's colour
/// spreads a pixel beyond its samples, by the filter's weights, and pixels out of reach keep the
/// image's value exactly.
#[test]
fn a_gaussian_filter_spreads_the_edge_by_its_weights() {
    let filter = PixelFilter::RENDERMAN_DEFAULT;
    let (scene, centre, radius, linear, _) = render(filter, true);
    let (w, h) = scene.size();
    let (mut spread, mut wrong, mut checked) = (0, 0, 0);
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            let share = sampled_share(&scene, &filter, centre, radius, i, j);
            let own = sampled_share(&scene, &PixelFilter::BOX, centre, radius, i, j);
            if share == 0.0 {
                assert_eq!(&linear[4 * k..4 * k + 3], &[0.0; 3], "pixel ({i}, {j}) out of reach");
                continue;
            }
            checked += 1;
            spread += usize::from(own == 0.0);
            let want = share as f32 * COLOUR.x;
            wrong += usize::from((linear[4 * k] - want).abs() > 2e-3);
        }
    }
    assert!(spread > 150, "pixels reached through the filter alone: {spread}");
    assert!(wrong * 100 <= checked, "{wrong} of {checked} pixels off the filtered share");
}

/// Turned off, every pixel is its centre sample: the sphere's colour inside its mask, the image
/// outside.
#[test]
fn without_antialiasing_pixels_are_centre_samples() {
    let (_, _, _, linear, mask) = render(PixelFilter::RENDERMAN_DEFAULT, false);
    for (k, &m) in mask.iter().enumerate() {
        let want = if m == 255 { COLOUR.to_array() } else { [0.0; 3] };
        assert_eq!(&linear[4 * k..4 * k + 3], &want, "pixel {k}");
    }
}

/// Antialiasing touches only the pixels near live objects, and keeps nothing of an earlier
/// frame: a sphere that moved gives, bit for bit, the frame a fresh compositor draws with it
/// there (lit, shadowing and seeing its own shadow), and with it gone the frame is the image.
#[test]
fn a_frame_after_a_move_equals_a_fresh_one() {
    let light = DVec3::new(-0.2, 0.9, 0.1);
    let mut scene = layered_cornell(light, false, 0.5);
    scene.set_probes(uniform_probe([1.0; 3]));
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let sphere_at = |centre: DVec3| LiveObjects {
        sphere: Some(Sphere { centre, radius: 0.25, material }),
        meshes: Vec::new(),
    };
    let gpu = gpu();
    let settings = CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() };
    let mut moving = Compositor::new(&gpu, &scene, settings).unwrap();
    assert!(moving.antialias_off().is_none(), "{:?}", moving.antialias_off());
    moving.render(&sphere_at(DVec3::new(-0.2, -0.55, 0.1))).unwrap();
    let image = {
        let mut empty = Compositor::new(&gpu, &scene, settings).unwrap();
        empty.render(&LiveObjects::default()).unwrap();
        empty.read_back_linear().unwrap().rgba
    };
    let there = sphere_at(DVec3::new(0.3, -0.3, -0.2));
    moving.render(&there).unwrap();
    let mut fresh = Compositor::new(&gpu, &scene, settings).unwrap();
    fresh.render(&there).unwrap();
    let (got, want) = (moving.read_back_linear().unwrap().rgba, fresh.read_back_linear().unwrap().rgba);
    assert_ne!(want, image, "the sphere is in view");
    let differing = got.iter().zip(&want).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differing, 0, "{differing} channels differ from a fresh compositor's frame");
    moving.render(&LiveObjects::default()).unwrap();
    let gone = moving.read_back_linear().unwrap().rgba;
    assert!(gone.iter().zip(&image).all(|(a, b)| a.to_bits() == b.to_bits()), "the sphere left a trace");
}

/// A live sphere drawn as a mesh (as `--live` draws RIB spheres) is covered as the exact
/// sphere, as the cursor sphere is: their antialiased frames agree but where the tessellated
/// silhouette and the sphere's differ at a pixel centre.
#[test]
fn a_mesh_sphere_s_edges_are_the_exact_sphere_s() {
    let mut scene = grey_cornell(vec![], 0);
    scene.set_pixel_filter(PixelFilter::from_rib("gaussian", 2.0, 2.0).unwrap());
    let (centre, radius) = (DVec3::new(0.1, 0.05, 0.2), 0.31);
    let material = Material::unlit(COLOUR);
    let cursor = LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() };
    let mesh = LiveObjects {
        sphere: None,
        meshes: vec![viewer::MeshInstance {
            mesh: std::sync::Arc::new(viewer::Mesh::unit_sphere(48, 96)),
            world_from_object: glam::DMat4::from_translation(centre)
                * glam::DMat4::from_scale(DVec3::splat(radius)),
            material,
            exact_sphere: Some((centre, radius)),
        }],
    };
    let gpu = gpu();
    let settings =
        CompositorSettings { mode: CompositeMode::Fullscreen, shadows: None, ..Default::default() };
    let frame = |live: &LiveObjects| {
        let mut c = Compositor::new(&gpu, &scene, settings).unwrap();
        c.render(live).unwrap();
        (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
    };
    let ((a, a_mask), (b, b_mask)) = (frame(&cursor), frame(&mesh));
    let centres_differ = a_mask.iter().zip(&b_mask).filter(|(x, y)| x != y).count();
    let (mut edge, mut differ) = (0, 0);
    for k in 0..a_mask.len() {
        let (x, y) = (&a[4 * k..4 * k + 3], &b[4 * k..4 * k + 3]);
        let partial = x.iter().any(|&v| v > 0.0 && v < 0.999 * COLOUR.x.max(COLOUR.y).max(COLOUR.z));
        edge += usize::from(partial && a_mask[k] == 0);
        differ += usize::from(x.iter().zip(y).any(|(p, q)| (p - q).abs() > 1e-3));
    }
    eprintln!("{edge} edge pixels, {differ} differ, {centres_differ} centre samples differ");
    assert!(edge > 200, "{edge} edge pixels");
    assert!(differ <= centres_differ, "{differ} pixels differ ({centres_differ} centres)");
}

/// The first hit of a camera-space ray with world triangles `tris` (f64), if any.
fn first_hit(scene: &ViewerScene, origin: DVec3, direction: DVec3, tris: &[[DVec3; 3]]) -> Option<f64> {
    let world = scene.camera().world_from_camera();
    let (o, d) = (world.transform_point3(origin), world.transform_vector3(direction));
    tris.iter()
        .filter_map(|t| {
            let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            let tv = o - t[0];
            let (u, qv) = (tv.dot(pv) / det, tv.cross(e1));
            let v = d.dot(qv) / det;
            let hit = e2.dot(qv) / det;
            (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && hit > 0.0).then_some(hit)
        })
        .reduce(f64::min)
}

/// Where the slanted edge of a pre-rendered board crosses pixels whose centre shows a live sphere
/// behind it, the samples the board hides show the board, not the sphere nor what lies behind
/// it: with a box filter each such pixel holds the sphere's colour for the samples that see it,
/// the board's (its neighbour's) for those the board hides, and the backdrop's for the rest.
/// Before the samples were traced through the scene's triangles, all of them counted as live.
#[test]
fn samples_behind_a_pre_rendered_edge_show_the_edge() {
    let (w, h) = (512u32, 512u32);
    let camera = cornell_camera();
    // A board at z = 0.6 in front of the sphere, its right edge slanting across it.
    let c = [
        DVec3::new(-1.0, -1.0, 0.6),
        DVec3::new(-0.1, -1.0, 0.6),
        DVec3::new(0.3, 1.0, 0.6),
        DVec3::new(-1.0, 1.0, 0.6),
    ];
    let board = vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]];
    let (board_colour, back_colour) = ([0.2f32, 0.6, 0.1], [0.5f32; 3]);
    let mut depth = Vec::with_capacity((w * h) as usize);
    let mut linear = Vec::with_capacity((4 * w * h) as usize);
    let probe = grey_cornell(vec![], 0);
    for j in 0..h {
        for i in 0..w {
            let ray = camera.pixel_centre_ray(i, j);
            // Behind the board, a wall at world z = -1 (camera-space z = 4.9).
            let (d, colour) = match first_hit(&probe, ray.origin, ray.direction, &board) {
                Some(t) => (t, board_colour),
                None => (4.9 / ray.direction.z, back_colour),
            };
            depth.push(d as f32);
            linear.extend_from_slice(&[colour[0], colour[1], colour[2], 1.0]);
        }
    }
    let backdrop = viewer::Backdrop::from_linear(w, h, linear, 1.0).unwrap();
    let table = depth_remap::DepthTable::new(w, h, depth).unwrap();
    let mut scene =
        ViewerScene::with_backdrop(camera, backdrop, table, vec![], viewer::ToneMap::default()).unwrap();
    scene.set_pixel_filter(PixelFilter::BOX);
    scene.set_occluders(viewer::occluders::SceneOccluders { triangles: board.clone() });
    let (centre_world, radius) = (DVec3::new(0.1, 0.0, 0.0), 0.3);
    let live = LiveObjects {
        sphere: Some(Sphere { centre: centre_world, radius, material: Material::unlit(COLOUR) }),
        meshes: Vec::new(),
    };
    let settings =
        CompositorSettings { mode: CompositeMode::Fullscreen, shadows: None, ..Default::default() };
    let mut c = Compositor::new(&gpu(), &scene, settings).unwrap();
    c.render(&live).unwrap();
    let (got, mask) = (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask);
    let centre = scene.camera().camera_from_world().transform_point3(centre_world);
    let (mut partly_hidden, mut checked, mut wrong) = (0, 0, 0);
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            if mask[k] != 255 {
                continue;
            }
            let mut want = [0.0f32; 3];
            let mut hidden = 0;
            for [sx, sy] in SAMPLE_POSITIONS {
                let ray = scene.camera().ray_through_raster(DVec2::new(
                    f64::from(i) + f64::from(sx),
                    f64::from(j) + f64::from(sy),
                ));
                let sphere = ray_sphere(ray.origin, ray.direction, centre, radius);
                let wall = first_hit(&scene, ray.origin, ray.direction, &board);
                let colour = match (sphere, wall) {
                    (Some(s), Some(b)) if b < s => {
                        hidden += 1;
                        board_colour
                    }
                    (Some(_), _) => COLOUR.to_array(),
                    (None, _) => back_colour,
                };
                for ch in 0..3 {
                    want[ch] += 0.25 * colour[ch];
                }
            }
            checked += 1;
            partly_hidden += usize::from(hidden > 0);
            wrong += usize::from((0..3).any(|ch| (got[4 * k + ch] - want[ch]).abs() > 2e-3));
        }
    }
    eprintln!("{checked} live pixels, {partly_hidden} partly behind the board, {wrong} off");
    assert!(partly_hidden > 30, "pixels partly behind the board: {partly_hidden}");
    assert!(wrong * 100 <= partly_hidden, "{wrong} pixels off the sampled colours");
}

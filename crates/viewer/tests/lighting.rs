//! GPU tests of the live objects' shading (the RIB's lights in physical units), the sphere's
//! shadow on the pre-rendered scene, and live meshes.

mod common;

use common::*;
use glam::{DMat4, DVec2, DVec3, Vec3};
use std::sync::Arc;
use viewer::{
    CompositeMode, Compositor, CompositorSettings, FrameReadback, LiveLight, LiveObjects, Material, Mesh,
    MeshInstance, ShadowSettings, Sphere, ViewerScene,
};

fn render(scene: &ViewerScene, live: &LiveObjects, shadows: Option<ShadowSettings>) -> FrameReadback {
    let gpu = gpu();
    let settings =
        CompositorSettings { mode: CompositeMode::Fullscreen, shadows, ..CompositorSettings::default() };
    let mut c = Compositor::new(&gpu, scene, settings).unwrap();
    c.render(live).unwrap();
    c.read_back().unwrap()
}

fn sphere(centre: DVec3, radius: f64, material: Material) -> LiveObjects {
    LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() }
}

fn luminance(frame: &FrameReadback, k: usize) -> u32 {
    frame.colour.pixels[4 * k..4 * k + 3].iter().map(|&b| u32::from(b)).sum()
}

/// The brightest sphere pixel (raster centre).
fn brightest(frame: &FrameReadback) -> DVec2 {
    let w = frame.colour.width as usize;
    let k =
        (0..frame.mask.len()).filter(|&k| frame.mask[k] == 255).max_by_key(|&k| luminance(frame, k)).unwrap();
    DVec2::new((k % w) as f64 + 0.5, (k / w) as f64 + 0.5)
}

/// Where a sharp highlight must be: the sphere point whose normal bisects the directions to the
/// light and to the eye.
fn highlight_point(centre: DVec3, radius: f64, light: DVec3, eye: DVec3) -> DVec3 {
    let mut n = ((light - centre).normalize() + (eye - centre).normalize()).normalize();
    for _ in 0..100 {
        let p = centre + n * radius;
        n = ((light - p).normalize() + (eye - p).normalize()).normalize();
    }
    centre + n * radius
}

/// A sharp, dim highlight (its peak stays below 1 so it does not saturate into a plateau).
fn shiny() -> Material {
    Material { colour: Vec3::ONE, ka: 0.0, kd: 0.0, ks: 0.02, roughness: 0.002, ..Material::default() }
}

/// A sharp highlight sits where the light is: for a point light and for the Cornell area light
/// (its representative point at the emitter's centroid).
#[test]
fn highlights_sit_where_the_lights_are() {
    let eye = DVec3::new(0.0, 0.0, 3.9);
    let (centre, radius) = (DVec3::new(0.1, -0.1, 0.2), 0.3);
    let point = DVec3::new(0.7, 0.8, 0.6);
    let cases = [
        ("point light", LiveLight::Point { position: point, colour: Vec3::splat(2.0) }, point),
        ("area light", cornell_light(), DVec3::new(0.0, 0.99, 0.01)),
    ];
    for (what, light, at) in cases {
        let scene = grey_cornell(vec![light], 100);
        let frame = render(&scene, &sphere(centre, radius, shiny()), None);
        let expected = raster_of(scene.camera(), highlight_point(centre, radius, at, eye));
        let got = brightest(&frame);
        eprintln!("{what}: highlight at {got}, expected {expected}");
        assert!((got - expected).length() <= 1.5, "{what}: highlight at {got}, expected at {expected}");
    }
}

/// Lambertian shading in physical units: a white sphere facing a point light at the eye has
/// radiance `I / (pi d^2)` at the pixel nearest the eye.
#[test]
fn lambert_shading_has_physical_units() {
    let eye = DVec3::new(0.0, 0.0, 3.9);
    let (centre, radius) = (DVec3::new(0.0, 0.0, 0.5), 0.4);
    let d = 3.9 - 0.9;
    let intensity = 0.5 * std::f32::consts::PI * (d * d) as f32;
    let scene = grey_cornell(vec![LiveLight::Point { position: eye, colour: Vec3::splat(intensity) }], 0);
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let frame = render(&scene, &sphere(centre, radius, material), None);
    // The image centre (256, 256) sees the sphere's nearest point head-on (pixel centres are
    // half a pixel off, so the cosine there is 1 - 1e-6).
    let k = 256 * 512 + 256;
    let value = frame.colour.pixels[4 * k];
    assert!((i32::from(value) - 128).abs() <= 1, "expected 0.5 -> 128, got {value}");
}

/// A spot light lights what is inside its cone and not what is outside; a distant light lights
/// the side of the sphere that faces it.
#[test]
fn spot_and_distant_lights() {
    let spot = LiveLight::Spot {
        position: DVec3::new(0.0, 0.95, 0.3),
        axis: DVec3::NEG_Y,
        colour: Vec3::splat(3.0),
        cone_angle: 20f32.to_radians(),
        cone_delta_angle: 5f32.to_radians(),
        beam_distribution: 2.0,
    };
    let matte = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let scene = grey_cornell(vec![spot], 0);
    let inside = render(&scene, &sphere(DVec3::new(0.0, -0.3, 0.3), 0.2, matte), None);
    let outside = render(&scene, &sphere(DVec3::new(0.7, -0.3, 0.3), 0.2, matte), None);
    let max =
        |f: &FrameReadback| (0..f.mask.len()).filter(|&k| f.mask[k] == 255).map(|k| luminance(f, k)).max();
    assert!(max(&inside).unwrap() > 200, "the sphere inside the cone is lit");
    assert_eq!(max(&outside).unwrap(), 0, "the sphere outside the cone is dark");

    // Light travelling towards +x (image right) lights the sphere's left half.
    let scene = grey_cornell(vec![LiveLight::Distant { direction: DVec3::X, colour: Vec3::splat(2.0) }], 0);
    let frame = render(&scene, &sphere(DVec3::new(0.0, 0.0, 0.3), 0.3, matte), None);
    let centre = raster_of(scene.camera(), DVec3::new(0.0, 0.0, 0.3));
    let (mut left, mut right) = (0u64, 0u64);
    for k in (0..frame.mask.len()).filter(|&k| frame.mask[k] == 255) {
        let x = (k % 512) as f64 + 0.5;
        if x < centre.x - 2.0 {
            left += u64::from(luminance(&frame, k));
        } else if x > centre.x + 2.0 {
            right += u64::from(luminance(&frame, k));
        }
    }
    assert!(left > 0 && right == 0, "left {left}, right {right}");
}

/// The sphere's shadow from the Cornell area light darkens the floor below it by the full
/// strength at its centre, leaves the rest of the image untouched, and disappears when shadows
/// are off.
#[test]
fn sphere_casts_a_shadow_on_the_pre_rendered_floor() {
    let scene = grey_cornell(vec![cornell_light()], 200);
    let (centre, radius) = (DVec3::new(-0.3, -0.3, 0.5), 0.15);
    let live = sphere(centre, radius, Material::default());
    let strength = 0.6;
    let frame = render(&scene, &live, Some(ShadowSettings { strength, light: None }));
    // The shadow's centre on the floor: from the light's centroid through the sphere's centre.
    let light = DVec3::new(0.0, 0.99, 0.01);
    let dir = centre - light;
    let floor = light + dir * ((-1.0 - light.y) / dir.y);
    let r = raster_of(scene.camera(), floor);
    let k = r.y as usize * 512 + r.x as usize;
    let expected = (200.0 * (1.0 - strength)).round() as i32;
    assert_eq!(frame.mask[k], 0, "the shadow centre is not hidden by the sphere");
    let got = i32::from(frame.colour.pixels[4 * k]);
    assert!((got - expected).abs() <= 2, "umbra: expected {expected}, got {got}");
    // Far from the shadow (the top-left of the back wall) nothing changes.
    let far = raster_of(scene.camera(), DVec3::new(-0.8, 0.8, -1.0));
    let kf = far.y as usize * 512 + far.x as usize;
    assert_eq!(frame.colour.pixels[4 * kf], 200);
    let darkened =
        (0..frame.mask.len()).filter(|&k| frame.mask[k] == 0 && frame.colour.pixels[4 * k] < 200).count();
    assert!(darkened > 100, "a visible shadow ({darkened} pixels)");

    let plain = render(&scene, &live, None);
    // Away from the sphere's antialiased edge (pixels next to its mask), nothing changes.
    assert!(
        (0..plain.mask.len())
            .filter(|&k| !next_to_mask(&plain.mask, 512, k))
            .all(|k| plain.colour.pixels[4 * k] == 200)
    );
}

/// A live mesh (a box) pushed half through the back wall: its visible part matches the analytic
/// ray-box test against the depth table.
#[test]
fn live_mesh_is_occluded_by_the_wall() {
    let scene = grey_cornell(vec![cornell_light()], 100);
    let half = Vec3::new(0.2, 0.15, 0.3);
    let position = DVec3::new(0.3, 0.4, -1.0);
    let world_from_object = DMat4::from_translation(position) * DMat4::from_rotation_y(0.4);
    let live = LiveObjects {
        sphere: None,
        meshes: vec![MeshInstance {
            mesh: Arc::new(Mesh::cuboid(half)),
            world_from_object,
            material: Material::unlit(Vec3::new(1.0, 0.0, 0.0)),
            exact_sphere: None,
        }],
    };
    let frame = render(&scene, &live, None);
    let camera = scene.camera();
    let object_from_world = world_from_object.inverse();
    let world_from_camera = camera.world_from_camera();
    let (mut both, mut either, mut mismatch) = (0, 0, 0);
    for j in 0..512u32 {
        for i in 0..512u32 {
            let ray = camera.pixel_centre_ray(i, j);
            let o = object_from_world.transform_point3(world_from_camera.transform_point3(ray.origin));
            let d = object_from_world.transform_vector3(world_from_camera.transform_vector3(ray.direction));
            // Slab test in object space (t stays a world distance: rigid transforms).
            let h = half.as_dvec3();
            let t1 = (-h - o) / d;
            let t2 = (h - o) / d;
            let near = t1.min(t2).max_element();
            let far = t1.max(t2).min_element();
            let k = (j * 512 + i) as usize;
            let depth = f64::from(scene.depth().values()[k]);
            let truth = near <= far && far > 0.0 && near < depth;
            let got = frame.mask[k] == 255;
            both += usize::from(truth && got);
            either += usize::from(truth || got);
            mismatch += usize::from(truth != got);
        }
    }
    let iou = both as f64 / either as f64;
    eprintln!("mesh: IoU {iou}, {mismatch} mismatches of {either}");
    assert!(either > 500);
    assert!(iou >= 0.99, "IoU {iou}");
}

/// A spot light's sharp cone edge crossing a live sphere: each pixel along the edge holds the
/// share of its area the cone lights, as the ray tracer's box filter averages its samples over
/// the pixel, not the value at the pixel's centre (lit or dark). Checked against the box mean of
/// 16 x 16 rays per pixel computed here.
#[test]
fn a_cone_edge_is_averaged_over_each_pixel() {
    let (position, axis) = (DVec3::new(0.0, 0.95, 0.3), DVec3::NEG_Y);
    let (cone, intensity) = (20f64.to_radians(), 3.0f64);
    let spot = LiveLight::Spot {
        position,
        axis,
        colour: Vec3::splat(intensity as f32),
        cone_angle: cone as f32,
        cone_delta_angle: 1e-4,
        beam_distribution: 0.0,
    };
    let matte = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let (centre, radius) = (DVec3::new(0.35, -0.3, 0.3), 0.25);
    let scene = grey_cornell(vec![spot], 0);
    let gpu = gpu();
    let mut compositor = Compositor::new(&gpu, &scene, CompositorSettings::default()).unwrap();
    compositor.render(&sphere(centre, radius, matte)).unwrap();
    let frame = compositor.read_back_linear().unwrap();

    // The Lambertian radiance at world point p on the sphere, inside the cone or not.
    let radiance = |p: DVec3| {
        let to_light = position - p;
        let l = to_light.normalize();
        let inside = (-l).dot(axis) >= cone.cos();
        let n_dot_l = ((p - centre) / radius).dot(l).max(0.0);
        if inside { intensity / to_light.length_squared() * n_dot_l / std::f64::consts::PI } else { 0.0 }
    };
    let camera = scene.camera();
    let world_from_camera = camera.camera_from_world().inverse();
    let (width, height) = (frame.width as usize, frame.height as usize);
    let (mut edge_pixels, mut worst) = (0, 0.0f64);
    for j in 0..height {
        for i in 0..width {
            // The box mean over 16 x 16 rays; pixels the sphere covers only in part are left to
            // the antialiasing tests.
            let mut values = Vec::with_capacity(256);
            for s in 0..256 {
                let at = DVec2::new(
                    i as f64 + (f64::from(s % 16) + 0.5) / 16.0,
                    j as f64 + (f64::from(s / 16) + 0.5) / 16.0,
                );
                let ray = camera.ray_through_raster(at);
                let origin = world_from_camera.transform_point3(ray.origin);
                let direction = world_from_camera.transform_vector3(ray.direction).normalize();
                match ray_sphere(origin, direction, centre, radius) {
                    Some(t) => values.push(radiance(origin + t * direction)),
                    None => break,
                }
            }
            if values.len() < 256 {
                continue;
            }
            let lit = values.iter().filter(|&&v| v > 0.0).count();
            if lit == 0 || lit == 256 {
                continue;
            }
            let mean = values.iter().sum::<f64>() / 256.0;
            let level = values.iter().cloned().fold(0.0, f64::max);
            let got = f64::from(frame.rgba[4 * (j * width + i)]);
            edge_pixels += 1;
            worst = worst.max((got - mean).abs() / level);
        }
    }
    eprintln!("{edge_pixels} pixels crossed by the cone's edge; worst error {worst:.3} of the lit level");
    assert!(edge_pixels >= 10, "the cone's edge crosses the sphere ({edge_pixels} pixels)");
    // Centre sampling is off by up to half the lit level there; 16 points by about 1/8.
    assert!(worst < 0.15, "edge pixels off by up to {worst:.3} of the lit level");
}

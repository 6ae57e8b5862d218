//! GPU tests of shadows with the renderer's light layers (docs/sidecar.md): a live sphere
//! removes exactly the occluded share of each light's own layer, and its occlusion of
//! indirect light near contact from the indirect layer. Checked against the same geometry in
//! f64 on the CPU over the Cornell box's exact depth table.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::{
    CompositeMode, Compositor, CompositorSettings, LiveLight, LiveObjects, Material, SceneLayers, Sphere,
    ViewerScene,
};

const LEVEL: f32 = 0.5;

fn scene(light: DVec3, indirect: bool) -> ViewerScene {
    layered_cornell(light, indirect, LEVEL)
}

fn sphere(centre: DVec3, radius: f64) -> LiveObjects {
    LiveObjects {
        sphere: Some(Sphere { centre, radius, material: Material::unlit(Vec3::new(0.0, 0.0, 1.0)) }),
        meshes: Vec::new(),
    }
}

fn hits(p: DVec3, to: DVec3, centre: DVec3, radius: f64) -> bool {
    let d = to - p;
    let len = d.length();
    ray_sphere(p, d / len, centre, radius).is_some_and(|t| t < len)
}

/// Point light: each floor pixel loses the share of `light.0` that the sphere hides over the
/// pixel's footprint (the f64 integral): all of it in the shadow, none outside, and the
/// footprint's share on the shadow's edge, which one ray through the pixel's centre cut into a
/// staircase (0.11 of 0.5 off on average there).
#[test]
fn a_point_light_layer_is_removed_where_the_sphere_hides_the_light_over_each_pixel() {
    let gpu = gpu();
    let light = DVec3::new(0.0, 0.9, 0.0);
    let (centre, radius) = (DVec3::new(-0.2, -0.4, 0.1), 0.25);
    let s = scene(light, false);
    let mut c = Compositor::new(
        &gpu,
        &s,
        CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() },
    )
    .unwrap();
    c.render(&sphere(centre, radius)).unwrap();
    let linear = c.read_back_linear().unwrap();
    let frame = c.read_back().unwrap();
    let shadow = footprint_shadow(&s, &linear.rgba, &frame.mask, LEVEL, |q| hits(q, light, centre, radius));
    assert_footprint_shadow(&shadow, LEVEL, 2000);
}

/// The indirect layer loses `(r / d)^2 cos` near the sphere (normals up on the floor), and
/// nothing far from it.
#[test]
fn indirect_light_is_occluded_near_contact() {
    let gpu = gpu();
    let (centre, radius) = (DVec3::new(0.3, -0.7, 0.2), 0.3);
    // The light is behind the sphere's shadow from nowhere: put it far below the floor so no
    // floor point sees it through the sphere (only the indirect layer matters here).
    let s = scene(DVec3::new(0.0, -50.0, 0.0), true);
    let mut c = Compositor::new(&gpu, &s, CompositorSettings::default()).unwrap();
    c.render(&sphere(centre, radius)).unwrap();
    let linear = c.read_back_linear().unwrap();
    let frame = c.read_back().unwrap();
    let mut checked = 0;
    for_each_backdrop_point(&s, &frame.mask, 3, Skip::Covered, |i, j, k, p| {
        if (p.y + 1.0).abs() > 1e-3 {
            return; // Floor pixels only: their normal is the layer's.
        }
        let to = centre - p;
        let d = to.length();
        let ao = if d > 6.0 * radius { 0.0 } else { (to.y / d).max(0.0) * (radius / d).powi(2) };
        if d > 6.0 * radius && d < 8.0 * radius {
            return; // The fade.
        }
        let expected = LEVEL as f64 * (1.0 - ao);
        let got = f64::from(linear.rgba[4 * k]);
        assert!((got - expected).abs() < 2e-3, "pixel ({i}, {j}) at d = {d:.3}: {got} vs {expected}");
        checked += 1;
    });
    assert!(checked > 1000, "checked {checked}");
}

/// Layers of the wrong size or bound to the wrong lights are refused.
#[test]
fn mismatched_layers_are_refused() {
    let mut s = scene(DVec3::Y, false);
    let small = sidecar::LightLayers::new(4, 4, 0, vec![sidecar::LightSource::new(0, "pointlight")]);
    let e = s.set_light_layers(SceneLayers {
        layers: small.clone(),
        layer_of_light: vec![Some(0)],
        area_samples: vec![vec![]],
    });
    assert!(e.unwrap_err().to_string().contains("4x4"));
    let (w, h) = s.size();
    let right = sidecar::LightLayers::new(w, h, 0, vec![sidecar::LightSource::new(0, "pointlight")]);
    let e = s.set_light_layers(SceneLayers {
        layers: right.clone(),
        layer_of_light: vec![Some(3)],
        area_samples: vec![vec![]],
    });
    assert!(e.is_err());
    let e = s.set_light_layers(SceneLayers { layers: right, layer_of_light: vec![], area_samples: vec![] });
    assert!(e.is_err());
}

/// An area light's layer loses the occluded share of the emitter as integrated over its
/// samples (`area cos_light cos_surface / d^2`), penumbra included; the cone test that skips
/// most pixels never skips one the sphere shadows.
#[test]
fn an_area_light_layer_loses_the_occluded_share_of_the_emitter() {
    let gpu = gpu();
    let (w, h) = (512u32, 512u32);
    let corners = [
        DVec3::new(-0.23, 0.99, -0.19),
        DVec3::new(0.23, 0.99, -0.19),
        DVec3::new(0.23, 0.99, 0.19),
        DVec3::new(-0.23, 0.99, 0.19),
    ];
    let triangles = [[corners[0], corners[1], corners[2]], [corners[0], corners[2], corners[3]]];
    let samples = viewer::light_layers::area_samples(&triangles, 64);
    assert!(samples.iter().all(|s| (s.normal - DVec3::NEG_Y).length() < 1e-9));
    let mut s = flat_cornell(LEVEL, vec![cornell_light()]);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers =
        sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    layers.light[0].iter_mut().for_each(|v| *v = [LEVEL; 3]);
    layers.normal.iter_mut().for_each(|v| *v = [0.0, 1.0, 0.0]);
    s.set_light_layers(SceneLayers {
        layers,
        layer_of_light: vec![Some(0)],
        area_samples: vec![samples.clone()],
    })
    .unwrap();
    let (centre, radius) = (DVec3::new(0.1, -0.5, 0.0), 0.25);
    let mut c = Compositor::new(&gpu, &s, CompositorSettings::default()).unwrap();
    c.render(&sphere(centre, radius)).unwrap();
    let linear = c.read_back_linear().unwrap();
    let frame = c.read_back().unwrap();
    let (mut penumbra, mut checked, mut off) = (0, 0, 0);
    for_each_backdrop_point(&s, &frame.mask, 2, Skip::Covered, |i, j, k, p| {
        if (p.y + 1.0).abs() > 1e-3 {
            return; // Floor pixels: their normal is the layer's.
        }
        let share = hidden_share(p, &samples, |p, to| hits(p, to, centre, radius));
        // The ambient-occlusion term of the (empty) indirect layer is zero.
        let expected = f64::from(LEVEL) * (1.0 - share);
        let got = f64::from(linear.rgba[4 * k]);
        penumbra += usize::from(share > 0.05 && share < 0.95);
        // One sample of 64 tested the other way at the sphere's silhouette moves the share
        // by about 1/64 of the light; anything else is an error.
        assert!((got - expected).abs() < 0.02, "pixel ({i}, {j}): {got} vs {expected} (share {share})");
        off += usize::from((got - expected).abs() > 1e-4);
        checked += 1;
    });
    assert!(checked > 5000 && penumbra > 100, "checked {checked}, penumbra {penumbra}");
    assert!(off * 100 <= checked, "{off} of {checked} pixels off by more than 1e-4");
}

/// With the layers' emitter samples, a live surface near an area light is lit by the light
/// integrated over them (`L A cos_e cos_l / d^2` per sample, as the ray tracer integrates it),
/// not by one representative point, which overestimates grazing light close to the emitter.
#[test]
fn an_area_light_lights_a_live_sphere_over_its_samples() {
    let gpu = gpu();
    let (w, h) = (512u32, 512u32);
    let samples = cornell_emitter_samples();
    let light = cornell_light();
    let LiveLight::Area { radiance, area, .. } = light else { unreachable!() };
    let mut s = flat_cornell(LEVEL, vec![light]);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let layers =
        sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    s.set_light_layers(SceneLayers {
        layers,
        layer_of_light: vec![Some(0)],
        area_samples: vec![samples.clone()],
    })
    .unwrap();
    let (centre, radius) = (DVec3::new(0.05, 0.55, 0.0), 0.2);
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live = LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() };
    let mut c = Compositor::new(&gpu, &s, CompositorSettings::default()).unwrap();
    c.render(&live).unwrap();
    let linear = c.read_back_linear().unwrap();
    let mask = c.read_back().unwrap().mask;
    let camera = s.camera();
    let total_area: f64 = samples.iter().map(|s| s.area).sum();
    let (mut checked, mut worst_point) = (0, 0.0f64);
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            if mask[k] != 255 {
                continue;
            }
            let ray = camera.pixel_centre_world_ray(i, j);
            let Some(t) = ray_sphere(ray.origin, ray.direction, centre, radius) else { continue };
            let p = ray.origin + t * ray.direction;
            let normal = (p - centre).normalize();
            if normal.dot(-ray.direction) < 0.15 {
                continue; // The silhouette, where rasterisation and the pixel centre may differ.
            }
            let mut e = 0.0;
            for sample in &samples {
                let v = sample.position - p;
                let d2 = v.length_squared();
                let l = v / d2.sqrt();
                e += sample.area * sample.normal.dot(-l).max(0.0) * normal.dot(l).max(0.0) / d2;
            }
            let want = f64::from(radiance.x) * area / total_area * e / std::f64::consts::PI;
            let got = f64::from(linear.rgba[4 * k]);
            assert!((got - want).abs() <= 2e-3 * want + 1e-5, "pixel ({i}, {j}): {got} vs {want}");
            // What the representative point would give, to show the test tells them apart.
            let v = DVec3::new(0.0, 0.99, 0.01) - p;
            let d2 = v.length_squared();
            let l = v / d2.sqrt();
            let point = f64::from(radiance.x) * area * (-l.y).max(0.0) * normal.dot(l).max(0.0)
                / d2
                / std::f64::consts::PI;
            worst_point = worst_point.max((point - want).abs() / want.max(1e-3));
            checked += 1;
        }
    }
    assert!(checked > 1000, "checked {checked}");
    assert!(worst_point > 0.05, "the representative point is within {worst_point} everywhere");
}

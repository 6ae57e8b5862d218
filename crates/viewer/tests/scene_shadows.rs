//! GPU tests of the scene's own shadows on live objects: with the scene's triangles bound
//! (`ViewerScene::set_occluders`), a live surface point gets a light's direct light only where
//! no scene triangle lies between it and the light. Checked against the same triangles in f64.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::occluders::SceneOccluders;
use viewer::{Compositor, CompositorSettings, LiveLight, LiveObjects, Material, Sphere, ViewerScene};

/// A white matte surface lit by the lights alone.
fn matte() -> Material {
    Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() }
}

/// A horizontal square at height `y` spanning x in [-1, x_edge], z in [-1, 1]: a shelf whose
/// edge runs over the sphere, so it shades part of it from a light above.
fn shelf(y: f64, x_edge: f64) -> Vec<[DVec3; 3]> {
    let c = [
        DVec3::new(-1.0, y, -1.0),
        DVec3::new(x_edge, y, -1.0),
        DVec3::new(x_edge, y, 1.0),
        DVec3::new(-1.0, y, 1.0),
    ];
    vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
}

fn crosses(p: DVec3, light: DVec3, tris: &[[DVec3; 3]]) -> bool {
    let d = light - p;
    let len = d.length();
    let dir = d / len;
    tris.iter().any(|t| {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let pv = dir.cross(e2);
        let det = e1.dot(pv);
        let tv = p - t[0];
        let (u, qv) = (tv.dot(pv) / det, tv.cross(e1));
        let v = dir.dot(qv) / det;
        let hit = e2.dot(qv) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && hit > 0.0 && hit < len
    })
}

/// Renders a matte sphere under a point light with `occluders` bound and returns, over the
/// sphere's interior pixels that face the light: (pixels the f64 test shadows, lit ones, and
/// pixels whose value disagrees: shadowed but lit, or lit but black).
fn shadowed_sphere(occluders: Option<Vec<[DVec3; 3]>>, tris: &[[DVec3; 3]]) -> (usize, usize, usize) {
    let gpu = gpu();
    let light = DVec3::new(0.0, 0.9, 0.0);
    let mut s: ViewerScene =
        cornell_scene(vec![LiveLight::Point { position: light, colour: Vec3::splat(1.0) }]);
    if let Some(triangles) = occluders {
        s.set_occluders(SceneOccluders { triangles });
    }
    let (centre, radius) = (DVec3::new(0.05, -0.45, 0.1), 0.3);
    let settings = CompositorSettings { shadows: None, ..Default::default() };
    let mut c = Compositor::new(&gpu, &s, settings).unwrap();
    c.render(&LiveObjects { sphere: Some(Sphere { centre, radius, material: matte() }), meshes: Vec::new() })
        .unwrap();
    let linear = c.read_back_linear().unwrap();
    let frame = c.read_back().unwrap();
    let camera = s.camera();
    let (mut shadowed, mut lit, mut wrong) = (0, 0, 0);
    for j in 0..512u32 {
        for i in 0..512u32 {
            let k = (j * 512 + i) as usize;
            if !inside_mask(&frame.mask, 512, k) {
                continue;
            }
            let ray = camera.pixel_centre_ray(i, j);
            let world = camera.world_from_camera();
            let (o, d) =
                (world.transform_point3(ray.origin), world.transform_vector3(ray.direction).normalize());
            let Some(t) = ray_sphere(o, d, centre, radius) else { continue };
            let p = o + d * t;
            let n = (p - centre) / radius;
            // Grazing light is too close to call in f32.
            if n.dot((light - p).normalize()) < 0.05 {
                continue;
            }
            let value = linear.rgba[4 * k];
            if crosses(p, light, tris) {
                shadowed += 1;
                wrong += usize::from(value > 1e-6);
            } else {
                lit += 1;
                wrong += usize::from(value < 1e-3);
            }
        }
    }
    (shadowed, lit, wrong)
}

#[test]
fn a_live_sphere_under_a_scene_shelf_gets_the_light_only_where_the_shelf_lets_it() {
    let tris = shelf(0.2, 0.0);
    let (shadowed, lit, wrong) = shadowed_sphere(Some(tris.clone()), &tris);
    assert!(shadowed > 1000 && lit > 1000, "shadowed {shadowed}, lit {lit}");
    // Only points whose ray to the light grazes the shelf's edge may fall on the other side.
    assert!(wrong * 100 <= shadowed, "{wrong} of {shadowed} + {lit} pixels wrong");
}

#[test]
fn without_the_scene_bound_the_sphere_is_lit_everywhere_it_faces_the_light() {
    let tris = shelf(0.2, 0.0);
    let (shadowed, _, wrong) = shadowed_sphere(None, &tris);
    // The pixels the shelf would shadow are all lit: the check above can fail.
    assert!(wrong >= shadowed && shadowed > 1000, "{wrong} of {shadowed}");
}

/// The Cornell box with its area light and light layers (which bring the emitter's samples).
fn area_lit_cornell(samples: &[viewer::AreaSample]) -> ViewerScene {
    let mut s = cornell_scene(vec![cornell_light()]);
    let (w, h) = s.size();
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers =
        sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    layers.normal.iter_mut().for_each(|v| *v = [0.0, 1.0, 0.0]);
    s.set_light_layers(viewer::SceneLayers {
        layers,
        layer_of_light: vec![Some(0)],
        area_samples: vec![samples.to_vec()],
    })
    .unwrap();
    s
}

/// Under an area light, each live pixel keeps the share of its unshadowed light
/// (`sum A cos_e cos_l / d^2` over the emitter's samples) whose rays miss the shelf: the
/// penumbra on the live object as the ray tracer integrates it, and the cone test that frees
/// most of each ray never frees a blocked one.
#[test]
fn under_an_area_light_a_live_sphere_keeps_the_share_of_the_emitter_the_shelf_lets_through() {
    let gpu = gpu();
    let samples = cornell_emitter_samples();
    let tris = shelf(0.2, 0.0);
    let (centre, radius) = (DVec3::new(0.05, -0.45, 0.1), 0.3);
    let live = LiveObjects { sphere: Some(Sphere { centre, radius, material: matte() }), meshes: Vec::new() };
    let frames: Vec<(Vec<f32>, Vec<u8>)> = [false, true]
        .iter()
        .map(|&bound| {
            let mut s = area_lit_cornell(&samples);
            if bound {
                s.set_occluders(SceneOccluders { triangles: tris.clone() });
            }
            // Shadows on: the compositor binds the layers (and the emitter's samples) for them.
            let mut c = Compositor::new(&gpu, &s, CompositorSettings::default()).unwrap();
            c.render(&live).unwrap();
            (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
        })
        .collect();
    let ((open, mask), (shaded, _)) = (&frames[0], &frames[1]);
    let s = area_lit_cornell(&samples);
    let camera = s.camera();
    let (mut penumbra, mut checked) = (0, 0);
    for j in (0..512u32).step_by(2) {
        for i in (0..512u32).step_by(2) {
            let k = (j * 512 + i) as usize;
            if !inside_mask(mask, 512, k) {
                continue;
            }
            let world = camera.world_from_camera();
            let ray = camera.pixel_centre_ray(i, j);
            let (o, d) =
                (world.transform_point3(ray.origin), world.transform_vector3(ray.direction).normalize());
            let Some(t) = ray_sphere(o, d, centre, radius) else { continue };
            let p = o + d * t;
            let n = (p - centre) / radius;
            let (mut total, mut visible) = (0.0, 0.0);
            for sample in &samples {
                let v = sample.position - p;
                let d2 = v.length_squared();
                let dir = v / d2.sqrt();
                let g = sample.area * sample.normal.dot(-dir).max(0.0) * n.dot(dir).max(0.0) / d2;
                total += g;
                if !crosses(p, sample.position, &tris) {
                    visible += g;
                }
            }
            if total <= 0.0 || open[4 * k] < 1e-4 {
                continue;
            }
            let share = visible / total;
            penumbra += usize::from(share > 0.05 && share < 0.95);
            let expected = f64::from(open[4 * k]) * share;
            let got = f64::from(shaded[4 * k]);
            // A sample or two on a grazing ray may fall on the other side in f32.
            assert!(
                (got - expected).abs() <= 0.035 * f64::from(open[4 * k]),
                "pixel ({i}, {j}): {got} vs {expected} (share {share})"
            );
            checked += 1;
        }
    }
    assert!(checked > 500 && penumbra > 100, "checked {checked}, penumbra {penumbra}");
}

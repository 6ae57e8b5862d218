//! GPU tests of glossy live surfaces lit by the renderer's reflection probes (docs/sidecar.md):
//! the shader's lookup agrees with `sidecar::ReflectionProbes::glossy_radiance`, the reference,
//! and reflects a field as the ray tracer's Blinn lobe does; lights' glossy reflection is that
//! lobe too.

mod common;

use common::*;
use glam::{DVec2, DVec3, Vec3};
use viewer::{
    CompositeMode, Compositor, CompositorSettings, LiveLight, LiveObjects, Material, Sphere, ViewerScene,
};

const CENTRE: DVec3 = DVec3::new(0.0, -0.2, 0.0);
const RADIUS: f64 = 0.3;

/// Probes along x at `xs` (one row), every one seeing radiance `field(direction)` and a
/// surface `distance` away in every direction, prefiltered by the sidecar's own code.
fn probes(xs: &[f32], distance: f32, field: impl Fn([f32; 3]) -> [f32; 3]) -> sidecar::ReflectionProbes {
    let n = sidecar::REFLECTION_TEXELS;
    let base: Vec<[f32; 3]> = (0..n * n).map(|t| field(sidecar::octahedral_texel_center(n, t))).collect();
    let levels = sidecar::reflection_levels(&base);
    let spacing = if xs.len() > 1 { xs[1] - xs[0] } else { 1.0 };
    sidecar::ReflectionProbes {
        depth_fingerprint: 0,
        origin: [xs[0], CENTRE.y as f32, CENTRE.z as f32],
        spacing: [spacing, 1.0, 1.0],
        counts: [xs.len() as u32, 1, 1],
        radiance: levels.iter().map(|level| level.repeat(xs.len())).collect(),
        distance: vec![distance; n * n * xs.len()],
        specular: Vec::new(),
    }
}

fn glossy(roughness: f32) -> Material {
    Material {
        colour: Vec3::ONE,
        ka: 0.0,
        kd: 0.0,
        ks: 1.0,
        roughness,
        specular_colour: Vec3::ONE,
        unlit: false,
    }
}

fn render(scene: &ViewerScene, material: Material) -> (Vec<f32>, Vec<u8>) {
    let gpu = gpu();
    let live =
        LiveObjects { sphere: Some(Sphere { centre: CENTRE, radius: RADIUS, material }), meshes: Vec::new() };
    let mut c = Compositor::new(
        &gpu,
        scene,
        CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() },
    )
    .unwrap();
    c.render(&live).unwrap();
    (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
}

/// The world-space hit point, unit normal and unit direction toward the eye of pixel `k`'s ray
/// on the sphere (`None` for a miss).
fn hit(scene: &ViewerScene, k: usize) -> Option<(DVec3, DVec3, DVec3)> {
    sphere_hit(scene, k, CENTRE, RADIUS)
}

/// Pixels inside the sphere whose normal faces the eye by more than `min_cos` (away from the
/// silhouette, where a pixel's centre and the GPU's rasterisation may disagree).
fn inside(scene: &ViewerScene, mask: &[u8], min_cos: f64) -> Vec<(usize, DVec3, DVec3, DVec3)> {
    (0..mask.len())
        .filter(|&k| mask[k] == 255)
        .filter_map(|k| hit(scene, k).map(|(p, n, v)| (k, p, n, v)))
        .filter(|(_, _, n, v)| n.dot(*v) > min_cos)
        .collect()
}

/// In a uniform field of radiance `l`, a glossy sphere (Ks 1, nothing else) shows `l` times
/// its lobe's directional albedo: the split sum's two factors.
#[test]
fn a_uniform_field_is_reflected_with_the_lobe_s_albedo() {
    let l = [0.4f32, 0.6, 0.8];
    let mut scene = cornell_scene(vec![]);
    scene.set_reflections(probes(&[0.0], 5.0, |_| l)).unwrap();
    let roughness = 0.1;
    let (rgba, mask) = render(&scene, glossy(roughness));
    let pixels = inside(&scene, &mask, 0.15);
    assert!(pixels.len() > 1000, "{} pixels", pixels.len());
    let exponent = sidecar::blinn_exponent(roughness);
    for (k, _, n, v) in pixels {
        let albedo = sidecar::blinn_albedo(exponent, n.dot(v) as f32);
        for c in 0..3 {
            let (got, want) = (rgba[4 * k + c], albedo * l[c]);
            assert!((got - want).abs() <= 0.01 * want, "pixel {k} channel {c}: {got} vs {want}");
        }
    }
}

/// With a field that varies with direction and two probes on either side of the sphere, the
/// GPU's lookup (the lobe's directions, parallax correction, probe weights, mip levels) gives
/// what the reference `ReflectionProbes::glossy_radiance` gives, pixel by pixel, at two
/// roughnesses.
#[test]
fn the_shader_s_lookup_matches_the_reference() {
    let field = |d: [f32; 3]| [0.5 + 0.5 * d[0], 0.5 + 0.5 * d[1], 1.0 + d[2] * d[2]];
    let reflections = probes(&[-0.6, 0.6], 1.5, field);
    let mut scene = cornell_scene(vec![]);
    scene.set_reflections(reflections.clone()).unwrap();
    for roughness in [0.02f32, 0.3] {
        let (rgba, mask) = render(&scene, glossy(roughness));
        let pixels = inside(&scene, &mask, 0.15);
        assert!(pixels.len() > 1000, "{} pixels", pixels.len());
        let exponent = sidecar::blinn_exponent(roughness);
        let mut worst = 0.0f32;
        for (k, p, n, v) in pixels {
            let [p, n32, v32] = [p, n, v].map(|x| x.as_vec3().to_array());
            let radiance = reflections.glossy_radiance(p, n32, v32, exponent);
            let albedo = sidecar::blinn_albedo(exponent, n.dot(v) as f32);
            for c in 0..3 {
                let (got, want) = (rgba[4 * k + c], albedo * radiance[c]);
                worst = worst.max((got - want).abs() / want);
            }
        }
        assert!(worst <= 0.02, "roughness {roughness}: worst relative difference {worst}");
    }
}

/// A wide lobe (RenderMan's default roughness 0.1) seen at a grazing angle leans toward the
/// normal and loses its part below the horizon: under a sky dark above and bright below (a lit
/// floor), the lower half of a glossy sphere reflects what lies below it. Against the ray
/// tracer's lobe integrated in f64 over the field itself, the lower half (normals pointing
/// down by more than 0.2) is within 4 % on average and 12 % at worst, and the whole sphere
/// within 12 % on average. The split sum (one lookup toward the mirror direction times the
/// lobe's albedo) fails it: 8 % on average and 37 % at worst on the lower half, 17 % on
/// average overall. What remains above the horizon is the prefiltered levels' own blur: the
/// bright half leaks into the dark one (docs/viewer-lighting.md, "With the renderer's reflection probes").
#[test]
fn a_wide_lobe_seen_at_a_grazing_angle_reflects_what_lies_below_it() {
    let field = |d: [f32; 3]| {
        let below = (-d[1]).max(0.0);
        [0.05 + below, 0.05 + 0.5 * below, 0.05 + 0.25 * below]
    };
    // One probe at the sphere's centre, the scene far away: no parallax to speak of.
    let mut scene = cornell_scene(vec![]);
    scene.set_reflections(probes(&[CENTRE.x as f32], 1000.0, field)).unwrap();
    let roughness = 0.1;
    let (rgba, mask) = render(&scene, glossy(roughness));
    let pixels = inside(&scene, &mask, 0.15);
    assert!(pixels.len() > 1000, "{} pixels", pixels.len());
    let exponent = f64::from(sidecar::blinn_exponent(roughness));
    // Relative differences summed (and the largest) over the lower half and over all pixels.
    let (mut lower, mut all) = ([0.0f64; 3], [0.0f64; 3]);
    for (k, _, n, v) in pixels {
        let want = lobe_integral(n, v, exponent, |l| field(l.as_vec3().to_array()).map(f64::from));
        for c in 0..3 {
            let error = (f64::from(rgba[4 * k + c]) - want[c]).abs() / want[c];
            all = [all[0] + error, all[1].max(error), all[2] + 1.0];
            if n.y < -0.2 {
                lower = [lower[0] + error, lower[1].max(error), lower[2] + 1.0];
            }
        }
    }
    let (lower_mean, all_mean) = (lower[0] / lower[2], all[0] / all[2]);
    assert!(lower[2] > 1000.0, "{} lower channels", lower[2]);
    assert!(
        lower_mean <= 0.04 && lower[1] <= 0.12 && all_mean <= 0.12,
        "lower half: mean relative difference {lower_mean}, worst {}; all: mean {all_mean}",
        lower[1]
    );
}

/// A point light's glossy reflection is the ray tracer's Blinn lobe (D with V-cavity shadowing
/// over 4 cos_o, no Fresnel) times the light's irradiance, computed here in f64 and averaged
/// over the pixel filter's footprint as the compositor averages a point light
/// (`viewer::pixel_filter::footprint`; the ray tracer's pixel is its filter's mean).
#[test]
fn a_point_light_s_highlight_is_the_ray_tracer_s_blinn_lobe() {
    let (position, intensity) = (DVec3::new(0.3, 0.8, -0.6), 3.0);
    let light = LiveLight::Point { position, colour: Vec3::splat(intensity as f32) };
    let scene = cornell_scene(vec![light]);
    let roughness = 0.2;
    let (rgba, mask) = render(&scene, glossy(roughness));
    let e = f64::from(sidecar::blinn_exponent(roughness));
    let blinn = |p: DVec3, n: DVec3, v: DVec3| {
        let to_light = position - p;
        let l = to_light.normalize();
        let h = (l + v).normalize();
        let (cos_h, cos_o, cos_l, o_dot_h) = (n.dot(h), n.dot(v), n.dot(l), v.dot(h));
        let value = if cos_l > 0.0 && cos_h > 0.0 {
            let d = (e + 2.0) / (2.0 * std::f64::consts::PI) * cos_h.powf(e);
            let g = (2.0 * cos_h * cos_o / o_dot_h).min(2.0 * cos_h * cos_l / o_dot_h).min(1.0);
            intensity / to_light.length_squared() * d * g / (4.0 * cos_o)
        } else {
            0.0
        };
        (value, cos_l)
    };
    let footprint = viewer::pixel_filter::footprint(&scene.pixel_filter());
    let camera = scene.camera();
    let (w, _) = scene.size();
    let (mut lit, mut relative, mut got_sum, mut want_sum) = (0, 0.0, 0.0, 0.0);
    'pixels: for (k, _, _, _) in inside(&scene, &mask, 0.15) {
        let (i, j) = (k as u32 % w, k as u32 / w);
        let mut want = 0.0;
        for [x, y, weight, _] in footprint {
            let raster = DVec2::new(f64::from(i) + 0.5 + f64::from(x), f64::from(j) + 0.5 + f64::from(y));
            let ray = camera.world_ray_through_raster(raster);
            let Some(t) = ray_sphere(ray.origin, ray.direction, CENTRE, RADIUS) else { continue 'pixels };
            let p = ray.origin + t * ray.direction;
            let (value, cos_l) = blinn(p, (p - CENTRE).normalize(), -ray.direction);
            // Points where the light grazes the surface are too close to call in f32.
            if cos_l.abs() < 1e-3 {
                continue 'pixels;
            }
            want += f64::from(weight) * value;
        }
        let got = f64::from(rgba[4 * k]);
        // The compositor's footprint is the surface to first order around the pixel centre's
        // hit; here it is the sphere itself, so single pixels differ by up to about 1 %.
        assert!((got - want).abs() <= 2e-2 * want + 5e-5, "pixel {k}: {got} vs {want}");
        if want > 1e-3 {
            lit += 1;
            relative += (got - want).abs() / want;
            (got_sum, want_sum) = (got_sum + got, want_sum + want);
        }
    }
    assert!(lit > 200, "{lit} highlight pixels");
    // A wrong lobe (its normalisation, its shadowing term, its exponent) moves every pixel.
    let mean = relative / lit as f64;
    assert!(mean <= 3e-3, "mean relative difference {mean}");
    assert!((got_sum / want_sum - 1.0).abs() <= 2e-3, "highlight's total {got_sum} vs {want_sum}");
}

/// The probes hold no emitted light (the bake leaves out the emitters it sees directly), so an
/// area light's glossy reflection comes from the light itself with or without probes: probes
/// that saw nothing change nothing, and the highlight is there.
#[test]
fn an_area_light_s_highlight_comes_from_the_light() {
    let light = LiveLight::Area {
        centroid: DVec3::new(0.0, 0.9, 0.0),
        normal: Some(DVec3::NEG_Y),
        two_sided: false,
        radiance: Vec3::splat(5.0),
        area: 0.1,
        radius: 0.18,
    };
    let without = cornell_scene(vec![light.clone()]);
    let (plain, mask) = render(&without, glossy(0.1));
    let lit = inside(&without, &mask, 0.15).iter().filter(|(k, ..)| plain[4 * k] > 1e-3).count();
    assert!(lit > 100, "the area light's highlight shows on {lit} pixels");
    let mut with = cornell_scene(vec![light]);
    with.set_reflections(probes(&[0.0], 5.0, |_| [0.0; 3])).unwrap();
    let (probed, probed_mask) = render(&with, glossy(0.1));
    assert_eq!(mask, probed_mask);
    for (k, ..) in inside(&with, &mask, 0.0) {
        for c in 0..3 {
            let (a, b) = (plain[4 * k + c], probed[4 * k + c]);
            assert!((a - b).abs() <= 1e-6 * a.max(1.0), "pixel {k}: {a} without probes, {b} with");
        }
    }
}

/// The scene refuses probes it cannot bind, naming why.
#[test]
fn unusable_probes_are_refused() {
    let mut scene = cornell_scene(vec![]);
    let mut bad = probes(&[0.0], 1.0, |_| [1.0; 3]);
    bad.distance.pop();
    assert!(scene.set_reflections(bad).unwrap_err().to_string().contains("do not match"));
    let mut many = probes(&[0.0], 1.0, |_| [1.0; 3]);
    many.counts = [300, 1, 1];
    assert!(scene.set_reflections(many).unwrap_err().to_string().contains("300 reflection probes"));
    assert!(scene.reflections().is_none());
}

/// The scene of the contact tests: a sphere resting on the Cornell box's floor (world `y = -1`),
/// away from both blocks.
const RESTING_CENTRE: DVec3 = DVec3::new(-0.55, -0.75, 0.4);
const RESTING_RADIUS: f64 = 0.25;
/// The floor's Lambertian albedo and the uniform indirect radiance the irradiance probes hold.
const FLOOR_ALBEDO: f64 = 0.6;
const INDIRECT_RADIANCE: f64 = 0.05;

/// Where unit direction `d` from `origin` (inside the box) leaves the box `[-1, 1]^3`: the
/// distance and whether it is the floor.
fn box_exit(origin: DVec3, d: DVec3) -> (f64, bool) {
    let mut best = (f64::INFINITY, false);
    for axis in 0..3 {
        if d[axis] == 0.0 {
            continue;
        }
        let wall = if d[axis] > 0.0 { 1.0 } else { -1.0 };
        let t = (wall - origin[axis]) / d[axis];
        if t < best.0 {
            best = (t, axis == 1 && wall < 0.0);
        }
    }
    best
}

/// The floor's radiance at floor point `q` lit by `direct(q)` (irradiance, the live sphere's
/// shadow included or not) and by the uniform indirect light (`occluded`: less the sphere's
/// exact cosine-weighted occlusion, `(r / d)^2 cos` for a sphere above the floor's horizon).
fn floor_radiance(q: DVec3, direct: f64, occluded: bool) -> f64 {
    let to_centre = RESTING_CENTRE - q;
    let d = to_centre.length();
    let occlusion = if occluded { (RESTING_RADIUS / d).powi(2) * to_centre.y / d } else { 0.0 };
    let indirect = std::f64::consts::PI * INDIRECT_RADIANCE * (1.0 - occlusion);
    FLOOR_ALBEDO / std::f64::consts::PI * (direct + indirect)
}

/// One reflection probe at the box's centre that saw the empty box: the floor lit by
/// `direct(q)` and the indirect light, black walls, and the distances to the box's faces.
fn floor_probe(direct: &dyn Fn(DVec3) -> f64) -> sidecar::ReflectionProbes {
    let n = sidecar::REFLECTION_TEXELS;
    let (mut base, mut distance) = (Vec::new(), Vec::new());
    for t in 0..n * n {
        let d = DVec3::from(sidecar::octahedral_texel_center(n, t).map(f64::from)).normalize();
        let (s, floor) = box_exit(DVec3::ZERO, d);
        let l = if floor { floor_radiance(s * d, direct(s * d), false) as f32 } else { 0.0 };
        base.push([l; 3]);
        distance.push(s as f32);
    }
    sidecar::ReflectionProbes {
        depth_fingerprint: 0,
        origin: [0.0; 3],
        spacing: [1.0; 3],
        counts: [1, 1, 1],
        radiance: sidecar::reflection_levels(&base),
        distance,
        specular: Vec::new(),
    }
}

/// The Cornell camera and depth over the floor of the empty box as the renderer would have
/// drawn it, lit by `lights` (`direct(q)`: the irradiance at floor point q) and by the uniform
/// indirect light, everything else black: its light layers (the direct light in the first
/// light's layer, the indirect in its own, normals up), the irradiance probes' indirect light
/// and the reflection probes of the empty box.
fn floor_scene(
    lights: Vec<LiveLight>,
    area_samples: Vec<viewer::AreaSample>,
    direct: &dyn Fn(DVec3) -> f64,
) -> ViewerScene {
    let (w, h) = (512u32, 512u32);
    let camera = cornell_camera();
    let depth = cornell_depth();
    let fingerprint = sidecar::depth_fingerprint(depth.values());
    let mut layers =
        sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "light")]);
    layers.normal.iter_mut().for_each(|v| *v = [0.0, 1.0, 0.0]);
    let mut linear = vec![0.0f32; (4 * w * h) as usize];
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            linear[4 * k + 3] = 1.0;
            let Some(r) = depth.get(i, j).filter(|r| r.is_finite()) else { continue };
            let ray = camera.pixel_centre_ray(i, j);
            let q = camera.world_from_camera().transform_point3(ray.origin + ray.direction * f64::from(r));
            if (q.y + 1.0).abs() > 1e-3 {
                continue;
            }
            let lit = (FLOOR_ALBEDO / std::f64::consts::PI * direct(q)) as f32;
            let indirect = (FLOOR_ALBEDO * INDIRECT_RADIANCE) as f32;
            layers.light[0][k] = [lit; 3];
            layers.indirect[k] = [indirect; 3];
            linear[4 * k..4 * k + 3].copy_from_slice(&[lit + indirect; 3]);
        }
    }
    let backdrop = viewer::Backdrop::from_linear(w, h, linear, 1.0).unwrap();
    let mut scene =
        ViewerScene::with_backdrop(camera, backdrop, depth, lights, viewer::ToneMap::default()).unwrap();
    scene
        .set_light_layers(viewer::SceneLayers {
            layers,
            layer_of_light: vec![Some(0)],
            area_samples: vec![area_samples],
        })
        .unwrap();
    scene.set_probes(uniform_probe([INDIRECT_RADIANCE as f32; 3]));
    scene.set_reflections(floor_probe(direct)).unwrap();
    scene
}

/// A glossy sphere resting on the floor of `floor_scene` (`direct(q, blocked)`: the irradiance
/// at floor point q, with the sphere blocking light where `blocked`); `highlight(p, n, v)` is
/// the light's own glossy reflection on the sphere. The sphere's glossy radiance against the
/// ray tracer's lobe integrated in f64 over the floor the sphere shadows and occludes: the
/// summed absolute difference over the pixels facing the floor, as a share of their summed
/// radiance, and the same for the floor without the sphere's shadow (what the probes alone
/// give).
fn contact_error(
    scene: ViewerScene,
    direct: &dyn Fn(DVec3, bool) -> f64,
    highlight: &dyn Fn(DVec3, DVec3, DVec3) -> f64,
) -> (f64, f64) {
    let roughness = 0.1;
    let material = glossy(roughness);
    let gpu = gpu();
    let live = LiveObjects {
        sphere: Some(Sphere { centre: RESTING_CENTRE, radius: RESTING_RADIUS, material }),
        meshes: Vec::new(),
    };
    let mut c = Compositor::new(&gpu, &scene, CompositorSettings::default()).unwrap();
    c.render(&live).unwrap();
    let rgba = c.read_back_linear().unwrap().rgba;
    let mask = c.read_back().unwrap().mask;
    let exponent = f64::from(sidecar::blinn_exponent(roughness));
    let (mut error, mut unshadowed_error, mut total, mut pixels) = (0.0, 0.0, 0.0, 0);
    for k in (0..mask.len()).filter(|&k| mask[k] == 255) {
        let Some((p, n, v)) = sphere_hit(&scene, k, RESTING_CENTRE, RESTING_RADIUS) else { continue };
        if n.y > -0.3 || n.dot(v) < 0.15 {
            continue;
        }
        let seen = |l: DVec3, shadowed: bool| {
            let (s, floor) = box_exit(p, l);
            let q = p + s * l;
            if floor { floor_radiance(q, direct(q, shadowed), shadowed) } else { 0.0 }
        };
        let lit = highlight(p, n, v);
        let want = lit + lobe_integral(n, v, exponent, |l| [seen(l, true); 3])[0];
        let unshadowed = lit + lobe_integral(n, v, exponent, |l| [seen(l, false); 3])[0];
        let got = f64::from(rgba[4 * k]);
        error += (got - want).abs();
        unshadowed_error += (unshadowed - want).abs();
        total += want;
        pixels += 1;
    }
    assert!(pixels > 300, "{pixels} pixels facing the floor");
    (error / total, unshadowed_error / total)
}

/// The Blinn lobe's `f cos` toward unit `l` (the ray tracer's, as `blinn_lobe_cos` takes it).
fn blinn_lobe_cos(n: DVec3, v: DVec3, l: DVec3, e: f64) -> f64 {
    let h = (l + v).normalize();
    let (cos_h, cos_o, cos_l, o_dot_h) = (n.dot(h), n.dot(v).max(1e-3), n.dot(l), v.dot(h).abs());
    if cos_h <= 0.0 || cos_l <= 0.0 || o_dot_h == 0.0 {
        return 0.0;
    }
    let d = (e + 2.0) / (2.0 * std::f64::consts::PI) * cos_h.powf(e);
    let g = (2.0 * cos_h * cos_o / o_dot_h).min(2.0 * cos_h * cos_l / o_dot_h).min(1.0);
    d * g / (4.0 * cos_o)
}

/// A glossy sphere resting on a floor under a point light reflects, near where it rests, its
/// own shadow and its occlusion of the floor's indirect light, which the probes (baked without
/// it) do not hold: the pixels facing the floor match the ray tracer's lobe integrated in f64
/// over the floor it darkens within 16 % (summed absolute difference over summed radiance; 13 %
/// measured, the 16 lobe directions' own noise), where main before the change (the screen-space
/// glossy loss) was 29 % off and the probes without any loss are 158 %.
#[test]
fn a_glossy_sphere_reflects_its_own_shadow_under_a_point_light() {
    let light = DVec3::new(-0.4, 0.6, 0.1);
    let direct = |q: DVec3, shadowed: bool| {
        let to_light = light - q;
        let d = to_light.length();
        let blocked =
            shadowed && ray_sphere(q, to_light / d, RESTING_CENTRE, RESTING_RADIUS).is_some_and(|t| t < d);
        if blocked { 0.0 } else { (to_light.y / d).max(0.0) / (d * d) }
    };
    let exponent = f64::from(sidecar::blinn_exponent(0.1));
    let highlight = |p: DVec3, n: DVec3, v: DVec3| {
        let to_light = light - p;
        blinn_lobe_cos(n, v, to_light.normalize(), exponent) / to_light.length_squared()
    };
    let point = LiveLight::Point { position: light, colour: Vec3::ONE };
    let scene = floor_scene(vec![point], Vec::new(), &|q| direct(q, false));
    let (error, unshadowed) = contact_error(scene, &direct, &highlight);
    eprintln!("point light: relative error {error}, the probes as they are {unshadowed}");
    assert!(
        error <= 0.16 && unshadowed >= 5.0 * error,
        "relative error {error} (the probes as they are: {unshadowed})"
    );
}

/// The same under the Cornell box's area light, integrated over the light layers' 64 emitter
/// samples: the sphere's penumbra on the floor as well as its umbra (10 % measured; main before
/// the change 24 %, the probes without any loss 137 %).
#[test]
fn a_glossy_sphere_reflects_its_own_shadow_under_an_area_light() {
    let samples = cornell_emitter_samples();
    let light = cornell_light();
    let LiveLight::Area { radiance, .. } = light else { unreachable!() };
    let radiance = f64::from(radiance.x);
    // Irradiance of the samples at q (each `L A cos_e cos_q / d^2`), those the sphere blocks
    // left out where `shadowed`.
    let direct = |q: DVec3, shadowed: bool| {
        samples
            .iter()
            .map(|s| {
                let to_sample = s.position - q;
                let d = to_sample.length();
                let l = to_sample / d;
                let blocked =
                    shadowed && ray_sphere(q, l, RESTING_CENTRE, RESTING_RADIUS).is_some_and(|t| t < d);
                if blocked {
                    0.0
                } else {
                    radiance * s.area * s.normal.dot(-l).max(0.0) * l.y.max(0.0) / (d * d)
                }
            })
            .sum::<f64>()
    };
    let exponent = f64::from(sidecar::blinn_exponent(0.1));
    let highlight = |p: DVec3, n: DVec3, v: DVec3| {
        samples
            .iter()
            .map(|s| {
                let to_sample = s.position - p;
                let d2 = to_sample.length_squared();
                let l = to_sample / d2.sqrt();
                radiance * s.area * s.normal.dot(-l).max(0.0) / d2 * blinn_lobe_cos(n, v, l, exponent)
            })
            .sum::<f64>()
    };
    let scene = floor_scene(vec![light], samples.clone(), &|q| direct(q, false));
    let (error, unshadowed) = contact_error(scene, &direct, &highlight);
    eprintln!("area light: relative error {error}, the probes as they are {unshadowed}");
    assert!(
        error <= 0.16 && unshadowed >= 5.0 * error,
        "relative error {error} (the probes as they are: {unshadowed})"
    );
}

/// The plate of `plate_scene`: a black horizontal square at `y = PLATE_Y` over
/// `x, z` in `[PLATE_MIN, PLATE_MAX]`, between the left probe and the floor.
const PLATE_Y: f64 = -0.45;
const PLATE_MIN: [f64; 2] = [-0.9, -0.4];
const PLATE_MAX: [f64; 2] = [-0.1, 0.4];

/// Where unit direction `d` from `origin` first meets the box `[-1, 1]^3` or the plate: the
/// distance and whether it is the floor (the floor's radiance is 1, everything else black).
fn plate_box_hit(origin: DVec3, d: DVec3) -> (f64, bool) {
    let (s, floor) = box_exit(origin, d);
    if d.y != 0.0 {
        let t = (PLATE_Y - origin.y) / d.y;
        let q = origin + t * d;
        let on_plate =
            (PLATE_MIN[0]..=PLATE_MAX[0]).contains(&q.x) && (PLATE_MIN[1]..=PLATE_MAX[1]).contains(&q.z);
        if t > 0.0 && t < s && on_plate {
            return (t, false);
        }
    }
    (s, floor)
}

/// Two reflection probes, at x = -0.5 and 0.5 (y -0.2, z 0), that saw the box of
/// `plate_box_hit`: the left one looks down onto the plate and sees almost none of the floor,
/// the right one sees all of it.
fn plate_probes() -> sidecar::ReflectionProbes {
    probes_of(|origin, d| {
        let (s, floor) = plate_box_hit(origin, d);
        (if floor { 1.0 } else { 0.0 }, s)
    })
}

/// The box's walls and the plate as the scene's triangles.
fn plate_occluders() -> viewer::occluders::SceneOccluders {
    let (a, b) = (PLATE_MIN, PLATE_MAX);
    let v = |x: f64, z: f64| DVec3::new(x, PLATE_Y, z);
    let plate = [v(a[0], a[1]), v(b[0], a[1]), v(b[0], b[1]), v(a[0], b[1])];
    let mut triangles = box_faces();
    triangles.extend([[plate[0], plate[1], plate[2]], [plate[0], plate[2], plate[3]]]);
    viewer::occluders::SceneOccluders { triangles }
}

/// A glossy sphere beside a black plate reflects the lit floor under and in front of it, which
/// the reflection probe nearest to it cannot see (the plate lies between them) and the other
/// probe can. Read from the probes around the sphere toward where each lobe direction meets the
/// scene, the nearest one's view of the plate took the floor's place (the room's floating
/// sphere over the metal cylinder, docs/viewer-specular.md); each direction's point, traced
/// through the scene's triangles, is read from the probes that see it. Against the ray tracer's
/// lobe integrated in f64 over the floor the sphere sees, on the pixels facing down: summed
/// absolute difference over summed radiance 21 % from the sphere's near-field map, 26 % traced
/// per fragment (bound 35 %; main's shaders 82 %; what is left is not diagnosed).
#[test]
fn a_glossy_sphere_reflects_the_floor_its_nearest_probe_does_not_see() {
    let (centre, radius) = (PLATE_SPHERE, PLATE_SPHERE_RADIUS);
    let (scene, rgba, mask) = plate_frame(true);
    let roughness = PLATE_SPHERE_ROUGHNESS;
    let exponent = f64::from(sidecar::blinn_exponent(roughness));
    let (mut error, mut total, mut pixels) = (0.0, 0.0, 0);
    for k in (0..mask.len()).filter(|&k| mask[k] == 255) {
        let Some((p, n, v)) = sphere_hit(&scene, k, centre, radius) else { continue };
        if n.y > -0.2 || n.dot(v) < 0.15 {
            continue;
        }
        let want = lobe_integral(n, v, exponent, |l| [if plate_box_hit(p, l).1 { 1.0 } else { 0.0 }; 3])[0];
        error += (f64::from(rgba[4 * k]) - want).abs();
        total += want;
        pixels += 1;
    }
    assert!(pixels > 300, "{pixels} pixels facing down");
    let relative = error / total;
    eprintln!("{pixels} pixels facing down: relative error {relative}");
    assert!(relative <= 0.35, "relative error {relative} over {pixels} pixels");
}

/// The glossy sphere beside the plate reads its traced lobes from its near-field map, drawn once
/// per texel over the half facing the eye, instead of tracing them per fragment: over the
/// sphere's pixels the two differ by a small share of the radiance (summed absolute difference
/// over summed radiance: 0.041 measured with 32^2 texels, mostly the per-fragment lobe's own
/// sampling noise, which the map's bilinear reading smooths; against the f64 lobe the map's
/// error is 0.21, the per-fragment tracing's 0.26).
#[test]
fn the_glossy_sphere_s_map_agrees_with_tracing_per_fragment() {
    let (_, mapped, mask) = plate_frame(true);
    let (_, traced, traced_mask) = plate_frame(false);
    assert_eq!(mask, traced_mask);
    let (mut difference, mut total, mut pixels) = (0.0, 0.0, 0);
    for k in (0..mask.len()).filter(|&k| mask[k] == 255 && inside_mask(&mask, 512, k)) {
        for ch in 0..3 {
            difference += (f64::from(mapped[4 * k + ch]) - f64::from(traced[4 * k + ch])).abs();
            total += f64::from(traced[4 * k + ch]);
        }
        pixels += 1;
    }
    let relative = difference / total;
    eprintln!("{pixels} sphere pixels: map against per fragment {relative}");
    assert!(pixels > 1000 && relative <= 0.06, "{relative} over {pixels} pixels");
}

/// The sphere beside the plate (a_glossy_sphere_reflects_the_floor_its_nearest_probe_does_not_see).
const PLATE_SPHERE: DVec3 = DVec3::new(-0.3, -0.55, 0.65);
const PLATE_SPHERE_RADIUS: f64 = 0.2;
const PLATE_SPHERE_ROUGHNESS: f32 = 0.1;

/// The scene with the plate, its triangles and materials bound, and the glossy sphere's linear
/// frame and mask, with or without its near-field map.
fn plate_frame(near_field_maps: bool) -> (ViewerScene, Vec<f32>, Vec<u8>) {
    let (centre, radius) = (PLATE_SPHERE, PLATE_SPHERE_RADIUS);
    let mut scene = cornell_scene(vec![]);
    scene.set_reflections(plate_probes()).unwrap();
    let occluders = plate_occluders();
    // The lobe directions are traced only with the scene's materials bound (`hybrid-view
    // --near-field`); which material each triangle has does not matter to the reflection.
    let of_triangle = vec![0; occluders.triangles.len()];
    scene.set_occluders(occluders);
    scene.set_occluder_materials(viewer::occluders::SceneMaterials {
        materials: vec![viewer::occluders::SceneMaterial { diffuse: Vec3::splat(0.5), ..Default::default() }],
        of_triangle,
    });
    let gpu = gpu();
    let live = LiveObjects {
        sphere: Some(Sphere { centre, radius, material: glossy(PLATE_SPHERE_ROUGHNESS) }),
        meshes: Vec::new(),
    };
    let settings =
        CompositorSettings { mode: CompositeMode::Fullscreen, near_field_maps, ..Default::default() };
    let mut c = Compositor::new(&gpu, &scene, settings).unwrap();
    c.render(&live).unwrap();
    let rgba = c.read_back_linear().unwrap().rgba;
    let mask = c.read_back().unwrap().mask;
    (scene, rgba, mask)
}

/// The probes' radiance in glossy_surface_radiance's test: grey, as the probes saw the scene.
const GREY: f32 = 0.3;
/// The wall's glossy reflectance: a red metal.
const RED_METAL: [f32; 3] = [1.0, 0.2, 0.2];

/// A square wall 1.4 on a side in the plane 0.1 to the left of the sphere, facing it.
fn left_wall() -> Vec<[DVec3; 3]> {
    let x = CENTRE.x - RADIUS - 0.1;
    let c = [
        DVec3::new(x, CENTRE.y - 0.7, CENTRE.z - 0.7),
        DVec3::new(x, CENTRE.y + 0.7, CENTRE.z - 0.7),
        DVec3::new(x, CENTRE.y + 0.7, CENTRE.z + 0.7),
        DVec3::new(x, CENTRE.y - 0.7, CENTRE.z + 0.7),
    ];
    vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
}

/// The glossy sphere beside the wall of `material`, in grey reflection and irradiance probes of
/// radiance GREY (no lights): its linear frame and mask.
fn wall_frame(material: viewer::occluders::SceneMaterial) -> (ViewerScene, Vec<f32>, Vec<u8>) {
    let mut scene = cornell_scene(vec![]);
    scene.set_reflections(probes(&[0.0], 5.0, |_| [GREY; 3])).unwrap();
    scene.set_probes(uniform_probe([GREY; 3]));
    scene.set_occluders(viewer::occluders::SceneOccluders { triangles: left_wall() });
    scene.set_occluder_materials(viewer::occluders::SceneMaterials {
        materials: vec![material],
        of_triangle: vec![0, 0],
    });
    let (rgba, mask) = render(&scene, glossy(0.1));
    (scene, rgba, mask)
}

/// A glossy scene surface's radiance depends on where it is seen from, and the reflection
/// probes saw it from their own points: where a glossy live sphere's lobe meets a glossy scene
/// surface, it takes that surface's radiance from its material toward the sphere
/// (glossy_surface_radiance), here the red metal wall's reflection of the grey field, red times
/// GREY. Against the ray tracer's lobe integrated in f64 over the wall and the field, in blue
/// (where the wall and the probes differ): summed absolute difference over summed radiance on
/// the pixels whose lobe meets the wall, 4.4 % measured (bound 10 %; the probes' grey there
/// would be at least 25 % off, these pixels' lobes being a fifth or more on the wall). A matte
/// wall keeps the probes' grey (its radiance does not depend on the direction), so the blue
/// there stays the red's.
#[test]
fn a_glossy_sphere_takes_a_glossy_wall_s_light_toward_itself_from_the_wall_s_material() {
    let metal = viewer::occluders::SceneMaterial {
        glossy: Vec3::from(RED_METAL),
        exponent: 10.0,
        ..Default::default()
    };
    let (scene, rgba, mask) = wall_frame(metal);
    let exponent = f64::from(sidecar::blinn_exponent(0.1));
    let wall = left_wall();
    let meets_wall = |p: DVec3, l: DVec3| {
        wall.iter().any(|t| {
            let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
            let pv = l.cross(e2);
            let det = e1.dot(pv);
            let tv = p - t[0];
            let (u, qv) = (tv.dot(pv) / det, tv.cross(e1));
            let v = l.dot(qv) / det;
            u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(qv) / det > 0.0
        })
    };
    let (mut error, mut total, mut pixels) = (0.0, 0.0, 0);
    for (k, p, n, v) in inside(&scene, &mask, 0.15) {
        let blue =
            |l: DVec3| [if meets_wall(p, l) { f64::from(RED_METAL[2] * GREY) } else { f64::from(GREY) }; 3];
        let want = lobe_integral(n, v, exponent, blue)[2];
        let field = lobe_integral(n, v, exponent, |_| [f64::from(GREY); 3])[2];
        if want > 0.8 * field {
            continue;
        }
        error += (f64::from(rgba[4 * k + 2]) - want).abs();
        total += want;
        pixels += 1;
    }
    let relative = error / total;
    eprintln!("{pixels} pixels whose lobe meets the wall: relative error in blue {relative}");
    assert!(pixels > 300 && relative <= 0.1, "relative error {relative} over {pixels} pixels");
    let matte = viewer::occluders::SceneMaterial { diffuse: Vec3::from(RED_METAL), ..Default::default() };
    let (scene, rgba, mask) = wall_frame(matte);
    for (k, ..) in inside(&scene, &mask, 0.15) {
        let (red, blue) = (rgba[4 * k], rgba[4 * k + 2]);
        assert!(
            (red - blue).abs() <= 0.01 * red,
            "pixel {k}: a matte wall changed blue {blue} against red {red}"
        );
    }
}

/// The box's five faces (no front) as the scene's triangles, the floor's two first.
fn box_faces() -> Vec<[DVec3; 3]> {
    let quad = |c: [DVec3; 4]| [[c[0], c[1], c[2]], [c[0], c[2], c[3]]];
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let faces = [
        [v(-1.0, -1.0, -1.0), v(1.0, -1.0, -1.0), v(1.0, -1.0, 1.0), v(-1.0, -1.0, 1.0)],
        [v(-1.0, 1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(-1.0, 1.0, 1.0)],
        [v(-1.0, -1.0, -1.0), v(1.0, -1.0, -1.0), v(1.0, 1.0, -1.0), v(-1.0, 1.0, -1.0)],
        [v(-1.0, -1.0, -1.0), v(-1.0, 1.0, -1.0), v(-1.0, 1.0, 1.0), v(-1.0, -1.0, 1.0)],
        [v(1.0, -1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(1.0, -1.0, 1.0)],
    ];
    faces.into_iter().flat_map(quad).collect()
}

/// Two reflection probes, at x = -0.5 and 0.5 (y -0.2, z 0), that saw `radiance(origin, d)`
/// (radiance and the distance to the first surface) through each texel, none marked specular.
fn probes_of(radiance: impl Fn(DVec3, DVec3) -> (f64, f64)) -> sidecar::ReflectionProbes {
    two_probes_of(|origin, d| {
        let (l, s) = radiance(origin, d);
        (l, s, false)
    })
}

/// The relative error (summed absolute difference over summed radiance) of a glossy sphere's
/// pixels facing down against the ray tracer's lobe integrated in f64 over `radiance`, the
/// scene's triangles and their materials bound, with the probes of `probes_of(radiance)`; and
/// the pixels counted.
fn glossy_sphere_error(
    (centre, radius): (DVec3, f64),
    triangles: Vec<[DVec3; 3]>,
    materials: viewer::occluders::SceneMaterials,
    radiance: impl Fn(DVec3, DVec3) -> (f64, f64) + Copy,
) -> (f64, usize) {
    let mut scene = cornell_scene(vec![]);
    scene.set_reflections(probes_of(radiance)).unwrap();
    scene.set_occluders(viewer::occluders::SceneOccluders { triangles });
    scene.set_occluder_materials(materials);
    let roughness = 0.1;
    let live = LiveObjects {
        sphere: Some(Sphere { centre, radius, material: glossy(roughness) }),
        meshes: Vec::new(),
    };
    let settings = CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() };
    let mut c = Compositor::new(&gpu(), &scene, settings).unwrap();
    c.render(&live).unwrap();
    let rgba = c.read_back_linear().unwrap().rgba;
    let mask = c.read_back().unwrap().mask;
    let exponent = f64::from(sidecar::blinn_exponent(roughness));
    sphere_lobe_error(&scene, (&rgba, &mask), (centre, radius, exponent), 0.2, |p, l| radiance(p, l).0)
}

/// What the box's faces other than the floor shine with toward a ray that meets them at
/// `end`: radiance 1 where x < 0, black elsewhere.
fn left_half(end: DVec3) -> f64 {
    if end.x < 0.0 { 1.0 } else { 0.0 }
}

/// The radiance along unit `d` from `origin` in the box whose floor is a perfect mirror and
/// whose other faces are `left_half`; with the distance to the first surface.
fn mirror_box_radiance(origin: DVec3, d: DVec3) -> (f64, f64) {
    let (s, floor) = box_exit(origin, d);
    let (q, d2) = if floor { (origin + s * d, DVec3::new(d.x, -d.y, d.z)) } else { (origin, d) };
    let (s2, _) = box_exit(q, d2);
    (left_half(q + s2 * d2), s)
}

/// A glossy sphere above a mirror floor reflects, in the mirror, the walls beyond it: the lobe
/// directions that meet the mirror follow it (specular_chain.wgsl) and the probes are read
/// toward the wall point they reach. Read toward the mirror's point, the probes give what their
/// own places see in it (the probe at x = -0.5 sees the dark half there). Against the ray tracer's lobe
/// integrated in f64 over the mirror box, on the pixels facing down: summed absolute difference
/// over summed radiance 6.0 % (bound 10 %; 15.5 % read toward the mirror).
#[test]
fn a_glossy_sphere_sees_the_walls_in_a_mirror_floor() {
    use viewer::occluders::{SceneMaterial, SceneMaterials};
    let triangles = box_faces();
    // The floor's two triangles are the mirror (material 1), the walls matte.
    let of_triangle = (0..triangles.len()).map(|k| if k < 2 { 1 } else { 0 }).collect();
    let materials = SceneMaterials {
        materials: vec![
            SceneMaterial { diffuse: Vec3::splat(0.5), ..Default::default() },
            SceneMaterial { specular: true, reflect: Vec3::ONE, ..Default::default() },
        ],
        of_triangle,
    };
    let sphere = (DVec3::new(-0.25, -0.5, 0.3), 0.2);
    let (relative, pixels) = glossy_sphere_error(sphere, triangles, materials, mirror_box_radiance);
    eprintln!("{pixels} pixels facing down: relative error {relative}");
    assert!(relative <= 0.10, "relative error {relative} over {pixels} pixels");
}

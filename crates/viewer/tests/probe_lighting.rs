//! GPU test of live objects lit by the renderer's irradiance probes (docs/sidecar.md): their
//! diffuse light is the probes' SH irradiance, not the bare lights'.

mod common;

use common::*;
use glam::{DMat4, DVec3, Vec3};
use viewer::{
    CompositeMode, Compositor, CompositorSettings, LiveLight, LiveObjects, Material, Mesh, MeshInstance,
    Sphere, ViewerScene,
};

/// A white Lambertian sphere (Kd 1, no Ka, no Ks) in a uniform environment of radiance `l`
/// (and no lights) has radiance `l` at every visible point.
#[test]
fn a_white_matte_sphere_in_a_uniform_probe_field_has_the_field_s_radiance() {
    let gpu = gpu();
    let l = [0.3f32, 0.5, 0.7];
    let mut scene = cornell_scene(vec![]);
    scene.set_probes(uniform_probe(l));
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live = LiveObjects {
        sphere: Some(Sphere { centre: DVec3::new(0.0, -0.2, 0.0), radius: 0.3, material }),
        meshes: Vec::new(),
    };
    let mut c = Compositor::new(
        &gpu,
        &scene,
        CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() },
    )
    .unwrap();
    c.render(&live).unwrap();
    let linear = c.read_back_linear().unwrap();
    let mask = c.read_back().unwrap().mask;
    let mut inside = 0;
    for k in 0..mask.len() {
        // The antialiased edge blends in the backdrop.
        if inside_mask(&mask, 512, k) {
            inside += 1;
            for (ch, want) in l.iter().enumerate() {
                let got = linear.rgba[4 * k + ch];
                assert!((got - want).abs() < 1e-4 * want.max(1.0), "pixel {k} channel {ch}: {got} vs {want}");
            }
        }
    }
    assert!(inside > 1000, "inside {inside}");
}

fn render_linear(scene: &ViewerScene, live: &LiveObjects) -> (Vec<f32>, Vec<u8>) {
    render_linear_with(scene, live, true)
}

/// The linear frame and mask, the live spheres' own-shadow loss from their maps or gathered
/// per fragment (`own_shadow_maps`).
fn render_linear_with(scene: &ViewerScene, live: &LiveObjects, own_shadow_maps: bool) -> (Vec<f32>, Vec<u8>) {
    let gpu = gpu();
    let settings =
        CompositorSettings { mode: CompositeMode::Fullscreen, own_shadow_maps, ..Default::default() };
    let mut c = Compositor::new(&gpu, scene, settings).unwrap();
    c.render(live).unwrap();
    (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
}

/// A point light never reaches a probe (no ray hits it), so nothing of its direct light is
/// taken out of the probes: a dark probe field adds nothing and takes nothing away.
#[test]
fn a_dark_probe_field_takes_nothing_from_a_point_light() {
    let light = LiveLight::Point { position: DVec3::new(0.1, 0.9, 0.2), colour: Vec3::splat(4.0) };
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let centre = DVec3::new(0.0, -0.2, 0.0);
    let live = LiveObjects { sphere: Some(Sphere { centre, radius: 0.3, material }), meshes: Vec::new() };
    let without = render_linear(&cornell_scene(vec![light.clone()]), &live);
    for emitters_seen in [false, true] {
        let mut probes = uniform_probe([0.0; 3]);
        probes.origin = [centre.x as f32, centre.y as f32, centre.z as f32];
        probes.emitters_seen = emitters_seen;
        let mut scene = cornell_scene(vec![light.clone()]);
        scene.set_probes(probes);
        let with = render_linear(&scene, &live);
        assert_eq!(without.1, with.1);
        let inside: Vec<usize> = (0..with.1.len()).filter(|&k| with.1[k] == 255).collect();
        assert!(inside.len() > 1000);
        for k in inside {
            let (a, b) = (without.0[4 * k], with.0[4 * k]);
            assert!((a - b).abs() <= 1e-4 * a.abs().max(1e-3), "pixel {k}: {a} without probes, {b} with");
        }
    }
}

/// Probes written before the bake left emitters out (`emitters_seen`) hold an area light's
/// direct light, which the viewer adds itself over the light layers' emitter samples: probes
/// that saw only that light (projected from those samples) add nothing. Probes baked without
/// the emitters hold no such light, so the same SH is light they add.
#[test]
fn probes_that_saw_only_a_sampled_area_light_add_nothing() {
    let centre = DVec3::new(0.05, 0.5, 0.0);
    let samples = cornell_emitter_samples();
    let light = cornell_light();
    let LiveLight::Area { radiance, area, .. } = light else { unreachable!() };
    let layered = |probes: Option<sidecar::ProbeGrid>| {
        let mut scene = cornell_scene(vec![light.clone()]);
        let (w, h) = scene.size();
        let fingerprint = sidecar::depth_fingerprint(scene.depth().values());
        let layers =
            sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
        scene
            .set_light_layers(viewer::SceneLayers {
                layers,
                layer_of_light: vec![Some(0)],
                area_samples: vec![samples.clone()],
            })
            .unwrap();
        if let Some(p) = probes {
            scene.set_probes(p);
        }
        scene
    };
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live = LiveObjects { sphere: Some(Sphere { centre, radius: 0.2, material }), meshes: Vec::new() };
    let without = render_linear(&layered(None), &live);
    let total: f64 = samples.iter().map(|s| s.area).sum();
    let mut sh = [[0.0f32; 3]; 9];
    for s in &samples {
        let v = s.position - centre;
        let d2 = v.length_squared();
        let l = v / d2.sqrt();
        let weight = area / total * s.area * s.normal.dot(-l).max(0.0) / d2;
        let y = sidecar::sh::sh_basis([l.x as f32, l.y as f32, l.z as f32]);
        for (c, yi) in sh.iter_mut().zip(y) {
            for (ch, v) in c.iter_mut().enumerate() {
                *v += yi * (f64::from(radiance[ch]) * weight) as f32;
            }
        }
    }
    let mut probes = uniform_probe([0.0; 3]);
    probes.origin = [centre.x as f32, centre.y as f32, centre.z as f32];
    probes.radiance_sh[0] = sh;
    probes.emitters_seen = true;
    let with = render_linear(&layered(Some(probes.clone())), &live);
    assert_eq!(without.1, with.1);
    let inside: Vec<usize> = (0..with.1.len()).filter(|&k| with.1[k] == 255).collect();
    assert!(inside.len() > 1000);
    for k in inside {
        for ch in 0..3 {
            let (a, b) = (without.0[4 * k + ch], with.0[4 * k + ch]);
            assert!((a - b).abs() <= 1e-3 * a.abs().max(1e-2), "pixel {k}: {a} without probes, {b} with");
        }
    }
    // Baked without the emitters, the same SH is the scene's light on the sphere: brighter.
    probes.emitters_seen = false;
    let added = render_linear(&layered(Some(probes)), &live);
    let brighter =
        (0..added.1.len()).filter(|&k| added.1[k] == 255 && added.0[4 * k] > 1.05 * without.0[4 * k]);
    assert!(brighter.count() > 1000);
}

/// Each fragment of a live object gets the probe field's irradiance at its own point and
/// normal, as `sidecar::ProbeGrid::irradiance` evaluates it (DDGI weights over the 8 probes of
/// its cell): a white Lambertian sphere (no lights) spanning a 3x3x3 grid of probes, each with
/// its own light and a wall hiding some of them, has radiance `E(p, n) / pi` at every pixel.
#[test]
fn each_fragment_takes_the_probe_field_at_its_own_point_and_normal() {
    let texels = sidecar::VISIBILITY_TEXELS * sidecar::VISIBILITY_TEXELS;
    let (centre, radius) = (DVec3::new(0.05, -0.1, 0.1), 0.45);
    let mut grid = uniform_probe([0.0; 3]);
    grid.counts = [3, 3, 3];
    grid.spacing = [0.4, 0.35, 0.45];
    grid.origin = [-0.35, -0.45, -0.35];
    grid.radiance_sh = (0..27)
        .map(|p| {
            let mut sh = [[0.0f32; 3]; 9];
            sh[0] = [0.5 + 0.1 * (p % 3) as f32, 0.3 + 0.05 * (p / 9) as f32, 0.4];
            sh[1] = [0.2 * ((p / 3) % 3) as f32 - 0.2, 0.1, -0.05];
            sh[3] = [0.1, -0.1 * (p % 2) as f32, 0.15];
            sh[6] = [0.05, 0.02, -0.03];
            sh
        })
        .collect();
    // Probes with odd index see a surface 0.3 away in every direction: the sphere's points
    // beyond it are hidden from them.
    grid.visibility =
        (0..27 * texels).map(|t| if (t / texels) % 2 == 1 { [0.3, 0.09] } else { [10.0, 100.0] }).collect();
    let mut scene = cornell_scene(vec![]);
    scene.set_probes(grid.clone());
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live = LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() };
    let (linear, mask) = render_linear(&scene, &live);
    let camera = scene.camera();
    let (w, _) = scene.size();
    let (mut checked, mut spread) = (0, (f32::INFINITY, 0.0f32));
    for (k, &m) in mask.iter().enumerate() {
        let (i, j) = ((k as u32) % w, (k as u32) / w);
        let ray = camera.pixel_centre_world_ray(i, j);
        let Some(t) = ray_sphere(ray.origin, ray.direction, centre, radius) else { continue };
        let p = ray.origin + t * ray.direction;
        let n = (p - centre) / radius;
        // Skip the silhouette, where f32 and f64 may disagree on the hit.
        if !inside_mask(&mask, w as usize, k) || m != 255 || n.dot(-ray.direction) < 0.05 {
            continue;
        }
        let e = grid.irradiance(p.as_vec3().to_array(), n.as_vec3().to_array());
        for (ch, e) in e.iter().enumerate() {
            let (got, want) = (linear[4 * k + ch], e / std::f32::consts::PI);
            assert!(
                (got - want).abs() <= 2e-3 * want.max(0.05),
                "pixel ({i}, {j}) channel {ch}: {got} vs {want}"
            );
        }
        spread = (spread.0.min(e[0]), spread.1.max(e[0]));
        checked += 1;
    }
    assert!(checked > 5000, "{checked}");
    // The field varies over the sphere: one SH for the whole object would not pass.
    assert!(spread.1 > 1.5 * spread.0, "{spread:?}");
}

/// A live sphere's own shadow darkens its underside: the floor under it reflects less light
/// than the probes (baked without the sphere) remember. A white matte sphere in a uniform probe
/// field of radiance 1 hangs over the Cornell floor under a point light; the light layers hold
/// the whole backdrop (0.5) as the light's direct light, so the floor in the sphere's shadow
/// lost 0.5. Each fragment facing away from the light loses 0.5 times the share of its 16
/// cosine-distributed gather directions that reach the shadowed floor: checked against the same
/// directions traced to the exact floor plane on the CPU (a direction grazing the shadow's edge
/// may fall either way, or meet a floor pixel that lost part of the light).
#[test]
fn a_sphere_s_underside_sees_its_own_shadow() {
    let light = DVec3::new(-0.2, 0.9, 0.1);
    let (centre, radius) = (DVec3::new(-0.2, -0.55, 0.1), 0.25);
    let mut scene = layered_cornell(light, false, 0.5);
    scene.set_probes(uniform_probe([1.0; 3]));
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live = LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() };
    let (linear, mask) = render_linear_with(&scene, &live, false);
    let camera = scene.camera();
    let (w, _) = scene.size();
    let (mut checked, mut wrong, mut far_off, mut darkened) = (0, 0, 0, 0);
    for k in 0..mask.len() {
        if !inside_mask(&mask, w as usize, k) {
            continue;
        }
        let (i, j) = ((k as u32) % w, (k as u32) / w);
        let ray = camera.pixel_centre_world_ray(i, j);
        let Some(t) = ray_sphere(ray.origin, ray.direction, centre, radius) else { continue };
        let p = ray.origin + t * ray.direction;
        let n = (p - centre) / radius;
        if n.dot(light - p) > 0.0 {
            continue;
        }
        let in_shadow = directions_in_shadow(&scene, (light, centre, radius), p, n, 16);
        let got = linear[4 * k];
        // The GPU's count of directions reaching the shadow, from the fragment's radiance: a
        // whole number, but for a direction that meets a floor pixel on the shadow's edge, which
        // lost the share of its footprint in the shadow (shadow_footprint.wgsl).
        let gpu_count = f64::from((1.0 - got) / 0.5 * 16.0);
        let off = (gpu_count - in_shadow as f64).abs();
        checked += 1;
        darkened += usize::from(got < 0.97);
        wrong += usize::from(off > 0.01 && off <= 1.01);
        far_off += usize::from(off > 1.01);
    }
    eprintln!("checked {checked}, darkened {darkened}, off by one direction {wrong}, by more {far_off}");
    assert!(checked > 500 && darkened > 300, "checked {checked}, darkened {darkened}");
    assert!(wrong * 10 <= checked, "{wrong} of {checked} fragments off the CPU's count by a direction");
    assert!(
        far_off * 200 <= checked,
        "{far_off} of {checked} fragments off the CPU's count by more than a direction"
    );
}

/// How many of `count` cosine-distributed directions from `p` (world space, unit normal `n` of
/// the sphere `(centre, radius)`) reach, within the gather's reach, floor of the Cornell box
/// (`y = -1`) that the sphere shadows from the point light `light` and that the eye sees in the
/// render: the shader's directions (shadow_loss.wgsl shadow_loss_over), built as it builds them
/// in camera space, then taken to world space.
fn directions_in_shadow(
    scene: &ViewerScene,
    (light, centre, radius): (DVec3, DVec3, f64),
    p: DVec3,
    n: DVec3,
    count: u32,
) -> usize {
    let camera = scene.camera();
    let (w, _) = scene.size();
    let reach = 8.0 * radius;
    let n_camera = camera.camera_from_world().transform_vector3(n).normalize();
    let helper = if n_camera.x.abs() > 0.9 { DVec3::Y } else { DVec3::X };
    let tangent = helper.cross(n_camera).normalize();
    let bitangent = n_camera.cross(tangent);
    let world = |v: DVec3| camera.world_from_camera().transform_vector3(v).normalize();
    let mut in_shadow = 0;
    for d in 0..count {
        let u = (f64::from(d) + 0.5) / f64::from(count);
        let phi = f64::from(d) * 2.399_963_23;
        let dir = world(
            tangent * (u.sqrt() * phi.cos())
                + bitangent * (u.sqrt() * phi.sin())
                + n_camera * (1.0 - u).sqrt(),
        );
        if dir.y >= 0.0 {
            continue;
        }
        let s = (-1.0 - p.y) / dir.y;
        let floor = p + dir * s;
        let to_light = light - floor;
        let shadowed = ray_sphere(floor, to_light.normalize(), centre, radius).is_some();
        // The march finds surfaces the eye sees in the render without the sphere only.
        let seen = raster_of(camera, floor);
        let (fi, fj) = (seen.x.floor() as u32, seen.y.floor() as u32);
        let visible = fi < w
            && fj < w
            && scene.depth().get(fi, fj).is_some_and(|r| {
                let eye_ray = camera.pixel_centre_world_ray(fi, fj);
                (f64::from(r) - (floor - eye_ray.origin).length()).abs() < 0.02
            });
        in_shadow += usize::from(s <= reach && shadowed && visible);
    }
    in_shadow
}

/// The own-shadow loss read from a sphere's map (compositor/loss_map.rs) and gathered per
/// fragment, against the loss over 1024 directions traced on the CPU, on the scene of
/// `a_sphere_s_underside_sees_its_own_shadow` (the share of directions reaching the shadow takes
/// up to 0.5 from the radiance 1): for the cursor sphere, and for the same sphere drawn as a live
/// mesh (`--live`'s spheres), whose map is its row among the shadow-casting spheres. The map
/// gathers the same 16 directions per texel and is read bilinearly, which averages
/// neighbouring texels' directions: it is closer to the reference than each fragment's own
/// gather. Measured on lavapipe (3112 fragments facing away from the light, 1046 darkened):
/// mean error 0.0077 from the map (the largest 0.055), 0.0093 from the gather, for either
/// sphere.
#[test]
fn a_sphere_s_loss_map_is_closer_to_the_loss_than_the_per_fragment_gather() {
    let light = DVec3::new(-0.2, 0.9, 0.1);
    let (centre, radius) = (DVec3::new(-0.2, -0.55, 0.1), 0.25);
    let mut scene = layered_cornell(light, false, 0.5);
    scene.set_probes(uniform_probe([1.0; 3]));
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let cursor = LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() };
    let mesh = LiveObjects {
        sphere: None,
        meshes: vec![MeshInstance {
            mesh: std::sync::Arc::new(Mesh::unit_sphere(48, 96)),
            world_from_object: DMat4::from_translation(centre) * DMat4::from_scale(DVec3::splat(radius)),
            material,
            exact_sphere: Some((centre, radius)),
        }],
    };
    let camera = scene.camera();
    let (w, _) = scene.size();
    for (what, live) in [("cursor sphere", &cursor), ("mesh sphere", &mesh)] {
        let (mapped, mask) = render_linear_with(&scene, live, true);
        let (gathered, gathered_mask) = render_linear_with(&scene, live, false);
        assert_eq!(mask, gathered_mask, "{what}: the maps change no pixel's coverage");
        let (mut n, mut darkened, mut map_error, mut gather_error, mut map_max) = (0, 0, 0.0, 0.0, 0.0f64);
        for k in 0..mask.len() {
            if !inside_mask(&mask, w as usize, k) {
                continue;
            }
            let ray = camera.pixel_centre_world_ray((k as u32) % w, (k as u32) / w);
            let Some(t) = ray_sphere(ray.origin, ray.direction, centre, radius) else { continue };
            let p = ray.origin + t * ray.direction;
            let normal = (p - centre) / radius;
            if normal.dot(light - p) > 0.0 {
                continue;
            }
            let share =
                directions_in_shadow(&scene, (light, centre, radius), p, normal, 1024) as f64 / 1024.0;
            let reference = 1.0 - 0.5 * share;
            n += 1;
            darkened += usize::from(reference < 0.97);
            let e = (f64::from(mapped[4 * k]) - reference).abs();
            map_error += e;
            map_max = map_max.max(e);
            gather_error += (f64::from(gathered[4 * k]) - reference).abs();
        }
        let (map_error, gather_error) = (map_error / f64::from(n), gather_error / f64::from(n));
        eprintln!(
            "{what}: {n} fragments facing away from the light, {darkened} darkened; mean error against 1024 \
             directions: map {map_error:.4} (largest {map_max:.4}), per-fragment gather {gather_error:.4}"
        );
        assert!(n > 1000 && darkened > 300, "{what}: {n} fragments, {darkened} darkened");
        assert!(map_error <= gather_error, "{what}: map {map_error} against gather {gather_error}");
        assert!(map_max < 0.1, "{what}: largest error {map_max}");
    }
}

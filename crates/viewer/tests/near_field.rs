//! GPU tests of the irradiance probes' light on a live surface near a large scene surface
//! (docs/viewer-lighting.md, "Near a large scene surface"): the probes sit a grid spacing
//! apart, so a sphere beside a wall would get the light the probes saw around it; within a
//! spacing the scene's triangles say what the fragment sees, and each triangle's own material
//! what light it sends (its lights' direct light and the probes' light at it). Checked against
//! the irradiance integrated over the hemisphere in f64.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use viewer::occluders::{SceneMaterial, SceneMaterials, SceneOccluders};
use viewer::{
    CompositeMode, Compositor, CompositorSettings, LiveLight, LiveObjects, Material, SceneLayers, Sphere,
    ViewerScene,
};

const CENTRE: DVec3 = DVec3::new(0.0, -0.2, 0.0);
const RADIUS: f64 = 0.3;
/// Radiance of the probe field: what the irradiance probes saw around them.
const FAR: f64 = 0.3;
/// The wall's Lambertian reflectance per channel.
const WALL_ALBEDO: [f64; 3] = [0.8, 0.4, 0.1];
/// The distant light: irradiance on a surface facing it, travelling along -x and down.
const SUN: f64 = 2.0;

fn sun_direction() -> DVec3 {
    DVec3::new(-1.0, -1.0, 0.3).normalize()
}

/// A square wall in the plane x = CENTRE.x - RADIUS - 0.15 (0.15 from the sphere), 1.4 on a side
/// about the sphere's centre, its face toward the sphere lit by the sun: it hides nearly half of
/// the hemisphere of the sphere's left side and never the sun from the sphere.
fn wall() -> Vec<[DVec3; 3]> {
    let x = CENTRE.x - RADIUS - 0.15;
    let c = [
        DVec3::new(x, CENTRE.y - 0.7, CENTRE.z - 0.7),
        DVec3::new(x, CENTRE.y + 0.7, CENTRE.z - 0.7),
        DVec3::new(x, CENTRE.y + 0.7, CENTRE.z + 0.7),
        DVec3::new(x, CENTRE.y - 0.7, CENTRE.z + 0.7),
    ];
    vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
}

/// The wall's radiance in channel `ch`: albedo / pi times the sun's irradiance on it and the
/// probe field's (pi FAR on any surface).
fn wall_radiance(ch: usize) -> f64 {
    WALL_ALBEDO[ch] / PI * (SUN * sun_direction().dot(-DVec3::X) + PI * FAR)
}

fn meets(p: DVec3, dir: DVec3, tris: &[[DVec3; 3]]) -> bool {
    tris.iter().any(|t| {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let pv = dir.cross(e2);
        let det = e1.dot(pv);
        let tv = p - t[0];
        let (u, qv) = (tv.dot(pv) / det, tv.cross(e1));
        let v = dir.dot(qv) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(qv) / det > 0.0
    })
}

/// Radiance of a white matte point at p (unit normal n): the sun's light, and the irradiance
/// where the wall sends `wall_radiance` and every other direction FAR over the cosine-weighted
/// hemisphere in 64 x 64 strata, over pi, in f64.
fn radiance(p: DVec3, n: DVec3, ch: usize) -> f64 {
    let tris = wall();
    let (t, b) = n.any_orthonormal_pair();
    let strata = 64;
    let mut sum = 0.0;
    for a in 0..strata {
        for c in 0..strata {
            let r = ((a as f64 + 0.5) / strata as f64).sqrt();
            let phi = 2.0 * PI * (c as f64 + 0.5) / strata as f64;
            let d = t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - r * r).sqrt();
            sum += if meets(p, d, &tris) { wall_radiance(ch) } else { FAR };
        }
    }
    let indirect = PI * sum / (strata * strata) as f64;
    (SUN * n.dot(-sun_direction()).max(0.0) + indirect) / PI
}

/// The wall as a matte surface of WALL_ALBEDO (or `material`).
fn wall_materials(material: SceneMaterial) -> SceneMaterials {
    SceneMaterials { materials: vec![material], of_triangle: vec![0, 0] }
}

fn matte_wall() -> SceneMaterial {
    let [r, g, b] = WALL_ALBEDO.map(|v| v as f32);
    SceneMaterial { diffuse: Vec3::new(r, g, b), ..SceneMaterial::default() }
}

/// The Cornell camera's scene lit by the sun, with a uniform irradiance probe of radiance FAR
/// and grid spacing `spacing` (the near field reaches that far), the wall bound as the scene's
/// triangles and, if given, their materials.
fn scene(spacing: f32, materials: Option<SceneMaterials>) -> ViewerScene {
    let sun = LiveLight::Distant { direction: sun_direction(), colour: Vec3::splat(SUN as f32) };
    let mut s = cornell_scene(vec![sun]);
    let mut probes = uniform_probe([FAR as f32; 3]);
    probes.spacing = [spacing; 3];
    s.set_probes(probes);
    s.set_occluders(SceneOccluders { triangles: wall() });
    if let Some(m) = materials {
        s.set_occluder_materials(m);
    }
    s
}

/// A white Lambertian sphere's linear frame and mask. Without the live shadows: the light its
/// own shadow takes from the pre-rendered box below it is not what these tests check.
fn render(scene: &ViewerScene) -> (Vec<f32>, Vec<u8>) {
    render_with(
        scene,
        CompositorSettings { mode: CompositeMode::Fullscreen, shadows: None, ..Default::default() },
    )
}

fn render_with(scene: &ViewerScene, settings: CompositorSettings) -> (Vec<f32>, Vec<u8>) {
    let gpu = gpu();
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live =
        LiveObjects { sphere: Some(Sphere { centre: CENTRE, radius: RADIUS, material }), meshes: Vec::new() };
    let mut c = Compositor::new(&gpu, scene, settings).unwrap();
    c.render(&live).unwrap();
    (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
}

/// Interior pixels of the sphere away from its silhouette: (pixel index, world point, normal).
fn interior(scene: &ViewerScene, mask: &[u8]) -> Vec<(usize, DVec3, DVec3)> {
    let camera = scene.camera();
    let (w, _) = scene.size();
    (0..mask.len())
        .filter(|&k| mask[k] == 255 && inside_mask(mask, w as usize, k))
        .filter_map(|k| {
            let ray = camera.pixel_centre_world_ray(k as u32 % w, k as u32 / w);
            let t = ray_sphere(ray.origin, ray.direction, CENTRE, RADIUS)?;
            let p = ray.origin + t * ray.direction;
            let n = (p - CENTRE) / RADIUS;
            (n.dot(-ray.direction) > 0.05).then_some((k, p, n))
        })
        .collect()
}

/// A white matte sphere 0.15 from a sunlit matte wall (orange, radiance about 0.53 in red and
/// 0.07 in blue) in a probe field of radiance 0.3: on the side facing the wall each channel
/// tends to the wall's own radiance. The probes alone give 0.3 from every direction (the wall
/// is far closer than their spacing), so the check fails without the near field, in red (too
/// dark) as in blue (too bright).
#[test]
fn a_sphere_beside_a_sunlit_wall_gets_the_wall_s_light_from_its_material() {
    let s = scene(2.0, Some(wall_materials(matte_wall())));
    let (linear, mask) = render(&s);
    let pixels = interior(&s, &mask);
    assert!(pixels.len() > 5000, "{}", pixels.len());
    for ch in [0, 2] {
        let (mut shaded, mut total_error, mut worst, mut field_error) = (0, 0.0, 0.0f64, 0.0);
        for &(k, p, n) in &pixels {
            let want = radiance(p, n, ch);
            let got = f64::from(linear[4 * k + ch]);
            let error = (got - want).abs();
            total_error += error;
            worst = worst.max(error);
            // What the probes alone would give.
            let field = (SUN * n.dot(-sun_direction()).max(0.0) + PI * FAR) / PI;
            field_error += (field - want).abs();
            shaded += usize::from((field - want).abs() > 0.05 * FAR);
        }
        let checked = pixels.len() as f64;
        assert!(shaded > 1000, "channel {ch}: {shaded} pixels see the wall");
        // Sixteen directions resolve the wall's share of the hemisphere to about a sixteenth:
        // a pixel may be off by a sixteenth of (wall - field) per direction either side of the
        // wall's edge (a Python model of the same directions: at most 0.035 in red).
        let (mean, field_mean) = (total_error / checked, field_error / checked);
        assert!(
            mean < 0.25 * field_mean,
            "channel {ch}: mean error {mean} (the field alone: {field_mean}), worst {worst}"
        );
        assert!(worst < 0.06, "channel {ch}: mean error {mean}, worst {worst}");
    }
}

/// The same frame, bit for bit, with and without the wall's material when the wall lies beyond
/// the near field's reach (a probe spacing of 0.1, the wall 0.15 away), and when the wall is a
/// mirror (whose light the near field does not know): the probes' light stays as it was.
#[test]
fn without_a_known_surface_within_reach_the_probes_light_is_unchanged() {
    let without = render(&scene(0.1, None));
    let far_wall = render(&scene(0.1, Some(wall_materials(matte_wall()))));
    assert_eq!(without.1, far_wall.1);
    assert!(without.0 == far_wall.0, "a wall beyond reach changed the frame");
    let near_without = render(&scene(2.0, None));
    let mirror = SceneMaterial { specular: true, ..SceneMaterial::default() };
    let near_mirror = render(&scene(2.0, Some(wall_materials(mirror))));
    assert!(near_without.0 == near_mirror.0, "a mirror wall changed the frame");
    // A wall with a material changes it (so the comparisons above test something).
    let near_matte = render(&scene(2.0, Some(wall_materials(matte_wall()))));
    assert!(near_without.0 != near_matte.0);
}

/// The floor under the sphere: GAP below it, 2 on a side about the sphere's centre.
const GAP: f64 = 0.02;
/// The floor's Lambertian reflectance.
const FLOOR_ALBEDO: f64 = 0.8;

/// The sun over the floor, travelling down and toward the camera (+z), so that the sphere's
/// shadow on the floor lies partly in front of it, where its visible underside looks.
fn high_sun() -> DVec3 {
    DVec3::new(0.15, -1.0, 0.35).normalize()
}

fn floor() -> Vec<[DVec3; 3]> {
    let y = CENTRE.y - RADIUS - GAP;
    let c = [
        DVec3::new(CENTRE.x - 1.0, y, CENTRE.z - 1.0),
        DVec3::new(CENTRE.x + 1.0, y, CENTRE.z - 1.0),
        DVec3::new(CENTRE.x + 1.0, y, CENTRE.z + 1.0),
        DVec3::new(CENTRE.x - 1.0, y, CENTRE.z + 1.0),
    ];
    vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
}

/// The first floor point along p + t dir (t > 0), if any.
fn floor_hit(p: DVec3, dir: DVec3) -> Option<DVec3> {
    let y = CENTRE.y - RADIUS - GAP;
    let t = (y - p.y) / dir.y;
    let q = p + t * dir;
    (t > 0.0 && (q.x - CENTRE.x).abs() <= 1.0 && (q.z - CENTRE.z).abs() <= 1.0).then_some(q)
}

/// The floor's radiance at q: FLOOR_ALBEDO / pi times the sun's irradiance where the sphere
/// lets it through (`live`) and the probe field's (pi FAR) less the sphere's cosine-weighted
/// share of the sky, `(r / d)^2 cos`, faded out between 6 and 8 radii as the backdrop's
/// occlusion of indirect light is (`live`; the light the sphere itself sends the floor is left
/// out, as the near field leaves it).
fn floor_radiance(q: DVec3, live: bool) -> f64 {
    let up = DVec3::Y;
    let to_sun = -high_sun();
    let sun_seen = !live || ray_sphere(q, to_sun, CENTRE, RADIUS).is_none();
    let direct = if sun_seen { SUN * up.dot(to_sun) } else { 0.0 };
    let to_sphere = CENTRE - q;
    let d = to_sphere.length();
    let x = ((d - 6.0 * RADIUS) / (2.0 * RADIUS)).clamp(0.0, 1.0);
    let fade = 1.0 - x * x * (3.0 - 2.0 * x);
    let occluded = if live { (RADIUS / d).powi(2) * up.dot(to_sphere / d).max(0.0) * fade } else { 0.0 };
    FLOOR_ALBEDO / PI * (direct + PI * FAR * (1.0 - occluded))
}

/// Radiance of the white matte sphere's point p (unit normal n) over the floor: the sun's light
/// and the cosine-weighted hemisphere in 64 x 64 strata, the floor's radiance where a direction
/// meets it (floor_radiance with or without the sphere's shadow and occlusion, `live`), FAR
/// elsewhere, in f64.
fn radiance_over_floor(p: DVec3, n: DVec3, live: bool) -> f64 {
    let (t, b) = n.any_orthonormal_pair();
    let strata = 64;
    let mut sum = 0.0;
    for a in 0..strata {
        for c in 0..strata {
            let r = ((a as f64 + 0.5) / strata as f64).sqrt();
            let phi = 2.0 * PI * (c as f64 + 0.5) / strata as f64;
            let d = t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - r * r).sqrt();
            sum += floor_hit(p, d).map_or(FAR, |q| floor_radiance(q, live));
        }
    }
    let indirect = PI * sum / (strata * strata) as f64;
    (SUN * n.dot(-high_sun()).max(0.0) + indirect) / PI
}

/// The Cornell camera over a flat backdrop with light layers that hold nothing (the live
/// shadows then take nothing from the backdrop, and the sphere loses nothing to them), lit by
/// the high sun, with a uniform probe field of radiance FAR and spacing 2, the floor bound as
/// the scene's matte triangles.
fn floor_scene() -> ViewerScene {
    let sun = LiveLight::Distant { direction: high_sun(), colour: Vec3::splat(SUN as f32) };
    let mut s = flat_cornell(0.5, vec![sun]);
    let (w, h) = s.size();
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let layers =
        sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "distantlight")]);
    s.set_light_layers(SceneLayers { layers, layer_of_light: vec![Some(0)], area_samples: vec![vec![]] })
        .unwrap();
    let mut probes = uniform_probe([FAR as f32; 3]);
    probes.spacing = [2.0; 3];
    s.set_probes(probes);
    s.set_occluders(SceneOccluders { triangles: floor() });
    let albedo = Vec3::splat(FLOOR_ALBEDO as f32);
    s.set_occluder_materials(SceneMaterials {
        materials: vec![SceneMaterial { diffuse: albedo, ..SceneMaterial::default() }],
        of_triangle: vec![0, 0],
    });
    s
}

/// A white matte sphere GAP above a sunlit matte floor, with the live shadows on: the floor its
/// underside sees lies partly in the sphere's own shadow and loses the field's light the sphere
/// hides near contact, so the near field must take both from the floor's light. Without them
/// the underside would see the floor fully lit (0.145 off on average; measured 0.018 with them
/// from the sphere's near-field map, 0.023 traced per fragment); the check asks for a mean
/// error under a quarter of that.
#[test]
fn a_sphere_over_a_sunlit_floor_sees_its_own_shadow_on_the_floor() {
    let s = floor_scene();
    let (linear, mask) = render_with(&s, CompositorSettings::default());
    let pixels: Vec<_> = interior(&s, &mask).into_iter().filter(|&(_, _, n)| n.y < -0.2).collect();
    assert!(pixels.len() > 1000, "{}", pixels.len());
    let (mut total_error, mut worst, mut unshadowed_error, mut shadowed) = (0.0, 0.0f64, 0.0, 0);
    for &(k, p, n) in &pixels {
        let want = radiance_over_floor(p, n, true);
        let got = f64::from(linear[4 * k]);
        let error = (got - want).abs();
        total_error += error;
        worst = worst.max(error);
        // What the near field would give with the floor fully lit.
        let unshadowed = radiance_over_floor(p, n, false);
        unshadowed_error += (unshadowed - want).abs();
        shadowed += usize::from(unshadowed - want > 0.05 * FAR);
    }
    let checked = pixels.len() as f64;
    assert!(shadowed > 500, "{shadowed} pixels see the sphere's shadow on the floor");
    let (mean, unshadowed_mean) = (total_error / checked, unshadowed_error / checked);
    eprintln!(
        "{shadowed} of {checked} pixels see the shadow: mean error {mean} (fully lit {unshadowed_mean}), worst {worst}"
    );
    assert!(
        mean < 0.25 * unshadowed_mean,
        "mean error {mean} (the floor fully lit: {unshadowed_mean}), worst {worst}"
    );
    // Sixteen directions resolve the shadow's share of the hemisphere to about a sixteenth
    // (worst 0.057 measured from the map, 0.088 traced per fragment).
    assert!(worst < 0.08, "mean error {mean}, worst {worst}");
}

/// The white sphere beside the sunlit wall reads the near field from its map, drawn once per
/// texel over the half facing the eye, instead of tracing it per fragment: over the pixels the
/// near field changes, the two differ by a small share of that change (summed absolute
/// difference over the summed change: 0.041 in red and blue with 32^2 texels).
#[test]
fn the_sphere_s_near_field_map_agrees_with_tracing_per_fragment() {
    let s = scene(2.0, Some(wall_materials(matte_wall())));
    let settings = |near_field_maps| CompositorSettings {
        mode: CompositeMode::Fullscreen,
        shadows: None,
        near_field_maps,
        ..Default::default()
    };
    let (mapped, mask) = render_with(&s, settings(true));
    let (traced, _) = render_with(&s, settings(false));
    let (field, _) = render(&scene(2.0, None));
    let pixels = interior(&s, &mask);
    for ch in [0, 2] {
        let (mut difference, mut change, mut changed) = (0.0, 0.0, 0);
        for &(k, _, _) in &pixels {
            let near = f64::from(traced[4 * k + ch]) - f64::from(field[4 * k + ch]);
            if near.abs() > 0.01 {
                difference += (f64::from(mapped[4 * k + ch]) - f64::from(traced[4 * k + ch])).abs();
                change += near.abs();
                changed += 1;
            }
        }
        let relative = difference / change;
        eprintln!(
            "channel {ch}: {changed} pixels the near field changes, map against per fragment {relative}"
        );
        assert!(changed > 1000 && relative <= 0.1, "channel {ch}: {relative} over {changed} pixels");
    }
}

/// A moving frame (`amortise_while_moving`) leaves the near field out, so that the spheres' maps
/// are not drawn again every frame: the sphere moving beside the wall is the same, bit for bit,
/// with and without the wall's material; the frame at rest after it has the near field.
#[test]
fn a_moving_frame_leaves_the_near_field_to_the_frame_at_rest() {
    let frames = |scene: &ViewerScene| {
        let settings = CompositorSettings {
            mode: CompositeMode::Fullscreen,
            shadows: None,
            amortise_while_moving: true,
            ..Default::default()
        };
        let mut c = Compositor::new(&gpu(), scene, settings).unwrap();
        let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
        let at = |x: f64| LiveObjects {
            sphere: Some(Sphere { centre: CENTRE + DVec3::new(x, 0.0, 0.0), radius: RADIUS, material }),
            meshes: Vec::new(),
        };
        c.render(&at(0.01)).unwrap();
        c.render(&at(0.0)).unwrap();
        let moving = c.read_back_linear().unwrap().rgba;
        c.render(&at(0.0)).unwrap();
        (moving, c.read_back_linear().unwrap().rgba)
    };
    let (moving_with, rest_with) = frames(&scene(2.0, Some(wall_materials(matte_wall()))));
    let (moving_without, rest_without) = frames(&scene(2.0, None));
    assert!(moving_with == moving_without, "a moving frame drew the near field");
    assert!(rest_with != rest_without, "the frame at rest has no near field");
}

//! Shared test scenes and analytic ground truth.
#![allow(dead_code)]

use depth_remap::DepthTable;
use depth_remap::{Camera, CameraSettings, Clipping, Projection as RibProjection};
use glam::{DMat4, DVec3, Vec3};
use std::path::PathBuf;
use viewer::{Backends, Gpu, LiveLight, Rgba8Image, ToneMap, ViewerScene};

/// A GPU device. Fails, never skips, when there is no adapter: `cargo xtask test` installs
/// lavapipe (mesa-vulkan-drivers) so there always is one.
pub fn gpu() -> Gpu {
    let gpu = Gpu::new(Backends::default())
        .expect("no GPU adapter: run `cargo xtask install-test-deps` (lavapipe) or use a machine with a GPU");
    eprintln!("adapter: {}", gpu.describe());
    gpu
}

pub fn shared() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared"))
}

/// The Cornell reference camera (../shared/reference/cornell/cornell.rib): 512x512, fov 39.3077,
/// `Scale 1 1 -1; Translate 0 0 -3.9`.
pub fn cornell_camera() -> Camera {
    cornell_camera_of_size(512)
}

/// [`cornell_camera`] at `size`^2 pixels, for tests that draw smaller frames.
pub fn cornell_camera_of_size(size: u32) -> Camera {
    let camera_from_world =
        DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0)) * DMat4::from_translation(DVec3::new(0.0, 0.0, -3.9));
    Camera::new(CameraSettings {
        x_resolution: size,
        y_resolution: size,
        projection: RibProjection::Perspective { fov_degrees: 39.3077 },
        clipping: Clipping { near: 0.001, far: 100.0 },
        camera_from_world,
        ..CameraSettings::default()
    })
    .unwrap()
}

/// The exact depth table of the Cornell RIB.
pub fn cornell_depth() -> DepthTable {
    DepthTable::read(shared().join("reference/cornell/depth-analytic.depth"))
        .expect("the Cornell analytic depth")
}

/// The Cornell area light as the viewer sees it: a representative point at the emitter's
/// centroid, facing down.
pub fn cornell_light() -> LiveLight {
    LiveLight::Area {
        centroid: DVec3::new(0.0, 0.99, 0.01),
        normal: Some(DVec3::NEG_Y),
        two_sided: false,
        radiance: Vec3::new(18.387, 13.9873, 6.75357),
        area: 0.46 * 0.38,
        radius: (0.46f64 * 0.38 / std::f64::consts::PI).sqrt(),
    }
}

/// 64 samples of the Cornell box's emitter (`light_layers::area_samples` of its two triangles),
/// as the light layers bring them.
pub fn cornell_emitter_samples() -> Vec<viewer::AreaSample> {
    let corners = [
        DVec3::new(-0.23, 0.99, -0.18),
        DVec3::new(0.23, 0.99, -0.18),
        DVec3::new(0.23, 0.99, 0.2),
        DVec3::new(-0.23, 0.99, 0.2),
    ];
    let triangles = [[corners[0], corners[1], corners[2]], [corners[0], corners[2], corners[3]]];
    viewer::light_layers::area_samples(&triangles, 64)
}

/// A deterministic image in which neighbouring pixels differ and every byte value occurs.
pub fn noise_image(width: u32, height: u32) -> Rgba8Image {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut pixels = Vec::with_capacity(width as usize * height as usize * 4);
    for _ in 0..width * height {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let b = state.to_le_bytes();
        pixels.extend_from_slice(&[b[0], b[1], b[2], 255]);
    }
    Rgba8Image { width, height, pixels }
}

pub fn cornell_scene(lights: Vec<LiveLight>) -> ViewerScene {
    ViewerScene::new(cornell_camera(), noise_image(512, 512), cornell_depth(), lights, ToneMap::default())
        .unwrap()
}

/// Ray-sphere hit distance along a unit ray in f64 (nearest hit in front of the origin).
pub fn ray_sphere(origin: DVec3, direction: DVec3, centre: DVec3, radius: f64) -> Option<f64> {
    let f = origin - centre;
    let b = f.dot(direction);
    let q = f - b * direction;
    let disc = radius * radius - q.dot(q);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let (t0, t1) = (-b - s, -b + s);
    if t0 > 0.0 {
        Some(t0)
    } else if t1 > 0.0 {
        Some(t1)
    } else {
        None
    }
}

/// Ground truth of where a sphere (world space) is visible in front of the pre-rendered
/// surfaces, per pixel, and which pixels are too close to call in f32 (silhouette within
/// `1e-3` pixels' worth of the ray, or sphere and surface within `1e-6` relative distance).
pub struct Truth {
    pub visible: Vec<bool>,
    pub ambiguous: Vec<bool>,
    /// Pixels whose ray hits the sphere behind a pre-rendered surface.
    pub occluded: usize,
}

pub fn sphere_truth(scene: &ViewerScene, centre_world: DVec3, radius: f64) -> Truth {
    let camera = scene.camera();
    let (w, h) = scene.size();
    let c = camera.camera_from_world().transform_point3(centre_world);
    let mut visible = Vec::new();
    let mut ambiguous = Vec::new();
    let mut occluded = 0;
    let pixel_angle = 2.0 * camera.tan_half_fov().unwrap() / f64::from(h.min(w));
    for j in 0..h {
        for i in 0..w {
            let ray = camera.pixel_centre_ray(i, j);
            let d = f64::from(scene.depth().values()[(j * w + i) as usize]);
            let hit = ray_sphere(ray.origin, ray.direction, c, radius);
            let to_c = c - ray.origin;
            let perp = (to_c - to_c.dot(ray.direction) * ray.direction).length();
            let silhouette = ((perp - radius) / (to_c.length() * pixel_angle)).abs() < 1e-3;
            match hit {
                Some(t) => {
                    visible.push(t < d);
                    occluded += usize::from(t >= d);
                    ambiguous.push(silhouette || (d.is_finite() && ((t - d) / d).abs() < 1e-6));
                }
                None => {
                    visible.push(false);
                    ambiguous.push(silhouette);
                }
            }
        }
    }
    Truth { visible, ambiguous, occluded }
}

/// Intersection over union of two masks.
pub fn iou(a: &[bool], b: &[bool]) -> f64 {
    let inter = a.iter().zip(b).filter(|(x, y)| **x && **y).count();
    let union = a.iter().zip(b).filter(|(x, y)| **x || **y).count();
    if union == 0 { 1.0 } else { inter as f64 / union as f64 }
}

/// Raster position (pixels, y down) of a world point.
pub fn raster_of(camera: &depth_remap::Camera, world: DVec3) -> glam::DVec2 {
    let p = camera.camera_from_world().transform_point3(world);
    let t = camera.tan_half_fov().unwrap();
    let s = glam::DVec2::new(p.x / (p.z * t), p.y / (p.z * t));
    let sw = camera.screen_window();
    let (w, h) = camera.resolution();
    glam::DVec2::new(
        (s.x - sw.left) / (sw.right - sw.left) * f64::from(w),
        (sw.top - s.y) / (sw.top - sw.bottom) * f64::from(h),
    )
}

/// The Cornell camera and depth with a flat grey image.
pub fn grey_cornell(lights: Vec<LiveLight>, grey: u8) -> ViewerScene {
    ViewerScene::new(
        cornell_camera(),
        Rgba8Image::filled(512, 512, [grey, grey, grey, 255]),
        cornell_depth(),
        lights,
        ToneMap::default(),
    )
    .unwrap()
}

/// Whether any pixel of the 3x3 block about pixel `k` of a `width`-wide mask satisfies `test`.
fn any_in_block(mask: &[u8], width: usize, k: usize, test: impl Fn(u8) -> bool) -> bool {
    let height = mask.len() / width;
    let (i, j) = ((k % width) as i64, (k / width) as i64);
    (-1..=1).any(|dy| {
        (-1..=1).any(|dx| {
            let (x, y) = (i + dx, j + dy);
            x >= 0
                && y >= 0
                && (x as usize) < width
                && (y as usize) < height
                && test(mask[y as usize * width + x as usize])
        })
    })
}

/// Whether pixel `k` is on or next to a live object's mask: such pixels may hold part of its
/// antialiased edge.
pub fn next_to_mask(mask: &[u8], width: usize, k: usize) -> bool {
    any_in_block(mask, width, k, |m| m == 255)
}

/// Whether pixel `k` and its eight neighbours are all inside a live object's mask: such a pixel
/// shows the live object alone, away from its antialiased edge.
pub fn inside_mask(mask: &[u8], width: usize, k: usize) -> bool {
    !any_in_block(mask, width, k, |m| m != 255)
}

/// The world-space surface point of pixel (i, j) of the Cornell depth, when it is on the floor.
pub fn floor_point(scene: &ViewerScene, i: u32, j: u32) -> Option<DVec3> {
    let r = scene.depth().get(i, j).filter(|r| r.is_finite())?;
    let camera = scene.camera();
    let ray = camera.pixel_centre_ray(i, j);
    let p = camera.world_from_camera().transform_point3(ray.origin + ray.direction * f64::from(r));
    ((p.y + 1.0).abs() < 1e-3).then_some(p)
}

/// The share of the floor (the plane y = -1) under pixel (i, j) where `blocked(point)`, over the
/// pixel's area in f64 (32 x 32 points): the renderer filters each pixel over its area, so a hard
/// shadow's edge is a ramp about a pixel wide in its light layers.
pub fn floor_footprint_share(scene: &ViewerScene, i: u32, j: u32, blocked: impl Fn(DVec3) -> bool) -> f64 {
    let cells = 32;
    let mut hidden = 0;
    for b in 0..cells {
        for a in 0..cells {
            let raster = glam::DVec2::new(
                f64::from(i) + (f64::from(a) + 0.5) / f64::from(cells),
                f64::from(j) + (f64::from(b) + 0.5) / f64::from(cells),
            );
            let ray = scene.camera().world_ray_through_raster(raster);
            hidden +=
                usize::from(blocked(ray.origin + ray.direction * ((-1.0 - ray.origin.y) / ray.direction.y)));
        }
    }
    hidden as f64 / f64::from(cells * cells)
}

/// How a hard shadow on the Cornell floor compares with the f64 footprint shares: pixels wholly
/// in or out of it, the pixels on its edge, how many of the former are off, the worst error and
/// the mean error on the edge.
#[derive(Debug, Default)]
pub struct FootprintShadow {
    pub shadowed: usize,
    pub edge: usize,
    pub wrong: usize,
    pub worst: f64,
    pub mean_edge_error: f64,
}

/// Compares the floor pixels of `linear` (a `level` backdrop whose point-light layer holds it
/// all) away from the live objects' mask with `level` times one less the share of each pixel's
/// footprint where `blocked(point)` ([`floor_footprint_share`]).
pub fn footprint_shadow(
    scene: &ViewerScene,
    linear: &[f32],
    mask: &[u8],
    level: f32,
    blocked: impl Fn(DVec3) -> bool,
) -> FootprintShadow {
    let mut out = FootprintShadow::default();
    // Pixels next to the live object's mask hold part of its antialiased edge.
    for_each_backdrop_point(scene, mask, 1, Skip::NearMask, |i, j, k, p| {
        if (p.y + 1.0).abs() > 1e-3 {
            return; // The floor: the layer's normal (up) is its own.
        }
        let share = floor_footprint_share(scene, i, j, &blocked);
        let error = (f64::from(linear[4 * k]) - f64::from(level) * (1.0 - share)).abs();
        out.shadowed += usize::from(share == 1.0);
        out.worst = out.worst.max(error);
        if share > 0.0 && share < 1.0 {
            out.edge += 1;
            out.mean_edge_error += error;
        } else if error > 1e-6 {
            out.wrong += 1;
        }
    });
    out.mean_edge_error /= out.edge.max(1) as f64;
    eprintln!("{out:?}");
    out
}

/// Asserts that a hard shadow on the floor follows the pixels' footprints ([`footprint_shadow`]):
/// exact wholly in or out of it but for footprints an outline grazes between the f64 points, and
/// on its edge within what 4 x 4 points of each footprint resolve (a sixteenth of the level per
/// point), where one ray through each pixel's centre was on average a fifth of the level off.
/// At least `shadowed` pixels lie wholly in the shadow.
pub fn assert_footprint_shadow(f: &FootprintShadow, level: f32, shadowed: usize) {
    assert!(f.shadowed > shadowed && f.edge > 80, "{f:?}");
    assert!(
        f.wrong * 200 <= f.shadowed,
        "{} of {} pixels wholly in or out of the shadow wrong",
        f.wrong,
        f.shadowed
    );
    assert!(f.worst <= 0.15 * f64::from(level), "{f:?}");
    assert!(f.mean_edge_error <= 0.08 * f64::from(level), "{f:?}");
}

/// The Cornell camera and depth, 512x512, over a flat backdrop of linear `level`, lit by
/// `lights`.
pub fn flat_cornell(level: f32, lights: Vec<LiveLight>) -> ViewerScene {
    let (w, h) = (512u32, 512u32);
    let linear = [level, level, level, 1.0].repeat((w * h) as usize);
    let backdrop = viewer::Backdrop::from_linear(w, h, linear, 1.0).unwrap();
    ViewerScene::with_backdrop(cornell_camera(), backdrop, cornell_depth(), lights, ToneMap::default())
        .unwrap()
}

/// The Cornell camera and depth with a flat backdrop of `level`, one white point light at
/// `light` and light layers: all of the backdrop in `light.0` (or in `indirect` when
/// `indirect`), normals facing up.
pub fn layered_cornell(light: DVec3, indirect: bool, level: f32) -> ViewerScene {
    let (w, h) = (512u32, 512u32);
    let point = LiveLight::Point { position: light, colour: Vec3::splat(1.0) };
    let mut s = flat_cornell(level, vec![point]);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers =
        sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "pointlight")]);
    let target = if indirect { &mut layers.indirect } else { &mut layers.light[0] };
    target.iter_mut().for_each(|v| *v = [level; 3]);
    layers.normal.iter_mut().for_each(|v| *v = [0.0, 1.0, 0.0]);
    s.set_light_layers(viewer::SceneLayers {
        layers,
        layer_of_light: vec![Some(0)],
        area_samples: vec![vec![]],
    })
    .unwrap();
    s
}

/// One probe in a uniform environment of radiance `l`: its only SH coefficient is
/// `l * 4 pi * Y00`.
pub fn uniform_probe(l: [f32; 3]) -> sidecar::ProbeGrid {
    let mut sh = [[0.0f32; 3]; 9];
    let y00 = 0.282_094_8 * 4.0 * std::f32::consts::PI;
    sh[0] = l.map(|v| v * y00);
    let texels = sidecar::VISIBILITY_TEXELS * sidecar::VISIBILITY_TEXELS;
    sidecar::ProbeGrid {
        depth_fingerprint: 0,
        origin: [0.0, 0.0, 0.0],
        spacing: [1.0, 1.0, 1.0],
        counts: [1, 1, 1],
        radiance_sh: vec![sh],
        visibility: vec![[10.0, 100.0]; texels],
        emitters_seen: false,
    }
}

/// Which backdrop pixels a per-pixel check leaves out because of the live objects' mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skip {
    /// Pixels a live object covers.
    Covered,
    /// Pixels a live object covers and their neighbours (its antialiased edge).
    NearMask,
}

/// Calls `check(i, j, k, p)` for every `step`-th pixel in each direction (`k` its index) whose
/// depth is finite and which `skip` keeps, `p` being the world point the depth table measured
/// along the pixel's centre ray.
pub fn for_each_backdrop_point(
    scene: &ViewerScene,
    mask: &[u8],
    step: usize,
    skip: Skip,
    mut check: impl FnMut(u32, u32, usize, DVec3),
) {
    let (w, h) = scene.size();
    let camera = scene.camera();
    for j in (0..h).step_by(step) {
        for i in (0..w).step_by(step) {
            let k = (j * w + i) as usize;
            let covered = match skip {
                Skip::Covered => mask[k] == 255,
                Skip::NearMask => next_to_mask(mask, w as usize, k),
            };
            let Some(r) = scene.depth().get(i, j).filter(|r| r.is_finite() && !covered) else { continue };
            let ray = camera.pixel_centre_ray(i, j);
            check(
                i,
                j,
                k,
                camera.world_from_camera().transform_point3(ray.origin + ray.direction * f64::from(r)),
            );
        }
    }
}

/// The share of an area light's direct light on a floor point `p` (normal up) that `blocked(p,
/// sample)` hides, summed over the emitter's samples as `area cos_l cos_s / d^2`.
pub fn hidden_share(p: DVec3, samples: &[viewer::AreaSample], blocked: impl Fn(DVec3, DVec3) -> bool) -> f64 {
    let (mut total, mut hidden) = (0.0, 0.0);
    for sample in samples {
        let v = sample.position - p;
        let d2 = v.length_squared();
        let dir = v / d2.sqrt();
        let g = sample.area * sample.normal.dot(-dir).max(0.0) * dir.y.max(0.0) / d2;
        total += g;
        if blocked(p, sample.position) {
            hidden += g;
        }
    }
    if total > 0.0 { hidden / total } else { 0.0 }
}

/// The world-space hit point, unit normal and unit direction toward the eye of pixel `k`'s ray
/// on the sphere of `centre` and `radius` (`None` for a miss).
pub fn sphere_hit(
    scene: &ViewerScene,
    k: usize,
    centre: DVec3,
    radius: f64,
) -> Option<(DVec3, DVec3, DVec3)> {
    let camera = scene.camera();
    let (w, _) = scene.size();
    let world_from_camera = camera.camera_from_world().inverse();
    let ray = camera.pixel_centre_ray(k as u32 % w, k as u32 / w);
    let origin = world_from_camera.transform_point3(ray.origin);
    let direction = world_from_camera.transform_vector3(ray.direction).normalize();
    let t = ray_sphere(origin, direction, centre, radius)?;
    let p = origin + t * direction;
    Some((p, (p - centre).normalize(), -direction))
}

/// The ray tracer's glossy reflection of a field, `integral of f(v, l) cos(theta_l) L(l) dl`,
/// in f64 over a 256 x 256 midpoint grid of the lobe's half vectors (the integrand made smooth
/// by the lobe's own importance sampling, as `sidecar::blinn_albedo` integrates it).
pub fn lobe_integral(n: DVec3, v: DVec3, exponent: f64, field: impl Fn(DVec3) -> [f64; 3]) -> [f64; 3] {
    const STEPS: usize = 256;
    let cos_o = n.dot(v).max(1e-3);
    let t = n.any_orthonormal_vector();
    let b = n.cross(t);
    let mut sum = [0.0f64; 3];
    for i in 0..STEPS {
        let cos_h = ((i as f64 + 0.5) / STEPS as f64).powf(1.0 / (exponent + 1.0));
        let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
        for j in 0..STEPS {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / STEPS as f64;
            let h = t * (sin_h * phi.cos()) + b * (sin_h * phi.sin()) + n * cos_h;
            let o_dot_h = v.dot(h);
            let l = 2.0 * o_dot_h * h - v;
            let cos_l = n.dot(l);
            if o_dot_h <= 0.0 || cos_l <= 0.0 {
                continue;
            }
            let g = (2.0 * cos_h * cos_o / o_dot_h).min(2.0 * cos_h * cos_l / o_dot_h).min(1.0);
            let radiance = field(l);
            for c in 0..3 {
                sum[c] += (exponent + 2.0) / (exponent + 1.0) * g * o_dot_h / cos_o * radiance[c];
            }
        }
    }
    sum.map(|x| x / (STEPS * STEPS) as f64)
}

/// Two reflection probes, at x = -0.5 and 0.5 (y -0.2, z 0), that saw `texel(origin, d)`
/// through each texel: the radiance, the distance to the first surface and whether that
/// surface is specular (the sidecar's `specular` marks; none kept where no texel is).
pub fn two_probes_of(texel: impl Fn(DVec3, DVec3) -> (f64, f64, bool)) -> sidecar::ReflectionProbes {
    let n = sidecar::REFLECTION_TEXELS;
    let (mut levels, mut distance, mut specular) =
        (vec![Vec::new(); sidecar::REFLECTION_LEVELS], Vec::new(), Vec::new());
    for x in [-0.5, 0.5] {
        let origin = DVec3::new(x, -0.2, 0.0);
        let mut base = Vec::new();
        for t in 0..n * n {
            let d = DVec3::from(sidecar::octahedral_texel_center(n, t).map(f64::from)).normalize();
            let (l, s, marked) = texel(origin, d);
            base.push([l as f32; 3]);
            distance.push(s as f32);
            specular.push(marked);
        }
        for (all, level) in levels.iter_mut().zip(sidecar::reflection_levels(&base)) {
            all.extend(level);
        }
    }
    if !specular.contains(&true) {
        specular.clear();
    }
    sidecar::ReflectionProbes {
        depth_fingerprint: 0,
        origin: [-0.5, -0.2, 0.0],
        spacing: [1.0; 3],
        counts: [2, 1, 1],
        radiance: levels,
        distance,
        specular,
    }
}

/// A live glossy sphere's summed absolute error over its pixels facing down and toward the eye
/// in a frame (`rgba`, `mask`) of `scene`, against the f64 integral of `radiance(point, l)` over
/// the Blinn lobe of `exponent` (red channel), and how many pixels were summed; asserts that
/// more than 300 were, with a reference of at least `least` per pixel.
pub fn sphere_lobe_error(
    scene: &ViewerScene,
    (rgba, mask): (&[f32], &[u8]),
    (centre, radius, exponent): (DVec3, f64, f64),
    least: f64,
    radiance: impl Fn(DVec3, DVec3) -> f64,
) -> (f64, usize) {
    let (mut error, mut total, mut pixels) = (0.0, 0.0, 0);
    for k in (0..mask.len()).filter(|&k| mask[k] == 255) {
        let Some((p, n, v)) = sphere_hit(scene, k, centre, radius) else { continue };
        if n.y > -0.2 || n.dot(v) < 0.15 {
            continue;
        }
        let want = lobe_integral(n, v, exponent, |l| [radiance(p, l); 3])[0];
        error += (f64::from(rgba[4 * k]) - want).abs();
        total += want;
        pixels += 1;
    }
    assert!(pixels > 300 && total > least * pixels as f64, "{pixels} pixels facing down, total {total}");
    (error / total, pixels)
}

/// Snell refraction of unit `v` at unit normal `n` (`n . v < 0`), relative index `eta`.
pub fn refract(v: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -n.dot(v);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    (sin2_t <= 1.0).then(|| eta * v + (eta * cos_i - (1.0 - sin2_t).sqrt()) * n)
}

/// The exit ray of the ray `(origin, dir)` through a glass sphere `(centre, radius)` of index
/// `eta` (entering, crossing, leaving; `None` when it misses it or reflects totally inside).
pub fn glass_exit_ray(origin: DVec3, dir: DVec3, (c, r): (DVec3, f64), eta: f64) -> Option<(DVec3, DVec3)> {
    let t = ray_sphere(origin, dir, c, r)?;
    let entry = origin + t * dir;
    let inside = refract(dir, (entry - c) / r, 1.0 / eta)?.normalize();
    let exit = entry + inside * (-2.0 * (entry - c).dot(inside));
    let out = refract(inside, -(exit - c) / r, eta)?.normalize();
    Some((exit, out))
}

/// The distance from `o` (inside the box [-1, 1]^3) along unit `d` to the box's walls.
pub fn to_the_box_walls(o: DVec3, d: DVec3) -> f64 {
    (0..3).filter(|&a| d[a] != 0.0).map(|a| (d[a].signum() - o[a]) / d[a]).fold(f64::INFINITY, f64::min)
}

/// Each pixel of a `width` x `height` frame seen by `camera`, row by row: its index and its
/// centre ray in world space (origin and unit direction).
pub fn world_pixel_rays(
    camera: &Camera,
    width: u32,
    height: u32,
) -> impl Iterator<Item = (usize, DVec3, DVec3)> + '_ {
    let world_from_camera = camera.world_from_camera();
    (0..height).flat_map(move |j| {
        (0..width).map(move |i| {
            let ray = camera.pixel_centre_ray(i, j);
            let origin = world_from_camera.transform_point3(ray.origin);
            let dir = world_from_camera.transform_vector3(ray.direction).normalize();
            ((j * width + i) as usize, origin, dir)
        })
    })
}

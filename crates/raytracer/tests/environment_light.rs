//! Environment lights (`LightSource "envlight"`, `"environmentlight"`, `"infinite"`) against
//! closed forms: a Lambertian plane under a constant sky of radiance `L` has radiance `Kd L`
//! (irradiance `pi L`) for every integrator and in the photons, a lat-long map lights only
//! from where it is bright, importance sampling finds a single bright texel, and the light
//! layers keep summing to the image.

use glam::{DMat3, DVec3, Vec2, Vec3};
use raytracer::diagnostics::Diagnostics;
use raytracer::environment_light::EnvironmentLight;
use raytracer::photon::{PhotonMapSettings, PhotonMapper, unpack_unit};
use raytracer::render::{RenderOptions, RenderOutput, render};
use raytracer::sampling::{Rng, sample_uniform_sphere};
use raytracer::texture::Texture;
use raytracer::world::{PixelFootprint, World};
use std::f32::consts::PI;
use std::path::Path;
use std::sync::Arc;

/// An orthographic camera looking down (-z) at the square `[-w, w]^2` of the plane z = 0.
fn camera(w: f32, integrator: &str) -> String {
    format!(
        "Format 8 8 1\nPixelSamples 4 4\nPixelFilter \"box\" 1 1\nProjection \"orthographic\"\n\
         ScreenWindow -{w} {w} -{w} {w}\nTranslate 0 0 5\nRotate 180 1 0 0\nSurfaceIntegrator {integrator}\n"
    )
}

/// A matte plane of `Kd` 0.8 spanning `[-1, 1]^2` at z = 0 (its front faces +z).
const PLANE: &str = "Surface \"matte\" \"Kd\" [0.8]\nPolygon \"P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0]\n";

const PATH: &str = "\"path\"";
const DIRECT: &str = "\"directlighting\"";
const PHOTONS: &str = "\"photonmap\" \"integer indirectphotons\" [5000] \"integer causticphotons\" [0] \"integer finalgathersamples\" [4]";

fn run_in(dir: Option<&Path>, rib: &str, layers: bool) -> RenderOutput {
    let scene = match dir {
        Some(dir) => {
            let path = dir.join("scene.rib");
            std::fs::write(&path, rib).unwrap();
            rib_parser::load_scene(&path, &Default::default()).unwrap().scene
        }
        None => {
            rib_parser::load_bytes("env.rib", rib.as_bytes().to_vec(), &Default::default())
                .unwrap_or_else(|e| panic!("{}", e.render()))
                .scene
        }
    };
    let options =
        RenderOptions { threads: Some(2), layers, depth: layers, seed: 7, ..RenderOptions::default() };
    render(&scene, &options).unwrap()
}

fn mean(out: &RenderOutput) -> Vec3 {
    let pixels = &out.image.pixels;
    pixels.iter().map(|p| Vec3::new(p[0], p[1], p[2])).sum::<Vec3>() / pixels.len() as f32
}

#[test]
fn a_lambertian_plane_under_a_constant_sky_has_radiance_kd_l() {
    for integrator in [PATH, DIRECT, PHOTONS] {
        for light in [
            "LightSource \"envlight\" 1 \"intensity\" [0.5]",
            "LightSource \"infinite\" 1 \"color L\" [1 1 1] \"float scale\" [0.5]",
            "LightSource \"environmentlight\" 1 \"intensity\" [1] \"lightcolor\" [0.5 0.5 0.5]",
        ] {
            let out = run_in(
                None,
                &format!("{}WorldBegin\n{light}\n{PLANE}WorldEnd\n", camera(0.9, integrator)),
                false,
            );
            assert!(out.warnings.is_empty(), "{integrator} {light}: {:?}", out.warnings);
            let m = mean(&out);
            let expected = 0.8 * 0.5;
            assert!(
                (m - Vec3::splat(expected)).abs().max_element() < 0.02 * expected,
                "{integrator} {light}: {m} vs {expected}"
            );
        }
    }
}

/// Camera rays that leave the scene see the sky (no coverage), and a coloured sky tints.
#[test]
fn rays_leaving_the_scene_see_the_sky() {
    let rib = format!(
        "{}WorldBegin\nLightSource \"envlight\" 1 \"intensity\" [2] \"lightcolor\" [1 0.5 0.25]\n{PLANE}WorldEnd\n",
        camera(3.0, PATH)
    );
    let out = run_in(None, &rib, false);
    let corner = out.image.pixels[0];
    assert_eq!(corner, [2.0, 1.0, 0.5, 0.0]);
    let centre =
        (out.image.rgb(3, 3) + out.image.rgb(4, 3) + out.image.rgb(3, 4) + out.image.rgb(4, 4)) / 4.0;
    assert!((centre - Vec3::new(1.6, 0.8, 0.4)).abs().max_element() < 0.05 * 1.6, "{centre}");
}

/// The photons an environment light shoots carry its irradiance: on the plane's top, the
/// density of direct photons is `pi L`. (A sphere under the plane gives the photons a second
/// diffuse surface, so that the global maps are kept.)
#[test]
fn photons_from_a_constant_sky_carry_irradiance_pi_l() {
    let rib = format!(
        "{}WorldBegin\nLightSource \"envlight\" 1 \"intensity\" [0.5]\n{PLANE}\
         TransformBegin\nTranslate 0 0 -2\nSphere 0.5 -0.5 0.5 360\nTransformEnd\nWorldEnd\n",
        camera(0.9, PHOTONS)
    );
    let scene = rib_parser::load_bytes("env.rib", rib.into_bytes(), &Default::default()).unwrap().scene;
    let mut diagnostics = Diagnostics::default();
    let world =
        World::build(&scene, DVec3::new(0.0, 0.0, 5.0), PixelFootprint::Unknown, &mut diagnostics).unwrap();
    let settings = PhotonMapSettings {
        indirect_photons: 3_000,
        radiance_photons: false,
        caustic_photons: 0,
        scene_analysis: false,
        ..PhotonMapSettings::default()
    };
    let mapper = PhotonMapper::prepare(&world, settings, 11);
    let direct = mapper.maps()[1].expect("a direct photon map");
    // Render space has its origin at the eye, 5 above the plane's centre.
    let centre = Vec3::new(0.0, 0.0, -5.0);
    let r = 0.5f32;
    let power: Vec3 = direct
        .items()
        .iter()
        .filter(|ph| ph.p.distance_squared(centre) < r * r && unpack_unit(ph.n).z > 0.5)
        .map(|ph| ph.power)
        .sum();
    let irradiance = power / (PI * r * r);
    let expected = PI * 0.5;
    assert!(
        (irradiance - Vec3::splat(expected)).abs().max_element() < 0.03 * expected,
        "{irradiance} vs {expected}"
    );
}

fn write_png(path: &Path, width: u32, height: u32, f: impl Fn(u32, u32) -> [u8; 3]) {
    image::RgbImage::from_fn(width, height, |x, y| image::Rgb(f(x, y))).save(path).unwrap();
}

/// A lat-long map white above the horizon and black below, made by `MakeLatLongEnvironment`
/// (or read directly): the plane facing up sees white (`Kd L`); turned upside down by the
/// light's transformation, the sky is black above the plane.
#[test]
fn a_lat_long_map_lights_from_where_it_is_bright() {
    let dir = tempfile::tempdir().unwrap();
    write_png(&dir.path().join("sky.png"), 16, 64, |_, y| if y < 32 { [255; 3] } else { [0; 3] });
    let make = "MakeLatLongEnvironment \"sky.png\" \"sky.env\" \"box\" 1 1\n";
    for (name, flip, expected) in
        [("sky.env", "", 0.8), ("sky.png", "", 0.8), ("sky.env", "Rotate 180 1 0 0\n", 0.0)]
    {
        let rib = format!(
            "{make}{}WorldBegin\nTransformBegin\n{flip}LightSource \"envlight\" 1 \"string envmap\" [\"{name}\"]\nTransformEnd\n{PLANE}WorldEnd\n",
            camera(0.9, PATH)
        );
        let out = run_in(Some(dir.path()), &rib, false);
        assert!(out.warnings.is_empty(), "{:?}", out.warnings);
        let m = mean(&out);
        assert!((m - Vec3::splat(expected)).abs().max_element() < 0.02, "{name} {flip}: {m} vs {expected}");
    }
    // A map that cannot be read: a warning at the light's line, the light is skipped.
    let rib = format!(
        "{}WorldBegin\nLightSource \"envlight\" 1 \"string envmap\" [\"missing.tex\"]\n{PLANE}WorldEnd\n",
        camera(0.9, PATH)
    );
    let out = run_in(Some(dir.path()), &rib, false);
    let warning =
        out.warnings.iter().map(|w| w.to_string()).find(|w| w.contains("missing.tex")).expect("a warning");
    assert!(warning.contains("scene.rib:10:1: warning:") && warning.contains("light skipped"), "{warning}");
    assert_eq!(mean(&out), Vec3::ZERO);
}

/// Irradiance on an upward surface from a map whose only light is one bright texel: light
/// sampling converges to the answer (a fine quadrature of the bilinear map) with far fewer
/// samples than uniform sampling of the sphere.
#[test]
fn importance_sampling_finds_one_bright_texel() {
    let (w, h) = (64u32, 32u32);
    let (bx, by) = (20u32, 9u32);
    let texels =
        (0..w * h).map(|i| if i == by * w + bx { Vec3::splat(1000.0) } else { Vec3::ZERO }).collect();
    let map = Arc::new(Texture::from_rgb(w, h, texels).unwrap());
    let light = EnvironmentLight::new(Vec3::ONE, Some(map), DMat3::IDENTITY).unwrap();
    let integrand = |d: Vec3| light.radiance(d).x * d.z.max(0.0);

    // The reference: midpoint quadrature over the texel and its neighbours in (s, t).
    let n = 600;
    let (s0, s1) = ((bx as f64 - 1.0) / w as f64, (bx as f64 + 2.0) / w as f64);
    let (t0, t1) = ((by as f64 - 1.0) / h as f64, (by as f64 + 2.0) / h as f64);
    let mut reference = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let s = s0 + (s1 - s0) * (i as f64 + 0.5) / n as f64;
            let t = t0 + (t1 - t0) * (j as f64 + 0.5) / n as f64;
            let (phi, theta) = (s * std::f64::consts::TAU, t * std::f64::consts::PI);
            let d = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()).as_vec3();
            let jacobian = 2.0 * std::f64::consts::PI * std::f64::consts::PI * theta.sin();
            reference += f64::from(integrand(d)) * jacobian;
        }
    }
    reference *= (s1 - s0) * (t1 - t0) / (n * n) as f64;
    assert!(reference > 1.0, "{reference}");

    let estimate = |samples: u32, importance: bool, seed: u64| {
        let mut rng = Rng::new(seed, 1);
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..samples {
            let u: Vec2 = rng.uniform2();
            let v = if importance {
                light.sample(u).map_or(0.0, |(d, pdf, _)| f64::from(integrand(d) / pdf))
            } else {
                f64::from(integrand(sample_uniform_sphere(u)) * 4.0 * PI)
            };
            sum += v;
            sum2 += v * v;
        }
        let m = sum / f64::from(samples);
        (m, sum2 / f64::from(samples) - m * m)
    };
    // 16k samples: the mean's standard deviation is about 0.8% here.
    let (is_mean, is_variance) = estimate(16_384, true, 1);
    assert!((is_mean - reference).abs() < 0.03 * reference, "{is_mean} vs {reference}");
    let (uniform_mean, uniform_variance) = estimate(200_000, false, 2);
    assert!((uniform_mean - reference).abs() < 0.2 * reference, "{uniform_mean} vs {reference}");
    // Samples needed for a given error scale with the variance.
    assert!(uniform_variance > 100.0 * is_variance, "{uniform_variance} vs {is_variance}");
}

/// With light layers, the sky's direct light is its own layer, the sky seen by the camera is
/// emission, and the layers sum to the image.
#[test]
fn light_layers_hold_the_sky() {
    for integrator in [PATH, DIRECT, PHOTONS] {
        let rib = format!(
            "{}WorldBegin\nLightSource \"envlight\" 1 \"intensity\" [0.5]\n{PLANE}WorldEnd\n",
            camera(1.5, integrator)
        );
        let out = run_in(None, &rib, true);
        let layers = out.layers.as_ref().unwrap();
        let beauty = layers.beauty();
        for (p, (sum, pixel)) in beauty.iter().zip(&out.image.pixels).enumerate() {
            for c in 0..3 {
                assert!((sum[c] - pixel[c]).abs() <= 1e-5 * (1.0 + pixel[c].abs()), "{integrator} {p}");
            }
        }
        // The corner sees the sky, the centre the lit plane.
        assert_eq!(layers.emission[0], [0.5; 3], "{integrator}");
        let centre = 4 * 8 + 4;
        assert!(
            (layers.light[0][centre][0] - 0.4).abs() < 0.03,
            "{integrator}: {:?}",
            layers.light[0][centre]
        );
        assert!(layers.indirect[centre][0].abs() < 1e-3, "{integrator}: {:?}", layers.indirect[centre]);
    }
}

/// A cube-face environment whose +z face alone is white lights an upward plane like a square
/// emitter of side 2 at height 1: irradiance `4 L * 0.4352` (four corner form factors,
/// `pi F = (1/sqrt 2) atan(1/sqrt 2)` each), radiance `Kd E / pi`.
#[test]
fn a_cube_face_environment_lights_through_its_faces() {
    let dir = tempfile::tempdir().unwrap();
    for face in ["px", "nx", "py", "ny", "pz", "nz"] {
        let value = if face == "pz" { 255 } else { 0 };
        write_png(&dir.path().join(format!("{face}.png")), 32, 32, |_, _| [value; 3]);
    }
    let rib = format!(
        "MakeCubeFaceEnvironment \"px.png\" \"nx.png\" \"py.png\" \"ny.png\" \"pz.png\" \"nz.png\" \"cube.env\" 90 \"box\" 1 1\n\
         {}WorldBegin\nLightSource \"envlight\" 1 \"string envmap\" [\"cube.env\"]\n{PLANE}WorldEnd\n",
        camera(0.9, DIRECT)
    );
    let out = run_in(Some(dir.path()), &rib, false);
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    let corner = (0.5f32.sqrt()) * (0.5f32.sqrt()).atan();
    let expected = 0.8 * 4.0 * corner / PI;
    let m = mean(&out);
    assert!((m - Vec3::splat(expected)).abs().max_element() < 0.03 * expected, "{m} vs {expected}");
}

/// The sky seen through a partially transparent surface of coloured opacity is tinted by
/// `1 - Os`: a black surface of `Os = (1, 0.5, 0)` in front of a white sky shows `(0, 0.5, 1) L`.
#[test]
fn the_sky_through_coloured_opacity_is_tinted() {
    for integrator in [PATH, DIRECT, PHOTONS] {
        let rib = format!(
            "{}WorldBegin\nLightSource \"envlight\" 1 \"intensity\" [2]\n\
             Opacity [1 0.5 0]\nSurface \"matte\" \"Kd\" [0]\n{}WorldEnd\n",
            camera(0.9, integrator),
            PLANE.lines().nth(1).unwrap()
        );
        let m = mean(&run_in(None, &rib, false));
        assert!((m - Vec3::new(0.0, 1.0, 2.0)).abs().max_element() < 0.15, "{integrator}: {m}");
    }
}

/// RenderMan's `"blur"` on an environment light: the map through a box filter `blur` wide in
/// `s` and `t`. The sky of `a_lat_long_map_lights_from_where_it_is_bright` (white above the
/// horizon, black below, its top row repeated beyond the pole) blurred by 1 is `1 - t` above
/// the horizon (`t = theta / pi`), so an upward plane of `Kd` 0.8 has radiance
/// `0.8 * 2 * int (1 - theta / pi) cos sin dtheta = 0.8 * (1 - 1 / 4) = 0.6` instead of 0.8.
#[test]
fn an_environment_light_blur_filters_its_map() {
    let dir = tempfile::tempdir().unwrap();
    write_png(&dir.path().join("sky.png"), 16, 64, |_, y| if y < 32 { [255; 3] } else { [0; 3] });
    let rib = format!(
        "{}WorldBegin\nLightSource \"envlight\" 1 \"string envmap\" [\"sky.png\"] \"float blur\" [1]\n{PLANE}WorldEnd\n",
        camera(0.9, PATH)
    );
    let out = run_in(Some(dir.path()), &rib, false);
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    let m = mean(&out);
    eprintln!("blurred sky: plane radiance {m} against 0.6");
    assert!((m - Vec3::splat(0.6)).abs().max_element() < 0.015, "{m} vs 0.6");
    // A width that is no width: a warning, and the map unblurred.
    let rib = rib.replace("[1]", "[-1]");
    let out = run_in(Some(dir.path()), &rib, false);
    assert!(out.warnings.iter().any(|w| w.to_string().contains("\"blur\" -1")), "{:?}", out.warnings);
    assert!((mean(&out) - Vec3::splat(0.8)).abs().max_element() < 0.02);
}

//! The sidecar's transmission layers (docs/sidecar.md): through a glass sphere, each pixel's
//! exit ray is the refraction of its camera ray through the sphere (checked by tracing it back
//! through the sphere in f64, independently of the ray tracer's code, to the eye), its
//! transmittance is the two interfaces' Fresnel transmission, its distance reaches the wall
//! behind, and `transmitted` is a part of `indirect` (the layers still sum to the image).

use raytracer::render::{RenderOptions, RenderOutput, render};

type V = [f64; 3];

fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn add(a: V, b: V, s: f64) -> V {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}
fn unit(a: V) -> V {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// Snell refraction of unit direction `v` at unit normal `n` (`n . v < 0`), relative index
/// `eta = n1 / n2`; `None` on total internal reflection.
fn refract(v: V, n: V, eta: f64) -> Option<V> {
    let cos_i = -dot(n, v);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t > 1.0 {
        return None;
    }
    Some(add([eta * v[0], eta * v[1], eta * v[2]], n, eta * cos_i - (1.0 - sin2_t).sqrt()))
}

/// Unpolarised Fresnel reflectance from index `n1` into `n2` at incidence cosine `cos_i`.
fn fresnel(n1: f64, n2: f64, cos_i: f64) -> f64 {
    let sin_t = n1 / n2 * (1.0 - cos_i * cos_i).sqrt();
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    0.5 * (rs * rs + rp * rp)
}

const ETA: f64 = 1.5;
/// The eye in world space (the camera's `Translate 0 0 4`) and the wall's plane `z = WALL`.
const EYE: V = [0.0, 0.0, -4.0];
const WALL: f64 = 3.0;

/// A glass sphere of radius 1 at the origin in front of a matte wall lit from above, one
/// sample per pixel in a box filter (each pixel is its one sample).
fn glass_scene(integrator: &str) -> String {
    format!(
        "Format 16 16 1\nPixelSamples 1 1\nPixelFilter \"box\" 1 1\n\
         Projection \"perspective\" \"fov\" [40]\nTranslate 0 0 4\n\
         SurfaceIntegrator {integrator}\nWorldBegin\n\
         LightSource \"pointlight\" 1 \"from\" [0 3 2] \"intensity\" [6]\n\
         AttributeBegin\nSurface \"matte\"\n\
         Polygon \"P\" [-20 -20 {WALL}  20 -20 {WALL}  20 20 {WALL}  -20 20 {WALL}]\nAttributeEnd\n\
         AttributeBegin\nSurface \"glass\" \"float eta\" [{ETA}]\nSphere 1 -1 1 360\nAttributeEnd\n\
         WorldEnd\n"
    )
}

const PATH: &str = "\"path\"";
const PHOTONS: &str = "\"photonmap\" \"integer indirectphotons\" [2000] \"integer causticphotons\" [2000] \"integer finalgathersamples\" [4]";
const DIRECT: &str = "\"directlighting\"";

fn run(rib: &str) -> RenderOutput {
    let scene = rib_parser::load_bytes("glass.rib", rib.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let options = RenderOptions { depth: true, layers: true, threads: Some(2), ..Default::default() };
    render(&scene, &options).unwrap()
}

/// Traces the exit ray (origin `o` on the sphere, direction `d` leaving it) back through the
/// sphere: the camera ray it came from, as its point of entry and the direction toward the
/// camera, and the cosine of incidence there.
fn camera_ray_of(o: V, d: V) -> (V, V, f64) {
    let inside = refract([-d[0], -d[1], -d[2]], unit(o), 1.0 / ETA).expect("the exit ray entered");
    let entry = add(o, inside, -2.0 * dot(o, inside));
    let n = unit(entry);
    let back = refract(inside, [-n[0], -n[1], -n[2]], ETA).expect("the ray left the sphere");
    (entry, back, dot(back, n))
}

#[test]
fn the_exit_ray_is_the_camera_ray_refracted_through_the_sphere() {
    for integrator in [DIRECT, PHOTONS, PATH] {
        let out = run(&glass_scene(integrator));
        let layers = out.layers.as_ref().unwrap();
        assert!(layers.has_transmission(), "{integrator}");
        let mut checked = 0;
        for p in 0..layers.pixel_count() {
            let t = layers.transmittance[p];
            // Grazing rays refract ill-conditioned: the check keeps well-transmitting pixels.
            if t[1] < 0.5 {
                continue;
            }
            let o = layers.transmission_origin[p].map(f64::from);
            let d = layers.transmission_direction[p].map(f64::from);
            assert!((dot(o, o).sqrt() - 1.0).abs() < 1e-4, "{integrator} pixel {p}: origin {o:?}");
            assert!((dot(d, d).sqrt() - 1.0).abs() < 1e-5, "{integrator} pixel {p}: direction {d:?}");
            let (entry, toward_camera, cos_i) = camera_ray_of(o, d);
            // The eye lies on the camera ray, within the renderer's f32 geometry (3e-4 rad seen
            // from the sphere; a ray not refracted, or refracted with another index, misses by
            // tenths).
            let to_eye = add(EYE, entry, -1.0);
            let along = dot(to_eye, toward_camera);
            let miss = (dot(to_eye, to_eye) - along * along).max(0.0).sqrt();
            assert!(
                along > 0.0 && miss < 1.5e-3 * dot(to_eye, to_eye).sqrt(),
                "{integrator} pixel {p}: the camera ray misses the eye by {miss}"
            );
            // The wall is this far along the exit ray.
            let distance = f64::from(layers.transmission_distance[p][0]);
            let expected = (WALL - o[2]) / d[2];
            assert!(
                (distance - expected).abs() < 1e-3 * expected,
                "{integrator} pixel {p}: {distance} vs {expected}"
            );
            // Whitted-style integrators weigh the chain by both interfaces' transmission
            // (the same angle inside at both); the path tracer by its sample's weight, 1.
            let expected_t = if integrator == PATH { 1.0 } else { (1.0 - fresnel(1.0, ETA, cos_i)).powi(2) };
            for c in 0..3 {
                assert!(
                    (f64::from(t[c]) - expected_t).abs() < 1e-4,
                    "{integrator} pixel {p}: {t:?} vs {expected_t}"
                );
            }
            checked += 1;
        }
        assert!(checked >= 40, "{integrator}: {checked} pixels checked");
    }
}

#[test]
fn transmitted_is_a_part_of_indirect_and_the_layers_sum_to_the_image() {
    for integrator in [DIRECT, PHOTONS, PATH] {
        let out = run(&glass_scene(integrator));
        let layers = out.layers.as_ref().unwrap();
        let beauty = layers.beauty();
        let mut seen = 0.0f64;
        for (p, sum) in beauty.iter().enumerate() {
            let pixel = out.image.pixels[p];
            for c in 0..3 {
                let tolerance = 1e-5 * (1.0 + pixel[c].abs());
                assert!((sum[c] - pixel[c]).abs() <= tolerance, "{integrator} pixel {p}");
                // The chain's light, with the glass's reflection, is at most what the glass
                // pixel shows beyond its direct light (internal reflections add the rest).
                let parts = layers.transmitted[p][c] + layers.reflected[p][c];
                assert!(
                    parts <= layers.indirect[p][c] + 1e-4 * (1.0 + pixel[c].abs()),
                    "{integrator} pixel {p}: {parts} > indirect {}",
                    layers.indirect[p][c]
                );
            }
            if layers.transmittance[p][1] > 0.5 && integrator != PATH {
                // Internal reflections bring a few percent at most.
                let (parts, indirect) =
                    (layers.transmitted[p][1] + layers.reflected[p][1], layers.indirect[p][1]);
                assert!(
                    parts >= 0.9 * indirect && indirect > 0.0,
                    "{integrator} pixel {p}: {parts} vs {indirect}"
                );
            }
            seen += f64::from(layers.transmitted[p][1]);
        }
        assert!(seen > 0.0, "{integrator}");
    }
    // Without glass there is no transmission group.
    let plain =
        run(&glass_scene(DIRECT).replace("Surface \"glass\" \"float eta\" [1.5]", "Surface \"matte\""));
    assert!(!plain.layers.unwrap().has_transmission());
}

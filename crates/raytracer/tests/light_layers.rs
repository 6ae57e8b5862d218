//! The sidecar's light layers (docs/sidecar.md): for every integrator the layers sum to the
//! image, each light's layer holds that light alone, and normal and albedo describe the
//! primary hit.

use raytracer::render::{RenderOptions, RenderOutput, render};

/// A floor (matte, Kd 0.8, red-tinted) seen from above at an angle, a matte sphere and a mirror
/// sphere on it, two point lights on either side and a small area light overhead.
fn scene(integrator: &str, intensities: [f32; 3]) -> String {
    let [a, b, c] = intensities;
    format!(
        "Format 12 10 1\nPixelSamples 2 2\nPixelFilter \"gaussian\" 2 2\n\
         Projection \"perspective\" \"fov\" [60]\nTranslate 0 0 4\n\
         SurfaceIntegrator {integrator}\nWorldBegin\n\
         LightSource \"pointlight\" 1 \"from\" [-2 2 -1] \"intensity\" [{a}]\n\
         LightSource \"pointlight\" 2 \"from\" [2 1.5 -1] \"intensity\" [{b}]\n\
         AttributeBegin\nAreaLightSource \"arealight\" 3 \"intensity\" [{c}]\nSides 2\n\
         Polygon \"P\" [-0.3 2.5 -0.3  0.3 2.5 -0.3  0.3 2.5 0.3  -0.3 2.5 0.3]\nAttributeEnd\n\
         AttributeBegin\nColor [1 0.5 0.25]\nSurface \"matte\" \"Kd\" [0.8]\n\
         Polygon \"P\" [-3 -1 -3  3 -1 -3  3 -1 3  -3 -1 3]\nAttributeEnd\n\
         AttributeBegin\nSurface \"matte\"\nTranslate -0.5 -0.5 0\nSphere 0.5 -0.5 0.5 360\nAttributeEnd\n\
         AttributeBegin\nSurface \"mirror\"\nTranslate 0.7 -0.6 0.3\nSphere 0.4 -0.4 0.4 360\nAttributeEnd\n\
         WorldEnd\n"
    )
}

const PATH: &str = "\"path\"";
const PHOTONS: &str = "\"photonmap\" \"integer indirectphotons\" [2000] \"integer causticphotons\" [2000] \"integer finalgathersamples\" [4]";
const DIRECT: &str = "\"directlighting\"";

fn run(rib: &str) -> RenderOutput {
    let scene = rib_parser::load_bytes("layers.rib", rib.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let options = RenderOptions { depth: true, layers: true, threads: Some(2), ..Default::default() };
    render(&scene, &options).unwrap()
}

#[test]
fn layers_sum_to_the_image_for_every_integrator() {
    for integrator in [PATH, PHOTONS, DIRECT] {
        let out = run(&scene(integrator, [1.0, 1.0, 1.0]));
        let layers = out.layers.as_ref().expect("layers were asked for");
        assert_eq!((layers.width, layers.height), (12, 10));
        assert_eq!(layers.light.len(), 3);
        assert_eq!(layers.depth_fingerprint, sidecar::depth_fingerprint(&out.depth.as_ref().unwrap().values));
        let beauty = layers.beauty();
        let mut light_total = [0.0f64; 3];
        let mut indirect_total = 0.0f64;
        for (p, (sum, pixel)) in beauty.iter().zip(&out.image.pixels).enumerate() {
            for c in 0..3 {
                let tolerance = 1e-5 * (1.0 + pixel[c].abs());
                assert!(
                    (sum[c] - pixel[c]).abs() <= tolerance,
                    "{integrator} pixel {p}: {sum:?} vs {pixel:?}"
                );
            }
            for (k, total) in light_total.iter_mut().enumerate() {
                *total += f64::from(layers.light[k][p][1]);
            }
            indirect_total += f64::from(layers.indirect[p][1]);
        }
        // Every light reaches the scene directly, and light bounces (floor to sphere, mirror).
        assert!(light_total.iter().all(|&t| t > 0.0), "{integrator}: {light_total:?}");
        if integrator != DIRECT {
            assert!(indirect_total > 0.0, "{integrator}: no indirect light");
        }
    }
}

#[test]
fn each_light_layer_holds_that_light_alone() {
    // Point lights are sampled deterministically by the direct-lighting and photon-mapping
    // integrators: a light's layer does not change when another light is switched off, and
    // the switched-off light's layer is black.
    for integrator in [DIRECT, PHOTONS] {
        let both = run(&scene(integrator, [1.0, 1.0, 0.0]));
        let first = run(&scene(integrator, [1.0, 0.0, 0.0]));
        let (both, first) = (both.layers.unwrap(), first.layers.unwrap());
        assert!(first.light[1].iter().all(|p| *p == [0.0; 3]), "{integrator}");
        assert!(first.light[2].iter().all(|p| *p == [0.0; 3]), "{integrator}");
        assert!(both.light[1].iter().any(|p| p[0] > 0.0), "{integrator}");
        for (a, b) in both.light[0].iter().zip(&first.light[0]) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-5 * (1.0 + a[c].abs()), "{integrator}: {a:?} vs {b:?}");
            }
        }
    }
}

#[test]
fn normal_and_albedo_describe_the_primary_hit() {
    let out = run(&scene(DIRECT, [1.0, 1.0, 1.0]));
    let layers = out.layers.unwrap();
    // The bottom-left pixel sees only the floor: normal +y, albedo Kd * Color.
    let p = (layers.height as usize - 1) * layers.width as usize;
    let n = layers.normal[p];
    assert!((n[1] - 1.0).abs() < 1e-4 && n[0].abs() < 1e-4 && n[2].abs() < 1e-4, "{n:?}");
    let a = layers.albedo[p];
    assert!((a[0] - 0.8).abs() < 1e-5 && (a[1] - 0.4).abs() < 1e-5 && (a[2] - 0.2).abs() < 1e-5, "{a:?}");
    // Without layers asked for, none are made.
    let scene =
        rib_parser::load_bytes("layers.rib", scene(DIRECT, [1.0; 3]).into_bytes(), &Default::default())
            .unwrap()
            .scene;
    assert!(
        render(&scene, &RenderOptions { depth: true, threads: Some(1), ..Default::default() })
            .unwrap()
            .layers
            .is_none()
    );
}

/// A camera facing a tinted mirror that fills its view and reflects a matte wall behind the
/// camera, lit by a point light between them.
fn mirror_scene(integrator: &str) -> String {
    format!(
        "Format 8 6 1\nPixelSamples 2 2\nPixelFilter \"box\" 1 1\n\
         Projection \"perspective\" \"fov\" [40]\nTranslate 0 0 4\n\
         SurfaceIntegrator {integrator}\nWorldBegin\n\
         LightSource \"pointlight\" 1 \"from\" [0 0 -6] \"intensity\" [4]\n\
         AttributeBegin\nColor [0.9 0.8 0.7]\nSurface \"mirror\"\n\
         Polygon \"P\" [-5 -5 0  5 -5 0  5 5 0  -5 5 0]\nAttributeEnd\n\
         AttributeBegin\nSurface \"matte\"\n\
         Polygon \"P\" [-20 -20 -8  20 -20 -8  20 20 -8  -20 20 -8]\nAttributeEnd\n\
         WorldEnd\n"
    )
}

/// Every pixel sees the mirror alone: `reflectance` is its `Kr * Color` and `reflected` all of
/// its light (the whole `indirect` layer, the image), for every integrator; a scene without
/// specular surfaces has no reflection at all.
#[test]
fn reflectance_and_reflected_describe_the_primary_specular_reflection() {
    for integrator in [PATH, PHOTONS, DIRECT] {
        let out = run(&mirror_scene(integrator));
        let layers = out.layers.unwrap();
        assert!(layers.has_reflection(), "{integrator}");
        for p in 0..layers.pixel_count() {
            let (r, reflected, indirect) = (layers.reflectance[p], layers.reflected[p], layers.indirect[p]);
            for c in 0..3 {
                assert!(
                    (r[c] - [0.9, 0.8, 0.7][c]).abs() < 1e-5,
                    "{integrator} pixel {p}: reflectance {r:?}"
                );
                let tolerance = 1e-4 * (1.0 + indirect[c].abs());
                assert!(
                    (reflected[c] - indirect[c]).abs() <= tolerance && indirect[c] > 0.0,
                    "{integrator} pixel {p}: reflected {reflected:?}, indirect {indirect:?}"
                );
            }
        }
    }
    let plain = run(&scene(DIRECT, [1.0; 3]).replace("Surface \"mirror\"", "Surface \"matte\""));
    assert!(!plain.layers.unwrap().has_reflection());
}

/// A camera facing a metal plane that fills its view: `glossy` is its Blinn lobe's weight
/// `Ks * Color` and `glossy_exponent` its exponent `1 / roughness`; a plastic plane's is its
/// `Ks * specularcolor` (energy-conserved with `Kd`), and the mirror scene has none.
#[test]
fn glossy_layers_describe_the_primary_blinn_lobe() {
    let plane = |surface: &str| mirror_scene(PHOTONS).replace("Surface \"mirror\"", surface);
    for integrator in [PATH, PHOTONS, DIRECT] {
        let metal = plane("Surface \"metal\" \"Ks\" [0.8] \"roughness\" [0.05]").replace(PHOTONS, integrator);
        let layers = run(&metal).layers.unwrap();
        assert!(layers.has_glossy() && !layers.has_reflection(), "{integrator}");
        for p in 0..layers.pixel_count() {
            let (g, e) = (layers.glossy[p], layers.glossy_exponent[p]);
            for c in 0..3 {
                let expected = 0.8 * [0.9, 0.8, 0.7][c];
                assert!((g[c] - expected).abs() < 1e-5, "{integrator} pixel {p}: glossy {g:?}");
                assert!((e[c] - 20.0).abs() < 1e-3, "{integrator} pixel {p}: exponent {e:?}");
            }
        }
    }
    let plastic = run(&plane("Surface \"plastic\" \"Kd\" [0.5] \"Ks\" [0.3] \"roughness\" [0.25]"));
    let layers = plastic.layers.unwrap();
    assert!(layers.glossy.iter().all(|g| g.iter().all(|&v| (v - 0.3).abs() < 1e-5)));
    assert!(layers.glossy_exponent.iter().all(|e| e.iter().all(|&v| (v - 4.0).abs() < 1e-3)));
    assert!(!run(&mirror_scene(DIRECT)).layers.unwrap().has_glossy());
}

//! The sidecar's caustic photons (docs/sidecar.md, "Caustic photons"): the exported photons and
//! kernels reproduce the render's own caustic, and what they say a blocker takes from it, summed
//! in `f64` from the export alone, is what the render with the blocker inserted loses.

use raytracer::render::{RenderOptions, RenderOutput, render};

/// A point light, a glass sphere that focuses it onto a matte floor beside the sphere, and
/// optionally a matte blocker. Without an indirect map the `indirect` layer is the caustic alone.
fn scene(blocker: Option<([f32; 3], f32)>) -> String {
    let blocker = blocker.map_or(String::new(), |([x, y, z], r)| {
        format!("AttributeBegin\nSurface \"matte\"\nTranslate {x} {y} {z}\nSphere {r} -{r} {r} 360\nAttributeEnd\n")
    });
    format!(
        "Format 48 36 1\nPixelSamples 4 4\nPixelFilter \"box\" 1 1\n\
         Projection \"perspective\" \"fov\" [50]\nTranslate 0 0 4\n\
         SurfaceIntegrator \"photonmap\" \"integer indirectphotons\" [0] \"integer causticphotons\" [40000] \"integer nused\" [40]\n\
         WorldBegin\n\
         LightSource \"pointlight\" 1 \"from\" [-2 3 0] \"intensity\" [20]\n\
         AttributeBegin\nSurface \"matte\" \"Kd\" [0.7]\n\
         Polygon \"P\" [-4 -1 -4  4 -1 -4  4 -1 4  -4 -1 4]\nAttributeEnd\n\
         AttributeBegin\nSurface \"glass\" \"float eta\" [1.5]\nSphere 0.4 -0.4 0.4 360\nAttributeEnd\n\
         {blocker}WorldEnd\n"
    )
}

fn run(rib: &str) -> RenderOutput {
    let scene = rib_parser::load_bytes("caustic.rib", rib.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let options = RenderOptions { depth: true, layers: true, threads: Some(2), ..Default::default() };
    render(&scene, &options).unwrap()
}

/// Sums of `a` and `b`'s luminance-free totals (all channels) over the pixels `keep` selects.
fn total(values: impl Iterator<Item = [f64; 3]>) -> f64 {
    values.map(|v| v[0] + v[1] + v[2]).sum()
}

#[test]
fn exported_photons_reproduce_the_caustic_and_what_a_blocker_takes_from_it() {
    let without = run(&scene(None));
    let caustics = without.caustics.as_ref().expect("a glass sphere over a floor has a caustic map");
    let layers = without.layers.as_ref().unwrap();
    assert_eq!(caustics.depth_fingerprint, layers.depth_fingerprint);
    assert_eq!((caustics.width, caustics.height), (48, 36));
    // Every path starts at the point light: a small sphere around it blocks every photon, and
    // the loss is then the whole caustic estimate, which the indirect layer holds.
    let everything = caustics.blocked_loss(&[([-2.0, 3.0, 0.0], 1e-3)]);
    let lit: Vec<usize> =
        (0..everything.len()).filter(|&p| everything[p].iter().sum::<f64>() > 0.05).collect();
    assert!(lit.len() > 20, "the caustic covers {} pixels", lit.len());
    let layer = |out: &RenderOutput, p: usize| out.layers.as_ref().unwrap().indirect[p].map(f64::from);
    let rendered = total(lit.iter().map(|&p| layer(&without, p)));
    let exported = total(lit.iter().map(|&p| everything[p]));
    // The render averages 16 samples over each pixel, the export estimates at its centre: a
    // focused caustic is sharper than a pixel, so single pixels differ by up to a quarter at the
    // peak (measured), their sum by 5.5%.
    assert!(
        (exported / rendered - 1.0).abs() < 0.08,
        "caustic {rendered} rendered, {exported} from the export"
    );

    // A blocker halfway between the light and the glass sphere, then one between the glass
    // sphere and the caustic, takes part of it: the same part of the export's estimates as of
    // the render's (fractions, so that the pixel footprint above cancels).
    for blocker in [([-1.0f32, 1.5, 0.0], 0.15f32), ([0.3, -0.55, 0.0], 0.12)] {
        let with = run(&scene(Some(blocker)));
        let loss = caustics.blocked_loss(&[(blocker.0.map(f64::from), f64::from(blocker.1))]);
        let predicted = total(lit.iter().map(|&p| loss[p])) / exported;
        let lost = 1.0 - total(lit.iter().map(|&p| layer(&with, p))) / rendered;
        assert!(predicted > 0.2, "{blocker:?} takes {predicted} of the caustic");
        assert!(
            (predicted / lost - 1.0).abs() < 0.1,
            "{blocker:?}: the render loses {lost} of its caustic, the export predicts {predicted}"
        );
    }
    // A sphere beside every path takes nothing.
    assert!(caustics.blocked_loss(&[([1.5, 2.0, -1.5], 0.3)]).iter().all(|v| *v == [0.0; 3]));
}

#[test]
fn a_render_without_a_caustic_map_exports_no_caustics() {
    let matte = scene(None).replace("Surface \"glass\" \"float eta\" [1.5]", "Surface \"matte\"");
    assert!(run(&matte).caustics.is_none());
    // Without a depth table (no sidecar) nothing is kept either.
    let scene =
        rib_parser::load_bytes("caustic.rib", scene(None).into_bytes(), &Default::default()).unwrap().scene;
    let out = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap();
    assert!(out.caustics.is_none());
}

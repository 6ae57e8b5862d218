//! Progressive photon mapping and rendering in passes (`--time`, `--target-error`): images
//! independent of the thread count, error that keeps falling with passes, adaptive sampling
//! that stops converged pixels and says so.

use raytracer::integrators::IntegratorKind;
use raytracer::passes::StopReason;
use raytracer::photon::{GatherSampling, PhotonMapSettings};
use raytracer::render::{RenderOptions, RenderOutput, render};
use rib_parser::scene::Scene;
use std::path::PathBuf;
use std::time::Duration;

/// `shared/reference/cornell` beside the checkout (or beside a directory above it, for a git
/// worktree nested one level deeper).
fn reference_dir() -> PathBuf {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest
        .ancestors()
        .map(|d| d.join("shared/reference/cornell"))
        .find(|d| d.join("cornell.rib").is_file())
        .expect("shared/reference/cornell is beside the checkout")
}

/// The reference Cornell box, cropped to a 64x64 window over the tall box's edge, the back
/// wall and the red wall.
fn cornell_crop() -> Scene {
    let mut scene =
        rib_parser::load_scene(&reference_dir().join("cornell.rib"), &rib_parser::LoadOptions::default())
            .expect("the reference RIB loads")
            .scene;
    scene.camera.crop_window = depth_remap::CropWindow { xmin: 0.125, xmax: 0.25, ymin: 0.4, ymax: 0.525 };
    scene
}

fn progressive_settings(passes: u32) -> PhotonMapSettings {
    PhotonMapSettings {
        indirect_photons: 5_000,
        final_gather_samples: 4,
        progressive: true,
        passes,
        ..Default::default()
    }
}

fn progressive(passes: u32) -> IntegratorKind {
    IntegratorKind::PhotonMap(progressive_settings(passes))
}

fn run(scene: &Scene, integrator: IntegratorKind, threads: usize, extra: RenderOptions) -> RenderOutput {
    render(
        scene,
        &RenderOptions {
            spp: Some(1),
            seed: 11,
            integrator: Some(integrator),
            threads: Some(threads),
            ..extra
        },
    )
    .expect("renders")
}

fn rel_mse(out: &RenderOutput) -> f64 {
    let reference = image::open(reference_dir().join("reference-path-11520spp.exr")).unwrap().to_rgb32f();
    let image = &out.image;
    let mut sum = 0.0;
    for y in 0..image.height {
        for x in 0..image.width {
            let ours = image.rgb(x, y);
            let r = reference.get_pixel(x + image.x_offset, y + image.y_offset);
            for c in 0..3 {
                let (a, b) = (f64::from(ours[c]), f64::from(r[c]));
                sum += (a - b) * (a - b) / (b * b + 0.01);
            }
        }
    }
    sum / f64::from(image.width * image.height * 3)
}

#[test]
fn progressive_images_do_not_depend_on_the_thread_count_and_converge() {
    let scene = cornell_crop();
    let one = run(&scene, progressive(3), 1, RenderOptions::default());
    let three = run(&scene, progressive(3), 3, RenderOptions::default());
    assert_eq!(one.image.pixels, three.image.pixels);
    let passes = one.stats.passes.as_ref().expect("a progressive render reports its passes");
    assert_eq!((passes.passes, passes.stopped), (3, StopReason::Passes));
    let photon = one.stats.photon.as_ref().unwrap();
    assert!(photon.radiance.is_none(), "progressive gathering reads the photons, not radiance photons");
    let (pass, radii) = photon.progressive.as_ref().unwrap();
    assert_eq!(*pass, 2);
    assert!(radii.scale < 1.0);
    // A pass reads its photons from grids: its maps are counted but keep no kd-tree, except the
    // indirect map's where photon-guided gathering searches it.
    let tree_bytes = |p: &raytracer::photon::PhotonStats| {
        [&p.direct, &p.indirect].map(|m| m.as_ref().expect("the map is counted").bytes)
    };
    assert_eq!(tree_bytes(photon), [0, 0]);
    let guided = IntegratorKind::PhotonMap(PhotonMapSettings {
        gather_sampling: GatherSampling::Photons,
        ..progressive_settings(2)
    });
    let guided = run(&scene, guided, 2, RenderOptions::default());
    let [direct, indirect] = tree_bytes(guided.stats.photon.as_ref().unwrap());
    assert!(direct == 0 && indirect > 0, "direct {direct} and indirect {indirect} bytes of kd-tree");

    // Each pass has new photons and a smaller radius: the error falls with passes.
    let few = rel_mse(&one);
    let many = rel_mse(&run(&scene, progressive(12), 2, RenderOptions::default()));
    assert!(many < 0.5 * few, "relMSE {few} after 3 passes, {many} after 12");
}

#[test]
fn target_error_stops_converged_pixels_and_time_budget_stops_passes() {
    let scene = cornell_crop();
    let path = IntegratorKind::Path { max_depth: 1024, rr_depth: 5 };
    let target = RenderOptions { target_error: Some(0.08), ..RenderOptions::default() };
    let a = run(&scene, path, 1, target.clone());
    let b = run(&scene, path, 2, target);
    assert_eq!(a.image.pixels, b.image.pixels);
    let s = a.stats.passes.as_ref().unwrap();
    assert_eq!(s.stopped, StopReason::TargetError, "{s:?}");
    assert_eq!(s.pixels_at_target, s.pixels);
    // Some pixels (the flat walls) stop long before the noisiest ones.
    assert!(s.pixel_passes < s.pixels * u64::from(s.passes) * 3 / 4, "{s:?}");
    assert!(a.stats.integrator_stats.iter().any(|l| l.contains("target error 0.08")));

    let budget = RenderOptions { time_budget: Some(Duration::from_millis(1)), ..RenderOptions::default() };
    let c = run(&scene, path, 2, budget);
    let s = c.stats.passes.as_ref().unwrap();
    assert_eq!((s.passes, s.stopped), (1, StopReason::TimeBudget));
    assert!(c.image.pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
    assert!(c.image.mean_rgb().max_element() > 0.0);
}

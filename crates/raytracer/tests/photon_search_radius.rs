//! The photon mapper's search radius (`maxdist`): its default follows the photons, not the
//! scene's bounds, so a far object leaves it (and the work of every sparse query, which it
//! bounds) as it is; an explicit `maxdist` is used as given; scenes without photons render.

use raytracer::photon::PhotonStats;
use raytracer::render::{RenderOptions, RenderOutput, render};

/// A floor, a wall and a small matte sphere under a point light, with `extra` before
/// `WorldEnd` and `params` on the integrator.
fn rib(params: &str, extra: &str) -> String {
    format!(
        "Format 8 8 1\nProjection \"perspective\" \"fov\" [60]\nTranslate 0 0 4\n\
         SurfaceIntegrator \"photonmap\" \"integer indirectphotons\" [20000] \"integer causticphotons\" [0] \
         \"integer finalgathersamples\" [4] {params}\n\
         WorldBegin\nLightSource \"pointlight\" 1 \"from\" [0 0.9 0] \"intensity\" [2]\nSurface \"matte\"\n\
         Polygon \"P\" [-1 -1 -1  1 -1 -1  1 -1 1  -1 -1 1]\n\
         Polygon \"P\" [-1 -1 1  1 -1 1  1 1 1  -1 1 1]\n\
         AttributeBegin\nTranslate 0.3 -0.8 0\nSphere 0.2 -0.2 0.2 360\nAttributeEnd\n\
         {extra}\nWorldEnd\n"
    )
}

fn far_sphere(distance: f64) -> String {
    format!("AttributeBegin\nTranslate 0 0 {distance}\nSphere 1 -1 1 360\nAttributeEnd")
}

fn render_rib(text: &str, threads: usize) -> RenderOutput {
    let scene =
        rib_parser::load_bytes("pm.rib", text.as_bytes().to_vec(), &rib_parser::LoadOptions::default())
            .expect("parses")
            .scene;
    render(
        &scene,
        &RenderOptions { spp: Some(1), threads: Some(threads), seed: 5, ..RenderOptions::default() },
    )
    .expect("renders")
}

fn photon_stats(out: &RenderOutput) -> &PhotonStats {
    out.stats.photon.as_ref().expect("photon statistics")
}

/// With a unit sphere 30, 3000 and 2^31 units away (which made the old default, a tenth of
/// the scene's bounding radius, 10 to 10^8 times larger and the preparation up to 25 times
/// slower) the radius measured on the photons stays within 5% of the scene's own, and the
/// default used (that radius, at most a tenth of the scene's radius) is no larger than it.
#[test]
fn a_far_object_leaves_the_default_radius_as_it_is() {
    let plain = render_rib(&rib("", ""), 2);
    let d = photon_stats(&plain).max_dist;
    let measured = photon_stats(&plain).max_dist_measured.expect("measured on the photons");
    let own = measured.max_dist().expect("photons to measure");
    assert!(d > 0.01 && d <= own, "{d} vs {own}");
    assert!(measured.median_radius > 0.0 && measured.median_radius < own, "{measured:?}");
    for distance in [30.0, 3000.0, 2f64.powi(31)] {
        let out = render_rib(&rib("", &far_sphere(distance)), 2);
        let stats = photon_stats(&out);
        let far_own = stats.max_dist_measured.and_then(|m| m.max_dist()).expect("photons to measure");
        assert!((far_own / own - 1.0).abs() < 0.05, "sphere {distance} away: {far_own} vs {own}");
        assert!(stats.max_dist <= 1.05 * own, "sphere {distance} away: {} vs {own}", stats.max_dist);
    }
}

/// A `maxdist` in the RIB is used exactly, also a huge one (whose sparse searches the search
/// budget bounds), and the images of 1 and 3 threads are the same bit for bit.
#[test]
fn an_explicit_maxdist_is_used_as_given_and_images_are_deterministic() {
    for maxdist in [0.05f32, 1000.0] {
        let text = rib(&format!("\"float maxdist\" [{maxdist}]"), &far_sphere(3000.0));
        let one = render_rib(&text, 1);
        assert_eq!(photon_stats(&one).max_dist, maxdist);
        assert_eq!(photon_stats(&one).max_dist_measured, None);
        let three = render_rib(&text, 3);
        assert_eq!(one.image.pixels, three.image.pixels, "maxdist {maxdist}");
        assert!(one.image.pixels.iter().flatten().all(|v| v.is_finite()));
    }
    let default = render_rib(&rib("", &far_sphere(3000.0)), 1);
    assert_eq!(default.image.pixels, render_rib(&rib("", &far_sphere(3000.0)), 3).image.pixels);
}

/// Progressive passes keep the first pass's default radius and stay deterministic.
#[test]
fn progressive_passes_measure_the_default_once() {
    let text = rib("\"integer progressive\" [1] \"integer passes\" [2]", &far_sphere(3000.0));
    let one = render_rib(&text, 1);
    let stats = photon_stats(&one);
    assert!(stats.max_dist_measured.is_some());
    let own = stats.max_dist_measured.and_then(|m| m.max_dist()).expect("photons to measure");
    assert!(stats.max_dist > 0.01 && stats.max_dist <= own, "{} vs {own}", stats.max_dist);
    assert_eq!(one.image.pixels, render_rib(&text, 3).image.pixels);
}

/// No photons (a light that reaches nothing, or no light): the radius falls back to the
/// scene's size, and nothing panics or turns NaN.
#[test]
fn scenes_without_photons_render() {
    let dark = rib("", "").replace("LightSource \"pointlight\" 1 \"from\" [0 0.9 0] \"intensity\" [2]", "");
    let out = render_rib(&dark, 2);
    let stats = photon_stats(&out);
    assert!(stats.max_dist.is_finite() && stats.max_dist > 0.0, "{}", stats.max_dist);
    assert!(out.image.pixels.iter().flatten().all(|v| v.is_finite()));
}

/// A plate under the floor, in view below its front edge, gathers from the floor's underside,
/// where no photon lands (the light is above it) while the photons of the floor's top side
/// lie at the same heights: each such lookup would read every radiance photon within
/// `maxdist` (most of the floor's under a `maxdist` of 0.5). It stops at its budget and says
/// so in the statistics; the image stays finite and the same for 1 and 3 threads. Under a
/// small `maxdist` the lookups stay under the budget.
#[test]
fn a_radiance_lookup_on_a_surface_without_photons_stops_at_its_budget() {
    let plate = "Polygon \"P\" [-3 -2 -1  3 -2 -1  3 -2 3  -3 -2 3]";
    for (maxdist, capped) in [(0.5, true), (0.05, false)] {
        let params = format!("\"float maxdist\" [{maxdist}]");
        let text = rib(&params, plate).replace("Format 8 8 1", "Format 24 24 1");
        let one = render_rib(&text, 1);
        let stats = photon_stats(&one);
        assert_eq!(stats.capped_radiance_lookups > 0, capped, "{maxdist}: {}", stats.capped_radiance_lookups);
        assert!(stats.capped_radiance_lookups < stats.gather_rays);
        assert!(one.image.pixels.iter().flatten().all(|v| v.is_finite()));
        assert_eq!(one.image.pixels, render_rib(&text, 3).image.pixels, "{maxdist}");
    }
}

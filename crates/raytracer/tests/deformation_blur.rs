//! Deformation motion blur against closed forms: a square whose vertices move across a row of
//! pixels covers each pixel for the fraction of the shutter it spends over it, a sphere whose
//! radius grows over the shutter covers a ring for the time its radius is past it. Keys that do
//! not match render as the first key, and scenes that do not deform while the shutter is open
//! render bit for bit as the same scene without keys.

use raytracer::render::{RenderOptions, RenderOutput, render};

/// `width` x `height` pixels over x in [-1, 1] seen orthographically from z = -5 (a pixel is
/// `2 / width` wide), with a box filter one pixel wide so a pixel averages only its own samples.
fn camera(width: u32, height: u32, shutter: &str) -> String {
    let half = f64::from(height) / f64::from(width);
    format!(
        "Format {width} {height} 1\nPixelFilter \"box\" 1 1\nProjection \"orthographic\"\nScreenWindow -1 1 -{half} {half}\n{shutter}\nTranslate 0 0 5\n"
    )
}

fn world(body: &str) -> String {
    format!("WorldBegin\nSurface \"constant\"\n{body}\nWorldEnd\n")
}

/// A polygon over x in [x0, x1], tall enough to cover the rows.
fn square(x0: f64, x1: f64) -> String {
    format!("Polygon \"P\" [{x0} -10 0  {x1} -10 0  {x1} 10 0  {x0} 10 0]")
}

fn keys(times: &str, requests: &[String]) -> String {
    format!("MotionBegin [{times}]\n{}\nMotionEnd", requests.join("\n"))
}

fn rendered(rib: &str, spp: u32, depth: bool) -> RenderOutput {
    let scene = rib_parser::load_bytes("deform.rib", rib.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let options = RenderOptions { spp: Some(spp), threads: Some(2), depth, ..Default::default() };
    render(&scene, &options).unwrap()
}

/// The alpha (coverage) of every pixel, row by row.
fn coverage(rib: &str, spp: u32) -> Vec<f32> {
    rendered(rib, spp, false).image.pixels.iter().map(|p| p[3]).collect()
}

#[test]
fn a_square_whose_vertices_slide_covers_each_pixel_for_the_time_it_spends_there() {
    // The square spans [t - 1, t] at shutter fraction t: a point x is covered for a fraction
    // 1 - |x| of the shutter, linear across each pixel, so a pixel's mean is its centre's.
    let slide = keys("0 1", &[square(-1.0, 0.0), square(0.0, 1.0)]);
    let alpha = coverage(&format!("{}{}", camera(32, 2, "Shutter 0 1"), world(&slide)), 256);
    let mut worst = 0.0f64;
    for (k, a) in alpha.iter().enumerate() {
        let x = -1.0 + (k % 32) as f64 / 16.0 + 1.0 / 32.0;
        worst = worst.max((f64::from(*a) - (1.0 - x.abs())).abs());
    }
    eprintln!("sliding square: worst pixel coverage error {worst}");
    assert!(worst < 0.02, "worst pixel coverage error {worst}");

    // Only its right edge moves (from x = 0 to x = 1): the square stretches, and a point
    // x in [0, 1] is covered while t > x, a fraction 1 - x; x < 0 always.
    let stretch = keys("0 1", &[square(-1.0, 0.0), square(-1.0, 1.0)]);
    let alpha = coverage(&format!("{}{}", camera(32, 2, "Shutter 0 1"), world(&stretch)), 256);
    for (k, a) in alpha.iter().enumerate() {
        let x = -1.0 + (k % 32) as f64 / 16.0 + 1.0 / 32.0;
        let expected = if x < 0.0 { 1.0 } else { 1.0 - x };
        assert!((f64::from(*a) - expected).abs() < 0.02, "pixel {k}: {a} against {expected}");
    }

    // Three keys at 0, 0.25 and 1 (the square reaches x = 0.5 a quarter into the shutter and
    // comes back to where it started): a point x in [0, 0.5] is covered from t = x / 2 until
    // the square's right edge passes it again, 0.5 - (t - 0.25) / 1.5 = x: t = 1 - 1.5 x.
    let there_and_back = keys("0 0.25 1", &[square(-1.0, 0.0), square(-0.5, 0.5), square(-1.0, 0.0)]);
    let alpha = coverage(&format!("{}{}", camera(32, 2, "Shutter 0 1"), world(&there_and_back)), 256);
    for (k, a) in alpha.iter().enumerate().filter(|(k, _)| (16..24).contains(&(k % 32))) {
        let x = (k % 32 - 16) as f64 / 16.0 + 1.0 / 32.0;
        let expected = 1.0 - 1.5 * x - x / 2.0;
        assert!((f64::from(*a) - expected).abs() < 0.02, "pixel {k}: {a} against {expected}");
    }
}

#[test]
fn a_growing_sphere_covers_its_mean_area_and_each_ring_for_the_time_its_radius_is_past_it() {
    // The radius grows linearly from r0 to r1: a point at distance rho in [r0, r1] from the
    // centre is covered while r(t) > rho, a fraction (r1 - rho) / (r1 - r0) of the shutter; the
    // covered area averages pi (r0^2 + r0 d + d^2 / 3), d = r1 - r0.
    let (r0, r1) = (0.25f64, 0.75f64);
    let grow = keys("0 1", &[format!("Sphere {r0} -{r0} {r0} 360"), format!("Sphere {r1} -{r1} {r1} 360")]);
    let n = 48usize;
    let alpha = coverage(&format!("{}{}", camera(n as u32, n as u32, "Shutter 0 1"), world(&grow)), 256);
    let pixel = 2.0 / n as f64;
    let area: f64 = alpha.iter().map(|a| f64::from(*a) * pixel * pixel).sum();
    let d = r1 - r0;
    let expected = std::f64::consts::PI * (r0 * r0 + r0 * d + d * d / 3.0);
    eprintln!("growing sphere: mean area {area} against {expected}");
    assert!((area - expected).abs() < 2e-3 * expected, "mean area {area} against {expected}");
    // The ring of pixels whose centres lie between the radii, pixel by pixel and on average.
    let (mut sum, mut sum_expected, mut count, mut worst) = (0.0, 0.0, 0, 0.0f64);
    for (k, a) in alpha.iter().enumerate() {
        let (x, y) = ((k % n) as f64 * pixel - 1.0 + pixel / 2.0, (k / n) as f64 * pixel - 1.0 + pixel / 2.0);
        let rho = x.hypot(y);
        if rho < r0 + pixel || rho > r1 - pixel {
            continue;
        }
        let e = (r1 - rho) / d;
        sum += f64::from(*a);
        sum_expected += e;
        count += 1;
        worst = worst.max((f64::from(*a) - e).abs());
    }
    eprintln!(
        "growing sphere: ring of {count} pixels, mean {} against {}, worst pixel {worst}",
        sum / count as f64,
        sum_expected / count as f64
    );
    assert!(((sum - sum_expected) / count as f64).abs() < 5e-3);
    assert!(worst < 0.03, "worst ring pixel {worst}");
}

#[test]
fn keys_that_do_not_match_render_the_first_key() {
    let cam = camera(32, 2, "Shutter 0 1");
    let first = coverage(&format!("{cam}{}", world(&square(-1.0, 0.0))), 16);
    // A triangle after a square: the parser warns at the triangle and keeps the square.
    let mismatched = keys("0 1", &[square(-1.0, 0.0), "Polygon \"P\" [0 -10 0  1 -10 0  1 10 0]".into()]);
    let rib = format!("{cam}{}", world(&mismatched));
    let loaded = rib_parser::load_bytes("deform.rib", rib.as_bytes().to_vec(), &Default::default()).unwrap();
    let text = loaded.render_warnings();
    assert!(text.contains("deform.rib:11:1: warning") && text.contains("the first key is used"), "{text}");
    assert_eq!(coverage(&rib, 16), first);
    // A sphere after a square.
    let mismatched = keys("0 1", &[square(-1.0, 0.0), "Sphere 1 -1 1 360".into()]);
    assert_eq!(coverage(&format!("{cam}{}", world(&mismatched)), 16), first);
}

#[test]
fn scenes_that_do_not_deform_during_the_shutter_render_as_the_still_scene() {
    let still_rib = |cam: &str| format!("{cam}{}", world(&square(-1.0, 0.0)));
    let cam = camera(32, 2, "Shutter 0 1");
    let still = rendered(&still_rib(&cam), 16, true);
    let slide = keys("0 1", &[square(-1.0, 0.0), square(0.0, 1.0)]);
    // Shutter 0 0 and no Shutter: the first key, no time sample drawn.
    for shutter in ["Shutter 0 0", ""] {
        let alpha = coverage(&format!("{}{}", camera(32, 2, shutter), world(&slide)), 16);
        assert_eq!(alpha, coverage(&still_rib(&camera(32, 2, shutter)), 16), "{shutter:?}");
    }
    // Keys that are all the same.
    let same = keys("0 1", &[square(-1.0, 0.0), square(-1.0, 0.0)]);
    let out = rendered(&format!("{cam}{}", world(&same)), 16, true);
    assert_eq!(out.image.pixels, still.image.pixels);
    // The depth table of a deforming scene is its first key's (the pinhole ray at shutter
    // open), bit for bit.
    let out = rendered(&format!("{cam}{}", world(&slide)), 16, true);
    assert_eq!(out.depth.unwrap().values, still.depth.unwrap().values);
}

#[test]
fn deformation_blurred_images_do_not_depend_on_threads() {
    let grow = keys("0 1", &["Sphere 0.25 -0.25 0.25 360".into(), "Sphere 0.75 -0.75 0.75 180".into()]);
    let rib = format!("{}{}", camera(16, 16, "Shutter 0 1"), world(&grow));
    let scene =
        rib_parser::load_bytes("deform.rib", rib.as_bytes().to_vec(), &Default::default()).unwrap().scene;
    let pixels = |threads| {
        let options = RenderOptions { spp: Some(16), threads: Some(threads), ..Default::default() };
        render(&scene, &options).unwrap().image.pixels
    };
    assert_eq!(pixels(1), pixels(2));
}

#[test]
fn a_tessellated_patch_deforms_as_the_polygon_does() {
    // The sliding square as a bilinear patch: every key is tessellated with one tolerance to
    // the same triangles, whose vertices are interpolated.
    let patch =
        |x0: f64, x1: f64| format!("Patch \"bilinear\" \"P\" [{x0} -10 0  {x1} -10 0  {x0} 10 0  {x1} 10 0]");
    let slide = keys("0 1", &[patch(-1.0, 0.0), patch(0.0, 1.0)]);
    let rib = format!("{}{}", camera(32, 2, "Shutter 0 1"), world(&slide));
    let out = rendered(&rib, 256, false);
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    for (k, p) in out.image.pixels.iter().enumerate() {
        let x = -1.0 + (k % 32) as f64 / 16.0 + 1.0 / 32.0;
        assert!((f64::from(p[3]) - (1.0 - x.abs())).abs() < 0.02, "pixel {k}: {}", p[3]);
    }
}

#[test]
fn a_deformation_under_a_moving_transformation_composes_with_it() {
    // The square's vertices slide by +1 while its transformation slides it by -1: it stays
    // where the still square is (up to rounding at its edges).
    let cam = camera(32, 2, "Shutter 0 1");
    let still = coverage(&format!("{cam}{}", world(&square(-1.0, 0.0))), 64);
    let body = format!(
        "MotionBegin [0 1]\nTranslate 0 0 0\nTranslate -1 0 0\nMotionEnd\n{}",
        keys("0 1", &[square(-1.0, 0.0), square(0.0, 1.0)])
    );
    let both = coverage(&format!("{cam}{}", world(&body)), 64);
    let worst = both.iter().zip(&still).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(worst <= 1.0 / 64.0, "worst pixel difference {worst}");
}

#[test]
fn a_bicubic_patch_whose_edge_bulges_covers_each_pixel_for_the_time_it_spends_there() {
    // A Bezier patch over x in [-1, 0] whose right edge bows out to x = G(v) = 4 v (1 - v) at
    // the last key: x(u, v) = -1 + u (1 + t G(v)) at shutter fraction t (the control points
    // move linearly, and a point of fixed (u, v) with them). The keys differ in curvature, so
    // on their own they are diced at other rates. Near v = 1/2 (the rows), G = 1: a point x in
    // [0, 1] is covered once t > x, a fraction 1 - x; x < 0 always.
    let patch = |bulge: f64| {
        let mut p = String::new();
        for (j, g) in [0.0, bulge, bulge, 0.0].iter().enumerate() {
            for i in 0..4 {
                let x = -1.0 + f64::from(i) / 3.0 * (1.0 + g);
                p += &format!("{x} {} 0  ", -10.0 + 20.0 * j as f64 / 3.0);
            }
        }
        format!("Patch \"bicubic\" \"P\" [{p}]")
    };
    let bulge = keys("0 1", &[patch(0.0), patch(4.0 / 3.0)]);
    let out = rendered(&format!("{}{}", camera(32, 2, "Shutter 0 1"), world(&bulge)), 256, false);
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    let mut worst = 0.0f64;
    for (k, p) in out.image.pixels.iter().enumerate() {
        let x = -1.0 + (k % 32) as f64 / 16.0 + 1.0 / 32.0;
        let expected = if x < 0.0 { 1.0 } else { (1.0 - x).max(0.0) };
        worst = worst.max((f64::from(p[3]) - expected).abs());
    }
    eprintln!("bulging bicubic patch: worst pixel coverage error {worst}");
    assert!(worst < 0.02, "worst pixel coverage error {worst}");
}

#[test]
fn blobby_keys_are_drawn_at_shutter_open_with_the_reason() {
    // Two blobs coming apart: the first key's triangles cannot be carried onto the last key's
    // two separate surfaces, so it is the first key (shutter open is key 0) with a warning
    // that says why.
    let blobs = |d: f64| {
        let at = |x: f64| format!("0.6 0 0 0 0 0.6 0 0 0 0 0.6 0 {x} 0 0 1");
        format!("Blobby 2 [1001 0 1001 16 0 2 0 1] [{} {}] [\"\"]", at(-d), at(d))
    };
    let cam = camera(32, 2, "Shutter 0 1");
    let out = rendered(&format!("{cam}{}", world(&keys("0 1", &[blobs(0.2), blobs(0.7)]))), 16, false);
    let said = |w: &raytracer::diagnostics::Warning| {
        w.message.contains("deforming Blobby drawn at shutter open") && w.message.contains("cannot be mapped")
    };
    assert!(out.warnings.iter().any(said), "{:?}", out.warnings);
    let still = rendered(&format!("{cam}{}", world(&blobs(0.2))), 16, false);
    assert_eq!(out.image.pixels, still.image.pixels);
}

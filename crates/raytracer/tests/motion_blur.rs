//! Transformation motion blur against a closed form: a square sliding across a row of pixels
//! during the shutter covers each pixel for the fraction of the shutter it spends over it.
//! Scenes whose shutter is closed (`Shutter 0 0`, RenderMan's default) or where nothing moves
//! render bit for bit as the same scene without motion.

use raytracer::render::{RenderOptions, render};

/// 32 x 2 pixels over x in [-1, 1] (a pixel is 1/16 wide), seen orthographically from z = -5,
/// with a box filter one pixel wide so a pixel averages only its own samples.
fn camera(shutter: &str) -> String {
    format!(
        "Format 32 2 1\nPixelFilter \"box\" 1 1\nProjection \"orthographic\"\nScreenWindow -1 1 -0.0625 0.0625\n{shutter}\nTranslate 0 0 5\n"
    )
}

/// The unit-wide square x in [-1, 0], tall enough to cover the rows, placed by `transform`.
fn square(transform: &str) -> String {
    format!(
        "WorldBegin\nSurface \"constant\"\n{transform}\nPolygon \"P\" [-1 -10 0  0 -10 0  0 10 0  -1 10 0]\nWorldEnd\n"
    )
}

const SLIDE: &str = "MotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\nMotionEnd";

/// The alpha (coverage) of every pixel, row by row.
fn coverage(rib: &str, spp: u32, threads: usize) -> Vec<f32> {
    let scene = rib_parser::load_bytes("motion.rib", rib.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let options = RenderOptions { spp: Some(spp), threads: Some(threads), ..Default::default() };
    render(&scene, &options).unwrap().image.pixels.iter().map(|p| p[3]).collect()
}

#[test]
fn a_sliding_square_covers_each_pixel_for_the_time_it_spends_there() {
    // The square spans [t - 1, t] at shutter fraction t: a point x is covered for
    // t in [x, x + 1] within [0, 1], a fraction 1 - |x|. That tent is linear across each pixel
    // (its kink at x = 0 is a pixel edge), so a pixel's mean coverage is its centre's.
    let alpha = coverage(&format!("{}{}", camera("Shutter 0 1"), square(SLIDE)), 256, 2);
    let mut worst = 0.0f64;
    for (k, a) in alpha.iter().enumerate() {
        let x = -1.0 + (k % 32) as f64 / 16.0 + 1.0 / 32.0;
        let expected = 1.0 - x.abs();
        worst = worst.max((f64::from(*a) - expected).abs());
    }
    eprintln!("worst pixel coverage error {worst}");
    assert!(worst < 0.02, "worst pixel coverage error {worst}");
    // Where the square ends up matters only through the shutter: half the shutter moves it
    // half as far, so a point x in [0, 0.5] is covered for t in [2x, 1] of the fraction-time
    // [0, 1]: 1 - 2x (and nothing is covered beyond x = 0.5).
    let alpha = coverage(&format!("{}{}", camera("Shutter 0 0.5"), square(SLIDE)), 256, 2);
    for (k, a) in alpha.iter().enumerate().filter(|(k, _)| k % 32 >= 16) {
        let x = (k % 32 - 16) as f64 / 16.0 + 1.0 / 32.0;
        let expected = (1.0 - 2.0 * x).max(0.0);
        assert!((f64::from(*a) - expected).abs() < 0.03, "pixel {k}: {a} against {expected}");
    }
}

#[test]
fn motion_blurred_images_do_not_depend_on_threads() {
    let rib = format!("{}{}", camera("Shutter 0 1"), square(SLIDE));
    assert_eq!(coverage(&rib, 16, 1), coverage(&rib, 16, 2));
}

#[test]
fn a_closed_shutter_or_a_still_block_renders_as_the_still_scene() {
    let still = coverage(&format!("{}{}", camera("Shutter 0 1"), square("")), 16, 2);
    // Shutter 0 0 (and no Shutter at all): the square at its first key, no time sample drawn.
    for shutter in ["Shutter 0 0", ""] {
        assert_eq!(coverage(&format!("{}{}", camera(shutter), square(SLIDE)), 16, 2), still, "{shutter:?}");
    }
    // A block whose keys are all the same moves nothing.
    let same = "MotionBegin [0 1]\nTranslate 0 0 0\nTranslate 0 0 0\nMotionEnd";
    assert_eq!(coverage(&format!("{}{}", camera("Shutter 0 1"), square(same)), 16, 2), still);
    // The still square covers exactly its half of the image.
    assert!(still.iter().enumerate().all(|(k, a)| *a == if k % 32 < 16 { 1.0 } else { 0.0 }), "{still:?}");
}

#[test]
fn a_camera_moving_by_d_sees_what_a_still_camera_sees_of_objects_moving_by_minus_d() {
    // The camera slides by -1 along x during the shutter (its `camera_from_world` adds +t to
    // x), so the still square sweeps across the image exactly as the square that slides by +1
    // does before a still camera: same samples, same rays up to rounding.
    let moving_camera = "Format 32 2 1\nPixelFilter \"box\" 1 1\nProjection \"orthographic\"\nScreenWindow -1 1 -0.0625 0.0625\nShutter 0 1\nMotionBegin [0 1]\nTranslate 0 0 5\nTranslate 1 0 5\nMotionEnd\n";
    let from_camera = coverage(&format!("{moving_camera}{}", square("")), 256, 2);
    let from_square = coverage(&format!("{}{}", camera("Shutter 0 1"), square(SLIDE)), 256, 2);
    let worst = from_camera.iter().zip(&from_square).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    eprintln!("worst pixel difference {worst}");
    assert!(worst <= 1.0 / 256.0, "worst pixel difference {worst}");
    // And both are the closed form of the sliding square: coverage 1 - |x|.
    for (k, a) in from_camera.iter().enumerate() {
        let x = -1.0 + (k % 32) as f64 / 16.0 + 1.0 / 32.0;
        assert!((f64::from(*a) - (1.0 - x.abs())).abs() < 0.02, "pixel {k}: {a}");
    }
    // A closed shutter renders the camera at its first key, with no warning about it.
    let closed = moving_camera.replace("Shutter 0 1", "Shutter 0 0");
    assert_eq!(
        coverage(&format!("{closed}{}", square("")), 16, 2),
        coverage(&format!("{}{}", camera("Shutter 0 1"), square("")), 16, 2)
    );
}

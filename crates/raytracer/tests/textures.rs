//! Texture files named through `MakeTexture` and `MakeLatLongEnvironment`: a `paintedplastic`
//! map made by `MakeTexture` is the picture itself, `shinymetal` reflects its lat-long
//! environment map (+z up) in the mirror direction, and `"blur"` filters the map.

use raytracer::render::{RenderOptions, render};
use std::path::Path;

/// An orthographic view of [-1.2, 1.2]^2 from z = -10 toward +z, 48 x 48 pixels.
const CAMERA: &str =
    "Format 48 48 1\nProjection \"orthographic\"\nScreenWindow -1.2 1.2 -1.2 1.2\nTranslate 0 0 10\n";

/// The RGB of every pixel of the scene (1 sample per pixel, box filter), read from `dir`.
fn pixels(dir: &Path, options_and_world: &str) -> Vec<[f32; 3]> {
    let rib = format!("{CAMERA}PixelFilter \"box\" 1 1\n{options_and_world}");
    let path = dir.join("scene.rib");
    std::fs::write(&path, &rib).unwrap();
    let loaded = rib_parser::load_scene(&path, &Default::default()).unwrap();
    let out = render(&loaded.scene, &RenderOptions { spp: Some(1), threads: Some(2), ..Default::default() })
        .unwrap();
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    out.image.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect()
}

fn write_png(path: &Path, width: u32, height: u32, f: impl Fn(u32, u32) -> [u8; 3]) {
    image::RgbImage::from_fn(width, height, |x, y| image::Rgb(f(x, y))).save(path).unwrap();
}

#[test]
fn a_made_texture_is_its_picture_and_shinymetal_reflects_a_lat_long_map() {
    let dir = tempfile::tempdir().unwrap();
    // A 4x4 checker of two greys, and a lat-long map: red above the horizon, blue below.
    write_png(&dir.path().join("checker.png"), 4, 4, |x, y| {
        if (x + y).is_multiple_of(2) { [200; 3] } else { [50; 3] }
    });
    write_png(&dir.path().join("sky.png"), 8, 4, |_, y| if y < 2 { [255, 0, 0] } else { [0, 0, 255] });

    let plane = "Polygon \"P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \"st\" [0 0  1 0  1 1  0 1]";
    let painted = |name: &str| {
        format!(
            "MakeTexture \"checker.png\" \"checker.tex\" \"periodic\" \"periodic\" \"box\" 1 1\n\
             WorldBegin\nLightSource \"ambientlight\" 1 \"intensity\" [1]\n\
             Surface \"paintedplastic\" \"Ka\" [1] \"Kd\" [0] \"Ks\" [0] \"texturename\" [\"{name}\"]\n{plane}\nWorldEnd\n"
        )
    };
    let made = pixels(dir.path(), &painted("checker.tex"));
    let direct = pixels(dir.path(), &painted("checker.png"));
    assert_eq!(made, direct, "the made texture reads its picture");
    let lit: Vec<f32> = made.iter().map(|p| p[0]).filter(|&v| v > 0.0).collect();
    assert!(lit.iter().any(|&v| v > 0.6) && lit.iter().any(|&v| v < 0.3), "the checker shows");

    let sphere = "MakeLatLongEnvironment \"sky.png\" \"sky.env\" \"box\" 1 1\n\
                  WorldBegin\nSurface \"shinymetal\" \"Ka\" [0] \"Ks\" [0] \"Kr\" [1] \"texturename\" [\"sky.env\"]\n\
                  Sphere 1 -1 1 360\nWorldEnd\n";
    let image = pixels(dir.path(), sphere);
    // The centre faces the eye: it reflects -z, below the horizon (blue). Near the top rim
    // (y = 0.9) the mirror direction points up (+z): red.
    let at =
        |x: f32, y: f32| image[(((1.2 - y) / 2.4 * 48.0) as usize) * 48 + ((x + 1.2) / 2.4 * 48.0) as usize];
    let centre = at(0.0, 0.0);
    assert!(centre[2] > 0.9 && centre[0] < 0.1, "centre {centre:?}");
    let top = at(0.0, 0.9);
    assert!(top[0] > 0.9 && top[2] < 0.1, "top {top:?}");
}

/// RenderMan's `"blur"` on the standard shaders' texture lookups: the map seen through a box
/// filter that wide. Blurred by half its width, a periodic 4 x 4 checker is its mean everywhere
/// (each texel averages half of each neighbour with itself, in s and in t).
#[test]
fn a_blurred_texture_is_filtered_by_the_blur_width() {
    let dir = tempfile::tempdir().unwrap();
    write_png(&dir.path().join("checker.png"), 4, 4, |x, y| {
        if (x + y).is_multiple_of(2) { [200; 3] } else { [50; 3] }
    });
    let plane = "Polygon \"P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \"st\" [0 0  1 0  1 1  0 1]";
    let painted = |blur: &str| {
        format!(
            "MakeTexture \"checker.png\" \"checker.tex\" \"periodic\" \"periodic\" \"box\" 1 1\n\
             WorldBegin\nLightSource \"ambientlight\" 1 \"intensity\" [1]\n\
             Surface \"paintedplastic\" \"Ka\" [1] \"Kd\" [0] \"Ks\" [0] \"texturename\" [\"checker.tex\"] {blur}\n{plane}\nWorldEnd\n"
        )
    };
    let sharp: Vec<f32> =
        pixels(dir.path(), &painted("")).iter().map(|p| p[0]).filter(|&v| v > 0.0).collect();
    let blurred: Vec<f32> = pixels(dir.path(), &painted("\"float blur\" [0.5]"))
        .iter()
        .map(|p| p[0])
        .filter(|&v| v > 0.0)
        .collect();
    let (lo, hi) = sharp.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    assert!(hi - lo > 0.3, "the checker shows unblurred: {lo} .. {hi}");
    let mean = blurred[0];
    assert!(blurred.iter().all(|&v| (v - mean).abs() < 1e-5), "blurred: {blurred:?}");
    assert!(mean > lo && mean < hi, "{mean} outside {lo} .. {hi}");
    // A width that is no width: a warning, and the map unblurred.
    let path = dir.path().join("bad.rib");
    std::fs::write(&path, format!("{CAMERA}{}", painted("\"float blur\" [-1]"))).unwrap();
    let scene = rib_parser::load_scene(&path, &Default::default()).unwrap().scene;
    let out =
        render(&scene, &RenderOptions { spp: Some(1), threads: Some(2), ..Default::default() }).unwrap();
    let said = out.warnings.iter().any(|w| w.to_string().contains("\"blur\" -1 is not a finite width"));
    assert!(said, "{:?}", out.warnings);
}

//! GPU tests of the one colour pipeline: the composite is made in linear values in the image's
//! units and encoded for display once, the same way for pre-rendered and live pixels
//! (`viewer::display`). They need a GPU adapter (lavapipe in CI) and fail without one.

mod common;

use common::*;
use glam::DVec3;
use viewer::{
    Backdrop, CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, ShadowSettings, Sphere,
    ToneMap, ViewerScene,
};

fn settings(mode: CompositeMode) -> CompositorSettings {
    CompositorSettings { mode, ..CompositorSettings::default() }
}

/// The shared Cornell reference image, linear, as a float backdrop under `gamma`.
fn cornell_float_backdrop(gamma: f32) -> Backdrop {
    Backdrop::read(&shared().join("reference/cornell/reference-path-11520spp.exr"), gamma).unwrap()
}

fn float_scene(tone: ToneMap) -> ViewerScene {
    ViewerScene::with_backdrop(
        cornell_camera(),
        cornell_float_backdrop(tone.gamma),
        cornell_depth(),
        vec![cornell_light()],
        tone,
    )
    .unwrap()
}

fn lit_sphere() -> LiveObjects {
    LiveObjects {
        sphere: Some(Sphere {
            centre: DVec3::new(0.1, -0.3, -0.2),
            radius: 0.3,
            material: Material::default(),
        }),
        meshes: Vec::new(),
    }
}

/// With nothing live in view, a float image comes back bit for bit in linear values and as its
/// own display encoding, in both modes.
#[test]
fn float_backdrop_round_trips_bit_for_bit() {
    let gpu = gpu();
    let scene = float_scene(ToneMap::default());
    for mode in [CompositeMode::Points, CompositeMode::Fullscreen] {
        let mut c = Compositor::new(&gpu, &scene, settings(mode)).unwrap();
        c.render(&LiveObjects::default()).unwrap();
        let linear = c.read_back_linear().unwrap();
        let input = &scene.backdrop().linear;
        let differing = linear.rgba.iter().zip(input).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
        assert_eq!(differing, 0, "{mode:?}: {differing} linear values differ from the input");
        assert!(c.read_back().unwrap().colour == *scene.image(), "{mode:?}: display differs");
    }
}

/// An 8-bit image decoded with a gamma other than 1 is still shown byte for byte.
#[test]
fn eight_bit_backdrop_with_gamma_passes_through() {
    let gpu = gpu();
    let tone = ToneMap { gain: 2.0, gamma: 2.2 };
    let scene = ViewerScene::new(
        cornell_camera(),
        noise_image(512, 512),
        cornell_depth(),
        vec![cornell_light()],
        tone,
    )
    .unwrap();
    let mut c = Compositor::new(&gpu, &scene, settings(CompositeMode::Fullscreen)).unwrap();
    c.render(&LiveObjects::default()).unwrap();
    assert!(c.read_back().unwrap().colour == *scene.image());
}

/// Live and shadowed pixels are encoded exactly as `DisplayEncoding::encode` encodes their
/// linear values (transfer and dither), and live radiance is scaled into the image's units by
/// Exposure's gain.
#[test]
fn live_and_shadowed_pixels_share_the_display_encoding() {
    let gpu = gpu();
    let mut linears = Vec::new();
    for gain in [1.0f32, 2.0] {
        let scene = float_scene(ToneMap { gain, gamma: 1.0 });
        let mut c = Compositor::new(
            &gpu,
            &scene,
            CompositorSettings {
                shadows: Some(ShadowSettings::default()),
                // Antialiased edges blend live colour into pixels outside the mask, which this
                // test takes for shadows; it is about the encoding, which is the same for both.
                antialias: false,
                ..settings(CompositeMode::Fullscreen)
            },
        )
        .unwrap();
        c.render(&lit_sphere()).unwrap();
        let frame = c.read_back().unwrap();
        let linear = c.read_back_linear().unwrap();
        let encoding = scene.backdrop().encoding;
        let (w, h) = c.size();
        let (mut live, mut shadowed, mut off_by_one) = (0, 0, 0);
        for y in 0..h {
            for x in 0..w {
                let k = (y * w + x) as usize;
                let changed = (0..3).any(|ch| linear.rgba[4 * k + ch] != scene.backdrop().linear[4 * k + ch]);
                if !changed {
                    continue;
                }
                if frame.mask[k] == 255 {
                    live += 1;
                } else {
                    shadowed += 1;
                    // A shadow only darkens.
                    for ch in 0..3 {
                        assert!(linear.rgba[4 * k + ch] <= scene.backdrop().linear[4 * k + ch]);
                    }
                }
                for ch in 0..3 {
                    let cpu = encoding.encode(linear.rgba[4 * k + ch], x, y, w, ch as u32);
                    let gpu_byte = frame.colour.pixels[4 * k + ch];
                    let d = (i32::from(cpu) - i32::from(gpu_byte)).abs();
                    assert!(d <= 1, "pixel ({x}, {y}) channel {ch}: GPU {gpu_byte}, CPU {cpu}");
                    off_by_one += usize::from(d == 1);
                }
            }
        }
        assert!(live > 1000 && shadowed > 100, "live {live}, shadowed {shadowed}");
        // Only a rounding boundary crossed by the shader's pow may differ.
        assert!(off_by_one * 1000 <= 3 * (live + shadowed), "{off_by_one} bytes differ by one");
        linears.push((linear, frame.mask));
    }
    // Twice the gain, twice the live radiance.
    let ((one, mask), (two, _)) = (&linears[0], &linears[1]);
    for k in (0..mask.len()).filter(|&k| mask[k] == 255).step_by(37) {
        for ch in 0..3 {
            let (a, b) = (one.rgba[4 * k + ch], two.rgba[4 * k + ch]);
            assert!((b - 2.0 * a).abs() <= 1e-6 * b.abs().max(1e-6), "pixel {k}: {a} vs {b}");
        }
    }
}

/// `LinearFrame::write_exr` writes what was read back, bit for bit, atomically.
#[test]
fn linear_screenshot_is_an_exact_exr() {
    let gpu = gpu();
    let scene = float_scene(ToneMap::default());
    let mut c = Compositor::new(&gpu, &scene, settings(CompositeMode::Fullscreen)).unwrap();
    c.render(&lit_sphere()).unwrap();
    let linear = c.read_back_linear().unwrap();
    let dir = tempfile::Builder::new().prefix("viewer-linear-shot-").tempdir().unwrap();
    let path = dir.path().join("shot.exr");
    linear.write_exr(&path).unwrap();
    let back = Backdrop::read(&path, 1.0).unwrap();
    assert_eq!((back.width, back.height), (linear.width, linear.height));
    for (a, b) in back.linear.chunks_exact(4).zip(linear.rgba.chunks_exact(4)) {
        assert_eq!(
            [a[0].to_bits(), a[1].to_bits(), a[2].to_bits()],
            [b[0].to_bits(), b[1].to_bits(), b[2].to_bits()]
        );
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "a temporary file was left behind");
}

/// A float image with NaN is refused, naming the file and the pixel.
#[test]
fn non_finite_float_images_are_refused() {
    let dir = tempfile::Builder::new().prefix("viewer-nan-").tempdir().unwrap();
    let path = dir.path().join("nan.exr");
    exr::prelude::write_rgb_file(&path, 4, 3, |x, y| {
        if (x, y) == (2, 1) { (f32::NAN, 0.0, 0.0) } else { (0.5, 0.5, 0.5) }
    })
    .unwrap();
    let err = Backdrop::read(&path, 1.0).unwrap_err().to_string();
    assert!(err.contains("nan.exr") && err.contains("(2, 1)"), "{err}");
}

/// On GL (llvmpipe), where 32-bit float targets are not renderable, the linear frame falls back
/// to half floats: the display is still the input's own encoding byte for byte, and the linear
/// values are the input's rounded to half precision.
#[test]
fn gl_backend_falls_back_to_half_floats() {
    let gpu = viewer::Gpu::new(viewer::Backends(wgpu::Backends::GL))
        .expect("no GL adapter: llvmpipe comes with Mesa's EGL (libegl-mesa0)");
    let scene = float_scene(ToneMap::default());
    let mut c = Compositor::new(&gpu, &scene, settings(CompositeMode::Fullscreen)).unwrap();
    c.render(&LiveObjects::default()).unwrap();
    assert!(c.read_back().unwrap().colour == *scene.image());
    let linear = c.read_back_linear().unwrap();
    for (got, input) in linear.rgba.iter().zip(&scene.backdrop().linear) {
        assert!((got - input).abs() <= input.abs() * 1e-3 + 1e-7, "{got} vs {input}");
        if c.linear_format() == viewer::LINEAR_FORMAT {
            assert_eq!(got.to_bits(), input.to_bits());
        }
    }
}

//! `cargo xtask env-light`: the environment light's picture for docs/raytracer.md. A lat-long
//! sky is generated here (deterministic, no file downloaded): a blue gradient above the
//! horizon, a small sun 35 degrees high whose radiance is about 500 times the sky's, and a dull
//! ground below. A matte floor, a matte sphere and a mirror sphere under it are rendered by
//! the release `lrt-depth` with `path` and with `photonmap`; the map (tone mapped) and both
//! renders are written side by side to `docs/environment-light.png`, and the render times with
//! the load average are printed.

use crate::{cargo, run, workspace_root};
use std::f32::consts::PI;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

const MAP_WIDTH: u32 = 512;
const MAP_HEIGHT: u32 = 256;
const IMAGE_WIDTH: u32 = 320;
const IMAGE_HEIGHT: u32 = 240;

/// The sky's radiance toward direction `d` (+z up, unit).
fn sky(d: [f32; 3]) -> [f32; 3] {
    let sun = {
        let (elevation, azimuth) = (35f32.to_radians(), 60f32.to_radians());
        [elevation.cos() * azimuth.cos(), elevation.cos() * azimuth.sin(), elevation.sin()]
    };
    let cos_sun = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2];
    if cos_sun > 3f32.to_radians().cos() {
        return [400.0, 380.0, 330.0];
    }
    if d[2] >= 0.0 {
        // Whitish at the horizon, deep blue at the zenith.
        let h = d[2].sqrt();
        [0.9 - 0.6 * h, 0.95 - 0.45 * h, 1.0 - 0.1 * h]
    } else {
        [0.3, 0.25, 0.2]
    }
}

/// The lat-long map: row 0 is straight up, `s = atan2(y, x) / 2 pi`, `t = acos(z) / pi`.
fn sky_map() -> Vec<[f32; 3]> {
    let mut texels = Vec::with_capacity((MAP_WIDTH * MAP_HEIGHT) as usize);
    for y in 0..MAP_HEIGHT {
        let theta = (y as f32 + 0.5) / MAP_HEIGHT as f32 * PI;
        for x in 0..MAP_WIDTH {
            let phi = (x as f32 + 0.5) / MAP_WIDTH as f32 * 2.0 * PI;
            texels.push(sky([theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()]));
        }
    }
    texels
}

fn scene(integrator: &str) -> String {
    format!(
        "MakeLatLongEnvironment \"sky.exr\" \"sky.env\" \"box\" 1 1\n\
         Format {IMAGE_WIDTH} {IMAGE_HEIGHT} 1\nPixelSamples 8 8\nPixelFilter \"gaussian\" 2 2\n\
         Projection \"perspective\" \"fov\" [40]\nTranslate 0 0 7\nRotate -105 1 0 0\nRotate -30 0 0 1\n\
         SurfaceIntegrator {integrator}\nWorldBegin\n\
         LightSource \"envlight\" 1 \"string envmap\" [\"sky.env\"] \"intensity\" [1]\n\
         AttributeBegin\nColor [0.7 0.7 0.7]\nSurface \"matte\"\n\
         Polygon \"P\" [-6 -6 0  6 -6 0  6 6 0  -6 6 0]\nAttributeEnd\n\
         AttributeBegin\nColor [0.8 0.3 0.2]\nSurface \"matte\"\nTranslate -0.8 0.2 1\nSphere 1 -1 1 360\nAttributeEnd\n\
         AttributeBegin\nSurface \"mirror\"\nTranslate 1.3 -0.6 0.7\nSphere 0.7 -0.7 0.7 360\nAttributeEnd\n\
         WorldEnd\n"
    )
}

/// sRGB encoding of a linear value in [0, 1].
fn srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let e = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (e * 255.0).round() as u8
}

pub fn env_light(_args: &[String]) -> Result<(), String> {
    run(cargo().args(["build", "--release", "-p", "lrt-depth"]))?;
    let root = workspace_root();
    let work = root.join("target/env-light");
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work).map_err(|e| e.to_string())?;

    let texels = sky_map();
    let flat: Vec<f32> = texels.iter().flatten().copied().collect();
    let map = image::Rgb32FImage::from_raw(MAP_WIDTH, MAP_HEIGHT, flat).ok_or("map size")?;
    map.save(work.join("sky.exr")).map_err(|e| format!("sky.exr: {e}"))?;

    let lrt = root.join("target/release/lrt-depth");
    let mut renders = Vec::new();
    for (name, integrator) in [
        ("path", "\"path\""),
        ("photonmap", "\"photonmap\" \"integer indirectphotons\" [50000] \"integer causticphotons\" [50000]"),
    ] {
        let rib = work.join(format!("{name}.rib"));
        std::fs::write(&rib, scene(integrator)).map_err(|e| e.to_string())?;
        let png = work.join(format!("{name}.png"));
        let load = crate::bench_error::load_average();
        let start = Instant::now();
        let status = Command::new(&lrt)
            .current_dir(&work)
            .args([rib.to_str().ok_or("path")?, "-o", png.to_str().ok_or("path")?, "--threads", "2", "-q"])
            .status()
            .map_err(|e| format!("cannot start {}: {e}", lrt.display()))?;
        if !status.success() {
            return Err(format!("lrt-depth failed on {}", rib.display()));
        }
        println!(
            "{name}: {IMAGE_WIDTH}x{IMAGE_HEIGHT}, 64 samples per pixel, {:.1} s wall (load average before: {load})",
            start.elapsed().as_secs_f64()
        );
        renders.push(image::open(&png).map_err(|e| format!("{}: {e}", png.display()))?.to_rgb8());
    }

    // The map shown at the renders' height, tone mapped by clamping (the sun saturates).
    let map_width = IMAGE_HEIGHT * 2;
    let mut sheet = image::RgbImage::new(map_width + 2 * IMAGE_WIDTH, IMAGE_HEIGHT);
    for y in 0..IMAGE_HEIGHT {
        for x in 0..map_width {
            let (mx, my) = (x * MAP_WIDTH / map_width, y * MAP_HEIGHT / IMAGE_HEIGHT);
            let t = texels[(my * MAP_WIDTH + mx) as usize];
            sheet.put_pixel(x, y, image::Rgb([srgb(t[0]), srgb(t[1]), srgb(t[2])]));
        }
    }
    for (k, render) in renders.iter().enumerate() {
        image::imageops::replace(&mut sheet, render, i64::from(map_width + k as u32 * IMAGE_WIDTH), 0);
    }
    let out = root.join("docs/environment-light.png");
    write_atomically(&sheet, &out)?;
    println!("wrote {}", out.display());
    Ok(())
}

fn write_atomically(image: &image::RgbImage, path: &Path) -> Result<(), String> {
    let tmp = path.with_extension("png.tmp");
    image.save_with_format(&tmp, image::ImageFormat::Png).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("{}: {e}", path.display()))
}

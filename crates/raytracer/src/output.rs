//! Writing images: `Exposure`, `Quantize` and the file formats, atomically.
//!
//! The format comes from the file name's extension (`.tif`/`.tiff`, `.png`, `.jpg`/`.jpeg`,
//! `.exr`), else from the display driver (`"tiff"`/`"file"`, `"png"`, `"jpeg"`, `"openexr"`).
//!
//! | `Quantize "rgba" one min max dither` | TIFF | PNG | JPEG | EXR |
//! |---|---|---|---|---|
//! | `one = 0` (float) | 32-bit float | 16-bit (no float PNG) | 8-bit | 32-bit float |
//! | `max <= 255` | 8-bit | 8-bit | 8-bit | 32-bit float |
//! | `max > 255` | 16-bit | 16-bit | 8-bit (no 16-bit JPEG) | 32-bit float |
//!
//! Integer outputs get `out = (gain * v)^(1/gamma)` (RenderMan's `Exposure`), then
//! `round(one * out + dither * r)` clamped to `[min, max]` with `r` uniform in `[-1, 1]` from a
//! hash of the pixel (deterministic), scaled to the file's bit depth when `max` differs from it.
//! Float outputs (EXR, float TIFF) stay linear: only the gain is applied. Alpha is written for
//! the display modes that contain `a` (`"rgba"`); colour is premultiplied by coverage, as
//! RenderMan writes it. Files are written to a temporary name in the same directory and renamed
//! into place, so a reader never sees half a file.
//!
//! A crop window's region is written as an image of the region's size. EXR files also record
//! where it sits: the display window is the full frame and the data window the region (as pbrt
//! and PRMan write crops), which is what `lrt-merge` reads to put tiles back together. Dither
//! is a function of the full-frame pixel, so 8- and 16-bit tiles hold the same bytes as the
//! full frame's pixels too.

use crate::film::Image;
use crate::sampling::mix64;
use image::{DynamicImage, ImageBuffer, ImageFormat, Rgb, Rgba};
use rib_parser::scene::{Exposure, Quantize};
use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

/// An image file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Tiff,
    Png,
    Jpeg,
    Exr,
}

impl Format {
    /// The format for a file name (by extension) and display driver.
    pub fn for_output(path: &Path, driver: &str) -> Option<Format> {
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("tif" | "tiff") => return Some(Format::Tiff),
            Some("png") => return Some(Format::Png),
            Some("jpg" | "jpeg") => return Some(Format::Jpeg),
            Some("exr") => return Some(Format::Exr),
            _ => {}
        }
        match driver.to_ascii_lowercase().as_str() {
            "tiff" | "file" | "tif" => Some(Format::Tiff),
            "png" => Some(Format::Png),
            "jpeg" | "jpg" => Some(Format::Jpeg),
            "openexr" | "exr" => Some(Format::Exr),
            _ => None,
        }
    }
}

/// Why an image could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    #[error("{path}: cannot tell the image format from the name or the display driver \"{driver}\"")]
    UnknownFormat { path: PathBuf, driver: String },
    #[error("{path}: {message}")]
    Encode { path: PathBuf, message: String },
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

/// How to turn radiance into file values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputSettings {
    pub exposure: Exposure,
    pub quantize: Quantize,
    /// Write an alpha channel.
    pub alpha: bool,
}

/// What the writer had to change (e.g. 16 bits asked of JPEG), for warnings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OutputNotes {
    pub notes: Vec<String>,
}

/// Writes `data` to `path` atomically (a temporary file in the same directory, then a rename).
pub fn write_atomically(path: &Path, data: &[u8]) -> Result<(), OutputError> {
    let io = |source| OutputError::Io { path: path.to_path_buf(), source };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(data)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}

/// Deterministic dither in `[-1, 1]` for pixel `(x, y)`, channel `c`.
fn dither_noise(x: u32, y: u32, c: u32) -> f32 {
    let h = mix64((u64::from(x) << 40) ^ (u64::from(y) << 8) ^ u64::from(c) ^ 0x5eed);
    ((h >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
}

/// Applies `Exposure` (gain, then gamma) to a linear value.
#[inline]
pub fn expose(v: f32, exposure: Exposure) -> f32 {
    let g = v * exposure.gain;
    if g <= 0.0 || !g.is_finite() {
        return if g.is_infinite() && g > 0.0 { f32::MAX } else { 0.0 };
    }
    if exposure.gamma == 1.0 || !(exposure.gamma > 0.0) { g } else { g.powf(1.0 / exposure.gamma) }
}

/// Quantises an exposed value to `[min, max]` (RenderMan's `Quantize`).
#[inline]
fn quantize(v: f32, q: Quantize, noise: f32) -> f32 {
    let one = q.one as f32;
    let value = (one * v + q.dither * noise).round();
    value.clamp(q.min as f32, q.max as f32)
}

/// Encodes and writes `image` (a crop window's region is written as the whole image).
pub fn write_image(
    path: &Path,
    driver: &str,
    image: &Image,
    settings: &OutputSettings,
) -> Result<OutputNotes, OutputError> {
    let format = Format::for_output(path, driver)
        .ok_or_else(|| OutputError::UnknownFormat { path: path.to_path_buf(), driver: driver.to_string() })?;
    let (bytes, notes) = encode(format, image, settings)
        .map_err(|message| OutputError::Encode { path: path.to_path_buf(), message })?;
    write_atomically(path, &bytes)?;
    Ok(notes)
}

/// Writes `image` as OpenEXR (as [`write_image`] does for an `.exr` name) with `stamp` as text
/// attributes of its layer: a render farm's tiles say which render, frame and tile they are.
pub fn write_stamped_exr(
    path: &Path,
    image: &Image,
    settings: &OutputSettings,
    stamp: &[(String, String)],
) -> Result<(), OutputError> {
    let encode_error = |message: String| OutputError::Encode { path: path.to_path_buf(), message };
    if image.width == 0 || image.height == 0 {
        return Err(encode_error("the image has no pixels".into()));
    }
    // As `encode` writes OpenEXR: linear, with the exposure's gain only.
    let linear = |p: &[f32; 4], c: usize| if c == 3 { p[3] } else { p[c] * settings.exposure.gain };
    let bytes = encode_exr(image, settings.alpha, linear, stamp).map_err(encode_error)?;
    write_atomically(path, &bytes)
}

/// Encodes `image` in `format` into memory.
pub fn encode(
    format: Format,
    image: &Image,
    settings: &OutputSettings,
) -> Result<(Vec<u8>, OutputNotes), String> {
    let mut notes = OutputNotes::default();
    let q = settings.quantize;
    let float = q.one == 0;
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 {
        return Err("the image has no pixels".into());
    }
    let linear = |p: &[f32; 4], c: usize| if c == 3 { p[3] } else { p[c] * settings.exposure.gain };
    let dynamic = match format {
        Format::Exr => return Ok((encode_exr(image, settings.alpha, linear, &[])?, notes)),
        Format::Tiff if float => float_image(image, settings.alpha, linear),
        _ => {
            let mut bits16 = float || q.max > 255;
            if float {
                notes.notes.push(format!(
                    "{format:?} cannot hold floating-point values: written as 16-bit integers"
                ));
            }
            if format == Format::Jpeg && bits16 {
                notes.notes.push("JPEG holds 8 bits per channel: written as 8-bit".into());
                bits16 = false;
            }
            // Float requests quantise to the full range of the integer depth chosen.
            let q = if float {
                let max = if bits16 { 65535 } else { 255 };
                Quantize { one: max, min: 0, max, dither: 0.0 }
            } else {
                q
            };
            let file_max = if bits16 { 65535.0 } else { 255.0 };
            // A Quantize range other than the file's depth is rescaled to it.
            let rescale = if q.max > 0 { file_max / q.max as f32 } else { 1.0 };
            let value = |x: u32, y: u32, c: usize| {
                let p = &image.pixels[(y * w + x) as usize];
                let v = if c == 3 { p[3] } else { expose(p[c], settings.exposure) };
                let noise = dither_noise(x + image.x_offset, y + image.y_offset, c as u32);
                (quantize(v, q, noise) * rescale).clamp(0.0, file_max)
            };
            let channels = if settings.alpha && format != Format::Jpeg { 4 } else { 3 };
            if bits16 {
                let mut data = Vec::with_capacity((w * h) as usize * channels);
                for y in 0..h {
                    for x in 0..w {
                        for c in 0..channels {
                            data.push(value(x, y, c) as u16);
                        }
                    }
                }
                if channels == 4 {
                    DynamicImage::ImageRgba16(
                        ImageBuffer::<Rgba<u16>, _>::from_raw(w, h, data).ok_or("buffer size")?,
                    )
                } else {
                    DynamicImage::ImageRgb16(
                        ImageBuffer::<Rgb<u16>, _>::from_raw(w, h, data).ok_or("buffer size")?,
                    )
                }
            } else {
                let mut data = Vec::with_capacity((w * h) as usize * channels);
                for y in 0..h {
                    for x in 0..w {
                        for c in 0..channels {
                            data.push(value(x, y, c) as u8);
                        }
                    }
                }
                if channels == 4 {
                    DynamicImage::ImageRgba8(
                        ImageBuffer::<Rgba<u8>, _>::from_raw(w, h, data).ok_or("buffer size")?,
                    )
                } else {
                    DynamicImage::ImageRgb8(
                        ImageBuffer::<Rgb<u8>, _>::from_raw(w, h, data).ok_or("buffer size")?,
                    )
                }
            }
        }
    };
    let image_format = match format {
        Format::Tiff => ImageFormat::Tiff,
        Format::Png => ImageFormat::Png,
        Format::Jpeg => ImageFormat::Jpeg,
        Format::Exr => ImageFormat::OpenExr,
    };
    let mut out = Cursor::new(Vec::new());
    dynamic.write_to(&mut out, image_format).map_err(|e| e.to_string())?;
    Ok((out.into_inner(), notes))
}

/// 32-bit float RGB(A) OpenEXR with the crop region placed in the full frame (data window inside
/// the display window).
fn encode_exr(
    image: &Image,
    alpha: bool,
    linear: impl Fn(&[f32; 4], usize) -> f32,
    stamp: &[(String, String)],
) -> Result<Vec<u8>, String> {
    use exr::prelude::{
        AnyChannel, AnyChannels, Encoding, FlatSamples, Image as ExrImage, IntegerBounds, Layer,
        LayerAttributes, SmallVec, Vec2, WritableImage,
    };
    let channel = |name: &str, c: usize| {
        AnyChannel::new(name, FlatSamples::F32(image.pixels.iter().map(|p| linear(p, c)).collect()))
    };
    let mut channels = vec![channel("R", 0), channel("G", 1), channel("B", 2)];
    if alpha {
        channels.push(channel("A", 3));
    }
    let position = |v: u32| i32::try_from(v).map_err(|_| format!("offset {v} does not fit OpenEXR"));
    let layer_position = Vec2(position(image.x_offset)?, position(image.y_offset)?);
    let mut attributes = LayerAttributes { layer_position, ..LayerAttributes::default() };
    for (key, value) in stamp {
        attributes.other.insert(
            exr::prelude::Text::from(key.as_str()),
            exr::meta::attribute::AttributeValue::Text(exr::prelude::Text::from(value.as_str())),
        );
    }
    let layer = Layer::new(
        (image.width as usize, image.height as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let mut exr_image = ExrImage::from_layer(layer);
    exr_image.attributes.display_window = IntegerBounds::new(
        (0, 0),
        (image.full_width.max(image.width) as usize, image.full_height.max(image.height) as usize),
    );
    let mut out = Cursor::new(Vec::new());
    exr_image.write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    let mut bytes = out.into_inner();
    // The stamp's attributes are hashed in a random order by exr; name order makes the file
    // the same bytes on every run.
    sidecar::sort_exr_header_attributes(&mut bytes);
    Ok(bytes)
}

fn float_image(image: &Image, alpha: bool, linear: impl Fn(&[f32; 4], usize) -> f32) -> DynamicImage {
    let (w, h) = (image.width, image.height);
    if alpha {
        let data: Vec<f32> = image
            .pixels
            .iter()
            .flat_map(|p| [linear(p, 0), linear(p, 1), linear(p, 2), linear(p, 3)])
            .collect();
        DynamicImage::ImageRgba32F(ImageBuffer::<Rgba<f32>, _>::from_raw(w, h, data).unwrap_or_default())
    } else {
        let data: Vec<f32> =
            image.pixels.iter().flat_map(|p| [linear(p, 0), linear(p, 1), linear(p, 2)]).collect();
        DynamicImage::ImageRgb32F(ImageBuffer::<Rgb<f32>, _>::from_raw(w, h, data).unwrap_or_default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image() -> Image {
        Image {
            width: 2,
            height: 1,
            x_offset: 0,
            y_offset: 0,
            full_width: 2,
            full_height: 1,
            pixels: vec![[0.25, 0.5, 1.0, 1.0], [2.0, 0.0, 0.1, 0.5]],
        }
    }

    fn settings(one: i32, max: i32, gamma: f32) -> OutputSettings {
        OutputSettings {
            exposure: Exposure { gain: 1.0, gamma },
            quantize: Quantize { one, min: 0, max, dither: 0.0 },
            alpha: true,
        }
    }

    #[test]
    fn formats_round_trip() {
        let scratch = tempfile::Builder::new().prefix("raytracer-output-").tempdir().unwrap();
        let dir = scratch.path();
        for (name, s) in [
            ("a.png", settings(255, 255, 1.0)),
            ("b.png", settings(65535, 65535, 1.0)),
            ("c.tif", settings(255, 255, 2.2)),
            ("d.tif", settings(0, 0, 1.0)),
            ("e.jpg", settings(255, 255, 1.0)),
            ("f.exr", settings(0, 0, 1.0)),
        ] {
            let path = dir.join(name);
            write_image(&path, "file", &image(), &s).unwrap();
            let back = image::open(&path).unwrap();
            assert_eq!((back.width(), back.height()), (2, 1), "{name}");
            let px = back.to_rgba32f();
            let p = px.get_pixel(0, 0);
            let expected = if s.exposure.gamma == 2.2 { 0.5f32.powf(1.0 / 2.2) } else { 0.5 };
            let tolerance = if name.ends_with(".jpg") { 0.05 } else { 1.0 / 255.0 };
            assert!((p[1] - expected).abs() <= tolerance, "{name}: {p:?}");
            // Out-of-range values clamp in integer files and stay in float ones.
            let q = px.get_pixel(1, 0);
            if name.ends_with(".exr") || name == "d.tif" {
                assert!((q[0] - 2.0).abs() < 1e-6, "{name}");
            } else {
                assert!((q[0] - 1.0).abs() < 1e-6, "{name}");
            }
        }
        // No temporary files are left behind.
        let leftovers: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
            .collect();
        assert!(leftovers.is_empty());
    }

    #[test]
    fn stamped_exr_is_the_same_bytes_every_time() {
        let stamp: Vec<(String, String)> = ["render", "frame", "tile", "of", "seed"]
            .iter()
            .map(|k| (format!("lrt.{k}"), format!("{k} value")))
            .collect();
        let first = encode_exr(&image(), true, |p, c| p[c], &stamp).unwrap();
        for attempt in 0..8 {
            let again = encode_exr(&image(), true, |p, c| p[c], &stamp).unwrap();
            assert!(again == first, "encoding {attempt} differs from the first");
        }
    }

    #[test]
    fn format_from_name_and_driver() {
        assert_eq!(Format::for_output(Path::new("x.TIF"), "framebuffer"), Some(Format::Tiff));
        assert_eq!(Format::for_output(Path::new("x.pic"), "file"), Some(Format::Tiff));
        assert_eq!(Format::for_output(Path::new("x"), "openexr"), Some(Format::Exr));
        assert_eq!(Format::for_output(Path::new("x"), "framebuffer"), None);
    }

    #[test]
    fn quantize_with_dither_stays_in_range() {
        let q = Quantize { one: 255, min: 0, max: 255, dither: 0.5 };
        for x in 0..100 {
            let v = quantize(0.5, q, dither_noise(x, 3, 1));
            assert!((127.0..=128.0).contains(&v));
        }
        assert!((expose(0.25, Exposure { gain: 4.0, gamma: 2.0 }) - 1.0).abs() < 1e-6);
    }
}

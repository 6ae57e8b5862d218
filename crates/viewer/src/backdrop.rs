//! The pre-rendered image (the depth table is `depth_remap::DepthTable`).
//!
//! The compositor works in linear values in the image's own units ([`Backdrop`]) and encodes
//! the frame for display once, the same way for pre-rendered and live pixels
//! ([`crate::display`]).
//!
//! - OpenEXR images and 32-bit float TIFFs hold linear values and are taken as they are:
//!   `lrt-depth` writes float outputs with `Exposure`'s gain already applied. They are shown
//!   with the sRGB transfer when the RIB's gamma is 1 (as EXR viewers show them), else with the
//!   RIB's gamma, and dithered ([`DisplayEncoding::for_float_image`]).
//! - PNG, JPEG and integer TIFF images are display values already: their bytes are shown
//!   untouched (16-bit values are reduced to 8 bits by `image`'s rounding, `round(v / 257)`),
//!   and their linear values are the bytes decoded with the RIB's gamma, `(b / 255)^gamma`, the
//!   exact inverse of how `lrt-depth` writes 8-bit files (`Quantize`'s dither aside).

use crate::display::DisplayEncoding;
use crate::error::ViewerError;
use std::path::Path;

/// Largest image side accepted (pixels). The GPU's own texture limit is checked as well when the
/// compositor is created.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// The RIB's `Exposure gain gamma`: the gain scales live radiance into the image's units, the
/// gamma decodes 8-bit images and chooses the display transfer ([`crate::display`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMap {
    pub gain: f32,
    pub gamma: f32,
}

impl Default for ToneMap {
    fn default() -> Self {
        ToneMap { gain: 1.0, gamma: 1.0 }
    }
}

/// An 8-bit RGBA image, rows top to bottom, 4 bytes per pixel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgba8Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<u8>,
}

impl Rgba8Image {
    /// An image of `width x height` filled with one colour.
    pub fn filled(width: u32, height: u32, rgba: [u8; 4]) -> Rgba8Image {
        let pixels = rgba.iter().copied().cycle().take(width as usize * height as usize * 4).collect();
        Rgba8Image { width, height, pixels }
    }

    /// Writes the image as PNG, atomically (temporary file + rename).
    pub fn write_png(&self, path: &Path) -> Result<(), ViewerError> {
        write_png_atomically(path, self.width, self.height, image::ExtendedColorType::Rgba8, &self.pixels)
    }
}

/// The pre-rendered image as the compositor draws it: linear values in the image's own units,
/// the display values of its unchanged pixels, and the encoding from the first to the second.
#[derive(Clone, Debug, PartialEq)]
pub struct Backdrop {
    pub width: u32,
    pub height: u32,
    /// Linear RGBA, 4 floats per pixel, rows top to bottom; finite.
    pub linear: Vec<f32>,
    /// What the window shows where nothing live changes a pixel: the input bytes of an 8-bit
    /// image, the encoded values of a float image.
    pub display: Rgba8Image,
    pub encoding: DisplayEncoding,
    /// Whether the input held float values (an EXR or float TIFF), not display bytes.
    pub is_float: bool,
}

impl Backdrop {
    /// An 8-bit image whose bytes are display values under `gamma`: linear values are
    /// `(b / 255)^gamma` (alpha `b / 255`), and the display is the bytes themselves.
    pub fn from_rgba8(image: Rgba8Image, gamma: f32) -> Backdrop {
        let encoding = DisplayEncoding::for_8bit_image(gamma);
        let gamma = match encoding.transfer {
            crate::display::DisplayTransfer::Gamma(g) => f64::from(g),
            crate::display::DisplayTransfer::Srgb => 1.0,
        };
        let table: Vec<f32> = (0..=255u8).map(|b| (f64::from(b) / 255.0).powf(gamma) as f32).collect();
        let linear = image
            .pixels
            .chunks_exact(4)
            .flat_map(|p| {
                [table[p[0] as usize], table[p[1] as usize], table[p[2] as usize], f32::from(p[3]) / 255.0]
            })
            .collect();
        Backdrop {
            width: image.width,
            height: image.height,
            linear,
            display: image,
            encoding,
            is_float: false,
        }
    }

    /// A float image (linear RGBA, 4 values per pixel) shown with the float encoding for the
    /// RIB's `gamma`. Values must be finite.
    pub fn from_linear(
        width: u32,
        height: u32,
        linear: Vec<f32>,
        gamma: f32,
    ) -> Result<Backdrop, ViewerError> {
        if linear.len() != width as usize * height as usize * 4 {
            return Err(ViewerError::Invalid("the image's pixel buffer does not match its size".into()));
        }
        if let Some(k) = linear.iter().position(|v| !v.is_finite()) {
            let pixel = k / 4;
            return Err(ViewerError::Invalid(format!(
                "the image holds {} at pixel ({}, {}); values must be finite",
                linear[k],
                pixel % width as usize,
                pixel / width as usize
            )));
        }
        let encoding = DisplayEncoding::for_float_image(gamma);
        let pixels = linear
            .chunks_exact(4)
            .enumerate()
            .flat_map(|(k, p)| {
                let (x, y) = ((k % width as usize) as u32, (k / width as usize) as u32);
                [
                    encoding.encode(p[0], x, y, width, 0),
                    encoding.encode(p[1], x, y, width, 1),
                    encoding.encode(p[2], x, y, width, 2),
                    (p[3].clamp(0.0, 1.0) * 255.0).round() as u8,
                ]
            })
            .collect();
        let display = Rgba8Image { width, height, pixels };
        Ok(Backdrop { width, height, linear, display, encoding, is_float: true })
    }

    /// Reads a PNG, JPEG, TIFF or OpenEXR file (by content for the first three, by the `.exr`
    /// extension for the last); `gamma` is the RIB's `Exposure` gamma.
    pub fn read(path: &Path, gamma: f32) -> Result<Backdrop, ViewerError> {
        let is_exr = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let bad = |e: ViewerError| match e {
            ViewerError::Invalid(message) => ViewerError::BadInput { path: path.to_path_buf(), message },
            other => other,
        };
        if is_exr {
            let (w, h, linear) = read_exr_linear(path)?;
            return Backdrop::from_linear(w, h, linear, gamma).map_err(bad);
        }
        match decode_integer_or_float(path)? {
            Decoded::Float(rgba) => {
                let (w, h) = (rgba.width(), rgba.height());
                Backdrop::from_linear(w, h, rgba.into_raw(), gamma).map_err(bad)
            }
            Decoded::Bytes(image) => Ok(Backdrop::from_rgba8(image, gamma)),
        }
    }
}

fn check_size(path: &Path, width: u32, height: u32) -> Result<(), ViewerError> {
    if width == 0 || height == 0 || width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE {
        return Err(ViewerError::BadInput {
            path: path.to_path_buf(),
            message: format!("image size {width}x{height} is outside 1..={MAX_IMAGE_SIDE} pixels per side"),
        });
    }
    Ok(())
}

/// A decoded non-EXR file: float values (a float TIFF) or display bytes.
enum Decoded {
    Float(image::Rgba32FImage),
    Bytes(Rgba8Image),
}

fn decode_integer_or_float(path: &Path) -> Result<Decoded, ViewerError> {
    let bad = |message: String| ViewerError::BadInput { path: path.to_path_buf(), message };
    let reader = image::ImageReader::open(path)
        .map_err(|e| ViewerError::Io { path: path.to_path_buf(), source: e })?
        .with_guessed_format()
        .map_err(|e| ViewerError::Io { path: path.to_path_buf(), source: e })?;
    let mut reader = reader;
    // Bound the decoder's allocation: the largest accepted image, RGBA at 16 bits per channel.
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(u64::from(MAX_IMAGE_SIDE) * u64::from(MAX_IMAGE_SIDE) * 8);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| bad(format!("cannot decode the image: {e}")))?;
    check_size(path, decoded.width(), decoded.height())?;
    if matches!(decoded, image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)) {
        // A float TIFF holds linear values, like an EXR.
        return Ok(Decoded::Float(decoded.to_rgba32f()));
    }
    let rgba = decoded.to_rgba8();
    Ok(Decoded::Bytes(Rgba8Image { width: rgba.width(), height: rgba.height(), pixels: rgba.into_raw() }))
}

/// Reads an OpenEXR file's RGB channels as linear RGBA (alpha 1).
fn read_exr_linear(path: &Path) -> Result<(u32, u32, Vec<f32>), ViewerError> {
    use exr::prelude::*;
    let bad = |message: String| ViewerError::BadInput { path: path.to_path_buf(), message };
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |resolution, _| {
                let (w, h) = (resolution.width(), resolution.height());
                // An impossible size yields an empty buffer; the size check below rejects it.
                let ok = w > 0 && h > 0 && w <= MAX_IMAGE_SIDE as usize && h <= MAX_IMAGE_SIDE as usize;
                (w, h, if ok { vec![0f32; w * h * 4] } else { Vec::new() })
            },
            move |(w, _, pixels): &mut (usize, usize, Vec<f32>), position, (r, g, b): (f32, f32, f32)| {
                let k = (position.y() * *w + position.x()) * 4;
                if let Some(px) = pixels.get_mut(k..k + 4) {
                    px.copy_from_slice(&[r, g, b, 1.0]);
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| bad(format!("cannot read the OpenEXR image: {e}")))?;
    let (w, h, pixels) = image.layer_data.channel_data.pixels;
    check_size(path, w as u32, h as u32)?;
    Ok((w as u32, h as u32, pixels))
}

/// Writes an 8-bit PNG atomically: a temporary file beside the target, then a rename.
pub(crate) fn write_png_atomically(
    path: &Path,
    width: u32,
    height: u32,
    color: image::ExtendedColorType,
    bytes: &[u8],
) -> Result<(), ViewerError> {
    use image::ImageEncoder;
    write_atomically(path, |tmp| {
        let io = |e: std::io::Error| ViewerError::Io { path: path.to_path_buf(), source: e };
        let file = std::fs::File::create(tmp).map_err(io)?;
        let mut writer = std::io::BufWriter::new(file);
        image::codecs::png::PngEncoder::new(&mut writer).write_image(bytes, width, height, color).map_err(
            |e| ViewerError::BadInput {
                path: path.to_path_buf(),
                message: format!("cannot encode PNG: {e}"),
            },
        )?;
        writer.into_inner().map_err(|e| io(e.into_error()))?;
        Ok(())
    })
}

/// Writes `path` atomically: `write` fills a temporary file beside it, which is synced and
/// renamed over `path`, or removed if anything fails.
pub(crate) fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), ViewerError>,
) -> Result<(), ViewerError> {
    let io = |e: std::io::Error| ViewerError::Io { path: path.to_path_buf(), source: e };
    let file_name =
        path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let tmp = path.with_file_name(format!(".{file_name}.tmp{}", std::process::id()));
    let result = write(&tmp).and_then(|()| {
        std::fs::File::open(&tmp).and_then(|f| f.sync_all()).map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("viewer-backdrop-{name}-")).tempdir().unwrap()
    }

    #[test]
    fn float_images_stay_linear_and_8bit_images_are_copied() {
        let scratch_dir = scratch("read");
        let dir = scratch_dir.path();
        let value = |x: usize, y: usize| (x as f32 * 0.3, y as f32 * 0.45, 1.7 - x as f32 * 0.2);
        let exr_path = dir.join("a.exr");
        exr::prelude::write_rgb_file(&exr_path, 5, 3, value).unwrap();
        let img = Backdrop::read(&exr_path, 2.2).unwrap();
        assert!(img.is_float);
        assert_eq!((img.width, img.height), (5, 3));
        for y in 0..3 {
            for x in 0..5 {
                let (r, g, b) = value(x, y);
                let k = (y * 5 + x) * 4;
                assert_eq!(img.linear[k..k + 4], [r, g, b, 1.0]);
                let e = img.encoding;
                let (xu, yu) = (x as u32, y as u32);
                let bytes =
                    [e.encode(r, xu, yu, 5, 0), e.encode(g, xu, yu, 5, 1), e.encode(b, xu, yu, 5, 2), 255];
                assert_eq!(img.display.pixels[k..k + 4], bytes);
            }
        }
        let png_path = dir.join("a.png");
        let rgba = image::RgbaImage::from_fn(4, 2, |x, y| image::Rgba([x as u8 * 60, y as u8 * 200, 7, 255]));
        rgba.save(&png_path).unwrap();
        assert_eq!(Backdrop::read(&png_path, 2.2).unwrap().display.pixels, rgba.into_raw());
        let png16 = dir.join("b.png");
        let wide = image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(2, 1, |x, _| {
            image::Rgb([x as u16 * 40000, 257, 65535])
        });
        wide.save(&png16).unwrap();
        assert_eq!(
            Backdrop::read(&png16, 2.2).unwrap().display.pixels,
            vec![0, 1, 255, 255, 156, 1, 255, 255]
        );
        assert!(Backdrop::read(&dir.join("missing.png"), 2.2).is_err());
        std::fs::write(dir.join("junk.png"), b"not an image").unwrap();
        assert!(Backdrop::read(&dir.join("junk.png"), 2.2).is_err());
    }
}

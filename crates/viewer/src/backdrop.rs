//! The pre-rendered image: 8-bit RGBA, shown pixel for pixel (the depth table is
//! `depth_remap::DepthTable`).
//!
//! Image files: PNG, JPEG and TIFF are decoded to 8-bit RGBA and their values copied through
//! untouched (16-bit files are reduced to 8 bits by `image`'s rounding, `round(v / 257)`;
//! 32-bit float TIFFs are tone-mapped like EXRs).
//! OpenEXR images hold linear values and are tone-mapped the way `lrt-depth` writes its 8-bit
//! outputs: `byte = round(255 * clamp((gain * v) ^ (1 / gamma), 0, 1))` per channel with the
//! given [`ToneMap`]; alpha is 255. `lrt-depth` writes float outputs with `Exposure`'s gain
//! already applied, so for its EXRs the caller passes `gain = 1` and the RIB's gamma
//! ([`ToneMap::for_float_image`]). The one difference from `lrt-depth`'s own 8-bit files is
//! `Quantize`'s dither (default amplitude 0.5), which it adds before rounding and the viewer
//! does not: a value may differ by one step where the dither crossed a rounding boundary.

use crate::error::ViewerError;
use std::path::Path;

/// Largest image side accepted (pixels). The GPU's own texture limit is checked as well when the
/// compositor is created.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// `Exposure gain gamma`, applied to linear values to get display values.
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

impl ToneMap {
    /// The tone map for a float image written with this exposure: `lrt-depth` applies the gain
    /// to float outputs already, so only the gamma is left.
    pub fn for_float_image(self) -> ToneMap {
        ToneMap { gain: 1.0, gamma: self.gamma }
    }

    /// The 8-bit value of a linear channel value: `round(255 * clamp((gain v)^(1/gamma), 0, 1))`.
    /// NaN maps to 0.
    pub fn to_byte(self, v: f32) -> u8 {
        let scaled = self.gain * v;
        let display = if self.gamma == 1.0 { scaled } else { scaled.max(0.0).powf(1.0 / self.gamma) };
        if display.is_nan() {
            return 0;
        }
        (display.clamp(0.0, 1.0) * 255.0).round() as u8
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

    /// Reads a PNG, JPEG, TIFF or OpenEXR file (by content for the first three, by the `.exr`
    /// extension for the last). Float images (EXR, 32-bit float TIFF) are tone-mapped with
    /// `tone_map`; 8-bit values are copied through; 16-bit values become `round(v / 257)`.
    pub fn read(path: &Path, tone_map: ToneMap) -> Result<Rgba8Image, ViewerError> {
        let is_exr = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let image =
            if is_exr { read_exr_rgba(path, tone_map)? } else { read_integer_or_float(path, tone_map)? };
        check_size(path, image.width, image.height)?;
        Ok(image)
    }

    /// Writes the image as PNG, atomically (temporary file + rename).
    pub fn write_png(&self, path: &Path) -> Result<(), ViewerError> {
        write_png_atomically(path, self.width, self.height, image::ExtendedColorType::Rgba8, &self.pixels)
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

fn read_integer_or_float(path: &Path, tone_map: ToneMap) -> Result<Rgba8Image, ViewerError> {
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
    if matches!(decoded, image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)) {
        // A float TIFF holds linear values, like an EXR.
        let linear = decoded.to_rgba32f();
        let pixels = linear
            .pixels()
            .flat_map(|p| [tone_map.to_byte(p.0[0]), tone_map.to_byte(p.0[1]), tone_map.to_byte(p.0[2]), 255])
            .collect();
        return Ok(Rgba8Image { width: linear.width(), height: linear.height(), pixels });
    }
    let rgba = decoded.to_rgba8();
    Ok(Rgba8Image { width: rgba.width(), height: rgba.height(), pixels: rgba.into_raw() })
}

fn read_exr_rgba(path: &Path, tone_map: ToneMap) -> Result<Rgba8Image, ViewerError> {
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
                (w, h, if ok { vec![0u8; w * h * 4] } else { Vec::new() })
            },
            move |(w, _, pixels): &mut (usize, usize, Vec<u8>), position, (r, g, b): (f32, f32, f32)| {
                let k = (position.y() * *w + position.x()) * 4;
                if let Some(px) = pixels.get_mut(k..k + 4) {
                    px.copy_from_slice(&[tone_map.to_byte(r), tone_map.to_byte(g), tone_map.to_byte(b), 255]);
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| bad(format!("cannot read the OpenEXR image: {e}")))?;
    let (w, h, pixels) = image.layer_data.channel_data.pixels;
    check_size(path, w as u32, h as u32)?;
    Ok(Rgba8Image { width: w as u32, height: h as u32, pixels })
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
    let io = |e: std::io::Error| ViewerError::Io { path: path.to_path_buf(), source: e };
    let file_name =
        path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let tmp = path.with_file_name(format!(".{file_name}.tmp{}", std::process::id()));
    let result = (|| {
        let file = std::fs::File::create(&tmp).map_err(io)?;
        let mut writer = std::io::BufWriter::new(file);
        image::codecs::png::PngEncoder::new(&mut writer).write_image(bytes, width, height, color).map_err(
            |e| ViewerError::BadInput {
                path: path.to_path_buf(),
                message: format!("cannot encode PNG: {e}"),
            },
        )?;
        let file = writer.into_inner().map_err(|e| io(e.into_error()))?;
        file.sync_all().map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_map_matches_the_8bit_writer_rule() {
        let t = ToneMap::default();
        assert_eq!(
            [t.to_byte(0.0), t.to_byte(1.0), t.to_byte(0.5), t.to_byte(2.0), t.to_byte(-1.0)],
            [0, 255, 128, 255, 0]
        );
        assert_eq!(t.to_byte(f32::NAN), 0);
        let g = ToneMap { gain: 2.0, gamma: 2.2 };
        assert_eq!(g.to_byte(0.25), ((0.5f32).powf(1.0 / 2.2) * 255.0).round() as u8);
    }

    fn scratch(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("viewer-backdrop-{name}-")).tempdir().unwrap()
    }

    #[test]
    fn float_images_are_tone_mapped_and_8bit_images_copied() {
        let scratch_dir = scratch("read");
        let dir = scratch_dir.path();
        let value = |x: usize, y: usize| (x as f32 * 0.3, y as f32 * 0.45, 1.7 - x as f32 * 0.2);
        let exr_path = dir.join("a.exr");
        exr::prelude::write_rgb_file(&exr_path, 5, 3, value).unwrap();
        let tone = ToneMap { gain: 1.5, gamma: 2.2 };
        let img = Rgba8Image::read(&exr_path, tone).unwrap();
        assert_eq!((img.width, img.height), (5, 3));
        for y in 0..3 {
            for x in 0..5 {
                let (r, g, b) = value(x, y);
                let k = (y * 5 + x) * 4;
                assert_eq!(img.pixels[k..k + 4], [tone.to_byte(r), tone.to_byte(g), tone.to_byte(b), 255]);
            }
        }
        let png_path = dir.join("a.png");
        let rgba = image::RgbaImage::from_fn(4, 2, |x, y| image::Rgba([x as u8 * 60, y as u8 * 200, 7, 255]));
        rgba.save(&png_path).unwrap();
        assert_eq!(Rgba8Image::read(&png_path, tone).unwrap().pixels, rgba.into_raw());
        let png16 = dir.join("b.png");
        let wide = image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(2, 1, |x, _| {
            image::Rgb([x as u16 * 40000, 257, 65535])
        });
        wide.save(&png16).unwrap();
        assert_eq!(Rgba8Image::read(&png16, tone).unwrap().pixels, vec![0, 1, 255, 255, 156, 1, 255, 255]);
        assert!(Rgba8Image::read(&dir.join("missing.png"), tone).is_err());
        std::fs::write(dir.join("junk.png"), b"not an image").unwrap();
        assert!(Rgba8Image::read(&dir.join("junk.png"), tone).is_err());
    }
}

//! The pre-rendered inputs: the image (8-bit RGBA, shown pixel for pixel) and its depth table.
//!
//! Image files: PNG, JPEG and TIFF are decoded to 8-bit RGBA and their values copied through
//! untouched (16-bit files are reduced to 8 bits by `image`'s rounding, `round(v / 257)`).
//! OpenEXR images hold linear radiance and are tone-mapped exactly the way `lrt-depth` writes
//! its 8-bit outputs: `byte = round(255 * clamp((gain * v) ^ (1 / gamma), 0, 1))` per channel,
//! with the RIB's `Exposure gain gamma` ([`ToneMap`]); alpha is 255.

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
    /// extension for the last). EXR values are tone-mapped with `tone_map`.
    pub fn read(path: &Path, tone_map: ToneMap) -> Result<Rgba8Image, ViewerError> {
        let is_exr = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let image = if is_exr { read_exr_rgba(path, tone_map)? } else { read_8bit(path)? };
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

fn read_8bit(path: &Path) -> Result<Rgba8Image, ViewerError> {
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

/// A radial depth table: per pixel, the distance from the eye along the pixel-centre ray to the
/// nearest surface, `inf` for a miss (CONTRACTS.md §2). Rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct RadialDepth {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
}

impl RadialDepth {
    /// Reads an ASCII `.depth` table or an OpenEXR `Z` image (by the `.exr` extension).
    ///
    /// PROVISIONAL: the depth-table reader belongs to `depth_remap`; this one follows
    /// CONTRACTS.md §2 and is replaced by theirs when it lands.
    pub fn read(path: &Path) -> Result<RadialDepth, ViewerError> {
        let is_exr = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        if is_exr {
            return read_depth_exr(path);
        }
        let text =
            std::fs::read(path).map_err(|e| ViewerError::Io { path: path.to_path_buf(), source: e })?;
        let text = std::str::from_utf8(&text).map_err(|e| ViewerError::BadInput {
            path: path.to_path_buf(),
            message: format!("the depth table is not UTF-8 text: {e}"),
        })?;
        parse_depth_table(text).map_err(|(line, column, message)| ViewerError::BadInput {
            path: path.to_path_buf(),
            message: format!("{line}:{column}: {message}"),
        })
    }
}

/// Parses the ASCII depth table; errors are `(line, column, message)`, 1-based.
fn parse_depth_table(text: &str) -> Result<RadialDepth, (usize, usize, String)> {
    let mut header: Option<(u32, u32)> = None;
    let mut width: Option<u32> = None;
    let mut values = Vec::new();
    let mut rows = 0u32;
    for (line_index, raw_line) in text.split('\n').enumerate() {
        let line_no = line_index + 1;
        let line = raw_line.strip_suffix('\r').unwrap_or(raw_line);
        if let Some(comment) = line.strip_prefix('#') {
            if rows == 0 && header.is_none() {
                header = parse_header(comment);
            }
            continue;
        }
        if line.is_empty() {
            continue;
        }
        let mut count = 0u32;
        let mut column = 1usize;
        for token in line.split(' ') {
            if token.is_empty() {
                return Err((line_no, column, "values must be separated by single spaces".into()));
            }
            let v = match token {
                "inf" | "+inf" | "infinity" => f32::INFINITY,
                _ => match token.parse::<f32>() {
                    Ok(v) if v.is_finite() && v >= 0.0 => v,
                    _ => {
                        return Err((
                            line_no,
                            column,
                            format!("`{token}` is not a finite non-negative number or `inf`"),
                        ));
                    }
                },
            };
            values.push(v);
            count += 1;
            column += token.len() + 1;
            if values.len() > (MAX_IMAGE_SIDE as usize) * (MAX_IMAGE_SIDE as usize) {
                return Err((line_no, column, "the table is larger than any accepted image".into()));
            }
        }
        match width {
            None => width = Some(count),
            Some(w) if w != count => {
                return Err((line_no, 1, format!("row has {count} values, the first row has {w}")));
            }
            Some(_) => {}
        }
        rows += 1;
    }
    let width = width.ok_or((1, 1, "the depth table has no rows".to_string()))?;
    if let Some((hw, hh)) = header
        && (hw, hh) != (width, rows)
    {
        return Err((1, 1, format!("header says {hw}x{hh} but the table holds {width}x{rows} values")));
    }
    Ok(RadialDepth { width, height: rows, values })
}

fn parse_header(comment: &str) -> Option<(u32, u32)> {
    let mut words = comment.split_whitespace();
    if words.next()? != "lrt-depth" {
        return None;
    }
    let (mut w, mut h) = (None, None);
    for word in words {
        if let Some(v) = word.strip_prefix("width=") {
            w = v.parse().ok();
        } else if let Some(v) = word.strip_prefix("height=") {
            h = v.parse().ok();
        }
    }
    Some((w?, h?))
}

fn read_depth_exr(path: &Path) -> Result<RadialDepth, ViewerError> {
    use exr::prelude::*;
    let bad = |message: String| ViewerError::BadInput { path: path.to_path_buf(), message };
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required("Z")
        .collect_pixels(
            |resolution, _| {
                let (w, h) = (resolution.width(), resolution.height());
                let ok = w > 0 && h > 0 && w <= MAX_IMAGE_SIDE as usize && h <= MAX_IMAGE_SIDE as usize;
                (w, h, if ok { vec![0f32; w * h] } else { Vec::new() })
            },
            |(w, _, values): &mut (usize, usize, Vec<f32>), position, (z,): (f32,)| {
                if let Some(v) = values.get_mut(position.y() * *w + position.x()) {
                    *v = z;
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| bad(format!("cannot read the `Z` channel: {e}")))?;
    let (w, h, values) = image.layer_data.channel_data.pixels;
    check_size(path, w as u32, h as u32)?;
    if let Some(k) = values.iter().position(|v| v.is_nan() || *v < 0.0) {
        return Err(bad(format!("pixel ({}, {}) holds {}, not a distance or +inf", k % w, k / w, values[k])));
    }
    Ok(RadialDepth { width: w as u32, height: h as u32, values })
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

    #[test]
    fn depth_table_parses_with_header_comments_and_crlf() {
        let t = parse_depth_table(
            "# lrt-depth v1 width=3 height=2 depth=radial units=scene\r\n1 2.5 inf\r\n# c\n0 3 4\n",
        )
        .unwrap();
        assert_eq!((t.width, t.height), (3, 2));
        assert_eq!(t.values, vec![1.0, 2.5, f32::INFINITY, 0.0, 3.0, 4.0]);
    }

    #[test]
    fn depth_table_errors_name_line_and_column() {
        let e = parse_depth_table("1 2\n3 nan\n").unwrap_err();
        assert_eq!((e.0, e.1), (2, 3));
        let e = parse_depth_table("1 -2\n").unwrap_err();
        assert_eq!((e.0, e.1), (1, 3));
        let e = parse_depth_table("1 2\n3\n").unwrap_err();
        assert_eq!(e.0, 2);
        let e = parse_depth_table("1  2\n").unwrap_err();
        assert_eq!(e.0, 1);
        let e = parse_depth_table("# lrt-depth v1 width=2 height=2\n1 2\n").unwrap_err();
        assert!(e.2.contains("2x2"), "{}", e.2);
        assert!(parse_depth_table("# only a comment\n").is_err());
    }
}

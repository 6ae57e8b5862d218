//! Pixel reconstruction filters (as the RenderMan Interface defines them) and the image types.
//!
//! Filter widths are full widths in pixels: a sample at raster offset `(dx, dy)` from a pixel
//! centre contributes to that pixel when `-xwidth/2 <= dx < xwidth/2` (and likewise in y), with
//! the weight below (RISpec 3.2, Appendix E; `x`, `y` in pixels):
//!
//! | name | weight |
//! |---|---|
//! | `box` | 1 |
//! | `triangle` | `(1 - |x| / (xwidth/2)) (1 - |y| / (ywidth/2))` |
//! | `gaussian` | `exp(-2 (x'^2 + y'^2))` with `x' = 2x / xwidth`, `y' = 2y / ywidth` |
//! | `catmull-rom` | radial cubic in `r = sqrt(x^2 + y^2)`: `3r^3 - 5r^2 + 2` for `r < 1`, `-r^3 + 5r^2 - 8r + 4` for `r < 2` |
//! | `sinc` | `cos(pi x / (2 xwidth)) sin(pi x) / (pi x)` times the same in y |
//!
//! The half-open support makes `PixelFilter "box" 1 1` give each sample to exactly one pixel.

use glam::Vec3;
use rib_parser::scene::PixelFilter;
use std::f32::consts::PI;

/// The filter shapes RenderMan names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterKind {
    Box,
    Triangle,
    Gaussian,
    CatmullRom,
    Sinc,
}

/// A pixel filter with its full widths in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Filter {
    pub kind: FilterKind,
    pub x_width: f32,
    pub y_width: f32,
}

impl Filter {
    /// From `PixelFilter`; an unknown name or a non-positive width is an error message (the
    /// caller falls back to RenderMan's default, `gaussian 2 2`).
    pub fn from_settings(f: &PixelFilter) -> Result<Filter, String> {
        let kind = match f.name.as_str() {
            "box" => FilterKind::Box,
            "triangle" => FilterKind::Triangle,
            "gaussian" => FilterKind::Gaussian,
            "catmull-rom" | "catmullrom" => FilterKind::CatmullRom,
            "sinc" => FilterKind::Sinc,
            other => return Err(format!("unknown pixel filter \"{other}\"")),
        };
        let ok = |w: f32| w.is_finite() && w > 0.0 && w <= 64.0;
        if !ok(f.x_width) || !ok(f.y_width) {
            return Err(format!("pixel filter widths {} {} must be in (0, 64]", f.x_width, f.y_width));
        }
        Ok(Filter { kind, x_width: f.x_width, y_width: f.y_width })
    }

    /// Half widths (the support radius along each axis).
    pub fn radius(&self) -> (f32, f32) {
        (self.x_width * 0.5, self.y_width * 0.5)
    }

    /// How many neighbouring pixels' samples can reach a pixel, along x and y.
    pub fn pixel_margin(&self) -> (i32, i32) {
        let (rx, ry) = self.radius();
        (((rx - 0.5).max(0.0)).ceil() as i32, ((ry - 0.5).max(0.0)).ceil() as i32)
    }

    /// Weight of a sample at offset `(x, y)` from a pixel centre; 0 outside the support.
    #[inline]
    pub fn eval(&self, x: f32, y: f32) -> f32 {
        let (rx, ry) = self.radius();
        if !(x >= -rx && x < rx && y >= -ry && y < ry) {
            return 0.0;
        }
        match self.kind {
            FilterKind::Box => 1.0,
            FilterKind::Triangle => (1.0 - x.abs() / rx).max(0.0) * (1.0 - y.abs() / ry).max(0.0),
            FilterKind::Gaussian => {
                let (xs, ys) = (x * 2.0 / self.x_width, y * 2.0 / self.y_width);
                (-2.0 * (xs * xs + ys * ys)).exp()
            }
            FilterKind::CatmullRom => {
                let r2 = x * x + y * y;
                let r = r2.sqrt();
                if r >= 2.0 {
                    0.0
                } else if r < 1.0 {
                    3.0 * r * r2 - 5.0 * r2 + 2.0
                } else {
                    -r * r2 + 5.0 * r2 - 8.0 * r + 4.0
                }
            }
            FilterKind::Sinc => {
                let s = |v: f32, width: f32| {
                    if v == 0.0 {
                        1.0
                    } else {
                        let a = v * PI;
                        (0.5 * a / width).cos() * a.sin() / a
                    }
                };
                s(x, self.x_width) * s(y, self.y_width)
            }
        }
    }
}

/// A rendered image region: linear RGB radiance (premultiplied by coverage) and alpha.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Position of this region in the full frame (non-zero for a crop window).
    pub x_offset: u32,
    pub y_offset: u32,
    pub full_width: u32,
    pub full_height: u32,
    /// Row-major from the top-left, RGBA.
    pub pixels: Vec<[f32; 4]>,
}

impl Image {
    pub fn rgb(&self, x: u32, y: u32) -> Vec3 {
        let p = self.pixels[(y * self.width + x) as usize];
        Vec3::new(p[0], p[1], p[2])
    }

    /// Mean of each channel (RGB).
    pub fn mean_rgb(&self) -> Vec3 {
        let mut sum = glam::DVec3::ZERO;
        for p in &self.pixels {
            sum += glam::DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
        }
        (sum / self.pixels.len().max(1) as f64).as_vec3()
    }
}

/// Per-pixel radial distances of a rendered region (`inf` where the ray hits nothing).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    pub width: u32,
    pub height: u32,
    pub x_offset: u32,
    pub y_offset: u32,
    /// Row-major from the top-left.
    pub values: Vec<f32>,
}

impl DepthImage {
    /// The depth table of this region (CONTRACTS.md §2), for depth_remap's writers.
    pub fn to_table(&self) -> Result<depth_remap::DepthTable, depth_remap::DepthTableError> {
        depth_remap::DepthTable::new(self.width, self.height, self.values.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filter(name: &str, w: f32) -> Filter {
        Filter::from_settings(&PixelFilter { name: name.into(), x_width: w, y_width: w }).unwrap()
    }

    #[test]
    fn renderman_definitions() {
        let g = filter("gaussian", 2.0);
        assert_eq!(g.eval(0.0, 0.0), 1.0);
        assert!((g.eval(0.5, 0.0) - (-0.5f32).exp()).abs() < 1e-6);
        assert_eq!(g.eval(1.0, 0.0), 0.0);
        let b = filter("box", 1.0);
        assert_eq!(b.eval(-0.5, 0.0), 1.0);
        assert_eq!(b.eval(0.5, 0.0), 0.0);
        assert_eq!(b.pixel_margin(), (0, 0));
        assert_eq!(g.pixel_margin(), (1, 1));
        let t = filter("triangle", 2.0);
        assert!((t.eval(0.5, 0.5) - 0.25).abs() < 1e-6);
        let c = filter("catmull-rom", 4.0);
        assert_eq!(c.eval(0.0, 0.0), 2.0);
        assert!(c.eval(1.5, 0.0) < 0.0);
        assert_eq!(c.eval(1.0, 0.0), 0.0);
        let s = filter("sinc", 4.0);
        assert_eq!(s.eval(0.0, 0.0), 1.0);
        assert!(s.eval(1.0, 0.0).abs() < 1e-6);
        assert!(s.eval(1.5, 0.0) < 0.0);
        assert!(
            Filter::from_settings(&PixelFilter { name: "mitchell".into(), x_width: 2.0, y_width: 2.0 })
                .is_err()
        );
        assert!(
            Filter::from_settings(&PixelFilter { name: "box".into(), x_width: 0.0, y_width: 2.0 }).is_err()
        );
    }
}

//! RenderMan's pixel reconstruction filters (RISpec 3.2, Appendix E), defined once for the ray
//! tracer, which filters every pixel's samples with them, and the viewer, which filters live
//! objects' edges with the filter the image was made with.
//!
//! Filter widths are full widths in pixels: a sample at raster offset `(dx, dy)` from a pixel
//! centre contributes to that pixel when `-xwidth/2 <= dx < xwidth/2` (and likewise in y), with
//! the weight below (`x`, `y` in pixels):
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

use std::f32::consts::PI;

/// The filter shapes RenderMan names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FilterKind {
    Box,
    Triangle,
    Gaussian,
    CatmullRom,
    Sinc,
}

/// A pixel filter with its full widths in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFilter {
    pub kind: FilterKind,
    pub x_width: f32,
    pub y_width: f32,
}

impl PixelFilter {
    /// RenderMan's default, `PixelFilter "gaussian" 2 2`.
    pub const RENDERMAN_DEFAULT: PixelFilter =
        PixelFilter { kind: FilterKind::Gaussian, x_width: 2.0, y_width: 2.0 };

    /// `PixelFilter "box" 1 1`: each sample counts for its own pixel only.
    pub const BOX: PixelFilter = PixelFilter { kind: FilterKind::Box, x_width: 1.0, y_width: 1.0 };

    /// From a RIB `PixelFilter` name and widths; an unknown name or a width outside `(0, 64]` is
    /// an error message (renderers then fall back to [`PixelFilter::RENDERMAN_DEFAULT`]).
    pub fn from_rib(name: &str, x_width: f32, y_width: f32) -> Result<PixelFilter, String> {
        let kind = match name {
            "box" => FilterKind::Box,
            "triangle" => FilterKind::Triangle,
            "gaussian" => FilterKind::Gaussian,
            "catmull-rom" | "catmullrom" => FilterKind::CatmullRom,
            "sinc" => FilterKind::Sinc,
            other => return Err(format!("unknown pixel filter \"{other}\"")),
        };
        let ok = |w: f32| w.is_finite() && w > 0.0 && w <= 64.0;
        if !ok(x_width) || !ok(y_width) {
            return Err(format!("pixel filter widths {x_width} {y_width} must be in (0, 64]"));
        }
        Ok(PixelFilter { kind, x_width, y_width })
    }

    /// Half widths (the support radius along each axis).
    pub fn radius(&self) -> (f32, f32) {
        (self.x_width * 0.5, self.y_width * 0.5)
    }

    /// How many neighbouring pixels' samples can reach a pixel, along x and y.
    pub fn pixel_margin(&self) -> (u32, u32) {
        let (rx, ry) = self.radius();
        (((rx - 0.5).max(0.0)).ceil() as u32, ((ry - 0.5).max(0.0)).ceil() as u32)
    }

    /// Weight of a sample at offset `(x, y)` from a pixel centre; 0 outside the support.
    #[inline]
    pub fn weight(&self, x: f32, y: f32) -> f32 {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn filter(name: &str, w: f32) -> PixelFilter {
        PixelFilter::from_rib(name, w, w).unwrap()
    }

    #[test]
    fn renderman_definitions() {
        let g = filter("gaussian", 2.0);
        assert_eq!(g, PixelFilter::RENDERMAN_DEFAULT);
        assert_eq!(g.weight(0.0, 0.0), 1.0);
        assert!((g.weight(0.5, 0.0) - (-0.5f32).exp()).abs() < 1e-6);
        assert_eq!(g.weight(1.0, 0.0), 0.0);
        let b = filter("box", 1.0);
        assert_eq!(b, PixelFilter::BOX);
        assert_eq!(b.weight(-0.5, 0.0), 1.0);
        assert_eq!(b.weight(0.5, 0.0), 0.0);
        assert_eq!(b.pixel_margin(), (0, 0));
        assert_eq!(g.pixel_margin(), (1, 1));
        assert_eq!(PixelFilter::from_rib("sinc", 6.0, 3.0).unwrap().pixel_margin(), (3, 1));
        let t = filter("triangle", 2.0);
        assert!((t.weight(0.5, 0.5) - 0.25).abs() < 1e-6);
        let c = filter("catmull-rom", 4.0);
        assert_eq!(c.weight(0.0, 0.0), 2.0);
        assert!(c.weight(1.5, 0.0) < 0.0);
        assert_eq!(c.weight(1.0, 0.0), 0.0);
        assert_eq!(filter("catmullrom", 4.0).kind, FilterKind::CatmullRom);
        let s = filter("sinc", 4.0);
        assert_eq!(s.weight(0.0, 0.0), 1.0);
        assert!(s.weight(1.0, 0.0).abs() < 1e-6);
        assert!(s.weight(1.5, 0.0) < 0.0);
        assert!(PixelFilter::from_rib("mitchell", 2.0, 2.0).is_err());
        assert!(PixelFilter::from_rib("box", 0.0, 2.0).is_err());
        assert!(PixelFilter::from_rib("box", 1.0, f32::NAN).is_err());
    }
}

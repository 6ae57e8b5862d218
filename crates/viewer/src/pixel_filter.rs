//! The pixel filter the pre-rendered image was made with (the RIB's `PixelFilter`), which the
//! compositor applies to live objects' edges so that they blend into their surroundings as the
//! ray tracer's own objects do.
//!
//! The weights are RenderMan's (RISpec 3.2, Appendix E), exactly as `raytracer::film::Filter`
//! evaluates them (`shaders/resolve.wgsl` ports [`PixelFilter::weight`]): a sample at raster
//! offset `(x, y)` from a pixel centre counts for that pixel when `-xwidth/2 <= x < xwidth/2`
//! (and likewise in y).

/// The filter shapes RenderMan names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FilterKind {
    Box,
    Triangle,
    Gaussian,
    CatmullRom,
    Sinc,
}

impl FilterKind {
    /// The shader's code for the kind (`resolve.wgsl`).
    pub(crate) fn code(self) -> u32 {
        match self {
            FilterKind::Box => 0,
            FilterKind::Triangle => 1,
            FilterKind::Gaussian => 2,
            FilterKind::CatmullRom => 3,
            FilterKind::Sinc => 4,
        }
    }
}

/// A pixel filter with its full widths in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFilter {
    pub kind: FilterKind,
    pub x_width: f32,
    pub y_width: f32,
}

/// How many neighbouring pixels, along each axis, the viewer gathers live samples from: wider
/// filters are cut to this reach (5 x 5 pixels), with a note from [`PixelFilter::note`].
pub const MAX_FILTER_MARGIN: u32 = 2;

impl PixelFilter {
    /// RenderMan's default, `PixelFilter "gaussian" 2 2` (what `lrt-depth` uses without one).
    pub const RENDERMAN_DEFAULT: PixelFilter =
        PixelFilter { kind: FilterKind::Gaussian, x_width: 2.0, y_width: 2.0 };

    /// `PixelFilter "box" 1 1`: each sample counts for its own pixel only.
    pub const BOX: PixelFilter = PixelFilter { kind: FilterKind::Box, x_width: 1.0, y_width: 1.0 };

    /// From a RIB `PixelFilter` name and widths; an unknown name or a width outside `(0, 64]` is
    /// an error message (`lrt-depth` then renders with [`PixelFilter::RENDERMAN_DEFAULT`]).
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

    /// How many neighbouring pixels' samples can reach a pixel, along x and y, before the
    /// viewer's cut at [`MAX_FILTER_MARGIN`].
    pub fn pixel_margin(&self) -> (u32, u32) {
        let m = |w: f32| ((w * 0.5 - 0.5).max(0.0)).ceil() as u32;
        (m(self.x_width), m(self.y_width))
    }

    /// What the viewer does differently from the ray tracer with this filter, if anything.
    pub fn note(&self) -> Option<String> {
        let (mx, my) = self.pixel_margin();
        (mx > MAX_FILTER_MARGIN || my > MAX_FILTER_MARGIN).then(|| {
            format!(
                "live objects' edges are filtered over at most {0}x{0} pixels; the image's {1}x{2} pixel filter reaches further",
                2 * MAX_FILTER_MARGIN + 1,
                self.x_width,
                self.y_width
            )
        })
    }

    /// Weight of a sample at offset `(x, y)` pixels from a pixel centre; 0 outside the support.
    pub fn weight(&self, x: f32, y: f32) -> f32 {
        let (rx, ry) = (self.x_width * 0.5, self.y_width * 0.5);
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
                        let a = v * std::f32::consts::PI;
                        (0.5 * a / width).cos() * a.sin() / a
                    }
                };
                s(x, self.x_width) * s(y, self.y_width)
            }
        }
    }
}

impl Default for PixelFilter {
    /// [`PixelFilter::BOX`]: a scene built without a RIB gives each live sample to its pixel.
    fn default() -> Self {
        PixelFilter::BOX
    }
}

/// Where the four samples of a pixel lie (fractions of a pixel from its top-left corner): the
/// standard 4x pattern of Vulkan, Direct3D and Metal, which `composite.wgsl` (the sphere's
/// coverage) and `resolve.wgsl` (the filter weights) also hold.
pub const SAMPLE_POSITIONS: [[f32; 2]; 4] = [[0.375, 0.125], [0.875, 0.375], [0.125, 0.625], [0.625, 0.875]];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_widths_are_read_as_renderman_says() {
        assert_eq!(PixelFilter::from_rib("gaussian", 2.0, 2.0).unwrap(), PixelFilter::RENDERMAN_DEFAULT);
        assert_eq!(PixelFilter::from_rib("catmullrom", 4.0, 4.0).unwrap().kind, FilterKind::CatmullRom);
        assert!(PixelFilter::from_rib("lanczos", 2.0, 2.0).is_err());
        assert!(PixelFilter::from_rib("box", 0.0, 1.0).is_err());
        assert!(PixelFilter::from_rib("box", 1.0, f32::NAN).is_err());
    }

    #[test]
    fn the_support_is_half_open_and_the_margin_covers_it() {
        let b = PixelFilter::BOX;
        assert_eq!(b.weight(-0.5, 0.0), 1.0);
        assert_eq!(b.weight(0.5, 0.0), 0.0);
        assert_eq!(b.pixel_margin(), (0, 0));
        assert_eq!(PixelFilter::RENDERMAN_DEFAULT.pixel_margin(), (1, 1));
        assert_eq!(PixelFilter::from_rib("sinc", 6.0, 3.0).unwrap().pixel_margin(), (3, 1));
        assert!(PixelFilter::from_rib("sinc", 6.0, 3.0).unwrap().note().is_some());
        assert!(PixelFilter::RENDERMAN_DEFAULT.note().is_none());
    }

    #[test]
    fn weights_peak_at_the_centre() {
        for f in [
            PixelFilter::RENDERMAN_DEFAULT,
            PixelFilter::from_rib("triangle", 2.0, 2.0).unwrap(),
            PixelFilter::from_rib("catmull-rom", 4.0, 4.0).unwrap(),
            PixelFilter::from_rib("sinc", 4.0, 4.0).unwrap(),
        ] {
            assert!(f.weight(0.0, 0.0) >= f.weight(0.3, 0.2), "{f:?}");
            assert!(f.weight(0.3, 0.2) > 0.0, "{f:?}");
        }
        assert!((PixelFilter::RENDERMAN_DEFAULT.weight(0.5, 0.0) - (-0.5f32).exp()).abs() < 1e-7);
    }
}

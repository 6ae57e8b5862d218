//! Pixel reconstruction filters and the image types. The filters are RenderMan's, defined in
//! `depth_remap::pixel_filter` (the viewer filters live objects' edges with the same ones).

pub use depth_remap::pixel_filter::{FilterKind, PixelFilter as Filter};
use glam::Vec3;
use rib_parser::scene::PixelFilter;

/// The filter a RIB's `PixelFilter` asks for; an unknown name or a non-positive width is an
/// error message (the caller falls back to RenderMan's default, `gaussian 2 2`).
pub fn filter_from_settings(f: &PixelFilter) -> Result<Filter, String> {
    Filter::from_rib(&f.name, f.x_width, f.y_width)
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

//! The pixel filter the pre-rendered image was made with (the RIB's `PixelFilter`, defined in
//! `depth_remap::pixel_filter` for the ray tracer and the viewer alike), which the compositor
//! applies to live objects' edges so that they blend into their surroundings as the ray
//! tracer's own objects do (`shaders/resolve.wgsl` ports [`PixelFilter::weight`]).

pub use depth_remap::pixel_filter::{FilterKind, PixelFilter};

/// How many neighbouring pixels, along each axis, the viewer gathers live samples from: wider
/// filters are cut to this reach (5 x 5 pixels), with a note from [`note`].
pub const MAX_FILTER_MARGIN: u32 = 2;

/// Where the four samples of a pixel lie (fractions of a pixel from its top-left corner): the
/// standard 4x pattern of Vulkan, Direct3D and Metal, which `live_coverage.wgsl` (the sphere's
/// coverage) and `resolve.wgsl` (the filter weights) also hold.
pub const SAMPLE_POSITIONS: [[f32; 2]; 4] = [[0.375, 0.125], [0.875, 0.375], [0.125, 0.625], [0.625, 0.875]];

/// The shader's code for a filter kind (`resolve.wgsl`).
pub(crate) fn kind_code(kind: FilterKind) -> u32 {
    match kind {
        FilterKind::Box => 0,
        FilterKind::Triangle => 1,
        FilterKind::Gaussian => 2,
        FilterKind::CatmullRom => 3,
        FilterKind::Sinc => 4,
    }
}

/// What the viewer does differently from the ray tracer with `filter`, if anything.
pub fn note(filter: &PixelFilter) -> Option<String> {
    let (mx, my) = filter.pixel_margin();
    (mx > MAX_FILTER_MARGIN || my > MAX_FILTER_MARGIN).then(|| {
        format!(
            "live objects' edges are filtered over at most {0}x{0} pixels; the image's {1}x{2} pixel filter reaches further",
            2 * MAX_FILTER_MARGIN + 1,
            filter.x_width,
            filter.y_width
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_filters_reaching_past_the_gather_get_a_note() {
        assert!(note(&PixelFilter::from_rib("sinc", 6.0, 3.0).unwrap()).is_some());
        assert!(note(&PixelFilter::from_rib("catmull-rom", 4.0, 4.0).unwrap()).is_none());
        assert!(note(&PixelFilter::RENDERMAN_DEFAULT).is_none());
    }
}

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

/// How many points of a pixel's footprint the live objects' sharply varying light is
/// integrated over ([`footprint`]).
pub const FOOTPRINT_SAMPLES: usize = 16;

/// Where a pixel's value comes from under `filter`, as points for the composite to shade: a
/// 4 x 4 grid of cell centres over the filter's support (cut to the gather's reach,
/// [`MAX_FILTER_MARGIN`]), each `[x, y, weight, quadrant]` with x, y the offset in pixels from
/// the pixel centre, the weights the filter's own, summing to 1, and the quadrant (0 to 3, as
/// [`footprint_rays`]) whose shadow ray stands for the point. The ray tracer's pixel is the
/// filter's weighted mean of the radiance over this support, so a live object's light that
/// varies within a pixel (a spot light's cone edge, a small highlight) is integrated over these
/// points rather than taken at the centre (`shaders/composite.wgsl`, `direct_light_over`).
pub fn footprint(filter: &PixelFilter) -> [[f32; 4]; FOOTPRINT_SAMPLES] {
    let reach = MAX_FILTER_MARGIN as f32 + 0.5;
    let (rx, ry) = filter.radius();
    let (rx, ry) = (rx.min(reach), ry.min(reach));
    let mut points = [[0.0f32; 4]; FOOTPRINT_SAMPLES];
    let mut total = 0.0f32;
    for (i, point) in points.iter_mut().enumerate() {
        let (col, row) = ((i % 4) as f32, (i / 4) as f32);
        let x = -rx + (col + 0.5) * (2.0 * rx / 4.0);
        let y = -ry + (row + 0.5) * (2.0 * ry / 4.0);
        let w = filter.weight(x, y);
        total += w;
        let quadrant = (i % 4) / 2 + 2 * (i / 8);
        *point = [x, y, w, quadrant as f32];
    }
    // Every filter weighs its centre cells positively, so the total is never zero.
    for point in &mut points {
        point[2] /= total;
    }
    points
}

/// Where the shadow rays of a pixel's footprint start, one per quadrant of [`footprint`]'s
/// support (`[x, y, 0, 0]`, offsets in pixels): the 4x sample pattern
/// ([`SAMPLE_POSITIONS`]) stretched over the support, whose four distinct rows and columns
/// place a shadow's edge within the pixel in either direction. Shadow rays cost a traversal
/// each, so four stand for the sixteen points.
pub fn footprint_rays(filter: &PixelFilter) -> [[f32; 4]; 4] {
    let reach = MAX_FILTER_MARGIN as f32 + 0.5;
    let (rx, ry) = filter.radius();
    let (rx, ry) = (rx.min(reach), ry.min(reach));
    SAMPLE_POSITIONS.map(|[x, y]| [(x - 0.5) * 2.0 * rx, (y - 0.5) * 2.0 * ry, 0.0, 0.0])
}

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
    fn the_footprint_covers_the_filter_support_with_its_weights() {
        let box_points = footprint(&PixelFilter::BOX);
        assert!(
            box_points
                .iter()
                .all(|p| p[0].abs() < 0.5 && p[1].abs() < 0.5 && (p[2] - 1.0 / 16.0).abs() < 1e-6)
        );
        let gaussian = footprint(&PixelFilter::RENDERMAN_DEFAULT);
        assert!((gaussian.iter().map(|p| p[2]).sum::<f32>() - 1.0).abs() < 1e-5);
        assert!(gaussian.iter().any(|p| p[0].abs() > 0.5), "a 2x2 gaussian reaches into the neighbours");
        let corner = gaussian.iter().map(|p| p[2]).fold(f32::MAX, f32::min);
        let centre = gaussian.iter().map(|p| p[2]).fold(0.0, f32::max);
        assert!(corner < centre, "the gaussian weighs its centre most");
        // Each point's quadrant holds its shadow ray.
        let rays = footprint_rays(&PixelFilter::RENDERMAN_DEFAULT);
        for p in gaussian {
            let ray = rays[p[3] as usize];
            assert!(ray[0] * p[0] > 0.0 && ray[1] * p[1] > 0.0, "{p:?} and its ray {ray:?} share a quadrant");
        }
        let wide = footprint(&PixelFilter::from_rib("sinc", 12.0, 12.0).unwrap());
        assert!(wide.iter().all(|p| p[0].abs() <= MAX_FILTER_MARGIN as f32 + 0.5));
    }

    #[test]
    fn only_filters_reaching_past_the_gather_get_a_note() {
        assert!(note(&PixelFilter::from_rib("sinc", 6.0, 3.0).unwrap()).is_some());
        assert!(note(&PixelFilter::from_rib("catmull-rom", 4.0, 4.0).unwrap()).is_none());
        assert!(note(&PixelFilter::RENDERMAN_DEFAULT).is_none());
    }
}

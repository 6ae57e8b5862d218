//! Per-pixel conversion of a radial depth table into depth-buffer values, and the choice of
//! near and far planes from the data.
//!
//! Each pixel `(i, j)` holding radial distance `r` becomes planar eye depth
//! `d = r * Camera::eye_depth_per_radial(i, j)` (the same function the single-pixel API uses,
//! so the two agree bit for bit), then NDC or window depth through the [`DepthMapping`]'s
//! `f32` matrix coefficients evaluated in `f64`, rounded once to `f32`. A miss (`inf`) becomes
//! the far value: 1 for standard depth, 0 for reversed.

use crate::camera::{Camera, Clipping, pixel_centre};
use crate::mapping::{DepthConvention, DepthMapping, FarPlane, MappingError};
use crate::table::{DepthTable, DepthTableError, DepthTableErrorKind, thread_count};
use std::fmt;

/// Which value the remap produces per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DepthOutput {
    /// Window depth: what the depth buffer stores, what a full-screen pass writes to
    /// `@builtin(frag_depth)` / `gl_FragDepth`. Clamped to `[0, 1]`.
    Window,
    /// NDC depth: what the point-cloud vertex carries as `z` with [`crate::point_cloud_matrix`]
    /// (equal to window depth for wgpu). Clamped to the convention's NDC range.
    Ndc,
}

/// What the remap met on the way (reported by `--stats`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RemapStats {
    /// Pixels whose ray missed (`inf`): written as the far value.
    pub misses: u64,
    /// Pixels nearer than the near plane: clamped to the near value.
    pub clamped_near: u64,
    /// Pixels beyond a finite far plane: clamped to the far value.
    pub clamped_far: u64,
}

impl std::ops::AddAssign for RemapStats {
    fn add_assign(&mut self, other: Self) {
        self.misses += other.misses;
        self.clamped_near += other.clamped_near;
        self.clamped_far += other.clamped_far;
    }
}

/// A remapped table: one `f32` per pixel, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct RemappedDepth {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
    pub stats: RemapStats,
}

/// Why a remap could not run.
#[derive(Debug)]
#[non_exhaustive]
pub enum RemapError {
    /// The table is neither the camera's full image size nor its crop window's size.
    Size(DepthTableError),
    /// The mapping's projection kind differs from the camera's.
    ProjectionMismatch { camera_perspective: bool },
}

impl fmt::Display for RemapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RemapError::Size(e) => write!(f, "{e}"),
            RemapError::ProjectionMismatch { camera_perspective } => {
                let (camera, mapping) = if *camera_perspective {
                    ("perspective", "orthographic")
                } else {
                    ("orthographic", "perspective")
                };
                write!(f, "the camera is {camera} but the depth mapping is {mapping}")
            }
        }
    }
}

impl std::error::Error for RemapError {}

/// The pixel offset of a table within the camera's image: `(0, 0)` for a full-size table, the
/// crop window's corner for a crop-sized one.
fn table_origin(camera: &Camera, table: &DepthTable) -> Result<(u32, u32), RemapError> {
    let (w, h) = camera.resolution();
    if (table.width(), table.height()) == (w, h) {
        return Ok((0, 0));
    }
    let (x0, x1, y0, y1) = camera.crop_pixel_bounds();
    if (table.width(), table.height()) == (x1 - x0, y1 - y0) {
        return Ok((x0, y0));
    }
    Err(RemapError::Size(table.check_size(w, h).err().unwrap_or_else(|| {
        DepthTableError::new(DepthTableErrorKind::SizeMismatch {
            table: (table.width(), table.height()),
            image: (w, h),
        })
    })))
}

/// Screen x of each column and screen y of each row of a table placed at `origin`.
fn screen_coordinates(camera: &Camera, table: &DepthTable, origin: (u32, u32)) -> (Vec<f64>, Vec<f64>) {
    let xs =
        (0..table.width()).map(|i| camera.raster_to_screen(pixel_centre(origin.0 + i, origin.1)).x).collect();
    let ys = (0..table.height())
        .map(|j| camera.raster_to_screen(pixel_centre(origin.0, origin.1 + j)).y)
        .collect();
    (xs, ys)
}

/// Converts a radial depth table into NDC or window depth for `mapping`, in parallel over rows
/// (`threads`: 0 means all available). The table is either the camera's full image or its crop
/// window.
pub fn remap_depth_table(
    camera: &Camera,
    table: &DepthTable,
    mapping: &DepthMapping,
    output: DepthOutput,
    threads: usize,
) -> Result<RemappedDepth, RemapError> {
    if camera.is_perspective() != mapping.is_perspective() {
        return Err(RemapError::ProjectionMismatch { camera_perspective: camera.is_perspective() });
    }
    let origin = table_origin(camera, table)?;
    let (xs, ys) = screen_coordinates(camera, table, origin);
    let width = table.width() as usize;
    let mut values = vec![0.0f32; table.values().len()];
    let convention = mapping.convention();
    let (near_value, far_value) = match output {
        DepthOutput::Window => (convention.near_window_depth(), convention.far_window_depth()),
        DepthOutput::Ndc => (convention.near_ndc_depth(), convention.far_ndc_depth()),
    };
    let far_eye_depth = match mapping.far() {
        FarPlane::Finite(f) => f,
        FarPlane::Infinite => f64::INFINITY,
    };
    let near_eye_depth = mapping.near();
    let to_output = |d: f64| match output {
        DepthOutput::Window => mapping.window_depth(d),
        DepthOutput::Ndc => mapping.ndc_depth(d),
    };
    let (low, high) = if near_value < far_value { (near_value, far_value) } else { (far_value, near_value) };
    let remap_rows = |first_row: usize, out: &mut [f32]| -> RemapStats {
        let mut stats = RemapStats::default();
        for (k, out_row) in out.chunks_mut(width).enumerate() {
            let j = first_row + k;
            let sy = ys[j];
            let radial_row = table.row(j as u32);
            for ((o, &radial), &sx) in out_row.iter_mut().zip(radial_row).zip(&xs) {
                *o = if radial == f32::INFINITY {
                    stats.misses += 1;
                    far_value
                } else {
                    let d = f64::from(radial) * camera.eye_depth_per_radial_at_screen(sx, sy);
                    if d < near_eye_depth {
                        stats.clamped_near += 1;
                        near_value
                    } else if d > far_eye_depth {
                        stats.clamped_far += 1;
                        far_value
                    } else {
                        // Inside the planes the value is within range up to rounding; the
                        // clamp only removes an ulp of overshoot at the planes themselves.
                        (to_output(d) as f32).clamp(low, high)
                    }
                };
            }
        }
        stats
    };
    let height = table.height() as usize;
    let threads = thread_count(threads, values.len() / (1 << 16));
    let stats = if threads <= 1 {
        remap_rows(0, &mut values)
    } else {
        let rows_per_chunk = height.div_ceil(threads);
        std::thread::scope(|scope| {
            let handles: Vec<_> = values
                .chunks_mut(rows_per_chunk * width)
                .enumerate()
                .map(|(c, chunk)| {
                    let remap_rows = &remap_rows;
                    scope.spawn(move || remap_rows(c * rows_per_chunk, chunk))
                })
                .collect();
            let mut total = RemapStats::default();
            for handle in handles {
                // The closure cannot panic on valid input; a panic would be a bug worth seeing.
                total += handle.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
            }
            total
        })
    };
    Ok(RemappedDepth { width: table.width(), height: table.height(), values, stats })
}

impl Camera {
    /// Window depth (rounded once to `f32`, clamped) of pixel `(i, j)` holding `radial`: the
    /// single-pixel form of [`remap_depth_table`], with `mapping` from
    /// [`Camera::depth_mapping`]. A miss (`inf`), and anything that is not a depth (`nan`, a
    /// negative), gives the far value.
    pub fn window_depth_from_radial(&self, i: u32, j: u32, radial: f32, mapping: &DepthMapping) -> f32 {
        let convention = mapping.convention();
        if radial == f32::INFINITY || !crate::table::is_depth(radial) {
            return convention.far_window_depth();
        }
        let d = f64::from(radial) * self.eye_depth_per_radial(i, j);
        let (near_value, far_value) = (convention.near_window_depth(), convention.far_window_depth());
        let (low, high) =
            if near_value < far_value { (near_value, far_value) } else { (far_value, near_value) };
        (mapping.window_depth(d) as f32).clamp(low, high)
    }

    /// The finite planar eye-depth range of a radial table (full-size or crop-sized), or `None`
    /// when every ray missed.
    pub fn eye_depth_range(&self, table: &DepthTable) -> Result<Option<EyeDepthRange>, RemapError> {
        let origin = table_origin(self, table)?;
        let (xs, ys) = screen_coordinates(self, table, origin);
        let mut range: Option<EyeDepthRange> = None;
        for (j, &sy) in ys.iter().enumerate() {
            for (&radial, &sx) in table.row(j as u32).iter().zip(&xs) {
                if radial.is_finite() {
                    let d = f64::from(radial) * self.eye_depth_per_radial_at_screen(sx, sy);
                    range = Some(match range {
                        None => EyeDepthRange { min: d, max: d },
                        Some(r) => EyeDepthRange { min: r.min.min(d), max: r.max.max(d) },
                    });
                }
            }
        }
        Ok(range)
    }

    /// The depth mapping for this camera's projection with `convention` and `planes`.
    pub fn depth_mapping(
        &self,
        convention: DepthConvention,
        planes: NearFar,
    ) -> Result<DepthMapping, MappingError> {
        let far = if planes.infinite_far { FarPlane::Infinite } else { FarPlane::Finite(planes.far) };
        if self.is_perspective() {
            DepthMapping::perspective(convention, planes.near, far)
        } else {
            DepthMapping::orthographic(convention, planes.near, FarPlane::Finite(planes.far))
        }
    }
}

/// The smallest and largest finite planar eye depth in a table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeDepthRange {
    pub min: f64,
    pub max: f64,
}

/// How much room to leave around the data when choosing near and far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearFarPolicy {
    /// Near is the nearest surface's eye depth times this (so live objects may come that much
    /// closer than anything pre-rendered).
    pub near_factor: f64,
    /// Far is the farthest surface's eye depth times this.
    pub far_factor: f64,
    /// Use an infinite far plane (perspective only); far is then only informational.
    pub infinite_far: bool,
}

impl NearFarPolicy {
    /// The margins that suit a convention. Reversed-Z with `[0, 1]` NDC keeps the same relative
    /// precision wherever the planes are, so live objects get room: near at 1/64 of the nearest
    /// surface and an infinite far plane. Every other convention loses precision in proportion
    /// to `far / near`: near at half the nearest surface, far at twice the farthest.
    pub fn for_convention(convention: DepthConvention) -> Self {
        if convention == DepthConvention::WgpuReversed {
            NearFarPolicy { near_factor: 1.0 / 64.0, far_factor: 2.0, infinite_far: true }
        } else {
            NearFarPolicy { near_factor: 0.5, far_factor: 2.0, infinite_far: false }
        }
    }
}

impl Default for NearFarPolicy {
    /// The viewer's default: [`NearFarPolicy::for_convention`] of reversed-Z.
    fn default() -> Self {
        NearFarPolicy::for_convention(DepthConvention::WgpuReversed)
    }
}

/// Chosen clipping planes. Both are positive, finite, exactly representable as `f32` (so the
/// GPU's matrix has the same planes), and `near < far`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearFar {
    pub near: f64,
    pub far: f64,
    pub infinite_far: bool,
}

/// Rounds down (`up == false`) or up to an `f32`-representable value.
fn round_to_f32(x: f64, up: bool) -> f64 {
    let r = x as f32;
    let r64 = f64::from(r);
    let adjusted = if up && r64 < x {
        r.next_up()
    } else if !up && r64 > x {
        r.next_down()
    } else {
        r
    };
    f64::from(adjusted)
}

/// Chooses near and far from the data and `Clipping`: near is `range.min * near_factor` but
/// not before `clipping.near`, far is `range.max * far_factor` but not beyond `clipping.far`.
/// Without data (every ray missed) the planes are `Clipping`'s. Near is rounded down and far
/// up to `f32` values, so the data stays inside.
pub fn choose_near_far(range: Option<EyeDepthRange>, clipping: Clipping, policy: NearFarPolicy) -> NearFar {
    let sane = |x: f64, fallback: f64| if x.is_finite() && x > 0.0 { x } else { fallback };
    let clip_near = sane(clipping.near, 1e-10).max(f64::from(f32::MIN_POSITIVE));
    let clip_far = sane(clipping.far, f64::from(f32::MAX)).min(f64::from(f32::MAX));
    let (near, far) = match range {
        Some(r) => {
            let near = sane(r.min * policy.near_factor, clip_near).max(clip_near);
            let far = sane(r.max * policy.far_factor, clip_far).min(clip_far);
            (near, far)
        }
        None => (clip_near, clip_far),
    };
    let near = round_to_f32(near.min(f64::from(f32::MAX) / 4.0), false);
    let mut far = round_to_f32(far, true);
    if far <= near {
        // Degenerate clipping (far before the data's near): keep a valid, tiny-but-nonzero slab.
        far = f64::from(((near * 2.0) as f32).max((near as f32).next_up()));
    }
    NearFar { near, far, infinite_far: policy.infinite_far }
}

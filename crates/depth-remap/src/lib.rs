//! `depth-remap`: the one camera model of the project and everything that turns the ray
//! tracer's depth into what a rasteriser's depth buffer holds.
//!
//! Morris & Joshi's hybrid renderer draws a pre-rendered image as points whose depth must equal
//! what a live polygon at the same place would write. This crate makes that exact:
//!
//! - [`camera`]: the RenderMan camera (CONTRACTS.md §3). [`Camera::pixel_centre_world_ray`] /
//!   [`Camera::pixel_centre_ray`] are *the* ray through the centre of pixel `(i, j)`; the ray
//!   tracer shoots it and the depth table holds distances along it. Radial distance along it
//!   and planar eye depth convert through [`Camera::radial_to_eye_depth`]. The view matrix
//!   ([`Camera::eye_from_world`]) and [`Frustum`] map RenderMan's left-handed camera to the
//!   right-handed eye space of OpenGL and wgpu.
//! - [`mapping`]: every depth convention by name (`window_depth_gl`, `window_depth_wgpu`,
//!   `window_depth_reversed`, infinite-far forms), their projection matrices
//!   (`Frustum::perspective_rh_gl`, ...), and [`DepthMapping`], which evaluates exactly the
//!   `f32` matrix the GPU is given. [`point_cloud_matrix`] draws pre-rendered pixels with their
//!   depth passed through.
//! - [`remap`]: the whole-table conversion ([`remap_depth_table`], parallel over rows) and the
//!   choice of near and far planes from the data and `Clipping` ([`choose_near_far`]).
//! - [`table`]: the depth-table file (CONTRACTS.md §2), ASCII and OpenEXR, with exact
//!   shortest round-trip text ([`float_text`]).
//! - [`paper`]: the paper's formula and matrices exactly as printed, and the check of what they
//!   do together; [`precision`]: the depth-buffer precision simulation behind the viewer's
//!   default (reversed-Z `Depth32Float`, infinite far plane; see `docs/depth-mapping.md`).
//!
//! # Example
//!
//! ```
//! use depth_remap::*;
//!
//! // A 40-degree camera looking down +z from the origin, as a RIB would give it.
//! let camera = Camera::new(CameraSettings {
//!     x_resolution: 64,
//!     y_resolution: 48,
//!     projection: Projection::Perspective { fov_degrees: 40.0 },
//!     ..CameraSettings::default()
//! })
//! .unwrap();
//!
//! // A depth table: every pixel sees a wall at planar depth 5 (radial distance varies).
//! let mut table = DepthTable::all_misses(64, 48);
//! for j in 0..48 {
//!     for i in 0..64 {
//!         let radial = camera.eye_depth_to_radial(i, j, 5.0);
//!         table.set(i, j, radial as f32);
//!     }
//! }
//!
//! // The viewer's default: reversed-Z, infinite far, near chosen from the data.
//! let range = camera.eye_depth_range(&table).unwrap();
//! let planes = choose_near_far(range, camera.clipping(), NearFarPolicy::default());
//! let mapping = camera.depth_mapping(DepthConvention::WgpuReversed, planes).unwrap();
//! let remapped = remap_depth_table(&camera, &table, &mapping, DepthOutput::Window, 0).unwrap();
//!
//! // A live polygon at the same place, through the same projection, gets the same depth.
//! let projection = mapping.projection(&camera.frustum()) * camera.eye_from_world();
//! let point = camera.pixel_centre_world_ray(10, 7).at(f64::from(table.get(10, 7).unwrap()));
//! let clip = projection * point.extend(1.0);
//! let polygon_depth = (clip.z / clip.w) as f32;
//! let pixel_depth = remapped.values[7 * 64 + 10];
//! assert!((polygon_depth - pixel_depth).abs() <= 2.0 * f32::EPSILON * pixel_depth);
//! ```

pub mod camera;
mod exr_io;
pub mod float_text;
pub mod mapping;
pub mod paper;
pub mod pixel_filter;
pub mod precision;
pub mod remap;
pub mod table;

pub use camera::{
    Camera, CameraError, CameraRay, CameraSettings, Clipping, CropWindow, Frustum, Projection, ScreenWindow,
    WorldRay, pixel_centre,
};
pub use mapping::{
    DepthCompare, DepthConvention, DepthMapping, FarPlane, MappingError, ndc_depth_gl, ndc_depth_infinite_gl,
    ndc_depth_reversed_gl, point_cloud_matrix, window_depth_gl, window_depth_infinite_gl,
    window_depth_infinite_reversed, window_depth_infinite_wgpu, window_depth_reversed, window_depth_wgpu,
};
pub use remap::{
    DepthOutput, EyeDepthRange, NearFar, NearFarPolicy, RemapError, RemapStats, RemappedDepth,
    choose_near_far, remap_depth_table,
};
pub use table::{DepthTable, DepthTableError, DepthTableErrorKind, ParseOptions, ReadLimits};

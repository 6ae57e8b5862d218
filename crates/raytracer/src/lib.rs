//! `raytracer`: renders RIB scenes (as `rib_parser::scene::Scene`) to images and exact depth
//! tables.
//!
//! # Overview
//! - [`world`]: the render-ready scene in *render space* (world axes, origin at the eye; every
//!   transform composed in `f64` and rounded once), bottom-level BVHs per object definition and
//!   a top-level BVH over instances ([`accel`], obvhs' CWBVH with a conservative node test).
//! - [`shapes`]: watertight ray-triangle intersection and exact `f64` quadrics (sphere,
//!   cylinder, cone, disk, paraboloid, hyperboloid, torus with sweeps); patches, NURBS and
//!   polygons come as triangles from `tessellate`.
//! - [`materials`], [`bsdf`], [`lights`]: RenderMan's standard shaders and lights (and LRT's
//!   mirror and glass) as physically based BSDFs and emitters.
//! - [`integrators`]: `directlighting` (Whitted) and `path` (MIS, Russian roulette);
//!   [`photon`]: `photonmap` (global and caustic photon maps in kd-trees, final gathering with
//!   precomputed radiance photons, scene analysis that skips what a scene does not need).
//! - [`render`]: camera rays from `depth_remap::Camera`, parallel deterministic tiles, pixel
//!   filters ([`film`]), the depth table's distances; [`output`] writes TIFF, PNG, JPEG and EXR.
//! - [`passes`]: renders in passes (progressive photon mapping, `--time`, `--target-error`
//!   with a per-pixel error estimate).
//!
//! Spawned rays start at points pushed off their surface by a bound on the point's rounding
//! error ([`math::offset_ray_origin`]): there is no fixed epsilon anywhere, so a scene renders
//! the same at any scale and far from the origin.
//!
//! # Example
//! ```
//! use glam::{DMat4, DVec3, Vec3};
//! use raytracer::render::{render, RenderOptions};
//! use raytracer::testing::SceneBuilder;
//! use rib_parser::scene::{LightKind, Shape};
//!
//! // A matte sphere lit by a point light, seen from 5 units away.
//! let mut b = SceneBuilder::perspective(32, 24, 40.0, DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO);
//! b.light(LightKind::Point { position: DVec3::new(2.0, 3.0, 4.0), intensity: 20.0, color: Vec3::ONE }, "pointlight");
//! let red = b.matte(Vec3::new(0.8, 0.1, 0.1));
//! b.light_everything();
//! b.shape(Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 }, DMat4::IDENTITY, red);
//! let out = render(&b.build(), &RenderOptions { depth: true, ..RenderOptions::default() }).unwrap();
//! // The pixel next to the image centre sees the sphere about 4 units away (its ray is half a
//! // pixel off the axis).
//! let depth = out.depth.unwrap();
//! let centre = depth.values[(12 * 32 + 16) as usize];
//! assert!((centre - 4.0).abs() < 0.01);
//! assert!(out.image.rgb(16, 12).x > 0.0);
//! ```

// Comparisons are often written `!(x > 0.0)` on purpose: they are also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bsdf;
pub mod diagnostics;
pub mod environment_light;
pub mod film;
pub mod integrators;
mod layered_render;
pub mod lens;
pub mod light_layers;
pub mod lights;
pub mod materials;
pub mod math;
pub mod output;
pub mod passes;
pub mod photon;
pub mod probe_bake;
pub mod reflection_bake;
pub mod render;
pub mod sampler;
pub mod sampling;
pub mod shapes;
#[doc(hidden)]
pub mod testing;
pub mod transmission_layers;
/// Texture maps (moved to `tessellate`, which the haptics' displaced surfaces read them with).
pub mod texture {
    pub use tessellate::texture::*;
}
pub mod wavefront;
pub mod world;

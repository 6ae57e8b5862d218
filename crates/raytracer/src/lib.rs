//! `raytracer`: see ARCHITECTURE.md.

// Comparisons are often written `!(x > 0.0)` on purpose: they are also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bsdf;
pub mod diagnostics;
pub mod film;
pub mod integrators;
pub mod lights;
pub mod materials;
pub mod math;
pub mod render;
pub mod sampling;
pub mod shapes;
#[doc(hidden)]
pub mod testing;
pub mod texture;
pub mod world;

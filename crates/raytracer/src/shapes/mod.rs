//! Shapes in their own spaces: watertight triangles and exact quadrics.

pub mod quadric;
pub mod roots;
pub mod triangle;
pub mod triangle_rows;

pub use quadric::{DegenerateQuadric, Quadric, QuadricHit, QuadricShape};
pub(crate) use triangle::barycentric_point_rounded_v3;
pub use triangle::{RayShear, TriangleHit, barycentric_point, hits_front, intersect_triangle};
pub use triangle_rows::{RowShear, TriangleRows};

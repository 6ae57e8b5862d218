//! `rib-parser`: reads RenderMan Interface Bytestream files into a world-space scene description.
//!
//! The scene description ([`scene::Scene`]) is plain data: cameras, lights, attribute states and
//! shapes with their transforms, every entity carrying the [`scene::FileLoc`] it came from.

pub mod scene;
pub mod tessellate;

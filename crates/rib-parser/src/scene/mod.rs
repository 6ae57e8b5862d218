//! The world-space scene description that comes out of a RIB file.
//!
//! This is plain data, built by the scene builder (one implementation of the parser's target
//! trait) and read by the ray tracer, the viewer and the haptics. It says what the RIB means,
//! not how any consumer renders it: shader names and parameters are kept as given, and each
//! consumer interprets them (e.g. the ray tracer maps `"plastic"` to its material).
//!
//! Conventions:
//! - Transforms are `f64` ([`DMat4`], column vectors, `p_world = world_from_object * p`), composed
//!   as the RenderMan Interface says: the transform given last applies to the object first. A RIB
//!   matrix in row-vector layout converts with `DMat4::from_cols_array(&rib16)`.
//! - Geometry is stored in its own object space, as given (`f32`, like `RtFloat`), so a consumer
//!   can choose its own render space (e.g. camera-relative) and keep precision far from the origin.
//! - Angles are kept in the RIB's units (degrees) where the RIB gives them, and named `_degrees`.
//! - Every entity carries the [`FileLoc`] of the request that made it.

mod attributes;
mod hierarchical;
mod params;
mod settings;
mod shapes;

pub use attributes::*;
pub use hierarchical::*;
pub use params::*;
pub use settings::*;
pub use shapes::*;

use depth_remap::CameraSettings;
use glam::DMat4;
use std::fmt;
use std::sync::Arc;

// ---------------------------------------------------------------------------------------------
// Locations

/// Where something came from: `file:line:col`, 1-based. `file` is the path as the user or the
/// including file named it (so messages read like the command line).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct FileLoc {
    pub file: Arc<str>,
    pub line: u32,
    pub column: u32,
}

impl FileLoc {
    pub fn new(file: impl Into<Arc<str>>, line: u32, column: u32) -> FileLoc {
        FileLoc { file: file.into(), line, column }
    }
}

impl fmt::Display for FileLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

// ---------------------------------------------------------------------------------------------
// The scene

/// One frame of a RIB file, in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The file the scene was read from (`-` for standard input).
    pub source: Arc<str>,
    /// `FrameBegin n` of the frame this scene is, when the file has frames.
    pub frame: Option<i32>,
    /// The camera as the RIB describes it; `depth_remap::Camera::new` checks it.
    pub camera: CameraSettings,
    pub render: RenderSettings,
    pub displays: Vec<Display>,
    pub depth_request: Option<DepthRequest>,
    /// Every `Option` call, in order.
    pub options: Vec<OptionCall>,
    pub lights: Vec<Light>,
    pub attributes: Vec<Attributes>,
    pub shapes: Vec<ShapeEntity>,
    /// The world's `SolidBegin` blocks, outer blocks before the blocks they contain.
    pub solids: Vec<Solid>,
    pub objects: Vec<ObjectDefinition>,
    pub instances: Vec<ObjectInstanceEntity>,
    /// `CoordinateSystem "name"`: world-from-named-space, in the order declared.
    pub coordinate_systems: Vec<(String, DMat4)>,
}

impl Scene {
    pub fn attributes_of(&self, id: AttributesId) -> &Attributes {
        &self.attributes[id.0 as usize]
    }

    pub fn light(&self, id: LightId) -> &Light {
        &self.lights[id.0 as usize]
    }
}

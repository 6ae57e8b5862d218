//! `rib-parser`: reads RenderMan Interface Bytestream files into a world-space scene description.
//!
//! # Overview
//! - [`lexer`](crate::parser) tokens: ASCII RIB and the binary encoding of RISpec 3.2 Appendix C,
//!   freely intermixed; gzip is detected by its magic bytes whatever the file is called.
//! - [`parser::Reader`] drives a [`target::RibTarget`] with one typed, validated call per
//!   request (pbrt-v4's `ParserTarget` design): parameter declarations (`Declare`, inline
//!   `"uniform float Kd"`, the standard predeclared names), value counts per storage class and
//!   primitive, `ReadArchive` with search paths and cycle detection, inline archives,
//!   `DelayedReadArchive`. It never executes anything a scene names.
//! - [`builder::SceneBuilder`] is the target that produces a [`scene::Scene`]: plain data with
//!   the camera ([`depth_remap::CameraSettings`]), lights in world space, attribute states,
//!   shapes in object space with `f64` transforms, object instances, and the `file:line:col`
//!   of every entity.
//! - [`writer`] writes a scene back as RIB (an exact round trip); [`summary`] describes one in
//!   a few lines.
//! - [`diagnostics`]: warnings and errors rendered as `PATH:LINE:COL: error: message` with the
//!   source line and a caret.
//!
//! Nothing panics on any input, and [`limits::Limits`] bounds memory and nesting.
//!
//! # Example
//! ```
//! let rib = br#"
//!     Format 64 48 1
//!     Projection "perspective" "fov" [45]
//!     Translate 0 0 5
//!     WorldBegin
//!       LightSource "pointlight" 1 "from" [0 2 0] "intensity" [4]
//!       Color [1 0 0]
//!       Sphere 1 -1 1 360
//!     WorldEnd
//! "#;
//! let loaded = rib_parser::load_bytes("inline.rib", rib.to_vec(), &rib_parser::LoadOptions::default())
//!     .expect("a valid scene");
//! let scene = &loaded.scene;
//! assert_eq!(scene.shapes.len(), 1);
//! assert_eq!(scene.camera.x_resolution, 64);
//! assert_eq!(scene.attributes_of(scene.shapes[0].attributes).color, glam::Vec3::new(1.0, 0.0, 0.0));
//! ```

pub mod basis;
pub mod blobby;
pub mod builder;
pub mod conditional;
pub mod csg;
pub mod deformation;
pub mod diagnostics;
pub mod generated;
mod lexer;
pub mod limits;
pub mod motion;
pub mod params;
pub mod parser;
pub mod scene;
pub mod source;
pub mod summary;
pub mod target;
pub mod writer;

pub use builder::{BuildOptions, Built, FrameInfo, SceneBuilder};
pub use diagnostics::{Diagnostic, DiagnosticKind, Diagnostics, RibError, Severity};
pub use limits::Limits;
pub use parser::{ReadOptions, Reader};
pub use source::{FileSystem, SourceMap, StdFileSystem};

use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Everything that decides how a file is read and which scene is built from it.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    pub read: ReadOptions,
    /// The frame to keep (`None`: the first world of the file).
    pub frame: Option<i32>,
}

/// A scene read from RIB, with what else the run found.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub scene: scene::Scene,
    /// Every `FrameBegin` of the file.
    pub frames: Vec<FrameInfo>,
    /// Where `MakeShadow` was requested: superseded by ray-traced shadows (no map is made).
    pub superseded_shadow_maps: Vec<scene::FileLoc>,
    /// The warnings (a loaded scene has no errors).
    pub diagnostics: Diagnostics,
    pub sources: SourceMap,
    /// Requests read, archives included.
    pub requests: u64,
    /// RIB bytes read, after decompression, archives included.
    pub bytes_read: u64,
}

impl Loaded {
    /// The warnings rendered with their source lines.
    pub fn render_warnings(&self) -> String {
        self.diagnostics.render(&self.sources)
    }
}

/// Reads the RIB file at `path` (`-` for standard input) and builds its scene.
pub fn load_scene(path: &Path, options: &LoadOptions) -> Result<Loaded, RibError> {
    let name = path.to_string_lossy().into_owned();
    load_with(&name, options, |reader, builder| reader.read_file(path, builder))
}

/// Builds the scene of RIB bytes (ASCII, binary or gzip). Archives are resolved from the
/// current directory.
pub fn load_bytes(name: &str, bytes: Vec<u8>, options: &LoadOptions) -> Result<Loaded, RibError> {
    load_with(name, options, |reader, builder| reader.read_bytes(name, None, bytes, builder))
}

/// Like [`load_bytes`], with the bytes standing for the file at `path` (archives resolve
/// relative to it).
pub fn load_bytes_at(path: &Path, bytes: Vec<u8>, options: &LoadOptions) -> Result<Loaded, RibError> {
    let name = path.to_string_lossy().into_owned();
    load_with(&name, options, |reader, builder| {
        reader.read_bytes(&name, Some(PathBuf::from(path)), bytes, builder)
    })
}

fn load_with(
    name: &str,
    options: &LoadOptions,
    read: impl FnOnce(&mut Reader, &mut SceneBuilder),
) -> Result<Loaded, RibError> {
    let mut reader = Reader::new(options.read.clone());
    let build_options = BuildOptions { frame: options.frame, limits: options.read.limits.clone() };
    let mut builder = SceneBuilder::new(Arc::<str>::from(name), build_options);
    read(&mut reader, &mut builder);
    let requests = reader.request_count();
    let bytes_read = reader.bytes_read();
    let (mut diagnostics, sources) = reader.into_parts();
    let built = if diagnostics.is_fatal() { None } else { builder.finish(&mut diagnostics) };
    match built {
        Some(built) if !diagnostics.has_errors() => Ok(Loaded {
            scene: built.scene,
            frames: built.frames,
            superseded_shadow_maps: built.superseded_shadow_maps,
            diagnostics,
            sources,
            requests,
            bytes_read,
        }),
        _ => Err(RibError::new(diagnostics.into_items(), sources)),
    }
}

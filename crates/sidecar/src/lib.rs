//! The compositing data `lrt-depth` writes next to the depth table, defined once for the ray
//! tracer that writes it and the viewer that reads it (docs/sidecar.md).
//!
//! - [`SidecarPaths`]: the file names, derived from the depth table's (or the image's) path,
//!   e.g. `out.depth` -> `out.layers.exr`.
//! - [`LightLayers`]: per-pixel light layers (each light's or light group's direct
//!   contribution, emission, the indirect remainder) plus the shading normal and diffuse albedo
//!   at the primary hit, such that the beauty image is the sum of the radiance layers.
//! - [`write_layers`] writes them atomically; [`read_layers`] refuses anything that does not
//!   belong to the image it is paired with, naming the file.
//! - [`ProbeGrid`] ([`write_probes`], [`read_probes`]): irradiance probes (SH + visibility).
//! - [`ReflectionProbes`] ([`write_reflections`], [`read_reflections`]): octahedral radiance
//!   maps prefiltered per roughness ([`reflection_level`]) with a distance map each.
//! - [`CausticPhotons`] ([`write_caustics`], [`read_caustics`]): the caustic photons the
//!   primary hits' estimates read, their light paths' segments and each pixel's estimate kernel.
//!
//! ```
//! use sidecar::{LayerExpectation, LightLayers, LightSource, SidecarPaths, depth_fingerprint};
//! let dir = tempfile::TempDir::new().unwrap();
//! let depth = [1.0_f32, 2.0, f32::INFINITY, 4.0];
//! let mut layers = LightLayers::new(2, 2, depth_fingerprint(&depth), vec![LightSource::new(0, "pointlight")]);
//! layers.light_mut(0)[0] = [0.5, 0.25, 0.125];
//! let paths = SidecarPaths::for_depth(&dir.path().join("out.depth"));
//! sidecar::write_layers(&layers, &paths.layers).unwrap();
//! let expect = LayerExpectation { width: 2, height: 2, depth_fingerprint: Some(depth_fingerprint(&depth)) };
//! let back = sidecar::read_layers(&paths.layers, &expect, Default::default()).unwrap();
//! assert_eq!(back, layers);
//! assert_eq!(back.beauty()[0], [0.5, 0.25, 0.125]);
//! ```

mod caustics;
mod caustics_io;
mod error;
mod exr_file;
mod fingerprint;
mod layers;
mod layers_io;
mod paths;
mod probes;
mod probes_io;
mod reflections;
mod reflections_io;
pub mod sh;

pub use caustics::{
    CAUSTIC_NORMAL_COSINE, CausticFilter, CausticPhoton, CausticPhotons, CausticPixel, MAX_CAUSTIC_PHOTONS,
    MAX_CAUSTIC_SEGMENTS, segment_meets_sphere,
};
pub use caustics_io::{read_caustics, write_caustics};
pub use error::{SidecarError, SidecarErrorKind};
pub use exr_file::sort_exr_header_attributes;
pub use fingerprint::depth_fingerprint;
pub use layers::{
    GLOSSY_LAYERS, LayerExpectation, LightLayers, LightSource, MAX_LIGHT_LAYERS, OPTIONAL_LAYER_GROUPS,
    REFLECTION_LAYERS, TRANSMISSION_LAYERS, light_layer_count, light_layer_of,
};
pub use layers_io::{ReadLimits, channel_names, read_layers, write_layers};
pub use paths::SidecarPaths;
pub use probes::{
    ProbeGrid, VISIBILITY_TEXELS, octahedral_direction, octahedral_texel, octahedral_texel_direction,
    octahedral_uv,
};
pub use probes_io::{read_probes, write_probes};
pub use reflections::{
    GLOSSY_SAMPLES, LobeDirection, REFLECTION_LEVELS, REFLECTION_TEXELS, ReflectionProbes, blinn_albedo,
    blinn_exponent, glossy_lobe_directions, octahedral_texel_center, octahedral_texel_solid_angle,
    prefilter_radiance, reflection_level, reflection_level_exponent, reflection_level_roughness,
    reflection_level_texels, reflection_levels, reflection_lobe, reflections_absent_note,
};
pub use reflections_io::{MAX_REFLECTION_PROBES, read_reflections, write_reflections};

/// The sidecar format version written in every file's header (`lrt.sidecar.version`).
pub const FORMAT_VERSION: i32 = 1;

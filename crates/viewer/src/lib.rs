//! `viewer`: the real-time half of hybrid rendering. A pre-rendered image is shown pixel for
//! pixel; each pixel's ray-traced depth is converted to the depth a perspective projection with
//! the RIB camera would write, so live objects drawn with that projection occlude and are
//! occluded by the pre-rendered scene exactly.
//!
//! Overview:
//! - [`ViewerScene`]: the camera (`depth_remap::Camera`, the one camera model), the image
//!   ([`Rgba8Image`]), the radial depth table (`depth_remap::DepthTable`), the lights ([`LiveLight`]) and
//!   the tone map; checked for matching sizes.
//! - [`Gpu`]: a wgpu device (Vulkan first, GL as a fallback; software adapters count).
//! - [`Compositor`]: renders a frame into offscreen targets (colour, a live-object mask, depth)
//!   in either [`CompositeMode`] (the paper's point per pixel, or Lawlor's full-screen pass
//!   writing fragment depth; identical results), with the cursor [`Sphere`] as an exact
//!   ray-cast impostor, live [`Mesh`]es, lighting from the RIB's lights and the sphere's shadow
//!   on the pre-rendered scene. [`Compositor::read_back`] returns all three buffers.
//! - [`window::run`]: the same frames in a winit window, with keyboard and mouse control of the
//!   sphere, or driven each frame by a [`LiveUpdate`] (e.g. the haptic thread's shared state).
//!
//! ```
//! use depth_remap::{Camera, CameraSettings, DepthTable, Projection};
//! use glam::DVec3;
//! use viewer::{Compositor, CompositorSettings, Gpu, LiveObjects, Sphere, ViewerScene};
//! use viewer::{Rgba8Image, ToneMap};
//!
//! # fn main() -> Result<(), viewer::ViewerError> {
//! // A 64x48 grey image of a wall 5 units in front of the eye (radial distances per pixel).
//! let camera = Camera::new(CameraSettings {
//!     x_resolution: 64,
//!     y_resolution: 48,
//!     projection: Projection::Perspective { fov_degrees: 40.0 },
//!     ..CameraSettings::default()
//! })
//! .expect("a valid camera");
//! let values = (0..64 * 48)
//!     .map(|k| (5.0 / camera.pixel_centre_ray(k % 64, k / 64).direction.z) as f32)
//!     .collect();
//! let depth = DepthTable::new(64, 48, values).expect("valid depths");
//! let image = Rgba8Image::filled(64, 48, [128, 128, 128, 255]);
//! let scene = ViewerScene::new(camera, image, depth, vec![], ToneMap::default())?;
//!
//! let gpu = Gpu::new(Default::default())?;
//! let mut compositor = Compositor::new(&gpu, &scene, CompositorSettings::default())?;
//! // A sphere cutting through the wall: only its front half shows.
//! let sphere = Sphere { centre: DVec3::new(0.0, 0.0, 5.0), radius: 0.5, material: Default::default() };
//! compositor.render(&LiveObjects { sphere: Some(sphere), meshes: Vec::new() })?;
//! let frame = compositor.read_back()?;
//! assert_eq!(frame.mask[24 * 64 + 32], 255); // the sphere is visible at the centre
//! assert_eq!(frame.colour.pixels[..4], [128, 128, 128, 255]); // the corner is the image
//! # Ok(()) }
//! ```

pub mod backdrop;
pub mod compositor;
pub mod display;
pub mod error;
pub mod gpu;
pub mod light_layers;
pub mod live;
pub mod live_scene;
pub mod occluders;
pub mod pixel_filter;
pub mod projection;
pub mod scene;
pub mod window;

pub use backdrop::{Backdrop, Rgba8Image, ToneMap};
pub use compositor::{
    CompositeMode, Compositor, CompositorSettings, DepthSettings, FrameReadback, LINEAR_FORMAT,
    LINEAR_FORMAT_FALLBACK, LinearFrame, ShadowSettings,
};
pub use depth_remap::{DepthConvention, DepthTable, NearFar};
pub use display::{DisplayEncoding, DisplayTransfer};
pub use error::ViewerError;
pub use gpu::{Backends, Gpu};
pub use light_layers::{AreaSample, SceneLayers};
pub use live::{FrameInfo, LiveLight, LiveObjects, LiveUpdate, Material, Mesh, MeshInstance, Sphere};
pub use live_scene::{LiveMaterial, LiveMesh, LiveScene, LiveSphere, LiveSurface};
pub use pixel_filter::{FilterKind, PixelFilter};
pub use projection::Projection;
pub use scene::{MAX_VIEWER_REFLECTION_PROBES, ViewerScene};
pub use wgpu;

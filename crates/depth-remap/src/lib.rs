//! `depth-remap`: the one camera model of the project and everything that converts the ray
//! tracer's depth into what a rasteriser's depth buffer holds.
//!
//! The central invariant: [`camera::Camera::pixel_centre_ray`] is *the* definition of "the ray
//! through the centre of pixel (i, j)". The ray tracer shoots it to fill the depth table and the
//! viewer inverts it to turn a radial distance back into eye depth, so the two can never
//! disagree.

pub mod camera;

pub use camera::{
    Camera, CameraError, CameraRay, CameraSettings, Clipping, CropWindow, Projection, ScreenWindow,
};

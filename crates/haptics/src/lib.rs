//! `haptics`: touch a RIB scene's geometry through a haptic device.
//!
//! As in Morris & Joshi's hybrid renderer, a dedicated thread reads a device, maps its position
//! with a gain into scene space (`scene = centre + gain * device`), and renders forces from the
//! scene's triangles; the viewer draws the device as a sphere. This crate does it to the standard
//! of CHAI3D's finger proxy:
//!
//! - **Geometry** ([`CollisionMesh`], [`Bvh`]): world-space triangles stored relative to a local
//!   origin (precision far from the world origin), in a BVH built once for swept-sphere and
//!   closest-point queries.
//! - **Proxy** ([`GodObject`]): a god-object with a radius. Each tick it is swept from where it
//!   is towards the device's goal, constrained by up to three contact planes (sliding on faces,
//!   along creases, stopping in corners); it never passes through thin sheets or fast strikes.
//!   Friction cones (static and dynamic) and stiffness per object come from [`MaterialTable`].
//! - **Rendering** ([`HapticRenderer`]): the spring from device to proxy, optional damping and
//!   force shading, the workspace mapping, and the safety layer ([`SafeForce`], force ramps).
//! - **Devices** ([`HapticDevice`]): a deterministic [`SimulatedDevice`] (trajectory replay or
//!   manual input, optional mass-damper dynamics) and, with the default `spacemouse` feature,
//!   3Dconnexion SpaceMouse-family devices through hidapi.
//! - **Thread** ([`HapticThread`]): the 1 kHz loop with a watchdog, exchanging state with the
//!   viewer through wait-free triple buffers; [`replay`] runs the same loop in simulated time,
//!   deterministically, writing the force log ([`ForceLogWriter`]).
//! - **Scenes** ([`scene`], [`session`]): a RIB scene's surfaces tessellated into a collision
//!   mesh with materials from `Attribute "haptic"`, and everything a front end needs to run them.
//!
//! The core (geometry, proxy, devices, thread) works on plain triangles; see `docs/haptics.md`
//! for the design, measurements and limitations.
//!
//! # Example
//! Press a simulated device into a floor and read the force:
//! ```
//! use glam::DVec3;
//! use haptics::*;
//! use std::sync::Arc;
//!
//! // A 2 m square floor at z = 0, in world space.
//! let mut mesh = CollisionMesh::new(DVec3::ZERO);
//! let corners = [
//!     DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, -1.0, 0.0),
//!     DVec3::new(1.0, 1.0, 0.0), DVec3::new(-1.0, 1.0, 0.0),
//! ];
//! mesh.push_indexed(&corners, &[[0, 1, 2], [0, 2, 3]], None, MaterialId(0)).unwrap();
//! let world = Arc::new(CollisionWorld::new(mesh));
//!
//! // Device coordinates equal scene coordinates; a 1 cm proxy; 1000 N/m, no friction.
//! let mut device = SimulatedDevice::replay(
//!     Trajectory::parse("t,x,y,z\n0,0,0,0.05\n1,0,0,0.005\n", "press.csv").unwrap(),
//! );
//! let materials = MaterialTable::uniform(Material { stiffness: 1000.0, static_friction: 0.0, dynamic_friction: 0.0 });
//! let mapping = WorkspaceMapping::new(DVec3::ZERO, 1.0).unwrap();
//! let mut settings = RenderSettings::new(0.01);
//! settings.ramp_time = 0.0;
//! let mut renderer = HapticRenderer::new(world, materials, device.specs(), mapping, settings);
//!
//! let config = ReplayConfig { rate_hz: 1000.0, start: 0.0, end: 1.0 };
//! let mut last = None;
//! replay(&mut device, &mut renderer, &config, |tick| { last = Some(*tick); Ok(()) }).unwrap();
//! let last = last.unwrap();
//! // The device is 5 mm into the 1 cm proxy's contact: 1000 N/m * 5 mm = 5 N, straight up.
//! assert!((last.force.get() - DVec3::new(0.0, 0.0, 5.0)).length() < 1e-9);
//! assert!((last.proxy_scene.z - 0.01).abs() < 1e-12);
//! ```

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it is also true for NaN, so
// bad values take the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bvh;
pub mod clipping;
mod csg;
pub mod device;
pub mod geometry;
pub mod material;
pub mod proxy;
pub mod render;
pub mod replay;
pub mod scene;
pub mod session;
pub mod thread;
pub mod timing;
pub mod trajectory;
pub mod triple_buffer;

pub use bvh::Bvh;
pub use device::{DeviceError, DeviceSample, DeviceSpecs, HapticDevice, SafeForce, SimulatedDevice};
pub use geometry::{CollisionMesh, GeometryError, MaterialId};
pub use material::{Material, MaterialDefaults, MaterialSpec, MaterialTable};
pub use proxy::{CollisionWorld, GodObject, ProxySettings};
pub use render::{HapticRenderer, RenderSettings, TickOutput, WorkspaceMapping};
pub use replay::{ForceLogWriter, ReplayConfig, replay};
pub use thread::{HapticState, HapticThread, ThreadConfig, ThreadReport};
pub use trajectory::{Trajectory, TrajectoryError};

use std::path::PathBuf;

/// Errors of the haptics crate.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HapticError {
    #[error(transparent)]
    Device(#[from] DeviceError),
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    #[error(transparent)]
    Trajectory(#[from] TrajectoryError),
    #[error(transparent)]
    Mapping(#[from] render::MappingError),
    #[error("{path}: {detail}")]
    Io { path: PathBuf, detail: String },
    #[error("{0}")]
    Config(String),
    #[error("the haptic thread panicked")]
    ThreadPanicked,
}

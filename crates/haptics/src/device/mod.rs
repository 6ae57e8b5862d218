//! Haptic devices: the [`HapticDevice`] trait, the force type that is safe to send to one, and
//! the implementations: a [`SimulatedDevice`] (trajectory replay or manual input, with optional
//! mass-damper dynamics) and, with the `spacemouse` feature, 3Dconnexion SpaceMouse-family
//! 6-DoF input devices through hidapi.
//!
//! ## A grounded force device
//! No grounded force-feedback device speaks plain HID: a Force Dimension (omega, delta, sigma)
//! or a 3D Systems Touch needs its vendor SDK (`dhd`, OpenHaptics HD). Such a back end belongs
//! behind its own cargo feature (for example `forcedimension`, linking `dhd` through a small
//! `-sys` crate) and implements this trait directly: `read` returns `dhdGetPosition` (metres,
//! device frame) and the orientation, `apply_force` calls `dhdSetForce` with the already safe
//! force, `arm_watchdog` maps to `dhdSetWatchdog` so the controller's own hardware watchdog
//! zeroes the force if this process stops, and `specs` reports the model's workspace, force,
//! stiffness and damping limits. None is implemented here, because none can be tested here.

pub mod simulated;
#[cfg(feature = "spacemouse")]
pub mod spacemouse;

pub use simulated::{
    Dynamics, EnergyLedger, ManualInput, ManualInputWriter, SimulatedDevice, SimulatedFault,
};

use glam::{DQuat, DVec3};
use std::time::Duration;

/// What a device can do. Lengths in metres in the device's own frame, forces in newtons.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceSpecs {
    /// Model name, e.g. `"SpaceMouse Wireless"`.
    pub name: String,
    /// Radius of the sphere the device's position can reach, centred on its rest position.
    pub workspace_radius: f64,
    /// Largest force the device may be commanded (N). For an input-only device this is the
    /// nominal limit of the virtual force that is logged and fed back to its controller.
    pub max_force: f64,
    /// Stiffest virtual spring the device renders stably (N/m).
    pub max_stiffness: f64,
    /// Largest virtual damping the device renders stably (N s/m).
    pub max_damping: f64,
    /// True when `apply_force` produces a real force on the user's hand.
    pub has_force_output: bool,
    pub has_orientation: bool,
    pub button_count: u32,
}

/// One reading of a device.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceSample {
    /// Position in the device frame (metres).
    pub position: DVec3,
    /// Orientation of the handle, when the device has one.
    pub orientation: Option<DQuat>,
    /// Buttons, bit `i` set when button `i` is pressed.
    pub buttons: u32,
    /// The device's own timestamp of the reading (seconds); the loop's clock for devices
    /// without one.
    pub timestamp: f64,
}

/// Device failures. A device that fails stops the haptic loop cleanly (forces zeroed first).
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum DeviceError {
    #[error("{device}: device disconnected ({detail})")]
    Disconnected { device: String, detail: String },
    #[error("{device}: device stopped answering (no reading for {waited:?})")]
    NotAnswering { device: String, waited: Duration },
    #[error("{device}: {detail}")]
    Io { device: String, detail: String },
    #[error("no such device: {0}")]
    NotFound(String),
    #[error("{0}")]
    Unsupported(String),
}

/// A force that has been checked: finite and no larger than a limit. The only way to make one
/// is [`SafeForce::limit`] (or [`SafeForce::ZERO`]), so no NaN or over-limit force can reach a
/// device through [`HapticDevice::apply_force`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SafeForce(DVec3);

/// What [`SafeForce::limit`] had to do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ForceCorrection {
    /// The force was NaN or infinite and was replaced by zero.
    pub non_finite: bool,
    /// The force was longer than the limit and was scaled down to it.
    pub clamped: bool,
}

impl SafeForce {
    pub const ZERO: SafeForce = SafeForce(DVec3::ZERO);
    /// No device comes near a kilonewton; far above it any limit is a mistake. Keeping limits
    /// below this also keeps every length computation finite.
    pub const ABSOLUTE_MAX: f64 = 1.0e4;

    /// Makes `force` safe: zero when any component is not finite, scaled to `max_force` when
    /// longer. A `max_force` below a micronewton (or not finite) allows only zero; one above
    /// [`SafeForce::ABSOLUTE_MAX`] is taken as that.
    pub fn limit(force: DVec3, max_force: f64) -> (SafeForce, ForceCorrection) {
        let max_force =
            if max_force.is_finite() && max_force >= 1e-6 { max_force.min(Self::ABSOLUTE_MAX) } else { 0.0 };
        if !force.is_finite() {
            return (SafeForce::ZERO, ForceCorrection { non_finite: true, clamped: false });
        }
        let length = force.length();
        if length > max_force {
            // Very large components overflow the length; scale by the largest one first.
            let largest = force.abs().max_element();
            let unit = (force / largest).normalize_or_zero();
            let scaled = if length.is_finite() { force * (max_force / length) } else { unit * max_force };
            // Rounding can leave the scaled length a hair above the limit; shave it.
            let scaled = if scaled.length() > max_force { scaled * (1.0 - 1e-12) } else { scaled };
            return (SafeForce(scaled), ForceCorrection { non_finite: false, clamped: true });
        }
        (SafeForce(force), ForceCorrection::default())
    }

    pub fn get(self) -> DVec3 {
        self.0
    }
}

/// A haptic or 6-DoF input device, driven by the haptic loop: `read` then `apply_force`, once
/// per tick, from one thread.
pub trait HapticDevice: Send + std::fmt::Debug {
    fn specs(&self) -> &DeviceSpecs;

    /// Reads the device. `time` is the haptic loop's clock in seconds (simulated time in a
    /// replay, so simulated devices stay deterministic); devices with their own clock report it
    /// in [`DeviceSample::timestamp`].
    fn read(&mut self, time: f64) -> Result<DeviceSample, DeviceError>;

    /// Commands `force` (device frame) until the next call. Input-only devices may use it as
    /// feedback for their controller (see the SpaceMouse rate controller) or ignore it.
    fn apply_force(&mut self, force: SafeForce, time: f64) -> Result<(), DeviceError>;

    /// Arms the device's own watchdog, which zeroes its force if `apply_force` is not called
    /// within `timeout` (a grounded device's controller does this in hardware). Devices without
    /// one return `Ok(false)`; the haptic thread's software watchdog covers the rest.
    fn arm_watchdog(&mut self, timeout: Duration) -> Result<bool, DeviceError> {
        let _ = timeout;
        Ok(false)
    }

    /// When a replayed device runs out of input (seconds on the loop clock); `None` for live
    /// devices.
    fn end_time(&self) -> Option<f64> {
        None
    }
}

impl<D: HapticDevice + ?Sized> HapticDevice for Box<D> {
    fn specs(&self) -> &DeviceSpecs {
        (**self).specs()
    }
    fn read(&mut self, time: f64) -> Result<DeviceSample, DeviceError> {
        (**self).read(time)
    }
    fn apply_force(&mut self, force: SafeForce, time: f64) -> Result<(), DeviceError> {
        (**self).apply_force(force, time)
    }
    fn arm_watchdog(&mut self, timeout: Duration) -> Result<bool, DeviceError> {
        (**self).arm_watchdog(timeout)
    }
    fn end_time(&self) -> Option<f64> {
        (**self).end_time()
    }
}

/// A device found by [`list_devices`].
#[derive(Clone, Debug, PartialEq)]
pub struct ListedDevice {
    /// What to pass on a command line to pick it (`sim`, `spacemouse`, `spacemouse:PATH`).
    pub selector: String,
    pub description: String,
}

/// Every device this build can drive that is present now: the simulated device always, and
/// connected SpaceMouse-family devices. Enumeration failures of a back end are reported in the
/// second list rather than hiding the other devices.
pub fn list_devices() -> (Vec<ListedDevice>, Vec<DeviceError>) {
    let mut found = vec![ListedDevice {
        selector: "sim".into(),
        description: "simulated device (trajectory replay or keyboard/mouse; always available)".into(),
    }];
    #[allow(unused_mut)]
    let mut errors = Vec::new();
    #[cfg(feature = "spacemouse")]
    match spacemouse::enumerate() {
        Ok(devices) => {
            for d in devices {
                found.push(ListedDevice {
                    selector: format!("spacemouse:{}", d.path),
                    description: format!(
                        "{} (vendor {:04x}, product {:04x}) at {}",
                        d.name, d.vendor_id, d.product_id, d.path
                    ),
                });
            }
        }
        Err(e) => errors.push(e),
    }
    (found, errors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn safe_force_rejects_nan_and_clamps() {
        let (f, c) = SafeForce::limit(DVec3::new(f64::NAN, 0.0, 1.0), 5.0);
        assert_eq!(f, SafeForce::ZERO);
        assert!(c.non_finite);
        let (f, c) = SafeForce::limit(DVec3::new(30.0, 40.0, 0.0), 5.0);
        assert!(c.clamped);
        assert!(f.get().length() <= 5.0);
        assert!((f.get() - DVec3::new(3.0, 4.0, 0.0)).length() < 1e-9);
        let (f, _) = SafeForce::limit(DVec3::new(1.0, 0.0, 0.0), f64::NAN);
        assert_eq!(f, SafeForce::ZERO);
        let (f, c) = SafeForce::limit(DVec3::new(1.0, 2.0, 2.0), 5.0);
        assert_eq!(f.get(), DVec3::new(1.0, 2.0, 2.0));
        assert_eq!(c, ForceCorrection::default());
    }

    proptest::proptest! {
        #[test]
        fn safe_force_is_always_finite_and_bounded(x in proptest::num::f64::ANY, y in proptest::num::f64::ANY,
                                                  z in proptest::num::f64::ANY, max in proptest::num::f64::ANY) {
            let (f, _) = SafeForce::limit(DVec3::new(x, y, z), max);
            proptest::prop_assert!(f.get().is_finite());
            let bound = if max.is_finite() && max >= 1e-6 { max.min(SafeForce::ABSOLUTE_MAX) } else { 0.0 };
            proptest::prop_assert!(f.get().length() <= bound);
        }
    }
}

//! A simulated haptic device: deterministic, for tests, replays and machines without hardware.
//!
//! The device's "hand" input is a replayed [`Trajectory`], a position set by keyboard or mouse
//! through a [`ManualInputWriter`], or a fixed point. Without dynamics the device sits exactly
//! where the hand puts it (the force is recorded but moves nothing). With [`Dynamics`] the
//! device is a point mass with viscous damping, pulled towards the hand by a spring-damper
//! (the user's grip) and pushed by the rendered force: the closed loop a real impedance device
//! forms, which the passivity tests need. An [`EnergyLedger`] accounts for every joule.

use super::{DeviceError, DeviceSample, DeviceSpecs, HapticDevice, SafeForce};
use crate::trajectory::Trajectory;
use crate::triple_buffer::{self, Reader, Writer};
use glam::DVec3;
use std::time::Duration;

/// A point-mass device held by a hand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dynamics {
    /// Apparent mass of the handle (kg).
    pub mass: f64,
    /// The device's own viscous damping (N s/m): friction in its joints and motors.
    pub damping: f64,
    /// Stiffness of the grip coupling the hand to the handle (N/m).
    pub grip_stiffness: f64,
    /// Damping of the grip (N s/m).
    pub grip_damping: f64,
}

impl Default for Dynamics {
    /// A desktop device (0.1 kg, 1 N s/m) held with a firm grip (2000 N/m, 5 N s/m).
    fn default() -> Dynamics {
        Dynamics { mass: 0.1, damping: 1.0, grip_stiffness: 2000.0, grip_damping: 5.0 }
    }
}

/// Energy flows in the simulated device (joules), integrated with the dynamics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyLedger {
    /// Work done on the handle by the rendered force.
    pub by_rendered_force: f64,
    /// Work done on the handle by the hand (through the grip).
    pub by_hand: f64,
    /// Energy the device's own damping dissipated (non-negative).
    pub dissipated: f64,
    /// The part of `dissipated` while a force was rendered (in contact).
    pub dissipated_in_contact: f64,
}

impl EnergyLedger {
    /// Net energy the haptic display (rendered force and device together) delivered to the
    /// user. Over a cycle that starts and ends at rest, a passive display delivers none:
    /// this is `<= 0`.
    pub fn delivered_to_user(&self) -> f64 {
        self.by_rendered_force - self.dissipated
    }

    /// Energy the rendered contacts delivered beyond what the device dissipated while in
    /// contact: Colgate's condition for a passive virtual wall (`b > k T / 2`) is that this is
    /// `<= 0`, without credit for damping in free space.
    pub fn contact_surplus(&self) -> f64 {
        self.by_rendered_force - self.dissipated_in_contact
    }
}

/// Where a manually driven device is (device frame, metres), set from the viewer's input.
pub type ManualInput = Reader<DVec3>;
/// The writing end of [`ManualInput`]: never blocks.
pub type ManualInputWriter = Writer<DVec3>;

/// A failure to inject, for tests of the loop's error handling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SimulatedFault {
    /// From loop time `at` on, every read fails as an unplugged device does.
    Disconnect { at: f64 },
    /// At loop time `at`, one read blocks for `duration` of real time (a device that stops
    /// answering for a while).
    Stall { at: f64, duration: Duration },
}

#[derive(Debug)]
enum Input {
    Trajectory(Trajectory),
    Manual(ManualInput),
    Fixed(DVec3),
}

/// See the module documentation.
#[derive(Debug)]
pub struct SimulatedDevice {
    specs: DeviceSpecs,
    input: Input,
    dynamics: Option<Dynamics>,
    position: DVec3,
    velocity: DVec3,
    force: DVec3,
    last_time: Option<f64>,
    ledger: EnergyLedger,
    fault: Option<SimulatedFault>,
    stalled: bool,
}

/// Largest integration step of the dynamics (s); the grip spring needs it well below 1 ms.
const MAX_SUBSTEP: f64 = 1e-4;

impl SimulatedDevice {
    /// The specifications of the simulated device: a desktop impedance device comparable to a
    /// 3D Systems Touch X / Phantom Desktop. Its maximum stiffness is Colgate's passivity bound
    /// `2 b / T` for its own damping `b = 1 N s/m` at the nominal 1 kHz rate.
    pub fn default_specs() -> DeviceSpecs {
        DeviceSpecs {
            name: "Simulated device".into(),
            workspace_radius: 0.08,
            max_force: 8.0,
            max_stiffness: 2000.0,
            max_damping: 5.0,
            has_force_output: true,
            has_orientation: false,
            button_count: 2,
        }
    }

    fn with_input(input: Input) -> SimulatedDevice {
        let position = match &input {
            Input::Trajectory(t) => t.position_at(t.start_time()),
            Input::Manual(_) => DVec3::ZERO,
            Input::Fixed(p) => *p,
        };
        SimulatedDevice {
            specs: SimulatedDevice::default_specs(),
            input,
            dynamics: None,
            position,
            velocity: DVec3::ZERO,
            force: DVec3::ZERO,
            last_time: None,
            ledger: EnergyLedger::default(),
            fault: None,
            stalled: false,
        }
    }

    /// A device that replays `trajectory` (the hand's path when dynamics are enabled).
    pub fn replay(trajectory: Trajectory) -> SimulatedDevice {
        SimulatedDevice::with_input(Input::Trajectory(trajectory))
    }

    /// A device held still at `position`.
    pub fn fixed(position: DVec3) -> SimulatedDevice {
        SimulatedDevice::with_input(Input::Fixed(position))
    }

    /// A device driven by keyboard or mouse: the returned writer sets its position.
    pub fn manual(start: DVec3) -> (SimulatedDevice, ManualInputWriter) {
        let (writer, reader) = triple_buffer::triple_buffer(start);
        let mut device = SimulatedDevice::with_input(Input::Manual(reader));
        device.position = start;
        (device, writer)
    }

    /// Enables the mass-damper model.
    pub fn with_dynamics(mut self, dynamics: Dynamics) -> SimulatedDevice {
        self.dynamics = Some(dynamics);
        self
    }

    pub fn with_specs(mut self, specs: DeviceSpecs) -> SimulatedDevice {
        self.specs = specs;
        self
    }

    pub fn with_fault(mut self, fault: SimulatedFault) -> SimulatedDevice {
        self.fault = Some(fault);
        self
    }

    /// Energy accounting of the dynamics so far (all zero without dynamics).
    pub fn energy(&self) -> EnergyLedger {
        self.ledger
    }

    fn hand_at(&mut self, time: f64) -> DVec3 {
        match &mut self.input {
            Input::Trajectory(t) => t.position_at(time),
            Input::Manual(reader) => {
                let p = reader.read();
                if p.is_finite() { p } else { self.position }
            }
            Input::Fixed(p) => *p,
        }
    }

    /// Advances the mass-damper from `t0` to `t1` under the held force (semi-implicit Euler,
    /// with the work of each force integrated over each substep's displacement).
    fn integrate(&mut self, dynamics: Dynamics, t0: f64, t1: f64) {
        let span = t1 - t0;
        if !(span > 0.0) {
            return;
        }
        let steps = (span / MAX_SUBSTEP).ceil().clamp(1.0, 1e6) as usize;
        let h = span / steps as f64;
        for k in 0..steps {
            let t = t0 + h * (k + 1) as f64;
            let hand = self.hand_at(t);
            let hand_prev = self.hand_at(t - h);
            let hand_velocity = (hand - hand_prev) / h;
            let grip = (hand - self.position) * dynamics.grip_stiffness
                + (hand_velocity - self.velocity) * dynamics.grip_damping;
            let damping = -self.velocity * dynamics.damping;
            let total = grip + damping + self.force;
            self.velocity += total * (h / dynamics.mass);
            let step = self.velocity * h;
            self.position += step;
            self.ledger.by_rendered_force += self.force.dot(step);
            self.ledger.by_hand += grip.dot(step);
            let loss = dynamics.damping * self.velocity.length_squared() * h;
            self.ledger.dissipated += loss;
            if self.force != DVec3::ZERO {
                self.ledger.dissipated_in_contact += loss;
            }
        }
    }
}

impl HapticDevice for SimulatedDevice {
    fn specs(&self) -> &DeviceSpecs {
        &self.specs
    }

    fn read(&mut self, time: f64) -> Result<DeviceSample, DeviceError> {
        match self.fault {
            Some(SimulatedFault::Disconnect { at }) if time >= at => {
                return Err(DeviceError::Disconnected {
                    device: self.specs.name.clone(),
                    detail: "simulated unplug".into(),
                });
            }
            Some(SimulatedFault::Stall { at, duration }) if time >= at && !self.stalled => {
                self.stalled = true;
                std::thread::sleep(duration);
            }
            _ => {}
        }
        match self.dynamics {
            Some(dynamics) => {
                if let Some(t0) = self.last_time {
                    self.integrate(dynamics, t0, time);
                } else {
                    self.position = self.hand_at(time);
                }
            }
            None => {
                let previous = self.position;
                self.position = self.hand_at(time);
                if let Some(t0) = self.last_time
                    && time > t0
                {
                    self.velocity = (self.position - previous) / (time - t0);
                }
            }
        }
        self.last_time = Some(time);
        Ok(DeviceSample { position: self.position, orientation: None, buttons: 0, timestamp: time })
    }

    fn apply_force(&mut self, force: SafeForce, _time: f64) -> Result<(), DeviceError> {
        self.force = force.get();
        Ok(())
    }

    fn end_time(&self) -> Option<f64> {
        match &self.input {
            Input::Trajectory(t) => Some(t.end_time()),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replay_without_dynamics_follows_the_trajectory() {
        let tr = Trajectory::from_samples(&[(0.0, DVec3::ZERO), (1.0, DVec3::X)]).unwrap();
        let mut dev = SimulatedDevice::replay(tr);
        assert_eq!(dev.read(0.5).unwrap().position, DVec3::new(0.5, 0.0, 0.0));
        assert_eq!(dev.end_time(), Some(1.0));
    }

    #[test]
    fn dynamics_track_the_hand_and_a_force_pushes_back() {
        let tr = Trajectory::from_samples(&[(0.0, DVec3::ZERO), (10.0, DVec3::ZERO)]).unwrap();
        let mut dev = SimulatedDevice::replay(tr).with_dynamics(Dynamics::default());
        let (force, _) = SafeForce::limit(DVec3::new(2.0, 0.0, 0.0), 8.0);
        for i in 0..=3000 {
            dev.read(i as f64 * 1e-3).unwrap();
            dev.apply_force(force, 0.0).unwrap();
        }
        // At rest the grip balances the force: x = F / k_grip.
        let x = dev.read(3.001).unwrap().position.x;
        assert!((x - 2.0 / 2000.0).abs() < 1e-6, "{x}");
    }

    #[test]
    fn manual_input_moves_the_device() {
        let (mut dev, mut writer) = SimulatedDevice::manual(DVec3::ZERO);
        writer.write(DVec3::new(0.01, 0.02, 0.03));
        assert_eq!(dev.read(0.0).unwrap().position, DVec3::new(0.01, 0.02, 0.03));
        writer.write(DVec3::NAN);
        assert_eq!(dev.read(0.001).unwrap().position, DVec3::new(0.01, 0.02, 0.03));
    }

    #[test]
    fn disconnect_fault_fails_reads() {
        let mut dev = SimulatedDevice::fixed(DVec3::ZERO).with_fault(SimulatedFault::Disconnect { at: 0.5 });
        assert!(dev.read(0.4).is_ok());
        assert!(matches!(dev.read(0.5), Err(DeviceError::Disconnected { .. })));
    }
}

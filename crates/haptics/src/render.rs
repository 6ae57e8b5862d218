//! One haptic tick, from a device reading to a safe force: workspace mapping, the proxy, the
//! spring (and optional damping and force shading), and the safety layer (ramps, limits).
//!
//! Deterministic: the same readings at the same times give bit-identical outputs, which is what
//! headless replay relies on. The real-time thread and the simulated-time replay both call
//! [`HapticRenderer::tick`].

use crate::device::{DeviceSample, DeviceSpecs, SafeForce};
use crate::material::MaterialTable;
use crate::proxy::{CollisionWorld, GodObject, ProxySettings, ProxyUpdate};
use glam::DVec3;
use std::sync::Arc;

/// Device-to-scene mapping (CONTRACTS.md §5): `scene = centre + gain * device`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkspaceMapping {
    /// Scene (world) position of the device's origin.
    pub centre: DVec3,
    /// Scene units per metre of device travel.
    pub gain: f64,
}

/// A mapping that cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("invalid workspace mapping: {0}")]
pub struct MappingError(pub String);

impl WorkspaceMapping {
    /// Checks that the centre is finite and the gain finite and positive.
    pub fn new(centre: DVec3, gain: f64) -> Result<WorkspaceMapping, MappingError> {
        if !centre.is_finite() {
            return Err(MappingError(format!("the centre {centre} is not finite")));
        }
        if !(gain.is_finite() && gain > 0.0) {
            return Err(MappingError(format!("the gain {gain} must be a finite positive number")));
        }
        Ok(WorkspaceMapping { centre, gain })
    }

    /// The gain that maps a device workspace of radius `workspace_radius` (metres) onto a
    /// scene region of radius `scene_radius`.
    pub fn fit(
        centre: DVec3,
        scene_radius: f64,
        workspace_radius: f64,
    ) -> Result<WorkspaceMapping, MappingError> {
        WorkspaceMapping::new(centre, scene_radius / workspace_radius)
    }

    pub fn scene_from_device(&self, device: DVec3) -> DVec3 {
        self.centre + device * self.gain
    }

    pub fn device_from_scene(&self, scene: DVec3) -> DVec3 {
        (scene - self.centre) / self.gain
    }
}

/// Settings of the haptic rendering, beyond materials.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Radius of the proxy sphere (the drawn cursor), in scene units.
    pub proxy_radius: f64,
    /// Apply the materials' friction.
    pub friction: bool,
    /// Force limit below the device's own (N); the device's limit always applies.
    pub max_force: Option<f64>,
    /// Viscous damping along the contact normal while in contact (N s/m of device travel);
    /// clamped to the device's maximum damping.
    pub damping: f64,
    /// Turn the normal part of the force towards the interpolated vertex normal (Morgenbesser
    /// & Srinivasan's force shading) on single-face contacts, when the mesh has normals. Force
    /// shading is not conservative; it is off by default.
    pub force_shading: bool,
    /// Seconds over which the force ramps from zero to full: at start, after the mapping
    /// changes, after a watchdog trip, and when contact begins already deep inside geometry.
    pub ramp_time: f64,
    /// A contact that begins with a force above this fraction of the force limit counts as
    /// "beginning inside geometry" and ramps in.
    pub deep_contact_fraction: f64,
    /// Cut-off of the low-pass filter on the device velocity used for damping (Hz).
    pub velocity_cutoff_hz: f64,
}

impl RenderSettings {
    /// Defaults for a proxy of `proxy_radius` scene units.
    pub fn new(proxy_radius: f64) -> RenderSettings {
        RenderSettings {
            proxy_radius,
            friction: true,
            max_force: None,
            damping: 0.0,
            force_shading: false,
            ramp_time: 0.5,
            deep_contact_fraction: 0.5,
            velocity_cutoff_hz: 100.0,
        }
    }
}

/// Counters of what the safety layer did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SafetyCounters {
    /// Forces that were NaN or infinite and were replaced by zero.
    pub non_finite_forces: u64,
    /// Forces scaled down to the limit.
    pub clamped_forces: u64,
    /// Times the force ramp restarted (start, mapping changes, deep contacts, watchdog).
    pub ramp_restarts: u64,
    /// Device readings that were not finite (ignored; the force went to zero).
    pub invalid_samples: u64,
}

/// The result of one tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickOutput {
    /// Loop time (s).
    pub time: f64,
    /// Device position (device frame, m).
    pub device: DVec3,
    /// Proxy position in the device frame (m).
    pub proxy_device: DVec3,
    /// Proxy position in the scene (world).
    pub proxy_scene: DVec3,
    /// Device position mapped into the scene (the proxy's goal).
    pub goal_scene: DVec3,
    /// The force to command (device frame, N), already safe.
    pub force: SafeForce,
    /// Constraint planes touched this tick (0 = free).
    pub contacts: u32,
    /// The force ramp's current scale (0..=1).
    pub ramp: f64,
    pub buttons: u32,
}

/// See the module documentation.
#[derive(Clone, Debug)]
pub struct HapticRenderer {
    world: Arc<CollisionWorld>,
    base_materials: MaterialTable,
    materials: MaterialTable,
    stiffness_scale: f64,
    specs: DeviceSpecs,
    settings: RenderSettings,
    mapping: WorkspaceMapping,
    proxy: GodObject,
    max_force: f64,
    damping: f64,
    ramp: f64,
    was_in_contact: bool,
    previous_device: Option<DVec3>,
    velocity: DVec3,
    counters: SafetyCounters,
    last: Option<TickOutput>,
}

impl HapticRenderer {
    /// A renderer for `world` with `materials`, limited by the device's `specs`.
    pub fn new(
        world: Arc<CollisionWorld>,
        materials: MaterialTable,
        specs: &DeviceSpecs,
        mapping: WorkspaceMapping,
        settings: RenderSettings,
    ) -> HapticRenderer {
        let device_max =
            if specs.max_force.is_finite() && specs.max_force > 0.0 { specs.max_force } else { 0.0 };
        let max_force = settings.max_force.map_or(device_max, |m| m.clamp(0.0, device_max));
        let damping = settings.damping.clamp(0.0, specs.max_damping.max(0.0));
        let proxy =
            GodObject::new(ProxySettings { radius: settings.proxy_radius, friction: settings.friction });
        HapticRenderer {
            world,
            materials: materials.clone(),
            base_materials: materials,
            stiffness_scale: 1.0,
            specs: specs.clone(),
            settings,
            mapping,
            proxy,
            max_force,
            damping,
            ramp: 0.0,
            was_in_contact: false,
            previous_device: None,
            velocity: DVec3::ZERO,
            counters: SafetyCounters::default(),
            last: None,
        }
    }

    pub fn world(&self) -> &Arc<CollisionWorld> {
        &self.world
    }

    pub fn mapping(&self) -> WorkspaceMapping {
        self.mapping
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The force limit in effect (N).
    pub fn max_force(&self) -> f64 {
        self.max_force
    }

    pub fn counters(&self) -> SafetyCounters {
        self.counters
    }

    /// The proxy's position in the scene (world), once the first tick has placed it.
    pub fn proxy_scene(&self) -> Option<DVec3> {
        self.proxy.is_initialised().then(|| self.world.mesh().world_from_local(self.proxy.position()))
    }

    /// The last tick's output.
    pub fn last_output(&self) -> Option<&TickOutput> {
        self.last.as_ref()
    }

    /// Changes the mapping at run time. The proxy stays where it is in the scene; the force
    /// ramps in again, since the goal may have jumped.
    pub fn set_mapping(&mut self, mapping: WorkspaceMapping) {
        if mapping != self.mapping {
            self.mapping = mapping;
            self.restart_ramp();
        }
    }

    /// Scales every material's stiffness (clamped to the device's maximum).
    pub fn set_stiffness_scale(&mut self, scale: f64) {
        let scale = if scale.is_finite() { scale.max(0.0) } else { 1.0 };
        if scale != self.stiffness_scale {
            self.stiffness_scale = scale;
            self.materials = self.base_materials.with_stiffness_scaled(scale, self.specs.max_stiffness);
        }
    }

    /// Restarts the force ramp from zero.
    pub fn restart_ramp(&mut self) {
        self.ramp = 0.0;
        self.counters.ramp_restarts += 1;
    }

    /// Computes one tick at loop time `time`, `dt` seconds after the previous one.
    pub fn tick(&mut self, time: f64, sample: &DeviceSample, dt: f64) -> TickOutput {
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        if !sample.position.is_finite() {
            // A bad reading: hold the proxy, send no force, ramp in again afterwards.
            self.counters.invalid_samples += 1;
            self.restart_ramp();
            let mut out = self.last.unwrap_or(TickOutput {
                time,
                device: DVec3::ZERO,
                proxy_device: DVec3::ZERO,
                proxy_scene: self.mapping.centre,
                goal_scene: self.mapping.centre,
                force: SafeForce::ZERO,
                contacts: 0,
                ramp: 0.0,
                buttons: sample.buttons,
            });
            out.time = time;
            out.force = SafeForce::ZERO;
            out.ramp = 0.0;
            self.last = Some(out);
            return out;
        }
        let world = Arc::clone(&self.world);
        let mesh = world.mesh();
        let origin = mesh.origin();
        // Local goal: (centre - origin) + gain * device keeps precision far from the origin.
        let goal_local = (self.mapping.centre - origin) + sample.position * self.mapping.gain;
        if !self.proxy.is_initialised() {
            self.proxy.reset(&self.world, goal_local);
            self.restart_ramp();
        }
        let update = self.proxy.update(&self.world, &self.materials, goal_local);

        // Device velocity, low-pass filtered, for damping.
        if let Some(previous) = self.previous_device
            && dt > 0.0
        {
            let raw = (sample.position - previous) / dt;
            let alpha = 1.0 - (-2.0 * std::f64::consts::PI * self.settings.velocity_cutoff_hz * dt).exp();
            self.velocity += (raw - self.velocity) * alpha;
        }
        self.previous_device = Some(sample.position);

        let force = self.contact_force(&update, goal_local);
        let in_contact = update.in_contact();
        if in_contact
            && !self.was_in_contact
            && force.length() > self.settings.deep_contact_fraction * self.max_force
        {
            self.restart_ramp();
        }
        self.was_in_contact = in_contact;
        let scaled = force * self.ramp;
        if self.settings.ramp_time > 0.0 {
            self.ramp = (self.ramp + dt / self.settings.ramp_time).min(1.0);
        } else {
            self.ramp = 1.0;
        }
        let (safe, correction) = SafeForce::limit(scaled, self.max_force);
        self.counters.non_finite_forces += correction.non_finite as u64;
        self.counters.clamped_forces += correction.clamped as u64;

        let proxy_scene = mesh.world_from_local(update.position);
        let out = TickOutput {
            time,
            device: sample.position,
            proxy_device: sample.position + (update.position - goal_local) / self.mapping.gain,
            proxy_scene,
            goal_scene: mesh.world_from_local(goal_local),
            force: safe,
            contacts: update.contact_count() as u32,
            ramp: self.ramp,
            buttons: sample.buttons,
        };
        self.last = Some(out);
        out
    }

    /// The spring from device to proxy, with damping and force shading, before ramp and limit.
    fn contact_force(&self, update: &ProxyUpdate, goal_local: DVec3) -> DVec3 {
        let Some(primary) = update.primary() else {
            return DVec3::ZERO;
        };
        let mesh = self.world.mesh();
        let material = self.materials.get(mesh.material(primary.triangle as usize));
        // Device-frame displacement from the device to the proxy.
        let displacement = (update.position - goal_local) / self.mapping.gain;
        let mut force = displacement * material.stiffness;
        let normal = primary.normal;
        if self.damping > 0.0 {
            force -= normal * (self.damping * self.velocity.dot(normal));
            // Damping may slow a release but never pull the hand into the surface.
            let push = force.dot(normal);
            if push < 0.0 {
                force -= normal * push;
            }
        }
        if self.settings.force_shading
            && update.contact_count() == 1
            && let Some(normals) = mesh.vertex_normals(primary.triangle as usize)
        {
            let b = primary.barycentric;
            let shaded =
                (normals[0].as_dvec3() * b.x + normals[1].as_dvec3() * b.y + normals[2].as_dvec3() * b.z)
                    .normalize_or_zero();
            if shaded != DVec3::ZERO {
                let shaded = if shaded.dot(normal) < 0.0 { -shaded } else { shaded };
                let push = force.dot(normal);
                force += (shaded - normal) * push;
            }
        }
        force
    }
}

//! Per-light bookkeeping of a camera sample for the sidecar's light layers (docs/sidecar.md).
//!
//! The integrators stay as they are apart from a few calls into this module at their primary
//! vertex: [`primary_vertex`] when a camera ray's first surface is shaded, [`direct`] from
//! [`crate::integrators::direct_from_light`], [`end_primary`] once the primary vertex's direct
//! light is estimated, and [`direct_via_bsdf`] where a path tracer's BSDF sample from the
//! primary vertex hits an emitter; [`primary_reflection`] (or [`primary_reflection_weighted`])
//! with what the primary vertex's specular reflection brought. Everything is recorded in a thread-local tally that only a
//! layered render (`layered_render`) arms, so a render without layers pays one
//! thread-local flag test per call and nothing else.

use crate::bsdf::{Bsdf, Lobe, LobeFlags, TransportMode};
use crate::integrators::surface_terms;
use crate::materials::Material;
use crate::world::{SurfaceInteraction, World};
use glam::Vec3;
use std::cell::{Cell, RefCell};

/// What one camera sample contributed, split as the layers are.
#[derive(Clone, Debug, Default)]
pub(crate) struct Tally {
    /// Direct light at the primary vertex, per light of the world (`World::lights` order).
    pub direct: Vec<Vec3>,
    /// Emission and ambient terms seen at the primary vertex.
    pub emission: Vec3,
    /// Shading normal at the primary vertex, facing the camera.
    pub normal: Vec3,
    /// Diffuse albedo at the primary vertex.
    pub albedo: Vec3,
    /// The weight of the primary vertex's specular reflection (times its path weight).
    pub reflectance: Vec3,
    /// The radiance that specular reflection brought, weighted (a part of the sample's colour).
    pub reflected: Vec3,
    /// The weight `Ks` of the primary vertex's Blinn lobe (times its path weight).
    pub glossy: Vec3,
    /// The Blinn exponent times the largest channel of `glossy` (its weight in the pixel's
    /// mean exponent).
    pub glossy_exponent: f32,
    /// The primary vertex's path weight (stochastic opacity), applied to its direct light.
    scale: Vec3,
}

thread_local! {
    /// A layered sample is being traced on this thread.
    static ARMED: Cell<bool> = const { Cell::new(false) };
    /// The integrator is estimating the primary vertex's direct light.
    static AT_PRIMARY: Cell<bool> = const { Cell::new(false) };
    static TALLY: RefCell<Tally> = RefCell::new(Tally::default());
}

/// Starts recording one camera sample on this thread for a world of `light_count` lights.
pub(crate) fn arm(light_count: usize) {
    TALLY.with_borrow_mut(|t| {
        t.direct.clear();
        t.direct.resize(light_count, Vec3::ZERO);
        t.emission = Vec3::ZERO;
        t.normal = Vec3::ZERO;
        t.albedo = Vec3::ZERO;
        t.reflectance = Vec3::ZERO;
        t.reflected = Vec3::ZERO;
        t.glossy = Vec3::ZERO;
        t.glossy_exponent = 0.0;
        t.scale = Vec3::ZERO;
    });
    AT_PRIMARY.set(false);
    ARMED.set(true);
}

/// Stops recording and hands the sample's tally to `read`.
pub(crate) fn disarm<R>(read: impl FnOnce(&Tally) -> R) -> R {
    ARMED.set(false);
    AT_PRIMARY.set(false);
    TALLY.with_borrow(read)
}

/// The integrator shades the camera ray's first surface `si` (reached with path weight
/// `weight`); its direct light estimates follow until [`end_primary`].
#[inline]
pub fn primary_vertex(
    world: &World,
    si: &SurfaceInteraction,
    material: &Material,
    bsdf: &Bsdf,
    weight: Vec3,
) {
    if !ARMED.get() {
        return;
    }
    // Integrators estimate direct light exactly where a non-specular lobe is.
    AT_PRIMARY.set(!bsdf.is_black() && bsdf.has_non_specular());
    let mut emission = surface_terms(world, si, material);
    if let Some(e) = si.emitter {
        emission += world.lights[e as usize].emitted(si.ng, si.wo);
    }
    let albedo = bsdf.lobes().iter().map(|l| if let Lobe::Lambert { r } = l { *r } else { Vec3::ZERO }).sum();
    let normal = if si.ns.dot(si.wo) < 0.0 { -si.ns } else { si.ns };
    // The weight of the mirror direction, whichever branch a path tracer then samples.
    let reflectance: Vec3 = bsdf
        .specular_directions(si.wo, TransportMode::Radiance)
        .into_iter()
        .filter(|(_, _, flags)| flags.intersects(LobeFlags::REFLECTION))
        .map(|(_, w, _)| w)
        .sum();
    // The glossy lobe (materials have one at most) for the viewer's glossy reflections.
    let (ks, exponent) = bsdf
        .lobes()
        .iter()
        .find_map(|l| if let Lobe::Blinn { ks, exponent } = l { Some((*ks, *exponent)) } else { None })
        .unwrap_or((Vec3::ZERO, 0.0));
    TALLY.with_borrow_mut(|t| {
        t.scale = weight;
        t.emission = emission * weight;
        t.normal = normal;
        t.albedo = albedo;
        t.reflectance = reflectance * weight;
        t.glossy = ks * weight;
        t.glossy_exponent = exponent * t.glossy.max_element();
    });
}

/// The primary vertex's direct light is estimated: later estimates are indirect.
#[inline]
pub fn end_primary() {
    AT_PRIMARY.set(false);
}

/// `value`: light `light`'s direct contribution at the vertex being shaded, before its path
/// weight. Recorded only at the primary vertex of a layered sample.
#[inline]
pub fn direct(light: u32, value: Vec3) {
    if AT_PRIMARY.get() {
        TALLY.with_borrow_mut(|t| {
            if let Some(d) = t.direct.get_mut(light as usize) {
                *d += t.scale * value;
            }
        });
    }
}

/// `value`: the radiance the primary vertex's specular reflection brings, times the direction's
/// weight and before the vertex's path weight (integrators that follow every specular
/// direction).
#[inline]
pub fn primary_reflection(value: Vec3) {
    if ARMED.get() {
        TALLY.with_borrow_mut(|t| t.reflected += t.scale * value);
    }
}

/// `value` (path weight included): what a path that left the primary vertex by its specular
/// reflection added to the sample (integrators that sample one direction).
#[inline]
pub fn primary_reflection_weighted(value: Vec3) {
    if ARMED.get() {
        TALLY.with_borrow_mut(|t| t.reflected += value);
    }
}

/// `value`: the environment seen by a camera ray that leaves the scene (emission seen by the
/// camera, as the background is).
#[inline]
pub fn camera_escaped(value: Vec3) {
    if ARMED.get() {
        TALLY.with_borrow_mut(|t| t.emission += value);
    }
}

/// `value` (path weight included): emitter `light` reached by the BSDF sample taken at the
/// primary vertex, the MIS partner of its light sample.
#[inline]
pub fn direct_via_bsdf(light: u32, value: Vec3) {
    if ARMED.get() {
        TALLY.with_borrow_mut(|t| {
            if let Some(d) = t.direct.get_mut(light as usize) {
                *d += value;
            }
        });
    }
}

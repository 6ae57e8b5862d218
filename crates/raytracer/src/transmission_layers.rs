//! The primary hit's transmitted chain for the sidecar's transmission layers (docs/sidecar.md):
//! from a camera ray's first surface, the chain follows the specular transmission of each
//! surface it meets (or, at a dielectric that reflects totally, that reflection) until its exit
//! ray meets a surface that does not transmit specularly. Its weight, the radiance its exit ray
//! brought and the exit ray itself are what a viewer needs to show a live object seen through
//! glass in place of what it hides.
//!
//! Integrators that follow every specular direction call [`vertex`] at each surface they shade
//! and wrap each specular recursion in [`branch`] and [`after_branch`]; the path tracer, which
//! samples one direction, calls [`path_vertex`] and [`path_end`]. As with
//! [`crate::light_layers`], nothing is recorded unless a layered render armed this thread.

use crate::bsdf::{Bsdf, Lobe, LobeFlags, SpecularDirections};
use glam::Vec3;
use std::cell::{Cell, RefCell};

/// The distance recorded for an exit ray that leaves the scene.
pub const ESCAPED_DISTANCE: f32 = 1e30;

/// What one camera sample's transmitted chain contributed.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ChainTally {
    /// The chain's weight (path weights included); zero when the primary hit does not transmit
    /// or the chain was cut short.
    pub transmittance: Vec3,
    /// The radiance the exit ray brought, times `transmittance` (a part of the sample's colour).
    pub transmitted: Vec3,
    /// The averaging weight of the exit ray's values: `transmittance`'s largest channel.
    pub weight: f32,
    /// The exit ray's origin, direction and distance to what it met, each times `weight`.
    pub origin: Vec3,
    pub direction: Vec3,
    pub distance: f32,
}

/// The chain being followed by the sample traced on this thread.
#[derive(Clone, Copy, Debug, Default)]
struct Chain {
    /// The ray being traced is the chain's: set by the vertex that spawns it, cleared by the
    /// vertex it reaches (still set after the recursion: the ray left the scene).
    following: bool,
    /// The weight of the chain's ray being traced.
    throughput: Vec3,
    origin: Vec3,
    direction: Vec3,
    /// The chain's ray ended at a surface this far along it: set by that surface's vertex,
    /// taken by the vertex that spawned the ray.
    ended: Option<f32>,
}

thread_local! {
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static CHAIN: Cell<Chain> = Cell::new(Chain::default());
    static TALLY: RefCell<ChainTally> = RefCell::new(ChainTally::default());
}

/// Starts recording one camera sample on this thread.
pub(crate) fn arm() {
    TALLY.with_borrow_mut(|t| *t = ChainTally::default());
    CHAIN.set(Chain::default());
    ARMED.set(true);
}

/// Stops recording and hands the sample's tally to `read`.
pub(crate) fn disarm<R>(read: impl FnOnce(&ChainTally) -> R) -> R {
    ARMED.set(false);
    TALLY.with_borrow(read)
}

/// Which of `directions` (a vertex's specular directions, in order) continues a transmitted
/// chain through a surface with `bsdf`, with that direction and its lobe: its specular
/// transmission, or the total internal reflection of a dielectric; `None` where the surface
/// has a non-specular lobe or neither.
pub fn continuing_direction(bsdf: &Bsdf, directions: SpecularDirections) -> Option<(usize, Vec3, LobeFlags)> {
    if bsdf.is_black() || bsdf.has_non_specular() {
        return None;
    }
    let mut live = directions.into_iter().enumerate().filter(|(_, (_, w, _))| *w != Vec3::ZERO);
    if let Some((k, (dir, _, flags))) =
        live.clone().find(|(_, (_, _, f))| f.intersects(LobeFlags::TRANSMISSION))
    {
        return Some((k, dir, flags));
    }
    // A dielectric that transmits but gives a reflection alone reflects totally.
    let transmits = bsdf.lobes().iter().any(|l| matches!(l, Lobe::Dielectric { t, .. } if *t != Vec3::ZERO));
    match (live.next(), live.next()) {
        (Some((k, (dir, _, flags))), None) if transmits && flags.intersects(LobeFlags::REFLECTION) => {
            Some((k, dir, flags))
        }
        _ => None,
    }
}

/// A vertex at `depth` at point `p` whose specular directions are `directions`: returns which
/// of them continues the chain when the vertex is on it. A vertex on the chain that does not
/// continue it ends the chain's exit ray here.
pub fn vertex(depth: u32, p: Vec3, bsdf: &Bsdf, directions: SpecularDirections) -> Option<usize> {
    if !ARMED.get() {
        return None;
    }
    let mut chain = CHAIN.get();
    let on = depth == 0 || chain.following;
    chain.following = false;
    if depth == 0 {
        chain = Chain { throughput: Vec3::ONE, ..Chain::default() };
    }
    let next = if on { continuing_direction(bsdf, directions).map(|(k, _, _)| k) } else { None };
    if on && next.is_none() && depth > 0 {
        chain.ended = Some((p - chain.origin).length());
    }
    CHAIN.set(chain);
    next
}

/// Whether a branch recursion continues the chain, and the chain's state to restore after it.
#[derive(Clone, Copy, Debug)]
pub struct Link(Option<Chain>);

/// Before recursing along specular direction `dir` from point `p` (weight `w` times the
/// vertex's path weight `weight`): the chain follows it when `continues`.
pub fn branch(continues: bool, p: Vec3, dir: Vec3, w: Vec3, weight: Vec3) -> Link {
    if !continues || !ARMED.get() {
        return Link(None);
    }
    let before = CHAIN.get();
    CHAIN.set(Chain {
        following: true,
        throughput: before.throughput * w * weight,
        origin: p,
        direction: dir,
        ended: None,
    });
    Link(Some(before))
}

/// After the recursion of `link`'s branch returned `radiance`: records the chain when its ray
/// ended there (at a surface, or leaving the scene).
pub fn after_branch(link: Link, radiance: Vec3) {
    let Link(Some(before)) = link else { return };
    let chain = CHAIN.get();
    let ended = if chain.following { Some(ESCAPED_DISTANCE) } else { chain.ended };
    CHAIN.set(Chain { following: false, ended: None, ..before });
    if let Some(distance) = ended {
        record(chain.throughput, chain.throughput * radiance, chain.origin, chain.direction, distance);
    }
}

fn record(transmittance: Vec3, transmitted: Vec3, origin: Vec3, direction: Vec3, distance: f32) {
    let m = transmittance.max_element();
    if !(m > 0.0) || !transmitted.is_finite() {
        return;
    }
    TALLY.with_borrow_mut(|t| {
        t.transmittance += transmittance;
        t.transmitted += transmitted;
        t.weight += m;
        t.origin += m * origin;
        t.direction += m * direction;
        t.distance += m * distance;
    });
}

/// The path tracer's chain: while the sampled path follows the transmitted chain, its current
/// ray, the path weight it was spawned with (the chain's weight divided by the probability of
/// having sampled it, so that its mean is the chain's weight) and the sample's colour then.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathChain {
    on: bool,
    /// The direction that continues the chain at the vertex just reached (not sampled yet).
    pending: Option<(Vec3, LobeFlags)>,
    origin: Vec3,
    direction: Vec3,
    beta: Vec3,
    colour_before: Vec3,
    /// The distance along the exit ray to the surface it met, once it met one.
    ended: Option<f32>,
}

/// The path tracer reached point `p` at `depth` (seen from `wo`), a surface with `bsdf`, before
/// sampling it: a surface on the chain that does not continue it ends the exit ray there.
pub fn path_reached(chain: &mut PathChain, depth: u32, p: Vec3, wo: Vec3, bsdf: &Bsdf) {
    chain.pending = None;
    if !ARMED.get() || chain.ended.is_some() || (depth > 0 && !chain.on) {
        return;
    }
    let directions = bsdf.specular_directions(wo, crate::bsdf::TransportMode::Radiance);
    match continuing_direction(bsdf, directions) {
        Some((_, dir, flags)) => chain.pending = Some((dir, flags)),
        None if depth > 0 => {
            chain.ended = Some((p - chain.origin).length());
            chain.on = false;
        }
        None => {}
    }
}

/// The path tracer sampled direction `wi` (`flags`) at point `p` and goes on with path weight
/// `beta` (Russian roulette's included) and colour so far `l`: the chain follows when `wi` is
/// the direction that continues it; otherwise the sample left it.
pub fn path_sampled(chain: &mut PathChain, p: Vec3, wi: Vec3, flags: LobeFlags, beta: Vec3, l: Vec3) {
    let Some((dir, chain_flags)) = chain.pending.take() else {
        chain.on = false;
        return;
    };
    let same_lobe = flags.contains(LobeFlags::SPECULAR)
        && flags.intersects(chain_flags & (LobeFlags::TRANSMISSION | LobeFlags::REFLECTION));
    if same_lobe && wi.dot(dir) > 1.0 - 1e-4 {
        *chain = PathChain {
            on: true,
            pending: None,
            origin: p,
            direction: wi,
            beta,
            colour_before: l,
            ended: None,
        };
    } else {
        chain.on = false;
    }
}

/// The path tracer's sample ended with colour `l`: records the chain when its exit ray met a
/// surface or left the scene (a path cut short on the chain records nothing).
pub fn path_end(chain: &PathChain, l: Vec3) {
    if !ARMED.get() {
        return;
    }
    let distance = match (chain.ended, chain.on, chain.pending) {
        (Some(d), _, _) => d,
        (None, true, None) => ESCAPED_DISTANCE,
        _ => return,
    };
    record(chain.beta, l - chain.colour_before, chain.origin, chain.direction, distance);
}

//! Transformation motion in the world: which shapes and instances move while the shutter is
//! open, their keys in render space at shutter fractions, and boxes that hold them throughout.

use super::placement::transformed_box;
use glam::{DMat4, DVec3, Vec3};
use rib_parser::motion::TransformMotion;
use rib_parser::scene::Scene;
use std::sync::Arc;

/// The render-space motion of a shape or instance over the shutter interval (`Shutter open
/// close`, key times mapped to shutter fractions as [`super::Ray::time`] uses them), or `None`
/// when it does not move while the shutter is open (no motion, or `Shutter` absent or closed:
/// RenderMan's default `Shutter 0 0` has no blur). Keys outside the interval are kept, so
/// motion between a key before open and one after close is interpolated correctly.
pub(super) fn shutter_motion(
    scene: &Scene,
    motion: &Option<Arc<TransformMotion>>,
    render_from_world: &DMat4,
) -> Option<Arc<TransformMotion>> {
    let motion = motion.as_ref()?;
    let (open, close) = scene.render.shutter?;
    let (open, close) = (f64::from(open), f64::from(close));
    if !(close > open) {
        return None;
    }
    let moving = motion.retimed(|t| (t - open) / (close - open))?.map(|m| *render_from_world * m)?;
    // Static over the interval when every key inside it, and the ends, are equal.
    let inside: Vec<DMat4> = std::iter::once(moving.at(0.0))
        .chain(
            moving
                .times()
                .iter()
                .zip(moving.matrices())
                .filter(|(t, _)| **t > 0.0 && **t < 1.0)
                .map(|(_, m)| *m),
        )
        .chain(std::iter::once(moving.at(1.0)))
        .collect();
    if inside.iter().all(|m| *m == inside[0])
        || !inside.iter().all(|m| m.is_finite() && m.determinant() != 0.0)
    {
        return None;
    }
    Some(Arc::new(moving))
}

/// The camera's motion over the shutter as a map of render space: at shutter fraction `t`,
/// the matrix that carries a camera ray at shutter open (render space, whose origin is the eye
/// at shutter open) to the same camera ray at `t`:
/// `render_from_world * world_from_camera(t) * camera_from_world(open) * world_from_render`.
/// `None` when the camera does not move while the shutter is open.
pub(super) fn camera_shutter_motion(
    scene: &Scene,
    render_from_world: &DMat4,
) -> Option<Arc<TransformMotion>> {
    let camera_from_world_open = scene.camera.camera_from_world;
    let world_from_render = render_from_world.inverse();
    let world_from_camera = scene.render.camera_motion.as_ref()?.map(|m| m.inverse())?;
    let moving = shutter_motion(scene, &Some(Arc::new(world_from_camera)), render_from_world)?;
    moving.map(|m| m * camera_from_world_open * world_from_render).map(Arc::new)
}

/// A box holding `[lo, hi]` wherever `motion` carries it during the shutter: the transformed
/// boxes at 64 steps per key interval (and at open and close), grown by the farthest any
/// corner moves in one step, which bounds how far the path between two steps strays.
pub(super) fn motion_box(motion: &TransformMotion, lo: DVec3, hi: DVec3) -> (Vec3, Vec3) {
    const STEPS: usize = 64;
    let mut times = vec![0.0f64];
    times.extend(motion.times().iter().copied().filter(|t| *t > 0.0 && *t < 1.0));
    times.push(1.0);
    let corners: Vec<DVec3> = (0..8)
        .map(|k| DVec3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][k >> 1 & 1], [lo.z, hi.z][k >> 2]))
        .collect();
    let mut box_lo = DVec3::splat(f64::INFINITY);
    let mut box_hi = DVec3::splat(f64::NEG_INFINITY);
    let mut step_max = 0.0f64;
    let mut previous: Option<Vec<DVec3>> = None;
    for w in times.windows(2) {
        for s in 0..=STEPS {
            let t = w[0] + (w[1] - w[0]) * s as f64 / STEPS as f64;
            let m = motion.at(t);
            let placed: Vec<DVec3> = corners.iter().map(|c| m.transform_point3(*c)).collect();
            for p in &placed {
                box_lo = box_lo.min(*p);
                box_hi = box_hi.max(*p);
            }
            if let Some(prev) = &previous {
                for (a, b) in prev.iter().zip(&placed) {
                    step_max = step_max.max(a.distance(*b));
                }
            }
            previous = Some(placed);
        }
    }
    let pad = DVec3::splat(step_max);
    let (l, h) = (box_lo - pad, box_hi + pad);
    // Rounded outward to f32 as `transformed_box` does.
    transformed_box(&DMat4::IDENTITY, l, h)
}

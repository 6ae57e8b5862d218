//! Which lights can reach a shading point at all: a conservative test made once per light and
//! point before any light sample or shadow ray. A light is skipped when the point lies behind
//! a one-sided planar emitter, outside a spot light's cone, or when the whole light lies below
//! the horizon of a surface that only reflects.

use crate::lights::{EmitterShape, Light};
use glam::{DMat4, DVec3, Vec3};

/// Why a light cannot reach a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CullReason {
    /// The point is behind a one-sided planar area light.
    BehindEmitter,
    /// The point is outside a spot light's cone.
    OutsideSpotCone,
    /// The light lies entirely below the surface's horizon.
    BelowHorizon,
}

impl CullReason {
    pub const ALL: [CullReason; 3] =
        [CullReason::BehindEmitter, CullReason::OutsideSpotCone, CullReason::BelowHorizon];

    pub fn describe(&self) -> &'static str {
        match self {
            CullReason::BehindEmitter => "behind a one-sided area light",
            CullReason::OutsideSpotCone => "outside a spot light's cone",
            CullReason::BelowHorizon => "light entirely below the surface's horizon",
        }
    }
}

/// What the test needs to know about one light.
#[derive(Clone, Debug)]
pub(crate) enum LightBounds {
    Point {
        position: Vec3,
    },
    Spot {
        position: Vec3,
        axis: Vec3,
        cos_outside: f32,
    },
    Distant {
        direction: Vec3,
    },
    Area {
        /// The emitter's plane `(point, front normal)` when it is planar and one-sided.
        one_sided_plane: Option<(Vec3, Vec3)>,
        /// The corners of a box around the emitter.
        corners: [Vec3; 8],
    },
    /// No test (ambient, or a shape without usable bounds).
    Unknown,
}

fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

fn quadric_corners(m: &DMat4, lo: DVec3, hi: DVec3) -> [Vec3; 8] {
    let mut bmin = DVec3::splat(f64::INFINITY);
    let mut bmax = DVec3::splat(f64::NEG_INFINITY);
    for i in 0..8 {
        let c = DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let p = m.transform_point3(c);
        bmin = bmin.min(p);
        bmax = bmax.max(p);
    }
    // Widen by a relative margin so that rounding never moves a corner inward.
    let pad = (bmax - bmin) * 1e-6 + bmin.abs().max(bmax.abs()) * 1e-6;
    box_corners((bmin - pad).as_vec3(), (bmax + pad).as_vec3())
}

impl LightBounds {
    pub fn new(light: &Light) -> LightBounds {
        match light {
            Light::Point { position, .. } => LightBounds::Point { position: *position },
            Light::Spot { position, frame, cos_outside, .. } => {
                LightBounds::Spot { position: *position, axis: frame.z, cos_outside: *cos_outside }
            }
            Light::Distant { direction, .. } => LightBounds::Distant { direction: *direction },
            Light::Ambient { .. } | Light::Environment(_) => LightBounds::Unknown,
            Light::Area { shape, two_sided, .. } => match shape {
                EmitterShape::Triangles { triangles, normals, .. } => {
                    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                    for t in triangles {
                        for v in t {
                            lo = lo.min(*v);
                            hi = hi.max(*v);
                        }
                    }
                    if !(lo.is_finite() && hi.is_finite()) {
                        return LightBounds::Unknown;
                    }
                    let extent = (hi - lo).length();
                    let pad = Vec3::splat(extent * 1e-6) + lo.abs().max(hi.abs()) * 1e-6;
                    let (lo, hi) = (lo - pad, hi + pad);
                    let plane = if *two_sided || triangles.is_empty() {
                        None
                    } else {
                        let n0 = normals[0];
                        let p0 = triangles[0][0];
                        let planar = normals.iter().all(|n| n.dot(n0) > 1.0 - 1e-6)
                            && triangles
                                .iter()
                                .flatten()
                                .all(|v| (*v - p0).dot(n0).abs() <= 1e-6 * extent.max(f32::MIN_POSITIVE));
                        planar.then_some((p0, n0))
                    };
                    LightBounds::Area { one_sided_plane: plane, corners: box_corners(lo, hi) }
                }
                EmitterShape::Quadric { quadric, render_from_object, .. } => LightBounds::Area {
                    one_sided_plane: None,
                    corners: quadric_corners(render_from_object, quadric.bounds_min, quadric.bounds_max),
                },
            },
        }
    }

    /// Whether the light cannot reach point `p`; `n` is the surface's geometric normal on the
    /// side it reflects to when `reflect_only` (every non-specular lobe only reflects).
    pub fn cull(&self, p: Vec3, p_error: Vec3, n: Vec3, reflect_only: bool) -> Option<CullReason> {
        // A margin of the point's own error bound (and a relative one) keeps the test
        // conservative for points on the light's plane.
        let margin = p_error.length() + p.abs().max_element() * 1e-6;
        match self {
            LightBounds::Point { position } => {
                if reflect_only && (*position - p).dot(n) < -margin {
                    return Some(CullReason::BelowHorizon);
                }
                None
            }
            LightBounds::Spot { position, axis, cos_outside } => {
                let d = p - *position;
                let len = d.length();
                if len > margin && d.dot(*axis) < *cos_outside * len - margin {
                    return Some(CullReason::OutsideSpotCone);
                }
                if reflect_only && (*position - p).dot(n) < -margin {
                    return Some(CullReason::BelowHorizon);
                }
                None
            }
            LightBounds::Distant { direction } => {
                if reflect_only && (-*direction).dot(n) <= 0.0 {
                    return Some(CullReason::BelowHorizon);
                }
                None
            }
            LightBounds::Area { one_sided_plane, corners } => {
                if let Some((p0, n0)) = one_sided_plane
                    && (p - *p0).dot(*n0) < -margin
                {
                    return Some(CullReason::BehindEmitter);
                }
                if reflect_only && corners.iter().all(|c| (*c - p).dot(n) < -margin) {
                    return Some(CullReason::BelowHorizon);
                }
                None
            }
            LightBounds::Unknown => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Distribution1D;

    fn quad(two_sided: bool) -> Light {
        // A unit square at y = 1 facing down.
        let t = vec![
            [Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 1.0)],
            [Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 1.0), Vec3::new(0.0, 1.0, 1.0)],
        ];
        Light::Area {
            shape: EmitterShape::Triangles {
                triangles: t,
                normals: vec![-Vec3::Y, -Vec3::Y],
                by_area: Distribution1D::new(&[0.5, 0.5]),
                area: 1.0,
            },
            radiance: Vec3::ONE,
            two_sided,
        }
    }

    #[test]
    fn area_light_back_and_horizon() {
        let b = LightBounds::new(&quad(false));
        let e = Vec3::ZERO;
        // Above the light (its back): culled; below it: lit; a floor facing down: below horizon.
        assert_eq!(b.cull(Vec3::new(0.5, 2.0, 0.5), e, -Vec3::Y, true), Some(CullReason::BehindEmitter));
        assert_eq!(b.cull(Vec3::new(0.5, 0.0, 0.5), e, Vec3::Y, true), None);
        assert_eq!(b.cull(Vec3::new(0.5, 0.0, 0.5), e, -Vec3::Y, true), Some(CullReason::BelowHorizon));
        // Transmitting surfaces see both sides.
        assert_eq!(b.cull(Vec3::new(0.5, 0.0, 0.5), e, -Vec3::Y, false), None);
        // Two-sided: never behind.
        let b2 = LightBounds::new(&quad(true));
        assert_eq!(b2.cull(Vec3::new(0.5, 2.0, 0.5), e, -Vec3::Y, true), None);
        // A point in the light's own plane is not culled (conservative).
        assert_eq!(b.cull(Vec3::new(3.0, 1.0, 0.5), e, -Vec3::X, true), None);
    }

    #[test]
    fn spot_cone() {
        let s = Light::spot(Vec3::ZERO, Vec3::Z, Vec3::ONE, 30f32.to_radians(), 5f32.to_radians(), 1.0);
        let b = LightBounds::new(&s);
        assert_eq!(b.cull(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, -Vec3::Z, true), None);
        assert_eq!(
            b.cull(Vec3::new(2.0, 0.0, 1.0), Vec3::ZERO, -Vec3::X, true),
            Some(CullReason::OutsideSpotCone)
        );
        assert_eq!(
            b.cull(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, Vec3::Z, true),
            Some(CullReason::BelowHorizon)
        );
    }
}

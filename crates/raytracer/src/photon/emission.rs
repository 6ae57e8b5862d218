//! Where a photon starts: its first ray and power from the light's own emission distribution,
//! or aimed at the specular shapes so that caustic paths are not wasted on the rest of the scene.

use crate::lights::Light;
use glam::{Vec2, Vec3};

/// At most this many aiming spheres; more specular shapes share one sphere around them all
/// (aiming costs a cone per sphere for every photon).
pub(super) const MAX_AIM_SPHERES: usize = 32;

/// Bounding spheres of the specular shapes, at which caustic photons are aimed (Jensen's
/// projection maps, with exact cones instead of a grid of directions): a caustic path starts
/// with a specular hit, so emission toward anything else is wasted.
#[derive(Clone, Debug, Default)]
pub(crate) struct Aim {
    pub spheres: Vec<(Vec3, f32)>,
}

/// The cone of directions from a point toward one sphere.
#[derive(Clone, Copy, Debug)]
struct Cone {
    axis: Vec3,
    /// Cosine of the half-angle; -1 when the point is inside the sphere (all directions).
    cos_max: f32,
    /// `1 - cos_max`, accurate for small cones.
    one_minus_cos: f32,
}

impl Cone {
    fn solid_angle(&self) -> f32 {
        2.0 * std::f32::consts::PI * self.one_minus_cos
    }

    fn contains(&self, dir: Vec3) -> bool {
        self.cos_max <= -1.0 || dir.dot(self.axis) >= self.cos_max
    }
}

impl Aim {
    /// Spheres around the given render-space boxes (boxes that are not finite are skipped).
    pub fn from_boxes(boxes: &[(Vec3, Vec3)]) -> Aim {
        let sphere = |lo: Vec3, hi: Vec3| {
            // Rounding of the centre is covered by a margin relative to the coordinates' size.
            let margin = 1e-6 * lo.abs().max(hi.abs()).max_element();
            let r = (hi - lo).length() * 0.5 * (1.0 + 1e-5) + margin;
            ((lo + hi) * 0.5, r.max(f32::MIN_POSITIVE))
        };
        let finite: Vec<(Vec3, Vec3)> = boxes
            .iter()
            .copied()
            .filter(|(lo, hi)| lo.is_finite() && hi.is_finite() && lo.cmple(*hi).all())
            .collect();
        let spheres = if finite.len() > MAX_AIM_SPHERES {
            let lo = finite.iter().fold(Vec3::INFINITY, |a, b| a.min(b.0));
            let hi = finite.iter().fold(Vec3::NEG_INFINITY, |a, b| a.max(b.1));
            vec![sphere(lo, hi)]
        } else {
            finite.iter().map(|&(lo, hi)| sphere(lo, hi)).collect()
        };
        Aim { spheres }
    }

    /// The cone of directions from `p` toward sphere `(c, r)`; all directions when `p` is inside.
    fn cone(c: Vec3, r: f32, p: Vec3) -> Cone {
        let d = c - p;
        let dist2 = d.length_squared();
        if !(dist2 > r * r) {
            return Cone { axis: Vec3::Z, cos_max: -1.0, one_minus_cos: 2.0 };
        }
        let sin2 = r * r / dist2;
        let cos_max = (1.0 - sin2).max(0.0).sqrt();
        // 1 - sqrt(1 - s) = s / (1 + sqrt(1 - s)), without cancellation for small cones.
        let one_minus_cos = sin2 / (1.0 + cos_max);
        Cone { axis: d / dist2.sqrt(), cos_max, one_minus_cos }
    }

    /// Total solid angle of the cones from `p` (overlaps counted twice): what aiming samples.
    fn solid_angle(&self, p: Vec3) -> f32 {
        self.spheres.iter().take(MAX_AIM_SPHERES).map(|&(c, r)| Self::cone(c, r, p).solid_angle()).sum()
    }

    /// A direction from `p` toward a sphere chosen in proportion to its solid angle, uniform in
    /// that sphere's cone, and its density (per solid angle) over the union of all the cones.
    fn sample(&self, p: Vec3, u_pick: f32, u: Vec2) -> Option<(Vec3, f32)> {
        let n = self.spheres.len().min(MAX_AIM_SPHERES);
        if n == 0 {
            return None;
        }
        let mut cones = [Cone { axis: Vec3::Z, cos_max: -1.0, one_minus_cos: 2.0 }; MAX_AIM_SPHERES];
        let mut total = 0.0f32;
        for (cone, &(c, r)) in cones.iter_mut().zip(&self.spheres[..n]) {
            *cone = Self::cone(c, r, p);
            total += cone.solid_angle();
        }
        let cones = &cones[..n];
        if !(total > 0.0) || !total.is_finite() {
            return None;
        }
        let mut target = u_pick * total;
        let mut chosen = cones[n - 1];
        for cone in cones {
            let w = cone.solid_angle();
            if target < w {
                chosen = *cone;
                break;
            }
            target -= w;
        }
        // Uniform in the cone: 1 - cos(theta) uniform in [0, 1 - cos_max].
        let one_minus = u.x * chosen.one_minus_cos;
        let cos_theta = 1.0 - one_minus;
        let sin_theta = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * u.y;
        let local = Vec3::new(phi.cos() * sin_theta, phi.sin() * sin_theta, cos_theta);
        let dir = crate::math::Frame::from_z(chosen.axis).from_local(local).normalize();
        // Each cone is chosen with probability `solid angle / total` and sampled with density
        // `1 / solid angle`, so every cone that contains `dir` adds `1 / total`. The chosen cone
        // contains it (rounding aside).
        let inside = cones.iter().filter(|c| c.contains(dir)).count().max(1);
        Some((dir, inside as f32 / total))
    }
}

/// A photon's first ray and power, from the light's own emission distribution.
pub(super) fn emission(
    light: &Light,
    u_pos: Vec2,
    u_dir: Vec2,
    u_side: f32,
    scene: (Vec3, f32),
    pick: f32,
) -> Option<(Vec3, Vec3, Vec3)> {
    let le = light.sample_le(u_pos, u_dir, u_side, scene)?;
    let cos = if le.n == Vec3::ZERO { 1.0 } else { le.n.dot(le.direction).abs() };
    let denominator = pick * le.pdf_pos * le.pdf_dir;
    let alpha = le.le * (cos / denominator);
    let ok = denominator > 0.0 && alpha.is_finite() && alpha != Vec3::ZERO && le.direction.is_finite();
    ok.then_some((le.origin, le.direction, alpha))
}

/// A photon aimed at the specular shapes: the light's position as it samples it, a direction
/// from [`Aim::sample`], and the power `Le cos / (pick pdf_pos pdf_aim)`. Where the cones cover
/// no less solid angle than the light emits into (a narrow spot light, a point inside a bounding
/// sphere), the photon keeps the light's own direction distribution instead; the choice depends
/// on the position only, so each is unbiased given the position. Lights at infinity (distant and
/// environment lights) keep their direction distribution and aim the origin instead
/// ([`aimed_from_infinity`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn aimed_emission(
    light: &Light,
    aim: &Aim,
    u_pos: Vec2,
    u_dir: Vec2,
    u_side: f32,
    u_aim: f32,
    scene: (Vec3, f32),
    pick: f32,
) -> Option<(Vec3, Vec3, Vec3)> {
    use std::f32::consts::PI;
    let (origin, n, pdf_pos, two_sided, emitted_solid_angle) = match light {
        Light::Point { position, .. } => (*position, Vec3::ZERO, 1.0, false, 4.0 * PI),
        Light::Spot { position, cos_outside, .. } => {
            (*position, Vec3::ZERO, 1.0, false, 2.0 * PI * (1.0 - cos_outside))
        }
        Light::Area { two_sided, .. } => {
            // The position (and, for two-sided lights, the side) as the light samples them;
            // its origin is already pushed off the surface to that side.
            let le = light.sample_le(u_pos, u_dir, u_side, scene)?;
            (le.origin, le.n, le.pdf_pos, *two_sided, 2.0 * PI)
        }
        Light::Distant { .. } | Light::Environment(_) => {
            return aimed_from_infinity(light, aim, u_pos, u_dir, u_aim, scene, pick);
        }
        _ => return emission(light, u_pos, u_dir, u_side, scene, pick),
    };
    if aim.solid_angle(origin) >= emitted_solid_angle {
        return emission(light, u_pos, u_dir, u_side, scene, pick);
    }
    let (direction, pdf_dir) = aim.sample(origin, u_aim, u_dir)?;
    let intensity = match light {
        Light::Point { intensity, .. } => *intensity,
        Light::Spot { position, .. } => {
            // Spot intensity toward `direction`: the radiance arriving one unit away.
            let ctx = crate::lights::LightSampleContext {
                p: *position + direction,
                p_error: Vec3::ZERO,
                n: Vec3::ZERO,
                p64: (*position + direction).as_dvec3(),
            };
            light.sample_li(&ctx, Vec2::ZERO)?.li * (*position - ctx.p).length_squared()
        }
        _ => {
            // Emission leaves the sampled side only.
            let cos = n.dot(direction);
            if !(cos > 0.0) {
                return None;
            }
            let side = if two_sided { 0.5 } else { 1.0 };
            light.emitted(n, direction) * (cos / side)
        }
    };
    let denominator = pick * pdf_pos * pdf_dir;
    let alpha = intensity / denominator;
    let ok = denominator > 0.0 && alpha.is_finite() && alpha != Vec3::ZERO;
    ok.then_some((origin, direction, alpha))
}

/// A photon from a light at infinity aimed at the specular shapes: the direction from the
/// light's own distribution, the origin uniform on the silhouette (a disc of its radius) of an
/// aiming sphere chosen by area, seen along that direction, instead of on the disc of the whole
/// scene. The area density counts every silhouette that contains the origin. Where the
/// silhouettes cover no less area than the scene's disc, the photon is not aimed.
fn aimed_from_infinity(
    light: &Light,
    aim: &Aim,
    u_pos: Vec2,
    u_dir: Vec2,
    u_aim: f32,
    scene: (Vec3, f32),
    pick: f32,
) -> Option<(Vec3, Vec3, Vec3)> {
    use std::f32::consts::PI;
    let spheres = &aim.spheres[..aim.spheres.len().min(MAX_AIM_SPHERES)];
    let total_r2: f32 = spheres.iter().map(|&(_, r)| r * r).sum();
    let (centre, radius) = scene;
    if spheres.is_empty() || !(total_r2 > 0.0) || total_r2 >= radius * radius {
        return emission(light, u_pos, u_dir, 0.0, scene, pick);
    }
    // The direction (and radiance) as the light samples them; its origin is replaced.
    let le = light.sample_le(u_pos, u_dir, 0.0, scene)?;
    let wi = -le.direction;
    let mut target = u_aim * total_r2;
    let mut chosen = spheres[spheres.len() - 1];
    for &(c, r) in spheres {
        if target < r * r {
            chosen = (c, r);
            break;
        }
        target -= r * r;
    }
    let (c, r) = chosen;
    let frame = crate::math::Frame::from_z(wi);
    let d = crate::sampling::sample_concentric_disk(u_pos) * r;
    let on_plane = c + frame.x * d.x + frame.y * d.y;
    let covering = spheres
        .iter()
        .filter(|&&(c, r)| {
            let v = on_plane - c;
            (v - wi * v.dot(wi)).length_squared() <= r * r
        })
        .count()
        .max(1);
    let pdf_pos = covering as f32 / (PI * total_r2);
    // Moved back along the direction until it is outside the scene's bounding sphere.
    let origin = on_plane + wi * (radius + (c - centre).length());
    let denominator = pick * pdf_pos * le.pdf_dir;
    let alpha = le.le / denominator;
    let ok = denominator > 0.0 && alpha.is_finite() && alpha != Vec3::ZERO && origin.is_finite();
    ok.then_some((origin, le.direction, alpha))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Photons from lights at infinity aimed at two overlapping spheres carry, on average over
    /// the photons whose ray meets a sphere, the same power as unaimed photons: the flux through
    /// the spheres' silhouettes.
    #[test]
    fn aimed_photons_from_infinity_carry_the_flux_through_the_silhouettes() {
        use crate::environment_light::EnvironmentLight;
        let map = crate::texture::Texture::from_rgb(
            16,
            8,
            (0..128).map(|i| Vec3::splat(0.2 + (i % 5) as f32)).collect(),
        )
        .unwrap();
        let env = Light::Environment(std::sync::Arc::new(
            EnvironmentLight::new(Vec3::ONE, Some(std::sync::Arc::new(map)), glam::DMat3::IDENTITY).unwrap(),
        ));
        let distant =
            Light::Distant { direction: Vec3::new(0.3, -1.0, 0.2).normalize(), irradiance: Vec3::ONE };
        let spheres = vec![(Vec3::new(0.5, 0.0, 0.0), 0.6), (Vec3::new(1.0, 0.3, 0.2), 0.4)];
        let aim = Aim { spheres: spheres.clone() };
        let scene = (Vec3::ZERO, 3.0);
        let hits = |o: Vec3, d: Vec3| {
            spheres.iter().any(|&(c, r)| {
                let v = c - o;
                let t = v.dot(d);
                t > 0.0 && (v - d * t).length_squared() <= r * r
            })
        };
        for light in [&env, &distant] {
            let n = 200_000;
            let mut rng = Rng::new(3, 3);
            let (mut aimed, mut plain) = (Vec3::ZERO, Vec3::ZERO);
            for _ in 0..n {
                let (u_pos, u_dir, u_aim) = (rng.uniform2(), rng.uniform2(), rng.uniform());
                if let Some((o, d, a)) = aimed_from_infinity(light, &aim, u_pos, u_dir, u_aim, scene, 1.0) {
                    assert!(hits(o, d), "an aimed photon misses");
                    assert!((o - scene.0).length() >= scene.1 * 0.999);
                    aimed += a;
                }
                if let Some((o, d, a)) = emission(light, u_pos, u_dir, 0.0, scene, 1.0)
                    && hits(o, d)
                {
                    plain += a;
                }
            }
            let (aimed, plain) = (aimed / n as f32, plain / n as f32);
            assert!((aimed - plain).abs().max_element() < 0.03 * plain.max_element(), "{aimed} vs {plain}");
        }
    }

    /// With two overlapping spheres, one apart and one around the point, the mean of
    /// `1 / pdf` over aimed directions is the solid angle of the union of the cones (counted by
    /// uniform directions), which holds only if the density accounts for the overlaps.
    #[test]
    fn aim_density_covers_the_union_of_the_cones() {
        let p = Vec3::new(0.1, -0.2, 0.3);
        let cases = [
            vec![
                (Vec3::new(2.0, 0.0, 0.0), 0.8),
                (Vec3::new(2.2, 0.5, 0.0), 0.7),
                (Vec3::new(-1.0, -3.0, 1.0), 0.5),
            ],
            vec![(Vec3::new(3.0, 1.0, 0.0), 0.01), (Vec3::new(0.0, 0.0, 0.0), 1.0)],
        ];
        for spheres in cases {
            let aim = Aim { spheres: spheres.clone() };
            let n = 200_000;
            let mut rng = Rng::new(7, 1);
            let mut sum_inverse = 0.0f64;
            for _ in 0..n {
                let (dir, pdf) =
                    aim.sample(p, rng.uniform(), Vec2::new(rng.uniform(), rng.uniform())).unwrap();
                assert!((dir.length() - 1.0).abs() < 1e-4);
                sum_inverse += 1.0 / f64::from(pdf);
            }
            let mut inside = 0u32;
            for _ in 0..n {
                let dir = crate::sampling::sample_uniform_sphere(Vec2::new(rng.uniform(), rng.uniform()));
                if spheres.iter().any(|&(c, r)| Aim::cone(c, r, p).contains(dir)) {
                    inside += 1;
                }
            }
            let union = 4.0 * std::f64::consts::PI * f64::from(inside) / f64::from(n);
            let estimate = sum_inverse / f64::from(n);
            assert!((estimate - union).abs() < 0.02 * union, "{estimate} vs {union}");
        }
    }
}

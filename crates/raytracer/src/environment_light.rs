//! An environment light: radiance arriving from every direction at infinity, constant or read
//! from a lat-long map (pbrt-v3's `InfiniteAreaLight`, pbrt-v4's `ImageInfiniteLight`, a
//! RenderMan environment light shader).
//!
//! The map is indexed in the light's space as `shinymetal` indexes its map: +z up,
//! `s = atan2(y, x) / 2 pi`, `t = acos(z) / pi`, `(0, 0)` the top-left texel, read bilinearly
//! (periodic in `s`, clamped in `t`). Directions are sampled from a piecewise-constant density
//! over the map's cells weighted by `sin(theta)` (the lat-long parameterisation's area), so
//! bright texels are found by light sampling; a constant environment is sampled uniformly.

use crate::math::Frame;
use crate::sampling::{Distribution2D, UNIFORM_SPHERE_PDF, sample_concentric_disk, sample_uniform_sphere};
use crate::texture::Texture;
use glam::{DMat3, Mat3, Vec2, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

/// The sampling density is built on the finest level of the map's pyramid with at most this
/// many texels (about 16 MB of tables at most), whatever the map's size.
pub const MAX_DISTRIBUTION_CELLS: usize = 1 << 20;

/// Radiance from infinitely far away, `scale * map(direction)`, or `scale` without a map.
#[derive(Clone, Debug)]
pub struct EnvironmentLight {
    scale: Vec3,
    map: Option<Arc<Texture>>,
    /// The light's orientation: light space from render space, and back (rotations).
    light_from_render: Mat3,
    render_from_light: Mat3,
    /// Direction density over the map's `(s, t)` square (`None` without a map).
    distribution: Option<Distribution2D>,
    /// Mean radiance over the sphere of directions (scale included), each texel taken as
    /// constant over its cell.
    mean: Vec3,
}

/// A unit direction in light space from lat-long map coordinates.
fn direction_of(st: Vec2) -> Vec3 {
    let (phi, theta) = (st.x * 2.0 * PI, st.y * PI);
    let sin_theta = theta.sin();
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), theta.cos())
}

/// Lat-long map coordinates of a unit direction in light space.
fn st_of(d: Vec3) -> Vec2 {
    let phi = d.y.atan2(d.x).rem_euclid(2.0 * PI);
    Vec2::new(phi / (2.0 * PI), d.z.clamp(-1.0, 1.0).acos() / PI)
}

/// Non-finite or negative components as 0 (maps read from EXR may hold either).
fn non_negative(c: Vec3) -> Vec3 {
    let f = |v: f32| if v.is_finite() && v > 0.0 { v } else { 0.0 };
    Vec3::new(f(c.x), f(c.y), f(c.z))
}

impl EnvironmentLight {
    /// A light of radiance `scale * map` oriented by `render_from_light` (its rotation is used:
    /// scale and shear are dropped by orthonormalising its columns). `None` when `scale` or
    /// the orientation is not finite, or the orientation is singular.
    pub fn new(scale: Vec3, map: Option<Arc<Texture>>, render_from_light: DMat3) -> Option<EnvironmentLight> {
        if !scale.is_finite() || !render_from_light.is_finite() {
            return None;
        }
        // Gram-Schmidt on the columns, keeping a mirror's handedness.
        let x = render_from_light.x_axis.try_normalize()?;
        let y = (render_from_light.y_axis - x * x.dot(render_from_light.y_axis)).try_normalize()?;
        let z = x.cross(y) * render_from_light.determinant().signum();
        if render_from_light.determinant() == 0.0 {
            return None;
        }
        let render_from_light = DMat3::from_cols(x, y, z).as_mat3();
        let scale = non_negative(scale);
        let (distribution, mean) = match &map {
            Some(map) => {
                let (w, h, texels) = map.level_within(MAX_DISTRIBUTION_CELLS);
                let (weights, mean) = Self::cell_weights(w as usize, h as usize, texels);
                (Distribution2D::new(&weights, w as usize, h as usize), mean * scale)
            }
            None => (None, scale),
        };
        Some(EnvironmentLight {
            scale,
            map,
            light_from_render: render_from_light.transpose(),
            render_from_light,
            distribution,
            mean,
        })
    }

    /// Sampling weights of the map's cells and the map's mean over the sphere. A cell's weight
    /// is the integral over the cell of the bilinear reconstruction at this level (the
    /// `[1/8, 3/4, 1/8]` kernel in each direction), so it is positive wherever the lookup can
    /// be, times `sin(theta)` at the cell's centre.
    fn cell_weights(w: usize, h: usize, texels: &[Vec3]) -> (Vec<f32>, Vec3) {
        let value = |x: i64, y: i64| {
            let x = x.rem_euclid(w as i64) as usize;
            let y = y.clamp(0, h as i64 - 1) as usize;
            let c = non_negative(texels[y * w + x]);
            (c.x + c.y + c.z) / 3.0
        };
        let kernel = [(-1, 0.125f32), (0, 0.75), (1, 0.125)];
        let mut weights = Vec::with_capacity(w * h);
        let mut sum = glam::DVec3::ZERO;
        // Exact solid angle of a cell: (cos theta0 - cos theta1) dphi.
        let cell_solid_angle = |y: usize| {
            let theta = |y: usize| y as f64 / h as f64 * std::f64::consts::PI;
            (theta(y).cos() - theta(y + 1).cos()) * (2.0 * std::f64::consts::PI / w as f64)
        };
        for y in 0..h {
            let sin_theta = (((y as f32 + 0.5) / h as f32) * PI).sin();
            let solid_angle = cell_solid_angle(y);
            for x in 0..w {
                let mut v = 0.0;
                for (dy, ky) in kernel {
                    for (dx, kx) in kernel {
                        v += kx * ky * value(x as i64 + dx, y as i64 + dy);
                    }
                }
                weights.push(v * sin_theta);
                sum += non_negative(texels[y * w + x]).as_dvec3() * solid_angle;
            }
        }
        (weights, (sum / (4.0 * std::f64::consts::PI)).as_vec3())
    }

    /// Radiance arriving from render-space direction `wi` (unit, pointing away from the scene).
    pub fn radiance(&self, wi: Vec3) -> Vec3 {
        match &self.map {
            Some(map) => self.scale * non_negative(map.lookup_lat_long(st_of(self.light_from_render * wi))),
            None => self.scale,
        }
    }

    /// A direction toward the environment, its solid-angle density and the radiance from it.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32, Vec3)> {
        let (wi, pdf) = match &self.distribution {
            Some(d) => {
                let (st, pdf_st) = d.sample(u)?;
                let sin_theta = (st.y * PI).sin();
                if !(sin_theta > 0.0) {
                    return None;
                }
                (self.render_from_light * direction_of(st), pdf_st / (2.0 * PI * PI * sin_theta))
            }
            None if self.map.is_some() => return None,
            None => (sample_uniform_sphere(u), UNIFORM_SPHERE_PDF),
        };
        let le = self.radiance(wi);
        (pdf > 0.0 && pdf.is_finite() && le != Vec3::ZERO).then_some((wi, pdf, le))
    }

    /// The solid-angle density with which [`EnvironmentLight::sample`] returns `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        match &self.distribution {
            Some(d) => {
                let st = st_of(self.light_from_render * wi);
                let sin_theta = (st.y * PI).sin();
                if !(sin_theta > 0.0) {
                    return 0.0;
                }
                d.pdf(st) / (2.0 * PI * PI * sin_theta)
            }
            None if self.map.is_some() => 0.0,
            None => UNIFORM_SPHERE_PDF,
        }
    }

    /// Power reaching a scene of radius `scene_radius`: the flux through a disc of that radius
    /// facing each direction, `4 pi * pi R^2 * mean radiance` (pbrt-v4's `Phi`).
    pub fn power(&self, scene_radius: f32) -> Vec3 {
        self.mean * (4.0 * PI * PI * scene_radius * scene_radius)
    }

    /// A photon entering the scene (pbrt-v4's `ImageInfiniteLight::SampleLe`): a direction
    /// from the environment's density, and an origin on the disc of the scene's radius
    /// perpendicular to it, outside the scene's bounding sphere. Returns the origin, the
    /// direction of travel, the radiance, and the densities of position (area) and direction.
    pub fn sample_emission(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        (centre, radius): (Vec3, f32),
    ) -> Option<(Vec3, Vec3, Vec3, f32, f32)> {
        let (wi, pdf_dir, le) = self.sample(u_dir)?;
        let frame = Frame::from_z(wi);
        let d = sample_concentric_disk(u_pos) * radius;
        let origin = centre + wi * radius + frame.x * d.x + frame.y * d.y;
        Some((origin, -wi, le, 1.0 / (PI * radius * radius), pdf_dir))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn directions_and_map_coordinates_round_trip() {
        for st in [Vec2::new(0.1, 0.2), Vec2::new(0.75, 0.5), Vec2::new(0.999, 0.95)] {
            let back = st_of(direction_of(st));
            assert!((back - st).abs().max_element() < 1e-5, "{st} -> {back}");
        }
        // +z is the top row, +x the left edge.
        assert!(st_of(Vec3::Z).y < 1e-6);
        assert!(st_of(Vec3::X).x < 1e-6 && (st_of(Vec3::X).y - 0.5).abs() < 1e-6);
    }

    /// A rotated light looks its map up in its own space.
    #[test]
    fn orientation_rotates_the_map() {
        let texels = (0..8 * 4).map(|i| if i / 8 < 2 { Vec3::ONE } else { Vec3::ZERO }).collect();
        let map = Arc::new(Texture::from_rgb(8, 4, texels).unwrap());
        let upright = EnvironmentLight::new(Vec3::ONE, Some(map.clone()), DMat3::IDENTITY).unwrap();
        assert_eq!(upright.radiance(Vec3::new(0.0, 0.3, 0.95).normalize()), Vec3::ONE);
        assert_eq!(upright.radiance(-Vec3::Z), Vec3::ZERO);
        // Light space +z is render space -y after a rotation of 90 degrees about x.
        let tilted = DMat3::from_rotation_x(std::f64::consts::FRAC_PI_2)
            * DMat3::from_diagonal(glam::DVec3::splat(3.0));
        let tilted = EnvironmentLight::new(Vec3::ONE, Some(map), tilted).unwrap();
        assert_eq!(tilted.radiance(Vec3::new(0.0, -0.95, 0.3).normalize()), Vec3::ONE);
        assert_eq!(tilted.radiance(Vec3::new(0.0, 0.95, 0.3).normalize()), Vec3::ZERO);
        assert!(EnvironmentLight::new(Vec3::ONE, None, DMat3::ZERO).is_none());
        assert!(EnvironmentLight::new(Vec3::NAN, None, DMat3::IDENTITY).is_none());
    }

    /// The sampled density matches `pdf`, integrates to 1 over the sphere, and is positive
    /// wherever the map is.
    #[test]
    fn density_integrates_to_one_and_matches_sampling() {
        let (w, h) = (16u32, 8u32);
        let texels =
            (0..w * h).map(|i| Vec3::splat(((i * 7919) % 13) as f32 * 0.1 + 0.05 * (i % 3) as f32)).collect();
        let map = Arc::new(Texture::from_rgb(w, h, texels).unwrap());
        let light = EnvironmentLight::new(
            Vec3::ONE,
            Some(map),
            DMat3::from_rotation_z(0.4) * DMat3::from_rotation_x(0.3),
        )
        .unwrap();
        let mut rng = Rng::new(5, 5);
        let n = 200_000;
        let mut integral = 0.0f64;
        for _ in 0..n {
            let d = sample_uniform_sphere(rng.uniform2());
            integral += f64::from(light.pdf(d) / UNIFORM_SPHERE_PDF);
            if light.radiance(d) != Vec3::ZERO {
                assert!(light.pdf(d) > 0.0, "{d}");
            }
        }
        integral /= f64::from(n);
        assert!((integral - 1.0).abs() < 0.01, "{integral}");
        for _ in 0..1000 {
            let (wi, pdf, le) = light.sample(rng.uniform2()).unwrap();
            assert!((wi.length() - 1.0).abs() < 1e-4);
            assert!((light.pdf(wi) - pdf).abs() <= 2e-3 * pdf, "{} vs {pdf}", light.pdf(wi));
            assert_eq!(le, light.radiance(wi));
        }
    }
}

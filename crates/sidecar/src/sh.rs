//! Real spherical harmonics up to band 2 (9 coefficients) and irradiance from them
//! (Ramamoorthi & Hanrahan 2001): the form the irradiance probes store.

/// Coefficients per colour channel.
pub const SH_COEFFICIENTS: usize = 9;

/// The 9 real SH basis functions at unit direction `d` = (x, y, z), in the order
/// `Y00, Y1-1, Y10, Y11, Y2-2, Y2-1, Y20, Y21, Y22` (y, z, x for band 1).
pub fn sh_basis(d: [f32; 3]) -> [f32; SH_COEFFICIENTS] {
    let [x, y, z] = d;
    [
        0.282_094_8,
        0.488_602_5 * y,
        0.488_602_5 * z,
        0.488_602_5 * x,
        1.092_548_4 * x * y,
        1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z * z - 1.0),
        1.092_548_4 * x * z,
        0.546_274_2 * (x * x - y * y),
    ]
}

/// Convolution of radiance with the clamped cosine, per band: `pi`, `2 pi / 3`, `pi / 4`.
const COSINE_BAND: [f32; 3] =
    [std::f32::consts::PI, 2.0 * std::f32::consts::PI / 3.0, std::f32::consts::PI / 4.0];

/// The band of coefficient `i`.
fn band(i: usize) -> usize {
    match i {
        0 => 0,
        1..=3 => 1,
        _ => 2,
    }
}

/// Irradiance at a surface with unit normal `n` from radiance whose SH projection is `radiance`
/// (RGB per coefficient).
pub fn sh_irradiance(radiance: &[[f32; 3]; SH_COEFFICIENTS], n: [f32; 3]) -> [f32; 3] {
    let y = sh_basis(n);
    let mut e = [0.0f32; 3];
    for i in 0..SH_COEFFICIENTS {
        let w = COSINE_BAND[band(i)] * y[i];
        for c in 0..3 {
            e[c] += w * radiance[i][c];
        }
    }
    e
}

/// Accumulates the SH projection of radiance samples taken over the sphere with equal weights
/// (e.g. a spherical Fibonacci set): `L_i = 4 pi / N * sum L(d) Y_i(d)`.
#[derive(Debug, Clone, Default)]
pub struct ShProjector {
    sum: [[f64; 3]; SH_COEFFICIENTS],
    count: u64,
}

impl ShProjector {
    pub fn add(&mut self, direction: [f32; 3], radiance: [f32; 3]) {
        let y = sh_basis(direction);
        for (sum, y) in self.sum.iter_mut().zip(y) {
            for (s, l) in sum.iter_mut().zip(radiance) {
                *s += f64::from(y) * f64::from(l);
            }
        }
        self.count += 1;
    }

    pub fn finish(&self) -> [[f32; 3]; SH_COEFFICIENTS] {
        let scale = if self.count == 0 { 0.0 } else { 4.0 * std::f64::consts::PI / self.count as f64 };
        self.sum.map(|c| c.map(|v| (v * scale) as f32))
    }
}

/// `n` directions spread evenly over the unit sphere (spherical Fibonacci), rotated by `twist`
/// radians about z so successive bakes can use different sets.
pub fn fibonacci_sphere(n: usize, twist: f32) -> Vec<[f32; 3]> {
    let golden = std::f32::consts::PI * (3.0 - 5.0f32.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f32 + twist;
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn project(n: usize, radiance: impl Fn([f32; 3]) -> [f32; 3]) -> [[f32; 3]; SH_COEFFICIENTS] {
        let mut p = ShProjector::default();
        for d in fibonacci_sphere(n, 0.0) {
            p.add(d, radiance(d));
        }
        p.finish()
    }

    #[test]
    fn white_furnace_gives_pi_times_radiance_for_every_normal() {
        let sh = project(4096, |_| [1.0, 0.5, 2.0]);
        for n in fibonacci_sphere(50, 0.3) {
            let e = sh_irradiance(&sh, n);
            for (c, l) in [1.0f32, 0.5, 2.0].iter().enumerate() {
                assert!((e[c] - std::f32::consts::PI * l).abs() < 1e-3 * l, "{e:?}");
            }
        }
    }

    #[test]
    fn a_narrow_light_gives_the_band_limited_cosine_lobe() {
        // Radiance concentrated in a small cap around `d` with total irradiance-at-normal-
        // incidence E0: the L2 projection of the clamped cosine is
        // E0 (1/4 + t/2 + 5/32 (3 t^2 - 1)) with t = n . d (Ramamoorthi & Hanrahan).
        let d = {
            let v = [0.3f32, -0.5, 0.81];
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| c / l)
        };
        let dirs = fibonacci_sphere(200_000, 0.0);
        let cos_cap = 0.999f32;
        let in_cap = dirs.iter().filter(|w| w[0] * d[0] + w[1] * d[1] + w[2] * d[2] > cos_cap).count();
        // Each sample stands for 4 pi / N steradians; choose radiance so the cap's flux is E0 = 2.
        let radiance = 2.0 / (in_cap as f32 * 4.0 * std::f32::consts::PI / dirs.len() as f32);
        let mut p = ShProjector::default();
        for w in &dirs {
            let inside = w[0] * d[0] + w[1] * d[1] + w[2] * d[2] > cos_cap;
            p.add(*w, if inside { [radiance; 3] } else { [0.0; 3] });
        }
        let sh = p.finish();
        for n in fibonacci_sphere(40, 1.0) {
            let t = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            let expected = 2.0 * (0.25 + 0.5 * t + 5.0 / 32.0 * (3.0 * t * t - 1.0));
            let e = sh_irradiance(&sh, n)[0];
            assert!((e - expected).abs() < 5e-3, "t={t}: {e} vs {expected}");
        }
    }
}

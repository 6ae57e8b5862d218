//! RenderMan's `noise()` of a point: Ken Perlin's improved gradient noise (SIGGRAPH 2002,
//! "Improving Noise") in `f64`, mapped from about [-1, 1] to RenderMan's range [0, 1].
//!
//! RenderMan only specifies `noise` as a smooth pseudo-random function of range [0, 1] with mean
//! 0.5, equal to 0.5 at integer lattice points; implementations differ (PRMan's, Aqsis' and
//! BMRT's tables are not Perlin's). This one is Perlin's reference: his permutation table, the
//! twelve cube-edge gradients, the quintic fade `6t^5 - 15t^4 + 10t^3`, and
//! `noise = 0.5 + 0.5 n` clamped to [0, 1], deterministic on every machine.

/// Perlin's permutation of 0..=255 (the reference implementation's table).
const PERMUTATION: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69, 142, 8, 99,
    37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219, 203, 117, 35, 11, 32,
    57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175, 74, 165, 71, 134, 139, 48, 27,
    166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244,
    102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130,
    116, 188, 159, 86, 164, 100, 109, 198, 173, 186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147,
    118, 126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119,
    248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110,
    79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179,
    162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204, 176,
    115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195, 78,
    66, 215, 61, 156, 180,
];

/// Quintic fade curve: value, first and second derivatives vanish at 0 and 1.
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// The dot product of the lattice gradient `hash` (one of the cube's twelve edge directions,
/// four repeated to make sixteen) with the offset `(x, y, z)`.
fn gradient(hash: u8, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

fn hash(i: i64) -> u8 {
    PERMUTATION[(i & 255) as usize]
}

/// Perlin's improved noise at `(x, y, z)`, in about [-1, 1]; 0 at integer points. Non-finite
/// input gives 0.
pub fn perlin_noise(x: f64, y: f64, z: f64) -> f64 {
    if !(x.is_finite() && y.is_finite() && z.is_finite()) {
        return 0.0;
    }
    let (fx, fy, fz) = (x.floor(), y.floor(), z.floor());
    // Lattice cells wrap every 256, so each cell index is reduced modulo 256 before the hash
    // sums (which `hash` reduces again): the sums stay small, so huge coordinates, whose
    // conversion saturates, cannot overflow them.
    let (xi, yi, zi) = ((fx as i64) & 255, (fy as i64) & 255, (fz as i64) & 255);
    let (x, y, z) = (x - fx, y - fy, z - fz);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let a = hash(xi) as i64 + yi;
    let (aa, ab) = (hash(a) as i64 + zi, hash(a + 1) as i64 + zi);
    let b = hash(xi + 1) as i64 + yi;
    let (ba, bb) = (hash(b) as i64 + zi, hash(b + 1) as i64 + zi);
    lerp(
        w,
        lerp(
            v,
            lerp(u, gradient(hash(aa), x, y, z), gradient(hash(ba), x - 1.0, y, z)),
            lerp(u, gradient(hash(ab), x, y - 1.0, z), gradient(hash(bb), x - 1.0, y - 1.0, z)),
        ),
        lerp(
            v,
            lerp(u, gradient(hash(aa + 1), x, y, z - 1.0), gradient(hash(ba + 1), x - 1.0, y, z - 1.0)),
            lerp(
                u,
                gradient(hash(ab + 1), x, y - 1.0, z - 1.0),
                gradient(hash(bb + 1), x - 1.0, y - 1.0, z - 1.0),
            ),
        ),
    )
}

/// RenderMan's `float noise(point)`: `0.5 + 0.5 n` of [`perlin_noise`], clamped to [0, 1].
pub fn renderman_noise(x: f64, y: f64, z: f64) -> f64 {
    (0.5 + 0.5 * perlin_noise(x, y, z)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_coordinates_give_finite_noise_without_overflow() {
        for c in [f64::MAX, -f64::MAX, 9.3e18, -9.3e18, 1e300] {
            for (x, y, z) in [(c, 0.5, 0.5), (0.5, c, 0.5), (0.5, 0.5, c), (c, c, c)] {
                let n = perlin_noise(x, y, z);
                assert!(n.is_finite() && n.abs() <= 1.5, "{x} {y} {z}: {n}");
            }
        }
    }

    /// Reducing the cell indices modulo 256 before hashing keeps the lattice: noise repeats
    /// every 256 cells, as Perlin's table makes it.
    #[test]
    fn noise_repeats_every_256_cells() {
        for &(x, y, z) in &[(0.3, 1.7, -2.2), (-5.5, 7.25, 100.125), (12.5, -0.75, 3.0)] {
            // The shifted coordinates' fractions differ in the last bits, hence the tolerance.
            let n = perlin_noise(x, y, z);
            for shifted in
                [perlin_noise(x + 256.0, y, z), perlin_noise(x, y - 512.0, z), perlin_noise(x, y, z + 768.0)]
            {
                assert!((n - shifted).abs() < 1e-9, "{x} {y} {z}: {n} vs {shifted}");
            }
        }
    }

    #[test]
    fn permutation_is_a_permutation_of_0_to_255() {
        let mut seen = [false; 256];
        for &p in &PERMUTATION {
            assert!(!seen[p as usize], "{p} twice");
            seen[p as usize] = true;
        }
    }

    /// 0 at lattice points (RenderMan's 0.5), smooth, of mean about 0 and within [-1, 1]
    /// elsewhere.
    #[test]
    fn noise_is_half_at_lattice_points_and_in_range_elsewhere() {
        for (x, y, z) in [(0.0, 0.0, 0.0), (1.0, 2.0, 3.0), (-7.0, 300.0, -256.0)] {
            assert_eq!(renderman_noise(x, y, z), 0.5);
        }
        let (mut lo, mut hi, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
        let n = 20_000;
        for i in 0..n {
            let t = i as f64;
            let (x, y, z) = (t * 0.137 + 0.01, t * 0.291 - 3.3, t * 0.0731 + 0.5);
            let v = perlin_noise(x, y, z);
            assert!(v.abs() <= 1.05, "{v} at {x} {y} {z}");
            lo = lo.min(v);
            hi = hi.max(v);
            sum += v;
        }
        assert!(lo < -0.5 && hi > 0.5, "range [{lo}, {hi}] too narrow for gradient noise");
        assert!((sum / n as f64).abs() < 0.02, "mean {}", sum / n as f64);
        // Continuity: a tiny step moves the value by a tiny amount.
        let (a, b) = (perlin_noise(0.3, 0.7, 0.9), perlin_noise(0.3 + 1e-9, 0.7, 0.9));
        assert!((a - b).abs() < 1e-8);
        assert_eq!(perlin_noise(f64::NAN, 0.0, 0.0), 0.0);
    }

    /// Perlin's reference value at his own test point (3.14, 42, 7): 0.13691995878400012.
    #[test]
    // Perlin's test point, not an approximation of pi.
    #[allow(clippy::approx_constant)]
    fn noise_matches_perlins_reference_value() {
        assert!((perlin_noise(3.14, 42.0, 7.0) - 0.136_919_958_784).abs() < 1e-9);
    }
}

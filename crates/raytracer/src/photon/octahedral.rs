//! Unit vectors in 32 bits (octahedral mapping), as photons store their directions and normals.

use glam::Vec3;

/// Encodes a unit vector in 32 bits (octahedral mapping, 16 bits per coordinate on an odd grid
/// so that the axes are exact; error below 1e-4 radians).
pub fn pack_unit(v: Vec3) -> u32 {
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    if !(l1 > 0.0) || !l1.is_finite() {
        return pack_unit(Vec3::Z);
    }
    let (mut x, mut y) = (v.x / l1, v.y / l1);
    if v.z < 0.0 {
        let (ox, oy) = (x, y);
        x = (1.0 - oy.abs()) * if ox >= 0.0 { 1.0 } else { -1.0 };
        y = (1.0 - ox.abs()) * if oy >= 0.0 { 1.0 } else { -1.0 };
    }
    let q = |c: f32| ((c.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65534.0).round() as u32;
    q(x) | (q(y) << 16)
}

/// Decodes [`pack_unit`].
#[inline]
pub fn unpack_unit(bits: u32) -> Vec3 {
    let x = ((bits & 0xffff) as f32 / 65534.0 * 2.0 - 1.0).clamp(-1.0, 1.0);
    let y = ((bits >> 16) as f32 / 65534.0 * 2.0 - 1.0).clamp(-1.0, 1.0);
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let x = x + if x >= 0.0 { -t } else { t };
    let y = y + if y >= 0.0 { -t } else { t };
    Vec3::new(x, y, z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_vectors_round_trip() {
        let mut rng = crate::sampling::Rng::new(9, 9);
        for _ in 0..10_000 {
            let v = crate::sampling::sample_uniform_sphere(rng.uniform2());
            let w = unpack_unit(pack_unit(v));
            assert!((v - w).length() < 1e-4, "{v} -> {w}");
        }
        for v in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            assert!((unpack_unit(pack_unit(v)) - v).length() < 1e-4);
        }
        assert_eq!(unpack_unit(pack_unit(Vec3::new(f32::NAN, 0.0, 0.0))), Vec3::Z);
    }
}

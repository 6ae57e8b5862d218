//! Irradiance probes: a regular grid over the scene's bounds, each probe holding the L2
//! spherical-harmonic projection of the radiance arriving at it and DDGI-style visibility
//! (mean and mean squared distance to the nearest surface per direction, in an octahedral map;
//! Majercik et al. 2019), so that light does not leak through walls. [`ProbeGrid::irradiance`]
//! is the reference evaluator the viewer ports to WGSL.

use crate::sh::{SH_COEFFICIENTS, sh_irradiance};

/// Texels per side of a probe's octahedral visibility map.
pub const VISIBILITY_TEXELS: usize = 16;

/// A grid of irradiance probes in world space.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeGrid {
    /// [`crate::depth_fingerprint`] of the depth table rendered with these probes.
    pub depth_fingerprint: u64,
    /// World position of probe `(0, 0, 0)`.
    pub origin: [f32; 3],
    /// Distance between neighbouring probes along x, y, z (each > 0).
    pub spacing: [f32; 3],
    /// Probes along x, y, z (each >= 1).
    pub counts: [u32; 3],
    /// Per probe (x fastest, then y, then z): radiance projected on the 9 SH basis functions
    /// ([`crate::sh::sh_basis`] order), RGB, in the image's units.
    pub radiance_sh: Vec<[[f32; 3]; SH_COEFFICIENTS]>,
    /// Per probe, `VISIBILITY_TEXELS^2` texels (row-major over the octahedral square, see
    /// [`octahedral_texel`]): mean and mean squared distance to the first surface.
    pub visibility: Vec<[f32; 2]>,
    /// Whether `radiance_sh` includes the light emitters send straight to the probe (files
    /// written before the `lrt.probes.emitters` attribute); `false` when the bake left it out,
    /// so the SH holds only light leaving other surfaces, which a viewer adds to the lights'
    /// own direct light without subtracting anything.
    pub emitters_seen: bool,
}

/// The octahedral map's coordinates in `[0, 1]^2` of unit direction `d`.
pub fn octahedral_uv(d: [f32; 3]) -> [f32; 2] {
    let l1 = d[0].abs() + d[1].abs() + d[2].abs();
    let (mut x, mut y) = if l1 > 0.0 { (d[0] / l1, d[1] / l1) } else { (0.0, 0.0) };
    if d[2] < 0.0 {
        let (ox, oy) = (x, y);
        x = (1.0 - oy.abs()) * if ox >= 0.0 { 1.0 } else { -1.0 };
        y = (1.0 - ox.abs()) * if oy >= 0.0 { 1.0 } else { -1.0 };
    }
    [x * 0.5 + 0.5, y * 0.5 + 0.5]
}

/// The unit direction at octahedral coordinates `uv` in `[0, 1]^2` (inverse of [`octahedral_uv`]).
pub fn octahedral_direction(uv: [f32; 2]) -> [f32; 3] {
    let (mut x, mut y) = (uv[0] * 2.0 - 1.0, uv[1] * 2.0 - 1.0);
    let z = 1.0 - x.abs() - y.abs();
    if z < 0.0 {
        let (ox, oy) = (x, y);
        x = (1.0 - oy.abs()) * if ox >= 0.0 { 1.0 } else { -1.0 };
        y = (1.0 - ox.abs()) * if oy >= 0.0 { 1.0 } else { -1.0 };
    }
    let l = (x * x + y * y + z * z).sqrt();
    [x / l, y / l, z / l]
}

/// The visibility texel (index within a probe's map) that direction `d` falls in.
pub fn octahedral_texel(d: [f32; 3]) -> usize {
    let [u, v] = octahedral_uv(d);
    let r = VISIBILITY_TEXELS;
    let i = ((u * r as f32) as usize).min(r - 1);
    let j = ((v * r as f32) as usize).min(r - 1);
    j * r + i
}

/// The direction through the centre of visibility texel `texel`.
pub fn octahedral_texel_direction(texel: usize) -> [f32; 3] {
    let r = VISIBILITY_TEXELS;
    let (i, j) = (texel % r, texel / r);
    octahedral_direction([(i as f32 + 0.5) / r as f32, (j as f32 + 0.5) / r as f32])
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Crushes tiny probe weights (DDGI): removes the residual glow of a probe seen through a wall.
fn crushed(w: f32) -> f32 {
    if w < 0.2 { w * w * w / 0.04 } else { w }
}

impl ProbeGrid {
    pub fn probe_count(&self) -> usize {
        self.counts.iter().map(|&c| c as usize).product()
    }

    /// Index of probe `(x, y, z)`.
    pub fn probe_index(&self, [x, y, z]: [u32; 3]) -> usize {
        (x as usize) + self.counts[0] as usize * (y as usize + self.counts[1] as usize * z as usize)
    }

    /// World position of probe `(x, y, z)`.
    pub fn probe_position(&self, cell: [u32; 3]) -> [f32; 3] {
        std::array::from_fn(|a| self.origin[a] + cell[a] as f32 * self.spacing[a])
    }

    /// The probes of `q`'s grid cell with a trilinear weight above 0: index, weight, vector from
    /// `q` to the probe and its length.
    fn cell_probes(&self, q: [f32; 3]) -> impl Iterator<Item = (usize, f32, [f32; 3], f32)> + '_ {
        let mut base = [0u32; 3];
        let mut alpha = [0.0f32; 3];
        for a in 0..3 {
            let last = self.counts[a].saturating_sub(1);
            let t = ((q[a] - self.origin[a]) / self.spacing[a]).clamp(0.0, last as f32);
            let b = (t.floor() as u32).min(last.saturating_sub(1));
            base[a] = b;
            alpha[a] = if last == 0 { 0.0 } else { t - b as f32 };
        }
        (0..8u32).filter_map(move |corner| {
            let offset = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let cell: [u32; 3] = std::array::from_fn(|a| (base[a] + offset[a]).min(self.counts[a] - 1));
            let trilinear: f32 =
                (0..3).map(|a| if offset[a] == 1 { alpha[a] } else { 1.0 - alpha[a] }).product();
            if trilinear <= 0.0 {
                return None;
            }
            let to_probe = sub(self.probe_position(cell), q);
            Some((self.probe_index(cell), trilinear, to_probe, dot(to_probe, to_probe).sqrt()))
        })
    }

    /// Chebyshev visibility (DDGI) of a point `distance` from `probe` along unit `dir` (from
    /// the point toward the probe): 1 within the texel's mean distance, else
    /// `(var / (var + (d - mean)^2))^3`.
    fn visibility_of(&self, probe: usize, dir: [f32; 3], distance: f32) -> f32 {
        let texel = octahedral_texel(dir.map(|c| -c));
        let [mean, mean_sq] = self.visibility[probe * VISIBILITY_TEXELS * VISIBILITY_TEXELS + texel];
        if distance <= mean {
            return 1.0;
        }
        let variance = (mean_sq - mean * mean).abs().max(1e-6 * mean_sq.max(1e-12));
        let d = distance - mean;
        (variance / (variance + d * d)).powi(3).max(0.0)
    }

    /// Irradiance at world point `p` on a surface with unit normal `n`, from the 8 probes of the
    /// cell around `p` (DDGI): trilinear weights times a smooth backface term times Chebyshev
    /// visibility, so a probe on the far side of a wall does not light `p`. `p` is first moved
    /// `0.1 * min(spacing)` along `n` off the surface (DDGI's normal bias).
    pub fn irradiance(&self, p: [f32; 3], n: [f32; 3]) -> [f32; 3] {
        self.irradiance_of(&self.radiance_sh, p, n)
    }

    /// [`ProbeGrid::irradiance`] with each probe's radiance SH taken from `sh` (one set per
    /// probe, e.g. the probes' SH less light a viewer adds itself) instead of `radiance_sh`.
    /// A probe missing from `sh` counts as dark.
    pub fn irradiance_of(&self, sh: &[[[f32; 3]; SH_COEFFICIENTS]], p: [f32; 3], n: [f32; 3]) -> [f32; 3] {
        let bias = 0.1 * self.spacing.iter().copied().fold(f32::INFINITY, f32::min);
        let q: [f32; 3] = std::array::from_fn(|a| p[a] + n[a] * bias);
        let mut sum = [0.0f32; 3];
        let mut total = 0.0f32;
        for (probe, trilinear, to_probe, distance) in self.cell_probes(q) {
            let dir = if distance > 0.0 { to_probe.map(|c| c / distance) } else { n };
            // Smooth backface term: probes behind the surface count little, never nothing.
            let backface = {
                let h = (dot(dir, n) + 1.0) * 0.5;
                h * h + 0.2
            };
            let w = crushed(trilinear * backface * self.visibility_of(probe, dir, distance).max(1e-6));
            let e = sh.get(probe).map_or([0.0; 3], |probe_sh| sh_irradiance(probe_sh, n));
            for c in 0..3 {
                sum[c] += w * e[c];
            }
            total += w;
        }
        if total > 0.0 { sum.map(|v| (v / total).max(0.0)) } else { [0.0; 3] }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::{ShProjector, fibonacci_sphere};

    #[test]
    fn octahedral_map_round_trips_and_covers_every_texel() {
        for d in fibonacci_sphere(500, 0.1) {
            let back = octahedral_direction(octahedral_uv(d));
            assert!(dot(back, d) > 1.0 - 1e-5, "{d:?} -> {back:?}");
        }
        for t in 0..VISIBILITY_TEXELS * VISIBILITY_TEXELS {
            assert_eq!(octahedral_texel(octahedral_texel_direction(t)), t);
        }
    }

    /// Two probes one unit apart along x with a wall at x = 0.5 between them: the left one sees
    /// uniform radiance 1, the right one darkness.
    fn walled_pair(visibility_through_wall: bool) -> ProbeGrid {
        let mut lit = ShProjector::default();
        for d in fibonacci_sphere(2048, 0.0) {
            lit.add(d, [1.0; 3]);
        }
        let texels = VISIBILITY_TEXELS * VISIBILITY_TEXELS;
        let mut visibility = Vec::new();
        for probe in 0..2 {
            for t in 0..texels {
                let d = octahedral_texel_direction(t);
                // Toward the other probe the wall is 0.5 away (unless it is a hole).
                let toward_other = if probe == 0 { d[0] > 0.5 } else { d[0] < -0.5 };
                let dist = if toward_other && !visibility_through_wall { 0.5 } else { 10.0 };
                visibility.push([dist, dist * dist]);
            }
        }
        ProbeGrid {
            depth_fingerprint: 0,
            origin: [0.0; 3],
            spacing: [1.0; 3],
            counts: [2, 1, 1],
            radiance_sh: vec![lit.finish(), ShProjector::default().finish()],
            visibility,
            emitters_seen: false,
        }
    }

    #[test]
    fn light_does_not_leak_through_a_wall() {
        let n = [0.0, 1.0, 0.0];
        let walled = walled_pair(false);
        let open = walled_pair(true);
        // Just behind the wall, on the dark side: without the wall's visibility the lit probe
        // gives about 0.15 pi there (trilinear weight 0.3, backface and small-weight terms);
        // with it, almost nothing.
        let behind = walled.irradiance([0.7, 0.0, 0.0], n)[0];
        let through = open.irradiance([0.7, 0.0, 0.0], n)[0];
        assert!(through > 0.1 * std::f32::consts::PI, "{through}");
        assert!(behind < 1e-3 * std::f32::consts::PI, "{behind}");
        // On the lit side the lit probe dominates.
        let front = walled.irradiance([0.3, 0.0, 0.0], n)[0];
        assert!(front > 0.9 * std::f32::consts::PI, "{front}");
    }

    #[test]
    fn a_single_probe_grid_gives_that_probes_irradiance() {
        let mut p = ShProjector::default();
        for d in fibonacci_sphere(1024, 0.0) {
            p.add(d, [0.5, 1.0, 2.0]);
        }
        let grid = ProbeGrid {
            depth_fingerprint: 0,
            origin: [1.0, 2.0, 3.0],
            spacing: [1.0; 3],
            counts: [1, 1, 1],
            radiance_sh: vec![p.finish()],
            visibility: vec![[100.0, 10000.0]; VISIBILITY_TEXELS * VISIBILITY_TEXELS],
            emitters_seen: false,
        };
        let e = grid.irradiance([1.2, 2.0, 3.1], [0.0, 0.0, 1.0]);
        for (c, l) in [0.5f32, 1.0, 2.0].iter().enumerate() {
            assert!((e[c] - std::f32::consts::PI * l).abs() < 2e-3 * l, "{e:?}");
        }
    }
}

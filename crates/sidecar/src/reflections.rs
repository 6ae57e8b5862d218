//! Reflection probes: a coarse grid of probes, each holding an octahedral map of the radiance
//! arriving at it, prefiltered into mip levels for increasing roughness of the ray tracer's
//! glossy (Blinn) lobe (split-sum prefiltered radiance, Karis 2013), and the distance to the
//! first surface per texel so that a viewer can parallax-correct and choose probes
//! (docs/sidecar.md). [`ReflectionProbes::sample_level`] and
//! [`ReflectionProbes::glossy_radiance`] are the reference lookups the viewer ports to WGSL
//! (`glossy_radiance` averages the probes around a point over the ray tracer's lobe, leaving out
//! those a wall hides); [`ReflectionProbes::radiance`] is the split sum's single lookup toward
//! the mirror direction.

use crate::probes::{octahedral_direction, octahedral_uv};
use std::f32::consts::PI;
use std::path::Path;

/// Texels per side of level 0 of a reflection probe's octahedral map.
pub const REFLECTION_TEXELS: usize = 32;

/// Mip levels per probe: `32, 16, 8, 4, 2` texels per side.
pub const REFLECTION_LEVELS: usize = 5;

/// Blinn exponent the prefilter of level 1 uses; each further level uses a quarter of the
/// previous one's (64, 16, 4, 1), so that the lobe's angular width doubles as the texels do.
const LEVEL_1_EXPONENT: f32 = 64.0;

/// Texels per side of level `level` (`REFLECTION_TEXELS >> level`).
pub fn reflection_level_texels(level: usize) -> usize {
    (REFLECTION_TEXELS >> level.min(REFLECTION_LEVELS - 1)).max(1)
}

/// The Blinn exponent of `plastic`, `metal` and `shinymetal` for RenderMan's `roughness`, as
/// the ray tracer's materials compute it: `1 / max(roughness, 1e-4)`, clamped to `[1, 10^4]`.
pub fn blinn_exponent(roughness: f32) -> f32 {
    (1.0 / roughness.max(1e-4)).clamp(1.0, 10_000.0)
}

/// The Blinn exponent level `level` is prefiltered with: `None` for level 0 (the unfiltered
/// radiance, a mirror), `64 / 4^(level - 1)` above.
pub fn reflection_level_exponent(level: usize) -> Option<f32> {
    (level > 0).then(|| LEVEL_1_EXPONENT / 4f32.powi(level.min(REFLECTION_LEVELS - 1) as i32 - 1))
}

/// The roughness level `level` is prefiltered for (`1 / exponent`; 0 for level 0):
/// `0, 1/64, 1/16, 1/4, 1`.
pub fn reflection_level_roughness(level: usize) -> f32 {
    reflection_level_exponent(level).map_or(0.0, |e| 1.0 / e)
}

/// The (fractional) mip level a shader samples for a surface of RenderMan `roughness`: with
/// `e = blinn_exponent(roughness)`, `64 / e` for `e >= 64` (between the mirror level 0 and
/// level 1), else `1 + log4(64 / e)`; at most `REFLECTION_LEVELS - 1`. The level's own
/// roughness maps to the level exactly.
pub fn reflection_level(roughness: f32) -> f32 {
    let e = blinn_exponent(roughness);
    let level =
        if e >= LEVEL_1_EXPONENT { LEVEL_1_EXPONENT / e } else { 1.0 + (LEVEL_1_EXPONENT / e).log(4.0) };
    level.clamp(0.0, (REFLECTION_LEVELS - 1) as f32)
}

/// The prefilter's kernel: the ray tracer's Blinn lobe (`D(h) G / 4`, pbrt-v1's Blinn
/// distribution with V-cavity shadowing, `ks = 1`) at normal incidence, with the view
/// direction and the normal both along the reflected direction `r` (the split-sum
/// approximation's `n = v = r`), as a weight of unit incoming direction `l`. Its integral over
/// `l` is the lobe's albedo at normal incidence.
pub fn reflection_lobe(r: [f32; 3], l: [f32; 3], exponent: f32) -> f32 {
    let cos_l = dot(r, l);
    if cos_l <= 0.0 {
        return 0.0;
    }
    // The half vector of r and l makes half their angle with r.
    let cos_h = ((1.0 + cos_l) * 0.5).sqrt();
    let d = (exponent + 2.0) / (2.0 * PI) * cos_h.powf(exponent);
    let g = (2.0 * cos_l).min(1.0);
    d * g * 0.25
}

/// The split sum's second factor (Karis 2013): the directional albedo of the ray tracer's Blinn
/// lobe for `ks = 1`, `A(e, cos_o) = integral of f(o, l) cos(theta_l) dl` over the upper
/// hemisphere, with `f = D(h) G / (4 cos_o cos_l)` exactly as `raytracer::bsdf` evaluates it
/// (no Fresnel: `ks` plays its part). A glossy live surface reflects
/// `ks * blinn_albedo(e, n.v) * ReflectionProbes::sample(probe, r, roughness)`. Integrated over
/// the half vector with the lobe's own importance sampling (`cos_h = u^(1/(e+1))`) on a 64 x 64
/// midpoint grid, which makes the integrand smooth: `(e + 2) / (e + 1) G (o.h) / cos_o`.
/// `cos_o` is clamped to `[1e-3, 1]`.
pub fn blinn_albedo(exponent: f32, cos_o: f32) -> f32 {
    const STEPS: usize = 64;
    let e = f64::from(exponent.max(0.0));
    let cos_o = f64::from(cos_o).clamp(1e-3, 1.0);
    let o = [(1.0 - cos_o * cos_o).max(0.0).sqrt(), 0.0, cos_o];
    let mut sum = 0.0f64;
    for a in 0..STEPS {
        let u = (a as f64 + 0.5) / STEPS as f64;
        let cos_h = u.powf(1.0 / (e + 1.0));
        let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
        for b in 0..STEPS {
            let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / STEPS as f64;
            let h = [sin_h * phi.cos(), sin_h * phi.sin(), cos_h];
            let o_dot_h = o[0] * h[0] + o[2] * h[2];
            if o_dot_h <= 0.0 {
                continue;
            }
            // The reflected direction must stay above the surface.
            let cos_l = 2.0 * o_dot_h * h[2] - cos_o;
            if cos_l <= 0.0 {
                continue;
            }
            // V-cavity shadowing-masking (Torrance-Sparrow, as raytracer::bsdf).
            let g = (2.0 * cos_h * cos_o / o_dot_h).min(2.0 * cos_h * cos_l / o_dot_h).min(1.0);
            sum += (e + 2.0) / (e + 1.0) * g * o_dot_h / cos_o;
        }
    }
    (sum / (STEPS * STEPS) as f64) as f32
}

/// The direction through the centre of texel `texel` (row-major, `v` as the row) of an
/// octahedral map of `texels` per side.
pub fn octahedral_texel_center(texels: usize, texel: usize) -> [f32; 3] {
    let (i, j) = (texel % texels, texel / texels);
    octahedral_direction([(i as f32 + 0.5) / texels as f32, (j as f32 + 0.5) / texels as f32])
}

/// The solid angle of texel `texel` of an octahedral map of `texels` per side. The map sends
/// the point `p` of the octahedron `|x| + |y| + |z| = 1` to `p / |p|`, whose Jacobian is
/// `1 / |p|^3` per unit of octahedron area (the folding of the lower half keeps area), and the
/// square `[0, 1]^2` is a quarter of the octahedron's projected area: `4 / |p|^3` per unit of
/// `uv` area, integrated here with 4x4 points per texel. The texels sum to `4 pi`.
pub fn octahedral_texel_solid_angle(texels: usize, texel: usize) -> f32 {
    const SUB: usize = 4;
    let (i, j) = (texel % texels, texel / texels);
    let n = texels as f32;
    let mut sum = 0.0f32;
    for a in 0..SUB {
        for b in 0..SUB {
            let u = (i as f32 + (a as f32 + 0.5) / SUB as f32) / n * 2.0 - 1.0;
            let v = (j as f32 + (b as f32 + 0.5) / SUB as f32) / n * 2.0 - 1.0;
            let z = 1.0 - u.abs() - v.abs();
            // |p| is the same on both halves: the fold moves (x, y) but keeps |x| + |y| + |z|.
            let (x, y) =
                if z < 0.0 { ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum()) } else { (u, v) };
            let len = (x * x + y * y + z * z).sqrt();
            sum += 4.0 / (len * len * len);
        }
    }
    sum / (SUB * SUB) as f32 / (n * n)
}

/// Prefilters the octahedral radiance map `base` (`REFLECTION_TEXELS^2` texels) with the
/// [`reflection_lobe`] of `exponent` into a map of `texels` per side: each output texel is the
/// lobe-weighted mean (weights times the source texels' solid angles, normalised by their sum)
/// of the source texels around the output texel's direction. A constant map stays constant.
pub fn prefilter_radiance(base: &[[f32; 3]], exponent: f32, texels: usize) -> Vec<[f32; 3]> {
    let source = source_texels();
    (0..texels * texels)
        .map(|t| {
            let r = octahedral_texel_center(texels, t);
            let mut sum = [0.0f64; 3];
            let mut total = 0.0f64;
            for ((l, solid_angle), radiance) in source.iter().zip(base) {
                let w = reflection_lobe(r, *l, exponent) * solid_angle;
                if w > 0.0 {
                    total += f64::from(w);
                    for c in 0..3 {
                        sum[c] += f64::from(w * radiance[c]);
                    }
                }
            }
            if total > 0.0 { sum.map(|s| (s / total) as f32) } else { [0.0; 3] }
        })
        .collect()
}

/// Every mip level of a probe from its level-0 radiance map `base` (`REFLECTION_TEXELS^2`
/// texels): level 0 is `base` itself, level `k` is `base` prefiltered with
/// [`reflection_level_exponent`]`(k)` at [`reflection_level_texels`]`(k)`.
pub fn reflection_levels(base: &[[f32; 3]]) -> Vec<Vec<[f32; 3]>> {
    (0..REFLECTION_LEVELS)
        .map(|k| match reflection_level_exponent(k) {
            None => base.to_vec(),
            Some(e) => prefilter_radiance(base, e, reflection_level_texels(k)),
        })
        .collect()
}

/// Directions and solid angles of the level-0 texels.
fn source_texels() -> Vec<([f32; 3], f32)> {
    let n = REFLECTION_TEXELS;
    (0..n * n).map(|t| (octahedral_texel_center(n, t), octahedral_texel_solid_angle(n, t))).collect()
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A grid of reflection probes in world space.
#[derive(Debug, Clone, PartialEq)]
pub struct ReflectionProbes {
    /// [`crate::depth_fingerprint`] of the depth table rendered with these probes.
    pub depth_fingerprint: u64,
    /// World position of probe `(0, 0, 0)`.
    pub origin: [f32; 3],
    /// Distance between neighbouring probes along x, y, z (each > 0).
    pub spacing: [f32; 3],
    /// Probes along x, y, z (each >= 1).
    pub counts: [u32; 3],
    /// `REFLECTION_LEVELS` levels; level `k` holds, per probe (x fastest, then y, then z),
    /// `reflection_level_texels(k)^2` texels (row-major octahedral map) of RGB radiance in the
    /// image's units.
    pub radiance: Vec<Vec<[f32; 3]>>,
    /// Per probe, `REFLECTION_TEXELS^2` texels: the distance from the probe to the first
    /// surface through the texel's centre (`2 * |bounds diagonal|` where the ray leaves).
    pub distance: Vec<f32>,
    /// Per probe, `REFLECTION_TEXELS^2` texels as `distance`: whether that first surface
    /// sends light only along specular paths (a mirror or glass), so the texel's radiance is
    /// an image that changes with the viewpoint, not the surface's own; empty where no texel's
    /// is (a file without the `specular` layer reads so: docs/sidecar.md).
    pub specular: Vec<bool>,
}

impl ReflectionProbes {
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

    /// The grid cell of the probe nearest to world point `p`.
    pub fn nearest_probe(&self, p: [f32; 3]) -> [u32; 3] {
        std::array::from_fn(|a| {
            let t = ((p[a] - self.origin[a]) / self.spacing[a]).round();
            if t.is_finite() { t.clamp(0.0, (self.counts[a] - 1) as f32) as u32 } else { 0 }
        })
    }

    /// Radiance arriving at probe `probe` from unit direction `dir`, prefiltered for
    /// `roughness`: what one `textureSampleLevel(map, clamp-to-edge linear sampler, uv, level)`
    /// returns, with `uv = octahedral_uv(dir)` and `level = reflection_level(roughness)`
    /// (bilinear within a level, linear between levels).
    pub fn sample(&self, probe: usize, dir: [f32; 3], roughness: f32) -> [f32; 3] {
        self.sample_level(probe, dir, reflection_level(roughness))
    }

    /// [`ReflectionProbes::sample`] at the fractional mip level `level` (clamped to the levels).
    pub fn sample_level(&self, probe: usize, dir: [f32; 3], level: f32) -> [f32; 3] {
        let level = if level.is_nan() { 0.0 } else { level.clamp(0.0, (REFLECTION_LEVELS - 1) as f32) };
        let below = (level.floor() as usize).min(REFLECTION_LEVELS - 1);
        let above = (below + 1).min(REFLECTION_LEVELS - 1);
        let t = level - below as f32;
        let uv = octahedral_uv(dir);
        let a = self.bilinear(probe, below, uv);
        let b = self.bilinear(probe, above, uv);
        std::array::from_fn(|c| a[c] + (b[c] - a[c]) * t)
    }

    fn bilinear(&self, probe: usize, level: usize, uv: [f32; 2]) -> [f32; 3] {
        let n = reflection_level_texels(level);
        let map = &self.radiance[level][probe * n * n..(probe + 1) * n * n];
        let x = (uv[0] * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
        let y = (uv[1] * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(n - 1), (y0 + 1).min(n - 1));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        std::array::from_fn(|c| {
            let top = map[y0 * n + x0][c] * (1.0 - fx) + map[y0 * n + x1][c] * fx;
            let bottom = map[y1 * n + x0][c] * (1.0 - fx) + map[y1 * n + x1][c] * fx;
            top * (1.0 - fy) + bottom * fy
        })
    }

    /// Distance from probe `probe` to the first surface toward unit direction `dir` (the
    /// level-0 texel it falls in).
    pub fn distance_toward(&self, probe: usize, dir: [f32; 3]) -> f32 {
        self.distance[Self::texel_toward(probe, dir)]
    }

    /// Whether the first surface toward unit direction `dir` from probe `probe` is specular
    /// (the texel [`ReflectionProbes::distance_toward`] reads; false where `specular` is empty).
    pub fn specular_toward(&self, probe: usize, dir: [f32; 3]) -> bool {
        !self.specular.is_empty() && self.specular[Self::texel_toward(probe, dir)]
    }

    /// The index of probe `probe`'s level-0 texel that unit direction `dir` falls in.
    fn texel_toward(probe: usize, dir: [f32; 3]) -> usize {
        let n = REFLECTION_TEXELS;
        let [u, v] = octahedral_uv(dir);
        let i = ((u * n as f32) as usize).min(n - 1);
        let j = ((v * n as f32) as usize).min(n - 1);
        probe * n * n + j * n + i
    }

    /// Glossy reflection at world point `p` for the unit reflected direction `r`: the 8 probes
    /// of the grid cell around `p` (fewer at the grid's edges), each looked up parallax-corrected
    /// ([`ReflectionProbes::radiance_from`]), weighted trilinearly, and a probe whose distance
    /// map does not reach `p` (a wall between them) only by `1e-3` of that, so light does not
    /// leak through walls; with no probe seeing `p`, the trilinear mean.
    pub fn radiance(&self, p: [f32; 3], r: [f32; 3], roughness: f32) -> [f32; 3] {
        let mut sum = [0.0f32; 3];
        let mut total = 0.0f32;
        for (cell, w) in self.corner_weights(p) {
            let l = self.radiance_from(cell, p, r, roughness);
            for c in 0..3 {
                sum[c] += w * l[c];
            }
            total += w;
        }
        if total > 0.0 {
            sum.map(|v| v / total)
        } else {
            self.radiance_from(self.nearest_probe(p), p, r, roughness)
        }
    }

    /// Whether the probe of grid cell `cell` sees world point `p`: `p` is no farther from it
    /// than its distance map reaches toward `p` (5 % slack for the texels' coarseness).
    pub fn sees(&self, cell: [u32; 3], p: [f32; 3]) -> bool {
        let c = self.probe_position(cell);
        let to_p: [f32; 3] = std::array::from_fn(|a| p[a] - c[a]);
        let d = dot(to_p, to_p).sqrt();
        if d.is_nan() || d <= 0.0 {
            return true;
        }
        d <= 1.05 * self.distance_toward(self.probe_index(cell), to_p.map(|v| v / d))
    }

    /// The probes' radiance averaged over the ray tracer's Blinn lobe at world point `p` with
    /// unit normal `n` and unit direction to the eye `v` (the reference `composite.wgsl`'s
    /// `glossy_reflection` ports): the lobe's [`GLOSSY_SAMPLES`] directions
    /// ([`glossy_lobe_directions`]), each weighted by `f cos / pdf`, meet the scene where the
    /// probe of the largest weight (trilinear, a probe that does not see `p` by `1e-3` of it)
    /// finds it by its distance map ([`ReflectionProbes::hit_toward`]); every probe around `p`
    /// is read toward those points at each direction's level, and the probes are weighted as in
    /// [`ReflectionProbes::radiance`]. Times [`blinn_albedo`] it is the lobe's reflection.
    /// A direction whose point is on a specular surface (`specular`, that probe's texel) is read
    /// in the direction itself, as a distant scene's: a probe holds, toward a mirror or glass,
    /// the image its own place sees, and moved to `p` by the parallax it shows another (a glass
    /// ball's lens image, docs/viewer-specular.md).
    pub fn glossy_radiance(&self, p: [f32; 3], n: [f32; 3], v: [f32; 3], exponent: f32) -> [f32; 3] {
        let lobe = glossy_lobe_directions(n, v, exponent);
        let lobe_total: f32 = lobe.iter().map(|d| d.weight).sum();
        // Also when the total is not a number.
        if lobe_total.is_nan() || lobe_total <= 0.0 {
            return [0.0; 3];
        }
        let corners = self.corner_weights(p);
        // The first of the largest, as the shader's strict comparison keeps it.
        let Some(&(nearest, _)) = corners.iter().fold(None, |best: Option<&([u32; 3], f32)>, c| match best {
            Some(b) if b.1 >= c.1 => Some(b),
            _ => Some(c),
        }) else {
            return [0.0; 3];
        };
        let hits: Vec<[f32; 3]> = lobe.iter().map(|d| self.hit_toward(nearest, p, d.direction)).collect();
        let nearest_origin = self.probe_position(nearest);
        let on_specular: Vec<bool> = hits
            .iter()
            .map(|hit| {
                let to_hit: [f32; 3] = std::array::from_fn(|a| hit[a] - nearest_origin[a]);
                let len = dot(to_hit, to_hit).sqrt();
                len > 0.0 && self.specular_toward(self.probe_index(nearest), to_hit.map(|x| x / len))
            })
            .collect();
        let (mut sum, mut total) = ([0.0f32; 3], 0.0f32);
        for &(cell, w) in &corners {
            let probe = self.probe_index(cell);
            let origin = self.probe_position(cell);
            for ((d, hit), &specular) in lobe.iter().zip(&hits).zip(&on_specular) {
                let to_hit: [f32; 3] = std::array::from_fn(|a| hit[a] - origin[a]);
                let len = dot(to_hit, to_hit).sqrt();
                let dir = if len > 0.0 && !specular { to_hit.map(|x| x / len) } else { d.direction };
                let l = self.sample_level(probe, dir, d.level);
                for c in 0..3 {
                    sum[c] += w * d.weight * l[c];
                }
            }
            total += w;
        }
        if total > 0.0 { sum.map(|x| x / (total * lobe_total)) } else { [0.0; 3] }
    }

    /// The probes of the grid cell around `p` (fewer at the grid's edges) with their weights:
    /// trilinear, and `1e-3` of that for a probe that does not see `p` (a wall between them).
    fn corner_weights(&self, p: [f32; 3]) -> Vec<([u32; 3], f32)> {
        let (base, alpha) = self.grid_cell(p);
        let mut corners = Vec::with_capacity(8);
        for corner in 0..8u32 {
            let offset = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let trilinear: f32 =
                (0..3).map(|a| if offset[a] == 1 { alpha[a] } else { 1.0 - alpha[a] }).product();
            if trilinear <= 0.0 {
                continue;
            }
            let cell: [u32; 3] = std::array::from_fn(|a| (base[a] + offset[a]).min(self.counts[a] - 1));
            corners.push((cell, if self.sees(cell, p) { trilinear } else { 1e-3 * trilinear }));
        }
        corners
    }

    /// The grid cell below `p` and `p`'s fractions across it, clamped to the grid.
    fn grid_cell(&self, p: [f32; 3]) -> ([u32; 3], [f32; 3]) {
        let mut base = [0u32; 3];
        let mut alpha = [0.0f32; 3];
        for a in 0..3 {
            let last = self.counts[a].saturating_sub(1);
            let t = (p[a] - self.origin[a]) / self.spacing[a];
            let t = if t.is_finite() { t.clamp(0.0, last as f32) } else { 0.0 };
            let b = (t.floor() as u32).min(last.saturating_sub(1));
            base[a] = b;
            alpha[a] = if last == 0 { 0.0 } else { t - b as f32 };
        }
        (base, alpha)
    }

    /// Where the ray `p + t r` (world space, unit `r`) meets the surface the distance map of the
    /// probe of grid cell `cell` describes: the three fixed-point steps of
    /// [`ReflectionProbes::radiance_from`], as a world point.
    pub fn hit_toward(&self, cell: [u32; 3], p: [f32; 3], r: [f32; 3]) -> [f32; 3] {
        let c = self.probe_position(cell);
        let (hit, _) = self.parallax_steps(cell, p, r);
        std::array::from_fn(|a| c[a] + hit[a])
    }

    /// Parallax-corrected reflection from the probe of grid cell `cell` at world point `p` for
    /// the unit reflected direction `r`: the probe is looked up toward the point where the ray
    /// `p + t r` meets the surface its distance map describes, found by three fixed-point steps
    /// (start at the probe's distance toward `r`; each step intersects the ray with the sphere
    /// around the probe whose radius is the probe's distance toward the current estimate).
    pub fn radiance_from(&self, cell: [u32; 3], p: [f32; 3], r: [f32; 3], roughness: f32) -> [f32; 3] {
        let (_, dir) = self.parallax_steps(cell, p, r);
        self.sample(self.probe_index(cell), dir, roughness)
    }

    /// The fixed-point steps both lookups share: the hit relative to the probe (`p` itself when
    /// the ray misses the first sphere) and the direction the probe is read in (`r` then).
    fn parallax_steps(&self, cell: [u32; 3], p: [f32; 3], r: [f32; 3]) -> ([f32; 3], [f32; 3]) {
        let probe = self.probe_index(cell);
        let c = self.probe_position(cell);
        let pc: [f32; 3] = std::array::from_fn(|a| p[a] - c[a]);
        let mut hit = pc;
        let mut dir = r;
        for _ in 0..3 {
            let radius = self.distance_toward(probe, dir);
            // |pc + t r| = radius, the far root (p is inside the sphere when the probe sees
            // past it).
            let b = dot(pc, r);
            let disc = b * b - (dot(pc, pc) - radius * radius);
            if disc < 0.0 {
                break;
            }
            let t = (-b + disc.sqrt()).max(0.0);
            hit = std::array::from_fn(|a| pc[a] + t * r[a]);
            let len = dot(hit, hit).sqrt();
            if len.is_nan() || len <= 0.0 {
                break;
            }
            dir = hit.map(|v| v / len);
        }
        (hit, dir)
    }
}

/// Directions of the Blinn lobe a glossy live surface reads the reflection probes in
/// ([`ReflectionProbes::glossy_radiance`], `composite.wgsl` GLOSSY_SAMPLES).
pub const GLOSSY_SAMPLES: usize = 16;

/// One of the lobe's directions: unit world direction, weight `f cos / pdf` (0 below the
/// surface) and the mip level to read it at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeDirection {
    pub direction: [f32; 3],
    pub weight: f32,
    pub level: f32,
}

/// The ray tracer's Blinn lobe (`exponent`) at unit normal `n` seen from unit direction `v`,
/// importance-sampled by its half vector at a fixed stratified set (`cos_h = u^(1/(e+1))` at
/// `u = (i + 0.5) / N`, `phi = 2 pi` times `i`'s bits reversed), each direction weighted by
/// `f cos / pdf = (e + 2) / (e + 1) G (o.h) / cos_o` up to the constant factor and read at the
/// mip level whose prefiltering lobe spans the solid angle the direction stands for,
/// `1 / (N pdf)` (a lobe of exponent `e` spans about `8 pi / e` steradians; Krivanek and
/// Colbert 2008). A wide lobe seen at a grazing angle leans toward the normal and loses its part
/// below the horizon, which one lookup toward the mirror direction (the split sum) misses.
pub fn glossy_lobe_directions(n: [f32; 3], v: [f32; 3], exponent: f32) -> Vec<LobeDirection> {
    let cos_o = dot(n, v).max(1e-3);
    let helper = if n[0].abs() > 0.9 { [0.0, 1.0, 0.0] } else { [1.0, 0.0, 0.0] };
    let t = normalized(cross(helper, n));
    let b = cross(n, t);
    (0..GLOSSY_SAMPLES as u32)
        .map(|i| {
            let below = LobeDirection { direction: n, weight: 0.0, level: 0.0 };
            let u1 = (i as f32 + 0.5) / GLOSSY_SAMPLES as f32;
            let u2 = i.reverse_bits() as f32 * 2.328_306_4e-10;
            let cos_h = u1.powf(1.0 / (exponent + 1.0));
            let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
            let phi = 2.0 * PI * u2;
            let h = normalized(std::array::from_fn(|a| {
                t[a] * sin_h * phi.cos() + b[a] * sin_h * phi.sin() + n[a] * cos_h
            }));
            let o_dot_h = dot(v, h);
            if o_dot_h <= 0.0 {
                return below;
            }
            let l: [f32; 3] = std::array::from_fn(|a| 2.0 * o_dot_h * h[a] - v[a]);
            let cos_l = dot(n, l);
            if cos_l <= 0.0 {
                return below;
            }
            let g = (2.0 * cos_h * cos_o / o_dot_h).min(2.0 * cos_h * cos_l / o_dot_h).min(1.0);
            let pdf = (exponent + 1.0) * cos_h.powf(exponent) / (8.0 * PI * o_dot_h);
            let omega = 1.0 / (GLOSSY_SAMPLES as f32 * pdf.max(1e-6));
            LobeDirection {
                direction: l,
                weight: g * o_dot_h / cos_o,
                level: exponent_level(8.0 * PI / omega),
            }
        })
        .collect()
}

/// The mip level prefiltered with Blinn exponent `e` ([`reflection_level`] of roughness `1 / e`).
fn exponent_level(e: f32) -> f32 {
    let level =
        if e >= LEVEL_1_EXPONENT { LEVEL_1_EXPONENT / e } else { 1.0 + 0.5 * (LEVEL_1_EXPONENT / e).log2() };
    level.clamp(0.0, (REFLECTION_LEVELS - 1) as f32)
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn normalized(a: [f32; 3]) -> [f32; 3] {
    let len = dot(a, a).sqrt();
    if len > 0.0 { a.map(|x| x / len) } else { a }
}

/// What a reader says when a render has no reflection probes file (an `lrt-depth` from before
/// reflection probes, or a render without layers): glossy live materials then fall back.
pub fn reflections_absent_note(path: &Path) -> String {
    format!(
        "{}: note: no reflection probes (the render predates them or wrote no layers); glossy live surfaces reflect only the RIB's lights (area lights as points), not the scene",
        path.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed form of the lobe's integral over incoming directions (its albedo at normal
    /// incidence): with `c = cos(theta_h)`, `l` at twice `h`'s angle and `dl = 4 c dh`,
    /// `(e + 2) [ int_{1/sqrt2}^{sqrt3/2} c^(e+1) (4c^2 - 2) dc + int_{sqrt3/2}^1 c^(e+1) dc ]`.
    fn lobe_albedo(e: f64) -> f64 {
        let (a, b) = (0.5f64.sqrt(), 0.75f64.sqrt());
        let shadowed = |c: f64| 4.0 * c.powf(e + 4.0) / (e + 4.0) - 2.0 * c.powf(e + 2.0) / (e + 2.0);
        let lit = |c: f64| c.powf(e + 2.0) / (e + 2.0);
        (e + 2.0) * (shadowed(b) - shadowed(a) + lit(1.0) - lit(b))
    }

    #[test]
    fn texel_solid_angles_cover_the_sphere() {
        for n in [2, 8, REFLECTION_TEXELS] {
            let total: f32 = (0..n * n).map(|t| octahedral_texel_solid_angle(n, t)).sum();
            assert!((total - 4.0 * PI).abs() < 2e-3 * 4.0 * PI, "{n}: {total}");
        }
    }

    #[test]
    fn roughness_maps_to_levels_as_documented() {
        assert_eq!(reflection_level_texels(0), 32);
        assert_eq!(reflection_level_texels(4), 2);
        assert_eq!(reflection_level_roughness(0), 0.0);
        for (k, r) in [(1, 1.0 / 64.0), (2, 1.0 / 16.0), (3, 0.25), (4, 1.0)] {
            assert_eq!(reflection_level_roughness(k), r);
            assert!((reflection_level(r) - k as f32).abs() < 1e-5, "{k}: {}", reflection_level(r));
        }
        // Between levels, monotonic; a mirror-like surface reads (almost) level 0; past
        // roughness 1 the exponent stops at 1 and so does the level.
        assert!(reflection_level(0.0) < 0.01);
        assert!((reflection_level(0.1) - (1.0 + 6.4f32.log(4.0))).abs() < 1e-5);
        assert_eq!(reflection_level(5.0), 4.0);
        assert_eq!(reflection_level(f32::NAN), reflection_level(0.0));
        let mut last = -1.0;
        for i in 0..200 {
            let l = reflection_level(i as f32 * 0.01);
            assert!(l >= last);
            last = l;
        }
    }

    #[test]
    fn the_lobe_integrates_to_its_closed_form() {
        let source = source_texels();
        let r = octahedral_direction([0.3, 0.6]);
        for e in [1.0f32, 4.0, 16.0, 64.0] {
            let sum: f64 = source.iter().map(|(l, w)| f64::from(reflection_lobe(r, *l, e) * w)).sum();
            let exact = lobe_albedo(f64::from(e));
            assert!((sum - exact).abs() < 0.01 * exact, "e {e}: {sum} vs {exact}");
        }
    }

    /// `blinn_albedo` against a brute-force sum of `f cos` over fine octahedral texels.
    #[test]
    fn the_split_sum_albedo_is_the_lobes_directional_albedo() {
        let n = 256;
        let texels: Vec<([f32; 3], f32)> =
            (0..n * n).map(|t| (octahedral_texel_center(n, t), octahedral_texel_solid_angle(n, t))).collect();
        for e in [1.0f32, 4.0, 16.0] {
            assert!((blinn_albedo(e, 1.0) - lobe_albedo(f64::from(e)) as f32).abs() < 5e-3, "e {e}");
            for cos_o in [1.0f32, 0.7, 0.3] {
                let o = [(1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o];
                let brute: f32 = texels
                    .iter()
                    .filter(|(l, _)| l[2] > 0.0)
                    .map(|(l, w)| {
                        let h = {
                            let s = [o[0] + l[0], o[1] + l[1], o[2] + l[2]];
                            let len = dot(s, s).sqrt();
                            s.map(|v| v / len)
                        };
                        let d = (e + 2.0) / (2.0 * PI) * h[2].powf(e);
                        let o_h = dot(o, h);
                        let g = (2.0 * h[2] * cos_o / o_h).min(2.0 * h[2] * l[2] / o_h).min(1.0);
                        d * g / (4.0 * cos_o * l[2]) * l[2] * w
                    })
                    .sum();
                let a = blinn_albedo(e, cos_o);
                assert!((a - brute).abs() < 0.01 * brute, "e {e} cos_o {cos_o}: {a} vs {brute}");
            }
        }
    }

    #[test]
    fn a_constant_map_stays_constant_at_every_level() {
        let base = vec![[0.25f32, 1.0, 4.0]; REFLECTION_TEXELS * REFLECTION_TEXELS];
        for (k, level) in reflection_levels(&base).iter().enumerate() {
            assert_eq!(level.len(), reflection_level_texels(k).pow(2));
            for v in level {
                for c in 0..3 {
                    assert!((v[c] - base[0][c]).abs() < 1e-5 * base[0][c], "level {k}: {v:?}");
                }
            }
        }
    }

    #[test]
    fn one_bright_texel_spreads_into_the_lobe_and_keeps_its_energy() {
        let n = REFLECTION_TEXELS;
        let bright = 17 * n + 9;
        let l0 = octahedral_texel_center(n, bright);
        let omega = octahedral_texel_solid_angle(n, bright);
        let mut base = vec![[0.0f32; 3]; n * n];
        base[bright] = [1.0, 2.0, 0.0];
        let levels = reflection_levels(&base);
        for (k, level) in levels.iter().enumerate().skip(1) {
            let e = reflection_level_exponent(k).unwrap();
            let m = reflection_level_texels(k);
            let albedo = lobe_albedo(f64::from(e)) as f32;
            for (t, v) in level.iter().enumerate() {
                let r = octahedral_texel_center(m, t);
                // Shape: the lobe around each output direction, normalised by its albedo.
                let expected = omega * reflection_lobe(r, l0, e) / albedo;
                assert!(
                    (v[0] - expected).abs() <= 0.03 * expected + 1e-6,
                    "level {k} texel {t}: {v:?} vs {expected}"
                );
                assert!((v[1] - 2.0 * v[0]).abs() <= 1e-6 * v[1].abs() + 1e-12);
                assert_eq!(v[2], 0.0);
            }
            // Energy: spreading moves light between directions and loses none (integrated over
            // the same filter's output at full resolution, which resolves every lobe).
            let fine = prefilter_radiance(&base, e, n);
            let energy: f32 =
                fine.iter().enumerate().map(|(t, v)| v[0] * octahedral_texel_solid_angle(n, t)).sum();
            assert!((energy - omega).abs() < 0.02 * omega, "level {k}: {energy} vs {omega}");
        }
    }

    fn box_probe(radiance: impl Fn([f32; 3]) -> [f32; 3]) -> ReflectionProbes {
        // One probe at the centre of the cube [-1, 1]^3: distances to the walls.
        let n = REFLECTION_TEXELS;
        let base: Vec<[f32; 3]> = (0..n * n).map(|t| radiance(octahedral_texel_center(n, t))).collect();
        let distance = (0..n * n)
            .map(|t| {
                let d = octahedral_texel_center(n, t);
                1.0 / d.iter().fold(0.0f32, |m, v| m.max(v.abs()))
            })
            .collect();
        ReflectionProbes {
            depth_fingerprint: 0,
            origin: [0.0; 3],
            spacing: [2.0; 3],
            counts: [1, 1, 1],
            radiance: reflection_levels(&base),
            distance,
            specular: Vec::new(),
        }
    }

    /// Probes at x = 0 (seeing red everywhere) and x = 1 (blue), a wall at x = 0.5 between.
    #[test]
    fn a_probe_behind_a_wall_does_not_reflect_into_the_other_side() {
        let n = REFLECTION_TEXELS;
        let map = |rgb: [f32; 3]| reflection_levels(&vec![rgb; n * n]);
        let (red, blue) = (map([1.0, 0.0, 0.0]), map([0.0, 0.0, 1.0]));
        let radiance = (0..REFLECTION_LEVELS).map(|k| [red[k].clone(), blue[k].clone()].concat()).collect();
        let mut distance = Vec::new();
        for toward_wall in [1.0f32, -1.0] {
            for t in 0..n * n {
                let d = octahedral_texel_center(n, t);
                // The wall is 0.5 away along x; rays leaving at a slant meet it farther away.
                distance.push(if d[0] * toward_wall > 0.05 {
                    (0.5 / (d[0] * toward_wall)).min(10.0)
                } else {
                    10.0
                });
            }
        }
        let probes = ReflectionProbes {
            depth_fingerprint: 0,
            origin: [0.0; 3],
            spacing: [1.0; 3],
            counts: [2, 1, 1],
            radiance,
            distance,
            specular: Vec::new(),
        };
        let up = [0.0, 1.0, 0.0];
        assert!(probes.sees([0, 0, 0], [0.4, 0.0, 0.0]) && !probes.sees([1, 0, 0], [0.4, 0.0, 0.0]));
        let left = probes.radiance([0.4, 0.0, 0.0], up, 0.25);
        let right = probes.radiance([0.6, 0.0, 0.0], up, 0.25);
        assert!(left[0] > 0.99 && left[2] < 0.01, "{left:?}");
        assert!(right[2] > 0.99 && right[0] < 0.01, "{right:?}");
    }

    #[test]
    fn parallax_correction_finds_the_wall_the_reflected_ray_meets() {
        // The +x wall is red where y > 0 and blue below, the other walls black. Seen from
        // (0.8, -0.5, 0) along (0.6, 0.8, 0) the ray meets the +x wall at y = -0.23 (blue),
        // while the probe itself sees the black ceiling along that direction.
        let probes = box_probe(|d| {
            let t = 1.0 / d.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            let hit = d.map(|v| v * t);
            if hit[0] > 0.999 && hit[1] > 0.0 {
                [1.0, 0.0, 0.0]
            } else if hit[0] > 0.999 {
                [0.0, 0.0, 1.0]
            } else {
                [0.0; 3]
            }
        });
        let r = [0.6, 0.8, 0.0];
        let naive = probes.sample(0, r, 0.0);
        let corrected = probes.radiance([0.8, -0.5, 0.0], r, 0.0);
        assert!(naive[0] < 0.1 && naive[2] < 0.1, "{naive:?}");
        assert!(corrected[2] > 0.9 && corrected[0] < 0.1, "{corrected:?}");
        // The distance map is the cube's.
        assert!((probes.distance_toward(0, [0.0, -1.0, 0.0]) - 1.0).abs() < 1e-3);
    }

    /// The lobe's directions carry `f cos / pdf`: their mean is the lobe's directional albedo
    /// (16 fixed directions against `blinn_albedo`'s 4096, within 6 %), they stay above the
    /// surface, and a grazing view leans them toward the normal, away from the mirror direction.
    #[test]
    fn the_lobe_s_directions_integrate_its_albedo_and_lean_toward_the_normal() {
        let n = [0.0, 0.0, 1.0];
        for (e, cos_o) in [(10.0f32, 0.9f32), (10.0, 0.3), (4.0, 0.5), (100.0, 0.7)] {
            let v = [(1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o];
            let lobe = glossy_lobe_directions(n, v, e);
            assert_eq!(lobe.len(), GLOSSY_SAMPLES);
            // The weights leave out the constant factor (e + 2) / (e + 1).
            let mean =
                (e + 2.0) / (e + 1.0) * lobe.iter().map(|d| d.weight).sum::<f32>() / GLOSSY_SAMPLES as f32;
            let albedo = blinn_albedo(e, cos_o);
            assert!((mean - albedo).abs() <= 0.06 * albedo, "e {e}, cos_o {cos_o}: {mean} vs {albedo}");
            assert!(lobe.iter().all(|d| d.weight == 0.0 || dot(d.direction, n) > 0.0));
            assert!(lobe.iter().all(|d| (0.0..=(REFLECTION_LEVELS - 1) as f32).contains(&d.level)));
        }
        let grazing = [(1.0f32 - 0.01).sqrt(), 0.0, 0.1];
        let lobe = glossy_lobe_directions(n, grazing, 10.0);
        let total: f32 = lobe.iter().map(|d| d.weight).sum();
        let mean_cos = lobe.iter().map(|d| d.weight * dot(d.direction, n)).sum::<f32>() / total;
        // The mirror direction is 0.1 above the horizon; the lobe's weighted mean is well above.
        assert!(mean_cos > 0.3, "{mean_cos}");
    }
}

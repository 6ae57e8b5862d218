//! The irradiance probes on the GPU, for the per-fragment diffuse light of live objects: each
//! probe's radiance SH less what the shaders add themselves (nine `vec4`s per probe) and its
//! octahedral visibility texels (mean and mean squared distance), as two storage buffers the
//! shaders read with `sidecar::ProbeGrid::irradiance_of`'s weights (DDGI).

use crate::gpu::Gpu;
use crate::light_layers::AreaSample;
use crate::live::LiveLight;
use glam::DVec3;
use sidecar::ProbeGrid;
use sidecar::sh::SH_COEFFICIENTS;
use wgpu::util::DeviceExt;

/// What the compositor keeps of the irradiance probes.
#[derive(Debug)]
pub(super) struct GpuIrradiance {
    /// Per probe, 9 RGB SH coefficients as `vec4`s: the scene's indirect light.
    pub(super) sh: wgpu::Buffer,
    /// Per probe, `VISIBILITY_TEXELS^2` (mean, mean squared) distance pairs.
    pub(super) visibility: wgpu::Buffer,
    /// The grid for the shaders: origin (w 1 when bound), spacing, counts.
    pub(super) origin: [f32; 4],
    pub(super) spacing: [f32; 4],
    pub(super) counts: [u32; 4],
}

/// Each probe's radiance SH less the light the shaders add per fragment themselves: for probes
/// that hold what emitters send them straight (`emitters_seen`), the area lights' direct
/// light at the probe (over their emitter samples `samples[k]` where there are some); delta
/// lights never reach a probe, so nothing of theirs is subtracted.
pub(super) fn indirect_probe_sh(
    grid: &ProbeGrid,
    lights: &[LiveLight],
    samples: &[Vec<AreaSample>],
) -> Vec<[[f32; 3]; SH_COEFFICIENTS]> {
    let mut all = grid.radiance_sh.clone();
    if grid.emitters_seen {
        let n = grid.counts.map(|c| c as usize);
        for (index, sh) in all.iter_mut().enumerate() {
            let cell = [index % n[0], (index / n[0]) % n[1], index / (n[0] * n[1])];
            let p = grid.probe_position(cell.map(|c| c as u32));
            let p = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            subtract_area_lights(sh, lights, samples, p);
        }
    }
    all
}

/// Subtracts from radiance SH `sh` at `p` the area lights' direct light there, as the shaders
/// add it (unshadowed).
fn subtract_area_lights(sh: &mut [[f32; 3]; 9], lights: &[LiveLight], samples: &[Vec<AreaSample>], p: DVec3) {
    let mut subtract = |dir: DVec3, e: glam::Vec3| {
        let y = sidecar::sh::sh_basis([dir.x as f32, dir.y as f32, dir.z as f32]);
        for (c, yi) in sh.iter_mut().zip(y) {
            for k in 0..3 {
                c[k] -= yi * e[k];
            }
        }
    };
    for (k, light) in lights.iter().enumerate() {
        let LiveLight::Area { radiance, area, two_sided, .. } = light else { continue };
        match samples.get(k).filter(|s| !s.is_empty()) {
            Some(samples) => {
                let total: f64 = samples.iter().map(|s| s.area).sum();
                for s in samples {
                    let v = s.position - p;
                    let d2 = v.length_squared().max(1e-30);
                    let l = v / d2.sqrt();
                    let c = s.normal.dot(-l);
                    let cos_e = if *two_sided { c.abs() } else { c.max(0.0) };
                    if cos_e > 0.0 && total > 0.0 {
                        subtract(l, *radiance * (area / total * s.area * cos_e / d2) as f32);
                    }
                }
            }
            None => {
                if let Some((dir, e)) = area_light_at_centroid(light, p) {
                    subtract(dir, e);
                }
            }
        }
    }
}

/// Direction toward an area light seen as one point at its centroid, and the irradiance it
/// gives a surface facing it at `p`, as `composite.wgsl`'s `shade` computes it without the
/// light's emitter samples (`None` for other lights).
fn area_light_at_centroid(light: &LiveLight, p: DVec3) -> Option<(DVec3, glam::Vec3)> {
    let LiveLight::Area { centroid, normal, two_sided, radiance, area, .. } = light else { return None };
    let v = *centroid - p;
    let d2 = v.length_squared().max(1e-30);
    let l = v / d2.sqrt();
    let lobe = match normal {
        Some(n) => {
            let c = n.dot(-l) as f32;
            if *two_sided { c.abs() } else { c.max(0.0) }
        }
        None => 0.25,
    };
    Some((l, *radiance * (*area as f32) * lobe / d2 as f32))
}

/// Uploads `grid` with each probe's SH from [`indirect_probe_sh`]; without probes, one zero
/// entry of each keeps the bind group valid and the shaders skip the lookup.
pub(super) fn upload(
    gpu: &Gpu,
    grid: Option<&ProbeGrid>,
    lights: &[LiveLight],
    samples: &[Vec<AreaSample>],
) -> GpuIrradiance {
    let (sh, visibility): (Vec<[f32; 4]>, &[[f32; 2]]) = match grid {
        Some(g) => (
            indirect_probe_sh(g, lights, samples)
                .iter()
                .flat_map(|probe| probe.iter().map(|c| [c[0], c[1], c[2], 0.0]))
                .collect(),
            &g.visibility,
        ),
        None => (vec![[0.0; 4]; SH_COEFFICIENTS], &[[0.0; 2]]),
    };
    let buffer = |label: &str, contents: &[u8]| {
        gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::STORAGE,
        })
    };
    let (origin, spacing, counts) = match grid {
        Some(g) => (
            [g.origin[0], g.origin[1], g.origin[2], 1.0],
            [g.spacing[0], g.spacing[1], g.spacing[2], 0.0],
            [g.counts[0], g.counts[1], g.counts[2], 0],
        ),
        None => ([0.0; 4], [1.0, 1.0, 1.0, 0.0], [1, 1, 1, 0]),
    };
    GpuIrradiance {
        sh: buffer("irradiance probe SH", bytemuck::cast_slice(&sh)),
        visibility: buffer("irradiance probe visibility", bytemuck::cast_slice(visibility)),
        origin,
        spacing,
        counts,
    }
}

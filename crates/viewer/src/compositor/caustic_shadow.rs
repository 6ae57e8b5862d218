//! What live objects take from the scene's caustics (docs/viewer-specular.md, "Caustics that live
//! objects block"): the renderer's caustic photons (`sidecar::CausticPhotons`), each with its
//! light path's segments, are tested against the live spheres; the blocked ones are splatted
//! with each pixel's own estimate kernel (radius, filter, divisor, reflectance) into a per-pixel
//! loss (binding 30), which the backdrop subtracts (`caustic_removed` in composite.wgsl). On
//! the CPU, once per change of the spheres: a few milliseconds for the 2^18 photons a caustics
//! file holds at most, and nothing at all for a render without one (a 1x1 placeholder that the
//! shader's size test skips).

use glam::DVec3;
use sidecar::CausticPhotons;
use std::collections::HashMap;
use std::sync::Arc;

/// The kernels of the pixels with a caustic estimate, in a uniform grid whose cell is the
/// largest estimate radius: a photon can only count for the pixels of the 27 cells around it.
#[derive(Debug)]
struct PixelGrid {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl PixelGrid {
    fn new(caustics: &CausticPhotons) -> Option<PixelGrid> {
        let cell = f64::from(caustics.max_radius());
        (cell.is_finite() && cell > 0.0).then_some(())?;
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (k, px) in caustics.pixels.iter().enumerate() {
            if px.radius2 > 0.0 {
                cells.entry(Self::key(cell, px.position)).or_default().push(k as u32);
            }
        }
        Some(PixelGrid { cell, cells })
    }

    fn key(cell: f64, p: [f32; 3]) -> [i64; 3] {
        p.map(|v| (f64::from(v) / cell).floor() as i64)
    }
}

/// The caustic loss of the current live objects, on the CPU and in its texture.
#[derive(Debug)]
pub(super) struct CausticShadow {
    caustics: Option<(Arc<CausticPhotons>, PixelGrid)>,
    texture: wgpu::Texture,
    /// The spheres the texture's loss is for (`None` before the first frame).
    spheres: Option<Vec<([f64; 3], f64)>>,
    /// Whether the texture holds any loss (a frame that blocks nothing then skips the upload).
    holds_loss: bool,
}

impl CausticShadow {
    /// The loss texture for a `width x height` frame with `caustics`; without them (or with
    /// no pixel that has a caustic estimate), a 1x1 placeholder.
    pub(super) fn new(
        device: &wgpu::Device,
        caustics: Option<Arc<CausticPhotons>>,
        (width, height): (u32, u32),
    ) -> Self {
        let caustics = caustics
            .filter(|c| (c.width, c.height) == (width, height))
            .and_then(|c| PixelGrid::new(&c).map(|grid| (c, grid)));
        let (w, h) = if caustics.is_some() { (width, height) } else { (1, 1) };
        let texture = super::bindings::input_texture(
            device,
            "caustic loss",
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            wgpu::TextureFormat::Rgba32Float,
        );
        CausticShadow { caustics, texture, spheres: None, holds_loss: false }
    }

    pub(super) fn view(&self) -> wgpu::TextureView {
        self.texture.create_view(&wgpu::TextureViewDescriptor::default())
    }

    /// Brings the loss texture up to date with `spheres` (world space centre and radius):
    /// recomputed and uploaded only when they changed, and not uploaded when the loss stays
    /// zero.
    pub(super) fn update(&mut self, queue: &wgpu::Queue, spheres: Vec<([f64; 3], f64)>) {
        let Some((caustics, grid)) = &self.caustics else { return };
        if self.spheres.as_ref() == Some(&spheres) {
            return;
        }
        let loss = caustic_loss(caustics, grid, &spheres);
        let any = loss.iter().any(|v| v[..3].iter().any(|&c| c != 0.0));
        if any || self.holds_loss {
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &self.texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(&loss),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(caustics.width * 16),
                    rows_per_image: Some(caustics.height),
                },
                wgpu::Extent3d { width: caustics.width, height: caustics.height, depth_or_array_layers: 1 },
            );
        }
        self.holds_loss = any;
        self.spheres = Some(spheres);
    }
}

/// The radiance each pixel loses (RGBA, alpha 0) when the photons whose paths meet any of
/// `spheres` leave its caustic estimate: `sidecar::CausticPhotons::blocked_loss`, with the grid
/// instead of every pixel for every photon.
fn caustic_loss(caustics: &CausticPhotons, grid: &PixelGrid, spheres: &[([f64; 3], f64)]) -> Vec<[f32; 4]> {
    let mut sum = vec![[0.0f64; 3]; caustics.pixels.len()];
    if !spheres.is_empty() {
        for (i, ph) in caustics.photons.iter().enumerate() {
            if !caustics.photon_blocked(i, spheres) {
                continue;
            }
            let [x, y, z] = PixelGrid::key(grid.cell, ph.position);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(pixels) = grid.cells.get(&[x + dx, y + dy, z + dz]) else { continue };
                        for &k in pixels {
                            if let Some(w) = caustics.kernel_weight(&caustics.pixels[k as usize], ph) {
                                for (s, p) in sum[k as usize].iter_mut().zip(ph.power) {
                                    *s += w * f64::from(p);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    sum.iter()
        .zip(&caustics.pixels)
        .map(|(s, px)| {
            let [r, g, b] = [0, 1, 2].map(|c| (s[c] * f64::from(px.weight[c])) as f32);
            [r, g, b, 0.0]
        })
        .collect()
}

/// The live objects that block caustic photons: the sphere and the live meshes that are exact
/// spheres, in world space.
pub(super) fn blocking_spheres(live: &crate::live::LiveObjects) -> Vec<([f64; 3], f64)> {
    let ok = |(c, r): &(DVec3, f64)| c.is_finite() && *r > 0.0 && r.is_finite();
    live.sphere
        .iter()
        .map(|s| (s.centre, s.radius))
        .chain(live.meshes.iter().filter(|m| m.world_from_object.is_finite()).filter_map(|m| m.exact_sphere))
        .filter(ok)
        .map(|(c, r)| (c.to_array(), r))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sidecar::{CausticFilter, CausticPhoton, CausticPixel};

    /// A floor of 16x16 pixels a tenth apart, photons raining straight down on it; the grid's
    /// loss must be the reference's, to rounding.
    #[test]
    fn the_grid_loss_is_the_reference_loss() {
        let up = [0.0, 1.0, 0.0];
        let mut pixels = Vec::new();
        for j in 0..16 {
            for i in 0..16 {
                let radius2 = if (i + j) % 5 == 0 { 0.0 } else { 0.01 + 0.002 * ((i * j) % 7) as f32 };
                pixels.push(CausticPixel {
                    position: [i as f32 * 0.1, 0.0, j as f32 * 0.1],
                    normal: up,
                    radius2,
                    weight: [1.0, 0.5, 2.0],
                });
            }
        }
        let mut photons = Vec::new();
        let mut segments = Vec::new();
        for k in 0..400u32 {
            let (x, z) = ((k % 20) as f32 * 0.08, (k / 20) as f32 * 0.08);
            photons.push(CausticPhoton {
                position: [x, 0.0, z],
                normal: up,
                power: [1.0, (k % 3) as f32, 0.5],
                first_segment: k,
                segment_count: 1,
            });
            segments.push([[x, 2.0, z], [x, 0.0, z]]);
        }
        let caustics = CausticPhotons {
            depth_fingerprint: 0,
            width: 16,
            height: 16,
            filter: CausticFilter::Gaussian,
            photons,
            segments,
            pixels,
        };
        let grid = PixelGrid::new(&caustics).unwrap();
        let spheres = [([0.6, 1.0, 0.6], 0.35)];
        let fast = caustic_loss(&caustics, &grid, &spheres);
        let reference = caustics.blocked_loss(&spheres);
        let mut lit = 0;
        for (f, r) in fast.iter().zip(&reference) {
            for c in 0..3 {
                assert!((f64::from(f[c]) - r[c]).abs() <= 1e-6 * r[c].abs().max(1.0), "{f:?} vs {r:?}");
            }
            lit += usize::from(r[0] > 0.0);
        }
        assert!(lit > 20, "{lit} pixels lose light");
        assert!(caustic_loss(&caustics, &grid, &[]).iter().all(|v| *v == [0.0; 4]));
    }
}

//! The caustic photons of a render (`*.caustics.exr`): the photons of the caustic map that the
//! primary hits' caustic estimates read, each with the segments of its light path in free space,
//! and per pixel the kernel of the estimate at its primary hit, so that the viewer can remove
//! exactly what a live object between a light and a specular caster takes from the caustic
//! (docs/sidecar.md, "Caustic photons").
//!
//! [`CausticPhotons::blocked_loss`] is the reference evaluator, in `f64`: the radiance each
//! pixel loses when the photons whose paths meet any of the given spheres are taken out of its
//! estimate, with the renderer's own radius, filter and divisor.

/// Most photons a caustics file holds (the exporter thins a larger map to this many, scaling
/// the kept photons' power so that every estimate keeps its expectation).
pub const MAX_CAUSTIC_PHOTONS: usize = 1 << 18;
/// Most path segments a caustics file holds.
pub const MAX_CAUSTIC_SEGMENTS: usize = 1 << 21;

/// The kernel of the renderer's density estimates (`PhotonFilter`): a photon at squared
/// distance `d2` from the query counts with `weight(d2, r2)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CausticFilter {
    Box,
    /// Jensen's cone filter, `w = 1 - d / (k r)`.
    Cone {
        k: f32,
    },
    /// Jensen's Gaussian (after Pavicic).
    Gaussian,
}

const GAUSS_ALPHA: f64 = 0.918;
const GAUSS_BETA: f64 = 1.953;

impl CausticFilter {
    /// The photon's weight, as the renderer's `PhotonFilter::weight` (in `f64`).
    pub fn weight(&self, d2: f64, r2: f64) -> f64 {
        match *self {
            CausticFilter::Box => 1.0,
            CausticFilter::Cone { k } => (1.0 - (d2 / r2).sqrt() / f64::from(k)).max(0.0),
            CausticFilter::Gaussian => {
                let e = (1.0 - (-GAUSS_BETA * d2 / (2.0 * r2)).exp()) / (1.0 - (-GAUSS_BETA).exp());
                (GAUSS_ALPHA * (1.0 - e)).max(0.0)
            }
        }
    }
}

/// One photon of the caustic map: where it landed, the normal of its surface on the side it
/// arrived from, its power (already divided by the map's path count) and its path's segments,
/// `segments[first_segment .. first_segment + segment_count]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticPhoton {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub power: [f32; 3],
    pub first_segment: u32,
    pub segment_count: u32,
}

/// The caustic estimate's kernel at one pixel's primary hit (through the pixel's centre): the
/// hit, its normal on the side the camera sees, the squared radius the estimate used (0 where
/// the pixel has no caustic estimate: a specular or empty hit, no photon within reach) and the
/// factor its filtered photon sum is multiplied by (the surface's diffuse reflectance over `pi`,
/// divided by the filter's normalisation, `pi r^2` and the part of the disc on the surface).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CausticPixel {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub radius2: f32,
    pub weight: [f32; 3],
}

/// Photons whose surface normal is closer than this (cosine) to the query's count, as in the
/// renderer's estimates (`estimate::NORMAL_COSINE`).
pub const CAUSTIC_NORMAL_COSINE: f32 = 0.5;

/// A render's caustic photons and the per-pixel kernels of its caustic estimates, in world
/// space.
#[derive(Clone, Debug, PartialEq)]
pub struct CausticPhotons {
    pub depth_fingerprint: u64,
    pub width: u32,
    pub height: u32,
    pub filter: CausticFilter,
    pub photons: Vec<CausticPhoton>,
    /// Path segments in free space, `[start, end]`, each photon's in order from the light.
    pub segments: Vec<[[f32; 3]; 2]>,
    /// `width * height` kernels, row by row from the top.
    pub pixels: Vec<CausticPixel>,
}

/// Whether the segment `a -> b` passes through the sphere of `centre` and `radius` (its closest
/// point to the centre is strictly inside).
pub fn segment_meets_sphere(a: [f64; 3], b: [f64; 3], centre: [f64; 3], radius: f64) -> bool {
    let d = sub(b, a);
    let m = sub(centre, a);
    let len2 = dot(d, d);
    let t = if len2 > 0.0 { (dot(m, d) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let closest = [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]];
    let off = sub(centre, closest);
    dot(off, off) < radius * radius
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn wide(v: [f32; 3]) -> [f64; 3] {
    v.map(f64::from)
}

impl CausticPhotons {
    /// Whether photon `index`'s path meets any of `spheres` (`(centre, radius)`, world space).
    pub fn photon_blocked(&self, index: usize, spheres: &[([f64; 3], f64)]) -> bool {
        let p = &self.photons[index];
        let start = p.first_segment as usize;
        let end = start.saturating_add(p.segment_count as usize).min(self.segments.len());
        self.segments
            .get(start..end)
            .unwrap_or(&[])
            .iter()
            .any(|[a, b]| spheres.iter().any(|&(c, r)| segment_meets_sphere(wide(*a), wide(*b), c, r)))
    }

    /// The radiance each pixel loses (row by row) when the photons whose paths meet any of
    /// `spheres` leave its caustic estimate: the estimate's own sum over those photons within its
    /// radius on its surface, in `f64`. Visits every pixel for every blocked photon: the
    /// reference, not the viewer's per-frame path.
    pub fn blocked_loss(&self, spheres: &[([f64; 3], f64)]) -> Vec<[f64; 3]> {
        let blocked: Vec<usize> =
            (0..self.photons.len()).filter(|&i| self.photon_blocked(i, spheres)).collect();
        self.pixels
            .iter()
            .map(|px| {
                let mut sum = [0.0f64; 3];
                if px.radius2 > 0.0 {
                    for &i in &blocked {
                        let ph = &self.photons[i];
                        if let Some(w) = self.kernel_weight(px, ph) {
                            for (s, p) in sum.iter_mut().zip(ph.power) {
                                *s += w * f64::from(p);
                            }
                        }
                    }
                }
                [0, 1, 2].map(|c| sum[c] * f64::from(px.weight[c]))
            })
            .collect()
    }

    /// The filter weight of photon `ph` in the estimate of pixel `px`, if it counts there (within
    /// the radius, strictly, and on the same surface by the normal test).
    pub fn kernel_weight(&self, px: &CausticPixel, ph: &CausticPhoton) -> Option<f64> {
        let d = sub(wide(ph.position), wide(px.position));
        let d2 = dot(d, d);
        let r2 = f64::from(px.radius2);
        let aligned = dot(wide(ph.normal), wide(px.normal)) > f64::from(CAUSTIC_NORMAL_COSINE);
        (d2 < r2 && aligned).then(|| self.filter.weight(d2, r2))
    }

    /// The largest radius of any pixel's estimate (0 without any).
    pub fn max_radius(&self) -> f32 {
        self.pixels.iter().map(|p| p.radius2).fold(0.0f32, f32::max).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_meet_spheres_only_through_their_interior() {
        let c = [0.0, 1.0, 0.0];
        assert!(segment_meets_sphere([-2.0, 1.0, 0.0], [2.0, 1.0, 0.0], c, 0.5));
        // Ends before the sphere, passes beside it, touches it tangentially.
        assert!(!segment_meets_sphere([-2.0, 1.0, 0.0], [-0.6, 1.0, 0.0], c, 0.5));
        assert!(!segment_meets_sphere([-2.0, 1.6, 0.0], [2.0, 1.6, 0.0], c, 0.5));
        assert!(!segment_meets_sphere([-2.0, 1.5, 0.0], [2.0, 1.5, 0.0], c, 0.5));
        // Ends inside.
        assert!(segment_meets_sphere([-2.0, 1.0, 0.0], [-0.2, 1.0, 0.0], c, 0.5));
    }

    #[test]
    fn a_pixel_loses_exactly_its_blocked_photons_within_its_radius() {
        let up = [0.0, 1.0, 0.0];
        let photon = |x: f32, power: f32, first: u32| CausticPhoton {
            position: [x, 0.0, 0.0],
            normal: up,
            power: [power; 3],
            first_segment: first,
            segment_count: 1,
        };
        let caustics = CausticPhotons {
            depth_fingerprint: 0,
            width: 2,
            height: 1,
            filter: CausticFilter::Cone { k: 1.0 },
            // Photon 0 comes straight down through the blocker; photon 1 beside it.
            photons: vec![photon(0.0, 2.0, 0), photon(0.5, 4.0, 1)],
            segments: vec![[[0.0, 3.0, 0.0], [0.0, 0.0, 0.0]], [[0.5, 3.0, 5.0], [0.5, 0.0, 0.0]]],
            pixels: vec![
                CausticPixel {
                    position: [0.25, 0.0, 0.0],
                    normal: up,
                    radius2: 1.0,
                    weight: [1.0, 0.5, 0.25],
                },
                // A wall: the normal test leaves the photons out.
                CausticPixel {
                    position: [0.0, 0.0, 0.0],
                    normal: [1.0, 0.0, 0.0],
                    radius2: 1.0,
                    weight: [1.0; 3],
                },
            ],
        };
        let blocker = [([0.0, 1.5, 0.0], 0.3)];
        assert!(caustics.photon_blocked(0, &blocker));
        assert!(!caustics.photon_blocked(1, &blocker));
        let loss = caustics.blocked_loss(&blocker);
        // Cone weight at distance 0.25 of radius 1: 0.75; times power 2.
        assert_eq!(loss[0], [1.5, 0.75, 0.375]);
        assert_eq!(loss[1], [0.0; 3]);
        assert_eq!(caustics.blocked_loss(&[]), vec![[0.0; 3]; 2]);
    }
}

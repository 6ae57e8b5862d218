//! The sidecar's caustics file (`sidecar::CausticPhotons`, docs/sidecar.md "Caustic photons"):
//! the caustic map's photons that the primary hits' caustic estimates read, each with its light
//! path's segments, and per pixel the kernel of the estimate at the hit through its centre (the
//! radius, the filter, the divisor with the part of the disc on the surface, the reflectance),
//! so that the viewer can take out of the image exactly what the photons a live object blocks
//! brought to each pixel.

use super::estimate::{self, NORMAL_COSINE, Nearest, Query};
use super::kdtree::{KdTree, Positioned};
use super::render::{facing_normal, non_specular_albedo};
use super::{Photon, PhotonFilter, PhotonMapper, unpack_unit};
use crate::render::CameraRays;
use crate::world::World;
use glam::Vec3;
use rayon::prelude::*;
use sidecar::{
    CausticFilter, CausticPhoton, CausticPhotons, CausticPixel, MAX_CAUSTIC_PHOTONS, MAX_CAUSTIC_SEGMENTS,
};

/// The caustic map's photons in shooting order, each with the vertices of its path before it
/// (the emission point and every specular vertex, render space).
#[derive(Clone, Debug, Default)]
pub struct CausticPaths {
    pub photons: Vec<Photon>,
    pub vertices: Vec<Vec<Vec3>>,
}

/// A photon's position with its index in [`CausticPaths`], for finding the photons within an
/// estimate's radius.
#[derive(Clone, Copy)]
struct Indexed {
    p: Vec3,
    n: Vec3,
    index: u32,
}

impl Positioned for Indexed {
    fn position(&self) -> Vec3 {
        self.p
    }
}

fn sidecar_filter(filter: PhotonFilter) -> CausticFilter {
    match filter {
        PhotonFilter::Box => CausticFilter::Box,
        PhotonFilter::Cone { k } => CausticFilter::Cone { k },
        PhotonFilter::Gaussian => CausticFilter::Gaussian,
    }
}

impl PhotonMapper {
    /// The caustics file's content for the frame of `rays` (fingerprint 0: the writer sets it),
    /// or `None` without caustic paths (no caustic map, or not asked for) or when no pixel's
    /// estimate reads a photon.
    pub fn caustic_photons(&self, world: &World, rays: &CameraRays) -> Option<CausticPhotons> {
        let paths = self.caustic_paths.as_ref()?;
        let map = self.caustic.as_ref()?;
        let (width, height) = rays.camera.resolution();
        let n_used = self.settings.n_used as usize;
        let filter = self.settings.filter;
        // The kernel of each pixel's estimate, at the hit through its centre (render space).
        let kernels: Vec<Option<(Vec3, Vec3, f32, Vec3)>> = (0..width * height)
            .into_par_iter()
            .map_init(
                || Nearest::new(n_used),
                |nearest, pixel| {
                    let (i, j) = (pixel % width, pixel / width);
                    let (mut ray, _) = rays.pixel_centre_ray(i, j)?;
                    // As the depth table: surfaces without opacity are passed through.
                    for _ in 0..256 {
                        let hit = world.intersect(&ray)?;
                        let si = world.interaction(&ray, &hit);
                        let material = world.material(si.attributes);
                        if material.opacity == Vec3::ZERO {
                            ray.t_min = hit.t;
                            continue;
                        }
                        let bsdf =
                            material.bsdf(si.wo, si.ng, si.ns, si.n_outward, si.dpdu, si.st, si.st_width);
                        if !bsdf.has_non_specular() {
                            return None;
                        }
                        let q = Query { p: si.p, n: facing_normal(&si), max_d2: self.max_d2 };
                        let (r2, fraction) = estimate::gather_photons(map, &q, nearest);
                        let divisor = filter.normalisation() * std::f32::consts::PI * r2 * fraction;
                        if nearest.heap.is_empty() || !(r2 > 0.0) || !(divisor > 0.0) {
                            return None;
                        }
                        let weight = non_specular_albedo(&bsdf) * std::f32::consts::FRAC_1_PI / divisor;
                        return weight.is_finite().then_some((si.p, q.n, r2, weight));
                    }
                    None
                },
            )
            .collect();
        // The photons some estimate reads: within its radius, on its surface.
        let indexed: Vec<Indexed> = paths
            .photons
            .iter()
            .enumerate()
            .map(|(index, ph)| Indexed { p: ph.p, n: unpack_unit(ph.n), index: index as u32 })
            .collect();
        let tree = KdTree::build(indexed);
        let mut used = vec![false; paths.photons.len()];
        for &(p, n, r2, _) in kernels.iter().flatten() {
            tree.for_each_within(
                p,
                r2,
                |ph| ph.n.dot(n) > NORMAL_COSINE,
                |_, ph| used[ph.index as usize] = true,
            );
        }
        let used: Vec<usize> = (0..used.len()).filter(|&i| used[i]).collect();
        let segment_total: usize = used.iter().map(|&i| paths.vertices[i].len()).sum();
        // Over the budget, every `stride`-th photon is kept with `stride` times its power, so that
        // each estimate keeps its expectation.
        let stride =
            used.len().div_ceil(MAX_CAUSTIC_PHOTONS).max(segment_total.div_ceil(MAX_CAUSTIC_SEGMENTS)).max(1);
        let world_from_render = world.render_from_world.inverse();
        let to_world = |p: Vec3| world_from_render.transform_point3(p.as_dvec3()).as_vec3().to_array();
        let to_world_dir = |n: Vec3| {
            world_from_render.transform_vector3(n.as_dvec3()).normalize_or_zero().as_vec3().to_array()
        };
        let mut photons = Vec::new();
        let mut segments = Vec::new();
        for &i in used.iter().step_by(stride) {
            let ph = &paths.photons[i];
            let vertices = &paths.vertices[i];
            let first_segment = segments.len() as u32;
            for (k, &a) in vertices.iter().enumerate() {
                let b = vertices.get(k + 1).copied().unwrap_or(ph.p);
                segments.push([to_world(a), to_world(b)]);
            }
            photons.push(CausticPhoton {
                position: to_world(ph.p),
                normal: to_world_dir(unpack_unit(ph.n)),
                power: (ph.power * stride as f32).to_array(),
                first_segment,
                segment_count: vertices.len() as u32,
            });
        }
        if photons.is_empty() || segments.is_empty() {
            return None;
        }
        let pixels = kernels
            .iter()
            .map(|k| match *k {
                Some((p, n, radius2, weight)) => CausticPixel {
                    position: to_world(p),
                    normal: to_world_dir(n),
                    radius2,
                    weight: weight.to_array(),
                },
                None => CausticPixel::default(),
            })
            .collect();
        Some(CausticPhotons {
            depth_fingerprint: 0,
            width,
            height,
            filter: sidecar_filter(filter),
            photons,
            segments,
            pixels,
        })
    }
}

//! An irradiance cache for the final gather (Ward, Rubinstein and Clear 1988; Tabellion and
//! Lamorlette 2004; Jensen 2001, ch. 9.3): the indirect irradiance at camera-visible matte
//! surfaces is gathered once per *record* with many rays and interpolated between pixels,
//! instead of gathered with a few rays at every camera sample.
//!
//! Records are placed before the image is rendered, over the image in levels of pixel grids
//! (spacing 16, 8, 4, 2, 1 for the default largest spacing): at each level, the pixel-centre
//! hits that the records of the coarser levels do not cover (Ward's weight, below) get a record.
//! A level's candidates are gathered in parallel, each with a sampler seeded by its pixel, and
//! appended in pixel order, so the cache, and the image, do not depend on the thread count.
//! A record's gather is the default mode's own (radiance photons, photon-guided half, short
//! gather rays gathering again), through a white Lambertian BSDF in the surface's frame, so its
//! estimate has the same expectation as the per-sample gather it replaces.
//!
//! Shading interpolates the records around a camera-visible point with weights
//! `1 - eps / a`, `eps = |p - p_i| / R_i + sqrt(1 - n . n_i)` (Ward's error with Tabellion and
//! Lamorlette's smooth fall-off, `a` the accuracy), `R_i` the harmonic mean length of the
//! record's gather rays, clamped so that the record's reach `a R_i` is between the smallest and
//! the largest spacing in pixels. A record in front of the point (Ward's test) is not used: it
//! sees light that the point's corner hides. Where no record covers a point, the per-sample
//! gather runs as without the cache. Surfaces with a glossy lobe (plastic, metal) and those seen
//! only through specular surfaces keep the per-sample gather.

use super::PhotonMapper;
use super::settings::{bool_param, int_param};
use crate::bsdf::{Bsdf, Lobe};
use crate::integrators::{RayCounters, ViewContext, find_surface_or_escape};
use crate::sampler::PixelSampler;
use crate::world::World;
use glam::Vec3;
use rayon::prelude::*;
use rib_parser::scene::ParamList;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// The `SurfaceIntegrator "photonmap"` parameters of the cache.
pub const PARAMS: &[&str] =
    &["irradiancecache", "cacheaccuracy", "cacheminspacing", "cachemaxspacing", "cachesamples"];

/// Gather rays per record by default: 4 per pixel sample, at least 64. A record's noise is
/// shared by the pixels around it and does not average out with pixel samples, so it has to
/// fall as they grow; measured on the Cornell box (docs/photon-mapping.md), 64 rays cost the
/// least time to relMSE 5e-3 and 1e-3 (2 to 8 spp), and at 64 spp 64 rays left relMSE 1.57e-4
/// where 256 left 8.4e-5.
pub fn auto_samples(pixel_samples: u32) -> u32 {
    pixel_samples.saturating_mul(4).clamp(64, MAX_CACHE_SAMPLES)
}

/// Largest `cachesamples`.
pub const MAX_CACHE_SAMPLES: u32 = 65_536;

/// Sum of weights at a pixel-centre hit from which it needs no record of its own.
const COVERED: f32 = 1.0;

/// Sum of weights from which a camera sample reads the cache rather than gathering itself.
const USABLE: f32 = 0.05;

/// Distance from a record's plane, relative to its reach, beyond which a point with the
/// record's normal is on another surface.
const STEP: f32 = 0.01;

/// A neighbouring pixel's hit is off a pixel's tangent plane when its distance from the plane
/// is more than this part of its distance (about 6 degrees).
const OFF_PLANE: f32 = 0.1;

/// Images larger than this (pixels) are not scanned for occluded pixels (the scan keeps every
/// pixel-centre hit: 28 bytes each).
const MAX_SCANNED_PIXELS: u64 = 1 << 24;

/// Mixed into the render's seed for the records' samplers, so that they are not the camera
/// samplers of the same pixels.
const RECORD_SEED: u64 = 0x1cac_4e5e_ed00_0001;

/// The cache's parameters (`irradiancecache`, `cacheaccuracy`, `cacheminspacing`,
/// `cachemaxspacing`, `cachesamples`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradianceCacheSettings {
    /// Whether matte camera-visible surfaces read the cache.
    pub enabled: bool,
    /// Ward's `a`: the largest error `|p - p_i| / R_i + sqrt(1 - n . n_i)` a record is used at.
    pub accuracy: f32,
    /// Smallest and largest reach of a record, in pixels at its distance; the largest is also
    /// the spacing of the first level of records (rounded down to a power of two).
    pub min_spacing: f32,
    pub max_spacing: f32,
    /// Gather rays per record; `None`: [`auto_samples`] of the pixel samples.
    pub samples: Option<u32>,
}

impl Default for IrradianceCacheSettings {
    fn default() -> IrradianceCacheSettings {
        IrradianceCacheSettings {
            enabled: true,
            accuracy: 0.3,
            min_spacing: 1.5,
            max_spacing: 16.0,
            samples: None,
        }
    }
}

impl IrradianceCacheSettings {
    /// Reads the cache's parameters into `self`, with a note for each value out of range.
    pub fn read(&mut self, params: &ParamList, notes: &mut Vec<String>) {
        match bool_param(params, "irradiancecache") {
            None => {}
            Some(Ok(v)) => self.enabled = v,
            Some(Err(e)) => notes.push(format!("photonmap {e}")),
        }
        let mut float = |name: &str, field: &mut f32, min: f32, max: f32| {
            if let Some(v) = params.float(name) {
                if v.is_finite() && v > min && v <= max {
                    *field = v;
                } else {
                    notes.push(format!("photonmap \"{name}\" {v} must be in ({min}, {max}]: using {field}"));
                }
            }
        };
        float("cacheaccuracy", &mut self.accuracy, 0.0, 10.0);
        float("cacheminspacing", &mut self.min_spacing, 0.0, 1024.0);
        float("cachemaxspacing", &mut self.max_spacing, 0.0, 1024.0);
        if self.max_spacing < self.min_spacing {
            notes.push(format!(
                "photonmap \"cachemaxspacing\" {} is below \"cacheminspacing\" {}: using {}",
                self.max_spacing, self.min_spacing, self.min_spacing
            ));
            self.max_spacing = self.min_spacing;
        }
        if let Some(v) = int_param(params, "cachesamples") {
            if v.is_finite() && v >= 1.0 && v <= f64::from(MAX_CACHE_SAMPLES) {
                self.samples = Some(v as u32);
            } else {
                notes.push(format!(
                    "photonmap \"cachesamples\" {v} is outside [1, {MAX_CACHE_SAMPLES}]: using {}",
                    self.samples.map_or("4 per pixel sample, at least 64".into(), |n| n.to_string())
                ));
            }
        }
    }

    /// Pixel spacings of the levels of records, coarsest first, down to 1.
    fn level_spacings(&self) -> Vec<u32> {
        let top = if self.max_spacing >= 1.0 {
            1u32 << (self.max_spacing.log2().floor() as u32).min(10)
        } else {
            1
        };
        std::iter::successors(Some(top), |&s| (s > 1).then_some(s / 2)).collect()
    }
}

/// What the cache did, for `--stats`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CacheStats {
    /// Records per level, coarsest first.
    pub records_per_level: Vec<usize>,
    pub time: Duration,
    /// Camera samples whose indirect light came from the cache, and those that gathered
    /// themselves (a matte surface no record covered).
    pub interpolated: u64,
    pub gathered: u64,
    /// Gather rays per record.
    pub rays_per_record: u32,
}

impl CacheStats {
    pub fn line(&self) -> String {
        format!(
            "irradiance cache: {} records ({:?} per level) of {} gather rays in {:.3} s; {} camera samples interpolated, {} gathered",
            self.records_per_level.iter().sum::<usize>(),
            self.records_per_level,
            self.rays_per_record,
            self.time.as_secs_f64(),
            self.interpolated,
            self.gathered
        )
    }
}

/// One record: the indirect irradiance over pi at `p` (normal `n`, on the side the camera saw)
/// and the distance `reach` (`a R`) within which it is used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub p: Vec3,
    pub n: Vec3,
    pub irradiance: Vec3,
    pub reach: f32,
}

/// The records and a uniform grid over their reaches.
#[derive(Debug)]
pub struct IrradianceCache {
    records: Vec<Record>,
    accuracy: f32,
    cell: f32,
    cells: HashMap<[i32; 3], Vec<u32>>,
    stats: CacheStats,
    interpolated: AtomicU64,
    gathered: AtomicU64,
}

/// Whether a BSDF's indirect light may come from the cache: it has a Lambertian lobe and
/// every other non-specular lobe is Lambertian too (its specular lobes are followed apart).
pub fn cacheable(bsdf: &Bsdf) -> bool {
    let lobes = bsdf.lobes();
    lobes.iter().any(|l| matches!(l, Lobe::Lambert { .. }))
        && lobes.iter().all(|l| matches!(l, Lobe::Lambert { .. }) || l.flags().is_specular())
}

impl IrradianceCache {
    /// A cache of `records` (in this order) used with accuracy `accuracy`.
    pub fn new(records: Vec<Record>, accuracy: f32) -> IrradianceCache {
        let mut cache = IrradianceCache {
            records: Vec::new(),
            accuracy,
            cell: 1.0,
            cells: HashMap::new(),
            stats: CacheStats::default(),
            interpolated: AtomicU64::new(0),
            gathered: AtomicU64::new(0),
        };
        cache.extend(records);
        cache
    }

    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// Adds records and rebuilds the grid: cells twice the median reach wide, each record
    /// listed in every cell its reach's box overlaps, in the records' order.
    fn extend(&mut self, records: Vec<Record>) {
        self.records.extend(records.into_iter().filter(|r| {
            r.p.is_finite()
                && r.n.is_finite()
                && r.irradiance.is_finite()
                && r.reach.is_finite()
                && r.reach > 0.0
        }));
        self.cells.clear();
        if self.records.is_empty() {
            return;
        }
        let mut reaches: Vec<f32> = self.records.iter().map(|r| r.reach).collect();
        let mid = reaches.len() / 2;
        let (_, median, _) = reaches.select_nth_unstable_by(mid, f32::total_cmp);
        self.cell = 2.0 * *median;
        for (i, r) in self.records.iter().enumerate() {
            // A reach far above the median (a record that sees nothing near) is listed in the
            // cells around its centre only, enough for the points near it.
            let centre = self.cell_of(r.p);
            let lo = self.cell_of(r.p - Vec3::splat(r.reach));
            let hi = self.cell_of(r.p + Vec3::splat(r.reach));
            let range =
                |k: usize| lo[k].max(centre[k].saturating_sub(4))..=hi[k].min(centre[k].saturating_add(4));
            for z in range(2) {
                for y in range(1) {
                    for x in range(0) {
                        self.cells.entry([x, y, z]).or_default().push(i as u32);
                    }
                }
            }
        }
    }

    /// Křivánek et al.'s neighbour clamping (2006): a record's radius is at most a
    /// neighbour's plus their distance (a triangle inequality of the distance to the nearest
    /// surface), so a record whose gather rays missed a nearby occluder that a neighbour's
    /// found does not reach past it. Computed from the reaches before clamping, so the result
    /// does not depend on the records' order.
    fn clamp_to_neighbours(&mut self) {
        let before: Vec<f32> = self.records.iter().map(|r| r.reach).collect();
        let mut reaches = before.clone();
        for (j, rj) in self.records.iter().enumerate() {
            let Some(list) = self.cells.get(&self.cell_of(rj.p)) else { continue };
            for &i in list {
                let i = i as usize;
                let d = (self.records[i].p - rj.p).length();
                if i != j && d < before[i] {
                    reaches[i] = reaches[i].min(before[j] + self.accuracy * d);
                }
            }
        }
        if reaches != before {
            for (r, reach) in self.records.iter_mut().zip(reaches) {
                r.reach = reach;
            }
            self.extend(Vec::new());
        }
    }

    fn cell_of(&self, p: Vec3) -> [i32; 3] {
        // `as` saturates: points far outside the records' region share the extreme cells.
        (p / self.cell).floor().to_array().map(|c| c as i32)
    }

    /// Weight of record `r` at `p` (normal `n`): `1 - eps / a`, or 0 where it is not used.
    pub fn weight(&self, r: &Record, p: Vec3, n: Vec3) -> f32 {
        let d = p - r.p;
        let distance = d.length();
        if !(distance < r.reach) {
            return 0.0;
        }
        let cos = n.dot(r.n);
        if !(cos > 0.0) {
            return 0.0;
        }
        // The point's distance from the record's plane: on one smooth surface it is at most
        // about `distance * angle / 2` (the normals' angle); more is another surface, a step
        // away (the light quad 0.01 below the Cornell box's ceiling, whose records would light
        // the ceiling's dark strip beside it). Ward's test (behind the record's plane by
        // `0.05 R`) let that through.
        let offset = d.dot(n + r.n) * 0.5;
        if offset.abs() > distance * (n - r.n).length() + STEP * r.reach {
            return 0.0;
        }
        let error = distance / r.reach + (1.0 - cos).max(0.0).sqrt() / self.accuracy;
        (1.0 - error).max(0.0)
    }

    /// The weighted sum of the records' irradiance at `p` (normal `n`) and the sum of weights.
    pub fn sums(&self, p: Vec3, n: Vec3) -> (Vec3, f32) {
        let Some(list) = self.cells.get(&self.cell_of(p)) else { return (Vec3::ZERO, 0.0) };
        let (mut sum, mut weights) = (Vec3::ZERO, 0.0);
        for &i in list {
            let r = &self.records[i as usize];
            let w = self.weight(r, p, n);
            if w > 0.0 {
                sum += w * r.irradiance;
                weights += w;
            }
        }
        (sum, weights)
    }

    /// The interpolated irradiance over pi at `p`, or `None` where the records do not cover it.
    pub fn interpolate(&self, p: Vec3, n: Vec3) -> Option<Vec3> {
        let (sum, weights) = self.sums(p, n);
        (weights >= USABLE).then(|| sum / weights)
    }

    /// Counts camera samples that read the cache and those that gathered.
    pub fn count(&self, interpolated: u64, gathered: u64) {
        if interpolated > 0 {
            self.interpolated.fetch_add(interpolated, Ordering::Relaxed);
        }
        if gathered > 0 {
            self.gathered.fetch_add(gathered, Ordering::Relaxed);
        }
    }

    pub fn stats(&self) -> CacheStats {
        CacheStats {
            interpolated: self.interpolated.load(Ordering::Relaxed),
            gathered: self.gathered.load(Ordering::Relaxed),
            ..self.stats.clone()
        }
    }
}

/// A pixel-centre hit: the point, its normal on the camera's side and its distance.
type PixelHit = (Vec3, Vec3, f32);

/// The pixel-centre ray of `(x, y)` and the sampler of the pixel's record.
fn pixel_ray(view: &ViewContext, x: u32, y: u32) -> Option<(crate::world::Ray, crate::sampler::Sampler)> {
    let (ray, _) = view.rays.pixel_centre_ray(x, y)?;
    Some((ray, PixelSampler::new(view.seed ^ RECORD_SEED, i64::from(x), i64::from(y)).sample(0)))
}

impl PhotonMapper {
    /// Builds the irradiance cache for the view when the settings ask for it and final
    /// gathering runs outside progressive passes; returns the rays it traced.
    pub(super) fn build_irradiance_cache(&mut self, world: &World, view: &ViewContext) -> RayCounters {
        let settings = self.settings.irradiance_cache;
        if !settings.enabled || !self.gather || self.settings.progressive || self.fixed.is_some() {
            return RayCounters::default();
        }
        let start = Instant::now();
        let mut cache = IrradianceCache::new(Vec::new(), settings.accuracy);
        cache.stats.rays_per_record = settings.samples.unwrap_or_else(|| auto_samples(view.spp));
        let mut counters = RayCounters::default();
        let (x0, y0, x1, y1) = view.bounds;
        let forced = self.occluded_pixels(world, view, &mut counters);
        let spacings = settings.level_spacings();
        for (level, &s) in spacings.iter().enumerate() {
            // This level's pixels: every `s`-th of each row and column, but not those of the
            // coarser level (every `2 s`-th); the first level also takes the pixels beside an
            // occluder, whatever covers them.
            let coarser = |x: u32, y: u32| {
                level > 0 && (x - x0).is_multiple_of(2 * s) && (y - y0).is_multiple_of(2 * s)
            };
            let mut candidates: Vec<(u32, u32, bool)> = (y0..y1)
                .step_by(s as usize)
                .flat_map(|y| (x0..x1).step_by(s as usize).map(move |x| (x, y, false)))
                .filter(|&(x, y, _)| !coarser(x, y))
                .collect();
            if level == 0 {
                candidates.retain(|&(x, y, _)| forced.binary_search(&(y, x)).is_err());
                candidates.extend(forced.iter().map(|&(y, x)| (x, y, true)));
            }
            let cache_ref = &cache;
            let results: Vec<(Option<Record>, RayCounters)> = candidates
                .par_iter()
                .map(|&(x, y, forced)| self.candidate_record(world, view, cache_ref, x, y, forced))
                .collect();
            let mut records = Vec::new();
            for (r, c) in results {
                counters.add(&c);
                records.extend(r);
            }
            cache.stats.records_per_level.push(records.len());
            cache.extend(records);
            cache.clamp_to_neighbours();
        }
        cache.stats.time = start.elapsed();
        self.irradiance_cache = Some(cache);
        counters
    }

    /// Pixels (as `(y, x)`, sorted) whose pixel-centre hit has a nearer neighbour (of the four)
    /// off its tangent plane: the side of a silhouette or a crease that the other side may
    /// hide light from (the ceiling in the gap above the Cornell box's light), on a
    /// checkerboard. Their records are made whatever covers them, and neighbour clamping then
    /// keeps the records around from reaching into the hidden part.
    fn occluded_pixels(
        &self,
        world: &World,
        view: &ViewContext,
        counters: &mut RayCounters,
    ) -> Vec<(u32, u32)> {
        let (x0, y0, x1, y1) = view.bounds;
        if u64::from(x1 - x0) * u64::from(y1 - y0) > MAX_SCANNED_PIXELS {
            return Vec::new();
        }
        let rows: Vec<(Vec<Option<PixelHit>>, u64)> = (y0..y1)
            .into_par_iter()
            .map(|y| {
                let mut rays = 0;
                let row = (x0..x1)
                    .map(|x| {
                        let (ray, mut sampler) = pixel_ray(view, x, y)?;
                        let (si, _) = find_surface_or_escape(world, ray, &mut sampler, &mut rays).ok()?;
                        let n = super::render::facing_normal(&si);
                        Some((si.p, n, (si.p - ray.origin).length()))
                    })
                    .collect();
                (row, rays)
            })
            .collect();
        counters.camera += rows.iter().map(|(_, r)| r).sum::<u64>();
        let hit = |x: i64, y: i64| -> Option<PixelHit> {
            let row = &rows.get(usize::try_from(y - i64::from(y0)).ok()?)?.0;
            *row.get(usize::try_from(x - i64::from(x0)).ok()?)?
        };
        let mut out = Vec::new();
        for y in y0..y1 {
            for x in (x0..x1).filter(|x| (x + y) % 2 == 0) {
                let Some((p, n, d)) = hit(i64::from(x), i64::from(y)) else { continue };
                let (xi, yi) = (i64::from(x), i64::from(y));
                let beside = [(xi - 1, yi), (xi + 1, yi), (xi, yi - 1), (xi, yi + 1)];
                if beside.iter().any(|&(bx, by)| {
                    hit(bx, by)
                        .is_some_and(|(q, _, e)| e < d && (q - p).dot(n).abs() > OFF_PLANE * (q - p).length())
                }) {
                    out.push((y, x));
                }
            }
        }
        out
    }

    /// The record at the centre of pixel `(x, y)`, if its camera ray meets a matte surface
    /// that the cache does not cover yet (or covers, when `forced`).
    fn candidate_record(
        &self,
        world: &World,
        view: &ViewContext,
        cache: &IrradianceCache,
        x: u32,
        y: u32,
        forced: bool,
    ) -> (Option<Record>, RayCounters) {
        let settings = self.settings.irradiance_cache;
        let rays_per_record = settings.samples.unwrap_or_else(|| auto_samples(view.spp));
        let mut counters = RayCounters::default();
        let Some((ray, mut sampler)) = pixel_ray(view, x, y) else { return (None, counters) };
        let found = find_surface_or_escape(world, ray, &mut sampler, &mut counters.camera);
        let Ok((si, _)) = found else { return (None, counters) };
        let material = world.material(si.attributes);
        if material.holdout {
            return (None, counters);
        }
        let bsdf = material.bsdf(si.wo, si.ng, si.ns, si.n_outward, si.dpdu, si.st, si.st_width);
        if !cacheable(&bsdf) {
            return (None, counters);
        }
        let n = super::render::facing_normal(&si);
        if !forced && cache.sums(si.p, n).1 >= COVERED {
            return (None, counters);
        }
        // A pixel's width at the hit: the distance between this pixel's ray and its
        // neighbour's there.
        let distance = (si.p - ray.origin).length();
        let neighbour =
            view.rays.pixel_centre_ray(x + 1, y).or_else(|| view.rays.pixel_centre_ray(x.wrapping_sub(1), y));
        let pixel = neighbour.map_or(f32::NAN, |(r, _)| (r.direction - ray.direction).length() * distance);
        let (irradiance, harmonic) =
            self.record_gather(world, &si, &bsdf, rays_per_record, &mut sampler, &mut counters);
        let mut reach = settings.accuracy * harmonic;
        if pixel.is_finite() && pixel > 0.0 {
            reach = reach.clamp(settings.min_spacing * pixel, settings.max_spacing * pixel);
        }
        let valid = reach.is_finite() && reach > 0.0 && irradiance.is_finite();
        (valid.then_some(Record { p: si.p, n, irradiance, reach }), counters)
    }

    /// The cache, where one was built.
    pub fn irradiance_cache(&self) -> Option<&IrradianceCache> {
        self.irradiance_cache.as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(p: Vec3, n: Vec3, irradiance: f32, reach: f32) -> Record {
        Record { p, n, irradiance: Vec3::splat(irradiance), reach }
    }

    /// Two planes meeting at a right angle (a floor `z = 0` and a wall `x = 0`), a bright record
    /// on the wall next to the crease and a dark one on the floor: a point on the floor at the
    /// crease reads the floor's record only, however far the wall's record reaches.
    #[test]
    fn records_do_not_reach_across_a_crease() {
        let wall = record(Vec3::new(0.0, 0.0, 0.01), Vec3::X, 10.0, 1.0);
        let floor = record(Vec3::new(0.05, 0.0, 0.0), Vec3::Z, 1.0, 0.2);
        let cache = IrradianceCache::new(vec![wall, floor], 0.3);
        let at_crease = cache.interpolate(Vec3::new(0.001, 0.0, 0.0), Vec3::Z).expect("covered");
        assert_eq!(at_crease, Vec3::ONE);
        assert_eq!(cache.weight(&wall, Vec3::new(0.001, 0.0, 0.0), Vec3::Z), 0.0);
        // A floor point beyond the floor record's reach is not covered at all.
        assert!(cache.interpolate(Vec3::new(0.5, 0.0, 0.0), Vec3::Z).is_none());
        // On the other side of a thin sheet (the normal reversed) nothing is read.
        assert!(cache.interpolate(Vec3::new(0.05, 0.0, 0.0), -Vec3::Z).is_none());
    }

    /// A record on a parallel surface a step away (a step up, or the Cornell box's light quad
    /// below its ceiling) is not used on the other surface, on either side; one beside the
    /// point on the same plane is, and so is one on a curved surface that the normals follow.
    #[test]
    fn records_in_front_of_a_point_are_not_used() {
        let upper = record(Vec3::new(0.0, 0.0, 0.2), Vec3::Z, 5.0, 1.0);
        let cache = IrradianceCache::new(vec![upper], 0.3);
        assert_eq!(cache.weight(&upper, Vec3::new(0.1, 0.0, 0.0), Vec3::Z), 0.0);
        assert!(cache.weight(&upper, Vec3::new(0.1, 0.0, 0.2), Vec3::Z) > 0.8);
        let lower = record(Vec3::new(0.0, 0.0, 0.0), Vec3::Z, 5.0, 1.0);
        assert_eq!(cache.weight(&lower, Vec3::new(0.1, 0.0, 0.02), Vec3::Z), 0.0);
        // A sphere of radius 1: a point 0.1 away on it is 0.005 off the record's plane.
        let sphere = record(Vec3::Z, Vec3::Z, 5.0, 0.5);
        let p = Vec3::new(0.1f32.sin(), 0.0, 0.1f32.cos());
        assert!(cache.weight(&sphere, p, p) > 0.5);
    }

    /// Weights fall off smoothly with distance and normal, and the interpolation of equal
    /// records is that value wherever it is defined.
    #[test]
    fn interpolation_of_equal_records_is_exact() {
        let records: Vec<Record> = (0..50)
            .map(|i| {
                let a = i as f32 * 0.37;
                let n = Vec3::new(0.1 * a.sin(), 0.1 * a.cos(), 1.0).normalize();
                record(Vec3::new(a.cos() * a * 0.1, a.sin() * a * 0.1, 0.0), n, 2.5, 0.3 + 0.01 * i as f32)
            })
            .collect();
        let cache = IrradianceCache::new(records.clone(), 0.25);
        let mut covered = 0;
        for i in 0..400 {
            let p = Vec3::new((i % 20) as f32 * 0.1 - 1.0, (i / 20) as f32 * 0.1 - 1.0, 0.0);
            if let Some(e) = cache.interpolate(p, Vec3::Z) {
                assert!((e - Vec3::splat(2.5)).abs().max_element() < 1e-5, "{e}");
                covered += 1;
            }
            let r = &records[i % 50];
            let along = r.n.cross(Vec3::Y).normalize();
            let near = cache.weight(r, r.p + along * 0.01 * r.reach, r.n);
            let far = cache.weight(r, r.p + along * 0.5 * r.reach, r.n);
            assert!(near > 0.98 && far > 0.45 && far < 0.55, "{near} {far}");
        }
        assert!(covered > 50, "{covered}");
    }

    /// A record that reaches far (its rays missed the occluder) next to one that reaches little
    /// (its rays found it): clamping shrinks the first to the second's reach plus `a` times
    /// their distance, and leaves the second alone.
    #[test]
    fn neighbour_clamping_shrinks_far_reaching_records() {
        let far = record(Vec3::ZERO, Vec3::Z, 1.0, 1.0);
        let near = record(Vec3::new(0.2, 0.0, 0.0), Vec3::Z, 0.1, 0.01);
        let mut cache = IrradianceCache::new(vec![far, near], 0.3);
        assert!(cache.weight(&far, Vec3::new(0.21, 0.0, 0.0), Vec3::Z) > 0.0);
        cache.clamp_to_neighbours();
        let [a, b] = [cache.records()[0].reach, cache.records()[1].reach];
        assert!((a - (0.01 + 0.3 * 0.2)).abs() < 1e-6 && b == 0.01, "{a} {b}");
        assert!(cache.interpolate(Vec3::new(0.205, 0.0, 0.0), Vec3::Z).unwrap().x < 0.11);
    }

    #[test]
    fn settings_parse_and_report_ranges() {
        let call = crate::testing::shader(
            "photonmap",
            &[
                ("irradiancecache", 1.0),
                ("cacheaccuracy", -1.0),
                ("cachesamples", 64.0),
                ("cachemaxspacing", 8.0),
            ],
        );
        let mut s = IrradianceCacheSettings::default();
        let mut notes = Vec::new();
        s.read(&call.params, &mut notes);
        assert!(s.enabled);
        assert_eq!((s.accuracy, s.samples, s.max_spacing), (0.3, Some(64), 8.0));
        assert_eq!(
            [auto_samples(1), auto_samples(16), auto_samples(64), auto_samples(u32::MAX)],
            [64, 64, 256, 65_536]
        );
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert_eq!(s.level_spacings(), vec![8, 4, 2, 1]);
        let tiny = IrradianceCacheSettings { max_spacing: 0.5, min_spacing: 0.25, ..s };
        assert_eq!(tiny.level_spacings(), vec![1]);
    }

    /// Degenerate records (not finite, no reach) are dropped, and an empty cache covers nothing.
    #[test]
    fn degenerate_records_are_dropped() {
        let cache = IrradianceCache::new(
            vec![
                record(Vec3::splat(f32::NAN), Vec3::Z, 1.0, 1.0),
                record(Vec3::ZERO, Vec3::Z, 1.0, 0.0),
                record(Vec3::ZERO, Vec3::Z, f32::INFINITY, 1.0),
            ],
            0.3,
        );
        assert!(cache.records().is_empty());
        assert!(cache.interpolate(Vec3::ZERO, Vec3::Z).is_none());
        let huge = IrradianceCache::new(vec![record(Vec3::splat(3e38), Vec3::Z, 1.0, 1e30)], 0.3);
        assert!(huge.interpolate(Vec3::splat(3e38), Vec3::Z).is_some());
    }
}

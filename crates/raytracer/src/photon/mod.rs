//! Photon mapping (Jensen 1996, 2001; pbrt-v1/v2's `PhotonIntegrator`): `SurfaceIntegrator
//! "photonmap"`.
//!
//! # Overview
//! A preprocessing pass ([`PhotonMapper::prepare`]) shoots photons from every light in
//! proportion to its power (`shoot`) and stores them in three balanced kd-trees
//! ([`kdtree`]): the *caustic* map (paths `L S+ D`), the *indirect* map (paths with a
//! non-specular bounce) and, for final gathering, the *direct* map (`L D`). With final gathering
//! it then precomputes irradiance at a fraction of the photon hits (Christensen's *radiance
//! photons*), so that a gather ray needs one nearest-neighbour lookup instead of a full density
//! estimate.
//!
//! Rendering ([`PhotonMapper::li`]) splits the light at the first non-specular surface a camera
//! path reaches (after any specular bounces, followed by recursion):
//! - emitted light, and direct light by sampling the lights (shadow rays);
//! - caustics from the caustic map (a `k`-nearest-neighbour radiance estimate with a filter);
//! - indirect light by *final gathering*: rays sampled from the BSDF (and optionally guided by
//!   the directions of nearby photons, with multiple importance sampling) read the radiance
//!   photons where they land; without final gathering, the indirect map's estimate directly.
//!
//! The scene is analysed first, and `--stats` reports what was skipped and why ([`PhotonStats`]): no
//! caustic map without a specular surface reached from a light, no global map and no final
//! gathering without diffuse interreflection, no light sampling or shadow rays toward a light
//! that cannot reach the point ([`cull`]).
//!
//! A progressive pass ([`progressive`]) reads its photons from grids and builds only the
//! kd-trees that it reads ([`progressive::build_pass_maps`]).
//!
//! Deterministic: photon paths are numbered and seeded by their number, merged in order, and the
//! kd-trees are built deterministically, so an image depends only on the seed, never on the
//! thread count.

pub mod caustic_export;
pub mod clip;
pub mod cull;
mod emission;
pub mod estimate;
pub mod grid;
pub mod irradiance_cache;
pub mod kdtree;
mod octahedral;
pub mod progressive;
mod render;
pub mod search_radius;
mod settings;
pub(crate) mod shoot;

use crate::integrators::{Integrator, Radiance, RayCounters};
use crate::sampler::Sampler;
use crate::world::{Ray, World};
use cull::{CullReason, LightBounds};
pub use estimate::PhotonFilter;
use glam::Vec3;
use kdtree::{KdTree, Positioned};
pub use octahedral::{pack_unit, unpack_unit};
use rayon::prelude::*;
pub use settings::{
    GatherSampling, MAX_GATHER_SAMPLES, MAX_NUSED, MAX_PHOTONS, PILOT_PATHS, PhotonMapSettings,
    RADIANCE_FRACTION,
};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// A stored photon: where it landed, its power (divided by the paths of its map), the direction
/// it came from and the surface normal on that side, both as octahedral unit vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photon {
    pub p: Vec3,
    pub power: Vec3,
    pub wi: u32,
    pub n: u32,
}

impl Positioned for Photon {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// Irradiance precomputed at a photon hit, with the normal on the side it is valid for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiancePhoton {
    pub p: Vec3,
    pub n: u32,
    pub irradiance: Vec3,
}

impl Positioned for RadiancePhoton {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// Size and cost of one photon map.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MapStats {
    pub photons: usize,
    /// Light paths its photons are normalised by.
    pub paths: u64,
    /// Bytes of its kd-tree; 0 where none is kept (a progressive pass reads its photons from
    /// the pass's grids).
    pub bytes: usize,
    /// Total power of its photons: the flux the map carries onto surfaces (an unbiased
    /// estimate, whatever the density estimates do with it). Zero for radiance photons, which
    /// store irradiance.
    pub flux: Vec3,
}

/// What the photon mapper built, skipped and did, for `--stats`.
#[derive(Clone, Debug, Default)]
pub struct PhotonStats {
    pub caustic: Option<MapStats>,
    pub direct: Option<MapStats>,
    pub indirect: Option<MapStats>,
    pub radiance: Option<MapStats>,
    pub paths_traced: u64,
    pub photon_rays: u64,
    /// Spheres the caustic photons were aimed at (`None`: not aimed).
    pub caustic_aim_spheres: Option<usize>,
    /// The search radius (`maxdist`) used, and what its default was measured from (`None`
    /// where the RIB gave it).
    pub max_dist: f32,
    pub max_dist_measured: Option<search_radius::Measured>,
    pub final_gather: bool,
    pub time_shoot: Duration,
    pub time_build: Duration,
    pub time_radiance: Duration,
    /// Filled after rendering: gather rays and density lookups.
    pub gather_rays: u64,
    pub lookups: u64,
    /// Density estimates and radiance-photon lookups that met more photons than their search
    /// budget and were cut short.
    pub capped_estimates: u64,
    pub capped_radiance_lookups: u64,
    /// Light evaluations skipped per reason.
    pub culled: Vec<(CullReason, u64)>,
    /// What the analysis skipped and why.
    pub skipped: Vec<String>,
    /// Problems met while preparing (e.g. shooting stopped at the path limit).
    pub warnings: Vec<String>,
    /// Progressive mode: the pass and its search radii (squared).
    pub progressive: Option<(u32, progressive::Radii)>,
    /// The irradiance cache's records and use, where one was built.
    pub irradiance_cache: Option<irradiance_cache::CacheStats>,
}

impl PhotonStats {
    /// Lines for `--stats` (without a prefix).
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        let map = |name: &str, m: &Option<MapStats>| match m {
            Some(m) if m.bytes == 0 => {
                format!(
                    "{name} map: {} photons from {} paths, in the pass's photon grids",
                    m.photons, m.paths
                )
            }
            Some(m) => format!(
                "{name} map: {} photons from {} paths, {:.2} MiB",
                m.photons,
                m.paths,
                m.bytes as f64 / (1024.0 * 1024.0)
            ),
            None => format!("{name} map: not built"),
        };
        out.push(format!(
            "photons: {} paths traced, {} photon rays; shoot {:.3} s, kd-trees or grids {:.3} s, radiance photons {:.3} s",
            self.paths_traced,
            self.photon_rays,
            self.time_shoot.as_secs_f64(),
            self.time_build.as_secs_f64(),
            self.time_radiance.as_secs_f64()
        ));
        out.push(map("caustic", &self.caustic));
        if let Some(n) = self.caustic_aim_spheres {
            out.push(format!("caustic photons aimed at {n} bounding spheres of specular shapes"));
        }
        out.push(map("direct", &self.direct));
        out.push(map("indirect", &self.indirect));
        out.push(map("radiance-photon", &self.radiance));
        let source = search_radius::describe(self.max_dist_measured.as_ref(), self.max_dist);
        out.push(format!(
            "photon lookups: {} density estimates, {} final-gather rays (max distance {:.4}: {source}); cut at their search budget: {} density estimates, {} radiance-photon lookups",
            self.lookups, self.gather_rays, self.max_dist, self.capped_estimates, self.capped_radiance_lookups
        ));
        out.extend(self.irradiance_cache.as_ref().map(|c| c.line()));
        if let Some((pass, r)) = &self.progressive {
            let median = |f: &Option<std::sync::Arc<progressive::RadiusField>>| {
                f.as_ref().map_or("none".to_string(), |f| {
                    let (sites, r0) = f.summary();
                    format!("{:.5} ({sites} sites)", r0 * r.scale.sqrt())
                })
            };
            out.push(format!(
                "progressive photon mapping: pass {}, radii {:.4} of the first; median radius {} (gather), {} (caustic)",
                pass + 1,
                r.scale.sqrt(),
                median(&r.global),
                median(&r.caustic)
            ));
        }
        out
    }
}

/// Counters shared by the render threads.
#[derive(Debug, Default)]
struct SharedCounters {
    gather_rays: AtomicU64,
    lookups: AtomicU64,
    capped_estimates: AtomicU64,
    capped_radiance_lookups: AtomicU64,
    culled: [AtomicU64; 3],
}

/// A photon mapper prepared for one world.
#[derive(Debug)]
pub struct PhotonMapper {
    settings: PhotonMapSettings,
    caustic: Option<KdTree<Photon>>,
    direct: Option<KdTree<Photon>>,
    indirect: Option<KdTree<Photon>>,
    radiance: Option<KdTree<RadiancePhoton>>,
    /// Records of the final gather's indirect irradiance over the view, once built.
    irradiance_cache: Option<irradiance_cache::IrradianceCache>,
    /// Whether final gathering runs (it is skipped without interreflection).
    gather: bool,
    max_d2: f32,
    light_bounds: Vec<LightBounds>,
    cull_lights: bool,
    stats: PhotonStats,
    counters: SharedCounters,
    /// Progressive mode: the fixed search radii of this pass and its photons in grids for them.
    fixed: Option<progressive::FixedRadius>,
    /// The render's seed and this map's pass (progressive mode prepares one mapper per pass).
    seed: u64,
    pass: u32,
    /// The radii of the first pass, which later passes shrink.
    first_radii: Option<progressive::Radii>,
    /// With `caustic_paths`, the caustic map's photons in shooting order and their paths.
    caustic_paths: Option<caustic_export::CausticPaths>,
}

impl PhotonMapper {
    /// Shoots the photons and builds the maps for `world`; `seed` seeds every photon path.
    /// What the analysis skipped is in [`PhotonMapper::stats`].
    pub fn prepare(world: &World, settings: PhotonMapSettings, seed: u64) -> PhotonMapper {
        PhotonMapper::prepare_pass(world, settings, seed, 0, None)
    }

    /// The mapper of pass `pass` of a progressive render (fresh photons, shrunk radii); for a
    /// plain photon map the same as [`PhotonMapper::prepare`].
    pub fn next_pass(&self, world: &World) -> PhotonMapper {
        PhotonMapper::prepare_pass(world, self.settings, self.seed, self.pass + 1, self.first_radii.clone())
    }

    fn prepare_pass(
        world: &World,
        settings: PhotonMapSettings,
        render_seed: u64,
        pass: u32,
        first_radii: Option<progressive::Radii>,
    ) -> PhotonMapper {
        let seed = if settings.progressive { progressive::pass_seed(render_seed, pass) } else { render_seed };
        let mut stats = PhotonStats { final_gather: settings.final_gather, ..PhotonStats::default() };
        let analysis = settings.scene_analysis;

        // What the scene's surfaces can do (every attribute state's shader: conservative, an
        // unused one can only keep a map that the pilot then finds empty).
        let mut has_specular = false;
        let mut has_non_specular = false;
        for m in &world.materials {
            let bsdf = m.bsdf(Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Z, Vec3::X, glam::Vec2::ZERO, 0.0);
            has_specular |= m.has_specular();
            has_non_specular |= bsdf.has_non_specular();
        }
        let emitters = shoot::Emitters::new(world);
        let skip = |what: String, stats: &mut PhotonStats| stats.skipped.push(what);

        let mut want_caustic = settings.caustic_photons > 0;
        let mut want_indirect = settings.indirect_photons > 0;
        if settings.caustic_photons == 0 {
            skip("caustic photon map (causticphotons is 0)".into(), &mut stats);
        }
        if settings.indirect_photons == 0 {
            skip("indirect photon map (indirectphotons is 0)".into(), &mut stats);
        }
        if analysis {
            if emitters.lights.is_empty() && (want_caustic || want_indirect) {
                skip("photon maps (no light emits photons)".into(), &mut stats);
                want_caustic = false;
                want_indirect = false;
            }
            if want_caustic && !(has_specular && has_non_specular) {
                let why = if has_specular {
                    "no non-specular surface to store them"
                } else {
                    "no specular surface in the scene"
                };
                skip(format!("caustic photon map ({why})"), &mut stats);
                want_caustic = false;
            }
            if want_indirect && !has_non_specular {
                skip("indirect photon map (no non-specular surface)".into(), &mut stats);
                want_indirect = false;
            }
        }
        if !settings.final_gather {
            skip("direct photons (final gathering is off: direct light is sampled)".into(), &mut stats);
        }

        let request = shoot::ShootRequest {
            caustic: want_caustic.then_some(settings.caustic_photons as usize),
            indirect: want_indirect.then_some(settings.indirect_photons as usize),
            direct: settings.final_gather,
            radiance_fraction: if settings.final_gather && settings.radiance_photons && !settings.progressive
            {
                RADIANCE_FRACTION
            } else {
                0.0
            },
            max_depth: settings.max_photon_depth.max(1),
            seed,
            pilot_paths: PILOT_PATHS,
            max_paths: 200 * u64::from(settings.caustic_photons.max(settings.indirect_photons)) + (1 << 20),
            caustic_paths: settings.caustic_paths && !settings.progressive,
        };
        let shoot_start = Instant::now();
        let aim = (want_caustic && settings.caustic_aim)
            .then(|| emission::Aim::from_boxes(&world.shape_bounds(|m| m.has_specular())));
        let shot = shoot::shoot(world, &emitters, &request, aim.as_ref());
        stats.caustic_aim_spheres = aim.as_ref().map(|a| a.spheres.len()).filter(|&n| n > 0);
        stats.time_shoot = shoot_start.elapsed();
        stats.paths_traced = shot.paths_traced;
        stats.photon_rays = shot.rays;
        if shot.caustic_abandoned {
            skip(
                format!(
                    "caustic photon map (no specular surface reached from the lights in {} photon paths)",
                    shot.caustic_paths
                ),
                &mut stats,
            );
        }
        let mut gather = settings.final_gather;
        if shot.indirect_abandoned {
            let what = if settings.final_gather {
                "global photon maps and final gathering"
            } else {
                "indirect photon map"
            };
            skip(
                format!(
                    "{what} (no diffuse interreflection: none of {} photon paths reached a second non-specular surface)",
                    shot.paths_traced
                ),
                &mut stats,
            );
            if analysis {
                gather = false;
            }
        } else if settings.final_gather && !want_indirect && analysis {
            gather = false;
        }
        if shot.hit_path_limit {
            stats.warnings.push(format!(
                "photon shooting stopped after {} paths before the maps were full",
                shot.paths_traced
            ));
        }

        let build_start = Instant::now();
        let map_stats = |photons: &[Photon], paths: u64| {
            let flux = photons.iter().fold(glam::DVec3::ZERO, |sum, p| sum + p.power.as_dvec3()).as_vec3();
            (!photons.is_empty()).then(|| {
                let photons = photons.iter().filter(|p| p.p.is_finite()).count();
                MapStats { photons, paths, bytes: 0, flux }
            })
        };
        stats.caustic = map_stats(&shot.caustic, shot.caustic_paths);
        stats.direct = map_stats(&shot.direct, shot.indirect_paths);
        stats.indirect = map_stats(&shot.indirect, shot.indirect_paths);
        let (_, scene_radius) = world.bounding_sphere();
        let max_dist_of =
            |m: &search_radius::Measured| search_radius::chosen(settings.max_dist, m, scene_radius);
        let recorded = shot.caustic_vertices.len() == shot.caustic.len();
        let caustic_paths = (request.caustic_paths && recorded && !shot.caustic.is_empty()).then(|| {
            caustic_export::CausticPaths { photons: shot.caustic.clone(), vertices: shot.caustic_vertices }
        });
        let (caustic, direct, indirect, fixed, first_radii, measured) = if settings.progressive {
            let photons = [shot.caustic, shot.direct, shot.indirect];
            let maps =
                progressive::build_pass_maps(photons, gather, &settings, first_radii, &max_dist_of, pass);
            stats.progressive = Some((pass, maps.fixed.radii.clone()));
            let (max_dist, measured) = (maps.first.max_dist, maps.first.measured);
            (None, None, maps.indirect, Some(maps.fixed), Some(maps.first), (max_dist, measured))
        } else {
            let tree = |photons: Vec<Photon>| (!photons.is_empty()).then(|| KdTree::build(photons));
            let (caustic, direct, indirect) = (tree(shot.caustic), tree(shot.direct), tree(shot.indirect));
            let maps = [caustic.as_ref(), direct.as_ref(), indirect.as_ref()];
            let measured =
                settings.max_dist.is_none().then(|| search_radius::measure(&maps, settings.n_used as usize));
            let max_dist = max_dist_of(&measured.unwrap_or_default());
            (caustic, direct, indirect, None, None, (max_dist, measured))
        };
        let (max_dist, measured) = measured;
        stats.max_dist = max_dist;
        stats.max_dist_measured = measured;
        let max_d2 = max_dist * max_dist;
        for (m, t) in
            [(&mut stats.caustic, &caustic), (&mut stats.direct, &direct), (&mut stats.indirect, &indirect)]
        {
            if let (Some(m), Some(t)) = (m.as_mut(), t) {
                m.photons = t.len();
                m.bytes = t.bytes();
            }
        }
        stats.time_build = build_start.elapsed();

        let radiance_start = Instant::now();
        let radiance = if gather && settings.radiance_photons && !shot.sites.is_empty() {
            let filter = settings.filter;
            let n_used = settings.n_used as usize;
            let maps = [&direct, &indirect, &caustic];
            let photons: Vec<RadiancePhoton> = shot
                .sites
                .par_iter()
                .map_init(
                    || estimate::Nearest::new(n_used),
                    |nearest, site| {
                        let q = estimate::Query { p: site.p, n: site.n, max_d2 };
                        let mut e = Vec3::ZERO;
                        for m in maps.iter().copied().flatten() {
                            e += estimate::irradiance(m, &q, filter, nearest);
                        }
                        RadiancePhoton { p: site.p, n: pack_unit(site.n), irradiance: e }
                    },
                )
                .collect();
            let t = KdTree::build(photons);
            stats.radiance = Some(MapStats {
                photons: t.len(),
                paths: shot.indirect_paths,
                bytes: t.bytes(),
                flux: Vec3::ZERO,
            });
            Some(t)
        } else {
            None
        };
        stats.time_radiance = radiance_start.elapsed();

        let light_bounds = world.lights.iter().map(LightBounds::new).collect();
        PhotonMapper {
            settings,
            caustic,
            direct,
            indirect,
            radiance,
            irradiance_cache: None,
            gather,
            max_d2,
            light_bounds,
            cull_lights: analysis,
            stats,
            counters: SharedCounters::default(),
            fixed,
            seed: render_seed,
            pass,
            first_radii,
            caustic_paths,
        }
    }

    pub fn settings(&self) -> &PhotonMapSettings {
        &self.settings
    }

    /// Whether final gathering runs.
    pub fn gathers(&self) -> bool {
        self.gather
    }

    /// The maps' kd-trees: caustic, direct, indirect. A progressive pass keeps none but the
    /// indirect map's for photon-guided gathering (its estimates read grids).
    pub fn maps(&self) -> [Option<&KdTree<Photon>>; 3] {
        [self.caustic.as_ref(), self.direct.as_ref(), self.indirect.as_ref()]
    }

    pub fn radiance_photons(&self) -> Option<&KdTree<RadiancePhoton>> {
        self.radiance.as_ref()
    }

    /// Statistics, with the render's counts so far.
    pub fn stats(&self) -> PhotonStats {
        let mut s = self.stats.clone();
        s.gather_rays = self.counters.gather_rays.load(Ordering::Relaxed);
        s.lookups = self.counters.lookups.load(Ordering::Relaxed);
        s.capped_estimates = self.counters.capped_estimates.load(Ordering::Relaxed);
        s.capped_radiance_lookups = self.counters.capped_radiance_lookups.load(Ordering::Relaxed);
        s.culled = CullReason::ALL
            .iter()
            .zip(&self.counters.culled)
            .map(|(r, c)| (*r, c.load(Ordering::Relaxed)))
            .filter(|(_, c)| *c > 0)
            .collect();
        s.irradiance_cache = self.irradiance_cache.as_ref().map(|c| c.stats());
        s
    }
}

impl Integrator for PhotonMapper {
    fn name(&self) -> String {
        "photonmap".into()
    }

    fn li(&self, world: &World, ray: Ray, sampler: &mut Sampler, counters: &mut RayCounters) -> Radiance {
        self.radiance(world, ray, sampler, counters)
    }

    fn stats(&self) -> Vec<String> {
        PhotonMapper::stats(self).lines()
    }

    /// The analysis' skips, then the light evaluations culled while rendering.
    fn skipped(&self) -> Vec<(String, usize)> {
        let s = PhotonMapper::stats(self);
        let mut out: Vec<(String, usize)> = s.skipped.iter().map(|w| (w.clone(), 1)).collect();
        out.extend(
            s.culled.iter().map(|(r, n)| {
                (format!("light samples and shadow rays (point {})", r.describe()), *n as usize)
            }),
        );
        out
    }

    fn warnings(&self) -> Vec<String> {
        self.stats.warnings.clone()
    }

    fn photon_stats(&self) -> Option<PhotonStats> {
        Some(PhotonMapper::stats(self))
    }

    fn prepare_view(&mut self, world: &World, view: &crate::integrators::ViewContext) -> RayCounters {
        self.build_irradiance_cache(world, view)
    }

    fn default_passes(&self) -> Option<u32> {
        self.settings.progressive.then_some(self.settings.passes)
    }

    fn caustic_photons(
        &self,
        world: &World,
        rays: &crate::render::CameraRays,
    ) -> Option<sidecar::CausticPhotons> {
        PhotonMapper::caustic_photons(self, world, rays)
    }

    /// Drops this pass's grids before the next pass builds its own: nothing reads them again.
    fn next_pass(&mut self, world: &World) -> Option<Box<dyn Integrator>> {
        self.settings.progressive.then(|| {
            (self.fixed, self.indirect) = (None, None);
            Box::new(PhotonMapper::next_pass(self, world)) as Box<dyn Integrator>
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::shader;
    use rib_parser::scene::ParamList;

    #[test]
    fn parameters_parse_and_range_errors_are_reported() {
        let call = shader(
            "photonmap",
            &[
                ("indirectphotons", 5000.0),
                ("nused", 0.0),
                ("maxdist", 0.25),
                ("finalgathersamples", 16.0),
                ("wobble", 1.0),
            ],
        );
        let (s, notes) = PhotonMapSettings::from_params(&call.params);
        assert_eq!(s.indirect_photons, 5000);
        assert_eq!(s.n_used, 1);
        assert_eq!(s.max_dist, Some(0.25));
        assert_eq!(s.final_gather_samples, 16);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes.iter().any(|n| n.contains("nused")));
        assert!(notes.iter().any(|n| n.contains("wobble")));
        let (d, notes) = PhotonMapSettings::from_params(&ParamList::default());
        assert_eq!(d, PhotonMapSettings::default());
        assert!(notes.is_empty());
    }
}

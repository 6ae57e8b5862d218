//! The settings of `SurfaceIntegrator "photonmap"`: its parameters (names as in pbrt-v1/v2 and
//! LRT), their defaults and limits, read from the RIB call with a note for each one ignored.

use super::{PhotonFilter, irradiance_cache, progressive};
use rib_parser::scene::ParamList;

/// How final-gather directions are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GatherSampling {
    /// From the BSDF (cosine-weighted for matte surfaces), stratified.
    Bsdf,
    /// Half from the BSDF, half in cones around the directions the nearest indirect photons
    /// arrived from (pbrt-v2), combined by the power heuristic.
    Photons,
}

/// Parameters of `SurfaceIntegrator "photonmap"` (names as in pbrt-v1/v2 and LRT).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonMapSettings {
    /// `causticphotons`: photons in the caustic map.
    pub caustic_photons: u32,
    /// `indirectphotons`: photons in the indirect map (the direct map fills alongside).
    pub indirect_photons: u32,
    /// `nused`: photons per density estimate.
    pub n_used: u32,
    /// `maxdist`: the largest search radius, in scene units; `None` for a tenth of the scene's
    /// bounding radius (so that a scaled scene renders the same).
    pub max_dist: Option<f32>,
    /// `finalgather`: estimate indirect light by final gathering (otherwise directly from the
    /// indirect map).
    pub final_gather: bool,
    /// `finalgathersamples`: gather rays per camera sample.
    pub final_gather_samples: u32,
    /// `gatherangle`: half-angle in degrees of the cones of photon-guided gathering.
    pub gather_angle_degrees: f32,
    /// `gathersampling`: `"bsdf"` or `"photons"`.
    pub gather_sampling: GatherSampling,
    /// `radiancephotons`: precompute irradiance at photons for final gathering.
    pub radiance_photons: bool,
    /// `filter`: `"box"`, `"cone"` or `"gaussian"` kernel for density estimates.
    pub filter: PhotonFilter,
    /// `causticaim`: shoot caustic photons only toward the specular shapes (a separate pass).
    pub caustic_aim: bool,
    /// `maxdepth` (or `maxspeculardepth`): specular bounces followed from the camera.
    pub max_depth: u32,
    /// `maxphotondepth`: bounces of a photon path (Russian roulette ends them first).
    pub max_photon_depth: u32,
    /// Analyse the scene and skip what it does not need (tests turn it off to show that the
    /// skips change nothing).
    pub scene_analysis: bool,
    /// `progressive`: render in passes with fresh photons and fixed-radius estimates whose
    /// radius shrinks each pass ([`progressive`]): consistent, no bias floor.
    pub progressive: bool,
    /// `alpha`: the fraction of photons kept per pass of the radius reduction (Knaus and
    /// Zwicker's `alpha`, in (0, 1)).
    pub alpha: f32,
    /// `passes`: passes of a progressive render (unless `--time` or `--target-error` decide).
    pub passes: u32,
    /// `irradiancecache` and its parameters ([`irradiance_cache`]).
    pub irradiance_cache: irradiance_cache::IrradianceCacheSettings,
    /// Keep the caustic photons' light paths for the sidecar's caustics file
    /// ([`caustic_export`]); not a RIB parameter: set when the render writes a depth table.
    pub caustic_paths: bool,
}

impl Default for PhotonMapSettings {
    fn default() -> PhotonMapSettings {
        PhotonMapSettings {
            caustic_photons: 20_000,
            indirect_photons: 100_000,
            n_used: 50,
            max_dist: None,
            final_gather: true,
            final_gather_samples: 8,
            gather_angle_degrees: 10.0,
            gather_sampling: GatherSampling::Bsdf,
            radiance_photons: true,
            filter: PhotonFilter::Box,
            caustic_aim: true,
            max_depth: 5,
            max_photon_depth: crate::integrators::UNBOUNDED_DEPTH,
            scene_analysis: true,
            progressive: false,
            alpha: progressive::DEFAULT_ALPHA,
            passes: progressive::DEFAULT_PASSES,
            irradiance_cache: irradiance_cache::IrradianceCacheSettings::default(),
            caustic_paths: false,
        }
    }
}

/// Largest photon count a map may be asked for (32 bytes each).
pub const MAX_PHOTONS: u32 = 20_000_000;
/// Largest `nused` and `finalgathersamples`.
pub const MAX_NUSED: u32 = 4096;
pub const MAX_GATHER_SAMPLES: u32 = 65_536;
/// Fraction of photon hits that become radiance photons (pbrt-v2's choice).
pub const RADIANCE_FRACTION: f32 = 0.125;
/// Photon paths of the pilot after which a map still empty is abandoned.
pub const PILOT_PATHS: u64 = 1 << 16;

pub(super) fn int_param(params: &ParamList, name: &str) -> Option<f64> {
    params
        .ints(name)
        .and_then(|v| v.first().map(|&i| f64::from(i)))
        .or_else(|| params.float(name).map(f64::from))
}

pub(super) fn bool_param(params: &ParamList, name: &str) -> Option<Result<bool, String>> {
    if let Some(s) = params.string(name) {
        return Some(match s.to_ascii_lowercase().as_str() {
            "true" | "on" | "yes" | "1" => Ok(true),
            "false" | "off" | "no" | "0" => Ok(false),
            other => Err(format!("\"{name}\" must be true or false, not \"{other}\"")),
        });
    }
    int_param(params, name).map(|v| Ok(v != 0.0))
}

const KNOWN_PARAMS: &[&str] = &[
    "causticphotons",
    "indirectphotons",
    "nused",
    "maxdist",
    "finalgather",
    "finalgathersamples",
    "gatherangle",
    "gathersampling",
    "radiancephotons",
    "filter",
    "causticaim",
    "maxdepth",
    "maxspeculardepth",
    "maxphotondepth",
    "progressive",
    "alpha",
    "passes",
];

impl PhotonMapSettings {
    /// Reads the parameters of a `SurfaceIntegrator "photonmap"` call; returns the settings and
    /// a message for every parameter that was unknown or out of range (and replaced).
    pub fn from_params(params: &ParamList) -> (PhotonMapSettings, Vec<String>) {
        let mut s = PhotonMapSettings::default();
        let mut notes = Vec::new();
        let count = |name: &str, default: u32, min: u32, max: u32, notes: &mut Vec<String>| -> u32 {
            match int_param(params, name) {
                None => default,
                Some(v) if v.is_finite() && v >= f64::from(min) && v <= f64::from(max) => v as u32,
                Some(v) => {
                    let clamped =
                        if v.is_finite() { v.clamp(f64::from(min), f64::from(max)) as u32 } else { default };
                    notes
                        .push(format!("photonmap \"{name}\" {v} is outside [{min}, {max}]: using {clamped}"));
                    clamped
                }
            }
        };
        s.caustic_photons = count("causticphotons", s.caustic_photons, 0, MAX_PHOTONS, &mut notes);
        s.indirect_photons = count("indirectphotons", s.indirect_photons, 0, MAX_PHOTONS, &mut notes);
        s.n_used = count("nused", s.n_used, 1, MAX_NUSED, &mut notes);
        s.final_gather_samples =
            count("finalgathersamples", s.final_gather_samples, 1, MAX_GATHER_SAMPLES, &mut notes);
        let depth_name =
            if params.get("maxspeculardepth").is_some() { "maxspeculardepth" } else { "maxdepth" };
        s.max_depth = count(depth_name, s.max_depth, 0, crate::integrators::UNBOUNDED_DEPTH, &mut notes);
        s.max_photon_depth =
            count("maxphotondepth", s.max_photon_depth, 1, crate::integrators::UNBOUNDED_DEPTH, &mut notes);
        s.passes = count("passes", s.passes, 1, progressive::MAX_PASSES, &mut notes);
        if let Some(a) = params.float("alpha") {
            if a.is_finite() && a > 0.0 && a < 1.0 {
                s.alpha = a;
            } else {
                notes.push(format!(
                    "photonmap \"alpha\" {a} must be in (0, 1): using {}",
                    progressive::DEFAULT_ALPHA
                ));
            }
        }
        if let Some(d) = params.float("maxdist") {
            if d.is_finite() && d > 0.0 {
                s.max_dist = Some(d);
            } else {
                notes.push(format!("photonmap \"maxdist\" {d} must be positive: using the default"));
            }
        }
        if let Some(a) = params.float("gatherangle") {
            if a.is_finite() && a > 0.0 && a <= 90.0 {
                s.gather_angle_degrees = a;
            } else {
                notes.push(format!("photonmap \"gatherangle\" {a} must be in (0, 90] degrees: using 10"));
            }
        }
        for (name, field) in [
            ("finalgather", &mut s.final_gather),
            ("radiancephotons", &mut s.radiance_photons),
            ("causticaim", &mut s.caustic_aim),
            ("progressive", &mut s.progressive),
        ] {
            match bool_param(params, name) {
                None => {}
                Some(Ok(v)) => *field = v,
                Some(Err(e)) => notes.push(format!("photonmap {e}")),
            }
        }
        match params.string("gathersampling") {
            None => {}
            Some("bsdf") => s.gather_sampling = GatherSampling::Bsdf,
            Some("photons") => s.gather_sampling = GatherSampling::Photons,
            Some(other) => notes
                .push(format!("photonmap \"gathersampling\" \"{other}\" is not bsdf or photons: using bsdf")),
        }
        match params.string("filter") {
            None => {}
            Some("box") => s.filter = PhotonFilter::Box,
            Some("cone") => s.filter = PhotonFilter::Cone { k: 1.1 },
            Some("gaussian") => s.filter = PhotonFilter::Gaussian,
            Some(other) => notes
                .push(format!("photonmap \"filter\" \"{other}\" is not box, cone or gaussian: using box")),
        }
        s.irradiance_cache.read(params, &mut notes);
        for p in &params.0 {
            if !KNOWN_PARAMS.contains(&p.name.as_str())
                && !irradiance_cache::PARAMS.contains(&p.name.as_str())
            {
                notes.push(format!("photonmap parameter \"{}\" is unknown: ignored", p.name));
            }
        }
        (s, notes)
    }
}

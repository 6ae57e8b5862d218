//! The probes file (`*.probes.exr`): two layers of 32-bit float channels, `irradiance`
//! (one pixel per probe, channels `sh.I.R/G/B` for the 9 SH coefficients) and `visibility`
//! (one row per probe, one pixel per octahedral texel, channels `mean` and `meansq`), with the
//! grid in the header (docs/sidecar.md).

use crate::error::{SidecarError, SidecarErrorKind};
use crate::layers_io::{
    ATTR_FINGERPRINT, ATTR_KIND, ATTR_VERSION, ReadLimits, fingerprint_attribute, read_all_layers,
    read_header,
};
use crate::probes::{ProbeGrid, VISIBILITY_TEXELS};
use crate::sh::SH_COEFFICIENTS;
use exr::prelude::*;
use std::collections::HashMap;
use std::path::Path;
use std::result::Result;

const KIND_PROBES: &str = "probes";
const GRID_NAMES: GridNames =
    GridNames { origin: "lrt.probes.origin", spacing: "lrt.probes.spacing", counts: "lrt.probes.counts" };
const ATTR_TEXELS: &str = "lrt.probes.visibility_texels";
/// `excluded` when the SH leaves out light emitters send straight to the probe, `included`
/// when it holds it; files without the attribute (written before it) hold it.
const ATTR_EMITTERS: &str = "lrt.probes.emitters";
/// Most probes a reader accepts.
const MAX_PROBES: u64 = 1 << 20;

fn sh_channel(i: usize, c: usize) -> String {
    format!("sh.{i}.{}", ["R", "G", "B"][c])
}

/// Writes `grid` to `path` atomically; refuses inconsistent sizes and non-finite values.
pub fn write_probes(grid: &ProbeGrid, path: &Path) -> Result<(), SidecarError> {
    let fail = |kind| SidecarError::new(path, kind);
    let n = grid.probe_count();
    let texels = VISIBILITY_TEXELS * VISIBILITY_TEXELS;
    if n == 0 || grid.radiance_sh.len() != n || grid.visibility.len() != n * texels {
        return Err(fail(SidecarErrorKind::Inconsistent {
            detail: format!(
                "{n} probes, {} SH sets, {} visibility texels",
                grid.radiance_sh.len(),
                grid.visibility.len()
            ),
        }));
    }
    let finite = grid
        .radiance_sh
        .iter()
        .flatten()
        .flatten()
        .chain(grid.visibility.iter().flatten())
        .all(|v| v.is_finite());
    if !finite {
        return Err(fail(SidecarErrorKind::NonFinite {
            channel: "probes".into(),
            x: 0,
            y: 0,
            value: f32::NAN,
        }));
    }
    let attributes = |name: &str| {
        let placement = (grid.origin, grid.spacing, grid.counts);
        let mut a = grid_attributes(name, KIND_PROBES, grid.depth_fingerprint, &GRID_NAMES, placement);
        a.other.insert(Text::from(ATTR_TEXELS), AttributeValue::I32(VISIBILITY_TEXELS as i32));
        let emitters = if grid.emitters_seen { "included" } else { "excluded" };
        a.other.insert(Text::from(ATTR_EMITTERS), AttributeValue::Text(Text::from(emitters)));
        a
    };
    let mut sh = Vec::new();
    for i in 0..SH_COEFFICIENTS {
        for c in 0..3 {
            let values = grid.radiance_sh.iter().map(|p| p[i][c]).collect();
            sh.push(AnyChannel::new(sh_channel(i, c).as_str(), FlatSamples::F32(values)));
        }
    }
    let irradiance = Layer::new(
        (n, 1),
        attributes("irradiance"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(sh)),
    );
    let vis = vec![
        AnyChannel::new("mean", FlatSamples::F32(grid.visibility.iter().map(|v| v[0]).collect())),
        AnyChannel::new("meansq", FlatSamples::F32(grid.visibility.iter().map(|v| v[1]).collect())),
    ];
    let visibility = Layer::new(
        (texels, n),
        attributes("visibility"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vis)),
    );
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((n.max(texels), n))),
        SmallVec::from_vec(vec![irradiance, visibility]),
    );
    crate::exr_file::write_exr_atomically(path, |writer| image.write().to_buffered(writer))
        .map_err(|e| fail(SidecarErrorKind::Io(e)))
}

/// Reads and validates the probes file at `path`; with `depth_fingerprint`, refuses probes of
/// another render. Every error names `path`.
pub fn read_probes(path: &Path, depth_fingerprint: Option<u64>) -> Result<ProbeGrid, SidecarError> {
    read_inner(path, depth_fingerprint).map_err(|kind| SidecarError::new(path, kind))
}

/// A grid's placement: origin, spacing, counts.
pub(crate) type Placement = ([f32; 3], [f32; 3], [u32; 3]);

/// The header attribute names of a probe grid's placement.
pub(crate) struct GridNames {
    pub origin: &'static str,
    pub spacing: &'static str,
    pub counts: &'static str,
}

/// A part's header attributes of a probe grid file of `kind`: version, kind, fingerprint and
/// the grid's `(origin, spacing, counts)`, each as a text of three numbers.
pub(crate) fn grid_attributes(
    layer: &str,
    kind: &str,
    fingerprint: u64,
    names: &GridNames,
    (origin, spacing, counts): Placement,
) -> LayerAttributes {
    let mut a = LayerAttributes::named(layer);
    let o = &mut a.other;
    o.insert(Text::from(ATTR_VERSION), AttributeValue::I32(crate::FORMAT_VERSION));
    o.insert(Text::from(ATTR_KIND), AttributeValue::Text(Text::from(kind)));
    o.insert(
        Text::from(ATTR_FINGERPRINT),
        AttributeValue::Text(Text::from(format!("{fingerprint:016x}").as_str())),
    );
    let triple = |v: [String; 3]| AttributeValue::Text(Text::from(v.join(" ").as_str()));
    o.insert(Text::from(names.origin), triple(origin.map(|v| v.to_string())));
    o.insert(Text::from(names.spacing), triple(spacing.map(|v| v.to_string())));
    o.insert(Text::from(names.counts), triple(counts.map(|v| v.to_string())));
    a
}

/// The grid's placement from the header, checked: finite origin, positive spacing, between 1
/// and `max_probes` probes (`what` names the count in the error). Returns the probe count too.
pub(crate) fn read_grid(
    attrs: &HashMap<Text, AttributeValue>,
    names: &GridNames,
    what: &'static str,
    max_probes: u64,
) -> Result<(Placement, usize), SidecarErrorKind> {
    let origin: [f32; 3] = parse_triple(attrs, names.origin)?;
    let spacing: [f32; 3] = parse_triple(attrs, names.spacing)?;
    let counts: [u32; 3] = parse_triple(attrs, names.counts)?;
    if !origin.iter().all(|v| v.is_finite()) || !spacing.iter().all(|v| v.is_finite() && *v > 0.0) {
        return Err(SidecarErrorKind::BadAttribute {
            name: names.spacing.into(),
            detail: "origin must be finite and spacing positive".into(),
        });
    }
    let n = counts.iter().map(|&c| u64::from(c)).product::<u64>();
    if n == 0 || n > max_probes {
        return Err(SidecarErrorKind::TooLarge { what, size: n, limit: max_probes });
    }
    Ok(((origin, spacing, counts), n as usize))
}

/// The values of channel `c` (named `full` in errors) of a layer `width` pixels wide, as `f32`;
/// refuses integer channels and NaN or infinity.
pub(crate) fn finite_values(
    full: &str,
    c: &AnyChannel<FlatSamples>,
    width: usize,
) -> Result<Vec<f32>, SidecarErrorKind> {
    let values = match &c.sample_data {
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::U32(_) => {
            return Err(SidecarErrorKind::BadAttribute {
                name: c.name.to_string(),
                detail: "channel holds integers".into(),
            });
        }
    };
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        let w = width.max(1);
        return Err(SidecarErrorKind::NonFinite {
            channel: full.into(),
            x: (i % w) as u32,
            y: (i / w) as u32,
            value: values[i],
        });
    }
    Ok(values)
}

/// Removes channel `name` from `channels`, or says it is missing, listing the channels there are.
pub(crate) fn take_channel(
    channels: &mut HashMap<String, Vec<f32>>,
    name: String,
) -> Result<Vec<f32>, SidecarErrorKind> {
    match channels.remove(&name) {
        Some(v) => Ok(v),
        None => {
            let mut found: Vec<String> = channels.keys().cloned().collect();
            found.sort();
            Err(SidecarErrorKind::MissingChannel { name, found })
        }
    }
}

pub(crate) fn parse_triple<T: std::str::FromStr>(
    attrs: &HashMap<Text, AttributeValue>,
    name: &str,
) -> Result<[T; 3], SidecarErrorKind> {
    let bad = |detail: String| SidecarErrorKind::BadAttribute { name: name.into(), detail };
    let Some(AttributeValue::Text(t)) = attrs.get(&Text::from(name)) else {
        return Err(SidecarErrorKind::MissingAttribute { name: name.into() });
    };
    let text = t.to_string();
    let parts: Vec<T> = text
        .split(' ')
        .map(|p| p.parse::<T>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad(format!("`{text}` is not three numbers")))?;
    <[T; 3]>::try_from(parts).map_err(|_| bad(format!("`{text}` is not three numbers")))
}

fn read_inner(path: &Path, expected: Option<u64>) -> Result<ProbeGrid, SidecarErrorKind> {
    let limits = ReadLimits { max_pixels: MAX_PROBES * 64, ..ReadLimits::default() };
    let header = read_header(path, KIND_PROBES, limits)?;
    let attrs = &header.own_attributes.other;
    let fingerprint = fingerprint_attribute(attrs)?;
    if let Some(expected) = expected
        && expected != fingerprint
    {
        return Err(SidecarErrorKind::Stale { expected, found: fingerprint });
    }
    let ((origin, spacing, counts), n) = read_grid(attrs, &GRID_NAMES, "probe count", MAX_PROBES)?;
    match attrs.get(&Text::from(ATTR_TEXELS)) {
        Some(AttributeValue::I32(t)) if *t as usize == VISIBILITY_TEXELS => {}
        _ => {
            return Err(SidecarErrorKind::BadAttribute {
                name: ATTR_TEXELS.into(),
                detail: format!("expected {VISIBILITY_TEXELS}"),
            });
        }
    }
    let emitters_seen = match attrs.get(&Text::from(ATTR_EMITTERS)) {
        None => true,
        Some(AttributeValue::Text(t)) if t == "included" => true,
        Some(AttributeValue::Text(t)) if t == "excluded" => false,
        Some(_) => {
            return Err(SidecarErrorKind::BadAttribute {
                name: ATTR_EMITTERS.into(),
                detail: "expected `included` or `excluded`".into(),
            });
        }
    };
    let texels = VISIBILITY_TEXELS * VISIBILITY_TEXELS;
    let image = read_all_layers(path)?;
    let mut channels: HashMap<String, Vec<f32>> = HashMap::new();
    for layer in &image.layer_data {
        let name = layer.attributes.layer_name.as_ref().map(|t| t.to_string()).unwrap_or_default();
        let expected_size = if name == "irradiance" { (n, 1) } else { (texels, n) };
        if (layer.size.0, layer.size.1) != expected_size {
            return Err(SidecarErrorKind::SizeMismatch {
                expected: (expected_size.0 as u32, expected_size.1 as u32),
                found: (layer.size.0 as u64, layer.size.1 as u64),
            });
        }
        for c in &layer.channel_data.list {
            let full = format!("{name}.{}", c.name);
            let values = finite_values(&full, c, layer.size.0)?;
            channels.insert(full, values);
        }
    }
    let mut take = |name: String| take_channel(&mut channels, name);
    let mut radiance_sh = vec![[[0.0f32; 3]; SH_COEFFICIENTS]; n];
    for i in 0..SH_COEFFICIENTS {
        for c in 0..3 {
            let values = take(format!("irradiance.{}", sh_channel(i, c)))?;
            for (p, v) in radiance_sh.iter_mut().zip(values) {
                p[i][c] = v;
            }
        }
    }
    let mean = take("visibility.mean".into())?;
    let mean_sq = take("visibility.meansq".into())?;
    let visibility = mean.into_iter().zip(mean_sq).map(|(m, s)| [m, s]).collect();
    Ok(ProbeGrid {
        depth_fingerprint: fingerprint,
        origin,
        spacing,
        counts,
        radiance_sh,
        visibility,
        emitters_seen,
    })
}

//! The probes file (`*.probes.exr`): two layers of 32-bit float channels, `irradiance`
//! (one pixel per probe, channels `sh.I.R/G/B` for the 9 SH coefficients) and `visibility`
//! (one row per probe, one pixel per octahedral texel, channels `mean` and `meansq`), with the
//! grid in the header (docs/sidecar.md).

use crate::error::{SidecarError, SidecarErrorKind};
use crate::layers_io::{
    ATTR_FINGERPRINT, ATTR_KIND, ATTR_VERSION, ReadLimits, exr_error, fingerprint_attribute, read_header,
};
use crate::probes::{ProbeGrid, VISIBILITY_TEXELS};
use crate::sh::SH_COEFFICIENTS;
use exr::prelude::*;
use std::collections::HashMap;
use std::io;
use std::path::Path;
use std::result::Result;

const KIND_PROBES: &str = "probes";
const ATTR_ORIGIN: &str = "lrt.probes.origin";
const ATTR_SPACING: &str = "lrt.probes.spacing";
const ATTR_COUNTS: &str = "lrt.probes.counts";
const ATTR_TEXELS: &str = "lrt.probes.visibility_texels";
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
        let mut a = LayerAttributes::named(name);
        let o = &mut a.other;
        o.insert(Text::from(ATTR_VERSION), AttributeValue::I32(crate::FORMAT_VERSION));
        o.insert(Text::from(ATTR_KIND), AttributeValue::Text(Text::from(KIND_PROBES)));
        o.insert(
            Text::from(ATTR_FINGERPRINT),
            AttributeValue::Text(Text::from(format!("{:016x}", grid.depth_fingerprint).as_str())),
        );
        let triple = |v: [String; 3]| AttributeValue::Text(Text::from(v.join(" ").as_str()));
        o.insert(Text::from(ATTR_ORIGIN), triple(grid.origin.map(|v| v.to_string())));
        o.insert(Text::from(ATTR_SPACING), triple(grid.spacing.map(|v| v.to_string())));
        o.insert(Text::from(ATTR_COUNTS), triple(grid.counts.map(|v| v.to_string())));
        o.insert(Text::from(ATTR_TEXELS), AttributeValue::I32(VISIBILITY_TEXELS as i32));
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
    depth_remap::table::write_atomically(path, |writer| {
        image.write().to_buffered(writer).map_err(|e| match e {
            exr::error::Error::Io(io) => io,
            other => io::Error::other(other.to_string()),
        })
    })
    .map_err(|e| fail(SidecarErrorKind::Io(e)))
}

/// Reads and validates the probes file at `path`; with `depth_fingerprint`, refuses probes of
/// another render. Every error names `path`.
pub fn read_probes(path: &Path, depth_fingerprint: Option<u64>) -> Result<ProbeGrid, SidecarError> {
    read_inner(path, depth_fingerprint).map_err(|kind| SidecarError::new(path, kind))
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
    let origin: [f32; 3] = parse_triple(attrs, ATTR_ORIGIN)?;
    let spacing: [f32; 3] = parse_triple(attrs, ATTR_SPACING)?;
    let counts: [u32; 3] = parse_triple(attrs, ATTR_COUNTS)?;
    if !origin.iter().all(|v| v.is_finite()) || !spacing.iter().all(|v| v.is_finite() && *v > 0.0) {
        return Err(SidecarErrorKind::BadAttribute {
            name: ATTR_SPACING.into(),
            detail: "origin must be finite and spacing positive".into(),
        });
    }
    let n = counts.iter().map(|&c| u64::from(c)).product::<u64>();
    if n == 0 || n > MAX_PROBES {
        return Err(SidecarErrorKind::TooLarge { what: "probe count", size: n, limit: MAX_PROBES });
    }
    match attrs.get(&Text::from(ATTR_TEXELS)) {
        Some(AttributeValue::I32(t)) if *t as usize == VISIBILITY_TEXELS => {}
        _ => {
            return Err(SidecarErrorKind::BadAttribute {
                name: ATTR_TEXELS.into(),
                detail: format!("expected {VISIBILITY_TEXELS}"),
            });
        }
    }
    let n = n as usize;
    let texels = VISIBILITY_TEXELS * VISIBILITY_TEXELS;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(exr_error)?;
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
            let full = format!("{name}.{}", c.name);
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                let w = layer.size.0.max(1);
                return Err(SidecarErrorKind::NonFinite {
                    channel: full,
                    x: (i % w) as u32,
                    y: (i / w) as u32,
                    value: values[i],
                });
            }
            channels.insert(full, values);
        }
    }
    let found = |channels: &HashMap<String, Vec<f32>>| {
        let mut v: Vec<String> = channels.keys().cloned().collect();
        v.sort();
        v
    };
    let mut take = |name: String| match channels.remove(&name) {
        Some(v) => Ok(v),
        None => Err(SidecarErrorKind::MissingChannel { found: found(&channels), name }),
    };
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
    Ok(ProbeGrid { depth_fingerprint: fingerprint, origin, spacing, counts, radiance_sh, visibility })
}

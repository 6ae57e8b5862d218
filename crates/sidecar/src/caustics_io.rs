//! The caustics file (`*.caustics.exr`): three layers of 32-bit float channels, `photons` (one
//! pixel per photon: `P.x/y/z`, `N.x/y/z`, `power.R/G/B`, `segments.first`, `segments.count`),
//! `segments` (one pixel per path segment: `A.x/y/z` to `B.x/y/z`) and `pixels` (the frame:
//! `P.x/y/z`, `N.x/y/z`, `radius2`, `weight.R/G/B`), with the estimate's filter in the header
//! (docs/sidecar.md, "Caustic photons").

use crate::caustics::{
    CausticFilter, CausticPhoton, CausticPhotons, CausticPixel, MAX_CAUSTIC_PHOTONS, MAX_CAUSTIC_SEGMENTS,
};
use crate::error::{SidecarError, SidecarErrorKind};
use crate::layers_io::{
    ATTR_FINGERPRINT, ATTR_KIND, ATTR_VERSION, ReadLimits, fingerprint_attribute, read_all_layers,
    read_header,
};
use crate::probes_io::{finite_values, take_channel};
use exr::prelude::*;
use std::collections::HashMap;
use std::path::Path;
use std::result::Result;

const KIND_CAUSTICS: &str = "caustics";
const ATTR_FILTER: &str = "lrt.caustics.filter";
const XYZ: [&str; 3] = ["x", "y", "z"];
const RGB: [&str; 3] = ["R", "G", "B"];

fn filter_text(filter: CausticFilter) -> String {
    match filter {
        CausticFilter::Box => "box".into(),
        CausticFilter::Cone { k } => format!("cone {k}"),
        CausticFilter::Gaussian => "gaussian".into(),
    }
}

fn parse_filter(text: &str) -> Option<CausticFilter> {
    let mut words = text.split(' ');
    let filter = match (words.next()?, words.next()) {
        ("box", None) => CausticFilter::Box,
        ("gaussian", None) => CausticFilter::Gaussian,
        ("cone", Some(k)) => {
            CausticFilter::Cone { k: k.parse::<f32>().ok().filter(|k| k.is_finite() && *k >= 1.0)? }
        }
        _ => return None,
    };
    words.next().is_none().then_some(filter)
}

fn channel(name: String, values: Vec<f32>) -> AnyChannel<FlatSamples> {
    AnyChannel::new(name.as_str(), FlatSamples::F32(values))
}

/// Channels `PREFIX.x/y/z` (or `R/G/B`) of `items`' three-vectors.
fn triple_channels<T>(
    prefix: &str,
    names: [&str; 3],
    items: &[T],
    get: impl Fn(&T) -> [f32; 3],
) -> Vec<AnyChannel<FlatSamples>> {
    (0..3)
        .map(|c| channel(format!("{prefix}.{}", names[c]), items.iter().map(|i| get(i)[c]).collect()))
        .collect()
}

/// Writes `caustics` to `path` atomically; refuses inconsistent sizes, out-of-range segment
/// references and non-finite values.
pub fn write_caustics(caustics: &CausticPhotons, path: &Path) -> Result<(), SidecarError> {
    let fail = |kind| SidecarError::new(path, kind);
    check(caustics).map_err(fail)?;
    let layer = |name: &str, size: (usize, usize), channels: Vec<AnyChannel<FlatSamples>>| {
        let mut a = LayerAttributes::named(name);
        let o = &mut a.other;
        o.insert(Text::from(ATTR_VERSION), AttributeValue::I32(crate::FORMAT_VERSION));
        o.insert(Text::from(ATTR_KIND), AttributeValue::Text(Text::from(KIND_CAUSTICS)));
        o.insert(
            Text::from(ATTR_FINGERPRINT),
            AttributeValue::Text(Text::from(format!("{:016x}", caustics.depth_fingerprint).as_str())),
        );
        o.insert(
            Text::from(ATTR_FILTER),
            AttributeValue::Text(Text::from(filter_text(caustics.filter).as_str())),
        );
        Layer::new(size, a, Encoding::SMALL_LOSSLESS, AnyChannels::sort(SmallVec::from_vec(channels)))
    };
    let ph = &caustics.photons;
    let mut photon_channels = triple_channels("P", XYZ, ph, |p| p.position);
    photon_channels.extend(triple_channels("N", XYZ, ph, |p| p.normal));
    photon_channels.extend(triple_channels("power", RGB, ph, |p| p.power));
    photon_channels
        .push(channel("segments.first".into(), ph.iter().map(|p| p.first_segment as f32).collect()));
    photon_channels
        .push(channel("segments.count".into(), ph.iter().map(|p| p.segment_count as f32).collect()));
    let seg = &caustics.segments;
    let mut segment_channels = triple_channels("A", XYZ, seg, |s| s[0]);
    segment_channels.extend(triple_channels("B", XYZ, seg, |s| s[1]));
    let px = &caustics.pixels;
    let mut pixel_channels = triple_channels("P", XYZ, px, |p| p.position);
    pixel_channels.extend(triple_channels("N", XYZ, px, |p| p.normal));
    pixel_channels.push(channel("radius2".into(), px.iter().map(|p| p.radius2).collect()));
    pixel_channels.extend(triple_channels("weight", RGB, px, |p| p.weight));
    let (w, h) = (caustics.width as usize, caustics.height as usize);
    let layers = vec![
        layer("photons", (ph.len(), 1), photon_channels),
        layer("segments", (seg.len(), 1), segment_channels),
        layer("pixels", (w, h), pixel_channels),
    ];
    let widest = ph.len().max(seg.len()).max(w);
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((widest, h))),
        SmallVec::from_vec(layers),
    );
    crate::exr_file::write_exr_atomically(path, |writer| image.write().to_buffered(writer))
        .map_err(|e| fail(SidecarErrorKind::Io(e)))
}

/// The invariants a writer keeps and a reader checks.
fn check(c: &CausticPhotons) -> Result<(), SidecarErrorKind> {
    let inconsistent = |detail: String| Err(SidecarErrorKind::Inconsistent { detail });
    if c.photons.is_empty() || c.photons.len() > MAX_CAUSTIC_PHOTONS {
        return inconsistent(format!("{} photons (1 to {MAX_CAUSTIC_PHOTONS})", c.photons.len()));
    }
    if c.segments.is_empty() || c.segments.len() > MAX_CAUSTIC_SEGMENTS {
        return inconsistent(format!("{} segments (1 to {MAX_CAUSTIC_SEGMENTS})", c.segments.len()));
    }
    if c.width == 0 || c.height == 0 || c.pixels.len() != c.width as usize * c.height as usize {
        return inconsistent(format!("{} pixel kernels for {}x{}", c.pixels.len(), c.width, c.height));
    }
    for (i, p) in c.photons.iter().enumerate() {
        let end = u64::from(p.first_segment) + u64::from(p.segment_count);
        if end > c.segments.len() as u64 {
            return inconsistent(format!("photon {i}'s segments end at {end}, past {}", c.segments.len()));
        }
    }
    let finite =
        c.photons.iter().all(|p| p.position.iter().chain(&p.normal).chain(&p.power).all(|v| v.is_finite()))
            && c.segments.iter().flatten().flatten().all(|v| v.is_finite())
            && c.pixels.iter().all(|p| {
                p.position.iter().chain(&p.normal).chain(&p.weight).chain([&p.radius2]).all(|v| v.is_finite())
            });
    if !finite {
        return Err(SidecarErrorKind::NonFinite { channel: "caustics".into(), x: 0, y: 0, value: f32::NAN });
    }
    Ok(())
}

/// Reads and validates the caustics file at `path` for a `width x height` frame; with
/// `depth_fingerprint`, refuses photons of another render. Every error names `path`.
pub fn read_caustics(
    path: &Path,
    (width, height): (u32, u32),
    depth_fingerprint: Option<u64>,
) -> Result<CausticPhotons, SidecarError> {
    read_inner(path, (width, height), depth_fingerprint).map_err(|kind| SidecarError::new(path, kind))
}

fn read_inner(
    path: &Path,
    (width, height): (u32, u32),
    expected: Option<u64>,
) -> Result<CausticPhotons, SidecarErrorKind> {
    let limits = ReadLimits { max_pixels: (MAX_CAUSTIC_SEGMENTS as u64) << 12, ..ReadLimits::default() };
    let header = read_header(path, KIND_CAUSTICS, limits)?;
    let attrs = &header.own_attributes.other;
    let fingerprint = fingerprint_attribute(attrs)?;
    if let Some(expected) = expected
        && expected != fingerprint
    {
        return Err(SidecarErrorKind::Stale { expected, found: fingerprint });
    }
    let filter = match attrs.get(&Text::from(ATTR_FILTER)) {
        Some(AttributeValue::Text(t)) => {
            parse_filter(&t.to_string()).ok_or_else(|| SidecarErrorKind::BadAttribute {
                name: ATTR_FILTER.into(),
                detail: format!("`{t}` is not `box`, `gaussian` or `cone K` with K >= 1"),
            })?
        }
        _ => return Err(SidecarErrorKind::MissingAttribute { name: ATTR_FILTER.into() }),
    };
    let image = read_all_layers(path)?;
    let mut channels: HashMap<String, Vec<f32>> = HashMap::new();
    let mut sizes: HashMap<String, (usize, usize)> = HashMap::new();
    for layer in &image.layer_data {
        let name = layer.attributes.layer_name.as_ref().map(|t| t.to_string()).unwrap_or_default();
        sizes.insert(name.clone(), (layer.size.0, layer.size.1));
        for c in &layer.channel_data.list {
            let full = format!("{name}.{}", c.name);
            channels.insert(full.clone(), finite_values(&full, c, layer.size.0)?);
        }
    }
    let size_of = |name: &str| sizes.get(name).copied().unwrap_or((0, 0));
    let (photon_count, segment_count) = (size_of("photons").0, size_of("segments").0);
    if size_of("pixels") != (width as usize, height as usize) {
        let (w, h) = size_of("pixels");
        return Err(SidecarErrorKind::SizeMismatch {
            expected: (width, height),
            found: (w as u64, h as u64),
        });
    }
    for (what, n, limit) in [
        ("caustic photons", photon_count, MAX_CAUSTIC_PHOTONS),
        ("caustic path segments", segment_count, MAX_CAUSTIC_SEGMENTS),
    ] {
        if n > limit {
            return Err(SidecarErrorKind::TooLarge { what, size: n as u64, limit: limit as u64 });
        }
    }
    let mut take = |name: String| take_channel(&mut channels, name);
    let mut triple = |prefix: &str, names: [&str; 3]| -> Result<Vec<[f32; 3]>, SidecarErrorKind> {
        let [a, b, c] = names.map(|n| take(format!("{prefix}.{n}")));
        let (a, b, c) = (a?, b?, c?);
        Ok(a.into_iter().zip(b).zip(c).map(|((a, b), c)| [a, b, c]).collect())
    };
    let positions = triple("photons.P", XYZ)?;
    let normals = triple("photons.N", XYZ)?;
    let powers = triple("photons.power", RGB)?;
    let starts = triple("segments.A", XYZ)?;
    let ends = triple("segments.B", XYZ)?;
    let pixel_positions = triple("pixels.P", XYZ)?;
    let pixel_normals = triple("pixels.N", XYZ)?;
    let weights = triple("pixels.weight", RGB)?;
    let index = |v: f32| (v >= 0.0 && v <= (1u32 << 24) as f32 && v.fract() == 0.0).then_some(v as u32);
    let mut take = |name: &str| take_channel(&mut channels, name.into());
    let firsts = take("photons.segments.first")?;
    let counts = take("photons.segments.count")?;
    let radii = take("pixels.radius2")?;
    let mut photons = Vec::with_capacity(photon_count);
    for i in 0..photon_count {
        let (Some(first_segment), Some(segment_count)) = (index(firsts[i]), index(counts[i])) else {
            return Err(SidecarErrorKind::BadAttribute {
                name: "photons.segments".into(),
                detail: format!("photon {i}'s segment range is not two whole numbers"),
            });
        };
        photons.push(CausticPhoton {
            position: positions[i],
            normal: normals[i],
            power: powers[i],
            first_segment,
            segment_count,
        });
    }
    let segments = starts.into_iter().zip(ends).map(|(a, b)| [a, b]).collect();
    let pixels = (0..radii.len())
        .map(|i| CausticPixel {
            position: pixel_positions[i],
            normal: pixel_normals[i],
            radius2: radii[i],
            weight: weights[i],
        })
        .collect();
    let caustics =
        CausticPhotons { depth_fingerprint: fingerprint, width, height, filter, photons, segments, pixels };
    check(&caustics)?;
    if caustics.pixels.iter().any(|p| p.radius2 < 0.0) {
        return Err(SidecarErrorKind::BadAttribute {
            name: "pixels.radius2".into(),
            detail: "negative".into(),
        });
    }
    Ok(caustics)
}

//! The reflection probes file (`*.reflections.exr`): one layer per mip level, `radiance.K`
//! (one row per probe, `reflection_level_texels(K)^2` pixels per row, channels `R`, `G`, `B`),
//! `distance` (one row per probe, `REFLECTION_TEXELS^2` pixels, channel `Z`) and, where some
//! texel's first surface is a mirror or glass, `specular` (the same size, channel `S`, 1 there,
//! else 0), with the grid and the level layout in the header (docs/sidecar.md).

use crate::error::{SidecarError, SidecarErrorKind};
use crate::layers_io::{ReadLimits, fingerprint_attribute, read_all_layers, read_header};
use crate::probes_io::{GridNames, finite_values, grid_attributes, read_grid, take_channel};
use crate::reflections::{
    REFLECTION_LEVELS, REFLECTION_TEXELS, ReflectionProbes, reflection_level_roughness,
    reflection_level_texels,
};
use exr::prelude::*;
use std::collections::HashMap;
use std::io;
use std::path::Path;
use std::result::Result;

const KIND_REFLECTIONS: &str = "reflections";
const GRID_NAMES: GridNames = GridNames {
    origin: "lrt.reflections.origin",
    spacing: "lrt.reflections.spacing",
    counts: "lrt.reflections.counts",
};
const ATTR_TEXELS: &str = "lrt.reflections.texels";
const ATTR_LEVELS: &str = "lrt.reflections.levels";
const ATTR_ROUGHNESS: &str = "lrt.reflections.roughness";
/// Most reflection probes a reader accepts (each is 1365 texels of radiance and 1024 of
/// distance: 4096 probes are about 60 MiB).
pub const MAX_REFLECTION_PROBES: u64 = 4096;
const RGB: [&str; 3] = ["R", "G", "B"];

fn radiance_layer(level: usize) -> String {
    format!("radiance.{level}")
}

/// The roughness of every level as the header lists it: `"0 0.015625 0.0625 0.25 1"`.
fn roughness_text() -> String {
    (0..REFLECTION_LEVELS).map(|k| reflection_level_roughness(k).to_string()).collect::<Vec<_>>().join(" ")
}

/// The optional layer marking the texels whose first surface is specular.
const SPECULAR_LAYER: &str = "specular";

/// The (layer, size) pairs of a file of `n` probes: every level, then `distance`, then the
/// optional `specular`.
fn layer_sizes(n: usize) -> Vec<(String, (usize, usize))> {
    let mut out: Vec<_> =
        (0..REFLECTION_LEVELS).map(|k| (radiance_layer(k), (reflection_level_texels(k).pow(2), n))).collect();
    out.push(("distance".into(), (REFLECTION_TEXELS * REFLECTION_TEXELS, n)));
    out.push((SPECULAR_LAYER.into(), (REFLECTION_TEXELS * REFLECTION_TEXELS, n)));
    out
}

/// Writes `probes` to `path` atomically; refuses inconsistent sizes and non-finite values
/// (and writes nothing then).
pub fn write_reflections(probes: &ReflectionProbes, path: &Path) -> Result<(), SidecarError> {
    let fail = |kind| SidecarError::new(path, kind);
    let n = probes.probe_count();
    let sizes = layer_sizes(n);
    let inconsistent = n == 0
        || probes.radiance.len() != REFLECTION_LEVELS
        || probes.radiance.iter().zip(&sizes).any(|(level, (_, (w, h)))| level.len() != w * h)
        || probes.distance.len() != n * REFLECTION_TEXELS * REFLECTION_TEXELS
        || !(probes.specular.is_empty() || probes.specular.len() == probes.distance.len());
    if inconsistent {
        return Err(fail(SidecarErrorKind::Inconsistent {
            detail: format!(
                "{n} probes, levels of {:?} texels, {} distances, {} specular marks",
                probes.radiance.iter().map(Vec::len).collect::<Vec<_>>(),
                probes.distance.len(),
                probes.specular.len()
            ),
        }));
    }
    for (k, level) in probes.radiance.iter().enumerate() {
        let w = reflection_level_texels(k).pow(2);
        if let Some(i) = level.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
            let value = level[i].into_iter().find(|c| !c.is_finite()).unwrap_or(f32::NAN);
            return Err(fail(non_finite(radiance_layer(k), i, w, value)));
        }
    }
    if let Some(i) = probes.distance.iter().position(|v| !v.is_finite()) {
        return Err(fail(non_finite("distance.Z".into(), i, REFLECTION_TEXELS.pow(2), probes.distance[i])));
    }
    let attributes = |name: &str| {
        let placement = (probes.origin, probes.spacing, probes.counts);
        let mut a = grid_attributes(name, KIND_REFLECTIONS, probes.depth_fingerprint, &GRID_NAMES, placement);
        let o = &mut a.other;
        o.insert(Text::from(ATTR_TEXELS), AttributeValue::I32(REFLECTION_TEXELS as i32));
        o.insert(Text::from(ATTR_LEVELS), AttributeValue::I32(REFLECTION_LEVELS as i32));
        o.insert(Text::from(ATTR_ROUGHNESS), AttributeValue::Text(Text::from(roughness_text().as_str())));
        a
    };
    let mut layers = Vec::new();
    for (k, level) in probes.radiance.iter().enumerate() {
        let channels = (0..3)
            .map(|c| AnyChannel::new(RGB[c], FlatSamples::F32(level.iter().map(|v| v[c]).collect())))
            .collect();
        layers.push(Layer::new(
            sizes[k].1,
            attributes(&radiance_layer(k)),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels),
        ));
    }
    let distance = AnyChannel::new("Z", FlatSamples::F32(probes.distance.clone()));
    layers.push(Layer::new(
        sizes[REFLECTION_LEVELS].1,
        attributes("distance"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vec![distance])),
    ));
    // Only where some texel is marked: files of scenes without mirrors or glass stay as they
    // were, and readers from before the layer read them.
    if probes.specular.contains(&true) {
        let marks = probes.specular.iter().map(|&s| if s { 1.0 } else { 0.0 }).collect();
        layers.push(Layer::new(
            sizes[REFLECTION_LEVELS + 1].1,
            attributes(SPECULAR_LAYER),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new("S", FlatSamples::F32(marks))])),
        ));
    }
    let width = REFLECTION_TEXELS * REFLECTION_TEXELS;
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((width, n))),
        SmallVec::from_vec(layers),
    );
    crate::exr_file::write_exr_atomically(path, |writer| image.write().to_buffered(writer))
        .map_err(|e| fail(SidecarErrorKind::Io(e)))
}

fn non_finite(channel: String, index: usize, width: usize, value: f32) -> SidecarErrorKind {
    SidecarErrorKind::NonFinite { channel, x: (index % width) as u32, y: (index / width) as u32, value }
}

/// Reads and validates the reflection probes file at `path`; with `depth_fingerprint`, refuses
/// probes of another render. A file that does not exist is `Ok(None)`: renders by an
/// `lrt-depth` from before reflection probes have none (the caller says so, e.g. with
/// [`crate::reflections_absent_note`]). Every error names `path`.
pub fn read_reflections(
    path: &Path,
    depth_fingerprint: Option<u64>,
) -> Result<Option<ReflectionProbes>, SidecarError> {
    match std::fs::metadata(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(SidecarError::new(path, SidecarErrorKind::Io(e))),
        Ok(_) => {}
    }
    read_inner(path, depth_fingerprint).map(Some).map_err(|kind| SidecarError::new(path, kind))
}

fn int_attribute(
    attrs: &HashMap<Text, AttributeValue>,
    name: &str,
    expected: usize,
) -> Result<(), SidecarErrorKind> {
    match attrs.get(&Text::from(name)) {
        Some(AttributeValue::I32(v)) if usize::try_from(*v).ok() == Some(expected) => Ok(()),
        Some(AttributeValue::I32(v)) => Err(SidecarErrorKind::BadAttribute {
            name: name.into(),
            detail: format!("{v}, this reader knows {expected}"),
        }),
        Some(_) => {
            Err(SidecarErrorKind::BadAttribute { name: name.into(), detail: "expected an int".into() })
        }
        None => Err(SidecarErrorKind::MissingAttribute { name: name.into() }),
    }
}

fn read_inner(path: &Path, expected: Option<u64>) -> Result<ReflectionProbes, SidecarErrorKind> {
    let limits = ReadLimits {
        max_pixels: MAX_REFLECTION_PROBES * (REFLECTION_TEXELS * REFLECTION_TEXELS) as u64,
        ..ReadLimits::default()
    };
    let header = read_header(path, KIND_REFLECTIONS, limits)?;
    let attrs = &header.own_attributes.other;
    let fingerprint = fingerprint_attribute(attrs)?;
    if let Some(expected) = expected
        && expected != fingerprint
    {
        return Err(SidecarErrorKind::Stale { expected, found: fingerprint });
    }
    int_attribute(attrs, ATTR_TEXELS, REFLECTION_TEXELS)?;
    int_attribute(attrs, ATTR_LEVELS, REFLECTION_LEVELS)?;
    // The levels must have been prefiltered for the roughness this reader maps to them.
    match attrs.get(&Text::from(ATTR_ROUGHNESS)) {
        Some(AttributeValue::Text(t)) if t.to_string() == roughness_text() => {}
        Some(AttributeValue::Text(t)) => {
            return Err(SidecarErrorKind::BadAttribute {
                name: ATTR_ROUGHNESS.into(),
                detail: format!("`{t}`, this reader's levels are `{}`", roughness_text()),
            });
        }
        Some(_) => {
            return Err(SidecarErrorKind::BadAttribute {
                name: ATTR_ROUGHNESS.into(),
                detail: "expected a string".into(),
            });
        }
        None => return Err(SidecarErrorKind::MissingAttribute { name: ATTR_ROUGHNESS.into() }),
    }
    let ((origin, spacing, counts), n) =
        read_grid(attrs, &GRID_NAMES, "reflection probe count", MAX_REFLECTION_PROBES)?;
    let sizes: HashMap<String, (usize, usize)> = layer_sizes(n).into_iter().collect();
    let image = read_all_layers(path)?;
    let mut channels: HashMap<String, Vec<f32>> = HashMap::new();
    for layer in &image.layer_data {
        let name = layer.attributes.layer_name.as_ref().map(|t| t.to_string()).unwrap_or_default();
        let Some(&expected_size) = sizes.get(&name) else {
            return Err(SidecarErrorKind::UnexpectedChannel { name: format!("{name}.*") });
        };
        if (layer.size.0, layer.size.1) != expected_size {
            return Err(SidecarErrorKind::SizeMismatch {
                expected: (expected_size.0 as u32, expected_size.1 as u32),
                found: (layer.size.0 as u64, layer.size.1 as u64),
            });
        }
        for c in &layer.channel_data.list {
            let full = format!("{name}.{}", c.name);
            let allowed = match name.as_str() {
                "distance" => c.name.eq("Z"),
                SPECULAR_LAYER => c.name.eq("S"),
                _ => RGB.iter().any(|s| c.name.eq(s)),
            };
            if !allowed {
                return Err(SidecarErrorKind::UnexpectedChannel { name: full });
            }
            let values = finite_values(&full, c, layer.size.0)?;
            channels.insert(full, values);
        }
    }
    let mut take = |name: String| take_channel(&mut channels, name);
    let mut radiance = Vec::with_capacity(REFLECTION_LEVELS);
    for k in 0..REFLECTION_LEVELS {
        let mut level = vec![[0.0f32; 3]; reflection_level_texels(k).pow(2) * n];
        for (c, suffix) in RGB.iter().enumerate() {
            for (texel, v) in level.iter_mut().zip(take(format!("{}.{suffix}", radiance_layer(k)))?) {
                texel[c] = v;
            }
        }
        radiance.push(level);
    }
    let distance = take("distance.Z".into())?;
    // Absent (a bake from before the layer, or no mirror or glass in view of any probe): no
    // texel is marked, and a viewer parallax-corrects every direction as before.
    let specular = match channels.remove(&format!("{SPECULAR_LAYER}.S")) {
        Some(marks) => marks.into_iter().map(|m| m > 0.5).collect(),
        None => Vec::new(),
    };
    Ok(ReflectionProbes {
        depth_fingerprint: fingerprint,
        origin,
        spacing,
        counts,
        radiance,
        distance,
        specular,
    })
}

//! The light layers as one single-part OpenEXR file of 32-bit float channels
//! (`light.K.R`, ..., `normal.X`, ...) with the sidecar's metadata as header attributes.

use crate::error::{SidecarError, SidecarErrorKind};
use crate::layers::{
    LayerExpectation, LightLayers, LightSource, OPTIONAL_LAYER_GROUPS, channel_suffixes, light_layer_count,
};
use exr::prelude::*;
use std::collections::HashMap;
use std::path::Path;
use std::result::Result;

/// Header attribute names (all files).
pub(crate) const ATTR_VERSION: &str = "lrt.sidecar.version";
pub(crate) const ATTR_KIND: &str = "lrt.sidecar.kind";
pub(crate) const ATTR_FINGERPRINT: &str = "lrt.depth.fingerprint";
/// Header attribute names (layers files).
const ATTR_LIGHTS: &str = "lrt.lights";
const ATTR_LIGHT_LAYERS: &str = "lrt.light.layers";
const KIND_LAYERS: &str = "layers";

/// Bounds on what a reader accepts before it decodes any pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadLimits {
    /// Largest `width * height` accepted.
    pub max_pixels: u64,
    /// Most lights listed in the header.
    pub max_lights: u64,
}

impl Default for ReadLimits {
    /// 2^28 pixels (16384 x 16384), as for depth tables, and 2^20 lights.
    fn default() -> Self {
        ReadLimits { max_pixels: 1 << 28, max_lights: 1 << 20 }
    }
}

/// The channel names of a layers file with `light_layers` light layers, in the order the format
/// lists them: `light.0.R`, `light.0.G`, `light.0.B`, ..., `emission.*`, `indirect.*`,
/// `normal.X`, `normal.Y`, `normal.Z`, `albedo.R`, `albedo.G`, `albedo.B`.
pub fn channel_names(light_layers: usize) -> Vec<String> {
    let mut layers: Vec<String> = (0..light_layers).map(|k| format!("light.{k}")).collect();
    layers.extend(["emission", "indirect", "normal", "albedo"].map(String::from));
    layers.iter().flat_map(|layer| channel_suffixes(layer).map(|c| format!("{layer}.{c}"))).collect()
}

/// Writes `layers` to `path` atomically (temporary file in the same directory + rename).
/// Refuses (and writes nothing) if a buffer has the wrong length or holds NaN or infinity.
pub fn write_layers(layers: &LightLayers, path: &Path) -> Result<(), SidecarError> {
    let fail = |kind| SidecarError::new(path, kind);
    let n = layers.pixel_count();
    if layers.light.len() != light_layer_count(layers.lights.len()) {
        return Err(fail(SidecarErrorKind::Inconsistent {
            detail: format!("{} light layers for {} lights", layers.light.len(), layers.lights.len()),
        }));
    }
    let mut channels = Vec::new();
    for (name, buffer) in layers.named_buffers() {
        if buffer.len() != n {
            return Err(fail(SidecarErrorKind::Inconsistent {
                detail: format!("layer `{name}` has {} pixels, the frame {n}", buffer.len()),
            }));
        }
        for (c, suffix) in channel_suffixes(&name).iter().enumerate() {
            let channel = format!("{name}.{suffix}");
            let values: Vec<f32> = buffer.iter().map(|p| p[c]).collect();
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                let w = layers.width.max(1) as usize;
                return Err(fail(SidecarErrorKind::NonFinite {
                    channel,
                    x: (i % w) as u32,
                    y: (i / w) as u32,
                    value: values[i],
                }));
            }
            channels.push(AnyChannel::new(channel.as_str(), FlatSamples::F32(values)));
        }
    }
    let mut attributes = LayerAttributes::default();
    let other = &mut attributes.other;
    other.insert(Text::from(ATTR_VERSION), AttributeValue::I32(crate::FORMAT_VERSION));
    other.insert(Text::from(ATTR_KIND), AttributeValue::Text(Text::from(KIND_LAYERS)));
    other.insert(
        Text::from(ATTR_FINGERPRINT),
        AttributeValue::Text(Text::from(format!("{:016x}", layers.depth_fingerprint).as_str())),
    );
    let light_layers = i32::try_from(layers.light.len()).unwrap_or(i32::MAX);
    other.insert(Text::from(ATTR_LIGHT_LAYERS), AttributeValue::I32(light_layers));
    let lights: Vec<Text> =
        layers.lights.iter().map(|l| ascii_text(&format!("{} {}", l.index, l.description))).collect();
    // EXR forbids an empty text vector: a scene without lights has no `lrt.lights`.
    if !layers.lights.is_empty() {
        other.insert(Text::from(ATTR_LIGHTS), AttributeValue::TextVector(lights));
    }
    let size = (layers.width as usize, layers.height as usize);
    let layer = Layer::new(
        size,
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let image = Image::from_layer(layer);
    crate::exr_file::write_exr_atomically(path, |writer| image.write().to_buffered(writer))
        .map_err(|e| fail(SidecarErrorKind::Io(e)))
}

/// Reads and validates the layers file at `path` for an image of `expect`'s size (and depth
/// fingerprint, when given). Every error names `path`.
pub fn read_layers(
    path: &Path,
    expect: &LayerExpectation,
    limits: ReadLimits,
) -> Result<LightLayers, SidecarError> {
    read_layers_inner(path, expect, limits).map_err(|kind| SidecarError::new(path, kind))
}

fn read_layers_inner(
    path: &Path,
    expect: &LayerExpectation,
    limits: ReadLimits,
) -> Result<LightLayers, SidecarErrorKind> {
    let header = read_header(path, KIND_LAYERS, limits)?;
    check_frame(&header, expect)?;
    let attrs = &header.own_attributes.other;
    let fingerprint = fingerprint_attribute(attrs)?;
    if let Some(expected) = expect.depth_fingerprint
        && expected != fingerprint
    {
        return Err(SidecarErrorKind::Stale { expected, found: fingerprint });
    }
    let lights = match attrs.get(&Text::from(ATTR_LIGHTS)) {
        Some(AttributeValue::TextVector(v)) => {
            if v.len() as u64 > limits.max_lights {
                return Err(SidecarErrorKind::TooLarge {
                    what: "light count",
                    size: v.len() as u64,
                    limit: limits.max_lights,
                });
            }
            v.iter().map(|t| parse_light(&t.to_string())).collect::<Result<Vec<_>, _>>()?
        }
        Some(_) => return Err(bad_type(ATTR_LIGHTS, "a text vector")),
        // Written only when the scene has lights.
        None => Vec::new(),
    };
    let light_layers = match attrs.get(&Text::from(ATTR_LIGHT_LAYERS)) {
        Some(AttributeValue::I32(v)) => *v,
        Some(_) => return Err(bad_type(ATTR_LIGHT_LAYERS, "an int")),
        None => return Err(SidecarErrorKind::MissingAttribute { name: ATTR_LIGHT_LAYERS.into() }),
    };
    if usize::try_from(light_layers).ok() != Some(light_layer_count(lights.len())) {
        return Err(SidecarErrorKind::BadAttribute {
            name: ATTR_LIGHT_LAYERS.into(),
            detail: format!(
                "{light_layers} light layers for {} lights (expected {})",
                lights.len(),
                light_layer_count(lights.len())
            ),
        });
    }

    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(exr_error)?;
    let mut channels: HashMap<String, Vec<f32>> = HashMap::new();
    for channel in image.layer_data.channel_data.list {
        let values = match channel.sample_data {
            FlatSamples::F32(v) => v,
            FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
            FlatSamples::U32(_) => {
                return Err(SidecarErrorKind::BadAttribute {
                    name: channel.name.to_string(),
                    detail: "channel holds integers, expected float".into(),
                });
            }
        };
        channels.insert(channel.name.to_string(), values);
    }
    let found = || {
        let mut names: Vec<String> = channels.keys().cloned().collect();
        names.sort();
        names
    };
    let mut layers = LightLayers::new(expect.width, expect.height, fingerprint, lights);
    let width = expect.width.max(1) as usize;
    let expected_names = channel_names(layers.light.len());
    let group_names = |group: &&[&str]| -> Vec<String> {
        group.iter().flat_map(|layer| channel_suffixes(layer).map(|c| format!("{layer}.{c}"))).collect()
    };
    let optional_names: Vec<String> = OPTIONAL_LAYER_GROUPS.iter().flat_map(group_names).collect();
    if let Some(extra) =
        channels.keys().find(|name| !expected_names.contains(name) && !optional_names.contains(name))
    {
        return Err(SidecarErrorKind::UnexpectedChannel { name: extra.clone() });
    }
    // The optional groups (the reflection, glossy and transmission layers: older files, frames without such
    // surfaces) are read with all of their channels or not at all.
    let absent_groups: Vec<&&[&str]> = OPTIONAL_LAYER_GROUPS
        .iter()
        .filter(|group| !group_names(group).iter().any(|name| channels.contains_key(name)))
        .collect();
    for (name, buffer) in layers.named_buffers_mut() {
        if absent_groups.iter().any(|group| group.contains(&name.as_str())) {
            continue;
        }
        for (c, suffix) in channel_suffixes(&name).iter().enumerate() {
            let channel = format!("{name}.{suffix}");
            let Some(values) = channels.get(&channel) else {
                return Err(SidecarErrorKind::MissingChannel { name: channel, found: found() });
            };
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(SidecarErrorKind::NonFinite {
                    channel,
                    x: (i % width) as u32,
                    y: (i / width) as u32,
                    value: values[i],
                });
            }
            for (pixel, v) in buffer.iter_mut().zip(values) {
                pixel[c] = *v;
            }
        }
    }
    Ok(layers)
}

/// Reads the first header of the sidecar at `path`, checks its version and kind and that its
/// size is within `limits`, without decoding pixels.
pub(crate) fn read_header(
    path: &Path,
    kind: &'static str,
    limits: ReadLimits,
) -> Result<exr::meta::header::Header, SidecarErrorKind> {
    let meta = MetaData::read_from_file(path, false).map_err(exr_error)?;
    let Some(header) = meta.headers.into_iter().next() else {
        return Err(SidecarErrorKind::Exr { message: "no header".into() });
    };
    let attrs = &header.own_attributes.other;
    match attrs.get(&Text::from(ATTR_VERSION)) {
        Some(AttributeValue::I32(v)) if *v == crate::FORMAT_VERSION => {}
        Some(AttributeValue::I32(v)) => return Err(SidecarErrorKind::UnsupportedVersion { found: *v }),
        Some(_) => return Err(bad_type(ATTR_VERSION, "an int")),
        None => return Err(SidecarErrorKind::MissingAttribute { name: ATTR_VERSION.into() }),
    }
    match attrs.get(&Text::from(ATTR_KIND)) {
        Some(AttributeValue::Text(t)) if t.eq(kind) => {}
        Some(AttributeValue::Text(t)) => {
            return Err(SidecarErrorKind::WrongKind { expected: kind, found: t.to_string() });
        }
        Some(_) => return Err(bad_type(ATTR_KIND, "a string")),
        None => return Err(SidecarErrorKind::MissingAttribute { name: ATTR_KIND.into() }),
    }
    let pixels = header.layer_size.0 as u64 * header.layer_size.1 as u64;
    if pixels > limits.max_pixels {
        return Err(SidecarErrorKind::TooLarge {
            what: "width x height",
            size: pixels,
            limit: limits.max_pixels,
        });
    }
    Ok(header)
}

fn check_frame(
    header: &exr::meta::header::Header,
    expect: &LayerExpectation,
) -> Result<(), SidecarErrorKind> {
    let display = header.shared_attributes.display_window;
    let (w, h) = (header.layer_size.0 as u64, header.layer_size.1 as u64);
    let display_size = (display.size.0 as u64, display.size.1 as u64);
    if display_size != (u64::from(expect.width), u64::from(expect.height)) {
        return Err(SidecarErrorKind::SizeMismatch {
            expected: (expect.width, expect.height),
            found: display_size,
        });
    }
    if (w, h) != display_size || header.own_attributes.layer_position != display.position {
        return Err(SidecarErrorKind::Crop);
    }
    Ok(())
}

pub(crate) fn fingerprint_attribute(attrs: &HashMap<Text, AttributeValue>) -> Result<u64, SidecarErrorKind> {
    match attrs.get(&Text::from(ATTR_FINGERPRINT)) {
        Some(AttributeValue::Text(t)) => {
            u64::from_str_radix(&t.to_string(), 16).map_err(|_| SidecarErrorKind::BadAttribute {
                name: ATTR_FINGERPRINT.into(),
                detail: format!("`{t}` is not 16 hexadecimal digits"),
            })
        }
        Some(_) => Err(bad_type(ATTR_FINGERPRINT, "a string")),
        None => Err(SidecarErrorKind::MissingAttribute { name: ATTR_FINGERPRINT.into() }),
    }
}

fn parse_light(text: &str) -> Result<LightSource, SidecarErrorKind> {
    let (index, description) = text.split_once(' ').unwrap_or((text, ""));
    let index = index.parse::<u32>().map_err(|_| SidecarErrorKind::BadAttribute {
        name: ATTR_LIGHTS.into(),
        detail: format!("entry `{text}` does not start with a light index"),
    })?;
    Ok(LightSource::new(index, description))
}

fn bad_type(name: &str, expected: &str) -> SidecarErrorKind {
    SidecarErrorKind::BadAttribute { name: name.into(), detail: format!("expected {expected}") }
}

/// `text` as an EXR `Text`: printable ASCII kept, everything else replaced by `?`.
pub(crate) fn ascii_text(text: &str) -> Text {
    let ascii: String =
        text.chars().map(|c| if c.is_ascii() && !c.is_ascii_control() { c } else { '?' }).collect();
    Text::new_or_none(&ascii).unwrap_or_default()
}

/// Every layer and channel of the EXR file at `path`, at its largest resolution, as the probe,
/// reflection and caustics readers take them (each then checks the names and sizes it expects).
pub(crate) fn read_all_layers(
    path: &Path,
) -> Result<Image<Layers<AnyChannels<FlatSamples>>>, SidecarErrorKind> {
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(exr_error)
}

pub(crate) fn exr_error(e: exr::error::Error) -> SidecarErrorKind {
    match e {
        exr::error::Error::Io(io) => SidecarErrorKind::Io(io),
        other => SidecarErrorKind::Exr { message: other.to_string() },
    }
}

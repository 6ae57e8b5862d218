//! The OpenEXR form of a depth table: one layer with a single float channel `Z` holding the
//! radial distance, `+inf` for a miss (CONTRACTS.md §2), compressed losslessly (ZIP).

use crate::table::{
    DepthTable, DepthTableError, DepthTableErrorKind, ReadLimits, is_depth, write_atomically,
};
use exr::prelude::*;
use std::io;
use std::path::Path;

fn exr_error(e: exr::error::Error) -> DepthTableError {
    match e {
        exr::error::Error::Io(io) => DepthTableError::new(DepthTableErrorKind::Io(io)),
        other => DepthTableError::new(DepthTableErrorKind::Exr { message: other.to_string() }),
    }
}

/// Writes `table` as a single-channel (`Z`, 32-bit float) OpenEXR file, atomically.
pub(crate) fn write_exr(table: &DepthTable, path: &Path) -> std::result::Result<(), DepthTableError> {
    let size = (table.width() as usize, table.height() as usize);
    let channel = AnyChannel::new("Z", FlatSamples::F32(table.values().to_vec()));
    let layer = Layer::new(
        size,
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vec![channel])),
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |writer| {
        image.write().to_buffered(writer).map_err(|e| match e {
            exr::error::Error::Io(io) => io,
            other => io::Error::other(other.to_string()),
        })
    })
    .map_err(|e| DepthTableError::from(e).with_path(path))
}

/// Reads the `Z` channel of the first layer of an OpenEXR file as a depth table.
pub(crate) fn read_exr(path: &Path, limits: ReadLimits) -> std::result::Result<DepthTable, DepthTableError> {
    read_exr_unchecked_path(path, limits).map_err(|e| e.with_path(path))
}

fn read_exr_unchecked_path(
    path: &Path,
    limits: ReadLimits,
) -> std::result::Result<DepthTable, DepthTableError> {
    // Check the size in the header before decoding any pixels.
    let meta = MetaData::read_from_file(path, false).map_err(exr_error)?;
    for header in meta.headers.iter() {
        let pixels = header.layer_size.0 as u64 * header.layer_size.1 as u64;
        if pixels > limits.max_pixels {
            return Err(DepthTableError::new(DepthTableErrorKind::TooLarge {
                what: "width x height",
                size: pixels,
                limit: limits.max_pixels,
            }));
        }
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(exr_error)?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let Some(channel) = layer.channel_data.list.iter().find(|c| c.name.eq("Z")) else {
        let channels = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
        return Err(DepthTableError::new(DepthTableErrorKind::MissingZChannel { channels }));
    };
    let values: Vec<f32> = match &channel.sample_data {
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
    };
    if let Some(index) = values.iter().position(|v| !is_depth(*v)) {
        let (x, y) = (index % width.max(1), index / width.max(1));
        return Err(DepthTableError::new(DepthTableErrorKind::InvalidExrValue {
            x: x as u32,
            y: y as u32,
            value: values[index],
        }));
    }
    let (width, height) = (
        u32::try_from(width).map_err(|_| too_large("width", width))?,
        u32::try_from(height).map_err(|_| too_large("height", height))?,
    );
    DepthTable::new(width, height, values)
}

fn too_large(what: &'static str, size: usize) -> DepthTableError {
    DepthTableError::new(DepthTableErrorKind::TooLarge {
        what,
        size: size as u64,
        limit: u64::from(u32::MAX),
    })
}

//! The layers file round-trips exactly, and every kind of bad file is refused with an error
//! naming it.

use exr::prelude::*;
use sidecar::{
    LayerExpectation, LightLayers, LightSource, SidecarErrorKind, SidecarPaths, channel_names,
    depth_fingerprint, read_layers, write_layers,
};
use std::path::Path;

fn sample_layers(lights: usize) -> LightLayers {
    let sources =
        (0..lights).map(|k| LightSource::new(k as u32, format!("pointlight at s.rib:{k}:1 é"))).collect();
    let mut layers = LightLayers::new(3, 2, 0xdead_beef_0123_4567, sources);
    for (k, layer) in layers.light.iter_mut().enumerate() {
        for (i, p) in layer.iter_mut().enumerate() {
            *p = [k as f32 + 0.5, i as f32 * 0.25, -0.125];
        }
    }
    layers.indirect[4] = [1e-30, 3.0e5, 0.1];
    layers.emission[0] = [7.0, 7.0, 7.0];
    layers.normal[1] = [0.0, -1.0, 0.0];
    layers.albedo[2] = [0.8, 0.5, 0.25];
    layers
}

fn expectation(layers: &LightLayers) -> LayerExpectation {
    LayerExpectation {
        width: layers.width,
        height: layers.height,
        depth_fingerprint: Some(layers.depth_fingerprint),
    }
}

/// Writes an arbitrary EXR with the given channels and header attributes.
fn write_raw(path: &Path, size: (usize, usize), channels: &[(&str, f32)], attrs: &[(&str, AttributeValue)]) {
    let list = channels
        .iter()
        .map(|(name, v)| AnyChannel::new(*name, FlatSamples::F32(vec![*v; size.0 * size.1])))
        .collect();
    let mut attributes = LayerAttributes::default();
    for (k, v) in attrs {
        attributes.other.insert(Text::from(*k), v.clone());
    }
    let layer = Layer::new(size, attributes, Encoding::UNCOMPRESSED, AnyChannels::sort(list));
    Image::from_layer(layer).write().to_file(path).unwrap();
}

fn good_attrs(lights: usize) -> Vec<(&'static str, AttributeValue)> {
    vec![
        ("lrt.sidecar.version", AttributeValue::I32(1)),
        ("lrt.sidecar.kind", AttributeValue::Text(Text::from("layers"))),
        ("lrt.depth.fingerprint", AttributeValue::Text(Text::from("00000000000000ff"))),
        ("lrt.light.layers", AttributeValue::I32(lights as i32)),
        (
            "lrt.lights",
            AttributeValue::TextVector(
                (0..lights).map(|k| Text::from(format!("{k} light").as_str())).collect(),
            ),
        ),
    ]
}

#[test]
fn round_trip_is_exact_and_beauty_is_the_sum() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = SidecarPaths::for_depth(&dir.path().join("out.depth")).layers;
    for lights in [0, 2, 20] {
        let layers = sample_layers(lights);
        write_layers(&layers, &path).unwrap();
        let back = read_layers(&path, &expectation(&layers), Default::default()).unwrap();
        let mut expected = layers.clone();
        for l in &mut expected.lights {
            l.description = l.description.replace('é', "?");
        }
        assert_eq!(back, expected);
        assert_eq!(back.light.len(), lights.min(16));
        let beauty = back.beauty();
        let p = 4;
        let direct: f32 = (0..back.light.len()).map(|k| back.light[k][p][1]).sum();
        assert_eq!(beauty[p][1], direct + 3.0e5);
    }
    // Nothing but the file itself is left in the directory (atomic write cleans up).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // Without a fingerprint to check, any render of the right size is accepted.
    let layers = sample_layers(1);
    write_layers(&layers, &path).unwrap();
    let loose = LayerExpectation { depth_fingerprint: None, ..expectation(&layers) };
    assert!(read_layers(&path, &loose, Default::default()).is_ok());
}

#[test]
fn the_same_layers_give_the_same_bytes_every_time() {
    // exr keeps custom attributes in a randomly hashed map; each write must still put them in
    // one order (by name, as OpenEXR does), so outputs are reproducible run after run.
    let dir = tempfile::TempDir::new().unwrap();
    let layers = sample_layers(3);
    let first = dir.path().join("first.exr");
    write_layers(&layers, &first).unwrap();
    let expected = std::fs::read(&first).unwrap();
    for attempt in 0..8 {
        let path = dir.path().join(format!("again{attempt}.exr"));
        write_layers(&layers, &path).unwrap();
        assert!(std::fs::read(&path).unwrap() == expected, "write {attempt} differs from the first");
    }
}

#[test]
fn bad_files_get_errors_naming_the_file() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("bad.layers.exr");
    let layers = sample_layers(2);
    write_layers(&layers, &path).unwrap();
    let read = |expect: &LayerExpectation| {
        let e = read_layers(&path, expect, Default::default()).unwrap_err();
        assert!(e.to_string().starts_with(&format!("{}: error: ", path.display())), "{e}");
        e.kind
    };

    let wrong_size = LayerExpectation { width: 4, ..expectation(&layers) };
    assert!(matches!(read(&wrong_size), SidecarErrorKind::SizeMismatch { expected: (4, 2), found: (3, 2) }));
    let other_render =
        LayerExpectation { depth_fingerprint: Some(depth_fingerprint(&[1.0])), ..expectation(&layers) };
    assert!(matches!(read(&other_render), SidecarErrorKind::Stale { .. }));

    let expect = LayerExpectation { width: 3, height: 2, depth_fingerprint: Some(0xff) };
    let names = channel_names(2);
    let all: Vec<(&str, f32)> = names.iter().map(|n| (n.as_str(), 0.5)).collect();

    // A NaN in one channel.
    let mut with_nan = all.clone();
    with_nan[4].1 = f32::NAN;
    write_raw(&path, (3, 2), &with_nan, &good_attrs(2));
    match read(&expect) {
        SidecarErrorKind::NonFinite { channel, x: 0, y: 0, value } => {
            assert_eq!(channel, "light.1.G");
            assert!(value.is_nan());
        }
        other => panic!("{other:?}"),
    }
    // An infinity.
    let mut with_inf = all.clone();
    with_inf[names.len() - 1].1 = f32::INFINITY;
    write_raw(&path, (3, 2), &with_inf, &good_attrs(2));
    assert!(matches!(read(&expect), SidecarErrorKind::NonFinite { .. }));
    // A missing layer.
    write_raw(&path, (3, 2), &all[3..], &good_attrs(2));
    assert!(matches!(read(&expect), SidecarErrorKind::MissingChannel { name, .. } if name == "light.0.R"));
    // A layer the format does not have (the header claims 1 light, the file holds 2).
    write_raw(&path, (3, 2), &all, &good_attrs(1));
    assert!(
        matches!(read(&expect), SidecarErrorKind::UnexpectedChannel { name } if name.starts_with("light.1"))
    );
    // Light count and layer count disagree.
    let mut attrs = good_attrs(2);
    attrs[3].1 = AttributeValue::I32(5);
    write_raw(&path, (3, 2), &all, &attrs);
    assert!(matches!(read(&expect), SidecarErrorKind::BadAttribute { .. }));
    // Any other EXR (e.g. the beauty image itself).
    write_raw(&path, (3, 2), &[("R", 1.0), ("G", 1.0), ("B", 1.0)], &[]);
    assert!(
        matches!(read(&expect), SidecarErrorKind::MissingAttribute { name } if name == "lrt.sidecar.version")
    );
    // A probes file where layers were expected.
    let mut attrs = good_attrs(2);
    attrs[1].1 = AttributeValue::Text(Text::from("probes"));
    write_raw(&path, (3, 2), &all, &attrs);
    assert!(matches!(read(&expect), SidecarErrorKind::WrongKind { .. }));
    // A future version.
    let mut attrs = good_attrs(2);
    attrs[0].1 = AttributeValue::I32(2);
    write_raw(&path, (3, 2), &all, &attrs);
    assert!(matches!(read(&expect), SidecarErrorKind::UnsupportedVersion { found: 2 }));
    // Not an EXR at all, and no file at all.
    std::fs::write(&path, b"# lrt-depth v1 width=3 height=2\n").unwrap();
    assert!(matches!(read(&expect), SidecarErrorKind::Exr { .. } | SidecarErrorKind::Io(_)));
    std::fs::remove_file(&path).unwrap();
    assert!(matches!(read(&expect), SidecarErrorKind::Io(_)));
}

#[test]
fn writer_refuses_non_finite_values_and_keeps_the_old_file() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("out.layers.exr");
    let good = sample_layers(1);
    write_layers(&good, &path).unwrap();
    let mut bad = good.clone();
    bad.albedo[5] = [0.0, f32::NAN, 0.0];
    let e = write_layers(&bad, &path).unwrap_err();
    assert!(matches!(e.kind, SidecarErrorKind::NonFinite { x: 2, y: 1, .. }), "{e}");
    assert_eq!(read_layers(&path, &expectation(&good), Default::default()).unwrap().albedo, good.albedo);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn reflection_layers_are_written_when_a_pixel_reflects_and_read_all_or_none() {
    let (_dir, path, plain) = optional_layers_fixture();
    // Without a specular reflection the file is what it was before the optional layers.
    write_layers(&plain, &path).unwrap();
    assert_eq!(channel_count(&path), channel_names(2).len());
    assert_eq!(read_layers(&path, &expectation(&plain), Default::default()).unwrap(), plain);
    // With one, both layers are written and read back exactly.
    let mut mirror = plain.clone();
    mirror.reflectance[3] = [0.95, 0.9, 0.85];
    mirror.reflected[3] = [1.5, 0.25, 0.125];
    write_layers(&mirror, &path).unwrap();
    assert_eq!(channel_count(&path), channel_names(2).len() + 6);
    assert_eq!(read_layers(&path, &expectation(&mirror), Default::default()).unwrap(), mirror);
    // Half of them is refused, naming a missing channel.
    assert_half_a_group_is_refused(&path, "reflectance", "reflected.");
}

#[test]
fn glossy_layers_are_written_when_a_pixel_has_a_lobe_and_read_all_or_none() {
    let (_dir, path, plain) = optional_layers_fixture();
    assert!(!plain.has_glossy());
    // A glossy pixel adds both glossy layers; a file with a mirror as well holds both groups.
    let mut glossy = plain.clone();
    glossy.glossy[2] = [0.9, 0.75, 0.3];
    glossy.glossy_exponent[2] = [20.0; 3];
    write_layers(&glossy, &path).unwrap();
    assert_eq!(channel_count(&path), channel_names(2).len() + 6);
    assert_eq!(read_layers(&path, &expectation(&glossy), Default::default()).unwrap(), glossy);
    let mut both = glossy.clone();
    both.reflectance[3] = [0.95, 0.9, 0.85];
    both.reflected[3] = [1.5, 0.25, 0.125];
    write_layers(&both, &path).unwrap();
    assert_eq!(channel_count(&path), channel_names(2).len() + 12);
    assert_eq!(read_layers(&path, &expectation(&both), Default::default()).unwrap(), both);
    // `glossy` without its exponent is refused, naming the missing channel.
    assert_half_a_group_is_refused(&path, "glossy", "glossy_exponent.");
}

#[test]
fn transmission_layers_are_written_when_a_pixel_transmits_and_read_all_or_none() {
    let (_dir, path, plain) = optional_layers_fixture();
    assert!(!plain.has_transmission());
    // A glass pixel adds the five transmission layers (the vectors with X, Y, Z channels).
    let mut glass = plain.clone();
    glass.transmittance[4] = [0.9, 0.9, 0.9];
    glass.transmitted[4] = [0.25, 0.5, 0.125];
    glass.transmission_origin[4] = [0.4, -0.6, 0.75];
    glass.transmission_direction[4] = [0.0, -0.6, -0.8];
    glass.transmission_distance[4] = [1.25; 3];
    write_layers(&glass, &path).unwrap();
    assert_eq!(channel_count(&path), channel_names(2).len() + 15);
    let channels: Vec<String> = read_all_data_from_file(&path).unwrap().layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert!(channels.contains(&"transmission_origin.X".to_string()), "{channels:?}");
    assert!(channels.contains(&"transmission_direction.Z".to_string()), "{channels:?}");
    assert_eq!(read_layers(&path, &expectation(&glass), Default::default()).unwrap(), glass);
    // With a mirror as well, both groups are written and read back exactly.
    let mut both = glass.clone();
    both.reflectance[3] = [0.95, 0.9, 0.85];
    both.reflected[3] = [1.5, 0.25, 0.125];
    write_layers(&both, &path).unwrap();
    assert_eq!(channel_count(&path), channel_names(2).len() + 21);
    assert_eq!(read_layers(&path, &expectation(&both), Default::default()).unwrap(), both);
    // Part of the group is refused, naming a missing channel.
    assert_half_a_group_is_refused(&path, "transmittance", "transmitted.");
}

/// A directory for a layers file, the file's path and layers of two lights without optional
/// layers (their descriptions in ASCII, which the file keeps exactly).
fn optional_layers_fixture() -> (tempfile::TempDir, std::path::PathBuf, LightLayers) {
    let dir = tempfile::TempDir::new().unwrap();
    let path = SidecarPaths::for_depth(&dir.path().join("out.depth")).layers;
    let mut plain = sample_layers(2);
    for l in &mut plain.lights {
        l.description = l.description.replace('é', "?");
    }
    (dir, path, plain)
}

/// The number of channels in the layers file at `path`.
fn channel_count(path: &Path) -> usize {
    read_all_data_from_file(path).unwrap().layer_data[0].channel_data.list.len()
}

/// A file with the layers of two lights and only `present` of an optional group of two
/// layers is refused, naming a channel of the other (`missing` is its name's start).
fn assert_half_a_group_is_refused(path: &Path, present: &str, missing: &str) {
    let mut channels: Vec<(String, f32)> = channel_names(2).into_iter().map(|c| (c, 0.0)).collect();
    channels.extend(["R", "G", "B"].map(|c| (format!("{present}.{c}"), 0.5)));
    let refs: Vec<(&str, f32)> = channels.iter().map(|(c, v)| (c.as_str(), *v)).collect();
    write_raw(path, (3, 2), &refs, &good_attrs(2));
    let expect = LayerExpectation { width: 3, height: 2, depth_fingerprint: None };
    let err = read_layers(path, &expect, Default::default()).unwrap_err();
    assert!(
        matches!(&err.kind, SidecarErrorKind::MissingChannel { name, .. } if name.starts_with(missing)),
        "{err}"
    );
}

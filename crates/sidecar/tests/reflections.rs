//! The reflection probes file round-trips exactly, an absent one is reported as absent, and every
//! kind of bad file is refused naming the file.

use exr::prelude::*;
use sidecar::{
    REFLECTION_LEVELS, REFLECTION_TEXELS, ReflectionProbes, SidecarErrorKind, SidecarPaths, read_probes,
    read_reflections, reflection_level_texels, write_reflections,
};
use std::path::Path;

fn probes() -> ReflectionProbes {
    let n = 2;
    ReflectionProbes {
        depth_fingerprint: 0xabcd,
        origin: [-1.5, 0.25, 1e-3],
        spacing: [0.5, 0.75, 1.0],
        counts: [2, 1, 1],
        radiance: (0..REFLECTION_LEVELS)
            .map(|k| {
                (0..n * reflection_level_texels(k).pow(2))
                    .map(|t| [t as f32 * 0.5, k as f32, -(t as f32) * 1e-3])
                    .collect()
            })
            .collect(),
        distance: (0..n * REFLECTION_TEXELS * REFLECTION_TEXELS).map(|t| 0.5 + t as f32 * 1e-2).collect(),
        specular: Vec::new(),
    }
}

/// Rewrites the file at `path` with each part passed through `edit` (layer name, attributes,
/// channels): for the refusals a writer of this crate would never produce.
fn rewrite(
    path: &Path,
    edit: impl Fn(&str, &mut LayerAttributes, &mut Vec<AnyChannel<FlatSamples>>) -> Option<(usize, usize)>,
) {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .unwrap();
    let mut layers = Vec::new();
    for layer in image.layer_data {
        let name = layer.attributes.layer_name.as_ref().map(|t| t.to_string()).unwrap_or_default();
        let mut attributes = layer.attributes.clone();
        let mut channels: Vec<_> = layer.channel_data.list.into_iter().collect();
        let size = edit(&name, &mut attributes, &mut channels).unwrap_or((layer.size.0, layer.size.1));
        layers.push(Layer::new(
            size,
            attributes,
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(SmallVec::from_vec(channels)),
        ));
    }
    Image::from_layers(image.attributes, SmallVec::from_vec(layers)).write().to_file(path).unwrap();
}

fn set_attribute(path: &Path, name: &'static str, value: AttributeValue) {
    rewrite(path, |_, a, _| {
        a.other.insert(Text::from(name), value.clone());
        None
    });
}

fn refusal(path: &Path) -> SidecarErrorKind {
    let e = read_reflections(path, None).unwrap_err();
    let text = e.to_string();
    assert!(text.starts_with(&format!("{}: error: ", path.display())), "{text}");
    e.kind
}

#[test]
fn reflections_round_trip_and_an_old_render_has_none() {
    let dir = tempfile::TempDir::new().unwrap();
    let paths = SidecarPaths::for_depth(&dir.path().join("out.depth"));
    // A render from before reflection probes: no file, no error.
    assert_eq!(read_reflections(&paths.reflections, Some(1)).unwrap(), None);
    assert!(sidecar::reflections_absent_note(&paths.reflections).contains("no reflection probes"));
    let p = probes();
    write_reflections(&p, &paths.reflections).unwrap();
    assert_eq!(read_reflections(&paths.reflections, Some(0xabcd)).unwrap(), Some(p.clone()));
    assert_eq!(read_reflections(&paths.reflections, None).unwrap(), Some(p.clone()));
    let e = read_reflections(&paths.reflections, Some(7)).unwrap_err();
    assert!(matches!(e.kind, SidecarErrorKind::Stale { .. }));
    // A reflections file is not a probes file, nor the other way round.
    assert!(matches!(
        read_probes(&paths.reflections, None).unwrap_err().kind,
        SidecarErrorKind::WrongKind { .. }
    ));
    let other = dir.path().join("other.exr");
    sidecar::write_layers(&sidecar::LightLayers::new(2, 2, 0, vec![]), &other).unwrap();
    assert!(matches!(refusal(&other), SidecarErrorKind::WrongKind { expected: "reflections", .. }));
    // The writer refuses NaN, infinity and wrong sizes and keeps the old file.
    let mut bad = p.clone();
    bad.radiance[2][5][1] = f32::NAN;
    let e = write_reflections(&bad, &paths.reflections).unwrap_err();
    assert!(
        matches!(&e.kind, SidecarErrorKind::NonFinite { channel, x: 5, y: 0, .. } if channel == "radiance.2"),
        "{e}"
    );
    let mut bad = p.clone();
    bad.distance[3] = f32::INFINITY;
    assert!(write_reflections(&bad, &paths.reflections).is_err());
    let mut bad = p.clone();
    bad.radiance[4].pop();
    assert!(matches!(
        write_reflections(&bad, &paths.reflections).unwrap_err().kind,
        SidecarErrorKind::Inconsistent { .. }
    ));
    let mut bad = p.clone();
    bad.radiance.pop();
    assert!(write_reflections(&bad, &paths.reflections).is_err());
    assert_eq!(read_reflections(&paths.reflections, None).unwrap(), Some(p));
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

#[test]
fn bad_reflection_files_are_refused() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("out.reflections.exr");
    let fresh = || write_reflections(&probes(), &path).unwrap();

    fresh();
    set_attribute(&path, "lrt.sidecar.version", AttributeValue::I32(2));
    assert!(matches!(refusal(&path), SidecarErrorKind::UnsupportedVersion { found: 2 }));

    fresh();
    set_attribute(&path, "lrt.reflections.texels", AttributeValue::I32(64));
    assert!(matches!(refusal(&path), SidecarErrorKind::BadAttribute { .. }));

    fresh();
    set_attribute(&path, "lrt.reflections.levels", AttributeValue::I32(6));
    assert!(matches!(refusal(&path), SidecarErrorKind::BadAttribute { .. }));

    // Levels prefiltered for other roughness than this reader maps to them.
    fresh();
    set_attribute(&path, "lrt.reflections.roughness", AttributeValue::Text(Text::from("0 0.1 0.2 0.3 0.4")));
    assert!(matches!(refusal(&path), SidecarErrorKind::BadAttribute { .. }));

    fresh();
    set_attribute(&path, "lrt.reflections.counts", AttributeValue::Text(Text::from("100 100 100")));
    assert!(matches!(refusal(&path), SidecarErrorKind::TooLarge { .. }));

    fresh();
    set_attribute(&path, "lrt.reflections.spacing", AttributeValue::Text(Text::from("1 0 1")));
    assert!(matches!(refusal(&path), SidecarErrorKind::BadAttribute { .. }));

    fresh();
    set_attribute(&path, "lrt.reflections.origin", AttributeValue::Text(Text::from("1 2")));
    assert!(matches!(refusal(&path), SidecarErrorKind::BadAttribute { .. }));

    // One probe fewer in the header than in the layers.
    fresh();
    set_attribute(&path, "lrt.reflections.counts", AttributeValue::Text(Text::from("1 1 1")));
    assert!(matches!(refusal(&path), SidecarErrorKind::SizeMismatch { .. }));

    // A missing, an extra and a non-finite channel.
    fresh();
    rewrite(&path, |name, _, channels| {
        if name == "radiance.3" {
            channels.retain(|c| !c.name.eq("G"));
        }
        None
    });
    assert!(
        matches!(refusal(&path), SidecarErrorKind::MissingChannel { name, .. } if name == "radiance.3.G")
    );

    fresh();
    rewrite(&path, |name, _, channels| {
        if name == "distance" {
            let extra = AnyChannel::new("A", channels[0].sample_data.clone());
            channels.push(extra);
        }
        None
    });
    assert!(matches!(refusal(&path), SidecarErrorKind::UnexpectedChannel { name } if name == "distance.A"));

    fresh();
    rewrite(&path, |name, _, channels| {
        if name == "radiance.1"
            && let FlatSamples::F32(v) = &mut channels[0].sample_data
        {
            v[3] = f32::NAN;
        }
        None
    });
    assert!(
        matches!(refusal(&path), SidecarErrorKind::NonFinite { channel, x: 3, y: 0, .. } if channel == "radiance.1.B")
    );

    // Garbage is an EXR error naming the file.
    std::fs::write(&path, b"not an exr").unwrap();
    assert!(matches!(refusal(&path), SidecarErrorKind::Exr { .. } | SidecarErrorKind::Io(_)));
}

/// The `specular` marks round-trip as their own layer, written only where some texel is
/// marked: probes without marks make the file they made before the layer existed (no such
/// layer), which reads back without marks.
#[test]
fn specular_marks_round_trip_and_are_absent_where_none_is_set() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("out.reflections.exr");
    let layer_names = |path: &Path| -> Vec<String> {
        let image =
            read().no_deep_data().largest_resolution_level().all_channels().all_layers().all_attributes();
        let image = image.from_file(path).unwrap();
        image.layer_data.iter().map(|l| l.attributes.layer_name.as_ref().unwrap().to_string()).collect()
    };
    let unmarked = probes();
    write_reflections(&unmarked, &path).unwrap();
    assert!(!layer_names(&path).contains(&"specular".to_string()));
    assert_eq!(read_reflections(&path, None).unwrap(), Some(unmarked.clone()));
    let mut marked = unmarked.clone();
    marked.specular = (0..marked.distance.len()).map(|t| t % 7 == 3).collect();
    write_reflections(&marked, &path).unwrap();
    assert!(layer_names(&path).contains(&"specular".to_string()));
    let read_back = read_reflections(&path, None).unwrap().unwrap();
    assert_eq!(read_back, marked);
    let n = REFLECTION_TEXELS * REFLECTION_TEXELS;
    let texel = n + 3 * REFLECTION_TEXELS + 5;
    let dir_of = sidecar::octahedral_texel_center(REFLECTION_TEXELS, texel - n);
    assert_eq!(read_back.specular_toward(1, dir_of), texel % 7 == 3);
    // Marks of the wrong length are refused.
    let mut bad = marked.clone();
    bad.specular.pop();
    assert!(matches!(
        write_reflections(&bad, &path).unwrap_err().kind,
        SidecarErrorKind::Inconsistent { .. }
    ));
}

//! The probes file round-trips exactly and bad ones are refused naming the file.

use sidecar::{ProbeGrid, SidecarErrorKind, VISIBILITY_TEXELS, read_probes, write_probes};

fn grid() -> ProbeGrid {
    let n = 6;
    ProbeGrid {
        depth_fingerprint: 0x1234,
        origin: [-1.5, 0.25, 1e-3],
        spacing: [0.5, 0.75, 1.0],
        counts: [2, 3, 1],
        radiance_sh: (0..n).map(|p| std::array::from_fn(|i| [p as f32, i as f32 * 0.1, -0.5])).collect(),
        visibility: (0..n * VISIBILITY_TEXELS * VISIBILITY_TEXELS)
            .map(|t| [t as f32 * 0.01, t as f32 * 1e-4 + 0.5])
            .collect(),
        emitters_seen: false,
    }
}

#[test]
fn probes_round_trip_and_bad_files_are_refused() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("out.probes.exr");
    let g = grid();
    write_probes(&g, &path).unwrap();
    assert_eq!(read_probes(&path, Some(0x1234)).unwrap(), g);
    assert_eq!(read_probes(&path, None).unwrap(), g);
    let e = read_probes(&path, Some(7)).unwrap_err();
    assert!(matches!(e.kind, SidecarErrorKind::Stale { .. }));
    assert!(e.to_string().starts_with(&format!("{}: error: ", path.display())));
    // A layers file is not a probes file.
    let layers = sidecar::LightLayers::new(2, 2, 0, vec![]);
    let other = dir.path().join("out.layers.exr");
    sidecar::write_layers(&layers, &other).unwrap();
    assert!(matches!(read_probes(&other, None).unwrap_err().kind, SidecarErrorKind::WrongKind { .. }));
    // The writer refuses NaN and keeps the old file.
    let mut bad = g.clone();
    bad.visibility[3][1] = f32::NAN;
    assert!(write_probes(&bad, &path).is_err());
    assert_eq!(read_probes(&path, None).unwrap(), g);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

/// The `lrt.probes.emitters` attribute round-trips both ways, and a file written before it (no
/// attribute) is read as holding the emitters' light, as such files do.
#[test]
fn whether_the_probes_hold_the_emitters_light_round_trips_and_defaults_to_held() {
    use exr::prelude::*;
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("out.probes.exr");
    for emitters_seen in [false, true] {
        let g = ProbeGrid { emitters_seen, ..grid() };
        write_probes(&g, &path).unwrap();
        assert_eq!(read_probes(&path, None).unwrap(), g);
    }
    let mut image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(&path)
        .unwrap();
    for layer in image.layer_data.iter_mut() {
        assert!(layer.attributes.other.remove(&Text::from("lrt.probes.emitters")).is_some());
    }
    let legacy = dir.path().join("legacy.probes.exr");
    image.write().to_file(&legacy).unwrap();
    assert!(read_probes(&legacy, None).unwrap().emitters_seen);
}

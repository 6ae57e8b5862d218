//! The caustics file: written and read back exactly, and refused (naming the file) when it
//! belongs to another render or frame, or is not a caustics file.

use sidecar::{
    CausticFilter, CausticPhoton, CausticPhotons, CausticPixel, SidecarErrorKind, read_caustics,
    write_caustics,
};

fn fixture() -> CausticPhotons {
    let photon = |x: f32, first: u32, count: u32| CausticPhoton {
        position: [x, -1.0, 0.25],
        normal: [0.0, 1.0, 0.0],
        power: [x, 0.5, 0.125],
        first_segment: first,
        segment_count: count,
    };
    let mut pixels = vec![CausticPixel::default(); 6];
    pixels[4] = CausticPixel {
        position: [0.1, -1.0, 0.2],
        normal: [0.0, 1.0, 0.0],
        radius2: 0.01,
        weight: [3.0, 2.0, 1.0],
    };
    CausticPhotons {
        depth_fingerprint: 0x0123_4567_89ab_cdef,
        width: 3,
        height: 2,
        filter: CausticFilter::Cone { k: 1.1 },
        photons: vec![photon(0.125, 0, 2), photon(0.25, 2, 1)],
        segments: vec![
            [[0.0, 0.99, 0.0], [0.3, -0.2, 0.3]],
            [[0.4, -0.6, 0.3], [0.125, -1.0, 0.25]],
            [[0.1, 0.99, 0.1], [0.25, -1.0, 0.25]],
        ],
        pixels,
    }
}

#[test]
fn caustics_round_trip_exactly() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("out.caustics.exr");
    let caustics = fixture();
    write_caustics(&caustics, &path).unwrap();
    let back = read_caustics(&path, (3, 2), Some(caustics.depth_fingerprint)).unwrap();
    assert_eq!(back, caustics);
    for filter in [CausticFilter::Box, CausticFilter::Gaussian] {
        let c = CausticPhotons { filter, ..fixture() };
        write_caustics(&c, &path).unwrap();
        assert_eq!(read_caustics(&path, (3, 2), None).unwrap().filter, filter);
    }
}

#[test]
fn caustics_of_another_render_or_frame_are_refused_naming_the_file() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("out.caustics.exr");
    write_caustics(&fixture(), &path).unwrap();
    let stale = read_caustics(&path, (3, 2), Some(1)).unwrap_err();
    assert!(matches!(stale.kind, SidecarErrorKind::Stale { .. }), "{stale}");
    assert!(stale.to_string().contains("out.caustics.exr"), "{stale}");
    let size = read_caustics(&path, (2, 3), None).unwrap_err();
    assert!(matches!(size.kind, SidecarErrorKind::SizeMismatch { .. }), "{size}");
    // A layers file is not a caustics file.
    let other = dir.path().join("out.layers.exr");
    let layers = sidecar::LightLayers::new(3, 2, 7, vec![sidecar::LightSource::new(0, "pointlight")]);
    sidecar::write_layers(&layers, &other).unwrap();
    let wrong = read_caustics(&other, (3, 2), None).unwrap_err();
    assert!(matches!(wrong.kind, SidecarErrorKind::WrongKind { .. }), "{wrong}");
}

#[test]
fn inconsistent_caustics_are_not_written() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("bad.caustics.exr");
    let mut past_the_end = fixture();
    past_the_end.photons[1].segment_count = 2;
    let e = write_caustics(&past_the_end, &path).unwrap_err();
    assert!(matches!(e.kind, SidecarErrorKind::Inconsistent { .. }), "{e}");
    let mut nan = fixture();
    nan.pixels[0].radius2 = f32::NAN;
    assert!(matches!(write_caustics(&nan, &path).unwrap_err().kind, SidecarErrorKind::NonFinite { .. }));
    assert!(!path.exists());
}

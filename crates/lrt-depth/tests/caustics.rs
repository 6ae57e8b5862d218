//! `lrt-depth` writes the sidecar's caustic photons beside the depth table where the photon
//! mapper has a caustic map, tied to the table, and none (removing an earlier one) where it has
//! not (docs/sidecar.md, "Caustic photons").

use std::path::Path;
use std::process::{Command, Output};

/// A point light focused by a glass sphere onto a floor, or the same with a matte sphere.
fn scene(surface: &str) -> String {
    format!(
        "Option \"lrt\" \"string depthfile\" [\"small.depth\"]\nDisplay \"small.exr\" \"openexr\" \"rgb\"\n\
         Format 24 16 1\nProjection \"perspective\" \"fov\" [50]\nPixelSamples 1 1\nTranslate 0 0 4\n\
         SurfaceIntegrator \"photonmap\" \"integer indirectphotons\" [0] \"integer causticphotons\" [5000]\n\
         WorldBegin\nLightSource \"pointlight\" 1 \"from\" [-2 3 0] \"intensity\" [20]\n\
         AttributeBegin\nSurface \"matte\"\nPolygon \"P\" [-4 -1 -4  4 -1 -4  4 -1 4  -4 -1 4]\nAttributeEnd\n\
         AttributeBegin\nSurface {surface}\nSphere 0.4 -0.4 0.4 360\nAttributeEnd\nWorldEnd\n"
    )
}

fn run(dir: &Path) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_lrt-depth"))
        .current_dir(dir)
        .args(["small.rib", "--threads", "2"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

#[test]
fn caustic_photons_go_with_the_depth_table_only_where_there_is_a_caustic_map() {
    let scratch = tempfile::Builder::new().prefix("lrt-depth-caustics-").tempdir().unwrap();
    let dir = scratch.path();
    std::fs::write(dir.join("small.rib"), scene("\"glass\" \"float eta\" [1.5]")).unwrap();
    let out = run(dir);
    let paths = sidecar::SidecarPaths::for_depth(&dir.join("small.depth"));
    let table = depth_remap::DepthTable::read(dir.join("small.depth")).unwrap();
    let fingerprint = sidecar::depth_fingerprint(table.values());
    let caustics = sidecar::read_caustics(&paths.caustics, (24, 16), Some(fingerprint)).unwrap();
    assert!(!caustics.photons.is_empty() && caustics.pixels.iter().any(|p| p.radius2 > 0.0));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("small.caustics.exr (") && stdout.contains("caustic photons"), "{stdout}");
    // The same name rendered without a specular surface: no caustic map, no caustics file.
    std::fs::write(dir.join("small.rib"), scene("\"matte\"")).unwrap();
    run(dir);
    assert!(dir.join("small.layers.exr").exists());
    assert!(!paths.caustics.exists(), "an earlier render's caustics file was left behind");
}

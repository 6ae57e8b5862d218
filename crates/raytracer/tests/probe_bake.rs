//! Probes baked with the layers: light from one side of a wall does not reach the other side
//! through the probe field.

use raytracer::render::{RenderOptions, render};

const WALLED: &str = "Format 8 8 1\nPixelSamples 1 1\nProjection \"perspective\" \"fov\" [60]\n\
    Translate 0 0 6\nSurfaceIntegrator \"directlighting\"\nWorldBegin\n\
    LightSource \"pointlight\" 1 \"from\" [-1.5 1 0] \"intensity\" [4]\n\
    Surface \"matte\"\nSides 2\n\
    Polygon \"P\" [-3 -1 -3  3 -1 -3  3 -1 3  -3 -1 3]\n\
    Polygon \"P\" [0 -1 -3  0 3 -3  0 3 3  0 -1 3]\nWorldEnd\n";

#[test]
fn probes_do_not_leak_light_through_a_wall() {
    let scene = rib_parser::load_bytes("walled.rib", WALLED.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let options = RenderOptions { depth: true, layers: true, threads: Some(2), ..Default::default() };
    let out = render(&scene, &options).unwrap();
    let grid = out.probes.expect("probes are baked with the layers");
    assert_eq!(grid.counts, [16, 11, 16]);
    assert_eq!(grid.depth_fingerprint, sidecar::depth_fingerprint(&out.depth.unwrap().values));
    let up = [0.0, 1.0, 0.0];
    let lit = grid.irradiance([-0.05, -1.0, 0.0], up)[0];
    let dark = grid.irradiance([0.05, -1.0, 0.0], up)[0];
    // The floor just left of the (zero-thickness) wall receives the light, the floor just right
    // of it none, although the probes of both sides surround both points.
    let mut blind = grid.clone();
    for v in &mut blind.visibility {
        *v = [1e3, 1e6];
    }
    let leaked = blind.irradiance([0.05, -1.0, 0.0], up)[0];
    assert!(lit > 0.0, "{lit}");
    assert!(dark < 0.05 * lit, "lit {lit}, dark {dark}");
    // Without the visibility term the same probes do leak.
    assert!(leaked > 4.0 * dark.max(1e-3 * lit), "leaked {leaked}, dark {dark}");
}

const LIT_FLOOR: &str = "Format 8 8 1\nPixelSamples 1 1\nProjection \"perspective\" \"fov\" [60]\n\
    Translate 0 0 6\nSurfaceIntegrator \"directlighting\"\nWorldBegin\nSurface \"matte\"\n\
    AttributeBegin\nAreaLightSource \"arealight\" 1 \"intensity\" [2]\n\
    Polygon \"P\" [-2 1 -2  2 1 -2  2 1 2  -2 1 2]\nAttributeEnd\n\
    Polygon \"P\" [-2 -1 -2  -2 -1 2  2 -1 2  2 -1 -2]\nWorldEnd\n";

/// The probes hold the light leaving non-emitting surfaces only: a viewer adds the lights' own
/// direct light itself, so what an emitter sends straight to a probe is left out.
#[test]
fn probes_leave_out_the_light_emitters_send_them_straight() {
    let scene = rib_parser::load_bytes("lit.rib", LIT_FLOOR.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let options = RenderOptions { depth: true, layers: true, threads: Some(2), ..Default::default() };
    let grid = render(&scene, &options).unwrap().probes.expect("probes are baked with the layers");
    assert!(!grid.emitters_seen);
    // Between the light (above) and the lit floor (below): the floor's light arrives from
    // below; from above only the emitter's, which is left out.
    let from_floor = grid.irradiance([0.0, 0.0, 0.0], [0.0, -1.0, 0.0])[0];
    let from_light = grid.irradiance([0.0, 0.0, 0.0], [0.0, 1.0, 0.0])[0];
    assert!(from_floor > 0.1, "{from_floor}");
    assert!(from_light < 0.25 * from_floor, "from the light {from_light}, from the floor {from_floor}");
}

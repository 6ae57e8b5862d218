//! Reflection probes baked with the layers: a probe in a closed box with one self-luminous
//! (`constant`) wall sees that wall's radiance toward it and black elsewhere, its distance map
//! is the box, an area light's emitter seen directly is left out (viewers reflect the lights
//! from their samples), and the bake is the same for any thread count.

use raytracer::render::{RenderOptions, RenderOutput, render};
use sidecar::{REFLECTION_TEXELS, octahedral_texel_center};

/// The cube [-1, 1]^3, black matte walls, the +x wall `wall` (RIB lines before its polygon);
/// the camera at the centre.
fn box_rib(wall: &str) -> String {
    format!(
        "Format 4 4 1\nPixelSamples 1 1\nProjection \"perspective\" \"fov\" [60]\n\
         SurfaceIntegrator \"directlighting\"\nWorldBegin\nSides 2\nSurface \"matte\" \"Kd\" [0]\n\
         AttributeBegin\n{wall}\nPolygon \"P\" [1 -1 -1  1 1 -1  1 1 1  1 -1 1]\nAttributeEnd\n\
         Polygon \"P\" [-1 -1 -1  -1 -1 1  -1 1 1  -1 1 -1]\n\
         Polygon \"P\" [-1 -1 -1  1 -1 -1  1 -1 1  -1 -1 1]\n\
         Polygon \"P\" [-1 1 -1  -1 1 1  1 1 1  1 1 -1]\n\
         Polygon \"P\" [-1 -1 -1  -1 1 -1  1 1 -1  1 -1 -1]\n\
         Polygon \"P\" [-1 -1 1  1 -1 1  1 1 1  -1 1 1]\nWorldEnd\n"
    )
}

/// A self-luminous wall of radiance (2, 1, 0.5): surface radiance, not a light.
const CONSTANT_WALL: &str = "Color [2 1 0.5]\nSurface \"constant\"";

/// The same wall as a two-sided area light of that radiance.
const EMITTER_WALL: &str =
    "AreaLightSource \"arealight\" 1 \"intensity\" [2] \"lightcolor\" [1 0.5 0.25] \"twosided\" [1]";

fn run(threads: usize) -> RenderOutput {
    run_with(CONSTANT_WALL, threads)
}

fn run_with(wall: &str, threads: usize) -> RenderOutput {
    let scene = rib_parser::load_bytes("box.rib", box_rib(wall).into_bytes(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let options = RenderOptions { depth: true, layers: true, threads: Some(threads), ..Default::default() };
    render(&scene, &options).unwrap()
}

#[test]
fn a_probe_in_a_box_sees_the_luminous_wall_where_it_is_and_how_far() {
    let out = run(2);
    let probes = out.reflections.clone().expect("reflection probes are baked with the layers");
    assert_eq!(probes.counts, [6, 6, 6]);
    assert_eq!(probes.depth_fingerprint, sidecar::depth_fingerprint(&out.depth.as_ref().unwrap().values));
    for a in 0..3 {
        assert!((probes.origin[a] + 5.0 / 6.0).abs() < 1e-4, "{:?}", probes.origin);
        assert!((probes.spacing[a] - 1.0 / 3.0).abs() < 1e-4, "{:?}", probes.spacing);
    }
    let wall = [2.0f32, 1.0, 0.5];
    let n = REFLECTION_TEXELS * REFLECTION_TEXELS;
    // The probe nearest the box's centre, at (-1/6, -1/6, -1/6).
    let centre = probes.probe_index([2, 2, 2]);
    let at = -1.0f32 / 6.0;
    let (mut lit, mut dark) = (0, 0);
    for t in 0..n {
        let d = octahedral_texel_center(REFLECTION_TEXELS, t);
        // How far the box's face across each axis is along d (infinite along an axis d does not
        // move along).
        let face = |a: usize| if d[a] == 0.0 { f32::INFINITY } else { (d[a].signum() - at) / d[a] };
        let (to_x, to_other) = (face(0), face(1).min(face(2)));
        // The distance map is the cube's, seen from the probe.
        let distance = probes.distance[centre * n + t];
        let want = to_x.min(to_other);
        assert!((distance - want).abs() < 1e-3, "texel {t}: {distance} vs {want}");
        // Texels whose whole footprint (about 6 degrees) lies on the lit wall (x = 1) see its
        // radiance exactly; texels well away from it see black walls.
        let radiance = probes.radiance[0][centre * n + t];
        if d[0] > 0.0 && to_x < 0.8 * to_other {
            lit += 1;
            for c in 0..3 {
                assert!((radiance[c] - wall[c]).abs() < 1e-4 * wall[c], "texel {t} {d:?}: {radiance:?}");
            }
        } else if d[0] <= 0.0 || to_x > 1.25 * to_other {
            dark += 1;
            assert_eq!(radiance, [0.0; 3], "texel {t} {d:?}");
        }
    }
    // From 7/6 away the lit wall covers less of the map than from the centre (1 away).
    assert!(lit > n / 10 && dark > n / 2, "{lit} lit, {dark} dark texels");
    // A probe nearer the wall sees it nearer.
    let near = probes.probe_index([5, 2, 2]);
    assert!((probes.distance_toward(near, [1.0, 0.0, 0.0]) - 1.0 / 6.0).abs() < 1e-3);
    assert!((probes.distance_toward(near, [-1.0, 0.0, 0.0]) - 11.0 / 6.0).abs() < 1e-3);
    // The lookup: a mirror and a moderately glossy surface facing the wall see its radiance, a
    // surface facing away none; the broadest lobe toward the wall sees part of it.
    for roughness in [0.0, 1.0 / 64.0] {
        let toward = probes.sample(centre, [1.0, 0.0, 0.0], roughness);
        assert!((toward[0] - wall[0]).abs() < 0.02 * wall[0], "{roughness}: {toward:?}");
        assert!(probes.sample(centre, [-1.0, 0.0, 0.0], roughness)[0] < 1e-3);
    }
    // Blended and parallax-corrected from anywhere in the box: toward the wall its radiance,
    // away from it none.
    for p in [[0.5, 0.1, 0.2], [-0.7, -0.6, 0.3], [0.1, 0.8, -0.8]] {
        let toward = probes.radiance(p, [1.0, 0.0, 0.0], 0.0);
        assert!((toward[0] - wall[0]).abs() < 0.02 * wall[0], "{p:?}: {toward:?}");
        assert!(probes.radiance(p, [-1.0, 0.0, 0.0], 0.0)[0] < 1e-3, "{p:?}");
    }
    let broad = probes.sample(centre, [1.0, 0.0, 0.0], 1.0)[0];
    assert!(broad > 0.2 * wall[0] && broad < 0.9 * wall[0], "{broad}");
}

#[test]
fn reflection_probes_are_the_same_for_any_thread_count() {
    assert_eq!(run(1).reflections, run(2).reflections);
}

/// An area light's emitter seen straight from a probe is left out of its radiance: the same box
/// with the wall an area light of the same radiance (and black walls, which reflect nothing)
/// leaves every texel black, while the distance map still sees the wall.
#[test]
fn an_emitter_seen_directly_is_left_out() {
    let out = run_with(EMITTER_WALL, 2);
    let probes = out.reflections.expect("reflection probes are baked with the layers");
    for level in &probes.radiance {
        assert!(level.iter().all(|t| *t == [0.0; 3]), "a texel holds emitted light");
    }
    let centre = probes.probe_index([2, 2, 2]);
    assert!((probes.distance_toward(centre, [1.0, 0.0, 0.0]) - 7.0 / 6.0).abs() < 1e-3);
}

/// The texels whose first surface is a mirror or glass are marked (their radiance is an image
/// that changes with the viewpoint): with the +x wall a mirror, exactly the centre probe's
/// texels whose centre ray meets that wall first; with the wall glass, likewise; with the wall
/// self-luminous and matte, none (the marks left empty, as a sidecar from before them reads).
#[test]
fn texels_that_see_a_mirror_or_glass_are_marked() {
    assert!(run(2).reflections.unwrap().specular.is_empty());
    for wall in ["Surface \"mirror\"", "Surface \"glass\" \"float eta\" [1.5]"] {
        let probes = run_with(wall, 2).reflections.unwrap();
        let n = REFLECTION_TEXELS * REFLECTION_TEXELS;
        assert_eq!(probes.specular.len(), probes.distance.len(), "{wall}");
        let centre = probes.probe_index([2, 2, 2]);
        let at = -1.0f32 / 6.0;
        let mut marked = 0;
        for t in 0..n {
            let d = octahedral_texel_center(REFLECTION_TEXELS, t);
            let face = |a: usize| if d[a] == 0.0 { f32::INFINITY } else { (d[a].signum() - at) / d[a] };
            let (to_x, to_other) = (face(0), face(1).min(face(2)));
            // A centre ray along the box's edge may meet either face.
            if (to_x - to_other).abs() < 1e-3 * to_x {
                continue;
            }
            let on_wall = d[0] > 0.0 && to_x < to_other;
            assert_eq!(probes.specular[centre * n + t], on_wall, "{wall}: texel {t} {d:?}");
            marked += usize::from(on_wall);
        }
        assert!(marked > n / 20, "{wall}: {marked} texels marked");
    }
}

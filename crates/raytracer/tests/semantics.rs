//! What RIB attributes mean to the renderer: sides and orientation, emitters' front sides,
//! object instancing, opacity, light linking, holdouts, lossless glass and mirrors, warnings.

use glam::Vec3;
use raytracer::integrators::IntegratorKind;
use raytracer::render::{RenderOptions, RenderOutput, render};

fn run(rib: &str, options: RenderOptions) -> RenderOutput {
    let scene = rib_parser::load_bytes("semantics.rib", rib.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    render(&scene, &RenderOptions { depth: true, threads: Some(2), ..options }).unwrap()
}

fn centre_depth(out: &RenderOutput) -> f32 {
    let d = out.depth.as_ref().unwrap();
    d.values[((d.height / 2) * d.width + d.width / 2) as usize]
}

const CAMERA: &str =
    "Format 9 9 1\nProjection \"perspective\" \"fov\" [20]\nPixelFilter \"box\" 1 1\nTranslate 0 0 5\n";

/// A square in the plane z = 0 whose normal `(P1 - P0) x (P2 - P0)` is +z (away from the
/// camera, which looks along +z from z = -5).
const AWAY: &str = "Polygon \"P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0]";

#[test]
fn one_sided_surfaces_hide_their_back() {
    let rib = |attrs: &str| format!("{CAMERA}WorldBegin\n{attrs}\n{AWAY}\nWorldEnd\n");
    assert_eq!(centre_depth(&run(&rib("Sides 2"), RenderOptions::default())), 5.0);
    assert!(centre_depth(&run(&rib("Sides 1"), RenderOptions::default())).is_infinite());
    assert_eq!(centre_depth(&run(&rib("Sides 1\nReverseOrientation"), RenderOptions::default())), 5.0);
}

#[test]
fn one_sided_reversed_sphere_shows_its_inside() {
    let rib = |attrs: &str| format!("{CAMERA}WorldBegin\n{attrs}\nSphere 1 -1 1 360\nWorldEnd\n");
    assert!((centre_depth(&run(&rib("Sides 1"), RenderOptions::default())) - 4.0).abs() < 1e-5);
    // Normals point in: the near half faces away and is culled, the far half is seen.
    assert!(
        (centre_depth(&run(&rib("Sides 1\nReverseOrientation"), RenderOptions::default())) - 6.0).abs()
            < 1e-5
    );
}

#[test]
fn area_lights_emit_from_their_front_side() {
    // A light square at z = 0 seen by the camera at z = -5; a matte wall at z = 1 behind it.
    let rib = |light_normal_toward_camera: bool, extra: &str| {
        let light = if light_normal_toward_camera {
            "Polygon \"P\" [-0.5 -0.5 0  -0.5 0.5 0  0.5 0.5 0  0.5 -0.5 0]"
        } else {
            "Polygon \"P\" [-0.5 -0.5 0  0.5 -0.5 0  0.5 0.5 0  -0.5 0.5 0]"
        };
        format!(
            "{CAMERA}SurfaceIntegrator \"path\"\nWorldBegin\nAttributeBegin\nAreaLightSource \"arealight\" 1 \"intensity\" [2] {extra}\nSurface \"matte\" \"Kd\" [0]\n{light}\nAttributeEnd\nWorldEnd\n"
        )
    };
    let opts = || RenderOptions { spp: Some(1), ..Default::default() };
    let toward = run(&rib(true, ""), opts());
    assert_eq!(toward.image.rgb(4, 4), Vec3::splat(2.0));
    let away = run(&rib(false, ""), opts());
    assert_eq!(away.image.rgb(4, 4), Vec3::ZERO);
    let two_sided = run(&rib(false, "\"float twosided\" [1]"), opts());
    assert_eq!(two_sided.image.rgb(4, 4), Vec3::splat(2.0));
}

#[test]
fn instances_share_geometry_and_place_it() {
    let rib = format!(
        "{CAMERA}WorldBegin\nObjectBegin \"ball\"\nSphere 0.5 -0.5 0.5 360\nObjectEnd\n\
         AttributeBegin\nTranslate 0 0 1\nObjectInstance \"ball\"\nAttributeEnd\n\
         AttributeBegin\nTranslate 3 0 0\nObjectInstance \"ball\"\nAttributeEnd\n\
         Polygon \"P\" [-9 -9 3  9 -9 3  9 9 3  -9 9 3]\nWorldEnd\n"
    );
    let out = run(&rib, RenderOptions::default());
    assert!((centre_depth(&out) - 5.5).abs() < 1e-5, "{}", centre_depth(&out));
    let w = &out.stats.world;
    // The world's own shapes, one definition, three placements and a top-level BVH.
    assert_eq!((w.blases, w.instances, w.quadrics, w.top_level), (2, 3, 1, true));
}

#[test]
fn transparent_surfaces_are_seen_through() {
    let rib = |opacity: &str| {
        format!(
            "{CAMERA}WorldBegin\nLightSource \"ambientlight\" 1 \"intensity\" [1]\n\
             AttributeBegin\nOpacity {opacity}\nColor [1 0 0]\nSurface \"matte\" \"Ka\" [1] \"Kd\" [0]\nPolygon \"P\" [-2 -2 -1  2 -2 -1  2 2 -1  -2 2 -1]\nAttributeEnd\n\
             Color [0 0 1]\nSurface \"matte\" \"Ka\" [1] \"Kd\" [0]\n{AWAY}\nWorldEnd\n"
        )
    };
    let clear = run(&rib("[0 0 0]"), RenderOptions { spp: Some(4), ..Default::default() });
    assert_eq!(centre_depth(&clear), 5.0);
    assert_eq!(clear.image.rgb(4, 4), Vec3::new(0.0, 0.0, 1.0));
    let half = run(&rib("[0.5 0.5 0.5]"), RenderOptions { spp: Some(400), ..Default::default() });
    assert_eq!(centre_depth(&half), 4.0);
    let c = half.image.rgb(4, 4);
    assert!((c - Vec3::new(0.5, 0.0, 0.5)).abs().max_element() < 0.1, "{c}");
}

#[test]
fn light_linking_and_holdouts() {
    let rib = format!(
        "{CAMERA}WorldBegin\nLightSource \"distantlight\" 1 \"from\" [0 0 0] \"to\" [0 0 1]\n\
         AttributeBegin\nIlluminate 1 0\nTranslate -0.5 0 0\nSurface \"matte\"\nPolygon \"P\" [-0.5 -1 0  0.5 -1 0  0.5 1 0  -0.5 1 0]\nAttributeEnd\n\
         AttributeBegin\nTranslate 0.5 0 0\nSurface \"matte\"\nPolygon \"P\" [-0.5 -1 0  0.5 -1 0  0.5 1 0  -0.5 1 0]\nAttributeEnd\n\
         WorldEnd\n"
    );
    let out = run(&rib, RenderOptions { spp: Some(1), ..Default::default() });
    // Left half: not illuminated by the light; right half: lit (cos = 1, pi * 1 / pi).
    assert_eq!(out.image.rgb(2, 4), Vec3::ZERO);
    assert!((out.image.rgb(6, 4) - Vec3::ONE).abs().max_element() < 1e-5, "{}", out.image.rgb(6, 4));
    let holdout = rib.replace("Translate 0.5 0 0\n", "Translate 0.5 0 0\nMatte 1\n");
    let out = run(&holdout, RenderOptions { spp: Some(1), ..Default::default() });
    assert_eq!(out.image.pixels[4 * 9 + 6], [0.0; 4]);
}

/// Inside an enclosure that emits 1 and reflects half (radiance 2 everywhere), a perfect mirror
/// and a clear glass sphere are invisible: they neither absorb nor add light.
#[test]
fn glass_and_mirror_are_lossless() {
    for surface in ["\"glass\" \"eta\" [1.5]", "\"mirror\" \"Kr\" [1]"] {
        let rib = format!(
            "{CAMERA}SurfaceIntegrator \"path\"\nWorldBegin\n\
             AttributeBegin\nAreaLightSource \"arealight\" 1 \"intensity\" [1]\nReverseOrientation\nColor [0.5 0.5 0.5]\nSurface \"matte\"\nSphere 20 -20 20 360\nAttributeEnd\n\
             Surface {surface}\nSphere 1 -1 1 360\nWorldEnd\n"
        );
        let out = run(
            &rib,
            RenderOptions {
                spp: Some(256),
                integrator: Some(IntegratorKind::Path { max_depth: 1024, rr_depth: 5 }),
                ..Default::default()
            },
        );
        let mean = out.image.mean_rgb();
        assert!((mean - Vec3::splat(2.0)).abs().max_element() < 0.05, "{surface}: {mean}");
        let centre = out.image.rgb(4, 4);
        assert!((centre - Vec3::splat(2.0)).abs().max_element() < 0.15, "{surface}: centre {centre}");
    }
}

#[test]
fn unknown_shaders_warn_once_by_name() {
    let rib = format!("{CAMERA}WorldBegin\nSurface \"velvet\"\n{AWAY}\nSphere 0.5 -0.5 0.5 360\nWorldEnd\n");
    let out = run(&rib, RenderOptions { spp: Some(1), ..Default::default() });
    let warnings: Vec<_> = out.warnings.iter().filter(|w| w.message.contains("velvet")).collect();
    assert_eq!(warnings.len(), 1, "{:?}", out.warnings);
    assert!(warnings[0].loc.is_some());
}

#[test]
fn paintedplastic_reads_its_texture_map_at_st() {
    let scratch = tempfile::Builder::new().prefix("raytracer-texture-").tempdir().unwrap();
    let dir = scratch.path();
    let path = dir.join("halves.png");
    // Left half red, right half blue.
    let img =
        image::RgbImage::from_fn(
            4,
            2,
            |x, _| if x < 2 { image::Rgb([255, 0, 0]) } else { image::Rgb([0, 0, 255]) },
        );
    img.save(&path).unwrap();
    let rib = format!(
        "{CAMERA}WorldBegin\nLightSource \"ambientlight\" 1 \"intensity\" [1]\n\
         Surface \"paintedplastic\" \"Ka\" [1] \"Kd\" [0] \"Ks\" [0] \"string texturename\" [\"{}\"]\n\
         Polygon \"P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \"st\" [0 0  1 0  1 1  0 1]\nWorldEnd\n",
        path.display()
    );
    let out = run(&rib, RenderOptions { spp: Some(1), ..Default::default() });
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    // Screen x runs from -x to +x in world here, so the left of the image is s near 0.
    // Away from the middle (where the bilinear lookup and the gaussian pixel filter blend).
    let left = out.image.rgb(1, 4);
    let right = out.image.rgb(7, 4);
    assert!(left.x > 0.9 && left.z < 0.1, "{left}");
    assert!(right.z > 0.9 && right.x < 0.1, "{right}");
}

#[test]
fn clipping_planes_cut_geometry() {
    let rib = |clipping: &str| format!("{clipping}\n{CAMERA}WorldBegin\nSphere 1 -1 1 360\nWorldEnd\n");
    assert!((centre_depth(&run(&rib(""), RenderOptions::default())) - 4.0).abs() < 1e-5);
    // The near plane at z = 4.5 cuts the sphere's front: the ray sees its inside at the back.
    assert!((centre_depth(&run(&rib("Clipping 4.5 100"), RenderOptions::default())) - 6.0).abs() < 1e-5);
    // The far plane at z = 3 hides everything.
    assert!(centre_depth(&run(&rib("Clipping 0.1 3"), RenderOptions::default())).is_infinite());
}

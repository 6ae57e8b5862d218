//! Displacement shaders against closed forms: `bumpy` of a constant texture makes a sphere of
//! radius `r + Km amplitude value` (measured by rays), `dented` only pushes inward within its
//! bound, `null` renders bit for bit as no shader, and custom shaders are named in a warning.
//! (The dicing budget against a hostile shading rate is tested in `tessellate`.)

use glam::DVec3;
use raytracer::diagnostics::Diagnostics;
use raytracer::render::{RenderOptions, render};
use raytracer::world::{PixelFootprint, Ray, World};
use std::path::Path;
use tessellate::DENTED_MAX_MAGNITUDE_CUBED;

const EYE: DVec3 = DVec3::new(0.0, 0.0, -5.0);

fn load(dir: &Path, world: &str) -> rib_parser::scene::Scene {
    let path = dir.join("scene.rib");
    std::fs::write(&path, format!("WorldBegin\n{world}\nWorldEnd\n")).unwrap();
    rib_parser::load_scene(&path, &Default::default()).unwrap_or_else(|e| panic!("{}", e.render())).scene
}

fn world_of(scene: &rib_parser::scene::Scene) -> (World, Diagnostics) {
    let mut diagnostics = Diagnostics::default();
    let footprint = PixelFootprint::Perspective { radians_per_pixel: 1e-3 };
    let world = World::build(scene, EYE, footprint, &mut diagnostics).expect("the world builds");
    (world, diagnostics)
}

/// Distances from the origin at which rays aimed at the origin from 3 units away, from
/// directions spread over the sphere, first meet the world (render space: the eye at `EYE`).
fn radii(world: &World) -> Vec<(DVec3, f64)> {
    let mut out = Vec::new();
    let n = 40;
    for i in 0..n {
        // A Fibonacci spiral of directions.
        let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
        let phi = i as f64 * 2.399_963_229_728_653;
        let rho = (1.0 - z * z).sqrt();
        let d = DVec3::new(rho * phi.cos(), rho * phi.sin(), z);
        let origin = 3.0 * d - EYE;
        let ray = Ray::new(origin.as_vec3(), (-d).as_vec3());
        let hit = world.intersect(&ray).expect("every ray meets the sphere");
        out.push((d, 3.0 - f64::from(hit.t)));
    }
    out
}

/// A unit sphere with `bumpy` "Km" 0.5 "amplitude" 0.4 of an all-white texture (value 1) is a
/// sphere of radius 1.2: 40 rays measure it within the tessellation's half-pixel tolerance
/// (micropolygons of 16 pixels, 4 pixels on a side, keep the test quick).
/// Without displacement they would measure 1.
#[test]
fn bumpy_of_a_constant_texture_makes_a_sphere_of_the_displaced_radius() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(4, 4, image::Rgb([255, 255, 255]))
        .save(dir.path().join("white.png"))
        .unwrap();
    let scene = load(
        dir.path(),
        "ShadingRate 16\nDisplacement \"bumpy\" \"Km\" [0.5] \"amplitude\" [0.4] \"texturename\" [\"white.png\"]\n\
         Sphere 1 -1 1 360",
    );
    let (world, diagnostics) = world_of(&scene);
    assert!(diagnostics.warnings.is_empty(), "{:?}", diagnostics.warnings);
    assert!(world.stats.triangles > 1000, "the sphere is a displaced mesh: {:?}", world.stats);
    for (d, r) in radii(&world) {
        assert!((r - 1.2).abs() < 3e-3, "radius {r} along {d}, expected 1.2");
    }
}

/// `dented` "Km" 0.3 on a unit sphere: every measured radius lies in [1 - Km max^3, 1], some
/// well inside (dents), and the world holds triangles instead of the exact quadric.
#[test]
fn dented_pushes_a_sphere_inward_within_its_bound() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(dir.path(), "ShadingRate 16\nDisplacement \"dented\" \"Km\" [0.3]\nSphere 1 -1 1 360");
    let (world, diagnostics) = world_of(&scene);
    assert!(diagnostics.warnings.is_empty(), "{:?}", diagnostics.warnings);
    let lowest = 1.0 - 0.3 * DENTED_MAX_MAGNITUDE_CUBED;
    let measured = radii(&world);
    for (d, r) in &measured {
        assert!(*r <= 1.0 + 2e-3 && *r >= lowest - 2e-3, "radius {r} along {d}");
    }
    let deepest = measured.iter().map(|(_, r)| *r).fold(f64::INFINITY, f64::min);
    assert!(deepest < 1.0 - 5e-3, "no dent found: smallest radius {deepest}");
}

/// A render with `Displacement "null"` is the render without a displacement shader, bit for
/// bit, and warns about nothing; a custom shader is named in a warning and not run.
#[test]
fn null_renders_bit_identically_and_custom_shaders_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let render_world = |world: &str| {
        let path = dir.path().join("scene.rib");
        let rib = format!(
            "Format 32 32 1\nProjection \"perspective\" \"fov\" [30]\nTranslate 0 0 5\nWorldBegin\n\
             LightSource \"distantlight\" 1 \"from\" [0 0 -1] \"to\" [0 0 0]\n{world}\nWorldEnd\n"
        );
        std::fs::write(&path, rib).unwrap();
        let loaded = rib_parser::load_scene(&path, &Default::default()).unwrap();
        render(&loaded.scene, &RenderOptions { spp: Some(2), threads: Some(2), ..Default::default() })
            .unwrap()
    };
    let plain = render_world("Surface \"plastic\"\nSphere 1 -1 1 360");
    let null = render_world("Displacement \"null\"\nSurface \"plastic\"\nSphere 1 -1 1 360");
    assert!(null.warnings.is_empty(), "{:?}", null.warnings);
    assert!(plain.image.pixels == null.image.pixels, "Displacement \"null\" changed the image");
    let custom = render_world("Displacement \"micro_bumps\"\nSurface \"plastic\"\nSphere 1 -1 1 360");
    assert!(
        custom.warnings.iter().any(|w| w.message.contains("\"micro_bumps\" is a custom shader")),
        "{:?}",
        custom.warnings
    );
    assert!(plain.image.pixels == custom.image.pixels, "a custom shader is not run");
}

/// A deforming square (z = 0 at shutter open, z = 1 at close) with `bumpy` of a white texture
/// (Km 0.5, amplitude 0.4: +0.2 along the normal, +z) is displaced at every key: rays at shutter
/// open and close meet it at z = 0.2 and z = 1.2 (0.1 halfway), with no warning.
#[test]
fn a_deforming_displaced_shape_is_displaced_at_every_key() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(4, 4, image::Rgb([255, 255, 255]))
        .save(dir.path().join("white.png"))
        .unwrap();
    let path = dir.path().join("scene.rib");
    let square = |z: f32| format!("Polygon \"P\" [-1 -1 {z}  1 -1 {z}  1 1 {z}  -1 1 {z}]");
    std::fs::write(
        &path,
        format!(
            "Shutter 0 1\nWorldBegin\nShadingRate 16\n\
             Displacement \"bumpy\" \"Km\" [0.5] \"amplitude\" [0.4] \"texturename\" [\"white.png\"]\n\
             MotionBegin [0 1]\n{}\n{}\nMotionEnd\nWorldEnd\n",
            square(0.0),
            square(1.0)
        ),
    )
    .unwrap();
    let scene =
        rib_parser::load_scene(&path, &Default::default()).unwrap_or_else(|e| panic!("{}", e.render())).scene;
    let (world, diagnostics) = world_of(&scene);
    assert!(diagnostics.warnings.is_empty(), "{:?}", diagnostics.warnings);
    for (time, z) in [(0.0f32, 0.2f64), (1.0, 1.2), (0.5, 0.7)] {
        // From z = 5 straight down, at (0.3, -0.2).
        let origin = DVec3::new(0.3, -0.2, 5.0) - EYE;
        let ray = Ray { time, ..Ray::new(origin.as_vec3(), glam::Vec3::new(0.0, 0.0, -1.0)) };
        let hit = world.intersect(&ray).expect("the ray meets the square");
        let hit_z = 5.0 - f64::from(hit.t);
        assert!((hit_z - z).abs() < 1e-4, "at time {time} the square is at z {hit_z}, expected {z}");
    }
}

/// `displacementbound` bounds no work here (the BVH is built over the displaced triangles):
/// a bound smaller than the displacement (`bumpy` of a white map moves the unit sphere by
/// 0.2) is named in a warning and the sphere is drawn in full, radius 1.2 (PRMan would show
/// clipping or missing pieces); a bound that holds it gives no warning and the same surface.
#[test]
fn a_displacementbound_too_small_is_reported_and_the_displacement_drawn_in_full() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(4, 4, image::Rgb([255, 255, 255]))
        .save(dir.path().join("white.png"))
        .unwrap();
    for (bound, warned) in [(0.05, true), (0.25, false)] {
        let scene = load(
            dir.path(),
            &format!(
                "ShadingRate 16\nAttribute \"displacementbound\" \"sphere\" [{bound}]\n\
                 Displacement \"bumpy\" \"Km\" [0.5] \"amplitude\" [0.4] \"texturename\" [\"white.png\"]\n\
                 Sphere 1 -1 1 360"
            ),
        );
        let (world, diagnostics) = world_of(&scene);
        let text = format!("{:?}", diagnostics.warnings);
        assert_eq!(text.contains("beyond its displacementbound"), warned, "bound {bound}: {text}");
        if warned {
            assert!(text.contains("drawn in full (PRMan would show clipping or missing pieces"), "{text}");
        }
        for (d, r) in radii(&world) {
            assert!((r - 1.2).abs() < 3e-3, "bound {bound}: radius {r} along {d}, expected 1.2");
        }
    }
}

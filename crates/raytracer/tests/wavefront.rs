//! The wavefront path integrator (`raytracer::wavefront`) renders every qualifying scene bit
//! for bit as the scalar one does, with one thread and with two; a scene that does not qualify
//! takes the scalar integrator even when the wavefront is asked for.

use glam::{DVec3, Vec3};
use raytracer::integrators::IntegratorKind;
use raytracer::render::{RenderOptions, RenderOutput, render};
use raytracer::testing::{SceneBuilder, shader};
use rib_parser::scene::{Attributes, LightKind, Scene};
use std::path::PathBuf;

fn cornell() -> Scene {
    let path =
        PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell/cornell.rib"));
    let mut scene = rib_parser::load_scene(&path, &rib_parser::LoadOptions::default())
        .expect("the reference RIB loads")
        .scene;
    // A 64x64 window of the 512x512 frame: the light, the tall box and the walls' corner.
    scene.camera.crop_window = depth_remap::CropWindow { xmin: 0.3, xmax: 0.425, ymin: 0.05, ymax: 0.175 };
    scene
}

/// A room of matte quads in four colours lit by an area quad, a point light, a spot light and
/// a distant light (two-sided geometry, light from both sides of the walls).
fn lit_room() -> Scene {
    lit_room_with(None)
}

/// The lit room, with an ambient light of this intensity where one is given, and then the
/// tilted panel's material with `Ka` (the others have none).
fn lit_room_with(ambient: Option<f32>) -> Scene {
    let mut b =
        SceneBuilder::perspective(40, 30, 60.0, DVec3::new(0.2, 0.3, -2.5), DVec3::new(0.0, -0.1, 0.0));
    b.light(
        LightKind::Point { position: DVec3::new(0.4, 0.6, -0.3), intensity: 0.6, color: Vec3::ONE },
        "pointlight",
    );
    b.light(
        LightKind::Spot {
            position: DVec3::new(-0.5, 0.8, -0.8),
            direction: DVec3::new(0.3, -1.0, 0.4).normalize(),
            intensity: 1.5,
            color: Vec3::new(1.0, 0.8, 0.6),
            cone_angle: 0.5,
            cone_delta_angle: 0.1,
            beam_distribution: 2.0,
        },
        "spotlight",
    );
    b.light(
        LightKind::Distant {
            direction: DVec3::new(0.2, -1.0, 0.3).normalize(),
            intensity: 0.2,
            color: Vec3::ONE,
        },
        "distantlight",
    );
    let area = b.light(LightKind::Area { intensity: 4.0, color: Vec3::new(1.0, 0.9, 0.7) }, "arealight");
    let walls = [
        Vec3::new(0.8, 0.8, 0.8),
        Vec3::new(0.7, 0.2, 0.2),
        Vec3::new(0.2, 0.6, 0.3),
        Vec3::new(0.3, 0.3, 0.9),
    ];
    let mut ids: Vec<_> = walls.iter().map(|&c| b.matte(c)).collect();
    if let Some(intensity) = ambient {
        b.light(LightKind::Ambient { intensity, color: Vec3::new(0.3, 0.2, 0.4) }, "ambientlight");
        ids[2] = b.attributes(Attributes {
            color: walls[2],
            surface: Some(shader("matte", &[("Kd", 1.0), ("Ka", 0.5)])),
            ..Attributes::default()
        });
    }
    let quad = |y0: f32, y1: f32, x0: f32, x1: f32, z0: f32, z1: f32| {
        [Vec3::new(x0, y0, z0), Vec3::new(x1, y0, z0), Vec3::new(x1, y1, z1), Vec3::new(x0, y1, z1)]
    };
    // Floor, ceiling, back wall, left and right walls, and a tilted panel in the middle.
    b.polygon(&quad(-1.0, -1.0, -1.0, 1.0, 1.0, -1.0), ids[0]);
    b.polygon(&quad(1.0, 1.0, -1.0, 1.0, -1.0, 1.0), ids[0]);
    b.polygon(
        &[
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(-1.0, 1.0, 1.0),
        ],
        ids[3],
    );
    b.polygon(
        &[
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(-1.0, 1.0, 1.0),
            Vec3::new(-1.0, 1.0, -1.0),
        ],
        ids[1],
    );
    b.polygon(
        &[
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(1.0, 1.0, -1.0),
            Vec3::new(1.0, 1.0, 1.0),
        ],
        ids[2],
    );
    b.polygon(
        &[
            Vec3::new(-0.4, -1.0, 0.1),
            Vec3::new(0.1, -1.0, 0.4),
            Vec3::new(0.0, 0.2, 0.3),
            Vec3::new(-0.5, 0.2, 0.0),
        ],
        ids[2],
    );
    let lamp = b.attributes(Attributes {
        color: Vec3::splat(0.5),
        surface: Some(shader("matte", &[("Kd", 1.0), ("Ka", 0.0)])),
        area_light: Some(area),
        ..Attributes::default()
    });
    b.polygon(&quad(0.99, 0.99, -0.3, 0.3, -0.2, 0.2), lamp);
    b.light_everything();
    b.build()
}

fn render_with(scene: &Scene, wavefront: bool, threads: usize, spp: u32) -> RenderOutput {
    let options = RenderOptions {
        spp: Some(spp),
        threads: Some(threads),
        depth: true,
        seed: 7,
        integrator: Some(IntegratorKind::Path { max_depth: 1024, rr_depth: 5 }),
        wavefront: Some(wavefront),
        ..RenderOptions::default()
    };
    render(scene, &options).expect("the scene renders")
}

/// The bits of every channel of every pixel, and of every depth value.
fn bits(out: &RenderOutput) -> (Vec<u32>, Vec<u32>) {
    let pixels = out.image.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect();
    let depth = out.depth.as_ref().expect("a depth table").values.iter().map(|d| d.to_bits()).collect();
    (pixels, depth)
}

fn assert_same_images(scene: &Scene, spp: u32) {
    let scalar = render_with(scene, false, 1, spp);
    assert!(!scalar.stats.wavefront);
    let (image, depth) = bits(&scalar);
    assert!(image.iter().any(|&b| f32::from_bits(b) > 0.0), "the image is not black");
    for threads in [1, 2] {
        let lanes = render_with(scene, true, threads, spp);
        assert!(lanes.stats.wavefront, "the scene qualifies for the wavefront");
        assert_eq!(lanes.stats.rays, scalar.stats.rays, "the same rays, {threads} threads");
        let (lanes_image, lanes_depth) = bits(&lanes);
        let differ = image.iter().zip(&lanes_image).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{differ} channels differ, {threads} threads");
        assert_eq!(image.len(), lanes_image.len());
        assert_eq!(depth, lanes_depth, "{threads} threads");
    }
}

#[test]
fn cornell_box_is_bit_identical() {
    assert_same_images(&cornell(), 4);
}

#[test]
fn lit_room_with_every_light_kind_is_bit_identical() {
    assert_same_images(&lit_room(), 8);
}

/// Under a finite ambient light, surfaces without ambient reflection take the wavefront's
/// stand-in for their surface terms (`+0`, without the light set's lookup), and one with `Ka`
/// the general terms: the image is the scalar integrator's, bit for bit, with the ambient
/// light positive and negative.
#[test]
fn lit_room_under_ambient_light_is_bit_identical() {
    assert_same_images(&lit_room_with(Some(0.4)), 4);
    assert_same_images(&lit_room_with(Some(-0.3)), 2);
}

/// A sphere (a quadric: not a flat world) keeps the scalar integrator.
#[test]
fn a_scene_that_does_not_qualify_takes_the_scalar_path() {
    let scene = raytracer::testing::sphere_furnace();
    let lanes = render_with(&scene, true, 2, 2);
    assert!(!lanes.stats.wavefront);
    assert!(lanes.stats.integrator_stats.iter().any(|l| l == "paths: scalar (not a flat world)"));
    let scalar = render_with(&scene, false, 2, 2);
    assert_eq!(bits(&lanes), bits(&scalar));
}

//! Numerical stability: watertight meshes, scale and translation invariance, grazing rays,
//! degenerate input.

use glam::{DMat4, DVec3, Vec3};
use raytracer::diagnostics::Diagnostics;
use raytracer::sampling::Rng;
use raytracer::testing::SceneBuilder;
use raytracer::world::{Ray, World};
use rib_parser::scene::{ParamList, PolygonMesh, Shape};
use std::path::PathBuf;
use tessellate::{Tolerance, tessellate};

/// A closed triangle mesh (a tessellated sphere and a torus) as polygon shapes.
fn closed_meshes() -> Vec<(tessellate::TriangleMesh, Shape)> {
    let shapes = [
        Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 },
        Shape::Torus {
            major_radius: 1.0,
            minor_radius: 0.4,
            phi_min_degrees: 0.0,
            phi_max_degrees: 360.0,
            theta_max_degrees: 360.0,
        },
    ];
    shapes
        .iter()
        .map(|s| {
            let mesh = tessellate(s, &Tolerance::relative(2e-3)).unwrap();
            assert!(mesh.is_closed());
            let polygons = PolygonMesh {
                loops_per_face: vec![1; mesh.indices.len()],
                vertices_per_loop: vec![3; mesh.indices.len()],
                vertex_indices: mesh.indices.iter().flatten().copied().collect(),
                positions: mesh.positions.clone(),
                primvars: ParamList::default(),
            };
            (mesh, Shape::Polygons(polygons))
        })
        .collect()
}

fn leak_rays() -> usize {
    std::env::var("RAYTRACER_LEAK_RAYS").ok().and_then(|v| v.parse().ok()).unwrap_or(1_000_000)
}

/// Rays from inside a closed mesh aimed exactly at its vertices and at points on its edges
/// must hit it: count the ones that escape, at several scales and far from the origin.
#[test]
fn closed_meshes_do_not_leak() {
    let total = leak_rays();
    let placements = [
        ("unit", DMat4::IDENTITY),
        ("scaled 1e-4", DMat4::from_scale(DVec3::splat(1e-4))),
        ("scaled 1e4", DMat4::from_scale(DVec3::splat(1e4))),
        ("translated 1e5", DMat4::from_translation(DVec3::new(1e5, -1e5, 1e5))),
        (
            "rotated and skewed",
            DMat4::from_rotation_y(0.7)
                * DMat4::from_cols_array(&[
                    1.0, 0.3, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.2, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
                ]),
        ),
    ];
    let meshes = closed_meshes();
    let per_case = total.div_ceil(placements.len() * meshes.len());
    let mut rng = Rng::new(99, 1);
    let mut leaks = 0usize;
    let mut traced = 0usize;
    for (name, m) in &placements {
        for (mesh, shape) in &meshes {
            let mut b = SceneBuilder::perspective(4, 4, 40.0, DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO);
            let a = b.matte(Vec3::ONE);
            b.shape(shape.clone(), *m, a);
            let scene = b.build();
            // The eye is the render-space origin: put it at the world origin so that points are
            // in world coordinates.
            let world = World::build(
                &scene,
                DVec3::ZERO,
                raytracer::world::PixelFootprint::Unknown,
                &mut Diagnostics::default(),
            )
            .unwrap();
            let place = |p: Vec3| m.transform_point3(p.as_dvec3());
            // Interior points: the sphere's centre region, the torus tube's centre line.
            let is_torus =
                matches!(shape, Shape::Polygons(_)) && mesh.positions.iter().any(|p| p.length() < 0.7);
            for k in 0..per_case {
                let t = mesh.indices[rng.below(mesh.indices.len() as u32) as usize];
                let (a, bb, c) = (
                    mesh.positions[t[0] as usize],
                    mesh.positions[t[1] as usize],
                    mesh.positions[t[2] as usize],
                );
                // Every other ray aims at a vertex, the rest at a point of an edge.
                let target_obj = if k % 2 == 0 { a } else { a.lerp(bb, rng.uniform()) };
                let _ = c;
                let inside_obj = if is_torus {
                    let phi = rng.uniform() * std::f32::consts::TAU;
                    Vec3::new(phi.cos(), phi.sin(), 0.0)
                        + Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 0.2
                } else {
                    Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 0.8
                };
                let origin = place(inside_obj).as_vec3();
                let target = place(target_obj).as_vec3();
                let ray = Ray::new(origin, target - origin);
                traced += 1;
                if world.intersect(&ray).is_none() {
                    leaks += 1;
                    eprintln!("{name}: leak from {origin} toward {target}");
                }
            }
        }
    }
    assert!(traced >= total);
    assert_eq!(leaks, 0, "{leaks} of {traced} rays escaped");
}

/// The reference Cornell box, with its world mapped by `scale` and then moved by `offset`: the
/// camera follows, so the image must not change and depths scale by `scale`.
fn cornell_moved(scale: f64, offset: DVec3) -> rib_parser::scene::Scene {
    let path =
        PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell/cornell.rib"));
    let mut scene = rib_parser::load_scene(&path, &rib_parser::LoadOptions::default()).unwrap().scene;
    let s = DMat4::from_translation(offset) * DMat4::from_scale(DVec3::splat(scale));
    scene.camera.camera_from_world *= s.inverse();
    for shape in &mut scene.shapes {
        shape.world_from_object = s * shape.world_from_object;
    }
    // Clipping distances are camera-space z, which this keeps unchanged (the camera transform
    // absorbs the scale), but keep the near plane out of the way at every scale.
    scene.camera.clipping.near = 1e-10;
    // A crop across the tall box's edge, the light and the wall corner.
    scene.camera.crop_window = depth_remap::CropWindow { xmin: 0.25, xmax: 0.5, ymin: 0.0, ymax: 0.25 };
    scene
}

fn render_moved(scale: f64, offset: DVec3) -> raytracer::render::RenderOutput {
    let options = raytracer::render::RenderOptions {
        spp: Some(16),
        depth: true,
        threads: Some(2),
        seed: 3,
        ..Default::default()
    };
    raytracer::render::render(&cornell_moved(scale, offset), &options).unwrap()
}

/// The same scene scaled by 1e-4 and 1e4 and translated 1e5 from the origin renders the same
/// image (within noise: paths follow the same random numbers, so nearly all are identical) and
/// the same depth (within relative 1e-5, after dividing by the scale).
#[test]
fn scale_and_translation_invariance() {
    let base = render_moved(1.0, DVec3::ZERO);
    let base_depth = base.depth.as_ref().unwrap();
    for (scale, offset) in [
        (1e-4, DVec3::ZERO),
        (1e4, DVec3::ZERO),
        (1.0, DVec3::new(1e5, -1e5, 1e5)),
        (1e-4, DVec3::new(-1e5, 0.0, 1e5)),
    ] {
        let out = render_moved(scale, offset);
        let depth = out.depth.as_ref().unwrap();
        let mut worst = 0.0f64;
        for (&a, &b) in depth.values.iter().zip(&base_depth.values) {
            assert_eq!(a.is_finite(), b.is_finite());
            if a.is_finite() {
                worst = worst.max((f64::from(a) / scale - f64::from(b)).abs() / f64::from(b));
            }
        }
        assert!(worst < 1e-5, "scale {scale} offset {offset}: depth error {worst}");
        let mut rel = 0.0f64;
        let mut n = 0.0;
        for (p, q) in out.image.pixels.iter().zip(&base.image.pixels) {
            assert!(p.iter().all(|v| v.is_finite()));
            for c in 0..3 {
                let (x, r) = (f64::from(p[c]), f64::from(q[c]));
                rel += (x - r) * (x - r) / (r * r + 0.01);
                n += 1.0;
            }
        }
        let rel = rel / n;
        // Two independent 16-spp renders differ by a relative MSE of about 2e-2; these must be
        // far closer.
        assert!(rel < 2e-3, "scale {scale} offset {offset}: image relMSE {rel}");
        eprintln!("scale {scale} offset {offset}: depth error {worst:.2e}, image relMSE {rel:.2e}");
    }
}

/// Degenerate and non-finite input never reaches the film or the depth table as NaN: zero-area
/// polygons, NaN vertices, radii and transforms, lights with NaN intensity, and camera rays that
/// graze a plane exactly.
#[test]
fn degenerate_and_non_finite_input_gives_finite_output() {
    use raytracer::render::{RenderOptions, render};
    use rib_parser::scene::LightKind;
    // The eye sits exactly in the plane y = 0 of a large square: its rays graze it.
    let mut b = SceneBuilder::perspective(24, 16, 60.0, DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO);
    b.light(
        LightKind::Point { position: DVec3::new(1.0, 2.0, 3.0), intensity: f32::NAN, color: Vec3::ONE },
        "pointlight",
    );
    b.light(
        LightKind::Point { position: DVec3::new(1.0, 2.0, 3.0), intensity: 10.0, color: Vec3::ONE },
        "pointlight",
    );
    let a = b.matte(Vec3::splat(0.5));
    b.light_everything();
    b.polygon(
        &[
            Vec3::new(-9.0, 0.0, -9.0),
            Vec3::new(9.0, 0.0, -9.0),
            Vec3::new(9.0, 0.0, 9.0),
            Vec3::new(-9.0, 0.0, 9.0),
        ],
        a,
    );
    // Zero area: collinear and repeated vertices.
    b.polygon(&[Vec3::ZERO, Vec3::X, Vec3::X * 2.0], a);
    b.polygon(&[Vec3::ONE, Vec3::ONE, Vec3::ONE], a);
    // NaN vertex, NaN radius, NaN transform, zero scale.
    b.polygon(&[Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Y, Vec3::Z], a);
    b.shape(
        Shape::Sphere { radius: f32::NAN, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 },
        DMat4::IDENTITY,
        a,
    );
    b.shape(
        Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 },
        DMat4::from_translation(DVec3::new(f64::NAN, 0.0, 0.0)),
        a,
    );
    b.shape(
        Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 },
        DMat4::from_scale(DVec3::ZERO),
        a,
    );
    // A torus seen exactly edge-on through its hole's rim.
    b.shape(
        Shape::Torus {
            major_radius: 1.0,
            minor_radius: 0.3,
            phi_min_degrees: 0.0,
            phi_max_degrees: 360.0,
            theta_max_degrees: 360.0,
        },
        DMat4::from_rotation_x(std::f64::consts::FRAC_PI_2)
            * DMat4::from_translation(DVec3::new(0.0, 0.0, 0.0)),
        a,
    );
    let scene = b.build();
    for integrator in [
        raytracer::integrators::IntegratorKind::DirectLighting { max_depth: 5 },
        raytracer::integrators::IntegratorKind::Path { max_depth: 64, rr_depth: 5 },
    ] {
        let out = render(
            &scene,
            &RenderOptions { spp: Some(4), depth: true, integrator: Some(integrator), ..Default::default() },
        )
        .unwrap();
        assert!(out.image.pixels.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        assert!(out.depth.unwrap().values.iter().all(|v| *v >= 0.0));
        assert!(!out.warnings.is_empty());
    }
}

/// Geometry reaching far past the BVH's coordinate range (a polygon corner at 1e30, as a typo
/// or a hostile file gives) used to panic in the BVH build or take minutes in it. The far
/// triangles are left out with a warning at the shape; the rest renders as before, promptly.
#[test]
fn geometry_far_beyond_the_bvh_range_is_left_out_with_a_warning() {
    use raytracer::render::{RenderOptions, render};
    use rib_parser::scene::LightKind;
    // A lit floor, with the far triangles below added or not.
    let floor_scene = || {
        let mut b = SceneBuilder::perspective(24, 16, 60.0, DVec3::new(0.0, 1.0, 5.0), DVec3::ZERO);
        b.light(
            LightKind::Point { position: DVec3::new(1.0, 3.0, 3.0), intensity: 10.0, color: Vec3::ONE },
            "pointlight",
        );
        let a = b.matte(Vec3::splat(0.5));
        b.light_everything();
        b.polygon(
            &[
                Vec3::new(-2.0, 0.0, -2.0),
                Vec3::new(2.0, 0.0, -2.0),
                Vec3::new(2.0, 0.0, 2.0),
                Vec3::new(-2.0, 0.0, 2.0),
            ],
            a,
        );
        (b, a)
    };
    let reference =
        render(&floor_scene().0.build(), &RenderOptions { spp: Some(4), ..Default::default() }).unwrap();

    let (mut b, a) = floor_scene();
    // Many triangles reaching to 1e30 (their boxes used to make PLOC quadratic) and one that
    // spans the whole range: left out, so the image is the floor's alone.
    for i in 0..2000 {
        let x = i as f32;
        b.polygon(&[Vec3::new(x, -1e30, -3.0), Vec3::new(x + 0.5, -1e30, -3.0), Vec3::new(x, 1e30, -3.5)], a);
    }
    b.polygon(&[Vec3::new(-1e30, -5.0, -1e30), Vec3::new(1e30, -5.0, -1e30), Vec3::new(0.0, -5.0, 1e30)], a);
    let out = render(&b.build(), &RenderOptions { spp: Some(4), ..Default::default() }).unwrap();
    assert_eq!(out.image.pixels, reference.image.pixels);
    assert!(
        out.warnings.iter().any(|w| w.message.contains("left out")),
        "no warning about the far triangles: {:?}",
        out.warnings
    );
}

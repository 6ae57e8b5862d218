use super::polygon::{CUBE_FACES, CUBE_POSITIONS, points_polygons};
use super::{assert_normals_follow_winding, assert_well_formed, max_deviation};
use crate::placed::{largest_stretch, spectral_norm};
use crate::{
    MeshOrigin, TessellateError, Tolerance, is_quadric, tessellate, tessellate_placed, tessellate_scene,
    tessellate_scene_filtered,
};
use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};
use rib_parser::scene::{
    AttributeCall, Attributes, AttributesId, FileLoc, Handle, ObjectDefinition, ObjectId,
    ObjectInstanceEntity, ParamList, Points, Scene, Shape, ShapeEntity,
};
use std::sync::Arc;

fn unit_sphere() -> Shape {
    Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 }
}

/// Every normal points away from `centre` and every triangle faces outward.
fn assert_outward(mesh: &crate::TriangleMesh, centre: DVec3) {
    let normals = mesh.normals.as_ref().unwrap();
    for (p, n) in mesh.positions.iter().zip(normals) {
        assert!(n.as_dvec3().dot(p.as_dvec3() - centre) > 0.0, "normal {n} at {p}");
    }
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t).map(|p| p.as_dvec3());
        assert!(mesh.face_cross(t).dot((a + b + c) / 3.0 - centre) > 0.0);
    }
}

#[test]
fn a_mirror_transform_keeps_a_sphere_outward() {
    let tol = Tolerance::absolute(1e-2);
    let centre = DVec3::new(3.0, -1.0, 2.0);
    for mirror in [
        DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0)),
        DMat4::from_scale(DVec3::new(2.0, -3.0, 0.5)),
        DMat4::from_scale(DVec3::splat(-1.0)) * DMat4::from_rotation_x(0.7),
    ] {
        let m = DMat4::from_translation(centre) * mirror;
        let mesh = tessellate_placed(&unit_sphere(), &m, false, &tol).unwrap();
        assert_well_formed(&mesh);
        assert!(mesh.is_closed());
        assert_normals_follow_winding(&mesh, 1e-3);
        assert_outward(&mesh, centre);
        assert!(mesh.signed_volume() > 0.0);
    }
}

#[test]
fn reverse_orientation_flips_normals_and_winding_together() {
    let tol = Tolerance::absolute(1e-2);
    for m in [DMat4::IDENTITY, DMat4::from_scale(DVec3::new(1.0, -1.0, 1.0))] {
        let mesh = tessellate_placed(&unit_sphere(), &m, true, &tol).unwrap();
        assert_normals_follow_winding(&mesh, 1e-3);
        let normals = mesh.normals.as_ref().unwrap();
        for (p, n) in mesh.positions.iter().zip(normals) {
            assert!(n.dot(*p) < 0.0);
        }
        assert!(mesh.signed_volume() < 0.0);
    }
}

#[test]
fn polygons_follow_the_same_rules() {
    let cube = Shape::Polygons(points_polygons(&CUBE_POSITIONS, &CUBE_FACES));
    let tol = Tolerance::default();
    let mirrored =
        tessellate_placed(&cube, &DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0)), false, &tol).unwrap();
    assert!(mirrored.is_closed());
    assert!((mirrored.signed_volume() - 1.0).abs() < 1e-9, "still outward: {}", mirrored.signed_volume());
    let reversed = tessellate_placed(&cube, &DMat4::IDENTITY, true, &tol).unwrap();
    assert!((reversed.signed_volume() + 1.0).abs() < 1e-9);
}

#[test]
fn the_absolute_tolerance_is_in_world_units() {
    // A unit sphere scaled by 10 (and squashed in z) must stay within 1e-3 world units.
    let scale = DVec3::new(10.0, 10.0, 2.0);
    let m =
        DMat4::from_scale_rotation_translation(scale, DQuat::from_rotation_y(0.3), DVec3::new(1e3, 0.0, 0.0));
    let eps = 1e-3;
    let mesh = tessellate_placed(&unit_sphere(), &m, false, &Tolerance::absolute(eps)).unwrap();
    let inverse = m.inverse();
    // Distance to the ellipsoid, to first order: |F| / |grad F| with F(q) = |S^-1 q|^2 - 1 in
    // the ellipsoid's own frame.
    let distance = |p: DVec3| {
        let q = inverse.transform_point3(p);
        let f = q.length_squared() - 1.0;
        let rot = DMat3::from_quat(DQuat::from_rotation_y(0.3));
        let grad_local = 2.0 * q / scale;
        (f.abs()) / (rot * grad_local).length()
    };
    let (on, inside) = max_deviation(&mesh, distance);
    assert!(on < 1e-3 * 0.05, "f32 positions far from the origin: {on}");
    assert!(inside <= eps * 1.05, "{inside}");
    // ... while the object-space tessellation at the same number is far coarser.
    let coarse = tessellate(&unit_sphere(), &Tolerance::absolute(eps)).unwrap();
    assert!(mesh.triangle_count() > 5 * coarse.triangle_count());
}

#[test]
fn spectral_norm_is_the_largest_stretch() {
    let m = DMat3::from_quat(DQuat::from_rotation_z(0.4)) * DMat3::from_diagonal(DVec3::new(3.0, -7.0, 2.0));
    assert!((spectral_norm(&m) - 7.0).abs() < 1e-9);
    let shear = DMat3::from_cols(DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Z);
    // Singular values of [[1, 1], [0, 1]]: the golden ratio and its inverse.
    assert!((spectral_norm(&shear) - (1.0 + 5f64.sqrt()) / 2.0).abs() < 1e-9);
    assert_eq!(spectral_norm(&DMat3::ZERO), 0.0);
}

#[test]
fn singular_and_projective_transforms_do_not_break() {
    let flat = DMat4::from_scale(DVec3::new(1.0, 1.0, 0.0));
    let mesh = tessellate_placed(&unit_sphere(), &flat, false, &Tolerance::absolute(1e-2)).unwrap();
    assert!(mesh.normals.is_none());
    assert!(mesh.positions.iter().all(|p| p.z == 0.0));
    // A perspective divide in the object transform.
    let mut persp = DMat4::from_translation(DVec3::new(0.0, 0.0, 5.0));
    persp.w_axis.w = 1.0;
    persp.z_axis.w = 0.1;
    let mesh = tessellate_placed(&unit_sphere(), &persp, false, &Tolerance::absolute(1e-2)).unwrap();
    assert_well_formed(&mesh);
    assert_normals_follow_winding(&mesh, 0.2);
    let bad = DMat4::from_scale(DVec3::new(f64::NAN, 1.0, 1.0));
    assert!(matches!(
        tessellate_placed(&unit_sphere(), &bad, false, &Tolerance::default()),
        Err(TessellateError::NonFinite { .. })
    ));
}

#[test]
fn the_stretch_bound_holds_the_jacobian_of_a_perspective() {
    // `Perspective 90` then `Translate 0 0 1.5` (the unit sphere spans z in [0.5, 2.5] there).
    let persp = DMat4::from_cols_array(&[
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, -1.0, 0.0,
    ]) * DMat4::from_translation(DVec3::new(0.0, 0.0, 1.5));
    let bound = largest_stretch(&persp, &unit_sphere());
    // The Jacobian by central differences at points of the sphere's box.
    let mut largest = 0f64;
    for i in 0..=10 {
        for j in 0..=10 {
            for k in 0..=10 {
                let p = DVec3::new(i as f64 / 5.0 - 1.0, j as f64 / 5.0 - 1.0, k as f64 / 5.0 - 1.0);
                let h = 1e-6;
                let column = |e: DVec3| {
                    (persp.project_point3(p + e * h) - persp.project_point3(p - e * h)) / (2.0 * h)
                };
                let jacobian = DMat3::from_cols(column(DVec3::X), column(DVec3::Y), column(DVec3::Z));
                largest = largest.max(spectral_norm(&jacobian));
            }
        }
    }
    // At (1, 1, -1) (z = 0.5) the Jacobian stretches by about 7; the bound (8) is not much looser.
    assert!(largest <= bound * (1.0 + 1e-6), "Jacobian {largest} over the bound {bound}");
    assert!(bound < 2.0 * largest, "bound {bound} for a largest stretch of {largest}");
    // The linear part alone (stretch 1) would have tessellated 7 times too coarsely.
    assert!(largest > 6.0, "{largest}");
    // An affine transform keeps the spectral norm.
    let affine = DMat4::from_scale(DVec3::new(2.0, 3.0, 0.5));
    assert_eq!(largest_stretch(&affine, &unit_sphere()), 3.0);
}

fn entity(shape: Shape, m: DMat4, attributes: u32) -> ShapeEntity {
    ShapeEntity {
        shape: Arc::new(shape),
        world_from_object: m,
        motion: None,
        deformation: None,
        attributes: AttributesId(attributes),
        in_solid: false,
        loc: FileLoc::new("scene.rib", 10 + attributes, 1),
    }
}

fn test_scene() -> Scene {
    let reversed = Attributes { reverse_orientation: true, ..Default::default() };
    let trim_outside = Attributes {
        user: vec![AttributeCall {
            namespace: "trimcurve".into(),
            params: ParamList(vec![rib_parser::scene::Param {
                name: "sense".into(),
                decl: rib_parser::scene::ParamDecl {
                    class: rib_parser::scene::StorageClass::Uniform,
                    ty: rib_parser::scene::ParamType::String,
                    array_len: 1,
                },
                values: rib_parser::scene::ParamValues::Strings(vec!["outside".into()]),
                loc: FileLoc::new("scene.rib", 3, 1),
            }]),
            loc: FileLoc::new("scene.rib", 3, 1),
        }],
        ..Default::default()
    };
    Scene {
        source: "scene.rib".into(),
        frame: None,
        camera: Default::default(),
        render: Default::default(),
        displays: Vec::new(),
        depth_request: None,
        options: Vec::new(),
        lights: Vec::new(),
        attributes: vec![Attributes::default(), reversed, trim_outside],
        shapes: vec![
            entity(unit_sphere(), DMat4::from_translation(DVec3::X * 5.0), 0),
            // A Blobby plane needs a depth map: skipped with the reason.
            entity(
                Shape::Blobby(rib_parser::scene::Blobby {
                    leaf_count: 1,
                    code: vec![1003, 0, 0],
                    floats: vec![0.0; 4],
                    strings: vec!["flat.zfile".into()],
                    primvars: ParamList::default(),
                }),
                DMat4::IDENTITY,
                0,
            ),
            entity(Shape::Polygons(points_polygons(&CUBE_POSITIONS, &CUBE_FACES)), DMat4::IDENTITY, 1),
        ],
        objects: vec![ObjectDefinition {
            handle: Handle::Int(1),
            shapes: vec![entity(unit_sphere(), DMat4::from_translation(DVec3::Y), 0)],
            loc: FileLoc::new("scene.rib", 20, 1),
        }],
        instances: vec![
            ObjectInstanceEntity {
                object: ObjectId(0),
                world_from_instance: DMat4::from_translation(DVec3::Z * 10.0),
                motion: None,
                attributes: AttributesId(0),
                shape_attributes: vec![AttributesId(0)],
                loc: FileLoc::new("scene.rib", 30, 1),
            },
            ObjectInstanceEntity {
                object: ObjectId(0),
                world_from_instance: DMat4::from_scale(DVec3::new(-2.0, 2.0, 2.0)),
                motion: None,
                attributes: AttributesId(1),
                shape_attributes: vec![AttributesId(1)],
                loc: FileLoc::new("scene.rib", 31, 1),
            },
            // A dangling object id is skipped, not a panic.
            ObjectInstanceEntity {
                object: ObjectId(7),
                world_from_instance: DMat4::IDENTITY,
                motion: None,
                attributes: AttributesId(0),
                shape_attributes: vec![AttributesId(0)],
                loc: FileLoc::new("scene.rib", 32, 1),
            },
        ],
        coordinate_systems: Vec::new(),
        solids: Vec::new(),
    }
}

#[test]
fn the_scene_walk_places_shapes_and_instances() {
    let scene = test_scene();
    let out = tessellate_scene(&scene, &Tolerance::absolute(1e-2));
    assert_eq!(out.meshes.len(), 4);
    assert_eq!(out.skipped.len(), 1);
    assert!(matches!(out.skipped[0].error, TessellateError::InvalidShape { kind: "Blobby", .. }));
    assert_eq!(out.skipped[0].origin, MeshOrigin::Shape { index: 1 });
    assert_eq!(out.skipped[0].loc.line, 10);

    let sphere = &out.meshes[0];
    assert_eq!(sphere.origin, MeshOrigin::Shape { index: 0 });
    let (lo, hi) = sphere.mesh.bounds().unwrap();
    assert!((((lo + hi) / 2.0) - Vec3::X * 5.0).length() < 1e-2);
    assert_outward(&sphere.mesh, DVec3::X * 5.0);

    let cube = &out.meshes[1];
    assert!(cube.reverse_orientation);
    assert!(cube.mesh.signed_volume() < 0.0);

    let first = &out.meshes[2];
    assert_eq!(first.origin, MeshOrigin::Instance { instance: 0, object: ObjectId(0), shape: 0 });
    assert_eq!(first.instance_attributes, Some(AttributesId(0)));
    assert_outward(&first.mesh, DVec3::new(0.0, 1.0, 10.0));

    // The second instance mirrors x and its attributes say ReverseOrientation.
    let second = &out.meshes[3];
    assert!(second.reverse_orientation);
    assert!(second.mesh.signed_volume() < 0.0);
    assert_normals_follow_winding(&second.mesh, 1e-3);
    let (lo, hi) = second.mesh.bounds().unwrap();
    assert!((((lo + hi) / 2.0).as_dvec3() - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-2);
    // Each side may fall short by the tolerance.
    assert!((hi.x - lo.x - 4.0).abs() <= 2e-2);

    assert_eq!(out.triangle_count(), out.meshes.iter().map(|m| m.mesh.triangle_count() as u64).sum::<u64>());

    let no_quadrics = tessellate_scene_filtered(&scene, &Tolerance::absolute(1e-2), |s| !is_quadric(s));
    assert_eq!(no_quadrics.meshes.len(), 1);
}

#[test]
fn the_scene_budget_skips_shapes_past_it() {
    let scene = test_scene();
    let mut tol = Tolerance::absolute(1e-3);
    let one_sphere = tessellate(&unit_sphere(), &tol).unwrap().triangle_count() as u64;
    // Room for one sphere (its estimate is a little above its count), the cube, and less than
    // another sphere.
    tol.max_scene_triangles = one_sphere + 12 + one_sphere / 10;
    let out = tessellate_scene(&scene, &tol);
    assert_eq!(out.meshes.len(), 2, "the first sphere and the cube fit: {:?}", out.skipped);
    assert_eq!(out.triangle_count(), one_sphere + 12);
    let over =
        out.skipped.iter().filter(|s| matches!(s.error, TessellateError::TooManyTriangles { .. })).count();
    assert_eq!(over, 2);
}

#[test]
fn scene_bounds_cover_shapes_and_instances() {
    let scene = test_scene();
    let (lo, hi) = crate::scene_bounds(&scene).unwrap();
    assert!((lo - DVec3::new(-2.0, -1.0, -2.0)).length() < 1e-9, "{lo}");
    assert!((hi - DVec3::new(6.0, 4.0, 11.0)).length() < 1e-9, "{hi}");
    // Every tessellated vertex lies inside.
    for m in tessellate_scene(&scene, &Tolerance::absolute(1e-2)).meshes {
        for p in &m.mesh.positions {
            let p = p.as_dvec3();
            assert!(p.cmpge(lo - 1e-5).all() && p.cmple(hi + 1e-5).all(), "{p}");
        }
    }
    assert!(
        crate::shape_bounds(&Shape::Points(Points { positions: vec![], primvars: ParamList::default() }))
            .is_none()
    );
    // A NaN radius has no bounds (it used to panic in clamp).
    let nan = Shape::Sphere { radius: f32::NAN, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 };
    assert!(crate::shape_bounds(&nan).is_none());
}

#[test]
fn the_seam_welder_snaps_boundary_vertices_within_its_radius_only() {
    use crate::{SeamWelder, TriangleMesh};
    let square = |x0: f32, offset: f32| TriangleMesh {
        positions: vec![
            Vec3::new(x0, 0.0, 0.0),
            Vec3::new(x0 + 1.0, offset, 0.0),
            Vec3::new(x0 + 1.0, 1.0 + offset, 0.0),
            Vec3::new(x0, 1.0, 0.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        face_index: vec![0, 0],
        ..TriangleMesh::default()
    };
    let mut seams = SeamWelder::new(DVec3::ZERO, DVec3::new(2.0, 1.0, 0.0));
    let mut left = square(0.0, 0.0);
    assert_eq!(seams.weld(&mut left), 0);
    // The right square's left side is a rounding error away from the left square's right side.
    let ulp = f32::EPSILON;
    let mut right = square(1.0 + ulp, 0.0);
    assert_eq!(seams.weld(&mut right), 2);
    assert_eq!((right.positions[0], right.positions[3]), (left.positions[1], left.positions[2]));
    // Far beyond the radius nothing moves.
    let mut apart = square(1.0 + 1e-3, 0.0);
    assert_eq!(seams.weld(&mut apart), 0);
    assert_eq!(apart.positions[0].x, 1.0 + 1e-3);
}

//! Scene-building semantics: the reference Cornell box, transforms, orientation, lights,
//! instances, frames.

use glam::{DMat4, DVec3, DVec4, Vec3};
use rib_parser::scene::*;
use rib_parser::{LoadOptions, load_bytes};

fn load(rib: &str) -> rib_parser::Loaded {
    load_bytes("test.rib", rib.as_bytes().to_vec(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

fn load_err(rib: &str) -> String {
    match load_bytes("test.rib", rib.as_bytes().to_vec(), &LoadOptions::default()) {
        Ok(_) => panic!("expected an error for:\n{rib}"),
        Err(e) => e.render(),
    }
}

const SHARED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared");

/// The geometric normal a consumer computes: `world_from_object^-T * n_object`, flipped iff
/// `reverse_orientation`.
fn world_normal(scene: &Scene, shape: &ShapeEntity, n_object: DVec3) -> DVec3 {
    let m = shape.world_from_object.inverse().transpose();
    let n = m.transform_vector3(n_object).normalize();
    if scene.attributes_of(shape.attributes).reverse_orientation { -n } else { n }
}

fn polygon_normal(mesh: &PolygonMesh) -> DVec3 {
    let p = |i: usize| mesh.positions[i].as_dvec3();
    (p(1) - p(0)).cross(p(2) - p(0))
}

#[test]
fn cornell_box_reference_scene() {
    let path = std::path::Path::new(SHARED).join("reference/cornell/cornell.rib");
    let loaded =
        rib_parser::load_scene(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{}", e.render()));
    let s = &loaded.scene;
    assert_eq!(loaded.diagnostics.warning_count(), 0, "{}", loaded.render_warnings());
    assert_eq!((s.camera.x_resolution, s.camera.y_resolution), (512, 512));
    assert_eq!(s.camera.projection, depth_remap::Projection::Perspective { fov_degrees: 39.3077 });
    assert_eq!((s.camera.clipping.near, s.camera.clipping.far), (0.001, 100.0));
    // world -> camera: P_cam = (x, y, 3.9 - z).
    let p = s.camera.camera_from_world.transform_point3(DVec3::new(0.25, -0.5, 1.0));
    assert!((p - DVec3::new(0.25, -0.5, 2.9)).length() < 1e-12, "{p}");
    depth_remap::Camera::new(s.camera.clone()).expect("a valid camera");
    let depth = s.depth_request.as_ref().expect("a depth request");
    assert_eq!(depth.path, std::path::PathBuf::from("cornell.depth"));
    assert_eq!(depth.source, DepthRequestSource::Option);
    assert_eq!(s.render.pixel_filter, PixelFilter { name: "box".into(), x_width: 1.0, y_width: 1.0 });
    assert_eq!(s.render.pixel_samples, (16.0, 16.0));
    assert_eq!(s.render.quantize.one, 0);
    assert_eq!(s.displays.len(), 1);
    assert_eq!(s.shapes.len(), 18);
    // The area light and its emitting quad.
    assert_eq!(s.lights.len(), 1);
    assert_eq!(
        s.lights[0].kind,
        LightKind::Area { intensity: 1.0, color: Vec3::new(18.387, 13.9873, 6.75357) }
    );
    let light_quad = &s.shapes[0];
    let a = s.attributes_of(light_quad.attributes);
    assert_eq!(a.area_light, Some(LightId(0)));
    assert_eq!(a.name.as_deref(), Some("light"));
    assert_eq!(a.surface.as_ref().map(|c| c.name.as_str()), Some("matte"));
    // Normals as the file's comments state them: no automatic flip (CONTRACTS.md §3).
    let expected: [(usize, DVec3); 6] = [
        (0, DVec3::NEG_Y),
        (1, DVec3::Y),
        (2, DVec3::NEG_Y),
        (3, DVec3::Z),
        (4, DVec3::NEG_X),
        (5, DVec3::X),
    ];
    for (i, n) in expected {
        let sh = &s.shapes[i];
        let Shape::Polygons(m) = &*sh.shape else { panic!() };
        let got = world_normal(s, sh, polygon_normal(m));
        assert!((got - n).length() < 1e-6, "shape {i}: {got} != {n}");
    }
    // Shapes after the light's block are not emitters but are lit by it.
    let floor = s.attributes_of(s.shapes[1].attributes);
    assert_eq!(floor.area_light, None);
    assert_eq!(floor.illuminated_by, Vec::<LightId>::new());
    assert_eq!(floor.color, Vec3::new(0.885809, 0.698859, 0.666422));
}

#[test]
fn transforms_compose_last_given_first_applied() {
    let s = load("WorldBegin Translate 1 0 0 Rotate 90 0 0 1 Scale 2 2 2 Sphere 1 -1 1 360 WorldEnd").scene;
    let p = s.shapes[0].world_from_object.transform_point3(DVec3::new(1.0, 0.0, 0.0));
    // Scale to (2,0,0), rotate (right hand about z) to (0,2,0), translate to (1,2,0).
    assert!((p - DVec3::new(1.0, 2.0, 0.0)).length() < 1e-12, "{p}");
}

#[test]
fn concat_transform_takes_row_vector_layout() {
    let s =
        load("WorldBegin ConcatTransform [1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1] Sphere 1 -1 1 360 WorldEnd")
            .scene;
    assert_eq!(s.shapes[0].world_from_object.w_axis, DVec4::new(5.0, 6.0, 7.0, 1.0));
    let s = load(
        "WorldBegin Transform [2 0 0 0 0 2 0 0 0 0 2 0 1 1 1 1] Translate 1 0 0 Sphere 1 -1 1 360 WorldEnd",
    )
    .scene;
    let p = s.shapes[0].world_from_object.transform_point3(DVec3::ZERO);
    assert_eq!(p, DVec3::new(3.0, 1.0, 1.0));
}

#[test]
fn orientation_rules() {
    // Camera space is left-handed; a mirror in the camera transform flips handedness and the
    // current orientation together: no flip.
    let s = load("Scale 1 1 -1 WorldBegin Polygon \"P\" [0 0 0 1 0 0 0 1 0] WorldEnd").scene;
    assert!(!s.attributes_of(s.shapes[0].attributes).reverse_orientation);
    // Orientation "lh" in a right-handed world (after the mirror) differs: flip.
    let s =
        load("Scale 1 1 -1 WorldBegin Orientation \"lh\" Polygon \"P\" [0 0 0 1 0 0 0 1 0] WorldEnd").scene;
    assert!(s.attributes_of(s.shapes[0].attributes).reverse_orientation);
    // ... and "rh" matches it.
    let s =
        load("Scale 1 1 -1 WorldBegin Orientation \"rh\" Polygon \"P\" [0 0 0 1 0 0 0 1 0] WorldEnd").scene;
    assert!(!s.attributes_of(s.shapes[0].attributes).reverse_orientation);
    // "lh" set in the left-handed camera space, then a mirror: both flip, no reversal.
    let s =
        load("Orientation \"lh\" Scale 1 1 -1 WorldBegin Polygon \"P\" [0 0 0 1 0 0 0 1 0] WorldEnd").scene;
    assert!(!s.attributes_of(s.shapes[0].attributes).reverse_orientation);
    // ReverseOrientation toggles; "inside" and "outside" are relative to the coordinate system.
    let s = load(
        "WorldBegin ReverseOrientation Sphere 1 -1 1 360 ReverseOrientation Sphere 1 -1 1 360 \
         Orientation \"inside\" Sphere 1 -1 1 360 Scale -1 1 1 Sphere 1 -1 1 360 Orientation \"outside\" Sphere 1 -1 1 360 WorldEnd",
    )
    .scene;
    let r: Vec<bool> = s.shapes.iter().map(|sh| s.attributes_of(sh.attributes).reverse_orientation).collect();
    assert_eq!(r, [true, false, true, true, false]);
    // AttributeEnd restores the orientation.
    let s =
        load("WorldBegin AttributeBegin ReverseOrientation AttributeEnd Sphere 1 -1 1 360 WorldEnd").scene;
    assert!(!s.attributes_of(s.shapes[0].attributes).reverse_orientation);
}

#[test]
fn mirrored_object_keeps_its_polygon_side() {
    // A polygon whose normal is +z in object space, placed with a mirror in x: the consumer's
    // normal (inverse transpose) still points +z in world space, and no flip is requested.
    let s = load("WorldBegin Scale -1 1 1 Polygon \"P\" [0 0 0 1 0 0 0 1 0] WorldEnd").scene;
    let Shape::Polygons(m) = &*s.shapes[0].shape else { panic!() };
    let n = world_normal(&s, &s.shapes[0], polygon_normal(m));
    assert!((n - DVec3::Z).length() < 1e-12, "{n}");
}

#[test]
fn standard_lights_resolve_to_world_space_with_defaults() {
    let s = load(
        "WorldBegin Translate 0 0 5 \
         LightSource \"ambientlight\" 1 \"intensity\" 0.1 \
         LightSource \"pointlight\" 2 \"from\" [1 0 0] \
         LightSource \"distantlight\" \"sun\" \"from\" [0 0 0] \"to\" [0 -2 0] \
         LightSource \"spotlight\" 4 \"coneangle\" [0.5] \
         WorldEnd",
    )
    .scene;
    assert_eq!(s.lights[0].kind, LightKind::Ambient { intensity: 0.1, color: Vec3::ONE });
    assert_eq!(
        s.lights[1].kind,
        LightKind::Point { position: DVec3::new(1.0, 0.0, 5.0), intensity: 1.0, color: Vec3::ONE }
    );
    assert_eq!(s.lights[2].handle, Handle::Name("sun".into()));
    assert_eq!(
        s.lights[2].kind,
        LightKind::Distant { direction: DVec3::NEG_Y, intensity: 1.0, color: Vec3::ONE }
    );
    let LightKind::Spot { position, direction, cone_angle, cone_delta_angle, beam_distribution, .. } =
        s.lights[3].kind
    else {
        panic!()
    };
    assert_eq!((position, direction), (DVec3::new(0.0, 0.0, 5.0), DVec3::Z));
    assert_eq!((cone_angle, cone_delta_angle, beam_distribution), (0.5, 5f32.to_radians(), 2.0));
}

#[test]
fn light_lists_follow_attribute_blocks_and_illuminate() {
    let s = load(
        "WorldBegin LightSource \"pointlight\" 1 \
         AttributeBegin LightSource \"pointlight\" 2 Sphere 1 -1 1 360 AttributeEnd \
         Sphere 1 -1 1 360 \
         Illuminate 2 1 Illuminate 1 0 Sphere 1 -1 1 360 WorldEnd",
    )
    .scene;
    let lights = |i: usize| s.attributes_of(s.shapes[i].attributes).illuminated_by.clone();
    assert_eq!(lights(0), vec![LightId(0), LightId(1)]);
    assert_eq!(lights(1), vec![LightId(0)]);
    assert_eq!(lights(2), vec![LightId(1)]);
}

#[test]
fn lights_before_world_begin_are_placed_in_world_space() {
    let s = load("LightSource \"pointlight\" 1 Translate 0 0 5 WorldBegin Sphere 1 -1 1 360 WorldEnd").scene;
    // The light sits at the camera-space origin: the camera position in world space.
    let LightKind::Point { position, .. } = s.lights[0].kind else { panic!() };
    assert!((position - DVec3::new(0.0, 0.0, -5.0)).length() < 1e-12, "{position}");
}

#[test]
fn object_instances_inherit_the_instance_state() {
    let s = load(
        "WorldBegin \
         ObjectBegin 1 Color [1 0 0] Sphere 1 -1 1 360 ObjectEnd \
         ObjectBegin \"plain\" Translate 0 0 1 Disk 0 1 360 ObjectEnd \
         Surface \"plastic\" Translate 3 0 0 ObjectInstance 1 ObjectInstance \"plain\" WorldEnd",
    )
    .scene;
    assert_eq!(s.objects.len(), 2);
    assert_eq!(s.instances.len(), 2);
    let i0 = &s.instances[0];
    let a = s.attributes_of(i0.shape_attributes[0]);
    assert_eq!(a.color, Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(a.surface.as_ref().unwrap().name, "plastic");
    let i1 = &s.instances[1];
    let a = s.attributes_of(i1.shape_attributes[0]);
    assert_eq!(a.color, Vec3::ONE);
    let disk = &s.objects[i1.object.0 as usize].shapes[0];
    let p = (i1.world_from_instance * disk.world_from_object).transform_point3(DVec3::ZERO);
    assert_eq!(p, DVec3::new(3.0, 0.0, 1.0));
    assert!(load_err("WorldBegin ObjectInstance 7 WorldEnd").contains("no object with handle 7"));
}

#[test]
fn frames_are_listed_and_selectable() {
    let rib = "FrameBegin 1 Format 10 10 1 WorldBegin Sphere 1 -1 1 360 WorldEnd FrameEnd \
               FrameBegin 2 WorldBegin Cone 1 1 360 WorldEnd FrameEnd";
    let l = load(rib);
    assert_eq!(l.frames.iter().map(|f| f.number).collect::<Vec<_>>(), [1, 2]);
    assert_eq!(l.scene.frame, Some(1));
    assert_eq!(l.scene.camera.x_resolution, 10);
    let opts = LoadOptions { frame: Some(2), ..Default::default() };
    let l2 = load_bytes("t.rib", rib.as_bytes().to_vec(), &opts).unwrap();
    assert_eq!(l2.scene.frame, Some(2));
    // FrameEnd restored the options of frame 1.
    assert_eq!(l2.scene.camera.x_resolution, 640);
    assert!(matches!(*l2.scene.shapes[0].shape, Shape::Cone { .. }));
    let opts = LoadOptions { frame: Some(9), ..Default::default() };
    let e = load_bytes("t.rib", rib.as_bytes().to_vec(), &opts).unwrap_err().render();
    assert!(e.contains("frame 9 not found or has no world (frames in the file: 1, 2)"), "{e}");
}

#[test]
fn depth_of_field_is_kept_and_checked() {
    let s = load("DepthOfField 2.8 0.05 3 WorldBegin WorldEnd").scene;
    let d = s.render.depth_of_field.unwrap();
    assert_eq!((d.fstop, d.focal_length, d.focal_distance), (2.8, 0.05, 3.0));
    assert!((d.lens_radius() - 0.05 / 5.6).abs() < 1e-9);
    // RI_INFINITY as the f-stop and the bare request are pinholes.
    assert!(load("DepthOfField 1e38 0.05 3 WorldBegin WorldEnd").scene.render.depth_of_field.is_none());
    assert!(
        load("DepthOfField 2 1 3 DepthOfField WorldBegin WorldEnd").scene.render.depth_of_field.is_none()
    );
    let e = load_err("DepthOfField 0 0.05 3 WorldBegin WorldEnd");
    assert!(e.contains("test.rib:1:1: error:") && e.contains("DepthOfField"), "{e}");
}

#[test]
fn depth_requests() {
    let s = load("Option \"lrt\" \"depthfile\" [\"a.depth\"] WorldBegin WorldEnd").scene;
    assert_eq!(s.depth_request.unwrap().path, std::path::PathBuf::from("a.depth"));
    let s = load(
        "Display \"x.tif\" \"tiff\" \"rgb\" Display \"+z.depth\" \"depthtable\" \"z\" WorldBegin WorldEnd",
    )
    .scene;
    let d = s.depth_request.unwrap();
    assert_eq!((d.path, d.source), (std::path::PathBuf::from("z.depth"), DepthRequestSource::Display));
    assert_eq!(s.displays.len(), 2);
    assert!(s.displays[1].secondary);
    let s = load("WorldBegin WorldEnd").scene;
    assert!(s.depth_request.is_none());
}

#[test]
fn perspective_camera_rules() {
    let s = load("Format 200 100 1 Projection \"perspective\" WorldBegin WorldEnd").scene;
    assert_eq!(s.camera.projection, depth_remap::Projection::Perspective { fov_degrees: 90.0 });
    let cam = depth_remap::Camera::new(s.camera).unwrap();
    assert_eq!(cam.frame_aspect_ratio(), 2.0);
    let e = load_err("Projection \"perspective\" \"fov\" [180] WorldBegin WorldEnd");
    assert!(
        e.contains("test.rib:1:1: error: Projection \"perspective\": fov 180 must be in (0, 180) degrees"),
        "{e}"
    );
    let e = load_err("Scale 0 1 1 WorldBegin WorldEnd");
    assert!(
        e.contains("test.rib:1:13: error: the camera is invalid: the camera transform is singular"),
        "{e}"
    );
}

#[test]
fn perspective_request_matches_prman() {
    let l = load("WorldBegin Perspective 90 Sphere 1 -1 1 360 WorldEnd");
    // Every consumer places shapes through a projective transformation: nothing to warn about.
    assert_eq!(l.render_warnings(), "");
    // tan(45 deg) = 1: (x, y, z) -> (x/z, y/z, 1 - 1/z).
    let p = l.scene.shapes[0].world_from_object.project_point3(DVec3::new(1.0, 2.0, 4.0));
    assert!((p - DVec3::new(0.25, 0.5, 0.75)).length() < 1e-12, "{p}");
    // Aqsis' persptrans.rib: PRMan 3.9 draws `Perspective 90` as this ConcatTransform; the two
    // matrices agree up to the homogeneous scale tan(45 deg), which rounds to 1 - 2^-53.
    let explicit =
        load("WorldBegin ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 1 0 0 -1 0] Sphere 1 -1 1 360 WorldEnd");
    let (a, b) = (l.scene.shapes[0].world_from_object, explicit.scene.shapes[0].world_from_object);
    for p in [DVec3::new(1.0, 2.0, 4.0), DVec3::new(-0.3, 0.7, 0.5), DVec3::new(0.25, -0.5, 1.5)] {
        let (pa, pb) = (a.project_point3(p), b.project_point3(p));
        assert!((pa - pb).length() < 1e-15 * pb.length().max(1.0), "{pa} {pb}");
    }
}

#[test]
fn skew_turns_the_first_vector_by_the_angle() {
    let s = load("WorldBegin Skew 30 0 1 0 1 0 0 Sphere 1 -1 1 360 WorldEnd").scene;
    let m: DMat4 = s.shapes[0].world_from_object;
    // d1 = y, d2 = x: y turns 30 degrees towards x.
    let v = m.transform_vector3(DVec3::Y).normalize();
    assert!((v.angle_between(DVec3::Y).to_degrees() - 30.0).abs() < 1e-9, "{v}");
    assert!(v.x > 0.0);
    // Points along d2 do not move, nor do points off the plane (z).
    assert_eq!(m.transform_vector3(DVec3::X), DVec3::X);
    assert_eq!(m.transform_vector3(DVec3::Z), DVec3::Z);
    assert!(load_err("WorldBegin Skew 95 0 1 0 1 0 0 WorldEnd").contains("skews past the axis"));
}

#[test]
fn a_motion_block_around_the_camera_moves_the_camera() {
    let l = load(
        "Shutter 0 1\nMotionBegin [0 1]\nTranslate 0 0 5\nTranslate 1 0 5\nMotionEnd\nScale 1 -1 1\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    assert_eq!(l.diagnostics.warning_count(), 0, "{}", l.render_warnings());
    let s = &l.scene;
    let motion = s.render.camera_motion.as_ref().expect("a moving camera");
    // Transformations after the block apply to every key; the camera is the key at shutter open.
    let key = |x: f64| {
        DMat4::from_translation(DVec3::new(x, 0.0, 5.0)) * DMat4::from_scale(DVec3::new(1.0, -1.0, 1.0))
    };
    assert_eq!(motion.times(), &[0.0, 1.0]);
    assert_eq!(motion.matrices(), &[key(0.0), key(1.0)]);
    assert_eq!(s.camera.camera_from_world, key(0.0));
    assert!(s.has_motion_blur());
    // Without an open shutter nothing blurs; the keys are still kept.
    let l = load("MotionBegin [0 1]\nTranslate 0 0 5\nTranslate 1 0 5\nMotionEnd\nWorldBegin\nWorldEnd\n");
    assert!(l.scene.render.camera_motion.is_some() && !l.scene.has_motion_blur());
    // Written back and read again, the same motion.
    let again = load(&rib_parser::writer::write_scene(s));
    assert_eq!(again.scene.render.camera_motion, s.render.camera_motion);
}

#[test]
fn clipping_planes_are_kept_in_camera_space() {
    let l = load(
        "ClippingPlane 0.5 0 0 1 0 0\nTranslate 0 0 10\nScale 2 1 1\nClippingPlane 1 0 0 1 1 0\nWorldBegin\nClippingPlane 0 0 0 0 0 1\nWorldEnd\n",
    );
    let planes = &l.scene.render.clipping_planes;
    assert_eq!(planes.len(), 2, "the one inside the world is ignored");
    assert!(l.render_warnings().contains("ClippingPlane inside WorldBegin"), "{}", l.render_warnings());
    assert_eq!(planes[0], ClippingPlane { point: DVec3::new(0.5, 0.0, 0.0), normal: DVec3::X });
    // The point moves with the transformation, the normal by its inverse transpose.
    assert_eq!(planes[1].point, DVec3::new(2.0, 0.0, 10.0));
    assert!(planes[1].normal.abs_diff_eq(DVec3::new(0.5, 1.0, 0.0), 1e-15), "{}", planes[1].normal);
    assert!(load_err("ClippingPlane 0 0 0 0 0 0\nWorldBegin\nWorldEnd\n").contains("normal"));
}

#[test]
fn geometry_teapot_is_32_bezier_patches_and_other_names_are_named() {
    let l = load(
        "Basis \"b-spline\" 1 \"b-spline\" 1\nWorldBegin\nGeometry \"teapot\" \"constant float Kd\" [0.5] \"varying float s\" [0 1 0 1]\nGeometry \"bunny\"\nWorldEnd\n",
    );
    let patches: Vec<&PatchMesh> = l
        .scene
        .shapes
        .iter()
        .map(|s| match &*s.shape {
            Shape::Patches(p) => p,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(patches.len(), 32);
    for p in &patches {
        assert_eq!(
            (p.kind, p.nu, p.nv, p.u_basis, p.v_basis),
            (PatchKind::Bicubic, 4, 4, rib_parser::basis::bezier_basis(), rib_parser::basis::bezier_basis())
        );
        assert!(p.primvars.get("Kd").is_some() && p.primvars.get("s").is_none());
    }
    let warnings = l.render_warnings();
    assert!(warnings.contains("Geometry \"bunny\" is not supported"), "{warnings}");
    assert!(warnings.contains("parameter \"s\""), "{warnings}");
    assert!(!warnings.contains("\"teapot\" is not supported"), "{warnings}");
}

/// `Displacement` keeps the transformation current at the request as its shader space
/// (RenderMan's "shader" space, where `dented` evaluates its noise); the standard shaders are
/// evaluated downstream without a warning, a custom one is named as custom.
#[test]
fn displacement_keeps_its_shader_space_and_warns_only_for_custom_shaders() {
    let l = load(
        "WorldBegin\nAttributeBegin\nTranslate 1 2 3\nDisplacement \"dented\" \"Km\" 2\nScale 2 2 2\n\
         Sphere 1 -1 1 360\nAttributeEnd\nAttributeBegin\nDisplacement \"bumpy\"\nSphere 1 -1 1 360\n\
         AttributeEnd\nWorldEnd\n",
    );
    assert_eq!(l.diagnostics.warning_count(), 0, "{}", l.render_warnings());
    let a = l.scene.attributes_of(l.scene.shapes[0].attributes);
    assert_eq!(a.displacement.as_ref().map(|d| d.name.as_str()), Some("dented"));
    assert_eq!(a.displacement_space, DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0)));
    let b = l.scene.attributes_of(l.scene.shapes[1].attributes);
    assert_eq!(b.displacement_space, DMat4::IDENTITY);

    let custom = load("WorldBegin\nDisplacement \"micro_bumps\"\nSphere 1 -1 1 360\nWorldEnd\n");
    let warnings = custom.render_warnings();
    assert!(warnings.contains("\"micro_bumps\" is a custom shader"), "{warnings}");
}

//! Blobby, Points, Curves and CSG solids in the ray tracer against closed forms, through the depth table
//! of an orthographic camera (one ray per pixel centre, parallel): covered area, and depth.

use depth_remap::Camera;
use raytracer::render::{RenderOptions, render};

/// 200 x 200 pixels over [-2, 2]^2: a pixel is 0.02 units wide; the eye is 10 units away.
const CAMERA: &str = r#"
Format 200 200 1
Projection "orthographic"
ScreenWindow -2 2 -2 2
Translate 0 0 10
"#;

const PIXEL: f64 = 0.02;

/// The depth table of the world block, and the number of pixels that hit something.
fn depths(world: &str) -> (Vec<f32>, usize) {
    let rib = format!("{CAMERA}WorldBegin\n{world}\nWorldEnd\n");
    let scene = rib_parser::load_bytes("geometry.rib", rib.into_bytes(), &Default::default()).unwrap().scene;
    let out =
        render(&scene, &RenderOptions { spp: Some(1), depth: true, threads: Some(2), ..Default::default() })
            .unwrap();
    let depth = out.depth.unwrap();
    let camera = Camera::new(scene.camera.clone()).unwrap();
    assert_eq!(camera.resolution(), (200, 200));
    let hits = depth.values.iter().filter(|v| v.is_finite()).count();
    (depth.values, hits)
}

fn assert_area(hits: usize, area: f64, what: &str) {
    let measured = hits as f64 * PIXEL * PIXEL;
    eprintln!("{what}: area {measured} by pixel count, {area} exact");
    assert!((measured - area).abs() <= 0.01 * area, "{what}: area {measured} by pixel count, {area} exact");
}

#[test]
fn a_single_ellipsoid_blobby_is_the_sphere_of_half_its_scale() {
    // Matrix scale 1.6: the level set 0.421875 of (1 - r^2)^3 is r = 1/2, a sphere of radius 0.8.
    let (depth, hits) = depths("Blobby 1 [1001 0 0 1 0] [1.6 0 0 0 0 1.6 0 0 0 0 1.6 0 0 0 0 1] [\"\"]");
    assert_area(hits, std::f64::consts::PI * 0.64, "Blobby");
    // The centre pixel's ray (through (0.01, -0.01)) meets the sphere at depth 10 - sqrt(r^2 - rho^2),
    // within the tessellation tolerance (half a pixel at most, 1e-2 of its size).
    let centre = f64::from(depth[100 * 200 + 100]);
    let exact = 10.0 - (0.64f64 - 2.0 * 0.01 * 0.01).sqrt();
    assert!((centre - exact).abs() < 0.8 * 2.0 * 1e-2, "depth {centre}, exact {exact}");
}

#[test]
fn points_are_spheres_that_cover_their_width() {
    let (depth, hits) =
        depths("Points \"P\" [-1 0 0  1 0 0  0 1.2 0] \"constant float constantwidth\" [0.8]");
    assert_area(hits, 3.0 * std::f64::consts::PI * 0.16, "Points");
    // Exact spheres: the depth at a pixel centre is the sphere's own.
    let (x, y) = (-1.0 + 0.01f64, 0.01f64);
    let (i, j) = (((x + 2.0) / PIXEL) as usize, ((2.0 - y) / PIXEL) as usize);
    let exact = 10.0 - (0.16 - (x + 1.0).powi(2) - y * y).sqrt();
    assert!((f64::from(depth[j * 200 + i]) - exact).abs() < 1e-5, "{} vs {exact}", depth[j * 200 + i]);
}

#[test]
fn curves_are_ribbons_of_their_projected_width() {
    // A straight linear curve and a cubic Bezier arch, both 0.1 wide (5 pixels), facing the
    // orthographic camera: the covered area is length times width.
    let (_, hits) = depths(
        "Curves \"linear\" [2] \"nonperiodic\" \"P\" [-1.5 -1.2 0  1.4 1.1 0] \"constant float constantwidth\" [0.1]",
    );
    // Diagonal, so that pixel rows do not line up with its edges.
    assert_area(hits, (2.9f64.hypot(2.3)) * 0.1, "linear curve");
    let (_, hits) = depths(
        "Basis \"bezier\" 3 \"bezier\" 3\nCurves \"cubic\" [4] \"nonperiodic\" \"P\" [-1 0 0  -1 1.5 0  1 1.5 0  1 0 0] \"varying float width\" [0.1 0.1]",
    );
    // Length of the arch by fine sampling of the Bezier curve.
    let b = |t: f64| {
        let s = 1.0 - t;
        let x = -s * s * s - 3.0 * s * s * t + 3.0 * s * t * t + t * t * t;
        let y = 3.0 * 1.5 * (s * s * t + s * t * t);
        (x, y)
    };
    let length: f64 = (0..10_000)
        .map(|k| {
            let (a, c) = (b(k as f64 / 1e4), b((k + 1) as f64 / 1e4));
            ((c.0 - a.0).powi(2) + (c.1 - a.1).powi(2)).sqrt()
        })
        .sum();
    assert_area(hits, length * 0.1, "cubic curve");
}

/// The depth at the pixel whose centre is nearest `(x, y)`, and that centre.
fn depth_at(depth: &[f32], x: f64, y: f64) -> (f64, f64, f64) {
    let (i, j) = (((x + 2.0) / PIXEL) as usize, ((2.0 - y) / PIXEL) as usize);
    let (cx, cy) = (-2.0 + (i as f64 + 0.5) * PIXEL, 2.0 - (j as f64 + 0.5) * PIXEL);
    (f64::from(depth[j * 200 + i]), cx, cy)
}

/// Two unit spheres whose centres are 1 apart: their silhouettes overlap in a lens of area
/// 2 acos(1/2) - sqrt(3)/2.
const LENS_AREA: f64 = 2.0 * std::f64::consts::FRAC_PI_3 - 0.866_025_403_784_438_6;

#[test]
fn csg_intersection_and_union_cover_the_lens_and_both_discs() {
    let spheres = "SolidBegin \"primitive\" TransformBegin Translate -0.5 0 0 Sphere 1 -1 1 360 TransformEnd SolidEnd\n\
                   SolidBegin \"primitive\" TransformBegin Translate 0.5 0 0 Sphere 1 -1 1 360 TransformEnd SolidEnd";
    let (depth, hits) = depths(&format!("SolidBegin \"intersection\"\n{spheres}\nSolidEnd"));
    assert_area(hits, LENS_AREA, "intersection");
    // At the centre both spheres' front surfaces are at z = sqrt(1 - 0.25 - y^2): the nearer
    // of the two, where the ray is inside both, is the lens's surface.
    let (d, x, y) = depth_at(&depth, 0.0, 0.0);
    let exact = 10.0 - (1.0 - (x.abs() + 0.5).powi(2) - y * y).sqrt();
    assert!((d - exact).abs() < 1e-4, "intersection depth {d}, exact {exact}");
    let (_, hits) = depths(&format!("SolidBegin \"union\"\n{spheres}\nSolidEnd"));
    assert_area(hits, 2.0 * std::f64::consts::PI - LENS_AREA, "union");
}

#[test]
fn csg_difference_carves_the_subtracted_solid_out() {
    // A closed can (a cylinder and two caps as one primitive solid) minus a sphere of radius
    // 0.5 centred on its cap at z = -1, which faces the eye (at z = -10, looking along +z):
    // the centre sees the bottom of the spherical dimple (z = -0.5), outside it the cap.
    let world = "SolidBegin \"difference\"\n\
                 SolidBegin \"primitive\" Cylinder 1 -1 1 360\n\
                   TransformBegin Translate 0 0 1 Disk 0 1 360 TransformEnd\n\
                   TransformBegin Translate 0 0 -1 Disk 0 1 360 TransformEnd SolidEnd\n\
                 SolidBegin \"primitive\" TransformBegin Translate 0 0 -1 Sphere 0.5 -0.5 0.5 360 TransformEnd SolidEnd\n\
                 SolidEnd";
    let (depth, hits) = depths(world);
    assert_area(hits, std::f64::consts::PI, "difference silhouette");
    let (d, x, y) = depth_at(&depth, 0.0, 0.0);
    let exact = 10.0 - (1.0 - (0.25 - x * x - y * y).sqrt());
    assert!((d - exact).abs() < 1e-4, "dimple depth {d}, exact {exact}");
    let (d, ..) = depth_at(&depth, 0.7, 0.0);
    assert!((d - 9.0).abs() < 1e-4, "cap depth {d}, exact 9");
    // The same with a triangle mesh: a cube [-1, 1]^3 minus the sphere.
    let cube = "SolidBegin \"difference\"\n\
                SolidBegin \"primitive\" PointsPolygons [4 4 4 4 4 4]\n\
                  [0 1 3 2  4 6 7 5  0 4 5 1  2 3 7 6  0 2 6 4  1 5 7 3]\n\
                  \"P\" [-1 -1 -1  1 -1 -1  -1 1 -1  1 1 -1  -1 -1 1  1 -1 1  -1 1 1  1 1 1] SolidEnd\n\
                SolidBegin \"primitive\" TransformBegin Translate 0 0 -1 Sphere 0.5 -0.5 0.5 360 TransformEnd SolidEnd\n\
                SolidEnd";
    let (depth, hits) = depths(cube);
    assert_area(hits, 4.0, "cube silhouette");
    let (d, x, y) = depth_at(&depth, 0.0, 0.0);
    let exact = 10.0 - (1.0 - (0.25 - x * x - y * y).sqrt());
    assert!((d - exact).abs() < 1e-4, "cube dimple depth {d}, exact {exact}");
    assert!((depth_at(&depth, 0.8, 0.3).0 - 9.0).abs() < 1e-4);

    // As a union the sphere bulges out of the cap instead.
    let (depth, _) = depths(&world.replace("\"difference\"", "\"union\""));
    let (d, x, y) = depth_at(&depth, 0.0, 0.0);
    let exact = 9.0 - (0.25 - x * x - y * y).sqrt();
    assert!((d - exact).abs() < 1e-4, "union depth {d}, exact {exact}");
}

#[test]
fn clipping_planes_remove_what_lies_on_the_side_their_normal_points_to() {
    // Two planes in the coordinate system current where each is given: camera space for the
    // first (x > 0.5 is clipped), the sphere's centre for the second (z < 10 in camera space,
    // the half towards the eye, is clipped), so the eye sees into the unit sphere's back half.
    let options = "Format 200 200 1\nProjection \"orthographic\"\nScreenWindow -2 2 -2 2\nClippingPlane 0.5 0 0 1 0 0\nTranslate 0 0 10\nClippingPlane 0 0 0 0 0 -1\n";
    let rib = format!("{options}WorldBegin\nSphere 1 -1 1 360\nWorldEnd\n");
    let scene = rib_parser::load_bytes("clip.rib", rib.into_bytes(), &Default::default()).unwrap().scene;
    assert_eq!(scene.render.clipping_planes.len(), 2);
    let out =
        render(&scene, &RenderOptions { spp: Some(1), depth: true, threads: Some(2), ..Default::default() })
            .unwrap();
    let depth = out.depth.unwrap().values;
    let hits = depth.iter().filter(|v| v.is_finite()).count();
    // The unit disc less its segment beyond x = 0.5: pi - (acos(0.5) - 0.5 sqrt(0.75)).
    let segment = 0.5f64.acos() - 0.5 * 0.75f64.sqrt();
    assert_area(hits, std::f64::consts::PI - segment, "clipped sphere");
    // Nothing right of x = 0.5, and the centre pixel sees the back of the sphere.
    for j in 0..200 {
        for i in 0..200 {
            let x = -2.0 + (i as f64 + 0.5) * PIXEL;
            assert!(x < 0.5 || !depth[j * 200 + i].is_finite(), "pixel ({i}, {j}) at x = {x} is not clipped");
        }
    }
    let centre = f64::from(depth[100 * 200 + 100]);
    let exact = 10.0 + (1.0 - 2.0 * 0.01f64 * 0.01).sqrt();
    assert!((centre - exact).abs() < 1e-4, "depth {centre}, exact {exact}");
}

/// `Perspective 90` then `Translate 0 0 1.5`: the unit sphere at (0, 0, 1.5) seen through
/// `(x, y, z) -> (x/z, y/z, 1 - 1/z)`. Along the orthographic view (world z) its outline is the
/// central projection of the sphere from the origin: a disc of radius `tan(asin(1/1.5))`. The
/// pixel `(X, Y)` sees the object-space points `s (X, Y, 1)`; the eye is at world z = -10, so
/// the smallest `s` on the sphere is nearest it (`1 - 1/s` grows with `s`), at depth
/// `10 + (1 - 1/s)`.
#[test]
fn a_sphere_under_perspective_is_drawn_through_the_projection() {
    let placed = "Perspective 90 Translate 0 0 1.5 Sphere 1 -1 1 360";
    // The same sphere as an object instance placed through the projection.
    let instanced =
        "ObjectBegin 1 Sphere 1 -1 1 360 ObjectEnd Perspective 90 Translate 0 0 1.5 ObjectInstance 1";
    for world in [placed, instanced] {
        sphere_under_perspective(world);
    }
}

fn sphere_under_perspective(world: &str) {
    let (depth, hits) = depths(world);
    let alpha = (1.0f64 / 1.5).asin();
    assert_area(hits, std::f64::consts::PI * alpha.tan().powi(2), "projected sphere");
    let mut checked = 0;
    for (i, j) in [(100, 100), (120, 90), (70, 130), (140, 100), (100, 60)] {
        let (x, y) = (-2.0 + (i as f64 + 0.5) * PIXEL, 2.0 - (j as f64 + 0.5) * PIXEL);
        // |s (X, Y, 1) - (0, 0, 1.5)|^2 = 1.
        let (a, b, c) = (x * x + y * y + 1.0, -3.0, 1.5f64 * 1.5 - 1.0);
        let disc = b * b - 4.0 * a * c;
        assert!(disc > 0.0, "pixel ({i}, {j}) is inside the outline");
        let s = (-b - disc.sqrt()) / (2.0 * a);
        let exact = 10.0 + (1.0 - 1.0 / s);
        let measured = f64::from(depth[j * 200 + i]);
        // Within the tessellation's tolerance (half a pixel, 0.01).
        assert!((measured - exact).abs() < 0.01, "pixel ({i}, {j}): depth {measured}, exact {exact}");
        checked += 1;
    }
    assert_eq!(checked, 5);
}

/// Aqsis' `content/Test/persptrans.rib`: its hyperboloid under `Perspective 90` must be drawn as
/// under `ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 1 0 0 -1 0]` (PRMan 3.9 matched them).
#[test]
fn perspective_90_draws_as_prmans_explicit_matrix() {
    let shape = "Translate 0 0 1 Hyperboloid -0.25 -0.25 -0.5  0.75 0.25 0.5 300";
    let (request, request_hits) = depths(&format!("Rotate 30 0 1 0 Perspective 90 {shape}"));
    let (matrix, matrix_hits) =
        depths(&format!("Rotate 30 0 1 0 ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 1 0 0 -1 0] {shape}"));
    assert!(request_hits > 1000, "{request_hits} pixels hit");
    assert!(request_hits.abs_diff(matrix_hits) <= 2, "{request_hits} vs {matrix_hits} pixels");
    let both = request.iter().zip(&matrix).filter(|(a, b)| a.is_finite() && b.is_finite());
    let largest = both.map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
    assert!(largest < 1e-4, "depths differ by up to {largest}");
}

/// A moving shape under `Perspective` is drawn at shutter open, with a warning (moving BLASes
/// map rays affinely): the ray along the z axis meets the sphere of the first key where the
/// closed form of `a_sphere_under_perspective_is_drawn_through_the_projection` says,
/// `1 - 1/s` with `s = 0.5` (world z = -1), not where the second key (0.5 further along x)
/// would put it.
#[test]
fn a_moving_shape_under_perspective_is_drawn_at_shutter_open_with_a_warning() {
    use raytracer::diagnostics::Diagnostics;
    use raytracer::world::{PixelFootprint, Ray, World};
    let rib = "Shutter 0 1\nWorldBegin\nPerspective 90\nMotionBegin [0 1]\nTranslate 0 0 1.5\nTranslate 0.5 0 1.5\n\
               MotionEnd\nSphere 1 -1 1 360\nWorldEnd\n";
    let scene =
        rib_parser::load_bytes("moving.rib", rib.as_bytes().to_vec(), &Default::default()).unwrap().scene;
    let eye = glam::DVec3::new(0.0, 0.0, -10.0);
    let mut diagnostics = Diagnostics::default();
    let footprint = PixelFootprint::Perspective { radians_per_pixel: 1e-3 };
    let world = World::build(&scene, eye, footprint, &mut diagnostics).expect("the world builds");
    let text = format!("{:?}", diagnostics.warnings);
    assert!(text.contains("transformation is projective (Perspective) is drawn at shutter open"), "{text}");
    for time in [0.0f32, 0.5, 1.0] {
        let mut ray = Ray::new(glam::Vec3::ZERO, glam::Vec3::Z);
        ray.time = time;
        let hit = world.intersect(&ray).expect("the ray meets the sphere");
        // From the eye at z = -10 to z = -1 (the tessellation's tolerance: half a milliradian
        // pixel at that distance and 1e-2 of the size at most).
        assert!((f64::from(hit.t) - 9.0).abs() < 1e-2, "t = {} at time {time}", hit.t);
    }
}

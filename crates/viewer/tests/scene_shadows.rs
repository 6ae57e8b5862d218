//! GPU tests of the scene's own shadows on live objects: with the scene's triangles bound
//! (`ViewerScene::set_occluders`), a live surface point gets a light's direct light only where
//! no scene triangle lies between it and the light. Checked against the same triangles in f64.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::occluders::SceneOccluders;
use viewer::{Compositor, CompositorSettings, LiveLight, LiveObjects, Material, Sphere, ViewerScene};

/// A white matte surface lit by the lights alone.
fn matte() -> Material {
    Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() }
}

/// A horizontal square at height `y` spanning x in [-1, x_edge], z in [-1, 1]: a shelf whose
/// edge runs over the sphere, so it shades part of it from a light above.
fn shelf(y: f64, x_edge: f64) -> Vec<[DVec3; 3]> {
    let c = [
        DVec3::new(-1.0, y, -1.0),
        DVec3::new(x_edge, y, -1.0),
        DVec3::new(x_edge, y, 1.0),
        DVec3::new(-1.0, y, 1.0),
    ];
    vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
}

fn crosses(p: DVec3, light: DVec3, tris: &[[DVec3; 3]]) -> bool {
    let d = light - p;
    let len = d.length();
    let dir = d / len;
    tris.iter().any(|t| {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let pv = dir.cross(e2);
        let det = e1.dot(pv);
        let tv = p - t[0];
        let (u, qv) = (tv.dot(pv) / det, tv.cross(e1));
        let v = dir.dot(qv) / det;
        let hit = e2.dot(qv) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && hit > 0.0 && hit < len
    })
}

/// Renders a matte sphere under a point light with `occluders` bound and returns, over the
/// sphere's interior pixels that face the light: (pixels the f64 test shadows, lit ones, and
/// pixels whose value disagrees: shadowed but lit, or lit but black).
fn shadowed_sphere(occluders: Option<Vec<[DVec3; 3]>>, tris: &[[DVec3; 3]]) -> (usize, usize, usize) {
    let gpu = gpu();
    let light = DVec3::new(0.0, 0.9, 0.0);
    let mut s: ViewerScene =
        cornell_scene(vec![LiveLight::Point { position: light, colour: Vec3::splat(1.0) }]);
    if let Some(triangles) = occluders {
        s.set_occluders(SceneOccluders { triangles });
    }
    let (centre, radius) = (DVec3::new(0.05, -0.45, 0.1), 0.3);
    let settings = CompositorSettings { shadows: None, ..Default::default() };
    let mut c = Compositor::new(&gpu, &s, settings).unwrap();
    c.render(&LiveObjects { sphere: Some(Sphere { centre, radius, material: matte() }), meshes: Vec::new() })
        .unwrap();
    let linear = c.read_back_linear().unwrap();
    let frame = c.read_back().unwrap();
    let camera = s.camera();
    let (mut shadowed, mut lit, mut wrong) = (0, 0, 0);
    for j in 0..512u32 {
        for i in 0..512u32 {
            let k = (j * 512 + i) as usize;
            if !inside_mask(&frame.mask, 512, k) {
                continue;
            }
            let ray = camera.pixel_centre_ray(i, j);
            let world = camera.world_from_camera();
            let (o, d) =
                (world.transform_point3(ray.origin), world.transform_vector3(ray.direction).normalize());
            let Some(t) = ray_sphere(o, d, centre, radius) else { continue };
            let p = o + d * t;
            let n = (p - centre) / radius;
            // Grazing light is too close to call in f32.
            if n.dot((light - p).normalize()) < 0.05 {
                continue;
            }
            let value = linear.rgba[4 * k];
            if crosses(p, light, tris) {
                shadowed += 1;
                wrong += usize::from(value > 1e-6);
            } else {
                lit += 1;
                wrong += usize::from(value < 1e-3);
            }
        }
    }
    (shadowed, lit, wrong)
}

#[test]
fn a_live_sphere_under_a_scene_shelf_gets_the_light_only_where_the_shelf_lets_it() {
    let tris = shelf(0.2, 0.0);
    let (shadowed, lit, wrong) = shadowed_sphere(Some(tris.clone()), &tris);
    assert!(shadowed > 1000 && lit > 1000, "shadowed {shadowed}, lit {lit}");
    // Only points whose ray to the light grazes the shelf's edge may fall on the other side.
    assert!(wrong * 100 <= shadowed, "{wrong} of {shadowed} + {lit} pixels wrong");
}

#[test]
fn without_the_scene_bound_the_sphere_is_lit_everywhere_it_faces_the_light() {
    let tris = shelf(0.2, 0.0);
    let (shadowed, _, wrong) = shadowed_sphere(None, &tris);
    // The pixels the shelf would shadow are all lit: the check above can fail.
    assert!(wrong >= shadowed && shadowed > 1000, "{wrong} of {shadowed}");
}

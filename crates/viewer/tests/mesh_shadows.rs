//! GPU tests of live meshes' shadows with the renderer's light layers: a live triangle mesh
//! removes exactly the occluded share of each light's layer, as spheres do
//! (layered_shadows.rs). Checked against the mesh's triangles in f64 on the CPU over the
//! Cornell box's exact depth table.

mod common;

use common::*;
use glam::{DMat4, DQuat, DVec3, Vec3};
use std::sync::Arc;
use viewer::{Compositor, CompositorSettings, LiveObjects, Material, Mesh, MeshInstance};

const LEVEL: f32 = 0.5;

/// A flat box tilted about two axes, floating over the floor.
fn tilted_box() -> MeshInstance {
    let world_from_object = DMat4::from_rotation_translation(
        DQuat::from_rotation_z(0.5) * DQuat::from_rotation_x(0.3),
        DVec3::new(-0.15, -0.45, 0.1),
    );
    MeshInstance {
        mesh: Arc::new(Mesh::cuboid(Vec3::new(0.25, 0.04, 0.15))),
        world_from_object,
        material: Material::unlit(Vec3::new(0.0, 0.0, 1.0)),
        exact_sphere: None,
    }
}

/// The mesh's world-space triangles.
fn world_triangles(m: &MeshInstance) -> Vec<[DVec3; 3]> {
    m.mesh
        .indices
        .chunks_exact(3)
        .map(|t| {
            [t[0], t[1], t[2]]
                .map(|i| m.world_from_object.transform_point3(m.mesh.positions[i as usize].as_dvec3()))
        })
        .collect()
}

/// Möller-Trumbore in f64: the hit's ray parameter.
fn hit(origin: DVec3, dir: DVec3, t: &[DVec3; 3]) -> Option<f64> {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let pv = dir.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-300 {
        return None;
    }
    let tv = origin - t[0];
    let u = tv.dot(pv) / det;
    let qv = tv.cross(e1);
    let v = dir.dot(qv) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0).then(|| e2.dot(qv) / det)
}

fn blocked(p: DVec3, to: DVec3, tris: &[[DVec3; 3]]) -> bool {
    let d = to - p;
    let len = d.length();
    tris.iter().any(|t| hit(p, d / len, t).is_some_and(|h| h > 1e-9 && h < len))
}

/// Each floor pixel loses the share of the point light's layer that the mesh hides over the
/// pixel's footprint (as the renderer filters it; layered_shadows.rs does the same for spheres).
#[test]
fn a_point_light_layer_is_removed_where_a_live_mesh_hides_the_light_over_each_pixel() {
    let gpu = gpu();
    let light = DVec3::new(0.0, 0.9, 0.0);
    let s = layered_cornell(light, false, LEVEL);
    let mut c = Compositor::new(&gpu, &s, CompositorSettings::default()).unwrap();
    let instance = tilted_box();
    let tris = world_triangles(&instance);
    c.render(&LiveObjects { sphere: None, meshes: vec![instance] }).unwrap();
    let linear = c.read_back_linear().unwrap();
    let frame = c.read_back().unwrap();
    let shadow = footprint_shadow(&s, &linear.rgba, &frame.mask, LEVEL, |q| blocked(q, light, &tris));
    assert_footprint_shadow(&shadow, LEVEL, 1000);
}

/// Over an area light's samples, the layer loses the share of `area cos_l cos_s / d^2` whose
/// rays the mesh blocks: penumbrae as wide as the emitter makes them.
#[test]
fn an_area_light_layer_loses_the_share_of_the_emitter_a_live_mesh_hides() {
    let gpu = gpu();
    let samples = cornell_emitter_samples();
    let s = area_layered_cornell(&samples, LEVEL);
    let mut c = Compositor::new(&gpu, &s, CompositorSettings::default()).unwrap();
    let instance = tilted_box();
    let tris = world_triangles(&instance);
    c.render(&LiveObjects { sphere: None, meshes: vec![instance] }).unwrap();
    let linear = c.read_back_linear().unwrap();
    let frame = c.read_back().unwrap();
    let (mut penumbra, mut checked) = (0, 0);
    for_each_backdrop_point(&s, &frame.mask, 2, Skip::NearMask, |i, j, k, p| {
        if (p.y + 1.0).abs() > 1e-3 {
            return; // Floor pixels: their normal is the layer's.
        }
        let share = hidden_share(p, &samples, |p, to| blocked(p, to, &tris));
        penumbra += usize::from(share > 0.05 && share < 0.95);
        let expected = f64::from(LEVEL) * (1.0 - share);
        let got = f64::from(linear.rgba[4 * k]);
        // One sample's share flipping on a grazing ray is the most a pixel may be off.
        assert!((got - expected).abs() < 0.04 * f64::from(LEVEL), "pixel ({i}, {j}): {got} vs {expected}");
        checked += 1;
    });
    assert!(checked > 5000 && penumbra > 150, "checked {checked}, penumbra {penumbra}");
}

/// The Cornell box at `level` everywhere, all of it the area light's layer (normals up).
fn area_layered_cornell(samples: &[viewer::AreaSample], level: f32) -> viewer::ViewerScene {
    let (w, h) = (512u32, 512u32);
    let n = (w * h) as usize;
    let backdrop = viewer::Backdrop::from_linear(w, h, [level, level, level, 1.0].repeat(n), 1.0).unwrap();
    let mut s = viewer::ViewerScene::with_backdrop(
        cornell_camera(),
        backdrop,
        cornell_depth(),
        vec![cornell_light()],
        viewer::ToneMap::default(),
    )
    .unwrap();
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers =
        sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    layers.light[0].iter_mut().for_each(|v| *v = [level; 3]);
    layers.normal.iter_mut().for_each(|v| *v = [0.0, 1.0, 0.0]);
    s.set_light_layers(viewer::SceneLayers {
        layers,
        layer_of_light: vec![Some(0)],
        area_samples: vec![samples.to_vec()],
    })
    .unwrap();
    s
}

//! The RIB scene tessellated for the viewer's shadow rays: the scene's own shadows on live
//! objects (docs/viewer.md, "The scene's shadows on live objects").

use tessellate::{Tolerance, tessellate_scene};
use viewer::occluders::{MAX_SCENE_OCCLUDER_TRIANGLES, SceneOccluders};

/// Every surface of `scene` as world-space triangles, at the haptics' relative tolerance (1e-3
/// of each shape's size). Says on stderr what is left out: shapes that gave no triangles, and
/// triangles over the viewer's budget.
pub fn scene_occluders(scene: &rib_parser::scene::Scene) -> SceneOccluders {
    let meshes = tessellate_scene(scene, &Tolerance::relative(1e-3));
    let mut triangles = Vec::with_capacity(meshes.triangle_count().min(1 << 24) as usize);
    for m in &meshes.meshes {
        let p = &m.mesh.positions;
        for t in &m.mesh.indices {
            let corner = |i: u32| p.get(i as usize).map(|v| v.as_dvec3());
            if let (Some(a), Some(b), Some(c)) = (corner(t[0]), corner(t[1]), corner(t[2])) {
                triangles.push([a, b, c]);
            }
        }
    }
    // Points and curves give no triangles (thin, they hide little light): left out quietly.
    let failed = meshes.skipped.iter().filter(|s| !s.error.is_not_a_surface()).count();
    if failed > 0 {
        eprintln!("note: {failed} shape(s) could not be tessellated and cast no shadow on live objects");
    }
    if triangles.len() > MAX_SCENE_OCCLUDER_TRIANGLES {
        eprintln!(
            "note: the scene's {} triangles exceed the viewer's budget of {MAX_SCENE_OCCLUDER_TRIANGLES}: only the largest shadow live objects",
            triangles.len()
        );
    }
    SceneOccluders { triangles }
}

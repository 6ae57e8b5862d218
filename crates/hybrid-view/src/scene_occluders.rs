//! The RIB scene tessellated for the viewer's shadow rays: the scene's own shadows on live
//! objects (docs/viewer-lighting.md, "The scene's shadows on live objects"). With haptics the same
//! tessellation is shared with them (at theirs, the finer tolerance), so the scene is
//! tessellated once at startup.

use std::time::Instant;
use tessellate::{SceneMeshes, Tolerance, tessellate_scene};
use viewer::occluders::{MAX_SCENE_OCCLUDER_TRIANGLES, SceneOccluders};

/// The tolerance of the shadow rays' triangles without haptics: 1e-3 of each shape's size, as
/// the haptics' own (`haptics::scene::tessellation_tolerance`, which also bounds it by the
/// proxy's radius, so it is never coarser than this one).
pub fn viewer_tolerance() -> Tolerance {
    Tolerance::relative(1e-3)
}

/// Tessellates `scene` once at `tolerance` for the viewer's shadow rays (and whoever shares
/// the meshes); with `stats`, says on stderr how long it took.
pub fn tessellate_once(scene: &rib_parser::scene::Scene, tolerance: &Tolerance, stats: bool) -> SceneMeshes {
    let start = Instant::now();
    let meshes = tessellate_scene(scene, tolerance);
    for name in &meshes.unreadable_textures {
        eprintln!(
            "warning: bumpy's texture \"{name}\" cannot be read: the surface is displaced as if it read 0"
        );
    }
    if stats {
        eprintln!(
            "scene tessellated once: {} triangles in {:.1} ms",
            meshes.triangle_count(),
            start.elapsed().as_secs_f64() * 1e3
        );
    }
    meshes
}

/// Every surface of `meshes` as world-space triangles. Says on stderr what is left out:
/// shapes that gave no triangles, and triangles over the viewer's budget.
pub fn scene_occluders(meshes: &SceneMeshes) -> SceneOccluders {
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

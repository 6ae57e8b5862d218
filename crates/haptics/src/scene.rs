//! Haptics from a RIB scene: every surface through rib-parser's tessellation, in world space,
//! with a haptic material per attribute state from `Attribute "haptic"` (so [`MaterialId`] `n`
//! is `rib_parser::scene::AttributesId(n)`).
//!
//! A surface whose `Attribute "haptic" "float stiffness"` is 0 cannot be felt: it is left out
//! of the collision mesh (the proxy passes through it), as CHAI3D leaves out objects with
//! haptics disabled.

use crate::clipping::{clip_mesh, world_clipping_planes};
use crate::csg::Solids;
use crate::geometry::{CollisionMesh, MaterialId};
use crate::material::MaterialSpec;
use glam::DVec3;
use rib_parser::scene::{AttributesId, HapticMaterial, Scene};
use tessellate::{MeshOrigin, SceneMeshes, Tolerance, WorldMesh, tessellate_scene};

/// The material a RIB attribute state asks for (`None` fields take the device's defaults).
pub fn material_spec(haptic: &HapticMaterial) -> MaterialSpec {
    MaterialSpec {
        stiffness: haptic.stiffness.map(f64::from),
        friction: haptic.friction.map(f64::from),
        static_friction: haptic.static_friction.map(f64::from),
        dynamic_friction: haptic.dynamic_friction.map(f64::from),
    }
}

/// One [`MaterialSpec`] per attribute state of `scene`, indexed like `scene.attributes`.
pub fn material_specs(scene: &Scene) -> Vec<MaterialSpec> {
    scene.attributes.iter().map(|a| material_spec(&a.haptic)).collect()
}

/// The haptic material id of shapes made under attribute state `id`.
pub fn material_id(id: AttributesId) -> MaterialId {
    MaterialId(id.0)
}

/// The tessellation tolerance for haptics: 0.1 % of each shape's size, and no coarser than a
/// twentieth of the proxy's radius when it is known (a coarser chord would be felt as facets).
pub fn tessellation_tolerance(proxy_radius: Option<f64>) -> Tolerance {
    let mut tol = Tolerance::relative(1e-3);
    if let Some(r) = proxy_radius.filter(|r| r.is_finite() && *r > 0.0) {
        tol.max_deviation = Some(r / 20.0);
    }
    tol
}

/// A RIB scene's touchable geometry.
#[derive(Clone, Debug)]
pub struct SceneGeometry {
    /// The triangles, relative to the centre of the scene's bounds.
    pub mesh: CollisionMesh,
    /// One per attribute state (see [`material_specs`]).
    pub materials: Vec<MaterialSpec>,
    /// World-space bounds of every tessellated surface (touchable or not); `None` for a scene
    /// without surfaces.
    pub bounds: Option<(DVec3, DVec3)>,
    /// Surfaces left out because their stiffness is 0.
    pub untouchable_shapes: usize,
    /// Shapes that gave no triangles or could not be used, as `file:line:col: warning: ...`.
    pub warnings: Vec<String>,
}

impl SceneGeometry {
    /// The centre of the scene's bounds (CONTRACTS.md §5's default mapping centre); the world
    /// origin for an empty scene.
    pub fn centre(&self) -> DVec3 {
        self.bounds.map_or(DVec3::ZERO, |(lo, hi)| (lo + hi) * 0.5)
    }

    /// Half the diagonal of the scene's bounds (0 for an empty scene).
    pub fn radius(&self) -> f64 {
        self.bounds.map_or(0.0, |(lo, hi)| (hi - lo).length() * 0.5)
    }
}

/// Tessellates every surface of `scene` (see [`tessellation_tolerance`]) into a collision mesh.
pub fn scene_geometry(scene: &Scene, tolerance: &Tolerance) -> SceneGeometry {
    scene_geometry_from_meshes(scene, &tessellate_scene(scene, tolerance))
}

/// The attribute state whose haptic material applies to a mesh: the shape's own, unless it
/// says nothing haptic and the object instance placing it does.
fn material_of(scene: &Scene, mesh: &WorldMesh) -> AttributesId {
    let says_something = |id: AttributesId| {
        scene.attributes.get(id.0 as usize).is_some_and(|a| a.haptic != HapticMaterial::default())
    };
    match mesh.instance_attributes {
        Some(instance) if !says_something(mesh.attributes) && says_something(instance) => instance,
        _ => mesh.attributes,
    }
}

/// The collision mesh of `scene` from its tessellation `meshes` (`tessellate_scene` at
/// [`tessellation_tolerance`] or finer), for a caller that shares one tessellation.
pub fn scene_geometry_from_meshes(scene: &Scene, meshes: &SceneMeshes) -> SceneGeometry {
    let materials = material_specs(scene);
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for m in &meshes.meshes {
        for p in &m.mesh.positions {
            let p = p.as_dvec3();
            if p.is_finite() {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    let bounds = (lo.x <= hi.x).then_some((lo, hi));
    let centre = bounds.map_or(DVec3::ZERO, |(lo, hi)| (lo + hi) * 0.5);
    let mut mesh = CollisionMesh::new(centre);
    let mut warnings = Vec::new();
    let mut untouchable_shapes = 0;
    // What the ray tracer clips away is not touched either.
    let planes = world_clipping_planes(scene);
    // What CSG removes is not touched either; the solids' work is bounded per scene.
    let mut solids = Solids::new(scene, meshes);
    for name in &meshes.unreadable_textures {
        warnings.push(format!(
            "warning: bumpy's texture \"{name}\" cannot be read: the surface is displaced as if it read 0"
        ));
    }
    for skipped in &meshes.skipped {
        let what =
            if skipped.error.is_not_a_surface() { "has no surface to touch" } else { "cannot be touched" };
        warnings.push(format!("{}: warning: {} ({what})", skipped.loc, skipped.error));
    }
    for m in &meshes.meshes {
        let id = material_of(scene, m);
        let spec = materials.get(id.0 as usize).copied().unwrap_or_default();
        if spec.stiffness == Some(0.0) {
            untouchable_shapes += 1;
            continue;
        }
        let positions: Vec<DVec3> = m.mesh.positions.iter().map(|p| p.as_dvec3()).collect();
        let normals: Option<Vec<DVec3>> =
            m.mesh.normals.as_ref().map(|n| n.iter().map(|v| v.as_dvec3()).collect());
        let mut csg_triangles = None;
        let (positions, normals) = match (&mut solids, m.origin) {
            (Some(solids), MeshOrigin::Shape { index }) => {
                match solids.clip(index, &positions, &m.mesh.indices, normals.as_deref()) {
                    Ok(Some(clipped)) => {
                        csg_triangles = Some(clipped.triangles);
                        (clipped.positions, clipped.normals)
                    }
                    Ok(None) => (positions, normals),
                    Err(e) => {
                        warnings.push(format!("{}: warning: touched as part of a union: {e}", m.loc));
                        (positions, normals)
                    }
                }
            }
            _ => (positions, normals),
        };
        let triangles = csg_triangles.as_deref().unwrap_or(m.mesh.indices.as_slice());
        let clipped;
        let (positions, triangles, normals) = if planes.is_empty() {
            (positions, triangles, normals)
        } else {
            let (p, t, n) = clip_mesh(&planes, &positions, triangles, normals.as_deref());
            clipped = t;
            (p, clipped.as_slice(), n)
        };
        if let Err(e) = mesh.push_indexed(&positions, triangles, normals.as_deref(), material_id(id)) {
            warnings.push(format!("{}: warning: cannot be touched: {e}", m.loc));
        }
    }
    SceneGeometry { mesh, materials, bounds, untouchable_shapes, warnings }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rib_parser::scene::{Attributes, FileLoc, Shape, ShapeEntity};
    use std::sync::Arc;

    #[test]
    fn rib_haptic_attributes_become_material_specs() {
        let h = HapticMaterial {
            stiffness: Some(800.0),
            friction: Some(0.25),
            static_friction: None,
            dynamic_friction: Some(0.125),
        };
        let spec = material_spec(&h);
        assert_eq!(spec.stiffness, Some(800.0));
        assert_eq!(spec.friction, Some(0.25));
        assert_eq!(spec.dynamic_friction, Some(0.125));
        assert_eq!(spec.static_friction, None);
        assert_eq!(material_id(AttributesId(7)), MaterialId(7));
    }

    fn scene_with(shapes: Vec<(Shape, DVec3, HapticMaterial)>) -> Scene {
        let mut attributes = Vec::new();
        let mut entities = Vec::new();
        for (i, (shape, at, haptic)) in shapes.into_iter().enumerate() {
            attributes.push(Attributes { haptic, ..Attributes::default() });
            entities.push(ShapeEntity {
                shape: Arc::new(shape),
                world_from_object: glam::DMat4::from_translation(at),
                motion: None,
                deformation: None,
                attributes: AttributesId(i as u32),
                in_solid: false,
                loc: FileLoc::new("test.rib", i as u32 + 1, 1),
            });
        }
        Scene {
            source: "test.rib".into(),
            frame: None,
            camera: Default::default(),
            render: Default::default(),
            displays: Vec::new(),
            depth_request: None,
            options: Vec::new(),
            lights: Vec::new(),
            attributes,
            shapes: entities,
            objects: Vec::new(),
            instances: Vec::new(),
            coordinate_systems: Vec::new(),
            solids: Vec::new(),
        }
    }

    #[test]
    fn a_scene_becomes_touchable_triangles_with_materials() {
        let sphere = Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 };
        let soft = HapticMaterial { stiffness: Some(300.0), ..HapticMaterial::default() };
        let ghost = HapticMaterial { stiffness: Some(0.0), ..HapticMaterial::default() };
        let scene = scene_with(vec![
            (sphere.clone(), DVec3::new(10.0, 0.0, 0.0), soft),
            (sphere.clone(), DVec3::new(-10.0, 0.0, 0.0), HapticMaterial::default()),
            (sphere, DVec3::new(0.0, 5.0, 0.0), ghost),
        ]);
        let geometry = scene_geometry(&scene, &tessellation_tolerance(Some(0.1)));
        assert_eq!(geometry.untouchable_shapes, 1);
        assert!(geometry.warnings.is_empty(), "{:?}", geometry.warnings);
        let (lo, hi) = geometry.bounds.unwrap();
        // Inscribed triangles: the extremes are within the chord tolerance (0.1 / 20).
        assert!((lo - DVec3::new(-11.0, -1.0, -1.0)).abs().max_element() <= 0.005, "{lo}");
        assert!((hi - DVec3::new(11.0, 6.0, 1.0)).abs().max_element() <= 0.005, "{hi}");
        assert!((geometry.centre() - DVec3::new(0.0, 2.5, 0.0)).abs().max_element() <= 0.005);
        assert_eq!(geometry.mesh.origin(), geometry.centre());
        // Both touchable spheres are there, each with its own material; the ghost is not.
        let mut seen = [0usize; 3];
        for t in 0..geometry.mesh.triangle_count() {
            seen[geometry.mesh.material(t).0 as usize] += 1;
            let [a, _, _] = geometry.mesh.triangle_local(t);
            let world = geometry.mesh.world_from_local(a);
            // Chord error at most radius / 20 = 0.005 inside the unit spheres.
            let centre = if world.x > 0.0 { DVec3::new(10.0, 0.0, 0.0) } else { DVec3::new(-10.0, 0.0, 0.0) };
            assert!(((world - centre).length() - 1.0).abs() < 1e-4, "{world}");
        }
        assert!(seen[0] > 100 && seen[1] > 100 && seen[2] == 0, "{seen:?}");
        assert_eq!(geometry.materials[0].stiffness, Some(300.0));
        assert!(geometry.mesh.has_vertex_normals());
    }

    #[test]
    fn points_are_touched_as_spheres_of_their_width() {
        // RenderMan's default width is 1: a sphere of radius 1/2 around the point.
        let points = Shape::Points(rib_parser::scene::Points {
            positions: vec![glam::Vec3::ZERO],
            primvars: Default::default(),
        });
        let geometry = scene_geometry(
            &scene_with(vec![(points, DVec3::ZERO, HapticMaterial::default())]),
            &tessellation_tolerance(None),
        );
        assert!(geometry.warnings.is_empty(), "{:?}", geometry.warnings);
        assert!(geometry.mesh.triangle_count() > 100);
        for t in 0..geometry.mesh.triangle_count() {
            for p in geometry.mesh.triangle_local(t) {
                let r = geometry.mesh.world_from_local(p).length();
                assert!((r - 0.5).abs() < 1e-4, "{r}");
            }
        }
    }
}

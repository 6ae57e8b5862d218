//! Triangle meshes in object space, with the shading data the renderer uses.

use glam::{Vec2, Vec3};
use rib_parser::scene::{ParamValues, PolygonMesh, PrimVars, StorageClass};

/// Triangles with optional per-vertex shading normals and texture coordinates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// One normal per position (`N` primitive variable), when given.
    pub normals: Option<Vec<Vec3>>,
    /// One `(s, t)` per position, when given.
    pub st: Option<Vec<Vec2>>,
}

/// Why a mesh cannot be triangulated.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshError(pub String);

/// Per-vertex values of a primitive variable with `components` floats per vertex (vertex or
/// varying storage), when present and of the right length.
pub fn vertex_floats<'a>(
    primvars: &'a PrimVars,
    name: &str,
    components: usize,
    vertices: usize,
) -> Option<&'a [f32]> {
    let p = primvars.get(name)?;
    if !matches!(p.decl.class, StorageClass::Vertex | StorageClass::Varying) {
        return None;
    }
    match &p.values {
        ParamValues::Floats(v) if v.len() == components * vertices => Some(v),
        _ => None,
    }
}

/// Per-vertex `(s, t)` from `st`, or from separate `s` and `t`.
pub fn vertex_st(primvars: &PrimVars, vertices: usize) -> Option<Vec<Vec2>> {
    if let Some(st) = vertex_floats(primvars, "st", 2, vertices) {
        return Some(st.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect());
    }
    let s = vertex_floats(primvars, "s", 1, vertices)?;
    let t = vertex_floats(primvars, "t", 1, vertices)?;
    Some(s.iter().zip(t).map(|(&s, &t)| Vec2::new(s, t)).collect())
}

/// Triangulates polygons without holes by fans (exact for convex polygons, which is what
/// `Polygon` and `PointsPolygons` promise). Faces with holes are reported in the error.
pub fn triangulate_convex_polygons(mesh: &PolygonMesh) -> Result<TriangleMesh, MeshError> {
    let n = mesh.positions.len();
    let mut triangles = Vec::new();
    let mut loop_start = 0usize;
    for (loop_index, &loops) in mesh.loops_per_face.iter().enumerate() {
        if loops != 1 {
            return Err(MeshError("polygons with holes need the tessellator".into()));
        }
        let count =
            *mesh.vertices_per_loop.get(loop_index).ok_or_else(|| MeshError("loop count mismatch".into()))?
                as usize;
        let indices = mesh
            .vertex_indices
            .get(loop_start..loop_start + count)
            .ok_or_else(|| MeshError("vertex index count mismatch".into()))?;
        if indices.iter().any(|&i| i as usize >= n) {
            return Err(MeshError("vertex index out of range".into()));
        }
        for k in 1..count.saturating_sub(1) {
            triangles.push([indices[0], indices[k], indices[k + 1]]);
        }
        loop_start += count;
    }
    let normals = vertex_floats(&mesh.primvars, "N", 3, n)
        .map(|v| v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect());
    Ok(TriangleMesh {
        positions: mesh.positions.clone(),
        triangles,
        normals,
        st: vertex_st(&mesh.primvars, n),
    })
}

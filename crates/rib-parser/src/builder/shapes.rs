//! Geometry requests to [`Shape`]s, added to the world or the object being defined. The parser
//! has checked every count and index, so these only move data into place.

use super::transforms::snap_affine;
use super::{AttrState, SceneBuilder};
use crate::diagnostics::DiagnosticKind;
use crate::scene::*;
use crate::target::{Cx, NuPatchBasis, Quadric};
use glam::{Vec3, Vec4};
use std::sync::Arc;

/// Removes the parameter `name` from `params` and returns its floats.
fn take_floats(params: &mut ParamList, name: &str) -> Option<Vec<f32>> {
    let i = params.0.iter().position(|p| p.name == name)?;
    match params.0.remove(i).values {
        ParamValues::Floats(v) => Some(v),
        _ => None,
    }
}

fn vec3s(v: &[f32]) -> Vec<Vec3> {
    v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect()
}

/// Positions as 3-vectors: `P`, or `Pw` divided by `w`.
fn positions3(params: &mut ParamList) -> Vec<Vec3> {
    if let Some(p) = take_floats(params, "P") {
        return vec3s(&p);
    }
    if let Some(pw) = take_floats(params, "Pw") {
        return pw
            .chunks_exact(4)
            .map(
                |c| {
                    if c[3] != 0.0 { Vec3::new(c[0], c[1], c[2]) / c[3] } else { Vec3::new(c[0], c[1], c[2]) }
                },
            )
            .collect();
    }
    Vec::new()
}

/// Homogeneous positions: `P` with `w = 1`, `Pw` as given, or `Pz` over the unit square
/// (u varying fastest, `nu` by `nv` points).
fn positions4(params: &mut ParamList, nu: u32, nv: u32) -> Vec<Vec4> {
    if let Some(p) = take_floats(params, "P") {
        return p.chunks_exact(3).map(|c| Vec4::new(c[0], c[1], c[2], 1.0)).collect();
    }
    if let Some(pw) = take_floats(params, "Pw") {
        return pw.chunks_exact(4).map(|c| Vec4::new(c[0], c[1], c[2], c[3])).collect();
    }
    if let Some(pz) = take_floats(params, "Pz") {
        let fu = |i: u32| if nu > 1 { i as f32 / (nu - 1) as f32 } else { 0.0 };
        let fv = |j: u32| if nv > 1 { j as f32 / (nv - 1) as f32 } else { 0.0 };
        return pz
            .iter()
            .enumerate()
            .map(|(k, &z)| {
                let k = k as u32;
                Vec4::new(fu(k % nu.max(1)), fv(k / nu.max(1)), z, 1.0)
            })
            .collect();
    }
    Vec::new()
}

fn polygons_shape(
    loops_per_face: Vec<u32>,
    vertices_per_loop: Vec<u32>,
    vertex_indices: Vec<u32>,
    mut params: ParamList,
) -> Shape {
    let positions = positions3(&mut params);
    Shape::Polygons(PolygonMesh {
        loops_per_face,
        vertices_per_loop,
        vertex_indices,
        positions,
        primvars: params,
    })
}

fn patch_mesh_shape(
    kind: PatchKind,
    nu: u32,
    u_wrap: Wrap,
    nv: u32,
    v_wrap: Wrap,
    attrs: &AttrState,
    mut params: ParamList,
) -> Shape {
    let positions = positions4(&mut params, nu, nv);
    Shape::Patches(PatchMesh {
        kind,
        nu,
        nv,
        u_wrap,
        v_wrap,
        u_basis: attrs.u_basis,
        v_basis: attrs.v_basis,
        positions,
        primvars: params,
    })
}

fn nu_patch_shape(a: NuPatchBasis, trim: Option<Arc<TrimCurves>>, mut params: ParamList) -> Shape {
    let positions = positions4(&mut params, a.nu, a.nv);
    Shape::NuPatch(NuPatch { basis: a, positions, trim, primvars: params })
}

fn subdivision_mesh_shape(
    scheme: &str,
    vertices_per_face: Vec<u32>,
    vertex_indices: Vec<u32>,
    tags: Vec<SubdivisionTag>,
    mut params: ParamList,
) -> Shape {
    let positions = positions3(&mut params);
    Shape::SubdivisionMesh(SubdivisionMesh {
        scheme: scheme.to_string(),
        vertices_per_face,
        vertex_indices,
        tags,
        positions,
        primvars: params,
    })
}

fn quadric_shape(q: Quadric) -> Shape {
    match q {
        Quadric::Sphere { radius, z_min, z_max, theta_max } => {
            Shape::Sphere { radius, z_min, z_max, theta_max_degrees: theta_max }
        }
        Quadric::Cylinder { radius, z_min, z_max, theta_max } => {
            Shape::Cylinder { radius, z_min, z_max, theta_max_degrees: theta_max }
        }
        Quadric::Cone { height, radius, theta_max } => {
            Shape::Cone { height, radius, theta_max_degrees: theta_max }
        }
        Quadric::Disk { height, radius, theta_max } => {
            Shape::Disk { height, radius, theta_max_degrees: theta_max }
        }
        Quadric::Paraboloid { r_max, z_min, z_max, theta_max } => {
            Shape::Paraboloid { r_max, z_min, z_max, theta_max_degrees: theta_max }
        }
        Quadric::Hyperboloid { point1, point2, theta_max } => {
            Shape::Hyperboloid { point1, point2, theta_max_degrees: theta_max }
        }
        Quadric::Torus { major_radius, minor_radius, phi_min, phi_max, theta_max } => Shape::Torus {
            major_radius,
            minor_radius,
            phi_min_degrees: phi_min,
            phi_max_degrees: phi_max,
            theta_max_degrees: theta_max,
        },
    }
}

fn points_shape(mut params: ParamList) -> Shape {
    let positions = positions3(&mut params);
    Shape::Points(Points { positions, primvars: params })
}

fn curves_shape(
    cubic: bool,
    vertices_per_curve: Vec<u32>,
    wrap: Wrap,
    v_basis: Basis,
    mut params: ParamList,
) -> Shape {
    let positions = positions3(&mut params);
    Shape::Curves(Curves { cubic, vertices_per_curve, wrap, v_basis, positions, primvars: params })
}

impl SceneBuilder {
    /// Adds a shape made now to the world (or the object being defined).
    pub(super) fn add_shape(&mut self, shape: Shape, cx: &mut Cx<'_>) {
        self.add_shapes(vec![shape], cx);
    }

    /// Shapes made by one request (`Geometry "teapot"` makes 32): one motion sample. Inside a
    /// motion block the first geometry request is added now and the later ones are kept as its
    /// deformation keys (`deform.rs`).
    pub(super) fn add_shapes(&mut self, shapes: Vec<Shape>, cx: &mut Cx<'_>) {
        if let Some(m) = &mut self.motion {
            m.others += 1;
            if m.others > 1 {
                if m.first_is_geometry {
                    m.later_shapes.push((shapes, cx.loc.clone()));
                }
                return;
            }
            m.first_is_geometry = true;
            let in_world = self.recording.is_none() && self.world.is_some();
            let first = self.world.as_ref().map(|w| w.shapes.len());
            if let Some(m) = &mut self.motion {
                m.first_shapes = first.filter(|_| in_world);
            }
        }
        for shape in shapes {
            self.push_shape(shape, cx);
        }
    }

    fn push_shape(&mut self, shape: Shape, cx: &mut Cx<'_>) {
        let in_solid = self.solid_depth > 0;
        if self.recording.is_some() && self.gs.motion.is_some() {
            self.warn_once(
                "motion-in-object",
                cx,
                DiagnosticKind::Unsupported,
                "motion blur inside ObjectBegin/ObjectEnd is not supported: the shape is placed at shutter open (move the ObjectInstance instead)",
            );
        }
        if let Some(def) = &mut self.recording {
            def.add_shape(
                Arc::new(shape),
                self.gs.ctm,
                self.gs.attrs.attrs.clone(),
                in_solid,
                cx.loc.clone(),
            );
            return;
        }
        if !self.in_world() {
            cx.error(DiagnosticKind::Nesting, "geometry outside WorldBegin/WorldEnd is ignored");
            return;
        }
        let attributes = self.intern_attributes();
        // A projective transformation (`Perspective` inside the world) is kept as given: every
        // consumer places shapes through it exactly (tessellate's `transform_mesh`).
        let world_from_object = snap_affine(self.gs.ctm);
        let motion = self.gs.motion.clone();
        if let Some(world) = self.world_mut() {
            if let Some(&solid) = world.open_solids.last() {
                let index = world.shapes.len() as u32;
                world.solids[solid as usize].parts.push(SolidPart::Shape(index));
            }
            world.shapes.push(ShapeEntity {
                shape: Arc::new(shape),
                world_from_object,
                motion,
                deformation: None,
                attributes,
                in_solid,
                loc: cx.loc.clone(),
            });
        }
    }

    pub(super) fn polygon(&mut self, vertex_count: u32, params: ParamList, cx: &mut Cx<'_>) {
        let shape = polygons_shape(vec![1], vec![vertex_count], (0..vertex_count).collect(), params);
        self.add_shape(shape, cx);
    }

    pub(super) fn general_polygon(
        &mut self,
        vertices_per_loop: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        let total: u32 = vertices_per_loop.iter().sum();
        let loops = vertices_per_loop.len() as u32;
        let shape = polygons_shape(vec![loops], vertices_per_loop, (0..total).collect(), params);
        self.add_shape(shape, cx);
    }

    pub(super) fn points_polygons(
        &mut self,
        vertices_per_face: Vec<u32>,
        vertex_indices: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        let loops = vec![1; vertices_per_face.len()];
        self.add_shape(polygons_shape(loops, vertices_per_face, vertex_indices, params), cx);
    }

    pub(super) fn points_general_polygons(
        &mut self,
        loops_per_face: Vec<u32>,
        vertices_per_loop: Vec<u32>,
        vertex_indices: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        self.add_shape(polygons_shape(loops_per_face, vertices_per_loop, vertex_indices, params), cx);
    }

    pub(super) fn patch(&mut self, kind: PatchKind, params: ParamList, cx: &mut Cx<'_>) {
        let (nu, nv) = if kind == PatchKind::Bilinear { (2, 2) } else { (4, 4) };
        let shape =
            patch_mesh_shape(kind, nu, Wrap::NonPeriodic, nv, Wrap::NonPeriodic, &self.gs.attrs, params);
        self.add_shape(shape, cx);
    }

    // The request's own arguments, as `RibTarget::patch_mesh` takes them.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn patch_mesh(
        &mut self,
        kind: PatchKind,
        nu: u32,
        u_wrap: Wrap,
        nv: u32,
        v_wrap: Wrap,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        let shape = patch_mesh_shape(kind, nu, u_wrap, nv, v_wrap, &self.gs.attrs, params);
        self.add_shape(shape, cx);
    }

    pub(super) fn nu_patch(&mut self, patch: NuPatchBasis, params: ParamList, cx: &mut Cx<'_>) {
        let shape = nu_patch_shape(patch, self.gs.attrs.trim.clone(), params);
        self.add_shape(shape, cx);
    }

    pub(super) fn subdivision_mesh(
        &mut self,
        scheme: &str,
        vertices_per_face: Vec<u32>,
        vertex_indices: Vec<u32>,
        tags: Vec<SubdivisionTag>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        if scheme != "catmull-clark" {
            cx.warn(
                DiagnosticKind::Unsupported,
                format!(
                    "SubdivisionMesh scheme \"{scheme}\" is kept, but only \"catmull-clark\" is tessellated"
                ),
            );
        }
        let shape = subdivision_mesh_shape(scheme, vertices_per_face, vertex_indices, tags, params);
        self.add_shape(shape, cx);
    }

    pub(super) fn quadric(&mut self, q: Quadric, _params: ParamList, cx: &mut Cx<'_>) {
        self.add_shape(quadric_shape(q), cx);
    }

    pub(super) fn points(&mut self, params: ParamList, cx: &mut Cx<'_>) {
        self.add_shape(points_shape(params), cx);
    }

    pub(super) fn curves(
        &mut self,
        cubic: bool,
        vertices_per_curve: Vec<u32>,
        wrap: Wrap,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        let shape = curves_shape(cubic, vertices_per_curve, wrap, self.gs.attrs.v_basis, params);
        self.add_shape(shape, cx);
    }

    pub(super) fn blobby(&mut self, blobby: crate::scene::Blobby, cx: &mut Cx<'_>) {
        self.add_shape(Shape::Blobby(blobby), cx);
    }
}

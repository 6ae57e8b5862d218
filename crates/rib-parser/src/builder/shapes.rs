//! Geometry requests to [`Shape`]s. The parser has checked every count and index, so these
//! only move data into place.

use super::AttrState;
use crate::scene::*;
use crate::target::{NuPatchArgs, Quadric};
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

pub(super) fn polygons(
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

pub(super) fn patch_mesh(
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

pub(super) fn nu_patch(a: NuPatchArgs, trim: Option<Arc<TrimCurves>>, mut params: ParamList) -> Shape {
    let positions = positions4(&mut params, a.nu, a.nv);
    Shape::NuPatch(NuPatch {
        nu: a.nu,
        u_order: a.u_order,
        u_knots: a.u_knots,
        u_min: a.u_min,
        u_max: a.u_max,
        nv: a.nv,
        v_order: a.v_order,
        v_knots: a.v_knots,
        v_min: a.v_min,
        v_max: a.v_max,
        positions,
        trim,
        primvars: params,
    })
}

pub(super) fn subdivision_mesh(
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

pub(super) fn quadric(q: Quadric) -> Shape {
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

pub(super) fn points(mut params: ParamList) -> Shape {
    let positions = positions3(&mut params);
    Shape::Points(Points { positions, primvars: params })
}

pub(super) fn curves(
    cubic: bool,
    vertices_per_curve: Vec<u32>,
    wrap: Wrap,
    v_basis: Basis,
    mut params: ParamList,
) -> Shape {
    let positions = positions3(&mut params);
    Shape::Curves(Curves { cubic, vertices_per_curve, wrap, v_basis, positions, primvars: params })
}

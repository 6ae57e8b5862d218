//! Geometric primitives: positional arguments, sizes, and parameter counts per storage class
//! (RISpec 3.2 §5 and its table of primitive variable counts).

use super::{PResult, ParamContext, PeekKind, Reader, Stop};
use crate::diagnostics::DiagnosticKind;
use crate::params::ClassCounts;
use crate::scene::{
    FileLoc, ParamList, ParamValues, PatchKind, SubdivisionTag, TrimCurves, Wrap, decode_hierarchical_edits,
    is_hierarchical_edit,
};
use crate::target::{NuPatchBasis, Quadric, RibTarget};
use glam::Vec3;

fn sum(v: &[u32]) -> u64 {
    v.iter().map(|&x| u64::from(x)).sum()
}

fn usize_of(v: u64) -> usize {
    usize::try_from(v).unwrap_or(usize::MAX)
}

impl Reader {
    fn bad(&mut self, loc: &FileLoc, message: String) -> Stop {
        self.diagnostics.error(DiagnosticKind::BadValue, loc, message);
        Stop
    }

    /// Number of vertices given by the position parameter (`P`, `Pw`, or `Pz` where allowed),
    /// after checking its value count is a whole number of points and its values are finite.
    fn vertex_count(
        &mut self,
        request: &str,
        params: &ParamList,
        loc: &FileLoc,
        allow_pz: bool,
    ) -> PResult<usize> {
        let names: &[(&str, usize)] =
            if allow_pz { &[("P", 3), ("Pw", 4), ("Pz", 1)] } else { &[("P", 3), ("Pw", 4)] };
        for &(name, per) in names {
            let Some(p) = params.get(name) else { continue };
            let ParamValues::Floats(values) = &p.values else {
                return Err(self.bad(&p.loc, format!("{request}: \"{name}\" must have numeric values")));
            };
            let per = per * p.decl.array_len as usize;
            if values.len() % per != 0 {
                let ploc = p.loc.clone();
                return Err(self.bad(
                    &ploc,
                    format!("{request}: \"{name}\" has {} values, not a multiple of {per}", values.len()),
                ));
            }
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                let ploc = p.loc.clone();
                return Err(
                    self.bad(&ploc, format!("{request}: \"{name}\" value {i} is not a finite number"))
                );
            }
            return Ok(values.len() / per);
        }
        let what = if allow_pz { "\"P\", \"Pw\" or \"Pz\"" } else { "\"P\" or \"Pw\"" };
        Err(self.bad(loc, format!("{request}: no positions given (needs {what})")))
    }

    /// Checks vertex indices against the number of vertices.
    fn check_indices(
        &mut self,
        request: &str,
        indices: &[u32],
        vertices: usize,
        loc: &FileLoc,
    ) -> PResult<()> {
        if let Some((i, &bad)) = indices.iter().enumerate().find(|&(_, &v)| v as usize >= vertices) {
            return Err(self.bad(
                loc,
                format!("{request}: vertex index {bad} (entry {i}) is out of range: only {vertices} vertices are given"),
            ));
        }
        Ok(())
    }

    fn geometry_params(&mut self, request: &str) -> PResult<ParamList> {
        self.param_list(request, ParamContext::Geometry, None)
    }

    pub(crate) fn geometry<T: RibTarget + ?Sized>(
        &mut self,
        name: &str,
        loc: &FileLoc,
        t: &mut T,
    ) -> PResult<()> {
        let r = name;
        let loc = loc.clone();
        match name {
            "Polygon" => {
                let params = self.geometry_params(r)?;
                let n = self.vertex_count(r, &params, &loc, false)?;
                if n < 3 {
                    return Err(
                        self.bad(&loc, format!("Polygon: a polygon needs at least 3 vertices, got {n}"))
                    );
                }
                let counts = polygon_counts(n);
                self.check_counts(r, &params, &counts)?;
                t.polygon(n as u32, params, &mut self.cx(loc));
            }
            "GeneralPolygon" => {
                let nverts = self.arg_count_array(r, "the vertices per loop")?;
                let params = self.geometry_params(r)?;
                let n = self.vertex_count(r, &params, &loc, false)?;
                if nverts.is_empty() || nverts.contains(&0) {
                    return Err(
                        self.bad(&loc, "GeneralPolygon: needs at least one loop, and no empty loop".into())
                    );
                }
                let total = usize_of(sum(&nverts));
                if total != n {
                    return Err(self.bad(
                        &loc,
                        format!(
                            "GeneralPolygon: the loops have {total} vertices but {n} positions are given"
                        ),
                    ));
                }
                self.check_counts(r, &params, &polygon_counts(n))?;
                t.general_polygon(nverts, params, &mut self.cx(loc));
            }
            "PointsPolygons" => {
                let nverts = self.arg_count_array(r, "the vertices per polygon")?;
                let verts = self.arg_count_array(r, "the vertex indices")?;
                let params = self.geometry_params(r)?;
                let total = usize_of(sum(&nverts));
                if total != verts.len() {
                    return Err(self.bad(
                        &loc,
                        format!(
                            "PointsPolygons: the {} polygons have {total} vertices in all, but {} vertex indices are given",
                            nverts.len(),
                            verts.len()
                        ),
                    ));
                }
                let n = self.vertex_count(r, &params, &loc, false)?;
                self.check_indices(r, &verts, n, &loc)?;
                let counts = mesh_counts(nverts.len(), n, verts.len());
                self.check_counts(r, &params, &counts)?;
                t.points_polygons(nverts, verts, params, &mut self.cx(loc));
            }
            "PointsGeneralPolygons" => {
                let nloops = self.arg_count_array(r, "the loops per polygon")?;
                let nverts = self.arg_count_array(r, "the vertices per loop")?;
                let verts = self.arg_count_array(r, "the vertex indices")?;
                let params = self.geometry_params(r)?;
                let loops = usize_of(sum(&nloops));
                if loops != nverts.len() {
                    return Err(self.bad(
                        &loc,
                        format!("PointsGeneralPolygons: the polygons have {loops} loops but {} loop sizes are given", nverts.len()),
                    ));
                }
                let total = usize_of(sum(&nverts));
                if total != verts.len() {
                    return Err(self.bad(
                        &loc,
                        format!("PointsGeneralPolygons: the loops have {total} vertices but {} vertex indices are given", verts.len()),
                    ));
                }
                let n = self.vertex_count(r, &params, &loc, false)?;
                self.check_indices(r, &verts, n, &loc)?;
                let counts = mesh_counts(nloops.len(), n, verts.len());
                self.check_counts(r, &params, &counts)?;
                t.points_general_polygons(nloops, nverts, verts, params, &mut self.cx(loc));
            }
            "Patch" => {
                let kind = self.patch_kind(r)?;
                let params = self.geometry_params(r)?;
                let n = self.vertex_count(r, &params, &loc, true)?;
                let need = if kind == PatchKind::Bilinear { 4 } else { 16 };
                if n != need {
                    return Err(self.bad(
                        &loc,
                        format!("Patch: a {} patch needs {need} control points, got {n}", kind_name(kind)),
                    ));
                }
                let counts = ClassCounts {
                    constant: 1,
                    uniform: 1,
                    varying: 4,
                    vertex: need,
                    face_varying: 4,
                    face_vertex: 4,
                };
                self.check_counts(r, &params, &counts)?;
                t.patch(kind, params, &mut self.cx(loc));
            }
            "PatchMesh" => {
                let kind = self.patch_kind(r)?;
                let nu = self.arg_count(r, "nu")?;
                let u_wrap = self.wrap(r, "the u wrap mode")?;
                let nv = self.arg_count(r, "nv")?;
                let v_wrap = self.wrap(r, "the v wrap mode")?;
                let params = self.geometry_params(r)?;
                let scope = self.scope();
                let (u_steps, v_steps) = match kind {
                    PatchKind::Bilinear => (1, 1),
                    PatchKind::Bicubic => (scope.u_step, scope.v_step),
                };
                let nu_patches = patches_along(kind, nu, u_wrap, u_steps)
                    .map_err(|m| self.bad(&loc, format!("PatchMesh: in u, {m}")))?;
                let nv_patches = patches_along(kind, nv, v_wrap, v_steps)
                    .map_err(|m| self.bad(&loc, format!("PatchMesh: in v, {m}")))?;
                let n = self.vertex_count(r, &params, &loc, true)?;
                let expected = nu as u64 * nv as u64;
                if n as u64 != expected {
                    return Err(
                        self.bad(&loc, format!("PatchMesh: {nu} x {nv} control points expected, {n} given"))
                    );
                }
                let uniform = nu_patches * nv_patches;
                let vary_u = if u_wrap == Wrap::Periodic { nu_patches } else { nu_patches + 1 };
                let vary_v = if v_wrap == Wrap::Periodic { nv_patches } else { nv_patches + 1 };
                let counts = ClassCounts {
                    constant: 1,
                    uniform,
                    varying: vary_u * vary_v,
                    vertex: n,
                    face_varying: 4 * uniform,
                    face_vertex: 4 * uniform,
                };
                self.check_patch_counts(r, &params, counts)?;
                t.patch_mesh(kind, nu, u_wrap, nv, v_wrap, params, &mut self.cx(loc));
            }
            "NuPatch" => self.nu_patch(&loc, t)?,
            "SubdivisionMesh" => self.subdivision_mesh(&loc, t, false)?,
            "HierarchicalSubdivisionMesh" => self.subdivision_mesh(&loc, t, true)?,
            "Sphere" | "Cylinder" | "Paraboloid" => {
                let [a, b, c, d] = self.arg_f32s::<4>(r, "the quadric's 4 arguments")?;
                let q = match name {
                    "Sphere" => Quadric::Sphere { radius: a, z_min: b, z_max: c, theta_max: d },
                    "Cylinder" => Quadric::Cylinder { radius: a, z_min: b, z_max: c, theta_max: d },
                    _ => Quadric::Paraboloid { r_max: a, z_min: b, z_max: c, theta_max: d },
                };
                self.finish_quadric(r, q, &[a, b, c, d], &loc, t)?;
            }
            "Cone" | "Disk" => {
                let [a, b, c] = self.arg_f32s::<3>(r, "height radius thetamax")?;
                let q = if name == "Cone" {
                    Quadric::Cone { height: a, radius: b, theta_max: c }
                } else {
                    Quadric::Disk { height: a, radius: b, theta_max: c }
                };
                self.finish_quadric(r, q, &[a, b, c], &loc, t)?;
            }
            "Hyperboloid" => {
                let v = self.arg_f32s::<7>(r, "x1 y1 z1 x2 y2 z2 thetamax")?;
                let q = Quadric::Hyperboloid {
                    point1: Vec3::new(v[0], v[1], v[2]),
                    point2: Vec3::new(v[3], v[4], v[5]),
                    theta_max: v[6],
                };
                self.finish_quadric(r, q, &v, &loc, t)?;
            }
            "Torus" => {
                let v = self.arg_f32s::<5>(r, "majorradius minorradius phimin phimax thetamax")?;
                let q = Quadric::Torus {
                    major_radius: v[0],
                    minor_radius: v[1],
                    phi_min: v[2],
                    phi_max: v[3],
                    theta_max: v[4],
                };
                self.finish_quadric(r, q, &v, &loc, t)?;
            }
            "Points" => {
                let params = self.geometry_params(r)?;
                let n = self.vertex_count(r, &params, &loc, false)?;
                let counts = ClassCounts {
                    constant: 1,
                    uniform: 1,
                    varying: n,
                    vertex: n,
                    face_varying: n,
                    face_vertex: n,
                };
                self.check_counts(r, &params, &counts)?;
                t.points(params, &mut self.cx(loc));
            }
            "Curves" => {
                let kind = self.arg_string(r, "the curve type")?;
                let cubic = match kind.as_str() {
                    "linear" => false,
                    "cubic" => true,
                    other => {
                        return Err(self.bad(
                            &loc,
                            format!("Curves: type must be \"linear\" or \"cubic\", got \"{other}\""),
                        ));
                    }
                };
                let nverts = self.arg_count_array(r, "the vertices per curve")?;
                let wrap = self.wrap(r, "the wrap mode")?;
                let params = self.geometry_params(r)?;
                let n = self.vertex_count(r, &params, &loc, false)?;
                let total = usize_of(sum(&nverts));
                if total != n {
                    return Err(self.bad(
                        &loc,
                        format!("Curves: the curves have {total} vertices but {n} positions are given"),
                    ));
                }
                let step = self.scope().v_step;
                let mut varying = 0usize;
                for (i, &nv) in nverts.iter().enumerate() {
                    let segs = if cubic {
                        patches_along(PatchKind::Bicubic, nv, wrap, step)
                            .map_err(|m| self.bad(&loc, format!("Curves: curve {i}: {m}")))?
                    } else {
                        if nv < 2 {
                            return Err(self
                                .bad(&loc, format!("Curves: curve {i} has {nv} vertices; a curve needs 2")));
                        }
                        if wrap == Wrap::Periodic { nv as usize } else { nv as usize - 1 }
                    };
                    varying += if wrap == Wrap::Periodic { segs } else { segs + 1 };
                }
                let counts = ClassCounts {
                    constant: 1,
                    uniform: nverts.len(),
                    varying,
                    vertex: n,
                    face_varying: varying,
                    face_vertex: varying,
                };
                self.check_counts(r, &params, &counts)?;
                t.curves(cubic, nverts, wrap, params, &mut self.cx(loc));
            }
            "Blobby" => {
                let leaf_count = self.arg_count(r, "the number of leaves")?;
                let code = self.arg_int_array(r, "the code array")?;
                let floats = self.arg_float_array(r, "the float array")?;
                let strings = self.arg_string_array(r, "the string array")?;
                let params = self.geometry_params(r)?;
                if let Some(i) = floats.iter().position(|v| !v.is_finite()) {
                    return Err(self.bad(&loc, format!("Blobby: float {i} is not a finite number")));
                }
                crate::blobby::decode_blobby(leaf_count, &code, floats.len(), strings.len())
                    .map_err(|m| self.bad(&loc, format!("Blobby: {m}")))?;
                let n = leaf_count as usize;
                let counts = ClassCounts {
                    constant: 1,
                    uniform: 1,
                    varying: n,
                    vertex: n,
                    face_varying: n,
                    face_vertex: n,
                };
                self.check_counts(r, &params, &counts)?;
                t.blobby(
                    crate::scene::Blobby { leaf_count, code, floats, strings, primvars: params },
                    &mut self.cx(loc),
                );
            }
            "Geometry" => {
                let kind = self.arg_string(r, "the geometry type")?;
                let params = self.param_list(r, ParamContext::Call, Some(("Geometry", &kind)))?;
                t.geometry(&kind, params, &mut self.cx(loc));
            }
            "Procedural" => self.procedural(&loc, t)?,
            _ => {}
        }
        Ok(())
    }

    /// Patch meshes: `facevarying` is accepted with either one value per patch corner or
    /// with the `varying` count (renderers differ).
    fn check_patch_counts(&mut self, request: &str, params: &ParamList, counts: ClassCounts) -> PResult<()> {
        let mut alt = counts;
        alt.face_varying = counts.varying;
        alt.face_vertex = counts.varying;
        let face_varying_ok_either = params.0.iter().all(|p| {
            !matches!(
                p.decl.class,
                crate::scene::StorageClass::FaceVarying | crate::scene::StorageClass::FaceVertex
            )
        });
        if face_varying_ok_either {
            return self.check_counts(request, params, &counts);
        }
        let mut diags = std::mem::take(&mut self.diagnostics);
        let first = self.check_counts(request, params, &counts);
        std::mem::swap(&mut diags, &mut self.diagnostics);
        if first.is_ok() {
            return Ok(());
        }
        self.check_counts(request, params, &alt)
    }

    fn finish_quadric<T: RibTarget + ?Sized>(
        &mut self,
        request: &str,
        q: Quadric,
        args: &[f32],
        loc: &FileLoc,
        t: &mut T,
    ) -> PResult<()> {
        if args.iter().any(|v| !v.is_finite()) {
            return Err(self.bad(loc, format!("{request}: arguments must be finite numbers")));
        }
        let params = self.geometry_params(request)?;
        let counts =
            ClassCounts { constant: 1, uniform: 1, varying: 4, vertex: 4, face_varying: 4, face_vertex: 4 };
        self.check_counts(request, &params, &counts)?;
        t.quadric(q, params, &mut self.cx(loc.clone()));
        Ok(())
    }

    fn patch_kind(&mut self, request: &str) -> PResult<PatchKind> {
        let start = self.peek_start();
        let kind = self.arg_string(request, "the patch type")?;
        match kind.as_str() {
            "bilinear" => Ok(PatchKind::Bilinear),
            "bicubic" => Ok(PatchKind::Bicubic),
            other => {
                let loc = self.loc(start);
                Err(self.bad(
                    &loc,
                    format!("{request}: type must be \"bilinear\" or \"bicubic\", got \"{other}\""),
                ))
            }
        }
    }

    fn wrap(&mut self, request: &str, what: &str) -> PResult<Wrap> {
        let start = self.peek_start();
        let w = self.arg_string(request, what)?;
        match w.as_str() {
            "periodic" => Ok(Wrap::Periodic),
            "nonperiodic" => Ok(Wrap::NonPeriodic),
            other => {
                let loc = self.loc(start);
                Err(self.bad(
                    &loc,
                    format!("{request}: {what} must be \"periodic\" or \"nonperiodic\", got \"{other}\""),
                ))
            }
        }
    }

    fn nu_patch<T: RibTarget + ?Sized>(&mut self, loc: &FileLoc, t: &mut T) -> PResult<()> {
        let r = "NuPatch";
        let nu = self.arg_count(r, "nu")?;
        let u_order = self.arg_count(r, "uorder")?;
        let u_knots = self.arg_float_array(r, "uknot")?;
        let [u_min, u_max] = self.arg_f32s::<2>(r, "umin umax")?;
        let nv = self.arg_count(r, "nv")?;
        let v_order = self.arg_count(r, "vorder")?;
        let v_knots = self.arg_float_array(r, "vknot")?;
        let [v_min, v_max] = self.arg_f32s::<2>(r, "vmin vmax")?;
        let params = self.geometry_params(r)?;
        for (dir, n, order, knots) in [("u", nu, u_order, &u_knots), ("v", nv, v_order, &v_knots)] {
            if order == 0 || n < order {
                return Err(self.bad(loc, format!("NuPatch: in {dir}, order {order} needs 1 <= order <= {n} (the number of control points)")));
            }
            let need = n as usize + order as usize;
            if knots.len() != need {
                return Err(self
                    .bad(loc, format!("NuPatch: {dir} has {} knots, but n + order = {need}", knots.len())));
            }
            if knots.windows(2).any(|w| w[0].partial_cmp(&w[1]).is_none_or(|o| o.is_gt())) {
                return Err(
                    self.bad(loc, format!("NuPatch: the {dir} knots are not in non-decreasing order"))
                );
            }
        }
        let n = self.vertex_count(r, &params, loc, false)?;
        if n as u64 != nu as u64 * nv as u64 {
            return Err(self.bad(loc, format!("NuPatch: {nu} x {nv} control points expected, {n} given")));
        }
        let su = (nu - u_order + 1) as usize;
        let sv = (nv - v_order + 1) as usize;
        let counts = ClassCounts {
            constant: 1,
            uniform: su * sv,
            varying: (su + 1) * (sv + 1),
            vertex: n,
            face_varying: 4 * su * sv,
            face_vertex: 4 * su * sv,
        };
        self.check_patch_counts(r, &params, counts)?;
        let args = NuPatchBasis { nu, u_order, u_knots, u_min, u_max, nv, v_order, v_knots, v_min, v_max };
        t.nu_patch(args, params, &mut self.cx(loc.clone()));
        Ok(())
    }

    pub(crate) fn trim_curve<T: RibTarget + ?Sized>(&mut self, loc: &FileLoc, t: &mut T) -> PResult<()> {
        let r = "TrimCurve";
        let curves_per_loop = self.arg_count_array(r, "ncurves")?;
        let order = self.arg_count_array(r, "order")?;
        let knots = self.arg_float_array(r, "knot")?;
        let min = self.arg_float_array(r, "min")?;
        let max = self.arg_float_array(r, "max")?;
        let n = self.arg_count_array(r, "n")?;
        let u = self.arg_float_array(r, "u")?;
        let v = self.arg_float_array(r, "v")?;
        let w = self.arg_float_array(r, "w")?;
        let curves = usize_of(sum(&curves_per_loop));
        if [order.len(), min.len(), max.len(), n.len()].iter().any(|&l| l != curves) {
            return Err(self.bad(
                loc,
                format!(
                    "TrimCurve: {curves} curves, but order, min, max and n have {}, {}, {} and {} entries",
                    order.len(),
                    min.len(),
                    max.len(),
                    n.len()
                ),
            ));
        }
        if let Some(i) = (0..curves).find(|&i| order[i] == 0 || n[i] < order[i]) {
            return Err(self.bad(
                loc,
                format!("TrimCurve: curve {i} has order {} with {} control points", order[i], n[i]),
            ));
        }
        let knot_count = usize_of(sum(&n) + sum(&order));
        if knots.len() != knot_count {
            return Err(self.bad(loc, format!("TrimCurve: {} knots given, {knot_count} needed", knots.len())));
        }
        let points = usize_of(sum(&n));
        if u.len() != points || v.len() != points || w.len() != points {
            return Err(self.bad(
                loc,
                format!(
                    "TrimCurve: {points} control points, but u, v and w have {}, {} and {} values",
                    u.len(),
                    v.len(),
                    w.len()
                ),
            ));
        }
        t.trim_curve(
            TrimCurves { curves_per_loop, order, knots, min, max, n, u, v, w },
            &mut self.cx(loc.clone()),
        );
        Ok(())
    }

    /// `SubdivisionMesh`, or PRMan's `HierarchicalSubdivisionMesh` (`hierarchical`), which
    /// always gives three argument counts per tag and the tags' string arguments, and may
    /// carry hierarchical edits; it becomes a `SubdivisionMesh` whose tags keep the edits the
    /// tessellator applies.
    fn subdivision_mesh<T: RibTarget + ?Sized>(
        &mut self,
        loc: &FileLoc,
        t: &mut T,
        hierarchical: bool,
    ) -> PResult<()> {
        let r = if hierarchical { "HierarchicalSubdivisionMesh" } else { "SubdivisionMesh" };
        let scheme = self.arg_string(r, "the scheme")?;
        let nverts = self.arg_count_array(r, "the vertices per face")?;
        let verts = self.arg_count_array(r, "the vertex indices")?;
        let mut tags = Vec::new();
        // The tag arrays are optional in practice (several writers stop after the indices).
        if self.peek(0) == Some(PeekKind::ArrayBegin) {
            let names = self.arg_string_array(r, "the tags")?;
            let nargs = self.arg_int_array(r, "the tag argument counts")?;
            let ints = self.arg_int_array(r, "the tag integer arguments")?;
            let floats = self.arg_float_array(r, "the tag float arguments")?;
            let with_strings = hierarchical || (!names.is_empty() && nargs.len() == 3 * names.len());
            let per_tag = if with_strings { 3 } else { 2 };
            if nargs.len() != per_tag * names.len() {
                return Err(self.bad(
                    loc,
                    format!(
                        "{r}: {} tags need {} argument counts, got {}",
                        names.len(),
                        per_tag * names.len(),
                        nargs.len()
                    ),
                ));
            }
            let strings =
                if with_strings { self.arg_string_array(r, "the tag string arguments")? } else { Vec::new() };
            let per = if with_strings { 3 } else { 2 };
            let (mut ii, mut fi, mut si) = (0usize, 0usize, 0usize);
            for (k, name) in names.into_iter().enumerate() {
                let counts: Vec<usize> =
                    (0..per).map(|j| usize::try_from(nargs[k * per + j]).unwrap_or(usize::MAX)).collect();
                let (ni, nf) = (counts[0], counts[1]);
                let ns = if with_strings { counts[2] } else { 0 };
                let (Some(ie), Some(fe), Some(se)) =
                    (ii.checked_add(ni), fi.checked_add(nf), si.checked_add(ns))
                else {
                    return Err(self.bad(loc, format!("{r}: tag argument counts overflow")));
                };
                if ie > ints.len() || fe > floats.len() || se > strings.len() {
                    return Err(
                        self.bad(loc, format!("{r}: tag \"{name}\" asks for more arguments than are given"))
                    );
                }
                tags.push(SubdivisionTag {
                    name,
                    int_args: ints[ii..ie].to_vec(),
                    float_args: floats[fi..fe].to_vec(),
                    string_args: strings[si..se].to_vec(),
                });
                (ii, fi, si) = (ie, fe, se);
            }
            if ii != ints.len() || fi != floats.len() || (hierarchical && si != strings.len()) {
                return Err(self.bad(loc, format!("{r}: more tag arguments are given than the tags use")));
            }
        }
        // The writer writes edits as a `SubdivisionMesh` with string arguments: read back, they
        // are checked alike.
        tags = self.supported_hierarchical_edits(r, tags, &nverts, loc);
        let params = self.geometry_params(r)?;
        let total = usize_of(sum(&nverts));
        if total != verts.len() {
            return Err(self.bad(
                loc,
                format!(
                    "{r}: the {} faces have {total} vertices in all, but {} indices are given",
                    nverts.len(),
                    verts.len()
                ),
            ));
        }
        let n = self.vertex_count(r, &params, loc, false)?;
        self.check_indices(r, &verts, n, loc)?;
        for tag in &tags {
            if matches!(tag.name.as_str(), "crease" | "corner")
                && let Some(bad) = tag.int_args.iter().find(|&&i| i < 0 || i as usize >= n)
            {
                return Err(
                    self.bad(loc, format!("{r}: \"{}\" tag refers to vertex {bad}, out of range", tag.name))
                );
            }
            if tag.name == "hole"
                && let Some(bad) = tag.int_args.iter().find(|&&i| i < 0 || i as usize >= nverts.len())
            {
                return Err(self.bad(loc, format!("{r}: \"hole\" tag refers to face {bad}, out of range")));
            }
        }
        let counts = mesh_counts(nverts.len(), n, verts.len());
        self.check_counts(r, &params, &counts)?;
        t.subdivision_mesh(&scheme, nverts, verts, tags, params, &mut self.cx(loc.clone()));
        Ok(())
    }

    /// Keeps the hierarchical edits of a `HierarchicalSubdivisionMesh` the tessellator applies
    /// (`P` values, vertex and edge sharpness, holes: `scene::decode_hierarchical_edits`) and
    /// drops the others with a warning that says why.
    fn supported_hierarchical_edits(
        &mut self,
        r: &str,
        tags: Vec<SubdivisionTag>,
        vertices_per_face: &[u32],
        loc: &FileLoc,
    ) -> Vec<SubdivisionTag> {
        let mut kept = Vec::with_capacity(tags.len());
        for tag in tags {
            if !is_hierarchical_edit(&tag.name) {
                kept.push(tag);
                continue;
            }
            match decode_hierarchical_edits(&tag, vertices_per_face) {
                Ok(_) => kept.push(tag),
                Err(why) => self.diagnostics.warn(
                    DiagnosticKind::Unsupported,
                    loc,
                    format!(
                        "{r}: hierarchical edit \"{}\" skipped: {why}; the surface is drawn without it",
                        tag.name
                    ),
                ),
            }
        }
        kept
    }

    fn procedural<T: RibTarget + ?Sized>(&mut self, loc: &FileLoc, t: &mut T) -> PResult<()> {
        let r = "Procedural";
        let kind = self.arg_string(r, "the procedural type")?;
        let args = self.arg_string_array(r, "the procedural's arguments")?;
        let bound = if matches!(self.peek(0), Some(PeekKind::ArrayBegin | PeekKind::Number)) {
            self.arg_f32s::<6>(r, "the bound")?
        } else {
            [0.0; 6]
        };
        match kind.as_str() {
            "DelayedReadArchive" => {
                let Some(file) = args.first() else {
                    return Err(self.bad(loc, "Procedural \"DelayedReadArchive\" needs a file name".into()));
                };
                let file = file.clone();
                self.read_archive(&file, loc)?;
            }
            "RunProgram" | "DynamicLoad" => {
                let program = args.first().cloned().unwrap_or_default();
                self.diagnostics.warn(
                    DiagnosticKind::Refused,
                    loc,
                    format!("Procedural \"{kind}\" would run '{program}'; refused (scenes never execute programs), its geometry is missing"),
                );
            }
            _ => t.procedural(&kind, args, bound, &mut self.cx(loc.clone())),
        }
        Ok(())
    }
}

fn kind_name(kind: PatchKind) -> &'static str {
    match kind {
        PatchKind::Bilinear => "bilinear",
        PatchKind::Bicubic => "bicubic",
    }
}

/// Counts for one polygon of `n` vertices.
fn polygon_counts(n: usize) -> ClassCounts {
    ClassCounts { constant: 1, uniform: 1, varying: n, vertex: n, face_varying: n, face_vertex: n }
}

/// Counts for a polygon or subdivision mesh: `faces` faces over `vertices` vertices with
/// `corners` face corners in all.
fn mesh_counts(faces: usize, vertices: usize, corners: usize) -> ClassCounts {
    ClassCounts {
        constant: 1,
        uniform: faces,
        varying: vertices,
        vertex: vertices,
        face_varying: corners,
        face_vertex: corners,
    }
}

/// Number of patches (or curve segments) along one direction of a patch mesh.
fn patches_along(kind: PatchKind, n: u32, wrap: Wrap, step: u32) -> Result<usize, String> {
    let n = n as usize;
    let step = step.max(1) as usize;
    match (kind, wrap) {
        (PatchKind::Bilinear, Wrap::NonPeriodic) if n >= 2 => Ok(n - 1),
        (PatchKind::Bilinear, Wrap::Periodic) if n >= 2 => Ok(n),
        (PatchKind::Bilinear, _) => Err(format!("{n} control points; at least 2 are needed")),
        (PatchKind::Bicubic, Wrap::NonPeriodic) => {
            if n < 4 || !(n - 4).is_multiple_of(step) {
                Err(format!(
                    "{n} control points do not fit a bicubic basis with step {step} (4 + k*{step} needed)"
                ))
            } else {
                Ok((n - 4) / step + 1)
            }
        }
        (PatchKind::Bicubic, Wrap::Periodic) => {
            if n == 0 || !n.is_multiple_of(step) {
                Err(format!("{n} control points do not fit a periodic bicubic basis with step {step}"))
            } else {
                Ok(n / step)
            }
        }
    }
}

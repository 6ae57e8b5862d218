//! `Patch` and `PatchMesh`: bilinear and bicubic, any basis and step, periodic or not,
//! homogeneous control points (`P`, `Pz`, `Pw`).
//!
//! A bicubic patch is `P(u, v) = sum_a sum_b Bu_a(u) Bv_b(v) G[b][a]` with the basis weights
//! `B(t) = [t^3 t^2 t 1] M` of RISpec's `Basis` matrix `M` (row-major as in the RIB) and the
//! 4 x 4 control points `G` picked with the basis step; homogeneous points are summed in 4D and
//! divided by `w`. The whole mesh is one grid whose columns and rows never straddle a patch
//! boundary, so neighbouring patches share their boundary vertices; the density per patch comes
//! from [`choose_span_counts`]. The mesh's four sides are diced per patch from their boundary
//! curves alone and stitched to the grid (the `stitch` module), so separate primitives that
//! share a side meet without cracks.

use super::grid::{Grid, GridSpec, RatePlanning, Rates, choose_span_counts, span_of, span_values};
use super::primvar::st_var;
use super::stitch::{Sides, check_stitched_budget};
use super::{TessellateError, Tolerance, TriangleMesh, check_budget, diagonal_of};
use glam::{DVec3, DVec4, Vec2};
use rib_parser::scene::{Basis, PatchKind, PatchMesh, StorageClass, Wrap};
use std::cell::Cell;

const KIND: &str = "PatchMesh";

fn invalid(reason: String) -> TessellateError {
    TessellateError::InvalidShape { kind: KIND, reason }
}

/// Number of patches along one direction, or why the control-point count does not fit.
pub(crate) fn patch_count(
    kind: PatchKind,
    n: u32,
    wrap: Wrap,
    step: u32,
    dir: &str,
) -> Result<usize, TessellateError> {
    let n = n as usize;
    match (kind, wrap) {
        (PatchKind::Bilinear, Wrap::NonPeriodic) if n >= 2 => Ok(n - 1),
        (PatchKind::Bilinear, Wrap::Periodic) if n >= 1 => Ok(n),
        (PatchKind::Bilinear, _) => {
            Err(invalid(format!("{n} control points in {dir}: a bilinear mesh needs 2")))
        }
        (PatchKind::Bicubic, _) if step == 0 => Err(invalid(format!("basis step 0 in {dir}"))),
        (PatchKind::Bicubic, Wrap::NonPeriodic) => {
            let step = step as usize;
            if n < 4 || !(n - 4).is_multiple_of(step) {
                Err(invalid(format!(
                    "{n} control points in {dir} do not fit a nonperiodic bicubic mesh with step {step}"
                )))
            } else {
                Ok((n - 4) / step + 1)
            }
        }
        (PatchKind::Bicubic, Wrap::Periodic) => {
            let step = step as usize;
            if n < 4 || !n.is_multiple_of(step) {
                Err(invalid(format!(
                    "{n} control points in {dir} do not fit a periodic bicubic mesh with step {step}"
                )))
            } else {
                Ok(n / step)
            }
        }
    }
}

/// Weights of the four control points and their derivatives at `t` for basis `m`.
#[inline]
pub(crate) fn cubic_weights(m: &[f64; 16], t: f64) -> ([f64; 4], [f64; 4]) {
    let powers = [t * t * t, t * t, t, 1.0];
    let derivs = [3.0 * t * t, 2.0 * t, 1.0, 0.0];
    let mut w = [0.0; 4];
    let mut d = [0.0; 4];
    for k in 0..4 {
        for r in 0..4 {
            w[k] += powers[r] * m[4 * r + k];
            d[k] += derivs[r] * m[4 * r + k];
        }
    }
    (w, d)
}

/// One parametric direction of a patch mesh.
struct Direction {
    patches: usize,
    /// Control-point counts and step in this direction.
    n: usize,
    step: usize,
    cubic: bool,
    matrix: [f64; 16],
}

impl Direction {
    fn new(
        kind: PatchKind,
        n: u32,
        wrap: Wrap,
        basis: &Basis,
        dir: &str,
    ) -> Result<Direction, TessellateError> {
        let step = if kind == PatchKind::Bilinear { 1 } else { basis.step };
        let patches = patch_count(kind, n, wrap, step, dir)?;
        let matrix = basis.matrix.map(|x| x as f64);
        if !matrix.iter().all(|x| x.is_finite()) {
            return Err(TessellateError::NonFinite { kind: KIND, reason: format!("basis matrix in {dir}") });
        }
        Ok(Direction {
            patches,
            n: n as usize,
            step: step as usize,
            cubic: kind == PatchKind::Bicubic,
            matrix,
        })
    }

    /// The patch a parameter in `[0, patches]` falls in, and the local parameter in it.
    fn locate(&self, t: f64) -> (usize, f64) {
        let p = (t.floor().max(0.0) as usize).min(self.patches - 1);
        (p, t - p as f64)
    }

    /// Control-point indices (in this direction) of patch `p`, wrapping for periodic meshes.
    fn controls(&self, p: usize) -> ([usize; 4], usize) {
        let count = if self.cubic { 4 } else { 2 };
        let mut idx = [0usize; 4];
        for (k, slot) in idx.iter_mut().enumerate().take(count) {
            *slot = (p * self.step + k) % self.n;
        }
        (idx, count)
    }

    fn weights(&self, t: f64) -> ([f64; 4], [f64; 4]) {
        if self.cubic {
            cubic_weights(&self.matrix, t)
        } else {
            ([1.0 - t, t, 0.0, 0.0], [-1.0, 1.0, 0.0, 0.0])
        }
    }
}

/// A patch mesh as a function of its parameters `(u, v)` in `[0, patches u] x [0, patches v]`.
pub(crate) struct PatchSurface {
    du: Direction,
    dv: Direction,
    control: Vec<DVec4>,
    homogeneous: bool,
    max_w: f64,
    /// The diagonal of the control points' box (those with a usable weight).
    pub size: f64,
    /// Set when an evaluation met a vanishing homogeneous weight.
    pub bad_weight: Cell<bool>,
}

impl PatchSurface {
    pub fn new(pm: &PatchMesh) -> Result<PatchSurface, TessellateError> {
        let du = Direction::new(pm.kind, pm.nu, pm.u_wrap, &pm.u_basis, "u")?;
        let dv = Direction::new(pm.kind, pm.nv, pm.v_wrap, &pm.v_basis, "v")?;
        let expected = du.n * dv.n;
        if pm.positions.len() != expected {
            return Err(invalid(format!(
                "{} control points given, nu * nv = {expected}",
                pm.positions.len()
            )));
        }
        let control: Vec<DVec4> = pm.positions.iter().map(|p| p.as_dvec4()).collect();
        if !control.iter().all(|p| p.is_finite()) {
            return Err(TessellateError::NonFinite { kind: KIND, reason: "control point".into() });
        }
        let max_w = check_weights(KIND, control.iter().map(|p| p.w))?;
        // Size from the control points that have a usable weight.
        let size = diagonal_of(
            KIND,
            control.iter().filter(|p| p.w.abs() > 1e-12 * max_w).map(|p| p.truncate() / p.w),
        )?;
        let homogeneous = control.iter().any(|p| p.w != 1.0);
        Ok(PatchSurface { du, dv, control, homogeneous, max_w, size, bad_weight: Cell::new(false) })
    }

    /// The number of patches in u and in v.
    pub fn patches(&self) -> (usize, usize) {
        (self.du.patches, self.dv.patches)
    }

    /// The position and `S_u x S_v` at `(u, v)`.
    pub fn eval(&self, u: f64, v: f64) -> (DVec3, DVec3) {
        let (du, dv) = (&self.du, &self.dv);
        let (pu, tu) = du.locate(u);
        let (pv, tv) = dv.locate(v);
        let (iu, cu) = du.controls(pu);
        let (iv, cv) = dv.controls(pv);
        let (wu, dwu) = du.weights(tu);
        let (wv, dwv) = dv.weights(tv);
        let (mut h, mut h_u, mut h_v) = (DVec4::ZERO, DVec4::ZERO, DVec4::ZERO);
        for b in 0..cv {
            let row = iv[b] * du.n;
            let (mut r, mut r_u) = (DVec4::ZERO, DVec4::ZERO);
            for a in 0..cu {
                let g = self.control[row + iu[a]];
                r += wu[a] * g;
                r_u += dwu[a] * g;
            }
            h += wv[b] * r;
            h_u += wv[b] * r_u;
            h_v += dwv[b] * r;
        }
        if !self.homogeneous {
            // Points given as "P" or "Pz" are not homogeneous: the Hermite and power bases'
            // weights do not sum to one (tangents and coefficients are no points), so the
            // weight must not be summed with them.
            (h.w, h_u.w, h_v.w) = (1.0, 0.0, 0.0);
        }
        rational(h, h_u, h_v, self.max_w, &self.bad_weight)
    }
}

pub(crate) fn tessellate_patches(
    pm: &PatchMesh,
    tol: &Tolerance,
    scale: f64,
    planning: &mut RatePlanning,
) -> Result<TriangleMesh, TessellateError> {
    let surface = PatchSurface::new(pm)?;
    let (du, dv, size, bad_weight) = (&surface.du, &surface.dv, surface.size, &surface.bad_weight);
    let eps = tol.effective(size, scale)?;
    check_budget(KIND, 2.0 * du.patches as f64 * dv.patches as f64, tol)?;

    let eval_full = |u: f64, v: f64| surface.eval(u, v);
    let eval_position = |u: f64, v: f64| eval_full(u, v).0;

    let u_breaks: Vec<f64> = (0..=du.patches).map(|k| k as f64).collect();
    let v_breaks: Vec<f64> = (0..=dv.patches).map(|k| k as f64).collect();
    // Each side is diced from its own boundary curve, so separate primitives sharing it agree.
    let (mut nu, mut nv, sides) = match planning.given(du.patches, dv.patches, true) {
        Some(Rates { nu, nv, sides: Some(sides) }) => {
            (nu.clone(), nv.clone(), Sides::with_counts(&u_breaks, &v_breaks, sides))
        }
        _ => {
            let (nu, nv) = choose_span_counts(KIND, &u_breaks, &v_breaks, &eval_position, eps, (1, 1), tol)?;
            (nu, nv, Sides::new(KIND, &u_breaks, &v_breaks, &eval_position, eps)?)
        }
    };
    planning.record(Rates { nu: nu.clone(), nv: nv.clone(), sides: Some(sides.counts().clone()) });
    let stitch = !sides.match_grid(&nu, &nv);
    let spec = if stitch {
        sides.grid_spec(&u_breaks, &v_breaks, &mut nu, &mut nv)
    } else {
        GridSpec {
            us: span_values(&u_breaks, &nu),
            vs: span_values(&v_breaks, &nv),
            u_periodic: false,
            v_periodic: false,
        }
    };
    check_stitched_budget(KIND, &spec, &sides, tol)?;
    if bad_weight.get() {
        return Err(TessellateError::NonFinite {
            kind: KIND,
            reason: "a homogeneous weight vanishes on the surface".into(),
        });
    }

    let st_fn = texture_coordinates(pm, du, dv);
    let mut eval = eval_full;
    let weld = weld_distance(size, eps);
    let mut grid = Grid::evaluate(&spec, &mut eval, weld, Some(&*st_fn));
    let patches_u = du.patches as u32;
    if stitch {
        let face_at = |u: f64, v: f64| dv.locate(v).0 as u32 * patches_u + du.locate(u).0 as u32;
        grid.emit_stitched(&spec, &sides, &mut eval, Some(&*st_fn), weld, &face_at);
    } else {
        let (u_span, v_span) = (span_of(&nu), span_of(&nv));
        grid.emit_all(&|i, j| v_span[j] as u32 * patches_u + u_span[i] as u32);
    }
    if bad_weight.get() {
        return Err(TessellateError::NonFinite {
            kind: KIND,
            reason: "a homogeneous weight vanishes on the surface".into(),
        });
    }
    Ok(grid.finish())
}

/// Projects a homogeneous point and its derivatives: the position and `S_u x S_v`.
#[inline]
pub(crate) fn rational(h: DVec4, h_u: DVec4, h_v: DVec4, max_w: f64, bad: &Cell<bool>) -> (DVec3, DVec3) {
    if !(h.w.abs() > 1e-12 * max_w) {
        bad.set(true);
        return (DVec3::ZERO, DVec3::ZERO);
    }
    let p = h.truncate() / h.w;
    let s_u = (h_u.truncate() - p * h_u.w) / h.w;
    let s_v = (h_v.truncate() - p * h_v.w) / h.w;
    (p, s_u.cross(s_v))
}

/// The largest weight magnitude, or an error when the weights are all zero or of mixed signs
/// (then the surface passes through infinity).
pub(crate) fn check_weights(
    kind: &'static str,
    weights: impl Iterator<Item = f64>,
) -> Result<f64, TessellateError> {
    let (mut positive, mut negative, mut max_w) = (false, false, 0.0f64);
    for w in weights {
        positive |= w > 0.0;
        negative |= w < 0.0;
        max_w = max_w.max(w.abs());
    }
    if positive && negative {
        return Err(TessellateError::NonFinite { kind, reason: "homogeneous weights of both signs".into() });
    }
    if !(max_w > 0.0) {
        return Err(TessellateError::NonFinite { kind, reason: "every homogeneous weight is zero".into() });
    }
    Ok(max_w)
}

/// Distance under which grid-border points are one vertex (closed seams, collapsed edges).
pub(crate) fn weld_distance(size: f64, eps: f64) -> f64 {
    (size * 1e-7).min(eps * 1e-2)
}

/// Texture coordinates of the mesh: an `st` of class vertex (through the basis like the
/// positions), varying (bilinear over the patch corners) or constant; otherwise `(u, v)` across
/// the whole mesh, each in `[0, 1]`.
fn texture_coordinates<'a>(
    pm: &'a PatchMesh,
    du: &'a Direction,
    dv: &'a Direction,
) -> Box<dyn Fn(f64, f64) -> Vec2 + 'a> {
    let (npu, npv) = (du.patches as f64, dv.patches as f64);
    let default = Box::new(move |u: f64, v: f64| Vec2::new((u / npu) as f32, (v / npv) as f32));
    let Some(var) = st_var(&pm.primvars) else { return default };
    match var.class {
        StorageClass::Constant if !var.values.is_empty() => {
            let c = var.values[0];
            Box::new(move |_, _| c)
        }
        StorageClass::Vertex if var.values.len() >= du.n * dv.n => Box::new(move |u: f64, v: f64| {
            let (pu, tu) = du.locate(u);
            let (pv, tv) = dv.locate(v);
            let (iu, cu) = du.controls(pu);
            let (iv, cv) = dv.controls(pv);
            let (wu, _) = du.weights(tu);
            let (wv, _) = dv.weights(tv);
            let mut st = glam::DVec2::ZERO;
            for b in 0..cv {
                for a in 0..cu {
                    st += wu[a] * wv[b] * var.values[iv[b] * du.n + iu[a]].as_dvec2();
                }
            }
            st.as_vec2()
        }),
        StorageClass::Varying => {
            // One value per patch corner: (patches + 1) per nonperiodic direction, patches per
            // periodic one (the last corner wraps to the first).
            let corners_u = if pm.u_wrap == Wrap::Periodic { du.patches } else { du.patches + 1 };
            let corners_v = if pm.v_wrap == Wrap::Periodic { dv.patches } else { dv.patches + 1 };
            if var.values.len() < corners_u * corners_v {
                return default;
            }
            Box::new(move |u: f64, v: f64| {
                let (pu, tu) = du.locate(u);
                let (pv, tv) = dv.locate(v);
                let at =
                    |a: usize, b: usize| var.values[(b % corners_v) * corners_u + a % corners_u].as_dvec2();
                let low = at(pu, pv).lerp(at(pu + 1, pv), tu);
                let high = at(pu, pv + 1).lerp(at(pu + 1, pv + 1), tu);
                low.lerp(high, tv).as_vec2()
            })
        }
        _ => default,
    }
}

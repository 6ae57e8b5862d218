//! `NuPatch`: non-uniform rational B-spline surfaces of any order up to [`MAX_ORDER`].
//!
//! Evaluation is Cox-de Boor (the basis functions and their first derivatives of one knot
//! span, as in Piegl and Tiller's *The NURBS Book*, A2.2 and A2.3) on homogeneous control
//! points, divided by `w`. The grid covers `[umin, umax] x [vmin, vmax]`, with grid lines on
//! every distinct knot inside it so no cell straddles a knot (where the surface may only be
//! C0); the density per knot span comes from [`choose_span_counts`]. Trim curves are handled
//! by the `trim` module; an untrimmed surface's sides are diced per knot span from their
//! boundary curves alone and stitched to the grid (the `stitch` module), so separate surfaces
//! that share a side (with the same knots along it) meet without cracks.

use super::grid::{Grid, GridSpec, RatePlanning, Rates, choose_span_counts, span_of, span_values};
use super::patch::{check_weights, rational, weld_distance};
use super::stitch::{Sides, check_stitched_budget};
use super::{ShapeOptions, TessellateError, Tolerance, TriangleMesh, check_budget, diagonal_of};
use glam::{DVec3, DVec4, Vec2};
use rib_parser::scene::NuPatch;
use std::cell::Cell;

/// The highest order (degree + 1) supported; real files stay far below.
pub(crate) const MAX_ORDER: usize = 16;

const KIND: &str = "NuPatch";

/// A validated knot vector with its order and control-point count.
#[derive(Clone, Debug)]
pub(crate) struct KnotVector {
    pub knots: Vec<f64>,
    pub order: usize,
    pub n: usize,
}

impl KnotVector {
    /// Checks counts, order and monotonicity.
    pub fn new(
        kind: &'static str,
        knots: &[f32],
        order: u32,
        n: u32,
        dir: &str,
    ) -> Result<KnotVector, TessellateError> {
        let invalid = |reason: String| TessellateError::InvalidShape { kind, reason };
        let (order, n) = (order as usize, n as usize);
        if !(2..=MAX_ORDER).contains(&order) {
            return Err(invalid(format!("{dir} order {order} (supported: 2 to {MAX_ORDER})")));
        }
        if n < order {
            return Err(invalid(format!("{n} control points in {dir}, fewer than the order {order}")));
        }
        if knots.len() != n + order {
            return Err(invalid(format!(
                "{} knots in {dir}, expected {} (n + order)",
                knots.len(),
                n + order
            )));
        }
        if let Some(k) = knots.iter().find(|k| !k.is_finite()) {
            return Err(TessellateError::NonFinite { kind, reason: format!("knot {k}") });
        }
        if knots.windows(2).any(|w| w[1] < w[0]) {
            return Err(invalid(format!("{dir} knots decrease")));
        }
        let knots: Vec<f64> = knots.iter().map(|&k| k as f64).collect();
        if !(knots[order - 1] < knots[n]) {
            return Err(invalid(format!("the {dir} knots leave an empty parameter range")));
        }
        Ok(KnotVector { knots, order, n })
    }

    /// The valid parameter range `[t_{order-1}, t_n]`.
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[self.order - 1], self.knots[self.n])
    }

    /// The knot span `k` (`t_k <= t < t_{k+1}`, non-empty) that holds `t`, clamped to the domain.
    pub fn span(&self, t: f64) -> usize {
        let p = self.order - 1;
        let (lo, hi) = (p, self.n - 1);
        if t >= self.knots[hi + 1] {
            // The end of the domain belongs to the last non-empty span.
            let mut k = hi;
            while k > lo && self.knots[k] >= self.knots[k + 1] {
                k -= 1;
            }
            return k;
        }
        if t <= self.knots[lo] {
            let mut k = lo;
            while k < hi && self.knots[k + 1] <= self.knots[lo] {
                k += 1;
            }
            return k;
        }
        // Largest k in [lo, hi] with t_k <= t.
        let (mut a, mut b) = (lo, hi);
        while a < b {
            let mid = (a + b).div_ceil(2);
            if self.knots[mid] <= t { a = mid } else { b = mid - 1 }
        }
        a
    }

    /// The `order` non-zero basis functions at `t` in span `k` (for control points
    /// `k - p ..= k`) and their derivatives.
    pub fn basis(&self, k: usize, t: f64) -> ([f64; MAX_ORDER], [f64; MAX_ORDER]) {
        let p = self.order - 1;
        let u = &self.knots;
        let mut n = [0.0f64; MAX_ORDER];
        let mut d = [0.0f64; MAX_ORDER];
        let mut left = [0.0f64; MAX_ORDER];
        let mut right = [0.0f64; MAX_ORDER];
        n[0] = 1.0;
        for j in 1..=p {
            if j == p {
                // n holds the degree p - 1 functions N_{k-p+1+s}: differentiate them.
                for r in 0..=p {
                    let mut v = 0.0;
                    if r >= 1 {
                        let den = u[k + r] - u[k + r - p];
                        if den > 0.0 {
                            v += n[r - 1] / den;
                        }
                    }
                    if r < p {
                        let den = u[k + r + 1] - u[k + r + 1 - p];
                        if den > 0.0 {
                            v -= n[r] / den;
                        }
                    }
                    d[r] = p as f64 * v;
                }
            }
            left[j] = t - u[k + 1 - j];
            right[j] = u[k + j] - t;
            let mut saved = 0.0;
            for r in 0..j {
                let den = right[r + 1] + left[j - r];
                let temp = if den != 0.0 { n[r] / den } else { 0.0 };
                n[r] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            n[j] = saved;
        }
        (n, d)
    }

    /// The distinct knots strictly inside `(a, b)`, with `a` and `b` at the ends.
    pub fn breaks(&self, a: f64, b: f64) -> Vec<f64> {
        let mut out = vec![a];
        for &k in &self.knots {
            if k > a && k < b && k > *out.last().expect("not empty") {
                out.push(k);
            }
        }
        out.push(b);
        out
    }
}

/// The validated surface, ready to evaluate.
pub(crate) struct Surface {
    pub u: KnotVector,
    pub v: KnotVector,
    pub control: Vec<DVec4>,
    pub max_w: f64,
    pub bad_weight: Cell<bool>,
}

impl Surface {
    pub fn new(np: &NuPatch) -> Result<Surface, TessellateError> {
        let u = KnotVector::new(KIND, &np.basis.u_knots, np.basis.u_order, np.basis.nu, "u")?;
        let v = KnotVector::new(KIND, &np.basis.v_knots, np.basis.v_order, np.basis.nv, "v")?;
        if np.positions.len() != u.n * v.n {
            return Err(TessellateError::InvalidShape {
                kind: KIND,
                reason: format!("{} control points given, nu * nv = {}", np.positions.len(), u.n * v.n),
            });
        }
        let control: Vec<DVec4> = np.positions.iter().map(|p| p.as_dvec4()).collect();
        if !control.iter().all(|p| p.is_finite()) {
            return Err(TessellateError::NonFinite { kind: KIND, reason: "control point".into() });
        }
        let max_w = check_weights(KIND, control.iter().map(|p| p.w))?;
        Ok(Surface { u, v, control, max_w, bad_weight: Cell::new(false) })
    }

    /// Position and `S_u x S_v` at `(s, t)`.
    pub fn eval(&self, s: f64, t: f64) -> (DVec3, DVec3) {
        let (ku, kv) = (self.u.span(s), self.v.span(t));
        let (nu, du) = self.u.basis(ku, s);
        let (nv, dv) = self.v.basis(kv, t);
        let (pu, pv) = (self.u.order - 1, self.v.order - 1);
        let (mut h, mut h_u, mut h_v) = (DVec4::ZERO, DVec4::ZERO, DVec4::ZERO);
        for b in 0..=pv {
            let row = (kv - pv + b) * self.u.n + ku - pu;
            let (mut r, mut r_u) = (DVec4::ZERO, DVec4::ZERO);
            for a in 0..=pu {
                let g = self.control[row + a];
                r += nu[a] * g;
                r_u += du[a] * g;
            }
            h += nv[b] * r;
            h_u += nv[b] * r_u;
            h_v += dv[b] * r;
        }
        rational(h, h_u, h_v, self.max_w, &self.bad_weight)
    }

    fn weight_error(&self) -> Result<(), TessellateError> {
        if self.bad_weight.get() {
            Err(TessellateError::NonFinite {
                kind: KIND,
                reason: "the homogeneous weight vanishes on the surface".into(),
            })
        } else {
            Ok(())
        }
    }
}

pub(crate) fn tessellate_nupatch(
    np: &NuPatch,
    tol: &Tolerance,
    scale: f64,
    options: ShapeOptions,
    planning: &mut RatePlanning,
) -> Result<TriangleMesh, TessellateError> {
    let surface = Surface::new(np)?;
    let limits = [np.basis.u_min, np.basis.u_max, np.basis.v_min, np.basis.v_max];
    if let Some(x) = limits.iter().find(|x| !x.is_finite()) {
        return Err(TessellateError::NonFinite { kind: KIND, reason: format!("parameter range {x}") });
    }
    // The ranges are clamped to where the surface is defined.
    let (u_lo, u_hi) = surface.u.domain();
    let (v_lo, v_hi) = surface.v.domain();
    let (u0, u1) = ((np.basis.u_min as f64).max(u_lo), (np.basis.u_max as f64).min(u_hi));
    let (v0, v1) = ((np.basis.v_min as f64).max(v_lo), (np.basis.v_max as f64).min(v_hi));
    if !(u0 < u1 && v0 < v1) {
        return Ok(TriangleMesh::default());
    }
    let size = diagonal_of(
        KIND,
        surface.control.iter().filter(|p| p.w.abs() > 1e-12 * surface.max_w).map(|p| p.truncate() / p.w),
    )?;
    let eps = tol.effective(size, scale)?;
    let u_breaks = surface.u.breaks(u0, u1);
    let v_breaks = surface.v.breaks(v0, v1);
    check_budget(KIND, 2.0 * (u_breaks.len() - 1) as f64 * (v_breaks.len() - 1) as f64, tol)?;
    let position = |s: f64, t: f64| surface.eval(s, t).0;
    // Untrimmed, each side is diced per knot span from its own boundary curve, so separate
    // surfaces sharing it agree; trimmed surfaces end on their trim curves instead.
    let (u_spans, v_spans) = (u_breaks.len() - 1, v_breaks.len() - 1);
    let (mut nu, mut nv, sides) = match planning.given(u_spans, v_spans, np.trim.is_none()) {
        Some(r) => {
            let sides = r.sides.as_ref().map(|counts| Sides::with_counts(&u_breaks, &v_breaks, counts));
            (r.nu.clone(), r.nv.clone(), sides)
        }
        None => {
            let (nu, nv) = choose_span_counts(KIND, &u_breaks, &v_breaks, &position, eps, (1, 1), tol)?;
            let sides = match np.trim {
                Some(_) => None,
                None => Some(Sides::new(KIND, &u_breaks, &v_breaks, &position, eps)?),
            };
            (nu, nv, sides)
        }
    };
    planning.record(Rates {
        nu: nu.clone(),
        nv: nv.clone(),
        sides: sides.as_ref().map(|s| s.counts().clone()),
    });
    let sides = sides.filter(|s| !s.match_grid(&nu, &nv));
    let spec = match &sides {
        Some(sides) => {
            let spec = sides.grid_spec(&u_breaks, &v_breaks, &mut nu, &mut nv);
            check_stitched_budget(KIND, &spec, sides, tol)?;
            spec
        }
        None => GridSpec {
            us: span_values(&u_breaks, &nu),
            vs: span_values(&v_breaks, &nv),
            u_periodic: false,
            v_periodic: false,
        },
    };
    surface.weight_error()?;
    let st = |s: f64, t: f64| Vec2::new(s as f32, t as f32);
    let mut eval = |s: f64, t: f64| surface.eval(s, t);
    let weld = weld_distance(size, eps);
    let mut grid = Grid::evaluate(&spec, &mut eval, weld, Some(&st));
    surface.weight_error()?;
    let (u_span, v_span) = (span_of(&nu), span_of(&nv));
    let spans_u = (u_breaks.len() - 1) as u32;
    let face = |i: usize, j: usize| v_span[j] as u32 * spans_u + u_span[i] as u32;
    match (&np.trim, &sides) {
        (Some(trim), _) => {
            let loops = super::trim::TrimLoops::new(trim, eps, &surface, (u0, u1, v0, v1))?;
            super::trim::emit_trimmed(
                &mut grid,
                &spec,
                &loops,
                options.trim_keeps_outside,
                &face,
                &surface,
                eps,
            );
            surface.weight_error()?;
        }
        (None, Some(sides)) => {
            // The span of a parameter: the last break at or below it.
            let span =
                |breaks: &[f64], x: f64| breaks.partition_point(|&b| b <= x).clamp(1, breaks.len() - 1) - 1;
            let face_at = |s: f64, t: f64| span(&v_breaks, t) as u32 * spans_u + span(&u_breaks, s) as u32;
            grid.emit_stitched(&spec, sides, &mut eval, Some(&st), weld, &face_at);
            surface.weight_error()?;
        }
        (None, None) => grid.emit_all(&face),
    }
    Ok(grid.finish())
}

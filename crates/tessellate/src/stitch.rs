//! Edge-consistent dicing of parametric surfaces, so that separate primitives that share an
//! edge (the 32 `Patch`es of a teapot, a `PatchMesh` split into pieces, `NuPatch`es cut along a
//! knot line) meet without T-junction cracks.
//!
//! The interior of a surface keeps the span counts [`choose_span_counts`] picks for its own
//! tolerance. Every span of the domain's four sides is diced separately, at a rate chosen from
//! that side's boundary curve alone ([`edge_segments`]): both surfaces that share the curve
//! see the same points, so they choose the same rate and put their boundary vertices at the
//! same curve parameters. The outer ring of grid cells is then replaced by triangle strips
//! between those boundary vertices and the first interior grid row ([`Grid::emit_stitched`]),
//! as production renderers stitch diced grids. The positions on both sides agree to rounding;
//! [`crate::SeamWelder`] then makes them bitwise equal in the placed meshes.
//!
//! [`choose_span_counts`]: crate::grid::choose_span_counts

use super::grid::{Grid, GridSpec, Sample, find_root, sample_at, span_values, weld_roots};
use super::{TessellateError, Tolerance, check_budget};
use glam::{DVec3, Vec2};

/// Chord error of boundary curves relative to the curve's own size (the bounding-box diagonal
/// of its samples). It depends on the curve alone, so both primitives that share the curve agree
/// on it; it is finer than any relative tolerance the consumers ask for (the ray tracer's finest
/// is `1e-4` of the shape), so it rarely falls back to the shape's own bound.
pub(crate) const EDGE_RELATIVE_DEVIATION: f64 = 1.0 / 16384.0;

/// Most segments one boundary span may get (hostile rational weights stay bounded).
pub(crate) const MAX_EDGE_SEGMENTS: usize = 4096;

/// Samples per boundary span for the first estimate (symmetric, so the estimate is the same
/// whichever way the span is walked).
const EDGE_SAMPLES: usize = 16;

/// How many straight segments the boundary curve `curve(t)`, `t` in `[0, 1]`, needs.
///
/// The bound is the smaller of [`EDGE_RELATIVE_DEVIATION`] times the curve's size and the
/// shape's `eps` rounded down to a power of two (so two shapes with the same tolerance agree
/// even when it is the finer one). The first guess comes from second differences at 17
/// symmetric samples; then every segment's midpoint is checked against its chord and the count
/// is raised until all are within the bound. Every sample set is symmetric under `t -> 1 - t`.
pub(crate) fn edge_segments(
    kind: &'static str,
    curve: &dyn Fn(f64) -> DVec3,
    eps: f64,
) -> Result<usize, TessellateError> {
    let samples: Vec<DVec3> = (0..=EDGE_SAMPLES).map(|k| curve(k as f64 / EDGE_SAMPLES as f64)).collect();
    if !samples.iter().all(|p| p.is_finite()) {
        return Err(TessellateError::NonFinite { kind, reason: "surface boundary evaluation".into() });
    }
    let (lo, hi) = samples.iter().fold((samples[0], samples[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let size = (hi - lo).length();
    if !(size > 0.0) {
        return Ok(1);
    }
    let shape_bound = if eps.is_finite() && eps > 0.0 { eps.log2().floor().exp2() } else { f64::INFINITY };
    let bound = (EDGE_RELATIVE_DEVIATION * size).min(shape_bound).max(size * (-30f64).exp2());
    let second = samples.windows(3).map(|w| (w[0] - 2.0 * w[1] + w[2]).length()).fold(0.0, f64::max);
    // A chord of parameter length h deviates by about h^2 |C''| / 8; the samples are 1/16
    // apart, so |C''| ~ 256 * second.
    let mut n = (EDGE_SAMPLES as f64 * (second / (8.0 * bound)).sqrt()).ceil();
    n = n.clamp(1.0, MAX_EDGE_SEGMENTS as f64);
    for _round in 0..4 {
        let count = n as usize;
        let mut worst = 0.0f64;
        let mut previous = curve(0.0);
        for k in 0..count {
            let next = if k + 1 == count { curve(1.0) } else { curve((k + 1) as f64 / n) };
            let mid = curve((k as f64 + 0.5) / n);
            worst = worst.max(mid.distance(0.5 * (previous + next)));
            previous = next;
        }
        if !worst.is_finite() {
            return Err(TessellateError::NonFinite { kind, reason: "surface boundary evaluation".into() });
        }
        // The midpoint shows the chord's deviation of a quadratic exactly; leave a margin for
        // the rest of a cubic or rational curve.
        let target = 0.9 * bound;
        if worst <= target || count >= MAX_EDGE_SEGMENTS {
            break;
        }
        n = (n * (worst / target).sqrt() * 1.2).ceil().min(MAX_EDGE_SEGMENTS as f64);
    }
    Ok(n as usize)
}

/// Parameter values of the boundary vertices along one side: each span `[breaks[s],
/// breaks[s + 1]]` split evenly into the segments its boundary curve needs (`point(t)` is the
/// surface on this side at parameter `t`). Span ends are the breaks exactly, and inner values
/// are computed as [`crate::grid::span_values`] computes grid lines, so a span diced at the grid's
/// own count puts its vertices exactly on grid points.
pub(crate) fn side_params(
    kind: &'static str,
    breaks: &[f64],
    point: &dyn Fn(f64) -> DVec3,
    eps: f64,
) -> Result<(Vec<f64>, Vec<usize>), TessellateError> {
    let mut counts = Vec::with_capacity(breaks.len() - 1);
    for s in 0..breaks.len() - 1 {
        let (a, b) = (breaks[s], breaks[s + 1]);
        let curve = |t: f64| point(if t == 1.0 { b } else { a + (b - a) * t });
        counts.push(edge_segments(kind, &curve, eps)?);
    }
    Ok((span_values(breaks, &counts), counts))
}

/// The boundary vertices of a rectangular domain: parameter values along each side, corner to
/// corner, increasing (`bottom` and `top` in `u`, `left` and `right` in `v`).
pub(crate) struct Sides {
    pub bottom: Vec<f64>,
    pub right: Vec<f64>,
    pub top: Vec<f64>,
    pub left: Vec<f64>,
    /// Segments per span of each side, in the same order.
    counts: [Vec<usize>; 4],
}

impl Sides {
    /// Dices the four sides of `[u_breaks] x [v_breaks]` of the surface `position`.
    pub fn new(
        kind: &'static str,
        u_breaks: &[f64],
        v_breaks: &[f64],
        position: &dyn Fn(f64, f64) -> DVec3,
        eps: f64,
    ) -> Result<Sides, TessellateError> {
        let (u0, u1) = (u_breaks[0], *u_breaks.last().expect("breaks"));
        let (v0, v1) = (v_breaks[0], *v_breaks.last().expect("breaks"));
        let (bottom, cb) = side_params(kind, u_breaks, &|u| position(u, v0), eps)?;
        let (top, ct) = side_params(kind, u_breaks, &|u| position(u, v1), eps)?;
        let (left, cl) = side_params(kind, v_breaks, &|v| position(u0, v), eps)?;
        let (right, cr) = side_params(kind, v_breaks, &|v| position(u1, v), eps)?;
        Ok(Sides { bottom, right, top, left, counts: [cb, cr, ct, cl] })
    }

    /// The sides diced at given segments per span (bottom, right, top, left).
    pub fn with_counts(u_breaks: &[f64], v_breaks: &[f64], counts: &[Vec<usize>; 4]) -> Sides {
        let [cb, cr, ct, cl] = counts.clone();
        Sides {
            bottom: span_values(u_breaks, &cb),
            right: span_values(v_breaks, &cr),
            top: span_values(u_breaks, &ct),
            left: span_values(v_breaks, &cl),
            counts: [cb, cr, ct, cl],
        }
    }

    /// Segments per span of each side (bottom, right, top, left).
    pub fn counts(&self) -> &[Vec<usize>; 4] {
        &self.counts
    }

    /// True when every side is diced exactly like the grid's span counts `nu` / `nv`: the grid
    /// then needs no stitching (its border points are the boundary vertices).
    pub fn match_grid(&self, nu: &[usize], nv: &[usize]) -> bool {
        let [b, r, t, l] = &self.counts;
        b == nu && t == nu && l == nv && r == nv
    }

    /// Boundary segments in all.
    pub fn segment_count(&self) -> usize {
        self.bottom.len() + self.right.len() + self.top.len() + self.left.len() - 4
    }
}

impl Sides {
    /// The grid to stitch to these sides: the span counts `nu` / `nv` (at least two segments
    /// in each direction, so there is an interior row and column), plus one extra grid line
    /// next to every side diced more coarsely than the grid along it.
    ///
    /// A strip triangle spans one boundary segment and reaches to the first interior line;
    /// where the boundary is coarser than the grid by a factor `r` (a straight edge of a
    /// twisted patch: one segment for the whole side), that line is put at `r` of the first
    /// cell, so the triangle's twist error (the product of its two extents) stays that of a
    /// grid cell.
    pub fn grid_spec(
        &self,
        u_breaks: &[f64],
        v_breaks: &[f64],
        nu: &mut [usize],
        nv: &mut [usize],
    ) -> GridSpec {
        for counts in [&mut *nu, &mut *nv] {
            if counts.iter().sum::<usize>() < 2 {
                counts[0] = 2;
            }
        }
        let mut us = span_values(u_breaks, nu);
        let mut vs = span_values(v_breaks, nv);
        let ratio = |side: &[usize], grid: &[usize]| {
            side.iter().zip(grid).map(|(&s, &g)| s as f64 / g as f64).fold(1.0, f64::min)
        };
        let [b, r, t, l] = &self.counts;
        let inset = |values: &mut Vec<f64>, low: f64, high: f64| {
            let n = values.len() - 1;
            if high < 1.0 {
                let at = values[n] - high * (values[n] - values[n - 1]);
                values.insert(n, at);
            }
            if low < 1.0 {
                let at = values[0] + low * (values[1] - values[0]);
                values.insert(1, at);
            }
        };
        inset(&mut vs, ratio(b, nu), ratio(t, nu));
        inset(&mut us, ratio(l, nv), ratio(r, nv));
        GridSpec { us, vs, u_periodic: false, v_periodic: false }
    }
}

/// Checks the budget of a stitched grid: the grid's cells and the boundary strips.
pub(crate) fn check_stitched_budget(
    kind: &'static str,
    spec: &GridSpec,
    sides: &Sides,
    tol: &Tolerance,
) -> Result<(), TessellateError> {
    let cells = spec.nu() as f64 * spec.nv() as f64;
    check_budget(kind, 2.0 * cells + 2.0 * sides.segment_count() as f64, tol)
}

/// A vertex of a strip: its output id and its parameter along the side.
#[derive(Clone, Copy)]
struct StripVertex {
    id: u32,
    t: f64,
    uv: (f64, f64),
}

impl Grid {
    /// Emits the grid's interior cells and stitches its outer ring to the boundary vertices of
    /// `sides` (evaluated here with `eval`, welded to each other within `weld_eps`: corners,
    /// poles, periodic seams). `face_at(u, v)` names the face of a triangle from its parameter
    /// centroid. The grid must have at least two segments in each direction.
    pub fn emit_stitched(
        &mut self,
        spec: &GridSpec,
        sides: &Sides,
        eval: &mut dyn FnMut(f64, f64) -> Sample,
        st_of: Option<&dyn Fn(f64, f64) -> Vec2>,
        weld_eps: f64,
        face_at: &dyn Fn(f64, f64) -> u32,
    ) {
        let (nu, nv) = (self.nu, self.nv);
        debug_assert!(nu >= 2 && nv >= 2);
        let (u0, u1, v0, v1) = (spec.us[0], spec.us[nu], spec.vs[0], spec.vs[nv]);
        let mid = (0.5 * (u0 + u1), 0.5 * (v0 + v1));

        // Boundary samples of the four sides, welded among themselves.
        let side_uv: [Vec<(f64, f64)>; 4] = [
            sides.bottom.iter().map(|&u| (u, v0)).collect(),
            sides.right.iter().map(|&v| (u1, v)).collect(),
            sides.top.iter().map(|&u| (u, v1)).collect(),
            sides.left.iter().map(|&v| (u0, v)).collect(),
        ];
        let mut points = Vec::new();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        for (s, side) in side_uv.iter().enumerate() {
            for (k, &uv) in side.iter().enumerate() {
                // The step towards the inside, for a normal at a singular point.
                let along = if k + 1 < side.len() { k + 1 } else { k.saturating_sub(1) };
                let step_along = if s % 2 == 0 {
                    ((side[along].0 - uv.0).abs(), (spec.vs[1] - spec.vs[0]).abs())
                } else {
                    ((spec.us[1] - spec.us[0]).abs(), (side[along].1 - uv.1).abs())
                };
                let (p, n) = sample_at(eval, uv, step_along, mid);
                points.push(p);
                normals.push(n);
                uvs.push(uv);
            }
        }
        let mut candidates: Vec<usize> = (0..points.len()).collect();
        let mut parent = weld_roots(&points, &mut candidates, weld_eps, 0);
        let mut id_of_root = vec![u32::MAX; points.len()];
        let mut ids = Vec::with_capacity(points.len());
        for k in 0..points.len() {
            let root = find_root(&mut parent, k);
            if id_of_root[root] == u32::MAX {
                let (u, v) = uvs[root];
                let st = st_of.map_or(Vec2::ZERO, |f| f(u, v));
                id_of_root[root] = self.push_vertex(points[root], normals[root], st);
            } else {
                self.add_normal(id_of_root[root], normals[k]);
            }
            ids.push(id_of_root[root]);
        }
        let mut offset = 0;
        let mut outer: Vec<Vec<StripVertex>> = Vec::with_capacity(4);
        for (s, side) in side_uv.iter().enumerate() {
            outer.push(
                side.iter()
                    .enumerate()
                    .map(|(k, &uv)| StripVertex {
                        id: ids[offset + k],
                        t: if s % 2 == 0 { uv.0 } else { uv.1 },
                        uv,
                    })
                    .collect(),
            );
            offset += side.len();
        }

        // The first interior row or column next to each side, corner to corner.
        let inner_row = |j: usize| -> Vec<StripVertex> {
            (1..nu)
                .map(|i| StripVertex { id: self.id(i, j), t: spec.us[i], uv: (spec.us[i], spec.vs[j]) })
                .collect()
        };
        let inner_column = |i: usize| -> Vec<StripVertex> {
            (1..nv)
                .map(|j| StripVertex { id: self.id(i, j), t: spec.vs[j], uv: (spec.us[i], spec.vs[j]) })
                .collect()
        };
        let inner = [inner_row(1), inner_column(nu - 1), inner_row(nv - 1), inner_column(1)];

        for j in 1..nv - 1 {
            for i in 1..nu - 1 {
                let (u, v) = (0.5 * (spec.us[i] + spec.us[i + 1]), 0.5 * (spec.vs[j] + spec.vs[j + 1]));
                self.emit_cell(i, j, face_at(u, v));
            }
        }
        // Bottom and right strips run counter-clockwise as listed; top and left the other way.
        for (s, (o, i)) in outer.iter().zip(&inner).enumerate() {
            self.emit_strip(o, i, s >= 2, face_at);
        }
    }

    /// Triangles between an outer polyline and an inner one, both listed by increasing `t`,
    /// merged by `t` (a zipper). `flip` reverses the winding.
    fn emit_strip(
        &mut self,
        outer: &[StripVertex],
        inner: &[StripVertex],
        flip: bool,
        face_at: &dyn Fn(f64, f64) -> u32,
    ) {
        let (mut a, mut b) = (0, 0);
        while a + 1 < outer.len() || b + 1 < inner.len() {
            let advance_outer =
                b + 1 >= inner.len() || (a + 1 < outer.len() && outer[a + 1].t <= inner[b + 1].t);
            let tri = if advance_outer {
                a += 1;
                [outer[a - 1], outer[a], inner[b]]
            } else {
                b += 1;
                [outer[a], inner[b], inner[b - 1]]
            };
            let (u, v) = tri.iter().fold((0.0, 0.0), |(u, v), x| (u + x.uv.0 / 3.0, v + x.uv.1 / 3.0));
            let mut ids = tri.map(|x| x.id);
            if flip {
                ids.swap(1, 2);
            }
            self.push_triangle(ids, face_at(u, v));
        }
    }
}

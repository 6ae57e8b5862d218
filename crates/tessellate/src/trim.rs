//! Trim curves of a `NuPatch` (`TrimCurve`).
//!
//! Approach:
//! 1. Every trim curve (a rational B-spline in the surface's parameter space) is flattened
//!    into a polyline, refined until its chord error, mapped to object space through the
//!    surface's largest parametric speed, is below a quarter of the tolerance. A loop's
//!    curves are joined head to tail and closed.
//! 2. A point is kept when it lies inside an odd number of loops (the even-odd rule of RISpec's
//!    `TrimCurve`, as Aqsis implements it); `Attribute "trimcurve" "sense" "outside"` keeps the
//!    other points instead. Grid vertices are classified exactly, a row at a time, from the
//!    sorted crossings of the row's horizontal line with every loop segment.
//! 3. Cells no loop segment touches are kept or dropped whole. Cells a segment touches are
//!    split into `s x s` sub-cells (`s` = 1 for a single straight segment; otherwise from the
//!    loop's curvature in the cell so it bends less than half the tolerance across a sub-cell,
//!    at most 16), and every sub-triangle is clipped marching-triangles style: its corners are
//!    classified exactly (the cell corner's class, flipped by each segment crossed on the way),
//!    and where an edge changes class the exact crossing with the loop segment becomes a new
//!    vertex. The boundary is therefore the refined polyline to within a sub-cell; a loop
//!    smaller than a sub-cell can be missed, and the finer sub-grid meets untouched
//!    neighbouring cells with T-junctions whose gaps are within the tolerance.

use super::TessellateError;
use super::grid::{Grid, GridSpec};
use super::nurbs::{KnotVector, Surface};
use glam::{DVec2, Vec2};
use rib_parser::scene::TrimCurves;
use std::collections::HashMap;

const KIND: &str = "TrimCurve";

/// The trim loops as closed polylines in parameter space.
#[derive(Debug)]
pub(crate) struct TrimLoops {
    /// Every loop segment `(a, b)`; loops are closed (the last point joins the first).
    segments: Vec<(DVec2, DVec2)>,
    /// The segment that follows each segment in its loop.
    next: Vec<usize>,
}

impl TrimLoops {
    pub fn new(
        trim: &TrimCurves,
        eps: f64,
        surface: &Surface,
        (u0, u1, v0, v1): (f64, f64, f64, f64),
    ) -> Result<TrimLoops, TessellateError> {
        let invalid = |reason: String| TessellateError::InvalidShape { kind: KIND, reason };
        let curves: usize = trim.curves_per_loop.iter().map(|&c| c as usize).sum();
        for (name, len) in [
            ("order", trim.order.len()),
            ("min", trim.min.len()),
            ("max", trim.max.len()),
            ("n", trim.n.len()),
        ] {
            if len != curves {
                return Err(invalid(format!("{len} values of {name} for {curves} curves")));
            }
        }
        let points: usize = trim.n.iter().map(|&n| n as usize).sum();
        if trim.u.len() != points || trim.v.len() != points || trim.w.len() != points {
            return Err(invalid(format!(
                "{points} control points expected, u/v/w have {}/{}/{}",
                trim.u.len(),
                trim.v.len(),
                trim.w.len()
            )));
        }
        let knot_total: usize = trim.n.iter().zip(&trim.order).map(|(&n, &o)| n as usize + o as usize).sum();
        if trim.knots.len() != knot_total {
            return Err(invalid(format!("{} knots, expected {knot_total}", trim.knots.len())));
        }

        // How far the surface moves per unit of u and v: maps parameter error to object space.
        let speed = parametric_speed(surface, (u0, u1, v0, v1));
        let uv_eps = (eps / 4.0) / speed.max(1e-300);
        let max_points = 1usize << 22;

        let mut segments = Vec::new();
        let mut next = Vec::new();
        let (mut curve, mut point, mut knot) = (0usize, 0usize, 0usize);
        for &ncurves in &trim.curves_per_loop {
            let mut polyline: Vec<DVec2> = Vec::new();
            for _ in 0..ncurves {
                let (order, n) = (trim.order[curve], trim.n[curve]);
                let kv = KnotVector::new(
                    KIND,
                    &trim.knots[knot..knot + n as usize + order as usize],
                    order,
                    n,
                    "trim",
                )?;
                let ctrl: Vec<[f64; 3]> = (point..point + n as usize)
                    .map(|i| [trim.u[i] as f64, trim.v[i] as f64, trim.w[i] as f64])
                    .collect();
                if !ctrl.iter().flatten().all(|x| x.is_finite()) {
                    return Err(TessellateError::NonFinite { kind: KIND, reason: "control point".into() });
                }
                let (lo, hi) = kv.domain();
                let (t0, t1) = ((trim.min[curve] as f64).max(lo), (trim.max[curve] as f64).min(hi));
                if t0 < t1 {
                    flatten_curve(&kv, &ctrl, t0, t1, uv_eps, &mut polyline, max_points)?;
                }
                curve += 1;
                point += n as usize;
                knot += n as usize + order as usize;
            }
            polyline.dedup();
            if polyline.len() > 1 && polyline.first() == polyline.last() {
                polyline.pop();
            }
            if polyline.len() >= 3 {
                let first = segments.len();
                for i in 0..polyline.len() {
                    segments.push((polyline[i], polyline[(i + 1) % polyline.len()]));
                    next.push(if i + 1 == polyline.len() { first } else { first + i + 1 });
                }
            }
        }
        Ok(TrimLoops { segments, next })
    }

    /// Even-odd inside test of one point against every loop (used by tests; rows use a sweep).
    #[cfg(test)]
    pub fn inside(&self, p: DVec2) -> bool {
        let mut odd = false;
        for &(a, b) in &self.segments {
            if (a.y <= p.y) != (b.y <= p.y) {
                let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
                if x < p.x {
                    odd = !odd;
                }
            }
        }
        odd
    }
}

/// The largest `|dP/du|` and `|dP/dv|` over a coarse sample of the domain.
fn parametric_speed(surface: &Surface, (u0, u1, v0, v1): (f64, f64, f64, f64)) -> f64 {
    let n = 16;
    let mut speed = 0.0f64;
    let at = |i: usize, j: usize| {
        surface.eval(u0 + (u1 - u0) * i as f64 / n as f64, v0 + (v1 - v0) * j as f64 / n as f64).0
    };
    for j in 0..=n {
        for i in 0..=n {
            if i < n {
                speed = speed.max(at(i, j).distance(at(i + 1, j)) * n as f64 / (u1 - u0));
            }
            if j < n {
                speed = speed.max(at(i, j).distance(at(i, j + 1)) * n as f64 / (v1 - v0));
            }
        }
    }
    // Between samples the surface can move faster: keep a margin.
    2.0 * speed
}

fn eval_curve(kv: &KnotVector, ctrl: &[[f64; 3]], t: f64) -> Option<DVec2> {
    let k = kv.span(t);
    let (n, _) = kv.basis(k, t);
    let p = kv.order - 1;
    let mut h = [0.0f64; 3];
    for a in 0..=p {
        let c = ctrl[k - p + a];
        for d in 0..3 {
            h[d] += n[a] * c[d];
        }
    }
    (h[2].abs() > 1e-300).then(|| DVec2::new(h[0] / h[2], h[1] / h[2])).filter(|p| p.is_finite())
}

/// Appends the polyline of one curve over `[t0, t1]`: `order` samples per knot span, each
/// interval halved until its midpoint is within `uv_eps` of the chord.
fn flatten_curve(
    kv: &KnotVector,
    ctrl: &[[f64; 3]],
    t0: f64,
    t1: f64,
    uv_eps: f64,
    out: &mut Vec<DVec2>,
    max_points: usize,
) -> Result<(), TessellateError> {
    let bad = || TessellateError::NonFinite { kind: KIND, reason: "a trim curve's weight vanishes".into() };
    let breaks = kv.breaks(t0, t1);
    let per_span = kv.order.max(4);
    let mut ts = Vec::new();
    for w in breaks.windows(2) {
        for k in 0..per_span {
            ts.push(w[0] + (w[1] - w[0]) * k as f64 / per_span as f64);
        }
    }
    ts.push(t1);
    let mut stack: Vec<(f64, DVec2, f64, DVec2, u32)> = Vec::new();
    let first = eval_curve(kv, ctrl, ts[0]).ok_or_else(bad)?;
    out.push(first);
    for w in ts.windows(2) {
        let pa = *out.last().expect("not empty");
        let pb = eval_curve(kv, ctrl, w[1]).ok_or_else(bad)?;
        stack.push((w[0], pa, w[1], pb, 0));
        // Depth-first, right halves pushed first, so points come out in order.
        while let Some((a, pa, b, pb, depth)) = stack.pop() {
            let m = 0.5 * (a + b);
            let pm = eval_curve(kv, ctrl, m).ok_or_else(bad)?;
            let chord = pb - pa;
            let off = if chord.length_squared() > 0.0 {
                (pm - pa).perp_dot(chord).abs() / chord.length()
            } else {
                pm.distance(pa)
            };
            if off > uv_eps && depth < 20 {
                stack.push((m, pm, b, pb, depth + 1));
                stack.push((a, pa, m, pm, depth + 1));
            } else {
                out.push(pb);
                if out.len() > max_points {
                    return Err(TessellateError::TooManyTriangles {
                        kind: KIND,
                        estimated: out.len() as u64,
                        limit: max_points as u64,
                    });
                }
            }
        }
    }
    Ok(())
}

/// Where segment `p0 + t (p1 - p0)` crosses segment `(a, b)`: `t`, when it does (the loop
/// segment half-open at `b`, so a path through a shared vertex counts it once).
fn crossing(p0: DVec2, p1: DVec2, a: DVec2, b: DVec2) -> Option<f64> {
    let d = p1 - p0;
    let e = b - a;
    let den = d.perp_dot(e);
    if den == 0.0 {
        return None;
    }
    let w = a - p0;
    let t = w.perp_dot(e) / den;
    let s = w.perp_dot(d) / den;
    ((0.0..=1.0).contains(&t) && (0.0..1.0).contains(&s)).then_some(t)
}

/// True when segment `(a, b)` touches the closed rectangle `[x0, x1] x [y0, y1]` (Liang-Barsky).
fn touches_rect(a: DVec2, b: DVec2, x0: f64, x1: f64, y0: f64, y1: f64) -> bool {
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-d.x, a.x - x0), (d.x, x1 - a.x), (-d.y, a.y - y0), (d.y, y1 - a.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

/// Index of the last value `<= x` in the sorted `values`, clamped to a cell index.
fn cell_of(values: &[f64], x: f64) -> usize {
    let cells = values.len() - 1;
    values.partition_point(|&v| v <= x).saturating_sub(1).min(cells - 1)
}

/// Emits the kept part of every grid cell (see the module docs).
pub(crate) fn emit_trimmed(
    grid: &mut Grid,
    spec: &GridSpec,
    loops: &TrimLoops,
    keep_outside: bool,
    face_of_cell: &dyn Fn(usize, usize) -> u32,
    surface: &Surface,
    eps: f64,
) {
    let (us, vs) = (&spec.us, &spec.vs);
    let (nu, nv) = (us.len() - 1, vs.len() - 1);
    let cols = nu + 1;

    let mut clipper = Clipper {
        surface,
        loops,
        points: HashMap::new(),
        crossings: HashMap::new(),
        rows: HashMap::new(),
        keep_outside,
    };
    // Classify grid vertices a row at a time.
    let mut kept = vec![false; cols * (nv + 1)];
    for (j, &y) in vs.iter().enumerate() {
        for (i, &x) in us.iter().enumerate() {
            kept[j * cols + i] = clipper.classify(DVec2::new(x, y));
        }
    }

    // Which cells each segment touches.
    let mut buckets: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (s, &(a, b)) in loops.segments.iter().enumerate() {
        let (lo, hi) = (a.min(b), a.max(b));
        if hi.x < us[0] || lo.x > us[nu] || hi.y < vs[0] || lo.y > vs[nv] {
            continue;
        }
        let (i0, i1) = (cell_of(us, lo.x), cell_of(us, hi.x));
        let (j0, j1) = (cell_of(vs, lo.y), cell_of(vs, hi.y));
        for j in j0..=j1 {
            for i in i0..=i1 {
                if touches_rect(a, b, us[i], us[i + 1], vs[j], vs[j + 1]) {
                    buckets.entry((i, j)).or_default().push(s);
                }
            }
        }
    }

    // Sub-cells per touched cell: one when a single straight segment crosses it (marching
    // triangles then cut it exactly); otherwise enough that the loop's curvature inside the
    // cell bends less than half the tolerance across a sub-cell, and at least four where the
    // loop passes more than once; at most 16.
    let subdivisions = |i: usize, j: usize, segs: &[usize], grid: &Grid| -> usize {
        if segs.len() == 1 {
            return 1;
        }
        let (u0, u1, v0, v1) = (us[i], us[i + 1], vs[j], vs[j + 1]);
        let uv_diagonal = DVec2::new(u1 - u0, v1 - v0).length();
        let diagonal_3d = grid.position(grid.id(i, j)).distance(grid.position(grid.id(i + 1, j + 1)));
        let scale = diagonal_3d / uv_diagonal.max(1e-300);
        let inside = |p: DVec2| p.x >= u0 && p.x <= u1 && p.y >= v0 && p.y <= v1;
        let (mut curvature, mut runs) = (0.0f64, 0usize);
        for &s in segs {
            let (a, v) = loops.segments[s];
            let b = loops.segments[loops.next[s]].1;
            if inside(v) {
                let (d0, d1) = (v - a, b - v);
                let turn = d0.angle_to(d1).abs();
                let length = 0.5 * (d0.length() + d1.length());
                if length > 0.0 {
                    curvature = curvature.max(turn / length);
                }
            }
            // A run starts where the previous segment is not in this cell.
            if !segs.iter().any(|&p| loops.next[p] == s) {
                runs += 1;
            }
        }
        // A chord of length h on a curve of curvature k sags h^2 k / 8.
        let h = (4.0 * eps / (curvature * scale).max(1e-300)).sqrt();
        let mut s = (uv_diagonal / h).ceil().clamp(1.0, 16.0) as usize;
        if runs > 1 {
            s = s.max(4);
        }
        s.max(2)
    };

    for j in 0..nv {
        for i in 0..nu {
            let face = face_of_cell(i, j);
            match buckets.get(&(i, j)) {
                None => {
                    let corners = [
                        kept[j * cols + i],
                        kept[j * cols + i + 1],
                        kept[(j + 1) * cols + i],
                        kept[(j + 1) * cols + i + 1],
                    ];
                    // Untouched cells are uniform; a disagreement means a boundary passing
                    // exactly through corners: go by the majority.
                    if corners.iter().filter(|&&k| k).count() >= 3 {
                        grid.emit_cell(i, j, face);
                    }
                }
                Some(segs) => {
                    let s = subdivisions(i, j, segs, grid);
                    clipper.clip_cell(grid, spec, (i, j), segs, s, face);
                }
            }
        }
    }
}

struct Clipper<'a> {
    surface: &'a Surface,
    loops: &'a TrimLoops,
    /// Sub-grid points by their exact parameters.
    points: HashMap<(u64, u64), u32>,
    /// Crossing vertices by the sub-grid points of their edge.
    crossings: HashMap<(u32, u32), u32>,
    /// For each row `v` classified so far, the sorted `u` where loop segments cross it.
    rows: HashMap<u64, Vec<f64>>,
    keep_outside: bool,
}

impl Clipper<'_> {
    fn vertex(&mut self, grid: &mut Grid, uv: DVec2) -> u32 {
        *self.points.entry((uv.x.to_bits(), uv.y.to_bits())).or_insert_with(|| {
            let (p, n) = self.surface.eval(uv.x, uv.y);
            grid.push_vertex(p, n, Vec2::new(uv.x as f32, uv.y as f32))
        })
    }

    /// Kept or not: the even-odd count of loop crossings left of `q` on its row (half-open
    /// in `v`, so a loop vertex on the row counts once), the same rule for every point.
    fn classify(&mut self, q: DVec2) -> bool {
        let loops = self.loops;
        let xs = self.rows.entry(q.y.to_bits()).or_insert_with(|| {
            let mut xs: Vec<f64> = loops
                .segments
                .iter()
                .filter(|(a, b)| (a.y <= q.y) != (b.y <= q.y))
                .map(|&(a, b)| a.x + (q.y - a.y) / (b.y - a.y) * (b.x - a.x))
                .collect();
            xs.sort_by(f64::total_cmp);
            xs
        });
        let inside = xs.partition_point(|&c| c < q.x) % 2 == 1;
        inside != self.keep_outside
    }

    #[allow(clippy::too_many_arguments)]
    fn clip_cell(
        &mut self,
        grid: &mut Grid,
        spec: &GridSpec,
        (i, j): (usize, usize),
        segs: &[usize],
        subdivisions: usize,
        face: u32,
    ) {
        let (u0, u1, v0, v1) = (spec.us[i], spec.us[i + 1], spec.vs[j], spec.vs[j + 1]);
        let s = subdivisions;
        let param = |a: usize, b: usize| {
            // The cell's own corners exactly, so they match the grid.
            let u = if a == s { u1 } else { u0 + (u1 - u0) * a as f64 / s as f64 };
            let v = if b == s { v1 } else { v0 + (v1 - v0) * b as f64 / s as f64 };
            DVec2::new(u, v)
        };
        // Sub-grid points with ids and classes; cell corners are the grid's vertices.
        let mut ids = vec![0u32; (s + 1) * (s + 1)];
        let mut classes = vec![false; (s + 1) * (s + 1)];
        for b in 0..=s {
            for a in 0..=s {
                let uv = param(a, b);
                let k = b * (s + 1) + a;
                ids[k] = match (a, b) {
                    (0, 0) => grid.id(i, j),
                    (x, 0) if x == s => grid.id(i + 1, j),
                    (0, y) if y == s => grid.id(i, j + 1),
                    (x, y) if x == s && y == s => grid.id(i + 1, j + 1),
                    _ => self.vertex(grid, uv),
                };
                classes[k] = self.classify(uv);
            }
        }
        for b in 0..s {
            for a in 0..s {
                let k = |x: usize, y: usize| y * (s + 1) + x;
                let corners = [k(a, b), k(a + 1, b), k(a + 1, b + 1), k(a, b + 1)];
                for tri in [[corners[0], corners[1], corners[2]], [corners[0], corners[2], corners[3]]] {
                    let pts = tri.map(|c| (ids[c], classes[c], param(c % (s + 1), c / (s + 1))));
                    self.clip_triangle(grid, pts, segs, face);
                }
            }
        }
    }

    /// Emits the kept part of one sub-triangle (corners counter-clockwise in `(u, v)`).
    fn clip_triangle(&mut self, grid: &mut Grid, pts: [(u32, bool, DVec2); 3], segs: &[usize], face: u32) {
        let kept = pts.iter().filter(|p| p.1).count();
        if kept == 3 {
            grid.push_triangle(pts.map(|p| p.0), face);
            return;
        }
        if kept == 0 {
            return;
        }
        // Walk the triangle's edges, keeping kept corners and the crossings between classes.
        let mut polygon: Vec<u32> = Vec::with_capacity(4);
        for e in 0..3 {
            let (a, b) = (pts[e], pts[(e + 1) % 3]);
            if a.1 {
                polygon.push(a.0);
            }
            if a.1 != b.1 {
                polygon.push(self.crossing_vertex(grid, a, b, segs));
            }
        }
        for k in 1..polygon.len().saturating_sub(1) {
            grid.push_triangle([polygon[0], polygon[k], polygon[k + 1]], face);
        }
    }

    /// The vertex where edge `a`-`b` crosses the trim boundary (the middle crossing when
    /// several do), shared by both triangles of the edge.
    fn crossing_vertex(
        &mut self,
        grid: &mut Grid,
        a: (u32, bool, DVec2),
        b: (u32, bool, DVec2),
        segs: &[usize],
    ) -> u32 {
        let key = (a.0.min(b.0), a.0.max(b.0));
        if let Some(&id) = self.crossings.get(&key) {
            return id;
        }
        let (pa, pb) = if a.0 <= b.0 { (a.2, b.2) } else { (b.2, a.2) };
        let mut ts: Vec<f64> = segs
            .iter()
            .filter_map(|&s| {
                let (p, q) = self.loops.segments[s];
                crossing(pa, pb, p, q)
            })
            .collect();
        ts.sort_by(f64::total_cmp);
        let t = match ts.get(ts.len() / 2) {
            Some(&t) => t,
            None => {
                // The boundary passes through a loop vertex exactly on this edge: bisect on
                // the classification instead.
                let class_a = self.classify(pa);
                let (mut lo, mut hi) = (0.0f64, 1.0f64);
                for _ in 0..40 {
                    let mid = 0.5 * (lo + hi);
                    if self.classify(pa.lerp(pb, mid)) == class_a { lo = mid } else { hi = mid }
                }
                0.5 * (lo + hi)
            }
        };
        let uv = pa.lerp(pb, t);
        let (p, n) = self.surface.eval(uv.x, uv.y);
        let id = grid.push_vertex(p, n, Vec2::new(uv.x as f32, uv.y as f32));
        self.crossings.insert(key, id);
        id
    }
}

//! Tensor-product grids over a parametric surface: evaluation, welding of seams and poles,
//! triangle emission, and the choice of grid density for a deviation bound.

use super::{TessellateError, Tolerance, TriangleMesh, check_budget};
use glam::{DVec3, Vec2};
use std::collections::HashMap;

/// A surface sample: the position and the front normal direction (any length; zero where the
/// parametrisation is singular, e.g. at a pole, and the builder then looks slightly inside).
pub(crate) type Sample = (DVec3, DVec3);

/// Parameter values of a grid's columns (`us`) and rows (`vs`).
#[derive(Clone, Debug)]
pub(crate) struct GridSpec {
    pub us: Vec<f64>,
    pub vs: Vec<f64>,
    /// The surface at the last column equals the first: the last column reuses its vertices.
    pub u_periodic: bool,
    pub v_periodic: bool,
}

impl GridSpec {
    pub fn uniform(u0: f64, u1: f64, nu: usize, v0: f64, v1: f64, nv: usize) -> GridSpec {
        GridSpec { us: linspace(u0, u1, nu), vs: linspace(v0, v1, nv), u_periodic: false, v_periodic: false }
    }

    pub fn nu(&self) -> usize {
        self.us.len() - 1
    }

    pub fn nv(&self) -> usize {
        self.vs.len() - 1
    }
}

/// `n + 1` evenly spaced values from `a` to `b`, both ends exact.
pub(crate) fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    let n = n.max(1);
    (0..=n).map(|i| if i == n { b } else { a + (b - a) * (i as f64 / n as f64) }).collect()
}

/// A grid's vertices, welded, ready for triangles.
pub(crate) struct Grid {
    pub(crate) nu: usize,
    pub(crate) nv: usize,
    /// Output vertex of grid point `(i, j)` at `j * (nu + 1) + i`.
    ids: Vec<u32>,
    pub mesh: TriangleMesh,
    /// Sum of unit sample normals per output vertex (normalised in `finish`).
    normal_sums: Vec<DVec3>,
}

impl Grid {
    /// Evaluates the surface at every grid point and welds coincident points on the grid's
    /// border (poles, collapsed edges, closed seams) into one vertex each.
    pub fn evaluate(
        spec: &GridSpec,
        eval: &mut dyn FnMut(f64, f64) -> Sample,
        weld_eps: f64,
        st_of: Option<&dyn Fn(f64, f64) -> Vec2>,
    ) -> Grid {
        let (nu, nv) = (spec.nu(), spec.nv());
        let cols = nu + 1;
        let count = cols * (nv + 1);
        let (u_mid, v_mid) = (0.5 * (spec.us[0] + spec.us[nu]), 0.5 * (spec.vs[0] + spec.vs[nv]));
        let mut points = vec![DVec3::ZERO; count];
        let mut normals = vec![DVec3::ZERO; count];
        let mut source = vec![usize::MAX; count];
        for j in 0..=nv {
            for i in 0..=nu {
                let k = j * cols + i;
                if spec.u_periodic && i == nu {
                    source[k] = j * cols;
                    continue;
                }
                if spec.v_periodic && j == nv {
                    source[k] = if spec.u_periodic && i == nu { 0 } else { i };
                    continue;
                }
                let (u, v) = (spec.us[i], spec.vs[j]);
                let du = if nu > 0 { (spec.us[1.min(nu)] - spec.us[0]).abs() } else { 0.0 };
                let dv = if nv > 0 { (spec.vs[1.min(nv)] - spec.vs[0]).abs() } else { 0.0 };
                (points[k], normals[k]) = sample_at(eval, (u, v), (du, dv), (u_mid, v_mid));
                source[k] = k;
            }
        }
        // Periodic copies point at evaluated samples (the corner may chain once).
        for k in 0..count {
            let s = source[k];
            source[k] = if source[s] == s { s } else { source[source[s]] };
        }

        let mut border: Vec<usize> = Vec::with_capacity(2 * (nu + nv + 2));
        for i in 0..=nu {
            border.push(source[i]);
            border.push(source[nv * cols + i]);
        }
        for j in 0..=nv {
            border.push(source[j * cols]);
            border.push(source[j * cols + nu]);
        }
        let mut parent = weld_roots(&points, &mut border, weld_eps, source[0]);
        let mut ids = vec![u32::MAX; count];
        let mut out_of_root: HashMap<usize, u32> = HashMap::new();
        let mut mesh = TriangleMesh::default();
        let mut st = st_of.map(|_| Vec::new());
        let mut normal_sums = Vec::new();
        for j in 0..=nv {
            for i in 0..=nu {
                let k = j * cols + i;
                let s = source[k];
                let root = find_root(&mut parent, s);
                let id = *out_of_root.entry(root).or_insert_with(|| {
                    mesh.positions.push(points[root].as_vec3());
                    normal_sums.push(DVec3::ZERO);
                    if let (Some(st), Some(f)) = (st.as_mut(), st_of) {
                        let (si, sj) = (s % cols, s / cols);
                        st.push(f(spec.us[si], spec.vs[sj]));
                    }
                    (mesh.positions.len() - 1) as u32
                });
                if s == k {
                    normal_sums[id as usize] += normals[k];
                }
                ids[k] = id;
            }
        }
        mesh.st = st;
        Grid { nu, nv, ids, mesh, normal_sums }
    }

    pub fn id(&self, i: usize, j: usize) -> u32 {
        self.ids[j * (self.nu + 1) + i]
    }

    pub fn position(&self, id: u32) -> DVec3 {
        self.mesh.positions[id as usize].as_dvec3()
    }

    /// Emits the two triangles of cell `(i, j)`, split along its shorter diagonal, counter-
    /// clockwise in `(u, v)` (so along `dPdu x dPdv`). Degenerate triangles are skipped.
    pub fn emit_cell(&mut self, i: usize, j: usize, face: u32) {
        let (a, b, c, d) = (self.id(i, j), self.id(i + 1, j), self.id(i + 1, j + 1), self.id(i, j + 1));
        let ac = self.position(a).distance_squared(self.position(c));
        let bd = self.position(b).distance_squared(self.position(d));
        let tris = if ac <= bd { [[a, b, c], [a, c, d]] } else { [[a, b, d], [b, c, d]] };
        for t in tris {
            self.push_triangle(t, face);
        }
    }

    /// Adds a triangle unless two of its corners are the same vertex or it has no area.
    pub fn push_triangle(&mut self, [a, b, c]: [u32; 3], face: u32) {
        let (pa, pb, pc) = (self.position(a), self.position(b), self.position(c));
        if a != b && b != c && a != c && (pb - pa).cross(pc - pa) != DVec3::ZERO {
            self.mesh.indices.push([a, b, c]);
            self.mesh.face_index.push(face);
        }
    }

    /// Adds a vertex that is not a grid point (trimming), with its sample normal.
    pub fn push_vertex(&mut self, p: DVec3, n: DVec3, st: Vec2) -> u32 {
        self.mesh.positions.push(p.as_vec3());
        self.normal_sums.push(if n.is_finite() { n.normalize_or_zero() } else { DVec3::ZERO });
        if let Some(s) = self.mesh.st.as_mut() {
            s.push(st);
        }
        (self.mesh.positions.len() - 1) as u32
    }

    /// Adds another sample's unit normal to vertex `id` (a vertex welded from several samples).
    pub fn add_normal(&mut self, id: u32, n: DVec3) {
        self.normal_sums[id as usize] += n;
    }

    pub fn emit_all(&mut self, face_of_cell: &dyn Fn(usize, usize) -> u32) {
        self.mesh.indices.reserve(2 * self.nu * self.nv);
        self.mesh.face_index.reserve(2 * self.nu * self.nv);
        for j in 0..self.nv {
            for i in 0..self.nu {
                self.emit_cell(i, j, face_of_cell(i, j));
            }
        }
    }

    /// Normalises the vertex normals; a vertex without a usable one takes the area-weighted
    /// normal of its triangles. Vertices no triangle uses are dropped.
    pub fn finish(self) -> TriangleMesh {
        let Grid { mut mesh, mut normal_sums, .. } = self;
        let mut face_sums: Option<Vec<DVec3>> = None;
        for n in &normal_sums {
            if n.length_squared() < 1e-12 {
                let mut sums = vec![DVec3::ZERO; mesh.positions.len()];
                for t in 0..mesh.indices.len() {
                    let cross = mesh.face_cross(t);
                    for &i in &mesh.indices[t] {
                        sums[i as usize] += cross;
                    }
                }
                face_sums = Some(sums);
                break;
            }
        }
        for (i, n) in normal_sums.iter_mut().enumerate() {
            if n.length_squared() < 1e-12 {
                *n = face_sums.as_ref().map_or(DVec3::ZERO, |s| s[i]);
            }
        }
        mesh.normals = Some(normal_sums.iter().map(|n| n.normalize_or(DVec3::Z).as_vec3()).collect());
        compact(&mut mesh);
        mesh
    }
}

/// Evaluates `eval` at `(u, v)`; where the normal is singular (a pole), takes it a little way
/// (1e-3 of `step`) towards the domain centre `mid`. Returns the position and unit normal (zero
/// when none is usable).
pub(crate) fn sample_at(
    eval: &mut dyn FnMut(f64, f64) -> Sample,
    (u, v): (f64, f64),
    step: (f64, f64),
    mid: (f64, f64),
) -> Sample {
    let (p, mut n) = eval(u, v);
    if !(n.length_squared() > 0.0) || !n.is_finite() {
        let nudge = |x: f64, mid: f64, step: f64| x + (mid - x).signum() * step * 1e-3;
        n = eval(nudge(u, mid.0, step.0), nudge(v, mid.1, step.1)).1;
    }
    (p, if n.is_finite() { n.normalize_or_zero() } else { DVec3::ZERO })
}

/// Union-find root of `x`, compressing the path.
pub(crate) fn find_root(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// Groups the points listed in `candidates` that lie within `weld_eps` of each other: returns a
/// union-find parent table over all of `points` (resolve with [`find_root`]); the root of a
/// group is its lowest index. `origin` (an index into `points`) keeps the cell keys small.
pub(crate) fn weld_roots(
    points: &[DVec3],
    candidates: &mut Vec<usize>,
    weld_eps: f64,
    origin: usize,
) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..points.len()).collect();
    if !(weld_eps > 0.0) || points.is_empty() {
        return parent;
    }
    let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    let origin = points[origin];
    let key = |p: DVec3| ((p - origin) / weld_eps).floor().as_i64vec3().to_array();
    candidates.sort_unstable();
    candidates.dedup();
    for &k in candidates.iter() {
        let p = points[k];
        let c = key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let cell = [c[0].saturating_add(dx), c[1].saturating_add(dy), c[2].saturating_add(dz)];
                    let Some(others) = cells.get(&cell) else { continue };
                    // One representative per cell is enough: its members are already one.
                    if let Some(&o) = others.iter().find(|&&o| points[o].distance(p) <= weld_eps) {
                        let (ra, rb) = (find_root(&mut parent, k), find_root(&mut parent, o));
                        if ra != rb {
                            parent[ra.max(rb)] = ra.min(rb);
                        }
                    }
                }
            }
        }
        let members = cells.entry(c).or_default();
        if members.len() < 4 {
            members.push(k);
        }
    }
    parent
}

/// Drops vertices no triangle uses.
pub(crate) fn compact(mesh: &mut TriangleMesh) {
    let mut used = vec![u32::MAX; mesh.positions.len()];
    let mut next = 0u32;
    for tri in &mesh.indices {
        for &i in tri {
            if used[i as usize] == u32::MAX {
                used[i as usize] = next;
                next += 1;
            }
        }
    }
    if next as usize == mesh.positions.len() && used.iter().enumerate().all(|(i, &u)| u == i as u32) {
        return;
    }
    fn keep<T: Copy + Default>(v: &mut Vec<T>, used: &[u32], count: usize) {
        let mut out = vec![T::default(); count];
        for (i, &u) in used.iter().enumerate() {
            if u != u32::MAX {
                out[u as usize] = v[i];
            }
        }
        *v = out;
    }
    let count = next as usize;
    keep(&mut mesh.positions, &used, count);
    if let Some(n) = mesh.normals.as_mut() {
        keep(n, &used, count);
    }
    if let Some(st) = mesh.st.as_mut() {
        keep(st, &used, count);
    }
    for tri in &mut mesh.indices {
        *tri = tri.map(|i| used[i as usize]);
    }
}

/// Chooses how many grid segments each span of a piecewise-smooth surface needs so that the
/// two triangles of every cell stay within `eps` of the surface.
///
/// `u_breaks` / `v_breaks` are the span boundaries (patch edges or distinct knots); segments
/// never straddle them. The first guess uses second differences sampled on each span cell
/// (Filip, Magedson and Markot's bound `(h_u^2 M_uu + 2 h_u h_v M_uv + h_v^2 M_vv) / 8`); then
/// every cell is checked at its edge midpoints and centre against the surface (to 3/4 of the
/// bound: a quadratic error inside a triangle is at most 4/3 of its edge-midpoint maximum), and
/// spans whose cells miss are refined until all pass (or the budget is exhausted).
pub(crate) fn choose_span_counts(
    kind: &'static str,
    u_breaks: &[f64],
    v_breaks: &[f64],
    eval: &dyn Fn(f64, f64) -> DVec3,
    eps: f64,
    min_per_span: (usize, usize),
    tol: &Tolerance,
) -> Result<(Vec<usize>, Vec<usize>), TessellateError> {
    let (su, sv) = (u_breaks.len() - 1, v_breaks.len() - 1);
    let mut nu = vec![min_per_span.0.max(1); su];
    let mut nv = vec![min_per_span.1.max(1); sv];
    check_budget(kind, 2.0 * su as f64 * sv as f64, tol)?;

    // First guess from second differences on a 5 x 5 sample of every span cell.
    let mut samples = [[DVec3::ZERO; 5]; 5];
    for j in 0..sv {
        for i in 0..su {
            let (u0, u1, v0, v1) = (u_breaks[i], u_breaks[i + 1], v_breaks[j], v_breaks[j + 1]);
            for (b, row) in samples.iter_mut().enumerate() {
                for (a, s) in row.iter_mut().enumerate() {
                    *s = eval(u0 + (u1 - u0) * a as f64 / 4.0, v0 + (v1 - v0) * b as f64 / 4.0);
                }
            }
            let (mut d_uu, mut d_vv, mut d_uv) = (0f64, 0f64, 0f64);
            for b in 0..5 {
                for a in 0..3 {
                    d_uu = d_uu.max((samples[b][a] - 2.0 * samples[b][a + 1] + samples[b][a + 2]).length());
                    d_vv = d_vv.max((samples[a][b] - 2.0 * samples[a + 1][b] + samples[a + 2][b]).length());
                }
            }
            for b in 0..4 {
                for a in 0..4 {
                    d_uv = d_uv.max(
                        (samples[b][a] - samples[b][a + 1] - samples[b + 1][a] + samples[b + 1][a + 1])
                            .length(),
                    );
                }
            }
            // Samples a quarter span apart: M h^2 ~ 16 d for the second differences, 16 d for
            // the mixed one.
            let (a2, c2, b2) = (16.0 * d_uu, 16.0 * d_vv, 16.0 * d_uv);
            let need_u = ((a2 + b2) / (4.0 * eps)).sqrt().ceil();
            let need_v = ((c2 + b2) / (4.0 * eps)).sqrt().ceil();
            if !(need_u.is_finite() && need_v.is_finite()) {
                return Err(TessellateError::NonFinite { kind, reason: "surface evaluation".into() });
            }
            check_budget(kind, 2.0 * need_u * need_v, tol)?;
            nu[i] = nu[i].max(need_u as usize);
            nv[j] = nv[j].max(need_v as usize);
        }
    }

    // Check every cell and refine the spans that miss.
    for _round in 0..6 {
        let total = 2.0 * nu.iter().sum::<usize>() as f64 * nv.iter().sum::<usize>() as f64;
        check_budget(kind, total, tol)?;
        let us = span_values(u_breaks, &nu);
        let vs = span_values(v_breaks, &nv);
        let u_span = span_of(&nu);
        let v_span = span_of(&nv);
        let cols = us.len();
        let grid: Vec<DVec3> = vs.iter().flat_map(|&v| us.iter().map(move |&u| eval(u, v))).collect();
        let mut factor_u = vec![1.0f64; su];
        let mut factor_v = vec![1.0f64; sv];
        for j in 0..vs.len() - 1 {
            for i in 0..cols - 1 {
                let (u0, u1, v0, v1) = (us[i], us[i + 1], vs[j], vs[j + 1]);
                let (um, vm) = (0.5 * (u0 + u1), 0.5 * (v0 + v1));
                let p00 = grid[j * cols + i];
                let p10 = grid[j * cols + i + 1];
                let p01 = grid[(j + 1) * cols + i];
                let p11 = grid[(j + 1) * cols + i + 1];
                let e_u = eval(um, v0).distance(0.5 * (p00 + p10));
                let e_v = eval(u0, vm).distance(0.5 * (p00 + p01));
                let centre = eval(um, vm);
                let e_c = centre.distance(0.5 * (p00 + p11)).max(centre.distance(0.5 * (p10 + p01)));
                let mut e_u = e_u;
                let mut e_v = e_v;
                if j + 1 == vs.len() - 1 {
                    e_u = e_u.max(eval(um, v1).distance(0.5 * (p01 + p11)));
                }
                if i + 1 == cols - 1 {
                    e_v = e_v.max(eval(u1, vm).distance(0.5 * (p10 + p11)));
                }
                if !(e_u.is_finite() && e_v.is_finite() && e_c.is_finite()) {
                    return Err(TessellateError::NonFinite { kind, reason: "surface evaluation".into() });
                }
                // Interpolation error shrinks with the square of the segment length. Inside a
                // triangle a quadratic error reaches up to 4/3 of its largest edge-midpoint
                // value (it is at most 1/3 of its largest coefficient, the midpoints show 1/4),
                // so the sampled values must stay within 3/4 of the bound.
                let bound = 0.75 * eps;
                let grow = |e: f64| if e > bound { (e / bound).sqrt() * 1.2 } else { 1.0 };
                let (fu, fv) = (grow(e_u.max(e_c)), grow(e_v.max(e_c)));
                factor_u[u_span[i]] = factor_u[u_span[i]].max(fu);
                factor_v[v_span[j]] = factor_v[v_span[j]].max(fv);
            }
        }
        if factor_u.iter().chain(&factor_v).all(|&f| f == 1.0) {
            return Ok((nu, nv));
        }
        for (n, f) in nu.iter_mut().zip(&factor_u) {
            *n = ((*n as f64) * f).ceil().min(1e9) as usize;
        }
        for (n, f) in nv.iter_mut().zip(&factor_v) {
            *n = ((*n as f64) * f).ceil().min(1e9) as usize;
        }
    }
    let total = 2.0 * nu.iter().sum::<usize>() as f64 * nv.iter().sum::<usize>() as f64;
    check_budget(kind, total, tol)?;
    Ok((nu, nv))
}

/// Parameter values of spans `breaks` split into `counts` equal segments each.
pub(crate) fn span_values(breaks: &[f64], counts: &[usize]) -> Vec<f64> {
    let mut out = Vec::with_capacity(counts.iter().sum::<usize>() + 1);
    for (s, &n) in counts.iter().enumerate() {
        let (a, b) = (breaks[s], breaks[s + 1]);
        for k in 0..n {
            out.push(a + (b - a) * (k as f64 / n as f64));
        }
    }
    out.push(*breaks.last().expect("at least one span"));
    out
}

/// For every segment of `span_values(_, counts)`, the span it lies in.
pub(crate) fn span_of(counts: &[usize]) -> Vec<usize> {
    counts.iter().enumerate().flat_map(|(s, &n)| std::iter::repeat_n(s, n)).collect()
}

/// The dicing rates of a parametric surface: segments per span of the interior grid and of
/// each side (bottom, right, top, left; `None` for a trimmed NuPatch, which ends on its trim
/// curves instead).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Rates {
    pub nu: Vec<usize>,
    pub nv: Vec<usize>,
    pub sides: Option<[Vec<usize>; 4]>,
}

impl Rates {
    /// The span by span largest of several keys' rates, so that each key is diced at least as
    /// finely as it needs; `None` unless every key has rates of the same layout. Side counts
    /// depend on their boundary curve alone, so surfaces sharing a curve at every key take the
    /// same largest counts and still meet.
    pub fn largest(rates: &[Option<Rates>]) -> Option<Rates> {
        let mut out = rates.first()?.clone()?;
        let max_into = |into: &mut Vec<usize>, from: &[usize]| {
            (into.len() == from.len()).then(|| into.iter_mut().zip(from).for_each(|(a, &b)| *a = (*a).max(b)))
        };
        for r in &rates[1..] {
            let r = r.as_ref()?;
            max_into(&mut out.nu, &r.nu)?;
            max_into(&mut out.nv, &r.nv)?;
            match (&mut out.sides, &r.sides) {
                (Some(a), Some(b)) => {
                    for (a, b) in a.iter_mut().zip(b) {
                        max_into(a, b)?;
                    }
                }
                (None, None) => {}
                _ => return None,
            }
        }
        Some(out)
    }
}

/// How a parametric surface's rates are chosen: from its own positions, recorded as well, or
/// given (the largest of a deforming shape's keys, see keys.rs).
pub(crate) enum RatePlanning {
    Free,
    Record(Option<Rates>),
    Given(Rates),
}

impl RatePlanning {
    /// The rates given for spans `u_spans` x `v_spans` (with sides or not), if they fit.
    pub fn given(&self, u_spans: usize, v_spans: usize, with_sides: bool) -> Option<&Rates> {
        match self {
            RatePlanning::Given(r)
                if r.nu.len() == u_spans && r.nv.len() == v_spans && r.sides.is_some() == with_sides =>
            {
                Some(r)
            }
            _ => None,
        }
    }

    pub fn record(&mut self, rates: Rates) {
        if let RatePlanning::Record(slot) = self {
            *slot = Some(rates);
        }
    }
}

//! `Blobby` implicit surfaces: the field (value and exact gradient) and its level set as
//! triangles by marching tetrahedra.
//!
//! # The field
//! Every primitive field falls off as Wyvill's soft-object kernel `(1 - r^2)^3` for `r < 1` and
//! is 0 beyond, where `r` is the distance in the primitive's own space: from the centre of the
//! unit sphere for an ellipsoid (1001), from the segment divided by its radius for a segment
//! (1002); the 16-float matrix places that space in the Blobby's object space (row vectors,
//! as every RIB matrix). The surface is the level set at [`BLOBBY_THRESHOLD`] = 0.421875
//! `= 0.75^3`, as in Aqsis and PRMan, so a lone unit ellipsoid is a sphere of radius 1/2.
//! The operators combine the primitives' values (and gradients, by the chain rule) exactly.
//! Planes (1003) need a depth-map file and plugins (1004) a program: neither is read, and such
//! a Blobby is refused with a message.
//!
//! # Tessellation and its tolerance
//! The field is sampled on a grid covering every primitive's support (the surface cannot leave
//! it unless a constant field reaches the threshold on its own). Each grid cube is split into
//! six tetrahedra along its main diagonal (the Kuhn split, the same on shared faces, so the
//! mesh is closed), and every tetrahedron edge that crosses the level set gets one vertex,
//! found by the Illinois method on the exact field to `1e-9` of the spacing: every vertex lies
//! on the surface. The spacing `h` starts from the chord bound `h^2 / (8 R) <= eps` with `R`
//! half the smallest primitive radius; then the distance of every triangle's centroid from the
//! surface (`|f - T| / |grad f|`, first order) is measured, and the grid is halved (at most
//! twice, within the triangle budget) until it is below `eps`. Where operators make creases
//! (`max`, `min`, `sub`) the surface has no curvature bound, and the crease is resolved to the
//! grid spacing. Vertex normals are the normalised `-grad f`.

use super::{TessellateError, Tolerance, TriangleMesh, check_budget};
use glam::{DMat3, DMat4, DVec3, Vec3};
use rib_parser::blobby::{BlobbyInstruction, BlobbyOp, decode_blobby};
use rib_parser::scene::Blobby;
use std::collections::HashMap;

/// The field value on the surface (Aqsis and PRMan): `(1 - 0.5^2)^3`.
pub const BLOBBY_THRESHOLD: f64 = 0.421875;

/// Most grid points times instructions one tessellation may evaluate.
const MAX_FIELD_WORK: f64 = 2e9;

const KIND: &str = "Blobby";

#[derive(Clone, Debug)]
enum Leaf {
    Constant(f64),
    Ellipsoid {
        leaf_from_object: DMat4,
        lin_t: DMat3,
        lo: DVec3,
        hi: DVec3,
    },
    Segment {
        leaf_from_object: DMat4,
        lin_t: DMat3,
        a: DVec3,
        b: DVec3,
        inv_r2: f64,
        lo: DVec3,
        hi: DVec3,
    },
    /// A primitive with a singular matrix: no field.
    Zero,
}

#[derive(Clone, Debug)]
enum Step {
    Leaf(u32),
    Op(BlobbyOp, Vec<u32>),
}

/// A `Blobby`'s field, ready to evaluate anywhere in its object space.
#[derive(Clone, Debug)]
pub struct BlobbyField {
    leaves: Vec<Leaf>,
    steps: Vec<Step>,
    /// Bounds of the union of the primitives' supports; `None` when no primitive has one.
    pub bounds: Option<(DVec3, DVec3)>,
    /// Half the smallest primitive's radius: the smallest feature a lone primitive makes.
    pub feature_radius: f64,
}

/// The Wyvill kernel `(1 - r2)^3` and its derivative in `r2`.
fn kernel(r2: f64) -> (f64, f64) {
    if r2 >= 1.0 {
        return (0.0, 0.0);
    }
    let s = 1.0 - r2;
    (s * s * s, -3.0 * s * s)
}

/// RIB row-vector matrix (16 floats) as a column-vector `DMat4`.
fn rib_matrix(m: &[f32]) -> DMat4 {
    let mut a = [0.0f64; 16];
    for (o, &v) in a.iter_mut().zip(m) {
        *o = f64::from(v);
    }
    DMat4::from_cols_array(&a)
}

fn box_of(m: &DMat4, lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
    let mut bl = DVec3::splat(f64::INFINITY);
    let mut bh = DVec3::splat(f64::NEG_INFINITY);
    for k in 0..8 {
        let c = DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let p = m.transform_point3(c);
        bl = bl.min(p);
        bh = bh.max(p);
    }
    (bl, bh)
}

/// Frobenius norm of a 3x3 matrix (an upper bound of its largest stretch).
fn frobenius(m: &DMat3) -> f64 {
    (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt()
}

impl BlobbyField {
    /// Compiles a `Blobby`. Refuses planes (1003, a depth map is needed) and plugins (1004).
    pub fn new(blobby: &Blobby) -> Result<BlobbyField, TessellateError> {
        let invalid = |reason: String| TessellateError::InvalidShape { kind: KIND, reason };
        let program =
            decode_blobby(blobby.leaf_count, &blobby.code, blobby.floats.len(), blobby.strings.len())
                .map_err(invalid)?;
        let f = &blobby.floats;
        let mut leaves = Vec::new();
        let mut steps = Vec::with_capacity(program.len());
        let mut bounds: Option<(DVec3, DVec3)> = None;
        let mut feature_radius = f64::INFINITY;
        let mut grow = |lo: DVec3, hi: DVec3| {
            bounds = Some(match bounds {
                Some((a, b)) => (a.min(lo), b.max(hi)),
                None => (lo, hi),
            });
        };
        for instruction in program {
            let leaf = match instruction {
                BlobbyInstruction::Constant { float } => Leaf::Constant(f64::from(f[float as usize])),
                BlobbyInstruction::Ellipsoid { float } => {
                    let i = float as usize;
                    let object_from_leaf = rib_matrix(&f[i..i + 16]);
                    let leaf_from_object = object_from_leaf.inverse();
                    if object_from_leaf.determinant().abs() > 0.0 && leaf_from_object.is_finite() {
                        let (lo, hi) = box_of(&object_from_leaf, DVec3::NEG_ONE, DVec3::ONE);
                        grow(lo, hi);
                        let lin = DMat3::from_mat4(leaf_from_object);
                        feature_radius = feature_radius.min(0.5 / frobenius(&lin));
                        Leaf::Ellipsoid { leaf_from_object, lin_t: lin.transpose(), lo, hi }
                    } else {
                        Leaf::Zero
                    }
                }
                BlobbyInstruction::Segment { float } => {
                    let i = float as usize;
                    let a = DVec3::new(f64::from(f[i]), f64::from(f[i + 1]), f64::from(f[i + 2]));
                    let b = DVec3::new(f64::from(f[i + 3]), f64::from(f[i + 4]), f64::from(f[i + 5]));
                    let radius = f64::from(f[i + 6]).abs();
                    let object_from_leaf = rib_matrix(&f[i + 7..i + 23]);
                    let leaf_from_object = object_from_leaf.inverse();
                    if radius > 0.0
                        && object_from_leaf.determinant().abs() > 0.0
                        && leaf_from_object.is_finite()
                    {
                        let r = DVec3::splat(radius);
                        let (lo, hi) = box_of(&object_from_leaf, a.min(b) - r, a.max(b) + r);
                        grow(lo, hi);
                        let lin = DMat3::from_mat4(leaf_from_object);
                        feature_radius = feature_radius.min(0.5 * radius / frobenius(&lin));
                        Leaf::Segment {
                            leaf_from_object,
                            lin_t: lin.transpose(),
                            a,
                            b,
                            inv_r2: 1.0 / (radius * radius),
                            lo,
                            hi,
                        }
                    } else {
                        Leaf::Zero
                    }
                }
                BlobbyInstruction::Plane { string, .. } => {
                    return Err(invalid(format!(
                        "plane primitives (opcode 1003) need the depth map \"{}\", which is not read",
                        blobby.strings[string as usize]
                    )));
                }
                BlobbyInstruction::Plugin { string } => {
                    return Err(invalid(format!(
                        "implicit-field plugins (opcode 1004, \"{}\") are never run",
                        blobby.strings[string as usize]
                    )));
                }
                BlobbyInstruction::Operator { op, operands } => {
                    steps.push(Step::Op(op, operands));
                    continue;
                }
            };
            steps.push(Step::Leaf(leaves.len() as u32));
            leaves.push(leaf);
        }
        Ok(BlobbyField { leaves, steps, bounds, feature_radius })
    }

    /// Number of instructions: the cost of one evaluation.
    pub fn instruction_count(&self) -> usize {
        self.steps.len()
    }

    fn leaf(&self, leaf: &Leaf, p: DVec3) -> (f64, DVec3) {
        let inside = |lo: &DVec3, hi: &DVec3| p.cmpge(*lo).all() && p.cmple(*hi).all();
        match leaf {
            Leaf::Constant(c) => (*c, DVec3::ZERO),
            Leaf::Zero => (0.0, DVec3::ZERO),
            Leaf::Ellipsoid { leaf_from_object, lin_t, lo, hi } => {
                if !inside(lo, hi) {
                    return (0.0, DVec3::ZERO);
                }
                let q = leaf_from_object.transform_point3(p);
                let (v, dv) = kernel(q.length_squared());
                (v, *lin_t * (q * (2.0 * dv)))
            }
            Leaf::Segment { leaf_from_object, lin_t, a, b, inv_r2, lo, hi } => {
                if !inside(lo, hi) {
                    return (0.0, DVec3::ZERO);
                }
                let q = leaf_from_object.transform_point3(p);
                let ab = *b - *a;
                let len2 = ab.length_squared();
                let t = if len2 > 0.0 { ((q - *a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
                let d = q - (*a + ab * t);
                let (v, dv) = kernel(d.length_squared() * inv_r2);
                (v, *lin_t * (d * (2.0 * dv * inv_r2)))
            }
        }
    }

    /// The field and its gradient at `p` (object space). `scratch` is reused between calls.
    pub fn eval(&self, p: DVec3, scratch: &mut Vec<(f64, DVec3)>) -> (f64, DVec3) {
        scratch.clear();
        for step in &self.steps {
            let r = match step {
                Step::Leaf(i) => self.leaf(&self.leaves[*i as usize], p),
                Step::Op(op, operands) => {
                    let get = |k: usize| scratch[operands[k] as usize];
                    match op {
                        BlobbyOp::Add => operands.iter().fold((0.0, DVec3::ZERO), |(v, g), &o| {
                            let (a, ga) = scratch[o as usize];
                            (v + a, g + ga)
                        }),
                        BlobbyOp::Multiply => {
                            let mut acc = get(0);
                            for k in 1..operands.len() {
                                let (b, gb) = get(k);
                                acc = (acc.0 * b, acc.1 * b + gb * acc.0);
                            }
                            acc
                        }
                        BlobbyOp::Maximum => {
                            (1..operands.len()).map(get).fold(get(0), |m, x| if x.0 > m.0 { x } else { m })
                        }
                        BlobbyOp::Minimum => {
                            (1..operands.len()).map(get).fold(get(0), |m, x| if x.0 < m.0 { x } else { m })
                        }
                        BlobbyOp::Subtract => {
                            let ((a, ga), (b, gb)) = (get(0), get(1));
                            (a - b, ga - gb)
                        }
                        BlobbyOp::Divide => {
                            let ((a, ga), (b, gb)) = (get(0), get(1));
                            // Outside the divisor's support the quotient is taken as no field.
                            if b == 0.0 { (0.0, DVec3::ZERO) } else { (a / b, (ga * b - gb * a) / (b * b)) }
                        }
                        BlobbyOp::Negate => {
                            let (a, ga) = get(0);
                            (-a, -ga)
                        }
                        BlobbyOp::Identity => get(0),
                    }
                }
            };
            scratch.push(r);
        }
        scratch.last().copied().unwrap_or((0.0, DVec3::ZERO))
    }
}

/// The grid a tessellation samples.
struct Grid {
    origin: DVec3,
    h: f64,
    n: [usize; 3],
}

impl Grid {
    fn point(&self, id: u64) -> DVec3 {
        let (nx, ny) = (self.n[0] as u64, self.n[1] as u64);
        let (i, j, k) = (id % nx, (id / nx) % ny, id / (nx * ny));
        self.origin + DVec3::new(i as f64, j as f64, k as f64) * self.h
    }
}

/// Tessellates a `Blobby` in its object space within the tolerance (see the module docs).
pub(crate) fn tessellate_blobby(
    blobby: &Blobby,
    tol: &Tolerance,
    scale: f64,
) -> Result<TriangleMesh, TessellateError> {
    let field = BlobbyField::new(blobby)?;
    let Some((lo, hi)) = field.bounds else { return Ok(TriangleMesh::default()) };
    let size = (hi - lo).length();
    let eps = tol.effective(size, scale)?;
    let radius = field.feature_radius.min(size);
    // Chord bound, and never coarser than the smallest feature.
    let mut h = (8.0 * radius * eps).sqrt().min(0.5 * radius).max(size * 1e-6);
    let mut best: Option<TriangleMesh> = None;
    for _ in 0..3 {
        let extent = hi - lo;
        let cells = (extent / h).ceil() + DVec3::splat(2.0);
        let points = (cells.x + 1.0) * (cells.y + 1.0) * (cells.z + 1.0);
        // The surface crosses about (area / h^2) cells, each giving a few triangles; the grid's
        // faces bound the area from above.
        let estimated = 12.0 * 2.0 * (cells.x * cells.y + cells.y * cells.z + cells.x * cells.z);
        let work = points * field.instruction_count() as f64;
        let within = check_budget(KIND, estimated, tol).is_ok() && work <= MAX_FIELD_WORK;
        if !within {
            if best.is_some() {
                break;
            }
            check_budget(KIND, estimated, tol)?;
            return Err(TessellateError::InvalidShape {
                kind: KIND,
                reason: format!(
                    "the field of {} instructions on {points:.0} grid points is more work than the limit of {MAX_FIELD_WORK:.0}",
                    field.instruction_count()
                ),
            });
        }
        let grid = Grid {
            origin: lo - DVec3::splat(h),
            h,
            n: [cells.x as usize + 1, cells.y as usize + 1, cells.z as usize + 1],
        };
        let mesh = march(&field, &grid);
        let deviation = max_deviation(&field, &mesh);
        best = Some(mesh);
        if deviation <= eps {
            break;
        }
        h *= 0.5;
    }
    Ok(best.unwrap_or_default())
}

/// Largest first-order distance of a triangle centroid from the level set, over the triangles
/// whose vertex normals agree within 25 degrees (creases have no curvature bound to meet).
fn max_deviation(field: &BlobbyField, mesh: &TriangleMesh) -> f64 {
    let mut scratch = Vec::new();
    let mut worst = 0.0f64;
    let normals = mesh.normals.as_deref().unwrap_or(&[]);
    for t in 0..mesh.indices.len() {
        let [i, j, k] = mesh.indices[t].map(|v| v as usize);
        if let (Some(a), Some(b), Some(c)) = (normals.get(i), normals.get(j), normals.get(k))
            && a.dot(*b).min(b.dot(*c)).min(a.dot(*c)) < 0.9
        {
            continue;
        }
        let [a, b, c] = mesh.triangle(t).map(|p| p.as_dvec3());
        let (v, g) = field.eval((a + b + c) / 3.0, &mut scratch);
        let gl = g.length();
        if gl > 0.0 {
            worst = worst.max((v - BLOBBY_THRESHOLD).abs() / gl);
        }
    }
    worst
}

/// Marching tetrahedra over the grid.
fn march(field: &BlobbyField, grid: &Grid) -> TriangleMesh {
    let [nx, ny, nz] = grid.n;
    let mut scratch = Vec::new();
    let mut values = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = grid.origin + DVec3::new(i as f64, j as f64, k as f64) * grid.h;
                values.push(field.eval(p, &mut scratch).0 as f32);
            }
        }
    }
    let threshold = BLOBBY_THRESHOLD as f32;
    let id = |i: usize, j: usize, k: usize| (i + nx * (j + ny * k)) as u64;
    let mut edge_vertex: HashMap<(u64, u64), u32> = HashMap::new();
    let mut positions: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut indices: Vec<[u32; 3]> = Vec::new();
    // The Kuhn split: paths from corner 0 to corner 7 along the axes in each order.
    const ORDERS: [[usize; 3]; 6] = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    let mut vertex_on = |a: u64,
                         b: u64,
                         positions: &mut Vec<Vec3>,
                         normals: &mut Vec<Vec3>,
                         scratch: &mut Vec<(f64, DVec3)>| {
        let key = (a.min(b), a.max(b));
        if let Some(&v) = edge_vertex.get(&key) {
            return v;
        }
        let p = crossing(field, grid.point(key.0), grid.point(key.1), scratch);
        let (_, g) = field.eval(p, scratch);
        positions.push(p.as_vec3());
        normals.push((-g).normalize_or_zero().as_vec3());
        let v = positions.len() as u32 - 1;
        edge_vertex.insert(key, v);
        v
    };
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let corner = |c: [usize; 3]| id(i + c[0], j + c[1], k + c[2]);
                let ids: [u64; 8] = std::array::from_fn(|c| corner([c & 1, (c >> 1) & 1, (c >> 2) & 1]));
                let inside: [bool; 8] = std::array::from_fn(|c| values[ids[c] as usize] > threshold);
                if inside.iter().all(|&x| x) || inside.iter().all(|&x| !x) {
                    continue;
                }
                for order in ORDERS {
                    let mut c = [0usize; 3];
                    let mut tet = [ids[0]; 4];
                    let mut tin = [inside[0]; 4];
                    for (s, &axis) in order.iter().enumerate() {
                        c[axis] = 1;
                        let corner_index = c[0] | (c[1] << 1) | (c[2] << 2);
                        tet[s + 1] = ids[corner_index];
                        tin[s + 1] = inside[corner_index];
                    }
                    let ins: Vec<usize> = (0..4).filter(|&v| tin[v]).collect();
                    let outs: Vec<usize> = (0..4).filter(|&v| !tin[v]).collect();
                    if ins.is_empty() || outs.is_empty() {
                        continue;
                    }
                    let centre = |set: &[usize]| {
                        set.iter().map(|&v| grid.point(tet[v])).fold(DVec3::ZERO, |s, p| s + p)
                            / set.len() as f64
                    };
                    let outward = centre(&outs) - centre(&ins);
                    let mut emit = |tri: [u32; 3], positions: &Vec<Vec3>| {
                        let [a, b, c] = tri.map(|v| positions[v as usize].as_dvec3());
                        let n = (b - a).cross(c - a);
                        if n == DVec3::ZERO {
                            return;
                        }
                        indices.push(if n.dot(outward) >= 0.0 { tri } else { [tri[0], tri[2], tri[1]] });
                    };
                    match (ins.len(), outs.len()) {
                        (1, 3) | (3, 1) => {
                            let (single, others) =
                                if ins.len() == 1 { (ins[0], &outs) } else { (outs[0], &ins) };
                            let tri = [0, 1, 2].map(|m| {
                                vertex_on(
                                    tet[single],
                                    tet[others[m]],
                                    &mut positions,
                                    &mut normals,
                                    &mut scratch,
                                )
                            });
                            emit(tri, &positions);
                        }
                        _ => {
                            let (a, b, c, d) = (ins[0], ins[1], outs[0], outs[1]);
                            let mut v = |x: usize, y: usize| {
                                vertex_on(tet[x], tet[y], &mut positions, &mut normals, &mut scratch)
                            };
                            let (ac, ad, bd, bc) = (v(a, c), v(a, d), v(b, d), v(b, c));
                            emit([ac, ad, bd], &positions);
                            emit([ac, bd, bc], &positions);
                        }
                    }
                }
            }
        }
    }
    let count = indices.len();
    TriangleMesh {
        positions,
        normals: Some(normals),
        st: None,
        indices,
        face_index: vec![0; count],
        degenerate_faces: 0,
    }
}

/// The point where the field crosses the threshold between `a` and `b` (one inside, one
/// outside), by the Illinois method on the exact field.
fn crossing(field: &BlobbyField, a: DVec3, b: DVec3, scratch: &mut Vec<(f64, DVec3)>) -> DVec3 {
    let f =
        |t: f64, scratch: &mut Vec<(f64, DVec3)>| field.eval(a + (b - a) * t, scratch).0 - BLOBBY_THRESHOLD;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let (mut f0, mut f1) = (f(t0, scratch), f(t1, scratch));
    let mut side = 0;
    for _ in 0..60 {
        let t = if f1 != f0 { (t0 * f1 - t1 * f0) / (f1 - f0) } else { 0.5 * (t0 + t1) };
        let t = if t > t0.min(t1) && t < t0.max(t1) { t } else { 0.5 * (t0 + t1) };
        let ft = f(t, scratch);
        if ft == 0.0 {
            return a + (b - a) * t;
        }
        if (ft > 0.0) == (f1 > 0.0) {
            t1 = t;
            f1 = ft;
            if side == -1 {
                f0 *= 0.5;
            }
            side = -1;
        } else {
            t0 = t;
            f0 = ft;
            if side == 1 {
                f1 *= 0.5;
            }
            side = 1;
        }
        if (t1 - t0).abs() <= 1e-9 {
            break;
        }
    }
    a + (b - a) * (0.5 * (t0 + t1))
}

//! Limit positions and normals of a quad level, the vertices where uniform refinement
//! converges slowly, and how far each face is from the limit surface.

use super::level::{Boundary, Level};
use super::rules::{Rule, rules};
use glam::DVec3;
use std::f64::consts::PI;

/// Limit positions of every vertex of a quad level, and the exact limit normal where the
/// vertex is smooth (zero elsewhere).
pub(super) fn limit(level: &Level, boundary: Boundary) -> (Vec<DVec3>, Vec<DVec3>) {
    let rule = rules(level, boundary);
    let nv = level.positions.len();
    let mut positions = vec![DVec3::ZERO; nv];
    let mut normals = vec![DVec3::ZERO; nv];
    for v in 0..nv {
        let p = level.positions[v];
        // Remaining semi-sharpness counts as sharp at the drawn level.
        positions[v] = match rule[v] {
            Rule::Corner => p,
            Rule::Crease(a, b) => (level.positions[a] + 4.0 * p + level.positions[b]) / 6.0,
            Rule::Smooth => match smooth_ring(level, v) {
                Some((ring_e, ring_f)) => {
                    let n = ring_e.len() as f64;
                    let sum_e: DVec3 = ring_e.iter().map(|&i| level.positions[i]).sum();
                    let sum_f: DVec3 = ring_f.iter().map(|&i| level.positions[i]).sum();
                    normals[v] = limit_normal(level, &ring_e, &ring_f);
                    (n * n * p + 4.0 * sum_e + sum_f) / (n * (n + 5.0))
                }
                // A boundary vertex with a smooth rule (it has no sharp edges) cannot happen;
                // non-manifold fans keep their position.
                None => p,
            },
        };
    }
    (positions, normals)
}

/// The one-ring of an interior vertex of a quad level in counter-clockwise order: edge
/// neighbours `e_i` and the opposite corners `f_i` of the quads between `e_i` and `e_{i+1}`.
pub(super) fn smooth_ring(level: &Level, v: usize) -> Option<(Vec<usize>, Vec<usize>)> {
    let faces = level.faces_of(v);
    // A boundary vertex has fewer faces than edges (and its walk would not close anyway).
    if faces.is_empty() || faces.len() != level.edges_of(v).len() {
        return None;
    }
    let corner = |f: u32, k: u32, offset: u32| {
        let r = level.face(f as usize);
        let n = r.len() as u32;
        level.face_verts[r.start + ((k + offset) % n) as usize] as usize
    };
    let (mut ring_e, mut ring_f) = (Vec::with_capacity(faces.len()), Vec::with_capacity(faces.len()));
    let (mut f, mut k) = faces[0];
    for _ in 0..faces.len() {
        if level.face(f as usize).len() != 4 {
            return None;
        }
        ring_e.push(corner(f, k, 1));
        ring_f.push(corner(f, k, 2));
        // The next face counter-clockwise has the current face's previous corner as its next.
        let prev = corner(f, k, 3);
        let (nf, nk) = *faces.iter().find(|&&(g, j)| g != f && corner(g, j, 1) == prev)?;
        f = nf;
        k = nk;
    }
    (f == faces[0].0).then_some((ring_e, ring_f))
}

/// Halstead, Kass and DeRose's limit tangents; their cross product is the limit normal.
pub(super) fn limit_normal(level: &Level, ring_e: &[usize], ring_f: &[usize]) -> DVec3 {
    let p = |i: usize| level.positions[i];
    if ring_e.len() == 4 {
        // The regular case, with the stencil's constants: A_4 = 4, cos and sin of i pi / 2.
        let t1 =
            4.0 * (p(ring_e[0]) - p(ring_e[2])) + p(ring_f[0]) - p(ring_f[1]) - p(ring_f[2]) + p(ring_f[3]);
        let t2 =
            4.0 * (p(ring_e[1]) - p(ring_e[3])) + p(ring_f[0]) + p(ring_f[1]) - p(ring_f[2]) - p(ring_f[3]);
        return t1.cross(t2);
    }
    let n = ring_e.len();
    let nf = n as f64;
    let a_n = 1.0 + (2.0 * PI / nf).cos() + (PI / nf).cos() * (2.0 * (9.0 + (2.0 * PI / nf).cos())).sqrt();
    let (mut t1, mut t2) = (DVec3::ZERO, DVec3::ZERO);
    let angle = |i: usize| (2.0 * PI * i as f64 / nf).sin_cos();
    let (mut s0, mut c0) = angle(0);
    for i in 0..n {
        let (s1, c1) = angle(i + 1);
        let (e, f) = (p(ring_e[i]), p(ring_f[i]));
        t1 += a_n * c0 * e + (c0 + c1) * f;
        t2 += a_n * s0 * e + (s0 + s1) * f;
        (s0, c0) = (s1, c1);
    }
    t1.cross(t2)
}

/// Vertices around which uniform refinement converges slowly: sharp corners, darts, and
/// extraordinary vertices (valence other than 4 inside or along a crease, other than 3 on a
/// boundary). The faces around them are refined adaptively.
pub(super) fn special_vertices(level: &Level, boundary: Boundary) -> Vec<bool> {
    let rule = rules(level, boundary);
    (0..level.positions.len())
        .map(|v| {
            if level.faces_of(v).is_empty() {
                return false;
            }
            let valence = level.edges_of(v).len();
            let sharp = level
                .edges_of(v)
                .iter()
                .filter(|&&e| {
                    let e = &level.edges[e as usize];
                    e.faces != 2 || e.sharpness > 0.0
                })
                .count();
            match rule[v] {
                Rule::Corner => true,
                Rule::Crease(..) => valence != if level.is_boundary_vertex(v) { 3 } else { 4 },
                Rule::Smooth => sharp == 1 || valence != 4,
            }
        })
        .collect()
}

/// How far each face of a level is from the limit surface (0 for hidden faces): the next
/// level's edge and face points on the limit against the face's flat triangles, times 4/3
/// (sampled at edge midpoints and quad centres; inside a triangle a quadratic error reaches
/// up to 4/3 of its largest edge-midpoint value).
pub(super) fn face_deviations(level: &Level, level_limit: &[DVec3], next_limit: &[DVec3]) -> Vec<f64> {
    let (nv, ne) = (level.positions.len(), level.edges.len());
    (0..level.face_count())
        .map(|f| {
            if level.face_hidden[f] {
                return 0.0;
            }
            let r = level.face(f);
            let q: Vec<DVec3> = r.clone().map(|c| level_limit[level.face_verts[c] as usize]).collect();
            let centre = next_limit[nv + ne + f];
            let mut worst = 0.0f64;
            if q.len() == 4 {
                worst = centre.distance(0.5 * (q[0] + q[2])).max(centre.distance(0.5 * (q[1] + q[3])));
            }
            for c in r {
                let e = level.face_edges[c] as usize;
                let [a, b] = level.edges[e].v.map(|v| level_limit[v as usize]);
                worst = worst.max(next_limit[nv + e].distance(0.5 * (a + b)));
            }
            4.0 / 3.0 * worst
        })
        .collect()
}

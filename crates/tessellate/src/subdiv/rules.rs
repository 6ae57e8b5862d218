//! One Catmull-Clark step: face, edge and vertex points with DeRose's semi-sharp creases,
//! corners and boundaries.

use super::level::{Boundary, Edge, Level};
use glam::{DVec2, DVec3};

/// How a vertex moves: its rule and the ends of its sharp edges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Rule {
    Smooth,
    Crease(usize, usize),
    Corner,
}

/// The rule of vertex `v` with edge sharpness lowered by `lowered` (0: this level, 1: next).
pub(super) fn vertex_rule(level: &Level, v: usize, lowered: f64, boundary: Boundary) -> Rule {
    let mut ends = [0usize; 2];
    let mut sharp = 0usize;
    let mut faces_boundary = 0usize;
    for &e in level.edges_of(v) {
        let edge = &level.edges[e as usize];
        let is_sharp = edge.faces != 2 || edge.sharpness - lowered > 0.0;
        if edge.faces != 2 {
            faces_boundary += 1;
        }
        if is_sharp {
            if sharp < 2 {
                ends[sharp] = level.other_end(e, v);
            }
            sharp += 1;
        }
    }
    let corner_vertex =
        boundary == Boundary::EdgeAndCorner && faces_boundary == 2 && level.faces_of(v).len() == 1;
    if level.vertex_sharpness[v] - lowered > 0.0 || sharp > 2 || corner_vertex {
        Rule::Corner
    } else if sharp == 2 {
        Rule::Crease(ends[0], ends[1])
    } else {
        Rule::Smooth
    }
}

/// Every vertex's rule at this level.
pub(super) fn rules(level: &Level, boundary: Boundary) -> Vec<Rule> {
    (0..level.positions.len()).map(|v| vertex_rule(level, v, 0.0, boundary)).collect()
}

pub(super) fn lowered_sharpness(s: f64) -> f64 {
    if s.is_infinite() { s } else { (s - 1.0).max(0.0) }
}

/// One Catmull-Clark step.
pub(super) fn subdivide(level: &Level, boundary: Boundary) -> Level {
    let (nv, ne, nf) = (level.positions.len(), level.edges.len(), level.face_count());
    let mut positions = vec![DVec3::ZERO; nv + ne + nf];

    // Face points.
    for f in 0..nf {
        let r = level.face(f);
        let n = r.len() as f64;
        positions[nv + ne + f] = r.map(|c| level.positions[level.face_verts[c] as usize]).sum::<DVec3>() / n;
    }
    // Edge points.
    for (e, edge) in level.edges.iter().enumerate() {
        let (a, b) = (level.positions[edge.v[0] as usize], level.positions[edge.v[1] as usize]);
        let mid = 0.5 * (a + b);
        positions[nv + e] = if edge.faces != 2 || edge.sharpness >= 1.0 {
            mid
        } else {
            let smooth = 0.25
                * (a + b
                    + positions[nv + ne + edge.face[0] as usize]
                    + positions[nv + ne + edge.face[1] as usize]);
            if edge.sharpness > 0.0 { smooth.lerp(mid, edge.sharpness) } else { smooth }
        };
    }
    // Vertex points.
    for v in 0..nv {
        let p = level.positions[v];
        let apply = |rule: Rule| -> DVec3 {
            match rule {
                Rule::Corner => p,
                Rule::Crease(a, b) => (level.positions[a] + 6.0 * p + level.positions[b]) / 8.0,
                Rule::Smooth => {
                    let faces = level.faces_of(v);
                    let edges = level.edges_of(v);
                    if faces.is_empty() || edges.is_empty() {
                        return p;
                    }
                    let n = edges.len() as f64;
                    let f_avg = faces.iter().map(|&(f, _)| positions[nv + ne + f as usize]).sum::<DVec3>()
                        / faces.len() as f64;
                    let r_avg = edges
                        .iter()
                        .map(|&e| 0.5 * (p + level.positions[level.other_end(e, v)]))
                        .sum::<DVec3>()
                        / n;
                    (f_avg + 2.0 * r_avg + (n - 3.0) * p) / n
                }
            }
        };
        let parent = vertex_rule(level, v, 0.0, boundary);
        let child = vertex_rule(level, v, 1.0, boundary);
        positions[v] = if parent == child || matches!(parent, Rule::Smooth) {
            apply(parent)
        } else {
            // Sharpness runs out here: blend by the fractional sharpness that runs out.
            let mut weights = Vec::new();
            for &e in level.edges_of(v) {
                let s = level.edges[e as usize].sharpness;
                if level.edges[e as usize].faces == 2 && s > 0.0 && s <= 1.0 {
                    weights.push(s);
                }
            }
            let vs = level.vertex_sharpness[v];
            if vs > 0.0 && vs <= 1.0 {
                weights.push(vs);
            }
            let alpha =
                if weights.is_empty() { 1.0 } else { weights.iter().sum::<f64>() / weights.len() as f64 };
            apply(child).lerp(apply(parent), alpha.clamp(0.0, 1.0))
        };
    }

    // Children: one quad per face corner, counter-clockwise like the parent. Child edges:
    // `2e` and `2e + 1` are the halves of parent edge `e` (from `v[0]` and to `v[1]`), and
    // `2E + c` joins the edge point of corner `c`'s edge to its face point.
    let corners = level.face_verts.len();
    let mut edges = Vec::with_capacity(2 * ne + corners);
    for (e, edge) in level.edges.iter().enumerate() {
        let (ep, s) = ((nv + e) as u32, lowered_sharpness(edge.sharpness));
        edges.push(Edge { v: [edge.v[0], ep], faces: 0, face: [u32::MAX; 2], sharpness: s });
        edges.push(Edge { v: [ep, edge.v[1]], faces: 0, face: [u32::MAX; 2], sharpness: s });
    }
    let mut child = Level {
        positions,
        face_start: (0..=corners as u32).map(|i| 4 * i).collect(),
        face_verts: Vec::with_capacity(4 * corners),
        face_edges: Vec::with_capacity(4 * corners),
        face_origin: Vec::with_capacity(corners),
        face_hidden: Vec::with_capacity(corners),
        face_tag: Vec::with_capacity(corners),
        vertex_sharpness: Vec::with_capacity(nv + ne + nf),
        st: level.st.as_ref().map(|_| Vec::with_capacity(4 * corners)),
        ..Default::default()
    };
    // The half of parent edge `e` that touches vertex `v`.
    let half = |e: u32, v: u32| 2 * e + u32::from(level.edges[e as usize].v[0] != v);
    for f in 0..nf {
        let r = level.face(f);
        let n = r.len();
        let fp = (nv + ne + f) as u32;
        let st_centre = level.st.as_ref().map(|st| r.clone().map(|c| st[c]).sum::<DVec2>() / n as f64);
        for k in 0..n {
            let c = r.start + k;
            let prev = r.start + (k + n - 1) % n;
            let v = level.face_verts[c];
            let (e_next, e_prev) = (level.face_edges[c], level.face_edges[prev]);
            edges.push(Edge { v: [nv as u32 + e_next, fp], faces: 0, face: [u32::MAX; 2], sharpness: 0.0 });
            child.face_verts.extend_from_slice(&[v, nv as u32 + e_next, fp, nv as u32 + e_prev]);
            child.face_edges.extend_from_slice(&[
                half(e_next, v),
                (2 * ne + c) as u32,
                (2 * ne + prev) as u32,
                half(e_prev, v),
            ]);
            child.face_origin.push(level.face_origin[f]);
            child.face_hidden.push(level.face_hidden[f]);
            child.face_tag.push(level.face_tag[f]);
            if let (Some(out), Some(st), Some(centre)) = (child.st.as_mut(), level.st.as_ref(), st_centre) {
                let next = r.start + (k + 1) % n;
                out.extend_from_slice(&[st[c], 0.5 * (st[c] + st[next]), centre, 0.5 * (st[prev] + st[c])]);
            }
        }
    }
    child.edges = edges;
    child.vertex_sharpness.extend(level.vertex_sharpness.iter().map(|&s| lowered_sharpness(s)));
    child.vertex_sharpness.resize(nv + ne + nf, 0.0);
    child.build_adjacency();
    child
}

//! Adaptive refinement: the faces that miss the tolerance are refined on their own, one level
//! at a time, each with the one-ring their limit surface depends on.

use super::level::{Boundary, Level};
use super::limit::{face_deviations, limit};
use super::rules::{Rule, rules, subdivide};
use super::{KIND, MAX_LEVEL, Planning, TessellateError, Tolerance, check_budget, invalid};
use glam::DVec3;
use std::collections::HashMap;

/// The one-ring sub-mesh of some faces of a level: those faces (tagged with their index in
/// `faces`) and every face sharing a vertex with them, which is all a Catmull-Clark face's
/// limit surface depends on.
pub(super) struct Ring {
    pub(super) mesh: Level,
    /// The level's vertex of each sub-mesh vertex.
    pub(super) global: Vec<u32>,
    /// The sub-mesh vertex of each level vertex in it.
    pub(super) local: HashMap<u32, u32>,
    /// The sub-mesh face of each of the given faces.
    pub(super) face_of: Vec<u32>,
}

impl Ring {
    pub(super) fn new(level: &Level, faces: &[usize]) -> Ring {
        let mut ring = vec![false; level.face_count()];
        let mut tag = vec![u32::MAX; level.face_count()];
        for (i, &f) in faces.iter().enumerate() {
            tag[f] = i as u32;
            for c in level.face(f) {
                for &(g, _) in level.faces_of(level.face_verts[c] as usize) {
                    ring[g as usize] = true;
                }
            }
        }
        let mut local: HashMap<u32, u32> = HashMap::new();
        let mut global = Vec::new();
        let mut face_of = vec![0u32; faces.len()];
        let mut sub =
            Level { face_start: vec![0], st: level.st.as_ref().map(|_| Vec::new()), ..Default::default() };
        for f in (0..level.face_count()).filter(|&f| ring[f]) {
            if tag[f] != u32::MAX {
                face_of[tag[f] as usize] = sub.face_origin.len() as u32;
            }
            for c in level.face(f) {
                let v = level.face_verts[c];
                let id = *local.entry(v).or_insert_with(|| {
                    global.push(v);
                    sub.positions.push(level.positions[v as usize]);
                    sub.vertex_sharpness.push(level.vertex_sharpness[v as usize]);
                    (global.len() - 1) as u32
                });
                sub.face_verts.push(id);
                if let (Some(out), Some(st)) = (sub.st.as_mut(), level.st.as_ref()) {
                    out.push(st[c]);
                }
            }
            sub.face_start.push(sub.face_verts.len() as u32);
            sub.face_origin.push(level.face_origin[f]);
            sub.face_hidden.push(level.face_hidden[f]);
            sub.face_tag.push(tag[f]);
        }
        let mut sharp = HashMap::new();
        for e in &level.edges {
            if e.sharpness > 0.0
                && let (Some(&a), Some(&b)) = (local.get(&e.v[0]), local.get(&e.v[1]))
            {
                sharp.insert((a.min(b), a.max(b)), e.sharpness);
            }
        }
        sub.build_topology(&sharp);
        Ring { mesh: sub, global, local, face_of }
    }
}

/// One node of the adaptive refinement: a level (the drawn level at the root, else one step
/// below its parent's ring of refined faces), the faces it draws, and the edges its child
/// splits.
pub(super) struct Node {
    pub(super) level: Level,
    pub(super) limit: (Vec<DVec3>, Vec<DVec3>),
    /// For a child: its parent node, and the parent vertex of each of its first vertices
    /// (vertex points keep their index through a subdivision step).
    pub(super) parent: Option<(usize, Vec<u32>)>,
    /// Faces of `level` drawn here.
    pub(super) drawn: Vec<usize>,
    /// Edges of `level` (by their ends) that the child refines, with the child's vertex in
    /// their middle.
    pub(super) split: HashMap<(u32, u32), u32>,
}

pub(super) fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Refines, below node `id`, the faces among `candidates` that miss the tolerance, one level
/// at a time, until every drawn face meets it (faces at sharp corners excepted) or the budget
/// or depth runs out.
pub(super) fn refine(
    nodes: &mut Vec<Node>,
    root: usize,
    root_candidates: Vec<usize>,
    (eps, boundary, tol): (f64, Boundary, &Tolerance),
    planning: &mut Planning,
) -> Result<(), TessellateError> {
    let (mut id, mut candidates, mut depth) = (root, root_candidates, 0u32);
    let mut faces_so_far = nodes[root].level.face_count() as f64;
    while !candidates.is_empty() && depth < MAX_LEVEL {
        let level = &nodes[id].level;
        let ring = Ring::new(level, &candidates);
        check_budget(KIND, 2.0 * (faces_so_far + 4.0 * ring.mesh.face_count() as f64), tol)?;
        let child_level = subdivide(&ring.mesh, boundary);
        let child_limit = limit(&child_level, boundary);
        let bad: Vec<bool> = match planning {
            // Another key's choice, face for face.
            Planning::Replay(plan) => match plan.refined.get(depth as usize) {
                Some(bad) if bad.len() == candidates.len() => bad.clone(),
                Some(_) => return Err(invalid("its keys refine different faces".into())),
                None => break,
            },
            _ => {
                // Each candidate against the child's edge and face points on the limit.
                let ring_limit: Vec<DVec3> =
                    ring.global.iter().map(|&g| nodes[id].limit.0[g as usize]).collect();
                let deviations = face_deviations(&ring.mesh, &ring_limit, &child_limit.0);
                if deviations.iter().any(|d| !d.is_finite()) {
                    return Err(TessellateError::NonFinite {
                        kind: KIND,
                        reason: "subdivision diverged".into(),
                    });
                }
                let level = &nodes[id].level;
                let rule = rules(level, boundary);
                candidates
                    .iter()
                    .enumerate()
                    .map(|(i, &f)| {
                        // Faces at sharp corners (cone points) converge only linearly however far
                        // they are refined: they do not decide anything.
                        let at_corner =
                            level.face(f).any(|c| rule[level.face_verts[c] as usize] == Rule::Corner);
                        deviations[ring.face_of[i] as usize] > eps && !at_corner
                    })
                    .collect()
            }
        };
        if !bad.contains(&true) {
            break;
        }
        if let Planning::Record(plan) = planning {
            plan.refined.push(bad.clone());
        }
        let level = &nodes[id].level;
        // The bad faces are replaced by their children; the others stay drawn here.
        let mut split = HashMap::new();
        let n_ring = ring.mesh.positions.len() as u32;
        let mut replaced = vec![false; level.face_count()];
        for (i, &f) in candidates.iter().enumerate().filter(|&(i, _)| bad[i]) {
            replaced[f] = true;
            for c in level.face(f) {
                let e = &level.edges[level.face_edges[c] as usize];
                let (a, b) = (e.v[0], e.v[1]);
                let (la, lb) = (ring.local[&a], ring.local[&b]);
                let ring_face = ring.face_of[i] as usize;
                // The ring's edge between them: one of its face's edges.
                let ring_edge = ring
                    .mesh
                    .face(ring_face)
                    .map(|rc| ring.mesh.face_edges[rc])
                    .find(|&re| {
                        key(ring.mesh.edges[re as usize].v[0], ring.mesh.edges[re as usize].v[1])
                            == key(la, lb)
                    })
                    .expect("a face's edge is in its ring");
                split.insert(key(a, b), n_ring + ring_edge);
            }
        }
        nodes[id].drawn.retain(|&f| !replaced[f]);
        nodes[id].split = split;
        let drawn: Vec<usize> = (0..child_level.face_count())
            .filter(|&f| {
                let tag = child_level.face_tag[f];
                tag != u32::MAX && bad[tag as usize] && !child_level.face_hidden[f]
            })
            .collect();
        // Tags of the child: the index of each face among its drawn faces, for the next step.
        faces_so_far += drawn.len() as f64;
        nodes.push(Node {
            level: child_level,
            limit: child_limit,
            parent: Some((id, ring.global)),
            drawn: drawn.clone(),
            split: HashMap::new(),
        });
        id = nodes.len() - 1;
        candidates = drawn;
        depth += 1;
    }
    Ok(())
}

//! Triangle geometry for haptic rendering: a collision mesh kept relative to a local origin, and
//! the exact point and swept-sphere queries against one triangle that the BVH and the proxy use.
//!
//! Precision: a scene may sit far from its world origin (a city model at x = 1e6) while the
//! proxy moves by micrometres per tick. Vertices are therefore stored as `f32` **relative to a
//! local origin** (normally the centre of the scene's bounding box), and every query runs in
//! `f64` on those values. Queries see exactly the same triangles whatever they ask, so the
//! proxy's non-penetration guarantee holds against the stored geometry to `f64` rounding.

use glam::{DVec3, Vec3};

/// Index of a haptic material in a [`crate::MaterialTable`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MaterialId(pub u32);

/// Errors building a collision mesh.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum GeometryError {
    #[error("triangle {triangle}: vertex {vertex} is not finite ({value})")]
    NonFiniteVertex { triangle: usize, vertex: usize, value: DVec3 },
    #[error(
        "vertex index {index} of triangle {triangle} is out of range (the mesh has {vertex_count} vertices)"
    )]
    IndexOutOfRange { triangle: usize, index: u32, vertex_count: usize },
    #[error("too many triangles: {count} (the limit is {limit})")]
    TooManyTriangles { count: usize, limit: usize },
    #[error("vertex normals: {normals} given for {vertices} vertices")]
    NormalCountMismatch { normals: usize, vertices: usize },
}

/// The most triangles one collision mesh may hold (indices are `u32`; this also bounds memory).
pub const MAX_TRIANGLES: usize = 1 << 28;

/// Triangles in a local frame (`world = origin + local`) with a material per triangle and
/// optional per-vertex normals (used only for force shading).
#[derive(Clone, Debug, Default)]
pub struct CollisionMesh {
    origin: DVec3,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    materials: Vec<MaterialId>,
    dropped_degenerate: usize,
}

impl CollisionMesh {
    /// An empty mesh whose local frame is centred on `origin` (world coordinates).
    pub fn new(origin: DVec3) -> CollisionMesh {
        CollisionMesh { origin, ..CollisionMesh::default() }
    }

    /// The world position of the local frame's origin.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// World -> local (the frame the proxy works in).
    pub fn local_from_world(&self, world: DVec3) -> DVec3 {
        world - self.origin
    }

    /// Local -> world.
    pub fn world_from_local(&self, local: DVec3) -> DVec3 {
        local + self.origin
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Triangles that were dropped because their area was zero (they cannot be touched: their
    /// edges belong to their neighbours, and a lone degenerate triangle has no surface).
    pub fn dropped_degenerate(&self) -> usize {
        self.dropped_degenerate
    }

    /// The three local-frame vertices of triangle `index`, in `f64`.
    pub fn triangle_local(&self, index: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[index];
        [
            self.positions[a as usize].as_dvec3(),
            self.positions[b as usize].as_dvec3(),
            self.positions[c as usize].as_dvec3(),
        ]
    }

    /// The stored `f32` vertices of triangle `index`.
    pub fn triangle_f32(&self, index: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[index];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    pub fn material(&self, index: usize) -> MaterialId {
        self.materials[index]
    }

    /// Unit vertex normals of triangle `index`, when the mesh has them.
    pub fn vertex_normals(&self, index: usize) -> Option<[Vec3; 3]> {
        if self.normals.is_empty() {
            return None;
        }
        let [a, b, c] = self.triangles[index];
        Some([self.normals[a as usize], self.normals[b as usize], self.normals[c as usize]])
    }

    pub fn has_vertex_normals(&self) -> bool {
        !self.normals.is_empty()
    }

    /// Adds one world-space triangle. Degenerate triangles are counted and skipped.
    pub fn push_world_triangle(
        &mut self,
        world: [DVec3; 3],
        material: MaterialId,
    ) -> Result<(), GeometryError> {
        self.push_indexed(&world, &[[0, 1, 2]], None, material)
    }

    /// Adds an indexed world-space mesh (`positions` in world coordinates, `f64`), all of one
    /// material, with optional per-vertex normals. A mesh with normals and one without cannot be
    /// mixed: once any part has normals, parts without get their face normals per vertex.
    pub fn push_indexed(
        &mut self,
        positions: &[DVec3],
        triangles: &[[u32; 3]],
        normals: Option<&[DVec3]>,
        material: MaterialId,
    ) -> Result<(), GeometryError> {
        let total = self.triangles.len().saturating_add(triangles.len());
        if total > MAX_TRIANGLES {
            return Err(GeometryError::TooManyTriangles { count: total, limit: MAX_TRIANGLES });
        }
        if let Some(n) = normals
            && n.len() != positions.len()
        {
            return Err(GeometryError::NormalCountMismatch { normals: n.len(), vertices: positions.len() });
        }
        for (t, tri) in triangles.iter().enumerate() {
            for (v, &index) in tri.iter().enumerate() {
                let Some(p) = positions.get(index as usize) else {
                    return Err(GeometryError::IndexOutOfRange {
                        triangle: t,
                        index,
                        vertex_count: positions.len(),
                    });
                };
                if !p.is_finite() {
                    return Err(GeometryError::NonFiniteVertex { triangle: t, vertex: v, value: *p });
                }
            }
        }
        let base = self.positions.len();
        if base + positions.len() > u32::MAX as usize {
            return Err(GeometryError::TooManyTriangles { count: total, limit: MAX_TRIANGLES });
        }
        // Once normals are present, every vertex needs one: fill earlier parts with zeros,
        // which force shading treats as "no normal" (it falls back to the face normal).
        if normals.is_some() && self.normals.len() < base {
            self.normals.resize(base, Vec3::ZERO);
        }
        self.positions.extend(positions.iter().map(|p| (*p - self.origin).as_vec3()));
        match normals {
            Some(n) => self.normals.extend(n.iter().map(|v| v.normalize_or_zero().as_vec3())),
            None if !self.normals.is_empty() => {
                self.normals.resize(self.positions.len(), Vec3::ZERO);
            }
            None => {}
        }
        for tri in triangles {
            let local = [tri[0] as usize + base, tri[1] as usize + base, tri[2] as usize + base];
            let [a, b, c] = local.map(|i| self.positions[i].as_dvec3());
            // Area test on the stored f32 values, in f64: exactly what the queries will see.
            let twice_area = (b - a).cross(c - a).length();
            let scale = (b - a).length().max((c - a).length()).max((c - b).length());
            if !(twice_area > 1e-12 * scale * scale) {
                self.dropped_degenerate += 1;
                continue;
            }
            self.triangles.push(local.map(|i| i as u32));
            self.materials.push(material);
        }
        Ok(())
    }

    /// Local-frame bounds of all triangles (`None` when empty).
    pub fn local_bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for tri in &self.triangles {
            for &i in tri {
                let p = self.positions[i as usize].as_dvec3();
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (!self.triangles.is_empty()).then_some((lo, hi))
    }
}

/// The centre of the axis-aligned bounds of a set of world-space points (the origin to use for
/// a [`CollisionMesh`]); `None` for no points or non-finite ones.
pub fn bounds_centre(points: impl IntoIterator<Item = DVec3>) -> Option<DVec3> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut any = false;
    for p in points {
        if !p.is_finite() {
            return None;
        }
        lo = lo.min(p);
        hi = hi.max(p);
        any = true;
    }
    any.then(|| (lo + hi) * 0.5)
}

// ---------------------------------------------------------------------------------------------
// Queries against one triangle

/// Which part of a triangle a closest point or contact lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    Face,
    /// Edge `i` runs from vertex `i` to vertex `(i + 1) % 3`.
    Edge(u8),
    Vertex(u8),
}

/// The closest point of triangle `[a, b, c]` to `p`, with the feature it lies on and its
/// barycentric coordinates (Ericson, Real-Time Collision Detection, 5.1.5).
pub fn closest_point_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> (DVec3, Feature, DVec3) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0), DVec3::X);
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1), DVec3::Y);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, Feature::Edge(0), DVec3::new(1.0 - v, v, 0.0));
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2), DVec3::Z);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, Feature::Edge(2), DVec3::new(1.0 - w, 0.0, w));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, Feature::Edge(1), DVec3::new(0.0, 1.0 - w, w));
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w, Feature::Face, DVec3::new(1.0 - v - w, v, w))
}

/// First contact of a sphere moving along a segment with a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepContact {
    /// Fraction of the segment travelled at contact, in `[0, 1]`.
    pub t: f64,
    /// Unit normal of the contact: from the surface point towards the sphere's centre.
    pub normal: DVec3,
    /// The point of the triangle that is touched.
    pub surface_point: DVec3,
    pub feature: Feature,
    /// Barycentric coordinates of `surface_point`.
    pub barycentric: DVec3,
    /// Distance from the sphere's starting centre to the triangle (ranks contacts met at
    /// `t = 0`: the closest triangle is the one really touched).
    pub start_distance: f64,
}

/// Tolerance of the swept-sphere test.
///
/// Contacts are decided by depth, not by angle: a motion counts as a contact only if it would
/// take the sphere more than `skin` closer than `radius` to the triangle. A proxy resting on a
/// surface (its distance equal to the radius up to rounding) therefore slides freely, even over
/// the edges a face shares with coplanar neighbours, whose contact normals rounding can tilt by
/// `sqrt(rounding / radius)`; and no motion ever leaves the sphere's centre closer than
/// `radius - skin` to any triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepTolerance {
    pub skin: f64,
}

impl SweepTolerance {
    /// `skin = 1e-8 * radius`: far above `f64` rounding for any scene whose extent is below
    /// 1e6 radii around the mesh's local origin, far below anything a hand can feel.
    pub fn for_radius(radius: f64) -> SweepTolerance {
        SweepTolerance { skin: radius * 1e-8 }
    }
}

/// Where a sphere of `radius` whose centre moves from `p0` by `d` first touches triangle `tri`,
/// at a fraction `t <= t_max` of the motion; `None` when there is no contact (see
/// [`SweepTolerance`] for what counts).
///
/// The set of centres within `radius` of a triangle is the union of a prism over the face, three
/// cylinders around the edges and three spheres at the vertices; the first contact is the
/// earliest entry into any of them. The distance along a line to a convex set is convex, so a
/// sphere that starts touching and moves away never comes back.
pub fn sweep_sphere_triangle(
    p0: DVec3,
    d: DVec3,
    radius: f64,
    tri: [DVec3; 3],
    t_max: f64,
    tol: SweepTolerance,
) -> Option<SweepContact> {
    let dd = d.length_squared();
    if !(dd > 0.0) {
        return None;
    }
    let floor = radius - tol.skin;
    let (q0, feature0, bary0) = closest_point_on_triangle(p0, tri);
    let offset0 = p0 - q0;
    let dist0 = offset0.length();
    let [a, b, c] = tri;
    let face_normal = (b - a).cross(c - a).normalize_or_zero();

    if dist0 < radius + tol.skin {
        // Touching at the start: a contact only if the motion goes into the surface, i.e.
        // comes closer than the floor somewhere along it (exactly: segment-triangle distance).
        let normal = if dist0 > radius * 1e-9 {
            offset0 / dist0
        } else {
            // The centre lies on the triangle: take the face side opposite to the motion.
            if face_normal.dot(d) > 0.0 { -face_normal } else { face_normal }
        };
        let approach = normal.dot(d);
        let goes_in = approach < 0.0 && (dist0 < floor || segment_triangle_distance(p0, p0 + d, tri) < floor);
        if goes_in {
            return Some(SweepContact {
                t: 0.0,
                normal,
                surface_point: q0,
                feature: feature0,
                barycentric: bary0,
                start_distance: dist0,
            });
        }
        return None;
    }

    let r2 = radius * radius;
    let mut best: Option<SweepContact> = None;
    let mut t_best = t_max;

    // Face: the plane offset by `radius` on the side the centre starts on.
    if face_normal != DVec3::ZERO {
        let s0 = face_normal.dot(p0 - a);
        let side = if s0 >= 0.0 { 1.0 } else { -1.0 };
        let approach = side * face_normal.dot(d);
        // Deepest point of the motion inside the offset plane (at its end: depth is linear).
        let depth = radius - (s0.abs() + approach);
        if s0.abs() >= radius && approach < 0.0 && depth > tol.skin {
            let t = (s0.abs() - radius) / -approach;
            if t <= t_best {
                let centre = p0 + d * t;
                let q = centre - face_normal * (side * radius);
                if let Some(bary) = inside_triangle(q, tri) {
                    t_best = t;
                    best = Some(SweepContact {
                        t,
                        normal: face_normal * side,
                        surface_point: q,
                        feature: Feature::Face,
                        barycentric: bary,
                        start_distance: dist0,
                    });
                }
            }
        }
    }

    // Edges: infinite cylinders, accepted where the contact lies within the edge.
    for i in 0..3u8 {
        let e0 = tri[i as usize];
        let e1 = tri[(i as usize + 1) % 3];
        let e = e1 - e0;
        let ee = e.length_squared();
        if !(ee > 0.0) {
            continue;
        }
        let m = p0 - e0;
        let d_perp = d - e * (d.dot(e) / ee);
        let m_perp = m - e * (m.dot(e) / ee);
        let qa = d_perp.length_squared();
        let qb = m_perp.dot(d_perp);
        let qc = m_perp.length_squared() - r2;
        if let Some(t) = entering_root(qa, qb, qc)
            && t <= t_best
            && deepest_penetration(m_perp, d_perp, radius) > tol.skin
        {
            let centre = p0 + d * t;
            let s = (centre - e0).dot(e) / ee;
            if (0.0..=1.0).contains(&s) {
                let q = e0 + e * s;
                let normal = (centre - q).normalize_or_zero();
                if normal != DVec3::ZERO {
                    let mut bary = DVec3::ZERO;
                    bary[i as usize] = 1.0 - s;
                    bary[(i as usize + 1) % 3] = s;
                    t_best = t;
                    best = Some(SweepContact {
                        t,
                        normal,
                        surface_point: q,
                        feature: Feature::Edge(i),
                        barycentric: bary,
                        start_distance: dist0,
                    });
                }
            }
        }
    }

    // Vertices: spheres.
    for i in 0..3u8 {
        let v = tri[i as usize];
        let m = p0 - v;
        if let Some(t) = entering_root(dd, m.dot(d), m.length_squared() - r2)
            && t <= t_best
            && deepest_penetration(m, d, radius) > tol.skin
        {
            let centre = p0 + d * t;
            let normal = (centre - v).normalize_or_zero();
            if normal != DVec3::ZERO {
                let mut bary = DVec3::ZERO;
                bary[i as usize] = 1.0;
                t_best = t;
                best = Some(SweepContact {
                    t,
                    normal,
                    surface_point: v,
                    feature: Feature::Vertex(i),
                    barycentric: bary,
                    start_distance: dist0,
                });
            }
        }
    }
    best
}

/// Distance between the segment `[p, q]` and a triangle: zero when they cross, else the least
/// of the endpoints' distances to the triangle and the segment's distances to the three edges.
pub fn segment_triangle_distance(p: DVec3, q: DVec3, tri: [DVec3; 3]) -> f64 {
    let [a, b, c] = tri;
    let n = (b - a).cross(c - a);
    let sp = n.dot(p - a);
    let sq = n.dot(q - a);
    if (sp <= 0.0 && sq >= 0.0) || (sp >= 0.0 && sq <= 0.0) {
        let denom = sp - sq;
        let t = if denom != 0.0 { sp / denom } else { 0.0 };
        let x = p + (q - p) * t;
        if inside_triangle(x, tri).is_some() {
            return 0.0;
        }
    }
    let mut best = (p - closest_point_on_triangle(p, tri).0).length();
    best = best.min((q - closest_point_on_triangle(q, tri).0).length());
    for i in 0..3 {
        best = best.min(segment_segment_distance(p, q, tri[i], tri[(i + 1) % 3]));
    }
    best
}

/// Distance between segments `[p1, q1]` and `[p2, q2]` (Ericson, 5.1.9).
pub fn segment_segment_distance(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> f64 {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.length_squared();
    let e = d2.length_squared();
    let f = d2.dot(r);
    let (s, t);
    if a <= 0.0 && e <= 0.0 {
        return r.length();
    }
    if a <= 0.0 {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(r);
        if e <= 0.0 {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let s0 = if denom > 0.0 { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            } else {
                t = t0;
                s = s0;
            }
        }
    }
    ((p1 + d1 * s) - (p2 + d2 * t)).length()
}

/// How far inside a sphere (or, with components perpendicular to an axis, a cylinder) of
/// `radius` around the origin the motion `m + t d`, `t` in `[0, 1]`, goes at its deepest.
fn deepest_penetration(m: DVec3, d: DVec3, radius: f64) -> f64 {
    let dd = d.length_squared();
    let t = if dd > 0.0 { (-m.dot(d) / dd).clamp(0.0, 1.0) } else { 0.0 };
    radius - (m + d * t).length()
}

/// The smaller root of `a t^2 + 2 b t + c = 0` when the motion enters the quadric from outside
/// (`c > 0`, approaching: `b < 0`), in the cancellation-free form `c / (-b + sqrt(b^2 - a c))`.
fn entering_root(a: f64, b: f64, c: f64) -> Option<f64> {
    if !(a > 0.0) || !(c > 0.0) || !(b < 0.0) {
        return None;
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let t = c / (-b + disc.sqrt());
    (t >= 0.0).then_some(t)
}

/// Barycentric coordinates of `q` (assumed in the triangle's plane) when it lies inside.
fn inside_triangle(q: DVec3, [a, b, c]: [DVec3; 3]) -> Option<DVec3> {
    let v0 = b - a;
    let v1 = c - a;
    let v2 = q - a;
    let d00 = v0.dot(v0);
    let d01 = v0.dot(v1);
    let d11 = v1.dot(v1);
    let d20 = v2.dot(v0);
    let d21 = v2.dot(v1);
    let denom = d00 * d11 - d01 * d01;
    if !(denom > 0.0) {
        return None;
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    let u = 1.0 - v - w;
    (u >= 0.0 && v >= 0.0 && w >= 0.0).then_some(DVec3::new(u, v, w))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [DVec3; 3] = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];

    #[test]
    fn closest_point_regions() {
        let (q, f, _) = closest_point_on_triangle(DVec3::new(0.2, 0.2, 1.0), TRI);
        assert_eq!(f, Feature::Face);
        assert!((q - DVec3::new(0.2, 0.2, 0.0)).length() < 1e-15);
        let (q, f, _) = closest_point_on_triangle(DVec3::new(-1.0, -1.0, 0.5), TRI);
        assert_eq!((q, f), (TRI[0], Feature::Vertex(0)));
        let (q, f, _) = closest_point_on_triangle(DVec3::new(0.5, -1.0, 0.0), TRI);
        assert_eq!(f, Feature::Edge(0));
        assert!((q - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-15);
        let (q, f, _) = closest_point_on_triangle(DVec3::new(1.0, 1.0, 0.0), TRI);
        assert_eq!(f, Feature::Edge(1));
        assert!((q - DVec3::new(0.5, 0.5, 0.0)).length() < 1e-15);
    }

    #[test]
    fn sweep_hits_face_at_the_offset_plane() {
        let tol = SweepTolerance::for_radius(0.1);
        let hit =
            sweep_sphere_triangle(DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.0, 0.0, -2.0), 0.1, TRI, 1.0, tol)
                .unwrap();
        assert_eq!(hit.feature, Feature::Face);
        assert!((hit.t - 0.45).abs() < 1e-12, "{}", hit.t);
        assert!((hit.normal - DVec3::Z).length() < 1e-12);
        // From below the same triangle is touched from its back side.
        let hit =
            sweep_sphere_triangle(DVec3::new(0.2, 0.2, -1.0), DVec3::new(0.0, 0.0, 2.0), 0.1, TRI, 1.0, tol)
                .unwrap();
        assert!((hit.normal + DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn sweep_hits_edge_and_vertex_capsules() {
        let tol = SweepTolerance::for_radius(0.1);
        // Moving in the triangle's plane towards edge 0 from below (y < 0).
        let hit =
            sweep_sphere_triangle(DVec3::new(0.5, -1.0, 0.0), DVec3::new(0.0, 2.0, 0.0), 0.1, TRI, 1.0, tol)
                .unwrap();
        assert_eq!(hit.feature, Feature::Edge(0));
        assert!((hit.t - 0.45).abs() < 1e-12);
        // Towards vertex 0 along the diagonal.
        let s = 1.0 / 2f64.sqrt();
        let hit = sweep_sphere_triangle(DVec3::new(-s, -s, 0.0), DVec3::new(s, s, 0.0), 0.1, TRI, 1.0, tol)
            .unwrap();
        assert_eq!(hit.feature, Feature::Vertex(0));
        assert!((hit.t - 0.9).abs() < 1e-12);
    }

    #[test]
    fn sweep_ignores_sliding_and_leaving() {
        let tol = SweepTolerance::for_radius(0.1);
        let p0 = DVec3::new(0.2, 0.2, 0.1);
        assert!(sweep_sphere_triangle(p0, DVec3::new(0.1, 0.0, 0.0), 0.1, TRI, 1.0, tol).is_none());
        assert!(sweep_sphere_triangle(p0, DVec3::new(0.0, 0.0, 0.1), 0.1, TRI, 1.0, tol).is_none());
        let hit = sweep_sphere_triangle(p0, DVec3::new(0.0, 0.0, -0.1), 0.1, TRI, 1.0, tol).unwrap();
        assert_eq!(hit.t, 0.0);
    }

    #[test]
    fn sweep_misses_past_the_triangle() {
        let tol = SweepTolerance::for_radius(0.1);
        assert!(
            sweep_sphere_triangle(DVec3::new(2.0, 2.0, 1.0), DVec3::new(0.0, 0.0, -2.0), 0.1, TRI, 1.0, tol)
                .is_none()
        );
        // Stops short.
        assert!(
            sweep_sphere_triangle(DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.0, 0.0, -0.5), 0.1, TRI, 1.0, tol)
                .is_none()
        );
    }

    #[test]
    fn degenerate_triangles_are_dropped() {
        let mut mesh = CollisionMesh::new(DVec3::ZERO);
        mesh.push_world_triangle([DVec3::ZERO, DVec3::X, DVec3::X * 2.0], MaterialId(0)).unwrap();
        mesh.push_world_triangle(TRI, MaterialId(0)).unwrap();
        assert_eq!(mesh.triangle_count(), 1);
        assert_eq!(mesh.dropped_degenerate(), 1);
        let err = mesh.push_world_triangle([DVec3::ZERO, DVec3::X, DVec3::NAN], MaterialId(0));
        assert!(matches!(err, Err(GeometryError::NonFiniteVertex { vertex: 2, .. })));
    }

    #[test]
    fn far_from_origin_keeps_precision_locally() {
        let origin = DVec3::new(1.0e7, -3.0e6, 2.5e6);
        let mut mesh = CollisionMesh::new(origin);
        let tri = TRI.map(|v| v * 1e-3 + origin);
        mesh.push_world_triangle(tri, MaterialId(0)).unwrap();
        let local = mesh.triangle_local(0);
        for (l, w) in local.iter().zip(tri) {
            assert!((mesh.world_from_local(*l) - w).length() < 1e-9);
        }
    }
}

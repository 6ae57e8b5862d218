//! `Curves` and `Points` as triangles: curves as polylines within the chord tolerance, then as
//! round tubes (touchable, any view) or as ribbons facing an eye (what PRMan and pbrt's flat
//! curves render); points as spheres of their width.
//!
//! Widths follow RISpec 3.2 §5.5: `constantwidth` (constant), or `width` (varying: one value
//! per segment end, interpolated linearly; vertex: per control point, interpolated with the
//! basis; uniform: one per curve), default 1. Points take `constantwidth` or a `width` per point.

use super::{TessellateError, Tolerance, TriangleMesh, check_budget};
use glam::{DMat3, DMat4, DVec3, Vec3};
use rib_parser::scene::{Curves, ParamList, ParamValues, Points, StorageClass, Wrap};

/// One curve as a polyline: points, the width at each, and whether it closes on itself.
#[derive(Clone, Debug, PartialEq)]
pub struct CurvePolyline {
    pub points: Vec<DVec3>,
    pub widths: Vec<f64>,
    pub periodic: bool,
}

/// Most points one `Curves` may be sampled into.
const MAX_CURVE_POINTS: u64 = 16_000_000;

fn width_param(params: &ParamList) -> Option<(StorageClass, &[f32])> {
    let p = params.get("width")?;
    match &p.values {
        ParamValues::Floats(v) => Some((p.decl.class, v.as_slice())),
        _ => None,
    }
}

/// The width of every point of a `Points`.
pub fn point_widths(points: &Points) -> Vec<f64> {
    let n = points.positions.len();
    if let Some(w) = points.primvars.float("constantwidth") {
        return vec![f64::from(w); n];
    }
    match width_param(&points.primvars) {
        Some((StorageClass::Constant | StorageClass::Uniform, v)) if !v.is_empty() => {
            vec![f64::from(v[0]); n]
        }
        Some((_, v)) if v.len() >= n => v[..n].iter().map(|&w| f64::from(w)).collect(),
        _ => vec![1.0; n],
    }
}

/// Samples every curve into a polyline whose chords stay within `eps` of the curve.
pub fn curve_polylines(curves: &Curves, eps: f64) -> Result<Vec<CurvePolyline>, TessellateError> {
    curve_polylines_counted(curves, eps, None, &mut Vec::new())
}

/// [`curve_polylines`] with the number of chords of every cubic segment (all curves' in order)
/// pushed to `counts`, or taken from `forced` when given (the same length).
fn curve_polylines_counted(
    curves: &Curves,
    eps: f64,
    forced: Option<&[usize]>,
    counts: &mut Vec<usize>,
) -> Result<Vec<CurvePolyline>, TessellateError> {
    let kind = "Curves";
    let m = curves.v_basis.matrix.map(f64::from);
    let step = curves.v_basis.step.max(1) as usize;
    let periodic = curves.wrap == Wrap::Periodic;
    let constant = curves.primvars.float("constantwidth").map(f64::from);
    let width = width_param(&curves.primvars);
    let (mut vertex_start, mut varying_start) = (0usize, 0usize);
    let mut out = Vec::with_capacity(curves.vertices_per_curve.len());
    let mut total_points = 0u64;
    for (curve, &nv) in curves.vertices_per_curve.iter().enumerate() {
        let nv = nv as usize;
        let cps = curves.positions.get(vertex_start..vertex_start + nv).ok_or_else(|| {
            TessellateError::InvalidShape {
                kind,
                reason: format!("curve {curve} needs more positions than given"),
            }
        })?;
        let cps: Vec<DVec3> = cps.iter().map(|p| p.as_dvec3()).collect();
        let segments = if curves.cubic {
            if periodic { nv / step } else { nv.saturating_sub(4) / step + 1 }
        } else if periodic {
            nv
        } else {
            nv.saturating_sub(1)
        };
        let varying_count = if periodic { segments } else { segments + 1 };
        let vertex_width = |i: usize| -> f64 {
            match (constant, width) {
                (Some(w), _) => w,
                (None, Some((StorageClass::Vertex, v))) => {
                    v.get(vertex_start + i % nv).map_or(1.0, |&w| f64::from(w))
                }
                (None, Some((StorageClass::Uniform, v))) => v.get(curve).map_or(1.0, |&w| f64::from(w)),
                (None, Some((StorageClass::Constant, v))) => v.first().map_or(1.0, |&w| f64::from(w)),
                _ => 1.0,
            }
        };
        let varying_width = |s: usize| -> Option<f64> {
            match (constant, width) {
                (
                    None,
                    Some((StorageClass::Varying | StorageClass::FaceVarying | StorageClass::FaceVertex, v)),
                ) => v.get(varying_start + s % varying_count).map(|&w| f64::from(w)),
                _ => None,
            }
        };
        let mut points = Vec::new();
        let mut widths = Vec::new();
        for s in 0..segments {
            // Control points (and vertex widths) of this segment, and its polynomial coefficients.
            let (coefficients, width_coefficients, n) = if curves.cubic {
                let idx: [usize; 4] = std::array::from_fn(|k| (s * step + k) % nv);
                let g = idx.map(|i| cps[i]);
                let gw = idx.map(vertex_width);
                let mut c = [DVec3::ZERO; 4];
                let mut cw = [0.0f64; 4];
                for r in 0..4 {
                    for k in 0..4 {
                        c[r] += g[k] * m[r * 4 + k];
                        cw[r] += gw[k] * m[r * 4 + k];
                    }
                }
                // |P''(t)| = |6 a t + 2 b| <= 6|a| + 2|b|; chord error <= max|P''| / (8 n^2).
                let bound = 6.0 * c[0].length() + 2.0 * c[1].length();
                let n = ((bound / (8.0 * eps)).sqrt().ceil() as usize).clamp(1, 1 << 16);
                let n = forced.and_then(|f| f.get(counts.len()).copied()).unwrap_or(n).clamp(1, 1 << 16);
                counts.push(n);
                (c, cw, n)
            } else {
                let (a, b) = (cps[s % nv], cps[(s + 1) % nv]);
                let (wa, wb) = (vertex_width(s % nv), vertex_width((s + 1) % nv));
                ([DVec3::ZERO, DVec3::ZERO, b - a, a], [0.0, 0.0, wb - wa, wa], 1)
            };
            total_points += n as u64;
            if total_points > MAX_CURVE_POINTS {
                return Err(TessellateError::TooManyTriangles {
                    kind,
                    estimated: total_points,
                    limit: MAX_CURVE_POINTS,
                });
            }
            let last = s + 1 == segments;
            let first_k = if s == 0 { 0 } else { 1 };
            let end_k = if last && periodic { n - 1 } else { n };
            for k in first_k..=end_k {
                let t = k as f64 / n as f64;
                let c = &coefficients;
                points.push(((c[0] * t + c[1]) * t + c[2]) * t + c[3]);
                let w = match (varying_width(s), varying_width(s + 1)) {
                    (Some(a), Some(b)) => a + (b - a) * t,
                    _ => {
                        let cw = &width_coefficients;
                        ((cw[0] * t + cw[1]) * t + cw[2]) * t + cw[3]
                    }
                };
                widths.push(w.abs());
            }
        }
        if !points.iter().all(|p| p.is_finite()) || !widths.iter().all(|w| w.is_finite()) {
            return Err(TessellateError::NonFinite { kind, reason: format!("curve {curve}") });
        }
        if points.len() >= 2 {
            out.push(CurvePolyline { points, widths, periodic });
        }
        vertex_start += nv;
        varying_start += varying_count;
    }
    Ok(out)
}

/// A unit vector perpendicular to `t`.
fn any_perpendicular(t: DVec3) -> DVec3 {
    let a = if t.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    t.cross(a).normalize_or(DVec3::Z)
}

/// Tangent of a polyline at point `i`.
fn tangent(line: &CurvePolyline, i: usize) -> DVec3 {
    let n = line.points.len();
    let (prev, next) = if line.periodic {
        ((i + n - 1) % n, (i + 1) % n)
    } else {
        (i.saturating_sub(1), (i + 1).min(n - 1))
    };
    (line.points[next] - line.points[prev]).normalize_or_zero()
}

/// Round tubes of the curves' widths (closed by flat caps), within `eps` of the true tubes.
pub(crate) fn tessellate_curves(
    curves: &Curves,
    tol: &Tolerance,
    scale: f64,
) -> Result<TriangleMesh, TessellateError> {
    let size = super::diagonal_of("Curves", curves.positions.iter().map(|p| p.as_dvec3()))?;
    let eps = tol.effective(size, scale)?;
    let lines = curve_polylines(curves, eps)?;
    let max_width = lines.iter().flat_map(|l| l.widths.iter().copied()).fold(0.0f64, f64::max);
    // Ring vertices: the chord of a circle of radius r over angle 2 pi / m stays within eps.
    let ring = |r: f64| -> usize {
        if !(r > eps) {
            return 3;
        }
        let m = std::f64::consts::PI / (1.0 - eps / r).acos();
        (m.ceil() as usize).clamp(3, 64)
    };
    let m = ring(0.5 * max_width);
    let points: u64 = lines.iter().map(|l| l.points.len() as u64).sum();
    check_budget("Curves", (points * m as u64 * 2 + 2 * m as u64 * lines.len() as u64) as f64, tol)?;
    let mut mesh = TriangleMesh::default();
    let mut normals = Vec::new();
    for line in &lines {
        let n = line.points.len();
        let base = mesh.positions.len() as u32;
        // Parallel-transported frames, so the tube does not twist.
        let mut u = any_perpendicular(tangent(line, 0));
        for i in 0..n {
            let t = tangent(line, i);
            let projected = u - t * u.dot(t);
            u = if projected.length_squared() > 1e-24 { projected.normalize() } else { any_perpendicular(t) };
            let v = t.cross(u);
            let r = 0.5 * line.widths[i];
            for k in 0..m {
                let a = std::f64::consts::TAU * k as f64 / m as f64;
                let dir = u * a.cos() + v * a.sin();
                mesh.positions.push((line.points[i] + dir * r).as_vec3());
                normals.push(dir.as_vec3());
            }
        }
        let at = |i: usize, k: usize| base + ((i % n) * m + k % m) as u32;
        let rings = if line.periodic { n } else { n - 1 };
        for i in 0..rings {
            for k in 0..m {
                // Counter-clockwise seen from outside: (u, v, t) is right-handed, so going
                // round the ring and then along the curve turns outward.
                mesh.indices.push([at(i, k), at(i + 1, k + 1), at(i + 1, k)]);
                mesh.indices.push([at(i, k), at(i, k + 1), at(i + 1, k + 1)]);
            }
        }
        if !line.periodic {
            for (i, sign) in [(0usize, -1.0f64), (n - 1, 1.0)] {
                let centre = mesh.positions.len() as u32;
                mesh.positions.push(line.points[i].as_vec3());
                normals.push((tangent(line, i) * sign).as_vec3());
                for k in 0..m {
                    let tri = [centre, at(i, k), at(i, k + 1)];
                    mesh.indices.push(if sign > 0.0 { tri } else { [tri[0], tri[2], tri[1]] });
                }
            }
        }
    }
    mesh.face_index = vec![0; mesh.indices.len()];
    mesh.normals = normals.iter().all(|n| n.length_squared() > 0.5).then_some(normals);
    Ok(mesh)
}

/// What ribbons turn to face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RibbonFacing {
    /// A perspective camera's eye (placed space).
    Eye(DVec3),
    /// Toward an orthographic camera: the unit direction from the scene to it.
    Direction(DVec3),
}

impl RibbonFacing {
    fn toward(&self, p: DVec3) -> DVec3 {
        match *self {
            RibbonFacing::Eye(eye) => (eye - p).normalize_or_zero(),
            RibbonFacing::Direction(d) => d.normalize_or_zero(),
        }
    }
}

/// Ribbons facing the camera, placed by `placed_from_object`: at every polyline point the
/// ribbon spans the width across the direction perpendicular to both the curve and the line of
/// sight (RenderMan's and pbrt's flat curves), so a curve seen side-on projects to exactly its
/// width. Normals face the camera.
pub fn curve_ribbons(
    curves: &Curves,
    placed_from_object: &DMat4,
    facing: RibbonFacing,
    tol: &Tolerance,
) -> Result<TriangleMesh, TessellateError> {
    let linear = DMat3::from_mat4(*placed_from_object);
    let stretch = super::placed::spectral_norm(&linear);
    let size = super::diagonal_of("Curves", curves.positions.iter().map(|p| p.as_dvec3()))?;
    let eps = tol.effective(size, stretch)?;
    let lines = curve_polylines(curves, eps)?;
    ribbons(&lines, placed_from_object, facing, tol)
}

/// [`curve_ribbons`] of every key of a deforming `Curves` (same curves and vertex counts): the
/// keys are sampled with the same number of chords per segment (the most any key needs), so
/// vertex `i` of one key's mesh is vertex `i` of every other's, and the triangles are the first
/// key's.
pub fn curve_ribbons_keys(
    keys: &[&Curves],
    placed_from_object: &DMat4,
    facing: RibbonFacing,
    tol: &Tolerance,
) -> Result<Vec<TriangleMesh>, TessellateError> {
    let linear = DMat3::from_mat4(*placed_from_object);
    let stretch = super::placed::spectral_norm(&linear);
    let mut eps = f64::INFINITY;
    for curves in keys {
        let size = super::diagonal_of("Curves", curves.positions.iter().map(|p| p.as_dvec3()))?;
        eps = eps.min(tol.effective(size, stretch)?);
    }
    let mut most: Vec<usize> = Vec::new();
    for curves in keys {
        let mut counts = Vec::new();
        curve_polylines_counted(curves, eps, None, &mut counts)?;
        if most.is_empty() {
            most = counts;
        } else {
            for (m, c) in most.iter_mut().zip(counts) {
                *m = (*m).max(c);
            }
        }
    }
    let mut meshes = Vec::with_capacity(keys.len());
    for curves in keys {
        let lines = curve_polylines_counted(curves, eps, Some(&most), &mut Vec::new())?;
        let mut mesh = ribbons(&lines, placed_from_object, facing, tol)?;
        if let Some(first) = meshes.first().map(|m: &TriangleMesh| m.indices.clone())
            && first.len() == mesh.indices.len()
        {
            mesh.indices = first;
        }
        meshes.push(mesh);
    }
    Ok(meshes)
}

/// Ribbons along `lines` (object space), placed and facing as [`curve_ribbons`] says.
fn ribbons(
    lines: &[CurvePolyline],
    placed_from_object: &DMat4,
    facing: RibbonFacing,
    tol: &Tolerance,
) -> Result<TriangleMesh, TessellateError> {
    let linear = DMat3::from_mat4(*placed_from_object);
    // Widths scale with the transform's mean stretch (exact for similarities).
    let width_scale = linear.determinant().abs().cbrt();
    let points: u64 = lines.iter().map(|l| l.points.len() as u64).sum();
    check_budget("Curves", 2.0 * points as f64, tol)?;
    let mut mesh = TriangleMesh::default();
    let mut normals = Vec::new();
    for line in lines {
        let placed = CurvePolyline {
            points: line.points.iter().map(|&p| placed_from_object.project_point3(p)).collect(),
            widths: line.widths.iter().map(|&w| w * width_scale).collect(),
            periodic: line.periodic,
        };
        let base = mesh.positions.len() as u32;
        let n = placed.points.len();
        for i in 0..n {
            let p = placed.points[i];
            let t = tangent(&placed, i);
            let to_eye = facing.toward(p);
            let side = t.cross(to_eye).normalize_or_zero();
            let side = if side == DVec3::ZERO { any_perpendicular(t) } else { side };
            let r = 0.5 * placed.widths[i];
            mesh.positions.push((p - side * r).as_vec3());
            mesh.positions.push((p + side * r).as_vec3());
            let normal = side.cross(t).normalize_or(to_eye);
            let normal = if normal.dot(to_eye) < 0.0 { -normal } else { normal };
            normals.push(normal.as_vec3());
            normals.push(normal.as_vec3());
        }
        let segments = if placed.periodic { n } else { n - 1 };
        for i in 0..segments {
            let j = (i + 1) % n;
            let (a, b, c, d) =
                (base + 2 * i as u32, base + 2 * i as u32 + 1, base + 2 * j as u32, base + 2 * j as u32 + 1);
            for tri in [[a, c, d], [a, d, b]] {
                // Wind each triangle toward the eye (its front faces the camera).
                let [pa, pb, pc] = tri.map(|v| mesh.positions[v as usize].as_dvec3());
                let front = (pb - pa).cross(pc - pa).dot(facing.toward(pa)) >= 0.0;
                mesh.indices.push(if front { tri } else { [tri[0], tri[2], tri[1]] });
            }
        }
    }
    mesh.face_index = vec![0; mesh.indices.len()];
    mesh.normals = normals.iter().all(|n| n.length_squared() > 0.5).then_some(normals);
    mesh.check_finite("Curves")?;
    Ok(mesh)
}

/// Spheres of the points' widths, within the tolerance.
pub(crate) fn tessellate_points(
    points: &Points,
    tol: &Tolerance,
    scale: f64,
) -> Result<TriangleMesh, TessellateError> {
    let widths = point_widths(points);
    let mut mesh = TriangleMesh::default();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut budget = *tol;
    for (p, w) in points.positions.iter().zip(widths) {
        let radius = (0.5 * w) as f32;
        if !(radius > 0.0) {
            continue;
        }
        let sphere = rib_parser::scene::Shape::Sphere {
            radius,
            z_min: -radius,
            z_max: radius,
            theta_max_degrees: 360.0,
        };
        let one = super::quadric::tessellate_quadric(&sphere, &budget, scale)?;
        budget.max_triangles = budget.max_triangles.saturating_sub(one.indices.len() as u64);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(one.positions.iter().map(|q| *q + *p));
        normals.extend(one.normals.unwrap_or_else(|| vec![Vec3::Z; one.positions.len()]));
        mesh.indices.extend(one.indices.iter().map(|t| t.map(|v| v + base)));
    }
    mesh.face_index = vec![0; mesh.indices.len()];
    mesh.normals = Some(normals);
    Ok(mesh)
}

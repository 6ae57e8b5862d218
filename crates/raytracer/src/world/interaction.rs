//! The surface at a ray's hit: position, normals, texture coordinates and their footprint,
//! and the material and emitter of the shape hit, from the hit the ray queries return.

use super::{Hit, HitDetail, MeshShading, Ray, SurfaceInteraction, World};
use crate::accel::X86_64V3;
use crate::math::{round_point, transform_normal, transform_point_error};
use crate::shapes::{barycentric_point, barycentric_point_rounded_v3};
use glam::{DMat4, DVec3, Vec2, Vec3};

impl World {
    /// Evaluates the surface at a hit. Texture coordinates and their footprint (`st`,
    /// `st_width`) are computed only for materials that read a texture; they are zero for the
    /// others.
    #[inline]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        if self.flat
            && let HitDetail::Triangle(i, b) = hit.detail
        {
            return self.interaction_flat(None, ray, hit.t, i, b);
        }
        self.interaction_general(ray, hit)
    }

    /// [`World::interaction`] written into `out`, which it replaces whole: where the record
    /// is stored (the wavefront's) it is built there. Returned by value, the flat case's
    /// record shared its return slot with the general case's out-of-line call, so it was built
    /// on the stack and copied in with `memcpy`. `v3` is the caller's proof of x86-64-v3, for
    /// the hit point's lanes ([`barycentric_point_rounded_v3`]).
    // Always inlined into the wavefront's x86-64-v3 batch, its one caller.
    #[inline(always)]
    pub(crate) fn write_interaction(
        &self,
        v3: Option<X86_64V3>,
        ray: &Ray,
        hit: &Hit,
        out: &mut SurfaceInteraction,
    ) {
        if self.flat
            && let HitDetail::Triangle(i, b) = hit.detail
        {
            *out = self.interaction_flat(v3, ray, hit.t, i, b);
        } else {
            *out = self.interaction_general(ray, hit);
        }
    }

    /// [`World::interaction`] in a flat world (`flat.rs`): one BLAS of triangles alone, placed
    /// as it is, so no deformation, placement or solid to look at. The same `f32` and `f64`
    /// operations as [`World::interaction_general`] in the same order, so the same surface
    /// bit for bit; what it leaves out (the checks and bounds checks of the general case,
    /// about half of that function's instructions, and the record's copy where it is inlined)
    /// was a tenth of a Cornell box sample's.
    #[inline(always)]
    fn interaction_flat(
        &self,
        v3: Option<X86_64V3>,
        ray: &Ray,
        t: f32,
        i: u32,
        b: [f64; 3],
    ) -> SurfaceInteraction {
        let inst = &self.instances[0];
        let blas = &self.blases[inst.blas as usize];
        let tri = &blas.triangles[i as usize];
        let surface = &self.flat_surfaces[i as usize];
        let sides = self.flat_sides[i as usize];
        // The material's and the mesh's flags, read at build.
        let wants_st = sides & super::TEXTURE_COORDINATES != 0;
        let tp = tri.p;
        let (p64, p, p_error) = barycentric_point_rounded_v3(v3, b, &tri.p);
        let mesh = if sides & (super::SHADING_NORMALS | super::TEXTURE_COORDINATES) != 0 {
            blas.shapes[tri.shape as usize].mesh.map(|m| &blas.meshes[m as usize])
        } else {
            None
        };
        let bw = [b[0] as f32, b[1] as f32, b[2] as f32];
        // The mesh's vertex indices are read only where its normals or `st` are.
        let ns_blas = match mesh {
            Some(MeshShading { normals: Some(normals), triangles, .. }) => {
                vertex_normal(normals, triangles[tri.index as usize], bw)
            }
            _ => None,
        };
        let (mut st, mut st_per_length) = (Vec2::ZERO, 0.0f64);
        if wants_st {
            let sts = mesh.and_then(|m| m.st.as_deref().map(|sts| (sts, m.triangles[tri.index as usize])));
            (st, st_per_length) = triangle_st(sts, bw, triangle_normal(tp));
        }
        let ng_unit = surface.ng_unit;
        let ns = ns_blas.map(|n| n.normalize_or_zero().as_vec3());
        let dpdu = (tp[1] - tp[0]).as_dvec3().as_vec3();
        let reverse = sides & super::REVERSED != 0;
        let normals = if sides & super::DEGENERATE != 0 {
            let shape = Oriented { ng_unit, ns: ns.unwrap_or(ng_unit), n_outward: ng_unit, reverse };
            shape.orient(ray)
        } else {
            Oriented::orient_proper(ng_unit, ns, reverse)
        };
        self.surface(
            ray,
            t,
            normals,
            (dpdu, st, st_per_length),
            (p64, p, p_error),
            wants_st,
            surface.attributes,
            Some(&surface.emitter),
        )
    }

    /// [`World::interaction`] in any world.
    #[inline(never)]
    fn interaction_general(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let inst = &self.instances[hit.instance as usize];
        let blas = &self.blases[inst.blas as usize];
        let shape = match hit.detail {
            HitDetail::Triangle(i, _) => blas.triangles[i as usize].shape,
            HitDetail::Quadric(i, _) => blas.quadrics[i as usize].shape,
        };
        let attributes = inst.attributes.unwrap_or(blas.shapes[shape as usize].attributes);
        let wants_st = self.material(attributes).reads_texture_coordinates();
        let (p_blas, err_blas, ng_blas, dpdu_blas);
        // `None` when the normal is the geometric one (computed and normalised once).
        let (ns_blas, n_outward_blas): (Option<DVec3>, Option<DVec3>);
        let mut st = Vec2::ZERO;
        // Texture-space units per BLAS-space unit around the hit (isotropic).
        let mut st_per_length = 0.0f64;
        match hit.detail {
            HitDetail::Triangle(i, b) => {
                let tri = &blas.triangles[i as usize];
                // A deforming triangle where the ray met it.
                let deformed = blas.deforming.as_ref().and_then(|d| d.triangle(tri.index, ray.time));
                let tp = deformed.unwrap_or(tri.p);
                let (p, err) = barycentric_point(b, tp[0], tp[1], tp[2]);
                p_blas = p;
                err_blas = err;
                ng_blas = triangle_normal(tp);
                let s = &blas.shapes[tri.shape as usize];
                let mesh = s.mesh.map(|m| &blas.meshes[m as usize]);
                let vidx = mesh.map(|m| m.triangles[tri.index as usize]);
                let bw = [b[0] as f32, b[1] as f32, b[2] as f32];
                ns_blas = match (mesh.and_then(|m| m.normals.as_ref()), vidx) {
                    (Some(_), Some(_)) if deformed.is_some() => blas
                        .deforming
                        .as_ref()
                        .and_then(|d| d.normal(tri.index, bw, ray.time))
                        .map(|n| n.as_dvec3()),
                    (Some(normals), Some(v)) => vertex_normal(normals, v, bw),
                    _ => None,
                };
                n_outward_blas = None;
                if wants_st {
                    let sts = mesh.and_then(|m| m.st.as_deref()).zip(vidx);
                    (st, st_per_length) = triangle_st(sts, bw, ng_blas);
                }
                dpdu_blas = (tp[1] - tp[0]).as_dvec3();
            }
            HitDetail::Quadric(i, h) => {
                // A deforming quadric as the ray met it.
                let deformed = blas.deforming.as_ref().and_then(|d| d.quadric(i, ray.time));
                let q = deformed.as_ref().unwrap_or(&blas.quadrics[i as usize]);
                let m = &q.blas_from_object;
                p_blas = m.transform_point3(h.p);
                // The f64 solve and projection leave errors far below f32 rounding; bound them
                // generously with a relative 1e-9 of the quadric's extent.
                let extent = (q.quadric.bounds_max - q.quadric.bounds_min).length();
                let scale = m
                    .x_axis
                    .truncate()
                    .length()
                    .max(m.y_axis.truncate().length())
                    .max(m.z_axis.truncate().length());
                err_blas = transform_point_error(m, h.p) + DVec3::splat(1e-9 * extent * scale);
                let normal_matrix = &q.object_from_blas;
                ng_blas = transform_normal(normal_matrix, h.n);
                ns_blas = None;
                n_outward_blas = Some(transform_normal(normal_matrix, h.n * q.quadric.orientation));
                dpdu_blas = m.transform_vector3(h.dpdu);
                if wants_st {
                    st = h.uv.as_vec2();
                    st_per_length = 1.0 / dpdu_blas.length();
                }
            }
        }
        // BLAS space to render space (where a moving instance is at the ray's time).
        let placement = (!inst.identity).then(|| Self::placement(inst, ray.time));
        let (p64, err64) = match &placement {
            None => (p_blas, err_blas),
            Some((m, _)) => {
                let p = m.transform_point3(p_blas);
                let abs = DMat4::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs(), glam::DVec4::ZERO);
                let err = abs.transform_vector3(err_blas) + transform_point_error(m, p_blas);
                (p, err)
            }
        };
        let map_n = |n: DVec3| match &placement {
            Some((_, inv)) => transform_normal(inv, n),
            None => n,
        };
        let ng_unit = map_n(ng_blas).normalize_or_zero().as_vec3();
        let ns = match ns_blas {
            Some(n) => map_n(n).normalize_or_zero().as_vec3(),
            None => ng_unit,
        };
        let mut n_outward = match n_outward_blas {
            Some(n) => map_n(n).normalize_or_zero().as_vec3(),
            None => ng_unit,
        };
        // On a solid's boundary the outward side is where the ray is not inside the solid.
        if let Some(entering) = hit.csg_entering
            && (n_outward.dot(ray.direction) < 0.0) != entering
        {
            n_outward = -n_outward;
        }
        let dpdu = match &placement {
            Some((m, _)) => m.transform_vector3(dpdu_blas).as_vec3(),
            None => dpdu_blas.as_vec3(),
        };
        let (_, reverse) = self.sidedness(inst, blas, shape);
        let oriented = Oriented { ng_unit, ns, n_outward, reverse };
        let (p, p_error) = round_point(p64, err64);
        self.surface(
            ray,
            hit.t,
            oriented.orient(ray),
            (dpdu, st, st_per_length),
            (p64, p, p_error),
            wants_st,
            attributes,
            inst.emitters.get(shape as usize),
        )
    }

    /// The end of [`World::interaction`] for both kinds of world, once the normals are
    /// oriented ([`Oriented`]) and the point rounded: the texture footprint and the record.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn surface(
        &self,
        ray: &Ray,
        t: f32,
        Normals { ng, ns, n_outward }: Normals,
        (dpdu, st, st_per_length): (Vec3, Vec2, f64),
        (p64, p, p_error): (DVec3, Vec3, Vec3),
        wants_st: bool,
        attributes: rib_parser::scene::AttributesId,
        emitter: Option<&u32>,
    ) -> SurfaceInteraction {
        let st_width = if wants_st {
            let pixel = self.footprint.width_at(p64.length());
            let st_width = (pixel * st_per_length) as f32;
            if st_width.is_finite() { st_width } else { 0.0 }
        } else {
            0.0
        };
        let emitter = emitter.copied().filter(|&e| e != u32::MAX);
        let wo = -ray.direction.normalize_or(Vec3::Z);
        SurfaceInteraction {
            p,
            p_error,
            p64,
            t,
            ng,
            ns,
            n_outward,
            dpdu,
            st,
            st_width,
            wo,
            front: ray.direction.dot(ng) < 0.0,
            attributes,
            emitter,
            time: ray.time,
        }
    }
}

/// A triangle's geometric normal (unnormalised: twice its area) from its vertices.
#[inline(always)]
fn triangle_normal(tp: [Vec3; 3]) -> DVec3 {
    (tp[1] - tp[0]).cross(tp[2] - tp[0]).as_dvec3()
}

/// A triangle's unit geometric normal as [`World::interaction`] computes it (zero for a
/// degenerate triangle): [`World::flat_surfaces`] holds it per triangle of a flat world.
pub(super) fn triangle_unit_normal(tp: [Vec3; 3]) -> Vec3 {
    triangle_normal(tp).normalize_or_zero().as_vec3()
}

/// A mesh triangle's shading normal at barycentric weights `bw` from its vertices' normals
/// (indices `v`), `None` where they cancel or are not finite (the geometric normal serves).
#[inline(always)]
fn vertex_normal(normals: &[Vec3], v: [u32; 3], bw: [f32; 3]) -> Option<DVec3> {
    let n = normals[v[0] as usize] * bw[0] + normals[v[1] as usize] * bw[1] + normals[v[2] as usize] * bw[2];
    (n.length_squared() > 0.0 && n.is_finite()).then(|| n.as_dvec3())
}

/// A triangle's texture coordinates at barycentric weights `bw` and texture-space units per
/// BLAS-space unit around them (isotropic): from its vertices' `st` (with their indices) where
/// the mesh has them, else the barycentrics themselves; `ng` is the unnormalised geometric
/// normal, twice the triangle's area.
#[inline(always)]
fn triangle_st(sts: Option<(&[Vec2], [u32; 3])>, bw: [f32; 3], ng: DVec3) -> (Vec2, f64) {
    let area = 0.5 * ng.length();
    match sts {
        Some((sts, v)) => {
            let [a, b, c] = [0, 1, 2].map(|k| sts[v[k] as usize]);
            let st_area = 0.5 * f64::from((b - a).perp_dot(c - a).abs());
            (a * bw[0] + b * bw[1] + c * bw[2], (st_area / area).sqrt())
        }
        None => (Vec2::new(bw[1], bw[2]), (0.5 / area).sqrt()),
    }
}

/// A hit's normals before [`Oriented::orient`]: the unit geometric normal as the shape has it,
/// the unit shading and outward normals, and whether the shape's orientation is reversed.
struct Oriented {
    ng_unit: Vec3,
    ns: Vec3,
    n_outward: Vec3,
    reverse: bool,
}

/// A hit's normals as the record holds them: the geometric normal on the front side, the
/// shading normal in its hemisphere and the outward normal.
struct Normals {
    ng: Vec3,
    ns: Vec3,
    n_outward: Vec3,
}

impl Oriented {
    /// The orientation rules: the shape's reversal, the shading normal into the geometric
    /// normal's hemisphere, and stand-ins where a normal is zero or not finite (the geometric
    /// normal: against the ray; the shading and outward normals: the geometric normal).
    #[inline(always)]
    fn orient(self, ray: &Ray) -> Normals {
        let Oriented { ng_unit: mut ng, mut ns, n_outward, reverse } = self;
        if reverse {
            ng = -ng;
            ns = -ns;
        }
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        if ng == Vec3::ZERO || !ng.is_finite() {
            ng = -ray.direction.normalize_or(Vec3::Z);
        }
        if ns == Vec3::ZERO || !ns.is_finite() {
            ns = ng;
        }
        Normals { ng, ns, n_outward: if n_outward == Vec3::ZERO { ng } else { n_outward } }
    }

    /// [`Oriented::orient`] of a flat world's triangle whose unit geometric normal `ng_unit`
    /// (its outward normal too) is neither zero nor infinite nor NaN, as
    /// [`World::flat_sides`]' [`DEGENERATE`](super::DEGENERATE) bit tells: that normal's
    /// stand-ins are then never taken, and without the mesh's shading normal `ns` (the
    /// geometric one serves), the shading normal is the geometric one, whose dot product with
    /// itself is not negative. The same bits as `orient` without those tests.
    #[inline(always)]
    fn orient_proper(ng_unit: Vec3, ns: Option<Vec3>, reverse: bool) -> Normals {
        let ng = if reverse { -ng_unit } else { ng_unit };
        let ns = match ns {
            None => ng,
            Some(mut ns) => {
                if reverse {
                    ns = -ns;
                }
                if ns.dot(ng) < 0.0 {
                    ns = -ns;
                }
                if ns == Vec3::ZERO || !ns.is_finite() { ng } else { ns }
            }
        };
        Normals { ng, ns, n_outward: ng_unit }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`Oriented::orient_proper`] is [`Oriented::orient`] bit for bit wherever the flat
    /// world's [`DEGENERATE`](super::super::DEGENERATE) bit is clear (the geometric normal
    /// neither zero nor infinite nor NaN): unit normals and others of every scale and sign, zero
    /// components of both signs, subnormals, `f32::MAX`, and shading normals that are absent,
    /// zero, opposite, infinite or NaN, with and without the reversal.
    #[test]
    fn orientation_without_stand_ins_matches_the_rules() {
        let special =
            [0.0, -0.0, 1e-40, -1e-40, 1.0, -1.0, f32::MAX, -f32::MAX, f32::INFINITY, f32::NAN, -f32::NAN];
        let mut rng = crate::sampling::Rng::new(5, 11);
        let mut value = |k: usize| {
            if k.is_multiple_of(3) {
                special[(k / 3) % special.len()]
            } else {
                (rng.uniform() - 0.5) * 10f32.powi((rng.uniform() * 60.0) as i32 - 30)
            }
        };
        let bits = |n: Normals| [n.ng, n.ns, n.n_outward].map(|v| v.to_array().map(f32::to_bits));
        let ray = Ray::new(Vec3::ZERO, Vec3::new(0.3, -0.4, 0.5));
        let (mut proper, mut shading) = (0, 0);
        for k in 0..60_000 {
            let mut ng_unit = Vec3::new(value(k), value(k + 1), value(k + 2));
            if k.is_multiple_of(2) {
                ng_unit = ng_unit.normalize_or_zero();
            }
            if ng_unit == Vec3::ZERO || !ng_unit.is_finite() {
                continue;
            }
            proper += 1;
            let ns = match k % 5 {
                0 => None,
                1 => Some(-ng_unit),
                _ => Some(Vec3::new(value(k + 4), value(k + 5), value(k + 7))),
            };
            shading += usize::from(ns.is_some());
            for reverse in [false, true] {
                let rules =
                    Oriented { ng_unit, ns: ns.unwrap_or(ng_unit), n_outward: ng_unit, reverse }.orient(&ray);
                assert_eq!(
                    bits(Oriented::orient_proper(ng_unit, ns, reverse)),
                    bits(rules),
                    "{ng_unit:?} {ns:?}"
                );
            }
        }
        assert!(proper > 20_000 && shading > 10_000, "{proper} {shading}");
    }

    /// A flat world's surface interaction ([`World::interaction_flat`], with the tables
    /// [`World::flat_sides`] and [`World::flat_surfaces`]) is the general one bit for bit, with
    /// and without x86-64-v3 ([`World::write_interaction`]): on every triangle of polygons
    /// plain, with vertex normals (one set of which cancels along an edge), with `st` under a
    /// textured material and without, emitting, one-sided and reversed, and degenerate
    /// (collinear, tiny, huge: a zero unit normal), at barycentrics inside, on the edges and at
    /// the corners, from rays of every direction.
    #[test]
    fn flat_interaction_matches_the_general_one() {
        use crate::diagnostics::Diagnostics;
        use crate::world::{DEGENERATE, PixelFootprint, SHADING_NORMALS, TEXTURE_COORDINATES};
        let dir = tempfile::tempdir().unwrap();
        let texture = dir.path().join("checker.png");
        image::RgbImage::from_fn(4, 4, |x, y| image::Rgb(if (x + y) % 2 == 0 { [200; 3] } else { [50; 3] }))
            .save(&texture)
            .unwrap();
        let painted = format!("Surface \"paintedplastic\" \"texturename\" [\"{}\"]\n", texture.display());
        let mut rib = String::from("WorldBegin\n");
        for i in 0..36 {
            let (x, z) = ((i % 6) as f32 - 3.0, (i / 6) as f32 - 3.0);
            let p = format!("\"P\" [{x} -1 {z} {} -0.5 {z} {x} 1 {}]", x + 1.5, z + 0.7);
            let (attributes, extra) = match i % 6 {
                0 => ("", ""),
                1 => ("", " \"N\" [0 0 1 0.3 0.2 0.9 -0.1 0.5 0.8]"),
                2 => ("", " \"N\" [0 0 1 0 0 -1 0 0 1]"),
                3 => (painted.as_str(), " \"st\" [0 0 1 0 0.5 1]"),
                4 if i < 18 => (painted.as_str(), ""),
                4 => ("AreaLightSource \"arealight\" 1 \"intensity\" [1]\n", ""),
                _ => ("Sides 1\nReverseOrientation\n", ""),
            };
            rib += &format!("AttributeBegin\n{attributes}Polygon {p}{extra}\nAttributeEnd\n");
        }
        rib += "WorldEnd\n";
        let scene = rib_parser::load_bytes("flat.rib", rib.into_bytes(), &Default::default())
            .unwrap_or_else(|e| panic!("{}", e.render()))
            .scene;
        let eye = glam::DVec3::new(0.3, 0.2, -7.0);
        let mut world = World::build(&scene, eye, PixelFootprint::Unknown, &mut Diagnostics::default())
            .expect("the world builds");
        assert!(world.flat, "a world of polygons alone is flat");
        // Degenerate triangles (the build drops them from the scene): three points on a line,
        // and normals whose `f32` cross product underflows to zero or overflows.
        let blas = world.instances[0].blas as usize;
        for (k, p) in [[0.0, 1.0, 2.0], [0.0, 1e-23, 1e-23], [0.0, 1e20, 1e20]].into_iter().enumerate() {
            let t = &mut world.blases[blas].triangles[5 * k];
            t.p = [Vec3::new(p[0], 0.0, 5.0), Vec3::new(p[1], 0.0, 5.0), Vec3::new(0.0, p[2], 5.0)];
            if k == 0 {
                t.p[2] = Vec3::new(p[2], 0.0, 5.0);
            }
        }
        world.set_flat_tables();
        let count = |bit: u8| world.flat_sides.iter().filter(|&&s| s & bit != 0).count();
        let flags = [DEGENERATE, SHADING_NORMALS, TEXTURE_COORDINATES].map(count);
        assert!(flags.iter().all(|&n| n > 0), "degenerate, with normals, with st: {flags:?}");
        let emitting = world.flat_surfaces.iter().filter(|s| s.emitter != u32::MAX).count();
        assert!(emitting > 0, "no emitting triangle");
        let v3 = crate::accel::X86_64V3::detect();
        let triangles = world.flat_sides.len();
        let mut rng = crate::sampling::Rng::new(7, 3);
        for k in 0..20_000 {
            let (b1, b2) = (f64::from(rng.uniform()), f64::from(rng.uniform()));
            let b = match k % 4 {
                0 if b1 + b2 <= 1.0 => [1.0 - b1 - b2, b1, b2],
                0 | 1 => [0.0, b1, 1.0 - b1],
                2 => [0.0, 0.0, 1.0],
                _ => [1.0 - b1, b1 * 0.5, b1 * 0.5],
            };
            let origin = (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5) * 12.0;
            let direction =
                crate::sampling::sample_uniform_sphere(rng.uniform2()) * (0.01 + 3.0 * rng.uniform());
            let ray = Ray { time: rng.uniform(), ..Ray::new(origin, direction) };
            let detail = HitDetail::Triangle((k % triangles) as u32, b);
            let hit = Hit { t: 5.0 * rng.uniform(), instance: 0, detail, csg_entering: None };
            let mut records = Vec::new();
            for (flat, v3) in [(true, v3), (false, v3), (true, None), (false, None)] {
                world.flat = flat;
                let mut out = world.interaction(&ray, &hit);
                records.push(format!("{out:?}"));
                world.write_interaction(v3, &ray, &hit, &mut out);
                records.push(format!("{out:?}"));
            }
            assert!(records.iter().all(|r| *r == records[0]), "hit {k}: {records:#?}");
        }
    }
}

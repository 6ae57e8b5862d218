//! Shadow queries: the fraction of light passing along a segment, stopping at the first surface
//! that blocks it (any-hit traversal).

use super::{Blas, HitDetail, Instance, Prim, QuadricPrim, Ray, RayQuery, World, clipping, csg};
use super::{vertex_shear, vertex_test};
use crate::accel::{Baseline, NodeLanes, TraversalRay, X86_64V3};
use crate::shapes::{RayShear, TriangleHit};
#[cfg(target_arch = "x86_64")]
use crate::shapes::{RowShear, triangle_rows::intersect_rows_avx2};
use glam::Vec3;
use rib_parser::scene::AttributesId;

impl World {
    /// Fraction of light passing along the segment `ray` (origin + t direction, `t` in
    /// `(t_min, t_max)`): zero when something opaque, a mirror or glass is in the way, the
    /// product of `1 - Os` of the semi-transparent surfaces crossed otherwise.
    #[inline]
    pub fn transmittance(&self, ray: &Ray) -> Vec3 {
        if self.flat {
            return self.transmittance_flat(ray);
        }
        self.transmittance_general(ray)
    }

    /// [`World::transmittance`] in a world that is not flat, out of line as
    /// [`World::intersect`]'s general query.
    #[inline(never)]
    fn transmittance_general(&self, ray: &Ray) -> Vec3 {
        let mut tr = Vec3::ONE;
        let clipped;
        let ray = if self.clipping_planes.is_empty() {
            ray
        } else {
            let Some(r) = clipping::clip_ray(&self.clipping_planes, ray) else { return tr };
            clipped = r;
            &clipped
        };
        let render = TraversalRay::new(ray.origin, ray.direction, ray.t_min, ray.t_max);
        let mut render_shear = None;
        let mut query = RayQuery { ray, render: render.as_ref(), render_shear: &mut render_shear };
        match &self.tlas {
            None => {
                if let Some(inst) = self.instances.first() {
                    self.transmittance_instance(inst, &mut query, &mut tr);
                }
            }
            Some(tlas) => {
                let Some(tray) = render else {
                    return tr;
                };
                tlas.any(&tray, |_, slot| {
                    self.transmittance_instance(&self.instances[slot as usize], &mut query, &mut tr);
                    tr == Vec3::ZERO
                });
            }
        }
        tr
    }

    /// Attenuation by one surface crossing: `None` means fully blocked.
    pub(super) fn attenuation(&self, attributes: AttributesId) -> Option<Vec3> {
        let m = self.material(attributes);
        if m.blocks_shadows() || m.opacity == Vec3::ONE { None } else { Some(Vec3::ONE - m.opacity) }
    }

    fn transmittance_instance(&self, inst: &Instance, query: &mut RayQuery, tr: &mut Vec3) {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.x86_64_v3 {
            // SAFETY: the token exists only on a CPU with these features.
            return unsafe { self.transmittance_instance_v3(v3, inst, query, tr) };
        }
        self.transmittance_instance_inlined(Baseline, (vertex_shear, vertex_test), inst, query, tr)
    }

    /// [`World::transmittance_instance`] compiled for x86-64-v3, with the triangle test on the
    /// rows stored for it, as [`World::intersect_instance`]'s copy.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
    fn transmittance_instance_v3(&self, v3: X86_64V3, inst: &Instance, query: &mut RayQuery, tr: &mut Vec3) {
        let triangle = (
            RowShear::new,
            #[inline(always)]
            // SAFETY: the token `v3` exists only on a CPU with AVX2.
            |shear: &RowShear, blas: &Blas, i: u32, t_max: f32| unsafe {
                intersect_rows_avx2(shear, &blas.rows[i as usize], t_max)
            },
        );
        self.transmittance_instance_inlined(v3, triangle, inst, query, tr)
    }

    /// The shadow query of one instance, `triangle` as in [`World::intersect_instance_inlined`].
    #[inline(always)]
    fn transmittance_instance_inlined<S>(
        &self,
        lanes: impl NodeLanes,
        (prepare, test): (impl Fn(&RayShear) -> S, impl Fn(&S, &Blas, u32, f32) -> Option<TriangleHit>),
        inst: &Instance,
        query: &mut RayQuery,
        tr: &mut Vec3,
    ) {
        let blas = &self.blases[inst.blas as usize];
        let ray = query.ray;
        if let Some(csg) = &blas.csg {
            let (o, d) = Self::to_blas(inst, ray.origin, ray.direction, ray.time);
            // The first boundary crossing of the solid decides (a semi-transparent solid
            // attenuates once).
            if let Some((_, detail, _)) = csg::intersect(blas, csg, o, d, ray.t_min, ray.t_max) {
                let shape = match detail {
                    HitDetail::Triangle(i, _) => blas.triangles[i as usize].shape,
                    HitDetail::Quadric(i, _) => blas.quadrics[i as usize].shape,
                };
                let attributes = inst.attributes.unwrap_or(blas.shapes[shape as usize].attributes);
                match self.attenuation(attributes) {
                    None => *tr = Vec3::ZERO,
                    Some(a) => *tr *= a,
                }
            }
            return;
        }
        if let Some(deforming) = &blas.deforming {
            return self.transmittance_deforming(inst, blas, deforming, query, tr);
        }
        let Some((tray, shear)) = Self::blas_ray(inst, query, ray.t_max) else { return };
        let shear = prepare(&shear);
        let (origin, direction) = (Vec3::from(tray.origin), Vec3::from(tray.direction));
        let (t_min, t_max) = (ray.t_min, ray.t_max);
        // Whether slot `slot` stops the segment's light (after attenuating `tr`); inlined into the
        // traversal loop, as in `intersect_instance`.
        // In a BLAS of triangles alone, slot `k` holds triangle `k` (`BlasBuilder::finish`).
        let triangles_only = blas.quadrics.is_empty();
        blas.bvh.any_with(
            lanes,
            &tray,
            #[inline(always)]
            |_, slot| match if triangles_only { Prim::Triangle(slot) } else { blas.prims[slot as usize] } {
                Prim::Triangle(i) => {
                    let Some(h) = test(&shear, blas, i, t_max) else {
                        return false;
                    };
                    if h.t <= t_min {
                        return false;
                    }
                    let tri = &blas.triangles[i as usize];
                    let (one_sided, reverse) = self.sidedness(inst, blas, tri.shape);
                    if one_sided && (tri.hits_front(direction) == reverse) {
                        return false;
                    }
                    let attributes = inst.attributes.unwrap_or(blas.shapes[tri.shape as usize].attributes);
                    match self.attenuation(attributes) {
                        None => {
                            *tr = Vec3::ZERO;
                            true
                        }
                        Some(a) => {
                            *tr *= a;
                            *tr == Vec3::ZERO
                        }
                    }
                }
                Prim::Quadric(i) => self.quadric_blocks(
                    inst,
                    blas,
                    &blas.quadrics[i as usize],
                    (origin, direction),
                    (t_min, t_max),
                    tr,
                ),
            },
        );
    }

    /// Crosses quadric `q` of `blas` (one of its quadrics, or a deforming one at the ray's time)
    /// along the BLAS-space segment `(origin, direction)`,
    /// `(t_min, t_max)`, attenuating `tr` at each crossing on a side the instance sees; true
    /// when the segment is blocked. Out of line, as `World::quadric_hit`, so that the traversal
    /// loop inlines the triangle test.
    #[inline(never)]
    pub(super) fn quadric_blocks(
        &self,
        inst: &Instance,
        blas: &Blas,
        q: &QuadricPrim,
        (origin, direction): (Vec3, Vec3),
        (t_min, t_max): (f32, f32),
        tr: &mut Vec3,
    ) -> bool {
        let oo = q.object_from_blas.transform_point3(origin.as_dvec3());
        let od = q.object_from_blas.transform_vector3(direction.as_dvec3());
        let (one_sided, reverse) = self.sidedness(inst, blas, q.shape);
        let attributes = inst.attributes.unwrap_or(blas.shapes[q.shape as usize].attributes);
        let attenuation = self.attenuation(attributes);
        let mut blocked = false;
        // Visit every crossing (a closed quadric is crossed twice).
        q.quadric.intersect(oo, od, f64::from(t_min), f64::from(t_max), |h| {
            let t32 = h.t as f32;
            if !(t32 > t_min && t32 < t_max) {
                return false;
            }
            if one_sided && ((h.n.dot(od) < 0.0) == reverse) {
                return false;
            }
            match attenuation {
                None => blocked = true,
                Some(a) => *tr *= a,
            }
            blocked
        });
        if blocked {
            *tr = Vec3::ZERO;
        }
        *tr == Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use crate::diagnostics::Diagnostics;
    use crate::sampling::{Rng, sample_uniform_sphere};
    use crate::world::{PixelFootprint, Ray, World};
    use glam::{DVec3, Vec3};

    /// The ray queries compiled for x86-64-v3 give the baseline copies' results bit for bit:
    /// closest hits (triangles of the world's BLAS, instanced triangles and quadrics, one-sided
    /// surfaces) and transmittance through semi-transparent and opaque surfaces, on random rays
    /// and segments.
    #[test]
    fn x86_64_v3_queries_match_the_baseline() {
        let Some(v3) = crate::accel::X86_64V3::detect() else {
            eprintln!("skipped: this CPU lacks x86-64-v3");
            return;
        };
        let mut rib = String::from("WorldBegin\nAttributeBegin\nOpacity [0.5 0.6 0.7]\n");
        for i in 0..60 {
            let (x, z) = ((i % 8) as f32 - 4.0, (i / 8) as f32 - 4.0);
            rib += &format!("Polygon \"P\" [{x} -1 {z} {} -0.5 {z} {x} 1 {}]\n", x + 1.5, z + 0.7);
            if i == 30 {
                rib += "AttributeEnd\nAttributeBegin\nSides 1\n";
            }
        }
        rib += "AttributeEnd\nObjectBegin 1\nSphere 0.7 -0.7 0.7 360\n\
                Polygon \"P\" [0 0 0 1 0 0 0 1 0]\nObjectEnd\n\
                ObjectBegin 2\nPolygon \"P\" [0 0 0 1 0 0 0 1 0]\nPolygon \"P\" [0 0 1 1 0 1 0 1 1]\nObjectEnd\n\
                TransformBegin\nTranslate 1 2 0\nObjectInstance 1\nTransformEnd\n\
                TransformBegin\nRotate 30 0 1 0\nObjectInstance 2\nTransformEnd\nWorldEnd\n";
        let scene = rib_parser::load_bytes("v3.rib", rib.into_bytes(), &Default::default())
            .unwrap_or_else(|e| panic!("{}", e.render()))
            .scene;
        let mut world = World::build(
            &scene,
            DVec3::new(0.3, 0.2, -7.0),
            PixelFootprint::Unknown,
            &mut Diagnostics::default(),
        )
        .expect("the world builds");
        assert!(world.tlas.is_some(), "the scene should have a top-level BVH");
        let mut rng = Rng::new(77, 1);
        let (mut hits, mut partial) = (0, 0);
        for k in 0..4000 {
            // Render space has its origin at the eye.
            let eye = Vec3::new(0.3, 0.2, -7.0);
            let origin = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 12.0 - 6.0 - eye;
            // Half the rays aimed at a point among the surfaces, the others anywhere.
            let target = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 8.0 - 4.0 - eye;
            let scale = 0.01 + 3.0 * rng.uniform();
            let mut direction = if k % 2 == 0 {
                (target - origin).normalize_or(Vec3::X) * scale
            } else {
                sample_uniform_sphere(rng.uniform2()) * scale
            };
            if k % 7 == 0 {
                direction[k % 3] = 0.0;
            }
            let ray = Ray::new(origin, direction);
            let segment = Ray { t_max: 0.2 + 4.0 * rng.uniform(), ..ray };
            let results = [Some(v3), None].map(|v3| {
                world.x86_64_v3 = v3;
                let hit = world.intersect(&ray).map(|h| format!("{h:?}"));
                (hit, world.transmittance(&segment).to_array().map(f32::to_bits))
            });
            assert_eq!(results[0], results[1], "ray {k}");
            hits += usize::from(results[0].0.is_some());
            let tr = results[0].1.map(f32::from_bits);
            partial += usize::from(tr != [0.0; 3] && tr != [1.0; 3]);
        }
        assert!(hits > 500 && partial > 50, "{hits} hits, {partial} partly shadowed segments");
    }
}

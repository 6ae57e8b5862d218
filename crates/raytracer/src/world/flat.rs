//! The ray queries of a flat world: one BLAS of triangles alone in render space (no object
//! instances, quadrics, solids, deformation or clipping planes), as most scenes without
//! `ObjectInstance` are.
//!
//! They do what [`World::intersect`] and [`World::transmittance`] do for such a world, the same
//! `f32` and `f64` operations in the same order, so the results are the same bit for bit. What
//! they leave out is the per-ray work of the general queries that a flat world does not need:
//! the cached shear shared between instances, the checks for solids, deformation and quadrics,
//! the record of the closest hit written through pointers (a hit is 120 bytes), and one call
//! level. On the Cornell box that work was about a tenth of a ray's instructions.

use super::{Blas, Hit, HitDetail, ONE_SIDED, REVERSED, Ray, World, vertex_test};
use crate::accel::{Baseline, NodeLanes, TraversalRay, X86_64V3};
use crate::shapes::{RayShear, TriangleHit};
#[cfg(target_arch = "x86_64")]
use crate::shapes::{RowShear, triangle_rows::intersect_rows_avx2};
use glam::Vec3;

impl World {
    /// Whether this world is flat (see the module's comment): its queries then take the paths
    /// below. Decided once, when the world is built.
    pub(super) fn is_flat(&self) -> bool {
        if self.tlas.is_some() || self.instances.len() != 1 || !self.clipping_planes.is_empty() {
            return false;
        }
        let inst = &self.instances[0];
        let blas = &self.blases[inst.blas as usize];
        inst.identity
            && inst.motion.is_none()
            && blas.csg.is_none()
            && blas.deforming.is_none()
            && blas.quadrics.is_empty()
    }

    /// [`World::intersect`] in a flat world.
    #[inline]
    pub(super) fn intersect_flat(&self, ray: &Ray) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.x86_64_v3 {
            // SAFETY: the token exists only on a CPU with these features.
            return unsafe { self.intersect_flat_v3(v3, ray) };
        }
        self.intersect_flat_baseline(ray)
    }

    /// [`World::intersect_flat`] on a CPU without x86-64-v3. Out of line, as the x86-64-v3
    /// copy is, so that the dispatch before them is a few instructions without a frame.
    #[inline(never)]
    fn intersect_flat_baseline(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_flat_inlined(Baseline, ray, (RayShear::for_traversal, vertex_test))
    }

    /// [`World::intersect_flat`] compiled for x86-64-v3, with the triangle test on the rows
    /// stored for it ([`TriangleRows`](crate::shapes::TriangleRows); the closure is defined here
    /// so that it has these target features).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
    fn intersect_flat_v3(&self, v3: X86_64V3, ray: &Ray) -> Option<Hit> {
        // The one BLAS's rows, held here rather than read through `blas` per triangle.
        let rows = &self.blases[self.instances[0].blas as usize].rows[..];
        let triangle = (
            #[inline(always)]
            // SAFETY: the token `v3` exists only on a CPU with AVX2 (and so AVX).
            |tray: &TraversalRay| unsafe { RowShear::for_traversal_avx(tray) },
            #[inline(always)]
            // SAFETY: the token `v3` exists only on a CPU with AVX2.
            |shear: &RowShear, _: &Blas, i: u32, t_max: f32| unsafe {
                intersect_rows_avx2(shear, &rows[i as usize], t_max)
            },
        );
        self.intersect_flat_inlined(v3, ray, triangle)
    }

    /// The closest-hit query of a flat world; `triangle` is how to test a triangle, as in
    /// [`World::intersect_instance_inlined`].
    #[inline(always)]
    fn intersect_flat_inlined<S>(
        &self,
        lanes: impl NodeLanes,
        ray: &Ray,
        (prepare, test): (impl Fn(&TraversalRay) -> S, impl Fn(&S, &Blas, u32, f32) -> Option<TriangleHit>),
    ) -> Option<Hit> {
        let inst = &self.instances[0];
        let blas = &self.blases[inst.blas as usize];
        let mut tray = TraversalRay::new(ray.origin, ray.direction, ray.t_min, ray.t_max)?;
        let shear = prepare(&tray);
        let (direction, t_min) = (ray.direction, ray.t_min);
        // The closest hit so far: its slot, which in a BLAS of triangles alone is its triangle
        // (`BlasBuilder::finish`), `t` and barycentrics; the hit record is made once, at the end.
        let mut best: Option<(u32, f32, [f64; 3])> = None;
        blas.bvh.closest_with(
            lanes,
            &mut tray,
            #[inline(always)]
            |r, slot| {
                let h = test(&shear, blas, slot, r.t_max)?;
                if h.t <= t_min {
                    return None;
                }
                let sides = self.flat_sides[slot as usize];
                if sides & ONE_SIDED != 0
                    && (blas.triangles[slot as usize].hits_front(direction) == (sides & REVERSED != 0))
                {
                    return None;
                }
                best = Some((slot, h.t, h.b));
                Some(h.t)
            },
        );
        let (i, t, b) = best?;
        Some(Hit { t, instance: 0, detail: HitDetail::Triangle(i, b), csg_entering: None })
    }

    /// [`World::transmittance`] in a flat world.
    #[inline]
    pub(super) fn transmittance_flat(&self, ray: &Ray) -> Vec3 {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.x86_64_v3 {
            // SAFETY: the token exists only on a CPU with these features.
            return unsafe { self.transmittance_flat_v3(v3, ray) };
        }
        self.transmittance_flat_baseline(ray)
    }

    /// [`World::transmittance_flat`] on a CPU without x86-64-v3. Out of line, as the x86-64-v3
    /// copy is, so that the dispatch before them is a few instructions without a frame.
    #[inline(never)]
    fn transmittance_flat_baseline(&self, ray: &Ray) -> Vec3 {
        self.transmittance_flat_inlined(Baseline, ray, (RayShear::for_traversal, vertex_test))
    }

    /// [`World::transmittance_flat`] compiled for x86-64-v3, with the row test as
    /// [`World::intersect_flat_v3`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
    fn transmittance_flat_v3(&self, v3: X86_64V3, ray: &Ray) -> Vec3 {
        // The one BLAS's rows, held here rather than read through `blas` per triangle.
        let rows = &self.blases[self.instances[0].blas as usize].rows[..];
        let triangle = (
            #[inline(always)]
            // SAFETY: the token `v3` exists only on a CPU with AVX2 (and so AVX).
            |tray: &TraversalRay| unsafe { RowShear::for_traversal_avx(tray) },
            #[inline(always)]
            // SAFETY: the token `v3` exists only on a CPU with AVX2.
            |shear: &RowShear, _: &Blas, i: u32, t_max: f32| unsafe {
                intersect_rows_avx2(shear, &rows[i as usize], t_max)
            },
        );
        self.transmittance_flat_inlined(v3, ray, triangle)
    }

    /// The shadow query of a flat world, the triangle test as in
    /// [`World::intersect_flat_inlined`].
    #[inline(always)]
    fn transmittance_flat_inlined<S>(
        &self,
        lanes: impl NodeLanes,
        ray: &Ray,
        (prepare, test): (impl Fn(&TraversalRay) -> S, impl Fn(&S, &Blas, u32, f32) -> Option<TriangleHit>),
    ) -> Vec3 {
        let mut tr = Vec3::ONE;
        let inst = &self.instances[0];
        let blas = &self.blases[inst.blas as usize];
        let Some(tray) = TraversalRay::new(ray.origin, ray.direction, ray.t_min, ray.t_max) else {
            return tr;
        };
        let shear = prepare(&tray);
        let (direction, t_min, t_max) = (ray.direction, ray.t_min, ray.t_max);
        blas.bvh.any_with(
            lanes,
            &tray,
            #[inline(always)]
            |_, slot| {
                let Some(h) = test(&shear, blas, slot, t_max) else {
                    return false;
                };
                if h.t <= t_min {
                    return false;
                }
                let tri = &blas.triangles[slot as usize];
                let sides = self.flat_sides[slot as usize];
                if sides & ONE_SIDED != 0 && (tri.hits_front(direction) == (sides & REVERSED != 0)) {
                    return false;
                }
                let attributes = inst.attributes.unwrap_or(blas.shapes[tri.shape as usize].attributes);
                match self.attenuation(attributes) {
                    None => {
                        tr = Vec3::ZERO;
                        true
                    }
                    Some(a) => {
                        tr *= a;
                        tr == Vec3::ZERO
                    }
                }
            },
        );
        tr
    }
}

#[cfg(test)]
mod tests {
    use crate::diagnostics::Diagnostics;
    use crate::sampling::{Rng, sample_uniform_sphere};
    use crate::world::{PixelFootprint, Ray, World};
    use glam::Vec3;

    /// A flat world's queries give the general queries' results bit for bit, with and without
    /// x86-64-v3: closest hits (their triangle, `t` and barycentrics) on two-sided, one-sided
    /// and reversed surfaces, and transmittance through semi-transparent and opaque ones.
    #[test]
    fn flat_queries_match_the_general_ones() {
        let mut rib = String::from("WorldBegin\nAttributeBegin\nOpacity [0.5 0.6 0.7]\n");
        for i in 0..80 {
            let (x, z) = ((i % 9) as f32 - 4.0, (i / 9) as f32 - 4.0);
            rib += &format!("Polygon \"P\" [{x} -1 {z} {} -0.5 {z} {x} 1 {}]\n", x + 1.5, z + 0.7);
            match i {
                25 => rib += "AttributeEnd\nAttributeBegin\nSides 1\n",
                45 => rib += "AttributeEnd\nAttributeBegin\nSides 1\nReverseOrientation\n",
                65 => rib += "AttributeEnd\nAttributeBegin\n",
                _ => {}
            }
        }
        rib += "AttributeEnd\nWorldEnd\n";
        let scene = rib_parser::load_bytes("flat.rib", rib.into_bytes(), &Default::default())
            .unwrap_or_else(|e| panic!("{}", e.render()))
            .scene;
        let eye = Vec3::new(0.3, 0.2, -7.0);
        let mut world =
            World::build(&scene, eye.as_dvec3(), PixelFootprint::Unknown, &mut Diagnostics::default())
                .expect("the world builds");
        assert!(world.flat, "a world of polygons alone is flat");
        let v3 = crate::accel::X86_64V3::detect();
        let mut rng = Rng::new(5, 12);
        let (mut hits, mut partial, mut blocked) = (0, 0, 0);
        for k in 0..4000 {
            // Render space has its origin at the eye.
            let origin = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 12.0 - 6.0 - eye;
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
            let ray = Ray { t_min: if k % 5 == 0 { 0.5 } else { 0.0 }, ..Ray::new(origin, direction) };
            let segment = Ray { t_max: 0.2 + 4.0 * rng.uniform(), ..ray };
            let mut results = Vec::new();
            for (flat, v3) in [(true, v3), (false, v3), (true, None), (false, None)] {
                world.flat = flat;
                world.x86_64_v3 = v3;
                let hit = world.intersect(&ray).map(|h| format!("{h:?}"));
                results.push((hit, world.transmittance(&segment).to_array().map(f32::to_bits)));
            }
            assert!(results.iter().all(|r| *r == results[0]), "ray {k}: {results:?}");
            hits += usize::from(results[0].0.is_some());
            let tr = results[0].1.map(f32::from_bits);
            partial += usize::from(tr != [0.0; 3] && tr != [1.0; 3]);
            blocked += usize::from(tr == [0.0; 3]);
        }
        assert!(
            hits > 500 && partial > 50 && blocked > 50,
            "{hits} hits, {partial} partial, {blocked} blocked"
        );
    }
}

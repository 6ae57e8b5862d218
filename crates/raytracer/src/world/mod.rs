//! The render-ready world: geometry in bottom-level BVHs, instances in a top-level BVH,
//! materials, lights and light-linking sets, all in render space.
//!
//! Render space has the world's axes and its origin at the eye (pbrt-v4's "camera-world"
//! space). Every transform is composed in `f64` and rounded to `f32` once, so a scene placed
//! 1e5 units from the world origin keeps full precision near the camera.
//!
//! Geometry without `ObjectInstance` goes into one bottom-level BVH (BLAS) whose space is render
//! space; each `ObjectBegin` definition gets its own BLAS in its object space, placed by
//! instances without copying its geometry. Triangles live in their BLAS space as `f32`; quadrics
//! keep their object space and are intersected in `f64`.

mod build;
mod clipping;
mod csg;
mod deformation;
mod displacement;
mod flat;
mod interaction;
mod lighting;
mod motion;
mod placement;
mod shadow;

pub use build::WorldError;
pub use displacement::MAX_DISPLACED_TRIANGLES;
pub use placement::{
    MAX_WORLD_TRIANGLES, PixelFootprint, TESSELLATION_COARSEST, TESSELLATION_DEFAULT, TESSELLATION_FINEST,
};

use crate::accel::{Baseline, Bvh, NodeLanes, TraversalRay, X86_64V3};
use crate::lights::{Light, LightSet};
use crate::materials::Material;
use crate::math::offset_ray_origin_v3;

use crate::shapes::{
    Quadric, QuadricHit, RayShear, TriangleHit, TriangleRows, hits_front, intersect_triangle,
};
#[cfg(target_arch = "x86_64")]
use crate::shapes::{RowShear, triangle_rows::intersect_rows_avx2};
use glam::{DMat4, DVec3, Vec2, Vec3};
use rib_parser::motion::TransformMotion;
use rib_parser::scene::AttributesId;
use std::sync::Arc;
use std::time::Duration;

/// A ray in render space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
    pub t_min: f32,
    pub t_max: f32,
    /// When the ray travels, as a fraction of the shutter interval (0 at shutter open, 1 at
    /// close): moving objects are placed at that time.
    pub time: f32,
}

impl Ray {
    /// A ray at shutter open.
    pub fn new(origin: Vec3, direction: Vec3) -> Ray {
        Ray { origin, direction, t_min: 0.0, t_max: f32::INFINITY, time: 0.0 }
    }
}

#[derive(Clone, Copy, Debug)]
struct TrianglePrim {
    p: [Vec3; 3],
    shape: u32,
    index: u32,
}

impl TrianglePrim {
    /// [`hits_front`] of this triangle, out of line, reading its vertices again. Inlined, it
    /// made the traversal loops keep the nine vertex coordinates of every triangle they test
    /// (spilled to the stack) for this test, which only hits on one-sided surfaces need.
    #[inline(never)]
    fn hits_front(&self, direction: Vec3) -> bool {
        hits_front(self.p[0], self.p[1], self.p[2], direction)
    }
}

/// The baseline's triangle test takes the ray's shear as it is ([`vertex_test`]).
#[inline(always)]
fn vertex_shear(shear: &RayShear) -> RayShear {
    *shear
}

/// The baseline's triangle test of triangle `i` of `blas`, on its vertices; the x86-64-v3 query
/// copies test its rows instead ([`intersect_rows_avx2`], the same result bit for bit).
#[inline(always)]
fn vertex_test(shear: &RayShear, blas: &Blas, i: u32, t_max: f32) -> Option<TriangleHit> {
    let tri = &blas.triangles[i as usize];
    intersect_triangle(shear, tri.p[0], tri.p[1], tri.p[2], t_max)
}

#[derive(Clone, Debug)]
struct QuadricPrim {
    quadric: Quadric,
    object_from_blas: DMat4,
    blas_from_object: DMat4,
    shape: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Prim {
    Triangle(u32),
    Quadric(u32),
}

#[derive(Clone, Debug)]
struct BlasShape {
    attributes: AttributesId,
    one_sided: bool,
    reverse: bool,
    mesh: Option<u32>,
}

/// Shading data of a mesh (positions live in the triangles).
#[derive(Clone, Debug)]
struct MeshShading {
    triangles: Vec<[u32; 3]>,
    normals: Option<Vec<Vec3>>,
    st: Option<Vec<Vec2>>,
}

/// A bottom-level acceleration structure and its primitives, in BVH order.
#[derive(Debug)]
struct Blas {
    bvh: Bvh,
    prims: Vec<Prim>,
    triangles: Vec<TrianglePrim>,
    /// `triangles` stored for the x86-64-v3 triangle test ([`TriangleRows`]), made when the
    /// world is built on a CPU with x86-64-v3 (empty otherwise, and for deforming shapes, whose
    /// vertices move).
    rows: Vec<TriangleRows>,
    quadrics: Vec<QuadricPrim>,
    shapes: Vec<BlasShape>,
    meshes: Vec<MeshShading>,
    bounds: (Vec3, Vec3),
    /// The solid tree when this BLAS holds one outermost `SolidBegin` block.
    csg: Option<csg::Csg>,
    /// The keys of its one shape when it deforms over the shutter (`deformation.rs`).
    deforming: Option<Box<deformation::Deforming>>,
}

#[derive(Clone, Debug)]
struct Instance {
    blas: u32,
    identity: bool,
    /// At shutter open when the instance moves.
    render_from_blas: DMat4,
    blas_from_render: DMat4,
    /// `render_from_blas` at key times given as shutter fractions ([`Ray::time`]).
    motion: Option<Arc<TransformMotion>>,
    /// Attribute state of an `ObjectInstance` (replaces the definition's).
    attributes: Option<AttributesId>,
    one_sided: Option<bool>,
    reverse_xor: bool,
    /// Light index of each BLAS shape that emits (`u32::MAX` for none); empty when none does.
    emitters: Vec<u32>,
}

/// A render-space ray query, prepared once: its traversal ray (`None` when the ray has no
/// usable direction) and, made on first use, its shear; both serve every instance placed
/// without a transform.
struct RayQuery<'a> {
    ray: &'a Ray,
    render: Option<&'a TraversalRay>,
    render_shear: &'a mut Option<RayShear>,
}

/// Where a ray hit, before the surface is evaluated.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    instance: u32,
    detail: HitDetail,
    /// On a solid (CSG) boundary: whether the ray enters the solid there.
    csg_entering: Option<bool>,
}

#[derive(Clone, Copy, Debug)]
enum HitDetail {
    /// Triangle index in its BLAS and barycentric coordinates.
    Triangle(u32, [f64; 3]),
    /// Quadric index in its BLAS and the object-space hit.
    Quadric(u32, QuadricHit),
}

/// The local geometry of a hit, everything a material or light needs.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    /// Position (render space, `f32`) and a bound on its rounding error.
    pub p: Vec3,
    pub p_error: Vec3,
    /// Position in `f64` before rounding.
    pub p64: DVec3,
    pub t: f32,
    /// Unit geometric normal on the front side (after orientation rules).
    pub ng: Vec3,
    /// Unit shading normal, in the same hemisphere as `ng`.
    pub ns: Vec3,
    /// Normal pointing out of the solid (for dielectrics).
    pub n_outward: Vec3,
    pub dpdu: Vec3,
    /// Texture coordinates (zero where the material reads no texture: they are computed only
    /// for materials that do, see [`Material::reads_texture_coordinates`]).
    pub st: Vec2,
    /// About how far `st` changes across one pixel's footprint here (for filtered texture
    /// lookups; 0 when the camera is not known or the material reads no texture).
    pub st_width: f32,
    /// Direction toward the ray's origin.
    pub wo: Vec3,
    /// True when the ray arrived on the front side.
    pub front: bool,
    pub attributes: AttributesId,
    /// The area light this surface belongs to, if it emits.
    pub emitter: Option<u32>,
    /// The time of the ray that found the surface ([`Ray::time`]); rays leaving it keep it.
    pub time: f32,
}

impl SurfaceInteraction {
    /// A ray leaving the surface in direction `d`, from an origin pushed off the surface.
    pub fn spawn_ray(&self, d: Vec3) -> Ray {
        self.spawn_ray_inlined(None, d)
    }

    /// [`SurfaceInteraction::spawn_ray`], inlined where it is called: the wavefront's
    /// x86-64-v3 copy compiles it with its own features and passes its token `v3` for the
    /// origin's offset in lanes ([`offset_ray_origin_v3`]). (Inlined everywhere, it made the
    /// photon mapper's first-hit loop, which calls it only behind partly opaque surfaces, dearer.)
    #[inline(always)]
    pub(crate) fn spawn_ray_inlined(&self, v3: Option<X86_64V3>, d: Vec3) -> Ray {
        Ray { time: self.time, ..Ray::new(offset_ray_origin_v3(v3, self.p, self.p_error, self.ng, d), d) }
    }

    /// A shadow-ray segment from this surface to a point `p` (with error `p_error` and normal
    /// `n`, zero for points not on surfaces): origin, direction (unnormalised) and `t_max`.
    #[inline(always)]
    pub fn spawn_ray_to(&self, p: Vec3, p_error: Vec3, n: Vec3) -> Ray {
        self.spawn_ray_to_v3(None, p, p_error, n)
    }

    /// [`SurfaceInteraction::spawn_ray_to`], its ends offset in lanes where the wavefront's
    /// x86-64-v3 batch passes its token `v3` ([`offset_ray_origin_v3`]).
    #[inline(always)]
    pub(crate) fn spawn_ray_to_v3(&self, v3: Option<X86_64V3>, p: Vec3, p_error: Vec3, n: Vec3) -> Ray {
        let from = offset_ray_origin_v3(v3, self.p, self.p_error, self.ng, p - self.p);
        let to = if n == Vec3::ZERO { p } else { offset_ray_origin_v3(v3, p, p_error, n, from - p) };
        // Stop just short of the end: a relative epsilon (scale-free).
        Ray { origin: from, direction: to - from, t_min: 0.0, t_max: 1.0 - 1e-4, time: self.time }
    }
}

/// Counts and timings of the world build.
#[derive(Clone, Debug, Default)]
pub struct WorldStats {
    pub triangles: usize,
    pub quadrics: usize,
    pub blases: usize,
    pub instances: usize,
    pub bvh_nodes: usize,
    pub bvh_bytes: usize,
    pub bvh_build_time: Duration,
    pub build_time: Duration,
    pub lights: usize,
    pub area_lights: usize,
    pub top_level: bool,
}

/// The render-ready scene.
#[derive(Debug)]
pub struct World {
    pub render_from_world: DMat4,
    blases: Vec<Blas>,
    /// Instances in top-level BVH order.
    instances: Vec<Instance>,
    tlas: Option<Bvh>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    /// The indices in `lights` of the environment lights, which rays leaving the scene see.
    pub environment_lights: Vec<u32>,
    /// For each of `lights`, the index of the scene light it comes from (`Scene::lights`).
    pub light_sources: Vec<u32>,
    pub light_sets: Vec<LightSet>,
    attributes_light_set: Vec<u32>,
    /// Render-space bounds of all geometry.
    pub bounds: (Vec3, Vec3),
    pub stats: WorldStats,
    /// Whether something moves while the shutter is open (camera rays then need a time sample).
    pub motion_blur: bool,
    /// A moving camera: at each shutter fraction, the map that carries a camera ray at shutter
    /// open to the same ray at that time (render space); `None` when the camera stays.
    pub camera_motion: Option<Arc<TransformMotion>>,
    /// `ClippingPlane`s in render space: every ray query first narrows its range to the kept
    /// side ([`clipping::clip_ray`]).
    clipping_planes: Vec<clipping::RenderClippingPlane>,
    /// `Imager "background"`: composited under each camera sample by its alpha, as RenderMan's
    /// `Ci += (1 - alpha) * background` (reflections and lighting do not see it).
    pub background: Vec3,
    /// The camera's pixel footprint, for texture filter widths (pbrt-v4's approximation: the
    /// footprint of a camera ray at the hit's distance from the eye, on every path vertex).
    footprint: PixelFootprint,
    /// Present when this CPU has x86-64-v3's instruction set: the ray queries then run their
    /// copies compiled for it, with eight-lane node tests. The results do not change (the same
    /// IEEE operations in the same order; Rust never fuses a multiply and an add by itself).
    /// The wavefront's batch takes it too; tests set it to `None` to run the baseline copies.
    pub(crate) x86_64_v3: Option<X86_64V3>,
    /// One BLAS of triangles alone in render space ([`World::is_flat`]): the ray queries then
    /// take the paths of `flat.rs`, which skip the general queries' per-ray work.
    flat: bool,
    /// The flat BLAS's triangles' sidedness in slot order, [`World::sidedness`] of each as
    /// [`ONE_SIDED`] and [`REVERSED`] bits, [`DEGENERATE`] where its unit normal is no proper
    /// normal, and the [`SHADING_NORMALS`] and [`TEXTURE_COORDINATES`] its surface interaction
    /// needs; read on every hit (empty when the world is not flat).
    flat_sides: Vec<u8>,
    /// What the surface interaction reads of the flat BLAS's triangles besides their
    /// vertices, in slot order (one bounds check for the three); empty when the world is not
    /// flat.
    flat_surfaces: Vec<FlatSurface>,
}

/// [`World::flat_surfaces`]: a flat world's triangle as its surface interaction reads it.
#[derive(Clone, Copy, Debug)]
struct FlatSurface {
    /// The unit geometric normal, as the surface interaction computes it from the vertices (an
    /// `f64` cross product and normalisation per hit before).
    ng_unit: Vec3,
    /// The triangle's shape's attributes, or the instance's where it overrides them.
    attributes: AttributesId,
    /// The instance's emitter entry for the triangle's shape: the area light's index, or
    /// `u32::MAX` for none (also where the instance has no entry).
    emitter: u32,
}

/// [`World::flat_sides`]: the triangle's surface is one-sided.
const ONE_SIDED: u8 = 1;
/// [`World::flat_sides`]: the triangle's orientation is reversed.
const REVERSED: u8 = 2;
/// [`World::flat_sides`]: the triangle's unit geometric normal ([`FlatSurface::ng_unit`]) is
/// zero, infinite or NaN (a degenerate triangle's is zero), so the surface interaction's
/// orientation rules may stand in for it.
const DEGENERATE: u8 = 4;
/// [`World::flat_sides`]: the triangle's mesh has vertex normals (a shading normal to
/// interpolate); without the bit its mesh is not read.
const SHADING_NORMALS: u8 = 8;
/// [`World::flat_sides`]: the triangle's material reads texture coordinates
/// ([`Material::reads_texture_coordinates`]).
const TEXTURE_COORDINATES: u8 = 16;

impl World {
    /// A camera sample over the background colour (alpha, the coverage, is kept).
    pub fn over_background(&self, r: crate::integrators::Radiance) -> crate::integrators::Radiance {
        if self.background == Vec3::ZERO {
            return r;
        }
        crate::integrators::Radiance { rgb: r.rgb + (1.0 - r.alpha) * self.background, alpha: r.alpha }
    }

    /// The render-space bounding sphere of the geometry (centre, radius).
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let (lo, hi) = self.bounds;
        if !(lo.is_finite() && hi.is_finite()) {
            return (Vec3::ZERO, 1.0);
        }
        ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(f32::MIN_POSITIVE))
    }

    /// True when the ray queries take the flat world's paths (`flat.rs`: one BLAS of triangles
    /// in render space), decided when the world was built.
    pub fn flat_queries(&self) -> bool {
        self.flat
    }

    /// The light set of an attribute state.
    pub fn light_set(&self, attributes: AttributesId) -> &LightSet {
        &self.light_sets[self.attributes_light_set[attributes.0 as usize] as usize]
    }

    pub fn material(&self, attributes: AttributesId) -> &Material {
        &self.materials[attributes.0 as usize]
    }

    /// Render-space bounding boxes of the shapes whose material passes `select`, one per placed
    /// shape (the photon mapper aims caustic photons at the specular ones).
    pub fn shape_bounds(&self, mut select: impl FnMut(&Material) -> bool) -> Vec<(Vec3, Vec3)> {
        let mut out = Vec::new();
        for inst in &self.instances {
            let blas = &self.blases[inst.blas as usize];
            let wanted: Vec<bool> = blas
                .shapes
                .iter()
                .map(|s| select(self.material(inst.attributes.unwrap_or(s.attributes))))
                .collect();
            if !wanted.contains(&true) {
                continue;
            }
            if blas.deforming.is_some() {
                out.push(deformation::instance_box(inst, blas));
                continue;
            }
            let mut boxes: Vec<Option<(Vec3, Vec3)>> = vec![None; blas.shapes.len()];
            let mut grow = |shape: u32, lo: Vec3, hi: Vec3| {
                let b = &mut boxes[shape as usize];
                *b = Some(match *b {
                    Some((a, c)) => (a.min(lo), c.max(hi)),
                    None => (lo, hi),
                });
            };
            for t in &blas.triangles {
                if wanted[t.shape as usize] {
                    grow(t.shape, t.p[0].min(t.p[1]).min(t.p[2]), t.p[0].max(t.p[1]).max(t.p[2]));
                }
            }
            for q in &blas.quadrics {
                if wanted[q.shape as usize] {
                    let (lo, hi) = placement::transformed_box(
                        &q.blas_from_object,
                        q.quadric.bounds_min,
                        q.quadric.bounds_max,
                    );
                    grow(q.shape, lo, hi);
                }
            }
            for (lo, hi) in boxes.into_iter().flatten() {
                out.push(if inst.identity {
                    (lo, hi)
                } else {
                    placement::transformed_box(&inst.render_from_blas, lo.as_dvec3(), hi.as_dvec3())
                });
            }
        }
        out
    }

    fn sidedness(&self, inst: &Instance, blas: &Blas, shape: u32) -> (bool, bool) {
        let s = &blas.shapes[shape as usize];
        (inst.one_sided.unwrap_or(s.one_sided), s.reverse ^ inst.reverse_xor)
    }

    /// The closest hit along `ray` within `(t_min, t_max)`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.flat {
            return self.intersect_flat(ray);
        }
        self.intersect_general(ray)
    }

    /// [`World::intersect`] in a world that is not flat. Out of line so that a flat world's
    /// query does not pay this function's prologue (a 1.3 KB frame and six saved registers).
    #[inline(never)]
    fn intersect_general(&self, ray: &Ray) -> Option<Hit> {
        let clipped;
        let ray = if self.clipping_planes.is_empty() {
            ray
        } else {
            clipped = clipping::clip_ray(&self.clipping_planes, ray)?;
            &clipped
        };
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        // Prepared once and shared by every instance placed without a transform.
        let render = TraversalRay::new(ray.origin, ray.direction, ray.t_min, ray.t_max);
        let mut render_shear = None;
        match &self.tlas {
            None => {
                if let Some(inst) = self.instances.first() {
                    let mut query =
                        RayQuery { ray, render: render.as_ref(), render_shear: &mut render_shear };
                    self.intersect_instance(0, inst, &mut query, &mut t_max, &mut best);
                }
            }
            Some(tlas) => {
                let mut tray = render?;
                let mut query = RayQuery { ray, render: render.as_ref(), render_shear: &mut render_shear };
                tlas.closest(&mut tray, |r, slot| {
                    let inst = &self.instances[slot as usize];
                    let mut t = r.t_max;
                    self.intersect_instance(slot, inst, &mut query, &mut t, &mut best);
                    (t < r.t_max).then_some(t)
                });
            }
        }
        best
    }

    /// An instance's `(render_from_blas, blas_from_render)` at shutter fraction `time`.
    fn placement(inst: &Instance, time: f32) -> (DMat4, DMat4) {
        match &inst.motion {
            None => (inst.render_from_blas, inst.blas_from_render),
            Some(motion) => {
                let m = motion.at(f64::from(time));
                (m, m.inverse())
            }
        }
    }

    /// The ray in an instance's BLAS space (the parameter `t` is preserved).
    #[inline]
    fn to_blas(inst: &Instance, o: Vec3, d: Vec3, time: f32) -> (Vec3, Vec3) {
        if inst.identity {
            (o, d)
        } else {
            let moved;
            let m = match &inst.motion {
                None => &inst.blas_from_render,
                Some(_) => {
                    moved = Self::placement(inst, time).1;
                    &moved
                }
            };
            (m.transform_point3(o.as_dvec3()).as_vec3(), m.transform_vector3(d.as_dvec3()).as_vec3())
        }
    }

    /// The traversal ray and shear of `query` in an instance's BLAS space, for `(t_min,
    /// t_max)`: those of the render-space ray when the instance has no transform.
    #[inline(always)]
    fn blas_ray(inst: &Instance, query: &mut RayQuery, t_max: f32) -> Option<(TraversalRay, RayShear)> {
        let ray = query.ray;
        if inst.identity {
            let render = query.render?;
            let shear = *query.render_shear.get_or_insert_with(|| RayShear::for_traversal(render));
            let mut tray = *render;
            tray.t_max = t_max;
            return Some((tray, shear));
        }
        let (o, d) = Self::to_blas(inst, ray.origin, ray.direction, ray.time);
        let tray = TraversalRay::new(o, d, ray.t_min, t_max)?;
        Some((tray, RayShear::for_traversal(&tray)))
    }

    fn intersect_instance(
        &self,
        instance: u32,
        inst: &Instance,
        query: &mut RayQuery,
        t_max: &mut f32,
        best: &mut Option<Hit>,
    ) {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.x86_64_v3 {
            // SAFETY: the token exists only on a CPU with these features.
            return unsafe { self.intersect_instance_v3(v3, instance, inst, query, t_max, best) };
        }
        self.intersect_instance_inlined(
            Baseline,
            (vertex_shear, vertex_test),
            instance,
            inst,
            query,
            t_max,
            best,
        )
    }

    /// [`World::intersect_instance`] compiled for x86-64-v3, with the triangle test on the rows
    /// stored for it ([`TriangleRows`]; the closure is defined here so that it has these target
    /// features).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
    fn intersect_instance_v3(
        &self,
        v3: X86_64V3,
        instance: u32,
        inst: &Instance,
        query: &mut RayQuery,
        t_max: &mut f32,
        best: &mut Option<Hit>,
    ) {
        let triangle = (
            RowShear::new,
            #[inline(always)]
            // SAFETY: the token `v3` exists only on a CPU with AVX2.
            |shear: &RowShear, blas: &Blas, i: u32, t_max: f32| unsafe {
                intersect_rows_avx2(shear, &blas.rows[i as usize], t_max)
            },
        );
        self.intersect_instance_inlined(v3, triangle, instance, inst, query, t_max, best)
    }

    /// The closest-hit query of one instance; `triangle` is how to test triangle `i` of a BLAS:
    /// a shear prepared once per ray from the ray's [`RayShear`], and the test on it.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn intersect_instance_inlined<S>(
        &self,
        lanes: impl NodeLanes,
        (prepare, test): (impl Fn(&RayShear) -> S, impl Fn(&S, &Blas, u32, f32) -> Option<TriangleHit>),
        instance: u32,
        inst: &Instance,
        query: &mut RayQuery,
        t_max: &mut f32,
        best: &mut Option<Hit>,
    ) {
        let blas = &self.blases[inst.blas as usize];
        let ray = query.ray;
        let t_min = ray.t_min;
        if let Some(csg) = &blas.csg {
            let (o, d) = Self::to_blas(inst, ray.origin, ray.direction, ray.time);
            if let Some((t, detail, entering)) = csg::intersect(blas, csg, o, d, t_min, *t_max) {
                *best = Some(Hit { t, instance, detail, csg_entering: Some(entering) });
                *t_max = t;
            }
            return;
        }
        if blas.deforming.is_some() {
            return self.intersect_deforming(instance, inst, query, t_max, best);
        }
        let Some((mut tray, shear)) = Self::blas_ray(inst, query, *t_max) else { return };
        let shear = prepare(&shear);
        let (origin, direction) = (Vec3::from(tray.origin), Vec3::from(tray.direction));
        // Tests BVH slot `slot` against the ray whose closest hit so far is at `r.t_max`; inlined
        // into the traversal loop (a call per primitive costs more than the test's setup).
        // In a BLAS of triangles alone, slot `k` holds triangle `k` (`BlasBuilder::finish`).
        let triangles_only = blas.quadrics.is_empty();
        blas.bvh.closest_with(
            lanes,
            &mut tray,
            #[inline(always)]
            |r, slot| {
                let t_max = r.t_max;
                match if triangles_only { Prim::Triangle(slot) } else { blas.prims[slot as usize] } {
                    Prim::Triangle(i) => {
                        let h = test(&shear, blas, i, t_max)?;
                        if h.t <= t_min {
                            return None;
                        }
                        let tri = &blas.triangles[i as usize];
                        let (one_sided, reverse) = self.sidedness(inst, blas, tri.shape);
                        if one_sided && (tri.hits_front(direction) == reverse) {
                            return None;
                        }
                        *best = Some(Hit {
                            t: h.t,
                            instance,
                            detail: HitDetail::Triangle(i, h.b),
                            csg_entering: None,
                        });
                        Some(h.t)
                    }
                    Prim::Quadric(i) => {
                        let q = &blas.quadrics[i as usize];
                        let h = self.quadric_hit(inst, blas, q, (origin, direction), (t_min, t_max))?;
                        let t = h.t as f32;
                        *best =
                            Some(Hit { t, instance, detail: HitDetail::Quadric(i, h), csg_entering: None });
                        Some(t)
                    }
                }
            },
        );
        *t_max = tray.t_max;
    }

    /// The first crossing of quadric `q` of `blas` (one of its quadrics, or a deforming one at
    /// the ray's time) by the BLAS-space ray `(origin, direction)` with its `f32` parameter in
    /// `(t_min, t_max)` and on a side the instance sees. Out of line: kept out of the traversal
    /// loop, which inlines the triangle test.
    #[inline(never)]
    fn quadric_hit(
        &self,
        inst: &Instance,
        blas: &Blas,
        q: &QuadricPrim,
        (origin, direction): (Vec3, Vec3),
        (t_min, t_max): (f32, f32),
    ) -> Option<QuadricHit> {
        let oo = q.object_from_blas.transform_point3(origin.as_dvec3());
        let od = q.object_from_blas.transform_vector3(direction.as_dvec3());
        let (one_sided, reverse) = self.sidedness(inst, blas, q.shape);
        q.quadric.intersect(oo, od, f64::from(t_min), f64::from(t_max), |h| {
            let t32 = h.t as f32;
            if !(t32 > t_min && t32 < t_max) {
                return false;
            }
            if one_sided {
                let front = h.n.dot(od) < 0.0;
                if front == reverse {
                    return false;
                }
            }
            true
        })
    }

    /// For benchmarks: the BVH and the triangles (in BVH slot order) of a one-level world
    /// (no object instances, no quadrics), so that obvhs' own traversal can run on the same tree.
    #[doc(hidden)]
    pub fn single_level_triangles(&self) -> Option<(&Bvh, Vec<[Vec3; 3]>)> {
        if self.tlas.is_some() || self.instances.len() != 1 || !self.instances[0].identity {
            return None;
        }
        let blas = &self.blases[self.instances[0].blas as usize];
        if !blas.quadrics.is_empty() {
            return None;
        }
        let tris = blas
            .prims
            .iter()
            .map(|p| match p {
                Prim::Triangle(i) => blas.triangles[*i as usize].p,
                Prim::Quadric(_) => [Vec3::ZERO; 3],
            })
            .collect();
        Some((&blas.bvh, tris))
    }
}

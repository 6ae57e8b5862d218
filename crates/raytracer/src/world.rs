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

use crate::accel::{Bvh, BvhStats, TraversalRay};
use crate::diagnostics::Diagnostics;
use crate::lights::{EmitterShape, Light, LightSet, RENDERMAN_LIGHT_SCALE, quadric_area};
use crate::materials::{Material, MaterialNote};
use crate::math::{offset_ray_origin, round_point, transform_normal, transform_point_error};

use crate::sampling::Distribution1D;
use crate::shapes::{Quadric, QuadricHit, RayShear, barycentric_point, intersect_triangle};
use crate::texture::Texture;
use glam::{DMat4, DVec3, Vec2, Vec3};
use rib_parser::scene::{AttributesId, LightKind, Scene, Shape, ShapeEntity};
use rib_parser::tessellate::{Tolerance, TriangleMesh, is_quadric, shape_kind, tessellate_placed};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A ray in render space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, direction: Vec3) -> Ray {
        Ray { origin, direction, t_min: 0.0, t_max: f32::INFINITY }
    }
}

#[derive(Clone, Copy, Debug)]
struct TrianglePrim {
    p: [Vec3; 3],
    shape: u32,
    index: u32,
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
    quadrics: Vec<QuadricPrim>,
    shapes: Vec<BlasShape>,
    meshes: Vec<MeshShading>,
    bounds: (Vec3, Vec3),
}

#[derive(Clone, Debug)]
struct Instance {
    blas: u32,
    identity: bool,
    render_from_blas: DMat4,
    blas_from_render: DMat4,
    /// Attribute state of an `ObjectInstance` (replaces the definition's).
    attributes: Option<AttributesId>,
    one_sided: Option<bool>,
    reverse_xor: bool,
    /// Light index of each BLAS shape that emits (`u32::MAX` for none); empty when none does.
    emitters: Vec<u32>,
}

/// Where a ray hit, before the surface is evaluated.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    instance: u32,
    detail: HitDetail,
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
    /// Texture coordinates.
    pub st: Vec2,
    /// Direction toward the ray's origin.
    pub wo: Vec3,
    /// True when the ray arrived on the front side.
    pub front: bool,
    pub attributes: AttributesId,
    /// The area light this surface belongs to, if it emits.
    pub emitter: Option<u32>,
}

impl SurfaceInteraction {
    /// A ray leaving the surface in direction `d`, from an origin pushed off the surface.
    pub fn spawn_ray(&self, d: Vec3) -> Ray {
        Ray::new(offset_ray_origin(self.p, self.p_error, self.ng, d), d)
    }

    /// A shadow-ray segment from this surface to a point `p` (with error `p_error` and normal
    /// `n`, zero for points not on surfaces): origin, direction (unnormalised) and `t_max`.
    pub fn spawn_ray_to(&self, p: Vec3, p_error: Vec3, n: Vec3) -> Ray {
        let from = offset_ray_origin(self.p, self.p_error, self.ng, p - self.p);
        let to = if n == Vec3::ZERO { p } else { offset_ray_origin(p, p_error, n, from - p) };
        // Stop just short of the end: a relative epsilon (scale-free).
        Ray { origin: from, direction: to - from, t_min: 0.0, t_max: 1.0 - 1e-4 }
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
    pub light_sets: Vec<LightSet>,
    attributes_light_set: Vec<u32>,
    /// Render-space bounds of all geometry.
    pub bounds: (Vec3, Vec3),
    pub stats: WorldStats,
}

struct BlasBuilder {
    triangles: Vec<TrianglePrim>,
    quadrics: Vec<QuadricPrim>,
    shapes: Vec<BlasShape>,
    meshes: Vec<MeshShading>,
}

/// A placed shape: triangles already in BLAS space, or a quadric in its object space.
enum Geometry {
    Mesh(TriangleMesh),
    Quadric(Quadric),
}

/// How large a pixel is at a distance from the eye: the tessellation of curved surfaces aims
/// at a chord error of half a pixel where the surface is (like RenderMan's shading rate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelFootprint {
    /// A perspective camera: one pixel spans this angle (radians, the smaller of x and y).
    Perspective { radians_per_pixel: f64 },
    /// An orthographic camera: one pixel spans this size in world units.
    Orthographic { size: f64 },
    /// No camera: tessellate relative to each shape's size only.
    Unknown,
}

impl PixelFootprint {
    fn at(&self, distance: f64) -> Option<f64> {
        let s = match *self {
            PixelFootprint::Perspective { radians_per_pixel } => radians_per_pixel * distance,
            PixelFootprint::Orthographic { size } => size,
            PixelFootprint::Unknown => return None,
        };
        (s.is_finite() && s > 0.0).then_some(s)
    }
}

/// Chord error bounds of the tessellation relative to a shape's size: never coarser than 1%,
/// never finer than 1e-4 (and 2e-4 where the camera distance is not known: object definitions).
pub const TESSELLATION_COARSEST: f64 = 1e-2;
pub const TESSELLATION_FINEST: f64 = 1e-4;
pub const TESSELLATION_DEFAULT: f64 = 2e-4;

/// At most this many triangles in a world; shapes beyond it are skipped with a warning.
pub const MAX_WORLD_TRIANGLES: usize = 64_000_000;

/// Bounds of a shape's control points (object space), when it has any.
fn control_bounds(shape: &Shape) -> Option<(DVec3, DVec3)> {
    let points: Box<dyn Iterator<Item = DVec3> + '_> = match shape {
        Shape::Polygons(m) => Box::new(m.positions.iter().map(|p| p.as_dvec3())),
        Shape::SubdivisionMesh(m) => Box::new(m.positions.iter().map(|p| p.as_dvec3())),
        Shape::Patches(m) => {
            Box::new(m.positions.iter().filter(|p| p.w != 0.0).map(|p| (p.truncate() / p.w).as_dvec3()))
        }
        Shape::NuPatch(m) => {
            Box::new(m.positions.iter().filter(|p| p.w != 0.0).map(|p| (p.truncate() / p.w).as_dvec3()))
        }
        _ => return None,
    };
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in points {
        if p.is_finite() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo.x <= hi.x).then_some((lo, hi))
}

/// The tessellation tolerance of a shape placed with `blas_from_object`: half a pixel at the
/// shape's nearest point to the eye (`eye_distance` from its bounds, when known), clamped to
/// [`TESSELLATION_FINEST`, `TESSELLATION_COARSEST`] of the shape's size.
fn tolerance_for(shape: &Shape, blas_from_object: &DMat4, footprint: Option<&PixelFootprint>) -> Tolerance {
    let relative = Tolerance::relative(TESSELLATION_DEFAULT);
    let (Some(footprint), Some((lo, hi))) = (footprint, control_bounds(shape)) else { return relative };
    let (lo, hi) = transformed_box(blas_from_object, lo, hi);
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let size = (hi - lo).length();
    if !(size > 0.0) || !size.is_finite() {
        return relative;
    }
    // Distance from the eye (the render-space origin) to the box.
    let distance = (DVec3::ZERO.clamp(lo, hi)).length();
    let Some(pixel) = footprint.at(distance) else { return relative };
    let eps = (0.5 * pixel).clamp(TESSELLATION_FINEST * size, TESSELLATION_COARSEST * size);
    Tolerance::absolute(eps)
}

/// Turns a scene shape into renderable geometry placed with `blas_from_object`, or says why it
/// is skipped. Quadrics are kept exact; everything else goes through rib-parser's tessellator.
fn place_geometry(
    shape: &Shape,
    blas_from_object: &DMat4,
    footprint: Option<&PixelFootprint>,
) -> Result<Geometry, String> {
    if is_quadric(shape) {
        return Quadric::new(shape).map(Geometry::Quadric).map_err(|e| e.0.to_string());
    }
    let tolerance = tolerance_for(shape, blas_from_object, footprint);
    let mesh = tessellate_placed(shape, blas_from_object, false, &tolerance).map_err(|e| e.to_string())?;
    if mesh.is_empty() {
        return Err("it has no area".into());
    }
    Ok(Geometry::Mesh(mesh))
}

/// Emission parameters of an area light: radiance and two-sidedness.
fn area_light_params(scene: &Scene, light: u32) -> Option<(Vec3, bool)> {
    let l = scene.lights.get(light as usize)?;
    match l.kind {
        LightKind::Area { intensity, color } => {
            let params = &l.shader.params;
            let two_sided = params.float("twosided").map(|v| v != 0.0).unwrap_or(false)
                || params.ints("twosided").is_some_and(|v| v.first().is_some_and(|&x| x != 0))
                || params.string("twosided").is_some_and(|s| s == "true" || s == "on");
            Some((color * intensity, two_sided))
        }
        _ => None,
    }
}

impl BlasBuilder {
    fn new() -> BlasBuilder {
        BlasBuilder { triangles: Vec::new(), quadrics: Vec::new(), shapes: Vec::new(), meshes: Vec::new() }
    }

    /// Adds a placed shape (`blas_from_object` places quadrics; meshes are placed already);
    /// returns the BLAS shape index.
    fn add(
        &mut self,
        geometry: &Geometry,
        blas_from_object: &DMat4,
        attributes: AttributesId,
        scene: &Scene,
    ) -> Option<u32> {
        let attrs = scene.attributes_of(attributes);
        let shape_index = self.shapes.len() as u32;
        match geometry {
            Geometry::Mesh(mesh) => {
                let first = self.triangles.len();
                for (i, t) in mesh.indices.iter().enumerate() {
                    let p = [
                        mesh.positions[t[0] as usize],
                        mesh.positions[t[1] as usize],
                        mesh.positions[t[2] as usize],
                    ];
                    // Zero-area and non-finite triangles can never be hit: leave them out.
                    if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite())
                        || (p[1] - p[0]).cross(p[2] - p[0]) == Vec3::ZERO
                    {
                        continue;
                    }
                    self.triangles.push(TrianglePrim { p, shape: shape_index, index: i as u32 });
                }
                if self.triangles.len() == first {
                    return None;
                }
                self.meshes.push(MeshShading {
                    triangles: mesh.indices.clone(),
                    normals: mesh.normals.clone(),
                    st: mesh.st.clone(),
                });
                self.shapes.push(BlasShape {
                    attributes,
                    one_sided: attrs.sides == 1,
                    reverse: attrs.reverse_orientation,
                    mesh: Some(self.meshes.len() as u32 - 1),
                });
            }
            Geometry::Quadric(q) => {
                let object_from_blas = blas_from_object.inverse();
                if !object_from_blas.is_finite() {
                    return None;
                }
                self.quadrics.push(QuadricPrim {
                    quadric: *q,
                    object_from_blas,
                    blas_from_object: *blas_from_object,
                    shape: shape_index,
                });
                self.shapes.push(BlasShape {
                    attributes,
                    one_sided: attrs.sides == 1,
                    reverse: attrs.reverse_orientation,
                    mesh: None,
                });
            }
        }
        Some(shape_index)
    }

    fn finish(self) -> Blas {
        let mut boxes = Vec::with_capacity(self.triangles.len() + self.quadrics.len());
        let mut refs = Vec::with_capacity(boxes.capacity());
        for (i, t) in self.triangles.iter().enumerate() {
            boxes.push((t.p[0].min(t.p[1]).min(t.p[2]), t.p[0].max(t.p[1]).max(t.p[2])));
            refs.push(Prim::Triangle(i as u32));
        }
        for (i, q) in self.quadrics.iter().enumerate() {
            boxes.push(transformed_box(&q.blas_from_object, q.quadric.bounds_min, q.quadric.bounds_max));
            refs.push(Prim::Quadric(i as u32));
        }
        let mut bounds = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for b in &boxes {
            bounds.0 = bounds.0.min(b.0);
            bounds.1 = bounds.1.max(b.1);
        }
        let bvh = Bvh::build(&boxes);
        // Store triangles in BVH order for locality; quadrics stay indexed.
        let mut triangles = Vec::with_capacity(self.triangles.len());
        let mut prims = Vec::with_capacity(bvh.order().len());
        for &i in bvh.order() {
            match refs[i as usize] {
                Prim::Triangle(t) => {
                    prims.push(Prim::Triangle(triangles.len() as u32));
                    triangles.push(self.triangles[t as usize]);
                }
                q @ Prim::Quadric(_) => prims.push(q),
            }
        }
        Blas {
            bvh,
            prims,
            triangles,
            quadrics: self.quadrics,
            shapes: self.shapes,
            meshes: self.meshes,
            bounds,
        }
    }
}

/// Bounds of the transformed box (all eight corners in `f64`, rounded outward).
fn transformed_box(m: &DMat4, lo: DVec3, hi: DVec3) -> (Vec3, Vec3) {
    let mut bmin = DVec3::splat(f64::INFINITY);
    let mut bmax = DVec3::splat(f64::NEG_INFINITY);
    for i in 0..8 {
        let c = DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let p = m.transform_point3(c);
        bmin = bmin.min(p);
        bmax = bmax.max(p);
    }
    let pad = (bmax - bmin).abs() * 1e-9 + bmin.abs().max(bmax.abs()) * 1e-12;
    let lo = (bmin - pad).as_vec3();
    let hi = (bmax + pad).as_vec3();
    (
        Vec3::new(
            crate::math::next_float_down(lo.x),
            crate::math::next_float_down(lo.y),
            crate::math::next_float_down(lo.z),
        ),
        Vec3::new(
            crate::math::next_float_up(hi.x),
            crate::math::next_float_up(hi.y),
            crate::math::next_float_up(hi.z),
        ),
    )
}

/// Errors that stop a world from being built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum WorldError {
    #[error("the camera transform places the eye at a non-finite position")]
    BadEye,
}

impl World {
    /// Builds the world for `scene` seen from the eye at `eye_world` (world space); curved
    /// surfaces are tessellated to half of `footprint`'s pixel where they are.
    pub fn build(
        scene: &Scene,
        eye_world: DVec3,
        footprint: PixelFootprint,
        diagnostics: &mut Diagnostics,
    ) -> Result<World, WorldError> {
        let start = Instant::now();
        if !eye_world.is_finite() {
            return Err(WorldError::BadEye);
        }
        let render_from_world = DMat4::from_translation(-eye_world);

        // Materials, one per attribute state.
        let mut texture_cache: HashMap<String, Result<Arc<Texture>, String>> = HashMap::new();
        let mut materials = Vec::with_capacity(scene.attributes.len());
        for attrs in &scene.attributes {
            let mut notes = Vec::new();
            let mut load = |path: &str| {
                texture_cache
                    .entry(path.to_string())
                    .or_insert_with(|| Texture::load(&PathBuf::from(path)).map(Arc::new))
                    .clone()
            };
            let m = Material::from_attributes(attrs, &mut load, &mut notes);
            let loc = attrs.surface.as_ref().map(|s| &s.loc);
            for note in notes {
                match note {
                    MaterialNote::UnknownShader(name) => diagnostics
                        .warn_once(loc, format!("unknown surface shader \"{name}\": rendered as \"matte\"")),
                    MaterialNote::TextureUnreadable { path, reason } => diagnostics.warn_once(
                        loc,
                        format!("texture \"{path}\" cannot be read ({reason}): rendered without it"),
                    ),
                }
            }
            if attrs.displacement.is_some() {
                diagnostics.warn_once(
                    attrs.displacement.as_ref().map(|d| &d.loc),
                    "displacement shaders are ignored".to_string(),
                );
            }
            materials.push(m);
        }

        // Geometry, placed (and for meshes tessellated) per placement.
        // World shapes are placed in render space, where the eye is the origin; object
        // definitions in their own space (no camera distance).
        let mut triangle_count = 0usize;
        let mut geometry = |entity: &ShapeEntity,
                            blas_from_object: &DMat4,
                            in_render_space: bool,
                            diagnostics: &mut Diagnostics| {
            if triangle_count >= MAX_WORLD_TRIANGLES && !is_quadric(&entity.shape) {
                let kind = shape_kind(&entity.shape);
                let why = format!("the world already has {MAX_WORLD_TRIANGLES} triangles");
                diagnostics.warn_once(Some(&entity.loc), format!("{kind} skipped: {why}"));
                diagnostics.skip(&format!("{kind} ({why})"));
                return None;
            }
            let fp = if in_render_space { Some(&footprint) } else { None };
            match place_geometry(&entity.shape, blas_from_object, fp) {
                Ok(g) => {
                    if let Geometry::Mesh(m) = &g {
                        triangle_count += m.indices.len();
                    }
                    Some(g)
                }
                Err(why) => {
                    let kind = shape_kind(&entity.shape);
                    diagnostics.warn_once(Some(&entity.loc), format!("{kind} skipped: {why}"));
                    diagnostics.skip(&format!("{kind} ({why})"));
                    None
                }
            }
        };

        let mut lights: Vec<Light> = Vec::new();
        // Scene light id -> our light index, for non-area lights.
        let mut light_index: HashMap<u32, u32> = HashMap::new();
        for (i, l) in scene.lights.iter().enumerate() {
            let scale = RENDERMAN_LIGHT_SCALE;
            let to_render = |p: DVec3| render_from_world.transform_point3(p).as_vec3();
            let light = match &l.kind {
                LightKind::Ambient { intensity, color } => {
                    Some(Light::Ambient { color: *color * *intensity })
                }
                LightKind::Point { position, intensity, color } => Some(Light::Point {
                    position: to_render(*position),
                    intensity: *color * *intensity * scale,
                }),
                LightKind::Distant { direction, intensity, color } => Some(Light::Distant {
                    direction: direction.normalize_or(DVec3::Z).as_vec3(),
                    irradiance: *color * *intensity * scale,
                }),
                LightKind::Spot {
                    position,
                    direction,
                    intensity,
                    color,
                    cone_angle,
                    cone_delta_angle,
                    beam_distribution,
                } => Some(Light::spot(
                    to_render(*position),
                    direction.as_vec3(),
                    *color * *intensity * scale,
                    *cone_angle,
                    *cone_delta_angle,
                    *beam_distribution,
                )),
                LightKind::Area { .. } => None,
                LightKind::Other => {
                    diagnostics.warn_once(
                        Some(&l.shader.loc),
                        format!("light shader \"{}\" is not supported: skipped", l.shader.name),
                    );
                    diagnostics.skip("light sources (unsupported shader)");
                    None
                }
            };
            if let Some(light) = light {
                let valid = match &light {
                    Light::Point { position, intensity } => position.is_finite() && intensity.is_finite(),
                    Light::Spot { position, intensity, .. } => position.is_finite() && intensity.is_finite(),
                    Light::Distant { direction, irradiance } => {
                        direction.is_finite() && irradiance.is_finite()
                    }
                    Light::Ambient { color } => color.is_finite(),
                    Light::Area { .. } => true,
                };
                if valid {
                    light_index.insert(i as u32, lights.len() as u32);
                    lights.push(light);
                } else {
                    diagnostics
                        .warn_once(Some(&l.shader.loc), "light with non-finite values skipped".to_string());
                }
            }
        }

        // Emitters collected while placing shapes: (scene light id, render-space emitter shape).
        let mut emitters: Vec<(u32, EmitterShape)> = Vec::new();

        // The world BLAS (render space).
        let mut world_blas = BlasBuilder::new();
        let mut world_emitters: Vec<u32> = Vec::new();
        for entity in &scene.shapes {
            let render_from_object = render_from_world * entity.world_from_object;
            if !render_from_object.is_finite() || render_from_object.determinant() == 0.0 {
                diagnostics
                    .warn_once(Some(&entity.loc), "shape with a singular transform skipped".to_string());
                diagnostics.skip("shapes (singular transform)");
                continue;
            }
            let Some(g) = geometry(entity, &render_from_object, true, diagnostics) else { continue };
            let Some(shape_index) = world_blas.add(&g, &render_from_object, entity.attributes, scene) else {
                diagnostics.skip("shapes (degenerate geometry)");
                continue;
            };
            let attrs = scene.attributes_of(entity.attributes);
            let emitter = attrs.area_light.and_then(|id| {
                let shape =
                    emitter_shape(&g, &DMat4::IDENTITY, &render_from_object, attrs.reverse_orientation)?;
                emitters.push((id.0, shape));
                Some(emitters.len() as u32 - 1)
            });
            world_emitters.resize(shape_index as usize, u32::MAX);
            world_emitters.push(emitter.unwrap_or(u32::MAX));
        }

        let mut blases = Vec::new();
        let mut instances = Vec::new();
        let world_blas = world_blas.finish();
        if !world_blas.prims.is_empty() {
            let has_emitters = world_emitters.iter().any(|&e| e != u32::MAX);
            blases.push(world_blas);
            instances.push(Instance {
                blas: 0,
                identity: true,
                render_from_blas: DMat4::IDENTITY,
                blas_from_render: DMat4::IDENTITY,
                attributes: None,
                one_sided: None,
                reverse_xor: false,
                emitters: if has_emitters { world_emitters } else { Vec::new() },
            });
        }

        // Object definitions, each its own BLAS, built only when instanced.
        let mut definition_blas: HashMap<u32, Option<u32>> = HashMap::new();
        let mut definition_geometry: HashMap<u32, Vec<(Geometry, DMat4, bool)>> = HashMap::new();
        for inst in &scene.instances {
            let object = inst.object.0;
            let Some(def) = scene.objects.get(object as usize) else { continue };
            let blas_index = *definition_blas.entry(object).or_insert_with(|| {
                let mut builder = BlasBuilder::new();
                let mut placed = Vec::new();
                for entity in &def.shapes {
                    let Some(g) = geometry(entity, &entity.world_from_object, false, diagnostics) else {
                        continue;
                    };
                    if builder.add(&g, &entity.world_from_object, entity.attributes, scene).is_some() {
                        let reverse = scene.attributes_of(entity.attributes).reverse_orientation;
                        placed.push((g, entity.world_from_object, reverse));
                    }
                }
                let blas = builder.finish();
                if blas.prims.is_empty() {
                    return None;
                }
                blases.push(blas);
                definition_geometry.insert(object, placed);
                Some(blases.len() as u32 - 1)
            });
            let Some(blas_index) = blas_index else { continue };
            let render_from_blas = render_from_world * inst.world_from_instance;
            if !render_from_blas.is_finite() || render_from_blas.determinant() == 0.0 {
                diagnostics.warn_once(
                    Some(&inst.loc),
                    "object instance with a singular transform skipped".to_string(),
                );
                continue;
            }
            let attrs = scene.attributes_of(inst.attributes);
            let mut inst_emitters = Vec::new();
            if let Some(id) = attrs.area_light {
                for (g, def_from_object, reverse) in definition_geometry.get(&object).into_iter().flatten() {
                    let reverse = *reverse ^ attrs.reverse_orientation;
                    let shape =
                        emitter_shape(g, &render_from_blas, &(render_from_blas * *def_from_object), reverse);
                    match shape {
                        Some(s) => {
                            emitters.push((id.0, s));
                            inst_emitters.push(emitters.len() as u32 - 1);
                        }
                        None => inst_emitters.push(u32::MAX),
                    }
                }
            }
            instances.push(Instance {
                blas: blas_index,
                identity: false,
                render_from_blas,
                blas_from_render: render_from_blas.inverse(),
                attributes: Some(inst.attributes),
                one_sided: Some(attrs.sides == 1),
                reverse_xor: attrs.reverse_orientation,
                emitters: inst_emitters,
            });
        }

        // Area lights: one light per emitting shape placement.
        let mut emitter_light = vec![u32::MAX; emitters.len()];
        let mut area_lights = 0;
        for (k, (scene_light, shape)) in emitters.into_iter().enumerate() {
            let Some((radiance, two_sided)) = area_light_params(scene, scene_light) else { continue };
            if !radiance.is_finite() {
                continue;
            }
            emitter_light[k] = lights.len() as u32;
            lights.push(Light::Area { shape, radiance, two_sided });
            area_lights += 1;
        }
        for inst in &mut instances {
            for e in &mut inst.emitters {
                if *e != u32::MAX {
                    *e = emitter_light[*e as usize];
                }
            }
        }

        // Bounds.
        let mut bounds = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut instance_boxes = Vec::with_capacity(instances.len());
        for inst in &instances {
            let b = &blases[inst.blas as usize].bounds;
            let bb = if inst.identity {
                *b
            } else {
                transformed_box(&inst.render_from_blas, b.0.as_dvec3(), b.1.as_dvec3())
            };
            bounds.0 = bounds.0.min(bb.0);
            bounds.1 = bounds.1.max(bb.1);
            instance_boxes.push(bb);
        }
        let (tlas, instances) = if instances.is_empty() || (instances.len() == 1 && instances[0].identity) {
            (None, instances)
        } else {
            let tlas = Bvh::build(&instance_boxes);
            let ordered = tlas.order().iter().map(|&i| instances[i as usize].clone()).collect();
            (Some(tlas), ordered)
        };

        // Light sets, one per distinct list of illuminating lights. Area lights illuminate
        // every surface (they are physical emitters, found by BSDF sampling too); the
        // attribute's light list links the other lights.
        let scene_radius = {
            let ext = (bounds.1 - bounds.0).max(Vec3::ZERO);
            if ext.is_finite() { (ext.length() * 0.5).max(f32::MIN_POSITIVE) } else { 1.0 }
        };
        let area_members: Vec<u32> =
            (0..lights.len() as u32).filter(|&i| !lights[i as usize].is_delta()).collect();
        let mut set_index: HashMap<Vec<u32>, u32> = HashMap::new();
        let mut light_sets = Vec::new();
        let mut attributes_light_set = Vec::with_capacity(scene.attributes.len());
        for attrs in &scene.attributes {
            let mut members: Vec<u32> =
                attrs.illuminated_by.iter().filter_map(|id| light_index.get(&id.0).copied()).collect();
            members.extend(&area_members);
            members.sort_unstable();
            members.dedup();
            let idx = *set_index.entry(members.clone()).or_insert_with(|| {
                light_sets.push(LightSet::new(&lights, &members, scene_radius));
                light_sets.len() as u32 - 1
            });
            attributes_light_set.push(idx);
        }

        let mut stats = WorldStats {
            triangles: blases.iter().map(|b| b.triangles.len()).sum(),
            quadrics: blases.iter().map(|b| b.quadrics.len()).sum(),
            blases: blases.len(),
            instances: instances.len(),
            lights: lights.len(),
            area_lights,
            top_level: tlas.is_some(),
            ..WorldStats::default()
        };
        let mut all_bvh: Vec<BvhStats> = blases.iter().map(|b| b.bvh.stats).collect();
        if let Some(t) = &tlas {
            all_bvh.push(t.stats);
        }
        stats.bvh_nodes = all_bvh.iter().map(|s| s.nodes).sum();
        stats.bvh_bytes = all_bvh.iter().map(|s| s.bytes).sum::<usize>()
            + blases.iter().map(|b| b.triangles.len() * std::mem::size_of::<TrianglePrim>()).sum::<usize>();
        stats.bvh_build_time = all_bvh.iter().map(|s| s.build_time).sum();
        stats.build_time = start.elapsed();

        Ok(World {
            render_from_world,
            blases,
            instances,
            tlas,
            materials,
            lights,
            light_sets,
            attributes_light_set,
            bounds,
            stats,
        })
    }

    /// The render-space bounding sphere of the geometry (centre, radius).
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let (lo, hi) = self.bounds;
        if !(lo.is_finite() && hi.is_finite()) {
            return (Vec3::ZERO, 1.0);
        }
        ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(f32::MIN_POSITIVE))
    }

    /// The light set of an attribute state.
    pub fn light_set(&self, attributes: AttributesId) -> &LightSet {
        &self.light_sets[self.attributes_light_set[attributes.0 as usize] as usize]
    }

    pub fn material(&self, attributes: AttributesId) -> &Material {
        &self.materials[attributes.0 as usize]
    }

    fn sidedness(&self, inst: &Instance, blas: &Blas, shape: u32) -> (bool, bool) {
        let s = &blas.shapes[shape as usize];
        (inst.one_sided.unwrap_or(s.one_sided), s.reverse ^ inst.reverse_xor)
    }

    /// The closest hit along `ray` within `(t_min, t_max)`.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        match &self.tlas {
            None => {
                if let Some(inst) = self.instances.first() {
                    self.intersect_instance(
                        0,
                        inst,
                        ray.origin,
                        ray.direction,
                        ray.t_min,
                        &mut t_max,
                        &mut best,
                    );
                }
            }
            Some(tlas) => {
                let mut tray = TraversalRay::new(ray.origin, ray.direction, ray.t_min, ray.t_max)?;
                tlas.closest(&mut tray, |r, slot| {
                    let inst = &self.instances[slot as usize];
                    let mut t = r.t_max;
                    self.intersect_instance(
                        slot,
                        inst,
                        ray.origin,
                        ray.direction,
                        ray.t_min,
                        &mut t,
                        &mut best,
                    );
                    (t < r.t_max).then_some(t)
                });
            }
        }
        best
    }

    /// The ray in an instance's BLAS space (the parameter `t` is preserved).
    #[inline]
    fn to_blas(inst: &Instance, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        if inst.identity {
            (o, d)
        } else {
            let m = &inst.blas_from_render;
            (m.transform_point3(o.as_dvec3()).as_vec3(), m.transform_vector3(d.as_dvec3()).as_vec3())
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn intersect_instance(
        &self,
        instance: u32,
        inst: &Instance,
        o: Vec3,
        d: Vec3,
        t_min: f32,
        t_max: &mut f32,
        best: &mut Option<Hit>,
    ) {
        let blas = &self.blases[inst.blas as usize];
        let (o, d) = Self::to_blas(inst, o, d);
        let Some(shear) = RayShear::new(o, d) else { return };
        let Some(mut tray) = TraversalRay::new(o, d, t_min, *t_max) else { return };
        let (o64, d64) = (o.as_dvec3(), d.as_dvec3());
        blas.bvh.closest(&mut tray, |r, slot| match blas.prims[slot as usize] {
            Prim::Triangle(i) => {
                let tri = &blas.triangles[i as usize];
                let h = intersect_triangle(&shear, tri.p[0], tri.p[1], tri.p[2], r.t_max)?;
                if h.t <= t_min {
                    return None;
                }
                let (one_sided, reverse) = self.sidedness(inst, blas, tri.shape);
                if one_sided && (h.front == reverse) {
                    return None;
                }
                *best = Some(Hit { t: h.t, instance, detail: HitDetail::Triangle(i, h.b) });
                Some(h.t)
            }
            Prim::Quadric(i) => {
                let q = &blas.quadrics[i as usize];
                let oo = q.object_from_blas.transform_point3(o64);
                let od = q.object_from_blas.transform_vector3(d64);
                let (one_sided, reverse) = self.sidedness(inst, blas, q.shape);
                let limit = f64::from(r.t_max);
                let h = q.quadric.intersect(oo, od, f64::from(t_min), limit, |h| {
                    let t32 = h.t as f32;
                    if !(t32 > t_min && t32 < r.t_max) {
                        return false;
                    }
                    if one_sided {
                        let front = h.n.dot(od) < 0.0;
                        if front == reverse {
                            return false;
                        }
                    }
                    true
                })?;
                let t = h.t as f32;
                *best = Some(Hit { t, instance, detail: HitDetail::Quadric(i, h) });
                Some(t)
            }
        });
        *t_max = tray.t_max;
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

    /// Fraction of light passing along the segment `ray` (origin + t direction, `t` in
    /// `(t_min, t_max)`): zero when something opaque, a mirror or glass is in the way, the
    /// product of `1 - Os` of the semi-transparent surfaces crossed otherwise.
    pub fn transmittance(&self, ray: &Ray) -> Vec3 {
        let mut tr = Vec3::ONE;
        match &self.tlas {
            None => {
                if let Some(inst) = self.instances.first() {
                    self.transmittance_instance(inst, ray, &mut tr);
                }
            }
            Some(tlas) => {
                let Some(tray) = TraversalRay::new(ray.origin, ray.direction, ray.t_min, ray.t_max) else {
                    return tr;
                };
                tlas.any(&tray, |_, slot| {
                    self.transmittance_instance(&self.instances[slot as usize], ray, &mut tr);
                    tr == Vec3::ZERO
                });
            }
        }
        tr
    }

    /// Attenuation by one surface crossing: `None` means fully blocked.
    fn attenuation(&self, attributes: AttributesId) -> Option<Vec3> {
        let m = self.material(attributes);
        if m.blocks_shadows() || m.opacity == Vec3::ONE { None } else { Some(Vec3::ONE - m.opacity) }
    }

    fn transmittance_instance(&self, inst: &Instance, ray: &Ray, tr: &mut Vec3) {
        let blas = &self.blases[inst.blas as usize];
        let (o, d) = Self::to_blas(inst, ray.origin, ray.direction);
        let Some(shear) = RayShear::new(o, d) else { return };
        let Some(tray) = TraversalRay::new(o, d, ray.t_min, ray.t_max) else { return };
        let (o64, d64) = (o.as_dvec3(), d.as_dvec3());
        let (t_min, t_max) = (ray.t_min, ray.t_max);
        blas.bvh.any(&tray, |_, slot| {
            match blas.prims[slot as usize] {
                Prim::Triangle(i) => {
                    let tri = &blas.triangles[i as usize];
                    let Some(h) = intersect_triangle(&shear, tri.p[0], tri.p[1], tri.p[2], t_max) else {
                        return false;
                    };
                    if h.t <= t_min {
                        return false;
                    }
                    let (one_sided, reverse) = self.sidedness(inst, blas, tri.shape);
                    if one_sided && (h.front == reverse) {
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
                Prim::Quadric(i) => {
                    let q = &blas.quadrics[i as usize];
                    let oo = q.object_from_blas.transform_point3(o64);
                    let od = q.object_from_blas.transform_vector3(d64);
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
        });
    }

    /// Evaluates the surface at a hit.
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let inst = &self.instances[hit.instance as usize];
        let blas = &self.blases[inst.blas as usize];
        let (p_blas, err_blas, ng_blas, ns_blas, n_outward_blas, dpdu_blas, st, shape);
        match hit.detail {
            HitDetail::Triangle(i, b) => {
                let tri = &blas.triangles[i as usize];
                let (p, err) = barycentric_point(b, tri.p[0], tri.p[1], tri.p[2]);
                p_blas = p;
                err_blas = err;
                let ng = (tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0]).as_dvec3();
                ng_blas = ng;
                shape = tri.shape;
                let s = &blas.shapes[tri.shape as usize];
                let mesh = s.mesh.map(|m| &blas.meshes[m as usize]);
                let vidx = mesh.map(|m| m.triangles[tri.index as usize]);
                let bw = [b[0] as f32, b[1] as f32, b[2] as f32];
                ns_blas = match (mesh.and_then(|m| m.normals.as_ref()), vidx) {
                    (Some(normals), Some(v)) => {
                        let n = normals[v[0] as usize] * bw[0]
                            + normals[v[1] as usize] * bw[1]
                            + normals[v[2] as usize] * bw[2];
                        if n.length_squared() > 0.0 && n.is_finite() { n.as_dvec3() } else { ng }
                    }
                    _ => ng,
                };
                n_outward_blas = ng;
                st = match (mesh.and_then(|m| m.st.as_ref()), vidx) {
                    (Some(sts), Some(v)) => {
                        sts[v[0] as usize] * bw[0] + sts[v[1] as usize] * bw[1] + sts[v[2] as usize] * bw[2]
                    }
                    _ => Vec2::new(bw[1], bw[2]),
                };
                dpdu_blas = (tri.p[1] - tri.p[0]).as_dvec3();
            }
            HitDetail::Quadric(i, h) => {
                let q = &blas.quadrics[i as usize];
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
                ns_blas = ng_blas;
                n_outward_blas = transform_normal(normal_matrix, h.n * q.quadric.orientation);
                dpdu_blas = m.transform_vector3(h.dpdu);
                st = h.uv.as_vec2();
                shape = q.shape;
            }
        }
        // BLAS space to render space.
        let (p64, err64, to_render_n): (DVec3, DVec3, Option<&DMat4>) = if inst.identity {
            (p_blas, err_blas, None)
        } else {
            let m = &inst.render_from_blas;
            let p = m.transform_point3(p_blas);
            let abs = DMat4::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs(), glam::DVec4::ZERO);
            let err = abs.transform_vector3(err_blas) + transform_point_error(m, p_blas);
            (p, err, Some(&inst.blas_from_render))
        };
        let map_n = |n: DVec3| match to_render_n {
            Some(inv) => transform_normal(inv, n),
            None => n,
        };
        let mut ng = map_n(ng_blas).normalize_or_zero().as_vec3();
        let mut ns = map_n(ns_blas).normalize_or_zero().as_vec3();
        let n_outward = map_n(n_outward_blas).normalize_or_zero().as_vec3();
        let dpdu = match to_render_n {
            Some(_) => inst.render_from_blas.transform_vector3(dpdu_blas).as_vec3(),
            None => dpdu_blas.as_vec3(),
        };
        let (_, reverse) = self.sidedness(inst, blas, shape);
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
        let (p, p_error) = round_point(p64, err64);
        let attributes = inst.attributes.unwrap_or(blas.shapes[shape as usize].attributes);
        let emitter = inst.emitters.get(shape as usize).copied().filter(|&e| e != u32::MAX);
        let wo = -ray.direction.normalize_or(Vec3::Z);
        SurfaceInteraction {
            p,
            p_error,
            p64,
            t: hit.t,
            ng,
            ns,
            n_outward: if n_outward == Vec3::ZERO { ng } else { n_outward },
            dpdu,
            st,
            wo,
            front: ray.direction.dot(ng) < 0.0,
            attributes,
            emitter,
        }
    }
}

/// The render-space emitter shape of a placed shape: meshes are in BLAS space (placed in
/// render space by `render_from_blas`), quadrics in object space (`render_from_object`).
/// `reverse` flips the front side.
fn emitter_shape(
    g: &Geometry,
    render_from_blas: &DMat4,
    render_from_object: &DMat4,
    reverse: bool,
) -> Option<EmitterShape> {
    match g {
        Geometry::Mesh(mesh) => {
            let identity = *render_from_blas == DMat4::IDENTITY;
            let positions: Vec<Vec3> = if identity {
                mesh.positions.clone()
            } else {
                mesh.positions
                    .iter()
                    .map(|p| render_from_blas.transform_point3(p.as_dvec3()).as_vec3())
                    .collect()
            };
            // A mirroring placement reverses the winding relative to the normal.
            let mirrored = render_from_blas.determinant() < 0.0;
            let mut triangles = Vec::new();
            let mut normals = Vec::new();
            let mut areas = Vec::new();
            for t in &mesh.indices {
                let p = [positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]];
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                let area: f32 = 0.5 * n.length();
                if !(area > 0.0) || !area.is_finite() {
                    continue;
                }
                triangles.push(p);
                normals.push(if reverse != mirrored { -n.normalize() } else { n.normalize() });
                areas.push(area);
            }
            if triangles.is_empty() {
                return None;
            }
            let area: f32 = areas.iter().sum();
            Some(EmitterShape::Triangles { triangles, normals, by_area: Distribution1D::new(&areas), area })
        }
        Geometry::Quadric(q) => {
            let object_from_render = render_from_object.inverse();
            let det = glam::DMat3::from_mat4(*render_from_object).determinant();
            let area = quadric_area(q, &object_from_render, det);
            // A full sphere under a similarity transform can be sampled by the cone it subtends.
            let sphere = match q.shape {
                crate::shapes::QuadricShape::Sphere { radius, z_min, z_max, .. }
                    if q.theta_max.abs() >= std::f64::consts::TAU && z_min <= -radius && z_max >= radius =>
                {
                    let l = glam::DMat3::from_mat4(*render_from_object);
                    let ltl = l.transpose() * l;
                    let s2 = ltl.x_axis.x;
                    let similar = (ltl - glam::DMat3::from_diagonal(DVec3::splat(s2)))
                        .to_cols_array()
                        .iter()
                        .all(|v| v.abs() <= 1e-9 * s2);
                    similar.then(|| (render_from_object.transform_point3(DVec3::ZERO), radius * s2.sqrt()))
                }
                _ => None,
            };
            (area > 0.0 && area.is_finite()).then_some(EmitterShape::Quadric {
                quadric: *q,
                render_from_object: *render_from_object,
                object_from_render,
                det,
                flip: reverse,
                sphere,
                area,
            })
        }
    }
}

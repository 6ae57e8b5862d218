//! Building the world from a scene: tessellation at the camera's resolution, bottom-level BVHs
//! per definition, instances, materials, lights and light sets.

use super::csg::Csg;
use super::motion::{motion_box, shutter_motion};
use super::*;
use crate::accel::BvhStats;
use crate::diagnostics::Diagnostics;
use crate::lights::{EmitterShape, Light, LightSet, RENDERMAN_LIGHT_SCALE, quadric_area};
use crate::materials::{Material, MaterialNote};

use crate::sampling::Distribution1D;
use crate::texture::{Texture, Wrap};
use rib_parser::scene::{AttributesId, LightKind, MadeTextureKind, Scene, Shape, ShapeEntity};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;
use tessellate::{
    RibbonFacing, SeamWelder, Tolerance, TriangleMesh, curve_ribbons, is_quadric, point_widths, shape_kind,
    tessellate_placed,
};

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
    /// `Points`: exact spheres of their width, each with its object-from-sphere translation.
    Spheres(Vec<(Quadric, DMat4)>),
}

/// How large a pixel is at a distance from the eye: the tessellation of curved surfaces aims
/// at a chord error of half a pixel where the surface is (like RenderMan's shading rate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelFootprint {
    /// A perspective camera: one pixel spans this angle (radians, the smaller of x and y).
    Perspective { radians_per_pixel: f64 },
    /// An orthographic camera: one pixel spans this size in world units; every ray goes along
    /// `view_direction` (world space; ribbons face against it).
    Orthographic { size: f64, view_direction: DVec3 },
    /// No camera: tessellate relative to each shape's size only.
    Unknown,
}

impl PixelFootprint {
    /// The footprint at `distance` from the eye, 0 when the camera is not known.
    pub(super) fn width_at(&self, distance: f64) -> f64 {
        self.at(distance).unwrap_or(0.0)
    }

    fn at(&self, distance: f64) -> Option<f64> {
        let s = match *self {
            PixelFootprint::Perspective { radians_per_pixel } => radians_per_pixel * distance,
            PixelFootprint::Orthographic { size, .. } => size,
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
        Shape::Blobby(_) => return tessellate::shape_bounds(shape),
        Shape::Curves(c) => Box::new(c.positions.iter().map(|p| p.as_dvec3())),
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
    if let Shape::Points(points) = shape {
        return points_as_spheres(points);
    }
    let tolerance = tolerance_for(shape, blas_from_object, footprint);
    let mesh = match shape {
        // Seen from the eye (the render-space origin), curves are ribbons facing it; in an
        // object definition, where no eye is known, round tubes.
        Shape::Curves(curves) if footprint.is_some() => {
            let facing = match footprint {
                Some(PixelFootprint::Orthographic { view_direction, .. }) => {
                    RibbonFacing::Direction(-*view_direction)
                }
                _ => RibbonFacing::Eye(DVec3::ZERO),
            };
            curve_ribbons(curves, blas_from_object, facing, &tolerance).map_err(|e| e.to_string())?
        }
        _ => tessellate_placed(shape, blas_from_object, false, &tolerance).map_err(|e| e.to_string())?,
    };
    if mesh.is_empty() {
        return Err("it has no area".into());
    }
    Ok(Geometry::Mesh(mesh))
}

/// `Points` as exact spheres of diameter `width` (RenderMan's default 1) around each point.
fn points_as_spheres(points: &rib_parser::scene::Points) -> Result<Geometry, String> {
    let mut spheres = Vec::with_capacity(points.positions.len());
    for (p, width) in points.positions.iter().zip(point_widths(points)) {
        let radius = (0.5 * width.abs()) as f32;
        if !(radius > 0.0 && radius.is_finite() && p.is_finite()) {
            continue;
        }
        let sphere = Shape::Sphere { radius, z_min: -radius, z_max: radius, theta_max_degrees: 360.0 };
        let q = Quadric::new(&sphere).map_err(|e| e.0.to_string())?;
        spheres.push((q, DMat4::from_translation(p.as_dvec3())));
    }
    if spheres.is_empty() {
        return Err("no point has a positive width".into());
    }
    Ok(Geometry::Spheres(spheres))
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
            Geometry::Spheres(spheres) => {
                for (q, object_from_sphere) in spheres {
                    let blas_from_sphere = *blas_from_object * *object_from_sphere;
                    let sphere_from_blas = blas_from_sphere.inverse();
                    if !sphere_from_blas.is_finite() {
                        return None;
                    }
                    self.quadrics.push(QuadricPrim {
                        quadric: *q,
                        object_from_blas: sphere_from_blas,
                        blas_from_object: blas_from_sphere,
                        shape: shape_index,
                    });
                }
                self.shapes.push(BlasShape {
                    attributes,
                    one_sided: attrs.sides == 1,
                    reverse: attrs.reverse_orientation,
                    mesh: None,
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
            csg: None,
        }
    }
}

/// The texture a shader names: the picture of the last `MakeTexture` (or lat-long environment)
/// that made `name`, with its wrap modes, or else the file `name` itself. Relative paths are
/// tried from the working directory, then from the RIB file's directory.
fn load_texture(scene: &Scene, name: &str) -> Result<Arc<Texture>, String> {
    let resolve = |file: &str| {
        let direct = PathBuf::from(file);
        if direct.is_absolute() || direct.exists() {
            return direct;
        }
        match Path::new(scene.source.as_ref()).parent() {
            Some(dir) if dir.join(file).exists() => dir.join(file),
            _ => direct,
        }
    };
    let made = scene.render.textures.iter().rev().find(|t| t.name == name);
    match made.map(|t| &t.kind) {
        Some(MadeTextureKind::Texture { picture, swrap, twrap }) => {
            let wrap = |w: &str| Wrap::from_name(w).unwrap_or(Wrap::Periodic);
            let texture = Texture::load(&resolve(picture)).map_err(|e| format!("{picture}: {e}"))?;
            Ok(Arc::new(texture.with_wrap(wrap(swrap), wrap(twrap))))
        }
        Some(MadeTextureKind::LatLong { picture }) => {
            let texture = Texture::load(&resolve(picture)).map_err(|e| format!("{picture}: {e}"))?;
            Ok(Arc::new(texture.with_wrap(Wrap::Periodic, Wrap::Clamp)))
        }
        Some(MadeTextureKind::CubeFaces { .. }) => {
            Err("a cube-face environment cannot be a surface texture".to_string())
        }
        None => Texture::load(&resolve(name)).map(Arc::new),
    }
}

/// Bounds of the transformed box (all eight corners in `f64`, rounded outward).
/// A seam welder for the shapes of an object definition, in their BLAS space (the
/// definition's), over their bounds; `None` when no shape has bounds.
fn definition_seams(shapes: &[ShapeEntity]) -> Option<SeamWelder> {
    let mut bounds: Option<(DVec3, DVec3)> = None;
    for entity in shapes {
        let Some((lo, hi)) = tessellate::shape_bounds(&entity.shape) else { continue };
        let (lo, hi) = transformed_box(&entity.world_from_object, lo, hi);
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        bounds = Some(bounds.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
    }
    bounds.filter(|(lo, hi)| lo.is_finite() && hi.is_finite()).map(|(lo, hi)| SeamWelder::new(lo, hi))
}

pub(super) fn transformed_box(m: &DMat4, lo: DVec3, hi: DVec3) -> (Vec3, Vec3) {
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
                texture_cache.entry(path.to_string()).or_insert_with(|| load_texture(scene, path)).clone()
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
        // Separate patches of the world that share an edge get bitwise-equal vertices along it,
        // so the watertight triangle test closes the seam.
        let mut seams =
            tessellate::scene_bounds(scene).map(|(lo, hi)| SeamWelder::new(lo - eye_world, hi - eye_world));
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
                Ok(mut g) => {
                    if let Geometry::Mesh(m) = &mut g {
                        if let Some(seams) = seams.as_mut().filter(|_| in_render_space)
                            && SeamWelder::applies_to(&entity.shape)
                        {
                            seams.weld(m);
                        }
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
        let mut light_sources: Vec<u32> = Vec::new();
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
                    light_sources.push(i as u32);
                } else {
                    diagnostics
                        .warn_once(Some(&l.shader.loc), "light with non-finite values skipped".to_string());
                }
            }
        }

        // Emitters collected while placing shapes: (scene light id, render-space emitter shape).
        let mut emitters: Vec<(u32, EmitterShape)> = Vec::new();

        // Shapes of outermost solid blocks go into BLASes of their own (`csg.rs`).
        let solid_plans = Csg::plans(scene);
        let mut in_solid_blas = vec![false; scene.shapes.len()];
        for plan in &solid_plans {
            for &(s, _) in &plan.shapes {
                if let Some(flag) = in_solid_blas.get_mut(s as usize) {
                    *flag = true;
                }
            }
        }

        // Places a world shape (render space) into `builder`; its emitter index (or `u32::MAX`)
        // goes to `shape_emitters` at its BLAS shape index.
        let mut place_world_shape = |entity: &ShapeEntity,
                                     builder: &mut BlasBuilder,
                                     shape_emitters: &mut Vec<u32>,
                                     diagnostics: &mut Diagnostics|
         -> Option<u32> {
            let render_from_object = render_from_world * entity.world_from_object;
            if !render_from_object.is_finite() || render_from_object.determinant() == 0.0 {
                diagnostics
                    .warn_once(Some(&entity.loc), "shape with a singular transform skipped".to_string());
                diagnostics.skip("shapes (singular transform)");
                return None;
            }
            let g = geometry(entity, &render_from_object, true, diagnostics)?;
            let Some(shape_index) = builder.add(&g, &render_from_object, entity.attributes, scene) else {
                diagnostics.skip("shapes (degenerate geometry)");
                return None;
            };
            let attrs = scene.attributes_of(entity.attributes);
            let emitter = attrs.area_light.and_then(|id| {
                let shape =
                    emitter_shape(&g, &DMat4::IDENTITY, &render_from_object, attrs.reverse_orientation)?;
                emitters.push((id.0, shape));
                Some(emitters.len() as u32 - 1)
            });
            shape_emitters.resize(shape_index as usize, u32::MAX);
            shape_emitters.push(emitter.unwrap_or(u32::MAX));
            Some(shape_index)
        };

        // The world BLAS (render space).
        let mut world_blas = BlasBuilder::new();
        let mut world_emitters: Vec<u32> = Vec::new();
        // Shapes that move while the shutter is open get a BLAS of their own (object space),
        // placed by a moving instance.
        let mut moving_shapes: Vec<(&ShapeEntity, Arc<TransformMotion>)> = Vec::new();
        for (i, entity) in scene.shapes.iter().enumerate() {
            if let Some(motion) = shutter_motion(scene, &entity.motion, &render_from_world) {
                let static_why = if in_solid_blas[i] {
                    Some("a moving shape inside SolidBegin is placed at shutter open (no motion blur)")
                } else if scene.attributes_of(entity.attributes).area_light.is_some() {
                    Some("a moving area light is placed at shutter open (no motion blur)")
                } else {
                    None
                };
                match static_why {
                    Some(why) => diagnostics.warn_once(Some(&entity.loc), why.to_string()),
                    None => {
                        moving_shapes.push((entity, motion));
                        continue;
                    }
                }
            }
            if !in_solid_blas[i] {
                place_world_shape(entity, &mut world_blas, &mut world_emitters, diagnostics);
            }
        }
        let mut solid_blases = Vec::with_capacity(solid_plans.len());
        for mut plan in solid_plans {
            let mut builder = BlasBuilder::new();
            let mut shape_emitters = Vec::new();
            for &(s, leaf) in &plan.shapes {
                let Some(entity) = scene.shapes.get(s as usize) else { continue };
                if let Some(shape_index) =
                    place_world_shape(entity, &mut builder, &mut shape_emitters, diagnostics)
                {
                    plan.csg.leaf_of_shape.resize(shape_index as usize, u32::MAX);
                    plan.csg.leaf_of_shape.push(leaf);
                }
            }
            solid_blases.push((builder, shape_emitters, plan.csg));
        }

        let mut blases = Vec::new();
        let mut instances = Vec::new();
        let world_blas = world_blas.finish();
        let identity_instance = |blas: u32, emitters: Vec<u32>| {
            let has_emitters = emitters.iter().any(|&e| e != u32::MAX);
            Instance {
                blas,
                identity: true,
                render_from_blas: DMat4::IDENTITY,
                blas_from_render: DMat4::IDENTITY,
                attributes: None,
                one_sided: None,
                reverse_xor: false,
                emitters: if has_emitters { emitters } else { Vec::new() },
                motion: None,
            }
        };
        if !world_blas.prims.is_empty() {
            blases.push(world_blas);
            instances.push(identity_instance(0, world_emitters));
        }
        for (builder, shape_emitters, csg) in solid_blases {
            let mut blas = builder.finish();
            if blas.prims.is_empty() {
                continue;
            }
            blas.csg = Some(csg);
            blases.push(blas);
            instances.push(identity_instance(blases.len() as u32 - 1, shape_emitters));
        }

        for (entity, motion) in moving_shapes {
            let object_from_object = DMat4::IDENTITY;
            let Some(g) = geometry(entity, &object_from_object, false, diagnostics) else { continue };
            let mut builder = BlasBuilder::new();
            if builder.add(&g, &object_from_object, entity.attributes, scene).is_none() {
                diagnostics.skip("shapes (degenerate geometry)");
                continue;
            }
            let blas = builder.finish();
            if blas.prims.is_empty() {
                continue;
            }
            blases.push(blas);
            let render_from_blas = motion.at(0.0);
            instances.push(Instance {
                blas: blases.len() as u32 - 1,
                identity: false,
                render_from_blas,
                blas_from_render: render_from_blas.inverse(),
                attributes: None,
                one_sided: None,
                reverse_xor: false,
                emitters: Vec::new(),
                motion: Some(motion),
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
                let mut seams = definition_seams(&def.shapes);
                for entity in &def.shapes {
                    let Some(mut g) = geometry(entity, &entity.world_from_object, false, diagnostics) else {
                        continue;
                    };
                    if let (Geometry::Mesh(m), Some(seams)) = (&mut g, seams.as_mut())
                        && SeamWelder::applies_to(&entity.shape)
                    {
                        seams.weld(m);
                    }
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
            let attrs = scene.attributes_of(inst.attributes);
            let mut motion = shutter_motion(scene, &inst.motion, &render_from_world);
            if motion.is_some() && attrs.area_light.is_some() {
                diagnostics.warn_once(
                    Some(&inst.loc),
                    "a moving area light is placed at shutter open (no motion blur)".to_string(),
                );
                motion = None;
            }
            let render_from_blas = match &motion {
                Some(m) => m.at(0.0),
                None => render_from_world * inst.world_from_instance,
            };
            if !render_from_blas.is_finite() || render_from_blas.determinant() == 0.0 {
                diagnostics.warn_once(
                    Some(&inst.loc),
                    "object instance with a singular transform skipped".to_string(),
                );
                continue;
            }
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
                motion,
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
            light_sources.push(scene_light);
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
            } else if let Some(motion) = &inst.motion {
                motion_box(motion, b.0.as_dvec3(), b.1.as_dvec3())
            } else {
                transformed_box(&inst.render_from_blas, b.0.as_dvec3(), b.1.as_dvec3())
            };
            bounds.0 = bounds.0.min(bb.0);
            bounds.1 = bounds.1.max(bb.1);
            instance_boxes.push(bb);
        }
        let motion_blur = instances.iter().any(|i| i.motion.is_some());
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
            light_sources,
            light_sets,
            attributes_light_set,
            bounds,
            stats,
            motion_blur,
            background: background(scene),
            footprint,
        })
    }
}

/// The colour of `Imager "background"` (black without one, or for other imagers, which are
/// shader programs). Non-finite or negative components are taken as 0.
fn background(scene: &Scene) -> Vec3 {
    scene
        .render
        .imager
        .as_ref()
        .filter(|i| i.name == "background")
        .and_then(|i| rib_parser::builder::background_color(&i.params))
        .map_or(Vec3::ZERO, |c| c.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 }))
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
        // Points do not emit: an area light on them is left out.
        Geometry::Spheres(_) => None,
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

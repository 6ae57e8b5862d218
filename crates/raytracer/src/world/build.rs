//! Building the world from a scene: materials, shapes placed into bottom-level BVHs (see
//! `placement.rs`) per definition, instances, lights (see `lighting.rs`) and light sets.

use super::clipping::render_clipping_planes;
use super::csg::Csg;
use super::deformation::{KeyDisplacement, deforming_blas, shutter_deformation};
use super::displacement::{custom_shader_warning, displaced_geometry, displaced_keys, displacement_of};
use super::lighting::{self, area_light_params, background, emitter_shape};
use super::motion::{camera_shutter_motion, motion_box, shutter_motion};
use super::placement::{
    BlasBuilder, Geometry, MAX_WORLD_TRIANGLES, PixelFootprint, definition_seams, place_geometry,
    transformed_box,
};
use super::*;
use crate::accel::BvhStats;
use crate::diagnostics::Diagnostics;
use crate::lights::{EmitterShape, Light, LightSet};
use crate::materials::{Material, MaterialNote};
use crate::texture::Texture;
use rib_parser::deformation::Deformation;
use rib_parser::scene::{Scene, ShapeEntity};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;
use tessellate::{DisplacementTextures, SeamWelder, is_quadric, shape_kind};

/// Adds `g` (the geometry of `entity`) to `builder`, warning at the shape when triangles beyond
/// the BVH's coordinate range were left out.
fn add_to_blas(
    builder: &mut BlasBuilder,
    g: &Geometry,
    blas_from_object: &DMat4,
    entity: &ShapeEntity,
    scene: &Scene,
    diagnostics: &mut Diagnostics,
) -> Option<u32> {
    let far_before = builder.far_triangles;
    let added = builder.add(g, blas_from_object, entity.attributes, scene);
    if builder.far_triangles > far_before {
        diagnostics.warn_once(
            Some(&entity.loc),
            format!(
                "{} triangles of this shape lie beyond {:.1e} scene units from the eye or its object origin: left out",
                builder.far_triangles - far_before,
                crate::accel::MAX_BOX_COORD
            ),
        );
    }
    added
}

/// Whether `m` has a projective bottom row (a `Perspective` in a shape's transform).
fn is_projective(m: &DMat4) -> bool {
    m.row(3) != glam::DVec4::W
}

/// Whether a transformation motion has a projective key.
fn motion_is_projective(motion: &Option<Arc<TransformMotion>>) -> bool {
    motion.as_ref().is_some_and(|m| m.matrices().iter().any(is_projective))
}

/// The texture a shader names (`tessellate::load_scene_texture`, shared with the haptics).
pub(super) fn load_texture(scene: &Scene, name: &str) -> Result<Arc<Texture>, String> {
    tessellate::load_scene_texture(scene, name)
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
                    MaterialNote::BadBlur(blur) => diagnostics.warn_once(
                        loc,
                        format!("\"blur\" {blur} is not a finite width >= 0: the texture is read unblurred"),
                    ),
                }
            }
            if let Some(warning) = custom_shader_warning(attrs) {
                diagnostics.warn_once(attrs.displacement.as_ref().map(|d| &d.loc), warning);
            }
            materials.push(m);
        }

        // Geometry, placed (and for meshes tessellated) per placement.
        // World shapes are placed in render space, where the eye is the origin; object
        // definitions in their own space (no camera distance).
        // Every triangle placed so far, a deforming shape's counted once per key.
        let triangle_count = std::cell::Cell::new(0usize);
        // Separate patches of the world that share an edge get bitwise-equal vertices along it,
        // so the watertight triangle test closes the seam.
        let mut seams =
            tessellate::scene_bounds(scene).map(|(lo, hi)| SeamWelder::new(lo - eye_world, hi - eye_world));
        let displacement_textures = DisplacementTextures::new(scene);
        let world_from_render = DMat4::from_translation(eye_world);
        let mut geometry = |entity: &ShapeEntity,
                            blas_from_object: &DMat4,
                            world_from_blas: Option<&DMat4>,
                            diagnostics: &mut Diagnostics| {
            // Render space (`None`), or the space of an object definition or a moving shape.
            let in_render_space = world_from_blas.is_none();
            let displacement = displacement_of(scene, entity);
            if triangle_count.get() >= MAX_WORLD_TRIANGLES
                && (!is_quadric(&entity.shape) || displacement.is_some())
            {
                let kind = shape_kind(&entity.shape);
                let why = format!("the world already has {MAX_WORLD_TRIANGLES} triangles");
                diagnostics.warn_once(Some(&entity.loc), format!("{kind} skipped: {why}"));
                diagnostics.skip(&format!("{kind} ({why})"));
                return None;
            }
            let fp = if in_render_space { Some(&footprint) } else { None };
            let placed = match &displacement {
                Some(shader) => displaced_geometry(
                    scene,
                    entity,
                    shader,
                    blas_from_object,
                    world_from_blas.unwrap_or(&world_from_render),
                    fp,
                    &displacement_textures,
                    MAX_WORLD_TRIANGLES.saturating_sub(triangle_count.get()) as u64,
                    diagnostics,
                ),
                None => place_geometry(&entity.shape, blas_from_object, fp),
            };
            match placed {
                Ok(mut g) => {
                    if let Geometry::Mesh(m) = &mut g {
                        if let Some(seams) = seams.as_mut().filter(|_| in_render_space)
                            && SeamWelder::applies_to(&entity.shape)
                        {
                            seams.weld(m);
                        }
                        triangle_count.set(triangle_count.get() + m.indices.len());
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

        let (mut lights, mut light_sources, light_index) = lighting::scene_lights(
            scene,
            &render_from_world,
            &mut |path: &str| {
                texture_cache.entry(path.to_string()).or_insert_with(|| load_texture(scene, path)).clone()
            },
            diagnostics,
        );

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
            let g = geometry(entity, &render_from_object, None, diagnostics)?;
            let Some(shape_index) = add_to_blas(builder, &g, &render_from_object, entity, scene, diagnostics)
            else {
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
        // Shapes that deform while the shutter is open get a BLAS of their own holding their
        // keys (`deformation.rs`), in render space or, when they also move, in object space.
        let mut deforming_shapes: Vec<(&ShapeEntity, Deformation)> = Vec::new();
        // Whether shape `i`, which moves or deforms over the shutter, is held at shutter open
        // instead (inside a solid, or an area light: `why` says so for each), warning once if so.
        let held_at_open = |i: usize, entity: &ShapeEntity, why: [&str; 2], diagnostics: &mut Diagnostics| {
            let held = if in_solid_blas[i] {
                Some(why[0])
            } else if scene.attributes_of(entity.attributes).area_light.is_some() {
                Some(why[1])
            } else {
                None
            };
            if let Some(why) = held {
                diagnostics.warn_once(Some(&entity.loc), why.to_string());
            }
            held.is_some()
        };
        for (i, entity) in scene.shapes.iter().enumerate() {
            if is_projective(&entity.world_from_object) || motion_is_projective(&entity.motion) {
                // Moving and deforming BLASes map rays (or intersect quadric keys) affinely;
                // the shape at shutter open is tessellated through its transform instead.
                if entity.motion.is_some() || entity.deformation.is_some() {
                    diagnostics.warn_once(
                        Some(&entity.loc),
                        "a moving or deforming shape whose transformation is projective (Perspective) is drawn at shutter open (no motion blur)".to_string(),
                    );
                }
                if !in_solid_blas[i] {
                    place_world_shape(entity, &mut world_blas, &mut world_emitters, diagnostics);
                }
                continue;
            }
            if let Some(deformation) = shutter_deformation(scene, &entity.deformation) {
                let why = [
                    "a deforming shape inside SolidBegin is drawn at shutter open (no deformation blur)",
                    "a deforming area light is drawn at shutter open (no deformation blur)",
                ];
                if !held_at_open(i, entity, why, diagnostics) {
                    deforming_shapes.push((entity, deformation));
                    continue;
                }
            }
            if let Some(motion) = shutter_motion(scene, &entity.motion, &render_from_world) {
                let why = [
                    "a moving shape inside SolidBegin is placed at shutter open (no motion blur)",
                    "a moving area light is placed at shutter open (no motion blur)",
                ];
                if !held_at_open(i, entity, why, diagnostics) {
                    moving_shapes.push((entity, motion));
                    continue;
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
            let Some(g) = geometry(entity, &object_from_object, Some(&entity.world_from_object), diagnostics)
            else {
                continue;
            };
            let mut builder = BlasBuilder::new();
            if add_to_blas(&mut builder, &g, &object_from_object, entity, scene, diagnostics).is_none() {
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

        for (entity, deformation) in deforming_shapes {
            let motion = shutter_motion(scene, &entity.motion, &render_from_world);
            // Render space for a shape that does not move, its object space for one that does.
            let blas_from_object = match motion {
                Some(_) => DMat4::IDENTITY,
                None => render_from_world * entity.world_from_object,
            };
            if !blas_from_object.is_finite() || blas_from_object.determinant() == 0.0 {
                diagnostics
                    .warn_once(Some(&entity.loc), "shape with a singular transform skipped".to_string());
                diagnostics.skip("shapes (singular transform)");
                continue;
            }
            let fp = if motion.is_none() { Some(&footprint) } else { None };
            let budget = MAX_WORLD_TRIANGLES.saturating_sub(triangle_count.get());
            // A displaced shape's keys are diced alike and displaced each at its own vertices.
            let shader = displacement_of(scene, entity);
            let world_from_blas = match motion {
                Some(_) => entity.world_from_object,
                None => world_from_render,
            };
            let mut key_warnings = Diagnostics::default();
            let mut displace_keys = |keys: &[tessellate::TriangleMesh], budget: u64| {
                let shader = shader.as_ref().ok_or("no displacement")?;
                displaced_keys(
                    scene,
                    entity,
                    shader,
                    keys,
                    &world_from_blas,
                    fp,
                    &displacement_textures,
                    budget,
                    &mut key_warnings,
                )
            };
            let displace: Option<KeyDisplacement<'_>> =
                if shader.is_some() { Some(&mut displace_keys) } else { None };
            let placed = deforming_blas(
                &deformation,
                entity.attributes,
                &blas_from_object,
                fp,
                budget,
                scene,
                displace,
            );
            for warning in std::mem::take(&mut key_warnings.warnings) {
                diagnostics.warn_once(warning.loc.as_ref(), warning.message);
            }
            let blas = match placed {
                Ok((blas, keyed_triangles)) => {
                    triangle_count.set(triangle_count.get() + keyed_triangles);
                    blas
                }
                Err(why) => {
                    let kind = shape_kind(&entity.shape);
                    diagnostics.warn_once(
                        Some(&entity.loc),
                        format!("deforming {kind} drawn at shutter open (no deformation blur): {why}"),
                    );
                    // The shape at shutter open, in a BLAS of its own.
                    let world_from_blas = motion.as_ref().map(|_| &entity.world_from_object);
                    let Some(g) = geometry(entity, &blas_from_object, world_from_blas, diagnostics) else {
                        continue;
                    };
                    let mut builder = BlasBuilder::new();
                    if add_to_blas(&mut builder, &g, &blas_from_object, entity, scene, diagnostics).is_none()
                    {
                        diagnostics.skip("shapes (degenerate geometry)");
                        continue;
                    }
                    builder.finish()
                }
            };
            if blas.prims.is_empty() {
                continue;
            }
            blases.push(blas);
            let render_from_blas = motion.as_ref().map_or(DMat4::IDENTITY, |m| m.at(0.0));
            instances.push(Instance {
                blas: blases.len() as u32 - 1,
                identity: motion.is_none(),
                render_from_blas,
                blas_from_render: render_from_blas.inverse(),
                attributes: None,
                one_sided: None,
                reverse_xor: false,
                emitters: Vec::new(),
                motion,
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
                    // The definition's own space stands for the world (its shader spaces are
                    // relative to it too).
                    let Some(mut g) =
                        geometry(entity, &entity.world_from_object, Some(&DMat4::IDENTITY), diagnostics)
                    else {
                        continue;
                    };
                    if let (Geometry::Mesh(m), Some(seams)) = (&mut g, seams.as_mut())
                        && SeamWelder::applies_to(&entity.shape)
                    {
                        seams.weld(m);
                    }
                    if add_to_blas(&mut builder, &g, &entity.world_from_object, entity, scene, diagnostics)
                        .is_some()
                    {
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
            if motion.is_some() && motion_is_projective(&inst.motion) {
                diagnostics.warn_once(
                    Some(&inst.loc),
                    "a moving object instance whose transformation is projective (Perspective) is placed at shutter open (no motion blur)".to_string(),
                );
                motion = None;
            }
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
            // A projective placement does not preserve a ray's parameter: the definition's
            // shapes are placed through it (tessellated) into a render-space BLAS of their own.
            let (blas_index, render_from_blas, projected) = if is_projective(&render_from_blas) {
                let mut builder = BlasBuilder::new();
                let mut placed = Vec::new();
                for entity in &def.shapes {
                    let render_from_object = render_from_blas * entity.world_from_object;
                    let Some(g) = geometry(entity, &render_from_object, None, diagnostics) else { continue };
                    if add_to_blas(&mut builder, &g, &render_from_object, entity, scene, diagnostics)
                        .is_some()
                    {
                        let reverse = scene.attributes_of(entity.attributes).reverse_orientation;
                        placed.push((g, render_from_object, reverse));
                    }
                }
                let blas = builder.finish();
                if blas.prims.is_empty() {
                    continue;
                }
                blases.push(blas);
                (blases.len() as u32 - 1, DMat4::IDENTITY, Some(placed))
            } else {
                (blas_index, render_from_blas, None)
            };
            let placed = match &projected {
                Some(placed) => Some(placed),
                None => definition_geometry.get(&object),
            };
            let mut inst_emitters = Vec::new();
            if let Some(id) = attrs.area_light {
                for (g, def_from_object, reverse) in placed.into_iter().flatten() {
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
        let camera_motion = camera_shutter_motion(scene, &render_from_world);
        let motion_blur = camera_motion.is_some()
            || instances.iter().any(|i| i.motion.is_some() || blases[i.blas as usize].deforming.is_some());
        let (tlas, instances) = if instances.is_empty() || (instances.len() == 1 && instances[0].identity) {
            (None, instances)
        } else {
            let tlas = Bvh::build(&instance_boxes);
            let ordered = tlas.order().iter().map(|&i| instances[i as usize].clone()).collect();
            (Some(tlas), ordered)
        };

        // Light sets, one per distinct list of illuminating lights. Area lights illuminate
        // every surface (they are physical emitters, found by BSDF sampling too); the
        // attribute's light list links the other lights, environment lights included.
        let scene_radius = {
            let ext = (bounds.1 - bounds.0).max(Vec3::ZERO);
            if ext.is_finite() { (ext.length() * 0.5).max(f32::MIN_POSITIVE) } else { 1.0 }
        };
        let area_members: Vec<u32> =
            (0..lights.len() as u32).filter(|&i| matches!(lights[i as usize], Light::Area { .. })).collect();
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

        let mut world = World {
            render_from_world,
            blases,
            instances,
            tlas,
            materials,
            environment_lights: (0..lights.len() as u32)
                .filter(|&i| matches!(lights[i as usize], Light::Environment(_)))
                .collect(),
            lights,
            light_sources,
            light_sets,
            attributes_light_set,
            bounds,
            stats,
            motion_blur,
            camera_motion,
            clipping_planes: render_clipping_planes(scene, &render_from_world),
            background: background(scene),
            footprint,
            x86_64_v3: crate::accel::X86_64V3::detect(),
            flat: false,
            flat_sides: Vec::new(),
            flat_surfaces: Vec::new(),
        };
        world.flat = world.is_flat();
        // The x86-64-v3 queries test triangles stored as rows (`shapes/triangle_rows.rs`). A
        // deforming shape's vertices move, and its queries test them where they are.
        if world.x86_64_v3.is_some() {
            for blas in world.blases.iter_mut().filter(|b| b.deforming.is_none()) {
                blas.rows = blas.triangles.iter().map(|t| crate::shapes::TriangleRows::new(t.p)).collect();
                world.stats.bvh_bytes += blas.rows.len() * std::mem::size_of::<crate::shapes::TriangleRows>();
            }
        }
        if world.flat {
            world.set_flat_tables();
        }
        Ok(world)
    }

    /// A flat world's per-triangle tables, [`World::flat_surfaces`] and [`World::flat_sides`],
    /// from its one BLAS's triangles.
    pub(super) fn set_flat_tables(&mut self) {
        let (inst, blas) = (&self.instances[0], &self.blases[self.instances[0].blas as usize]);
        let triangles = &blas.triangles;
        self.flat_surfaces = triangles
            .iter()
            .map(|t| FlatSurface {
                ng_unit: super::interaction::triangle_unit_normal(t.p),
                attributes: inst.attributes.unwrap_or(blas.shapes[t.shape as usize].attributes),
                emitter: inst.emitters.get(t.shape as usize).copied().unwrap_or(u32::MAX),
            })
            .collect();
        self.flat_sides = triangles
            .iter()
            .zip(&self.flat_surfaces)
            .map(|(t, &FlatSurface { ng_unit: n, .. })| {
                let (one_sided, reversed) = self.sidedness(inst, blas, t.shape);
                let degenerate = n == Vec3::ZERO || !n.is_finite();
                let s = &blas.shapes[t.shape as usize];
                let normals = s.mesh.is_some_and(|m| blas.meshes[m as usize].normals.is_some());
                let st = self.material(inst.attributes.unwrap_or(s.attributes)).reads_texture_coordinates();
                (if one_sided { super::ONE_SIDED } else { 0 })
                    | (if reversed { super::REVERSED } else { 0 })
                    | (if degenerate { super::DEGENERATE } else { 0 })
                    | (if normals { super::SHADING_NORMALS } else { 0 })
                    | (if st { super::TEXTURE_COORDINATES } else { 0 })
            })
            .collect();
    }
}

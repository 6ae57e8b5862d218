//! Displaced shapes: a shape whose attributes name one of RenderMan's standard displacement
//! shaders (`dented`, `bumpy`) becomes a displaced triangle mesh from
//! `tessellate::tessellate_displaced` (quadrics included), diced to micropolygons of the
//! shading rate's area at the camera's pixel size where they are. See docs/tessellation.md.

use super::placement::{Geometry, PixelFootprint, tolerance_for};
use crate::diagnostics::Diagnostics;
use glam::{DMat3, DMat4, DVec3, Vec2};
use rib_parser::scene::{Attributes, Scene, ShapeEntity};
use tessellate::{
    DicingRule, Displaced, DisplacementShader, DisplacementTextures, SCENE_DICING, displacement_bound,
    is_surface, shape_kind, tessellate_displaced,
};

/// Most triangles one displaced shape may be diced into (within the world's own budget); the
/// dicing is coarsened, with a warning, beyond it.
pub const MAX_DISPLACED_TRIANGLES: u64 = 4_000_000;

/// The displacement shader a shape is drawn with: `None` without one, for `null` and other
/// shaders that move nothing, and for custom shaders (warned about once per attribute state
/// when materials are built).
pub(super) fn displacement_of(scene: &Scene, entity: &ShapeEntity) -> Option<DisplacementShader> {
    let attrs = scene.attributes_of(entity.attributes);
    DisplacementShader::from_attributes(attrs).ok().flatten().filter(|s| !s.is_identity())
}

/// The warning for an attribute state's displacement shader that is not run, if any.
pub(super) fn custom_shader_warning(attrs: &Attributes) -> Option<String> {
    DisplacementShader::from_attributes(attrs).err().map(|name| {
        format!(
            "displacement shader \"{name}\" is a custom shader (RenderMan Shading Language), which is not run: \
             surfaces are not displaced"
        )
    })
}

/// The micropolygon size for a shape placed in render space (`footprint` known) or in a space
/// of its own (object definitions, moving shapes: relative to the shape's size).
fn dicing_rule(footprint: Option<&PixelFootprint>, shading_rate: f32) -> DicingRule {
    let shading_rate = f64::from(shading_rate);
    match footprint {
        Some(PixelFootprint::Perspective { radians_per_pixel }) => {
            DicingRule::Perspective { eye: DVec3::ZERO, radians_per_pixel: *radians_per_pixel, shading_rate }
        }
        Some(PixelFootprint::Orthographic { size, .. }) => {
            DicingRule::Orthographic { pixel: *size, shading_rate }
        }
        Some(PixelFootprint::Unknown) | None => SCENE_DICING,
    }
}

/// The displaced mesh of `entity` placed with `blas_from_object` (`world_from_blas` maps its
/// space to the world, for the shader space), at most `budget` triangles. Warnings (coarsened
/// dicing, unreadable textures, a displacement beyond its `displacementbound`) go to
/// `diagnostics`.
#[allow(clippy::too_many_arguments)]
pub(super) fn displaced_geometry(
    scene: &Scene,
    entity: &ShapeEntity,
    shader: &DisplacementShader,
    blas_from_object: &DMat4,
    world_from_blas: &DMat4,
    footprint: Option<&PixelFootprint>,
    textures: &DisplacementTextures<'_>,
    budget: u64,
    diagnostics: &mut Diagnostics,
) -> Result<Geometry, String> {
    let attrs = scene.attributes_of(entity.attributes);
    let kind = shape_kind(&entity.shape);
    let name = attrs.displacement.as_ref().map_or("", |d| d.name.as_str());
    let loc = attrs.displacement.as_ref().map(|d| &d.loc);
    if !is_surface(&entity.shape) {
        diagnostics
            .warn_once(loc, format!("Displacement \"{name}\" does not apply to {kind}: drawn undisplaced"));
        return super::placement::place_geometry(&entity.shape, blas_from_object, footprint);
    }
    let tolerance = tolerance_for(&entity.shape, blas_from_object, footprint)
        .with_max_triangles(budget.min(MAX_DISPLACED_TRIANGLES));
    let lookup = |name: &str, st: Vec2| textures.value(name, st);
    let displaced = Displaced {
        shader,
        world_from_placed: *world_from_blas,
        texture: &lookup,
        dicing: dicing_rule(footprint, attrs.shading_rate),
    };
    let reverse = attrs.reverse_orientation;
    let out = tessellate_displaced(&entity.shape, blas_from_object, reverse, &tolerance, &displaced)
        .map_err(|e| e.to_string())?;
    report(
        scene,
        entity,
        out.dicing.coarsened_by,
        tolerance.max_triangles,
        &out.unreadable_textures,
        diagnostics,
    );
    if let Some(bound) = displacement_bound(attrs) {
        let bound = bound_in_render_units(bound, attrs, blas_from_object);
        if out.largest_displacement > bound * (1.0 + 1e-6) {
            diagnostics.warn_once(
                loc,
                format!(
                    "Displacement \"{name}\" moves {kind} by up to {:.4}, beyond its displacementbound of {bound:.4}: \
                     drawn in full (PRMan would show clipping or missing pieces where the surface leaves its bound; \
                     a ray tracer needs no bound)",
                    out.largest_displacement
                ),
            );
        }
    }
    let mut mesh = out.mesh;
    if mesh.is_empty() {
        return Err("it has no area".into());
    }
    // The world's meshes are wound by the unflipped normal; the BLAS shape applies the
    // orientation (the displacement itself went along RenderMan's normal, which it flips).
    if reverse {
        for t in &mut mesh.indices {
            t.swap(1, 2);
        }
        for n in mesh.normals.iter_mut().flatten() {
            *n = -*n;
        }
    }
    Ok(Geometry::Mesh(mesh))
}

/// The keys of a deforming shape (the same triangles at every key, placed by
/// `blas_from_object`) displaced alike by `tessellate::displace_keys`, at most `budget`
/// triangles per key; warnings as for [`displaced_geometry`].
#[allow(clippy::too_many_arguments)]
pub(super) fn displaced_keys(
    scene: &Scene,
    entity: &ShapeEntity,
    shader: &DisplacementShader,
    keys: &[tessellate::TriangleMesh],
    world_from_blas: &DMat4,
    footprint: Option<&PixelFootprint>,
    textures: &DisplacementTextures<'_>,
    budget: u64,
    diagnostics: &mut Diagnostics,
) -> Result<Vec<tessellate::TriangleMesh>, String> {
    let attrs = scene.attributes_of(entity.attributes);
    let lookup = |name: &str, st: Vec2| textures.value(name, st);
    let displaced = Displaced {
        shader,
        world_from_placed: *world_from_blas,
        texture: &lookup,
        dicing: dicing_rule(footprint, attrs.shading_rate),
    };
    let max_triangles = budget.min(MAX_DISPLACED_TRIANGLES);
    let out = tessellate::displace_keys(keys, attrs.reverse_orientation, &displaced, max_triangles)
        .map_err(|e| e.to_string())?;
    report(scene, entity, out.dicing.coarsened_by, max_triangles, &out.unreadable_textures, diagnostics);
    Ok(out.meshes)
}

/// Warns about a coarsened dicing and unreadable textures.
fn report(
    scene: &Scene,
    entity: &ShapeEntity,
    coarsened_by: Option<f64>,
    max_triangles: u64,
    unreadable_textures: &[String],
    diagnostics: &mut Diagnostics,
) {
    let attrs = scene.attributes_of(entity.attributes);
    let kind = shape_kind(&entity.shape);
    let name = attrs.displacement.as_ref().map_or("", |d| d.name.as_str());
    let loc = attrs.displacement.as_ref().map(|d| &d.loc);
    if let Some(factor) = coarsened_by {
        diagnostics.warn_once(
            Some(&entity.loc),
            format!(
                "displaced {kind}: ShadingRate {} would need more than {max_triangles} triangles; diced {factor:.3}x \
                 coarser",
                attrs.shading_rate
            ),
        );
    }
    for texture in unreadable_textures {
        diagnostics.warn_once(
            loc,
            format!(
                "Displacement \"{name}\": texture \"{texture}\" cannot be read: it reads 0 (not displaced)"
            ),
        );
    }
}

/// `displacementbound`'s sphere in render units: its `"coordinatesystem"` ("object" by
/// default, scaled by the object transform's largest stretch; "world", "camera", "current" and
/// "shader"-less names as given).
fn bound_in_render_units(bound: f64, attrs: &Attributes, blas_from_object: &DMat4) -> f64 {
    let space = attrs
        .user
        .iter()
        .rev()
        .filter(|call| call.namespace == "displacementbound")
        .find_map(|call| call.params.string("coordinatesystem"))
        .unwrap_or("object");
    if space == "object" {
        let linear = DMat3::from_mat4(*blas_from_object);
        let stretch =
            [linear.x_axis, linear.y_axis, linear.z_axis].iter().map(|c| c.length()).fold(0.0, f64::max);
        bound * stretch
    } else {
        bound
    }
}

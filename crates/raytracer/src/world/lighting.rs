//! The world's lights: the scene's light sources in render space, the emitting shapes of area
//! lights, and the background colour.

use super::placement::Geometry;
use super::*;
use crate::diagnostics::Diagnostics;
use crate::environment_light::EnvironmentLight;
use crate::lights::{EmitterShape, RENDERMAN_LIGHT_SCALE, quadric_area};
use crate::sampling::Distribution1D;
use crate::texture::Texture;
use rib_parser::scene::{LightKind, Scene};
use std::collections::HashMap;

/// The world's lights converted from the scene's non-area light sources: the lights, the
/// scene light id of each, and the map from scene light id to light index. `load` reads the
/// texture an environment light names.
pub(super) fn scene_lights(
    scene: &Scene,
    render_from_world: &DMat4,
    load: &mut dyn FnMut(&str) -> Result<Arc<Texture>, String>,
    diagnostics: &mut Diagnostics,
) -> (Vec<Light>, Vec<u32>, HashMap<u32, u32>) {
    let mut lights: Vec<Light> = Vec::new();
    let mut light_sources: Vec<u32> = Vec::new();
    // Scene light id -> our light index, for non-area lights.
    let mut light_index: HashMap<u32, u32> = HashMap::new();
    for (i, l) in scene.lights.iter().enumerate() {
        let scale = RENDERMAN_LIGHT_SCALE;
        let to_render = |p: DVec3| render_from_world.transform_point3(p).as_vec3();
        let light = match &l.kind {
            LightKind::Ambient { intensity, color } => Some(Light::Ambient { color: *color * *intensity }),
            LightKind::Point { position, intensity, color } => {
                Some(Light::Point { position: to_render(*position), intensity: *color * *intensity * scale })
            }
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
            LightKind::Other if rib_parser::builder::environment_light(&l.shader).is_some() => {
                environment_light(l, render_from_world, load, diagnostics)
            }
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
                Light::Distant { direction, irradiance } => direction.is_finite() && irradiance.is_finite(),
                Light::Ambient { color } => color.is_finite(),
                Light::Area { .. } | Light::Environment(_) => true,
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

    (lights, light_sources, light_index)
}

/// An environment light (`rib_parser::builder::ENVIRONMENT_LIGHTS`) with its map, oriented by
/// the light's transformation; `None`, with a warning, when its map cannot be read or its
/// values are not finite.
fn environment_light(
    light: &rib_parser::scene::Light,
    render_from_world: &DMat4,
    load: &mut dyn FnMut(&str) -> Result<Arc<Texture>, String>,
    diagnostics: &mut Diagnostics,
) -> Option<Light> {
    let params = rib_parser::builder::environment_light(&light.shader)?;
    let loc = Some(&light.shader.loc);
    let name = &light.shader.name;
    let map = match &params.map {
        Some(map) => {
            match load(map) {
                Ok(texture) => Some(texture),
                Err(reason) => {
                    diagnostics.warn_once(
                    loc,
                    format!("light \"{name}\": environment map \"{map}\" cannot be read ({reason}): light skipped"),
                );
                    diagnostics.skip("light sources (unreadable environment map)");
                    return None;
                }
            }
        }
        None => None,
    };
    // RenderMan's "blur": the map seen through a box filter that wide (a light without a map
    // is constant and has nothing to blur).
    let map = match (map, params.blur) {
        (map, 0.0) => map,
        (Some(map), blur) => match map.blurred_lat_long(blur) {
            Some(blurred) => Some(Arc::new(blurred)),
            None => {
                diagnostics.warn_once(
                    loc,
                    format!("light \"{name}\": \"blur\" {blur} is not a finite width >= 0: the map is read unblurred"),
                );
                Some(map)
            }
        },
        (None, _) => None,
    };
    let render_from_light = glam::DMat3::from_mat4(*render_from_world * light.world_from_light);
    match EnvironmentLight::new(params.color * params.intensity, map, render_from_light) {
        Some(env) => Some(Light::Environment(Arc::new(env))),
        None => {
            diagnostics.warn_once(
                loc,
                format!("light \"{name}\": non-finite radiance or a singular orientation: light skipped"),
            );
            None
        }
    }
}

/// Emission parameters of an area light: radiance and two-sidedness.
pub(super) fn area_light_params(scene: &Scene, light: u32) -> Option<(Vec3, bool)> {
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

/// The colour of `Imager "background"` (black without one, or for other imagers, which are
/// shader programs). Non-finite or negative components are taken as 0.
pub(super) fn background(scene: &Scene) -> Vec3 {
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
pub(super) fn emitter_shape(
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

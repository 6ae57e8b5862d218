//! Light requests: `LightSource`, `AreaLightSource` and `Illuminate`, and the standard light
//! shaders resolved to world-space [`LightKind`]s.

use super::{PendingLight, SceneBuilder, WorldState};
use crate::diagnostics::DiagnosticKind;
use crate::scene::*;
use crate::target::Cx;
use glam::{DMat4, DVec3, Vec3};

/// Places a light with `world_from_light`, resolving its standard parameters to world space.
pub(crate) fn place_light(light: &mut Light, world_from_light: DMat4) {
    light.world_from_light = world_from_light;
    light.kind = resolve_kind(&light.shader, world_from_light, matches!(light.kind, LightKind::Area { .. }));
}

fn param_point(params: &ParamList, name: &str, default: DVec3) -> DVec3 {
    params.vec3(name).map_or(default, |v| v.as_dvec3())
}

/// The light shaders of the Pixar and Aqsis standard libraries that are a standard light plus
/// shadow maps, with the standard light they are when shadows are ray traced exactly.
pub(crate) const SHADOW_MAP_LIGHTS: &[(&str, &str)] =
    &[("shadowspot", "spotlight"), ("shadowpoint", "pointlight"), ("shadowdistant", "distantlight")];

/// Their parameters that only steer the shadow map lookup.
const SHADOW_MAP_PARAMS: &[&str] =
    &["shadowname", "blur", "bias", "samples", "width", "sfpx", "sfnx", "sfpy", "sfny", "sfpz", "sfnz"];

/// Light shaders that light the scene from an environment at infinity: PRMan-style
/// environment lights and pbrt's `infinite` light.
pub const ENVIRONMENT_LIGHTS: &[&str] = &["envlight", "environmentlight", "infinite"];

/// The parameters that may name an environment light's lat-long map, in the order tried:
/// PRMan-style `envmap`/`envname`/`mapname`/`texturename`, pbrt-v3's `mapname`, pbrt-v4's
/// `filename`.
pub const ENVIRONMENT_MAP_PARAMS: &[&str] =
    &["envmap", "envname", "environmentmap", "mapname", "texturename", "filename"];

/// An environment light: radiance `intensity * color * map(direction)`, or a constant
/// `intensity * color` from every direction without a map. The map is lat-long in the light's
/// space (+z up, `s = atan2(y, x) / 2 pi`, `t = acos(z) / pi`).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentLight {
    /// The map's name as given (a `MakeLatLongEnvironment` name or a picture file).
    pub map: Option<String>,
    /// `intensity` times pbrt's `scale`.
    pub intensity: f32,
    /// `lightcolor` times pbrt's `L`.
    pub color: Vec3,
    /// `blur`: the width of a box filter over the map, in texture coordinates (a fraction of
    /// the map's width in `s` and of its height in `t`), as RenderMan's `environment()` takes
    /// it; 0 without one.
    pub blur: f32,
}

/// The environment light `call` describes, when its shader is one of [`ENVIRONMENT_LIGHTS`].
/// An empty map name means no map.
pub fn environment_light(call: &ShaderCall) -> Option<EnvironmentLight> {
    if !ENVIRONMENT_LIGHTS.contains(&call.name.as_str()) {
        return None;
    }
    let p = &call.params;
    let map =
        ENVIRONMENT_MAP_PARAMS.iter().find_map(|n| p.string(n)).filter(|m| !m.is_empty()).map(str::to_string);
    let intensity = p.float("intensity").unwrap_or(1.0) * p.float("scale").unwrap_or(1.0);
    let color = p.vec3("lightcolor").unwrap_or(Vec3::ONE) * p.vec3("L").unwrap_or(Vec3::ONE);
    let blur = p.float("blur").unwrap_or(0.0);
    Some(EnvironmentLight { map, intensity, color, blur })
}

/// The standard light a shader name stands for (itself, or the one a shadow-map light extends).
pub(crate) fn standard_light(name: &str) -> &str {
    SHADOW_MAP_LIGHTS.iter().find(|(shadowed, _)| *shadowed == name).map_or(name, |(_, standard)| standard)
}

/// The standard light shaders with RenderMan's defaults.
fn resolve_kind(call: &ShaderCall, world_from_light: DMat4, area: bool) -> LightKind {
    let p = &call.params;
    let intensity = p.float("intensity").unwrap_or(1.0);
    let color = p.vec3("lightcolor").unwrap_or(Vec3::ONE);
    let from = world_from_light.project_point3(param_point(p, "from", DVec3::ZERO));
    let to = world_from_light.project_point3(param_point(p, "to", DVec3::Z));
    let direction = (to - from).normalize_or_zero();
    if area {
        return match call.name.as_str() {
            "arealight" => LightKind::Area { intensity, color },
            _ => LightKind::Other,
        };
    }
    match standard_light(&call.name) {
        "ambientlight" => LightKind::Ambient { intensity, color },
        "distantlight" => LightKind::Distant { direction, intensity, color },
        "pointlight" => LightKind::Point { position: from, intensity, color },
        "spotlight" => LightKind::Spot {
            position: from,
            direction,
            intensity,
            color,
            cone_angle: p.float("coneangle").unwrap_or(30f32.to_radians()),
            cone_delta_angle: p.float("conedeltaangle").unwrap_or(5f32.to_radians()),
            beam_distribution: p.float("beamdistribution").unwrap_or(2.0),
        },
        _ => LightKind::Other,
    }
}

impl SceneBuilder {
    pub(super) fn add_light(&mut self, call: ShaderCall, handle: Handle, area: bool, cx: &mut Cx<'_>) {
        let request = if area { "AreaLightSource" } else { "LightSource" };
        if self.skip_motion_sample() {
            return;
        }
        if self.recording.is_some() {
            cx.error(
                DiagnosticKind::Nesting,
                format!("{request} inside ObjectBegin/ObjectEnd is not allowed; ignored"),
            );
            return;
        }
        if let Some(bad) = ["intensity", "coneangle", "conedeltaangle", "beamdistribution"]
            .into_iter()
            .find(|n| call.params.float(n).is_some_and(|v| !v.is_finite()))
        {
            cx.error(
                DiagnosticKind::BadValue,
                format!("{request} \"{}\": \"{bad}\" is not finite", call.name),
            );
            return;
        }
        if !area && matches!(standard_light(&call.name), "distantlight" | "spotlight") {
            let from = call.params.vec3("from").unwrap_or(Vec3::ZERO);
            let to = call.params.vec3("to").unwrap_or(Vec3::Z);
            if from == to {
                cx.error(
                    DiagnosticKind::BadValue,
                    format!("{request} \"{}\": \"from\" and \"to\" are the same point", call.name),
                );
                return;
            }
        }
        if !area && standard_light(&call.name) != call.name {
            if let Some(ignored) = SHADOW_MAP_PARAMS.iter().find(|n| call.params.get(n).is_some()) {
                self.warn_once(
                    "shadow-map-params",
                    cx,
                    DiagnosticKind::Unsupported,
                    format!(
                        "light \"{}\": shadows are ray traced exactly, so its shadow-map parameters (\"{ignored}\" and the like: shadowname, blur, bias, samples, width) are ignored",
                        call.name
                    ),
                );
            }
        } else if !area
            && !matches!(call.name.as_str(), "ambientlight" | "distantlight" | "pointlight" | "spotlight")
            && !ENVIRONMENT_LIGHTS.contains(&call.name.as_str())
        {
            cx.warn(
                DiagnosticKind::Unsupported,
                format!(
                    "light shader \"{}\" is not a standard light; kept, but consumers may skip it",
                    call.name
                ),
            );
        }
        let ctm = self.gs.ctm;
        let placeholder =
            if area { LightKind::Area { intensity: 0.0, color: Vec3::ZERO } } else { LightKind::Other };
        let mut light =
            Light { handle: handle.clone(), shader: call, kind: placeholder, world_from_light: ctm };
        let id = if let Some(world) = self.world.as_mut() {
            place_light(&mut light, ctm);
            push_light(world, light)
        } else {
            // Before WorldBegin the current transformation is camera-relative: placed at
            // WorldBegin once the camera is known.
            let id = LightId(self.pre_world_lights.len() as u32);
            self.pre_world_lights.push(light);
            self.pre_world_handles.insert(handle.clone(), id);
            self.pending_lights.push(PendingLight { light: id, camera_from_light: ctm });
            id
        };
        let attrs = &mut self.gs.attrs;
        if let Err(pos) = attrs.attrs.illuminated_by.binary_search(&id) {
            attrs.attrs.illuminated_by.insert(pos, id);
        }
        if area {
            attrs.attrs.area_light = Some(id);
        }
        attrs.id = None;
    }

    pub(super) fn illuminate_light(&mut self, handle: Handle, on: bool, cx: &mut Cx<'_>) {
        let id = match &self.world {
            Some(w) => w.light_handles.get(&handle).copied(),
            None => self.pre_world_handles.get(&handle).copied(),
        };
        let Some(id) = id else {
            let h = match &handle {
                Handle::Int(i) => i.to_string(),
                Handle::Name(n) => format!("\"{n}\""),
            };
            cx.warn(DiagnosticKind::UnknownHandle, format!("Illuminate: no light with handle {h}; ignored"));
            return;
        };
        let list = &mut self.gs.attrs.attrs.illuminated_by;
        match (list.binary_search(&id), on) {
            (Err(pos), true) => list.insert(pos, id),
            (Ok(pos), false) => {
                list.remove(pos);
            }
            _ => return,
        }
        self.gs.attrs.id = None;
    }
}

fn push_light(world: &mut WorldState, light: Light) -> LightId {
    let id = LightId(world.lights.len() as u32);
    world.light_handles.insert(light.handle.clone(), id);
    world.lights.push(light);
    id
}

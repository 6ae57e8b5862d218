//! Attribute requests and lights.

use super::{SceneBuilder, WorldState};
use crate::basis::bezier_basis;
use crate::diagnostics::DiagnosticKind;
use crate::scene::*;
use crate::target::{Cx, ShaderSlot};
use glam::{DMat4, DVec3, Vec3};
use std::sync::Arc;

/// The attribute part of the graphics state: the scene-facing [`Attributes`] plus what only
/// shapes need at creation (bases, trim curves), and the interned id of the current state.
#[derive(Clone, Debug)]
pub(crate) struct AttrState {
    pub attrs: Attributes,
    /// Id of `attrs` in the world's attribute table while it is unchanged.
    pub id: Option<AttributesId>,
    pub u_basis: Basis,
    pub v_basis: Basis,
    pub trim: Option<Arc<TrimCurves>>,
}

impl Default for AttrState {
    fn default() -> Self {
        AttrState {
            attrs: Attributes::default(),
            id: None,
            u_basis: bezier_basis(),
            v_basis: bezier_basis(),
            trim: None,
        }
    }
}

/// `Orientation` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Orient {
    Outside,
    Inside,
    LeftHanded,
    RightHanded,
}

/// A request that changes [`Attributes`]. Object definitions record these to replay them on
/// every instance.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum AttrOp {
    Color(Vec3),
    Opacity(Vec3),
    Shader(ShaderSlot, ShaderCall),
    ShadingRate(f32),
    Matte(bool),
    Orientation(Orient),
    ReverseOrientation,
    Sides(u8),
    Attribute(AttributeCall),
}

/// Applies `op` to `a`. `coordsys_left_handed` is the handedness of the current coordinate
/// system (needed by `Orientation "lh"`/`"rh"`).
pub(crate) fn apply(a: &mut Attributes, op: &AttrOp, coordsys_left_handed: bool) {
    match op {
        AttrOp::Color(c) => a.color = *c,
        AttrOp::Opacity(c) => a.opacity = *c,
        AttrOp::Shader(slot, call) => {
            let slot_ref = match slot {
                ShaderSlot::Surface => &mut a.surface,
                ShaderSlot::Displacement => &mut a.displacement,
                ShaderSlot::Atmosphere => &mut a.atmosphere,
                ShaderSlot::Interior => &mut a.interior,
                ShaderSlot::Exterior => &mut a.exterior,
                ShaderSlot::Deformation => return,
            };
            *slot_ref = Some(call.clone());
        }
        AttrOp::ShadingRate(r) => a.shading_rate = *r,
        AttrOp::Matte(m) => a.matte = *m,
        AttrOp::Orientation(o) => {
            a.reverse_orientation = match o {
                Orient::Outside => false,
                Orient::Inside => true,
                Orient::LeftHanded => !coordsys_left_handed,
                Orient::RightHanded => coordsys_left_handed,
            }
        }
        AttrOp::ReverseOrientation => a.reverse_orientation = !a.reverse_orientation,
        AttrOp::Sides(s) => a.sides = *s,
        AttrOp::Attribute(call) => {
            if call.namespace == "identifier"
                && let Some(name) = call.params.string("name")
            {
                a.name = Some(name.to_string());
            }
            if call.namespace == "haptic" {
                let h = &mut a.haptic;
                let get = |n: &str| call.params.float(n).filter(|v| v.is_finite() && *v >= 0.0);
                if let Some(v) = get("stiffness") {
                    h.stiffness = Some(v);
                }
                if let Some(v) = get("friction") {
                    h.friction = Some(v);
                }
                if let Some(v) = get("staticfriction") {
                    h.static_friction = Some(v);
                }
                if let Some(v) = get("dynamicfriction") {
                    h.dynamic_friction = Some(v);
                }
            }
            // An attribute set again replaces its earlier value: keep only what is in effect.
            for earlier in a.user.iter_mut().filter(|c| c.namespace == call.namespace) {
                earlier.params.0.retain(|p| call.params.get(&p.name).is_none());
            }
            a.user.retain(|c| !c.params.0.is_empty());
            a.user.push(call.clone());
        }
    }
}

/// Reports `Attribute "haptic"` parameters that are unknown or out of range.
pub(crate) fn check_haptic(params: &ParamList, cx: &mut Cx<'_>) {
    for p in &params.0 {
        match p.name.as_str() {
            "stiffness" | "friction" | "staticfriction" | "dynamicfriction" => match &p.values {
                ParamValues::Floats(v) if v.len() == 1 && v[0].is_finite() && v[0] >= 0.0 => {}
                _ => cx.error_at(
                    &p.loc,
                    DiagnosticKind::ParameterValues,
                    format!("Attribute \"haptic\" \"{}\" needs one finite non-negative float", p.name),
                ),
            },
            other => cx.diagnostics.warn(
                DiagnosticKind::UndeclaredParameter,
                &p.loc,
                format!(
                    "Attribute \"haptic\" \"{other}\" is not a haptic material parameter (stiffness, friction, staticfriction, dynamicfriction); kept but unused"
                ),
            ),
        }
    }
}

/// The id of `state`'s attributes in `table`, appending them when they changed since the last
/// time.
pub(crate) fn intern(state: &mut AttrState, table: &mut Vec<Attributes>) -> AttributesId {
    if let Some(id) = state.id
        && (id.0 as usize) < table.len()
    {
        return id;
    }
    let id = AttributesId(table.len() as u32);
    table.push(state.attrs.clone());
    state.id = Some(id);
    id
}

/// Places a light with `world_from_light`, resolving its standard parameters to world space.
pub(crate) fn place_light(light: &mut Light, world_from_light: DMat4) {
    light.world_from_light = world_from_light;
    light.kind = resolve_kind(&light.shader, world_from_light, matches!(light.kind, LightKind::Area { .. }));
}

fn param_point(params: &ParamList, name: &str, default: DVec3) -> DVec3 {
    params.vec3(name).map_or(default, |v| v.as_dvec3())
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
    match call.name.as_str() {
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
    /// Applies an attribute request to the current state (and records it in the object being
    /// defined).
    pub(super) fn set_attr(&mut self, op: AttrOp, _cx: &mut Cx<'_>) {
        if self.skip_motion_sample() {
            return;
        }
        let lh = self.coordsys_left_handed();
        if let Some(def) = &mut self.recording {
            def.record(op.clone(), self.gs.ctm.determinant() < 0.0);
        }
        apply(&mut self.gs.attrs.attrs, &op, lh);
        self.gs.attrs.id = None;
    }

    /// A `Color`/`Opacity` value as RGB (converting `ColorSamples` colours).
    pub(super) fn rgb_of(&self, values: &[f32], request: &str, cx: &mut Cx<'_>) -> Option<Vec3> {
        if values.iter().any(|v| !v.is_finite()) {
            cx.error(DiagnosticKind::BadValue, format!("{request}: values must be finite"));
            return None;
        }
        match &self.opts.color_to_rgb {
            None if values.len() == 3 => Some(Vec3::new(values[0], values[1], values[2])),
            Some(m) if m.len() == values.len() * 3 => {
                let mut rgb = Vec3::ZERO;
                for (i, &v) in values.iter().enumerate() {
                    rgb += v * Vec3::new(m[3 * i], m[3 * i + 1], m[3 * i + 2]);
                }
                Some(rgb)
            }
            _ => {
                cx.error(
                    DiagnosticKind::BadArguments,
                    format!("{request}: {} values do not match the colour samples", values.len()),
                );
                None
            }
        }
    }

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
        if !area && matches!(call.name.as_str(), "distantlight" | "spotlight") {
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
        if !area
            && !matches!(call.name.as_str(), "ambientlight" | "distantlight" | "pointlight" | "spotlight")
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
            self.pending_lights.push(super::PendingLight { light: id, camera_from_light: ctm });
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

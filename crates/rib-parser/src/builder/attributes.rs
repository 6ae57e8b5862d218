//! Attribute requests (`Color`, `Opacity`, shaders, `ShadingRate`, `Matte`, `Orientation`,
//! `ReverseOrientation`, `Sides`, `Attribute`, `Basis`, `TrimCurve`) and the attribute state.

use super::SceneBuilder;
use crate::basis::bezier_basis;
use crate::diagnostics::DiagnosticKind;
use crate::scene::*;
use crate::target::{Cx, ShaderSlot};
use glam::{DMat4, Vec3};
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
    /// The transformation current at a `Displacement` request (its shader space).
    DisplacementSpace(DMat4),
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
        AttrOp::DisplacementSpace(m) => a.displacement_space = *m,
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
}

impl SceneBuilder {
    pub(super) fn color(&mut self, color: &[f32], cx: &mut Cx<'_>) {
        if let Some(c) = self.rgb_of(color, "Color", cx) {
            self.set_attr(AttrOp::Color(c), cx);
        }
    }

    pub(super) fn opacity(&mut self, opacity: &[f32], cx: &mut Cx<'_>) {
        if let Some(c) = self.rgb_of(opacity, "Opacity", cx) {
            self.set_attr(AttrOp::Opacity(c), cx);
        }
    }

    pub(super) fn shader(&mut self, slot: ShaderSlot, call: ShaderCall, cx: &mut Cx<'_>) {
        match slot {
            ShaderSlot::Displacement => {
                if !STANDARD_DISPLACEMENT_SHADERS.contains(&call.name.as_str()) {
                    self.warn_once(
                        "displacement",
                        cx,
                        DiagnosticKind::Unsupported,
                        format!(
                            "Displacement \"{}\" is a custom shader (RenderMan Shading Language), which is \
                             not run: surfaces are not displaced",
                            call.name
                        ),
                    );
                }
                self.set_attr(AttrOp::DisplacementSpace(self.gs.ctm), cx);
            }
            ShaderSlot::Deformation => {
                cx.warn(
                    DiagnosticKind::Unsupported,
                    format!("Deformation \"{}\" is not supported; ignored", call.name),
                );
                return;
            }
            _ => {}
        }
        self.set_attr(AttrOp::Shader(slot, call), cx);
    }

    pub(super) fn shading_rate(&mut self, rate: f32, cx: &mut Cx<'_>) {
        if !(rate.is_finite() && rate > 0.0) {
            cx.error(DiagnosticKind::BadValue, format!("ShadingRate must be positive, got {rate}"));
            return;
        }
        self.set_attr(AttrOp::ShadingRate(rate), cx);
    }

    pub(super) fn matte(&mut self, on: bool, cx: &mut Cx<'_>) {
        self.set_attr(AttrOp::Matte(on), cx);
    }

    pub(super) fn orientation(&mut self, orientation: &str, cx: &mut Cx<'_>) {
        let op = match orientation {
            "outside" => Orient::Outside,
            "inside" => Orient::Inside,
            "lh" => Orient::LeftHanded,
            "rh" => Orient::RightHanded,
            other => {
                cx.error(
                    DiagnosticKind::BadValue,
                    format!("Orientation \"{other}\": expected outside, inside, lh or rh"),
                );
                return;
            }
        };
        self.set_attr(AttrOp::Orientation(op), cx);
    }

    pub(super) fn reverse_orientation(&mut self, cx: &mut Cx<'_>) {
        self.set_attr(AttrOp::ReverseOrientation, cx);
    }

    pub(super) fn sides(&mut self, sides: i32, cx: &mut Cx<'_>) {
        if sides != 1 && sides != 2 {
            cx.error(DiagnosticKind::BadValue, format!("Sides must be 1 or 2, got {sides}"));
            return;
        }
        self.set_attr(AttrOp::Sides(sides as u8), cx);
    }

    pub(super) fn attribute(&mut self, namespace: &str, params: ParamList, cx: &mut Cx<'_>) {
        if namespace == "haptic" {
            check_haptic(&params, cx);
        }
        self.set_attr(
            AttrOp::Attribute(AttributeCall {
                namespace: namespace.to_string(),
                params,
                loc: cx.loc.clone(),
            }),
            cx,
        );
    }

    pub(super) fn basis(&mut self, u: Basis, v: Basis, _cx: &mut Cx<'_>) {
        self.gs.attrs.u_basis = u;
        self.gs.attrs.v_basis = v;
    }

    pub(super) fn trim_curve(&mut self, trim: TrimCurves, _cx: &mut Cx<'_>) {
        self.gs.attrs.trim = Some(Arc::new(trim));
    }
}

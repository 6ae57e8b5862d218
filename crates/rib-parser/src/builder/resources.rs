//! What conditional expressions and resources read and write of the graphics state:
//! variables (`$Frame`, options, attributes) for `IfBegin`/`ElseIf`, and `Resource "name"
//! "attributes"` saving and restoring attributes and the transformation, scoped by
//! `ResourceBegin`/`ResourceEnd`.

use super::{GraphicsState, SceneBuilder};
use crate::conditional::Value;
use crate::diagnostics::DiagnosticKind;
use crate::scene::{ParamList, ParamValues};
use crate::target::Cx;

/// A graphics state saved by `Resource "name" "attributes" "string operation" "save"`.
#[derive(Clone, Debug)]
pub(super) struct SavedState {
    gs: GraphicsState,
    /// Which world (or none: `None`) the transformation belongs to: before `WorldBegin` it is
    /// camera-relative, inside it world-relative, so it only restores in the same place.
    world: Option<usize>,
}

/// Which parts of a saved graphics state a `Resource` restore brings back.
#[derive(Clone, Copy, Debug, Default)]
struct RestoredParts {
    shading: bool,
    geometry_modification: bool,
    geometry_definition: bool,
    hiding: bool,
    transform: bool,
    /// Every attribute, also those in no named subset (`Attribute` calls, names, haptic
    /// materials): only "all".
    all_attributes: bool,
}

impl RestoredParts {
    fn all() -> Self {
        RestoredParts {
            shading: true,
            geometry_modification: true,
            geometry_definition: true,
            hiding: true,
            transform: true,
            all_attributes: true,
        }
    }
}

/// A parameter's values as one expression value: a single number or string as itself, several
/// values as their text joined by blanks.
fn value_of(values: &ParamValues) -> Value {
    match values {
        ParamValues::Floats(v) if v.len() == 1 => Value::Number(f64::from(v[0])),
        ParamValues::Ints(v) if v.len() == 1 => Value::Number(f64::from(v[0])),
        ParamValues::Strings(v) if v.len() == 1 => Value::Str(v[0].clone()),
        ParamValues::Floats(v) => Value::Str(v.iter().map(f32::to_string).collect::<Vec<_>>().join(" ")),
        ParamValues::Ints(v) => Value::Str(v.iter().map(i32::to_string).collect::<Vec<_>>().join(" ")),
        ParamValues::Strings(v) => Value::Str(v.join(" ")),
    }
}

/// `name` (`ns:param`, or a bare `param` of any namespace) in calls given latest first.
fn find<'a>(mut calls: impl Iterator<Item = (&'a str, &'a ParamList)> + Clone, name: &str) -> Option<Value> {
    if let Some((namespace, param)) = name.split_once(':')
        && let Some(p) =
            calls.clone().find(|(ns, _)| *ns == namespace).and_then(|(_, params)| params.get(param))
    {
        return Some(value_of(&p.values));
    }
    calls.find_map(|(_, params)| params.get(name)).map(|p| value_of(&p.values))
}

impl SceneBuilder {
    /// See [`crate::target::RibTarget::variable`]: attributes are looked up before options.
    pub(super) fn variable(&self, name: &str) -> Option<Value> {
        if name == "Frame" {
            return self.current_frame.map(|f| Value::Number(f64::from(f)));
        }
        let (attributes, options, rest) = match name.split_once(':') {
            Some(("Option", rest)) => (false, true, rest),
            Some(("Attribute", rest)) => (true, false, rest),
            _ => (true, true, name),
        };
        let attribute_calls =
            self.gs.attrs.attrs.user.iter().rev().map(|c| (c.namespace.as_str(), &c.params));
        let option_calls = self.opts.options.iter().rev().map(|c| (c.namespace.as_str(), &c.params));
        attributes
            .then(|| find(attribute_calls, rest))
            .flatten()
            .or_else(|| options.then(|| find(option_calls, rest)).flatten())
    }

    fn current_world(&self) -> Option<usize> {
        self.in_world().then_some(self.worlds_seen)
    }

    pub(super) fn resource(&mut self, handle: &str, kind: &str, params: ParamList, cx: &mut Cx<'_>) {
        if kind != "attributes" {
            cx.warn(
                DiagnosticKind::Unsupported,
                format!(
                    "Resource \"{handle}\" \"{kind}\": only \"attributes\" resources are supported; ignored"
                ),
            );
            return;
        }
        let operation = params.string("operation").unwrap_or("");
        match operation {
            "save" => {
                let saved = SavedState { gs: self.gs.clone(), world: self.current_world() };
                if let Some(scope) = self.resources.last_mut() {
                    scope.insert(handle.to_string(), saved);
                }
            }
            // "load" is what ricpp's samples write for a restore (ricpp itself does nothing
            // with it); a RenderMan user means the same state back.
            "restore" | "load" => {
                self.restore_resource(handle, operation, params.string("subset").unwrap_or("all"), cx)
            }
            other => cx.warn(
                DiagnosticKind::BadValue,
                format!("Resource \"{handle}\" \"attributes\": \"operation\" must be \"save\", \"restore\" or \"load\", got \"{other}\"; ignored"),
            ),
        }
    }

    /// Restores parts of the saved state `handle`, as PRMan's `RiResource` names them:
    /// `subset` "all" (the default) restores every attribute and the transformation,
    /// "shading" the shaders, lights, colour, opacity and shading rate, "geometrymodification"
    /// the orientation and sides, "geometrydefinition" the bases and trim curves, "hiding" the
    /// matte flag, "transform" the transformation ("geometry", an older name, both geometry
    /// subsets). A comma-separated list restores each part named.
    fn restore_resource(&mut self, handle: &str, operation: &str, subset: &str, cx: &mut Cx<'_>) {
        let Some(saved) = self.resources.iter().rev().find_map(|scope| scope.get(handle)).cloned() else {
            cx.error(
                DiagnosticKind::UnknownHandle,
                format!(
                    "Resource \"{handle}\" \"attributes\" {operation}: no resource of that name was saved"
                ),
            );
            return;
        };
        if self.recording.is_some() {
            cx.warn(
                DiagnosticKind::Unsupported,
                "Resource restore inside ObjectBegin/ObjectEnd is not supported; ignored",
            );
            return;
        }
        let mut parts = RestoredParts::default();
        for part in subset.split(',').map(str::trim) {
            match part {
                "all" => parts = RestoredParts::all(),
                "transform" => parts.transform = true,
                "shading" => parts.shading = true,
                "geometrymodification" => parts.geometry_modification = true,
                "geometrydefinition" => parts.geometry_definition = true,
                "geometry" => (parts.geometry_modification, parts.geometry_definition) = (true, true),
                "hiding" => parts.hiding = true,
                other => {
                    cx.warn(
                        DiagnosticKind::BadValue,
                        format!("Resource \"{handle}\": unknown subset \"{other}\" (all, shading, geometrymodification, geometrydefinition, hiding or transform); ignored"),
                    );
                    return;
                }
            }
        }
        let (now, then) = (&mut self.gs.attrs, &saved.gs.attrs);
        if parts.all_attributes {
            *now = then.clone();
        } else {
            if parts.shading {
                let (a, b) = (&mut now.attrs, &then.attrs);
                (a.color, a.opacity, a.shading_rate) = (b.color, b.opacity, b.shading_rate);
                a.surface.clone_from(&b.surface);
                a.displacement.clone_from(&b.displacement);
                a.displacement_space = b.displacement_space;
                a.atmosphere.clone_from(&b.atmosphere);
                a.interior.clone_from(&b.interior);
                a.exterior.clone_from(&b.exterior);
                a.area_light = b.area_light;
                a.illuminated_by.clone_from(&b.illuminated_by);
            }
            if parts.geometry_modification {
                (now.attrs.reverse_orientation, now.attrs.sides) =
                    (then.attrs.reverse_orientation, then.attrs.sides);
            }
            if parts.geometry_definition {
                (now.u_basis, now.v_basis) = (then.u_basis, then.v_basis);
                now.trim.clone_from(&then.trim);
            }
            if parts.hiding {
                now.attrs.matte = then.attrs.matte;
            }
        }
        // The saved id may index another world's attribute table: intern again.
        now.id = None;
        if parts.transform {
            if saved.world == self.current_world() {
                self.gs.ctm = saved.gs.ctm;
                self.gs.motion = saved.gs.motion;
            } else {
                cx.warn(
                    DiagnosticKind::Nesting,
                    format!("Resource \"{handle}\" was saved in another world block (or outside one): its transformation is not restored"),
                );
            }
        }
    }

    pub(super) fn resource_begin(&mut self, _cx: &mut Cx<'_>) {
        self.resources.push(Default::default());
    }

    pub(super) fn resource_end(&mut self, cx: &mut Cx<'_>) {
        if self.resources.len() > 1 {
            self.resources.pop();
        } else {
            cx.error(DiagnosticKind::Nesting, "ResourceEnd without ResourceBegin");
        }
    }
}

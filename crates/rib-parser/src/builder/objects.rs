//! `ObjectBegin`/`ObjectEnd`/`ObjectInstance` (see the module documentation of
//! [`crate::builder`] for the semantics).

use super::attributes::{self, AttrOp};
use super::{BlockKind, SceneBuilder};
use crate::diagnostics::DiagnosticKind;
use crate::scene::*;
use crate::target::Cx;
use glam::DMat4;
use std::sync::Arc;

/// One step of a definition, replayed for every instance.
#[derive(Clone, Debug)]
enum DefStep {
    /// An attribute request; `flipped` is true when the definition's transformation had a
    /// negative determinant there (needed by `Orientation "lh"`/`"rh"`).
    Attr {
        op: AttrOp,
        flipped: bool,
    },
    Push,
    Pop,
    Shape(usize),
}

#[derive(Clone, Debug)]
struct DefShape {
    shape: Arc<Shape>,
    object_from_shape: DMat4,
    attrs: Attributes,
    in_solid: bool,
    loc: FileLoc,
}

/// An object definition, kept by the builder for the rest of the file.
#[derive(Clone, Debug)]
pub(crate) struct ObjectDef {
    handle: Handle,
    shapes: Vec<DefShape>,
    steps: Vec<DefStep>,
    loc: FileLoc,
}

impl ObjectDef {
    pub(super) fn add_shape(
        &mut self,
        shape: Arc<Shape>,
        object_from_shape: DMat4,
        attrs: Attributes,
        in_solid: bool,
        loc: FileLoc,
    ) {
        self.steps.push(DefStep::Shape(self.shapes.len()));
        self.shapes.push(DefShape { shape, object_from_shape, attrs, in_solid, loc });
    }

    pub(super) fn record(&mut self, op: AttrOp, flipped: bool) {
        self.steps.push(DefStep::Attr { op, flipped });
    }

    pub(super) fn push(&mut self) {
        self.steps.push(DefStep::Push);
    }

    pub(super) fn pop(&mut self) {
        self.steps.push(DefStep::Pop);
    }
}

impl SceneBuilder {
    pub(super) fn begin_object(&mut self, handle: Handle, cx: &mut Cx<'_>) {
        if self.recording.is_some() {
            cx.error(DiagnosticKind::Nesting, "ObjectBegin inside ObjectBegin/ObjectEnd");
            return;
        }
        self.push_block(BlockKind::Object, cx);
        // The definition's shapes are kept in the object's own space.
        self.gs.ctm = DMat4::IDENTITY;
        self.gs.motion = None;
        self.recording =
            Some(ObjectDef { handle, shapes: Vec::new(), steps: Vec::new(), loc: cx.loc.clone() });
    }

    pub(super) fn end_object(&mut self, cx: &mut Cx<'_>) {
        let Some(block) = self.pop_block(BlockKind::Object, "ObjectEnd", cx) else { return };
        self.restore(block);
        let Some(def) = self.recording.take() else { return };
        let index = self.defs.len();
        self.def_handles.insert(def.handle.clone(), index);
        self.defs.push(def);
    }

    pub(super) fn instance_object(&mut self, handle: Handle, cx: &mut Cx<'_>) {
        if self.skip_motion_sample() {
            return;
        }
        if self.recording.is_some() {
            cx.error(DiagnosticKind::Nesting, "ObjectInstance inside ObjectBegin/ObjectEnd is not supported");
            return;
        }
        let Some(&def_index) = self.def_handles.get(&handle) else {
            cx.error(
                DiagnosticKind::UnknownHandle,
                format!("ObjectInstance: no object with handle {}", handle_text(&handle)),
            );
            return;
        };
        if !self.in_world() {
            cx.error(DiagnosticKind::Nesting, "ObjectInstance outside WorldBegin/WorldEnd is ignored");
            return;
        }
        let world_from_instance = self.gs.ctm;
        let motion = self.gs.motion.clone();
        let instance_attrs = self.intern_attributes();
        let camera_from_instance_det = (self.camera_from_world * world_from_instance).determinant();
        let def = &self.defs[def_index];
        let Some(world) = self.world.as_mut() else { return };

        // Make the definition part of this world's scene (once).
        let object = match world.object_ids.get(&def_index) {
            Some(&id) => id,
            None => {
                let shapes = def
                    .shapes
                    .iter()
                    .map(|s| {
                        let mut state = super::AttrState { attrs: s.attrs.clone(), ..Default::default() };
                        ShapeEntity {
                            shape: s.shape.clone(),
                            world_from_object: s.object_from_shape,
                            motion: None,
                            deformation: None,
                            attributes: attributes::intern(&mut state, &mut world.attributes),
                            in_solid: s.in_solid,
                            loc: s.loc.clone(),
                        }
                    })
                    .collect();
                let id = ObjectId(world.objects.len() as u32);
                world.objects.push(ObjectDefinition {
                    handle: def.handle.clone(),
                    shapes,
                    loc: def.loc.clone(),
                });
                world.object_ids.insert(def_index, id);
                id
            }
        };

        // Replay the definition's attribute requests on the instance's state.
        let base = world.attributes[instance_attrs.0 as usize].clone();
        let mut stack: Vec<Attributes> = Vec::new();
        let mut current = base;
        let mut current_id: Option<AttributesId> = Some(instance_attrs);
        let mut shape_attributes = vec![instance_attrs; def.shapes.len()];
        for step in &def.steps {
            match step {
                DefStep::Attr { op, flipped } => {
                    let left_handed = (camera_from_instance_det > 0.0) != *flipped;
                    attributes::apply(&mut current, op, left_handed);
                    current_id = None;
                }
                DefStep::Push => stack.push(current.clone()),
                DefStep::Pop => {
                    if let Some(prev) = stack.pop() {
                        current = prev;
                        current_id = None;
                    }
                }
                DefStep::Shape(i) => {
                    let id = *current_id.get_or_insert_with(|| {
                        world.attributes.push(current.clone());
                        AttributesId(world.attributes.len() as u32 - 1)
                    });
                    if let Some(slot) = shape_attributes.get_mut(*i) {
                        *slot = id;
                    }
                }
            }
        }
        world.instances.push(ObjectInstanceEntity {
            object,
            world_from_instance,
            motion,
            attributes: instance_attrs,
            shape_attributes,
            loc: cx.loc.clone(),
        });
    }
}

fn handle_text(h: &Handle) -> String {
    match h {
        Handle::Int(i) => i.to_string(),
        Handle::Name(n) => format!("\"{n}\""),
    }
}

//! The block requests: `FrameBegin`/`FrameEnd` (saving the options), `WorldBegin`/`WorldEnd`
//! (fixing the camera and keeping one world as the scene), `AttributeBegin`/`AttributeEnd`,
//! `TransformBegin`/`TransformEnd`, `SolidBegin`/`SolidEnd` and `MotionBegin`/`MotionEnd`.

use super::transforms::snap_affine;
use super::{Block, BlockKind, FrameInfo, Motion, MotionStep, SceneBuilder, WorldState, lights};
use crate::diagnostics::DiagnosticKind;
use crate::motion::TransformMotion;
use crate::scene::*;
use crate::target::Cx;
use glam::{DMat4, DVec4};
use std::sync::Arc;

impl SceneBuilder {
    pub(super) fn push_block(&mut self, kind: BlockKind, cx: &mut Cx<'_>) {
        let saved_options = (kind == BlockKind::Frame).then(|| Box::new(self.opts.clone()));
        self.blocks.push(Block { kind, saved: self.gs.clone(), saved_options, loc: cx.loc.clone() });
    }

    /// Ends the innermost block of `kind`. Returns the block, or `None` (with an error) when no
    /// such block is open.
    pub(super) fn pop_block(&mut self, kind: BlockKind, end: &str, cx: &mut Cx<'_>) -> Option<Block> {
        let Some(pos) = self.blocks.iter().rposition(|b| b.kind == kind) else {
            cx.error(DiagnosticKind::Nesting, format!("{end} without {}", kind.begin()));
            return None;
        };
        while self.blocks.len() > pos + 1 {
            if let Some(inner) = self.blocks.pop() {
                cx.error(
                    DiagnosticKind::Nesting,
                    format!("{end} closes {} at {} before its own end", inner.kind.begin(), inner.loc),
                );
                self.restore(inner);
            }
        }
        let block = self.blocks.pop()?;
        Some(block)
    }

    pub(super) fn restore(&mut self, block: Block) {
        match block.kind {
            BlockKind::Transform => {
                self.gs.ctm = block.saved.ctm;
                self.gs.motion = block.saved.motion;
            }
            _ => self.gs = block.saved,
        }
        if let Some(opts) = block.saved_options {
            self.opts = *opts;
        }
    }

    pub(super) fn begin_world(&mut self, cx: &mut Cx<'_>) {
        if self.in_world() {
            cx.error(DiagnosticKind::Nesting, "WorldBegin inside WorldBegin/WorldEnd");
            return;
        }
        self.push_block(BlockKind::World, cx);
        self.camera_from_world = snap_affine(self.gs.ctm);
        // A moving camera: its keys must be cameras too (affine, invertible), else the camera
        // at shutter open is used.
        self.opts.render.camera_motion = self.gs.motion.take().and_then(|motion| {
            let moving = motion.map(snap_affine)?;
            if moving.matrices().iter().all(|m| m.row(3) == DVec4::W && m.determinant() != 0.0) {
                Some(Arc::new(moving))
            } else {
                cx.warn(
                    DiagnosticKind::Unsupported,
                    "a key of the camera's motion block is projective or singular: the camera at shutter open is used",
                );
                None
            }
        });
        let mut settings = self.opts.camera.clone();
        settings.camera_from_world = self.camera_from_world;
        if self.camera_from_world.row(3) != DVec4::W {
            cx.error(
                DiagnosticKind::Camera,
                "the camera transformation is projective (a Perspective request or a matrix with a projective row before WorldBegin); use Projection \"perspective\" instead",
            );
        } else if let Err(e) = depth_remap::Camera::new(settings) {
            cx.error(DiagnosticKind::Camera, format!("the camera is invalid: {e}"));
        }
        self.gs.ctm = DMat4::IDENTITY;
        let world_from_camera = self.camera_from_world.inverse();
        // Lights declared before WorldBegin were given in camera space.
        let mut world = WorldState {
            lights: self.pre_world_lights.clone(),
            light_handles: self.pre_world_handles.clone(),
            ..Default::default()
        };
        for p in &self.pending_lights {
            if let Some(l) = world.lights.get_mut(p.light.0 as usize) {
                let world_from_light = world_from_camera * p.camera_from_light;
                lights::place_light(l, world_from_light);
            }
        }
        for (name, camera_from_space) in &self.named_spaces {
            world.coordinate_systems.push((name.clone(), world_from_camera * *camera_from_space));
        }
        self.named_spaces = world.coordinate_systems.clone();
        self.world = Some(world);
        self.world_loc = Some(cx.loc.clone());
        self.worlds_seen += 1;
        if let Some(f) = self.frames.last_mut()
            && self.current_frame.is_some()
        {
            f.has_world = true;
        }
    }

    pub(super) fn end_world(&mut self, cx: &mut Cx<'_>) {
        let Some(block) = self.pop_block(BlockKind::World, "WorldEnd", cx) else { return };
        self.restore(block);
        let Some(world) = self.world.take() else { return };
        // The camera-space names become camera-space again for what follows the world.
        self.named_spaces =
            world.coordinate_systems.iter().map(|(n, m)| (n.clone(), self.camera_from_world * *m)).collect();
        let shadow_pass = self.opts.displays.iter().any(|d| !d.secondary)
            && self.opts.displays.iter().all(|d| {
                matches!(d.driver.as_str(), "zfile" | "shadow" | "deepshad")
                    || (d.mode == "z" && d.driver != "depthtable")
            });
        if let Some(f) = self.frames.last_mut()
            && self.current_frame.is_some()
        {
            f.shadow_pass = shadow_pass;
        }
        let keep = match self.options.frame {
            Some(n) => self.kept.is_none() && self.current_frame == Some(n),
            // A shadow-map pass is kept only until a world that is not one comes.
            None => self.kept.is_none() || (self.kept_shadow_pass && !shadow_pass),
        };
        if !keep {
            return;
        }
        self.kept_shadow_pass = shadow_pass;
        let mut camera = self.opts.camera.clone();
        camera.camera_from_world = self.camera_from_world;
        self.kept = Some(Scene {
            source: self.source.clone(),
            frame: self.current_frame,
            camera,
            render: self.opts.render.clone(),
            displays: self.opts.displays.clone(),
            depth_request: self.opts.depth_request.clone(),
            options: self.opts.options.clone(),
            lights: world.lights,
            attributes: world.attributes,
            shapes: world.shapes,
            solids: world.solids,
            objects: world.objects,
            instances: world.instances,
            coordinate_systems: world.coordinate_systems,
        });
    }

    pub(super) fn frame_begin(&mut self, frame: i32, cx: &mut Cx<'_>) {
        if self.in_world() || self.current_frame.is_some() {
            cx.error(DiagnosticKind::Nesting, "FrameBegin inside a frame or world block");
            return;
        }
        self.push_block(BlockKind::Frame, cx);
        self.current_frame = Some(frame);
        self.frames.push(FrameInfo {
            number: frame,
            loc: cx.loc.clone(),
            has_world: false,
            shadow_pass: false,
        });
    }

    pub(super) fn frame_end(&mut self, cx: &mut Cx<'_>) {
        if let Some(block) = self.pop_block(BlockKind::Frame, "FrameEnd", cx) {
            if self.in_world() {
                // `pop_block` already reported the unclosed world; drop it.
                self.world = None;
            }
            self.restore(block);
            self.current_frame = None;
        }
    }

    pub(super) fn attribute_begin(&mut self, cx: &mut Cx<'_>) {
        if self.motion.is_some() {
            cx.error(DiagnosticKind::Nesting, "AttributeBegin inside a motion block");
            return;
        }
        self.push_block(BlockKind::Attribute, cx);
        if let Some(def) = &mut self.recording {
            def.push();
        }
    }

    pub(super) fn attribute_end(&mut self, cx: &mut Cx<'_>) {
        if let Some(block) = self.pop_block(BlockKind::Attribute, "AttributeEnd", cx) {
            self.restore(block);
            if let Some(def) = &mut self.recording {
                def.pop();
            }
        }
    }

    pub(super) fn transform_begin(&mut self, cx: &mut Cx<'_>) {
        self.push_block(BlockKind::Transform, cx);
    }

    pub(super) fn transform_end(&mut self, cx: &mut Cx<'_>) {
        if let Some(block) = self.pop_block(BlockKind::Transform, "TransformEnd", cx) {
            self.restore(block);
        }
    }

    pub(super) fn solid_begin(&mut self, operation: &str, cx: &mut Cx<'_>) {
        let op = match operation {
            "primitive" => Some(SolidOp::Primitive),
            "union" => Some(SolidOp::Union),
            "intersection" => Some(SolidOp::Intersection),
            "difference" => Some(SolidOp::Difference),
            _ => {
                cx.error(
                    DiagnosticKind::BadValue,
                    format!(
                        "SolidBegin: unknown operation \"{operation}\" (primitive, union, intersection or difference); read as a union"
                    ),
                );
                None
            }
        };
        self.solid_depth += 1;
        if self.recording.is_some() {
            // Solids inside ObjectBegin are kept as their surfaces (instances share one BLAS).
            if matches!(op, Some(SolidOp::Intersection | SolidOp::Difference)) {
                self.warn_once(
                    "csg-object",
                    cx,
                    DiagnosticKind::Unsupported,
                    format!("SolidBegin \"{operation}\" inside ObjectBegin: the solids' surfaces are kept as a union"),
                );
            }
            return;
        }
        let loc = cx.loc.clone();
        if let Some(world) = self.world_mut() {
            let id = world.solids.len() as u32;
            let parent = world.open_solids.last().copied();
            if let Some(p) = parent {
                world.solids[p as usize].parts.push(SolidPart::Solid(id));
            }
            world.solids.push(Solid { op: op.unwrap_or(SolidOp::Union), parent, parts: Vec::new(), loc });
            world.open_solids.push(id);
        }
    }

    pub(super) fn solid_end(&mut self, cx: &mut Cx<'_>) {
        if self.solid_depth == 0 {
            cx.error(DiagnosticKind::Nesting, "SolidEnd without SolidBegin");
            return;
        }
        self.solid_depth -= 1;
        if self.recording.is_none()
            && let Some(world) = self.world_mut()
        {
            world.open_solids.pop();
        }
    }

    pub(super) fn motion_begin(&mut self, times: &[f32], cx: &mut Cx<'_>) {
        if self.motion.is_some() {
            cx.error(DiagnosticKind::Nesting, "MotionBegin inside a motion block");
            return;
        }
        if times.is_empty() {
            cx.error(DiagnosticKind::BadArguments, "MotionBegin needs at least one time");
        }
        let times = times.iter().map(|&t| f64::from(t)).collect();
        self.motion = Some(Motion {
            times,
            transforms: Vec::new(),
            others: 0,
            non_geometry: 0,
            first_shapes: None,
            first_is_geometry: false,
            later_shapes: Vec::new(),
        });
    }

    /// Ends a motion block. Its transformation requests, one per key time, make the current
    /// transformation move: key `i` is the transformation before the block (at time `t_i`)
    /// followed by request `i`. Other requests keep their first sample.
    pub(super) fn motion_end(&mut self, cx: &mut Cx<'_>) {
        let Some(motion) = self.motion.take() else {
            cx.error(DiagnosticKind::Nesting, "MotionEnd without MotionBegin");
            return;
        };
        if motion.others > 1 && motion.non_geometry > 0 {
            self.warn_once(
                "motion-attributes",
                cx,
                DiagnosticKind::Unsupported,
                "motion blur of lights and attributes (inside MotionBegin) is not supported: the first sample of each such motion block is used",
            );
        }
        if motion.transforms.is_empty() {
            if motion.first_is_geometry && motion.others > 1 && motion.non_geometry == 0 {
                self.deform(motion, cx);
            }
            return;
        }
        if motion.others > 0 {
            cx.warn(
                DiagnosticKind::BadArguments,
                "a motion block mixes transformations with other requests; its transformations are used, the other requests keep their first sample",
            );
        }
        let base = (self.gs.ctm, self.gs.motion.clone());
        let key = |step: MotionStep, time: f64| match step {
            MotionStep::Concat(m) => base.1.as_ref().map_or(base.0, |b| b.at(time)) * m,
            MotionStep::Set(m) => m,
        };
        if motion.transforms.len() != motion.times.len() {
            cx.error(
                DiagnosticKind::BadArguments,
                format!(
                    "MotionBegin gives {} times but the block has {} transformations; only the first is used",
                    motion.times.len(),
                    motion.transforms.len()
                ),
            );
            // The block is closed, so these apply as plain requests.
            match motion.transforms[0] {
                MotionStep::Concat(m) => self.concat(m, "MotionBegin", cx),
                MotionStep::Set(m) => self.set_transform(m),
            }
            return;
        }
        let keys: Vec<DMat4> =
            motion.transforms.iter().zip(&motion.times).map(|(&step, &t)| key(step, t)).collect();
        if !keys.iter().all(|k| k.is_finite()) {
            cx.error(DiagnosticKind::BadValue, "a motion block makes the transformation non-finite; ignored");
            return;
        }
        match TransformMotion::new(motion.times, keys) {
            None => cx.error(
                DiagnosticKind::BadValue,
                "MotionBegin times must be finite and increasing; the block's transformations are ignored",
            ),
            Some(m) if m.is_static() => {
                self.gs.ctm = m.matrices()[0];
                self.gs.motion = None;
            }
            Some(m) => {
                self.gs.ctm = m.at(self.shutter_open());
                self.gs.motion = Some(Arc::new(m));
            }
        }
    }
}

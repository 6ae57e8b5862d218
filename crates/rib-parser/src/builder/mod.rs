//! The scene builder: the [`RibTarget`] that turns requests into a world-space [`Scene`].
//!
//! # Graphics state
//! The builder keeps RenderMan's graphics state: options (camera, display, render settings;
//! saved by `FrameBegin`), attributes (saved by `AttributeBegin`, `WorldBegin`, `FrameBegin`)
//! and the current transformation (also saved by `TransformBegin`). Transformations compose in
//! `f64` with the one given last applied to the object first (`ctm = ctm * m`). Before
//! `WorldBegin` the current transformation maps the current space to camera space; at
//! `WorldBegin` it becomes `camera_from_world` and the current transformation restarts as the
//! identity of world space. Inside the world block `Identity`, `Transform` and
//! `CoordSysTransform "world"` are relative to world space (as in pbrt and Aqsis).
//!
//! # Orientation: which way normals point
//! The RenderMan Interface (RISpec 3.2 §4.2.14) keeps two handednesses: that of the current
//! coordinate system (left-handed in camera space; it flips with every transformation of
//! negative determinant) and the *current orientation* (initially the same; it flips whenever
//! the coordinate system's flips, and `Orientation`/`ReverseOrientation` set or toggle it).
//! When the two differ, primitives are turned inside out and their normals flipped. Aqsis
//! implements exactly this (`eOrientation` against `eCoordsysOrientation`, normals negated when
//! they differ, then transformed by the inverse transpose).
//!
//! Since transformations flip both together, only their relation matters, and that is what
//! [`Attributes::reverse_orientation`] stores: `true` when the current orientation differs
//! from the coordinate system's handedness. Transformations never change it;
//! `Orientation "outside"` clears it, `"inside"` sets it, `"lh"`/`"rh"` compare with the
//! handedness of the current coordinate system at that point (left-handed when
//! `det(camera_from_object) > 0`), and `ReverseOrientation` toggles it. The geometric normal a
//! consumer computes is then `world_from_object^-T * n_object`, with `n_object` taken in object
//! space (`(P1 - P0) x (P2 - P0)` for a polygon, `dP/du x dP/dv` for a parametric surface),
//! negated iff `reverse_orientation`. In the Cornell box of the reference scene the camera
//! transform mirrors z, which flips both handednesses together, so no flip happens and
//! `(P1 - P0) x (P2 - P0)` in world space is the normal (CONTRACTS.md §3).
//!
//! # Object instances
//! An `ObjectBegin`/`ObjectEnd` definition keeps its shapes in object space (the current
//! transformation restarts at the identity at `ObjectBegin`) with the attribute requests made
//! inside it. An `ObjectInstance` places the definition with the current transformation and
//! the current attributes (RISpec: an instance inherits the graphics state where it is
//! instanced), and the definition's own attribute requests are replayed on top, so a definition
//! that sets `Color` keeps it while `Surface` set before `ObjectInstance` applies
//! ([`crate::scene::ObjectInstanceEntity::shape_attributes`]). Definitions stay valid for the
//! rest of the file; redefining a handle replaces it.
//!
//! # Frames
//! Every `FrameBegin` is listed in [`Built::frames`]. One world is kept as the scene: the one in
//! the frame [`BuildOptions::frame`] names, or by default the first world of the file.

mod attributes;
mod objects;
mod shapes;

use crate::diagnostics::{DiagnosticKind, Diagnostics};
use crate::limits::Limits;
use crate::scene::*;
use crate::target::{Cx, NuPatchArgs, Quadric, RibTarget, ShaderSlot};
use depth_remap::{CameraSettings, Clipping, CropWindow, Projection, ScreenWindow};
use glam::{DMat4, DVec3, DVec4};
use std::collections::HashMap;
use std::sync::Arc;

pub(crate) use attributes::AttrState;
use objects::ObjectDef;

/// What to build.
#[derive(Clone, Debug, Default)]
pub struct BuildOptions {
    /// Keep the world of `FrameBegin frame`; `None` keeps the first world of the file.
    pub frame: Option<i32>,
    /// Image size limits (the rest of [`Limits`] is for the parser).
    pub limits: Limits,
}

/// One `FrameBegin` of the file.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameInfo {
    pub number: i32,
    pub loc: FileLoc,
    pub has_world: bool,
}

/// What the builder produced.
#[derive(Clone, Debug)]
pub struct Built {
    pub scene: Scene,
    /// Every frame of the file, in order (empty when the file has no `FrameBegin`).
    pub frames: Vec<FrameInfo>,
}

/// The options part of the graphics state (saved by `FrameBegin`).
#[derive(Clone, Debug, Default)]
struct OptionState {
    camera: CameraSettings,
    render: RenderSettings,
    displays: Vec<Display>,
    depth_request: Option<DepthRequest>,
    options: Vec<OptionCall>,
    /// `ColorSamples` `n x 3` matrix (row-major) converting `n` samples to RGB.
    color_to_rgb: Option<Vec<f32>>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BlockKind {
    Frame,
    World,
    Attribute,
    Transform,
    Object,
}

impl BlockKind {
    fn begin(self) -> &'static str {
        match self {
            BlockKind::Frame => "FrameBegin",
            BlockKind::World => "WorldBegin",
            BlockKind::Attribute => "AttributeBegin",
            BlockKind::Transform => "TransformBegin",
            BlockKind::Object => "ObjectBegin",
        }
    }
}

/// The attribute and transformation part of the graphics state.
#[derive(Clone, Debug)]
struct GraphicsState {
    /// Before `WorldBegin`: `camera_from_current`; inside the world: `world_from_current`;
    /// inside an object definition: `object_from_current`.
    ctm: DMat4,
    attrs: AttrState,
}

struct Block {
    kind: BlockKind,
    saved: GraphicsState,
    saved_options: Option<Box<OptionState>>,
    loc: FileLoc,
}

/// A light declared before `WorldBegin`: placed in world space once the camera is known.
struct PendingLight {
    light: LightId,
    camera_from_light: DMat4,
}

/// The world being built.
#[derive(Default)]
struct WorldState {
    lights: Vec<Light>,
    attributes: Vec<Attributes>,
    shapes: Vec<ShapeEntity>,
    objects: Vec<ObjectDefinition>,
    /// Builder definition index -> this world's object id.
    object_ids: HashMap<usize, ObjectId>,
    instances: Vec<ObjectInstanceEntity>,
    coordinate_systems: Vec<(String, DMat4)>,
    light_handles: HashMap<Handle, LightId>,
}

/// Motion block state: only the first sample of each motion block is used.
struct Motion {
    seen: usize,
}

/// Builds a [`Scene`] from RIB requests. Use it with [`crate::parser::Reader`], or through
/// [`crate::load_scene`].
pub struct SceneBuilder {
    options: BuildOptions,
    source: Arc<str>,
    opts: OptionState,
    gs: GraphicsState,
    blocks: Vec<Block>,
    world: Option<WorldState>,
    world_loc: Option<FileLoc>,
    camera_from_world: DMat4,
    /// `CoordinateSystem` spaces: `camera_from_space` before the world, converted at
    /// `WorldBegin`; inside the world `world_from_space`.
    named_spaces: Vec<(String, DMat4)>,
    pending_lights: Vec<PendingLight>,
    pre_world_lights: Vec<Light>,
    pre_world_handles: HashMap<Handle, LightId>,
    defs: Vec<ObjectDef>,
    def_handles: HashMap<Handle, usize>,
    /// The definition being recorded, if inside `ObjectBegin`.
    recording: Option<ObjectDef>,
    solid_depth: usize,
    motion: Option<Motion>,
    frames: Vec<FrameInfo>,
    current_frame: Option<i32>,
    kept: Option<Scene>,
    worlds_seen: usize,
    warned: std::collections::HashSet<&'static str>,
}

impl std::fmt::Debug for SceneBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SceneBuilder")
            .field("source", &self.source)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

impl SceneBuilder {
    /// A builder for the scene read from `source` (the name reported in [`Scene::source`]).
    pub fn new(source: impl Into<Arc<str>>, options: BuildOptions) -> SceneBuilder {
        SceneBuilder {
            options,
            source: source.into(),
            opts: OptionState::default(),
            gs: GraphicsState { ctm: DMat4::IDENTITY, attrs: AttrState::default() },
            blocks: Vec::new(),
            world: None,
            world_loc: None,
            camera_from_world: DMat4::IDENTITY,
            named_spaces: Vec::new(),
            pending_lights: Vec::new(),
            pre_world_lights: Vec::new(),
            pre_world_handles: HashMap::new(),
            defs: Vec::new(),
            def_handles: HashMap::new(),
            recording: None,
            solid_depth: 0,
            motion: None,
            frames: Vec::new(),
            current_frame: None,
            kept: None,
            worlds_seen: 0,
            warned: Default::default(),
        }
    }

    /// The scene, once every request has been given. Reports an error (and returns `None`) when
    /// the input had no world block, the selected frame does not exist, or a block was left open.
    pub fn finish(mut self, diagnostics: &mut Diagnostics) -> Option<Built> {
        for block in std::mem::take(&mut self.blocks).iter().rev() {
            diagnostics.error(
                DiagnosticKind::Nesting,
                &block.loc,
                format!("{} is never closed (the input ends inside it)", block.kind.begin()),
            );
        }
        if self.kept.is_none() {
            let at = FileLoc::new(self.source.clone(), 1, 1);
            match self.options.frame {
                Some(n) => {
                    let list: Vec<String> = self.frames.iter().map(|f| f.number.to_string()).collect();
                    diagnostics.error(
                        DiagnosticKind::BadValue,
                        &at,
                        format!(
                            "frame {n} not found or has no world (frames in the file: {})",
                            if list.is_empty() { "none".into() } else { list.join(", ") }
                        ),
                    );
                }
                None if diagnostics.has_errors() => {}
                None => diagnostics.error(
                    DiagnosticKind::Nesting,
                    &at,
                    "the input has no WorldBegin/WorldEnd block, so it describes no scene",
                ),
            }
            return None;
        }
        self.kept.map(|scene| Built { scene, frames: self.frames })
    }

    fn warn_once(
        &mut self,
        key: &'static str,
        cx: &mut Cx<'_>,
        kind: DiagnosticKind,
        message: impl Into<String>,
    ) {
        if self.warned.insert(key) {
            cx.warn(kind, message);
        }
    }

    fn in_world(&self) -> bool {
        self.world.is_some()
    }

    /// Inside a motion block only the first request is used; the rest are skipped.
    fn skip_motion_sample(&mut self) -> bool {
        match &mut self.motion {
            Some(m) => {
                m.seen += 1;
                m.seen > 1
            }
            None => false,
        }
    }

    /// The handedness of the current coordinate system: left-handed (RenderMan's camera
    /// space) when `det(camera_from_current) > 0`.
    fn coordsys_left_handed(&self) -> bool {
        let camera_from_current =
            if self.in_world() { self.camera_from_world * self.gs.ctm } else { self.gs.ctm };
        camera_from_current.determinant() > 0.0
    }

    fn push_block(&mut self, kind: BlockKind, cx: &mut Cx<'_>) {
        let saved_options = (kind == BlockKind::Frame).then(|| Box::new(self.opts.clone()));
        self.blocks.push(Block { kind, saved: self.gs.clone(), saved_options, loc: cx.loc.clone() });
    }

    /// Ends the innermost block of `kind`. Returns the block, or `None` (with an error) when no
    /// such block is open.
    fn pop_block(&mut self, kind: BlockKind, end: &str, cx: &mut Cx<'_>) -> Option<Block> {
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

    fn restore(&mut self, block: Block) {
        match block.kind {
            BlockKind::Transform => self.gs.ctm = block.saved.ctm,
            _ => self.gs = block.saved,
        }
        if let Some(opts) = block.saved_options {
            self.opts = *opts;
        }
    }

    /// Options may only change outside the world block.
    fn option_allowed(&mut self, request: &str, cx: &mut Cx<'_>) -> bool {
        if self.in_world() {
            cx.warn(
                DiagnosticKind::Nesting,
                format!("{request} inside WorldBegin/WorldEnd is ignored (options are fixed at WorldBegin)"),
            );
            return false;
        }
        true
    }

    /// Applies `m` to the current transformation (`ctm = ctm * m`), refusing non-finite results.
    fn concat(&mut self, m: DMat4, request: &str, cx: &mut Cx<'_>) {
        if self.skip_motion_sample() {
            return;
        }
        let next = self.gs.ctm * m;
        if !next.is_finite() {
            cx.error(
                DiagnosticKind::BadValue,
                format!("{request} makes the transformation non-finite; ignored"),
            );
            return;
        }
        self.gs.ctm = next;
    }

    fn world_mut(&mut self) -> Option<&mut WorldState> {
        self.world.as_mut()
    }

    fn begin_world(&mut self, cx: &mut Cx<'_>) {
        if self.in_world() {
            cx.error(DiagnosticKind::Nesting, "WorldBegin inside WorldBegin/WorldEnd");
            return;
        }
        self.push_block(BlockKind::World, cx);
        self.camera_from_world = snap_affine(self.gs.ctm);
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
                attributes::place_light(l, world_from_light);
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

    fn end_world(&mut self, cx: &mut Cx<'_>) {
        let Some(block) = self.pop_block(BlockKind::World, "WorldEnd", cx) else { return };
        self.restore(block);
        let Some(world) = self.world.take() else { return };
        // The camera-space names become camera-space again for what follows the world.
        self.named_spaces =
            world.coordinate_systems.iter().map(|(n, m)| (n.clone(), self.camera_from_world * *m)).collect();
        let keep = self.kept.is_none()
            && match self.options.frame {
                Some(n) => self.current_frame == Some(n),
                None => true,
            };
        if !keep {
            return;
        }
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
            objects: world.objects,
            instances: world.instances,
            coordinate_systems: world.coordinate_systems,
        });
    }

    /// Adds a shape made now to the world (or the object being defined).
    fn add_shape(&mut self, shape: Shape, cx: &mut Cx<'_>) {
        if self.skip_motion_sample() {
            return;
        }
        let in_solid = self.solid_depth > 0;
        if let Some(def) = &mut self.recording {
            def.add_shape(
                Arc::new(shape),
                self.gs.ctm,
                self.gs.attrs.attrs.clone(),
                in_solid,
                cx.loc.clone(),
            );
            return;
        }
        if !self.in_world() {
            cx.error(DiagnosticKind::Nesting, "geometry outside WorldBegin/WorldEnd is ignored");
            return;
        }
        let attributes = self.intern_attributes();
        let world_from_object = snap_affine(self.gs.ctm);
        if world_from_object.row(3) != DVec4::W {
            self.warn_once(
                "projective-shape",
                cx,
                DiagnosticKind::Unsupported,
                "this shape's transformation is projective (Perspective); consumers that need affine transformations may reject it",
            );
        }
        if let Some(world) = self.world_mut() {
            world.shapes.push(ShapeEntity {
                shape: Arc::new(shape),
                world_from_object,
                attributes,
                in_solid,
                loc: cx.loc.clone(),
            });
        }
    }

    /// The id of the current attributes in this world's table, adding them if they changed.
    fn intern_attributes(&mut self) -> AttributesId {
        let Some(world) = self.world.as_mut() else { return AttributesId(0) };
        attributes::intern(&mut self.gs.attrs, &mut world.attributes)
    }
}

impl RibTarget for SceneBuilder {
    fn version(&mut self, _version: f64, _cx: &mut Cx<'_>) {}

    fn frame_begin(&mut self, frame: i32, cx: &mut Cx<'_>) {
        if self.in_world() || self.current_frame.is_some() {
            cx.error(DiagnosticKind::Nesting, "FrameBegin inside a frame or world block");
            return;
        }
        self.push_block(BlockKind::Frame, cx);
        self.current_frame = Some(frame);
        self.frames.push(FrameInfo { number: frame, loc: cx.loc.clone(), has_world: false });
    }

    fn frame_end(&mut self, cx: &mut Cx<'_>) {
        if let Some(block) = self.pop_block(BlockKind::Frame, "FrameEnd", cx) {
            if self.in_world() {
                // `pop_block` already reported the unclosed world; drop it.
                self.world = None;
            }
            self.restore(block);
            self.current_frame = None;
        }
    }

    fn world_begin(&mut self, cx: &mut Cx<'_>) {
        self.begin_world(cx);
    }

    fn world_end(&mut self, cx: &mut Cx<'_>) {
        self.end_world(cx);
    }

    fn attribute_begin(&mut self, cx: &mut Cx<'_>) {
        if self.motion.is_some() {
            cx.error(DiagnosticKind::Nesting, "AttributeBegin inside a motion block");
            return;
        }
        self.push_block(BlockKind::Attribute, cx);
        if let Some(def) = &mut self.recording {
            def.push();
        }
    }

    fn attribute_end(&mut self, cx: &mut Cx<'_>) {
        if let Some(block) = self.pop_block(BlockKind::Attribute, "AttributeEnd", cx) {
            self.restore(block);
            if let Some(def) = &mut self.recording {
                def.pop();
            }
        }
    }

    fn transform_begin(&mut self, cx: &mut Cx<'_>) {
        self.push_block(BlockKind::Transform, cx);
    }

    fn transform_end(&mut self, cx: &mut Cx<'_>) {
        if let Some(block) = self.pop_block(BlockKind::Transform, "TransformEnd", cx) {
            self.restore(block);
        }
    }

    fn solid_begin(&mut self, operation: &str, cx: &mut Cx<'_>) {
        if !matches!(operation, "primitive" | "union" | "intersection" | "difference") {
            cx.error(
                DiagnosticKind::BadValue,
                format!("SolidBegin: unknown operation \"{operation}\" (primitive, union, intersection or difference)"),
            );
        }
        if operation != "primitive" && operation != "union" {
            self.warn_once(
                "csg",
                cx,
                DiagnosticKind::Unsupported,
                format!("SolidBegin \"{operation}\": solid operations are not supported; the solids' surfaces are kept as a union"),
            );
        }
        self.solid_depth += 1;
    }

    fn solid_end(&mut self, cx: &mut Cx<'_>) {
        if self.solid_depth == 0 {
            cx.error(DiagnosticKind::Nesting, "SolidEnd without SolidBegin");
        } else {
            self.solid_depth -= 1;
        }
    }

    fn object_begin(&mut self, handle: Handle, cx: &mut Cx<'_>) {
        self.begin_object(handle, cx);
    }

    fn object_end(&mut self, cx: &mut Cx<'_>) {
        self.end_object(cx);
    }

    fn object_instance(&mut self, handle: Handle, cx: &mut Cx<'_>) {
        self.instance_object(handle, cx);
    }

    fn motion_begin(&mut self, times: &[f32], cx: &mut Cx<'_>) {
        if self.motion.is_some() {
            cx.error(DiagnosticKind::Nesting, "MotionBegin inside a motion block");
            return;
        }
        if times.is_empty() {
            cx.error(DiagnosticKind::BadArguments, "MotionBegin needs at least one time");
        }
        self.warn_once(
            "motion",
            cx,
            DiagnosticKind::Unsupported,
            "motion blur is not supported: the first sample of each motion block is used",
        );
        self.motion = Some(Motion { seen: 0 });
    }

    fn motion_end(&mut self, cx: &mut Cx<'_>) {
        if self.motion.take().is_none() {
            cx.error(DiagnosticKind::Nesting, "MotionEnd without MotionBegin");
        }
    }

    fn format(&mut self, x: i32, y: i32, pixel_aspect: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("Format", cx) {
            return;
        }
        let limits = &self.options.limits;
        let side = i64::from(limits.max_image_side);
        if x < 1 || y < 1 || i64::from(x) > side || i64::from(y) > side {
            cx.error(
                DiagnosticKind::BadValue,
                format!("Format: resolution {x}x{y} must be between 1 and {side} pixels per side"),
            );
            return;
        }
        let pixels = x as u64 * y as u64;
        if pixels > limits.max_image_pixels {
            cx.error(
                DiagnosticKind::Limit,
                format!(
                    "Format: {x}x{y} = {pixels} pixels exceeds the limit of {} pixels",
                    limits.max_image_pixels
                ),
            );
            return;
        }
        let aspect = if pixel_aspect.is_finite() && pixel_aspect > 0.0 {
            pixel_aspect
        } else {
            cx.warn(
                DiagnosticKind::BadValue,
                format!("Format: pixel aspect ratio {pixel_aspect} is not positive; using 1"),
            );
            1.0
        };
        let c = &mut self.opts.camera;
        c.x_resolution = x as u32;
        c.y_resolution = y as u32;
        c.pixel_aspect_ratio = aspect;
    }

    fn frame_aspect_ratio(&mut self, ratio: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("FrameAspectRatio", cx) {
            return;
        }
        if !(ratio.is_finite() && ratio > 0.0) {
            cx.error(DiagnosticKind::BadValue, format!("FrameAspectRatio must be positive, got {ratio}"));
            return;
        }
        self.opts.camera.frame_aspect_ratio = Some(ratio);
    }

    fn screen_window(&mut self, left: f64, right: f64, bottom: f64, top: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("ScreenWindow", cx) {
            return;
        }
        let finite = [left, right, bottom, top].iter().all(|v| v.is_finite());
        if !finite || left == right || bottom == top {
            cx.error(
                DiagnosticKind::BadValue,
                format!("ScreenWindow [{left} {right} {bottom} {top}] has no extent"),
            );
            return;
        }
        self.opts.camera.screen_window = Some(ScreenWindow { left, right, bottom, top });
    }

    fn crop_window(&mut self, x_min: f64, x_max: f64, y_min: f64, y_max: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("CropWindow", cx) {
            return;
        }
        let crop = CropWindow { xmin: x_min, xmax: x_max, ymin: y_min, ymax: y_max };
        if !crop.is_valid() {
            cx.error(
                DiagnosticKind::BadValue,
                format!("CropWindow [{x_min} {x_max} {y_min} {y_max}] must satisfy 0 <= min < max <= 1"),
            );
            return;
        }
        self.opts.camera.crop_window = crop;
    }

    fn projection(&mut self, name: &str, params: ParamList, fov_degrees: Option<f64>, cx: &mut Cx<'_>) {
        if !self.option_allowed("Projection", cx) {
            return;
        }
        match name {
            "perspective" => {
                let fov = fov_degrees.or(params.float("fov").map(f64::from)).unwrap_or(90.0);
                if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
                    cx.error(
                        DiagnosticKind::BadValue,
                        format!("Projection \"perspective\": fov {fov} must be in (0, 180) degrees"),
                    );
                    return;
                }
                self.opts.camera.projection = Projection::Perspective { fov_degrees: fov };
            }
            "orthographic" => self.opts.camera.projection = Projection::Orthographic,
            // `Projection "NULL"` or `""` leaves the camera transformation as the whole projection.
            "null" | "NULL" | "" => self.opts.camera.projection = Projection::Orthographic,
            other => cx.error(
                DiagnosticKind::Unsupported,
                format!("Projection \"{other}\" is not supported (perspective or orthographic)"),
            ),
        }
    }

    fn clipping(&mut self, near: f64, far: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("Clipping", cx) {
            return;
        }
        if !(near > 0.0 && far > near) || near.is_nan() {
            cx.error(DiagnosticKind::BadValue, format!("Clipping {near} {far}: needs 0 < near < far"));
            return;
        }
        self.opts.camera.clipping = Clipping { near, far };
    }

    fn shutter(&mut self, open: f32, close: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("Shutter", cx) {
            return;
        }
        self.opts.render.shutter = Some((open, close));
    }

    fn pixel_samples(&mut self, x: f32, y: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("PixelSamples", cx) {
            return;
        }
        if !(x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0) {
            cx.error(DiagnosticKind::BadValue, format!("PixelSamples {x} {y} must be positive"));
            return;
        }
        self.opts.render.pixel_samples = (x, y);
    }

    fn pixel_filter(&mut self, name: &str, x_width: f32, y_width: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("PixelFilter", cx) {
            return;
        }
        if !(x_width.is_finite() && y_width.is_finite() && x_width > 0.0 && y_width > 0.0) {
            cx.error(
                DiagnosticKind::BadValue,
                format!("PixelFilter widths {x_width} {y_width} must be positive"),
            );
            return;
        }
        self.opts.render.pixel_filter = PixelFilter { name: name.to_string(), x_width, y_width };
    }

    fn exposure(&mut self, gain: f32, gamma: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("Exposure", cx) {
            return;
        }
        if !(gain.is_finite() && gain >= 0.0 && gamma.is_finite() && gamma > 0.0) {
            cx.error(
                DiagnosticKind::BadValue,
                format!("Exposure {gain} {gamma}: needs gain >= 0 and gamma > 0"),
            );
            return;
        }
        self.opts.render.exposure = Exposure { gain, gamma };
    }

    fn quantize(&mut self, kind: &str, one: i32, min: i32, max: i32, dither: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("Quantize", cx) {
            return;
        }
        let q = Quantize { one, min, max, dither };
        match kind {
            "rgba" => self.opts.render.quantize = q,
            "z" => self.opts.render.quantize_depth = Some(q),
            other => cx
                .warn(DiagnosticKind::Unsupported, format!("Quantize \"{other}\" is not supported; ignored")),
        }
    }

    fn display(&mut self, name: &str, driver: &str, mode: &str, params: ParamList, cx: &mut Cx<'_>) {
        if !self.option_allowed("Display", cx) {
            return;
        }
        let (secondary, bare) = match name.strip_prefix('+') {
            Some(rest) => (true, rest),
            None => (false, name),
        };
        if bare.is_empty() {
            cx.error(DiagnosticKind::BadValue, "Display: empty name");
            return;
        }
        if !secondary {
            // A primary display replaces the display list (RISpec §4.1.3).
            self.opts.displays.clear();
        }
        if driver == "depthtable" {
            if let Some(prev) = &self.opts.depth_request
                && prev.path.as_os_str() != bare
            {
                cx.warn(
                    DiagnosticKind::BadValue,
                    format!(
                        "a depth table was already requested ({}); this Display replaces it",
                        prev.path.display()
                    ),
                );
            }
            self.opts.depth_request = Some(DepthRequest {
                path: bare.into(),
                source: DepthRequestSource::Display,
                loc: Some(cx.loc.clone()),
            });
        }
        self.opts.displays.push(Display {
            name: bare.to_string(),
            secondary,
            driver: driver.to_string(),
            mode: mode.to_string(),
            params,
            loc: cx.loc.clone(),
        });
    }

    fn hider(&mut self, name: &str, params: ParamList, cx: &mut Cx<'_>) {
        if !self.option_allowed("Hider", cx) {
            return;
        }
        self.opts.render.hider = Some(ShaderCall { name: name.to_string(), params, loc: cx.loc.clone() });
    }

    fn color_samples(&mut self, n_to_rgb: Vec<f32>, _rgb_to_n: Vec<f32>, cx: &mut Cx<'_>) {
        if !self.option_allowed("ColorSamples", cx) {
            return;
        }
        self.opts.color_to_rgb =
            if n_to_rgb.len() == 9 && is_identity3(&n_to_rgb) { None } else { Some(n_to_rgb) };
    }

    fn option(&mut self, namespace: &str, params: ParamList, cx: &mut Cx<'_>) {
        if namespace == "lrt" {
            if let Some(path) = params.string("depthfile") {
                if path.is_empty() {
                    cx.error(DiagnosticKind::BadValue, "Option \"lrt\" \"depthfile\": empty file name");
                } else {
                    let loc = params.get("depthfile").map_or_else(|| cx.loc.clone(), |p| p.loc.clone());
                    self.opts.depth_request = Some(DepthRequest {
                        path: path.into(),
                        source: DepthRequestSource::Option,
                        loc: Some(loc),
                    });
                }
            } else if params.get("depthfile").is_some() {
                cx.error(DiagnosticKind::ParameterValues, "Option \"lrt\" \"depthfile\" needs a string");
            }
        }
        self.opts.options.push(OptionCall { namespace: namespace.to_string(), params, loc: cx.loc.clone() });
    }

    fn surface_integrator(&mut self, call: ShaderCall, cx: &mut Cx<'_>) {
        if !self.option_allowed("SurfaceIntegrator", cx) {
            return;
        }
        self.opts.render.surface_integrator = Some(call);
    }

    fn color(&mut self, color: &[f32], cx: &mut Cx<'_>) {
        if let Some(c) = self.rgb_of(color, "Color", cx) {
            self.set_attr(attributes::AttrOp::Color(c), cx);
        }
    }

    fn opacity(&mut self, opacity: &[f32], cx: &mut Cx<'_>) {
        if let Some(c) = self.rgb_of(opacity, "Opacity", cx) {
            self.set_attr(attributes::AttrOp::Opacity(c), cx);
        }
    }

    fn light_source(&mut self, call: ShaderCall, handle: Handle, cx: &mut Cx<'_>) {
        self.add_light(call, handle, false, cx);
    }

    fn area_light_source(&mut self, call: ShaderCall, handle: Handle, cx: &mut Cx<'_>) {
        self.add_light(call, handle, true, cx);
    }

    fn illuminate(&mut self, handle: Handle, on: bool, cx: &mut Cx<'_>) {
        self.illuminate_light(handle, on, cx);
    }

    fn shader(&mut self, slot: ShaderSlot, call: ShaderCall, cx: &mut Cx<'_>) {
        match slot {
            ShaderSlot::Displacement => self.warn_once(
                "displacement",
                cx,
                DiagnosticKind::Unsupported,
                format!("Displacement \"{}\" is kept but ignored: surfaces are not displaced", call.name),
            ),
            ShaderSlot::Deformation => {
                cx.warn(
                    DiagnosticKind::Unsupported,
                    format!("Deformation \"{}\" is not supported; ignored", call.name),
                );
                return;
            }
            _ => {}
        }
        self.set_attr(attributes::AttrOp::Shader(slot, call), cx);
    }

    fn shading_rate(&mut self, rate: f32, cx: &mut Cx<'_>) {
        if !(rate.is_finite() && rate > 0.0) {
            cx.error(DiagnosticKind::BadValue, format!("ShadingRate must be positive, got {rate}"));
            return;
        }
        self.set_attr(attributes::AttrOp::ShadingRate(rate), cx);
    }

    fn matte(&mut self, on: bool, cx: &mut Cx<'_>) {
        self.set_attr(attributes::AttrOp::Matte(on), cx);
    }

    fn orientation(&mut self, orientation: &str, cx: &mut Cx<'_>) {
        let op = match orientation {
            "outside" => attributes::Orient::Outside,
            "inside" => attributes::Orient::Inside,
            "lh" => attributes::Orient::LeftHanded,
            "rh" => attributes::Orient::RightHanded,
            other => {
                cx.error(
                    DiagnosticKind::BadValue,
                    format!("Orientation \"{other}\": expected outside, inside, lh or rh"),
                );
                return;
            }
        };
        self.set_attr(attributes::AttrOp::Orientation(op), cx);
    }

    fn reverse_orientation(&mut self, cx: &mut Cx<'_>) {
        self.set_attr(attributes::AttrOp::ReverseOrientation, cx);
    }

    fn sides(&mut self, sides: i32, cx: &mut Cx<'_>) {
        if sides != 1 && sides != 2 {
            cx.error(DiagnosticKind::BadValue, format!("Sides must be 1 or 2, got {sides}"));
            return;
        }
        self.set_attr(attributes::AttrOp::Sides(sides as u8), cx);
    }

    fn attribute(&mut self, namespace: &str, params: ParamList, cx: &mut Cx<'_>) {
        if namespace == "haptic" {
            attributes::check_haptic(&params, cx);
        }
        self.set_attr(
            attributes::AttrOp::Attribute(AttributeCall {
                namespace: namespace.to_string(),
                params,
                loc: cx.loc.clone(),
            }),
            cx,
        );
    }

    fn basis(&mut self, u: Basis, v: Basis, _cx: &mut Cx<'_>) {
        self.gs.attrs.u_basis = u;
        self.gs.attrs.v_basis = v;
    }

    fn trim_curve(&mut self, trim: TrimCurves, _cx: &mut Cx<'_>) {
        self.gs.attrs.trim = Some(Arc::new(trim));
    }

    fn identity(&mut self, _cx: &mut Cx<'_>) {
        if self.skip_motion_sample() {
            return;
        }
        self.gs.ctm = DMat4::IDENTITY;
    }

    fn transform(&mut self, matrix: DMat4, cx: &mut Cx<'_>) {
        if self.skip_motion_sample() {
            return;
        }
        if !matrix.is_finite() {
            cx.error(DiagnosticKind::BadValue, "Transform: the matrix is not finite; ignored");
            return;
        }
        self.gs.ctm = matrix;
    }

    fn concat_transform(&mut self, matrix: DMat4, cx: &mut Cx<'_>) {
        self.concat(matrix, "ConcatTransform", cx);
    }

    fn perspective(&mut self, fov_degrees: f64, cx: &mut Cx<'_>) {
        if !(fov_degrees > 0.0 && fov_degrees < 180.0) {
            cx.error(
                DiagnosticKind::BadValue,
                format!("Perspective: fov {fov_degrees} must be in (0, 180) degrees"),
            );
            return;
        }
        self.concat(perspective_matrix(fov_degrees), "Perspective", cx);
    }

    fn translate(&mut self, delta: DVec3, cx: &mut Cx<'_>) {
        self.concat(DMat4::from_translation(delta), "Translate", cx);
    }

    fn rotate(&mut self, angle_degrees: f64, axis: DVec3, cx: &mut Cx<'_>) {
        let len = axis.length();
        if !(len > 0.0 && len.is_finite()) {
            if angle_degrees == 0.0 {
                // `Rotate 0 0 0 0` is a no-op some writers emit.
                return;
            }
            cx.error(DiagnosticKind::BadValue, "Rotate: the axis has zero length; ignored");
            return;
        }
        self.concat(rotation_matrix(angle_degrees, axis / len), "Rotate", cx);
    }

    fn scale(&mut self, scale: DVec3, cx: &mut Cx<'_>) {
        self.concat(DMat4::from_scale(scale), "Scale", cx);
    }

    fn skew(&mut self, angle_degrees: f64, from: DVec3, to: DVec3, cx: &mut Cx<'_>) {
        match skew_matrix(angle_degrees, from, to) {
            Ok(m) => self.concat(m, "Skew", cx),
            Err(msg) => cx.error(DiagnosticKind::BadValue, format!("Skew: {msg}; ignored")),
        }
    }

    fn coordinate_system(&mut self, name: &str, _cx: &mut Cx<'_>) {
        let m = self.gs.ctm;
        match self.named_spaces.iter_mut().find(|(n, _)| n == name) {
            Some(entry) => entry.1 = m,
            None => self.named_spaces.push((name.to_string(), m)),
        }
        if let Some(world) = self.world_mut() {
            match world.coordinate_systems.iter_mut().find(|(n, _)| n == name) {
                Some(entry) => entry.1 = m,
                None => world.coordinate_systems.push((name.to_string(), m)),
            }
        }
    }

    fn coord_sys_transform(&mut self, name: &str, cx: &mut Cx<'_>) {
        if self.skip_motion_sample() {
            return;
        }
        let in_world = self.in_world();
        let m = match name {
            "world" if in_world => Some(DMat4::IDENTITY),
            "camera" if in_world => Some(self.camera_from_world.inverse()),
            "camera" => Some(DMat4::IDENTITY),
            "object" | "current" | "shader" => Some(self.gs.ctm),
            other => self.named_spaces.iter().find(|(n, _)| n == other).map(|(_, m)| *m),
        };
        match m {
            Some(m) => self.gs.ctm = m,
            None => cx.error(
                DiagnosticKind::UnknownHandle,
                format!("CoordSysTransform: no coordinate system named \"{name}\""),
            ),
        }
    }

    fn polygon(&mut self, vertex_count: u32, params: ParamList, cx: &mut Cx<'_>) {
        let shape = shapes::polygons(vec![1], vec![vertex_count], (0..vertex_count).collect(), params);
        self.add_shape(shape, cx);
    }

    fn general_polygon(&mut self, vertices_per_loop: Vec<u32>, params: ParamList, cx: &mut Cx<'_>) {
        let total: u32 = vertices_per_loop.iter().sum();
        let loops = vertices_per_loop.len() as u32;
        let shape = shapes::polygons(vec![loops], vertices_per_loop, (0..total).collect(), params);
        self.add_shape(shape, cx);
    }

    fn points_polygons(
        &mut self,
        vertices_per_face: Vec<u32>,
        vertex_indices: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        let loops = vec![1; vertices_per_face.len()];
        self.add_shape(shapes::polygons(loops, vertices_per_face, vertex_indices, params), cx);
    }

    fn points_general_polygons(
        &mut self,
        loops_per_face: Vec<u32>,
        vertices_per_loop: Vec<u32>,
        vertex_indices: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        self.add_shape(shapes::polygons(loops_per_face, vertices_per_loop, vertex_indices, params), cx);
    }

    fn patch(&mut self, kind: PatchKind, params: ParamList, cx: &mut Cx<'_>) {
        let (nu, nv) = if kind == PatchKind::Bilinear { (2, 2) } else { (4, 4) };
        let shape =
            shapes::patch_mesh(kind, nu, Wrap::NonPeriodic, nv, Wrap::NonPeriodic, &self.gs.attrs, params);
        self.add_shape(shape, cx);
    }

    fn patch_mesh(
        &mut self,
        kind: PatchKind,
        nu: u32,
        u_wrap: Wrap,
        nv: u32,
        v_wrap: Wrap,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        let shape = shapes::patch_mesh(kind, nu, u_wrap, nv, v_wrap, &self.gs.attrs, params);
        self.add_shape(shape, cx);
    }

    fn nu_patch(&mut self, patch: NuPatchArgs, params: ParamList, cx: &mut Cx<'_>) {
        let shape = shapes::nu_patch(patch, self.gs.attrs.trim.clone(), params);
        self.add_shape(shape, cx);
    }

    fn subdivision_mesh(
        &mut self,
        scheme: &str,
        vertices_per_face: Vec<u32>,
        vertex_indices: Vec<u32>,
        tags: Vec<SubdivisionTag>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        if scheme != "catmull-clark" {
            cx.warn(
                DiagnosticKind::Unsupported,
                format!(
                    "SubdivisionMesh scheme \"{scheme}\" is kept, but only \"catmull-clark\" is tessellated"
                ),
            );
        }
        let shape = shapes::subdivision_mesh(scheme, vertices_per_face, vertex_indices, tags, params);
        self.add_shape(shape, cx);
    }

    fn quadric(&mut self, quadric: Quadric, _params: ParamList, cx: &mut Cx<'_>) {
        self.add_shape(shapes::quadric(quadric), cx);
    }

    fn points(&mut self, params: ParamList, cx: &mut Cx<'_>) {
        self.add_shape(shapes::points(params), cx);
    }

    fn curves(
        &mut self,
        cubic: bool,
        vertices_per_curve: Vec<u32>,
        wrap: Wrap,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        let shape = shapes::curves(cubic, vertices_per_curve, wrap, self.gs.attrs.v_basis, params);
        self.add_shape(shape, cx);
    }

    fn blobby(&mut self, blobby: crate::scene::Blobby, cx: &mut Cx<'_>) {
        self.add_shape(Shape::Blobby(blobby), cx);
    }
}

/// Exporters write camera and object matrices whose projective row holds float noise
/// (`2.7e-12` instead of 0, as in the corpus's `complexnurbs1.rib`); below `f32` precision it
/// is taken as the exact affine row `(0 0 0 1)`.
fn snap_affine(mut m: DMat4) -> DMat4 {
    let r = m.row(3);
    let noise = f64::from(f32::EPSILON);
    if r.x.abs() < noise
        && r.y.abs() < noise
        && r.z.abs() < noise
        && (r.w - 1.0).abs() < noise
        && r != DVec4::W
    {
        m.x_axis.w = 0.0;
        m.y_axis.w = 0.0;
        m.z_axis.w = 0.0;
        m.w_axis.w = 1.0;
    }
    m
}

fn is_identity3(m: &[f32]) -> bool {
    m.iter().enumerate().all(|(i, &v)| v == if i % 4 == 0 { 1.0 } else { 0.0 })
}

/// `Perspective fov`: the projection of PRMan (and Aqsis, which matched it in testing), in the
/// row-vector layout `[1 0 0 0; 0 1 0 0; 0 0 f f; 0 0 -f 0]` with `f = tan(fov / 2)`:
/// screen `x = x / (z f)`, `y = y / (z f)`.
pub fn perspective_matrix(fov_degrees: f64) -> DMat4 {
    let f = (fov_degrees.to_radians() * 0.5).tan();
    DMat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, f, f, 0.0, 0.0, -f, 0.0])
}

/// `Rotate angle x y z`: the right-hand-rule rotation about the unit axis (numerically the
/// matrix pbrt and Aqsis build).
pub fn rotation_matrix(angle_degrees: f64, unit_axis: DVec3) -> DMat4 {
    DMat4::from_axis_angle(unit_axis, angle_degrees.to_radians())
}

/// `Skew angle d1 d2` (RISpec §4.3): shears along `d2` so that `d1` turns by `angle` towards
/// `d2`, leaving the plane of `d1` and `d2` (and every plane parallel to it) in place.
/// With `d1 = cos(a) d2 + sin(a) o` (`o` the unit vector in the plane, perpendicular to `d2`),
/// points move by `s (p . o) d2` with `s = cot(a - angle) - cot(a)`.
pub fn skew_matrix(angle_degrees: f64, d1: DVec3, d2: DVec3) -> Result<DMat4, String> {
    let (l1, l2) = (d1.length(), d2.length());
    if !(l1 > 0.0 && l2 > 0.0 && l1.is_finite() && l2.is_finite()) {
        return Err("both vectors need a non-zero length".into());
    }
    let (d1, d2) = (d1 / l1, d2 / l2);
    let par = d1.dot(d2).clamp(-1.0, 1.0);
    let a = par.acos();
    let o = d1 - par * d2;
    let perp = o.length();
    if perp < 1e-12 {
        return Err("the two vectors are parallel".into());
    }
    let o = o / perp;
    let angle = angle_degrees.to_radians();
    let b = a - angle;
    if !(b > 0.0 && b < std::f64::consts::PI) {
        return Err(format!(
            "angle {angle_degrees} skews past the axis (must be between {} and {})",
            (a - std::f64::consts::PI).to_degrees(),
            a.to_degrees()
        ));
    }
    let s = 1.0 / b.tan() - par / perp;
    // p' = p + s (o . p) d2, i.e. I + s d2 o^T.
    let shear = glam::DMat3::from_cols(d2 * (s * o.x), d2 * (s * o.y), d2 * (s * o.z));
    Ok(DMat4::from_mat3(glam::DMat3::IDENTITY + shear))
}

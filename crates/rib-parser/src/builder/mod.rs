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
//! the frame [`BuildOptions::frame`] names, or by default the first world of the file that is
//! not a shadow-map pass (a frame whose displays all write depth only, as scenes render their
//! shadow maps before the image; ray-traced shadows supersede them), or the first world when
//! every one is.

mod attributes;
mod blocks;
mod deform;
mod lights;
mod objects;
mod options;
mod resources;
mod shapes;
mod teapot;
mod transforms;

use crate::diagnostics::{DiagnosticKind, Diagnostics};
use crate::limits::Limits;
use crate::motion::TransformMotion;
use crate::scene::*;
use crate::target::{Cx, NuPatchBasis, Quadric, RibTarget, ShaderSlot};
use depth_remap::CameraSettings;
use glam::{DMat4, DVec3};
use std::collections::HashMap;
use std::sync::Arc;

pub(crate) use attributes::AttrState;
pub use lights::{ENVIRONMENT_LIGHTS, ENVIRONMENT_MAP_PARAMS, EnvironmentLight, environment_light};
use objects::ObjectDef;
pub use options::background_color;

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
    /// Every display of the frame writes depth only (`"zfile"`, `"shadow"`, `"deepshad"` or
    /// mode `"z"`): a shadow-map pass, superseded by ray-traced shadows.
    pub shadow_pass: bool,
}

/// What the builder produced.
#[derive(Clone, Debug)]
pub struct Built {
    pub scene: Scene,
    /// Every frame of the file, in order (empty when the file has no `FrameBegin`).
    pub frames: Vec<FrameInfo>,
    /// Where `MakeShadow` was requested: no map is made, shadows are ray traced exactly.
    pub superseded_shadow_maps: Vec<FileLoc>,
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
    /// The current transformation at each key time when a `MotionBegin` block moved it;
    /// `ctm` is then its value at shutter open.
    motion: Option<Arc<TransformMotion>>,
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
    solids: Vec<Solid>,
    /// Indices into `solids` of the open world solid blocks, innermost last.
    open_solids: Vec<u32>,
    objects: Vec<ObjectDefinition>,
    /// Builder definition index -> this world's object id.
    object_ids: HashMap<usize, ObjectId>,
    instances: Vec<ObjectInstanceEntity>,
    coordinate_systems: Vec<(String, DMat4)>,
    light_handles: HashMap<Handle, LightId>,
}

/// An open `MotionBegin` block.
struct Motion {
    times: Vec<f64>,
    /// Its transformation requests, one per key time.
    transforms: Vec<MotionStep>,
    /// Its other requests (geometry, lights, attributes): only the first is used, except
    /// that geometry requests after a first one become its deformation keys.
    others: usize,
    /// Lights, attributes and instances among `others`: these keep their first sample.
    non_geometry: usize,
    /// Where the first request's shapes went when it was geometry: the world's shapes from
    /// this index on (`None` in an object definition or outside the world).
    first_shapes: Option<usize>,
    first_is_geometry: bool,
    /// The shapes of each later geometry request, where it was given.
    later_shapes: Vec<(Vec<Shape>, FileLoc)>,
}

/// One transformation request inside a motion block.
#[derive(Clone, Copy)]
enum MotionStep {
    /// `Translate`, `Rotate`, `Scale`, `Skew`, `ConcatTransform`, `Perspective`.
    Concat(DMat4),
    /// `Identity`, `Transform`, `CoordSysTransform`.
    Set(DMat4),
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
    /// The kept world is a shadow-map pass (replaced by the next world that is not one, unless
    /// a frame was asked for).
    kept_shadow_pass: bool,
    superseded_shadow_maps: Vec<FileLoc>,
    /// Saved graphics states by name, one map per `ResourceBegin` scope (outermost first).
    resources: Vec<HashMap<String, resources::SavedState>>,
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
            gs: GraphicsState { ctm: DMat4::IDENTITY, motion: None, attrs: AttrState::default() },
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
            kept_shadow_pass: false,
            superseded_shadow_maps: Vec::new(),
            resources: vec![HashMap::new()],
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
        self.kept.map(|scene| Built {
            scene,
            frames: self.frames,
            superseded_shadow_maps: self.superseded_shadow_maps,
        })
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

    /// Inside a motion block only the first light, attribute or instance request is used
    /// (they are not motion blurred); the rest are skipped.
    fn skip_motion_sample(&mut self) -> bool {
        match &mut self.motion {
            Some(m) => {
                m.others += 1;
                m.non_geometry += 1;
                m.others > 1
            }
            None => false,
        }
    }

    /// Inside a motion block, records a transformation request as the next key and returns
    /// true; outside one returns false.
    fn record_motion_step(&mut self, step: MotionStep) -> bool {
        match &mut self.motion {
            Some(m) => {
                m.transforms.push(step);
                true
            }
            None => false,
        }
    }

    /// The scene time of shutter open (`Shutter`'s first value, 0 without one as RISpec says).
    fn shutter_open(&self) -> f64 {
        self.opts.render.shutter.map_or(0.0, |(open, _)| f64::from(open))
    }

    fn world_mut(&mut self) -> Option<&mut WorldState> {
        self.world.as_mut()
    }

    /// The id of the current attributes in this world's table, adding them if they changed.
    fn intern_attributes(&mut self) -> AttributesId {
        let Some(world) = self.world.as_mut() else { return AttributesId(0) };
        attributes::intern(&mut self.gs.attrs, &mut world.attributes)
    }
}

/// Routes each request to its body, kept in the file of its kind: `blocks.rs` (frame, world,
/// attribute, transform, solid and motion blocks), `options.rs`, `attributes.rs`, `lights.rs`,
/// `transforms.rs`, `shapes.rs` (geometry), `objects.rs` (object definitions and instances) and
/// `resources.rs` (conditional expressions' variables, `Resource`).
impl RibTarget for SceneBuilder {
    fn version(&mut self, _version: f64, _cx: &mut Cx<'_>) {}

    fn frame_begin(&mut self, frame: i32, cx: &mut Cx<'_>) {
        SceneBuilder::frame_begin(self, frame, cx)
    }

    fn frame_end(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::frame_end(self, cx)
    }

    fn world_begin(&mut self, cx: &mut Cx<'_>) {
        self.begin_world(cx);
    }

    fn world_end(&mut self, cx: &mut Cx<'_>) {
        self.end_world(cx);
    }

    fn attribute_begin(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::attribute_begin(self, cx)
    }

    fn attribute_end(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::attribute_end(self, cx)
    }

    fn transform_begin(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::transform_begin(self, cx)
    }

    fn transform_end(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::transform_end(self, cx)
    }

    fn solid_begin(&mut self, operation: &str, cx: &mut Cx<'_>) {
        SceneBuilder::solid_begin(self, operation, cx)
    }

    fn solid_end(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::solid_end(self, cx)
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
        SceneBuilder::motion_begin(self, times, cx)
    }

    fn motion_end(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::motion_end(self, cx)
    }

    fn format(&mut self, x: i32, y: i32, pixel_aspect: f64, cx: &mut Cx<'_>) {
        SceneBuilder::format(self, x, y, pixel_aspect, cx)
    }

    fn frame_aspect_ratio(&mut self, ratio: f64, cx: &mut Cx<'_>) {
        SceneBuilder::frame_aspect_ratio(self, ratio, cx)
    }

    fn screen_window(&mut self, left: f64, right: f64, bottom: f64, top: f64, cx: &mut Cx<'_>) {
        SceneBuilder::screen_window(self, left, right, bottom, top, cx)
    }

    fn crop_window(&mut self, x_min: f64, x_max: f64, y_min: f64, y_max: f64, cx: &mut Cx<'_>) {
        SceneBuilder::crop_window(self, x_min, x_max, y_min, y_max, cx)
    }

    fn projection(&mut self, name: &str, params: ParamList, fov_degrees: Option<f64>, cx: &mut Cx<'_>) {
        SceneBuilder::projection(self, name, params, fov_degrees, cx)
    }

    fn clipping(&mut self, near: f64, far: f64, cx: &mut Cx<'_>) {
        SceneBuilder::clipping(self, near, far, cx)
    }

    fn clipping_plane(&mut self, point: DVec3, normal: DVec3, cx: &mut Cx<'_>) {
        SceneBuilder::clipping_plane(self, point, normal, cx)
    }

    fn shutter(&mut self, open: f32, close: f32, cx: &mut Cx<'_>) {
        SceneBuilder::shutter(self, open, close, cx)
    }

    fn depth_of_field(&mut self, settings: Option<[f32; 3]>, cx: &mut Cx<'_>) {
        SceneBuilder::depth_of_field(self, settings, cx)
    }

    fn pixel_samples(&mut self, x: f32, y: f32, cx: &mut Cx<'_>) {
        SceneBuilder::pixel_samples(self, x, y, cx)
    }

    fn pixel_filter(&mut self, name: &str, x_width: f32, y_width: f32, cx: &mut Cx<'_>) {
        SceneBuilder::pixel_filter(self, name, x_width, y_width, cx)
    }

    fn exposure(&mut self, gain: f32, gamma: f32, cx: &mut Cx<'_>) {
        SceneBuilder::exposure(self, gain, gamma, cx)
    }

    fn quantize(&mut self, kind: &str, one: i32, min: i32, max: i32, dither: f32, cx: &mut Cx<'_>) {
        SceneBuilder::quantize(self, kind, one, min, max, dither, cx)
    }

    fn display(&mut self, name: &str, driver: &str, mode: &str, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::display(self, name, driver, mode, params, cx)
    }

    fn hider(&mut self, name: &str, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::hider(self, name, params, cx)
    }

    fn color_samples(&mut self, n_to_rgb: Vec<f32>, rgb_to_n: Vec<f32>, cx: &mut Cx<'_>) {
        SceneBuilder::color_samples(self, n_to_rgb, rgb_to_n, cx)
    }

    fn option(&mut self, namespace: &str, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::option(self, namespace, params, cx)
    }

    fn surface_integrator(&mut self, call: ShaderCall, cx: &mut Cx<'_>) {
        SceneBuilder::surface_integrator(self, call, cx)
    }

    fn color(&mut self, color: &[f32], cx: &mut Cx<'_>) {
        SceneBuilder::color(self, color, cx)
    }

    fn opacity(&mut self, opacity: &[f32], cx: &mut Cx<'_>) {
        SceneBuilder::opacity(self, opacity, cx)
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
        SceneBuilder::shader(self, slot, call, cx)
    }

    fn shading_rate(&mut self, rate: f32, cx: &mut Cx<'_>) {
        SceneBuilder::shading_rate(self, rate, cx)
    }

    fn matte(&mut self, on: bool, cx: &mut Cx<'_>) {
        SceneBuilder::matte(self, on, cx)
    }

    fn orientation(&mut self, orientation: &str, cx: &mut Cx<'_>) {
        SceneBuilder::orientation(self, orientation, cx)
    }

    fn reverse_orientation(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::reverse_orientation(self, cx)
    }

    fn sides(&mut self, sides: i32, cx: &mut Cx<'_>) {
        SceneBuilder::sides(self, sides, cx)
    }

    fn attribute(&mut self, namespace: &str, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::attribute(self, namespace, params, cx)
    }

    fn basis(&mut self, u: Basis, v: Basis, cx: &mut Cx<'_>) {
        SceneBuilder::basis(self, u, v, cx)
    }

    fn trim_curve(&mut self, trim: TrimCurves, cx: &mut Cx<'_>) {
        SceneBuilder::trim_curve(self, trim, cx)
    }

    fn identity(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::identity(self, cx)
    }

    fn transform(&mut self, matrix: DMat4, cx: &mut Cx<'_>) {
        SceneBuilder::transform(self, matrix, cx)
    }

    fn concat_transform(&mut self, matrix: DMat4, cx: &mut Cx<'_>) {
        SceneBuilder::concat_transform(self, matrix, cx)
    }

    fn perspective(&mut self, fov_degrees: f64, cx: &mut Cx<'_>) {
        SceneBuilder::perspective(self, fov_degrees, cx)
    }

    fn translate(&mut self, delta: DVec3, cx: &mut Cx<'_>) {
        SceneBuilder::translate(self, delta, cx)
    }

    fn rotate(&mut self, angle_degrees: f64, axis: DVec3, cx: &mut Cx<'_>) {
        SceneBuilder::rotate(self, angle_degrees, axis, cx)
    }

    fn scale(&mut self, scale: DVec3, cx: &mut Cx<'_>) {
        SceneBuilder::scale(self, scale, cx)
    }

    fn skew(&mut self, angle_degrees: f64, from: DVec3, to: DVec3, cx: &mut Cx<'_>) {
        SceneBuilder::skew(self, angle_degrees, from, to, cx)
    }

    fn coordinate_system(&mut self, name: &str, cx: &mut Cx<'_>) {
        SceneBuilder::coordinate_system(self, name, cx)
    }

    fn coord_sys_transform(&mut self, name: &str, cx: &mut Cx<'_>) {
        SceneBuilder::coord_sys_transform(self, name, cx)
    }

    fn polygon(&mut self, vertex_count: u32, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::polygon(self, vertex_count, params, cx)
    }

    fn general_polygon(&mut self, vertices_per_loop: Vec<u32>, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::general_polygon(self, vertices_per_loop, params, cx)
    }

    fn points_polygons(
        &mut self,
        vertices_per_face: Vec<u32>,
        vertex_indices: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        SceneBuilder::points_polygons(self, vertices_per_face, vertex_indices, params, cx)
    }

    fn points_general_polygons(
        &mut self,
        loops_per_face: Vec<u32>,
        vertices_per_loop: Vec<u32>,
        vertex_indices: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        SceneBuilder::points_general_polygons(
            self,
            loops_per_face,
            vertices_per_loop,
            vertex_indices,
            params,
            cx,
        )
    }

    fn patch(&mut self, kind: PatchKind, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::patch(self, kind, params, cx)
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
        SceneBuilder::patch_mesh(self, kind, nu, u_wrap, nv, v_wrap, params, cx)
    }

    fn nu_patch(&mut self, patch: NuPatchBasis, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::nu_patch(self, patch, params, cx)
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
        SceneBuilder::subdivision_mesh(self, scheme, vertices_per_face, vertex_indices, tags, params, cx)
    }

    fn quadric(&mut self, quadric: Quadric, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::quadric(self, quadric, params, cx)
    }

    fn points(&mut self, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::points(self, params, cx)
    }

    fn curves(
        &mut self,
        cubic: bool,
        vertices_per_curve: Vec<u32>,
        wrap: Wrap,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        SceneBuilder::curves(self, cubic, vertices_per_curve, wrap, params, cx)
    }

    fn blobby(&mut self, blobby: crate::scene::Blobby, cx: &mut Cx<'_>) {
        SceneBuilder::blobby(self, blobby, cx)
    }

    fn geometry(&mut self, kind: &str, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::geometry(self, kind, params, cx)
    }

    fn imager(&mut self, call: ShaderCall, cx: &mut Cx<'_>) {
        SceneBuilder::imager(self, call, cx)
    }

    fn made_texture(&mut self, made: MadeTexture, cx: &mut Cx<'_>) {
        // A bound on the list, not on the pictures (their sizes are the renderer's limit).
        if self.opts.render.textures.len() >= 1 << 16 {
            cx.error(DiagnosticKind::Limit, "too many texture requests; this one is ignored");
            return;
        }
        self.opts.render.textures.push(made);
    }

    fn make_shadow(&mut self, cx: &mut Cx<'_>) {
        // Shadows are ray traced exactly: no map is needed (reported by `lrt-depth --stats`).
        self.superseded_shadow_maps.push(cx.loc.clone());
    }

    fn variable(&self, name: &str) -> Option<crate::conditional::Value> {
        SceneBuilder::variable(self, name)
    }

    fn resource(&mut self, handle: &str, kind: &str, params: ParamList, cx: &mut Cx<'_>) {
        SceneBuilder::resource(self, handle, kind, params, cx)
    }

    fn resource_begin(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::resource_begin(self, cx)
    }

    fn resource_end(&mut self, cx: &mut Cx<'_>) {
        SceneBuilder::resource_end(self, cx)
    }
}

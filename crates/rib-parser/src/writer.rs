//! Writes a [`Scene`] back as ASCII RIB that reads into the same scene.
//!
//! Numbers are written with the shortest representation that reads back to the same `f32` or
//! `f64`, so a round trip (scene -> RIB -> parser -> scene) is exact: same camera, options,
//! lights, shapes, transforms and attribute states. Every parameter is written with its
//! declaration inline (`"vertex point P"`), so nothing depends on `Declare` or on predeclared
//! names.
//!
//! How the scene maps to requests:
//! - the camera and options come first, then `Transform [camera_from_world]` and `WorldBegin`;
//! - each light (other than area lights) in an `AttributeBegin`/`AttributeEnd` block of its own
//!   with `Transform [world_from_light]` (so it is off outside it);
//! - each shape in its own `AttributeBegin`/`AttributeEnd` with its complete attribute state,
//!   `Illuminate` for every light (light linking), and `Transform [world_from_object]`;
//!   shapes that emit as the same area light share one enclosing block with its
//!   `AreaLightSource`;
//! - object definitions with their shapes in object space, and each instance as
//!   `ObjectInstance` in a block with the instance's attribute state.
//!
//! Limits: a definition's shapes are written with the attributes that differ from RenderMan's
//! defaults, so an instance reads back with those on top of its own state (as the builder
//! documents); an instance whose shapes were resolved differently reads back as the builder
//! resolves it. `Illuminate` cannot name an area light written later in the file.

use crate::params;
use crate::scene::*;
use glam::DMat4;
use std::fmt::Write;

/// The scene as RIB text.
pub fn write_scene(scene: &Scene) -> String {
    // A handle names the light declared last with it: earlier lights with the same handle are
    // shadowed and cannot be named by Illuminate.
    let mut last_with_handle = std::collections::HashMap::new();
    for (index, light) in scene.lights.iter().enumerate() {
        last_with_handle.insert(&light.handle, index);
    }
    let shadowed = (0..scene.lights.len()).map(|i| last_with_handle[&scene.lights[i].handle] != i).collect();
    let mut w = Writer { out: String::new(), declared: vec![false; scene.lights.len()], shadowed };
    w.scene(scene);
    w.out
}

struct Writer {
    out: String,
    /// Lights already written (only those can be named by `Illuminate`).
    declared: Vec<bool>,
    /// Lights whose handle a later light reuses.
    shadowed: Vec<bool>,
}

/// `f32` written so it reads back exactly (Rust's `Display` is the shortest round-trip form).
fn f(v: f32) -> String {
    if v.is_finite() {
        format!("{v}")
    } else if v.is_nan() {
        "0".into()
    } else if v > 0.0 {
        "1e39".into()
    } else {
        "-1e39".into()
    }
}

fn d(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else if v.is_nan() {
        "0".into()
    } else if v > 0.0 {
        "1e309".into()
    } else {
        "-1e309".into()
    }
}

fn s(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn floats(v: &[f32]) -> String {
    let items: Vec<String> = v.iter().map(|&x| f(x)).collect();
    format!("[{}]", items.join(" "))
}

fn ints<T: std::fmt::Display>(v: &[T]) -> String {
    let items: Vec<String> = v.iter().map(|x| x.to_string()).collect();
    format!("[{}]", items.join(" "))
}

fn strings(v: &[String]) -> String {
    let items: Vec<String> = v.iter().map(|x| s(x)).collect();
    format!("[{}]", items.join(" "))
}

fn matrix(m: &DMat4) -> String {
    let items: Vec<String> = m.to_cols_array().iter().map(|&x| d(x)).collect();
    format!("[{}]", items.join(" "))
}

fn handle(h: &Handle) -> String {
    match h {
        Handle::Int(i) => i.to_string(),
        Handle::Name(n) => s(n),
    }
}

fn param_list(p: &ParamList) -> String {
    let mut out = String::new();
    for p in &p.0 {
        let values = match &p.values {
            ParamValues::Floats(v) => floats(v),
            ParamValues::Ints(v) => ints(v),
            ParamValues::Strings(v) => strings(v),
        };
        let _ = write!(out, " {} {values}", s(&format!("{} {}", params::decl_string(&p.decl), p.name)));
    }
    out
}

fn basis(b: &Basis) -> String {
    format!("{} {}", floats(&b.matrix), b.step)
}

fn wrap(w: Wrap) -> &'static str {
    match w {
        Wrap::Periodic => "\"periodic\"",
        Wrap::NonPeriodic => "\"nonperiodic\"",
    }
}

impl Writer {
    fn line(&mut self, text: impl AsRef<str>) {
        self.out.push_str(text.as_ref());
        self.out.push('\n');
    }

    fn scene(&mut self, scene: &Scene) {
        self.line("##RenderMan RIB");
        self.line("version 3.04");
        if let Some(n) = scene.frame {
            self.line(format!("FrameBegin {n}"));
        }
        self.options(scene);
        match &scene.render.camera_motion {
            // The keys read back as the same motion, and its value at shutter open as the camera.
            Some(motion) => {
                let times: Vec<String> = motion.times().iter().map(|t| f(*t as f32)).collect();
                self.line(format!("MotionBegin [{}]", times.join(" ")));
                for m in motion.matrices() {
                    self.line(format!("Transform {}", matrix(m)));
                }
                self.line("MotionEnd");
            }
            None => self.line(format!("Transform {}", matrix(&scene.camera.camera_from_world))),
        }
        self.line("WorldBegin");
        // Attribute state outside every block is RenderMan's default; lights are declared
        // first so that shapes can name them in Illuminate.
        for (index, light) in scene.lights.iter().enumerate() {
            let id = Some(LightId(index as u32));
            let used_by_shapes =
                scene.shapes.iter().any(|sh| scene.attributes_of(sh.attributes).area_light == id);
            if used_by_shapes {
                continue;
            }
            self.declared[index] = true;
            if scene.attributes.iter().any(|a| a.area_light == id)
                || matches!(light.kind, LightKind::Area { .. })
            {
                // An area light no (direct) shape emits as: declared in a block of its own.
                self.line("AttributeBegin");
                self.line(format!("Transform {}", matrix(&light.world_from_light)));
                self.line(format!(
                    "AreaLightSource {} {}{}",
                    s(&light.shader.name),
                    handle(&light.handle),
                    param_list(&light.shader.params)
                ));
                self.line("AttributeEnd");
                continue;
            }
            // Declared in a block of its own, so it is off outside it; every shape block then
            // turns on exactly the lights that illuminate it. A light whose handle a later light
            // reuses cannot be named by Illuminate: it stays on when it lights every shape.
            let shadowed = self.shadowed[index];
            let everywhere = shadowed
                && scene.shapes.iter().all(|sh| {
                    scene.attributes_of(sh.attributes).illuminated_by.contains(&LightId(index as u32))
                });
            let (begin, end) = if everywhere {
                ("TransformBegin", "TransformEnd")
            } else {
                ("AttributeBegin", "AttributeEnd")
            };
            self.line(begin);
            self.line(format!("Transform {}", matrix(&light.world_from_light)));
            self.line(format!(
                "LightSource {} {}{}",
                s(&light.shader.name),
                handle(&light.handle),
                param_list(&light.shader.params)
            ));
            self.line(end);
        }
        for (name, m) in &scene.coordinate_systems {
            self.line("TransformBegin");
            self.line(format!("Transform {}", matrix(m)));
            self.line(format!("CoordinateSystem {}", s(name)));
            self.line("TransformEnd");
        }
        self.shapes(scene);
        for obj in &scene.objects {
            self.object(scene, obj);
        }
        for inst in &scene.instances {
            let Some(obj) = scene.objects.get(inst.object.0 as usize) else { continue };
            self.line("AttributeBegin");
            self.attributes(scene, scene.attributes_of(inst.attributes), true);
            self.line(format!("Transform {}", matrix(&inst.world_from_instance)));
            self.line(format!("ObjectInstance {}", handle(&obj.handle)));
            self.line("AttributeEnd");
        }
        self.line("WorldEnd");
        if scene.frame.is_some() {
            self.line("FrameEnd");
        }
    }

    fn options(&mut self, scene: &Scene) {
        let c = &scene.camera;
        self.line(format!("Format {} {} {}", c.x_resolution, c.y_resolution, d(c.pixel_aspect_ratio)));
        if let Some(r) = c.frame_aspect_ratio {
            self.line(format!("FrameAspectRatio {}", d(r)));
        }
        if let Some(w) = c.screen_window {
            self.line(format!("ScreenWindow {} {} {} {}", d(w.left), d(w.right), d(w.bottom), d(w.top)));
        }
        let cw = c.crop_window;
        if cw != depth_remap::CropWindow::default() {
            self.line(format!("CropWindow {} {} {} {}", d(cw.xmin), d(cw.xmax), d(cw.ymin), d(cw.ymax)));
        }
        match c.projection {
            depth_remap::Projection::Perspective { fov_degrees } => {
                self.line(format!("Projection \"perspective\" \"uniform float fov\" [{}]", d(fov_degrees)))
            }
            depth_remap::Projection::Orthographic => self.line("Projection \"orthographic\""),
        }
        self.line(format!("Clipping {} {}", d(c.clipping.near), d(c.clipping.far)));
        let r = &scene.render;
        self.line(format!("PixelSamples {} {}", f(r.pixel_samples.0), f(r.pixel_samples.1)));
        self.line(format!(
            "PixelFilter {} {} {}",
            s(&r.pixel_filter.name),
            f(r.pixel_filter.x_width),
            f(r.pixel_filter.y_width)
        ));
        self.line(format!("Exposure {} {}", f(r.exposure.gain), f(r.exposure.gamma)));
        let q = r.quantize;
        self.line(format!("Quantize \"rgba\" {} {} {} {}", q.one, q.min, q.max, f(q.dither)));
        if let Some(q) = r.quantize_depth {
            self.line(format!("Quantize \"z\" {} {} {} {}", q.one, q.min, q.max, f(q.dither)));
        }
        if let Some(h) = &r.hider {
            self.line(format!("Hider {}{}", s(&h.name), param_list(&h.params)));
        }
        if let Some(i) = &r.surface_integrator {
            self.line(format!("SurfaceIntegrator {}{}", s(&i.name), param_list(&i.params)));
        }
        if let Some(i) = &r.imager {
            self.line(format!("Imager {}{}", s(&i.name), param_list(&i.params)));
        }
        // Options are written in camera space, where the planes are kept.
        for plane in &r.clipping_planes {
            let (p, n) = (plane.point, plane.normal);
            self.line(format!(
                "ClippingPlane {} {} {} {} {} {}",
                d(p.x),
                d(p.y),
                d(p.z),
                d(n.x),
                d(n.y),
                d(n.z)
            ));
        }
        if let Some((open, close)) = r.shutter {
            self.line(format!("Shutter {} {}", f(open), f(close)));
        }
        if let Some(d) = r.depth_of_field {
            self.line(format!("DepthOfField {} {} {}", f(d.fstop), f(d.focal_length), f(d.focal_distance)));
        }
        for t in &r.textures {
            let (sw, tw) = (f(t.filter_width.0), f(t.filter_width.1));
            let (filter, name, params) = (s(&t.filter), s(&t.name), param_list(&t.params));
            self.line(match &t.kind {
                MadeTextureKind::Texture { picture, swrap, twrap } => format!(
                    "MakeTexture {} {name} {} {} {filter} {sw} {tw}{params}",
                    s(picture),
                    s(swrap),
                    s(twrap)
                ),
                MadeTextureKind::LatLong { picture } => {
                    format!("MakeLatLongEnvironment {} {name} {filter} {sw} {tw}{params}", s(picture))
                }
                MadeTextureKind::CubeFaces { faces, fov } => format!(
                    "MakeCubeFaceEnvironment {} {name} {} {filter} {sw} {tw}{params}",
                    faces.iter().map(|p| s(p)).collect::<Vec<_>>().join(" "),
                    f(*fov)
                ),
            });
        }
        for disp in &scene.displays {
            let name = if disp.secondary { format!("+{}", disp.name) } else { disp.name.clone() };
            self.line(format!(
                "Display {} {} {}{}",
                s(&name),
                s(&disp.driver),
                s(&disp.mode),
                param_list(&disp.params)
            ));
        }
        for o in &scene.options {
            self.line(format!("Option {}{}", s(&o.namespace), param_list(&o.params)));
        }
        if let Some(dr) = &scene.depth_request
            && dr.source == DepthRequestSource::CommandLine
        {
            self.line(format!("Option \"lrt\" \"string depthfile\" [{}]", s(&dr.path.to_string_lossy())));
        }
    }

    /// Shapes in order; consecutive shapes of the same area light share its block.
    fn shapes(&mut self, scene: &Scene) {
        let mut i = 0;
        while i < scene.shapes.len() {
            let area = scene.attributes_of(scene.shapes[i].attributes).area_light;
            let mut j = i + 1;
            while area.is_some()
                && j < scene.shapes.len()
                && scene.attributes_of(scene.shapes[j].attributes).area_light == area
            {
                j += 1;
            }
            match area.and_then(|id| scene.lights.get(id.0 as usize).map(|l| (id, l))) {
                Some((id, light)) => {
                    self.line("AttributeBegin");
                    self.line(format!("Transform {}", matrix(&light.world_from_light)));
                    self.line(format!(
                        "AreaLightSource {} {}{}",
                        s(&light.shader.name),
                        handle(&light.handle),
                        param_list(&light.shader.params)
                    ));
                    if let Some(d) = self.declared.get_mut(id.0 as usize) {
                        *d = true;
                    }
                    for shape in &scene.shapes[i..j] {
                        self.shape_block(scene, shape);
                    }
                    self.line("AttributeEnd");
                }
                None => {
                    for shape in &scene.shapes[i..j] {
                        self.shape_block(scene, shape);
                    }
                }
            }
            i = j;
        }
    }

    fn shape_block(&mut self, scene: &Scene, shape: &ShapeEntity) {
        self.line("AttributeBegin");
        self.attributes(scene, scene.attributes_of(shape.attributes), true);
        self.line(format!("Transform {}", matrix(&shape.world_from_object)));
        if shape.in_solid {
            self.line("SolidBegin \"primitive\"");
        }
        match &shape.deformation {
            // The keys read back as the same deformation, and its value at shutter open as
            // the shape.
            Some(d) => self.deformation(d),
            None => self.shape(&shape.shape),
        }
        if shape.in_solid {
            self.line("SolidEnd");
        }
        self.line("AttributeEnd");
    }

    fn object(&mut self, scene: &Scene, obj: &ObjectDefinition) {
        self.line(format!("ObjectBegin {}", handle(&obj.handle)));
        let defaults = Attributes::default();
        for shape in &obj.shapes {
            self.line("AttributeBegin");
            let a = scene.attributes_of(shape.attributes);
            self.attribute_changes(a, &defaults);
            self.line(format!("Transform {}", matrix(&shape.world_from_object)));
            self.shape(&shape.shape);
            self.line("AttributeEnd");
        }
        self.line("ObjectEnd");
    }

    /// The complete attribute state (the block starts from RenderMan's defaults).
    fn attributes(&mut self, scene: &Scene, a: &Attributes, with_lights: bool) {
        self.attribute_changes(a, &Attributes::default());
        if with_lights {
            for (index, light) in scene.lights.iter().enumerate() {
                if !self.declared[index] || self.shadowed[index] {
                    continue;
                }
                let on = a.illuminated_by.binary_search(&LightId(index as u32)).is_ok();
                self.line(format!("Illuminate {} {}", handle(&light.handle), i32::from(on)));
            }
        }
    }

    /// The attribute requests that turn `base` into `a` (lights and area lights aside).
    fn attribute_changes(&mut self, a: &Attributes, base: &Attributes) {
        if a.color != base.color {
            self.line(format!("Color [{} {} {}]", f(a.color.x), f(a.color.y), f(a.color.z)));
        }
        if a.opacity != base.opacity {
            self.line(format!("Opacity [{} {} {}]", f(a.opacity.x), f(a.opacity.y), f(a.opacity.z)));
        }
        for (request, call) in [
            ("Surface", &a.surface),
            ("Displacement", &a.displacement),
            ("Atmosphere", &a.atmosphere),
            ("Interior", &a.interior),
            ("Exterior", &a.exterior),
        ] {
            if let Some(c) = call {
                // The shader space is the transformation current at the request; the shape's
                // own `Transform` follows the attributes.
                if request == "Displacement" && a.displacement_space != DMat4::IDENTITY {
                    self.line(format!("Transform {}", matrix(&a.displacement_space)));
                }
                self.line(format!("{request} {}{}", s(&c.name), param_list(&c.params)));
            }
        }
        if a.sides != base.sides {
            self.line(format!("Sides {}", a.sides));
        }
        if a.reverse_orientation != base.reverse_orientation {
            self.line("ReverseOrientation");
        }
        if a.matte != base.matte {
            self.line(format!("Matte {}", i32::from(a.matte)));
        }
        if a.shading_rate != base.shading_rate {
            self.line(format!("ShadingRate {}", f(a.shading_rate)));
        }
        for call in &a.user {
            self.line(format!("Attribute {}{}", s(&call.namespace), param_list(&call.params)));
        }
    }

    fn shape(&mut self, shape: &Shape) {
        self.shape_with(shape, true);
    }

    /// A shape's deformation keys in a motion block; the attributes they need (`Basis`,
    /// `TrimCurve`, the same for every key) are written before it.
    fn deformation(&mut self, d: &crate::deformation::Deformation) {
        self.shape_attributes(&d.shapes()[0]);
        let times: Vec<String> = d.times().iter().map(|t| f(*t as f32)).collect();
        self.line(format!("MotionBegin [{}]", times.join(" ")));
        for key in d.shapes() {
            self.shape_with(key, false);
        }
        self.line("MotionEnd");
    }

    /// The attribute requests a shape's request depends on.
    fn shape_attributes(&mut self, shape: &Shape) {
        match shape {
            Shape::Patches(p) => self.line(format!("Basis {} {}", basis(&p.u_basis), basis(&p.v_basis))),
            Shape::Curves(c) => self.line(format!("Basis {} {}", basis(&c.v_basis), basis(&c.v_basis))),
            Shape::NuPatch(n) => {
                if let Some(t) = &n.trim {
                    self.line(format!(
                        "TrimCurve {} {} {} {} {} {} {} {} {}",
                        ints(&t.curves_per_loop),
                        ints(&t.order),
                        floats(&t.knots),
                        floats(&t.min),
                        floats(&t.max),
                        ints(&t.n),
                        floats(&t.u),
                        floats(&t.v),
                        floats(&t.w)
                    ));
                }
            }
            _ => {}
        }
    }

    /// A shape's request, after the attributes it needs when `with_attributes`.
    fn shape_with(&mut self, shape: &Shape, with_attributes: bool) {
        if with_attributes {
            self.shape_attributes(shape);
        }
        let line = match shape {
            Shape::Sphere { radius, z_min, z_max, theta_max_degrees } => {
                format!("Sphere {} {} {} {}", f(*radius), f(*z_min), f(*z_max), f(*theta_max_degrees))
            }
            Shape::Cylinder { radius, z_min, z_max, theta_max_degrees } => {
                format!("Cylinder {} {} {} {}", f(*radius), f(*z_min), f(*z_max), f(*theta_max_degrees))
            }
            Shape::Cone { height, radius, theta_max_degrees } => {
                format!("Cone {} {} {}", f(*height), f(*radius), f(*theta_max_degrees))
            }
            Shape::Disk { height, radius, theta_max_degrees } => {
                format!("Disk {} {} {}", f(*height), f(*radius), f(*theta_max_degrees))
            }
            Shape::Paraboloid { r_max, z_min, z_max, theta_max_degrees } => {
                format!("Paraboloid {} {} {} {}", f(*r_max), f(*z_min), f(*z_max), f(*theta_max_degrees))
            }
            Shape::Hyperboloid { point1: a, point2: b, theta_max_degrees } => format!(
                "Hyperboloid {} {} {} {} {} {} {}",
                f(a.x),
                f(a.y),
                f(a.z),
                f(b.x),
                f(b.y),
                f(b.z),
                f(*theta_max_degrees)
            ),
            Shape::Torus {
                major_radius,
                minor_radius,
                phi_min_degrees,
                phi_max_degrees,
                theta_max_degrees,
            } => {
                format!(
                    "Torus {} {} {} {} {}",
                    f(*major_radius),
                    f(*minor_radius),
                    f(*phi_min_degrees),
                    f(*phi_max_degrees),
                    f(*theta_max_degrees)
                )
            }
            Shape::Polygons(m) => {
                let p: Vec<f32> = m.positions.iter().flat_map(|v| v.to_array()).collect();
                format!(
                    "PointsGeneralPolygons {} {} {} \"vertex point P\" {}{}",
                    ints(&m.loops_per_face),
                    ints(&m.vertices_per_loop),
                    ints(&m.vertex_indices),
                    floats(&p),
                    param_list(&m.primvars)
                )
            }
            Shape::Patches(p) => {
                let pw: Vec<f32> = p.positions.iter().flat_map(|v| v.to_array()).collect();
                let kind = match p.kind {
                    PatchKind::Bilinear => "bilinear",
                    PatchKind::Bicubic => "bicubic",
                };
                format!(
                    "PatchMesh \"{kind}\" {} {} {} {} \"vertex hpoint Pw\" {}{}",
                    p.nu,
                    wrap(p.u_wrap),
                    p.nv,
                    wrap(p.v_wrap),
                    floats(&pw),
                    param_list(&p.primvars)
                )
            }
            Shape::NuPatch(n) => {
                let pw: Vec<f32> = n.positions.iter().flat_map(|v| v.to_array()).collect();
                format!(
                    "NuPatch {} {} {} {} {} {} {} {} {} {} \"vertex hpoint Pw\" {}{}",
                    n.basis.nu,
                    n.basis.u_order,
                    floats(&n.basis.u_knots),
                    f(n.basis.u_min),
                    f(n.basis.u_max),
                    n.basis.nv,
                    n.basis.v_order,
                    floats(&n.basis.v_knots),
                    f(n.basis.v_min),
                    f(n.basis.v_max),
                    floats(&pw),
                    param_list(&n.primvars)
                )
            }
            Shape::SubdivisionMesh(m) => {
                let names: Vec<String> = m.tags.iter().map(|t| t.name.clone()).collect();
                let with_strings = m.tags.iter().any(|t| !t.string_args.is_empty());
                let mut nargs = Vec::new();
                for t in &m.tags {
                    nargs.push(t.int_args.len());
                    nargs.push(t.float_args.len());
                    if with_strings {
                        nargs.push(t.string_args.len());
                    }
                }
                let int_args: Vec<i32> = m.tags.iter().flat_map(|t| t.int_args.iter().copied()).collect();
                let float_args: Vec<f32> = m.tags.iter().flat_map(|t| t.float_args.iter().copied()).collect();
                let string_args: Vec<String> =
                    m.tags.iter().flat_map(|t| t.string_args.iter().cloned()).collect();
                let p: Vec<f32> = m.positions.iter().flat_map(|v| v.to_array()).collect();
                let strings_part =
                    if with_strings { format!(" {}", strings(&string_args)) } else { String::new() };
                format!(
                    "SubdivisionMesh {} {} {} {} {} {} {}{} \"vertex point P\" {}{}",
                    s(&m.scheme),
                    ints(&m.vertices_per_face),
                    ints(&m.vertex_indices),
                    strings(&names),
                    ints(&nargs),
                    ints(&int_args),
                    floats(&float_args),
                    strings_part,
                    floats(&p),
                    param_list(&m.primvars)
                )
            }
            Shape::Points(p) => {
                let pos: Vec<f32> = p.positions.iter().flat_map(|v| v.to_array()).collect();
                format!("Points \"vertex point P\" {}{}", floats(&pos), param_list(&p.primvars))
            }
            Shape::Blobby(b) => format!(
                "Blobby {} {} {} {}{}",
                b.leaf_count,
                ints(&b.code),
                floats(&b.floats),
                strings(&b.strings),
                param_list(&b.primvars)
            ),
            Shape::Curves(c) => {
                let pos: Vec<f32> = c.positions.iter().flat_map(|v| v.to_array()).collect();
                format!(
                    "Curves {} {} {} \"vertex point P\" {}{}",
                    if c.cubic { "\"cubic\"" } else { "\"linear\"" },
                    ints(&c.vertices_per_curve),
                    wrap(c.wrap),
                    floats(&pos),
                    param_list(&c.primvars)
                )
            }
        };
        self.line(line);
    }
}

//! Human-readable descriptions of a [`Scene`]: counts for `lrt-depth --check`, and a stable
//! multi-line dump used by the data-driven fixtures (`fixtures/rib/ok/*.dump`).

use crate::params;
use crate::scene::*;
use depth_remap::Projection;
use glam::DMat4;
use std::fmt::Write;

/// How many of each thing a scene has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneCounts {
    /// Shapes placed directly in the world.
    pub shapes: usize,
    /// Shapes placed through object instances (definition shapes x instances).
    pub instanced_shapes: usize,
    pub lights: usize,
    pub area_lights: usize,
    pub objects: usize,
    pub instances: usize,
    pub attribute_states: usize,
}

impl SceneCounts {
    pub fn of(scene: &Scene) -> SceneCounts {
        let instanced_shapes = scene
            .instances
            .iter()
            .map(|i| scene.objects.get(i.object.0 as usize).map_or(0, |o| o.shapes.len()))
            .sum();
        SceneCounts {
            shapes: scene.shapes.len(),
            instanced_shapes,
            lights: scene.lights.len(),
            area_lights: scene.lights.iter().filter(|l| matches!(l.kind, LightKind::Area { .. })).count(),
            objects: scene.objects.len(),
            instances: scene.instances.len(),
            attribute_states: scene.attributes.len(),
        }
    }

    /// All shapes the scene places, direct and instanced.
    pub fn total_shapes(&self) -> usize {
        self.shapes + self.instanced_shapes
    }
}

/// The name of a shape's kind as a RIB request would call it.
pub fn shape_kind(shape: &Shape) -> &'static str {
    match shape {
        Shape::Sphere { .. } => "Sphere",
        Shape::Cylinder { .. } => "Cylinder",
        Shape::Cone { .. } => "Cone",
        Shape::Disk { .. } => "Disk",
        Shape::Paraboloid { .. } => "Paraboloid",
        Shape::Hyperboloid { .. } => "Hyperboloid",
        Shape::Torus { .. } => "Torus",
        Shape::Polygons(_) => "Polygons",
        Shape::Patches(_) => "PatchMesh",
        Shape::NuPatch(_) => "NuPatch",
        Shape::SubdivisionMesh(_) => "SubdivisionMesh",
        Shape::Points(_) => "Points",
        Shape::Curves(_) => "Curves",
        Shape::Blobby(_) => "Blobby",
    }
}

/// A number printed with at most 6 decimals and no trailing zeros (stable across platforms for
/// the fixtures).
fn n(v: f64) -> String {
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let s = format!("{v:.6}");
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
    if s == "-0" { "0".into() } else { s }
}

fn n32(v: f32) -> String {
    n(f64::from(v))
}

fn v3(v: glam::Vec3) -> String {
    format!("({} {} {})", n32(v.x), n32(v.y), n32(v.z))
}

fn dv3(v: glam::DVec3) -> String {
    format!("({} {} {})", n(v.x), n(v.y), n(v.z))
}

/// ` motion=[t0: m0; t1: m1 ...]` for a moving transformation, empty otherwise.
fn motion_text(motion: Option<&crate::motion::TransformMotion>) -> String {
    let Some(motion) = motion else { return String::new() };
    let keys: Vec<String> =
        motion.times().iter().zip(motion.matrices()).map(|(t, m)| format!("{}: {}", n(*t), mat(m))).collect();
    format!(" motion=[{}]", keys.join("; "))
}

/// A matrix as `identity` or its 16 numbers in RIB's row-vector order.
fn mat(m: &DMat4) -> String {
    if m.abs_diff_eq(DMat4::IDENTITY, 0.0) {
        return "identity".into();
    }
    let a = m.to_cols_array();
    format!("[{}]", a.iter().map(|&x| n(x)).collect::<Vec<_>>().join(" "))
}

fn handle(h: &Handle) -> String {
    match h {
        Handle::Int(i) => i.to_string(),
        Handle::Name(s) => format!("\"{s}\""),
    }
}

fn params_text(p: &ParamList) -> String {
    let items: Vec<String> =
        p.0.iter()
            .map(|p| {
                let values = match &p.values {
                    ParamValues::Floats(v) if v.len() <= 8 => {
                        v.iter().map(|&x| n32(x)).collect::<Vec<_>>().join(" ")
                    }
                    ParamValues::Ints(v) if v.len() <= 8 => {
                        v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ")
                    }
                    ParamValues::Strings(v) if v.len() <= 8 => {
                        v.iter().map(|s| format!("{s:?}")).collect::<Vec<_>>().join(" ")
                    }
                    other => format!("<{} values>", other.len()),
                };
                format!("\"{} {}\" [{}]", params::decl_string(&p.decl), p.name, values)
            })
            .collect();
    items.join(" ")
}

fn call(c: &Option<ShaderCall>) -> String {
    match c {
        Some(c) if c.params.0.is_empty() => format!("\"{}\"", c.name),
        Some(c) => format!("\"{}\" {}", c.name, params_text(&c.params)),
        None => "-".into(),
    }
}

fn shape_text(shape: &Shape) -> String {
    match shape {
        Shape::Sphere { radius, z_min, z_max, theta_max_degrees } => {
            format!(
                "Sphere r={} z=[{} {}] theta={}",
                n32(*radius),
                n32(*z_min),
                n32(*z_max),
                n32(*theta_max_degrees)
            )
        }
        Shape::Cylinder { radius, z_min, z_max, theta_max_degrees } => {
            format!(
                "Cylinder r={} z=[{} {}] theta={}",
                n32(*radius),
                n32(*z_min),
                n32(*z_max),
                n32(*theta_max_degrees)
            )
        }
        Shape::Cone { height, radius, theta_max_degrees } => {
            format!("Cone h={} r={} theta={}", n32(*height), n32(*radius), n32(*theta_max_degrees))
        }
        Shape::Disk { height, radius, theta_max_degrees } => {
            format!("Disk h={} r={} theta={}", n32(*height), n32(*radius), n32(*theta_max_degrees))
        }
        Shape::Paraboloid { r_max, z_min, z_max, theta_max_degrees } => {
            format!(
                "Paraboloid r={} z=[{} {}] theta={}",
                n32(*r_max),
                n32(*z_min),
                n32(*z_max),
                n32(*theta_max_degrees)
            )
        }
        Shape::Hyperboloid { point1, point2, theta_max_degrees } => {
            format!("Hyperboloid {} {} theta={}", v3(*point1), v3(*point2), n32(*theta_max_degrees))
        }
        Shape::Torus { major_radius, minor_radius, phi_min_degrees, phi_max_degrees, theta_max_degrees } => {
            format!(
                "Torus R={} r={} phi=[{} {}] theta={}",
                n32(*major_radius),
                n32(*minor_radius),
                n32(*phi_min_degrees),
                n32(*phi_max_degrees),
                n32(*theta_max_degrees)
            )
        }
        Shape::Polygons(m) => format!(
            "Polygons faces={} loops={} indices={} positions={} first={} primvars=[{}]",
            m.loops_per_face.len(),
            m.vertices_per_loop.len(),
            m.vertex_indices.len(),
            m.positions.len(),
            m.positions.first().map_or("-".into(), |p| v3(*p)),
            primvar_names(&m.primvars)
        ),
        Shape::Patches(p) => format!(
            "PatchMesh {:?} {}x{} wrap={:?}/{:?} steps={}/{} primvars=[{}]",
            p.kind,
            p.nu,
            p.nv,
            p.u_wrap,
            p.v_wrap,
            p.u_basis.step,
            p.v_basis.step,
            primvar_names(&p.primvars)
        ),
        Shape::NuPatch(p) => format!(
            "NuPatch {}x{} order={}x{} trimmed={} primvars=[{}]",
            p.basis.nu,
            p.basis.nv,
            p.basis.u_order,
            p.basis.v_order,
            p.trim.is_some(),
            primvar_names(&p.primvars)
        ),
        Shape::SubdivisionMesh(s) => format!(
            "SubdivisionMesh \"{}\" faces={} vertices={} tags=[{}] primvars=[{}]",
            s.scheme,
            s.vertices_per_face.len(),
            s.positions.len(),
            s.tags.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(" "),
            primvar_names(&s.primvars)
        ),
        Shape::Points(p) => {
            format!("Points n={} primvars=[{}]", p.positions.len(), primvar_names(&p.primvars))
        }
        Shape::Blobby(b) => format!(
            "Blobby leaves={} code={} floats={} primvars=[{}]",
            b.leaf_count,
            b.code.len(),
            b.floats.len(),
            primvar_names(&b.primvars)
        ),
        Shape::Curves(c) => format!(
            "Curves {} n={} vertices={} wrap={:?}",
            if c.cubic { "cubic" } else { "linear" },
            c.vertices_per_curve.len(),
            c.positions.len(),
            c.wrap
        ),
    }
}

fn primvar_names(p: &ParamList) -> String {
    p.0.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(" ")
}

fn light_kind(k: &LightKind) -> String {
    match k {
        LightKind::Ambient { intensity, color } => {
            format!("ambient intensity={} color={}", n32(*intensity), v3(*color))
        }
        LightKind::Distant { direction, intensity, color } => {
            format!(
                "distant direction={} intensity={} color={}",
                dv3(*direction),
                n32(*intensity),
                v3(*color)
            )
        }
        LightKind::Point { position, intensity, color } => {
            format!("point position={} intensity={} color={}", dv3(*position), n32(*intensity), v3(*color))
        }
        LightKind::Spot {
            position,
            direction,
            intensity,
            color,
            cone_angle,
            cone_delta_angle,
            beam_distribution,
        } => {
            format!(
                "spot position={} direction={} intensity={} color={} cone={} delta={} beam={}",
                dv3(*position),
                dv3(*direction),
                n32(*intensity),
                v3(*color),
                n32(*cone_angle),
                n32(*cone_delta_angle),
                n32(*beam_distribution)
            )
        }
        LightKind::Area { intensity, color } => {
            format!("area intensity={} color={}", n32(*intensity), v3(*color))
        }
        LightKind::Other => "other".into(),
    }
}

/// A stable, complete-enough textual dump of a scene: camera, options, lights, attribute states,
/// shapes (with their transforms and locations) and instances.
pub fn dump(scene: &Scene) -> String {
    let mut o = String::new();
    let c = &scene.camera;
    let _ = writeln!(o, "frame: {}", scene.frame.map_or("-".into(), |f| f.to_string()));
    let projection = match c.projection {
        Projection::Perspective { fov_degrees } => format!("perspective fov={}", n(fov_degrees)),
        Projection::Orthographic => "orthographic".into(),
    };
    let _ = writeln!(
        o,
        "camera: {}x{} pixel_aspect={} frame_aspect={} {} clipping=[{} {}]",
        c.x_resolution,
        c.y_resolution,
        n(c.pixel_aspect_ratio),
        c.frame_aspect_ratio.map_or("-".into(), n),
        projection,
        n(c.clipping.near),
        n(c.clipping.far)
    );
    if let Some(w) = c.screen_window {
        let _ = writeln!(o, "screen_window: [{} {} {} {}]", n(w.left), n(w.right), n(w.bottom), n(w.top));
    }
    let cw = c.crop_window;
    if cw != depth_remap::CropWindow::default() {
        let _ = writeln!(o, "crop_window: [{} {} {} {}]", n(cw.xmin), n(cw.xmax), n(cw.ymin), n(cw.ymax));
    }
    let _ = writeln!(o, "camera_from_world: {}", mat(&c.camera_from_world));
    let r = &scene.render;
    let _ = writeln!(
        o,
        "render: samples={}x{} filter=\"{}\" {}x{} exposure={} {} quantize={} {} {} {}",
        n32(r.pixel_samples.0),
        n32(r.pixel_samples.1),
        r.pixel_filter.name,
        n32(r.pixel_filter.x_width),
        n32(r.pixel_filter.y_width),
        n32(r.exposure.gain),
        n32(r.exposure.gamma),
        r.quantize.one,
        r.quantize.min,
        r.quantize.max,
        n32(r.quantize.dither)
    );
    if r.hider.is_some() {
        let _ = writeln!(o, "hider: {}", call(&r.hider));
    }
    if r.surface_integrator.is_some() {
        let _ = writeln!(o, "surface_integrator: {}", call(&r.surface_integrator));
    }
    if let Some((a, b)) = r.shutter {
        let _ = writeln!(o, "shutter: {} {}", n32(a), n32(b));
    }
    for d in &scene.displays {
        let _ = writeln!(
            o,
            "display: {}\"{}\" \"{}\" \"{}\" {}",
            if d.secondary { "+" } else { "" },
            d.name,
            d.driver,
            d.mode,
            params_text(&d.params)
        );
    }
    if let Some(dr) = &scene.depth_request {
        let _ = writeln!(o, "depth_request: {} ({:?})", dr.path.display(), dr.source);
    }
    for opt in &scene.options {
        let _ = writeln!(o, "option: \"{}\" {}", opt.namespace, params_text(&opt.params));
    }
    for (name, m) in &scene.coordinate_systems {
        let _ = writeln!(o, "coordinate_system: \"{name}\" {}", mat(m));
    }
    for (i, l) in scene.lights.iter().enumerate() {
        let _ = writeln!(
            o,
            "light {i}: handle={} shader=\"{}\" {} world_from_light={}",
            handle(&l.handle),
            l.shader.name,
            light_kind(&l.kind),
            mat(&l.world_from_light)
        );
    }
    for (i, a) in scene.attributes.iter().enumerate() {
        let lights: Vec<String> = a.illuminated_by.iter().map(|l| l.0.to_string()).collect();
        let user: Vec<String> =
            a.user.iter().map(|c| format!("\"{}\" {}", c.namespace, params_text(&c.params))).collect();
        let user = if user.is_empty() { String::new() } else { format!(" attributes=[{}]", user.join("; ")) };
        let _ = writeln!(
            o,
            "attributes {i}: color={} opacity={} surface={} sides={} reverse={} area={} lights=[{}]{}{}{}{}",
            v3(a.color),
            v3(a.opacity),
            call(&a.surface),
            a.sides,
            a.reverse_orientation,
            a.area_light.map_or("-".into(), |l| l.0.to_string()),
            lights.join(" "),
            a.name.as_ref().map_or(String::new(), |n| format!(" name=\"{n}\"")),
            if a.matte { " matte" } else { "" },
            haptic_text(&a.haptic),
            user
        );
    }
    for (i, s) in scene.shapes.iter().enumerate() {
        let _ = writeln!(
            o,
            "shape {i}: {} attributes={}{} world_from_object={}{} at {}",
            shape_text(&s.shape),
            s.attributes.0,
            if s.in_solid { " solid" } else { "" },
            mat(&s.world_from_object),
            motion_text(s.motion.as_deref()),
            s.loc
        );
    }
    for (i, solid) in scene.solids.iter().enumerate() {
        let parts: Vec<String> = solid
            .parts
            .iter()
            .map(|p| match p {
                SolidPart::Solid(k) => format!("solid {k}"),
                SolidPart::Shape(k) => format!("shape {k}"),
            })
            .collect();
        let _ = writeln!(
            o,
            "solid {i}: {:?} parent={} parts=[{}] at {}",
            solid.op,
            solid.parent.map_or("-".into(), |p| p.to_string()),
            parts.join(", "),
            solid.loc
        );
    }
    for (i, obj) in scene.objects.iter().enumerate() {
        let _ = writeln!(
            o,
            "object {i}: handle={} shapes={} at {}",
            handle(&obj.handle),
            obj.shapes.len(),
            obj.loc
        );
        for (j, s) in obj.shapes.iter().enumerate() {
            let _ = writeln!(
                o,
                "  shape {j}: {} object_from_shape={}",
                shape_text(&s.shape),
                mat(&s.world_from_object)
            );
        }
    }
    for (i, inst) in scene.instances.iter().enumerate() {
        let ids: Vec<String> = inst.shape_attributes.iter().map(|a| a.0.to_string()).collect();
        let _ = writeln!(
            o,
            "instance {i}: object={} attributes={} shape_attributes=[{}] world_from_instance={}{} at {}",
            inst.object.0,
            inst.attributes.0,
            ids.join(" "),
            mat(&inst.world_from_instance),
            motion_text(inst.motion.as_deref()),
            inst.loc
        );
    }
    o
}

fn haptic_text(h: &HapticMaterial) -> String {
    let mut s = String::new();
    for (name, v) in [
        ("stiffness", h.stiffness),
        ("friction", h.friction),
        ("staticfriction", h.static_friction),
        ("dynamicfriction", h.dynamic_friction),
    ] {
        if let Some(v) = v {
            let _ = write!(s, " haptic.{name}={}", n32(v));
        }
    }
    s
}

//! The parser drives a `RibTarget` with typed, validated calls and never builds a scene: a
//! recording target sees exactly what each request means.

use glam::{DMat4, DVec3};
use rib_parser::scene::*;
use rib_parser::target::{Cx, NuPatchBasis, Quadric, RibTarget, ShaderSlot};
use rib_parser::{ReadOptions, Reader};

/// Records every call as `name arg=value ...`.
#[derive(Default)]
struct Recorder(Vec<String>);

macro_rules! record {
    ($($name:ident($($arg:ident: $ty:ty),*);)*) => {
        $(fn $name(&mut self, $($arg: $ty,)* _cx: &mut Cx<'_>) {
            #[allow(unused_mut)]
            let mut line = String::from(stringify!($name));
            $(line.push_str(&format!(" {}={:?}", stringify!($arg), $arg));)*
            self.0.push(line);
        })*
    };
}

impl RibTarget for Recorder {
    record! {
        frame_begin(frame: i32);
        frame_end();
        world_begin();
        world_end();
        attribute_begin();
        attribute_end();
        transform_begin();
        transform_end();
        solid_begin(operation: &str);
        solid_end();
        object_begin(handle: Handle);
        object_end();
        object_instance(handle: Handle);
        motion_begin(times: &[f32]);
        motion_end();
        format(x: i32, y: i32, aspect: f64);
        frame_aspect_ratio(ratio: f64);
        screen_window(l: f64, r: f64, b: f64, t: f64);
        crop_window(x0: f64, x1: f64, y0: f64, y1: f64);
        projection(name: &str, params: ParamList, fov: Option<f64>);
        clipping(near: f64, far: f64);
        shutter(open: f32, close: f32);
        pixel_samples(x: f32, y: f32);
        pixel_filter(name: &str, xw: f32, yw: f32);
        exposure(gain: f32, gamma: f32);
        quantize(kind: &str, one: i32, min: i32, max: i32, dither: f32);
        display(name: &str, driver: &str, mode: &str, params: ParamList);
        hider(name: &str, params: ParamList);
        color_samples(n_to_rgb: Vec<f32>, rgb_to_n: Vec<f32>);
        option(namespace: &str, params: ParamList);
        surface_integrator(call: ShaderCall);
        color(color: &[f32]);
        opacity(opacity: &[f32]);
        light_source(call: ShaderCall, handle: Handle);
        area_light_source(call: ShaderCall, handle: Handle);
        illuminate(handle: Handle, on: bool);
        shader(slot: ShaderSlot, call: ShaderCall);
        shading_rate(rate: f32);
        matte(on: bool);
        orientation(o: &str);
        reverse_orientation();
        sides(sides: i32);
        attribute(namespace: &str, params: ParamList);
        basis(u: Basis, v: Basis);
        trim_curve(trim: TrimCurves);
        identity();
        transform(matrix: DMat4);
        concat_transform(matrix: DMat4);
        perspective(fov: f64);
        translate(d: DVec3);
        rotate(angle: f64, axis: DVec3);
        scale(s: DVec3);
        skew(angle: f64, from: DVec3, to: DVec3);
        coordinate_system(name: &str);
        coord_sys_transform(name: &str);
        polygon(n: u32, params: ParamList);
        general_polygon(loops: Vec<u32>, params: ParamList);
        points_polygons(nverts: Vec<u32>, verts: Vec<u32>, params: ParamList);
        points_general_polygons(nloops: Vec<u32>, nverts: Vec<u32>, verts: Vec<u32>, params: ParamList);
        patch(kind: PatchKind, params: ParamList);
        patch_mesh(kind: PatchKind, nu: u32, uwrap: Wrap, nv: u32, vwrap: Wrap, params: ParamList);
        nu_patch(patch: NuPatchBasis, params: ParamList);
        subdivision_mesh(scheme: &str, nverts: Vec<u32>, verts: Vec<u32>, tags: Vec<SubdivisionTag>, params: ParamList);
        quadric(q: Quadric, params: ParamList);
        points(params: ParamList);
        curves(cubic: bool, nverts: Vec<u32>, wrap: Wrap, params: ParamList);
    }
}

fn record(rib: &str) -> (Vec<String>, String) {
    let mut target = Recorder::default();
    let mut reader = Reader::new(ReadOptions::default());
    reader.read_bytes("t.rib", None, rib.as_bytes().to_vec(), &mut target);
    let (diagnostics, sources) = reader.into_parts();
    (target.0, diagnostics.render(&sources))
}

fn calls(rib: &str) -> Vec<String> {
    let (calls, diagnostics) = record(rib);
    assert!(diagnostics.is_empty(), "{diagnostics}");
    calls
}

#[test]
fn positional_arguments_bare_or_bracketed() {
    assert_eq!(
        calls("Color 1 0 0 Color [0 1 0] Translate [1 2] 3"),
        ["color color=[1.0, 0.0, 0.0]", "color color=[0.0, 1.0, 0.0]", "translate d=DVec3(1.0, 2.0, 3.0)"]
    );
}

#[test]
fn matrices_convert_from_row_vector_layout() {
    let c = calls("ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 7 8 9 1]");
    assert_eq!(
        c,
        [format!("concat_transform matrix={:?}", DMat4::from_translation(DVec3::new(7.0, 8.0, 9.0)))]
    );
}

#[test]
fn named_bases_are_resolved() {
    let c = calls("Basis \"catmull-rom\" 1 [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1] 4");
    assert!(c[0].starts_with("basis u=Basis { matrix: [-0.5, 1.5, -1.5, 0.5, 1.0, -2.5, 2.0, -0.5, -0.5, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0], step: 1 }"), "{c:?}");
    assert!(c[0].ends_with("v=Basis { matrix: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0], step: 4 }"));
}

#[test]
fn light_handles_numbers_names_and_missing() {
    let c = calls("LightSource \"pointlight\" 3 LightSource \"spotlight\" \"key\" \"intensity\" 2");
    assert!(c[0].ends_with("handle=Int(3)"), "{c:?}");
    assert!(c[1].ends_with("handle=Name(\"key\")"), "{c:?}");
    assert!(c[1].contains("name: \"intensity\""), "{c:?}");
    let (c, d) = record("LightSource \"pointlight\" \"intensity\" [2]");
    assert!(c[0].ends_with("handle=Name(\"<unnamed light 1>\")"), "{c:?}");
    assert!(d.contains("t.rib:1:1: warning: LightSource without a handle"), "{d}");
}

#[test]
fn parameters_get_their_declarations() {
    let c = calls(
        "Declare \"myparam\" \"varying float\" Surface \"s\" \"myparam\" 1 \"color c\" [1 2 3] \"custom\" [\"a\" \"b\"] \"n\" [1 2]",
    );
    let s = &c[0];
    assert!(
        s.contains("name: \"myparam\", decl: ParamDecl { class: Varying, ty: Float, array_len: 1 }"),
        "{s}"
    );
    assert!(s.contains("name: \"c\", decl: ParamDecl { class: Uniform, ty: Color, array_len: 1 }"), "{s}");
    // Undeclared shader parameters take their type from their values.
    assert!(
        s.contains("name: \"custom\", decl: ParamDecl { class: Uniform, ty: String, array_len: 2 }"),
        "{s}"
    );
    assert!(s.contains("name: \"n\", decl: ParamDecl { class: Uniform, ty: Float, array_len: 2 }"), "{s}");
}

#[test]
fn undeclared_primitive_variables_are_dropped_with_a_warning() {
    let (c, d) = record("Polygon \"P\" [0 0 0 1 0 0 0 1 0] \"mystery\" [1 2 3]");
    assert_eq!(c.len(), 1);
    assert!(!c[0].contains("mystery"));
    assert!(d.contains("t.rib:1:33: warning: Polygon: parameter \"mystery\" is not declared"), "{d}");
}

#[test]
fn wrong_counts_never_reach_the_target() {
    let (c, d) = record("Polygon \"P\" [0 0 0 1 0 0 0 1 0] \"varying float s\" [1 2] Sphere 1 -1 1 360");
    assert_eq!(c.len(), 1, "{c:?}");
    assert!(c[0].starts_with("quadric q=Sphere"));
    assert!(d.contains("parameter \"s\" (varying float) has 2 values, but this Polygon takes 3"), "{d}");
}

#[test]
fn inline_archives_and_declarations_are_handled_by_the_parser() {
    let c = calls("ArchiveBegin \"a\" Sphere 1 -1 1 360 ArchiveEnd ReadArchive \"a\" ReadArchive \"a\"");
    assert_eq!(c.len(), 2);
    assert!(c.iter().all(|l| l.starts_with("quadric q=Sphere")));
}

#[test]
fn camera_fov_is_kept_at_full_precision() {
    let c = calls("Projection \"perspective\" \"fov\" [39.3077]");
    assert!(c[0].ends_with("fov=Some(39.3077)"), "{c:?}");
}

#[test]
fn subdivision_tags_and_nurbs_arguments() {
    let c = calls(
        "SubdivisionMesh \"catmull-clark\" [3] [0 1 2] [\"crease\" \"corner\"] [2 1 1 1] [0 1 2] [5 9] \"P\" [0 0 0 1 0 0 0 1 0] \
         NuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]",
    );
    assert!(
        c[0].contains(
            "SubdivisionTag { name: \"crease\", int_args: [0, 1], float_args: [5.0], string_args: [] }"
        ),
        "{c:?}"
    );
    assert!(
        c[0].contains(
            "SubdivisionTag { name: \"corner\", int_args: [2], float_args: [9.0], string_args: [] }"
        ),
        "{c:?}"
    );
    assert!(
        c[1].starts_with("nu_patch patch=NuPatchBasis { nu: 2, u_order: 2, u_knots: [0.0, 0.0, 1.0, 1.0]"),
        "{c:?}"
    );
}

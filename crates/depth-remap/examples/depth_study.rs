//! Prints the numbers behind `docs/depth-mapping.md`, as Markdown:
//! the paper's printed formula and matrix checked numerically, radial against planar depth on
//! the reference Cornell camera, the depth-buffer precision study, and what `f32` world-space
//! coordinates cost far from the origin.
//!
//! `cargo run --release -p depth-remap --example depth_study`

use depth_remap::paper::{gl_window_from_ndc, paper_colocation};
use depth_remap::precision::{DepthBufferFormat, min_separation};
use depth_remap::*;
use glam::{DMat4, DVec3, Vec4};

fn main() {
    paper_check();
    radial_versus_planar();
    precision_study();
    far_from_origin();
}

fn paper_check() {
    println!("## The printed recipe, numerically (zNear = 1, zFar = 100)\n");
    println!(
        "| d | z_transformed (printed, z_eye = +d) | gluPerspective clip z, w at eye z = -d | polygon NDC z | polygon window | point NDC z, printed matrix fed z_transformed | printed formula with z_eye = -d, then matrix | vertex z that co-locates (z_t/d - 1) | corrected point NDC (row [0 0 1 0], fed z_t/d) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for d in [1.0, 2.0, 10.0, 50.0, 100.0] {
        let mut c = paper_colocation(d, 1.0, 100.0);
        // Print -0 as 0.
        c.polygon_window += 0.0;
        c.printed_point_ndc += 0.0;
        let printed = if c.printed_point_visible {
            format!("{:.6} (window {:.6})", c.printed_point_ndc, gl_window_from_ndc(c.printed_point_ndc))
        } else {
            format!("{:.6} (clipped)", c.printed_point_ndc)
        };
        println!(
            "| {d} | {:.6} | {:.6}, {} | {:.6} | {:.6} | {printed} | {:.6} (clipped) | {:.6} | {:.6} |",
            c.z_transformed,
            c.polygon_clip_z,
            c.polygon_clip_w,
            c.polygon_ndc,
            c.polygon_window,
            c.printed_negative_eye_ndc,
            c.vertex_z_for_printed_matrix,
            c.corrected_point_ndc,
        );
    }
    println!();
}

fn cornell_camera() -> Camera {
    Camera::new(CameraSettings {
        x_resolution: 512,
        y_resolution: 512,
        projection: Projection::Perspective { fov_degrees: 39.3077 },
        clipping: Clipping { near: 0.001, far: 100.0 },
        camera_from_world: DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0))
            * DMat4::from_translation(DVec3::new(0.0, 0.0, -3.9)),
        ..CameraSettings::default()
    })
    .unwrap()
}

fn radial_versus_planar() {
    println!("## Radial against planar depth (reference Cornell camera, 512x512, fov 39.3077)\n");
    let camera = cornell_camera();
    let planes = NearFar { near: 1.0, far: 100.0, infinite_far: true };
    let mapping = camera.depth_mapping(DepthConvention::WgpuReversed, planes).unwrap();
    println!(
        "| pixel | planar / radial | window depth of the back wall (reversed, n = 1) | same, radial used as planar | error in f32 steps |"
    );
    println!("|---|---|---|---|---|");
    for (name, i, j) in [("centre (256, 256)", 256, 256), ("edge (0, 256)", 0, 256), ("corner (0, 0)", 0, 0)]
    {
        let factor = camera.eye_depth_per_radial(i, j);
        // The back wall (world z = -1) is 4.9 units in front of the eye.
        let radial = camera.eye_depth_to_radial(i, j, 4.9);
        let right = mapping.window_depth(4.9) as f32;
        let wrong = mapping.window_depth(radial) as f32;
        let steps = (right.to_bits() as i64 - wrong.to_bits() as i64).abs();
        println!("| {name} | {factor:.6} | {right:.9} | {wrong:.9} | {steps} |");
    }
    println!();
}

fn precision_study() {
    println!("## Precision: smallest separation for correct ordering, relative to distance (delta / d)\n");
    println!(
        "Near plane at 1; `-` where d is not inside (near, far). Simulated GPU pipeline (see `precision.rs`).\n"
    );
    let cases: [(&str, DepthConvention, bool, DepthBufferFormat); 7] = [
        ("24-bit unorm, OpenGL [-1,1], standard", DepthConvention::Gl, false, DepthBufferFormat::Unorm24),
        ("24-bit unorm, [0,1], reversed", DepthConvention::WgpuReversed, false, DepthBufferFormat::Unorm24),
        ("float32, OpenGL [-1,1], standard", DepthConvention::Gl, false, DepthBufferFormat::Float32),
        ("float32, OpenGL [-1,1], reversed", DepthConvention::GlReversed, false, DepthBufferFormat::Float32),
        ("float32, wgpu [0,1], standard", DepthConvention::Wgpu, false, DepthBufferFormat::Float32),
        (
            "float32, wgpu [0,1], reversed, finite far",
            DepthConvention::WgpuReversed,
            false,
            DepthBufferFormat::Float32,
        ),
        (
            "float32, wgpu [0,1], reversed, infinite far",
            DepthConvention::WgpuReversed,
            true,
            DepthBufferFormat::Float32,
        ),
    ];
    let distances = [2.0, 10.0, 1e2, 1e3, 1e4, 1e5, 1e6];
    for (name, convention, infinite, format) in cases {
        println!("### {name}\n");
        print!("| far / near |");
        for d in distances {
            print!(" d = {d:e} |");
        }
        println!(" d = 0.9 far |");
        println!("|---|{}---|", "---|".repeat(distances.len()));
        for exponent in 1..=7 {
            let far = 10f64.powi(exponent);
            let far_plane = if infinite { FarPlane::Infinite } else { FarPlane::Finite(far) };
            let mapping = DepthMapping::perspective(convention, 1.0, far_plane).unwrap();
            print!("| 1e{exponent} |");
            for d in distances.into_iter().chain([0.9 * far]) {
                if d >= far {
                    print!(" - |");
                    continue;
                }
                match min_separation(&mapping, format, d, 1024) {
                    Some(delta) => print!(" {:.1e} |", delta / d),
                    None => print!(" none |"),
                }
            }
            println!();
        }
        println!();
    }
}

fn far_from_origin() {
    println!("## f32 coordinates far from the origin\n");
    println!(
        "A 5-unit-deep scene seen from 1e6 units from the world origin, reversed-Z infinite far, near 0.5."
    );
    println!("Error of the GPU's window depth against the exact value, in f32 steps of the stored value:\n");
    println!("| vertex path | worst error (steps) | as relative depth |");
    println!("|---|---|---|");
    let eye = DVec3::new(1.0e6, 2.0e5, -3.0e5);
    let camera = Camera::new(CameraSettings {
        x_resolution: 256,
        y_resolution: 256,
        projection: Projection::Perspective { fov_degrees: 40.0 },
        camera_from_world: glam::dcamera::lh::view::look_at_mat4(
            eye,
            eye + DVec3::new(0.3, -0.2, 1.0),
            DVec3::Y,
        ),
        ..CameraSettings::default()
    })
    .unwrap();
    let mapping = DepthMapping::perspective(DepthConvention::WgpuReversed, 0.5, FarPlane::Infinite).unwrap();
    let projection = mapping.projection(&camera.frustum());
    let view = camera.eye_from_world();
    let world_matrix = (projection * view).as_mat4();
    let (mut world_steps, mut relative_steps) = (0i64, 0i64);
    for k in 0..4096u32 {
        let (i, j) = ((k * 37) % 256, (k * 91) % 256);
        let r = 2.0 + 5.0 * f64::from(k) / 4096.0;
        let point = camera.pixel_centre_world_ray(i, j).at(r);
        let exact = camera.window_depth_from_radial(i, j, r as f32, &mapping);
        // Naive: world-space f32 vertex through an f32 view-projection matrix.
        let clip = world_matrix * point.as_vec3().extend(1.0);
        let naive = clip.z / clip.w;
        // Camera-relative: model-view composed in f64, eye-space vertex rounded to f32.
        let eye_space = view.transform_point3(point);
        let clip: Vec4 = projection.as_mat4() * eye_space.as_vec3().extend(1.0);
        let relative = clip.z / clip.w;
        world_steps = world_steps.max((naive.to_bits() as i64 - exact.to_bits() as i64).abs());
        relative_steps = relative_steps.max((relative.to_bits() as i64 - exact.to_bits() as i64).abs());
    }
    let as_relative = |steps: i64| steps as f64 * f64::from(f32::EPSILON);
    println!(
        "| world-space f32 vertex, f32 view-projection | {world_steps} | {:.1e} |",
        as_relative(world_steps)
    );
    println!(
        "| eye-space vertex from an f64 model-view | {relative_steps} | {:.1e} |",
        as_relative(relative_steps)
    );
    println!();
}

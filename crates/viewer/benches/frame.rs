//! Frame time of the compositor, headless: each compositing mode at 512^2 and 2048^2, with the
//! cursor sphere and its shadow in view (a typical interactive frame). One iteration is
//! `render` + waiting for the GPU, so it is the whole frame's latency.
//!
//! Run: `cargo bench -p viewer --bench frame` (results in docs/viewer.md).

use criterion::{Criterion, criterion_group, criterion_main};
use depth_remap::{Camera, CameraSettings, Projection};
use glam::{DMat4, DVec3, Vec3};
use std::time::Duration;
use viewer::{
    Backends, CompositeMode, Compositor, CompositorSettings, DepthTable, Gpu, LiveLight, LiveObjects,
    Material, Rgba8Image, Sphere, ToneMap, ViewerScene,
};

/// The Cornell room without its boxes (five walls, the eye 3.9 in front of the back wall) at
/// `size^2`, with analytic radial depths.
fn room(size: u32) -> ViewerScene {
    let camera_from_world =
        DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0)) * DMat4::from_translation(DVec3::new(0.0, 0.0, -3.9));
    let camera = Camera::new(CameraSettings {
        x_resolution: size,
        y_resolution: size,
        projection: Projection::Perspective { fov_degrees: 39.3077 },
        camera_from_world,
        ..CameraSettings::default()
    })
    .expect("camera");
    let world_from_camera = camera.world_from_camera();
    let mut values = Vec::with_capacity((size * size) as usize);
    let mut pixels = Vec::with_capacity((size * size * 4) as usize);
    for j in 0..size {
        for i in 0..size {
            let ray = camera.pixel_centre_ray(i, j);
            let o = world_from_camera.transform_point3(ray.origin);
            let d = world_from_camera.transform_vector3(ray.direction);
            // Walls: x = +-1, y = +-1, z = -1 (the box is open towards the eye).
            let mut best = f64::INFINITY;
            for (axis, plane) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0), (2, -1.0)] {
                let t = (plane - o[axis]) / d[axis];
                if t > 0.0 {
                    let p = o + d * t;
                    if p.x.abs() <= 1.0 + 1e-9 && p.y.abs() <= 1.0 + 1e-9 && p.z <= 1.0 && p.z >= -1.0 - 1e-9
                    {
                        best = best.min(t);
                    }
                }
            }
            values.push(best as f32);
            pixels.extend_from_slice(&[(i % 256) as u8, (j % 256) as u8, ((i ^ j) % 256) as u8, 255]);
        }
    }
    let depth = DepthTable::new(size, size, values).expect("depths");
    let image = Rgba8Image { width: size, height: size, pixels };
    let light = LiveLight::Area {
        centroid: DVec3::new(0.0, 0.99, 0.0),
        normal: Some(DVec3::NEG_Y),
        two_sided: false,
        radiance: Vec3::new(18.4, 14.0, 6.75),
        area: 0.17,
        radius: 0.23,
    };
    ViewerScene::new(camera, image, depth, vec![light], ToneMap::default()).expect("scene")
}

fn frame_time(c: &mut Criterion) {
    let gpu = Gpu::new(Backends::default()).expect("a GPU adapter (lavapipe: cargo xtask install-test-deps)");
    eprintln!("adapter: {}", gpu.describe());
    let live = LiveObjects {
        sphere: Some(Sphere {
            centre: DVec3::new(0.2, -0.6, -0.3),
            radius: 0.3,
            material: Material::default(),
        }),
        meshes: Vec::new(),
    };
    let mut group = c.benchmark_group("frame");
    group.sample_size(10).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(4));
    for size in [512u32, 2048] {
        let scene = room(size);
        for mode in [CompositeMode::Points, CompositeMode::Fullscreen] {
            let mut compositor =
                Compositor::new(&gpu, &scene, CompositorSettings { mode, ..CompositorSettings::default() })
                    .expect("compositor");
            // The first frame uploads the point cloud; keep it out of the measurement.
            compositor.render(&live).expect("render");
            compositor.wait_idle().expect("wait");
            group.bench_function(format!("{}/{size}", mode.name()), |b| {
                b.iter(|| {
                    compositor.render(&live).expect("render");
                    compositor.wait_idle().expect("wait");
                })
            });
        }
    }
    // Where the time goes (full-screen mode): the backdrop alone, then with the sphere but
    // without its shadow pass.
    let no_sphere = LiveObjects::default();
    for size in [512u32, 2048] {
        let scene = room(size);
        for (what, live, shadows) in [("backdrop-only", &no_sphere, true), ("sphere-no-shadow", &live, false)]
        {
            let settings = CompositorSettings {
                shadows: if shadows { CompositorSettings::default().shadows } else { None },
                ..CompositorSettings::default()
            };
            let mut compositor = Compositor::new(&gpu, &scene, settings).expect("compositor");
            group.bench_function(format!("fullscreen-{what}/{size}"), |b| {
                b.iter(|| {
                    compositor.render(live).expect("render");
                    compositor.wait_idle().expect("wait");
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, frame_time);
criterion_main!(benches);

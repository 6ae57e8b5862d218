//! Whole-table remapping and the choice of near and far planes.

use depth_remap::*;
use glam::DVec3;

fn camera(w: u32, h: u32, crop: Option<CropWindow>) -> Camera {
    Camera::new(CameraSettings {
        x_resolution: w,
        y_resolution: h,
        projection: Projection::Perspective { fov_degrees: 50.0 },
        camera_from_world: glam::dcamera::lh::view::look_at_mat4(
            DVec3::new(3.0, 2.0, -8.0),
            DVec3::ZERO,
            DVec3::Y,
        ),
        crop_window: crop.unwrap_or_default(),
        ..CameraSettings::default()
    })
    .unwrap()
}

/// A sphere of radius 2 at the origin, traced through every pixel-centre ray.
fn sphere_table(camera: &Camera, origin: (u32, u32), size: (u32, u32)) -> DepthTable {
    let mut table = DepthTable::all_misses(size.0, size.1);
    for j in 0..size.1 {
        for i in 0..size.0 {
            let ray = camera.pixel_centre_world_ray(origin.0 + i, origin.1 + j);
            let b = ray.origin.dot(ray.direction);
            let c = ray.origin.length_squared() - 4.0;
            let disc = b * b - c;
            if disc >= 0.0 {
                assert!(table.set(i, j, (-b - disc.sqrt()) as f32));
            }
        }
    }
    table
}

#[test]
fn remap_equals_the_single_pixel_function_bit_for_bit() {
    let camera = camera(97, 61, None);
    let table = sphere_table(&camera, (0, 0), (97, 61));
    let range = camera.eye_depth_range(&table).unwrap().unwrap();
    let planes = choose_near_far(Some(range), camera.clipping(), NearFarPolicy::default());
    for convention in DepthConvention::ALL {
        for infinite_far in [false, true] {
            let mapping = camera.depth_mapping(convention, NearFar { infinite_far, ..planes }).unwrap();
            let single = remap_depth_table(&camera, &table, &mapping, DepthOutput::Window, 1).unwrap();
            let parallel = remap_depth_table(&camera, &table, &mapping, DepthOutput::Window, 7).unwrap();
            assert_eq!(single, parallel);
            for j in 0..61 {
                for i in 0..97 {
                    let expected = camera.window_depth_from_radial(i, j, table.get(i, j).unwrap(), &mapping);
                    assert_eq!(single.values[(j * 97 + i) as usize].to_bits(), expected.to_bits());
                }
            }
            let misses = table.values().iter().filter(|v| v.is_infinite()).count() as u64;
            assert_eq!(single.stats, RemapStats { misses, clamped_near: 0, clamped_far: 0 });
            // Misses are at the far value, hits strictly in front of it.
            for (v, r) in single.values.iter().zip(table.values()) {
                if r.is_infinite() {
                    assert_eq!(*v, convention.far_window_depth());
                } else {
                    assert_ne!(*v, convention.far_window_depth());
                }
            }
            // NDC output is the window depth through the inverse viewport transform.
            let ndc = remap_depth_table(&camera, &table, &mapping, DepthOutput::Ndc, 0).unwrap();
            for (n, w) in ndc.values.iter().zip(&single.values) {
                let back = convention.ndc_to_window(f64::from(*n)) as f32;
                assert!((back - w).abs() <= 2.0 * f32::EPSILON, "{convention}: ndc {n} window {w}");
            }
        }
    }
}

#[test]
fn crop_sized_tables_use_the_crop_offset() {
    let crop = CropWindow { xmin: 0.25, xmax: 0.75, ymin: 0.5, ymax: 1.0 };
    let camera = camera(80, 60, Some(crop));
    let (x0, x1, y0, y1) = camera.crop_pixel_bounds();
    let table = sphere_table(&camera, (x0, y0), (x1 - x0, y1 - y0));
    let planes = NearFar { near: 1.0, far: 100.0, infinite_far: true };
    let mapping = camera.depth_mapping(DepthConvention::WgpuReversed, planes).unwrap();
    let remapped = remap_depth_table(&camera, &table, &mapping, DepthOutput::Window, 0).unwrap();
    for j in 0..table.height() {
        for i in 0..table.width() {
            let expected =
                camera.window_depth_from_radial(x0 + i, y0 + j, table.get(i, j).unwrap(), &mapping);
            assert_eq!(remapped.values[(j * table.width() + i) as usize], expected);
        }
    }
    // Any other size is refused, naming both sizes.
    let wrong = DepthTable::all_misses(10, 10);
    let error = remap_depth_table(&camera, &wrong, &mapping, DepthOutput::Window, 0).unwrap_err();
    assert_eq!(error.to_string(), "the depth table is 10x10 but the image is 80x60");
}

#[test]
fn clamping_is_counted() {
    let camera = camera(8, 8, None);
    let mut table = DepthTable::all_misses(8, 8);
    table.set(0, 0, 0.001);
    table.set(1, 0, 1e9);
    table.set(2, 0, 9.0);
    let planes = NearFar { near: 1.0, far: 100.0, infinite_far: false };
    let mapping = camera.depth_mapping(DepthConvention::Wgpu, planes).unwrap();
    let remapped = remap_depth_table(&camera, &table, &mapping, DepthOutput::Window, 0).unwrap();
    assert_eq!(remapped.stats, RemapStats { misses: 61, clamped_near: 1, clamped_far: 1 });
    assert_eq!(&remapped.values[..3], &[0.0, 1.0, remapped.values[2]]);
    assert!(remapped.values[2] > 0.0 && remapped.values[2] < 1.0);
    // Values that are not depths never reach a table, and the single-pixel form refuses them.
    for bad in [f32::NAN, -1.0, f32::NEG_INFINITY] {
        assert_eq!(camera.window_depth_from_radial(0, 0, bad, &mapping), 1.0);
    }
}

#[test]
fn near_and_far_come_from_the_data_and_clipping() {
    let range = EyeDepthRange { min: 3.0, max: 40.0 };
    let policy = NearFarPolicy::for_convention(DepthConvention::Gl);
    assert_eq!(policy, NearFarPolicy { near_factor: 0.5, far_factor: 2.0, infinite_far: false });
    let reversed = choose_near_far(Some(range), Clipping::default(), NearFarPolicy::default());
    assert_eq!((reversed.near, reversed.infinite_far), (3.0 / 64.0, true));
    let planes = choose_near_far(Some(range), Clipping::default(), policy);
    assert!(planes.near <= 1.5 && planes.near > 1.5 * (1.0 - 1e-7));
    assert!(planes.far >= 80.0 && planes.far < 80.0 * (1.0 + 1e-7));
    assert_eq!(f64::from(planes.near as f32), planes.near);
    assert_eq!(f64::from(planes.far as f32), planes.far);
    // Clipping wins where it is tighter.
    let clipped = choose_near_far(Some(range), Clipping { near: 2.0, far: 50.0 }, policy);
    assert_eq!((clipped.near, clipped.far), (2.0, 50.0));
    // No data: Clipping's planes (rounded outward to f32, and kept within f32's range).
    let empty = choose_near_far(None, Clipping::default(), policy);
    assert!(empty.near > 0.0 && empty.near <= 1e-10);
    assert!(empty.far >= 1e38 && empty.far < 1.0000001e38 && f64::from(empty.far as f32) == empty.far);
    let huge = choose_near_far(None, Clipping { near: 1e-3, far: 1e300 }, policy);
    assert_eq!(huge.far, f64::from(f32::MAX));
    // Nonsense clipping still gives valid planes.
    let odd = choose_near_far(Some(range), Clipping { near: 10.0, far: 5.0 }, policy);
    assert!(odd.near > 0.0 && odd.far > odd.near);
    // The sphere scene: the nearest surface is the sphere's front.
    let camera = camera(40, 30, None);
    let table = sphere_table(&camera, (0, 0), (40, 30));
    let range = camera.eye_depth_range(&table).unwrap().unwrap();
    let eye_distance = DVec3::new(3.0, 2.0, -8.0).length();
    assert!(range.min > eye_distance - 2.0 - 1e-6 && range.min < eye_distance - 1.9);
    assert!(camera.eye_depth_range(&DepthTable::all_misses(40, 30)).unwrap().is_none());
}

#[test]
fn point_cloud_matrix_puts_pixel_centres_on_pixel_centres() {
    let m = point_cloud_matrix(640, 480);
    for (i, j) in [(0u32, 0u32), (639, 479), (320, 17)] {
        let ndc = m * glam::DVec4::new(f64::from(i) + 0.5, f64::from(j) + 0.5, 0.25, 1.0);
        // wgpu: framebuffer x = (x + 1) / 2 * W, y = (1 - y) / 2 * H (y down).
        assert!(((ndc.x + 1.0) * 320.0 - (f64::from(i) + 0.5)).abs() < 1e-12);
        assert!(((1.0 - ndc.y) * 240.0 - (f64::from(j) + 0.5)).abs() < 1e-12);
        // The depth passes through.
        assert_eq!((ndc.z, ndc.w), (0.25, 1.0));
    }
}

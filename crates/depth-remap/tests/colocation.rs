//! The central property: a pre-rendered pixel's depth, converted from the radial distance in
//! the table, equals the depth a live polygon at the same point gets through the perspective
//! matrix, for every named convention, over random cameras, pixels and surface points.
//!
//! Two references:
//! - the real-number value of the matrix the GPU is given (evaluated in `f64`): the remap must
//!   be within one `f32` ulp of it, plus what `f64` itself cannot resolve for points far from
//!   the origin (their coordinates carry `|p| 2^-53` of rounding);
//! - a GPU-like `f32` pipeline (eye-space vertex rounded to `f32`, `f32` matrix, `f32` divide):
//!   within four units of `2^-24` times the condition of the matrix's depth row at that point
//!   (see [`f32_scale`] and `docs/depth-mapping.md`, "How close is close").

use depth_remap::*;
use glam::{DMat4, DQuat, DVec2, DVec3, DVec4, Vec4};
use proptest::prelude::*;

fn ulp(x: f32) -> f64 {
    let a = x.abs();
    f64::from(a.next_up()) - f64::from(a)
}

#[derive(Clone, Debug)]
struct Case {
    settings: CameraSettings,
    pixel: (f64, f64),
    radial_exponent: f64,
    near_fraction_exponent: f64,
    far_factor_exponent: f64,
}

fn camera_settings() -> impl Strategy<Value = CameraSettings> {
    (
        (1u32..=4096, 1u32..=4096),
        1.0f64..170.0,
        prop_oneof![Just(1.0), 0.5f64..2.0],
        prop::option::weighted(0.3, ((-3.0f64..1.0), (0.05f64..4.0), (-3.0f64..1.0), (0.05f64..4.0))),
        (prop::array::uniform3(-1.0f64..1.0), 0.0f64..std::f64::consts::TAU),
        (prop::array::uniform3(-1.0f64..1.0), -3.0f64..6.5),
        (any::<bool>(), prop_oneof![Just(0.0), -2.0f64..2.0]),
    )
        .prop_map(|(resolution, fov, pixel_aspect, window, rotation, translation, scale)| {
            let axis = DVec3::from_array(rotation.0).try_normalize().unwrap_or(DVec3::Y);
            let rotation = DQuat::from_axis_angle(axis, rotation.1);
            let offset = DVec3::from_array(translation.0) * 10f64.powf(translation.1);
            let (mirror, log_scale) = scale;
            let scale = 10f64.powf(log_scale);
            let mirror = if mirror { DVec3::new(1.0, 1.0, -1.0) } else { DVec3::ONE };
            let camera_from_world = DMat4::from_scale(mirror * scale)
                * DMat4::from_quat(rotation)
                * DMat4::from_translation(offset);
            CameraSettings {
                x_resolution: resolution.0,
                y_resolution: resolution.1,
                pixel_aspect_ratio: pixel_aspect,
                screen_window: window.map(|(left, width, bottom, height)| ScreenWindow {
                    left,
                    right: left + width,
                    bottom,
                    top: bottom + height,
                }),
                projection: Projection::Perspective { fov_degrees: fov },
                camera_from_world,
                ..CameraSettings::default()
            }
        })
}

fn cases() -> impl Strategy<Value = Case> {
    (camera_settings(), (0.0f64..1.0, 0.0f64..1.0), -3.0f64..5.0, -6.0f64..-0.005, 0.005f64..7.0).prop_map(
        |(settings, pixel, radial_exponent, near_fraction_exponent, far_factor_exponent)| Case {
            settings,
            pixel,
            radial_exponent,
            near_fraction_exponent,
            far_factor_exponent,
        },
    )
}

/// The condition of the depth row at eye depth `d`: `f32` evaluation of
/// `(z_scale * z_eye + z_offset) / -z_eye` makes errors of a few `2^-24` times
/// `|z_scale| + |z_offset| / d` (the two terms and the rounding of `z_eye` itself), halved by
/// OpenGL's viewport transform. For reversed-Z with an infinite far plane this is `n / d`, about
/// the value itself, so the error is a few ulps of the stored value; for the others it is about
/// 1, or `(f + n) / (f - n)` when near and far are close.
fn f32_scale(mapping: &DepthMapping, d: f64) -> f64 {
    let (z_scale, z_offset) = mapping.z_row();
    let scale = z_scale.abs() + z_offset.abs() / d;
    if mapping.convention().is_gl() { 0.5 * scale } else { scale }
}

fn check(case: &Case) -> Result<(), TestCaseError> {
    let camera = Camera::new(case.settings.clone()).expect("valid camera");
    let (w, h) = camera.resolution();
    let i = ((case.pixel.0 * f64::from(w)) as u32).min(w - 1);
    let j = ((case.pixel.1 * f64::from(h)) as u32).min(h - 1);
    let radial = 10f64.powf(case.radial_exponent) as f32;
    let r = f64::from(radial);
    let ray = camera.pixel_centre_world_ray(i, j);
    let point = ray.at(r);
    let d = camera.radial_to_eye_depth(i, j, r);
    prop_assert!(d > 0.0 && d.is_finite());

    // The f64 reference itself is only as good as the point's coordinates far from the origin.
    let view = camera.eye_from_world();
    let eye = view.transform_point3(point);
    let view_norm = view.row(0).truncate().length().max(view.row(2).truncate().length());
    let coordinate_error =
        8.0 * f64::EPSILON * (view_norm * (point.length() + ray.origin.length()) + eye.length());
    prop_assert!((-eye.z - d).abs() <= coordinate_error + 8.0 * f64::EPSILON * d, "eye z {} vs {d}", -eye.z);

    // The pixel centre ray projects to the pixel centre.
    let frustum = camera.frustum();
    let near = f64::from((d * 10f64.powf(case.near_fraction_exponent)) as f32);
    let far = f64::from((d * 10f64.powf(case.far_factor_exponent)) as f32);
    prop_assume!(near > 0.0 && near < d && far > d);
    let mapping = DepthMapping::perspective(DepthConvention::Wgpu, near, FarPlane::Finite(far)).unwrap();
    let clip = mapping.projection(&frustum) * eye.extend(1.0);
    let raster = DVec2::new(
        (clip.x / clip.w + 1.0) * 0.5 * f64::from(w),
        (1.0 - clip.y / clip.w) * 0.5 * f64::from(h),
    );
    let raster_error = (raster - pixel_centre(i, j)).length();
    // A coordinate error e at depth d changes the slope x/d by up to e (1 + |x/d|) / d, which
    // is this many pixels per unit of slope (grazing rays of very wide lenses amplify it).
    let pixels_per_slope = (f64::from(w) / (frustum.right - frustum.left).abs())
        .max(f64::from(h) / (frustum.top - frustum.bottom).abs());
    let steepest =
        [frustum.left, frustum.right, frustum.bottom, frustum.top].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let raster_tolerance =
        1e-9 * f64::from(w.max(h)) + 2.0 * coordinate_error * (1.0 + steepest) / d * pixels_per_slope;
    prop_assert!(
        raster_error < raster_tolerance,
        "raster {raster} for pixel ({i}, {j}), error {raster_error}"
    );

    for convention in DepthConvention::ALL {
        for far_plane in [FarPlane::Finite(far), FarPlane::Infinite] {
            let mapping = DepthMapping::perspective(convention, near, far_plane).unwrap();
            let remapped = camera.window_depth_from_radial(i, j, radial, &mapping);
            let projection = mapping.projection(&frustum);

            // Against the real-number value of the GPU's matrix.
            let clip = projection * eye.extend(1.0);
            // Clamped like the remap (a point within rounding of a plane may fall just outside
            // the f32 matrix's planes).
            let reference = convention.ndc_to_window(clip.z / clip.w).clamp(0.0, 1.0);
            let (_, z_offset) = mapping.z_row();
            let slope = z_offset.abs() / (d * d) * if convention.is_gl() { 0.5 } else { 1.0 };
            let tolerance = ulp(remapped) + slope * (coordinate_error + 8.0 * f64::EPSILON * d);
            prop_assert!(
                (f64::from(remapped) - reference).abs() <= tolerance,
                "{convention} {far_plane:?}: remapped {remapped}, matrix {reference}, tolerance {tolerance}"
            );

            // Against a GPU-like f32 pipeline fed a camera-relative eye-space vertex.
            let eye32 = eye.as_vec3().extend(1.0);
            let clip32: Vec4 = projection.as_mat4() * eye32;
            let ndc32 = clip32.z / clip32.w;
            let gpu = if convention.is_gl() { ndc32 * 0.5 + 0.5 } else { ndc32 }.clamp(0.0, 1.0);
            let tolerance_f32 = 4.0 * f64::from(f32::EPSILON) / 2.0 * f32_scale(&mapping, d)
                + 2.0 * ulp(remapped)
                + slope * coordinate_error;
            prop_assert!(
                (f64::from(remapped) - f64::from(gpu)).abs() <= tolerance_f32,
                "{convention} {far_plane:?}: remapped {remapped}, f32 pipeline {gpu}, tolerance {tolerance_f32}"
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 384, ..ProptestConfig::default() })]

    #[test]
    fn remapped_depth_equals_projected_depth(case in cases()) {
        check(&case)?;
    }

    #[test]
    fn radial_eye_round_trip(settings in camera_settings(), pixel in (0.0f64..1.0, 0.0f64..1.0), r in 1e-3f64..1e5) {
        let camera = Camera::new(settings).unwrap();
        let (w, h) = camera.resolution();
        let i = ((pixel.0 * f64::from(w)) as u32).min(w - 1);
        let j = ((pixel.1 * f64::from(h)) as u32).min(h - 1);
        let d = camera.radial_to_eye_depth(i, j, r);
        let back = camera.eye_depth_to_radial(i, j, d);
        prop_assert!((back - r).abs() <= 4.0 * f64::EPSILON * r);
        // Planar depth never exceeds the radial distance in camera units.
        let ray = camera.pixel_centre_world_ray(i, j);
        let camera_point = camera.camera_from_world().transform_point3(ray.at(r));
        prop_assert!((camera_point.z - d).abs() <= 1e-9 * (d + camera_point.length()) + 1e-12 * ray.origin.length());
    }
}

#[test]
fn named_functions_match_named_matrices() {
    let frustum = Frustum { left: -0.7, right: 0.4, bottom: -0.3, top: 0.5, perspective: true };
    let (n, f) = (0.25, 4000.0);
    let eye_depth = |m: DMat4, d: f64| {
        let clip = m * DVec4::new(0.1 * d, -0.05 * d, -d, 1.0);
        clip.z / clip.w
    };
    for d in [0.25, 0.3, 1.0, 17.0, 999.0, 3999.0, 4000.0] {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-13;
        let gl = eye_depth(frustum.perspective_rh_gl(n, f), d);
        assert!(close(gl, ndc_depth_gl(d, n, f)));
        assert!(close(0.5 * gl + 0.5, window_depth_gl(d, n, f)));
        let glr = eye_depth(frustum.perspective_reversed_rh_gl(n, f), d);
        assert!(close(glr, ndc_depth_reversed_gl(d, n, f)));
        assert!(close(0.5 * glr + 0.5, window_depth_reversed(d, n, f)));
        assert!(close(eye_depth(frustum.perspective_rh_wgpu(n, f), d), window_depth_wgpu(d, n, f)));
        assert!(close(
            eye_depth(frustum.perspective_reversed_rh_wgpu(n, f), d),
            window_depth_reversed(d, n, f)
        ));
        let gli = eye_depth(frustum.perspective_infinite_rh_gl(n), d);
        assert!(close(gli, ndc_depth_infinite_gl(d, n)));
        assert!(close(0.5 * gli + 0.5, window_depth_infinite_gl(d, n)));
        let glri = eye_depth(frustum.perspective_infinite_reversed_rh_gl(n), d);
        assert!(close(0.5 * glri + 0.5, window_depth_infinite_reversed(d, n)));
        assert!(close(
            eye_depth(frustum.perspective_infinite_rh_wgpu(n), d),
            window_depth_infinite_wgpu(d, n)
        ));
        assert!(close(
            eye_depth(frustum.perspective_infinite_reversed_rh_wgpu(n), d),
            window_depth_infinite_reversed(d, n)
        ));
        // And the DepthMapping with f32 coefficients stays within f32 resolution of the ideal.
        for convention in DepthConvention::ALL {
            let ideal = match convention {
                DepthConvention::Gl | DepthConvention::Wgpu => window_depth_wgpu(d, n, f),
                _ => window_depth_reversed(d, n, f),
            };
            let mapping = DepthMapping::perspective(convention, n, FarPlane::Finite(f)).unwrap();
            assert!((mapping.window_depth(d) - ideal).abs() <= 4.0 * f64::from(f32::EPSILON), "{convention}");
        }
    }
    // The planes land where the table says.
    for convention in DepthConvention::ALL {
        let mapping = DepthMapping::perspective(convention, n, FarPlane::Finite(f)).unwrap();
        assert!((mapping.window_depth(n) - f64::from(convention.near_window_depth())).abs() < 1e-6);
        assert!((mapping.window_depth(f) - f64::from(convention.far_window_depth())).abs() < 1e-6);
        assert!((mapping.ndc_depth(n) - f64::from(convention.near_ndc_depth())).abs() < 1e-6);
        assert!((mapping.ndc_depth(f) - f64::from(convention.far_ndc_depth())).abs() < 1e-6);
    }
    // Off-centre frusta match glam's symmetric ones when centred.
    let symmetric = Frustum { left: -1.5, right: 1.5, bottom: -1.0, top: 1.0, perspective: true };
    let fov_y = 2.0 * 1.0f64.atan();
    use glam::dcamera::rh::proj::{directx, opengl};
    let glam_gl = opengl::perspective(fov_y, 1.5, n, f);
    let glam_wgpu = directx::perspective(fov_y, 1.5, n, f);
    let glam_reverse = directx::perspective_infinite_reverse(fov_y, 1.5, n);
    assert!(symmetric.perspective_rh_gl(n, f).abs_diff_eq(glam_gl, 1e-12));
    assert!(symmetric.perspective_rh_wgpu(n, f).abs_diff_eq(glam_wgpu, 1e-12));
    assert!(symmetric.perspective_infinite_reversed_rh_wgpu(n).abs_diff_eq(glam_reverse, 1e-12));
}

#[test]
fn orthographic_cameras_map_linearly() {
    let camera = Camera::new(CameraSettings {
        x_resolution: 40,
        y_resolution: 30,
        camera_from_world: DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0)),
        ..CameraSettings::default()
    })
    .unwrap();
    let planes = NearFar { near: 0.5, far: 100.5, infinite_far: false };
    for convention in DepthConvention::ALL {
        let mapping = camera.depth_mapping(convention, planes).unwrap();
        assert!(!mapping.is_perspective());
        let projection = mapping.projection(&camera.frustum()) * camera.eye_from_world();
        for (i, j, r) in [(0, 0, 1.0f32), (39, 29, 50.5), (20, 3, 100.0)] {
            let point = camera.pixel_centre_world_ray(i, j).at(f64::from(r));
            let clip = projection * point.extend(1.0);
            let reference = convention.ndc_to_window(clip.z / clip.w) as f32;
            let remapped = camera.window_depth_from_radial(i, j, r, &mapping);
            assert!((remapped - reference).abs() <= f32::EPSILON, "{convention}: {remapped} vs {reference}");
            let raster = DVec2::new((clip.x + 1.0) * 20.0, (1.0 - clip.y) * 15.0);
            assert!((raster - pixel_centre(i, j)).length() < 1e-9);
        }
    }
    let infinite = NearFar { near: 0.5, far: 100.5, infinite_far: true };
    // An orthographic camera ignores an infinite far request: the far plane stays finite.
    assert!(camera.depth_mapping(DepthConvention::Wgpu, infinite).is_ok());
    assert!(DepthMapping::orthographic(DepthConvention::Wgpu, 0.5, FarPlane::Infinite).is_err());
}

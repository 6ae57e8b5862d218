//! Property tests: arbitrary shapes and tolerances never panic and never yield NaN.

use super::assert_well_formed;
use crate::{
    DicingRule, Displaced, DisplacementShader, Tolerance, tessellate, tessellate_displaced, tessellate_placed,
};
use glam::{DMat4, DVec3, Vec3, Vec4};
use proptest::prelude::*;
use rib_parser::scene::{
    Basis, NuPatch, NuPatchBasis, ParamList, PatchKind, PatchMesh, PolygonMesh, Shape, SubdivisionMesh,
    SubdivisionTag, TrimCurves, Wrap,
};
use std::sync::Arc;

/// Mostly ordinary numbers, sometimes the awkward ones.
fn number() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -4.0f32..4.0,
        1 => Just(0.0f32),
        1 => prop::sample::select(vec![f32::NAN, f32::INFINITY, -f32::INFINITY, 1e30, -1e30, 1e-30, 360.0, -360.0, 720.0]),
    ]
}

fn angle() -> impl Strategy<Value = f32> {
    prop_oneof![4 => -400.0f32..400.0, 1 => number()]
}

fn point() -> impl Strategy<Value = Vec3> {
    (number(), number(), number()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn tame_point() -> impl Strategy<Value = Vec3> {
    (-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn quadric() -> impl Strategy<Value = Shape> {
    prop_oneof![
        (number(), number(), number(), angle()).prop_map(|(radius, z_min, z_max, t)| Shape::Sphere {
            radius,
            z_min,
            z_max,
            theta_max_degrees: t
        }),
        (number(), number(), number(), angle()).prop_map(|(radius, z_min, z_max, t)| Shape::Cylinder {
            radius,
            z_min,
            z_max,
            theta_max_degrees: t
        }),
        (number(), number(), angle()).prop_map(|(height, radius, t)| Shape::Cone {
            height,
            radius,
            theta_max_degrees: t
        }),
        (number(), number(), angle()).prop_map(|(height, radius, t)| Shape::Disk {
            height,
            radius,
            theta_max_degrees: t
        }),
        (number(), number(), number(), angle()).prop_map(|(r_max, z_min, z_max, t)| Shape::Paraboloid {
            r_max,
            z_min,
            z_max,
            theta_max_degrees: t
        }),
        (point(), point(), angle()).prop_map(|(point1, point2, t)| Shape::Hyperboloid {
            point1,
            point2,
            theta_max_degrees: t
        }),
        (number(), number(), angle(), angle(), angle()).prop_map(|(a, b, p0, p1, t)| Shape::Torus {
            major_radius: a,
            minor_radius: b,
            phi_min_degrees: p0,
            phi_max_degrees: p1,
            theta_max_degrees: t,
        }),
    ]
}

/// Faces as lists of loops of vertex indices into `vertices` positions; one mesh in ten has
/// indices out of range.
fn faces(vertices: u32) -> impl Strategy<Value = Vec<Vec<Vec<u32>>>> {
    let vertices = vertices.max(1);
    let limit = prop_oneof![9 => Just(vertices), 1 => Just(vertices + 2)];
    limit.prop_flat_map(|limit| {
        prop::collection::vec(prop::collection::vec(prop::collection::vec(0..limit, 0..9), 1..4), 0..8)
    })
}

fn polygons() -> impl Strategy<Value = Shape> {
    prop::collection::vec(prop_oneof![6 => tame_point(), 1 => point()], 3..16)
        .prop_flat_map(|positions| {
            let n = positions.len() as u32;
            (Just(positions), faces(n))
        })
        .prop_map(|(positions, faces)| {
            let mut pm = PolygonMesh {
                loops_per_face: Vec::new(),
                vertices_per_loop: Vec::new(),
                vertex_indices: Vec::new(),
                positions,
                primvars: ParamList::default(),
            };
            for f in faces {
                pm.loops_per_face.push(f.len() as u32);
                for l in f {
                    pm.vertices_per_loop.push(l.len() as u32);
                    pm.vertex_indices.extend(l);
                }
            }
            Shape::Polygons(pm)
        })
}

fn basis() -> impl Strategy<Value = Basis> {
    prop_oneof![
        Just(Basis {
            matrix: [-1.0, 3.0, -3.0, 1.0, 3.0, -6.0, 3.0, 0.0, -3.0, 3.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            step: 3
        }),
        Just(Basis {
            matrix: [-1.0, 3.0, -3.0, 1.0, 3.0, -6.0, 3.0, 0.0, -3.0, 0.0, 3.0, 0.0, 1.0, 4.0, 1.0, 0.0]
                .map(|x: f32| x / 6.0),
            step: 1
        }),
        (prop::array::uniform16(-3.0f32..3.0), prop_oneof![9 => 1u32..5, 1 => Just(0u32)])
            .prop_map(|(matrix, step)| Basis { matrix, step }),
    ]
}

fn wrap() -> impl Strategy<Value = Wrap> {
    prop_oneof![Just(Wrap::Periodic), Just(Wrap::NonPeriodic)]
}

fn homogeneous() -> impl Strategy<Value = Vec4> {
    (tame_point(), prop_oneof![30 => Just(1.0f32), 10 => 0.2f32..3.0, 1 => number()])
        .prop_map(|(p, w)| p.extend(w))
}

/// Control points along one direction that fit `patches` patches (usually).
fn fitting_count(bicubic: bool, wrap: Wrap, step: u32, patches: u32) -> u32 {
    match (bicubic, wrap) {
        (false, Wrap::NonPeriodic) => patches + 1,
        (false, Wrap::Periodic) => patches.max(1),
        (true, Wrap::NonPeriodic) => 4 + step * (patches - 1),
        (true, Wrap::Periodic) => (step * patches).max(4),
    }
}

fn patches() -> impl Strategy<Value = Shape> {
    (
        any::<bool>(),
        1u32..4,
        1u32..4,
        wrap(),
        wrap(),
        basis(),
        basis(),
        prop_oneof![8 => Just(0i32), 1 => -1i32..2],
    )
        .prop_flat_map(|(bicubic, pu, pv, u_wrap, v_wrap, u_basis, v_basis, off)| {
            let nu = fitting_count(bicubic, u_wrap, u_basis.step, pu);
            let nv = fitting_count(bicubic, v_wrap, v_basis.step, pv);
            let count = ((nu * nv) as i32 + off).max(0) as usize;
            prop::collection::vec(homogeneous(), count).prop_map(move |positions| {
                Shape::Patches(PatchMesh {
                    kind: if bicubic { PatchKind::Bicubic } else { PatchKind::Bilinear },
                    nu,
                    nv,
                    u_wrap,
                    v_wrap,
                    u_basis,
                    v_basis,
                    positions,
                    primvars: ParamList::default(),
                })
            })
        })
}

/// A knot vector, usually valid (sorted, with repeated knots now and then), sometimes not.
fn knots(len: usize) -> impl Strategy<Value = Vec<f32>> {
    prop_oneof![
        6 => prop::collection::vec(prop_oneof![3 => 0.0f32..3.0, 1 => Just(1.0f32)], len).prop_map(|mut k| {
            k.sort_by(f32::total_cmp);
            k
        }),
        3 => Just((0..len).map(|i| i as f32).collect::<Vec<f32>>()),
        1 => prop::collection::vec(number(), len),
    ]
}

fn trim() -> impl Strategy<Value = Option<Arc<TrimCurves>>> {
    let curve = (2u32..4, 2u32..6).prop_flat_map(|(order, n)| {
        let n = n.max(order);
        (
            Just(order),
            Just(n),
            knots((n + order) as usize),
            prop::collection::vec((0.0f32..3.0, 0.0f32..3.0, 0.3f32..2.0), n as usize),
        )
    });
    prop_oneof![
        2 => Just(None),
        1 => prop::collection::vec(curve, 1..3).prop_map(|curves| {
            let mut t = TrimCurves {
                curves_per_loop: vec![curves.len() as u32],
                order: Vec::new(),
                knots: Vec::new(),
                min: Vec::new(),
                max: Vec::new(),
                n: Vec::new(),
                u: Vec::new(),
                v: Vec::new(),
                w: Vec::new(),
            };
            for (order, n, k, pts) in curves {
                t.order.push(order);
                t.n.push(n);
                t.min.push(k[order as usize - 1]);
                t.max.push(k[n as usize]);
                t.knots.extend(k);
                for (u, v, w) in pts {
                    t.u.push(u * w);
                    t.v.push(v * w);
                    t.w.push(w);
                }
            }
            Some(Arc::new(t))
        }),
    ]
}

fn nupatch() -> impl Strategy<Value = Shape> {
    (
        prop_oneof![9 => 2u32..5, 1 => 0u32..2],
        0u32..4,
        prop_oneof![9 => 2u32..5, 1 => 0u32..2],
        0u32..4,
        prop_oneof![8 => Just(0i32), 1 => -1i32..2],
    )
        .prop_flat_map(|(uo, extra_u, vo, extra_v, off)| {
            let (nu, nv) = (uo.max(1) + extra_u, vo.max(1) + extra_v);
            let count = ((nu * nv) as i32 + off).max(0) as usize;
            (
                knots((nu + uo) as usize),
                knots((nv + vo) as usize),
                prop::collection::vec(homogeneous(), count),
                (number(), number(), number(), number()),
                trim(),
            )
                .prop_map(
                    move |(u_knots, v_knots, positions, (u_min, u_max, v_min, v_max), trim)| {
                        // Ranges usually from the knots, sometimes arbitrary.
                        let pick = |x: f32, k: &[f32], i: usize| {
                            if x.abs() < 3.0 {
                                k.get(i.min(k.len().saturating_sub(1))).copied().unwrap_or(x)
                            } else {
                                x
                            }
                        };
                        Shape::NuPatch(NuPatch {
                            basis: NuPatchBasis {
                                nu,
                                u_order: uo,
                                u_min: pick(u_min, &u_knots, (uo as usize).saturating_sub(1)),
                                u_max: pick(u_max, &u_knots, nu as usize),
                                u_knots,
                                nv,
                                v_order: vo,
                                v_min: pick(v_min, &v_knots, (vo as usize).saturating_sub(1)),
                                v_max: pick(v_max, &v_knots, nv as usize),
                                v_knots,
                            },
                            positions,
                            trim,
                            primvars: ParamList::default(),
                        })
                    },
                )
        })
}

fn subdivision() -> impl Strategy<Value = Shape> {
    let tag = (
        prop::sample::select(vec!["interpolateboundary", "crease", "corner", "hole", "smoothtriangles"]),
        prop::collection::vec(-2i32..12, 0..6),
        prop::collection::vec(prop_oneof![0.0f32..12.0, number()], 0..3),
    )
        .prop_map(|(name, int_args, float_args)| SubdivisionTag {
            name: name.into(),
            int_args,
            float_args,
            string_args: Vec::new(),
        });
    prop::collection::vec(tame_point(), 3..12)
        .prop_flat_map(move |positions| {
            let n = positions.len() as u32;
            (Just(positions), faces(n), prop::collection::vec(tag.clone(), 0..4), any::<bool>())
        })
        .prop_map(|(positions, faces, mut tags, interpolate)| {
            if interpolate {
                tags.insert(
                    0,
                    SubdivisionTag {
                        name: "interpolateboundary".into(),
                        int_args: vec![],
                        float_args: vec![],
                        string_args: vec![],
                    },
                );
            }
            let faces: Vec<Vec<u32>> = faces.into_iter().filter_map(|f| f.into_iter().next()).collect();
            Shape::SubdivisionMesh(SubdivisionMesh {
                scheme: "catmull-clark".into(),
                vertices_per_face: faces.iter().map(|f| f.len() as u32).collect(),
                vertex_indices: faces.into_iter().flatten().collect(),
                tags,
                positions,
                primvars: ParamList::default(),
            })
        })
}

fn tolerance() -> impl Strategy<Value = Tolerance> {
    prop_oneof![
        (1e-4f64..0.3).prop_map(Tolerance::relative),
        (1e-4f64..1.0).prop_map(Tolerance::absolute),
        prop::sample::select(vec![0.0, -1.0, f64::NAN, 1e-300]).prop_map(Tolerance::absolute),
    ]
    .prop_map(|t| t.with_max_triangles(30_000))
}

fn check(shape: &Shape, tol: &Tolerance) {
    if let Ok(mesh) = tessellate(shape, tol) {
        assert_well_formed(&mesh);
        assert!(mesh.triangle_count() as u64 <= tol.max_triangles);
    }
    let m = DMat4::from_scale(DVec3::new(-2.0, 1.0, 0.5)) * DMat4::from_rotation_z(1.0);
    if let Ok(mesh) = tessellate_placed(shape, &m, true, tol) {
        assert_well_formed(&mesh);
    }
}

/// A displacement shader with arbitrary amounts and a dicing rule with arbitrary rates.
fn displacement() -> impl Strategy<Value = (DisplacementShader, DicingRule)> {
    let shader = prop_oneof![
        number().prop_map(|km| DisplacementShader::Dented {
            km: f64::from(km),
            world_from_shader: DMat4::IDENTITY
        }),
        (number(), number()).prop_map(|(km, amplitude)| DisplacementShader::Bumpy {
            km: f64::from(km),
            amplitude: f64::from(amplitude),
            texture: Some("t".into()),
        }),
    ];
    let rate = prop_oneof![3 => 0.1f64..16.0, 1 => prop::sample::select(vec![1e-30, 0.0, f64::NAN, 1e30])];
    let rule = prop_oneof![
        (rate.clone(), 1e-4f64..1e-2).prop_map(|(shading_rate, radians_per_pixel)| {
            DicingRule::Perspective { eye: DVec3::new(0.0, 0.0, -5.0), radians_per_pixel, shading_rate }
        }),
        rate.prop_map(|shading_rate| DicingRule::Orthographic { pixel: 0.01, shading_rate }),
        (-1.0f64..0.5).prop_map(DicingRule::RelativeToSize),
    ];
    (shader, rule)
}

/// A displaced shape stays within its budget and is well formed, whatever the shader does.
fn check_displaced(shape: &Shape, tol: &Tolerance, (shader, dicing): &(DisplacementShader, DicingRule)) {
    let texture = |_: &str, st: glam::Vec2| Some(f64::from(st.x * 3.0 - 1.0));
    let displaced =
        Displaced { shader, world_from_placed: DMat4::IDENTITY, texture: &texture, dicing: *dicing };
    let m = DMat4::from_scale(DVec3::new(-2.0, 1.0, 0.5)) * DMat4::from_rotation_z(1.0);
    if let Ok(out) = tessellate_displaced(shape, &m, true, tol, &displaced) {
        assert_well_formed(&out.mesh);
        assert!(out.mesh.triangle_count() as u64 <= tol.max_triangles.max(out.dicing.base_triangles as u64));
    }
}

proptest! {
    // 200 cases each in the normal suite; `PROPTEST_CASES=N` runs more.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(200),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn quadrics_never_panic_or_nan(shape in quadric(), tol in tolerance()) {
        check(&shape, &tol);
    }

    #[test]
    fn polygons_never_panic_or_nan(shape in polygons(), tol in tolerance()) {
        check(&shape, &tol);
    }

    #[test]
    fn patches_never_panic_or_nan(shape in patches(), tol in tolerance()) {
        check(&shape, &tol);
    }

    #[test]
    fn nupatches_never_panic_or_nan(shape in nupatch(), tol in tolerance()) {
        check(&shape, &tol);
    }

    #[test]
    fn subdivision_meshes_never_panic_or_nan(shape in subdivision(), tol in tolerance()) {
        check(&shape, &tol);
    }

    #[test]
    fn displaced_shapes_never_panic_or_nan(
        shape in prop_oneof![quadric(), polygons(), patches()],
        tol in tolerance(),
        displacement in displacement(),
    ) {
        check_displaced(&shape, &tol, &displacement);
    }
}

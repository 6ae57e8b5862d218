//! Tessellation throughput: triangles per second for every shape family.
//!
//! `cargo bench -p tessellate --bench tessellate` (figures in docs/tessellation.md). Each case
//! reports its triangle count as criterion's element throughput, so "elem/s" is triangles per
//! second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{DMat4, DVec3, Vec3, Vec4};
use rib_parser::scene::{
    Basis, NuPatch, NuPatchBasis, ParamList, PatchKind, PatchMesh, PolygonMesh, Shape, SubdivisionMesh,
    SubdivisionTag, TrimCurves, Wrap,
};
use std::hint::black_box;
use std::sync::Arc;
use tessellate::{Tolerance, tessellate, tessellate_placed};

fn sphere() -> Shape {
    Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 }
}

fn torus() -> Shape {
    Shape::Torus {
        major_radius: 1.0,
        minor_radius: 0.3,
        phi_min_degrees: 0.0,
        phi_max_degrees: 360.0,
        theta_max_degrees: 360.0,
    }
}

fn hyperboloid() -> Shape {
    Shape::Hyperboloid {
        point1: Vec3::new(1.0, -1.0, -1.0),
        point2: Vec3::new(1.0, 1.0, 1.0),
        theta_max_degrees: 360.0,
    }
}

/// A `n x n` grid of quads, wavy in z, as one `PointsPolygons`.
fn quad_grid(n: usize) -> Shape {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            positions.push(Vec3::new(x, y, 0.05 * (7.0 * x).sin() * (5.0 * y).cos()));
        }
    }
    let mut vertex_indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let v = |a: usize, b: usize| (b * (n + 1) + a) as u32;
            vertex_indices.extend([v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    Shape::Polygons(PolygonMesh {
        loops_per_face: vec![1; n * n],
        vertices_per_loop: vec![4; n * n],
        vertex_indices,
        positions,
        primvars: ParamList::default(),
    })
}

/// One `GeneralPolygon`: a 400-gon with 100 square holes (ear clipping with hole bridging).
fn holey_polygon() -> Shape {
    let mut positions = Vec::new();
    let mut loops = Vec::new();
    for k in 0..400 {
        let a = k as f32 * std::f32::consts::TAU / 400.0;
        positions.push(Vec3::new(20.0 * a.cos(), 20.0 * a.sin(), 0.0));
    }
    loops.push(400);
    for i in 0..10 {
        for j in 0..10 {
            let (x, y) = (-12.0 + 2.5 * i as f32, -12.0 + 2.5 * j as f32);
            positions.extend([
                Vec3::new(x, y, 0.0),
                Vec3::new(x, y + 1.0, 0.0),
                Vec3::new(x + 1.0, y + 1.0, 0.0),
                Vec3::new(x + 1.0, y, 0.0),
            ]);
            loops.push(4);
        }
    }
    Shape::Polygons(PolygonMesh {
        loops_per_face: vec![loops.len() as u32],
        vertex_indices: (0..positions.len() as u32).collect(),
        vertices_per_loop: loops,
        positions,
        primvars: ParamList::default(),
    })
}

/// A closed bicubic B-spline tube, 16 x 8 control points.
fn bspline_torus() -> Shape {
    let m = [-1.0, 3.0, -3.0, 1.0, 3.0, -6.0, 3.0, 0.0, -3.0, 0.0, 3.0, 0.0, 1.0, 4.0, 1.0, 0.0]
        .map(|x: f32| x / 6.0);
    let basis = Basis { matrix: m, step: 1 };
    let (ring, rows) = (16, 8);
    let mut positions = Vec::new();
    for j in 0..rows {
        let phi = j as f32 / rows as f32 * std::f32::consts::TAU;
        for i in 0..ring {
            let theta = i as f32 / ring as f32 * std::f32::consts::TAU;
            let rho = 1.0 + 0.3 * phi.cos();
            positions.push(Vec4::new(rho * theta.cos(), rho * theta.sin(), 0.3 * phi.sin(), 1.0));
        }
    }
    Shape::Patches(PatchMesh {
        kind: PatchKind::Bicubic,
        nu: ring,
        nv: rows,
        u_wrap: Wrap::Periodic,
        v_wrap: Wrap::Periodic,
        u_basis: basis,
        v_basis: basis,
        positions,
        primvars: ParamList::default(),
    })
}

const H: f32 = std::f32::consts::FRAC_1_SQRT_2;
const CIRCLE: [(f32, f32, f32); 9] = [
    (1.0, 0.0, 1.0),
    (1.0, 1.0, H),
    (0.0, 1.0, 1.0),
    (-1.0, 1.0, H),
    (-1.0, 0.0, 1.0),
    (-1.0, -1.0, H),
    (0.0, -1.0, 1.0),
    (1.0, -1.0, H),
    (1.0, 0.0, 1.0),
];
const CIRCLE_KNOTS: [f32; 12] = [0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0];

/// The rational unit sphere (9 x 5 control points, quadratic).
fn nurbs_sphere() -> NuPatch {
    let half: [(f32, f32, f32); 5] =
        [(0.0, -1.0, 1.0), (1.0, -1.0, H), (1.0, 0.0, 1.0), (1.0, 1.0, H), (0.0, 1.0, 1.0)];
    let mut positions = Vec::new();
    for (rho, z, wv) in half {
        for (x, y, wu) in CIRCLE {
            let w = wu * wv;
            positions.push(Vec4::new(x * rho * w, y * rho * w, z * w, w));
        }
    }
    NuPatch {
        basis: NuPatchBasis {
            nu: 9,
            u_order: 3,
            u_knots: CIRCLE_KNOTS.to_vec(),
            u_min: 0.0,
            u_max: 1.0,
            nv: 5,
            v_order: 3,
            v_knots: vec![0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0],
            v_min: 0.0,
            v_max: 1.0,
        },
        positions,
        trim: None,
        primvars: ParamList::default(),
    }
}

/// The NURBS sphere with a circular hole trimmed out of its side.
fn trimmed_nurbs() -> Shape {
    let mut np = nurbs_sphere();
    let mut t = TrimCurves {
        curves_per_loop: vec![1, 1],
        order: vec![2, 3],
        knots: vec![0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0],
        min: vec![0.0, 0.0],
        max: vec![4.0, 1.0],
        n: vec![5, 9],
        u: vec![0.0, 1.0, 1.0, 0.0, 0.0],
        v: vec![0.0, 0.0, 1.0, 1.0, 0.0],
        w: vec![1.0; 5],
    };
    t.knots.extend(CIRCLE_KNOTS);
    for (x, y, w) in CIRCLE {
        t.u.push((0.5 + 0.2 * x) * w);
        t.v.push((0.5 + 0.2 * y) * w);
        t.w.push(w);
    }
    np.trim = Some(Arc::new(t));
    Shape::NuPatch(np)
}

/// A cube of 6 quads with two semi-sharp creases and a corner.
fn subdivision_cube() -> Shape {
    let positions = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let faces: [[u32; 4]; 6] =
        [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]];
    let tag = |name: &str, int_args: Vec<i32>, float_args: Vec<f32>| SubdivisionTag {
        name: name.into(),
        int_args,
        float_args,
        string_args: Vec::new(),
    };
    Shape::SubdivisionMesh(SubdivisionMesh {
        scheme: "catmull-clark".into(),
        vertices_per_face: vec![4; 6],
        vertex_indices: faces.iter().flatten().copied().collect(),
        tags: vec![tag("crease", vec![4, 5, 6, 7, 4], vec![2.5]), tag("crease", vec![0, 1], vec![10.0])],
        positions: positions.iter().map(|p| Vec3::from_array(*p)).collect(),
        primvars: ParamList::default(),
    })
}

/// The smooth cube on a 12 x 12 x 12 control lattice (864 faces).
fn subdivision_box() -> Shape {
    let n = 12usize;
    let mut positions: Vec<Vec3> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut id = |p: [i32; 3], positions: &mut Vec<Vec3>| -> u32 {
        *index.entry(p).or_insert_with(|| {
            positions.push(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / n as f32);
            (positions.len() - 1) as u32
        })
    };
    let mut vertex_indices = Vec::new();
    let n = n as i32;
    // Each cube face as an n x n grid, wound outward.
    for axis in 0..3 {
        for side in [0, n] {
            for a in 0..n {
                for b in 0..n {
                    let corner = |da: i32, db: i32| {
                        let mut p = [0; 3];
                        p[axis] = side;
                        p[(axis + 1) % 3] = a + da;
                        p[(axis + 2) % 3] = b + db;
                        p
                    };
                    let mut quad = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    if side == 0 {
                        quad.reverse();
                    }
                    for p in quad {
                        vertex_indices.push(id(p, &mut positions));
                    }
                }
            }
        }
    }
    Shape::SubdivisionMesh(SubdivisionMesh {
        scheme: "catmull-clark".into(),
        vertices_per_face: vec![4; vertex_indices.len() / 4],
        vertex_indices,
        tags: Vec::new(),
        positions,
        primvars: ParamList::default(),
    })
}

fn bench(c: &mut Criterion) {
    let cases: Vec<(&str, Shape, Tolerance)> = vec![
        ("sphere", sphere(), Tolerance::absolute(1e-4)),
        ("torus", torus(), Tolerance::absolute(1e-4)),
        ("hyperboloid", hyperboloid(), Tolerance::absolute(1e-4)),
        ("polygons_quad_grid", quad_grid(300), Tolerance::default()),
        ("polygon_400gon_100_holes", holey_polygon(), Tolerance::default()),
        ("patchmesh_bspline", bspline_torus(), Tolerance::absolute(1e-4)),
        ("nupatch_sphere", Shape::NuPatch(nurbs_sphere()), Tolerance::absolute(1e-4)),
        ("nupatch_trimmed", trimmed_nurbs(), Tolerance::absolute(1e-4)),
        ("subdivision_creased_cube", subdivision_cube(), Tolerance::absolute(1e-4)),
        ("subdivision_864_faces", subdivision_box(), Tolerance::absolute(1e-4)),
    ];
    let mut group = c.benchmark_group("tessellate");
    group.sample_size(10);
    for (name, shape, tol) in &cases {
        let triangles = tessellate(shape, tol).expect("tessellates").triangle_count();
        group.throughput(Throughput::Elements(triangles as u64));
        group.bench_function(format!("{name}/{triangles}_triangles"), |b| {
            b.iter(|| tessellate(black_box(shape), black_box(tol)).expect("tessellates"))
        });
    }
    // Placement in world space: the same sphere with a transform (f64 transform, re-winding).
    let m = DMat4::from_scale_rotation_translation(DVec3::new(2.0, -1.0, 1.0), Default::default(), DVec3::X);
    let tol = Tolerance::absolute(1e-4);
    let triangles = tessellate_placed(&sphere(), &m, true, &tol).expect("tessellates").triangle_count();
    group.throughput(Throughput::Elements(triangles as u64));
    group.bench_function(format!("sphere_placed/{triangles}_triangles"), |b| {
        b.iter(|| {
            tessellate_placed(black_box(&sphere()), black_box(&m), true, black_box(&tol))
                .expect("tessellates")
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

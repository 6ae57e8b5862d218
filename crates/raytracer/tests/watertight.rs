//! Watertight seams between separate patch primitives (issue 11): rays aimed at shared edges,
//! from many directions and from both sides, must meet the surface there, both in the ray
//! tracer's world and on the haptic proxy's triangles.
//!
//! Scenes: the aqsis teapot (32 Bezier `NuPatch`es), a `PatchMesh` per basis split into 2 x 2
//! separate primitives, a periodic b-spline tube split in two, two uniform-knot `NuPatch`es
//! (one walked backwards) sharing a side, a closed subdivision mesh, and a closed body cut
//! into two subdivision meshes that dice their shared boundary at different levels. Each seam
//! point is the true surface at the shared parameter line, nudged across the seam by up to a
//! few tessellation tolerances; a ray from a quarter of the scene away must hit within a few
//! tolerances of it. A crack (T-junction or a few-ulp mismatch) lets some of these rays
//! through to whatever lies behind, or to nothing.

use glam::{DMat4, DVec3, Vec3, Vec4};
use haptics::Bvh;
use haptics::scene::{scene_geometry, tessellation_tolerance};
use raytracer::diagnostics::Diagnostics;
use raytracer::shapes::{RayShear, intersect_triangle};
use raytracer::world::{PixelFootprint, Ray, World};
use rib_parser::scene::{Scene, Shape};

/// A small deterministic generator (xorshift64*), so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }

    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

/// A bicubic patch mesh evaluated as RISpec defines it (non-rational): the test's own
/// evaluator, independent of the tessellator's.
struct Surface {
    mu: [f64; 16],
    mv: [f64; 16],
    step: (usize, usize),
    n: (usize, usize),
    periodic: (bool, bool),
    control: Vec<DVec3>,
    world_from_object: DMat4,
}

impl Surface {
    fn patches(&self) -> (usize, usize) {
        let count =
            |n: usize, step: usize, periodic: bool| if periodic { n / step } else { (n - 4) / step + 1 };
        (count(self.n.0, self.step.0, self.periodic.0), count(self.n.1, self.step.1, self.periodic.1))
    }

    /// World position and the two parametric derivatives at `(u, v)` (`u` in `[0, patches]`).
    fn eval(&self, u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
        let (pu, pv) = self.patches();
        let locate = |t: f64, patches: usize| {
            let p = (t.floor().max(0.0) as usize).min(patches - 1);
            (p, t - p as f64)
        };
        let weights = |m: &[f64; 16], t: f64| {
            let (pw, dw) = ([t * t * t, t * t, t, 1.0], [3.0 * t * t, 2.0 * t, 1.0, 0.0]);
            let mut w = [0.0; 4];
            let mut d = [0.0; 4];
            for k in 0..4 {
                for r in 0..4 {
                    w[k] += pw[r] * m[4 * r + k];
                    d[k] += dw[r] * m[4 * r + k];
                }
            }
            (w, d)
        };
        let ((iu, tu), (iv, tv)) = (locate(u, pu), locate(v, pv));
        let ((wu, du), (wv, dv)) = (weights(&self.mu, tu), weights(&self.mv, tv));
        let (mut p, mut p_u, mut p_v) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
        for b in 0..4 {
            for a in 0..4 {
                let col = (iu * self.step.0 + a) % self.n.0;
                let row = (iv * self.step.1 + b) % self.n.1;
                let g = self.control[row * self.n.0 + col];
                p += wu[a] * wv[b] * g;
                p_u += du[a] * wv[b] * g;
                p_v += wu[a] * dv[b] * g;
            }
        }
        let m = &self.world_from_object;
        (m.transform_point3(p), m.transform_vector3(p_u), m.transform_vector3(p_v))
    }
}

/// A shared parameter line of a surface: `u = at` (`along_v`) or `v = at`, over `range`.
struct Seam {
    surface: usize,
    along_v: bool,
    at: f64,
    range: (f64, f64),
}

/// A ray aimed at `aim` from `length` away along `-direction`.
struct Probe {
    aim: DVec3,
    direction: DVec3,
}

/// Probes across every seam: `per_seam` points of the surface, each up to `jitter` across the
/// seam in the parameter, with a direction within 60 degrees of the surface normal there, from
/// either side.
fn seam_probes(
    surfaces: &[Surface],
    seams: &[Seam],
    per_seam: usize,
    jitter: f64,
    rng: &mut Rng,
) -> Vec<Probe> {
    let mut probes = Vec::new();
    for seam in seams {
        let s = &surfaces[seam.surface];
        let (a, b) = seam.range;
        let mut made = 0;
        let mut tries = 0;
        while made < per_seam && tries < 20 * per_seam {
            tries += 1;
            let t = rng.range(a + 0.01 * (b - a), b - 0.01 * (b - a));
            // Across the seam by up to `jitter` in the parameter, most of them very close: a
            // point of the true surface on either side (also where the seam is a crease).
            let r = rng.range(-1.0, 1.0);
            let across = jitter * r * r * r;
            let (u, v) = if seam.along_v { (seam.at + across, t) } else { (t, seam.at + across) };
            let (aim, p_u, p_v) = s.eval(u, v);
            let normal = p_u.cross(p_v);
            if normal.length() <= 1e-9 * p_u.length().max(p_v.length()).powi(2) {
                continue; // A pole: no seam to cross there.
            }
            let n = normal.normalize();
            let direction = loop {
                let d = rng.unit();
                if d.dot(n).abs() >= 60f64.to_radians().cos() {
                    break d;
                }
            };
            probes.push(Probe { aim, direction });
            made += 1;
        }
    }
    probes
}

fn load(name: &str, rib: String) -> Scene {
    rib_parser::load_bytes(name, rib.into_bytes(), &Default::default()).expect("scene parses").scene
}

fn bounds_size(surfaces: &[Surface]) -> (DVec3, f64) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for s in surfaces {
        for &c in &s.control {
            let p = s.world_from_object.transform_point3(c);
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    ((lo + hi) * 0.5, (hi - lo).length())
}

/// Counts the probes that do not meet the surface within `tol` of their aim point: in the
/// ray tracer's world (the eye placed so that every patch gets its own pixel-based tolerance,
/// as in a render) and on the haptic proxy's collision triangles.
fn leaks(scene: &Scene, probes: &[Probe], length: f64, tol: f64, eye: DVec3) -> (usize, usize) {
    let mut diagnostics = Diagnostics::default();
    let footprint = PixelFootprint::Perspective { radians_per_pixel: 1e-3 };
    let world = World::build(scene, eye, footprint, &mut diagnostics).expect("world builds");
    let mut world_leaks = 0;
    for probe in probes {
        let origin = probe.aim - probe.direction * length - eye;
        let ray = Ray::new(origin.as_vec3(), probe.direction.as_vec3());
        match world.intersect(&ray) {
            Some(hit) if f64::from(hit.t) <= length + tol => {}
            _ => world_leaks += 1,
        }
    }

    let geometry = scene_geometry(scene, &tessellation_tolerance(None));
    let bvh = Bvh::build(&geometry.mesh);
    let mut proxy_leaks = 0;
    for probe in probes {
        let aim = geometry.mesh.local_from_world(probe.aim);
        let origin = aim - probe.direction * length;
        let shear = RayShear::new(origin.as_vec3(), probe.direction.as_vec3()).expect("a ray");
        let mut hit = false;
        bvh.for_each_within(aim, tol, |index, _, _| {
            let [p0, p1, p2] = geometry.mesh.triangle_f32(index as usize);
            if let Some(h) = intersect_triangle(&shear, p0, p1, p2, (length + tol) as f32) {
                hit |= (f64::from(h.t) - length).abs() <= tol;
            }
        });
        if !hit {
            proxy_leaks += 1;
        }
    }
    (world_leaks, proxy_leaks)
}

/// Counts the probes that, started `back` before their aim point, meet no surface within `reach`:
/// in the ray tracer's world and on the haptic proxy's collision triangles.
fn leaks_before(scene: &Scene, probes: &[Probe], (back, reach): (f64, f64), eye: DVec3) -> (usize, usize) {
    let mut diagnostics = Diagnostics::default();
    let footprint = PixelFootprint::Perspective { radians_per_pixel: 1e-3 };
    let world = World::build(scene, eye, footprint, &mut diagnostics).expect("world builds");
    let geometry = scene_geometry(scene, &tessellation_tolerance(None));
    let triangles: Vec<[Vec3; 3]> =
        (0..geometry.mesh.triangle_count()).map(|t| geometry.mesh.triangle_f32(t)).collect();
    let (mut world_leaks, mut proxy_leaks) = (0, 0);
    for probe in probes {
        let origin = probe.aim - probe.direction * back;
        let ray = Ray::new((origin - eye).as_vec3(), probe.direction.as_vec3());
        if !world.intersect(&ray).is_some_and(|h| f64::from(h.t) <= reach) {
            world_leaks += 1;
        }
        let local = geometry.mesh.local_from_world(origin);
        let shear = RayShear::new(local.as_vec3(), probe.direction.as_vec3()).expect("a ray");
        if !triangles.iter().any(|&[a, b, c]| intersect_triangle(&shear, a, b, c, reach as f32).is_some()) {
            proxy_leaks += 1;
        }
    }
    (world_leaks, proxy_leaks)
}

fn assert_watertight(name: &str, scene: &Scene, surfaces: &[Surface], seams: &[Seam], per_seam: usize) {
    let (centre, size) = bounds_size(surfaces);
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let probes = seam_probes(surfaces, seams, per_seam, 0.02, &mut rng);
    let (length, tol) = (0.25 * size, 0.02 * size);
    let eye = centre + DVec3::new(0.3, -0.4, 2.0) * size;
    let (world_leaks, proxy_leaks) = leaks(scene, &probes, length, tol, eye);
    eprintln!(
        "{name}: {} probes on {} seams: {world_leaks} world leaks, {proxy_leaks} proxy leaks",
        probes.len(),
        seams.len()
    );
    assert!(probes.len() >= seams.len() * per_seam / 2, "{name}: too few probes");
    assert_eq!((world_leaks, proxy_leaks), (0, 0), "{name}: rays through seams (world, haptic proxy)");
}

/// The basis matrix of `Basis "name"`, as the parser reads it.
fn basis_of(scene: &Scene) -> ([f64; 16], usize) {
    match &*scene.shapes[0].shape {
        Shape::Patches(m) => (m.u_basis.matrix.map(f64::from), m.u_basis.step as usize),
        _ => panic!("a PatchMesh"),
    }
}

fn rib_points(points: impl IntoIterator<Item = DVec3>) -> String {
    points.into_iter().map(|p| format!("{} {} {} ", p.x as f32, p.y as f32, p.z as f32)).collect()
}

/// A bumpy height field over an `n x n` control grid.
fn height_field(n: usize) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f64, j as f64);
            out.push(DVec3::new(x, y, 1.5 * (0.9 * x).sin() * (0.7 * y + 0.3).cos() + 0.05 * x * y));
        }
    }
    out
}

/// Hermite geometry of the smooth surface `(3u, 3v, h(3u, 3v))` over `patches x patches`:
/// positions and parametric derivatives at the patch corners, interleaved as the Hermite basis
/// (step 2) takes them, so neighbouring patches share a corner's position and tangents.
fn hermite_field(patches: usize) -> (Vec<DVec3>, usize) {
    let h = |x: f64, y: f64| 1.5 * (0.3 * x).sin() * (0.25 * y + 0.3).cos();
    let h_x = |x: f64, y: f64| 0.45 * (0.3 * x).cos() * (0.25 * y + 0.3).cos();
    let h_y = |x: f64, y: f64| -0.375 * (0.3 * x).sin() * (0.25 * y + 0.3).sin();
    let h_xy = |x: f64, y: f64| -0.1125 * (0.3 * x).cos() * (0.25 * y + 0.3).sin();
    let n = 2 * (patches + 1);
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (3.0 * (i / 2) as f64, 3.0 * (j / 2) as f64);
            out.push(match (i % 2, j % 2) {
                (0, 0) => DVec3::new(x, y, h(x, y)),
                (1, 0) => DVec3::new(3.0, 0.0, 3.0 * h_x(x, y)),
                (0, 1) => DVec3::new(0.0, 3.0, 3.0 * h_y(x, y)),
                _ => DVec3::new(0.0, 0.0, 9.0 * h_xy(x, y)),
            });
        }
    }
    (out, n)
}

const BEZIER: [f64; 16] =
    [-1.0, 3.0, -3.0, 1.0, 3.0, -6.0, 3.0, 0.0, -3.0, 3.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];

/// Power-basis coefficients of the Bezier patch grid `bezier` (`n x n`, step 3): `M G M^T` per
/// patch, so the power mesh is the same (continuous) surface.
fn bezier_to_power(bezier: &[DVec3], n: usize) -> (Vec<DVec3>, usize) {
    let patches = (n - 4) / 3 + 1;
    let m = |r: usize, c: usize| BEZIER[4 * r + c];
    let size = 4 * patches;
    let mut out = vec![DVec3::ZERO; size * size];
    for pv in 0..patches {
        for pu in 0..patches {
            for r in 0..4 {
                for c in 0..4 {
                    let mut sum = DVec3::ZERO;
                    for b in 0..4 {
                        for a in 0..4 {
                            sum += m(r, b) * m(c, a) * bezier[(3 * pv + b) * n + 3 * pu + a];
                        }
                    }
                    out[(4 * pv + r) * size + 4 * pu + c] = sum;
                }
            }
        }
    }
    (out, size)
}

#[test]
fn patch_meshes_of_every_basis_split_into_pieces_have_no_cracks() {
    for (basis, step) in [("bezier", 3), ("b-spline", 1), ("catmull-rom", 1), ("hermite", 2), ("power", 4)] {
        // Four patches each way, as 2 x 2 separate PatchMeshes of 2 x 2 patches.
        let (control, n) = match basis {
            "power" => bezier_to_power(&height_field(13), 13),
            "hermite" => hermite_field(4),
            _ => (height_field(4 + 3 * step), 4 + 3 * step),
        };
        let piece = 4 + step;
        let mut rib = format!("Basis \"{basis}\" {step} \"{basis}\" {step}\n");
        for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let (i0, j0) = (2 * step * a, 2 * step * b);
            let points = (j0..j0 + piece).flat_map(|j| (i0..i0 + piece).map(move |i| (i, j)));
            let points = rib_points(points.map(|(i, j)| control[j * n + i]));
            rib += &format!(
                "PatchMesh \"bicubic\" {piece} \"nonperiodic\" {piece} \"nonperiodic\" \"P\" [{points}]\n"
            );
        }
        let scene = load("split.rib", format!("WorldBegin\n{rib}WorldEnd\n"));
        let (m, parsed_step) = basis_of(&scene);
        assert_eq!(parsed_step, step);
        let surface = Surface {
            mu: m,
            mv: m,
            step: (step, step),
            n: (n, n),
            periodic: (false, false),
            control,
            world_from_object: DMat4::IDENTITY,
        };
        let seams = [
            Seam { surface: 0, along_v: true, at: 2.0, range: (0.0, 4.0) },
            Seam { surface: 0, along_v: false, at: 2.0, range: (0.0, 4.0) },
        ];
        assert_watertight(basis, &scene, &[surface], &seams, 300);
    }
}

#[test]
fn a_periodic_bspline_tube_split_in_two_has_no_crack() {
    // Eight control points around, seven along z; the second piece starts three rows on.
    let (ring, rows) = (8, 7);
    let control: Vec<DVec3> = (0..rows)
        .flat_map(|j| {
            (0..ring).map(move |i| {
                let a = std::f64::consts::TAU * i as f64 / ring as f64;
                let r = 2.0 + 0.6 * (1.3 * j as f64).sin() + 0.3 * (3.0 * a).cos();
                DVec3::new(r * a.cos(), r * a.sin(), 1.2 * j as f64)
            })
        })
        .collect();
    let mut rib = "Basis \"b-spline\" 1 \"b-spline\" 1\n".to_string();
    for j0 in [0, 2] {
        let points = rib_points(control[j0 * ring..(j0 + 5) * ring].iter().copied());
        rib += &format!("PatchMesh \"bicubic\" {ring} \"periodic\" 5 \"nonperiodic\" \"P\" [{points}]\n");
    }
    let scene = load("tube.rib", format!("WorldBegin\n{rib}WorldEnd\n"));
    let (m, _) = basis_of(&scene);
    let surface = Surface {
        mu: m,
        mv: m,
        step: (1, 1),
        n: (ring, rows),
        periodic: (true, false),
        control,
        world_from_object: DMat4::IDENTITY,
    };
    // The seam between the pieces, and the periodic seam of each piece (u = 0).
    let seams = [
        Seam { surface: 0, along_v: false, at: 2.0, range: (0.0, 8.0) },
        Seam { surface: 0, along_v: true, at: 0.0, range: (0.0, 4.0) },
    ];
    assert_watertight("periodic b-spline", &scene, &[surface], &seams, 600);
}

#[test]
fn nupatches_sharing_a_side_have_no_crack() {
    // One uniform cubic B-spline surface over 9 x 5 control points (six knot spans in u),
    // given as two NuPatches over columns 0..6 and 3..9; the second one walks u backwards.
    let (nu, nv) = (9, 5);
    let control = {
        let f = height_field(nu);
        (0..nv).flat_map(|j| (0..nu).map(move |i| (i, j))).map(|(i, j)| f[j * nu + i]).collect::<Vec<_>>()
    };
    let knots = |n: usize| (0..n + 4).map(|k| format!("{k} ")).collect::<String>();
    let mut rib = String::new();
    for (i0, backwards) in [(0, false), (3, true)] {
        let mut cols: Vec<usize> = (i0..i0 + 6).collect();
        if backwards {
            cols.reverse();
        }
        let points: String = (0..nv)
            .flat_map(|j| cols.iter().map(move |&i| (i, j)))
            .map(|(i, j)| {
                let p = control[j * nu + i];
                format!("{} {} {} 1 ", p.x as f32, p.y as f32, p.z as f32)
            })
            .collect();
        rib += &format!("NuPatch 6 4 [{}] 3 6 {nv} 4 [{}] 3 {nv} \"Pw\" [{points}]\n", knots(6), knots(nv));
    }
    let scene = load("nupatch.rib", format!("WorldBegin\n{rib}WorldEnd\n"));
    let s = 1.0 / 6.0;
    let bspline = [-s, 0.5, -0.5, s, 0.5, -1.0, 0.5, 0.0, -0.5, 0.0, 0.5, 0.0, s, 4.0 * s, s, 0.0];
    let surface = Surface {
        mu: bspline,
        mv: bspline,
        step: (1, 1),
        n: (nu, nv),
        periodic: (false, false),
        control,
        world_from_object: DMat4::IDENTITY,
    };
    // Columns 3..9 start at patch 3 of the whole surface.
    let seams = [Seam { surface: 0, along_v: true, at: 3.0, range: (0.0, 2.0) }];
    assert_watertight("NuPatch", &scene, &[surface], &seams, 600);
}

/// The sides of a Bezier patch given as 16 homogeneous points: bottom (v = 0), top (v = 1),
/// left (u = 0), right (u = 1), each with its parameter line.
fn teapot_sides(p: &[Vec4]) -> [([Vec4; 4], bool, f64); 4] {
    let pick = |idx: [usize; 4]| idx.map(|k| p[k]);
    [
        (pick([0, 1, 2, 3]), false, 0.0),
        (pick([12, 13, 14, 15]), false, 1.0),
        (pick([0, 4, 8, 12]), true, 0.0),
        (pick([3, 7, 11, 15]), true, 1.0),
    ]
}

/// The 32 Bezier patches of a teapot (16 homogeneous control points each, with their
/// placement) as surfaces, and every side that another patch shares as a seam.
fn teapot_surfaces(patches: &[(Vec<Vec4>, DMat4)]) -> (Vec<Surface>, Vec<Seam>) {
    let mut surfaces = Vec::new();
    let mut sides = Vec::new();
    for (positions, world_from_object) in patches {
        for (side, along_v, at) in teapot_sides(positions) {
            sides.push((surfaces.len(), side, along_v, at));
        }
        surfaces.push(Surface {
            mu: BEZIER,
            mv: BEZIER,
            step: (3, 3),
            n: (4, 4),
            periodic: (false, false),
            control: positions.iter().map(|p| (p.truncate() / p.w).as_dvec3()).collect(),
            world_from_object: *world_from_object,
        });
    }
    assert_eq!(surfaces.len(), 32);
    // A side is a seam when another patch has the same four control points, either way round.
    let mut seams = Vec::new();
    for (k, (s, side, along_v, at)) in sides.iter().enumerate() {
        let collapsed = side.iter().all(|p| *p == side[0]);
        let mut reversed = *side;
        reversed.reverse();
        let shared = sides
            .iter()
            .enumerate()
            .any(|(l, (t, other, _, _))| l != k && t != s && (*other == *side || *other == reversed));
        if shared && !collapsed {
            seams.push(Seam { surface: *s, along_v: *along_v, at: *at, range: (0.0, 1.0) });
        }
    }
    (surfaces, seams)
}

#[test]
fn the_teapot_has_no_cracks_between_its_patches() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/rib-corpus/aqsis__aqsis/librib2__tests__teapot.rib"
    );
    let bytes = std::fs::read(path).expect("the corpus teapot");
    let scene = rib_parser::load_bytes("teapot.rib", bytes, &Default::default()).unwrap().scene;
    let mut patches = Vec::new();
    for entity in &scene.shapes {
        let Shape::NuPatch(np) = &*entity.shape else { continue };
        assert_eq!((np.basis.nu, np.basis.nv, np.basis.u_order, np.basis.v_order), (4, 4, 4, 4));
        patches.push((np.positions.clone(), entity.world_from_object));
    }
    let (surfaces, seams) = teapot_surfaces(&patches);
    assert!(seams.len() >= 40, "{} shared sides", seams.len());
    assert_watertight("teapot", &scene, &surfaces, &seams, 40);

    // The same patches inside an object definition, instanced once: the definition's own
    // space has its seam welder too.
    let text = String::from_utf8(std::fs::read(path).unwrap()).unwrap().replace("\r\n", "\n");
    let text = text.replacen("# Object \"Teekanne01\"\nAttributeBegin", "ObjectBegin 1\nAttributeBegin", 1);
    let text =
        text.replacen("AttributeEnd\nWorldEnd", "AttributeEnd\nObjectEnd\nObjectInstance 1\nWorldEnd", 1);
    let instanced =
        rib_parser::load_bytes("teapot.rib", text.into_bytes(), &Default::default()).unwrap().scene;
    assert_eq!((instanced.shapes.len(), instanced.instances.len()), (0, 1));
    assert_watertight("instanced teapot", &instanced, &surfaces, &seams, 40);
}

#[test]
fn geometry_teapot_is_newells_teapot_placed_as_aqsis_places_it_and_has_no_cracks() {
    let rib = "WorldBegin\nTranslate 1 -2 0.5\nRotate 30 0 0 1\nGeometry \"teapot\" \"uniform color Cs\" [0 0.5 1]\nWorldEnd\n";
    let scene = load("teapot.rib", rib.to_string());
    let mut patches = Vec::new();
    for entity in &scene.shapes {
        let Shape::Patches(mesh) = &*entity.shape else { panic!("only patches") };
        assert_eq!((mesh.nu, mesh.nv, mesh.u_basis.step, mesh.v_basis.step), (4, 4, 3, 3));
        assert_eq!(mesh.u_basis.matrix.map(f64::from), BEZIER);
        assert!(mesh.primvars.get("Cs").is_some(), "the teapot's colour");
        patches.push((mesh.positions.clone(), entity.world_from_object));
    }
    let (surfaces, seams) = teapot_surfaces(&patches);
    // Rim, body, handle, spout, lid and bottom meet along 52 edges, each a seam of both its
    // patches (the pole sides of the lid and bottom are points, not seams).
    assert_eq!(seams.len(), 104);

    // The object-space box of the true surface, sampled densely by the test's own evaluator:
    // Newell's extents (y and the radius 2 of the body, the lid's top at 3.15 and the bottom's
    // centre at 0), moved down by 0.15 as Aqsis places the teapot.
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let object_from_world = patches[0].1.inverse();
    for s in &surfaces {
        for j in 0..=64 {
            for i in 0..=64 {
                let p = object_from_world.transform_point3(s.eval(i as f64 / 64.0, j as f64 / 64.0).0);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
    assert!(close(lo.y, -2.0) && close(hi.y, 2.0), "y extent {} {}", lo.y, hi.y);
    assert!(close(lo.z, -0.15) && close(hi.z, 3.0), "z extent {} {}", lo.z, hi.z);
    // The handle's back is x = -3 and the spout's lip reaches x = 3.434 (Newell's extents).
    assert!(close(lo.x, -3.0), "x from {}", lo.x);
    assert!((hi.x - 3.434).abs() < 1e-3, "x to {}", hi.x);

    // The haptic proxy's triangles span the same box, within the tessellation tolerance.
    let geometry = scene_geometry(&scene, &tessellation_tolerance(None));
    let mut t_lo = DVec3::splat(f64::INFINITY);
    let mut t_hi = DVec3::splat(f64::NEG_INFINITY);
    for k in 0..geometry.mesh.triangle_count() {
        for p in geometry.mesh.triangle_local(k) {
            let p = object_from_world.transform_point3(geometry.mesh.world_from_local(p));
            t_lo = t_lo.min(p);
            t_hi = t_hi.max(p);
        }
    }
    assert!(
        t_lo.abs_diff_eq(lo, 0.02) && t_hi.abs_diff_eq(hi, 0.02),
        "tessellated box {t_lo} {t_hi}, surface {lo} {hi}"
    );

    assert_watertight("Geometry teapot", &scene, &surfaces, &seams, 40);
}

#[test]
fn a_closed_subdivision_mesh_has_no_holes() {
    // A lumpy cube: every ray from outside towards a point inside must meet the surface.
    let rib = r#"WorldBegin
SubdivisionMesh "catmull-clark" [4 4 4 4 4 4] [0 1 3 2  2 3 5 4  4 5 7 6  6 7 1 0  1 7 5 3  6 0 2 4]
  ["crease"] [2 1] [1 3] [2.5]
  "P" [-1 -1 1  1.3 -1 1.2  -1 1 0.8  1 1.1 1  -0.9 1 -1  1 1 -1.2  -1 -1.2 -1  1.1 -1 -1]
WorldEnd
"#;
    let scene = load("subdiv.rib", rib.to_string());
    let mut rng = Rng(7);
    let length = 6.0;
    let mut probes = Vec::new();
    for _ in 0..2000 {
        let target = rng.unit() * rng.range(0.0, 0.6);
        probes.push(Probe { aim: target, direction: rng.unit() });
    }
    // The target is inside, so an intact surface is met before it: at most `length` along.
    let eye = DVec3::new(1.0, -2.0, 8.0);
    let (world_leaks, proxy_leaks) = leaks_before(&scene, &probes, (length, length), eye);
    eprintln!("subdivision: {} probes: {world_leaks} world leaks, {proxy_leaks} proxy leaks", probes.len());
    assert_eq!((world_leaks, proxy_leaks), (0, 0));
}

/// A point of the uniform cubic B-spline through `c` (sharp ends: phantom points `2 c0 - c1`),
/// at `t` in `[0, c.len() - 1]`: the limit of a boundary crease of a `SubdivisionMesh` with
/// `interpolateboundary` between two sharp corners.
fn crease_curve(c: &[DVec3], t: f64) -> DVec3 {
    let n = c.len();
    let at = |i: isize| -> DVec3 {
        if i < 0 {
            2.0 * c[0] - c[1]
        } else if i as usize >= n {
            2.0 * c[n - 1] - c[n - 2]
        } else {
            c[i as usize]
        }
    };
    let span = (t.floor() as isize).clamp(0, n as isize - 2);
    let s = t - span as f64;
    let w = [
        (1.0 - s).powi(3),
        3.0 * s.powi(3) - 6.0 * s * s + 4.0,
        -3.0 * s.powi(3) + 3.0 * s * s + 3.0 * s + 1.0,
        s.powi(3),
    ];
    (w[0] * at(span - 1) + w[1] * at(span) + w[2] * at(span + 1) + w[3] * at(span + 2)) / 6.0
}

/// The vertices on edges used by one triangle only.
fn open_boundary_vertices(indices: &[[u32; 3]]) -> usize {
    let mut edges = std::collections::HashMap::new();
    for t in indices {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let mut vertices: Vec<u32> =
        edges.iter().filter(|&(_, &n)| n == 1).flat_map(|(&(a, b), _)| [a, b]).collect();
    vertices.sort_unstable();
    vertices.dedup();
    vertices.len()
}

#[test]
fn two_subdivision_meshes_sharing_a_boundary_at_different_levels_have_no_crack() {
    // A closed lumpy box cut along a wavy ring into a tall spiky dome and a nearly flat cap:
    // two 3 x 3-face SubdivisionMeshes sharing their 12 boundary vertices. The dome's
    // curvature asks for more levels than the cap's, so each dices the shared boundary curve
    // at its own rate unless the seam is closed between them.
    let ring: Vec<DVec3> = (0..16)
        .map(|k| {
            let (x, y) = ((k / 4) as f64 - 1.5, (k % 4) as f64 - 1.5);
            DVec3::new(x, y, 0.15 * (2.1 * x + 1.3 * y).sin())
        })
        .collect();
    let grid = |lift: &dyn Fn(usize) -> f64| -> Vec<DVec3> {
        (0..16)
            .map(|k| {
                let inner = (1..3).contains(&(k / 4)) && (1..3).contains(&(k % 4));
                let p = ring[k];
                if inner { DVec3::new(p.x * 0.8, p.y * 0.8, lift(k)) } else { p }
            })
            .collect()
    };
    let dome = grid(&|k| match k {
        5 => 4.0,
        6 => 1.2,
        9 => 1.5,
        _ => 3.5,
    });
    let cap = grid(&|_| -0.05);
    // Faces of a 4 x 4 vertex grid; the cap walks them the other way so both face outwards.
    let faces = |flip: bool| -> String {
        let mut s = String::new();
        for i in 0..3 {
            for j in 0..3 {
                let q = [4 * i + j, 4 * i + j + 1, 4 * (i + 1) + j + 1, 4 * (i + 1) + j];
                let q = if flip { [q[3], q[2], q[1], q[0]] } else { q };
                s += &format!("{} {} {} {}  ", q[0], q[1], q[2], q[3]);
            }
        }
        s
    };
    let mesh = |points: &[DVec3], flip: bool| {
        format!(
            "SubdivisionMesh \"catmull-clark\" [4 4 4 4 4 4 4 4 4] [{}] [\"interpolateboundary\"] [1 0] [1] [] \"P\" [{}]\n",
            faces(flip),
            rib_points(points.iter().copied())
        )
    };
    let rib = format!("WorldBegin\n{}{}WorldEnd\n", mesh(&dome, false), mesh(&cap, true));
    let scene = load("two-subdivs.rib", rib);

    // Tessellated one by one, the two put different numbers of vertices on the ring.
    let tolerance = tessellation_tolerance(None);
    let ring_vertices = |shape: &Shape| {
        let mesh = tessellate::tessellate(shape, &tolerance).expect("tessellates");
        open_boundary_vertices(&mesh.indices)
    };
    let (dome_ring, cap_ring) =
        (ring_vertices(&scene.shapes[0].shape), ring_vertices(&scene.shapes[1].shape));
    eprintln!("ring vertices tessellated alone: dome {dome_ring}, cap {cap_ring}");
    assert!(
        dome_ring >= 2 * cap_ring,
        "the dome should dice the ring more finely: {dome_ring} vs {cap_ring}"
    );

    // Targets next to the ring (the crease between dome and cap), nudged towards a point the
    // body is star-shaped around (so inside it); rays from
    // far outside, within 60 degrees of the normal of either side (the box's side outwards,
    // the cap's downwards), must meet the surface by `slack` past them. A ray through a crack
    // goes on to the far side of the body, at least half a unit further.
    let sides: [([usize; 4], DVec3); 4] = [
        ([0, 1, 2, 3], DVec3::NEG_X),
        ([3, 7, 11, 15], DVec3::Y),
        ([15, 14, 13, 12], DVec3::X),
        ([12, 8, 4, 0], DVec3::NEG_Y),
    ];
    let inside = DVec3::new(0.0, 0.0, 0.5);
    let mut rng = Rng(0x51ab_d1c5);
    let mut probes = Vec::new();
    for (side, out) in &sides {
        let c: Vec<DVec3> = side.iter().map(|&k| ring[k]).collect();
        for k in 0..1000 {
            // Away from the sharp corners, where dome and cap close to a thin wedge.
            let t = rng.range(0.4, 2.6);
            let on_seam = crease_curve(&c, t);
            let aim = on_seam + 0.01 * (inside - on_seam).normalize();
            let normal = if k % 2 == 0 { *out } else { DVec3::NEG_Z };
            let direction = loop {
                let d = rng.unit();
                if -d.dot(normal) >= 60f64.to_radians().cos() {
                    break d;
                }
            };
            probes.push(Probe { aim, direction });
        }
    }
    let (length, slack) = (10.0, 0.05);
    let eye = DVec3::new(1.0, -2.0, 12.0);
    // The welder adds its fans to the newer mesh: the finer one, or the coarser one.
    let cap_first = format!("WorldBegin\n{}{}WorldEnd\n", mesh(&cap, true), mesh(&dome, false));
    let mut leaks_by_order = Vec::new();
    for (order, scene) in [("dome first", scene), ("cap first", load("cap-first.rib", cap_first))] {
        let (world_leaks, proxy_leaks) = leaks_before(&scene, &probes, (length, length + slack), eye);
        eprintln!(
            "two subdivision meshes, {order}: {} probes: {world_leaks} world leaks, {proxy_leaks} proxy leaks",
            probes.len()
        );
        leaks_by_order.push((world_leaks, proxy_leaks));
    }
    assert_eq!(
        leaks_by_order,
        [(0, 0), (0, 0)],
        "rays through the seam (world, haptic proxy; dome first, cap first)"
    );
}

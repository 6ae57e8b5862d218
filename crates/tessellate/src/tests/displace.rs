//! Displacement against closed forms: `bumpy` of a constant texture grows a sphere by exactly
//! its amount, `null` changes nothing, `dented` stays within its bound and equals its formula,
//! the dicing budget holds against a hostile shading rate.

use super::assert_well_formed;
use crate::{
    DENTED_MAX_MAGNITUDE_CUBED, DicingRule, Displaced, DisplacementShader, Tolerance, dented_magnitude_cubed,
    tessellate_displaced, tessellate_placed, tessellate_scene,
};
use glam::{DMat4, DVec3, Vec2};
use rib_parser::scene::Shape;

fn sphere(radius: f32) -> Shape {
    Shape::Sphere { radius, z_min: -radius, z_max: radius, theta_max_degrees: 360.0 }
}

fn constant_texture(value: f64) -> impl Fn(&str, Vec2) -> Option<f64> {
    move |name, _| (name == "flat.tif").then_some(value)
}

fn bumpy(km: f64, amplitude: f64) -> DisplacementShader {
    DisplacementShader::Bumpy { km, amplitude, texture: Some("flat.tif".into()) }
}

/// A sphere of radius 2 scaled by 1.5 (radius 3 in the world) with `bumpy` Km 0.5, amplitude
/// 0.4, of a texture that reads 0.25 everywhere: a sphere of radius 3 + 0.05 in world units
/// (RenderMan displaces in current space, after the object's scale), closed, its normals the
/// radial direction.
#[test]
fn bumpy_of_a_constant_texture_grows_a_sphere_by_its_amount() {
    let eps = 1e-3;
    let texture = constant_texture(0.25);
    let shader = bumpy(0.5, 0.4);
    let displaced = Displaced {
        shader: &shader,
        world_from_placed: DMat4::IDENTITY,
        texture: &texture,
        dicing: DicingRule::RelativeToSize(0.01),
    };
    let m = DMat4::from_scale(DVec3::splat(1.5));
    let out = tessellate_displaced(&sphere(2.0), &m, false, &Tolerance::absolute(eps), &displaced).unwrap();
    assert_well_formed(&out.mesh);
    assert!(out.mesh.is_closed(), "diced and displaced sphere has holes");
    assert!(out.dicing.triangles > out.dicing.base_triangles, "{:?}", out.dicing);
    assert_eq!(out.dicing.coarsened_by, None);
    assert!((out.largest_displacement - 0.05).abs() < 1e-12, "{}", out.largest_displacement);
    let expected = 3.0 + 0.5 * 0.4 * 0.25;
    let normals = out.mesh.normals.as_ref().expect("normals");
    for (p, n) in out.mesh.positions.iter().zip(normals) {
        let r = p.as_dvec3().length();
        // Vertices made by dicing lie on chords of the undisplaced tessellation (within eps).
        assert!((r - expected).abs() < eps + 1e-5, "radius {r}, expected {expected}");
        assert!(n.as_dvec3().dot(p.as_dvec3().normalize()) > 0.99, "normal {n} at {p}");
    }
    // Every edge is within the dicing rule (1 % of the diagonal of the undisplaced sphere).
    let size = (2.0 * 3.0f64 * 3.0f64.sqrt()) * 0.01;
    for t in &out.mesh.indices {
        for k in 0..3 {
            let (a, b) = (out.mesh.positions[t[k] as usize], out.mesh.positions[t[(k + 1) % 3] as usize]);
            assert!(((a - b).length() as f64) < size * 1.02 * expected / 3.0, "edge {}", (a - b).length());
        }
    }
}

/// `null`, `bumpy` without a texture and `dented` with `Km 0` move nothing: the mesh is the
/// undisplaced tessellation bit for bit.
#[test]
fn identity_shaders_leave_the_tessellation_bit_identical() {
    let tol = Tolerance::absolute(1e-3);
    let m = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0));
    let plain = tessellate_placed(&sphere(1.0), &m, true, &tol).unwrap();
    let none = |_: &str, _: Vec2| None;
    for shader in [
        DisplacementShader::Null,
        DisplacementShader::Bumpy { km: 1.0, amplitude: 1.0, texture: None },
        DisplacementShader::Dented { km: 0.0, world_from_shader: DMat4::IDENTITY },
    ] {
        let displaced = Displaced {
            shader: &shader,
            world_from_placed: DMat4::IDENTITY,
            texture: &none,
            dicing: DicingRule::RelativeToSize(1e-3),
        };
        let out = tessellate_displaced(&sphere(1.0), &m, true, &tol, &displaced).unwrap();
        assert_eq!(out.mesh.positions, plain.positions, "{shader:?}");
        assert_eq!(out.mesh.indices, plain.indices);
        assert_eq!(out.mesh.normals, plain.normals);
    }
}

/// `dented` on the plane z = 0 (normal +z): every vertex moves straight down by exactly
/// `Km magnitude^3` of its own shader-space point, within [-Km max magnitude^3, 0]; the noise
/// is read in the shader space (a translated shader space moves the dents with it).
#[test]
fn dented_moves_each_vertex_down_by_its_formula_within_the_bound() {
    // A 4 x 4 square at z = 0, wound counter-clockwise seen from +z.
    let square = Shape::Polygons(super::polygon::points_polygons(
        &[[-2.0, -2.0, 0.0], [2.0, -2.0, 0.0], [2.0, 2.0, 0.0], [-2.0, 2.0, 0.0]],
        &[&[0, 1, 2, 3]],
    ));
    let km = 2.0;
    let shift = DVec3::new(0.3, -0.7, 0.0);
    let shader = DisplacementShader::Dented { km, world_from_shader: DMat4::from_translation(shift) };
    let none = |_: &str, _: Vec2| None;
    let displaced = Displaced {
        shader: &shader,
        world_from_placed: DMat4::IDENTITY,
        texture: &none,
        dicing: DicingRule::Orthographic { pixel: 0.05, shading_rate: 1.0 },
    };
    let out = tessellate_displaced(&square, &DMat4::IDENTITY, false, &Tolerance::absolute(1e-3), &displaced)
        .unwrap();
    assert_well_formed(&out.mesh);
    assert!(out.mesh.triangle_count() > 10_000, "{:?}", out.dicing);
    let bound = km * DENTED_MAX_MAGNITUDE_CUBED;
    let mut deepest = 0.0f64;
    for p in &out.mesh.positions {
        let p = p.as_dvec3();
        let expected = -km * dented_magnitude_cubed(DVec3::new(p.x, p.y, 0.0) - shift);
        assert!((p.z - expected).abs() < 1e-6, "z {} expected {expected} at {p}", p.z);
        assert!(p.z <= 0.0 && p.z >= -bound, "{} outside [-{bound}, 0]", p.z);
        deepest = deepest.min(p.z);
    }
    assert!(deepest < -0.01 * km, "no dents: deepest {deepest}");
    assert!((out.largest_displacement + deepest).abs() < 1e-6);
}

/// A hostile shading rate (1e-12 pixels per micropolygon on a perspective camera) is diced
/// only as far as the triangle budget allows, and says by how much it is coarser.
#[test]
fn a_hostile_shading_rate_is_held_to_the_triangle_budget() {
    let texture = constant_texture(1.0);
    let shader = bumpy(0.1, 1.0);
    let displaced = Displaced {
        shader: &shader,
        world_from_placed: DMat4::IDENTITY,
        texture: &texture,
        dicing: DicingRule::Perspective {
            eye: DVec3::new(0.0, 0.0, -5.0),
            radians_per_pixel: 1e-3,
            shading_rate: 1e-12,
        },
    };
    let tol = Tolerance::absolute(1e-2).with_max_triangles(50_000);
    let out = tessellate_displaced(&sphere(1.0), &DMat4::IDENTITY, false, &tol, &displaced).unwrap();
    assert!(out.mesh.triangle_count() <= 50_000, "{}", out.mesh.triangle_count());
    let factor = out.dicing.coarsened_by.expect("the budget coarsened the dicing");
    assert!(factor > 100.0, "coarsened by {factor}");
    assert!(out.mesh.is_closed());
}

/// `tessellate_scene` (the haptics' and `lrt-depth --check`'s tessellation) displaces shapes
/// with a standard shader: a dented sphere's vertices all lie within [r - Km max^3, r].
#[test]
fn the_scene_tessellation_displaces_dented_shapes() {
    let rib = "WorldBegin\nAttributeBegin\nDisplacement \"dented\" \"Km\" 0.2\nSphere 1 -1 1 360\n\
               AttributeEnd\nAttributeBegin\nTranslate 5 0 0\nSphere 1 -1 1 360\nAttributeEnd\nWorldEnd\n";
    let scene = rib_parser::load_bytes("dented.rib", rib.as_bytes().to_vec(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let out = tessellate_scene(&scene, &Tolerance::default());
    assert!(out.skipped.is_empty(), "{:?}", out.skipped);
    let radii = |i: usize, centre: DVec3| {
        out.meshes[i].mesh.positions.iter().map(move |p| (p.as_dvec3() - centre).length())
    };
    let (lo, hi) = radii(0, DVec3::ZERO).fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r), hi.max(r)));
    assert!(hi <= 1.0 + 1e-6 && lo >= 1.0 - 0.2 * DENTED_MAX_MAGNITUDE_CUBED - 1e-3, "[{lo}, {hi}]");
    assert!(lo < 1.0 - 1e-3, "the sphere is not dented: smallest radius {lo}");
    // The undisplaced sphere is untouched.
    assert!(radii(1, DVec3::new(5.0, 0.0, 0.0)).all(|r| r > 1.0 - 2e-3 && r <= 1.0 + 1e-6));
}

/// The keys of a deforming square (z = 0 and a key tilted to z = x / 2 and lifted by 1)
/// with `bumpy` of a constant texture: diced alike (the same triangles), every vertex of each
/// key moved by the amount along that key's own normal.
#[test]
fn deformation_keys_are_diced_alike_and_displaced_along_their_own_normals() {
    let square = |z: [f32; 4]| {
        Shape::Polygons(super::polygon::points_polygons(
            &[[-1.0, -1.0, z[0]], [1.0, -1.0, z[1]], [1.0, 1.0, z[2]], [-1.0, 1.0, z[3]]],
            &[&[0, 1, 2, 3]],
        ))
    };
    let (flat, tilted) = (square([0.0; 4]), square([0.5, 1.5, 1.5, 0.5]));
    let tol = Tolerance::absolute(1e-3);
    let keys: Vec<_> = [&flat, &tilted]
        .iter()
        .map(|s| tessellate_placed(s, &DMat4::IDENTITY, false, &tol).unwrap())
        .collect();
    let texture = constant_texture(1.0);
    let shader = bumpy(0.5, 0.2);
    let displaced = Displaced {
        shader: &shader,
        world_from_placed: DMat4::IDENTITY,
        texture: &texture,
        dicing: DicingRule::Orthographic { pixel: 0.1, shading_rate: 1.0 },
    };
    let out = crate::displace_keys(&keys, false, &displaced, 100_000).unwrap();
    let [a, b] = [&out.meshes[0], &out.meshes[1]];
    assert_eq!(a.indices, b.indices);
    assert!(a.triangle_count() > 500, "{:?}", out.dicing);
    let tilted_normal = DVec3::new(-0.5, 0.0, 1.0).normalize();
    for (p, q) in a.positions.iter().zip(&b.positions) {
        let (p, q) = (p.as_dvec3(), q.as_dvec3());
        assert!((p.z - 0.1).abs() < 1e-6, "flat key at z {}", p.z);
        // The tilted key's undisplaced point is at z = x / 2 + 1.
        let undisplaced = q - 0.1 * tilted_normal;
        assert!(
            (undisplaced.z - (0.5 * undisplaced.x + 1.0)).abs() < 1e-5,
            "tilted key off its plane at {q}"
        );
        // Same parameters at both keys: the undisplaced x, y match the flat key's.
        assert!((undisplaced.y - p.y).abs() < 1e-5 && (undisplaced.x - p.x).abs() < 1e-5);
    }
}

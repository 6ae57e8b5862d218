//! The proxy touches what the ray tracer renders: trimmed NuPatches only where the trim keeps
//! them, `SolidBegin` CSG results only on their boundary, and `bumpy` surfaces displaced by
//! their texture.

use glam::DVec3;
use haptics::scene::{SceneGeometry, scene_geometry, tessellation_tolerance};
use haptics::*;
use rib_parser::{LoadOptions, load_bytes};
use std::f64::consts::PI;

const RADIUS: f64 = 0.01;

fn geometry(rib: &str) -> SceneGeometry {
    let loaded = load_bytes("test.rib", rib.as_bytes().to_vec(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()));
    let geometry = scene_geometry(&loaded.scene, &tessellation_tolerance(Some(RADIUS)));
    assert!(geometry.warnings.is_empty(), "{:?}", geometry.warnings);
    geometry
}

fn triangles(g: &SceneGeometry) -> impl Iterator<Item = [DVec3; 3]> + '_ {
    (0..g.mesh.triangle_count()).map(|t| g.mesh.triangle_local(t).map(|p| g.mesh.world_from_local(p)))
}

fn area(g: &SceneGeometry) -> f64 {
    triangles(g).map(|[a, b, c]| 0.5 * (b - a).cross(c - a).length()).sum()
}

fn signed_volume(g: &SceneGeometry) -> f64 {
    triangles(g).map(|[a, b, c]| a.dot(b.cross(c)) / 6.0).sum()
}

/// Moves the device from `from` to `to` (world) in small steps; returns whether the proxy
/// was ever held back (a force) and where it ended.
fn probe(g: &SceneGeometry, from: DVec3, to: DVec3) -> (bool, DVec3) {
    let world = CollisionWorld::new(g.mesh.clone());
    let materials =
        MaterialTable::uniform(Material { stiffness: 1000.0, static_friction: 0.0, dynamic_friction: 0.0 });
    let mut proxy = GodObject::new(ProxySettings { radius: RADIUS, friction: false });
    let local = |p: DVec3| g.mesh.local_from_world(p);
    assert!(proxy.reset(&world, local(from)), "the probe starts free");
    let mut touched = false;
    let steps = 400;
    for k in 1..=steps {
        let goal = local(from.lerp(to, k as f64 / steps as f64));
        let update = proxy.update(&world, &materials, goal);
        touched |= update.in_contact() || (update.position - goal).length() > 1e-12;
    }
    (touched, g.mesh.world_from_local(proxy.position()))
}

/// A unit square in z = 0 (a bilinear NuPatch) trimmed to the disc of radius 0.3 around its
/// centre (a rational quadratic circle, homogeneous `u w, v w, w`).
fn trimmed_square() -> String {
    let w = std::f64::consts::FRAC_1_SQRT_2;
    let pts = [
        (0.8, 0.5),
        (0.8, 0.8),
        (0.5, 0.8),
        (0.2, 0.8),
        (0.2, 0.5),
        (0.2, 0.2),
        (0.5, 0.2),
        (0.8, 0.2),
        (0.8, 0.5),
    ];
    let weight = |i: usize| if i % 2 == 1 { w } else { 1.0 };
    let u: Vec<String> = pts.iter().enumerate().map(|(i, p)| format!("{}", p.0 * weight(i))).collect();
    let v: Vec<String> = pts.iter().enumerate().map(|(i, p)| format!("{}", p.1 * weight(i))).collect();
    let ws: Vec<String> = (0..9).map(|i| format!("{}", weight(i))).collect();
    format!(
        "WorldBegin\nTrimCurve [1] [3] [0 0 0 0.25 0.25 0.5 0.5 0.75 0.75 1 1 1] [0] [1] [9] [{}] [{}] [{}]\n\
         NuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]\nWorldEnd\n",
        u.join(" "),
        v.join(" "),
        ws.join(" ")
    )
}

#[test]
fn a_trimmed_patch_is_touchable_only_where_the_trim_keeps_it() {
    let g = geometry(&trimmed_square());
    let disc = PI * 0.3 * 0.3;
    // Inscribed polygons lose at most the perimeter times the chord bound (RADIUS / 20).
    assert!((area(&g) - disc).abs() < 2.0 * PI * 0.3 * RADIUS / 20.0 + 1e-9, "area {} vs {disc}", area(&g));
    for [a, b, c] in triangles(&g) {
        for p in [a, b, c, (a + b + c) / 3.0] {
            assert!((p.truncate() - glam::DVec2::splat(0.5)).length() <= 0.3 + 1e-6, "{p} outside the disc");
        }
    }
    // Pressing at the disc's centre is held back at the surface; at a trimmed-away corner the
    // probe passes through the plane of the patch.
    let (touched, end) = probe(&g, DVec3::new(0.5, 0.5, 0.05), DVec3::new(0.5, 0.5, -0.005));
    assert!(touched && (end.z - RADIUS).abs() < 1e-9, "{end}");
    let (touched, end) = probe(&g, DVec3::new(0.1, 0.1, 0.05), DVec3::new(0.1, 0.1, -0.05));
    assert!(!touched, "nothing to touch at a trimmed corner, ended at {end}");
    let (touched, _) = probe(&g, DVec3::new(0.5, 0.9, 0.05), DVec3::new(0.5, 0.9, -0.05));
    assert!(!touched, "nothing to touch between the disc and the side");
}

const TWO_SPHERES: &str = "Sphere 1 -1 1 360\nTranslate 1 0 0\nSphere 0.8 -0.8 0.8 360\n";

fn solid(op: &str) -> String {
    format!("WorldBegin\nSolidBegin \"{op}\"\n{TWO_SPHERES}SolidEnd\nWorldEnd\n")
}

/// The volume two spheres (radii `r1`, `r2`, centres `d` apart) share.
fn lens_volume(r1: f64, r2: f64, d: f64) -> f64 {
    PI * (r1 + r2 - d).powi(2)
        * (d * d + 2.0 * d * r2 - 3.0 * r2 * r2 + 2.0 * d * r1 + 6.0 * r2 * r1 - 3.0 * r1 * r1)
        / (12.0 * d)
}

#[test]
fn a_sphere_minus_a_sphere_has_the_difference_volume_and_no_surface_in_the_bite() {
    let g = geometry(&solid("difference"));
    let sphere = 4.0 / 3.0 * PI;
    let expected = sphere - lens_volume(1.0, 0.8, 1.0);
    let volume = signed_volume(&g);
    assert!((volume - expected).abs() < 2e-3 * expected, "volume {volume} vs {expected}");
    // Along +x the first sphere's surface (x = 1) is inside the second: removed, so a probe
    // pushing into the bite feels nothing until the bite's wall, the second sphere's surface
    // at x = 1 - 0.8.
    let (touched, end) = probe(&g, DVec3::new(1.5, 0.0, 0.0), DVec3::new(0.35, 0.0, 0.0));
    assert!(!touched, "no force inside the removed region, ended at {end}");
    let (touched, end) = probe(&g, DVec3::new(0.5, 0.0, 0.0), DVec3::new(0.1, 0.0, 0.0));
    assert!(touched && (end.x - (0.2 + RADIUS)).abs() < 2e-3, "held at the bite's wall: {end}");
    // The rest of the first sphere is still there.
    let (touched, end) = probe(&g, DVec3::new(-1.5, 0.0, 0.0), DVec3::new(-0.9, 0.0, 0.0));
    assert!(touched && (end.x + 1.0 + RADIUS).abs() < 2e-3, "{end}");
    // Given as a union, the same spheres are felt at x = 1.
    let union = geometry(&format!("WorldBegin\n{TWO_SPHERES}WorldEnd\n"));
    let (touched, _) = probe(&union, DVec3::new(2.0, 0.0, 0.0), DVec3::new(1.5, 0.0, 0.0));
    assert!(touched);
}

#[test]
fn an_intersection_of_spheres_is_the_lens() {
    let g = geometry(&solid("intersection"));
    let expected = lens_volume(1.0, 0.8, 1.0);
    let volume = signed_volume(&g);
    assert!((volume - expected).abs() < 5e-3 * expected, "volume {volume} vs {expected}");
    // Nothing of either sphere outside the other is left.
    for [a, b, c] in triangles(&g) {
        let centroid = (a + b + c) / 3.0;
        assert!(centroid.length() < 1.0 + 1e-3 && (centroid - DVec3::X).length() < 0.8 + 1e-3, "{centroid}");
    }
    let (touched, _) = probe(&g, DVec3::new(-1.5, 0.0, 0.0), DVec3::new(-0.5, 0.0, 0.0));
    assert!(!touched, "the first sphere's far side is not part of the lens");
}

/// A unit sphere with `Displacement "dented" "Km" 2` is touched where the ray tracer draws it:
/// a probe pushed toward the centre stops its radius off the dented surface, at
/// `1 - Km magnitude^3` of the direction it rests in (the undisplaced sphere is at 1).
#[test]
fn a_dented_sphere_is_touched_at_its_displaced_radius() {
    let g = geometry("WorldBegin\nDisplacement \"dented\" \"Km\" [2]\nSphere 1 -1 1 360\nWorldEnd\n");
    // The direction (of a few) where the dent is deepest, so that the test tells dented from
    // undented.
    let directions = [DVec3::new(1.0, 0.3, 0.2), DVec3::new(-0.4, 0.8, 0.1), DVec3::new(0.2, -0.5, -0.9)];
    let dent = |d: DVec3| 2.0 * tessellate::dented_magnitude_cubed(d.normalize());
    let d = directions.into_iter().max_by(|a, b| dent(*a).total_cmp(&dent(*b))).unwrap().normalize();
    assert!(dent(d) > 0.02, "dent {} too shallow to tell", dent(d));
    let (touched, end) = probe(&g, 3.0 * d, 0.5 * d);
    assert!(touched, "the proxy never touched the dented sphere");
    let rest = end.normalize();
    let expected = 1.0 - dent(rest);
    let surface = end.length() - RADIUS;
    assert!(
        (surface - expected).abs() < 4e-3,
        "proxy rests at radius {surface}, the dented surface is at {expected}"
    );
}

/// `bumpy` "Km" 1 "amplitude" 0.1 on the unit square z = 0 (a bilinear patch, `(s, t) = (u, v)`
/// = `(x, y)`), reading a texture whose columns are 64, 64, 192, 192 (of 255): where `s` is in
/// [1/8, 3/8] it reads 64/255 (the texel centres are at 1/8, 3/8, ...; bilinear between them),
/// in [5/8, 7/8] 192/255, so the surface is the plane `z = 0.1 value` there. A proxy pressed
/// down rests on it at that height plus its radius, as the ray tracer draws it.
#[test]
fn the_proxy_rests_on_a_bumpy_surface_at_its_textures_height() {
    let dir = tempfile::tempdir().unwrap();
    let texture = dir.path().join("steps.png");
    let columns = [64u8, 64, 192, 192];
    image::GrayImage::from_fn(4, 4, |x, _| image::Luma([columns[x as usize]])).save(&texture).unwrap();
    let rib = format!(
        "WorldBegin\nDisplacement \"bumpy\" \"Km\" [1] \"amplitude\" [0.1] \"texturename\" [\"{}\"]\n\
         Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\nWorldEnd\n",
        texture.display()
    );
    let g = geometry(&rib);
    for (s, value) in [(0.25, 64.0 / 255.0), (0.75, 192.0 / 255.0)] {
        let height = 0.1 * value;
        let (touched, rest) = probe(&g, DVec3::new(s, 0.5, 0.3), DVec3::new(s, 0.5, -0.2));
        assert!(touched, "at s = {s} the proxy passed through");
        // Within the tessellation's tolerance (1e-3 of the patch's size at most).
        let expected = height + RADIUS;
        assert!(
            (rest.z - expected).abs() < 1e-3,
            "at s = {s} the proxy rests at z = {}, expected {expected}",
            rest.z
        );
        assert!((rest.truncate() - glam::DVec2::new(s, 0.5)).length() < 1e-6, "{rest}");
    }
}

/// A hierarchical hole edit is not touched either: a subdivided unit cube whose top face's
/// child 1 (the quarter at the top's vertex 1, (1, 0, 1)) is a hole lets a probe through
/// there and holds one over the next quarter on the limit surface.
#[test]
fn a_hierarchical_hole_is_not_touched() {
    let g = geometry(
        "WorldBegin\nHierarchicalSubdivisionMesh \"catmull-clark\" [4 4 4 4 4 4] \
         [0 3 2 1  4 5 6 7  0 1 5 4  1 2 6 5  2 3 7 6  3 0 4 7] [\"faceedit\"] [3 0 1] [2 1 1] [] [\"hole\"] \
         \"P\" [0 0 0  1 0 0  1 1 0  0 1 0  0 0 1  1 0 1  1 1 1  0 1 1]\nWorldEnd\n",
    );
    let (through, _) = probe(&g, DVec3::new(0.7, 0.3, 2.0), DVec3::new(0.7, 0.3, 0.6));
    assert!(!through, "the probe was held over the hole");
    // Pressed just below the top's limit surface (about 0.87 there; 0.92 at the centre), so
    // the frictionless proxy does not slide far down the rounded cube.
    let (held, rest) = probe(&g, DVec3::new(0.3, 0.3, 2.0), DVec3::new(0.3, 0.3, 0.8));
    assert!(held, "the probe passed through the top outside the hole");
    assert!(rest.z > 0.8 && rest.z < 0.95, "{rest}");
    assert!((rest.truncate() - glam::DVec2::new(0.3, 0.3)).length() < 0.05, "{rest}");
}

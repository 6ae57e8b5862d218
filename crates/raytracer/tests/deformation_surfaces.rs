//! Deforming adaptive surfaces (issue 11): a subdivision surface whose keys differ in
//! curvature, and a Blobby whose blobs move (keys that on their own are tessellated
//! differently), make one moving shape whose every interpolated mesh is closed, and which at
//! shutter open and close is the first and the last key.

use glam::{DVec3, Vec3};
use raytracer::diagnostics::Diagnostics;
use raytracer::world::{PixelFootprint, Ray, World};

/// A lumpy cube (the watertight tests' one) as a subdivision mesh; `pull` moves its corner 5.
fn lumpy_cube(pull: [f64; 3]) -> String {
    let [x, y, z] = pull;
    format!(
        r#"SubdivisionMesh "catmull-clark" [4 4 4 4 4 4] [0 1 3 2  2 3 5 4  4 5 7 6  6 7 1 0  1 7 5 3  6 0 2 4]
  ["crease"] [2 1] [1 3] [2.5]
  "P" [-1 -1 1  1.3 -1 1.2  -1 1 0.8  1 1.1 1  -0.9 1 -1  {x} {y} {z}  -1 -1.2 -1  1.1 -1 -1]"#
    )
}

const STILL: [f64; 3] = [1.0, 1.1, -1.0];
const PULLED: [f64; 3] = [2.5, 2.8, -3.0];

/// The world of `body` under `Shutter 0 1`, seen from `eye`, and its warnings.
fn world(body: &str, eye: DVec3) -> (World, Vec<String>) {
    let rib = format!("Shutter 0 1\nWorldBegin\n{body}\nWorldEnd\n");
    let scene = rib_parser::load_bytes("subdiv.rib", rib.into_bytes(), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
        .scene;
    let mut diagnostics = Diagnostics::default();
    let footprint = PixelFootprint::Perspective { radians_per_pixel: 1e-3 };
    let world = World::build(&scene, eye, footprint, &mut diagnostics).expect("world builds");
    (world, diagnostics.warnings.into_iter().map(|w| w.message).collect())
}

/// A small deterministic generator (xorshift64*), so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(2.0 * self.next() - 1.0, 2.0 * self.next() - 1.0, 2.0 * self.next() - 1.0);
            if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

/// The ray from `from` (world space) along `direction` at shutter fraction `time`.
fn ray(eye: DVec3, from: DVec3, direction: DVec3, time: f32) -> Ray {
    Ray { time, ..Ray::new((from - eye).as_vec3(), direction.as_vec3()) }
}

#[test]
fn a_deforming_subdivision_surface_is_closed_at_every_time() {
    let eye = DVec3::new(1.0, -2.0, 8.0);
    let keys = format!("MotionBegin [0 1]\n{}\n{}\nMotionEnd", lumpy_cube(STILL), lumpy_cube(PULLED));
    let (world, warnings) = world(&keys, eye);
    assert!(warnings.is_empty(), "{warnings:?}");
    // Every ray from outside towards a point inside meets the surface before it, whatever its
    // time (the ends of the shutter included).
    let (mut rng, length, mut leaks) = (Rng(11), 8.0, 0);
    for k in 0..4000 {
        let target = rng.unit() * 0.6 * rng.next();
        let direction = rng.unit();
        let time = match k % 8 {
            0 => 0.0,
            1 => 1.0,
            _ => rng.next() as f32,
        };
        let hit = world.intersect(&ray(eye, target - direction * length, direction, time));
        leaks += usize::from(!hit.is_some_and(|h| f64::from(h.t) <= length));
    }
    assert_eq!(leaks, 0, "{leaks} of 4000 rays went through the deforming surface");
}

#[test]
fn at_shutter_open_and_close_the_deforming_surface_is_its_first_and_last_key() {
    let keys = format!("MotionBegin [0 1]\n{}\n{}\nMotionEnd", lumpy_cube(STILL), lumpy_cube(PULLED));
    let worst = open_and_close(&keys, &lumpy_cube(STILL), &lumpy_cube(PULLED));
    assert!(worst[0] < 0.02 && worst[1] < 0.02, "{worst:?}");
    // The keys themselves are far apart, so the comparison tells them apart.
    assert!(worst[2] > 0.5, "{worst:?}");
}

/// Two blobs of radius about 0.75 at `x = -d` and `d`, added.
fn two_blobs(d: f64) -> String {
    let at = |x: f64| format!("1.5 0 0 0 0 1.5 0 0 0 0 1.5 0 {x} 0 0 1");
    format!("Blobby 2 [1001 0 1001 16 0 2 0 1] [{} {}] [\"\"]", at(-d), at(d))
}

#[test]
fn blobs_that_move_apart_but_stay_merged_blur_and_end_on_their_keys() {
    let keys = format!("MotionBegin [0 1]\n{}\n{}\nMotionEnd", two_blobs(0.2), two_blobs(0.5));
    let (deforming, warnings) = world(&keys, DVec3::new(1.0, -2.0, 8.0));
    assert!(warnings.is_empty(), "{warnings:?}");
    // Closed at every time: rays towards points near the centre always meet it first.
    let (mut rng, length, mut leaks) = (Rng(3), 8.0, 0);
    let eye = DVec3::new(1.0, -2.0, 8.0);
    for _ in 0..2000 {
        let (target, direction) = (rng.unit() * 0.3 * rng.next(), rng.unit());
        let hit = deforming.intersect(&ray(eye, target - direction * length, direction, rng.next() as f32));
        leaks += usize::from(!hit.is_some_and(|h| f64::from(h.t) <= length));
    }
    assert_eq!(leaks, 0, "{leaks} of 2000 rays went through the deforming Blobby");
    let worst = open_and_close(&keys, &two_blobs(0.2), &two_blobs(0.5));
    assert!(worst[0] < 0.02 && worst[1] < 0.02, "{worst:?}");
    assert!(worst[2] > 0.2, "{worst:?}");
}

/// Over 2000 rays towards the centre from all around: the largest difference in hit distance
/// between the deforming world at shutter open and the first key alone, at shutter close and
/// the last key alone, and between the two keys.
fn open_and_close(keys: &str, first: &str, last: &str) -> [f64; 3] {
    let eye = DVec3::new(1.0, -2.0, 8.0);
    let (deforming, _) = world(keys, eye);
    let (first, _) = world(first, eye);
    let (last, _) = world(last, eye);
    // Rays towards the centre from all around: the distances agree within a few tessellation
    // tolerances (each world dices its own way; a pixel here is 1e-3 of the distance, ~0.01).
    let (mut rng, length) = (Rng(5), 10.0);
    let mut worst = [0.0f64; 3];
    for _ in 0..2000 {
        let direction = rng.unit();
        let from = -direction * length;
        let t = |w: &World, time: f32| w.intersect(&ray(eye, from, direction, time)).map(|h| f64::from(h.t));
        let (open, close) = (t(&deforming, 0.0), t(&deforming, 1.0));
        let (Some(open), Some(close), Some(a), Some(b)) = (open, close, t(&first, 0.0), t(&last, 0.0)) else {
            panic!("a ray towards the centre missed");
        };
        worst[0] = worst[0].max((open - a).abs());
        worst[1] = worst[1].max((close - b).abs());
        worst[2] = worst[2].max((a - b).abs());
    }
    eprintln!(
        "open against the first key {}, close against the last {}, keys apart {}",
        worst[0], worst[1], worst[2]
    );
    worst
}

#[test]
fn each_key_alone_is_refined_differently() {
    // What the subdivision tests above rely on: on their own the keys give other triangle
    // counts.
    let count = |pull| {
        let rib = format!("WorldBegin\n{}\nWorldEnd\n", lumpy_cube(pull));
        let scene = rib_parser::load_bytes("k.rib", rib.into_bytes(), &Default::default()).unwrap().scene;
        let tol = tessellate::Tolerance::absolute(2e-3);
        let placed: Vec<Vec3> = tessellate::tessellate(&scene.shapes[0].shape, &tol).unwrap().positions;
        placed.len()
    };
    assert_ne!(count(STILL), count(PULLED));
}

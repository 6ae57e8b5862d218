//! The frame bench's scenes (`benches/frame.rs`), shared with `examples/stop_frames.rs`: the
//! Cornell room without its boxes, lit as the illusion's renders come, its sphere's path, and the
//! frames the sphere takes to settle after a stop.

use depth_remap::{Camera, CameraSettings, Projection};
use glam::{DMat4, DVec3, Vec3};
use viewer::{
    DepthTable, LiveLight, LiveObjects, Material, Rgba8Image, SceneLayers, Sphere, ToneMap, ViewerScene,
};

/// The Cornell room without its boxes (five walls, the eye 3.9 in front of the back wall) at
/// `size^2`, with analytic radial depths.
pub fn room(size: u32) -> ViewerScene {
    room_and_normals(size).0
}

/// The glossy floor's lobe weight (`Ks`) and Blinn exponent (`1 / roughness`) in the
/// `-glossy-floor` benches.
pub const FLOOR_KS: f32 = 0.3;
pub const FLOOR_EXPONENT: f32 = 20.0;

/// The area light's emitting quad, a centimetre below the ceiling, as two triangles.
pub const LIGHT_QUAD: [[DVec3; 3]; 2] = {
    let c = [
        DVec3::new(-0.23, 0.99, -0.18),
        DVec3::new(0.23, 0.99, -0.18),
        DVec3::new(0.23, 0.99, 0.2),
        DVec3::new(-0.23, 0.99, 0.2),
    ];
    [[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
};

/// [`room`] with what the illusion's renders come with: light layers (the wall's normal, an
/// albedo of 0.7, direct light 0.3 and indirect light 0.1 everywhere), the area light's 256
/// samples and one irradiance probe of uniform radiance 0.2. With `glossy_floor` the floor is
/// plastic as well: its pixels get a Blinn lobe ([`FLOOR_KS`], [`FLOOR_EXPONENT`]) in the
/// layers, which turns on the glossy lobes' passes (the room of `examples/room` has one).
pub fn lit_room(size: u32, glossy_floor: bool) -> ViewerScene {
    let (mut scene, normals) = room_and_normals(size);
    let fingerprint = sidecar::depth_fingerprint(scene.depth().values());
    let mut layers =
        sidecar::LightLayers::new(size, size, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    for (k, normal) in normals.iter().enumerate() {
        if let Some(n) = normal {
            layers.normal[k] = n.as_vec3().to_array();
            layers.albedo[k] = [0.7; 3];
            layers.light[0][k] = [0.3; 3];
            layers.indirect[k] = [0.1; 3];
        }
    }
    if glossy_floor {
        let floor = |n: &Option<DVec3>| n.is_some_and(|n| n.y > 0.5);
        layers.glossy = normals.iter().map(|n| if floor(n) { [FLOOR_KS; 3] } else { [0.0; 3] }).collect();
        layers.glossy_exponent =
            normals.iter().map(|n| if floor(n) { [FLOOR_EXPONENT; 3] } else { [0.0; 3] }).collect();
    }
    let area_samples = vec![viewer::light_layers::area_samples(&LIGHT_QUAD, 256)];
    scene
        .set_light_layers(SceneLayers { layers, layer_of_light: vec![Some(0)], area_samples })
        .expect("layers");
    let texels = sidecar::VISIBILITY_TEXELS * sidecar::VISIBILITY_TEXELS;
    let mut sh = [[0.0f32; 3]; 9];
    sh[0] = [0.2 * 0.282_094_8 * 4.0 * std::f32::consts::PI; 3];
    scene.set_probes(sidecar::ProbeGrid {
        depth_fingerprint: fingerprint,
        origin: [0.0; 3],
        spacing: [1.0; 3],
        counts: [1, 1, 1],
        radiance_sh: vec![sh],
        visibility: vec![[10.0, 100.0]; texels],
        emitters_seen: false,
    });
    scene
}

/// [`room`] and each pixel's wall normal (world space, into the room; `None` where no wall).
/// The room's five walls (x = +-1, y = +-1, z = -1, open toward the eye) as the scene's
/// triangles (the scene's shadows on the sphere, which `hybrid-view` always binds) and a
/// reflection probe at the centre seeing radiance 0.2 a unit away (the sphere's default
/// material has a glossy lobe); with `materials` the walls are matte of albedo 0.7 as the layers
/// have them, which turns on the near field and the glossy lobes traced through the scene; with
/// `glossy_floor` too the floor is plastic of the same albedo, with the layers' lobe.
pub fn bind_room_scene(scene: &mut ViewerScene, materials: bool, glossy_floor: bool) {
    let texels = sidecar::REFLECTION_TEXELS;
    let radiance = sidecar::reflection_levels(&vec![[0.2f32; 3]; texels * texels]);
    scene
        .set_reflections(sidecar::ReflectionProbes {
            depth_fingerprint: sidecar::depth_fingerprint(scene.depth().values()),
            origin: [0.0; 3],
            spacing: [1.0; 3],
            counts: [1, 1, 1],
            radiance,
            distance: vec![1.0; texels * texels],
            specular: Vec::new(),
        })
        .expect("reflection probe");
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let quads = [
        [v(-1.0, -1.0, -1.0), v(1.0, -1.0, -1.0), v(1.0, -1.0, 1.0), v(-1.0, -1.0, 1.0)],
        [v(-1.0, 1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(-1.0, 1.0, 1.0)],
        [v(-1.0, -1.0, -1.0), v(1.0, -1.0, -1.0), v(1.0, 1.0, -1.0), v(-1.0, 1.0, -1.0)],
        [v(-1.0, -1.0, -1.0), v(-1.0, 1.0, -1.0), v(-1.0, 1.0, 1.0), v(-1.0, -1.0, 1.0)],
        [v(1.0, -1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(1.0, -1.0, 1.0)],
    ];
    let triangles: Vec<[DVec3; 3]> =
        quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    // The floor is the first quad: its two triangles get the second material.
    let mut of_triangle = vec![0; triangles.len()];
    of_triangle[..2].fill(1);
    scene.set_occluders(viewer::occluders::SceneOccluders { triangles });
    if materials {
        let wall = viewer::occluders::SceneMaterial { diffuse: Vec3::splat(0.7), ..Default::default() };
        let floor = if glossy_floor {
            viewer::occluders::SceneMaterial {
                glossy: Vec3::splat(FLOOR_KS),
                exponent: FLOOR_EXPONENT,
                ..wall
            }
        } else {
            wall
        };
        scene.set_occluder_materials(viewer::occluders::SceneMaterials {
            materials: vec![wall, floor],
            of_triangle,
        });
    }
}

pub fn room_and_normals(size: u32) -> (ViewerScene, Vec<Option<DVec3>>) {
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
    let mut normals = Vec::with_capacity((size * size) as usize);
    let mut pixels = Vec::with_capacity((size * size * 4) as usize);
    for j in 0..size {
        for i in 0..size {
            let ray = camera.pixel_centre_ray(i, j);
            let o = world_from_camera.transform_point3(ray.origin);
            let d = world_from_camera.transform_vector3(ray.direction);
            // Walls: x = +-1, y = +-1, z = -1 (the box is open towards the eye).
            let (mut best, mut normal) = (f64::INFINITY, None);
            for (axis, plane) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0), (2, -1.0)] {
                let t = (plane - o[axis]) / d[axis];
                if t > 0.0 {
                    let p = o + d * t;
                    if p.x.abs() <= 1.0 + 1e-9
                        && p.y.abs() <= 1.0 + 1e-9
                        && p.z <= 1.0
                        && p.z >= -1.0 - 1e-9
                        && t < best
                    {
                        best = t;
                        let mut n = DVec3::ZERO;
                        n[axis] = -plane;
                        normal = Some(n);
                    }
                }
            }
            values.push(best as f32);
            normals.push(normal);
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
    (ViewerScene::new(camera, image, depth, vec![light], ToneMap::default()).expect("scene"), normals)
}

/// The sphere of the lit benches in frame `frame`: back and forth over 40 cm along x above the
/// floor, 1 cm a frame.
pub fn sphere_at(frame: u32) -> LiveObjects {
    let step = f64::from(frame % 80);
    let x = -0.2 + 0.01 * if step < 40.0 { step } else { 80.0 - step };
    LiveObjects {
        sphere: Some(Sphere {
            centre: DVec3::new(x, -0.6, -0.3),
            radius: 0.3,
            material: Material::default(),
        }),
        meshes: Vec::new(),
    }
}

/// Frames the sphere moves before it stops in `fullscreen-lit-stop-worst-near-field`.
pub const STOP_MOVES: u32 = 3;
/// Frames timed after it stops: the backdrop's settling frames at 512^2 (the layered shadows',
/// `SETTLE_SHADOW_PIXELS` of their scissor a frame, 4 at most; the maps'; the rows',
/// `SETTLE_PIXELS` a frame), the sphere's (7 or 8 for the bench's sphere,
/// `SETTLE_SPHERE_PIXELS` of its bounds a frame) and the first kept ones.
pub const STOP_FRAMES: usize = {
    let frame = 512 * 512;
    let shadows = frame / viewer::compositor::SETTLE_SHADOW_PIXELS as usize;
    shadows + 1 + frame / viewer::compositor::SETTLE_PIXELS as usize + 10
};
/// [`STOP_FRAMES`] for `scene` at 512^2, whose frame shows the cursor sphere in reflections (the
/// glossy floor), at most: the bounce light's bands, a mirror's frame, the sphere's glossy lobes
/// in bands of the rows with a lobe (`SETTLE_REFLECTION_PIXELS / 512` rows a band at least, the
/// reflections' rectangle being no wider than the frame), then the loss's bands (settle.rs).
pub fn stop_frames_with_reflections(scene: &ViewerScene) -> usize {
    let layers = &scene.light_layers().expect("light layers").layers;
    let glossy_rows = layers.glossy.chunks(512).filter(|row| row.iter().any(|ks| *ks != [0.0; 3])).count();
    let rows_a_band = (viewer::compositor::SETTLE_REFLECTION_PIXELS as usize / 512).max(1);
    STOP_FRAMES
        + 512 * 512 / viewer::compositor::SETTLE_PIXELS as usize
        + 1
        + glossy_rows.div_ceil(rows_a_band)
}

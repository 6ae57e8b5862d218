// ---------------------------------------------------------------------------------------------
// A glossy live surface's lobe directions through the scene's mirrors (appended to
// composite.wgsl: compositor/mod.rs COMPOSITE_WGSL). What a mirror sends depends on where it is
// seen from: a probe reads, toward a point of a mirror, the reflection its own place sees there,
// not the one a live surface beside the mirror sees (docs/viewer-specular.md, "Glossy lobes
// through mirrors"). So a lobe direction that meets a mirror triangle of the tessellated scene
// follows it, as the ray tracer's path does, until it meets a surface that is not a mirror; the
// probes are then read toward that point, and the mirrors' weights scale what they give. Glass
// ends the chain as any other surface does: followed through a glass ball, refracted in and
// out, the chain made the composite worse (the same section).

// Most mirrors a lobe direction follows.
const SPECULAR_CHAIN_STEPS: u32 = 4u;

// Where a lobe direction's chain ends: `point` (world space) on the first surface that is not
// a mirror, `direction` (world, unit) the chain's last direction, `weight` the product of its
// mirrors' weights; `ended` 1 at such a surface, 0 where the chain left the scene or ran out of
// steps after a mirror (then `point` is where the last segment starts), -1 where the first
// direction met nothing. With `ended` 1, `hit` is that surface's hit on the last segment, which
// starts at camera-space `start`.
struct ChainEnd {
    point: vec3<f32>,
    ended: f32,
    direction: vec3<f32>,
    weight: vec3<f32>,
    start: vec3<f32>,
    hit: SceneHit,
}

// The mirror weight of scene triangle `triangle`'s material (near_field.rs material_table: a
// mirror's kind is 1), or -1 where it is not a mirror.
fn chain_mirror(triangle: u32) -> vec4<f32> {
    let tag = bitcast<u32>(occluder_triangles[3u * triangle].w);
    let count = u32(scene_materials[0].x);
    if tag >= 1u && tag <= count {
        let m = scene_materials[1u + 4u * (tag - 1u) + 1u];
        if m.w > 0.5 && m.w < 1.5 {
            return vec4<f32>(m.rgb, 1.0);
        }
    }
    return vec4<f32>(0.0, 0.0, 0.0, -1.0);
}

// The chain of world unit direction l from world point p (camera-space p_camera) through the
// scene's mirrors (see above). The hierarchy is in camera space; the camera's transform may
// scale, so the direction is found through camera_point_of.
fn specular_chain(p_camera: vec3<f32>, p: vec3<f32>, l: vec3<f32>) -> ChainEnd {
    var origin = p_camera;
    var dir = normalize(camera_point_of(p + l) - p_camera);
    var weight = vec3<f32>(1.0);
    var ended = -1.0;
    var start = p_camera;
    var last = SceneHit(-1.0, dir, 0u);
    for (var step = 0u; step < SPECULAR_CHAIN_STEPS; step++) {
        let hit = bvh_nearest(frame.scene_occluders, origin, dir, 0.0, 3.0e38);
        if !(hit.t < 3.0e38) {
            ended = select(-1.0, 0.0, step > 0u);
            break;
        }
        let x = origin + hit.t * dir;
        let mirror = chain_mirror(hit.triangle);
        if mirror.w < 0.0 {
            start = origin;
            last = SceneHit(hit.t, dir, hit.triangle);
            origin = x;
            ended = 1.0;
            break;
        }
        let g = normalize(cross(occluder_triangles[3u * hit.triangle + 1u].xyz, occluder_triangles[3u * hit.triangle + 2u].xyz));
        // The facet's normal on the side the chain comes from.
        let m = select(g, -g, dot(g, dir) > 0.0);
        weight *= mirror.rgb;
        dir = reflect(dir, m);
        origin = x + m * ray_offset(x);
        ended = 0.0;
    }
    let point = (frame.world_from_camera_point * vec4<f32>(origin, 1.0)).xyz;
    let direction = normalize((frame.world_from_camera * vec4<f32>(dir, 0.0)).xyz);
    return ChainEnd(point, ended, direction, weight, start, last);
}

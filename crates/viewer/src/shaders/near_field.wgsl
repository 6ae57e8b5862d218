// The irradiance probes' light on a live surface corrected for the scene surfaces near it (part
// of the compositing module: compositor::COMPOSITE_WGSL). The probes sit a grid spacing apart
// and each saw the scene from its own point: a live fragment closer to a scene surface than
// that (a sphere beside a large object) gets the light the probes saw around it, where the
// surface hides part of it and sends its own. Within one spacing the scene's triangles say
// exactly what the fragment sees, and the reflection probes (radiance and distance maps) what
// light those surfaces send.

// Cosine-distributed directions a fragment traces toward the scene near it.
const NEAR_FIELD_RAYS: u32 = 16u;
// The reflection probes' mip level read toward a near surface (prefiltered over a Blinn lobe of
// exponent 16, about 1.6 sr): each direction stands for a sixteenth of the hemisphere, and a
// sharper read lets the fixed directions alias the probes' 6-degree texels.
const NEAR_FIELD_LEVEL: f32 = 2.0;

// Where the ray from `origin` along unit `dir` first meets a triangle of hierarchy `bvh`
// between t_min and t_max (the layout of bvh_blocks), t_max when it meets none.
fn bvh_nearest(bvh: vec4<u32>, origin: vec3<f32>, dir: vec3<f32>, t_min: f32, t_max: f32) -> f32 {
    var nearest = t_max;
    if bvh.z == 0u {
        return nearest;
    }
    let inv = select(1.0 / dir, vec3<f32>(1e30), abs(dir) < vec3<f32>(1e-30));
    var stack: array<u32, OCCLUDER_STACK>;
    stack[0] = 0u;
    var top = 1u;
    while top > 0u {
        top -= 1u;
        let k = bvh.x + stack[top];
        let lo = occluder_nodes[2u * k];
        let hi = occluder_nodes[2u * k + 1u];
        let range = slab(origin, inv, lo.xyz, hi.xyz, 0.0, t_min, nearest);
        if range.x > range.y {
            continue;
        }
        let a = bitcast<u32>(lo.w);
        let count = bitcast<u32>(hi.w);
        if count == 0u {
            if top + 2u <= OCCLUDER_STACK {
                stack[top] = a;
                stack[top + 1u] = a + 1u;
                top += 2u;
            }
            continue;
        }
        for (var i = bvh.y + a; i < bvh.y + a + count; i++) {
            let t = occluder_triangle_t(i, origin, dir);
            if t > t_min && t < nearest {
                nearest = t;
            }
        }
    }
    return nearest;
}

// The radiance world point y sends toward the reflection probes of its cell that see it
// (trilinear weights, level NEAR_FIELD_LEVEL) in rgb, and the weight of those probes in w (0:
// no probe sees y, and rgb says nothing). A Lambertian surface sends the same toward a live
// fragment near it.
fn near_surface_radiance(y: vec3<f32>) -> vec4<f32> {
    let grid = grid_cell(y, frame.reflection_origin.xyz, frame.reflection_spacing.xyz, frame.reflection_counts.xyz);
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let c = cell_corner(grid, corner);
        if c.trilinear <= 0.0 || !probe_sees(c.probe, y) {
            continue;
        }
        let to_y = y - probe_position(c.probe);
        let len = length(to_y);
        if !(len > 0.0) {
            continue;
        }
        let uv = octahedral_uv(to_y / len);
        sum += c.trilinear * textureSampleLevel(reflection_radiance, reflection_sampler, uv, probe_index(c.probe), NEAR_FIELD_LEVEL).rgb;
        total += c.trilinear;
    }
    if total > 0.0 {
        return vec4<f32>(sum / total, total);
    }
    return vec4<f32>(0.0);
}

// What the scene surfaces within one irradiance-grid spacing of camera-space point p (unit
// normal n) change in its probe irradiance: over NEAR_FIELD_RAYS cosine-distributed directions
// (a fixed Fibonacci set about n), each direction whose ray meets a scene triangle that close
// and whose hit point a reflection probe sees trades the probe field's radiance from that
// direction (field_radiance_sh) for the hit surface's; the sum times pi / NEAR_FIELD_RAYS is
// the change in irradiance (world units, may be negative). Zero without the scene's triangles
// or the reflection probes.
fn near_field_change(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let bvh = frame.scene_occluders;
    if bvh.z == 0u || frame.reflection_origin.w <= 0.5 {
        return vec3<f32>(0.0);
    }
    let spacing = frame.irradiance_spacing.xyz;
    let reach = min(spacing.x, min(spacing.y, spacing.z));
    let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
    let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
    // The field's radiance SH is blended at the first direction that meets a near surface: a
    // fragment far from the scene meets none and needs none.
    var sh: array<vec4<f32>, 9>;
    var blended = false;
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
    let t = normalize(cross(helper, n));
    let b = cross(n, t);
    let origin = p + n * ray_offset(p);
    // The golden angle: successive directions spiral evenly over the projected disc.
    let golden = PI * (3.0 - sqrt(5.0));
    var change = vec3<f32>(0.0);
    for (var i = 0u; i < NEAR_FIELD_RAYS; i++) {
        let r = sqrt((f32(i) + 0.5) / f32(NEAR_FIELD_RAYS));
        let phi = f32(i) * golden;
        let d = normalize(t * (r * cos(phi)) + b * (r * sin(phi)) + n * sqrt(max(1.0 - r * r, 0.0)));
        let d_world = (frame.world_from_camera * vec4<f32>(d, 0.0)).xyz;
        // Camera units are world units unless the camera transform scales.
        let world_per_camera = length(d_world);
        let t_max = reach / world_per_camera;
        let hit = bvh_nearest(bvh, origin, d, 0.0, t_max);
        if hit >= t_max {
            continue;
        }
        let y = (frame.world_from_camera_point * vec4<f32>(origin + hit * d, 1.0)).xyz;
        let surface = near_surface_radiance(y);
        if surface.w <= 0.0 {
            continue;
        }
        if !blended {
            sh = field_radiance_sh(p_world, n_world);
            blended = true;
        }
        change += surface.rgb - sh_radiance(sh, d_world / world_per_camera);
    }
    return change * (PI / f32(NEAR_FIELD_RAYS));
}

// The probes' indirect irradiance on a live surface at camera-space p with unit normal n, the
// scene near it accounted for (near_field_change), less what the live objects' shadows took
// from it (`loss`, radiance units); zero without probes.
fn live_probe_irradiance(p: vec3<f32>, n: vec3<f32>, loss: vec3<f32>) -> vec3<f32> {
    if frame.counts.w != 1u {
        return vec3<f32>(0.0);
    }
    let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
    let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
    let e = field_irradiance(p_world, n_world) + near_field_change(p, n);
    return max(e - loss, vec3<f32>(0.0));
}

// The irradiance probes' light on a live surface corrected for the scene surfaces near it (part
// of the compositing module: compositor::COMPOSITE_WGSL). The probes sit a grid spacing apart
// and each saw the scene from its own point: a live fragment closer to a scene surface than
// that (a sphere beside a large object) gets the light the probes saw around it, where the
// surface hides part of it and sends its own. Within one spacing the scene's triangles say
// what the fragment sees, and each triangle's own material (compositor/near_field.rs) what
// light it sends: its lights' direct light with shadow rays and the probes' light at it,
// through its diffuse, ambient and glossy lobes (docs/viewer-lighting.md, "Near a large scene
// surface").

// The scene's surface materials: a header vec4 (x: how many) and four vec4s per material
// (compositor/near_field.rs material_table).
@group(0) @binding(31) var<storage, read> scene_materials: array<vec4<f32>>;

// Cosine-distributed directions a fragment traces toward the scene near it.
const NEAR_FIELD_RAYS: u32 = 16u;

// Whether the live objects' shadows (when on) block scene point y's light along unit l up to
// `distance`: the shadow-casting spheres and live meshes with the light layers (as the layered
// shadows take the light from the backdrop, live_blocks), the cursor sphere without them. A
// live sphere resting on a surface darkens that surface under it, which its own underside sees.
fn near_live_blocks(y: vec3<f32>, l: vec3<f32>, distance: f32) -> bool {
    if frame.counts.y != 1u {
        return false;
    }
    if frame.layer_info.x == 1u {
        return live_blocks(y, l, distance);
    }
    return frame.counts.z == 1u && one_sphere_blocks(frame.sphere, y, l, distance);
}

// The share of the probes' light at scene point y (unit normal m) the live spheres leave it:
// with shadows on and the light layers, one less their occlusion of indirect light near
// contact (indirect_occlusion, as the backdrop loses it); the light the spheres send in its
// place is left out.
fn near_field_unoccluded(y: vec3<f32>, m: vec3<f32>) -> f32 {
    if frame.counts.y != 1u || frame.layer_info.x != 1u {
        return 1.0;
    }
    return 1.0 - indirect_occlusion(y, m);
}

// The lights' direct light at scene point y (unit normal m, toward the live fragment along w):
// as direct_light_with, but each area light as one point at its centroid (light_toward) with
// one shadow ray, not over its emitter samples: the near surfaces are lit from afar, and a
// fragment traces up to NEAR_FIELD_RAYS of them. The live objects' shadows block it too.
fn near_direct_light(y: vec3<f32>, m: vec3<f32>, w: vec3<f32>, exponent: f32) -> DirectLight {
    var ambient = vec3<f32>(0.0);
    var diffuse = vec3<f32>(0.0);
    var specular = vec3<f32>(0.0);
    let count = min(frame.counts.x, MAX_LIGHTS);
    // No `continue` (lavapipe, as in direct_light_with).
    for (var k = 0u; k < count; k++) {
        let light = frame.lights[k];
        if u32(light.position.w + 0.5) == LIGHT_AMBIENT {
            ambient += light.colour.rgb;
        } else {
            let toward = light_toward(k, y);
            let n_dot_l = dot(m, toward.l);
            var lit = n_dot_l > 0.0 && !all(toward.e <= vec3<f32>(0.0));
            if lit {
                lit = !near_live_blocks(y, toward.l, toward.distance);
            }
            if lit {
                lit = scene_lets_light(y, m, toward.l, toward.distance, 0.0);
            }
            if lit {
                diffuse += toward.e * n_dot_l;
                specular += toward.e * blinn_lobe_cos(m, w, toward.l, exponent);
            }
        }
    }
    return DirectLight(ambient, diffuse, specular);
}

// The radiance a scene surface of material `material` (an index into the table) at
// camera-space y, unit normal m facing the live fragment, sends toward it along unit w (from y
// to the fragment): its diffuse lobe over the lights' direct light (near_direct_light) and
// the probes' irradiance at y less the live spheres' occlusion of it, its ambient term, its
// glossy lobe's highlights of the lights toward w, and a shader's own emission. Area lights'
// emission is the lights' direct light on the fragment already, and the probes' light in the
// surface's glossy lobe is left out.
fn near_surface_radiance(material: u32, y: vec3<f32>, m: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    let base = 1u + 4u * material;
    let diffuse = scene_materials[base];
    let glossy = scene_materials[base + 1u];
    let ambient = scene_materials[base + 2u];
    let emission = scene_materials[base + 3u];
    let lit = near_direct_light(y, m, w, max(diffuse.w, 1.0));
    let y_world = (frame.world_from_camera_point * vec4<f32>(y, 1.0)).xyz;
    let m_world = normalize((frame.world_from_camera * vec4<f32>(m, 0.0)).xyz);
    let e = lit.diffuse + field_irradiance(y_world, m_world) * near_field_unoccluded(y, m);
    let cos_o = clamp(dot(m, w), 0.0, 1.0);
    return diffuse.rgb / PI * e + ambient.rgb * lit.ambient + glossy.rgb * lit.specular
        + emission.rgb * (emission.w + ambient.w * cos_o * cos_o);
}

// What the scene surfaces within one irradiance-grid spacing of camera-space point p (unit
// normal n) change in its probe irradiance. Over NEAR_FIELD_RAYS cosine-distributed directions
// (a fixed Fibonacci set about n), each direction whose ray meets a scene triangle with a
// known, non-specular material that close trades the probe field's radiance from that
// direction (field_radiance_sh) for the light the surface sends (near_surface_radiance); the
// sum times pi / NEAR_FIELD_RAYS is the change in irradiance (may be negative). Where no ray
// meets a near surface the change is exactly zero, so the probes' light stays as it was; as the
// directions grow in number the sum tends to the integral of (surface - field) radiance over
// the near directions. Zero without the scene's triangles, their materials or the probes.
fn near_field_change(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let bvh = frame.scene_occluders;
    if bvh.z == 0u || frame.counts.w != 1u || scene_materials[0].x < 0.5 {
        return vec3<f32>(0.0);
    }
    let spacing = frame.irradiance_spacing.xyz;
    let reach = min(spacing.x, min(spacing.y, spacing.z));
    let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
    let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
    let material_count = u32(scene_materials[0].x);
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
        let tag = bitcast<u32>(occluder_triangles[3u * hit.triangle].w);
        var material = 0u;
        var known = hit.t < t_max && tag >= 1u && tag <= material_count;
        if known {
            material = tag - 1u;
            // Mirror and glass keep the probes' light from their direction.
            known = scene_materials[1u + 4u * material + 1u].w < 0.5;
        }
        // No `continue` after the traversal (lavapipe, as in direct_light_with).
        if known {
            let e1 = occluder_triangles[3u * hit.triangle + 1u].xyz;
            let e2 = occluder_triangles[3u * hit.triangle + 2u].xyz;
            var m = normalize(cross(e1, e2));
            m = select(m, -m, dot(m, d) > 0.0);
            let y = origin + hit.t * d;
            let surface = near_surface_radiance(material, y, m, -d);
            if !blended {
                sh = field_radiance_sh(p_world, n_world);
                blended = true;
            }
            change += surface - sh_radiance(sh, d_world / world_per_camera);
        }
    }
    return change * (PI / f32(NEAR_FIELD_RAYS));
}

// The probes' indirect irradiance on a live surface at camera-space p with unit normal n, the
// scene surfaces near it accounted for (near_field_change), less what the live objects'
// shadows took from it (`loss`, radiance units); zero without probes.
fn live_probe_irradiance(p: vec3<f32>, n: vec3<f32>, loss: vec3<f32>) -> vec3<f32> {
    if frame.counts.w != 1u {
        return vec3<f32>(0.0);
    }
    let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
    let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
    let e = field_irradiance(p_world, n_world) + near_field_change(p, n);
    return max(e - loss, vec3<f32>(0.0));
}

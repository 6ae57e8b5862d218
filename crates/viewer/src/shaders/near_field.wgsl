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
// glossy lobe's highlights of the lights toward w and its reflection of the probes' light, and
// a shader's own emission. Area lights' emission is the lights' direct light on the fragment
// already. A metal beside a live object sends it the scene it reflects (the room's gold
// cylinder warms a sphere's side facing it in the ray tracer's image, where the lobe's
// highlights alone left that side dark).
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
    // The probes' radiance at y from the lobe's centre, the mirror direction of w: the SH's
    // band limit blurs it as a rough lobe would. The lobe's albedo is taken as 1, the ray
    // tracer's Blinn lobe being normalised (its albedo falls below 1 only toward grazing).
    var reflected = vec3<f32>(0.0);
    if any(glossy.rgb > vec3<f32>(0.0)) {
        let r_world = normalize((frame.world_from_camera * vec4<f32>(reflect(-w, m), 0.0)).xyz);
        reflected = sh_radiance(field_radiance_sh(y_world, m_world), r_world) * near_field_unoccluded(y, m);
    }
    return diffuse.rgb / PI * e + ambient.rgb * lit.ambient + glossy.rgb * (lit.specular + reflected)
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
// Spheres read it from their near-field maps (near_field_change).
fn near_field_traced(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
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

// ---------------------------------------------------------------------------------------------
// Near-field maps (compositor/near_field_map.rs). On a live sphere the near field and the glossy
// lobe traced through the scene depend on the point alone once the camera, the spheres and the
// lights are fixed (the view direction at a point of a sphere is the point's own), as the
// own-shadow loss does: so they are traced once per texel of a map over the hemisphere facing
// the eye (the loss maps' hemi-octahedral layout and rows) when those change, and fragments read
// them bilinearly instead of tracing 16 directions each per frame. Row k, columns
// [0, NEAR_FIELD_MAP_TEXELS): near_field_traced's irradiance (rgb); the next
// NEAR_FIELD_MAP_TEXELS columns: glossy_reflection's radiance with traced hits (rgb). Alpha is
// 1 where a part is drawn.
@group(0) @binding(32) var near_field_maps: texture_2d<f32>;

const NEAR_FIELD_MAP_TEXELS: u32 = 32u;
const NEAR_FIELD_PART: u32 = 0u;
const GLOSSY_PART: u32 = 1u;

// The row of the sphere whose fragment is shaded (loss_map_row) when its map's `part` is drawn
// and serves it; -1 otherwise (trace per fragment).
fn near_field_map_row(part: u32) -> i32 {
    if loss_map_row < 0 || u32(loss_map_row) >= loss_map_rows() {
        return -1;
    }
    let row = u32(loss_map_row);
    let first = vec2<i32>(i32(part * NEAR_FIELD_MAP_TEXELS), i32(row * NEAR_FIELD_MAP_TEXELS));
    let drawn = textureLoad(near_field_maps, first, 0).a > 0.5;
    return select(-1, loss_map_row, drawn && loss_map_serves(loss_map_sphere(row)));
}

// The map's `part` of sphere `row` at camera-space unit normal n, bilinear (as loss_map_lookup).
fn near_field_map_lookup(row: u32, part: u32, n: vec3<f32>) -> vec3<f32> {
    let basis = loss_map_basis(loss_map_sphere(row).xyz);
    let uv = hemi_octahedral(transpose(basis) * n);
    let size = f32(NEAR_FIELD_MAP_TEXELS);
    let texel = (uv * 0.5 + 0.5) * size - 0.5;
    let base = clamp(floor(texel), vec2<f32>(0.0), vec2<f32>(size - 2.0));
    let f = clamp(texel - base, vec2<f32>(0.0), vec2<f32>(1.0));
    let at = vec2<i32>(base) + vec2<i32>(i32(part * NEAR_FIELD_MAP_TEXELS), i32(row * NEAR_FIELD_MAP_TEXELS));
    let l00 = textureLoad(near_field_maps, at, 0).rgb;
    let l10 = textureLoad(near_field_maps, at + vec2<i32>(1, 0), 0).rgb;
    let l01 = textureLoad(near_field_maps, at + vec2<i32>(0, 1), 0).rgb;
    let l11 = textureLoad(near_field_maps, at + vec2<i32>(1, 1), 0).rgb;
    return mix(mix(l00, l10, f.x), mix(l01, l11, f.x), f.y);
}

// The near field's change of the probes' irradiance at camera-space p (unit normal n): from the
// map of the sphere being shaded where it has one, else traced here; none in a moving frame
// (frame.tone.w, compositor/frame.rs), which the frame at rest makes exact.
fn near_field_change(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    if frame.tone.w > 0.5 {
        return vec3<f32>(0.0);
    }
    let row = near_field_map_row(NEAR_FIELD_PART);
    if row >= 0 {
        return near_field_map_lookup(u32(row), NEAR_FIELD_PART, n);
    }
    return near_field_traced(p, n);
}

// The radiance a live surface's glossy lobe (`exponent`) reflects at camera-space p (unit normal
// n, toward the eye v; world-space p_world, n_world, v_world): with `traced` the lobe's
// directions meet the scene's triangles, from the map of the sphere being shaded where it has
// one; else, and in a moving frame, they meet the reflection probes' distance maps
// (glossy_reflection).
fn glossy_lobe(p_world: vec3<f32>, n: vec3<f32>, n_world: vec3<f32>, v_world: vec3<f32>, exponent: f32, traced_asked: bool) -> vec3<f32> {
    let traced = traced_asked && frame.tone.w < 0.5;
    if traced {
        let row = near_field_map_row(GLOSSY_PART);
        if row >= 0 {
            return near_field_map_lookup(u32(row), GLOSSY_PART, n);
        }
    }
    return glossy_reflection(p_world, n_world, v_world, exponent, traced);
}

// One texel of the atlas: at the texel's normal of the sphere of its row, the near field's
// irradiance or the traced glossy lobe's radiance (the sphere's material: the cursor sphere's
// or the mesh bound in group 1), alpha 1; zero where the row has no sphere or no such lobe.
@fragment
fn fs_near_field_map(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let texel = vec2<u32>(position.xy);
    let row = texel.y / NEAR_FIELD_MAP_TEXELS;
    let part = texel.x / NEAR_FIELD_MAP_TEXELS;
    if row >= loss_map_rows() || scene_materials[0].x < 0.5 {
        return vec4<f32>(0.0);
    }
    let s = loss_map_sphere(row);
    if !loss_map_serves(s) {
        return vec4<f32>(0.0);
    }
    let local = texel % vec2<u32>(NEAR_FIELD_MAP_TEXELS);
    let uv = (vec2<f32>(local) + vec2<f32>(0.5)) / f32(NEAR_FIELD_MAP_TEXELS) * 2.0 - vec2<f32>(1.0);
    let n = loss_map_basis(s.xyz) * hemi_octahedral_direction(uv);
    let p = s.xyz + s.w * n;
    let half_max = vec3<f32>(65504.0);
    if part == NEAR_FIELD_PART {
        return vec4<f32>(clamp(near_field_traced(p, n), -half_max, half_max), 1.0);
    }
    let material = live_sphere_material(row);
    let ks = material.coefficients.z;
    if material.colour.w > 0.5 || ks == 0.0 || frame.reflection_origin.w < 0.5 {
        return vec4<f32>(0.0);
    }
    let exponent = clamp(1.0 / max(material.coefficients.w, 1e-4), 1.0, 10000.0);
    // The direction toward the eye at p, as the sphere's fragments see it.
    let v = select(vec3<f32>(0.0, 0.0, -1.0), normalize(-p), frame.raster.w > 0.5);
    let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
    let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
    let v_world = normalize((frame.world_from_camera * vec4<f32>(v, 0.0)).xyz);
    let lobe = glossy_reflection(p_world, n_world, v_world, exponent, true);
    return vec4<f32>(min(lobe, half_max), 1.0);
}

// The live objects' shadows on the pre-rendered scene (appended to composite.wgsl:
// compositor/mod.rs COMPOSITE_WGSL; the bindings and helpers are composite.wgsl's): spheres
// analytically, live meshes through their triangle hierarchy (scene_visibility.wgsl).

// ---------------------------------------------------------------------------------------------
// Shadows of the sphere on the pre-rendered scene: each pixel's surface point is rebuilt from
// the radial depth along its pixel-centre ray; the fraction of the shadow light hidden by the
// sphere (disc overlap of their angular extents) darkens the pixel by a multiplicative blend.
// Unshadowed pixels are discarded, so they keep their exact input value.

fn surface_point(pixel: vec2<i32>) -> vec4<f32> {
    let size = vec2<i32>(frame.raster.xy);
    let q = clamp(pixel, vec2<i32>(0), size - vec2<i32>(1));
    let r = textureLoad(backdrop_radial_depth, q, 0).r;
    let ray = ray_through_raster(vec2<f32>(q) + vec2<f32>(0.5));
    // A miss (inf) has no surface.
    let hit = r < 3.0e38;
    return vec4<f32>(ray.origin + r * ray.direction, select(0.0, 1.0, hit));
}

// Area of the intersection of two discs of radii a and b whose centres are d apart.
fn disc_overlap(a: f32, b: f32, d: f32) -> f32 {
    if d >= a + b {
        return 0.0;
    }
    let small = min(a, b);
    if d <= abs(a - b) {
        return PI * small * small;
    }
    let a2 = a * a;
    let b2 = b * b;
    let alpha = acos(clamp((d * d + a2 - b2) / (2.0 * d * a), -1.0, 1.0));
    let beta = acos(clamp((d * d + b2 - a2) / (2.0 * d * b), -1.0, 1.0));
    return a2 * alpha + b2 * beta - 0.5 * sqrt(max((-d + a + b) * (d + a - b) * (d - a + b) * (d + a + b), 0.0));
}

const CONE_CLEAR: u32 = 0u;
const CONE_UMBRA: u32 = 1u;
const CONE_PENUMBRA: u32 = 2u;

// How the shadow-casting spheres stand against an emitter's bounding cone from p (unit `axis`,
// half-angle with cosine `cos_e` and sine `sin_e`, emitter points between `near` and `far`
// from p), compared by cosines: CONE_CLEAR when no sphere's cone overlaps it (the angle
// between the axes at least the sum of the half-angles plus 1e-3 radians), CONE_UMBRA when one
// sphere's cone holds it whole with every emitter point beyond the sphere's nearest hit (which
// is at most the sphere's distance along any ray inside its cone), else CONE_PENUMBRA.
fn emitter_cone_class(p: vec3<f32>, axis: vec3<f32>, cos_e: f32, sin_e: f32, near: f32, far: f32) -> u32 {
    var cone_class = CONE_CLEAR;
    for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
        let sphere = frame.shadow_spheres[i];
        let to_sphere = sphere.xyz - p;
        let ds = length(to_sphere);
        let r = sphere.w;
        if ds <= r {
            return CONE_UMBRA;
        }
        if ds - r >= far {
            continue;
        }
        let sin_s = r / ds;
        let cos_s = sqrt(max(1.0 - sin_s * sin_s, 0.0));
        let cos_between = dot(to_sphere / ds, axis);
        let cos_sum = cos_s * cos_e - sin_s * sin_e;
        let sin_sum = sin_s * cos_e + cos_s * sin_e;
        // cos(sum + 1e-3); a sum within 1e-3 of pi overlaps every direction.
        if cos_sum > -0.9999 && cos_between <= cos_sum * 0.9999995 - sin_sum * 1e-3 {
            continue;
        }
        let sin_diff = sin_s * cos_e - cos_s * sin_e;
        let cos_diff = cos_s * cos_e + sin_s * sin_e;
        if sin_diff > 1e-3 && ds <= near && cos_between >= cos_diff * 0.9999995 + sin_diff * 1e-3 {
            return CONE_UMBRA;
        }
        cone_class = CONE_PENUMBRA;
    }
    return cone_class;
}

// Whether a live mesh's bounding sphere (radius 0: no meshes) can overlap an emitter's bounding
// cone from p (unit `axis`, half-angle cosine `cos_e` and sine `sin_e`, emitter points at most
// `far` from p), by the cone test of emitter_cone_class: if not, no mesh hides any of it.
fn live_meshes_near_cone(p: vec3<f32>, axis: vec3<f32>, cos_e: f32, sin_e: f32, far: f32) -> bool {
    let bound = frame.live_occluder_bound;
    if frame.live_occluders.z == 0u || bound.w <= 0.0 {
        return false;
    }
    let to_bound = bound.xyz - p;
    let ds = length(to_bound);
    if ds <= bound.w {
        return true;
    }
    if ds - bound.w >= far {
        return false;
    }
    let sin_s = bound.w / ds;
    let cos_s = sqrt(max(1.0 - sin_s * sin_s, 0.0));
    let cos_sum = cos_s * cos_e - sin_s * sin_e;
    let sin_sum = sin_s * cos_e + cos_s * sin_e;
    return cos_sum <= -0.9999 || dot(to_bound / ds, axis) > cos_sum * 0.9999995 - sin_sum * 1e-3;
}

// Whether a live object (a shadow-casting sphere or a live mesh) blocks the segment from p
// along unit dir up to max_t.
fn live_blocks(p: vec3<f32>, dir: vec3<f32>, max_t: f32) -> bool {
    return sphere_blocks(p, dir, max_t) || live_mesh_blocks(p, dir, max_t);
}

// Whether any shadow-casting sphere blocks the segment from p along unit dir up to max_t.
fn sphere_blocks(p: vec3<f32>, dir: vec3<f32>, max_t: f32) -> bool {
    for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
        if one_sphere_blocks(frame.shadow_spheres[i], p, dir, max_t) {
            return true;
        }
    }
    return false;
}

// Whether sphere (centre, radius) blocks the segment from p along unit dir up to max_t.
fn one_sphere_blocks(sphere: vec4<f32>, p: vec3<f32>, dir: vec3<f32>, max_t: f32) -> bool {
    let f = p - sphere.xyz;
    let r = sphere.w;
    let c = dot(f, f) - r * r;
    if c <= 0.0 {
        return true;
    }
    let b = dot(f, dir);
    let q = f - b * dir;
    let disc = r * r - dot(q, q);
    if disc < 0.0 || b >= 0.0 {
        return false;
    }
    let t = c / (-b + sqrt(disc));
    return t < max_t;
}

fn luminance(c: vec3<f32>) -> f32 {
    return (c.r + c.g + c.b) / 3.0;
}

// The share of light i's direct light at p, the surface point at the centre of `pixel` (normal
// n, zero if unknown), that live objects hide, and the light's unshadowed irradiance there (to
// weigh lights that share a layer). Hard shadows are taken over the pixel's footprint
// (shadow_footprint.wgsl).
fn hidden_share(i: u32, pixel: vec2<i32>, p: vec3<f32>, n: vec3<f32>) -> vec2<f32> {
    let light = frame.lights[i];
    let kind = u32(light.position.w + 0.5);
    let has_n = dot(n, n) > 0.0;
    let power = luminance(light.colour.rgb);
    if kind == LIGHT_DISTANT {
        let dir = -light.direction.xyz;
        let cos_s = select(1.0, max(dot(n, dir), 0.0), has_n);
        return vec2<f32>(footprint_hidden(pixel, p, n, has_n, dir, true), power * cos_s);
    }
    if kind == LIGHT_POINT || kind == LIGHT_SPOT {
        let v = light.position.xyz - p;
        let d = length(v);
        let dir = v / d;
        let cos_s = select(1.0, max(dot(n, dir), 0.0), has_n);
        return vec2<f32>(footprint_hidden(pixel, p, n, has_n, light.position.xyz, false), power * cos_s / (d * d));
    }
    if kind == LIGHT_AREA {
        // The ray tracer's integral over the emitter, on its fixed samples: the occluded share
        // of sum(area cos_l cos_s / d^2). First a cone test: when no sphere's cone from p
        // or live mesh bound overlaps the emitter's bounding cone, nothing is hidden (most
        // pixels).
        let slot = frame.shadow_slots[i];
        let to_light = light.position.xyz - p;
        let dl = length(to_light);
        let bound = bitcast<f32>(slot.w);
        if dl > bound {
            let sin_e = bound / dl;
            let axis = to_light / dl;
            let cos_e = sqrt(max(1.0 - sin_e * sin_e, 0.0));
            let cone_class = emitter_cone_class(p, axis, cos_e, sin_e, dl - bound, dl + bound);
            if cone_class == CONE_CLEAR && !live_meshes_near_cone(p, axis, cos_e, sin_e, dl + bound) {
                return vec2<f32>(0.0, power / (dl * dl));
            }
            if cone_class == CONE_UMBRA {
                return vec2<f32>(1.0, power / (dl * dl));
            }
        }
        var total = 0.0;
        var hidden = 0.0;
        for (var k = slot.y; k < min(slot.y + slot.z, MAX_AREA_SAMPLES); k = k + 1u) {
            let s = area_samples.samples[2u * k];
            let sn = area_samples.samples[2u * k + 1u];
            let v = s.xyz - p;
            let d2 = dot(v, v);
            if d2 <= 0.0 {
                continue;
            }
            let d = sqrt(d2);
            let dir = v / d;
            var cos_l = 1.0;
            if dot(sn.xyz, sn.xyz) > 0.0 {
                cos_l = dot(sn.xyz, -dir);
                if sn.w > 0.5 {
                    cos_l = abs(cos_l);
                }
            }
            let cos_s = select(1.0, dot(n, dir), has_n);
            if cos_l <= 0.0 || cos_s <= 0.0 {
                continue;
            }
            let g = s.w * cos_l * cos_s / d2;
            total += g;
            if live_blocks(p, dir, d) {
                hidden += g;
            }
        }
        if total <= 0.0 {
            return vec2<f32>(0.0, 0.0);
        }
        return vec2<f32>(hidden / total, power * total);
    }
    return vec2<f32>(0.0, 0.0);
}

// Shadows with the renderer's light layers: each light's occluded share of its own layer, and
// the sphere's occlusion of indirect light (cosine-weighted solid angle, (r/d)^2 cos) of the
// indirect layer, both in the image's units.
fn layered_shadow(pixel: vec2<i32>, p: vec3<f32>) -> vec3<f32> {
    let n = layer_normal(pixel);
    var removed = vec3<f32>(0.0);
    if frame.shadow_params.z < 0.5 {
        // Every layer holds one light (the usual case): its own share, no bookkeeping.
        for (var i = 0u; i < frame.counts.x; i = i + 1u) {
            let slice = frame.shadow_slots[i].x;
            if slice == NO_LAYER {
                continue;
            }
            let s = hidden_share(i, pixel, p, n).x;
            if s > 0.0 {
                removed += s * textureLoad(light_layers, pixel, i32(slice), 0).rgb;
            }
        }
    } else {
        removed = shared_layer_shadow(pixel, p, n);
    }
    return (removed + indirect_occlusion(p, n) * occludable_indirect(pixel)) * frame.tone.x;
}

// The unit normal the light layers hold at `pixel` (zero where they hold none).
fn layer_normal(pixel: vec2<i32>) -> vec3<f32> {
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    return select(vec3<f32>(0.0), normalize(n_raw), dot(n_raw, n_raw) > 1e-12);
}

// The indirect light at `pixel` that the spheres' occlusion hides (indirect_occlusion's share
// of it), in the layers' units.
fn occludable_indirect(pixel: vec2<i32>) -> vec3<f32> {
    // A specular reflection's light is not hidden evenly: the reflection pass traces its one
    // direction (specular.wgsl, fs_reflection), so only the rest of the indirect light is. A
    // glossy lobe is traced there too (fs_glossy): only the share of the indirect light that
    // is not the lobe's (glossy_indirect_share) is hidden here, none of a metal's.
    var indirect = textureLoad(light_layers, pixel, i32(frame.layer_info.y), 0).rgb;
    if frame.reflection.x == 1u && frame.reflection.z != NO_LAYER {
        indirect -= textureLoad(light_layers, pixel, i32(frame.reflection.z), 0).rgb;
    }
    if frame.reflection.x == 1u && frame.reflection.w != NO_LAYER {
        let glossy = textureLoad(light_layers, pixel, i32(frame.reflection.w), 0).rgb;
        // Without the bounce light's albedo slice no pixel has a diffuse albedo.
        var albedo = vec3<f32>(0.0);
        if frame.bounce.x == 1u {
            albedo = textureLoad(light_layers, pixel, i32(frame.bounce.y), 0).rgb;
        }
        if any(glossy > vec3<f32>(0.0)) {
            indirect *= vec3<f32>(1.0) - glossy_indirect_share(pixel, glossy, albedo);
        }
    }
    return indirect;
}

// Layers that hold several lights (scenes with more than 16): each light's share weighted by
// its unshadowed irradiance.
fn shared_layer_shadow(pixel: vec2<i32>, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    var numerator = array<f32, MAX_LIGHTS>();
    var weight = array<f32, MAX_LIGHTS>();
    var share = array<f32, MAX_LIGHTS>();
    var lights_in = array<u32, MAX_LIGHTS>();
    for (var i = 0u; i < frame.counts.x; i = i + 1u) {
        let slice = frame.shadow_slots[i].x;
        if slice == NO_LAYER {
            continue;
        }
        let h = hidden_share(i, pixel, p, n);
        numerator[slice] += h.x * h.y;
        weight[slice] += h.y;
        share[slice] = h.x;
        lights_in[slice] += 1u;
    }
    var removed = vec3<f32>(0.0);
    for (var slice = 0u; slice < MAX_LIGHTS; slice = slice + 1u) {
        if lights_in[slice] == 0u {
            continue;
        }
        // One light per layer: its own share; several: weighted by their irradiance.
        var s = share[slice];
        if lights_in[slice] > 1u {
            s = select(0.0, numerator[slice] / weight[slice], weight[slice] > 0.0);
        }
        if s > 0.0 {
            removed += s * textureLoad(light_layers, pixel, i32(slice), 0).rgb;
        }
    }
    return removed;
}

// The spheres' cosine-weighted occluded solid angle at p (normal n): occluded indirect light.
fn indirect_occlusion(p: vec3<f32>, n: vec3<f32>) -> f32 {
    // Occluded solid angles of separate spheres add (overlaps are rare and small).
    var ao = 0.0;
    for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
        let sphere = frame.shadow_spheres[i];
        let to_sphere = sphere.xyz - p;
        let d = length(to_sphere);
        let r = sphere.w;
        if d <= r {
            ao = 1.0;
            break;
        }
        let cos_s = select(1.0, max(dot(n, to_sphere / d), 0.0), dot(n, n) > 0.0);
        let fade = 1.0 - smoothstep(0.75 * AO_REACH * r, AO_REACH * r, d);
        ao += cos_s * (r / d) * (r / d) * fade;
    }
    return min(ao, 1.0);
}

@fragment
fn fs_shadow(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let centre = surface_point(pixel);
    if centre.w < 0.5 {
        discard;
    }
    if frame.layer_info.x == 1u {
        let removed = layered_shadow(pixel, centre.xyz);
        if all(removed <= vec3<f32>(0.0)) {
            discard;
        }
        let before = caustic_removed(pixel, textureLoad(backdrop_colour, pixel, 0));
        return vec4<f32>(max(before.rgb - removed, vec3<f32>(0.0)), before.a);
    }
    let p = centre.xyz;
    // Direction and distance to the light.
    var to_light: vec3<f32>;
    var light_distance: f32;
    if frame.shadow_light.w > 0.5 {
        let v = frame.shadow_light.xyz - p;
        light_distance = length(v);
        to_light = v / light_distance;
    } else {
        to_light = -frame.shadow_light.xyz;
        light_distance = 3.0e38;
    }
    // The sphere as seen from p.
    let to_sphere = frame.sphere.xyz - p;
    let sphere_distance = length(to_sphere);
    let r = frame.sphere.w;
    if sphere_distance <= r || sphere_distance - r >= light_distance {
        discard;
    }
    let sphere_angle = asin(r / sphere_distance);
    let separation = acos(clamp(dot(to_sphere / sphere_distance, to_light), -1.0, 1.0));
    var hidden = 0.0;
    let light_angle = atan(frame.shadow_params.x / light_distance);
    if light_angle > 1e-4 {
        hidden = disc_overlap(light_angle, sphere_angle, separation) / (PI * light_angle * light_angle);
    } else if separation < sphere_angle {
        hidden = 1.0;
    }
    hidden = clamp(hidden, 0.0, 1.0);
    if hidden <= 0.0 {
        discard;
    }
    // Only surfaces facing the light receive its direct light (checked last: it reads four
    // neighbours, and most pixels are out of the shadow). The normal comes from the
    // rebuilt neighbours, taking on each axis the neighbour nearer in depth so edges do not
    // bend it.
    let right = surface_point(pixel + vec2<i32>(1, 0));
    let left = surface_point(pixel - vec2<i32>(1, 0));
    let down = surface_point(pixel + vec2<i32>(0, 1));
    let up = surface_point(pixel - vec2<i32>(0, 1));
    var dx = right.xyz - p;
    if right.w < 0.5 || (left.w > 0.5 && abs(p.z - left.z) < abs(right.z - p.z)) {
        dx = p - left.xyz;
    }
    var dy = down.xyz - p;
    if down.w < 0.5 || (up.w > 0.5 && abs(p.z - up.z) < abs(down.z - p.z)) {
        dy = p - up.xyz;
    }
    var n = cross(dx, dy);
    let len = length(n);
    if len > 0.0 {
        n = n / len;
        let toward_eye = -ray_through_raster(position.xy).direction;
        if dot(n, toward_eye) < 0.0 {
            n = -n;
        }
        if dot(n, to_light) <= 0.0 {
            discard;
        }
    }
    let keep = 1.0 - frame.shadow_params.y * hidden;
    let backdrop = caustic_removed(pixel, textureLoad(backdrop_colour, pixel, 0));
    return vec4<f32>(backdrop.rgb * keep, backdrop.a);
}

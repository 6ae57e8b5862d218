// Hard shadows over a pixel's footprint (appended to composite.wgsl after shadows.wgsl:
// compositor/mod.rs COMPOSITE_WGSL; the bindings and helpers are composite.wgsl's and
// shadows.wgsl's).
//
// The renderer filters each pixel over its area, so in its light layers the edge of a point,
// spot or distant light's shadow is a ramp about a pixel wide. One shadow ray through the
// pixel's centre cut that ramp into a staircase of pixels too dark and too bright against a
// ray trace with the live object in it (in `cargo xtask illusion`, the room's sphere resting
// in front of its point light: about half the error of the region the sphere changes). So
// where a live object's outline, seen from the light, passes within a pixel's footprint, the
// hidden share is the mean over FOOTPRINT_SIDE^2 points of the footprint; elsewhere one ray
// decides for the whole pixel, as before.

const FOOTPRINT_SIDE: u32 = 4u;

// The surface point under raster position `raster`: where its ray meets the plane through p
// with unit normal n (when has_n), else, or where that plane is more than 4 times the
// footprint's size away (a grazing view), the point at p's depth along that ray.
fn footprint_point(raster: vec2<f32>, p: vec3<f32>, n: vec3<f32>, has_n: bool) -> vec3<f32> {
    let ray = ray_through_raster(raster);
    let level = ray.origin + ray.direction * dot(p - ray.origin, ray.direction);
    let denom = dot(ray.direction, n);
    if !has_n || abs(denom) < 1e-6 {
        return level;
    }
    let on_plane = ray.origin + ray.direction * (dot(p - ray.origin, n) / denom);
    if length(on_plane - p) > 4.0 * length(level - p) + 1e-6 {
        return level;
    }
    return on_plane;
}

// How the segment from p along unit dir up to max_t passes a sphere (centre, radius): -1 when
// it stays farther than `reach` outside it, 1 when it passes more than `reach` inside (so every
// segment within `reach` of it is blocked), 0 when within `reach` of its outline.
fn segment_against_sphere(sphere: vec4<f32>, p: vec3<f32>, dir: vec3<f32>, max_t: f32, reach: f32) -> i32 {
    let to_centre = sphere.xyz - p;
    let t = clamp(dot(to_centre, dir), 0.0, max_t);
    let s = length(to_centre - t * dir);
    if s > sphere.w + reach {
        return -1;
    }
    if s < sphere.w - reach {
        return 1;
    }
    return 0;
}

// The unit direction from q toward a light at `position` and the distance to it, or, with
// `distant`, the direction `position` itself and 3e38.
fn toward_light_from(q: vec3<f32>, position: vec3<f32>, distant: bool) -> vec4<f32> {
    if distant {
        return vec4<f32>(position, 3.0e38);
    }
    let v = position - q;
    let dist = length(v);
    return vec4<f32>(v / dist, dist);
}

// The share of light `light` (a point or spot light at position `position`, or with `distant`
// a light along unit direction `position` toward it) that live objects hide over the footprint
// of `pixel`, whose centre's surface point is p (unit normal n when has_n).
fn footprint_hidden(pixel: vec2<i32>, p: vec3<f32>, n: vec3<f32>, has_n: bool, position: vec3<f32>, distant: bool) -> f32 {
    let toward = toward_light_from(p, position, distant);
    let dir = toward.xyz;
    let dist = toward.w;
    // Every segment toward the light from a point of the footprint stays within `reach` of the
    // centre's (they converge on a point light and run parallel to a distant one).
    let centre = vec2<f32>(pixel) + vec2<f32>(0.5);
    var reach = 0.0;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let corner = centre + vec2<f32>(f32(k & 1u) - 0.5, f32(k >> 1u) - 0.5);
        reach = max(reach, length(footprint_point(corner, p, n, has_n) - p));
    }
    // One ray decides unless a sphere's outline or the live meshes' bound is within reach.
    var near_outline = false;
    for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
        let side = segment_against_sphere(frame.shadow_spheres[i], p, dir, dist, reach);
        if side == 1 {
            return 1.0;
        }
        near_outline = near_outline || side == 0;
    }
    let bound = frame.live_occluder_bound;
    if frame.live_occluders.z != 0u && bound.w > 0.0 {
        near_outline = near_outline || segment_against_sphere(bound, p, dir, dist, reach) != -1;
    }
    if !near_outline {
        return select(0.0, 1.0, live_blocks(p, dir, dist));
    }
    var hidden = 0u;
    for (var k = 0u; k < FOOTPRINT_SIDE * FOOTPRINT_SIDE; k = k + 1u) {
        let cell = vec2<f32>(f32(k % FOOTPRINT_SIDE), f32(k / FOOTPRINT_SIDE));
        let q = footprint_point(vec2<f32>(pixel) + (cell + vec2<f32>(0.5)) / f32(FOOTPRINT_SIDE), p, n, has_n);
        let toward_q = toward_light_from(q, position, distant);
        if live_blocks(q, toward_q.xyz, toward_q.w) {
            hidden += 1u;
        }
    }
    return f32(hidden) / f32(FOOTPRINT_SIDE * FOOTPRINT_SIDE);
}

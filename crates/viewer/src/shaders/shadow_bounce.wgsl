// The light the live objects' shadows take from the rest of the scene: the second bounce of
// the shadow (appended to composite.wgsl: compositor/mod.rs COMPOSITE_WGSL; the bindings and
// helpers are composite.wgsl's, shadows.wgsl's and bounce.wgsl's).
//
// Differential rendering removes from each receiver x
// `albedo(x) / pi * integral over its hemisphere of dL(y(w)) cos_x dw`, dL(y) the outgoing
// radiance the surface y seen along w lost to the shadows. For a Lambertian y that is what the
// shadow pass took from y's pixel (the image less the backdrop after shadows: the occluded share
// of each light's layer and the occlusion of indirect light near contact), so the backdrop's
// pixels within the shadows' scissor are a "negative emitter". They are summed into
// SHADOW_BOUNCE_FINE^2 clusters (flux, area, loss-weighted position and normal per tile of that
// scissor) and those into SHADOW_BOUNCE_COARSE^2 (fs_shadow_bounce_clusters). Each receiver sums
// the coarse clusters' (the fine ones' near it) form factors `cos_x cos_y A / (pi d^2 + A)` (a
// disc of the cluster's area seen from x, finite at d = 0) times their loss flux
// (fs_shadow_bounce_taken, into a full-frame texture drawn only when the frame's uniform or a
// live mesh's changed); fs_shadow_bounce removes it every frame. Between receiver and cluster
// only the live spheres are tested (they hide part of the shadow from the surfaces above it),
// not the scene: a surface the scene hides from the shadow loses light too. Only surfaces the
// camera sees in the render are emitters.

// Clusters along each side of the shadows' scissor: fine ones (tiles of the scissor) and coarse
// ones (4x4 fine ones each).
const SHADOW_BOUNCE_FINE: u32 = 64u;
const SHADOW_BOUNCE_COARSE: u32 = 16u;
// A receiver nearer a coarse cluster than 4 times the square root of its area sums its 16 fine
// clusters instead (the point a cluster is summed into stands for it poorly up close).
const SHADOW_BOUNCE_REFINE: f32 = 16.0;
// A receiver losing at most this share of its own value (each channel) keeps its value bit
// for bit: such a change is far below the renderer's noise.
const SHADOW_BOUNCE_NEGLIGIBLE: f32 = 0.0009765625;

// The clusters: fine ones in rows [0, FINE), coarse ones in rows [FINE, FINE + COARSE). Per
// cluster, at column x of its grid: loss flux (rgb, the image's units times camera-space area)
// and the area of its losing pixels; at x + side: loss-weighted mean position and the weight
// (loss times area, summed); at x + 2 side: loss-weighted mean normal (camera space, not
// renormalised).
@group(0) @binding(16) var shadow_bounce_clusters: texture_2d<f32>;
// Per pixel: what it loses (fs_shadow_bounce_taken), zero where nothing.
@group(0) @binding(17) var shadow_bounce_taken: texture_2d<f32>;

// The shadows' scissor the clusters tile: x, y, width, height in pixels.
fn shadow_bounce_rect() -> vec4<u32> {
    let origin = frame.shadow_bounce.y;
    let size = frame.shadow_bounce.z;
    return vec4<u32>(origin & 0xffffu, origin >> 16u, size & 0xffffu, size >> 16u);
}

// The camera-space area of the surface seen through pixel `pixel` at distance r along the
// unit ray `direction`, with unit normal n: the pixel's footprint on the image plane at unit
// distance, times r^2 cos^3 of the ray's angle to the axis, over the surface's obliquity
// (taken at least 0.05, so that a grazing surface's area stays bounded).
fn pixel_area(direction: vec3<f32>, r: f32, n: vec3<f32>) -> f32 {
    let sw = frame.screen_window;
    let footprint = (sw.y - sw.x) / frame.raster.x * (sw.w - sw.z) / frame.raster.y;
    let obliquity = max(abs(dot(n, direction)), 0.05);
    if frame.raster.w > 0.5 {
        let t = frame.raster.z;
        let cos_axis = direction.z;
        return footprint * t * t * r * r * cos_axis * cos_axis * cos_axis / obliquity;
    }
    return footprint / obliquity;
}

// A fine cluster's three texels (see the texture), drawn at once into three targets
// (compositor/shadow_bounce.rs copies them into the clusters' rows): summing each tile once
// instead of once per part.
struct FineCluster {
    @location(0) flux_area: vec4<f32>,
    @location(1) position_weight: vec4<f32>,
    @location(2) normal: vec4<f32>,
}

// The sums over a fine cluster's tile of the shadows' scissor (see the texture).
fn fine_cluster(cell: vec2<u32>) -> FineCluster {
    let rect = shadow_bounce_rect();
    let lo = rect.xy + rect.zw * cell / SHADOW_BOUNCE_FINE;
    let hi = rect.xy + rect.zw * (cell + vec2<u32>(1u)) / SHADOW_BOUNCE_FINE;
    var flux = vec3<f32>(0.0);
    var area = 0.0;
    var weight = 0.0;
    var position_sum = vec3<f32>(0.0);
    var normal_sum = vec3<f32>(0.0);
    for (var y = lo.y; y < hi.y; y = y + 1u) {
        for (var x = lo.x; x < hi.x; x = x + 1u) {
            let pixel = vec2<i32>(i32(x), i32(y));
            let loss = max(
                textureLoad(backdrop_colour, pixel, 0).rgb - textureLoad(backdrop_shadowed, pixel, 0).rgb,
                vec3<f32>(0.0),
            );
            let level = loss.r + loss.g + loss.b;
            if level <= 0.0 {
                continue;
            }
            let r = textureLoad(backdrop_radial_depth, pixel, 0).r;
            let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
            if r >= 3.0e38 || dot(n_raw, n_raw) <= 1e-12 {
                continue;
            }
            let ray = ray_through_raster(vec2<f32>(pixel) + vec2<f32>(0.5));
            let n = normalize(n_raw);
            let a = pixel_area(ray.direction, r, n);
            flux += loss * a;
            area += a;
            weight += level * a;
            position_sum += (ray.origin + r * ray.direction) * (level * a);
            normal_sum += n * (level * a);
        }
    }
    if weight <= 0.0 {
        return FineCluster(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    }
    return FineCluster(
        vec4<f32>(flux, area),
        vec4<f32>(position_sum / weight, weight),
        vec4<f32>(normal_sum / weight, 0.0),
    );
}

// The sums over a coarse cluster's 4x4 fine clusters (read from the copy of the fine rows).
fn coarse_cluster(part: u32, cell: vec2<u32>) -> vec4<f32> {
    let side = i32(SHADOW_BOUNCE_FINE);
    var flux_area = vec4<f32>(0.0);
    var weight = 0.0;
    var position_sum = vec3<f32>(0.0);
    var normal_sum = vec3<f32>(0.0);
    for (var k = 0; k < 16; k = k + 1) {
        let at = vec2<i32>(cell * 4u) + vec2<i32>(k % 4, k / 4);
        let fine = textureLoad(shadow_bounce_clusters, at, 0);
        if fine.w <= 0.0 {
            continue;
        }
        let position_weight = textureLoad(shadow_bounce_clusters, at + vec2<i32>(side, 0), 0);
        let w = position_weight.w;
        flux_area += fine;
        weight += w;
        position_sum += position_weight.xyz * w;
        normal_sum += textureLoad(shadow_bounce_clusters, at + vec2<i32>(2 * side, 0), 0).xyz * w;
    }
    if weight <= 0.0 {
        return vec4<f32>(0.0);
    }
    if part == 0u {
        return flux_area;
    }
    if part == 1u {
        return vec4<f32>(position_sum / weight, weight);
    }
    return vec4<f32>(normal_sum / weight, 0.0);
}

// The three texels of the fine cluster at the texel drawn (a FINE x FINE target each).
@fragment
fn fs_shadow_bounce_fine_clusters(@builtin(position) position: vec4<f32>) -> FineCluster {
    return fine_cluster(vec2<u32>(position.xy));
}

// One texel of the coarse rows (see the texture), from the fine ones (drawn in a second pass,
// after the fine rows were copied).
@fragment
fn fs_shadow_bounce_coarse_clusters(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let texel = vec2<u32>(position.xy);
    let cell = vec2<u32>(texel.x % SHADOW_BOUNCE_COARSE, texel.y - SHADOW_BOUNCE_FINE);
    return coarse_cluster(texel.x / SHADOW_BOUNCE_COARSE, cell);
}

// What the cluster at `at` (its parts `side` texels apart) takes from the surface at p with
// unit normal n per unit albedo: its loss flux times `cos_x cos_y / (pi d^2 + A)`.
fn cluster_loss(p: vec3<f32>, n: vec3<f32>, at: vec2<i32>, side: i32, flux_area: vec4<f32>) -> vec3<f32> {
    let v = textureLoad(shadow_bounce_clusters, at + vec2<i32>(side, 0), 0).xyz - p;
    let d2 = dot(v, v);
    let cos_x = dot(n, v);
    if cos_x <= 0.0 || d2 <= 0.0 {
        return vec3<f32>(0.0);
    }
    let m = textureLoad(shadow_bounce_clusters, at + vec2<i32>(2 * side, 0), 0).xyz;
    let cos_y = -dot(m, v) * inverseSqrt(max(dot(m, m), 1e-30));
    if cos_y <= 0.0 {
        return vec3<f32>(0.0);
    }
    // Where a live sphere stands between them, the surface did not see the cluster's light
    // with the sphere there (the occlusion of indirect light already took what the sphere
    // hides); the scene's own surfaces are not tested.
    let d = sqrt(d2);
    if sphere_blocks(p, v / d, d) {
        return vec3<f32>(0.0);
    }
    // Both cosines carry a factor d: d2 * d2 below is (d^2) * (pi d^2 + A) over d^2.
    return flux_area.rgb * (cos_x * cos_y / (d2 * (PI * d2 + flux_area.w)));
}

// Whether a live sphere comes within `extent` of the segment from p to q: it may then hide part
// of a cluster of that size at q and not the rest, which its fine clusters resolve.
fn sphere_near_segment(p: vec3<f32>, q: vec3<f32>, extent: f32) -> bool {
    let along = q - p;
    let length2 = max(dot(along, along), 1e-30);
    for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
        let sphere = frame.shadow_spheres[i];
        let t = clamp(dot(sphere.xyz - p, along) / length2, 0.0, 1.0);
        let gap = sphere.xyz - (p + t * along);
        let reach = sphere.w + extent;
        if dot(gap, gap) < reach * reach {
            return true;
        }
    }
    return false;
}

// The radiance per unit albedo the surface at p (camera space, unit normal n) no longer
// receives from the shadowed surfaces, in the image's units: the coarse clusters' losses, or
// their fine clusters' where p is near or a live sphere may hide part of the coarse one.
fn shadow_bounce_loss(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let coarse_side = i32(SHADOW_BOUNCE_COARSE);
    let fine_side = i32(SHADOW_BOUNCE_FINE);
    for (var k = 0; k < coarse_side * coarse_side; k = k + 1) {
        let cell = vec2<i32>(k % coarse_side, k / coarse_side);
        let at = cell + vec2<i32>(0, fine_side);
        let flux_area = textureLoad(shadow_bounce_clusters, at, 0);
        if flux_area.w <= 0.0 {
            continue;
        }
        let q = textureLoad(shadow_bounce_clusters, at + vec2<i32>(coarse_side, 0), 0).xyz;
        let d2 = dot(q - p, q - p);
        if d2 >= SHADOW_BOUNCE_REFINE * flux_area.w && !sphere_near_segment(p, q, sqrt(flux_area.w)) {
            sum += cluster_loss(p, n, at, coarse_side, flux_area);
            continue;
        }
        for (var f = 0; f < 16; f = f + 1) {
            let fine_at = cell * 4 + vec2<i32>(f % 4, f / 4);
            let fine = textureLoad(shadow_bounce_clusters, fine_at, 0);
            if fine.w > 0.0 {
                sum += cluster_loss(p, n, fine_at, fine_side, fine);
            }
        }
    }
    return sum;
}

// What this pixel loses (rgb, the image's units; a target cleared to zero, drawn only when the
// frame's uniform or a live mesh's changed): the light the shadows took from the surfaces it
// sees, from the sidecar's albedo and normal layers. Pixels that would lose a negligible share of
// the backdrop after shadows (and bounce light) are left at zero.
@fragment
fn fs_shadow_bounce_taken(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let r = receiver_at(pixel, i32(frame.shadow_bounce.w));
    if !r.valid {
        discard;
    }
    let taken = r.albedo * shadow_bounce_loss(r.p, r.n);
    let before = textureLoad(backdrop_shadowed, pixel, 0).rgb;
    if all(taken <= before * SHADOW_BOUNCE_NEGLIGIBLE) {
        discard;
    }
    return vec4<f32>(taken, 1.0);
}

// The frame so far (the backdrop after shadows and bounce light) less what the pixel loses,
// never below zero. Pixels that lose nothing keep their value bit for bit.
@fragment
fn fs_shadow_bounce(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let taken = textureLoad(shadow_bounce_taken, pixel, 0).rgb;
    if all(taken == vec3<f32>(0.0)) {
        discard;
    }
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    return vec4<f32>(max(before.rgb - taken, vec3<f32>(0.0)), before.a);
}

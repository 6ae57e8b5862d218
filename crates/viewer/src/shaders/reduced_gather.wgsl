// While live objects move (compositor/reduced_gather.rs): the layered shadows, the bounce light
// and the shadows' second bounce gathered at one pixel of each square block of pixels and
// spread to the others (appended to composite.wgsl after shadows.wgsl, bounce.wgsl and
// shadow_bounce.wgsl, whose functions it calls). The two bounces are a receiver's albedo times a
// function of its surface point and normal that varies smoothly along a surface, so the function
// is interpolated between the four nearest samples that lie on the receiver's own surface and
// multiplied by the receiver's own albedo; the shadows are, in the same way, the shares of the
// area lights (and of the indirect light) they hide, applied to the pixel's own layers. A pixel with no such sample (a sliver of surface thinner than
// a block) takes the sample whose normal is nearest its own. (Gathering its own instead cost as
// much as the whole pass on lavapipe, which runs a branch for every pixel of a block when one
// pixel takes it.)

// Pixels along each side of a block: the bounce light's (compositor/reduced_gather.rs
// BOUNCE_STRIDE) and the second bounce's loss (LOSS_STRIDE: a smaller term, drawn over the frame).
const REDUCED_BOUNCE_STRIDE: i32 = 8;
const REDUCED_LOSS_STRIDE: i32 = 32;
// The layered shadows' (compositor/reduced_gather.rs SHADOW_STRIDE).
const REDUCED_SHADOW_STRIDE: i32 = 4;
// A sample lies on the receiver's surface when their normals are within about 25 degrees and
// the sample is within this share of its distance from the receiver off the receiver's plane.
const REDUCED_SAME_NORMAL: f32 = 0.9;
const REDUCED_SAME_PLANE: f32 = 0.05;

// Per texel of the grid of samples: the gathered function (rgb), and in alpha 1 where the
// sample's pixel is a receiver, 0 where there is no sample.
@group(0) @binding(22) var reduced_gather: texture_2d<f32>;

// The pixel sample `q` of a grid of blocks of `stride` pixels stands for: its block's centre.
fn reduced_sample_pixel(q: vec2<i32>, stride: i32) -> vec2<i32> {
    let size = vec2<i32>(frame.raster.xy);
    return min(q * stride + vec2<i32>(stride / 2), size - vec2<i32>(1));
}

// One sample of the bounce light per unit albedo times pi (bounce_irradiance) at the pixel its
// grid texel stands for.
@fragment
fn fs_bounce_gather(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = reduced_sample_pixel(vec2<i32>(position.xy), REDUCED_BOUNCE_STRIDE);
    let r = receiver_at(pixel, i32(frame.bounce.y));
    if !r.valid {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(bounce_irradiance(r.p, r.n), 1.0);
}

// One sample of what the shadows' second bounce takes per unit albedo (shadow_bounce_loss).
@fragment
fn fs_loss_gather(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = reduced_sample_pixel(vec2<i32>(position.xy), REDUCED_LOSS_STRIDE);
    let r = receiver_at(pixel, i32(frame.shadow_bounce.w));
    if !r.valid {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(shadow_bounce_loss(r.p, r.n), 1.0);
}

// The gathered function at `pixel` (receiver `r`): bilinear between the four nearest samples of
// the grid of `stride` (all four channels), over those on the receiver's surface
// (renormalised), else the one of them whose normal is nearest the receiver's; zero when none
// of them is a receiver (alpha below 0.5).
fn spread(pixel: vec2<i32>, r: Receiver, stride: i32) -> vec4<f32> {
    let size = vec2<i32>(frame.raster.xy);
    let grid = (size + vec2<i32>(stride - 1)) / stride;
    let at = (vec2<f32>(pixel) - f32(stride / 2)) / f32(stride);
    let base = vec2<i32>(floor(at));
    let f = at - floor(at);
    var sum = vec4<f32>(0.0);
    var weight = 0.0;
    var nearest = vec4<f32>(0.0);
    var nearest_cos = -2.0;
    for (var k = 0; k < 4; k = k + 1) {
        let corner = vec2<i32>(k & 1, k >> 1u);
        let q = base + corner;
        if any(q < vec2<i32>(0)) || any(q >= grid) {
            continue;
        }
        let sample = textureLoad(reduced_gather, q, 0);
        if sample.a < 0.5 {
            continue;
        }
        let sample_pixel = reduced_sample_pixel(q, stride);
        let apart = surface_point(sample_pixel).xyz - r.p;
        let n = normalize(textureLoad(light_layers, sample_pixel, i32(frame.layer_info.z), 0).xyz);
        if dot(n, r.n) > nearest_cos {
            nearest_cos = dot(n, r.n);
            nearest = sample;
        }
        if dot(n, r.n) < REDUCED_SAME_NORMAL || abs(dot(apart, r.n)) > REDUCED_SAME_PLANE * length(apart) {
            continue;
        }
        let w = select(1.0 - f.x, f.x, corner.x == 1) * select(1.0 - f.y, f.y, corner.y == 1);
        sum += w * sample;
        weight += w;
    }
    return select(nearest, sum / max(weight, 1e-30), weight > 0.0);
}

// fs_bounce with the bounce light spread from the grid, without the light a sphere hides taken
// from behind it (bounce.wgsl with_bounce_light_alone).
@fragment
fn fs_bounce_spread(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let r = receiver_at(pixel, i32(frame.bounce.y));
    if !r.valid {
        discard;
    }
    return with_bounce_light_alone(pixel, r, spread(pixel, r, REDUCED_BOUNCE_STRIDE).rgb);
}

// fs_bounce_spread with the light a sphere hides taken from behind it, found per pixel
// (`occlusion_from_behind`).
@fragment
fn fs_bounce_spread_from_behind(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let r = receiver_at(pixel, i32(frame.bounce.y));
    if !r.valid {
        discard;
    }
    return with_bounce_light(pixel, r, spread(pixel, r, REDUCED_BOUNCE_STRIDE).rgb);
}

// fs_shadow_bounce_taken with the loss spread from the grid.
@fragment
fn fs_loss_spread(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let r = receiver_at(pixel, i32(frame.shadow_bounce.w));
    if !r.valid {
        discard;
    }
    let taken = r.albedo * spread(pixel, r, REDUCED_LOSS_STRIDE).rgb;
    let before = textureLoad(backdrop_shadowed, pixel, 0).rgb;
    if all(taken <= before * SHADOW_BOUNCE_NEGLIGIBLE) {
        discard;
    }
    return vec4<f32>(taken, 1.0);
}

// The most area lights whose layered shadows a moving frame gathers at reduced resolution
// (compositor/reduced_gather.rs SHADOW_LIGHTS: it draws the shadows at full resolution when
// there are more, or when a light with a layer is no area light, or when layers hold several
// lights). Area lights' shadows are soft and smooth along a surface; hard shadows' edges would
// be spread over a block. (Finding a hard light's share per pixel in the spreading pass cost as
// much as the whole pass on lavapipe, even where no pixel needed it.)
const REDUCED_SHADOW_LIGHTS: u32 = 3u;

// Whether light i's shadows are gathered at reduced resolution: an area light with a layer.
fn reduced_shadow_soft(i: u32) -> bool {
    return frame.shadow_slots[i].x != NO_LAYER && u32(frame.lights[i].position.w + 0.5) == LIGHT_AREA;
}

// One sample of the layered shadows: the share of each area light's direct light the live
// objects hide (hidden_share), up to three (rgb), and 1 plus the spheres' occlusion of
// indirect light (a); zero where the sample's pixel has no surface. Shares, not the light
// removed: the pixel's own layers, which hold the photon map's noise and the textures, give
// that back exactly.
@fragment
fn fs_shadow_gather(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = reduced_sample_pixel(vec2<i32>(position.xy), REDUCED_SHADOW_STRIDE);
    let centre = surface_point(pixel);
    if centre.w < 0.5 {
        return vec4<f32>(0.0);
    }
    let n = layer_normal(pixel);
    var shares = array<f32, REDUCED_SHADOW_LIGHTS>();
    var k = 0u;
    for (var i = 0u; i < frame.counts.x && k < REDUCED_SHADOW_LIGHTS; i = i + 1u) {
        if reduced_shadow_soft(i) {
            shares[k] = hidden_share(i, pixel, centre.xyz, n).x;
            k += 1u;
        }
    }
    return vec4<f32>(shares[0], shares[1], shares[2], 1.0 + indirect_occlusion(centre.xyz, n));
}

// fs_shadow's layered shadows with the area lights' hidden shares and the occlusion spread from
// the grid and applied to the pixel's own layers; pixels they take nothing from are discarded
// and keep their value bit for bit. A pixel without a normal in the layers takes the nearest
// sample's.
@fragment
fn fs_shadow_spread(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let centre = surface_point(pixel);
    if centre.w < 0.5 {
        discard;
    }
    var r: Receiver;
    r.p = centre.xyz;
    r.n = layer_normal(pixel);
    r.valid = true;
    let shadow = spread(pixel, r, REDUCED_SHADOW_STRIDE);
    let shares = array<f32, REDUCED_SHADOW_LIGHTS>(shadow.r, shadow.g, shadow.b);
    var removed = max(shadow.a - 1.0, 0.0) * occludable_indirect(pixel);
    var k = 0u;
    for (var i = 0u; i < frame.counts.x; i = i + 1u) {
        let slice = frame.shadow_slots[i].x;
        if slice == NO_LAYER {
            continue;
        }
        // (Only area lights have layers here: compositor/reduced_gather.rs shadows_fit.)
        if !reduced_shadow_soft(i) || k >= REDUCED_SHADOW_LIGHTS {
            continue;
        }
        if shares[k] > 0.0 {
            removed += shares[k] * textureLoad(light_layers, pixel, i32(slice), 0).rgb;
        }
        k += 1u;
    }
    removed *= frame.tone.x;
    if all(removed <= vec3<f32>(0.0)) {
        discard;
    }
    let before = textureLoad(backdrop_colour, pixel, 0);
    return vec4<f32>(max(before.rgb - removed, vec3<f32>(0.0)), before.a);
}

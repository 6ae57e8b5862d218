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
// The live spheres seen in glossy lobes (GLOSSY_STRIDE), spread with the layered shadows'
// weights, whose stride it is.
const REDUCED_GLOSSY_STRIDE: i32 = 4;
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

// Which sample a spreading pass reads, and so which layer of the spreading weights it takes
// (compositor/reduced_gather.rs SpreadWeights).
const REDUCED_SPREAD_SHADOWS: i32 = 0;
const REDUCED_SPREAD_BOUNCE: i32 = 1;
const REDUCED_SPREAD_LOSS: i32 = 2;

// Per pixel, a layer for each of the three strides (REDUCED_SPREAD_*): the
// weight of each of the four nearest samples (x: the one below and left, y: below and right,
// z: above and left, w: above and right), which sum to 1, or all zero where the pixel takes
// nothing. They depend on the pre-rendered surfaces alone, so they are drawn once
// (fs_spread_weights_*), and a moving frame's spreading passes read them instead of comparing
// each pixel's surface with its four samples' again.
@group(0) @binding(34) var reduced_weights: texture_2d_array<f32>;

// Whether the sample `q` of the grid of `stride` holds a value: its pixel is a receiver of the
// spread `which` (as fs_bounce_gather, fs_loss_gather and fs_shadow_gather find it).
fn reduced_sample_valid(q: vec2<i32>, stride: i32, which: i32) -> bool {
    let pixel = reduced_sample_pixel(q, stride);
    if which == REDUCED_SPREAD_BOUNCE {
        return receiver_at(pixel, i32(frame.bounce.y)).valid;
    }
    if which == REDUCED_SPREAD_LOSS {
        return receiver_at(pixel, i32(frame.shadow_bounce.w)).valid;
    }
    return surface_point(pixel).w >= 0.5;
}

// The weights of the four samples nearest `pixel` (receiver `r`) of the grid of `stride`:
// bilinear over those that hold a value and lie on the receiver's surface (renormalised), else
// all on the one of them whose normal is nearest the receiver's; zero when none holds a value.
fn spread_weights(pixel: vec2<i32>, r: Receiver, stride: i32, which: i32) -> vec4<f32> {
    let size = vec2<i32>(frame.raster.xy);
    let grid = (size + vec2<i32>(stride - 1)) / stride;
    let at = (vec2<f32>(pixel) - f32(stride / 2)) / f32(stride);
    let base = vec2<i32>(floor(at));
    let f = at - floor(at);
    var weights = vec4<f32>(0.0);
    var weight = 0.0;
    var nearest = vec4<f32>(0.0);
    var nearest_cos = -2.0;
    for (var k = 0; k < 4; k = k + 1) {
        let corner = vec2<i32>(k & 1, k >> 1u);
        let q = base + corner;
        if any(q < vec2<i32>(0)) || any(q >= grid) {
            continue;
        }
        if !reduced_sample_valid(q, stride, which) {
            continue;
        }
        let one = select(vec4<f32>(0.0), vec4<f32>(1.0), vec4<i32>(0, 1, 2, 3) == vec4<i32>(k));
        let sample_pixel = reduced_sample_pixel(q, stride);
        let apart = surface_point(sample_pixel).xyz - r.p;
        let n = normalize(textureLoad(light_layers, sample_pixel, i32(frame.layer_info.z), 0).xyz);
        if dot(n, r.n) > nearest_cos {
            nearest_cos = dot(n, r.n);
            nearest = one;
        }
        if dot(n, r.n) < REDUCED_SAME_NORMAL || abs(dot(apart, r.n)) > REDUCED_SAME_PLANE * length(apart) {
            continue;
        }
        let w = select(1.0 - f.x, f.x, corner.x == 1) * select(1.0 - f.y, f.y, corner.y == 1);
        weights += w * one;
        weight += w;
    }
    return select(nearest, weights / max(weight, 1e-30), weight > 0.0);
}

// The spreading weights of the layer `which` at `pixel` (its stride's), summing to 1, or zero
// where the pixel takes nothing.
fn reduced_weights_at(pixel: vec2<i32>, which: i32) -> vec4<f32> {
    let w = textureLoad(reduced_weights, pixel, which, 0);
    let total = w.x + w.y + w.z + w.w;
    return select(vec4<f32>(0.0), w / total, total > 0.0);
}

// The gathered function at `pixel` (all four channels): its samples of the grid of `stride`
// times their spreading `weights` (reduced_weights_at).
fn spread(pixel: vec2<i32>, weights: vec4<f32>, stride: i32) -> vec4<f32> {
    let size = vec2<i32>(frame.raster.xy);
    let last = (size + vec2<i32>(stride - 1)) / stride - vec2<i32>(1);
    let base = vec2<i32>(floor((vec2<f32>(pixel) - f32(stride / 2)) / f32(stride)));
    // A sample outside the grid has no weight; the clamps keep its load inside.
    let lo = clamp(base, vec2<i32>(0), last);
    let hi = clamp(base + vec2<i32>(1), vec2<i32>(0), last);
    return weights.x * textureLoad(reduced_gather, lo, 0)
        + weights.y * textureLoad(reduced_gather, vec2<i32>(hi.x, lo.y), 0)
        + weights.z * textureLoad(reduced_gather, vec2<i32>(lo.x, hi.y), 0)
        + weights.w * textureLoad(reduced_gather, hi, 0);
}

// The spreading weights of the layered shadows (REDUCED_SPREAD_SHADOWS), drawn once: a pixel
// with a surface point takes them, with the layers' normal (zero where they hold none).
@fragment
fn fs_spread_weights_shadows(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let centre = surface_point(pixel);
    if centre.w < 0.5 {
        return vec4<f32>(0.0);
    }
    var r: Receiver;
    r.p = centre.xyz;
    r.n = layer_normal(pixel);
    r.valid = true;
    return spread_weights(pixel, r, REDUCED_SHADOW_STRIDE, REDUCED_SPREAD_SHADOWS);
}

// The spreading weights of the bounce light (REDUCED_SPREAD_BOUNCE), drawn once.
@fragment
fn fs_spread_weights_bounce(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let r = receiver_at(pixel, i32(frame.bounce.y));
    if !r.valid {
        return vec4<f32>(0.0);
    }
    return spread_weights(pixel, r, REDUCED_BOUNCE_STRIDE, REDUCED_SPREAD_BOUNCE);
}

// The spreading weights of the second bounce's loss (REDUCED_SPREAD_LOSS), drawn once.
@fragment
fn fs_spread_weights_loss(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let r = receiver_at(pixel, i32(frame.shadow_bounce.w));
    if !r.valid {
        return vec4<f32>(0.0);
    }
    return spread_weights(pixel, r, REDUCED_LOSS_STRIDE, REDUCED_SPREAD_LOSS);
}

// fs_bounce with the bounce light spread from the grid, without the light a sphere hides taken
// from behind it (bounce.wgsl with_bounce_light_alone, which reads the receiver's albedo alone).
@fragment
fn fs_bounce_spread(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let weights = reduced_weights_at(pixel, REDUCED_SPREAD_BOUNCE);
    if all(weights == vec4<f32>(0.0)) {
        discard;
    }
    var r: Receiver;
    r.albedo = textureLoad(light_layers, pixel, i32(frame.bounce.y), 0).rgb;
    return with_bounce_light_alone(pixel, r, spread(pixel, weights, REDUCED_BOUNCE_STRIDE).rgb);
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
    let weights = reduced_weights_at(pixel, REDUCED_SPREAD_BOUNCE);
    return with_bounce_light(pixel, r, spread(pixel, weights, REDUCED_BOUNCE_STRIDE).rgb);
}

// fs_shadow_bounce_taken with the loss spread from the grid.
@fragment
fn fs_loss_spread(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let weights = reduced_weights_at(pixel, REDUCED_SPREAD_LOSS);
    if all(weights == vec4<f32>(0.0)) {
        discard;
    }
    let albedo = textureLoad(light_layers, pixel, i32(frame.shadow_bounce.w), 0).rgb;
    let taken = albedo * spread(pixel, weights, REDUCED_LOSS_STRIDE).rgb;
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
    let weights = reduced_weights_at(pixel, REDUCED_SPREAD_SHADOWS);
    if all(weights == vec4<f32>(0.0)) {
        discard;
    }
    let shadow = spread(pixel, weights, REDUCED_SHADOW_STRIDE);
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

// One sample of what the live spheres change in the glossy lobe of the pixel its grid texel
// stands for (specular.wgsl glossy_change, per unit Ks): drawn once per sphere, each draw adding
// its sphere's change to the draws' before it (read from the grid's copy), as fs_glossy's draws
// add theirs at full resolution; alpha 1 where a draw changed the sample.
@fragment
fn fs_glossy_gather(in: ReflectionOut) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(in.position.xy);
    let change = glossy_change(reduced_sample_pixel(texel, REDUCED_GLOSSY_STRIDE), in.row, true);
    return glossy_gathered(texel, in.row, change);
}

// fs_glossy_gather where the frame draws the spheres' radiosity maps (the bounce light on): the
// spheres in the lobe shaded from their maps (glossy_change_from_maps).
@fragment
fn fs_glossy_gather_from_maps(in: ReflectionOut) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(in.position.xy);
    let change = glossy_change_from_maps(reduced_sample_pixel(texel, REDUCED_GLOSSY_STRIDE), in.row);
    return glossy_gathered(texel, in.row, change);
}

// Draw `row`'s change at grid texel `texel` added to what the draws before it left there.
fn glossy_gathered(texel: vec2<i32>, row: u32, change: vec4<f32>) -> vec4<f32> {
    var before = vec4<f32>(0.0);
    if row > 0u {
        before = textureLoad(reduced_gather, texel, 0);
    }
    return vec4<f32>(before.rgb + change.rgb, max(before.a, change.w));
}

// fs_glossy with the spheres' change spread from the grid (the layered shadows' weights: the
// four nearest samples on the pixel's own surface) and scaled by the pixel's own Ks; pixels
// without a lobe, or whose samples changed nothing, are discarded and keep their value.
@fragment
fn fs_glossy_spread(in: ReflectionOut) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    if frame.reflection.x != 1u || frame.reflection.w == NO_LAYER {
        discard;
    }
    let ks = textureLoad(light_layers, pixel, i32(frame.reflection.w), 0).rgb;
    let weights = reduced_weights_at(pixel, REDUCED_SPREAD_SHADOWS);
    if all(ks <= vec3<f32>(0.0)) || all(weights == vec4<f32>(0.0)) {
        discard;
    }
    let change = spread(pixel, weights, REDUCED_GLOSSY_STRIDE);
    if change.a <= 0.0 {
        discard;
    }
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    return vec4<f32>(max(before.rgb + change.rgb * (ks / f32(GLOSSY_TRACED)), vec3<f32>(0.0)), before.a);
}

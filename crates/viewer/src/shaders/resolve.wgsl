// Live objects' samples filtered into the frame with the image's pixel filter
// (compositor/antialias.rs). A pixel that no live sample reaches keeps the centre-sampled
// frame's value bit for bit. Elsewhere every sample within the filter's reach counts with the
// filter's weight: a live sample with its colour, any other with the pixel's own backdrop after
// shadows (what the scene shows there without the live object), so that an edge pixel blends
// the two by the share of the filter the live object covers, as in the ray tracer's image.
// Samples of a pixel whose centre is live take the centre frame's colour; those of its samples
// that a nearer pre-rendered surface hides take the colour of the neighbour that shows it.

struct Resolve {
    // The filter's kind (pixel_filter.rs FilterKind::code), reach in pixels along x and y.
    kind_reach: vec4<u32>,
    // The filter's full widths in pixels.
    widths: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> resolve: Resolve;
@group(0) @binding(1) var centre_frame: texture_2d<f32>;
@group(0) @binding(2) var backdrop_shadowed: texture_2d<f32>;
@group(0) @binding(3) var live_samples: texture_multisampled_2d<f32>;
@group(0) @binding(4) var centre_mask: texture_2d<f32>;

const PI: f32 = 3.14159265358979;

fn sinc_windowed(v: f32, width: f32) -> f32 {
    if v == 0.0 {
        return 1.0;
    }
    let a = v * PI;
    return cos(0.5 * a / width) * sin(a) / a;
}

// pixel_filter::PixelFilter::weight.
fn filter_weight(x: f32, y: f32) -> f32 {
    let rx = resolve.widths.x * 0.5;
    let ry = resolve.widths.y * 0.5;
    if !(x >= -rx && x < rx && y >= -ry && y < ry) {
        return 0.0;
    }
    switch resolve.kind_reach.x {
        case 0u: {
            return 1.0;
        }
        case 1u: {
            return max(1.0 - abs(x) / rx, 0.0) * max(1.0 - abs(y) / ry, 0.0);
        }
        case 2u: {
            let xs = x * 2.0 / resolve.widths.x;
            let ys = y * 2.0 / resolve.widths.y;
            return exp(-2.0 * (xs * xs + ys * ys));
        }
        case 3u: {
            let r2 = x * x + y * y;
            let r = sqrt(r2);
            if r >= 2.0 {
                return 0.0;
            }
            if r < 1.0 {
                return 3.0 * r * r2 - 5.0 * r2 + 2.0;
            }
            return -r * r2 + 5.0 * r2 - 8.0 * r + 4.0;
        }
        default: {
            return sinc_windowed(x, resolve.widths.x) * sinc_windowed(y, resolve.widths.y);
        }
    }
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(index & 1u) * 4 - 1);
    let y = f32(i32(index >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.5, 1.0);
}

@fragment
fn fs_resolve(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    // The standard 4x sample positions from a pixel's top-left corner
    // (pixel_filter::SAMPLE_POSITIONS, live_coverage.wgsl).
    var positions = array<vec2<f32>, 4>(
        vec2<f32>(0.375, 0.125), vec2<f32>(0.875, 0.375), vec2<f32>(0.125, 0.625), vec2<f32>(0.625, 0.875),
    );
    let pixel = vec2<i32>(position.xy);
    let centre = textureLoad(centre_frame, pixel, 0);
    let size = vec2<i32>(textureDimensions(centre_frame));
    let reach = vec2<i32>(resolve.kind_reach.yz);
    var total = 0.0;
    var live_weight = 0.0;
    var live = vec3<f32>(0.0);
    var any_live = false;
    // Samples where a pre-rendered surface hides a live object whose centre sample it does not.
    var hidden_weight = 0.0;
    var in_front = vec3<f32>(0.0);
    for (var dy = -reach.y; dy <= reach.y; dy = dy + 1) {
        for (var dx = -reach.x; dx <= reach.x; dx = dx + 1) {
            let q = pixel + vec2<i32>(dx, dy);
            if any(q < vec2<i32>(0)) || any(q >= size) {
                continue;
            }
            // A live pixel centre's colour is the centre frame's, shaded in full precision
            // (the samples are half floats, and the sphere leaves them unshaded there).
            let q_live = textureLoad(centre_mask, q, 0).r > 0.5;
            let q_colour = textureLoad(centre_frame, q, 0).rgb;
            // A live centre's covered samples say which of its samples a pre-rendered surface
            // hides, and which neighbour shows that surface (live_coverage.wgsl,
            // centre_live_samples).
            var hidden = 0u;
            var occluder = vec3<f32>(0.0);
            if q_live {
                for (var s = 0u; s < 4u; s = s + 1u) {
                    let sample = textureLoad(live_samples, q, i32(s));
                    if sample.a > 0.5 && sample.b < 0.0 {
                        hidden = u32(sample.r + 0.5);
                        let k = i32(sample.g + 0.5);
                        let o = clamp(q + vec2<i32>(k % 3 - 1, k / 3 - 1), vec2<i32>(0), size - 1);
                        occluder = textureLoad(backdrop_shadowed, o, 0).rgb;
                        break;
                    }
                }
            }
            for (var s = 0u; s < 4u; s = s + 1u) {
                let offset = vec2<f32>(f32(dx), f32(dy)) + positions[s] - vec2<f32>(0.5);
                let w = filter_weight(offset.x, offset.y);
                if w == 0.0 {
                    continue;
                }
                total = total + w;
                let sample = textureLoad(live_samples, q, i32(s));
                if sample.a > 0.5 {
                    any_live = true;
                    live_weight = live_weight + w;
                    live = live + w * select(sample.rgb, q_colour, q_live);
                } else if (hidden & (1u << s)) != 0u {
                    hidden_weight = hidden_weight + w;
                    in_front = in_front + w * occluder;
                }
            }
        }
    }
    if !any_live || abs(total) < 1e-6 {
        return centre;
    }
    let backdrop = textureLoad(backdrop_shadowed, pixel, 0).rgb;
    let rest = (total - live_weight - hidden_weight) / total;
    let colour = (live + in_front) / total + rest * backdrop;
    return vec4<f32>(max(colour, vec3<f32>(0.0)), centre.a);
}

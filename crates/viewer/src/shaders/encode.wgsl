// The display encode pass: linear frame -> 8-bit display frame, as crate::display encodes on
// the CPU (keep the two identical). A pixel still equal to the backdrop's linear value shows
// the backdrop's own display bytes.

struct Encoding {
    // 1 / gamma, 1 if sRGB, dither amplitude in steps, unused.
    parameters: vec4<f32>,
    // Image width, unused x3.
    size: vec4<u32>,
}

@group(0) @binding(0) var<storage, read> encoding: Encoding;
@group(0) @binding(1) var frame_linear: texture_2d<f32>;
@group(0) @binding(2) var backdrop_linear: texture_2d<f32>;
@group(0) @binding(3) var backdrop_display: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(index & 1u) * 4 - 1);
    let y = f32(i32(index >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.5, 1.0);
}

// PCG's output hash (Jarzynski & Olano 2020).
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn dither_noise(pixel: vec2<u32>, channel: u32) -> f32 {
    let index = (pixel.y * encoding.size.x + pixel.x) * 4u + channel;
    return f32(pcg_hash(index) >> 8u) * (1.0 / 16777216.0);
}

fn transfer(v: f32) -> f32 {
    let x = max(v, 0.0);
    var display = x;
    if encoding.parameters.y > 0.5 {
        if x <= 0.0031308 {
            display = 12.92 * x;
        } else {
            display = 1.055 * pow(x, 1.0 / 2.4) - 0.055;
        }
    } else if encoding.parameters.x != 1.0 {
        display = pow(x, encoding.parameters.x);
    }
    return min(display, 1.0);
}

fn encode_channel(v: f32, pixel: vec2<u32>, channel: u32) -> f32 {
    var noise = 0.0;
    if encoding.parameters.z > 0.0 {
        noise = encoding.parameters.z * (2.0 * dither_noise(pixel, channel) - 1.0);
    }
    return clamp(floor(transfer(v) * 255.0 + 0.5 + noise), 0.0, 255.0) / 255.0;
}

@fragment
fn fs_encode(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let v = textureLoad(frame_linear, pixel, 0);
    if all(v == textureLoad(backdrop_linear, pixel, 0)) {
        return textureLoad(backdrop_display, pixel, 0);
    }
    let p = vec2<u32>(pixel);
    return vec4<f32>(
        encode_channel(v.r, p, 0u),
        encode_channel(v.g, p, 1u),
        encode_channel(v.b, p, 2u),
        round(clamp(v.a, 0.0, 1.0) * 255.0) / 255.0,
    );
}

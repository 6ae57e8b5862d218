// Shows the composited frame in the window pixel for pixel (no filtering, no colour-space
// change: both the frame and the surface are unorm formats). Window pixels outside the frame
// are black.

@group(0) @binding(0) var frame_colour: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(index & 1u) * 4 - 1);
    let y = f32(i32(index >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.5, 1.0);
}

@fragment
fn fs_present(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let size = vec2<i32>(textureDimensions(frame_colour));
    let pixel = vec2<i32>(position.xy);
    if pixel.x >= size.x || pixel.y >= size.y {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    return textureLoad(frame_colour, pixel, 0);
}

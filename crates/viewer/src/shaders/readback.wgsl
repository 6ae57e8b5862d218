// Copies a depth texture into a storage buffer, bit for bit. GL backends cannot copy depth
// textures to buffers directly, so every backend goes through this pass. The depth texture is
// bound as an unfilterable float texture: naga's GLSL output cannot `textureLoad` a
// `texture_depth_2d`.

@group(0) @binding(0) var depth_in: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> depth_out: array<u32>;

@compute @workgroup_size(8, 8)
fn cs_copy_depth(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth_in);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    depth_out[id.y * size.x + id.x] = bitcast<u32>(textureLoad(depth_in, vec2<i32>(id.xy), 0).r);
}

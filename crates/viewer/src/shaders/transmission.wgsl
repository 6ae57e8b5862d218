// The live spheres seen through the pre-rendered scene's glass (appended to composite.wgsl:
// compositor/mod.rs COMPOSITE_WGSL; the pass is compositor/transmission.rs). The render's
// transmission layers give, per pixel, the primary hit's transmitted chain (docs/sidecar.md):
// its weight, the radiance its exit ray brought, and the exit ray itself, here in camera space
// (slice 2: origin and the distance to the surface it met; slice 3: unit direction and the
// length of the samples' mean direction). Where the exit ray meets a sphere before that
// surface, the light it brought is hidden and the sphere's own radiance toward the glass, times
// the chain's weight, is seen instead, as fs_reflection does for the mirror direction. One ray
// per pixel, the samples' mean exit ray. Drawn once per sphere (its material bound in group 1,
// its row as the instance): a pixel changes only in the draw of the sphere its ray meets first.

@group(2) @binding(26) var transmission_layers: texture_2d_array<f32>;

// The change in the pixel's transmitted light from the spheres' occlusion of indirect light:
// the shadow pass took it at the glass's surface (shadows.wgsl, layered_shadow, with the
// pixel's whole indirect light), which is given back, and it is taken at the surface the exit
// ray meets instead (the point `distance` along it, its normal taken as facing the ray: the
// layers do not give that surface's normal), as what is seen through the glass, unless a
// sphere hides that surface (`hit`); in the layers' units.
fn transmitted_occlusion(pixel: vec2<i32>, transmitted: vec3<f32>, exit: vec4<f32>, dir: vec3<f32>, hit: bool) -> vec3<f32> {
    let centre = surface_point(pixel);
    if frame.layer_info.x != 1u || frame.counts.y != 1u || centre.w < 0.5 {
        return vec3<f32>(0.0);
    }
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    let n = select(vec3<f32>(0.0), normalize(n_raw), dot(n_raw, n_raw) > 1e-12);
    var seen = 0.0;
    if !hit && exit.w < 1e29 {
        seen = indirect_occlusion(exit.xyz + exit.w * dir, -dir);
    }
    return (indirect_occlusion(centre.xyz, n) - seen) * transmitted;
}

@fragment
fn fs_transmission(in: ReflectionOut) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    let transmittance = textureLoad(transmission_layers, pixel, 0, 0).rgb;
    if all(transmittance <= vec3<f32>(0.0)) {
        discard;
    }
    let transmitted = textureLoad(transmission_layers, pixel, 1, 0).rgb;
    let exit = textureLoad(transmission_layers, pixel, 2, 0);
    let dir = textureLoad(transmission_layers, pixel, 3, 0).xyz;
    // The sphere the exit ray meets first, before the surface the render saw (8: none).
    var row = 8u;
    var nearest = 0.0;
    if dot(dir, dir) > 0.5 {
        let first = first_sphere(exit.xyz, dir);
        if first.x < 8.0 && first.y < exit.w {
            row = u32(first.x);
            nearest = first.y;
        }
    }
    // A pixel changes in one draw: its sphere's, or the first when its ray meets none.
    if row != in.row && !(row == 8u && in.row == 0u) {
        discard;
    }
    var change = transmitted_occlusion(pixel, transmitted, exit, dir, row != 8u);
    if row == in.row {
        let sphere = frame.shadow_spheres[in.row];
        let q = exit.xyz + nearest * dir;
        let m = normalize(q - sphere.xyz);
        let material = live_sphere_material(in.row);
        loss_map_row = loss_map_row_at(in.row, sphere.xyz, m);
        change += transmittance * shade(material, q, m, dir) - transmitted;
    }
    if all(change == vec3<f32>(0.0)) {
        discard;
    }
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    return vec4<f32>(max(before.rgb + change * frame.tone.x, vec3<f32>(0.0)), before.a);
}

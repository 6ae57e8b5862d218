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

// The change in the pixel's transmitted light from the live objects, in the frame's units: the
// shadow pass took the spheres' occlusion of indirect light at the glass's surface
// (shadows.wgsl, layered_shadow, with the pixel's whole indirect light), which is given back;
// and unless a sphere hides it (`hit`), the surface the exit ray meets (the point `distance`
// along it) takes what the live objects change there (seen_surface_change: their shadows from
// every light, their bounce light and their occlusion of its indirect light, once), seen with
// the chain's weight.
fn transmitted_occlusion(pixel: vec2<i32>, transmittance: vec3<f32>, transmitted: vec3<f32>, exit: vec4<f32>, dir: vec3<f32>, hit: bool) -> vec3<f32> {
    let centre = surface_point(pixel);
    if frame.layer_info.x != 1u || frame.counts.y != 1u || centre.w < 0.5 {
        return vec3<f32>(0.0);
    }
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    let n = select(vec3<f32>(0.0), normalize(n_raw), dot(n_raw, n_raw) > 1e-12);
    var change = indirect_occlusion(centre.xyz, n) * transmitted * frame.tone.x;
    if !hit && exit.w < 1e29 {
        // The surface itself: its pixel where the eye sees it, else the scene's triangles from a
        // little short of it along the exit ray (the layers do not give its normal).
        let x = exit.xyz + exit.w * dir;
        let seen = probe_depth(x);
        if frame.bounce.x == 1u && seen.pixel.x >= 0 && abs(seen.distance - seen.surface) <= 1e-3 * seen.surface {
            let now = textureLoad(backdrop_shadowed, seen.pixel, 0).rgb;
            let image = textureLoad(backdrop_colour, seen.pixel, 0).rgb;
            change += transmittance * (now - image);
        } else {
            let short = 1e-3 * max(exit.w, 1e-3);
            let origin = x - short * dir;
            let found = scene_first_hit(origin, dir, 2.0 * short);
            let nx = select(-dir, found.xyz, found.w > 0.0);
            change -= live_shadow_share(x, nx) * transmitted * frame.tone.x;
        }
    }
    return change;
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
    var change = transmitted_occlusion(pixel, transmittance, transmitted, exit, dir, row != 8u);
    if row == in.row {
        let sphere = frame.shadow_spheres[in.row];
        let q = exit.xyz + nearest * dir;
        let m = normalize(q - sphere.xyz);
        let material = live_sphere_material(in.row);
        loss_map_row = loss_map_row_at(in.row, sphere.xyz, m);
        change += (transmittance * shade(material, q, m, dir) - transmitted) * frame.tone.x;
    }
    if all(change == vec3<f32>(0.0)) {
        discard;
    }
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    return vec4<f32>(max(before.rgb + change, vec3<f32>(0.0)), before.a);
}

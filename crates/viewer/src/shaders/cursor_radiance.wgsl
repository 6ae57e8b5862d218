// The moving cursor sphere's radiance from one map (appended to composite.wgsl:
// compositor/mod.rs COMPOSITE_WGSL; compositor/cursor_radiance_map.rs draws it).
//
// With the camera fixed, the radiance the eye receives from a point of the cursor sphere depends
// on that point alone (the view direction at a point of a sphere is the point's own), as the
// own-shadow loss does (shadow_loss.wgsl). So a moving frame shades the sphere once per texel of
// a CURSOR_RADIANCE_TEXELS^2 map over its half facing the eye (the loss maps' hemi-octahedral
// layout) with the moving frame's own shading (cursor_map_shading, shade_with's `map_row`: the
// diffuse radiance from the radiosity map, the highlights without the scene's shadow rays, the
// reflection probes' lobe), and its fragments and edge samples read the map bilinearly instead
// of integrating the lights' samples and the probes' lobe each.

const CURSOR_RADIANCE_TEXELS: u32 = 64u;
// The least cosine between a texel's normal and the direction toward the eye that the map shades
// with: texels past the outline, which the outline's fragments interpolate toward, are shaded
// with their normal turned this far toward the eye, so the map continues the visible shading
// smoothly instead of flipping to the sphere's far side (shade_with's two-sided normal).
const CURSOR_RADIANCE_LEAST_COS: f32 = 0.01;

// Per texel: the cursor sphere's radiance toward the eye (rgb, radiance units) at the texel's
// normal, alpha 1 (0: no sphere).
@group(0) @binding(33) var cursor_radiance_map: texture_2d<f32>;

// The cursor sphere's radiance at camera-space unit normal `n` on its half facing the eye,
// bilinear between the map's texels (clamped at its edges).
fn cursor_radiance_lookup(n: vec3<f32>) -> vec3<f32> {
    let uv = hemi_octahedral(transpose(loss_map_basis(frame.sphere.xyz)) * n);
    let size = f32(CURSOR_RADIANCE_TEXELS);
    let texel = (uv * 0.5 + 0.5) * size - 0.5;
    let base = clamp(floor(texel), vec2<f32>(0.0), vec2<f32>(size - 2.0));
    let f = clamp(texel - base, vec2<f32>(0.0), vec2<f32>(1.0));
    let at = vec2<i32>(base);
    let l00 = textureLoad(cursor_radiance_map, at, 0).rgb;
    let l10 = textureLoad(cursor_radiance_map, at + vec2<i32>(1, 0), 0).rgb;
    let l01 = textureLoad(cursor_radiance_map, at + vec2<i32>(0, 1), 0).rgb;
    let l11 = textureLoad(cursor_radiance_map, at + vec2<i32>(1, 1), 0).rgb;
    return mix(mix(l00, l10, f.x), mix(l01, l11, f.x), f.y);
}

// One texel of the map: the cursor sphere's radiance toward the eye at the texel's normal, as a
// moving frame shades it from its radiosity map (drawn before this pass in the same frame).
@fragment
fn fs_cursor_radiance_map(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let s = frame.sphere;
    if frame.counts.z != 1u || !loss_map_serves(s) {
        return vec4<f32>(0.0);
    }
    let uv = (floor(position.xy) + vec2<f32>(0.5)) / f32(CURSOR_RADIANCE_TEXELS) * 2.0 - vec2<f32>(1.0);
    let n = loss_map_basis(s.xyz) * hemi_octahedral_direction(uv);
    let p = s.xyz + s.w * n;
    // The eye's ray toward p, as ray_through_raster gives it to the sphere's fragments.
    let view_dir = select(vec3<f32>(0.0, 0.0, 1.0), normalize(p), frame.raster.w > 0.5);
    let facing = -dot(n, view_dir);
    var m = n;
    if facing < CURSOR_RADIANCE_LEAST_COS {
        m = normalize(n - (CURSOR_RADIANCE_LEAST_COS - facing) * view_dir);
    }
    return vec4<f32>(cursor_map_shading(frame.sphere_material, p, m, view_dir, 0u), 1.0);
}

// shade_with(material, p, n_in, view_dir, map_row, false) in a moving frame, the only frame
// that draws the radiosity maps (row 0, the cursor sphere's, for its radiance map; a sphere's
// own row in a glossy lobe, glossy_change_from_maps): the diffuse radiance from the map, the
// highlights without the scene's shadow rays scaled by its share let through, and the reflection
// probes' lobe without traced directions (frame.tone.w, glossy_lobe). The same sums, without the
// code of the exact shading's branches: lavapipe runs the code of a branch no fragment of a
// group takes with its lanes off (the traced lobe's walk through the scene, once per lobe
// direction), so the map's entry point holds only what a moving frame runs (what that saves was
// measured while lavapipe still compiled each pipeline again at every bind:
// docs/viewer-frame-time.md, "The leak fixed").
fn cursor_map_shading(material: Material, p: vec3<f32>, n_in: vec3<f32>, view_dir: vec3<f32>, map_row: u32) -> vec3<f32> {
    if material.colour.w > 0.5 {
        return material.colour.rgb;
    }
    let v = -view_dir;
    let n = select(n_in, -n_in, dot(n_in, v) < 0.0);
    let ks = material.coefficients.z;
    let exponent = clamp(1.0 / max(material.coefficients.w, 1e-4), 1.0, 10000.0);
    let map = radiosity_lookup(map_row, n);
    var specular = vec3<f32>(0.0);
    if ks != 0.0 {
        specular = direct_light_over(p, n, v, exponent, true, false, false).specular * map.a;
    }
    if frame.reflection_origin.w > 0.5 && ks != 0.0 {
        let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
        let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
        let v_world = normalize((frame.world_from_camera * vec4<f32>(v, 0.0)).xyz);
        specular += blinn_albedo(material, dot(n, v)) * glossy_reflection_from_probes(p_world, n_world, v_world, exponent);
    }
    return map.rgb + material.specular_colour.rgb * ks * specular;
}

// fs_sphere for a moving frame that reads the cursor sphere's radiance map, which
// compositor/frame.rs draws only where the eye sees the sphere's outside alone: the same hit
// and depth, the colour from the map. An entry point of its own, without shade_with: lavapipe runs
// the code of a branch no fragment of a group takes with its lanes off, each loop's body once
// (what that costs was measured while lavapipe still compiled each pipeline again at every bind
// (docs/viewer-frame-time.md, "The leak fixed")).
@fragment
fn fs_sphere_mapped(@builtin(position) position: vec4<f32>) -> LiveOut {
    let hit = sphere_hit(position.xy);
    if hit.w < 0.0 {
        discard;
    }
    let n = (hit.xyz - frame.sphere.xyz) / frame.sphere.w;
    var out: LiveOut;
    out.colour = to_image_units(cursor_radiance_lookup(n));
    out.mask = vec4<f32>(1.0);
    out.depth = hit.w;
    return out;
}

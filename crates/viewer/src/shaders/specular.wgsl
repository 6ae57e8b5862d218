// The live spheres seen in the pre-rendered scene's specular reflections (appended to
// composite.wgsl: compositor/mod.rs COMPOSITE_WGSL; the bindings and helpers are composite.wgsl's,
// the pass is compositor/specular.rs).

// A live sphere seen in the pixel's specular reflection (a mirror, a glass surface's Fresnel
// reflection): the render's `reflected` layer is the radiance that reflection brought at the
// primary hit, weighted by its `reflectance`; where the mirror direction from the pixel's
// surface point meets a sphere first (and the scene lets it see the sphere), that light is
// hidden and the sphere's own radiance toward the pixel, times the reflectance, is seen instead.
// One ray per pixel, through its centre. Drawn once per sphere (its material bound in group 1,
// its row as the instance): a pixel changes only in the draw of the sphere its ray meets first.
struct ReflectionOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) row: u32,
}

@vertex
fn vs_reflection(@builtin(vertex_index) index: u32, @builtin(instance_index) row: u32) -> ReflectionOut {
    // vs_fullscreen's triangle (an entry point cannot be called).
    let x = f32(i32(index & 1u) * 4 - 1);
    let y = f32(i32(index >> 1u) * 4 - 1);
    return ReflectionOut(vec4<f32>(x, y, 0.5, 1.0), row);
}

@fragment
fn fs_reflection(in: ReflectionOut) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    let reflectance = textureLoad(light_layers, pixel, i32(frame.reflection.y), 0).rgb;
    let centre = surface_point(pixel);
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    if frame.reflection.x != 1u || all(reflectance <= vec3<f32>(0.0)) || centre.w < 0.5
        || dot(n_raw, n_raw) <= 1e-12 {
        discard;
    }
    let p = centre.xyz;
    let n = normalize(n_raw);
    // The camera looks down +z (orthographic) or from the origin (perspective).
    var view = vec3<f32>(0.0, 0.0, 1.0);
    if frame.raster.w > 0.5 {
        view = normalize(p);
    }
    let dir = view - 2.0 * dot(view, n) * n;
    var nearest = -1.0;
    var nearest_row = 0u;
    for (var i = 0u; i < min(frame.layer_info.w, 8u); i = i + 1u) {
        let sphere = frame.shadow_spheres[i];
        let to_sphere = sphere.xyz - p;
        let b = dot(to_sphere, dir);
        let disc = sphere.w * sphere.w - (dot(to_sphere, to_sphere) - b * b);
        if disc < 0.0 {
            continue;
        }
        let t = b - sqrt(disc);
        if t > 0.0 && (nearest < 0.0 || t < nearest) {
            nearest = t;
            nearest_row = i;
        }
    }
    if nearest < 0.0 || nearest_row != in.row || !scene_lets_light(p, n, dir, nearest, 0.0) {
        discard;
    }
    let sphere = frame.shadow_spheres[in.row];
    let q = p + nearest * dir;
    let m = normalize(q - sphere.xyz);
    // The cursor sphere is the first row when it is drawn; the others are live meshes.
    var material = mesh.material;
    if in.row == 0u && frame.counts.z == 1u {
        material = frame.sphere_material;
    }
    // The own-shadow loss from the sphere's loss map on the half it covers (the half facing
    // the eye), gathered at the point on the other half.
    var toward_eye = vec3<f32>(0.0, 0.0, -1.0);
    if frame.raster.w > 0.5 {
        toward_eye = -normalize(sphere.xyz);
    }
    loss_map_row = select(-1, i32(in.row), dot(m, toward_eye) >= 0.0);
    let seen = shade(material, q, m, dir);
    let reflected = textureLoad(light_layers, pixel, i32(frame.reflection.z), 0).rgb;
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    return vec4<f32>(max(before.rgb + reflectance * seen * frame.tone.x - reflected, vec3<f32>(0.0)), before.a);
}

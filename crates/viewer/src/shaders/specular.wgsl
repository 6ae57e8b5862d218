// The live spheres seen in the pre-rendered scene's specular reflections (appended to
// composite.wgsl: compositor/mod.rs COMPOSITE_WGSL; the bindings and helpers are composite.wgsl's,
// the pass is compositor/specular.rs).

// A live sphere seen in the pixel's specular reflection (a mirror, a glass surface's Fresnel
// reflection): the render's `reflected` layer is the radiance that reflection brought at the
// primary hit, weighted by its `reflectance`; where the mirror direction from the pixel's
// surface point meets a sphere first (and the scene lets it see the sphere), that light is
// hidden and the sphere's own radiance toward the pixel, times the reflectance, is seen instead;
// where it meets none, the reflectance times what the live objects changed on the surface it
// meets (seen_surface_change: their shadows, bounce light and occlusion) is added. One ray per
// pixel, through its centre. Drawn once per sphere (its material bound in group 1, its row as
// the instance): a pixel changes only in the draw of the sphere its ray meets first, or in the
// first draw when it meets none.
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

// The direction from the eye to camera-space point p: the camera looks down +z (orthographic)
// or from the origin (perspective).
fn view_direction_to(p: vec3<f32>) -> vec3<f32> {
    if frame.raster.w > 0.5 {
        return normalize(p);
    }
    return vec3<f32>(0.0, 0.0, 1.0);
}

@fragment
fn fs_reflection(in: ReflectionOut) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    if frame.reflection.x != 1u || frame.reflection.y == NO_LAYER {
        discard;
    }
    let reflectance = textureLoad(light_layers, pixel, i32(frame.reflection.y), 0).rgb;
    let centre = surface_point(pixel);
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    if all(reflectance <= vec3<f32>(0.0)) || centre.w < 0.5 || dot(n_raw, n_raw) <= 1e-12 {
        discard;
    }
    let p = centre.xyz;
    let n = normalize(n_raw);
    let view = view_direction_to(p);
    let dir = view - 2.0 * dot(view, n) * n;
    // The first sphere along the mirror direction; its draw shows it where the scene lets the
    // direction reach it. Elsewhere the mirror shows the scene's surface there, and the first
    // draw adds what the live objects changed on it (each pixel changes in one draw).
    let first = first_sphere(p, dir);
    let nearest = first.y;
    let sees_sphere = first.x < 7.5 && scene_lets_light(p, n, dir, nearest, 0.0);
    let reflected = textureLoad(light_layers, pixel, i32(frame.reflection.z), 0).rgb;
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    if !sees_sphere {
        if in.row != 0u {
            discard;
        }
        let change = seen_surface_change(p, p + n * ray_offset(p), dir, reflectance, reflected);
        if all(change == vec3<f32>(0.0)) {
            discard;
        }
        return vec4<f32>(max(before.rgb + change, vec3<f32>(0.0)), before.a);
    }
    if u32(first.x) != in.row {
        discard;
    }
    let sphere = frame.shadow_spheres[in.row];
    let q = p + nearest * dir;
    let m = normalize(q - sphere.xyz);
    let material = live_sphere_material(in.row);
    // The own-shadow loss from the sphere's loss map on the half it covers (the half facing
    // the eye), gathered at the point on the other half.
    loss_map_row = loss_map_row_at(in.row, sphere.xyz, m);
    let seen = shade(material, q, m, dir);
    return vec4<f32>(max(before.rgb + (reflectance * seen - reflected) * frame.tone.x, vec3<f32>(0.0)), before.a);
}

// What the live objects change (shadows, bounce light, occlusion of indirect light) in the
// radiance that unit `dir` from camera-space p brings from the pre-rendered surface it meets
// first, seen with `weight` (a mirror's reflectance, a glass chain's weight) and bringing
// `brought` (that radiance times the weight, in the layers' units): where a march through the
// depth finds the surface's pixel, the weight times that pixel's change so far (the backdrop
// after shadows less the image: a Lambertian surface sends p what it sends the eye); where it
// finds none (hidden from the eye, off screen), the scene's triangles find the surface from
// `origin` (p off its surface) and the share of its light the live objects take
// (live_shadow_share) is taken from `brought`. Zero when shadows are off or neither finds it.
fn seen_surface_change(p: vec3<f32>, origin: vec3<f32>, dir: vec3<f32>, weight: vec3<f32>, brought: vec3<f32>) -> vec3<f32> {
    if frame.counts.y != 1u || frame.layer_info.x != 1u {
        return vec3<f32>(0.0);
    }
    let far = bitcast<f32>(frame.bounce.z);
    if frame.bounce.x == 1u {
        let at = march_to_surface(p, dir, 0.01 * far, far);
        if at.x >= 0 {
            let now = textureLoad(backdrop_shadowed, at, 0).rgb;
            let image = textureLoad(backdrop_colour, at, 0).rgb;
            return weight * (now - image);
        }
    }
    let hit = scene_first_hit(origin, dir, 3.0e38);
    if hit.w <= 0.0 {
        return vec3<f32>(0.0);
    }
    return -live_shadow_share(origin + hit.w * dir, hit.xyz) * brought * frame.tone.x;
}

// A live sphere seen in the pixel's glossy lobe (the ray tracer's Blinn lobe of metal and
// plastic: the sidecar's `glossy` weight Ks and `glossy_exponent`). The render's indirect light
// at the pixel is the lobe's integral of the scene's radiance; where some of the lobe's
// directions meet a sphere first, the sphere shows there instead of what it hides. The lobe is
// integrated with GLOSSY_TRACED directions importance-sampled by its half vector (turned about
// the normal per pixel, so that the stratification shows as fine noise rather than as bands),
// each weighted `f cos / pdf`. Every direction is tested against the spheres (which share of the
// lobe meets this draw's sphere); up to GLOSSY_SHADED of those that do, evenly spread, are shaded
// (the sphere's radiance less what it hides, hidden_radiance, where the scene lets the direction
// through). And in the first sphere's draw, every direction that meets no sphere reads, where a
// march finds the surface it meets, what the live objects' shadows took from that surface: a
// metal reflects the spheres' shadows on the scene too (every direction: a fourth of them left
// the gold cylinder under the spot light's shadow noisy enough to be worse than before). Where
// no march finds it (hidden from the eye: the room's floor between the gold cylinder and a
// sphere beside it, behind the torus), the scene's triangles do, and the share of its light the
// live objects block (live_shadow_share) is taken from the lobe's mean radiance. On a surface
// with a diffuse albedo as well (plastic, or a metal's outline partly over a matte wall) the
// lobe's mean radiance is taken from the lobe's share of the indirect light
// (glossy_indirect_share), and the shadow pass's occlusion of indirect light takes only the
// rest (docs/viewer-specular.md, "The glossy share of a plastic pixel"). Drawn once per sphere, each draw adding its
// share to the backdrop after shadows as the draws before it left it (compositor/specular.rs
// copies the frame there between draws).
const GLOSSY_TRACED: u32 = 64u;
const GLOSSY_SHADED: u32 = 8u;
// The lobe directions of a moving frame's samples (fs_glossy_gather, one pixel in
// REDUCED_GLOSSY_STRIDE^2): an eighth, each weighing eight. Every pixel's change is then
// spread from four samples' 8 directions, turned differently at each; the lobes' samples cost
// about 300 of a 520 ms moving frame on lavapipe with all 64, and 8 instead of 16 cost 14 ms
// less in the room at 512x384 with the moving frame's error there no larger
// (docs/viewer-frame-time.md).
const GLOSSY_TRACED_MOVING: u32 = 8u;
// The directions that meet a sphere a moving frame's sample shades, at most: the sphere's
// radiance then comes from its radiosity map, smooth over the sphere, and each shaded direction
// still marches for the light the sphere hides (hidden_radiance).
const GLOSSY_SHADED_MOVING: u32 = 2u;
// The directions toward a surface the eye does not see that a moving frame's sample rebuilds
// the live objects' shadows at, at most (glossy_lobe_survey): each walks the scene's triangles
// and integrates the lights' samples there, about half a moving frame's lobe samples' cost in
// the room with all of them.
const GLOSSY_HIDDEN_MOVING: u32 = 2u;

// Direction `i` of `count` (GLOSSY_TRACED, or fewer while moving) of the Blinn lobe of exponent
// `e` at normal n (tangents t, b) seen from v, the strata turned by `turn`: xyz the direction,
// w its `f cos / pdf` per unit Ks (0 when it leaves the hemisphere), raytracer::bsdf's D G /
// (4 cos_o) over the half vector's density (e + 1) cos_h^e / (8 pi o_dot_h), times
// GLOSSY_TRACED / count, so that a sum over `count` directions weighs as one over GLOSSY_TRACED.
fn glossy_direction(i: u32, count: u32, e: f32, n: vec3<f32>, t: vec3<f32>, b: vec3<f32>, v: vec3<f32>, turn: f32) -> vec4<f32> {
    let d = blinn_direction(i, count, turn, e, n, t, b, v);
    let cos_h = d.cos_h;
    let o_dot_h = d.o_dot_h;
    let l = d.l;
    let cos_l = d.cos_l;
    let cos_o = max(dot(n, v), 1e-3);
    if o_dot_h <= 0.0 || cos_l <= 0.0 {
        return vec4<f32>(l, 0.0);
    }
    let g = min(min(2.0 * cos_h * cos_o / o_dot_h, 2.0 * cos_h * cos_l / o_dot_h), 1.0);
    let weight = (e + 2.0) / (e + 1.0) * g * o_dot_h / cos_o;
    return vec4<f32>(l, weight * (f32(GLOSSY_TRACED) / f32(count)));
}

// The tangents of normal n that glossy_direction turns the lobe about.
fn lobe_tangents(n: vec3<f32>) -> mat2x3<f32> {
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
    let t = normalize(cross(helper, n));
    return mat2x3<f32>(t, cross(n, t));
}

// The turn of a scene pixel's lobe strata (fs_glossy), so that their pattern shows as fine
// noise rather than as bands.
fn lobe_turn(pixel: vec2<i32>) -> f32 {
    return fract(f32((u32(pixel.x) * 1973u + u32(pixel.y) * 9277u) % 4096u) * 0.6180339887);
}

// The share of a glossy scene pixel's indirect light that its lobe brings, per channel: the
// lobe's weight (Ks times its albedo at the view, the mean of fs_glossy's GLOSSY_TRACED
// weights) against the diffuse albedo, as if the light around were even. 1 for a metal, about
// a third for the room's red plastic; a pixel on a metal's outline that is partly a matte wall
// is mostly glossy. fs_glossy traces that share; the shadow pass's occlusion of indirect light
// takes the rest (shadows.wgsl occludable_indirect).
fn glossy_indirect_share(pixel: vec2<i32>, ks: vec3<f32>, diffuse_albedo: vec3<f32>) -> vec3<f32> {
    if all(diffuse_albedo <= vec3<f32>(0.0)) {
        return vec3<f32>(1.0);
    }
    let exponent = textureLoad(light_layers, pixel, i32(frame.reflection.w) + 1, 0).r;
    let centre = surface_point(pixel);
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    if all(ks <= vec3<f32>(0.0)) || !(exponent >= 1.0) || centre.w < 0.5 || dot(n_raw, n_raw) <= 1e-12 {
        return vec3<f32>(0.0);
    }
    let n = normalize(n_raw);
    let v = -view_direction_to(centre.xyz);
    let tb = lobe_tangents(n);
    let turn = lobe_turn(pixel);
    var albedo = 0.0;
    for (var i = 0u; i < GLOSSY_TRACED; i++) {
        albedo += max(glossy_direction(i, GLOSSY_TRACED, exponent, n, tb[0], tb[1], v, turn).w, 0.0);
    }
    let lobe = ks * (albedo / f32(GLOSSY_TRACED));
    return lobe / max(lobe + diffuse_albedo, vec3<f32>(1e-6));
}

// The first sphere along unit `l` from p: x its row (8 for none), y the entry distance, z the
// exit distance.
fn first_sphere(p: vec3<f32>, l: vec3<f32>) -> vec3<f32> {
    var out = vec3<f32>(8.0, -1.0, 0.0);
    for (var k = 0u; k < min(frame.layer_info.w, 8u); k = k + 1u) {
        let s = frame.shadow_spheres[k];
        let to_s = s.xyz - p;
        let bb = dot(to_s, l);
        let disc = s.w * s.w - (dot(to_s, to_s) - bb * bb);
        if disc < 0.0 {
            continue;
        }
        let root = sqrt(disc);
        if bb - root > 0.0 && (out.y < 0.0 || bb - root < out.y) {
            out = vec3<f32>(f32(k), bb - root, bb + root);
        }
    }
    return out;
}

@fragment
fn fs_glossy(in: ReflectionOut) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    let change = glossy_change(pixel, in.row, false);
    if change.w == 0.0 {
        discard;
    }
    let ks = textureLoad(light_layers, pixel, i32(frame.reflection.w), 0).rgb;
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    return vec4<f32>(max(before.rgb + change.rgb * (ks / f32(GLOSSY_TRACED)), vec3<f32>(0.0)), before.a);
}

// What draw `row`'s sphere changes in the glossy lobe of `pixel` (fs_glossy), per unit Ks and
// times GLOSSY_TRACED, in rgb; w is 0 where it changes nothing (no lobe there, or the lobe
// meets neither the sphere nor the live objects' shadows), else 1. At full resolution
// (fs_glossy) and, while moving, at one pixel of each block (fs_glossy_gather, `moving`): then
// over GLOSSY_TRACED_MOVING directions. The sphere in the lobe is shaded as the eye would see
// it (shade_with); a moving frame with radiosity maps shades it from its map instead
// (glossy_change_from_maps).
fn glossy_change(pixel: vec2<i32>, row: u32, moving: bool) -> vec4<f32> {
    let survey = glossy_lobe_survey(pixel, row, moving);
    if !survey.changes {
        return vec4<f32>(0.0);
    }
    if survey.chosen_count == 0u {
        return vec4<f32>(survey.change, 1.0);
    }
    let material = live_sphere_material(row);
    let sphere = frame.shadow_spheres[row];
    var shaded = vec3<f32>(0.0);
    var shaded_weight = 0.0;
    for (var j = 0u; j < survey.chosen_count; j++) {
        let hit = lobe_sphere_hit(survey, j, row);
        shaded_weight += hit.weight;
        if hit.lit {
            loss_map_row = loss_map_row_at(row, sphere.xyz, hit.m);
            let seen = shade_with(material, hit.q, hit.m, hit.dir, -1, false) * frame.tone.x;
            shaded += hit.weight * (seen - hidden_radiance(survey.p, hit.dir, hit.beyond, survey.mean));
        }
    }
    return vec4<f32>(survey.change + survey.met * shaded / max(shaded_weight, 1e-30), 1.0);
}

// glossy_change(pixel, row, true) in a moving frame with the bounce light on, which draws the
// spheres' radiosity maps first: the sphere in the lobe shaded from its map as the moving cursor
// sphere's own is (cursor_map_shading), the same sums as shade_with's `map_row`. A function of
// its own, for an entry point of its own (fs_glossy_gather_from_maps) without shade_with's code:
// lavapipe runs the code of a branch no fragment of a group takes with its lanes off, and a branch
// on a constant argument kept that cost (both measured while lavapipe still compiled each pipeline
// again at every bind (docs/viewer-frame-time.md, "The leak fixed")).
fn glossy_change_from_maps(pixel: vec2<i32>, row: u32) -> vec4<f32> {
    let survey = glossy_lobe_survey(pixel, row, true);
    if !survey.changes {
        return vec4<f32>(0.0);
    }
    if survey.chosen_count == 0u {
        return vec4<f32>(survey.change, 1.0);
    }
    let material = live_sphere_material(row);
    var shaded = vec3<f32>(0.0);
    var shaded_weight = 0.0;
    for (var j = 0u; j < survey.chosen_count; j++) {
        let hit = lobe_sphere_hit(survey, j, row);
        shaded_weight += hit.weight;
        if hit.lit {
            let seen = cursor_map_shading(material, hit.q, hit.m, hit.dir, row) * frame.tone.x;
            shaded += hit.weight * (seen - hidden_radiance(survey.p, hit.dir, hit.beyond, survey.mean));
        }
    }
    return vec4<f32>(survey.change + survey.met * shaded / max(shaded_weight, 1e-30), 1.0);
}

// What a glossy pixel's lobe holds for draw `row`'s sphere before the sphere is shaded
// (glossy_change): the lobe's frame, the change of the shadows seen in it, and the directions
// that meet the sphere and are to be shaded.
struct LobeSurvey {
    // False where the draw changes nothing at the pixel.
    changes: bool,
    // The camera-space surface point, its unit normal and lobe tangents, and the direction
    // toward the eye.
    p: vec3<f32>,
    n: vec3<f32>,
    t: vec3<f32>,
    b: vec3<f32>,
    v: vec3<f32>,
    exponent: f32,
    turn: f32,
    // The lobe's directions (GLOSSY_TRACED, or GLOSSY_TRACED_MOVING).
    traced: u32,
    // The shadows' change seen in the lobe, less the light the live objects take from surfaces
    // the eye does not see.
    change: vec3<f32>,
    // The lobe's mean incoming radiance, for what a direction hides where no march finds it.
    mean: vec3<f32>,
    // The weight of the directions that meet the sphere first.
    met: f32,
    // Which of them are shaded (every stride-th).
    chosen: array<u32, GLOSSY_SHADED>,
    chosen_count: u32,
}

fn glossy_lobe_survey(pixel: vec2<i32>, row: u32, moving: bool) -> LobeSurvey {
    var survey: LobeSurvey;
    survey.changes = false;
    survey.chosen_count = 0u;
    if frame.reflection.x != 1u || frame.reflection.w == NO_LAYER {
        return survey;
    }
    let ks = textureLoad(light_layers, pixel, i32(frame.reflection.w), 0).rgb;
    let exponent = textureLoad(light_layers, pixel, i32(frame.reflection.w) + 1, 0).r;
    let centre = surface_point(pixel);
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    if all(ks <= vec3<f32>(0.0)) || !(exponent >= 1.0) || centre.w < 0.5 || dot(n_raw, n_raw) <= 1e-12 {
        return survey;
    }
    let p = centre.xyz;
    let n = normalize(n_raw);
    let view = view_direction_to(p);
    let v = -view;
    let tb = lobe_tangents(n);
    let t = tb[0];
    let b = tb[1];
    let turn = lobe_turn(pixel);
    let traced = select(GLOSSY_TRACED, GLOSSY_TRACED_MOVING, moving);
    // A surface with a diffuse albedo as well (plastic, or a metal's outline partly on a matte
    // surface) has only its lobe's share of the indirect light traced here.
    var diffuse_albedo = vec3<f32>(0.0);
    if frame.bounce.x == 1u {
        diffuse_albedo = textureLoad(light_layers, pixel, i32(frame.bounce.y), 0).rgb;
    }
    // Which share of the lobe meets this draw's sphere first, and in how many directions; and
    // the shadows seen in the rest of the lobe (first draw).
    let far = bitcast<f32>(frame.bounce.z);
    let shadows_seen = row == 0u && frame.bounce.x == 1u;
    var albedo = 0.0;
    var met = 0.0;
    var met_count = 0u;
    // Which of the `traced` directions met the sphere, so that the choice below visits only
    // those.
    var met_mask = vec2<u32>(0u);
    // Which free directions met a surface no march finds (the eye does not see it).
    var hidden_mask = vec2<u32>(0u);
    var hidden_count = 0u;
    var hidden_weight = 0.0;
    var shadowed = vec3<f32>(0.0);
    // The lobe's weight times the share of light the live objects take, summed over the free
    // directions that meet a surface the eye does not see.
    var hidden_taken = vec3<f32>(0.0);
    for (var i = 0u; i < traced; i++) {
        let d = glossy_direction(i, traced, exponent, n, t, b, v, turn);
        if d.w <= 0.0 {
            continue;
        }
        albedo += d.w;
        let first = first_sphere(p, d.xyz);
        if u32(first.x) == row {
            met += d.w;
            met_count += 1u;
            met_mask[i / 32u] |= 1u << (i % 32u);
        } else if shadows_seen && first.x > 7.5 {
            let at = march_to_surface(p, d.xyz, 0.01 * far, far);
            if at.x >= 0 {
                let now = textureLoad(backdrop_shadowed, at, 0).rgb;
                let before = textureLoad(backdrop_colour, at, 0).rgb;
                shadowed += d.w * (now - before);
            } else {
                hidden_mask[i / 32u] |= 1u << (i % 32u);
                hidden_count += 1u;
                hidden_weight += d.w;
            }
        }
    }
    // A surface the eye does not see (behind another, or off screen) has no shadowed pixel to
    // read: the scene's triangles find it, and the share of its light the live objects take is
    // rebuilt there (its radiance taken as the lobe's mean, below). While moving, every k-th of
    // those directions stands for all of them by weight, as the shaded directions stand for
    // the sphere's: each costs a walk through the scene and the lights' samples.
    let rebuilt_most = select(GLOSSY_TRACED, GLOSSY_HIDDEN_MOVING, moving);
    let hidden_stride = (hidden_count + rebuilt_most - 1u) / rebuilt_most;
    var rebuilt_weight = 0.0;
    var hidden_k = 0u;
    for (var i = 0u; i < traced; i++) {
        if (hidden_mask[i / 32u] & (1u << (i % 32u))) == 0u {
            continue;
        }
        let chosen = hidden_k % hidden_stride == 0u;
        hidden_k += 1u;
        if !chosen {
            continue;
        }
        let d = glossy_direction(i, traced, exponent, n, t, b, v, turn);
        rebuilt_weight += d.w;
        let hit = scene_first_hit(p + n * ray_offset(p), d.xyz, 3.0e38);
        if hit.w > 0.0 {
            hidden_taken += d.w * live_shadow_share(p + hit.w * d.xyz, hit.xyz);
        }
    }
    if hidden_stride > 1u {
        hidden_taken *= hidden_weight / rebuilt_weight;
    }
    if met_count == 0u && all(shadowed == vec3<f32>(0.0)) && all(hidden_taken == vec3<f32>(0.0)) {
        return survey;
    }
    // The lobe's mean incoming radiance: what a direction hides, or sends from a surface the eye
    // does not see, where no march finds it.
    let indirect = textureLoad(light_layers, pixel, i32(frame.layer_info.y), 0).rgb;
    let mean = indirect / max(ks * albedo / f32(GLOSSY_TRACED) + diffuse_albedo, vec3<f32>(1e-6));
    survey.changes = true;
    survey.p = p;
    survey.n = n;
    survey.t = t;
    survey.b = b;
    survey.v = v;
    survey.exponent = exponent;
    survey.turn = turn;
    survey.traced = traced;
    survey.change = shadowed - mean * hidden_taken;
    survey.mean = mean;
    survey.met = met;
    if met_count > 0u {
        let shaded_most = select(GLOSSY_SHADED, GLOSSY_SHADED_MOVING, moving);
        let stride = (met_count + shaded_most - 1u) / shaded_most;
        // The directions to shade are chosen first and shaded in a loop without `continue`:
        // on lavapipe, a loop that skipped directions with `continue` around the call to
        // shade left about half the fragments after their first or second shaded direction
        // (docs/viewer-specular.md, "Directions the shading loop lost").
        var k = 0u;
        for (var i = 0u; i < traced; i++) {
            if (met_mask[i / 32u] & (1u << (i % 32u))) != 0u {
                if k % stride == 0u && survey.chosen_count < shaded_most {
                    survey.chosen[survey.chosen_count] = i;
                    survey.chosen_count += 1u;
                }
                k += 1u;
            }
        }
    }
    return survey;
}

// Where chosen direction `j` of a lobe survey meets draw `row`'s sphere.
struct LobeSphereHit {
    // The direction and its weight.
    dir: vec3<f32>,
    weight: f32,
    // The point on the sphere and its unit normal.
    q: vec3<f32>,
    m: vec3<f32>,
    // The distance past the sphere (its exit), where the light it hides comes from.
    beyond: f32,
    // Whether the scene lets the sphere's light reach the surface point.
    lit: bool,
}

fn lobe_sphere_hit(survey: LobeSurvey, j: u32, row: u32) -> LobeSphereHit {
    let d = glossy_direction(survey.chosen[j], survey.traced, survey.exponent, survey.n, survey.t, survey.b, survey.v, survey.turn);
    let first = first_sphere(survey.p, d.xyz);
    var hit: LobeSphereHit;
    hit.dir = d.xyz;
    hit.weight = d.w;
    hit.q = survey.p + first.y * d.xyz;
    hit.m = normalize(hit.q - frame.shadow_spheres[row].xyz);
    hit.beyond = first.z;
    hit.lit = scene_lets_light(survey.p, survey.n, d.xyz, first.y, 0.0);
    return hit;
}

// The radiance (image units, without what emitters emit: their light hidden is their light
// layer's share, which the shadows take) that the pre-rendered scene sends toward p from
// unit direction `dir` beyond distance `beyond` (past a sphere): the image's light layers where
// a march through the depth finds the surface there (a Lambertian surface sends p what it sends
// the eye); `fallback` where the march finds none (off screen, or hidden from the eye).
fn hidden_radiance(p: vec3<f32>, dir: vec3<f32>, beyond: f32, fallback: vec3<f32>) -> vec3<f32> {
    let far = bitcast<f32>(frame.bounce.z);
    if frame.bounce.x != 1u || beyond >= far {
        return fallback;
    }
    let at = march_to_surface(p, dir, beyond, far);
    if at.x < 0 {
        return fallback;
    }
    var behind = vec3<f32>(0.0);
    for (var slice = 0u; slice <= frame.layer_info.y; slice = slice + 1u) {
        behind += textureLoad(light_layers, at, i32(slice), 0).rgb;
    }
    return behind;
}

// The first triangle of the tessellated scene along unit `dir` from camera-space `origin`
// (t up to t_max): xyz its unit normal turned toward the origin, w the distance (-1: none, or
// no hierarchy): bvh_nearest's hit, as the near field takes it too.
fn scene_first_hit(origin: vec3<f32>, dir: vec3<f32>, t_max: f32) -> vec4<f32> {
    let hit = bvh_nearest(frame.scene_occluders, origin, dir, 0.0, t_max);
    if !(hit.t < t_max) {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let g = normalize(cross(occluder_triangles[3u * hit.triangle + 1u].xyz, occluder_triangles[3u * hit.triangle + 2u].xyz));
    return vec4<f32>(select(g, -g, dot(g, dir) > 0.0), hit.t);
}

// At most this many of an area light's samples weigh its light at a surface point the eye does
// not see (every k-th, each standing for k).
const HIDDEN_AREA_SAMPLES: u32 = 16u;

// The share of the light that pre-rendered surface point q (camera space, unit normal nq on
// the side it is seen from) receives which the live objects take, per channel: each light's
// irradiance there and the part live_blocks finds blocked (an area light over every k-th of
// its samples from the light layers), the irradiance probes' indirect light and the spheres'
// occlusion of it (indirect_occlusion, as the shadow pass takes it), and the ambient light as
// the irradiance pi L that a Lambertian surface turns into L. For a surface without a shadowed
// pixel to read (hidden from the eye), whose light is in no layer: its Lambertian radiance
// scales with what it receives, so this share of any estimate of that radiance is what the
// live objects take from it. The scene's own shadows at q are not traced (every light is
// taken to reach it): a second hierarchy traversal beside scene_first_hit's in one shader made
// lavapipe's glossy_direction return wrong directions for the rest of the fragment.
fn live_shadow_share(q: vec3<f32>, nq: vec3<f32>) -> vec3<f32> {
    let occluded = indirect_occlusion(q, nq);
    let count = min(frame.counts.x, MAX_LIGHTS);
    var received = vec3<f32>(0.0);
    var taken = vec3<f32>(0.0);
    for (var k = 0u; k < count; k++) {
        let light = frame.lights[k];
        let kind = u32(light.position.w + 0.5);
        let slot = frame.shadow_slots[k];
        if kind == LIGHT_AMBIENT {
            received += PI * light.colour.rgb;
            continue;
        }
        let area = kind == LIGHT_AREA && frame.layer_info.x == 1u && slot.x != NO_LAYER && slot.z > 0u;
        let samples = select(1u, min(slot.z, MAX_AREA_SAMPLES), area);
        let stride = (samples + HIDDEN_AREA_SAMPLES - 1u) / HIDDEN_AREA_SAMPLES;
        for (var j = 0u; j < samples; j += stride) {
            var l: vec3<f32>;
            var distance: f32;
            var e: vec3<f32>;
            if area {
                let s = area_sample_toward(slot.y + j, q);
                l = s.l;
                distance = sqrt(s.dist2);
                e = light.params.rgb * (f32(stride) * s.weight * s.cos_e / s.dist2);
            } else {
                let toward = light_toward(k, q);
                l = toward.l;
                distance = toward.distance;
                e = toward.e;
            }
            let cos_q = dot(nq, l);
            if cos_q <= 0.0 || all(e <= vec3<f32>(0.0)) {
                continue;
            }
            received += e * cos_q;
            if live_blocks(q, l, distance) {
                taken += e * cos_q;
            }
        }
    }
    let indirect = probe_irradiance(q, nq, vec3<f32>(0.0));
    received += indirect;
    taken += occluded * indirect;
    return select(vec3<f32>(0.0), min(taken / max(received, vec3<f32>(1e-30)), vec3<f32>(1.0)), received > vec3<f32>(0.0));
}

// The light live spheres reflect onto the pre-rendered scene (appended to composite.wgsl:
// compositor/mod.rs COMPOSITE_WGSL; the bindings and helpers are composite.wgsl's).
//
// Differential rendering adds to each pre-rendered surface the light an inserted object sends
// it. A live sphere is diffuse toward the scene with the radiance the viewer itself shades it
// with (its lights with the scene's shadows, the probes' indirect light less what its own
// shadows took), which on a sphere is a function of the normal alone. So it is computed once
// per texel of a RADIOSITY_MAP_TEXELS^2 octahedral map over the whole sphere (row k of an atlas
// for the k-th shadow-casting sphere: compositor/bounce.rs), and each pixel near a sphere
// integrates the sphere's visible cap over BOUNCE_RINGS x BOUNCE_SECTORS directions reading that
// map: `albedo / pi * sum L cos_p * solid angle / N` (the sidecar's albedo and normal layers).
// A glossy sphere also reflects its lights' highlights toward the receiver, which depends on
// the direction: each direction adds the Blinn lobe of the lights toward the receiver, scaled
// by the share of their light the scene lets reach that point of the sphere (the map's alpha),
// with the sphere's specular colour and lobe from the map's last column (glossy_toward).

const RADIOSITY_MAP_TEXELS: u32 = 32u;
// Directions over a sphere's cap: rings of equal solid angle, each with evenly spaced sectors
// (every other ring turned by half a sector), so that a radiance linear in the direction, and
// so the cosine of an uncut cap, is integrated exactly. Up to 4 rings of 8 sectors near the
// sphere; fewer where the sphere is small in the surface's view (see bounce_irradiance).
const BOUNCE_RINGS: u32 = 4u;
const BOUNCE_SECTORS: u32 = 8u;

// Per texel: the sphere's outgoing diffuse radiance (rgb, radiance units) at the texel's normal
// and the share of its lights' direct light the scene lets reach that point (a). Column
// RADIOSITY_MAP_TEXELS, first texel of each row: the sphere's `Ks * specular colour` (rgb) and
// Blinn exponent (a).
@group(0) @binding(15) var radiosity_maps: texture_2d<f32>;

// The unit direction of octahedral coordinates `uv` in [0, 1]^2 (the inverse of octahedral_uv).
fn octahedral_direction(uv: vec2<f32>) -> vec3<f32> {
    let xy = uv * 2.0 - vec2<f32>(1.0);
    let z = 1.0 - abs(xy.x) - abs(xy.y);
    var d = vec3<f32>(xy, z);
    if z < 0.0 {
        d = vec3<f32>(
            (1.0 - abs(xy.y)) * select(-1.0, 1.0, xy.x >= 0.0),
            (1.0 - abs(xy.x)) * select(-1.0, 1.0, xy.y >= 0.0),
            z,
        );
    }
    return normalize(d);
}

// The outgoing diffuse radiance of the sphere of row `row` at camera-space unit normal `m` (rgb)
// and the share of its lights' light reaching it there (a), bilinear in its map (clamped at the
// map's edges, where the octahedral fold meets itself).
fn radiosity_lookup(row: u32, m: vec3<f32>) -> vec4<f32> {
    let size = f32(RADIOSITY_MAP_TEXELS);
    let texel = octahedral_uv(m) * size - 0.5;
    let base = clamp(floor(texel), vec2<f32>(0.0), vec2<f32>(size - 2.0));
    let f = clamp(texel - base, vec2<f32>(0.0), vec2<f32>(1.0));
    let at = vec2<i32>(base) + vec2<i32>(0, i32(row * RADIOSITY_MAP_TEXELS));
    let l00 = textureLoad(radiosity_maps, at, 0);
    let l10 = textureLoad(radiosity_maps, at + vec2<i32>(1, 0), 0);
    let l01 = textureLoad(radiosity_maps, at + vec2<i32>(0, 1), 0);
    let l11 = textureLoad(radiosity_maps, at + vec2<i32>(1, 1), 0);
    return mix(mix(l00, l10, f.x), mix(l01, l11, f.x), f.y);
}

// The texel of the sphere of row `row` nearest camera-space unit normal `m`.
fn radiosity_texel(row: u32, m: vec3<f32>) -> vec2<i32> {
    let size = f32(RADIOSITY_MAP_TEXELS);
    let texel = clamp(vec2<i32>(octahedral_uv(m) * size), vec2<i32>(0), vec2<i32>(i32(RADIOSITY_MAP_TEXELS) - 1));
    return texel + vec2<i32>(0, i32(row * RADIOSITY_MAP_TEXELS));
}

// The share of the lights' direct irradiance at camera-space point p (unit normal n) that the
// scene lets through: `direct_light`'s shadowed diffuse irradiance (`shadowed`, which the caller
// has from its own direct_light(p, n, n, 1.0, false)) over the same sum unshadowed (1 where no
// light reaches p).
fn lights_let_through(p: vec3<f32>, n: vec3<f32>, shadowed: vec3<f32>) -> f32 {
    var unshadowed = 0.0;
    for (var k = 0u; k < min(frame.counts.x, MAX_LIGHTS); k++) {
        let kind = u32(frame.lights[k].position.w + 0.5);
        let slot = frame.shadow_slots[k];
        if kind == LIGHT_AMBIENT {
            continue;
        }
        if kind == LIGHT_AREA && frame.layer_info.x == 1u && slot.x != NO_LAYER && slot.z > 0u {
            let radiance = luminance(frame.lights[k].params.rgb);
            for (var i = 0u; i < min(slot.z, MAX_AREA_SAMPLES); i++) {
                let s = area_sample_toward(slot.y + i, p);
                unshadowed += radiance * s.weight * s.cos_e / s.dist2 * max(dot(n, s.l), 0.0);
            }
            continue;
        }
        let toward = light_toward(k, p);
        unshadowed += luminance(toward.e) * max(dot(n, toward.l), 0.0);
    }
    if unshadowed <= 0.0 {
        return 1.0;
    }
    return clamp(luminance(shadowed) / unshadowed, 0.0, 1.0);
}

// The radiance the lights' highlights on the sphere of row `row` send from its camera-space
// point q (unit normal m) along unit direction v: `Ks * specular colour` times the Blinn lobe
// of each light (the ray tracer's, as `shade` takes it), times the share `let_through` of their
// light the scene lets reach q. Zero for a sphere without a specular lobe.
fn glossy_toward(row: u32, q: vec3<f32>, m: vec3<f32>, v: vec3<f32>, let_through: f32) -> vec3<f32> {
    let lobe = textureLoad(radiosity_maps, vec2<i32>(i32(RADIOSITY_MAP_TEXELS), i32(row * RADIOSITY_MAP_TEXELS)), 0);
    if all(lobe.rgb <= vec3<f32>(0.0)) || let_through <= 0.0 || dot(m, v) <= 0.0 {
        return vec3<f32>(0.0);
    }
    var specular = vec3<f32>(0.0);
    for (var k = 0u; k < min(frame.counts.x, MAX_LIGHTS); k++) {
        if u32(frame.lights[k].position.w + 0.5) == LIGHT_AMBIENT {
            continue;
        }
        let toward = light_toward(k, q);
        specular += toward.e * blinn_lobe_cos(m, v, toward.l, lobe.a);
    }
    return lobe.rgb * specular * let_through;
}

// One texel of the atlas: the diffuse radiance the sphere of its row sends out at the texel's
// normal, with its material (the cursor sphere's, or the mesh bound in group 1).
@fragment
fn fs_radiosity_map(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return radiosity_map_texel(position, true);
}

// fs_radiosity_map for a moving frame: the own-shadow loss where no loss map serves (the half of
// the sphere turned from the eye, or all of it while the eye is inside it) is left out rather
// than gathered per texel. In the room it changes the moving frame by at most 6e-4
// (docs/viewer-frame-time.md), and a shader without the gather's code drew the maps in half the
// time there (in the frame bench, an eighth) on lavapipe, measured while lavapipe still compiled
// each pipeline again at every bind (docs/viewer-frame-time.md, "The leak fixed").
@fragment
fn fs_radiosity_map_moving(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return radiosity_map_texel(position, false);
}

// The texel of fs_radiosity_map at `position`; the own-shadow loss where the loss maps do not
// serve gathered only with `gather_loss` (a constant at each entry point).
fn radiosity_map_texel(position: vec4<f32>, gather_loss: bool) -> vec4<f32> {
    let texel = vec2<u32>(position.xy);
    let row = texel.y / RADIOSITY_MAP_TEXELS;
    if frame.layer_info.x != 1u || row >= min(frame.layer_info.w, 8u) {
        return vec4<f32>(0.0);
    }
    let material = live_sphere_material(row);
    // The last column: the specular lobe (none for an unlit sphere).
    if texel.x >= RADIOSITY_MAP_TEXELS {
        if material.colour.w > 0.5 || material.coefficients.z <= 0.0 {
            return vec4<f32>(0.0);
        }
        let exponent = clamp(1.0 / max(material.coefficients.w, 1e-4), 1.0, 10000.0);
        return vec4<f32>(material.specular_colour.rgb * material.coefficients.z, exponent);
    }
    let s = frame.shadow_spheres[row];
    let uv = (vec2<f32>(texel % vec2<u32>(RADIOSITY_MAP_TEXELS)) + vec2<f32>(0.5)) / f32(RADIOSITY_MAP_TEXELS);
    let n = octahedral_direction(uv);
    let p = s.xyz + s.w * n;
    // The own-shadow loss from the sphere's loss map on the half the map covers (as the
    // sphere's shading reads it), gathered here on the half turned from the eye (`gather_loss`).
    loss_map_row = loss_map_row_at(row, s.xyz, n);
    if material.colour.w > 0.5 {
        return vec4<f32>(material.colour.rgb, 1.0);
    }
    // The lights' light with the scene's shadows, once for both the radiance and the share.
    let lit = direct_light(p, n, n, 1.0, false);
    var let_through = 1.0;
    if material.coefficients.z > 0.0 {
        let_through = lights_let_through(p, n, lit.diffuse);
    }
    return vec4<f32>(diffuse_radiance_lit_with(material, p, n, lit, gather_loss), let_through);
}

// The light the highlights of the sphere of row `row` send to the surface at p (unit normal n),
// the integral of glossy_toward times cos_p over the sphere's cap, unhidden. A highlight is a
// patch of the sphere's normals about the half vector (a tenth of those facing p for roughness
// 0.1), which the cap's directions, dense at its centre and sparse at its rim where a grazing
// reflection sends most, would miss: so the integral runs over the normals facing p, rings of
// equal solid angle times sectors (`side` x `side`), with
// `d omega = r^2 cos_o / t^2 d omega_m` (t from p to the point, cos_o at the point).
fn glossy_cap(row: u32, p: vec3<f32>, n: vec3<f32>, side: u32) -> vec3<f32> {
    let lobe = textureLoad(radiosity_maps, vec2<i32>(i32(RADIOSITY_MAP_TEXELS), i32(row * RADIOSITY_MAP_TEXELS)), 0);
    if all(lobe.rgb <= vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    let sphere = frame.shadow_spheres[row];
    let r = sphere.w;
    let to_p = p - sphere.xyz;
    let d = length(to_p);
    let axis = to_p / d;
    // Normals m with m . axis >= r / d face p.
    let one_minus_cos = 1.0 - r / d;
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(axis.x) > 0.9);
    let tangent = normalize(cross(helper, axis));
    let bitangent = cross(axis, tangent);
    let ring_count = side;
    let sectors = side;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < ring_count * sectors; k = k + 1u) {
        let ring = k / sectors;
        let u = (f32(ring) + 0.5) / f32(ring_count);
        let cos_t = 1.0 - u * one_minus_cos;
        let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
        let phi = (f32(k % sectors) + 0.5 * f32(ring % 2u)) * (2.0 * PI / f32(sectors));
        let m = tangent * (sin_t * cos(phi)) + bitangent * (sin_t * sin(phi)) + axis * cos_t;
        let q = sphere.xyz + r * m;
        let to_q = q - p;
        let t2 = dot(to_q, to_q);
        let w = to_q * inverseSqrt(t2);
        let cos_p = dot(n, w);
        let cos_o = -dot(m, w);
        if cos_p <= 0.0 || cos_o <= 0.0 {
            continue;
        }
        let shadowed = textureLoad(radiosity_maps, radiosity_texel(row, m), 0).a;
        sum += glossy_toward(row, q, m, -w, shadowed) * (cos_p * cos_o / t2);
    }
    return sum * (r * r * 2.0 * PI * one_minus_cos / f32(ring_count * sectors));
}

// The light the shadow-casting spheres reflect onto the surface at p (camera space) with unit
// normal n, per unit diffuse albedo times pi: the sum over spheres of the integral of their
// outgoing radiance times cos_p over the parts of their caps the scene lets p see, in radiance
// units. Faded out between
// 6 and 8 radii as their occlusion of indirect light is, so that a sphere as bright as what it
// hides changes nothing at any distance.
fn bounce_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < min(frame.layer_info.w, 8u); i = i + 1u) {
        let sphere = frame.shadow_spheres[i];
        let to_sphere = sphere.xyz - p;
        let d = length(to_sphere);
        let r = sphere.w;
        if d <= r * 1.0001 || d >= AO_REACH * r {
            continue;
        }
        let axis = to_sphere / d;
        let sin_a = r / d;
        // The cap lies wholly below the surface's horizon.
        if dot(n, axis) <= -sin_a {
            continue;
        }
        let cos_a = sqrt(max(1.0 - sin_a * sin_a, 0.0));
        // 1 - cos_a without cancellation for small caps.
        let one_minus_cos = sin_a * sin_a / (1.0 + cos_a);
        let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(axis.x) > 0.9);
        let tangent = normalize(cross(helper, axis));
        let bitangent = cross(axis, tangent);
        // The gain falls as (r / d)^2 and so does the error of a coarser estimate: 32
        // directions within 2 radii of the centre, 8 within 4, 4 beyond (a sixteenth of the
        // sphere's radiance at most), where most pixels of the reach lie.
        var rings = BOUNCE_RINGS;
        var sectors = BOUNCE_SECTORS;
        if sin_a < 0.25 {
            rings = 1u;
            sectors = 4u;
        } else if sin_a < 0.5 {
            rings = 2u;
            sectors = 4u;
        }
        var cap = vec3<f32>(0.0);
        // Of the directions above the surface's horizon, those the scene lets through.
        var tried = 0u;
        var let_through = 0u;
        for (var k = 0u; k < rings * sectors; k = k + 1u) {
            // The midpoint of cell k: rings uniform in solid angle, sectors uniform in angle.
            let ring = k / sectors;
            let u = (f32(ring) + 0.5) / f32(rings);
            let cos_t = 1.0 - u * one_minus_cos;
            let sin_t = sqrt(u * one_minus_cos * (1.0 + cos_t));
            let phi = (f32(k % sectors) + 0.5 * f32(ring % 2u)) * (2.0 * PI / f32(sectors));
            let w = tangent * (sin_t * cos(phi)) + bitangent * (sin_t * sin(phi)) + axis * cos_t;
            let cos_p = dot(n, w);
            if cos_p <= 0.0 {
                continue;
            }
            // The sphere's nearer hit along w, and its normal there.
            let b = dot(to_sphere, w);
            let t = b - sqrt(max(r * r - (d * d - b * b), 0.0));
            // The scene may hide part of the cap (the room's furniture, the Cornell light's
            // panel a centimetre below the ceiling). (A cone traversal as the live objects'
            // area lights use cannot skip these rays here: the receiver's own triangle always
            // meets the cone at its apex.)
            tried += 1u;
            if !scene_lets_light(p, n, w, t, 0.0) {
                continue;
            }
            let_through += 1u;
            let m = normalize(p + t * w - sphere.xyz);
            cap += radiosity_lookup(i, m).rgb * cos_p;
        }
        let solid_angle = 2.0 * PI * one_minus_cos;
        let fade = 1.0 - smoothstep(0.75 * AO_REACH * r, AO_REACH * r, d);
        sum += cap * (solid_angle / f32(rings * sectors) * fade);
        // The lights' highlights, hidden by the scene as the diffuse directions are.
        if let_through > 0u {
            // A highlight covers few of the normals: 8 x 8 within 4 radii, 4 x 4 beyond.
            sum += glossy_cap(i, p, n, select(4u, 8u, sin_a >= 0.25)) * (f32(let_through) / f32(tried) * fade);
        }
    }
    return sum;
}

// What the shadow pass's occlusion of indirect light (shadows.wgsl, indirect_occlusion) got
// wrong at pixel `pixel` (surface point p, unit normal n, diffuse albedo `albedo`), in the
// image's units: it removes each sphere's weight `cos (r / d)^2` times the pixel's indirect
// light, as if the light hidden behind the sphere were the average light the surface receives
// (its indirect layer over its albedo). The light hidden is what the surface behind the sphere
// reflected, the image's radiance less emission where a march from p through the sphere's
// centre meets the pre-rendered scene (a Lambertian surface sends p what it sends the eye; an
// emitter's own light hidden is its light layer's share, already removed): the correction adds
// back `weight (indirect - albedo L_behind)` per sphere whose march finds that surface, nothing
// for the others.
fn occlusion_correction(pixel: vec2<i32>, p: vec3<f32>, n: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    let indirect = textureLoad(light_layers, pixel, i32(frame.layer_info.y), 0).rgb;
    // As far as any visible surface can be (the bounds of the visible surfaces' diagonal).
    let far = bitcast<f32>(frame.bounce.z);
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < min(frame.layer_info.w, 8u); i = i + 1u) {
        let sphere = frame.shadow_spheres[i];
        let to_sphere = sphere.xyz - p;
        let d = length(to_sphere);
        let r = sphere.w;
        if d <= r || d >= AO_REACH * r {
            continue;
        }
        let axis = to_sphere / d;
        let cos_s = dot(n, axis);
        if cos_s <= 0.0 || d + r >= far {
            continue;
        }
        let at = march_to_surface(p, axis, d + r, far);
        if at.x < 0 {
            continue;
        }
        // What that surface reflects, without what it emits (the light layers and the
        // indirect layer): an emitter's light hidden by the sphere is its light layer's share.
        var behind = vec3<f32>(0.0);
        for (var slice = 0u; slice <= frame.layer_info.y; slice = slice + 1u) {
            behind += textureLoad(light_layers, at, i32(slice), 0).rgb;
        }
        let weight = cos_s * (r / d) * (r / d) * (1.0 - smoothstep(0.75 * AO_REACH * r, AO_REACH * r, d));
        sum += weight * (indirect - albedo * behind);
    }
    return sum;
}

// A pre-rendered pixel as a receiver of indirect light: its albedo (from the sidecar layer
// `albedo_layer`), surface point and unit normal; `valid` is false where the pixel has no
// albedo, no surface or no normal, so it neither gains nor loses light.
struct Receiver {
    albedo: vec3<f32>,
    p: vec3<f32>,
    n: vec3<f32>,
    valid: bool,
}

fn receiver_at(pixel: vec2<i32>, albedo_layer: i32) -> Receiver {
    var r: Receiver;
    r.valid = false;
    r.albedo = textureLoad(light_layers, pixel, albedo_layer, 0).rgb;
    if all(r.albedo <= vec3<f32>(0.0)) {
        return r;
    }
    let centre = surface_point(pixel);
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    if centre.w < 0.5 || dot(n_raw, n_raw) <= 1e-12 {
        return r;
    }
    r.p = centre.xyz;
    r.n = normalize(n_raw);
    r.valid = true;
    return r;
}

// The backdrop after shadows plus what the live spheres reflect onto it (albedo / pi times the
// irradiance they send, from the sidecar's albedo and normal layers) and the correction of what
// they hide (occlusion_correction), in the image's units, never below zero. Pixels that change
// by nothing are discarded and keep their value bit for bit.
@fragment
fn fs_bounce(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let r = receiver_at(pixel, i32(frame.bounce.y));
    if !r.valid {
        discard;
    }
    return with_bounce_light(pixel, r, bounce_irradiance(r.p, r.n));
}

// with_bounce_light without the light a sphere hides taken from behind it (off by default): a
// moving frame's spreading pass takes it when that is off (compositor/reduced_gather.rs): lavapipe
// runs an untaken branch's code with its lanes off, each loop's body once, for every group of
// fragments (what that costs was measured while lavapipe still compiled each pipeline again at
// every bind (docs/viewer-frame-time.md, "The leak fixed")).
fn with_bounce_light_alone(pixel: vec2<i32>, r: Receiver, irradiance: vec3<f32>) -> vec4<f32> {
    let added = r.albedo / PI * irradiance * frame.tone.x;
    if all(added == vec3<f32>(0.0)) {
        discard;
    }
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    return vec4<f32>(max(before.rgb + added, vec3<f32>(0.0)), before.a);
}

// The frame's colour at `pixel` with receiver `r`'s bounce light added, from the spheres'
// `irradiance` at it (per unit albedo, times pi), and with the light a sphere hides taken from
// behind it when that is on; a pixel that changes by nothing is discarded and keeps its value.
fn with_bounce_light(pixel: vec2<i32>, r: Receiver, irradiance: vec3<f32>) -> vec4<f32> {
    var added = r.albedo / PI * irradiance * frame.tone.x;
    if frame.bounce.w == 1u {
        added += occlusion_correction(pixel, r.p, r.n, r.albedo);
    }
    if all(added == vec3<f32>(0.0)) {
        discard;
    }
    let before = textureLoad(backdrop_shadowed, pixel, 0);
    return vec4<f32>(max(before.rgb + added, vec3<f32>(0.0)), before.a);
}

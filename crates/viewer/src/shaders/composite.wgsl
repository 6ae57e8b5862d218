// Compositing of the pre-rendered image with live objects. shadow_loss.wgsl and shadows.wgsl
// are appended to this file (compositor/mod.rs COMPOSITE_WGSL), and bounce.wgsl.
//
// Spaces: raster (pixels, origin top-left, y down; a fragment's position.xy is its pixel
// centre), camera (RenderMan's left-handed camera space, +z forward) and wgpu clip space. All
// live geometry arrives in camera space (moved there on the CPU in f64), lights too.

const MAX_LIGHTS: u32 = 16u;
const PI: f32 = 3.14159265358979;

const LIGHT_AMBIENT: u32 = 0u;
const LIGHT_DISTANT: u32 = 1u;
const LIGHT_POINT: u32 = 2u;
const LIGHT_SPOT: u32 = 3u;
const LIGHT_AREA: u32 = 4u;

struct Light {
    // xyz: camera-space position; w: kind.
    position: vec4<f32>,
    // xyz: distant: direction of travel; spot: axis; area: emitter normal. w: area two-sided.
    direction: vec4<f32>,
    // rgb: intensity * colour (area: radiance * area); w: area light has a normal (1) or not.
    colour: vec4<f32>,
    // spot: cos(cone), cos(cone - delta), beam distribution; area: rgb the radiance each emitter
    // sample of the light layers carries.
    params: vec4<f32>,
}

struct Material {
    // rgb: Cs; w: 1 when unlit.
    colour: vec4<f32>,
    // Ka, Kd, Ks, roughness.
    coefficients: vec4<f32>,
    // rgb: specular colour; w: the reflection probes' mip level for the roughness.
    specular_colour: vec4<f32>,
    // The Blinn lobe's directional albedo at cos_o = max(i / 15, 1e-3), i = 0..16.
    albedo: array<vec4<f32>, 4>,
}

struct Frame {
    clip_from_camera: mat4x4<f32>,
    // The paper's point-cloud matrix: raster x, y to clip space, z passed through.
    clip_from_raster: mat4x4<f32>,
    // left, right, bottom, top.
    screen_window: vec4<f32>,
    // width, height, tan(fov / 2) (0 when orthographic), 1 when perspective.
    raster: vec4<f32>,
    // x: scale from radiance to the image's units (Exposure's gain, which lrt-depth applies);
    // y: 1 in a moving frame whose cursor sphere is shaded from its radiosity map (shade_moving).
    tone: vec4<f32>,
    // light count, shadow on, sphere on, irradiance probes on.
    counts: vec4<u32>,
    // Shadow light: xyz camera-space position (w = 1) or direction of travel (w = 0).
    shadow_light: vec4<f32>,
    // Shadow light radius, shadow strength.
    shadow_params: vec4<f32>,
    // Sphere: camera-space centre, radius.
    sphere: vec4<f32>,
    sphere_material: Material,
    // Light layers: 1 when bound, indirect slice, camera-space normal slice, shadow spheres.
    layer_info: vec4<u32>,
    // Camera-space centre and radius of the spheres casting shadows with the layers.
    shadow_spheres: array<vec4<f32>, 8>,
    // Rotation from camera to world space (normals for the probes' SH, which is world space).
    world_from_camera: mat4x4<f32>,
    // Per light: layer slice (0xffffffff: none), first area sample, sample count.
    shadow_slots: array<vec4<u32>, MAX_LIGHTS>,
    // Camera space to world space for points.
    world_from_camera_point: mat4x4<f32>,
    // The reflection probes' grid: origin (w = 1 when bound), spacing, counts.
    reflection_origin: vec4<f32>,
    reflection_spacing: vec4<f32>,
    reflection_counts: vec4<u32>,
    // The irradiance probes' grid: origin (w = 1 when bound), spacing, counts.
    irradiance_origin: vec4<f32>,
    irradiance_spacing: vec4<f32>,
    irradiance_counts: vec4<u32>,
    lights: array<Light, MAX_LIGHTS>,
    // Shadow-ray hierarchies (scene_visibility.wgsl): the tessellated scene's and the live
    // meshes' (first node, first triangle, node count), the live meshes' bounding sphere.
    scene_occluders: vec4<u32>,
    live_occluders: vec4<u32>,
    live_occluder_bound: vec4<f32>,
    // The light live spheres reflect onto the scene (bounce.wgsl): 1 when on, the albedo
    // layer's slice, the visible surfaces' bounding diagonal (f32 bits), 1 when the occlusion
    // of indirect light is corrected with what lies behind the spheres.
    bounce: vec4<u32>,
    // The light the shadows take from the rest of the scene (shadow_bounce.wgsl): 1 when on,
    // the shadows' scissor (x | y << 16, width | height << 16), the albedo layer's slice.
    shadow_bounce: vec4<u32>,
    // The live spheres seen in the scene's specular reflections (bounce.wgsl): 1 when on, the
    // reflectance layer's slice, the reflected layer's slice.
    reflection: vec4<u32>,
    // The points of a pixel's footprint (offset in pixels from its centre, the pixel filter's
    // weight, the quadrant whose shadow ray stands for it) over which the lights' direct light
    // on live objects the eye sees is integrated, and the quadrants' shadow-ray offsets
    // (pixel_filter.rs footprint, footprint_rays).
    footprint: array<vec4<f32>, 16>,
    footprint_rays: array<vec4<f32>, 4>,
}

const NO_LAYER: u32 = 0xffffffffu;
const MAX_AREA_SAMPLES: u32 = 256u;
// How far from the sphere's centre, in radii, its occlusion of indirect light reaches
// (compositor/shadows.rs AO_REACH).
const AO_REACH: f32 = 8.0;

struct AreaSamples {
    // Per sample: camera-space position and area, then unit normal and two-sidedness.
    samples: array<vec4<f32>, 512>,
}

// The frame's parameters, like every buffer the viewer's shaders read, are a read-only storage
// buffer, not a uniform one: lavapipe of Mesa 22.3 specialises a pipeline on its uniform
// values when that halves its code, then compiles the pipeline again at every bind without
// freeing it (ARCHITECTURE.md, "No uniform buffers").
@group(0) @binding(0) var<storage, read> frame: Frame;
@group(0) @binding(1) var backdrop_colour: texture_2d<f32>;
@group(0) @binding(2) var backdrop_window_depth: texture_2d<f32>;
@group(0) @binding(3) var backdrop_radial_depth: texture_2d<f32>;
@group(0) @binding(4) var light_layers: texture_2d_array<f32>;
@group(0) @binding(5) var<storage, read> area_samples: AreaSamples;
// The reflection probes: prefiltered radiance (a layer per probe, a mip level per roughness
// level) and the distance to the first surface per level-0 texel.
@group(0) @binding(6) var reflection_radiance: texture_2d_array<f32>;
@group(0) @binding(7) var reflection_distance: texture_2d_array<f32>;
@group(0) @binding(8) var reflection_sampler: sampler;
// The irradiance probes: 9 SH coefficients (rgb) per probe, the scene's indirect light, and
// 16x16 visibility texels (mean, mean squared distance) per probe.
@group(0) @binding(9) var<storage, read> irradiance_sh: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> irradiance_visibility: array<vec2<f32>>;
// The backdrop after the live objects' shadows (a copy of the frame before live objects are
// drawn): with `backdrop_colour`, the light the shadows took from each pixel's surface.
@group(0) @binding(11) var backdrop_shadowed: texture_2d<f32>;
// The caustic light the live objects block, per pixel (caustic_shadow.rs); a 1x1 placeholder
// without the renderer's caustic photons.
@group(0) @binding(30) var caustic_loss: texture_2d<f32>;

// The backdrop's colour less the caustic light live objects block: exactly `colour` where
// they block none (x - 0 is x), and never below zero.
fn caustic_removed(pixel: vec2<i32>, colour: vec4<f32>) -> vec4<f32> {
    if textureDimensions(caustic_loss).x == 1u {
        return colour;
    }
    let loss = textureLoad(caustic_loss, pixel, 0).rgb;
    return vec4<f32>(colour.rgb - min(loss, max(colour.rgb, vec3<f32>(0.0))), colour.a);
}

struct MeshUniform {
    camera_from_object: mat4x4<f32>,
    normal_from_object: mat4x4<f32>,
    material: Material,
    // x: the mesh's row in the own-shadow loss maps when it is a sphere, else -1.
    loss_map: vec4<i32>,
}

@group(1) @binding(0) var<storage, read> mesh: MeshUniform;

struct BackdropOut {
    @location(0) colour: vec4<f32>,
    @location(1) mask: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

struct LiveOut {
    @location(0) colour: vec4<f32>,
    @location(1) mask: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

// ---------------------------------------------------------------------------------------------
// The camera: the same ray as depth_remap::Camera::ray_through_raster.

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

fn ray_through_raster(raster: vec2<f32>) -> Ray {
    let sw = frame.screen_window;
    let ndc = raster / frame.raster.xy;
    let s = vec2<f32>(sw.x + ndc.x * (sw.y - sw.x), sw.w - ndc.y * (sw.w - sw.z));
    if frame.raster.w > 0.5 {
        let t = frame.raster.z;
        return Ray(vec3<f32>(0.0), normalize(vec3<f32>(s.x * t, s.y * t, 1.0)));
    }
    return Ray(vec3<f32>(s, 0.0), vec3<f32>(0.0, 0.0, 1.0));
}

fn window_depth(p_camera: vec3<f32>) -> f32 {
    let clip = frame.clip_from_camera * vec4<f32>(p_camera, 1.0);
    return clip.z / clip.w;
}

// ---------------------------------------------------------------------------------------------
// Full-screen triangle.

@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(index & 1u) * 4 - 1);
    let y = f32(i32(index >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.5, 1.0);
}

// Backdrop, Lawlor's way: one fragment per pixel, its depth taken from the converted table.
@fragment
fn fs_backdrop_fullscreen(@builtin(position) position: vec4<f32>) -> BackdropOut {
    let pixel = vec2<i32>(position.xy);
    var out: BackdropOut;
    out.colour = caustic_removed(pixel, textureLoad(backdrop_colour, pixel, 0));
    out.mask = vec4<f32>(0.0);
    out.depth = textureLoad(backdrop_window_depth, pixel, 0).r;
    return out;
}

// ---------------------------------------------------------------------------------------------
// Backdrop, the paper's way: one point per pixel at (i + 0.5, j + 0.5, window depth), through
// the orthographic matrix that passes z through. The point's depth also travels as a flat
// varying written as the fragment depth: GL backends remap clip z to [-1, 1] and back, which
// loses up to 16 ulps; the varying keeps the table's value bit for bit on every backend.

struct PointOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) colour: vec4<f32>,
    @location(1) @interpolate(flat) depth: f32,
}

@vertex
fn vs_backdrop_points(@location(0) raster_depth: vec3<f32>, @location(1) colour: vec4<f32>) -> PointOut {
    var out: PointOut;
    out.position = frame.clip_from_raster * vec4<f32>(raster_depth, 1.0);
    out.colour = colour;
    out.depth = out.position.z / out.position.w;
    return out;
}

@fragment
fn fs_backdrop_points(in: PointOut) -> BackdropOut {
    return BackdropOut(caustic_removed(vec2<i32>(in.position.xy), in.colour), vec4<f32>(0.0), in.depth);
}

// ---------------------------------------------------------------------------------------------
// Lighting (physical units: irradiance E per light; Lambert albedo / pi; normalised Blinn-Phong).
// The baked probes' light is in probes.wgsl.

// The ray tracer's Blinn lobe times cos(theta_l) (raytracer::bsdf: Blinn's D with V-cavity
// shadowing, D G / (4 cos_o cos_l), no Fresnel: Ks plays its part).
fn blinn_lobe_cos(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, exponent: f32) -> f32 {
    let h = normalize(l + v);
    let cos_h = dot(n, h);
    let cos_o = max(dot(n, v), 1e-3);
    let cos_l = dot(n, l);
    let o_dot_h = abs(dot(v, h));
    if cos_h <= 0.0 || cos_l <= 0.0 || o_dot_h == 0.0 {
        return 0.0;
    }
    let d = (exponent + 2.0) / (2.0 * PI) * pow(cos_h, exponent);
    let g = min(min(2.0 * cos_h * cos_o / o_dot_h, 2.0 * cos_h * cos_l / o_dot_h), 1.0);
    return d * g / (4.0 * cos_o);
}

// An area light's sample `index` from the light layers (compositor/lighting.rs) seen from p:
// the unit direction toward it, the squared distance, the emitter's cosine toward p (either
// side's for a two-sided light) and the sample's weight.
struct AreaSampleToward {
    l: vec3<f32>,
    dist2: f32,
    cos_e: f32,
    weight: f32,
}

fn area_sample_toward(index: u32, p: vec3<f32>) -> AreaSampleToward {
    let sample = area_samples.samples[2u * index];
    let sample_normal = area_samples.samples[2u * index + 1u];
    let to_sample = sample.xyz - p;
    let dist2 = max(dot(to_sample, to_sample), 1e-30);
    let l = to_sample * inverseSqrt(dist2);
    let c = dot(sample_normal.xyz, -l);
    return AreaSampleToward(l, dist2, select(max(c, 0.0), abs(c), sample_normal.w > 0.5), sample.w);
}

// The irradiance light k (not ambient) brings to camera-space point q, unshadowed, the unit
// direction toward it and its distance (3e38 for a distant light): point and spot lights as
// the ray tracer takes them (the spot's cone and falloff), an area light as a point at its
// centroid with its intensity toward q (`direct_light` integrates the area light's samples
// instead where the light layers hold them).
struct LightToward {
    e: vec3<f32>,
    l: vec3<f32>,
    distance: f32,
}

fn light_toward(k: u32, q: vec3<f32>) -> LightToward {
    let light = frame.lights[k];
    let kind = u32(light.position.w + 0.5);
    if kind == LIGHT_DISTANT {
        return LightToward(light.colour.rgb, -light.direction.xyz, 3.0e38);
    }
    let to_light = light.position.xyz - q;
    let dist2 = max(dot(to_light, to_light), 1e-30);
    let l = to_light * inverseSqrt(dist2);
    var intensity = light.colour.rgb;
    if kind == LIGHT_SPOT {
        let cos_angle = dot(-l, light.direction.xyz);
        intensity *= pow(max(cos_angle, 0.0), light.params.z) * smoothstep(light.params.x, light.params.y, cos_angle);
    } else if kind == LIGHT_AREA {
        var lobe = 0.25;
        if light.colour.w > 0.5 {
            let c = dot(light.direction.xyz, -l);
            lobe = select(max(c, 0.0), abs(c), light.direction.w > 0.5);
        }
        intensity *= lobe;
    }
    return LightToward(intensity / dist2, l, sqrt(dist2));
}

// The footprint of the pixel being shaded on the live surface the eye sees there: the surface
// to first order around the hit at the pixel centre (point p, unnormalised normal n, their
// changes per pixel along raster x and y). The ray tracer's pixel is its filter's weighted mean
// over this footprint, and a spot light's cone edge, a scene object's shadow edge or a small
// highlight can cross a pixel: shade_with integrates the point, distant and spot lights over it
// (direct_light_over). Set by the entry points that shade what the eye sees at a pixel centre
// (fs_sphere, fs_mesh); `on` false everywhere else, e.g. where a surface is shaded as seen in
// a mirror or for the bounce light, whose directions a pixel's footprint does not describe.
struct PixelFootprint {
    on: bool,
    raster: vec2<f32>,
    p: vec3<f32>,
    dp_dx: vec3<f32>,
    dp_dy: vec3<f32>,
    n: vec3<f32>,
    dn_dx: vec3<f32>,
    dn_dy: vec3<f32>,
}

var<private> pixel_footprint: PixelFootprint;

// Where the ray through raster position `at` meets the plane through p with normal n, less p:
// a neighbouring pixel's point on the surface to first order. Rays grazing the plane are held
// to 8 pixels' width at p's distance, as beyond that the first order says nothing.
fn tangent_step(at: vec2<f32>, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let ray = ray_through_raster(at);
    let along = dot(ray.direction, n);
    let t = dot(p - ray.origin, n) / select(along, -1e-6, abs(along) < 1e-6);
    let step = ray.origin + max(t, 0.0) * ray.direction - p;
    let pixel = max(length(p - ray.origin), 1e-6) * 2.0 * max(frame.raster.z, 1e-6) / frame.raster.y;
    let limit = 8.0 * select(pixel, (frame.screen_window.y - frame.screen_window.x) / frame.raster.x, frame.raster.w < 0.5);
    return step * min(1.0, limit / max(length(step), 1e-30));
}

// The footprint of a sphere (camera-space centre and radius) hit at p through pixel centre
// `raster`: its normal is (p - c) / r everywhere, so its change is the point's over r.
fn sphere_footprint(raster: vec2<f32>, p: vec3<f32>, sphere: vec4<f32>) -> PixelFootprint {
    let n = (p - sphere.xyz) / sphere.w;
    let dp_dx = tangent_step(raster + vec2<f32>(1.0, 0.0), p, n);
    let dp_dy = tangent_step(raster + vec2<f32>(0.0, 1.0), p, n);
    return PixelFootprint(true, raster, p, dp_dx, dp_dy, n, dp_dx / sphere.w, dp_dy / sphere.w);
}

// The footprint's point at `offset` pixels from its centre: its point, unit normal facing the same side
// as `n` (the shaded side), and unit direction toward the eye.
struct PixelFootprintPoint {
    p: vec3<f32>,
    n: vec3<f32>,
    v: vec3<f32>,
}

fn pixel_footprint_point(offset: vec2<f32>, n: vec3<f32>) -> PixelFootprintPoint {
    let f = pixel_footprint;
    let p = f.p + offset.x * f.dp_dx + offset.y * f.dp_dy;
    var m = normalize(f.n + offset.x * f.dn_dx + offset.y * f.dn_dy);
    m = select(m, -m, dot(m, n) < 0.0);
    let ray = ray_through_raster(f.raster + offset);
    return PixelFootprintPoint(p, m, -normalize(p - ray.origin));
}

// The lights' direct light at p (normal n, facing v): ambient, the irradiance the diffuse lobe
// integrates (with the scene's shadows) and the Blinn lobe's (`exponent`) radiance per unit Ks,
// the latter only `with_specular`.
struct DirectLight {
    ambient: vec3<f32>,
    diffuse: vec3<f32>,
    specular: vec3<f32>,
}

fn direct_light(p: vec3<f32>, n: vec3<f32>, v: vec3<f32>, exponent: f32, with_specular: bool) -> DirectLight {
    return direct_light_with(p, n, v, exponent, with_specular, true);
}

// direct_light, with the scene's shadow rays (`shadowed`) or without (every light reaching p).
fn direct_light_with(p: vec3<f32>, n: vec3<f32>, v: vec3<f32>, exponent: f32, with_specular: bool, shadowed: bool) -> DirectLight {
    return direct_light_over(p, n, v, exponent, with_specular, shadowed, false);
}

// direct_light_with; `over_footprint`: the point, distant and spot lights integrated over the
// pixel's footprint (pixel_footprint, whose centre p is), their unshadowed light at its 16
// points and the scene's shadows from one ray per quadrant, as the ray tracer's pixel filter
// averages its samples. Area lights stay at p: their light varies slowly over a pixel.
fn direct_light_over(p: vec3<f32>, n: vec3<f32>, v: vec3<f32>, exponent: f32, with_specular: bool, shadowed: bool, over_footprint: bool) -> DirectLight {
    var ambient = vec3<f32>(0.0);
    var diffuse = vec3<f32>(0.0);
    var specular = vec3<f32>(0.0);
    let count = min(frame.counts.x, MAX_LIGHTS);
    // No `continue` in these loops: on lavapipe a `continue` after the scene's shadow rays lost
    // fragments' remaining iterations (docs/viewer-specular.md, "the shading loop's lost
    // directions").
    for (var k = 0u; k < count; k++) {
        let light = frame.lights[k];
        let kind = u32(light.position.w + 0.5);
        // An area light with samples from the light layers is integrated over them, as the
        // ray tracer integrates it (`A cos_e cos_l / d^2` per sample), not seen as one point.
        let slot = frame.shadow_slots[k];
        if kind == LIGHT_AMBIENT {
            ambient += light.colour.rgb;
        } else if kind == LIGHT_AREA && frame.layer_info.x == 1u && slot.x != NO_LAYER && slot.z > 0u {
            let sample_count = min(slot.z, MAX_AREA_SAMPLES);
            // The radiance each sample carries (compositor/lighting.rs).
            let radiance = light.params.rgb;
            var clear = 1.0;
            var leaves = ConeLeaves(array<u32, CONE_LEAVES>(0u, 0u, 0u, 0u), 0u, false);
            if shadowed {
                clear = scene_clear_toward(p, n, light.position.xyz, bitcast<f32>(slot.w));
                leaves = scene_leaves_toward(p, n, light.position.xyz, bitcast<f32>(slot.w));
            }
            for (var i = 0u; i < sample_count; i++) {
                let s = area_sample_toward(slot.y + i, p);
                let l = s.l;
                let n_dot_l = dot(n, l);
                var lit = n_dot_l > 0.0 && s.cos_e > 0.0;
                if lit && shadowed {
                    lit = scene_lets_light_among(p, n, l, sqrt(s.dist2), clear, leaves);
                }
                if lit {
                    let e = radiance * (s.weight * s.cos_e / s.dist2);
                    diffuse += e * n_dot_l;
                    if with_specular {
                        specular += e * blinn_lobe_cos(n, v, l, exponent);
                    }
                }
            }
        } else if over_footprint {
            // Which quadrants' shadow rays meet no scene surface on the way to the light (all
            // without `shadowed`). Only the scene's occluders count here: whether the light's
            // cone and the surface's cosine let it reach is each point's own (a quadrant's ray
            // can leave the cone where some of its points are inside).
            var open = array<f32, 4>(1.0, 1.0, 1.0, 1.0);
            if shadowed {
                for (var q = 0u; q < 4u; q++) {
                    let at = pixel_footprint_point(frame.footprint_rays[q].xy, n);
                    let toward = light_toward(k, at.p);
                    open[q] = select(0.0, 1.0, scene_lets_light(at.p, at.n, toward.l, toward.distance, 0.0));
                }
            }
            for (var i = 0u; i < 16u; i++) {
                let point = frame.footprint[i];
                let at = pixel_footprint_point(point.xy, n);
                let toward = light_toward(k, at.p);
                let n_dot_l = dot(at.n, toward.l);
                let weight = point.z * open[u32(point.w + 0.5)];
                if n_dot_l > 0.0 {
                    diffuse += weight * toward.e * n_dot_l;
                    if with_specular {
                        specular += weight * toward.e * blinn_lobe_cos(at.n, at.v, toward.l, exponent);
                    }
                }
            }
        } else {
            let toward = light_toward(k, p);
            let l = toward.l;
            let e = toward.e;
            let n_dot_l = dot(n, l);
            var lit = n_dot_l > 0.0 && !all(e <= vec3<f32>(0.0));
            if lit && shadowed {
                lit = scene_lets_light(p, n, l, toward.distance, 0.0);
            }
            if lit {
                diffuse += e * n_dot_l;
                if with_specular {
                    specular += e * blinn_lobe_cos(n, v, l, exponent);
                }
            }
        }
    }
    return DirectLight(ambient, diffuse, specular);
}

// The probes' indirect irradiance at camera-space p with unit normal n (zero without probes),
// less what the live objects' shadows took from it (`loss`, radiance units). Live surfaces
// take live_probe_irradiance (near_field.wgsl), which adds the scene surfaces near them.
fn probe_irradiance(p: vec3<f32>, n: vec3<f32>, loss: vec3<f32>) -> vec3<f32> {
    if frame.counts.w != 1u {
        return vec3<f32>(0.0);
    }
    let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
    let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
    return max(field_irradiance(p_world, n_world) - loss, vec3<f32>(0.0));
}

// The radiance a Lambertian live surface at p with unit normal n sends in every direction: the
// diffuse and ambient terms of `shade`, without the view-dependent normal flip (compositor's
// bounce light reads it on the sphere's far side too).
fn diffuse_radiance(material: Material, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    if material.colour.w > 0.5 {
        return material.colour.rgb;
    }
    return diffuse_radiance_lit(material, p, n, direct_light(p, n, n, 1.0, false));
}

// diffuse_radiance of a lit material, with the lights' direct light at p already integrated
// (`lit`: direct_light(p, n, n, 1.0, false)).
fn diffuse_radiance_lit(material: Material, p: vec3<f32>, n: vec3<f32>, lit: DirectLight) -> vec3<f32> {
    return diffuse_radiance_lit_with(material, p, n, lit, true);
}

// diffuse_radiance_lit; the own-shadow loss where no loss map serves p gathered only with
// `gather_loss` (own_shadow_loss_with).
fn diffuse_radiance_lit_with(material: Material, p: vec3<f32>, n: vec3<f32>, lit: DirectLight, gather_loss: bool) -> vec3<f32> {
    var loss = vec3<f32>(0.0);
    if frame.counts.y == 1u && frame.counts.w == 1u {
        loss = own_shadow_loss_with(p, n, gather_loss) / max(frame.tone.x, 1e-30);
    }
    let diffuse = lit.diffuse + live_probe_irradiance(p, n, loss);
    return material.colour.rgb * (material.coefficients.x * lit.ambient + material.coefficients.y / PI * diffuse);
}

// Seen in a mirror, glass or metal (the passes' several shaded directions a pixel), a glossy
// surface's lobe directions meet the scene on the reflection probes' distance maps; live
// surfaces the eye sees directly (shade_seen, shade_cursor_sphere) trace them through the
// scene's triangles (glossy_reflection's `traced_hits`) when the scene's materials are bound
// (`hybrid-view` binds them unless `--no-near-field`): spheres read them from their near-field
// maps (glossy_lobe), drawn when their inputs change, live meshes trace them per fragment.
fn shade(material: Material, p: vec3<f32>, n_in: vec3<f32>, view_dir: vec3<f32>) -> vec3<f32> {
    return shade_with(material, p, n_in, view_dir, -1, false);
}

// shade for a live surface the eye sees directly (a live mesh or sphere).
fn shade_seen(material: Material, p: vec3<f32>, n_in: vec3<f32>, view_dir: vec3<f32>) -> vec3<f32> {
    return shade_with(material, p, n_in, view_dir, -1, true);
}

// The cursor sphere's radiance at p (unit outward normal n) seen along view_dir: in a moving
// frame whose radiosity maps hold it (frame.tone.y, compositor/frame.rs) and seen from outside,
// from its map (shade_with's `map_row`), or where its radiance map is drawn from that (tone.y
// 2), from the radiance map (cursor_radiance.wgsl); else exactly.
fn shade_cursor_sphere(p: vec3<f32>, n: vec3<f32>, view_dir: vec3<f32>) -> vec3<f32> {
    let outside = dot(n, view_dir) < 0.0;
    if frame.tone.y > 1.5 && outside {
        return cursor_radiance_lookup(n);
    }
    let map_row = select(-1, 0, frame.tone.y > 0.5 && outside);
    return shade_with(frame.sphere_material, p, n, view_dir, map_row, true);
}

// shade. With `map_row` >= 0 (a moving frame: a sphere seen from outside, whose row of the
// radiosity maps is drawn this frame: the cursor sphere's row 0, or a sphere seen in a glossy
// lobe) the costliest terms come from the sphere's radiosity map, drawn this frame by the same
// diffuse_radiance: its diffuse and ambient radiance (bilinear between the map's
// texels), and its lights' highlights integrated without the scene's shadow rays, scaled by
// the share of the lights' light the scene lets reach p (the map's alpha); the reflection
// probes' part is as shade's.
fn shade_with(material: Material, p: vec3<f32>, n_in: vec3<f32>, view_dir: vec3<f32>, map_row: i32, traced: bool) -> vec3<f32> {
    if material.colour.w > 0.5 {
        return material.colour.rgb;
    }
    // Two-sided: the normal facing the viewer.
    let v = -view_dir;
    let n = select(n_in, -n_in, dot(n_in, v) < 0.0);
    let ka = material.coefficients.x;
    let kd = material.coefficients.y;
    let ks = material.coefficients.z;
    let exponent = clamp(1.0 / max(material.coefficients.w, 1e-4), 1.0, 10000.0);
    // The reflection probes hold the scene's radiance without the lights' emission (the bake
    // leaves the emitters it sees directly out): every light's glossy reflection is added here.
    let reflections = frame.reflection_origin.w > 0.5 && ks != 0.0;
    let from_map = map_row >= 0;
    var map = vec4<f32>(0.0);
    if from_map {
        map = radiosity_lookup(u32(map_row), n);
    }
    // From the map, only the highlights need the lights.
    var lit = DirectLight(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    if !from_map || ks != 0.0 {
        // Only what the eye sees at the pixel, where its footprint is set, is integrated
        // over the footprint.
        let over_footprint = pixel_footprint.on && all(p == pixel_footprint.p);
        lit = direct_light_over(p, n, v, exponent, true, !from_map, over_footprint && !from_map);
    }
    var diffuse = lit.diffuse;
    var specular = lit.specular * select(1.0, map.a, from_map);
    // With the renderer's irradiance probes, the scene's indirect light at this fragment
    // (compositor/irradiance.rs) joins the lights', less what the shadows took (the probes saw
    // the scene before the live objects' shadows took light from it).
    if !from_map {
        var loss = vec3<f32>(0.0);
        if frame.counts.y == 1u && frame.counts.w == 1u {
            loss = own_shadow_loss(p, n) / max(frame.tone.x, 1e-30);
        }
        diffuse += live_probe_irradiance(p, n, loss);
    }
    // With the reflection probes, the scene's radiance averaged over the lobe's own directions
    // times the lobe's albedo, less what the shadows took.
    if reflections {
        let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
        let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
        let v_world = normalize((frame.world_from_camera * vec4<f32>(v, 0.0)).xyz);
        let reflected = blinn_albedo(material, dot(n, v))
            * glossy_lobe(p_world, n, n_world, v_world, exponent, traced && scene_materials[0].x > 0.5);
        specular += reflected;
    }
    let glossy = material.specular_colour.rgb * ks * specular;
    if from_map {
        // The map's diffuse_radiance: the ambient, the lights' and the probes' diffuse terms.
        return map.rgb + glossy;
    }
    let cs = material.colour.rgb;
    return cs * (ka * lit.ambient + kd / PI * diffuse) + glossy;
}

// Radiance in the image's own units, into the linear frame (the encode pass displays it).
fn to_image_units(radiance: vec3<f32>) -> vec4<f32> {
    return vec4<f32>(max(radiance * frame.tone.x, vec3<f32>(0.0)), 1.0);
}

// ---------------------------------------------------------------------------------------------
// The cursor sphere: a ray-cast impostor inside its camera-space bounding cube. Back faces are
// drawn so the cube still covers the sphere when the eye is inside the cube; the cube's clip z
// is held mid-range so only the eye plane (w > 0) clips it, never the near or far planes.

struct SphereVertexOut {
    @builtin(position) position: vec4<f32>,
}

@vertex
fn vs_sphere(@builtin(vertex_index) index: u32) -> SphereVertexOut {
    var out: SphereVertexOut;
    out.position = sphere_cube_clip(index, frame.sphere);
    return out;
}

// Corner `index` (0 to 35) of the bounding cube of `sphere` (camera-space centre, radius).
fn sphere_cube_clip(index: u32, sphere: vec4<f32>) -> vec4<f32> {
    // 12 triangles of a unit cube, wound so that the outside is the front in raster space.
    var corners = array<vec3<f32>, 8>(
        vec3<f32>(-1.0, -1.0, -1.0), vec3<f32>(1.0, -1.0, -1.0), vec3<f32>(1.0, 1.0, -1.0), vec3<f32>(-1.0, 1.0, -1.0),
        vec3<f32>(-1.0, -1.0, 1.0), vec3<f32>(1.0, -1.0, 1.0), vec3<f32>(1.0, 1.0, 1.0), vec3<f32>(-1.0, 1.0, 1.0),
    );
    var indices = array<u32, 36>(
        0u, 1u, 2u, 0u, 2u, 3u, // z = -1
        5u, 4u, 7u, 5u, 7u, 6u, // z = +1
        4u, 0u, 3u, 4u, 3u, 7u, // x = -1
        1u, 5u, 6u, 1u, 6u, 2u, // x = +1
        3u, 2u, 6u, 3u, 6u, 7u, // y = +1
        4u, 5u, 1u, 4u, 1u, 0u, // y = -1
    );
    let corner = corners[indices[index]];
    // A slightly larger cube so that rounding never trims the silhouette.
    let p = sphere.xyz + corner * sphere.w * 1.001;
    var clip = frame.clip_from_camera * vec4<f32>(p, 1.0);
    clip.z = 0.5 * clip.w;
    return clip;
}

// The sphere's nearest visible hit along the ray through `raster`: camera-space point and
// window depth, w < 0 when the ray misses it or its hits lie outside the depth range.
fn sphere_hit(raster: vec2<f32>) -> vec4<f32> {
    return sphere_hit_of(raster, frame.sphere);
}

fn sphere_hit_of(raster: vec2<f32>, sphere: vec4<f32>) -> vec4<f32> {
    let ray = ray_through_raster(raster);
    let c = sphere.xyz;
    let r = sphere.w;
    // Numerically robust ray-sphere intersection (Haines et al., Ray Tracing Gems, ch. 7).
    let f = ray.origin - c;
    let b = dot(f, ray.direction);
    let q_perp = f - b * ray.direction;
    let disc = r * r - dot(q_perp, q_perp);
    if disc < 0.0 {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let root = sqrt(disc);
    let q = -b - select(-root, root, b >= 0.0);
    let c_term = dot(f, f) - r * r;
    var t0 = q;
    var t1 = q;
    if q != 0.0 {
        t0 = c_term / q;
    }
    let t_near = min(t0, t1);
    let t_far = max(t0, t1);
    // The nearest hit in front of the eye whose depth is inside the depth range.
    var t = t_near;
    var p = ray.origin + t * ray.direction;
    var depth = window_depth(p);
    if t <= 0.0 || !(depth >= 0.0 && depth <= 1.0) {
        t = t_far;
        p = ray.origin + t * ray.direction;
        depth = window_depth(p);
        if t <= 0.0 || !(depth >= 0.0 && depth <= 1.0) {
            return vec4<f32>(0.0, 0.0, 0.0, -1.0);
        }
    }
    return vec4<f32>(p, depth);
}

@fragment
fn fs_sphere(@builtin(position) position: vec4<f32>) -> LiveOut {
    let hit = sphere_hit(position.xy);
    if hit.w < 0.0 {
        discard;
    }
    let p = hit.xyz;
    let n = (p - frame.sphere.xyz) / frame.sphere.w;
    loss_map_row = 0;
    pixel_footprint = sphere_footprint(position.xy, p, frame.sphere);
    var out: LiveOut;
    out.colour = to_image_units(shade_cursor_sphere(p, n, ray_through_raster(position.xy).direction));
    out.mask = vec4<f32>(1.0);
    out.depth = hit.w;
    return out;
}

// ---------------------------------------------------------------------------------------------
// Live meshes, with the RIB camera's projection.

struct MeshVertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) p_camera: vec3<f32>,
    @location(1) n_camera: vec3<f32>,
}

@vertex
fn vs_mesh(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>) -> MeshVertexOut {
    let p = mesh.camera_from_object * vec4<f32>(position, 1.0);
    var out: MeshVertexOut;
    out.position = frame.clip_from_camera * p;
    out.p_camera = p.xyz;
    out.n_camera = (mesh.normal_from_object * vec4<f32>(normal, 0.0)).xyz;
    return out;
}

struct MeshFragmentOut {
    @location(0) colour: vec4<f32>,
    @location(1) mask: vec4<f32>,
}

fn mesh_colour(in: MeshVertexOut) -> vec4<f32> {
    let ray = ray_through_raster(in.position.xy);
    let n = normalize(in.n_camera);
    loss_map_row = mesh.loss_map.x;
    return to_image_units(shade_seen(mesh.material, in.p_camera, n, ray.direction));
}

@fragment
fn fs_mesh(in: MeshVertexOut) -> MeshFragmentOut {
    // The footprint from the interpolated point's and normal's changes across the pixel quad
    // (uniform control flow here, as derivatives need).
    let dp_dx = dpdxFine(in.p_camera);
    let dp_dy = dpdyFine(in.p_camera);
    let dn_dx = dpdxFine(in.n_camera);
    let dn_dy = dpdyFine(in.n_camera);
    let n = normalize(in.n_camera);
    // The normal's change, for the unit normal (the varying is not normalised).
    let scale = 1.0 / max(length(in.n_camera), 1e-30);
    pixel_footprint = PixelFootprint(true, in.position.xy, in.p_camera, dp_dx, dp_dy, n, dn_dx * scale, dn_dy * scale);
    return MeshFragmentOut(mesh_colour(in), vec4<f32>(1.0));
}

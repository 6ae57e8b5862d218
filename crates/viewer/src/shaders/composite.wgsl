// Compositing of the pre-rendered image with live objects.
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
    // x: scale from radiance to the image's units (Exposure's gain, which lrt-depth applies).
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

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var backdrop_colour: texture_2d<f32>;
@group(0) @binding(2) var backdrop_window_depth: texture_2d<f32>;
@group(0) @binding(3) var backdrop_radial_depth: texture_2d<f32>;
@group(0) @binding(4) var light_layers: texture_2d_array<f32>;
@group(0) @binding(5) var<uniform> area_samples: AreaSamples;
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

struct MeshUniform {
    camera_from_object: mat4x4<f32>,
    normal_from_object: mat4x4<f32>,
    material: Material,
}

@group(1) @binding(0) var<uniform> mesh: MeshUniform;

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
    out.colour = textureLoad(backdrop_colour, pixel, 0);
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
    return BackdropOut(in.colour, vec4<f32>(0.0), in.depth);
}

// ---------------------------------------------------------------------------------------------
// Lighting (physical units: irradiance E per light; Lambert albedo / pi; normalised Blinn-Phong).

// Irradiance at world-space unit normal n from radiance SH (Ramamoorthi & Hanrahan 2001; the
// basis and band factors of sidecar::sh).
fn sh_irradiance(sh: array<vec4<f32>, 9>, n: vec3<f32>) -> vec3<f32> {
    let a0 = PI;
    let a1 = 2.0 * PI / 3.0;
    let a2 = PI / 4.0;
    var e = a0 * 0.2820948 * sh[0].rgb;
    e += a1 * 0.4886025 * (n.y * sh[1].rgb + n.z * sh[2].rgb + n.x * sh[3].rgb);
    e += a2 * (1.0925484 * n.x * n.y * sh[4].rgb + 1.0925484 * n.y * n.z * sh[5].rgb
        + 0.3153916 * (3.0 * n.z * n.z - 1.0) * sh[6].rgb + 1.0925484 * n.x * n.z * sh[7].rgb
        + 0.5462742 * (n.x * n.x - n.y * n.y) * sh[8].rgb);
    return max(e, vec3<f32>(0.0));
}

// ---------------------------------------------------------------------------------------------
// Probe grids (sidecar's cell_probes): the cell around a point and its 8 corners.

struct GridCell {
    // The cell's first corner, the point's fractions along each axis, the last probe per axis.
    base: vec3<u32>,
    alpha: vec3<f32>,
    last: vec3<u32>,
}

// The cell of a grid (`origin`, `spacing`, `counts`) around `q`: a point outside the grid is
// clamped to it; NaN (a point at infinity) goes to the first probe, as the references do.
fn grid_cell(q: vec3<f32>, origin: vec3<f32>, spacing: vec3<f32>, counts: vec3<u32>) -> GridCell {
    let last = max(counts, vec3<u32>(1u)) - vec3<u32>(1u);
    var t = clamp((q - origin) / spacing, vec3<f32>(0.0), vec3<f32>(last));
    t = select(vec3<f32>(0.0), t, t == t);
    let base = min(vec3<u32>(floor(t)), max(last, vec3<u32>(1u)) - vec3<u32>(1u));
    let alpha = select(t - vec3<f32>(base), vec3<f32>(0.0), last == vec3<u32>(0u));
    return GridCell(base, alpha, last);
}

struct CellCorner {
    probe: vec3<u32>,
    trilinear: f32,
}

// Corner `corner` (0 to 7) of `cell`: its probe's grid coordinates and trilinear weight.
fn cell_corner(cell: GridCell, corner: u32) -> CellCorner {
    let offset = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
    let w3 = select(vec3<f32>(1.0) - cell.alpha, cell.alpha, offset == vec3<u32>(1u));
    return CellCorner(min(cell.base + offset, cell.last), w3.x * w3.y * w3.z);
}

// ---------------------------------------------------------------------------------------------
// The reflection probes: a port of sidecar::ReflectionProbes::radiance (its reference lookup).

const REFLECTION_TEXELS: u32 = 32u;

fn octahedral_uv(d: vec3<f32>) -> vec2<f32> {
    let l1 = abs(d.x) + abs(d.y) + abs(d.z);
    var xy = vec2<f32>(0.0);
    if l1 > 0.0 {
        xy = d.xy / l1;
    }
    if d.z < 0.0 {
        let o = xy;
        xy = vec2<f32>(
            (1.0 - abs(o.y)) * select(-1.0, 1.0, o.x >= 0.0),
            (1.0 - abs(o.x)) * select(-1.0, 1.0, o.y >= 0.0),
        );
    }
    return xy * 0.5 + 0.5;
}

fn probe_index(cell: vec3<u32>) -> u32 {
    let c = frame.reflection_counts;
    return cell.x + c.x * (cell.y + c.y * cell.z);
}

fn probe_position(cell: vec3<u32>) -> vec3<f32> {
    return frame.reflection_origin.xyz + vec3<f32>(cell) * frame.reflection_spacing.xyz;
}

fn probe_distance_toward(probe: u32, dir: vec3<f32>) -> f32 {
    let uv = octahedral_uv(dir);
    let n = f32(REFLECTION_TEXELS);
    let texel = min(vec2<u32>(uv * n), vec2<u32>(REFLECTION_TEXELS - 1u));
    return textureLoad(reflection_distance, texel, probe, 0).r;
}

fn probe_sees(cell: vec3<u32>, p: vec3<f32>) -> bool {
    let to_p = p - probe_position(cell);
    let d = length(to_p);
    if !(d > 0.0) {
        return true;
    }
    return d <= 1.05 * probe_distance_toward(probe_index(cell), to_p / d);
}

// Parallax-corrected lookup of one probe (ReflectionProbes::radiance_from).
fn probe_radiance_from(cell: vec3<u32>, p: vec3<f32>, r: vec3<f32>, level: f32) -> vec3<f32> {
    let probe = probe_index(cell);
    let pc = p - probe_position(cell);
    var dir = r;
    for (var step = 0; step < 3; step++) {
        let radius = probe_distance_toward(probe, dir);
        let b = dot(pc, r);
        let disc = b * b - (dot(pc, pc) - radius * radius);
        if disc < 0.0 {
            break;
        }
        let t = max(-b + sqrt(disc), 0.0);
        let hit = pc + t * r;
        let len = length(hit);
        if !(len > 0.0) {
            break;
        }
        dir = hit / len;
    }
    return textureSampleLevel(reflection_radiance, reflection_sampler, octahedral_uv(dir), probe, level).rgb;
}

// Glossy reflection at world point p toward unit r (ReflectionProbes::radiance): the probes
// around p weighted trilinearly, a probe a wall hides from p by 1e-3 of that.
fn reflection_radiance_at(p: vec3<f32>, r: vec3<f32>, level: f32) -> vec3<f32> {
    let grid = grid_cell(p, frame.reflection_origin.xyz, frame.reflection_spacing.xyz, frame.reflection_counts.xyz);
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let c = cell_corner(grid, corner);
        let trilinear = c.trilinear;
        if trilinear <= 0.0 {
            continue;
        }
        let cell = c.probe;
        let w = select(1e-3 * trilinear, trilinear, probe_sees(cell, p));
        sum += w * probe_radiance_from(cell, p, r, level);
        total += w;
    }
    if total > 0.0 {
        return sum / total;
    }
    return probe_radiance_from(vec3<u32>(round(vec3<f32>(grid.base) + grid.alpha)), p, r, level);
}

// ---------------------------------------------------------------------------------------------
// The irradiance probes per fragment: a port of sidecar::ProbeGrid::irradiance_of (DDGI), each
// probe's SH the scene's indirect light (compositor/irradiance.rs).

const VISIBILITY_TEXELS: u32 = 16u;

fn field_probe_index(cell: vec3<u32>) -> u32 {
    let c = frame.irradiance_counts;
    return cell.x + c.x * (cell.y + c.y * cell.z);
}

// Chebyshev visibility of a point `distance` from `probe` along unit `dir` (from the point
// toward the probe).
fn field_visibility(probe: u32, dir: vec3<f32>, distance: f32) -> f32 {
    let uv = octahedral_uv(-dir);
    let n = f32(VISIBILITY_TEXELS);
    let texel = min(vec2<u32>(uv * n), vec2<u32>(VISIBILITY_TEXELS - 1u));
    let moments = irradiance_visibility[probe * VISIBILITY_TEXELS * VISIBILITY_TEXELS + texel.y * VISIBILITY_TEXELS + texel.x];
    let mean = moments.x;
    if distance <= mean {
        return 1.0;
    }
    let variance = max(abs(moments.y - mean * mean), 1e-6 * max(moments.y, 1e-12));
    let d = distance - mean;
    let v = variance / (variance + d * d);
    return max(v * v * v, 0.0);
}

// Tiny weights crushed (DDGI): the residual glow of a probe seen through a wall goes.
fn crushed(w: f32) -> f32 {
    return select(w, w * w * w / 0.04, w < 0.2);
}

fn probe_sh_irradiance(probe: u32, n: vec3<f32>) -> vec3<f32> {
    var sh: array<vec4<f32>, 9>;
    for (var i = 0u; i < 9u; i++) {
        sh[i] = irradiance_sh[9u * probe + i];
    }
    return sh_irradiance(sh, n);
}

// The scene's indirect irradiance at world point p with world unit normal n.
fn field_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let spacing = frame.irradiance_spacing.xyz;
    let bias = 0.1 * min(spacing.x, min(spacing.y, spacing.z));
    let q = p + n * bias;
    let grid = grid_cell(q, frame.irradiance_origin.xyz, spacing, frame.irradiance_counts.xyz);
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let c = cell_corner(grid, corner);
        let trilinear = c.trilinear;
        if trilinear <= 0.0 {
            continue;
        }
        let cell = c.probe;
        let probe = field_probe_index(cell);
        let to_probe = frame.irradiance_origin.xyz + vec3<f32>(cell) * spacing - q;
        let distance = length(to_probe);
        var dir = n;
        if distance > 0.0 {
            dir = to_probe / distance;
        }
        let h = (dot(dir, n) + 1.0) * 0.5;
        let backface = h * h + 0.2;
        let w = crushed(trilinear * backface * max(field_visibility(probe, dir, distance), 1e-6));
        sum += w * probe_sh_irradiance(probe, n);
        total += w;
    }
    if total > 0.0 {
        return max(sum / total, vec3<f32>(0.0));
    }
    return vec3<f32>(0.0);
}

// The Blinn lobe's directional albedo for the material (linear in its 16-entry table).
fn blinn_albedo(material: Material, cos_o: f32) -> f32 {
    let x = clamp(cos_o, 0.0, 1.0) * 15.0;
    let i = min(u32(x), 14u);
    let f = x - f32(i);
    let a = material.albedo[i / 4u][i % 4u];
    let b = material.albedo[(i + 1u) / 4u][(i + 1u) % 4u];
    return a + (b - a) * f;
}

// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Live objects' own shadows as live objects see them. The probes hold the scene as it was
// rendered; the shadow pass has since taken light from the surfaces a live object shadows
// (`backdrop_colour - backdrop_shadowed`), and a live surface facing them (the underside of a
// sphere above its shadow) no longer receives the light they reflected. Each fragment gathers
// that loss over SHADOW_GATHER_DIRECTIONS cosine-distributed directions, each marched in screen
// space against the pre-rendered depth (exact surfaces, but only those the eye sees in the
// render without live objects); a surface's loss is taken as Lambertian, the same toward the
// fragment as toward the eye.

const SHADOW_GATHER_DIRECTIONS: u32 = 16u;
const SHADOW_GATHER_STEPS: u32 = 16u;
const GOLDEN_ANGLE: f32 = 2.39996323;

// How far from a fragment the live objects' shadows are looked for: as far as their occlusion
// of indirect light reaches (AO_REACH radii of the largest caster).
fn shadow_gather_reach() -> f32 {
    var r = 0.0;
    if frame.layer_info.x == 1u {
        for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
            r = max(r, frame.shadow_spheres[i].w);
        }
    } else if frame.counts.z == 1u {
        r = frame.sphere.w;
    }
    return r * AO_REACH;
}

// Where camera-space point y falls in the depth table: its pixel (x < 0 when outside the image
// or behind the eye), its distance along the pixel's ray and the table's distance there.
struct DepthProbe {
    pixel: vec2<i32>,
    distance: f32,
    surface: f32,
}

fn probe_depth(y: vec3<f32>) -> DepthProbe {
    let size = frame.raster.xy;
    let clip = frame.clip_from_camera * vec4<f32>(y, 1.0);
    if clip.w <= 0.0 {
        return DepthProbe(vec2<i32>(-1), 0.0, 0.0);
    }
    let ndc = clip.xy / clip.w;
    let raster = vec2<f32>((ndc.x + 1.0) * 0.5 * size.x, (1.0 - ndc.y) * 0.5 * size.y);
    if any(raster < vec2<f32>(0.0)) || any(raster >= size) {
        return DepthProbe(vec2<i32>(-1), 0.0, 0.0);
    }
    let pixel = vec2<i32>(raster);
    let surface = textureLoad(backdrop_radial_depth, pixel, 0).r;
    // Distance along the pixel's ray, as the depth table measures it.
    let distance = select(y.z, length(y), frame.raster.w > 0.5);
    return DepthProbe(pixel, distance, surface);
}

// The radiance the shadows took from the first pre-rendered surface along p + t w (t up to
// `reach`), in the image's units; zero when the march leaves the image, passes behind a
// surface or finds none.
fn shadow_loss_along(p: vec3<f32>, w: vec3<f32>, reach: f32) -> vec3<f32> {
    var previous = p;
    for (var j = 1u; j <= SHADOW_GATHER_STEPS; j = j + 1u) {
        // Steps grow with distance: near surfaces matter most.
        let s = f32(j) / f32(SHADOW_GATHER_STEPS);
        let y = p + (reach * s * s) * w;
        var at = probe_depth(y);
        if at.pixel.x < 0 {
            return vec3<f32>(0.0);
        }
        if at.surface < 3.0e38 && at.distance >= at.surface {
            // Behind the surface: bisect the step for where it crossed, since at grazing views
            // a point a step behind the surface projects far from the crossing.
            var front = previous;
            var behind = y;
            for (var b = 0u; b < 6u; b = b + 1u) {
                let middle = 0.5 * (front + behind);
                let m = probe_depth(middle);
                if m.pixel.x >= 0 && m.surface < 3.0e38 && m.distance >= m.surface {
                    behind = middle;
                    at = m;
                } else {
                    front = middle;
                }
            }
            // The step crossed the surface when the pixel's surface point lies on what is
            // left of the step (within its length); else the march went behind a surface
            // nearer the eye, and what it reaches is hidden from the eye.
            let ray = ray_through_raster(vec2<f32>(at.pixel) + vec2<f32>(0.5));
            let x = ray.origin + at.surface * ray.direction;
            let step = behind - front;
            let along = clamp(dot(x - front, step) / max(dot(step, step), 1e-30), 0.0, 1.0);
            if length(x - (front + along * step)) > length(y - previous) {
                return vec3<f32>(0.0);
            }
            let before = textureLoad(backdrop_colour, at.pixel, 0).rgb;
            let after = textureLoad(backdrop_shadowed, at.pixel, 0).rgb;
            return max(before - after, vec3<f32>(0.0));
        }
        previous = y;
    }
    return vec3<f32>(0.0);
}

// What the live objects' shadows took from the light a fragment at p (normal n, camera space,
// seen from v) receives, in the image's units: the irradiance its diffuse lobe loses and the
// radiance its Blinn lobe (`exponent`) loses, both from the same directions.
struct ShadowLoss {
    irradiance: vec3<f32>,
    glossy: vec3<f32>,
}

fn shadow_loss(p: vec3<f32>, n: vec3<f32>, v: vec3<f32>, exponent: f32) -> ShadowLoss {
    let reach = shadow_gather_reach();
    if reach <= 0.0 {
        return ShadowLoss(vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
    let tangent = normalize(cross(helper, n));
    let bitangent = cross(n, tangent);
    // Start off the surface, so the march never finds the fragment's own pixel's surface.
    let origin = p + n * (reach * 1e-3);
    var irradiance = vec3<f32>(0.0);
    var glossy = vec3<f32>(0.0);
    for (var i = 0u; i < SHADOW_GATHER_DIRECTIONS; i = i + 1u) {
        // Cosine-distributed directions on a spiral (uniform in the disc, lifted).
        let u = (f32(i) + 0.5) / f32(SHADOW_GATHER_DIRECTIONS);
        let radius = sqrt(u);
        let phi = f32(i) * GOLDEN_ANGLE;
        let cos_w = sqrt(1.0 - u);
        let w = tangent * (radius * cos(phi)) + bitangent * (radius * sin(phi)) + n * cos_w;
        let loss = shadow_loss_along(origin, w, reach);
        irradiance += loss;
        // The Blinn lobe's BRDF times cosine over the directions' density (cos / pi).
        glossy += loss * (blinn_lobe_cos(n, v, w, exponent) / cos_w);
    }
    // Over cosine-distributed directions: E = pi / N * sum of L, L_o = pi / N * sum of f L.
    let scale = PI / f32(SHADOW_GATHER_DIRECTIONS);
    return ShadowLoss(irradiance * scale, glossy * scale);
}

fn shade(material: Material, p: vec3<f32>, n_in: vec3<f32>, view_dir: vec3<f32>) -> vec3<f32> {
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
    var ambient = vec3<f32>(0.0);
    var diffuse = vec3<f32>(0.0);
    var specular = vec3<f32>(0.0);
    let count = min(frame.counts.x, MAX_LIGHTS);
    for (var k = 0u; k < count; k++) {
        let light = frame.lights[k];
        let kind = u32(light.position.w + 0.5);
        if kind == LIGHT_AMBIENT {
            ambient += light.colour.rgb;
            continue;
        }
        // An area light with samples from the light layers is integrated over them, as the
        // ray tracer integrates it (`A cos_e cos_l / d^2` per sample), not seen as one point.
        let slot = frame.shadow_slots[k];
        if kind == LIGHT_AREA && frame.layer_info.x == 1u && slot.x != NO_LAYER && slot.z > 0u {
            let sample_count = min(slot.z, MAX_AREA_SAMPLES);
            // The radiance each sample carries (compositor/lighting.rs).
            let radiance = light.params.rgb;
            for (var i = 0u; i < sample_count; i++) {
                let sample = area_samples.samples[2u * (slot.y + i)];
                let sample_normal = area_samples.samples[2u * (slot.y + i) + 1u];
                let to_sample = sample.xyz - p;
                let dist2 = max(dot(to_sample, to_sample), 1e-30);
                let l = to_sample * inverseSqrt(dist2);
                let c = dot(sample_normal.xyz, -l);
                let cos_e = select(max(c, 0.0), abs(c), sample_normal.w > 0.5);
                let n_dot_l = dot(n, l);
                if n_dot_l <= 0.0 || cos_e <= 0.0 {
                    continue;
                }
                let e = radiance * (sample.w * cos_e / dist2);
                diffuse += e * n_dot_l;
                specular += e * blinn_lobe_cos(n, v, l, exponent);
            }
            continue;
        }
        var l: vec3<f32>;
        var e: vec3<f32>;
        if kind == LIGHT_DISTANT {
            l = -light.direction.xyz;
            e = light.colour.rgb;
        } else {
            let to_light = light.position.xyz - p;
            let dist2 = max(dot(to_light, to_light), 1e-30);
            l = to_light * inverseSqrt(dist2);
            var intensity = light.colour.rgb;
            if kind == LIGHT_SPOT {
                let cos_angle = dot(-l, light.direction.xyz);
                intensity *= pow(max(cos_angle, 0.0), light.params.z)
                    * smoothstep(light.params.x, light.params.y, cos_angle);
            } else if kind == LIGHT_AREA {
                var lobe = 0.25;
                if light.colour.w > 0.5 {
                    let c = dot(light.direction.xyz, -l);
                    lobe = select(max(c, 0.0), abs(c), light.direction.w > 0.5);
                }
                intensity *= lobe;
            }
            e = intensity / dist2;
        }
        let n_dot_l = dot(n, l);
        if n_dot_l <= 0.0 {
            continue;
        }
        diffuse += e * n_dot_l;
        specular += e * blinn_lobe_cos(n, v, l, exponent);
    }
    // The probes saw the scene before the live objects' shadows took light from it.
    var loss = ShadowLoss(vec3<f32>(0.0), vec3<f32>(0.0));
    if frame.counts.y == 1u && (frame.counts.w == 1u || reflections) {
        loss = shadow_loss(p, n, v, exponent);
        let to_radiance = 1.0 / max(frame.tone.x, 1e-30);
        loss = ShadowLoss(loss.irradiance * to_radiance, loss.glossy * to_radiance);
    }
    // With the renderer's irradiance probes, the scene's indirect light at this fragment
    // (compositor/irradiance.rs) joins the lights', less what the shadows took.
    if frame.counts.w == 1u {
        let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
        let n_world = normalize((frame.world_from_camera * vec4<f32>(n, 0.0)).xyz);
        diffuse += max(field_irradiance(p_world, n_world) - loss.irradiance, vec3<f32>(0.0));
    }
    // With the reflection probes, the scene's prefiltered radiance in the reflected direction
    // times the lobe's albedo (the split sum), less what the shadows took.
    if reflections {
        let p_world = (frame.world_from_camera_point * vec4<f32>(p, 1.0)).xyz;
        let r = reflect(view_dir, n);
        let r_world = normalize((frame.world_from_camera * vec4<f32>(r, 0.0)).xyz);
        let reflected = blinn_albedo(material, dot(n, v))
            * reflection_radiance_at(p_world, r_world, material.specular_colour.w);
        specular += max(reflected - loss.glossy, vec3<f32>(0.0));
    }
    let cs = material.colour.rgb;
    return cs * (ka * ambient + kd / PI * diffuse) + material.specular_colour.rgb * ks * specular;
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
    let p = frame.sphere.xyz + corner * frame.sphere.w * 1.001;
    var clip = frame.clip_from_camera * vec4<f32>(p, 1.0);
    clip.z = 0.5 * clip.w;
    var out: SphereVertexOut;
    out.position = clip;
    return out;
}

// The sphere's nearest visible hit along the ray through `raster`: camera-space point and
// window depth, w < 0 when the ray misses it or its hits lie outside the depth range.
fn sphere_hit(raster: vec2<f32>) -> vec4<f32> {
    let ray = ray_through_raster(raster);
    let c = frame.sphere.xyz;
    let r = frame.sphere.w;
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
    var out: LiveOut;
    out.colour = to_image_units(shade(frame.sphere_material, p, n, ray_through_raster(position.xy).direction));
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
    return to_image_units(shade(mesh.material, in.p_camera, n, ray.direction));
}

@fragment
fn fs_mesh(in: MeshVertexOut) -> MeshFragmentOut {
    return MeshFragmentOut(mesh_colour(in), vec4<f32>(1.0));
}

// ---------------------------------------------------------------------------------------------
// Shadows of the sphere on the pre-rendered scene: each pixel's surface point is rebuilt from
// the radial depth along its pixel-centre ray; the fraction of the shadow light hidden by the
// sphere (disc overlap of their angular extents) darkens the pixel by a multiplicative blend.
// Unshadowed pixels are discarded, so they keep their exact input value.

fn surface_point(pixel: vec2<i32>) -> vec4<f32> {
    let size = vec2<i32>(frame.raster.xy);
    let q = clamp(pixel, vec2<i32>(0), size - vec2<i32>(1));
    let r = textureLoad(backdrop_radial_depth, q, 0).r;
    let ray = ray_through_raster(vec2<f32>(q) + vec2<f32>(0.5));
    // A miss (inf) has no surface.
    let hit = r < 3.0e38;
    return vec4<f32>(ray.origin + r * ray.direction, select(0.0, 1.0, hit));
}

// Area of the intersection of two discs of radii a and b whose centres are d apart.
fn disc_overlap(a: f32, b: f32, d: f32) -> f32 {
    if d >= a + b {
        return 0.0;
    }
    let small = min(a, b);
    if d <= abs(a - b) {
        return PI * small * small;
    }
    let a2 = a * a;
    let b2 = b * b;
    let alpha = acos(clamp((d * d + a2 - b2) / (2.0 * d * a), -1.0, 1.0));
    let beta = acos(clamp((d * d + b2 - a2) / (2.0 * d * b), -1.0, 1.0));
    return a2 * alpha + b2 * beta - 0.5 * sqrt(max((-d + a + b) * (d + a - b) * (d - a + b) * (d + a + b), 0.0));
}

const CONE_CLEAR: u32 = 0u;
const CONE_UMBRA: u32 = 1u;
const CONE_PENUMBRA: u32 = 2u;

// How the shadow-casting spheres stand against an emitter's bounding cone from p (unit `axis`,
// half-angle with cosine `cos_e` and sine `sin_e`, emitter points between `near` and `far`
// from p), compared by cosines: CONE_CLEAR when no sphere's cone overlaps it (the angle
// between the axes at least the sum of the half-angles plus 1e-3 radians), CONE_UMBRA when one
// sphere's cone holds it whole with every emitter point beyond the sphere's nearest hit (which
// is at most the sphere's distance along any ray inside its cone), else CONE_PENUMBRA.
fn emitter_cone_class(p: vec3<f32>, axis: vec3<f32>, cos_e: f32, sin_e: f32, near: f32, far: f32) -> u32 {
    var cone_class = CONE_CLEAR;
    for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
        let sphere = frame.shadow_spheres[i];
        let to_sphere = sphere.xyz - p;
        let ds = length(to_sphere);
        let r = sphere.w;
        if ds <= r {
            return CONE_UMBRA;
        }
        if ds - r >= far {
            continue;
        }
        let sin_s = r / ds;
        let cos_s = sqrt(max(1.0 - sin_s * sin_s, 0.0));
        let cos_between = dot(to_sphere / ds, axis);
        let cos_sum = cos_s * cos_e - sin_s * sin_e;
        let sin_sum = sin_s * cos_e + cos_s * sin_e;
        // cos(sum + 1e-3); a sum within 1e-3 of pi overlaps every direction.
        if cos_sum > -0.9999 && cos_between <= cos_sum * 0.9999995 - sin_sum * 1e-3 {
            continue;
        }
        let sin_diff = sin_s * cos_e - cos_s * sin_e;
        let cos_diff = cos_s * cos_e + sin_s * sin_e;
        if sin_diff > 1e-3 && ds <= near && cos_between >= cos_diff * 0.9999995 + sin_diff * 1e-3 {
            return CONE_UMBRA;
        }
        cone_class = CONE_PENUMBRA;
    }
    return cone_class;
}

// Whether any shadow-casting sphere blocks the segment from p along unit dir up to max_t.
fn sphere_blocks(p: vec3<f32>, dir: vec3<f32>, max_t: f32) -> bool {
    for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
        if one_sphere_blocks(frame.shadow_spheres[i], p, dir, max_t) {
            return true;
        }
    }
    return false;
}

// Whether sphere (centre, radius) blocks the segment from p along unit dir up to max_t.
fn one_sphere_blocks(sphere: vec4<f32>, p: vec3<f32>, dir: vec3<f32>, max_t: f32) -> bool {
    let f = p - sphere.xyz;
    let r = sphere.w;
    let c = dot(f, f) - r * r;
    if c <= 0.0 {
        return true;
    }
    let b = dot(f, dir);
    let q = f - b * dir;
    let disc = r * r - dot(q, q);
    if disc < 0.0 || b >= 0.0 {
        return false;
    }
    let t = c / (-b + sqrt(disc));
    return t < max_t;
}

fn luminance(c: vec3<f32>) -> f32 {
    return (c.r + c.g + c.b) / 3.0;
}

// The share of light i's direct light at p (normal n, zero if unknown) that the sphere hides,
// and the light's unshadowed irradiance there (to weigh lights that share a layer).
fn hidden_share(i: u32, p: vec3<f32>, n: vec3<f32>) -> vec2<f32> {
    let light = frame.lights[i];
    let kind = u32(light.position.w + 0.5);
    let has_n = dot(n, n) > 0.0;
    let power = luminance(light.colour.rgb);
    if kind == LIGHT_DISTANT {
        let dir = -light.direction.xyz;
        let cos_s = select(1.0, max(dot(n, dir), 0.0), has_n);
        return vec2<f32>(select(0.0, 1.0, sphere_blocks(p, dir, 3.0e38)), power * cos_s);
    }
    if kind == LIGHT_POINT || kind == LIGHT_SPOT {
        let v = light.position.xyz - p;
        let d = length(v);
        let dir = v / d;
        let cos_s = select(1.0, max(dot(n, dir), 0.0), has_n);
        return vec2<f32>(select(0.0, 1.0, sphere_blocks(p, dir, d)), power * cos_s / (d * d));
    }
    if kind == LIGHT_AREA {
        // The ray tracer's integral over the emitter, on its fixed samples: the occluded share
        // of sum(area cos_l cos_s / d^2). First a cone test: when no sphere's cone from p
        // overlaps the emitter's bounding cone, nothing is hidden (most pixels).
        let slot = frame.shadow_slots[i];
        let to_light = light.position.xyz - p;
        let dl = length(to_light);
        let bound = bitcast<f32>(slot.w);
        if dl > bound {
            let sin_e = bound / dl;
            let cone_class = emitter_cone_class(
                p, to_light / dl, sqrt(max(1.0 - sin_e * sin_e, 0.0)), sin_e, dl - bound, dl + bound,
            );
            if cone_class == CONE_CLEAR {
                return vec2<f32>(0.0, power / (dl * dl));
            }
            if cone_class == CONE_UMBRA {
                return vec2<f32>(1.0, power / (dl * dl));
            }
        }
        var total = 0.0;
        var hidden = 0.0;
        for (var k = slot.y; k < min(slot.y + slot.z, MAX_AREA_SAMPLES); k = k + 1u) {
            let s = area_samples.samples[2u * k];
            let sn = area_samples.samples[2u * k + 1u];
            let v = s.xyz - p;
            let d2 = dot(v, v);
            if d2 <= 0.0 {
                continue;
            }
            let d = sqrt(d2);
            let dir = v / d;
            var cos_l = 1.0;
            if dot(sn.xyz, sn.xyz) > 0.0 {
                cos_l = dot(sn.xyz, -dir);
                if sn.w > 0.5 {
                    cos_l = abs(cos_l);
                }
            }
            let cos_s = select(1.0, dot(n, dir), has_n);
            if cos_l <= 0.0 || cos_s <= 0.0 {
                continue;
            }
            let g = s.w * cos_l * cos_s / d2;
            total += g;
            if sphere_blocks(p, dir, d) {
                hidden += g;
            }
        }
        if total <= 0.0 {
            return vec2<f32>(0.0, 0.0);
        }
        return vec2<f32>(hidden / total, power * total);
    }
    return vec2<f32>(0.0, 0.0);
}

// Shadows with the renderer's light layers: each light's occluded share of its own layer, and
// the sphere's occlusion of indirect light (cosine-weighted solid angle, (r/d)^2 cos) of the
// indirect layer, both in the image's units.
fn layered_shadow(pixel: vec2<i32>, p: vec3<f32>) -> vec3<f32> {
    let n_raw = textureLoad(light_layers, pixel, i32(frame.layer_info.z), 0).xyz;
    let n = select(vec3<f32>(0.0), normalize(n_raw), dot(n_raw, n_raw) > 1e-12);
    var removed = vec3<f32>(0.0);
    if frame.shadow_params.z < 0.5 {
        // Every layer holds one light (the usual case): its own share, no bookkeeping.
        for (var i = 0u; i < frame.counts.x; i = i + 1u) {
            let slice = frame.shadow_slots[i].x;
            if slice == NO_LAYER {
                continue;
            }
            let s = hidden_share(i, p, n).x;
            if s > 0.0 {
                removed += s * textureLoad(light_layers, pixel, i32(slice), 0).rgb;
            }
        }
    } else {
        removed = shared_layer_shadow(pixel, p, n);
    }
    return (removed + indirect_occlusion(p, n) * textureLoad(light_layers, pixel, i32(frame.layer_info.y), 0).rgb)
        * frame.tone.x;
}

// Layers that hold several lights (scenes with more than 16): each light's share weighted by
// its unshadowed irradiance.
fn shared_layer_shadow(pixel: vec2<i32>, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    var numerator = array<f32, MAX_LIGHTS>();
    var weight = array<f32, MAX_LIGHTS>();
    var share = array<f32, MAX_LIGHTS>();
    var lights_in = array<u32, MAX_LIGHTS>();
    for (var i = 0u; i < frame.counts.x; i = i + 1u) {
        let slice = frame.shadow_slots[i].x;
        if slice == NO_LAYER {
            continue;
        }
        let h = hidden_share(i, p, n);
        numerator[slice] += h.x * h.y;
        weight[slice] += h.y;
        share[slice] = h.x;
        lights_in[slice] += 1u;
    }
    var removed = vec3<f32>(0.0);
    for (var slice = 0u; slice < MAX_LIGHTS; slice = slice + 1u) {
        if lights_in[slice] == 0u {
            continue;
        }
        // One light per layer: its own share; several: weighted by their irradiance.
        var s = share[slice];
        if lights_in[slice] > 1u {
            s = select(0.0, numerator[slice] / weight[slice], weight[slice] > 0.0);
        }
        if s > 0.0 {
            removed += s * textureLoad(light_layers, pixel, i32(slice), 0).rgb;
        }
    }
    return removed;
}

// The spheres' cosine-weighted occluded solid angle at p (normal n): occluded indirect light.
fn indirect_occlusion(p: vec3<f32>, n: vec3<f32>) -> f32 {
    // Occluded solid angles of separate spheres add (overlaps are rare and small).
    var ao = 0.0;
    for (var i = 0u; i < frame.layer_info.w; i = i + 1u) {
        let sphere = frame.shadow_spheres[i];
        let to_sphere = sphere.xyz - p;
        let d = length(to_sphere);
        let r = sphere.w;
        if d <= r {
            ao = 1.0;
            break;
        }
        let cos_s = select(1.0, max(dot(n, to_sphere / d), 0.0), dot(n, n) > 0.0);
        let fade = 1.0 - smoothstep(0.75 * AO_REACH * r, AO_REACH * r, d);
        ao += cos_s * (r / d) * (r / d) * fade;
    }
    return min(ao, 1.0);
}

@fragment
fn fs_shadow(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let centre = surface_point(pixel);
    if centre.w < 0.5 {
        discard;
    }
    if frame.layer_info.x == 1u {
        let removed = layered_shadow(pixel, centre.xyz);
        if all(removed <= vec3<f32>(0.0)) {
            discard;
        }
        let before = textureLoad(backdrop_colour, pixel, 0);
        return vec4<f32>(max(before.rgb - removed, vec3<f32>(0.0)), before.a);
    }
    let p = centre.xyz;
    // Direction and distance to the light.
    var to_light: vec3<f32>;
    var light_distance: f32;
    if frame.shadow_light.w > 0.5 {
        let v = frame.shadow_light.xyz - p;
        light_distance = length(v);
        to_light = v / light_distance;
    } else {
        to_light = -frame.shadow_light.xyz;
        light_distance = 3.0e38;
    }
    // The sphere as seen from p.
    let to_sphere = frame.sphere.xyz - p;
    let sphere_distance = length(to_sphere);
    let r = frame.sphere.w;
    if sphere_distance <= r || sphere_distance - r >= light_distance {
        discard;
    }
    let sphere_angle = asin(r / sphere_distance);
    let separation = acos(clamp(dot(to_sphere / sphere_distance, to_light), -1.0, 1.0));
    var hidden = 0.0;
    let light_angle = atan(frame.shadow_params.x / light_distance);
    if light_angle > 1e-4 {
        hidden = disc_overlap(light_angle, sphere_angle, separation) / (PI * light_angle * light_angle);
    } else if separation < sphere_angle {
        hidden = 1.0;
    }
    hidden = clamp(hidden, 0.0, 1.0);
    if hidden <= 0.0 {
        discard;
    }
    // Only surfaces facing the light receive its direct light (checked last: it reads four
    // neighbours, and most pixels are out of the shadow). The normal comes from the
    // rebuilt neighbours, taking on each axis the neighbour nearer in depth so edges do not
    // bend it.
    let right = surface_point(pixel + vec2<i32>(1, 0));
    let left = surface_point(pixel - vec2<i32>(1, 0));
    let down = surface_point(pixel + vec2<i32>(0, 1));
    let up = surface_point(pixel - vec2<i32>(0, 1));
    var dx = right.xyz - p;
    if right.w < 0.5 || (left.w > 0.5 && abs(p.z - left.z) < abs(right.z - p.z)) {
        dx = p - left.xyz;
    }
    var dy = down.xyz - p;
    if down.w < 0.5 || (up.w > 0.5 && abs(p.z - up.z) < abs(down.z - p.z)) {
        dy = p - up.xyz;
    }
    var n = cross(dx, dy);
    let len = length(n);
    if len > 0.0 {
        n = n / len;
        let toward_eye = -ray_through_raster(position.xy).direction;
        if dot(n, toward_eye) < 0.0 {
            n = -n;
        }
        if dot(n, to_light) <= 0.0 {
            discard;
        }
    }
    let keep = 1.0 - frame.shadow_params.y * hidden;
    let backdrop = textureLoad(backdrop_colour, pixel, 0);
    return vec4<f32>(backdrop.rgb * keep, backdrop.a);
}

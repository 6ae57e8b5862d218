// Live objects seeing their own shadows (appended to composite.wgsl: compositor/mod.rs
// COMPOSITE_WGSL; the bindings and helpers are composite.wgsl's).

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
// The directions a moving frame's loss maps gather over (fs_loss_map); the frame at rest draws
// them again over SHADOW_GATHER_DIRECTIONS (the maps are keyed with the moving flag).
const SHADOW_GATHER_MOVING: u32 = 8u;
// The directions shadow_loss gathers over: SHADOW_GATHER_DIRECTIONS unless the entry point sets
// another count.
var<private> shadow_gather_directions: u32 = SHADOW_GATHER_DIRECTIONS;
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

// The pixel of the first pre-rendered surface along p + t w for t from t0 to t1 (x < 0 when the
// march leaves the image, passes behind a surface or finds none). Steps grow with distance, so
// near surfaces are found most closely.
fn march_to_surface(p: vec3<f32>, w: vec3<f32>, t0: f32, t1: f32) -> vec2<i32> {
    var previous = p + t0 * w;
    for (var j = 1u; j <= SHADOW_GATHER_STEPS; j = j + 1u) {
        let s = f32(j) / f32(SHADOW_GATHER_STEPS);
        let y = p + (t0 + (t1 - t0) * s * s) * w;
        var at = probe_depth(y);
        if at.pixel.x < 0 {
            return vec2<i32>(-1);
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
                return vec2<i32>(-1);
            }
            return at.pixel;
        }
        previous = y;
    }
    return vec2<i32>(-1);
}

// The radiance the shadows took from the first pre-rendered surface along p + t w (t up to
// `reach`), in the image's units; zero when the march leaves the image, passes behind a
// surface or finds none.
fn shadow_loss_along(p: vec3<f32>, w: vec3<f32>, reach: f32) -> vec3<f32> {
    let pixel = march_to_surface(p, w, 0.0, reach);
    if pixel.x < 0 {
        return vec3<f32>(0.0);
    }
    let before = textureLoad(backdrop_colour, pixel, 0).rgb;
    let after = textureLoad(backdrop_shadowed, pixel, 0).rgb;
    return max(before - after, vec3<f32>(0.0));
}

// The irradiance the live objects' shadows took from what a fragment at p (normal n, camera
// space) receives, in the image's units. (A glossy fragment's reflection of those shadows is
// glossy_reflection's, per lobe direction: probes.wgsl, live_share_at_hit.)
fn shadow_loss(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let reach = shadow_gather_reach();
    if reach <= 0.0 {
        return vec3<f32>(0.0);
    }
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
    let tangent = normalize(cross(helper, n));
    let bitangent = cross(n, tangent);
    // Start off the surface, so the march never finds the fragment's own pixel's surface.
    let origin = p + n * (reach * 1e-3);
    var irradiance = vec3<f32>(0.0);
    let directions = shadow_gather_directions;
    for (var i = 0u; i < directions; i = i + 1u) {
        // Cosine-distributed directions on a spiral (uniform in the disc, lifted).
        let u = (f32(i) + 0.5) / f32(directions);
        let radius = sqrt(u);
        let phi = f32(i) * GOLDEN_ANGLE;
        let cos_w = sqrt(1.0 - u);
        let w = tangent * (radius * cos(phi)) + bitangent * (radius * sin(phi)) + n * cos_w;
        irradiance += shadow_loss_along(origin, w, reach);
    }
    // Over cosine-distributed directions: E = pi / N * sum of L.
    return irradiance * (PI / f32(directions));
}

// ---------------------------------------------------------------------------------------------
// Own-shadow loss maps (compositor/loss_map.rs). On a sphere the loss is a smooth function of the
// point on it (its normal) once the camera, the sphere and the shadows are fixed: the view
// direction at a point of a sphere is the point's own. So shadow_loss runs once per texel of a
// LOSS_MAP_TEXELS^2 map per sphere, over the hemisphere of normals facing the eye (a
// hemi-octahedral map around the direction from the centre to the eye), and fragments read it
// bilinearly instead of marching 16 directions each. Row k of the atlas is the k-th sphere of
// loss_map_sphere.

const LOSS_MAP_TEXELS: u32 = 32u;

// Per texel: the irradiance loss rgb as three half floats (pack2x16float), and 1 where the
// texel holds a sphere's loss (0: the row was never drawn, or its sphere has no map).
@group(0) @binding(14) var loss_maps: texture_2d<u32>;

// The atlas row of the sphere a fragment belongs to (-1: none, march per fragment). Set by the
// fragment entry points of spheres before they shade.
var<private> loss_map_row: i32 = -1;

// How many spheres have a row: with the light layers, the spheres casting shadows (the cursor
// sphere first); without them, the cursor sphere.
fn loss_map_rows() -> u32 {
    if frame.layer_info.x == 1u {
        return min(frame.layer_info.w, 8u);
    }
    return frame.counts.z;
}

// The camera-space centre and radius of the sphere of atlas row `row`.
fn loss_map_sphere(row: u32) -> vec4<f32> {
    if frame.layer_info.x == 1u {
        return frame.shadow_spheres[row];
    }
    return frame.sphere;
}

// The direction from the sphere's centre `c` toward the eye (in an orthographic frame, the
// view direction reversed).
fn sphere_toward_eye(c: vec3<f32>) -> vec3<f32> {
    if frame.raster.w > 0.5 {
        return -normalize(c);
    }
    return vec3<f32>(0.0, 0.0, -1.0);
}

// The loss map row that the shading of sphere `row` (centre `c`) reads at normal `n`: the map
// covers the half facing the eye; on the other half (-1) the loss is gathered per point.
fn loss_map_row_at(row: u32, c: vec3<f32>, n: vec3<f32>) -> i32 {
    return select(-1, i32(row), dot(n, sphere_toward_eye(c)) >= 0.0);
}

// The material of live sphere `row`: the cursor sphere is the first row when it is drawn, the
// others are live meshes (the mesh uniform bound for the draw).
fn live_sphere_material(row: u32) -> Material {
    if row == 0u && frame.counts.z == 1u {
        return frame.sphere_material;
    }
    return mesh.material;
}

// A basis whose third axis points from the sphere's centre `c` toward the eye.
fn loss_map_basis(c: vec3<f32>) -> mat3x3<f32> {
    let toward_eye = sphere_toward_eye(c);
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(toward_eye.x) > 0.9);
    let tangent = normalize(cross(helper, toward_eye));
    return mat3x3<f32>(tangent, cross(toward_eye, tangent), toward_eye);
}

// The map serves a sphere whose outside the eye sees (a perspective eye inside it sees its
// inside, which the map does not hold).
fn loss_map_serves(s: vec4<f32>) -> bool {
    return s.w > 0.0 && (frame.raster.w < 0.5 || length(s.xyz) > s.w * 1.0001);
}

// Hemi-octahedral coordinates in [-1, 1]^2 of unit `local` (z >= 0 the hemisphere kept; normals
// behind it are taken to its rim).
fn hemi_octahedral(local: vec3<f32>) -> vec2<f32> {
    let d = vec3<f32>(local.xy, max(local.z, 0.0));
    let p = d.xy / max(abs(d.x) + abs(d.y) + d.z, 1e-30);
    return vec2<f32>(p.x + p.y, p.x - p.y);
}

fn hemi_octahedral_direction(uv: vec2<f32>) -> vec3<f32> {
    let p = vec2<f32>(uv.x + uv.y, uv.x - uv.y) * 0.5;
    return normalize(vec3<f32>(p, 1.0 - abs(p.x) - abs(p.y)));
}

fn unpack_loss(texel: vec4<u32>) -> vec3<f32> {
    return vec3<f32>(unpack2x16float(texel.x), unpack2x16float(texel.y).x);
}

// The loss at unit normal `n` (camera space) of the sphere of row `row`, bilinear in the map.
fn loss_map_lookup(row: u32, n: vec3<f32>) -> vec3<f32> {
    let basis = loss_map_basis(loss_map_sphere(row).xyz);
    let uv = hemi_octahedral(transpose(basis) * n);
    let size = f32(LOSS_MAP_TEXELS);
    let texel = (uv * 0.5 + 0.5) * size - 0.5;
    let base = clamp(floor(texel), vec2<f32>(0.0), vec2<f32>(size - 2.0));
    let f = clamp(texel - base, vec2<f32>(0.0), vec2<f32>(1.0));
    let at = vec2<i32>(base) + vec2<i32>(0, i32(row * LOSS_MAP_TEXELS));
    let l00 = unpack_loss(textureLoad(loss_maps, at, 0));
    let l10 = unpack_loss(textureLoad(loss_maps, at + vec2<i32>(1, 0), 0));
    let l01 = unpack_loss(textureLoad(loss_maps, at + vec2<i32>(0, 1), 0));
    let l11 = unpack_loss(textureLoad(loss_maps, at + vec2<i32>(1, 1), 0));
    return mix(mix(l00, l10, f.x), mix(l01, l11, f.x), f.y);
}

// What the live objects' shadows took from the light a live fragment receives (shadow_loss):
// from its sphere's map where it has one, else gathered here.
fn own_shadow_loss(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return own_shadow_loss_with(p, n, true);
}

// own_shadow_loss; where no map serves, gathered here only with `gather` (else zero). Callers
// pass a constant: with `false` the shader holds no gather code at all, which lavapipe would
// otherwise run through with its lanes off (fs_radiosity_map_moving).
fn own_shadow_loss_with(p: vec3<f32>, n: vec3<f32>, gather: bool) -> vec3<f32> {
    if loss_map_row >= 0 && u32(loss_map_row) < loss_map_rows() {
        let row = u32(loss_map_row);
        let drawn = textureLoad(loss_maps, vec2<i32>(0, i32(row * LOSS_MAP_TEXELS)), 0).w == 1u;
        if drawn && loss_map_serves(loss_map_sphere(row)) {
            return loss_map_lookup(row, n);
        }
    }
    if gather {
        return shadow_loss(p, n);
    }
    return vec3<f32>(0.0);
}

// One texel of the atlas: the loss at the texel's normal of the sphere of its row.
@fragment
fn fs_loss_map(@builtin(position) position: vec4<f32>) -> @location(0) vec4<u32> {
    let texel = vec2<u32>(position.xy);
    if frame.tone.w > 0.5 {
        shadow_gather_directions = SHADOW_GATHER_MOVING;
    }
    let row = texel.y / LOSS_MAP_TEXELS;
    if row >= loss_map_rows() {
        return vec4<u32>(0u);
    }
    let s = loss_map_sphere(row);
    if !loss_map_serves(s) {
        return vec4<u32>(0u);
    }
    let uv = (vec2<f32>(texel % vec2<u32>(LOSS_MAP_TEXELS)) + vec2<f32>(0.5)) / f32(LOSS_MAP_TEXELS) * 2.0
        - vec2<f32>(1.0);
    let n = loss_map_basis(s.xyz) * hemi_octahedral_direction(uv);
    let irradiance = min(shadow_loss(s.xyz + s.w * n, n), vec3<f32>(65504.0));
    return vec4<u32>(pack2x16float(irradiance.rg), pack2x16float(vec2<f32>(irradiance.b, 0.0)), 0u, 1u);
}

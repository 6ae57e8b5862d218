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

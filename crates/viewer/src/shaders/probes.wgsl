// Scene light on live surfaces from the renderer's baked probes: the irradiance field (SH
// probes with visibility) and the reflection probes (octahedral radiance and distance maps).
// Part of the compositing module (compositor::COMPOSITE_WGSL); the bindings are composite.wgsl's.

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
// The reflection probes: a port of sidecar::ReflectionProbes::glossy_radiance (its reference
// lookup over the glossy lobe).

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
    return probe_distance_texel(probe, dir).r;
}

// The distance map's texel of `probe` toward unit `dir`: r the distance, g the `specular` mark.
fn probe_distance_texel(probe: u32, dir: vec3<f32>) -> vec4<f32> {
    let uv = octahedral_uv(dir);
    let n = f32(REFLECTION_TEXELS);
    let texel = min(vec2<u32>(uv * n), vec2<u32>(REFLECTION_TEXELS - 1u));
    return textureLoad(reflection_distance, texel, probe, 0);
}

// Whether the first surface toward world point `x` from the probe of grid cell `cell` is
// specular (a mirror or glass: the distance map's second channel, the sidecar's `specular`
// marks, 0 for probes without them).
fn probe_specular_at(cell: vec3<u32>, x: vec3<f32>) -> bool {
    let to_x = x - probe_position(cell);
    let d = length(to_x);
    if !(d > 0.0) {
        return false;
    }
    return probe_distance_texel(probe_index(cell), to_x / d).g > 0.5;
}

fn probe_sees(cell: vec3<u32>, p: vec3<f32>) -> bool {
    let to_p = p - probe_position(cell);
    let d = length(to_p);
    if !(d > 0.0) {
        return true;
    }
    return d <= 1.05 * probe_distance_toward(probe_index(cell), to_p / d);
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

// The weight of probe corner `c` for the point q (p moved off its surface by the normal bias)
// with world unit normal n: trilinear times the backface term times Chebyshev visibility,
// small weights crushed (sidecar::ProbeGrid::irradiance_of).
fn field_corner_weight(c: CellCorner, q: vec3<f32>, n: vec3<f32>) -> f32 {
    let to_probe = frame.irradiance_origin.xyz + vec3<f32>(c.probe) * frame.irradiance_spacing.xyz - q;
    let distance = length(to_probe);
    var dir = n;
    if distance > 0.0 {
        dir = to_probe / distance;
    }
    let h = (dot(dir, n) + 1.0) * 0.5;
    let backface = h * h + 0.2;
    return crushed(c.trilinear * backface * max(field_visibility(field_probe_index(c.probe), dir, distance), 1e-6));
}

// p moved off its surface along n by DDGI's normal bias, `0.1 * min(spacing)`.
fn field_biased(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let spacing = frame.irradiance_spacing.xyz;
    return p + n * (0.1 * min(spacing.x, min(spacing.y, spacing.z)));
}

fn field_cell(q: vec3<f32>) -> GridCell {
    return grid_cell(q, frame.irradiance_origin.xyz, frame.irradiance_spacing.xyz, frame.irradiance_counts.xyz);
}

// The scene's indirect irradiance at world point p with world unit normal n.
fn field_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let q = field_biased(p, n);
    let grid = field_cell(q);
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let c = cell_corner(grid, corner);
        if c.trilinear <= 0.0 {
            continue;
        }
        let w = field_corner_weight(c, q, n);
        sum += w * probe_sh_irradiance(field_probe_index(c.probe), n);
        total += w;
    }
    if total > 0.0 {
        return max(sum / total, vec3<f32>(0.0));
    }
    return vec3<f32>(0.0);
}

// The radiance SH field_irradiance blends at p (normal n): the probes' SH with its weights.
fn field_radiance_sh(p: vec3<f32>, n: vec3<f32>) -> array<vec4<f32>, 9> {
    let q = field_biased(p, n);
    let grid = field_cell(q);
    var sh: array<vec4<f32>, 9>;
    for (var i = 0u; i < 9u; i++) {
        sh[i] = vec4<f32>(0.0);
    }
    var total = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let c = cell_corner(grid, corner);
        if c.trilinear <= 0.0 {
            continue;
        }
        let w = field_corner_weight(c, q, n);
        let probe = field_probe_index(c.probe);
        for (var i = 0u; i < 9u; i++) {
            sh[i] += w * irradiance_sh[9u * probe + i];
        }
        total += w;
    }
    if total > 0.0 {
        for (var i = 0u; i < 9u; i++) {
            sh[i] /= total;
        }
    }
    return sh;
}

// Radiance arriving from world unit direction d according to radiance SH `sh` (sidecar::sh's
// basis), never below zero (a band-limited field rings).
fn sh_radiance(sh: array<vec4<f32>, 9>, d: vec3<f32>) -> vec3<f32> {
    var l = 0.2820948 * sh[0].rgb;
    l += 0.4886025 * (d.y * sh[1].rgb + d.z * sh[2].rgb + d.x * sh[3].rgb);
    l += 1.0925484 * d.x * d.y * sh[4].rgb + 1.0925484 * d.y * d.z * sh[5].rgb
        + 0.3153916 * (3.0 * d.z * d.z - 1.0) * sh[6].rgb + 1.0925484 * d.x * d.z * sh[7].rgb
        + 0.5462742 * (d.x * d.x - d.y * d.y) * sh[8].rgb;
    return max(l, vec3<f32>(0.0));
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

// The reflection probes' mip level whose prefiltering lobe has Blinn exponent e
// (sidecar::reflection_level of roughness 1 / e).
fn reflection_level_of_exponent(e: f32) -> f32 {
    if e >= 64.0 {
        return 64.0 / e;
    }
    return min(1.0 + 0.5 * log2(64.0 / e), 4.0);
}

// Directions of the Blinn lobe a glossy live fragment reads the reflection probes in
// (sidecar::GLOSSY_SAMPLES).
const GLOSSY_SAMPLES: u32 = 16u;
// The same in a moving frame (glossy_reflection_from_probes), each direction read at the mip
// level of the wider solid angle it stands for: the lobe's eight probe reads per direction cost
// most of the moving cursor sphere's radiance map on lavapipe.
const GLOSSY_SAMPLES_MOVING: u32 = 8u;

// Direction `i` of `count` of a Blinn lobe of exponent `e` about unit normal n (tangents t and
// b) seen from unit direction v, importance-sampled as raytracer::bsdf samples it: a stratified
// u1, u2 the radical inverse of i, turned by `turn` (0: none). Every lobe sampler here draws its
// directions through it, so the frame at rest, the moving frame and the maps see one lobe.
struct BlinnDirection {
    // The reflected direction (unit when o_dot_h > 0).
    l: vec3<f32>,
    // The half vector's cosine to n, its cosine to v, and l's cosine to n.
    cos_h: f32,
    o_dot_h: f32,
    cos_l: f32,
}

fn blinn_direction(i: u32, count: u32, turn: f32, e: f32, n: vec3<f32>, t: vec3<f32>, b: vec3<f32>, v: vec3<f32>) -> BlinnDirection {
    let u1 = (f32(i) + 0.5) / f32(count);
    let u2 = fract(f32(reverseBits(i)) * 2.3283064365386963e-10 + turn);
    let cos_h = pow(u1, 1.0 / (e + 1.0));
    let sin_h = sqrt(max(1.0 - cos_h * cos_h, 0.0));
    let phi = 2.0 * PI * u2;
    let h = normalize(t * (sin_h * cos(phi)) + b * (sin_h * sin(phi)) + n * cos_h);
    let o_dot_h = dot(v, h);
    let l = 2.0 * o_dot_h * h - v;
    return BlinnDirection(l, cos_h, o_dot_h, dot(n, l));
}

// The reflection probes' radiance averaged over the ray tracer's Blinn lobe (`exponent`) at
// world point p, unit normal n and unit direction to the eye v: the lobe's own directions
// (importance-sampled, a fixed stratified set), each weighted by `f cos / pdf` and read at the
// mip level whose prefiltering lobe is as wide as the solid angle the direction stands for
// (Krivanek and Colbert 2008); the probe of the largest weight finds where each direction meets
// the scene, and every probe is read toward those points. A port of
// sidecar::ReflectionProbes::glossy_radiance, but for the live objects, which the reference
// does not know: with their shadows on, each direction's radiance loses the share their shadows
// took from the point it meets (live_share_at_hit). The split sum's single lookup toward the mirror
// direction assumes the lobe centred there, as it is only at normal incidence; a wide lobe seen at a
// grazing angle leans toward the normal and loses its part below the horizon, so it reflects
// what lies under a sphere's lower half, not the horizon the mirror direction meets.
fn glossy_reflection(p: vec3<f32>, n: vec3<f32>, v: vec3<f32>, exponent: f32, traced_hits: bool) -> vec3<f32> {
    let cos_o = max(dot(n, v), 1e-3);
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
    let t = normalize(cross(helper, n));
    let b = cross(n, t);
    var directions: array<vec4<f32>, GLOSSY_SAMPLES>;
    var weights: array<f32, GLOSSY_SAMPLES>;
    var total = 0.0;
    for (var i = 0u; i < GLOSSY_SAMPLES; i++) {
        weights[i] = 0.0;
        directions[i] = vec4<f32>(n, 0.0);
        let d = blinn_direction(i, GLOSSY_SAMPLES, 0.0, exponent, n, t, b, v);
        let cos_h = d.cos_h;
        let o_dot_h = d.o_dot_h;
        if o_dot_h <= 0.0 {
            continue;
        }
        let l = d.l;
        let cos_l = d.cos_l;
        if cos_l <= 0.0 {
            continue;
        }
        // f cos / pdf of raytracer::bsdf's Blinn lobe sampled by its half vector.
        let g = min(min(2.0 * cos_h * cos_o / o_dot_h, 2.0 * cos_h * cos_l / o_dot_h), 1.0);
        weights[i] = g * o_dot_h / cos_o;
        total += weights[i];
        // The prefiltering lobe of exponent e spans about 8 pi / e steradians.
        let pdf = (exponent + 1.0) * pow(cos_h, exponent) / (8.0 * PI * o_dot_h);
        let omega = 1.0 / (f32(GLOSSY_SAMPLES) * max(pdf, 1e-6));
        directions[i] = vec4<f32>(l, reflection_level_of_exponent(8.0 * PI / omega));
    }
    if !(total > 0.0) {
        return vec3<f32>(0.0);
    }
    let grid = grid_cell(p, frame.reflection_origin.xyz, frame.reflection_spacing.xyz, frame.reflection_counts.xyz);
    // The probes around p and their weights; the one with the largest weight that sees p
    // finds where each direction meets the scene (its distance map, parallax-corrected).
    var cells: array<vec3<u32>, 8>;
    var probe_weights: array<f32, 8>;
    var nearest = 0u;
    var nearest_weight = -1.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let c = cell_corner(grid, corner);
        cells[corner] = c.probe;
        probe_weights[corner] = 0.0;
        if c.trilinear <= 0.0 {
            continue;
        }
        let sees = probe_sees(c.probe, p);
        probe_weights[corner] = select(1e-3 * c.trilinear, c.trilinear, sees);
        if probe_weights[corner] > nearest_weight {
            nearest_weight = probe_weights[corner];
            nearest = corner;
        }
    }
    // Where each direction meets the scene: the first triangle of the tessellated scene where
    // the viewer has them (scene_occluders), else the distance map of that probe. A lobe
    // direction from a surface close to others meets points the probes around p do not see (the
    // floor behind a neighbour, a crevice): read from p's probes toward such a point, they show
    // the neighbour in front of it.
    // A traced direction that meets a mirror follows it (specular_chain): its point is then
    // where the chain ends, and its radiance carries the chain's weight; a chain that leaves the
    // scene reads p's probes in its last direction. A traced direction whose chain ends on a
    // glossy scene surface takes that surface's radiance toward the chain's last point from its
    // own material (own_radiance, w 1): the probes saw its highlights and reflections from their
    // own points.
    // Where the directions are not traced (a mirror's, glass's or metal's pass), one whose point
    // is on a mirror or glass (the nearest probe's `specular` mark there) is read in its own
    // direction, as a distant scene's, not toward that point: a probe holds there the image its
    // own place sees (a glass ball's lens image, 1.5 times what the sphere behind the ball sees
    // in caustics given0), which the parallax correction would move to p.
    var hits: array<vec3<f32>, GLOSSY_SAMPLES>;
    var traced: array<bool, GLOSSY_SAMPLES>;
    var own_radiance: array<vec4<f32>, GLOSSY_SAMPLES>;
    var chain_weights: array<vec3<f32>, GLOSSY_SAMPLES>;
    // Read in its (last) direction, not toward a point: a chain that left the scene, or an
    // untraced direction toward a mirror or glass.
    var distant: array<bool, GLOSSY_SAMPLES>;
    let p_camera = camera_point_of(p);
    for (var i = 0u; i < GLOSSY_SAMPLES; i++) {
        traced[i] = false;
        own_radiance[i] = vec4<f32>(0.0);
        chain_weights[i] = vec3<f32>(1.0);
        distant[i] = false;
        if weights[i] > 0.0 {
            hits[i] = probe_hit(cells[nearest], p, directions[i].xyz);
            if traced_hits {
                let chain = specular_chain(p_camera, p, directions[i].xyz);
                if chain.ended > 0.5 {
                    hits[i] = chain.point;
                    traced[i] = true;
                    chain_weights[i] = chain.weight;
                    own_radiance[i] = glossy_surface_radiance(chain.start, chain.hit);
                } else if chain.ended > -0.5 {
                    directions[i] = vec4<f32>(chain.direction, directions[i].w);
                    chain_weights[i] = chain.weight;
                    distant[i] = true;
                }
            } else {
                distant[i] = probe_specular_at(cells[nearest], hits[i]);
            }
        }
    }
    // The probes saw the scene without the live objects: with their shadows on, what those
    // took from each hit's light (backdrop_shadowed is the frame after the shadow pass) is
    // taken from its radiance, as the eye sees it taken (live_share_at_hit).
    var kept: array<vec3<f32>, GLOSSY_SAMPLES>;
    for (var i = 0u; i < GLOSSY_SAMPLES; i++) {
        kept[i] = vec3<f32>(1.0);
        if frame.counts.y == 1u && weights[i] > 0.0 && own_radiance[i].w < 0.5 && !distant[i] {
            if traced[i] {
                kept[i] = vec3<f32>(1.0) - live_share_at_point(hits[i]);
            } else {
                kept[i] = vec3<f32>(1.0) - live_share_at_hit(cells[nearest], p, directions[i].xyz, hits[i]);
            }
        }
    }
    // Each direction's radiance, read toward its point from p's probes, those that do not see a
    // traced point by 1e-3 of their weight; where none of them sees it, from the probes of the
    // point's own cell, trilinear at the point and 1e-3 of that for a probe that does not see it.
    var sum = vec3<f32>(0.0);
    var probes_total = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        probes_total += probe_weights[corner];
    }
    if !(probes_total > 0.0) {
        return vec3<f32>(0.0);
    }
    for (var i = 0u; i < GLOSSY_SAMPLES; i++) {
        if own_radiance[i].w > 0.5 {
            sum += weights[i] * chain_weights[i] * own_radiance[i].rgb;
        } else if weights[i] > 0.0 {
            var hit_grid = grid;
            var from_hit_cell = false;
            if traced[i] {
                var seen = false;
                for (var corner = 0u; corner < 8u; corner++) {
                    seen = seen || (probe_weights[corner] > 0.0 && probe_sees_hit(cells[corner], hits[i]));
                }
                from_hit_cell = !seen;
                hit_grid = grid_cell(hits[i], frame.reflection_origin.xyz, frame.reflection_spacing.xyz, frame.reflection_counts.xyz);
            }
            var radiance = vec3<f32>(0.0);
            var radiance_weight = 0.0;
            for (var corner = 0u; corner < 8u; corner++) {
                var w = probe_weights[corner];
                var cell = cells[corner];
                if from_hit_cell {
                    let c = cell_corner(hit_grid, corner);
                    cell = c.probe;
                    w = select(1e-3 * c.trilinear, c.trilinear, probe_sees_hit(cell, hits[i]));
                } else if traced[i] {
                    w = select(1e-3 * w, w, probe_sees_hit(cell, hits[i]));
                }
                if w > 0.0 {
                    let to_hit = hits[i] - probe_position(cell);
                    let len = length(to_hit);
                    let dir = select(directions[i].xyz, to_hit / len, len > 0.0 && !distant[i]);
                    radiance += w * textureSampleLevel(reflection_radiance, reflection_sampler, octahedral_uv(dir), probe_index(cell), directions[i].w).rgb;
                    radiance_weight += w;
                }
            }
            if radiance_weight > 0.0 {
                sum += weights[i] * kept[i] * chain_weights[i] * radiance / radiance_weight;
            }
        }
    }
    return sum / total;
}

// glossy_reflection without traced hits, for entry points that never trace the lobe's
// directions (the moving cursor sphere's radiance map): the same sums in one pass over the
// directions, without the traced directions' code or the arrays that carry each direction
// between passes. lavapipe runs the code of a branch no fragment of a group takes with its
// lanes off, each loop's body once; that the traced branches then cost a frame that never takes
// them as much as one that does was measured while lavapipe still compiled
// each pipeline again at every bind (docs/viewer-frame-time.md, "The leak fixed").
fn glossy_reflection_from_probes(p: vec3<f32>, n: vec3<f32>, v: vec3<f32>, exponent: f32) -> vec3<f32> {
    let cos_o = max(dot(n, v), 1e-3);
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
    let t = normalize(cross(helper, n));
    let b = cross(n, t);
    let grid = grid_cell(p, frame.reflection_origin.xyz, frame.reflection_spacing.xyz, frame.reflection_counts.xyz);
    var cells: array<vec3<u32>, 8>;
    var probe_weights: array<f32, 8>;
    var nearest_cell = vec3<u32>(0u);
    var nearest_weight = -1.0;
    var probes_total = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let c = cell_corner(grid, corner);
        cells[corner] = c.probe;
        probe_weights[corner] = 0.0;
        if c.trilinear > 0.0 {
            let sees = probe_sees(c.probe, p);
            probe_weights[corner] = select(1e-3 * c.trilinear, c.trilinear, sees);
            if probe_weights[corner] > nearest_weight {
                nearest_weight = probe_weights[corner];
                nearest_cell = c.probe;
            }
        }
        probes_total += probe_weights[corner];
    }
    if !(probes_total > 0.0) {
        return vec3<f32>(0.0);
    }
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var i = 0u; i < GLOSSY_SAMPLES_MOVING; i++) {
        let d = blinn_direction(i, GLOSSY_SAMPLES_MOVING, 0.0, exponent, n, t, b, v);
        let cos_h = d.cos_h;
        let o_dot_h = d.o_dot_h;
        let l = d.l;
        let cos_l = d.cos_l;
        // No `continue`: lavapipe lost fragments' remaining iterations after one (direct_light_over).
        if o_dot_h > 0.0 && cos_l > 0.0 {
            let g = min(min(2.0 * cos_h * cos_o / o_dot_h, 2.0 * cos_h * cos_l / o_dot_h), 1.0);
            let weight = g * o_dot_h / cos_o;
            total += weight;
            if weight > 0.0 {
                let pdf = (exponent + 1.0) * pow(cos_h, exponent) / (8.0 * PI * o_dot_h);
                let omega = 1.0 / (f32(GLOSSY_SAMPLES_MOVING) * max(pdf, 1e-6));
                let level = reflection_level_of_exponent(8.0 * PI / omega);
                // Where the direction meets the scene, and the radiance of each probe toward it.
                let hit = probe_hit(nearest_cell, p, l);
                let distant = probe_specular_at(nearest_cell, hit);
                var kept = vec3<f32>(1.0);
                if frame.counts.y == 1u && !distant {
                    kept = vec3<f32>(1.0) - live_share_at_hit(nearest_cell, p, l, hit);
                }
                var radiance = vec3<f32>(0.0);
                var radiance_weight = 0.0;
                for (var corner = 0u; corner < 8u; corner++) {
                    let w = probe_weights[corner];
                    if w > 0.0 {
                        let to_hit = hit - probe_position(cells[corner]);
                        let len = length(to_hit);
                        let dir = select(l, to_hit / len, len > 0.0 && !distant);
                        radiance += w * textureSampleLevel(reflection_radiance, reflection_sampler, octahedral_uv(dir), probe_index(cells[corner]), level).rgb;
                        radiance_weight += w;
                    }
                }
                if radiance_weight > 0.0 {
                    sum += weight * kept * radiance / radiance_weight;
                }
            }
        }
    }
    if !(total > 0.0) {
        return vec3<f32>(0.0);
    }
    return sum / total;
}

// Whether the probe of grid cell `cell` sees the scene's surface point `x`: nothing nearer than
// 80 % of x's distance in x's direction on its distance map. probe_sees's 5 % slack takes a
// floor point seen at a grazing angle for hidden (the texel's centre meets it nearer).
fn probe_sees_hit(cell: vec3<u32>, x: vec3<f32>) -> bool {
    let to_x = x - probe_position(cell);
    let d = length(to_x);
    if !(d > 0.0) {
        return true;
    }
    return 0.8 * d <= probe_distance_toward(probe_index(cell), to_x / d);
}

// Where a ray first meets the tessellated scene (specular_chain's last segment): its distance
// in camera units from the segment's start, the ray's unit camera-space direction and the
// triangle (the chain's end carries the world point).
struct SceneHit {
    distance: f32,
    dir: vec3<f32>,
    triangle: u32,
}

// The radiance a traced lobe direction's hit sends back along the ray to camera-space
// p_camera (the start of the hit's segment) when the scene's materials are bound and the hit's material has a glossy lobe (and is
// no mirror or glass), w 1; else w 0 (the reflection probes' radiance serves). A glossy
// surface's radiance depends on the direction it is seen from: a reflection probe reads the
// highlights and reflections it shows toward the probe, not toward p (room given2: the red
// plastic sphere beside a live sphere sent its side 0.02-0.03 too much grey in G and B, and the
// gold metal cylinder on the other side too little warm light). Its own material gives it
// (near_surface_radiance: the lights' direct light and highlights toward p, the irradiance
// probes' diffuse light and their light the lobe reflects from the mirror direction), with the
// live objects' shadows on it.
fn glossy_surface_radiance(p_camera: vec3<f32>, hit: SceneHit) -> vec4<f32> {
    let count = u32(scene_materials[0].x);
    let tag = bitcast<u32>(occluder_triangles[3u * hit.triangle].w);
    if tag < 1u || tag > count || frame.counts.w != 1u {
        return vec4<f32>(0.0);
    }
    let material = tag - 1u;
    let glossy = scene_materials[1u + 4u * material + 1u];
    if glossy.w > 0.5 || !any(glossy.rgb > vec3<f32>(0.0)) {
        return vec4<f32>(0.0);
    }
    let e1 = occluder_triangles[3u * hit.triangle + 1u].xyz;
    let e2 = occluder_triangles[3u * hit.triangle + 2u].xyz;
    var m = normalize(cross(e1, e2));
    m = select(m, -m, dot(m, hit.dir) > 0.0);
    let y = p_camera + hit.distance * hit.dir;
    return vec4<f32>(near_surface_radiance(material, y, m, -hit.dir), 1.0);
}

// Where the ray p + t r meets the surface a probe's distance map describes (world space; the
// fixed-point steps of sidecar::ReflectionProbes::hit_toward).
fn probe_hit(cell: vec3<u32>, p: vec3<f32>, r: vec3<f32>) -> vec3<f32> {
    let probe = probe_index(cell);
    let origin = probe_position(cell);
    let pc = p - origin;
    var hit = pc;
    var dir = r;
    for (var step = 0; step < 3; step++) {
        let radius = probe_distance_toward(probe, dir);
        let b = dot(pc, r);
        let disc = b * b - (dot(pc, pc) - radius * radius);
        if disc < 0.0 {
            break;
        }
        let t = max(-b + sqrt(disc), 0.0);
        hit = pc + t * r;
        let len = length(hit);
        if !(len > 0.0) {
            break;
        }
        dir = hit / len;
    }
    return origin + hit;
}

// ---------------------------------------------------------------------------------------------
// The live objects' shadows where a glossy live surface's lobe meets the scene.

// The surface point a probe's distance map holds at `texel` (the bake measures each texel's
// centre), relative to the probe (octahedral_direction is bounce.wgsl's).
fn probe_texel_point(probe: u32, texel: vec2<u32>) -> vec3<f32> {
    let dir = octahedral_direction((vec2<f32>(texel) + 0.5) / f32(REFLECTION_TEXELS));
    return dir * textureLoad(reflection_distance, texel, probe, 0).r;
}

// The step from surface point `centre` (of `texel`) to its neighbour along one axis of the map,
// on the side whose surface point lies nearer (the same surface more likely than across an
// edge); the step back is negated, so both point the same way.
fn nearer_neighbour(probe: u32, texel: vec2<u32>, axis: vec2<u32>, centre: vec3<f32>) -> vec3<f32> {
    let t = dot(texel, axis);
    var best = vec3<f32>(0.0);
    var best_gap = 3.0e38;
    if t + 1u < REFLECTION_TEXELS {
        best = probe_texel_point(probe, texel + axis) - centre;
        best_gap = dot(best, best);
    }
    if t > 0u {
        let back = centre - probe_texel_point(probe, texel - axis);
        if dot(back, back) < best_gap {
            best = back;
        }
    }
    return best;
}

// Where the ray p + t l meets the surface a probe's distance map describes, from `hit` (the
// ray's probe_hit): the ray met with the plane through the surface points of the texel the
// point is in and of its nearer neighbours along both axes, again with the texel that point is
// in until it stays (three times at most); `hit` where the map has no plane facing the ray.
// probe_hit's fixed-point steps on the texels' distances land up to a texel off, which near a
// live object's contact is the difference between its shadow and none.
fn probe_surface_point(cell: vec3<u32>, p: vec3<f32>, l: vec3<f32>, hit: vec3<f32>) -> vec3<f32> {
    let probe = probe_index(cell);
    let origin = probe_position(cell);
    var point = hit;
    var texel = vec2<u32>(REFLECTION_TEXELS);
    for (var round = 0; round < 3; round++) {
        let to_point = point - origin;
        let len = length(to_point);
        if !(len > 0.0) {
            break;
        }
        let at = min(vec2<u32>(octahedral_uv(to_point / len) * f32(REFLECTION_TEXELS)), vec2<u32>(REFLECTION_TEXELS - 1u));
        if all(at == texel) {
            break;
        }
        texel = at;
        let centre = probe_texel_point(probe, texel);
        let n = cross(nearer_neighbour(probe, texel, vec2<u32>(1u, 0u), centre), nearer_neighbour(probe, texel, vec2<u32>(0u, 1u), centre));
        let facing = dot(l, n);
        // A plane seen edge-on (or no plane: n zero) keeps the last point.
        if !(abs(facing) > 1e-4 * length(n)) {
            break;
        }
        let t = dot(origin + centre - p, n) / facing;
        if !(t > 0.0) {
            break;
        }
        point = p + t * l;
    }
    return point;
}

// Camera-space point of world point w (the camera transform is a similarity:
// compositor/lighting.rs takes its uniform scale).
fn camera_point_of(w: vec3<f32>) -> vec3<f32> {
    let m = mat3x3<f32>(frame.world_from_camera[0].xyz, frame.world_from_camera[1].xyz, frame.world_from_camera[2].xyz);
    return transpose(m) * (w - frame.world_from_camera_point[3].xyz) / dot(m[0], m[0]);
}

// The share of its radiance that the live objects take from the point where lobe direction l
// from world point p meets the scene (near `hit`, its probe_hit with the probe of grid cell
// `cell`), per channel: where the eye sees that point in the render, the shadow pass's own share
// at its pixel, `1 - backdrop_shadowed / backdrop_colour` (the light layers' exact shadows of
// every light, the occlusion of indirect light, the blocked caustics, for whatever material
// the surface has: a metal or glass surface loses only its own highlight); zero where the eye
// does not see it (a Lambertian model there, live_shadow_share, made the room's floating
// sphere over the metal cylinder darker than the truth: docs/viewer-lighting.md).
fn live_share_at_hit(cell: vec3<u32>, p: vec3<f32>, l: vec3<f32>, hit: vec3<f32>) -> vec3<f32> {
    return live_share_at_point(probe_surface_point(cell, p, l, hit));
}

// live_share_at_hit at world point `point` on the scene's surface.
fn live_share_at_point(point: vec3<f32>) -> vec3<f32> {
    let seen = probe_depth(camera_point_of(point));
    // Within 3 % of the depth: a pixel's footprint along its ray at grazing views.
    if seen.pixel.x < 0 || !(seen.surface < 3.0e38) || abs(seen.distance - seen.surface) > 0.03 * seen.surface {
        return vec3<f32>(0.0);
    }
    let before = textureLoad(backdrop_colour, seen.pixel, 0).rgb;
    let after = textureLoad(backdrop_shadowed, seen.pixel, 0).rgb;
    let share = clamp(vec3<f32>(1.0) - after / max(before, vec3<f32>(1e-30)), vec3<f32>(0.0), vec3<f32>(1.0));
    return select(vec3<f32>(0.0), share, before > vec3<f32>(1e-6));
}

// Shadow rays through triangle hierarchies (appended to composite.wgsl: compositor/mod.rs
// COMPOSITE_WGSL): the tessellated scene blocking the RIB lights' light on live objects, and
// the live meshes blocking it on the pre-rendered scene. The layout is viewer::occluders::
// FlatBvh's; both hierarchies share the two buffers (compositor/scene_shadows.rs).

// Per node two vec4s: bounds minimum with the first child (interior) or first triangle (leaf)
// as bits in w, bounds maximum with the triangle count (0: interior) in w.
@group(0) @binding(12) var<storage, read> occluder_nodes: array<vec4<f32>>;
// Per triangle three vec4s: a corner and the two edges from it.
@group(0) @binding(13) var<storage, read> occluder_triangles: array<vec4<f32>>;

// Deeper than any hierarchy of the budgets' triangles (median splits halve each level).
const OCCLUDER_STACK: u32 = 40u;
// How far barycentric coordinates may stray outside a triangle (occluders::ray_triangle), so
// that edges shared by two triangles leak no light.
const EDGE_SLACK: f32 = 1e-5;

// Where the ray from `origin` along unit `dir` meets occluder triangle i (Moeller-Trumbore, its
// edges widened by EDGE_SLACK), NO_TRIANGLE_HIT where it does not.
const NO_TRIANGLE_HIT: f32 = -3.0e38;
fn occluder_triangle_t(i: u32, origin: vec3<f32>, dir: vec3<f32>) -> f32 {
    let v0 = occluder_triangles[3u * i].xyz;
    let e1 = occluder_triangles[3u * i + 1u].xyz;
    let e2 = occluder_triangles[3u * i + 2u].xyz;
    let pv = cross(dir, e2);
    let det = dot(e1, pv);
    if det == 0.0 {
        return NO_TRIANGLE_HIT;
    }
    let inv_det = 1.0 / det;
    let tv = origin - v0;
    let u = dot(tv, pv) * inv_det;
    let qv = cross(tv, e1);
    let v = dot(dir, qv) * inv_det;
    if u < -EDGE_SLACK || v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
        return NO_TRIANGLE_HIT;
    }
    return dot(e2, qv) * inv_det;
}

// Whether a triangle of hierarchy `bvh` (first node, first triangle, node count) blocks the
// segment from `origin` along unit `dir` between t_min and t_max.
fn bvh_blocks(bvh: vec4<u32>, origin: vec3<f32>, dir: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    if bvh.z == 0u {
        return false;
    }
    // Near-zero components get a huge finite inverse: the slab test stays free of NaN.
    let inv = select(1.0 / dir, vec3<f32>(1e30), abs(dir) < vec3<f32>(1e-30));
    var stack: array<u32, OCCLUDER_STACK>;
    stack[0] = 0u;
    var top = 1u;
    while top > 0u {
        top -= 1u;
        let k = bvh.x + stack[top];
        let lo = occluder_nodes[2u * k];
        let hi = occluder_nodes[2u * k + 1u];
        let t0 = (lo.xyz - origin) * inv;
        let t1 = (hi.xyz - origin) * inv;
        let tn = min(t0, t1);
        let tf = max(t0, t1);
        let near = max(max(tn.x, tn.y), max(tn.z, t_min));
        let far = min(min(tf.x, tf.y), min(tf.z, t_max));
        if near > far {
            continue;
        }
        let a = bitcast<u32>(lo.w);
        let count = bitcast<u32>(hi.w);
        if count == 0u {
            if top + 2u <= OCCLUDER_STACK {
                stack[top] = a;
                stack[top + 1u] = a + 1u;
                top += 2u;
            }
            continue;
        }
        for (var i = bvh.y + a; i < bvh.y + a + count; i++) {
            let t = occluder_triangle_t(i, origin, dir);
            if t > t_min && t < t_max {
                return true;
            }
        }
    }
    return false;
}

// The first scene triangle a ray meets: its distance along the ray (t_max: none) and index.
struct NearHit {
    t: f32,
    triangle: u32,
}

// Where the ray from `origin` along unit `dir` first meets a triangle of hierarchy `bvh`
// between t_min and t_max (the layout of bvh_blocks).
fn bvh_nearest(bvh: vec4<u32>, origin: vec3<f32>, dir: vec3<f32>, t_min: f32, t_max: f32) -> NearHit {
    var hit = NearHit(t_max, 0u);
    if bvh.z == 0u {
        return hit;
    }
    let inv = select(1.0 / dir, vec3<f32>(1e30), abs(dir) < vec3<f32>(1e-30));
    var stack: array<u32, OCCLUDER_STACK>;
    stack[0] = 0u;
    var top = 1u;
    while top > 0u {
        top -= 1u;
        let k = bvh.x + stack[top];
        let lo = occluder_nodes[2u * k];
        let hi = occluder_nodes[2u * k + 1u];
        let range = slab(origin, inv, lo.xyz, hi.xyz, 0.0, t_min, hit.t);
        if range.x > range.y {
            continue;
        }
        let a = bitcast<u32>(lo.w);
        let count = bitcast<u32>(hi.w);
        if count == 0u {
            if top + 2u <= OCCLUDER_STACK {
                stack[top] = a;
                stack[top + 1u] = a + 1u;
                top += 2u;
            }
            continue;
        }
        for (var i = bvh.y + a; i < bvh.y + a + count; i++) {
            let t = occluder_triangle_t(i, origin, dir);
            if t > t_min && t < hit.t {
                hit = NearHit(t, i);
            }
        }
    }
    return hit;
}

// How far a shadow ray starts off a surface at camera-space p: relative to p's distance from
// the eye, where f32 positions are that coarse.
fn ray_offset(p: vec3<f32>) -> f32 {
    return 2e-5 * max(length(p), 1.0);
}

// Whether the scene lets a light's light reach live-object point p (two-sided normal n facing
// the viewer) along unit `dir` from `distance` away: the tessellated scene (the live objects
// are not in it, so they never shadow themselves this way), the segment shortened at the light
// so that an emitter's own triangles do not hide it. The first `clear` of the segment is known
// to be free (scene_clear_toward).
fn scene_lets_light(p: vec3<f32>, n: vec3<f32>, dir: vec3<f32>, distance: f32, clear: f32) -> bool {
    if frame.scene_occluders.z == 0u {
        return true;
    }
    let eps = ray_offset(p);
    let origin = p + n * eps;
    return !bvh_blocks(frame.scene_occluders, origin, dir, clear * distance, distance * (1.0 - 1e-4) - eps);
}

// The segment [origin + t dir, t_min <= t <= t_max] against the box [lo - r, hi + r]: the
// overlapping range of t (empty when x > y).
fn slab(origin: vec3<f32>, inv: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>, r: f32, t_min: f32, t_max: f32) -> vec2<f32> {
    let t0 = (lo - vec3<f32>(r) - origin) * inv;
    let t1 = (hi + vec3<f32>(r) - origin) * inv;
    let tn = min(t0, t1);
    let tf = max(t0, t1);
    return vec2<f32>(max(max(tn.x, tn.y), max(tn.z, t_min)), min(min(tf.x, tf.y), min(tf.z, t_max)));
}

// How much of every segment from live-object point p (normal n) to an emitter within `bound`
// of `centre` is free of scene triangles, as a fraction of the segment: one traversal of the
// cone from p around the emitter (radius `bound / d` per unit distance along its axis) instead
// of a ray per emitter sample over the whole segment. A segment's point at fraction s lies
// within s * bound of the axis point at s * d, so a cone free up to axial distance c frees the
// first c / d of each segment; boxes are widened by the cone's radius (a superset of it), and
// the first leaf the cone may touch ends the free part there. The samples' rays then only test
// the rest, near the emitter, where they meet few boxes.
fn scene_clear_toward(p: vec3<f32>, n: vec3<f32>, centre: vec3<f32>, bound: f32) -> f32 {
    let bvh = frame.scene_occluders;
    let eps = ray_offset(p);
    let origin = p + n * eps;
    let to_centre = centre - origin;
    let d = length(to_centre);
    var cut = d - bound - eps;
    // No ray is traced when the whole emitter lies below p's horizon.
    if bvh.z == 0u || !(cut > 0.0) || dot(n, to_centre) < -bound {
        return 0.0;
    }
    let dir = to_centre / d;
    let slope = bound / d;
    let inv = select(1.0 / dir, vec3<f32>(1e30), abs(dir) < vec3<f32>(1e-30));
    var stack: array<u32, OCCLUDER_STACK>;
    stack[0] = 0u;
    var top = 1u;
    while top > 0u {
        top -= 1u;
        let k = bvh.x + stack[top];
        let lo = occluder_nodes[2u * k].xyz;
        let hi = occluder_nodes[2u * k + 1u];
        // The cone's radius is at most slope * (the range's far end): three narrowing steps.
        var range = slab(origin, inv, lo, hi.xyz, slope * cut, 0.0, cut);
        for (var step = 0; step < 3 && range.x <= range.y; step++) {
            range = slab(origin, inv, lo, hi.xyz, slope * range.y, 0.0, range.y);
        }
        if range.x > range.y {
            continue;
        }
        let a = bitcast<u32>(occluder_nodes[2u * k].w);
        if bitcast<u32>(hi.w) != 0u {
            cut = min(cut, range.x);
            if cut <= 0.0 {
                return 0.0;
            }
            continue;
        }
        if top + 2u <= OCCLUDER_STACK {
            stack[top] = a;
            stack[top + 1u] = a + 1u;
            top += 2u;
        } else {
            // Too deep to follow: nothing is known to be free.
            return 0.0;
        }
    }
    return max(cut, 0.0) / d;
}

// The most leaves of the scene's hierarchy scene_leaves_toward lists.
const CONE_LEAVES: u32 = 4u;

// The leaves of the scene's hierarchy that a light's samples' shadow rays from one point can
// meet (scene_leaves_toward): `count` node indices within the hierarchy; `listed` false where
// there are more than CONE_LEAVES of them, or the hierarchy is too deep to follow, and each ray
// traverses the whole hierarchy instead.
struct ConeLeaves {
    node: array<u32, CONE_LEAVES>,
    count: u32,
    listed: bool,
}

// Every leaf whose box a segment from live-object point p (normal n, the rays' origin as
// scene_lets_light offsets it) to a point within `bound` of `centre` can enter: the cone of
// scene_clear_toward over the whole length of the segments, each box widened by the cone's
// radius (narrowed in the same three steps) and by a margin for rounding. A ray through
// scene_lets_light_among then tests these leaves alone, with the same slab and triangle tests as
// bvh_blocks: a leaf's ancestors' boxes hold its own, so a ray that passes a leaf's slab test
// passes theirs, and a leaf no segment enters is one whose slab test no ray passes. So each ray's
// answer is bvh_blocks', without a traversal from the root for each of a light's many samples.
fn scene_leaves_toward(p: vec3<f32>, n: vec3<f32>, centre: vec3<f32>, bound: f32) -> ConeLeaves {
    var leaves = ConeLeaves(array<u32, CONE_LEAVES>(0u, 0u, 0u, 0u), 0u, false);
    let bvh = frame.scene_occluders;
    let eps = ray_offset(p);
    let origin = p + n * eps;
    let to_centre = centre - origin;
    let d = length(to_centre);
    if bvh.z == 0u || !(d > 0.0) {
        return leaves;
    }
    // The rays run from origin toward the samples moved by n * eps (scene_lets_light), so within
    // bound + eps of the centre; widened further for rounding.
    let reach = (bound + eps) * (1.0 + 1e-3) + eps;
    let end = d + reach;
    let dir = to_centre / d;
    let slope = reach / d;
    let inv = select(1.0 / dir, vec3<f32>(1e30), abs(dir) < vec3<f32>(1e-30));
    var stack: array<u32, OCCLUDER_STACK>;
    stack[0] = 0u;
    var top = 1u;
    while top > 0u {
        top -= 1u;
        let node = stack[top];
        let k = bvh.x + node;
        let lo = occluder_nodes[2u * k].xyz;
        let hi = occluder_nodes[2u * k + 1u];
        var range = slab(origin, inv, lo, hi.xyz, slope * end + eps, 0.0, end);
        for (var step = 0; step < 3 && range.x <= range.y; step++) {
            range = slab(origin, inv, lo, hi.xyz, slope * range.y + eps, 0.0, range.y);
        }
        if range.x > range.y {
            continue;
        }
        if bitcast<u32>(hi.w) != 0u {
            if leaves.count == CONE_LEAVES {
                return leaves;
            }
            leaves.node[leaves.count] = node;
            leaves.count += 1u;
            continue;
        }
        if top + 2u > OCCLUDER_STACK {
            return leaves;
        }
        let a = bitcast<u32>(occluder_nodes[2u * k].w);
        stack[top] = a;
        stack[top + 1u] = a + 1u;
        top += 2u;
    }
    leaves.listed = true;
    return leaves;
}

// scene_lets_light for a ray toward one of the samples `leaves` (scene_leaves_toward) was listed
// for: the same answer, from those leaves alone when they are listed.
fn scene_lets_light_among(p: vec3<f32>, n: vec3<f32>, dir: vec3<f32>, distance: f32, clear: f32, leaves: ConeLeaves) -> bool {
    if !leaves.listed {
        return scene_lets_light(p, n, dir, distance, clear);
    }
    let bvh = frame.scene_occluders;
    let eps = ray_offset(p);
    let origin = p + n * eps;
    let t_min = clear * distance;
    let t_max = distance * (1.0 - 1e-4) - eps;
    // bvh_blocks' slab and triangle tests, leaf by leaf.
    let inv = select(1.0 / dir, vec3<f32>(1e30), abs(dir) < vec3<f32>(1e-30));
    var blocked = false;
    for (var j = 0u; j < leaves.count && !blocked; j++) {
        let k = bvh.x + leaves.node[j];
        let lo = occluder_nodes[2u * k];
        let hi = occluder_nodes[2u * k + 1u];
        let t0 = (lo.xyz - origin) * inv;
        let t1 = (hi.xyz - origin) * inv;
        let tn = min(t0, t1);
        let tf = max(t0, t1);
        let near = max(max(tn.x, tn.y), max(tn.z, t_min));
        let far = min(min(tf.x, tf.y), min(tf.z, t_max));
        if near <= far {
            let first = bvh.y + bitcast<u32>(lo.w);
            let count = bitcast<u32>(hi.w);
            for (var i = first; i < first + count; i++) {
                let t = occluder_triangle_t(i, origin, dir);
                blocked = blocked || (t > t_min && t < t_max);
            }
        }
    }
    return !blocked;
}

// Whether a live mesh blocks the segment from pre-rendered surface point p along unit dir up
// to max_t. Meshes that are exact spheres cast their shadow as spheres instead.
fn live_mesh_blocks(p: vec3<f32>, dir: vec3<f32>, max_t: f32) -> bool {
    // Checked here as well: the traversal's stack is set up on every call that reaches it.
    if frame.live_occluders.z == 0u {
        return false;
    }
    return bvh_blocks(frame.live_occluders, p, dir, ray_offset(p), max_t);
}


// ---------------------------------------------------------------------------------------------
// Live objects at four samples per pixel (compositor/antialias.rs; this file is appended to
// composite.wgsl). Each sample a live object covers holds its colour, shaded once per pixel,
// with alpha 1; the others stay clear (alpha 0). resolve.wgsl filters them into the frame with
// the image's pixel filter, as the ray tracer filters its own objects' edges.

struct CoverageBackdropOut {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

// The pre-rendered depth in every sample, so that the scene hides live samples behind it.
@fragment
fn fs_coverage_backdrop(@builtin(position) position: vec4<f32>) -> CoverageBackdropOut {
    let depth = textureLoad(backdrop_window_depth, vec2<i32>(position.xy), 0).r;
    return CoverageBackdropOut(vec4<f32>(0.0), depth);
}

// Half floats hold the samples: keep live radiance finite in them.
fn coverage_colour(colour: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(min(colour.rgb, vec3<f32>(65504.0)), 1.0);
}

struct CoverageOut {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
    @builtin(sample_mask) samples: u32,
}

// The sphere covers the samples whose rays hit it; it is shaded at the first covered sample's
// hit where the centre ray misses it (elsewhere the resolve uses the centre frame's colour).
// Which of a pixel's samples the rays through them hit `sphere`, and where: the centre ray's hit,
// else the first covered sample's (its raster position in `raster`). `hidden`: the samples whose
// rays meet the sphere but a pre-rendered surface first, and `occluder` the neighbouring pixel
// (0..8, row-major over the 3x3 around it) that shows the nearest such surface.
struct SphereSamples {
    hit: vec4<f32>,
    raster: vec2<f32>,
    samples: u32,
    hidden: u32,
    occluder: u32,
}

// The nearest pre-rendered surface among the 3x3 pixels around `position`: its distance (radial
// for a perspective camera, planar for an orthographic one, as the depth table's) and which
// pixel (0..8, row-major).
fn nearest_neighbour_surface(position: vec2<f32>) -> vec2<f32> {
    let size = vec2<i32>(textureDimensions(backdrop_radial_depth));
    let pixel = vec2<i32>(position);
    var nearest = vec2<f32>(3.0e38, 4.0);
    for (var k = 0; k < 9; k++) {
        let q = clamp(pixel + vec2<i32>(k % 3 - 1, k / 3 - 1), vec2<i32>(0), size - 1);
        let d = textureLoad(backdrop_radial_depth, q, 0).r;
        if d < nearest.x {
            nearest = vec2<f32>(d, f32(k));
        }
    }
    return nearest;
}

// Whether a pre-rendered surface lies between the eye and live point `p` seen through raster
// position `at`, given the nearest surface the image shows around the pixel (`nearest`, from
// nearest_neighbour_surface). The depth test compares every sample with the depth at the
// pixel's centre, so where the edge of a nearer pre-rendered object crosses a pixel whose centre
// shows the live object, the samples behind that object counted as live (in `cargo xtask
// illusion`, the Cornell box's sphere resting behind a box: all of its error inside). Such an
// object is one the image shows among the pixel's neighbours, nearer than `p`: only then is the
// sample's ray traced through the tessellated scene, and only from just before that surface.
fn scene_hides_sample(at: vec2<f32>, p: vec3<f32>, nearest: f32) -> bool {
    let distance = select(p.z, length(p), frame.raster.w > 0.5);
    if frame.scene_occluders.z == 0u || !(nearest < distance) {
        return false;
    }
    let ray = ray_through_raster(at);
    let t = dot(p - ray.origin, ray.direction);
    return bvh_blocks(frame.scene_occluders, ray.origin, ray.direction, 0.99 * nearest, t * (1.0 - 1e-4));
}

fn sphere_samples(position: vec2<f32>, sphere: vec4<f32>) -> SphereSamples {
    // The standard 4x sample positions from the pixel's top-left corner
    // (pixel_filter::SAMPLE_POSITIONS, resolve.wgsl).
    var positions = array<vec2<f32>, 4>(
        vec2<f32>(0.375, 0.125), vec2<f32>(0.875, 0.375), vec2<f32>(0.125, 0.625), vec2<f32>(0.625, 0.875),
    );
    let corner = floor(position);
    var hit = sphere_hit_of(position, sphere);
    var raster = position;
    var samples = 0u;
    var hidden = 0u;
    let nearest = nearest_neighbour_surface(position);
    for (var i = 0u; i < 4u; i = i + 1u) {
        let at = corner + positions[i];
        let sample_hit = sphere_hit_of(at, sphere);
        if sample_hit.w < 0.0 {
            continue;
        }
        if scene_hides_sample(at, sample_hit.xyz, nearest.x) {
            hidden = hidden | (1u << i);
            continue;
        }
        samples = samples | (1u << i);
        if hit.w < 0.0 {
            hit = sample_hit;
            raster = at;
        }
    }
    return SphereSamples(hit, raster, samples, hidden, u32(nearest.y));
}

// The samples of a pixel whose centre is live carry, instead of a colour (the resolve takes the
// centre frame's), which of the pixel's samples a pre-rendered surface hides (red, a 4-bit mask)
// and the neighbouring pixel that shows it (green, 0..8), marked by a negative blue (live colours
// are never negative): the resolve gives those samples that pixel's colour, the surface in front,
// not the pixel's own backdrop, which is partly what the live object hides.
fn centre_live_samples(covered: SphereSamples) -> vec4<f32> {
    return vec4<f32>(f32(covered.hidden), f32(covered.occluder), -1.0, 1.0);
}

// Whether the resolve takes the colour of the cursor sphere's `covered` samples in the pixel at
// `position` from the centre frame: where the pixel centre shows the sphere (clearly in front of
// the pre-rendered surface), no need to shade it again.
fn centre_shows_sphere(position: vec2<f32>, covered: SphereSamples) -> bool {
    if covered.raster.x != position.x || covered.raster.y != position.y {
        return false;
    }
    let surface = textureLoad(backdrop_radial_depth, vec2<i32>(position), 0).r;
    let distance = select(covered.hit.z, length(covered.hit.xyz), frame.raster.w > 0.5);
    return distance < surface * (1.0 - 1e-5);
}

@fragment
fn fs_sphere_coverage(@builtin(position) position: vec4<f32>) -> CoverageOut {
    let covered = sphere_samples(position.xy, frame.sphere);
    let hit = covered.hit;
    if covered.samples == 0u {
        discard;
    }
    if centre_shows_sphere(position.xy, covered) {
        return CoverageOut(centre_live_samples(covered), hit.w, covered.samples);
    }
    let p = hit.xyz;
    let n = (p - frame.sphere.xyz) / frame.sphere.w;
    loss_map_row = 0;
    let colour = to_image_units(shade_cursor_sphere(p, n, ray_through_raster(covered.raster).direction));
    return CoverageOut(coverage_colour(colour), hit.w, covered.samples);
}

// fs_sphere_coverage for a moving frame that reads the cursor sphere's radiance map
// (cursor_radiance.wgsl fs_sphere_mapped: an entry point without shade_with).
@fragment
fn fs_sphere_coverage_mapped(@builtin(position) position: vec4<f32>) -> CoverageOut {
    let covered = sphere_samples(position.xy, frame.sphere);
    let hit = covered.hit;
    if covered.samples == 0u {
        discard;
    }
    if centre_shows_sphere(position.xy, covered) {
        return CoverageOut(centre_live_samples(covered), hit.w, covered.samples);
    }
    let n = (hit.xyz - frame.sphere.xyz) / frame.sphere.w;
    return CoverageOut(coverage_colour(to_image_units(cursor_radiance_lookup(n))), hit.w, covered.samples);
}

// The centre-sampled frame's live-object mask (compositor/antialias.rs binds it for meshes).
@group(2) @binding(0) var coverage_centre_mask: texture_2d<f32>;

// Meshes: the rasteriser decides which samples a triangle covers. Where the pixel centre shows
// a live object, the resolve takes the centre frame's colour: no need to shade it again.
@fragment
fn fs_mesh_coverage(in: MeshVertexOut) -> @location(0) vec4<f32> {
    if textureLoad(coverage_centre_mask, vec2<i32>(in.position.xy), 0).r > 0.5 {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    return coverage_colour(mesh_colour(in));
}

// Live spheres drawn as meshes (`--live`'s): their samples are the exact sphere's, ray-cast as the
// cursor sphere's over its bounding cube, since the rasteriser's cost for the tessellated
// sphere's thousands of triangles at four samples per pixel was most of the frame's. The
// sphere is the mesh's unit sphere moved by its transform (compositor/antialias.rs draws only
// instances whose transform is a translation and a uniform scale this way).
fn mesh_sphere() -> vec4<f32> {
    let m = mesh.camera_from_object;
    return vec4<f32>(m[3].xyz, length(m[0].xyz));
}

@vertex
fn vs_mesh_sphere_coverage(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    return sphere_cube_clip(index, mesh_sphere());
}

@fragment
fn fs_mesh_sphere_coverage(@builtin(position) position: vec4<f32>) -> CoverageOut {
    let sphere = mesh_sphere();
    let covered = sphere_samples(position.xy, sphere);
    if covered.samples == 0u {
        discard;
    }
    // Where the centre-sampled frame shows a live object the resolve takes its colour.
    if textureLoad(coverage_centre_mask, vec2<i32>(position.xy), 0).r > 0.5 {
        return CoverageOut(centre_live_samples(covered), covered.hit.w, covered.samples);
    }
    let p = covered.hit.xyz;
    let n = (p - sphere.xyz) / sphere.w;
    loss_map_row = mesh.loss_map.x;
    let colour = to_image_units(shade_seen(mesh.material, p, n, ray_through_raster(covered.raster).direction));
    return CoverageOut(coverage_colour(colour), covered.hit.w, covered.samples);
}

//! Shadow-ray hierarchies on the GPU (`scene_visibility.wgsl`): the tessellated scene, built
//! once in camera space (the scene is static), whose shadows fall on live objects; and the
//! live meshes, rebuilt when they move, whose shadows fall on the pre-rendered scene.

use super::lighting::MAX_SHADOW_SPHERES;
use crate::live::LiveObjects;
use crate::occluders::{
    FlatBvh, MAX_LIVE_OCCLUDER_TRIANGLES, MAX_SCENE_OCCLUDER_TRIANGLES, SceneMaterials, SceneOccluders,
    transformed_triangles,
};
use glam::{DMat4, DVec3, Vec3};

/// Bytes of one node and one triangle in the buffers.
const NODE_BYTES: u64 = 32;
const TRIANGLE_BYTES: u64 = 48;

/// The hierarchies' buffers and where each hierarchy lies in them.
#[derive(Debug)]
pub(super) struct GpuOccluders {
    pub(super) nodes: wgpu::Buffer,
    pub(super) triangles: wgpu::Buffer,
    /// The scene's hierarchy: first node, first triangle, node count (0: none).
    pub(super) scene: [u32; 4],
    /// The live meshes' hierarchy, after the scene's in both buffers.
    pub(super) live: [u32; 4],
    /// Camera-space bounding sphere of the live meshes' triangles (radius 0: none).
    pub(super) live_bound: [f32; 4],
    /// What the scene's shadows on live objects leave out, if anything (for stderr and --stats).
    pub(super) note: Option<String>,
    /// The scene's triangles in the hierarchy.
    pub(super) scene_triangles: usize,
    /// The live meshes (and their placements) the live hierarchy was built from.
    live_key: Vec<(usize, usize, DMat4)>,
    /// What the live meshes' shadows leave out, if anything, and whether stderr was told.
    pub(super) live_note: Option<String>,
    live_note_told: bool,
}

/// The budget of scene triangles on this device: the buffers of scene and live hierarchies
/// within the largest storage binding (nodes: at most two per triangle).
fn scene_budget(limits: &wgpu::Limits) -> usize {
    let per_binding = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
    let fit = (per_binding / (2 * NODE_BYTES)) as usize;
    fit.saturating_sub(MAX_LIVE_OCCLUDER_TRIANGLES).min(MAX_SCENE_OCCLUDER_TRIANGLES)
}

/// Builds the scene's hierarchy in camera space and makes room for the live meshes'.
pub(super) fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    occluders: Option<&SceneOccluders>,
    materials: Option<&SceneMaterials>,
    camera_from_world: DMat4,
) -> GpuOccluders {
    let budget = scene_budget(&device.limits());
    let (kept, left_out) = occluders.map(|o| o.kept_within_budget(budget)).unwrap_or_default();
    let (camera, tags): (Vec<[Vec3; 3]>, Vec<u32>) = match occluders {
        Some(o) => kept
            .iter()
            .map(|&k| {
                let t = o.triangles[k].map(|p| camera_from_world.transform_point3(p).as_vec3());
                (t, materials.map_or(0, |m| m.tag_of(k)))
            })
            .unzip(),
        None => Default::default(),
    };
    let bvh = FlatBvh::build_tagged(&camera, &tags);
    let note = match occluders {
        None => Some(
            "no scene geometry: live objects get every light's direct light, unshadowed by the scene"
                .to_string(),
        ),
        Some(o) if left_out > 0 => Some(format!(
            "the scene's {} triangles exceed the viewer's budget of {budget}: the {} largest shadow live objects, the rest do not",
            o.triangles.len(),
            bvh.triangles.len()
        )),
        Some(_) => None,
    };
    let live_nodes = 2 * MAX_LIVE_OCCLUDER_TRIANGLES as u64;
    let buffer = |label: &str, bytes: u64| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(NODE_BYTES),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    };
    let nodes = buffer("occluder nodes", (bvh.nodes.len() as u64 + live_nodes) * NODE_BYTES);
    let triangles = buffer(
        "occluder triangles",
        (bvh.triangles.len() as u64 + MAX_LIVE_OCCLUDER_TRIANGLES as u64) * TRIANGLE_BYTES,
    );
    queue.write_buffer(&nodes, 0, bytemuck::cast_slice(&bvh.nodes));
    queue.write_buffer(&triangles, 0, bytemuck::cast_slice(&bvh.triangles));
    let scene_triangles = bvh.triangles.len();
    let (node_count, triangle_count) = (bvh.nodes.len() as u32, scene_triangles as u32);
    GpuOccluders {
        nodes,
        triangles,
        scene: [0, 0, node_count, 0],
        live: [node_count, triangle_count, 0, 0],
        live_bound: [0.0; 4],
        note,
        scene_triangles,
        live_key: Vec::new(),
        live_note: None,
        live_note_told: false,
    }
}

impl GpuOccluders {
    /// Rebuilds the live meshes' hierarchy when they changed since the last frame. Meshes that
    /// are exact spheres cast their shadows as spheres (the first `MAX_SHADOW_SPHERES` of the
    /// cursor sphere and them; the rest as meshes). Meshes over the budget are left out, with a
    /// note on stderr the first time.
    pub(super) fn update_live(&mut self, queue: &wgpu::Queue, live: &LiveObjects, camera_from_world: DMat4) {
        let sphere =
            live.sphere.as_ref().filter(|s| s.radius > 0.0 && s.radius.is_finite() && s.centre.is_finite());
        let mut spheres_left = MAX_SHADOW_SPHERES - usize::from(sphere.is_some());
        let mut casting = Vec::new();
        for (k, m) in live.meshes.iter().enumerate() {
            if !m.world_from_object.is_finite() {
                continue;
            }
            if let Some((c, r)) = m.exact_sphere
                && c.is_finite()
                && r > 0.0
                && r.is_finite()
                && spheres_left > 0
            {
                spheres_left -= 1;
                continue;
            }
            casting.push(k);
        }
        let key: Vec<(usize, usize, DMat4)> = casting
            .iter()
            .map(|&k| {
                let m = &live.meshes[k];
                (std::sync::Arc::as_ptr(&m.mesh) as usize, m.mesh.indices.len(), m.world_from_object)
            })
            .collect();
        if key == self.live_key {
            return;
        }
        self.live_key = key;
        let mut tris = Vec::new();
        let mut left_out = 0;
        for &k in &casting {
            let m = &live.meshes[k];
            let moved = transformed_triangles(
                &m.mesh.positions,
                &m.mesh.indices,
                camera_from_world * m.world_from_object,
            );
            if tris.len() + moved.len() > MAX_LIVE_OCCLUDER_TRIANGLES {
                left_out += 1;
                continue;
            }
            tris.extend(moved);
        }
        let bvh = FlatBvh::build(&tris);
        let (node_base, triangle_base) = (self.live[0], self.live[1]);
        queue.write_buffer(&self.nodes, u64::from(node_base) * NODE_BYTES, bytemuck::cast_slice(&bvh.nodes));
        queue.write_buffer(
            &self.triangles,
            u64::from(triangle_base) * TRIANGLE_BYTES,
            bytemuck::cast_slice(&bvh.triangles),
        );
        self.live[2] = bvh.nodes.len() as u32;
        self.live_bound = bounding_sphere(&tris);
        self.live_note = (left_out > 0).then(|| {
            format!(
                "{left_out} live mesh(es) cast no shadow: the live meshes' triangles exceed the budget of {MAX_LIVE_OCCLUDER_TRIANGLES}"
            )
        });
        if let Some(note) = self.live_note.as_ref().filter(|_| !self.live_note_told) {
            eprintln!("note: {note}");
            self.live_note_told = true;
        }
    }
}

/// A sphere (centre, radius) around the triangles (the centre of their bounds); radius 0 for
/// none.
fn bounding_sphere(tris: &[[Vec3; 3]]) -> [f32; 4] {
    let points = tris.iter().flatten().filter(|p| p.is_finite());
    let (lo, hi) =
        points.clone().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), p| {
            (lo.min(p.as_dvec3()), hi.max(p.as_dvec3()))
        });
    if !lo.is_finite() {
        return [0.0; 4];
    }
    let centre = (lo + hi) * 0.5;
    let r = points.map(|p| (p.as_dvec3() - centre).length()).fold(0.0, f64::max);
    // Widened a little so that f32 rounding never leaves a corner outside.
    [centre.x as f32, centre.y as f32, centre.z as f32, (r * (1.0 + 1e-5) + 1e-6) as f32]
}

impl super::Compositor {
    /// The scene's shadows on live objects in words (for `--stats`): how many triangles cast
    /// them, or what is approximated.
    pub fn scene_shadows_summary(&self) -> String {
        match &self.occluders.note {
            Some(note) => note.clone(),
            None => format!("{} triangles of the tessellated scene", self.occluders.scene_triangles),
        }
    }

    /// What live meshes' shadows on the scene leave out, if anything (for `--stats`).
    pub fn live_shadows_note(&self) -> Option<&str> {
        self.occluders.live_note.as_deref()
    }
}

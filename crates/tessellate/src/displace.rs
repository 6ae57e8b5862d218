//! Displacement: RenderMan's standard displacement shaders run on a finely diced mesh.
//!
//! A shape with `Displacement "dented"` or `"bumpy"` is tessellated as usual (within its
//! [`Tolerance`]), placed, diced into micropolygons by [`DicingRule`] (`dice.rs`), every vertex
//! moved along the smooth surface normal by the shader's amount, and its normals recomputed
//! from the displaced triangles (RenderMan's `calculatenormal(P)`). The shaders, as in the
//! RenderMan Companion and RISpec's standard library:
//!
//! - `null`: no displacement;
//! - `dented` (`Km` = 1): `magnitude = sum_{i<6} |0.5 - noise(P_shader 2^i)| / 2^i`, then
//!   `P -= normalize(N) magnitude^3 Km`, with `P_shader` the point in the shader's space (the
//!   transformation current at the `Displacement` request) and `noise` Perlin's improved
//!   noise mapped to [0, 1] (`noise.rs`);
//! - `bumpy` (`Km` = 1, `amplitude` = 1, `texturename` = ""): `P += normalize(N) Km amplitude
//!   float texture(texturename, s, t)`; without a texture it does nothing (as 3Delight's
//!   `bumpy` does), an unreadable one reads 0 as RenderMan's `texture()` does.
//!
//! Amounts are in the units of the space the mesh is placed in, taken as RenderMan's "current"
//! (camera) space: they agree for the world and the ray tracer's render space whenever the
//! camera transformation is rigid.

use crate::dice::{DiceMesh, DiceReport, DicingRule, dice, dice_keys};
use crate::noise::renderman_noise;
use crate::placed::place;
use crate::{ShapeOptions, TessellateError, Tolerance, TriangleMesh};
use glam::{DMat4, DVec3, Vec2};
use rib_parser::scene::{Attributes, Shape};
use std::collections::HashMap;

/// The largest `magnitude^3` `dented` can reach: `magnitude <= sum_{i<6} 0.5 / 2^i`.
pub const DENTED_MAX_MAGNITUDE_CUBED: f64 = {
    let m = 0.5 * (1.0 + 0.5 + 0.25 + 0.125 + 0.0625 + 0.03125);
    m * m * m
};

/// A displacement shader the tessellator runs.
#[derive(Clone, Debug, PartialEq)]
pub enum DisplacementShader {
    /// `Displacement "null"`.
    Null,
    /// `Displacement "dented" "Km" km`; `world_from_shader` is its shader space.
    Dented { km: f64, world_from_shader: DMat4 },
    /// `Displacement "bumpy" "Km" km "amplitude" amplitude "texturename" name`.
    Bumpy { km: f64, amplitude: f64, texture: Option<String> },
}

impl DisplacementShader {
    /// The displacement of an attribute state: `Ok(None)` without one, `Err(name)` for a shader
    /// that is not one of RenderMan's standard ones (a custom RSL shader, which is not run).
    /// Non-finite parameters read as the defaults.
    pub fn from_attributes(attributes: &Attributes) -> Result<Option<DisplacementShader>, String> {
        let Some(call) = &attributes.displacement else { return Ok(None) };
        let float = |name: &str, default: f64| {
            call.params.float(name).map(f64::from).filter(|v| v.is_finite()).unwrap_or(default)
        };
        match call.name.as_str() {
            "null" => Ok(Some(DisplacementShader::Null)),
            "dented" => Ok(Some(DisplacementShader::Dented {
                km: float("Km", 1.0),
                world_from_shader: attributes.displacement_space,
            })),
            "bumpy" => Ok(Some(DisplacementShader::Bumpy {
                km: float("Km", 1.0),
                amplitude: float("amplitude", 1.0),
                texture: call.params.string("texturename").filter(|s| !s.is_empty()).map(str::to_string),
            })),
            other => Err(other.to_string()),
        }
    }

    /// True when the shader moves no point (`null`, `bumpy` without texture or amplitude).
    pub fn is_identity(&self) -> bool {
        match self {
            DisplacementShader::Null => true,
            DisplacementShader::Dented { km, .. } => *km == 0.0,
            DisplacementShader::Bumpy { km, amplitude, texture } => {
                texture.is_none() || km * amplitude == 0.0
            }
        }
    }
}

/// `Attribute "displacementbound" "sphere" [r]`: how far the shader says it displaces (in
/// `"coordinatesystem"`'s units, "object" by default; read as given).
pub fn displacement_bound(attributes: &Attributes) -> Option<f64> {
    attributes
        .user
        .iter()
        .rev()
        .filter(|call| call.namespace == "displacementbound")
        .find_map(|call| call.params.float("sphere"))
        .map(f64::from)
        .filter(|r| r.is_finite() && *r >= 0.0)
}

/// Everything a displacement needs besides the shape.
pub struct Displaced<'a> {
    pub shader: &'a DisplacementShader,
    /// Maps points of the space the mesh is placed in to world space (the shader space is
    /// given in world space by [`DisplacementShader::Dented`]).
    pub world_from_placed: DMat4,
    /// `float texture(name, s, t)` for `bumpy`: the first channel, `None` when the texture
    /// cannot be read (it then reads 0).
    pub texture: &'a dyn Fn(&str, Vec2) -> Option<f64>,
    pub dicing: DicingRule,
}

impl std::fmt::Debug for Displaced<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Displaced")
            .field("shader", self.shader)
            .field("world_from_placed", &self.world_from_placed)
            .field("dicing", &self.dicing)
            .finish_non_exhaustive()
    }
}

/// A displaced mesh and what making it did.
#[derive(Clone, Debug)]
pub struct DisplacedMesh {
    pub mesh: TriangleMesh,
    pub dicing: DiceReport,
    /// The largest distance any vertex moved.
    pub largest_displacement: f64,
    /// Texture names that could not be read (each once).
    pub unreadable_textures: Vec<String>,
}

/// Tessellates `shape` placed with `world_from_object` (as [`crate::tessellate_placed`]),
/// dices it by `displaced.dicing` within `tol.max_triangles` (coarser, and reported, where
/// the budget does not allow the rule) and displaces it by `displaced.shader`. The mesh's
/// orientation and winding follow `reverse_orientation` as for `tessellate_placed`; its normals
/// are those of the displaced triangles.
pub fn tessellate_displaced(
    shape: &Shape,
    world_from_object: &DMat4,
    reverse_orientation: bool,
    tol: &Tolerance,
    displaced: &Displaced<'_>,
) -> Result<DisplacedMesh, TessellateError> {
    tessellate_displaced_with(
        shape,
        world_from_object,
        reverse_orientation,
        tol,
        displaced,
        ShapeOptions::default(),
    )
}

pub(crate) fn tessellate_displaced_with(
    shape: &Shape,
    world_from_object: &DMat4,
    reverse_orientation: bool,
    tol: &Tolerance,
    displaced: &Displaced<'_>,
    options: ShapeOptions,
) -> Result<DisplacedMesh, TessellateError> {
    let kind = crate::shape_kind(shape);
    let base = place(shape, world_from_object, reverse_orientation, tol, options)?;
    let base_triangles = base.triangle_count();
    if displaced.shader.is_identity() || base.is_empty() {
        let dicing = DiceReport { base_triangles, triangles: base_triangles, coarsened_by: None };
        return Ok(DisplacedMesh {
            mesh: base,
            dicing,
            largest_displacement: 0.0,
            unreadable_textures: Vec::new(),
        });
    }
    let mut mesh = dice_mesh_of(&base);
    let size = base.bounds().map_or(0.0, |(lo, hi)| (hi - lo).as_dvec3().length());
    // The f32 output resolves no finer than this.
    let floor = size * (-20f64).exp2();
    let report = dice(&mut mesh, &displaced.dicing, floor, size, tol.max_triangles);
    let mut unreadable = Vec::new();
    let largest = displace(&mut mesh, displaced, &mut unreadable);
    let out = finish(mesh, base.degenerate_faces, base.st.is_some());
    out.check_finite(kind)?;
    Ok(DisplacedMesh {
        mesh: out,
        dicing: report,
        largest_displacement: largest,
        unreadable_textures: unreadable,
    })
}

/// The keys of a deforming shape displaced alike (see [`displace_keys`]).
#[derive(Clone, Debug)]
pub struct DisplacedKeys {
    pub meshes: Vec<TriangleMesh>,
    pub dicing: DiceReport,
    /// The largest distance any vertex of any key moved.
    pub largest_displacement: f64,
    pub unreadable_textures: Vec<String>,
}

/// Displaces the keys of a deforming shape: meshes with the same triangles, each key its own
/// vertices (as [`crate::tessellate_placed_keys`] makes them). They are diced alike (an edge is
/// halved where any key needs it), and each key's vertices are moved by the shader at their
/// own positions along their own normals, as RenderMan displaces every motion sample; each
/// key's normals are then those of its own displaced triangles, so every key keeps the same
/// triangles. `flip_normal`: the keys are wound by the normal before `Orientation` flips it,
/// and the displacement goes along the flipped one.
pub fn displace_keys(
    keys: &[TriangleMesh],
    flip_normal: bool,
    displaced: &Displaced<'_>,
    max_triangles: u64,
) -> Result<DisplacedKeys, TessellateError> {
    let kind = "deformation key";
    let Some(first) = keys.first() else {
        return Err(TessellateError::InvalidShape { kind, reason: "no keys".into() });
    };
    if keys.iter().any(|k| k.indices != first.indices || k.positions.len() != first.positions.len()) {
        return Err(TessellateError::InvalidShape { kind, reason: "the keys have other triangles".into() });
    }
    let base_triangles = first.triangle_count();
    if displaced.shader.is_identity() || first.is_empty() {
        let dicing = DiceReport { base_triangles, triangles: base_triangles, coarsened_by: None };
        return Ok(DisplacedKeys {
            meshes: keys.to_vec(),
            dicing,
            largest_displacement: 0.0,
            unreadable_textures: Vec::new(),
        });
    }
    let sign = if flip_normal { -1.0 } else { 1.0 };
    let mut diced: Vec<DiceMesh> = keys
        .iter()
        .map(|k| {
            let mut m = dice_mesh_of(k);
            m.normals.iter_mut().for_each(|n| *n *= sign);
            m
        })
        .collect();
    let size = keys
        .iter()
        .filter_map(|k| k.bounds())
        .map(|(lo, hi)| (hi - lo).as_dvec3().length())
        .fold(0.0, f64::max);
    let report = dice_keys(&mut diced, &displaced.dicing, size * (-20f64).exp2(), size, max_triangles);
    let mut unreadable = Vec::new();
    let mut largest = 0.0f64;
    let mut meshes = Vec::with_capacity(keys.len());
    for (mut m, key) in diced.into_iter().zip(keys) {
        largest = largest.max(displace(&mut m, displaced, &mut unreadable));
        m.normals.iter_mut().for_each(|n| *n *= sign);
        let out = finish(m, key.degenerate_faces, key.st.is_some());
        out.check_finite(kind)?;
        meshes.push(out);
    }
    Ok(DisplacedKeys {
        meshes,
        dicing: report,
        largest_displacement: largest,
        unreadable_textures: unreadable,
    })
}

/// The placed mesh in `f64`, with a displacement direction at every vertex: its smooth normal,
/// averaged over every vertex at the same position (so duplicated seam vertices, and the
/// corners of hard-edged meshes, move together and leave no crack), or the area-weighted
/// normal of the triangles around the position where the mesh has none.
fn dice_mesh_of(mesh: &TriangleMesh) -> DiceMesh {
    let positions: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    let mut by_position: HashMap<[u64; 3], DVec3> = HashMap::new();
    let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    match &mesh.normals {
        Some(normals) => {
            for (p, n) in positions.iter().zip(normals) {
                *by_position.entry(key(*p)).or_default() += n.as_dvec3();
            }
        }
        None => {
            for t in &mesh.indices {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                let cross = (b - a).cross(c - a);
                for p in [a, b, c] {
                    *by_position.entry(key(p)).or_default() += cross;
                }
            }
        }
    }
    // A vertex no triangle uses has no normal and is not moved.
    let normals = positions
        .iter()
        .map(|p| by_position.get(&key(*p)).copied().unwrap_or_default().normalize_or_zero())
        .collect();
    let st = match &mesh.st {
        Some(st) => st.clone(),
        None => vec![Vec2::ZERO; positions.len()],
    };
    DiceMesh { positions, normals, st, indices: mesh.indices.clone(), face_index: mesh.face_index.clone() }
}

/// Moves every vertex by the shader; returns the largest distance moved.
fn displace(mesh: &mut DiceMesh, displaced: &Displaced<'_>, unreadable: &mut Vec<String>) -> f64 {
    let mut largest = 0.0f64;
    let shader_from_placed = match displaced.shader {
        DisplacementShader::Dented { world_from_shader, .. } => {
            let inverse = world_from_shader.inverse();
            let m = inverse * displaced.world_from_placed;
            // A singular shader space evaluates noise in world space instead.
            if m.is_finite() { m } else { displaced.world_from_placed }
        }
        _ => DMat4::IDENTITY,
    };
    for i in 0..mesh.positions.len() {
        let (p, n) = (mesh.positions[i], mesh.normals[i]);
        let amount = match displaced.shader {
            DisplacementShader::Null => 0.0,
            DisplacementShader::Dented { km, .. } => {
                -dented_magnitude_cubed(shader_from_placed.project_point3(p)) * km
            }
            DisplacementShader::Bumpy { km, amplitude, texture } => match texture {
                None => 0.0,
                Some(name) => {
                    let value = (displaced.texture)(name, mesh.st[i]);
                    if value.is_none() && !unreadable.contains(name) {
                        unreadable.push(name.clone());
                    }
                    km * amplitude * value.filter(|v| v.is_finite()).unwrap_or(0.0)
                }
            },
        };
        if amount.is_finite() && n != DVec3::ZERO {
            mesh.positions[i] = p + n * amount;
            largest = largest.max(amount.abs());
        }
    }
    largest
}

/// `dented`'s `magnitude^3` at a point of its shader space.
pub fn dented_magnitude_cubed(p_shader: DVec3) -> f64 {
    let mut size = 1.0;
    let mut magnitude = 0.0;
    for _ in 0..6 {
        let q = p_shader * size;
        magnitude += (0.5 - renderman_noise(q.x, q.y, q.z)).abs() / size;
        size *= 2.0;
    }
    magnitude * magnitude * magnitude
}

/// The displaced mesh in `f32`, with the normals of its own triangles (area-weighted around
/// every position: RenderMan's `calculatenormal`).
fn finish(mesh: DiceMesh, degenerate_faces: u32, keep_st: bool) -> TriangleMesh {
    let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let mut sums: HashMap<[u64; 3], DVec3> = HashMap::new();
    for t in &mesh.indices {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let cross = (b - a).cross(c - a);
        for p in [a, b, c] {
            *sums.entry(key(p)).or_default() += cross;
        }
    }
    let mut normals = Vec::with_capacity(mesh.positions.len());
    for (p, fallback) in mesh.positions.iter().zip(&mesh.normals) {
        let n = sums.get(&key(*p)).copied().unwrap_or_default().normalize_or_zero();
        // A vertex no triangle of area touches keeps its smooth normal.
        normals.push(if n == DVec3::ZERO { *fallback } else { n }.as_vec3());
    }
    let normals = normals.iter().all(|n| *n != glam::Vec3::ZERO).then_some(normals);
    TriangleMesh {
        positions: mesh.positions.iter().map(|p| p.as_vec3()).collect(),
        normals,
        st: keep_st.then_some(mesh.st),
        indices: mesh.indices,
        face_index: mesh.face_index,
        degenerate_faces,
    }
}

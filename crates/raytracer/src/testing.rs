//! Building scenes in code, for tests and benchmarks (the RIB parser is the normal way in).

use depth_remap::{CameraSettings, Projection};
use glam::{DMat4, DVec3, Vec3};
use rib_parser::scene::{
    Attributes, AttributesId, FileLoc, Handle, Light, LightId, LightKind, ParamList, PolygonMesh,
    RenderSettings, Scene, ShaderCall, Shape, ShapeEntity,
};
use std::sync::Arc;

/// A location for entities made in code.
pub fn here() -> FileLoc {
    FileLoc::new("<test>", 1, 1)
}

/// A shader call with float parameters.
pub fn shader(name: &str, floats: &[(&str, f32)]) -> ShaderCall {
    use rib_parser::scene::{Param, ParamDecl, ParamType, ParamValues, StorageClass};
    let params = floats
        .iter()
        .map(|(n, v)| Param {
            name: n.to_string(),
            decl: ParamDecl { class: StorageClass::Uniform, ty: ParamType::Float, array_len: 1 },
            values: ParamValues::Floats(vec![*v]),
            loc: here(),
        })
        .collect();
    ShaderCall { name: name.into(), params: ParamList(params), loc: here() }
}

/// Accumulates a [`Scene`].
#[derive(Debug)]
pub struct SceneBuilder {
    pub scene: Scene,
}

impl SceneBuilder {
    /// A perspective camera (`fov` across the shorter axis) at `eye` looking at `target` with
    /// +y up (+z when looking along y), in a right-handed world (RenderMan camera space is left-handed: x right, y up,
    /// z forward).
    pub fn perspective(width: u32, height: u32, fov_degrees: f64, eye: DVec3, target: DVec3) -> SceneBuilder {
        let forward = (target - eye).normalize();
        let up_hint = if forward.cross(DVec3::Y).length() < 1e-9 { DVec3::Z } else { DVec3::Y };
        let right = forward.cross(up_hint).normalize();
        let up = right.cross(forward);
        // Rows of camera_from_world: right, up, forward (left-handed camera space).
        let rot = DMat4::from_cols(
            glam::DVec4::new(right.x, up.x, forward.x, 0.0),
            glam::DVec4::new(right.y, up.y, forward.y, 0.0),
            glam::DVec4::new(right.z, up.z, forward.z, 0.0),
            glam::DVec4::W,
        );
        let camera_from_world = rot * DMat4::from_translation(-eye);
        let camera = CameraSettings {
            x_resolution: width,
            y_resolution: height,
            projection: Projection::Perspective { fov_degrees },
            camera_from_world,
            ..CameraSettings::default()
        };
        SceneBuilder {
            scene: Scene {
                source: Arc::from("<test>"),
                frame: None,
                camera,
                render: RenderSettings::default(),
                displays: Vec::new(),
                depth_request: None,
                options: Vec::new(),
                lights: Vec::new(),
                attributes: Vec::new(),
                shapes: Vec::new(),
                objects: Vec::new(),
                instances: Vec::new(),
                coordinate_systems: Vec::new(),
                solids: Vec::new(),
            },
        }
    }

    pub fn attributes(&mut self, a: Attributes) -> AttributesId {
        self.scene.attributes.push(a);
        AttributesId(self.scene.attributes.len() as u32 - 1)
    }

    /// A matte attribute state with albedo `color` (Kd 1).
    pub fn matte(&mut self, color: Vec3) -> AttributesId {
        self.attributes(Attributes {
            color,
            surface: Some(shader("matte", &[("Kd", 1.0), ("Ka", 0.0)])),
            ..Attributes::default()
        })
    }

    pub fn shape(&mut self, shape: Shape, world_from_object: DMat4, attributes: AttributesId) {
        self.scene.shapes.push(ShapeEntity {
            shape: Arc::new(shape),
            world_from_object,
            motion: None,
            deformation: None,
            attributes,
            in_solid: false,
            loc: here(),
        });
    }

    /// A convex polygon (object space = world space).
    pub fn polygon(&mut self, points: &[Vec3], attributes: AttributesId) {
        let mesh = PolygonMesh {
            loops_per_face: vec![1],
            vertices_per_loop: vec![points.len() as u32],
            vertex_indices: (0..points.len() as u32).collect(),
            positions: points.to_vec(),
            primvars: ParamList::default(),
        };
        self.shape(Shape::Polygons(mesh), DMat4::IDENTITY, attributes);
    }

    pub fn light(&mut self, kind: LightKind, name: &str) -> LightId {
        let id = LightId(self.scene.lights.len() as u32);
        self.scene.lights.push(Light {
            handle: Handle::Int(id.0 as i32),
            shader: shader(name, &[]),
            kind,
            world_from_light: DMat4::IDENTITY,
        });
        // Every attribute state made from now on is lit by it (RenderMan's light list).
        id
    }

    /// Lights every attribute state by every non-area light (call after adding both).
    pub fn light_everything(&mut self) {
        let ids: Vec<LightId> = (0..self.scene.lights.len() as u32).map(LightId).collect();
        for a in &mut self.scene.attributes {
            a.illuminated_by = ids.clone();
        }
    }

    pub fn build(self) -> Scene {
        self.scene
    }
}

/// A furnace: the camera inside a sphere of radius 2 that emits 1 from its inner side and
/// reflects with albedo 0.5 (matte), so the radiance is `Le / (1 - albedo) = 2` everywhere.
pub fn sphere_furnace() -> Scene {
    let mut b = SceneBuilder::perspective(16, 12, 60.0, DVec3::new(0.1, 0.2, 0.3), DVec3::new(1.0, 0.0, 0.0));
    let light = b.light(LightKind::Area { intensity: 1.0, color: Vec3::ONE }, "arealight");
    let a = b.attributes(Attributes {
        color: Vec3::splat(0.5),
        surface: Some(shader("matte", &[("Kd", 1.0), ("Ka", 0.0)])),
        reverse_orientation: true,
        area_light: Some(light),
        ..Attributes::default()
    });
    b.shape(
        Shape::Sphere { radius: 2.0, z_min: -2.0, z_max: 2.0, theta_max_degrees: 360.0 },
        DMat4::from_translation(DVec3::new(0.0, 0.0, 0.5)),
        a,
    );
    b.build()
}

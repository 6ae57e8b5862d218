//! Shader and request parameters as the RIB gives them: declarations, values, lists.

use super::*;
use glam::Vec3;

// ---------------------------------------------------------------------------------------------
// Parameters

/// Storage class of a parameter or primitive variable (RISpec §2.3, plus `facevertex`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StorageClass {
    Constant,
    Uniform,
    Varying,
    Vertex,
    FaceVarying,
    FaceVertex,
}

/// Base type of a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ParamType {
    Float,
    Integer,
    String,
    Point,
    Vector,
    Normal,
    Color,
    HPoint,
    Matrix,
}

impl ParamType {
    /// Number of scalar components of one element (`color` assumes 3 colour samples).
    pub fn components(self) -> usize {
        match self {
            ParamType::Float | ParamType::Integer | ParamType::String => 1,
            ParamType::Point | ParamType::Vector | ParamType::Normal | ParamType::Color => 3,
            ParamType::HPoint => 4,
            ParamType::Matrix => 16,
        }
    }
}

/// A parameter's declared type: `"vertex point"`, `"uniform float[2]"`, ...
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ParamDecl {
    pub class: StorageClass,
    pub ty: ParamType,
    /// `n` of `type[n]`; 1 when not an array.
    pub array_len: u32,
}

impl ParamDecl {
    /// Scalars per element: `components * array_len`.
    pub fn scalars_per_element(&self) -> usize {
        self.ty.components() * self.array_len as usize
    }
}

/// The values of a parameter, as given.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValues {
    Floats(Vec<f32>),
    Ints(Vec<i32>),
    Strings(Vec<String>),
}

impl ParamValues {
    pub fn len(&self) -> usize {
        match self {
            ParamValues::Floats(v) => v.len(),
            ParamValues::Ints(v) => v.len(),
            ParamValues::Strings(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One `"name" [values]` pair with its resolved declaration.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// The bare name, without any inline type (`"uniform float Kd"` gives `Kd`).
    pub name: String,
    pub decl: ParamDecl,
    pub values: ParamValues,
    pub loc: FileLoc,
}

/// A parameter list, in the order given.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParamList(pub Vec<Param>);

impl ParamList {
    pub fn get(&self, name: &str) -> Option<&Param> {
        self.0.iter().find(|p| p.name == name)
    }

    /// The floats of parameter `name`, when it has float values.
    pub fn floats(&self, name: &str) -> Option<&[f32]> {
        match &self.get(name)?.values {
            ParamValues::Floats(v) => Some(v),
            _ => None,
        }
    }

    /// The first float of parameter `name`.
    pub fn float(&self, name: &str) -> Option<f32> {
        self.floats(name)?.first().copied()
    }

    pub fn ints(&self, name: &str) -> Option<&[i32]> {
        match &self.get(name)?.values {
            ParamValues::Ints(v) => Some(v),
            _ => None,
        }
    }

    pub fn strings(&self, name: &str) -> Option<&[String]> {
        match &self.get(name)?.values {
            ParamValues::Strings(v) => Some(v),
            _ => None,
        }
    }

    /// The first string of parameter `name`.
    pub fn string(&self, name: &str) -> Option<&str> {
        self.strings(name)?.first().map(String::as_str)
    }

    /// Three floats of parameter `name` as a vector (a `color`, `point`, `vector` or `normal`).
    pub fn vec3(&self, name: &str) -> Option<Vec3> {
        let f = self.floats(name)?;
        (f.len() >= 3).then(|| Vec3::new(f[0], f[1], f[2]))
    }
}

/// The displacement shaders of the RenderMan standard library that consumers evaluate (the
/// RenderMan Companion's `dented`, RISpec's `bumpy`, and `null`); any other name is a custom
/// shader written in the RenderMan Shading Language.
pub const STANDARD_DISPLACEMENT_SHADERS: [&str; 3] = ["null", "dented", "bumpy"];

/// A shader-like call as given: `Surface "plastic" "Ks" [0.5]`, `LightSource ...`,
/// `SurfaceIntegrator "photonmap" ...`, `PixelFilter`-style calls are typed elsewhere.
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderCall {
    pub name: String,
    pub params: ParamList,
    pub loc: FileLoc,
}

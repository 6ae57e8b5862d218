//! Reading the primitive variables tessellation carries through: `N` and `st` (or `s`, `t`).

use glam::{Vec2, Vec3};
use rib_parser::scene::{ParamType, ParamValues, PrimVars, StorageClass};

/// One primitive variable's values with its storage class.
#[derive(Clone, Debug)]
pub(crate) struct Var<T> {
    pub class: StorageClass,
    pub values: Vec<T>,
}

impl<T: Copy> Var<T> {
    /// The value for a face corner, given how many elements each class has for this shape.
    /// `None` when the data is too short (the parser checks sizes; this never panics).
    pub fn at(&self, face: usize, vertex: usize, corner: usize) -> Option<T> {
        let i = match self.class {
            StorageClass::Constant => 0,
            StorageClass::Uniform => face,
            StorageClass::Varying | StorageClass::Vertex => vertex,
            StorageClass::FaceVarying | StorageClass::FaceVertex => corner,
        };
        self.values.get(i).copied()
    }

    /// True when the values differ per face or per face corner, so vertices must be split.
    pub fn splits_vertices(&self) -> bool {
        matches!(self.class, StorageClass::Uniform | StorageClass::FaceVarying | StorageClass::FaceVertex)
    }

    /// True when there are enough values for `faces`, `vertices` and `corners` elements.
    pub fn fits(&self, faces: usize, vertices: usize, corners: usize) -> bool {
        let need = match self.class {
            StorageClass::Constant => 1,
            StorageClass::Uniform => faces,
            StorageClass::Varying | StorageClass::Vertex => vertices,
            StorageClass::FaceVarying | StorageClass::FaceVertex => corners,
        };
        self.values.len() >= need
    }
}

fn floats<'a>(pv: &'a PrimVars, name: &str) -> Option<(StorageClass, &'a [f32], usize)> {
    let p = pv.get(name)?;
    match &p.values {
        ParamValues::Floats(v) => Some((p.decl.class, v, p.decl.scalars_per_element().max(1))),
        _ => None,
    }
}

/// A normal (or point/vector) primitive variable with three floats per element.
pub(crate) fn vec3_var(pv: &PrimVars, name: &str) -> Option<Var<Vec3>> {
    let p = pv.get(name)?;
    if !matches!(p.decl.ty, ParamType::Normal | ParamType::Vector | ParamType::Point | ParamType::Float)
        || (p.decl.ty == ParamType::Float && p.decl.array_len != 3)
    {
        return None;
    }
    let (class, v, _) = floats(pv, name)?;
    Some(Var { class, values: v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect() })
}

/// Texture coordinates: `"float[2] st"`, or `"s"` and `"t"` of the same class.
pub(crate) fn st_var(pv: &PrimVars) -> Option<Var<Vec2>> {
    if let Some((class, v, per)) = floats(pv, "st")
        && per == 2
    {
        return Some(Var { class, values: v.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect() });
    }
    let (sc, s, sper) = floats(pv, "s")?;
    let (tc, t, tper) = floats(pv, "t")?;
    if sc != tc || sper != 1 || tper != 1 {
        return None;
    }
    Some(Var { class: sc, values: s.iter().zip(t).map(|(&s, &t)| Vec2::new(s, t)).collect() })
}

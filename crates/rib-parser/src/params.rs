//! Parameter declarations and value counts.
//!
//! A parameter's type comes from, in order: an inline declaration in its name
//! (`"uniform float Kd"`, `"vertex point P"`, `"float[2] st"`), a `Declare` request, or the
//! standard predeclared names of the RenderMan Interface (`P`, `N`, `Cs`, `st`, `Kd`,
//! `intensity`, `from`, ...). Shader, option and attribute parameters nobody declared take
//! their type from their values (a renderer would read it from the compiled shader).
//!
//! How many values a parameter must have depends on its storage class and the primitive
//! ([`ClassCounts`]), e.g. a `PointsPolygons` with 6 faces over 8 vertices takes 1 `constant`,
//! 6 `uniform`, 8 `varying`/`vertex` and one `facevarying` value per face corner.

use crate::scene::{ParamDecl, ParamType, StorageClass};
use std::collections::HashMap;

/// Why a declaration string cannot be parsed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DeclError {
    #[error("empty declaration")]
    Empty,
    #[error(
        "unknown type '{0}' (expected float, integer, string, point, vector, normal, color, hpoint or matrix)"
    )]
    UnknownType(String),
    #[error("bad array size in '{0}'")]
    BadArraySize(String),
    #[error("unexpected '{0}' in a declaration")]
    Trailing(String),
    #[error("a declaration without a parameter name")]
    MissingName,
}

fn parse_class(word: &str) -> Option<StorageClass> {
    Some(match word {
        "constant" => StorageClass::Constant,
        "uniform" => StorageClass::Uniform,
        "varying" => StorageClass::Varying,
        "vertex" => StorageClass::Vertex,
        "facevarying" => StorageClass::FaceVarying,
        "facevertex" => StorageClass::FaceVertex,
        _ => return None,
    })
}

fn parse_type(word: &str) -> Option<ParamType> {
    Some(match word {
        "float" | "double" => ParamType::Float,
        "integer" | "int" | "bool" => ParamType::Integer,
        "string" | "shader" | "reference" => ParamType::String,
        "point" => ParamType::Point,
        "vector" => ParamType::Vector,
        "normal" => ParamType::Normal,
        "color" => ParamType::Color,
        "hpoint" => ParamType::HPoint,
        "matrix" => ParamType::Matrix,
        _ => return None,
    })
}

/// Maximum `n` of a `type[n]` declaration.
const MAX_DECL_ARRAY: u32 = 1 << 20;

/// Reads `[class] type [ '[' n ']' ]` from the front of `text`. Returns `Ok(None)` when the
/// text does not start with a class or type word (then it is a plain name, perhaps with
/// blanks), else the declaration and the rest of the text.
fn parse_decl_prefix(text: &str) -> Result<Option<(ParamDecl, &str)>, DeclError> {
    let rest = text.trim_start();
    let word_end = |s: &str| s.find(|c: char| c.is_whitespace() || c == '[').unwrap_or(s.len());
    let first = &rest[..word_end(rest)];
    let (class, rest) = match parse_class(first) {
        Some(c) => (Some(c), rest[first.len()..].trim_start()),
        None => (None, rest),
    };
    let type_word = &rest[..word_end(rest)];
    let Some(ty) = parse_type(type_word) else {
        return match class {
            Some(_) if type_word.is_empty() => Err(DeclError::Empty),
            Some(_) => Err(DeclError::UnknownType(type_word.into())),
            None => Ok(None),
        };
    };
    let mut rest = rest[type_word.len()..].trim_start();
    let mut array_len = 1;
    if let Some(inner) = rest.strip_prefix('[') {
        let close = inner.find(']').ok_or_else(|| DeclError::BadArraySize(text.trim().into()))?;
        let size = inner[..close].trim();
        // Writers emit `float[2]`, `float [ 2 ]` and even `integer [ 2.0 ]`.
        let n = size
            .parse::<u32>()
            .ok()
            .or_else(|| {
                size.parse::<f64>()
                    .ok()
                    .filter(|f| f.fract() == 0.0 && *f >= 0.0 && *f <= f64::from(u32::MAX))
                    .map(|f| f as u32)
            })
            .ok_or_else(|| DeclError::BadArraySize(text.trim().into()))?;
        if n == 0 || n > MAX_DECL_ARRAY {
            return Err(DeclError::BadArraySize(text.trim().into()));
        }
        array_len = n;
        rest = inner[close + 1..].trim_start();
    }
    Ok(Some((ParamDecl { class: class.unwrap_or(StorageClass::Uniform), ty, array_len }, rest)))
}

/// Parses `"[class] type[n]"` (a `Declare` type). The class defaults to `uniform`.
pub fn parse_decl(text: &str) -> Result<ParamDecl, DeclError> {
    match parse_decl_prefix(text)? {
        Some((decl, "")) => Ok(decl),
        Some((_, extra)) => Err(DeclError::Trailing(extra.split_whitespace().next().unwrap_or(extra).into())),
        None => match text.split_whitespace().next() {
            Some(word) => Err(DeclError::UnknownType(word.into())),
            None => Err(DeclError::Empty),
        },
    }
}

/// Splits an inline declaration `"[class] type[n] name"` into its declaration and name.
/// Returns `Ok(None)` when the text does not start with a class or type (a plain name, which
/// may contain blanks).
pub fn parse_inline(text: &str) -> Result<Option<(ParamDecl, &str)>, DeclError> {
    match parse_decl_prefix(text)? {
        Some((_, "")) => {
            // A lone type word is a parameter named like a type (e.g. `"color"`), not a
            // declaration without a name.
            if text.split_whitespace().count() == 1 { Ok(None) } else { Err(DeclError::MissingName) }
        }
        Some((decl, name)) => Ok(Some((decl, name.trim_end()))),
        None => Ok(None),
    }
}

/// The RenderMan Interface's standard declarations (RISpec 3.2 tables 4.x and 5.x, the standard
/// shaders' parameters, and common renderer options), plus our `haptic` and `lrt` names.
const PREDECLARED: &[(&str, &str)] = &[
    // Geometry (RISpec §5).
    ("P", "vertex point"),
    ("Pz", "vertex float"),
    ("Pw", "vertex hpoint"),
    ("N", "varying normal"),
    ("Np", "uniform normal"),
    ("Cs", "varying color"),
    ("Os", "varying color"),
    ("s", "varying float"),
    ("t", "varying float"),
    ("st", "varying float[2]"),
    ("width", "varying float"),
    ("constantwidth", "constant float"),
    ("Ng", "varying normal"),
    // Standard light shaders.
    ("intensity", "float"),
    ("lightcolor", "color"),
    ("from", "point"),
    ("to", "point"),
    ("coneangle", "float"),
    ("conedeltaangle", "float"),
    ("beamdistribution", "float"),
    // Standard surface shaders.
    ("Ka", "float"),
    ("Kd", "float"),
    ("Ks", "float"),
    ("Kr", "float"),
    ("Kt", "float"),
    ("roughness", "float"),
    ("specularcolor", "color"),
    ("texturename", "string"),
    ("eta", "float"),
    ("maxdistance", "float"),
    ("mindistance", "float"),
    ("distance", "float"),
    ("background", "color"),
    ("amplitude", "float"),
    ("sphere", "float"),
    ("disk", "float"),
    ("name", "string"),
    ("shadowname", "string"),
    ("shadowmap", "string"),
    ("fov", "float"),
    // Options and attributes.
    ("shader", "string"),
    ("texture", "string"),
    ("archive", "string"),
    ("procedural", "string"),
    ("resource", "string"),
    ("display", "string"),
    ("bucketsize", "integer[2]"),
    ("gridsize", "integer"),
    ("texturememory", "integer"),
    ("eyesplits", "integer"),
    ("endofframe", "integer"),
    ("filename", "string"),
    ("xmlfilename", "string"),
    ("jitter", "integer"),
    ("depthfilter", "string"),
    ("binary", "integer"),
    ("compression", "string"),
    ("quantize", "integer[4]"),
    ("dither", "float"),
    ("origin", "integer[2]"),
    ("shadows", "string"),
    ("sphere", "float"),
    ("depthfile", "string"),
    ("stiffness", "float"),
    ("friction", "float"),
    ("staticfriction", "float"),
    ("dynamicfriction", "float"),
    ("varsubst", "string"),
];

/// The declarations in effect: the predeclared names and every `Declare` so far.
#[derive(Clone, Debug)]
pub struct DeclTable {
    decls: HashMap<String, ParamDecl>,
}

impl Default for DeclTable {
    fn default() -> Self {
        let mut decls = HashMap::with_capacity(PREDECLARED.len() * 2);
        for (name, decl) in PREDECLARED {
            // The table is a constant of this file; a bad entry is caught by the unit test.
            if let Ok(d) = parse_decl(decl) {
                decls.insert((*name).to_string(), d);
            }
        }
        DeclTable { decls }
    }
}

impl DeclTable {
    pub fn declare(&mut self, name: &str, decl: ParamDecl) {
        self.decls.insert(name.to_string(), decl);
    }

    /// The declaration of `name`, also trying the namespaced forms `namespace:name` and
    /// `Context:namespace:name` (`Declare "Option:limits:foo"` style).
    pub fn lookup(&self, name: &str, context: Option<(&str, &str)>) -> Option<ParamDecl> {
        if let Some(d) = self.decls.get(name) {
            return Some(*d);
        }
        let (ctx, ns) = context?;
        self.decls
            .get(&format!("{ns}:{name}"))
            .or_else(|| self.decls.get(&format!("{ctx}:{ns}:{name}")))
            .copied()
    }
}

/// How many elements a parameter of each class must have on one primitive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClassCounts {
    pub constant: usize,
    pub uniform: usize,
    pub varying: usize,
    pub vertex: usize,
    pub face_varying: usize,
    pub face_vertex: usize,
}

impl ClassCounts {
    /// Counts for a call that is not a primitive (shader, option, attribute): one element.
    pub const SINGLE: ClassCounts =
        ClassCounts { constant: 1, uniform: 1, varying: 1, vertex: 1, face_varying: 1, face_vertex: 1 };

    pub fn of(&self, class: StorageClass) -> usize {
        match class {
            StorageClass::Constant => self.constant,
            StorageClass::Uniform => self.uniform,
            StorageClass::Varying => self.varying,
            StorageClass::Vertex => self.vertex,
            StorageClass::FaceVarying => self.face_varying,
            StorageClass::FaceVertex => self.face_vertex,
        }
    }
}

/// The name of a storage class as written in RIB.
pub fn class_name(class: StorageClass) -> &'static str {
    match class {
        StorageClass::Constant => "constant",
        StorageClass::Uniform => "uniform",
        StorageClass::Varying => "varying",
        StorageClass::Vertex => "vertex",
        StorageClass::FaceVarying => "facevarying",
        StorageClass::FaceVertex => "facevertex",
    }
}

/// The name of a type as written in RIB.
pub fn type_name(ty: ParamType) -> &'static str {
    match ty {
        ParamType::Float => "float",
        ParamType::Integer => "integer",
        ParamType::String => "string",
        ParamType::Point => "point",
        ParamType::Vector => "vector",
        ParamType::Normal => "normal",
        ParamType::Color => "color",
        ParamType::HPoint => "hpoint",
        ParamType::Matrix => "matrix",
    }
}

/// A declaration written back as RIB: `"vertex point"`, `"uniform float[2]"`.
pub fn decl_string(decl: &ParamDecl) -> String {
    if decl.array_len == 1 {
        format!("{} {}", class_name(decl.class), type_name(decl.ty))
    } else {
        format!("{} {}[{}]", class_name(decl.class), type_name(decl.ty), decl.array_len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_predeclared_entry_parses() {
        for (name, decl) in PREDECLARED {
            assert!(parse_decl(decl).is_ok(), "{name}: {decl}");
        }
        let t = DeclTable::default();
        assert_eq!(
            t.lookup("P", None),
            Some(ParamDecl { class: StorageClass::Vertex, ty: ParamType::Point, array_len: 1 })
        );
        assert_eq!(t.lookup("st", None).unwrap().array_len, 2);
    }

    #[test]
    fn declarations_with_class_type_and_array() {
        assert_eq!(
            parse_decl("facevarying float[2]").unwrap(),
            ParamDecl { class: StorageClass::FaceVarying, ty: ParamType::Float, array_len: 2 }
        );
        assert_eq!(parse_decl("  int ").unwrap().class, StorageClass::Uniform);
        assert_eq!(parse_decl("integer[3]").unwrap().array_len, 3);
        assert!(matches!(parse_decl("uniform banana"), Err(DeclError::UnknownType(_))));
        assert!(matches!(parse_decl("float[0]"), Err(DeclError::BadArraySize(_))));
        assert!(matches!(parse_decl(""), Err(DeclError::Empty)));
        assert!(matches!(parse_decl("uniform"), Err(DeclError::Empty)));
    }

    #[test]
    fn inline_declarations_split_type_and_name() {
        let (d, name) = parse_inline("uniform float Kd").unwrap().unwrap();
        assert_eq!((d.class, d.ty, name), (StorageClass::Uniform, ParamType::Float, "Kd"));
        let (d, name) = parse_inline("int[2] bucketsize").unwrap().unwrap();
        assert_eq!((d.ty, d.array_len, name), (ParamType::Integer, 2, "bucketsize"));
        assert_eq!(parse_inline("Kd").unwrap(), None);
        assert_eq!(parse_inline("color").unwrap(), None);
        // Names with blanks (RiCPP writes them) are names, not declarations.
        assert_eq!(parse_inline("A declaration with blanks").unwrap(), None);
        let (d, name) = parse_inline("   point   Another declaration with blanks    ").unwrap().unwrap();
        assert_eq!((d.ty, name), (ParamType::Point, "Another declaration with blanks"));
        // cgkit writes the array size with blanks and as a float.
        let (d, name) = parse_inline("integer [ 2.0 ] origin").unwrap().unwrap();
        assert_eq!((d.ty, d.array_len, name), (ParamType::Integer, 2, "origin"));
        assert!(matches!(parse_inline("uniform sausage Kd"), Err(DeclError::UnknownType(_))));
        assert!(matches!(parse_inline("float[1.5] x"), Err(DeclError::BadArraySize(_))));
    }

    #[test]
    fn namespaced_lookup() {
        let mut t = DeclTable::default();
        t.declare("Option:MyOption:MyVariable", parse_decl("constant string").unwrap());
        assert!(t.lookup("MyVariable", Some(("Option", "MyOption"))).is_some());
        assert!(t.lookup("MyVariable", Some(("Attribute", "MyOption"))).is_none());
    }
}

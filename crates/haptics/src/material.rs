//! Haptic materials: stiffness and friction per object, with defaults relative to the device.

use crate::device::DeviceSpecs;
use crate::geometry::MaterialId;

/// How a surface feels. Stiffness is in newtons per metre of **device** travel (so the feel does
/// not change with the workspace gain); friction coefficients are dimensionless (the tangent of
/// the friction cone's half angle, as in CHAI3D).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub stiffness: f64,
    pub static_friction: f64,
    pub dynamic_friction: f64,
}

/// A material as a scene gives it: any field may be missing. Mirrors
/// `rib_parser::scene::HapticMaterial` without depending on it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaterialSpec {
    pub stiffness: Option<f64>,
    pub friction: Option<f64>,
    pub static_friction: Option<f64>,
    pub dynamic_friction: Option<f64>,
}

/// Defaults for what a scene leaves out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialDefaults {
    /// Stiffness for surfaces that give none (N/m of device travel).
    pub stiffness: f64,
    pub static_friction: f64,
    pub dynamic_friction: f64,
}

/// Fraction of the device's maximum stiffness used when a surface gives none. CHAI3D's examples
/// use about half the device's stable maximum, which leaves margin for the device's own
/// dynamics and for stiffer spots where contacts stack up (edges, corners).
pub const DEFAULT_STIFFNESS_FRACTION: f64 = 0.5;

impl MaterialDefaults {
    /// Half the device's maximum stiffness, frictionless (the paper's rigid triangles).
    pub fn for_device(specs: &DeviceSpecs) -> MaterialDefaults {
        MaterialDefaults {
            stiffness: DEFAULT_STIFFNESS_FRACTION * specs.max_stiffness,
            static_friction: 0.0,
            dynamic_friction: 0.0,
        }
    }
}

/// Problems with a material that were corrected (reported, not fatal).
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialWarning {
    /// Stiffness above what the device renders stably: clamped.
    StiffnessClamped { material: MaterialId, given: f64, used: f64 },
    /// Negative or non-finite values: replaced by the default.
    Invalid { material: MaterialId, field: &'static str, given: f64 },
    /// Dynamic friction above static friction: static raised to match (a slipping contact
    /// could otherwise never stick again).
    StaticBelowDynamic { material: MaterialId, static_friction: f64, dynamic_friction: f64 },
}

impl std::fmt::Display for MaterialWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MaterialWarning::StiffnessClamped { material, given, used } => write!(
                f,
                "haptic material {}: stiffness {given} N/m exceeds the device's maximum; using {used} N/m",
                material.0
            ),
            MaterialWarning::Invalid { material, field, given } => {
                write!(f, "haptic material {}: {field} {given} is invalid; using the default", material.0)
            }
            MaterialWarning::StaticBelowDynamic { material, static_friction, dynamic_friction } => write!(
                f,
                "haptic material {}: static friction {static_friction} is below dynamic friction {dynamic_friction}; raising it to match",
                material.0
            ),
        }
    }
}

/// Materials indexed by [`MaterialId`], resolved against defaults and the device's limits.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialTable {
    materials: Vec<Material>,
    fallback: Material,
}

impl MaterialTable {
    /// Resolves `specs` (index = material id) against `defaults`, clamping stiffness to
    /// `max_stiffness`. Returns the table and what had to be corrected.
    pub fn resolve(
        specs: &[MaterialSpec],
        defaults: MaterialDefaults,
        max_stiffness: f64,
    ) -> (MaterialTable, Vec<MaterialWarning>) {
        let mut warnings = Vec::new();
        let valid = |v: f64| v.is_finite() && v >= 0.0;
        let fallback = Material {
            stiffness: defaults.stiffness.min(max_stiffness).max(0.0),
            static_friction: defaults.static_friction.max(defaults.dynamic_friction),
            dynamic_friction: defaults.dynamic_friction,
        };
        let mut materials = Vec::with_capacity(specs.len());
        for (i, spec) in specs.iter().enumerate() {
            let id = MaterialId(i as u32);
            let mut pick = |field: &'static str, value: Option<f64>, default: f64| match value {
                Some(v) if valid(v) => v,
                Some(v) => {
                    warnings.push(MaterialWarning::Invalid { material: id, field, given: v });
                    default
                }
                None => default,
            };
            let mut stiffness = pick("stiffness", spec.stiffness, fallback.stiffness);
            let friction = spec.friction;
            let static_friction =
                pick("static friction", spec.static_friction.or(friction), fallback.static_friction);
            let dynamic_friction =
                pick("dynamic friction", spec.dynamic_friction.or(friction), fallback.dynamic_friction);
            if stiffness > max_stiffness {
                warnings.push(MaterialWarning::StiffnessClamped {
                    material: id,
                    given: stiffness,
                    used: max_stiffness,
                });
                stiffness = max_stiffness;
            }
            let static_friction = if static_friction < dynamic_friction {
                warnings.push(MaterialWarning::StaticBelowDynamic {
                    material: id,
                    static_friction,
                    dynamic_friction,
                });
                dynamic_friction
            } else {
                static_friction
            };
            materials.push(Material { stiffness, static_friction, dynamic_friction });
        }
        (MaterialTable { materials, fallback }, warnings)
    }

    /// One material for everything.
    pub fn uniform(material: Material) -> MaterialTable {
        MaterialTable { materials: vec![material], fallback: material }
    }

    /// The material of `id`; ids beyond the table get the defaults.
    pub fn get(&self, id: MaterialId) -> &Material {
        self.materials.get(id.0 as usize).unwrap_or(&self.fallback)
    }

    pub fn len(&self) -> usize {
        self.materials.len()
    }

    pub fn is_empty(&self) -> bool {
        self.materials.is_empty()
    }

    /// Scales every stiffness by `factor` (clamped to `max_stiffness`), e.g. for a run-time
    /// stiffness control.
    pub fn with_stiffness_scaled(&self, factor: f64, max_stiffness: f64) -> MaterialTable {
        let scale = |m: &Material| Material { stiffness: (m.stiffness * factor).min(max_stiffness), ..*m };
        MaterialTable {
            materials: self.materials.iter().map(scale).collect(),
            fallback: scale(&self.fallback),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn defaults() -> MaterialDefaults {
        MaterialDefaults { stiffness: 500.0, static_friction: 0.0, dynamic_friction: 0.0 }
    }

    #[test]
    fn friction_shorthand_and_overrides() {
        let specs = [
            MaterialSpec { friction: Some(0.4), ..MaterialSpec::default() },
            MaterialSpec { friction: Some(0.4), dynamic_friction: Some(0.2), ..MaterialSpec::default() },
            MaterialSpec::default(),
        ];
        let (table, warnings) = MaterialTable::resolve(&specs, defaults(), 1000.0);
        assert!(warnings.is_empty());
        assert_eq!(table.get(MaterialId(0)).static_friction, 0.4);
        assert_eq!(table.get(MaterialId(0)).dynamic_friction, 0.4);
        assert_eq!(table.get(MaterialId(1)).static_friction, 0.4);
        assert_eq!(table.get(MaterialId(1)).dynamic_friction, 0.2);
        assert_eq!(table.get(MaterialId(2)).stiffness, 500.0);
        assert_eq!(table.get(MaterialId(99)).stiffness, 500.0);
    }

    #[test]
    fn stiffness_is_clamped_and_invalid_values_replaced() {
        let specs = [
            MaterialSpec { stiffness: Some(5000.0), ..MaterialSpec::default() },
            MaterialSpec { stiffness: Some(f64::NAN), friction: Some(-1.0), ..MaterialSpec::default() },
            MaterialSpec {
                static_friction: Some(0.1),
                dynamic_friction: Some(0.3),
                ..MaterialSpec::default()
            },
        ];
        let (table, warnings) = MaterialTable::resolve(&specs, defaults(), 1000.0);
        assert_eq!(table.get(MaterialId(0)).stiffness, 1000.0);
        assert_eq!(table.get(MaterialId(1)).stiffness, 500.0);
        assert_eq!(table.get(MaterialId(1)).static_friction, 0.0);
        assert_eq!(table.get(MaterialId(2)).static_friction, 0.3);
        assert_eq!(warnings.len(), 5, "{warnings:?}");
    }
}

//! Haptics from a RIB scene: materials from `Attribute "haptic"` (one haptic material per
//! attribute state, so [`MaterialId`] `n` is `rib_parser::scene::AttributesId(n)`).

use crate::geometry::MaterialId;
use crate::material::MaterialSpec;
use rib_parser::scene::{AttributesId, HapticMaterial, Scene};

/// The material a RIB attribute state asks for (`None` fields take the device's defaults).
pub fn material_spec(haptic: &HapticMaterial) -> MaterialSpec {
    MaterialSpec {
        stiffness: haptic.stiffness.map(f64::from),
        friction: haptic.friction.map(f64::from),
        static_friction: haptic.static_friction.map(f64::from),
        dynamic_friction: haptic.dynamic_friction.map(f64::from),
    }
}

/// One [`MaterialSpec`] per attribute state of `scene`, indexed like `scene.attributes`.
pub fn material_specs(scene: &Scene) -> Vec<MaterialSpec> {
    scene.attributes.iter().map(|a| material_spec(&a.haptic)).collect()
}

/// The haptic material id of shapes made under attribute state `id`.
pub fn material_id(id: AttributesId) -> MaterialId {
    MaterialId(id.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rib_haptic_attributes_become_material_specs() {
        let h = HapticMaterial {
            stiffness: Some(800.0),
            friction: Some(0.25),
            static_friction: None,
            dynamic_friction: Some(0.125),
        };
        let spec = material_spec(&h);
        assert_eq!(spec.stiffness, Some(800.0));
        assert_eq!(spec.friction, Some(0.25));
        assert_eq!(spec.dynamic_friction, Some(0.125));
        assert_eq!(spec.static_friction, None);
        assert_eq!(material_id(AttributesId(7)), MaterialId(7));
    }
}

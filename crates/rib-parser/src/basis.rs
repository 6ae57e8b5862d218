//! The standard patch and curve bases of `Basis` (RISpec 3.2 §4.2.4).

use crate::scene::Basis;

/// The standard bases of RISpec 3.2 §4.2.4 (row-vector layout, as `Basis` takes them).
pub fn named_basis(name: &str) -> Option<Basis> {
    const S6: f32 = 1.0 / 6.0;
    let (matrix, step) = match name {
        "bezier" => ([-1.0, 3.0, -3.0, 1.0, 3.0, -6.0, 3.0, 0.0, -3.0, 3.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], 3),
        "b-spline" => (
            [
                -S6,
                3.0 * S6,
                -3.0 * S6,
                S6,
                3.0 * S6,
                -6.0 * S6,
                3.0 * S6,
                0.0,
                -3.0 * S6,
                0.0,
                3.0 * S6,
                0.0,
                S6,
                4.0 * S6,
                S6,
                0.0,
            ],
            1,
        ),
        "catmull-rom" => {
            ([-0.5, 1.5, -1.5, 0.5, 1.0, -2.5, 2.0, -0.5, -0.5, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0], 1)
        }
        "hermite" => {
            ([2.0, 1.0, -2.0, 1.0, -3.0, -2.0, 3.0, -1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], 2)
        }
        "power" => ([1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0], 4),
        _ => return None,
    };
    Some(Basis { matrix, step })
}

/// RenderMan's default basis (Bezier, step 3).
pub fn bezier_basis() -> Basis {
    Basis {
        matrix: [-1.0, 3.0, -3.0, 1.0, 3.0, -6.0, 3.0, 0.0, -3.0, 3.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        step: 3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A curve through four equal control points is constant for the approximating and
    /// interpolating bases: the rows of their matrices sum to [0 0 0 1].
    #[test]
    fn standard_bases_reproduce_constants() {
        for name in ["bezier", "b-spline", "catmull-rom"] {
            let b = named_basis(name).unwrap();
            let row_sum: Vec<f32> = (0..4).map(|r| (0..4).map(|c| b.matrix[r * 4 + c]).sum()).collect();
            for (r, s) in row_sum.iter().enumerate() {
                let expect = if r == 3 { 1.0 } else { 0.0 };
                assert!((s - expect).abs() < 1e-6, "{name} row {r}: {s}");
            }
        }
        assert_eq!(named_basis("bezier").unwrap(), bezier_basis());
        assert_eq!(named_basis("hermite").unwrap().step, 2);
        assert!(named_basis("nurbs").is_none());
    }
}

//! The fingerprint that ties a sidecar to the depth table rendered with it.

/// FNV-1a (64 bit) over the little-endian bits of every depth value in row order (top row first,
/// as the depth table stores them), followed by nothing else.
///
/// A depth table round-trips its `f32` values exactly in both of its formats (CONTRACTS.md §2),
/// so the viewer computes the same fingerprint from the table it loaded; a sidecar left over from
/// another render of another scene or camera does not match and is refused.
pub fn depth_fingerprint(depth: &[f32]) -> u64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut hash = OFFSET;
    for value in depth {
        for byte in value.to_bits().to_le_bytes() {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(PRIME);
        }
    }
    hash
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fingerprint_changes_with_any_value_and_with_order() {
        let a = depth_fingerprint(&[1.0, 2.0, f32::INFINITY]);
        assert_ne!(a, depth_fingerprint(&[1.0, 2.0, f32::MAX]));
        assert_ne!(a, depth_fingerprint(&[2.0, 1.0, f32::INFINITY]));
        assert_eq!(a, depth_fingerprint(&[1.0, 2.0, f32::INFINITY]));
        // Reference value for the empty table: FNV-1a's offset basis.
        assert_eq!(depth_fingerprint(&[]), 0xcbf2_9ce4_8422_2325);
    }
}

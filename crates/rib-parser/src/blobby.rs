//! The `Blobby` program (RISpec 3.2 §5.6): decoding and checking the code array into
//! instructions, shared by the parser (which refuses a bad program with a located error) and
//! every consumer that evaluates the field.

/// One decoded `Blobby` instruction. Each instruction's result has the index of the
/// instruction; operands of the operators name earlier results.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BlobbyInstruction {
    /// 1000: a constant field, `floats[float]`.
    Constant { float: u32 },
    /// 1001: an ellipsoid, the unit sphere under the 16-float matrix at `floats[float]`.
    Ellipsoid { float: u32 },
    /// 1002: a segment (a capsule): end points, radius and a 16-float matrix, 23 floats at
    /// `floats[float]`.
    Segment { float: u32 },
    /// 1003: a plane from a depth map (`strings[string]`) and 4 floats at `floats[float]`.
    Plane { string: u32, float: u32 },
    /// 1004: a field computed by a plugin, which is never run.
    Plugin { string: u32 },
    /// 0 .. 7: an operator and the results it combines.
    Operator { op: BlobbyOp, operands: Vec<u32> },
}

/// The field operators of RISpec Table 5.3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlobbyOp {
    Add,
    Multiply,
    Maximum,
    Minimum,
    /// The first operand minus the second.
    Subtract,
    /// The first operand divided by the second.
    Divide,
    Negate,
    Identity,
}

impl BlobbyInstruction {
    /// True for the primitive fields (the leaves that `Blobby`'s leaf count counts).
    pub fn is_leaf(&self) -> bool {
        !matches!(self, BlobbyInstruction::Operator { .. })
    }
}

/// Decodes and checks a `Blobby` code array against the lengths of its float and string
/// arrays and its leaf count. The message says what is wrong and where.
pub fn decode_blobby(
    leaf_count: u32,
    code: &[i32],
    floats: usize,
    strings: usize,
) -> Result<Vec<BlobbyInstruction>, String> {
    let mut out = Vec::new();
    let mut at = 0usize;
    let mut leaves = 0u64;
    let operand = |at: usize, what: &str| -> Result<u32, String> {
        let v = *code.get(at).ok_or_else(|| format!("code ends at entry {at} where {what} is expected"))?;
        u32::try_from(v).map_err(|_| format!("code entry {at} ({what}) is negative: {v}"))
    };
    let float_block = |index: u32, len: usize, at: usize, what: &str| -> Result<u32, String> {
        if (index as usize).checked_add(len).is_none_or(|end| end > floats) {
            return Err(format!(
                "code entry {at}: the {what} needs floats {index}..{} but only {floats} floats are given",
                index as u64 + len as u64
            ));
        }
        Ok(index)
    };
    let string_index = |index: u32, at: usize| -> Result<u32, String> {
        if index as usize >= strings {
            return Err(format!("code entry {at}: string {index} is out of range ({strings} strings given)"));
        }
        Ok(index)
    };
    while at < code.len() {
        let opcode = code[at];
        let here = out.len();
        let instruction = match opcode {
            1000 => BlobbyInstruction::Constant {
                float: float_block(operand(at + 1, "a float index")?, 1, at, "constant")?,
            },
            1001 => BlobbyInstruction::Ellipsoid {
                float: float_block(operand(at + 1, "a float index")?, 16, at, "ellipsoid")?,
            },
            1002 => BlobbyInstruction::Segment {
                float: float_block(operand(at + 1, "a float index")?, 23, at, "segment")?,
            },
            1003 => BlobbyInstruction::Plane {
                string: string_index(operand(at + 1, "a string index")?, at)?,
                float: float_block(operand(at + 2, "a float index")?, 4, at, "plane")?,
            },
            1004 => {
                // Plugin name, float count, float start, string count, string start.
                let string = string_index(operand(at + 1, "a string index")?, at)?;
                let float_count = operand(at + 2, "a float count")?;
                float_block(operand(at + 3, "a float index")?, float_count as usize, at, "plugin")?;
                let string_count = operand(at + 4, "a string count")?;
                let start = operand(at + 5, "a string index")?;
                if (start as u64 + string_count as u64) > strings as u64 {
                    return Err(format!("code entry {at}: the plugin's strings are out of range"));
                }
                BlobbyInstruction::Plugin { string }
            }
            0..=7 => {
                let op = [
                    BlobbyOp::Add,
                    BlobbyOp::Multiply,
                    BlobbyOp::Maximum,
                    BlobbyOp::Minimum,
                    BlobbyOp::Subtract,
                    BlobbyOp::Divide,
                    BlobbyOp::Negate,
                    BlobbyOp::Identity,
                ][opcode as usize];
                let (count, first) = match op {
                    BlobbyOp::Subtract | BlobbyOp::Divide => (2, at + 1),
                    BlobbyOp::Negate | BlobbyOp::Identity => (1, at + 1),
                    _ => (operand(at + 1, "an operand count")? as usize, at + 2),
                };
                if count == 0 {
                    return Err(format!("code entry {at}: operator {opcode} has no operands"));
                }
                if first.checked_add(count).is_none_or(|end| end > code.len()) {
                    return Err(format!(
                        "code entry {at}: operator {opcode} needs {count} operands but the code ends"
                    ));
                }
                let mut operands = Vec::with_capacity(count);
                for k in 0..count {
                    let v = operand(first + k, "an operand")?;
                    if v as usize >= here {
                        return Err(format!(
                            "code entry {}: operand {v} does not name an earlier instruction (this is instruction {here})",
                            first + k
                        ));
                    }
                    operands.push(v);
                }
                BlobbyInstruction::Operator { op, operands }
            }
            other => return Err(format!("code entry {at}: unknown opcode {other}")),
        };
        at += match &instruction {
            BlobbyInstruction::Constant { .. }
            | BlobbyInstruction::Ellipsoid { .. }
            | BlobbyInstruction::Segment { .. } => 2,
            BlobbyInstruction::Plane { .. } => 3,
            BlobbyInstruction::Plugin { .. } => 6,
            BlobbyInstruction::Operator { op, operands } => match op {
                BlobbyOp::Subtract | BlobbyOp::Divide | BlobbyOp::Negate | BlobbyOp::Identity => {
                    1 + operands.len()
                }
                _ => 2 + operands.len(),
            },
        };
        if instruction.is_leaf() {
            leaves += 1;
        }
        out.push(instruction);
    }
    if out.is_empty() {
        return Err("the code array is empty".into());
    }
    if leaves != u64::from(leaf_count) {
        return Err(format!("{leaf_count} leaves are declared but the code has {leaves} primitive fields"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_the_corpus_forms_and_rejects_bad_operands() {
        let code = [1001, 0, 1001, 16, 1001, 32, 0, 3, 0, 1, 2];
        let p = decode_blobby(3, &code, 48, 1).unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(p[3], BlobbyInstruction::Operator { op: BlobbyOp::Add, operands: vec![0, 1, 2] });
        let seg = decode_blobby(1, &[1002, 0, 0, 1, 0], 23, 1).unwrap();
        assert_eq!(seg[0], BlobbyInstruction::Segment { float: 0 });
        assert!(decode_blobby(1, &[1001, 0, 4, 0, 1], 16, 0).unwrap_err().contains("earlier instruction"));
        assert!(decode_blobby(1, &[1001, 8], 16, 0).unwrap_err().contains("floats"));
        assert!(decode_blobby(2, &[1001, 0], 16, 0).unwrap_err().contains("leaves"));
        assert!(decode_blobby(1, &[1001, 0, 9, 0], 16, 0).unwrap_err().contains("unknown opcode"));
        assert!(decode_blobby(1, &[1001, 0, 0, 2147483647, 0], 16, 0).unwrap_err().contains("code ends"));
    }
}

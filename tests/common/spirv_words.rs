//! Hand-made SPIR-V: instructions and names as the module's words, for the cost model's tests.

/// Instruction `op` with `operands`, its word count in the high half of the first word.
pub fn inst(op: u32, operands: &[u32]) -> Vec<u32> {
    let mut v = vec![((operands.len() as u32 + 1) << 16) | op];
    v.extend_from_slice(operands);
    v
}

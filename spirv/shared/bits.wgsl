// Bit helpers shared by passes. Import with `//! import shared/bits.wgsl`.

// Number of set bits in a subgroup ballot (bit i of .x is lane i; lanes 32.. are in .y, .z, .w).
fn ballot_count(ballot: vec4<u32>) -> u32 {
    return countOneBits(ballot.x) + countOneBits(ballot.y) + countOneBits(ballot.z) + countOneBits(ballot.w);
}

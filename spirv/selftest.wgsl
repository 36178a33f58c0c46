// Self-test pass: exercises subgroup arithmetic and ballot, workgroup atomics, a uniform buffer and
// two storage buffers. Per 256-invocation workgroup it writes the sum of `input[i] * scale + bias.x`
// and the number of odd inputs, whatever the subgroup size, so a CPU check is exact.
//! import shared/bits.wgsl

// Shared with Rust as `tests/common/selftest.rs`'s `SelftestParams`; layout checked by tests/vk_backbone.rs.
struct SelftestParams {
    count: u32,
    scale: u32,
    bias: vec2<u32>,
}

// One per workgroup. Shared with Rust as `tests/common/selftest.rs`'s `SelftestOut`.
struct SelftestOut {
    sum: u32,
    odd: u32,
    subgroup_size: u32,
    subgroups: u32,
}

@group(0) @binding(0) var<uniform> params: SelftestParams;
@group(0) @binding(1) var<storage, read> input: array<u32>;
@group(0) @binding(2) var<storage, read_write> output: array<SelftestOut>;

var<workgroup> wg_sum: atomic<u32>;
var<workgroup> wg_odd: atomic<u32>;
var<workgroup> wg_subgroups: atomic<u32>;

@compute @workgroup_size(256)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(subgroup_invocation_id) lane: u32,
    @builtin(subgroup_size) sg_size: u32,
) {
    let i = gid.x;
    var v = 0u;
    var odd = false;
    if i < params.count {
        let x = input[i];
        v = x * params.scale + params.bias.x;
        odd = (x & 1u) == 1u;
    }
    let s = subgroupAdd(v);
    let n = ballot_count(subgroupBallot(odd));
    // No subgroupElect in naga: the first active lane broadcasts its own id.
    if subgroupBroadcastFirst(lane) == lane {
        atomicAdd(&wg_sum, s);
        atomicAdd(&wg_odd, n);
        atomicAdd(&wg_subgroups, 1u);
    }
    // Uniform control flow: every invocation reaches this barrier.
    workgroupBarrier();
    if local == 0u {
        output[wg.x] = SelftestOut(atomicLoad(&wg_sum), atomicLoad(&wg_odd), sg_size, atomicLoad(&wg_subgroups));
    }
}

// dispatch_args: sizes the `compute_trace` dispatch from the ray count on the GPU (no CPU round
// trip): ceil(count / rays_per_group) workgroups, at most MAX_GROUPS_X (the kernel strides over
// the queue, so a capped dispatch still traces every ray). Zero rays give an empty dispatch.
//! import shared/compute_rays.wgsl

@group(0) @binding(0) var<storage, read_write> ray_counter: RayCounter;
@group(0) @binding(1) var<storage, read_write> dispatch_args: DispatchArgs;
@group(0) @binding(2) var<uniform> dispatch_params: DispatchParams;

@compute @workgroup_size(1)
fn main() {
    let n = atomicLoad(&ray_counter.count);
    let r = max(dispatch_params.rays_per_group, 1u);
    let groups = n / r + select(0u, 1u, n % r != 0u);
    dispatch_args = DispatchArgs(min(groups, MAX_GROUPS_X), 1u, 1u);
}

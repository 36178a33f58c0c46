// dispatch_args: sizes the `compute_trace` dispatch from the ray count on the GPU (no CPU round
// trip): ceil(count / rays_per_group) workgroups, at most MAX_GROUPS_X (the kernel strides over
// the queue, so a capped dispatch still traces every ray). Zero rays give an empty dispatch.
// It also computes, once per frame, each CMO's near-centre cut radius for `compute_trace`
// (which every ray recomputed before): 0.5 * min D (0 when no finite positive minimum), as
// `CmoTracer::new`; the min over the hierarchy's root cells is the min over the texels (exact:
// the data has no NaN, and a min does not depend on the order).
//! import shared/compute_rays.wgsl

@group(0) @binding(0) var<storage, read_write> ray_counter: RayCounter;
@group(0) @binding(1) var<storage, read_write> dispatch_args: DispatchArgs;
@group(0) @binding(2) var<storage, read> dispatch_params: DispatchParams;
// Per CMO: the cut radius (read by `compute_trace` as `cmo_cut`).
@group(0) @binding(3) var<storage, read_write> cut_out: array<f32>;
// The hierarchy's layout and cells (`compute_trace`'s `hier_config` and `cmo_hier`).
@group(0) @binding(4) var<storage, read> cut_hier_config: HierConfig;
@group(0) @binding(5) var<storage, read> cut_hier: array<vec2<f32>>;
// The texels (`cmo_distance`), read when the texels are the root (N <= 4).
@group(0) @binding(6) var<storage, read> cut_distance: array<f32>;

// The retrace dispatch after `main_lanes1` or `main_wave` (`compute_trace` in mode
// 1, `HierConfig`): one batch per subgroup for every ray the first dispatch cut (`retrace_size`).
@group(0) @binding(7) var<storage, read_write> retrace_args: DispatchArgs;

fn group_count(n: u32, rays_per_group: u32) -> u32 {
    let r = max(rays_per_group, 1u);
    return min(n / r + select(0u, 1u, n % r != 0u), MAX_GROUPS_X);
}

@compute @workgroup_size(1)
fn main() {
    let n = atomicLoad(&ray_counter.count);
    ray_counter.traced += n;
    dispatch_args = DispatchArgs(group_count(n, dispatch_params.rays_per_group), 1u, 1u);
    atomicStore(&ray_counter.cut, 0u);

    let size = dispatch_params.size;
    let root = cut_hier_config.root;
    let d = cut_hier_config.dims[root];
    for (var k = 0u; k < dispatch_params.cmo_count; k++) {
        var m = bitcast<f32>(0x7f800000u);
        if root == 0u {
            for (var i = 0u; i < 6u * size * size; i++) {
                m = min(m, cut_distance[k * 6u * size * size + i]);
            }
        } else {
            for (var i = 0u; i < 6u * d.y * d.z; i++) {
                m = min(m, cut_hier[k * cut_hier_config.hier_len + d.x + i].x);
            }
        }
        var cut = 0.0;
        // Finite (on the bits, as `is_finite_f32`) and positive.
        if (bitcast<u32>(m) & 0x7f800000u) != 0x7f800000u && m > 0.0 {
            cut = 0.5 * m;
        }
        cut_out[k] = cut;
    }
}

// Sizes the retrace dispatch from the rays the first `compute_trace` dispatch cut (after a
// barrier from it): none cut (every built-in scene), an empty dispatch. It used to cover every
// queued ray, each workgroup reading its rays' `cut` flags, and on lavapipe every subgroup ran
// the whole kernel body once, masked, for nothing: about half of `compute_trace`'s time on
// `default` (`benches/results/lavapipe-shaders.md`, "What was kept").
@compute @workgroup_size(1)
fn retrace_size() {
    var retrace = 0u;
    if dispatch_params.retrace_rays_per_group != 0u {
        retrace = group_count(atomicLoad(&ray_counter.cut), dispatch_params.retrace_rays_per_group);
    }
    retrace_args = DispatchArgs(retrace, 1u, 1u);
}

// The compute path's ray queue: the `append` pass writes one `AppendedRay` per mirror pixel
// through the atomic `RayCounter.count`; `dispatch_args` sizes the `compute_trace` dispatch from
// that count on the GPU; `compute_trace` traces each queued ray and writes `records[pixel]`.
// Rust twins: `cubetrace::vk::methods::compute::{AppendedRay, RayCounter, DispatchArgs}` (layouts checked
// in tests/compute.rs). Bindings are declared by each pass (their access differs).

// One queued mirror ray. Its fields lie where `BvhRay`'s do (shared/bvh_rays.wgsl; `t_min` unused,
// `BvhRay::flags` a pad): a round of `--bounces` copies its BVH queue here (`vk::passes::bounce`).
struct AppendedRay {
    // World ray origin (the G-buffer position of the mirror pixel; the previous hit in a
    // bounce round).
    origin: vec3<f32>,
    // Pixel index j * width + i (row 0 at the top), where the result goes.
    pixel: u32,
    // Unit reflected direction, exactly `mirror_ray`'s (the bounce round's in a round).
    dir: vec3<f32>,
    // `BvhRay::t_min`'s place: 0.
    t_min: f32,
    // The global triangle the ray leaves (the G-buffer's ID, the hit it reflects at in a bounce
    // round; 0xffffffff: none), for the start rule.
    from_triangle: u32,
    // Reflections already taken before this ray: 0 for the camera's first reflected ray, k - 1
    // in round k of `--bounces` (the record's `bounces` is this + 1).
    bounce: u32,
    pad0: u32,
    pad1: u32,
}

// Zeroed (vkCmdFillBuffer) before `append` every frame.
struct RayCounter {
    // Rays appended.
    count: atomic<u32>,
    // Largest subgroup size `compute_trace` ran with.
    subgroup_max: atomic<u32>,
    // Bitwise NOT of the smallest subgroup size (atomicMax of !size over a zeroed word).
    subgroup_min_not: atomic<u32>,
    // Rays traced this frame, over the rounds of `--bounces` (`dispatch_args` adds each round's
    // count; the counter is zeroed before the camera's rays, a round copies in its `count` only).
    traced: u32,
    // Rays of this dispatch whose step loop the driver's loop limit cut, appended by
    // `compute_trace` to its cut queue for the retrace (zeroed by `dispatch_args` before each
    // dispatch; `retrace_size` sizes the retrace from it).
    cut: atomic<u32>,
}

// VkDispatchIndirectCommand.
struct DispatchArgs {
    x: u32,
    y: u32,
    z: u32,
}

// Sizing of the `compute_trace` dispatch (Rust `cubetrace::vk::methods::compute::DispatchParams`).
struct DispatchParams {
    // Rays one `compute_trace` workgroup takes per batch at the device's subgroup size S:
    // 256 / min(S, 32). The kernel strides over the queue with the rays per workgroup it really
    // has, so any value >= 1 is correct; a smaller one only launches idle workgroups.
    rays_per_group: u32,
    // Number of CMOs K and face size N (for the cut radii).
    cmo_count: u32,
    size: u32,
    // Rays one retrace workgroup (`main_lanes1` or `main_wave` in mode 1) takes per
    // batch (256 / min(S, 32)); 0: no retrace dispatch (`retrace_args` is then 0).
    retrace_rays_per_group: u32,
}
// The largest workgroup count per dimension every Vulkan device accepts.
const MAX_GROUPS_X: u32 = 65535u;

// The hierarchy layout (Rust `cubetrace::vk::methods::compute::HierConfig`).
struct HierConfig {
    // Index of the root level (0 when the texels are the root, N <= 4).
    root: u32,
    // Cells per CMO in `cmo_hier`: hier32_len(N).
    hier_len: u32,
    // `compute_trace`'s mode (the entries that read it, `main_lanes1` and `main_wave`): 0 the
    // first dispatch, 1 the retrace; each dispatch binds its own copy of this buffer.
    mode: u32,
    // The first dispatch's step loop cap: MAX_STEPS but where a test lowers it
    // (`CUBETRACE_STEP_CAP`, `vk::methods::compute::STEP_CAP_ENV`) to make the retrace run: no
    // scene of the suite has a ray the driver's loop limit cuts.
    step_cap: u32,
    // Level l: (offset in cells within a CMO block (l >= 1), width, height, 0).
    dims: array<vec4<u32>, 8>,
    // Level l: (gx, gy) block of level l - 1 cells per cell, (span x, span y) in texels.
    shape: array<vec4<u32>, 8>,
}

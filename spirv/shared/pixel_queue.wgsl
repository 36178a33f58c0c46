// A queue of pixel indices, for a pass whose work lies on a few of the frame's pixels (the
// glossy cone passes, spirv/cone.wgsl and spirv/ssr_cone.wgsl). The pass's selection entry point
// (one invocation per pixel, a small body) pushes the pixels it keeps, `queue_args` sizes an
// indirect dispatch from their count, and the pass's `main` runs one invocation per queued
// pixel (`pixel_queue_at`). Run over every pixel instead, with an early return, a CPU driver ran
// `main`'s whole body, masked, for every subgroup, whether it held such a pixel or not
// (spirv/README.md, "What lavapipe does"). Rust side: `vk::passes::pixel_queue`, which zeroes the
// head before the selection.

const PIXEL_QUEUE_WG: u32 = 64u;

// `main`'s dispatch (`VkDispatchIndirectCommand`, written by `queue_args`) and the number of
// pixels queued.
struct PixelQueueHead {
    x: u32,
    y: u32,
    z: u32,
    count: atomic<u32>,
}

// The queued pixels' indices (`j * width + i`), in the order they were pushed.
@group(0) @binding(9) var<storage, read_write> pixel_queue: array<u32>;
@group(0) @binding(10) var<storage, read_write> pixel_queue_head: PixelQueueHead;

// The pixel of invocation `gid` of a selection entry point's dispatch (one invocation per pixel,
// workgroups of PIXEL_QUEUE_WG, rows of `groups.x` workgroups), or 0xffffffff past the frame's
// `pixels`.
fn pixel_queue_pixel(gid: vec3<u32>, groups: vec3<u32>, pixels: u32) -> u32 {
    let i = gid.y * (groups.x * PIXEL_QUEUE_WG) + gid.x;
    if i >= pixels {
        return 0xffffffffu;
    }
    return i;
}

fn pixel_queue_push(index: u32) {
    pixel_queue[atomicAdd(&pixel_queue_head.count, 1u)] = index;
}

// The pixel of invocation `gid` of `main`'s dispatch (workgroups of PIXEL_QUEUE_WG, rows of
// `groups.x` workgroups), or 0xffffffff past the queue's end.
fn pixel_queue_at(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    let q = gid.y * (groups.x * PIXEL_QUEUE_WG) + gid.x;
    if q >= atomicLoad(&pixel_queue_head.count) {
        return 0xffffffffu;
    }
    return pixel_queue[q];
}

// Sizes `main`'s dispatch: one invocation per queued pixel, rows of at most 65535 workgroups.
@compute @workgroup_size(1)
fn queue_args() {
    let groups = (atomicLoad(&pixel_queue_head.count) + PIXEL_QUEUE_WG - 1u) / PIXEL_QUEUE_WG;
    pixel_queue_head.x = min(groups, 65535u);
    pixel_queue_head.y = (groups + 65534u) / 65535u;
    pixel_queue_head.z = 1u;
}

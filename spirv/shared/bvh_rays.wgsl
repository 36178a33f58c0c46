// The BVH tracer's ray queue (Rust twins: `cubetrace::vk::passes::bvh::{BvhRay, BvhCounter}`, layouts
// checked in tests/bvh.rs). A producer appends `BvhRay`s through the atomic
// `BvhCounter.count`; `bvh_queue`'s `args` entry sizes the `bvh_trace` dispatch from the count;
// `bvh_trace` traces each ray and writes `records[ray.pixel]`. Bindings are declared by each pass
// (their access differs).

// One queued ray.
struct BvhRay {
    // World origin and the pixel (j * width + i) whose record the result goes to.
    origin: vec3<f32>,
    pixel: u32,
    // Unit direction.
    dir: vec3<f32>,
    // Start distance: hits at t < t_min are not taken (0: from the origin on).
    t_min: f32,
    // The triangle the ray leaves (the start rule in shared/bvh.wgsl), BVH_NO_TRIANGLE if none.
    from_triangle: u32,
    // Reflections already taken before this ray (0: the camera's first reflection).
    bounce: u32,
    // BVH_RAY_FALLBACK: the ray finishes a record another method left unresolved (only the
    // result fields of the record are written, and its `fallback` flag set). BVH_RAY_CHECK: the
    // reflector check (vk::passes::bvh::ReflectorCheck) re-traces a resolved record's ray against the
    // reflectors' BVH; a hit replaces the record's result only if strictly nearer than its `t`
    // (any hit when it escaped), on another triangle, and sets its `checked` flag.
    flags: u32,
    pad0: u32,
}

const BVH_RAY_FALLBACK: u32 = 1u;
const BVH_RAY_CHECK: u32 = 2u;
// A glossy reflector's lobe sample below the surface (bvh_queue's `append_mirror`,
// shared/lobe.wgsl): absorbed, so bvh_trace writes the record black (escaped, colour 0, no
// triangle) without tracing it.
const BVH_RAY_ABSORBED: u32 = 4u;
const BVH_NO_TRIANGLE: u32 = 0xffffffffu;

// Zeroed (vkCmdFillBuffer) before every append.
struct BvhCounter {
    // Rays appended.
    count: atomic<u32>,
    // Rays whose traversal loop reached its cap (`BVH_MAX_ITERATIONS`): left unresolved, `cut`.
    cut: atomic<u32>,
    pad0: u32,
    pad1: u32,
}

// VkDispatchIndirectCommand.
struct BvhDispatch {
    x: u32,
    y: u32,
    z: u32,
}

// Rays per `bvh_trace` workgroup (its @workgroup_size).
const BVH_GROUP_SIZE: u32 = 64u;
// The largest workgroup count per dimension every Vulkan device accepts.
const BVH_MAX_GROUPS_X: u32 = 65535u;

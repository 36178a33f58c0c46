// bvh_queue: the BVH tracer's ray queue (shared/bvh_rays.wgsl). Seven entry points, each one
// dispatch:
// - `append_mirror` (the `bvh` method): every mirror pixel of the G-buffer appends its reflected
//   ray (`mirror_ray`, the ray the cubemap paths trace) from t = 0, leaving the G-buffer's
//   triangle (the start rule of shared/bvh.wgsl). On a glossy reflector (the G-buffer normal's w,
//   shared/lobe.wgsl) the ray goes along one direction of the Phong lobe around the mirror
//   direction, that of the pixel, the frame's sample key (`frame.sample`) and bounce 0, as the
//   CPU reference draws it (`cubetrace::lobe`); a direction below the surface is queued flagged
//   BVH_RAY_ABSORBED (bvh_trace writes it black, untraced).
// - `append_unresolved` (`--fallback trace`): every mirror pixel whose record another method left
//   unresolved appends the record's ray, flagged BVH_RAY_FALLBACK, from t = 0 under the start
//   rule (leaving the G-buffer's triangle), as `append_mirror` would: the cubemap tracer's
//   "proven-empty" prefix [0, t_done] is empty for its model, not for the triangles. Measured
//   (tests/bvh.rs, compute path, built-in scenes): 46 of 1065 fallback rays at 160x120 with
//   the scenes' cube size 256, 26 of 410 at 96x72 with cube size 64, have the reference's hit
//   before t_done, on a reflector the CMOs do not capture (self-reflections
//   off: the sphere, teapot and torus seen in themselves near their outlines) or on a surface
//   that stands in front of its texel's patch (0.2 to 3 % before t_done).
// - `append_unresolved_from_t_done`: the same rays from t_min = t_done (1 - FALLBACK_SLACK), the
//   rule the issue proposed; kept to show (in the tests) what it misses, not used by a render.
//   The slack covers t_done's f32 rounding in a CMO's frame (a few ulps; 2^-10 is far above).
// - `append_check` (the reflector check, vk::passes::bvh::ReflectorCheck): every mirror pixel whose
//   record the method resolved (hit or escaped) and whose ray can meet a reflector
//   (`frame.check_below`) appends the record's ray, flagged BVH_RAY_CHECK,
//   from t = 0 under the start rule (leaving the G-buffer's triangle, as `append_mirror`); the
//   unresolved ones are the fallback's, which traces every triangle anyway.
// - `append_unresolved_queued`, `append_check_queued` (the rounds of `--bounces` that a cubemap
//   method traces, vk::passes::bounce): the same two rules per ray of the round's queue (`in_rays`,
//   one invocation per ray, dispatched with that queue's own `bvh_trace` arguments), for the
//   pixel's record the method just wrote: the queued ray itself, leaving its own `from_triangle`
//   and keeping its `bounce`. Every resolved ray is checked (`check_below` is the camera rays'
//   bound, from the G-buffer's normal).
// - `args`: one invocation; the `bvh_trace` dispatch from the count: ceil(n / 64) workgroups as
//   x <= 65535 by y (zero rays: an empty dispatch).
// Both appends run one invocation per pixel over a 2-D grid of 64-wide workgroups
// (`vk::passes::bvh::pixel_groups`); the order of the queue is the atomic's and nothing depends on it.
//! import shared/mirror.wgsl
//! import shared/bvh_rays.wgsl
//! import shared/lobe.wgsl

// The G-buffer's global triangle ID (`u32::MAX` where nothing is drawn).
@group(0) @binding(8) var gbuffer_triangle: texture_2d<u32>;
@group(2) @binding(0) var<storage, read_write> bvh_counter: BvhCounter;
@group(2) @binding(1) var<storage, read_write> bvh_rays: array<BvhRay>;
@group(2) @binding(2) var<storage, read_write> bvh_dispatch: BvhDispatch;
// A bounce round's queue (the `_queued` entries).
@group(2) @binding(3) var<storage, read_write> in_counter: BvhCounter;
@group(2) @binding(4) var<storage, read> in_rays: array<BvhRay>;

// Relative slack below t_done where a fallback ray starts (see above): 2^-10.
const FALLBACK_SLACK: f32 = 0.0009765625;

fn pixel_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * BVH_GROUP_SIZE;
}

fn push(ray: BvhRay) {
    let i = atomicAdd(&bvh_counter.count, 1u);
    bvh_rays[i] = ray;
}

@compute @workgroup_size(64)
fn append_mirror(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(gid, groups);
    if i >= frame.width * frame.height {
        return;
    }
    let pixel = vec2<u32>(i % frame.width, i / frame.width);
    let ray = mirror_ray(pixel);
    if !ray.mirror {
        return;
    }
    let tri = textureLoad(gbuffer_triangle, vec2<i32>(pixel), 0).x;
    let normal = textureLoad(gbuffer_normal, vec2<i32>(pixel), 0);
    let power = lobe_gbuffer_power(normal.w);
    var dir = ray.dir;
    var flags = 0u;
    if power >= 0.0 {
        // The normal as `mirror_ray` normalises it.
        let n = normalize_glam(normal.xyz);
        let u = lobe_uniforms(pixel.x, pixel.y, frame.sample, 0u);
        let s = lobe_sample(ray.dir, n, power, u);
        dir = s.dir;
        flags = select(BVH_RAY_ABSORBED, 0u, s.above);
    }
    push(BvhRay(ray.origin, i, dir, 0.0, tri, 0u, flags, 0u));
}

// The unresolved record of pixel `i` as a fallback ray from `t_min(t_done)`.
fn push_unresolved(i: u32, from_t_done: bool) {
    if i >= frame.width * frame.height {
        return;
    }
    let pixel = vec2<i32>(vec2<u32>(i % frame.width, i / frame.width));
    if textureLoad(gbuffer_position, pixel, 0).w != 1.0 {
        return;
    }
    let r = records[i];
    if r.status != RECORD_UNRESOLVED {
        return;
    }
    let tri = textureLoad(gbuffer_triangle, pixel, 0).x;
    var t_min = 0.0;
    if from_t_done {
        t_min = max(r.t_done - r.t_done * FALLBACK_SLACK, 0.0);
    }
    push(BvhRay(r.origin, i, r.dir, t_min, tri, 0u, BVH_RAY_FALLBACK, 0u));
}

@compute @workgroup_size(64)
fn append_unresolved(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    push_unresolved(pixel_index(gid, groups), false);
}

@compute @workgroup_size(64)
fn append_unresolved_from_t_done(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    push_unresolved(pixel_index(gid, groups), true);
}

@compute @workgroup_size(64)
fn append_check(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(gid, groups);
    if i >= frame.width * frame.height {
        return;
    }
    let pixel = vec2<i32>(vec2<u32>(i % frame.width, i / frame.width));
    if textureLoad(gbuffer_position, pixel, 0).w != 1.0 {
        return;
    }
    let r = records[i];
    if r.status == RECORD_UNRESOLVED {
        return;
    }
    // Only the rays that can meet a reflector (`Scene::check_below`); the normal as `mirror_ray`.
    let n = normalize_glam(textureLoad(gbuffer_normal, pixel, 0).xyz);
    if r.dir.x * n.x + r.dir.y * n.y + r.dir.z * n.z >= frame.check_below {
        return;
    }
    let tri = textureLoad(gbuffer_triangle, pixel, 0).x;
    push(BvhRay(r.origin, i, r.dir, 0.0, tri, 0u, BVH_RAY_CHECK, 0u));
}

// The ray of the round's queue at invocation `gid`, with its pixel's record, if there is one.
struct Queued {
    ok: bool,
    ray: BvhRay,
    record: PixelRecord,
}

fn queued(gid: vec3<u32>, groups: vec3<u32>) -> Queued {
    let k = pixel_index(gid, groups);
    var q: Queued;
    q.ok = k < atomicLoad(&in_counter.count);
    if q.ok {
        q.ray = in_rays[k];
        q.record = records[q.ray.pixel];
    }
    return q;
}

@compute @workgroup_size(64)
fn append_unresolved_queued(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let q = queued(gid, groups);
    if q.ok && q.record.status == RECORD_UNRESOLVED {
        push(BvhRay(q.ray.origin, q.ray.pixel, q.ray.dir, 0.0, q.ray.from_triangle, q.ray.bounce, BVH_RAY_FALLBACK, 0u));
    }
}

@compute @workgroup_size(64)
fn append_check_queued(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let q = queued(gid, groups);
    if q.ok && q.record.status != RECORD_UNRESOLVED {
        push(BvhRay(q.ray.origin, q.ray.pixel, q.ray.dir, 0.0, q.ray.from_triangle, q.ray.bounce, BVH_RAY_CHECK, 0u));
    }
}

@compute @workgroup_size(1)
fn args() {
    let n = atomicLoad(&bvh_counter.count);
    let g = n / BVH_GROUP_SIZE + select(0u, 1u, n % BVH_GROUP_SIZE != 0u);
    let x = min(g, BVH_MAX_GROUPS_X);
    var y = 1u;
    if x > 0u {
        y = g / x + select(0u, 1u, g % x != 0u);
    }
    bvh_dispatch = BvhDispatch(x, y, 1u);
}

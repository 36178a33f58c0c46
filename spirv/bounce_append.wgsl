// bounce_append: the producers of `--bounces N`'s wavefront (`vk::passes::bounce`). Three entry points:
// - `own_material` (N = 0): no ray is traced; every mirror pixel's record is the mirror surface
//   itself, shaded with its own material as any surface the camera sees (the G-buffer's colour),
//   `bounces` = 0, status hit at the G-buffer's point and triangle.
// - `append_first` (before round 2): one invocation per pixel; every mirror pixel whose record
//   (written by the method's round 1, and the trace fallback if any) is a hit on a reflector
//   triangle appends the next reflected ray to the out queue, `bounce` = 1.
// - `append_next` (before round k + 1, k >= 2): one invocation per ray of the in queue (the rays
//   round k traced; the indirect dispatch is the in queue's own `bvh_trace` dispatch); a ray
//   whose record is now a hit on a reflector appends the next reflected ray, `bounce` + 1.
// The CPU records exactly N - 1 appends (round 1 is the method's), so no shader needs N: the
// rays of round N are not appended to anything, and a reflector they hit keeps the colour
// `bvh_trace` shaded there, its own material, as the reference shades a reflector met after the
// last bounce.
//
// The next ray (`reference::finish_path`): from the record's point, along
// `normalize(reflect(d, n))`, `d` the record's direction and `n` the normalised interpolated
// vertex normal of the hit triangle at the hit's barycentrics (`Tracer::normal`, the arithmetic
// of `hit_shade`). The barycentrics are recomputed by the watertight test of the record's own
// ray against its triangle (for a `bvh_trace` record the very computation that found the hit,
// so the same bits); should that test miss (a verified cubemap hit the watertight test does not
// reproduce), they are the point's area coordinates in the triangle. The ray leaves the hit
// triangle (the BVH kernel's start rule, shared/bvh.wgsl) with t_min = 0.
//! import shared/mirror.wgsl
//! import shared/bvh_rays.wgsl
//! import shared/watertight.wgsl
//! import shared/hit.wgsl

// The scene (shared/scene.wgsl); group 0 is the frame's, 1 is unused (shared/mirror.wgsl's CMO
// data), 2 the queues.
const SCENE_GROUP: u32 = 3u;

@group(0) @binding(4) var gbuffer_colour: texture_2d<f32>;
// The G-buffer's global triangle ID (`u32::MAX` where nothing is drawn).
@group(0) @binding(8) var gbuffer_triangle: texture_2d<u32>;
// The out queue (the next round's) and, for `append_next`, the in queue (this round's).
@group(2) @binding(0) var<storage, read_write> out_counter: BvhCounter;
@group(2) @binding(1) var<storage, read_write> out_rays: array<BvhRay>;
@group(2) @binding(2) var<storage, read_write> in_counter: BvhCounter;
@group(2) @binding(3) var<storage, read> in_rays: array<BvhRay>;

fn invocation_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * BVH_GROUP_SIZE;
}

// Barycentric weights of `p` in triangle (a, b, c) by sub-triangle areas (the fallback above).
fn area_bary(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    let n = cross(b - a, c - a);
    let nn = dot(n, n);
    if !(nn > 0.0) {
        return vec3<f32>(1.0, 0.0, 0.0);
    }
    let u = dot(cross(c - p, a - p), n) / nn;
    let v = dot(cross(a - p, b - p), n) / nn;
    return vec3<f32>(1.0 - u - v, u, v);
}

// Appends the ray reflected at record `r`'s hit (pixel `pixel`, `bounce` reflections before it)
// if that hit is on a reflector.
fn append_reflection(pixel: u32, r: PixelRecord, bounce: u32) {
    if r.status != RECORD_HIT || r.triangle == BVH_NO_TRIANGLE {
        return;
    }
    let v0 = hit_vertex(r.triangle, 0u);
    if !scene_is_reflector(v0.object) {
        return;
    }
    let v1 = hit_vertex(r.triangle, 1u);
    let v2 = hit_vertex(r.triangle, 2u);
    let w = wt_intersect(r.origin, r.dir, v0.position, v1.position, v2.position);
    var bary = w.bary;
    if !w.hit {
        bary = area_bary(r.point, v0.position, v1.position, v2.position);
    }
    let u = bary.y;
    let v = bary.z;
    let n = scene_normalize(v0.normal * (1.0 - u - v) + v1.normal * u + v2.normal * v);
    let d = r.dir;
    let dn = d.x * n.x + d.y * n.y + d.z * n.z;
    let dir = normalize_glam(d - n * (2.0 * dn));
    let i = atomicAdd(&out_counter.count, 1u);
    out_rays[i] = BvhRay(r.point, pixel, dir, 0.0, r.triangle, bounce, 0u, 0u);
}

@compute @workgroup_size(64)
fn own_material(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation_index(gid, groups);
    if i >= frame.width * frame.height {
        return;
    }
    let pixel = vec2<i32>(vec2<u32>(i % frame.width, i / frame.width));
    let p = textureLoad(gbuffer_position, pixel, 0);
    if p.w != 1.0 {
        return;
    }
    let colour = textureLoad(gbuffer_colour, pixel, 0).xyz;
    let tri = textureLoad(gbuffer_triangle, pixel, 0).x;
    let d = normalize_glam(p.xyz - frame.eye);
    records[i] = PixelRecord(
        frame.eye, RECORD_HIT, d, 0xffffffffu, p.xyz, 0u, colour,
        0u, 0u, 0u, 0u, 0u, 0u, length(p.xyz - frame.eye), 0.0, tri,
        0u, 0u, 0u, 0u,
    );
}

@compute @workgroup_size(64)
fn append_first(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation_index(gid, groups);
    if i >= frame.width * frame.height {
        return;
    }
    let pixel = vec2<i32>(vec2<u32>(i % frame.width, i / frame.width));
    if textureLoad(gbuffer_position, pixel, 0).w != 1.0 {
        return;
    }
    append_reflection(i, records[i], 1u);
}

@compute @workgroup_size(64)
fn append_next(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = invocation_index(gid, groups);
    if k >= atomicLoad(&in_counter.count) {
        return;
    }
    let ray = in_rays[k];
    append_reflection(ray.pixel, records[ray.pixel], ray.bounce + 1u);
}

// bvh_trace: traces the queued rays (shared/bvh_rays.wgsl) exactly against the scene's triangles
// over the CWBVH (shared/bvh.wgsl), one ray per invocation, and writes `records[ray.pixel]`:
// a hit gets the point, t, the triangle and the colour shaded there (`hit_shade`, as the verified
// hits and the reference shade); no hit is escaped (the background, point at t_hi); a ray whose
// loop reached its cap is unresolved with `cut` = 1 (and counted in `bvh_counter.cut`). A plain
// ray writes the whole record (cmo = 0xffffffff, no texel, counters: `texels` = triangles tested,
// `cells` = nodes visited, `t_done` = its t_min, `bounces` = its `bounce` + 1); a BVH_RAY_FALLBACK ray writes only the result
// fields (status, point, colour, t, triangle, cut) and sets `fallback`, keeping the cubemap
// tracer's texel, counters and t_done. A BVH_RAY_CHECK ray (the reflector check, over the
// reflectors' BVH) writes the same result fields and sets `checked` only when its hit is strictly
// nearer than the record's `t` (any hit when the record escaped) and on another triangle than
// the record's; otherwise (a miss, a farther hit, a cut loop) it leaves the record untouched.
// A BVH_RAY_ABSORBED ray (a glossy lobe's sample below the surface) is not traced: its record is
// escaped with colour 0, no triangle, t = 0.
// The dispatch is `bvh_queue`'s `args`.
//! import shared/record.wgsl
//! import shared/bvh_rays.wgsl
//! import shared/bvh.wgsl

// The scene (shared/scene.wgsl); group 0 is the frame's records, 1 the BVH (shared/bvh.wgsl), 2
// the queue.
const SCENE_GROUP: u32 = 3u;

@group(0) @binding(3) var<storage, read_write> records: array<PixelRecord>;
@group(2) @binding(0) var<storage, read_write> bvh_counter: BvhCounter;
@group(2) @binding(1) var<storage, read> bvh_rays: array<BvhRay>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * BVH_GROUP_SIZE;
    if i >= atomicLoad(&bvh_counter.count) {
        return;
    }
    let ray = bvh_rays[i];
    if (ray.flags & BVH_RAY_ABSORBED) != 0u {
        // A glossy lobe's sample below the surface (`cubetrace::lobe`): no light, no hit.
        records[ray.pixel] = PixelRecord(
            ray.origin, RECORD_ESCAPED, ray.dir, 0xffffffffu, ray.origin, 0u, vec3<f32>(0.0),
            0u, 0u, 0u, 0u, 0u, 1u, 0.0, ray.t_min, BVH_NO_TRIANGLE,
            0u, 0u, ray.bounce + 1u, 0u,
        );
        return;
    }
    let h = bvh_nearest(ray.origin, ray.dir, ray.t_min, ray.from_triangle);
    var status = RECORD_ESCAPED;
    var t = bvh_params.t_hi;
    var colour = scene_shading.background;
    if h.cut {
        status = RECORD_UNRESOLVED;
        t = ray.t_min;
        atomicAdd(&bvh_counter.cut, 1u);
    } else if h.hit {
        status = RECORD_HIT;
        t = h.t;
        colour = hit_shade(h.triangle, h.bary.yz);
    }
    let point = ray.origin + ray.dir * t;
    let cut = select(0u, 1u, h.cut);
    if (ray.flags & BVH_RAY_CHECK) != 0u {
        let r = records[ray.pixel];
        // The method's hit is where the ray starts: the triangle it leaves, or a neighbour the
        // start rule ignores (a self-captured reflector's own surface, verified at t ~ 0). That
        // is no hit; the pixel is unresolved again (`checked` = 2) and the fallback, which runs
        // next, traces the ray against every triangle.
        if r.status == RECORD_HIT && bvh_start_hit(ray.origin, ray.from_triangle, r.triangle, r.t * length(ray.dir)) {
            records[ray.pixel].status = RECORD_UNRESOLVED;
            records[ray.pixel].checked = 2u;
            return;
        }
        let nearer = r.status == RECORD_ESCAPED || (r.status == RECORD_HIT && h.t < r.t && h.triangle != r.triangle);
        if h.hit && nearer {
            records[ray.pixel].status = status;
            records[ray.pixel].point = point;
            records[ray.pixel].colour = colour;
            records[ray.pixel].t = t;
            records[ray.pixel].triangle = h.triangle;
            records[ray.pixel].checked = 1u;
        }
    } else if (ray.flags & BVH_RAY_FALLBACK) != 0u {
        records[ray.pixel].status = status;
        records[ray.pixel].point = point;
        records[ray.pixel].colour = colour;
        records[ray.pixel].t = t;
        records[ray.pixel].triangle = h.triangle;
        records[ray.pixel].cut = cut;
        records[ray.pixel].fallback = 1u;
    } else {
        // A bounce round's ray (`bounce` > 0, vk::passes::bounce) keeps the pixel's `fallback` and
        // `checked` flags: its first round may have been finished by the fallback, or changed by
        // the reflector check.
        var fallback = 0u;
        var checked = 0u;
        if ray.bounce > 0u {
            fallback = records[ray.pixel].fallback;
            checked = records[ray.pixel].checked;
        }
        records[ray.pixel] = PixelRecord(
            ray.origin, status, ray.dir, 0xffffffffu, point, 0u, colour,
            0u, 0u, 0u, h.tests, h.nodes, 1u, t, ray.t_min, h.triangle,
            cut, fallback, ray.bounce + 1u, checked,
        );
    }
}

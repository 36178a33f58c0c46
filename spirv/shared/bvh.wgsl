// Exact ray tracing of the scene's triangles over a compressed wide BVH (CWBVH, Ylitie, Karras
// and Laine 2017, "Efficient incoherent ray traversal on GPUs through compressed wide BVHs"),
// built on the CPU by `obvhs` (`vk::passes::bvh::BvhData`). Our own traversal of obvhs's 80-byte
// `CwBvhNode` layout; the node order and octant trick follow the paper.
//
// Data, @group(1) (a file that imports this one keeps group 1 for it):
// - binding 0 `bvh_nodes`: 5 vec4<u32> per node, the bytes of `CwBvhNode` in order:
//   [p.xyz bits, e0 | e1 << 8 | e2 << 16 | imask << 24], [child_base, primitive_base, cmeta 0..4,
//   cmeta 4..8], then per axis x, y, z [qmin 0..4, qmin 4..8, qmax 0..4, qmax 4..8].
// - binding 1 `bvh_tris`: 3 vec4<f32> per primitive slot (the order of `primitive_indices`):
//   the triangle's corners, `.w` of the first is the bits of its global index
//   (`WorldGeometry::triangles` order, the scene's index buffer order).
// - binding 2 `bvh_params`: `BvhParams`.
// Needs the scene (shared/hit.wgsl, @group(SCENE_GROUP)) for the start rule and shading.
//
// Exactness: the box test is conservative (each slab distance is widened by 2^-20 of the
// magnitudes it is computed from, far above f32 rounding; obvhs quantises boxes outwards), so a
// box that holds a triangle the ray meets is never skipped; the triangle test is the watertight
// one of the verified hits (shared/watertight.wgsl: a ray through a shared edge or vertex meets
// at least one of the triangles there); the nearest hit wins, ties (equal t) go to the lower
// global index, as in the CPU reference.
//
// The start rule (the GPU analogue of `reference::Tracer::nearest`'s `from`): a ray that leaves
// triangle F (`from_triangle`: the G-buffer's triangle ID for a camera's reflected ray) at the
// f32 point o ignores hits on F itself, and hits on a neighbour F' of F (a corner at a
// bit-identical position) whose plane passes within `e` of o, with
//   e = 2 |s_F(o)| + 2^-18 max(|o|_inf, |F's corners|_inf),
// `s_F(o)` the distance of o from F's plane. The G-buffer's o is the rasteriser's interpolation,
// whose error Vulkan does not bound; its distance from F's plane is the part of that error we can
// see (an error within the plane moves the start along the surface, which the rule does not
// need), doubled, plus 16 f32 ulps of the coordinates for the f32 plane distances themselves.
// Past an edge the error within the plane does matter: the rasteriser can interpolate o beyond
// F's edge, and there o lies off the surface, behind the neighbour across that edge, whose plane
// holds the edge and so passes within |s_F(o)| + x_F(o) of o, `x_F(o)` how far o's projection
// lies past F's farthest edge line. A ray leaving o over that edge meets the neighbour within
// about x_F(o) of o (for a convex crease; the plane is tilted towards the ray). So a neighbour
// whose plane passes within the reach r = e + 2 x_F(o) of o is ignored too, where the hit lies
// within r of o; a hit farther out is real (a grazing ray that meets the next triangle of a
// concave crease 2.6e-3 away, on `default`). Without the reach a ray from a point interpolated
// 2e-5 past a crease of the teapot met the neighbour at t = 1.5e-5: a wrong surface that every
// GPU method drew (tests/hard_cases/start_rule.rs). Inside F, r = e: only `e` decides.
// A neighbour's plane within e of o may meet the ray ahead of or behind the exact start: the
// hit is rounding, as in the reference. Every other hit with t > 0 (and t >= t_min) counts.
//
// Loop cap: lavapipe ends every loop of an invocation after 65535 back-edges in all
// (spirv/README.md, "Known defect"). The traversal is one loop whose every iteration tests one
// triangle or one node (a loop of 8 children: at most 9 back-edges per iteration), one ray per
// invocation, capped at BVH_MAX_ITERATIONS (9 x 7000 < 65535); a ray that reaches the cap ends
// unresolved with `cut` set (and counted). Typical rays take tens to hundreds of iterations.
//! import shared/bvh_rays.wgsl
//! import shared/watertight.wgsl
//! import shared/hit.wgsl
//! import shared/start.wgsl

struct BvhParams {
    // Nodes in `bvh_nodes` (0: an empty scene, every ray escapes).
    node_count: u32,
    // Length of an escaped ray (its record's `point` is origin + t_hi dir, as the other methods').
    t_hi: f32,
    pad0: u32,
    pad1: u32,
}

@group(1) @binding(0) var<storage, read> bvh_nodes: array<vec4<u32>>;
@group(1) @binding(1) var<storage, read> bvh_tris: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> bvh_params: BvhParams;

// Traversal iterations (one node or one triangle each) per ray (see "Loop cap").
const BVH_MAX_ITERATIONS: u32 = 7000u;
// Stack of node groups: obvhs bounds a CWBVH's depth by 32 (`CwBvh::validate`).
const BVH_STACK: u32 = 32u;
// Relative widening of the slab distances (see "Exactness").
const BVH_PAD: f32 = 9.5367431640625e-7; // 2^-20

struct BvhHit {
    hit: bool,
    t: f32,
    // Global triangle index (BVH_NO_TRIANGLE without a hit).
    triangle: u32,
    // Barycentric weights of the corners.
    bary: vec3<f32>,
    // The loop reached BVH_MAX_ITERATIONS (no result).
    cut: bool,
    // Nodes visited, triangles tested.
    nodes: u32,
    tests: u32,
}

// Byte i (0..8) of the 8-byte field stored in words (lo, hi).
fn bvh_byte8(lo: u32, hi: u32, i: u32) -> u32 {
    return (select(lo, hi, i >= 4u) >> ((i & 3u) * 8u)) & 0xffu;
}

// 1 / d with zero components replaced by +-2^100 (sign from the bits): the slab distances stay
// finite and of the right sign, and a box is entered where the exact ray meets it.
fn bvh_inv_dir(d: vec3<f32>) -> vec3<f32> {
    var inv = vec3<f32>(0.0);
    for (var i = 0u; i < 3u; i++) {
        let neg = (bitcast<u32>(d[i]) & 0x80000000u) != 0u;
        if abs(d[i]) < 1e-30 {
            inv[i] = select(1.2676506e30, -1.2676506e30, neg);
        } else {
            inv[i] = 1.0 / d[i];
        }
    }
    return inv;
}

// The hit mask of node `n`'s children whose boxes the ray meets within [t_lo, t_best]: internal
// children at bit 24 + (slot ^ octant) (nearer first from the top bit), leaves' primitive bits
// in 0..24 (obvhs `CwBvhNode::intersect_ray`, made conservative).
fn bvh_node_hits(n: u32, o: vec3<f32>, inv: vec3<f32>, oct: u32, t_lo: f32, t_best: f32) -> u32 {
    let w0 = bvh_nodes[5u * n];
    let w1 = bvh_nodes[5u * n + 1u];
    let wx = bvh_nodes[5u * n + 2u];
    let wy = bvh_nodes[5u * n + 3u];
    let wz = bvh_nodes[5u * n + 4u];
    let p = bitcast<vec3<f32>>(w0.xyz);
    let ext = vec3<f32>(
        bitcast<f32>((w0.w & 0xffu) << 23u),
        bitcast<f32>(((w0.w >> 8u) & 0xffu) << 23u),
        bitcast<f32>(((w0.w >> 16u) & 0xffu) << 23u),
    );
    let sd = ext * inv;
    let so = (p - o) * inv;
    let neg = vec3<bool>(inv.x < 0.0, inv.y < 0.0, inv.z < 0.0);
    var mask = 0u;
    for (var i = 0u; i < 8u; i++) {
        let cmeta = bvh_byte8(w1.z, w1.w, i);
        if cmeta == 0u {
            continue;
        }
        let lo = vec3<f32>(f32(bvh_byte8(wx.x, wx.y, i)), f32(bvh_byte8(wy.x, wy.y, i)), f32(bvh_byte8(wz.x, wz.y, i)));
        let hi = vec3<f32>(f32(bvh_byte8(wx.z, wx.w, i)), f32(bvh_byte8(wy.z, wy.w, i)), f32(bvh_byte8(wz.z, wz.w, i)));
        let qn = select(lo, hi, neg);
        let qf = select(hi, lo, neg);
        let an = qn * sd;
        let af = qf * sd;
        let tn = an + so - (abs(an) + abs(so)) * BVH_PAD;
        let tf = af + so + (abs(af) + abs(so)) * BVH_PAD;
        let t0 = max(max(tn.x, tn.y), max(tn.z, t_lo));
        let t1 = min(min(tf.x, tf.y), min(tf.z, t_best));
        if t0 <= t1 {
            let inner = (cmeta & (cmeta << 1u) & 0x10u) != 0u;
            let index = (cmeta ^ select(0u, oct, inner)) & 0x1fu;
            mask |= ((cmeta >> 5u) & 7u) << index;
        }
    }
    return mask;
}

fn bvh_corner(k: u32) -> vec3<f32> {
    return bvh_tris[k].xyz;
}

// Whether the start rule ignores a hit on global triangle `tri` for a ray leaving global
// triangle `from_tri` at `o`, `dist` from `o` (the rule `bvh_nearest` applies; false where
// either is BVH_NO_TRIANGLE).
fn bvh_start_hit(o: vec3<f32>, from_tri: u32, tri: u32, dist: f32) -> bool {
    if from_tri == BVH_NO_TRIANGLE || tri == BVH_NO_TRIANGLE {
        return false;
    }
    let f0 = hit_vertex(from_tri, 0u).position;
    let f1 = hit_vertex(from_tri, 1u).position;
    let f2 = hit_vertex(from_tri, 2u).position;
    let a = hit_vertex(tri, 0u).position;
    let b = hit_vertex(tri, 1u).position;
    let c = hit_vertex(tri, 2u).position;
    let e = bvh_start_tolerance(o, f0, f1, f2);
    return bvh_start_ignores(o, from_tri, f0, f1, f2, e, bvh_start_reach(o, f0, f1, f2, e), tri, a, b, c, dist);
}

fn bvh_miss() -> BvhHit {
    return BvhHit(false, 0.0, BVH_NO_TRIANGLE, vec3<f32>(0.0), false, 0u, 0u);
}

// The nearest hit along `o + t d`, t > 0 and t >= t_min, under the start rule for a ray leaving
// global triangle `from` (BVH_NO_TRIANGLE: none).
fn bvh_nearest(o: vec3<f32>, d: vec3<f32>, t_min: f32, from_tri: u32) -> BvhHit {
    var best = bvh_miss();
    if bvh_params.node_count == 0u {
        return best;
    }
    // The start rule's triangle and tolerance.
    var f0 = vec3<f32>(0.0);
    var f1 = vec3<f32>(0.0);
    var f2 = vec3<f32>(0.0);
    var e = -1.0;
    var r = -1.0;
    if from_tri != BVH_NO_TRIANGLE {
        f0 = hit_vertex(from_tri, 0u).position;
        f1 = hit_vertex(from_tri, 1u).position;
        f2 = hit_vertex(from_tri, 2u).position;
        e = bvh_start_tolerance(o, f0, f1, f2);
        r = bvh_start_reach(o, f0, f1, f2, e);
    }
    let inv = bvh_inv_dir(d);
    let oct = select(4u, 0u, inv.x < 0.0) | select(2u, 0u, inv.y < 0.0) | select(1u, 0u, inv.z < 0.0);
    let t_lo = max(t_min, 0.0);
    var t_best = bitcast<f32>(0x7f800000u);
    var stack: array<vec2<u32>, BVH_STACK>;
    var sp = 0u;
    // (child base, hit bits << 24 | imask) and (primitive base, primitive bits).
    var nodes = vec2<u32>(0u, 0x80000000u);
    var prims = vec2<u32>(0u, 0u);
    var iterations = 0u;
    loop {
        if iterations >= BVH_MAX_ITERATIONS {
            best = bvh_miss();
            best.cut = true;
            break;
        }
        iterations += 1u;
        if prims.y != 0u {
            let j = firstLeadingBit(prims.y);
            prims.y &= ~(1u << j);
            let k = prims.x + j;
            let a = bvh_corner(3u * k);
            let b = bvh_corner(3u * k + 1u);
            let c = bvh_corner(3u * k + 2u);
            let tri = bitcast<u32>(bvh_tris[3u * k].w);
            best.tests += 1u;
            let w = wt_intersect(o, d, a, b, c);
            if w.hit && w.t >= t_lo && (w.t < best.t || !best.hit || (w.t == best.t && tri < best.triangle)) {
                var start = false;
                if e >= 0.0 {
                    start = bvh_start_ignores(o, from_tri, f0, f1, f2, e, r, tri, a, b, c, w.t * length(d));
                }
                if !start {
                    best.hit = true;
                    best.t = w.t;
                    best.triangle = tri;
                    best.bary = w.bary;
                    t_best = w.t + w.t * BVH_PAD;
                }
            }
            continue;
        }
        if (nodes.y & 0xff000000u) != 0u {
            let group = nodes;
            let bit = firstLeadingBit(group.y);
            nodes.y &= ~(1u << bit);
            if (nodes.y & 0xff000000u) != 0u {
                if sp >= BVH_STACK {
                    best = bvh_miss();
                    best.cut = true;
                    break;
                }
                stack[sp] = nodes;
                sp += 1u;
            }
            let slot = (bit - 24u) ^ oct;
            let n = group.x + countOneBits(group.y & ~(0xffffffffu << slot));
            best.nodes += 1u;
            let mask = bvh_node_hits(n, o, inv, oct, t_lo, t_best);
            let w0 = bvh_nodes[5u * n];
            let w1 = bvh_nodes[5u * n + 1u];
            nodes = vec2<u32>(w1.x, (mask & 0xff000000u) | (w0.w >> 24u));
            prims = vec2<u32>(w1.y, mask & 0x00ffffffu);
            continue;
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        nodes = stack[sp];
    }
    return best;
}

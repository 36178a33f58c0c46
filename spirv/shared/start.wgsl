// The start rule of a ray that leaves a scene triangle (the GPU analogue of
// `reference::Tracer::nearest`'s `from`), shared by the BVH tracer (shared/bvh.wgsl, whose module
// docs state the rule and why `e` is what it is) and the `bounded` criterion's tracer
// (shared/trace_bounded.wgsl, which applies it in CMO-local coordinates). Pure functions of the
// corners and the start point: no bindings.

// 2^-18: the f32 ulps of the coordinates in the tolerance `e` (shared/bvh.wgsl, "start rule").
const BVH_START_ULPS: f32 = 3.814697265625e-6; // 2^-18

// Distance of `p` from the plane of (a, b, c) (infinite for a degenerate triangle).
fn bvh_plane_distance(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    let n = cross(b - a, c - a);
    let l = length(n);
    if !(l > 0.0) {
        return bitcast<f32>(0x7f800000u);
    }
    return abs(dot(p - a, n)) / l;
}

fn bvh_same(a: vec3<f32>, b: vec3<f32>) -> bool {
    return all(bitcast<vec3<u32>>(a) == bitcast<vec3<u32>>(b));
}

fn bvh_shares_corner(f0: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> bool {
    return bvh_same(f0, a) || bvh_same(f0, b) || bvh_same(f0, c)
        || bvh_same(f1, a) || bvh_same(f1, b) || bvh_same(f1, c)
        || bvh_same(f2, a) || bvh_same(f2, b) || bvh_same(f2, c);
}

// The start rule's `e` for a ray leaving the triangle (f0, f1, f2) at `o`.
fn bvh_start_tolerance(o: vec3<f32>, f0: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>) -> f32 {
    let m = max(max(abs(o), abs(f0)), max(abs(f1), abs(f2)));
    return 2.0 * bvh_plane_distance(o, f0, f1, f2) + BVH_START_ULPS * max(max(m.x, m.y), m.z);
}

// The start rule itself: a ray leaving `from_tri` (corners f0, f1, f2; tolerance `e`) at `o`
// ignores a hit on `tri` (corners a, b, c) when it is `from_tri` or a neighbour whose plane
// passes within `e` of `o`.
fn bvh_start_ignores(
    o: vec3<f32>, from_tri: u32, f0: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>, e: f32,
    tri: u32, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>,
) -> bool {
    return tri == from_tri
        || (bvh_shares_corner(f0, f1, f2, a, b, c) && bvh_plane_distance(o, a, b, c) <= e);
}

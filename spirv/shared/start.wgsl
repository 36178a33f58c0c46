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

// How far `o`, projected on the plane of (f0, f1, f2), lies beyond the farthest of the
// triangle's edge lines (0 inside it, and for a degenerate triangle): the rasteriser's
// interpolation can put a G-buffer point past its triangle's edge, off the surface there.
fn bvh_outside_distance(o: vec3<f32>, f0: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>) -> f32 {
    let n = cross(f1 - f0, f2 - f0);
    let l = length(n);
    if !(l > 0.0) {
        return 0.0;
    }
    let w0 = dot(cross(f1 - f0, o - f0), n) / (length(f1 - f0) * l);
    let w1 = dot(cross(f2 - f1, o - f1), n) / (length(f2 - f1) * l);
    let w2 = dot(cross(f0 - f2, o - f2), n) / (length(f0 - f2) * l);
    return max(max(0.0, -w0), max(-w1, -w2));
}

// The start rule's `e` for a ray leaving the triangle (f0, f1, f2) at `o`.
fn bvh_start_tolerance(o: vec3<f32>, f0: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>) -> f32 {
    let m = max(max(abs(o), abs(f0)), max(abs(f1), abs(f2)));
    return 2.0 * bvh_plane_distance(o, f0, f1, f2) + BVH_START_ULPS * max(max(m.x, m.y), m.z);
}

// The start rule's reach `r` for a ray leaving (f0, f1, f2) at `o` with tolerance `e`: `e` plus
// twice how far `o` lies past the triangle's farthest edge line (`r` = `e` inside it).
fn bvh_start_reach(o: vec3<f32>, f0: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>, e: f32) -> f32 {
    return e + 2.0 * bvh_outside_distance(o, f0, f1, f2);
}

// The start rule itself: a ray leaving `from_tri` (corners f0, f1, f2; tolerance `e`, reach
// `r`) at `o` ignores a hit on `tri` (corners a, b, c), `dist` from `o`, when it is `from_tri`,
// or a neighbour whose plane passes within `e` of `o`, or within `r` of `o` with the hit within
// `r` of `o` too.
fn bvh_start_ignores(
    o: vec3<f32>, from_tri: u32, f0: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>, e: f32, r: f32,
    tri: u32, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, dist: f32,
) -> bool {
    if tri == from_tri {
        return true;
    }
    let p = bvh_plane_distance(o, a, b, c);
    return bvh_shares_corner(f0, f1, f2, a, b, c) && (p <= e || (p <= r && dist <= r));
}

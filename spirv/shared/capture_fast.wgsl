// Step 5's fast paths (a texel wholly outside or wholly inside the triangle, and a tile of texels
// wholly outside it): the WGSL twin of `src/cubemap/texel_cone.rs`, whose module docs derive the
// slacks. Every expression keeps the CPU twin's f32 operation order; products that feed a sum go
// through `prod` (shared/frustum.wgsl), so that GPU bits equal the CPU's. `cb_dot` and
// `cb_max_abs` come from shared/capture_bounds.wgsl (each file imports the other; the splicer
// takes each once).
// The code is straight-line (no loop, no early exit in the tests): lavapipe runs 8 texels in lock
// step and executes both arms of a divergent branch.
// `one` is a 1.0 the compiler cannot see through: lavapipe reassociates a sum that ends in a
// literal constant (`x x + y y + 1.0` came out as from one rounding, a bit off the CPU's), so no
// literal enters a rounded sum here.
//! import shared/capture_bounds.wgsl

const CF_EDGE_SLACK: f32 = 0.00000095367431640625; // 2^-20
const CF_DET_SLACK: f32 = 0.000003814697265625; // 2^-18
const CF_DOT_SLACK: f32 = 0.0000002384185791015625; // 2^-22
const CF_CONDITION: f32 = 1024.0;

const CF_OUTSIDE: u32 = 0u;
const CF_INSIDE: u32 = 1u;
const CF_CLIP: u32 = 2u;

// `TexelCone`: `kind` one of CF_*, `(lo, hi)` for CF_INSIDE.
struct CfCone {
    kind: u32,
    lo: f32,
    hi: f32,
}

// `Edges`: the edge planes through the centre, `h = det(l0, l1, l2)`, its error bound `d_h`,
// `unit = 2^-20 R^2`, and `one` (see above).
struct CfEdges {
    n0: vec3<f32>,
    n1: vec3<f32>,
    n2: vec3<f32>,
    h: f32,
    d_h: f32,
    unit: f32,
    one: f32,
}

// `cross3`.
fn cf_cross(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(prod(a.y, b.z) - prod(a.z, b.y), prod(a.z, b.x) - prod(a.x, b.z), prod(a.x, b.y) - prod(a.y, b.x));
}

// `edges`; `e` (never negative) only makes `one` opaque.
fn cf_edges(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, e: f32) -> CfEdges {
    let r = max(max(cb_max_abs(l0), cb_max_abs(l1)), cb_max_abs(l2));
    let n1 = cf_cross(l1, l2);
    let r2 = r * r;
    return CfEdges(cf_cross(l0, l1), n1, cf_cross(l2, l0), cb_dot(l0, n1), CF_DET_SLACK * r2 * r, CF_EDGE_SLACK * r2, select(1.0, 0.5, e < 0.0));
}

// One edge plane against the four corners: bit 0 all four strictly outside (by `d`), bit 1 all
// four strictly inside.
fn cf_edge(n: vec3<f32>, s: f32, c0: vec3<f32>, c1: vec3<f32>, c2: vec3<f32>, c3: vec3<f32>, d: vec4<f32>) -> u32 {
    let v = vec4<f32>(cb_dot(n, c0), cb_dot(n, c1), cb_dot(n, c2), cb_dot(n, c3)) * s;
    return select(0u, 1u, all(v < -d)) | select(0u, 2u, all(v > d));
}

// `|c_j|_1` of the four corners `(k.x | k.y, k.z | k.w, 1)`.
fn cf_norms(k: vec4<f32>, one: f32) -> vec4<f32> {
    return vec4<f32>(abs(k.x) + abs(k.z) + one, abs(k.y) + abs(k.z) + one, abs(k.x) + abs(k.w) + one, abs(k.y) + abs(k.w) + one);
}

// `classify`: bit 0 some edge has the four corners of `k` outside, bit 1 every edge has them
// inside; 4 when the orientation is not sure (`|h| <= d_h`: neither may be used).
fn cf_classify(g: CfEdges, k: vec4<f32>) -> u32 {
    let c0 = vec3<f32>(k.x, k.z, g.one);
    let c1 = vec3<f32>(k.y, k.z, g.one);
    let c2 = vec3<f32>(k.x, k.w, g.one);
    let c3 = vec3<f32>(k.y, k.w, g.one);
    let d = g.unit * cf_norms(k, g.one);
    let s = select(-g.one, g.one, g.h > 0.0);
    let e0 = cf_edge(g.n0, s, c0, c1, c2, c3, d);
    let e1 = cf_edge(g.n1, s, c0, c1, c2, c3, d);
    let e2 = cf_edge(g.n2, s, c0, c1, c2, c3, d);
    let bits = ((e0 | e1 | e2) & 1u) | (e0 & e1 & e2 & 2u);
    return select(4u, bits, abs(g.h) > g.d_h);
}

// One corner of the inside path: `(t dot(c, w), t |c|, rho_d, rho_w)`, or `rho_d = -1` where its
// condition fails.
fn cf_corner(n: vec3<f32>, h: f32, c: vec3<f32>, c1: f32, unit: f32, w: vec3<f32>) -> vec4<f32> {
    let dd = 4.0 * (unit * c1);
    let den = cb_dot(n, c);
    let cw = cb_dot(c, w);
    let ok = abs(den) >= CF_CONDITION * dd && cw > 0.0;
    let t = h / den;
    let rho_d = dd / abs(den);
    let rho_w = CF_DOT_SLACK * c1 / cw;
    return select(vec4<f32>(0.0, 0.0, -1.0, 0.0), vec4<f32>(t * cw, t * sqrt(cb_dot(c, c)), rho_d, rho_w), ok);
}

// `inside_bounds`.
fn cf_inside(g: CfEdges, k: vec4<f32>, w: vec3<f32>, e: f32) -> CfCone {
    let n = g.n0 + g.n1 + g.n2;
    let a = cf_norms(k, g.one);
    let q0 = cf_corner(n, g.h, vec3<f32>(k.x, k.z, g.one), a.x, g.unit, w);
    let q1 = cf_corner(n, g.h, vec3<f32>(k.y, k.z, g.one), a.y, g.unit, w);
    let q2 = cf_corner(n, g.h, vec3<f32>(k.x, k.w, g.one), a.z, g.unit, w);
    let q3 = cf_corner(n, g.h, vec3<f32>(k.y, k.w, g.one), a.w, g.unit, w);
    if min(min(q0.z, q1.z), min(q2.z, q3.z)) < 0.0 {
        return CfCone(CF_CLIP, 0.0, 0.0);
    }
    let lo = min(min(q0.x, q1.x), min(q2.x, q3.x));
    let hi = max(max(q0.y, q1.y), max(q2.y, q3.y));
    let rho_d = max(max(q0.z, q1.z), max(q2.z, q3.z));
    let rho_w = max(max(q0.w, q1.w), max(q2.w, q3.w));
    let rho = g.d_h / abs(g.h) + rho_d + rho_w + CF_EDGE_SLACK * g.one;
    let lo_e = prod(lo, g.one - 2.0 * rho) - e;
    return CfCone(CF_INSIDE, select(0.0, lo_e, lo_e > 0.0), prod(hi, g.one + 2.0 * rho) + e);
}

// `texel_cone` of the face-local triangle `l*` whose `edges` are `g` (`cf_edges(l0, l1, l2, e)`,
// made once for a job's texels), the widened texel planes `k` (u min, u max, v min, v max), the
// texel-centre direction `w`, the error budget `e`.
fn cf_texel_cone_edges(g: CfEdges, k: vec4<f32>, w: vec3<f32>, e: f32) -> CfCone {
    let bits = cf_classify(g, k);
    if bits == 1u || bits == 3u {
        return CfCone(CF_OUTSIDE, 0.0, 0.0);
    }
    if bits != 2u || !(abs(g.h) >= CF_CONDITION * g.d_h) {
        return CfCone(CF_CLIP, 0.0, 0.0);
    }
    return cf_inside(g, k, w, e);
}

// `tile_outside`: whether the tile of texels `[x0, x1] x [y0, y1]` widened by `m` lies wholly
// outside the triangle (every texel of it would be `Outside` or clipped to nothing).
fn cf_tile_outside(g: CfEdges, x0: u32, x1: u32, y0: u32, y1: u32, size: u32, m: f32) -> bool {
    let k = vec4<f32>(face_coord(x0, size) - m, face_coord(x1 + 1u, size) + m, face_coord(y0, size) - m, face_coord(y1 + 1u, size) + m);
    let bits = cf_classify(g, k);
    return bits == 1u || bits == 3u;
}

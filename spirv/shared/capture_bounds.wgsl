// Sound per-texel bounds of a triangle (the `bounded` criterion): the WGSL twin of
// `src/cubemap/bounds.rs` (read its module docs: steps 1-5, the error budget E, the margins, the
// near-centre rule). Every expression keeps the CPU twin's f32 operation order; products that feed
// a sum go through `prod` (shared/frustum.wgsl), so that GPU bits equal the CPU's.
//! import shared/frustum.wgsl

const CB_MAX_POLY: u32 = 8u;
const CB_E_SCALE: f32 = 0.000003814697265625; // 2^-18
const CB_FACE_DILATION: f32 = 0.0078125; // 2^-7
const CB_MARGIN_FLOOR: f32 = 0.00000095367431640625; // 2^-20
const CB_NEAR_BOX: f32 = 1024.0;
const CB_TILE: u32 = 8u;

const CB_PLANE_U_MIN: u32 = 0u;
const CB_PLANE_U_MAX: u32 = 1u;
const CB_PLANE_V_MIN: u32 = 2u;
const CB_PLANE_V_MAX: u32 = 3u;
const CB_PLANE_BOX: u32 = 4u;

// A polygon of at most CB_MAX_POLY vertices; `overflow` 1 when a clip produced more.
struct CbPoly {
    p: array<vec3<f32>, 8>,
    n: u32,
    overflow: u32,
}

fn cb_triangle(t0: vec3<f32>, t1: vec3<f32>, t2: vec3<f32>) -> CbPoly {
    var q: CbPoly;
    q.p[0] = t0;
    q.p[1] = t1;
    q.p[2] = t2;
    q.n = 3u;
    q.overflow = 0u;
    return q;
}

// `plane_value`.
fn cb_plane_value(p: vec3<f32>, kind: u32, k: f32) -> f32 {
    switch kind {
        case 0u: { return p.x - prod(k, p.z); }
        case 1u: { return prod(k, p.z) - p.x; }
        case 2u: { return p.y - prod(k, p.z); }
        case 3u: { return prod(k, p.z) - p.y; }
        case 4u: { return k - p.x; }
        case 5u: { return p.x + k; }
        case 6u: { return k - p.y; }
        case 7u: { return p.y + k; }
        case 8u: { return k - p.z; }
        default: { return p.z + k; }
    }
}

// `i + (o - i) * s`, each component's product rounded on its own.
fn cb_lerp(pi: vec3<f32>, po: vec3<f32>, s: f32) -> vec3<f32> {
    return vec3<f32>(pi.x + prod(po.x - pi.x, s), pi.y + prod(po.y - pi.y, s), pi.z + prod(po.z - pi.z, s));
}

// Appends `v` to `out` (or flags the overflow). The store goes through constant indices (a
// loop the compiler unrolls): lavapipe turns a store at a per-lane index into a loop over lanes.
fn cb_push(out: ptr<function, CbPoly>, v: vec3<f32>) {
    let n = (*out).n;
    if n < CB_MAX_POLY {
        for (var k = 0u; k < CB_MAX_POLY; k++) {
            if k == n {
                (*out).p[k] = v;
            }
        }
        (*out).n = n + 1u;
    } else {
        (*out).overflow = 1u;
    }
}

// `clip`: Sutherland-Hodgman against `cb_plane_value(., kind, k) >= 0`. The vertex loop has a
// constant trip count (unrolled; constant indices) and skips the unused slots.
fn cb_clip(poly: CbPoly, kind: u32, k: f32) -> CbPoly {
    var out: CbPoly;
    out.n = 0u;
    out.overflow = poly.overflow;
    if poly.n == 0u {
        return out;
    }
    // The last vertex, through constant indices.
    var a = poly.p[0];
    for (var i = 1u; i < CB_MAX_POLY; i++) {
        if i == poly.n - 1u {
            a = poly.p[i];
        }
    }
    var fa = cb_plane_value(a, kind, k);
    for (var i = 0u; i < CB_MAX_POLY; i++) {
        if i < poly.n {
            let b = poly.p[i];
            let fb = cb_plane_value(b, kind, k);
            let a_in = fa >= 0.0;
            let b_in = fb >= 0.0;
            if a_in != b_in {
                var pi = b;
                var fi = fb;
                var po = a;
                var fo = fa;
                if a_in {
                    pi = a;
                    fi = fa;
                    po = b;
                    fo = fb;
                }
                let s = min(fi / (fi - fo), 1.0);
                cb_push(&out, cb_lerp(pi, po, s));
            }
            if b_in {
                cb_push(&out, b);
            }
            a = b;
            fa = fb;
        }
    }
    return out;
}

// `dot3`: (x x' + y y') + z z', each product rounded on its own.
fn cb_dot(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return prod(a.x, b.x) + prod(a.y, b.y) + prod(a.z, b.z);
}

fn cb_max_abs(v: vec3<f32>) -> f32 {
    return max(max(abs(v.x), abs(v.y)), abs(v.z));
}

// `texel_floor`.
fn cb_texel_floor(u: f32, size: u32) -> u32 {
    let k = floor((u + 1.0) * f32(size) * 0.5);
    return u32(min(max(k, 0.0), f32(size - 1u)));
}

// `error_budget`: E from the CMO-local triangle.
fn cb_error_budget(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>) -> f32 {
    let r = max(max(cb_max_abs(l0), cb_max_abs(l1)), cb_max_abs(l2));
    return CB_E_SCALE * r;
}

// `near_centre`.
fn cb_near_centre(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, e: f32) -> bool {
    let h = CB_NEAR_BOX * e;
    var p = cb_triangle(l0, l1, l2);
    for (var kind = CB_PLANE_BOX; kind < CB_PLANE_BOX + 6u; kind++) {
        p = cb_clip(p, kind, h);
    }
    return p.n > 0u || p.overflow != 0u;
}

// `FaceRect` (without the pool bound's area and perimeter); `hit` 0 when the face is skipped.
struct CbRect {
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
    m: f32,
    e: f32,
    whole: u32,
    hit: u32,
}

fn cb_whole_face(size: u32, e: f32) -> CbRect {
    return CbRect(0u, size - 1u, 0u, size - 1u, 2.0, e, 1u, 1u);
}

// `face_rect` of the face-local triangle `l*` (CMO-local).
fn cb_face_rect(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, size: u32) -> CbRect {
    let e = cb_error_budget(l0, l1, l2);
    if cb_near_centre(l0, l1, l2, e) {
        return cb_whole_face(size, e);
    }
    let d = 1.0 + CB_FACE_DILATION;
    var p = cb_triangle(l0, l1, l2);
    p = cb_clip(p, CB_PLANE_U_MIN, -d);
    p = cb_clip(p, CB_PLANE_U_MAX, d);
    p = cb_clip(p, CB_PLANE_V_MIN, -d);
    p = cb_clip(p, CB_PLANE_V_MAX, d);
    if p.overflow != 0u {
        return cb_whole_face(size, e);
    }
    if p.n == 0u {
        return CbRect(0u, 0u, 0u, 0u, 0.0, e, 0u, 0u);
    }
    var z_min = p.p[0].z;
    for (var i = 1u; i < p.n; i++) {
        z_min = min(z_min, p.p[i].z);
    }
    if z_min <= 4.0 * e {
        return cb_whole_face(size, e);
    }
    let m = CB_MARGIN_FLOOR + 4.0 * e / z_min;
    var u_lo = f32_inf();
    var u_hi = -f32_inf();
    var v_lo = f32_inf();
    var v_hi = -f32_inf();
    for (var i = 0u; i < p.n; i++) {
        let u = p.p[i].x / p.p[i].z;
        let v = p.p[i].y / p.p[i].z;
        u_lo = min(u_lo, u);
        u_hi = max(u_hi, u);
        v_lo = min(v_lo, v);
        v_hi = max(v_hi, v);
    }
    return CbRect(cb_texel_floor(u_lo - m, size), cb_texel_floor(u_hi + m, size), cb_texel_floor(v_lo - m, size), cb_texel_floor(v_hi + m, size), m, e, 0u, 1u);
}

// `texel_centre_unit`.
fn cb_texel_centre_unit(x: u32, y: u32, size: u32) -> vec3<f32> {
    let n = f32(size);
    let d = vec3<f32>(f32(2u * x + 1u) / n - 1.0, f32(2u * y + 1u) / n - 1.0, 1.0);
    let inv = 1.0 / sqrt(cb_dot(d, d));
    return d * inv;
}

// `texel_bound`: (lo, hi, hit) of the face-local triangle in texel (x, y).
struct CbBound {
    lo: f32,
    hi: f32,
    hit: bool,
}

// Step 5's first half: the triangle clipped to column x's planes (widened by m); the whole
// triangle for a `whole` rect.
fn cb_texel_column(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, whole: bool, m: f32, x: u32, size: u32) -> CbPoly {
    var q = cb_triangle(l0, l1, l2);
    if !whole {
        q = cb_clip(q, CB_PLANE_U_MIN, face_coord(x, size) - m);
        q = cb_clip(q, CB_PLANE_U_MAX, face_coord(x + 1u, size) + m);
    }
    return q;
}

// Step 5's second half, from the column polygon `column` (`cb_texel_column`).
fn cb_texel_finish(column: CbPoly, l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, whole: bool, m: f32, e: f32, x: u32, y: u32, size: u32) -> CbBound {
    var q = column;
    if !whole {
        q = cb_clip(q, CB_PLANE_V_MIN, face_coord(y, size) - m);
        q = cb_clip(q, CB_PLANE_V_MAX, face_coord(y + 1u, size) + m);
        if q.overflow != 0u {
            q = cb_triangle(l0, l1, l2);
        } else if q.n == 0u {
            return CbBound(0.0, 0.0, false);
        }
    }
    let w = cb_texel_centre_unit(x, y, size);
    var d_min = f32_inf();
    var r_max = 0.0;
    for (var i = 0u; i < CB_MAX_POLY; i++) {
        if i < q.n {
            d_min = min(d_min, cb_dot(q.p[i], w));
            r_max = max(r_max, sqrt(cb_dot(q.p[i], q.p[i])));
        }
    }
    let lo = d_min - e;
    return CbBound(select(0.0, lo, lo > 0.0), r_max + e, true);
}

// `texel_bound`: (lo, hi, hit) of the face-local triangle in texel (x, y).
fn cb_texel_bound(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, whole: bool, m: f32, e: f32, x: u32, y: u32, size: u32) -> CbBound {
    return cb_texel_finish(cb_texel_column(l0, l1, l2, whole, m, x, size), l0, l1, l2, whole, m, e, x, y, size);
}

// Sound per-texel bounds of a triangle (the `bounded` criterion): the WGSL twin of
// `src/cubemap/bounds.rs` (read its module docs: steps 1-5, the error budget E, the margins, the
// near-centre rule). Every expression keeps the CPU twin's f32 operation order; products that feed
// a sum go through `prod` (shared/frustum.wgsl), so that GPU bits equal the CPU's.
//! import shared/frustum.wgsl
//! import shared/capture_fast.wgsl

const CB_MAX_POLY: u32 = 8u;
const CB_E_SCALE: f32 = 0.000003814697265625; // 2^-18
const CB_FACE_DILATION: f32 = 0.0078125; // 2^-7
const CB_MARGIN_FLOOR: f32 = 0.00000095367431640625; // 2^-20
const CB_NEAR_BOX: f32 = 1024.0;
const CB_TILE: u32 = 8u;
// `cubemap::bounds::UNCLIPPED_TEXELS`: a rect of at most this many texels takes the whole
// triangle's bounds where the fast paths leave a texel.
const CB_UNCLIPPED_TEXELS: u32 = 4u;

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

// What `cb_clip` by the plane (`kind`, `k`) makes of the triangle `l*` where the answer needs no
// clip: CB_KEEPS (every corner inside: the same three vertices in the same order, since each
// edge then pushes its end alone), CB_EMPTIES (every corner outside: no vertex), else CB_CUTS.
// A NaN plane value is neither inside nor outside: CB_CUTS.
const CB_KEEPS: u32 = 0u;
const CB_EMPTIES: u32 = 1u;
const CB_CUTS: u32 = 2u;

fn cb_plane_effect(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, kind: u32, k: f32) -> u32 {
    let f = vec3<f32>(cb_plane_value(l0, kind, k), cb_plane_value(l1, kind, k), cb_plane_value(l2, kind, k));
    return select(select(CB_CUTS, CB_EMPTIES, all(f < vec3<f32>(0.0))), CB_KEEPS, all(f >= vec3<f32>(0.0)));
}

// The effect of clips in a row, from the effect so far `a` and the next plane's `b` on the
// triangle: a polygon emptied stays empty, one kept takes the next effect, a cut is a cut.
fn cb_then(a: u32, b: u32) -> u32 {
    return select(a, b, a == CB_KEEPS);
}

// The effect of the six box planes of `near_centre` in turn.
fn cb_box_effect(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, e: f32) -> u32 {
    let h = CB_NEAR_BOX * e;
    var effect = CB_KEEPS;
    for (var kind = CB_PLANE_BOX; kind < CB_PLANE_BOX + 6u; kind++) {
        effect = cb_then(effect, cb_plane_effect(l0, l1, l2, kind, h));
    }
    return effect;
}

// `near_centre`. The triangle clipped by the six box planes in turn; where every plane keeps or
// empties it (a triangle away from the three coordinate planes through the centre, the common
// case), the clips' outcome is known without them: the triangle (3 vertices, no overflow) or
// nothing. Only the rest run them.
fn cb_near_centre(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, e: f32) -> bool {
    let h = CB_NEAR_BOX * e;
    let effect = cb_box_effect(l0, l1, l2, e);
    if effect != CB_CUTS {
        return effect == CB_KEEPS;
    }
    var p = cb_triangle(l0, l1, l2);
    for (var kind = CB_PLANE_BOX; kind < CB_PLANE_BOX + 6u; kind++) {
        p = cb_clip(p, kind, h);
    }
    return p.n > 0u || p.overflow != 0u;
}

const CB_MISS_SLACK: f32 = 0.0009765625; // 2^-10

// `face_missed`: the face-local triangle's three corners outside one side plane of the face
// frustum dilated by 2^-7, each by more than 2^-10 of the coordinates its plane value sums.
fn cb_out_by(p: vec3<f32>, kind: u32, k: f32) -> bool {
    let a = select(p.y, p.x, kind < CB_PLANE_V_MIN);
    return cb_plane_value(p, kind, k) < -(CB_MISS_SLACK * (abs(a) + abs(p.z)));
}

fn cb_plane_missed(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, kind: u32, k: f32) -> bool {
    return cb_out_by(l0, kind, k) && cb_out_by(l1, kind, k) && cb_out_by(l2, kind, k);
}

fn cb_face_missed(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>) -> bool {
    let d = 1.0 + CB_FACE_DILATION;
    return cb_plane_missed(l0, l1, l2, CB_PLANE_U_MIN, -d) || cb_plane_missed(l0, l1, l2, CB_PLANE_U_MAX, d) || cb_plane_missed(l0, l1, l2, CB_PLANE_V_MIN, -d) || cb_plane_missed(l0, l1, l2, CB_PLANE_V_MAX, d);
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
    // The four clips run only where one of them cuts the triangle (as in `cb_near_centre`): a
    // triangle inside the face's frustum, most of them, is its own clipped polygon.
    let effect = cb_frustum_effect(l0, l1, l2);
    if effect == CB_KEEPS {
        return cb_corner_rect(l0, l1, l2, e, size);
    }
    var p = cb_triangle(l0, l1, l2);
    if effect == CB_EMPTIES {
        p.n = 0u;
    } else {
        p = cb_clip(p, CB_PLANE_U_MIN, -d);
        p = cb_clip(p, CB_PLANE_U_MAX, d);
        p = cb_clip(p, CB_PLANE_V_MIN, -d);
        p = cb_clip(p, CB_PLANE_V_MAX, d);
    }
    if p.overflow != 0u {
        return cb_whole_face(size, e);
    }
    if p.n == 0u {
        return cb_no_rect(e);
    }
    var z_min = p.p[0].z;
    for (var i = 1u; i < p.n; i++) {
        z_min = min(z_min, p.p[i].z);
    }
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
    return cb_rect_of(z_min, u_lo, u_hi, v_lo, v_hi, e, size);
}

// The rect of a face that the triangle misses.
fn cb_no_rect(e: f32) -> CbRect {
    return CbRect(0u, 0u, 0u, 0u, 0.0, e, 0u, 0u);
}

// The effect of the face frustum's four side planes (dilated) in turn.
fn cb_frustum_effect(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>) -> u32 {
    let d = 1.0 + CB_FACE_DILATION;
    var effect = cb_plane_effect(l0, l1, l2, CB_PLANE_U_MIN, -d);
    effect = cb_then(effect, cb_plane_effect(l0, l1, l2, CB_PLANE_U_MAX, d));
    effect = cb_then(effect, cb_plane_effect(l0, l1, l2, CB_PLANE_V_MIN, -d));
    return cb_then(effect, cb_plane_effect(l0, l1, l2, CB_PLANE_V_MAX, d));
}

// The rect of a triangle that every frustum plane keeps (its own clipped polygon), in straight
// code: the polygon loops' values in their order (the corners are finite here: a NaN plane
// value cuts).
fn cb_corner_rect(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, e: f32, size: u32) -> CbRect {
    let z_min = min(min(l0.z, l1.z), l2.z);
    let u = vec3<f32>(l0.x / l0.z, l1.x / l1.z, l2.x / l2.z);
    let v = vec3<f32>(l0.y / l0.z, l1.y / l1.z, l2.y / l2.z);
    let u_lo = min(min(min(f32_inf(), u.x), u.y), u.z);
    let u_hi = max(max(max(-f32_inf(), u.x), u.y), u.z);
    let v_lo = min(min(min(f32_inf(), v.x), v.y), v.z);
    let v_hi = max(max(max(-f32_inf(), v.x), v.y), v.z);
    return cb_rect_of(z_min, u_lo, u_hi, v_lo, v_hi, e, size);
}

// The texel rect of a polygon with nearest depth `z_min` and projections in
// `[u_lo, u_hi] x [v_lo, v_hi]`, widened by the margin; the whole face where the polygon comes
// within four error budgets of the centre's plane.
fn cb_rect_of(z_min: f32, u_lo: f32, u_hi: f32, v_lo: f32, v_hi: f32, e: f32, size: u32) -> CbRect {
    if z_min <= 4.0 * e {
        return cb_whole_face(size, e);
    }
    let m = CB_MARGIN_FLOOR + 4.0 * e / z_min;
    return CbRect(cb_texel_floor(u_lo - m, size), cb_texel_floor(u_hi + m, size), cb_texel_floor(v_lo - m, size), cb_texel_floor(v_hi + m, size), m, e, 0u, 1u);
}

// `cb_face_rect` where it needs no clip (no box plane cuts the triangle, and no frustum plane
// does, or the box keeps it: the whole face), else `hit` = 2: the caller runs `cb_face_rect`.
// The rect is then the same bits.
fn cb_face_rect_unclipped(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, size: u32) -> CbRect {
    let e = cb_error_budget(l0, l1, l2);
    let near = cb_box_effect(l0, l1, l2, e);
    let effect = cb_frustum_effect(l0, l1, l2);
    if near == CB_KEEPS {
        return cb_whole_face(size, e);
    }
    if near == CB_CUTS || effect == CB_CUTS {
        return CbRect(0u, 0u, 0u, 0u, 0.0, e, 0u, 2u);
    }
    if effect == CB_EMPTIES {
        return cb_no_rect(e);
    }
    return cb_corner_rect(l0, l1, l2, e, size);
}

// `texel_centre_unit`.
fn cb_texel_centre_unit(x: u32, y: u32, size: u32) -> vec3<f32> {
    let n = f32(size);
    let d = vec3<f32>(f32(2u * x + 1u) / n - 1.0, f32(2u * y + 1u) / n - 1.0, 1.0);
    let inv = 1.0 / sqrt(cb_dot(d, d));
    return d * inv;
}


// Step 5 streamed: the triangle's four clips to the texel's widened cone without building any
// clipped polygon. Only the set of the last polygon's vertices matters (`lo` and `hi` are a min
// and a max over it), and Sutherland-Hodgman makes each output vertex from one input edge: the
// crossing `cb_lerp(inside, outside, s)` (the same operands whichever way the edge runs) and
// the edge's end where it is inside. So each clip's outputs go straight into the next clip as
// they come (`cb_in*`, each closing an edge of the next clip from the previous output), the
// last clip's into the min and max (`cb_out`), and the closing edges run in clip order at the
// end. Starting a cycle at another vertex only rotates the clip's output, so the set and the
// counts are those of `cb_clip` four times, the bits too (the CPU twin `texel_bound` builds
// the polygons; `tests/bounded/capture_lists.rs` compares bits). More than `CB_MAX_POLY` outputs of
// any clip is the polygons' overflow. Lavapipe turns the polygons' stores at a per-lane index
// into loops over the slots; the stream has none.
struct CbStage {
    first: vec3<f32>,
    f_first: f32,
    prev: vec3<f32>,
    f_prev: f32,
    // The clip's inputs so far.
    seen: u32,
}

struct CbChain {
    // The plane constants of clips 1-4 (u min, u max, v min, v max).
    k: vec4<f32>,
    w: vec3<f32>,
    s: array<CbStage, 4>,
    // The last clip's outputs, and their min of `dot(q, w)` and max of `|q|`.
    count: u32,
    d_min: f32,
    r_max: f32,
}

fn cb_out(c: ptr<function, CbChain>, q: vec3<f32>) {
    (*c).count += 1u;
    (*c).d_min = min((*c).d_min, cb_dot(q, (*c).w));
    (*c).r_max = max((*c).r_max, sqrt(cb_dot(q, q)));
}

// Clip 4 (v max): edge (a, b) with plane values (fa, fb), `cb_clip`'s step.
fn cb_edge4(c: ptr<function, CbChain>, a: vec3<f32>, fa: f32, b: vec3<f32>, fb: f32) {
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
        cb_out(c, cb_lerp(pi, po, min(fi / (fi - fo), 1.0)));
    }
    if b_in {
        cb_out(c, b);
    }
}

// A vertex into clip 4: the edge from the previous one ends here.
fn cb_in4(c: ptr<function, CbChain>, b: vec3<f32>) {
    let fb = prod((*c).k.w, b.z) - b.y;
    if (*c).s[3].seen == 0u {
        (*c).s[3].first = b;
        (*c).s[3].f_first = fb;
    } else {
        cb_edge4(c, (*c).s[3].prev, (*c).s[3].f_prev, b, fb);
    }
    (*c).s[3].prev = b;
    (*c).s[3].f_prev = fb;
    (*c).s[3].seen += 1u;
}

// Clip 4's closing edge, from its last input to its first.
fn cb_close4(c: ptr<function, CbChain>) {
    if (*c).s[3].seen > 0u {
        cb_edge4(c, (*c).s[3].prev, (*c).s[3].f_prev, (*c).s[3].first, (*c).s[3].f_first);
    }
}

// Clip 3 (v min): edge (a, b) with plane values (fa, fb), `cb_clip`'s step.
fn cb_edge3(c: ptr<function, CbChain>, a: vec3<f32>, fa: f32, b: vec3<f32>, fb: f32) {
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
        cb_in4(c, cb_lerp(pi, po, min(fi / (fi - fo), 1.0)));
    }
    if b_in {
        cb_in4(c, b);
    }
}

// A vertex into clip 3: the edge from the previous one ends here.
fn cb_in3(c: ptr<function, CbChain>, b: vec3<f32>) {
    let fb = b.y - prod((*c).k.z, b.z);
    if (*c).s[2].seen == 0u {
        (*c).s[2].first = b;
        (*c).s[2].f_first = fb;
    } else {
        cb_edge3(c, (*c).s[2].prev, (*c).s[2].f_prev, b, fb);
    }
    (*c).s[2].prev = b;
    (*c).s[2].f_prev = fb;
    (*c).s[2].seen += 1u;
}

// Clip 3's closing edge, from its last input to its first.
fn cb_close3(c: ptr<function, CbChain>) {
    if (*c).s[2].seen > 0u {
        cb_edge3(c, (*c).s[2].prev, (*c).s[2].f_prev, (*c).s[2].first, (*c).s[2].f_first);
    }
}

// Clip 2 (u max): edge (a, b) with plane values (fa, fb), `cb_clip`'s step.
fn cb_edge2(c: ptr<function, CbChain>, a: vec3<f32>, fa: f32, b: vec3<f32>, fb: f32) {
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
        cb_in3(c, cb_lerp(pi, po, min(fi / (fi - fo), 1.0)));
    }
    if b_in {
        cb_in3(c, b);
    }
}

// A vertex into clip 2: the edge from the previous one ends here.
fn cb_in2(c: ptr<function, CbChain>, b: vec3<f32>) {
    let fb = prod((*c).k.y, b.z) - b.x;
    if (*c).s[1].seen == 0u {
        (*c).s[1].first = b;
        (*c).s[1].f_first = fb;
    } else {
        cb_edge2(c, (*c).s[1].prev, (*c).s[1].f_prev, b, fb);
    }
    (*c).s[1].prev = b;
    (*c).s[1].f_prev = fb;
    (*c).s[1].seen += 1u;
}

// Clip 2's closing edge, from its last input to its first.
fn cb_close2(c: ptr<function, CbChain>) {
    if (*c).s[1].seen > 0u {
        cb_edge2(c, (*c).s[1].prev, (*c).s[1].f_prev, (*c).s[1].first, (*c).s[1].f_first);
    }
}

// Clip 1 (u min): edge (a, b) with plane values (fa, fb), `cb_clip`'s step.
fn cb_edge1(c: ptr<function, CbChain>, a: vec3<f32>, fa: f32, b: vec3<f32>, fb: f32) {
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
        cb_in2(c, cb_lerp(pi, po, min(fi / (fi - fo), 1.0)));
    }
    if b_in {
        cb_in2(c, b);
    }
}

// A vertex into clip 1: the edge from the previous one ends here.
fn cb_in1(c: ptr<function, CbChain>, b: vec3<f32>) {
    let fb = b.x - prod((*c).k.x, b.z);
    if (*c).s[0].seen == 0u {
        (*c).s[0].first = b;
        (*c).s[0].f_first = fb;
    } else {
        cb_edge1(c, (*c).s[0].prev, (*c).s[0].f_prev, b, fb);
    }
    (*c).s[0].prev = b;
    (*c).s[0].f_prev = fb;
    (*c).s[0].seen += 1u;
}

// Clip 1's closing edge, from its last input to its first.
fn cb_close1(c: ptr<function, CbChain>) {
    if (*c).s[0].seen > 0u {
        cb_edge1(c, (*c).s[0].prev, (*c).s[0].f_prev, (*c).s[0].first, (*c).s[0].f_first);
    }
}

// `texel_bound`: (lo, hi, hit) of the face-local triangle in texel (x, y).
struct CbBound {
    lo: f32,
    hi: f32,
    hit: bool,
}

// The widened texel planes `(u min, u max, v min, v max)` of texel (x, y) with margin `m`.
fn cb_texel_k(x: u32, y: u32, size: u32, m: f32) -> vec4<f32> {
    return vec4<f32>(face_coord(x, size) - m, face_coord(x + 1u, size) + m, face_coord(y, size) - m, face_coord(y + 1u, size) + m);
}

// `texel_bound`'s whole-triangle bounds (a `whole` rect, or a clip that overflowed).
fn cb_whole_bound(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, w: vec3<f32>, e: f32) -> CbBound {
    let d_min = min(min(cb_dot(l0, w), cb_dot(l1, w)), cb_dot(l2, w));
    let r_max = max(max(sqrt(cb_dot(l0, l0)), sqrt(cb_dot(l1, l1))), sqrt(cb_dot(l2, l2)));
    let lo = d_min - e;
    return CbBound(select(0.0, lo, lo > 0.0), r_max + e, true);
}

// `texel_bound`'s clipped path: (lo, hi, hit) of the face-local triangle `l*` in texel (x, y)
// of a rect (not `whole`) with margin `m` and error budget `e`, by the four clips. The fast
// paths (`cf_texel_cone_edges`) run in the `texels` pass; only the texels they leave come here.
fn cb_clip_bound(l0: vec3<f32>, l1: vec3<f32>, l2: vec3<f32>, m: f32, e: f32, x: u32, y: u32, size: u32) -> CbBound {
    let w = cb_texel_centre_unit(x, y, size);
    let k = cb_texel_k(x, y, size, m);
    let none = CbStage(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, 0u);
    var c = CbChain(k, w, array<CbStage, 4>(none, none, none, none), 0u, f32_inf(), 0.0);
    cb_in1(&c, l0);
    cb_in1(&c, l1);
    cb_in1(&c, l2);
    cb_close1(&c);
    cb_close2(&c);
    cb_close3(&c);
    cb_close4(&c);
    let n = CB_MAX_POLY;
    if c.s[1].seen > n || c.s[2].seen > n || c.s[3].seen > n || c.count > n {
        return cb_whole_bound(l0, l1, l2, w, e);
    }
    if c.count == 0u {
        return CbBound(0.0, 0.0, false);
    }
    let lo = c.d_min - e;
    return CbBound(select(0.0, lo, lo > 0.0), c.r_max + e, true);
}

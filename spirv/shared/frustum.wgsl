// Where a ray segment crosses a cell's frustum, and the convexity bounds of r(t) = |a + t d|:
// the WGSL twin of `src/cubemap/frustum.rs` (read its module docs: face-local vectors, cells as
// texel rectangles [x0, x1) x [y0, y1), the half-open rule, `t0 < t1` for texels and the
// inflated superset for hierarchy cells).
//
// Bit-exactness with the CPU: every expression keeps the Rust twin's f32 operation order.
// Products that feed a sum go through `prod`, see there.
//! import shared/cube.wgsl

const SIDE_X0: u32 = 0u;
const SIDE_X1: u32 = 1u;
const SIDE_Y0: u32 = 2u;
const SIDE_Y1: u32 = 3u;
const SIDE_Z: u32 = 4u;
const SIDE_SEGMENT: u32 = 5u;

// Relative widening of hierarchy cell intervals (`CELL_INFLATE` = 2^-12 of the cell's own t
// scale, `inflated`).
const CELL_INFLATE: f32 = 0.000244140625;

// +inf and -inf from bits (WGSL has no infinity literal; naga folds these to the same bits).
const F32_INF_BITS: u32 = 0x7f800000u;
const F32_MAX: f32 = 3.40282347e+38;

fn f32_inf() -> f32 {
    return bitcast<f32>(F32_INF_BITS);
}

// Rust's `f32::is_finite`, on the bits (a compiler may assume `x == x`).
fn is_finite_f32(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// Rust's `f32::is_nan`, on the bits.
fn is_nan_f32(x: f32) -> bool {
    let b = bitcast<u32>(x);
    return ((b & 0x7f800000u) == 0x7f800000u) & ((b & 0x007fffffu) != 0u);
}

// A product that is then added to something, rounded on its own as the CPU does (Rust never
// contracts `a * b + c` into a fused multiply-add). Every such product in the tracer goes
// through here, so that this is the one place to change for a driver that contracts.
// Measured: lavapipe (Mesa 22.3.6, LLVM 15) never fuses; it lowers even an explicit WGSL `fma`
// to a multiply and an add (`tests/tracer/gpu_twin.rs` is bit-identical either way). naga emits no
// `NoContraction` decoration, and drivers for real GPUs may fuse `a * b + c`; the fix then is
// to round the product on its own here (e.g. multiply it by a 1.0 the compiler cannot see
// through, read from a uniform), and to check with `tests/tracer/gpu_twin.rs` on that GPU.
fn prod(a: f32, b: f32) -> f32 {
    return a * b;
}

// A rectangle of texels [x0, x1) x [y0, y1) of one face of size `size`.
struct CellRect {
    face: u32,
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
    size: u32,
}

fn cell_rect_face(face: u32, size: u32) -> CellRect {
    return CellRect(face, 0u, size, 0u, size, size);
}

fn cell_rect_texel(face: u32, x: u32, y: u32, size: u32) -> CellRect {
    return CellRect(face, x, x + 1u, y, y + 1u, size);
}

// The t range of a segment inside a frustum; `entry`/`exit`: the constraint that set t0/t1.
struct Interval {
    t0: f32,
    t1: f32,
    entry: u32,
    exit: u32,
}

fn interval_empty() -> Interval {
    return Interval(f32_inf(), -f32_inf(), SIDE_SEGMENT, SIDE_SEGMENT);
}

// Texel rule: crossed over a positive length.
fn crosses(iv: Interval) -> bool {
    return iv.t0 < iv.t1;
}

// `Interval::inflated`: `ok` false where the CPU returns `None`.
struct Inflated {
    ok: bool,
    lo: f32,
    hi: f32,
}

fn inflated(iv: Interval, t_lo: f32, t_hi: f32, reach: f32) -> Inflated {
    if !(iv.t0 <= F32_MAX && iv.t1 >= -F32_MAX) {
        return Inflated(false, 0.0, 0.0);
    }
    // The cell's own t scale (`Interval::inflated`): its far end te, in [t_lo, t_hi].
    let te = min(max(iv.t0, iv.t1), t_hi);
    let e = CELL_INFLATE * ((((te - t_lo) + abs(t_lo)) + abs(te)) + reach);
    let lo = max(iv.t0 - e, t_lo);
    let hi = min(iv.t1 + e, t_hi);
    return Inflated(lo <= hi, lo, hi);
}

// `cubemap::frustum::seg_reach`: |a|_1 / |d|_1, summed in x, y, z order.
fn seg_reach(a: vec3<f32>, d: vec3<f32>) -> f32 {
    return ((abs(a.x) + abs(a.y)) + abs(a.z)) / ((abs(d.x) + abs(d.y)) + abs(d.z));
}

// [t0, t1] of `la + t ld`, t in [t_lo, t_hi] (face-local), inside the frustum of `cell`.
fn cell_interval(la: vec3<f32>, ld: vec3<f32>, cell: CellRect, t_lo: f32, t_hi: f32) -> Interval {
    let n = cell.size;
    let inc = owned_sides(edge_inclusive_bits(cell.face), cell.x0, cell.x1, cell.y0, cell.y1, n);
    let f = vec4<f32>(face_coord(cell.x0, n), face_coord(cell.x1, n), face_coord(cell.y0, n), face_coord(cell.y1, n));
    return frustum_interval(la, ld, f, inc, t_lo, t_hi);
}

// Which sides x0, x1, y0, y1 of the cell [x0, x1) x [y0, y1) of a face of `n` texels (face edge
// bits `edge`, `edge_inclusive_bits`) belong to it: interior lower sides yes, interior upper
// sides no, face edges by the tie rule.
fn owned_sides(edge: u32, x0: u32, x1: u32, y0: u32, y1: u32, n: u32) -> vec4<bool> {
    return vec4<bool>(
        select(true, (edge & 1u) != 0u, x0 == 0u),
        select(false, (edge & 2u) != 0u, x1 == n),
        select(true, (edge & 4u) != 0u, y0 == 0u),
        select(false, (edge & 8u) != 0u, y1 == n),
    );
}

// `cell_interval` of the frustum with side planes at face coordinates `f` (x0, x1, y0, y1)
// owning the sides `inc` says (the caller computes both, e.g. once for several cells).
fn frustum_interval(la: vec3<f32>, ld: vec3<f32>, f: vec4<f32>, owned: vec4<bool>, t_lo: f32, t_hi: f32) -> Interval {
    let fx0 = f.x;
    let fx1 = f.y;
    let fy0 = f.z;
    let fy1 = f.w;
    // The five planes in order, written out (a loop over arrays would keep them in memory).
    var c = Clip(Interval(t_lo, t_hi, SIDE_SEGMENT, SIDE_SEGMENT), true);
    c = clip_plane(c, la.x - prod(fx0, la.z), ld.x - prod(fx0, ld.z), owned.x, 0u);
    c = clip_plane(c, prod(fx1, la.z) - la.x, prod(fx1, ld.z) - ld.x, owned.y, 1u);
    c = clip_plane(c, la.y - prod(fy0, la.z), ld.y - prod(fy0, ld.z), owned.z, 2u);
    c = clip_plane(c, prod(fy1, la.z) - la.y, prod(fy1, ld.z) - ld.y, owned.w, 3u);
    c = clip_plane(c, la.z, ld.z, false, 4u);
    if c.keep {
        return c.iv;
    }
    return interval_empty();
}

// `frustum_interval` without the exit side, for readers that take only the ends and the entry
// side: the same planes from the same operands in the same order, each by `clip_entry`;
// `interval_empty()`'s ends and entry where a plane drops the interval. The exit is
// SIDE_SEGMENT.
fn frustum_entry(la: vec3<f32>, ld: vec3<f32>, f: vec4<f32>, owned: vec4<bool>, t_lo: f32, t_hi: f32) -> Interval {
    var c = Entry(t_lo, t_hi, SIDE_SEGMENT, true);
    c = clip_entry(c, la.x - prod(f.x, la.z), ld.x - prod(f.x, ld.z), owned.x, SIDE_X0);
    c = clip_entry(c, prod(f.y, la.z) - la.x, prod(f.y, ld.z) - ld.x, owned.y, SIDE_X1);
    c = clip_entry(c, la.y - prod(f.z, la.z), ld.y - prod(f.z, ld.z), owned.z, SIDE_Y0);
    c = clip_entry(c, prod(f.w, la.z) - la.y, prod(f.w, ld.z) - ld.y, owned.w, SIDE_Y1);
    c = clip_entry(c, la.z, ld.z, false, SIDE_Z);
    return Interval(select(f32_inf(), c.t0, c.keep), select(-f32_inf(), c.t1, c.keep), select(SIDE_SEGMENT, c.entry, c.keep), SIDE_SEGMENT);
}

// An interval's ends and entry side being clipped, and whether every plane so far keeps it.
struct Entry {
    t0: f32,
    t1: f32,
    entry: u32,
    keep: bool,
}

// `clip_plane` without the exit side: its comparisons and selects on the same quotient (an
// entering plane, be > 0, raises t0 and sets the entry side where its bound is above t0, a
// leaving one, be < 0, lowers t1 where below). Its drop, `parallel & (al < 0 | (al == 0 & !inc)
// | is_nan(al))` with parallel = `!(be > 0) & !(be < 0)`, is `!(be > 0 | be < 0 | al > 0 | (al
// == 0 & inc))`: a NaN fails every comparison, and any other al is below, at or above 0.
fn clip_entry(c: Entry, al: f32, be: f32, inc: bool, k: u32) -> Entry {
    let b = -al / be;
    let pos = be > 0.0;
    let neg = be < 0.0;
    let enter = pos & (b > c.t0);
    let drop = !(pos | neg | (al > 0.0) | ((al == 0.0) & inc));
    return Entry(select(c.t0, b, enter), select(c.t1, b, neg & (b < c.t1)), select(c.entry, k, enter), c.keep & !drop);
}

// An interval being clipped by the planes `alpha + t beta >= 0` in turn.
struct Clip {
    iv: Interval,
    keep: bool,
}

// Plane k: `alpha + t beta >= 0` (`inc`: whether the plane itself belongs to the cell).
// Branch-free, with the outcome of testing `be > 0`, `be < 0` and the parallel case in turn
// (`cubemap::frustum`'s clip step): every comparison is false for a NaN, so a NaN `be` is the
// parallel case and a NaN bound moves neither end; the quotient is taken once, and where `be` is
// zero its value is not selected. `&` and `|`, not `&&` and `||`: naga lowers a short-circuit
// operator to a branch through a temporary.
fn clip_plane(c: Clip, al: f32, be: f32, inc: bool, k: u32) -> Clip {
    let b = -al / be;
    let enter = (be > 0.0) & (b > c.iv.t0);
    let exit = (be < 0.0) & (b < c.iv.t1);
    let parallel = !(be > 0.0) & !(be < 0.0);
    let drop = parallel & ((al < 0.0) | ((al == 0.0) & !inc) | is_nan_f32(al));
    let iv = Interval(select(c.iv.t0, b, enter), select(c.iv.t1, b, exit), select(c.iv.entry, k, enter), select(c.iv.exit, k, exit));
    return Clip(iv, c.keep & !drop);
}

// r(t) = |a + t d| on CMO-local vectors, summed in x, y, z order.
fn r_at(a: vec3<f32>, d: vec3<f32>, t: f32) -> f32 {
    let p = vec3<f32>(a.x + prod(t, d.x), a.y + prod(t, d.y), a.z + prod(t, d.z));
    return sqrt(prod(p.x, p.x) + prod(p.y, p.y) + prod(p.z, p.z));
}

// Closest approach of the line to the centre: t* = -(a.d)/(d.d).
fn closest_t(a: vec3<f32>, d: vec3<f32>) -> f32 {
    return -(prod(a.x, d.x) + prod(a.y, d.y) + prod(a.z, d.z))
        / (prod(d.x, d.x) + prod(d.y, d.y) + prod(d.z, d.z));
}

// (rmin, rmax) of r over [t0, t1] (max at an endpoint; min at an endpoint or at t* inside).
fn r_bounds(a: vec3<f32>, d: vec3<f32>, t0: f32, t1: f32) -> vec2<f32> {
    let r0 = r_at(a, d, t0);
    let r1 = r_at(a, d, t1);
    let ts = closest_t(a, d);
    var rmin = min(r0, r1);
    if ts > t0 && ts < t1 {
        rmin = min(min(r_at(a, d, ts), r0), r1);
    }
    return vec2<f32>(rmin, max(r0, r1));
}

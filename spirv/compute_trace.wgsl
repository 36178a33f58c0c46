// compute_trace: thesis alg. 3. Traces the rays `append` queued, each by a group of lanes of one
// subgroup, over the alternating 8x4/4x8 hierarchy (`hier32`), and writes `records[pixel]` for
// the composite pass. CPU twin: `cubetrace::cpu::alg3::trace_alg3` (the traversal, loop for
// loop) inside `cpu::multi::trace_cmos` (the occlusion handoff between CMOs).
//
// Lanes. `@workgroup_size(256)` (128 for the `_wg128` entry points), 1-D (naga rejects the subgroup builtins with a 2-D size). A ray
// owns `lanes = min(S, 32, cap)` lanes of one subgroup of size S (cap: 32 for `main`, 1 for
// `main_lanes1`); logical lane j in 0..32 (child j of the node being visited) lives on lane
// `j % lanes`, round `j / lanes`, so with lanes < 32 each lane tests 32 / lanes children and the
// 32-bit mask is assembled from 32 / lanes ballots; S / lanes rays share a subgroup (e.g. lanes
// 0..32 and 32..64 at S = 64), and each takes its bits of the ballot (`ray_bits`).
// With S = 32 and `main` this is the thesis's 8 rays x 32 lanes per workgroup. `main_wave` keeps
// one ray per lane (as `main_lanes1`) and spreads the crossed children of the subgroup's rays
// over its lanes (`wave_tests`).
//
// Per ray (every lane of a ray holds the same copy of the ray's state, computed redundantly):
// per CMO (handoff), per piece of the segment and per face crossed in order of t, a depth-first
// search. Visiting a node, lane j tests child j (the `t` interval from the frustum
// inequalities, then the range test `rmax < min`: skip, ALGORITHM.md fact 3; at the texel level
// "not entirely in front", `rmax >= D`); the ballot gives the candidate mask, kept per level
// with each lane's keys (the children's entry t). The first candidate along the ray (smallest
// key: a min over the ray's lanes by xor shuffles, then a ballot of the lanes holding it, lowest
// j) is removed from the mask and descended into; an empty mask backtracks to the parent. The
// first texel candidate is classified exactly as the fragment path does (`classify`), which
// ends the single-CMO trace; the CMOs are combined by `trace_ray`'s handoff. A hit is then
// verified against the captured triangle IDs (`verify_decision`, shared/trace_verified.wgsl, as
// `trace_ray_verified` does for the fragment path): the record gets the verified point, the
// triangle and the colour shaded there; a failed verification counts as behind at the texel's
// entry and the handoff goes on. Verification is per-ray work: it runs inside `if busy` blocks.
// The `_bounded` entry points classify with the `bounded` criterion instead
// (`classify_bounded_pick`, shared/trace_bounded.wgsl: the candidate lists, the ray leaving its
// G-buffer triangle `from_triangle`); a hit's triangle and barycentrics are its deciding texel's
// nearest candidate, kept in the ray state, and nothing is verified. `bounded` is a constant
// threaded down from the entry point (folded by the driver: the other entry points run none of
// it, though they bind the lists, as naga counts a binding used by any reachable function).
//
// Uniformity (reviewed; naga and lavapipe would not catch a mistake): there is NO workgroup
// barrier in this shader. Every subgroup operation (ballot, shuffle, any) sits in control flow
// that is uniform over the subgroup: the loops around them run until `subgroupAny` says that no
// ray of the subgroup has work left, their trip counts (`cells`, the shuffle offsets) depend on
// the subgroup size only, and a finished or absent ray keeps taking part with empty ballots.
// Everything per-ray is inside `if busy` blocks holding no subgroup operation.
//
// Invariants: no recursion; every loop has an explicit cap (`MAX_BATCHES`, `MAX_STEPS`, the
// handoff's `MAX_ROUNDS * cmo_count`; see there). Subgroup sizes 4..=128 (powers of two); the
// Rust side refuses others.
//! import shared/mirror.wgsl
//! import shared/compute_rays.wgsl
//! import shared/trace_verified.wgsl
//! import shared/trace_bounded.wgsl

// The scene's bind group (shared/scene.wgsl): groups 0..2 are the frame's, the CMOs' and this
// pass's own.
const SCENE_GROUP: u32 = 3u;

// Levels of a node stack: HIER_MAX_LEVELS (8) + the face on top.
const NODE_LEVELS: u32 = 9u;
// Children per lane with at least 4 lanes per ray (32 / 4): the keys of `main`.
const MAX_CELLS: u32 = 8u;
// Children per lane with 1 lane per ray (`main_lanes1`).
const MAX_CELLS_ONE: u32 = 32u;
// Steps one turn of the hot loop may run with one lane per ray (`trace_queued`): more than the
// 32 texels of a node, a backtrack per level and the face's end.
const MERGED_STEPS: u32 = 48u;
// Traversal steps of one subgroup over its rays. One step visits, descends into, classifies or
// leaves one node; a single-CMO trace takes fewer than 4 * (2 pieces * 4 faces) * (sum over
// levels of the cells a segment crosses, under 8 * N + 64) steps, about 2^21 for N = 4096, and a
// ray runs at most MAX_ROUNDS * 16 CMOs = 256 traces: 2^29 < 2^31. Never reached for the sizes
// `TraceConfig::new` accepts; a ray that reached it would be reported unresolved.
const MAX_STEPS: u32 = 0x80000000u;
// Batches of the grid-stride loop over the queue. `dispatch_args` launches ceil(n / h) groups
// with h = `rays_per_group` (4 to 256), and a group takes h rays per batch, so one batch is
// needed below the 65535-group cap, and at most 2^32 / (65535 * 4) < 2^15 above it (the retrace
// takes one batch per subgroup: fewer groups, same bound).
const MAX_BATCHES: u32 = 65536u;

@group(2) @binding(0) var<storage, read_write> ray_counter: RayCounter;
@group(2) @binding(1) var<storage, read> rays: array<AppendedRay>;
@group(2) @binding(2) var<storage, read> hier_config: HierConfig;
@group(2) @binding(3) var<storage, read> cmo_hier: array<vec2<f32>>;
// Per pixel: (texels tested, cells tested, descents, backtracks), summed over the ray's traces.
@group(2) @binding(4) var<storage, read_write> ray_stats: array<vec4<u32>>;
// Per CMO: the near-centre cut radius, computed once per frame by `dispatch_args`.
@group(2) @binding(5) var<storage, read> cmo_cut: array<f32>;
// The `bounded` criterion's gaps over the hierarchy (`cpu::bounded::Bounded::gap_hier`): a
// packed word per cell (shared/trace.wgsl's `unpack_gap`), laid out as `cmo_hier`; a one-word
// placeholder, never read, for the other criteria.
@group(2) @binding(7) var<storage, read> cmo_gap_hier: array<u32>;
// The cut queue: the queue indices of the rays the first dispatch cut (`ray_counter.cut` of
// them), which the retrace (mode 1) traces; a one-word placeholder, never written, for
// the thesis layout (no retrace).
@group(2) @binding(8) var<storage, read_write> cut_rays: array<u32>;

struct RayState {
    // The world ray.
    origin: vec3<f32>,
    dir: vec3<f32>,
    pixel: u32,
    // The triangle it leaves (the `bounded` criterion's start rule).
    from_tri: u32,
    // Handoff (`trace_ray`): current CMO, round, proven-empty prefix, traces run.
    k: u32,
    round: u32,
    progress: bool,
    t_done: f32,
    traces: u32,
    // The ray is done; `out` holds its result.
    finished: bool,
    out: TraceOut,
    // Sums over the ray's traces: texels, cells, descents, backtracks.
    sums: vec4<u32>,
    // The single-CMO trace (`cpu::alg3::RayState`).
    seg: Segment,
    pieces: Pieces,
    piece: u32,
    faces: FaceList,
    // The piece whose faces `faces` holds (0xffffffff: none yet).
    faces_piece: u32,
    face: u32,
    // `start_trace` ran for the current trace; `advance` moved past a face (`settle` enters
    // the next one).
    started: bool,
    next_face: bool,
    la: vec3<f32>,
    ld: vec3<f32>,
    // The face being searched and its piece's [lo, hi] (`faces.face[face]`,
    // `pieces.range[piece]`, cached by `enter_face`: read by every lane test).
    cur_face: u32,
    range: vec2<f32>,
    level: u32,
    node: array<vec2<u32>, NODE_LEVELS>,
    mask: array<u32, NODE_LEVELS>,
    need_mask: bool,
    trace_done: bool,
    result: TraceResult,
    // The verified hit (when `out` is a hit): triangle and barycentric weights.
    triangle: u32,
    bary: vec3<f32>,
    descents: u32,
    backtracks: u32,
    // Texels whose list the current trace walked (`classify_bounded_pick`'s budget).
    walks: u32,
}

fn hier_top() -> u32 {
    return hier_config.root + 1u;
}

// `(gx, gy)`: the children grid of a node at level `lvl` (the root level's size for the face).
fn child_grid(lvl: u32) -> vec2<u32> {
    if lvl == hier_top() {
        return hier_config.dims[lvl - 1u].yz;
    }
    return hier_config.shape[lvl].xy;
}

struct LaneTest {
    cand: bool,
    key: f32,
}

// What every lane test of one node reads: the node's level, children grid, child level's
// dims and span (loaded once per visit, not once per child).
struct NodeCtx {
    // Child level.
    cl: u32,
    // The child level's (offset, width, height, 0).
    cd: vec4<u32>,
    // Children grid of the node.
    g: vec2<u32>,
    // The node's cell.
    nd: vec2<u32>,
    // The child level's span in texels.
    span: vec2<u32>,
}

fn node_ctx(st: ptr<function, RayState>) -> NodeCtx {
    return node_ctx_at((*st).level, (*st).node[(*st).level]);
}

// The context of node `nd` at level `lvl` (the wave layout builds it for another lane's ray).
fn node_ctx_at(lvl: u32, nd: vec2<u32>) -> NodeCtx {
    let cl = lvl - 1u;
    return NodeCtx(cl, hier_config.dims[cl], child_grid(lvl), nd, hier_config.shape[cl].zw);
}

// What a lane test reads of its ray: the face-local ray, the piece's [lo, hi], the face, the
// CMO and the segment's ray (fields of `RayState`; the wave layout passes them between lanes).
struct TestRay {
    la: vec3<f32>,
    ld: vec3<f32>,
    range: vec2<f32>,
    face: u32,
    k: u32,
    a: vec3<f32>,
    d: vec3<f32>,
}

fn test_ray(st: ptr<function, RayState>) -> TestRay {
    return TestRay((*st).la, (*st).ld, (*st).range, (*st).cur_face, (*st).k, (*st).seg.a, (*st).seg.d);
}

// Test of child j of the ray's current node (`cpu::alg3::lane_test`).
fn lane_test(tr: TestRay, nc: NodeCtx, j: u32, bounded: bool) -> LaneTest {
    let none = LaneTest(false, f32_inf());
    let n = trace_config.size;
    let cl = nc.cl;
    let cd = nc.cd;
    let g = nc.g;
    if j >= g.x * g.y {
        return none;
    }
    let nd = nc.nd;
    let cx = nd.x * g.x + j % g.x;
    let cy = nd.y * g.y + j / g.x;
    if cx >= cd.y || cy >= cd.z {
        return none;
    }
    let range = tr.range;
    let face = tr.face;
    // One frustum interval for both kinds of child: at the texel level (cl = 0) the span is
    // 1 x 1 and cx < N, cy < N, so this is `cell_rect_texel(face, cx, cy, n)` field for field.
    let span = nc.span;
    let rect = CellRect(face, min(cx * span.x, n), min((cx + 1u) * span.x, n), min(cy * span.y, n), min((cy + 1u) * span.y, n), n);
    if rect.x0 >= rect.x1 || rect.y0 >= rect.y1 {
        return none;
    }
    let iv = cell_interval_entry(tr.la, tr.ld, rect, range.x, range.y);
    // Then one r_max over the range that counts, against the texel's distance or the cell's
    // least distance: `texel_not_in_front` (crossed, `r_max >= D`) at the texel level, else the
    // inflated interval and `r_bounds(..).y < min` (skip iff entirely in front; a NaN keeps the
    // cell, conservative). The same operations as calling those, in one place for both kinds.
    var ok = crosses(iv);
    var lo = iv.t0;
    var hi = iv.t1;
    var bound: f32;
    var cell = 0u;
    if cl == 0u {
        bound = distance_at(tr.k, Texel(face, cx, cy));
    } else {
        let inf = inflated(iv, range.x, range.y, seg_reach(tr.a, tr.d));
        ok = inf.ok;
        lo = inf.lo;
        hi = inf.hi;
        cell = tr.k * hier_config.hier_len + cd.x + (face * cd.z + cy) * cd.y + cx;
        bound = cmo_hier[cell].x;
    }
    if !ok {
        return none;
    }
    // The bounded criterion: a cell is skipped, too, where the ray lies inside its gap
    // (`r_bounds`' max is the r_max below, the same operations).
    if bounded && cl != 0u {
        let rb = r_bounds(tr.a, tr.d, lo, hi);
        let g = unpack_gap(cmo_gap_hier[cell]);
        let skip = rb.y < bound || (rb.x > g.y && rb.y < g.x);
        return LaneTest(!skip, iv.t0);
    }
    let r_max = max(r_at(tr.a, tr.d, lo), r_at(tr.a, tr.d, hi));
    return LaneTest(select(!(r_max < bound), r_max >= bound, cl == 0u), iv.t0);
}

// `cell_interval` without its exit side, which no reader here takes (`lane_test` reads the ends,
// `advance`'s texel classification the ends and the entry side): `frustum_entry`.
fn cell_interval_entry(la: vec3<f32>, ld: vec3<f32>, cell: CellRect, t_lo: f32, t_hi: f32) -> Interval {
    let n = cell.size;
    let inc = owned_sides(edge_inclusive_bits(cell.face), cell.x0, cell.x1, cell.y0, cell.y1, n);
    let f = vec4<f32>(face_coord(cell.x0, n), face_coord(cell.x1, n), face_coord(cell.y0, n), face_coord(cell.y1, n));
    return frustum_entry(la, ld, f, inc, t_lo, t_hi);
}

// The children of the ray's current node that pass `lane_test`'s interval test (all of its
// conditions but the range test), as bits j: with one ray per lane (`main_lanes1`, `main_wave`)
// `lane_test` runs on these alone.
// Exact, not an estimate: a child's `cell_interval` clips the piece's [lo, hi] by its column's
// planes (x0, x1), its row's (y0, y1) and the face's (z), and whatever the order, `clip_plane`
// leaves t0 = the largest entry bound and t1 = the smallest exit bound (comparisons skip a NaN
// bound in every order; +0 and -0 compare equal) and drops the interval where any plane does.
// So clipping [lo, hi] by each column's two planes and each row's two once, and combining them
// per child with max / min, gives every comparison of `lane_test` the same outcome: the long
// side's 8 slabs and the short side's 5 (below) and the face's plane per node instead of 5
// planes per child. A slab's upper plane is the next slab's lower one negated, so each plane is
// found once (`Bound`: 9 + 6 per node). The per-ray cost this saves:
// `benches/results/lavapipe-shaders.md`, "What was kept".
//
// `keys` (a constant: the wave layout): each crossed child's key, the entry t that `lane_test`
// would return (its interval's largest entry bound, here the pair's t0: the same bound values,
// so equal to it, up to the sign of a zero, which no comparison of the pick tells apart), is
// kept at `keys_one[level * MAX_CELLS_ONE + j]`, since the lane that tests the child may be
// another.
fn children_crossed(st: ptr<function, RayState>, nc: NodeCtx, keys: bool) -> u32 {
    let n = trace_config.size;
    let la = (*st).la;
    let ld = (*st).ld;
    let range = (*st).range;
    let edge = edge_inclusive_bits((*st).cur_face);
    let g = nc.g;
    let z = clip_entry(Entry(range.x, range.y, SIDE_SEGMENT, true), la.z, ld.z, false, SIDE_Z);
    // The grid's long side and its short side: at most 8 and 5 children (a node has at most 32
    // children and at most 8 on a side: 8x4 and 4x8 below the root, up to 5x5 at the root). So
    // 8 x 5 pairs cover every child, where 8 columns x 8 rows would take 64.
    let long_x = g.x >= g.y;
    let x = Axis(la.x, ld.x, nc.nd.x * g.x, g.x, nc.cd.y, nc.span.x, (edge & 1u) != 0u, (edge & 2u) != 0u);
    let y = Axis(la.y, ld.y, nc.nd.y * g.y, g.y, nc.cd.z, nc.span.y, (edge & 4u) != 0u, (edge & 8u) != 0u);
    let long = pick_axis(x, y, long_x);
    let short = pick_axis(y, x, long_x);
    // The short side's planes and slabs, written out (a loop would keep them in an array, read
    // lane by lane).
    let nf = f32(n);
    let b0 = bound(short, la.z, ld.z, n, nf, 0u);
    let b1 = bound(short, la.z, ld.z, n, nf, 1u);
    let b2 = bound(short, la.z, ld.z, n, nf, 2u);
    let b3 = bound(short, la.z, ld.z, n, nf, 3u);
    let b4 = bound(short, la.z, ld.z, n, nf, 4u);
    let b5 = bound(short, la.z, ld.z, n, nf, 5u);
    let s = array<Slab, 5>(
        dropped_above(slab_between(range, short, b0, b1, 0u)),
        dropped_above(slab_between(range, short, b1, b2, 1u)),
        dropped_above(slab_between(range, short, b2, b3, 2u)),
        dropped_above(slab_between(range, short, b3, b4, 3u)),
        dropped_above(slab_between(range, short, b4, b5, 4u)),
    );
    // Child (column cx, row cy) is bit cx + cy * g.x: a step along the long side moves the bit
    // by `dl`, along the short side by `ds`.
    let dl = select(g.x, 1u, long_x);
    let ds = select(1u, g.x, long_x);
    let p = PairCtx(range.x, range.y, abs(range.x), seg_reach((*st).seg.a, (*st).seg.d), nc.cl == 0u, (*st).level * MAX_CELLS_ONE);
    // The short side's slabs' bit offsets and bits (a slab past the grid's side, whose pairs
    // never pass, may wrap; a child's bit j is below 32).
    let o1 = ds;
    let o2 = 2u * ds;
    let o3 = 3u * ds;
    let o4 = 4u * ds;
    let r1 = 1u << (o1 & 31u);
    let r2 = 1u << (o2 & 31u);
    let r3 = 1u << (o3 & 31u);
    let r4 = 1u << (o4 & 31u);
    var bits = 0u;
    var lower = bound(long, la.z, ld.z, n, nf, 0u);
    for (var l = 0u; l < 8u; l++) {
        let upper = bound(long, la.z, ld.z, n, nf, l + 1u);
        let c = dropped_above(with_face(slab_between(range, long, lower, upper, l), z));
        lower = upper;
        // Column l's first bit: l * dl is at most 28.
        let j = l * dl;
        bits |= pair_keyed(c, s[0], p, keys, j, 1u, 0u);
        bits |= pair_keyed(c, s[1], p, keys, j, r1, o1);
        bits |= pair_keyed(c, s[2], p, keys, j, r2, o2);
        bits |= pair_keyed(c, s[3], p, keys, j, r3, o3);
        bits |= pair_keyed(c, s[4], p, keys, j, r4, o4);
    }
    return bits;
}

// One side of a node's children grid as `bound` reads it: the face-local ray's components on
// that axis, the node's first child index on it, the children on it, the level's size on it
// (the child exists below it), the span in texels, and whether the face owns its lower and its
// upper edge on this axis (`edge_inclusive_bits`, as `owned_sides` reads them).
struct Axis {
    a: f32,
    d: f32,
    first: u32,
    g: u32,
    size: u32,
    span: u32,
    own_lo: bool,
    own_hi: bool,
}

fn pick_axis(a: Axis, b: Axis, take_a: bool) -> Axis {
    if take_a {
        return a;
    }
    return b;
}

// The lower plane `al + t be >= 0` of column or row `i` on `ax` (`az`, `dz`: the face-local
// ray's z components), at texel k = min((first + i) span, n), as `clip_plane` reads it: its
// quotient `-al / be`, the signs of `be`, and whether the plane, where parallel, drops the
// interval as the slab's lower side (`drop_lower`, `cell_interval`'s side rule: owned unless
// it is the face's lower edge and the face does not own it) or as slab i - 1's upper side
// (`drop_upper`: that plane is (-al, -be), owned only where it is the face's upper edge and the
// face owns it).
// The upper side's own operands, f a_z - a and f d_z - d, are exactly -al and -be (IEEE
// rounding is symmetric; both are +0 where al or be is 0), so its quotient is this one up to the
// sign of a zero, its `be > 0` is `neg` here, its `be < 0` is `pos`, its parallel case and NaN
// are this plane's and its `al < 0` is `al > 0` here.
struct Bound {
    b: f32,
    pos: bool,
    neg: bool,
    drop_lower: bool,
    drop_upper: bool,
    k: u32,
}

fn bound(ax: Axis, az: f32, dz: f32, n: u32, nf: f32, i: u32) -> Bound {
    let k = min((ax.first + i) * ax.span, n);
    // `face_coord(k, n)`, with f32(n) as `nf`.
    let f = f32(2u * k) / nf - 1.0;
    let al = ax.a - prod(f, az);
    let be = ax.d - prod(f, dz);
    let pos = be > 0.0;
    let neg = be < 0.0;
    let zero = al == 0.0;
    // `owned_sides`: an interior lower side is owned, an interior upper side not, a face edge
    // as the face owns it.
    let inc_lower = (k != 0u) | ax.own_lo;
    let inc_upper = (k == n) & ax.own_hi;
    // `clip_plane`'s drop, `parallel & (al < 0 | (al == 0 & !inc) | is_nan(al))` with parallel
    // = `!(be > 0) & !(be < 0)`, is `!(be > 0 | be < 0 | al > 0 | (al == 0 & inc))`: a NaN
    // fails every comparison, and any other al is below, at or above 0.
    let drop_lower = !(pos | neg | (al > 0.0) | (zero & inc_lower));
    let drop_upper = !(pos | neg | (al < 0.0) | (zero & inc_upper));
    return Bound(-al / be, pos, neg, drop_lower, drop_upper, k);
}

// One column's or row's part of `children_crossed`: [t0, t1] clipped by its two planes, and
// whether the child range there exists and is kept.
struct Slab {
    t0: f32,
    t1: f32,
    ok: bool,
}

// Column or row `i` on `ax`, between its lower plane `lo` and the next one `hi`: the piece's
// `range` clipped by `lo` and then by `hi` negated, `clip_plane`'s comparisons and selects in
// its order (an entering plane raises t0 where its bound is above it, a leaving one lowers t1),
// kept where neither drops it, the child index is in the node and the level and the span is not
// empty (k0 < k1).
fn slab_between(range: vec2<f32>, ax: Axis, lo: Bound, hi: Bound, i: u32) -> Slab {
    let t0 = select(range.x, lo.b, lo.pos & (lo.b > range.x));
    let t1 = select(range.y, lo.b, lo.neg & (lo.b < range.y));
    let u0 = select(t0, hi.b, hi.neg & (hi.b > t0));
    let u1 = select(t1, hi.b, hi.pos & (hi.b < t1));
    let exists = (i < ax.g) & (ax.first + i < ax.size) & (lo.k < hi.k);
    return Slab(u0, u1, exists & !lo.drop_lower & !hi.drop_upper);
}

// The long side's slab `c` clipped by the face's plane `z` as well, once for its five pairs:
// the largest entry and smallest exit bound of the two, and kept where both are. The bounds are
// never NaN (`clip_entry` takes a bound only where it compares), so max and min give each pair's
// bounds the same values in this order as in any other.
fn with_face(c: Slab, z: Entry) -> Slab {
    return Slab(max(c.t0, z.t0), min(c.t1, z.t1), c.ok & z.keep);
}

// A slab whose child range does not exist or is dropped, or whose t0 is above F32_MAX or t1
// below -F32_MAX, with t0 = +inf. Each of its pairs' t0 is then +inf, which fails both of the
// pair's tests, as `ok` false did (`crosses`: +inf < t1 is false; `inflated`: a bound beyond
// F32_MAX is refused), so the pair test needs no `ok`, and `inflated`'s refusal (t0 above F32_MAX or t1
// below -F32_MAX, the pair's t0 being its slabs' larger t0 and its t1 their smaller t1) is the
// pair's t0 above F32_MAX.
fn dropped_above(c: Slab) -> Slab {
    let fine = c.ok & (c.t0 <= F32_MAX) & (c.t1 >= -F32_MAX);
    return Slab(select(f32_inf(), c.t0, fine), c.t1, fine);
}

// What each pair test of a node reads besides its two slabs: the piece's range, |range.x|, the
// segment's reach (`seg_reach`), whether the children are texels, and where the node's keys go
// in `keys_one` (level * MAX_CELLS_ONE).
struct PairCtx {
    lo: f32,
    hi: f32,
    abs_lo: f32,
    reach: f32,
    texel: bool,
    keys_at: u32,
}

// The child at (`col`, `row`; `col` clipped by the face's plane, `with_face`; both
// `dropped_above`), bit j = `first` + `off` (`row_bit` = 1 << off), where it passes: `crosses`
// at the texel level, `inflated` above; its key kept where `keys` (a constant) asks.
// `inflated`'s operations in its order, its refusal of a bound beyond F32_MAX folded into the
// outcome (the values it then skips are compared, never kept).
fn pair_keyed(col: Slab, row: Slab, p: PairCtx, keys: bool, first: u32, row_bit: u32, off: u32) -> u32 {
    let t0 = max(col.t0, row.t0);
    let t1 = min(col.t1, row.t1);
    let te = min(max(t0, t1), p.hi);
    let e = CELL_INFLATE * ((((te - p.lo) + p.abs_lo) + abs(te)) + p.reach);
    let inflated_ok = (t0 <= F32_MAX) & (max(t0 - e, p.lo) <= min(t1 + e, p.hi));
    let ok = select(inflated_ok, t0 < t1, p.texel);
    if keys && ok {
        keys_one[p.keys_at + first + off] = t0;
    }
    return select(0u, row_bit << first, ok);
}

// Sets up the search at the current (piece, face), advancing past exhausted ones; ends the
// single-CMO trace as escaped when none is left (`cpu::alg3::enter_face`). A piece's faces are
// found on its first visit (`faces_piece`), here only, so that `faces_crossed` (six frustum
// intervals) has one call site. At most 3 turns: piece 0, piece 1, none left.
fn enter_face(st: ptr<function, RayState>) {
    for (var turn = 0u; turn < 4u; turn++) {
        if (*st).piece >= (*st).pieces.count {
            (*st).trace_done = true;
            (*st).result = escaped((*st).seg, (*st).result.counters);
            return;
        }
        if (*st).faces_piece != (*st).piece {
            let r = (*st).pieces.range[(*st).piece];
            (*st).faces = faces_crossed((*st).seg, r.x, r.y, trace_config.size);
            (*st).faces_piece = (*st).piece;
            (*st).face = 0u;
        }
        if (*st).face < (*st).faces.count {
            let f = (*st).faces.face[(*st).face];
            (*st).cur_face = f;
            (*st).range = (*st).pieces.range[(*st).piece];
            (*st).la = to_face_local(f, (*st).seg.a);
            (*st).ld = to_face_local(f, (*st).seg.d);
            (*st).level = hier_top();
            (*st).node[(*st).level] = vec2<u32>(0u, 0u);
            (*st).need_mask = true;
            return;
        }
        (*st).piece += 1u;
    }
}

// Starts the single-CMO trace of CMO `k` over [t_done, t_hi] (`cpu::alg3::new_state`); the
// caller then enters its first face (`enter_face`).
fn start_trace(st: ptr<function, RayState>) {
    let k = (*st).k;
    let seg = Segment((*st).origin - cmo_centres[k].xyz, (*st).dir, (*st).t_done, frame.t_hi, (*st).from_tri);
    (*st).seg = seg;
    (*st).pieces = split_near_centre(seg, cmo_cut[k]);
    (*st).faces_piece = 0xffffffffu;
    (*st).piece = 0u;
    (*st).face = 0u;
    (*st).started = true;
    (*st).trace_done = false;
    (*st).need_mask = false;
    (*st).result.counters = Counters(0u, 0u);
    (*st).walks = 0u;
    (*st).descents = 0u;
    (*st).backtracks = 0u;
}

fn finish_ray(st: ptr<function, RayState>, status: u32, cmo: u32, point: vec3<f32>) {
    (*st).finished = true;
    (*st).out = trace_out(status, cmo, (*st).result, point, (*st).t_done, (*st).traces);
}

// The handoff after a single-CMO trace ended (`trace_ray`, one CMO step of its loops).
fn handoff(st: ptr<function, RayState>, bounded: bool) {
    let r = (*st).result;
    (*st).traces += 1u;
    (*st).sums += vec4<u32>(r.counters.texels, r.counters.cells, (*st).descents, (*st).backtracks);
    let k = (*st).k;
    var t_b = r.t;
    if bounded && r.status == ONE_HIT {
        // `advance` kept the deciding texel's nearest candidate.
        finish_ray(st, STATUS_HIT, k, bounded_point((*st).origin, (*st).dir, r.t));
        return;
    } else if r.status == ONE_HIT {
        let v = verify_decision(k, (*st).seg, r.texel, (*st).origin, (*st).dir, (*st).t_done, frame.t_hi);
        if v.hit.hit {
            (*st).triangle = v.hit.triangle;
            (*st).bary = v.hit.bary;
            finish_ray(st, STATUS_HIT, k, v.hit.position);
            return;
        }
        t_b = v.t_behind;
    } else if r.status == ONE_ESCAPED {
        finish_ray(st, STATUS_ESCAPED, k, r.point + cmo_centres[k].xyz);
        return;
    }
    if t_b > (*st).t_done {
        (*st).t_done = t_b;
        (*st).progress = true;
    }
    // A bounded trace that spent its walk budget ends the ray at its behind (`bounded_spent`).
    let spent = bounded && r.status == ONE_BEHIND && bounded_spent((*st).walks);
    (*st).k += 1u;
    if (*st).k >= trace_config.cmo_count || spent {
        (*st).round += 1u;
        if !(*st).progress || (*st).round >= MAX_ROUNDS || spent {
            let o = (*st).origin;
            let d = (*st).dir;
            let t = (*st).t_done;
            finish_ray(st, STATUS_UNRESOLVED, 0xffffffffu, vec3<f32>(o.x + prod(t, d.x), o.y + prod(t, d.y), o.z + prod(t, d.z)));
            return;
        }
        (*st).k = 0u;
        (*st).progress = false;
    }
}

// What `advance` left due, or the start: the handoff of a single-CMO trace that ended
// (`trace_done`), starting traces until one needs a traversal or the ray is finished (a trace
// can end at once: nothing left of the segment), and entering the next face (`advance` moved
// past a face). At most MAX_ROUNDS * cmo_count traces run in all. This is the only call site of
// `handoff`, `start_trace` and `enter_face` (the driver inlines every call, so each extra site
// would be another copy of the verification and the set-up to compile).
fn settle(st: ptr<function, RayState>, bounded: bool) {
    for (var i = 0u; i <= MAX_ROUNDS * trace_config.cmo_count + 1u; i++) {
        if (*st).trace_done {
            handoff(st, bounded);
            if (*st).finished {
                return;
            }
            (*st).started = false;
        }
        if !(*st).started {
            start_trace(st);
        }
        enter_face(st);
        if !(*st).trace_done {
            return;
        }
    }
}

// One traversal step once the node's mask is known (`cpu::alg3::advance`). A trace that ends
// here (`trace_done`) or a face left (`next_face`) is settled by `settle` at the top of the next
// step.
fn advance(st: ptr<function, RayState>, pick: u32, bounded: bool) {
    let top = hier_top();
    let lvl = (*st).level;
    if (*st).mask[lvl] == 0u {
        if lvl == top {
            // The next face: `settle` enters it (`enter_face`).
            (*st).face += 1u;
            (*st).next_face = true;
        } else {
            (*st).level += 1u;
            (*st).backtracks += 1u;
        }
        return;
    }
    (*st).mask[lvl] &= ~(1u << pick);
    let g = child_grid(lvl);
    let nd = (*st).node[lvl];
    let cx = nd.x * g.x + pick % g.x;
    let cy = nd.y * g.y + pick / g.x;
    if lvl == 1u {
        let range = (*st).range;
        let face = (*st).cur_face;
        let tex = Texel(face, cx, cy);
        let iv = cell_interval_entry((*st).la, (*st).ld, cell_rect_texel(face, cx, cy, trace_config.size), range.x, range.y);
        var o: Outcome;
        if bounded {
            // Through a local: naga 30 cannot pass a pointer to a field behind a pointer.
            var walks = (*st).walks;
            let b = classify_bounded_pick((*st).k, (*st).seg, tex, iv, &walks);
            (*st).walks = walks;
            o = b.o;
            (*st).triangle = b.pick.triangle;
            (*st).bary = b.pick.bary;
        } else {
            // Without `--strict`'s code: compute never runs it (`method::METHOD_OPTIONS` refuses
            // the flag, `ComputePath::new` a strict `TraceOptions`).
            o = classify_with((*st).k, (*st).seg, tex, iv, false);
        }
        if o.kind != 0u {
            (*st).trace_done = true;
            (*st).result = finish((*st).seg, tex, o, (*st).result.counters);
        }
        return;
    }
    (*st).level -= 1u;
    (*st).node[(*st).level] = vec2<u32>(cx, cy);
    (*st).need_mask = true;
    (*st).descents += 1u;
}

// The first candidate along the ray with one lane per ray: among the set bits of `m` at level
// `lvl`, in one pass in increasing j, a strictly smaller key, or the first key equal to +inf,
// takes it (none: firstTrailingBit(m); all NaN: the lowest candidate). The keys are in
// `keys_one` (every one-lane entry point is `big`).
fn pick_one(lvl: u32, m: u32, cells: u32) -> u32 {
    var pick = firstTrailingBit(m);
    var kmin = f32_inf();
    var found = false;
    var rest = m;
    for (var i = 0u; i < cells && rest != 0u; i++) {
        let c = firstTrailingBit(rest);
        rest &= rest - 1u;
        let key = keys_one[lvl * MAX_CELLS_ONE + c];
        if key < kmin || (!found && key == kmin) {
            kmin = key;
            pick = c;
            found = true;
        }
    }
    return pick;
}

// The 32 bits of one ray from a ballot: the ray whose lanes are `half * lanes ..` of the
// subgroup (`lanes` <= 32 divides 32, so they lie in one 32-bit word of the ballot).
fn ray_bits(b: vec4<u32>, half: u32, lanes: u32) -> u32 {
    let first = half * lanes;
    let bits = b[first / 32u] >> (first % 32u);
    if lanes < 32u {
        return bits & ((1u << lanes) - 1u);
    }
    return bits;
}

// This lane's keys (its children's entry t): level l, round c at l * MAX_CELLS + c (`main`,
// at least 4 lanes per ray), or at l * MAX_CELLS_ONE + c (`big`: `main_lanes1`, whose dispatches
// run with 1 lane per ray or, retracing, with the thesis layout). `big` is a constant per entry
// point: the driver keeps only the array its entry point uses, so `main` does not carry the
// large one.
var<private> keys_wide: array<f32, 72>;
var<private> keys_one: array<f32, 288>;

fn key_get(big: bool, lvl: u32, c: u32) -> f32 {
    if big {
        return keys_one[lvl * MAX_CELLS_ONE + c];
    }
    return keys_wide[lvl * MAX_CELLS + c];
}

fn key_set(big: bool, lvl: u32, c: u32, key: f32) {
    if big {
        keys_one[lvl * MAX_CELLS_ONE + c] = key;
    } else {
        keys_wide[lvl * MAX_CELLS + c] = key;
    }
}

// The wave layout's lane tests of one traversal step (`main_wave`: one ray per lane, as in
// `main_lanes1`, but a ray's crossed children are tested by whichever lanes are free). Item i of
// the subgroup's list is the crossed child of the ray on lane o with pre(o) <= i < pre(o) + n(o)
// (n: the lane's crossed children, pre: their exclusive prefix sum), in increasing j; round r
// tests items r S .. r S + S - 1, item i on lane i - r S, with its ray's `TestRay` and node
// shuffled from lane o (`wave_owner`: a binary search over pre). A round's candidate bits (1 << j)
// are OR-ed over each ray's lanes by a segmented scan and read back by the ray's lane. The rounds
// number ceil(sum n / S) where `main_lanes1` runs max n; the keys came from `children_crossed`.
// Called in subgroup-uniform control flow (the trip count and every shuffle are uniform).
// `crossed`: this lane's ray's crossed children (0 when it is not testing), `nc` its node.
fn wave_tests(st: ptr<function, RayState>, nc: NodeCtx, crossed: u32, sg_lane: u32, sg_size: u32, bounded: bool) -> u32 {
    let items = wave_items(crossed, sg_lane);
    let tr = test_ray(st);
    let lvl = (*st).level;
    var mask = 0u;
    for (var base = 0u; base < items.total; base += sg_size) {
        let it = wave_item(tr, lvl, nc.nd, crossed, items.pre, base + sg_lane, sg_size);
        var bit = 0u;
        if base + sg_lane < items.total {
            let t = lane_test(it.tr, it.nc, it.j, bounded);
            bit = select(0u, 1u << it.j, t.cand);
        }
        mask |= wave_collect(bit, max(it.first, base) - base, items.pre, items.n, base, sg_lane, sg_size);
    }
    return mask;
}

// This lane's crossed children `n`, their exclusive prefix sum over the subgroup `pre`, and the
// subgroup's total.
struct WaveItems {
    n: u32,
    pre: u32,
    total: u32,
}

fn wave_items(crossed: u32, sg_lane: u32) -> WaveItems {
    let n = countOneBits(crossed);
    var s = wave_sum_bit(n, 0u, sg_lane);
    s += wave_sum_bit(n, 1u, sg_lane);
    s += wave_sum_bit(n, 2u, sg_lane);
    s += wave_sum_bit(n, 3u, sg_lane);
    s += wave_sum_bit(n, 4u, sg_lane);
    s += wave_sum_bit(n, 5u, sg_lane);
    return WaveItems(n, s.x, s.y);
}

// Bit `b` of `n` (n <= 32: six bits) summed over the lanes below this one and over the subgroup,
// by one ballot. (`subgroupExclusiveAdd` / `subgroupAdd` would do it, but lavapipe 22.3 with its
// CPU caps limited to SSE4.1 crashes on a shader holding them at 256 and 512 bits.)
fn wave_sum_bit(n: u32, b: u32, sg_lane: u32) -> vec2<u32> {
    let m = subgroupBallot(((n >> b) & 1u) != 0u);
    let k = vec4<u32>(0u, 1u, 2u, 3u);
    let word = vec4<u32>(sg_lane / 32u);
    let below = select(vec4<u32>(0u), vec4<u32>(0xffffffffu), k < word) | select(vec4<u32>(0u), vec4<u32>((1u << (sg_lane % 32u)) - 1u), k == word);
    let c = countOneBits(m & below);
    let t = countOneBits(m);
    return vec2<u32>(c.x + c.y + c.z + c.w, t.x + t.y + t.z + t.w) << vec2<u32>(b);
}

// Item `i` of a round: its ray's test inputs and node, the child j, and the first item of its
// ray (`first`, the ray's `pre`).
struct WaveItem {
    tr: TestRay,
    nc: NodeCtx,
    j: u32,
    first: u32,
}

// Item `i`, fetched from the lane that owns it (`wave_owner`): every lane runs it, whether it has
// an item this round or not (the shuffles must be uniform).
fn wave_item(tr: TestRay, lvl: u32, nd: vec2<u32>, crossed: u32, pre: u32, i: u32, sg_size: u32) -> WaveItem {
    let o = wave_owner(pre, i, sg_size);
    let first = subgroupShuffle(pre, o);
    let j = nth_bit(subgroupShuffle(crossed, o), i - first);
    let other = TestRay(
        subgroupShuffle(tr.la, o), subgroupShuffle(tr.ld, o), subgroupShuffle(tr.range, o),
        subgroupShuffle(tr.face, o), subgroupShuffle(tr.k, o), subgroupShuffle(tr.a, o),
        subgroupShuffle(tr.d, o),
    );
    let nc = node_ctx_at(subgroupShuffle(lvl, o), subgroupShuffle(nd, o));
    return WaveItem(other, nc, j, first);
}

// The lane of the subgroup whose items hold item `i`: the last lane o with pre(o) <= i (the
// binary search over the non-decreasing exclusive sums; a lane without items shares its pre
// with the next, so the last such lane is the one that has items). Straight-line: one guarded
// step per power of two below the subgroup size (uniform), no loop.
fn wave_owner(pre: u32, i: u32, sg_size: u32) -> u32 {
    var o = wave_owner_step(pre, i, 0u, 64u, sg_size);
    o = wave_owner_step(pre, i, o, 32u, sg_size);
    o = wave_owner_step(pre, i, o, 16u, sg_size);
    o = wave_owner_step(pre, i, o, 8u, sg_size);
    o = wave_owner_step(pre, i, o, 4u, sg_size);
    o = wave_owner_step(pre, i, o, 2u, sg_size);
    return wave_owner_step(pre, i, o, 1u, sg_size);
}

fn wave_owner_step(pre: u32, i: u32, o: u32, step: u32, sg_size: u32) -> u32 {
    if step >= sg_size {
        return o;
    }
    let p = subgroupShuffle(pre, o + step);
    return select(o, o + step, p <= i);
}

// The position of the k-th (from 0) set bit of `m` (k < countOneBits(m)): five halvings,
// straight-line.
fn nth_bit(m: u32, k: u32) -> u32 {
    var p = nth_bit_step(vec3<u32>(m, k, 0u), 16u);
    p = nth_bit_step(p, 8u);
    p = nth_bit_step(p, 4u);
    p = nth_bit_step(p, 2u);
    return nth_bit_step(p, 1u).z;
}

// (bits left, rank left, position): past the low `w` bits where the rank lies above them.
fn nth_bit_step(p: vec3<u32>, w: u32) -> vec3<u32> {
    let c = countOneBits(p.x & ((1u << w) - 1u));
    if p.y >= c {
        return vec3<u32>(p.x >> w, p.y - c, p.z + w);
    }
    return p;
}

// One round's candidate bits for this lane's ray: the OR of `bit` over the lanes holding its
// items this round (a segmented inclusive scan: lane i's segment starts at lane `start`, its
// owner's first item of the round), read at the segment's last lane. `pre`, `n`: this lane's own
// items, which lie at lanes [max(pre, base), min(pre + n, base + S)) - base of the round.
fn wave_collect(bit: u32, start: u32, pre: u32, n: u32, base: u32, sg_lane: u32, sg_size: u32) -> u32 {
    var v = bit;
    v = wave_scan_step(v, start, 1u, sg_lane, sg_size);
    v = wave_scan_step(v, start, 2u, sg_lane, sg_size);
    v = wave_scan_step(v, start, 4u, sg_lane, sg_size);
    v = wave_scan_step(v, start, 8u, sg_lane, sg_size);
    v = wave_scan_step(v, start, 16u, sg_lane, sg_size);
    v = wave_scan_step(v, start, 32u, sg_lane, sg_size);
    v = wave_scan_step(v, start, 64u, sg_lane, sg_size);
    let lo = max(pre, base);
    let hi = min(pre + n, base + sg_size);
    let own = hi > lo;
    let got = subgroupShuffle(v, select(0u, hi - 1u - base, own));
    return select(0u, got, own);
}

fn wave_scan_step(v: u32, start: u32, d: u32, sg_lane: u32, sg_size: u32) -> u32 {
    if d >= sg_size {
        return v;
    }
    let u = subgroupShuffle(v, select(sg_lane - d, sg_lane, sg_lane < d));
    return select(v, v | u, sg_lane >= start + d);
}

// Traces queued ray `index` (absent when `valid` is false: the lanes still take part in the
// subgroup operations) and writes its record. Called in subgroup-uniform control flow.
// `queue_cut`: a ray the step loop leaves unfinished is appended to the cut queue (the first
// dispatch of `main_lanes1` and `main_wave`, which the retrace follows). `step_cap`: the step
// loop's cap, MAX_STEPS but where a test lowers it for the first dispatch (`HierConfig`).
fn trace_queued(valid: bool, index: u32, lane: u32, half: u32, lanes: u32, cells: u32, big: bool, bounded: bool, wave: bool, queue_cut: bool, step_cap: u32, sg_size: u32) {
    // One lane per ray (uniform over the dispatch).
    let one = lanes == 1u;
    var st: RayState;
    // Reflections before this ray (0 but in the rounds of `--bounces`): the record's `bounces`
    // is one more.
    var bounce = 0u;
    if valid {
        let q = rays[index];
        bounce = q.bounce;
        st.origin = q.origin;
        st.dir = q.dir;
        st.pixel = q.pixel;
        st.from_tri = q.from_triangle;
        st.t_done = 0.0;
        st.triangle = VERIFY_NO_TRIANGLE;
        st.result = TraceResult(ONE_ESCAPED, 0.0, Texel(0u, 0u, 0u), false, vec3<f32>(0.0), Counters(0u, 0u));
    }
    var busy = valid;
    // `settle` is due: the first trace, or the handoff of one that `advance` ended. Run at the
    // top of the next step rather than inside `advance` (so that it has one call site); the
    // loops run the same iterations as if it ran at the end of the step.
    var pending = valid;
    var step = 0u;
    loop {
        if step >= step_cap {
            break;
        }
        if pending {
            settle(&st, bounded);
            pending = false;
            busy = !st.finished;
        }
        if !subgroupAny(busy) {
            break;
        }
        // The steps until a ray of the subgroup has `settle` due: the hot loop, which leaves the
        // set-up, handoff and verification code out (lavapipe runs the body of a branch for all
        // lanes, masked, whether a lane takes it or not; spirv/README.md, "What lavapipe does").
        // The rays take the same steps as with `settle` inside: a ray that is not pending is left
        // alone by it, and none turns idle without being pending. Entered and left by the whole
        // subgroup (`subgroupAny`), so the ballots inside stay in uniform control flow.
        loop {
            // Lane tests of the node's children, one ballot per round. With one lane per ray (`one`)
            // the ray's 32 logical lanes are this lane's rounds (j = c), so its mask bits are its own
            // tests: no ballot, the loop ends where no lane tests, and only the candidates' keys are
            // kept (the others are never read). One call site of `lane_test` for these two layouts.
            let testing = busy && st.need_mask;
            var mask = 0u;
            var nc: NodeCtx;
            if testing {
                nc = node_ctx(&st);
            }
            // The rounds: with one lane per ray only the children `children_crossed` leaves (c
            // their j), in increasing j; with more, all `cells` of them, uniformly.
            var rest = 0xffffffffu;
            if one {
                rest = 0u;
                if testing {
                    rest = children_crossed(&st, nc, wave);
                }
            }
            if wave {
                // The crossed children of every ray of the subgroup, spread over its lanes (with
                // one lane per ray, `half` is the lane's index in the subgroup).
                mask = wave_tests(&st, nc, rest, half, sg_size, bounded);
                rest = 0u;
            }
            for (var i = 0u; i < cells && rest != 0u; i++) {
                var c = i;
                if one {
                    c = firstTrailingBit(rest);
                    rest &= rest - 1u;
                }
                var cand = false;
                if testing {
                    let t = lane_test(test_ray(&st), nc, lane + lanes * c, bounded);
                    cand = t.cand;
                    if cand || !one {
                        key_set(big, st.level, c, t.key);
                    }
                }
                if one {
                    mask |= select(0u, 1u, cand) << c;
                } else {
                    mask |= ray_bits(subgroupBallot(cand), half, lanes) << (lanes * c);
                }
            }
            if testing {
                let g = child_grid(st.level);
                if st.level == 1u {
                    st.result.counters.texels += g.x * g.y;
                } else {
                    st.result.counters.cells += g.x * g.y;
                }
                st.mask[st.level] = mask;
                st.need_mask = false;
            }
            // The first candidate along the ray: with one lane per ray `pick_one`, in the turn's
            // steps below; with more, the min key over the ray's lanes, then the lowest j holding
            // it (NaN keys never win; all NaN: the lowest candidate).
            let lvl = st.level;
            let m = select(0u, st.mask[lvl], busy);
            var pick = firstTrailingBit(m);
            if !one {
                var kmin = f32_inf();
                for (var c = 0u; c < cells; c++) {
                    let key = key_get(big, lvl, c);
                    if ((m >> (lane + lanes * c)) & 1u) != 0u && key < kmin {
                        kmin = key;
                    }
                }
                for (var off = lanes / 2u; off > 0u; off /= 2u) {
                    let other = subgroupShuffleXor(kmin, off);
                    if other < kmin {
                        kmin = other;
                    }
                }
                var eq = 0u;
                for (var c = 0u; c < cells; c++) {
                    let j = lane + lanes * c;
                    let holds = ((m >> j) & 1u) != 0u && key_get(big, lvl, c) == kmin;
                    eq |= ray_bits(subgroupBallot(holds), half, lanes) << (lanes * c);
                }
                if eq != 0u {
                    pick = firstTrailingBit(eq);
                }
            }
            if busy {
                st.next_face = false;
                // With one lane per ray the steps that test no node run on in this turn: a texel
                // candidate that did not decide the trace, a backtrack, and the parent's pick after
                // it, until a step descends (the next node's children are tested in the next
                // turn), ends the trace or leaves the face. The same steps in the same order as
                // one per turn (the pick is the one that turn would make, and a step that tests
                // nothing runs no subgroup operation), in fewer turns of the loop whose every turn
                // runs the node tests too (for all lanes on lavapipe, masked). At most 32 texels
                // of one node, a backtrack per level (`NODE_LEVELS`) and the face's end:
                // `MERGED_STEPS` is never reached (were it, the next turn would go on).
                for (var i = 0u; i < MERGED_STEPS; i++) {
                    if one {
                        pick = pick_one(st.level, st.mask[st.level], cells);
                    }
                    advance(&st, pick, bounded);
                    if !one || st.trace_done || st.next_face || st.need_mask {
                        break;
                    }
                }
                pending = st.trace_done || st.next_face;
            }
    
            step += 1u;
            if subgroupAny(pending) || step >= step_cap {
                break;
            }
        }
    }
    if valid && lane == 0u {
        var r = st.out;
        if !st.finished {
            // The step loop ended before the ray did: cut by the driver's loop limit (lavapipe:
            // 65535 loop iterations per invocation, all loops together; spirv/README.md, "Known
            // defect") or the step cap. Unresolved at the proven-empty prefix, flagged `cut`,
            // and queued for the retrace (mode 1) where there is one.
            let t = st.t_done;
            let p = vec3<f32>(st.origin.x + prod(t, st.dir.x), st.origin.y + prod(t, st.dir.y), st.origin.z + prod(t, st.dir.z));
            r = trace_out(STATUS_UNRESOLVED, 0xffffffffu, st.result, p, t, st.traces);
            if queue_cut {
                cut_rays[atomicAdd(&ray_counter.cut, 1u)] = index;
            }
        }
        var colour = frame.background;
        var triangle = VERIFY_NO_TRIANGLE;
        if r.status == STATUS_HIT {
            triangle = st.triangle;
            colour = hit_shade(st.triangle, st.bary.yz);
        }
        // A bounce round's ray keeps the pixel's `fallback` and `checked` flags and adds its
        // counters to the path's (as `bvh_trace` does for its rounds): its earlier rounds may
        // have been finished by the fallback, or changed by the reflector check (a ray the
        // retrace finishes counts its cut attempt too).
        var fallback = 0u;
        var checked = 0u;
        var sums = st.sums;
        if bounce > 0u {
            fallback = records[st.pixel].fallback;
            checked = records[st.pixel].checked;
            sums += ray_stats[st.pixel];
        }
        records[st.pixel] = PixelRecord(
            st.origin, r.status, st.dir, r.cmo, r.point, r.riser, colour,
            r.face, r.x, r.y, r.texels, r.cells, r.traces, r.t, r.t_done, triangle,
            select(0u, 1u, !st.finished), fallback, bounce + 1u, checked,
        );
        ray_stats[st.pixel] = sums;
    }
}

// Entry points: the same kernel with at most `lane_cap` lanes per ray. `main`: the thesis
// layout, min(S, 32) lanes per ray (`lane_cap` a constant, folded by the driver). `main_lanes1`:
// chosen for CPU devices (`vk::methods::compute::ray_lanes`), where the per-ray work every lane of a ray
// repeats costs in proportion to the lanes (spirv/README.md, "What lavapipe does"); its
// layout is read from `hier_config.mode`, so that one pipeline (one compile) serves both of its
// dispatches:
// - mode 0: 1 lane per ray (its 32 logical lanes in 32 rounds), S rays per subgroup;
// - mode 1: the thesis layout over the rays the first dispatch cut (the cut queue,
//   `cut_rays`): it retraces from scratch the rays that the driver's loop limit cut
//   (spirv/README.md, "Known defect"), one ray per subgroup (at S <= 32) with min(S, 32) lanes,
//   so with far fewer loop iterations per step. Dispatched (`retrace_args`, sized by
//   `dispatch_args`' `retrace_size` from the queue's length) with one batch per subgroup.
// The `_wg128` twins run 128-invocation workgroups, for subgroups of 4 (lavapipe's
// `maxComputeWorkgroupSubgroups` is 32: `vk::methods::compute::workgroup_size`).
// `hier_config.mode` 0 or 1 as above, `hier_config.step_cap` the first dispatch's cap (each
// dispatch binds its own copy of `hier_config`: a binding of its own for the mode would take
// the compute stage past lavapipe's 32 storage buffers with the `bounded` criterion's).

@compute @workgroup_size(256)
fn main(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 256u, 32u, false, false, false, false, MAX_STEPS);
}

@compute @workgroup_size(256)
fn main_lanes1(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    let retrace = hier_config.mode != 0u;
    let cap = select(hier_config.step_cap, MAX_STEPS, retrace);
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 256u, select(1u, 32u, retrace), retrace, true, false, false, cap);
}

@compute @workgroup_size(128)
fn main_wg128(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 128u, 32u, false, false, false, false, MAX_STEPS);
}

@compute @workgroup_size(128)
fn main_lanes1_wg128(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    let retrace = hier_config.mode != 0u;
    let cap = select(hier_config.step_cap, MAX_STEPS, retrace);
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 128u, select(1u, 32u, retrace), retrace, true, false, false, cap);
}

// The same four with the `bounded` criterion.
@compute @workgroup_size(256)
fn main_bounded(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 256u, 32u, false, false, true, false, MAX_STEPS);
}

@compute @workgroup_size(256)
fn main_lanes1_bounded(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    let retrace = hier_config.mode != 0u;
    let cap = select(hier_config.step_cap, MAX_STEPS, retrace);
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 256u, select(1u, 32u, retrace), retrace, true, true, false, cap);
}

@compute @workgroup_size(128)
fn main_wg128_bounded(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 128u, 32u, false, false, true, false, MAX_STEPS);
}

@compute @workgroup_size(128)
fn main_lanes1_wg128_bounded(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    let retrace = hier_config.mode != 0u;
    let cap = select(hier_config.step_cap, MAX_STEPS, retrace);
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 128u, select(1u, 32u, retrace), retrace, true, true, false, cap);
}

// `main_wave`: one ray per lane as `main_lanes1` (the same two dispatches, mode 1 the
// thesis layout's retrace), with the crossed children of the subgroup's rays spread over its
// lanes (`wave_tests`); the same four sizes and criteria.
@compute @workgroup_size(256)
fn main_wave(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    let retrace = hier_config.mode != 0u;
    let cap = select(hier_config.step_cap, MAX_STEPS, retrace);
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 256u, select(1u, 32u, retrace), retrace, true, false, true, cap);
}

@compute @workgroup_size(128)
fn main_wave_wg128(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    let retrace = hier_config.mode != 0u;
    let cap = select(hier_config.step_cap, MAX_STEPS, retrace);
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 128u, select(1u, 32u, retrace), retrace, true, false, true, cap);
}

@compute @workgroup_size(256)
fn main_wave_bounded(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    let retrace = hier_config.mode != 0u;
    let cap = select(hier_config.step_cap, MAX_STEPS, retrace);
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 256u, select(1u, 32u, retrace), retrace, true, true, true, cap);
}

@compute @workgroup_size(128)
fn main_wave_wg128_bounded(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_invocation_id) sg_lane: u32,
    @builtin(subgroup_id) sg_id: u32,
) {
    let retrace = hier_config.mode != 0u;
    let cap = select(hier_config.step_cap, MAX_STEPS, retrace);
    trace_all(wg, groups, sg_size, sg_lane, sg_id, 128u, select(1u, 32u, retrace), retrace, true, true, true, cap);
}

// `group_size`: the entry point's workgroup size (a constant); `big`: `main_lanes1`'s keys
// (`key_get`, a constant); `bounded`: the `bounded` criterion (a constant); `wave`: the wave
// layout's lane tests (`main_wave`, a constant).
fn trace_all(wg: vec3<u32>, groups: vec3<u32>, sg_size: u32, sg_lane: u32, sg_id: u32, group_size: u32, lane_cap: u32, retrace: bool, big: bool, bounded: bool, wave: bool, step_cap: u32) {
    let lanes = min(min(sg_size, 32u), lane_cap);
    if min(sg_size, 32u) < 4u {
        // Unsupported (refused on the Rust side); uniform over the whole dispatch.
        return;
    }
    let lane = sg_lane % lanes;
    let half = sg_lane / lanes;
    let cells = 32u / lanes;
    let rays_per_group = group_size / lanes;
    let slot = sg_id * (sg_size / lanes) + half;
    if sg_lane == 0u {
        atomicMax(&ray_counter.subgroup_max, sg_size);
        atomicMax(&ray_counter.subgroup_min_not, ~sg_size);
    }
    // The retrace runs over the cut queue.
    var count = atomicLoad(&ray_counter.count);
    if retrace {
        count = atomicLoad(&ray_counter.cut);
    }
    for (var batch = 0u; batch < MAX_BATCHES; batch++) {
        let i = (wg.x + batch * groups.x) * rays_per_group + slot;
        let valid = i < count;
        if !subgroupAny(valid) {
            break;
        }
        var index = i;
        if retrace && valid {
            index = cut_rays[i];
        }
        trace_queued(valid, index, lane, half, lanes, cells, big, bounded, wave && !retrace, big && !retrace, step_cap, sg_size);
    }
}

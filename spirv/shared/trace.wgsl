// The cubemap tracer: the WGSL twin of `src/cpu/` (mod.rs, walk.rs, mip.rs, approx.rs,
// multi.rs), loop for loop. Surface model, near-centre split, traversals and the occlusion
// handoff are documented in `src/cpu/mod.rs` and `src/cpu/multi.rs`; the options in
// `src/cpu/options.rs` (`TraceOptions`), whose GPU form is `TraceConfig` below.
//
// Entry: `trace_ray(origin, dir, t_lo, t_hi)` on a world-space ray, over the `cmo_count` CMOs,
// with any options; `trace_ray_variant(.., TRACE_EXACT_MIP)` carries only the centre criterion's
// mip march (its usual path), for options with `criterion` centre and `accel` set.
//
// Data (all passes that import this file bind the same @group(1)):
// - binding 0 `trace_config`: `TraceConfig` (Rust `cubetrace::vk::passes::cmo::TraceConfig`).
// - binding 1 `cmo_centres`: CMO k's centre in `.xyz` (w unused).
// - binding 2 `cmo_distance`: CMO k's texels at `k * 6 * N * N`, index `(face * N + y) * N + x`.
// - binding 3 `cmo_mip`: CMO k's 2x2 pyramid (levels 1..) at `k * mip_len`, `[min, max]`.
// - bindings 15, 16 `cmo_gap`, `cmo_gap_mip`: the `bounded` criterion's gaps
//   (`cpu::bounded::Bounded::gaps`), a word per cell packing `[g1, g0]` rounded inwards to
//   bfloat16 (`cubemap::bounds::pack_gap`): CMO k's texels at `k * 6 N N` (as `cmo_distance`),
//   their 2x2 pyramid at `k * mip_len` (as `cmo_mip`; a cell the min of `g1` and the max of
//   `g0`); placeholders, never read, for the other criteria (`gaps` false in `mip_turn`).
// Distances are `+inf` where nothing was captured and never NaN (WGSL's min/max leave NaN
// implementation-defined where Rust's ignore it). The near-centre radius `0.5 * min D` is
// computed here from the data (min over the top mip
// level, or over the texels when N = 1), as `CmoTracer::new` does on the CPU.
//
// Invariants: no recursion; every loop has an explicit cap (`MAX_ROUNDS`, `MAX_FACE_STEPS`,
// `MAX_TEXEL_SAMPLES`, `MAX_SAMPLE_STEPS`). `MAX_ROUNDS` and `MAX_TEXEL_SAMPLES` are the CPU's
// own caps; the other two are never reached for the sizes and step counts `TraceConfig::new`
// accepts (N <= 4096, steps <= 65536), so the CPU twin needs none.
//! import shared/frustum.wgsl

const TRACE_MIP_MAX_LEVELS: u32 = 16u;
// Rounds over the CMOs (`cpu::multi::MAX_ROUNDS`).
const MAX_ROUNDS: u32 = 16u;
// Samples of per-texel sampling (`cpu::approx::MAX_TEXEL_SAMPLES`).
const MAX_TEXEL_SAMPLES: u32 = 16384u;
// Steps (texels or skips) of one face walk. A piece crosses at most 2N + 2 texels of a face and
// each skip passes at least one, so at most 4N + 4 steps: never reached for N <= 4096, the
// largest size `TraceConfig::new` accepts.
const MAX_FACE_STEPS: u32 = 65536u;
// Cap on `steps` of constant-step/constant-angle sampling (`TraceConfig::new` refuses more).
const MAX_SAMPLE_STEPS: u32 = 65536u;

const CRITERION_CENTRE: u32 = 0u;
const CRITERION_THRESHOLD: u32 = 1u;
const CRITERION_SIGN_CHANGE: u32 = 2u;
// Sound per-texel bounds and candidate lists (shared/trace_bounded.wgsl; `trace_one` never
// sees it: the bounded entry points call `trace_ray_bounded`).
const CRITERION_BOUNDED: u32 = 3u;
const SAMPLING_CONSTANT_STEP: u32 = 0u;
const SAMPLING_CONSTANT_ANGLE: u32 = 1u;
const SAMPLING_PER_TEXEL: u32 = 2u;

// Which tracing code a caller carries. Always pass a constant: the driver inlines every call,
// folds the constant and drops the code of the other methods (specialisation by entry point).
// TRACE_ANY: every criterion, sampling and acceleration, chosen at run time by `trace_config`.
const TRACE_ANY: u32 = 0u;
// TRACE_EXACT_MIP: the centre criterion with the mip march only (`criterion` centre, `accel` 1,
// `strict` 0; the Rust side picks it only then: `vk::passes::cmo::exact_mip_only`).
const TRACE_EXACT_MIP: u32 = 1u;

const STATUS_HIT: u32 = 0u;
const STATUS_ESCAPED: u32 = 1u;
const STATUS_UNRESOLVED: u32 = 2u;
// Single-CMO status (CPU `Status`): hit, escaped, behind.
const ONE_HIT: u32 = 0u;
const ONE_ESCAPED: u32 = 1u;
const ONE_BEHIND: u32 = 2u;

// The tracer's options and the scene's CMO layout (Rust `TraceConfig`, layout checked there).
struct TraceConfig {
    // Number of CMOs K.
    cmo_count: u32,
    // Face size N (same for every CMO).
    size: u32,
    // 0 exact, 1 threshold, 2 sign change, 3 bounded.
    criterion: u32,
    // Approximate criteria only: 0 constant step, 1 constant angle, 2 per texel.
    sampling: u32,
    // Centre criterion only: 0 per-texel walk, 1 2x2 mip march.
    accel: u32,
    // Sample intervals of constant-step/constant-angle sampling (steps + 1 samples).
    steps: u32,
    // Threshold criterion's eps (world units).
    eps: f32,
    // k of the continuity rule.
    continuity_k: f32,
    // Pyramid levels above the texels (the top level's index; 0 when N = 1).
    mip_top: u32,
    // Cells per CMO in `cmo_mip` (`mip_len(N)`).
    mip_len: u32,
    // 1: patch hits count only when decisive (`decisive_patch_hit`); 0: every patch hit counts.
    strict: u32,
    pad1: u32,
    // Level l (1..=mip_top): (offset in cells, width, height, span in texels).
    mip_levels: array<vec4<u32>, 16>,
}

@group(1) @binding(0) var<storage, read> trace_config: TraceConfig;
@group(1) @binding(1) var<storage, read> cmo_centres: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> cmo_distance: array<f32>;
@group(1) @binding(3) var<storage, read> cmo_mip: array<vec2<f32>>;
@group(1) @binding(15) var<storage, read> cmo_gap: array<u32>;
@group(1) @binding(16) var<storage, read> cmo_gap_mip: array<u32>;

// What one world ray found over the CMOs (Rust `ProbeResult` has the same layout).
struct TraceOut {
    // 0 hit, 1 escaped, 2 unresolved.
    status: u32,
    // CMO that decided; 0xffffffff when unresolved.
    cmo: u32,
    // The deciding texel of the last single-CMO trace (0, 0, 0 when escaped).
    face: u32,
    x: u32,
    y: u32,
    // 1 for a hit on the riser between two patches.
    riser: u32,
    // Counters of the last single-CMO trace.
    texels: u32,
    cells: u32,
    // Single-CMO traces run.
    traces: u32,
    // The last single-CMO trace's t (hit t, t_hi when escaped, t_b when behind).
    t: f32,
    // Proven-empty prefix [t_lo, t_done].
    t_done: f32,
    pad0: u32,
    // World point: the hit (or escape) point, `origin + t_done dir` when unresolved.
    point: vec3<f32>,
    pad1: u32,
}

// A CMO-local ray segment a + t d, t in [t_lo, t_hi].
struct Segment {
    a: vec3<f32>,
    d: vec3<f32>,
    t_lo: f32,
    t_hi: f32,
    // The global triangle the ray leaves at t = 0 (TRACE_NO_TRIANGLE: none): the `bounded`
    // criterion's start rule (shared/trace_bounded.wgsl); the other criteria ignore it.
    from_tri: u32,
}

// No triangle (`Segment::from_tri`; Rust `Segment::from`, a word WGSL reserves).
const TRACE_NO_TRIANGLE: u32 = 0xffffffffu;

fn seg_at(seg: Segment, t: f32) -> vec3<f32> {
    return vec3<f32>(seg.a.x + prod(t, seg.d.x), seg.a.y + prod(t, seg.d.y), seg.a.z + prod(t, seg.d.z));
}

struct Counters {
    texels: u32,
    cells: u32,
}

// One ray against one CMO (CPU `TraceResult`).
struct TraceResult {
    status: u32,
    t: f32,
    texel: Texel,
    riser: bool,
    point: vec3<f32>,
    counters: Counters,
}

fn distance_at(k: u32, t: Texel) -> f32 {
    let n = trace_config.size;
    return cmo_distance[k * 6u * n * n + texel_index(t, n)];
}

// 0.5 * min D of CMO k (0 when no finite positive minimum), as `CmoTracer::new`.
fn cut_radius(k: u32) -> f32 {
    let n = trace_config.size;
    var m = f32_inf();
    let top = trace_config.mip_top;
    if top == 0u {
        for (var i = 0u; i < 6u * n * n; i++) {
            m = min(m, cmo_distance[k * 6u * n * n + i]);
        }
    } else {
        let lev = trace_config.mip_levels[top];
        for (var i = 0u; i < 6u * lev.y * lev.z; i++) {
            m = min(m, cmo_mip[k * trace_config.mip_len + lev.x + i].x);
        }
    }
    if is_finite_f32(m) && m > 0.0 {
        return 0.5 * m;
    }
    return 0.0;
}

// Up to two [lo, hi] pieces of a segment with r >= radius, in order.
struct Pieces {
    count: u32,
    range: array<vec2<f32>, 2>,
}

fn split_near_centre(seg: Segment, radius: f32) -> Pieces {
    var out = Pieces(0u, array<vec2<f32>, 2>(vec2<f32>(0.0), vec2<f32>(0.0)));
    let dd = prod(seg.d.x, seg.d.x) + prod(seg.d.y, seg.d.y) + prod(seg.d.z, seg.d.z);
    let ts = -(prod(seg.a.x, seg.d.x) + prod(seg.a.y, seg.d.y) + prod(seg.a.z, seg.d.z)) / dd;
    let q = seg_at(seg, ts);
    let q2 = prod(q.x, q.x) + prod(q.y, q.y) + prod(q.z, q.z);
    let r2 = radius * radius;
    var lo = array<f32, 2>(seg.t_lo, 0.0);
    var hi = array<f32, 2>(seg.t_hi, 0.0);
    var n = 1u;
    if q2 < r2 {
        let h = sqrt((r2 - q2) / dd);
        lo = array<f32, 2>(seg.t_lo, max(seg.t_lo, ts + h));
        hi = array<f32, 2>(min(seg.t_hi, ts - h), seg.t_hi);
        n = 2u;
    }
    for (var i = 0u; i < n; i++) {
        if lo[i] < hi[i] {
            out.range[out.count] = vec2<f32>(lo[i], hi[i]);
            out.count += 1u;
        }
    }
    return out;
}

// The faces a piece crosses, in order of entry t (ties: lower face index first), and the entry
// t of each (`cpu::FaceList`'s `iv[i].t0`, the only field the tracers read).
struct FaceList {
    count: u32,
    face: array<u32, 6>,
    t0: array<f32, 6>,
}

// A face's sort key: its entry t (+inf where the piece does not cross it) and its index.
struct FaceKey {
    t: f32,
    f: u32,
}

// One compare-exchange of the sorting network: `a` ends the one of the two that sorts first,
// by entry t, then by face index.
fn face_keys_order(a: ptr<function, FaceKey>, b: ptr<function, FaceKey>) {
    let x = *a;
    let y = *b;
    let swap = y.t < x.t || (y.t == x.t && y.f < x.f);
    *a = FaceKey(select(x.t, y.t, swap), select(x.f, y.f, swap));
    *b = FaceKey(select(y.t, x.t, swap), select(y.f, x.f, swap));
}

// The faces the piece [lo, hi] of `seg` crosses (`cpu::faces_crossed`): each face's interval
// (`face_interval`), then their order (`face_order`). The six intervals stay in a loop: written
// out, they cost the pipelines 40 to 500 ms more to create (this function is inlined at every
// call site), for no measurable gain per ray.
fn faces_crossed(seg: Segment, lo: f32, hi: f32, size: u32) -> FaceList {
    var t0: array<f32, FACE_COUNT>;
    for (var f = 0u; f < FACE_COUNT; f++) {
        let iv = face_interval(f, to_face_local(f, seg.a), to_face_local(f, seg.d), lo, hi);
        t0[f] = select(f32_inf(), iv.t0, crosses(iv));
    }
    return face_order(t0);
}

// The crossed faces in order of entry t `t0` (+inf for a face not crossed; `cpu::face_order`):
// what inserting the crossed faces in index order, each after the faces of no larger entry t,
// gives (the CPU's stable sort), which is the order of the keys (t0, face), all distinct, with
// the faces not crossed last (a crossed face's t0 is below its t1, so neither NaN nor +inf).
// The keys go through the optimal sorting network for six (12 compare-exchanges in 5 rounds,
// Knuth TAOCP vol. 3, 5.3.4), straight-line code on six registers: the insertion loop moved
// entries at a per-lane position, which lavapipe ran lane by lane, and the ranks that replaced it
// took 36 pairwise comparisons and 36 per-lane copies. `tests/tracer/face_order.rs` holds it to
// the CPU on every key tuple over four values, ties and +inf included.
fn face_order(t0: array<f32, FACE_COUNT>) -> FaceList {
    var k0 = FaceKey(t0[0], 0u);
    var k1 = FaceKey(t0[1], 1u);
    var k2 = FaceKey(t0[2], 2u);
    var k3 = FaceKey(t0[3], 3u);
    var k4 = FaceKey(t0[4], 4u);
    var k5 = FaceKey(t0[5], 5u);
    face_keys_order(&k0, &k5);
    face_keys_order(&k1, &k3);
    face_keys_order(&k2, &k4);
    face_keys_order(&k1, &k2);
    face_keys_order(&k3, &k4);
    face_keys_order(&k0, &k3);
    face_keys_order(&k2, &k5);
    face_keys_order(&k0, &k1);
    face_keys_order(&k2, &k3);
    face_keys_order(&k4, &k5);
    face_keys_order(&k1, &k2);
    face_keys_order(&k3, &k4);
    var fl: FaceList;
    fl.face = array<u32, 6>(k0.f, k1.f, k2.f, k3.f, k4.f, k5.f);
    fl.t0 = array<f32, 6>(k0.t, k1.t, k2.t, k3.t, k4.t, k5.t);
    let inf = f32_inf();
    fl.count = select(0u, 1u, k0.t < inf) + select(0u, 1u, k1.t < inf) + select(0u, 1u, k2.t < inf)
        + select(0u, 1u, k3.t < inf) + select(0u, 1u, k4.t < inf) + select(0u, 1u, k5.t < inf);
    return fl;
}

// `cell_interval` of a whole face (`cell_rect_face`), without the rectangle's arithmetic: its
// side planes at face coordinates -1 and 1 (`face_coord(0, n)` and `face_coord(n, n)`, exactly,
// for every size) and its edges owned as `edge_inclusive_bits` says (`owned_sides` of the whole
// face): the same operands in the same order, so the same bits. Its exit side is not kept
// (`frustum_entry`): `faces_crossed`, its one reader, takes t0 and whether the face is crossed.
fn face_interval(face: u32, la: vec3<f32>, ld: vec3<f32>, lo: f32, hi: f32) -> Interval {
    let e = edge_inclusive_bits(face);
    let owned = vec4<bool>((e & 1u) != 0u, (e & 2u) != 0u, (e & 4u) != 0u, (e & 8u) != 0u);
    return frustum_entry(la, ld, vec4<f32>(-1.0, 1.0, -1.0, 1.0), owned, lo, hi);
}

fn texel_interval(seg: Segment, t: Texel, size: u32, lo: f32, hi: f32) -> Interval {
    return cell_interval(to_face_local(t.face, seg.a), to_face_local(t.face, seg.d), cell_rect_texel(t.face, t.x, t.y, size), lo, hi);
}

// Crossed and not entirely in front (rmax >= D): a candidate.
fn texel_not_in_front(seg: Segment, iv: Interval, d: f32) -> bool {
    return crosses(iv) && max(r_at(seg.a, seg.d, iv.t0), r_at(seg.a, seg.d, iv.t1)) >= d;
}

// The continuity rule (`cpu::continuous`).
fn continuous(d_prev: f32, d: f32, chord: f32, k: f32) -> bool {
    return is_finite_f32(d_prev) && is_finite_f32(d) && abs(d_prev - d) <= k * max(d_prev, d) * chord;
}

// glam's `Vec3::normalize`: v * (1 / sqrt(v.v)).
fn normalize_glam(v: vec3<f32>) -> vec3<f32> {
    let rcp = 1.0 / sqrt(prod(v.x, v.x) + prod(v.y, v.y) + prod(v.z, v.z));
    return v * rcp;
}

// glam's `Vec3::length`.
fn length_glam(v: vec3<f32>) -> f32 {
    return sqrt(prod(v.x, v.x) + prod(v.y, v.y) + prod(v.z, v.z));
}

// Outcome of classifying a texel: kind 0 none (in front or not crossed), 1 hit, 2 behind.
struct Outcome {
    kind: u32,
    t: f32,
    riser: bool,
}

// `continuous` between `texel` (distance `d`) and its neighbour `nb` (`cpu::continuous_with`).
fn continuous_with(k: u32, texel: Texel, d: f32, nb: Texel) -> bool {
    let n = trace_config.size;
    let chord = length_glam(normalize_glam(texel_centre_dir(texel, n)) - normalize_glam(texel_centre_dir(nb, n)));
    return continuous(distance_at(k, nb), d, chord, trace_config.continuity_k);
}

// A patch hit at `t` counts only when decisive (`cpu::decisive_patch_hit`): the two side
// neighbours of the hit point's quadrant are continuous with the texel, and the ray reaches the
// largest of the three distances within the texel.
fn decisive_patch_hit(k: u32, seg: Segment, texel: Texel, iv: Interval, d: f32, t: f32) -> bool {
    let n = trace_config.size;
    let l = to_face_local(texel.face, seg_at(seg, t));
    let u = l.x / l.z;
    let v = l.y / l.z;
    let uc = f32(2u * texel.x + 1u) / f32(n) - 1.0;
    let vc = f32(2u * texel.y + 1u) / f32(n) - 1.0;
    let side_x = select(1u, 0u, u < uc);
    let side_y = select(3u, 2u, v < vc);
    let nx = neighbour_across(texel, side_x, n);
    let ny = neighbour_across(texel, side_y, n);
    if !continuous_with(k, texel, d, nx) || !continuous_with(k, texel, d, ny) {
        return false;
    }
    let d_hi = max(max(d, 0.5 * (d + distance_at(k, nx))), 0.5 * (d + distance_at(k, ny)));
    return max(r_at(seg.a, seg.d, iv.t0), r_at(seg.a, seg.d, iv.t1)) >= d_hi;
}

fn classify(k: u32, seg: Segment, texel: Texel, iv: Interval) -> Outcome {
    return classify_with(k, seg, texel, iv, true);
}

// `classify`; `strict_code` false (a constant) leaves `--strict` out: the production variant's
// code (`TRACE_EXACT_MIP`, picked only without `--strict`: `vk::passes::cmo::exact_mip_only`).
fn classify_with(k: u32, seg: Segment, texel: Texel, iv: Interval, strict_code: bool) -> Outcome {
    let d = distance_at(k, texel);
    if !texel_not_in_front(seg, iv, d) {
        return Outcome(0u, 0.0, false);
    }
    return classify_candidate(k, seg, texel, iv, d, strict_code);
}

// The outcome of a candidate texel (distance `d`, not entirely in front): a hit or behind, so
// the single-CMO trace's last texel. A function of its own so that the cost model counts it
// where a lane's texel is a candidate, not at every texel classified (`model::methods`'
// `decide` blocks).
fn classify_candidate(k: u32, seg: Segment, texel: Texel, iv: Interval, d: f32, strict_code: bool) -> Outcome {
    let n = trace_config.size;
    let r0 = r_at(seg.a, seg.d, iv.t0);
    if r0 <= d {
        // First root after t0 of |a + t d| = D: the larger root (r(t0) <= D, r convex).
        let dd = prod(seg.d.x, seg.d.x) + prod(seg.d.y, seg.d.y) + prod(seg.d.z, seg.d.z);
        let ts = -(prod(seg.a.x, seg.d.x) + prod(seg.a.y, seg.d.y) + prod(seg.a.z, seg.d.z)) / dd;
        let q = seg_at(seg, ts);
        let q2 = prod(q.x, q.x) + prod(q.y, q.y) + prod(q.z, q.z);
        let t = clamp_rust(ts + sqrt(max(prod(d, d) - q2, 0.0) / dd), iv.t0, iv.t1);
        if !strict_code || trace_config.strict == 0u || decisive_patch_hit(k, seg, texel, iv, d, t) {
            return Outcome(1u, t, false);
        }
        return Outcome(2u, iv.t0, false);
    }
    if iv.entry == SIDE_SEGMENT || iv.entry > SIDE_Y1 {
        return Outcome(2u, iv.t0, false);
    }
    let prev = neighbour_across(texel, iv.entry - SIDE_X0, n);
    if continuous_with(k, texel, d, prev) {
        return Outcome(1u, iv.t0, true);
    }
    return Outcome(2u, iv.t0, false);
}

fn finish(seg: Segment, texel: Texel, o: Outcome, c: Counters) -> TraceResult {
    var status = ONE_HIT;
    if o.kind == 2u {
        status = ONE_BEHIND;
    }
    return TraceResult(status, o.t, texel, o.riser, seg_at(seg, o.t), c);
}

fn escaped(seg: Segment, c: Counters) -> TraceResult {
    return TraceResult(ONE_ESCAPED, seg.t_hi, Texel(0u, 0u, 0u), false, seg_at(seg, seg.t_hi), c);
}

// A texel and its interval, or none (`found` false).
struct Located {
    found: bool,
    tex: Texel,
    iv: Interval,
}

// The 3x3 texel search of `locate`, `next_texel` and `mip_turn`, where the texel they try first
// is not certified (`texel_certified`): of the texels of `face` around (cx, cy)
// (with `ahead`, only the 8 neighbours on the ray's side of the centre, by the signs of `mx`,
// `my`), the one crossed with the smallest entry among those whose interval ends after `t`
// (the first in row order on ties).
//
// The neighbourhood's distinct planes are clipped once (`cpu::texel_search`, the same steps):
// each column's two x planes (3 columns), each row's two y planes (3 rows) and the face's z
// plane: 13 divisions where nine `frustum_interval`s took 45. Each candidate's interval is
// still `texel_interval`'s (`frustum_interval`'s), bit for bit:
// - `frustum_interval` clips [lo, hi] by the planes x0, x1, y0, y1, z in that order. Its
//   first two steps depend on the column alone: the column's `Clip` below is those two
//   `clip_plane` calls, on the same operands (`face_coord` of the same boundary, the same
//   face-local ray, the same `owned_sides` bits), so the same bits; the candidate continues
//   from it.
// - What `clip_plane` does with a plane (al, be, inc) to any interval depends on the plane
//   alone: it compares `b = -al / be` with t0 (be > 0: `b > t0` sets t0 and the entry side) or
//   with t1 (be < 0: `b < t1` sets t1 and the exit), or, where be is 0 or NaN, drops the
//   interval by the sign of al (and `inc`). `plane_bound` computes b once with the same f32
//   operations (PlaneBound: lo = b or -inf, hi = b or +inf, keep) and `apply_bound` makes the
//   same comparisons in the same plane order: `-inf > t0` and `+inf < t1` are false for every
//   t0, t1 (NaN included), so a bound a plane does not set changes nothing, as in
//   `clip_plane`; a NaN b fails its comparison in both. Nothing is reordered and no min/max is
//   taken, so ties (the earlier plane keeps the end, +0 against -0 included) and sides come
//   out as `clip_plane` makes them; `keep` is the conjunction of the same per-plane tests, and the interval is
//   `interval_empty()` where it is false, as `frustum_interval` returns.
// Measured on lavapipe: the pass's time per ray did not change beyond noise (probably its
// compiler already shared the planes the nine inlined copies have in common); the pipelines
// that carry the search compile faster (`render default`'s renderer set-up took 3.3-3.7 s
// before, 2.0-2.7 s after, on a loaded 2-core machine).
fn texel_search(seg: Segment, face: u32, cx: u32, cy: u32, ahead: bool, mx: f32, my: f32, t: f32, size: u32, lo: f32, hi: f32) -> Located {
    return texel_search_face(face_consts(seg, face), face, cx, cy, ahead, mx, my, t, size, lo, hi);
}

// What the texel tests on one face share: the face-local ray, the face's edge bits
// (`edge_inclusive_bits`) and its z plane (`plane_bound(la.z, ld.z, false)`), made once per
// face by the march (`mip_start`) and per call elsewhere: the same values either way.
struct FaceConsts {
    la: vec3<f32>,
    ld: vec3<f32>,
    edge: u32,
    z: PlaneBound,
}

fn face_consts(seg: Segment, face: u32) -> FaceConsts {
    let la = to_face_local(face, seg.a);
    let ld = to_face_local(face, seg.d);
    return FaceConsts(la, ld, edge_inclusive_bits(face), plane_bound(la.z, ld.z, false));
}

// `texel_search` on the face constants `f`.
fn texel_search_face(f: FaceConsts, face: u32, cx: u32, cy: u32, ahead: bool, mx: f32, my: f32, t: f32, size: u32, lo: f32, hi: f32) -> Located {
    let la = f.la;
    let ld = f.ld;
    let edge = f.edge;
    var q: TexelSearch;
    q.face = face;
    q.c = vec2<i32>(i32(cx), i32(cy));
    q.ahead = ahead;
    q.m = vec2<f32>(mx, my);
    q.t = t;
    q.size = size;
    let start = Clip(Interval(lo, hi, SIDE_SEGMENT, SIDE_SEGMENT), true);
    // Boundaries c - 1 .. c + 2 (the first is unused where c = 0: out of the face).
    let fx = vec4<f32>(face_coord(cx - 1u, size), face_coord(cx, size), face_coord(cx + 1u, size), face_coord(cx + 2u, size));
    let fy = vec4<f32>(face_coord(cy - 1u, size), face_coord(cy, size), face_coord(cy + 1u, size), face_coord(cy + 2u, size));
    // The columns and rows, written out (the offsets are constants in each copy).
    let c0 = search_column(start, la, ld, fx.x, fx.y, edge, cx - 1u, size);
    let c1 = search_column(start, la, ld, fx.y, fx.z, edge, cx, size);
    let c2 = search_column(start, la, ld, fx.z, fx.w, edge, cx + 1u, size);
    let r0 = search_row(la, ld, fy.x, fy.y, edge, cy - 1u, size);
    let r1 = search_row(la, ld, fy.y, fy.z, edge, cy, size);
    let r2 = search_row(la, ld, fy.z, fy.w, edge, cy + 1u, size);
    let z = f.z;
    var best = Located(false, Texel(0u, 0u, 0u), interval_empty());
    // Row order, written out.
    best = search_candidate(q, best, c0, r0, z, -1, -1);
    best = search_candidate(q, best, c1, r0, z, 0, -1);
    best = search_candidate(q, best, c2, r0, z, 1, -1);
    best = search_candidate(q, best, c0, r1, z, -1, 0);
    best = search_candidate(q, best, c1, r1, z, 0, 0);
    best = search_candidate(q, best, c2, r1, z, 1, 0);
    best = search_candidate(q, best, c0, r2, z, -1, 1);
    best = search_candidate(q, best, c1, r2, z, 0, 1);
    best = search_candidate(q, best, c2, r2, z, 1, 1);
    return best;
}

struct TexelSearch {
    face: u32,
    c: vec2<i32>,
    ahead: bool,
    m: vec2<f32>,
    t: f32,
    size: u32,
}

// What `clip_plane` does with one plane to any interval (`texel_search`): `lo` the entry bound
// it sets where it is larger than t0 (-inf: none), `hi` the exit bound where smaller than t1
// (+inf: none), `keep` false where it drops the interval.
struct PlaneBound {
    lo: f32,
    hi: f32,
    keep: bool,
}

// The plane `al + t be >= 0` (`inc`: whether the plane belongs to the cell), `clip_plane`'s
// operations and tests.
fn plane_bound(al: f32, be: f32, inc: bool) -> PlaneBound {
    var p = PlaneBound(-f32_inf(), f32_inf(), true);
    if be > 0.0 {
        p.lo = -al / be;
    } else if be < 0.0 {
        p.hi = -al / be;
    } else if al < 0.0 || (al == 0.0 && !inc) || is_nan_f32(al) {
        p.keep = false;
    }
    return p;
}

// `clip_plane(c, ..)` of the plane `p` (its side `k`), from `plane_bound`.
fn apply_bound(c: Clip, p: PlaneBound, k: u32) -> Clip {
    var out = c;
    if p.lo > out.iv.t0 {
        out.iv.t0 = p.lo;
        out.iv.entry = k;
    }
    if p.hi < out.iv.t1 {
        out.iv.t1 = p.hi;
        out.iv.exit = k;
    }
    out.keep = out.keep && p.keep;
    return out;
}

// Column x (sides at face coordinates f0, f1) of `texel_search`: `start` clipped by its x0 and
// x1 planes, `frustum_interval`'s first two steps (`owned_sides`' x bits; `edge`:
// `edge_inclusive_bits`).
fn search_column(start: Clip, la: vec3<f32>, ld: vec3<f32>, f0: f32, f1: f32, edge: u32, x: u32, n: u32) -> Clip {
    let c = clip_plane(start, la.x - prod(f0, la.z), ld.x - prod(f0, ld.z), select(true, (edge & 1u) != 0u, x == 0u), SIDE_X0);
    return clip_plane(c, prod(f1, la.z) - la.x, prod(f1, ld.z) - ld.x, select(false, (edge & 2u) != 0u, x + 1u == n), SIDE_X1);
}

// Row y's two planes (y0, y1) of `texel_search`, each clipped once.
struct RowBounds {
    y0: PlaneBound,
    y1: PlaneBound,
}

// Row y (sides at face coordinates f0, f1) of `texel_search`: `frustum_interval`'s y0 and y1
// planes (`owned_sides`' y bits).
fn search_row(la: vec3<f32>, ld: vec3<f32>, f0: f32, f1: f32, edge: u32, y: u32, n: u32) -> RowBounds {
    return RowBounds(
        plane_bound(la.y - prod(f0, la.z), ld.y - prod(f0, ld.z), select(true, (edge & 4u) != 0u, y == 0u)),
        plane_bound(prod(f1, la.z) - la.y, prod(f1, ld.z) - ld.y, select(false, (edge & 8u) != 0u, y + 1u == n)),
    );
}

// Candidate (c.x + dx, c.y + dy) of `texel_search` (its column `col`, row `row`, the face's z
// plane `z`): `best` or the candidate, whichever wins.
fn search_candidate(q: TexelSearch, best: Located, col: Clip, row: RowBounds, z: PlaneBound, dx: i32, dy: i32) -> Located {
    if q.ahead && ((dx == 0 && dy == 0) || f32(dx) * q.m.x < 0.0 || f32(dy) * q.m.y < 0.0) {
        return best;
    }
    let x = q.c.x + dx;
    let y = q.c.y + dy;
    let n = i32(q.size);
    if x < 0 || y < 0 || x >= n || y >= n {
        return best;
    }
    // `frustum_interval` of the texel: its column's x0, x1, then y0, y1, z.
    let c = apply_bound(apply_bound(apply_bound(col, row.y0, SIDE_Y0), row.y1, SIDE_Y1), z, SIDE_Z);
    var iv = interval_empty();
    if c.keep {
        iv = c.iv;
    }
    if crosses(iv) && iv.t1 > q.t && (!best.found || iv.t0 < best.iv.t0) {
        return Located(true, Texel(q.face, u32(x), u32(y)), iv);
    }
    return best;
}

// `cell_interval` with the face's z plane clipped once per face (`z`: `plane_bound(la.z, ld.z,
// false)`) and the face's edge bits given (`edge_inclusive_bits`): the same bits
// (`cubemap::frustum::cell_interval_face`; `apply_bound` of a plane's `PlaneBound` makes
// `clip_plane`'s comparisons, `texel_search`'s argument).
fn cell_interval_face(la: vec3<f32>, ld: vec3<f32>, cell: CellRect, edge: u32, z: PlaneBound, t_lo: f32, t_hi: f32) -> Interval {
    return clip_cell_face(la, ld, cell, edge, z, t_lo, t_hi);
}

// `cell_interval_face`'s steps. The cost model's `cell_test` block names `cell_interval_face`,
// and a function a block names is counted in that block only (`model::weights`), so the texel
// check (`texel_certified_face`) calls this one: each block counts its own call.
fn clip_cell_face(la: vec3<f32>, ld: vec3<f32>, cell: CellRect, edge: u32, z: PlaneBound, t_lo: f32, t_hi: f32) -> Interval {
    let n = cell.size;
    let inc = owned_sides(edge, cell.x0, cell.x1, cell.y0, cell.y1, n);
    let fx0 = face_coord(cell.x0, n);
    let fx1 = face_coord(cell.x1, n);
    let fy0 = face_coord(cell.y0, n);
    let fy1 = face_coord(cell.y1, n);
    var c = Clip(Interval(t_lo, t_hi, SIDE_SEGMENT, SIDE_SEGMENT), true);
    c = clip_plane(c, la.x - prod(fx0, la.z), ld.x - prod(fx0, ld.z), inc.x, SIDE_X0);
    c = clip_plane(c, prod(fx1, la.z) - la.x, prod(fx1, ld.z) - ld.x, inc.y, SIDE_X1);
    c = clip_plane(c, la.y - prod(fy0, la.z), ld.y - prod(fy0, ld.z), inc.z, SIDE_Y0);
    c = clip_plane(c, prod(fy1, la.z) - la.y, prod(fy1, ld.z) - ld.y, inc.w, SIDE_Y1);
    c = apply_bound(c, z, SIDE_Z);
    if c.keep {
        return c.iv;
    }
    return interval_empty();
}

// `r_bounds` from the ray's closest approach `closest` (t*, r(t*)), made once per face march
// (`mip_start`; `cubemap::frustum::r_bounds_from`): the same operations on the same operands.
fn r_bounds_from(a: vec3<f32>, d: vec3<f32>, closest: vec2<f32>, t0: f32, t1: f32) -> vec2<f32> {
    let r0 = r_at(a, d, t0);
    let r1 = r_at(a, d, t1);
    var rmin = min(r0, r1);
    if closest.x > t0 && closest.x < t1 {
        rmin = min(min(closest.y, r0), r1);
    }
    return vec2<f32>(rmin, max(r0, r1));
}

// The texel (x, y) of `face` around which `locate` searches for t: the one the point at t
// projects to, or the face's middle where the point is not in front of the face.
fn locate_centre(seg: Segment, face: u32, t: f32, size: u32) -> vec2<u32> {
    let l = to_face_local(face, seg_at(seg, t));
    var c = vec2<u32>(size / 2u, size / 2u);
    if l.z > 0.0 {
        c = vec2<u32>(st_to_texel_coord(0.5 * (l.x / l.z + 1.0), size), st_to_texel_coord(0.5 * (l.y / l.z + 1.0), size));
    }
    return c;
}

// `next_texel`'s direction of travel on the face: (mx, my), the signs that keep a neighbour.
fn travel_signs(seg: Segment, face: u32) -> vec2<f32> {
    let la = to_face_local(face, seg.a);
    let ld = to_face_local(face, seg.d);
    return vec2<f32>(prod(ld.x, la.z) - prod(la.x, ld.z), prod(ld.y, la.z) - prod(la.y, ld.z));
}

// The texel of `face` whose interval contains or follows t (`cpu::locate`).
fn locate(seg: Segment, face: u32, t: f32, size: u32, lo: f32, hi: f32) -> Located {
    let c = locate_centre(seg, face, t, size);
    let one = texel_certified(seg, face, c.x, c.y, t, size, lo, hi);
    if one.found {
        return one;
    }
    return texel_search(seg, face, c.x, c.y, false, 0.0, 0.0, t, size, lo, hi);
}

// `cpu::certified`: texel (x, y) of `face` with its interval, `found` where it is crossed with
// t0 <= t < t1. Then it is the answer of every texel search around it, and of an `ahead` search
// around a neighbour it is across a strict side of (`across_exit`); the proof is there.
fn texel_certified(seg: Segment, face: u32, x: u32, y: u32, t: f32, size: u32, lo: f32, hi: f32) -> Located {
    return texel_certified_face(seg, face_consts(seg, face), face, x, y, t, size, lo, hi);
}

// The certificate's bound on the ray (`cpu::certified`): every component of `a` and `d` below
// 2^126 in magnitude, tested on the bits (false for NaN, which a compiler may assume away in a
// compare).
fn certifiable(seg: Segment) -> bool {
    let limit = vec3<u32>(CERTIFIED_LIMIT_BITS);
    let mag = vec3<u32>(0x7fffffffu);
    return all((bitcast<vec3<u32>>(seg.a) & mag) < limit) && all((bitcast<vec3<u32>>(seg.d) & mag) < limit);
}

// `texel_certified` on the face constants `f` of `face` (made once per face by the march): the
// texel's interval by `clip_cell_face`, the same bits as `texel_interval`'s.
fn texel_certified_face(seg: Segment, f: FaceConsts, face: u32, x: u32, y: u32, t: f32, size: u32, lo: f32, hi: f32) -> Located {
    let iv = clip_cell_face(f.la, f.ld, cell_rect_texel(face, x, y, size), f.edge, f.z, lo, hi);
    return Located(certifiable(seg) && crosses(iv) && iv.t1 > t && iv.t0 <= t, Texel(face, x, y), iv);
}

// The bits of `cpu::CERTIFIED_LIMIT`, 2^126.
const CERTIFIED_LIMIT_BITS: u32 = 0x7e800000u;

// The texel across side `exit` of `cur` (`cpu::across_exit`): `ok` where it is on the face and
// the ray moves across that side strictly (`m`: `travel_signs`).
struct Across {
    ok: bool,
    x: u32,
    y: u32,
}

fn across_exit(cur: Texel, exit: u32, m: vec2<f32>, size: u32) -> Across {
    var d = vec2<i32>(0, 0);
    if exit == SIDE_X0 {
        d.x = -1;
    } else if exit == SIDE_X1 {
        d.x = 1;
    } else if exit == SIDE_Y0 {
        d.y = -1;
    } else if exit == SIDE_Y1 {
        d.y = 1;
    }
    let p = vec2<i32>(i32(cur.x), i32(cur.y)) + d;
    let n = i32(size);
    let strict = f32(d.x) * m.x > 0.0 || f32(d.y) * m.y > 0.0;
    return Across(strict && p.x >= 0 && p.y >= 0 && p.x < n && p.y < n, u32(max(p.x, 0)), u32(max(p.y, 0)));
}

// The next texel after `cur` within its face (`cpu::next_texel`): the texel across its exit
// side where its certificate holds, else the 3x3 search.
fn next_texel(seg: Segment, cur: Texel, iv: Interval, size: u32, lo: f32, hi: f32) -> Located {
    let m = travel_signs(seg, cur.face);
    let a = across_exit(cur, iv.exit, m, size);
    if a.ok {
        let one = texel_certified(seg, cur.face, a.x, a.y, iv.t1, size, lo, hi);
        if one.found {
            return one;
        }
    }
    return texel_search(seg, cur.face, cur.x, cur.y, true, m.x, m.y, iv.t1, size, lo, hi);
}

// Per-texel walk (`cpu::walk::trace_walk`).
fn trace_walk(k: u32, seg: Segment, cut: f32) -> TraceResult {
    let n = trace_config.size;
    var c = Counters(0u, 0u);
    let pieces = split_near_centre(seg, cut);
    for (var p = 0u; p < pieces.count; p++) {
        let lo = pieces.range[p].x;
        let hi = pieces.range[p].y;
        let faces = faces_crossed(seg, lo, hi, n);
        for (var f = 0u; f < faces.count; f++) {
            var cur = locate(seg, faces.face[f], faces.t0[f], n, lo, hi);
            for (var step = 0u; step < MAX_FACE_STEPS && cur.found; step++) {
                c.texels += 1u;
                let o = classify(k, seg, cur.tex, cur.iv);
                if o.kind != 0u {
                    return finish(seg, cur.tex, o, c);
                }
                cur = next_texel(seg, cur.tex, cur.iv, n, lo, hi);
            }
        }
    }
    return escaped(seg, c);
}

// [min, max] of cell (x, y) of pyramid level l (>= 1) on `face`, CMO k.
fn mip_get(k: u32, l: u32, face: u32, x: u32, y: u32) -> vec2<f32> {
    let lev = trace_config.mip_levels[l];
    return cmo_mip[k * trace_config.mip_len + lev.x + (face * lev.z + y) * lev.y + x];
}

// `[g1, g0]` of a packed gap word (`cubemap::bounds::unpack_gap`).
fn unpack_gap(w: u32) -> vec2<f32> {
    return vec2<f32>(bitcast<f32>(w & 0xffff0000u), bitcast<f32>(w << 16u));
}

// The gap `[g1, g0]` of cell (x, y) of gap level l (0: the texels) on `face`, CMO k.
fn gap_get(k: u32, l: u32, face: u32, x: u32, y: u32) -> vec2<f32> {
    let n = trace_config.size;
    if l == 0u {
        return unpack_gap(cmo_gap[k * 6u * n * n + (face * n + y) * n + x]);
    }
    let lev = trace_config.mip_levels[l];
    return unpack_gap(cmo_gap_mip[k * trace_config.mip_len + lev.x + (face * lev.z + y) * lev.y + x]);
}

// Whether distances `rb` (rmin, rmax) lie strictly inside the gap of that cell
// (`cpu::bounded::Bounded::in_gap`).
fn in_gap(k: u32, l: u32, face: u32, x: u32, y: u32, rb: vec2<f32>) -> bool {
    let g = gap_get(k, l, face, x, y);
    return rb.x > g.y && rb.y < g.x;
}

// Thesis alg. 2 over the 2x2 pyramid (`cpu::mip::trace_mip`), the same decisions in the same
// order, written for a CPU driver. Lavapipe runs a shader's lanes in lockstep: it executes the
// body of every branch for all lanes, masked (an `if` costs its body whether any lane takes it or
// not), and runs a loop until its last lane leaves (a loop body runs at least once). So the code
// inside the hottest loop is what every turn pays: here the inner loop holds only the cell tests
// (the pyramid, top down, around the current texel), and the texel search (`texel_search`:
// `locate` after a skip, `next_texel` after a classified texel) and the classification run once
// per turn of the outer loop, each from one place. (Written as the CPU twin's loops, with a
// `locate` inside the level loop, a turn paid a search per pyramid level.) `variant`
// (a constant) leaves `--strict` out of `TRACE_EXACT_MIP`.
//
// The march over one face is a stepper (`MipMarch`, `mip_start`, `mip_turn`, `mip_passed`) so
// that another criterion marches the same pyramid with its own classification
// (shared/trace_bounded.wgsl's `trace_mip_bounded`) without this file reaching its bindings
// (naga counts a binding used where any function reachable from the entry point reads it). Each
// caller's face loop runs one `mip_turn` (the search, the cell tests) per turn and classifies
// where it stops at a texel: the loop shape of the march before the split.
fn trace_mip(k: u32, seg: Segment, cut: f32, variant: u32) -> TraceResult {
    let n = trace_config.size;
    var c = Counters(0u, 0u);
    let pieces = split_near_centre(seg, cut);
    let reach = seg_reach(seg.a, seg.d);
    for (var p = 0u; p < pieces.count; p++) {
        let lo = pieces.range[p].x;
        let hi = pieces.range[p].y;
        let faces = faces_crossed(seg, lo, hi, n);
        for (var f = 0u; f < faces.count; f++) {
            var m: MipMarch;
            var checked: array<u32, TRACE_MIP_MAX_LEVELS>;
            mip_start(&m, seg, faces.face[f], faces.t0[f]);
            loop {
                let turn = mip_turn(k, seg, &m, &checked, lo, hi, reach, &c, false);
                if turn == MIP_DONE {
                    break;
                }
                if turn == MIP_TEXEL {
                    c.texels += 1u;
                    let o = classify_with(k, seg, m.cur.tex, m.cur.iv, variant != TRACE_EXACT_MIP);
                    if o.kind != 0u {
                        return finish(seg, m.cur.tex, o, c);
                    }
                    mip_passed(&m);
                }
            }
        }
    }
    return escaped(seg, c);
}

// What `mip_turn` did: stopped at texel `cur` (the caller classifies it, then `mip_passed`
// where it decided nothing), skipped a cell, or ended the face.
const MIP_TEXEL: u32 = 0u;
const MIP_SKIPPED: u32 = 1u;
const MIP_DONE: u32 = 2u;

// The pyramid march over one face of one piece between turns.
struct MipMarch {
    face: u32,
    // The face's constants (the face-local ray, edge bits, z plane), `next_texel`'s signs of
    // travel and the ray's closest approach to the centre (t*, r(t*)), for the texel and cell
    // tests.
    f: FaceConsts,
    signs: vec2<f32>,
    closest: vec2<f32>,
    // Bit l: the caller's `checked[l]` was written (none before); `checked[l]` is the level-l
    // cell last found not skippable, packed `x | y << 16` (cells are under 2^11 for
    // N <= TRACE_MAX_SIZE). Lavapipe keeps an array indexed by a variable in memory and reads
    // it lane by lane (hence an array of its own: the rest of this state can stay in
    // registers), so the level scan works on bit masks instead: bit l of `valid` says
    // checked[l] is the cell around `vtex` at level l, and is recomputed from the array only
    // for the levels whose cell changed when the texel does.
    written: u32,
    valid: u32,
    vtex: vec2<u32>,
    // The cell skipped last (level, x, y), which the located texel may still touch.
    last_skip: vec3<u32>,
    // The side the search due after a skip starts across (`cpu::locate_after_skip`; SIDE_Z
    // or above: none, `locate`) and the skipped cell's rect (x0, x1, y0, y1).
    across: u32,
    skip_rect: vec4<u32>,
    // The search due at the top of the next turn: `locate` at `search_t` (ahead false) or
    // `next_texel` after `cur` (ahead true, search_t its exit).
    search: bool,
    ahead: bool,
    search_t: f32,
    // The current texel and its interval.
    cur: Located,
    // Steps as the CPU counts them: texels classified and cells skipped.
    step: u32,
}

// The march over `face` from `t0` (the face's entry), with a new `checked` array beside it.
fn mip_start(m: ptr<function, MipMarch>, seg: Segment, face: u32, t0: f32) {
    let none = 0xffffffffu;
    (*m).face = face;
    (*m).f = face_consts(seg, face);
    (*m).signs = travel_signs(seg, face);
    let ts = closest_t(seg.a, seg.d);
    (*m).closest = vec2<f32>(ts, r_at(seg.a, seg.d, ts));
    (*m).written = 0u;
    (*m).valid = 0u;
    (*m).vtex = vec2<u32>(0u, 0u);
    (*m).last_skip = vec3<u32>(none, none, none);
    (*m).across = SIDE_SEGMENT;
    (*m).skip_rect = vec4<u32>(0u, 0u, 0u, 0u);
    (*m).search = true;
    (*m).ahead = false;
    (*m).search_t = t0;
    (*m).cur = Located(false, Texel(0u, 0u, 0u), interval_empty());
    (*m).step = 0u;
}

// After a texel that decided nothing: `next_texel` after it at the next turn.
fn mip_passed(m: ptr<function, MipMarch>) {
    (*m).search = true;
    (*m).ahead = true;
    (*m).search_t = (*m).cur.iv.t1;
    (*m).step += 1u;
}

// One turn of the march over piece [lo, hi] (`reach`: `seg_reach`): the search due, then the
// cell tests around the texel found, top down, until one skips (MIP_SKIPPED: the search after
// the cell is due) or every level is checked (MIP_TEXEL: `cur` is the next texel to classify);
// MIP_DONE where the face has no texel left (or at MAX_FACE_STEPS). `c.cells` counts the cells
// tested (each a turn of the inner loop). One exit: no early return in the hot loop.
fn mip_turn(k: u32, seg: Segment, m: ptr<function, MipMarch>, checked: ptr<function, array<u32, TRACE_MIP_MAX_LEVELS>>, lo: f32, hi: f32, reach: f32, c: ptr<function, Counters>, gaps: bool) -> u32 {
    let n = trace_config.size;
    let top = trace_config.mip_top;
    let face = (*m).face;
    var turn = MIP_DONE;
    if (*m).step < MAX_FACE_STEPS {
        if (*m).search {
            // The search due: one texel tried first, its certificate (`texel_certified`), then
            // the 3x3 search where it does not hold (`cpu::locate_counted`,
            // `cpu::locate_after_skip`, `cpu::next_texel_counted`).
            let t = (*m).search_t;
            let fc = (*m).f;
            var centre = vec2<u32>((*m).cur.tex.x, (*m).cur.tex.y);
            var first = centre;
            var tried = true;
            var face_done = false;
            if (*m).ahead {
                let a = across_exit((*m).cur.tex, (*m).cur.iv.exit, (*m).signs, n);
                first = vec2<u32>(a.x, a.y);
                tried = a.ok;
            } else {
                centre = locate_centre(seg, face, t, n);
                let r = (*m).skip_rect;
                let side = (*m).across;
                // After a skip through a side: the texel across it, at p(t)'s other coordinate
                // clamped into the cell; none past the face's edge.
                var p = vec2<i32>(i32(centre.x), i32(centre.y));
                if side == SIDE_X0 || side == SIDE_X1 {
                    p = vec2<i32>(select(i32(r.y), i32(r.x) - 1, side == SIDE_X0), i32(clamp(centre.y, r.z, r.w - 1u)));
                } else if side == SIDE_Y0 || side == SIDE_Y1 {
                    p = vec2<i32>(i32(clamp(centre.x, r.x, r.y - 1u)), select(i32(r.w), i32(r.z) - 1, side == SIDE_Y0));
                }
                face_done = p.x < 0 || p.y < 0 || p.x >= i32(n) || p.y >= i32(n);
                centre = vec2<u32>(u32(max(p.x, 0)), u32(max(p.y, 0)));
                first = centre;
                tried = !face_done;
            }
            var found = Located(false, Texel(0u, 0u, 0u), interval_empty());
            if tried {
                found = texel_certified_face(seg, fc, face, first.x, first.y, t, n, lo, hi);
            }
            if !found.found && !face_done {
                found = texel_search_face(fc, face, centre.x, centre.y, (*m).ahead, (*m).signs.x, (*m).signs.y, t, n, lo, hi);
            }
            (*m).cur = found;
            (*m).search = false;
        }
        // Without a search, `cur` is the texel the last one found.
        if (*m).cur.found {
            turn = MIP_TEXEL;
            let tex = (*m).cur.tex;
            let iv = (*m).cur.iv;
            // The level-l cells around `tex` and `vtex` differ exactly for l <= the highest
            // bit in which their coordinates differ.
            let diff = (tex.x ^ (*m).vtex.x) | (tex.y ^ (*m).vtex.y);
            if diff != 0u {
                let moved = min(firstLeadingBit(diff), top);
                var valid = (*m).valid & ~((2u << moved) - 1u);
                for (var l = 1u; l <= moved; l++) {
                    if (((*m).written >> l) & 1u) != 0u && (*checked)[l] == ((tex.x >> l) | ((tex.y >> l) << 16u)) {
                        valid |= 1u << l;
                    }
                }
                (*m).valid = valid;
                (*m).vtex = vec2<u32>(tex.x, tex.y);
            }
            // Bits 1..=top: the pyramid's levels.
            let levels = ((2u << top) - 1u) & ~1u;
            // The cell tests around `tex`, top down, until one skips or every level is
            // checked: the hot loop, kept small.
            loop {
                // The highest level whose cell around `tex` is not checked yet.
                let todo = levels & ~(*m).valid;
                if todo == 0u {
                    break;
                }
                let level = firstLeadingBit(todo);
                let cell = vec2<u32>(tex.x >> level, tex.y >> level);
                (*c).cells += 1u;
                let span = 1u << level;
                let rect = CellRect(face, min(cell.x * span, n), min((cell.x + 1u) * span, n), min(cell.y * span, n), min((cell.y + 1u) * span, n), n);
                let civ = cell_interval_face((*m).f.la, (*m).f.ld, rect, (*m).f.edge, (*m).f.z, lo, hi);
                let inf = inflated(civ, lo, hi, reach);
                var skip = false;
                if inf.ok && any((*m).last_skip != vec3<u32>(level, cell.x, cell.y)) {
                    let rb = r_bounds_from(seg.a, seg.d, (*m).closest, inf.lo, inf.hi);
                    skip = rb.y < mip_get(k, level, face, cell.x, cell.y).x;
                    if gaps && !skip {
                        skip = in_gap(k, level, face, cell.x, cell.y, rb);
                    }
                }
                if skip {
                    (*m).last_skip = vec3<u32>(level, cell.x, cell.y);
                    var t_exit = iv.t1;
                    if crosses(civ) {
                        t_exit = civ.t1;
                    }
                    (*m).search_t = max(t_exit, iv.t1);
                    (*m).across = SIDE_SEGMENT;
                    if crosses(civ) && civ.t1 == (*m).search_t && civ.exit < SIDE_Z {
                        (*m).across = civ.exit;
                        (*m).skip_rect = vec4<u32>(rect.x0, rect.x1, rect.y0, rect.y1);
                    }
                    (*m).search = true;
                    (*m).ahead = false;
                    (*m).step += 1u;
                    turn = MIP_SKIPPED;
                    break;
                }
                (*checked)[level] = cell.x | (cell.y << 16u);
                (*m).written |= 1u << level;
                (*m).valid |= 1u << level;
            }
        }
    }
    return turn;
}

// One sample of an approximate criterion (`cpu::approx::sample`); `hit` set on a hit.
struct SampleState {
    prev: f32,
    c: Counters,
    hit: bool,
    result: TraceResult,
}

fn sample(k: u32, seg: Segment, t: f32, cut: f32, st: ptr<function, SampleState>) {
    let p = seg_at(seg, t);
    let r = r_at(seg.a, seg.d, t);
    if r < cut || r == 0.0 || is_nan_f32(r) {
        return;
    }
    let tex = dir_to_texel(p, trace_config.size);
    (*st).c.texels += 1u;
    let delta = r - distance_at(k, tex);
    var hit = false;
    if trace_config.criterion == CRITERION_THRESHOLD {
        hit = abs(delta) < trace_config.eps;
    } else {
        hit = (*st).prev < 0.0 && delta >= 0.0;
    }
    (*st).prev = delta;
    if hit {
        (*st).hit = true;
        (*st).result = TraceResult(ONE_HIT, t, tex, false, p, (*st).c);
    }
}

// glam's `Vec3::normalize_or_zero`.
fn normalize_or_zero_glam(v: vec3<f32>) -> vec3<f32> {
    let rcp = 1.0 / sqrt(prod(v.x, v.x) + prod(v.y, v.y) + prod(v.z, v.z));
    if is_finite_f32(rcp) && rcp > 0.0 {
        return v * rcp;
    }
    return vec3<f32>(0.0);
}

// glam's `Vec3::cross`.
fn cross_glam(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        prod(a.y, b.z) - prod(b.y, a.z),
        prod(a.z, b.x) - prod(b.z, a.x),
        prod(a.x, b.y) - prod(b.x, a.y),
    );
}

fn dot_glam(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return prod(a.x, b.x) + prod(a.y, b.y) + prod(a.z, b.z);
}

// Approximate criteria (`cpu::approx::trace_sampled`).
fn trace_sampled(k: u32, seg: Segment, cut: f32) -> TraceResult {
    var st: SampleState;
    st.prev = -f32_inf();
    st.c = Counters(0u, 0u);
    st.hit = false;
    let sampling = trace_config.sampling;
    let steps = min(trace_config.steps, MAX_SAMPLE_STEPS);
    if sampling == SAMPLING_CONSTANT_STEP {
        for (var i = 0u; i <= steps; i++) {
            let t = seg.t_lo + prod(seg.t_hi - seg.t_lo, f32(i) / f32(max(steps, 1u)));
            sample(k, seg, t, cut, &st);
            if st.hit {
                return st.result;
            }
        }
    } else if sampling == SAMPLING_CONSTANT_ANGLE {
        let w0 = normalize_or_zero_glam(seg_at(seg, seg.t_lo));
        let w1 = normalize_or_zero_glam(seg_at(seg, seg.t_hi));
        for (var i = 0u; i <= steps; i++) {
            let s = f32(i) / f32(max(steps, 1u));
            let dw1 = w1 - w0;
            let w = vec3<f32>(w0.x + prod(s, dw1.x), w0.y + prod(s, dw1.y), w0.z + prod(s, dw1.z));
            // The ray point seen in direction w: a + t d parallel to w.
            let dw = cross_glam(seg.d, w);
            let den = dot_glam(dw, dw);
            if den == 0.0 {
                continue;
            }
            let t = clamp_rust(-dot_glam(cross_glam(seg.a, w), dw) / den, seg.t_lo, seg.t_hi);
            sample(k, seg, t, cut, &st);
            if st.hit {
                return st.result;
            }
        }
    } else {
        let n = trace_config.size;
        let pieces = split_near_centre(seg, cut);
        var budget = MAX_TEXEL_SAMPLES;
        for (var p = 0u; p < pieces.count; p++) {
            let lo = pieces.range[p].x;
            let hi = pieces.range[p].y;
            let faces = faces_crossed(seg, lo, hi, n);
            for (var f = 0u; f < faces.count; f++) {
                var cur = locate(seg, faces.face[f], faces.t0[f], n, lo, hi);
                while cur.found {
                    if budget == 0u {
                        return escaped(seg, st.c);
                    }
                    budget -= 1u;
                    let t = 0.5 * (cur.iv.t0 + cur.iv.t1);
                    sample(k, seg, t, cut, &st);
                    if st.hit {
                        return st.result;
                    }
                    cur = next_texel(seg, cur.tex, cur.iv, n, lo, hi);
                }
            }
        }
    }
    return escaped(seg, st.c);
}

// One CMO-local segment with the configured method (`cpu::options::trace_one_with`).
fn trace_one(k: u32, seg: Segment, variant: u32) -> TraceResult {
    let cut = cut_radius(k);
    if variant == TRACE_EXACT_MIP {
        return trace_mip(k, seg, cut, TRACE_EXACT_MIP);
    }
    if trace_config.criterion != CRITERION_CENTRE {
        return trace_sampled(k, seg, cut);
    } else if trace_config.accel != 0u {
        return trace_mip(k, seg, cut, TRACE_ANY);
    }
    return trace_walk(k, seg, cut);
}

fn trace_out(status: u32, cmo: u32, r: TraceResult, point: vec3<f32>, t_done: f32, traces: u32) -> TraceOut {
    return TraceOut(status, cmo, r.texel.face, r.texel.x, r.texel.y, select(0u, 1u, r.riser), r.counters.texels, r.counters.cells, traces, r.t, t_done, 0u, point, 0u);
}

// The world ray origin + t dir, t in [t_lo, t_hi], over the CMOs with the occlusion handoff
// (`cpu::multi::trace_cmos`), with any options.
fn trace_ray(origin: vec3<f32>, dir: vec3<f32>, t_lo: f32, t_hi: f32) -> TraceOut {
    return trace_ray_variant(origin, dir, t_lo, t_hi, TRACE_ANY);
}

// `trace_ray` carrying only the code of `variant` (a constant: TRACE_ANY or TRACE_EXACT_MIP).
fn trace_ray_variant(origin: vec3<f32>, dir: vec3<f32>, t_lo: f32, t_hi: f32, variant: u32) -> TraceOut {
    var t_done = t_lo;
    var traces = 0u;
    var last = TraceResult(ONE_ESCAPED, 0.0, Texel(0u, 0u, 0u), false, vec3<f32>(0.0), Counters(0u, 0u));
    for (var round = 0u; round < MAX_ROUNDS; round++) {
        var progress = false;
        for (var k = 0u; k < trace_config.cmo_count; k++) {
            let centre = cmo_centres[k].xyz;
            let seg = Segment(origin - centre, dir, t_done, t_hi, TRACE_NO_TRIANGLE);
            let r = trace_one(k, seg, variant);
            traces += 1u;
            last = r;
            if r.status == ONE_HIT || r.status == ONE_ESCAPED {
                var status = STATUS_ESCAPED;
                if r.status == ONE_HIT {
                    status = STATUS_HIT;
                }
                return trace_out(status, k, r, r.point + centre, t_done, traces);
            }
            if r.t > t_done {
                t_done = r.t;
                progress = true;
            }
        }
        if !progress {
            break;
        }
    }
    let p = vec3<f32>(origin.x + prod(t_done, dir.x), origin.y + prod(t_done, dir.y), origin.z + prod(t_done, dir.z));
    return trace_out(STATUS_UNRESOLVED, 0xffffffffu, last, p, t_done, traces);
}

// The `bounded` criterion: the WGSL twin of `cpu::bounded` (classification) and of
// its multi-CMO layer. A CMO holds per texel sound bounds and a sorted candidate list
// (`cubemap::bounds::TexelLists`, module docs there); a hit is the nearest intersection of the
// ray with a listed triangle inside the part of the texel the list is known to be complete for,
// so it is the first along the ray (up to the capture's f32 tolerance). No 3x3 verification:
// the triangle and barycentrics come from the classification itself.
//
// Data (@group(1), besides shared/trace.wgsl's; Rust `cubetrace::vk::passes::lists`):
// - binding 2 `cmo_distance`: the texel's `lo` (so the pyramids, cut radius and skip tests of
//   the centre criterion work unchanged);
// - bindings 6 to 9 `cmo_list_head`, `cmo_list_complete`, `cmo_list_hi`, `cmo_list_count`: per
//   texel of CMO k at `k * 6 N N + texel_index`, a u32 each: `head`, `bits(complete_to)`,
//   `bits(hi)`, `count_kept`;
// - bindings 10 to 13 `cmo_node_triangle`, `cmo_node_lo`, `cmo_node_hi`, `cmo_node_next`:
//   the node pool of all CMOs, a u32 per node each; the first `count_kept` nodes from `head`
//   along `next` are the texel's entries sorted by (lo, triangle). BOUNDED_NO_NODE ends a list.
// A word per binding (4 B per texel or node) keeps each binding within maxStorageBufferRange
// up to 33.5 M nodes at lavapipe's 128 MiB (`src/vk/passes/lists.rs`).
// The triangles' corners come from the scene (shared/hit.wgsl, @group(SCENE_GROUP)).
//
// Texel T crossed over [t0, t1] (`rmin, rmax` of r over it):
// - `rmax < lo` or `rmin > hi`, or inside the texel's gap (binding 15, shared/trace.wgsl's
//   `in_gap`): nothing here (kind 0, the traversal goes on);
// - complete_to finite: `r(t0) >= complete_to` is behind at t0; else the list is known up to
//   t_known = the larger root of r(t) = complete_to, clamped to [t0, t1] (t1 when +inf);
// - candidates: the entries in order until one has `lo > rmax`, but those with `hi < rmin` (the
//   ray is beyond them all through the texel); the watertight intersection of the CMO-local ray
//   with the triangle's corners minus the centre, kept where `seg.t_lo <= t <= t_known` and not
//   ignored by the start rule (shared/start.wgsl, in CMO-local coordinates, for a ray leaving
//   `seg.from_tri` at `seg.a`); nearest wins, ties to the lower triangle: a hit;
// - else behind at t_known when t_known < t1, else nothing.
// A list whose chain ends before `count_kept` nodes (a capture defect) is behind at t0: nothing
// is claimed from it.
//
// Traversal: the centre criterion's 2x2 pyramid march (shared/trace.wgsl's stepper `mip_turn`,
// CPU twin `cpu::mip`; the pyramid's min is the texels' `lo`) with the gaps' pyramid (`gaps`
// true: a cell is skipped, too, where the ray lies inside its gap), classifying with
// `classify_bounded_pick`.
//
// Loop caps: `count_kept` entries at most, and at most BOUNDED_MAX_ENTRIES; the march is
// trace.wgsl's (MAX_FACE_STEPS). lavapipe ends every loop of an invocation after 65535
// back-edges in all (spirv/README.md, "The loop limit"), which would end a march early as if
// the ray had escaped: `trace_ray_bounded` counts the back-edges it takes (one per turn of the
// march, per cell tested and per entry read, BOUNDED_TRACE_EDGES per single-CMO trace for its
// fixed loops) and stops at BOUNDED_MAX_EDGES with the ray unresolved at its proven-empty
// prefix and `cut` set (sound: nothing is claimed; the CPU twin has no such cap, so it differs
// only on such rays).
//! import shared/trace_verified.wgsl
//! import shared/watertight.wgsl
//! import shared/hit.wgsl
//! import shared/start.wgsl

@group(1) @binding(6) var<storage, read> cmo_list_head: array<u32>;
@group(1) @binding(7) var<storage, read> cmo_list_complete: array<u32>;
@group(1) @binding(8) var<storage, read> cmo_list_hi: array<u32>;
@group(1) @binding(9) var<storage, read> cmo_list_count: array<u32>;
@group(1) @binding(10) var<storage, read> cmo_node_triangle: array<u32>;
@group(1) @binding(11) var<storage, read> cmo_node_lo: array<u32>;
@group(1) @binding(12) var<storage, read> cmo_node_hi: array<u32>;
@group(1) @binding(13) var<storage, read> cmo_node_next: array<u32>;

const BOUNDED_NO_NODE: u32 = 0xffffffffu;
// Most entries read per texel (the capture's `depth`, 64 by default, stays below it): a texel
// with more is unknown, behind at its entry (sound; the CPU twin reads them all).
const BOUNDED_MAX_ENTRIES: u32 = 1024u;

// Texels whose list one single-CMO trace may walk (`walks` of `classify_bounded_pick`;
// `cpu::bounded::WALK_BUDGET`, whose docs say why): the next one is behind at its entry and
// the ray ends there unresolved, for the exact fallback (`bounded_spent`).
const BOUNDED_WALK_BUDGET: u32 = 64u;

// Whether a single-CMO trace that walked `walks` lists spent the budget: its behind ends the ray.
fn bounded_spent(walks: u32) -> bool {
    return walks > BOUNDED_WALK_BUDGET;
}

// Back-edges a ray may take before `trace_ray_bounded` stops it (below lavapipe's 65535).
const BOUNDED_MAX_EDGES: u32 = 60000u;
// Back-edges of one single-CMO trace outside the texel walk: `faces_crossed` (6 per piece),
// `cut_radius` (6 cells of the top level, or 6 texels), the piece and face loops.
const BOUNDED_TRACE_EDGES: u32 = 200u;

// The nearest candidate of a classification (found false: none).
struct BoundedPick {
    found: bool,
    t: f32,
    triangle: u32,
    bary: vec3<f32>,
}

fn bounded_no_pick() -> BoundedPick {
    return BoundedPick(false, 0.0, TRACE_NO_TRIANGLE, vec3<f32>(0.0));
}

// The start rule in CMO-local coordinates for a ray leaving `from_tri` at `o`: its corners
// tolerance and reach (`e` < 0: no start triangle).
struct BoundedStart {
    f0: vec3<f32>,
    f1: vec3<f32>,
    f2: vec3<f32>,
    e: f32,
    r: f32,
}

fn bounded_start(o: vec3<f32>, from_tri: u32, centre: vec3<f32>) -> BoundedStart {
    if from_tri == TRACE_NO_TRIANGLE {
        return BoundedStart(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), -1.0, -1.0);
    }
    let f0 = hit_vertex(from_tri, 0u).position - centre;
    let f1 = hit_vertex(from_tri, 1u).position - centre;
    let f2 = hit_vertex(from_tri, 2u).position - centre;
    let e = bvh_start_tolerance(o, f0, f1, f2);
    return BoundedStart(f0, f1, f2, e, bvh_start_reach(o, f0, f1, f2, e));
}

// Outcome of a texel (shared/trace.wgsl's kinds: 0 none, 1 hit, 2 behind) and, for a hit, its
// triangle and barycentrics.
struct BoundedOutcome {
    o: Outcome,
    pick: BoundedPick,
    // Entries read (back-edges of the candidate loop).
    read: u32,
}

// The larger root of |a + t d| = r (as `classify_with`'s patch hit), unclamped.
fn bounded_root(seg: Segment, r: f32) -> f32 {
    let dd = prod(seg.d.x, seg.d.x) + prod(seg.d.y, seg.d.y) + prod(seg.d.z, seg.d.z);
    let ts = -(prod(seg.a.x, seg.d.x) + prod(seg.a.y, seg.d.y) + prod(seg.a.z, seg.d.z)) / dd;
    let q = seg_at(seg, ts);
    let q2 = prod(q.x, q.x) + prod(q.y, q.y) + prod(q.z, q.z);
    return ts + sqrt(max(prod(r, r) - q2, 0.0) / dd);
}

// `cpu::bounded::classify_bounded` of `texel` of CMO k crossed over `iv` (module docs).
fn classify_bounded_pick(k: u32, seg: Segment, texel: Texel, iv: Interval, walks: ptr<function, u32>) -> BoundedOutcome {
    let none = BoundedOutcome(Outcome(0u, 0.0, false), bounded_no_pick(), 0u);
    if !crosses(iv) {
        return none;
    }
    let n = trace_config.size;
    let i = k * 6u * n * n + texel_index(texel, n);
    let lo = cmo_distance[i];
    let hi = bitcast<f32>(cmo_list_hi[i]);
    let rb = r_bounds(seg.a, seg.d, iv.t0, iv.t1);
    if rb.y < lo || rb.x > hi || in_gap(k, 0u, texel.face, texel.x, texel.y, rb) {
        return none;
    }
    let behind_t0 = BoundedOutcome(Outcome(2u, iv.t0, false), bounded_no_pick(), 0u);
    var t_known = iv.t1;
    let complete_to = bitcast<f32>(cmo_list_complete[i]);
    if is_finite_f32(complete_to) {
        if r_at(seg.a, seg.d, iv.t0) >= complete_to {
            return behind_t0;
        }
        let root = bounded_root(seg, complete_to);
        if root < iv.t1 {
            t_known = max(root, iv.t0);
        }
    }
    // More entries than the loop reads: the texel is unknown (as `complete_to` = 0).
    let count = cmo_list_count[i];
    if count > BOUNDED_MAX_ENTRIES {
        return behind_t0;
    }
    // The walk budget: past it, behind at the texel's entry (the ray is proven empty up to it).
    *walks += 1u;
    if bounded_spent(*walks) {
        return behind_t0;
    }
    let centre = cmo_centres[k].xyz;
    let start = bounded_start(seg.a, seg.from_tri, centre);
    var best = bounded_no_pick();
    var node = cmo_list_head[i];
    var j = 0u;
    for (; j < count; j++) {
        if node == BOUNDED_NO_NODE {
            return BoundedOutcome(behind_t0.o, behind_t0.pick, j);
        }
        if bitcast<f32>(cmo_node_lo[node]) > rb.y {
            break;
        }
        let e_hi = bitcast<f32>(cmo_node_hi[node]);
        let tri = cmo_node_triangle[node];
        node = cmo_node_next[node];
        if e_hi < rb.x {
            continue;
        }
        let a = hit_vertex(tri, 0u).position - centre;
        let b = hit_vertex(tri, 1u).position - centre;
        let c = hit_vertex(tri, 2u).position - centre;
        let w = wt_intersect(seg.a, seg.d, a, b, c);
        if !w.hit || w.t < seg.t_lo || w.t > t_known {
            continue;
        }
        if best.found && (w.t > best.t || (w.t == best.t && tri > best.triangle)) {
            continue;
        }
        if start.e >= 0.0 && bvh_start_ignores(seg.a, seg.from_tri, start.f0, start.f1, start.f2, start.e, start.r, tri, a, b, c, w.t * length(seg.d)) {
            continue;
        }
        best = BoundedPick(true, w.t, tri, w.bary);
    }
    if best.found {
        return BoundedOutcome(Outcome(1u, best.t, false), best, j);
    }
    if t_known < iv.t1 {
        return BoundedOutcome(Outcome(2u, t_known, false), bounded_no_pick(), j);
    }
    return BoundedOutcome(none.o, none.pick, j);
}

// The world point of a bounded hit at t (`cpu::multi::trace_world_ray`: origin + dir * t).
fn bounded_point(origin: vec3<f32>, dir: vec3<f32>, t: f32) -> vec3<f32> {
    return vec3<f32>(origin.x + prod(dir.x, t), origin.y + prod(dir.y, t), origin.z + prod(dir.z, t));
}

// A single-CMO trace with the pick of its deciding texel; `cut`: stopped at the back-edge cap;
// `spent`: behind because the walk budget ran out (`bounded_spent`).
struct BoundedResult {
    r: TraceResult,
    pick: BoundedPick,
    cut: bool,
    spent: bool,
}

// The pyramid march (shared/trace.wgsl's `trace_mip`, its stepper `mip_turn`) with the bounded
// classification; `edges` counts the back-edges (module docs, "Loop caps": one per turn, one
// per cell tested, one per entry read).
fn trace_mip_bounded(k: u32, seg: Segment, cut: f32, edges: ptr<function, u32>) -> BoundedResult {
    let n = trace_config.size;
    var c = Counters(0u, 0u);
    var walks = 0u;
    *edges += BOUNDED_TRACE_EDGES;
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
                let cells = c.cells;
                let turn = mip_turn(k, seg, &m, &checked, lo, hi, reach, &c, true);
                if turn == MIP_DONE {
                    break;
                }
                var b = BoundedOutcome(Outcome(0u, 0.0, false), bounded_no_pick(), 0u);
                if turn == MIP_TEXEL {
                    c.texels += 1u;
                    b = classify_bounded_pick(k, seg, m.cur.tex, m.cur.iv, &walks);
                }
                *edges += 1u + (c.cells - cells) + b.read;
                if *edges > BOUNDED_MAX_EDGES {
                    return BoundedResult(finish(seg, m.cur.tex, b.o, c), bounded_no_pick(), true, false);
                }
                if b.o.kind != 0u {
                    return BoundedResult(finish(seg, m.cur.tex, b.o, c), b.pick, false, bounded_spent(walks));
                }
                if turn == MIP_TEXEL {
                    mip_passed(&m);
                }
            }
        }
    }
    return BoundedResult(escaped(seg, c), bounded_no_pick(), false, false);
}

// `trace_ray_bounded`'s result: `cut` where it stopped at the back-edge cap (then unresolved).
struct BoundedOut {
    v: VerifiedOut,
    cut: bool,
}

// The world ray origin + t dir, t in [t_lo, t_hi], leaving global triangle `from_tri`
// (TRACE_NO_TRIANGLE: none), over the CMOs with the occlusion handoff (`trace_ray_variant`'s
// loops) and the bounded criterion; a hit's triangle and barycentrics are its deciding texel's
// nearest candidate, its point `origin + t dir` in world space (`VerifiedOut` as
// shared/trace_verified.wgsl's `trace_ray_verified` gives it; `cpu::multi::trace_world_ray`).
fn trace_ray_bounded(origin: vec3<f32>, dir: vec3<f32>, t_lo: f32, t_hi: f32, from_tri: u32) -> BoundedOut {
    var t_done = t_lo;
    var traces = 0u;
    var edges = 0u;
    var cut = false;
    var spent = false;
    var last = TraceResult(ONE_ESCAPED, 0.0, Texel(0u, 0u, 0u), false, vec3<f32>(0.0), Counters(0u, 0u));
    for (var round = 0u; round < MAX_ROUNDS; round++) {
        var progress = false;
        for (var k = 0u; k < trace_config.cmo_count; k++) {
            let centre = cmo_centres[k].xyz;
            let seg = Segment(origin - centre, dir, t_done, t_hi, from_tri);
            let b = trace_mip_bounded(k, seg, cut_radius(k), &edges);
            let r = b.r;
            traces += 1u;
            last = r;
            if b.cut {
                cut = true;
                break;
            }
            if r.status == ONE_HIT {
                let v = VerifiedOut(trace_out(STATUS_HIT, k, r, bounded_point(origin, dir, r.t), t_done, traces), b.pick.triangle, b.pick.bary);
                return BoundedOut(v, false);
            }
            if r.status == ONE_ESCAPED {
                let v = VerifiedOut(trace_out(STATUS_ESCAPED, k, r, r.point + centre, t_done, traces), TRACE_NO_TRIANGLE, vec3<f32>(0.0));
                return BoundedOut(v, false);
            }
            if r.t > t_done {
                t_done = r.t;
                progress = true;
            }
            if b.spent {
                spent = true;
                break;
            }
        }
        if !progress || cut || spent {
            break;
        }
    }
    let p = vec3<f32>(origin.x + prod(t_done, dir.x), origin.y + prod(t_done, dir.y), origin.z + prod(t_done, dir.z));
    let v = VerifiedOut(trace_out(STATUS_UNRESOLVED, 0xffffffffu, last, p, t_done, traces), TRACE_NO_TRIANGLE, vec3<f32>(0.0));
    return BoundedOut(v, cut);
}

//! Thesis alg. 3 (compute path): depth-first traversal of the 8x4/4x8 hierarchy
//! ([`crate::cubemap::pyramid::Hier32`]) by one ray per 32 logical lanes, with the subgroup
//! ballot emulated for subgroup sizes 4, 8, 16, 32 and 64.
//!
//! Structure (the shader follows it loop for loop):
//! - Per CMO, per piece of the segment ([`super::split_near_centre`]), per face in order of `t`
//!   ([`super::faces_crossed`]), a depth-first search. The node at the top is the face, whose
//!   children are the root level's cells (`W x H <= 32`); a cell of level `l >= 1` has the
//!   `gx x gy` (32) cells of level `l - 1` as children, child `j` at `(j % gx, j / gx)`.
//! - Visiting a node, logical lane `j` tests child `j`: interval from the frustum inequalities,
//!   then the range test. A cell is a candidate unless its widened interval is empty or the ray
//!   is entirely in front of it (`rmax < min`), or, with the `bounded` criterion, inside its gap
//!   ([`super::bounded::Bounded::in_hier_gap`]); a texel is a candidate iff crossed and
//!   `rmax >= D` (the surface model's "not entirely in front"). The 32-bit candidate mask comes
//!   from ballots and is kept per level, with each lane's key `t0` (the exact entry parameter).
//! - The first candidate along the ray (smallest key, ties: lowest `j`; a subgroup min then a
//!   ballot of equal keys) is removed from the mask and descended into; an empty mask returns to
//!   the parent (backtrack). The first texel candidate is classified ([`super::classify`]) and
//!   ends the ray.
//!
//! Subgroup sizes: with `S < 32` lanes, lane `i` tests children `i + S c` for `c < 32 / S` and
//! the mask is assembled from `32 / S` ballots (`ballot_c << S c`); with `S = 64` two rays share
//! the subgroup (lanes `32 r .. 32 r + 32` for ray slot `r`), advance in lockstep, and each
//! takes its 32 bits of the 64-bit ballot. No barrier is needed: all communication is ballots.
//!
//! GPU: `spirv/compute_trace.wgsl` (the `compute_trace` pass), checked against this twin field
//! for field, counters included, in `tests/compute.rs`.

use glam::Vec3;

use super::{
    CmoTracer, Counters, FaceList, NoLog, Pieces, Segment, TraceResult, Work, WorkLog, classify,
    escaped, faces_crossed, finish, split_near_centre,
};
use crate::cubemap::face::{Texel, to_face_local};
use crate::cubemap::frustum::{CellRect, cell_interval, r_at, r_bounds, seg_reach};
use crate::cubemap::pyramid::HIER_MAX_LEVELS;

/// Supported subgroup sizes.
pub const SUBGROUP_SIZES: [u32; 5] = [4, 8, 16, 32, 64];

const NODE_LEVELS: usize = HIER_MAX_LEVELS + 1;

/// Per-ray traversal state (registers of the ray's lanes, uniform across them).
#[derive(Debug, Clone, Copy)]
struct RayState {
    seg: Segment,
    pieces: Pieces,
    piece: u32,
    faces: FaceList,
    face: u32,
    la: Vec3,
    ld: Vec3,
    /// Current node level; `top` = the face itself.
    level: usize,
    node: [(u32, u32); NODE_LEVELS],
    mask: [u32; NODE_LEVELS],
    key: [[f32; 32]; NODE_LEVELS],
    need_mask: bool,
    done: bool,
    result: TraceResult,
    counters: Counters,
}

/// The child grid of the ray's current node: the child level's whole grid at the top, else the
/// node's group.
fn child_group(tr: &CmoTracer, st: &RayState) -> (u32, u32) {
    let child = &tr.hier.levels[st.level - 1];
    if st.level == tr.hier.root() + 1 {
        (child.width, child.height)
    } else {
        tr.hier.levels[st.level].group
    }
}

/// Child `j` of the ray's current node, as [`lane_test`] and [`lane_crossing`] address it.
struct ChildCell {
    /// The piece's interval.
    lo: f32,
    hi: f32,
    face: u32,
    /// The child level.
    cl: usize,
    cx: u32,
    cy: u32,
}

/// [`ChildCell`] `j`; `None` where `j` is outside the node's group or the group runs past the
/// child level's edge.
fn child_cell(tr: &CmoTracer, st: &RayState, j: u32) -> Option<ChildCell> {
    let [lo, hi] = st.pieces.range[st.piece as usize];
    let face = st.faces.face[st.face as usize];
    let cl = st.level - 1;
    let child = &tr.hier.levels[cl];
    let (gx, gy) = child_group(tr, st);
    if j >= gx * gy {
        return None;
    }
    let (nx, ny) = st.node[st.level];
    let (cx, cy) = (nx * gx + j % gx, ny * gy + j / gx);
    (cx < child.width && cy < child.height).then_some(ChildCell {
        lo,
        hi,
        face,
        cl,
        cx,
        cy,
    })
}

/// Test of child `j` of the ray's current node: `(candidate, key)`.
fn lane_test(tr: &CmoTracer, st: &RayState, j: u32) -> (bool, f32) {
    let n = tr.cube.size;
    let Some(ChildCell {
        lo,
        hi,
        face,
        cl,
        cx,
        cy,
    }) = child_cell(tr, st, j)
    else {
        return (false, f32::INFINITY);
    };
    let child = &tr.hier.levels[cl];
    if cl == 0 {
        let iv = cell_interval(st.la, st.ld, &CellRect::texel(face, cx, cy, n), lo, hi);
        let d = tr.cube.distance_at(Texel { face, x: cx, y: cy });
        let cand = iv.crosses()
            && r_at(st.seg.a, st.seg.d, iv.t0).max(r_at(st.seg.a, st.seg.d, iv.t1)) >= d;
        return (cand, iv.t0);
    }
    let rect = child.rect(face, cx, cy, n);
    if rect.is_empty() {
        return (false, f32::INFINITY);
    }
    let iv = cell_interval(st.la, st.ld, &rect, lo, hi);
    match iv.inflated(lo, hi, seg_reach(st.seg.a, st.seg.d)) {
        Some((a, b)) => {
            // Skip iff entirely in front, or (bounded) inside the cell's gap; a NaN keeps the
            // cell (conservative).
            let rb = r_bounds(st.seg.a, st.seg.d, a, b);
            let skip = rb.1 < child.get(face, cx, cy)[0]
                || tr
                    .bounded
                    .as_ref()
                    .is_some_and(|g| g.in_hier_gap(cl, face, cx, cy, rb));
            (!skip, iv.t0)
        }
        None => (false, f32::INFINITY),
    }
}

/// For the work log: whether child `j` of the ray's current node exists (`lane_test` reads its
/// bound) and passes the interval test (`children_crossed` in the shader), by `lane_test`'s
/// own conditions ([`child_cell`]). Only run when logging.
fn lane_crossing(tr: &CmoTracer, st: &RayState, j: u32) -> (bool, bool) {
    let n = tr.cube.size;
    let Some(ChildCell {
        lo,
        hi,
        face,
        cl,
        cx,
        cy,
    }) = child_cell(tr, st, j)
    else {
        return (false, false);
    };
    let child = &tr.hier.levels[cl];
    if cl == 0 {
        let iv = cell_interval(st.la, st.ld, &CellRect::texel(face, cx, cy, n), lo, hi);
        return (true, iv.crosses());
    }
    let rect = child.rect(face, cx, cy, n);
    if rect.is_empty() {
        return (false, false);
    }
    let iv = cell_interval(st.la, st.ld, &rect, lo, hi);
    (
        true,
        iv.inflated(lo, hi, seg_reach(st.seg.a, st.seg.d)).is_some(),
    )
}

/// The [`Work::Visit`] of the ray's current node.
fn visit_work(tr: &CmoTracer, st: &RayState) -> Work {
    let group = child_group(tr, st);
    let (mut exists, mut crossed) = (0u32, 0u32);
    for j in 0..32 {
        let (e, c) = lane_crossing(tr, st, j);
        exists |= u32::from(e) << j;
        crossed |= u32::from(c) << j;
    }
    Work::Visit {
        face: st.faces.face[st.face as usize],
        level: st.level as u32,
        node: st.node[st.level],
        group,
        exists,
        crossed,
    }
}

/// Sets up the DFS at the current (piece, face), advancing past exhausted ones; marks the ray
/// escaped when none is left.
fn enter_face(tr: &CmoTracer, st: &mut RayState) {
    loop {
        if st.piece >= st.pieces.count {
            st.done = true;
            st.result = escaped(&st.seg, st.counters);
            return;
        }
        if st.face < st.faces.count {
            let f = st.faces.face[st.face as usize];
            st.la = to_face_local(f, st.seg.a);
            st.ld = to_face_local(f, st.seg.d);
            st.level = tr.hier.root() + 1;
            st.node[st.level] = (0, 0);
            st.need_mask = true;
            return;
        }
        st.piece += 1;
        st.face = 0;
        if st.piece < st.pieces.count {
            let [lo, hi] = st.pieces.range[st.piece as usize];
            st.faces = faces_crossed(&st.seg, lo, hi, tr.cube.size);
        }
    }
}

fn new_state(tr: &CmoTracer, seg: &Segment) -> RayState {
    let pieces = split_near_centre(seg, tr.cut_radius);
    let faces = if pieces.count > 0 {
        faces_crossed(seg, pieces.range[0][0], pieces.range[0][1], tr.cube.size)
    } else {
        FaceList {
            count: 0,
            face: [0; 6],
            iv: [super::Interval::EMPTY; 6],
        }
    };
    let mut st = RayState {
        seg: *seg,
        pieces,
        piece: 0,
        faces,
        face: 0,
        la: Vec3::ZERO,
        ld: Vec3::ZERO,
        level: 0,
        node: [(0, 0); NODE_LEVELS],
        mask: [0; NODE_LEVELS],
        key: [[f32::INFINITY; 32]; NODE_LEVELS],
        need_mask: false,
        done: false,
        result: TraceResult::default(),
        counters: Counters::default(),
    };
    enter_face(tr, &mut st);
    st
}

/// One traversal step after the node's mask is known: pick, descend, classify or backtrack.
fn advance<L: WorkLog + ?Sized>(tr: &CmoTracer, st: &mut RayState, log: &mut L) {
    let top = tr.hier.root() + 1;
    let lvl = st.level;
    if st.mask[lvl] == 0 {
        if lvl == top {
            st.face += 1;
            enter_face(tr, st);
        } else {
            st.level += 1;
            st.counters.backtracks += 1;
        }
        return;
    }
    // Subgroup min over candidate keys, then ballot of lanes holding it: first set bit.
    let mut kmin = f32::INFINITY;
    let mut m = st.mask[lvl];
    while m != 0 {
        let j = m.trailing_zeros() as usize;
        kmin = kmin.min(st.key[lvl][j]);
        m &= m - 1;
    }
    let mut pick = st.mask[lvl].trailing_zeros();
    let mut m = st.mask[lvl];
    while m != 0 {
        let j = m.trailing_zeros();
        if st.key[lvl][j as usize] == kmin {
            pick = j;
            break;
        }
        m &= m - 1;
    }
    st.mask[lvl] &= !(1u32 << pick);
    let h = &tr.hier;
    let child = &h.levels[lvl - 1];
    let (gx, gy) = if lvl == top {
        (child.width, child.height)
    } else {
        h.levels[lvl].group
    };
    let (nx, ny) = st.node[lvl];
    let (cx, cy) = (nx * gx + pick % gx, ny * gy + pick / gx);
    if lvl - 1 == 0 {
        let [lo, hi] = st.pieces.range[st.piece as usize];
        let face = st.faces.face[st.face as usize];
        let tex = Texel { face, x: cx, y: cy };
        let iv = cell_interval(
            st.la,
            st.ld,
            &CellRect::texel(face, cx, cy, tr.cube.size),
            lo,
            hi,
        );
        log.log(Work::Classify(tex));
        if let Some(o) = classify(tr, &st.seg, tex, &iv, &mut st.counters) {
            st.done = true;
            st.result = finish(&st.seg, tex, o, st.counters);
        }
        return;
    }
    st.level -= 1;
    st.node[st.level] = (cx, cy);
    st.need_mask = true;
    st.counters.descents += 1;
}

/// Traces `segs` (one CMO) on an emulated subgroup of `subgroup` lanes (4, 8, 16, 32 or 64).
pub fn trace_alg3(tr: &CmoTracer, segs: &[Segment], subgroup: u32) -> Vec<TraceResult> {
    trace_alg3_logged(tr, segs, subgroup, &mut NoLog)
}

/// [`trace_alg3`], reporting each ray's node visits and steps to `log` (one ray per call for a
/// per-ray log: with several rays the events of a subgroup's rays interleave).
pub fn trace_alg3_logged<L: WorkLog + ?Sized>(
    tr: &CmoTracer,
    segs: &[Segment],
    subgroup: u32,
    log: &mut L,
) -> Vec<TraceResult> {
    assert!(
        SUBGROUP_SIZES.contains(&subgroup),
        "unsupported subgroup size {subgroup}"
    );
    let rays_per_sg = (subgroup / 32).max(1) as usize;
    let lanes_per_ray = subgroup.min(32);
    let cells_per_lane = 32 / lanes_per_ray;
    let mut out = Vec::with_capacity(segs.len());
    for chunk in segs.chunks(rays_per_sg) {
        let mut st: [Option<RayState>; 2] = [None, None];
        for (r, s) in chunk.iter().enumerate() {
            st[r] = Some(new_state(tr, s));
        }
        loop {
            let active = st.iter().flatten().any(|s| !s.done);
            if !active {
                break;
            }
            // Lane work: every lane of the subgroup evaluates its children for its ray slot;
            // `ballot[c]` is the subgroup-wide ballot of round `c` (64 bits).
            let mut ballot = [0u64; 8];
            let mut keys = [[f32::INFINITY; 32]; 2];
            for lane in 0..subgroup {
                let slot = (lane / 32) as usize;
                let Some(s) = st[slot].as_ref() else { continue };
                if s.done || !s.need_mask {
                    continue;
                }
                for c in 0..cells_per_lane {
                    let j = lane % 32 + lanes_per_ray * c;
                    let (cand, key) = lane_test(tr, s, j);
                    keys[slot][j as usize] = key;
                    if cand {
                        ballot[c as usize] |= 1u64 << lane;
                    }
                }
            }
            for (slot, so) in st.iter_mut().enumerate() {
                let Some(s) = so.as_mut() else { continue };
                if s.done {
                    continue;
                }
                if s.need_mask {
                    log.log(visit_work(tr, s));
                    let mut mask = 0u32;
                    for c in 0..cells_per_lane {
                        let bits = (ballot[c as usize] >> (32 * slot)) as u32;
                        let bits = if lanes_per_ray == 32 {
                            bits
                        } else {
                            bits & ((1u32 << lanes_per_ray) - 1)
                        };
                        mask |= bits << (lanes_per_ray * c);
                    }
                    let lvl = s.level;
                    let top = tr.hier.root() + 1;
                    let child = &tr.hier.levels[lvl - 1];
                    let (gx, gy) = if lvl == top {
                        (child.width, child.height)
                    } else {
                        tr.hier.levels[lvl].group
                    };
                    if lvl == 1 {
                        s.counters.texels += gx * gy;
                    } else {
                        s.counters.cells += gx * gy;
                    }
                    s.mask[lvl] = mask;
                    s.key[lvl] = keys[slot];
                    s.need_mask = false;
                }
                let (lvl, top) = (s.level, tr.hier.root() + 1);
                let leaves_face = s.mask[lvl] == 0 && lvl == top;
                advance(tr, s, log);
                log.log(Work::Step {
                    left_face: leaves_face,
                    done: s.done,
                });
            }
        }
        for s in st.iter().flatten() {
            out.push(s.result);
        }
    }
    out
}

//! Several CMOs: the occlusion handoff of ALGORITHM.md ("Occlusion and several CMOs").
//!
//! `t_done` is the end of the part of the ray proven empty. Each CMO in turn traces
//! `[t_done, t_hi]`: a hit ends the ray; escaped (in front of that CMO's profile up to `t_hi`)
//! ends it as background; behind at `t_b` sets `t_done = max(t_done, t_b)` and passes to the
//! next CMO. A full round over the CMOs without `t_done` growing leaves the ray unresolved (the
//! caller's fallback fills it). Rounds are capped at [`MAX_ROUNDS`] (then unresolved too).

use glam::Vec3;

use super::{CmoTracer, Segment, Status, TraceResult, alg3, mip, walk};

/// Cap on rounds over the CMOs.
pub const MAX_ROUNDS: u32 = 16;

/// Which traversal traces each CMO.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Traversal {
    /// [`walk::trace_walk`].
    Walk,
    /// [`mip::trace_mip`].
    Mip,
    /// [`alg3::trace_alg3`] with this subgroup size.
    Alg3(u32),
    /// [`walk::trace_brute`] (tests).
    Brute,
}

/// Traces one CMO-local segment with a traversal.
pub fn trace_one(tr: &CmoTracer, seg: &Segment, how: Traversal) -> TraceResult {
    match how {
        Traversal::Walk => walk::trace_walk(tr, seg),
        Traversal::Mip => mip::trace_mip(tr, seg),
        Traversal::Alg3(s) => alg3::trace_alg3(tr, std::slice::from_ref(seg), s)[0],
        Traversal::Brute => walk::trace_brute(tr, seg),
    }
}

/// Final state of a ray over several CMOs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MultiStatus {
    /// A CMO saw the hit.
    Hit,
    /// A CMO saw the ray empty up to `t_hi`.
    Escaped,
    /// No CMO could see the part after `t_done`.
    Unresolved,
}

/// Result of [`trace_cmos`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiResult {
    /// Final state.
    pub status: MultiStatus,
    /// CMO that decided (hit or escaped); `u32::MAX` when unresolved.
    pub cmo: u32,
    /// That CMO's result (the last one traced when unresolved).
    pub result: TraceResult,
    /// World hit point (for hits).
    pub point: Vec3,
    /// Proven-empty prefix `[t_lo, t_done]`.
    pub t_done: f32,
    /// Single-CMO traces run.
    pub traces: u32,
}

/// Traces the world ray `origin + t dir`, `t in [t_lo, t_hi]`, over the CMOs in order.
pub fn trace_cmos(
    cmos: &[CmoTracer],
    origin: Vec3,
    dir: Vec3,
    t_lo: f32,
    t_hi: f32,
    how: Traversal,
) -> MultiResult {
    trace_cmos_by(cmos, origin, dir, t_lo, t_hi, |tr, seg| {
        trace_one(tr, seg, how)
    })
}

/// [`trace_cmos`] with any single-CMO trace (e.g. an approximate criterion, which never reports
/// behind, so the first CMO decides).
pub fn trace_cmos_by(
    cmos: &[CmoTracer],
    origin: Vec3,
    dir: Vec3,
    t_lo: f32,
    t_hi: f32,
    trace: impl Fn(&CmoTracer, &Segment) -> TraceResult,
) -> MultiResult {
    let mut t_done = t_lo;
    let mut traces = 0;
    let mut last = TraceResult::default();
    for _round in 0..MAX_ROUNDS {
        let mut progress = false;
        for (k, tr) in cmos.iter().enumerate() {
            let seg = Segment {
                a: origin - tr.cube.centre,
                d: dir,
                t_lo: t_done,
                t_hi,
            };
            let r = trace(tr, &seg);
            traces += 1;
            last = r;
            match r.status {
                Status::Hit | Status::Escaped => {
                    let status = if r.status == Status::Hit {
                        MultiStatus::Hit
                    } else {
                        MultiStatus::Escaped
                    };
                    return MultiResult {
                        status,
                        cmo: k as u32,
                        result: r,
                        point: r.point + tr.cube.centre,
                        t_done,
                        traces,
                    };
                }
                Status::Behind => {
                    if r.t > t_done {
                        t_done = r.t;
                        progress = true;
                    }
                }
            }
        }
        if !progress {
            break;
        }
    }
    MultiResult {
        status: MultiStatus::Unresolved,
        cmo: u32::MAX,
        result: last,
        point: origin + t_done * dir,
        t_done,
        traces,
    }
}

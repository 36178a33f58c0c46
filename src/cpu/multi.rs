//! Several CMOs: the occlusion handoff of ALGORITHM.md ("Occlusion and several CMOs").
//!
//! `t_done` is the end of the part of the ray proven empty. Each CMO in turn traces
//! `[t_done, t_hi]`: a hit ends the ray; escaped (in front of that CMO's profile up to `t_hi`)
//! ends it as background; behind at `t_b` sets `t_done = max(t_done, t_b)` and passes to the
//! next CMO. A full round over the CMOs without `t_done` growing leaves the ray unresolved (the
//! caller's fallback fills it). Rounds are capped at [`MAX_ROUNDS`] (then unresolved too).
//!
//! # Verified hits
//! With a [`Verify`] (the scene's triangle corners), a hit that a CMO decides at texel `T` is
//! verified ([`super::verify::verify_hit`] over `T`'s 3x3 neighbourhood of captured triangle
//! IDs, with the proven-empty prefix `t_done` and the segment end `t_hi`): the result's point
//! and triangle are then the verified ones, on a triangle the ray meets. When verification
//! finds nothing, `T` counts as **behind at its entry** `t0` (the start of the ray's interval in
//! `T`'s cone, within the segment): the ray goes on by the occlusion handoff from
//! `max(t_done, t0)`, exactly as if the CMO had reported behind there.
//!
//! Why this is safe: (1) a hit is only ever reported by a successful verification, so it is on a
//! triangle the ray intersects; (2) `t_done` grows only to `t0`, the point where the ray entered
//! `T`'s cone, and everything before `t0` the CMO classified in front of its profile, which is
//! the same evidence the handoff already relies on for "behind": the prefix claim is not made
//! stronger than before. What it can cost: a single CMO that fails to verify at `T` finds `T`
//! again from `t0` in the next round, so the round makes no progress and the ray ends
//! unresolved (the fallback fills it) unless another CMO resolves it.

use std::borrow::Borrow;

use glam::Vec3;

use super::verify::{Neighbourhood, VerifyRay, verify_hit};
use super::{CmoTracer, Segment, Status, TraceResult, compute, mip, texel_interval, walk};

/// Cap on rounds over the CMOs.
pub const MAX_ROUNDS: u32 = 16;

/// Which traversal traces each CMO.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Traversal {
    /// [`walk::trace_walk`].
    Walk,
    /// [`mip::trace_mip`].
    Mip,
    /// [`compute::trace_alg3`] with this subgroup size.
    Alg3(u32),
    /// [`walk::trace_brute`] (tests).
    Brute,
}

/// Traces one CMO-local segment with a traversal.
pub fn trace_one(tr: &CmoTracer, seg: &Segment, how: Traversal) -> TraceResult {
    match how {
        Traversal::Walk => walk::trace_walk(tr, seg),
        Traversal::Mip => mip::trace_mip(tr, seg),
        Traversal::Alg3(s) => compute::trace_alg3(tr, std::slice::from_ref(seg), s)[0],
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
    /// Verified hits: the global triangle hit ([`super::verify::NO_TRIANGLE`] otherwise).
    pub triangle: u32,
    /// Verified hits: the barycentric weights of the triangle's three vertices (zero otherwise).
    pub bary: [f32; 3],
}

/// What verification needs besides the CMOs (which carry the captured triangle IDs in
/// [`crate::cubemap::CubeMap::triangle`]): the corners of every scene triangle by global index
/// ([`super::verify::triangle_corners`]).
#[derive(Debug, Clone, Copy)]
pub struct Verify<'a> {
    pub triangles: &'a [[Vec3; 3]],
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
    trace_cmos_verified_by(cmos, origin, dir, t_lo, t_hi, None, trace)
}

/// [`trace_cmos`] with verified hits when `verify` is given (module docs, "Verified hits").
pub fn trace_cmos_verified(
    cmos: &[impl Borrow<CmoTracer>],
    origin: Vec3,
    dir: Vec3,
    t_lo: f32,
    t_hi: f32,
    how: Traversal,
    verify: Option<Verify>,
) -> MultiResult {
    trace_cmos_verified_by(cmos, origin, dir, t_lo, t_hi, verify, |tr, seg| {
        trace_one(tr, seg, how)
    })
}

/// [`trace_cmos_by`] with verified hits when `verify` is given.
pub fn trace_cmos_verified_by(
    cmos: &[impl Borrow<CmoTracer>],
    origin: Vec3,
    dir: Vec3,
    t_lo: f32,
    t_hi: f32,
    verify: Option<Verify>,
    trace: impl Fn(&CmoTracer, &Segment) -> TraceResult,
) -> MultiResult {
    let ray = WorldRay {
        origin,
        dir,
        from: super::bounded::NO_TRIANGLE,
        t_lo,
        t_hi,
    };
    trace_world_ray(cmos, &ray, verify, trace)
}

/// A world ray `origin + t dir`, `t in [t_lo, t_hi]`, leaving triangle `from`
/// ([`super::bounded::NO_TRIANGLE`]: none; the `bounded` criterion's start rule).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub from: u32,
    pub t_lo: f32,
    pub t_hi: f32,
}

/// [`trace_cmos_verified_by`] on a [`WorldRay`]. With CMOs of the `bounded` criterion
/// ([`CmoTracer::bounded`]) a hit names its triangle itself and is not verified again.
pub fn trace_world_ray(
    cmos: &[impl Borrow<CmoTracer>],
    ray: &WorldRay,
    verify: Option<Verify>,
    trace: impl Fn(&CmoTracer, &Segment) -> TraceResult,
) -> MultiResult {
    let WorldRay {
        origin,
        dir,
        from,
        t_lo,
        t_hi,
    } = *ray;
    let mut t_done = t_lo;
    let mut traces = 0;
    let mut last = TraceResult::default();
    'rounds: for _round in 0..MAX_ROUNDS {
        let mut progress = false;
        for (k, tr) in cmos.iter().map(Borrow::borrow).enumerate() {
            let seg = Segment {
                a: origin - tr.cube.centre,
                d: dir,
                t_lo: t_done,
                t_hi,
                from,
            };
            let r = trace(tr, &seg);
            traces += 1;
            last = r;
            let mut r = r;
            let mut verified = None;
            if r.status == Status::Hit && tr.bounded.is_some() {
                verified = Some(super::verify::VerifiedHit {
                    triangle: r.triangle,
                    t: r.t,
                    position: origin + dir * r.t,
                    bary: r.bary,
                });
            } else if let (Status::Hit, Some(v)) = (r.status, verify) {
                let size = tr.cube.size;
                let hood = Neighbourhood::around(r.texel, size, &tr.cube.triangle);
                let ray = VerifyRay {
                    a: origin,
                    d: dir,
                    t_done,
                    t_hi,
                };
                verified = verify_hit(ray, tr.cube.centre, &hood, v.triangles);
                if verified.is_none() {
                    // Behind at the entry into T's cone (module docs).
                    let iv = texel_interval(&seg, r.texel, size, seg.t_lo, seg.t_hi);
                    r.status = Status::Behind;
                    r.t = if iv.crosses() { iv.t0 } else { t_done };
                }
            }
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
                        point: verified.map_or(r.point + tr.cube.centre, |v| v.position),
                        t_done,
                        traces,
                        triangle: verified.map_or(super::verify::NO_TRIANGLE, |v| v.triangle),
                        bary: verified.map_or([0.0; 3], |v| v.bary),
                    };
                }
                Status::Behind => {
                    if r.t > t_done {
                        t_done = r.t;
                        progress = true;
                    }
                    if tr
                        .bounded
                        .as_ref()
                        .is_some_and(|b| b.spent(r.counters.walks))
                    {
                        break 'rounds;
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
        triangle: super::verify::NO_TRIANGLE,
        bary: [0.0; 3],
    }
}

//! The thesis's approximate criteria (fragment path options, thesis §3.4 and §3.5). The exact
//! criterion is [`super`]'s surface model; these exist to measure against it.
//!
//! At each sample `t_i` the ray point `p` is looked up in its texel
//! ([`crate::cubemap::face::dir_to_texel`] of `p`), giving `delta = r - D`:
//! - [`Criterion::Threshold`]: hit at the first sample with `|delta| < eps`.
//! - [`Criterion::SignChange`]: hit at the first sample where `delta` goes from `< 0` (in front)
//!   to `>= 0`; it also fires where the ray passes behind an occluder (thesis fig. 3.2, C).
//!
//! Neither has a "behind" outcome: a ray without a hit is reported escaped. Samples with
//! `r < cut_radius` (in front of everything, direction ill-defined) are skipped.

use super::{
    CmoTracer, Counters, Segment, Status, TraceResult, escaped, faces_crossed, locate, next_texel,
    split_near_centre,
};
use crate::cubemap::face::dir_to_texel;
use crate::cubemap::frustum::r_at;

/// Intersection criterion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Criterion {
    /// `|r - D| < eps` (world units).
    Threshold(f32),
    /// `r - D` changes sign from negative to non-negative between samples.
    SignChange,
}

/// Sample placement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sampling {
    /// `n + 1` samples evenly spaced in `t` over `[t_lo, t_hi]`.
    ConstantStep(u32),
    /// `n + 1` samples evenly spaced along the chord between the endpoint directions (thesis:
    /// interpolated cube map coordinates), mapped back to the ray.
    ConstantAngle(u32),
    /// One sample per crossed texel, at the middle of its interval (the walk's order).
    PerTexel,
}

/// Most samples of [`Sampling::PerTexel`] (four faces of 2048 texels along a diagonal, twice).
pub const MAX_TEXEL_SAMPLES: u32 = 16384;

/// Tests one sample; `Some(result)` on a hit. `prev` holds the last `delta`.
fn sample(
    tr: &CmoTracer,
    seg: &Segment,
    t: f32,
    crit: Criterion,
    prev: &mut f32,
    c: &mut Counters,
) -> Option<TraceResult> {
    let p = seg.at(t);
    let r = r_at(seg.a, seg.d, t);
    if r < tr.cut_radius || r == 0.0 || r.is_nan() {
        return None;
    }
    let tex = dir_to_texel(p, tr.cube.size);
    c.texels += 1;
    let delta = r - tr.cube.distance_at(tex);
    let hit = match crit {
        Criterion::Threshold(eps) => delta.abs() < eps,
        Criterion::SignChange => *prev < 0.0 && delta >= 0.0,
    };
    *prev = delta;
    if hit {
        Some(TraceResult {
            status: Status::Hit,
            t,
            texel: tex,
            riser: false,
            point: p,
            counters: *c,
            ..TraceResult::default()
        })
    } else {
        None
    }
}

/// Traces one segment with an approximate criterion.
pub fn trace_sampled(
    tr: &CmoTracer,
    seg: &Segment,
    crit: Criterion,
    sampling: Sampling,
) -> TraceResult {
    let mut c = Counters::default();
    let mut prev = f32::NEG_INFINITY;
    match sampling {
        Sampling::ConstantStep(n) => {
            for i in 0..=n {
                let t = seg.t_lo + (seg.t_hi - seg.t_lo) * (i as f32 / n.max(1) as f32);
                if let Some(r) = sample(tr, seg, t, crit, &mut prev, &mut c) {
                    return r;
                }
            }
        }
        Sampling::ConstantAngle(n) => {
            let w0 = seg.at(seg.t_lo).normalize_or_zero();
            let w1 = seg.at(seg.t_hi).normalize_or_zero();
            for i in 0..=n {
                let s = i as f32 / n.max(1) as f32;
                let w = w0 + s * (w1 - w0);
                // The ray point seen in direction w: a + t d parallel to w.
                let dw = seg.d.cross(w);
                let den = dw.length_squared();
                if den == 0.0 {
                    continue;
                }
                let t = (-(seg.a.cross(w)).dot(dw) / den).clamp(seg.t_lo, seg.t_hi);
                if let Some(r) = sample(tr, seg, t, crit, &mut prev, &mut c) {
                    return r;
                }
            }
        }
        Sampling::PerTexel => {
            let n = tr.cube.size;
            let pieces = split_near_centre(seg, tr.cut_radius);
            let mut budget = MAX_TEXEL_SAMPLES;
            for p in 0..pieces.count as usize {
                let [lo, hi] = pieces.range[p];
                let faces = faces_crossed(seg, lo, hi, n);
                for f in 0..faces.count as usize {
                    let mut cur = locate(seg, faces.face[f], faces.iv[f].t0, n, lo, hi);
                    while let Some((tex, iv)) = cur {
                        if budget == 0 {
                            return escaped(seg, c);
                        }
                        budget -= 1;
                        let t = 0.5 * (iv.t0 + iv.t1);
                        if let Some(r) = sample(tr, seg, t, crit, &mut prev, &mut c) {
                            return r;
                        }
                        cur = next_texel(seg, tex, &iv, n, lo, hi);
                    }
                }
            }
        }
    }
    escaped(seg, c)
}

//! Per-texel walk (each crossed texel once, in order along the ray) and the brute-force
//! definition it must agree with. Surface model: see [`super`].

use super::{
    CmoTracer, Counters, Segment, TraceResult, classify, escaped, faces_crossed, finish, locate,
    next_texel, split_near_centre, texel_interval, texel_not_in_front,
};
use crate::cubemap::face::Texel;

/// Walks the texels the segment crosses, face by face in order of `t`, and classifies the first
/// one that is not entirely in front.
pub fn trace_walk(tr: &CmoTracer, seg: &Segment) -> TraceResult {
    let n = tr.cube.size;
    let mut c = Counters::default();
    let pieces = split_near_centre(seg, tr.cut_radius);
    for p in 0..pieces.count as usize {
        let [lo, hi] = pieces.range[p];
        let faces = faces_crossed(seg, lo, hi, n);
        for f in 0..faces.count as usize {
            let mut cur = locate(seg, faces.face[f], faces.iv[f].t0, n, lo, hi);
            while let Some((tex, iv)) = cur {
                c.texels += 1;
                if let Some(o) = classify(tr, seg, tex, &iv, &mut c) {
                    return finish(seg, tex, o, c);
                }
                cur = next_texel(seg, tex, &iv, n, lo, hi);
            }
        }
    }
    escaped(seg, c)
}

/// The definition: tests every texel of every face and keeps the not-in-front texel with the
/// smallest `t0` (ties: piece, then lower linear index). O(6 N^2) per ray; tests only.
pub fn trace_brute(tr: &CmoTracer, seg: &Segment) -> TraceResult {
    let n = tr.cube.size;
    let mut c = Counters::default();
    let pieces = split_near_centre(seg, tr.cut_radius);
    for p in 0..pieces.count as usize {
        let [lo, hi] = pieces.range[p];
        let mut best = None;
        for i in 0..tr.cube.distance.len() {
            let tex = Texel::from_index(i, n);
            let iv = texel_interval(seg, tex, n, lo, hi);
            c.texels += 1;
            if texel_not_in_front(seg, &iv, tr.cube.distance[i])
                && best.is_none_or(|(_, b): (Texel, super::Interval)| iv.t0 < b.t0)
            {
                best = Some((tex, iv));
            }
        }
        if let Some((tex, iv)) = best
            && let Some(o) = classify(tr, seg, tex, &iv, &mut c)
        {
            return finish(seg, tex, o, c);
        }
    }
    escaped(seg, c)
}

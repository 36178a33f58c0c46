//! Thesis alg. 2 (fragment path): the per-texel walk accelerated by the 2x2 `[min, max]`
//! pyramid. At each texel, levels are checked coarsest first; a cell entered for the first time
//! is tested over its (conservatively widened) interval, and skipped when the ray is entirely in
//! front of it there (`rmax < min`, ALGORITHM.md fact 3; the thesis's endpoint test is not
//! used). After a skip the walk resumes at the texel across the cell's exit side (alg. 4's
//! boundary, from the frustum inequalities; [`super::locate_after_skip`]). A cell found not
//! skippable is remembered per level (`checked`) until the walk leaves it, like alg. 2's `B(i)`. With the `bounded` criterion a
//! cell is skipped, too, where the ray's distances there lie inside the cell's gap
//! ([`super::bounded::Bounded::in_gap`]): between the surfaces its lists hold.

use super::{
    CmoTracer, Counters, NoLog, Segment, TraceResult, Work, WorkLog, classify, escaped,
    faces_crossed, finish, locate_after_skip, locate_counted, next_texel_counted,
    split_near_centre,
};
use crate::cubemap::face::to_face_local;
use crate::cubemap::frustum::{Closest, PlaneBound, cell_interval_face, r_bounds_from, seg_reach};

/// Most pyramid levels (N = 2048 has 12).
pub const MIP_MAX_LEVELS: usize = 16;

/// Traces one segment with the 2x2 pyramid.
pub fn trace_mip(tr: &CmoTracer, seg: &Segment) -> TraceResult {
    trace_mip_logged(tr, seg, &mut NoLog)
}

/// [`trace_mip`], reporting its work to `log` in the shader's terms (`spirv/shared/trace.wgsl`,
/// `trace_mip`: a turn of the march starts at each texel search).
pub fn trace_mip_logged<L: WorkLog + ?Sized>(
    tr: &CmoTracer,
    seg: &Segment,
    log: &mut L,
) -> TraceResult {
    let n = tr.cube.size;
    let top = tr.mip.levels.len() - 1;
    let mut c = Counters::default();
    let pieces = split_near_centre(seg, tr.cut_radius);
    let reach = seg_reach(seg.a, seg.d);
    // The ray's constants of the cell tests: its closest approach, and per face the z plane.
    let closest = Closest::of(seg.a, seg.d);
    for p in 0..pieces.count as usize {
        log.log(Work::Piece);
        let [lo, hi] = pieces.range[p];
        let faces = faces_crossed(seg, lo, hi, n);
        for f in 0..faces.count as usize {
            log.log(Work::Face);
            let face = faces.face[f];
            let la = to_face_local(face, seg.a);
            let ld = to_face_local(face, seg.d);
            let z = PlaneBound::new(la.z, ld.z, false);
            // checked[l]: the level-l cell last found not skippable (u32::MAX: none).
            let mut checked = [(u32::MAX, u32::MAX); MIP_MAX_LEVELS];
            // The cell skipped last, which the located texel may still touch by rounding.
            let mut last_skip = (usize::MAX, u32::MAX, u32::MAX);
            let (mut cur, full) = locate_counted(seg, face, faces.iv[f].t0, n, lo, hi);
            log.log(Work::Search {
                found: cur.is_some(),
                full,
            });
            'walk: while let Some((tex, iv)) = cur {
                let mut l = top;
                while l >= 1 {
                    let lev = &tr.mip.levels[l];
                    let cx = tex.x / lev.span.0;
                    let cy = tex.y / lev.span.1;
                    if checked[l] != (cx, cy) {
                        c.cells += 1;
                        log.log(Work::Cell {
                            level: l as u32,
                            face,
                            x: cx,
                            y: cy,
                        });
                        let rect = lev.rect(face, cx, cy, n);
                        let civ = cell_interval_face(la, ld, &rect, z, lo, hi);
                        let skip = match civ.inflated(lo, hi, reach) {
                            Some((a, b)) if last_skip != (l, cx, cy) => {
                                let rb = r_bounds_from(seg.a, seg.d, closest, a, b);
                                rb.1 < lev.get(face, cx, cy)[0]
                                    || tr
                                        .bounded
                                        .as_ref()
                                        .is_some_and(|g| g.in_gap(l, face, cx, cy, rb))
                            }
                            _ => false,
                        };
                        if skip {
                            last_skip = (l, cx, cy);
                            let t_exit = if civ.crosses() { civ.t1 } else { iv.t1 };
                            let t = t_exit.max(iv.t1);
                            let full;
                            (cur, full) = locate_after_skip(seg, &rect, &civ, t, n, lo, hi);
                            log.log(Work::Search {
                                found: cur.is_some(),
                                full,
                            });
                            continue 'walk;
                        }
                        checked[l] = (cx, cy);
                    }
                    l -= 1;
                }
                c.texels += 1;
                log.log(Work::Classify(tex));
                if let Some(o) = classify(tr, seg, tex, &iv, &mut c) {
                    return finish(seg, tex, o, c);
                }
                let full;
                (cur, full) = next_texel_counted(seg, tex, &iv, n, lo, hi);
                log.log(Work::Search {
                    found: cur.is_some(),
                    full,
                });
            }
        }
    }
    escaped(seg, c)
}

//! The `bounded` criterion: first hits proven over sound per-texel bounds and
//! complete candidate lists ([`crate::cubemap::bounds`]), the CPU twin of `classify_bounded` in
//! `spirv/shared/trace_bounded.wgsl` (`classify_bounded_pick`).
//!
//! # The rule
//! The traversals ([`super::walk`], [`super::mip`], [`super::compute`]) are unchanged: they take
//! the texels the ray crosses in order of `t`, skip every cell and texel with `rmax < lo` (the
//! CMO's distance is the texel lower bound `lo`), and hand each remaining texel `T`, crossed over
//! `[t0, t1]`, to [`classify_bounded`]:
//! 1. `rmax < lo` or `rmin > hi` (`r_bounds` over `[t0, t1]`): the ray is in front of, or beyond,
//!    everything `T` holds; or `g0 < rmin` and `rmax < g1` for `T`'s gap `(g0, g1)`
//!    ([`crate::cubemap::bounds::texel_gap`]): it passes between two surfaces. Nothing here, the
//!    traversal goes on. The fragment path's pyramid march skips whole cells the same way, over
//!    the gaps' pyramid ([`Bounded::gaps`]: the largest `g0` and smallest `g1` of the cell), and
//!    the compute path's over their 8x4/4x8 hierarchy ([`Bounded::gap_hier`]).
//! 2. The known part: with `complete_to = L` finite, the list holds every triangle nearer than
//!    `L` only. `r(t0) >= L`: nothing of `T` is known: **behind** at `t0`. Otherwise the known
//!    part ends at `t_known = min(t1, the larger root of r(t) = L)` (`r` is convex and
//!    `r(t0) < L`, so `{r < L}` holds `[t0, root)`).
//! 3. The walk budget: the trace's walks so far, this one included, above [`WALK_BUDGET`]:
//!    **behind** at `t0`, and the ray ends there unresolved (for the exact fallback).
//! 4. Candidates: every kept entry with `lo <= rmax`, in list order, but those with
//!    `hi < rmin` (the ray is beyond that triangle's part of the cone all through `T`: a ray
//!    running behind a captured surface passes such entries texel after texel): the watertight
//!    intersection ([`super::watertight`]) of the CMO-local ray `a + t d` with the triangle's
//!    corners minus the CMO centre, kept when `t_lo <= t <= t_known` and not at the ray's start
//!    (the start rule, `StartRule`). The nearest kept one (ties: lower triangle) is the **hit**.
//! 5. No candidate: **behind** at `t_known` when the known part ended inside `T`
//!    (`t_known < t1`: the next CMO, then the fallback, take the ray from there), else nothing
//!    here: the traversal goes on.
//!
//! # Proof sketch: the hit is the first
//! Bounds (the capture's module docs derive their rounding): every surface point `p` in `T`'s
//! cone has `|p| >= lo(T)`, and every triangle touching the cone with a point nearer than
//! `complete_to(T)` is among `T`'s entries, with `lo(entry) <=` its distance there.
//! 1. **Skipped stretches are empty.** A cell or texel is skipped only where the ray's largest
//!    distance from the centre over its interval is below the smallest `lo` of its texels: no
//!    surface point in those cones is that near, so the ray meets nothing there. Step 1's
//!    `rmin > hi` skip needs `complete_to = +inf`, so `hi` bounds every triangle of `T`. A gap
//!    skip: every triangle touching the cone is a kept entry with `[lo, hi]` outside the gap,
//!    or was dropped with `lo >= complete_to >= g1`; a cell's gap lies inside each of its
//!    texels' gaps.
//! 2. **Texels decide in order.** Let the ray's true first hit be at `t*`, on triangle `X`, in
//!    texel `T*`'s cone. Every texel before `T*` along the ray either was skipped (empty by 1),
//!    or tested its candidates: any hit it reports is a real intersection at `t >= t_lo`, so
//!    `t >= t*` (in exact arithmetic it is `t*` itself); or it ended the CMO's trace by going
//!    behind at a point before which the ray is empty in that CMO (steps 2, 3, 5). At `T*`, `X`
//!    touches the cone at `p(t*)`, `|p(t*)| = r(t*) <= rmax`, so `X` is an entry with
//!    `lo <= rmax` unless it lies at or beyond `complete_to`, where step 2 stops before `t*`.
//!    So `T*` reports `X` (or a tie at `t*`), or the CMO hands the ray on before `t*`. `X`'s
//!    entry is not passed over as beyond: its `hi >= |p(t*)| >= rmin`. An entry passed over
//!    could only give an intersection before `t0`, in an earlier texel, which that texel skipped
//!    as empty or tested.
//! 3. **Several CMOs.** A CMO that goes behind at `t_b` has shown `[t_lo, t_b]` empty (the
//!    handoff's `t_done`); the next traces from there. A hit is only ever a candidate's
//!    intersection, so it is never on a triangle the ray does not meet, and never past a nearer
//!    one that a CMO could know of.
//!
//! Rounding: the watertight test and `r_bounds` are f32; a hit may lie a few ulps of `t` from
//! the exact first hit, and two surfaces closer than that along the ray can swap. The capture's
//! margin covers the texel boundaries (a triangle within rounding of `T`'s cone is `T`'s entry).

use glam::Vec3;

use super::watertight::{intersect_sheared, shear};
use super::{CmoTracer, Counters, Outcome, Segment};
use crate::cubemap::bounds::TexelLists;
use crate::cubemap::face::Texel;
use crate::cubemap::frustum::{Interval, r_at, r_bounds};
use crate::cubemap::pyramid::{Hier32, MipPyramid};

/// Texels whose list one single-CMO trace may walk (module docs, step 3): the next texel that
/// would walk its list is behind at its entry instead, and that behind ends the ray unresolved
/// ([`Bounded::spent`], `cpu::multi::trace_world_ray`): the exact fallback finishes it from there,
/// where every texel before has been proven empty or tested. Without it, a ray that runs
/// behind a captured surface for long (a ray leaving a reflector whose inside its CMO sees; a
/// CMO far from where the ray goes) tests candidates at every texel it crosses: 700-1000
/// texels a ray on such corpus scenes, against about 40 where the lists end the walk early.
/// `BOUNDED_WALK_BUDGET` in `spirv/shared/trace_bounded.wgsl`.
pub const WALK_BUDGET: u32 = 64;

/// "No triangle": a ray that leaves none (the start rule is off).
pub const NO_TRIANGLE: u32 = u32::MAX;

/// The start rule's ulps of the coordinates (`BVH_START_ULPS` in `spirv/shared/bvh.wgsl`).
const START_ULPS: f32 = 3.814_697_3e-6; // 2^-18

/// A CMO's `bounded` data: its lists and the scene's triangle corners (world space, global
/// index order) that the entries name.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounded {
    pub lists: TexelLists,
    pub corners: Vec<[Vec3; 3]>,
    /// The walk budget ([`WALK_BUDGET`]; the GPU's is that constant, tests may raise it).
    pub walk_budget: u32,
    /// The lists' gaps and their 2x2 pyramid (level 0 the texels' `[g1, g0]`,
    /// [`TexelLists::gaps`]; a cell keeps the min of `g1` and the max of `g0`), which the
    /// traversals skip through (module docs, step 1).
    pub gaps: MipPyramid,
    /// The same gaps over the compute path's 8x4/4x8 hierarchy ([`Hier32::over_cells`]).
    pub gap_hier: Hier32,
}

impl Bounded {
    /// The CPU twin of what the GPU holds: `lists` over `corners`, the walk budget
    /// [`WALK_BUDGET`].
    pub fn new(lists: TexelLists, corners: Vec<[Vec3; 3]>) -> Bounded {
        let cells = lists.gaps();
        let gap_hier = Hier32::over_cells(lists.size, cells.clone());
        let gaps = MipPyramid::over_cells(lists.size, cells);
        Bounded {
            lists,
            corners,
            walk_budget: WALK_BUDGET,
            gaps,
            gap_hier,
        }
    }

    /// [`Bounded::in_gap`] for a cell of the compute path's hierarchy ([`Bounded::gap_hier`]).
    pub fn in_hier_gap(&self, level: usize, face: u32, x: u32, y: u32, rb: (f32, f32)) -> bool {
        inside(self.gap_hier.levels[level].get(face, x, y), rb)
    }

    /// Whether distances `rb = (rmin, rmax)` lie strictly inside the gap `[g1, g0]` of cell
    /// `(x, y)` of `face` at pyramid level `level` (0: a texel): nothing there (step 1).
    pub fn in_gap(&self, level: usize, face: u32, x: u32, y: u32, rb: (f32, f32)) -> bool {
        inside(self.gaps.levels[level].get(face, x, y), rb)
    }

    /// Whether a trace that walked `walks` lists spent the budget (step 3).
    pub fn spent(&self, walks: u32) -> bool {
        walks > self.walk_budget
    }
}

/// A candidate hit: the triangle, the ray parameter and the barycentric weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundedHit {
    pub triangle: u32,
    pub t: f32,
    pub bary: [f32; 3],
}

/// Step 1 to 5 of the module docs for texel `texel` crossed over `iv`, with the walk budget
/// ([`WALK_BUDGET`]); `counters` gains the candidates intersected (`triangles`) and the lists
/// walked (`walks`).
pub fn classify_bounded(
    tr: &CmoTracer,
    b: &Bounded,
    seg: &Segment,
    texel: Texel,
    iv: &Interval,
    counters: &mut Counters,
) -> Option<Outcome> {
    if !iv.crosses() {
        return None;
    }
    let (lo, hi, complete_to) = b.lists.bounds_at(texel);
    let (rmin, rmax) = r_bounds(seg.a, seg.d, iv.t0, iv.t1);
    if rmax < lo || rmin > hi || b.in_gap(0, texel.face, texel.x, texel.y, (rmin, rmax)) {
        return None;
    }
    let mut t_known = iv.t1;
    let mut cut = false;
    if complete_to < f32::INFINITY {
        if r_at(seg.a, seg.d, iv.t0) >= complete_to {
            return Some(Outcome::Behind { t: iv.t0 });
        }
        let root = larger_root(seg, complete_to);
        if root < iv.t1 {
            t_known = root.max(iv.t0);
            cut = true;
        }
    }
    counters.walks += 1;
    if b.spent(counters.walks) {
        return Some(Outcome::Behind { t: iv.t0 });
    }
    match nearest_candidate(
        tr,
        b,
        seg,
        texel,
        (rmin, rmax),
        t_known,
        &mut counters.triangles,
    ) {
        Some(h) => Some(Outcome::Candidate(h)),
        None if cut => Some(Outcome::Behind { t: t_known }),
        None => None,
    }
}

/// Whether `rb = (rmin, rmax)` lies strictly inside the gap `[g1, g0]`.
fn inside([g1, g0]: [f32; 2], rb: (f32, f32)) -> bool {
    rb.0 > g0 && rb.1 < g1
}

/// The larger root of `|a + t d| = radius` (the same operations as the centre criterion's patch
/// hit in [`super::classify`]).
fn larger_root(seg: &Segment, radius: f32) -> f32 {
    let dd = seg.d.x * seg.d.x + seg.d.y * seg.d.y + seg.d.z * seg.d.z;
    let ts = -(seg.a.x * seg.d.x + seg.a.y * seg.d.y + seg.a.z * seg.d.z) / dd;
    let q = seg.at(ts);
    let q2 = q.x * q.x + q.y * q.y + q.z * q.z;
    ts + ((radius * radius - q2).max(0.0) / dd).sqrt()
}

/// Step 3: the nearest kept candidate of `texel` with `t_lo <= t <= t_max`.
fn nearest_candidate(
    tr: &CmoTracer,
    b: &Bounded,
    seg: &Segment,
    texel: Texel,
    (rmin, rmax): (f32, f32),
    t_max: f32,
    tested: &mut u32,
) -> Option<BoundedHit> {
    let sh = shear(seg.d)?;
    let centre = tr.cube.centre;
    let start = StartRule::new(b, seg, centre);
    let mut best: Option<BoundedHit> = None;
    for e in b.lists.entries_at(texel) {
        if e.lo > rmax {
            break;
        }
        if e.hi < rmin {
            continue;
        }
        let Some(world) = b.corners.get(e.triangle as usize) else {
            continue;
        };
        let local = world.map(|p| p - centre);
        *tested += 1;
        let Some(h) = intersect_sheared(seg.a, &sh, local) else {
            continue;
        };
        if h.t < seg.t_lo
            || h.t > t_max
            || start.ignores(e.triangle, world, local, h.t * seg.d.length())
        {
            continue;
        }
        if best.is_none_or(|x| h.t < x.t || (h.t == x.t && e.triangle < x.triangle)) {
            best = Some(BoundedHit {
                triangle: e.triangle,
                t: h.t,
                bary: h.bary,
            });
        }
    }
    best
}

/// The start rule of `spirv/shared/bvh.wgsl` (`bvh_start_ignores`) in CMO-local coordinates: a
/// ray that leaves triangle F at `o` ignores hits on F and on F's neighbours (a corner at a
/// bit-identical world position) whose plane passes within `e` of `o` ([`start_tolerance`]),
/// or within the reach `r` with the hit within `r` of `o` too ([`start_reach`]).
struct StartRule {
    from: u32,
    o: Vec3,
    world: [Vec3; 3],
    e: f32,
    r: f32,
}

impl StartRule {
    fn new(b: &Bounded, seg: &Segment, centre: Vec3) -> StartRule {
        let o = seg.a;
        match b.corners.get(seg.from as usize) {
            Some(&world) => {
                let f = world.map(|p| p - centre);
                let e = start_tolerance(o, f);
                StartRule {
                    from: seg.from,
                    o,
                    world,
                    e,
                    r: start_reach(o, f, e),
                }
            }
            None => StartRule {
                from: NO_TRIANGLE,
                o,
                world: [Vec3::NAN; 3],
                e: -1.0,
                r: -1.0,
            },
        }
    }

    /// Whether a hit on `tri` (corners `world`, and `local` in CMO-local coordinates), `dist`
    /// from `o`, is ignored.
    fn ignores(&self, tri: u32, world: &[Vec3; 3], local: [Vec3; 3], dist: f32) -> bool {
        if self.from == NO_TRIANGLE {
            return false;
        }
        let plane = plane_distance(self.o, local);
        tri == self.from
            || (shares_corner(&self.world, world)
                && start_ignores_neighbour(plane, self.e, self.r, dist))
    }
}

/// The start rule's tolerance `e` for a ray leaving triangle `f` at `o` (`bvh_start_tolerance`
/// in `spirv/shared/start.wgsl`, bit for bit; the rule and why `e` is what it is:
/// `spirv/shared/bvh.wgsl`): `2 |s_F(o)| + 2^-18 max(|o|, |f|)`.
pub fn start_tolerance(o: Vec3, f: [Vec3; 3]) -> f32 {
    let m = o.abs().max(f[0].abs()).max(f[1].abs().max(f[2].abs()));
    2.0 * plane_distance(o, f) + START_ULPS * m.max_element()
}

/// The start rule's reach `r` for a ray leaving `f` at `o` with tolerance `e`
/// (`bvh_start_reach`, bit for bit): `e + 2 x_F(o)`, `e` inside `f`.
pub fn start_reach(o: Vec3, f: [Vec3; 3], e: f32) -> f32 {
    e + 2.0 * outside_distance(o, f)
}

/// The start rule's decision on a neighbour (`bvh_start_ignores` past its `from_tri` test):
/// ignored where its plane passes within `e` of `o`, or within `r` of `o` with the hit `dist`
/// from `o` within `r` too.
pub fn start_ignores_neighbour(plane: f32, e: f32, r: f32, dist: f32) -> bool {
    plane <= e || (plane <= r && dist <= r)
}

/// How far `o`, projected on the plane of `f`, lies beyond the farthest of `f`'s edge lines: 0
/// inside `f` and for a degenerate triangle (`bvh_outside_distance`, bit for bit).
pub fn outside_distance(o: Vec3, f: [Vec3; 3]) -> f32 {
    let n = (f[1] - f[0]).cross(f[2] - f[0]);
    let l = n.length();
    if l.is_nan() || l <= 0.0 {
        return 0.0;
    }
    let inside = |a: Vec3, b: Vec3| (b - a).cross(o - a).dot(n) / ((b - a).length() * l);
    let (w0, w1, w2) = (inside(f[0], f[1]), inside(f[1], f[2]), inside(f[2], f[0]));
    0.0f32.max(-w0).max((-w1).max(-w2))
}

/// Distance of `p` from the plane of `t` (infinite for a degenerate triangle).
fn plane_distance(p: Vec3, t: [Vec3; 3]) -> f32 {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let l = n.length();
    if l.is_nan() || l <= 0.0 {
        return f32::INFINITY;
    }
    (p - t[0]).dot(n).abs() / l
}

fn shares_corner(a: &[Vec3; 3], b: &[Vec3; 3]) -> bool {
    let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
    a.iter().any(|p| b.iter().any(|q| bits(p) == bits(q)))
}

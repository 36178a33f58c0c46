#![forbid(unsafe_code)]
//! CPU twins of the tracing passes, written loop-for-loop as the WGSL shaders will read: f32
//! math, fixed-size arrays, no recursion, no allocation per ray; and the CPU twin of the CMO
//! capture ([`capture`]: a ray per texel centre, traced by the reference).
//!
//! # Surface model: exact per texel, sphere patches
//! Texel `i` (distance `D_i`) is the piece of the sphere `|x| = D_i` (CMO-local) inside the
//! texel's frustum ([`crate::cubemap::frustum`]). Along the ray the texels it crosses (positive
//! length, half-open tie rule) are taken in order of `t`; the first texel whose interval
//! `[t0, t1]` is **not entirely in front** (`rmax >= D_i`, `rmax = max(r(t0), r(t1))`) decides:
//! - `r(t0) <= D_i`: the ray meets the patch inside the texel at the first root of
//!   `|a + t d| = D_i` after `t0`: a **hit** ([`Outcome::Hit`]); in strict mode
//!   ([`TraceParams::strict`]) only if it is decisive (below), otherwise **behind** at `t0`
//!   (undecided: this CMO cannot tell; the next CMO goes on).
//! - `r(t0) > D_i` and `t0` is the segment start: the ray starts behind the profile: **behind**
//!   at `t_lo`.
//! - `r(t0) > D_i` otherwise: the ray entered through side `s` (the constraint that set `t0`)
//!   from the neighbour texel `p` across `s` ([`crate::cubemap::face::neighbour_across`]), where
//!   it was in front, so `D_p > r(t0) > D_i`: a step down. It is a **hit on the riser** joining
//!   the patches (at `t0`, reported on texel `i`) iff the two patches are one continuous
//!   surface by the [continuity rule](continuous); otherwise the ray went **behind** an occluder
//!   at `t_b = t0`. A silhouette never becomes a hit.
//! - No such texel up to `t_hi`: **escaped**.
//!
//! # Decisive patch hits (strict mode)
//! A texel's sample is the surface at its centre only; across the texel the true distance
//! varies (by `D tan(psi)` per radian on a surface at `psi` from the view direction) and may end
//! at a silhouette. A patch hit counts only when the samples around the hit direction show the
//! ray behind the surface: the hit point's quadrant (its side of the centre in `u` and in `v`)
//! names the two side neighbours whose samples, with the texel's, surround it; both must be
//! continuous with the texel (else the silhouette may pass between: thin objects, object
//! edges), and the ray must reach `max(D_i, (D_i + D_n) / 2)` over those two neighbours (the
//! half-way distances, the surface at the texel's edges) within the texel (else it may pass in
//! front of the surface where the patch sticks out of it: grazing rays). Undecided is reported
//! as behind, which is exact: no hit is claimed that the samples do not show, and another CMO
//! (or the fallback, flagged unresolved) takes the rest of the ray. Risers are unchanged.
//!
//! Strict mode is an option, not the default: on the built-in scenes it turns 2 to 5% of the
//! mirror pixels unresolved (sphere-room 2.2% -> 6.9%, torus 0.5% -> 5.8% at 96x72). It was
//! made to remove the silent wrong hits that grazing surfaces and outlines inside a texel
//! caused; with verified hits ([`verify`]) the default mode has none of those left. Over the
//! whole hard-case suite (`tests/hard_cases.rs`, module docs: both GPU paths and their CPU
//! twins) strict mode removes wrong hits in one case only, 2 of 5 at cube size 3 (rays verified
//! on the floor behind a box that no texel centre sees), and none elsewhere.
//!
//! # Near-centre rays
//! Where the ray comes within `cut_radius = min(D) / 2` of the centre it is in front of every
//! texel, and the projection onto faces degenerates (at the centre every face is crossed at
//! once). That stretch is removed: the segment is split into at most two pieces with
//! `r >= cut_radius` ([`split_near_centre`]), traced in order. Rays through the centre, or
//! starting at it, are thus handled exactly.
//!
//! # Traversals (same classification and hit texel by construction of the order)
//! - [`walk`]: per-texel walk across the faces (faces in order of entry `t`).
//! - [`mip`]: thesis alg. 2 over the 2x2 [`crate::cubemap::pyramid::MipPyramid`], with cell
//!   boundaries from the frustum inequalities (alg. 4) and the skip test `rmax < min` (fact 3).
//! - [`compute`]: depth-first traversal of the [`crate::cubemap::pyramid::Hier32`] with an emulated
//!   subgroup ballot, for subgroup sizes 4..64.
//! - [`walk::trace_brute`]: every texel tested, the first along `t` kept (the definition).
//! - [`multi`]: several CMOs with the occlusion handoff.
//! - [`fragment`]: the per-pixel twins of the `fragment_trace` and `envmap` passes.
//! - [`options`]: the method options ([`options::TraceOptions`]) shared with the GPU tracer.

pub mod approx;
pub mod bounded;
pub mod capture;
pub mod closure;
pub mod compute;
pub mod cone;
pub mod fragment;
pub mod mip;
pub mod multi;
pub mod options;
pub mod reflection_point;
pub mod ssr;
pub mod ssr_cone;
pub mod verify;
pub mod walk;
pub mod watertight;

use glam::Vec3;

/// What a twin ran, reported step by step for the SIMT cost model ([`crate::model::work`]);
/// the events follow the shader's blocks, not the twin's own loops where they differ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Work {
    /// Alg. 3: a node visit (the ray is testing `node`'s children): `level` is the node's
    /// level (children at `level - 1`), `group` its children grid; bit j of `exists` is set
    /// where child j exists (its bound is read), of `crossed` where it passes the interval
    /// test (what `children_crossed` leaves for the 1-lane layout).
    Visit {
        face: u32,
        level: u32,
        node: (u32, u32),
        group: (u32, u32),
        exists: u32,
        crossed: u32,
    },
    /// Alg. 3: the end of one traversal step (`advance`): it left the face (`left_face`; the
    /// shader's `settle` enters the next one) or ended the trace (`done`).
    Step {
        left_face: bool,
        done: bool,
    },
    /// A texel classified (both paths).
    Classify(Texel),
    /// Alg. 2: a piece of the segment, a face entered.
    Piece,
    Face,
    /// Alg. 2: a texel search (`locate` or `next_texel`), the start of a turn of the march;
    /// `full`: the 3x3 search ran (the certificate of the texel tried first did not hold,
    /// [`certified`]).
    Search {
        found: bool,
        full: bool,
    },
    /// SSR: one iteration of the Hi-Z loop: the cell it read (`level`, x, y) and whether it
    /// crossed into the next cell; `Hiz { level: -1, .. }` is the first crossing, before the
    /// loop.
    Hiz {
        level: i32,
        x: i32,
        y: i32,
        cross: bool,
    },
    /// Reflection point: one distance `d` of the start texel's crosshair search (the same for
    /// every vertex: `rp.start` was off the reflector).
    StartArms {
        d: i32,
    },
    /// Reflection point: the start of a walk (`inverse`: the inverse search).
    Walk {
        inverse: bool,
    },
    /// Reflection point: one iteration of a walk.
    WalkStep,
    /// Reflection point: a texel scored.
    Score {
        x: i32,
        y: i32,
    },
    /// Alg. 2: a pyramid cell tested.
    Cell {
        level: u32,
        face: u32,
        x: u32,
        y: u32,
    },
}

/// Where a twin reports its [`Work`]; [`NoLog`] (what the plain entry points pass) drops it.
pub trait WorkLog {
    fn log(&mut self, w: Work);
}

/// The log that records nothing.
pub struct NoLog;

impl WorkLog for NoLog {
    #[inline(always)]
    fn log(&mut self, _: Work) {}
}

impl WorkLog for Vec<Work> {
    fn log(&mut self, w: Work) {
        self.push(w);
    }
}

use crate::cubemap::CubeMap;
use crate::cubemap::face::{
    Texel, edge_inclusive, face_coord, neighbour_across, st_to_texel_coord, texel_centre_dir,
    to_face_local,
};
use crate::cubemap::frustum::{
    CellRect, Clip, Interval, PlaneBound, SIDE_SEGMENT, SIDE_X0, SIDE_X1, SIDE_Y0, SIDE_Y1, SIDE_Z,
    cell_interval, r_at,
};
use crate::cubemap::pyramid::{Hier32, MipPyramid};

/// A ray segment in CMO-local coordinates: `a + t d`, `t in [t_lo, t_hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Start point minus the CMO centre.
    pub a: Vec3,
    /// Direction (any non-zero length; `t` is in its units).
    pub d: Vec3,
    /// First parameter.
    pub t_lo: f32,
    /// Last parameter.
    pub t_hi: f32,
    /// The triangle the ray leaves ([`bounded::NO_TRIANGLE`]: none), for the `bounded`
    /// criterion's start rule ([`bounded`]); the other criteria ignore it.
    pub from: u32,
}

impl Segment {
    /// `a + t d`.
    pub fn at(&self, t: f32) -> Vec3 {
        Vec3::new(
            self.a.x + t * self.d.x,
            self.a.y + t * self.d.y,
            self.a.z + t * self.d.z,
        )
    }
}

/// Result class of one ray against one CMO.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Status {
    /// The ray met the surface.
    Hit,
    /// The ray went behind the profile at `t` (this CMO can't see the rest).
    Behind,
    /// The ray stayed in front of the profile up to `t_hi`.
    #[default]
    Escaped,
}

/// Work done for one ray.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counters {
    /// Texels whose interval and distance were tested.
    pub texels: u32,
    /// Hierarchy cells tested (interval + range test).
    pub cells: u32,
    /// Descents into a child cell.
    pub descents: u32,
    /// Returns to a parent cell after its child held nothing.
    pub backtracks: u32,
    /// Candidate triangles intersected (the `bounded` criterion, [`bounded`]).
    pub triangles: u32,
    /// Texels whose candidate list the `bounded` criterion walked (its budget,
    /// [`bounded::WALK_BUDGET`]).
    pub walks: u32,
}

/// What one ray found in one CMO.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceResult {
    /// Hit, behind or escaped.
    pub status: Status,
    /// Hit parameter, the `t_b` of behind, or `t_hi` when escaped.
    pub t: f32,
    /// The deciding texel (hit texel, or the occluding texel for behind); default if escaped.
    pub texel: Texel,
    /// Hit on the riser between two patches (rather than inside a patch).
    pub riser: bool,
    /// `a + t d` (CMO-local).
    pub point: Vec3,
    /// Work done.
    pub counters: Counters,
    /// The `bounded` criterion's hit: the triangle ([`bounded::NO_TRIANGLE`] otherwise) and
    /// its barycentric weights.
    pub triangle: u32,
    pub bary: [f32; 3],
}

impl Default for TraceResult {
    fn default() -> Self {
        TraceResult {
            status: Status::default(),
            t: 0.0,
            texel: Texel::default(),
            riser: false,
            point: Vec3::ZERO,
            counters: Counters::default(),
            triangle: bounded::NO_TRIANGLE,
            bary: [0.0; 3],
        }
    }
}

/// Tracer options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceParams {
    /// `k` of the continuity rule: `tan` of the steepest surface slope (angle between the
    /// surface normal and the direction from the CMO centre) still treated as continuous.
    /// Default `tan(80 deg) = 5.671`.
    pub continuity_k: f32,
    /// Patch hits count only when decisive (module docs, "Decisive patch hits"); default off.
    pub strict: bool,
}

impl Default for TraceParams {
    fn default() -> Self {
        TraceParams {
            continuity_k: 5.671_282,
            strict: false,
        }
    }
}

/// A CMO prepared for tracing: the capture, its two hierarchies and the near-centre radius.
#[derive(Debug, Clone)]
pub struct CmoTracer {
    /// The capture.
    pub cube: CubeMap,
    /// 2x2 pyramid (fragment path).
    pub mip: MipPyramid,
    /// 8x4/4x8 hierarchy (compute path).
    pub hier: Hier32,
    /// Half the smallest stored distance: the ray is in front of everything inside it.
    pub cut_radius: f32,
    /// Options.
    pub params: TraceParams,
    /// The `bounded` criterion's lists ([`bounded`]): with them every texel is classified by
    /// [`bounded::classify_bounded`], and `cube.distance` holds the texels' lower bounds.
    pub bounded: Option<Box<bounded::Bounded>>,
}

impl CmoTracer {
    /// Builds both hierarchies.
    pub fn new(cube: CubeMap, params: TraceParams) -> CmoTracer {
        let mip = MipPyramid::build(&cube);
        let hier = Hier32::build(&cube);
        let m = cube.min_distance();
        let cut_radius = if m.is_finite() && m > 0.0 {
            0.5 * m
        } else {
            0.0
        };
        CmoTracer {
            cube,
            mip,
            hier,
            cut_radius,
            params,
            bounded: None,
        }
    }

    /// A tracer of the `bounded` criterion: the capture's lists with the scene's triangle
    /// corners (world space, global order); the distance is the lists' per-texel lower bound.
    pub fn bounded(
        centre: Vec3,
        lists: crate::cubemap::bounds::TexelLists,
        corners: Vec<[Vec3; 3]>,
        params: TraceParams,
    ) -> CmoTracer {
        let mut cube = CubeMap::new(lists.size, centre);
        cube.distance.clone_from(&lists.lo);
        let mut tr = CmoTracer::new(cube, params);
        tr.bounded = Some(Box::new(bounded::Bounded::new(lists, corners)));
        tr
    }
}

/// Up to two `[lo, hi]` pieces of a segment, in order.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pieces {
    /// Number of valid pieces (0..=2).
    pub count: u32,
    /// The pieces.
    pub range: [[f32; 2]; 2],
}

/// Removes the stretch where `r < radius` (see module docs). Pieces have positive length.
pub fn split_near_centre(seg: &Segment, radius: f32) -> Pieces {
    let mut out = Pieces::default();
    let mut push = |lo: f32, hi: f32| {
        if lo < hi {
            out.range[out.count as usize] = [lo, hi];
            out.count += 1;
        }
    };
    let dd = seg.d.x * seg.d.x + seg.d.y * seg.d.y + seg.d.z * seg.d.z;
    let ts = -(seg.a.x * seg.d.x + seg.a.y * seg.d.y + seg.a.z * seg.d.z) / dd;
    let q = seg.at(ts);
    let q2 = q.x * q.x + q.y * q.y + q.z * q.z;
    let r2 = radius * radius;
    if q2 < r2 {
        let h = ((r2 - q2) / dd).sqrt();
        push(seg.t_lo, seg.t_hi.min(ts - h));
        push(seg.t_lo.max(ts + h), seg.t_hi);
    } else {
        push(seg.t_lo, seg.t_hi);
    }
    out
}

/// The faces a piece crosses, in order of entry `t` (ties: lower face index first).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaceList {
    /// Number of faces (0..=6; at most 4 for a piece that avoids the centre).
    pub count: u32,
    /// Face indices.
    pub face: [u32; 6],
    /// The piece's interval in each face.
    pub iv: [Interval; 6],
}

/// Faces crossed by `seg` over `[lo, hi]`, in order of entry ([`face_order`]).
pub fn faces_crossed(seg: &Segment, lo: f32, hi: f32, size: u32) -> FaceList {
    let iv: [Interval; 6] = std::array::from_fn(|f| {
        let f = f as u32;
        cell_interval(
            to_face_local(f, seg.a),
            to_face_local(f, seg.d),
            &CellRect::face(f, size),
            lo,
            hi,
        )
    });
    face_order(&iv)
}

/// The faces whose interval `iv[f]` is crossed, sorted by entry `t0` with ties in face order:
/// each inserted in index order after the faces of no larger `t0` (a stable insertion sort).
/// The shaders reach the same list by a sorting network on the keys `(t0, face)`
/// (`spirv/shared/trace.wgsl`'s `face_order`).
pub fn face_order(iv: &[Interval; 6]) -> FaceList {
    let mut fl = FaceList {
        count: 0,
        face: [0; 6],
        iv: [Interval::EMPTY; 6],
    };
    for (f, &iv) in (0u32..).zip(iv) {
        if iv.crosses() {
            let mut k = fl.count as usize;
            while k > 0 && fl.iv[k - 1].t0 > iv.t0 {
                fl.face[k] = fl.face[k - 1];
                fl.iv[k] = fl.iv[k - 1];
                k -= 1;
            }
            fl.face[k] = f;
            fl.iv[k] = iv;
            fl.count += 1;
        }
    }
    fl
}

/// The texel interval every traversal uses (bit-identical across them).
pub fn texel_interval(seg: &Segment, texel: Texel, size: u32, lo: f32, hi: f32) -> Interval {
    cell_interval(
        to_face_local(texel.face, seg.a),
        to_face_local(texel.face, seg.d),
        &CellRect::texel(texel.face, texel.x, texel.y, size),
        lo,
        hi,
    )
}

/// Whether a texel crossed over `iv` is not entirely in front (`rmax >= D`): a candidate.
pub fn texel_not_in_front(seg: &Segment, iv: &Interval, d: f32) -> bool {
    iv.crosses() && r_at(seg.a, seg.d, iv.t0).max(r_at(seg.a, seg.d, iv.t1)) >= d
}

/// Continuity rule: patches at `d_prev` and `d` whose texel centres are a chord `chord` apart
/// (unit directions; the chord is within 0.5% of the angle for texels under 10 degrees) are one
/// surface iff `|d_prev - d| <= k * max(d_prev, d) * chord`. A surface whose normal makes an
/// angle `psi` with the direction from the centre changes its distance by `D tan(psi)` per
/// radian, so `k = tan(psi_max)`; steeper steps are silhouettes (and an infinite `d_prev`,
/// the background, is always one).
pub fn continuous(d_prev: f32, d: f32, chord: f32, k: f32) -> bool {
    d_prev.is_finite() && d.is_finite() && (d_prev - d).abs() <= k * d_prev.max(d) * chord
}

/// [`continuous`] between `texel` (distance `d`) and its neighbour `nb`, with the chord between
/// their centre directions.
fn continuous_with(tr: &CmoTracer, texel: Texel, d: f32, nb: Texel) -> bool {
    let chord = (texel_centre_dir(texel, tr.cube.size).normalize()
        - texel_centre_dir(nb, tr.cube.size).normalize())
    .length();
    continuous(tr.cube.distance_at(nb), d, chord, tr.params.continuity_k)
}

/// Whether a patch hit at `t` in `texel` (distance `d`, crossed over `iv`) is decisive (module
/// docs, "Decisive patch hits"): the hit point's quadrant of the texel (the side of the centre
/// it lies on in `u` and in `v`) names the two side neighbours whose samples, with the texel's,
/// surround the hit direction; both must be continuous with the texel, and the ray must reach
/// the largest of the three distances within the texel.
fn decisive_patch_hit(
    tr: &CmoTracer,
    seg: &Segment,
    texel: Texel,
    iv: &Interval,
    d: f32,
    t: f32,
) -> bool {
    let n = tr.cube.size;
    let l = to_face_local(texel.face, seg.at(t));
    let u = l.x / l.z;
    let v = l.y / l.z;
    let uc = (2 * texel.x + 1) as f32 / n as f32 - 1.0;
    let vc = (2 * texel.y + 1) as f32 / n as f32 - 1.0;
    let sides = [if u < uc { 0 } else { 1 }, if v < vc { 2 } else { 3 }];
    let mut d_hi = d;
    for side in sides {
        let nb = neighbour_across(texel, side, n);
        if !continuous_with(tr, texel, d, nb) {
            return false;
        }
        d_hi = d_hi.max(0.5 * (d + tr.cube.distance_at(nb)));
    }
    r_at(seg.a, seg.d, iv.t0).max(r_at(seg.a, seg.d, iv.t1)) >= d_hi
}

/// Outcome of classifying the first not-in-front texel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// Hit at `t` (riser: on the step joining two patches).
    Hit {
        /// Ray parameter.
        t: f32,
        /// On a riser.
        riser: bool,
    },
    /// Behind the profile from `t` on.
    Behind {
        /// Ray parameter.
        t: f32,
    },
    /// The `bounded` criterion's hit on a candidate triangle ([`bounded`]).
    Candidate(bounded::BoundedHit),
}

/// Classifies texel `texel` crossed over `iv` (see module docs); `None` if it is entirely in
/// front, or not crossed.
/// `counters` gains the candidate triangles the `bounded` criterion tests.
pub fn classify(
    tr: &CmoTracer,
    seg: &Segment,
    texel: Texel,
    iv: &Interval,
    counters: &mut Counters,
) -> Option<Outcome> {
    if let Some(b) = &tr.bounded {
        return bounded::classify_bounded(tr, b, seg, texel, iv, counters);
    }
    let d = tr.cube.distance_at(texel);
    if !texel_not_in_front(seg, iv, d) {
        return None;
    }
    let r0 = r_at(seg.a, seg.d, iv.t0);
    if r0 <= d {
        // First root after t0 of |a + t d| = D: the larger root, since r(t0) <= D and r is convex.
        let dd = seg.d.x * seg.d.x + seg.d.y * seg.d.y + seg.d.z * seg.d.z;
        let ts = -(seg.a.x * seg.d.x + seg.a.y * seg.d.y + seg.a.z * seg.d.z) / dd;
        let q = seg.at(ts);
        let q2 = q.x * q.x + q.y * q.y + q.z * q.z;
        let t = (ts + ((d * d - q2).max(0.0) / dd).sqrt()).clamp(iv.t0, iv.t1);
        if !tr.params.strict || decisive_patch_hit(tr, seg, texel, iv, d, t) {
            return Some(Outcome::Hit { t, riser: false });
        }
        return Some(Outcome::Behind { t: iv.t0 });
    }
    if iv.entry == SIDE_SEGMENT || iv.entry > SIDE_Y1 {
        return Some(Outcome::Behind { t: iv.t0 });
    }
    let prev = neighbour_across(texel, iv.entry - SIDE_X0, tr.cube.size);
    if continuous_with(tr, texel, d, prev) {
        Some(Outcome::Hit {
            t: iv.t0,
            riser: true,
        })
    } else {
        Some(Outcome::Behind { t: iv.t0 })
    }
}

/// Builds the result for an outcome.
pub fn finish(seg: &Segment, texel: Texel, o: Outcome, counters: Counters) -> TraceResult {
    let (status, t, riser) = match o {
        Outcome::Hit { t, riser } => (Status::Hit, t, riser),
        Outcome::Behind { t } => (Status::Behind, t, false),
        Outcome::Candidate(h) => (Status::Hit, h.t, false),
    };
    let (triangle, bary) = match o {
        Outcome::Candidate(h) => (h.triangle, h.bary),
        _ => (bounded::NO_TRIANGLE, [0.0; 3]),
    };
    TraceResult {
        status,
        t,
        texel,
        riser,
        point: seg.at(t),
        counters,
        triangle,
        bary,
    }
}

/// The escaped result.
pub fn escaped(seg: &Segment, counters: Counters) -> TraceResult {
    TraceResult {
        status: Status::Escaped,
        t: seg.t_hi,
        point: seg.at(seg.t_hi),
        counters,
        ..TraceResult::default()
    }
}

/// The texel of `face` whose interval contains or follows `t` (a boundary the ray is on): the
/// lookup of `p(t)` and its 3x3 neighbourhood, keeping crossed texels with `t1 > t`, smallest
/// `t0` first (ties: row-major order). `None` when the ray has left the face there.
pub fn locate(
    seg: &Segment,
    face: u32,
    t: f32,
    size: u32,
    lo: f32,
    hi: f32,
) -> Option<(Texel, Interval)> {
    locate_counted(seg, face, t, size, lo, hi).0
}

/// [`locate`], and whether its 3x3 search ran.
pub fn locate_counted(
    seg: &Segment,
    face: u32,
    t: f32,
    size: u32,
    lo: f32,
    hi: f32,
) -> (Option<(Texel, Interval)>, bool) {
    locate_around(
        seg,
        face,
        locate_centre(seg, face, t, size),
        t,
        size,
        lo,
        hi,
    )
}

/// The texel [`locate`] searches around for `t`: the one `p(t)` projects to, or the face's
/// middle where `p(t)` is not in front of the face.
pub fn locate_centre(seg: &Segment, face: u32, t: f32, size: u32) -> (u32, u32) {
    let l = to_face_local(face, seg.at(t));
    if l.z > 0.0 {
        (
            st_to_texel_coord(0.5 * (l.x / l.z + 1.0), size),
            st_to_texel_coord(0.5 * (l.y / l.z + 1.0), size),
        )
    } else {
        (size / 2, size / 2)
    }
}

/// [`texel_search`] around `centre` (no `ahead`), the centre's certificate first
/// ([`certified`]: where it holds, the centre is the search's answer, and the 3x3 search is
/// not run); with whether the 3x3 search ran.
#[allow(clippy::too_many_arguments)]
pub fn locate_around(
    seg: &Segment,
    face: u32,
    centre: (u32, u32),
    t: f32,
    size: u32,
    lo: f32,
    hi: f32,
) -> (Option<(Texel, Interval)>, bool) {
    let tex = Texel {
        face,
        x: centre.0,
        y: centre.1,
    };
    match certified(seg, tex, t, size, lo, hi) {
        Some(iv) => (Some((tex, iv)), false),
        None => (texel_search(seg, face, centre, None, t, size, lo, hi), true),
    }
}

/// The texel the march resumes at after skipping `cell` (its interval `civ`; `t`: where the
/// march resumes, `civ.t1` or the current texel's exit if later). Where the ray leaves the
/// cell at `t` through a side, the texel across that side (at `p(t)`'s other coordinate,
/// clamped into the cell's span) is searched around ([`locate_around`]: the ray enters it at
/// `t`, so its certificate holds but at a corner), and a side on the face's edge ends the face
/// (`None`); otherwise [`locate`].
///
/// This is the reference the shader's march follows (`mip_turn`). It is not [`locate`]'s 3x3
/// around `p(t)` by construction, only by geometry: the ray crosses the cell's side plane at
/// `t`, so the texel entered there is the one across the side (inside the 3x3 around `p(t)`,
/// which rounds to either side of the plane), and past a face edge the face's frustum, convex,
/// is left for good. Checked against [`locate`] on every skip of the cost model's frames of
/// scene `default` (160x120: 94573 of 94573 skips through a side found the same texel, 10463
/// of 10463 on a face's edge where [`locate`] found none), on every cell of levels 1 to 5
/// crossed by a few hundred rays in `tests/tracer/texel_search.rs`, and by the images of
/// every tracer that marches the pyramid, which did not change. With whether a 3x3 search
/// ran.
#[allow(clippy::too_many_arguments)]
pub fn locate_after_skip(
    seg: &Segment,
    cell: &CellRect,
    civ: &Interval,
    t: f32,
    size: u32,
    lo: f32,
    hi: f32,
) -> (Option<(Texel, Interval)>, bool) {
    let face = cell.face;
    if !(civ.crosses() && civ.t1 == t && civ.exit < SIDE_Z) {
        return locate_counted(seg, face, t, size, lo, hi);
    }
    let (cx, cy) = locate_centre(seg, face, t, size);
    let (x, y) = match civ.exit {
        SIDE_X0 => (cell.x0 as i64 - 1, cy.clamp(cell.y0, cell.y1 - 1) as i64),
        SIDE_X1 => (cell.x1 as i64, cy.clamp(cell.y0, cell.y1 - 1) as i64),
        SIDE_Y0 => (cx.clamp(cell.x0, cell.x1 - 1) as i64, cell.y0 as i64 - 1),
        _ => (cx.clamp(cell.x0, cell.x1 - 1) as i64, cell.y1 as i64),
    };
    let n = size as i64;
    if x < 0 || y < 0 || x >= n || y >= n {
        return (None, false);
    }
    locate_around(seg, face, (x as u32, y as u32), t, size, lo, hi)
}

/// The interval of `tex` where it is the answer of every 3x3 [`texel_search`] around it (and of
/// an `ahead` search around a neighbour of it, [`next_texel`]) that holds it: `tex` crossed,
/// with `t0 <= t < t1`. Proof: let M be another candidate with `t1 > t` that would win, so
/// `M.t0 <= tex.t0 <= t`. M is adjacent to `tex` (both lie in one 3x3 block and M is not two
/// columns or rows away, see the callers), so a column or row boundary P separates them,
/// and both clip by P from the same plane, `(al, be)` for `tex` and `(-al, -be)` for M:
/// `a - b` and `b - a` are exact negations, and so are `-al / be` and `al / -be`, so one bound
/// `b` in the same bits (`+0` and `-0` compare equal). Where `be < 0` for `tex`, `tex.t1 <= b
/// <= M.t0`, so `M.t0 >= tex.t1 > tex.t0 >= M.t0`: impossible. Where `be > 0`, `M.t1 <= b <=
/// tex.t0 <= t`: M is not kept by `t1 > t`. Where `be` is 0 or NaN, `tex` crossing means `al`
/// is positive, or 0 with P owned by `tex`, so M (`-al`, not owning P: the sides between two
/// texels of a face belong to one of them) is dropped. So no other candidate has `t0 <=
/// tex.t0`: `tex` is the unique smallest entry, whatever the row order. The steps above hold
/// for infinite bounds too, not for NaN ones (a NaN bound constrains neither side, so two
/// texels can both hold the ray): `b` is NaN only where `al` or `be` is, or both are
/// infinite. So the certificate asks every component of the ray's `a` and `d` to be below
/// [`CERTIFIED_LIMIT`] in magnitude: then `al` and `be` (`|f| <= 1`) are finite. A NaN
/// anywhere else fails a comparison of the certificate, which then does not hold.
pub fn certified(
    seg: &Segment,
    tex: Texel,
    t: f32,
    size: u32,
    lo: f32,
    hi: f32,
) -> Option<Interval> {
    let limit = Vec3::splat(CERTIFIED_LIMIT);
    let planes_finite = seg.a.abs().cmplt(limit).all() && seg.d.abs().cmplt(limit).all();
    let iv = texel_interval(seg, tex, size, lo, hi);
    (planes_finite && iv.crosses() && iv.t1 > t && iv.t0 <= t).then_some(iv)
}

/// [`certified`]'s bound on the ray's components, 2^126: `x - f z` with `|x|, |z|` below it
/// and `|f| <= 1` stays below `f32::MAX`.
pub const CERTIFIED_LIMIT: f32 = 8.507059e37;

/// The next texel after `cur` (crossed over `iv`) within its face: among the neighbours in the
/// projected direction of motion (`du/dt`, `dv/dt` have a constant sign on a face), the crossed
/// one with `t1 > iv.t1` and the smallest `t0`. `None` at the end of the face or segment.
///
/// The texel across `cur`'s exit side is tried first ([`certified`]): where its sign of
/// motion across that side is strictly positive, the neighbours on the other side of `cur` are
/// not candidates, so every candidate is adjacent to it, and where its certificate holds it is
/// the search's answer. Otherwise the 3x3 search runs.
pub fn next_texel(
    seg: &Segment,
    cur: Texel,
    iv: &Interval,
    size: u32,
    lo: f32,
    hi: f32,
) -> Option<(Texel, Interval)> {
    next_texel_counted(seg, cur, iv, size, lo, hi).0
}

/// [`next_texel`], and whether its 3x3 search ran.
pub fn next_texel_counted(
    seg: &Segment,
    cur: Texel,
    iv: &Interval,
    size: u32,
    lo: f32,
    hi: f32,
) -> (Option<(Texel, Interval)>, bool) {
    let la = to_face_local(cur.face, seg.a);
    let ld = to_face_local(cur.face, seg.d);
    let mx = ld.x * la.z - la.x * ld.z;
    let my = ld.y * la.z - la.y * ld.z;
    if let Some(tex) = across_exit(cur, iv.exit, mx, my, size)
        && let Some(next) = certified(seg, tex, iv.t1, size, lo, hi)
    {
        return (Some((tex, next)), false);
    }
    let found = texel_search(
        seg,
        cur.face,
        (cur.x, cur.y),
        Some((mx, my)),
        iv.t1,
        size,
        lo,
        hi,
    );
    (found, true)
}

/// The texel across side `exit` of `cur`, where it is on the face and the ray moves across
/// that side strictly (`mx`, `my`: [`next_texel`]'s signs of motion).
pub fn across_exit(cur: Texel, exit: u32, mx: f32, my: f32, size: u32) -> Option<Texel> {
    let (dx, dy) = match exit {
        SIDE_X0 => (-1, 0),
        SIDE_X1 => (1, 0),
        SIDE_Y0 => (0, -1),
        SIDE_Y1 => (0, 1),
        _ => return None,
    };
    let x = cur.x as i64 + dx as i64;
    let y = cur.y as i64 + dy as i64;
    let n = size as i64;
    let strict = (dx as f32) * mx > 0.0 || (dy as f32) * my > 0.0;
    (strict && x >= 0 && y >= 0 && x < n && y < n).then_some(Texel {
        face: cur.face,
        x: x as u32,
        y: y as u32,
    })
}

/// The 3x3 texel search of [`locate`] and [`next_texel`] (the shader's `texel_search`): of the
/// texels of `face` around `centre` (with `ahead` = `Some((mx, my))`, only the 8 neighbours on
/// the ray's side of the centre, by the signs of `mx`, `my`), the crossed one with the smallest
/// `t0` among those with `t1 > t` (the first in row order on ties).
///
/// The neighbourhood's distinct planes are clipped once: each column's two x planes, each row's
/// two y planes and the face's z plane, 13 divisions instead of the 45 of nine
/// [`texel_interval`]s. Each candidate's interval is still [`texel_interval`]'s, bit for bit:
/// [`cell_interval`] clips `[lo, hi]` by the planes x0, x1, y0, y1, z in that order
/// ([`Clip::plane`]); its first two steps depend on the column alone and are the same calls on
/// the same operands here (the column's `Clip`). What [`Clip::plane`] does with a plane to any
/// interval depends on the plane alone (`b = -al / be` compared with `t0` or `t1`, or the
/// half-open test where `be` is 0 or NaN), so the row planes and the z plane are clipped once
/// ([`PlaneBound::new`], the same f32 operations) and applied per candidate by
/// [`Clip::bound`], the same comparisons in the same plane order. Nothing is reordered and no
/// min/max is taken: ties (the earlier plane keeps an end, `+0` against `-0` included), the
/// entry and exit sides, NaN bounds (they fail every comparison) and the dropped intervals
/// ([`Interval::EMPTY`]) come out as [`texel_interval`] makes them.
#[allow(clippy::too_many_arguments)]
pub fn texel_search(
    seg: &Segment,
    face: u32,
    centre: (u32, u32),
    ahead: Option<(f32, f32)>,
    t: f32,
    size: u32,
    lo: f32,
    hi: f32,
) -> Option<(Texel, Interval)> {
    let la = to_face_local(face, seg.a);
    let ld = to_face_local(face, seg.d);
    let edge = edge_inclusive(face);
    let n = size;
    // Column or row `i` (offset i - 1) of the centre `c`, where it lies on the face.
    let on_face = |c: u32, i: usize| {
        let k = c as i64 + i as i64 - 1;
        (k >= 0 && k < n as i64).then_some(k as u32)
    };
    let start = Clip::new(lo, hi);
    let cols: [Option<Clip>; 3] = std::array::from_fn(|i| {
        on_face(centre.0, i).map(|x| {
            let (f0, f1) = (face_coord(x, n), face_coord(x + 1, n));
            let inc0 = if x == 0 { edge[0] } else { true };
            let inc1 = if x + 1 == n { edge[1] } else { false };
            start
                .plane(la.x - f0 * la.z, ld.x - f0 * ld.z, inc0, SIDE_X0)
                .plane(f1 * la.z - la.x, f1 * ld.z - ld.x, inc1, SIDE_X1)
        })
    });
    let rows: [Option<(PlaneBound, PlaneBound)>; 3] = std::array::from_fn(|i| {
        on_face(centre.1, i).map(|y| {
            let (f0, f1) = (face_coord(y, n), face_coord(y + 1, n));
            let inc0 = if y == 0 { edge[2] } else { true };
            let inc1 = if y + 1 == n { edge[3] } else { false };
            (
                PlaneBound::new(la.y - f0 * la.z, ld.y - f0 * ld.z, inc0),
                PlaneBound::new(f1 * la.z - la.y, f1 * ld.z - ld.y, inc1),
            )
        })
    });
    let z = PlaneBound::new(la.z, ld.z, false);
    let mut best: Option<(Texel, Interval)> = None;
    for dy in -1i32..=1 {
        for dx in -1i32..=1 {
            if let Some((mx, my)) = ahead
                && ((dx == 0 && dy == 0) || (dx as f32) * mx < 0.0 || (dy as f32) * my < 0.0)
            {
                continue;
            }
            let (Some(col), Some((y0, y1))) = (cols[(dx + 1) as usize], rows[(dy + 1) as usize])
            else {
                continue;
            };
            let iv = col
                .bound(y0, SIDE_Y0)
                .bound(y1, SIDE_Y1)
                .bound(z, SIDE_Z)
                .interval();
            if iv.crosses() && iv.t1 > t && best.is_none_or(|(_, b)| iv.t0 < b.t0) {
                let tex = Texel {
                    face,
                    x: (centre.0 as i32 + dx) as u32,
                    y: (centre.1 as i32 + dy) as u32,
                };
                best = Some((tex, iv));
            }
        }
    }
    best
}

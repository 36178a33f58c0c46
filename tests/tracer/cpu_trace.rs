//! CPU tracer tests on analytic cube maps: a box room with a floating box occluder.
//!
//! Every comparison has a negative twin that perturbs one input and must see the comparison fail.

use crate::common;
use common::Rng;
use common::analytic::{Aabb, enter_box, exit_box};

use cubetrace::cpu::approx::{Criterion, Sampling, trace_sampled};
use cubetrace::cpu::compute::{SUBGROUP_SIZES, trace_alg3};
use cubetrace::cpu::mip::trace_mip;
use cubetrace::cpu::multi::{MultiStatus, Traversal, trace_cmos};
use cubetrace::cpu::walk::{trace_brute, trace_walk};
use cubetrace::cpu::{CmoTracer, Segment, Status, TraceParams, TraceResult};
use cubetrace::cubemap::CubeMap;
use cubetrace::cubemap::face::{
    Texel, dir_to_texel, face_coord, from_face_local, neighbour_across,
};
use glam::Vec3;

const ROOM: Aabb = Aabb {
    lo: Vec3::new(-3.0, -2.0, -4.0),
    hi: Vec3::new(3.0, 2.5, 4.0),
};
const OCCLUDER: Aabb = Aabb {
    lo: Vec3::new(0.6, -0.7, 1.2),
    hi: Vec3::new(1.8, 0.5, 2.2),
};
const CENTRE: Vec3 = Vec3::new(0.3, -0.2, 0.4);

/// First scene hit along `o + t d` (unit `d`), `t > 0`.
fn scene_hit(o: Vec3, d: Vec3, with_occluder: bool) -> f32 {
    let t = exit_box(ROOM, o, d);
    if with_occluder {
        t.min(enter_box(OCCLUDER, o, d))
    } else {
        t
    }
}

fn capture(size: u32, centre: Vec3, with_occluder: bool) -> CubeMap {
    let mut c = CubeMap::new(size, centre);
    c.fill(|t, dir| {
        let d = scene_hit(centre, dir, with_occluder);
        (d, [t.face as f32, t.x as f32, t.y as f32, 1.0])
    });
    c
}

/// World rays `(origin, unit dir)` from inside the room, outside the occluder.
fn rays(seed: u64, count: usize) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng(seed);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let o = Vec3::new(
            rng.range(-2.7, 2.7),
            rng.range(-1.7, 2.2),
            rng.range(-3.7, 3.7),
        );
        if o.cmpge(OCCLUDER.lo - 0.1).all() && o.cmple(OCCLUDER.hi + 0.1).all() {
            continue;
        }
        out.push((o, rng.unit()));
    }
    out
}

const T_HI: f32 = 20.0;

fn segment(tr: &CmoTracer, o: Vec3, d: Vec3) -> Segment {
    Segment {
        a: o - tr.cube.centre,
        d,
        t_lo: 0.0,
        t_hi: T_HI,
        from: cubetrace::cpu::bounded::NO_TRIANGLE,
    }
}

/// Special rays: through the centre, starting at it, along cube edges and corners (as seen
/// from the centre), parallel to face planes, and long diagonals crossing 4 faces.
fn special_rays(c: Vec3) -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::new();
    for d in [
        Vec3::X,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::ONE,
        Vec3::new(-1.0, 1.0, -1.0),
    ] {
        let d = d.normalize();
        v.push((c, d)); // starts at the centre
        v.push((c - 1.5 * d, d)); // through the centre
        v.push((c - 1.5 * d + Vec3::new(1e-7, -1e-7, 0.0), d)); // within 1e-6 of it
    }
    // Rays lying in face edge planes and texel boundary planes (x = z, y = 0 through c).
    v.push((
        c + Vec3::new(0.5, 0.0, 0.5),
        Vec3::new(0.3, 0.4, 0.3).normalize(),
    ));
    v.push((
        c + Vec3::new(-0.5, 0.0, 0.2),
        Vec3::new(0.2, 0.0, 1.0).normalize(),
    ));
    v.push((
        c + Vec3::new(0.0, 0.2, -0.5),
        Vec3::new(0.0, 0.3, 1.0).normalize(),
    ));
    // Parallel to face planes: along x at a fixed offset in y and z.
    v.push((c + Vec3::new(-2.5, 0.5, 0.5), Vec3::X));
    v.push((c + Vec3::new(0.7, -1.0, 0.3), Vec3::Y));
    // Crossing four faces: a long ray passing near (not through) the centre, diagonally.
    v.push((
        c + Vec3::new(-2.0, -1.2, -0.2),
        Vec3::new(1.0, 0.6, 0.9).normalize(),
    ));
    v.push((
        c + Vec3::new(2.5, 0.3, -3.0),
        Vec3::new(-1.0, 0.2, 1.2).normalize(),
    ));
    v
}

fn same(a: &TraceResult, b: &TraceResult) -> bool {
    a.status == b.status
        && (a.status == Status::Escaped || (a.texel == b.texel && a.t.to_bits() == b.t.to_bits()))
}

/// Counts rays on which the traversals disagree with the per-texel walk.
fn disagreements(tr: &CmoTracer, other: &CmoTracer, rays: &[(Vec3, Vec3)], brute: bool) -> usize {
    let segs: Vec<Segment> = rays.iter().map(|&(o, d)| segment(tr, o, d)).collect();
    let walk: Vec<TraceResult> = segs.iter().map(|s| trace_walk(tr, s)).collect();
    let mut bad = 0;
    let mut alg3: Vec<Vec<TraceResult>> = Vec::new();
    for &sg in &SUBGROUP_SIZES {
        alg3.push(trace_alg3(other, &segs, sg));
    }
    for (i, s) in segs.iter().enumerate() {
        let mut ok = same(&walk[i], &trace_mip(other, s));
        for r in &alg3 {
            ok &= same(&walk[i], &r[i]);
        }
        if brute {
            ok &= same(&walk[i], &trace_brute(other, s));
        }
        if !ok {
            bad += 1;
        }
    }
    bad
}

#[test]
fn traversals_and_subgroup_sizes_agree() {
    for (size, count) in [(1u32, 400usize), (2, 400), (3, 400), (16, 1500), (32, 1500)] {
        let tr = CmoTracer::new(capture(size, CENTRE, true), TraceParams::default());
        let mut rs = rays(size as u64, count);
        rs.extend(special_rays(CENTRE));
        assert_eq!(disagreements(&tr, &tr, &rs, size <= 16), 0, "size {size}");
    }
}

#[test]
fn agreement_check_detects_a_perturbed_input() {
    let tr = CmoTracer::new(capture(16, CENTRE, true), TraceParams::default());
    let mut cube = tr.cube.clone();
    // Push one face's walls out: the other traversals now see another profile.
    for d in cube.distance[..(16 * 16)].iter_mut() {
        *d *= 1.05;
    }
    let other = CmoTracer::new(cube, TraceParams::default());
    assert!(disagreements(&tr, &other, &rays(5, 300), false) > 0);
    // Corrupting the hierarchy alone (a cell claims min > its texels) is also caught.
    let mut broken = tr.clone();
    for c in broken.hier.levels[1].cells.iter_mut() {
        c[0] = 1e9;
    }
    for l in broken.mip.levels.iter_mut().skip(1) {
        for c in l.cells.iter_mut() {
            c[0] = 1e9;
        }
    }
    assert!(disagreements(&tr, &broken, &rays(6, 300), false) > 0);
}

/// Whether `q` (on a scene surface) is hidden from `c` by something nearer.
fn hidden_from(c: Vec3, q: Vec3) -> bool {
    let v = q - c;
    let dist = v.length();
    scene_hit(c, v / dist, true) < dist - 1e-3
}

/// Whether the scene point `p` is seen from `c`, or `None` when points of the same surface
/// within `margin * |p - c|` disagree (a silhouette crosses the texel there).
fn visible_from(c: Vec3, p: Vec3, margin: f32) -> Option<bool> {
    let on = |k: usize| {
        [ROOM.lo[k], ROOM.hi[k], OCCLUDER.lo[k], OCCLUDER.hi[k]]
            .iter()
            .any(|b| (p[k] - b).abs() < 1e-3)
    };
    let normal = (0..3).find(|&k| on(k)).unwrap_or(0);
    let (e1, e2) = (Vec3::AXES[(normal + 1) % 3], Vec3::AXES[(normal + 2) % 3]);
    let delta = margin * (p - c).length();
    let hidden = hidden_from(c, p);
    for (i, j) in [
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (0.0, -1.0),
        (1.0, 1.0),
        (-1.0, -1.0),
        (1.0, -1.0),
        (-1.0, 1.0),
    ] {
        if hidden_from(c, p + delta * (i * e1 + j * e2)) != hidden {
            return None;
        }
    }
    Some(!hidden)
}

/// Accuracy of exact hits against the analytic scene, in texel footprints at the hit
/// (`|p_hit - p_true| / (|p_true - c| * 2 / N)`), and silhouette safety.
/// Returns (hits, hits within `k_fp` footprints, behind, hits on points hidden from c).
fn accuracy(tr: &CmoTracer, rays: &[(Vec3, Vec3)], k_fp: f32) -> (usize, usize, usize, usize) {
    let n = tr.cube.size as f32;
    let c = tr.cube.centre;
    let (mut hits, mut good, mut behind, mut hidden_hits) = (0, 0, 0, 0);
    for &(o, d) in rays {
        let s = segment(tr, o, d);
        let r = trace_walk(tr, &s);
        let t_true = scene_hit(o, d, true);
        let p_true = o + t_true * d;
        let vis = visible_from(c, p_true, 4.0 / n);
        match r.status {
            Status::Hit => {
                hits += 1;
                let p = r.point + c;
                let fp = (p_true - c).length() * 2.0 / n;
                if (p - p_true).length() <= k_fp * fp {
                    good += 1;
                }
                if vis == Some(false) {
                    eprintln!(
                        "hidden hit: o {o:?} d {d:?} r {r:?} p_true {p_true:?} t_true {t_true}"
                    );
                    hidden_hits += 1;
                }
            }
            Status::Behind => behind += 1,
            Status::Escaped => {}
        }
    }
    (hits, good, behind, hidden_hits)
}

#[test]
fn hits_match_the_analytic_scene() {
    // Measured at N = 64 over 3000 rays: 99.5% of hits within 3 footprints; the rest are
    // grazing walls seen at > 75 degrees from the centre, where a sphere patch is a poor plane.
    let tr = CmoTracer::new(capture(64, CENTRE, true), TraceParams::default());
    let rs = rays(42, 3000);
    let (hits, good, behind, hidden) = accuracy(&tr, &rs, 3.0);
    eprintln!("hits {hits} good {good} behind {behind} hidden {hidden}");
    assert!(hits > 2000);
    assert!(good as f32 >= 0.98 * hits as f32, "{good}/{hits}");
    assert_eq!(hidden, 0, "a ray passing behind the occluder became a hit");
    assert!(
        behind > 0,
        "no ray went behind the occluder: the test lost its point"
    );
}

#[test]
fn accuracy_check_detects_wrong_distances() {
    let mut cube = capture(64, CENTRE, true);
    for d in cube.distance.iter_mut() {
        *d *= 1.1;
    }
    let tr = CmoTracer::new(cube, TraceParams::default());
    let (hits, good, _, _) = accuracy(&tr, &rays(42, 1000), 3.0);
    assert!((good as f32) < 0.98 * hits as f32);
}

#[test]
fn silhouettes_are_not_hits_without_the_continuity_rule_they_are() {
    let rs = rays(9, 3000);
    let tr = CmoTracer::new(capture(64, CENTRE, true), TraceParams::default());
    assert_eq!(accuracy(&tr, &rs, 3.0).3, 0);
    // Negative: treat every step as continuous and silhouettes become (wrong) hits.
    let loose = CmoTracer::new(
        capture(64, CENTRE, true),
        TraceParams {
            continuity_k: 1e9,
            ..TraceParams::default()
        },
    );
    assert!(accuracy(&loose, &rs, 3.0).3 > 0);
}

/// Points per texel side where [`depth_range`] samples the room's distance.
const SIDE_SAMPLES: u32 = 64;

/// The range `[lo, hi]` of the empty room's distance from `CENTRE` over the directions of
/// `texel`'s frustum (a cube map of `size` centred there).
///
/// Why this is the whole range: the frustum is a convex cone and the room a convex box, so
/// their intersection is a convex polytope. The farthest point of a polytope from the apex is
/// one of its vertices: a cone edge on a wall (a texel corner direction), a cone side crossing
/// a room edge (a direction on a texel side) or a room corner inside the cone. The nearest
/// point of the walls inside the cone is a wall's foot of the perpendicular, a room edge's
/// nearest point, or on a cone side. The sides are sampled at [`SIDE_SAMPLES`] points each
/// (corners included); the rest are the 8 + 6 + 12 points themselves, where inside the texel.
fn depth_range(texel: Texel, size: u32) -> (f32, f32) {
    let depth = |dir: Vec3| exit_box(ROOM, CENTRE, dir.normalize());
    let mut dirs = Vec::new();
    for k in 0..=SIDE_SAMPLES {
        let f = k as f32 / SIDE_SAMPLES as f32;
        let (u0, u1) = (face_coord(texel.x, size), face_coord(texel.x + 1, size));
        let (v0, v1) = (face_coord(texel.y, size), face_coord(texel.y + 1, size));
        let (u, v) = (u0 + f * (u1 - u0), v0 + f * (v1 - v0));
        for (a, b) in [(u, v0), (u, v1), (u0, v), (u1, v)] {
            dirs.push(from_face_local(texel.face, Vec3::new(a, b, 1.0)));
        }
    }
    let (lo, hi) = (ROOM.lo - CENTRE, ROOM.hi - CENTRE);
    let pick = |i: usize, k: usize| if (i >> k) & 1 == 0 { lo[k] } else { hi[k] };
    let mut inner: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new(pick(i, 0), pick(i, 1), pick(i, 2)))
        .collect();
    for k in 0..3 {
        for wall in [lo[k], hi[k]] {
            let mut foot = Vec3::ZERO;
            foot[k] = wall;
            inner.push(foot);
        }
        // The room edges along axis k: nearest to the centre where the axis coordinate is 0.
        for i in 0..4 {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let mut e = Vec3::ZERO;
            e[a] = if i & 1 == 0 { lo[a] } else { hi[a] };
            e[b] = if i & 2 == 0 { lo[b] } else { hi[b] };
            inner.push(e);
        }
    }
    dirs.extend(
        inner
            .into_iter()
            .filter(|&p| dir_to_texel(p, size) == texel),
    );
    dirs.into_iter()
        .map(depth)
        .fold((f32::INFINITY, 0.0f32), |(l, h), d| (l.min(d), h.max(d)))
}

/// How far a hit on `texel` may lie from the true wall, along the line from the centre: the
/// patch sits at the texel's sample, the true wall anywhere in the texel's range, so the range's
/// width bounds the gap (a riser lies between the texel's sample and a side neighbour's: the
/// range over the five). Plus 1e-4 relative for the f32 arithmetic of the trace and of the
/// sampled sides.
fn hit_tolerance(texel: Texel, size: u32, riser: bool) -> f32 {
    let mut texels = vec![texel];
    if riser {
        texels.extend((0..4).map(|side| neighbour_across(texel, side, size)));
    }
    let (lo, hi) = texels
        .into_iter()
        .map(|t| depth_range(t, size))
        .fold((f32::INFINITY, 0.0f32), |(l, h), (a, b)| {
            (l.min(a), h.max(b))
        });
    hi - lo + 1e-4 * hi
}

/// Special rays in the empty room whose hit lies further from the true wall, along the line
/// from the centre through the hit, than [`hit_tolerance`] allows.
fn off_the_wall(tr: &CmoTracer, size: u32) -> usize {
    let mut off = 0;
    for (o, d) in special_rays(CENTRE) {
        let r = trace_walk(tr, &segment(tr, o, d));
        assert_eq!(r.status, Status::Hit, "size {size} {o:?} {d:?}");
        let wall = exit_box(ROOM, CENTRE, r.point.normalize());
        let gap = (r.point.length() - wall).abs();
        let tol = hit_tolerance(r.texel, size, r.riser);
        if gap > tol {
            eprintln!("size {size} {o:?} {d:?}: {gap} from the wall, tolerance {tol}");
            off += 1;
        }
    }
    off
}

#[test]
fn empty_room_from_the_centre() {
    // Every special ray hits the wall within its texel's depth range (`hit_tolerance`). For
    // rays from or through the centre the hit's direction is the ray's, so this is the distance
    // to the analytic hit itself.
    for size in [1u32, 2, 3, 32] {
        let tr = CmoTracer::new(capture(size, CENTRE, false), TraceParams::default());
        assert_eq!(off_the_wall(&tr, size), 0, "size {size}");
        // Axis rays from the centre: exact wall distance for odd N (texel centre on the axis).
        if size % 2 == 1 {
            let r = trace_walk(&tr, &segment(&tr, CENTRE, Vec3::X));
            assert!((r.t - (ROOM.hi.x - CENTRE.x)).abs() < 1e-4, "{}", r.t);
        }
    }
    // Negative: the walls captured 3% too far (the trace's patches off the true walls) put
    // most special rays outside the tolerance at N = 32.
    let mut far = capture(32, CENTRE, false);
    for d in far.distance.iter_mut() {
        *d *= 1.03;
    }
    let off = off_the_wall(&CmoTracer::new(far, TraceParams::default()), 32);
    assert!(off * 2 > special_rays(CENTRE).len(), "{off}");
}

#[test]
fn several_cmos_hand_off_behind_the_occluder() {
    // CMO A sees the room but not behind the occluder; CMO B, on the other side, does.
    let a = CmoTracer::new(capture(64, CENTRE, true), TraceParams::default());
    let b_centre = Vec3::new(1.2, -0.1, 3.4);
    let b = CmoTracer::new(capture(64, b_centre, true), TraceParams::default());
    let rs = rays(77, 2000);
    let mut a_behind = 0;
    let mut resolved_by_b = 0;
    let mut unresolved = 0;
    for &(o, d) in &rs {
        let one = trace_cmos(std::slice::from_ref(&a), o, d, 0.0, T_HI, Traversal::Walk);
        let two = trace_cmos(&[a.clone(), b.clone()], o, d, 0.0, T_HI, Traversal::Alg3(8));
        let walk2 = trace_cmos(&[a.clone(), b.clone()], o, d, 0.0, T_HI, Traversal::Walk);
        assert_eq!(two.status, walk2.status);
        assert_eq!(two.cmo, walk2.cmo);
        if one.status == MultiStatus::Unresolved {
            a_behind += 1;
            match two.status {
                MultiStatus::Hit => {
                    resolved_by_b += 1;
                    let p_true = o + scene_hit(o, d, true) * d;
                    let fp = (p_true - b_centre).length() * 2.0 / 64.0;
                    assert!((two.point - p_true).length() < 8.0 * fp, "{o:?} {d:?}");
                }
                MultiStatus::Unresolved => unresolved += 1,
                MultiStatus::Escaped => panic!("escaped a closed room"),
            }
        }
        if two.status == MultiStatus::Hit {
            assert!(two.t_done <= two.result.t);
        }
    }
    eprintln!("A behind {a_behind}, resolved by B {resolved_by_b}, unresolved {unresolved}");
    assert!(a_behind > 20);
    assert!(resolved_by_b as f32 > 0.8 * a_behind as f32);
}

/// (hits, hits within 3 footprints, hits on points hidden from the CMO) for an approximate
/// criterion.
fn approx_stats(
    tr: &CmoTracer,
    rays: &[(Vec3, Vec3)],
    trace: impl Fn(&Segment) -> TraceResult,
) -> (usize, usize, usize) {
    let n = tr.cube.size as f32;
    let c = tr.cube.centre;
    let (mut hits, mut good, mut hidden) = (0, 0, 0);
    for &(o, d) in rays {
        let r = trace(&segment(tr, o, d));
        if r.status != Status::Hit {
            continue;
        }
        hits += 1;
        let p = r.point + c;
        let p_true = o + scene_hit(o, d, true) * d;
        if (p - p_true).length() <= 3.0 * (p_true - c).length() * 2.0 / n {
            good += 1;
        }
        // Hidden: the reported point's own surface point is not what the CMO sees there.
        if visible_from(c, p_true, 4.0 / n) == Some(false) && (p - p_true).length() > 0.05 {
            hidden += 1;
        }
    }
    (hits, good, hidden)
}

/// Least `(hits, within 3 footprints)` of 1500 rays per row of [`approximate_criteria`]
/// (N = 64), lower bounds only: 97% of the measured hits and 95% of the measured good ones,
/// rounded down. Measured: sign/texel 1500, 1270; sign/step 1500, 1307; sign/angle 1500, 1304;
/// eps/texel 1248, 1193; eps/step 1396, 1331. With the walls 10% too far the good ones fall to
/// 268, 384, 416, 598 and 933.
const APPROX_LEAST: [(usize, usize); 5] = [
    (1455, 1206),
    (1455, 1241),
    (1455, 1238),
    (1210, 1133),
    (1354, 1264),
];

#[test]
fn approximate_criteria() {
    let tr = CmoTracer::new(capture(64, CENTRE, true), TraceParams::default());
    let mut far = capture(64, CENTRE, true);
    for d in far.distance.iter_mut() {
        *d *= 1.1;
    }
    let far = CmoTracer::new(far, TraceParams::default());
    let rs = rays(123, 1500);
    let mut table = Vec::new();
    let mut failures = Vec::new();
    for (row, (name, crit, sampling)) in [
        ("sign/texel", Criterion::SignChange, Sampling::PerTexel),
        (
            "sign/step",
            Criterion::SignChange,
            Sampling::ConstantStep(400),
        ),
        (
            "sign/angle",
            Criterion::SignChange,
            Sampling::ConstantAngle(400),
        ),
        ("eps/texel", Criterion::Threshold(0.1), Sampling::PerTexel),
        (
            "eps/step",
            Criterion::Threshold(0.1),
            Sampling::ConstantStep(400),
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let s = approx_stats(&tr, &rs, |seg| trace_sampled(&tr, seg, crit, sampling));
        // Negative: walls captured 10% too far; judged against the true scene as above.
        let f = approx_stats(&tr, &rs, |seg| trace_sampled(&far, seg, crit, sampling));
        eprintln!(
            "{name}: hits {} good {} hidden {}; 10% too far: hits {} good {}",
            s.0, s.1, s.2, f.0, f.1
        );
        let (hits, good) = APPROX_LEAST[row];
        if s.0 < hits || s.1 < good {
            failures.push(format!("{name}: {s:?} below {:?}", APPROX_LEAST[row]));
        }
        if f.0 >= hits && f.1 >= good {
            failures.push(format!("{name}: 10% too far passes: {f:?}"));
        }
        table.push(s);
    }
    assert!(failures.is_empty(), "{failures:#?}");
    // Measured (N = 64, 1500 rays): sign change hits 1500, 1270 within 3 footprints, 93 on
    // points hidden from the CMO, for all three samplings; threshold 0.1 misses 7-17% of rays.
    // Sign change per texel finds the surface where the CMO sees it...
    let (hits, good, hidden) = table[0];
    assert!(hits > 1300 && good as f32 > 0.8 * hits as f32);
    // ...but also "hits" where the ray only passes behind the occluder (thesis fig. 3.2, C),
    // which the centre criterion reports as behind (tested above with zero such hits).
    assert!(hidden > 0);
    // The same metric on the exact model finds none.
    assert_eq!(approx_stats(&tr, &rs, |seg| trace_walk(&tr, seg)).2, 0);
}

#[test]
fn special_rays_cover_four_faces_and_pieces_cross_at_most_four() {
    use cubetrace::cpu::{faces_crossed, split_near_centre};
    let tr = CmoTracer::new(capture(32, CENTRE, true), TraceParams::default());
    let mut most = 0;
    for (o, d) in special_rays(CENTRE).into_iter().chain(rays(3, 500)) {
        let s = segment(&tr, o, d);
        let p = split_near_centre(&s, tr.cut_radius);
        let mut total = 0;
        for k in 0..p.count as usize {
            let n = faces_crossed(&s, p.range[k][0], p.range[k][1], 32).count;
            assert!(n <= 4, "thesis th. 3.3: at most 4 faces per piece");
            total += n;
        }
        most = most.max(total);
    }
    assert_eq!(most, 4, "no test ray crosses four faces");
}

//! The 3x3 texel search (`cpu::texel_search`, behind `locate` and `next_texel`) clips the
//! neighbourhood's distinct planes once and combines them per candidate, and `locate` and
//! `next_texel` try one texel first and skip the search where its certificate holds
//! (`cpu::certified`). These tests hold both to the search they replaced, nine independent
//! `texel_interval`s, bit for bit (t0, t1, sides, the texel found), over random rays and over
//! the rays that make ties: rays in a side plane (`beta == 0`, `alpha == 0`), through texel
//! corners, from the CMO centre, with zero and non-finite components and segment ends. A
//! certificate with one of its conditions left out is caught by the same rays.
use cubetrace::cpu::{
    Segment, across_exit, locate, locate_centre, next_texel, texel_interval, texel_search,
};
use cubetrace::cubemap::face::{FACE_COUNT, Texel, face_coord, from_face_local};
use cubetrace::cubemap::frustum::Interval;
use glam::Vec3;

/// The search as it was: each candidate's own `texel_interval`.
#[allow(clippy::too_many_arguments)]
fn search_by_texel(
    seg: &Segment,
    face: u32,
    centre: (u32, u32),
    ahead: Option<(f32, f32)>,
    t: f32,
    size: u32,
    lo: f32,
    hi: f32,
) -> Option<(Texel, Interval)> {
    let mut best: Option<(Texel, Interval)> = None;
    for dy in -1i32..=1 {
        for dx in -1i32..=1 {
            if let Some((mx, my)) = ahead
                && ((dx == 0 && dy == 0) || (dx as f32) * mx < 0.0 || (dy as f32) * my < 0.0)
            {
                continue;
            }
            let x = centre.0 as i32 + dx;
            let y = centre.1 as i32 + dy;
            if x < 0 || y < 0 || x >= size as i32 || y >= size as i32 {
                continue;
            }
            let tex = Texel {
                face,
                x: x as u32,
                y: y as u32,
            };
            let iv = texel_interval(seg, tex, size, lo, hi);
            if iv.crosses() && iv.t1 > t && best.is_none_or(|(_, b)| iv.t0 < b.t0) {
                best = Some((tex, iv));
            }
        }
    }
    best
}

/// Bits of a search result, so that -0 and +0 (and NaN payloads) count as different.
fn bits(r: Option<(Texel, Interval)>) -> Option<(Texel, u32, u32, u32, u32)> {
    r.map(|(t, iv)| (t, iv.t0.to_bits(), iv.t1.to_bits(), iv.entry, iv.exit))
}

struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) as u32
    }
    fn unit(&mut self) -> f32 {
        self.next() as f32 / (1u64 << 31) as f32 * 2.0 - 1.0
    }
    fn pick<T: Copy>(&mut self, v: &[T]) -> T {
        v[self.next() as usize % v.len()]
    }
}

/// A face coordinate: random, or exactly a texel boundary of `size` (ties), or 0 / ±1.
fn coord(rng: &mut Lcg, size: u32) -> f32 {
    match rng.next() % 4 {
        0 => face_coord(rng.next() % (size + 1), size),
        1 => rng.pick(&[0.0, -0.0, 1.0, -1.0]),
        _ => rng.unit(),
    }
}

/// A CMO-local vector from face-local parts on a random face, some parts exact boundaries.
fn vector(rng: &mut Lcg, size: u32) -> Vec3 {
    let face = rng.next() % FACE_COUNT;
    let z = match rng.next() % 5 {
        0 => 0.0,
        1 => -0.0,
        2 => -rng.unit().abs(),
        _ => 0.1 + rng.unit().abs() * 3.0,
    };
    let (u, v) = (coord(rng, size), coord(rng, size));
    // On the side plane through the boundary u: x = u z exactly where the product rounds back.
    from_face_local(face, Vec3::new(u * z, v * z, z))
}

fn segment(rng: &mut Lcg, size: u32) -> Segment {
    let a = match rng.next() % 6 {
        0 => Vec3::ZERO,
        1 => Vec3::new(-0.0, 0.0, -0.0),
        _ => vector(rng, size),
    };
    let d = match rng.next() % 8 {
        0 => Vec3::new(rng.unit(), 0.0, 0.0),
        1 => Vec3::ZERO,
        _ => vector(rng, size),
    };
    let t_lo = rng.pick(&[0.0, -0.0, 1e-3, 0.5, f32::NEG_INFINITY]);
    let t_hi = rng.pick(&[10.0, 1.0, f32::INFINITY, 0.0]);
    Segment {
        a,
        d,
        t_lo,
        t_hi,
        from: u32::MAX,
    }
}

/// A texel search under test: `locate` (`None`) or `next_texel` after a texel (`Some`).
type SearchFn = dyn Fn(
    &Segment,
    u32,
    f32,
    Option<(Texel, &Interval)>,
    u32,
    f32,
    f32,
) -> Option<(Texel, Interval)>;
type Search<'a> = &'a SearchFn;

/// The searches as the tracer runs them.
fn tracer_search(
    seg: &Segment,
    face: u32,
    t: f32,
    after: Option<(Texel, &Interval)>,
    size: u32,
    lo: f32,
    hi: f32,
) -> Option<(Texel, Interval)> {
    match after {
        None => locate(seg, face, t, size, lo, hi),
        Some((cur, iv)) => next_texel(seg, cur, iv, size, lo, hi),
    }
}

/// `locate` and `next_texel` against the per-texel search, on every face, around centres on
/// the face's edges and inside, with `t` the segment's start, a crossing or a bound.
fn check(rng: &mut Lcg, size: u32, seg: &Segment) -> usize {
    let (found, wrong) = compare(rng, size, seg, &tracer_search);
    assert_eq!(wrong, Vec::<String>::new());
    found
}

/// [`check`]'s comparison of `search`: the searches that found a texel, and what differed.
fn compare(rng: &mut Lcg, size: u32, seg: &Segment, search: Search) -> (usize, Vec<String>) {
    let mut found = 0;
    let mut wrong = Vec::new();
    for face in 0..FACE_COUNT {
        let ts = [seg.t_lo, 0.0, 0.25, 1.0, seg.t_hi];
        let t = rng.pick(&ts);
        let cut = rng.pick(&[seg.t_lo, 0.0, 0.5]).max(seg.t_lo);
        let (lo, hi) = (cut, seg.t_hi);
        // `locate`'s centre comes from p(t); compare against the same centre.
        let new = search(seg, face, t, None, size, lo, hi);
        let old = search_by_texel(
            seg,
            face,
            locate_centre(seg, face, t, size),
            None,
            t,
            size,
            lo,
            hi,
        );
        if bits(new) != bits(old) {
            wrong.push(format!("locate: {seg:?} face {face} t {t}"));
        }
        found += usize::from(new.is_some());
        // `next_texel` after texels on the face's edges and corners and after the located one.
        let edge = size - 1;
        let mut texels = vec![(0, 0), (edge, edge), (0, edge), (edge, 0)];
        texels.push((rng.next() % size, rng.next() % size));
        if let Some((tex, _)) = new {
            texels.push((tex.x, tex.y));
        }
        for (x, y) in texels {
            let cur = Texel { face, x, y };
            let iv = texel_interval(seg, cur, size, lo, hi);
            let la = cubetrace::cubemap::face::to_face_local(face, seg.a);
            let ld = cubetrace::cubemap::face::to_face_local(face, seg.d);
            let m = (ld.x * la.z - la.x * ld.z, ld.y * la.z - la.y * ld.z);
            let new = search(seg, face, iv.t1, Some((cur, &iv)), size, lo, hi);
            let old = search_by_texel(seg, face, (x, y), Some(m), iv.t1, size, lo, hi);
            if bits(new) != bits(old) {
                wrong.push(format!("next_texel: {seg:?} after {cur:?}"));
            }
            found += usize::from(new.is_some());
        }
    }
    (found, wrong)
}

#[test]
fn search_matches_per_texel_intervals_bit_for_bit() {
    let mut rng = Lcg(0x5eed_7e7e);
    let mut found = 0;
    for size in [1u32, 2, 3, 4, 8, 16, 64] {
        for _ in 0..4000 {
            let seg = segment(&mut rng, size);
            found += check(&mut rng, size, &seg);
        }
    }
    // The rays must reach texels, not only miss (the comparison would be vacuous).
    assert!(found > 10_000, "only {found} searches found a texel");
}

#[test]
fn search_matches_on_non_finite_rays() {
    let mut rng = Lcg(0x0ddba11);
    let specials = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.0,
        -0.0,
        1e-38,
        3e38,
    ];
    for size in [1u32, 4, 16] {
        for _ in 0..3000 {
            let mut seg = segment(&mut rng, size);
            // One or two components special.
            for _ in 0..1 + rng.next() % 2 {
                let v = rng.pick(&specials);
                let i = rng.next() as usize % 3;
                if rng.next().is_multiple_of(2) {
                    seg.a[i] = v;
                } else {
                    seg.d[i] = v;
                }
            }
            if rng.next().is_multiple_of(4) {
                seg.t_lo = rng.pick(&specials);
            }
            check(&mut rng, size, &seg);
        }
    }
}

/// A ray in the plane of a texel column boundary (`beta == 0` and `alpha == 0` for that side)
/// must be found in exactly the texel the per-texel search finds (the half-open rule).
#[test]
fn search_matches_for_rays_in_side_planes() {
    let mut rng = Lcg(42);
    let size = 8u32;
    for face in 0..FACE_COUNT {
        for k in 0..=size {
            let u = face_coord(k, size);
            for v in [-0.9f32, 0.0, 0.3, 0.75] {
                let a = from_face_local(face, Vec3::new(0.0, 0.0, 0.0));
                let d = from_face_local(face, Vec3::new(u, v, 1.0));
                let seg = Segment {
                    a,
                    d,
                    t_lo: 0.0,
                    t_hi: 4.0,
                    from: u32::MAX,
                };
                check(&mut rng, size, &seg);
                // The same plane, the ray offset along it.
                let seg = Segment {
                    a: from_face_local(face, Vec3::new(u * 0.5, 0.25, 0.5)),
                    d: from_face_local(face, Vec3::new(u, -0.5, 1.0)),
                    ..seg
                };
                check(&mut rng, size, &seg);
            }
        }
    }
}

/// The searches with a certificate that leaves out one condition: `entry` (`t0 <= t`) or
/// `limit` (the ray's components below `cpu::CERTIFIED_LIMIT`).
fn weak_search(leave_out: &'static str) -> Box<SearchFn> {
    Box::new(move |seg, face, t, after, size, lo, hi| {
        let limit = Vec3::splat(cubetrace::cpu::CERTIFIED_LIMIT);
        let finite = seg.a.abs().cmplt(limit).all() && seg.d.abs().cmplt(limit).all();
        let la = cubetrace::cubemap::face::to_face_local(face, seg.a);
        let ld = cubetrace::cubemap::face::to_face_local(face, seg.d);
        let m = (ld.x * la.z - la.x * ld.z, ld.y * la.z - la.y * ld.z);
        let (first, centre, ahead) = match after {
            None => {
                let c = locate_centre(seg, face, t, size);
                (
                    Some(Texel {
                        face,
                        x: c.0,
                        y: c.1,
                    }),
                    c,
                    None,
                )
            }
            Some((cur, iv)) => (
                across_exit(cur, iv.exit, m.0, m.1, size),
                (cur.x, cur.y),
                Some(m),
            ),
        };
        if let Some(tex) = first {
            let iv = texel_interval(seg, tex, size, lo, hi);
            let holds = iv.crosses()
                && iv.t1 > t
                && (leave_out == "entry" || iv.t0 <= t)
                && (leave_out == "limit" || finite);
            if holds {
                return Some((tex, iv));
            }
        }
        texel_search(seg, face, centre, ahead, t, size, lo, hi)
    })
}

/// Negative: each condition of the certificate is needed, and these rays show it.
#[test]
fn a_certificate_without_one_of_its_conditions_is_caught() {
    for leave_out in ["entry", "limit"] {
        let search = weak_search(leave_out);
        let mut wrong = 0;
        let mut rng = Lcg(0x0ddba11);
        for size in [1u32, 4, 16] {
            for _ in 0..3000 {
                let mut seg = segment(&mut rng, size);
                if leave_out == "limit" {
                    let i = rng.next() as usize % 3;
                    seg.a[i] = rng.pick(&[f32::INFINITY, f32::NAN, 3e38]);
                }
                wrong += compare(&mut rng, size, &seg, &search).1.len();
            }
        }
        assert!(
            wrong > 0,
            "a certificate without `{leave_out}` went unnoticed"
        );
    }
}

/// The march's search after a skipped cell (`cpu::locate_after_skip`: the texel across the
/// cell's exit side, none past the face's edge) against `locate` at the cell's exit: the same
/// texel and interval, bit for bit, on every cell of every face crossed by rays from inside
/// the cube (a CMO's rays), at levels 1 to 5 of a face of 64 texels; the comparison sees every
/// exit side and face edges.
#[test]
fn after_a_skip_the_texel_across_the_side_is_the_located_one() {
    let (agree, off_face) = skip_agreement(|seg, cell, civ, t, n, lo, hi| {
        cubetrace::cpu::locate_after_skip(seg, cell, civ, t, n, lo, hi).0
    });
    assert_eq!(agree.1, 0, "{} of {} skips differ", agree.1, agree.0);
    assert!(agree.0 > 20_000 && off_face > 1_000, "{agree:?} {off_face}");
}

/// Negative: the texel on the cell's own side of its exit instead is caught.
#[test]
fn after_a_skip_the_texel_inside_the_cell_is_caught() {
    let (agree, _) = skip_agreement(|seg, cell, civ, t, n, lo, hi| {
        let mut inside = *cell;
        match civ.exit {
            0 => inside.x1 = inside.x0 + 1,
            1 => inside.x0 = inside.x1 - 1,
            2 => inside.y1 = inside.y0 + 1,
            _ => inside.y0 = inside.y1 - 1,
        }
        let x = inside.x0.max(cell.x0);
        let y = inside.y0.max(cell.y0);
        let tex = Texel {
            face: cell.face,
            x,
            y,
        };
        let iv = texel_interval(seg, tex, n, lo, hi);
        (iv.crosses() && iv.t1 > t).then_some((tex, iv))
    });
    assert!(agree.1 > 1_000, "{agree:?}");
}

/// Skips (cells crossed, left through a side at `civ.t1`) where `after` gives `locate`'s
/// answer at the exit, `(skips, differing)`, and how many exits lie on a face's edge.
fn skip_agreement(
    after: impl Fn(
        &Segment,
        &cubetrace::cubemap::frustum::CellRect,
        &Interval,
        f32,
        u32,
        f32,
        f32,
    ) -> Option<(Texel, Interval)>,
) -> ((usize, usize), usize) {
    use cubetrace::cubemap::frustum::{CellRect, SIDE_Z, cell_interval};
    let n = 64u32;
    let mut rng = Lcg(0x5c1b);
    let (mut skips, mut differ, mut off_face) = (0, 0, 0);
    for _ in 0..300 {
        let a = Vec3::new(rng.unit(), rng.unit(), rng.unit()) * 0.9;
        let d = Vec3::new(rng.unit(), rng.unit(), rng.unit());
        let seg = Segment {
            a,
            d,
            t_lo: 0.0,
            t_hi: 8.0,
            from: u32::MAX,
        };
        let (lo, hi) = (seg.t_lo, seg.t_hi);
        for face in 0..FACE_COUNT {
            let la = cubetrace::cubemap::face::to_face_local(face, a);
            let ld = cubetrace::cubemap::face::to_face_local(face, d);
            for level in 1..=5u32 {
                let span = 1u32 << level;
                for cy in 0..n / span {
                    for cx in 0..n / span {
                        let cell = CellRect {
                            face,
                            x0: cx * span,
                            x1: (cx + 1) * span,
                            y0: cy * span,
                            y1: (cy + 1) * span,
                            size: n,
                        };
                        let civ = cell_interval(la, ld, &cell, lo, hi);
                        if !(civ.crosses() && civ.exit < SIDE_Z) {
                            continue;
                        }
                        let t = civ.t1;
                        let expected = locate(&seg, face, t, n, lo, hi);
                        skips += 1;
                        let edge = matches!(civ.exit, 0 if cell.x0 == 0)
                            || matches!(civ.exit, 1 if cell.x1 == n)
                            || matches!(civ.exit, 2 if cell.y0 == 0)
                            || matches!(civ.exit, 3 if cell.y1 == n);
                        off_face += usize::from(edge);
                        if bits(after(&seg, &cell, &civ, t, n, lo, hi)) != bits(expected) {
                            differ += 1;
                        }
                    }
                }
            }
        }
    }
    ((skips, differ), off_face)
}

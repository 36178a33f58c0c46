//! The 3x3 texel search (`cpu::texel_search`, behind `locate` and `next_texel`) clips the
//! neighbourhood's distinct planes once and combines them per candidate. These tests hold it to
//! the search it replaced, nine independent `texel_interval`s, bit for bit (t0, t1, sides, the
//! texel found), over random rays and over the rays that make ties: rays in a side plane
//! (`beta == 0`, `alpha == 0`), through texel corners, from the CMO centre, with zero and
//! non-finite components and segment ends.
use cubetrace::cpu::{Segment, locate, next_texel, texel_interval};
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

/// `locate` and `next_texel` against the per-texel search, on every face, around centres on
/// the face's edges and inside, with `t` the segment's start, a crossing or a bound.
fn check(rng: &mut Lcg, size: u32, seg: &Segment) -> usize {
    let mut found = 0;
    for face in 0..FACE_COUNT {
        let ts = [seg.t_lo, 0.0, 0.25, 1.0, seg.t_hi];
        let t = rng.pick(&ts);
        let cut = rng.pick(&[seg.t_lo, 0.0, 0.5]).max(seg.t_lo);
        let (lo, hi) = (cut, seg.t_hi);
        // `locate`'s centre comes from p(t); compare against the same centre.
        let new = locate(seg, face, t, size, lo, hi);
        let mut centre = (size / 2, size / 2);
        let l = cubetrace::cubemap::face::to_face_local(face, seg.at(t));
        if l.z > 0.0 {
            centre = (
                cubetrace::cubemap::face::st_to_texel_coord(0.5 * (l.x / l.z + 1.0), size),
                cubetrace::cubemap::face::st_to_texel_coord(0.5 * (l.y / l.z + 1.0), size),
            );
        }
        let old = search_by_texel(seg, face, centre, None, t, size, lo, hi);
        assert_eq!(bits(new), bits(old), "locate: {seg:?} face {face} t {t}");
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
            let new = next_texel(seg, cur, &iv, size, lo, hi);
            let old = search_by_texel(seg, face, (x, y), Some(m), iv.t1, size, lo, hi);
            assert_eq!(bits(new), bits(old), "next_texel: {seg:?} after {cur:?}");
            found += usize::from(new.is_some());
        }
    }
    found
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

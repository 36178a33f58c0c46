//! Where a ray segment crosses a cell's frustum (ALGORITHM.md, "Which cells a ray crosses"), and
//! the convexity bounds of `r(t) = |a + t d|` over an interval (facts 2 and 3).
//!
//! Conventions:
//! - `a`, `d` are CMO-local (`x - c`) and, for [`cell_interval`], rotated into the face's local
//!   frame by [`super::face::to_face_local`] (exact). `r(t)` is always evaluated on the
//!   CMO-local vectors by [`r_at`] so every caller gets the same bits.
//! - A cell is a rectangle of texels `[x0, x1) x [y0, y1)` (integer texel indices, `x1 <= N`) of
//!   one face; its sides in face coordinates come from [`super::face::face_coord`], so a side
//!   shared by two cells (or two faces, at `±1`) yields bit-identical bounds on both sides
//!   (`alpha`, `beta` of the two cells are exact negatives of each other; never fuse them into
//!   an FMA in a shader).
//! - Half-open rule: an affine constraint `alpha + t beta >= 0` with `beta == 0` keeps everything
//!   when `alpha > 0`, nothing when `alpha < 0`, and, when `alpha == 0` (the ray lies in the side
//!   plane), keeps everything only if that side belongs to the cell: lower sides inside a face
//!   do, upper sides inside a face don't, face edges follow [`super::face::edge_inclusive`].
//!   A ray lying in a boundary plane is thus in exactly one of the two cells.
//! - A texel is crossed iff `t0 < t1` (positive length); rays that only touch a texel at a point
//!   (through a corner) do not cross it. Hierarchy cells use [`Interval::inflated`] instead, a
//!   conservative superset, so that rounding never hides a crossed texel.

use glam::Vec3;

use super::face::{edge_inclusive, face_coord};

/// Which constraint bounded an interval end.
pub const SIDE_X0: u32 = 0;
/// Upper `x` side.
pub const SIDE_X1: u32 = 1;
/// Lower `y` side.
pub const SIDE_Y0: u32 = 2;
/// Upper `y` side.
pub const SIDE_Y1: u32 = 3;
/// The `z > 0` half-space (the ray comes from behind the CMO centre).
pub const SIDE_Z: u32 = 4;
/// The segment's own end (`t_lo` for `entry`, `t_hi` for `exit`).
pub const SIDE_SEGMENT: u32 = 5;

/// A rectangle of texels `[x0, x1) x [y0, y1)` on one face of size `size`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellRect {
    /// Face index.
    pub face: u32,
    /// First column.
    pub x0: u32,
    /// One past the last column (`<= size`).
    pub x1: u32,
    /// First row.
    pub y0: u32,
    /// One past the last row (`<= size`).
    pub y1: u32,
    /// Face size N.
    pub size: u32,
}

impl CellRect {
    /// The whole face.
    pub fn face(face: u32, size: u32) -> CellRect {
        CellRect {
            face,
            x0: 0,
            x1: size,
            y0: 0,
            y1: size,
            size,
        }
    }

    /// One texel.
    pub fn texel(face: u32, x: u32, y: u32, size: u32) -> CellRect {
        CellRect {
            face,
            x0: x,
            x1: x + 1,
            y0: y,
            y1: y + 1,
            size,
        }
    }

    /// Whether the rectangle covers no texel (a padding cell).
    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }
}

/// The `t` range over which a segment is inside a cell's frustum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Entry parameter (`+inf` when excluded by a parallel side).
    pub t0: f32,
    /// Exit parameter (`-inf` when excluded by a parallel side).
    pub t1: f32,
    /// The constraint that set `t0` (first in the order x0, x1, y0, y1, z on ties; the segment
    /// start wins ties with all of them).
    pub entry: u32,
    /// The constraint that set `t1` (same tie order; the segment end wins ties).
    pub exit: u32,
}

/// Relative widening of hierarchy cell intervals, as a fraction of the cell's own `t` scale
/// ([`Interval::inflated`]). Rounding in `t` is a few ulps (`~1e-7`) of that scale once
/// near-centre rays are split off (see `cpu::trace`); `2^-12` is far above it and costs at most
/// a neighbouring cell.
pub const CELL_INFLATE: f32 = 1.0 / 4096.0;

/// The origin's share of the `t` scale of a segment `a + t d` ([`Interval::inflated`]):
/// `|a|_1 / |d|_1`, the `t` it takes to travel as far as the origin lies from the centre. A side
/// plane's crossing `t = -alpha / beta` rounds by ulps of `|a|` over `|beta|` plus ulps of
/// `|t|`; this covers the first part where `t` itself is small. Summed in x, y, z order (the
/// shaders must match).
pub fn seg_reach(a: Vec3, d: Vec3) -> f32 {
    (a.x.abs() + a.y.abs() + a.z.abs()) / (d.x.abs() + d.y.abs() + d.z.abs())
}

impl Interval {
    /// The empty interval.
    pub const EMPTY: Interval = Interval {
        t0: f32::INFINITY,
        t1: f32::NEG_INFINITY,
        entry: SIDE_SEGMENT,
        exit: SIDE_SEGMENT,
    };

    /// Texel rule: crossed over a positive length.
    pub fn crosses(&self) -> bool {
        self.t0 < self.t1
    }

    /// A conservative superset for hierarchy cells, clamped to `[t_lo, t_hi]`: widened by
    /// [`CELL_INFLATE`] times the cell's own `t` scale, `te - t_lo + |t_lo| + |te| + reach`,
    /// where `te` is the cell's far end (`max(t0, t1)` clamped to `[t_lo, t_hi]`) and `reach`
    /// the segment's [`seg_reach`]. Returns `None` when even the widened interval is empty.
    ///
    /// The scale is the cell's, not the segment's: with `t_hi` (the scene's diagonal) in it, one
    /// far vertex (a large ground plane) widened every cell near the start of the ray to the
    /// whole segment, so that no cell was ever skipped and the compute path's depth-first search
    /// walked every cell whose planes the ray crossed anywhere (on a scene with a 1e6 ground
    /// triangle: 11,489 texels per ray instead of 40). A crossing `t` rounds by ulps of its own
    /// magnitude (and of the origin's, `reach`), which the local scale still covers `2^11`
    /// times over.
    pub fn inflated(&self, t_lo: f32, t_hi: f32, reach: f32) -> Option<(f32, f32)> {
        if !(self.t0 <= f32::MAX && self.t1 >= -f32::MAX) {
            return None;
        }
        // t0 >= t_lo (it starts there and only grows), so te lies in [t_lo, t_hi].
        let te = self.t0.max(self.t1).min(t_hi);
        let e = CELL_INFLATE * ((te - t_lo) + t_lo.abs() + te.abs() + reach);
        let lo = (self.t0 - e).max(t_lo);
        let hi = (self.t1 + e).min(t_hi);
        if lo <= hi { Some((lo, hi)) } else { None }
    }
}

/// `[t0, t1]` of the segment `la + t ld`, `t in [t_lo, t_hi]` (face-local `la`, `ld`) inside the
/// frustum of `cell`, from the five affine inequalities of ALGORITHM.md: the four side planes
/// (`side_planes`), then the face's plane `z >= 0`.
pub fn cell_interval(la: Vec3, ld: Vec3, cell: &CellRect, t_lo: f32, t_hi: f32) -> Interval {
    side_planes(la, ld, cell, t_lo, t_hi)
        .plane(la.z, ld.z, false, SIDE_Z)
        .interval()
}

/// [`cell_interval`] with the face's z plane clipped once for every cell of a face (`z`:
/// `PlaneBound::new(la.z, ld.z, false)`, the pyramid march's per-face constant): the same bits.
/// The z plane comes last, and [`Clip::bound`] of a plane's [`PlaneBound`] makes the same
/// comparisons as [`Clip::plane`] of it (the argument of `cpu::texel_search`).
pub fn cell_interval_face(
    la: Vec3,
    ld: Vec3,
    cell: &CellRect,
    z: PlaneBound,
    t_lo: f32,
    t_hi: f32,
) -> Interval {
    side_planes(la, ld, cell, t_lo, t_hi)
        .bound(z, SIDE_Z)
        .interval()
}

/// `[t_lo, t_hi]` clipped by the four side planes of `cell`, in the order x0, x1, y0, y1 (the
/// first four steps of [`cell_interval`]). Inclusive (owned) sides: interior lower sides yes,
/// interior upper sides no, face edges by the face tie rule.
fn side_planes(la: Vec3, ld: Vec3, cell: &CellRect, t_lo: f32, t_hi: f32) -> Clip {
    let n = cell.size;
    let fx0 = face_coord(cell.x0, n);
    let fx1 = face_coord(cell.x1, n);
    let fy0 = face_coord(cell.y0, n);
    let fy1 = face_coord(cell.y1, n);
    let edge = edge_inclusive(cell.face);
    let inc = [
        if cell.x0 == 0 { edge[0] } else { true },
        if cell.x1 == n { edge[1] } else { false },
        if cell.y0 == 0 { edge[2] } else { true },
        if cell.y1 == n { edge[3] } else { false },
    ];
    Clip::new(t_lo, t_hi)
        .plane(la.x - fx0 * la.z, ld.x - fx0 * ld.z, inc[0], SIDE_X0)
        .plane(fx1 * la.z - la.x, fx1 * ld.z - ld.x, inc[1], SIDE_X1)
        .plane(la.y - fy0 * la.z, ld.y - fy0 * ld.z, inc[2], SIDE_Y0)
        .plane(fy1 * la.z - la.y, fy1 * ld.z - ld.y, inc[3], SIDE_Y1)
}

/// An interval being clipped by the planes `alpha + t beta >= 0` in turn ([`cell_interval`]'s
/// steps; the shaders' `Clip`, `clip_plane`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clip {
    /// The interval so far.
    pub iv: Interval,
    /// False once a plane parallel to the ray has dropped it.
    pub keep: bool,
}

impl Clip {
    /// `[t_lo, t_hi]`, both ends the segment's.
    pub fn new(t_lo: f32, t_hi: f32) -> Clip {
        Clip {
            iv: Interval {
                t0: t_lo,
                t1: t_hi,
                entry: SIDE_SEGMENT,
                exit: SIDE_SEGMENT,
            },
            keep: true,
        }
    }

    /// Clipped by the plane `al + t be >= 0` (side `k`; `inc`: whether the plane belongs to the
    /// cell). `b = -al / be` bounds the entry where `be > 0` (it replaces `t0` only where larger:
    /// the earlier plane keeps a tie), the exit where `be < 0`; `be` zero or NaN keeps or drops
    /// the interval by the half-open rule.
    pub fn plane(self, al: f32, be: f32, inc: bool, k: u32) -> Clip {
        let mut out = self;
        if be > 0.0 {
            let b = -al / be;
            if b > out.iv.t0 {
                out.iv.t0 = b;
                out.iv.entry = k;
            }
        } else if be < 0.0 {
            let b = -al / be;
            if b < out.iv.t1 {
                out.iv.t1 = b;
                out.iv.exit = k;
            }
        } else if al < 0.0 || (al == 0.0 && !inc) || al.is_nan() {
            out.keep = false;
        }
        out
    }

    /// [`Clip::plane`] of a plane clipped once ([`PlaneBound::new`]), side `k`: the same
    /// comparisons on the same `b`.
    pub fn bound(self, p: PlaneBound, k: u32) -> Clip {
        let mut out = self;
        if p.lo > out.iv.t0 {
            out.iv.t0 = p.lo;
            out.iv.entry = k;
        }
        if p.hi < out.iv.t1 {
            out.iv.t1 = p.hi;
            out.iv.exit = k;
        }
        out.keep = out.keep && p.keep;
        out
    }

    /// The interval, or [`Interval::EMPTY`] where a plane dropped it.
    pub fn interval(self) -> Interval {
        if self.keep { self.iv } else { Interval::EMPTY }
    }
}

/// What [`Clip::plane`] does with one plane to any interval, computed once for several cells
/// (`cpu::texel_search`): `b = -al / be` as the entry bound `lo` (`-inf`: none) or the exit
/// bound `hi` (`+inf`: none), and whether the plane keeps the interval. `-inf > t0` and
/// `+inf < t1` hold for no `t0`, `t1` (NaN included), so [`Clip::bound`] changes nothing through
/// a bound the plane does not set, as [`Clip::plane`]; a NaN `b` fails its comparison in both.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneBound {
    /// Entry bound (`-inf` where the plane bounds no entry).
    pub lo: f32,
    /// Exit bound (`+inf` where the plane bounds no exit).
    pub hi: f32,
    /// False where the plane drops every interval (parallel, outside).
    pub keep: bool,
}

impl PlaneBound {
    /// The plane `al + t be >= 0` (`inc`: whether it belongs to the cell), with
    /// [`Clip::plane`]'s operations and tests.
    pub fn new(al: f32, be: f32, inc: bool) -> PlaneBound {
        let mut p = PlaneBound {
            lo: f32::NEG_INFINITY,
            hi: f32::INFINITY,
            keep: true,
        };
        if be > 0.0 {
            p.lo = -al / be;
        } else if be < 0.0 {
            p.hi = -al / be;
        } else if al < 0.0 || (al == 0.0 && !inc) || al.is_nan() {
            p.keep = false;
        }
        p
    }
}

/// `r(t) = |a + t d|` on CMO-local vectors, summed in x, y, z order (the shader must match).
pub fn r_at(a: Vec3, d: Vec3, t: f32) -> f32 {
    let p = Vec3::new(a.x + t * d.x, a.y + t * d.y, a.z + t * d.z);
    (p.x * p.x + p.y * p.y + p.z * p.z).sqrt()
}

/// Closest approach of the line to the centre: `t* = -(a.d)/(d.d)`.
pub fn closest_t(a: Vec3, d: Vec3) -> f32 {
    -(a.x * d.x + a.y * d.y + a.z * d.z) / (d.x * d.x + d.y * d.y + d.z * d.z)
}

/// `(rmin, rmax)` of `r` over `[t0, t1]` (fact 2: max at an endpoint, min at an endpoint or at
/// `t*` when it lies inside).
pub fn r_bounds(a: Vec3, d: Vec3, t0: f32, t1: f32) -> (f32, f32) {
    r_bounds_from(a, d, Closest::of(a, d), t0, t1)
}

/// The line's closest approach to the centre, a ray's constants of [`r_bounds`]: `t` =
/// [`closest_t`], `r` = `r(t)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    pub t: f32,
    pub r: f32,
}

impl Closest {
    pub fn of(a: Vec3, d: Vec3) -> Closest {
        let t = closest_t(a, d);
        Closest {
            t,
            r: r_at(a, d, t),
        }
    }
}

/// [`r_bounds`] from the ray's [`Closest`] (made once per ray): the same operations on the same
/// operands, so the same bits.
pub fn r_bounds_from(a: Vec3, d: Vec3, closest: Closest, t0: f32, t1: f32) -> (f32, f32) {
    let r0 = r_at(a, d, t0);
    let r1 = r_at(a, d, t1);
    let ts = closest.t;
    let rmin = if ts > t0 && ts < t1 {
        closest.r.min(r0).min(r1)
    } else {
        r0.min(r1)
    };
    (rmin, r0.max(r1))
}

#[cfg(test)]
mod tests {
    use super::super::face::{FACE_COUNT, dir_to_texel, to_face_local};
    use super::*;

    /// Brute-force membership of `p` in a cell: the texel lookup of its direction.
    fn in_cell(p: Vec3, c: &CellRect) -> bool {
        if p == Vec3::ZERO {
            return false;
        }
        let t = dir_to_texel(p, c.size);
        t.face == c.face && t.x >= c.x0 && t.x < c.x1 && t.y >= c.y0 && t.y < c.y1
    }

    fn lcg(s: &mut u64) -> f32 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*s >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }

    #[test]
    fn interval_matches_sampled_membership() {
        let mut s = 7u64;
        let size = 4;
        for _ in 0..300 {
            let a = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 2.0;
            let d = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s));
            for face in 0..FACE_COUNT {
                let c = CellRect {
                    face,
                    x0: 1,
                    x1: 3,
                    y0: 0,
                    y1: 2,
                    size,
                };
                let iv =
                    cell_interval(to_face_local(face, a), to_face_local(face, d), &c, 0.0, 4.0);
                for k in 0..64 {
                    let t = 4.0 * (k as f32 + 0.5) / 64.0;
                    let inside = iv.crosses() && t > iv.t0 + 1e-4 && t < iv.t1 - 1e-4;
                    let outside = !iv.crosses() || t < iv.t0 - 1e-4 || t > iv.t1 + 1e-4;
                    let m = in_cell(a + t * d, &c);
                    if inside {
                        assert!(m);
                    }
                    if outside {
                        assert!(!m);
                    }
                }
            }
        }
    }

    #[test]
    fn ray_in_shared_plane_is_in_exactly_one_cell() {
        let size = 4;
        // In the +Z face's plane x = 0 (boundary k = 2): a = (0, -0.5, 1), d = (0, 1, 0.2).
        let a = Vec3::new(0.0, -0.5, 1.0);
        let d = Vec3::new(0.0, 1.0, 0.2);
        let left = CellRect::texel(4, 1, 1, size);
        let right = CellRect::texel(4, 2, 1, size);
        let la = to_face_local(4, a);
        let ld = to_face_local(4, d);
        let il = cell_interval(la, ld, &left, 0.0, 10.0);
        let ir = cell_interval(la, ld, &right, 0.0, 10.0);
        assert!(!il.crosses() && ir.crosses());
        // Negative: without the half-open rule both would claim it.
        let mut l2 = left;
        l2.x1 = 3;
        assert!(cell_interval(la, ld, &l2, 0.0, 10.0).crosses());
        // On the X/Z face edge plane x = z: only +X owns it.
        let a = Vec3::new(1.0, 0.1, 1.0);
        let d = Vec3::new(0.5, 0.3, 0.5);
        let n: Vec<u32> = (0..FACE_COUNT)
            .filter(|&f| {
                cell_interval(
                    to_face_local(f, a),
                    to_face_local(f, d),
                    &CellRect::face(f, size),
                    0.0,
                    5.0,
                )
                .crosses()
            })
            .collect();
        assert_eq!(n, vec![0]);
    }

    #[test]
    fn shared_side_bounds_are_bit_identical() {
        let mut s = 11u64;
        let size = 3; // face coordinates not exactly representable
        for _ in 0..500 {
            let a = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s));
            let d = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s));
            let la = to_face_local(4, a);
            let ld = to_face_local(4, d);
            let l = cell_interval(la, ld, &CellRect::texel(4, 0, 1, size), -1e9, 1e9);
            let r = cell_interval(la, ld, &CellRect::texel(4, 1, 1, size), -1e9, 1e9);
            if l.exit == SIDE_X1 && r.entry == SIDE_X0 {
                assert_eq!(l.t1.to_bits(), r.t0.to_bits());
            }
            if r.exit == SIDE_X0 && l.entry == SIDE_X1 {
                assert_eq!(r.t1.to_bits(), l.t0.to_bits());
            }
        }
    }

    #[test]
    fn r_bounds_uses_closest_approach() {
        // A ray passing 0.1 from the centre: the endpoint test alone would say rmin = |a|.
        let a = Vec3::new(-5.0, 0.1, 0.0);
        let d = Vec3::X;
        let (rmin, rmax) = r_bounds(a, d, 0.0, 10.0);
        assert!((rmin - 0.1).abs() < 1e-6);
        assert!((rmax - a.length()).abs() < 1e-5);
        // Negative: on an interval not containing t*, the min is at an endpoint.
        let (rmin2, _) = r_bounds(a, d, 0.0, 2.0);
        assert!((rmin2 - r_at(a, d, 2.0)).abs() < 1e-6);
    }

    /// The march's per-face constant changes no bit: `cell_interval_face` (the z plane clipped
    /// once) against `cell_interval`, on random rays with exact zeros, signed zeros, infinities
    /// and NaNs among their components and cells at every face edge. Negative: a z plane from
    /// a ray one ulp off is caught. (`r_bounds` is `r_bounds_from` on the ray's `Closest`.)
    #[test]
    fn per_face_constants_change_no_bit() {
        let bits = |iv: Interval| (iv.t0.to_bits(), iv.t1.to_bits(), iv.entry, iv.exit);
        let specials = [0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1e-30];
        let mut s = 11u64;
        let size = 8u32;
        let (mut compared, mut caught) = (0, 0);
        for i in 0..3000 {
            let mut a = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 2.0;
            let mut d = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s));
            if i % 3 == 0 {
                let k = (lcg(&mut s).abs() * 5.99) as usize;
                let v = specials[(lcg(&mut s).abs() * 5.99) as usize];
                if k < 3 { a[k] = v } else { d[k - 3] = v }
            }
            let (lo, hi) = (0.0, 4.0);
            for face in 0..FACE_COUNT {
                let (la, ld) = (to_face_local(face, a), to_face_local(face, d));
                let z = PlaneBound::new(la.z, ld.z, false);
                let off = PlaneBound::new(la.z, f32::from_bits(ld.z.to_bits() + 1), false);
                for (x0, x1, y0, y1) in [(0, 2, 0, 2), (6, 8, 2, 4), (3, 4, 7, 8), (0, 8, 0, 8)] {
                    let c = CellRect {
                        face,
                        x0,
                        x1,
                        y0,
                        y1,
                        size,
                    };
                    let want = bits(cell_interval(la, ld, &c, lo, hi));
                    assert_eq!(
                        bits(cell_interval_face(la, ld, &c, z, lo, hi)),
                        want,
                        "{a} {d} {c:?}"
                    );
                    compared += 1;
                    caught +=
                        usize::from(bits(cell_interval_face(la, ld, &c, off, lo, hi)) != want);
                }
            }
        }
        assert!(compared > 50_000 && caught > 100, "{compared} {caught}");
    }
}

//! Sound per-texel bounds and candidate lists: what a CMO holds for the `bounded`
//! criterion ([`crate::cpu::bounded`]).
//!
//! A texel's frustum is the cone of directions through its square on the face. For every
//! triangle that touches that cone (dilated, see the capture), the texel keeps an entry
//! `(triangle, lo, hi)`: `lo` a lower and `hi` an upper bound of the distance from the CMO centre
//! over the part of the triangle inside the cone. Per texel:
//! - `entries`: the `depth` entries with the smallest `(lo, triangle)`, in that order;
//! - `complete_to`: every triangle touching the texel whose entry was dropped (list deeper than
//!   `depth`, or the GPU's node pool full) has `lo >= complete_to`; `+inf` when none was dropped;
//! - `lo`: `min(first entry's lo, complete_to)` (`+inf` for an empty texel): no surface point in
//!   the cone is nearer. This is what the CMO's distance (and so its pyramids) holds.
//! - `hi`: the largest kept `hi` when nothing was dropped, `+inf` when something was, `-inf`
//!   for an empty texel.
//! - the gap `(g0, g1)` ([`texel_gap`]): a range of distances that no surface in the cone
//!   takes. Walking the kept entries in order, an entry whose `lo` lies past the end (the
//!   largest `hi`) of the entries before it opens a gap from that end to its `lo`; the texel
//!   keeps the widest by ratio, clamped to `complete_to` (the one after the last entry, up to
//!   `complete_to`, where none opens). A ray whose distances over the texel lie strictly
//!   inside `(g0, g1)` meets nothing there: every kept entry's `[lo, hi]` lies outside the
//!   range, and a dropped one starts at or past `complete_to >= g1`. Behind a captured surface
//!   and in front of the next one, a ray passes through such gaps texel after texel; the
//!   tracer skips them, and whole cells of them through a pyramid over the gaps
//!   ([`TexelLists::gaps`]). Each end is stored rounded inwards to bfloat16 ([`pack_gap`]).
//!
//! # Capture (the CPU twin of `spirv/capture_lists.wgsl`)
//!
//! Written like a shader (fixed arrays, f32, the same operations in the same order as the WGSL;
//! every product rounded on its own, see `prod` in `spirv/shared/frustum.wgsl`). Per (triangle,
//! face), `l_i = to_face_local(face, v_i - centre)` (the permutation is exact):
//! 0. [`face_missed`]: the three corners outside one side plane of the dilated face frustum,
//!    each by a relative slack far above the plane value's rounding: skip the face. (This runs
//!    before step 1, so a triangle near the centre skips the faces it surely misses.)
//! 1. `R = max_i |l_i|_inf`, `E = 2^-18 R` ([`E_SCALE`]). `R` is CMO-local on purpose: the
//!    tracer intersects the same rounded local corners (`corner - centre`), so the bounds are
//!    sound for what is traced, and a scene far from the world's origin keeps the precision of
//!    its own extent (a world-scale `R` would make every triangle near a CMO at `1e5` "near the
//!    centre"). The local corners differ from the world triangle by `<= u R`, inside `E`.
//!    A triangle meeting the box `|p|_inf <= 2^10 E` around the centre ([`near_centre`]) gets
//!    every texel of every face, each with the whole triangle's bounds (below).
//! 2. [`clip`] the triangle to the face frustum dilated to `u, v in [-1 - 2^-7, 1 + 2^-7]`
//!    (planes `x - k z >= 0`, `k z - x >= 0`, same in y) -> P. Empty: skip the face.
//! 3. `z_min = min z over P`; `z_min <= 4 E`: the whole face (cannot happen after 1, kept as a
//!    guard); else the texel margin `m = 2^-20 + 4 E / z_min` (face units).
//! 4. The rect: the bbox of P's `(x / z, y / z)` widened by `m`, to texels by [`texel_floor`].
//! 5. Per 8x8 tile of the rect, skip the tile when it lies wholly outside the triangle
//!    ([`crate::cubemap::texel_cone::tile_outside`]). Per texel of the other tiles
//!    ([`texel_bound`]): first the fast paths of [`crate::cubemap::texel_cone`] (the texel's
//!    widened cone wholly outside the triangle: not touched; wholly inside it: bounds from the
//!    four corner rays, with their own derived slack); for the texels they leave, clip the
//!    *triangle* (not P: four clips instead of eight, half the error) to the texel's cone
//!    widened by `m` -> Q; empty: not touched. In a rect of at most [`UNCLIPPED_TEXELS`]
//!    texels, Q is the whole triangle instead (no clip; its bounds hold Q's).
//!    With `w` the f32 unit texel-centre direction, `lo = max(0, min_i dot(q_i, w) - E)`
//!    (written `lo > 0 ? lo : 0`),
//!    `hi = max_i |q_i| + E`: `|p| >= dot(p, w)` (Cauchy-Schwarz, `|w| <= 1` up to 2 ulps),
//!    a linear function's min over a polygon is at a vertex, and `|p|` is convex.
//! 6. `resolve_slice`: sort by `(lo, triangle)`, keep `depth`, `complete_to` = the smallest
//!    dropped `lo`.
//!
//! # Error budget (why `E = 2^-18 R`; the design's `2^-20 R` is too small for this chain)
//!
//! Unit roundoff `u = 2^-24`, absolute errors per component. Every point the capture computes
//! lies (up to the errors below) in the triangle's hull, so its coordinates are `<= R`, and
//! differences of two of them `<= 2R`.
//! - `v_i - centre`: `<= u R` from the world triangle (rounding is relative to the result,
//!   whose coordinates are `<= R`); the tracer uses these rounded corners itself.
//! - One clip point `i + (o - i) s` with `s` in `[0, 1]` (clamped): the subtraction `<= 2uR s`-ish,
//!   the product and the sum `<= 2uR s + uR`, at most `5 u R` in all. An error in `s` itself
//!   only moves the point *along* the segment (it stays on the triangle): it acts as a shifted
//!   plane, which the margin covers (next item). Errors of the ends carry over as a convex
//!   combination, so after the four clips of step 5 a vertex of Q is within `e = 21 u R` per
//!   component of a point `q'` of the exact triangle (`sqrt(3) e < 37 u R` in length).
//! - `lo`: `dot(q', w) >= dot(q, w) - 37 u R - 6 u R` (the 3-term dot product rounds by at most
//!   `3 u sqrt(3) R`), and `|w| <= 1 + 2u` costs `<= 4 u R` more: `< 48 u R < E = 64 u R`.
//!   `hi`: `|q'| <= |q| + 37 u R` plus the rounding of `sqrt(dot)` (`<= 3 u sqrt(3) R`): `< E`.
//!
//! # Why the margin makes inclusion sound
//!
//! Sutherland-Hodgman with rounded plane values `f` drops only the region between the computed
//! chord and the outside vertices; the exact points of that region have `f <= err_f`, where
//! `err_f` is the plane value's rounding at a clip point (`x - k z` with `|k| <= 3`: `<= 7 u R`)
//! plus the chord's position error through the plane (`(1 + |k|) e`), below `2 E` in all. A
//! point `p` of the texel's (closed) cone has `f = (u - x0 + m) z >= m z` for the widened plane,
//! so it is kept when `m z > 2 E`. Every point of the exact P lies `>= z_min - e` along z, so
//! `m = 4 E / z_min` (with `z_min >> e`) gives `m z > 2 E`. The `2^-20` in `m` covers the
//! rounding of the plane constants `x0 - m` (face units `<= 3`, so `<= 2^-22`), of `x / z` and of
//! [`texel_floor`] (relative `2^-24` of values `<= N`). The rect (step 4) contains every texel
//! the exact P reaches: `u` of a point moves by `<= e (1 + |u|) / z <= m` under a position error
//! `e`, and the perspective image of a convex polygon is the hull of its vertices' images.
//! The face clip of step 2 (dilation `D = 2^-7`) drops no point of the undilated face when
//! every point there has `D z > 2 E`: true once the triangle misses the near box (a point in the
//! face cone has `|p|_inf = z > 2^10 E / (1 + D)`).
//!
//! # Where it stops being sound, and what is done there
//! - Near the centre: within the box `|p|_inf <= 2^10 E = 2^-8 R` plane values through the centre
//!   lose their relative precision. Such a triangle gets every texel of all six faces with
//!   `lo = max(0, min_i dot(l_i, w) - E)`, `hi = max_i |l_i| + E` over its own three vertices
//!   (sound for any point of the triangle, however coarse). So does a face whose `z_min <= 4 E`
//!   or whose clip produced more than [`MAX_POLY`] vertices (only from rounding).
//! - Step 5's clip of more than [`MAX_POLY`] vertices falls back to the whole triangle for that
//!   texel.
//! - Inputs must be finite (the scene loader refuses others); `R` in the normal range.
//! - Other drivers: Vulkan lets division round to 2.5 ulp and `sqrt` inherit `inversesqrt`'s
//!   precision, and a driver may fuse `a * b + c`. The GPU's bits may then differ from this
//!   twin's (lavapipe's do not: `tests/bounded/capture_lists.rs`), but the bounds stay sound: a few
//!   ulps more in `s` (a shifted plane), in `u = x / z` (inside `2^-20`) and in `|w|` (`<= 9 u R`)
//!   still fit the `16 u R` left in `E`.
//! - The error terms above are first-order (products of two `u` are dropped); the budget keeps a
//!   factor `64 / 48` for them.
//!
//! # Where this departs from the design (`design22.md`), and why
//! - `E = 2^-18 R`, not `2^-20 R`: the error chain above needs `48 u R`; `2^-20 R` is `16 u R`.
//! - Face dilation `2^-7`, not `2^-10`: the face clip is sound only for points with
//!   `D z > 2 E`, so the near box must be `2 E / D` or larger; with `2^-10` it would be
//!   `2^-5 R`, with `2^-7` it is `2^-8 R` (the rect grows by `N 2^-8` texels a side, which
//!   step 5 rejects).
//! - The near box (step 1) is new: the design's `z_min <= 4 E` test alone does not catch a
//!   triangle whose part near the centre the face clip itself lost.
//! - Step 5 clips the triangle (four clips), not P (eight): half the error, same result up to it.
//! - `lo` is `lo > 0 ? lo : 0` (no `-0.0`, which the GPU's ordering by bits would misplace).
//! - The pool's `r` is `sqrt(2) (2 m + 2 / N)`: a square margin `m` reaches `sqrt(2) m`, and P's
//!   own error adds another `m`.
//!
//! # Pool
//! [`pool_bound`]: per (triangle, face), a texel touched lies in P (projected, face units, area
//! `A`, perimeter `L`) dilated by `r = sqrt(2) (2 m + 2 / N)` (the margin, P's own error `<= m`,
//! the texel's diagonal), whose area is `<= A + L r + pi r^2` (Steiner, P convex); divided by
//! the texel area `(2 / N)^2`, widened by `(1 + 2^-10)` and `+ 4` for rounding, and capped by the
//! rect's texel count. The GPU's job buffer holds one job per 8x8 tile of every rect.
//!
//! # Capacity
//! A convex polygon clipped by k planes has at most `3 + k` vertices (7 after four); rounding
//! can make a computed polygon slightly non-convex, hence [`MAX_POLY`] = 8 and the overflow
//! fallbacks above.

use glam::Vec3;
use rayon::prelude::*;

use super::face::{FACE_COUNT, Texel, face_coord, to_face_local};
pub use super::texel_cone::dot3;
use super::texel_cone::{Edges, TexelCone, edges, texel_cone_edges, tile_outside};

/// Entries kept per texel by default. Every entry is a node of the GPU's pool whatever the
/// depth: the depth bounds only the sorted prefix the tracer reads (and the resolve's
/// `depth x list` selection), so it costs time, not memory. At 16, a texel crossing a fence or
/// a dense mesh overflowed and the ray went unresolved (`tests/bounded/bounded_frame.rs` at cube
/// size 32: 35 of 1027 fence pixels, 56 of 1102 bunny pixels); at 64, 0 and 9. On the corpus's
/// dense scenes 64 still cut lists that rays pass behind: one CMO at the placement search's
/// first centre left 2.65 % of truck-garage's sample unresolved at 64, none at 1024, and the
/// search placed three CMOs to make up for it (a 477-588 ms frame against 258-311 ms with the
/// one CMO it places at 256). At 256 every corpus scene's fallback share is at most 1 % with
/// one CMO (320x240, the files' cube size 64), and the capture at cube size 256 is the same on
/// truck-garage and 30 % dearer on living-room (`benches/results/lavapipe-default-bounded.md`).
pub const DEFAULT_DEPTH: u32 = 256;

/// Vertices a clipped polygon holds (fixed arrays, as in a shader): a triangle clipped by four
/// planes has at most 7; one more for rounding (module docs, "Capacity").
pub const MAX_POLY: usize = 8;

/// `E / R` (module docs, "Error budget").
pub const E_SCALE: f32 = 1.0 / 262_144.0; // 2^-18
/// Dilation of the face frustum for the rect (`u, v in [-1 - D, 1 + D]`).
pub const FACE_DILATION: f32 = 1.0 / 128.0; // 2^-7
/// Face-unit floor of the texel margin: covers the rounding of plane constants and indices.
pub const MARGIN_FLOOR: f32 = 1.0 / 1_048_576.0; // 2^-20
/// Half-size of the box around the centre, in units of `E`, inside which a triangle gets every
/// texel of every face with its whole-triangle bounds ("Near the centre").
pub const NEAR_BOX: f32 = 1024.0; // 2^10

/// Rounding knobs: the sound capture, or every margin zero (the negative tests show that the
/// latter misses triangles). Not a user setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Margins {
    /// The derived margins (module docs).
    Sound,
    /// `E = 0`, no face dilation, no texel margin, no near-centre rule.
    #[cfg(test)]
    Zero,
}

/// A convex polygon of at most [`MAX_POLY`] vertices; `overflow` when a clip produced more
/// (only from rounding on a degenerate polygon: the caller falls back to the whole triangle).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Poly {
    pub p: [Vec3; MAX_POLY],
    pub n: u32,
    pub overflow: bool,
}

impl Poly {
    /// The triangle as a polygon.
    pub fn triangle(t: &[Vec3; 3]) -> Poly {
        let mut p = [Vec3::ZERO; MAX_POLY];
        p[0] = t[0];
        p[1] = t[1];
        p[2] = t[2];
        Poly {
            p,
            n: 3,
            overflow: false,
        }
    }

    fn push(&mut self, v: Vec3) {
        if (self.n as usize) < MAX_POLY {
            self.p[self.n as usize] = v;
            self.n += 1;
        } else {
            self.overflow = true;
        }
    }
}

/// Plane kinds of [`plane_value`]: face-local `u >= k`, `u <= k`, `v >= k`, `v <= k` (through
/// the centre), then the axis box `x <= k`, `x >= -k`, `y <= k`, `y >= -k`, `z <= k`, `z >= -k`.
pub const PLANE_U_MIN: u32 = 0;
pub const PLANE_U_MAX: u32 = 1;
pub const PLANE_V_MIN: u32 = 2;
pub const PLANE_V_MAX: u32 = 3;
pub const PLANE_BOX: u32 = 4;

/// The plane function (`>= 0` inside) of kind `kind` with constant `k` at `p`; a product is
/// rounded on its own (WGSL `prod`).
pub fn plane_value(p: Vec3, kind: u32, k: f32) -> f32 {
    match kind {
        PLANE_U_MIN => p.x - k * p.z,
        PLANE_U_MAX => k * p.z - p.x,
        PLANE_V_MIN => p.y - k * p.z,
        PLANE_V_MAX => k * p.z - p.y,
        4 => k - p.x,
        5 => p.x + k,
        6 => k - p.y,
        7 => p.y + k,
        8 => k - p.z,
        _ => p.z + k,
    }
}

/// Relative slack of [`face_missed`]: `2^-10`.
pub const MISS_SLACK: f32 = 1.0 / 1024.0;

/// Step 0: whether the face-local triangle `l` surely misses the face's frustum dilated by
/// `2^-7`: its three vertices lie outside the same side plane, each by more than `2^-10` of the
/// two coordinates the plane value sums. The plane value rounds by under `3 u (|x| + 2 |z|)`,
/// far inside that slack, so each vertex really lies in the open half-space outside the plane,
/// and so does the whole (convex) triangle: it meets no texel cone of the face. Cheap (no
/// clip), and the GPU's `faces` pass runs it on every (triangle, face) so that the costly steps
/// 1-4 run only on the pairs it keeps.
pub fn face_missed(l: &[Vec3; 3]) -> bool {
    let d = 1.0 + FACE_DILATION;
    let out = |p: Vec3, kind: u32, k: f32| {
        let a = if kind < PLANE_V_MIN { p.x } else { p.y };
        plane_value(p, kind, k) < -(MISS_SLACK * (a.abs() + p.z.abs()))
    };
    [
        (PLANE_U_MIN, -d),
        (PLANE_U_MAX, d),
        (PLANE_V_MIN, -d),
        (PLANE_V_MAX, d),
    ]
    .into_iter()
    .any(|(kind, k)| l.iter().all(|&p| out(p, kind, k)))
}

/// Sutherland-Hodgman: `poly` clipped to `plane_value(., kind, k) >= 0`. A crossing edge's new
/// vertex is interpolated from its inside end: `i + (o - i) s`, `s = min(f_i / (f_i - f_o), 1)`.
pub fn clip(poly: &Poly, kind: u32, k: f32) -> Poly {
    let mut out = Poly {
        p: [Vec3::ZERO; MAX_POLY],
        n: 0,
        overflow: poly.overflow,
    };
    if poly.n == 0 {
        return out;
    }
    let n = poly.n as usize;
    let mut f = [0.0f32; MAX_POLY];
    for (fi, &p) in f.iter_mut().zip(&poly.p[..n]) {
        *fi = plane_value(p, kind, k);
    }
    // Every vertex inside: the same vertices in the same order (each edge pushes its end
    // alone); every one outside: none. What the loop below gives, without it.
    if f[..n].iter().all(|&v| v >= 0.0) {
        return *poly;
    }
    if f[..n].iter().all(|&v| v < 0.0) {
        return out;
    }
    let mut a = poly.p[n - 1];
    let mut fa = f[n - 1];
    for (&b, &fb) in poly.p[..n].iter().zip(&f[..n]) {
        let a_in = fa >= 0.0;
        let b_in = fb >= 0.0;
        if a_in != b_in {
            let (pi, fi, po, fo) = if a_in { (a, fa, b, fb) } else { (b, fb, a, fa) };
            let s = (fi / (fi - fo)).min(1.0);
            out.push(pi + (po - pi) * s);
        }
        if b_in {
            out.push(b);
        }
        a = b;
        fa = fb;
    }
    out
}

/// [`clip`] of the triangle `t` by each `(kind, k)` of `planes` in turn, the same polygon bit for
/// bit: while a plane has every vertex inside, `clip` returns its input, so the triangle stays
/// as it is (no copy); the first plane with every vertex outside gives the empty polygon (and
/// so does every `clip` after it); only from the first plane that splits the triangle on is
/// `clip` run.
fn clip_triangle(t: &[Vec3; 3], planes: impl IntoIterator<Item = (u32, f32)>) -> Poly {
    let mut planes = planes.into_iter();
    while let Some((kind, k)) = planes.next() {
        let f = t.map(|p| plane_value(p, kind, k));
        if f.iter().all(|&v| v >= 0.0) {
            continue;
        }
        if f.iter().all(|&v| v < 0.0) {
            return Poly {
                p: [Vec3::ZERO; MAX_POLY],
                n: 0,
                overflow: false,
            };
        }
        let mut q = clip(&Poly::triangle(t), kind, k);
        for (kind, k) in planes {
            q = clip(&q, kind, k);
        }
        return q;
    }
    Poly::triangle(t)
}

/// The four side planes of the face-local rect `k = (u_min, u_max, v_min, v_max)` in [`clip`]'s
/// order.
fn rect_planes(k: [f32; 4]) -> [(u32, f32); 4] {
    [
        (PLANE_U_MIN, k[0]),
        (PLANE_U_MAX, k[1]),
        (PLANE_V_MIN, k[2]),
        (PLANE_V_MAX, k[3]),
    ]
}

fn max_abs(v: Vec3) -> f32 {
    v.x.abs().max(v.y.abs()).max(v.z.abs())
}

/// Texel column (row) holding face coordinate `u`, clamped: `floor((u + 1) N / 2)` in
/// `[0, N - 1]`.
pub fn texel_floor(u: f32, size: u32) -> u32 {
    let k = ((u + 1.0) * size as f32 * 0.5).floor();
    k.max(0.0).min((size - 1) as f32) as u32
}

/// Steps 1-4 for one (triangle, face): what the texels of the face need (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaceRect {
    pub face: u32,
    /// Texel rect, inclusive: columns `x0..=x1`, rows `y0..=y1`.
    pub x0: u32,
    pub x1: u32,
    pub y0: u32,
    pub y1: u32,
    /// Texel margin in face units.
    pub m: f32,
    /// Absolute error budget `E`.
    pub e: f32,
    /// The triangle passes near the centre (or `z_min <= 4 E`): every texel of the face, each
    /// with the whole triangle's bounds.
    pub whole: bool,
    /// Area and perimeter of the face-clipped polygon P in face units (`(u, v)`), for the pool
    /// bound; 0 when `whole`.
    pub area: f32,
    pub perimeter: f32,
}

impl FaceRect {
    /// Texels in the rect.
    pub fn texels(&self) -> u64 {
        u64::from(self.x1 - self.x0 + 1) * u64::from(self.y1 - self.y0 + 1)
    }

    /// 8x8 tiles covering the rect (the GPU's jobs), aligned to the rect's corner.
    pub fn tiles(&self) -> u64 {
        u64::from((self.x1 - self.x0) / TILE + 1) * u64::from((self.y1 - self.y0) / TILE + 1)
    }

    /// The Steiner bound of the texels this (triangle, face) can touch (module docs, "Pool").
    pub fn steiner(&self, size: u32) -> u64 {
        if self.whole {
            return self.texels();
        }
        let n = f64::from(size);
        let r = std::f64::consts::SQRT_2 * (2.0 * f64::from(self.m) + 2.0 / n);
        let area =
            f64::from(self.area) + f64::from(self.perimeter) * r + std::f64::consts::PI * r * r;
        let texel = (2.0 / n) * (2.0 / n);
        let bound = (area / texel * (1.0 + 1.0 / 1024.0) + 4.0).ceil();
        (bound as u64).min(self.texels())
    }

    /// The texels the fast paths ([`crate::cubemap::texel_cone`]) are expected to leave to the
    /// clips: those within `r` (as in [`FaceRect::steiner`]) of P's boundary, whose
    /// neighbourhood has area `<= 2 L r + pi r^2`, with a quarter more for rounding. Every texel
    /// of a `whole` rect, or of one of at most [`UNCLIPPED_TEXELS`], takes the whole triangle's
    /// bounds: none is clipped. Sizes the GPU's clip queue only: a texel that finds it full takes
    /// the whole triangle's bounds (sound).
    pub fn boundary(&self, size: u32) -> u64 {
        if self.whole || self.texels() <= UNCLIPPED_TEXELS {
            return 0;
        }
        let n = f64::from(size);
        let r = std::f64::consts::SQRT_2 * (2.0 * f64::from(self.m) + 2.0 / n);
        let area = 2.0 * f64::from(self.perimeter) * r + std::f64::consts::PI * r * r;
        let texel = (2.0 / n) * (2.0 / n);
        let bound = (area / texel * 1.25 + 8.0).ceil();
        (bound as u64).min(self.texels())
    }
}

/// Step 5's small rects: a (triangle, face) rect of at most this many texels gives each texel
/// that the fast paths leave the whole triangle's bounds (`min_i dot(l_i, w) - E`,
/// `max_i |l_i| + E`, the bounds of Q's superset) instead of clipping the triangle to the texel's
/// cone. A triangle that small spans at most a few texels, so its whole extent is not much
/// looser than its part in one texel, while the clips cost the GPU's capture most where the
/// triangles are smallest: on truck-garage at N = 64, 263k of its 285k nodes took a clip; the
/// `clips` pass was 20 ms of the 71 (benches/results/lavapipe-bounded-cost.md). A texel whose
/// cone the triangle misses may keep its entry: sound (a list may hold more than its cone
/// touches), and rare (5k of those clips came out empty).
pub const UNCLIPPED_TEXELS: u64 = 4;

/// Texels per side of a GPU job tile (the `texels` pass gives a tile job 16 lanes, up to four
/// texels each).
pub const TILE: u32 = 8;

/// The triangle in the face's local frame, CMO-local: `to_face_local(face, v_i - centre)`.
pub fn face_local(tri: &[Vec3; 3], centre: Vec3, face: u32) -> [Vec3; 3] {
    [
        to_face_local(face, tri[0] - centre),
        to_face_local(face, tri[1] - centre),
        to_face_local(face, tri[2] - centre),
    ]
}

/// Step 1: `E = 2^-18 R`, `R = max_i |l_i|_inf` (CMO-local: a scene far from the world's
/// origin keeps the precision of its own extent, module docs).
pub fn error_budget(local: &[Vec3; 3]) -> f32 {
    let mut r = max_abs(local[0]);
    for l in &local[1..] {
        r = r.max(max_abs(*l));
    }
    E_SCALE * r
}

/// Whether the triangle meets the box `|p|_inf <= NEAR_BOX E` around the centre (clipped by
/// its six planes; face-independent, the box is symmetric).
pub fn near_centre(local: &[Vec3; 3], e: f32) -> bool {
    let h = NEAR_BOX * e;
    let p = clip_triangle(local, (PLANE_BOX..PLANE_BOX + 6).map(|kind| (kind, h)));
    p.n > 0 || p.overflow
}

fn whole_face(face: u32, size: u32, e: f32) -> FaceRect {
    FaceRect {
        face,
        x0: 0,
        x1: size - 1,
        y0: 0,
        y1: size - 1,
        m: 2.0,
        e,
        whole: true,
        area: 0.0,
        perimeter: 0.0,
    }
}

/// Steps 1-4 for one (triangle, face): `None` when the triangle misses the (dilated) face.
pub fn face_rect(tri: &[Vec3; 3], centre: Vec3, face: u32, size: u32) -> Option<FaceRect> {
    face_rect_with(tri, centre, face, size, Margins::Sound)
}

fn face_rect_with(
    tri: &[Vec3; 3],
    centre: Vec3,
    face: u32,
    size: u32,
    margins: Margins,
) -> Option<FaceRect> {
    let l = face_local(tri, centre, face);
    if margins == Margins::Sound && face_missed(&l) {
        return None;
    }
    face_extent(&l, margins).map(|x| x.rect(face, size))
}

/// Steps 1-4 of one (triangle, face) before step 4's rounding to texels, which alone depends on
/// the face size: [`Extent::rect`] at a size is [`face_rect`] at it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Extent {
    /// The bbox of P's `(x / z, y / z)`, unwidened (unused when `whole`).
    u_lo: f32,
    u_hi: f32,
    v_lo: f32,
    v_hi: f32,
    m: f32,
    e: f32,
    whole: bool,
    area: f32,
    perimeter: f32,
}

impl Extent {
    /// Step 4's rect at face size `size`.
    fn rect(&self, face: u32, size: u32) -> FaceRect {
        if self.whole {
            return whole_face(face, size, self.e);
        }
        FaceRect {
            face,
            x0: texel_floor(self.u_lo - self.m, size),
            x1: texel_floor(self.u_hi + self.m, size),
            y0: texel_floor(self.v_lo - self.m, size),
            y1: texel_floor(self.v_hi + self.m, size),
            m: self.m,
            e: self.e,
            whole: false,
            area: self.area,
            perimeter: self.perimeter,
        }
    }
}

/// Steps 1-4 (no texels) of the face-local triangle `l`, which step 0 kept.
fn face_extent(l: &[Vec3; 3], margins: Margins) -> Option<Extent> {
    let sound = margins == Margins::Sound;
    let e = if sound { error_budget(l) } else { 0.0 };
    let whole = Extent {
        u_lo: 0.0,
        u_hi: 0.0,
        v_lo: 0.0,
        v_hi: 0.0,
        m: 2.0,
        e,
        whole: true,
        area: 0.0,
        perimeter: 0.0,
    };
    if sound && near_centre(l, e) {
        return Some(whole);
    }
    let d = if sound { 1.0 + FACE_DILATION } else { 1.0 };
    let p = clip_triangle(l, rect_planes([-d, d, -d, d]));
    if p.overflow {
        return Some(whole);
    }
    if p.n == 0 {
        return None;
    }
    let mut z_min = p.p[0].z;
    for i in 1..p.n as usize {
        z_min = z_min.min(p.p[i].z);
    }
    if z_min <= 4.0 * e {
        return Some(whole);
    }
    let m = if sound {
        MARGIN_FLOOR + 4.0 * e / z_min
    } else {
        0.0
    };
    let mut u_lo = f32::INFINITY;
    let mut u_hi = -f32::INFINITY;
    let mut v_lo = f32::INFINITY;
    let mut v_hi = -f32::INFINITY;
    let mut area = 0.0;
    let mut perimeter = 0.0;
    let last = p.p[p.n as usize - 1];
    let mut prev = (last.x / last.z, last.y / last.z);
    for i in 0..p.n as usize {
        let u = p.p[i].x / p.p[i].z;
        let v = p.p[i].y / p.p[i].z;
        u_lo = u_lo.min(u);
        u_hi = u_hi.max(u);
        v_lo = v_lo.min(v);
        v_hi = v_hi.max(v);
        area += prev.0 * v - u * prev.1;
        perimeter += ((u - prev.0) * (u - prev.0) + (v - prev.1) * (v - prev.1)).sqrt();
        prev = (u, v);
    }
    Some(Extent {
        u_lo,
        u_hi,
        v_lo,
        v_hi,
        m,
        e,
        whole: false,
        area: 0.5 * area.abs(),
        perimeter,
    })
}

/// The f32 unit direction through a texel's centre, face-local: `d / sqrt(dot(d, d))` as
/// `d * (1 / sqrt(..))`.
pub fn texel_centre_unit(x: u32, y: u32, size: u32) -> Vec3 {
    let n = size as f32;
    let d = Vec3::new(
        (2 * x + 1) as f32 / n - 1.0,
        (2 * y + 1) as f32 / n - 1.0,
        1.0,
    );
    let inv = 1.0 / dot3(d, d).sqrt();
    d * inv
}

/// Step 5: `(lo, hi)` of the face-local triangle `local` in texel `(x, y)` of `rect`'s face, or
/// `None` when it does not touch the texel's cone widened by `rect.m`.
pub fn texel_bound(
    local: &[Vec3; 3],
    rect: &FaceRect,
    x: u32,
    y: u32,
    size: u32,
) -> Option<(f32, f32)> {
    let f = [
        face_coord(x, size),
        face_coord(x + 1, size),
        face_coord(y, size),
        face_coord(y + 1, size),
    ];
    texel_bound_edges(local, &edges(local), rect, texel_centre_unit(x, y, size), f)
}

/// A face size's texel values that step 5 reads for every (triangle, texel): each texel's
/// unit centre direction ([`texel_centre_unit`]) and each texel edge's [`face_coord`], made once
/// per list build and looked up, the same values bit for bit.
struct TexelGrid {
    size: u32,
    /// `face_coord(k, size)`, `k = 0..=size`.
    coord: Vec<f32>,
    /// `texel_centre_unit(x, y, size)` at `y * size + x`.
    w: Vec<Vec3>,
}

impl TexelGrid {
    fn new(size: u32) -> Self {
        let w = (0..size * size)
            .map(|i| texel_centre_unit(i % size, i / size, size))
            .collect();
        TexelGrid {
            size,
            coord: (0..=size).map(|k| face_coord(k, size)).collect(),
            w,
        }
    }

    /// Texel `(x, y)`'s centre direction and its edges' face coordinates `(x0, x1, y0, y1)`.
    fn texel(&self, x: u32, y: u32) -> (Vec3, [f32; 4]) {
        let (c, i) = (&self.coord, (y * self.size + x) as usize);
        let (x, y) = (x as usize, y as usize);
        (self.w[i], [c[x], c[x + 1], c[y], c[y + 1]])
    }
}

/// [`texel_bound`] with the triangle's [`edges`] `g` made once for its texels, for the texel
/// whose unit centre direction is `w` and whose edges' face coordinates are `f`
/// (`(x0, x1, y0, y1)`, [`TexelGrid::texel`]).
fn texel_bound_edges(
    local: &[Vec3; 3],
    g: &Edges,
    rect: &FaceRect,
    w: Vec3,
    f: [f32; 4],
) -> Option<(f32, f32)> {
    let mut q = Poly::triangle(local);
    if !rect.whole {
        let m = rect.m;
        let k = [f[0] - m, f[1] + m, f[2] - m, f[3] + m];
        match texel_cone_edges(g, k, w, rect.e) {
            TexelCone::Outside => return None,
            TexelCone::Inside(lo, hi) => return Some((lo, hi)),
            // A small rect's texels take the whole triangle's bounds ([`UNCLIPPED_TEXELS`]).
            TexelCone::Clip if rect.texels() <= UNCLIPPED_TEXELS => {
                return Some(poly_bound(&q, w, rect.e));
            }
            TexelCone::Clip => {}
        }
        q = clip_triangle(local, rect_planes(k));
        if q.overflow {
            q = Poly::triangle(local);
        } else if q.n == 0 {
            return None;
        }
    }
    Some(poly_bound(&q, w, rect.e))
}

/// Step 5's `(lo, hi)` of the polygon `q` (the clipped Q, or the whole triangle) in the texel
/// whose unit centre direction is `w`, with error budget `e`.
fn poly_bound(q: &Poly, w: Vec3, e: f32) -> (f32, f32) {
    let mut d_min = f32::INFINITY;
    let mut r_max = 0.0f32;
    for i in 0..q.n as usize {
        d_min = d_min.min(dot3(q.p[i], w));
        r_max = r_max.max(dot3(q.p[i], q.p[i]).sqrt());
    }
    // `lo > 0 ? lo : 0`: no -0.0 (the GPU orders `lo` by its bits) and a NaN is 0.
    let lo = d_min - e;
    (if lo > 0.0 { lo } else { 0.0 }, r_max + e)
}

/// Step 6 for one texel, in place: sorts `list` by `(lo, triangle)` and keeps its first `depth`;
/// returns `(lo, hi, complete_to)` of the texel (module docs) and how many it keeps.
fn resolve_slice(list: &mut [Entry], depth: u32) -> ((f32, f32, f32), usize) {
    // Unstable is the same order: a texel's list holds a triangle once, so no two keys are equal.
    list.sort_unstable_by(|a, b| a.lo.total_cmp(&b.lo).then(a.triangle.cmp(&b.triangle)));
    let complete_to = list.get(depth as usize).map_or(f32::INFINITY, |e| e.lo);
    let kept = list.len().min(depth as usize);
    (texel_summary(&list[..kept], complete_to), kept)
}

/// The gap of a texel (module docs) from its kept entries, sorted by `(lo, triangle)`, and its
/// `complete_to`, as `[g1, g0]` (the far end first: a pyramid over gaps keeps the min of the far
/// ends and the max of the near ends, [`crate::cubemap::pyramid::MipPyramid::over_cells`]).
/// Walking the entries in order, each entry that starts past the end (the largest `hi`) of those
/// before it opens a gap between them; the texel keeps the widest by ratio (`g1 / g0`, the first
/// of equals; compared as `c1 b0 > b1 c0`, products that round alike on every device), clamped to
/// `complete_to`. The gap after the last entry, up to `complete_to`, competes when `complete_to`
/// is finite, and is the gap where no other opens (an empty texel's is `(0, complete_to)`). The
/// GPU's `resolve` (`spirv/capture_lists.wgsl`) computes the same while it sorts, with the same
/// comparisons.
///
/// Why the widest and not the first: a ray leaving a captured reflector runs behind the
/// reflector's own surfaces as the CMO sees them (an open mug's inner and outer walls, a
/// teapot's body). The first gap is often the thin one between those surfaces; the wide one behind
/// them is where such rays run, texel after texel.
pub fn texel_gap(kept: &[Entry], complete_to: f32) -> [f32; 2] {
    let wider = |c: [f32; 2], b: [f32; 2]| c[1] * b[0] > b[1] * c[0];
    let mut end = 0.0f32;
    let mut best: Option<[f32; 2]> = None;
    for (i, e) in kept.iter().enumerate() {
        if i == 0 {
            end = e.hi;
            continue;
        }
        if e.lo > end && best.is_none_or(|b| wider([end, e.lo], b)) {
            best = Some([end, e.lo]);
        }
        end = end.max(e.hi);
    }
    let tail = [end, complete_to];
    let [g0, g1] = match best {
        Some(b) if !(complete_to < f32::INFINITY && complete_to > end && wider(tail, b)) => b,
        _ => tail,
    };
    [g1.min(complete_to), g0]
}

/// A gap `[g1, g0]` in one word, as the GPU stores it (one word per texel, like the lists'
/// records, so the gaps fit wherever the records do): each end rounded inwards to bfloat16,
/// `g1` down into the high half, `g0` up into the low half. Rounding inwards only narrows the
/// gap, so it stays sound; the relative loss is below `2^-7`. Both ends are `>= +0.0`, whose
/// bits order as the values: truncating rounds down, and a truncated non-zero remainder adds
/// one unit to round up (`+inf` stays `+inf`; the largest finite value rounds up to `+inf`).
pub fn pack_gap([g1, g0]: [f32; 2]) -> u32 {
    let b0 = g0.to_bits();
    (g1.to_bits() & 0xffff_0000) | ((b0 >> 16) + u32::from(b0 & 0xffff != 0))
}

/// `[g1, g0]` of a packed gap ([`pack_gap`]).
pub fn unpack_gap(w: u32) -> [f32; 2] {
    [f32::from_bits(w & 0xffff_0000), f32::from_bits(w << 16)]
}

/// `(lo, hi, complete_to)` of a texel from its kept (sorted) entries and `complete_to`.
pub fn texel_summary(kept: &[Entry], complete_to: f32) -> (f32, f32, f32) {
    let first = kept.first().map_or(f32::INFINITY, |e| e.lo);
    let hi = if complete_to < f32::INFINITY {
        f32::INFINITY
    } else {
        kept.iter().fold(-f32::INFINITY, |h, e| h.max(e.hi))
    };
    (first.min(complete_to), hi, complete_to)
}

/// The face size of the `bounded` criterion's per-texel lists (`--list-size`). Every hit the
/// lists give is a listed triangle's exact intersection, the first along the ray whatever the
/// texels' size, and the exact fallback takes the rays they leave: the face size changes what
/// the capture and the trace cost and how many rays reach the fallback, not the image (but for
/// the last bits of a hit that one tracer finds and the other leaves; `lavapipe-list-size.md`
/// in `benches/results`). A glossy reflector's cone pass reads CMOs of its own at the cube size
/// (`CmoPlan::cone_size`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ListSize {
    /// The first of [`AUTO_LIST_MIN`], twice that, ... below the cube size whose lists stay
    /// short, at most [`AUTO_LIST_LENGTH`] nodes per texel by the node pool's bound, else the
    /// cube size ([`auto_list_size`], `vk::passes::capture_lists::list_size`).
    #[default]
    Auto,
    /// The cube size (`--cube-size`, else the scene's).
    Cube,
    /// This many texels per face side.
    Fixed(u32),
}

/// `--list-size auto`'s smallest face size ([`auto_list_size`]).
pub const AUTO_LIST_MIN: u32 = 32;
/// `--list-size auto`'s longest mean list: nodes of the pool's bound per texel (the help of
/// `--list-size` states it; [`auto_list_size`]). At 8 the dense corpus scenes took lists of 128
/// texels, whose capture cost more than the longer lists' walks saved: at 16 they take 32 or
/// 64, and their frames cost 15-50 % less for a fallback share of at most 0.8 %
/// (`benches/results/lavapipe-list-size.md`).
pub const AUTO_LIST_LENGTH: u64 = 16;
/// The placement search's shorter lists: where one CMO on the reflectors' axis misses the target
/// with lists of `auto`'s size, the search judges it with lists of this mean length before it
/// searches more centres (`placement`, [`Placement::list_size`](crate::placement::Placement)).
pub const SHORT_LIST_LENGTH: u64 = 8;

/// `--list-size auto`'s rule for `cmos` CMOs of face size `cube_size`: the first of
/// [`AUTO_LIST_MIN`], twice that, ... below `cube_size` at which `nodes(size)` (the node pool's
/// bound summed over the CMOs, [`pool_bound`]) is at most [`AUTO_LIST_LENGTH`] per texel, else
/// `cube_size`. The GPU's plan (`vk::passes::capture_lists::list_size`) and the placement
/// search's bounded score both take it.
pub fn auto_list_size(cube_size: u32, cmos: usize, nodes: impl FnMut(u32) -> u64) -> u32 {
    list_size_for(cube_size, cmos, AUTO_LIST_LENGTH, nodes)
}

/// [`auto_list_size`]'s rule with lists of at most `length` nodes per texel.
pub fn list_size_for(
    cube_size: u32,
    cmos: usize,
    length: u64,
    mut nodes: impl FnMut(u32) -> u64,
) -> u32 {
    let mut size = AUTO_LIST_MIN;
    while size < cube_size {
        let texels = cmos as u64 * 6 * u64::from(size) * u64::from(size);
        if nodes(size) <= length * texels {
            return size;
        }
        size *= 2;
    }
    cube_size
}

/// Steps 1-6 for one CMO: every triangle `t` with `captured[t]`, every face.
pub fn capture_lists(
    triangles: &[[Vec3; 3]],
    captured: &[bool],
    centre: Vec3,
    size: u32,
    depth: u32,
) -> TexelLists {
    capture_lists_with(triangles, captured, centre, size, depth, Margins::Sound)
}

fn capture_lists_with(
    triangles: &[[Vec3; 3]],
    captured: &[bool],
    centre: Vec3,
    size: u32,
    depth: u32,
    margins: Margins,
) -> TexelLists {
    FacePairs::with(triangles, captured, centre, margins).lists(size, depth)
}

/// One CMO's (triangle, face) pairs that step 0 keeps, each with its steps 1-4 at no face size:
/// what [`pool_bound`] sums and [`capture_lists`] fills texels from, found once for both and for
/// every face size (`--list-size auto`'s rule weighs several).
pub struct FacePairs<'a> {
    triangles: &'a [[Vec3; 3]],
    centre: Vec3,
    /// The pairs step 0 keeps ([`PoolBound::pairs`]).
    kept: u64,
    /// The kept pairs that step 2 leaves non-empty.
    pairs: Vec<Pair>,
}

/// `(triangle, face, extent)` of a pair.
type Pair = (u32, u32, Extent);

/// [`FacePairs`] without its borrow of the triangles ([`FacePairs::into_parts`]): kept while the
/// caller moves the triangles, and made whole again over the same triangles
/// ([`FacePairs::from_parts`]) for another face size.
pub struct PairParts {
    centre: Vec3,
    kept: u64,
    pairs: Vec<Pair>,
}

impl PairParts {
    /// The CMO centre the pairs were found at.
    pub fn centre(&self) -> Vec3 {
        self.centre
    }
}

impl<'a> FacePairs<'a> {
    /// The pairs of every triangle `t` with `captured[t]`, every face, at `centre`.
    pub fn new(triangles: &'a [[Vec3; 3]], captured: &[bool], centre: Vec3) -> Self {
        Self::with(triangles, captured, centre, Margins::Sound)
    }

    fn with(triangles: &'a [[Vec3; 3]], captured: &[bool], centre: Vec3, margins: Margins) -> Self {
        let sound = margins == Margins::Sound;
        let per: Vec<(u64, Vec<Pair>)> = (triangles.par_chunks(PAIR_CHUNK))
            .enumerate()
            .map(|(c, chunk)| {
                let (mut kept, mut pairs) = (0, Vec::new());
                for (i, tri) in chunk.iter().enumerate() {
                    let t = c * PAIR_CHUNK + i;
                    if !captured.get(t).copied().unwrap_or(false) {
                        continue;
                    }
                    // `face_local` of each face: the differences once, then each face's
                    // exact permutation of them.
                    let d = tri.map(|v| v - centre);
                    for face in 0..FACE_COUNT {
                        let l = d.map(|v| to_face_local(face, v));
                        if sound && face_missed(&l) {
                            continue;
                        }
                        kept += 1;
                        if let Some(x) = face_extent(&l, margins) {
                            pairs.push((t as u32, face, x));
                        }
                    }
                }
                (kept, pairs)
            })
            .collect();
        FacePairs {
            triangles,
            centre,
            kept: per.iter().map(|p| p.0).sum(),
            pairs: per.into_iter().flat_map(|p| p.1).collect(),
        }
    }

    /// The pairs without the triangles they were found on.
    pub fn into_parts(self) -> PairParts {
        PairParts {
            centre: self.centre,
            kept: self.kept,
            pairs: self.pairs,
        }
    }

    /// The pairs `parts` over `triangles`, which must be the triangles they were found on
    /// ([`FacePairs::new`]): the pairs name triangles by index.
    pub fn from_parts(triangles: &'a [[Vec3; 3]], parts: PairParts) -> Self {
        FacePairs {
            triangles,
            centre: parts.centre,
            kept: parts.kept,
            pairs: parts.pairs,
        }
    }

    /// [`pool_bound`] at face size `size`.
    pub fn bound(&self, size: u32) -> PoolBound {
        // Integer sums: the same whatever order the threads add them in.
        let mut b = (self.pairs.par_iter())
            .map(|&(_, face, x)| {
                let rect = x.rect(face, size);
                PoolBound {
                    jobs: rect.tiles(),
                    nodes: rect.steiner(size),
                    clips: rect.boundary(size),
                    rect_texels: rect.texels(),
                    pairs: 0,
                }
            })
            .reduce(PoolBound::default, |a, b| a + b);
        b.pairs = self.kept;
        b
    }

    /// Steps 5-6 at face size `size`, keeping `depth` entries per texel: [`capture_lists`].
    pub fn lists(&self, size: u32, depth: u32) -> TexelLists {
        let n = size as usize;
        let texels = FACE_COUNT as usize * n * n;
        let grid = TexelGrid::new(size);
        // Step 5 over chunks of pairs in parallel: `(texel, entry)` in any order, since step 6
        // sorts a texel's entries by `(lo, triangle)`, a total order (one entry per triangle).
        let found: Vec<Vec<(u32, Entry)>> = (self.pairs.par_chunks(PAIR_CHUNK))
            .map(|chunk| {
                let mut out = Vec::new();
                for &(t, face, x) in chunk {
                    let rect = x.rect(face, size);
                    let local = face_local(&self.triangles[t as usize], self.centre, face);
                    let base = face as usize * n * n;
                    rect_entries(&local, &rect, &grid, |x, y, lo, hi| {
                        let texel = (base + y as usize * n + x as usize) as u32;
                        out.push((
                            texel,
                            Entry {
                                triangle: t,
                                lo,
                                hi,
                            },
                        ));
                    });
                }
                out
            })
            .collect();
        // Bucketed by texel (a counting sort).
        let mut start = vec![0u32; texels + 1];
        for &(texel, _) in found.iter().flatten() {
            start[texel as usize + 1] += 1;
        }
        for i in 0..texels {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let empty = Entry {
            triangle: 0,
            lo: 0.0,
            hi: 0.0,
        };
        let mut all = vec![empty; start[texels] as usize];
        for &(texel, e) in found.iter().flatten() {
            all[fill[texel as usize] as usize] = e;
            fill[texel as usize] += 1;
        }
        drop(found);
        // Step 6 per texel, in parallel.
        let mut slices: Vec<&mut [Entry]> = Vec::with_capacity(texels);
        let mut rest = all.as_mut_slice();
        for w in start.windows(2) {
            let (head, tail) = rest.split_at_mut((w[1] - w[0]) as usize);
            slices.push(head);
            rest = tail;
        }
        let resolved: Vec<(f32, f32, f32)> = (slices.par_iter_mut())
            .map(|list| resolve_slice(list, depth).0)
            .collect();
        let mut out = TexelLists {
            size,
            depth,
            lo: Vec::with_capacity(texels),
            hi: Vec::with_capacity(texels),
            complete_to: Vec::with_capacity(texels),
            offsets: Vec::with_capacity(texels + 1),
            entries: Vec::new(),
        };
        out.offsets.push(0);
        for (w, (lo, hi, complete_to)) in start.windows(2).zip(resolved) {
            let kept = (w[1] - w[0]).min(depth) as usize;
            out.lo.push(lo);
            out.hi.push(hi);
            out.complete_to.push(complete_to);
            let from = w[0] as usize;
            out.entries.extend_from_slice(&all[from..from + kept]);
            out.offsets.push(out.entries.len() as u32);
        }
        out
    }
}

/// Triangles (of [`FacePairs::new`]) or pairs (of its steps 5-6) per parallel task.
const PAIR_CHUNK: usize = 1024;

/// Step 5 for the face-local triangle `local` over `rect`: `f(x, y, lo, hi)` for every texel it
/// touches, row by row within each 8x8 tile.
fn rect_entries(
    local: &[Vec3; 3],
    rect: &FaceRect,
    grid: &TexelGrid,
    mut f: impl FnMut(u32, u32, f32, f32),
) {
    let size = grid.size;
    let g = edges(local);
    for ty in (rect.y0..=rect.y1).step_by(TILE as usize) {
        for tx in (rect.x0..=rect.x1).step_by(TILE as usize) {
            let x1 = (tx + TILE - 1).min(rect.x1);
            let y1 = (ty + TILE - 1).min(rect.y1);
            if !rect.whole && tile_outside(&g, [tx, x1], [ty, y1], size, rect.m) {
                continue;
            }
            for y in ty..=y1 {
                for x in tx..=x1 {
                    let (w, fc) = grid.texel(x, y);
                    if let Some((lo, hi)) = texel_bound_edges(local, &g, rect, w, fc) {
                        f(x, y, lo, hi);
                    }
                }
            }
        }
    }
}

/// Capacities one CMO's capture needs: GPU jobs (8x8 tiles of every rect) and nodes (the
/// Steiner bound, summed).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PoolBound {
    pub jobs: u64,
    pub nodes: u64,
    /// Texels the GPU's clip queue is sized for ([`FaceRect::boundary`]).
    pub clips: u64,
    /// Texels of every rect (the nodes' trivial bound).
    pub rect_texels: u64,
    /// (Triangle, face) pairs that [`face_missed`] keeps: the GPU's face queue.
    pub pairs: u64,
}

/// The sum of two bounds (of two CMOs, or two parts of one).
impl std::ops::Add for PoolBound {
    type Output = PoolBound;

    fn add(self, b: PoolBound) -> PoolBound {
        PoolBound {
            jobs: self.jobs + b.jobs,
            nodes: self.nodes + b.nodes,
            clips: self.clips + b.clips,
            rect_texels: self.rect_texels + b.rect_texels,
            pairs: self.pairs + b.pairs,
        }
    }
}

/// [`PoolBound`] of one CMO at `centre`.
pub fn pool_bound(
    triangles: &[[Vec3; 3]],
    captured: &[bool],
    centre: Vec3,
    size: u32,
) -> PoolBound {
    FacePairs::new(triangles, captured, centre).bound(size)
}

/// One candidate of a texel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    /// Global triangle index ([`crate::scene::WorldGeometry::triangles`] order).
    pub triangle: u32,
    /// Lower bound of the triangle's distance from the centre inside the texel's cone.
    pub lo: f32,
    /// Upper bound of the same.
    pub hi: f32,
}

/// The lists of a set of CMOs built on the CPU, with what they were built from: the centres
/// (in CMO order), every triangle's corners (global order) and whether the capture takes it.
/// The GPU's capture is their twin bit for bit (`tests/bounded/capture_lists.rs`), so a frame
/// whose capture has the same inputs may upload these instead of capturing
/// ([`BuiltLists::same_inputs`]); the placement search's judge hands its lists on so.
#[derive(Debug, Clone)]
pub struct BuiltLists {
    pub centres: Vec<Vec3>,
    pub corners: Vec<[Vec3; 3]>,
    pub captured: Vec<bool>,
    /// One per centre, of one face size, [`DEFAULT_DEPTH`] entries deep.
    pub lists: Vec<TexelLists>,
}

/// A capture's triangles: each one's corners, and whether the capture takes it.
type Triangles = (Vec<[Vec3; 3]>, Vec<bool>);

impl BuiltLists {
    /// Whether a capture at face size `size` of the views `(centre, reflectors)`, each over
    /// `triangles(reflectors)` (corners and the capture's flags), has these lists' inputs, bit
    /// for bit; else what differs, in words.
    pub fn same_inputs(
        &self,
        size: u32,
        views: &[(Vec3, bool)],
        triangles: impl Fn(bool) -> Triangles,
    ) -> Result<(), String> {
        let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
        let corner_bits = |t: &[Vec3; 3]| t.map(|v| bits(&v));
        if views.len() != self.lists.len() {
            return Err(format!("{} CMOs, not {}", views.len(), self.lists.len()));
        }
        // Each flag's triangles built once, not once per view.
        let mut known: [Option<Triangles>; 2] = [None, None];
        for (k, ((c, reflectors), l)) in views.iter().zip(&self.lists).enumerate() {
            if (l.size, l.depth) != (size, DEFAULT_DEPTH) {
                let d = DEFAULT_DEPTH;
                return Err(format!(
                    "CMO {k}: lists of face size {} and depth {}, not {size} and {d}",
                    l.size, l.depth
                ));
            }
            if bits(c) != bits(&self.centres[k]) {
                return Err(format!("CMO {k}: centre {c}, not {}", self.centres[k]));
            }
            let (corners, flags) =
                known[usize::from(*reflectors)].get_or_insert_with(|| triangles(*reflectors));
            if *flags != self.captured {
                return Err(format!("CMO {k}: other triangles captured"));
            }
            let same = corners.len() == self.corners.len()
                && (corners.iter().zip(&self.corners))
                    .all(|(a, b)| corner_bits(a) == corner_bits(b));
            if !same {
                return Err(format!("CMO {k}: other triangle corners"));
            }
        }
        Ok(())
    }
}

/// One CMO's per-texel bounds and candidate lists (module docs). Texel order: [`Texel::index`].
#[derive(Debug, Clone, PartialEq)]
pub struct TexelLists {
    /// Face size N.
    pub size: u32,
    /// Entries kept per texel.
    pub depth: u32,
    /// Per texel: lower bound over everything in the cone.
    pub lo: Vec<f32>,
    /// Per texel: upper bound over what the list holds (`+inf` when incomplete).
    pub hi: Vec<f32>,
    /// Per texel: the distance from which the list may be incomplete.
    pub complete_to: Vec<f32>,
    /// Per texel `i`, its entries are `entries[offsets[i]..offsets[i + 1]]`.
    pub offsets: Vec<u32>,
    /// The kept entries, texel by texel, each texel's sorted by `(lo, triangle)`.
    pub entries: Vec<Entry>,
}

impl TexelLists {
    /// The kept entries of a texel.
    pub fn entries_at(&self, t: Texel) -> &[Entry] {
        let i = t.index(self.size);
        &self.entries[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Every texel's gap packed into a word ([`texel_gap`], [`pack_gap`]), in the texels'
    /// order: what the GPU's `resolve` writes.
    pub fn packed_gaps(&self) -> Vec<u32> {
        (0..self.lo.len())
            .map(|i| {
                let kept = &self.entries[self.offsets[i] as usize..self.offsets[i + 1] as usize];
                pack_gap(texel_gap(kept, self.complete_to[i]))
            })
            .collect()
    }

    /// Every texel's gap `[g1, g0]` as the tracers read it: packed and unpacked
    /// ([`pack_gap`]: rounded inwards), in the texels' order.
    pub fn gaps(&self) -> Vec<[f32; 2]> {
        self.packed_gaps().into_iter().map(unpack_gap).collect()
    }

    /// `(lo, hi, complete_to)` of a texel.
    pub fn bounds_at(&self, t: Texel) -> (f32, f32, f32) {
        let i = t.index(self.size);
        (self.lo[i], self.hi[i], self.complete_to[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cubemap::face::{dir_to_texel, from_face_local, texel_centre_dir};

    /// splitmix64, fixed seed.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        }
        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.next()
        }
        fn vec(&mut self, s: f32) -> Vec3 {
            Vec3::new(self.range(-s, s), self.range(-s, s), self.range(-s, s))
        }
    }

    /// Small triangles around `centre`: ordinary, thin (a sliver), edge-on (the centre in the
    /// plane), crossing behind the centre, and near the centre.
    fn test_triangles(rng: &mut Rng, centre: Vec3, count: usize) -> Vec<[Vec3; 3]> {
        let mut out = Vec::new();
        for i in 0..count {
            let c = centre + rng.vec(3.0);
            let t = match i % 5 {
                0 => [c, c + rng.vec(0.6), c + rng.vec(0.6)],
                1 => {
                    let a = c + rng.vec(0.8);
                    let b = c + rng.vec(0.8);
                    [a, b, a.lerp(b, 0.5) + rng.vec(0.002)]
                }
                2 => {
                    // Edge-on: two directions from the centre span the plane.
                    let d0 = rng.vec(1.0);
                    let d1 = rng.vec(1.0);
                    let p = |s: f32, t: f32| centre + d0 * s + d1 * t;
                    [p(1.0, 0.1), p(1.2, 0.3), p(0.8, 0.25)]
                }
                3 => {
                    let d = rng.vec(1.0);
                    [
                        centre + d * 2.0 + rng.vec(0.3),
                        centre - d * 1.5,
                        centre - d + rng.vec(0.5),
                    ]
                }
                _ => {
                    let d = rng.vec(0.01);
                    [centre + d, centre + rng.vec(0.5), centre + rng.vec(0.5)]
                }
            };
            out.push(t);
        }
        out
    }

    /// Points of a triangle on a barycentric grid (`k` steps per edge, corners and edges
    /// included).
    fn samples(t: &[Vec3; 3], k: u32) -> Vec<Vec3> {
        let mut out = Vec::new();
        for i in 0..=k {
            for j in 0..=k - i {
                let b1 = i as f32 / k as f32;
                let b2 = j as f32 / k as f32;
                let b0 = 1.0 - b1 - b2;
                out.push(t[0] * b0 + t[1] * b1 + t[2] * b2);
            }
        }
        out
    }

    /// The brute-force check: every sample point `p` of every triangle lies in the texel its
    /// direction maps to, that texel's list holds the triangle with `lo <= |p| <= hi`, and
    /// the texel's `lo <= |p|`. Returns the number of failures.
    fn brute_force_misses(lists: &TexelLists, triangles: &[[Vec3; 3]], centre: Vec3) -> usize {
        let mut misses = 0;
        for (t, tri) in triangles.iter().enumerate() {
            for p in samples(tri, 40) {
                let r = p - centre;
                if r == Vec3::ZERO {
                    continue;
                }
                let d = r.length();
                let texel = dir_to_texel(r, lists.size);
                let entry = lists
                    .entries_at(texel)
                    .iter()
                    .find(|e| e.triangle == t as u32);
                let (lo, _, _) = lists.bounds_at(texel);
                let ok = entry.is_some_and(|e| e.lo <= d && d <= e.hi) && lo <= d;
                if !ok {
                    misses += 1;
                }
            }
        }
        misses
    }

    fn all(n: usize) -> Vec<bool> {
        vec![true; n]
    }

    #[test]
    fn every_sampled_point_is_in_its_texels_list() {
        let mut rng = Rng(22);
        for (size, centre) in [
            (4u32, Vec3::ZERO),
            (16, Vec3::new(0.5, -2.0, 7.0)),
            (64, Vec3::new(100.0, 3.0, -40.0)),
        ] {
            let tris = test_triangles(&mut rng, centre, 40);
            let lists = capture_lists(&tris, &all(tris.len()), centre, size, 1000);
            assert_eq!(brute_force_misses(&lists, &tris, centre), 0, "N = {size}");
            assert!(lists.entries.len() > tris.len(), "N = {size}: no entries");
        }
    }

    /// Möller-Trumbore from the origin along `d` (edges inclusive): the hit's `t`.
    fn ray_hits(d: Vec3, p: [Vec3; 3]) -> Option<f32> {
        let e1 = p[1] - p[0];
        let e2 = p[2] - p[0];
        let h = d.cross(e2);
        let a = e1.dot(h);
        if a == 0.0 {
            return None;
        }
        let s = -p[0];
        let u = s.dot(h) / a;
        let q = s.cross(e1);
        let v = d.dot(q) / a;
        let t = e2.dot(q) / a;
        (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
    }

    /// Captured by the centre rays only (the `exact` criterion's capture): a triangle is in a
    /// texel's list when the texel's centre ray hits it.
    fn centre_sampled(tris: &[[Vec3; 3]], centre: Vec3, size: u32) -> TexelLists {
        let n = size as usize;
        let mut lists: Vec<Vec<Entry>> = vec![Vec::new(); 6 * n * n];
        for (i, list) in lists.iter_mut().enumerate() {
            let d = texel_centre_dir(Texel::from_index(i, size), size).normalize();
            for (t, tri) in tris.iter().enumerate() {
                let p = [tri[0] - centre, tri[1] - centre, tri[2] - centre];
                if let Some(t_hit) = ray_hits(d, p) {
                    list.push(Entry {
                        triangle: t as u32,
                        lo: t_hit,
                        hi: t_hit,
                    });
                }
            }
        }
        let mut out = TexelLists {
            size,
            depth: 1000,
            lo: Vec::new(),
            hi: Vec::new(),
            complete_to: Vec::new(),
            offsets: vec![0],
            entries: Vec::new(),
        };
        for mut list in lists {
            let ((lo, hi, c), kept) = resolve_slice(&mut list, 1000);
            out.lo.push(lo);
            out.hi.push(hi);
            out.complete_to.push(c);
            out.entries.extend_from_slice(&list[..kept]);
            out.offsets.push(out.entries.len() as u32);
        }
        out
    }

    #[test]
    fn negative_centre_sampling_misses_thin_triangles() {
        let mut rng = Rng(23);
        let centre = Vec3::new(0.5, -2.0, 7.0);
        let tris = test_triangles(&mut rng, centre, 20);
        let lists = centre_sampled(&tris, centre, 16);
        assert!(brute_force_misses(&lists, &tris, centre) > 0);
    }

    /// Thin triangles hugging texel boundaries (and face edges): with every margin zero the
    /// clip's rounding drops some of them from texels their points map to.
    #[test]
    fn negative_zero_margins_miss_boundary_triangles() {
        let mut rng = Rng(24);
        let size = 16;
        let centre = Vec3::new(0.3, 0.7, -0.2);
        let mut tris = Vec::new();
        for i in 0..400u32 {
            let face = i % 6;
            let k = (i / 6) % (size + 1);
            let u = face_coord(k, size);
            let on = |z: f32, v: f32, du: f32| {
                centre + from_face_local(face, Vec3::new((u + du) * z, v * z, z))
            };
            let z0 = rng.range(0.5, 5.0);
            let z1 = rng.range(0.5, 5.0);
            let v0 = rng.range(-1.0, 1.0);
            let v1 = rng.range(-1.0, 1.0);
            tris.push([on(z0, v0, 0.0), on(z1, v1, 0.0), on(z0, v1, 1e-7)]);
        }
        let sound = capture_lists(&tris, &all(tris.len()), centre, size, 1000);
        assert_eq!(brute_force_misses(&sound, &tris, centre), 0);
        let zero = capture_lists_with(&tris, &all(tris.len()), centre, size, 1000, Margins::Zero);
        let misses = brute_force_misses(&zero, &tris, centre);
        eprintln!("zero margins: {misses} sample points missed");
        assert!(misses > 0);
    }

    /// The docs' rules of a truncated texel against the full list; `Err` names the first
    /// difference.
    fn check_truncation(full: &TexelLists, cut: &TexelLists) -> Result<(), String> {
        for i in 0..full.lo.len() {
            let t = Texel::from_index(i, full.size);
            let all = full.entries_at(t);
            let kept = cut.entries_at(t);
            let depth = cut.depth as usize;
            if kept != &all[..all.len().min(depth)] {
                return Err(format!(
                    "{t:?}: kept entries are not the full list's prefix"
                ));
            }
            let (lo, hi, complete_to) = cut.bounds_at(t);
            for dropped in &all[kept.len()..] {
                if complete_to > dropped.lo {
                    return Err(format!(
                        "{t:?}: complete_to {complete_to} > dropped {dropped:?}"
                    ));
                }
            }
            let want_c = all.get(depth).map_or(f32::INFINITY, |e| e.lo);
            if complete_to != want_c {
                return Err(format!("{t:?}: complete_to {complete_to}, want {want_c}"));
            }
            let (full_lo, full_hi, _) = full.bounds_at(t);
            if lo != full_lo {
                return Err(format!("{t:?}: lo {lo}, full {full_lo}"));
            }
            let want_hi = if all.len() > depth {
                f32::INFINITY
            } else {
                full_hi
            };
            if hi != want_hi {
                return Err(format!("{t:?}: hi {hi}, want {want_hi}"));
            }
        }
        Ok(())
    }

    #[test]
    fn depth_truncation_keeps_complete_to_sound() {
        let mut rng = Rng(25);
        let centre = Vec3::new(1.0, 2.0, 3.0);
        // Many overlapping triangles: deep lists.
        let mut tris = test_triangles(&mut rng, centre, 30);
        for _ in 0..30 {
            let d = rng.vec(1.0).normalize_or(Vec3::X) * rng.range(1.0, 4.0);
            tris.push([
                centre + d + rng.vec(0.8),
                centre + d + rng.vec(0.8),
                centre + d + rng.vec(0.8),
            ]);
        }
        let flags = all(tris.len());
        let full = capture_lists(&tris, &flags, centre, 8, u32::MAX);
        let cut = capture_lists(&tris, &flags, centre, 8, 3);
        assert!(
            (0..full.lo.len()).any(|i| full.offsets[i + 1] - full.offsets[i] > 3),
            "no list deeper than 3"
        );
        check_truncation(&full, &cut).unwrap();
        // Negative: complete_to raised past a dropped entry, a kept entry's lo perturbed.
        let i = (0..cut.lo.len())
            .find(|&i| cut.complete_to[i].is_finite())
            .unwrap();
        let mut bad = cut.clone();
        bad.complete_to[i] = f32::from_bits(bad.complete_to[i].to_bits() + 1);
        assert!(check_truncation(&full, &bad).is_err());
        let mut bad = cut.clone();
        bad.entries[0].lo = f32::from_bits(bad.entries[0].lo.to_bits() + 1);
        assert!(check_truncation(&full, &bad).is_err());
    }

    #[test]
    fn a_triangle_clipped_at_once_is_clipped_plane_by_plane() {
        let bits = |p: &Poly| {
            let v: Vec<[u32; 3]> = p.p.iter().map(|v| v.to_array().map(f32::to_bits)).collect();
            (v, p.n, p.overflow)
        };
        let mut rng = Rng(57);
        let (mut split, mut empty, mut whole) = (0, 0, 0);
        for i in 0..4000 {
            let a = rng.vec(1.0) + Vec3::Z * 2.0;
            let t = match i % 3 {
                // Collinear corners: a sliver.
                0 => [a, a + Vec3::X * 0.3, a + Vec3::X * 0.6],
                _ => [a, a + rng.vec(0.8), a + rng.vec(0.8)],
            };
            let k = [rng.range(-1.2, 0.4), rng.range(-0.4, 1.2)];
            let planes: Vec<(u32, f32)> = match i % 2 {
                0 => rect_planes([k[0], k[1], k[0], k[1]]).to_vec(),
                _ => (PLANE_BOX..PLANE_BOX + 6)
                    .map(|kind| (kind, k[1] + 1.5))
                    .collect(),
            };
            let mut q = Poly::triangle(&t);
            for &(kind, k) in &planes {
                q = clip(&q, kind, k);
            }
            let p = clip_triangle(&t, planes.iter().copied());
            assert_eq!(bits(&p), bits(&q), "triangle {i}");
            match p.n {
                0 => empty += 1,
                3 if p == Poly::triangle(&t) => whole += 1,
                _ => split += 1,
            }
        }
        // Every case taken: whole, empty and split by a plane.
        assert!(
            split > 100 && empty > 100 && whole > 100,
            "{split} {empty} {whole}"
        );
        // Negative: a plane left out gives another polygon.
        let t = [
            Vec3::new(-0.5, -0.5, 1.0),
            Vec3::new(0.5, -0.5, 1.0),
            Vec3::new(0.0, 0.5, 1.0),
        ];
        let all = clip_triangle(&t, rect_planes([-0.2, 0.2, -0.2, 0.2]));
        let three = clip_triangle(&t, rect_planes([-0.2, 0.2, -0.2, 0.2]).into_iter().take(3));
        assert_ne!(bits(&all), bits(&three));
    }

    #[test]
    fn the_grid_holds_each_texels_values() {
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for size in [8u32, 32, 48] {
            let grid = TexelGrid::new(size);
            for y in 0..size {
                for x in 0..size {
                    let (w, f) = grid.texel(x, y);
                    let want = [x, x + 1, y, y + 1].map(|k| face_coord(k, size).to_bits());
                    assert_eq!(
                        bits(w),
                        bits(texel_centre_unit(x, y, size)),
                        "{x} {y} {size}"
                    );
                    assert_eq!(f.map(f32::to_bits), want, "{x} {y} {size}");
                }
            }
        }
        // Negative: a texel's values are not its transposed neighbour's.
        let grid = TexelGrid::new(32);
        assert_ne!(grid.texel(3, 5), grid.texel(5, 3));
    }

    /// The entries of `lists` in `(texel index, triangle, lo bits, hi bits)`, sorted.
    fn entry_set(lists: &TexelLists) -> Vec<(usize, u32, u32, u32)> {
        let mut out = Vec::new();
        for (i, w) in lists.offsets.windows(2).enumerate() {
            for e in &lists.entries[w[0] as usize..w[1] as usize] {
                out.push((i, e.triangle, e.lo.to_bits(), e.hi.to_bits()));
            }
        }
        out.sort_unstable();
        out
    }

    #[test]
    fn the_lists_hold_each_texels_own_bound() {
        let mut rng = Rng(41);
        let centre = Vec3::new(0.5, -2.0, 7.0);
        let tris = test_triangles(&mut rng, centre, 40);
        let size = 16u32;
        let lists = capture_lists(&tris, &all(tris.len()), centre, size, u32::MAX);
        // Each texel's bound found on its own ([`texel_bound`], no grid, no tiles), shifted
        // `dx` texels along x (0: the texel itself).
        let direct = |dx: u32| {
            let mut out = Vec::new();
            for (t, tri) in tris.iter().enumerate() {
                for face in 0..FACE_COUNT {
                    let Some(rect) = face_rect(tri, centre, face, size) else {
                        continue;
                    };
                    let l = face_local(tri, centre, face);
                    for y in rect.y0..=rect.y1 {
                        for x in rect.x0..=rect.x1 {
                            let xs = (x + dx).min(size - 1);
                            if let Some((lo, hi)) = texel_bound(&l, &rect, xs, y, size) {
                                let i = ((face * size + y) * size + x) as usize;
                                out.push((i, t as u32, lo.to_bits(), hi.to_bits()));
                            }
                        }
                    }
                }
            }
            out.sort_unstable();
            out
        };
        assert!(!lists.entries.is_empty());
        assert_eq!(entry_set(&lists), direct(0));
        // Negative: the neighbour's bounds are not the texel's.
        assert_ne!(entry_set(&lists), direct(1));
    }

    #[test]
    fn pairs_taken_apart_give_the_same_lists() {
        let mut rng = Rng(31);
        let centre = Vec3::new(0.5, -2.0, 7.0);
        let tris = test_triangles(&mut rng, centre, 60);
        let flags = all(tris.len());
        let fresh = FacePairs::new(&tris, &flags, centre);
        let parts = FacePairs::new(&tris, &flags, centre).into_parts();
        assert_eq!(parts.centre(), centre);
        let again = FacePairs::from_parts(&tris, parts);
        for size in [8, 32] {
            assert_eq!(again.bound(size), fresh.bound(size));
            assert_eq!(
                again.lists(size, DEFAULT_DEPTH),
                fresh.lists(size, DEFAULT_DEPTH)
            );
        }
        // Negative: the parts over other triangles give other lists.
        let other = test_triangles(&mut rng, centre, 60);
        let wrong = FacePairs::from_parts(&other, again.into_parts());
        assert_ne!(
            wrong.lists(32, DEFAULT_DEPTH),
            fresh.lists(32, DEFAULT_DEPTH)
        );
    }

    #[test]
    fn pool_bound_covers_the_entries() {
        let mut rng = Rng(26);
        for (size, centre) in [
            (4u32, Vec3::ZERO),
            (16, Vec3::new(0.5, -2.0, 7.0)),
            (64, Vec3::ONE),
        ] {
            let tris = test_triangles(&mut rng, centre, 40);
            let flags = all(tris.len());
            let lists = capture_lists(&tris, &flags, centre, size, u32::MAX);
            let b = pool_bound(&tris, &flags, centre, size);
            let used = lists.entries.len() as u64;
            eprintln!(
                "N = {size}: {used} entries, bound {} of {} rect texels",
                b.nodes, b.rect_texels
            );
            assert!(used <= b.nodes && b.nodes <= b.rect_texels, "N = {size}");
            assert!(b.jobs >= 1);
        }
        // Negative: the area alone (no Steiner terms) undercounts a thin triangle's texels.
        let centre = Vec3::ZERO;
        let tri = [
            Vec3::new(-0.9, 0.01, 1.0),
            Vec3::new(0.9, 0.0101, 1.0),
            Vec3::new(0.0, 0.0102, 1.0),
        ];
        let rect = face_rect(&tri, centre, 4, 64).unwrap();
        let lists = capture_lists(&[tri], &[true], centre, 64, u32::MAX);
        let area_only = (f64::from(rect.area) / (2.0f64 / 64.0).powi(2)).ceil() as usize;
        assert!(lists.entries.len() > area_only);
        assert!(lists.entries.len() as u64 <= rect.steiner(64));
    }

    #[test]
    fn near_centre_gets_the_whole_face() {
        let centre = Vec3::new(10.0, 0.0, 0.0);
        // Passes 1e-4 from the centre.
        let tri = [
            centre + Vec3::new(-1.0, 1e-4, 1.0),
            centre + Vec3::new(1.0, 1e-4, 1.0),
            centre + Vec3::new(0.0, 1e-4, -1.0),
        ];
        for face in 0..FACE_COUNT {
            let r = face_rect(&tri, centre, face, 8).unwrap();
            assert!(r.whole && r.texels() == 64, "face {face}");
        }
        // Negative: far from the centre it is not.
        let far = tri.map(|v| v + Vec3::new(0.0, 1.0, 0.0));
        assert!((0..FACE_COUNT).all(|f| face_rect(&far, centre, f, 8).is_none_or(|r| !r.whole)));
    }

    /// Whether the f64 point `p` (face-local) lies in the closed face frustum `|x|, |y| <= z`.
    fn in_face(p: glam::DVec3) -> bool {
        p.z >= 0.0 && p.x.abs() <= p.z && p.y.abs() <= p.z
    }

    /// Step 0 keeps its promise: a triangle it skips has no point in the face's frustum (f64
    /// samples over the triangle), and it skips many (so the property was exercised). The
    /// triangles include near-centre and edge-on ones (`test_triangles`).
    #[test]
    fn face_missed_triangles_miss_the_face() {
        let mut rng = Rng(11);
        let (mut missed, mut kept) = (0, 0);
        for scale in [1e-3f32, 1.0, 1e3] {
            let tris = test_triangles(&mut rng, Vec3::ZERO, 400);
            for tri in tris.iter().map(|t| t.map(|v| v * scale)) {
                for face in 0..FACE_COUNT {
                    let l = face_local(&tri, Vec3::ZERO, face);
                    if !face_missed(&l) {
                        kept += 1;
                        continue;
                    }
                    missed += 1;
                    let [a, b, c] = l.map(|v| v.as_dvec3());
                    for i in 0..=16 {
                        for j in 0..=16 - i {
                            let (u, v) = (f64::from(i) / 16.0, f64::from(j) / 16.0);
                            let p = a + (b - a) * u + (c - a) * v;
                            assert!(!in_face(p), "{tri:?} face {face}: {p} is in the face");
                        }
                    }
                }
            }
        }
        assert!(missed > 1000 && kept > 1000, "{missed} missed, {kept} kept");
    }

    /// Step 0's slack: a corner just outside a side plane (by less than the slack) keeps the
    /// face; the same corner well outside skips it. Negative for the test above: a triangle
    /// that reaches into the face is never skipped.
    #[test]
    fn face_missed_keeps_what_touches_the_face() {
        let d = 1.0 + FACE_DILATION;
        // Every corner at u = -d (1 + t), z = 1: outside the dilated u-min plane by t d.
        let at = |t: f32| {
            [
                Vec3::new(-d * (1.0 + t), 0.0, 1.0),
                Vec3::new(-d * (1.0 + t), 0.5, 1.0),
                Vec3::new(-2.0 * d * (1.0 + t), 0.0, 2.0),
            ]
        };
        assert!(face_missed(&at(1e-2)));
        assert!(!face_missed(&at(1e-4)));
        // One corner inside the face: never skipped.
        let mut tri = at(1.0);
        tri[1] = Vec3::new(0.0, 0.0, 1.0);
        assert!(!face_missed(&tri));
        // Behind the centre (z < 0): outside every side plane at once.
        let behind = [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.1, 0.0, -1.0),
            Vec3::new(0.0, 0.1, -1.0),
        ];
        assert!(face_missed(&behind));
    }

    /// The texel's gap is the widest by ratio that an entry opens past the end of those before
    /// it, not the first; the one after the last entry competes only up to a finite
    /// `complete_to`, and is the gap where no other opens. Negatives: an entry moved into the
    /// wide gap, or a nearer `complete_to`, changes the gap.
    #[test]
    fn the_gap_is_the_widest_an_entry_opens() {
        let e = |triangle, lo, hi| Entry { triangle, lo, hi };
        // Runs [1, 1.1] and [1.2, 1.3] (a thin gap between a reflector's two walls), then [5, 6].
        let walls = [e(0, 1.0, 1.1), e(1, 1.2, 1.3), e(2, 5.0, 6.0)];
        let inf = f32::INFINITY;
        assert_eq!(texel_gap(&walls, inf), [5.0, 1.3]);
        // A finite `complete_to` past the last entry competes: 100 / 6 is wider than 5 / 1.3.
        assert_eq!(texel_gap(&walls, 100.0), [100.0, 6.0]);
        // One that is narrower does not; one nearer than the gap's far end clamps it.
        assert_eq!(texel_gap(&walls, 7.0), [5.0, 1.3]);
        assert_eq!(texel_gap(&walls, 4.0), [4.0, 1.3]);
        // An entry that overlaps the run before it opens nothing; none opening: the tail.
        let overlapping = [e(0, 1.0, 2.0), e(1, 1.5, 3.0)];
        assert_eq!(texel_gap(&overlapping, inf), [inf, 3.0]);
        assert_eq!(texel_gap(&[], 9.0), [9.0, 0.0]);
        // Negatives: the far entry moved near makes the walls' gap the widest; moved into the
        // wide gap, it splits it.
        let near = [e(0, 1.0, 1.1), e(1, 1.2, 1.3), e(2, 1.31, 6.0)];
        assert_eq!(texel_gap(&near, inf), [1.2, 1.1]);
        let split = [
            e(0, 1.0, 1.1),
            e(1, 1.2, 1.3),
            e(3, 2.0, 2.1),
            e(2, 5.0, 6.0),
        ];
        assert_eq!(texel_gap(&split, inf), [5.0, 2.1]);
        // Equal ratios: the first.
        let equal = [e(0, 1.0, 1.0), e(1, 2.0, 2.0), e(2, 4.0, 4.0)];
        assert_eq!(texel_gap(&equal, inf), [2.0, 1.0]);
    }

    /// A small rect's texels that the fast paths leave take the whole triangle's bounds, not the
    /// clip's ([`UNCLIPPED_TEXELS`]). Negative: the same triangle grown past the rule has texels
    /// whose clipped `lo` lies above the whole triangle's.
    #[test]
    fn small_rects_take_the_whole_triangles_bounds() {
        let (centre, size) = (Vec3::ZERO, 8);
        // Tilted (its depth varies), across the texel column boundary at u = 0 on face +z.
        let small = [
            Vec3::new(-0.05, 0.02, 1.0),
            Vec3::new(0.05, 0.03, 1.3),
            Vec3::new(0.0, 0.06, 1.1),
        ];
        let whole = |tri: &[Vec3; 3], i: usize| {
            let t = Texel::from_index(i, size);
            let l = face_local(tri, centre, t.face);
            let (w, e) = (texel_centre_unit(t.x, t.y, size), error_budget(&l));
            let d_min = l.iter().fold(f32::INFINITY, |d, &p| d.min(dot3(p, w)));
            let r_max = l.iter().fold(0.0f32, |r, &p| r.max(dot3(p, p).sqrt()));
            let lo = d_min - e;
            (if lo > 0.0 { lo } else { 0.0 }, r_max + e)
        };
        let rect = face_rect(&small, centre, 4, size).unwrap();
        assert!((2..=UNCLIPPED_TEXELS).contains(&rect.texels()));
        let lists = capture_lists(&[small], &[true], centre, size, u32::MAX);
        let mut texels = 0;
        for (i, w) in lists.offsets.windows(2).enumerate() {
            for e in &lists.entries[w[0] as usize..w[1] as usize] {
                assert_eq!((e.lo, e.hi), whole(&small, i), "texel {i}");
                texels += 1;
            }
        }
        assert!(texels >= 2, "{texels} texels");
        let large = small.map(|v| Vec3::new(v.x * 12.0, v.y * 12.0, v.z));
        assert!(face_rect(&large, centre, 4, size).unwrap().texels() > UNCLIPPED_TEXELS);
        let lists = capture_lists(&[large], &[true], centre, size, u32::MAX);
        let tighter = (lists.offsets.windows(2).enumerate())
            .filter(|(i, w)| w[1] > w[0] && lists.entries[w[0] as usize].lo > whole(&large, *i).0)
            .count();
        assert!(
            tighter > 0,
            "no texel of the large triangle was clipped tighter"
        );
    }
}

//! Step 5's fast paths: most texels a triangle's rect holds are either wholly outside the
//! triangle or wholly inside it, and neither needs the four clips of [`super::bounds`]. This is
//! the CPU twin of `spirv/shared/capture_fast.wgsl` (the same f32 operations in the same order,
//! every product rounded on its own).
//!
//! Per (triangle, texel), with the CMO-local corners `l_i` (exact f32 values: the triangle the
//! tracer intersects) and the texel's cone widened by the margin `m`, whose four corner
//! directions are `c_j = (u_j, v_j, 1)` (`u` in `{x0 - m, x1 + m}`, `v` in `{y0 - m, y1 + m}`,
//! the same rounded constants the clips use):
//! - the edge planes through the centre `N_0 = l_0 x l_1`, `N_1 = l_1 x l_2`, `N_2 = l_2 x l_0`,
//!   and the orientation `s = sign(h)`, `h = dot(l_0, N_1) = det(l_0, l_1, l_2)`. A direction
//!   `d` points into the triangle exactly when `s dot(N_i, d) >= 0` for all `i` (the three planes
//!   bound the cone over the triangle; `l_2` itself has `s dot(N_0, l_2) = |h| > 0`).
//! - **Outside:** some edge plane has all four corners on its outer side, `s g_ij < -d_j` for
//!   every `j`, where `g_ij` is the computed `dot(N_i, c_j)` and `d_j = 2^-20 R^2 |c_j|_1` its
//!   error bound. The texel's cone is the hull of its corner directions, so no direction of the
//!   cone (widened or not) meets the triangle: the texel gets no entry.
//! - **Inside:** every `s g_ij > d_j`. The widened cone lies in the triangle's cone, so the
//!   triangle's part in it is the quad `P_j = t_j c_j`, `t_j = h / dot(n, c_j)`,
//!   `n = N_0 + N_1 + N_2 = (l_1 - l_0) x (l_2 - l_0)`. A linear function's minimum and `|p|`'s
//!   maximum over the quad are at its corners: `lo = min_j t_j dot(c_j, w) (1 - 2 rho) - E`,
//!   `hi = max_j t_j |c_j| (1 + 2 rho) + E`, with `rho` the relative error bound below. Taken
//!   only where `|h| >= 2^10 d_h` and every `|dot(n, c_j)| >= 2^10 4 d_j` (relative errors
//!   `<= 2^-10`); otherwise, and for texels neither outside nor inside, the clips run.
//!
//! # Error bounds (`u = 2^-24`, `R = max_i |l_i|_inf`, first order; the factor 2 on `rho` keeps
//! room for the second-order terms and for computing `rho` itself)
//! - A component of a cross product `a b - c d` with `|a|, .. <= R`: two products and a
//!   difference of magnitude `<= 2 R^2`: `<= 4 u R^2 (1 + u) <= 5 u R^2`.
//! - `g_ij`: rounding of a three-term dot product `<= 3 u (1 + 2u) sum_k |N_k c_k|
//!   <= 6.01 u R^2 |c|_1`, plus `|c|_1 5 u R^2` from `N`'s error: `<= 11.1 u R^2 |c|_1 < d_j =
//!   16 u R^2 |c|_1` (computing `d_j` loses `<= 4 u` of it).
//! - `h`: `3 u (1 + 2u) 3 R 2 R^2 + 3 R 5 u R^2 <= 33.1 u R^3 < d_h = 2^-18 R^3 = 64 u R^3`.
//! - `n`: three crosses (`15 u R^2`) and two sums (`|N_0 + N_1| <= 4 R^2`, `|n| <= 6 R^2`:
//!   `10 u R^2`), `<= 26 u R^2`; `dot(n, c_j)`: `3 u 6 R^2 |c|_1 + 26 u R^2 |c|_1 <= 44.1 u R^2
//!   |c|_1 < 4 d_j`.
//! - With `rho_h = d_h / |h|` and `rho_d = 4 d_j / |dot(n, c_j)|` (both `<= 2^-10`), the exact
//!   `h` and `dot(n, c_j)` share the computed ones' signs, and `t_j` is within
//!   `(rho_h + rho_d)(1 + 2^-8) + u` of the exact one, relatively.
//! - `dot(c_j, w)` (`w` the f32 texel-centre direction, used as is): `3.01 u |c|_1 max_k |w_k|`,
//!   relative `rho_w = 4 u |c|_1 / dot(c_j, w)`; `|c_j| = sqrt(dot(c_j, c_j))`: `2.5 u`; the
//!   products `u` each.
//! - `rho = rho_h + max_j rho_d + max_j rho_w + 16 u` bounds each corner's relative error
//!   (`1.01 (rho_h + rho_d + rho_w) + 5 u`) with room. `|p| >= dot(p, w) / |w|` and
//!   `|w| <= 1 + 3 u` (inside the `16 u`): `lo` is below the distance of every point of the quad,
//!   `hi` above it. `E` is kept on both, as on the clipped path.

use glam::Vec3;

use super::face::face_coord;

/// `2^-20 = 16 u`: `d_j / (R^2 |c_j|_1)`, and the constant term of `rho`.
const EDGE_SLACK: f32 = 1.0 / 1_048_576.0;
/// `2^-18 = 64 u`: `d_h / R^3`.
const DET_SLACK: f32 = 1.0 / 262_144.0;
/// `2^-22 = 4 u`: `rho_w |dot(c, w)| / |c|_1`.
const DOT_SLACK: f32 = 1.0 / 4_194_304.0;
/// The smallest `|value| / error bound` at which the inside path computes its bounds.
const CONDITION: f32 = 1024.0;

/// What the fast paths decide for one texel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TexelCone {
    /// The triangle misses the widened cone.
    Outside,
    /// The widened cone lies inside the triangle: `(lo, hi)`.
    Inside(f32, f32),
    /// Neither proven: clip.
    Clip,
}

/// `dot(a, b)` in the shader's order, each product rounded on its own.
pub fn dot3(a: Vec3, b: Vec3) -> f32 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// `a x b`, each product rounded on its own, in the shader's order.
fn cross3(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    )
}

/// The per-triangle values the tests share: the edge planes `N_i`, `h`, `d_h` and
/// `unit = 2^-20 R^2`.
#[derive(Debug, Clone, Copy)]
pub struct Edges {
    n: [Vec3; 3],
    h: f32,
    d_h: f32,
    unit: f32,
}

/// The [`Edges`] of the face-local triangle `l`.
pub fn edges(l: &[Vec3; 3]) -> Edges {
    let mut r = 0.0f32;
    for v in l {
        r = r.max(v.x.abs()).max(v.y.abs()).max(v.z.abs());
    }
    let n = [cross3(l[0], l[1]), cross3(l[1], l[2]), cross3(l[2], l[0])];
    let r2 = r * r;
    Edges {
        n,
        h: dot3(l[0], n[1]),
        d_h: DET_SLACK * r2 * r,
        unit: EDGE_SLACK * r2,
    }
}

/// The corner directions `c_j` of the widened planes `k` and their `|c_j|_1`.
fn corners(k: [f32; 4]) -> ([Vec3; 4], [f32; 4]) {
    let c = [
        Vec3::new(k[0], k[2], 1.0),
        Vec3::new(k[1], k[2], 1.0),
        Vec3::new(k[0], k[3], 1.0),
        Vec3::new(k[1], k[3], 1.0),
    ];
    (c, c.map(|c| c.x.abs() + c.y.abs() + 1.0))
}

/// Bit 0: some edge plane has the four corners of `k` outside; bit 1: every edge plane has them
/// inside; 4 when the orientation is not sure (`|h| <= d_h`; neither may then be used).
fn classify(g: &Edges, k: [f32; 4]) -> u32 {
    let (c, a) = corners(k);
    let mut any_out = 0;
    let mut all_in = 2;
    for n in &g.n {
        let (mut out, mut inside) = (true, true);
        for j in 0..4 {
            let v = dot3(*n, c[j]);
            let sv = if g.h > 0.0 { v } else { -v };
            let d = g.unit * a[j];
            out &= sv < -d;
            inside &= sv > d;
        }
        if out {
            any_out = 1;
        }
        if !inside {
            all_in = 0;
        }
    }
    if g.h.abs() > g.d_h {
        any_out | all_in
    } else {
        4
    }
}

/// The fast paths for the face-local triangle `l` and the widened texel planes
/// `k = (u_min, u_max, v_min, v_max)`, with `w` the texel-centre direction and `e` the error
/// budget `E` (module docs).
pub fn texel_cone(l: &[Vec3; 3], k: [f32; 4], w: Vec3, e: f32) -> TexelCone {
    texel_cone_edges(&edges(l), k, w, e)
}

/// [`texel_cone`] of the triangle whose [`edges`] are `g` (made once for its texels, as the
/// GPU's `texels` makes them once per job).
pub fn texel_cone_edges(g: &Edges, k: [f32; 4], w: Vec3, e: f32) -> TexelCone {
    match classify(g, k) {
        1 | 3 => TexelCone::Outside,
        2 if g.h.abs() >= CONDITION * g.d_h => inside_bounds(g, k, w, e),
        _ => TexelCone::Clip,
    }
}

/// Whether the tile of texels `[x0, x1] x [y0, y1]` of a face of size `size`, widened by the
/// margin `m`, lies wholly outside the triangle of `g`: each of its texels' widened cones lies in
/// the tile's (the corners are convex combinations), so none of them meets the triangle. The
/// GPU's `jobs` pass emits no job for such a tile, and the capture skips its texels.
pub fn tile_outside(g: &Edges, x: [u32; 2], y: [u32; 2], size: u32, m: f32) -> bool {
    let k = [
        face_coord(x[0], size) - m,
        face_coord(x[1] + 1, size) + m,
        face_coord(y[0], size) - m,
        face_coord(y[1] + 1, size) + m,
    ];
    matches!(classify(g, k), 1 | 3)
}

fn inside_bounds(g: &Edges, k: [f32; 4], w: Vec3, e: f32) -> TexelCone {
    let (c, a) = corners(k);
    let n = g.n[0] + g.n[1] + g.n[2];
    let mut rho_d = 0.0f32;
    let mut rho_w = 0.0f32;
    let mut lo = f32::INFINITY;
    let mut hi = 0.0f32;
    for j in 0..4 {
        let dd = 4.0 * (g.unit * a[j]);
        let den = dot3(n, c[j]);
        let cw = dot3(c[j], w);
        if !(den.abs() >= CONDITION * dd && cw > 0.0) {
            return TexelCone::Clip;
        }
        rho_d = rho_d.max(dd / den.abs());
        rho_w = rho_w.max(DOT_SLACK * a[j] / cw);
        let t = g.h / den;
        lo = lo.min(t * cw);
        hi = hi.max(t * dot3(c[j], c[j]).sqrt());
    }
    let rho = g.d_h / g.h.abs() + rho_d + rho_w + EDGE_SLACK;
    let lo = lo * (1.0 - 2.0 * rho) - e;
    TexelCone::Inside(if lo > 0.0 { lo } else { 0.0 }, hi * (1.0 + 2.0 * rho) + e)
}

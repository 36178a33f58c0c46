//! Cube face selection and texel addressing: the one mapping used for capture, lookup and tracing.
//!
//! Conventions (Vulkan specification, "Cube Map Face Selection"):
//! - Face order `+X, -X, +Y, -Y, +Z, -Z` (indices 0..6).
//! - For a direction `r`, the face's `(sc, tc, ma)` is
//!
//!   | face | sc  | tc  | ma |
//!   |------|-----|-----|----|
//!   | +X   | -rz | -ry | rx |
//!   | -X   | +rz | -ry | rx |
//!   | +Y   | +rx | +rz | ry |
//!   | -Y   | +rx | -rz | ry |
//!   | +Z   | +rx | -ry | rz |
//!   | -Z   | -rx | -ry | rz |
//!
//!   and `s = (sc/|ma| + 1)/2`, `t = (tc/|ma| + 1)/2`, both in `[0, 1]`.
//! - **Face-local frame**: `to_face_local(face, r) = (sc, tc, |ma|)`. It is a signed permutation
//!   (exact in f32, length preserving), so the face's frustum is `z > 0, |x| <= z, |y| <= z`, with
//!   face coordinates `u = x/z = 2s - 1`, `v = y/z = 2t - 1` in `[-1, 1]`.
//! - **Texels**: a face of size `N` has `N x N` texels; texel `(x, y)` covers
//!   `s in [x/N, (x+1)/N)`, `t in [y/N, (y+1)/N)` (row `y = 0` at `t = 0`). Texel boundaries in
//!   face coordinates are [`face_coord`]`(k, N) = 2k/N - 1`, computed by one f32 expression
//!   everywhere so that neighbours share bit-identical boundaries.
//! - Linear index: `(face * N + y) * N + x` (face-major, row-major).
//!
//! **Tie rule** (the Vulkan spec leaves ties to the implementation): the major axis is the first
//! of `X, Y, Z` whose magnitude is maximal (`|x| >= |y|, |x| >= |z|` picks X, else `|y| >= |z|`
//! picks Y, else Z), so an edge or corner direction belongs to the face of the earliest axis. The
//! sign is positive when the major component is `>= 0` (`-0.0` counts as positive; only the zero
//! vector has a zero major component, and it maps to `+X`, centre texel). Within a face texels
//! are half-open (`x = floor(s N)`), except that `s = 1` (resp. `t = 1`) belongs to the last
//! texel. Every direction therefore lands in exactly one texel.
//!
//! Per face, which of its four edges belong to it under this rule: [`edge_inclusive`].

use glam::Vec3;

/// Number of cube faces.
pub const FACE_COUNT: u32 = 6;
/// Face indices in the Vulkan order.
pub const POS_X: u32 = 0;
/// `-X` face.
pub const NEG_X: u32 = 1;
/// `+Y` face.
pub const POS_Y: u32 = 2;
/// `-Y` face.
pub const NEG_Y: u32 = 3;
/// `+Z` face.
pub const POS_Z: u32 = 4;
/// `-Z` face.
pub const NEG_Z: u32 = 5;

/// One texel of a cube map: face and integer coordinates (`y = 0` at `t = 0`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Texel {
    /// Face index in the Vulkan order.
    pub face: u32,
    /// Column, `0..N`.
    pub x: u32,
    /// Row, `0..N` (row 0 at `t = 0`).
    pub y: u32,
}

impl Texel {
    /// Linear index `(face * N + y) * N + x`.
    pub fn index(self, size: u32) -> usize {
        ((self.face as usize * size as usize + self.y as usize) * size as usize) + self.x as usize
    }

    /// Inverse of [`Texel::index`].
    pub fn from_index(index: usize, size: u32) -> Texel {
        let n = size as usize;
        Texel {
            face: (index / (n * n)) as u32,
            y: ((index / n) % n) as u32,
            x: (index % n) as u32,
        }
    }
}

/// Selects the face for a direction by the tie rule in the module docs.
pub fn select_face(r: Vec3) -> u32 {
    let ax = r.x.abs();
    let ay = r.y.abs();
    let az = r.z.abs();
    if ax >= ay && ax >= az {
        if r.x >= 0.0 { POS_X } else { NEG_X }
    } else if ay >= az {
        if r.y >= 0.0 { POS_Y } else { NEG_Y }
    } else if r.z >= 0.0 {
        POS_Z
    } else {
        NEG_Z
    }
}

/// World (CMO-local) vector to the face's local frame `(sc, tc, ma)`; exact (signed permutation).
/// For the selected face `ma = |major component|`.
pub fn to_face_local(face: u32, r: Vec3) -> Vec3 {
    match face {
        POS_X => Vec3::new(-r.z, -r.y, r.x),
        NEG_X => Vec3::new(r.z, -r.y, -r.x),
        POS_Y => Vec3::new(r.x, r.z, r.y),
        NEG_Y => Vec3::new(r.x, -r.z, -r.y),
        POS_Z => Vec3::new(r.x, -r.y, r.z),
        _ => Vec3::new(-r.x, -r.y, -r.z),
    }
}

/// Inverse of [`to_face_local`]; exact.
pub fn from_face_local(face: u32, l: Vec3) -> Vec3 {
    match face {
        POS_X => Vec3::new(l.z, -l.y, -l.x),
        NEG_X => Vec3::new(-l.z, -l.y, l.x),
        POS_Y => Vec3::new(l.x, l.z, l.y),
        NEG_Y => Vec3::new(l.x, -l.z, -l.y),
        POS_Z => Vec3::new(l.x, -l.y, l.z),
        _ => Vec3::new(-l.x, -l.y, -l.z),
    }
}

/// Direction to `(face, s, t)`, `s, t` in `[0, 1]`.
pub fn dir_to_face_st(r: Vec3) -> (u32, f32, f32) {
    let face = select_face(r);
    let l = to_face_local(face, r);
    if l.z <= 0.0 {
        return (face, 0.5, 0.5);
    }
    let s = (0.5 * (l.x / l.z + 1.0)).clamp(0.0, 1.0);
    let t = (0.5 * (l.y / l.z + 1.0)).clamp(0.0, 1.0);
    (face, s, t)
}

/// `(face, s, t)` to a (non-normalised) direction with `|major| = 1`.
pub fn face_st_to_dir(face: u32, s: f32, t: f32) -> Vec3 {
    from_face_local(face, Vec3::new(2.0 * s - 1.0, 2.0 * t - 1.0, 1.0))
}

/// Texel column (or row) for a coordinate `s` in `[0, 1]`: half-open, `s = 1` in the last texel.
pub fn st_to_texel_coord(s: f32, size: u32) -> u32 {
    let k = (s * size as f32).floor();
    if k < 0.0 {
        0
    } else if k >= size as f32 {
        size - 1
    } else {
        k as u32
    }
}

/// The one texel a direction lands in.
pub fn dir_to_texel(r: Vec3, size: u32) -> Texel {
    let (face, s, t) = dir_to_face_st(r);
    Texel {
        face,
        x: st_to_texel_coord(s, size),
        y: st_to_texel_coord(t, size),
    }
}

/// Texel boundary `k` (0..=N) in face coordinates: `2k/N - 1`. Exactly -1 and 1 at the edges.
pub fn face_coord(k: u32, size: u32) -> f32 {
    (2 * k) as f32 / size as f32 - 1.0
}

/// Direction (non-normalised, `|major| = 1`) through a texel's centre.
pub fn texel_centre_dir(texel: Texel, size: u32) -> Vec3 {
    let n = size as f32;
    let u = (2 * texel.x + 1) as f32 / n - 1.0;
    let v = (2 * texel.y + 1) as f32 / n - 1.0;
    from_face_local(texel.face, Vec3::new(u, v, 1.0))
}

/// Which face edges belong to the face under the tie rule, as
/// `[u = -1, u = +1, v = -1, v = +1]`. An edge is shared with a face of another axis; it belongs
/// to the face whose axis comes first in `X, Y, Z`. ±X own all four edges (shared with Z and Y),
/// ±Y own their `v` edges (shared with Z) but not their `u` edges (shared with X), ±Z own none.
pub fn edge_inclusive(face: u32) -> [bool; 4] {
    match face {
        POS_X | NEG_X => [true, true, true, true],
        POS_Y | NEG_Y => [false, false, true, true],
        _ => [false, false, false, false],
    }
}

/// The texel across one side of `texel` (side 0: `x-1`, 1: `x+1`, 2: `y-1`, 3: `y+1`), wrapping
/// across face edges. Found by looking up the direction a quarter texel beyond the side's
/// midpoint, which lies in the adjacent texel of the neighbouring face (the lookup's scaling
/// towards the face centre keeps it inside the edge row/column for every `N >= 1`).
pub fn neighbour_across(texel: Texel, side: u32, size: u32) -> Texel {
    let n = size as f32;
    let mut u = (2 * texel.x + 1) as f32 / n - 1.0;
    let mut v = (2 * texel.y + 1) as f32 / n - 1.0;
    let step = 1.25 / n; // half a texel (1/N in face coordinates) plus a quarter
    match side {
        0 => u -= step,
        1 => u += step,
        2 => v -= step,
        _ => v += step,
    }
    dir_to_texel(from_face_local(texel.face, Vec3::new(u, v, 1.0)), size)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_table_axes() {
        // (direction, face, s, t) from the Vulkan table: an axis direction hits its face centre.
        let axes = [
            (Vec3::X, POS_X),
            (Vec3::NEG_X, NEG_X),
            (Vec3::Y, POS_Y),
            (Vec3::NEG_Y, NEG_Y),
            (Vec3::Z, POS_Z),
            (Vec3::NEG_Z, NEG_Z),
        ];
        for (d, f) in axes {
            assert_eq!(dir_to_face_st(d), (f, 0.5, 0.5));
        }
        // Off-axis checks of sc/tc signs, one per face.
        let eps = 0.25;
        let cases = [
            (
                Vec3::new(1.0, eps, eps),
                POS_X,
                0.5 * (-eps + 1.0),
                0.5 * (-eps + 1.0),
            ),
            (
                Vec3::new(-1.0, eps, eps),
                NEG_X,
                0.5 * (eps + 1.0),
                0.5 * (-eps + 1.0),
            ),
            (
                Vec3::new(eps, 1.0, eps),
                POS_Y,
                0.5 * (eps + 1.0),
                0.5 * (eps + 1.0),
            ),
            (
                Vec3::new(eps, -1.0, eps),
                NEG_Y,
                0.5 * (eps + 1.0),
                0.5 * (-eps + 1.0),
            ),
            (
                Vec3::new(eps, eps, 1.0),
                POS_Z,
                0.5 * (eps + 1.0),
                0.5 * (-eps + 1.0),
            ),
            (
                Vec3::new(eps, eps, -1.0),
                NEG_Z,
                0.5 * (-eps + 1.0),
                0.5 * (-eps + 1.0),
            ),
        ];
        for (d, f, s, t) in cases {
            assert_eq!(dir_to_face_st(d), (f, s, t), "{d:?}");
        }
    }

    #[test]
    fn spec_table_negative() {
        // A swapped sign in the table must be detected by the same check.
        let (_, s, _) = dir_to_face_st(Vec3::new(1.0, 0.25, 0.25));
        assert_ne!(s, 0.5 * (0.25 + 1.0));
    }

    #[test]
    fn local_frame_round_trip() {
        let v = Vec3::new(0.3, -1.7, 2.9);
        for f in 0..FACE_COUNT {
            assert_eq!(from_face_local(f, to_face_local(f, v)), v);
            assert_eq!(to_face_local(f, v).length_squared(), v.length_squared());
        }
    }

    #[test]
    fn texel_centre_round_trip() {
        for size in [1u32, 2, 3, 5, 16, 64, 2048] {
            let stride = (size / 16).max(1) as usize;
            for face in 0..FACE_COUNT {
                for y in (0..size).step_by(stride) {
                    for x in (0..size).step_by(stride) {
                        let t = Texel { face, x, y };
                        assert_eq!(dir_to_texel(texel_centre_dir(t, size), size), t);
                        assert_eq!(Texel::from_index(t.index(size), size), t);
                    }
                }
            }
        }
    }

    #[test]
    fn edges_and_corners_land_in_one_valid_texel() {
        for size in [1u32, 2, 3, 32] {
            // All corners and edge midpoints and texel-boundary points along edges.
            for sx in [-1.0f32, 0.0, 1.0] {
                for sy in [-1.0f32, 0.0, 1.0] {
                    for sz in [-1.0f32, 0.0, 1.0] {
                        let d = Vec3::new(sx, sy, sz);
                        if d == Vec3::ZERO {
                            continue;
                        }
                        let t = dir_to_texel(d, size);
                        assert!(t.face < 6 && t.x < size && t.y < size);
                        // The chosen face has the earliest maximal axis.
                        let m = d.abs().max_element();
                        let axis = if d.x.abs() == m {
                            0
                        } else if d.y.abs() == m {
                            1
                        } else {
                            2
                        };
                        assert_eq!(t.face / 2, axis, "{d:?}");
                    }
                }
            }
            // Directions on the shared X/Z edge: exactly the +X face.
            for k in 0..=size {
                let v = face_coord(k, size);
                assert_eq!(select_face(Vec3::new(1.0, v, 1.0)), POS_X);
                // Y/Z edge: +Y, except at its ends where X ties too.
                let want = if v.abs() < 1.0 {
                    POS_Y
                } else if v > 0.0 {
                    POS_X
                } else {
                    NEG_X
                };
                assert_eq!(select_face(Vec3::new(v, 1.0, -1.0)), want);
            }
        }
        assert_eq!(select_face(Vec3::ZERO), POS_X);
        assert_eq!(select_face(Vec3::new(-0.0, 0.0, 0.0)), POS_X);
    }

    #[test]
    fn face_edge_ownership_matches_select_face() {
        for face in 0..FACE_COUNT {
            let inc = edge_inclusive(face);
            for (i, (u, v)) in [(-1.0, 0.1), (1.0, 0.1), (0.1, -1.0), (0.1, 1.0)]
                .into_iter()
                .enumerate()
            {
                let d = from_face_local(face, Vec3::new(u, v, 1.0));
                assert_eq!(select_face(d) == face, inc[i], "face {face} edge {i}");
            }
        }
    }

    #[test]
    fn neighbours_are_adjacent() {
        for size in [1u32, 2, 3, 8] {
            for i in 0..(6 * size * size) as usize {
                let t = Texel::from_index(i, size);
                for side in 0..4 {
                    let nb = neighbour_across(t, side, size);
                    assert_ne!(nb, t);
                    // Adjacency is symmetric: some side of the neighbour leads back.
                    assert!(
                        (0..4).any(|s| neighbour_across(nb, s, size) == t),
                        "{t:?} {side}"
                    );
                    let c0 = texel_centre_dir(t, size).normalize();
                    let c1 = texel_centre_dir(nb, size).normalize();
                    assert!(
                        c0.angle_between(c1)
                            < 2.5 * std::f32::consts::PI / (2.0 * size as f32) + 1e-3
                    );
                }
            }
        }
    }
}

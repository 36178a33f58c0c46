#![forbid(unsafe_code)]
//! Verified hits: the rule that turns a texel's decision into a hit on
//! a real triangle, in pure Rust. The tracers (fragment, compute and their CPU twins) call it, or
//! its WGSL twin, where the centre criterion decides a hit at texel `T` (`super::multi`,
//! "Verified hits"; `spirv/shared/trace_verified.wgsl`).
//!
//! # The rule
//! Input: the reflected ray `a + t d` (world space), the end `t_done` of the prefix that the
//! tracer has proven empty (the occlusion handoff's value when this CMO took the ray over; the
//! segment start otherwise), the end `t_hi` of the traced segment, the CMO centre `c`, and the
//! 3x3 texel neighbourhood of `T` ([`Neighbourhood`]) with the triangle ID each of its texels
//! captured (the triangle the texel's centre ray from `c` sees; `u32::MAX` for none).
//!
//! For every distinct ID of the neighbourhood, intersect the ray with that triangle by the
//! watertight test ([`super::watertight`]). Keep the intersections with `t_done <= t <= t_hi`
//! whose point `x = a + t d` lies, as a direction from `c`, in one of the neighbourhood's
//! texels. The nearest of them is the hit (ties: the lower triangle index). With none, there is
//! **no hit at `T`**: the ray passed a silhouette or a sub-texel gap, and the tracer goes on by
//! its existing rules (continue, hand off from `t_done`, or end unresolved).
//!
//! # Proof sketch: what a verified hit guarantees
//! 1. **On a real triangle.** The returned point is where the ray meets the returned triangle by
//!    the watertight test: a hit is never reported on a triangle the ray does not intersect.
//!    (By watertightness, a ray through a shared edge or vertex of the captured mesh meets at
//!    least one of the triangles around it, so closed surfaces have no cracks to fall through.)
//! 2. **Beyond the proven-empty prefix.** `t >= t_done`. Before `t_done` the tracer has shown
//!    the ray to lie in front of the captured profile of the CMOs that traced it, i.e. in front
//!    of every surface those CMOs saw at their texel centres.
//! 3. **Where the capture looked.** The hit's direction from `c` falls in the 3x3
//!    neighbourhood of `T`, the texels whose samples made the decision; the triangle is one that
//!    the capture saw at one of those texel centres. So the hit is consistent with the samples:
//!    the point is on a surface that the CMO sees near where the ray crossed its profile.
//! 4. **Nearest among the candidates.** No triangle of the neighbourhood's ID set meets the ray
//!    earlier in `[t_done, t_hi]` within the neighbourhood's directions.
//!
//! # What can still be missed
//! The profile is sampled at texel centres only. A surface that no texel centre of any CMO sees
//! can lie across the ray before the verified hit without being noticed: an occluder thinner
//! than a texel (a wire, a thin edge seen end-on) that falls between centres, or a triangle
//! hidden from the CMO centre by another surface yet reachable by the ray. Such a triangle is
//! not in any ID set, so the ray passes through it: the verified hit is then a real point on a
//! real triangle, but not the first along the ray. Conversely, a triangle of the neighbourhood
//! that the ray meets just outside the 3x3 directions is not accepted here; the ray then
//! continues, and the texel where it does fall decides it.

use glam::Vec3;

use super::watertight::{TriHit, intersect_sheared, shear};
use crate::cubemap::face::{Texel, dir_to_texel, neighbour_across};

/// "No triangle" in a captured ID.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// The 3x3 texels around a deciding texel, row-major (`texels[4]` is the centre), wrapping
/// across face edges; at a cube corner a texel can appear twice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbourhood {
    pub size: u32,
    pub texels: [Texel; 9],
    /// The captured triangle ID of each texel ([`NO_TRIANGLE`] where none).
    pub ids: [u32; 9],
}

impl Neighbourhood {
    /// The neighbourhood of `centre` in a cube map of `size` texels per side, with IDs read from
    /// `ids` (one per texel, [`Texel::index`] order).
    pub fn around(centre: Texel, size: u32, ids: &[u32]) -> Neighbourhood {
        let left = neighbour_across(centre, 0, size);
        let right = neighbour_across(centre, 1, size);
        let row = [left, centre, right];
        // Rows above (y - 1, side 2) and below (y + 1, side 3) of each texel in the middle row.
        let up = row.map(|t| neighbour_across(t, 2, size));
        let down = row.map(|t| neighbour_across(t, 3, size));
        let texels = [
            up[0], up[1], up[2], row[0], row[1], row[2], down[0], down[1], down[2],
        ];
        Neighbourhood {
            size,
            texels,
            ids: texels.map(|t| ids.get(t.index(size)).copied().unwrap_or(NO_TRIANGLE)),
        }
    }

    /// Whether the direction `r` (from the CMO centre) lands in one of the texels.
    pub fn contains_dir(&self, r: Vec3) -> bool {
        let t = dir_to_texel(r, self.size);
        self.texels.contains(&t)
    }
}

/// A verified hit: a triangle the ray meets, where and with which barycentrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VerifiedHit {
    /// Global triangle index ([`crate::scene::WorldGeometry::triangles`]).
    pub triangle: u32,
    pub t: f32,
    /// World position `a + t d`.
    pub position: Vec3,
    /// Barycentric weights of the triangle's three vertices.
    pub bary: [f32; 3],
}

/// The ray to verify: `a + t d`, world space, with the proven-empty prefix `[.., t_done]` and
/// the segment end `t_hi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VerifyRay {
    pub a: Vec3,
    pub d: Vec3,
    pub t_done: f32,
    pub t_hi: f32,
}

/// The rule of the module docs. `triangles[i]` holds the corners of global triangle `i`
/// ([`triangle_corners`]); `centre` is the CMO centre. IDs outside `triangles` are ignored.
pub fn verify_hit(
    ray: VerifyRay,
    centre: Vec3,
    nb: &Neighbourhood,
    triangles: &[[Vec3; 3]],
) -> Option<VerifiedHit> {
    let sh = shear(ray.d)?;
    let mut best: Option<VerifiedHit> = None;
    for (k, &id) in nb.ids.iter().enumerate() {
        // Each distinct ID once: skip it if an earlier texel carried it.
        if id == NO_TRIANGLE || nb.ids[..k].contains(&id) {
            continue;
        }
        let Some(&corners) = triangles.get(id as usize) else {
            continue;
        };
        let Some(TriHit { t, bary }) = intersect_sheared(ray.a, &sh, corners) else {
            continue;
        };
        if t < ray.t_done || t > ray.t_hi {
            continue;
        }
        let position = ray.a + ray.d * t;
        if !nb.contains_dir(position - centre) {
            continue;
        }
        let better = match best {
            None => true,
            Some(b) => t < b.t || (t == b.t && id < b.triangle),
        };
        if better {
            best = Some(VerifiedHit {
                triangle: id,
                t,
                position,
                bary,
            });
        }
    }
    best
}

/// The corners of every triangle of `world`, by global index.
pub fn triangle_corners(world: &crate::scene::WorldGeometry) -> Vec<[Vec3; 3]> {
    world
        .triangles
        .iter()
        .map(|t| t.map(|i| world.positions[i as usize]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cubemap::face::{POS_Z, texel_centre_dir};

    const N: u32 = 16;

    /// Captures `tris` from `centre` by the same rule as the capture (nearest watertight hit of
    /// each texel's centre ray), returning one ID per texel.
    fn capture_ids(centre: Vec3, tris: &[[Vec3; 3]]) -> Vec<u32> {
        (0..(6 * N * N) as usize)
            .map(|i| {
                let dir = texel_centre_dir(Texel::from_index(i, N), N);
                let mut best = (f32::INFINITY, NO_TRIANGLE);
                for (k, &t) in tris.iter().enumerate() {
                    if let Some(h) = crate::cpu::watertight::intersect(centre, dir, t)
                        && h.t < best.0
                    {
                        best = (h.t, k as u32);
                    }
                }
                best.1
            })
            .collect()
    }

    /// A wall at z = 4 made of two large triangles (each spans many texels of the +Z face),
    /// sharing the diagonal x = y.
    fn wall() -> Vec<[Vec3; 3]> {
        let p = |x: f32, y: f32| Vec3::new(x, y, 4.0);
        vec![
            [p(-9.0, -9.0), p(9.0, -9.0), p(9.0, 9.0)],
            [p(-9.0, -9.0), p(9.0, 9.0), p(-9.0, 9.0)],
        ]
    }

    /// The deciding texel for a ray: the texel of the exact hit direction (as a tracer finds).
    fn nb_at(point: Vec3, ids: &[u32]) -> Neighbourhood {
        Neighbourhood::around(dir_to_texel(point, N), N, ids)
    }

    fn ray(a: Vec3, to: Vec3) -> VerifyRay {
        VerifyRay {
            a,
            d: to - a,
            t_done: 0.0,
            t_hi: 10.0,
        }
    }

    #[test]
    fn large_triangles_spanning_many_texels() {
        let tris = wall();
        let ids = capture_ids(Vec3::ZERO, &tris);
        let face = &ids[(POS_Z * N * N) as usize..((POS_Z + 1) * N * N) as usize];
        assert!(face.iter().filter(|&&i| i == 0).count() > 50);
        assert!(face.iter().filter(|&&i| i == 1).count() > 50);
        // A ray from off the centre towards the lower-right triangle.
        let target = Vec3::new(2.0, -1.0, 4.0);
        let r = ray(Vec3::new(-1.0, 0.5, 0.5), target);
        let h = verify_hit(r, Vec3::ZERO, &nb_at(target, &ids), &tris).expect("hit");
        assert_eq!(h.triangle, 0);
        assert!((h.position - target).length() < 1e-5, "{h:?}");
        assert!((h.t - 1.0).abs() < 1e-6);
        // Negative: the neighbourhood of a texel far from the hit (same IDs, other directions)
        // accepts nothing; neither does a prefix proven empty past the wall.
        let far = nb_at(Vec3::new(-3.5, 3.5, 4.0), &ids);
        assert_eq!(far.ids, [1; 9]);
        assert!(verify_hit(r, Vec3::ZERO, &far, &tris).is_none());
        let done = VerifyRay { t_done: 1.5, ..r };
        assert!(verify_hit(done, Vec3::ZERO, &nb_at(target, &ids), &tris).is_none());
        let short = VerifyRay { t_hi: 0.5, ..r };
        assert!(verify_hit(short, Vec3::ZERO, &nb_at(target, &ids), &tris).is_none());
    }

    #[test]
    fn shared_edge_and_vertex_hits_are_found() {
        let tris = wall();
        let ids = capture_ids(Vec3::ZERO, &tris);
        // Exactly on the shared diagonal, and exactly on the shared corner vertex (9, 9, 4).
        for target in [Vec3::new(1.0, 1.0, 4.0), Vec3::new(2.5, 2.5, 4.0)] {
            let r = ray(Vec3::new(0.5, -0.25, 1.0), target);
            let h = verify_hit(r, Vec3::ZERO, &nb_at(target, &ids), &tris).expect("edge hit");
            assert!((h.position - target).length() < 1e-5, "{h:?}");
        }
        let corner = Vec3::new(9.0, 9.0, 4.0);
        let r = VerifyRay {
            t_hi: 2.0,
            ..ray(Vec3::new(8.0, 8.5, 3.0), corner)
        };
        let h = verify_hit(r, Vec3::ZERO, &nb_at(corner, &ids), &tris).expect("vertex hit");
        assert!((h.position - corner).length() < 1e-5, "{h:?}");
        // Both triangles meet the ray there; the tie goes to the lower index.
        assert_eq!(h.triangle, 0);
    }

    #[test]
    fn parallel_ray_and_degenerate_triangle_are_not_hits() {
        let mut tris = wall();
        // A zero-area triangle (a segment) across the +Z face, in front of the wall.
        tris.push([
            Vec3::new(-3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, 3.0),
            Vec3::new(0.0, 0.0, 3.0),
        ]);
        let mut ids = capture_ids(Vec3::ZERO, &tris);
        assert!(
            !ids.contains(&2),
            "the capture never sees a zero-area triangle"
        );
        // Put it in the ID buffer anyway, as a rasteriser's rounding might.
        let centre_texel = dir_to_texel(Vec3::new(0.0, 0.0, 1.0), N);
        ids[centre_texel.index(N)] = 2;
        // A ray through the segment hits the wall behind it, not the degenerate triangle.
        let target = Vec3::new(0.1, 0.0, 4.0);
        let r = ray(Vec3::new(0.1, 0.0, 1.0), target);
        let nb = nb_at(target, &ids);
        assert!(nb.ids.contains(&2));
        let h = verify_hit(r, Vec3::ZERO, &nb, &tris).expect("the wall behind");
        assert_ne!(h.triangle, 2);
        // A ray in the wall's plane, and one parallel to it in front: no hit.
        let along = VerifyRay {
            a: Vec3::new(-2.0, 0.3, 4.0),
            d: Vec3::X,
            t_done: 0.0,
            t_hi: 10.0,
        };
        let centre_nb = nb_at(Vec3::new(0.0, 0.3, 4.0), &ids);
        assert!(verify_hit(along, Vec3::ZERO, &centre_nb, &tris).is_none());
        let above = VerifyRay {
            a: Vec3::new(-2.0, 0.3, 3.9),
            ..along
        };
        assert!(verify_hit(above, Vec3::ZERO, &centre_nb, &tris).is_none());
        // Negative: tilt the parallel ray slightly into the wall and it hits.
        let tilted = VerifyRay {
            d: Vec3::new(1.0, 0.0, 0.05),
            ..above
        };
        assert!(verify_hit(tilted, Vec3::ZERO, &centre_nb, &tris).is_some());
    }

    #[test]
    fn a_ray_missing_every_candidate_is_no_hit() {
        let tris = wall();
        let ids = capture_ids(Vec3::ZERO, &tris);
        let target = Vec3::new(0.5, -0.5, 4.0);
        let nb = nb_at(target, &ids);
        // Away from the wall, and with the wall's IDs gone (a sub-texel gap: nothing captured).
        let away = ray(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.5, -0.5, -2.0));
        assert!(verify_hit(away, Vec3::ZERO, &nb, &tris).is_none());
        let empty = Neighbourhood {
            ids: [NO_TRIANGLE; 9],
            ..nb
        };
        let toward = ray(Vec3::new(0.0, 0.0, 1.0), target);
        assert!(verify_hit(toward, Vec3::ZERO, &empty, &tris).is_none());
        // Negative: the same ray with the captured IDs hits.
        assert!(verify_hit(toward, Vec3::ZERO, &nb, &tris).is_some());
        // IDs beyond the triangle list are ignored, not a panic.
        let bogus = Neighbourhood { ids: [77; 9], ..nb };
        assert!(verify_hit(toward, Vec3::ZERO, &bogus, &tris).is_none());
    }

    #[test]
    fn neighbourhood_wraps_across_face_edges() {
        let ids: Vec<u32> = (0..6 * N * N).collect();
        let corner = Texel {
            face: POS_Z,
            x: N - 1,
            y: 0,
        };
        let nb = Neighbourhood::around(corner, N, &ids);
        assert_eq!(nb.texels[4], corner);
        assert_eq!(nb.ids[4], corner.index(N) as u32);
        let faces: std::collections::BTreeSet<u32> = nb.texels.iter().map(|t| t.face).collect();
        assert!(faces.len() >= 2, "{nb:?}");
        assert!(nb.contains_dir(texel_centre_dir(corner, N)));
        // Negative: the opposite face is not in it.
        assert!(!nb.contains_dir(-texel_centre_dir(corner, N)));
    }
}

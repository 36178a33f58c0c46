#![forbid(unsafe_code)]
//! The exact CPU reference renderer: the ground truth every accuracy figure is measured against.
//!
//! Per pixel, one primary ray through the pixel centre ([`Camera::ray`], Vulkan's convention).
//! On a reflector, the ray reflects about the interpolated vertex normal (normalised, not
//! flipped: exactly what the rasteriser interpolates) and is traced again, up to `bounces`
//! reflections. Reflectors count as hits, so self-reflections are included. The first
//! non-reflector hit is shaded ([`crate::shading`]), a ray that leaves the scene takes the
//! background, and a reflector met after the last bounce is shaded with its own material.
//!
//! Glossy reflectors ([`crate::lobe`]: a Phong specular power below 1024) reflect each path
//! along one direction of their lobe around the mirror direction, drawn from a hash of the
//! pixel, the film's sample key and the bounce ([`LobeKey`]; [`render_sample`]); a direction
//! below the surface ends the path black. The film's average over `--spp` samples is then the
//! Monte Carlo estimate of the lobe integral. A mirror samples nothing: its frame is the one
//! without glossiness, bit for bit.
//!
//! Nearest hits come from a BVH built by the `obvhs` crate: it builds with glam types directly
//! (no conversion to nalgebra, which `bvh` and `parry3d` would need), is deterministic when
//! built single-threaded (as here), and exposes its nodes. The traversal is ours
//! ([`Tracer::nearest_accepting`]): a conservative f64 slab test (see `enter_box`), so that a
//! ray through a shared edge or vertex never loses the boxes of all the triangles there; the
//! triangle test runs in f64 (Möller–Trumbore) and ties are broken by the lower triangle index.
//!
//! ## Where a reflected ray starts
//!
//! A reflected ray starts at the f32 hit point `o` of the previous ray, which stands for an exact
//! point `p` on the triangle `T` it leaves. The rule, with no distance bias:
//!
//! - a hit on `T` itself is ignored (a line meets `T`'s plane once, and `o` is on that plane
//!   within rounding, so that one meeting is the start point);
//! - a hit on another triangle `T'` is ignored when `T'`'s plane passes within `e` of `o` and
//!   `T'` is a neighbour: it has a vertex at the same position as one of `T`'s (welded seams
//!   included), or `o` lies within `e` of `T'` itself (a T-junction, a seam that is not welded,
//!   a contact with another object); `e` bounds `|o - p|` ([`Hit::error`]);
//! - every other hit with `t > 0` counts, however near.
//!
//! Why this is right. The ray from `p` meets `T'`'s plane at `t_p = -s_p / (r . n')`, `s_p` the
//! signed distance of `p` to the plane and `n'` its unit normal. When `|s_o| <= e`, `s_p` lies
//! in `[s_o - e, s_o + e]`, which holds 0: whether the exact ray meets that plane ahead of `p`
//! or behind it (or at `p` itself, when `p` lies on `T'`: a shared edge or vertex, where the
//! exact ray meets `T'` only at `t = 0`) cannot be decided from `o`, and the computed hit, at
//! `t_o = |s_o| / |r . n'|`, however far a shallow angle puts it, is rounding. Such a hit on
//! the surface the ray leaves is the start point, and is ignored. A hit on a neighbour from an
//! origin further than `e` from its plane (a concave fold: the bowl, the torus's inner side) is
//! decided by the sign of `s_o`, is genuine, and counts, however near. (`s_o` itself is
//! computed in f64 from f32 data, its error some `2^-50` of the coordinates, far inside `e`.)
//! The neighbour test keeps a distant triangle whose plane happens to pass near `o` (a wall's
//! plane through the mirror's start point) a hit.
//!
//! Before this rule the reference ignored `T` plus hits nearer than `1e-6` of the scene's
//! extent: a scene-scale bias, too large for small detail and too small for a ray leaving at a
//! shallow angle to a neighbour's plane (`t_o` grows as `1 / |r . n'|`); ignoring only `T`
//! sends hundreds of the rays through `sphere-room`'s vertices and edge midpoints back onto
//! the mirror (`tests/reference.rs`).
//!
//! The bound `e` ([`Hit::error`], first-order, with a margin of `2^-20` for higher orders). With
//! `u = 2^-53`: the origin and the triangle's vertices are f32 values, so `s = o - a`,
//! `e1 = b - a` and `e2 = c - a` are exact in f64 when the exponents differ by at most 29 (any
//! sensible scene), and within `u` relative otherwise. The triple products `(s x e1).e2` and
//! `(d x e2).e1` then err by at most `(gamma_5 + 3u) |s|_1 |e1|_1 |e2|_1`, under
//! `(8u) 3 sqrt 3 |s| |e1| |e2| < 42 u |s| |e1| |e2|` (`|x|_1 <= sqrt 3 |x|`; the same with `d`
//! for `s`); we use `48u`. With `kappa = |d| |e1| |e2| / |det| =
//! 1 / (sin(angle at a) |cos(incidence)|)`, the division and the reciprocal,
//! `|d| |t^ - t| <= 2 u |d t| + 48 u kappa (|d t| + |s|)`. Forming `o + d t^`
//! in f64 adds `2 u (|o| + |d t|)`, and rounding to f32 adds `2^-24 |q| + 2^-149 sqrt 3` (half an
//! ulp per coordinate, subnormals included). For the rays of a render `kappa` is modest and
//! `e` is a few f32 ulps of the hit point's magnitude; a grazing hit (large `kappa`) widens it,
//! as it should, since its point is then that much less certain.
//!
//! Rendering is parallel over rows with `rayon`; every pixel is computed independently, so the
//! output is the same bits for the same scene whatever the thread count.

use glam::{DVec3, Vec2, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::scene::{Scene, WorldGeometry};
use crate::shading::albedo;

/// "No object / no primitive / no triangle" in [`Frame`] ids (the scene's one numbering,
/// [`WorldGeometry::ids`]).
pub use crate::scene::NO_ID;

/// The per-pixel result of a render, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Linear RGB.
    pub colour: Vec<Vec3>,
    /// 1 where the primary ray hits a reflector.
    pub mask: Vec<u8>,
    /// World-space point hit by the primary ray (NaN where it leaves the scene).
    pub surface_position: Vec<Vec3>,
    /// World-space point hit by the first reflected ray (NaN where there is none).
    pub hit_position: Vec<Vec3>,
    /// Object hit by the first reflected ray ([`NO_ID`] where none).
    pub object_id: Vec<u32>,
    /// Triangle (within its object) hit by the first reflected ray ([`NO_ID`] where none).
    pub primitive_id: Vec<u32>,
    /// The same triangle by its global index in [`WorldGeometry::triangles`] ([`NO_ID`] where
    /// none): what a GPU frame's triangle IDs are compared with.
    pub triangle: Vec<u32>,
    /// Number of reflections the pixel's path took.
    pub bounces: Vec<u8>,
    /// The point whose colour the pixel shows: the last hit of its path (the primary hit on a
    /// non-mirror or with no bounce; after the bounces, the last reflected ray's hit; NaN where
    /// the path left the scene). What a GPU frame's records hold ([`Frame::with_last_hits`]).
    pub last_position: Vec<Vec3>,
    /// The global triangle of that hit ([`NO_ID`] where none).
    pub last_triangle: Vec<u32>,
}

impl Frame {
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Frame {
            width,
            height,
            colour: vec![Vec3::ZERO; n],
            mask: vec![0; n],
            surface_position: vec![Vec3::NAN; n],
            hit_position: vec![Vec3::NAN; n],
            object_id: vec![NO_ID; n],
            primitive_id: vec![NO_ID; n],
            triangle: vec![NO_ID; n],
            bounces: vec![0; n],
            last_position: vec![Vec3::NAN; n],
            last_triangle: vec![NO_ID; n],
        }
    }

    /// This frame with each mirror pixel's reflected hit (`hit_position`, `triangle`,
    /// `object_id`, `primitive_id`) replaced by its path's last hit ([`Frame::shown_hit`]): the
    /// same frame for one bounce, and what a GPU frame's records hold for any bounce count
    /// (`--bounces`), so that the metrics compare like with like.
    pub fn with_last_hits(&self, tracer: &Tracer) -> Frame {
        let mut f = self.clone();
        for k in 0..f.mask.len() {
            let (position, triangle) = self.shown_hit(k);
            f.hit_position[k] = position;
            f.triangle[k] = triangle;
            (f.object_id[k], f.primitive_id[k]) = tracer.world.ids(triangle);
        }
        f
    }

    /// The hit whose colour pixel `k` shows, as a GPU frame's record names it: on a mirror
    /// pixel its path's last hit (point and global triangle; NaN and [`NO_ID`] where the path
    /// left the scene), which is the first reflected hit for one bounce and the mirror itself
    /// for none; elsewhere none (NaN, [`NO_ID`]).
    pub fn shown_hit(&self, k: usize) -> (Vec3, u32) {
        if self.mask[k] != 0 {
            (self.last_position[k], self.last_triangle[k])
        } else {
            (self.hit_position[k], self.triangle[k])
        }
    }

    pub fn index(&self, i: u32, j: u32) -> usize {
        (j * self.width + i) as usize
    }

    pub fn mirror_pixels(&self) -> usize {
        self.mask.iter().filter(|&&m| m != 0).count()
    }

    /// Stores pixel `k`'s path.
    /// Moves every position by `anchor` (world coordinates of a frame traced relative to it,
    /// [`Tracer::for_frames`]); nothing where it is zero.
    fn moved_by(&mut self, anchor: Vec3) {
        if anchor == Vec3::ZERO {
            return;
        }
        let a = anchor.as_dvec3();
        let positions = [
            &mut self.surface_position,
            &mut self.hit_position,
            &mut self.last_position,
        ];
        for p in positions.into_iter().flatten() {
            *p = (p.as_dvec3() + a).as_vec3();
        }
    }

    fn set_path(&mut self, k: usize, tracer: &Tracer, p: PathResult) {
        self.colour[k] = p.colour;
        self.mask[k] = p.mirror as u8;
        self.surface_position[k] = p.surface.unwrap_or(Vec3::NAN);
        self.bounces[k] = p.bounces;
        self.last_position[k] = p.last_position;
        self.last_triangle[k] = p.last_triangle;
        if let Some(h) = p.first_reflected {
            self.hit_position[k] = h.position;
            (self.object_id[k], self.primitive_id[k]) = tracer.world.ids(h.triangle);
            self.triangle[k] = h.triangle;
        }
    }
}

/// A nearest hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub position: Vec3,
    /// Global triangle index in [`WorldGeometry::triangles`].
    pub triangle: u32,
    /// Barycentric weights of vertices 1 and 2.
    pub bary: Vec2,
    /// A bound on the distance between `position` (rounded to f32) and the exact point where the
    /// ray meets the triangle (see the module docs): what a ray leaving this hit may ignore.
    pub error: f64,
}

/// The BVH build of [`Tracer::split`]: obvhs's `very_fast_build` (no PLOC search, few
/// reinsertions). It takes 30-55 % less time than the `medium_build` of [`Tracer::new`] on the
/// corpus's scenes of 2k-15k triangles, and the hits are the same (the nearest, ties to the
/// lower index); a ray costs a little more, which a search's few thousand rays do not feel.
pub const QUICK_BUILD: BvhBuildParams = BvhBuildParams::very_fast_build();

/// A scene prepared for ray queries.
pub struct Tracer {
    pub world: WorldGeometry,
    bvh: Bvh2,
    /// Triangles in BVH order.
    tris: Vec<[Vec3; 3]>,
    /// BVH order -> global triangle index.
    order: Vec<u32>,
    /// [`crate::ranges::anchor_of`] the geometry: frames are traced relative to it
    /// ([`Tracer::for_frames`]).
    anchor: Vec3,
    /// The twin over the geometry moved by `-anchor`, built on first use.
    local: std::sync::OnceLock<Box<Tracer>>,
    /// A second BVH over the triangles this one's leaves out, queried beside it
    /// ([`Tracer::split`]): the two answer as one BVH over them all.
    rest: Option<Box<Tracer>>,
}

struct Tri<'a>(&'a [Vec3; 3]);

impl obvhs::Boundable for Tri<'_> {
    fn aabb(&self) -> Aabb {
        let [a, b, c] = *self.0;
        Aabb::new(Vec3A::from(a.min(b).min(c)), Vec3A::from(a.max(b).max(c)))
    }
}

/// The ray's entry distance into the box `[min, max]` if it meets the box before `t_max`.
///
/// A conservative slab test in f64, after Ize, "Robust BVH Ray Traversal" (JCGT 2013): the box
/// corners and the origin are f32 values, so `min - o` is exact and each slab distance is off
/// by at most two roundings (`1 / d` and the product), relative `2u`; the far distance is
/// enlarged by `1 + 8u` so that a box the exact ray meets, even only along an edge or a face (a
/// ray through a shared edge that is a box face, as the rows of a UV sphere are), is never
/// dropped. A zero direction component is handled exactly (no `0 x inf`). `obvhs`'s own test
/// is not conservative: it is in f32 and replaces direction components up to `f32::EPSILON` by
/// `±f32::EPSILON`, so a ray in an axis plane (the middle column of an odd-width frame) skipped
/// boxes ending within about `1e-7` of it, and the reference saw through the front of a mirror.
fn enter_box(o: DVec3, d: DVec3, inv: DVec3, min: Vec3, max: Vec3, t_max: f64) -> Option<f64> {
    const PAD: f64 = 1.0 + 4.0 * f64::EPSILON;
    let (mut lo, mut hi) = (0.0f64, t_max);
    for i in 0..3 {
        let (a, b) = (min[i] as f64 - o[i], max[i] as f64 - o[i]);
        if d[i] == 0.0 {
            if a > 0.0 || b < 0.0 {
                return None;
            }
            continue;
        }
        let (t0, t1) = (a * inv[i], b * inv[i]);
        let (near, far) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        lo = lo.max(near);
        hi = hi.min(far * PAD);
    }
    (lo <= hi).then_some(lo)
}

/// An f64 Möller–Trumbore hit: `t`, the barycentrics of vertices 1 and 2, and what the bound on
/// the f32 hit point's error ([`Hit::error`]) needs.
struct Intersection {
    t: f64,
    u: f64,
    v: f64,
    /// `|d| |e1| |e2| / |det|` and `|o - a|`, for [`hit_error`].
    kappa: f64,
    s: f64,
}

/// f64 Möller–Trumbore, edges included.
fn intersect(o: DVec3, d: DVec3, tri: &[Vec3; 3]) -> Option<Intersection> {
    let [a, b, c] = tri.map(|v| v.as_dvec3());
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    let kappa = d.length() * e1.length() * e2.length() / det.abs();
    Some(Intersection {
        t,
        u,
        v,
        kappa,
        s: s.length(),
    })
}

/// The bound on `|fl32(o + d t^) - (o + d t)|` derived in the module docs.
fn hit_error(o: DVec3, d: DVec3, t: f64, kappa: f64, s: f64) -> f64 {
    const U: f64 = f64::EPSILON / 2.0;
    let dt = d.length() * t.abs();
    let q = o + d * t;
    let in_f64 = 2.0 * U * dt + 48.0 * U * kappa * (dt + s) + 2.0 * U * (o.length() + dt);
    let to_f32 = q.length() * 2f64.powi(-24) + 2f64.powi(-149) * 3f64.sqrt();
    (in_f64 + to_f32) * (1.0 + 2f64.powi(-20))
}

/// The distance from `p` to the plane of `tri` (infinite for a degenerate triangle, whose
/// plane is undefined).
fn plane_distance(p: DVec3, tri: &[Vec3; 3]) -> f64 {
    let [a, b, c] = tri.map(|v| v.as_dvec3());
    let n = (b - a).cross(c - a);
    let len = n.length();
    if len == 0.0 {
        return f64::INFINITY;
    }
    ((p - a).dot(n) / len).abs()
}

/// Whether two triangles have a vertex at the same (bit-identical) position: neighbours even
/// across seams whose vertices are distinct indices at equal positions.
fn shares_position(a: &[Vec3; 3], b: &[Vec3; 3]) -> bool {
    a.iter().any(|p| {
        b.iter()
            .any(|q| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits))
    })
}

/// The distance from `p` to the closed triangle `tri`, in f64 (the closest point by Voronoi
/// regions, as in Ericson, "Real-Time Collision Detection", 5.1.5).
fn distance_to_triangle(p: DVec3, tri: &[Vec3; 3]) -> f64 {
    let [a, b, c] = tri.map(|v| v.as_dvec3());
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let w = d1 / (d1 - d3);
        return (p - (a + ab * w)).length();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + ac * w)).length();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).length();
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // A degenerate triangle: the nearest of its three edges.
        let seg = |x: DVec3, y: DVec3| {
            let e = y - x;
            let w = if e.length_squared() > 0.0 {
                ((p - x).dot(e) / e.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p - (x + e * w)).length()
        };
        return seg(a, b).min(seg(b, c)).min(seg(c, a));
    }
    let (v, w) = (vb / denom, vc / denom);
    (p - (a + ab * v + ac * w)).length()
}

impl Tracer {
    pub fn new(scene: &Scene) -> Self {
        Self::from_world(scene.world())
    }

    pub fn from_world(world: WorldGeometry) -> Self {
        let all = (0..world.triangles.len() as u32).collect();
        Self::over(world, all, BvhBuildParams::medium_build())
    }

    /// A tracer over the same world whose BVH holds only the triangles (global indices) that
    /// `keep` keeps: its [`Tracer::nearest_accepting`] gives what this tracer's gives with
    /// `accept` refusing the others (the nearest accepted hit, ties to the lower index, which
    /// no BVH changes), in less time where many are left out.
    pub fn keeping(&self, keep: impl Fn(u32) -> bool) -> Tracer {
        let kept = (0..self.world.triangles.len() as u32)
            .filter(|&i| keep(i))
            .collect();
        Self::over(self.world.clone(), kept, BvhBuildParams::medium_build())
    }

    /// The tracer whose BVH holds the triangles `kept` (global indices, ascending) of `world`.
    fn over(world: WorldGeometry, kept: Vec<u32>, params: BvhBuildParams) -> Self {
        let tris_in: Vec<[Vec3; 3]> = (kept.iter())
            .map(|&g| world.triangles[g as usize].map(|i| world.positions[i as usize]))
            .collect();
        let prims: Vec<Tri> = tris_in.iter().map(Tri).collect();
        let bvh = if prims.is_empty() {
            Bvh2::default()
        } else {
            let mut t = std::time::Duration::ZERO;
            obvhs::bvh2::builder::build_bvh2(&prims, params, &mut t)
        };
        let order = (bvh.primitive_indices.iter())
            .map(|&i| kept[i as usize])
            .collect();
        let tris = (bvh.primitive_indices.iter())
            .map(|&i| tris_in[i as usize])
            .collect();
        Tracer {
            anchor: crate::ranges::anchor_of(&world),
            world,
            bvh,
            tris,
            order,
            local: std::sync::OnceLock::new(),
            rest: None,
        }
    }

    /// The tracer over all of `world`'s triangles and, where `keep` leaves some out, the
    /// [`Tracer::keeping`] of those it keeps, built together: the first holds the second's BVH
    /// (copied) and one over the rest, so the triangles are sorted into BVHs once, not twice.
    /// The same hits as [`Tracer::from_world`] and [`Tracer::keeping`] (the nearest, ties to the
    /// lower index, which no BVH changes). Its BVHs are built with [`QUICK_BUILD`]: the
    /// placement search, its one user, traces a few thousand rays with them.
    pub fn split(world: WorldGeometry, keep: impl Fn(u32) -> bool) -> (Tracer, Option<Tracer>) {
        let (kept, rest): (Vec<u32>, Vec<u32>) =
            (0..world.triangles.len() as u32).partition(|&i| keep(i));
        if rest.is_empty() || kept.is_empty() {
            let all = (0..world.triangles.len() as u32).collect();
            return (Self::over(world, all, QUICK_BUILD), None);
        }
        let shown = Self::over(world.clone(), kept, QUICK_BUILD);
        let full = Tracer {
            anchor: shown.anchor,
            world: shown.world.clone(),
            bvh: shown.bvh.clone(),
            tris: shown.tris.clone(),
            order: shown.order.clone(),
            local: std::sync::OnceLock::new(),
            rest: Some(Box::new(Self::over(world, rest, QUICK_BUILD))),
        };
        (full, Some(shown))
    }

    /// The tracer a frame is traced with, and the anchor its coordinates are relative to:
    /// itself and zero for a scene near the world origin; for one far from it
    /// ([`crate::ranges::anchor`]), a twin over the same triangles moved by `-anchor` (exact
    /// shifts), built once. A reflected ray starts at an f32 hit point (module docs): 3.9 km
    /// out, that point would be a rounding of 1.2e-4 off the mirror, relative to the anchor a
    /// rounding of the scene's size, as the GPU frame's ([`crate::vk::frame::GpuRenderer`]).
    pub fn for_frames(&self) -> (&Tracer, Vec3) {
        if self.anchor == Vec3::ZERO {
            return (self, Vec3::ZERO);
        }
        let local = self.local.get_or_init(|| {
            let mut world = self.world.clone();
            let a = self.anchor.as_dvec3();
            for p in &mut world.positions {
                *p = (p.as_dvec3() - a).as_vec3();
            }
            // Over the same triangles (all of them but for a tracer `keeping` some).
            let mut kept = self.order.clone();
            kept.extend(self.rest.iter().flat_map(|r| r.order.iter().copied()));
            kept.sort_unstable();
            Box::new(Tracer::over(world, kept, BvhBuildParams::medium_build()))
        });
        (local, self.anchor)
    }

    /// The nearest hit along `origin + t dir`, `t > 0`. A reflected ray passes `from`, the hit
    /// it leaves (`origin` is then `from.position`): hits on that triangle, and on neighbours
    /// whose plane passes within `from.error` of `origin`, are the start point itself and are
    /// ignored (see the module docs).
    pub fn nearest(&self, origin: Vec3, dir: Vec3, from: Option<&Hit>) -> Option<Hit> {
        self.nearest_where(origin, dir, from, |_| true)
    }

    /// [`Tracer::nearest`] among the triangles (global indices) that `accept` keeps.
    pub fn nearest_where(
        &self,
        origin: Vec3,
        dir: Vec3,
        from: Option<&Hit>,
        accept: impl Fn(u32) -> bool,
    ) -> Option<Hit> {
        self.nearest_accepting(origin, dir, from, |h| accept(h.triangle))
    }

    /// [`Tracer::nearest`] among the hits that `accept` keeps: a rejected hit is passed through,
    /// as a discarded fragment lets the next surface show.
    pub fn nearest_accepting(
        &self,
        origin: Vec3,
        dir: Vec3,
        from: Option<&Hit>,
        accept: impl Fn(&Hit) -> bool,
    ) -> Option<Hit> {
        let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
        let candidate = |triangle: u32, x: &Intersection| Hit {
            t: x.t as f32,
            position: (o + d * x.t).as_vec3(),
            triangle,
            bary: Vec2::new(x.u as f32, x.v as f32),
            error: hit_error(o, d, x.t, x.kappa, x.s),
        };
        let accept = |g: u32, x: &Intersection| accept(&candidate(g, x));
        let mine = self.nearest_in_bvh(o, d, from, &accept);
        let rest = (self.rest.as_ref()).and_then(|r| r.nearest_in_bvh(o, d, from, &accept));
        // The nearer of the two, ties to the lower index: one BVH's choice over them all.
        let best = match (mine, rest) {
            (Some(a), Some(b)) => Some(if (b.1.t, b.0) < (a.1.t, a.0) { b } else { a }),
            (a, b) => a.or(b),
        };
        best.map(|(triangle, x)| candidate(triangle, &x))
    }

    /// [`Tracer::nearest_accepting`] in this tracer's own BVH: the global index and the exact
    /// intersection of its nearest accepted hit.
    fn nearest_in_bvh(
        &self,
        o: DVec3,
        d: DVec3,
        from: Option<&Hit>,
        accept: &impl Fn(u32, &Intersection) -> bool,
    ) -> Option<(u32, Intersection)> {
        if self.tris.is_empty() {
            return None;
        }
        let mut best: Option<(u32, Intersection)> = None;
        // The start point itself (see the module docs).
        let left = from.map(|f| {
            let t = self.world.triangles[f.triangle as usize];
            (f, t.map(|i| self.world.positions[i as usize]))
        });
        let at_start = |global: u32, tri: &[Vec3; 3]| match &left {
            Some((f, start)) => {
                f.triangle == global
                    || (plane_distance(o, tri) <= f.error
                        && (shares_position(start, tri) || distance_to_triangle(o, tri) <= f.error))
            }
            None => false,
        };
        let inv = DVec3::ONE / d;
        // Depth-first, nearer child first; a box is entered only if it can hold a hit no
        // further than the best so far (enlarged as in `enter_box`, so ties are kept).
        let bound = |best: &Option<(u32, Intersection)>| {
            best.as_ref()
                .map_or(f64::INFINITY, |(_, b)| b.t * (1.0 + 4.0 * f64::EPSILON))
        };
        let root = &self.bvh.nodes[0].aabb();
        let entry = enter_box(o, d, inv, root.min.into(), root.max.into(), f64::INFINITY)?;
        // Nodes to visit with their entry distances; a node whose entry lies beyond the best
        // hit found since it was pushed is dropped.
        let mut stack = Vec::with_capacity(64);
        stack.push((0u32, entry));
        while let Some((n, entry)) = stack.pop() {
            if entry > bound(&best) {
                continue;
            }
            let node = &self.bvh.nodes[n as usize];
            if node.is_leaf() {
                for k in node.first_index..node.first_index + node.prim_count {
                    let k = k as usize;
                    let global = self.order[k];
                    let tri = &self.tris[k];
                    let Some(x) = intersect(o, d, tri) else {
                        continue;
                    };
                    let better = x.t > 0.0
                        && match &best {
                            None => true,
                            Some((bg, b)) => x.t < b.t || (x.t == b.t && global < *bg),
                        };
                    if better && !at_start(global, tri) && accept(global, &x) {
                        best = Some((global, x));
                    }
                }
                continue;
            }
            let t_max = bound(&best);
            let entry = |c: u32| {
                let a = self.bvh.nodes[c as usize].aabb();
                enter_box(o, d, inv, a.min.into(), a.max.into(), t_max).map(|t| (c, t))
            };
            let (l, r) = (node.first_index, node.first_index + 1);
            match (entry(l), entry(r)) {
                (Some(a), Some(b)) if a.1 <= b.1 => stack.extend([b, a]),
                (Some(a), Some(b)) => stack.extend([a, b]),
                (Some(a), None) | (None, Some(a)) => stack.push(a),
                (None, None) => {}
            }
        }
        best
    }

    /// Interpolated, normalised vertex normal at a hit (the rasteriser's shading normal).
    pub fn normal(&self, hit: &Hit) -> Vec3 {
        let [a, b, c] =
            self.world.triangles[hit.triangle as usize].map(|i| self.world.normals[i as usize]);
        let (u, v) = (hit.bary.x, hit.bary.y);
        (a * (1.0 - u - v) + b * u + c * v).normalize_or_zero()
    }

    pub fn uv(&self, hit: &Hit) -> Vec2 {
        let [a, b, c] =
            self.world.triangles[hit.triangle as usize].map(|i| self.world.uvs[i as usize]);
        let (u, v) = (hit.bary.x, hit.bary.y);
        a * (1.0 - u - v) + b * u + c * v
    }

    /// The vertex colour at a hit, interpolated as [`Tracer::uv`]; `None` where the hit
    /// object has no vertex colours ([`crate::scene::ObjectInfo::vertex_colours`]).
    pub fn vertex_colour(&self, hit: &Hit) -> Option<Vec3> {
        let object = self.world.triangle_object[hit.triangle as usize];
        if !self.world.objects[object as usize].vertex_colours {
            return None;
        }
        let [a, b, c] =
            self.world.triangles[hit.triangle as usize].map(|i| self.world.colours[i as usize]);
        let (u, v) = (hit.bary.x, hit.bary.y);
        Some(a * (1.0 - u - v) + b * u + c * v)
    }

    /// The Phong specular power of a glossy reflector's triangle ([`crate::lobe`]); `None` on
    /// a mirror and on every non-reflector.
    pub fn specular_power(&self, triangle: u32) -> Option<f32> {
        self.world.objects[self.world.triangle_object[triangle as usize] as usize].specular_power
    }

    pub fn is_reflector(&self, triangle: u32) -> bool {
        self.world.objects[self.world.triangle_object[triangle as usize] as usize].reflector
    }

    /// The view-independent shaded colour at a hit.
    pub fn shade(&self, scene: &Scene, hit: &Hit) -> Vec3 {
        let object =
            &self.world.objects[self.world.triangle_object[hit.triangle as usize] as usize];
        let material = &scene.materials[object.material as usize];
        let albedo = albedo(material, &scene.textures, self.uv(hit));
        let albedo = self.vertex_colour(hit).map_or(albedo, |c| albedo * c);
        scene.shading.shade(albedo, self.normal(hit))
    }
}

/// The mirror direction of `d` about the unit normal `n`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// One pixel's path.
#[derive(Clone, Copy, Debug)]
pub struct PathResult {
    pub colour: Vec3,
    pub surface: Option<Vec3>,
    pub mirror: bool,
    pub first_reflected: Option<Hit>,
    pub bounces: u8,
    /// The point and global triangle of the hit whose colour the path shows (NaN and
    /// [`NO_ID`] where it left the scene).
    pub last_position: Vec3,
    pub last_triangle: u32,
}

/// Which lobe directions a path takes on glossy reflectors ([`crate::lobe::uniforms`]): its
/// pixel and the film's sample key ([`crate::lobe::sample_key`]; 0 outside a film's sample
/// loop). A path that meets only mirrors ignores it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LobeKey {
    pub x: u32,
    pub y: u32,
    pub sample: u32,
}

/// Traces one path from `origin` along `dir` with up to `max_bounces` reflections.
pub fn trace_path(
    scene: &Scene,
    tracer: &Tracer,
    origin: Vec3,
    dir: Vec3,
    max_bounces: u32,
    key: LobeKey,
) -> PathResult {
    finish_path(
        scene,
        tracer,
        dir,
        tracer.nearest(origin, dir, None),
        max_bounces,
        key,
    )
}

/// The rest of [`trace_path`] once the primary ray (along `dir`) has found `first`: the
/// reflections off mirrors and the shading at the end. Split out so that the harness can time
/// the reflected rays on their own ([`render_phased`]).
///
/// On a glossy reflector ([`Tracer::specular_power`]) the reflected ray takes one direction of
/// the Phong lobe around the mirror direction ([`crate::lobe::sample`]: pixel and sample from
/// `key`, the bounce's index from 0); a direction below the surface is absorbed: the path ends
/// there, black, with no hit.
pub fn finish_path(
    scene: &Scene,
    tracer: &Tracer,
    dir: Vec3,
    first: Option<Hit>,
    max_bounces: u32,
    key: LobeKey,
) -> PathResult {
    let mut out = PathResult {
        colour: scene.background,
        surface: None,
        mirror: false,
        first_reflected: None,
        bounces: 0,
        last_position: Vec3::NAN,
        last_triangle: NO_ID,
    };
    let Some(mut hit) = first else {
        return out;
    };
    out.surface = Some(hit.position);
    out.mirror = tracer.is_reflector(hit.triangle);
    let mut d = dir;
    let mut bounce = 0u32;
    while tracer.is_reflector(hit.triangle) && bounce < max_bounces {
        let n = tracer.normal(&hit);
        d = reflect(d, n).normalize();
        let lobe = tracer.specular_power(hit.triangle).map(|p| {
            let u = crate::lobe::uniforms(key.x, key.y, key.sample, bounce);
            crate::lobe::sample(d, n, p, u)
        });
        bounce += 1;
        out.bounces = bounce as u8;
        match lobe {
            Some(Some(sampled)) => d = sampled,
            Some(None) => {
                out.colour = Vec3::ZERO;
                return out;
            }
            None => {}
        }
        let Some(next) = tracer.nearest(hit.position, d, Some(&hit)) else {
            out.colour = scene.background;
            return out;
        };
        if bounce == 1 {
            out.first_reflected = Some(next);
        }
        hit = next;
    }
    out.colour = tracer.shade(scene, &hit);
    out.last_position = hit.position;
    out.last_triangle = hit.triangle;
    out
}

/// Renders `camera`'s view of `scene` with up to `bounces` reflections per path (sample key 0
/// on glossy reflectors, [`LobeKey`]).
pub fn render(scene: &Scene, tracer: &Tracer, camera: &Camera, bounces: u32) -> Frame {
    render_with_progress(
        scene,
        tracer,
        camera,
        bounces,
        &indicatif::ProgressBar::hidden(),
    )
}

/// [`render`], advancing `progress` by one per finished row.
pub fn render_with_progress(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
    bounces: u32,
    progress: &indicatif::ProgressBar,
) -> Frame {
    render_sample(scene, tracer, camera, bounces, 0, progress)
}

/// [`render_with_progress`] of the film's sample of key `sample` ([`crate::lobe::sample_key`]):
/// the lobe directions glossy reflectors take. Mirrors ignore it.
pub fn render_sample(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
    bounces: u32,
    sample: u32,
    progress: &indicatif::ProgressBar,
) -> Frame {
    let (tracer, anchor) = tracer.for_frames();
    let camera = &camera.rebased(anchor);
    let mut frame = Frame::new(camera.width, camera.height);
    let w = camera.width as usize;
    progress.set_length(camera.height as u64);
    let rows: Vec<Vec<PathResult>> = (0..camera.height)
        .into_par_iter()
        .map(|j| {
            let row = (0..camera.width)
                .map(|i| {
                    let (o, d) = camera.ray(i, j);
                    let key = LobeKey { x: i, y: j, sample };
                    trace_path(scene, tracer, o, d, bounces, key)
                })
                .collect();
            progress.inc(1);
            row
        })
        .collect();
    progress.finish_and_clear();
    for (j, row) in rows.into_iter().enumerate() {
        for (i, p) in row.into_iter().enumerate() {
            frame.set_path(j * w + i, tracer, p);
        }
    }
    frame.moved_by(anchor);
    frame
}

/// Wall-clock times of the two phases of [`render_phased`], nanoseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    /// Primary rays of every pixel, and the shading of the pixels that are not mirrors.
    pub primary_ns: f64,
    /// The mirror pixels' reflected rays: each traced to its hit (and on, up to the bounces)
    /// and shaded there. This is the work the GPU tracing passes do.
    pub reflected_ns: f64,
    /// Mirror pixels, i.e. first reflected rays.
    pub reflected_rays: usize,
}

/// [`render`] in two timed phases: first every primary ray (and the shading of non-mirror
/// pixels), then the reflected rays of the mirror pixels, each phase parallel over pixels.
/// The frame is the same bits as [`render`]'s (tested); only the order of work differs.
pub fn render_phased(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
    bounces: u32,
) -> (Frame, PhaseTimes) {
    let (tracer, anchor) = tracer.for_frames();
    let camera = &camera.rebased(anchor);
    let w = camera.width as usize;
    let n = w * camera.height as usize;
    let key = |k: usize| LobeKey {
        x: (k % w) as u32,
        y: (k / w) as u32,
        sample: 0,
    };
    let start = std::time::Instant::now();
    let primary: Vec<(Vec3, Option<Hit>, Option<PathResult>)> = (0..n)
        .into_par_iter()
        .map(|k| {
            let (x, y) = ((k % w) as u32, (k / w) as u32);
            let (o, d) = camera.ray(x, y);
            let hit = tracer.nearest(o, d, None);
            let done = match hit {
                Some(h) if tracer.is_reflector(h.triangle) => None,
                _ => Some(finish_path(scene, tracer, d, hit, bounces, key(k))),
            };
            (d, hit, done)
        })
        .collect();
    let primary_ns = start.elapsed().as_secs_f64() * 1e9;
    let start = std::time::Instant::now();
    let paths: Vec<PathResult> = primary
        .into_par_iter()
        .enumerate()
        .map(|(k, (d, hit, done))| {
            done.unwrap_or_else(|| finish_path(scene, tracer, d, hit, bounces, key(k)))
        })
        .collect();
    let reflected_ns = start.elapsed().as_secs_f64() * 1e9;
    let mut frame = Frame::new(camera.width, camera.height);
    for (k, p) in paths.into_iter().enumerate() {
        frame.set_path(k, tracer, p);
    }
    frame.moved_by(anchor);
    let reflected_rays = frame.mirror_pixels();
    (
        frame,
        PhaseTimes {
            primary_ns,
            reflected_ns,
            reflected_rays,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The phased render (the harness's timing of the reflected rays) is the same frame as the
    /// plain one, bit for bit, bounces included; a different bounce count is not.
    #[test]
    fn phased_render_is_the_plain_render() {
        let scene = crate::scene::builtin::by_name("teapot").expect("built-in");
        let mut camera = scene.cameras[0].clone();
        (camera.width, camera.height) = (48, 36);
        let tracer = Tracer::new(&scene);
        for bounces in [0, 1, 3] {
            let plain = render(&scene, &tracer, &camera, bounces);
            let (phased, times) = render_phased(&scene, &tracer, &camera, bounces);
            assert!(plain.mirror_pixels() > 100);
            assert_eq!(times.reflected_rays, plain.mirror_pixels());
            assert!(
                plain.colour == phased.colour
                    && plain.bounces == phased.bounces
                    && plain.primitive_id == phased.primitive_id,
                "bounces {bounces}"
            );
            // NaN positions compare unequal: compare their bits.
            let bits = |v: &[Vec3]| {
                v.iter()
                    .map(|p| p.to_array().map(f32::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&plain.hit_position), bits(&phased.hit_position));
            assert_eq!(plain.mask, phased.mask);
        }
        let one = render(&scene, &tracer, &camera, 1);
        let three = render_phased(&scene, &tracer, &camera, 3).0;
        assert_ne!(
            one.colour, three.colour,
            "negative: the bounce count must show"
        );
    }
}

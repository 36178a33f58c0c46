#![forbid(unsafe_code)]
//! Watertight ray-triangle intersection (Woop, Benthin and Wald, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1), 2013), single precision, the CPU twin of
//! `spirv/shared/watertight.wgsl`: the same operations in the same order, so that both give the
//! same bits (checked on the device by `tests/tracer/gpu_verify.rs`).
//!
//! The ray is translated to the origin and sheared so that it runs along the local `+z` axis
//! (`kz` its dominant axis; `kx`, `ky` the next two, swapped when `d[kz] < 0` to keep the
//! winding). In that frame the three 2-D edge functions `u`, `v`, `w` of the projected triangle
//! say on which side of each edge the ray passes. Watertightness: an edge shared by two
//! triangles is computed from the same two transformed vertices in both, as `a*b - c*d` with the
//! same factor pairs in opposite order, so its edge function in one triangle is the exact
//! negative of the other's (IEEE multiplication is commutative and `x - y = -(y - x)`
//! exactly). A ray through the interior of the union of the two triangles therefore passes
//! inside at least one of them: on the shared edge (`u = 0` counts as inside) it hits both,
//! elsewhere exactly one. Likewise around a shared vertex.
//!
//! Conventions:
//! - No backface culling; both windings hit.
//! - Edges and vertices are inclusive (an edge function of exactly 0 is inside).
//! - A hit needs `t > 0` (strictly in front of the origin); `t` is in units of `|d|`.
//! - Degenerate triangles (zero area as seen along the ray, so also a ray in the plane of the
//!   triangle) give `det = 0` and never hit. A ray parallel to the plane but off it has all its
//!   projected edge functions of mixed sign or `det = 0`, and misses.
//! - The paper's double-precision fallback for edge functions that round to exactly 0 is left
//!   out (WGSL has no f64): it refines ties, it is not what makes the test watertight.
//! - No product is fused into a multiply-add (Rust does not contract; lavapipe does not either,
//!   see `prod` in `spirv/shared/frustum.wgsl`).

use glam::Vec3;

/// Where a ray meets a triangle: `org + t d = w0 p0 + w1 p1 + w2 p2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    /// Ray parameter, in units of `|d|`; `> 0`.
    pub t: f32,
    /// Barycentric weights of the three vertices; each in `[0, 1]`, summing to 1 up to
    /// rounding.
    pub bary: [f32; 3],
}

fn component(v: Vec3, k: usize) -> f32 {
    match k {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

/// The ray's shear frame: `kx`, `ky`, `kz` and the shear constants `sx`, `sy`, `sz`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shear {
    pub k: [usize; 3],
    pub s: [f32; 3],
}

/// The shear frame of direction `d`, or `None` for a zero (or NaN) direction.
pub fn shear(d: Vec3) -> Option<Shear> {
    let (ax, ay, az) = (d.x.abs(), d.y.abs(), d.z.abs());
    let kz = if ax >= ay && ax >= az {
        0
    } else if ay >= az {
        1
    } else {
        2
    };
    let dz = component(d, kz);
    if dz.is_nan() || dz == 0.0 {
        return None;
    }
    let mut kx = (kz + 1) % 3;
    let mut ky = (kx + 1) % 3;
    if dz < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    // One division, then products (the WGSL twin does the same, so that no driver's lowering
    // of `a / b` to `a * (1 / b)` can make the two differ).
    let sz = 1.0 / dz;
    Some(Shear {
        k: [kx, ky, kz],
        s: [component(d, kx) * sz, component(d, ky) * sz, sz],
    })
}

/// The watertight test of the ray `org + t d` (`t > 0`) against triangle `p`.
pub fn intersect(org: Vec3, d: Vec3, p: [Vec3; 3]) -> Option<TriHit> {
    intersect_sheared(org, &shear(d)?, p)
}

/// [`intersect`] with the ray's shear frame computed once (for several triangles).
pub fn intersect_sheared(org: Vec3, sh: &Shear, p: [Vec3; 3]) -> Option<TriHit> {
    let [kx, ky, kz] = sh.k;
    let [sx, sy, sz] = sh.s;
    let a = p[0] - org;
    let b = p[1] - org;
    let c = p[2] - org;
    let a_z = component(a, kz);
    let b_z = component(b, kz);
    let c_z = component(c, kz);
    let ax = component(a, kx) - sx * a_z;
    let ay = component(a, ky) - sy * a_z;
    let bx = component(b, kx) - sx * b_z;
    let by = component(b, ky) - sy * b_z;
    let cx = component(c, kx) - sx * c_z;
    let cy = component(c, ky) - sy * c_z;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || det.is_nan() {
        return None;
    }
    let t_scaled = u * (sz * a_z) + v * (sz * b_z) + w * (sz * c_z);
    let rcp = 1.0 / det;
    let t = t_scaled * rcp;
    if t.is_nan() || t <= 0.0 || t.is_infinite() {
        return None;
    }
    Some(TriHit {
        t,
        bary: [u * rcp, v * rcp, w * rcp],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [Vec3; 3] {
        [
            Vec3::new(-1.0, -1.0, 5.0),
            Vec3::new(1.0, -1.0, 5.0),
            Vec3::new(0.0, 1.0, 5.0),
        ]
    }

    #[test]
    fn centre_hit_gives_t_and_barycentrics() {
        let h = intersect(Vec3::ZERO, Vec3::Z, tri()).expect("hit");
        assert_eq!(h.t, 5.0);
        let p = tri();
        let x = p[0] * h.bary[0] + p[1] * h.bary[1] + p[2] * h.bary[2];
        assert!((x - Vec3::new(0.0, 0.0, 5.0)).length() < 1e-6, "{x}");
        // Both windings, and t in units of |d|.
        let [a, b, c] = tri();
        let back = intersect(Vec3::ZERO, Vec3::Z * 2.0, [a, c, b]).expect("either winding");
        assert_eq!(back.t, 2.5);
        // Negative: behind the origin, beside the triangle, and a zero direction.
        assert!(intersect(Vec3::ZERO, -Vec3::Z, tri()).is_none());
        assert!(intersect(Vec3::new(3.0, 0.0, 0.0), Vec3::Z, tri()).is_none());
        assert!(intersect(Vec3::ZERO, Vec3::ZERO, tri()).is_none());
        assert!(intersect(Vec3::ZERO, Vec3::NAN, tri()).is_none());
    }

    #[test]
    fn parallel_and_degenerate_never_hit() {
        // In the plane of the triangle, through its interior, and parallel off the plane.
        assert!(intersect(Vec3::new(-5.0, 0.0, 5.0), Vec3::X, tri()).is_none());
        assert!(intersect(Vec3::new(-5.0, 0.0, 4.0), Vec3::X, tri()).is_none());
        // Zero-area triangles: a line and a point, with rays straight through them.
        let line = [
            Vec3::new(-1.0, 0.0, 5.0),
            Vec3::new(1.0, 0.0, 5.0),
            Vec3::new(0.0, 0.0, 5.0),
        ];
        let point = [Vec3::new(0.0, 0.0, 5.0); 3];
        assert!(intersect(Vec3::ZERO, Vec3::Z, line).is_none());
        assert!(intersect(Vec3::ZERO, Vec3::Z, point).is_none());
        // Negative: the same line given area hits.
        let mut fat = line;
        fat[2].y = 0.5;
        assert!(intersect(Vec3::ZERO, Vec3::Z, fat).is_some());
    }

    /// A fan of triangles around a shared vertex and a strip of shared edges, hit by rays aimed
    /// at points on the edges and at the vertex from many origins: every ray finds at least one
    /// triangle, and its t agrees with the plane.
    #[test]
    fn shared_edges_and_vertices_are_watertight() {
        let mesh = fan_mesh();
        let mut both = 0;
        for (aim, o) in edge_rays(&mesh) {
            let d = aim - o;
            let hits: Vec<_> = mesh.iter().filter_map(|&t| intersect(o, d, t)).collect();
            assert!(
                !hits.is_empty(),
                "a ray through a shared edge found no triangle: {o} -> {aim}"
            );
            both += usize::from(hits.len() > 1);
            for h in &hits {
                let x = o + d * h.t;
                assert!((x - aim).length() < 1e-4, "{x} vs {aim}");
            }
        }
        assert!(
            both > 0,
            "some rays land exactly on an edge and hit both sides"
        );
        // Negative: with one triangle of the fan removed, rays through it find nothing.
        let holed: Vec<_> = mesh[1..].to_vec();
        let lost = edge_rays(&mesh)
            .filter(|(aim, o)| holed.iter().all(|&t| intersect(*o, *aim - *o, t).is_none()))
            .count();
        assert!(lost > 0, "the check must see a hole");
    }

    /// Eight triangles around the vertex (0.3, -0.2, 4): a fan in a tilted plane.
    pub(crate) fn fan_mesh() -> Vec<[Vec3; 3]> {
        let centre = Vec3::new(0.3, -0.2, 4.0);
        let ring: Vec<Vec3> = (0..8)
            .map(|k| {
                let a = k as f32 * std::f32::consts::TAU / 8.0 + 0.1;
                centre + Vec3::new(a.cos() * 1.7, a.sin() * 1.3, a.cos() * 0.6 - a.sin() * 0.3)
            })
            .collect();
        (0..8)
            .map(|k| [centre, ring[k], ring[(k + 1) % 8]])
            .collect()
    }

    /// Rays (aim point, origin) at points on the fan's spokes (shared edges) and at its centre.
    pub(crate) fn edge_rays(mesh: &[[Vec3; 3]]) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
        let origins = [
            Vec3::ZERO,
            Vec3::new(0.7, 0.4, -1.0),
            Vec3::new(-2.0, 1.5, 0.5),
            Vec3::new(0.31, -0.19, 0.0),
        ];
        mesh.iter().flat_map(move |t| {
            (0..16).flat_map(move |s| {
                let aim = t[0].lerp(t[1], s as f32 / 16.0);
                origins.into_iter().map(move |o| (aim, o))
            })
        })
    }
}

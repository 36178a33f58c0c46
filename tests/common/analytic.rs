//! Closed-form ray intersections for the synthetic CMO scenes of the tracer tests: distances
//! along `o + t d` (unit `d`), `t > 0`.

use glam::Vec3;

/// Axis-aligned box.
#[derive(Clone, Copy, Debug)]
pub struct Aabb {
    pub lo: Vec3,
    pub hi: Vec3,
}

/// Distance from `o` (inside) to the box's walls.
pub fn exit_box(b: Aabb, o: Vec3, d: Vec3) -> f32 {
    let mut t = f32::INFINITY;
    for k in 0..3 {
        if d[k] > 0.0 {
            t = t.min((b.hi[k] - o[k]) / d[k]);
        } else if d[k] < 0.0 {
            t = t.min((b.lo[k] - o[k]) / d[k]);
        }
    }
    t
}

/// Entry distance into a box (slab test), or infinity.
pub fn enter_box(b: Aabb, o: Vec3, d: Vec3) -> f32 {
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < b.lo[k] || o[k] > b.hi[k] {
                return f32::INFINITY;
            }
        } else {
            let a = (b.lo[k] - o[k]) / d[k];
            let c = (b.hi[k] - o[k]) / d[k];
            t0 = t0.max(a.min(c));
            t1 = t1.min(a.max(c));
        }
    }
    if t0 <= t1 { t0 } else { f32::INFINITY }
}

/// Roots of `|o + t d - c| = r`: `(near, far)`, NaN when missed.
pub fn sphere_roots(c: Vec3, r: f32, o: Vec3, d: Vec3) -> (f32, f32) {
    let oc = o - c;
    let b = oc.dot(d);
    let disc = b * b - (oc.length_squared() - r * r);
    if disc < 0.0 {
        return (f32::NAN, f32::NAN);
    }
    let s = disc.sqrt();
    (-b - s, -b + s)
}

/// Entry distance into a sphere from outside, or infinity.
pub fn enter_sphere(c: Vec3, r: f32, o: Vec3, d: Vec3) -> f32 {
    let (t0, _) = sphere_roots(c, r, o, d);
    if t0 > 0.0 { t0 } else { f32::INFINITY }
}

//! The sample the placement search scores centres on: the cameras' reflected rays and, with
//! several reflections per path, their later bounces; and what an unresolved one really meets
//! (for the fallback warning's cause).

use glam::Vec3;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::reference::{self, Hit, Tracer};

/// Columns of the grid of pixels that the sample is drawn from (per camera).
const GRID_COLUMNS: u32 = 96;

/// One reflected ray: origin on the mirror, unit direction, and the hit it leaves.
#[derive(Clone, Copy, Debug)]
pub(super) struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub from: Hit,
}

/// The cameras' reflected rays: each camera's mirror pixels on a grid of at most
/// [`GRID_COLUMNS`] columns, `samples` of them in all at an even stride (each camera an equal
/// share). Deterministic.
pub(super) fn reflected_rays(tracer: &Tracer, cameras: &[Camera], samples: usize) -> Vec<Ray> {
    let share = samples.div_ceil(cameras.len().max(1)).max(1);
    cameras
        .iter()
        .flat_map(|camera| {
            let rays = camera_rays(tracer, camera);
            let stride = rays.len().div_ceil(share).max(1);
            rays.into_iter().step_by(stride)
        })
        .collect()
}

/// The later reflections of the paths that `first` (the sample's first reflected rays) start,
/// up to `bounces` reflections per path in all (0 and 1: none): while a ray's exact nearest hit
/// is on a reflector, the ray reflected there about the interpolated normal, as the reference's
/// paths do ([`reference::finish_path`]). A glossy reflector reflects along the mirror direction
/// (its lobe's axis), not a sampled one. In the order of `first`, each path's rays in the order
/// taken; at most `bounces - 1` per first ray. Deterministic.
pub(super) fn bounce_rays(tracer: &Tracer, first: &[Ray], bounces: u32) -> Vec<Ray> {
    if bounces <= 1 {
        return Vec::new();
    }
    let paths: Vec<Vec<Ray>> = first
        .par_iter()
        .map(|&ray| {
            let mut ray = ray;
            let mut out = Vec::new();
            for _ in 1..bounces {
                let Some(hit) = tracer.nearest(ray.origin, ray.dir, Some(&ray.from)) else {
                    break;
                };
                if !tracer.is_reflector(hit.triangle) {
                    break;
                }
                let n = tracer.normal(&hit);
                ray = Ray {
                    origin: hit.position,
                    dir: reference::reflect(ray.dir, n).normalize(),
                    from: hit,
                };
                out.push(ray);
            }
            out
        })
        .collect();
    paths.into_iter().flatten().collect()
}

/// The cameras' rays through the grid's pixels whose nearest hit is on a reflector, reflected
/// there. A ray that misses the reflectors' box (grown by a margin) meets no reflector, and is
/// not traced: the same rays as tracing them all, in a fraction of the time where the mirrors
/// fill a small part of the view.
fn camera_rays(tracer: &Tracer, camera: &Camera) -> Vec<Ray> {
    let (lo, hi) = tracer.world.bounds(|o| o.reflector);
    if lo.x > hi.x {
        return Vec::new();
    }
    let margin = 1e-3 * (hi - lo).max_element() + 1e-4 * lo.abs().max(hi.abs()).max_element();
    grid_rays(
        tracer,
        camera,
        lo - Vec3::splat(margin),
        hi + Vec3::splat(margin),
    )
}

/// [`camera_rays`] with the box `[lo, hi]` in place of the reflectors' grown one.
fn grid_rays(tracer: &Tracer, camera: &Camera, lo: Vec3, hi: Vec3) -> Vec<Ray> {
    let step = camera.width.div_ceil(GRID_COLUMNS).max(1);
    let pixels: Vec<(u32, u32)> = (0..camera.height)
        .step_by(step as usize)
        .flat_map(|j| {
            (0..camera.width)
                .step_by(step as usize)
                .map(move |i| (i, j))
        })
        .collect();
    pixels
        .par_iter()
        .filter_map(|&(i, j)| {
            let (eye, dir) = camera.ray(i, j);
            if !meets_box(eye, dir, lo, hi) {
                return None;
            }
            let hit = tracer.nearest(eye, dir, None)?;
            if !tracer.is_reflector(hit.triangle) {
                return None;
            }
            let n = tracer.normal(&hit);
            Some(Ray {
                origin: hit.position,
                dir: reference::reflect(dir, n).normalize(),
                from: hit,
            })
        })
        .collect()
}

/// Whether the ray `eye + t dir`, `t >= 0`, may meet the box `[lo, hi]`: the slab test in f64
/// (a direction component of 0 gives infinite slab ends, or a NaN where the eye lies on the
/// slab's plane, which counts as meeting: the test errs only towards tracing).
fn meets_box(eye: Vec3, dir: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let (o, d) = (eye.as_dvec3(), dir.as_dvec3());
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        let a = (f64::from(lo[k]) - o[k]) / d[k];
        let b = (f64::from(hi[k]) - o[k]) / d[k];
        if a.is_nan() || b.is_nan() {
            continue;
        }
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    t0 <= t1
}

/// What the unresolved rays of a placement really meet (the exact tracer's first hit), so that
/// a warning can say what no centre could do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Unresolved {
    /// Rays that meet the reflector they leave (a non-convex reflector's own inside).
    pub own_reflector: usize,
    /// Rays that meet another reflector (facing mirrors).
    pub other_reflector: usize,
    /// Rays that meet another surface, or nothing.
    pub elsewhere: usize,
}

impl Unresolved {
    pub fn total(&self) -> usize {
        self.own_reflector + self.other_reflector + self.elsewhere
    }

    /// What the search could not do, in words, when the reflectors hold most of the rays it left
    /// unresolved; `None` otherwise.
    pub fn cause(&self) -> Option<String> {
        let total = self.total();
        if total == 0 {
            return None;
        }
        let pct = |n: usize| 100.0 * n as f64 / total as f64;
        if 2 * self.own_reflector >= total {
            Some(format!(
                "{:.0}% of the rays the CMO placement left unresolved meet the reflector they \
                 leave (its own inside, which a CMO sees only from one side)",
                pct(self.own_reflector)
            ))
        } else if 2 * (self.own_reflector + self.other_reflector) >= total {
            Some(format!(
                "{:.0}% of the rays the CMO placement left unresolved meet a reflector (facing \
                 reflectors or its own inside), which the CMOs capture only where it faces them",
                pct(self.own_reflector + self.other_reflector)
            ))
        } else {
            None
        }
    }
}

/// The mesh a triangle belongs to (object names are `"mesh/part"`).
fn mesh_of(tracer: &Tracer, triangle: u32) -> &str {
    let object = &tracer.world.objects[tracer.world.triangle_object[triangle as usize] as usize];
    object.name.split('/').next().unwrap_or("")
}

/// Sorts `rays` by what they really meet.
pub(super) fn classify(tracer: &Tracer, rays: &[&Ray]) -> Unresolved {
    let kinds: Vec<u8> = rays
        .par_iter()
        .map(|r| match tracer.nearest(r.origin, r.dir, Some(&r.from)) {
            Some(h) if tracer.is_reflector(h.triangle) => {
                if mesh_of(tracer, h.triangle) == mesh_of(tracer, r.from.triangle) {
                    0
                } else {
                    1
                }
            }
            _ => 2,
        })
        .collect();
    let count = |k: u8| kinds.iter().filter(|&&x| x == k).count();
    Unresolved {
        own_reflector: count(0),
        other_reflector: count(1),
        elsewhere: count(2),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box test drops only rays that meet no reflector: on every built-in scene the sample's
    /// rays are those of tracing every pixel of the grid. Negative: a box that leaves out part
    /// of the mirror loses rays.
    #[test]
    fn the_box_test_drops_no_mirror_ray() {
        let all = Vec3::splat(f32::INFINITY);
        let mut scenes = 0;
        for (name, _) in crate::scene::builtin::NAMES {
            let scene = crate::scene::load(name).unwrap();
            let tracer = Tracer::new(&scene);
            let Some(camera) = scene.cameras.first() else {
                continue;
            };
            let culled = camera_rays(&tracer, camera);
            let traced = grid_rays(&tracer, camera, -all, all);
            let key = |r: &Ray| (r.from.triangle, r.origin.to_array().map(f32::to_bits));
            assert_eq!(
                culled.iter().map(key).collect::<Vec<_>>(),
                traced.iter().map(key).collect::<Vec<_>>(),
                "{name}"
            );
            if traced.len() > 10 {
                scenes += 1;
                let (lo, hi) = tracer.world.bounds(|o| o.reflector);
                let half = grid_rays(&tracer, camera, lo, 0.5 * (lo + hi));
                assert!(half.len() < traced.len(), "{name}: {} rays", half.len());
            }
        }
        assert!(scenes >= 3, "{scenes} scenes with mirror pixels");
    }
}

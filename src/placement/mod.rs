#![forbid(unsafe_code)]
//! CMO placement, an algorithm over the scene (the scene itself is data and imports none):
//! [`resolve`] runs the search of `[cmo] placement = "auto"` ([`CmoPlacement::Search`]) for the
//! camera a render uses and stores its centres in the scene; [`diagnose`] finds set-ups that
//! load fine but cannot give a useful mirror image.
//!
//! The search: CMO centres chosen greedily to minimise the unresolved share of
//! a CPU sample of the camera's reflected rays.
//!
//! The sample: the camera's mirror pixels on a coarse grid, a few hundred of them evenly spread,
//! each reflected once about the interpolated normal at its primary hit (the exact
//! [`Tracer`]). Candidates: a small grid over the reflectors' bounding box grown by half its
//! largest side every way (a flat mirror's box is flat; a centre in front of it is a candidate
//! too) and clipped to the scene's box, plus the axis placements of `count = 1..=N`. A set of centres is scored by tracing the
//! sample with the CPU twin of the tracer ([`crate::cpu::options::trace_ray`], exact, over
//! CPU captures [`crate::reference::capture`] of each centre at a small cube size): the share of
//! rays that end unresolved. Each step adds the candidate that lowers the share most (first in
//! candidate order on ties), and stops early when none lowers it. Deterministic.

use glam::Vec3;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::cpu::CmoTracer;
use crate::cpu::multi::MultiStatus;
use crate::cpu::options::{TraceOptions, trace_ray};
use crate::reference::{self, Tracer};
use crate::scene::{CmoPlacement, Scene};

mod diagnose;

pub use diagnose::diagnose;

/// How much work the search does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacementOptions {
    /// Reflected rays sampled (at most).
    pub samples: usize,
    /// Face size of the CPU captures.
    pub cube_size: u32,
    /// Candidate grid points per axis.
    pub grid: u32,
}

impl Default for PlacementOptions {
    fn default() -> Self {
        PlacementOptions {
            samples: 400,
            cube_size: 32,
            grid: 4,
        }
    }
}

/// The chosen centres and what each buys.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// In the order chosen.
    pub centres: Vec<Vec3>,
    /// `unresolved[k]`: the unresolved share of the sample with the first `k + 1` centres.
    pub unresolved: Vec<f64>,
    /// The unresolved share with today's `count = N` along the longest axis (same sample).
    pub axis_unresolved: f64,
    /// Reflected rays in the sample.
    pub rays: usize,
}

/// One reflected ray: origin on the mirror and unit direction.
#[derive(Clone, Copy, Debug)]
struct Ray {
    origin: Vec3,
    dir: Vec3,
}

/// The camera's reflected rays: mirror pixels on a grid of at most 96 columns, `samples` of
/// them at an even stride.
fn reflected_rays(tracer: &Tracer, camera: &Camera, samples: usize) -> Vec<Ray> {
    let step = camera.width.div_ceil(96).max(1);
    let pixels: Vec<(u32, u32)> = (0..camera.height)
        .step_by(step as usize)
        .flat_map(|j| {
            (0..camera.width)
                .step_by(step as usize)
                .map(move |i| (i, j))
        })
        .collect();
    let rays: Vec<Ray> = pixels
        .par_iter()
        .filter_map(|&(i, j)| {
            let (eye, dir) = camera.ray(i, j);
            let hit = tracer.nearest(eye, dir, None)?;
            if !tracer.is_reflector(hit.triangle) {
                return None;
            }
            let n = tracer.normal(&hit);
            Some(Ray {
                origin: hit.position,
                dir: reference::reflect(dir, n).normalize(),
            })
        })
        .collect();
    let stride = rays.len().div_ceil(samples.max(1)).max(1);
    rays.into_iter().step_by(stride).collect()
}

/// Share of `rays` that no CMO of `cmos` resolves.
fn unresolved_share(cmos: &[&CmoTracer], rays: &[Ray], t_hi: f32) -> f64 {
    if rays.is_empty() {
        return 0.0;
    }
    let cmos: Vec<CmoTracer> = cmos.iter().map(|&c| c.clone()).collect();
    let opts = TraceOptions::default();
    let bad = rays
        .par_iter()
        .filter(|r| {
            trace_ray(&cmos, r.origin, r.dir, 0.0, t_hi, &opts).status == MultiStatus::Unresolved
        })
        .count();
    bad as f64 / rays.len() as f64
}

/// Candidate centres: the grid over the grown reflector box, then the axis placements.
fn candidates(scene: &Scene, count: u32, grid: u32) -> Vec<Vec3> {
    let world = scene.world();
    let (lo, hi) = world.bounds(|o| o.reflector);
    let (lo, hi) = if lo.x > hi.x {
        world.bounds(|_| true)
    } else {
        (lo, hi)
    };
    let grow = Vec3::splat(0.5 * (hi - lo).max_element());
    // Grown, but not beyond the scene: a centre outside it sees nothing the rays meet.
    let (all_lo, all_hi) = world.bounds(|_| true);
    let (lo, hi) = ((lo - grow).max(all_lo), (hi + grow).min(all_hi));
    let g = grid.max(1);
    let mut out = Vec::new();
    for x in 0..g {
        for y in 0..g {
            for z in 0..g {
                let f = (Vec3::new(x as f32, y as f32, z as f32) + 0.5) / g as f32;
                out.push(lo + (hi - lo) * f);
            }
        }
    }
    for n in 1..=count {
        out.extend(scene.axis_centres(n));
    }
    out
}

/// Chooses up to `count` centres for `camera`'s view of `scene` (see the module docs).
pub fn search(scene: &Scene, camera: &Camera, count: u32, opts: &PlacementOptions) -> Placement {
    let tracer = Tracer::new(scene);
    let rays = reflected_rays(&tracer, camera, opts.samples);
    let t_hi = 2.0 * tracer.world.extent().max(f32::MIN_POSITIVE);
    let params = TraceOptions::default().params();
    let capture = |c: Vec3| {
        CmoTracer::new(
            reference::capture(scene, &tracer, c, opts.cube_size),
            params,
        )
    };
    let axis: Vec<CmoTracer> = scene.axis_centres(count).into_iter().map(capture).collect();
    let axis_unresolved = unresolved_share(&axis.iter().collect::<Vec<_>>(), &rays, t_hi);
    let points = candidates(scene, count, opts.grid);
    let cmos: Vec<CmoTracer> = points.iter().map(|&c| capture(c)).collect();
    let mut chosen: Vec<usize> = Vec::new();
    let mut unresolved: Vec<f64> = Vec::new();
    for _ in 0..count.max(1) {
        let mut best: Option<(usize, f64)> = None;
        for k in 0..cmos.len() {
            if chosen.contains(&k) {
                continue;
            }
            let set: Vec<&CmoTracer> = chosen.iter().chain([&k]).map(|&i| &cmos[i]).collect();
            let share = unresolved_share(&set, &rays, t_hi);
            if best.is_none_or(|(_, s)| share < s) {
                best = Some((k, share));
            }
        }
        let Some((k, share)) = best else { break };
        if unresolved.last().is_some_and(|&s| share >= s) {
            break;
        }
        chosen.push(k);
        unresolved.push(share);
        if share == 0.0 {
            break;
        }
    }
    Placement {
        centres: chosen.iter().map(|&k| points[k]).collect(),
        unresolved,
        axis_unresolved,
        rays: rays.len(),
    }
}

/// Runs the search of [`CmoPlacement::Search`] for `camera` once and keeps its centres as the
/// scene's ([`CmoPlacement::Explicit`]), so that later [`Scene::cmo_centres`] calls (ranges,
/// renderer, metrics) read them; `None` (and the scene unchanged) for other placements.
pub fn resolve(scene: &mut Scene, camera: &Camera) -> Option<Placement> {
    let CmoPlacement::Search { count } = scene.cmo.placement else {
        return None;
    };
    let p = search(scene, camera, count, &PlacementOptions::default());
    scene.cmo.placement = CmoPlacement::Explicit(p.centres.clone());
    Some(p)
}

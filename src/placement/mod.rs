#![forbid(unsafe_code)]
//! CMO placement, an algorithm over the scene (the scene itself is data and imports none):
//! [`resolve_for`] runs the search of [`CmoPlacement::Search`] (the default without `[cmo]`
//! centres, and `[cmo] placement = "auto"`) for the cameras a render uses and stores its centres
//! in the scene; [`diagnose()`] finds set-ups that load fine but cannot give a useful mirror image.
//!
//! The search adds CMO centres greedily until the share of a sample of reflected rays that no
//! CMO resolves falls to [`TARGET_SHARE`], within a budget of CMOs (the scene's `count`, else
//! [`DEFAULT_SEARCH_CMOS`]) and of their memory at the scene's face size ([`MAX_CMO_BYTES`]).
//!
//! The sample: the cameras' mirror pixels on a coarse grid, a few hundred of them evenly spread,
//! each reflected once about the interpolated normal at its primary hit (the exact [`Tracer`]);
//! then, for `render --bounces N` ([`PlacementOptions::bounces`]), the later reflections of those
//! paths: while a ray's exact nearest hit is on a reflector, the ray reflected there, up to N
//! reflections per path (the reference's rule, along the mirror direction on a glossy reflector
//! too). The first rays come first, as with one reflection, and the later ones after all of them,
//! path by path; the sample budget counts the first rays only, and each adds at most N - 1. With
//! N = 1 the sample, and so the placement, is the first rays' alone. Candidates: a small grid over
//! the reflectors' bounding box grown by half its largest side every way (a flat mirror's box is
//! flat; a centre in front of it is a candidate too; a non-convex reflector and facing reflectors
//! get centres outside their hull) and clipped to the scene's box, plus the axis placements of one
//! to three CMOs. The greedy steps score a set of centres by tracing the sample with the CPU twin
//! of the centre criterion's tracer ([`crate::cpu::multi::trace_cmos_verified`]: the pyramid march,
//! every hit verified against the captured triangle IDs, as `compute` and `fragment` do), over CPU
//! captures ([`crate::cpu::capture::capture`]) of each centre at a small face size: the share of
//! rays that end unresolved. Each step adds the candidate that lowers that share most (first in
//! candidate order on ties), scoring only the rays the centres chosen so far leave unresolved, and
//! stops when none lowers it or the frame's criterion meets the target (below); the final share is
//! judged again over the whole sample. Before all this, the cheapest sets are tried: one CMO on
//! the reflectors' axis, and one in front of the mirror points in view (`near_centre`: where the
//! first reflected rays leave in a common direction, as off a flat mirror); where one meets the
//! target, the search ends with it, after a capture or two instead of the candidates' (the corpus's
//! slivers and the torus: 13-14 ms instead of 95-104). Where both meet it, the one in front is
//! taken only where the pyramid march's twin tests at most [`NEAR_WALK`] of the axis centre's
//! texels and cells per ray on the sample ([`NearChoice`]): the capture costs about the same for
//! either, the trace does not. Between the corpus's facing mirrors the axis centre sits above the
//! bunny, halfway between the mirrors, and the rays that leave the mirror in view sweep its cube
//! map; from just in front of that mirror they leave nearly straight on (at 320x240 on lavapipe:
//! 103 texels and cells per ray against 168, `compute`'s trace 54 ms against 135). Deterministic.
//!
//! The criterion ([`Scoring`]): whether a set meets the target is the frame's own criterion's share
//! of the whole sample. For the centre criterion (and the approximate ones) that is the greedy
//! steps' score. For the bounded criterion, the default, it is that criterion's CPU twin
//! ([`crate::cpu::bounded`]) over lists captured on the CPU
//! ([`crate::cubemap::bounds::capture_lists`]) at the frame's list size (for `--list-size auto`,
//! the size its rule takes for the centre alone; at most [`JUDGE_LISTS_MAX`]), built once per
//! centre the search judges: the axis CMO, then the set after each step. The lists carry what a
//! centre-sampled capture loses behind the first surface, so the bounded frame leaves far fewer
//! rays to the fallback with the same centres, and a search judged by the centre criterion placed
//! CMOs that only cost the bounded frame time (on the corpus at 320x240: robot-table 8 CMOs and a
//! 242 ms frame where one CMO leaves 0.7 % in 69 ms;
//! `benches/results/lavapipe-default-bounded.md`). The steps' order stays the centre criterion's:
//! scoring every candidate with lists would build them for 67 centres.
//!
//! Under `self_reflections = "auto"` with a reflector that would be captured (not convex),
//! [`resolve_for`] first searches with the reflectors left out of the capture and keeps that
//! where it meets the target or leaves fewer rays unresolved: the reflector check then traces
//! the rays that meet a reflector exactly, so the image is the same, and a CMO no longer sees
//! only a captured reflector's inside (the open mug of the corpus: 5.2 % of the sample
//! unresolved with 8 CMOs captured, 0.3 % with 2 left out). A view with no mirror pixel gets one
//! CMO on the reflectors' axis.
//!
//! Cost: the search runs before the first frame (`render -v` and the bench state its time), and
//! the captures of the candidates are most of it. They trace a BVH without the objects the
//! capture leaves out ([`Tracer::keeping`]: the same hits), a step stops counting a candidate's
//! rays once it is known to lose (`best_step`: the same pick), and the axis placement reuses the
//! captures of the candidates among its centres. `search_exhaustive` (test hooks) runs without
//! these, and the tests check that it gives the same placement. With `--bounces N` the later
//! reflections add their rays to every score (on the corpus's facing mirrors at N = 3: 115 rays
//! to the 387 first ones).
//!
//! What the sample cannot promise: the frame's own share differs by the sampling error (a few
//! rays in a hundred at 512 rays) and by the face size (a finer capture verifies more hits on
//! small triangles). `render` states both shares under `-v`.

use std::cell::Cell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::cpu::capture::capture_shaded;
use crate::cpu::multi::WorldRay;
use crate::cpu::multi::{MultiStatus, Traversal, Verify, trace_cmos_verified};
use crate::cpu::options::TraceOptions;
use crate::cpu::verify::triangle_corners;
use crate::cpu::{CmoTracer, bounded};
use crate::cubemap::bounds::{
    BuiltLists, DEFAULT_DEPTH, FacePairs, ListSize, PairParts, SHORT_LIST_LENGTH, auto_list_size,
    list_size_for,
};
use crate::reference::Tracer;
use crate::scene::{CmoPlacement, Scene, SelfReflections, WorldGeometry};

mod diagnose;
mod rays;

pub use diagnose::{diagnose, diagnose_with};
pub use rays::Unresolved;
use rays::{Ray, bounce_rays, classify, reflected_rays};

/// The share of sampled rays left unresolved at which the search stops adding CMOs: 1 %, half
/// the 2 % it aims at for the frame, for the sampling error of its 512 rays (0.6 % at 2 %) and
/// the coarser capture it scores with (measured on the corpus at 256: frames 0.04-0.96 % where
/// the sample gave 0-0.7 %; at a 1.5 % stop one frame came out at 2.17 %).
pub const TARGET_SHARE: f64 = 0.01;

pub use crate::scene::DEFAULT_SEARCH_CMOS;

/// Memory the searched CMOs may take at the scene's face size (their distance, colour and
/// triangle-ID cubes and the tracers' hierarchy, [`cmo_bytes`]): 512 MiB.
pub const MAX_CMO_BYTES: u64 = 512 << 20;

/// Bytes one CMO of face size `size` takes on the GPU for the default method, about: 16 per
/// texel (distance, colour, triangle ID, and the min/max hierarchy's share).
pub fn cmo_bytes(size: u32) -> u64 {
    6 * u64::from(size) * u64::from(size) * 16
}

/// How many CMOs the search may place: `count`, and no more than [`MAX_CMO_BYTES`] hold at face
/// size `size` (at least one).
pub fn cmo_budget(count: u32, size: u32) -> u32 {
    let fit = (MAX_CMO_BYTES / cmo_bytes(size).max(1)).max(1);
    count.min(u32::try_from(fit).unwrap_or(u32::MAX)).max(1)
}

/// The largest face size of the lists the bounded judge builds on the CPU ([`Scoring`]): the
/// frame's lists where they are at most this, else this. Coarser lists hold more entries per
/// texel and cut more of them at the depth, so a capped judge leaves more of the sample
/// unresolved, not less (truck-garage's first centre: 5.78 % at 32, 2.65 % at 64, 1.20 % at 128,
/// depth 64); the cost grows about 2.5 times per doubling (truck-garage, 2 cores: 50 ms at 64,
/// 78 at 128, 184 at 256, 515 at 512), and the search must stay cheap beside the capture.
pub const JUDGE_LISTS_MAX: u32 = 128;

/// How far the rays of the centre in front of the mirror points in view must walk below the
/// axis centre's to replace it (texels and cells tested per ray, the pyramid march's twin on the
/// sample): 3/4. The twin's count is an estimate of the GPU's cost, and a small gain is within
/// the sample's error: on the corpus's open mug it counted 11 % fewer and lavapipe's trace took
/// 20 % longer; between the corpus's facing mirrors, 45 % fewer and the trace took 60 % less.
pub const NEAR_WALK: f64 = 0.75;

/// How much work the search does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacementOptions {
    /// Reflected rays sampled (at most; shared between the cameras).
    pub samples: usize,
    /// Face size of the CPU captures.
    pub cube_size: u32,
    /// Candidate grid points per axis.
    pub grid: u32,
    /// Stop once the sampled unresolved share is at most this ([`TARGET_SHARE`]); 0 adds CMOs
    /// while any lowers it.
    pub target: f64,
    /// Reflections per path that the sample follows (the render's `--bounces`): 1 (and 0)
    /// samples the first reflected rays only; N adds each path's later reflections off
    /// reflectors, up to N in all (module docs).
    pub bounces: u32,
    /// The frame's criterion, whose share of the sample the search stops on (module docs,
    /// "The criterion").
    pub scoring: Scoring,
}

/// Which CPU twin judges a set of centres: the frame's criterion (module docs, "The
/// criterion").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scoring {
    /// The centre criterion's, with verified hits (the frame's criterion is the centre one, or
    /// an approximate one, which has no twin that reports rays it cannot resolve).
    Centre,
    /// The bounded criterion's ([`crate::cpu::bounded`]) over lists of the frame's face size
    /// (`--list-size`; for `auto`, the size its rule takes for each centre alone at the scene's
    /// cube size, [`auto_list_size`]), at most [`JUDGE_LISTS_MAX`].
    Bounded(ListSize),
}

impl Scoring {
    /// What judges the shares, in words (`render -v`).
    pub fn name(self) -> &'static str {
        match self {
            Scoring::Centre => "the centre criterion",
            Scoring::Bounded(_) => "the bounded criterion's lists",
        }
    }
}

impl Default for Scoring {
    /// The default criterion's (bounded) at the default list size.
    fn default() -> Self {
        Scoring::Bounded(ListSize::default())
    }
}

impl Default for PlacementOptions {
    fn default() -> Self {
        PlacementOptions {
            samples: 512,
            cube_size: 32,
            grid: 4,
            target: TARGET_SHARE,
            bounces: 1,
            scoring: Scoring::default(),
        }
    }
}

/// The chosen centres and what each buys. Equal placements compare equal whatever their
/// [`Placement::time`].
#[derive(Clone, Debug)]
pub struct Placement {
    /// In the order chosen.
    pub centres: Vec<Vec3>,
    /// `unresolved[k]`: the unresolved share of the sample with the first `k + 1` centres, as
    /// the frame's criterion judges it ([`PlacementOptions::scoring`]).
    pub unresolved: Vec<f64>,
    /// The unresolved share with as many centres along the reflectors' longest axis (the
    /// `placement = "axis"` of the same count; same sample, same judge).
    pub axis_unresolved: f64,
    /// Reflected rays in the sample.
    pub rays: usize,
    /// Of [`Placement::rays`], the reflections after the first of their paths
    /// ([`PlacementOptions::bounces`]).
    pub later_rays: usize,
    /// What the rays the chosen centres leave unresolved really meet.
    pub left: Unresolved,
    /// The search's wall-clock time: from [`resolve_for`], all of it (both searches where it
    /// tries the reflectors left out, the scene moved to its anchor and back).
    pub time: Duration,
    /// Whether [`resolve_for`] left the reflectors out of the capture
    /// (`self_reflections = "auto"` set to off), where that left fewer rays unresolved.
    pub self_capture_off: bool,
    /// The twin that judged the shares ([`PlacementOptions::scoring`]).
    pub judge: Scoring,
    /// Where one CMO on the reflectors' axis and one in front of the mirror points in view both
    /// met the target: the one in front and the two walks that chose between them.
    pub near: Option<NearChoice>,
    /// The bounded lists' face size the shares were judged at, where it is not `--list-size
    /// auto`'s rule: one CMO on the reflectors' axis missed the target with lists of the rule's
    /// size and met it with shorter ones ([`SHORT_LIST_LENGTH`] nodes per texel), so the frame
    /// takes that size ([`resolve_for`] sets `CmoSpec::lists`) instead of a search for more
    /// centres. `None`: the rule's.
    pub list_size: Option<u32>,
    /// The bounded judge's lists of the chosen centres (in the scene's coordinates relative to
    /// its anchor, as the search built them), which a still frame uploads instead of capturing
    /// where its capture has their inputs ([`BuiltLists::same_inputs`]); `None` for the centre
    /// criterion.
    pub lists: Option<Arc<BuiltLists>>,
}

/// One CMO in front of the mirror points in view (`near_centre`) weighed against one on the
/// reflectors' axis, both meeting the target: the texels and cells the pyramid march's twin
/// tests per ray on the sample with each ([`NEAR_WALK`] decides).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearChoice {
    pub centre: Vec3,
    pub walk: f64,
    pub axis_walk: f64,
}

impl NearChoice {
    /// Whether the centre in front replaces the axis one.
    pub fn taken(&self) -> bool {
        self.walk <= NEAR_WALK * self.axis_walk
    }
}

impl PartialEq for Placement {
    fn eq(&self, other: &Self) -> bool {
        let key = |p: &Self| {
            (
                p.centres.clone(),
                p.unresolved.clone(),
                p.axis_unresolved,
                p.rays,
                p.later_rays,
                p.left,
                p.self_capture_off,
                p.judge,
                p.near,
                p.list_size,
            )
        };
        key(self) == key(other)
    }
}

impl Placement {
    /// The placement of `centres` where no ray was sampled (no mirror pixel in view), judged
    /// by `judge`, the search started at `start`.
    fn unsampled(centres: Vec<Vec3>, start: Instant, judge: Scoring) -> Placement {
        Placement {
            centres,
            unresolved: vec![0.0],
            axis_unresolved: 0.0,
            rays: 0,
            later_rays: 0,
            left: Unresolved::default(),
            time: start.elapsed(),
            self_capture_off: false,
            judge,
            near: None,
            list_size: None,
            lists: None,
        }
    }

    /// The sampled unresolved share with every chosen centre.
    pub fn share(&self) -> f64 {
        self.unresolved.last().copied().unwrap_or(1.0)
    }
}

/// Scores sets of CMOs on the sample: the centre criterion's CPU twin with verified hits.
struct Scorer<'a> {
    rays: &'a [Ray],
    corners: Vec<[Vec3; 3]>,
    t_hi: f32,
}

impl<'a> Scorer<'a> {
    /// Scores `rays` against the triangles of `tracer`'s scene.
    fn new(tracer: &Tracer, rays: &'a [Ray], corners: Vec<[Vec3; 3]>) -> Self {
        Scorer {
            rays,
            corners,
            t_hi: 2.0 * tracer.world.extent().max(f32::MIN_POSITIVE),
        }
    }

    fn unresolved(&self, cmos: &[&CmoTracer], ray: &Ray) -> bool {
        let verify = Verify {
            triangles: &self.corners,
        };
        let r = trace_cmos_verified(
            cmos,
            ray.origin,
            ray.dir,
            0.0,
            self.t_hi,
            Traversal::Mip,
            Some(verify),
        );
        r.status == MultiStatus::Unresolved
    }

    /// Sampled ray `i` as the CPU twins trace it, over the whole of the scene's extent.
    fn world_ray(&self, i: usize) -> WorldRay {
        let r = &self.rays[i];
        WorldRay {
            origin: r.origin,
            dir: r.dir,
            from: r.from.triangle,
            t_lo: 0.0,
            t_hi: self.t_hi,
        }
    }

    /// The rays of `open` (indices into the sample) that `cmos` leave unresolved.
    fn left(&self, cmos: &[&CmoTracer], open: &[usize]) -> Vec<usize> {
        open.par_iter()
            .copied()
            .filter(|&i| self.unresolved(cmos, &self.rays[i]))
            .collect()
    }
}

/// Candidate centres: the grid over the grown reflector box, then the axis placements of one to
/// three CMOs.
fn candidates(world: &WorldGeometry, grid: u32) -> Vec<Vec3> {
    let (lo, hi) = world.reflector_bounds();
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
    for n in 1..=3 {
        out.extend(world.axis_centres(n));
    }
    out
}

/// Chooses up to `count` centres for the cameras' view of `scene` (see the module docs).
pub fn search(scene: &Scene, cameras: &[Camera], count: u32, opts: &PlacementOptions) -> Placement {
    search_by(scene, scene.world(), cameras, count, opts, true)
}

/// [`search`] without its shortcuts (module docs, "Cost"): the captures over every triangle,
/// every ray of every candidate counted at each step, the axis centres captured again. The
/// tests check that both give the same [`Placement`].
#[cfg(any(test, feature = "test-hooks"))]
pub fn search_exhaustive(
    scene: &Scene,
    cameras: &[Camera],
    count: u32,
    opts: &PlacementOptions,
) -> Placement {
    search_by(scene, scene.world(), cameras, count, opts, false)
}

/// [`search`] over `world` (the scene's, [`Scene::world`]), with its shortcuts or without.
fn search_by(
    scene: &Scene,
    world: WorldGeometry,
    cameras: &[Camera],
    count: u32,
    opts: &PlacementOptions,
    shortcuts: bool,
) -> Placement {
    let start = Instant::now();
    let bounded = BoundedJudge::new(scene, &world, opts);
    let (tracer, shown, corners, axis_cmo) = bvhs_and_axis(world, shortcuts, bounded.as_ref());
    let (rays, later_rays) = sample_rays(&tracer, cameras, opts);
    if rays.is_empty() {
        // No mirror pixel in view: nothing to score, one CMO on the reflectors' axis.
        return Placement::unsampled(tracer.world.axis_centres(1), start, opts.scoring);
    }
    let scorer = Scorer::new(&tracer, &rays, corners);
    let capture_tracer = shown.as_ref().unwrap_or(&tracer);
    let capture = |c: Vec3| scoring_capture(scene, capture_tracer, c, opts.cube_size);
    let mut judge = Judge {
        scorer: &scorer,
        bounded: bounded.map(|b| {
            let (built, axis_pairs) = axis_cmo.unzip();
            BoundedJudge {
                built: built.into_iter().collect(),
                axis_pairs,
                ..b
            }
        }),
    };
    // The cheapest sets first: one CMO ([`one_cmo`]).
    let all: Vec<usize> = (0..rays.len()).collect();
    let first_rays = &rays[..rays.len() - later_rays];
    let one = one_cmo(
        &tracer.world,
        &scorer,
        &mut judge,
        first_rays,
        opts.target,
        &capture,
    );
    // The placement of `centres`, which leave the sample's rays `left` unresolved.
    let placed = |centres, unresolved, axis_unresolved, left: &[usize], near| {
        let left: Vec<&Ray> = left.iter().map(|&i| &rays[i]).collect();
        Placement {
            centres,
            unresolved,
            axis_unresolved,
            rays: rays.len(),
            later_rays,
            left: classify(&tracer, &left),
            time: start.elapsed(),
            self_capture_off: false,
            judge: opts.scoring,
            near,
            list_size: None,
            lists: None,
        }
    };
    if let Some((centre, left)) = one.chosen {
        let share = left.len() as f64 / rays.len() as f64;
        let p = placed(vec![centre], vec![share], one.axis_share, &left, one.near);
        return Placement {
            list_size: one.list_size,
            lists: judge.hand_on(&[centre], one.short_lists),
            ..p
        };
    }
    let points = candidates(&tracer.world, opts.grid);
    let cmos: Vec<CmoTracer> = points.par_iter().map(|&c| capture(c)).collect();
    log::debug!(
        "cmo placement: {} rays sampled ({} of them later reflections), {} candidates captured at \
         {}: {:.2?}",
        rays.len(),
        later_rays,
        points.len(),
        opts.cube_size,
        start.elapsed()
    );
    let mut share_of = |chosen: &[usize], open: &[usize]| {
        let centres: Vec<Vec3> = chosen.iter().map(|&k| points[k]).collect();
        let left = judge.left(&centres, || open.to_vec());
        left.len() as f64 / rays.len() as f64
    };
    let (chosen, unresolved) = greedy(&scorer, &cmos, count, opts.target, shortcuts, &mut share_of);
    let centres: Vec<Vec3> = chosen.iter().map(|&k| points[k]).collect();
    let set: Vec<&CmoTracer> = chosen.iter().map(|&k| &cmos[k]).collect();
    let left = judge.left(&centres, || scorer.left(&set, &all));
    let mut unresolved = unresolved;
    if let Some(last) = unresolved.last_mut() {
        *last = left.len() as f64 / rays.len().max(1) as f64;
    }
    // The axis placement of as many CMOs; a centre that is a candidate (one to three CMOs) has
    // its capture already: the same centre gives the same capture.
    let axis_centres = tracer.world.axis_centres(chosen.len().max(1) as u32);
    let axis_left = judge.left(&axis_centres, || {
        let known = |c: &Vec3| {
            let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
            (points.iter().position(|p| bits(p) == bits(c))).filter(|_| shortcuts)
        };
        let fresh: Vec<CmoTracer> = (axis_centres.iter())
            .filter(|c| known(c).is_none())
            .map(|&c| capture(c))
            .collect();
        let mut fresh_iter = fresh.iter();
        let axis: Vec<&CmoTracer> = (axis_centres.iter())
            .filter_map(|c| known(c).map(|k| &cmos[k]).or_else(|| fresh_iter.next()))
            .collect();
        scorer.left(&axis, &all)
    });
    let axis_share = axis_left.len() as f64 / rays.len() as f64;
    Placement {
        lists: judge.hand_on(&centres, None),
        ..placed(centres, unresolved, axis_share, &left, None)
    }
}

/// What [`bvhs_and_axis`] builds: the tracer, the one over what a capture shows, the triangles'
/// corners and the axis CMO with its pairs.
type SearchStart = (
    Tracer,
    Option<Tracer>,
    Vec<[Vec3; 3]>,
    Option<(CmoTracer, KnownPairs)>,
);

/// The search's BVHs over `world` ([`tracers`] where `shortcuts`, else one over it all), its
/// triangles' corners ([`triangle_corners`]) and the `bounded` judge's CMO on the reflectors'
/// axis with its pairs, built at once: that CMO, the first the judge weighs (and on most scenes
/// the last), needs the world but not the sample, so its lists are built while the BVHs that
/// sample the rays are.
fn bvhs_and_axis(
    world: WorldGeometry,
    shortcuts: bool,
    bounded: Option<&BoundedJudge>,
) -> SearchStart {
    let corners = triangle_corners(&world);
    let axis = world.axis_centres(1)[0];
    let bvhs = move || {
        if shortcuts {
            tracers(world)
        } else {
            (Tracer::from_world(world), None)
        }
    };
    let axis_cmo = || Some(bounded?.cmo_keeping(&corners, axis));
    let ((tracer, shown), axis_cmo) = rayon::join(bvhs, axis_cmo);
    (tracer, shown, corners, axis_cmo)
}

/// What [`one_cmo`] found: the centre that ends the search and the sample's rays it leaves
/// unresolved (`None`: neither meets the target), the axis centre's unresolved share, and the
/// weighing of the two where both met it.
struct OneCmo {
    chosen: Option<(Vec3, Vec<usize>)>,
    axis_share: f64,
    near: Option<NearChoice>,
    /// The lists' face size where the axis CMO met the target only with shorter lists
    /// ([`Judge::axis_with_short_lists`]; `axis_share` is then its share with them).
    list_size: Option<u32>,
    /// That CMO, with those lists.
    short_lists: Option<CmoTracer>,
}

/// The cheapest sets: one CMO, on the reflectors' axis (the placement without a search) or in
/// front of the mirror points in view ([`near_centre`] of `first_rays`, the sample's first
/// reflected rays). Where one of them leaves at most `target` unresolved, the search ends with
/// it, at the cost of a capture or two instead of the candidates'. Where both do, the one in
/// front replaces the axis only where its rays walk clearly fewer texels and cells
/// ([`NEAR_WALK`]): the capture costs about the same for either, the trace does not. Where
/// neither does, the axis CMO is judged with shorter lists ([`Judge::axis_with_short_lists`]).
fn one_cmo(
    world: &WorldGeometry,
    scorer: &Scorer,
    judge: &mut Judge,
    first_rays: &[Ray],
    target: f64,
    capture: &(dyn Fn(Vec3) -> CmoTracer + Sync),
) -> OneCmo {
    let all: Vec<usize> = (0..scorer.rays.len()).collect();
    let axis_one = world.axis_centres(1);
    let singles: Vec<Vec3> = (axis_one.iter().copied())
        .chain(near_centre(world, first_rays).filter(|c| !axis_one.contains(c)))
        .collect();
    // Both centres' lists at once (the bounded judge), where the two builds share the threads.
    judge.build(&singles);
    let mut axis_share = None;
    let mut passing: Vec<(Vec3, Vec<usize>, Option<CmoTracer>)> = Vec::new();
    for &centre in &singles {
        let mut cmo: Option<CmoTracer> = None;
        let left = judge.left(&[centre], || {
            let c = cmo.insert(capture(centre));
            scorer.left(&[c], &all)
        });
        let share = left.len() as f64 / scorer.rays.len() as f64;
        axis_share.get_or_insert(share);
        if share <= target {
            passing.push((centre, left, cmo));
        }
    }
    let mut near = None;
    if passing.len() == 2 {
        let walks: Vec<f64> = (passing.iter_mut())
            .map(|(centre, _, cmo)| {
                let c = *centre;
                judge.walk(&[c], || cmo.take().unwrap_or_else(|| capture(c)))
            })
            .collect();
        let choice = NearChoice {
            centre: passing[1].0,
            walk: walks[1],
            axis_walk: walks[0],
        };
        if choice.taken() {
            passing.swap(0, 1);
        }
        near = Some(choice);
    }
    let mut axis_share = axis_share.unwrap_or(1.0);
    let mut chosen = passing.into_iter().next().map(|(c, left, _)| (c, left));
    let (mut list_size, mut short_lists) = (None, None);
    if chosen.is_none()
        && let Some((size, left, cmo)) = judge.axis_with_short_lists(world, target, axis_share)
    {
        axis_share = left.len() as f64 / scorer.rays.len() as f64;
        (chosen, list_size) = (Some((axis_one[0], left)), Some(size));
        short_lists = Some(cmo);
    }
    OneCmo {
        chosen,
        axis_share,
        near,
        list_size,
        short_lists,
    }
}

/// What the search stops on: the share of the sample that the frame's criterion leaves
/// unresolved ([`PlacementOptions::scoring`]; module docs, "The criterion"). For the bounded
/// criterion, its CPU twin over lists at the frame's list size (capped), each centre's lists
/// built once; for every other, the centre criterion's score that the greedy steps keep.
struct Judge<'a> {
    scorer: &'a Scorer<'a>,
    /// The bounded criterion's parts; `None` for the centre criterion.
    bounded: Option<BoundedJudge>,
}

/// [`Judge`]'s state for the bounded criterion.
struct BoundedJudge {
    /// Per global triangle, whether the capture takes it.
    captured: Vec<bool>,
    /// The lists' face size; `None`: `--list-size auto`'s rule for each centre at `cube`.
    size: Option<u32>,
    /// The scene's cube size, at most [`JUDGE_LISTS_MAX`].
    cube: u32,
    /// The CMOs built so far.
    built: Vec<CmoTracer>,
    /// The walks ([`Judge::walk`]) of the sets [`Judge::left`] traced, by their centres.
    walked: Vec<(Vec<Vec3>, f64)>,
    /// The axis CMO's pairs, kept for its lists at another size
    /// ([`Judge::axis_with_short_lists`]).
    axis_pairs: Option<KnownPairs>,
}

/// One CMO's (triangle, face) pairs ([`FacePairs`]) and the pool's node bounds weighed on them so
/// far, `(face size, nodes)`: another face size's lists at the same centre start from them.
struct KnownPairs {
    parts: PairParts,
    nodes: Vec<(u32, u64)>,
}

/// The node bound of `pairs` at face size `n`, from `known` where it holds it (added there).
fn known_nodes(pairs: &FacePairs, known: &mut Vec<(u32, u64)>, n: u32) -> u64 {
    match known.iter().find(|k| k.0 == n) {
        Some(k) => k.1,
        None => {
            let v = pairs.bound(n).nodes;
            known.push((n, v));
            v
        }
    }
}

impl BoundedJudge {
    /// The built CMOs at `centres` (those built), in that order.
    fn set(&self, centres: &[Vec3]) -> Vec<&CmoTracer> {
        let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
        (centres.iter())
            .filter_map(|c| self.built.iter().find(|t| bits(&t.cube.centre) == bits(c)))
            .collect()
    }

    /// The bounded judge of `opts` for `scene` (its `world`), no CMO built; `None` for the
    /// centre criterion.
    fn new(scene: &Scene, world: &WorldGeometry, opts: &PlacementOptions) -> Option<Self> {
        let Scoring::Bounded(lists) = opts.scoring else {
            return None;
        };
        // At most JUDGE_LISTS_MAX: `auto`'s rule below it gives the frame's size, or the cap.
        let cube = scene.cmo.resolution.min(JUDGE_LISTS_MAX);
        let size = match lists {
            ListSize::Auto => None,
            ListSize::Cube => Some(cube),
            ListSize::Fixed(n) => Some(n.min(JUDGE_LISTS_MAX)),
        };
        Some(BoundedJudge {
            captured: world.captured_triangles(),
            size,
            cube,
            built: Vec::new(),
            walked: Vec::new(),
            axis_pairs: None,
        })
    }

    /// The CMO at `c` over lists of the triangles `corners` ([`triangle_corners`]) at the
    /// judge's size (for `auto`, its rule at `c`).
    fn cmo(&self, corners: &[[Vec3; 3]], c: Vec3) -> CmoTracer {
        self.cmo_keeping(corners, c).0
    }

    /// [`BoundedJudge::cmo`] and the pairs and node bounds it weighed.
    fn cmo_keeping(&self, corners: &[[Vec3; 3]], c: Vec3) -> (CmoTracer, KnownPairs) {
        let t0 = Instant::now();
        let pairs = FacePairs::new(corners, &self.captured, c);
        let mut nodes = Vec::new();
        let size = (self.size).unwrap_or_else(|| {
            auto_list_size(self.cube, 1, |n| known_nodes(&pairs, &mut nodes, n))
        });
        let lists = pairs.lists(size, DEFAULT_DEPTH);
        log::debug!(
            "cmo placement: lists at {size} for {c}: {:.2?}",
            t0.elapsed()
        );
        let cmo = CmoTracer::bounded(c, lists, corners.to_vec(), TraceOptions::default().params());
        let parts = pairs.into_parts();
        (cmo, KnownPairs { parts, nodes })
    }
}

impl<'a> Judge<'a> {
    #[cfg(any(test, feature = "test-hooks"))]
    fn new(
        scene: &Scene,
        world: &WorldGeometry,
        scorer: &'a Scorer<'a>,
        opts: &PlacementOptions,
    ) -> Self {
        Judge {
            scorer,
            bounded: BoundedJudge::new(scene, world, opts),
        }
    }

    /// Under the bounded criterion with `--list-size auto`: where one CMO on the reflectors' axis
    /// meets `target` with lists of at most [`SHORT_LIST_LENGTH`] nodes per texel, larger than
    /// the rule's size (those of [`Judge::build`]), that size, the sample's rays it leaves and
    /// the CMO; else `None`. Shorter lists cost the capture more than the rule's but one CMO less than a
    /// second, and the search for more centres (70 candidate captures) much more.
    fn axis_with_short_lists(
        &mut self,
        world: &WorldGeometry,
        target: f64,
        axis_share: f64,
    ) -> Option<(u32, Vec<usize>, CmoTracer)> {
        let corners = &self.scorer.corners;
        let b = self.bounded.as_mut().filter(|b| b.size.is_none())?;
        let centre = world.axis_centres(1)[0];
        // The pairs and bounds the axis CMO's lists weighed, where it was built at this centre.
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let known = (b.axis_pairs.take()).filter(|k| bits(k.parts.centre()) == bits(centre));
        let (pairs, mut known) = match known {
            Some(k) => (FacePairs::from_parts(corners, k.parts), k.nodes),
            None => (FacePairs::new(corners, &b.captured, centre), Vec::new()),
        };
        // Each size's pool bound once, for both rules.
        let mut nodes = |n| known_nodes(&pairs, &mut known, n);
        let rule = auto_list_size(b.cube, 1, &mut nodes);
        let size = list_size_for(b.cube, 1, SHORT_LIST_LENGTH, &mut nodes);
        if size <= rule {
            return None;
        }
        let lists = pairs.lists(size, DEFAULT_DEPTH);
        let cmo = CmoTracer::bounded(
            centre,
            lists,
            self.scorer.corners.clone(),
            TraceOptions::default().params(),
        );
        let left = self.unresolved(&[&cmo]);
        let share = left.len() as f64 / self.scorer.rays.len().max(1) as f64;
        log::debug!(
            "cmo placement: one CMO on the reflectors' axis leaves {:.2}% of the sample with \
             lists of auto's size, {:.2}% with lists at {size}",
            100.0 * axis_share,
            100.0 * share
        );
        (share <= target).then_some((size, left, cmo))
    }

    /// The bounded lists of `centres` for the frame ([`Placement::lists`]): `short`'s where
    /// given (one CMO), else those [`Judge::build`] built, taken out of the judge; `None` for the
    /// centre criterion or where one is missing.
    fn hand_on(&mut self, centres: &[Vec3], short: Option<CmoTracer>) -> Option<Arc<BuiltLists>> {
        let b = self.bounded.as_mut()?;
        let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
        let mut taken: Vec<bounded::Bounded> = Vec::new();
        match short {
            Some(mut tr) => taken.push(*tr.bounded.take()?),
            None => {
                for c in centres {
                    let tr = (b.built.iter_mut()).find(|t| bits(&t.cube.centre) == bits(c))?;
                    taken.push(*tr.bounded.take()?);
                }
            }
        }
        let corners = std::mem::take(&mut taken.first_mut()?.corners);
        Some(Arc::new(BuiltLists {
            centres: centres.to_vec(),
            corners,
            captured: std::mem::take(&mut b.captured),
            lists: taken.into_iter().map(|t| t.lists).collect(),
        }))
    }

    /// The sample's rays (indices) that CMOs at `centres` leave unresolved: `centre()` (the
    /// centre criterion's, which the caller knows) unless the criterion is bounded.
    fn left(&mut self, centres: &[Vec3], centre: impl FnOnce() -> Vec<usize>) -> Vec<usize> {
        if self.bounded.is_none() {
            return centre();
        }
        self.build(centres);
        let set = (self.bounded.as_ref()).map_or_else(Vec::new, |b| b.set(centres));
        let (left, walk) = self.traced(&set);
        if let Some(b) = &mut self.bounded {
            b.walked.push((centres.to_vec(), walk));
        }
        left
    }

    /// The sample's rays (indices) that the bounded twin over `set` leaves unresolved.
    fn unresolved(&self, set: &[&CmoTracer]) -> Vec<usize> {
        self.traced(set).0
    }

    /// The sample traced once over the CMOs `set` by the pyramid march's twin: the rays
    /// (indices) it leaves unresolved, and the texels and cells it tests per ray, summed over a
    /// ray's traces ([`Judge::walk`]).
    fn traced(&self, set: &[&CmoTracer]) -> (Vec<usize>, f64) {
        let rays = self.scorer.rays.len();
        let per: Vec<(bool, u64)> = (0..rays)
            .into_par_iter()
            .map(|i| {
                let ray = self.scorer.world_ray(i);
                let work = Cell::new(0u64);
                let r = crate::cpu::multi::trace_world_ray(set, &ray, None, |tr, s| {
                    let r = crate::cpu::multi::trace_one(tr, s, Traversal::Mip);
                    let c = r.counters;
                    work.set(work.get() + u64::from(c.texels) + u64::from(c.cells));
                    r
                });
                (r.status == MultiStatus::Unresolved, work.get())
            })
            .collect();
        let left = (per.iter().enumerate())
            .filter(|(_, p)| p.0)
            .map(|(i, _)| i);
        let work: u64 = per.iter().map(|p| p.1).sum();
        (left.collect(), work as f64 / rays.max(1) as f64)
    }

    /// Builds the bounded criterion's lists of the `centres` not built yet, in parallel (none
    /// for the centre criterion).
    fn build(&mut self, centres: &[Vec3]) {
        let Some(b) = &mut self.bounded else {
            return;
        };
        let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
        let missing: Vec<Vec3> = (centres.iter())
            .filter(|c| !b.built.iter().any(|t| bits(&t.cube.centre) == bits(c)))
            .copied()
            .collect();
        let corners = &self.scorer.corners;
        let fresh: Vec<CmoTracer> = (missing.into_par_iter())
            .map(|c| b.cmo(corners, c))
            .collect();
        b.built.extend(fresh);
    }

    /// The trace's work on the sample with CMOs at `centres`: the texels and cells that the
    /// pyramid march's twin tests per ray, summed over a ray's traces; over the lists
    /// [`Judge::build`] built for the bounded criterion, else over `centre()` (one CMO, the
    /// centre criterion's capture, hits unverified).
    fn walk(&self, centres: &[Vec3], centre: impl FnOnce() -> CmoTracer) -> f64 {
        let Some(b) = &self.bounded else {
            return self.traced(&[&centre()]).1;
        };
        // A set [`Judge::left`] traced has its walk.
        let bits = |v: &[Vec3]| {
            v.iter()
                .map(|c| c.to_array().map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        match b.walked.iter().find(|w| bits(&w.0) == bits(centres)) {
            Some(w) => w.1,
            None => self.traced(&b.set(centres)).1,
        }
    }
}

/// The sample of the module docs: the cameras' first reflected rays, then the later reflections
/// of their paths; and how many of it are later reflections.
fn sample_rays(tracer: &Tracer, cameras: &[Camera], opts: &PlacementOptions) -> (Vec<Ray>, usize) {
    let mut rays = reflected_rays(tracer, cameras, opts.samples);
    let later = bounce_rays(tracer, &rays, opts.bounces);
    let n = later.len();
    rays.extend(later);
    (rays, n)
}

/// The rays [`search`] scores on for `cameras` and `opts` (module docs, in that order): each
/// ray's origin, unit direction, and the hit it leaves.
#[cfg(any(test, feature = "test-hooks"))]
pub fn sample(
    scene: &Scene,
    cameras: &[Camera],
    opts: &PlacementOptions,
) -> Vec<(Vec3, Vec3, crate::reference::Hit)> {
    let (rays, _) = sample_rays(&Tracer::new(scene), cameras, opts);
    rays.iter().map(|r| (r.origin, r.dir, r.from)).collect()
}

/// The share of [`sample`] that CMOs at `centres` leave unresolved, judged as [`search`] judges
/// a set against the target (`opts.scoring`: the centre criterion's twin over captures at
/// `opts.cube_size`, or the bounded criterion's over lists); 0 for an empty sample.
#[cfg(any(test, feature = "test-hooks"))]
pub fn sample_share(
    scene: &Scene,
    cameras: &[Camera],
    centres: &[Vec3],
    opts: &PlacementOptions,
) -> f64 {
    let tracer = Tracer::new(scene);
    let (rays, _) = sample_rays(&tracer, cameras, opts);
    if rays.is_empty() {
        return 0.0;
    }
    let scorer = Scorer::new(&tracer, &rays, triangle_corners(&tracer.world));
    let mut judge = Judge::new(scene, &tracer.world, &scorer, opts);
    let all: Vec<usize> = (0..rays.len()).collect();
    let left = judge.left(centres, || {
        let cmos: Vec<CmoTracer> = (centres.iter())
            .map(|&c| scoring_capture(scene, &tracer, c, opts.cube_size))
            .collect();
        scorer.left(&cmos.iter().collect::<Vec<_>>(), &all)
    });
    left.len() as f64 / rays.len() as f64
}

/// The CMO at `centre` as the search scores it: captured by `tracer` at face size `size`,
/// without colour, traced with the default options.
fn scoring_capture(scene: &Scene, tracer: &Tracer, centre: Vec3, size: u32) -> CmoTracer {
    let capture = capture_shaded(scene, tracer, centre, size, false);
    CmoTracer::new(capture, TraceOptions::default().params())
}

/// A centre in front of the mirror points in view: the mean of the first reflected rays'
/// origins, moved along their mean direction by a twentieth of the reflectors' largest side (a
/// flat mirror's points lie on its plane). `None` where the directions mostly cancel out (their
/// mean is shorter than a quarter: rays that leave every way, as off a convex mirror, whose axis
/// centre already lies inside it) or the point lies nearer to any surface than a fifth of the
/// step (a centre on a surface is refused as beyond f32 precision).
fn near_centre(world: &WorldGeometry, rays: &[Ray]) -> Option<Vec3> {
    if rays.is_empty() {
        return None;
    }
    let n = rays.len() as f64;
    let mean = |f: &dyn Fn(&Ray) -> Vec3| {
        (rays.iter().map(|r| f(r).as_dvec3()).sum::<glam::DVec3>() / n).as_vec3()
    };
    let origin = mean(&|r| r.origin);
    let dir = mean(&|r| r.dir);
    if dir.length() < 0.25 {
        return None;
    }
    let (lo, hi) = world.bounds(|o| o.reflector);
    let step = 0.05 * (hi - lo).max_element();
    let centre = origin + dir.normalize() * step;
    let clear =
        (world.nearest_triangle(centre, |_| true)).is_none_or(|(d, _)| d >= 0.2 * f64::from(step));
    (step > 0.0 && centre.is_finite() && clear).then_some(centre)
}

/// The world's tracer and one over the triangles a capture can show (`None` where that is all
/// of them), built together ([`Tracer::split`]): the objects left out of the capture
/// (reflectors without self-reflections) pass every ray on, so a BVH without them gives the
/// capture the same hits ([`Tracer::keeping`]), sooner.
fn tracers(world: WorldGeometry) -> (Tracer, Option<Tracer>) {
    let shown = world.captured_triangles();
    Tracer::split(world, |g| shown[g as usize])
}

/// The greedy steps: the chosen candidates (indices into `cmos`) and the sampled unresolved
/// share after each, as `share_of(chosen, open)` gives it (the frame criterion's, [`Judge`];
/// `open`: the rays the centre criterion's score leaves). `cut`: whether a step stops counting
/// a candidate known to lose ([`best_step`]); the same steps either way.
fn greedy(
    scorer: &Scorer,
    cmos: &[CmoTracer],
    count: u32,
    target: f64,
    cut: bool,
    share_of: &mut dyn FnMut(&[usize], &[usize]) -> f64,
) -> (Vec<usize>, Vec<f64>) {
    let n = scorer.rays.len();
    let mut open: Vec<usize> = (0..n).collect();
    let mut chosen: Vec<usize> = Vec::new();
    let mut unresolved: Vec<f64> = Vec::new();
    while chosen.len() < count.max(1) as usize && !open.is_empty() {
        let Some((k, left)) = best_step(scorer, cmos, &chosen, &open, cut) else {
            break;
        };
        if left.len() >= open.len() && !chosen.is_empty() {
            break;
        }
        chosen.push(k);
        open = left;
        let share = share_of(&chosen, &open);
        unresolved.push(share);
        if share <= target || open.len() as f64 <= target * n as f64 {
            break;
        }
    }
    (chosen, unresolved)
}

/// One greedy step: the candidate (an index into `cmos`, not in `chosen`) whose set after
/// `chosen` leaves the fewest of the `open` rays unresolved, the first in candidate order on
/// ties, and the rays it leaves; `None` when every candidate is chosen.
///
/// A candidate stops counting as soon as it is known to lose: once its count so far, with its
/// index, passes the least (count, index) that a candidate has finished with (a count only
/// grows, so its own would too). The winner never stops, so the step picks what counting every
/// ray of every candidate picks, whatever the order the threads finish in. Without `cut` every
/// candidate counts every ray.
fn best_step(
    scorer: &Scorer,
    cmos: &[CmoTracer],
    chosen: &[usize],
    open: &[usize],
    cut: bool,
) -> Option<(usize, Vec<usize>)> {
    let key = |count: usize, k: usize| ((count as u64) << 32) | k as u64;
    let best = AtomicU64::new(u64::MAX);
    let mut left: Vec<Option<Vec<usize>>> = (0..cmos.len())
        .into_par_iter()
        .map(|k| {
            if chosen.contains(&k) {
                return None;
            }
            let set: Vec<&CmoTracer> = chosen.iter().chain([&k]).map(|&i| &cmos[i]).collect();
            let mut left = Vec::new();
            for &i in open {
                if scorer.unresolved(&set, &scorer.rays[i]) {
                    left.push(i);
                    if cut && key(left.len(), k) > best.load(Ordering::Relaxed) {
                        return None;
                    }
                }
            }
            best.fetch_min(key(left.len(), k), Ordering::Relaxed);
            Some(left)
        })
        .collect();
    let k = (best.into_inner() & u64::from(u32::MAX)) as usize;
    Some((k, left.get_mut(k)?.take()?))
}

/// How the CMO centres are chosen when the command line overrides the scene's
/// (`render --placement`, the bench's placement axis).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PlacementChoice {
    /// The placement search (the default of a scene without `[cmo]` centres).
    Auto,
    /// Spread along the reflectors' longest axis.
    Axis,
}

/// Overrides `scene`'s CMO placement with `choice` and `cmos` (`--placement`, `--cmos N`):
/// `Auto` searches for up to `cmos` CMOs (else the scene's count, else
/// [`DEFAULT_SEARCH_CMOS`]); `Axis` spreads `cmos` (else the count of an axis placement the
/// scene gives, else 1) along the reflectors' axis; no choice with `cmos` is the axis placement
/// of that many; neither leaves the scene's own.
pub fn override_placement(scene: &mut Scene, choice: Option<PlacementChoice>, cmos: Option<u32>) {
    let p = &mut scene.cmo.placement;
    *p = match (choice, cmos, &*p) {
        (Some(PlacementChoice::Auto), Some(n), _) => CmoPlacement::Search { count: n },
        (
            Some(PlacementChoice::Auto),
            None,
            CmoPlacement::Auto { count } | CmoPlacement::Search { count },
        ) => CmoPlacement::Search { count: *count },
        (Some(PlacementChoice::Auto), None, CmoPlacement::Explicit(_)) => CmoPlacement::Search {
            count: DEFAULT_SEARCH_CMOS,
        },
        (Some(PlacementChoice::Axis) | None, Some(n), _) => CmoPlacement::Auto { count: n },
        (Some(PlacementChoice::Axis), None, CmoPlacement::Auto { count }) => {
            CmoPlacement::Auto { count: *count }
        }
        (Some(PlacementChoice::Axis), None, _) => CmoPlacement::Auto { count: 1 },
        (None, None, _) => return,
    };
}

/// Runs the search of [`CmoPlacement::Search`] once for `camera`; see [`resolve_for`].
pub fn resolve(
    scene: &mut Scene,
    camera: &Camera,
    bounces: u32,
    scoring: Scoring,
) -> Option<Placement> {
    resolve_for(scene, std::slice::from_ref(camera), bounces, scoring)
}

/// Runs the search of [`CmoPlacement::Search`] once for the rays of `cameras` (a sequence's
/// cameras share one placement) and keeps its centres as the scene's
/// ([`CmoPlacement::Explicit`]), so that later [`Scene::cmo_centres`] calls (ranges, renderer,
/// metrics) read them; `None` (and the scene unchanged) for other placements. The count is
/// capped by [`cmo_budget`] at the scene's face size. `bounces`: the render's reflections per
/// path, whose later reflections the sample follows ([`PlacementOptions::bounces`]; 1 for the
/// first reflected rays alone); `scoring`: the frame's criterion, which judges the sample
/// ([`PlacementOptions::scoring`]). A scene far from the origin is searched in coordinates
/// relative to its anchor ([`crate::ranges::anchor`]), as the frame is traced.
pub fn resolve_for(
    scene: &mut Scene,
    cameras: &[Camera],
    bounces: u32,
    scoring: Scoring,
) -> Option<Placement> {
    let CmoPlacement::Search { count } = scene.cmo.placement else {
        return None;
    };
    let start = Instant::now();
    let count = cmo_budget(count, scene.cmo.resolution);
    let opts = PlacementOptions {
        bounces,
        scoring,
        ..PlacementOptions::default()
    };
    // Self-reflections left to `auto` and captured: the search first tries the reflectors left
    // out of the capture (the reflector check traces the rays that meet them exactly, so the
    // image is the same), and keeps that where it meets the target or leaves fewer rays
    // unresolved than the capture with them.
    let p = if scene.self_reflections == SelfReflections::Auto && scene.captures_reflectors() {
        // Searched in place, the setting put back after (no copy of the scene's meshes and
        // textures).
        scene.self_reflections = SelfReflections::Off;
        let mut q = search_anchored(scene, cameras, count, &opts);
        scene.self_reflections = SelfReflections::Auto;
        // Left out only on the sample's evidence: with no mirror pixel in view, as the scene says.
        q.self_capture_off = q.rays > 0;
        if q.share() <= opts.target {
            q
        } else {
            let p = search_anchored(scene, cameras, count, &opts);
            log::info!(
                "cmo placement: reflectors captured: {:.2}% of the sample unresolved with {} \
                 CMOs; left out: {:.2}% with {}",
                100.0 * p.share(),
                p.centres.len(),
                100.0 * q.share(),
                q.centres.len()
            );
            if (q.share(), q.centres.len()) <= (p.share(), p.centres.len()) {
                q
            } else {
                p
            }
        }
    } else {
        search_anchored(scene, cameras, count, &opts)
    };
    let p = Placement {
        time: start.elapsed(),
        ..p
    };
    if p.self_capture_off {
        scene.self_reflections = SelfReflections::Off;
    }
    scene.cmo.placement = CmoPlacement::Explicit(p.centres.clone());
    scene.cmo.lists = p.list_size;
    Some(p)
}

/// [`search`] in coordinates relative to the scene's anchor, the centres moved back.
fn search_anchored(
    scene: &Scene,
    cameras: &[Camera],
    count: u32,
    opts: &PlacementOptions,
) -> Placement {
    // The world flattened once: for the anchor, and for the search where it is zero.
    let world = scene.world();
    let anchor = crate::ranges::anchor_of(&world);
    if anchor == Vec3::ZERO {
        return search_by(scene, world, cameras, count, opts, true);
    }
    let local = scene.rebased(anchor);
    let cams: Vec<Camera> = cameras.iter().map(|c| c.rebased(anchor)).collect();
    let mut p = search(&local, &cams, count, opts);
    let a = anchor.as_dvec3();
    for c in &mut p.centres {
        *c = (c.as_dvec3() + a).as_vec3();
    }
    p
}

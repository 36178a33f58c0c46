//! Lockstep replay of per-ray work in warps, in two modes.
//!
//! # How it works
//! [`record`] runs the CPU twins on a frame's rays ([`super::work`]); [`replay`] groups them
//! into warps ([`super::warps`]) and runs each warp in lockstep over the shader's loop nest:
//! - a loop turns until its last lane leaves; each turn runs the body's blocks in order;
//! - [`Mode::Gpu`]: a block issues when at least one lane of the warp needs it (as often as the
//!   lane that needs it most), a loop no lane enters is skipped;
//! - [`Mode::Lavapipe`]: every block of a loop body issues on every turn any lane makes, and
//!   every loop body runs at least once (lavapipe runs the body of each `if` for all lanes,
//!   masked, and a loop until its last lane leaves).
//!
//! Each issue counts one warp-step of its block, its active lanes (the lanes that need it),
//! `width` issued lanes, and per load of the block (the i-th load of each active lane is one
//! warp load) the distinct 32-byte sectors the active lanes read.
//!
//! compute_trace has its own replay (`replay_compute`): its hot loop is subgroup-synchronous
//! (every busy ray takes one step per turn; the loop is left for `settle` when any ray has it
//! due), and a ray spans `lanes` lanes: `min(width, 32)` in the thesis layout (`main`: 32 / lanes
//! rounds of lane tests per node visit, every lane of a ray running the per-ray blocks
//! redundantly, all counted active), 1 in `main_lanes1` (one lane tests the children that
//! `children_crossed` leaves, one per round, the rounds running until the last lane's run out)
//! and 1 in `main_wave`, the GPU default (the crossed children of all the warp's rays in
//! ceil(sum / width) rounds of one item per lane: `wave_tests`).
//!
//! # What it assumes
//! The warps of [`super::warps`]; the work of [`super::work`] (its assumptions); a block's cost
//! is the same on every issue (its weight, `model::weights`); a warp runs alone (no scheduling,
//! no latency hiding, no caches: sectors are transactions requested, not misses).
//!
//! # Where it stops
//! - Only one setting of each method (the centre criterion, pyramid, verified hits; not the
//!   bounded criterion, the default).
//! - The retrace of `main_lanes1` (rays cut by lavapipe's loop limit) is not modelled: the
//!   twins never cut a ray.
//! - Divergence inside a block (an `if` within a callee) is folded into the block's weight.
//! - compute's grid-stride batches are one warp each; the `subgroupAny` checks and the outer
//!   loop's own instructions are not blocks.
#![forbid(unsafe_code)]

use serde::Serialize;

use super::blocks::Stmt;
use super::frame::Frame;
pub use super::frame::{ComputeLanes, ModelSettings, TexelLayout};
pub use super::methods::compute::lavapipe_compute_group;
use super::methods::model;
use super::rays::{ComputeRay, Iter};
pub use super::rays::{FrameWork, Recorded};
use super::warps::{Assembly, Items, Lane, WIDTHS};
use super::work;
use crate::method::Method;
use crate::scene::Scene;

/// How a warp issues a block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// A block issues when at least one lane of the warp needs it; a loop runs until its last
    /// lane leaves, and not at all when no lane enters it.
    Gpu,
    /// Lavapipe: every block of a loop body runs on every turn that any lane makes (masked),
    /// and a loop's body runs at least once.
    Lavapipe,
}

/// The replay's outputs for one method, scene, width and mode.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplayStats {
    pub method: Method,
    pub width: u32,
    pub mode: Mode,
    pub rays: usize,
    /// Issued warp-steps per ray, per block (index = position in `work::blocks(method)`).
    pub steps_per_ray: Vec<f64>,
    /// Active lanes over issued lanes, over all issued blocks.
    pub simd_efficiency: f64,
    /// Per block (as `steps_per_ray`): its active lanes over its issued lanes (0 where it never
    /// issued). Where it is low, the block's lanes mostly wait for the few that need it.
    pub block_efficiency: Vec<f64>,
    /// Distinct 32-byte sectors per warp load, summed, per ray.
    pub sectors_per_ray: f64,
    /// Per lavapipe work item ([`lavapipe_items`], in the order its threads take them): the
    /// issued warp-steps of each block. What [`super::validate::imbalance`] schedules.
    #[serde(skip)]
    pub item_steps: Vec<Vec<u64>>,
}

/// Runs the CPU twins of `method` on `scene`'s rays under `settings` and replays them in warps
/// of `width` lanes in `mode`.
pub fn model_frame(
    scene: &Scene,
    method: Method,
    settings: &ModelSettings,
    width: u32,
    mode: Mode,
) -> anyhow::Result<ReplayStats> {
    let frame = work::frame(scene, settings)?;
    let rec = record(&frame, method)?;
    replay(&rec, width, mode, default_assembly(method))
}

/// The warp assembly a GPU uses for `method` (module docs of [`super::warps`]; the method's
/// model, [`super::methods`]).
pub fn default_assembly(method: Method) -> Assembly {
    model(method).map_or(Assembly::Queue, |m| m.assembly)
}

/// How lavapipe hands `method`'s tracing pass to its threads ([`Items`]) at subgroup size
/// `width`, `lanes` lanes per ray: compute's workgroups of `lavapipe_compute_group / lanes` rays,
/// bvh's of 64 rays, reflection-point's of 64 scene vertices (their `@workgroup_size`), the
/// full-screen fragment passes' 64x64 bins.
pub fn lavapipe_items(method: Method, width: u32, lanes: u32) -> Items {
    model(method).map_or(Items::Groups(64), |m| (m.lavapipe_items)(width, lanes))
}

/// Runs `method`'s CPU twin on every ray of `frame` and keeps its work.
pub fn record(frame: &Frame, method: Method) -> anyhow::Result<Recorded> {
    match model(method) {
        Some(m) => (m.record)(frame),
        None => anyhow::bail!(
            "model: --method {} has no model (it traces nothing per ray)",
            method.name()
        ),
    }
}

/// Sums over the issues of a replay.
#[derive(Clone, Debug, Default)]
struct Acc {
    steps: Vec<u64>,
    active: u64,
    issued: u64,
    /// Per block (as `steps`): active and issued lanes.
    block_lanes: Vec<(u64, u64)>,
    sectors: u64,
    /// Per work item: the warp-steps of each block its warps issued.
    items: Vec<Vec<u64>>,
    /// The work item of the warp being replayed.
    item: usize,
}

impl Acc {
    /// One issue of `block` with `active` lanes, and its loads (per lane, in program order).
    fn issue(&mut self, block: usize, width: u32, active: u64, loads: &[&[u64]]) {
        self.steps[block] += 1;
        if self.items.len() <= self.item {
            self.items.resize(self.item + 1, vec![0; self.steps.len()]);
        }
        self.items[self.item][block] += 1;
        self.active += active;
        self.issued += width as u64;
        self.block_lanes[block].0 += active;
        self.block_lanes[block].1 += width as u64;
        self.sectors += sectors(loads);
    }

    /// [`Acc::issue`] where lavapipe runs the block or a lane needs it (`active` > 0).
    fn issue_if(
        &mut self,
        lavapipe: bool,
        block: usize,
        width: u32,
        active: u64,
        loads: &[&[u64]],
    ) {
        if lavapipe || active > 0 {
            self.issue(block, width, active, loads);
        }
    }
}

/// Distinct 32-byte sectors of each warp load (the i-th load of every lane), summed.
fn sectors(loads: &[&[u64]]) -> u64 {
    let most = loads.iter().map(|l| l.len()).max().unwrap_or(0);
    let mut total = 0;
    let mut s: Vec<u64> = Vec::with_capacity(loads.len());
    for i in 0..most {
        s.clear();
        s.extend(loads.iter().filter_map(|l| l.get(i)).map(|a| a >> 5));
        s.sort_unstable();
        s.dedup();
        total += s.len() as u64;
    }
    total
}

/// Replays `rec` in warps of `width` lanes in `mode`, assembled by `assembly`.
pub fn replay(
    rec: &Recorded,
    width: u32,
    mode: Mode,
    assembly: Assembly,
) -> anyhow::Result<ReplayStats> {
    if !WIDTHS.contains(&width) {
        anyhow::bail!("model: warp width {width} is not one of {WIDTHS:?}");
    }
    let nblocks = work::blocks(rec.method).len();
    let mut acc = Acc {
        steps: vec![0; nblocks],
        block_lanes: vec![(0, 0); nblocks],
        ..Acc::default()
    };
    let rays = rec.rays();
    match &rec.work {
        FrameWork::Compute(work) => {
            let layout = compute_layout(rec.settings.compute_lanes, mode);
            let lanes = compute_lanes(rec.settings.compute_lanes, width, mode);
            let slots = width / lanes;
            let items = lavapipe_items(rec.method, width, lanes);
            let item_of =
                super::warps::warp_items(assembly, rays, rec.img, &rec.ray_at, slots, items);
            let warps = super::warps::warps(assembly, rays, rec.img, &rec.ray_at, slots);
            for (warp, item) in warps.into_iter().zip(item_of) {
                acc.item = item;
                let slot: Vec<Option<&ComputeRay>> = warp
                    .iter()
                    .map(|l| {
                        if let Lane::Ray(i) = l {
                            Some(&work[*i])
                        } else {
                            None
                        }
                    })
                    .collect();
                let wave = layout == ComputeLanes::Wave;
                replay_compute(&slot, lanes, wave, width, mode, &mut acc);
            }
        }
        FrameWork::Tree {
            program,
            rays: work,
            idle,
        } => {
            let items = lavapipe_items(rec.method, width, 1);
            let item_of =
                super::warps::warp_items(assembly, rays, rec.img, &rec.ray_at, width, items);
            let warps = super::warps::warps(assembly, rays, rec.img, &rec.ray_at, width);
            for (warp, item) in warps.into_iter().zip(item_of) {
                acc.item = item;
                let lanes: Vec<Option<&Iter>> = warp
                    .iter()
                    .map(|l| match l {
                        Lane::Ray(i) => Some(&work[*i]),
                        Lane::Idle => Some(idle),
                        Lane::Helper | Lane::Empty => None,
                    })
                    .collect();
                replay_body(program, &lanes, width, mode, &mut acc);
            }
        }
    }
    let per = |x: u64| {
        if rays == 0 {
            0.0
        } else {
            x as f64 / rays as f64
        }
    };
    Ok(ReplayStats {
        method: rec.method,
        width,
        mode,
        rays,
        steps_per_ray: acc.steps.iter().map(|&s| per(s)).collect(),
        simd_efficiency: if acc.issued == 0 {
            0.0
        } else {
            acc.active as f64 / acc.issued as f64
        },
        block_efficiency: (acc.block_lanes.iter())
            .map(|&(active, issued)| {
                if issued == 0 {
                    0.0
                } else {
                    active as f64 / issued as f64
                }
            })
            .collect(),
        sectors_per_ray: per(acc.sectors),
        item_steps: acc.items,
    })
}

/// The layout compute_trace runs in `mode`: `lanes`, `Auto` resolved as `ray_lanes` does (one
/// lane per ray on lavapipe, the wave layout on a GPU).
pub fn compute_layout(lanes: ComputeLanes, mode: Mode) -> ComputeLanes {
    match (lanes, mode) {
        (ComputeLanes::Auto, Mode::Lavapipe) => ComputeLanes::One,
        (ComputeLanes::Auto, Mode::Gpu) => ComputeLanes::Wave,
        (l, _) => l,
    }
}

/// Lanes per ray of compute_trace at `width` (module docs).
pub fn compute_lanes(lanes: ComputeLanes, width: u32, mode: Mode) -> u32 {
    match compute_layout(lanes, mode) {
        ComputeLanes::Thesis => width.min(32),
        _ => 1,
    }
}

/// Lockstep over one body of a static loop nest; `lanes[i]`: lane i's turn (None: the lane does
/// not run this turn).
fn replay_body(prog: &[Stmt], lanes: &[Option<&Iter>], width: u32, mode: Mode, acc: &mut Acc) {
    for stmt in prog {
        match *stmt {
            Stmt::Block(b) => {
                let execs: Vec<Vec<&work::Exec>> = lanes
                    .iter()
                    .map(|l| {
                        l.map_or(Vec::new(), |it| {
                            it.execs.iter().filter(|e| e.block == b).collect()
                        })
                    })
                    .collect();
                let most = execs.iter().map(Vec::len).max().unwrap_or(0);
                let issues = if mode == Mode::Lavapipe {
                    most.max(1)
                } else {
                    most
                };
                for r in 0..issues {
                    let loads: Vec<&[u64]> = execs
                        .iter()
                        .filter_map(|e| e.get(r))
                        .map(|e| e.loads.as_slice())
                        .collect();
                    acc.issue(b, width, loads.len() as u64, &loads);
                }
            }
            Stmt::Loop(id, body) => {
                let runs: Vec<Option<&work::Run>> =
                    lanes.iter().map(|l| l.and_then(|it| it.run(id))).collect();
                let most = runs
                    .iter()
                    .flatten()
                    .map(|r| r.iters.len())
                    .max()
                    .unwrap_or(0);
                let turns = if mode == Mode::Lavapipe {
                    most.max(1)
                } else {
                    most
                };
                for t in 0..turns {
                    let sub: Vec<Option<&Iter>> = runs
                        .iter()
                        .map(|r| r.and_then(|r| r.iters.get(t)))
                        .collect();
                    replay_body(body, &sub, width, mode, acc);
                }
            }
        }
    }
}

/// One compute_trace subgroup: `slot[s]` the ray on lanes `s * lanes ..` (module docs).
fn replay_compute(
    slot: &[Option<&ComputeRay>],
    lanes: u32,
    wave: bool,
    width: u32,
    mode: Mode,
    acc: &mut Acc,
) {
    use work::*;
    let lavapipe = mode == Mode::Lavapipe;
    let l = lanes as u64;
    let mut pos = vec![0usize; slot.len()];
    let phase = |s: usize, pos: &[usize]| slot[s].and_then(|r| r.phases.get(pos[s]));
    loop {
        // `if pending { settle }`.
        let pending: Vec<(usize, &Vec<SettleTurn>)> = (0..slot.len())
            .filter_map(|s| match phase(s, &pos) {
                Some(Phase::Settle(t)) => Some((s, t)),
                _ => None,
            })
            .collect();
        let most = pending.iter().map(|(_, t)| t.len()).max().unwrap_or(0);
        let turns = if lavapipe { most.max(1) } else { most };
        for t in 0..turns {
            let turn: Vec<&SettleTurn> = pending.iter().filter_map(|(_, ts)| ts.get(t)).collect();
            acc.issue_if(lavapipe, C_SETTLE, width, turn.len() as u64 * l, &[]);
            acc.issue_if(
                lavapipe,
                C_HANDOFF,
                width,
                turn.iter().filter(|x| x.handoff).count() as u64 * l,
                &[],
            );
            let v: Vec<&[u64]> = turn
                .iter()
                .filter(|x| !x.verify.is_empty())
                .map(|x| x.verify.as_slice())
                .collect();
            acc.issue_if(lavapipe, C_VERIFY, width, v.len() as u64 * l, &v);
            acc.issue_if(
                lavapipe,
                C_START_TRACE,
                width,
                turn.iter().filter(|x| x.start).count() as u64 * l,
                &[],
            );
            acc.issue_if(
                lavapipe,
                C_ENTER_FACE,
                width,
                turn.iter().filter(|x| x.enter).count() as u64 * l,
                &[],
            );
            acc.issue_if(
                lavapipe,
                C_FACES_CROSSED,
                width,
                turn.iter().filter(|x| x.faces).count() as u64 * l,
                &[],
            );
        }
        for (s, _) in &pending {
            pos[*s] += 1;
        }
        let busy = |pos: &[usize]| {
            (0..slot.len())
                .filter(|&s| matches!(phase(s, pos), Some(Phase::Step(_))))
                .count()
        };
        if busy(&pos) == 0 {
            break;
        }
        // The hot loop: per turn, a step per busy ray (with one lane per ray, its run of steps:
        // the first and the steps after it that test no node), until a ray has `settle` due.
        loop {
            let runs: Vec<Vec<&Step>> = (0..slot.len())
                .map(|s| {
                    let mut run = Vec::new();
                    let at = |k: usize| slot[s].and_then(|r| r.phases.get(pos[s] + k));
                    while let Some(Phase::Step(st)) = at(run.len()) {
                        if !run.is_empty() && (lanes > 1 || st.visit.is_some()) {
                            break;
                        }
                        run.push(st);
                    }
                    run
                })
                .collect();
            for (s, run) in runs.iter().enumerate() {
                pos[s] += run.len();
            }
            let runs: Vec<&[&Step]> = (runs.iter())
                .filter(|r| !r.is_empty())
                .map(Vec::as_slice)
                .collect();
            compute_step(&runs, lanes, wave, width, mode, acc);
            let due = (0..slot.len()).any(|s| matches!(phase(s, &pos), Some(Phase::Settle(_))));
            if due || busy(&pos) == 0 {
                break;
            }
        }
    }
    // The record: lane 0 of each ray, `hit_shade` for a hit.
    let hits = slot.iter().flatten().filter(|r| r.hit).count();
    if lavapipe || hits > 0 {
        acc.issue(C_SHADE, width, hits as u64, &[]);
    }
}

/// The wave layout's lane tests of one turn (`wave_tests`): uniform code, so every block issues
/// on every turn that reaches it. The item list is the testing lanes' crossed children in lane
/// order (`crossed`); round r takes items r * width .. r * width + width - 1, one per lane, and
/// runs `wave_item`, `lane_test` (on the lanes that hold an item) and `wave_collect`. `busy`:
/// the lanes with a ray (`wave_items` runs on them all).
fn wave_tests(crossed: &[Vec<u64>], busy: u64, width: u32, lavapipe: bool, acc: &mut Acc) {
    use work::*;
    acc.issue(C_WAVE_ITEMS, width, busy, &[]);
    let items: Vec<u64> = crossed.iter().flatten().copied().collect();
    let rounds = items.len().div_ceil(width as usize);
    // lavapipe runs a loop's body at least once (module docs).
    let rounds = if lavapipe { rounds.max(1) } else { rounds };
    for r in 0..rounds {
        let round: Vec<[u64; 1]> = (items.iter())
            .skip(r * width as usize)
            .take(width as usize)
            .map(|&a| [a])
            .collect();
        let refs: Vec<&[u64]> = round.iter().map(|a| a.as_slice()).collect();
        let n = refs.len() as u64;
        acc.issue(C_WAVE_ITEM, width, n, &[]);
        acc.issue_if(lavapipe, C_LANE_TEST, width, n, &refs);
        acc.issue(C_WAVE_COLLECT, width, n, &[]);
    }
}

/// One turn of compute_trace's hot loop over the busy rays' `runs` (each ray's steps this turn:
/// one, or with one lane per ray the steps after the first that test no node).
fn compute_step(
    runs: &[&[&work::Step]],
    lanes: u32,
    wave: bool,
    width: u32,
    mode: Mode,
    acc: &mut Acc,
) {
    use work::*;
    let lavapipe = mode == Mode::Lavapipe;
    let l = lanes as u64;
    let steps: Vec<&Step> = runs.iter().map(|r| r[0]).collect();
    let testing: Vec<&Visit> = steps.iter().filter_map(|s| s.visit.as_ref()).collect();
    acc.issue_if(lavapipe, C_VISIT, width, testing.len() as u64 * l, &[]);
    if lanes == 1 {
        acc.issue_if(
            lavapipe,
            C_CHILDREN_CROSSED,
            width,
            testing.len() as u64,
            &[],
        );
        // Each testing lane's crossed children, in increasing j, by their loads.
        let crossed: Vec<Vec<u64>> = testing
            .iter()
            .map(|v| {
                v.loads
                    .iter()
                    .filter(|(j, _)| v.crossed >> j & 1 == 1)
                    .map(|&(_, a)| a)
                    .collect()
            })
            .collect();
        if wave {
            wave_tests(&crossed, steps.len() as u64, width, lavapipe, acc);
        }
        // Round c: each testing lane tests its c-th crossed child (none left to the wave
        // layout's own loop).
        let most = if wave {
            0
        } else {
            crossed.iter().map(Vec::len).max().unwrap_or(0)
        };
        let rounds = if lavapipe { most.max(1) } else { most };
        for c in 0..rounds {
            let loads: Vec<[u64; 1]> = crossed
                .iter()
                .filter_map(|x| x.get(c))
                .map(|&a| [a])
                .collect();
            let refs: Vec<&[u64]> = loads.iter().map(|a| a.as_slice()).collect();
            acc.issue_if(lavapipe, C_LANE_TEST, width, refs.len() as u64, &refs);
        }
    } else {
        // 32 / lanes uniform rounds; lane i of a ray tests child i + lanes * c.
        for c in 0..32 / lanes {
            let loads: Vec<[u64; 1]> = testing
                .iter()
                .flat_map(|v| {
                    v.loads
                        .iter()
                        .filter(|(j, _)| *j as u32 / lanes == c)
                        .map(|&(_, a)| [a])
                })
                .collect();
            let refs: Vec<&[u64]> = loads.iter().map(|a| a.as_slice()).collect();
            let active = if testing.is_empty() {
                0
            } else {
                refs.len() as u64
            };
            if lavapipe || !testing.is_empty() {
                acc.issue(C_LANE_TEST, width, active, &refs);
            }
        }
    }
    // The pick runs on every lane (uniform code), advance on the busy rays: once, or with one
    // lane per ray once per step of each ray's run, `pick_one` before it, the turns of the
    // longest run.
    acc.issue(C_PICK, width, steps.len() as u64 * l, &[]);
    let trips = runs.iter().map(|r| r.len()).max().unwrap_or(0);
    for t in 0..trips {
        let steps: Vec<&Step> = runs.iter().filter_map(|r| r.get(t).copied()).collect();
        if lanes == 1 {
            acc.issue(C_PICK_ONE, width, steps.len() as u64, &[]);
        }
        acc.issue(C_ADVANCE, width, steps.len() as u64 * l, &[]);
        let loads: Vec<[u64; 1]> = steps
            .iter()
            .filter_map(|s| s.classify)
            .map(|a| [a])
            .collect();
        let refs: Vec<&[u64]> = loads.iter().map(|a| a.as_slice()).collect();
        acc.issue_if(lavapipe, C_CLASSIFY, width, refs.len() as u64 * l, &refs);
        let deciding = steps.iter().filter(|s| s.decide).count() as u64;
        acc.issue_if(lavapipe, C_DECIDE, width, deciding * l, &[]);
    }
}

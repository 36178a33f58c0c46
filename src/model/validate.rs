//! Validation on lavapipe, the one driver measured: the lavapipe mode's prediction against
//! lavapipe's measured cost of the tracing pass, on rows the fit never saw.
//!
//! # The prediction
//! For a measured row (scene, method, cube size N, subgroup size S, the bench's frame), the model
//! replays the method's CPU twin in [`Mode::Lavapipe`] at width S ([`model_frame`]). Each issued
//! warp-step of a block costs, on lavapipe, two kinds of work (spirv/README.md, "What lavapipe
//! does"; the mechanism below):
//! - its vector instructions (the block's SPIR-V count less its lane operations,
//!   [`weights::weights`] - [`weights::lane_weights`]), each one instruction per 256-bit register
//!   the S lanes fill: [`registers`]`(S) = max(1, S / 8)`;
//! - its lane operations ([`weights::lane_weights`]: storage and image accesses, per-lane array
//!   indices, subgroup operations), each run once per lane, masked lanes included: S.
//!
//! So a row's predicted pass time is `a x V + b x L` with `V = sum over blocks of warp-steps x
//! vector instructions x registers(S)` and `L = sum of warp-steps x lane operations x S`
//! ([`Modelled::vector_per_ray`], [`Modelled::lane_per_ray`], per model ray), `a` the ns per
//! vector instruction and `b` the ns per lane operation; divided by the bench's ray count it is
//! the predicted ns per ray the bench reports (the two ray counts differ for `reflection-point`,
//! whose search runs per scene vertex).
//!
//! # The mechanism (why this form)
//! gallivm compiles a subgroup of S lanes into vectors of S x 32 bits. On the AVX2 machine
//! measured (an AMD EPYC of family 23 model 49, Zen 2: 256-bit data paths), an 8-lane vector
//! instruction is one instruction; 16 lanes are legalised into two 256-bit halves; at S = 4
//! (`LP_NATIVE_VECTOR_WIDTH=128`) gallivm hides AVX and emits SSE, one instruction per op again,
//! for half the lanes. So a vector instruction costs `registers(S)` per warp-step: the same per
//! ray at 8 and 16 lanes, twice at 4. Per-lane accesses are loops over the S lanes (an extract,
//! a bounds and mask check, a scalar load or store, an insert), so they cost S per warp-step:
//! the same per issued lane at every S. A fixed time per warp-step (the earlier model) instead
//! predicts half the cost per ray at 16 lanes and twice at 4, which the measurements refute.
//!
//! # The threads
//! lavapipe runs a pass on one thread per CPU ([`Measured::threads`], the bench's
//! `driver_threads`), each taking the next work item when it is free: a compute dispatch's
//! workgroups in dispatch order, a fragment pass's 64x64 rasteriser bins row-major
//! ([`super::warps::Items`]; compute's 256 rays per workgroup, 128 at 4 lanes, bvh's and
//! reflection-point's 64, fragment's and ssr's bins). The replay charges each warp's issued
//! blocks to its item ([`ReplayStats::item_steps`](super::replay::ReplayStats)); with the
//! items' SPIR-V-weighted costs the greedy schedule's makespan over `threads` is [`imbalance`]
//! times the evenly divided work, and the prediction is multiplied by it. Nothing is fitted:
//! the item sizes are the shaders' `@workgroup_size` and llvmpipe's `TILE_SIZE`. It matters
//! where a pass has few items: a 192x120 frame has 6 bins, a reflection-point search ~7
//! workgroups; it is 1.00-1.18 on the built-in scenes.
//!
//! # Repeats
//! lavapipe's time of the same row varies more between processes (up to 1.7x measured) than
//! between the frames of one. A row measured in several processes
//! (`--model-from` with the row in several files) takes the median of their medians
//! ([`Measured::repeats`]); the report gives their spread.
//!
//! # The fit
//! `a` and `b` are fitted per method on that method's [`Training`] rows only (the standard rule:
//! scene `default`, every cube size and subgroup size measured), minimising the squared
//! relative error (the target is relative), with both kept >= 0 ([`fit`]). The rows at several
//! subgroup sizes are what separates `a` from `b`; where a method's training rows share one
//! subgroup size (a single `bench --model` run) the two cannot be told apart, and the fit falls
//! back to one scale on the SPIR-V-weighted cost (`b = a x registers(S) / S`: every instruction
//! priced alike, the earlier model). Every other row is held out, and its error is reported
//! ([`RowResult::error`]: predicted / measured - 1; the target is within +-25 %). Nothing is
//! fitted per scene, cube size or subgroup size, and the block weights are not fitted at all
//! (they are instruction counts). One global pair over every method is fitted too and its
//! held-out score reported beside ([`Validation::global`]). [`fit`] reads the training rows
//! alone, which tests/model/model_harness.rs checks by perturbing a held-out row.
//!
//! # A missed row
//! Where a held-out row misses the target, [`RowResult::miss`] names the block whose share of
//! the modelled time moved most from the same method's closest training row (the same subgroup
//! size and the nearest cube size; any subgroup size if none): the cost that the fitted pair converts differently from the training rows
//! is most likely that block's. Where no share moved by [`SHARE_SHIFT`] or more, it says so:
//! then no block is to blame, the time per step is (spills, scene-wide overhead or noise).
//!
//! # Where it stops
//! The model counts instructions, not their latency: texture fetches, atomics, register spills
//! (more likely at 16 lanes, where every value fills two of AVX2's 16 registers) and the fixed
//! cost per dispatch or draw are folded into the two coefficients. Within a work item, time is
//! taken as proportional to issued work; the threads share nothing (no contention for caches or
//! memory bandwidth is modelled).
#![forbid(unsafe_code)]

use anyhow::{Result, bail, ensure};
use serde::Serialize;

use super::dynamic::{Counting, weights_by};
use super::replay::{ComputeLanes, Mode, ModelSettings, ReplayStats, model_frame};
use super::{weights, work};
use crate::method::Method;

/// A block's share of the modelled cost must move this much from the training row's before a
/// miss is blamed on it.
pub const SHARE_SHIFT: f64 = 0.05;

/// The +-share the issue targets.
pub const TARGET: f64 = 0.25;

/// The vector register width of the machine measured (AVX2), in 32-bit lanes.
pub const REGISTER_LANES: u32 = 8;

/// Vector instructions one SPIR-V vector op takes at `subgroup` lanes on lavapipe: one per
/// 256-bit register the lanes fill, at least one (a 4-lane subgroup runs 128-bit SSE code, one
/// instruction per op on a core with 256-bit data paths).
pub fn registers(subgroup: u32) -> u32 {
    subgroup.div_ceil(REGISTER_LANES).max(1)
}

/// The fitted cost of the two kinds of work.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Coefficients {
    /// ns per vector instruction (per 256-bit register).
    pub vector_ns: f64,
    /// ns per lane operation per lane.
    pub lane_ns: f64,
    /// Whether the training rows spanned one subgroup size only, so that the fit fell back to
    /// one scale on the SPIR-V-weighted cost (module docs).
    pub one_width: bool,
}

impl Coefficients {
    /// Predicted ns of the work of `r` (the whole pass, its threads' [`imbalance`] included).
    pub fn time(&self, r: &Modelled) -> f64 {
        (self.vector_ns * r.vector_per_ray + self.lane_ns * r.lane_per_ray)
            * r.model_rays as f64
            * r.imbalance
    }

    pub fn describe(&self) -> String {
        if self.one_width {
            format!(
                "{:.3} ns per vector instruction, lane operations priced alike (one width)",
                self.vector_ns
            )
        } else {
            format!(
                "{:.3} ns per vector instruction + {:.3} ns per lane operation",
                self.vector_ns, self.lane_ns
            )
        }
    }
}

/// One measured row: the tracing pass of a method's default setting on lavapipe.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Measured {
    /// The scene as loaded: a built-in's name or a scene file's path.
    pub scene: String,
    pub method: Method,
    pub cube: u32,
    /// Lavapipe's subgroup size in this run (its SIMD width: 4, 8 or 16).
    pub subgroup: u32,
    pub width: u32,
    pub height: u32,
    /// Rays the bench divided by (its `rays`).
    pub rays: usize,
    /// The tracing pass's GPU time, ns: the median over [`Measured::repeats`].
    pub pass_ns: f64,
    /// Each process's median time of the pass, ns, where the row was measured in several
    /// processes (`--model-from` with the same row in several files); one entry otherwise.
    /// Their spread is the run-to-run noise the prediction is held against.
    pub repeats: Vec<f64>,
    /// lavapipe's threads in the run: one per CPU of the machine (Mesa's default).
    pub threads: u32,
}

impl Measured {
    /// A key naming the row: `scene/method/cubeN/sgS`.
    pub fn key(&self) -> String {
        format!(
            "{}/{}/cube{}/sg{}",
            self.scene,
            self.method.name(),
            self.cube,
            self.subgroup
        )
    }

    pub fn ns_per_ray(&self) -> f64 {
        self.pass_ns / self.rays.max(1) as f64
    }

    /// The smallest and the largest of [`Measured::repeats`] (both `pass_ns` when there are
    /// none).
    pub fn range(&self) -> (f64, f64) {
        let lo = self.repeats.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self.repeats.iter().copied().fold(0.0, f64::max);
        if lo.is_finite() {
            (lo, hi)
        } else {
            (self.pass_ns, self.pass_ns)
        }
    }

    /// The largest over the smallest of [`Measured::repeats`] (1 for one run).
    pub fn spread(&self) -> f64 {
        let (lo, hi) = self.range();
        if lo > 0.0 { hi / lo } else { 1.0 }
    }
}

/// The median of `v` (the mean of the middle two for an even count; 0 for none).
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => 0.0,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// How much longer a pass takes on `threads` threads than its work divided evenly: lavapipe's
/// threads take the work items (costs `costs`, in order) each the next when free, and the pass
/// ends when the last finishes. Returns that makespan over `total / threads`: 1 for perfectly
/// divided work, up to `threads` for one item holding it all (1 for no work).
pub fn imbalance(costs: &[f64], threads: u32) -> f64 {
    let t = threads.max(1) as usize;
    let total: f64 = costs.iter().sum();
    if total <= 0.0 {
        return 1.0;
    }
    let mut finish = vec![0.0f64; t];
    for &c in costs {
        let next = (0..t)
            .min_by(|a, b| finish[*a].total_cmp(&finish[*b]))
            .expect("at least one thread");
        finish[next] += c;
    }
    let makespan = finish.iter().copied().fold(0.0, f64::max);
    makespan * t as f64 / total
}

/// Which rows the coefficients are fitted on: one scene, optionally one cube size and subgroup
/// size.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Training {
    pub scene: String,
    pub cube: Option<u32>,
    pub subgroup: Option<u32>,
}

impl Training {
    /// The default rule: scene `default`, every cube size and subgroup size (the subgroup
    /// sizes separate the two coefficients; several cube sizes keep one noisy row from setting
    /// them).
    pub fn standard() -> Training {
        Training {
            scene: "default".into(),
            cube: None,
            subgroup: None,
        }
    }

    /// Whether `m` is a training row. `bvh` reads no cube map, so its rows match any cube size.
    pub fn contains(&self, m: &Measured) -> bool {
        m.scene == self.scene
            && (!m.method.captures_cmos() || self.cube.is_none_or(|c| c == m.cube))
            && self.subgroup.is_none_or(|s| s == m.subgroup)
    }

    pub fn describe(&self) -> String {
        let mut s = format!("scene {}", self.scene);
        if let Some(c) = self.cube {
            s += &format!(", cube {c}");
        }
        if let Some(g) = self.subgroup {
            s += &format!(", subgroup {g}");
        }
        s
    }
}

/// A measured row with the model's replay of it.
#[derive(Clone, Debug, Serialize)]
pub struct Modelled {
    pub measured: Measured,
    pub train: bool,
    /// Weighted issued warp-steps per model ray (lavapipe mode, width = subgroup): SPIR-V
    /// instructions, every one alike.
    pub cost_per_ray: f64,
    /// Vector instructions per model ray: warp-steps x (instructions - lane operations) x
    /// [`registers`]`(subgroup)`.
    pub vector_per_ray: f64,
    /// Lane operations per model ray, per lane: warp-steps x lane operations x subgroup.
    pub lane_per_ray: f64,
    /// Per block: `vector_per_ray`'s and `lane_per_ray`'s parts.
    pub vector_blocks: Vec<f64>,
    pub lane_blocks: Vec<f64>,
    pub model_rays: usize,
    pub blocks: Vec<String>,
    pub shares: Vec<f64>,
    pub simd_efficiency: f64,
    /// [`imbalance`] of the pass's work items (their SPIR-V-weighted warp-steps) over the run's
    /// threads: the factor by which the pass outlasts its evenly divided work.
    pub imbalance: f64,
}

impl Modelled {
    /// Weighted warp-steps of the whole pass.
    pub fn work(&self) -> f64 {
        self.cost_per_ray * self.model_rays as f64
    }
}

/// Replays `m` in lavapipe mode at width `m.subgroup` ([`model_frame`]).
pub fn model_row(scene: &crate::scene::Scene, m: Measured, train: bool) -> Result<Modelled> {
    let settings = ModelSettings::new(m.cube, m.width, m.height);
    let stats = model_frame(scene, m.method, &settings, m.subgroup, Mode::Lavapipe)?;
    modelled(&stats, m, train)
}

/// `m` beside its lavapipe-mode replay `stats` (the method's, at width `m.subgroup`), weighted
/// by the static count.
pub fn modelled(stats: &ReplayStats, m: Measured, train: bool) -> Result<Modelled> {
    modelled_with(stats, m, train, Counting::Static)
}

/// [`modelled`] with the blocks weighted by `counting` (lavapipe runs compute's one-lane entry
/// point, `main_lanes1`).
pub fn modelled_with(
    stats: &ReplayStats,
    m: Measured,
    train: bool,
    counting: Counting,
) -> Result<Modelled> {
    ensure!(
        stats.method == m.method && stats.mode == Mode::Lavapipe && stats.width == m.subgroup,
        "model: the replay of {} is not lavapipe mode at width {}",
        m.key(),
        m.subgroup
    );
    // Lavapipe runs compute's one-lane layout (`vk::methods::compute::ray_lanes`).
    let (w, lane) = weights_by(m.method, counting, ComputeLanes::One)?;
    let stats = stats.clone();
    let (vector_blocks, lane_blocks) = split(&stats.steps_per_ray, &w, &lane, m.subgroup);
    let item_costs: Vec<f64> = stats
        .item_steps
        .iter()
        .map(|steps| steps.iter().zip(&w).map(|(s, w)| *s as f64 * w).sum())
        .collect();
    Ok(Modelled {
        imbalance: imbalance(&item_costs, m.threads),
        cost_per_ray: weights::cost(&stats, &w),
        vector_per_ray: vector_blocks.iter().sum(),
        lane_per_ray: lane_blocks.iter().sum(),
        vector_blocks,
        lane_blocks,
        model_rays: stats.rays,
        blocks: work::blocks(m.method)
            .iter()
            .map(|b| b.name.to_string())
            .collect(),
        shares: weights::shares(&stats, &w),
        simd_efficiency: stats.simd_efficiency,
        measured: m,
        train,
    })
}

/// Per block, the vector instructions and the lane operations (per lane) of `steps` warp-steps
/// per ray at `subgroup` lanes: `steps x (weight - lane) x registers(subgroup)` and `steps x lane
/// x subgroup`.
pub fn split(steps: &[f64], weights: &[f64], lane: &[f64], subgroup: u32) -> (Vec<f64>, Vec<f64>) {
    let regs = f64::from(registers(subgroup));
    let w = f64::from(subgroup);
    steps
        .iter()
        .zip(weights.iter().zip(lane))
        .map(|(s, (t, l))| (s * (t - l).max(0.0) * regs, s * l * w))
        .unzip()
}

/// The coefficients fitted on the training rows (and only those) of `method`, or of every
/// method: least squares on the relative error, both coefficients >= 0 (module docs).
pub fn fit(rows: &[Modelled], method: Option<Method>) -> Result<Coefficients> {
    let train: Vec<&Modelled> = rows
        .iter()
        .filter(|r| r.train && method.is_none_or(|m| m == r.measured.method))
        .filter(|r| r.cost_per_ray > 0.0 && r.measured.pass_ns > 0.0)
        .collect();
    if train.is_empty() {
        bail!(
            "model: no training row{} (with work and a measured time) to fit the coefficients on",
            method.map_or(String::new(), |m| format!(" of --method {}", m.name()))
        );
    }
    let n = |r: &Modelled| r.model_rays as f64 * r.imbalance / r.measured.pass_ns;
    let mut widths: Vec<u32> = train.iter().map(|r| r.measured.subgroup).collect();
    widths.dedup();
    if widths.iter().all(|w| *w == widths[0]) {
        // One width: vector and lane work are priced alike per instruction.
        let s = widths[0];
        let ratio = f64::from(registers(s)) / f64::from(s);
        let z: Vec<f64> = train
            .iter()
            .map(|r| (r.vector_per_ray + r.lane_per_ray * ratio) * n(r))
            .collect();
        let a = z.iter().sum::<f64>() / z.iter().map(|z| z * z).sum::<f64>();
        return Ok(Coefficients {
            vector_ns: a,
            lane_ns: a * ratio,
            one_width: true,
        });
    }
    let xy: Vec<(f64, f64)> = train
        .iter()
        .map(|r| (r.vector_per_ray * n(r), r.lane_per_ray * n(r)))
        .collect();
    let sse =
        |a: f64, b: f64| -> f64 { xy.iter().map(|(x, y)| (a * x + b * y - 1.0).powi(2)).sum() };
    let (sxx, sxy, syy) = xy.iter().fold((0.0, 0.0, 0.0), |(p, q, r), (x, y)| {
        (p + x * x, q + x * y, r + y * y)
    });
    let (sx, sy) = xy.iter().fold((0.0, 0.0), |(p, q), (x, y)| (p + x, q + y));
    let det = sxx * syy - sxy * sxy;
    let mut best: Option<(f64, f64)> = None;
    if det.abs() > 1e-12 * sxx * syy {
        let a = (sx * syy - sy * sxy) / det;
        let b = (sy * sxx - sx * sxy) / det;
        if a >= 0.0 && b >= 0.0 {
            best = Some((a, b));
        }
    }
    let (a, b) = best.unwrap_or_else(|| {
        // On the boundary: one of the two is 0.
        let only_a = if sxx > 0.0 {
            (sx / sxx, 0.0)
        } else {
            (0.0, 0.0)
        };
        let only_b = if syy > 0.0 {
            (0.0, sy / syy)
        } else {
            (0.0, 0.0)
        };
        if sse(only_a.0, only_a.1) <= sse(only_b.0, only_b.1) {
            only_a
        } else {
            only_b
        }
    });
    Ok(Coefficients {
        vector_ns: a,
        lane_ns: b,
        one_width: false,
    })
}

/// One row of the validation.
#[derive(Clone, Debug, Serialize)]
pub struct RowResult {
    pub key: String,
    pub scene: String,
    pub method: Method,
    pub cube: u32,
    pub subgroup: u32,
    pub train: bool,
    pub measured_ns_per_ray: f64,
    pub predicted_ns_per_ray: f64,
    /// predicted / measured - 1.
    pub error: f64,
    pub within_target: bool,
    pub simd_efficiency: f64,
    /// The processes the row was measured in, and the slowest over the fastest
    /// ([`Measured::spread`]).
    pub processes: usize,
    pub spread: f64,
    /// The fastest and the slowest process's ns per ray (both the measured one for one process).
    pub measured_range_ns_per_ray: (f64, f64),
    /// [`Modelled::imbalance`].
    pub imbalance: f64,
    /// For a held-out row that misses the target: the block the model most likely misses.
    pub miss: Option<String>,
}

/// The validation: the fitted scale and every row's error.
#[derive(Clone, Debug, Serialize)]
pub struct Validation {
    pub training: Training,
    pub training_rows: Vec<String>,
    /// The coefficients of each method, fitted on its training rows: what the rows'
    /// predictions use.
    pub coefficients: Vec<(Method, Coefficients)>,
    /// One pair for every method, fitted on all training rows, for comparison: the held-out
    /// rows within the target with it.
    pub global: Coefficients,
    pub global_held_out_within_target: usize,
    pub target: f64,
    pub held_out: usize,
    pub held_out_within_target: usize,
    /// Held-out rows missing the target whose prediction still lies between the fastest and the
    /// slowest of the row's processes (within its run-to-run noise).
    pub missed_within_range: usize,
    pub rows: Vec<RowResult>,
}

/// Fits on the training rows of `rows` and scores every row.
pub fn validate(rows: &[Modelled], training: &Training) -> Result<Validation> {
    for r in rows {
        ensure!(
            r.train == training.contains(&r.measured),
            "model: row {} is marked {} but the rule says otherwise",
            r.measured.key(),
            if r.train { "training" } else { "held out" }
        );
    }
    let mut coefficients: Vec<(Method, Coefficients)> = Vec::new();
    for r in rows {
        if !coefficients.iter().any(|(m, _)| *m == r.measured.method) {
            let m = r.measured.method;
            coefficients.push((m, fit(rows, Some(m))?));
        }
    }
    let coef_of = |m: Method| {
        coefficients
            .iter()
            .find(|(k, _)| *k == m)
            .map(|c| c.1)
            .expect("every method's coefficients are fitted above")
    };
    let results: Vec<RowResult> = rows
        .iter()
        .map(|r| score(r, rows, &coef_of(r.measured.method)))
        .collect();
    let held: Vec<&RowResult> = results.iter().filter(|r| !r.train).collect();
    let global = fit(rows, None)?;
    let global_within = rows
        .iter()
        .filter(|r| !r.train)
        .filter(|r| score(r, rows, &global).within_target)
        .count();
    Ok(Validation {
        training: training.clone(),
        training_rows: rows
            .iter()
            .filter(|r| r.train)
            .map(|r| r.measured.key())
            .collect(),
        coefficients,
        global,
        global_held_out_within_target: global_within,
        target: TARGET,
        held_out: held.len(),
        held_out_within_target: held.iter().filter(|r| r.within_target).count(),
        missed_within_range: held
            .iter()
            .filter(|r| {
                let (lo, hi) = r.measured_range_ns_per_ray;
                !r.within_target && (lo..=hi).contains(&r.predicted_ns_per_ray)
            })
            .count(),
        rows: results,
    })
}

fn score(r: &Modelled, rows: &[Modelled], c: &Coefficients) -> RowResult {
    let m = &r.measured;
    let predicted = c.time(r) / m.rays.max(1) as f64;
    let measured = m.ns_per_ray();
    let error = predicted / measured - 1.0;
    let within = error.abs() <= TARGET;
    let miss = (!within && !r.train).then(|| miss(r, rows, c, error));
    RowResult {
        key: m.key(),
        scene: m.scene.clone(),
        method: m.method,
        cube: m.cube,
        subgroup: m.subgroup,
        train: r.train,
        measured_ns_per_ray: measured,
        predicted_ns_per_ray: predicted,
        error,
        within_target: within,
        simd_efficiency: r.simd_efficiency,
        processes: m.repeats.len(),
        spread: m.spread(),
        measured_range_ns_per_ray: {
            let (lo, hi) = m.range();
            let per = |x: f64| x / m.rays.max(1) as f64;
            (per(lo), per(hi))
        },
        imbalance: r.imbalance,
        miss,
    }
}

/// Per block, its share of the modelled time of `r` under `c`.
pub fn time_shares(r: &Modelled, c: &Coefficients) -> Vec<f64> {
    let parts: Vec<f64> = r
        .vector_blocks
        .iter()
        .zip(&r.lane_blocks)
        .map(|(v, l)| c.vector_ns * v + c.lane_ns * l)
        .collect();
    let total = parts.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    parts.iter().map(|p| p / total).collect()
}

/// The block whose share of the modelled time moved most from the same method's closest
/// training row (the same subgroup size, then the nearest cube size).
fn miss(r: &Modelled, rows: &[Modelled], c: &Coefficients, error: f64) -> String {
    let dir = if error > 0.0 { "over" } else { "under" };
    let same = |t: &&Modelled| t.train && t.measured.method == r.measured.method;
    // The closest training row: the same subgroup and cube size, else the same subgroup, else
    // any; so the blame does not depend on the order of the rows.
    let closeness = |t: &&Modelled| {
        (
            t.measured.subgroup != r.measured.subgroup,
            t.measured.cube.abs_diff(r.measured.cube),
            t.measured.key(),
        )
    };
    let Some(t) = rows.iter().filter(same).min_by_key(closeness) else {
        return format!("{dir}-predicts; no training row of this method to compare blocks with");
    };
    let here = time_shares(r, c);
    let there = time_shares(t, c);
    let best = here
        .iter()
        .zip(&there)
        .enumerate()
        .max_by(|a, b| {
            let d = |(_, (x, y)): &(usize, (&f64, &f64))| (*x - *y).abs();
            d(a).total_cmp(&d(b))
        })
        .map(|(i, (x, y))| (i, *x, *y));
    match best {
        Some((_, here, train)) if (here - train).abs() < SHARE_SHIFT => format!(
            "{dir}-predicts; no block: every share is within {:.0} points of the training \
             row's ({}), so the time per step itself differs here (spills, scene-wide overhead \
             or noise), not one block",
            100.0 * SHARE_SHIFT,
            t.measured.key()
        ),
        Some((i, here, train)) => format!(
            "{dir}-predicts; block {}: {:.0} % of the modelled time here, {:.0} % on the \
             training row {}",
            r.blocks.get(i).map_or("?", String::as_str),
            100.0 * here,
            100.0 * train,
            t.measured.key()
        ),
        None => format!("{dir}-predicts; no blocks to compare"),
    }
}

//! Validation on the machine we have (issue 25, item 4): the lavapipe mode's prediction against
//! lavapipe's measured cost of the tracing pass, on rows the fit never saw.
//!
//! # The prediction
//! For a measured row (scene, method, cube size N, subgroup size S, the bench's frame), the model
//! replays the method's CPU twin in [`Mode::Lavapipe`] at width S ([`model_frame`]) and weighs the
//! issued warp-steps with the SPIR-V block weights ([`weights::cost`]). The predicted time of the
//! pass is `scale x cost per model ray x model rays`; divided by the bench's ray count it is the
//! predicted ns per ray the bench reports (the two ray counts differ for `reflection-point`, whose
//! search runs per scene vertex).
//!
//! # The fit
//! `scale` (ns per weighted warp-step) is one number per method, fitted on that method's
//! [`Training`] rows only (with the standard rule, ONE row: scene `default`, cube 256, subgroup
//! 8): the geometric mean of measured over modelled time, which minimises the squared log error.
//! Every other row is held out, and its error is reported ([`RowResult::error`]: predicted /
//! measured - 1; the target is within +-25 %). So a held-out row tests what the model says about
//! the scene, the cube size and the subgroup size; nothing is fitted per scene, cube size or
//! subgroup size, and the block weights are not fitted at all (they are instruction counts). One
//! global scale over every method is fitted too and its held-out score reported beside
//! ([`Validation::global_scale`]): on lavapipe it misses by method (fragment's rasteriser and
//! quads, the reflection-point search's dispatch), which the per-method scale absorbs.
//! [`fit_scale`] reads the training rows alone, which tests/model_harness.rs checks by
//! perturbing a held-out row.
//!
//! # A missed row
//! Where a held-out row misses the target, [`RowResult::miss`] names the block whose share of
//! the modelled cost moved most from the same method's training row: the cost that the one scale
//! converts differently from the training row is most likely that block's (its instructions cost
//! more or less per step than the mix the scale was fitted on). Where no share moved by
//! [`SHARE_SHIFT`] or more, it says so: then no block is to blame, the time per weighted step is.
//!
//! # Where it stops
//! The model counts instructions, not their latency: texture fetches (gathers in lavapipe),
//! atomics, and the fixed cost per dispatch or draw are folded into the one scale. Lavapipe's
//! threads (one per core) and its rasteriser's tiles are not modelled: time is taken as
//! proportional to issued work.
#![forbid(unsafe_code)]

use anyhow::{Result, bail, ensure};
use serde::Serialize;

use super::replay::{Mode, ModelSettings, ReplayStats, model_frame};
use super::{weights, work};
use crate::method::Method;

/// A block's share of the modelled cost must move this much from the training row's before a
/// miss is blamed on it.
pub const SHARE_SHIFT: f64 = 0.05;

/// The +-share the issue targets.
pub const TARGET: f64 = 0.25;

/// One measured row: the tracing pass of a method's default setting on lavapipe.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Measured {
    pub scene: String,
    pub method: Method,
    pub cube: u32,
    /// Lavapipe's subgroup size in this run (its SIMD width: 4, 8 or 16).
    pub subgroup: u32,
    pub width: u32,
    pub height: u32,
    /// Rays the bench divided by (its `rays`).
    pub rays: usize,
    /// The tracing pass's median GPU time, ns.
    pub pass_ns: f64,
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
}

/// Which rows the scale is fitted on: one scene, optionally one cube size and subgroup size.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Training {
    pub scene: String,
    pub cube: Option<u32>,
    pub subgroup: Option<u32>,
}

impl Training {
    /// The default rule: scene `default`, cube 256, subgroup 8 (lavapipe's default width).
    pub fn standard() -> Training {
        Training {
            scene: "default".into(),
            cube: Some(256),
            subgroup: Some(8),
        }
    }

    /// Whether `m` is a training row. `bvh` reads no cube map, so its rows match any cube size.
    pub fn contains(&self, m: &Measured) -> bool {
        m.scene == self.scene
            && (m.method == Method::Bvh || self.cube.is_none_or(|c| c == m.cube))
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
    /// Weighted issued warp-steps per model ray (lavapipe mode, width = subgroup).
    pub cost_per_ray: f64,
    pub model_rays: usize,
    pub blocks: Vec<String>,
    pub shares: Vec<f64>,
    pub simd_efficiency: f64,
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

/// `m` beside its lavapipe-mode replay `stats` (the method's, at width `m.subgroup`).
pub fn modelled(stats: &ReplayStats, m: Measured, train: bool) -> Result<Modelled> {
    ensure!(
        stats.method == m.method && stats.mode == Mode::Lavapipe && stats.width == m.subgroup,
        "model: the replay of {} is not lavapipe mode at width {}",
        m.key(),
        m.subgroup
    );
    let w = weights::weights(m.method)?;
    let stats = stats.clone();
    Ok(Modelled {
        cost_per_ray: weights::cost(&stats, &w),
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

/// ns per weighted warp-step: the geometric mean of measured over modelled time over the
/// training rows (and only those), of `method` or of every method.
pub fn fit_scale(rows: &[Modelled], method: Option<Method>) -> Result<f64> {
    let logs: Vec<f64> = rows
        .iter()
        .filter(|r| r.train && method.is_none_or(|m| m == r.measured.method))
        .filter(|r| r.work() > 0.0 && r.measured.pass_ns > 0.0)
        .map(|r| (r.measured.pass_ns / r.work()).ln())
        .collect();
    if logs.is_empty() {
        bail!(
            "model: no training row{} (with work and a measured time) to fit the scale on",
            method.map_or(String::new(), |m| format!(" of --method {}", m.name()))
        );
    }
    Ok((logs.iter().sum::<f64>() / logs.len() as f64).exp())
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
    /// For a held-out row that misses the target: the block the model most likely misses.
    pub miss: Option<String>,
}

/// The validation: the fitted scale and every row's error.
#[derive(Clone, Debug, Serialize)]
pub struct Validation {
    pub training: Training,
    pub training_rows: Vec<String>,
    /// The scale of each method (ns per weighted warp-step), fitted on its training row(s):
    /// what the rows' predictions use.
    pub scales: Vec<(Method, f64)>,
    /// One scale for every method, fitted on all training rows, for comparison: the held-out
    /// rows within the target with it.
    pub global_scale: f64,
    pub global_held_out_within_target: usize,
    pub target: f64,
    pub held_out: usize,
    pub held_out_within_target: usize,
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
    let mut scales: Vec<(Method, f64)> = Vec::new();
    for r in rows {
        if !scales.iter().any(|(m, _)| *m == r.measured.method) {
            let m = r.measured.method;
            scales.push((m, fit_scale(rows, Some(m))?));
        }
    }
    let scale_of = |m: Method| scales.iter().find(|(k, _)| *k == m).map_or(0.0, |s| s.1);
    let results: Vec<RowResult> = rows
        .iter()
        .map(|r| score(r, rows, scale_of(r.measured.method)))
        .collect();
    let held: Vec<&RowResult> = results.iter().filter(|r| !r.train).collect();
    let global_scale = fit_scale(rows, None)?;
    let global_within = rows
        .iter()
        .filter(|r| !r.train)
        .filter(|r| score(r, rows, global_scale).within_target)
        .count();
    Ok(Validation {
        training: training.clone(),
        training_rows: rows
            .iter()
            .filter(|r| r.train)
            .map(|r| r.measured.key())
            .collect(),
        scales,
        global_scale,
        global_held_out_within_target: global_within,
        target: TARGET,
        held_out: held.len(),
        held_out_within_target: held.iter().filter(|r| r.within_target).count(),
        rows: results,
    })
}

fn score(r: &Modelled, rows: &[Modelled], scale: f64) -> RowResult {
    let m = &r.measured;
    let predicted = scale * r.work() / m.rays.max(1) as f64;
    let measured = m.ns_per_ray();
    let error = predicted / measured - 1.0;
    let within = error.abs() <= TARGET;
    let miss = (!within && !r.train).then(|| miss(r, rows, error));
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
        miss,
    }
}

/// The block whose share of the cost moved most from the same method's training row.
fn miss(r: &Modelled, rows: &[Modelled], error: f64) -> String {
    let dir = if error > 0.0 { "over" } else { "under" };
    let Some(t) = rows
        .iter()
        .find(|t| t.train && t.measured.method == r.measured.method)
    else {
        return format!("{dir}-predicts; no training row of this method to compare blocks with");
    };
    let best = r
        .shares
        .iter()
        .zip(&t.shares)
        .enumerate()
        .max_by(|a, b| {
            let d = |(_, (x, y)): &(usize, (&f64, &f64))| (*x - *y).abs();
            d(a).total_cmp(&d(b))
        })
        .map(|(i, (x, y))| (i, *x, *y));
    match best {
        Some((_, here, train)) if (here - train).abs() < SHARE_SHIFT => format!(
            "{dir}-predicts; no block: every share is within {:.0} points of the training \
             row's, so the time per weighted warp-step itself differs here (subgroup size, \
             scene-wide overhead or noise), not one block",
            100.0 * SHARE_SHIFT
        ),
        Some((i, here, train)) => format!(
            "{dir}-predicts; block {}: {:.0} % of the modelled cost here, {:.0} % on the \
             training row",
            r.blocks.get(i).map_or("?", String::as_str),
            100.0 * here,
            100.0 * train
        ),
        None => format!("{dir}-predicts; no blocks to compare"),
    }
}

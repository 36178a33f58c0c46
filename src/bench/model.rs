#![forbid(unsafe_code)]
//! `cubetrace bench --model`: the SIMT cost model ([`crate::model`]) beside the measurements.
//!
//! Three parts, each labelled a model in every output:
//! - **lavapipe check** ([`crate::model::validate`]): every run of a method in the setting the
//!   model replays ([`MethodSpec::modelled`]: compute-centre, fragment-centre-mip, ssr,
//!   reflection-point, bvh) is replayed in lavapipe mode at
//!   the device's subgroup size; two coefficients per method (ns per vector instruction, ns
//!   per lane operation, [`crate::model::validate`]) are fitted on the training rows (scene
//!   `default`, every cube size and subgroup size present) and every other row gets its
//!   prediction error.
//! - **per-ray work** at width 32 ([`per_ray_table`]): every method beside bvh, weighted
//!   warp-steps per ray with static and dynamic weights ([`crate::model::dynamic::Counting`]),
//!   SIMD efficiency, 32-byte sectors per ray and the block holding most of the dynamic cost;
//!   the lavapipe check is run under both counts.
//! - **GPU predictions** at widths 32 and 64 (GPU mode: a block issues when one lane needs it),
//!   per scene: compute / fragment, compute / bvh, fragment / bvh (ratios of weighted warp-steps
//!   per ray, i.e. the same ns per weighted step on every method), SIMD efficiency and 32-byte
//!   sectors per ray.
//! - **the triangle axis** of `bench --scaling` ([`super::scaling::TRIANGLE_SEGMENTS`]): compute
//!   and fragment over bvh at width 32 as the extra sphere gets finer; where a cube-map tracer
//!   would overtake the BVH (ratio below 1), interpolated in log triangles, if it does.
//!
//! The output is keyed by method: rows of `method` (and `over`, `layout`) built from
//! [`METHODS`], [`Method::traces_cubemaps`] and [`Method::EXACT_GPU`] ([`tracers`],
//! [`gpu_pairs`]), so no method is named here and a new modelled method gets its rows.
//!
//! `--model-from A.json,B.json,...` reads earlier `bench.json` files instead of rendering (one
//! per lavapipe subgroup size, cube size and process: `benches/model-measure.sh` takes them; a
//! row in several files is one row measured in several processes, [`measured_from_files`]),
//! which is how `benches/results/lavapipe-model.*` was made (from the files in
//! `benches/results/model-rows-3/`).
//!
//! Assumptions (also in [`ASSUMPTIONS`], written with every report): the warp assembly and
//! texel layout of [`crate::model::replay`]; one ns per weighted warp-step for every method on
//! a GPU (no latency, no occupancy, no caches beyond the sector count); the bench's frame and
//! cube size.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde::Serialize;

use super::plot::{self, Point};
use super::scaling::{TRIANGLE_SEGMENTS, tessellated_scene};
use super::{BenchReport, Method, MethodSpec, prepare_scene_judged};
use crate::model::dynamic::{Counting, weights_by};
use crate::model::methods::layouts;
use crate::model::replay::{
    ComputeLanes, Mode, ModelSettings, Recorded, ReplayStats, default_assembly, record, replay,
};
use crate::model::validate::{self, Measured, Modelled, Training, Validation};
use crate::model::weights;
use crate::model::work::{self, Frame, blocks};
use crate::output::write_atomic;
use crate::placement::Scoring;

/// The methods the model replays, in table order ([`crate::model::methods::MODELS`]).
pub const METHODS: [Method; 5] = {
    let m = crate::model::methods::MODELS;
    [
        m[0].method,
        m[1].method,
        m[2].method,
        m[3].method,
        m[4].method,
    ]
};

/// The corpus's largest scene (by triangles), added to the GPU predictions of `--model-from`
/// where the path exists (the bench run from the repository's root).
pub const LARGEST_CORPUS_SCENE: &str = "tests/scenes/truck-garage/scene.toml";

/// The GPU widths predicted.
pub const GPU_WIDTHS: [u32; 2] = [32, 64];

/// What every figure of the report assumes.
pub const ASSUMPTIONS: &[&str] = &[
    "MODEL, not a measurement: weighted issued warp-steps per ray from the CPU twins' work replayed in lockstep warps",
    "weights: SPIR-V instructions per block of the shipped shaders, callees expanded, counted two ways: static (every instruction once: a loop body once, both arms of an if, dead code included) and dynamic (model::dynamic: loops with a fixed trip count per trip, the entry point's constants carried into every call and constant branches, folded values and unused results removed; both arms of an if that does not fold; loops left early or without a counter once)",
    "lavapipe mode: every block of a loop body runs on every turn any lane makes; width = lavapipe's subgroup size",
    "GPU mode: a block issues when at least one lane needs it; widths 32 and 64",
    "warps (model::warps): compute and bvh = consecutive entries of the row-major mirror-pixel queue (compute: one lane per ray in lavapipe mode, min(width, 32) lanes per ray in GPU mode); fragment and ssr = 2x2 quads in 8x4-pixel tiles, tiles row-major (helper lanes issued, never active); reflection-point = consecutive vertices of its 1-D dispatch",
    "lavapipe check: per method, ns per vector instruction (one per 256-bit AVX2 register the subgroup's lanes fill, at least one: x1 at 4 and 8 lanes, x2 at 16) and ns per lane operation (storage/image access, per-lane array index, subgroup op: run once per lane), fitted on the training rows only (scene default, every cube and subgroup size); register spills, latency and per-dispatch overhead folded in; times the threads' imbalance: lavapipe's threads (one per CPU) take the pass's workgroups (compute 256 rays, 128 at 4 lanes; bvh and reflection-point 64) or 64x64 bins (fragment, ssr) in order, each the next when free, and the pass lasts the greedy makespan (model::validate::imbalance); a row in several processes: the median of their times",
    "GPU ratios assume the same ns per weighted warp-step for every method: no latency hiding, occupancy or cache model (a throughput view: issued warp instructions per ray); compute is its GPU default, the wave layout (main_wave: one ray per lane, the warp's crossed children spread over its lanes); the 'compute thesis' column replays the same work in the thesis layout (main: a 32-lane warp per ray, whose SIMD efficiency counts the lanes that repeat the per-ray work as active) and 'compute 1 lane/ray' in main_lanes1's (lavapipe's default)",
    "sectors: distinct 32-byte sectors per warp load, row-major texels per face (model::replay TexelLayout::Linear)",
];

/// One method's GPU-mode figures at one width.
#[derive(Clone, Debug, Serialize)]
pub struct GpuMethod {
    pub method: Method,
    /// The layout these figures are of: `Auto`, the method's GPU default (compute's `main_wave`),
    /// or one of compute's others ([`layouts`]: `Thesis`, `main`; `One`, `main_lanes1`).
    pub layout: ComputeLanes,
    /// Weighted warp-steps per ray, static weights.
    pub cost_per_ray: f64,
    /// Weighted warp-steps per ray, dynamic weights ([`crate::model::dynamic`]).
    pub dynamic_cost_per_ray: f64,
    pub simd_efficiency: f64,
    pub sectors_per_ray: f64,
    /// The block with the largest share of the dynamic cost, and that share.
    pub dominant_block: String,
    pub dominant_share: f64,
    /// The dominant block's SIMD efficiency (its active lanes over its issued lanes).
    pub dominant_efficiency: f64,
    /// Every block's share of the dynamic cost, largest first (`model.json` only).
    pub block_shares: Vec<(String, f64)>,
}

impl GpuMethod {
    /// The figures of `stats` (`method`'s replay in `layout`).
    pub fn of(stats: &ReplayStats, method: Method, layout: ComputeLanes) -> Result<GpuMethod> {
        let (ws, _) = weights_by(method, Counting::Static, layout)?;
        let (wd, _) = weights_by(method, Counting::Dynamic, layout)?;
        let shares = weights::shares(stats, &wd);
        let (i, share) = shares
            .iter()
            .copied()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, 0.0));
        let mut block_shares: Vec<(String, f64)> = blocks(method)
            .iter()
            .zip(&shares)
            .map(|(b, &s)| (b.name.to_string(), s))
            .collect();
        block_shares.sort_by(|a, b| b.1.total_cmp(&a.1));
        Ok(GpuMethod {
            method,
            layout,
            cost_per_ray: weights::cost(stats, &ws),
            dynamic_cost_per_ray: weights::cost(stats, &wd),
            simd_efficiency: stats.simd_efficiency,
            sectors_per_ray: stats.sectors_per_ray,
            dominant_block: blocks(method).get(i).map_or("-", |b| b.name).to_string(),
            dominant_share: share,
            dominant_efficiency: stats.block_efficiency.get(i).copied().unwrap_or(0.0),
            block_shares,
        })
    }
}

/// A ratio of weighted warp-steps per ray: `method`'s (in `layout`) over `over`'s (in its
/// default layout).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ModelRatio {
    pub method: Method,
    pub layout: ComputeLanes,
    pub over: Method,
    /// With static weights (`None`: a method not replayed, or a ratio not finite).
    pub ratio: Option<f64>,
    /// With dynamic weights ([`crate::model::dynamic`]).
    pub dynamic: Option<f64>,
}

impl ModelRatio {
    /// The ratio of `(method, layout)` over `over` among `methods`.
    fn of(
        methods: &[GpuMethod],
        (method, layout): (Method, ComputeLanes),
        over: Method,
    ) -> ModelRatio {
        let find =
            |k: Method, l: ComputeLanes| methods.iter().find(|g| g.method == k && g.layout == l);
        let (a, b) = (find(method, layout), find(over, ComputeLanes::Auto));
        let ratio =
            |cost: fn(&GpuMethod) -> f64| Some(cost(a?) / cost(b?)).filter(|r| r.is_finite());
        ModelRatio {
            method,
            layout,
            over,
            ratio: ratio(|g| g.cost_per_ray),
            dynamic: ratio(|g| g.dynamic_cost_per_ray),
        }
    }

    /// The column heading: `compute/bvh`, `compute thesis / bvh`, `compute 1 lane/ray / bvh`.
    fn heading(&self) -> String {
        match self.layout {
            ComputeLanes::Auto => format!("{}/{}", self.method.name(), self.over.name()),
            l => format!(
                "{} {} / {}",
                self.method.name(),
                l.label(),
                self.over.name()
            ),
        }
    }
}

/// The cube-map tracers among the modelled methods, in [`METHODS`]' order: the methods whose
/// ratios the predictions track.
pub fn tracers() -> Vec<Method> {
    METHODS
        .into_iter()
        .filter(|m| m.traces_cubemaps())
        .collect()
}

/// The ratios of the GPU predictions, `((method, layout), over)`: each cube-map tracer over
/// the tracers after it, over the exact GPU tracer ([`Method::EXACT_GPU`]) and, in each of its
/// other layouts, over the exact GPU tracer.
pub fn gpu_pairs() -> Vec<((Method, ComputeLanes), Method)> {
    let tracers = tracers();
    let mut out = Vec::new();
    for (k, &m) in tracers.iter().enumerate() {
        out.extend(
            tracers[k + 1..]
                .iter()
                .map(|&after| ((m, ComputeLanes::Auto), after)),
        );
        out.push(((m, ComputeLanes::Auto), Method::EXACT_GPU));
        out.extend(layouts(m).iter().map(|&l| ((m, l), Method::EXACT_GPU)));
    }
    out
}

/// Per scene and width, the GPU-mode predictions.
///
/// In `model.json` (and `bench.json`'s `model`): `{"scene": ..., "cube": 256, "width": 32,
/// "methods": [{"method": "compute", "layout": "auto", "cost_per_ray": ..., ...}, ...],
/// "ratios": [{"method": "compute", "layout": "auto", "over": "fragment", "ratio": 2.1,
/// "dynamic": 1.9}, ...]}`.
#[derive(Clone, Debug, Serialize)]
pub struct GpuPrediction {
    pub scene: String,
    pub cube: u32,
    pub width: u32,
    /// Every modelled method's figures in [`METHODS`]' order (compute in its GPU default,
    /// `main_wave`), then those of its other layouts (`layout`: compute in the thesis layout, one
    /// ray per 32-lane warp, and in `main_lanes1`'s, one lane per ray and 32 rays per warp).
    pub methods: Vec<GpuMethod>,
    /// The ratios of [`gpu_pairs`], in that order.
    pub ratios: Vec<ModelRatio>,
}

impl GpuPrediction {
    /// The figures of `method` in its default layout.
    pub fn method(&self, method: Method) -> Option<&GpuMethod> {
        self.methods
            .iter()
            .find(|g| g.method == method && g.layout == ComputeLanes::Auto)
    }

    /// The ratio of `method` (default layout) over `over`, if tracked.
    pub fn ratio(&self, method: Method, over: Method) -> Option<&ModelRatio> {
        self.ratios
            .iter()
            .find(|r| (r.method, r.layout, r.over) == (method, ComputeLanes::Auto, over))
    }
}

/// One point of the triangle axis (GPU mode, width 32).
#[derive(Clone, Debug, Serialize)]
pub struct TrianglePoint {
    pub scene: String,
    pub triangles: usize,
    /// Each cube-map tracer ([`tracers`]) over the exact GPU tracer, static and dynamic weights.
    pub ratios: Vec<ModelRatio>,
}

/// Where a cube-map tracer would overtake the exact GPU tracer on the triangle axis.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Crossover {
    pub method: Method,
    pub over: Method,
    /// Triangles at width 32 (static weights), interpolated ([`crossover`]); `None`: it does
    /// not on the axis.
    pub triangles: Option<f64>,
}

/// Everything `--model` adds.
#[derive(Clone, Debug, Serialize)]
pub struct ModelReport {
    pub assumptions: Vec<String>,
    /// The lavapipe check with static weights, and with dynamic weights (each fitted anew).
    pub lavapipe: Validation,
    pub lavapipe_dynamic: Validation,
    pub gpu: Vec<GpuPrediction>,
    pub triangles: Vec<TrianglePoint>,
    /// Per cube-map tracer ([`tracers`]), the triangles where it would overtake the exact GPU
    /// tracer at width 32, if it does on the axis.
    pub overtakes: Vec<Crossover>,
}

/// Whether a `bench.json` row (its label and `params`) is `kind` in the setting the model
/// replays ([`MethodSpec::modelled`]). Files written before the centre criterion was renamed
/// label it `compute` and `fragment-exact-mip`, with `criterion=exact` in `params`.
fn is_modelled_row(kind: Method, label: &str, params: &str) -> bool {
    let modelled = MethodSpec::modelled(kind).label();
    let legacy = modelled
        .replace("-centre-", "-exact-")
        .replace("-centre", "");
    label == modelled || (label == legacy && params.contains("criterion=exact"))
}

/// The measured rows of a report: each method in the setting the model replays, for the
/// methods modelled.
pub fn measured_of(report: &BenchReport) -> Vec<Measured> {
    report
        .runs
        .iter()
        .filter(|r| METHODS.contains(&r.kind) && r.method == MethodSpec::modelled(r.kind).label())
        .map(|r| Measured {
            scene: r.source.clone(),
            method: r.kind,
            cube: r.cube_size,
            subgroup: report.device.subgroup_size,
            width: r.width,
            height: r.height,
            rays: r.rays,
            pass_ns: r.trace_ns.median,
            repeats: vec![r.trace_ns.median],
            threads: report.driver_threads as u32,
        })
        .collect()
}

/// The measured rows of earlier `bench.json` files. A row (scene/method/cube/subgroup) found
/// in several files is one row measured in several processes: its time is the median of the
/// files' medians, and each is kept in [`Measured::repeats`] (lavapipe's time varies more from
/// process to process than from frame to frame).
pub fn measured_from_files(paths: &[PathBuf]) -> Result<Vec<Measured>> {
    let mut out: Vec<Measured> = Vec::new();
    for p in paths {
        let text = std::fs::read_to_string(p)
            .with_context(|| format!("--model-from: cannot read {}", p.display()))?;
        let v: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("--model-from: {} is not JSON", p.display()))?;
        let field = |what: &str| format!("--model-from: {}: no field {what}", p.display());
        let subgroup = v["device"]["subgroup_size"]
            .as_u64()
            .with_context(|| field("device.subgroup_size"))? as u32;
        // Files written before `driver_threads` existed: lavapipe ran one thread per CPU, as
        // many as the bench's own pool (`cpu_threads`, unset RAYON_NUM_THREADS).
        let threads = v["driver_threads"]
            .as_u64()
            .or_else(|| v["cpu_threads"].as_u64())
            .with_context(|| field("driver_threads"))? as u32;
        let runs = v["runs"].as_array().with_context(|| field("runs"))?;
        for (i, r) in runs.iter().enumerate() {
            let f = |k: &str| r[k].clone();
            let method = f("method");
            let label = method.as_str().unwrap_or_default();
            // Only the setting the model replays (not e.g. the bounded criterion).
            let params = r["params"].as_str().unwrap_or_default();
            let Some(kind) = METHODS
                .into_iter()
                .find(|k| is_modelled_row(*k, label, params))
            else {
                continue;
            };
            let num = |k: &str| {
                f(k).as_f64()
                    .with_context(|| field(&format!("runs[{i}].{k}")))
            };
            let pass_ns = r["trace_ns"]["median"]
                .as_f64()
                .with_context(|| field(&format!("runs[{i}].trace_ns.median")))?;
            let m = Measured {
                // Where the row's scene is loaded from: `source` (files written before it existed
                // hold built-in scenes only, by `scene`).
                scene: f("source")
                    .as_str()
                    .or(f("scene").as_str())
                    .unwrap_or_default()
                    .to_string(),
                method: kind,
                cube: num("cube_size")? as u32,
                subgroup,
                width: num("width")? as u32,
                height: num("height")? as u32,
                rays: num("rays")? as usize,
                pass_ns,
                repeats: vec![pass_ns],
                threads,
            };
            match out.iter_mut().find(|o| o.key() == m.key()) {
                None => out.push(m),
                Some(o) => {
                    if (o.width, o.height, o.rays, o.threads)
                        != (m.width, m.height, m.rays, m.threads)
                    {
                        bail!(
                            "--model-from: row {} is in several files with different frames \
                             ({}x{}, {} rays, {} threads against {}x{}, {} rays, {} threads in \
                             {}): repeats of a row must be the same measurement",
                            m.key(),
                            o.width,
                            o.height,
                            o.rays,
                            o.threads,
                            m.width,
                            m.height,
                            m.rays,
                            m.threads,
                            p.display()
                        );
                    }
                    o.repeats.push(pass_ns);
                    o.pass_ns = validate::median(&o.repeats);
                }
            }
        }
    }
    if out.is_empty() {
        bail!("--model-from: no run of a modelled method's default setting in the files");
    }
    Ok(out)
}

/// The model's recordings (CPU twins' work), one per scene, cube size and method, replayed at
/// every width and mode asked: recording is the expensive part.
#[derive(Default)]
pub struct Recordings {
    frames: HashMap<(String, u32), Frame>,
    recorded: HashMap<(String, u32, Method), Recorded>,
}

impl Recordings {
    /// The replay of `method` on built-in or file scene `name` at cube size `cube`, frame
    /// `dims`, `width` lanes, `mode`.
    pub fn stats(
        &mut self,
        name: &str,
        cube: u32,
        dims: (u32, u32),
        method: Method,
        width: u32,
        mode: Mode,
    ) -> Result<ReplayStats> {
        let key = (name.to_string(), cube, method);
        if !self.recorded.contains_key(&key) {
            let fkey = (name.to_string(), cube);
            if !self.frames.contains_key(&fkey) {
                let (scene, _) = prepare_scene_judged(
                    name,
                    dims.0,
                    dims.1,
                    (Some(cube), None),
                    Scoring::Centre,
                )?;
                let settings = ModelSettings::new(cube, dims.0, dims.1);
                self.frames
                    .insert(fkey.clone(), work::frame(&scene, &settings)?);
            }
            let rec = record(&self.frames[&fkey], method)
                .with_context(|| format!("model of {name} --method {}", method.name()))?;
            self.recorded.insert(key.clone(), rec);
        }
        replay(&self.recorded[&key], width, mode, default_assembly(method)).with_context(|| {
            format!(
                "model of {name} --method {} at width {width}",
                method.name()
            )
        })
    }
}

/// Replays every measured row (lavapipe mode) and validates with `training`, the blocks weighted
/// by `counting`.
pub fn lavapipe_check(
    rec: &mut Recordings,
    rows: &[Measured],
    training: &Training,
    counting: Counting,
) -> Result<Validation> {
    let mut modelled: Vec<Modelled> = Vec::with_capacity(rows.len());
    for m in rows {
        let dims = (m.width, m.height);
        let stats = rec.stats(&m.scene, m.cube, dims, m.method, m.subgroup, Mode::Lavapipe)?;
        let train = training.contains(m);
        modelled.push(validate::modelled_with(&stats, m.clone(), train, counting)?);
    }
    if !modelled.iter().any(|r| r.train) {
        bail!(
            "--model fits its scale on the training rows ({}), and the runs have none: add scene \
             '{}' to --scenes",
            training.describe(),
            training.scene
        );
    }
    validate::validate(&modelled, training)
}

/// GPU-mode figures of every modelled method on `scene` at `width`.
pub fn gpu_prediction(
    rec: &mut Recordings,
    name: &str,
    cube: u32,
    dims: (u32, u32),
    width: u32,
) -> Result<GpuPrediction> {
    let mut methods = Vec::new();
    for m in METHODS {
        let stats = rec.stats(name, cube, dims, m, width, Mode::Gpu)?;
        methods.push(GpuMethod::of(&stats, m, ComputeLanes::Auto)?);
    }
    // A method with other layouts again in each: the same recording, replayed in that layout.
    for m in METHODS {
        for &layout in layouts(m) {
            let Some(r) = rec.recorded.get_mut(&(name.to_string(), cube, m)) else {
                continue;
            };
            let saved = r.settings.compute_lanes;
            r.settings.compute_lanes = layout;
            let s = replay(r, width, Mode::Gpu, default_assembly(m));
            r.settings.compute_lanes = saved;
            methods.push(GpuMethod::of(&s?, m, layout)?);
        }
    }
    let ratios = gpu_pairs()
        .into_iter()
        .map(|(m, over)| ModelRatio::of(&methods, m, over))
        .collect();
    Ok(GpuPrediction {
        scene: name.to_string(),
        cube,
        width,
        methods,
        ratios,
    })
}

/// The triangle axis at width 32 (GPU mode), the scenes of `bench --scaling`'s triangle axis
/// with the camera at `dims`.
pub fn triangle_axis(dims: (u32, u32)) -> Result<Vec<TrianglePoint>> {
    let mut out = Vec::new();
    for seg in TRIANGLE_SEGMENTS {
        let mut scene = tessellated_scene(seg)?;
        if let Some(mut camera) = scene.cameras.first().cloned() {
            camera.width = dims.0;
            camera.height = dims.1;
            // The model replays one reflection per path.
            crate::placement::resolve(&mut scene, &camera, 1, Scoring::Centre);
        }
        let settings = ModelSettings::new(scene.cmo.resolution, dims.0, dims.1);
        let frame = work::frame(&scene, &settings)?;
        let methods = std::iter::once(Method::EXACT_GPU)
            .chain(tracers())
            .map(|m| -> Result<GpuMethod> {
                let rec = record(&frame, m)?;
                let s = replay(&rec, 32, Mode::Gpu, default_assembly(m))?;
                GpuMethod::of(&s, m, ComputeLanes::Auto)
            })
            .collect::<Result<Vec<_>>>()?;
        out.push(TrianglePoint {
            scene: scene.name.clone(),
            triangles: scene.world().triangles.len(),
            ratios: tracers()
                .into_iter()
                .map(|m| ModelRatio::of(&methods, (m, ComputeLanes::Auto), Method::EXACT_GPU))
                .collect(),
        });
    }
    Ok(out)
}

/// The first triangle count where `ratio` falls below 1, interpolated in log triangles (a
/// point without the ratio counts as not below 1).
pub fn crossover(points: &[TrianglePoint], ratio: impl Fn(&TrianglePoint) -> f64) -> Option<f64> {
    let first = points.first()?;
    if ratio(first) < 1.0 {
        return Some(first.triangles as f64);
    }
    points.windows(2).find_map(|w| {
        let (a, b) = (ratio(&w[0]), ratio(&w[1]));
        (a >= 1.0 && b < 1.0).then(|| {
            let (ta, tb) = ((w[0].triangles as f64).ln(), (w[1].triangles as f64).ln());
            let t = (a.ln() / (a.ln() - b.ln())).clamp(0.0, 1.0);
            (ta + t * (tb - ta)).exp()
        })
    })
}

/// The whole model report for `rows`; the GPU predictions per scene at `gpu_cube`, or at the
/// cube size of the scene's first row.
pub fn run(
    rows: &[Measured],
    training: &Training,
    gpu_cube: Option<u32>,
    progress: &dyn Fn(&str),
) -> Result<ModelReport> {
    progress("lavapipe check");
    let mut rec = Recordings::default();
    let lavapipe = lavapipe_check(&mut rec, rows, training, Counting::Static)?;
    let lavapipe_dynamic = lavapipe_check(&mut rec, rows, training, Counting::Dynamic)?;
    let dims = rows.first().map_or((160, 120), |m| (m.width, m.height));
    let mut scenes: Vec<(&str, u32)> = Vec::new();
    for m in rows {
        if !scenes.iter().any(|(s, _)| *s == m.scene) {
            scenes.push((&m.scene, gpu_cube.unwrap_or(m.cube)));
        }
    }
    // The corpus's largest scene: in the report from earlier files (`--model-from`, which sets
    // the cube size), where the bench runs from the repository, unless the rows have it.
    if gpu_cube.is_some()
        && Path::new(LARGEST_CORPUS_SCENE).exists()
        && !scenes.iter().any(|(s, _)| *s == LARGEST_CORPUS_SCENE)
    {
        let cube = scenes.first().map_or(256, |s| s.1);
        scenes.push((LARGEST_CORPUS_SCENE, cube));
    }
    let mut gpu = Vec::new();
    for (s, cube) in scenes {
        for w in GPU_WIDTHS {
            progress(&format!("GPU width {w}: {s}"));
            gpu.push(gpu_prediction(&mut rec, s, cube, dims, w)?);
        }
    }
    progress("triangle axis");
    let triangles = triangle_axis(dims)?;
    Ok(ModelReport {
        assumptions: ASSUMPTIONS.iter().map(|s| s.to_string()).collect(),
        lavapipe,
        lavapipe_dynamic,
        overtakes: tracers()
            .into_iter()
            .map(|method| Crossover {
                method,
                over: Method::EXACT_GPU,
                triangles: crossover(&triangles, |p| {
                    p.ratios
                        .iter()
                        .find(|r| r.method == method)
                        .and_then(|r| r.ratio)
                        .unwrap_or(f64::NAN)
                }),
            })
            .collect(),
        gpu,
        triangles,
    })
}

fn opt(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.2}"))
}

/// The lavapipe check as a Markdown table.
pub fn lavapipe_table(v: &Validation) -> String {
    let mut s = format!(
        "MODEL check, lavapipe mode: per method, time = a x vector instructions x registers(S) + \
         b x lane operations x S, times the threads' imbalance ({}), fitted on {} ({} rows: {}); {} \
         of {} held-out rows within +-{:.0} % ({} of the others between the row's fastest and slowest \
         process; one global pair, {}: {} within). Spread: the slowest over the fastest of the \
         row's processes (1.00 for one).\n\n\
         | scene | method | cube | subgroup | row | processes | spread | measured ns/ray | fastest-slowest process | model ns/ray | error | imbalance | SIMD eff. | missed block |\n\
         |---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n",
        v.coefficients
            .iter()
            .map(|(m, c)| format!("{}: {}", m.name(), c.describe()))
            .collect::<Vec<_>>()
            .join("; "),
        v.training.describe(),
        v.training_rows.len(),
        v.training_rows.join(", "),
        v.held_out_within_target,
        v.held_out,
        100.0 * v.target,
        v.missed_within_range,
        v.global.describe(),
        v.global_held_out_within_target,
    );
    for r in &v.rows {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {:.2} | {:.0} | {:.0}-{:.0} | {:.0} | {:+.0} % | {:.3} | {:.2} | {} |\n",
            scene_label(&r.scene),
            r.method.name(),
            r.cube,
            r.subgroup,
            if r.train { "training" } else { "held out" },
            r.processes,
            r.spread,
            r.measured_ns_per_ray,
            r.measured_range_ns_per_ray.0,
            r.measured_range_ns_per_ray.1,
            r.predicted_ns_per_ray,
            100.0 * r.error,
            r.imbalance,
            r.simd_efficiency,
            r.miss.as_deref().unwrap_or(""),
        );
    }
    s
}

/// The GPU predictions as a Markdown table.
pub fn gpu_table(gpu: &[GpuPrediction]) -> String {
    let pairs = gpu_pairs();
    let headings: Vec<String> = pairs
        .iter()
        .map(|&((method, layout), over)| {
            let r = ModelRatio {
                method,
                layout,
                over,
                ratio: None,
                dynamic: None,
            };
            r.heading()
        })
        .collect();
    // SIMD efficiency and sectors of the cube-map tracers and the exact GPU tracer.
    let shown: Vec<Method> = METHODS
        .into_iter()
        .filter(|&m| m.traces_cubemaps() || m == Method::EXACT_GPU)
        .collect();
    let names = |what: &str| {
        shown
            .iter()
            .enumerate()
            .map(|(k, m)| {
                if k == 0 {
                    format!("{what} {}", m.name())
                } else {
                    m.name().to_string()
                }
            })
            .collect::<Vec<_>>()
            .join(" | ")
    };
    let n = 3 + 2 * pairs.len() + 2 * shown.len();
    let mut s = format!(
        "MODEL predictions, GPU mode (not measured; assumptions below).\n\n\
         Ratios of weighted warp-steps per ray, static weights, then dynamic (model::dynamic).\n\n\
         | scene | cube | width | {} | dynamic: {} | {} | {} |\n|---|{}\n",
        headings.join(" | "),
        headings.join(" | "),
        names("SIMD eff."),
        names("sectors/ray"),
        "---:|".repeat(n - 1),
    );
    for g in gpu {
        let ratio = |f: fn(&ModelRatio) -> Option<f64>| {
            pairs
                .iter()
                .map(|&((m, layout), over)| {
                    let r = g
                        .ratios
                        .iter()
                        .find(|r| (r.method, r.layout, r.over) == (m, layout, over));
                    opt(r.and_then(f))
                })
                .collect::<Vec<_>>()
                .join(" | ")
        };
        let per = |f: fn(&GpuMethod) -> String| {
            shown
                .iter()
                .map(|&k| g.method(k).map_or("-".into(), f))
                .collect::<Vec<_>>()
                .join(" | ")
        };
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            scene_label(&g.scene),
            g.cube,
            g.width,
            ratio(|r| r.ratio),
            ratio(|r| r.dynamic),
            per(|x| opt(Some(x.simd_efficiency))),
            per(|x| format!("{:.1}", x.sectors_per_ray)),
        );
    }
    s
}

/// The triangle axis and the crossovers as Markdown.
pub fn triangle_table(triangles: &[TrianglePoint], overtakes: &[Crossover]) -> String {
    let headings: Vec<String> = tracers()
        .into_iter()
        .map(|m| format!("{}/{}", m.name(), Method::EXACT_GPU.name()))
        .collect();
    let dynamic: Vec<String> = headings.iter().map(|h| format!("dynamic {h}")).collect();
    let mut s = format!(
        "MODEL, GPU mode width 32, the triangle axis of `bench --scaling` (sphere-room + a UV \
         sphere), static and dynamic weights:\n\n\
         | scene | triangles | {} | {} |\n|---|---:|{}\n",
        headings.join(" | "),
        dynamic.join(" | "),
        "---:|".repeat(2 * headings.len()),
    );
    for p in triangles {
        let cells = |f: fn(&ModelRatio) -> Option<f64>| {
            p.ratios
                .iter()
                .map(|x| opt(f(x)))
                .collect::<Vec<_>>()
                .join(" | ")
        };
        s += &format!(
            "| {} | {} | {} | {} |\n",
            p.scene,
            p.triangles,
            cells(|x| x.ratio),
            cells(|x| x.dynamic)
        );
    }
    s += "\n";
    for c in overtakes {
        s += &match c.triangles {
            Some(t) => format!(
                "{} would overtake the BVH at about {t:.0} triangles (model).\n",
                c.method.name()
            ),
            None => format!(
                "{} does not overtake the BVH on this axis (model).\n",
                c.method.name()
            ),
        };
    }
    s
}

/// A scene's short name: a scene file's folder (`tests/scenes/<name>/scene.toml`).
fn scene_label(scene: &str) -> &str {
    let p = Path::new(scene);
    match p.file_name().and_then(|f| f.to_str()) {
        Some("scene.toml") => p
            .parent()
            .and_then(|d| d.file_name())
            .and_then(|f| f.to_str())
            .unwrap_or(scene),
        _ => scene,
    }
}

/// Per-ray work at width 32 (GPU mode), every method beside bvh: weighted warp-steps per ray
/// (static and dynamic) and over bvh's, SIMD efficiency, sectors per ray, and the block that
/// holds the largest share of the dynamic cost.
pub fn per_ray_table(gpu: &[GpuPrediction]) -> String {
    let mut s = format!(
        "MODEL, per-ray work at width 32 (GPU mode; weighted issued warp-steps per ray, static \
         and dynamic weights; the dominant block by its share of the dynamic cost, and the share \
         of its issued lanes that need it).\n\n\
         | scene | method | steps/ray static | dynamic | over {} static | dynamic | SIMD eff. | sectors/ray | dominant block (dynamic) |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---|\n",
        Method::EXACT_GPU.name()
    );
    for g in gpu.iter().filter(|g| g.width == 32) {
        let Some(bvh) = g.method(Method::EXACT_GPU) else {
            continue;
        };
        for m in &g.methods {
            let label = match m.layout {
                ComputeLanes::Auto => m.method.name().to_string(),
                l => format!("{}, {}", m.method.name(), l.label()),
            };
            s += &format!(
                "| {} | {} | {:.0} | {:.0} | {:.2} | {:.2} | {:.2} | {:.1} | {} ({:.0} %; lanes {:.2}) |\n",
                scene_label(&g.scene),
                label,
                m.cost_per_ray,
                m.dynamic_cost_per_ray,
                m.cost_per_ray / bvh.cost_per_ray,
                m.dynamic_cost_per_ray / bvh.dynamic_cost_per_ray,
                m.simd_efficiency,
                m.sectors_per_ray,
                m.dominant_block,
                100.0 * m.dominant_share,
                m.dominant_efficiency,
            );
        }
    }
    s
}

/// The Markdown section `--model` adds to `bench.md` (and writes as `model.md`).
pub fn markdown(r: &ModelReport) -> String {
    let mut s = String::from("## Cost model (`--model`)\n\n");
    s += "Static weights:\n\n";
    s += &lavapipe_table(&r.lavapipe);
    s += "\nDynamic weights (model::dynamic), fitted anew on the same training rows:\n\n";
    s += &lavapipe_table(&r.lavapipe_dynamic);
    s += "\n";
    s += &per_ray_table(&r.gpu);
    s += "\n";
    s += &gpu_table(&r.gpu);
    s += "\n";
    s += &triangle_table(&r.triangles, &r.overtakes);
    s += "\nAssumptions:\n\n";
    for a in &r.assumptions {
        s += &format!("- {a}\n");
    }
    s
}

/// The plot: model against measured ns per ray on lavapipe (held-out and training rows).
pub fn svg(r: &ModelReport) -> Result<String> {
    let points: Vec<Point> = r
        .lavapipe
        .rows
        .iter()
        .map(|row| Point {
            label: format!("{}{}", row.key, if row.train { " (training)" } else { "" }),
            cost: row.measured_ns_per_ray,
            error: row.predicted_ns_per_ray,
        })
        .collect();
    plot::scatter(
        "MODEL vs lavapipe: predicted against measured ns per ray (tracing pass)",
        "measured ns per ray (lavapipe)",
        "model ns per ray (lavapipe mode)",
        &points,
        1e-3,
        false,
    )
}

/// Writes `model.json`, `model.md`, `model.svg` into `dir`.
pub fn write(r: &ModelReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let json = dir.join("model.json");
    write_atomic(&json, serde_json::to_string_pretty(r)?.as_bytes())?;
    let md = dir.join("model.md");
    write_atomic(&md, markdown(r).as_bytes())?;
    let plot = dir.join("model.svg");
    write_atomic(&plot, svg(r)?.as_bytes())?;
    Ok(vec![json, md, plot])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The model reads the centre criterion's rows, also from files that call it `exact`, and
    /// never the bounded criterion's (now the default, labelled by the method alone).
    #[test]
    fn the_modelled_rows_are_the_centre_criterion() {
        let exact = "criterion=exact sampling=per-texel accel=true";
        let centre = "criterion=centre sampling=per-texel accel=true";
        let bounded = "criterion=bounded sampling=per-texel accel=true";
        assert!(is_modelled_row(Method::Compute, "compute-centre", centre));
        assert!(is_modelled_row(Method::Compute, "compute", exact));
        assert!(is_modelled_row(
            Method::Fragment,
            "fragment-exact-mip",
            exact
        ));
        assert!(is_modelled_row(
            Method::Fragment,
            "fragment-centre-mip",
            centre
        ));
        assert!(is_modelled_row(Method::Bvh, "bvh", ""));
        // Negatives: the default (bounded) rows, another setting, another method.
        assert!(!is_modelled_row(Method::Compute, "compute", bounded));
        assert!(!is_modelled_row(
            Method::Fragment,
            "fragment-bounded",
            bounded
        ));
        assert!(!is_modelled_row(
            Method::Fragment,
            "fragment-centre-walk",
            centre
        ));
        assert!(!is_modelled_row(Method::Bvh, "compute-centre", centre));
    }

    /// A method's figures with cost `cost` (static) and `2 * cost` (dynamic).
    fn figures(method: Method, layout: ComputeLanes, cost: f64) -> GpuMethod {
        GpuMethod {
            method,
            layout,
            cost_per_ray: cost,
            dynamic_cost_per_ray: 2.0 * cost,
            simd_efficiency: 0.5,
            sectors_per_ray: 3.0,
            dominant_block: "b".into(),
            dominant_share: 0.25,
            dominant_efficiency: 0.5,
            block_shares: vec![("b".into(), 0.25)],
        }
    }

    #[test]
    fn the_gpu_tables_have_a_column_per_tracked_ratio() {
        let mut methods: Vec<GpuMethod> = METHODS
            .into_iter()
            .map(|m| {
                let cost = if m == Method::Compute { 4.0 } else { 2.0 };
                figures(m, ComputeLanes::Auto, cost)
            })
            .collect();
        methods.push(figures(Method::Compute, ComputeLanes::Thesis, 3.0));
        methods.push(figures(Method::Compute, ComputeLanes::One, 1.0));
        let ratios = gpu_pairs()
            .into_iter()
            .map(|(m, over)| ModelRatio::of(&methods, m, over))
            .collect();
        let g = GpuPrediction {
            scene: "tests/scenes/mug/scene.toml".into(),
            cube: 64,
            width: 32,
            methods,
            ratios,
        };
        let table = gpu_table(std::slice::from_ref(&g));
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(
            lines[4],
            "| scene | cube | width | compute/fragment | compute/bvh | compute thesis / bvh \
             | compute 1 lane/ray / bvh | fragment/bvh | dynamic: compute/fragment | compute/bvh \
             | compute thesis / bvh | compute 1 lane/ray / bvh | fragment/bvh | SIMD eff. compute \
             | fragment | bvh | sectors/ray compute | fragment | bvh |"
        );
        assert_eq!(
            lines[6],
            "| mug | 64 | 32 | 2.00 | 2.00 | 1.50 | 0.50 | 1.00 | 2.00 | 2.00 | 1.50 | 0.50 | 1.00 \
             | 0.50 | 0.50 | 0.50 | 3.0 | 3.0 | 3.0 |"
        );
        assert_eq!(lines[5].matches('|').count(), lines[4].matches('|').count());
        assert_eq!(
            g.ratio(Method::Compute, Method::Bvh).unwrap().dynamic,
            Some(2.0)
        );
        let per_ray = per_ray_table(std::slice::from_ref(&g));
        assert!(per_ray.contains("| over bvh static |"), "{per_ray}");
        assert!(
            per_ray.contains("| mug | compute, 1 lane/ray | 1 | 2 | 0.50 | 0.50 |")
                && per_ray.contains("| mug | compute, thesis | 3 | 6 | 1.50 | 1.50 |"),
            "{per_ray}"
        );
        // Negative: a method not replayed leaves its ratios empty, not made up.
        let without_bvh: Vec<GpuMethod> = g
            .methods
            .iter()
            .filter(|m| m.method != Method::Bvh)
            .cloned()
            .collect();
        let r = ModelRatio::of(
            &without_bvh,
            (Method::Compute, ComputeLanes::Auto),
            Method::Bvh,
        );
        assert_eq!((r.ratio, r.dynamic), (None, None));
    }

    #[test]
    fn the_triangle_table_names_each_tracer_over_the_exact_tracer() {
        let methods: Vec<GpuMethod> = [Method::Bvh, Method::Compute, Method::Fragment]
            .into_iter()
            .zip([1.0, 3.0, 0.5])
            .map(|(m, c)| figures(m, ComputeLanes::Auto, c))
            .collect();
        let point = TrianglePoint {
            scene: "s".into(),
            triangles: 100,
            ratios: tracers()
                .into_iter()
                .map(|m| ModelRatio::of(&methods, (m, ComputeLanes::Auto), Method::EXACT_GPU))
                .collect(),
        };
        let overtakes = [
            Crossover {
                method: Method::Compute,
                over: Method::Bvh,
                triangles: None,
            },
            Crossover {
                method: Method::Fragment,
                over: Method::Bvh,
                triangles: Some(100.0),
            },
        ];
        let t = triangle_table(&[point], &overtakes);
        assert!(
            t.contains(
                "| scene | triangles | compute/bvh | fragment/bvh | dynamic compute/bvh | \
                 dynamic fragment/bvh |\n|---|---:|---:|---:|---:|---:|\n\
                 | s | 100 | 3.00 | 0.50 | 3.00 | 0.50 |\n"
            ),
            "{t}"
        );
        assert!(t.ends_with(
            "\ncompute does not overtake the BVH on this axis (model).\n\
             fragment would overtake the BVH at about 100 triangles (model).\n"
        ));
    }
}

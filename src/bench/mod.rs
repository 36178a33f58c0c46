#![forbid(unsafe_code)]
//! The speed-against-error harness behind `cubetrace bench` (and `cargo bench --bench paths`).
//!
//! A run is one scene x one [`MethodSpec`]. Each GPU run builds one
//! [`GpuRenderer`] (everything allocated once), renders `warmup` frames that are thrown away,
//! then `frames` timed frames. It reports, per pass, the median, min and max of the GPU
//! timestamps; the tracing pass's median per mirror pixel; the mean `cells`, `texels` and
//! `traces` counters of the pixel records over mirror pixels; the CMO memory; and the error of
//! the **last** frame against the exact CPU reference ([`metrics::compare`], plus the FLIP mean
//! over mirror pixels). `reference` runs on the CPU: its time is wall-clock, its tracing cost
//! the phase that traces the reflected rays ([`reference::render_phased`]), its error zero by
//! definition (it is the yardstick), and it appears in the table but not in the plot.
//! Per scene, [`SceneRatios`] sets the default settings' costs per ray side by side, and each
//! GPU method's default setting is timed again at a 16x12 frame ([`FloorRun`]) to expose a
//! fixed per-pass cost.
//!
//! Invariants:
//! - Every figure comes from the frames of this run; nothing is extrapolated. Frames are
//!   deterministic, so the last frame's error is every frame's error.
//! - A method is a [`Method`] plus tracer options; the grid ([`fragment_grid`]) sweeps the
//!   options of every kind for which [`Method::traces_cubemaps`] holds, so a new GPU method (compute)
//!   is one [`Method`] variant.
//! - "Cost" in the plot and in `ns/mirror px` is the tracing pass alone (`fragment_trace`,
//!   `envmap`): capture, pyramid and G-buffer are listed per pass but are the same for every
//!   tracing method of a scene and are not what the methods trade against error.

pub mod glossy;
pub mod heatmap;
pub mod model;
pub mod plot;
pub mod report;
pub mod scaling;
pub mod sequence;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use serde::Serialize;

use crate::camera::Camera;
use crate::cpu::options::{TraceCriterion, TraceOptions, TraceSampling};
use crate::memory;
use crate::metrics::{self, ErrorReport, PixelError, Traced};
use crate::output::Format;
use crate::placement::{PlacementChoice, override_placement};
use crate::reference::{self, Frame};
use crate::scene::{self, Scene};
use crate::vk::frame::{GpuFrame, GpuRenderer, RenderOptions, pass_name};
use crate::vk::{GpuContext, PassTime};

pub use crate::method::Method;

/// One method with its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MethodSpec {
    pub kind: Method,
    /// Used when [`Method::traces_cubemaps`].
    pub trace: TraceOptions,
    /// The non-reflector objects split into four this many times for this run
    /// ([`crate::cpu::reflection_point::subdivide_non_reflectors`]): the same surfaces, so the
    /// same reference. Used for the reflection-point method, whose quality depends on it.
    pub subdivide: u32,
}

/// The subdivision of the second reflection-point row of the grid.
pub const RP_BENCH_SUBDIVIDE: u32 = 2;

impl MethodSpec {
    pub fn plain(kind: Method) -> Self {
        MethodSpec {
            kind,
            trace: TraceOptions::default(),
            subdivide: 0,
        }
    }

    /// The renderer's options of this method in a bench run, with the default fallback
    /// ([`Fallback::Trace`](crate::vk::options::Fallback::Trace), as the CLI's: PSNR and FLIP
    /// measure the image a user would see; the fallback's share is counted and timed apart).
    pub fn render_options(&self, bounces: u32, reflector_check: bool) -> RenderOptions {
        RenderOptions {
            method: self.kind,
            trace: self.trace,
            bounces,
            reflector_check,
            ..RenderOptions::default()
        }
    }

    /// A short unique name, also used in file names: `fragment-exact-mip`,
    /// `fragment-threshold-step64`, `envmap`, ...
    pub fn label(&self) -> String {
        if self.subdivide > 0 {
            let plain = MethodSpec {
                subdivide: 0,
                ..*self
            };
            return format!("{}-sub{}", plain.label(), self.subdivide);
        }
        // The compute path has two settings on its own hierarchy: the exact criterion (named
        // by the method alone) and the bounded one.
        if self.kind == Method::Compute && self.trace.criterion == TraceCriterion::Bounded {
            return "compute-bounded".into();
        }
        if !self.kind.traces_cubemaps() || self.kind == Method::Compute {
            return self.kind.name().into();
        }
        let t = &self.trace;
        let sampling = match t.sampling {
            TraceSampling::PerTexel => "texel".to_string(),
            TraceSampling::ConstantStep => format!("step{}", t.steps),
            TraceSampling::ConstantAngle => format!("angle{}", t.steps),
        };
        match t.criterion {
            TraceCriterion::Exact => format!(
                "{}-exact-{}{}",
                self.kind.name(),
                if t.accel { "mip" } else { "walk" },
                if t.strict { "-strict" } else { "" }
            ),
            TraceCriterion::Threshold => format!("{}-threshold-{sampling}", self.kind.name()),
            TraceCriterion::SignChange => format!("{}-sign-{sampling}", self.kind.name()),
            TraceCriterion::Bounded => format!("{}-bounded", self.kind.name()),
        }
    }
}

/// The default parameter grid of a tracing method: the exact criterion with and without the
/// min/max pyramid and in strict mode, and the threshold and sign-change criteria with per-texel,
/// 64 and 256 constant steps, and 256 constant-angle steps (`eps` stays at its default, 0.05
/// world units: the built-in scenes are a few metres across).
pub fn fragment_grid(kind: Method) -> Vec<MethodSpec> {
    let base = TraceOptions::default();
    let mut out = vec![
        TraceOptions {
            accel: true,
            ..base
        },
        TraceOptions {
            accel: false,
            ..base
        },
        TraceOptions {
            strict: true,
            ..base
        },
    ];
    for criterion in [TraceCriterion::Threshold, TraceCriterion::SignChange] {
        for (sampling, steps) in [
            (TraceSampling::PerTexel, base.steps),
            (TraceSampling::ConstantStep, 64),
            (TraceSampling::ConstantStep, 256),
            (TraceSampling::ConstantAngle, 256),
        ] {
            out.push(TraceOptions {
                criterion,
                sampling,
                steps,
                ..base
            });
        }
    }
    out.into_iter()
        .map(|trace| MethodSpec {
            kind,
            trace,
            subdivide: 0,
        })
        .collect()
}

/// The full method list for the chosen kinds, in table order.
pub fn method_grid(kinds: &[Method], quick: bool) -> Vec<MethodSpec> {
    let mut out = Vec::new();
    for &kind in kinds {
        if kind.traces_cubemaps() {
            if quick || kind == Method::Compute {
                out.push(MethodSpec::plain(kind));
            } else {
                out.extend(fragment_grid(kind));
            }
            // The bounded criterion (proven first hits) beside the exact one, in every grid.
            out.push(MethodSpec {
                trace: TraceOptions {
                    criterion: TraceCriterion::Bounded,
                    ..TraceOptions::default()
                },
                ..MethodSpec::plain(kind)
            });
        } else {
            out.push(MethodSpec::plain(kind));
            if kind == Method::ReflectionPoint {
                out.push(MethodSpec {
                    subdivide: RP_BENCH_SUBDIVIDE,
                    ..MethodSpec::plain(kind)
                });
            }
        }
    }
    out
}

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// Built-in scene names or scene file paths.
    pub scenes: Vec<String>,
    pub methods: Vec<MethodSpec>,
    pub width: u32,
    pub height: u32,
    /// Timed frames per run (at least 1).
    pub frames: u32,
    /// Frames rendered and thrown away before timing.
    pub warmup: u32,
    /// Overrides the scenes' cube face size.
    pub cube_size: Option<u32>,
    /// Overrides the scenes' CMO placement with this many automatic CMOs.
    pub cmos: Option<u32>,
    /// The CMO placements each scene runs with (`--placement`): one run of every method per
    /// scene and placement.
    pub placements: Vec<BenchPlacement>,
    /// Compute FLIP (nv-flip) over mirror pixels (needs the `flip` feature, on by default).
    pub flip: bool,
    /// Write per-run error heat maps.
    pub heatmaps: bool,
    /// Also time each GPU method's default setting at this small frame size, to expose a fixed
    /// per-pass cost (the "floor": small frame time / full frame time, near 0 when the pass
    /// costs per ray).
    pub floor: Option<(u32, u32)>,
    /// Reflections per path (`--bounces`), for the reference and the GPU methods that trace
    /// more than one (`compute`, `fragment` with the exact criterion, `bvh`); with N != 1 the
    /// others are skipped, and the error figures compare each path's last hit.
    pub bounces: u32,
    /// [`RenderOptions::reflector_check`] for the GPU runs (`--no-reflector-check`: off).
    pub reflector_check: bool,
    pub out: PathBuf,
}

impl Default for BenchConfig {
    /// Every built-in still scene, reference + envmap + the fragment grid, 160x120, 1 + 5 frames:
    /// about two minutes on lavapipe (2 cores).
    fn default() -> Self {
        BenchConfig {
            scenes: scene::builtin::NAMES
                .iter()
                .map(|(n, _)| n.to_string())
                .collect(),
            methods: method_grid(&Method::ALL, false),
            width: 160,
            height: 120,
            frames: 5,
            warmup: 1,
            cube_size: None,
            cmos: None,
            placements: vec![BenchPlacement::Scene],
            flip: true,
            heatmaps: true,
            floor: Some(FLOOR_FRAME),
            bounces: RenderOptions::default().bounces,
            reflector_check: RenderOptions::default().reflector_check,
            out: PathBuf::from("out/bench"),
        }
    }
}

/// The small frame of the floor measurement ([`BenchConfig::floor`]).
pub const FLOOR_FRAME: (u32, u32) = (16, 12);

/// Median, min and max of a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Stats {
    /// `None` for an empty sample. NaNs sort last (`total_cmp`).
    pub fn of(values: &[f64]) -> Option<Stats> {
        if values.is_empty() {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Some(Stats {
            median,
            min: v[0],
            max: v[n - 1],
        })
    }
}

/// GPU time of one pass over the timed frames, nanoseconds.
#[derive(Clone, Debug, Serialize)]
pub struct PassStats {
    pub pass: String,
    pub ns: Stats,
}

/// Mean per-ray counters of the pixel records, over mirror pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Counters {
    pub cells: f64,
    pub texels: f64,
    /// CMO traces per ray (1 + handoffs to further CMOs).
    pub traces: f64,
    /// Reflection-point method: search steps per searched vertex in the frame, mean and max
    /// (the paper's Table 1); 0 for the other methods.
    pub search_mean: f64,
    pub search_max: u32,
}

impl Counters {
    /// Means over mirror pixels of `frame`.
    pub fn of(frame: &GpuFrame) -> Counters {
        let (mut c, mut n) = (Counters::default(), 0usize);
        for (r, _) in frame
            .records
            .iter()
            .zip(&frame.mask)
            .filter(|(_, m)| **m != 0)
        {
            c.cells += f64::from(r.cells);
            c.texels += f64::from(r.texels);
            c.traces += f64::from(r.traces);
            n += 1;
        }
        let n = n.max(1) as f64;
        Counters {
            cells: c.cells / n,
            texels: c.texels / n,
            traces: c.traces / n,
            search_mean: frame.search.map_or(0.0, |s| s.mean_iterations),
            search_max: frame.search.map_or(0, |s| s.max_iterations),
        }
    }
}

/// The result of one scene x method.
#[derive(Clone, Debug, Serialize)]
pub struct RunResult {
    pub scene: String,
    pub method: String,
    pub kind: Method,
    /// Tracer options as text (criterion, sampling, accel, steps, eps); empty for non-tracers.
    pub params: String,
    pub width: u32,
    pub height: u32,
    pub cube_size: u32,
    pub cmos: u32,
    pub triangles: usize,
    pub mirror_pixels: usize,
    /// Rays the tracing pass traced: the method's own mirror pixels (GPU), or the reference's
    /// first reflected rays.
    pub rays: usize,
    pub frames: u32,
    /// Per pass, in recording order (GPU methods).
    pub passes: Vec<PassStats>,
    /// The method's own pass (GPU), or the wall time of the reference's reflected-ray phase
    /// ([`reference::render_phased`]), ns.
    pub trace_ns: Stats,
    /// Sum of all passes per frame (GPU, the `trace` fallback included) or the whole frame's
    /// wall time (reference), ns.
    pub total_ns: Stats,
    /// Share of the mirror pixels the method left unresolved and the `trace` fallback finished
    /// (the bench renders with [`Fallback::Trace`](crate::vk::options::Fallback::Trace), the
    /// default; 0 for the reference, `bvh` and `envmap`, which leave none).
    pub fallback_share: f64,
    /// The `fallback` pass (queue + BVH trace of those rays), ns; zero where it did not run.
    pub fallback_ns: Stats,
    /// Share of the traced rays whose record the reflector check changed (a nearer hit on a
    /// reflector; [`crate::vk::passes::bvh::ReflectorCheck`]); 0 where it did not run. Not part of
    /// `fallback_share`.
    pub checked_share: f64,
    /// The `reflector_check` pass, ns; zero where it did not run.
    pub check_ns: Stats,
    /// Median of `trace_ns` per mirror pixel of the reference.
    pub trace_ns_per_mirror_px: f64,
    /// Median of `trace_ns` per traced ray (`rays`).
    pub ns_per_ray: f64,
    /// The tracing pass at the [`BenchConfig::floor`] frame size, for the default setting of
    /// each GPU method.
    pub floor: Option<FloorRun>,
    pub counters: Counters,
    /// Bytes of GPU memory of the CMO data (0 for the reference).
    pub cmo_bytes: u64,
    pub error: ErrorReport,
    /// [`metrics::wrong_surface_off_reflector`]: wrong surfaces among the mirror pixels whose
    /// reference hit is a non-reflector object (the verified hits' target; 0 for the reference,
    /// NaN where no such pixel exists).
    pub wrong_off_reflector: f64,
    /// FLIP mean over mirror pixels (LDR, sRGB 8-bit, 67 pixels per degree), if computed.
    pub flip_mean: Option<f64>,
    /// The error heat map, relative to the output folder.
    pub heatmap: Option<String>,
    /// The CMO placement search's wall time, ms, where it ran for this run's scene
    /// ([`BenchPlacement::Auto`], or a scene without `[cmo]` centres) and the method captures.
    pub placement_ms: Option<f64>,
}

/// The tracing pass of a method at a small frame ([`BenchConfig::floor`]).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct FloorRun {
    pub width: u32,
    pub height: u32,
    pub rays: usize,
    pub trace_ns: Stats,
    /// `trace_ns.median` at the small frame over the full frame's: a pass that costs per ray
    /// scales with the ray count, a fixed cost keeps this near 1.
    pub ratio: f64,
}

/// Per scene, the cost per ray of each method and the ratios the project tracks.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SceneRatios {
    pub scene: String,
    /// ns per ray of each method's default setting (`None` where not run).
    pub reference_ns_per_ray: Option<f64>,
    pub envmap_ns_per_ray: Option<f64>,
    pub fragment_ns_per_ray: Option<f64>,
    pub compute_ns_per_ray: Option<f64>,
    pub ssr_ns_per_ray: Option<f64>,
    pub bvh_ns_per_ray: Option<f64>,
    /// The compute path's cost per ray over the BVH tracer's (above 1: the BVH is cheaper).
    pub compute_over_bvh: Option<f64>,
    pub fragment_over_reference: Option<f64>,
    pub compute_over_reference: Option<f64>,
    pub compute_over_fragment: Option<f64>,
    /// Tracing pass at the small frame over the full frame ([`FloorRun::ratio`]).
    pub fragment_floor: Option<f64>,
    pub compute_floor: Option<f64>,
}

impl SceneRatios {
    /// The ratios of every scene of `runs`, in first-appearance order. The methods are the
    /// default settings: `reference`, `envmap`, `fragment-exact-mip` and `compute`.
    pub fn of(runs: &[RunResult]) -> Vec<SceneRatios> {
        let mut scenes: Vec<&str> = Vec::new();
        for r in runs {
            if !scenes.contains(&r.scene.as_str()) {
                scenes.push(&r.scene);
            }
        }
        let default_label = |kind: Method| MethodSpec::plain(kind).label();
        scenes
            .into_iter()
            .map(|scene| {
                let run = |kind: Method| {
                    let label = default_label(kind);
                    runs.iter().find(|r| r.scene == scene && r.method == label)
                };
                let per_ray = |kind| run(kind).map(|r| r.ns_per_ray);
                let ratio = |a: Option<f64>, b: Option<f64>| Some(a? / b?);
                let floor = |kind| run(kind).and_then(|r| r.floor).map(|f| f.ratio);
                let (refr, fragment, compute) = (
                    per_ray(Method::Reference),
                    per_ray(Method::Fragment),
                    per_ray(Method::Compute),
                );
                SceneRatios {
                    scene: scene.to_string(),
                    reference_ns_per_ray: refr,
                    envmap_ns_per_ray: per_ray(Method::Envmap),
                    fragment_ns_per_ray: fragment,
                    compute_ns_per_ray: compute,
                    ssr_ns_per_ray: per_ray(Method::Ssr),
                    bvh_ns_per_ray: per_ray(Method::Bvh),
                    compute_over_bvh: ratio(compute, per_ray(Method::Bvh)),
                    fragment_over_reference: ratio(fragment, refr),
                    compute_over_reference: ratio(compute, refr),
                    compute_over_fragment: ratio(compute, fragment),
                    fragment_floor: floor(Method::Fragment),
                    compute_floor: floor(Method::Compute),
                }
            })
            .collect()
    }
}

/// The device a run was measured on.
#[derive(Clone, Debug, Serialize)]
pub struct DeviceInfo {
    pub name: String,
    pub driver_name: Option<String>,
    pub driver_info: Option<String>,
    pub api_version: String,
    pub subgroup_size: u32,
    pub timestamps: bool,
}

impl DeviceInfo {
    pub fn of(ctx: &GpuContext) -> Self {
        let r = ctx.report();
        DeviceInfo {
            name: r.name.clone(),
            driver_name: r.driver_name.clone(),
            driver_info: r.driver_info.clone(),
            api_version: format!(
                "{}.{}.{}",
                r.api_version.0, r.api_version.1, r.api_version.2
            ),
            subgroup_size: r.subgroup_size,
            timestamps: r.timestamps_supported(),
        }
    }

    /// `name (driver_name driver_info)`.
    pub fn describe(&self) -> String {
        let driver = [self.driver_name.as_deref(), self.driver_info.as_deref()]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>()
            .join(" ");
        format!(
            "{} ({driver}, Vulkan {}, subgroup size {})",
            self.name, self.api_version, self.subgroup_size
        )
    }
}

/// [`BenchReport::driver_threads`] of this process.
pub fn driver_threads() -> usize {
    std::env::var("LP_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Everything a bench run produced.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub device: DeviceInfo,
    /// `git rev-parse HEAD` at run time, else the build-time `CUBETRACE_GIT_COMMIT`, else null.
    pub git_commit: Option<String>,
    pub cubetrace_version: &'static str,
    pub cpu_threads: usize,
    /// Threads a CPU driver runs its passes on: `LP_NUM_THREADS` where set (lavapipe reads
    /// it), else the CPUs this process may use (lavapipe's default: one per CPU). What the cost
    /// model schedules lavapipe's work items over (`model::validate::imbalance`).
    pub driver_threads: usize,
    pub warmup: u32,
    /// Reflections per path ([`BenchConfig::bounces`]).
    pub bounces: u32,
    pub runs: Vec<RunResult>,
    /// Per scene: ns per ray of each method and the ratios between them ([`SceneRatios::of`]).
    pub ratios: Vec<SceneRatios>,
    /// `--model`: the cost model beside the runs ([`model`]); absent without it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<model::ModelReport>,
}

/// The commit being measured: `git rev-parse HEAD` in the current folder, else the build-time
/// environment variable `CUBETRACE_GIT_COMMIT`; `None` when neither is available (no failure).
pub fn git_commit() -> Option<String> {
    let run = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty());
    run.or_else(|| option_env!("CUBETRACE_GIT_COMMIT").map(str::to_string))
}

/// A CMO placement of the bench's placement axis (`--placement`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum BenchPlacement {
    /// The scene's own `[cmo]` (a scene file without centres: the search).
    Scene,
    /// `placement = "axis"`: `--cmos N` (else the scene's count, else 1) along the reflectors'
    /// longest axis.
    Axis,
    /// The placement search ([`crate::placement`]): up to `--cmos N` (else the scene's count,
    /// else [`crate::scene::DEFAULT_SEARCH_CMOS`]).
    Auto,
}

impl BenchPlacement {
    /// The scene's label in a run of this placement: the name, with the placement after it
    /// where the axis has more than one.
    pub fn label(self, name: &str, several: bool) -> String {
        if several {
            let p = match self {
                BenchPlacement::Scene => "scene",
                BenchPlacement::Axis => "axis",
                BenchPlacement::Auto => "auto",
            };
            format!("{name} [{p}]")
        } else {
            name.to_string()
        }
    }
}

/// Loads a scene by name or path and applies the overrides of `cfg` and its frame size to its
/// first camera.
pub fn prepare_scene(
    name: &str,
    width: u32,
    height: u32,
    cube_size: Option<u32>,
    cmos: Option<u32>,
) -> Result<(Scene, Camera)> {
    let (scene, camera, _) = prepare_scene_placed(
        name,
        width,
        height,
        (cube_size, cmos),
        BenchPlacement::Scene,
        true,
    )?;
    Ok((scene, camera))
}

/// [`prepare_scene`] with a placement of the bench's axis (`cube_size`, `cmos`: the overrides);
/// also the placement search's result where one ran. `search`: whether a placement search runs
/// at all (not where no method of the grid captures CMOs: the scene keeps its unresolved
/// placement, which nothing reads).
pub fn prepare_scene_placed(
    name: &str,
    width: u32,
    height: u32,
    (cube_size, cmos): (Option<u32>, Option<u32>),
    placement: BenchPlacement,
    search: bool,
) -> Result<(Scene, Camera, Option<crate::placement::Placement>)> {
    let mut scene = scene::load(name)?;
    let choice = match placement {
        BenchPlacement::Scene => None,
        BenchPlacement::Axis => Some(PlacementChoice::Axis),
        BenchPlacement::Auto => Some(PlacementChoice::Auto),
    };
    override_placement(&mut scene, choice, cmos);
    if let Some(n) = cube_size {
        scene.cmo.resolution = n;
    }
    let mut camera = scene
        .cameras
        .first()
        .with_context(|| format!("scene '{name}' has no camera"))?
        .clone();
    camera.width = width;
    camera.height = height;
    // A placement search runs once, for this camera, not in every `cmo_centres` call.
    let searched = if search {
        crate::placement::resolve(&mut scene, &camera)
    } else {
        None
    };
    scene::check_resolution(width, height).map_err(|e| anyhow::anyhow!("frame size: {e}"))?;
    Ok((scene, camera, searched))
}

/// Refuses, before anything renders, a grid whose largest run would not fit in `limits`
/// ([`crate::memory`]): per scene, the reference frame (held through the scene's runs) beside
/// the largest GPU run's device data ([`crate::vk::budget::estimate`], the estimate `render`
/// checks: bounce queues and reflector check included) and its read-back and comparison. Runs
/// that the bounce rule skips ([`Method::check_bounces`]) are not counted: they allocate
/// nothing. The subdivided runs are estimated on the scene as loaded: subdivision splits the
/// non-reflector objects only, and the estimate depends on the frame, the CMOs and the
/// reflectors.
pub fn check_memory(
    cfg: &BenchConfig,
    prepared: &[(Scene, Camera)],
    limits: &memory::Limits,
) -> Result<()> {
    for (scene, camera) in prepared {
        let pixels = u64::from(camera.width) * u64::from(camera.height);
        let cmos = scene.cmo_centres().len() as u32;
        let device = cfg
            .methods
            .iter()
            .filter(|m| m.kind.is_gpu() && runs_at(m, cfg.bounces))
            .map(|m| {
                let options = m.render_options(cfg.bounces, cfg.reflector_check);
                crate::vk::budget::estimate(scene, camera, &options).total()
            })
            .max()
            .unwrap_or(0);
        let mut host = memory::reference_bytes(pixels, Format::Png)
            + memory::gpu_host_bytes(pixels, Format::Png, true);
        if limits.device_is_host {
            host += device;
        }
        let what = format!(
            "bench scene '{}' at {}x{} ({cmos} CMOs of {}^2 texels per face)",
            scene.name, camera.width, camera.height, scene.cmo.resolution
        );
        memory::check(&what, host, limits.host.clone())?;
        memory::check(&what, device, Some(limits.device.clone()))?;
    }
    Ok(())
}

/// Whether a GPU spec runs at `bounces` ([`Method::check_bounces`]); the grid skips it otherwise.
fn runs_at(spec: &MethodSpec, bounces: u32) -> bool {
    spec.kind
        .check_bounces(bounces, crate::vk::passes::bounce::MAX_BOUNCES, &spec.trace)
        .is_ok()
}

/// The reference frame of one scene, with its wall times per frame (ns).
pub struct ReferenceRun {
    pub frame: Frame,
    /// The whole frame.
    pub wall_ns: Vec<f64>,
    /// The reflected-ray phase alone ([`reference::PhaseTimes::reflected_ns`]).
    pub reflected_ns: Vec<f64>,
    /// First reflected rays per frame (the reference's mirror pixels).
    pub reflected_rays: usize,
}

/// Renders the CPU reference `warmup + frames` times (one bounce, [`reference::render_phased`])
/// and keeps the last frame.
pub fn run_reference(scene: &Scene, camera: &Camera, warmup: u32, frames: u32) -> ReferenceRun {
    run_reference_bounces(scene, camera, warmup, frames, 1)
}

/// [`run_reference`] with `bounces` reflections per path; the frame's hits are each path's last
/// ([`Frame::with_last_hits`]: what the GPU records hold).
pub fn run_reference_bounces(
    scene: &Scene,
    camera: &Camera,
    warmup: u32,
    frames: u32,
    bounces: u32,
) -> ReferenceRun {
    let tracer = reference::Tracer::new(scene);
    let (mut frame, _) = reference::render_phased(scene, &tracer, camera, bounces);
    for _ in 1..warmup {
        frame = reference::render_phased(scene, &tracer, camera, bounces).0;
    }
    let (mut wall_ns, mut reflected_ns) = (Vec::new(), Vec::new());
    let mut reflected_rays = 0;
    for _ in 0..frames.max(1) {
        let start = Instant::now();
        let (f, phases) = reference::render_phased(scene, &tracer, camera, bounces);
        wall_ns.push(start.elapsed().as_secs_f64() * 1e9);
        reflected_ns.push(phases.reflected_ns);
        reflected_rays = phases.reflected_rays;
        frame = f;
    }
    let frame = frame.with_last_hits(&tracer);
    ReferenceRun {
        frame,
        wall_ns,
        reflected_ns,
        reflected_rays,
    }
}

/// A GPU method's timed frames: the last frame, pass times per frame, CMO bytes.
pub struct GpuRun {
    pub frame: GpuFrame,
    pub pass_ns: Vec<Vec<PassTime>>,
    pub cmo_bytes: u64,
}

/// Renders `warmup` + `frames` frames of one GPU method, keeping the last frame.
pub fn run_gpu(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    method: Method,
    trace: TraceOptions,
    warmup: u32,
    frames: u32,
) -> Result<GpuRun> {
    let options = RenderOptions {
        method,
        trace,
        // The default fallback (`Fallback::Trace`, as the CLI's): PSNR and FLIP measure the
        // image a user would see. The pixels the method leaves unresolved are finished exactly by
        // the BVH, counted apart (the fallback share) and timed apart (the `fallback` pass); the
        // error figures (unresolved 0 %, wrong surface) are those of the final image.
        ..RenderOptions::default()
    };
    run_gpu_with(ctx, scene, camera, options, warmup, frames)
}

/// [`run_gpu`] with all the render options given.
pub fn run_gpu_with(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    options: RenderOptions,
    warmup: u32,
    frames: u32,
) -> Result<GpuRun> {
    let mut renderer = GpuRenderer::new(ctx, scene, camera, options)?;
    // Every timed frame is a whole frame, capture included (a renderer reuses its capture while
    // the scene stands still: `GpuRenderer::invalidate_capture`).
    for _ in 0..warmup {
        renderer.invalidate_capture();
        renderer.render(ctx)?;
    }
    let mut pass_ns = Vec::new();
    let mut last = None;
    for _ in 0..frames.max(1) {
        renderer.invalidate_capture();
        let f = renderer.render(ctx)?;
        pass_ns.push(f.pass_times.clone());
        last = Some(f);
    }
    let frame = last.context("no frame rendered")?;
    Ok(GpuRun {
        frame,
        pass_ns,
        cmo_bytes: renderer.cmo().bytes(),
    })
}

/// Statistics over frames of one pass's time (`Some(name)`) or of the sum of all passes.
pub fn frame_stats(pass_ns: &[Vec<PassTime>], pass: Option<&str>) -> Stats {
    let per_frame: Vec<f64> = pass_ns
        .iter()
        .map(|f| {
            f.iter()
                .filter(|(n, _)| pass.is_none_or(|p| p == n))
                .map(|(_, t)| t)
                .sum()
        })
        .collect();
    Stats::of(&per_frame).unwrap_or_default()
}

/// Per-pass statistics over frames, in the first frame's pass order.
pub fn pass_stats(pass_ns: &[Vec<PassTime>]) -> Vec<PassStats> {
    let Some(first) = pass_ns.first() else {
        return Vec::new();
    };
    first
        .iter()
        .filter_map(|(name, _)| {
            let v: Vec<f64> = pass_ns
                .iter()
                .map(|f| f.iter().filter(|(n, _)| n == name).map(|(_, t)| t).sum())
                .collect();
            Some(PassStats {
                pass: name.clone(),
                ns: Stats::of(&v)?,
            })
        })
        .collect()
}

/// FLIP mean (LDR) over the mirror pixels of either frame ([`metrics`]), on 8-bit sRGB images
/// of the whole frame; `None` when built without the `flip` feature.
#[cfg(not(feature = "flip"))]
pub fn flip_mean(_reference: &Frame, _traced: &Traced) -> Option<f64> {
    None
}

/// FLIP mean (LDR) over the mirror pixels of either frame ([`metrics`]), on 8-bit sRGB images
/// of the whole frame; `None` when built without the `flip` feature.
#[cfg(feature = "flip")]
pub fn flip_mean(reference: &Frame, traced: &Traced) -> Option<f64> {
    let srgb = |c: &[glam::Vec3]| -> Vec<u8> {
        c.iter()
            .flat_map(|c| c.to_array().map(crate::shading::linear_to_srgb))
            .collect()
    };
    let (w, h) = (reference.width, reference.height);
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &srgb(&reference.colour));
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &srgb(&traced.colour));
    let err = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec();
    let (sum, n) = err
        .iter()
        .enumerate()
        .filter(|(k, _)| reference.mask[*k] != 0 || traced.mask[*k] != 0)
        .fold((0f64, 0usize), |(s, n), (_, e)| (s + f64::from(*e), n + 1));
    Some(if n == 0 { 0.0 } else { sum / n as f64 })
}

/// Runs the grid, advancing `bar` by one per reference and per GPU run (indicatif hides it
/// off a terminal).
pub fn run(
    ctx: &GpuContext,
    cfg: &BenchConfig,
    bar: &indicatif::ProgressBar,
) -> Result<BenchReport> {
    if cfg.methods.is_empty() || cfg.scenes.is_empty() {
        bail!("nothing to run: no scenes or no methods chosen");
    }
    bar.set_length(planned_steps(cfg));
    // Every scene is loaded and checked before anything renders.
    let placements = if cfg.placements.is_empty() {
        vec![BenchPlacement::Scene]
    } else {
        cfg.placements.clone()
    };
    let several = placements.len() > 1;
    let search = cfg.methods.iter().any(|m| m.kind.captures_cmos());
    let mut labels = Vec::new();
    let mut prepared = Vec::new();
    let mut search_ms = Vec::new();
    for name in &cfg.scenes {
        for &p in &placements {
            let overrides = (cfg.cube_size, cfg.cmos);
            let (scene, camera, searched) =
                prepare_scene_placed(name, cfg.width, cfg.height, overrides, p, search)?;
            labels.push(p.label(name, several));
            prepared.push((scene, camera));
            search_ms.push(searched.map(|s| s.time.as_secs_f64() * 1e3));
        }
    }
    let limits = memory::Limits::of_device(ctx.device_local_heap_bytes(), ctx.device_is_cpu())?;
    check_memory(cfg, &prepared, &limits)?;
    let mut runs = Vec::new();
    // Heat map paths given so far: two scenes of one (sanitised) name get their own files.
    let mut heat_paths: Vec<String> = Vec::new();
    for ((name, (mut scene, camera)), search_ms) in labels.iter().zip(prepared).zip(search_ms) {
        if several {
            scene.name = name.clone();
        }
        bar.set_message(format!("{name}: reference"));
        // The reference is needed for every error figure, even when it is not a listed method.
        let refr = run_reference_bounces(&scene, &camera, cfg.warmup, cfg.frames, cfg.bounces);
        bar.inc(1);
        let sc = SceneRuns::new(name, &scene, &camera, refr);
        for spec in &cfg.methods {
            if !spec.kind.is_gpu() {
                runs.push(sc.reference_result(cfg, spec));
                continue;
            }
            if !runs_at(spec, cfg.bounces) {
                log::warn!(
                    "{name}: {} traces one reflection: skipped at --bounces {}",
                    spec.label(),
                    cfg.bounces
                );
                bar.inc(1);
                continue;
            }
            let mut run = sc.gpu_result(ctx, cfg, bar, spec, &mut heat_paths)?;
            if spec.kind.captures_cmos() {
                run.placement_ms = search_ms;
            }
            runs.push(run);
            bar.inc(1);
            check_validation(ctx)?;
        }
    }
    Ok(BenchReport {
        device: DeviceInfo::of(ctx),
        git_commit: git_commit(),
        cubetrace_version: env!("CARGO_PKG_VERSION"),
        cpu_threads: rayon::current_num_threads(),
        driver_threads: driver_threads(),
        warmup: cfg.warmup,
        bounces: cfg.bounces,
        ratios: SceneRatios::of(&runs),
        runs,
        model: None,
    })
}

/// The progress bar's length: per scene the reference, each GPU run and each floor run.
fn planned_steps(cfg: &BenchConfig) -> u64 {
    let placements = cfg.placements.len().max(1);
    let gpu_methods = cfg.methods.iter().filter(|m| m.kind.is_gpu()).count();
    let floor_runs = match cfg.floor {
        Some(_) => cfg
            .methods
            .iter()
            .filter(|m| m.kind.is_gpu() && **m == MethodSpec::plain(m.kind))
            .count(),
        None => 0,
    };
    (cfg.scenes.len() * placements * (1 + gpu_methods + floor_runs)) as u64
}

/// One scene's runs: the scene, its reference frame and the figures every run of it repeats.
struct SceneRuns<'a> {
    /// The name the scene was given by (`--scenes`), for messages.
    name: &'a str,
    scene: &'a Scene,
    camera: &'a Camera,
    refr: ReferenceRun,
    centres: Vec<glam::Vec3>,
    /// Per object of the scene's world: whether it is a reflector.
    reflector: Vec<bool>,
    triangles: usize,
    /// The reference's mirror pixels.
    mirror: usize,
}

impl<'a> SceneRuns<'a> {
    fn new(name: &'a str, scene: &'a Scene, camera: &'a Camera, refr: ReferenceRun) -> Self {
        let world = scene.world();
        SceneRuns {
            name,
            scene,
            camera,
            centres: scene.cmo_centres(),
            reflector: world.objects.iter().map(|o| o.reflector).collect(),
            triangles: world.triangles.len(),
            mirror: refr.frame.mirror_pixels(),
            refr,
        }
    }

    /// The figures of a run that do not depend on its frames (the rest zero).
    fn base(&self, cfg: &BenchConfig, spec: &MethodSpec) -> RunResult {
        RunResult {
            scene: self.scene.name.clone(),
            method: spec.label(),
            kind: spec.kind,
            params: if spec.kind.traces_cubemaps() {
                let t = &spec.trace;
                format!(
                    "criterion={} sampling={} accel={} steps={} eps={}",
                    crate::method::criterion_name(t.criterion),
                    crate::method::sampling_name(t.sampling),
                    t.accel,
                    t.steps,
                    t.eps
                )
            } else {
                String::new()
            },
            width: cfg.width,
            height: cfg.height,
            cube_size: self.scene.cmo.resolution,
            cmos: self.centres.len() as u32,
            triangles: self.triangles,
            mirror_pixels: self.mirror,
            rays: 0,
            frames: cfg.frames.max(1),
            passes: Vec::new(),
            trace_ns: Stats::default(),
            total_ns: Stats::default(),
            fallback_share: 0.0,
            fallback_ns: Stats::default(),
            checked_share: 0.0,
            check_ns: Stats::default(),
            trace_ns_per_mirror_px: 0.0,
            ns_per_ray: 0.0,
            floor: None,
            counters: Counters::default(),
            cmo_bytes: 0,
            error: ErrorReport::default(),
            wrong_off_reflector: 0.0,
            flip_mean: None,
            heatmap: None,
            placement_ms: None,
        }
    }

    /// The reference's row: its wall times, exact by definition.
    fn reference_result(&self, cfg: &BenchConfig, spec: &MethodSpec) -> RunResult {
        let refr = &self.refr;
        let wall = Stats::of(&refr.wall_ns).unwrap_or_default();
        let reflected = Stats::of(&refr.reflected_ns).unwrap_or_default();
        RunResult {
            rays: refr.reflected_rays,
            trace_ns: reflected,
            total_ns: wall,
            trace_ns_per_mirror_px: reflected.median / self.mirror.max(1) as f64,
            ns_per_ray: reflected.median / refr.reflected_rays.max(1) as f64,
            error: ErrorReport::exact(self.mirror),
            ..self.base(cfg, spec)
        }
    }

    /// One GPU run of `spec` (on the subdivided scene where it asks for one): its timed frames,
    /// the floor run, the error of its last frame against the reference and its heat map.
    fn gpu_result(
        &self,
        ctx: &GpuContext,
        cfg: &BenchConfig,
        bar: &indicatif::ProgressBar,
        spec: &MethodSpec,
        heat_paths: &mut Vec<String>,
    ) -> Result<RunResult> {
        let (name, label) = (self.name, spec.label());
        bar.set_message(format!("{name}: {label}"));
        let subdivided;
        let scene = if spec.subdivide > 0 {
            let mut s = self.scene.clone();
            crate::cpu::reflection_point::subdivide_non_reflectors(&mut s, spec.subdivide);
            subdivided = s;
            &subdivided
        } else {
            self.scene
        };
        let options = spec.render_options(cfg.bounces, cfg.reflector_check);
        let g = run_gpu_with(ctx, scene, self.camera, options, cfg.warmup, cfg.frames)
            .with_context(|| format!("scene '{name}', method {label}"))?;
        let traced = g.frame.traced();
        let refr = &self.refr.frame;
        let (position, resolution) = (&g.frame.surface_position, scene.cmo.resolution);
        let pixels = metrics::classify(refr, &traced, position, &self.centres, resolution);
        let error = metrics::compare(refr, &traced, position, &self.centres, resolution);
        let passes = pass_stats(&g.pass_ns);
        let trace_ns = frame_stats(&g.pass_ns, Some(pass_name(spec.kind)));
        let floor = self.floor_run(ctx, cfg, bar, scene, spec, trace_ns)?;
        let rays = g.frame.mirror_pixels();
        let heatmap = if cfg.heatmaps {
            Some(write_heatmap(
                cfg,
                &scene.name,
                &label,
                refr,
                &pixels,
                heat_paths,
            )?)
        } else {
            None
        };
        Ok(RunResult {
            fallback_ns: optional_pass(&g.pass_ns, &passes, crate::vk::frame::FALLBACK_PASS),
            check_ns: optional_pass(&g.pass_ns, &passes, crate::vk::frame::REFLECTOR_CHECK_PASS),
            passes,
            trace_ns,
            total_ns: frame_stats(&g.pass_ns, None),
            fallback_share: g.frame.fallback_pixels() as f64 / rays.max(1) as f64,
            checked_share: g.frame.checked_pixels() as f64 / rays.max(1) as f64,
            trace_ns_per_mirror_px: trace_ns.median / self.mirror.max(1) as f64,
            rays,
            ns_per_ray: trace_ns.median / rays.max(1) as f64,
            floor,
            counters: Counters::of(&g.frame),
            cmo_bytes: g.cmo_bytes,
            error,
            wrong_off_reflector: metrics::wrong_surface_off_reflector(
                refr,
                &self.reflector,
                &pixels,
            ),
            flip_mean: if cfg.flip {
                flip_mean(refr, &traced)
            } else {
                None
            },
            heatmap,
            triangles: scene.world().triangles.len(),
            ..self.base(cfg, spec)
        })
    }

    /// The floor run ([`BenchConfig::floor`]) of a GPU method's default setting, against the
    /// full frame's tracing pass `trace_ns`; `None` for the other settings or without a floor.
    fn floor_run(
        &self,
        ctx: &GpuContext,
        cfg: &BenchConfig,
        bar: &indicatif::ProgressBar,
        scene: &Scene,
        spec: &MethodSpec,
        trace_ns: Stats,
    ) -> Result<Option<FloorRun>> {
        let Some((w, h)) = cfg.floor.filter(|_| *spec == MethodSpec::plain(spec.kind)) else {
            return Ok(None);
        };
        let (name, label, gpu) = (self.name, spec.label(), spec.kind);
        bar.set_message(format!("{name}: {label} at {w}x{h}"));
        let small = Camera {
            width: w,
            height: h,
            ..self.camera.clone()
        };
        let f = run_gpu(ctx, scene, &small, gpu, spec.trace, cfg.warmup, cfg.frames)
            .with_context(|| format!("scene '{name}', method {label} at {w}x{h}"))?;
        let small_ns = frame_stats(&f.pass_ns, Some(pass_name(gpu)));
        bar.inc(1);
        Ok(Some(FloorRun {
            width: w,
            height: h,
            rays: f.frame.mirror_pixels(),
            trace_ns: small_ns,
            ratio: small_ns.median / trace_ns.median,
        }))
    }
}

/// Writes a run's heat map under `cfg.out` as `heat/SCENE-LABEL.png`, numbered (`-2`, `-3`, ...)
/// where an earlier run of `heat_paths` took the name; returns the path relative to `cfg.out`.
fn write_heatmap(
    cfg: &BenchConfig,
    scene_name: &str,
    label: &str,
    reference: &Frame,
    pixels: &[PixelError],
    heat_paths: &mut Vec<String>,
) -> Result<String> {
    // The scene's name comes from its file: only a sanitised form enters the path.
    let stem = format!("{}-{label}", crate::output::safe_file_stem(scene_name));
    let mut rel = format!("heat/{stem}.png");
    let mut k = 2;
    while heat_paths.contains(&rel) {
        rel = format!("heat/{stem}-{k}.png");
        k += 1;
    }
    heat_paths.push(rel.clone());
    heatmap::write(&cfg.out.join(&rel), reference, pixels)?;
    Ok(rel)
}

/// [`frame_stats`] of the pass `name` where it ran (it is in `passes`), else zero.
fn optional_pass(pass_ns: &[Vec<PassTime>], passes: &[PassStats], name: &str) -> Stats {
    if passes.iter().any(|p| p.pass == name) {
        frame_stats(pass_ns, Some(name))
    } else {
        Stats::default()
    }
}

/// Fails if the validation layer (when on) reported errors.
pub fn check_validation(ctx: &GpuContext) -> Result<()> {
    let errors = ctx.validation_errors();
    if !errors.is_empty() {
        bail!(
            "the validation layer reported errors:\n{}",
            errors.join("\n")
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_median_min_max() {
        let s = Stats::of(&[3.0, 1.0, 2.0]).unwrap();
        assert_eq!((s.median, s.min, s.max), (2.0, 1.0, 3.0));
        let s = Stats::of(&[4.0, 1.0, 2.0, 3.0]).unwrap();
        assert_eq!(s.median, 2.5);
        assert!(Stats::of(&[]).is_none());
    }

    #[test]
    fn labels_are_unique_across_the_grid() {
        let grid = method_grid(&Method::ALL, false);
        let mut labels: Vec<String> = grid.iter().map(MethodSpec::label).collect();
        let n = labels.len();
        labels.sort();
        labels.dedup();
        assert_eq!(labels.len(), n, "{labels:?}");
        assert!(labels.contains(&"fragment-exact-mip".to_string()));
        assert!(labels.contains(&"fragment-sign-angle256".to_string()));
        // Negative: two specs differing only in steps must get different labels.
        let a = fragment_grid(Method::Fragment)[4];
        let mut b = a;
        b.trace.steps += 1;
        assert_ne!(a.label(), b.label());
    }

    #[test]
    fn method_names_round_trip() {
        for m in Method::ALL {
            assert_eq!(Method::from_name(m.name()), Some(m));
        }
        assert_eq!(Method::from_name("raytrace"), None);
    }

    fn run(scene: &str, kind: Method, ns: f64, rays: usize, floor: Option<f64>) -> RunResult {
        RunResult {
            scene: scene.into(),
            method: MethodSpec::plain(kind).label(),
            kind,
            params: String::new(),
            width: 160,
            height: 120,
            cube_size: 256,
            cmos: 1,
            triangles: 1,
            mirror_pixels: rays,
            rays,
            frames: 1,
            passes: Vec::new(),
            trace_ns: Stats {
                median: ns,
                min: ns,
                max: ns,
            },
            total_ns: Stats::default(),
            fallback_share: 0.0,
            fallback_ns: Stats::default(),
            checked_share: 0.0,
            check_ns: Stats::default(),
            trace_ns_per_mirror_px: ns / rays as f64,
            ns_per_ray: ns / rays as f64,
            floor: floor.map(|ratio| FloorRun {
                width: 16,
                height: 12,
                rays: 1,
                trace_ns: Stats::default(),
                ratio,
            }),
            counters: Counters::default(),
            cmo_bytes: 0,
            error: ErrorReport::default(),
            wrong_off_reflector: 0.0,
            flip_mean: None,
            heatmap: None,
            placement_ms: None,
        }
    }

    #[test]
    fn scene_ratios_pair_the_default_settings_per_scene() {
        let mut strict = run("a", Method::Fragment, 1.0, 100, None);
        strict.method = "fragment-exact-mip-strict".into();
        let runs = vec![
            run("a", Method::Reference, 1000.0, 100, None),
            strict,
            run("a", Method::Fragment, 4000.0, 100, Some(0.5)),
            run("a", Method::Compute, 2000.0, 50, Some(0.1)),
            run("b", Method::Compute, 1.0, 1, None),
        ];
        let r = SceneRatios::of(&runs);
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].scene, "a");
        assert_eq!(r[0].reference_ns_per_ray, Some(10.0));
        assert_eq!(r[0].fragment_ns_per_ray, Some(40.0), "not the strict run");
        assert_eq!(
            r[0].compute_ns_per_ray,
            Some(40.0),
            "per the method's own rays"
        );
        assert_eq!(r[0].fragment_over_reference, Some(4.0));
        assert_eq!(r[0].compute_over_reference, Some(4.0));
        assert_eq!(r[0].compute_over_fragment, Some(1.0));
        assert_eq!(
            (r[0].fragment_floor, r[0].compute_floor),
            (Some(0.5), Some(0.1))
        );
        // Scene b ran no reference and no fragment: no ratio is made up.
        assert_eq!(r[1].compute_ns_per_ray, Some(1.0));
        assert_eq!(r[1].compute_over_reference, None);
        assert_eq!(r[1].compute_over_fragment, None);
    }

    #[test]
    fn pass_stats_per_pass() {
        let f = |a: f64, b: f64| vec![("capture".to_string(), a), ("envmap".to_string(), b)];
        let s = pass_stats(&[f(1.0, 10.0), f(3.0, 30.0), f(2.0, 20.0)]);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].pass, "capture");
        assert_eq!((s[0].ns.median, s[0].ns.min, s[0].ns.max), (2.0, 1.0, 3.0));
        assert_eq!(s[1].ns.median, 20.0);
    }
}

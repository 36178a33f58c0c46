#![forbid(unsafe_code)]
//! `cubetrace bench --glossy`: speed against error on glossy reflectors.
//!
//! For every scene and every specular power, the scene's reflectors are made glossy
//! ([`Scene::make_reflectors_glossy`]) and three kinds of image are measured against one truth:
//!
//! - **The converged reference**: the CPU reference's Monte Carlo integral of the Phong lobe at
//!   [`GlossyConfig::reference_spp`] samples per pixel ([`reference_frame`]). Its own
//!   convergence is stated: the PSNR
//!   of the frame of its even-numbered samples (half the samples) against it. For an unbiased
//!   estimator the difference of the two, `(odd - even) / 2`, has the variance of the full
//!   frame's own error, so this figure estimates the converged frame's PSNR against the exact
//!   integral (without rendering anything more). Its wall time is reported: it is the cost of
//!   the truth, not of a method.
//! - **Every requested GPU method but `bvh`, once**: its deterministic image at the pixel centre.
//!   A method that traces the mirror direction only is marked [`Tracing::Mirror`] (where the
//!   commands warn so, [`method_warning`]), one that traces the cone [`Tracing::Cone`].
//! - **`bvh` Monte Carlo at a ladder of spp** ([`crate::render::glossy::mc_frame`]), one
//!   renderer per scene and power ([`TimedRenderer`]).
//!
//! Where the samples lie ([`GlossyConfig::film`]): by default every sample is at the pixel
//! centre and only the lobe is sampled (sample keys [`lobe::sample_key`]), so that the truth is
//! the lobe's integral at the pixel centre, which is what a cone method approximates, and the
//! Monte Carlo ladder converges to it. With `film` (`--glossy-film`) the samples are the film's
//! jittered ones (box filter), bit for bit the frames of `cubetrace reference --spp N` and
//! `render --method bvh --spp N`: the truth then also integrates the pixel's footprint, which no
//! one-sample method renders, and on small frames that aliasing dominates every one-sample
//! method's error (at 32x24, every mirror-only method scored 14 to 18 dB on sphere-room and
//! teapot at power 16 and at power 256 alike, however close its lobe), so the default leaves it
//! out. At one sample both placements are the commands' frame.
//!
//! Per row: the PSNR over the reference's mirror pixels (linear RGB clamped to [0, 1], as
//! `tests/glossy.rs`), the cost per frame (the median over the timed frames of the GPU
//! timestamps summed over the frame's passes and, for Monte Carlo, over its samples: capture
//! included, every timed frame captures), the tracing pass per mirror pixel, and the pass list.
//! Per cone or mirror row, against the ladder: the cheapest `bvh` row that costs at least as
//! much per frame ([`cheapest_at_least`]) and whether the method beats its PSNR; the same
//! for the method's frame without its CMO stages ([`CMO_STAGES`]: capture, pyramids, the
//! pre-filter), which a frame skips while its scene is unchanged (a still scene rendered again,
//! a sequence where only the camera moves) and whose cost does not grow with the frame's size,
//! so that at a small frame they dominate the first comparison; and the spp at
//! which `bvh` would reach the method's PSNR, interpolated linearly in log spp
//! ([`spp_of_psnr`]), where the ladder brackets it.
//!
//! What it approximates: the "truth" is itself a Monte Carlo estimate (its half-spp figure says
//! how close); the ladder's cost is the sum of its samples' passes as `render --spp` runs them
//! (one submit per sample), not a many-samples-per-dispatch kernel.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use glam::Vec3;
use serde::Serialize;

use super::{DeviceInfo, MethodSpec, PassStats, Stats, git_commit, pass_stats};
use crate::Method;
use crate::camera::Camera;
use crate::files::write_atomic;
use crate::lobe::{self, MIRROR_POWER};
use crate::metrics::psnr_over;
use crate::reference::{self, Tracer};
use crate::render::checks::check_validation;
use crate::render::glossy::{method_warning, reference_frame};
use crate::render::timed::TimedRenderer;
use crate::scene::Scene;
use crate::vk::frame::pass_name;
use crate::vk::{GpuContext, PassTime};

/// The default specular powers: cones of about 23, 12 and 6 degrees ([`lobe::cone_half_angle`]).
pub const DEFAULT_POWERS: [f32; 3] = [16.0, 64.0, 256.0];
/// The default samples per pixel of the converged reference.
pub const DEFAULT_REFERENCE_SPP: u32 = 1024;
/// The default `bvh` Monte Carlo ladder.
pub const DEFAULT_SPP: [u32; 7] = [1, 2, 4, 8, 16, 32, 64];

/// What a `--glossy` run renders.
#[derive(Clone, Debug)]
pub struct GlossyConfig {
    pub scenes: Vec<String>,
    /// Specular powers, each in `[0, MIRROR_POWER)` ([`check_powers`]).
    pub powers: Vec<f32>,
    /// The GPU methods rendered once per scene and power (`bvh` and the CPU reference are left
    /// out: `bvh` runs the ladder, the reference is the truth).
    pub methods: Vec<Method>,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub warmup: u32,
    pub cube_size: Option<u32>,
    pub cmos: Option<u32>,
    pub reflector_check: bool,
    /// Samples per pixel of the converged reference (at least 2: its half is stated).
    pub reference_spp: u32,
    /// The `bvh` ladder, increasing.
    pub spp: Vec<u32>,
    /// Samples at the film's jittered offsets (as `render --spp`) instead of all at the pixel
    /// centre (module docs).
    pub film: bool,
}

/// How a row's image treats the lobe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tracing {
    /// `bvh`: samples the lobe, `spp` samples per pixel.
    MonteCarlo,
    /// A method that traces the lobe's cone.
    Cone,
    /// A method that traces the mirror direction only (it warns): a glossy reflector shows as
    /// a mirror.
    Mirror,
}

impl Tracing {
    pub fn name(self) -> &'static str {
        match self {
            Tracing::MonteCarlo => "monte-carlo",
            Tracing::Cone => "cone",
            Tracing::Mirror => "mirror only",
        }
    }
}

/// The converged reference of one scene and power.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceInfo {
    pub scene: String,
    pub power: f32,
    pub spp: u32,
    pub mirror_pixels: usize,
    /// Wall time of the reference's frame (CPU, every thread), seconds.
    pub wall_s: f64,
    /// PSNR of the frame of its even-numbered samples against it (module docs: an estimate of
    /// the converged frame's own PSNR against the exact integral).
    pub half_spp_psnr_db: f64,
}

/// A `bvh` ladder row as the comparison sees it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LadderPoint {
    pub spp: u32,
    /// Median cost per frame, ns.
    pub frame_ns: f64,
    pub psnr_db: f64,
}

/// A cone or mirror row against the `bvh` ladder of its scene and power.
#[derive(Clone, Debug, Serialize)]
pub struct Versus {
    /// The cheapest ladder row of at least the method's frame cost (`None`: the ladder's
    /// dearest row is cheaper than the method).
    pub same_cost: Option<LadderPoint>,
    /// Whether the method's PSNR is above that row's.
    pub beats_same_cost: Option<bool>,
    /// The spp at which `bvh` reaches the method's PSNR, interpolated in log spp (`None`
    /// outside the ladder).
    pub same_psnr_spp: Option<f64>,
    /// That spp's frame cost, interpolated in log cost, ns.
    pub same_psnr_frame_ns: Option<f64>,
    /// As `same_cost`, for the method's frame without its CMO stages
    /// ([`GlossyRow::reused_frame_ns`]).
    pub same_cost_reused: Option<LadderPoint>,
    /// Whether the method's PSNR is above that row's.
    pub beats_same_cost_reused: Option<bool>,
}

/// One scene x power x method (x spp for `bvh`).
#[derive(Clone, Debug, Serialize)]
pub struct GlossyRow {
    pub scene: String,
    pub power: f32,
    /// [`lobe::cone_half_angle`], degrees.
    pub cone_deg: f64,
    pub method: String,
    pub tracing: Tracing,
    /// Samples per pixel (1 for the methods rendered once).
    pub spp: u32,
    /// The reference's mirror pixels: the pixels PSNR is taken over.
    pub mirror_pixels: usize,
    pub psnr_db: f64,
    /// Sum over the frame's passes (and samples), over the timed frames, ns.
    pub frame_ns: Stats,
    /// The same without the CMO stages ([`CMO_STAGES`]), ns: a frame whose scene has not
    /// changed since the last capture (a still scene, a sequence where only the camera moves)
    /// skips them, and their cost does not grow with the frame's pixels.
    pub reused_frame_ns: Stats,
    /// The tracing pass ([`pass_name`]), summed over the frame's samples, ns.
    pub trace_ns: Stats,
    /// `trace_ns.median` per mirror pixel of the reference.
    pub trace_ns_per_mirror_px: f64,
    /// Per pass (summed over the frame's samples), in recording order.
    pub passes: Vec<PassStats>,
    /// Cone and mirror rows only.
    pub versus_bvh: Option<Versus>,
}

/// A `--glossy` run.
#[derive(Clone, Debug, Serialize)]
pub struct GlossyReport {
    pub device: DeviceInfo,
    pub git_commit: Option<String>,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub warmup: u32,
    pub powers: Vec<f32>,
    pub reference_spp: u32,
    pub spp: Vec<u32>,
    /// Where the samples lie: `centre` (the lobe alone) or `film` (module docs).
    pub samples_at: &'static str,
    pub references: Vec<ReferenceInfo>,
    pub rows: Vec<GlossyRow>,
}

/// Checks `--glossy`'s powers: at least one, each a finite number in `[0, 1024)` (1024 and
/// above is a mirror, which the grid measures), none twice.
pub fn check_powers(powers: &[f32]) -> Result<()> {
    if powers.is_empty() {
        bail!("--glossy: no specular power given (e.g. --glossy 16,64,256)");
    }
    for (k, &p) in powers.iter().enumerate() {
        if !p.is_finite() || p < 0.0 {
            bail!(
                "--glossy: {p} is not a specular power (a finite number from 0 up to, not \
                 including, {MIRROR_POWER})"
            );
        }
        if p >= MIRROR_POWER {
            bail!(
                "--glossy: {p} is a mirror (a specular power of {MIRROR_POWER} or more renders \
                 the perfect mirror, which the grid without --glossy measures): give powers below \
                 {MIRROR_POWER}"
            );
        }
        if powers[..k].contains(&p) {
            bail!("--glossy: power {p} is listed twice");
        }
    }
    Ok(())
}

/// Checks `--glossy-spp`: at least one, increasing, each in `1..=MAX_SPP`.
pub fn check_ladder(spp: &[u32]) -> Result<()> {
    if spp.is_empty() {
        bail!("--glossy-spp: no sample count given (e.g. --glossy-spp 1,2,4,8)");
    }
    for (k, &n) in spp.iter().enumerate() {
        if n == 0 || n > crate::film::MAX_SPP {
            bail!(
                "--glossy-spp: {n} is not a sample count (1 to {})",
                crate::film::MAX_SPP
            );
        }
        if k > 0 && n <= spp[k - 1] {
            bail!(
                "--glossy-spp: the counts must increase ({} then {n})",
                spp[k - 1]
            );
        }
    }
    Ok(())
}

/// The passes that fill and pre-filter the CMOs ([`crate::vk::frame::GpuRenderer`]'s CMO
/// stages): they run on a frame whose scene changed since the last capture, and not on the
/// others.
pub const CMO_STAGES: [&str; 5] = [
    "capture",
    "cone_prefilter",
    "pyramid",
    "hier32",
    "cone_pyramid",
];

/// [`super::frame_stats`] over the passes other than [`CMO_STAGES`].
fn reused_stats(pass_ns: &[Vec<PassTime>]) -> Stats {
    let per_frame: Vec<f64> = (pass_ns.iter())
        .map(|f| {
            (f.iter())
                .filter(|(n, _)| !CMO_STAGES.contains(&n.as_str()))
                .map(|(_, t)| t)
                .sum()
        })
        .collect();
    Stats::of(&per_frame).unwrap_or_default()
}

/// The cheapest ladder point whose frame costs at least `frame_ns` (`None` where none does).
pub fn cheapest_at_least(ladder: &[LadderPoint], frame_ns: f64) -> Option<LadderPoint> {
    ladder
        .iter()
        .filter(|p| p.frame_ns >= frame_ns)
        .min_by(|a, b| a.frame_ns.total_cmp(&b.frame_ns))
        .copied()
}

/// The spp (and frame cost) at which the ladder (in increasing spp) reaches `psnr_db`: on the
/// first segment whose ends bracket it, linear in PSNR against log spp and log cost. `None`
/// where no segment brackets it (below the first row or above every row) or it is not finite.
pub fn spp_of_psnr(ladder: &[LadderPoint], psnr_db: f64) -> Option<(f64, f64)> {
    if !psnr_db.is_finite() {
        return None;
    }
    if let Some(p) = ladder.iter().find(|p| p.psnr_db == psnr_db) {
        return Some((f64::from(p.spp), p.frame_ns));
    }
    ladder.windows(2).find_map(|w| {
        let (a, b) = (w[0], w[1]);
        let (lo, hi) = (a.psnr_db.min(b.psnr_db), a.psnr_db.max(b.psnr_db));
        if !(lo < psnr_db && psnr_db < hi) {
            return None;
        }
        let t = (psnr_db - a.psnr_db) / (b.psnr_db - a.psnr_db);
        let lerp_log = |x: f64, y: f64| (x.ln() + t * (y.ln() - x.ln())).exp();
        Some((
            lerp_log(f64::from(a.spp), f64::from(b.spp)),
            lerp_log(a.frame_ns, b.frame_ns),
        ))
    })
}

/// A method's row against the ladder.
pub fn versus(ladder: &[LadderPoint], frame_ns: f64, reused_ns: f64, psnr_db: f64) -> Versus {
    let same_cost = cheapest_at_least(ladder, frame_ns);
    let same_cost_reused = cheapest_at_least(ladder, reused_ns);
    let same_psnr = spp_of_psnr(ladder, psnr_db);
    Versus {
        same_cost,
        beats_same_cost: same_cost.map(|p| psnr_db > p.psnr_db),
        same_psnr_spp: same_psnr.map(|s| s.0),
        same_psnr_frame_ns: same_psnr.map(|s| s.1),
        same_cost_reused,
        beats_same_cost_reused: same_cost_reused.map(|p| psnr_db > p.psnr_db),
    }
}

/// The figures every row of one scene and power shares.
struct Case<'a> {
    name: &'a str,
    scene: Scene,
    camera: &'a Camera,
    power: f32,
    truth: reference::Frame,
}

impl Case<'_> {
    /// A row of `method` from its colour and timed frames' passes.
    fn row(
        &self,
        method: Method,
        tracing: Tracing,
        spp: u32,
        colour: &[Vec3],
        pass_ns: &[Vec<PassTime>],
    ) -> GlossyRow {
        let mirror = self.truth.mirror_pixels();
        let trace_ns = super::frame_stats(pass_ns, Some(pass_name(method)));
        GlossyRow {
            scene: self.scene.name.clone(),
            power: self.power,
            cone_deg: f64::from(lobe::cone_half_angle(self.power)).to_degrees(),
            method: MethodSpec::plain(method).label(),
            tracing,
            spp,
            mirror_pixels: mirror,
            psnr_db: psnr_over(colour, &self.truth.colour, &self.truth.mask),
            frame_ns: super::frame_stats(pass_ns, None),
            reused_frame_ns: reused_stats(pass_ns),
            trace_ns,
            trace_ns_per_mirror_px: trace_ns.median / mirror.max(1) as f64,
            passes: pass_stats(pass_ns),
            versus_bvh: None,
        }
    }

    /// The `bvh` ladder: one renderer, `warmup` + `frames` Monte Carlo frames per rung.
    fn ladder(
        &self,
        ctx: &GpuContext,
        cfg: &GlossyConfig,
        tick: &dyn Fn(&str),
    ) -> Result<Vec<GlossyRow>> {
        let options = MethodSpec::plain(Method::EXACT_GPU).render_options(1, cfg.reflector_check);
        let mut renderer = TimedRenderer::new(ctx, &self.scene, self.camera, options)
            .with_context(|| format!("scene '{}', method bvh", self.name))?;
        let mut rows = Vec::new();
        for &spp in &cfg.spp {
            tick(&format!(
                "{}: power {}: bvh at {spp} spp",
                self.name, self.power
            ));
            let mut pass_ns = Vec::new();
            let mut colour = Vec::new();
            for k in 0..cfg.warmup + cfg.frames.max(1) {
                let (c, p) = renderer.mc_frame(&self.scene, self.camera, spp, cfg.film)?;
                if k >= cfg.warmup {
                    pass_ns.push(p);
                }
                colour = c;
            }
            rows.push(self.row(
                Method::EXACT_GPU,
                Tracing::MonteCarlo,
                spp,
                &colour,
                &pass_ns,
            ));
            check_validation(ctx)?;
        }
        Ok(rows)
    }

    /// `method` rendered once per timed frame (capture included), its last frame's colour.
    fn method_row(
        &self,
        ctx: &GpuContext,
        cfg: &GlossyConfig,
        method: Method,
        tracing: Tracing,
    ) -> Result<GlossyRow> {
        let options = MethodSpec::plain(method).render_options(1, cfg.reflector_check);
        let g = super::run_gpu_with(
            ctx,
            &self.scene,
            self.camera,
            options,
            cfg.warmup,
            cfg.frames,
        )
        .with_context(|| format!("scene '{}', method {method}", self.name))?;
        check_validation(ctx)?;
        Ok(self.row(method, tracing, 1, &g.frame.colour, &g.pass_ns))
    }
}

/// The steps [`run`] reports through `tick`: per scene and power the reference, each method and
/// each rung of the ladder.
pub fn planned_steps(cfg: &GlossyConfig) -> u64 {
    (cfg.scenes.len() * cfg.powers.len() * (1 + cfg.methods.len() + cfg.spp.len())) as u64
}

/// Runs `--glossy`: every scene x power (module docs). A method traces the mirror direction
/// only where the commands warn so ([`crate::render::glossy::method_warning`] at one bounce);
/// `tick` is called before each step with what it renders.
pub fn run(ctx: &GpuContext, cfg: &GlossyConfig, tick: &dyn Fn(&str)) -> Result<GlossyReport> {
    check_powers(&cfg.powers)?;
    check_ladder(&cfg.spp)?;
    if cfg.scenes.is_empty() {
        bail!("--glossy: no scene to run");
    }
    if cfg.reference_spp < 2 {
        bail!("--glossy-reference-spp: at least 2 (its half-spp frame is stated)");
    }
    if let Some(m) = cfg
        .methods
        .iter()
        .find(|m| !m.is_gpu() || **m == Method::EXACT_GPU)
    {
        bail!(
            "--glossy: {m} is not a method rendered once (bvh runs the ladder, the reference is the truth)"
        );
    }
    let prepared = (cfg.scenes.iter())
        .map(|name| {
            super::prepare_scene(name, cfg.width, cfg.height, cfg.cube_size, cfg.cmos)
                .with_context(|| format!("--scenes {name}"))
        })
        .collect::<Result<Vec<_>>>()?;
    check_memory(ctx, cfg, &prepared)?;
    let (mut references, mut rows) = (Vec::new(), Vec::new());
    for (name, (scene, camera)) in cfg.scenes.iter().zip(&prepared) {
        if !scene.meshes.iter().any(|m| m.reflector) {
            bail!("--glossy: scene '{name}' has no reflector to make glossy");
        }
        for &power in &cfg.powers {
            let mut glossy = scene.clone();
            glossy.make_reflectors_glossy(power);
            tick(&format!("{name}: power {power}: reference"));
            let tracer = Tracer::new(&glossy);
            let start = Instant::now();
            let (truth, half) =
                reference_frame(&glossy, &tracer, camera, cfg.reference_spp, cfg.film);
            let wall_s = start.elapsed().as_secs_f64();
            if truth.mirror_pixels() == 0 {
                bail!(
                    "--glossy: scene '{name}' shows no reflector at {}x{}",
                    cfg.width,
                    cfg.height
                );
            }
            references.push(ReferenceInfo {
                scene: glossy.name.clone(),
                power,
                spp: cfg.reference_spp,
                mirror_pixels: truth.mirror_pixels(),
                wall_s,
                half_spp_psnr_db: psnr_over(&half, &truth.colour, &truth.mask),
            });
            let case = Case {
                name,
                scene: glossy,
                camera,
                power,
                truth,
            };
            rows.extend(case_rows(ctx, cfg, &case, tick)?);
        }
    }
    Ok(GlossyReport {
        device: DeviceInfo::of(ctx),
        git_commit: git_commit(),
        width: cfg.width,
        height: cfg.height,
        frames: cfg.frames.max(1),
        warmup: cfg.warmup,
        powers: cfg.powers.clone(),
        reference_spp: cfg.reference_spp,
        spp: cfg.spp.clone(),
        samples_at: if cfg.film { "film" } else { "centre" },
        references,
        rows,
    })
}

/// One scene and power: the methods' rows, then the ladder, each method set against it.
fn case_rows(
    ctx: &GpuContext,
    cfg: &GlossyConfig,
    case: &Case,
    tick: &dyn Fn(&str),
) -> Result<Vec<GlossyRow>> {
    let mut rows = Vec::new();
    for &method in &cfg.methods {
        tick(&format!("{}: power {}: {method}", case.name, case.power));
        let tracing = if method_warning(&case.scene, method, 1).is_some() {
            Tracing::Mirror
        } else {
            Tracing::Cone
        };
        rows.push(case.method_row(ctx, cfg, method, tracing)?);
    }
    let ladder_rows = case.ladder(ctx, cfg, tick)?;
    let ladder: Vec<LadderPoint> = (ladder_rows.iter())
        .map(|r| LadderPoint {
            spp: r.spp,
            frame_ns: r.frame_ns.median,
            psnr_db: r.psnr_db,
        })
        .collect();
    for r in &mut rows {
        r.versus_bvh = Some(versus(
            &ladder,
            r.frame_ns.median,
            r.reused_frame_ns.median,
            r.psnr_db,
        ));
    }
    rows.extend(ladder_rows);
    Ok(rows)
}

/// The grid's memory check ([`super::check_memory`]) for the methods and `bvh`.
fn check_memory(ctx: &GpuContext, cfg: &GlossyConfig, prepared: &[(Scene, Camera)]) -> Result<()> {
    let grid = super::BenchConfig {
        scenes: cfg.scenes.clone(),
        methods: (cfg.methods.iter().chain([&Method::EXACT_GPU]))
            .map(|&m| MethodSpec::plain(m))
            .collect(),
        width: cfg.width,
        height: cfg.height,
        cube_size: cfg.cube_size,
        cmos: cfg.cmos,
        reflector_check: cfg.reflector_check,
        ..super::BenchConfig::default()
    };
    let limits =
        crate::memory::Limits::of_device(ctx.device_local_heap_bytes(), ctx.device_is_cpu())?;
    super::check_memory(&grid, prepared, &limits)
}

fn ms(ns: f64) -> String {
    if ns.is_finite() && ns > 0.0 {
        format!("{:.2}", ns * 1e-6)
    } else {
        "-".into()
    }
}

fn db(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else {
        format!("{x:.2}")
    }
}

/// The converged references' table: cost and convergence.
pub fn reference_table(report: &GlossyReport) -> String {
    let mut t = String::from(
        "| scene | power | cone ° | spp | mirror px | wall s | half-spp PSNR dB |\n|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in &report.references {
        t.push_str(&format!(
            "| {} | {} | {:.1} | {} | {} | {:.2} | {} |\n",
            r.scene,
            r.power,
            f64::from(lobe::cone_half_angle(r.power)).to_degrees(),
            r.spp,
            r.mirror_pixels,
            r.wall_s,
            db(r.half_spp_psnr_db)
        ));
    }
    t
}

/// The rows of one power as a Markdown table.
pub fn table(report: &GlossyReport, power: f32) -> String {
    let mut t = String::from(
        "| scene | method | traces | spp | PSNR dB | ms/frame | ns/mirror px (trace) | bvh of >= cost: spp, PSNR dB | beats it | ms/frame, CMOs reused | bvh of >= that cost: spp, PSNR dB | beats it | bvh spp of same PSNR (ms/frame) | passes |\n|---|---|---|---:|---:|---:|---:|---|---|---:|---|---|---|---|\n",
    );
    for r in report.rows.iter().filter(|r| r.power == power) {
        let v = r.versus_bvh.as_ref();
        let rung = |p: Option<LadderPoint>| {
            p.map_or_else(
                || {
                    if v.is_some() {
                        "dearer than every rung".into()
                    } else {
                        String::new()
                    }
                },
                |p| format!("{}, {}", p.spp, db(p.psnr_db)),
            )
        };
        let yes_no = |b: Option<bool>| match b {
            Some(true) => "yes",
            Some(false) => "no",
            None => "",
        };
        let same_cost = rung(v.and_then(|v| v.same_cost));
        let beats = yes_no(v.and_then(|v| v.beats_same_cost));
        let reused = if v.is_some() {
            ms(r.reused_frame_ns.median)
        } else {
            String::new()
        };
        let same_reused = rung(v.and_then(|v| v.same_cost_reused));
        let beats_reused = yes_no(v.and_then(|v| v.beats_same_cost_reused));
        let same_psnr = match v {
            Some(Versus {
                same_psnr_spp: Some(s),
                same_psnr_frame_ns: Some(ns),
                ..
            }) => format!("{s:.1} ({})", ms(*ns)),
            Some(_) => "outside the ladder".into(),
            None => String::new(),
        };
        let passes: Vec<&str> = r.passes.iter().map(|p| p.pass.as_str()).collect();
        t.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {:.1} | {same_cost} | {beats} | {reused} | {same_reused} | {beats_reused} | {same_psnr} | {} |\n",
            r.scene,
            r.method,
            r.tracing.name(),
            r.spp,
            db(r.psnr_db),
            ms(r.frame_ns.median),
            r.trace_ns_per_mirror_px,
            passes.join(", ")
        ));
    }
    t
}

/// The per-roughness plot: one panel per power, PSNR against cost per frame; per scene the
/// ladder as a line and each method a labelled point (filled: cone, hollow: mirror only).
pub fn plot(report: &GlossyReport) -> Result<String> {
    let mut scenes: Vec<&str> = Vec::new();
    for r in &report.rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    let panels: Vec<super::plot::Panel> = (report.powers.iter())
        .map(|&power| {
            let rows = || report.rows.iter().filter(move |r| r.power == power);
            let series = |r: &GlossyRow| scenes.iter().position(|s| *s == r.scene).unwrap_or(0);
            super::plot::Panel {
                title: format!(
                    "power {power} ({:.0}° cone)",
                    f64::from(lobe::cone_half_angle(power)).to_degrees()
                ),
                lines: (scenes.iter().enumerate())
                    .map(|(k, s)| super::plot::PanelLine {
                        label: format!("{s}: bvh 1..{} spp", report.spp.last().unwrap_or(&1)),
                        series: k,
                        points: rows()
                            .filter(|r| r.scene == *s && r.tracing == Tracing::MonteCarlo)
                            .map(|r| (r.frame_ns.median * 1e-6, r.psnr_db))
                            .collect(),
                    })
                    .collect(),
                points: rows()
                    .filter(|r| r.tracing != Tracing::MonteCarlo)
                    .map(|r| super::plot::PanelPoint {
                        label: r.method.clone(),
                        series: series(r),
                        x: r.frame_ns.median * 1e-6,
                        y: r.psnr_db,
                        filled: r.tracing == Tracing::Cone,
                    })
                    .collect(),
            }
        })
        .collect();
    super::plot::panels(
        "glossy reflections: PSNR against the converged reference",
        "GPU ms per frame (log)",
        "PSNR over mirror pixels, dB",
        &panels,
    )
}

/// Writes `glossy.json`, `glossy.md` and `glossy.svg` into `dir`; returns their paths.
pub fn write(report: &GlossyReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let json = dir.join("glossy.json");
    write_atomic(&json, serde_json::to_string_pretty(report)?.as_bytes())?;
    let md = dir.join("glossy.md");
    write_atomic(&md, markdown(report).as_bytes())?;
    let svg = dir.join("glossy.svg");
    write_atomic(&svg, plot(report)?.as_bytes())?;
    Ok(vec![json, md, svg])
}

/// The whole Markdown document of a run.
pub fn markdown(report: &GlossyReport) -> String {
    let spp: Vec<String> = report.spp.iter().map(u32::to_string).collect();
    let mut doc = format!(
        "# cubetrace bench --glossy\n\nDevice: {}; commit {}; {}x{}; GPU times: median of {} \
         frames after {} warm-up, summed over the frame's passes (capture included) and, for \
         bvh, over its samples. PSNR over the reference's mirror pixels against the converged \
         reference ({} spp); bvh ladder at {} spp; samples {}.\n\n## The converged references\n\n{}",
        report.device.describe(),
        report.git_commit.as_deref().unwrap_or("unknown"),
        report.width,
        report.height,
        report.frames,
        report.warmup,
        report.reference_spp,
        spp.join(", "),
        if report.samples_at == "film" {
            "at the film's jittered offsets (as render --spp)"
        } else {
            "at the pixel centre (the lobe alone)"
        },
        reference_table(report)
    );
    for &p in &report.powers {
        doc.push_str(&format!(
            "\n## Power {p} ({:.1}° cone)\n\n{}",
            f64::from(lobe::cone_half_angle(p)).to_degrees(),
            table(report, p)
        ));
    }
    doc
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(spp: u32, ms: f64, db: f64) -> LadderPoint {
        LadderPoint {
            spp,
            frame_ns: ms * 1e6,
            psnr_db: db,
        }
    }

    fn ladder() -> Vec<LadderPoint> {
        vec![
            p(1, 2.0, 20.0),
            p(2, 4.0, 23.0),
            p(4, 8.0, 26.0),
            p(8, 16.0, 29.0),
        ]
    }

    #[test]
    fn cheapest_bvh_of_at_least_the_same_cost() {
        let l = ladder();
        // 5 ms: the 8 ms row (4 spp), not the cheaper 4 ms one nor the dearer 16 ms one.
        assert_eq!(cheapest_at_least(&l, 5e6), Some(l[2]));
        // Exactly a row's cost: that row.
        assert_eq!(cheapest_at_least(&l, 4e6), Some(l[1]));
        // Dearer than the whole ladder: none.
        assert_eq!(cheapest_at_least(&l, 17e6), None);
        // The ladder's order does not matter.
        let mut r = l.clone();
        r.reverse();
        assert_eq!(cheapest_at_least(&r, 5e6), Some(l[2]));
        let v = versus(&l, 5e6, 3e6, 27.0);
        assert_eq!((v.same_cost, v.beats_same_cost), (Some(l[2]), Some(true)));
        // Without the CMO stages (3 ms) the rung is the 4 ms one, beaten as well; dearer than
        // the ladder, none.
        assert_eq!(
            (v.same_cost_reused, v.beats_same_cost_reused),
            (Some(l[1]), Some(true))
        );
        assert_eq!(versus(&l, 20e6, 17e6, 27.0).same_cost_reused, None);
        // Negative: a PSNR below that row's does not beat it; the nearest row below in cost
        // (4 ms, 23 dB), which a PSNR of 24 dB would beat, is not the one chosen.
        let v = versus(&l, 5e6, 5e6, 24.0);
        assert_eq!((v.same_cost, v.beats_same_cost), (Some(l[2]), Some(false)));
    }

    #[test]
    fn same_psnr_interpolates_in_log_spp() {
        let l = ladder();
        // Halfway between 2 spp (23 dB) and 4 spp (26 dB): sqrt(8) spp, sqrt(32) ms.
        let (spp, ns) = spp_of_psnr(&l, 24.5).unwrap();
        assert!((spp - 8f64.sqrt()).abs() < 1e-9, "{spp}");
        assert!((ns - 32f64.sqrt() * 1e6).abs() < 1e-3, "{ns}");
        assert_eq!(spp_of_psnr(&l, 26.0), Some((4.0, 8e6)));
        // Outside the ladder: none.
        assert_eq!(spp_of_psnr(&l, 19.0), None);
        assert_eq!(spp_of_psnr(&l, 30.0), None);
        assert_eq!(spp_of_psnr(&l, f64::INFINITY), None);
        // Negative: linear in spp would give 3 at 24.5 dB.
        assert!((spp - 3.0).abs() > 0.1);
    }

    #[test]
    fn powers_and_ladder_are_checked() {
        assert!(check_powers(&DEFAULT_POWERS).is_ok());
        assert!(check_powers(&[0.0, 1023.5]).is_ok());
        for (bad, why) in [
            (vec![], "no specular power"),
            (vec![-1.0], "-1 is not a specular power"),
            (vec![f32::NAN], "NaN is not a specular power"),
            (vec![f32::INFINITY], "inf is not a specular power"),
            (vec![1024.0], "1024 is a mirror"),
            (vec![16.0, 16.0], "listed twice"),
        ] {
            let e = check_powers(&bad).unwrap_err().to_string();
            assert!(
                e.starts_with("--glossy: ") && e.contains(why),
                "{bad:?}: {e}"
            );
        }
        assert!(check_ladder(&DEFAULT_SPP).is_ok());
        for bad in [vec![], vec![0], vec![2, 2], vec![4, 2], vec![2048]] {
            let e = check_ladder(&bad).unwrap_err().to_string();
            assert!(e.starts_with("--glossy-spp: "), "{bad:?}: {e}");
        }
    }
}

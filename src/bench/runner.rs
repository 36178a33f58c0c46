#![forbid(unsafe_code)]
//! The run loop of `cubetrace bench` ([`run`]): every scene prepared and checked, then per
//! scene its reference and each method's runs, into a [`BenchReport`].

use anyhow::{Context, Result, bail};
use serde::Serialize;

use super::config::{BenchConfig, BenchPlacement};
use super::heatmap;
use super::machine::{DeviceInfo, driver_threads, git_commit};
use super::model;
use super::prepare::{check_memory, prepare_scene_placed, runs_at};
use super::ratios::SceneRatios;
use super::results::{FloorRun, RunResult};
use super::runs::{ReferenceRun, flip_mean, run_gpu, run_gpu_with, run_reference_bounces};
use super::spec::MethodSpec;
use super::stats::{Counters, Stats, frame_stats, optional_pass, pass_stats};
use crate::camera::Camera;
use crate::memory;
use crate::metrics::{self, ErrorReport, PixelError, Traced};
use crate::placement::Scoring;
use crate::reference::Frame;
use crate::render::checks::check_validation;
use crate::scene::Scene;
use crate::vk::GpuContext;
use crate::vk::frame::pass_name;

/// Everything a bench run produced.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub device: DeviceInfo,
    /// The commit the binary was built from ([`super::git_commit`]), else null.
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
    // The search (where a scene asks for one) is judged by the grid's first cube-map tracer's
    // criterion (the grid puts each method's default first), else by the centre criterion's
    // twin, as `render` judges it for a method that captures without tracing (`envmap`).
    let search = cfg.methods.iter().any(|m| m.kind.captures_cmos()).then(|| {
        (cfg.methods.iter())
            .find(|m| m.kind.traces_cubemaps())
            .map_or(Scoring::Centre, |m| {
                m.render_options(cfg.bounces, true).scoring()
            })
    });
    let mut labels = Vec::new();
    let mut prepared = Vec::new();
    let mut search_ms = Vec::new();
    for name in &cfg.scenes {
        for &p in &placements {
            let overrides = (cfg.cube_size, cfg.cmos);
            let (scene, camera, searched) = prepare_scene_placed(
                name,
                cfg.width,
                cfg.height,
                overrides,
                p,
                search,
                cfg.bounces,
            )?;
            labels.push((p.label(name, several), name.as_str()));
            prepared.push((scene, camera));
            search_ms.push(searched.map(|s| s.time.as_secs_f64() * 1e3));
        }
    }
    let limits = memory::Limits::of_device(ctx.device_local_heap_bytes(), ctx.device_is_cpu())?;
    check_memory(cfg, &prepared, &limits)?;
    let mut runs = Vec::new();
    // Heat map paths given so far: two scenes of one (sanitised) name get their own files.
    let mut heat_paths: Vec<String> = Vec::new();
    for (((name, source), (mut scene, camera)), search_ms) in
        labels.iter().zip(prepared).zip(search_ms)
    {
        if several {
            scene.name = name.clone();
        }
        bar.set_message(format!("{name}: reference"));
        // The reference is needed for every error figure, even when it is not a listed method.
        let refr = run_reference_bounces(&scene, &camera, cfg.warmup, cfg.frames, cfg.bounces);
        let truth = converged_truth(&scene, &camera, cfg.bounces, cfg.compare_spp, || {
            bar.set_message(format!(
                "{name}: converged reference ({} spp)",
                cfg.compare_spp
            ))
        });
        bar.inc(1);
        let sc = SceneRuns::new(name, source, &scene, &camera, refr, truth);
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

/// The converged frame that a scene with a glossy reflector is measured against
/// ([`crate::render::glossy::reference_frame_bounces`] of `bounces` at `spp` samples, all at
/// the pixel centre as the grid's frames are: the lobe's integral there); `None` for a scene
/// of mirrors, whose frames are compared hit by hit with the reference's.
fn converged_truth(
    scene: &Scene,
    camera: &Camera,
    bounces: u32,
    spp: u32,
    announce: impl FnOnce(),
) -> Option<Frame> {
    if scene.glossy_reflectors().is_empty() {
        return None;
    }
    announce();
    let tracer = crate::reference::Tracer::new(scene);
    let glossy = crate::render::glossy::reference_frame_bounces;
    Some(glossy(scene, &tracer, camera, bounces, spp, false).0)
}

/// A GPU run's error figures ([`SceneRuns::measure`]).
struct Measured {
    error: ErrorReport,
    wrong_off_reflector: f64,
    flip_mean: Option<f64>,
    heatmap: Option<String>,
}

/// One scene's runs: the scene, its reference frame and the figures every run of it repeats.
struct SceneRuns<'a> {
    /// The name the scene was given by (`--scenes`), for messages.
    name: &'a str,
    /// The `--scenes` entry it was loaded from (a built-in's name or a file's path).
    source: &'a str,
    scene: &'a Scene,
    camera: &'a Camera,
    refr: ReferenceRun,
    /// A scene with a glossy reflector: the converged frame every run is measured against,
    /// by colour ([`converged_truth`]).
    truth: Option<Frame>,
    centres: Vec<glam::Vec3>,
    /// Per object of the scene's world: whether it is a reflector.
    reflector: Vec<bool>,
    triangles: usize,
    /// The reference's mirror pixels.
    mirror: usize,
}

impl<'a> SceneRuns<'a> {
    fn new(
        name: &'a str,
        source: &'a str,
        scene: &'a Scene,
        camera: &'a Camera,
        refr: ReferenceRun,
        truth: Option<Frame>,
    ) -> Self {
        let world = scene.world();
        SceneRuns {
            name,
            source,
            scene,
            camera,
            centres: scene.cmo_centres(),
            reflector: world.objects.iter().map(|o| o.reflector).collect(),
            triangles: world.triangles.len(),
            mirror: refr.frame.mirror_pixels(),
            refr,
            truth,
        }
    }

    /// The figures of a run that do not depend on its frames (the rest zero).
    fn base(&self, cfg: &BenchConfig, spec: &MethodSpec) -> RunResult {
        RunResult {
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
            frames: cfg.frames.max(1),
            source: self.source.to_string(),
            ..RunResult::unmeasured(&self.scene.name, spec.label(), spec.kind)
        }
    }

    /// The reference's row: its wall times, exact by definition (on a glossy scene its frame
    /// of one lobe sample per pixel, measured against the converged one).
    fn reference_result(&self, cfg: &BenchConfig, spec: &MethodSpec) -> RunResult {
        let refr = &self.refr;
        let error = match &self.truth {
            Some(t) => metrics::compare_colour(t, &refr.frame.colour, &refr.frame.mask, None),
            None => ErrorReport::exact(self.mirror),
        };
        let wall = Stats::of(&refr.wall_ns).unwrap_or_default();
        let reflected = Stats::of(&refr.reflected_ns).unwrap_or_default();
        RunResult {
            rays: refr.reflected_rays,
            trace_ns: reflected,
            total_ns: wall,
            trace_ns_per_mirror_px: reflected.median / self.mirror.max(1) as f64,
            ns_per_ray: reflected.median / refr.reflected_rays.max(1) as f64,
            error,
            // Its own figure, 0 on a mirror scene; not measured on a glossy one.
            wrong_off_reflector: if self.truth.is_some() { f64::NAN } else { 0.0 },
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
        let at = (&g.frame.surface_position[..], scene.cmo.resolution);
        let m = self.measure(cfg, &scene.name, &label, &traced, at, heat_paths)?;
        let passes = pass_stats(&g.pass_ns);
        let trace_ns = frame_stats(&g.pass_ns, Some(pass_name(spec.kind)));
        let floor = self.floor_run(ctx, cfg, bar, scene, spec, trace_ns)?;
        let rays = g.frame.mirror_pixels();
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
            error: m.error,
            wrong_off_reflector: m.wrong_off_reflector,
            flip_mean: m.flip_mean,
            heatmap: m.heatmap,
            rounds: g.frame.rounds.clone(),
            triangles: scene.world().triangles.len(),
            ..self.base(cfg, spec)
        })
    }

    /// The error figures of a GPU run's frame `traced` (`at`: its primary mirror hits and the
    /// cube size, for the texel footprint): hit by hit against the reference, with the heat
    /// map; on a glossy scene by colour against the converged frame, without a heat map (its
    /// pixel verdicts are hits') and with NaN for the wrong surfaces off the reflectors.
    fn measure(
        &self,
        cfg: &BenchConfig,
        scene: &str,
        label: &str,
        traced: &Traced,
        at: (&[glam::Vec3], u32),
        heat_paths: &mut Vec<String>,
    ) -> Result<Measured> {
        let (position, resolution) = at;
        let against = self.truth.as_ref().unwrap_or(&self.refr.frame);
        let flip_mean = if cfg.flip {
            flip_mean(against, traced)
        } else {
            None
        };
        if let Some(truth) = &self.truth {
            let resolved = Some(&traced.resolved[..]);
            return Ok(Measured {
                error: metrics::compare_colour(truth, &traced.colour, &traced.mask, resolved),
                wrong_off_reflector: f64::NAN,
                flip_mean,
                heatmap: None,
            });
        }
        let refr = &self.refr.frame;
        let pixels = metrics::classify(refr, traced, position, &self.centres, resolution);
        let heatmap = if cfg.heatmaps {
            Some(write_heatmap(cfg, scene, label, refr, &pixels, heat_paths)?)
        } else {
            None
        };
        Ok(Measured {
            error: metrics::compare(refr, traced, position, &self.centres, resolution),
            wrong_off_reflector: metrics::wrong_surface_off_reflector(
                refr,
                &self.reflector,
                &pixels,
            ),
            flip_mean,
            heatmap,
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

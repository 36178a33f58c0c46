#![forbid(unsafe_code)]
//! `cubetrace render`: one frame of one method, written as PNG or EXR, optionally compared with
//! the reference.
//!
//! The order is the command's promise: the scene and its overrides are loaded and checked, then
//! the output path, then (GPU methods) the bounce rule, the device and the memory the render
//! needs ([`crate::render::checks`], the one estimate of [`crate::vk::budget::estimate`], also
//! the bench's) or (reference) the host memory; only then anything is rendered. A refusal at
//! any step leaves no file behind. The frame is [`crate::render`]'s ([`FrameRenderer`], opened
//! from the plain [`RenderSetup`] of [`render_setup`]); this module keeps the arguments, the
//! scene they prepare and the lines printed.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Result;

use super::GpuArgs;
use super::options::TraceArgs;
use super::summary::{self, FallbackCount};
use crate::Method;
use crate::camera::Camera;
use crate::metrics;
use crate::output::{self, Format};
use crate::placement::Placement;
use crate::reference;
use crate::render::scene::{SceneSetup, timed};
use crate::render::{self as engine, FrameRenderer, RenderSetup, RenderedFrame};
use crate::scene::Scene;
use crate::vk::GpuContext;
use crate::vk::frame::{GpuFrame, RenderOptions};

#[derive(clap::Args)]
pub struct RenderArgs {
    /// Built-in scene name or path to a .toml scene file.
    #[arg(default_value = "default")]
    pub scene: String,
    /// How reflections are computed (default: the compute path, thesis alg. 3).
    #[arg(long, value_enum, default_value_t = RenderOptions::default().method)]
    pub method: Method,
    /// Camera of the scene, by name or index (default: the first).
    #[arg(long)]
    pub camera: Option<String>,
    /// Image width in pixels (default: the camera's). Given alone, the height follows the
    /// camera's aspect ratio (rounded, at least 1).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height in pixels (default: the camera's). Given alone, the width follows the
    /// camera's aspect ratio (rounded, at least 1).
    #[arg(long)]
    pub height: Option<u32>,
    /// Maximum number of mirror reflections per path (0..=16). After the last one, a mirror
    /// shows its own material colour (Blender's Cycles, whose glossy bounces count one fewer,
    /// shows black: its N bounces are --bounces N+1). So at 1, the few silhouette pixels of a
    /// smooth-shaded convex mirror whose ray, reflected about the interpolated normal, meets
    /// the mirror's own facets show its colour. GPU methods: compute, bvh and fragment (bounded or
    /// centre criterion).
    /// compute traces the reflections after the first with the cube maps too (the fallback
    /// finishes what they cannot answer; the placement search places CMOs for them); fragment
    /// hands them to the BVH.
    #[arg(long, default_value_t = RenderOptions::default().bounces,
          value_parser = clap::value_parser!(u32).range(0..=16))]
    pub bounces: u32,
    /// Output file, .png or .exr [default: out/SCENE-METHOD.png].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also render the reference and print the error of the method against it, over the mirror
    /// pixels of either image: mask mismatch (a mirror pixel of one image only, counted both
    /// ways), unresolved, wrong surface, angular error; PSNR over mirror pixels and over the
    /// whole frame. In a sequence each frame is compared with the reference's same frame. On a
    /// scene with a glossy reflector the reference is a converged Monte Carlo frame of
    /// --compare-spp samples (its own half-spp PSNR stated), and the line gives the PSNR over
    /// mirror pixels. GPU methods only: with --method reference it is refused (the reference
    /// would be compared with itself).
    #[arg(long)]
    pub compare: bool,
    /// --compare on a glossy scene: samples per pixel of the converged reference (the CPU
    /// reference's Monte Carlo integral of the lobe; it costs about that many 1-spp reference
    /// frames).
    #[arg(long, default_value_t = 256, requires = "compare",
          value_parser = clap::value_parser!(u32).range(2..=4096))]
    pub compare_spp: u32,
    /// Split every triangle of the non-reflector objects into four, N times, before rendering
    /// (with any method, so the reference sees the same geometry): the surfaces stay, the vertex
    /// count grows 4^N-fold (at most 5: about 1000 times). The reflection-point method reflects
    /// vertices, so this is its quality knob.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=5))]
    pub subdivide: u32,
    #[command(flatten)]
    pub film: FilmArgs,
    #[command(flatten)]
    pub trace: TraceArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
    #[command(flatten)]
    pub shard: super::shard::ShardArgs,
    #[command(flatten)]
    pub sequence: super::frames::SequenceArgs,
}

/// Samples per pixel and their filter (`crate::film`), over the scene file's `[film]`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct FilmArgs {
    /// Samples per pixel (1..=1024) [default: the scene's `[film] spp`, else 1]. Every method,
    /// the reference too, renders the frame once per sample, each time with every pixel's sample
    /// at the same stratified sub-pixel offset (fixed: no seed), and filters them in linear
    /// colour; the cube maps are captured once per frame. 1 is one sample at each pixel centre,
    /// the frame without samples. At N > 1 the colour is filtered; the EXR's other channels
    /// (mask, P, hit, object_id, primitive_id, bounces, unresolved, fallback) are those of the
    /// one sample nearest the pixel centre, never a blend, so an ID names a triangle the pixel
    /// shows.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(crate::film::MAX_SPP)))]
    pub spp: Option<u32>,
    /// Pixel filter of the samples [default: the scene's `[film] filter`, else box]: `box`
    /// averages each pixel's own samples; `gaussian` is pbrt's Gaussian (radius 1.5 pixels,
    /// sigma 0.5), each sample weighing in the pixels within that radius.
    #[arg(long, value_enum)]
    pub filter: Option<crate::film::PixelFilter>,
}

/// Where the frame goes and what it is, settled before anything renders.
struct Target {
    path: PathBuf,
    format: Format,
}

impl RenderArgs {
    /// The method-specific options given on the command line, as typed: the tracer's
    /// ([`TraceArgs::given`]), `--compare`, `--device` and `--validate`.
    pub fn given(&self) -> Vec<&'static str> {
        let mut given = self.trace.given();
        for (flag, on) in [
            ("--compare", self.compare),
            ("--device", self.gpu.device.is_some()),
            ("--validate", self.gpu.validate),
        ] {
            if on {
                given.push(flag);
            }
        }
        given
    }

    /// Refuses the options the chosen method would ignore and the settings it cannot trace
    /// ([`Method::check_options`], the one table of [`crate::method::METHOD_OPTIONS`];
    /// [`Method::check_bounces`]).
    pub fn check_method(&self) -> Result<()> {
        let m = self.method;
        let trace = self.trace.options(m).trace;
        m.check_options(&self.given(), &trace)
            .and_then(|()| {
                m.check_bounces(self.bounces, crate::vk::passes::bounce::MAX_BOUNCES, &trace)
            })
            .map_err(anyhow::Error::msg)
    }
}

/// `cubetrace render`.
pub fn render(args: RenderArgs) -> Result<()> {
    let start = Instant::now();
    args.check_method()?;
    let (scene, camera, placement) = load_scene(&args)?;
    let target = check_target(&args, &scene)?;
    if let Some(warning) = engine::glossy::method_warning(&scene, args.method, args.bounces) {
        log::warn!("{warning}");
    }
    if args.method.is_gpu() {
        render_gpu(&args, &scene, &camera, placement.as_ref(), &target, start)
    } else {
        render_reference(&args, &scene, &camera, &target, start)
    }
}

/// The film of a run: the scene file's `[film]`, overridden by `--spp` and `--filter`.
pub fn film_settings(args: &RenderArgs, scene: &Scene) -> crate::film::FilmSettings {
    crate::film::FilmSettings {
        spp: args.film.spp.unwrap_or(scene.film.spp).max(1),
        filter: args.film.filter.unwrap_or(scene.film.filter),
    }
}

/// The plain set-up of a run's frames ([`crate::render::RenderSetup`]) from the command line,
/// checked by [`RenderArgs::check_method`] before: the film, the output's format, `--compare`,
/// and for GPU methods the device and the renderer's options.
pub fn render_setup(args: &RenderArgs, scene: &Scene) -> Result<RenderSetup> {
    let format = match &args.output {
        Some(p) => Format::from_path(p)?,
        None => Format::Png,
    };
    let gpu = if args.method.is_gpu() {
        Some((args.gpu.context_options(), gpu_options(args)?))
    } else {
        None
    };
    Ok(RenderSetup {
        method: args.method,
        bounces: args.bounces,
        film: film_settings(args, scene),
        format,
        compare: args.compare,
        gpu,
    })
}

impl FrameRenderer {
    /// The renderer of the command line's frames, for a caller that has not checked them (the
    /// commands check first and [`FrameRenderer::open`] the [`render_setup`] themselves): the
    /// set-up, the method's options checked (GPU methods), then [`FrameRenderer::open`] (the
    /// device and the checks once); nothing rendered yet.
    pub fn new(args: &RenderArgs, scene: &Scene, camera: &Camera) -> Result<Self> {
        let setup = render_setup(args, scene)?;
        if args.method.is_gpu() {
            args.check_method()?;
        }
        FrameRenderer::open(&setup, scene, camera)
    }
}

/// The plain set-up of the run's scene ([`SceneSetup`]) from the command line: the scene, its
/// CMO overrides, `--subdivide`, `--camera`, `--width`/`--height`, `--bounces` (the placement
/// search's sample follows it); `search`: whether a placement search the scene asks for runs
/// now (for the chosen camera).
pub fn scene_setup(args: &RenderArgs, search: bool) -> SceneSetup {
    let mut setup = SceneSetup {
        scene: args.scene.clone(),
        subdivide: args.subdivide,
        camera: args.camera.clone(),
        width: args.width,
        height: args.height,
        search,
        bounces: args.bounces,
        scoring: args.trace.options(args.method).scoring(),
        size_name: "--width/--height",
        ..SceneSetup::default()
    };
    args.trace.apply(&mut setup);
    setup
}

/// Loads the scene, applies the CMO overrides, the subdivision and the frame size to it and its
/// camera, resolves a CMO placement search for that camera ([`engine::scene::prepare`]) and
/// logs the search and the scene's problems.
pub fn load_scene(args: &RenderArgs) -> Result<(Scene, Camera, Option<Placement>)> {
    let (scene, camera, placement) =
        engine::scene::prepare(&scene_setup(args, args.method.captures_cmos()))?;
    if let Some(p) = &placement {
        log_placement(p);
    }
    // Centres that a search judged on sampled rays need no line-of-sight check.
    let sight = placement.as_ref().is_none_or(|p| p.rays == 0);
    let check = || crate::placement::diagnose_with(&scene, sight);
    for problem in timed("scene check", check) {
        log::warn!("{problem}");
    }
    Ok((scene, camera, placement))
}

/// The `-v` lines of a placement search: the sample, each chosen centre and what it buys.
pub fn log_placement(p: &Placement) {
    log::info!(
        "cmo placement: {} CMOs for {} sampled reflected rays in {:.2?}{}: {:.2}% of them \
         unresolved by {} (target {:.0}%; {:.2}% with as many along the reflectors' axis){}",
        p.centres.len(),
        p.rays,
        p.time,
        if p.later_rays > 0 {
            format!(" ({} of them later reflections of --bounces)", p.later_rays)
        } else {
            String::new()
        },
        100.0 * p.share(),
        p.judge.name(),
        100.0 * crate::placement::TARGET_SHARE,
        100.0 * p.axis_unresolved,
        if p.self_capture_off {
            "; the reflectors are left out of the capture (the reflector check traces the rays \
             that meet them)"
        } else {
            ""
        }
    );
    if let Some(n) = p.list_size {
        log::info!(
            "cmo placement: one CMO on the reflectors' axis met the target with the bounded \
             lists at {n} texels per face side (at most {} nodes per texel), not at --list-size \
             auto's size: the frame takes {n}",
            crate::cubemap::bounds::SHORT_LIST_LENGTH
        );
    }
    if let Some(n) = p.near {
        log::info!(
            "cmo placement: one CMO in front of the mirror points in view at [{:.3}, {:.3}, \
             {:.3}] tests {:.1} texels and cells per ray, one on the reflectors' axis {:.1} \
             (the pyramid march's twin on the sample); {}",
            n.centre.x,
            n.centre.y,
            n.centre.z,
            n.walk,
            n.axis_walk,
            if n.taken() {
                format!(
                    "the one in front is taken (at most {:.0}%)",
                    100.0 * crate::placement::NEAR_WALK
                )
            } else {
                format!(
                    "the axis is kept (the one in front must be at most {:.0}%)",
                    100.0 * crate::placement::NEAR_WALK
                )
            }
        );
    }
    for (k, (c, share)) in p.centres.iter().zip(&p.unresolved).enumerate() {
        log::info!(
            "cmo placement: CMO {k} at [{:.3}, {:.3}, {:.3}]: unresolved {:.2}%",
            c.x,
            c.y,
            c.z,
            100.0 * share
        );
    }
}

/// The output path (`-o`, else `out/SCENE-METHOD.png`), checked before any time is spent on the
/// render.
fn check_target(args: &RenderArgs, scene: &Scene) -> Result<Target> {
    let method = args.method;
    // The scene's name comes from its file: only a sanitised form of it enters the path.
    let path = args.output.clone().unwrap_or_else(|| {
        PathBuf::from("out").join(format!(
            "{}-{method}.png",
            output::safe_file_stem(&scene.name)
        ))
    });
    let format = output::check_output(&path)?;
    check_file_name(&path)?;
    Ok(Target { path, format })
}

/// The longest file or folder name, in bytes, that Linux file systems take (`NAME_MAX`).
pub const NAME_MAX: usize = 255;

/// Checks, before the render, that the output file can be created under its name: no part of
/// the path longer than [`NAME_MAX`] bytes, and where its folder exists and the file does not,
/// the file system takes the name (the file is created and removed at once; an existing file
/// is replaced by the atomic write, so its name is known to be good).
pub fn check_file_name(path: &Path) -> Result<()> {
    for part in path.iter() {
        let len = part.as_encoded_bytes().len();
        if len > NAME_MAX {
            anyhow::bail!(
                "output {}: the name '{}...' is {len} bytes long, more than the {NAME_MAX} a file \
                 system allows; choose a shorter name",
                path.display(),
                part.to_string_lossy().chars().take(24).collect::<String>()
            );
        }
    }
    if std::fs::symlink_metadata(path).is_ok() {
        return Ok(());
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        // Created by the write; the folder check (`output::check_output`) has passed.
        return Ok(());
    }
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
    {
        Ok(_) => std::fs::remove_file(path)
            .map_err(|e| anyhow::anyhow!("cannot remove the test file {}: {e}", path.display())),
        // Another process made it in between: the name is good.
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        Err(e) => anyhow::bail!(
            "output {}: cannot create a file of this name: {e}",
            path.display()
        ),
    }
}

/// The renderer's options of a GPU render: the tracer's and `--bounces` (the command checks
/// them first, once: [`RenderArgs::check_method`]).
pub fn gpu_options(args: &RenderArgs) -> Result<RenderOptions> {
    let options = args.trace.options(args.method);
    Ok(RenderOptions {
        bounces: args.bounces,
        ..options
    })
}

/// The GPU render: device, memory check and renderer ([`FrameRenderer::open`]), the frame's
/// samples, file, summary, validation and the optional comparison.
fn render_gpu(
    args: &RenderArgs,
    scene: &Scene,
    camera: &Camera,
    placement: Option<&Placement>,
    target: &Target,
    start: Instant,
) -> Result<()> {
    let loaded = start.elapsed();
    // A still frame takes the placement search's lists where they are its capture's.
    let lists = placement.and_then(|p| p.lists.as_deref());
    let setup = render_setup(args, scene)?;
    let mut renderer = FrameRenderer::open_with_lists(&setup, scene, camera, lists)?;
    let created = start.elapsed();
    let rendered = renderer.render(scene, camera)?;
    let render_time = start.elapsed();
    rendered.write(&target.path, target.format)?;
    let written = start.elapsed();
    log::info!(
        "host: scene {:.0} ms, device, passes and pipelines {:.0} ms, frame ({} sample(s): submit, wait, read back, filter) {:.0} ms, {} {:.0} ms",
        loaded.as_secs_f64() * 1e3,
        (created - loaded).as_secs_f64() * 1e3,
        rendered.spp,
        (render_time - created).as_secs_f64() * 1e3,
        target.path.display(),
        (written - render_time).as_secs_f64() * 1e3,
    );
    let (Some(frame), Some(ctx)) = (&rendered.gpu, renderer.context()) else {
        anyhow::bail!("--method {}: no GPU frame", args.method);
    };
    let traced = frame.traced();
    log_gpu_frame(frame, args.method);
    let count = FallbackCount::of(frame, &traced);
    if let Some(warning) = summary::fallback_warning(args.method, scene, &count, placement) {
        log::warn!("{warning}");
    }
    println!(
        "{}",
        gpu_summary(
            &target.path,
            args,
            scene,
            &rendered,
            &count,
            render_time,
            ctx
        )
    );
    engine::check_validation(ctx)?;
    if args.compare {
        for line in compare_with_reference(args, scene, camera, renderer.film(), &rendered) {
            println!("{line}");
        }
    }
    Ok(())
}

/// The `-v` lines of a GPU frame: pass times and the method's own counters.
fn log_gpu_frame(frame: &GpuFrame, method: Method) {
    for (pass, ns) in &frame.pass_times {
        log::info!("{pass:>16}: {:9.3} ms", ns * 1e-6);
    }
    if method.info().outcomes_in_records {
        log::info!("{method}: {}", ssr_outcomes(frame));
    }
    if let Some(s) = &frame.search {
        log::info!(
            "reflection-point: {} vertices searched, steps per vertex mean {:.1} max {}, {} hidden (inverse search), {} at the cap",
            s.searched,
            s.mean_iterations,
            s.max_iterations,
            s.hidden,
            s.capped
        );
    }
    if let Some(c) = &frame.compute {
        let [texels, cells, descents, backtracks] = c.summary(&frame.mask);
        log::info!(
            "compute: {} rays ({} retraced: cut by the driver's loop limit), subgroup size {} (min {}), per ray mean/max: texels {:.1}/{}, cells {:.1}/{}, descents {:.1}/{}, backtracks {:.1}/{}",
            c.rays,
            c.retraced,
            c.subgroup_size.1,
            c.subgroup_size.0,
            texels.0,
            texels.1,
            cells.0,
            cells.1,
            descents.0,
            descents.1,
            backtracks.0,
            backtracks.1
        );
    }
    if let Some(b) = &frame.bvh {
        log::info!(
            "bvh: {} rays traced ({}), {} cut by the loop cap",
            b.count,
            if method == Method::EXACT_GPU {
                "every mirror ray"
            } else if frame.compute.is_some() && frame.records.iter().any(|r| r.bounces >= 2) {
                // The compute path traces the rounds of --bounces, each with its fallback.
                "the fallback's, in the last round of --bounces"
            } else {
                "the fallback's"
            },
            b.cut
        );
    }
    for (k, r) in frame.rounds.iter().enumerate() {
        log::info!(
            "bounce round {}: {} rays{}",
            k + 2,
            r.rays,
            if r.method {
                format!(
                    " through the cube maps, {} of them finished by the fallback",
                    r.fallback
                )
            } else {
                " traced by the BVH".to_string()
            }
        );
    }
    if let Some(l) = &frame.lists {
        log::info!(
            "capture lists: {} nodes, {} jobs ({} small), {} faces queued; dropped {} nodes, {} \
             jobs and {} faces (full buffers), {} list walks and {} face tilings capped",
            l.nodes,
            l.jobs,
            l.small_jobs,
            l.pairs,
            l.nodes_dropped,
            l.jobs_dropped,
            l.pairs_dropped,
            l.walks_capped,
            l.tiles_capped
        );
        let cut =
            l.nodes_dropped + l.jobs_dropped + l.pairs_dropped + l.walks_capped + l.tiles_capped;
        if cut > 0 {
            log::warn!(
                "--criterion bounded: the capture's lists were cut ({} nodes, {} jobs and {} \
                 faces dropped, {} walks and {} tilings capped): rays through those texels past \
                 the cut go to the next CMO or the fallback",
                l.nodes_dropped,
                l.jobs_dropped,
                l.pairs_dropped,
                l.walks_capped,
                l.tiles_capped
            );
        }
    }
}

/// The `wrote ...` line of a GPU render (the counts of the AOV sample, the GPU time of every
/// sample).
fn gpu_summary(
    path: &Path,
    args: &RenderArgs,
    scene: &Scene,
    rendered: &RenderedFrame,
    count: &FallbackCount,
    render_time: Duration,
    ctx: &GpuContext,
) -> String {
    // A cube-map tracer names its criterion (the default is bounded; `centre` is asked for).
    let method = args.method;
    let criterion = args.trace.options(method).trace.criterion;
    let label = match method.traces_cubemaps() {
        true => format!(
            "{method} ({} criterion)",
            crate::method::criterion_name(criterion)
        ),
        false => method.to_string(),
    };
    format!(
        "wrote {} ({}x{}{}, scene '{}', method {}, {}) in {:.2?} ({:.2} ms GPU on {})",
        path.display(),
        rendered.width,
        rendered.height,
        spp_note(rendered.spp),
        scene.name,
        label,
        summary::counts(method, count),
        render_time,
        rendered.gpu_ms,
        ctx.report().name,
    )
}

/// `, N spp` in the summary line at more than one sample (nothing at one: the one-sample line).
fn spp_note(spp: u32) -> String {
    if spp > 1 {
        format!(", {spp} spp")
    } else {
        String::new()
    }
}

/// `--compare`: renders the reference with the same bounces and film (the same sample offsets
/// and filter) and gives the error line of the filtered frames (colours filtered, the rest of
/// the AOV sample's) and, at more than one sample, the mean of each sample's own comparison (a
/// warning where the mirror masks disagree). On a glossy scene, the PSNR against a converged
/// reference instead ([`glossy_comparison`]). The lines, for the caller to print.
pub(super) fn compare_with_reference(
    args: &RenderArgs,
    scene: &Scene,
    camera: &Camera,
    film: crate::film::FilmSettings,
    rendered: &RenderedFrame,
) -> Vec<String> {
    let Some(traced) = rendered.traced() else {
        return Vec::new();
    };
    let Some(frame) = &rendered.gpu else {
        return Vec::new();
    };
    let tracer = reference::Tracer::new(scene);
    if !scene.glossy_reflectors().is_empty() {
        return vec![glossy_comparison(
            scene,
            &tracer,
            camera,
            args.compare_spp,
            args.bounces,
            rendered,
        )];
    }
    let keep = film.spp > 1;
    let (refr, ref_samples) =
        engine::samples::reference_frame(scene, &tracer, camera, args.bounces, film, keep);
    // The GPU records hold each path's last hit (the first reflected one for one bounce).
    let refr = refr.with_last_hits(&tracer);
    let centres = scene.cmo_centres();
    let r = metrics::compare(
        &refr,
        &traced,
        &frame.surface_position,
        &centres,
        scene.cmo.resolution,
    );
    let mut lines = vec![compare_summary(&r)];
    if r.mask_mismatch > 0 {
        log::warn!(
            "the mirror masks disagree on {} pixels: {} mirror pixels of the reference are not mirror pixels here, {} mirror pixels here are not in the reference",
            r.mask_mismatch,
            r.mask_missed,
            r.mask_extra
        );
    }
    if keep {
        let per: Vec<metrics::ErrorReport> = rendered
            .samples
            .iter()
            .zip(&ref_samples)
            .filter_map(|(g, rf)| {
                let (t, p) = g.traced.as_ref()?;
                let rf = rf.reference.as_ref()?.with_last_hits(&tracer);
                Some(metrics::compare(&rf, t, p, &centres, scene.cmo.resolution))
            })
            .collect();
        lines.push(per_sample_summary(&per));
    }
    lines
}

/// The `--compare` line of a glossy scene. A reflected ray's hit is one sample of the lobe, so
/// hits cannot be compared; the colour can, against the lobe's integral: the reference of the
/// frame's `bounces` at `spp` samples at the film's offsets
/// ([`engine::glossy::reference_frame_bounces`], bit for bit `cubetrace reference --bounces B
/// --spp N`), whose own accuracy is the PSNR of its even-numbered samples
/// against all of them (an unbiased estimate's error falls as 1/sqrt(spp), so the full frame is
/// about 3 dB closer to the truth than that). PSNR over the reference's mirror pixels.
fn glossy_comparison(
    scene: &Scene,
    tracer: &reference::Tracer,
    camera: &Camera,
    spp: u32,
    bounces: u32,
    rendered: &RenderedFrame,
) -> String {
    let (truth, half) =
        engine::glossy::reference_frame_bounces(scene, tracer, camera, bounces, spp, true);
    let psnr = metrics::psnr_over(rendered.colour(), &truth.colour, &truth.mask);
    let half_psnr = metrics::psnr_over(&half, &truth.colour, &truth.mask);
    format!(
        "against a converged reference ({spp} spp; its half-spp PSNR {half_psnr:.2} dB, glossy \
         reflectors: {}): {} mirror pixels, PSNR {psnr:.2} dB over mirror pixels",
        scene.glossy_reflectors().join(", "),
        truth.mirror_pixels(),
    )
}

/// The `--compare` line of the samples one by one (more than one sample per pixel), each
/// against the reference's sample at the same offset: the mean share of each error, and the
/// PSNR of the samples' pooled squared error over mirror pixels, the sample-pixels of each error
/// summed (a share rounds a handful to 0.00 %), and the worst, median and best sample's PSNR.
fn per_sample_summary(per: &[metrics::ErrorReport]) -> String {
    let n = per.len().max(1) as f64;
    let mean = |f: &dyn Fn(&metrics::ErrorReport) -> f64| per.iter().map(f).sum::<f64>() / n;
    // PSNR back to the squared error it came from (peak 1), pooled, and back.
    let pooled = -10.0 * mean(&|r| 10f64.powf(-r.psnr_db / 10.0)).log10();
    let mut sorted: Vec<f64> = per.iter().map(|r| r.psnr_db).collect();
    sorted.sort_by(f64::total_cmp);
    let (worst, median, best) = match sorted.as_slice() {
        [] => (f64::NAN, f64::NAN, f64::NAN),
        s => (s[0], s[s.len() / 2], s[s.len() - 1]),
    };
    // Sample-pixels, summed over the samples: a share rounds a few of them to 0.00 %.
    let count = |f: &dyn Fn(&metrics::ErrorReport) -> f64| -> usize {
        per.iter()
            .map(|r| (f(r) * r.mirror_pixels as f64).round() as usize)
            .sum()
    };
    format!(
        "per sample ({} samples, each against the reference's sample at the same offset): mean {:.2}% in error: mask mismatch {:.2}%, unresolved {:.2}%, wrong surface {:.2}%; of {} mirror sample-pixels, {} mask mismatch ({} only in the reference, {} only here), {} unresolved, {} wrong surface; PSNR {:.2} dB over mirror pixels (all samples' squared error pooled); one sample's PSNR: worst {:.2}, median {:.2}, best {:.2} dB",
        per.len(),
        100.0 * mean(&|r| r.error),
        100.0 * mean(&|r| r.mask_mismatch_fraction),
        100.0 * mean(&|r| r.unresolved),
        100.0 * mean(&|r| r.wrong_surface),
        per.iter().map(|r| r.mirror_pixels).sum::<usize>(),
        per.iter().map(|r| r.mask_mismatch).sum::<usize>(),
        per.iter().map(|r| r.mask_missed).sum::<usize>(),
        per.iter().map(|r| r.mask_extra).sum::<usize>(),
        count(&|r| r.unresolved),
        count(&|r| r.wrong_surface),
        pooled,
        worst,
        median,
        best,
    )
}

/// The reference render: host memory check and BVH ([`FrameRenderer::open`]), the frame's
/// samples (with a progress bar on large frames), file and the `wrote ...` line.
fn render_reference(
    args: &RenderArgs,
    scene: &Scene,
    camera: &Camera,
    target: &Target,
    start: Instant,
) -> Result<()> {
    let mut renderer = FrameRenderer::open(&render_setup(args, scene)?, scene, camera)?;
    let rendered = renderer.render(scene, camera)?;
    let render_time = start.elapsed();
    rendered.write(&target.path, target.format)?;
    println!(
        "wrote {} ({}x{}{}, scene '{}', method {}, {} mirror pixels) in {:.2?}",
        target.path.display(),
        rendered.width,
        rendered.height,
        spp_note(rendered.spp),
        scene.name,
        args.method,
        rendered.mirror_pixels(),
        render_time
    );
    Ok(())
}

/// Mirror pixels per outcome of the screen-space method, and the mean iterations.
fn ssr_outcomes(frame: &GpuFrame) -> String {
    use crate::cpu::ssr::Outcome;
    let mirror: Vec<_> = (0..frame.records.len())
        .filter(|&k| frame.mask[k] != 0)
        .map(|k| frame.records[k])
        .collect();
    let n = mirror.len().max(1) as f64;
    let iterations: f64 = mirror.iter().map(|r| f64::from(r.cells)).sum();
    let traced = mirror
        .iter()
        .filter(|r| r.face != Outcome::TowardsCamera as u32)
        .count()
        .max(1) as f64;
    let counts: Vec<String> = Outcome::ALL
        .iter()
        .map(|o| {
            let c = mirror.iter().filter(|r| r.face == *o as u32).count();
            format!("{} {c}", o.name())
        })
        .collect();
    format!(
        "{}; {:.1} iterations per mirror pixel, {:.1} per traced ray",
        counts.join(", "),
        iterations / n,
        iterations / traced
    )
}

/// The `--compare` line: every figure over the mirror pixels of either frame, the mask
/// disagreements both ways first; `-` where a figure does not exist (no mirror pixel, no hit).
fn compare_summary(r: &metrics::ErrorReport) -> String {
    let num = |x: f64, digits: usize| {
        if x.is_nan() {
            "-".to_string()
        } else {
            format!("{x:.digits$}")
        }
    };
    format!(
        "against the reference: {} mirror pixels (either frame), {:.2}% in error: mask mismatch {:.2}% ({} only in the reference, {} only here), unresolved {:.2}%, wrong surface {:.2}%; angular error mean {} deg / p95 {} deg; PSNR {} dB over mirror pixels, {} dB over resolved mirror pixels, {} dB over the frame{}",
        r.mirror_pixels,
        100.0 * r.error,
        100.0 * r.mask_mismatch_fraction,
        r.mask_missed,
        r.mask_extra,
        100.0 * r.unresolved,
        100.0 * r.wrong_surface,
        num(r.angular_mean_deg, 3),
        num(r.angular_p95_deg, 3),
        num(r.psnr_db, 2),
        num(r.psnr_resolved_db, 2),
        num(r.psnr_frame_db, 2),
        if r.same_triangle.is_nan() {
            String::new()
        } else {
            format!(
                "; same triangle {:.2}% of resolved mirror pixels",
                100.0 * r.same_triangle
            )
        },
    )
}

#![forbid(unsafe_code)]
//! `cubetrace render`: one frame of one method, written as PNG or EXR, optionally compared with
//! the reference.
//!
//! The order is the command's promise: the scene and its overrides are loaded and checked, then
//! the output path, then (GPU methods) the bounce rule, the device and the memory the render
//! needs ([`check_gpu_memory`], the one estimate of [`crate::vk::budget::estimate`], also the
//! bench's) or (reference) the host memory; only then anything is rendered. A refusal at any
//! step leaves no file behind.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Result;

use super::GpuArgs;
use super::options::TraceArgs;
use super::summary::{self, FallbackCount};
use crate::Method;
use crate::camera::Camera;
use crate::memory;
use crate::metrics::{self, Traced};
use crate::output::{self, Format};
use crate::reference;
use crate::scene::{self, Scene};
use crate::vk::GpuContext;
use crate::vk::frame::{GpuFrame, GpuRenderer, RenderOptions};

#[derive(clap::Args)]
pub struct RenderArgs {
    /// Built-in scene name or path to a .toml scene file.
    #[arg(default_value = "default")]
    pub scene: String,
    /// How reflections are computed (default: the compute path, thesis alg. 3).
    #[arg(long, value_enum, default_value_t = Method::Compute)]
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
    /// shows its own material colour. GPU methods: compute, bvh and fragment (exact criterion);
    /// the reflections after the first are traced by the BVH.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=16))]
    pub bounces: u32,
    /// Output file, .png or .exr [default: out/SCENE-METHOD.png].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also render the reference and print the error of the method against it, over the mirror
    /// pixels of either image: mask mismatch (a mirror pixel of one image only, counted both
    /// ways), unresolved, wrong surface, angular error; PSNR over mirror pixels and over the
    /// whole frame. GPU methods only: with --method reference it is refused (the reference
    /// would be compared with itself).
    #[arg(long)]
    pub compare: bool,
    /// Split every triangle of the non-reflector objects into four, N times, before rendering
    /// (with any method, so the reference sees the same geometry): the surfaces stay, the vertex
    /// count grows 4^N-fold (at most 5: about 1000 times). The reflection-point method reflects
    /// vertices, so this is its quality knob.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=5))]
    pub subdivide: u32,
    #[command(flatten)]
    pub trace: TraceArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
    #[command(flatten)]
    pub sequence: super::frames::SequenceArgs,
}

/// Where the frame goes and what it is, settled before anything renders.
struct Target {
    path: PathBuf,
    format: Format,
    /// `a WxH frame with --method M`: the subject of the memory refusals.
    size: String,
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

/// The frame size: the camera's, or `--width`/`--height`; one of them alone keeps the camera's
/// aspect ratio (the other side rounded, at least 1).
pub fn frame_size(camera: (u32, u32), width: Option<u32>, height: Option<u32>) -> (u32, u32) {
    let (w, h) = (f64::from(camera.0), f64::from(camera.1));
    let other = |given: u32, ratio: f64| ((f64::from(given) * ratio).round().max(1.0)) as u32;
    match (width, height) {
        (Some(x), Some(y)) => (x, y),
        (Some(x), None) => (x, other(x, h / w)),
        (None, Some(y)) => (other(y, w / h), y),
        (None, None) => camera,
    }
}

/// `cubetrace render`.
pub fn render(args: RenderArgs) -> Result<()> {
    let start = Instant::now();
    args.check_method()?;
    let (scene, camera) = load_scene(&args)?;
    let target = check_target(&args, &scene, &camera)?;
    if args.method.is_gpu() {
        render_gpu(&args, &scene, &camera, &target, start)
    } else {
        render_reference(&args, &scene, &camera, &target, start)
    }
}

/// Loads the scene, applies the CMO overrides, the subdivision and the frame size to it and its
/// camera, resolves a CMO placement search for that camera and logs the scene's problems.
pub fn load_scene(args: &RenderArgs) -> Result<(Scene, Camera)> {
    let mut scene = timed("scene load", || scene::load(&args.scene))?;
    args.trace.apply(&mut scene);
    if args.subdivide > 0 {
        timed("subdivision", || {
            crate::cpu::reflection_point::subdivide_non_reflectors(&mut scene, args.subdivide)
        });
    }
    let mut camera = scene.camera(args.camera.as_deref())?.clone();
    (camera.width, camera.height) =
        frame_size((camera.width, camera.height), args.width, args.height);
    scene::check_resolution(camera.width, camera.height)
        .map_err(|e| anyhow::anyhow!("--width/--height: {e}"))?;
    let requested = match scene.cmo.placement {
        scene::CmoPlacement::Search { count } => count,
        _ => 0,
    };
    if let Some(p) = timed("CMO placement", || {
        crate::placement::resolve(&mut scene, &camera)
    }) {
        log::info!(
            "cmo placement auto: {} reflected rays sampled; unresolved {:.2}% with {count} along the axis",
            p.rays,
            100.0 * p.axis_unresolved,
            count = requested,
        );
        for (k, (c, share)) in p.centres.iter().zip(&p.unresolved).enumerate() {
            log::info!(
                "cmo placement auto: CMO {k} at [{:.3}, {:.3}, {:.3}]: unresolved {:.2}%",
                c.x,
                c.y,
                c.z,
                100.0 * share
            );
        }
    }
    timed("reflector convexity", || {
        scene.self_capture();
    });
    for problem in timed("scene check", || crate::placement::diagnose(&scene)) {
        log::warn!("{problem}");
    }
    Ok((scene, camera))
}

/// Runs one host phase of the command and logs its name and time (info; `-v`), so that no
/// phase's time is credited to another.
pub fn timed<T>(phase: &str, f: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let out = f();
    log::info!("{phase}: {:.2?}", start.elapsed());
    out
}

/// The output path (`-o`, else `out/SCENE-METHOD.png`), checked before any time is spent on the
/// render.
fn check_target(args: &RenderArgs, scene: &Scene, camera: &Camera) -> Result<Target> {
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
    let size = format!(
        "a {}x{} frame with --method {method}",
        camera.width, camera.height
    );
    Ok(Target { path, format, size })
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

/// Refuses a GPU render that would not fit: the host bytes (the read-back, the output and with
/// `compare` the reference; on a CPU device the device's bytes too) against `limits.host`, then
/// the device bytes of [`crate::vk::budget::estimate`] (CMOs, frame, bounce queues, reflector
/// check) against `limits.device`. `size` names the frame (`a WxH frame with --method M`),
/// `device` the device. The bench's [`crate::bench::check_memory`] holds the same estimate
/// against the same limits.
#[allow(clippy::too_many_arguments)]
pub fn check_gpu_memory(
    size: &str,
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    format: Format,
    compare: bool,
    device: &str,
    limits: &memory::Limits,
) -> Result<()> {
    let estimate = crate::vk::budget::estimate(scene, camera, options);
    let pixels = u64::from(camera.width) * u64::from(camera.height);
    let mut host = memory::gpu_host_bytes(pixels, format, compare);
    if limits.device_is_host {
        // A CPU device's memory is the machine's.
        host += estimate.total();
    }
    let gpu_size = format!(
        "{size} ({} CMOs of {}^2 texels per face: {} of GPU data)",
        scene.cmo_centres().len(),
        scene.cmo.resolution,
        memory::human(estimate.total())
    );
    let advice = memory::advice(&crate::vk::budget::largest_items(scene, camera, options));
    memory::check_with(&gpu_size, host, limits.host.clone(), &advice)?;
    memory::check_with(
        &format!(
            "{size} ({} of CMO data, {} per frame, {} of scene data) on {device}",
            memory::human(estimate.cmo),
            memory::human(estimate.frame),
            memory::human(estimate.scene),
        ),
        estimate.total(),
        Some(limits.device.clone()),
        &advice,
    )
}

/// Refuses a scene whose textures do not fit the one storage buffer that holds them all
/// (`maxStorageBufferRange` of the device, `limit` bytes), naming the largest textures.
pub fn check_textures(scene: &Scene, limit: u64, device: &str) -> Result<()> {
    let need = crate::vk::budget::texel_buffer_bytes(scene);
    if need <= limit {
        return Ok(());
    }
    let mut textures: Vec<_> = scene.textures.iter().collect();
    textures.sort_by_key(|t| std::cmp::Reverse(crate::vk::budget::texture_bytes(t)));
    let listed: Vec<String> = textures
        .iter()
        .take(3)
        .map(|t| {
            format!(
                "texture '{}' {}x{}: {}",
                t.name,
                t.width,
                t.height,
                memory::human(crate::vk::budget::texture_bytes(t))
            )
        })
        .collect();
    anyhow::bail!(
        "scene '{}': its textures take {} in one GPU buffer, more than {device} can bind \
         (maxStorageBufferRange = {}); the largest: {}; scale them down (each halving of a \
         texture's sides takes 3/4 off)",
        scene.name,
        memory::human(need),
        memory::human(limit),
        listed.join(", ")
    )
}

/// The renderer's options of a GPU render, refused where the method cannot trace `--bounces`.
pub fn gpu_options(args: &RenderArgs) -> Result<RenderOptions> {
    args.check_method()?;
    let options = args.trace.options(args.method);
    Ok(RenderOptions {
        bounces: args.bounces,
        ..options
    })
}

/// The GPU render: device, memory check, renderer, frame, file, summary, validation and the
/// optional comparison.
fn render_gpu(
    args: &RenderArgs,
    scene: &Scene,
    camera: &Camera,
    target: &Target,
    start: Instant,
) -> Result<()> {
    let options = gpu_options(args)?;
    let loaded = start.elapsed();
    let ctx = args.gpu.context()?;
    let device_ready = start.elapsed();
    check_textures(
        scene,
        u64::from(ctx.report().max_storage_buffer_range),
        &ctx.report().name,
    )?;
    let limits = memory::Limits::of_device(ctx.device_local_heap_bytes(), ctx.device_is_cpu())?;
    check_gpu_memory(
        &target.size,
        scene,
        camera,
        &options,
        target.format,
        args.compare,
        &ctx.report().name,
        &limits,
    )?;
    let mut renderer = timed("GPU renderer (passes, pipelines, BVHs)", || {
        GpuRenderer::new(&ctx, scene, camera, options)
    })?;
    let created = start.elapsed();
    let frame = renderer.render(&ctx)?;
    let render_time = start.elapsed();
    let traced = frame.traced();
    output::write_traced(
        &target.path,
        &traced,
        &frame.surface_position,
        &scene.world(),
    )?;
    let written = start.elapsed();
    log::info!(
        "host: scene {:.0} ms, device {:.0} ms, passes and pipelines {:.0} ms, frame (submit, wait, read back) {:.0} ms, {} {:.0} ms",
        loaded.as_secs_f64() * 1e3,
        (device_ready - loaded).as_secs_f64() * 1e3,
        (created - device_ready).as_secs_f64() * 1e3,
        (render_time - created).as_secs_f64() * 1e3,
        target.path.display(),
        (written - render_time).as_secs_f64() * 1e3,
    );
    log_gpu_frame(&frame, args.method);
    let count = FallbackCount::of(&frame, &traced);
    if let Some(warning) = summary::fallback_warning(args.method, scene, &count) {
        log::warn!("{warning}");
    }
    println!(
        "{}",
        gpu_summary(
            &target.path,
            args.method,
            scene,
            &frame,
            &count,
            render_time,
            &ctx
        )
    );
    crate::bench::check_validation(&ctx)?;
    if args.compare {
        compare_with_reference(scene, camera, args.bounces, &frame, &traced);
    }
    Ok(())
}

/// The `-v` lines of a GPU frame: pass times and the method's own counters.
fn log_gpu_frame(frame: &GpuFrame, method: Method) {
    for (pass, ns) in &frame.pass_times {
        log::info!("{pass:>16}: {:9.3} ms", ns * 1e-6);
    }
    if method == Method::Ssr {
        log::info!("ssr: {}", ssr_outcomes(frame));
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
            "compute: {} rays, subgroup size {} (min {}), per ray mean/max: texels {:.1}/{}, cells {:.1}/{}, descents {:.1}/{}, backtracks {:.1}/{}",
            c.rays,
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
            if method == Method::Bvh {
                "every mirror ray"
            } else {
                "the fallback's"
            },
            b.cut
        );
    }
    if let Some(l) = &frame.lists {
        log::info!(
            "capture lists: {} nodes, {} jobs; dropped {} nodes and {} jobs (full buffers), {} \
             list walks and {} face tilings capped",
            l.nodes,
            l.jobs,
            l.nodes_dropped,
            l.jobs_dropped,
            l.walks_capped,
            l.tiles_capped
        );
        let cut = l.nodes_dropped + l.jobs_dropped + l.walks_capped + l.tiles_capped;
        if cut > 0 {
            log::warn!(
                "--criterion bounded: the capture's lists were cut ({} nodes and {} jobs \
                 dropped, {} walks and {} tilings capped): rays through those texels past the \
                 cut go to the next CMO or the fallback",
                l.nodes_dropped,
                l.jobs_dropped,
                l.walks_capped,
                l.tiles_capped
            );
        }
    }
}

/// The `wrote ...` line of a GPU render.
fn gpu_summary(
    path: &Path,
    method: Method,
    scene: &Scene,
    frame: &GpuFrame,
    count: &FallbackCount,
    render_time: Duration,
    ctx: &GpuContext,
) -> String {
    let gpu_ms: f64 = frame.pass_times.iter().map(|(_, t)| t).sum::<f64>() * 1e-6;
    format!(
        "wrote {} ({}x{}, scene '{}', method {}, {}) in {:.2?} ({gpu_ms:.2} ms GPU on {})",
        path.display(),
        frame.width,
        frame.height,
        scene.name,
        method,
        summary::counts(method, count),
        render_time,
        ctx.report().name,
    )
}

/// `--compare`: renders the reference with the same bounces and prints the error line (and a
/// warning where the mirror masks disagree).
fn compare_with_reference(
    scene: &Scene,
    camera: &Camera,
    bounces: u32,
    frame: &GpuFrame,
    traced: &Traced,
) {
    let tracer = reference::Tracer::new(scene);
    // The GPU records hold each path's last hit (the first reflected one for one bounce).
    let refr = reference::render(scene, &tracer, camera, bounces).with_last_hits(&tracer);
    let r = metrics::compare(
        &refr,
        traced,
        &frame.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    );
    println!("{}", compare_summary(&r));
    if r.mask_mismatch > 0 {
        log::warn!(
            "the mirror masks disagree on {} pixels: {} mirror pixels of the reference are not mirror pixels here, {} mirror pixels here are not in the reference",
            r.mask_mismatch,
            r.mask_missed,
            r.mask_extra
        );
    }
}

/// The reference render: host memory check, BVH, frame (with a progress bar on large frames),
/// file and the `wrote ...` line.
fn render_reference(
    args: &RenderArgs,
    scene: &Scene,
    camera: &Camera,
    target: &Target,
    start: Instant,
) -> Result<()> {
    let pixels = u64::from(camera.width) * u64::from(camera.height);
    memory::check(
        &target.size,
        memory::reference_bytes(pixels, target.format),
        memory::host_available()?,
    )?;
    let bvh_start = Instant::now();
    let tracer = reference::Tracer::new(scene);
    log::info!(
        "{}: {} triangles, BVH built in {:.2?} ({:.2?} since the start)",
        scene.name,
        tracer.world.triangles.len(),
        bvh_start.elapsed(),
        start.elapsed()
    );
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("reference {bar:40} {pos}/{len} rows {elapsed}")
            .expect("the template is valid"),
    );
    // Small frames finish before a bar would help; indicatif hides it off a terminal.
    if camera.width as u64 * camera.height as u64 * (args.bounces as u64 + 1) < 2_000_000 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let frame = reference::render_with_progress(scene, &tracer, camera, args.bounces, &bar);
    let render_time = start.elapsed();
    output::write_frame(&target.path, &frame, &tracer.world)?;
    println!(
        "wrote {} ({}x{}, scene '{}', method {}, {} mirror pixels) in {:.2?}",
        target.path.display(),
        frame.width,
        frame.height,
        scene.name,
        args.method,
        frame.mirror_pixels(),
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

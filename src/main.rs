#![forbid(unsafe_code)]
//! The `cubetrace` command line.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};

use cubetrace::Method;
use cubetrace::cpu::options::{TraceCriterion, TraceOptions, TraceSampling};
use cubetrace::scene::{CmoPlacement, Scene};
use cubetrace::vk::frame::{Fallback, GpuRenderer, RenderOptions};
use cubetrace::vk::{ContextOptions, GpuContext, Validation};
use cubetrace::{memory, metrics, output, reference, scene};

/// Accurate mirror reflections on curved surfaces by cubemap tracing.
///
/// Scenes are built-in names (see `cubetrace scenes`) or paths to TOML scene files (see
/// `cubetrace scene export` for an example to start from).
#[derive(Parser)]
#[command(name = "cubetrace", version, propagate_version = true)]
struct Cli {
    /// Log more (-v: info, -vv: debug). RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to an image (PNG: 8-bit sRGB; EXR: 32-bit float with per-pixel data).
    Render(RenderArgs),
    /// List the built-in scenes, one line each.
    Scenes,
    /// List the Vulkan devices: name, driver, subgroup size and operations, limits, timestamps.
    Info(GpuArgs),
    /// Speed against error: scenes x methods x parameters on the GPU, against the CPU reference
    /// (JSON, Markdown, SVG plot, heat maps); `--scaling` for the cost curves.
    Bench(BenchArgs),
    /// Work with scene files.
    Scene {
        #[command(subcommand)]
        command: SceneCommand,
    },
}

#[derive(Subcommand)]
enum SceneCommand {
    /// Write a built-in scene out as TOML + OBJ/MTL/PNG into DIR. The export loads back to the
    /// same scene: `cubetrace render DIR/scene.toml`.
    Export {
        /// Built-in scene name.
        name: String,
        /// Output folder (created if needed).
        dir: PathBuf,
        /// Overwrite the files of an earlier export (a `scene.toml` already in DIR).
        #[arg(long)]
        force: bool,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum CriterionArg {
    /// Exact per-texel surface (sphere patches, continuity rule): a silhouette is never a hit.
    Exact,
    /// The thesis's `|r - D| < eps` at samples.
    Threshold,
    /// The thesis's sign change of `r - D` between samples (fires at silhouettes too).
    SignChange,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum SamplingArg {
    /// `--steps` + 1 samples evenly spaced along the ray.
    ConstantStep,
    /// `--steps` + 1 samples evenly spaced in angle (between the endpoint directions).
    ConstantAngle,
    /// One sample per crossed texel.
    PerTexel,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum FallbackArg {
    /// Magenta: shows where tracing gave up.
    Flag,
    /// The environment-map lookup of the nearest CMO.
    Envmap,
    /// The scene's background colour.
    Background,
    /// Finish the rays exactly: the BVH tracer traces them from the mirror, as `--method bvh`
    /// does (the EXR's `fallback` channel marks them).
    Trace,
}

/// Vulkan device choice and validation.
#[derive(clap::Args, Clone, Copy)]
struct GpuArgs {
    /// Vulkan device index (see `cubetrace info`); default: a discrete GPU if any, else the first.
    #[arg(long)]
    device: Option<usize>,
    /// Run under the Khronos validation layer (also: CUBETRACE_VALIDATION=1); fails if it is not
    /// installed (Debian: vulkan-validationlayers).
    #[arg(long)]
    validate: bool,
}

impl GpuArgs {
    fn context(&self) -> Result<GpuContext> {
        Ok(GpuContext::new(ContextOptions {
            validation: if self.validate {
                Validation::Required
            } else {
                Validation::default()
            },
            device_index: self.device,
        })?)
    }
}

/// Parses a positive, finite distance (`--eps`, `--ssr-thickness`). Negative numbers reach this
/// parser (the argument allows them), so that `--eps -1` gets this message rather than clap's
/// "unexpected argument".
fn positive_finite(s: &str) -> std::result::Result<f32, String> {
    let v: f32 = s
        .parse()
        .map_err(|e| format!("'{s}' is not a number ({e})"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!(
            "{s} is not allowed: it must be a positive, finite distance in world units"
        ))
    }
}

/// Options of the cubemap tracer (`--method compute|fragment`; compute: exact criterion only).
#[derive(clap::Args)]
struct TraceArgs {
    /// Intersection criterion.
    #[arg(long, value_enum, default_value_t = CriterionArg::Exact)]
    criterion: CriterionArg,
    /// Sample placement of the threshold and sign-change criteria.
    #[arg(long, value_enum, default_value_t = SamplingArg::PerTexel)]
    sampling: SamplingArg,
    /// Turn off the min/max pyramid (exact criterion: walk every texel instead; same result).
    #[arg(long)]
    no_accel: bool,
    /// Exact criterion: count a hit inside a texel only where the texel data decides it (the
    /// ray gets behind the surface around the hit and no outline passes through the texel);
    /// elsewhere the ray is handed on, so more pixels end unresolved.
    ///
    /// What the tests show (tests/hard_cases.rs): with verified hits the default mode has no
    /// wrong hit or escape for the ray the GPU reflected on grazing rays, slabs thinner than a
    /// texel, outlines right behind the rays, scales 1e-3 and 1e4, cube sizes 32 and 2048 and
    /// the built-in scenes, and this mode none either; it removes wrong hits only at cube size 3
    /// (2 of 5, behind an object no texel sees) and elsewhere only adds unresolved pixels. It
    /// does not make surfaces the CMOs never captured (a reflector seeing itself) right: against
    /// the reference those pixels stay wrong, as without it (see `cubetrace bench`).
    #[arg(long)]
    strict: bool,
    /// Sample intervals along the ray for constant-step and constant-angle sampling.
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(1..=65536))]
    steps: u32,
    /// Threshold of the threshold criterion, world units (positive).
    #[arg(long, default_value_t = 0.05, allow_negative_numbers = true, value_parser = positive_finite)]
    eps: f32,
    /// Number of CMOs, placed automatically along the reflectors' longest axis (overrides the
    /// scene's CMO centres).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16))]
    cmos: Option<u32>,
    /// Texels per cube face side (overrides the scene's; 1 to 4096).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    cube_size: Option<u32>,
    /// What fills mirror pixels that no CMO could resolve (the method left unresolved): `trace`
    /// finishes their rays exactly with the BVH tracer of `--method bvh`.
    #[arg(long, value_enum, default_value_t = FallbackArg::Trace)]
    fallback: FallbackArg,
    /// fragment, compute: skip the reflector check (the exact trace, after the cubemap trace,
    /// of the reflectors the CMOs do not capture: the torus or teapot seen in itself).
    #[arg(long)]
    no_reflector_check: bool,
    /// ssr: iterations of the Hi-Z ray march before a ray is given up (unresolved).
    #[arg(long, default_value_t = cubetrace::cpu::ssr::DEFAULT_MAX_ITERATIONS,
          value_parser = clap::value_parser!(u32).range(1..=65536))]
    ssr_iterations: u32,
    /// ssr: thickness test, world units along the view axis: a hit farther than this behind the
    /// surface it lands on is unresolved. Default: none (the chapter's: every surface is
    /// infinitely thick, so a ray passing behind a thin object hits it).
    #[arg(long, allow_negative_numbers = true, value_parser = positive_finite)]
    ssr_thickness: Option<f32>,
    /// reflection-point: steps of one search (forward or inverse) before the vertex is given up
    /// (its triangles are then not drawn). Default: the search textures' width + height in texels.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    rp_iterations: Option<u32>,
    /// reflection-point: the search textures (the reflector's positions and normals) have this
    /// many times the frame's width and height.
    #[arg(long, default_value_t = cubetrace::cpu::reflection_point::DEFAULT_SEARCH_SCALE,
          value_parser = clap::value_parser!(u32).range(1..=8))]
    rp_scale: u32,
    /// reflection-point: search on the reflectors as they are, not on the closed versions of
    /// open ones (the paper's open/closed pair).
    #[arg(long)]
    rp_open: bool,
}

impl TraceArgs {
    fn options(&self, method: Method) -> RenderOptions {
        RenderOptions {
            method,
            trace: TraceOptions {
                criterion: match self.criterion {
                    CriterionArg::Exact => TraceCriterion::Exact,
                    CriterionArg::Threshold => TraceCriterion::Threshold,
                    CriterionArg::SignChange => TraceCriterion::SignChange,
                },
                sampling: match self.sampling {
                    SamplingArg::ConstantStep => TraceSampling::ConstantStep,
                    SamplingArg::ConstantAngle => TraceSampling::ConstantAngle,
                    SamplingArg::PerTexel => TraceSampling::PerTexel,
                },
                accel: !self.no_accel,
                strict: self.strict,
                steps: self.steps,
                eps: self.eps,
                ..TraceOptions::default()
            },
            reflector_check: !self.no_reflector_check,
            fallback: match self.fallback {
                FallbackArg::Flag => Fallback::Flag,
                FallbackArg::Envmap => Fallback::Envmap,
                FallbackArg::Background => Fallback::Background,
                FallbackArg::Trace => Fallback::Trace,
            },
            ssr: cubetrace::cpu::ssr::SsrOptions {
                max_iterations: self.ssr_iterations,
                thickness: self.ssr_thickness,
            },
            reflection_point: cubetrace::cpu::reflection_point::RpOptions {
                max_iterations: self.rp_iterations,
                search_scale: self.rp_scale,
                close_reflectors: !self.rp_open,
            },
            ..RenderOptions::default()
        }
    }

    /// Applies the CMO overrides to the scene.
    fn apply(&self, scene: &mut Scene) {
        if let Some(count) = self.cmos {
            scene.cmo.placement = CmoPlacement::Auto { count };
        }
        if let Some(size) = self.cube_size {
            scene.cmo.resolution = size;
        }
    }
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Built-in scene name or path to a .toml scene file.
    #[arg(default_value = "default")]
    scene: String,
    /// How reflections are computed (default: the compute path, thesis alg. 3).
    #[arg(long, value_enum, default_value_t = Method::Compute)]
    method: Method,
    /// Camera of the scene, by name or index (default: the first).
    #[arg(long)]
    camera: Option<String>,
    /// Image width in pixels (default: the camera's).
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (default: the camera's).
    #[arg(long)]
    height: Option<u32>,
    /// Maximum number of mirror reflections per path (0..=16). After the last one, a mirror
    /// shows its own material colour. GPU methods: compute, bvh and fragment (exact criterion);
    /// the reflections after the first are traced by the BVH.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=16))]
    bounces: u32,
    /// Output file, .png or .exr [default: out/SCENE-METHOD.png].
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Also render the reference and print the error of the method against it, over the mirror
    /// pixels of either image: mask mismatch (a mirror pixel of one image only, counted both
    /// ways), unresolved, wrong surface, angular error; PSNR over mirror pixels and over the
    /// whole frame.
    #[arg(long)]
    compare: bool,
    /// Split every triangle of the non-reflector objects into four, N times, before rendering
    /// (with any method, so the reference sees the same geometry): the surfaces stay, the vertex
    /// count grows 4^N-fold (at most 5: about 1000 times). The reflection-point method reflects
    /// vertices, so this is its quality knob.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=5))]
    subdivide: u32,
    #[command(flatten)]
    trace: TraceArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// Mirror pixels per outcome of the screen-space method, and the mean iterations.
fn ssr_outcomes(frame: &cubetrace::vk::frame::GpuFrame) -> String {
    use cubetrace::cpu::ssr::Outcome;
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

fn render(args: RenderArgs) -> Result<()> {
    let start = Instant::now();
    let mut scene = scene::load(&args.scene)?;
    args.trace.apply(&mut scene);
    cubetrace::cpu::reflection_point::subdivide_non_reflectors(&mut scene, args.subdivide);
    let mut camera = scene.camera(args.camera.as_deref())?.clone();
    camera.width = args.width.unwrap_or(camera.width);
    camera.height = args.height.unwrap_or(camera.height);
    scene::check_resolution(camera.width, camera.height)
        .map_err(|e| anyhow::anyhow!("--width/--height: {e}"))?;
    let requested = match scene.cmo.placement {
        scene::CmoPlacement::Search { count } => count,
        _ => 0,
    };
    if let Some(p) = scene.resolve_cmo_placement(&camera) {
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
    for problem in scene::diagnose(&scene) {
        log::warn!("{problem}");
    }
    let method = args
        .method
        .to_possible_value()
        .map(|v| v.get_name().to_string());
    let method = method.unwrap_or_default();
    // The scene's name comes from its file: only a sanitised form of it enters the path.
    let out = args.output.unwrap_or_else(|| {
        PathBuf::from("out").join(format!(
            "{}-{method}.png",
            output::safe_file_stem(&scene.name)
        ))
    });
    // Check the output before spending time on the render.
    let format = output::check_output(&out)?;
    let pixels = u64::from(camera.width) * u64::from(camera.height);
    let size = format!(
        "a {}x{} frame with --method {method}",
        camera.width, camera.height
    );

    let gpu_method = args.method.is_gpu().then_some(args.method);
    if let Some(m) = gpu_method {
        m.check_bounces(
            args.bounces,
            cubetrace::vk::passes::bounce::MAX_BOUNCES,
            &args.trace.options(m).trace,
        )
        .map_err(anyhow::Error::msg)?;
        let options = RenderOptions {
            bounces: args.bounces,
            ..args.trace.options(m)
        };
        let loaded = start.elapsed();
        let ctx = args.gpu.context()?;
        let device_ready = start.elapsed();
        let device = cubetrace::vk::budget::estimate(&scene, &camera, &options);
        let mut host = memory::gpu_host_bytes(pixels, format, args.compare);
        if ctx.device_is_cpu() {
            // A CPU device's memory is the machine's.
            host += device.total();
        }
        let gpu_size = format!(
            "{size} ({} CMOs of {}^2 texels per face: {} of GPU data)",
            scene.cmo_centres().len(),
            scene.cmo.resolution,
            memory::human(device.total())
        );
        memory::check(&gpu_size, host, memory::host_available()?)?;

        memory::check(
            &format!(
                "{size} ({} of CMO data, {} per frame) on {}",
                memory::human(device.cmo),
                memory::human(device.frame),
                ctx.report().name
            ),
            device.total(),
            Some(memory::device_available(ctx.device_local_heap_bytes())?),
        )?;
        let mut renderer = GpuRenderer::new(&ctx, &scene, &camera, options)?;
        let created = start.elapsed();
        let frame = renderer.render(&ctx)?;
        let render_time = start.elapsed();
        let traced = frame.traced();
        output::write_traced(&out, &traced, &frame.surface_position)?;
        let written = start.elapsed();
        log::info!(
            "host: scene {:.0} ms, device {:.0} ms, passes and pipelines {:.0} ms, frame (submit, wait, read back) {:.0} ms, {} {:.0} ms",
            loaded.as_secs_f64() * 1e3,
            (device_ready - loaded).as_secs_f64() * 1e3,
            (created - device_ready).as_secs_f64() * 1e3,
            (render_time - created).as_secs_f64() * 1e3,
            out.display(),
            (written - render_time).as_secs_f64() * 1e3,
        );
        let gpu_ms: f64 = frame.pass_times.iter().map(|(_, t)| t).sum::<f64>() * 1e-6;
        for (pass, ns) in &frame.pass_times {
            log::info!("{pass:>16}: {:9.3} ms", ns * 1e-6);
        }
        if m == Method::Ssr {
            log::info!("ssr: {}", ssr_outcomes(&frame));
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
                if m == Method::Bvh {
                    "every mirror ray"
                } else {
                    "the fallback's"
                },
                b.cut
            );
        }
        let unresolved = traced
            .mask
            .iter()
            .zip(&traced.resolved)
            .filter(|(m, r)| **m != 0 && **r == 0)
            .count();
        println!(
            "wrote {} ({}x{}, scene '{}', method {method}, {} mirror pixels, {} unresolved) in {:.2?} ({gpu_ms:.2} ms GPU on {})",
            out.display(),
            frame.width,
            frame.height,
            scene.name,
            frame.mirror_pixels(),
            unresolved,
            render_time,
            ctx.report().name,
        );
        let errors = ctx.validation_errors();
        if !errors.is_empty() {
            anyhow::bail!(
                "the validation layer reported errors:\n{}",
                errors.join("\n")
            );
        }
        if args.compare {
            let tracer = reference::Tracer::new(&scene);
            // The GPU records hold each path's last hit (the first reflected one for one bounce).
            let refr =
                reference::render(&scene, &tracer, &camera, args.bounces).with_last_hits(&tracer);
            let r = metrics::compare(
                &refr,
                &traced,
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
        return Ok(());
    }
    let frame = {
        memory::check(
            &size,
            memory::reference_bytes(pixels, format),
            memory::host_available()?,
        )?;
        let tracer = reference::Tracer::new(&scene);
        log::info!(
            "{}: {} triangles, BVH built in {:.2?}",
            scene.name,
            tracer.world.triangles.len(),
            start.elapsed()
        );
        let bar = indicatif::ProgressBar::new(0).with_style(
            indicatif::ProgressStyle::with_template(
                "reference {bar:40} {pos}/{len} rows {elapsed}",
            )
            .expect("the template is valid"),
        );
        // Small frames finish before a bar would help; indicatif hides it off a terminal.
        if camera.width as u64 * camera.height as u64 * (args.bounces as u64 + 1) < 2_000_000 {
            bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        reference::render_with_progress(&scene, &tracer, &camera, args.bounces, &bar)
    };
    let render_time = start.elapsed();
    output::write_frame(&out, &frame)?;
    println!(
        "wrote {} ({}x{}, scene '{}', method {method}, {} mirror pixels) in {:.2?}",
        out.display(),
        frame.width,
        frame.height,
        scene.name,
        frame.mirror_pixels(),
        render_time
    );
    Ok(())
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

#[derive(clap::Args)]
struct BenchArgs {
    /// Scenes: built-in names or .toml paths, comma-separated [default: every built-in scene].
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Methods: reference, envmap, fragment, compute, ssr, reflection-point, bvh (comma-separated);
    /// fragment runs its parameter grid (criteria x sampling x acceleration x steps) unless
    /// --quick; compute has one setting (the exact criterion on its hierarchy), ssr its defaults
    /// (64 iterations, no thickness test), reflection-point its defaults (cap 256 steps, search
    /// scale 1) as is and with the other objects subdivided twice (`reflection-point-sub2`), bvh
    /// (exact GPU ray tracing) its one setting.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "reference,envmap,fragment,compute,ssr,reflection-point,bvh"
    )]
    methods: Vec<String>,
    /// Tracing methods: only the default options (exact criterion, pyramid) instead of the grid.
    #[arg(long)]
    quick: bool,
    /// Frame width in pixels.
    #[arg(long, default_value_t = 160)]
    width: u32,
    /// Frame height in pixels.
    #[arg(long, default_value_t = 120)]
    height: u32,
    /// Timed frames per run.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Frames rendered and discarded before timing.
    #[arg(long, default_value_t = 1)]
    warmup: u32,
    /// Texels per cube face side (overrides the scenes').
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    cube_size: Option<u32>,
    /// Number of automatically placed CMOs (overrides the scenes').
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16))]
    cmos: Option<u32>,
    /// Skip the FLIP metric.
    #[arg(long)]
    no_flip: bool,
    /// Skip the error heat maps.
    #[arg(long)]
    no_heatmaps: bool,
    /// Skip timing each GPU method's default setting again at 16x12 (the fixed-cost "floor"
    /// columns of the cost-per-ray table).
    #[arg(long)]
    no_floor: bool,
    /// Reflections per path for the reference and the methods that trace several (compute,
    /// fragment with the exact criterion, bvh; the others are skipped when N != 1). Not used by
    /// --scaling.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=16))]
    bounces: u32,
    /// fragment, compute: skip the reflector check (to show what it changes and costs).
    #[arg(long)]
    no_reflector_check: bool,
    /// Cost curves instead of the grid: against cube size, screen size, CMO count and triangle
    /// count (fragment, exact criterion with the pyramid); then the reflection-point method's
    /// error against the reference as the other objects are subdivided (the tessellation curve).
    #[arg(long)]
    scaling: bool,
    /// Scaling: the largest cube face size (powers of two from 32). The default stops at 1024:
    /// at 2048 one CMO's colour buffer (384 MiB) exceeds lavapipe's maxStorageBufferRange.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(32..=4096))]
    max_cube: u32,
    /// Output folder.
    #[arg(short, long, default_value = "out/bench")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

fn bench(args: BenchArgs) -> Result<()> {
    use cubetrace::bench;
    let kinds = args
        .methods
        .iter()
        .map(|m| {
            Method::from_name(m).ok_or_else(|| {
                let known: Vec<&str> = Method::ALL.iter().map(|k| k.name()).collect();
                anyhow::anyhow!(
                    "--methods: unknown method '{m}' (known: {})",
                    known.join(", ")
                )
            })
        })
        .collect::<Result<Vec<_>>>()?;
    output::check_folder(&args.out).context("-o")?;
    let ctx = args.gpu.context()?;
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed} {msg}")
            .expect("the template is valid"),
    );
    let paths = if args.scaling {
        let cfg = bench::scaling::ScalingConfig {
            method: bench::MethodSpec::plain(Method::Fragment),
            axes: bench::scaling::Axis::ALL.to_vec(),
            max_cube: args.max_cube,
            width: args.width,
            height: args.height,
            frames: args.frames,
            warmup: args.warmup,
            out: args.out.clone(),
            tessellation_series: bench::scaling::TESSELLATION_SERIES
                .iter()
                .map(|&(scene, scale)| (scene.to_string(), scale))
                .collect(),
            tessellation_levels: bench::scaling::TESSELLATION_LEVELS,
        };
        let report = bench::scaling::run(&ctx, &cfg, &bar)?;
        bar.finish_and_clear();
        println!("{}", bench::scaling::table(&report));
        println!(
            "{}",
            bench::scaling::tessellation_table(&report.tessellation)
        );
        bench::scaling::write(&report, &args.out)?
    } else {
        let defaults = bench::BenchConfig::default();
        let cfg = bench::BenchConfig {
            scenes: if args.scenes.is_empty() {
                defaults.scenes
            } else {
                args.scenes.clone()
            },
            methods: bench::method_grid(&kinds, args.quick),
            width: args.width,
            height: args.height,
            frames: args.frames,
            warmup: args.warmup,
            cube_size: args.cube_size,
            cmos: args.cmos,
            flip: !args.no_flip,
            heatmaps: !args.no_heatmaps,
            floor: (!args.no_floor).then_some(bench::FLOOR_FRAME),
            bounces: args.bounces,
            reflector_check: !args.no_reflector_check,
            out: args.out.clone(),
        };
        let report = bench::run(&ctx, &cfg, &bar)?;
        bar.finish_and_clear();
        println!("{}", bench::report::header(&report));
        println!("{}", bench::report::summary_table(&report));
        println!("{}", bench::report::ratios_table(&report));
        bench::report::write(&report, &args.out)?
    };
    bench::check_validation(&ctx)?;
    for p in paths {
        println!("wrote {}", p.display());
    }
    println!("heat maps (if any) in {}", args.out.join("heat").display());
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(args) => render(args),
        Command::Bench(args) => bench(args),
        Command::Info(gpu) => {
            let validation = if gpu.validate {
                Validation::Required
            } else {
                Validation::default()
            };
            for d in GpuContext::list_devices(validation)? {
                println!("{d}");
            }
            Ok(())
        }
        Command::Scenes => {
            for (name, about) in scene::builtin::NAMES {
                println!("{name:<12} {about}");
            }
            Ok(())
        }
        Command::Scene {
            command: SceneCommand::Export { name, dir, force },
        } => {
            let s = scene::builtin::by_name(&name).ok_or_else(|| export_suggestion(&name))?;
            let toml = dir.join("scene.toml");
            if !force && std::fs::symlink_metadata(&toml).is_ok() {
                anyhow::bail!(
                    "{} already exists; pass --force to overwrite it (and the export's other files), or choose another folder",
                    toml.display()
                );
            }
            let path = scene::export::export(&s, &dir)
                .with_context(|| format!("exporting scene '{name}' to {}", dir.display()))?;
            println!("wrote {}", path.display());
            Ok(())
        }
    }
}

/// The error of `scene export NAME` for a name that is not a built-in scene: what to run instead.
fn export_suggestion(name: &str) -> anyhow::Error {
    let known: Vec<&str> = scene::builtin::NAMES.iter().map(|(n, _)| *n).collect();
    if name.ends_with(".toml") || std::path::Path::new(name).is_file() {
        anyhow::anyhow!(
            "scene export: '{name}' is a scene file, not a built-in scene; `scene export` writes a built-in scene out \
             ({}). A scene file renders as it is: `cubetrace render {name}`",
            known.join(", ")
        )
    } else {
        anyhow::anyhow!(
            "scene export: unknown scene '{name}'; the built-in scenes are {} (`cubetrace scenes` describes them). \
             For example: `cubetrace scene export {} my-scene/`, then `cubetrace render my-scene/scene.toml`",
            known.join(", "),
            known.first().copied().unwrap_or("default")
        )
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let level = match cli.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(level))
        .format_timestamp(None)
        .init();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

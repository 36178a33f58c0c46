#![forbid(unsafe_code)]
//! `cubetrace bench`: the harness of [`crate::bench`] from the command line, either the grid
//! (scenes x methods x parameters against the reference) or, with `--scaling`, the cost curves
//! (`--sequence`: frames per minute of an animation; `--glossy`: glossy reflectors' PSNR
//! against cost per roughness).
//! Every method name and the output folder are checked before the device is created; the
//! harness itself checks the scenes and the memory before anything renders.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::GpuArgs;
use crate::Method;
use crate::bench;
use crate::output;
use crate::vk::GpuContext;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Scenes: built-in names or .toml paths, comma-separated [default: every built-in still scene].
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Also every scene of a corpus folder: each `DIR/NAME/scene.toml`, in name order (the
    /// project's public real-scene corpus is `tests/scenes` in its source tree).
    #[arg(long, value_name = "DIR")]
    pub corpus: Option<PathBuf>,
    /// Methods: reference, envmap, fragment, compute, ssr, reflection-point, bvh (comma-separated);
    /// fragment runs its default, the bounded criterion (`fragment-bounded`), and its study
    /// grid (the centre criterion x acceleration, the approximate criteria x sampling x steps)
    /// unless --quick (then the centre criterion with the pyramid alone); compute the bounded
    /// criterion, its default (`compute`), and the centre one (`compute-centre`) on its
    /// hierarchy and, unless --quick, its three lane layouts beside the device's default
    /// (`compute-thesis`, `compute-one-lane`, `compute-wave`: the same records, the cost of
    /// each), ssr its defaults (64 iterations, no thickness test), reflection-point its defaults
    /// (cap 256 steps, search scale 1) as is and with the other objects subdivided twice
    /// (`reflection-point-sub2`), bvh (exact GPU ray tracing) its one setting.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "reference,envmap,fragment,compute,ssr,reflection-point,bvh"
    )]
    pub methods: Vec<String>,
    /// fragment: only its default (the bounded criterion) and the centre criterion with the
    /// pyramid instead of its grid; compute: the device's lane layout only.
    #[arg(long)]
    pub quick: bool,
    /// Every method of --methods in the one setting the cost model replays: the cube-map
    /// tracers with the centre criterion (the pyramid, the device's lane layout), the others
    /// their defaults; no grid, no subdivided reflection-point (the rows --model reads;
    /// benches/model-measure.sh uses it). Formerly --defaults-only.
    #[arg(long, alias = "defaults-only", conflicts_with_all = ["quick", "scaling", "sequence", "glossy"])]
    pub model_rows: bool,
    /// Frame width in pixels.
    #[arg(long, default_value_t = 160)]
    pub width: u32,
    /// Frame height in pixels.
    #[arg(long, default_value_t = 120)]
    pub height: u32,
    /// Timed frames per run.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub frames: u32,
    /// Frames rendered and discarded before timing.
    #[arg(long, default_value_t = 1)]
    pub warmup: u32,
    /// Every GPU method but bvh: texels per cube face side (overrides the scenes').
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub cube_size: Option<u32>,
    /// Every GPU method but bvh: number of CMOs along the reflectors' axis (overrides the
    /// scenes'); with `--placement auto` or `axis`, that placement's count.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub cmos: Option<u32>,
    /// The CMO placement axis, comma separated: `scene` (each scene's own `[cmo]`; a scene
    /// without centres is placed by the search), `axis` (along the reflectors' longest axis),
    /// `auto` (the placement search). With more than one, every scene runs once per placement,
    /// labelled `NAME [placement]`, and the report gains a placement table: CMOs, search and
    /// capture time, frame time against bvh's, fallback share.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "scene")]
    pub placement: Vec<bench::BenchPlacement>,
    /// Skip the FLIP metric.
    #[arg(long)]
    pub no_flip: bool,
    /// Skip the error heat maps.
    #[arg(long)]
    pub no_heatmaps: bool,
    /// Skip timing each GPU method's default setting again at 16x12 (the fixed-cost "floor"
    /// columns of the cost-per-ray table).
    #[arg(long)]
    pub no_floor: bool,
    /// Reflections per path for the reference and the methods that trace several (compute,
    /// fragment with the centre criterion, bvh; the others are skipped when N != 1). With N > 1
    /// the grid (not --model-rows) runs compute twice, its later reflections through its cube
    /// maps and through the BVH (`compute-bvh-bounces`, render's --bvh-bounces), and bench.md
    /// gains a "Bounce rounds" table: each round's rays, what traced them, the fallback's share.
    /// Not used by --scaling.
    #[arg(long, default_value_t = crate::vk::options::RenderOptions::default().bounces,
          value_parser = clap::value_parser!(u32).range(0..=16))]
    pub bounces: u32,
    /// fragment, compute: skip the reflector check (to show what it changes and costs).
    #[arg(long)]
    pub no_reflector_check: bool,
    /// Scenes with a glossy reflector: samples per pixel of the converged reference (the CPU
    /// reference's Monte Carlo integral of the lobe) that their frames are measured against,
    /// as `render --compare` does. A reflected ray's hit is one sample of the lobe there, so
    /// their rows give the colour's figures (PSNR, mask mismatch, unresolved) and `-` for every
    /// hit figure (wrong surface, angles, same triangle), and the summary pools those over the
    /// other scenes.
    #[arg(long, default_value_t = bench::COMPARE_SPP,
          value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub compare_spp: u32,
    /// Cost curves instead of the grid: against cube size, screen size, CMO count and triangle
    /// count (fragment, centre criterion with the pyramid); then the reflection-point method's
    /// error against the reference as the other objects are subdivided (the tessellation curve).
    #[arg(long)]
    pub scaling: bool,
    /// Frames per minute of an animated scene instead of the grid: the first of --scenes
    /// [default: sphere-room-orbit, a 24-frame camera orbit], its `[animation]` frames, each GPU
    /// method of --methods with the capture reused between frames and with it run for every
    /// frame (bench::sequence). The row is at --width 320 --height 240.
    #[arg(long, conflicts_with = "scaling")]
    pub sequence: bool,
    /// Speed against error on glossy reflectors instead of the grid (bench::glossy): for every
    /// scene of --scenes and every specular power given [default: 16,64,256, cones of about 23,
    /// 12 and 6 degrees; each below 1024, the mirror], the reflectors made glossy, the converged
    /// reference (--glossy-reference-spp), each GPU method of --methods once, and bvh's Monte
    /// Carlo ladder (--glossy-spp), with PSNR over mirror pixels against the reference, the cost
    /// per frame and, per method, the cheapest bvh frame of at least its cost. Writes
    /// glossy.json, glossy.md and glossy.svg (one panel per power).
    #[arg(
        long,
        value_name = "POWERS",
        value_delimiter = ',',
        num_args = 0..=1,
        default_missing_value = "16,64,256",
        allow_negative_numbers = true,
        conflicts_with_all = ["scaling", "sequence", "model"]
    )]
    pub glossy: Option<Vec<String>>,
    /// --glossy: samples per pixel of the converged reference (the CPU reference's Monte Carlo
    /// integral of the lobe; its cost grows with it, about spp times a 1-spp reference frame).
    #[arg(long, default_value_t = bench::glossy::DEFAULT_REFERENCE_SPP, requires = "glossy",
          value_parser = clap::value_parser!(u32).range(2..=1024))]
    pub glossy_reference_spp: u32,
    /// --glossy: the samples at the film's jittered offsets, as `render --spp` and `reference
    /// --spp` take them, instead of all at the pixel centre (the default: the truth is then the
    /// lobe's integral at the pixel centre, which a cone method approximates; with the film it
    /// also integrates the pixel, which no one-sample method renders).
    #[arg(long, requires = "glossy")]
    pub glossy_film: bool,
    /// --glossy: bvh's Monte Carlo ladder, samples per pixel, increasing.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1,2,4,8,16,32,64",
        requires = "glossy"
    )]
    pub glossy_spp: Vec<u32>,
    /// Adds the SIMT cost model (a MODEL, not a measurement) to the grid's JSON, Markdown and
    /// plots (bench::model): each method's default setting replayed in lockstep warps from its
    /// CPU twin's work, weighted by SPIR-V instruction counts. (1) lavapipe mode at the device's
    /// subgroup size against the measured ns per ray of the tracing pass, two coefficients per
    /// method (ns per vector instruction, ns per lane operation) fitted on scene `default` only
    /// (keep it in --scenes), the error of every other row; (2) predictions
    /// at warp widths 32 and 64 (compute/fragment, compute/bvh, fragment/bvh, SIMD efficiency,
    /// sectors per ray); (3) where cube-map tracing would overtake the BVH on the triangle axis
    /// of --scaling. Writes model.svg beside the grid's files.
    #[arg(long, conflicts_with_all = ["scaling", "sequence"])]
    pub model: bool,
    /// With --model: render nothing; model the runs of these earlier bench.json files instead
    /// (e.g. one per LP_NATIVE_VECTOR_WIDTH and --cube-size; benches/model-measure.sh), fitting
    /// on scene `default` at every cube and subgroup size given, and write model.json, model.md
    /// and model.svg into -o (GPU predictions at cube 256). A row in several files is one row
    /// measured in several processes: the median of their times, with their spread reported.
    #[arg(long, value_delimiter = ',', requires = "model")]
    pub model_from: Vec<PathBuf>,
    /// Scaling: the largest cube face size (powers of two from 32). The default stops at 1024:
    /// at 2048 one CMO's colour buffer (384 MiB) exceeds lavapipe's maxStorageBufferRange.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(32..=4096))]
    pub max_cube: u32,
    /// Output folder.
    #[arg(short, long, default_value = "out/bench")]
    pub out: PathBuf,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// Refuses the method-specific options no chosen method reads: the rules of `render`
/// ([`crate::method::METHOD_OPTIONS`]), held against every method of `--methods` (an option
/// passes when one of them reads it under some setting of the grid); with `--scaling`, which
/// runs its own fragment curves, the grid's options.
pub fn check_options(args: &BenchArgs, methods: &[Method]) -> Result<()> {
    let given = [
        ("--quick", args.quick),
        ("--no-reflector-check", args.no_reflector_check),
        ("--cmos", args.cmos.is_some()),
        ("--cube-size", args.cube_size.is_some()),
        (
            "--placement",
            args.placement != [bench::BenchPlacement::Scene],
        ),
    ];
    for (flag, on) in given {
        if !on {
            continue;
        }
        if flag == "--placement" && (args.glossy.is_some() || args.model) {
            anyhow::bail!(
                "--placement does not apply to --glossy or --model (they render each scene's own \
                 CMO placement): leave it out"
            );
        }
        if args.glossy.is_some() && flag == "--quick" {
            anyhow::bail!(
                "--quick does not apply to --glossy (it renders each method's default setting \
                 once): leave it out"
            );
        }
        if args.sequence {
            anyhow::bail!(
                "{flag} does not apply to --sequence (it renders each method's default setting \
                 over the scene's frames): leave it out"
            );
        }
        if args.scaling {
            anyhow::bail!(
                "{flag} does not apply to --scaling (its curves set the cube size, CMO count and \
                 tracer options themselves): leave it out"
            );
        }
        let option = crate::method::method_option(flag).expect("bench's options are in the table");
        let readers = option.methods();
        if !methods.iter().any(|m| readers.contains(m)) {
            let chosen: Vec<&str> = methods.iter().map(|m| m.name()).collect();
            let first = methods.first().copied().unwrap_or(Method::TRUTH);
            anyhow::bail!(
                "--methods {}: none of them reads {flag} ({})",
                chosen.join(","),
                option.refusal(first)
            );
        }
    }
    Ok(())
}

/// `cubetrace bench`.
pub fn bench(mut args: BenchArgs) -> Result<()> {
    if let Some(dir) = &args.corpus {
        args.scenes.extend(corpus_scenes(dir)?);
    }
    let methods = parse_methods(&args.methods)?;
    check_options(&args, &methods)?;
    let glossy = glossy_config(&args, &methods)?;
    output::check_folder(&args.out).context("-o")?;
    if args.model {
        check_model_options(&args)?;
    }
    if !args.model_from.is_empty() {
        return run_model_from(&args);
    }
    let ctx = args.gpu.context()?;
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed} {msg}")
            .expect("the template is valid"),
    );
    let paths = if args.scaling {
        run_scaling(&args, &ctx, &bar)?
    } else if args.sequence {
        run_sequence(&args, &methods, &ctx, &bar)?
    } else if let Some(cfg) = glossy {
        run_glossy(&args, &cfg, &ctx, &bar)?
    } else {
        run_grid(&args, &methods, &ctx, &bar)?
    };
    crate::render::check_validation(&ctx)?;
    for p in paths {
        println!("wrote {}", p.display());
    }
    println!("heat maps (if any) in {}", args.out.join("heat").display());
    Ok(())
}

/// `--corpus DIR`: the `scene.toml` of every folder of `DIR`, in name order (folders without
/// one are skipped); none at all is an error naming `DIR`.
fn corpus_scenes(dir: &Path) -> Result<Vec<String>> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("--corpus {}", dir.display()))?;
    let mut folders: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    let scenes: Vec<String> = folders
        .iter()
        .map(|f| f.join("scene.toml"))
        .filter(|t| t.is_file())
        .map(|t| t.display().to_string())
        .collect();
    if scenes.is_empty() {
        anyhow::bail!(
            "--corpus {}: no folder there holds a scene.toml",
            dir.display()
        );
    }
    Ok(scenes)
}

/// `--methods`: the CLI's method names, an unknown one refused with the known ones.
pub fn parse_methods(names: &[String]) -> Result<Vec<Method>> {
    names
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
        .collect()
}

/// `--scaling`: the cost curves of `fragment`, printed and written; returns the files written.
fn run_scaling(
    args: &BenchArgs,
    ctx: &GpuContext,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<PathBuf>> {
    let cfg = bench::scaling::ScalingConfig {
        method: bench::MethodSpec::centre(Method::SCALING),
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
    let report = bench::scaling::run(ctx, &cfg, bar)?;
    bar.finish_and_clear();
    println!("{}", bench::scaling::table(&report));
    println!(
        "{}",
        bench::scaling::tessellation_table(&report.tessellation)
    );
    bench::scaling::write(&report, &args.out)
}

/// `--sequence`: the frames-per-minute rows of an animated scene, printed and written; returns
/// the files written.
fn run_sequence(
    args: &BenchArgs,
    methods: &[Method],
    ctx: &GpuContext,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<PathBuf>> {
    let name = args
        .scenes
        .first()
        .map_or("sphere-room-orbit", String::as_str);
    let scene = crate::scene::load(name)?;
    let frames: Vec<i64> = match scene.default_frames() {
        Some([first, last]) => (first..=last).collect(),
        None => anyhow::bail!(
            "--sequence: scene '{name}' has no [animation] frames; give an animated scene \
             (e.g. sphere-room-orbit)"
        ),
    };
    let gpu: Vec<Method> = methods.iter().copied().filter(|m| m.is_gpu()).collect();
    anyhow::ensure!(
        !gpu.is_empty(),
        "--sequence times GPU methods: --methods names none"
    );
    bar.set_length((gpu.len() * 2 * frames.len()) as u64);
    let report = bench::sequence::run(
        ctx,
        &scene,
        &gpu,
        (args.width, args.height),
        &frames,
        &|| bar.inc(1),
    )?;
    bar.finish_and_clear();
    println!("{}", bench::sequence::table(&report));
    bench::sequence::write(&report, &args.out)
}

/// `--glossy POWERS`: the powers, each a number (the flag named in every error).
pub fn parse_powers(values: &[String]) -> Result<Vec<f32>> {
    let powers = (values.iter())
        .filter(|v| !v.trim().is_empty())
        .map(|v| {
            v.trim().parse::<f32>().map_err(|_| {
                anyhow::anyhow!("--glossy: '{v}' is not a number (a specular power, e.g. 64)")
            })
        })
        .collect::<Result<Vec<f32>>>()?;
    bench::glossy::check_powers(&powers)?;
    Ok(powers)
}

/// The `--glossy` run's configuration (`None` without `--glossy`), every value checked before
/// the device is created.
pub fn glossy_config(
    args: &BenchArgs,
    methods: &[Method],
) -> Result<Option<bench::glossy::GlossyConfig>> {
    let Some(values) = &args.glossy else {
        return Ok(None);
    };
    let powers = parse_powers(values)?;
    bench::glossy::check_ladder(&args.glossy_spp)?;
    if args.bounces != 1 {
        anyhow::bail!(
            "--glossy compares the first reflection (bvh samples the lobe there only): leave out \
             --bounces"
        );
    }
    let defaults = bench::BenchConfig::default();
    Ok(Some(bench::glossy::GlossyConfig {
        scenes: if args.scenes.is_empty() {
            defaults.scenes
        } else {
            args.scenes.clone()
        },
        powers,
        // bvh runs the ladder and the reference is the truth: neither is a row of its own.
        methods: (methods.iter().copied())
            .filter(|m| m.is_gpu() && *m != Method::EXACT_GPU)
            .collect(),
        width: args.width,
        height: args.height,
        frames: args.frames,
        warmup: args.warmup,
        cube_size: args.cube_size,
        cmos: args.cmos,
        reflector_check: !args.no_reflector_check,
        reference_spp: args.glossy_reference_spp,
        spp: args.glossy_spp.clone(),
        film: args.glossy_film,
    }))
}

/// `--glossy`: the rows of every scene x power, printed and written; returns the files written.
fn run_glossy(
    args: &BenchArgs,
    cfg: &bench::glossy::GlossyConfig,
    ctx: &GpuContext,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<PathBuf>> {
    bar.set_length(bench::glossy::planned_steps(cfg));
    let started = std::cell::Cell::new(false);
    let tick = |what: &str| {
        if started.replace(true) {
            bar.inc(1);
        }
        bar.set_message(what.to_string());
    };
    let report = bench::glossy::run(ctx, cfg, &tick)?;
    bar.finish_and_clear();
    println!("{}", bench::glossy::markdown(&report));
    bench::glossy::write(&report, &args.out)
}

/// The harness's configuration of a grid run from the arguments and the parsed methods.
pub fn grid_config(args: &BenchArgs, methods: &[Method]) -> bench::BenchConfig {
    let defaults = bench::BenchConfig::default();
    bench::BenchConfig {
        scenes: if args.scenes.is_empty() {
            defaults.scenes
        } else {
            args.scenes.clone()
        },
        methods: match (args.model_rows, args.bounces > 1) {
            (true, _) => methods
                .iter()
                .map(|m| bench::MethodSpec::modelled(*m))
                .collect(),
            (false, false) => bench::method_grid(methods, args.quick),
            // compute's later reflections through its cube maps and through the BVH, side by side.
            (false, true) => bench::with_bvh_bounces(bench::method_grid(methods, args.quick)),
        },
        width: args.width,
        height: args.height,
        frames: args.frames,
        warmup: args.warmup,
        cube_size: args.cube_size,
        cmos: args.cmos,
        placements: args.placement.clone(),
        flip: !args.no_flip,
        heatmaps: !args.no_heatmaps,
        floor: (!args.no_floor).then_some(bench::FLOOR_FRAME),
        bounces: args.bounces,
        reflector_check: !args.no_reflector_check,
        compare_spp: args.compare_spp,
        out: args.out.clone(),
    }
}

/// The grid: runs it, prints the tables and writes the report; returns the files written.
fn run_grid(
    args: &BenchArgs,
    methods: &[Method],
    ctx: &GpuContext,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<PathBuf>> {
    let cfg = grid_config(args, methods);
    let mut report = bench::run(ctx, &cfg, bar)?;
    if args.model {
        let training = crate::model::validate::Training::standard();
        let rows = bench::model::measured_of(&report);
        let progress = |s: &str| bar.set_message(format!("model: {s}"));
        report.model = Some(bench::model::run(&rows, &training, None, &progress)?);
    }
    bar.finish_and_clear();
    println!("{}", bench::report::header(&report));
    println!("{}", bench::report::summary_table(&report));
    println!("{}", bench::report::ratios_table(&report));
    let placement = bench::report::placement_table(&report);
    if !placement.is_empty() {
        println!("{placement}");
    }
    bench::report::write(&report, &args.out)
}

/// `--model`: refuses the options the model does not replay.
fn check_model_options(args: &BenchArgs) -> Result<()> {
    if args.bounces != 1 {
        anyhow::bail!("--model replays one reflection per path: leave out --bounces");
    }
    if args.cmos.is_some() {
        anyhow::bail!("--model replays each scene's own CMO placement: leave out --cmos");
    }
    Ok(())
}

/// `--model --model-from`: the model over earlier bench.json files, printed and written.
fn run_model_from(args: &BenchArgs) -> Result<()> {
    let rows = bench::model::measured_from_files(&args.model_from)?;
    let training = crate::model::validate::Training::standard();
    let progress = |s: &str| eprintln!("model: {s}");
    let report = bench::model::run(&rows, &training, Some(256), &progress)?;
    println!("{}", bench::model::markdown(&report));
    for p in bench::model::write(&report, &args.out)? {
        println!("wrote {}", p.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: BenchArgs,
    }

    fn check(line: &[&str]) -> Result<()> {
        let args = Cli::try_parse_from(std::iter::once("bench").chain(line.iter().copied()))
            .unwrap()
            .args;
        let methods = parse_methods(&args.methods)?;
        check_options(&args, &methods)
    }

    /// `--methods` runs every method by default: its default is the registry's list, in order
    /// (a method added to [`Method::ALL`] and not here fails this).
    #[test]
    fn methods_default_is_every_method() {
        let args = Cli::try_parse_from(["bench"]).unwrap().args;
        let all: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
        assert_eq!(args.methods, all);
        // Negative: a list given replaces the default.
        let args = Cli::try_parse_from(["bench", "--methods", "bvh"])
            .unwrap()
            .args;
        assert_eq!(args.methods, ["bvh"]);
    }

    /// `--placement` is the grid's: refused where no chosen method captures CMOs and in the
    /// modes that render each scene's own placement; the default value is never refused.
    #[test]
    fn placement_is_refused_where_nothing_reads_it() {
        check(&["--methods", "compute,bvh", "--placement", "scene,axis,auto"]).unwrap();
        check(&["--methods", "bvh"]).unwrap();
        for (line, says) in [
            (
                &["--methods", "bvh", "--placement", "auto"][..],
                "none of them reads",
            ),
            (&["--sequence", "--placement", "auto"][..], "--sequence"),
            (
                &["--glossy", "--placement", "axis"][..],
                "--glossy or --model",
            ),
            (
                &["--model", "--placement", "auto"][..],
                "--glossy or --model",
            ),
        ] {
            let e = check(line).unwrap_err().to_string();
            assert!(
                e.contains("--placement") && e.contains(says),
                "{line:?}: {e}"
            );
        }
    }
}

#![forbid(unsafe_code)]
//! The `cubetrace` command line.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};

use cubetrace::{output, reference, scene};

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
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Method {
    /// Exact CPU ray tracing against the scene's triangles: the ground truth.
    Reference,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Built-in scene name or path to a .toml scene file.
    #[arg(default_value = "default")]
    scene: String,
    /// How reflections are computed.
    #[arg(long, value_enum, default_value_t = Method::Reference)]
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
    /// Maximum number of mirror reflections per path. After the last one, a mirror shows its
    /// own material colour.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=16))]
    bounces: u32,
    /// Output file, .png or .exr [default: out/SCENE-METHOD.png].
    #[arg(short, long)]
    output: Option<PathBuf>,
}

fn render(args: RenderArgs) -> Result<()> {
    let start = Instant::now();
    let scene = scene::load(&args.scene)?;
    let mut camera = scene.camera(args.camera.as_deref())?.clone();
    camera.width = args.width.unwrap_or(camera.width);
    camera.height = args.height.unwrap_or(camera.height);
    scene::check_resolution(camera.width, camera.height)
        .map_err(|e| anyhow::anyhow!("--width/--height: {e}"))?;
    let method = args
        .method
        .to_possible_value()
        .map(|v| v.get_name().to_string());
    let method = method.unwrap_or_default();
    let out = args
        .output
        .unwrap_or_else(|| PathBuf::from("out").join(format!("{}-{method}.png", scene.name)));
    // Check the extension before spending time on the render.
    output::Format::from_path(&out)?;

    let frame = match args.method {
        Method::Reference => {
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
        }
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

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(args) => render(args),
        Command::Scenes => {
            for (name, about) in scene::builtin::NAMES {
                println!("{name:<12} {about}");
            }
            Ok(())
        }
        Command::Scene {
            command: SceneCommand::Export { name, dir },
        } => {
            let s =
                scene::builtin::by_name(&name).ok_or_else(|| scene::SceneError::UnknownScene {
                    name: name.clone(),
                    known: scene::builtin::NAMES
                        .iter()
                        .map(|(n, _)| n.to_string())
                        .collect(),
                })?;
            let path = scene::export::export(&s, &dir)
                .with_context(|| format!("exporting scene '{name}' to {}", dir.display()))?;
            println!("wrote {}", path.display());
            Ok(())
        }
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

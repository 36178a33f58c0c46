#![forbid(unsafe_code)]
//! The `cubetrace` command line: parses the arguments (clap) and calls the command's library
//! function in [`cubetrace::app`]; an error is printed once, as `error: ...`, with exit status 1
//! (clap's usage errors exit with 2).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

use cubetrace::app::{self, GpuArgs, bench::BenchArgs, render::RenderArgs};

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
    ///
    /// The summary line counts the mirror pixels, those the fallback finished (with their share)
    /// and those left unresolved; when the method leaves more than 10 % of the mirror pixels to
    /// the fallback, a warning names the likely cause (CMO placement, inward normals, the
    /// method's known limits). Options the chosen method does not read are refused.
    Render(RenderArgs),
    /// List the built-in scenes, one line each.
    Scenes,
    /// List the Vulkan devices: name, driver, subgroup size and operations, limits, timestamps.
    Info(GpuArgs),
    /// Speed against error: scenes x methods x parameters on the GPU, against the CPU reference
    /// (JSON, Markdown, SVG plot, heat maps); `--scaling` for the cost curves.
    Bench(BenchArgs),
    /// Write a job that renders a sequence in chunks on a cluster's scheduler: a Slurm job
    /// array script (`farm slurm`) or a Kubernetes Indexed Job manifest (`farm k8s`), for a
    /// render command line given after `--`. Each task renders its chunk with --skip-existing;
    /// the job's comments say how to rerun failed tasks.
    Farm {
        #[command(subcommand)]
        command: app::farm::FarmCommand,
    },
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
        /// Replace an earlier export in DIR: the files it wrote (its `scene.toml` and the OBJ,
        /// MTL and PNG files named from there, recognised by the comment cubetrace writes) are
        /// removed or overwritten; other files in DIR are never touched.
        #[arg(long)]
        force: bool,
    },
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(args) => app::sequence::render(args),
        Command::Bench(args) => app::bench::bench(args),
        Command::Info(gpu) => app::info(gpu),
        Command::Farm { command } => app::farm::farm(command),
        Command::Scenes => {
            app::scenes();
            Ok(())
        }
        Command::Scene {
            command: SceneCommand::Export { name, dir, force },
        } => app::export::export(&name, &dir, force),
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

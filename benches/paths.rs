//! `cargo bench --bench paths`: the speed-against-error harness (`cubetrace bench`) on a small
//! grid: every built-in scene (an argument that is not a flag filters scenes by name), the CPU
//! reference, the environment map and the fragment tracer with its default options (exact
//! criterion, min/max pyramid), 160x120, 5 timed frames after 1 warm-up. For the full parameter
//! grid run `cubetrace bench`.
//!
//! Writes `out/bench/` (JSON, Markdown, plot, heat maps) like the command and prints the summary
//! table. Without `--bench` (`cargo test --all-targets` runs this binary as a test) one timed
//! frame per run, no heat maps and no FLIP are enough to show that the harness works.
//!
//! Needs a Vulkan device (CI: lavapipe); exits non-zero without one.
#![forbid(unsafe_code)]

use std::process::ExitCode;

use cubetrace::bench::{self, BenchConfig, Method};
use cubetrace::vk::{ContextOptions, GpuContext, Validation};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let filter = args.iter().find(|a| !a.starts_with("--"));
    let full = args.iter().any(|a| a == "--bench");
    let defaults = BenchConfig::default();
    let cfg = BenchConfig {
        scenes: defaults
            .scenes
            .into_iter()
            .filter(|s| filter.is_none_or(|f| s.contains(f.as_str())))
            .collect(),
        methods: bench::method_grid(&Method::ALL, true),
        frames: if full { 5 } else { 1 },
        flip: full,
        heatmaps: full,
        ..BenchConfig::default()
    };
    match run(&cfg) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cfg: &BenchConfig) -> anyhow::Result<()> {
    // Validation stays off unless CUBETRACE_VALIDATION=1: the layer distorts timings.
    let ctx = GpuContext::new(ContextOptions {
        validation: Validation::default(),
        device_index: None,
    })?;
    let bar = indicatif::ProgressBar::hidden();
    let report = bench::run(&ctx, cfg, &bar)?;
    println!("{}", bench::report::header(&report));
    println!("{}", bench::report::summary_table(&report));
    println!("{}", bench::report::ratios_table(&report));
    for p in bench::report::write(&report, &cfg.out)? {
        println!("wrote {}", p.display());
    }
    bench::check_validation(&ctx)
}

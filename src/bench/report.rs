#![forbid(unsafe_code)]
//! The harness's outputs: `bench.json` (everything, machine-readable; infinite PSNR is `null`),
//! `bench.md` (summary per method, one row per run, GPU time per pass), `speed-error.svg` (the
//! scatter plot of the summary) and the heat maps written during the run. Every file is written
//! atomically ([`crate::output::write_atomic`]).
//!
//! The per-method summary pools a method's runs over the scenes: costs are summed and divided by
//! the summed mirror pixels; fractions, counters, mean angles and FLIP are averages weighted by
//! mirror pixels; p95 is the worst scene's; PSNR is the plain mean over scenes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Result;

use super::plot::{self, Point};
use super::{BenchReport, MethodKind, RunResult};
use crate::output::write_atomic;

/// One method pooled over the scenes of a report.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub method: String,
    pub kind: MethodKind,
    pub scenes: usize,
    pub mirror_pixels: usize,
    pub trace_ns_per_mirror_px: f64,
    pub cells: f64,
    pub texels: f64,
    pub unresolved: f64,
    pub wrong_surface: f64,
    pub angular_mean_deg: f64,
    pub angular_p95_deg: f64,
    pub psnr_db: f64,
    pub flip_mean: Option<f64>,
}

/// Pools runs per method, in first-appearance order.
pub fn summarise(runs: &[RunResult]) -> Vec<Summary> {
    let mut methods: Vec<&str> = Vec::new();
    for r in runs {
        if !methods.contains(&r.method.as_str()) {
            methods.push(&r.method);
        }
    }
    methods
        .into_iter()
        .map(|m| {
            let rs: Vec<&RunResult> = runs.iter().filter(|r| r.method == m).collect();
            let px: usize = rs.iter().map(|r| r.mirror_pixels).sum();
            let w = px.max(1) as f64;
            let weighted = |f: &dyn Fn(&RunResult) -> f64| {
                rs.iter()
                    .map(|r| f(r) * r.mirror_pixels as f64)
                    .sum::<f64>()
                    / w
            };
            let flips: Vec<f64> = rs.iter().filter_map(|r| r.flip_mean).collect();
            Summary {
                method: m.to_string(),
                kind: rs[0].kind,
                scenes: rs.len(),
                mirror_pixels: px,
                trace_ns_per_mirror_px: rs.iter().map(|r| r.trace_ns.median).sum::<f64>() / w,
                cells: weighted(&|r| r.counters.cells),
                texels: weighted(&|r| r.counters.texels),
                unresolved: weighted(&|r| r.error.unresolved),
                wrong_surface: weighted(&|r| r.error.wrong_surface),
                angular_mean_deg: weighted(&|r| r.error.angular_mean_deg),
                angular_p95_deg: rs
                    .iter()
                    .map(|r| r.error.angular_p95_deg)
                    .fold(0.0, f64::max),
                psnr_db: rs.iter().map(|r| r.error.psnr_db).sum::<f64>() / rs.len() as f64,
                flip_mean: (flips.len() == rs.len())
                    .then(|| weighted(&|r| r.flip_mean.unwrap_or(0.0))),
            }
        })
        .collect()
}

fn pct(x: f64) -> String {
    format!("{:.2}", 100.0 * x)
}

fn num(x: f64, digits: usize) -> String {
    if x.is_infinite() {
        "inf".into()
    } else {
        format!("{x:.digits$}")
    }
}

/// The header lines: device, commit, frame size, frames.
pub fn header(report: &BenchReport) -> String {
    let r0 = report.runs.first();
    format!(
        "Device: {}; commit {}; cubetrace {}; {} CPU threads (reference).\n\
         Frames: {}x{}, {} timed after {} warm-up; cube size {}.\n",
        report.device.describe(),
        report.git_commit.as_deref().unwrap_or("unknown"),
        report.cubetrace_version,
        report.cpu_threads,
        r0.map_or(0, |r| r.width),
        r0.map_or(0, |r| r.height),
        r0.map_or(0, |r| r.frames),
        report.warmup,
        r0.map_or("?".into(), |r| r.cube_size.to_string()),
    )
}

/// The per-method summary table (what `cubetrace bench` prints).
pub fn summary_table(report: &BenchReport) -> String {
    let mut s = String::new();
    s.push_str(
        "| method | scenes | mirror px | ns/mirror px | cells/ray | texels/ray | unresolved % | wrong surface % | angle mean deg | angle p95 deg | PSNR dB | FLIP |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for m in summarise(&report.runs) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            m.method,
            m.scenes,
            m.mirror_pixels,
            num(m.trace_ns_per_mirror_px, 0),
            num(m.cells, 1),
            num(m.texels, 1),
            pct(m.unresolved),
            pct(m.wrong_surface),
            num(m.angular_mean_deg, 3),
            num(m.angular_p95_deg, 3),
            num(m.psnr_db, 2),
            m.flip_mean.map_or("-".into(), |f| num(f, 4)),
        );
    }
    s
}

/// One row per run.
pub fn runs_table(report: &BenchReport) -> String {
    let mut s = String::new();
    s.push_str(
        "| scene | method | mirror px | trace ms (median [min, max]) | ns/mirror px | frame GPU ms | cells/ray | texels/ray | traces/ray | CMO MiB | unresolved % | wrong % | angle mean | angle p95 | PSNR dB | FLIP |\n\
         |---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in &report.runs {
        let t = &r.trace_ns;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.3} [{:.3}, {:.3}] | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.scene,
            r.method,
            r.mirror_pixels,
            t.median * 1e-6,
            t.min * 1e-6,
            t.max * 1e-6,
            num(r.trace_ns_per_mirror_px, 0),
            if r.kind == MethodKind::Reference {
                "-".into()
            } else {
                num(r.total_ns.median * 1e-6, 2)
            },
            num(r.counters.cells, 1),
            num(r.counters.texels, 1),
            num(r.counters.traces, 2),
            num(r.cmo_bytes as f64 / (1024.0 * 1024.0), 2),
            pct(r.error.unresolved),
            pct(r.error.wrong_surface),
            num(r.error.angular_mean_deg, 3),
            num(r.error.angular_p95_deg, 3),
            num(r.error.psnr_db, 2),
            r.flip_mean.map_or("-".into(), |f| num(f, 4)),
        );
    }
    s
}

fn opt(x: Option<f64>, digits: usize) -> String {
    x.map_or("-".into(), |x| num(x, digits))
}

/// Per scene: ns per ray of each method's default setting and the ratios between them; the
/// floor columns are the tracing pass at the small frame over the full frame.
pub fn ratios_table(report: &BenchReport) -> String {
    let floor = report
        .runs
        .iter()
        .find_map(|r| r.floor)
        .map_or("small frame".to_string(), |f| {
            format!("{}x{}", f.width, f.height)
        });
    let mut s = format!(
        "| scene | reference ns/ray | envmap ns/ray | fragment ns/ray | compute ns/ray | fragment / reference | compute / reference | compute / fragment | fragment floor ({floor} / full) | compute floor ({floor} / full) |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    for r in &report.ratios {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.scene,
            opt(r.reference_ns_per_ray, 0),
            opt(r.envmap_ns_per_ray, 0),
            opt(r.fragment_ns_per_ray, 0),
            opt(r.compute_ns_per_ray, 0),
            opt(r.fragment_over_reference, 3),
            opt(r.compute_over_reference, 3),
            opt(r.compute_over_fragment, 3),
            opt(r.fragment_floor, 3),
            opt(r.compute_floor, 3),
        );
    }
    s
}

/// GPU time per pass: one row per GPU run, `median [min, max]` ms.
pub fn passes_table(report: &BenchReport) -> String {
    let mut s = String::from(
        "| scene | method | pass | median ms | min ms | max ms |\n|---|---|---|---:|---:|---:|\n",
    );
    for r in &report.runs {
        for p in &r.passes {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.3} | {:.3} | {:.3} |",
                r.scene,
                r.method,
                p.pass,
                p.ns.median * 1e-6,
                p.ns.min * 1e-6,
                p.ns.max * 1e-6
            );
        }
    }
    s
}

/// Error floor of the scatter plot, percent.
pub const PLOT_FLOOR_PCT: f64 = 0.01;

/// The scatter plot of the summary (GPU methods; the reference is the yardstick, not a point).
pub fn speed_error_svg(report: &BenchReport) -> Result<String> {
    let points: Vec<Point> = summarise(&report.runs)
        .into_iter()
        .filter(|m| m.kind != MethodKind::Reference)
        .map(|m| Point {
            label: m.method,
            cost: m.trace_ns_per_mirror_px,
            error: 100.0 * (m.unresolved + m.wrong_surface),
        })
        .collect();
    plot::scatter(
        &format!("speed against error on {}", report.device.name),
        "tracing pass, ns per mirror pixel (median, pooled over scenes)",
        &format!("unresolved + wrong surface, % of mirror pixels (floor {PLOT_FLOOR_PCT})"),
        &points,
        PLOT_FLOOR_PCT,
    )
}

/// Writes `bench.json`, `bench.md` and `speed-error.svg` into `dir`; returns the paths.
pub fn write(report: &BenchReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let json = dir.join("bench.json");
    write_atomic(&json, serde_json::to_string_pretty(report)?.as_bytes())?;
    let md = dir.join("bench.md");
    let doc = format!(
        "# cubetrace bench\n\n{}\n## Summary per method\n\n{}\nCost: the tracing pass alone (reference: CPU wall time of its reflected-ray phase). \
         Error: against the exact CPU reference, over mirror pixels.\n\n## Cost per ray\n\n{}\nns/ray: the tracing pass's median time over the rays it traced (GPU: the method's mirror pixels; \
         reference: the CPU wall time of its reflected-ray phase over its first reflected rays, shading at the hit included). \
         Default settings: `fragment` is fragment-exact-mip.\n\n## Runs\n\n{}\n## GPU time per pass\n\n{}\n\
         Heat maps (`heat/SCENE-METHOD.png`): grey = not a mirror pixel; black to red = angular error of the hit point, \
         0.01 to 10 degrees, logarithmic; white = wrong surface; magenta = unresolved; cyan = mirror pixel missed by the method's rasterisation.\n",
        header(report),
        summary_table(report),
        ratios_table(report),
        runs_table(report),
        passes_table(report)
    );
    write_atomic(&md, doc.as_bytes())?;
    let svg = dir.join("speed-error.svg");
    write_atomic(&svg, speed_error_svg(report)?.as_bytes())?;
    Ok(vec![json, md, svg])
}

#![forbid(unsafe_code)]
//! The harness's outputs: `bench.json` (everything, machine-readable; infinite PSNR is `null`),
//! `bench.md` (summary per method, one row per run, GPU time per pass), `speed-error.svg` (the
//! scatter plot of the summary) and the heat maps written during the run. Every file is written
//! atomically ([`crate::output::write_atomic`]).
//!
//! The per-method summary pools a method's runs over the scenes: costs are summed and divided by
//! the summed mirror pixels; fractions, counters, mean angles and FLIP are averages weighted by
//! mirror pixels; p95 is the worst scene's; PSNR is the plain mean over scenes. A figure that a
//! run cannot give (NaN: no mirror pixel, no pair of hits) is left out of its pool and printed
//! as `-`. Mask mismatch (mirror pixels of one frame only, [`crate::metrics`]) is a column of
//! its own and part of the plot's error.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Result;

use super::plot::{self, Point};
use super::{BenchReport, Method, RunResult, SceneRatios};
use crate::output::write_atomic;

/// One method pooled over the scenes of a report.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub method: String,
    pub kind: Method,
    pub scenes: usize,
    pub mirror_pixels: usize,
    pub trace_ns_per_mirror_px: f64,
    /// Share of mirror pixels the `trace` fallback finished, and its cost per mirror pixel.
    pub fallback_share: f64,
    pub fallback_ns_per_mirror_px: f64,
    /// All passes per mirror pixel (the frame's GPU time; the reference: its whole frame).
    pub frame_ns_per_mirror_px: f64,
    pub cells: f64,
    pub texels: f64,
    pub mask_mismatch: f64,
    pub unresolved: f64,
    pub wrong_surface: f64,
    pub angular_mean_deg: f64,
    pub angular_p95_deg: f64,
    pub psnr_db: f64,
    pub psnr_frame_db: f64,
    pub psnr_resolved_db: f64,
    /// NaN where no run of the method carries triangle IDs.
    pub same_triangle: f64,
    pub flip_mean: Option<f64>,
}

/// The mean of the values that are not NaN (NaN if none is).
fn mean_known(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values
        .filter(|v| !v.is_nan())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 { f64::NAN } else { sum / n as f64 }
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
            // Weighted over the runs where the figure exists.
            let weighted_known = |f: &dyn Fn(&RunResult) -> f64| {
                let known: Vec<&&RunResult> = rs.iter().filter(|r| !f(r).is_nan()).collect();
                let w: usize = known.iter().map(|r| r.mirror_pixels).sum();
                if known.is_empty() {
                    f64::NAN
                } else {
                    known
                        .iter()
                        .map(|r| f(r) * r.mirror_pixels as f64)
                        .sum::<f64>()
                        / w.max(1) as f64
                }
            };
            Summary {
                method: m.to_string(),
                kind: rs[0].kind,
                scenes: rs.len(),
                mirror_pixels: px,
                trace_ns_per_mirror_px: rs.iter().map(|r| r.trace_ns.median).sum::<f64>() / w,
                fallback_share: weighted(&|r| r.fallback_share),
                fallback_ns_per_mirror_px: rs.iter().map(|r| r.fallback_ns.median).sum::<f64>() / w,
                frame_ns_per_mirror_px: rs.iter().map(|r| r.total_ns.median).sum::<f64>() / w,
                cells: weighted(&|r| r.counters.cells),
                texels: weighted(&|r| r.counters.texels),
                mask_mismatch: weighted(&|r| r.error.mask_mismatch_fraction),
                unresolved: weighted(&|r| r.error.unresolved),
                // Not measured on a glossy scene (NaN): pooled over the others.
                wrong_surface: weighted_known(&|r| r.error.wrong_surface),
                angular_mean_deg: weighted_known(&|r| r.error.angular_mean_deg),
                angular_p95_deg: rs
                    .iter()
                    .map(|r| r.error.angular_p95_deg)
                    .filter(|a| !a.is_nan())
                    .reduce(f64::max)
                    .unwrap_or(f64::NAN),
                psnr_db: mean_known(rs.iter().map(|r| r.error.psnr_db)),
                psnr_frame_db: mean_known(rs.iter().map(|r| r.error.psnr_frame_db)),
                psnr_resolved_db: mean_known(rs.iter().map(|r| r.error.psnr_resolved_db)),
                same_triangle: weighted_known(&|r| r.error.same_triangle),
                flip_mean: (flips.len() == rs.len())
                    .then(|| weighted(&|r| r.flip_mean.unwrap_or(0.0))),
            }
        })
        .collect()
}

fn pct(x: f64) -> String {
    format!("{:.2}", 100.0 * x)
}

/// A percentage, `-` where the figure does not exist (NaN).
fn pct_known(x: f64) -> String {
    if x.is_nan() { "-".into() } else { pct(x) }
}

fn num(x: f64, digits: usize) -> String {
    if x.is_nan() {
        "-".into()
    } else if x.is_infinite() {
        "inf".into()
    } else {
        format!("{x:.digits$}")
    }
}

/// The header lines: device, commit, frame size, frames.
pub fn header(report: &BenchReport) -> String {
    let r0 = report.runs.first();
    let lists = if report.runs.iter().any(|r| r.method.contains("bounded")) {
        " (the bounded criterion's lists at their own face size, `--list-size auto`: `render -v` \
         names it)"
    } else {
        ""
    };
    format!(
        "Device: {}; commit {}; cubetrace {}; {} CPU threads (reference).\n\
         Frames: {}x{}, {} timed after {} warm-up; cube size {}{lists}{}.\n",
        report.device.describe(),
        report.git_commit.as_deref().unwrap_or("unknown"),
        report.cubetrace_version,
        report.cpu_threads,
        r0.map_or(0, |r| r.width),
        r0.map_or(0, |r| r.height),
        r0.map_or(0, |r| r.frames),
        report.warmup,
        r0.map_or("?".into(), |r| r.cube_size.to_string()),
        match report.bounces {
            1 => String::new(),
            n => format!(
                "; {n} bounces (the methods' ns/ray: their own first round; the rounds after it \
                 are the `bounce_append` pass)"
            ),
        },
    )
}

/// The per-method summary table (what `cubetrace bench` prints).
pub fn summary_table(report: &BenchReport) -> String {
    let mut s = String::new();
    s.push_str(
        "| method | scenes | mirror px | ns/mirror px | fallback % | fallback ns/mirror px | frame ns/mirror px | cells/ray | texels/ray | mask mismatch % | unresolved % | wrong surface % | angle mean deg | angle p95 deg | PSNR dB | PSNR resolved dB | PSNR frame dB | same triangle % | FLIP |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for m in summarise(&report.runs) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            m.method,
            m.scenes,
            m.mirror_pixels,
            num(m.trace_ns_per_mirror_px, 0),
            pct(m.fallback_share),
            num(m.fallback_ns_per_mirror_px, 0),
            num(m.frame_ns_per_mirror_px, 0),
            num(m.cells, 1),
            num(m.texels, 1),
            pct(m.mask_mismatch),
            pct(m.unresolved),
            pct_known(m.wrong_surface),
            num(m.angular_mean_deg, 3),
            num(m.angular_p95_deg, 3),
            num(m.psnr_db, 2),
            num(m.psnr_resolved_db, 2),
            num(m.psnr_frame_db, 2),
            pct_known(m.same_triangle),
            m.flip_mean.map_or("-".into(), |f| num(f, 4)),
        );
    }
    s
}

/// One row per run.
pub fn runs_table(report: &BenchReport) -> String {
    let mut s = String::new();
    s.push_str(
        "| scene | method | mirror px | trace ms (median [min, max]) | ns/mirror px | fallback % | fallback ms | check % | check ms | frame GPU ms | cells/ray | texels/ray | traces/ray | CMO MiB | mask mismatch (ref only + method only) | unresolved % | wrong % | wrong off-reflector % | angle mean | angle p95 | PSNR dB | PSNR resolved dB | PSNR frame dB | same triangle % | FLIP |\n\
         |---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in &report.runs {
        let t = &r.trace_ns;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.3} [{:.3}, {:.3}] | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} + {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.scene,
            r.method,
            r.mirror_pixels,
            t.median * 1e-6,
            t.min * 1e-6,
            t.max * 1e-6,
            num(r.trace_ns_per_mirror_px, 0),
            pct(r.fallback_share),
            num(r.fallback_ns.median * 1e-6, 3),
            pct(r.checked_share),
            num(r.check_ns.median * 1e-6, 3),
            if r.kind == Method::TRUTH {
                "-".into()
            } else {
                num(r.total_ns.median * 1e-6, 2)
            },
            num(r.counters.cells, 1),
            num(r.counters.texels, 1),
            num(r.counters.traces, 2),
            num(r.cmo_bytes as f64 / (1024.0 * 1024.0), 2),
            r.error.mask_missed,
            r.error.mask_extra,
            pct(r.error.unresolved),
            pct_known(r.error.wrong_surface),
            pct_known(r.wrong_off_reflector),
            num(r.error.angular_mean_deg, 3),
            num(r.error.angular_p95_deg, 3),
            num(r.error.psnr_db, 2),
            num(r.error.psnr_resolved_db, 2),
            num(r.error.psnr_frame_db, 2),
            pct_known(r.error.same_triangle),
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
    let (columns, floors, pairs) = (
        SceneRatios::columns(),
        SceneRatios::floor_columns(),
        SceneRatios::pairs(),
    );
    let mut head = String::from("| scene |");
    for m in &columns {
        let _ = write!(head, " {} ns/ray |", m.name());
    }
    for (m, over) in &pairs {
        let _ = write!(head, " {} / {} |", m.name(), over.name());
    }
    for m in &floors {
        let _ = write!(head, " {} floor ({floor} / full) |", m.name());
    }
    let n = columns.len() + pairs.len() + floors.len();
    let mut s = format!("{head}\n|---|{}\n", "---:|".repeat(n));
    for r in &report.ratios {
        let mut row = format!("| {} |", r.scene);
        for m in &columns {
            let _ = write!(row, " {} |", opt(r.ns_per_ray(*m), 0));
        }
        for (m, over) in &pairs {
            let _ = write!(row, " {} |", opt(r.ratio(*m, *over), 3));
        }
        for m in &floors {
            let _ = write!(row, " {} |", opt(r.floor(*m), 3));
        }
        let _ = writeln!(s, "{row}");
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
        .filter(|m| m.kind != Method::TRUTH)
        .map(|m| Point {
            label: m.method,
            cost: m.trace_ns_per_mirror_px,
            error: 100.0 * (m.mask_mismatch + m.unresolved + m.wrong_surface),
        })
        // A method run on glossy scenes only has no hit figures to place it by.
        .filter(|p| !p.error.is_nan())
        .collect();
    plot::scatter(
        &format!("speed against error on {}", report.device.name),
        "tracing pass, ns per mirror pixel (median, pooled over scenes)",
        &format!(
            "mask mismatch + unresolved + wrong surface, % of mirror pixels (floor {PLOT_FLOOR_PCT})"
        ),
        &points,
        PLOT_FLOOR_PCT,
        true,
    )
}

/// One point per scene and GPU method at its default setting (`compute` and `fragment-bounded`:
/// the bounded criterion), labelled `method: scene`; no Pareto front, since the scenes differ.
pub fn speed_error_scenes_svg(report: &BenchReport) -> Result<String> {
    let points: Vec<Point> = report
        .runs
        .iter()
        .filter(|r| r.kind != Method::TRUTH && r.method == super::MethodSpec::plain(r.kind).label())
        // A glossy scene's rows have no hit figures (`metrics::compare_colour`).
        .filter(|r| !r.error.error.is_nan())
        .map(|r| Point {
            label: format!("{}: {}", r.method, r.scene),
            cost: r.trace_ns_per_mirror_px,
            error: 100.0 * r.error.error,
        })
        .collect();
    plot::scatter(
        &format!("speed against error per scene on {}", report.device.name),
        "tracing pass, ns per mirror pixel (median)",
        &format!(
            "mask mismatch + unresolved + wrong surface, % of mirror pixels (floor {PLOT_FLOOR_PCT})"
        ),
        &points,
        PLOT_FLOOR_PCT,
        false,
    )
}

/// The reflection-point runs' search steps per vertex (mean and max in the frame, the paper's
/// Table 1); empty when none ran.
pub fn search_table(report: &BenchReport) -> String {
    let runs: Vec<&RunResult> = report
        .runs
        .iter()
        .filter(|r| r.kind.info().vertex_search)
        .collect();
    if runs.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\n## Reflection-point search\n\n| scene | method | steps/vertex mean | steps/vertex max |\n|---|---|---:|---:|\n",
    );
    for r in runs {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            r.scene,
            r.method,
            num(r.counters.search_mean, 1),
            r.counters.search_max
        );
    }
    s.push_str("\nCost: `reflection_point_targets` (the reflector textures), `reflection_point_search` (the per-vertex search) and `reflection_point_raster` (the virtual objects and the records) in the per-pass table.\n");
    s
}

/// The CMO placement of each cube-map run: its CMOs, the placement search's time (where it
/// ran), the capture pass, the frame against `bvh`'s on the same scene, the fallback's share;
/// empty when no run searched and the placement axis has one value.
pub fn placement_table(report: &BenchReport) -> String {
    let axis = report.runs.iter().any(|r| r.scene.ends_with(']'));
    let runs: Vec<&RunResult> = report
        .runs
        .iter()
        .filter(|r| r.kind.captures_cmos() && (axis || r.placement_ms.is_some()))
        .collect();
    if runs.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\n## CMO placement\n\n| scene | method | CMOs | search ms | capture ms | frame ms | frame / bvh | fallback % |\n|---|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in runs {
        let capture = r
            .passes
            .iter()
            .find(|p| p.pass == "capture")
            .map(|p| p.ns.median / 1e6);
        let bvh = report
            .runs
            .iter()
            .find(|b| b.scene == r.scene && b.kind == Method::EXACT_GPU)
            .map(|b| r.total_ns.median / b.total_ns.median);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            r.scene,
            r.method,
            r.cmos,
            opt(r.placement_ms, 0),
            opt(capture, 1),
            num(r.total_ns.median / 1e6, 1),
            opt(bvh, 2),
            pct(r.fallback_share)
        );
    }
    s.push_str(
        "\nsearch ms: CPU wall time of the placement search (run once per scene, before any frame); \
         capture ms: the GPU's capture pass (median); frame ms: every pass of the frame, capture and \
         fallback included; frame / bvh: against `bvh`'s frame on the same scene (where it ran).\n",
    );
    s
}

/// With `--bounces N > 1`: per GPU run, each round after the first (its rays, what traced
/// them, the share the fallback finished), the `bounce_append` pass that holds those rounds and
/// the frame; empty at one bounce.
pub fn rounds_table(report: &BenchReport) -> String {
    let runs: Vec<&RunResult> = report
        .runs
        .iter()
        .filter(|r| !r.rounds.is_empty())
        .collect();
    if runs.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\n## Bounce rounds\n\n| scene | method | rounds 2.. (rays, traced by, fallback %) | bounce_append ms | frame ms | wrong surface % |\n|---|---|---|---:|---:|---:|\n",
    );
    for r in runs {
        let rounds: Vec<String> = (r.rounds.iter())
            .map(|c| {
                let by = if c.method { "cube maps" } else { "BVH" };
                let fallback = f64::from(c.fallback) / f64::from(c.rays.max(1));
                format!("{} {by} {}", c.rays, pct(fallback))
            })
            .collect();
        let append = (r.passes.iter())
            .find(|p| p.pass == crate::vk::frame::BOUNCE_PASS)
            .map(|p| p.ns.median / 1e6);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} |",
            r.scene,
            r.method,
            rounds.join("; "),
            opt(append, 1),
            num(r.total_ns.median / 1e6, 1),
            pct(r.error.wrong_surface)
        );
    }
    s.push_str(
        "\nrays: the round's queued rays (paths still reflecting); traced by: the method's cube maps \
         (`compute`) or the BVH (`-bvh-bounces`, and every method that does not trace them); fallback %: \
         of the round's rays, those the exact fallback finished; bounce_append ms: the pass of all the \
         rounds after the first (median); wrong surface: of the mirror pixels, their paths' last hits.\n",
    );
    s
}

/// The Markdown document of `bench.md`: the header, then the summary, cost-per-ray (ratios),
/// runs and per-pass tables, each under its own heading, each the same text that
/// [`summary_table`], [`ratios_table`], [`runs_table`] and [`passes_table`] return (so the
/// tables a reader finds in `benches/results/` are the ones the bench printed, never retyped).
pub fn markdown(report: &BenchReport) -> String {
    format!(
        "# cubetrace bench\n\n{}\n## Summary per method\n\n{}\nCost: the tracing pass alone (reference: CPU wall time of its reflected-ray phase); \
         every GPU method renders with the render default `--fallback trace`: the mirror pixels it leaves unresolved are finished exactly by the BVH \
         (fallback %: their share; fallback ns: that pass's cost, apart from the tracing pass; frame ns: all passes, capture and fallback included). \
         Error: against the exact CPU reference, over the mirror pixels of either frame (mask mismatch: a mirror pixel of one frame only; \
         PSNR frame: the whole image). A scene with a glossy reflector is measured by colour against a converged reference \
         (`--compare-spp` samples at the pixel centre): a reflected ray's hit is one sample of the lobe there, so its hit figures \
         (wrong surface, angles, PSNR resolved, same triangle) are `-` and the summary pools them over the other scenes.\n\n## Cost per ray\n\n{}\nns/ray: the tracing pass's median time over the rays it traced (GPU: the method's mirror pixels; \
         reference: the CPU wall time of its reflected-ray phase over its first reflected rays, shading at the hit included). \
         Default settings: `compute` and `fragment-bounded` (the bounded criterion); `-centre` marks the centre-sampled criterion.\n\n## Runs\n\n{}\n## GPU time per pass\n\n{}\n\
         Heat maps (`heat/SCENE-METHOD.png`): grey = not a mirror pixel; black to red = angular error of the hit point, \
         0.01 to 10 degrees, logarithmic; white = wrong surface; magenta = unresolved; cyan = mirror pixel missed by the method's rasterisation; pink = mirror pixel of the method where the reference has none.\n{}",
        header(report),
        summary_table(report),
        ratios_table(report),
        runs_table(report),
        passes_table(report),
        search_table(report) + &placement_table(report) + &rounds_table(report)
    ) + &report.model.as_ref().map_or(String::new(), |m| {
        format!("\n{}", super::model::markdown(m))
    })
}

/// Writes `bench.json`, `bench.md` ([`markdown`]: the tables, next to the JSON they come
/// from), `speed-error.svg` and `speed-error-scenes.svg` (with `--model`, also `model.svg`:
/// [`super::model::svg`]) into `dir`; returns the paths, the
/// Markdown file's second, for the caller to print.
pub fn write(report: &BenchReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let json = dir.join("bench.json");
    write_atomic(&json, serde_json::to_string_pretty(report)?.as_bytes())?;
    let md = dir.join("bench.md");
    write_atomic(&md, markdown(report).as_bytes())?;
    let svg = dir.join("speed-error.svg");
    write_atomic(&svg, speed_error_svg(report)?.as_bytes())?;
    let scenes_svg = dir.join("speed-error-scenes.svg");
    write_atomic(&scenes_svg, speed_error_scenes_svg(report)?.as_bytes())?;
    let mut out = vec![json, md, svg, scenes_svg];
    if let Some(m) = &report.model {
        let model_svg = dir.join("model.svg");
        write_atomic(&model_svg, super::model::svg(m)?.as_bytes())?;
        out.push(model_svg);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::{DeviceInfo, Stats};
    use super::*;
    use crate::metrics::ErrorReport;

    fn run(scene: &str, error: ErrorReport) -> RunResult {
        RunResult {
            width: 10,
            height: 10,
            cube_size: 8,
            cmos: 1,
            triangles: 12,
            mirror_pixels: 100,
            rays: 100,
            frames: 1,
            error,
            ..RunResult::unmeasured(scene, "envmap".into(), Method::Envmap)
        }
    }

    fn report(runs: Vec<RunResult>) -> BenchReport {
        BenchReport {
            device: DeviceInfo {
                name: "test".into(),
                driver_name: None,
                driver_info: None,
                api_version: "1.3.0".into(),
                subgroup_size: 8,
                timestamps: true,
            },
            git_commit: None,
            cubetrace_version: "0",
            cpu_threads: 1,
            driver_threads: 1,
            warmup: 0,
            bounces: 1,
            ratios: super::super::SceneRatios::of(&runs),
            runs,
            model: None,
        }
    }

    /// The cell of `column` in the first data row of a Markdown table.
    fn cell(table: &str, column: &str) -> String {
        let rows: Vec<Vec<&str>> = table
            .lines()
            .map(|l| l.trim_matches('|').split(" | ").map(str::trim).collect())
            .collect();
        let k = rows[0].iter().position(|h| *h == column).unwrap();
        rows[2][k].to_string()
    }

    #[test]
    fn mask_mismatch_and_frame_psnr_are_in_every_table() {
        let good = ErrorReport {
            psnr_frame_db: 30.0,
            psnr_db: 20.0,
            ..ErrorReport::exact(100)
        };
        // A run whose frame lost 5 mirror pixels and drew 3 where the reference has none; no
        // angle to measure (NaN).
        let bad = ErrorReport {
            mask_missed: 5,
            mask_extra: 3,
            mask_mismatch: 8,
            mask_mismatch_fraction: 0.08,
            angular_mean_deg: f64::NAN,
            angular_p95_deg: f64::NAN,
            psnr_db: 10.0,
            psnr_frame_db: 20.0,
            psnr_resolved_db: 12.0,
            same_triangle: f64::NAN,
            ..ErrorReport::default()
        };
        let r = report(vec![run("a", good), run("b", bad)]);
        let summary = summary_table(&r);
        assert_eq!(cell(&summary, "mask mismatch %"), "4.00", "{summary}");
        assert_eq!(cell(&summary, "PSNR frame dB"), "25.00", "{summary}");
        // The NaN angle is left out of the pool, not averaged in as 0 or NaN.
        assert_eq!(cell(&summary, "angle mean deg"), "0.000", "{summary}");
        let runs = runs_table(&report(vec![run("b", bad)]));
        assert_eq!(
            cell(&runs, "mask mismatch (ref only + method only)"),
            "5 + 3"
        );
        assert_eq!(cell(&runs, "angle mean"), "-");
        // Same triangle: '-' for a run without triangle IDs, left out of the pool.
        assert_eq!(cell(&runs, "same triangle %"), "-");
        assert_eq!(cell(&runs, "PSNR resolved dB"), "12.00");
        assert_eq!(cell(&summary, "same triangle %"), "100.00", "{summary}");
        assert_eq!(cell(&summary, "PSNR resolved dB"), "inf", "{summary}");
        assert_eq!(cell(&runs, "PSNR frame dB"), "20.00");
        // The plot's error includes the mismatch.
        let svg = speed_error_svg(&report(vec![run("b", bad)])).unwrap();
        assert!(svg.contains("mask mismatch"), "axis label");
        // Negative: without a mismatch the column reads 0.
        let summary = summary_table(&report(vec![run("a", good)]));
        assert_eq!(cell(&summary, "mask mismatch %"), "0.00");
        assert_eq!(cell(&summary, "PSNR frame dB"), "30.00");
    }

    #[test]
    fn the_cost_per_ray_table_has_a_column_per_method_and_ratio() {
        let r = report(vec![run("a", ErrorReport::exact(100))]);
        let table = ratios_table(&r);
        assert_eq!(
            table.lines().next().unwrap(),
            "| scene | reference ns/ray | envmap ns/ray | fragment ns/ray | compute ns/ray | ssr ns/ray \
             | bvh ns/ray | fragment / reference | compute / reference | compute / fragment | \
             compute / bvh | fragment floor (small frame / full) | compute floor (small frame / \
             full) |"
        );
        // One cell per column in every row: the envmap run's cost, '-' for the rest.
        let cells = |line: &str| line.matches('|').count();
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 3, "{table}");
        assert!(lines.iter().all(|l| cells(l) == cells(lines[0])), "{table}");
        assert_eq!(cell(&table, "envmap ns/ray"), "0");
        assert_eq!(cell(&table, "compute / bvh"), "-");
    }

    /// A fresh, empty folder under the system's temporary folder.
    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("cubetrace-report-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A run of `scene` whose frame has one timed pass.
    fn timed_run(scene: &str, pass: &str, median_ns: f64) -> RunResult {
        let ns = Stats {
            median: median_ns,
            min: median_ns,
            max: median_ns,
        };
        RunResult {
            passes: vec![super::super::PassStats {
                pass: pass.into(),
                ns,
            }],
            trace_ns: ns,
            ..run(scene, ErrorReport::exact(100))
        }
    }

    #[test]
    fn bench_writes_its_tables_as_markdown_next_to_the_json() {
        let dir = scratch("tables");
        let r = report(vec![
            timed_run("room", "envmap", 2.0e6),
            timed_run("bowl", "envmap", 3.0e6),
        ]);
        let paths = write(&r, &dir).unwrap();
        assert_eq!(paths[0], dir.join("bench.json"));
        assert_eq!(paths[1], dir.join("bench.md"), "the caller prints paths[1]");
        let md = std::fs::read_to_string(&paths[1]).unwrap();
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&paths[0]).unwrap()).unwrap();
        assert_eq!(json["runs"].as_array().unwrap().len(), 2);
        for (heading, table) in [
            ("# cubetrace bench", header(&r)),
            ("## Summary per method", summary_table(&r)),
            ("## Cost per ray", ratios_table(&r)),
            ("## Runs", runs_table(&r)),
            ("## GPU time per pass", passes_table(&r)),
        ] {
            let at = md
                .find(heading)
                .unwrap_or_else(|| panic!("{heading} missing:\n{md}"));
            assert!(md[at..].contains(&table), "{heading}: table missing:\n{md}");
        }
        // Every run and every timed pass has its row (the tables are not empty shells).
        for scene in ["room", "bowl"] {
            assert!(md.contains(&format!("| {scene} | envmap | 100 |")), "{md}");
            assert!(
                md.contains(&format!("| {scene} | envmap | envmap |")),
                "{md}"
            );
        }
        assert!(md.contains("| envmap | 2 | 200 |"), "summary row: {md}");
        // Negative: another report's tables are not in this file, and writing it replaces the
        // file (no stale tables from the first run).
        let other = report(vec![timed_run("torus", "envmap", 5.0e6)]);
        assert!(!md.contains(&runs_table(&other)));
        assert!(!md.contains(&summary_table(&other)));
        write(&other, &dir).unwrap();
        let md = std::fs::read_to_string(dir.join("bench.md")).unwrap();
        assert!(md.contains(&runs_table(&other)), "{md}");
        assert!(!md.contains("| room |"), "stale row: {md}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

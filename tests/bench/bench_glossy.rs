//! `cubetrace bench --glossy` (`bench::glossy`), on tiny frames.
//! - Its frames are the commands' frames: with `--glossy-film` the converged reference is
//!   `reference --spp N`'s, a rung of the ladder `render --method bvh --spp N`'s, bit for bit;
//!   at one sample the default (every sample at the pixel centre) is too. At the pixel centre
//!   the GPU ladder is the CPU reference's estimate at the same spp (> 50 dB). Negatives:
//!   another spp (other offsets, other keys) is another frame.
//! - A run has a row for every scene x power x method and every rung of the ladder, each method
//!   marked as the commands' warning says (mirror only), set against the ladder and scoring
//!   within half a dB of its measured PSNR; bvh's PSNR rises along the ladder. Negatives: a
//!   black or grey frame fails the rows' bounds; against a reference of another power (a
//!   wrong lobe) or the mirror, the same ladder scores lower and stops rising.
//! - The JSON is deterministic apart from the timings (and what they choose). Negative: another
//!   power changes it.
//! - Bad `--glossy` values are refused before anything renders, naming the flag.
//!
//! The "cheapest bvh row of at least the same cost" and the interpolation in log spp are unit
//! tests of `bench::glossy` (hand-made ladders).
use crate::common;
use common::bits::vec3_bits as bits;
use common::render_args;
use common::{finish_gpu, finish_renderer, gpu_context};

use std::path::Path;

use cubetrace::Method;
use cubetrace::bench::MethodSpec;
use cubetrace::bench::glossy::{self, GlossyConfig, GlossyReport, Tracing};
use cubetrace::film::{FilmSettings, PixelFilter};
use cubetrace::metrics::psnr_over;
use cubetrace::reference::Tracer;
use cubetrace::render::glossy::{mc_frame, method_warning, reference_frame};
use cubetrace::render::{FrameRenderer, samples};
use cubetrace::scene::Scene;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{Fallback, GpuRenderer, RenderOptions};

const WIDTH: u32 = 32;
const HEIGHT: u32 = 24;

fn config(scenes: &[&str], powers: &[f32], methods: &[Method], spp: &[u32]) -> GlossyConfig {
    GlossyConfig {
        scenes: scenes.iter().map(|s| s.to_string()).collect(),
        powers: powers.to_vec(),
        methods: methods.to_vec(),
        width: WIDTH,
        height: HEIGHT,
        frames: 1,
        warmup: 0,
        cube_size: Some(32),
        cmos: None,
        reflector_check: true,
        reference_spp: 256,
        spp: spp.to_vec(),
        film: false,
    }
}

/// The commands' rule: a method that warns on the glossy scene traces the mirror direction only.
fn mirror_only(scene: &Scene, m: Method) -> bool {
    method_warning(scene, m, 1).is_some()
}

fn run(ctx: &GpuContext, cfg: &GlossyConfig) -> GlossyReport {
    glossy::run(ctx, cfg, &|_| {}).unwrap_or_else(|e| panic!("{e:#}"))
}

/// A built-in scene at 32x24 with 32-texel CMOs, its reflectors at `power`, and its camera.
fn glossy_scene(name: &str, power: f32) -> (Scene, cubetrace::camera::Camera) {
    let (mut s, cam) =
        cubetrace::bench::prepare_scene(name, WIDTH, HEIGHT, Some(32), None).unwrap();
    s.make_reflectors_glossy(power);
    (s, cam)
}

/// The bench's reference is `reference --spp N`'s frame and a rung of its ladder is
/// `render --method bvh --spp N`'s, bit for bit. Negative: the frames at another spp differ.
#[test]
fn the_bench_renders_the_commands_frames() {
    let (s, cam) = glossy_scene("sphere-room", 64.0);
    let t = Tracer::new(&s);
    let film = |spp| FilmSettings {
        spp,
        filter: PixelFilter::Box,
    };
    let (mine, half) = reference_frame(&s, &t, &cam, 8, true);
    let theirs = samples::reference_frame(&s, &t, &cam, 1, film(8), false).0;
    assert!(bits(&mine.colour) == bits(&theirs.colour));
    assert_eq!(mine.mask, theirs.mask);
    let four = samples::reference_frame(&s, &t, &cam, 1, film(4), false).0;
    assert!(
        bits(&mine.colour) != bits(&four.colour),
        "negative: 4 spp is another frame"
    );
    // The half-spp frame (even samples) is neither the frame nor the 4-spp frame.
    assert!(bits(&half) != bits(&mine.colour) && bits(&half) != bits(&four.colour));

    let ctx = gpu_context();
    let options = RenderOptions {
        method: Method::Bvh,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let mut r = GpuRenderer::new(&ctx, &s, &cam, options).unwrap();
    let (ladder4, passes) = mc_frame(&ctx, &mut r, &s, &cam, 4, true).unwrap();
    let trace = cubetrace::vk::frame::pass_name(Method::Bvh);
    assert!(passes.iter().any(|(n, _)| n == trace), "{passes:?}");
    let line = ["sphere-room", "--method", "bvh", "--spp", "4"];
    let mut fr = FrameRenderer::new(&render_args(&line), &s, &cam).unwrap();
    let cli = fr.render(&s, &cam).unwrap();
    assert!(bits(&ladder4) == bits(cli.colour()), "render --spp 4");
    let (ladder2, _) = mc_frame(&ctx, &mut r, &s, &cam, 2, true).unwrap();
    assert!(bits(&ladder2) != bits(cli.colour()), "negative: 2 spp");
    // The renderer is reused along the ladder: back at 4 spp, the same frame.
    let (again, _) = mc_frame(&ctx, &mut r, &s, &cam, 4, true).unwrap();
    assert!(bits(&again) == bits(&ladder4));

    // At one sample the pixel centre is the film's only offset: the commands' frames again.
    let one = samples::reference_frame(&s, &t, &cam, 1, film(1), false).0;
    assert!(bits(&reference_frame(&s, &t, &cam, 1, false).0.colour) == bits(&one.colour));
    let line = ["sphere-room", "--method", "bvh", "--spp", "1"];
    let mut fr1 = FrameRenderer::new(&render_args(&line), &s, &cam).unwrap();
    let cli1 = fr1.render(&s, &cam).unwrap();
    let (centre1, _) = mc_frame(&ctx, &mut r, &s, &cam, 1, false).unwrap();
    assert!(bits(&centre1) == bits(cli1.colour()), "render --spp 1");
    // At the pixel centre the GPU's 16 samples are the reference's 16 (the same keys), up to
    // rounding; negative: the reference's 15 (other keys) are another estimate.
    let (centre16, _) = mc_frame(&ctx, &mut r, &s, &cam, 16, false).unwrap();
    let cpu = |spp| reference_frame(&s, &t, &cam, spp, false).0;
    let (r16, r15) = (cpu(16), cpu(15));
    let same = psnr_over(&centre16, &r16.colour, &r16.mask);
    let other = psnr_over(&centre16, &r15.colour, &r16.mask);
    eprintln!(
        "bvh at the pixel centre, 16 spp: {same:.2} dB against the reference's 16, {other:.2} against its 15"
    );
    assert!(same > 50.0, "{same}");
    assert!(other < 40.0, "negative: {other}");
    finish_renderer(fr1);
    drop(r);
    finish_renderer(fr);
    finish_gpu(ctx);
}

/// The PSNR (dB, over the mirror pixels against the 256-spp reference) of each method row of
/// `rows_for_every_scene_power_and_method_and_bvh_converges`, as measured on lavapipe: (scene,
/// power, method label, dB).
const ROW_DB: [(&str, f32, &str, f64); 20] = [
    ("sphere-room", 16.0, "envmap", 16.61),
    ("sphere-room", 16.0, "fragment-bounded", 26.12),
    ("sphere-room", 16.0, "compute", 26.12),
    ("sphere-room", 16.0, "ssr", 17.91),
    ("sphere-room", 16.0, "reflection-point", 17.16),
    ("sphere-room", 256.0, "envmap", 16.45),
    ("sphere-room", 256.0, "fragment-bounded", 22.14),
    ("sphere-room", 256.0, "compute", 22.14),
    ("sphere-room", 256.0, "ssr", 19.14),
    ("sphere-room", 256.0, "reflection-point", 17.93),
    ("teapot", 16.0, "envmap", 15.19),
    ("teapot", 16.0, "fragment-bounded", 22.03),
    ("teapot", 16.0, "compute", 22.03),
    ("teapot", 16.0, "ssr", 16.64),
    ("teapot", 16.0, "reflection-point", 14.19),
    ("teapot", 256.0, "envmap", 14.33),
    ("teapot", 256.0, "fragment-bounded", 21.58),
    ("teapot", 256.0, "compute", 21.58),
    ("teapot", 256.0, "ssr", 16.66),
    ("teapot", 256.0, "reflection-point", 14.21),
];

/// How far below its measured PSNR a row may score. The frames and the references are
/// deterministic (fragment and compute score alike to 0.01 dB), so the margin only absorbs
/// another device's arithmetic: a loss of more than half a dB fails.
const ROW_MARGIN_DB: f64 = 0.5;

/// The row check: `db` is finite and at most [`ROW_MARGIN_DB`] below the measured PSNR of
/// `method` on `scene` at `power` in [`ROW_DB`].
fn row_bound(scene: &str, power: f32, method: &str, db: f64) -> Result<(), String> {
    let (.., measured) = ROW_DB
        .iter()
        .find(|r| r.0 == scene && r.1 == power && r.2 == method)
        .ok_or_else(|| format!("{scene} {power} {method}: no measured PSNR"))?;
    let bound = measured - ROW_MARGIN_DB;
    if db.is_finite() && db > bound {
        Ok(())
    } else {
        Err(format!(
            "{scene} {power} {method}: {db:.2} dB, bound {bound:.2}"
        ))
    }
}

/// Rows for every scene x power x method and every rung; the methods marked as the commands'
/// warning says and set against the ladder; bvh's PSNR rising along it (4x the samples: at
/// least 3 dB, where an unbiased estimate gains about 5 against a 256-spp truth); each method
/// row within [`ROW_MARGIN_DB`] of its measured PSNR ([`ROW_DB`]: 14.19 to 26.12 dB).
/// Negatives: a black frame and a constant grey one fail every row bound of their scene and
/// power (they score 10.5 to 12.4 dB); the same ladder against the reference of a power 4x too
/// high, or of the mirror, scores lower and stops rising.
#[test]
fn rows_for_every_scene_power_and_method_and_bvh_converges() {
    let ctx = gpu_context();
    let methods: Vec<Method> = (Method::ALL.into_iter())
        .filter(|m| m.is_gpu() && *m != Method::Bvh)
        .collect();
    let ladder = [1, 4, 16, 64];
    let cfg = config(
        &["sphere-room", "teapot"],
        &[16.0, 256.0],
        &methods,
        &ladder,
    );
    let report = run(&ctx, &cfg);
    assert_eq!(report.references.len(), 4);
    for r in &report.references {
        eprintln!(
            "reference {} power {}: {} mirror px, {} spp in {:.2} s, half-spp PSNR {:.2} dB",
            r.scene, r.power, r.mirror_pixels, r.spp, r.wall_s, r.half_spp_psnr_db
        );
        assert!(r.mirror_pixels > 20, "{r:?}");
        assert!(r.half_spp_psnr_db > 25.0 && r.half_spp_psnr_db.is_finite());
    }
    for scene in ["sphere-room", "teapot"] {
        for power in [16.0, 256.0] {
            let (s, _) = glossy_scene(scene, power);
            let rows: Vec<_> = (report.rows.iter())
                .filter(|r| r.scene == scene && r.power == power)
                .collect();
            assert_eq!(rows.len(), methods.len() + ladder.len(), "{scene} {power}");
            for &m in &methods {
                let label = MethodSpec::plain(m).label();
                let row = rows.iter().find(|r| r.method == label).expect(&label);
                let want = if mirror_only(&s, m) {
                    Tracing::Mirror
                } else {
                    Tracing::Cone
                };
                assert_eq!(row.tracing, want, "{scene} {power} {m}");
                eprintln!(
                    "{scene} power {power}: {label} ({}) {:.2} dB",
                    row.tracing.name(),
                    row.psnr_db
                );
                row_bound(scene, power, &label, row.psnr_db).unwrap_or_else(|e| panic!("{e}"));
                assert!(row.versus_bvh.is_some() && !row.passes.is_empty());
                assert_eq!(row.spp, 1);
            }
            let mc: Vec<_> = rows
                .iter()
                .filter(|r| r.tracing == Tracing::MonteCarlo)
                .collect();
            let db: Vec<f64> = mc.iter().map(|r| r.psnr_db).collect();
            let spp: Vec<u32> = mc.iter().map(|r| r.spp).collect();
            eprintln!("{scene} power {power}: bvh PSNR {db:.2?} at {spp:?} spp");
            assert_eq!(spp, ladder);
            assert!(
                mc.iter()
                    .all(|r| r.versus_bvh.is_none() && r.method == "bvh")
            );
            for w in db.windows(2) {
                assert!(w[1] > w[0] + 3.0, "{scene} {power}: {db:?}");
            }
            // Negatives: a black and a grey frame against the run's reference fail the row
            // bounds of every method.
            let (s, cam) = glossy_scene(scene, power);
            let truth = reference_frame(&s, &Tracer::new(&s), &cam, cfg.reference_spp, false).0;
            for (what, c) in [
                ("black", glam::Vec3::ZERO),
                ("grey", glam::Vec3::splat(0.5)),
            ] {
                let frame = vec![c; truth.colour.len()];
                let db = psnr_over(&frame, &truth.colour, &truth.mask);
                eprintln!("{scene} power {power}: a {what} frame {db:.2} dB");
                for &m in &methods {
                    let label = MethodSpec::plain(m).label();
                    row_bound(scene, power, &label, db)
                        .expect_err(&format!("negative: a {what} frame passes {label}"));
                }
            }
        }
    }
    wrong_lobe_stops_rising(&ctx);
    finish_gpu(ctx);
}

/// The bench's ladder (`mc_frame`) scored by the bench's PSNR against the right reference and
/// against wrong ones: power 64's ladder against power 256's reference and the mirror's.
fn wrong_lobe_stops_rising(ctx: &GpuContext) {
    let (s, cam) = glossy_scene("sphere-room", 64.0);
    let truth = reference_frame(&s, &Tracer::new(&s), &cam, 1024, false).0;
    let wrong = |power: f32| {
        let (w, _) = glossy_scene("sphere-room", power);
        reference_frame(&w, &Tracer::new(&w), &cam, 1024, false).0
    };
    let (w16, w256, mirror) = (
        wrong(16.0),
        wrong(256.0),
        wrong(cubetrace::lobe::MIRROR_POWER),
    );
    let options = RenderOptions {
        method: Method::Bvh,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let mut r = GpuRenderer::new(ctx, &s, &cam, options).unwrap();
    let mut at = Vec::new();
    for spp in [4, 64, 256] {
        let (c, _) = mc_frame(ctx, &mut r, &s, &cam, spp, false).unwrap();
        let score = |f: &cubetrace::reference::Frame| psnr_over(&c, &f.colour, &truth.mask);
        at.push((score(&truth), score(&w16), score(&w256), score(&mirror)));
    }
    drop(r);
    for (what, k) in [
        ("its reference", 0),
        ("power 16's", 1),
        ("power 256's", 2),
        ("the mirror's", 3),
    ] {
        let db: Vec<f64> = at.iter().map(|a| [a.0, a.1, a.2, a.3][k]).collect();
        eprintln!("bvh power 64 at 4 / 64 / 256 spp against {what} (1024 spp): {db:.2?} dB");
    }
    let ((r4, _, _, _), (r64, a64, b64, m64), (r256, a256, b256, m256)) = (at[0], at[1], at[2]);
    assert!(r64 - r4 > 8.0 && r256 - r64 > 3.0, "{at:?}");
    // A lobe 4x too wide and the mirror: far below, and they stop rising (their bias stays).
    let gain = r256 - r64;
    for (what, lo, hi) in [("power 16", a64, a256), ("mirror", m64, m256)] {
        assert!(hi < r256 - 3.0, "{what}: {hi} against {r256}");
        assert!(hi - lo < 0.5 * gain, "{what}: {lo} to {hi}");
    }
    // A lobe 4x too narrow differs less at 32x24: below, whether or not it has stopped.
    assert!(
        b256 < r256 - 1.5 && b64 < r64,
        "power 256: {b256} against {r256}"
    );
}

/// Strips what depends on the clock: the times and the comparison they choose.
fn without_timings(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(map) => {
            for key in [
                "frame_ns",
                "reused_frame_ns",
                "trace_ns",
                "trace_ns_per_mirror_px",
                "ns",
                "wall_s",
                "versus_bvh",
                "device",
                "git_commit",
            ] {
                map.remove(key);
            }
            map.values_mut().for_each(without_timings);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(without_timings),
        _ => {}
    }
}

/// Two runs give the same JSON apart from the timings. Negative: another power does not; and
/// the stripped JSON still holds the rows' PSNR and passes.
#[test]
fn json_is_deterministic_apart_from_timings() {
    let ctx = gpu_context();
    let cfg = GlossyConfig {
        reference_spp: 8,
        ..config(
            &["torus"],
            &[64.0],
            &[Method::Envmap, Method::Compute],
            &[1, 2],
        )
    };
    let json = |cfg: &GlossyConfig| {
        let mut v = serde_json::to_value(run(&ctx, cfg)).unwrap();
        without_timings(&mut v);
        v
    };
    let (a, b) = (json(&cfg), json(&cfg));
    assert_eq!(a, b);
    let text = a.to_string();
    assert!(
        text.contains("psnr_db") && text.contains("\"passes\""),
        "{text}"
    );
    let other = json(&GlossyConfig {
        powers: vec![65.0],
        ..cfg.clone()
    });
    assert_ne!(a, other, "negative: power 65");
    // The files: JSON, Markdown with a table per power, the plot with a panel per power.
    let dir = tempfile::tempdir().unwrap();
    let report = run(&ctx, &cfg);
    let paths = glossy::write(&report, dir.path()).unwrap();
    assert_eq!(paths.len(), 3);
    let md = std::fs::read_to_string(dir.path().join("glossy.md")).unwrap();
    assert!(
        md.contains("## Power 64") && md.contains("| torus | envmap |"),
        "{md}"
    );
    let svg = std::fs::read_to_string(dir.path().join("glossy.svg")).unwrap();
    assert!(svg.contains("power 64") && svg.contains("envmap") && svg.contains("compute"));
    finish_gpu(ctx);
}

fn cli(args: &[&str], cwd: &Path) -> (Option<i32>, String) {
    let o = common::binary::run(args, cwd);
    (o.code, o.stderr)
}

/// Bad `--glossy` (and `--glossy-spp`) values: exit 1, one error naming the flag and the value,
/// no panic, nothing written. Negative: the good powers parse.
#[test]
fn bad_glossy_values_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    for (value, needle) in [
        ("--glossy=", "--glossy: no specular power"),
        ("--glossy=-5", "--glossy: -5 is not a specular power"),
        ("--glossy=nan", "--glossy: NaN is not a specular power"),
        ("--glossy=16,inf", "--glossy: inf is not a specular power"),
        ("--glossy=1024", "--glossy: 1024 is a mirror"),
        ("--glossy=4096", "--glossy: 4096 is a mirror"),
        ("--glossy=64,64", "--glossy: power 64 is listed twice"),
        ("--glossy=shiny", "--glossy: 'shiny' is not a number"),
    ] {
        let (code, err) = cli(&["bench", value, "-o", "out"], dir.path());
        assert_eq!(code, Some(1), "{value}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(err.lines().filter(|l| l.starts_with("error:")).count(), 1);
        assert!(err.contains(needle), "{value}: {err}");
    }
    // A negative number after a space is the flag's value, not an unknown flag.
    let (code, err) = cli(&["bench", "--glossy", "-5", "-o", "out"], dir.path());
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("--glossy: -5 is not"), "{err}");
    for (line, needle) in [
        (
            &["--glossy", "--glossy-spp", "4,2"][..],
            "--glossy-spp: the counts must increase",
        ),
        (
            &["--glossy", "--glossy-spp", "0"][..],
            "--glossy-spp: 0 is not",
        ),
        (&["--glossy", "--bounces", "2"][..], "leave out --bounces"),
        (
            &["--glossy", "--quick"][..],
            "--quick does not apply to --glossy",
        ),
    ] {
        let mut args = vec!["bench"];
        args.extend_from_slice(line);
        args.extend_from_slice(&["-o", "out"]);
        let (code, err) = cli(&args, dir.path());
        assert_eq!(code, Some(1), "{line:?}: {err}");
        assert!(err.contains(needle), "{line:?}: {err}");
    }
    // The ladder's flags need --glossy (clap's refusal, exit 2).
    let (code, err) = cli(&["bench", "--glossy-spp", "4", "-o", "out"], dir.path());
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--glossy"), "{err}");
    assert!(!dir.path().join("out").exists(), "nothing is written");
    // Negative: the default and a good list parse.
    let parse = |v: &[&str]| {
        let v: Vec<String> = v.iter().map(|s| s.to_string()).collect();
        cubetrace::app::bench::parse_powers(&v)
    };
    assert_eq!(
        parse(&["16", "64", "256"]).unwrap(),
        vec![16.0, 64.0, 256.0]
    );
    assert_eq!(parse(&["0", " 1023 "]).unwrap(), vec![0.0, 1023.0]);
    assert!(parse(&["-0.5"]).is_err());
}

/// The converged reference of `--bounces N` (what `render --compare` and the grid measure a
/// glossy frame of N bounces against) samples every reflection: bit for bit `render --method
/// reference --bounces 2 --spp 8` on the glossy teapot, which sees itself. Negative: the
/// one-bounce reference is another frame there.
#[test]
fn the_converged_reference_follows_the_bounces() {
    let (s, cam) = glossy_scene("teapot", 64.0);
    let t = Tracer::new(&s);
    let film = FilmSettings {
        spp: 8,
        filter: PixelFilter::Box,
    };
    let two = cubetrace::render::glossy::reference_frame_bounces(&s, &t, &cam, 2, 8, true).0;
    let theirs = samples::reference_frame(&s, &t, &cam, 2, film, false).0;
    assert!(bits(&two.colour) == bits(&theirs.colour));
    let one = reference_frame(&s, &t, &cam, 8, true).0;
    assert!(
        bits(&one.colour) != bits(&two.colour),
        "negative: one bounce"
    );
}

/// The grid (`bench`, not `--glossy`) measures a scene with a glossy reflector by colour against
/// a converged reference: its rows have no hit figures (NaN, `-` in `bench.md`, no heat map),
/// their mirror pixels are the converged frame's (computed here), and cone-traced `compute`
/// scores above `bvh`'s single lobe sample. A mirror scene beside it keeps its hit figures, and
/// the summary pools those over it alone. Negative: against the one-sample reference (the
/// grid's comparison before), `bvh` would match the reference's own sample and score far above
/// `compute`, so the order of the two PSNRs fails.
#[test]
fn the_grid_measures_a_glossy_scene_against_a_converged_reference() {
    let ctx = gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let cfg = cubetrace::bench::BenchConfig {
        scenes: vec!["sphere-room-glossy".into(), "sphere-room".into()],
        methods: [Method::Compute, Method::EXACT_GPU, Method::TRUTH]
            .map(MethodSpec::plain)
            .to_vec(),
        width: WIDTH,
        height: HEIGHT,
        frames: 1,
        warmup: 0,
        cube_size: Some(32),
        flip: false,
        floor: None,
        compare_spp: 64,
        out: out.path().to_path_buf(),
        ..cubetrace::bench::BenchConfig::default()
    };
    let bar = indicatif::ProgressBar::hidden();
    let report = cubetrace::bench::run(&ctx, &cfg, &bar).unwrap_or_else(|e| panic!("{e:#}"));
    let row = |scene: &str, method: &str| {
        (report.runs.iter())
            .find(|r| r.scene == scene && r.method == method)
            .unwrap_or_else(|| panic!("no row {scene} {method}"))
    };
    let (scene, cam) = glossy_scene("sphere-room-glossy", 64.0);
    let truth = reference_frame(&scene, &Tracer::new(&scene), &cam, 8, false).0;
    for method in ["compute", "bvh", "reference"] {
        let r = row("sphere-room-glossy", method);
        let e = &r.error;
        for hit in [
            e.wrong_surface,
            e.angular_mean_deg,
            e.same_triangle,
            r.wrong_off_reflector,
        ] {
            assert!(hit.is_nan(), "{method}: a hit figure on a glossy scene");
        }
        assert_eq!(e.mirror_pixels, truth.mirror_pixels(), "{method}");
        assert_eq!(e.mask_mismatch, 0, "{method}");
        assert!(e.psnr_db.is_finite(), "{method}");
        assert!(r.heatmap.is_none(), "{method}: a heat map of hit verdicts");
        let m = row("sphere-room", method);
        assert!(m.error.wrong_surface.is_finite(), "{method}");
    }
    let (cone, sample) = (
        row("sphere-room-glossy", "compute").error.psnr_db,
        row("sphere-room-glossy", "bvh").error.psnr_db,
    );
    assert!(
        cone > sample + 3.0,
        "compute {cone:.2} dB, bvh {sample:.2} dB"
    );
    let summary = cubetrace::bench::report::summarise(&report.runs);
    let pooled = summary.iter().find(|s| s.method == "compute").unwrap();
    assert_eq!(
        pooled.wrong_surface,
        row("sphere-room", "compute").error.wrong_surface
    );
    let md = cubetrace::bench::report::markdown(&report);
    let line = (md.lines())
        .find(|l| l.starts_with("| sphere-room-glossy | compute |"))
        .expect("the glossy compute row");
    let header = (md.lines())
        .find(|l| l.starts_with("| scene | method | mirror px |"))
        .unwrap();
    let wrong = (header.split('|').map(str::trim))
        .position(|c| c == "wrong %")
        .unwrap();
    assert_eq!(line.split('|').map(str::trim).nth(wrong), Some("-"));
    finish_gpu(ctx);
}

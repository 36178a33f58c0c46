//! The harness end to end on one small scene: every method's default setting, the per-ray
//! costs and ratios per scene, the small-frame floor runs, and the files it writes.

use crate::common;

use cubetrace::app;
use cubetrace::bench::{self, BenchConfig, Method};
use cubetrace::vk::frame::RoundCount;

/// The full grid runs compute in its three lane layouts beside its default, labelled
/// `compute-thesis`, `compute-one-lane` and `compute-wave`: the same cells and texels per ray, the
/// same fallback share and error (the layouts write the same records). Negative: the centre
/// criterion's run differs in its counters.
#[test]
fn bench_sets_the_compute_layouts_side_by_side() {
    let ctx = common::gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let methods = bench::method_grid(&[Method::Compute], false);
    let cfg = small_teapot(out.path(), methods, 1);
    let report = bench::run(&ctx, &cfg, &indicatif::ProgressBar::hidden()).expect("bench");
    let labels: Vec<&str> = report.runs.iter().map(|r| r.method.as_str()).collect();
    assert_eq!(
        labels,
        [
            "compute",
            "compute-thesis",
            "compute-one-lane",
            "compute-wave",
            "compute-centre"
        ]
    );
    let key = |r: &bench::RunResult| {
        let c = &r.counters;
        format!(
            "{} {} {} {} {:?}",
            c.cells, c.texels, c.traces, r.fallback_share, r.error
        )
    };
    let plain = key(&report.runs[0]);
    assert!(report.runs[0].counters.cells > 0.0);
    for r in &report.runs[1..4] {
        assert_eq!(key(r), plain, "{}", r.method);
    }
    assert_ne!(key(&report.runs[4]), plain, "the comparison is blind");
}

#[test]
fn bench_reports_cost_per_ray_ratios_and_floor() {
    let ctx = common::gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let cfg = BenchConfig {
        scenes: vec!["sphere-room".into()],
        methods: bench::method_grid(&Method::ALL, true),
        width: 40,
        height: 30,
        frames: 1,
        warmup: 0,
        cube_size: Some(32),
        flip: false,
        heatmaps: false,
        out: out.path().to_path_buf(),
        ..BenchConfig::default()
    };
    let report = bench::run(&ctx, &cfg, &indicatif::ProgressBar::hidden()).expect("bench");
    assert_eq!(report.runs.len(), cfg.methods.len());
    // One run per method, the reflection-point method subdivided too, and the two cubemap
    // tracers with the centre criterion beside their default, the bounded one.
    assert_eq!(cfg.methods.len(), Method::ALL.len() + 3);
    let centre: Vec<_> = report
        .runs
        .iter()
        .filter(|r| r.method.contains("-centre"))
        .map(|r| r.method.as_str())
        .collect();
    assert_eq!(centre, ["fragment-centre-mip", "compute-centre"]);
    assert!(
        report
            .runs
            .iter()
            .filter(|r| r.method.contains("-centre"))
            .all(|r| r.floor.is_none())
    );
    assert!(
        report
            .runs
            .iter()
            .filter(|r| ["fragment-bounded", "compute"].contains(&r.method.as_str()))
            .all(|r| r.error.same_triangle >= 0.999)
    );
    // The reflection-point method runs plain and subdivided (more triangles, same reference),
    // with its search steps per vertex in the counters.
    let rp: Vec<_> = report
        .runs
        .iter()
        .filter(|r| r.kind == Method::ReflectionPoint)
        .collect();
    let [plain, sub] = rp.as_slice() else {
        panic!("two reflection-point runs: {rp:?}")
    };
    assert_eq!(sub.method, "reflection-point-sub2");
    assert!(sub.triangles > plain.triangles);
    assert!(plain.counters.search_mean > 1.0 && plain.counters.search_max >= 1);
    assert!(
        report
            .runs
            .iter()
            .all(|r| r.kind == Method::ReflectionPoint || r.counters.search_max == 0)
    );
    // Every GPU method renders with `--fallback trace`: nothing is left unresolved, and where
    // the method left pixels the fallback's share and cost are reported apart and counted in
    // the frame time. bvh needs no fallback and hits the reference's triangles.
    for r in report.runs.iter().filter(|r| r.kind != Method::Reference) {
        assert_eq!(r.error.unresolved, 0.0, "{}", r.method);
        if r.fallback_share > 0.0 {
            assert!(r.fallback_ns.median > 0.0, "{}", r.method);
            assert!(
                r.total_ns.median >= r.trace_ns.median + r.fallback_ns.median,
                "{}",
                r.method
            );
        }
        // Methods that leave no pixel unresolved get no fallback pass.
        if matches!(r.kind, Method::Envmap | Method::Bvh) {
            assert_eq!(r.fallback_ns.median, 0.0, "{}", r.method);
        }
    }
    let bvh = report
        .runs
        .iter()
        .find(|r| r.kind == Method::Bvh)
        .expect("bvh row");
    assert_eq!(bvh.fallback_share, 0.0);
    assert!(bvh.error.same_triangle >= 0.999, "{:?}", bvh.error);
    // Negative: the cubemap paths at cube size 32 do leave pixels to the fallback.
    assert!(
        report
            .runs
            .iter()
            .any(|r| r.kind == Method::Compute && r.fallback_share > 0.0)
    );
    let refr = &report.runs[0];
    assert_eq!(refr.kind, Method::Reference);
    assert!(refr.rays > 50 && refr.rays == refr.mirror_pixels);
    assert!(refr.trace_ns.median > 0.0 && refr.trace_ns.median <= refr.total_ns.median);
    // The floor is measured for each method's default setting only.
    for r in report.runs[1..]
        .iter()
        .filter(|r| r.method != "reflection-point-sub2" && !r.method.contains("-centre"))
    {
        let f = r
            .floor
            .unwrap_or_else(|| panic!("{}: no floor run", r.method));
        assert_eq!((f.width, f.height), bench::FLOOR_FRAME);
        assert!(
            f.rays < r.rays,
            "{}: the small frame has fewer rays",
            r.method
        );
        assert!(f.ratio > 0.0 && f.ratio.is_finite());
        assert!(r.ns_per_ray > 0.0);
    }
    let [ratios] = report.ratios.as_slice() else {
        panic!("one scene, one row: {:?}", report.ratios)
    };
    let (Some(c), Some(fr), Some(rf)) = (
        ratios.ns_per_ray(Method::Compute),
        ratios.ns_per_ray(Method::Fragment),
        ratios.ns_per_ray(Method::Reference),
    ) else {
        panic!("missing per-ray cost: {ratios:?}")
    };
    assert_eq!(
        ratios.ratio(Method::Compute, Method::Reference),
        Some(c / rf)
    );
    assert_eq!(
        ratios.ratio(Method::Compute, Method::Fragment),
        Some(c / fr)
    );
    let files = bench::report::write(&report, out.path()).expect("write");
    let md = std::fs::read_to_string(&files[1]).expect("bench.md");
    assert!(md.contains("## Cost per ray") && md.contains("| sphere-room | "));
    // One point per scene and method in the per-scene plot, without a Pareto front (the scenes
    // differ); the pooled plot has one.
    let scenes_svg = std::fs::read_to_string(&files[3]).expect("speed-error-scenes.svg");
    assert!(scenes_svg.contains("compute: sphere-room") && scenes_svg.contains("ssr: sphere-room"));
    assert!(!scenes_svg.contains("Pareto front"));
    let pooled_svg = std::fs::read_to_string(&files[2]).expect("speed-error.svg");
    assert!(pooled_svg.contains("Pareto front") && !pooled_svg.contains(": sphere-room"));
    let json = std::fs::read_to_string(&files[0]).expect("bench.json");
    let json: serde_json::Value = serde_json::from_str(&json).expect("bench.json is JSON");
    // Within a rounding of the text (serde_json's parsing is not exactly round trip).
    let near = |v: &serde_json::Value, x: f64| {
        v.as_f64().is_some_and(|v| (v - x).abs() <= 1e-12 * x.abs())
    };
    let pairs = json["ratios"][0]["ratios"]
        .as_array()
        .expect("ratios[0].ratios");
    assert!(
        pairs.iter().any(|p| p["method"] == "compute"
            && p["over"] == "reference"
            && near(&p["ratio"], c / rf)),
        "{pairs:?}"
    );
    let costs = json["ratios"][0]["methods"]
        .as_array()
        .expect("ratios[0].methods");
    assert!(
        costs
            .iter()
            .any(|m| m["method"] == "compute" && near(&m["ns_per_ray"], c)),
        "{costs:?}"
    );

    // Without the floor runs, no floor figure is reported.
    let cfg = BenchConfig {
        methods: bench::method_grid(&[Method::Envmap], true),
        floor: None,
        ..cfg
    };
    let report = bench::run(&ctx, &cfg, &indicatif::ProgressBar::hidden()).expect("bench");
    assert!(report.runs.iter().all(|r| r.floor.is_none()));
    assert_eq!(report.ratios[0].ns_per_ray(Method::Compute), None);
    cubetrace::render::check_validation(&ctx).expect("validation");
    common::finish_gpu(ctx);
}

/// `--scaling`'s triangle axis runs the cubemap paths and bvh side by side at every point.
#[test]
fn scaling_triangle_axis_sets_bvh_beside_the_cubemap_paths() {
    use cubetrace::bench::scaling::{self, Axis, ScalingConfig};
    let ctx = common::gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let cfg = ScalingConfig {
        method: bench::MethodSpec::centre(Method::Fragment),
        axes: vec![Axis::Triangles],
        max_cube: 32,
        width: 24,
        height: 18,
        frames: 1,
        warmup: 0,
        out: out.path().to_path_buf(),
        tessellation_series: Vec::new(),
        tessellation_levels: 0,
    };
    let report = scaling::run(&ctx, &cfg, &indicatif::ProgressBar::hidden()).expect("scaling");
    let methods: Vec<&str> = report.points.iter().map(|p| p.method.as_str()).collect();
    for m in ["fragment-centre-mip", "compute-centre", "bvh"] {
        assert_eq!(
            methods.iter().filter(|x| **x == m).count(),
            4,
            "{m}: {methods:?}"
        );
    }
    let table = scaling::table(&report);
    assert!(
        table.contains("| triangles | ") && table.contains(" bvh "),
        "{table}"
    );
    let files = scaling::write(&report, out.path()).expect("write");
    let svg = std::fs::read_to_string(files.last().unwrap()).unwrap();
    assert!(
        svg.contains("bvh bvh_trace"),
        "one series per method and pass"
    );
    common::finish_gpu(ctx);
}

/// `--bounces` in the bench: the reference and the GPU methods trace N reflections and are
/// compared on each path's last hit; a method that traces one only is skipped. Negative: the
/// same GPU frame against a one-bounce reference is not exact.
#[test]
fn bench_with_bounces() {
    let ctx = common::gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let cfg = BenchConfig {
        scenes: vec!["teapot".into()],
        methods: bench::method_grid(&[Method::Reference, Method::Envmap, Method::Bvh], true),
        width: 48,
        height: 36,
        frames: 1,
        warmup: 0,
        flip: false,
        heatmaps: false,
        floor: None,
        bounces: 3,
        out: out.path().to_path_buf(),
        ..BenchConfig::default()
    };
    let report = bench::run(&ctx, &cfg, &indicatif::ProgressBar::hidden()).expect("bench");
    let kinds: Vec<Method> = report.runs.iter().map(|r| r.kind).collect();
    assert_eq!(kinds, [Method::Reference, Method::Bvh]);
    assert_eq!(report.bounces, 3);
    assert!(bench::report::header(&report).contains("3 bounces"));
    let bvh = &report.runs[1].error;
    assert!(bvh.same_triangle >= 0.99 && bvh.psnr_db >= 45.0, "{bvh:?}");
    // Negative: one bounce for the reference (the teapot's spout and handle reflect twice).
    let (scene, camera) = bench::prepare_scene("teapot", 48, 36, None, None).expect("scene");
    let refr1 = bench::run_reference(&scene, &camera, 0, 1);
    let options = cubetrace::vk::frame::RenderOptions {
        method: cubetrace::Method::Bvh,
        bounces: 3,
        ..Default::default()
    };
    let g = bench::run_gpu_with(&ctx, &scene, &camera, options, 0, 1).expect("gpu");
    let e = cubetrace::metrics::compare(
        &refr1.frame,
        &g.frame.traced(),
        &g.frame.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    );
    assert!(e.same_triangle < bvh.same_triangle, "{e:?} against {bvh:?}");
    cubetrace::render::check_validation(&ctx).expect("validation");
    common::finish_gpu(ctx);
}

/// `bench` refuses for memory what `render` refuses: both hold the one estimate
/// (`vk::budget::estimate`: CMOs, frame, bounce queues, reflector check) against the same
/// limits. Each case is a command line and the same with one queue added (the bounce queues of
/// `--bounces 3`, the reflector check's queue on the torus, which the CMOs do not capture); the
/// device limit sits halfway into that queue, so only the queue pushes the run over: with it
/// both commands refuse, without it both accept. No device is made: the checks are arithmetic
/// on the parsed command lines, with the limits given instead of read from the machine.
#[test]
fn bench_refuses_what_render_refuses_for_memory() {
    use clap::Parser;
    use cubetrace::app::{bench::BenchArgs, render::RenderArgs};
    use cubetrace::memory::Limits;
    use cubetrace::vk::budget;

    #[derive(Parser)]
    struct Render {
        #[command(flatten)]
        args: RenderArgs,
    }
    #[derive(Parser)]
    struct Bench {
        #[command(flatten)]
        args: BenchArgs,
    }
    let (w, h) = (1024, 768);
    let size = ["--width", "1024", "--height", "768"];
    let render_args = |scene: &str, extra: &[&str]| {
        let mut a = vec!["render", scene];
        a.extend(size.iter().chain(extra));
        Render::try_parse_from(a).expect("render arguments").args
    };
    // `render`'s verdict, by the steps the command takes.
    let render = |scene: &str, extra: &[&str], limits: &Limits| {
        let args = render_args(scene, extra);
        let (scene, camera, _) = app::render::load_scene(&args).expect("scene");
        let options = app::render::gpu_options(&args).expect("options");
        let what = format!("a {w}x{h} frame with --method {}", args.method);
        cubetrace::render::checks::check_gpu_memory(
            &what,
            &scene,
            &camera,
            &options,
            cubetrace::output::Format::Png,
            false,
            "the test device",
            limits,
        )
    };
    // `bench --methods compute`'s verdict, by the steps the command takes.
    let bench = |scene: &str, extra: &[&str], limits: &Limits| {
        let mut a = vec!["bench", "--scenes", scene, "--methods", "compute"];
        a.extend(size.iter().chain(extra));
        let args = Bench::try_parse_from(a).expect("bench arguments").args;
        let methods = app::bench::parse_methods(&args.methods).expect("methods");
        let cfg = app::bench::grid_config(&args, &methods);
        let prepared: Vec<_> = cfg
            .scenes
            .iter()
            .map(|s| bench::prepare_scene(s, cfg.width, cfg.height, cfg.cube_size, cfg.cmos))
            .collect::<Result<_, _>>()
            .expect("scenes");
        bench::check_memory(&cfg, &prepared, limits)
    };
    let cases: [(&str, &[&str], &[&str], u64); 2] = [
        (
            "bowl",
            &["--bounces", "3"],
            &["--bounces", "1"],
            budget::bounce_bytes(w, h, 3),
        ),
        (
            "torus",
            &[],
            &["--no-reflector-check"],
            budget::reflector_check_bytes(w, h, true),
        ),
    ];
    for (scene, with, without, queue) in cases {
        assert!(queue > 0, "{scene}: the queue costs memory");
        // The limit: the run without the queue, plus half the queue.
        let args = render_args(scene, without);
        let (s, camera, _) = app::render::load_scene(&args).expect("scene");
        let options = app::render::gpu_options(&args).expect("options");
        let fits = budget::estimate(&s, &camera, &options).total();
        let limits = Limits {
            host: None,
            device: (fits + queue / 2, "the test's limit".into()),
            device_is_host: false,
        };
        let r = render(scene, with, &limits).expect_err("render refuses with the queue");
        let b = bench(scene, with, &limits).expect_err("bench refuses with the queue");
        let (r, b) = (r.to_string(), b.to_string());
        assert!(
            r.contains("--method compute") && r.contains("the test's limit"),
            "{r}"
        );
        assert!(
            b.contains(&format!("bench scene '{scene}' at {w}x{h}"))
                && b.contains("the test's limit"),
            "{b}"
        );
        // Negative: without the queue both accept under the same limit.
        render(scene, without, &limits).expect("render accepts without the queue");
        bench(scene, without, &limits).expect("bench accepts without the queue");
    }
}

/// `bench --sequence`: per method, the capture runs once with reuse (the first frame) and on
/// every frame with recapture; a method that reads no cube map (bvh) never captures. The
/// counts come from the frames (`GpuFrame::captured`), not from the mode.
#[test]
fn sequence_rows_count_the_captures_of_each_mode() {
    use cubetrace::bench::sequence::{self, Mode};
    let ctx = common::gpu_context();
    let mut scene = cubetrace::scene::load("sphere-room-orbit").expect("built-in");
    scene.cmo.resolution = 32;
    let frames = [1, 2, 3, 4];
    let report = sequence::run(
        &ctx,
        &scene,
        &[Method::Reference, Method::Compute, Method::Bvh],
        (32, 24),
        &frames,
        &|| {},
    )
    .expect("sequence bench");
    let rows: Vec<(&str, Mode, usize, usize)> = report
        .rows
        .iter()
        .map(|r| (r.method.as_str(), r.mode, r.frames, r.captured))
        .collect();
    // The reference is no GPU method: no row.
    assert_eq!(
        rows,
        [
            ("compute", Mode::Reuse, 4, 1),
            ("compute", Mode::Recapture, 4, 4),
            ("bvh", Mode::Reuse, 4, 0),
            ("bvh", Mode::Recapture, 4, 0),
        ]
    );
    assert!(report.rows.iter().all(|r| r.frames_per_minute > 0.0));
    let md = sequence::table(&report);
    assert!(md.contains("| compute | recapture | 4 | 4 |"), "{md}");
}

/// `--placement`: every scene runs once per placement, labelled `NAME [placement]`, and the
/// placement table sets CMOs, the search's time, the capture and the frame against `bvh`'s and
/// the fallback side by side. On the corpus's open mug the search leaves less to the fallback
/// than the scene's own centre (measured at 48x36, cube 32: 0.0 % against 99 %); the search's
/// time stands only on its own rows.
#[test]
fn placement_axis_sets_the_search_beside_the_scenes_centres() {
    let ctx = common::gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let mug = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/scenes/mug/scene.toml");
    let cfg = BenchConfig {
        scenes: vec![mug.into()],
        // The centre criterion, whose fallback share follows the placement (the default,
        // bounded, leaves none of the mug's rays with either placement).
        methods: vec![
            bench::MethodSpec::centre(Method::Compute),
            bench::MethodSpec::plain(Method::Bvh),
        ],
        width: 48,
        height: 36,
        frames: 1,
        warmup: 0,
        cube_size: Some(32),
        placements: vec![bench::BenchPlacement::Scene, bench::BenchPlacement::Auto],
        flip: false,
        heatmaps: false,
        floor: None,
        out: out.path().to_path_buf(),
        ..BenchConfig::default()
    };
    let report = bench::run(&ctx, &cfg, &indicatif::ProgressBar::hidden()).expect("bench");
    let row = |placement: &str, method: Method| {
        report
            .runs
            .iter()
            .find(|r| r.scene == format!("{mug} [{placement}]") && r.kind == method)
            .unwrap_or_else(|| panic!("no {placement} {method} row"))
    };
    let (own, searched) = (row("scene", Method::Compute), row("auto", Method::Compute));
    eprintln!(
        "fallback: scene {:.3}, auto {:.3} with {} CMOs in {:?} ms",
        own.fallback_share, searched.fallback_share, searched.cmos, searched.placement_ms
    );
    assert!(
        searched.fallback_share < 0.05,
        "{}",
        searched.fallback_share
    );
    assert!(own.fallback_share > 0.5, "{}", own.fallback_share);
    assert!(searched.placement_ms.is_some() && own.placement_ms.is_none());
    assert!(row("auto", Method::Bvh).placement_ms.is_none());
    let table = bench::report::placement_table(&report);
    assert!(
        table.contains("## CMO placement")
            && table.contains(&format!("| {mug} [auto] | compute-centre |")),
        "{table}"
    );
    // Negative: one placement and no search (the scene's own centres) adds no table.
    let one = bench::BenchReport {
        runs: vec![own.clone()],
        ..report.clone()
    };
    let mut plain = one.runs[0].clone();
    plain.scene = mug.into();
    let one = bench::BenchReport {
        runs: vec![plain],
        ..one
    };
    assert_eq!(bench::report::placement_table(&one), "");
    cubetrace::render::check_validation(&ctx).expect("validation");
    common::finish_gpu(ctx);
}

/// With `--bounces N > 1` the grid sets compute's later reflections through its cube maps beside
/// the same runs with the BVH tracing them (`-bvh-bounces`), and the report's "Bounce rounds"
/// table gives each round's rays, what traced them and the fallback's share. The second round
/// starts from the same first round, so it queues the same rays either way; the default pair
/// (bounded) is exact, so every round matches. Negatives: at one bounce the grid has no such row and the
/// report no rounds, and the BVH's rounds leave nothing to the fallback.
#[test]
fn bench_sets_the_bounce_rounds_through_the_cube_maps_beside_the_bvhs() {
    use clap::Parser;
    #[derive(Parser)]
    struct Bench {
        #[command(flatten)]
        args: app::bench::BenchArgs,
    }
    let grid = |bounces: &str| {
        let a = [
            "bench",
            "--methods",
            "compute,bvh",
            "--quick",
            "--bounces",
            bounces,
        ];
        let args = Bench::try_parse_from(a).expect("bench arguments").args;
        let methods = app::bench::parse_methods(&args.methods).expect("methods");
        app::bench::grid_config(&args, &methods).methods
    };
    let labels = |specs: &[bench::MethodSpec]| -> Vec<String> {
        specs.iter().map(bench::MethodSpec::label).collect()
    };
    let three = grid("3");
    assert_eq!(
        labels(&three),
        [
            "compute",
            "compute-bvh-bounces",
            "compute-centre",
            "compute-centre-bvh-bounces",
            "bvh"
        ]
    );
    assert_eq!(labels(&grid("1")), ["compute", "compute-centre", "bvh"]);
    let ctx = common::gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let cfg = |bounces: u32, methods| small_teapot(out.path(), methods, bounces);
    let hidden = indicatif::ProgressBar::hidden();
    let report = bench::run(&ctx, &cfg(3, three), &hidden).expect("bench");
    let run = |label: &str| {
        (report.runs.iter())
            .find(|r| r.method == label)
            .unwrap_or_else(|| panic!("no run {label}"))
    };
    for (cubes, bvh) in [
        ("compute", "compute-bvh-bounces"),
        ("compute-centre", "compute-centre-bvh-bounces"),
    ] {
        let (c, b) = (&run(cubes).rounds, &run(bvh).rounds);
        eprintln!("{cubes}: {c:?}; {bvh}: {b:?}");
        assert_eq!((c.len(), b.len()), (2, 2), "{cubes}");
        assert!(c.iter().all(|r| r.method) && b.iter().all(|r| !r.method));
        assert!(b.iter().all(|r| r.fallback == 0), "{bvh}");
        assert!(c[0].rays > 0 && c[0].rays == b[0].rays, "{cubes}");
    }
    let (c, b) = (run("compute"), run("compute-bvh-bounces"));
    assert_eq!(
        c.rounds,
        b.rounds
            .iter()
            .map(|r| RoundCount { method: true, ..*r })
            .collect::<Vec<_>>()
    );
    assert_eq!(c.error.wrong_surface, 0.0);
    assert!(run("bvh").rounds.iter().all(|r| !r.method));
    let table = bench::report::rounds_table(&report);
    assert!(table.contains("| teapot | compute | ") && table.contains("cube maps"));
    assert!(table.contains("| teapot | compute-bvh-bounces | ") && table.contains(" BVH "));
    // Negative: one bounce has no rounds to show.
    let one = bench::run(&ctx, &cfg(1, grid("1")), &hidden).expect("bench");
    assert!(one.runs.iter().all(|r| r.rounds.is_empty()));
    assert!(bench::report::rounds_table(&one).is_empty());
    common::finish_gpu(ctx);
}

/// A bench of `methods` on the teapot at 48x36 with 32-texel faces, one frame, no floor run,
/// FLIP or heat maps, at `bounces`, writing into `out`.
fn small_teapot(
    out: &std::path::Path,
    methods: Vec<bench::MethodSpec>,
    bounces: u32,
) -> BenchConfig {
    BenchConfig {
        scenes: vec!["teapot".into()],
        methods,
        width: 48,
        height: 36,
        frames: 1,
        warmup: 0,
        cube_size: Some(32),
        flip: false,
        heatmaps: false,
        floor: None,
        bounces,
        out: out.to_path_buf(),
        ..BenchConfig::default()
    }
}

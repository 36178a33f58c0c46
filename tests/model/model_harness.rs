//! The cost model's harness: SPIR-V block weights, the validation split,
//! and `bench --model`'s JSON. Tiny: one 16x12 frame where the device runs; no speed asserted.

use crate::common::spirv_words::inst;
use std::path::Path;
use std::process::Command;

use cubetrace::method::Method;
use cubetrace::model::validate::{self, Measured, Modelled, Training};
use cubetrace::model::weights::{self, ShaderFunctions};
use cubetrace::model::work::{Block, blocks};

const MODELLED: [Method; 5] = [
    Method::Compute,
    Method::Fragment,
    Method::Ssr,
    Method::ReflectionPoint,
    Method::Bvh,
];

/// Positive, and not all the same (a weight table of one repeated number would be no weight).
fn check_weights(w: &[f64]) -> Result<(), String> {
    if let Some(x) = w.iter().find(|x| x.is_nan() || **x <= 0.0) {
        return Err(format!("weight {x} is not positive"));
    }
    let first = w.first().copied().unwrap_or(0.0);
    if w.len() > 1 && w.iter().all(|x| *x == first) {
        return Err(format!("all {} weights equal {first}", w.len()));
    }
    Ok(())
}

#[test]
fn weights_are_positive_and_differ_between_blocks() {
    for m in MODELLED {
        let w = weights::weights(m).unwrap_or_else(|e| panic!("{}: {e:#}", m.name()));
        assert_eq!(w.len(), blocks(m).len(), "{}", m.name());
        let named: Vec<String> = blocks(m)
            .iter()
            .zip(&w)
            .map(|(b, w)| format!("{}={w}", b.name))
            .collect();
        eprintln!("{}: {}", m.name(), named.join(" "));
        check_weights(&w).unwrap_or_else(|e| panic!("{}: {e}", m.name()));
    }
    // Negative: the same function named by every block gives equal weights, which the check
    // refuses; a zero weight is refused too.
    let b = blocks(Method::Compute)[0];
    let same = [b, Block { name: "copy", ..b }];
    let w = weights::block_weights(&same).unwrap();
    assert!(check_weights(&w).is_err(), "{w:?}");
    assert!(check_weights(&[3.0, 0.0]).is_err());
}

#[test]
fn a_wrong_function_name_is_a_clear_error() {
    let good = blocks(Method::Bvh)[0];
    let bad = Block {
        name: "bogus_block",
        shader: good.shader,
        functions: &["no_such_function"],
    };
    let e = format!("{:#}", weights::block_weights(&[bad]).unwrap_err());
    assert!(
        e.contains("no_such_function") && e.contains("bogus_block") && e.contains(good.shader),
        "{e}"
    );
    let e = format!(
        "{:#}",
        weights::block_weights(&[Block {
            shader: "nope.wgsl",
            ..good
        }])
        .unwrap_err()
    );
    assert!(e.contains("nope") && e.contains("bvh_trace"), "{e}");
}

#[test]
fn callees_count_unless_another_block_names_them() {
    // `ssr_trace` calls the iteration's functions; excluded, they no longer count.
    let sh = ShaderFunctions::of("ssr.wgsl").unwrap();
    let alone = sh.expanded("ssr_trace", &Default::default()).unwrap();
    let excluded: std::collections::BTreeSet<&str> =
        ["hiz_at", "cell_of", "on_screen", "cross_cell"].into();
    let less = sh.expanded("ssr_trace", &excluded).unwrap();
    assert!(less < alone, "{less} !< {alone}");
    assert!(sh.names().any(|n| n == "ssr_trace"));
}

#[test]
fn the_debug_copy_is_the_shipped_code_plus_names() {
    // ShaderFunctions::of checks it; every modelled shader loads.
    for m in MODELLED {
        for b in blocks(m) {
            ShaderFunctions::of(b.shader).unwrap_or_else(|e| panic!("{}: {e:#}", b.shader));
        }
    }
    // Negative: a changed instruction no longer strips to the shipped words.
    let pass = cubetrace::vk::backend::shaders::PASSES
        .iter()
        .find(|p| p.name == "bvh_trace")
        .unwrap();
    let mut words = pass.spirv.to_vec();
    assert_eq!(weights::strip_debug(&words).unwrap(), words);
    let last = words.len() - 2;
    words[last] ^= 1;
    assert_ne!(weights::strip_debug(&words).unwrap(), pass.spirv);
}

/// A row with 100 model rays of `vector` vector instructions and `lane` lane operations each.
fn row_of(
    scene: &str,
    method: Method,
    cube: u32,
    subgroup: u32,
    ns: f64,
    t: &Training,
    (vector, lane): (f64, f64),
) -> Modelled {
    let measured = Measured {
        scene: scene.into(),
        method,
        cube,
        subgroup,
        width: 16,
        height: 12,
        rays: 100,
        pass_ns: ns,
        repeats: vec![ns],
        threads: 2,
    };
    Modelled {
        train: t.contains(&measured),
        measured,
        cost_per_ray: 10.0,
        vector_per_ray: vector,
        lane_per_ray: lane,
        vector_blocks: vec![vector, 0.0],
        lane_blocks: vec![0.0, lane],
        model_rays: 100,
        blocks: vec!["a".into(), "b".into()],
        shares: vec![0.5, 0.5],
        simd_efficiency: 1.0,
        imbalance: 1.0,
    }
}

/// The work of [`validate::split`] for 2 warp-steps per ray of a block of 10 instructions, 3 of
/// them lane operations, at `subgroup` lanes (vector: 2 x 7 x registers; lane: 2 x 3 x lanes).
fn work_at(subgroup: u32) -> (f64, f64) {
    match subgroup {
        4 => (14.0, 24.0),
        8 => (14.0, 48.0),
        16 => (28.0, 96.0),
        _ => unreachable!(),
    }
}

fn row(scene: &str, method: Method, cube: u32, subgroup: u32, ns: f64, t: &Training) -> Modelled {
    row_of(scene, method, cube, subgroup, ns, t, work_at(subgroup))
}

#[test]
fn the_validation_split_is_disjoint_and_the_fit_reads_training_rows_only() {
    let t = Training::standard();
    let mut rows = vec![
        row("default", Method::Compute, 256, 8, 4000.0, &t),
        row("default", Method::Fragment, 256, 8, 6000.0, &t),
        row("default", Method::Compute, 64, 8, 3000.0, &t),
        row("default", Method::Compute, 256, 4, 5000.0, &t),
        row("bowl", Method::Compute, 256, 8, 7000.0, &t),
        row("bowl", Method::Fragment, 64, 8, 2000.0, &t),
    ];
    // The standard rule trains on scene default at every cube and subgroup size.
    assert_eq!(
        rows.iter().map(|r| r.train).collect::<Vec<_>>(),
        [true, true, true, true, false, false]
    );
    let v = validate::validate(&rows, &t).unwrap();
    let held: Vec<&str> = v
        .rows
        .iter()
        .filter(|r| !r.train)
        .map(|r| r.key.as_str())
        .collect();
    assert_eq!(v.training_rows.len(), 4, "{:?}", v.training_rows);
    assert_eq!(held.len(), 2);
    assert!(v.training_rows.iter().all(|k| !held.contains(&k.as_str())));
    // A held-out row changed tenfold leaves the scale as it was ...
    let fits = |r: &[Modelled]| {
        [None, Some(Method::Compute), Some(Method::Fragment)].map(|m| validate::fit(r, m).unwrap())
    };
    let global = validate::fit(&rows, None).unwrap();
    let all = fits(&rows);
    let held_out: Vec<usize> = (0..rows.len()).filter(|i| !rows[*i].train).collect();
    assert_eq!(held_out.len(), 2);
    for &i in &held_out {
        let mut r = rows.clone();
        r[i].measured.pass_ns *= 10.0;
        assert_eq!(fits(&r), all, "row {i}");
        assert_eq!(
            validate::validate(&r, &t).unwrap().coefficients,
            v.coefficients,
            "row {i}"
        );
    }
    // bvh has no training row here: its coefficients cannot be fitted, and says so.
    let e = validate::fit(&rows, Some(Method::Bvh)).unwrap_err();
    assert!(format!("{e}").contains("--method bvh"), "{e}");
    // ... and a training row changed moves them (the negative: the check can fail).
    rows[0].measured.pass_ns *= 10.0;
    assert_ne!(validate::fit(&rows, None).unwrap(), global);
    // A row marked training against the rule is refused.
    rows[4].train = true;
    let e = format!("{:#}", validate::validate(&rows, &t).unwrap_err());
    assert!(e.contains("bowl/compute/cube256/sg8"), "{e}");
}

fn cli(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_cubetrace"))
        .args(args)
        .env("XDG_RUNTIME_DIR", "/tmp")
        .output()
        .expect("run cubetrace")
}

/// A tiny `bench` run of `methods` on `scenes` into `dir` (16x12, one frame, cube 32), with
/// `extra` arguments; its bench.json.
fn bench_run(dir: &Path, scenes: &str, methods: &str, extra: &[&str]) -> serde_json::Value {
    let out = dir.to_str().unwrap();
    let mut args = vec![
        "bench",
        "--scenes",
        scenes,
        "--methods",
        methods,
        "--width",
        "16",
        "--height",
        "12",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--cube-size",
        "32",
        "--no-flip",
        "--no-heatmaps",
        "--no-floor",
        "-o",
        out,
    ];
    args.extend_from_slice(extra);
    let o = cli(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_str(&std::fs::read_to_string(dir.join("bench.json")).unwrap()).unwrap()
}

fn bench(dir: &Path, model: bool) -> serde_json::Value {
    let extra: &[&str] = if model { &["--model"] } else { &[] };
    bench_run(dir, "default,bowl", "compute,bvh", extra)
}

#[test]
fn bench_model_json_has_the_columns() {
    let d = tempfile::tempdir().unwrap();
    let v = bench(d.path(), true);
    let m = &v["model"];
    let rows = m["lavapipe"]["rows"]
        .as_array()
        .expect("model.lavapipe.rows");
    assert!(rows.len() >= 4, "{rows:?}");
    for r in rows {
        for k in [
            "measured_ns_per_ray",
            "predicted_ns_per_ray",
            "error",
            "simd_efficiency",
        ] {
            assert!(r[k].is_number(), "{k} in {r}");
        }
    }
    assert!(
        rows.iter()
            .any(|r| r["train"] == false && r["scene"] == "bowl")
    );
    assert!(m["lavapipe"]["global"]["vector_ns"].as_f64().unwrap() >= 0.0);
    assert!(m["lavapipe"]["global"]["lane_ns"].as_f64().unwrap() >= 0.0);
    let widths: Vec<u64> = m["gpu"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["width"].as_u64().unwrap())
        .collect();
    assert!(widths.contains(&32) && widths.contains(&64), "{widths:?}");
    let g = &m["gpu"][0];
    // The ratios, keyed by method and layout: static and dynamic weights, compute's thesis and
    // one-lane layouts too.
    let ratios = g["ratios"].as_array().expect("gpu[0].ratios");
    for (method, layout, over) in [
        ("compute", "auto", "bvh"),
        ("compute", "auto", "fragment"),
        ("fragment", "auto", "bvh"),
        ("compute", "thesis", "bvh"),
        ("compute", "one", "bvh"),
    ] {
        let r = ratios
            .iter()
            .find(|r| r["method"] == method && r["layout"] == layout && r["over"] == over)
            .unwrap_or_else(|| panic!("{method} ({layout}) over {over} in {g}"));
        assert!(r["ratio"].is_number() && r["dynamic"].is_number(), "{r}");
    }
    assert!(g["methods"][0]["sectors_per_ray"].is_number());
    // Per-ray work beside bvh: static and dynamic weighted steps, the dominant block.
    for k in ["cost_per_ray", "dynamic_cost_per_ray", "dominant_share"] {
        assert!(g["methods"][0][k].is_number(), "{k} in {g}");
    }
    assert!(g["methods"][0]["dominant_block"].is_string());
    assert!(
        g["methods"]
            .as_array()
            .unwrap()
            .iter()
            .any(|m| m["method"] == "compute" && m["layout"] == "thesis"),
        "{g}"
    );
    assert!(
        m["lavapipe_dynamic"]["rows"]
            .as_array()
            .is_some_and(|r| r.len() == rows.len())
    );
    assert!(m["triangles"].as_array().is_some_and(|t| !t.is_empty()));
    assert!(
        m["triangles"][0]["ratios"][0]["ratio"].is_number(),
        "{}",
        m["triangles"]
    );
    assert!(
        m["overtakes"]
            .as_array()
            .is_some_and(|o| o.iter().any(|c| c["method"] == "compute")),
        "{}",
        m["overtakes"]
    );
    assert!(m["assumptions"][0].as_str().unwrap().contains("MODEL"));
    let md = std::fs::read_to_string(d.path().join("bench.md")).unwrap();
    assert!(md.contains("## Cost model"), "{md}");
    assert!(md.contains("per-ray work at width 32"), "{md}");
    assert!(d.path().join("model.svg").is_file());
    // Negative: without --model, none of it.
    let d2 = tempfile::tempdir().unwrap();
    let v2 = bench(d2.path(), false);
    assert!(v2.get("model").is_none());
    assert!(!d2.path().join("model.svg").exists());
}

#[test]
fn model_from_a_bad_file_names_the_field() {
    let d = tempfile::tempdir().unwrap();
    let f = d.path().join("bench.json");
    std::fs::write(&f, r#"{"device": {}, "runs": []}"#).unwrap();
    let out = d.path().join("out");
    let o = cli(&[
        "bench",
        "--model",
        "--model-from",
        f.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("device.subgroup_size") && e.contains("bench.json"),
        "{e}"
    );
    assert!(!out.join("model.json").exists());
    // A file without the driver's thread count (nor the bench's) names the field.
    let g = d.path().join("one.json");
    std::fs::write(
        &g,
        r#"{"device": {"subgroup_size": 8}, "runs": [{"scene": "default", "method": "bvh",
            "cube_size": 256, "width": 16, "height": 12, "rays": 10,
            "trace_ns": {"median": 1000.0}}]}"#,
    )
    .unwrap();
    let o = cli(&[
        "bench",
        "--model",
        "--model-from",
        g.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("driver_threads"), "{e}");
    // --model-from alone is refused by the parser (it needs --model).
    let o = cli(&["bench", "--model-from", f.to_str().unwrap()]);
    assert!(!o.status.success());
}

/// The lane term's arithmetic (`validate::split`): per warp-step a block's vector instructions
/// cost one per 256-bit register the lanes fill (1 at 4 and 8 lanes, 2 at 16), its lane
/// operations one per lane. The expected numbers are worked by hand in `work_at`.
#[test]
fn the_lane_term_prices_vectors_per_register_and_lane_operations_per_lane() {
    assert_eq!(
        [4, 8, 16, 32].map(validate::registers),
        [1, 1, 2, 4],
        "256-bit registers per 32-bit vector"
    );
    for w in [4, 8, 16] {
        let (v, l) = validate::split(&[2.0, 0.0], &[10.0, 99.0], &[3.0, 9.0], w);
        assert_eq!((v.iter().sum(), l.iter().sum()), work_at(w), "width {w}");
    }
    // Negative: one lane operation more per step moves the lane part at every width.
    let (_, l) = validate::split(&[2.0], &[10.0], &[4.0], 8);
    assert_ne!(l[0], work_at(8).1);
}

/// Rows made from known coefficients (2 ns per vector instruction, 5 per lane operation) at
/// subgroups 4, 8 and 16: the fit recovers them and predicts a held-out row exactly. Negative:
/// the 16-lane row at half its time (what a fixed time per warp-step would predict) does not
/// fit them.
#[test]
fn the_fit_recovers_known_coefficients_across_subgroup_sizes() {
    let t = Training::standard();
    let ns = |w: u32| {
        let (v, l) = work_at(w);
        (2.0 * v + 5.0 * l) * 100.0
    };
    let mut rows: Vec<Modelled> = [4, 8, 16]
        .map(|w| row("default", Method::Compute, 256, w, ns(w), &t))
        .to_vec();
    rows.push(row("torus", Method::Compute, 512, 16, 1.0, &t));
    let c = validate::fit(&rows, Some(Method::Compute)).unwrap();
    assert!(!c.one_width);
    assert!(
        (c.vector_ns - 2.0).abs() < 1e-9 && (c.lane_ns - 5.0).abs() < 1e-9,
        "{c:?}"
    );
    let v = validate::validate(&rows, &t).unwrap();
    let torus = v.rows.iter().find(|r| !r.train).unwrap();
    assert!((torus.predicted_ns_per_ray - (2.0 * 28.0 + 5.0 * 96.0)).abs() < 1e-9);
    rows[2].measured.pass_ns /= 2.0;
    let c2 = validate::fit(&rows, Some(Method::Compute)).unwrap();
    assert!(
        (c2.vector_ns - 2.0).abs() > 0.2 || (c2.lane_ns - 5.0).abs() > 0.5,
        "{c2:?}"
    );
}

/// A hand-made module: function `f` loads and stores through a storage-buffer pointer, loads a
/// function-local variable, a private array at a constant and at a per-lane index, adds, and
/// ballots. `dynamic_index` and `storage_class` are what the negatives change.
fn module(dynamic_index: u32, storage_class: u32) -> Vec<u32> {
    let mut w = vec![0x0723_0203, 0x0001_0300, 0, 100, 0];
    w.extend(inst(5, &[10, u32::from_le_bytes(*b"f\0\0\0")])); // OpName %10 "f"
    w.extend(inst(32, &[2, storage_class, 1])); // OpTypePointer %2
    w.extend(inst(32, &[3, 7, 1])); // Function
    w.extend(inst(32, &[4, 6, 1])); // Private
    w.extend(inst(43, &[1, 6, 0])); // OpConstant %6 = 0
    w.extend(inst(59, &[2, 20, storage_class])); // the buffer
    w.extend(inst(59, &[4, 21, 6])); // the private array
    w.extend(inst(54, &[1, 10, 0, 9])); // OpFunction %10
    w.extend(inst(248, &[11])); // OpLabel
    w.extend(inst(59, &[3, 22, 7])); // a local
    w.extend(inst(65, &[2, 30, 20, 6])); // chain into the buffer
    w.extend(inst(61, &[1, 31, 30])); // load from the buffer: lane
    w.extend(inst(61, &[1, 32, 22])); // load of the local: vector
    w.extend(inst(65, &[4, 33, 21, 6])); // private array, constant index
    w.extend(inst(61, &[1, 34, 33])); // vector
    w.extend(inst(65, &[4, 35, 21, dynamic_index])); // private array, index %31 (per lane)
    w.extend(inst(61, &[1, 36, 35])); // lane when the index is not a constant
    w.extend(inst(128, &[1, 37, 34, 36])); // OpIAdd: vector
    w.extend(inst(339, &[1, 38, 3, 37])); // OpGroupNonUniformBallot: lane
    w.extend(inst(62, &[30, 37])); // store to the buffer: lane
    w.extend(inst(253, &[])); // OpReturn
    w.extend(inst(56, &[])); // OpFunctionEnd
    w
}

/// Lane operations counted in SPIR-V: storage accesses, per-lane array indices, subgroup
/// operations; not local or constant-index accesses or arithmetic. Negatives: a constant index
/// instead of the per-lane one, and the buffer in private memory, each count fewer.
#[test]
fn lane_operations_are_counted_from_the_spirv() {
    let count = |words: &[u32]| {
        let f = ShaderFunctions::parse("hand", words).unwrap();
        let none = std::collections::BTreeSet::new();
        (
            f.expanded("f", &none).unwrap(),
            f.expanded_lane("f", &none).unwrap(),
        )
    };
    // 3 chains, 4 loads, the add, the ballot, the store, the return.
    assert_eq!(count(&module(31, 12)), (11, 4));
    assert_eq!(count(&module(6, 12)), (11, 3));
    assert_eq!(count(&module(31, 6)), (11, 2));
    // The shipped shaders: every method has lane operations, fewer than its instructions.
    for m in MODELLED {
        let w = weights::weights(m).unwrap();
        let l = weights::lane_weights(m).unwrap();
        assert_eq!(l.len(), w.len());
        assert!(
            l.iter().zip(&w).all(|(l, w)| l <= w),
            "{}: {l:?} {w:?}",
            m.name()
        );
        let (sl, sw) = (l.iter().sum::<f64>(), w.iter().sum::<f64>());
        eprintln!("{}: {sl} lane operations of {sw} instructions", m.name());
        assert!(sl > 0.0 && sl < sw, "{}", m.name());
    }
}

/// The threads' imbalance (`validate::imbalance`), worked by hand: lavapipe's 2 threads take the
/// items in order, each the next when free. [4, 1, 1, 1, 1]: 4 | 1+1+1+1, evenly split (1.0).
/// [5, 1, 1, 1]: 5 | 3, makespan 5 of 8 (1.25). Negative: the same costs in the other order
/// [1, 1, 1, 5]: 1+1 | 1+5, makespan 6 (1.5), so the order is read. One item: 2.0; one thread:
/// 1.0. A row's predicted time scales with it.
#[test]
fn the_threads_imbalance_is_the_greedy_makespan() {
    assert_eq!(validate::imbalance(&[4.0, 1.0, 1.0, 1.0, 1.0], 2), 1.0);
    assert_eq!(validate::imbalance(&[5.0, 1.0, 1.0, 1.0], 2), 1.25);
    assert_eq!(validate::imbalance(&[1.0, 1.0, 1.0, 5.0], 2), 1.5);
    assert_eq!(validate::imbalance(&[8.0], 2), 2.0);
    assert_eq!(validate::imbalance(&[5.0, 1.0, 1.0, 1.0], 1), 1.0);
    assert_eq!(validate::imbalance(&[], 2), 1.0);
    let t = Training::standard();
    let mut r = row("bowl", Method::Compute, 256, 8, 1000.0, &t);
    let c = validate::Coefficients {
        vector_ns: 1.0,
        lane_ns: 2.0,
        one_width: false,
    };
    let even = c.time(&r);
    r.imbalance = 1.25;
    assert_eq!(c.time(&r), even * 1.25);
}

fn bench_json(dir: &Path, name: &str, rays: u32, median: f64) -> String {
    let p = dir.join(name);
    std::fs::write(
        &p,
        format!(
            r#"{{"device": {{"subgroup_size": 8}}, "driver_threads": 2, "runs": [{{"scene": "default",
            "method": "bvh", "cube_size": 256, "width": 16, "height": 12, "rays": {rays},
            "trace_ns": {{"median": {median}}}}}]}}"#
        ),
    )
    .unwrap();
    p.display().to_string()
}

/// A row in several `--model-from` files is one row measured in several processes: its time is
/// the median of theirs, and the report gives the processes and their spread. Negative: the
/// same row with another ray count (another measurement) is refused, naming the row.
#[test]
fn model_from_merges_a_rows_processes() {
    let d = tempfile::tempdir().unwrap();
    let files = [
        bench_json(d.path(), "a.json", 10, 1000.0),
        bench_json(d.path(), "b.json", 10, 3000.0),
        bench_json(d.path(), "c.json", 10, 2000.0),
    ];
    let rows = cubetrace::bench::model::measured_from_files(
        &files
            .iter()
            .map(std::path::PathBuf::from)
            .collect::<Vec<_>>(),
    )
    .unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].pass_ns, 2000.0);
    assert_eq!(rows[0].repeats, [1000.0, 3000.0, 2000.0]);
    assert_eq!(rows[0].spread(), 3.0);
    assert_eq!(rows[0].threads, 2);
    let out = d.path().join("out");
    let other = bench_json(d.path(), "d.json", 11, 2000.0);
    let o = cli(&[
        "bench",
        "--model",
        "--model-from",
        &format!("{},{other}", files[0]),
        "-o",
        out.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("default/bvh/cube256/sg8") && e.contains("d.json"),
        "{e}"
    );
    assert!(!out.join("model.json").exists());
}

/// `bench --model-rows` runs each method in the setting the model replays alone (the rows
/// --model reads): `compute-centre`, not the default `compute` (bounded), no
/// `reflection-point-sub2`. Negative: without it all three are there. The old name of the flag,
/// `--defaults-only`, still runs the same rows.
#[test]
fn model_rows_runs_the_modelled_settings() {
    let labels = |extra: &[&str]| {
        let d = tempfile::tempdir().unwrap();
        let v = bench_run(d.path(), "default", "compute,reflection-point", extra);
        v["runs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["method"].as_str().unwrap().to_string())
            .collect::<Vec<_>>()
    };
    assert_eq!(
        labels(&["--model-rows"]),
        ["compute-centre", "reflection-point"]
    );
    assert_eq!(
        labels(&["--defaults-only"]),
        ["compute-centre", "reflection-point"]
    );
    let all = labels(&[]);
    assert!(
        all.iter().any(|l| l == "compute")
            && all.iter().any(|l| l == "compute-centre")
            && all.iter().any(|l| l == "reflection-point-sub2"),
        "{all:?}"
    );
    // It does not combine with --quick.
    let o = cli(&["bench", "--model-rows", "--quick"]);
    assert!(!o.status.success());
}

/// A missed row is compared with the closest training row of its method (the same subgroup
/// size, then the nearest cube size), whatever the rows' order: a held-out row at cube 64 names
/// the training row at cube 64, one at cube 1024 the one at 1024, in both orders.
#[test]
fn a_miss_is_compared_with_the_closest_training_row() {
    let t = Training::standard();
    let base = vec![
        row("default", Method::Compute, 1024, 16, 4000.0, &t),
        row("default", Method::Compute, 64, 16, 4000.0, &t),
        row("default", Method::Compute, 64, 8, 4000.0, &t),
        // Far off the training rows' time: both miss.
        row("bowl", Method::Compute, 64, 16, 40000.0, &t),
        row("bowl", Method::Compute, 1024, 16, 40000.0, &t),
    ];
    let mut reversed = base.clone();
    reversed.reverse();
    for rows in [base, reversed] {
        let v = validate::validate(&rows, &t).unwrap();
        let miss = |key: &str| {
            v.rows
                .iter()
                .find(|r| r.key == key)
                .and_then(|r| r.miss.clone())
                .unwrap_or_else(|| panic!("{key} should miss: {:?}", v.rows))
        };
        let m64 = miss("bowl/compute/cube64/sg16");
        assert!(m64.contains("default/compute/cube64/sg16"), "{m64}");
        let m1024 = miss("bowl/compute/cube1024/sg16");
        assert!(m1024.contains("default/compute/cube1024/sg16"), "{m1024}");
    }
}

/// A scene given to `--scenes` as a file's path is modelled too: the rows carry where the bench
/// loaded each scene (`source`), and the model loads it from there, in the bench's own run and
/// from its file (`--model-from`). Negative: the same file without `source` fails, naming the
/// scene it cannot load by its name.
#[test]
fn the_model_loads_a_scene_given_by_its_path() {
    let d = tempfile::tempdir().unwrap();
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/scenes/facing/scene.toml"
    );
    let scenes = format!("default,{path}");
    let v = bench_run(
        d.path(),
        &scenes,
        "fragment,bvh",
        &["--model", "--model-rows"],
    );
    let runs = v["runs"].as_array().expect("runs");
    assert!(runs.iter().any(|r| r["source"] == path), "{runs:?}");
    let rows = v["model"]["lavapipe"]["rows"].as_array().expect("rows");
    assert!(rows.iter().any(|r| r["scene"] == path), "{rows:?}");
    let model_from = |file: &Path, out: &Path| {
        cli(&[
            "bench",
            "--model",
            "--model-from",
            file.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
    };
    let json = d.path().join("bench.json");
    let o = model_from(&json, &d.path().join("again"));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut old = v.clone();
    for r in old["runs"].as_array_mut().unwrap() {
        r.as_object_mut().unwrap().remove("source");
    }
    let stripped = d.path().join("old.json");
    std::fs::write(&stripped, serde_json::to_string(&old).unwrap()).unwrap();
    let o = model_from(&stripped, &d.path().join("old"));
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("unknown scene 'facing'"), "{e}");
}

const FRAG: &str = "fragment_trace.wgsl";
const COMP: &str = "compute_trace.wgsl";
const BVH: &str = "bvh_trace.wgsl";
const SSR: &str = "ssr.wgsl";
const RP: &str = "reflection_point_search.wgsl";

/// Every function a block of a modelled method names (shader, function), with the functions
/// that call it (one entry per call site, in the order `ShaderFunctions::callers` gives).
const NAMED_CALLERS: &[(&str, &str, &[&str])] = &[
    // fragment (`fragment_trace`): the march's host is `mip_turn`; `fs_bounded`,
    // `trace_mip_bounded`, `classify`, `texel_search` and `texel_certified` (the walk's search
    // and certificate) are not reached from `fs_exact_mip` (`trace_one` takes `trace_mip` under
    // TRACE_EXACT_MIP).
    (FRAG, "mirror_ray", &["trace_pixel", "fs_bounded"]),
    (FRAG, "trace_mip", &["trace_one", "trace_one"]),
    (FRAG, "mip_start", &["trace_mip", "trace_mip_bounded"]),
    (FRAG, "mip_turn", &["trace_mip", "trace_mip_bounded"]),
    (FRAG, "texel_search_face", &["mip_turn", "texel_search"]),
    (FRAG, "cell_interval_face", &["mip_turn"]),
    (FRAG, "inflated", &["mip_turn"]),
    (FRAG, "r_bounds_from", &["mip_turn"]),
    (FRAG, "mip_get", &["mip_turn"]),
    (FRAG, "classify_with", &["trace_mip", "classify"]),
    (FRAG, "classify_candidate", &["classify_with"]),
    (FRAG, "verify_decision", &["trace_ray_verified"]),
    (FRAG, "hit_shade", &["trace_pixel", "fs_bounded"]),
    (
        FRAG,
        "texel_certified_face",
        &["mip_turn", "texel_certified"],
    ),
    // compute (`compute_trace`), as found (not each checked against the replay's logging).
    (COMP, "settle", &["trace_queued"]),
    (COMP, "start_trace", &["settle"]),
    (COMP, "enter_face", &["settle"]),
    (COMP, "handoff", &["settle"]),
    (COMP, "verify_decision", &["handoff", "trace_ray_verified"]),
    (COMP, "node_ctx", &["trace_queued"]),
    (
        COMP,
        "child_grid",
        &["node_ctx_at", "advance", "trace_queued"],
    ),
    (COMP, "children_crossed", &["trace_queued"]),
    // The wave layout calls `lane_test` (and `test_ray`, once per turn) from `wave_tests`.
    (COMP, "lane_test", &["wave_tests", "trace_queued"]),
    (COMP, "test_ray", &["wave_tests", "trace_queued"]),
    (COMP, "wave_items", &["wave_tests"]),
    (COMP, "wave_item", &["wave_tests"]),
    (COMP, "wave_collect", &["wave_tests"]),
    // The thesis layout's pick (the one-lane pick is `pick_one`, which reads the keys itself).
    (COMP, "key_get", &["trace_queued", "trace_queued"]),
    (COMP, "ray_bits", &["trace_queued", "trace_queued"]),
    (COMP, "pick_one", &["trace_queued"]),
    (COMP, "advance", &["trace_queued"]),
    // `advance` classifies without the strict code; `classify` and `trace_mip` are the shared
    // tracer's, which no compute entry point reaches.
    (COMP, "classify_with", &["advance", "classify", "trace_mip"]),
    (COMP, "classify_candidate", &["classify_with"]),
    (COMP, "hit_shade", &["trace_queued"]),
    (
        COMP,
        "faces_crossed",
        &[
            "enter_face",
            "trace_walk",
            "trace_mip",
            "trace_sampled",
            "trace_mip_bounded",
        ],
    ),
    // bvh (`bvh_trace`), as found.
    (BVH, "bvh_inv_dir", &["bvh_nearest"]),
    (
        BVH,
        "bvh_start_tolerance",
        &["bvh_nearest", "bvh_start_hit"],
    ),
    (BVH, "bvh_nearest", &["main"]),
    (BVH, "bvh_node_hits", &["bvh_nearest"]),
    (BVH, "wt_intersect", &["bvh_nearest"]),
    (BVH, "bvh_start_ignores", &["bvh_nearest", "bvh_start_hit"]),
    (BVH, "hit_shade", &["main"]),
    // ssr (`ssr`).
    (SSR, "mirror_ray", &["fs_main"]),
    (SSR, "ssr_trace", &["fs_main"]),
    (SSR, "on_screen", &["ssr_trace", "ssr_trace"]),
    (SSR, "cell_of", &["ssr_trace", "ssr_trace", "ssr_trace"]),
    (
        SSR,
        "hiz_at",
        &["ssr_trace", "ssr_trace", "ssr_trace", "ssr_trace"],
    ),
    (SSR, "cross_cell", &["ssr_trace", "ssr_trace"]),
    // reflection-point (`reflection_point_search`): `finish` names functions of its own, as
    // `rp_score` calls `scene_normalize` and `rp_mirror` too.
    (RP, "rp_start", &["search"]),
    (RP, "rp_walk", &["search", "search"]),
    (RP, "rp_score", &["rp_walk", "rp_walk"]),
    (RP, "rp_virtual_vertex", &["search"]),
    (RP, "rp_found_normal", &["search", "search"]),
    (RP, "rp_start_arms", &["rp_start"]),
];

/// The named functions whose callers differ from `listed` (`function: found callers`).
fn unlisted_callers(listed: &[(&str, &str, &[&str])]) -> Vec<String> {
    let mut wrong = Vec::new();
    for m in MODELLED {
        for b in blocks(m) {
            let sf = ShaderFunctions::of(b.shader).unwrap();
            for f in b.functions {
                let found = sf.callers(f);
                let ok = listed.iter().any(|(shader, name, callers)| {
                    (*shader, name) == (b.shader, f) && callers.iter().eq(found.iter())
                });
                if !ok {
                    wrong.push(format!("{} ({}): {f}: {found:?}", b.shader, b.name));
                }
            }
        }
    }
    wrong
}

/// A function a block names is counted in that block only, and left out of every other block
/// that calls it (`model::weights`): called anywhere else, those calls go uncounted (the
/// fragment cell test's `cell_interval` once left six whole-face intervals, `verify` and the
/// texel certificate uncounted; reflection-point's `finish` named `scene_normalize`, which
/// `rp_score` calls four times). So each named function's callers are listed in
/// `NAMED_CALLERS`, and a new caller fails here until it is looked at (a function of its own for
/// the block, or the caller listed). Negative: a list without one caller fails.
#[test]
fn named_functions_are_called_only_where_listed() {
    assert_eq!(unlisted_callers(NAMED_CALLERS), Vec::<String>::new());
    let fewer: Vec<(&str, &str, &[&str])> = NAMED_CALLERS
        .iter()
        .map(|&(s, f, c)| (s, f, if f == "texel_search_face" { &c[..1] } else { c }))
        .collect();
    let wrong = unlisted_callers(&fewer);
    assert!(
        wrong.len() == 1 && wrong[0].contains("texel_search_face"),
        "{wrong:?}"
    );
}

//! The cost model's harness (issue 25, items 4-6): SPIR-V block weights, the validation split,
//! and `bench --model`'s JSON. Tiny: one 16x12 frame where the device runs; no speed asserted.

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

fn row(scene: &str, method: Method, cube: u32, subgroup: u32, ns: f64, t: &Training) -> Modelled {
    let measured = Measured {
        scene: scene.into(),
        method,
        cube,
        subgroup,
        width: 16,
        height: 12,
        rays: 100,
        pass_ns: ns,
    };
    Modelled {
        train: t.contains(&measured),
        measured,
        cost_per_ray: 10.0,
        model_rays: 100,
        blocks: vec!["a".into(), "b".into()],
        shares: vec![0.5, 0.5],
        simd_efficiency: 1.0,
    }
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
    let v = validate::validate(&rows, &t).unwrap();
    let held: Vec<&str> = v
        .rows
        .iter()
        .filter(|r| !r.train)
        .map(|r| r.key.as_str())
        .collect();
    assert_eq!(v.training_rows.len(), 2, "{:?}", v.training_rows);
    assert_eq!(held.len(), 4);
    assert!(v.training_rows.iter().all(|k| !held.contains(&k.as_str())));
    // A held-out row changed tenfold leaves the scale as it was ...
    let fits = |r: &[Modelled]| {
        [None, Some(Method::Compute), Some(Method::Fragment)]
            .map(|m| validate::fit_scale(r, m).unwrap())
    };
    let scale = validate::fit_scale(&rows, None).unwrap();
    let all = fits(&rows);
    for i in 2..rows.len() {
        let mut r = rows.clone();
        r[i].measured.pass_ns *= 10.0;
        assert_eq!(fits(&r), all, "row {i}");
        assert_eq!(
            validate::validate(&r, &t).unwrap().scales,
            v.scales,
            "row {i}"
        );
    }
    // bvh has no training row here: its scale cannot be fitted, and says so.
    let e = validate::fit_scale(&rows, Some(Method::Bvh)).unwrap_err();
    assert!(format!("{e}").contains("--method bvh"), "{e}");
    // ... and a training row changed moves it (the negative: the check can fail).
    rows[0].measured.pass_ns *= 10.0;
    assert_ne!(validate::fit_scale(&rows, None).unwrap(), scale);
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

fn bench(dir: &Path, model: bool) -> serde_json::Value {
    let out = dir.to_str().unwrap();
    let mut args = vec![
        "bench",
        "--scenes",
        "default,bowl",
        "--methods",
        "compute,bvh",
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
    if model {
        args.push("--model");
    }
    let o = cli(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_str(&std::fs::read_to_string(dir.join("bench.json")).unwrap()).unwrap()
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
    assert!(m["lavapipe"]["global_scale"].as_f64().unwrap() > 0.0);
    let widths: Vec<u64> = m["gpu"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["width"].as_u64().unwrap())
        .collect();
    assert!(widths.contains(&32) && widths.contains(&64), "{widths:?}");
    let g = &m["gpu"][0];
    for k in [
        "compute_over_bvh",
        "compute_over_fragment",
        "fragment_over_bvh",
    ] {
        assert!(g[k].is_number(), "{k} in {g}");
    }
    assert!(g["methods"][0]["sectors_per_ray"].is_number());
    assert!(m["triangles"].as_array().is_some_and(|t| !t.is_empty()));
    assert!(m["assumptions"][0].as_str().unwrap().contains("MODEL"));
    let md = std::fs::read_to_string(d.path().join("bench.md")).unwrap();
    assert!(md.contains("## Cost model"), "{md}");
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
    // The same row from two files is refused (one of them would be fitted or scored twice).
    let g = d.path().join("one.json");
    std::fs::write(
        &g,
        r#"{"device": {"subgroup_size": 8}, "runs": [{"scene": "default", "method": "bvh",
            "cube_size": 256, "width": 16, "height": 12, "rays": 10,
            "trace_ns": {"median": 1000.0}}]}"#,
    )
    .unwrap();
    let both = format!("{},{}", g.display(), g.display());
    let o = cli(&[
        "bench",
        "--model",
        "--model-from",
        &both,
        "-o",
        out.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("default/bvh/cube256/sg8"),
        "{e}"
    );
    // --model-from alone is refused by the parser (it needs --model).
    let o = cli(&["bench", "--model-from", f.to_str().unwrap()]);
    assert!(!o.status.success());
}

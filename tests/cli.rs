//! The command line as a user meets it: the built binary run in a temporary folder, on small
//! frames. Output paths, refusals before the render, messages. Every check has its negative
//! side: the same command with the problem removed must pass.
//!
//! This crate also holds, each in its module of `tests/cli/`: `scale_out` (`cubetrace farm
//! slurm|k8s` and `--shard`).

mod common;

#[path = "cli/scale_out.rs"]
mod scale_out;

use common::binary::{Outcome, run, run_env};
use std::path::Path;

use cubetrace::Method;
use cubetrace::scene::{builtin, export};
use cubetrace::vk::budget;
use cubetrace::vk::frame::{Fallback, GpuRenderer, RenderOptions};

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    out.sort();
    out
}

/// A clean failure: exit status 1, no panic, exactly one `error:` line containing every needle.
fn assert_clean_failure(o: &Outcome, needles: &[&str]) {
    assert_eq!(o.code, Some(1), "exit status; stderr: {}", o.stderr);
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
    let errors = o.stderr.lines().filter(|l| l.starts_with("error:")).count();
    assert_eq!(errors, 1, "one error message: {}", o.stderr);
    for n in needles {
        assert!(o.stderr.contains(n), "expected '{n}' in: {}", o.stderr);
    }
}

fn occurrences(haystack: &str, needle: &str) -> usize {
    haystack.matches(needle).count()
}

// ---- Item 8: messages ----

#[test]
fn the_cause_is_printed_once() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["render", "missing/scene.toml", "-o", "x.png"], dir.path());
    assert_clean_failure(&o, &["missing/scene.toml", "cannot read"]);
    // The OS error's text, once (not a second time after the message).
    let cause = std::io::Error::from_raw_os_error(2).to_string();
    assert!(cause.contains("os error 2"), "{cause}");
    assert_eq!(occurrences(&o.stderr, &cause), 1, "{}", o.stderr);
    // Negative: the counter does see a doubled cause.
    let doubled = format!("error: cannot read x: {cause}: {cause}");
    assert_eq!(occurrences(&doubled, &cause), 2);
}

#[test]
fn validate_without_the_layer_says_what_to_install() {
    let dir = tempfile::tempdir().unwrap();
    // An explicit layer path with no layers in it hides the installed validation layer.
    let empty = tempfile::tempdir().unwrap();
    let hidden = [("VK_LAYER_PATH", empty.path().to_str().unwrap())];
    let o = run_env(&["info", "--validate"], dir.path(), &hidden);
    assert_clean_failure(
        &o,
        &[
            "VK_LAYER_KHRONOS_validation",
            "is not installed",
            "apt-get install vulkan-validationlayers",
        ],
    );
    // Not dressed up as a device feature, and not nested quotes.
    assert!(!o.stderr.contains("lacks required feature"), "{}", o.stderr);
    assert!(!o.stderr.contains("`instance`"), "{}", o.stderr);
    // Negative: without --validate (and without CI's CUBETRACE_VALIDATION=1) the same
    // environment lists the devices.
    let hidden_off = [hidden[0], ("CUBETRACE_VALIDATION", "0")];
    let o = run_env(&["info"], dir.path(), &hidden_off);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
}

#[test]
fn negative_eps_gets_our_message() {
    let dir = tempfile::tempdir().unwrap();
    for form in [
        &["--eps", "-1"][..],
        &["--eps=-1"],
        &["--eps", "0"],
        &["--eps=inf"],
    ] {
        let mut args = vec!["render", "--method", "fragment", "-o", "x.png"];
        args.extend_from_slice(form);
        let o = run(&args, dir.path());
        assert_ne!(o.code, Some(0), "{form:?}");
        assert!(
            o.stderr.contains("--eps") && o.stderr.contains("must be a positive"),
            "{form:?}: {}",
            o.stderr
        );
        assert!(!o.stderr.contains("unexpected argument"), "{}", o.stderr);
        assert!(!dir.path().join("x.png").exists());
    }
    // Negative: a positive value passes the parser (and the command then fails on the output
    // extension, which shows that the value was accepted without rendering anything).
    let o = run(
        &[
            "render",
            "--method",
            "fragment",
            "--criterion",
            "threshold",
            "--eps",
            "0.1",
            "-o",
            "x.jpg",
        ],
        dir.path(),
    );
    assert_clean_failure(&o, &["x.jpg", "unsupported extension"]);
}

#[test]
fn scene_export_suggests_the_next_command() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["scene", "export", "spheer-room", "x"], dir.path());
    assert_clean_failure(
        &o,
        &[
            "unknown scene 'spheer-room'",
            "sphere-room",
            "cubetrace scene export",
        ],
    );
    // A scene file is not something to export: the suggestion is to render it.
    std::fs::write(dir.path().join("mine.toml"), "").unwrap();
    let o = run(&["scene", "export", "mine.toml", "x"], dir.path());
    assert_clean_failure(&o, &["mine.toml", "cubetrace render mine.toml"]);
    assert!(!dir.path().join("x").exists());
    // Negative: a built-in name exports.
    let o = run(&["scene", "export", "bowl", "x"], dir.path());
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(dir.path().join("x/scene.toml").is_file());
}

#[test]
fn strict_help_claims_what_the_hard_cases_show() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["render", "--help"], dir.path());
    assert_eq!(o.code, Some(0));
    let help = o.stdout.replace('\n', " ");
    let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(help.contains("tests/hard_cases.rs"), "{help}");
    assert!(help.contains("against the reference"), "{help}");
    // A claim the bench's wrong-surface figures for strict mode contradict.
    assert!(!help.contains("Never a silent wrong hit"), "{help}");
}

// ---- Item 6: output paths ----

/// A built-in scene exported to `dir`, renamed to `name`.
fn renamed_scene(dir: &Path, name: &str) -> std::path::PathBuf {
    let path = export::export(&builtin::by_name("bowl").unwrap(), dir).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let line = text.lines().find(|l| l.starts_with("name = ")).unwrap();
    let quoted = toml::Value::String(name.into()).to_string();
    std::fs::write(&path, text.replacen(line, &format!("name = {quoted}"), 1)).unwrap();
    path
}

#[test]
fn scene_name_does_not_steer_the_default_output_path() {
    let root = tempfile::tempdir().unwrap();
    let work = root.path().join("work");
    std::fs::create_dir_all(work.join("scene")).unwrap();
    let evil = "../../escaped/\u{7}x\ny";
    let scene = renamed_scene(&work.join("scene"), evil);
    let o = run(
        &[
            "render",
            scene.to_str().unwrap(),
            "--method",
            "reference",
            "--width",
            "4",
            "--height",
            "3",
        ],
        &work,
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let written: Vec<String> = files(root.path())
        .into_iter()
        .filter(|f| f.ends_with(".png") && !f.starts_with("work/scene/"))
        .collect();
    assert_eq!(written, ["work/out/______escaped__x_y-reference.png"]);
    assert!(!root.path().join("escaped").exists());
    // Negative: a plain name is kept as it is.
    let scene = renamed_scene(&work.join("scene"), "plain-name_2");
    let o = run(
        &[
            "render",
            scene.to_str().unwrap(),
            "--method",
            "reference",
            "--width",
            "4",
            "--height",
            "3",
        ],
        &work,
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(work.join("out/plain-name_2-reference.png").is_file());
}

/// Info logging, whatever RUST_LOG the test runs under: the stages' log lines show how far a
/// command got.
const INFO: [(&str, &str); 1] = [("RUST_LOG", "info")];

/// The reference logs this when its BVH is built, before it renders a row.
const REFERENCE_STARTED: &str = "triangles, BVH built in";
/// The Vulkan backend logs this when it creates the device, before any GPU work.
const DEVICE_CREATED: &str = "Vulkan device: ";
/// The GPU renderer logs this while it creates its passes (the BVH of the `trace` fallback and
/// the reflector check), after the memory check and before the first frame.
const RENDERER_CREATED: &str = "CWBVH: ";

#[test]
fn output_problems_are_found_before_the_render() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("file"), "x").unwrap();
    std::fs::create_dir(dir.path().join("folder.png")).unwrap();
    // Before the render: the reference has not built its BVH, a GPU method has not created its
    // device (both are logged at info level, and the successful runs below show the lines).
    for (out, needle) in [
        ("file/x.png", "is not a folder"),
        ("file/sub/x.exr", "is not a folder"),
        ("folder.png", "is a folder"),
        ("x.jpg", "unsupported extension"),
    ] {
        for (method, started) in [
            ("reference", REFERENCE_STARTED),
            ("compute", DEVICE_CREATED),
        ] {
            let args = ["render", "sphere-room", "-o", out, "--method", method];
            let o = run_env(&args, dir.path(), &INFO);
            assert_clean_failure(&o, &[out, needle]);
            assert!(!o.stderr.contains(started), "{out} {method}: {}", o.stderr);
        }
    }
    assert_eq!(files(dir.path()), ["file"]);
    // Negative: a folder that does not exist yet is fine (it is created), and the render's
    // stages are logged.
    for (method, started) in [
        ("reference", REFERENCE_STARTED),
        ("compute", DEVICE_CREATED),
    ] {
        let out = format!("new/sub/{method}.png");
        let args = [
            "render", "bowl", "--method", method, "--width", "4", "--height", "3", "-o", &out,
        ];
        let o = run_env(&args, dir.path(), &INFO);
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        assert!(dir.path().join(&out).is_file());
        assert!(o.stderr.contains(started), "{method}: {}", o.stderr);
    }
}

#[test]
fn bench_checks_every_scene_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &[
            "bench",
            "--scenes",
            "bowl,no-such-scene",
            "--methods",
            "envmap",
            "--width",
            "8",
            "--height",
            "6",
            "--frames",
            "1",
            "--warmup",
            "0",
            "-o",
            "b",
        ],
        dir.path(),
    );
    assert_clean_failure(&o, &["no-such-scene"]);
    // Nothing was rendered or written: not even the first scene's heat map.
    assert!(files(dir.path()).is_empty(), "{:?}", files(dir.path()));
    // A bench output folder that cannot be made is found before any work too.
    std::fs::write(dir.path().join("file"), "x").unwrap();
    let o = run(&["bench", "--scenes", "bowl", "-o", "file/b"], dir.path());
    assert_clean_failure(&o, &["file/b", "is not a folder"]);
}

#[test]
fn bench_heat_map_names_are_sanitised() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("scene")).unwrap();
    let scene = renamed_scene(&dir.path().join("scene"), "../up");
    std::fs::create_dir(dir.path().join("other")).unwrap();
    // Another scene whose name sanitises to the same file name.
    let other = renamed_scene(&dir.path().join("other"), "__/up");
    let scenes = format!("{},{}", scene.display(), other.display());
    let o = run(
        &[
            "bench",
            "--scenes",
            &scenes,
            "--methods",
            "envmap",
            "--width",
            "8",
            "--height",
            "6",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--no-flip",
            "-o",
            "b",
        ],
        dir.path(),
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let heat: Vec<String> = files(dir.path())
        .into_iter()
        .filter(|f| f.contains("heat"))
        .collect();
    assert_eq!(
        heat,
        ["b/heat/___up-envmap-2.png", "b/heat/___up-envmap.png"]
    );
    let json = std::fs::read_to_string(dir.path().join("b/bench.json")).unwrap();
    assert!(json.contains("\"heat/___up-envmap-2.png\""), "{json}");
    // Negative: the unsanitised name would have left the heat folder.
    assert!(!dir.path().join("b/up-envmap.png").exists());
}

#[test]
fn scene_export_does_not_overwrite_without_force() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["scene", "export", "bowl", "x"], dir.path());
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let toml = dir.path().join("x/scene.toml");
    std::fs::write(&toml, "# my edits\n").unwrap();
    let o = run(&["scene", "export", "torus", "x"], dir.path());
    assert_clean_failure(&o, &["x/scene.toml", "already exists", "--force"]);
    assert_eq!(std::fs::read_to_string(&toml).unwrap(), "# my edits\n");
    // Negative: --force overwrites.
    let o = run(&["scene", "export", "torus", "x", "--force"], dir.path());
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(
        std::fs::read_to_string(&toml)
            .unwrap()
            .contains("scene 'torus'")
    );
}

// ---- Item 2: --compare counts both sides ----

#[test]
fn compare_reports_both_masks_and_the_whole_frame() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &[
            "render",
            "bowl",
            "--width",
            "32",
            "--height",
            "24",
            "--compare",
            "-o",
            "x.png",
        ],
        dir.path(),
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let line = o
        .stdout
        .lines()
        .find(|l| l.starts_with("against the reference"))
        .unwrap_or_else(|| panic!("no comparison in: {}", o.stdout));
    for needle in [
        "mirror pixels (either frame)",
        "in error: mask mismatch",
        "only in the reference",
        "only here",
        "dB over mirror pixels",
        "dB over resolved mirror pixels",
        "dB over the frame",
    ] {
        assert!(line.contains(needle), "'{needle}' in: {line}");
    }
    // A rendered frame has figures, not "inf" or NaN.
    assert!(!line.contains("inf") && !line.contains("NaN"), "{line}");
}

/// `--compare` on a sequence compares every frame with the reference's same frame: `bvh` (exact)
/// is 0.00 % in error on each, and each frame's line is the one that frame gets rendered alone.
/// Negative: the frames' lines differ from each other (the camera moves), so a line compared
/// against another frame's reference would not match.
#[test]
fn compare_works_on_every_frame_of_a_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let base = [
        "render",
        "sphere-room-orbit",
        "--method",
        "bvh",
        "--width",
        "32",
        "--height",
        "24",
        "--compare",
    ];
    let lines = |frames: &str| {
        let mut args = base.to_vec();
        args.extend(["--frames", frames, "-o", "f-##.png"]);
        let o = run(&args, dir.path());
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        o.stdout
            .lines()
            .filter(|l| l.contains(": against the reference"))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    let both = lines("7,13");
    assert_eq!(both.len(), 2, "{both:?}");
    assert!(both[0].starts_with("frame 7: ") && both[1].starts_with("frame 13: "));
    for l in &both {
        assert!(l.contains("0.00% in error"), "{l}");
    }
    assert_eq!(lines("13"), vec![both[1].clone()]);
    let strip = |l: &str| l.split_once(": ").unwrap().1.to_string();
    assert_ne!(strip(&both[0]), strip(&both[1]));
}

/// On a glossy scene `--compare` measures against a converged reference, states its spp and
/// its own half-spp PSNR, and separates the methods: the cone-traced `compute` frame scores
/// well above a 1-spp `bvh` frame (one lobe sample: noise), and the reference's own half is
/// closer still. Negative: with a 2-spp reference (far from converged) the same `compute` frame
/// scores lower than against 64 spp.
#[test]
fn compare_on_a_glossy_scene_uses_a_converged_reference() {
    let dir = tempfile::tempdir().unwrap();
    let psnr = |method: &str, spp: &str| {
        let o = run(
            &[
                "render",
                "sphere-room-glossy",
                "--method",
                method,
                "--width",
                "40",
                "--height",
                "30",
                "--compare",
                "--compare-spp",
                spp,
                "-o",
                "g.png",
            ],
            dir.path(),
        );
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        let line = o
            .stdout
            .lines()
            .find(|l| l.starts_with("against a converged reference"))
            .unwrap_or_else(|| panic!("no glossy comparison in: {}", o.stdout))
            .to_string();
        assert!(
            line.contains(&format!("({spp} spp; its half-spp PSNR")),
            "{line}"
        );
        let number = |after: &str| -> f64 {
            let rest = line.split(after).nth(1).unwrap_or_else(|| panic!("{line}"));
            rest.split_whitespace().next().unwrap().parse().unwrap()
        };
        (number("PSNR "), number("pixels, PSNR "))
    };
    let (half, compute) = psnr("compute", "64");
    let (_, bvh) = psnr("bvh", "64");
    eprintln!("half-spp {half} dB, compute {compute} dB, bvh 1 spp {bvh} dB");
    assert!(compute > bvh + 5.0, "{compute} against {bvh}");
    assert!(half > compute, "{half} against {compute}");
    let (_, rough) = psnr("compute", "2");
    assert!(rough + 3.0 < compute, "{rough} against {compute}");
}

/// At `--spp N > 1`, `--compare` adds the per-sample line, with the error counts summed over the
/// sample-pixels (a share would round a handful of them to 0.00 %); at 1 spp there is no such
/// line.
#[test]
fn compare_counts_sample_pixels_per_sample() {
    let dir = tempfile::tempdir().unwrap();
    let per_sample = |spp: &str| {
        let args = [
            "render",
            "bowl",
            "--width",
            "32",
            "--height",
            "24",
            "--spp",
            spp,
            "--compare",
            "-o",
            "x.png",
        ];
        let o = run(&args, dir.path());
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        o.stdout
            .lines()
            .find(|l| l.starts_with("per sample"))
            .map(str::to_string)
    };
    assert_eq!(per_sample("1"), None, "1 spp has no per-sample line");
    let line = per_sample("4").expect("a per-sample line at 4 spp");
    let number_after = |key: &str| -> usize {
        let tail = line
            .split(key)
            .nth(1)
            .unwrap_or_else(|| panic!("'{key}' in: {line}"));
        let digits: String = tail
            .trim_start()
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        digits
            .parse()
            .unwrap_or_else(|_| panic!("a count after '{key}' in: {line}"))
    };
    let total = number_after("; of ");
    assert!(
        total > 0 && total <= 4 * 32 * 24,
        "{total} sample-pixels in: {line}"
    );
    let mismatch = number_after("sample-pixels, ");
    let (only_ref, only_here) = (
        number_after("mask mismatch ("),
        number_after("in the reference, "),
    );
    assert_eq!(mismatch, only_ref + only_here, "{line}");
    assert!(line.contains("one sample's PSNR: worst"), "{line}");
}

/// `--no-reflector-check` turns the check off: on the torus (which the CMOs do not capture) the
/// same triangle share drops below the default's.
#[test]
fn no_reflector_check_turns_the_check_off() {
    let dir = tempfile::tempdir().unwrap();
    let same = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "render",
            "torus",
            "--width",
            "48",
            "--height",
            "36",
            "--compare",
            "-o",
            out,
        ];
        args.extend_from_slice(extra);
        let o = run(&args, dir.path());
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        let line = o
            .stdout
            .lines()
            .find(|l| l.starts_with("against the reference"))
            .unwrap_or_else(|| panic!("no comparison in: {}", o.stdout))
            .to_string();
        let tail = line
            .split("same triangle ")
            .nth(1)
            .unwrap_or_else(|| panic!("{line}"));
        tail.split('%').next().unwrap().parse::<f64>().unwrap()
    };
    let with = same("with.png", &[]);
    let without = same("without.png", &["--no-reflector-check"]);
    assert!(
        with >= 99.0 && without < with - 1.0,
        "{with} with, {without} without"
    );
}

#[test]
fn bench_outputs_carry_mask_mismatch_and_frame_psnr() {
    let dir = tempfile::tempdir().unwrap();
    let o = run_env(
        &[
            "bench",
            "--scenes",
            "bowl",
            "--methods",
            "envmap",
            "--width",
            "16",
            "--height",
            "12",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--no-flip",
            "--no-heatmaps",
            "-o",
            "b",
        ],
        dir.path(),
        // Under a cap it fits in (the negative side of the bench's memory refusal).
        &[("CUBETRACE_MEMORY_LIMIT", "1G")],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(o.stdout.contains("| mask mismatch % |"), "{}", o.stdout);
    assert!(o.stdout.contains("| PSNR frame dB |"), "{}", o.stdout);
    let md = std::fs::read_to_string(dir.path().join("b/bench.md")).unwrap();
    assert!(
        md.contains("mask mismatch (ref only + method only)"),
        "{md}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("b/bench.json")).unwrap())
            .unwrap();
    let error = &json["runs"][0]["error"];
    for field in [
        "mask_missed",
        "mask_extra",
        "mask_mismatch_fraction",
        "error",
    ] {
        assert!(error[field].is_number(), "{field}: {error}");
    }
    assert!(error["psnr_frame_db"].as_f64().unwrap() > 0.0, "{error}");
    // Negative: a field that does not exist reads as absent, so the checks above can fail.
    assert!(error["no_such_field"].is_null());
}

// ---- Item 7: memory ----

#[test]
fn a_render_too_large_for_memory_is_refused_before_it_starts() {
    let dir = tempfile::tempdir().unwrap();
    // The command: it grew past 14 GB. Capped at 8 GiB it must be refused at once, with
    // the figure, whatever memory the test machine has.
    let cap = [("CUBETRACE_MEMORY_LIMIT", "8G"), INFO[0]];
    // Refused before the render: the reference before its BVH, a GPU method before its renderer
    // (whose passes log the CWBVH they build; the successful runs below show the lines).
    for (method, started) in [
        ("reference", REFERENCE_STARTED),
        ("compute", RENDERER_CREATED),
    ] {
        let o = run_env(
            &[
                "render", "--method", method, "--width", "16384", "--height", "16384", "-o",
                "big.png",
            ],
            dir.path(),
            &cap,
        );
        assert_clean_failure(
            &o,
            &[
                "16384x16384",
                &format!("--method {method}"),
                "GiB of memory",
                "8.00 GiB",
                "CUBETRACE_MEMORY_LIMIT",
            ],
        );
        assert!(!o.stderr.contains(started), "{method}: {}", o.stderr);
    }
    // The GPU's CMO data counts too: a tiny frame with huge cube maps (the centre criterion's;
    // the bounded default's lists take their own, smaller size).
    let o = run_env(
        &[
            "render",
            "--criterion",
            "centre",
            "--cube-size",
            "4096",
            "--cmos",
            "16",
            "--width",
            "8",
            "--height",
            "8",
            "-o",
            "big.png",
        ],
        dir.path(),
        &cap,
    );
    assert_clean_failure(&o, &["16 CMOs of 4096^2 texels", "GiB of GPU data"]);
    assert!(files(dir.path()).is_empty(), "{:?}", files(dir.path()));
    // The bench checks every scene's largest run before it renders anything.
    let o = run_env(
        &[
            "bench",
            "--scenes",
            "bowl",
            "--methods",
            "envmap",
            "--width",
            "4096",
            "--height",
            "4096",
            "-o",
            "b",
        ],
        dir.path(),
        &[("CUBETRACE_MEMORY_LIMIT", "256M")],
    );
    assert_clean_failure(&o, &["bench scene 'bowl' at 4096x4096", "256.0 MiB"]);
    assert!(files(dir.path()).is_empty(), "{:?}", files(dir.path()));
    // A malformed cap is named.
    let o = run_env(
        &["render", "--method", "reference", "-o", "x.png"],
        dir.path(),
        &[("CUBETRACE_MEMORY_LIMIT", "lots")],
    );
    assert_clean_failure(&o, &["CUBETRACE_MEMORY_LIMIT=lots", "not a memory size"]);
    // Negative: small frames fit under the same cap, on the CPU and on the GPU, and render.
    for (method, started) in [
        ("reference", REFERENCE_STARTED),
        ("compute", RENDERER_CREATED),
    ] {
        let out = format!("{method}.png");
        let o = run_env(
            &[
                "render", "--method", method, "--width", "32", "--height", "24", "-o", &out,
            ],
            dir.path(),
            &cap,
        );
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        assert!(dir.path().join(&out).is_file());
        assert!(o.stderr.contains(started), "{method}: {}", o.stderr);
    }
}

/// The GPU estimate against what the renderer really allocates for its CMO data.
#[test]
fn gpu_estimate_covers_the_cmo_allocation() {
    let ctx = common::gpu_context();
    let mut scene = builtin::sphere_room();
    scene.cmo.resolution = 64;
    let mut camera = scene.cameras[0].clone();
    (camera.width, camera.height) = (16, 12);
    for method in [
        Method::Fragment,
        Method::Compute,
        Method::Envmap,
        Method::Ssr,
        Method::ReflectionPoint,
    ] {
        // The centre criterion: the scene-less estimate cannot know the bounded lists' size.
        let options = RenderOptions {
            method,
            trace: cubetrace::cpu::options::TraceOptions::centre(),
            fallback: Fallback::Envmap,
            ..RenderOptions::default()
        };
        let renderer = GpuRenderer::new(&ctx, &scene, &camera, options).unwrap();
        let real = renderer.cmo().bytes();
        let cmos = scene.cmo_centres().len() as u32;
        let trace = &options.trace;
        let estimate =
            budget::device_bytes(16, 12, method, cmos, 64, scene.captures_reflectors(), trace);
        eprintln!("{method:?}: CMO data {real} bytes, estimate {estimate:?}");
        assert!(estimate.cmo >= real, "{method:?}: {estimate:?} < {real}");
        // The estimate also holds the capture pass's own per-texel targets (f32 distance, and
        // u32 ID where captured), which `CmoData::bytes` does not: without them it is within
        // 1.5 times the CMO data.
        let texels = u64::from(cmos) * 6 * 64 * 64;
        let targets = texels
            * if renderer.cmo().contents().triangle_ids {
                8
            } else {
                4
            };
        assert!(
            ((estimate.cmo - targets) as f64) < 1.5 * real as f64,
            "{method:?}: {estimate:?} against {real}"
        );
        // Negative: the estimate for half the cube size is below the real allocation.
        let half =
            budget::device_bytes(16, 12, method, cmos, 32, scene.captures_reflectors(), trace);
        assert!(half.cmo < real, "{method:?}");
    }
    common::finish_gpu(ctx);
}

#[test]
fn reflection_point_renders_and_refuses_oversized_search_textures() {
    let dir = tempfile::tempdir().unwrap();
    let size = ["--width", "32", "--height", "24"];
    let mut args = vec!["render", "sphere-room", "--method", "reflection-point"];
    args.extend(size);
    args.extend(["--subdivide", "1", "--compare", "-o", "rp.png"]);
    let o = run(&args, dir.path());
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(o.stdout.contains("method reflection-point"), "{}", o.stdout);
    assert!(o.stdout.contains("against the reference"), "{}", o.stdout);
    assert_eq!(files(dir.path()), vec!["rp.png".to_string()]);
    // Search textures wider than the largest image side: refused, nothing written.
    let o = run(
        &[
            "render",
            "sphere-room",
            "--method",
            "reflection-point",
            "--width",
            "3000",
            "--height",
            "20",
            "--rp-scale",
            "8",
            "-o",
            "big.png",
        ],
        dir.path(),
    );
    assert_clean_failure(&o, &["search scale", "24000"]);
    assert_eq!(files(dir.path()), vec!["rp.png".to_string()]);
    // Out-of-range subdivision: clap's usage error.
    let o = run(&["render", "--subdivide", "9"], dir.path());
    assert_eq!(o.code, Some(2), "{}", o.stderr);
    assert!(o.stderr.contains("--subdivide"), "{}", o.stderr);
}

// ---- The summary, method options, frame size, output names, textures, phases ----

/// The `N finished by the fallback (x%)` and `M unresolved` counts of a GPU summary line.
fn summary_counts(stdout: &str) -> (usize, usize) {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("wrote "))
        .unwrap_or_else(|| panic!("no summary in: {stdout}"));
    let number_before = |needle: &str| -> usize {
        let head = line.split(needle).next().unwrap();
        head.rsplit(' ').next().unwrap().parse().unwrap()
    };
    (
        number_before(" finished by the fallback"),
        number_before(" unresolved"),
    )
}

/// The summary counts the fallback's pixels: with `--fallback trace` as many as the same frame
/// leaves unresolved with `--fallback flag` (two ways of counting the method's misses); above
/// 10 % a warning names the cause; a reflector with inward normals counts as with outward ones.
#[test]
fn the_summary_shows_the_fallback_share_and_warns_above_the_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let size = ["--width", "48", "--height", "36"];
    let render = |scene: &str, extra: &[&str]| {
        let mut args = vec!["render", scene, "--method", "compute", "-o", "x.png"];
        args.extend(size);
        args.extend_from_slice(extra);
        let o = run(&args, dir.path());
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        o
    };
    // The centre criterion: the bounded default leaves none of the teapot's pixels.
    let centre = ["--criterion", "centre"];
    let traced = render("teapot", &centre);
    let (fallback, unresolved) = summary_counts(&traced.stdout);
    assert_eq!(unresolved, 0, "{}", traced.stdout);
    let flagged = render("teapot", &["--criterion", "centre", "--fallback", "flag"]);
    let (none, left) = summary_counts(&flagged.stdout);
    assert_eq!((none, left), (0, fallback), "{}", flagged.stdout);
    // The teapot's compute frame leaves about 30 % to the fallback: above the threshold.
    assert!(fallback > 0, "{}", traced.stdout);
    assert!(traced.stderr.contains("resolved only"), "{}", traced.stderr);
    assert!(traced.stderr.contains("likely cause"), "{}", traced.stderr);
    // Negative: the built-in default leaves under 10 %: no warning.
    let default = render("default", &[]);
    // The summary names the criterion of a cube-map tracer: the one asked for, else the default.
    assert!(
        traced.stdout.contains("method compute (centre criterion)"),
        "{}",
        traced.stdout
    );
    assert!(
        default
            .stdout
            .contains("method compute (bounded criterion)"),
        "{}",
        default.stdout
    );
    assert!(
        !default.stderr.contains("resolved only"),
        "{}",
        default.stderr
    );
    // Inward normals: the default scene exported with its reflector's `vn` lines negated.
    let export = dir.path().join("inward");
    export::export(&builtin::by_name("default").unwrap(), &export).unwrap();
    let obj = export.join("mirror-ellipsoid.obj");
    let flipped: String = std::fs::read_to_string(&obj)
        .unwrap()
        .lines()
        .map(|l| match l.strip_prefix("vn ") {
            Some(rest) => {
                let v: Vec<f32> = rest
                    .split_whitespace()
                    .map(|x| x.parse().unwrap())
                    .collect();
                format!("vn {} {} {}\n", -v[0], -v[1], -v[2])
            }
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(&obj, flipped).unwrap();
    // The closed reflector seen from outside has its front turned (`Scene::front_turned`): the
    // method resolves as many pixels itself as with outward normals, and nothing warns.
    let inward = render(export.join("scene.toml").to_str().unwrap(), &[]);
    assert_eq!(
        summary_counts(&inward.stdout),
        summary_counts(&default.stdout),
        "{}\n{}",
        inward.stdout,
        default.stdout
    );
    assert!(
        !inward.stderr.contains("resolved only"),
        "{}",
        inward.stderr
    );
    // Negative: the teapot's warning (open mesh, outward normals) does not blame the normals.
    assert!(!traced.stderr.contains("point inward"), "{}", traced.stderr);
}

/// The centre-sampled criterion is `centre` since the bounded one became the default: the old
/// name `exact` is refused (it would name the unsound one), and the message lists both; a bare
/// `--strict` (a centre-criterion option) names the criterion it needs. Negative: `centre` and
/// `bounded` are taken.
#[test]
fn the_old_criterion_name_is_refused_with_the_new_ones() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &["render", "--criterion", "exact", "-o", "x.png"],
        dir.path(),
    );
    assert_eq!(o.code, Some(2), "{}", o.stderr);
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
    assert!(
        o.stderr.contains("'exact'") && o.stderr.contains("bounded, centre"),
        "{}",
        o.stderr
    );
    let o = run(
        &["render", "--method", "fragment", "--strict", "-o", "x.png"],
        dir.path(),
    );
    assert_clean_failure(&o, &["--strict", "--criterion centre"]);
    assert!(files(dir.path()).is_empty(), "{:?}", files(dir.path()));
    for criterion in ["centre", "bounded"] {
        let args = [
            "render",
            "--criterion",
            criterion,
            "--width",
            "8",
            "--height",
            "6",
            "-o",
            "x.png",
        ];
        let o = run(&args, dir.path());
        assert_eq!(o.code, Some(0), "{criterion}: {}", o.stderr);
    }
}

/// Options the method ignores are refused before anything runs, in the CLI's words; the same
/// options with a method that reads them run.
#[test]
fn options_the_method_ignores_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 6] = [
        (
            &["--method", "compute", "--ssr-iterations", "5"],
            "--ssr-iterations applies only to --method ssr",
        ),
        (&["--method", "bvh", "--strict"], "--strict applies only to"),
        (
            &["--method", "bvh", "--no-accel"],
            "--no-accel applies only to",
        ),
        (
            &["--method", "bvh", "--steps", "5"],
            "--steps applies only to",
        ),
        (
            &["--method", "envmap", "--fallback", "flag"],
            "--fallback applies only to",
        ),
        (
            &["--method", "reference", "--compare"],
            "compare the reference with itself",
        ),
    ];
    for (extra, needle) in cases {
        let mut args = vec!["render", "bowl", "-o", "x.png"];
        args.extend_from_slice(extra);
        let o = run_env(&args, dir.path(), &INFO);
        assert_clean_failure(&o, &[needle]);
        // In the CLI's words, and before the device or the reference's BVH.
        for internal in ["Compute", "Bvh", "Envmap", "Reference", "`method`"] {
            assert!(!o.stderr.contains(internal), "{internal}: {}", o.stderr);
        }
        assert!(!o.stderr.contains(DEVICE_CREATED), "{}", o.stderr);
        assert!(!o.stderr.contains(REFERENCE_STARTED), "{}", o.stderr);
    }
    assert!(files(dir.path()).is_empty(), "{:?}", files(dir.path()));
    // Negative: with a method that reads them, the same options run.
    for extra in [
        &["--method", "ssr", "--ssr-iterations", "5"][..],
        &[
            "--method",
            "fragment",
            "--criterion",
            "centre",
            "--strict",
            "--cube-size",
            "16",
        ],
    ] {
        let mut args = vec![
            "render", "bowl", "-o", "x.png", "--width", "4", "--height", "3",
        ];
        args.extend_from_slice(extra);
        let o = run(&args, dir.path());
        assert_eq!(o.code, Some(0), "{extra:?}: {}", o.stderr);
    }
}

/// Every flag of the table is one of `render`'s or `bench`'s, and every `render` flag outside
/// it is one every method reads (a new method-specific flag must enter the table).
#[test]
fn every_method_specific_flag_is_in_the_table() {
    use clap::CommandFactory;
    #[derive(clap::Parser)]
    struct Render {
        #[command(flatten)]
        args: cubetrace::app::render::RenderArgs,
    }
    #[derive(clap::Parser)]
    struct Bench {
        #[command(flatten)]
        args: cubetrace::app::bench::BenchArgs,
    }
    let flags = |c: clap::Command| -> Vec<String> {
        c.get_arguments()
            .filter_map(|a| a.get_long().map(|l| format!("--{l}")))
            .collect()
    };
    let render = flags(Render::command());
    let bench = flags(Bench::command());
    let table: Vec<&str> = cubetrace::method::METHOD_OPTIONS
        .iter()
        .map(|o| o.flag)
        .collect();
    for flag in &table {
        assert!(
            render.iter().chain(&bench).any(|f| f == flag),
            "{flag} is no flag of render or bench"
        );
    }
    let every_method = [
        "--method",
        "--camera",
        "--width",
        "--height",
        "--bounces",
        "--output",
        "--subdivide",
        "--frames",
        "--skip-existing",
        "--spp",
        "--filter",
        "--shard",
        "--shard-count",
        "--help",
    ];
    for flag in &render {
        assert!(
            table.contains(&flag.as_str()) || every_method.contains(&flag.as_str()),
            "render's {flag} is neither in METHOD_OPTIONS nor read by every method"
        );
    }
    // Negative: a flag that is not there is found missing.
    assert!(!render.iter().chain(&bench).any(|f| f == "--ssr-iteration"));
}

/// `bench` holds its method-specific options against the chosen methods, by the same table.
#[test]
fn bench_refuses_options_no_chosen_method_reads() {
    use clap::Parser;
    #[derive(Parser)]
    struct Bench {
        #[command(flatten)]
        args: cubetrace::app::bench::BenchArgs,
    }
    let check = |extra: &[&str]| {
        let mut a = vec!["bench"];
        a.extend_from_slice(extra);
        let args = Bench::try_parse_from(a).unwrap().args;
        let methods = cubetrace::app::bench::parse_methods(&args.methods).unwrap();
        cubetrace::app::bench::check_options(&args, &methods).map_err(|e| e.to_string())
    };
    let e = check(&["--methods", "envmap,bvh", "--quick"]).unwrap_err();
    assert!(
        e.contains("--quick applies only to --method fragment"),
        "{e}"
    );
    let e = check(&["--methods", "bvh", "--cube-size", "64"]).unwrap_err();
    assert!(e.contains("--cube-size"), "{e}");
    let e = check(&["--scaling", "--cmos", "2"]).unwrap_err();
    assert!(e.contains("--scaling"), "{e}");
    // Negative: one chosen method that reads the option is enough.
    check(&["--methods", "envmap,fragment", "--quick"]).unwrap();
    check(&[
        "--methods",
        "bvh,compute",
        "--cube-size",
        "64",
        "--no-reflector-check",
    ])
    .unwrap();
}

/// The PNG's width and height, from its header.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    let be = |k: usize| u32::from_be_bytes(bytes[k..k + 4].try_into().unwrap());
    (be(16), be(20))
}

#[test]
fn one_frame_side_keeps_the_camera_aspect() {
    use cubetrace::render::scene::frame_size;
    assert_eq!(frame_size((640, 480), None, Some(60)), (80, 60));
    assert_eq!(frame_size((640, 480), Some(100), None), (100, 75));
    assert_eq!(frame_size((640, 480), Some(3), None), (3, 2));
    assert_eq!(frame_size((640, 480), None, Some(1)), (1, 1));
    assert_eq!(frame_size((1, 1000), Some(1), None), (1, 1000));
    assert_eq!(frame_size((1000, 1), Some(10), None), (10, 1), "at least 1");
    // Negative: both sides, or neither, are taken as they are.
    assert_eq!(frame_size((640, 480), Some(64), Some(64)), (64, 64));
    assert_eq!(frame_size((640, 480), None, None), (640, 480));
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &[
            "render",
            "--method",
            "reference",
            "--height",
            "30",
            "-o",
            "h.png",
        ],
        dir.path(),
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert_eq!(png_size(&dir.path().join("h.png")), (40, 30));
    let o = run(&["render", "--help"], dir.path());
    assert!(o.stdout.contains("camera's aspect ratio"), "{}", o.stdout);
}

#[test]
fn a_file_name_too_long_is_refused_before_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let long = format!("{}.png", "a".repeat(300));
    for (method, started) in [
        ("reference", REFERENCE_STARTED),
        ("compute", DEVICE_CREATED),
    ] {
        for out in [long.clone(), format!("new/{long}"), format!("{long}/x.png")] {
            let args = ["render", "bowl", "--method", method, "-o", &out];
            let o = run_env(&args, dir.path(), &INFO);
            assert_clean_failure(&o, &["bytes long", "255"]);
            assert!(!o.stderr.contains(started), "{method}: {}", o.stderr);
        }
    }
    assert!(files(dir.path()).is_empty(), "{:?}", files(dir.path()));
    // Negative: 255 bytes are allowed, and written.
    let ok = format!("{}.png", "b".repeat(251));
    let o = run(
        &[
            "render",
            "bowl",
            "--method",
            "reference",
            "--width",
            "4",
            "--height",
            "3",
            "-o",
            &ok,
        ],
        dir.path(),
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert_eq!(files(dir.path()), [ok]);
}

/// A texture counts in the memory estimate and is named, with its size and the fix, when it
/// does not fit: the device's memory, or the one buffer the textures share.
#[test]
fn a_large_texture_is_named_in_the_refusal() {
    use clap::Parser;
    use cubetrace::memory::Limits;
    #[derive(Parser)]
    struct Render {
        #[command(flatten)]
        args: cubetrace::app::render::RenderArgs,
    }
    let args = Render::try_parse_from(["render", "default", "--width", "64", "--height", "48"])
        .unwrap()
        .args;
    let (mut scene, camera, _) = cubetrace::app::render::load_scene(&args).unwrap();
    let options = cubetrace::app::render::gpu_options(&args).unwrap();
    let before = budget::estimate(&scene, &camera, &options).total();
    scene.textures.push(cubetrace::scene::Texture {
        name: "floor-8k".into(),
        width: 8192,
        height: 8192,
        rgba8: Vec::new(),
    });
    let limits = Limits {
        host: None,
        device: (before + (128 << 20), "the test's limit".into()),
        device_is_host: false,
    };
    let check = |scene: &cubetrace::scene::Scene| {
        cubetrace::render::checks::check_gpu_memory(
            "a 64x48 frame with --method compute",
            scene,
            &camera,
            &options,
            cubetrace::output::Format::Png,
            false,
            "the test device",
            &limits,
        )
    };
    let e = check(&scene).unwrap_err().to_string();
    for needle in [
        "texture 'floor-8k' 8192x8192: 256.0 MiB",
        "scale that texture down",
        "the test's limit",
    ] {
        assert!(e.contains(needle), "'{needle}' in: {e}");
    }
    let e = cubetrace::render::checks::check_textures(&scene, 128 << 20, "lavapipe")
        .unwrap_err()
        .to_string();
    assert!(e.contains("texture 'floor-8k' 8192x8192: 256.0 MiB"), "{e}");
    assert!(e.contains("maxStorageBufferRange = 128.0 MiB"), "{e}");
    assert!(!e.contains("--cube-size"), "not the cube size's fault: {e}");
    // Negative: at 4096^2 (64 MiB) the texture fits both.
    scene.textures.last_mut().unwrap().width = 4096;
    scene.textures.last_mut().unwrap().height = 4096;
    check(&scene).unwrap();
    cubetrace::render::checks::check_textures(&scene, 128 << 20, "lavapipe").unwrap();
}

/// The host phases are logged each under its own name (the reference's BVH no longer takes
/// the time of loading and checking the scene).
#[test]
fn host_phases_are_logged_by_name() {
    let dir = tempfile::tempdir().unwrap();
    for method in ["reference", "bvh"] {
        let o = run_env(
            &[
                "render", "bowl", "--method", method, "--width", "8", "--height", "6", "-o",
                "x.png",
            ],
            dir.path(),
            &INFO,
        );
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        for phase in ["scene load: ", "reflector convexity: ", "scene check: "] {
            assert!(o.stderr.contains(phase), "{method} {phase}: {}", o.stderr);
        }
    }
    // The scene check traces the CMO centres' lines of sight against the other geometry only
    // (no BVH over a reflector of millions of triangles): a centre outside the room is still
    // found, behind the wall.
    let mut scene = builtin::by_name("default").unwrap();
    let at = |z: f32| vec![glam::Vec3::new(0.0, 1.0, z)];
    scene.cmo.placement = cubetrace::scene::CmoPlacement::Explicit(at(50.0));
    let blind = |scene: &cubetrace::scene::Scene| {
        cubetrace::placement::diagnose(scene)
            .iter()
            .any(|p| p.contains("sees none of the reflectors") && p.contains("'room"))
    };
    assert!(blind(&scene));
    // Negative: a centre inside the room sees the mirror.
    scene.cmo.placement = cubetrace::scene::CmoPlacement::Explicit(at(0.0));
    assert!(!blind(&scene));
}

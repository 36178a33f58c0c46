//! Scale-out from the command line: `cubetrace farm slurm|k8s` writes jobs whose tasks run the
//! intended command line (the Slurm script run by bash with a stand-in binary that records its
//! arguments), and `--shard` / the schedulers' array indices pick chunks whose frames are the
//! frames of one run. Every check has its negative.

use crate::common::binary::{self, Outcome};
use std::path::Path;
use std::process::Command;

/// The binary with `args` in `cwd`, with `env` set and no scheduler variables inherited.
fn run_env(args: &[&str], cwd: &Path, env: &[(&str, &str)]) -> Outcome {
    binary::run_with(args, cwd, env, &SCHEDULER_VARS)
}

fn run(args: &[&str], cwd: &Path) -> Outcome {
    run_env(args, cwd, &[])
}

const SCHEDULER_VARS: [&str; 6] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_COUNT",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_MAX",
    "SLURM_ARRAY_TASK_STEP",
    "JOB_COMPLETION_INDEX",
];

/// A clean failure: exit status 1 (2 for clap's usage errors), no panic, every needle in stderr.
fn assert_refused(o: &Outcome, code: i32, needles: &[&str]) {
    assert_eq!(o.code, Some(code), "exit status; stderr: {}", o.stderr);
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
    for n in needles {
        assert!(o.stderr.contains(n), "expected '{n}' in: {}", o.stderr);
    }
}

/// Every file name in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// A stand-in for the cubetrace binary: writes each argument it gets, NUL-terminated, to `log`.
fn recorder(dir: &Path, log: &Path) -> std::path::PathBuf {
    let path = dir.join("record.sh");
    std::fs::write(
        &path,
        format!("#!/bin/sh\nprintf '%s\\0' \"$@\" > '{}'\n", log.display()),
    )
    .unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    path
}

/// Runs the script `script` with bash as Slurm would run array task `task`, the binary replaced
/// by [`recorder`]; the arguments the binary got, or the script's failure.
fn run_task(dir: &Path, script: &Path, task: Option<&str>) -> Result<Vec<String>, Outcome> {
    let log = dir.join("args.bin");
    let _ = std::fs::remove_file(&log);
    let mut cmd = Command::new("bash");
    cmd.arg(script)
        .current_dir(dir)
        .env("CUBETRACE", recorder(dir, &log));
    for k in SCHEDULER_VARS {
        cmd.env_remove(k);
    }
    if let Some(t) = task {
        cmd.env("SLURM_ARRAY_TASK_ID", t);
    }
    let o = Outcome::of(cmd.output().unwrap());
    if o.code != Some(0) {
        return Err(o);
    }
    let bytes = std::fs::read(&log).unwrap();
    Ok(bytes
        .split(|b| *b == 0)
        .filter(|s| !s.is_empty())
        .map(|s| String::from_utf8_lossy(s).into_owned())
        .collect())
}

#[test]
fn the_slurm_script_runs_the_command_line_as_typed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Arguments a shell would split, expand or cut: spaces, quotes, $, #, a glob, a newline.
    let odd = "out dir/it's \"q\" $HOME `x` *-####.png";
    let job = d.join("jobs/render.sbatch");
    let o = run(
        &[
            "farm",
            "slurm",
            "--tasks",
            "5",
            "-o",
            job.to_str().unwrap(),
            "--",
            "render",
            "sphere-room",
            "--width",
            "32",
            "-o",
            odd,
            "--camera",
            "a\nb",
        ],
        d,
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(
        o.stdout.is_empty(),
        "-o writes the file, not stdout: {}",
        o.stdout
    );
    assert!(o.stderr.contains("sbatch"), "{}", o.stderr);
    let text = std::fs::read_to_string(&job).unwrap();
    assert!(text.lines().any(|l| l == "#SBATCH --array=0-4"), "{text}");
    let mut want: Vec<String> = ["render", "sphere-room", "--width", "32", "-o", odd]
        .into_iter()
        .chain(["--camera", "a\nb"])
        .map(String::from)
        .collect();
    want.push("--skip-existing".into());
    for task in ["0", "3"] {
        let mut w = want.clone();
        w.extend(["--shard".into(), format!("{task}/5")]);
        let got = run_task(d, &job, Some(task)).unwrap_or_else(|o| panic!("{}", o.stderr));
        assert_eq!(got, w, "task {task}");
    }
    // Negatives: outside Slurm the script refuses to run; another task gets another shard.
    let e = run_task(d, &job, None).unwrap_err();
    assert!(e.stderr.contains("SLURM_ARRAY_TASK_ID"), "{}", e.stderr);
    let got = run_task(d, &job, Some("1")).unwrap();
    assert_ne!(got.last().map(String::as_str), Some("0/5"));
}

/// `farm k8s -n 6` prints an Indexed Job of 6 completions whose container renders with
/// `--shard-count 6`, and writes nothing. Negative: the manifest of `-n 5` fails the same check.
#[test]
fn the_k8s_manifest_goes_to_stdout_and_names_the_shard_count() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let manifest = |n: &str| {
        let o = run(
            &[
                "farm",
                "k8s",
                "-n",
                n,
                "--image",
                "cubetrace:1",
                "--claim",
                "frames",
                "--",
                "sphere-room",
                "--frames",
                "1..12",
            ],
            d,
        );
        assert_eq!(o.code, Some(0), "-n {n}: {}", o.stderr);
        serde_norway::from_str::<serde_json::Value>(&o.stdout).unwrap()
    };
    // The check: 6 indexed completions, each rendering the run's frames as one of 6 shards.
    let six_shards = |v: &serde_json::Value| -> Result<(), String> {
        let want = serde_json::json!([
            "render",
            "sphere-room",
            "--frames",
            "1..12",
            "--skip-existing",
            "--shard-count",
            "6"
        ]);
        let args = &v["spec"]["template"]["spec"]["containers"][0]["args"];
        if v["spec"]["completions"] != 6 {
            return Err(format!("completions {}", v["spec"]["completions"]));
        }
        if v["spec"]["completionMode"] != "Indexed" {
            return Err(format!("completionMode {}", v["spec"]["completionMode"]));
        }
        if *args != want {
            return Err(format!("args {args}"));
        }
        Ok(())
    };
    six_shards(&manifest("6")).unwrap_or_else(|e| panic!("{e}"));
    assert!(names(d).is_empty(), "stdout only: {:?}", names(d));
    // Negative: 5 tasks are 5 completions of 5 shards.
    six_shards(&manifest("5")).expect_err("negative: -n 5 is not 6 shards");
    assert!(names(d).is_empty(), "stdout only: {:?}", names(d));
}

#[test]
fn bad_farm_jobs_are_refused_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let job = d.join("job.sbatch");
    let j = job.to_str().unwrap();
    let cases: [(&[&str], i32, &[&str]); 5] = [
        (
            &[
                "farm", "slurm", "-n", "2", "-o", j, "--", "a", "--shard", "1/2",
            ],
            1,
            &["--shard"],
        ),
        (
            &["farm", "slurm", "-n", "2", "-o", j, "--", "a", "--bogus"],
            1,
            &["--bogus"],
        ),
        (
            &["farm", "slurm", "-n", "0", "-o", j, "--", "a"],
            2,
            &["--tasks"],
        ),
        (
            &["farm", "k8s", "-n", "2", "-o", j, "--", "a"],
            2,
            &["--image"],
        ),
        (
            &[
                "farm", "slurm", "-n", "2", "-o", j, "--name", "x y", "--", "a",
            ],
            1,
            &["--name"],
        ),
    ];
    for (args, code, needles) in cases {
        let o = run(args, d);
        assert_refused(&o, code, needles);
        assert!(names(d).is_empty(), "{args:?} left {:?}", names(d));
    }
    // Negative: the same command without the problem writes the job.
    let o = run(&["farm", "slurm", "-n", "2", "-o", j, "--", "a"], d);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert_eq!(names(d), vec!["job.sbatch"]);
}

/// The animated scene the sharding tests render (tiny frames).
const SEQ_SCENE: &str = "sphere-room-orbit";
const SEQ_FRAMES: &str = "1..4";

/// Renders `SEQ_FRAMES` of `SEQ_SCENE` into `out` (`f-####.png`) with `extra` flags and `env`.
fn render_frames(out: &Path, extra: &[&str], env: &[(&str, &str)]) -> Outcome {
    let pattern = out.join("f-####.png");
    let mut args = vec![
        "render",
        SEQ_SCENE,
        "--width",
        "24",
        "--frames",
        SEQ_FRAMES,
        "-o",
        pattern.to_str().unwrap(),
    ];
    args.extend(extra);
    run_env(&args, Path::new("."), env)
}

/// One task of a split run: its flags and its environment.
type Task<'a> = (Vec<&'a str>, Vec<(&'a str, String)>);

/// A refused render: its flags, its environment, what the message must say.
type Refusal<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)], &'a [&'a str]);

/// Every file of `dir` with its bytes.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    names(dir)
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).unwrap();
            (n, bytes)
        })
        .collect()
}

#[test]
fn sharded_frames_are_byte_identical_to_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole");
    let o = render_frames(&whole, &[], &[]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let want = contents(&whole);
    assert_eq!(want.len(), 4, "{:?}", names(&whole));
    // --shard over 3; SLURM_ARRAY_TASK_ID over 2 (ids 1..=2, MIN 1); JOB_COMPLETION_INDEX over 5
    // (more tasks than frames: one renders nothing).
    let n3: Vec<String> = (0..3).map(|i| format!("{i}/3")).collect();
    let ways: Vec<(String, Vec<Task>)> = vec![
        (
            "shard3".into(),
            n3.iter()
                .map(|s| (vec!["--shard", s.as_str()], vec![]))
                .collect(),
        ),
        (
            "slurm2".into(),
            (1..=2)
                .map(|id| {
                    let vars = [
                        ("SLURM_ARRAY_TASK_ID", id.to_string()),
                        ("SLURM_ARRAY_TASK_MIN", "1".into()),
                        ("SLURM_ARRAY_TASK_MAX", "2".into()),
                        ("SLURM_ARRAY_TASK_COUNT", "2".into()),
                    ];
                    (vec![], vars.to_vec())
                })
                .collect(),
        ),
        (
            "k8s5".into(),
            (0..5)
                .map(|i| {
                    (
                        vec!["--shard-count", "5"],
                        vec![("JOB_COMPLETION_INDEX", i.to_string())],
                    )
                })
                .collect(),
        ),
    ];
    for (name, tasks) in &ways {
        let out = dir.path().join(name);
        let mut seen = Vec::new();
        for (flags, vars) in tasks {
            let before = names(&out).len();
            let env: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (*k, v.as_str())).collect();
            let o = render_frames(&out, flags, &env);
            assert_eq!(o.code, Some(0), "{name} {flags:?} {vars:?}: {}", o.stderr);
            seen.push(names(&out).len() - before);
        }
        assert_eq!(contents(&out), want, "{name}: tasks wrote {seen:?} frames");
        let (lo, hi) = (seen.iter().min().unwrap(), seen.iter().max().unwrap());
        assert!(hi - lo <= 1, "{name}: unbalanced {seen:?}");
    }
    // Negative: the frames differ from one another, so a task that rendered another index's
    // frame under this name would show.
    for w in want.windows(2) {
        assert_ne!(w[0].1, w[1].1, "{} and {} are equal", w[0].0, w[1].0);
    }
}

#[test]
fn a_wrong_shard_is_refused_before_anything_renders() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let gaps = [
        ("SLURM_ARRAY_TASK_ID", "7"),
        ("SLURM_ARRAY_TASK_MIN", "3"),
        ("SLURM_ARRAY_TASK_MAX", "7"),
        ("SLURM_ARRAY_TASK_COUNT", "2"),
    ];
    let cases: [Refusal; 6] = [
        (&["--shard", "4/4"], &[], &["--shard 4/4", "0-based"]),
        (&["--shard", "0/0"], &[], &["--shard 0/0", "at least 1"]),
        (&["--shard", "1-4"], &[], &["--shard", "I/N"]),
        (&[], &gaps, &["SLURM_ARRAY_TASK_MAX=7", "--shard"]),
        (&[], &[("JOB_COMPLETION_INDEX", "1")], &["--shard-count"]),
        (
            &["--shard-count", "2"],
            &[("JOB_COMPLETION_INDEX", "2")],
            &["JOB_COMPLETION_INDEX=2"],
        ),
    ];
    for (flags, env, needles) in cases {
        let o = render_frames(&out, flags, env);
        assert_refused(&o, 1, needles);
        assert!(
            names(&out).is_empty(),
            "{flags:?} {env:?} wrote {:?}",
            names(&out)
        );
    }
    // Negative: a right shard renders its chunk (frames 3 and 4 of 1..4 for 1/2).
    let o = render_frames(&out, &["--shard", "1/2"], &[]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert_eq!(names(&out), vec!["f-0003.png", "f-0004.png"]);
}

/// A still scene is one frame: a wrong `--shard` is refused as for a sequence, the shard whose
/// chunk holds the frame writes it under the still's name, and the others write nothing.
#[test]
fn a_still_scene_checks_its_shard() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = run(
        &[
            "render",
            "sphere-room",
            "--width",
            "16",
            "--shard",
            "5/2",
            "-o",
            "still.png",
        ],
        d,
    );
    assert_refused(&o, 1, &["--shard"]);
    assert!(names(d).is_empty(), "{:?}", names(d));
    let mut idle = 0;
    for i in 0..2 {
        let shard = format!("{i}/2");
        let o = run(
            &[
                "render",
                "sphere-room",
                "--width",
                "16",
                "--shard",
                &shard,
                "-o",
                "still.png",
            ],
            d,
        );
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        idle += usize::from(o.stdout.contains("nothing to render"));
    }
    // Exactly one of the two shards wrote the still (negative: not both, not neither).
    assert_eq!(idle, 1);
    assert_eq!(names(d), ["still.png"]);
}

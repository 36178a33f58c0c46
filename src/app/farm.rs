#![forbid(unsafe_code)]
//! `cubetrace farm slurm|k8s`: writes a job for an existing scheduler that renders a sequence in
//! chunks, one chunk per array task: a Slurm `sbatch --array` script, or a Kubernetes Indexed
//! Job manifest. Each task runs the given `cubetrace render` command line with its shard
//! ([`super::shard`]) and `--skip-existing`, so a rerun of a failed task (the same index)
//! renders only the frames that are missing.
//!
//! The render command line is checked as `cubetrace render` would check it (clap, and the
//! method's options) before anything is written, and it must not carry shard flags of its own
//! (the job adds them). The Slurm script passes `--shard $SLURM_ARRAY_TASK_ID/N` with `N` fixed
//! in the script, so a resubmission of some indices (`sbatch --array=3,7 FILE`) renders exactly
//! those chunks; the manifest passes `--shard-count N` and the pod's `JOB_COMPLETION_INDEX`
//! gives the chunk. Values are quoted for their target (shell words; YAML strings written as
//! JSON strings, which YAML reads as they are), so any argument arrives as typed.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use clap::{Args, FromArgMatches as _};

use super::render::RenderArgs;
use crate::files;

/// `cubetrace farm slurm|k8s`.
#[derive(clap::Subcommand)]
pub enum FarmCommand {
    /// A Slurm job array script (`sbatch FILE`): task I of `--array=0-(N-1)` renders chunk I of
    /// N of the frames. The script says how failed tasks are rerun: `sbatch --array=3,7 FILE`
    /// (the same indices; --skip-existing keeps the frames already written).
    Slurm(SlurmArgs),
    /// A Kubernetes Indexed Job manifest (`kubectl apply -f FILE`): `completionMode: Indexed`,
    /// `completions: N`; the pod of index I renders chunk I of N (JOB_COMPLETION_INDEX with
    /// --shard-count N). Failed indexes are retried on their own (`backoffLimitPerIndex`); the
    /// manifest says how to rerun the rest.
    K8s(K8sArgs),
}

/// What every farm job has: the task count, the render command line, where the job goes.
#[derive(Args, Debug)]
pub struct JobArgs {
    /// Number of tasks (Slurm array size, Kubernetes completions): the frames are cut into this
    /// many contiguous chunks whose sizes differ by at most one.
    #[arg(long, short = 'n', value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub tasks: u32,
    /// Write the job to FILE (atomically) instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Job name (letters, digits and '-'; for Kubernetes also lower case, at most 63).
    #[arg(long, default_value = "cubetrace")]
    pub name: String,
    /// The binary the tasks run (a Slurm task also honours $CUBETRACE).
    #[arg(long, default_value = "cubetrace")]
    pub binary: String,
    /// The arguments of `cubetrace render` after `--` (a leading `render` is allowed), e.g.
    /// `-- sphere-room --frames 1..48 -o out/orbit-####.png`. Without --shard/--shard-count
    /// (the job adds them); --skip-existing is added when missing.
    #[arg(last = true, required = true, value_name = "RENDER ARGS")]
    pub render: Vec<String>,
}

/// `cubetrace farm slurm`.
#[derive(Args, Debug)]
pub struct SlurmArgs {
    #[command(flatten)]
    pub job: JobArgs,
    /// CPUs per task (`--cpus-per-task`; lavapipe renders on every CPU it gets).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..))]
    pub cpus_per_task: u32,
    /// Partition (`--partition`); default: the cluster's.
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit per task (`--time`, e.g. 1:00:00); default: the partition's.
    #[arg(long)]
    pub time: Option<String>,
    /// Memory per task (`--mem`, e.g. 8G); default: the cluster's.
    #[arg(long)]
    pub mem: Option<String>,
    /// Generic resources per task (`--gres`, e.g. gpu:1).
    #[arg(long)]
    pub gres: Option<String>,
    /// At most this many tasks at once (`--array=0-(N-1)%K`).
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..))]
    pub max_running: Option<u32>,
    /// Each task's log (`--output`; %A: job id, %a: task index).
    #[arg(long, default_value = "cubetrace-%A_%a.out")]
    pub log: String,
}

/// `cubetrace farm k8s`.
#[derive(Args, Debug)]
pub struct K8sArgs {
    #[command(flatten)]
    pub job: JobArgs,
    /// Container image holding the cubetrace binary (and a Vulkan driver).
    #[arg(long)]
    pub image: String,
    /// Pods at once (`parallelism`); default: all (N).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub parallelism: Option<u32>,
    /// Retries of each failed index on its own (`backoffLimitPerIndex`, Kubernetes 1.29+).
    #[arg(long, default_value_t = 2)]
    pub retries: u32,
    /// PersistentVolumeClaim mounted at --mount, the working directory: relative output paths
    /// land there. Without it the frames stay in the pod's own file system and are lost.
    #[arg(long)]
    pub claim: Option<String>,
    /// Where the claim is mounted (the container's working directory).
    #[arg(long, default_value = "/work")]
    pub mount: String,
    /// CPU request per pod (e.g. 4).
    #[arg(long)]
    pub cpu: Option<String>,
    /// Memory request and limit per pod (e.g. 8Gi).
    #[arg(long)]
    pub memory: Option<String>,
    /// GPUs per pod (limit `nvidia.com/gpu`).
    #[arg(long)]
    pub gpus: Option<u32>,
}

/// `cubetrace farm slurm|k8s`: checks the render command line, writes the job.
pub fn farm(command: FarmCommand) -> Result<()> {
    let (job, text) = match &command {
        FarmCommand::Slurm(a) => (&a.job, slurm_script(a)?),
        FarmCommand::K8s(a) => (&a.job, k8s_manifest(a)?),
    };
    match &job.output {
        None => print!("{text}"),
        Some(path) => {
            files::write_atomic(path, text.as_bytes())?;
            let next = match command {
                FarmCommand::Slurm(_) => "sbatch",
                FarmCommand::K8s(_) => "kubectl apply -f",
            };
            eprintln!(
                "wrote {} ({} tasks); start it with: {next} {}",
                path.display(),
                job.tasks,
                shell_word(&path.display().to_string())
            );
        }
    }
    Ok(())
}

/// The render arguments the tasks run (without the shard flags the job adds): checked as
/// `cubetrace render` checks them, a leading `render` dropped, `--skip-existing` added.
pub fn render_command(args: &[String]) -> Result<Vec<String>> {
    let mut args: Vec<String> = args.to_vec();
    if args.first().is_some_and(|a| a == "render") {
        args.remove(0);
    }
    for a in &args {
        for flag in ["--shard", "--shard-count"] {
            if a == flag || a.starts_with(&format!("{flag}=")) {
                bail!(
                    "the render command line has {flag}: the farm job gives each task its \
                     chunk; leave it out (the task count is --tasks)"
                );
            }
        }
    }
    let command = RenderArgs::augment_args(clap::Command::new("cubetrace render"));
    // `-v`/`--verbose` belong to the binary (global flags, valid after `render` too).
    let verbose = |a: &String| {
        a == "--verbose" || (a.len() > 1 && a.starts_with('-') && a[1..].chars().all(|c| c == 'v'))
    };
    let checked = args.iter().filter(|a| !verbose(a)).cloned();
    let matches = command
        .try_get_matches_from(std::iter::once("render".to_string()).chain(checked))
        .map_err(|e| {
            let msg = e.to_string();
            let first = msg.lines().next().unwrap_or_default();
            let first = first.trim_start_matches("error: ");
            anyhow::anyhow!("the render command line after --: {first}")
        })?;
    let render = RenderArgs::from_arg_matches(&matches)?;
    render
        .check_method()
        .map_err(|e| anyhow::anyhow!("the render command line after --: {e:#}"))?;
    if !args.iter().any(|a| a == "--skip-existing") {
        args.push("--skip-existing".into());
    }
    Ok(args)
}

/// A job name: letters, digits, `-` and `_`, at most 63 bytes (`k8s`: a DNS label).
fn check_name(name: &str, k8s: bool) -> Result<()> {
    let ok_char = |c: char| {
        if k8s {
            c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-'
        } else {
            c.is_ascii_alphanumeric() || c == '-' || c == '_'
        }
    };
    let edges = !name.starts_with('-') && !name.ends_with('-');
    if name.is_empty() || name.len() > 63 || !name.chars().all(ok_char) || !edges {
        let rule = if k8s {
            "lower-case letters, digits and '-' (not at either end), at most 63"
        } else {
            "letters, digits, '-' and '_' (no '-' at either end), at most 63"
        };
        bail!("--name {name:?}: a job name is {rule}");
    }
    Ok(())
}

/// A value written into a `#SBATCH` line or a manifest field: one word, no control characters.
fn check_value(flag: &str, value: &str) -> Result<()> {
    if value.is_empty() || value.chars().any(|c| c.is_whitespace() || c.is_control()) {
        bail!("{flag} {value:?}: expected one word without spaces or control characters");
    }
    Ok(())
}

/// `word` as one shell word: as it is when it holds only safe characters, else single-quoted.
pub fn shell_word(word: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "_@%+=:,./-".contains(c);
    if !word.is_empty() && word.chars().all(safe) {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

/// `s` as a YAML string: a JSON string, which YAML reads as the same string.
fn yaml_str(s: &str) -> String {
    serde_json::Value::from(s).to_string()
}

/// The name the comments give the job file.
fn file_name(output: Option<&Path>, default: &str) -> String {
    output.map_or(default.to_string(), |p| {
        shell_word(&p.display().to_string())
    })
}

/// The `sbatch --array` script of `cubetrace farm slurm`.
pub fn slurm_script(a: &SlurmArgs) -> Result<String> {
    let job = &a.job;
    check_name(&job.name, false)?;
    for (flag, v) in [
        ("--partition", &a.partition),
        ("--time", &a.time),
        ("--mem", &a.mem),
        ("--gres", &a.gres),
        ("--log", &Some(a.log.clone())),
    ] {
        if let Some(v) = v {
            check_value(flag, v)?;
        }
    }
    let render = render_command(&job.render)?;
    let n = job.tasks;
    let last = n - 1;
    let file = file_name(job.output.as_deref(), "FILE");
    let throttle = a.max_running.map_or(String::new(), |k| format!("%{k}"));
    let mut s = String::new();
    let _ = writeln!(
        s,
        "#!/bin/bash\n\
         # A Slurm job array of {n} tasks rendering a sequence with cubetrace: task I renders\n\
         # chunk I of {n} of the frames (contiguous chunks whose sizes differ by at most one).\n\
         # Written by `cubetrace farm slurm` (cubetrace {version}).\n\
         #\n\
         # Submit:   sbatch {file}\n\
         # Watch:    squeue --me; each task logs to {log} (%A job id, %a task index).\n\
         # Rerun failed tasks: submit the script again with their indices, e.g. tasks 3 and 7:\n\
         #             sbatch --array=3,7 {file}\n\
         #           The index fixes the chunk (the script passes --shard INDEX/{n} itself), and\n\
         #           --skip-existing keeps every frame a task already wrote, so a rerun renders\n\
         #           only the missing frames; writes are atomic, so a killed task leaves no half\n\
         #           file. Failed indices: `sacct -X -j JOBID --state=F,TO,OOM,NF -o JobID`\n\
         #           (with accounting), else the logs; or rerun all: `sbatch {file}` skips the\n\
         #           frames that exist. CUBETRACE=/path/to/cubetrace overrides the binary.",
        version = env!("CARGO_PKG_VERSION"),
        log = a.log,
    );
    let _ = writeln!(s, "#SBATCH --job-name={}", job.name);
    let _ = writeln!(s, "#SBATCH --array=0-{last}{throttle}");
    let _ = writeln!(s, "#SBATCH --cpus-per-task={}", a.cpus_per_task);
    let _ = writeln!(s, "#SBATCH --output={}", a.log);
    for (key, v) in [
        ("partition", &a.partition),
        ("time", &a.time),
        ("mem", &a.mem),
        ("gres", &a.gres),
    ] {
        if let Some(v) = v {
            let _ = writeln!(s, "#SBATCH --{key}={v}");
        }
    }
    let words: Vec<String> = render.iter().map(|w| shell_word(w)).collect();
    let _ = writeln!(
        s,
        "set -euo pipefail\n\
         : \"${{SLURM_ARRAY_TASK_ID:?submit this script with sbatch (SLURM_ARRAY_TASK_ID is not set)}}\"\n\
         CUBETRACE=${{CUBETRACE:-{binary}}}\n\
         exec \"$CUBETRACE\" render {args} --shard \"$SLURM_ARRAY_TASK_ID/{n}\"",
        binary = shell_word(&job.binary),
        args = words.join(" "),
    );
    Ok(s)
}

/// The Kubernetes Indexed Job manifest of `cubetrace farm k8s`.
pub fn k8s_manifest(a: &K8sArgs) -> Result<String> {
    let job = &a.job;
    check_name(&job.name, true)?;
    check_value("--image", &a.image)?;
    check_value("--mount", &a.mount)?;
    for (flag, v) in [("--cpu", &a.cpu), ("--memory", &a.memory)] {
        if let Some(v) = v {
            check_value(flag, v)?;
        }
    }
    if let Some(c) = &a.claim {
        check_name(c, true).map_err(|_| {
            anyhow::anyhow!("--claim {c:?}: a claim name is lower-case letters, digits and '-'")
        })?;
    } else {
        log::warn!(
            "no --claim: the frames are written inside each pod and lost when it ends; mount a \
             volume (--claim NAME) or write to one the image has"
        );
    }
    let n = job.tasks;
    let mut args = render_command(&job.render)?;
    args.insert(0, "render".into());
    args.extend(["--shard-count".into(), n.to_string()]);
    let list = |v: &[String]| {
        let items: Vec<String> = v.iter().map(|s| yaml_str(s)).collect();
        format!("[{}]", items.join(", "))
    };
    let file = file_name(job.output.as_deref(), "FILE");
    let name = &job.name;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# A Kubernetes Indexed Job of {n} completions rendering a sequence with cubetrace: the pod\n\
         # of index I renders chunk I of {n} of the frames (JOB_COMPLETION_INDEX, --shard-count {n};\n\
         # contiguous chunks whose sizes differ by at most one).\n\
         # Written by `cubetrace farm k8s` (cubetrace {version}).\n\
         #\n\
         # Start:   kubectl apply -f {file}\n\
         # Watch:   kubectl get job {name}; kubectl logs -l batch.kubernetes.io/job-name={name}\n\
         # Failed indexes: each is retried on its own, with the same index, up to {r} times\n\
         #   (backoffLimitPerIndex: Kubernetes 1.29+; on older clusters delete that line). Those\n\
         #   that still failed: kubectl get job {name} -o jsonpath='{{.status.failedIndexes}}'.\n\
         #   Rerun them: kubectl delete job {name} && kubectl apply -f {file}. Every index runs\n\
         #   again and --skip-existing skips the frames already written, so only the missing\n\
         #   ones render (writes are atomic: a killed pod leaves no half file). One chunk by\n\
         #   hand, anywhere: cubetrace render ... --shard INDEX/{n}.",
        version = env!("CARGO_PKG_VERSION"),
        r = a.retries,
    );
    let _ = writeln!(
        s,
        "apiVersion: batch/v1\n\
         kind: Job\n\
         metadata:\n  name: {name_q}\n\
         spec:\n  completionMode: Indexed\n  completions: {n}\n  parallelism: {par}\n  \
         backoffLimitPerIndex: {r}\n  \
         template:\n    spec:\n      restartPolicy: Never\n      containers:\n        \
         - name: render\n          image: {image}\n          command: {command}\n          \
         args: {args}\n          workingDir: {mount}",
        name_q = yaml_str(name),
        par = a.parallelism.unwrap_or(n).min(n),
        r = a.retries,
        image = yaml_str(&a.image),
        command = list(std::slice::from_ref(&job.binary)),
        args = list(&args),
        mount = yaml_str(&a.mount),
    );
    k8s_resources(&mut s, a);
    Ok(s)
}

/// The container's resources and the claim's volume, appended to the manifest.
fn k8s_resources(s: &mut String, a: &K8sArgs) {
    let mut requests = Vec::new();
    let mut limits = Vec::new();
    if let Some(c) = &a.cpu {
        requests.push(format!("cpu: {}", yaml_str(c)));
    }
    if let Some(m) = &a.memory {
        requests.push(format!("memory: {}", yaml_str(m)));
        limits.push(format!("memory: {}", yaml_str(m)));
    }
    if let Some(g) = a.gpus {
        limits.push(format!("nvidia.com/gpu: {g}"));
    }
    if !requests.is_empty() || !limits.is_empty() {
        let _ = writeln!(s, "          resources:");
        for (key, items) in [("requests", &requests), ("limits", &limits)] {
            if !items.is_empty() {
                let _ = writeln!(s, "            {key}:");
                for i in items {
                    let _ = writeln!(s, "              {i}");
                }
            }
        }
    }
    if let Some(claim) = &a.claim {
        let _ = writeln!(
            s,
            "          volumeMounts:\n            - name: frames\n              mountPath: {m}\n      \
             volumes:\n        - name: frames\n          persistentVolumeClaim:\n            \
             claimName: {c}",
            m = yaml_str(&a.mount),
            c = yaml_str(claim),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(subcommand)]
        command: FarmCommand,
    }

    fn parse(args: &[&str]) -> FarmCommand {
        let argv = std::iter::once("farm").chain(args.iter().copied());
        Cli::try_parse_from(argv)
            .unwrap_or_else(|e| panic!("{args:?}: {e}"))
            .command
    }

    fn slurm(args: &[&str]) -> Result<String> {
        match parse(&[&["slurm"], args].concat()) {
            FarmCommand::Slurm(a) => slurm_script(&a),
            FarmCommand::K8s(_) => unreachable!(),
        }
    }

    fn k8s(args: &[&str]) -> Result<String> {
        match parse(&[&["k8s"], args].concat()) {
            FarmCommand::K8s(a) => k8s_manifest(&a),
            FarmCommand::Slurm(_) => unreachable!(),
        }
    }

    /// What is wrong with `script` as the array job of `n` tasks: its `--array` line and the
    /// shard it passes must both say `n`.
    fn slurm_problem(script: &str, n: u32) -> Option<String> {
        let arrays: Vec<&str> = script
            .lines()
            .filter(|l| l.starts_with("#SBATCH --array="))
            .collect();
        let want = format!("#SBATCH --array=0-{}", n - 1);
        if arrays.len() != 1 || !(arrays[0] == want || arrays[0].starts_with(&format!("{want}%"))) {
            return Some(format!("array lines {arrays:?}, want {want}"));
        }
        let exec: Vec<&str> = script.lines().filter(|l| l.starts_with("exec ")).collect();
        let shard = format!("--shard \"$SLURM_ARRAY_TASK_ID/{n}\"");
        if exec.len() != 1 || !exec[0].ends_with(&shard) {
            return Some(format!("exec lines {exec:?}, want one ending in {shard}"));
        }
        None
    }

    #[test]
    fn the_slurm_script_has_the_array_and_the_command_line() {
        for n in [1u32, 3, 8] {
            let ns = n.to_string();
            let s = slurm(&["-n", &ns, "--", "sphere-room", "-o", "out/f-####.png"]).unwrap();
            assert_eq!(slurm_problem(&s, n), None, "{s}");
            // Negative: the check sees a wrong count, in either line.
            assert!(slurm_problem(&s, n + 1).is_some());
            let wrong_shard = s.replace(&format!("/{n}\""), &format!("/{}\"", n + 1));
            assert!(slurm_problem(&wrong_shard, n).is_some());
            let exec = s.lines().find(|l| l.starts_with("exec ")).unwrap();
            assert!(
                exec.contains("render sphere-room -o 'out/f-####.png'"),
                "{exec}"
            );
            assert!(s.starts_with("#!/bin/bash\n"), "{s}");
            assert!(
                s.contains("sbatch --array=3,7"),
                "the rerun is documented: {s}"
            );
        }
        let s = slurm(&[
            "-n",
            "4",
            "--partition",
            "gpu",
            "--time",
            "2:00:00",
            "--gres",
            "gpu:1",
            "--max-running",
            "2",
            "--mem",
            "8G",
            "--",
            "render",
            "sphere-room",
        ])
        .unwrap();
        assert_eq!(slurm_problem(&s, 4), None, "{s}");
        for line in [
            "#SBATCH --array=0-3%2",
            "#SBATCH --partition=gpu",
            "#SBATCH --time=2:00:00",
            "#SBATCH --gres=gpu:1",
            "#SBATCH --mem=8G",
            "#SBATCH --cpus-per-task=4",
        ] {
            assert!(s.lines().any(|l| l == line), "{line} missing: {s}");
        }
        // The #SBATCH lines come before the first command (sbatch stops reading there).
        let first_cmd = s.lines().position(|l| !l.starts_with('#')).unwrap();
        let lines: Vec<&str> = s.lines().collect();
        let last_dir = lines
            .iter()
            .rposition(|l| l.starts_with("#SBATCH"))
            .unwrap();
        assert!(last_dir < first_cmd, "{s}");
    }

    #[test]
    fn shell_words_survive_the_shell() {
        assert_eq!(shell_word("out/f-####.png"), "'out/f-####.png'");
        assert_eq!(shell_word("1..48"), "1..48");
        assert_eq!(shell_word(""), "''");
        assert_eq!(shell_word("it's"), r"'it'\''s'");
        assert_eq!(shell_word("$HOME"), "'$HOME'");
    }

    /// The manifest read back as YAML (into JSON values to walk it).
    fn yaml(text: &str) -> serde_json::Value {
        serde_norway::from_str(text).unwrap_or_else(|e| panic!("not YAML: {e}\n{text}"))
    }

    /// What is wrong with the manifest `v` as the Indexed Job of `n` completions running
    /// `args` (the render arguments, before the shard flags).
    fn k8s_problem(v: &serde_json::Value, n: u32, args: &[&str]) -> Option<String> {
        let spec = &v["spec"];
        let container = &spec["template"]["spec"]["containers"][0];
        let mut want: Vec<String> = std::iter::once("render")
            .chain(args.iter().copied())
            .map(String::from)
            .collect();
        want.extend([
            "--skip-existing".into(),
            "--shard-count".into(),
            n.to_string(),
        ]);
        let checks = [
            (v["apiVersion"] == "batch/v1", "apiVersion"),
            (v["kind"] == "Job", "kind"),
            (spec["completionMode"] == "Indexed", "completionMode"),
            (spec["completions"] == n, "completions"),
            (
                spec["parallelism"]
                    .as_u64()
                    .is_some_and(|p| p >= 1 && p <= u64::from(n)),
                "parallelism",
            ),
            (
                spec["template"]["spec"]["restartPolicy"] == "Never",
                "restartPolicy",
            ),
            (container["args"] == serde_json::json!(want), "args"),
            (container["image"].is_string(), "image"),
        ];
        let bad: Vec<&str> = checks.iter().filter(|c| !c.0).map(|c| c.1).collect();
        (!bad.is_empty()).then(|| format!("wrong {bad:?}, want args {want:?}, in {v:#}"))
    }

    #[test]
    fn the_k8s_manifest_is_an_indexed_job_in_yaml() {
        let odd = "out dir/it's \"#\" $HOME-####.png";
        for n in [1u32, 5] {
            let ns = n.to_string();
            let text = k8s(&[
                "-n",
                &ns,
                "--image",
                "registry.example/cubetrace:1",
                "--claim",
                "frames",
                "--cpu",
                "4",
                "--memory",
                "8Gi",
                "--gpus",
                "1",
                "--",
                "sphere-room",
                "-o",
                odd,
            ])
            .unwrap();
            let v = yaml(&text);
            assert_eq!(k8s_problem(&v, n, &["sphere-room", "-o", odd]), None);
            // Negatives: another count, other arguments.
            assert!(k8s_problem(&v, n + 1, &["sphere-room", "-o", odd]).is_some());
            assert!(k8s_problem(&v, n, &["sphere-room", "-o", "x.png"]).is_some());
            let spec = &v["spec"];
            assert_eq!(spec["backoffLimitPerIndex"], 2);
            let pod = &spec["template"]["spec"];
            assert_eq!(
                pod["volumes"][0]["persistentVolumeClaim"]["claimName"],
                "frames"
            );
            let c = &pod["containers"][0];
            assert_eq!(c["volumeMounts"][0]["mountPath"], "/work");
            assert_eq!(c["workingDir"], "/work");
            assert_eq!(c["resources"]["limits"]["nvidia.com/gpu"], 1);
            assert_eq!(c["resources"]["requests"]["memory"], "8Gi");
            assert!(text.contains("failedIndexes") && text.contains("--skip-existing"));
        }
        // Without a claim there is no volume, and the parallelism option is capped at N.
        let v = yaml(&k8s(&["-n", "3", "--image", "x", "--parallelism", "9", "--", "a"]).unwrap());
        assert_eq!(k8s_problem(&v, 3, &["a"]), None);
        assert_eq!(v["spec"]["parallelism"], 3);
        assert!(v["spec"]["template"]["spec"]["volumes"].is_null());
        // Negative: a manifest broken by one indentation is no longer the same document.
        let text = k8s(&["-n", "3", "--image", "x", "--", "a"]).unwrap();
        let broken = text.replace("\n  completions:", "\ncompletions:");
        let parsed: Result<serde_json::Value, _> = serde_norway::from_str(&broken);
        assert!(parsed.map_or(true, |v| k8s_problem(&v, 3, &["a"]).is_some()));
    }

    #[test]
    fn bad_jobs_are_refused_by_name() {
        let e = slurm(&["-n", "2", "--", "a", "--shard", "0/2"]).unwrap_err();
        assert!(format!("{e:#}").contains("has --shard"), "{e:#}");
        let e = k8s(&["-n", "2", "--image", "x", "--", "a", "--shard-count=2"]).unwrap_err();
        assert!(format!("{e:#}").contains("has --shard-count"), "{e:#}");
        // -v is the binary's own flag, kept as given.
        let s = slurm(&["-n", "2", "--", "a", "-vv", "--verbose"]).unwrap();
        assert!(s.contains("render a -vv --verbose"), "{s}");
        let e = slurm(&["-n", "2", "--", "a", "-vx"]).unwrap_err();
        assert!(format!("{e:#}").contains("'-v'"), "{e:#}");
        let e = slurm(&["-n", "2", "--", "a", "--no-such-flag"]).unwrap_err();
        assert!(format!("{e:#}").contains("--no-such-flag"), "{e:#}");
        let e = slurm(&["-n", "2", "--", "a", "--method", "reference", "--compare"]).unwrap_err();
        assert!(format!("{e:#}").contains("--compare"), "{e:#}");
        let e = slurm(&["-n", "2", "--name", "a b", "--", "a"]).unwrap_err();
        assert!(format!("{e:#}").contains("--name"), "{e:#}");
        let e = k8s(&["-n", "2", "--image", "x", "--name", "Upper", "--", "a"]).unwrap_err();
        assert!(format!("{e:#}").contains("--name \"Upper\""), "{e:#}");
        let e = slurm(&["-n", "2", "--time", "1:00\n#SBATCH --x", "--", "a"]).unwrap_err();
        assert!(format!("{e:#}").contains("--time"), "{e:#}");
        let e = k8s(&["-n", "2", "--image", "x", "--claim", "A_b", "--", "a"]).unwrap_err();
        assert!(format!("{e:#}").contains("--claim"), "{e:#}");
        // clap refuses a zero task count and a missing render command line.
        let argv = ["farm", "slurm", "-n", "0", "--", "a"];
        assert!(Cli::try_parse_from(argv).is_err());
        assert!(Cli::try_parse_from(["farm", "slurm", "-n", "2"]).is_err());
        assert!(Cli::try_parse_from(["farm", "k8s", "-n", "2", "--", "a"]).is_err());
    }
}

//! The built `cubetrace` binary run as a user runs it: in a folder, with `XDG_RUNTIME_DIR` set
//! (the Vulkan loader's warnings about it are noise in the messages under test).

use std::path::Path;
use std::process::{Command, Output};

/// A finished run: its exit status and its output as text.
#[derive(Debug)]
pub struct Outcome {
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Outcome {
    pub fn of(out: Output) -> Outcome {
        Outcome {
            code: out.status.code(),
            stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        }
    }
}

/// The binary with `args` in `cwd`, with the variables of `unset` removed and `env` set.
pub fn run_with(args: &[&str], cwd: &Path, env: &[(&str, &str)], unset: &[&str]) -> Outcome {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubetrace"));
    cmd.args(args)
        .current_dir(cwd)
        .env("XDG_RUNTIME_DIR", "/tmp");
    for k in unset {
        cmd.env_remove(k);
    }
    for (k, v) in env {
        cmd.env(k, v);
    }
    Outcome::of(cmd.output().unwrap())
}

/// The binary with `args` in `cwd`, with `env` set.
pub fn run_env(args: &[&str], cwd: &Path, env: &[(&str, &str)]) -> Outcome {
    run_with(args, cwd, env, &[])
}

/// The binary with `args` in `cwd`.
pub fn run(args: &[&str], cwd: &Path) -> Outcome {
    run_with(args, cwd, &[], &[])
}

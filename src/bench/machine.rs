#![forbid(unsafe_code)]
//! What a bench report was measured on: the device ([`DeviceInfo`]), the threads of a CPU
//! driver ([`driver_threads`]) and the commit ([`git_commit`]).

use serde::Serialize;

use crate::vk::GpuContext;

/// The device a run was measured on.
#[derive(Clone, Debug, Serialize)]
pub struct DeviceInfo {
    pub name: String,
    pub driver_name: Option<String>,
    pub driver_info: Option<String>,
    pub api_version: String,
    pub subgroup_size: u32,
    pub timestamps: bool,
}

impl DeviceInfo {
    pub fn of(ctx: &GpuContext) -> Self {
        let r = ctx.report();
        DeviceInfo {
            name: r.name.clone(),
            driver_name: r.driver_name.clone(),
            driver_info: r.driver_info.clone(),
            api_version: format!(
                "{}.{}.{}",
                r.api_version.0, r.api_version.1, r.api_version.2
            ),
            subgroup_size: r.subgroup_size,
            timestamps: r.timestamps_supported(),
        }
    }

    /// `name (driver_name driver_info)`.
    pub fn describe(&self) -> String {
        let driver = [self.driver_name.as_deref(), self.driver_info.as_deref()]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>()
            .join(" ");
        format!(
            "{} ({driver}, Vulkan {}, subgroup size {})",
            self.name, self.api_version, self.subgroup_size
        )
    }
}

/// [`BenchReport::driver_threads`](super::BenchReport::driver_threads) of this process.
pub fn driver_threads() -> usize {
    std::env::var("LP_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// The commit being measured: the one the binary was built from (`CUBETRACE_GIT_COMMIT`, which
/// `build.rs` sets from the checkout's `git rev-parse HEAD`; a working tree's changes beyond it
/// are not told), else `git rev-parse HEAD` in the current folder; `None` when neither is
/// available (no failure).
pub fn git_commit() -> Option<String> {
    if let Some(built) = option_env!("CUBETRACE_GIT_COMMIT") {
        return Some(built.to_string());
    }
    std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
}

#[cfg(test)]
mod tests {
    use super::git_commit;

    /// Built in a git checkout, the recorded commit is the checkout's HEAD at build time (the
    /// test binary is built from it), a full object name; a folder without git changes nothing.
    #[test]
    fn the_recorded_commit_is_the_one_built() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let head = std::process::Command::new("git")
            .args(["rev-parse", "HEAD"])
            .current_dir(root)
            .output()
            .ok()
            .filter(|o| o.status.success() && root.join(".git").is_dir());
        let Some(head) = head else {
            return;
        };
        let Some(built) = option_env!("CUBETRACE_GIT_COMMIT") else {
            panic!("built in a git checkout without CUBETRACE_GIT_COMMIT");
        };
        assert_eq!(built, String::from_utf8_lossy(&head.stdout).trim());
        assert!(built.len() == 40 && built.chars().all(|c| c.is_ascii_hexdigit()));
        assert_eq!(git_commit().as_deref(), Some(built));
    }
}

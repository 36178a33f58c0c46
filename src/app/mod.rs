#![forbid(unsafe_code)]
//! The commands of the `cubetrace` binary as library functions: `main.rs` parses the command
//! line (clap) into the argument structs defined here and calls one function per command.
//!
//! - [`render`]: `cubetrace render` (one frame of one method, optionally compared with the
//!   reference); [`summary`]: its summary line and the fallback's warning.
//! - [`sequence`]: `cubetrace render` of several frames (`--frames`, an animated scene), with
//!   [`frames`]: the sequence flags, frame lists and output names.
//! - [`bench`](mod@bench): `cubetrace bench` (the harness of [`crate::bench`] and its scaling curves).
//! - [`export`]: `cubetrace scene export`.
//! - [`farm`]: `cubetrace farm slurm|k8s` (a scheduler's job that renders a sequence in chunks).
//! - [`shard`]: which chunk of a frame range a run renders (`--shard`, scheduler array indices).
//! - [`info`], [`scenes`]: the two listing commands.
//!
//! Invariants: every check that can refuse a command (arguments, scene, output path, memory)
//! runs before the work it protects, and a refusal is an `Err` with a message naming the
//! argument or file; nothing here exits the process or prints an error itself (`main` does).
//! The argument structs are the command line's: their doc comments are its `--help`.

pub mod bench;
pub mod export;
pub mod farm;
pub mod frame_renderer;
pub mod frames;
pub mod glossy;
pub mod options;
pub mod render;
pub mod sequence;
pub mod shard;
pub mod summary;

use anyhow::Result;

use crate::scene;
use crate::vk::{ContextOptions, GpuContext, Validation};

/// Vulkan device choice and validation.
#[derive(clap::Args, Clone, Copy, Debug)]
pub struct GpuArgs {
    /// Vulkan device index (see `cubetrace info`); default: a discrete GPU if any, else the first.
    #[arg(long)]
    pub device: Option<usize>,
    /// Run under the Khronos validation layer (also: CUBETRACE_VALIDATION=1); fails if it is not
    /// installed (Debian: vulkan-validationlayers).
    #[arg(long)]
    pub validate: bool,
}

impl GpuArgs {
    /// The validation choice: required with `--validate`, else the environment's default.
    pub fn validation(&self) -> Validation {
        if self.validate {
            Validation::Required
        } else {
            Validation::default()
        }
    }

    /// The GPU context of the chosen device.
    pub fn context(&self) -> Result<GpuContext> {
        Ok(GpuContext::new(ContextOptions {
            validation: self.validation(),
            device_index: self.device,
        })?)
    }
}

/// `cubetrace info`: one line per Vulkan device.
pub fn info(gpu: GpuArgs) -> Result<()> {
    for d in GpuContext::list_devices(gpu.validation())? {
        println!("{d}");
    }
    Ok(())
}

/// `cubetrace scenes`: one line per built-in scene.
pub fn scenes() {
    for (name, about) in scene::builtin::all() {
        println!("{name:<17} {about}");
    }
}

#![forbid(unsafe_code)]
//! The commands of the `cubetrace` binary as library functions: `main.rs` parses the command
//! line (clap) into the argument structs defined here and calls one function per command.
//!
//! - [`render`]: `cubetrace render` (one frame of one method, optionally compared with the
//!   reference): its arguments, the scene they prepare, the [`crate::render::RenderSetup`] they
//!   give the frame engine ([`crate::render`]) and the lines it prints; [`summary`]: its
//!   summary line and the fallback's warning.
//! - [`options`]: the tracer and fallback options of `render` and how they become the
//!   renderer's options and the scene's CMO overrides.
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
//! The argument structs are the command line's: their doc comments are its `--help`. The frames
//! themselves (the renderer and its reuse, the samples, the checks, the writer) are
//! [`crate::render`]'s.

pub mod bench;
pub mod export;
pub mod farm;
pub mod frames;
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

    /// How to create the GPU context of the chosen device.
    pub fn context_options(&self) -> ContextOptions {
        ContextOptions {
            validation: self.validation(),
            device_index: self.device,
        }
    }

    /// The GPU context of the chosen device.
    pub fn context(&self) -> Result<GpuContext> {
        Ok(GpuContext::new(self.context_options())?)
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

#![forbid(unsafe_code)]
//! The frame engine between the commands above ([`crate::app`], [`crate::bench`]) and the
//! Vulkan backend below ([`crate::vk`]): everything that turns a prepared scene into frames,
//! for `cubetrace render` and for the frames the bench times alike.
//!
//! - [`session`]: [`FrameRenderer`], the frames of one run through one code path, and its reuse
//!   rules (camera only, geometry in place, rebuild); [`RenderSetup`], the plain value it is
//!   opened from; [`RenderedFrame`] and its writer (PNG or EXR, [`crate::output`]).
//! - [`scene`]: the run's scene prepared from a plain [`scene::SceneSetup`] (loaded once,
//!   overridden, subdivided, its camera sized and checked, its placement searched), which
//!   `render` builds from its arguments and the bench from its configuration.
//! - [`samples`]: the sample loop of the GPU and of the reference (jittered cameras, lobe
//!   sample keys, the film), which the frame renderer and the bench's Monte Carlo frames share.
//! - [`checks`]: the checks around a render: memory and textures before, validation after.
//! - [`timed`]: frames timed one after another on the caller's device (the bench's runs: whole
//!   frames, a sequence's frames, Monte Carlo frames).
//! - [`glossy`]: glossy reflectors: the warning for a method that cannot sample their lobe, and
//!   the converged reference and Monte Carlo frames a glossy frame is measured with.
//!
//! Nothing here parses arguments or prints a line (it logs, and a large reference frame draws a
//! progress bar on a terminal): a refusal is an `Err` naming what to change, and the commands
//! say the rest.

pub mod checks;
pub mod glossy;
pub mod samples;
pub mod scene;
pub mod session;
pub mod timed;

pub use checks::check_validation;
pub use samples::SampleFrame;
pub use session::{
    FrameRenderer, FrameSetup, RenderSetup, RenderedFrame, RendererUse, SceneChange, classify,
};

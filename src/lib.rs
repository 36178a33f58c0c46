//! cubetrace: accurate mirror reflections on curved surfaces by cubemap tracing.
//!
//! Module map (everything outside [`vk`] forbids `unsafe`):
//! - [`app`]: the commands of the `cubetrace` binary (render, bench, scene export) as functions.
//! - [`method`]: [`Method`], the one method type of the CLI, the harness and the renderer.
//! - [`scene`]: the scene as data: scene files (TOML + OBJ/MTL/PNG), built-in scenes, mesh
//!   hygiene. It imports no algorithm (only the leaves [`camera`], [`shading`], [`files`] and
//!   [`lobe`]).
//! - [`placement`]: CMO placement search and set-up checks, algorithms over the scene.
//! - [`camera`]: the camera and its pixel convention (Vulkan's, pixel centres at +0.5).
//! - [`shading`]: the view-independent shading shared by the capture and the reference.
//! - [`reference`](mod@reference): the exact CPU ray tracer that every accuracy figure is measured against.
//! - [`bench`](mod@bench): the speed-against-error harness (`cubetrace bench`) and scaling curves.
//! - [`metrics`]: error of a traced reflection against the reference.
//! - [`ranges`]: depth ranges and ray length of a GPU frame, and the f32 precision check.
//! - [`output`]: PNG and EXR writers, and the meaning of every EXR channel.
//! - [`film`]: samples per pixel and the pixel filter.
//! - [`lobe`]: glossy reflectors: the Phong lobe, its mirror cap and its sample directions.
//! - [`files`]: atomic file writes (temporary file, then rename) and safe file names.
//! - [`cubemap`]: cube face mapping and distance hierarchies (pure data, no GPU).
//! - [`cpu`]: CPU twins of the GPU passes, with the shaders' names and loop structure.
//! - [`model`]: the SIMT cost model: lockstep warp replay of the CPU twins' work counters.
//! - [`vk`]: the Vulkan backend (ash); the only module tree that may use `unsafe`.
#![deny(unsafe_op_in_unsafe_fn)]

pub mod app;
pub mod bench;
pub mod camera;
pub mod cpu;
pub mod cubemap;
pub mod files;
pub mod film;
pub mod lobe;
pub mod memory;
pub mod method;
pub mod metrics;
pub mod model;
pub mod output;
pub mod placement;
pub mod ranges;
pub mod reference;
pub mod scene;
pub mod shading;
pub mod vk;

pub use method::Method;

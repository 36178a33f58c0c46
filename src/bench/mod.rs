#![forbid(unsafe_code)]
//! The speed-against-error harness behind `cubetrace bench` (and `cargo bench --bench paths`).
//!
//! The bench keeps the grids, the figures of each run and the reports; every frame it times is
//! rendered by the frame engine ([`crate::render`]: [`crate::render::timed`] on the bench's one
//! device, the glossy frames through [`crate::render::glossy`]), as `cubetrace render` renders it.
//!
//! A run is one scene x one [`MethodSpec`]. Each GPU run builds one renderer
//! ([`crate::render::timed::TimedRenderer`], everything allocated once), renders `warmup`
//! frames that are thrown away, then `frames` timed frames. It reports, per pass, the median, min
//! and max of the GPU timestamps; the tracing pass's median per mirror pixel; the mean `cells`,
//! `texels` and `traces` counters of the pixel records over mirror pixels; the CMO memory; and the
//! error of the **last** frame against the exact CPU reference
//! ([`metrics::compare`](crate::metrics::compare), plus the FLIP mean over mirror pixels).
//! `reference` runs on the CPU: its time is wall-clock, its tracing cost the phase that traces the
//! reflected rays ([`reference::render_phased`](crate::reference::render_phased)), its error zero
//! by definition (it is the yardstick), and it appears in the table but not in the plot. Per scene,
//! [`SceneRatios`] sets the default settings' costs per ray side by side, and each GPU method's
//! default setting is timed again at a 16x12 frame ([`FloorRun`]) to expose a fixed per-pass cost.
//!
//! Invariants:
//! - Every figure comes from the frames of this run; nothing is extrapolated. Frames are
//!   deterministic, so the last frame's error is every frame's error.
//! - A method is a [`Method`] plus tracer options; the grid ([`fragment_grid`]) sweeps the options
//!   of every kind for which [`Method::traces_cubemaps`] holds, so a new GPU method (compute) is
//!   one [`Method`] variant.
//! - "Cost" in the plot and in `ns/mirror px` is the tracing pass alone (`fragment_trace`,
//!   `envmap`): capture, pyramid and G-buffer are listed per pass but are the same for every
//!   tracing method of a scene and are not what the methods trade against error.

pub mod glossy;
pub mod heatmap;
pub mod model;
pub mod plot;
pub mod report;
pub mod scaling;
pub mod sequence;

mod config;
mod machine;
mod prepare;
mod ratios;
mod results;
mod runner;
mod runs;
mod spec;
mod stats;

/// The validation check after the runs is the renderer's ([`crate::render::checks`]).
pub use crate::render::checks::check_validation;
pub use config::{BenchConfig, BenchPlacement, COMPARE_SPP, FLOOR_FRAME};
pub use machine::{DeviceInfo, driver_threads, git_commit};
pub use prepare::{check_memory, prepare_scene, prepare_scene_judged, prepare_scene_placed};
pub use ratios::SceneRatios;
pub use results::{FloorRun, RunResult};
pub use runner::{BenchReport, run};
pub use runs::{
    GpuRun, ReferenceRun, flip_mean, run_gpu, run_gpu_with, run_reference, run_reference_bounces,
};
pub use spec::{MethodSpec, RP_BENCH_SUBDIVIDE, fragment_grid, method_grid, with_bvh_bounces};
pub use stats::{Counters, PassStats, Stats, frame_stats, pass_stats};

pub use crate::method::Method;

//! Lockstep replay of per-ray work in warps, in two modes (issue 25, item 3).
//!
//! (Being built: see the module docs once the replay lands.)
#![forbid(unsafe_code)]

use serde::Serialize;

use crate::method::Method;
use crate::scene::Scene;

/// How a warp issues a block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// A block issues when at least one lane of the warp needs it; a loop runs until its last
    /// lane leaves, and not at all when no lane enters it.
    Gpu,
    /// Lavapipe: every block of a loop body runs on every turn that any lane makes (masked),
    /// and a loop's body runs at least once.
    Lavapipe,
}

/// How compute_trace lays a ray over lanes (`vk::methods::compute::ray_lanes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ComputeLanes {
    /// `main`: min(width, 32) lanes per ray (the thesis layout).
    Thesis,
    /// `main_lanes1`: one lane per ray (what CPU devices, lavapipe, run).
    One,
    /// `One` in lavapipe mode, `Thesis` in GPU mode (what `ray_lanes` picks).
    Auto,
}

/// The byte layout of texel and node addresses for the sector count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TexelLayout {
    /// The GPU buffers' actual layout: row-major per face, faces in order, CMOs in order.
    Linear,
    /// 4x2-texel tiles of 8 4-byte texels (one 32-byte sector per tile), tiles row-major.
    Tiled,
}

/// What the model needs of one frame beside the scene and method (the bench's settings).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelSettings {
    /// Cube map size N (texels per face side).
    pub cube: u32,
    /// Image size in pixels.
    pub width: u32,
    pub height: u32,
    /// compute_trace's lane layout.
    pub compute_lanes: ComputeLanes,
    /// Texel layout for the memory transactions.
    pub layout: TexelLayout,
}

impl ModelSettings {
    /// The defaults for a frame: `ComputeLanes::Auto`, `TexelLayout::Linear`.
    pub fn new(cube: u32, width: u32, height: u32) -> ModelSettings {
        ModelSettings {
            cube,
            width,
            height,
            compute_lanes: ComputeLanes::Auto,
            layout: TexelLayout::Linear,
        }
    }
}

/// The replay's outputs for one method, scene, width and mode.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplayStats {
    pub method: Method,
    pub width: u32,
    pub mode: Mode,
    pub rays: usize,
    /// Issued warp-steps per ray, per block (index = position in `work::blocks(method)`).
    pub steps_per_ray: Vec<f64>,
    /// Active lanes over issued lanes, over all issued blocks.
    pub simd_efficiency: f64,
    /// Distinct 32-byte sectors per warp load, summed, per ray.
    pub sectors_per_ray: f64,
}

/// Runs the CPU twins of `method` on `scene`'s rays under `settings` and replays them in warps
/// of `width` lanes in `mode`.
pub fn model_frame(
    scene: &Scene,
    method: Method,
    settings: &ModelSettings,
    width: u32,
    mode: Mode,
) -> anyhow::Result<ReplayStats> {
    let _ = (scene, settings, width, mode);
    anyhow::bail!("model: --method {} is not built yet", method.name())
}

#![forbid(unsafe_code)]
//! What a bench run is asked to do ([`BenchConfig`]) and the CMO placements of its placement
//! axis ([`BenchPlacement`]).

use std::path::PathBuf;

use serde::Serialize;

use super::spec::{MethodSpec, method_grid};
use crate::method::Method;
use crate::scene;
use crate::vk::frame::RenderOptions;

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// Built-in scene names or scene file paths.
    pub scenes: Vec<String>,
    pub methods: Vec<MethodSpec>,
    pub width: u32,
    pub height: u32,
    /// Timed frames per run (at least 1).
    pub frames: u32,
    /// Frames rendered and thrown away before timing.
    pub warmup: u32,
    /// Overrides the scenes' cube face size.
    pub cube_size: Option<u32>,
    /// Overrides the scenes' CMO placement with this many automatic CMOs.
    pub cmos: Option<u32>,
    /// The CMO placements each scene runs with (`--placement`): one run of every method per
    /// scene and placement.
    pub placements: Vec<BenchPlacement>,
    /// Compute FLIP (nv-flip) over mirror pixels (needs the `flip` feature, on by default).
    pub flip: bool,
    /// Write per-run error heat maps.
    pub heatmaps: bool,
    /// Also time each GPU method's default setting at this small frame size, to expose a fixed
    /// per-pass cost (the "floor": small frame time / full frame time, near 0 when the pass
    /// costs per ray).
    pub floor: Option<(u32, u32)>,
    /// Reflections per path (`--bounces`), for the reference and the GPU methods that trace
    /// more than one (`compute`, `fragment` with the centre criterion, `bvh`); with N != 1 the
    /// others are skipped, and the error figures compare each path's last hit.
    pub bounces: u32,
    /// [`RenderOptions::reflector_check`] for the GPU runs (`--no-reflector-check`: off).
    pub reflector_check: bool,
    /// Scenes with a glossy reflector: samples per pixel of the converged reference their
    /// frames are measured against (`--compare-spp`). A reflected ray's hit is there one sample
    /// of the lobe, so hits are not compared ([`crate::metrics::compare_colour`]).
    pub compare_spp: u32,
    pub out: PathBuf,
}

impl Default for BenchConfig {
    /// Every built-in still scene, reference + envmap + the fragment grid, 160x120, 1 + 5 frames:
    /// about two minutes on lavapipe (2 cores).
    fn default() -> Self {
        BenchConfig {
            scenes: scene::builtin::NAMES
                .iter()
                .map(|(n, _)| n.to_string())
                .collect(),
            methods: method_grid(&Method::ALL, false),
            width: 160,
            height: 120,
            frames: 5,
            warmup: 1,
            cube_size: None,
            cmos: None,
            placements: vec![BenchPlacement::Scene],
            flip: true,
            heatmaps: true,
            floor: Some(FLOOR_FRAME),
            bounces: RenderOptions::default().bounces,
            reflector_check: RenderOptions::default().reflector_check,
            compare_spp: COMPARE_SPP,
            out: PathBuf::from("out/bench"),
        }
    }
}

/// The default [`BenchConfig::compare_spp`], as `render --compare-spp`.
pub const COMPARE_SPP: u32 = 256;

/// The small frame of the floor measurement ([`BenchConfig::floor`]).
pub const FLOOR_FRAME: (u32, u32) = (16, 12);

/// A CMO placement of the bench's placement axis (`--placement`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum BenchPlacement {
    /// The scene's own `[cmo]` (a scene file without centres: the search).
    Scene,
    /// `placement = "axis"`: `--cmos N` (else the scene's count, else 1) along the reflectors'
    /// longest axis.
    Axis,
    /// The placement search ([`crate::placement`]): up to `--cmos N` (else the scene's count,
    /// else [`crate::scene::DEFAULT_SEARCH_CMOS`]).
    Auto,
}

impl BenchPlacement {
    /// The scene's label in a run of this placement: the name, with the placement after it
    /// where the axis has more than one.
    pub fn label(self, name: &str, several: bool) -> String {
        if several {
            let p = match self {
                BenchPlacement::Scene => "scene",
                BenchPlacement::Axis => "axis",
                BenchPlacement::Auto => "auto",
            };
            format!("{name} [{p}]")
        } else {
            name.to_string()
        }
    }
}

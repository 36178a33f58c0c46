#![forbid(unsafe_code)]
//! The result of one scene x method ([`RunResult`]) and of its floor run ([`FloorRun`]).

use serde::Serialize;

use super::stats::{Counters, PassStats, Stats};
use crate::method::Method;
use crate::metrics::ErrorReport;
use crate::vk::frame::RoundCount;

/// The result of one scene x method.
#[derive(Clone, Debug, Serialize)]
pub struct RunResult {
    pub scene: String,
    /// What the scene was loaded from: the `--scenes` entry (a built-in's name or a scene file's
    /// path), so that a later step (the cost model, `--model-from`) can load it again.
    pub source: String,
    pub method: String,
    pub kind: Method,
    /// Tracer options as text (criterion, sampling, accel, steps, eps); empty for non-tracers.
    pub params: String,
    pub width: u32,
    pub height: u32,
    pub cube_size: u32,
    pub cmos: u32,
    pub triangles: usize,
    pub mirror_pixels: usize,
    /// Rays the tracing pass traced: the method's own mirror pixels (GPU), or the reference's
    /// first reflected rays.
    pub rays: usize,
    pub frames: u32,
    /// Per pass, in recording order (GPU methods).
    pub passes: Vec<PassStats>,
    /// The method's own pass (GPU), or the wall time of the reference's reflected-ray phase
    /// ([`reference::render_phased`](crate::reference::render_phased)), ns.
    pub trace_ns: Stats,
    /// Sum of all passes per frame (GPU, the `trace` fallback included) or the whole frame's
    /// wall time (reference), ns.
    pub total_ns: Stats,
    /// Share of the mirror pixels the method left unresolved and the `trace` fallback finished
    /// (the bench renders with [`Fallback::Trace`](crate::vk::options::Fallback::Trace), the
    /// default; 0 for the reference, `bvh` and `envmap`, which leave none).
    pub fallback_share: f64,
    /// The `fallback` pass (queue + BVH trace of those rays), ns; zero where it did not run.
    pub fallback_ns: Stats,
    /// Share of the traced rays whose record the reflector check changed (a nearer hit on a
    /// reflector; [`crate::vk::passes::bvh::ReflectorCheck`]); 0 where it did not run. Not part of
    /// `fallback_share`.
    pub checked_share: f64,
    /// The `reflector_check` pass, ns; zero where it did not run.
    pub check_ns: Stats,
    /// Median of `trace_ns` per mirror pixel of the reference.
    pub trace_ns_per_mirror_px: f64,
    /// Median of `trace_ns` per traced ray (`rays`).
    pub ns_per_ray: f64,
    /// The tracing pass at the [`BenchConfig::floor`](super::BenchConfig::floor) frame size, for
    /// the default setting of each GPU method.
    pub floor: Option<FloorRun>,
    pub counters: Counters,
    /// Bytes of GPU memory of the CMO data (0 for the reference).
    pub cmo_bytes: u64,
    pub error: ErrorReport,
    /// [`metrics::wrong_surface_off_reflector`](crate::metrics::wrong_surface_off_reflector): wrong
    /// surfaces among the mirror pixels whose reference hit is a non-reflector object (the verified
    /// hits' target; 0 for the reference, NaN where no such pixel exists).
    pub wrong_off_reflector: f64,
    /// FLIP mean over mirror pixels (LDR, sRGB 8-bit, 67 pixels per degree), if computed.
    pub flip_mean: Option<f64>,
    /// The error heat map, relative to the output folder.
    pub heatmap: Option<String>,
    /// The CMO placement search's wall time, ms, where it ran for this run's scene
    /// ([`BenchPlacement::Auto`](super::BenchPlacement::Auto), or a scene without `[cmo]` centres)
    /// and the method captures.
    pub placement_ms: Option<f64>,
    /// With `--bounces N > 1`, each round after the first of the last frame: its rays, whether
    /// the method's cube maps traced them (else the BVH) and how many of them the fallback
    /// finished ([`RoundCount`]); empty at one bounce and for the reference.
    pub rounds: Vec<RoundCount>,
}

impl RunResult {
    /// A run of `method` (labelled `label`) on `scene` with nothing measured: sizes, counts,
    /// times and errors zero, no floor, heat map or placement time.
    pub fn unmeasured(scene: &str, label: String, kind: Method) -> RunResult {
        RunResult {
            scene: scene.into(),
            source: scene.into(),
            method: label,
            kind,
            params: String::new(),
            width: 0,
            height: 0,
            cube_size: 0,
            cmos: 0,
            triangles: 0,
            mirror_pixels: 0,
            rays: 0,
            frames: 0,
            passes: Vec::new(),
            trace_ns: Stats::default(),
            total_ns: Stats::default(),
            fallback_share: 0.0,
            fallback_ns: Stats::default(),
            checked_share: 0.0,
            check_ns: Stats::default(),
            trace_ns_per_mirror_px: 0.0,
            ns_per_ray: 0.0,
            floor: None,
            counters: Counters::default(),
            cmo_bytes: 0,
            error: ErrorReport::default(),
            wrong_off_reflector: 0.0,
            flip_mean: None,
            heatmap: None,
            placement_ms: None,
            rounds: Vec::new(),
        }
    }
}

/// The tracing pass of a method at a small frame
/// ([`BenchConfig::floor`](super::BenchConfig::floor)).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct FloorRun {
    pub width: u32,
    pub height: u32,
    pub rays: usize,
    pub trace_ns: Stats,
    /// `trace_ns.median` at the small frame over the full frame's: a pass that costs per ray
    /// scales with the ray count, a fixed cost keeps this near 1.
    pub ratio: f64,
}

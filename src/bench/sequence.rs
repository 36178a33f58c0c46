#![forbid(unsafe_code)]
//! `cubetrace bench --sequence`: frames per minute of an animated scene (default the built-in
//! `sphere-room-orbit`, a 24-frame camera orbit of `sphere-room`), per GPU method, with the
//! capture reused between frames (`reuse`, as `render --frames` does when only the camera moves)
//! and with the capture run for every frame (`recapture`, as when a mesh moves).
//!
//! One renderer per method and mode ([`TimedRenderer`]), built before the clock starts (its
//! set-up, device aside, is reported apart); each frame is the scene at that frame, the renderer
//! pointed at its camera ([`TimedRenderer::camera_frame`]), rendered and read back. Wall time covers that loop (host work
//! and read-back included); GPU time is the sum of the frame's timestamped passes, median over
//! the frames. `captured` counts the frames that ran the capture: 1 with reuse (the first), every
//! frame with recapture, 0 for a method that reads no cube map (bvh).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result};
use serde::Serialize;

use super::{DeviceInfo, git_commit};
use crate::Method;
use crate::files::write_atomic;
use crate::render::timed::TimedRenderer;
use crate::scene::Scene;
use crate::vk::GpuContext;
use crate::vk::frame::{Fallback, RenderOptions};

/// Whether the renderer keeps its capture between frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    Reuse,
    Recapture,
}

impl Mode {
    pub const ALL: [Mode; 2] = [Mode::Reuse, Mode::Recapture];

    pub fn name(self) -> &'static str {
        match self {
            Mode::Reuse => "reuse",
            Mode::Recapture => "recapture",
        }
    }
}

/// One method and mode over the sequence.
#[derive(Clone, Debug, Serialize)]
pub struct SequenceRow {
    pub method: String,
    pub mode: Mode,
    pub frames: usize,
    /// Frames that ran the capture.
    pub captured: usize,
    /// Renderer creation (passes, pipelines, BVHs, scene upload), seconds.
    pub setup_s: f64,
    /// The frames' loop, seconds.
    pub wall_s: f64,
    pub frames_per_minute: f64,
    /// Median over the frames of the summed pass times, milliseconds (NaN without timestamps).
    pub gpu_ms_median: f64,
}

/// A `--sequence` run.
#[derive(Clone, Debug, Serialize)]
pub struct SequenceReport {
    pub device: DeviceInfo,
    pub git_commit: Option<String>,
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub frames: Vec<i64>,
    pub rows: Vec<SequenceRow>,
}

/// Renders `frames` of `scene` (its first camera at `width` x `height`) with each GPU method of
/// `methods` in both modes; `tick` after each frame (progress).
pub fn run(
    ctx: &GpuContext,
    scene: &Scene,
    methods: &[Method],
    (width, height): (u32, u32),
    frames: &[i64],
    tick: &dyn Fn(),
) -> Result<SequenceReport> {
    anyhow::ensure!(!frames.is_empty(), "no frames to render");
    let at = |f: i64| -> Result<(Scene, crate::camera::Camera)> {
        let s = scene.at_frame(f);
        let mut c = s
            .cameras
            .first()
            .context("the scene has no camera")?
            .clone();
        (c.width, c.height) = (width, height);
        Ok((s, c))
    };
    let mut rows = Vec::new();
    for &method in methods.iter().filter(|m| m.is_gpu()) {
        for mode in Mode::ALL {
            let (s0, c0) = at(frames[0])?;
            let options = RenderOptions {
                method,
                fallback: Fallback::Envmap,
                ..RenderOptions::default()
            };
            let setup = Instant::now();
            let mut renderer = TimedRenderer::new(ctx, &s0, &c0, options)
                .with_context(|| format!("--method {method}"))?;
            let setup_s = setup.elapsed().as_secs_f64();
            let mut gpu_ms = Vec::new();
            let mut captured = 0;
            let start = Instant::now();
            for &f in frames {
                let (s, c) = at(f)?;
                let frame = renderer.camera_frame(&s, &c, mode == Mode::Recapture)?;
                captured += usize::from(frame.captured);
                gpu_ms.push(frame.pass_times.iter().map(|(_, t)| t).sum::<f64>() * 1e-6);
                tick();
            }
            let wall_s = start.elapsed().as_secs_f64();
            rows.push(SequenceRow {
                method: method.name().to_string(),
                mode,
                frames: frames.len(),
                captured,
                setup_s,
                wall_s,
                frames_per_minute: 60.0 * frames.len() as f64 / wall_s,
                gpu_ms_median: median(&mut gpu_ms),
            });
        }
    }
    Ok(SequenceReport {
        device: DeviceInfo::of(ctx),
        git_commit: git_commit(),
        scene: scene.name.clone(),
        width,
        height,
        frames: frames.to_vec(),
        rows,
    })
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() || v.iter().all(|x| *x == 0.0) {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The Markdown table of a run.
pub fn table(report: &SequenceReport) -> String {
    let mut t = String::from(
        "| method | capture | frames | captured | set-up s | wall s | frames/min | GPU ms/frame (median) |\n|---|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in &report.rows {
        t.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.1} | {} |\n",
            r.method,
            r.mode.name(),
            r.frames,
            r.captured,
            r.setup_s,
            r.wall_s,
            r.frames_per_minute,
            if r.gpu_ms_median.is_nan() {
                "-".to_string()
            } else {
                format!("{:.2}", r.gpu_ms_median)
            }
        ));
    }
    t
}

/// Writes `sequence.json` and `sequence.md` into `dir`; returns their paths.
pub fn write(report: &SequenceReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let json = dir.join("sequence.json");
    write_atomic(&json, serde_json::to_string_pretty(report)?.as_bytes())?;
    let md = dir.join("sequence.md");
    let doc = format!(
        "# cubetrace bench --sequence\n\nDevice: {}; commit {}; scene {} at {}x{}, frames {}..{} ({} frames).\n\n{}",
        report.device.describe(),
        report.git_commit.as_deref().unwrap_or("unknown"),
        report.scene,
        report.width,
        report.height,
        report.frames.first().copied().unwrap_or(0),
        report.frames.last().copied().unwrap_or(0),
        report.frames.len(),
        table(report)
    );
    write_atomic(&md, doc.as_bytes())?;
    Ok(vec![json, md])
}

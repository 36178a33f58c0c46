#![forbid(unsafe_code)]
//! Frames timed one after another on a device the caller holds: the bench's frames (one device
//! for every run), where [`super::FrameRenderer`] owns its device for one command's run.
//!
//! - [`run_gpu_with`]: a GPU method's `warmup` + `frames` whole frames (capture included), the
//!   last kept, pass times per frame ([`GpuRun`]);
//! - [`run_reference_bounces`]: the CPU reference's, wall time and the reflected-ray phase per
//!   frame ([`ReferenceRun`]);
//! - [`TimedRenderer`]: one GPU renderer kept over several kinds of frame: whole frames, frames
//!   of a sequence whose camera moves (capture reused or run again), Monte Carlo frames of
//!   several samples ([`super::glossy::mc_frame`]).
//!
//! Every frame is rendered as the command renders it: the same renderer, the same sample loop
//! ([`super::samples`]); only the clock is the caller's.

use std::time::Instant;

use anyhow::{Context, Result};
use glam::Vec3;

use crate::camera::Camera;
use crate::reference::{self, Frame};
use crate::scene::Scene;
use crate::vk::frame::{FramePlan, GpuFrame, GpuRenderer, RenderOptions};
use crate::vk::{GpuContext, PassTime};

/// The reference frame of one scene, with its wall times per frame (ns).
pub struct ReferenceRun {
    pub frame: Frame,
    /// The whole frame.
    pub wall_ns: Vec<f64>,
    /// The reflected-ray phase alone ([`reference::PhaseTimes::reflected_ns`]).
    pub reflected_ns: Vec<f64>,
    /// First reflected rays per frame (the reference's mirror pixels).
    pub reflected_rays: usize,
}

/// Renders the CPU reference `warmup + frames` times with `bounces` reflections per path
/// ([`reference::render_phased`]) and keeps the last frame; its hits are each path's last
/// ([`Frame::with_last_hits`]: what the GPU records hold).
pub fn run_reference_bounces(
    scene: &Scene,
    camera: &Camera,
    warmup: u32,
    frames: u32,
    bounces: u32,
) -> ReferenceRun {
    let tracer = reference::Tracer::new(scene);
    let (mut frame, _) = reference::render_phased(scene, &tracer, camera, bounces);
    for _ in 1..warmup {
        frame = reference::render_phased(scene, &tracer, camera, bounces).0;
    }
    let (mut wall_ns, mut reflected_ns) = (Vec::new(), Vec::new());
    let mut reflected_rays = 0;
    for _ in 0..frames.max(1) {
        let start = Instant::now();
        let (f, phases) = reference::render_phased(scene, &tracer, camera, bounces);
        wall_ns.push(start.elapsed().as_secs_f64() * 1e9);
        reflected_ns.push(phases.reflected_ns);
        reflected_rays = phases.reflected_rays;
        frame = f;
    }
    let frame = frame.with_last_hits(&tracer);
    ReferenceRun {
        frame,
        wall_ns,
        reflected_ns,
        reflected_rays,
    }
}

/// A GPU method's timed frames: the last frame, pass times per frame, CMO bytes.
pub struct GpuRun {
    pub frame: GpuFrame,
    pub pass_ns: Vec<Vec<PassTime>>,
    pub cmo_bytes: u64,
}

/// Renders `warmup` + `frames` whole frames of one GPU method with `options`, keeping the last.
pub fn run_gpu_with(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    options: RenderOptions,
    warmup: u32,
    frames: u32,
) -> Result<GpuRun> {
    let mut renderer = TimedRenderer::new(ctx, scene, camera, options)?;
    for _ in 0..warmup {
        renderer.whole_frame()?;
    }
    let mut pass_ns = Vec::new();
    let mut last = None;
    for _ in 0..frames.max(1) {
        let f = renderer.whole_frame()?;
        pass_ns.push(f.pass_times.clone());
        last = Some(f);
    }
    let frame = last.context("no frame rendered")?;
    Ok(GpuRun {
        frame,
        pass_ns,
        cmo_bytes: renderer.cmo_bytes(),
    })
}

/// A GPU renderer on the caller's device, for frames timed one after another (module docs).
pub struct TimedRenderer<'a> {
    ctx: &'a GpuContext,
    renderer: GpuRenderer,
}

impl<'a> TimedRenderer<'a> {
    /// Builds the renderer (passes, pipelines, BVHs, scene upload) on `ctx`.
    pub fn new(
        ctx: &'a GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
    ) -> Result<Self> {
        let options = FramePlan::resolve_list_size(scene, camera, &options);
        let renderer = GpuRenderer::new(ctx, scene, camera, options)?;
        Ok(TimedRenderer { ctx, renderer })
    }

    /// A whole frame, capture included (a renderer reuses its capture while the scene stands
    /// still: `GpuRenderer::invalidate_capture`).
    pub fn whole_frame(&mut self) -> Result<GpuFrame> {
        self.renderer.invalidate_capture();
        Ok(self.renderer.render(self.ctx)?)
    }

    /// The frame of `scene` seen by `camera`, where only the camera changed since the last
    /// frame: the capture is reused (as `render --frames` does) unless `recapture`.
    pub fn camera_frame(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        recapture: bool,
    ) -> Result<GpuFrame> {
        self.renderer.set_camera(self.ctx, scene, camera)?;
        if recapture {
            self.renderer.invalidate_capture();
        }
        Ok(self.renderer.render(self.ctx)?)
    }

    /// A Monte Carlo frame of `spp` samples ([`super::glossy::mc_frame`]): its colour and the
    /// pass times summed over its samples.
    pub fn mc_frame(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        spp: u32,
        film: bool,
    ) -> Result<(Vec<Vec3>, Vec<PassTime>)> {
        super::glossy::mc_frame(self.ctx, &mut self.renderer, scene, camera, spp, film)
    }

    /// The device memory of the renderer's CMOs.
    pub fn cmo_bytes(&self) -> u64 {
        self.renderer.cmo().bytes()
    }
}

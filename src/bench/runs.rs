#![forbid(unsafe_code)]
//! One run's timed frames: the CPU reference's ([`run_reference_bounces`]) or a GPU method's
//! ([`run_gpu_with`]), and the FLIP mean of a frame ([`flip_mean`]).

use std::time::Instant;

use anyhow::{Context, Result};

use crate::camera::Camera;
use crate::cpu::options::TraceOptions;
use crate::method::Method;
use crate::metrics::Traced;
use crate::reference::{self, Frame};
use crate::scene::Scene;
use crate::vk::frame::{GpuFrame, GpuRenderer, RenderOptions};
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

/// Renders the CPU reference `warmup + frames` times (one bounce, [`reference::render_phased`])
/// and keeps the last frame.
pub fn run_reference(scene: &Scene, camera: &Camera, warmup: u32, frames: u32) -> ReferenceRun {
    run_reference_bounces(scene, camera, warmup, frames, 1)
}

/// [`run_reference`] with `bounces` reflections per path; the frame's hits are each path's last
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

/// Renders `warmup` + `frames` frames of one GPU method, keeping the last frame.
pub fn run_gpu(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    method: Method,
    trace: TraceOptions,
    warmup: u32,
    frames: u32,
) -> Result<GpuRun> {
    let options = RenderOptions {
        method,
        trace,
        // The default fallback (`Fallback::Trace`, as the CLI's): PSNR and FLIP measure the
        // image a user would see. The pixels the method leaves unresolved are finished exactly by
        // the BVH, counted apart (the fallback share) and timed apart (the `fallback` pass); the
        // error figures (unresolved 0 %, wrong surface) are those of the final image.
        ..RenderOptions::default()
    };
    run_gpu_with(ctx, scene, camera, options, warmup, frames)
}

/// [`run_gpu`] with all the render options given.
pub fn run_gpu_with(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    options: RenderOptions,
    warmup: u32,
    frames: u32,
) -> Result<GpuRun> {
    let mut renderer = GpuRenderer::new(ctx, scene, camera, options)?;
    // Every timed frame is a whole frame, capture included (a renderer reuses its capture while
    // the scene stands still: `GpuRenderer::invalidate_capture`).
    for _ in 0..warmup {
        renderer.invalidate_capture();
        renderer.render(ctx)?;
    }
    let mut pass_ns = Vec::new();
    let mut last = None;
    for _ in 0..frames.max(1) {
        renderer.invalidate_capture();
        let f = renderer.render(ctx)?;
        pass_ns.push(f.pass_times.clone());
        last = Some(f);
    }
    let frame = last.context("no frame rendered")?;
    Ok(GpuRun {
        frame,
        pass_ns,
        cmo_bytes: renderer.cmo().bytes(),
    })
}

/// FLIP mean (LDR) over the mirror pixels of either frame ([`metrics`](crate::metrics)), on 8-bit
/// sRGB images of the whole frame; `None` when built without the `flip` feature.
#[cfg(not(feature = "flip"))]
pub fn flip_mean(_reference: &Frame, _traced: &Traced) -> Option<f64> {
    None
}

/// FLIP mean (LDR) over the mirror pixels of either frame ([`metrics`](crate::metrics)), on 8-bit
/// sRGB images of the whole frame; `None` when built without the `flip` feature.
#[cfg(feature = "flip")]
pub fn flip_mean(reference: &Frame, traced: &Traced) -> Option<f64> {
    let srgb = |c: &[glam::Vec3]| -> Vec<u8> {
        c.iter()
            .flat_map(|c| c.to_array().map(crate::shading::linear_to_srgb))
            .collect()
    };
    let (w, h) = (reference.width, reference.height);
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &srgb(&reference.colour));
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &srgb(&traced.colour));
    let err = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec();
    let (sum, n) = err
        .iter()
        .enumerate()
        .filter(|(k, _)| reference.mask[*k] != 0 || traced.mask[*k] != 0)
        .fold((0f64, 0usize), |(s, n), (_, e)| (s + f64::from(*e), n + 1));
    Some(if n == 0 { 0.0 } else { sum / n as f64 })
}

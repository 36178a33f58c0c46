#![forbid(unsafe_code)]
//! One run's timed frames as the bench asks for them: the CPU reference's at one bounce
//! ([`run_reference`]) and a GPU method's at the CLI's default fallback ([`run_gpu`]), rendered
//! and timed by the frame engine ([`crate::render::timed`]: [`run_reference_bounces`],
//! [`run_gpu_with`]); and the FLIP mean of a frame ([`flip_mean`]).

use anyhow::Result;

use crate::camera::Camera;
use crate::cpu::options::TraceOptions;
use crate::method::Method;
use crate::metrics::Traced;
use crate::reference::Frame;
use crate::scene::Scene;
use crate::vk::GpuContext;
use crate::vk::frame::RenderOptions;

pub use crate::render::timed::{GpuRun, ReferenceRun, run_gpu_with, run_reference_bounces};

/// Renders the CPU reference `warmup + frames` times at one bounce ([`run_reference_bounces`])
/// and keeps the last frame.
pub fn run_reference(scene: &Scene, camera: &Camera, warmup: u32, frames: u32) -> ReferenceRun {
    run_reference_bounces(scene, camera, warmup, frames, 1)
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

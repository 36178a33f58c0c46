#![forbid(unsafe_code)]
//! Glossy reflectors ([`crate::lobe`]): the warning for a method that cannot sample their lobe
//! ([`method_warning`]), and the frames a glossy frame is measured with: the converged
//! reference ([`reference_frame`], with its half-spp frame) and `bvh`'s Monte Carlo frame
//! ([`mc_frame`]), both through the one sample loop ([`super::samples`]), with their samples
//! at the pixel centre (the lobe alone) or at the film's offsets ([`offsets`]).

use anyhow::Result;
use glam::{Vec2, Vec3};

use crate::camera::Camera;
use crate::film::{Film, PixelFilter, aov_sample, sample_offsets};
use crate::method::{GlossyLobe, Method};
use crate::reference::{self, Tracer};
use crate::scene::Scene;
use crate::vk::frame::GpuRenderer;
use crate::vk::{GpuContext, PassTime};

use super::samples;

/// What `method` makes of the scene's glossy reflectors where it cannot sample their lobe: a
/// warning naming the method and the reflectors (`None` where the scene has none, or the method
/// handles every reflection's lobe: the reference, `bvh` with at most one bounce, `fragment`
/// and `compute` (which cone trace it on the cube maps, [`crate::cpu::cone`]) with at most one
/// bounce, and `ssr`, which cone traces it (`cpu::ssr_cone`) and traces one reflection only).
pub fn method_warning(scene: &Scene, method: Method, bounces: u32) -> Option<String> {
    let names = scene.glossy_reflectors();
    if names.is_empty() {
        return None;
    }
    let names = names.join(", ");
    let m = method;
    match method.glossy() {
        GlossyLobe::SampledEverywhere | GlossyLobe::ConeTracedOnly => None,
        GlossyLobe::SampledFirst | GlossyLobe::ConeTracedFirst if bounces <= 1 => None,
        GlossyLobe::ConeTracedFirst => Some(format!(
            "--method {m} cone traces the glossy reflectors ({names}) on the first reflection \
             only: with --bounces {bounces} the later reflections follow the mirror direction \
             (--method reference samples every one)"
        )),
        GlossyLobe::SampledFirst => Some(format!(
            "--method {m} samples the lobe of the glossy reflectors ({names}) on the first \
             reflection only: with --bounces {bounces} the later reflections follow the mirror \
             direction (--method reference samples every one)"
        )),
        GlossyLobe::MirrorOnly => Some(format!(
            "--method {m} cannot render glossy reflections yet: it traces the mirror direction \
             only, so the glossy reflectors ({names}) show as perfect mirrors (--method bvh and \
             --method reference sample their lobe)"
        )),
    }
}

/// The sample offsets from the pixel centre of a frame of `spp` samples: the film's
/// ([`sample_offsets`]) with `film`, else all zero (the lobe alone, no pixel footprint).
pub fn offsets(spp: u32, film: bool) -> Vec<Vec2> {
    if film {
        sample_offsets(spp)
    } else {
        vec![Vec2::ZERO; spp.max(1) as usize]
    }
}

/// The converged reference's frame at `spp` samples (box filter, [`offsets`]), plus the colour
/// of its even-numbered samples alone. With `film`, bit for bit the frame of
/// `cubetrace render --method reference --spp N` ([`samples::reference_frame`]).
pub fn reference_frame(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
    spp: u32,
    film: bool,
) -> (reference::Frame, Vec<Vec3>) {
    reference_frame_bounces(scene, tracer, camera, 1, spp, film)
}

/// [`reference_frame`] of paths of up to `bounces` reflections, every one of them sampled from
/// its lobe (`render --method reference --bounces N --spp M`): what a frame of `--bounces N`
/// is measured against.
pub fn reference_frame_bounces(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
    bounces: u32,
    spp: u32,
    film: bool,
) -> (reference::Frame, Vec<Vec3>) {
    let offsets = offsets(spp, film);
    let aov = aov_sample(&offsets);
    let (w, h) = (camera.width, camera.height);
    let (mut all, mut half) = (
        Film::new(w, h, PixelFilter::Box),
        Film::new(w, h, PixelFilter::Box),
    );
    let bar = indicatif::ProgressBar::hidden();
    let mut kept = None;
    let each = |s: usize, o: Vec2, frame: reference::Frame| {
        if s.is_multiple_of(2) {
            half.add(o, &frame.colour);
        }
        if s == aov {
            kept = Some(frame);
        }
    };
    samples::reference_samples(
        scene, tracer, camera, bounces, spp, &offsets, &bar, &mut all, each,
    );
    let mut frame = kept.unwrap_or_else(|| reference::Frame::new(w, h));
    frame.colour = all.resolve();
    (frame, half.resolve())
}

/// One Monte Carlo frame of `renderer` at `spp` samples ([`samples::gpu_samples`] at
/// [`offsets`], box filter): with `film`, the frame of `render --method bvh --spp N`. Its
/// colour and the pass times summed over the samples, per pass in the first sample's order.
pub fn mc_frame(
    ctx: &GpuContext,
    renderer: &mut GpuRenderer,
    scene: &Scene,
    camera: &Camera,
    spp: u32,
    film: bool,
) -> Result<(Vec<Vec3>, Vec<PassTime>)> {
    let offsets = offsets(spp, film);
    let mut acc = Film::new(camera.width, camera.height, PixelFilter::Box);
    let mut passes: Vec<PassTime> = Vec::new();
    let each = |_: usize, _: Vec2, frame: crate::vk::frame::GpuFrame| {
        for (name, ns) in frame.pass_times {
            match passes.iter_mut().find(|(n, _)| *n == name) {
                Some(p) => p.1 += ns,
                None => passes.push((name, ns)),
            }
        }
    };
    samples::gpu_samples(ctx, renderer, scene, camera, spp, &offsets, &mut acc, each)?;
    Ok((acc.resolve(), passes))
}

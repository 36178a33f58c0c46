#![forbid(unsafe_code)]
//! The sample loop: a frame rendered once per sample ([`crate::film`]), each sample's camera
//! jittered by its offset and its lobe samples keyed by [`crate::lobe::sample_key`], and the
//! samples' colours added to a [`Film`] in sample order.
//!
//! [`gpu_samples`] and [`reference_samples`] are the one loop of each backend; what a caller
//! keeps of each sample (the AOV sample, every sample for `--compare`, the pass times of the
//! bench's Monte Carlo ladder, the even-numbered half of a converged reference) it takes in the
//! closure it passes. The frame renderer's frames (`gpu_frame`, `reference_frame_samples`),
//! the comparison's reference ([`reference_frame`]) and the bench's glossy frames
//! ([`super::glossy`]) all run through them, so a frame of the bench is bit for bit the frame of
//! `cubetrace render` at the same samples.

use anyhow::Result;
use glam::{Vec2, Vec3};

use crate::camera::Camera;
use crate::film::{Film, FilmSettings, aov_sample};
use crate::metrics::Traced;
use crate::reference;
use crate::scene::Scene;
use crate::vk::GpuContext;
use crate::vk::frame::{GpuFrame, GpuRenderer};

/// One sample of a frame, kept for `--compare`'s per-sample figures.
#[derive(Clone, Debug)]
pub struct SampleFrame {
    /// The sample's camera jitter.
    pub offset: Vec2,
    /// GPU methods: the sample as traced and its primary hits.
    pub traced: Option<(Traced, Vec<Vec3>)>,
    /// The reference: the sample's frame.
    pub reference: Option<reference::Frame>,
}

/// The camera of sample `offset`.
pub fn sample_camera(camera: &Camera, offset: Vec2) -> Camera {
    Camera {
        jitter: offset,
        ..camera.clone()
    }
}

/// Renders the GPU samples of one frame at `offsets` (sample `s` keyed
/// `lobe::sample_key(spp, s)`): each sample's camera set ([`GpuRenderer::set_camera`], skipped
/// where it is the renderer's already), rendered, its colour added to `film`, and the frame
/// handed to `each(s, offset, frame)`.
#[allow(clippy::too_many_arguments)]
pub fn gpu_samples(
    ctx: &GpuContext,
    renderer: &mut GpuRenderer,
    scene: &Scene,
    camera: &Camera,
    spp: u32,
    offsets: &[Vec2],
    film: &mut Film,
    mut each: impl FnMut(usize, Vec2, GpuFrame),
) -> Result<()> {
    for (s, &o) in offsets.iter().enumerate() {
        let cam = sample_camera(camera, o);
        if renderer.camera() != &cam {
            renderer.set_camera(ctx, scene, &cam)?;
        }
        renderer.set_sample(ctx, scene, crate::lobe::sample_key(spp, s as u32))?;
        let frame = renderer.render(ctx)?;
        film.add(o, &frame.colour);
        each(s, o, frame);
    }
    Ok(())
}

/// The reference's samples of one frame at `offsets` with `bounces` reflections per path
/// (sample `s` keyed `lobe::sample_key(spp, s)`, rows counted on `bar`): each sample's colour
/// added to `film`, and the frame handed to `each(s, offset, frame)`.
#[allow(clippy::too_many_arguments)]
pub fn reference_samples(
    scene: &Scene,
    tracer: &reference::Tracer,
    camera: &Camera,
    bounces: u32,
    spp: u32,
    offsets: &[Vec2],
    bar: &indicatif::ProgressBar,
    film: &mut Film,
    mut each: impl FnMut(usize, Vec2, reference::Frame),
) {
    for (s, &o) in offsets.iter().enumerate() {
        let cam = sample_camera(camera, o);
        let key = crate::lobe::sample_key(spp, s as u32);
        let frame = reference::render_sample(scene, tracer, &cam, bounces, key, bar);
        film.add(o, &frame.colour);
        each(s, o, frame);
    }
}

/// What a frame's sample loop gives: the GPU or reference AOV frame (filtered colour), the
/// kept samples, how its CMO data was filled, and the GPU milliseconds.
pub(super) type Samples = (
    Option<GpuFrame>,
    Option<reference::Frame>,
    Vec<SampleFrame>,
    Filled,
    f64,
);

/// Whether any sample of a frame captured its CMO data, or ran its CMO stages on lists uploaded
/// for it ([`GpuFrame::captured`], [`GpuFrame::lists_uploaded`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Filled {
    pub captured: bool,
    pub uploaded: bool,
}

/// The GPU frame at the film `film`: its samples ([`gpu_samples`]) filtered into the colour of
/// the AOV sample's frame, every sample kept where `keep`.
pub(super) fn gpu_frame(
    ctx: &GpuContext,
    renderer: &mut GpuRenderer,
    scene: &Scene,
    camera: &Camera,
    film: FilmSettings,
    keep: bool,
) -> Result<Samples> {
    let offsets = film.offsets();
    let aov = aov_sample(&offsets);
    let mut acc = Film::new(camera.width, camera.height, film.filter);
    let (mut filled, mut gpu_ms) = (Filled::default(), 0.0);
    let mut kept = Vec::new();
    let mut aov_frame = None;
    let each = |s: usize, o: Vec2, frame: GpuFrame| {
        filled.captured |= frame.captured;
        filled.uploaded |= frame.lists_uploaded;
        gpu_ms += frame.pass_times.iter().map(|(_, t)| t).sum::<f64>() * 1e-6;
        if keep {
            kept.push(SampleFrame {
                offset: o,
                traced: Some((frame.traced(), frame.surface_position.clone())),
                reference: None,
            });
        }
        if s == aov {
            aov_frame = Some(frame);
        }
    };
    gpu_samples(
        ctx, renderer, scene, camera, film.spp, &offsets, &mut acc, each,
    )?;
    let mut frame = aov_frame.ok_or_else(|| anyhow::anyhow!("no sample rendered"))?;
    frame.colour = acc.resolve();
    Ok((Some(frame), None, kept, filled, gpu_ms))
}

/// The reference's frame at the film `film`: the same offsets and filter as the GPU's
/// ([`reference_samples`]). Large frames show a progress bar of rows (indicatif hides it off a
/// terminal).
pub(super) fn reference_frame_samples(
    scene: &Scene,
    tracer: &reference::Tracer,
    camera: &Camera,
    bounces: u32,
    film: FilmSettings,
    keep: bool,
) -> Samples {
    let offsets = film.offsets();
    let aov = aov_sample(&offsets);
    let mut acc = Film::new(camera.width, camera.height, film.filter);
    let mut kept = Vec::new();
    let mut aov_frame = None;
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("reference {bar:40} {pos}/{len} rows {elapsed}")
            .expect("the template is valid"),
    );
    // Small frames finish before a bar would help.
    let work = u64::from(camera.width) * u64::from(camera.height) * (u64::from(bounces) + 1);
    if work * u64::from(film.spp) < 2_000_000 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let each = |s: usize, o: Vec2, frame: reference::Frame| {
        if keep {
            kept.push(SampleFrame {
                offset: o,
                traced: None,
                reference: Some(frame.clone()),
            });
        }
        if s == aov {
            aov_frame = Some(frame);
        }
    };
    reference_samples(
        scene, tracer, camera, bounces, film.spp, &offsets, &bar, &mut acc, each,
    );
    bar.finish_and_clear();
    let mut frame = aov_frame.unwrap_or_else(|| reference::Frame::new(camera.width, camera.height));
    frame.colour = acc.resolve();
    (None, Some(frame), kept, Filled::default(), 0.0)
}

/// The reference's frame at the film `film` of scene and camera, every sample kept where
/// `keep` (`--compare`): the comparison's other side.
pub fn reference_frame(
    scene: &Scene,
    tracer: &reference::Tracer,
    camera: &Camera,
    bounces: u32,
    film: FilmSettings,
    keep: bool,
) -> (reference::Frame, Vec<SampleFrame>) {
    let (_, frame, kept, _, _) =
        reference_frame_samples(scene, tracer, camera, bounces, film, keep);
    (
        frame.unwrap_or_else(|| reference::Frame::new(camera.width, camera.height)),
        kept,
    )
}

//! The film: sub-pixel samples, `GpuRenderer::set_camera` and the `FrameRenderer`.
//! - A renderer pointed at camera B (`set_camera`) renders B's frame bit for bit as a renderer
//!   created for B, for every GPU method, without running the capture again; a jitter alone
//!   likewise. Negatives: camera A's frame differs, and so does an update that skips the
//!   G-buffer's camera.
//! - The reference's box filter of N samples is each pixel's mean of N single-sample renders at
//!   the film's offsets, computed here; one sample is the render without samples, bit for bit.
//!   Negative: the mean at the mirrored offsets differs.
//! - The GPU film likewise (compute), through `FrameRenderer`; a second frame of another camera
//!   in the same `FrameRenderer` equals that frame rendered alone and reuses the capture; a moved
//!   mesh captures again (tests/sequence/sequence_inplace.rs checks the in-place geometry update).
use crate::common;
use common::bits::{frame_bits, vec3_bits};
use common::render::first_frame;
use common::render_args as args;
use common::{finish_gpu, finish_renderer, gpu_context};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::film::{FilmSettings, PixelFilter, sample_offsets};
use cubetrace::reference;
use cubetrace::render::{FrameRenderer, RenderedFrame, samples};
use cubetrace::scene::Scene;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{Fallback, GpuFrame, GpuRenderer, RECORD_HIT, RenderOptions};
use glam::{Vec2, Vec3};

const WIDTH: u32 = 40;
const HEIGHT: u32 = 30;

fn scene_and_camera(name: &str) -> (Scene, Camera) {
    let (mut s, cam) = common::render::load_sized(name, (WIDTH, HEIGHT));
    s.cmo.resolution = 64;
    (s, cam)
}

/// Everything of a frame the outputs read, as bits: colour, mask, primary positions, and the
/// records of mirror pixels (no pass writes the others).
fn bits(f: &GpuFrame) -> Vec<u32> {
    frame_bits(f, true)
}

fn fresh(ctx: &GpuContext, scene: &Scene, camera: &Camera, method: Method) -> GpuFrame {
    let options = RenderOptions {
        method,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    fresh_with(ctx, scene, camera, options)
}

fn fresh_with(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    options: RenderOptions,
) -> GpuFrame {
    first_frame(ctx, scene, camera, options, &scene.name).0
}

#[test]
fn set_camera_equals_a_fresh_renderer() {
    let ctx = gpu_context();
    let (scene, a) = scene_and_camera("default");
    let b = Camera {
        eye: a.eye + Vec3::new(0.35, -0.2, -0.3),
        target: a.target + Vec3::new(0.1, 0.05, 0.0),
        fov_y_deg: a.fov_y_deg * 0.9,
        ..a.clone()
    };
    let jittered = Camera {
        jitter: Vec2::new(0.25, -0.375),
        ..a.clone()
    };
    for method in [
        Method::Compute,
        Method::Fragment,
        Method::Bvh,
        Method::Ssr,
        Method::ReflectionPoint,
        Method::Envmap,
    ] {
        let options = RenderOptions {
            method,
            fallback: Fallback::Envmap,
            ..RenderOptions::default()
        };
        let mut r = GpuRenderer::new(&ctx, &scene, &a, options).unwrap_or_else(|e| panic!("{e}"));
        let fa = r.render(&ctx).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            fa.captured,
            method != Method::Bvh,
            "{method}: the first frame captures"
        );
        for cam in [&b, &jittered, &a] {
            r.set_camera(&ctx, &scene, cam)
                .unwrap_or_else(|e| panic!("{e}"));
            let got = r.render(&ctx).unwrap_or_else(|e| panic!("{e}"));
            assert!(!got.captured, "{method}: the capture is reused");
            let want = fresh(&ctx, &scene, cam, method);
            assert!(
                got.mirror_pixels() > 50,
                "{method}: {} mirror pixels",
                got.mirror_pixels()
            );
            assert!(
                bits(&got) == bits(&want),
                "{method}: set_camera differs from new"
            );
            if cam != &a {
                // Negative: camera A's frame is another frame.
                assert!(bits(&fa) != bits(&want), "{method}: A's frame equals B's");
            }
        }
        // Negative: an update that leaves the G-buffer's camera at A.
        let mut r = GpuRenderer::new(&ctx, &scene, &a, options).unwrap_or_else(|e| panic!("{e}"));
        r.set_camera_skipping_gbuffer(&ctx, &scene, &b)
            .unwrap_or_else(|e| panic!("{e}"));
        let wrong = r.render(&ctx).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            bits(&wrong) != bits(&fresh(&ctx, &scene, &b, method)),
            "{method}: skipping the G-buffer update went unnoticed"
        );
    }
    // Another frame size is refused.
    let options = RenderOptions {
        method: Method::Fragment,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let mut r = GpuRenderer::new(&ctx, &scene, &a, options).unwrap();
    let small = Camera {
        width: WIDTH / 2,
        ..a.clone()
    };
    let e = r.set_camera(&ctx, &scene, &small).unwrap_err().to_string();
    assert!(e.contains("frame size"), "{e}");
    finish_gpu(ctx);
}

/// The reference's film against single-sample renders at the offsets, averaged here.
#[test]
fn reference_box_filter_is_the_mean_of_jittered_renders() {
    let (scene, camera) = scene_and_camera("sphere-room");
    let tracer = reference::Tracer::new(&scene);
    let one = FilmSettings {
        spp: 1,
        filter: PixelFilter::Box,
    };
    let (f1, _) = samples::reference_frame(&scene, &tracer, &camera, 1, one, false);
    let plain = reference::render(&scene, &tracer, &camera, 1);
    assert_eq!(
        vec3_bits(&f1.colour),
        vec3_bits(&plain.colour),
        "spp 1 is the frame without samples"
    );
    assert_eq!(f1.mask, plain.mask);
    let film = FilmSettings { spp: 4, ..one };
    let (f4, kept) = samples::reference_frame(&scene, &tracer, &camera, 1, film, true);
    assert_eq!(kept.len(), 4);
    let mean_at = |offsets: &[Vec2]| -> Vec<Vec3> {
        let frames: Vec<_> = offsets
            .iter()
            .map(|&o| {
                let cam = Camera {
                    jitter: o,
                    ..camera.clone()
                };
                reference::render(&scene, &tracer, &cam, 1).colour
            })
            .collect();
        (0..frames[0].len())
            .map(|k| frames.iter().map(|f| f[k]).sum::<Vec3>() / offsets.len() as f32)
            .collect()
    };
    let offsets = sample_offsets(4);
    let want = mean_at(&offsets);
    let max_diff = |a: &[Vec3], b: &[Vec3]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (*x - *y).abs().max_element())
            .fold(0.0f32, f32::max)
    };
    assert!(
        max_diff(&f4.colour, &want) < 1e-5,
        "{}",
        max_diff(&f4.colour, &want)
    );
    // The samples differ from each other (edges), so the filter has something to do.
    assert!(max_diff(&f4.colour, &plain.colour) > 1e-2);
    // Negative: the mean at the offsets mirrored in x is another image.
    let mirrored: Vec<Vec2> = offsets.iter().map(|o| Vec2::new(-o.x, o.y)).collect();
    assert!(max_diff(&f4.colour, &mean_at(&mirrored)) > 1e-2);
}

fn colour_bits(f: &RenderedFrame) -> Vec<u32> {
    vec3_bits(f.colour())
}

/// The GPU film (compute, 4 samples, box) through `FrameRenderer`: the mean of fresh renders
/// at the offsets; the AOVs are the centre-nearest sample's. A second camera in the same
/// `FrameRenderer` reuses the capture and equals that frame rendered alone; a moved mesh
/// captures again.
#[test]
fn frame_renderer_film_and_reuse() {
    let ctx = gpu_context();
    let (scene, a) = scene_and_camera("sphere-room");
    let line = ["sphere-room", "--method", "compute", "--spp", "4"];
    let mut fr = FrameRenderer::new(&args(&line), &scene, &a).unwrap_or_else(|e| panic!("{e}"));
    let f = fr.render(&scene, &a).unwrap_or_else(|e| panic!("{e}"));
    assert!(f.captured);
    let offsets = sample_offsets(4);
    let frames: Vec<GpuFrame> = offsets
        .iter()
        .map(|&o| {
            let cam = Camera {
                jitter: o,
                ..a.clone()
            };
            let options = cubetrace::app::render::gpu_options(&args(&line)).unwrap();
            fresh_with(&ctx, &scene, &cam, options)
        })
        .collect();
    let mean: Vec<Vec3> = (0..frames[0].colour.len())
        .map(|k| frames.iter().map(|g| g.colour[k]).sum::<Vec3>() / 4.0)
        .collect();
    let diff = f
        .colour()
        .iter()
        .zip(&mean)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(diff < 1e-5, "{diff}");
    let aov = cubetrace::film::aov_sample(&offsets);
    let g = f.gpu.as_ref().unwrap();
    assert_eq!(g.mask, frames[aov].mask);
    let hits = |x: &GpuFrame| {
        (0..x.records.len())
            .filter(|&k| x.mask[k] != 0 && x.records[k].status == RECORD_HIT)
            .map(|k| x.records[k].point.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert!(hits(g) == hits(&frames[aov]));
    // Negative: another sample's AOVs are not these.
    assert!(hits(g) != hits(&frames[(aov + 1) % 4]));

    // A second camera: the capture is reused, the frame is the frame alone.
    let b = Camera {
        eye: a.eye + Vec3::new(-0.3, 0.2, 0.25),
        ..a.clone()
    };
    let fb = fr.render(&scene, &b).unwrap_or_else(|e| panic!("{e}"));
    assert!(!fb.captured);
    let mut alone = FrameRenderer::new(&args(&line), &scene, &b).unwrap();
    let fb_alone = alone.render(&scene, &b).unwrap();
    finish_renderer(alone);
    assert!(colour_bits(&fb) == colour_bits(&fb_alone));
    assert!(colour_bits(&fb) != colour_bits(&f), "negative: A's frame");
    // A moved mesh: captured again, and equal to that scene alone.
    let mut moved = scene.clone();
    let last = moved.meshes.len() - 1;
    moved.meshes[last].transform.translate += Vec3::new(0.2, 0.0, 0.1);
    let fm = fr.render(&moved, &b).unwrap_or_else(|e| panic!("{e}"));
    assert!(fm.captured);
    let mut alone = FrameRenderer::new(&args(&line), &moved, &b).unwrap();
    assert!(colour_bits(&fm) == colour_bits(&alone.render(&moved, &b).unwrap()));
    assert!(
        colour_bits(&fm) != colour_bits(&fb),
        "negative: the mesh did not move"
    );
    finish_renderer(alone);
    finish_renderer(fr);
    finish_gpu(ctx);
}

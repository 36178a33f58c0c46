//! The placement search's lists handed to a still frame (`GpuRenderer::with_built_lists`): the
//! bounded judge builds each chosen centre's lists on the CPU, and the frame uploads them
//! instead of capturing where its capture has the same inputs (centres, triangles, flags, face
//! size). The capture is the lists' twin bit for bit where it cuts nothing, so the frame must be
//! the captured frame bit for bit, without a capture pass. Negatives: lists emptied (bounds
//! kept) are taken and change the frame, so the frame reads what it was handed; lists whose
//! inputs differ (a centre one ulp off, one triangle's flag flipped) are not taken, and the frame
//! captures its own.

use crate::common;

use std::sync::Arc;

use common::bits::frame_bits;
use common::render::{first_frame, first_frame_of};
use common::{finish_gpu, gpu_context};
use cubetrace::Method;
use cubetrace::cubemap::bounds::BuiltLists;
use cubetrace::placement::{self, Scoring};
use cubetrace::scene::Scene;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{Fallback, GpuFrame, GpuRenderer, RenderOptions};
use cubetrace::vk::options::ListSize;
use glam::Vec3;

use crate::corpus_searched as corpus;

/// `compute` under the default (bounded) criterion with the lists' face size `lists`, the
/// fallback finishing what the lists leave.
fn options(lists: ListSize) -> RenderOptions {
    RenderOptions {
        method: Method::Compute,
        fallback: Fallback::Trace,
        list_size: lists,
        ..RenderOptions::default()
    }
}

/// Corpus scene `name`, placed by the search judged with lists of `lists`, and its lists.
fn searched(name: &str, lists: ListSize) -> (Scene, Arc<BuiltLists>) {
    let mut scene = corpus(name);
    let camera = scene.cameras[0].clone();
    let p = placement::resolve(&mut scene, &camera, 1, Scoring::Bounded(lists)).unwrap();
    let built = p
        .lists
        .unwrap_or_else(|| panic!("{name}: the bounded judge handed no lists"));
    assert_eq!(built.lists.len(), scene.cmo_centres().len(), "{name}");
    (scene, built)
}

/// The first frame on `built`'s lists, and whether the renderer runs a capture.
fn frame_on(
    ctx: &GpuContext,
    scene: &Scene,
    lists: ListSize,
    built: &BuiltLists,
) -> (GpuFrame, bool) {
    let camera = &scene.cameras[0];
    let made = GpuRenderer::with_built_lists(ctx, scene, camera, options(lists), built);
    let (f, r) = first_frame_of(ctx, made, &scene.name);
    (f, r.captures())
}

/// On the mug (one CMO, `auto`'s face size) and on the facing mirrors judged with lists of 8
/// texels per face side (three CMOs), the frame on the search's lists runs no capture and is
/// the captured frame bit for bit; with the lists emptied it is not.
#[test]
fn a_still_frame_on_the_search_lists_is_the_captured_frame() {
    let ctx = gpu_context();
    for (name, lists, cmos) in [
        ("mug", ListSize::Auto, 1),
        ("facing", ListSize::Fixed(8), 3),
    ] {
        let (scene, built) = searched(name, lists);
        assert_eq!(built.lists.len(), cmos, "{name}");
        let camera = &scene.cameras[0];
        let (captured, r) = first_frame(&ctx, &scene, camera, options(lists), name);
        assert!(r.captures(), "{name}");
        let (reused, captures) = frame_on(&ctx, &scene, lists, &built);
        assert!(!captures, "{name}: the search's lists were not taken");
        assert!(
            frame_bits(&captured, true) == frame_bits(&reused, true),
            "{name}"
        );
        // The negative: every list emptied, its bounds kept; taken, and the frame moves.
        let mut emptied = (*built).clone();
        for l in &mut emptied.lists {
            l.entries.clear();
            l.offsets.fill(0);
        }
        let (wrong, captures) = frame_on(&ctx, &scene, lists, &emptied);
        assert!(!captures, "{name}");
        assert!(
            frame_bits(&captured, true) != frame_bits(&wrong, true),
            "{name}"
        );
    }
    finish_gpu(ctx);
}

/// Lists built from other inputs than the frame's capture are left, and the frame is the
/// captured one: a centre one ulp off, one triangle's capture flag flipped. The same lists as
/// built are taken (the frame runs no capture).
#[test]
fn lists_of_other_inputs_are_not_taken() {
    let ctx = gpu_context();
    let lists = ListSize::Auto;
    let (scene, built) = searched("mug", lists);
    let camera = &scene.cameras[0];
    let (captured, _) = first_frame(&ctx, &scene, camera, options(lists), "mug");
    let (_, captures) = frame_on(&ctx, &scene, lists, &built);
    assert!(!captures);
    let mut moved = (*built).clone();
    let c = moved.centres[0];
    moved.centres[0] = Vec3::new(f32::from_bits(c.x.to_bits() + 1), c.y, c.z);
    let mut flipped = (*built).clone();
    flipped.captured[0] = !flipped.captured[0];
    for (what, other) in [("moved centre", moved), ("flipped flag", flipped)] {
        let (f, captures) = frame_on(&ctx, &scene, lists, &other);
        assert!(captures, "{what}: lists of other inputs were taken");
        assert!(
            frame_bits(&captured, true) == frame_bits(&f, true),
            "{what}"
        );
    }
    finish_gpu(ctx);
}

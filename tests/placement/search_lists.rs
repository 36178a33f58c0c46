//! The placement search's lists handed to a still frame (`GpuRenderer::with_built_lists`): the
//! bounded judge builds each chosen centre's lists on the CPU, and the frame uploads them
//! instead of capturing where its capture has the same inputs (centres, triangles, flags, face
//! size). The capture is the lists' twin bit for bit where it cuts nothing, so the frame must be
//! the captured frame bit for bit, without a capture pass. Negatives: lists emptied (bounds
//! kept) are taken and change the frame, so the frame reads what it was handed; lists whose
//! inputs differ (a centre one ulp off, one triangle's flag flipped) are not taken, and the frame
//! captures its own. The same holds where a renderer's geometry moves and the search of the moved
//! scene hands its lists to the update (`GpuRenderer::update_geometry_with_lists`), as a sequence
//! whose meshes move does on every moved frame.

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
use cubetrace::vk::VkResult;
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
    searched_scene(corpus(name), lists)
}

/// `scene`, placed by the search judged with lists of `lists`, and its lists.
fn searched_scene(mut scene: Scene, lists: ListSize) -> (Scene, Arc<BuiltLists>) {
    let name = scene.name.clone();
    let camera = scene.cameras[0].clone();
    let p = placement::resolve(&mut scene, &camera, 1, Scoring::Bounded(lists)).unwrap();
    let built = p
        .lists
        .unwrap_or_else(|| panic!("{name}: the bounded judge handed no lists"));
    assert_eq!(built.lists.len(), scene.cmo_centres().len(), "{name}");
    (scene, built)
}

/// `built` with every list emptied, its bounds kept: lists a frame takes (their inputs are
/// `built`'s) whose frame is not the captured one.
fn emptied(built: &BuiltLists) -> BuiltLists {
    let mut out = built.clone();
    for l in &mut out.lists {
        l.entries.clear();
        l.offsets.fill(0);
    }
    out
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
        let (wrong, captures) = frame_on(&ctx, &scene, lists, &emptied(&built));
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

/// Corpus scene `name` with its reflector moved by `by`, placed by the search, and its lists.
fn moved(name: &str, by: Vec3) -> (Scene, Arc<BuiltLists>) {
    let mut scene = corpus(name);
    let mirror = scene.meshes.iter_mut().find(|m| m.reflector).unwrap();
    mirror.transform.translate += by;
    searched_scene(scene, ListSize::Auto)
}

/// The next frame after `update` ([`GpuRenderer::update_geometry_with_lists`] or a sibling)
/// accepted the update.
fn frame_after(
    ctx: &GpuContext,
    r: &mut GpuRenderer,
    update: VkResult<Option<String>>,
) -> GpuFrame {
    let refused = update.unwrap();
    assert_eq!(refused, None, "the update was refused");
    r.render(ctx).unwrap()
}

/// A renderer that captured the mug, its reflector then moved: updated with the moved scene's
/// search lists, the next frame runs no capture and is the moved scene's captured frame bit for
/// bit. Negatives: the lists emptied (bounds kept) are taken and the frame moves; the unmoved
/// scene's lists are not taken, and the frame captures.
#[test]
fn an_update_on_the_search_lists_is_the_captured_frame() {
    let ctx = gpu_context();
    let lists = ListSize::Auto;
    let (a, built_a) = searched("mug", lists);
    let (b, built_b) = moved("mug", Vec3::new(0.02, 0.01, 0.0));
    assert_eq!(a.cmo_centres().len(), b.cmo_centres().len());
    assert_ne!(
        built_a.centres, built_b.centres,
        "the move should move the searched centre"
    );
    let camera = &a.cameras[0];
    let (fresh, _) = first_frame(&ctx, &b, camera, options(lists), "moved mug");
    assert!(fresh.captured);
    for (what, given, uploaded) in [
        ("the moved scene's lists", (*built_b).clone(), true),
        ("the unmoved scene's lists", (*built_a).clone(), false),
    ] {
        let (_, mut r) = first_frame(&ctx, &a, camera, options(lists), "mug");
        let update = r.update_geometry_with_lists(&ctx, &b, camera, &given);
        let f = frame_after(&ctx, &mut r, update);
        assert_eq!(
            (f.lists_uploaded, f.captured),
            (uploaded, !uploaded),
            "{what}"
        );
        assert!(frame_bits(&fresh, true) == frame_bits(&f, true), "{what}");
    }
    // The negative: every list emptied, its bounds kept; taken, and the frame moves.
    let (_, mut r) = first_frame(&ctx, &a, camera, options(lists), "mug");
    let update = r.update_geometry_with_lists(&ctx, &b, camera, &emptied(&built_b));
    let wrong = frame_after(&ctx, &mut r, update);
    assert!(wrong.lists_uploaded);
    assert!(frame_bits(&fresh, true) != frame_bits(&wrong, true));
    finish_gpu(ctx);
}

/// A renderer made on the search's lists has no capture: its geometry moves only with lists
/// that it takes. Given the moved scene's, the frame is the moved scene's captured frame bit for
/// bit; without lists, or with the unmoved scene's, the update is refused (the caller rebuilds).
#[test]
fn a_renderer_on_uploaded_lists_moves_only_with_lists() {
    let ctx = gpu_context();
    let lists = ListSize::Auto;
    let (a, built_a) = searched("mug", lists);
    let (b, built_b) = moved("mug", Vec3::new(0.02, 0.01, 0.0));
    let camera = &a.cameras[0];
    let (fresh, _) = first_frame(&ctx, &b, camera, options(lists), "moved mug");
    let made = GpuRenderer::with_built_lists(&ctx, &a, camera, options(lists), &built_a);
    let (first, mut r) = first_frame_of(&ctx, made, "mug on lists");
    assert!(!r.captures() && first.lists_uploaded && !first.captured);
    let refused = r.update_geometry(&ctx, &b, camera).unwrap();
    assert!(refused.is_some_and(|why| why.contains("none were given")));
    let refused = r
        .update_geometry_with_lists(&ctx, &b, camera, &built_a)
        .unwrap();
    assert!(refused.is_some_and(|why| why.contains("not taken")));
    let update = r.update_geometry_with_lists(&ctx, &b, camera, &built_b);
    let f = frame_after(&ctx, &mut r, update);
    assert!(f.lists_uploaded && !f.captured);
    assert!(frame_bits(&fresh, true) == frame_bits(&f, true));
    // Kept, the next frame reuses the CMO data: nothing uploaded, nothing captured.
    r.set_camera(&ctx, &b, camera).unwrap();
    let again = r.render(&ctx).unwrap();
    assert!(!again.lists_uploaded && !again.captured);
    assert!(frame_bits(&fresh, true) == frame_bits(&again, true));
    finish_gpu(ctx);
}

//! The EXR's ID channels mean the same on every method (`output`'s module docs): on every
//! mirror pixel of each built-in scene, the `object_id` and `primitive_id` that the `bvh`
//! method's EXR holds are the reference EXR's wherever both hit the same triangle, and differ
//! wherever they hit different ones. Both files go through the real writers and are read back.
//!
//! Which pixels saw the same triangle is decided from the frames in memory (the global triangle
//! the GPU records and the reference name, one index space), not from the channels under test.

use crate::common;
use common::{finish_gpu, gpu_context};

use std::path::Path;

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::metrics::Traced;
use cubetrace::output;
use cubetrace::reference::{self, Frame, NO_ID, Tracer};
use cubetrace::scene::{Scene, builtin};
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{Fallback, GpuRenderer, RenderOptions};
use glam::Vec3;

/// Small frames: lavapipe renders them in a moment, and each scene still has hundreds of
/// mirror pixels.
const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;

fn load(name: &str) -> (Scene, Camera) {
    common::render::load_sized(name, (WIDTH, HEIGHT))
}

/// One u32 channel of an EXR file.
fn u32_channel(path: &Path, name: &str) -> Vec<u32> {
    let img = exr::prelude::read_all_flat_layers_from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let list = &img.layer_data[0].channel_data.list;
    let c = list
        .iter()
        .find(|c| c.name.to_string() == name)
        .unwrap_or_else(|| panic!("{}: no {name} channel", path.display()));
    match &c.sample_data {
        exr::prelude::FlatSamples::U32(v) => v.clone(),
        _ => panic!("{}: {name} is not u32", path.display()),
    }
}

/// `(object_id, primitive_id)` per pixel of an EXR file.
fn read_ids(path: &Path) -> Vec<(u32, u32)> {
    let objects = u32_channel(path, "object_id");
    let primitives = u32_channel(path, "primitive_id");
    objects.into_iter().zip(primitives).collect()
}

/// What the two EXRs' IDs say, over the mirror pixels (of both frames) where both hit
/// something: `(pixels, same triangle, disagreements)`, a disagreement being a pixel whose IDs
/// are equal although the triangles in memory differ, or differ although they are the same.
fn compare_ids(
    reference: &[(u32, u32)],
    traced: &[(u32, u32)],
    same_triangle: &[Option<bool>],
) -> (usize, usize, usize) {
    let (mut pixels, mut same, mut wrong) = (0, 0, 0);
    for (k, s) in same_triangle.iter().enumerate() {
        let Some(s) = *s else { continue };
        pixels += 1;
        same += usize::from(s);
        wrong += usize::from((reference[k] == traced[k]) != s);
    }
    (pixels, same, wrong)
}

/// Per pixel: `None` unless both frames have a mirror pixel there and both name a hit;
/// otherwise whether they name the same global triangle.
fn same_triangles(refr: &Frame, traced: &Traced) -> Vec<Option<bool>> {
    let triangles = traced.triangle.as_ref().expect("the method names its hits");
    (0..triangles.len())
        .map(|k| {
            let (_, want) = refr.shown_hit(k);
            let both = refr.mask[k] != 0 && traced.mask[k] != 0;
            (both && want != NO_ID && triangles[k] != NO_ID).then_some(want == triangles[k])
        })
        .collect()
}

/// The IDs read back from the two EXRs of one scene, and which pixels saw the same triangle
/// ([`same_triangles`]).
struct Pair {
    reference: Vec<(u32, u32)>,
    traced: Vec<(u32, u32)>,
    same: Vec<Option<bool>>,
}

/// Renders `name` with the reference and with `options`, writes both EXRs into `dir` and
/// reads their IDs back.
fn render_both(ctx: &GpuContext, name: &str, options: RenderOptions, dir: &Path) -> Pair {
    let (scene, camera) = load(name);
    let world = scene.world();
    let tracer = Tracer::new(&scene);
    let refr = reference::render(&scene, &tracer, &camera, options.bounces);
    let ref_path = dir.join(format!("{name}-reference.exr"));
    output::write_frame(&ref_path, &refr, &world).unwrap();
    let mut renderer = GpuRenderer::new(ctx, &scene, &camera, options).unwrap();
    let frame = renderer.render(ctx).unwrap();
    let traced = frame.traced();
    let gpu_path = dir.join(format!("{name}-{:?}.exr", options.method));
    output::write_traced(&gpu_path, &traced, &frame.surface_position, &world).unwrap();
    Pair {
        reference: read_ids(&ref_path),
        traced: read_ids(&gpu_path),
        same: same_triangles(&refr, &traced),
    }
}

/// Checks one pair of EXRs, and that the check fails on IDs shifted by one.
fn check(label: &str, pair: &Pair) {
    let (refr, gpu, same) = (&pair.reference, &pair.traced, &pair.same);
    let (pixels, same_count, wrong) = compare_ids(refr, gpu, same);
    eprintln!("{label}: {pixels} mirror pixels hit in both, {same_count} on the same triangle");
    assert!(pixels >= 100, "{label}: {pixels} pixels to compare");
    assert!(
        same_count as f64 >= 0.9 * pixels as f64,
        "{label}: {same_count} of {pixels} on the same triangle"
    );
    assert_eq!(
        wrong, 0,
        "{label}: IDs disagree on {wrong} of {pixels} pixels"
    );
    // Negative: a primitive numbering off by one, or another object numbering, is found.
    let shifted: Vec<(u32, u32)> = gpu.iter().map(|&(o, p)| (o, p.wrapping_add(1))).collect();
    assert!(compare_ids(refr, &shifted, same).2 >= same_count, "{label}");
    let shifted: Vec<(u32, u32)> = gpu.iter().map(|&(o, p)| (o.wrapping_add(1), p)).collect();
    assert!(compare_ids(refr, &shifted, same).2 >= same_count, "{label}");
}

#[test]
fn bvh_ids_are_the_references_on_every_builtin() {
    let ctx = gpu_context();
    let dir = tempfile::tempdir().unwrap();
    for &(name, _) in builtin::NAMES {
        let options = RenderOptions {
            method: Method::Bvh,
            fallback: Fallback::Envmap,
            ..RenderOptions::default()
        };
        check(name, &render_both(&ctx, name, options, dir.path()));
    }
    finish_gpu(ctx);
}

/// With more than one bounce the IDs (and `hit.*`) name the hit the pixel shows, its path's
/// last, on the reference as in the GPU records; and a cubemap method (compute, centre criterion)
/// writes the same numbering as the BVH.
#[test]
fn ids_agree_with_bounces_and_on_the_cubemap_tracer() {
    let ctx = gpu_context();
    let dir = tempfile::tempdir().unwrap();
    let bounces = RenderOptions {
        method: Method::Bvh,
        bounces: 2,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    check(
        "teapot, 2 bounces",
        &render_both(&ctx, "teapot", bounces, dir.path()),
    );
    let compute = RenderOptions {
        method: Method::Compute,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    check(
        "sphere-room, compute",
        &render_both(&ctx, "sphere-room", compute, dir.path()),
    );
    finish_gpu(ctx);
}

/// The reference's `hit.*` channels hold the hit its IDs name: with 2 bounces, on a pixel whose
/// path reflected twice, the last hit, not the first reflected one.
#[test]
fn reference_hit_channels_name_the_last_hit() {
    let (scene, camera) = load("teapot");
    let tracer = Tracer::new(&scene);
    let frame = reference::render(&scene, &tracer, &camera, 2);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.exr");
    output::write_frame(&path, &frame, &scene.world()).unwrap();
    let img = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let list = &img.layer_data[0].channel_data.list;
    let f32s = |name: &str| -> Vec<f32> {
        let c = list.iter().find(|c| c.name.to_string() == name).unwrap();
        (0..c.sample_data.len())
            .map(|k| c.sample_data.value_by_flat_index(k).to_f32())
            .collect()
    };
    let (x, y, z) = (f32s("hit.X"), f32s("hit.Y"), f32s("hit.Z"));
    let ids = read_ids(&path);
    let world = scene.world();
    let mut twice = 0;
    for k in 0..frame.mask.len() {
        let shown = Vec3::new(x[k], y[k], z[k]);
        let (position, triangle) = frame.shown_hit(k);
        assert_eq!(ids[k], world.ids(triangle), "pixel {k}");
        assert!(shown == position || (shown.is_nan() && position.is_nan()));
        if frame.bounces[k] == 2 && triangle != NO_ID {
            twice += 1;
            // Negative: the first reflected hit is another point (a reflector, the teapot).
            assert_ne!(shown, frame.hit_position[k], "pixel {k}");
        }
    }
    assert!(twice > 10, "{twice} pixels reflected twice");
}

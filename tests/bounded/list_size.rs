//! The bounded lists' face size (`--list-size`, `vk::options::ListSize`) changes what a frame
//! costs and which rays reach the exact fallback, not the image: every hit the lists give is a
//! listed triangle's exact intersection, the first along the ray at any texel size.
//!
//! Asserted on `teapot` (its reflector captured) and `default`, both GPU paths, the fallback on,
//! lists of 32 texels against lists of the cube size (128):
//! - every mirror pixel has the same status and names the same triangle;
//! - where neither frame's ray went to the fallback, its hit point and colour are the same bits;
//! - where one did, the colours agree within 1e-4 (the BVH's and the list walk's roundings of
//!   one hit).
//!
//! Negatives: one pixel's triangle and one last bit of another's colour changed are counted;
//! and the centre criterion's frames (centre-sampled captures) at the same two sizes name
//! different triangles on some pixels (what a centre-sampled capture sees depends on its
//! texels), so the comparison can tell real frames apart.

use crate::common;

use common::render::{criterion_options, first_frame_of};
use common::{finish_gpu, gpu_context};
use cubetrace::Method;
use cubetrace::cpu::options::TraceCriterion;
use cubetrace::scene::builtin;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{GpuFrame, GpuRenderer};
use cubetrace::vk::options::{Fallback, ListSize, RenderOptions};

const CUBE: u32 = 128;

/// How two frames of one view differ: mirror pixels whose status or triangle differ, pixels
/// resolved by the CMOs in both whose hit or colour bits differ, and the largest colour
/// difference where one of them went to the fallback (with how many such pixels).
#[derive(Debug, Default)]
struct Differences {
    mirror: usize,
    named: usize,
    listed_bits: usize,
    fallback: usize,
    fallback_colour: f32,
}

fn differences(a: &GpuFrame, b: &GpuFrame) -> Differences {
    let mut d = Differences::default();
    for k in 0..a.records.len() {
        if a.mask[k] == 0 {
            continue;
        }
        d.mirror += 1;
        let (ra, rb) = (&a.records[k], &b.records[k]);
        if ra.status != rb.status || ra.triangle != rb.triangle {
            d.named += 1;
        } else if ra.fallback == 0 && rb.fallback == 0 {
            let same = ra.point.map(f32::to_bits) == rb.point.map(f32::to_bits)
                && a.colour[k].to_array().map(f32::to_bits)
                    == b.colour[k].to_array().map(f32::to_bits);
            d.listed_bits += usize::from(!same);
        } else {
            d.fallback += 1;
            d.fallback_colour = d
                .fallback_colour
                .max((a.colour[k] - b.colour[k]).abs().max_element());
        }
    }
    d
}

/// The first frame of `scene` (96 x 72, the fallback on) with CMOs of `cube` texels per face
/// side and the bounded lists at `size`.
fn frame(
    ctx: &GpuContext,
    (scene, cube): (&str, u32),
    method: Method,
    criterion: TraceCriterion,
    size: ListSize,
) -> GpuFrame {
    let mut scene = builtin::by_name(scene).unwrap();
    scene.cmo.resolution = cube;
    let mut camera = scene.cameras[0].clone();
    (camera.width, camera.height) = (96, 72);
    let options = RenderOptions {
        fallback: Fallback::Trace,
        list_size: size,
        ..criterion_options(method, criterion)
    };
    let made = GpuRenderer::new(ctx, &scene, &camera, options);
    first_frame_of(
        ctx,
        made,
        &format!("{method:?} {criterion:?} {cube} {size:?}"),
    )
    .0
}

#[test]
fn the_list_size_changes_the_cost_not_the_image() {
    let ctx = gpu_context();
    let mut exact_named = 0;
    for scene in ["teapot", "default"] {
        for method in [Method::Compute, Method::Fragment] {
            let bounded = |size| frame(&ctx, (scene, CUBE), method, TraceCriterion::Bounded, size);
            let (small, cube) = (bounded(ListSize::Fixed(32)), bounded(ListSize::Cube));
            let d = differences(&small, &cube);
            eprintln!("{scene} {method:?} bounded, lists of 32 against {CUBE}: {d:?}");
            assert!(d.mirror > 500, "{scene} {method:?}: {d:?}");
            assert_eq!(
                (d.named, d.listed_bits),
                (0, 0),
                "{scene} {method:?}: {d:?}"
            );
            assert!(d.fallback_colour <= 1e-4, "{scene} {method:?}: {d:?}");
            // Negative: one pixel's triangle, and one last bit of another's colour, changed.
            let listed = (0..small.records.len())
                .filter(|&k| small.mask[k] != 0 && small.records[k].fallback == 0)
                .take(2)
                .collect::<Vec<_>>();
            let mut wrong = small.clone();
            wrong.records[listed[0]].triangle ^= 1;
            let c = &mut wrong.colour[listed[1]].x;
            *c = f32::from_bits(c.to_bits() ^ 1);
            let d = differences(&wrong, &cube);
            assert_eq!(
                (d.named, d.listed_bits),
                (1, 1),
                "{scene} {method:?}: {d:?}"
            );
            // The centre criterion reads the cube size itself.
            let exact = |cube| {
                frame(
                    &ctx,
                    (scene, cube),
                    method,
                    TraceCriterion::Centre,
                    ListSize::Cube,
                )
            };
            let d = differences(&exact(32), &exact(CUBE));
            eprintln!("{scene} {method:?} exact, captures of 32 against {CUBE}: {d:?}");
            exact_named += d.named;
        }
    }
    assert!(
        exact_named > 0,
        "the comparison cannot tell two captures apart"
    );
    finish_gpu(ctx);
}

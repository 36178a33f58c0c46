//! `--criterion bounded` end to end on the GPU (issue 22): the lists' capture
//! (`vk::passes::capture_lists`) feeding both GPU tracers in a real frame, on stress scenes
//! whose geometry is thinner than a texel (`tests/common/stress.rs`), judged against the CPU
//! reference's frame pixel by pixel with the fallback off (`--fallback flag`: the method alone).
//!
//! Asserted: on the pixels both frames see as mirror and the method resolved, the reference's
//! triangle on >= 99.9 % and no wrong surface (metrics' footprint rule), on the fence, wire
//! grid, edge-on fins and the Stanford bunny at cube size 32 with 1 and 2 CMOs. Negative: the
//! `exact` criterion (centre-sampled capture, verified hits) on the same thin-geometry frames
//! fails the bound (measured: 68 to 95 % same triangle, 43 to 243 wrong-surface pixels).

mod common;
#[allow(dead_code)]
#[path = "common/stress.rs"]
mod stress;

use common::{finish_gpu, gpu_context};
use cubetrace::Method;
use cubetrace::cpu::options::{TraceCriterion, TraceOptions};
use cubetrace::metrics;
use cubetrace::reference::{self, Frame, Tracer};
use cubetrace::scene::Scene;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::GpuRenderer;
use cubetrace::vk::options::{Fallback, RenderOptions};

/// `(same-triangle share of the judged pixels, wrong-surface pixels, judged, unresolved)`.
fn judge(
    ctx: &GpuContext,
    scene: &Scene,
    reference: &Frame,
    method: Method,
    criterion: TraceCriterion,
) -> (f64, usize, usize, usize) {
    let camera = scene.cameras[0].clone();
    let options = RenderOptions {
        method,
        trace: TraceOptions {
            criterion,
            ..TraceOptions::default()
        },
        fallback: Fallback::Flag,
        ..RenderOptions::default()
    };
    let mut renderer = GpuRenderer::new(ctx, scene, &camera, options)
        .unwrap_or_else(|e| panic!("{method:?} {criterion:?}: {e}"));
    let frame = renderer.render(ctx).unwrap();
    let traced = frame.traced();
    let classes = metrics::classify(
        reference,
        &traced,
        &frame.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    );
    let ids = traced.triangle.as_ref().expect("bounded frames name hits");
    let (mut judged, mut same, mut wrong, mut unresolved) = (0, 0, 0, 0);
    for (k, c) in classes.iter().enumerate() {
        match c.class {
            metrics::PixelClass::Unresolved => unresolved += 1,
            metrics::PixelClass::WrongSurface => {
                judged += 1;
                wrong += 1;
            }
            metrics::PixelClass::Correct => {
                judged += 1;
                same += usize::from(ids[k] == reference.triangle[k]);
            }
            _ => {}
        }
    }
    (
        same as f64 / judged.max(1) as f64,
        wrong,
        judged,
        unresolved,
    )
}

#[test]
fn bounded_frames_find_the_first_hit_on_thin_geometry() {
    let ctx = gpu_context();
    let mut exact_failures = 0;
    let mut exact_runs = 0;
    for name in ["fence", "wire-grid", "edge-on", "bunny"] {
        for cmos in [1, 2] {
            let scene = match name {
                "bunny" => stress::bunny_scene(64, 48, 32, cmos),
                _ => stress::stress_scene(name, 64, 48, 32, cmos),
            };
            let tracer = Tracer::new(&scene);
            let reference = reference::render(&scene, &tracer, &scene.cameras[0], 1);
            for method in [Method::Compute, Method::Fragment] {
                let (same, wrong, judged, unresolved) =
                    judge(&ctx, &scene, &reference, method, TraceCriterion::Bounded);
                eprintln!(
                    "{name} cmos {cmos} {}: bounded same {:.3} % of {judged}, wrong {wrong}, \
                     unresolved {unresolved}",
                    method.name(),
                    100.0 * same
                );
                assert!(judged > 300, "{name}: only {judged} pixels judged");
                assert_eq!(wrong, 0, "{name} cmos {cmos} {}", method.name());
                assert!(
                    same >= 0.999,
                    "{name} cmos {cmos} {}: {same}",
                    method.name()
                );
            }
            if name == "bunny" {
                // The dense mesh's triangles are larger than a texel here: the exact
                // criterion finds them too (tests/stress_capture.rs), so no negative.
                continue;
            }
            let (same, wrong, judged, _) = judge(
                &ctx,
                &scene,
                &reference,
                Method::Compute,
                TraceCriterion::Exact,
            );
            eprintln!(
                "{name} cmos {cmos} compute: exact same {:.3} % of {judged}, wrong {wrong}",
                100.0 * same
            );
            exact_runs += 1;
            exact_failures += usize::from(same < 0.999 || wrong > 0);
        }
    }
    // Negative: the centre-sampled capture misses the thin geometry.
    assert_eq!(
        exact_failures, exact_runs,
        "the exact criterion must fail the bound on every thin scene"
    );
    finish_gpu(ctx);
}

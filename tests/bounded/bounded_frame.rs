//! `--criterion bounded` end to end on the GPU: the lists' capture
//! (`vk::passes::capture_lists`) feeding both GPU tracers in a real frame, on stress scenes
//! whose geometry is thinner than a texel (`tests/common/stress.rs`), judged against the CPU
//! reference's frame pixel by pixel with the fallback off (`--fallback flag`: the method alone).
//!
//! Asserted (`failure`): on the pixels both frames see as mirror and the method resolved, the
//! reference's triangle on >= 99.9 % and no wrong surface (metrics' footprint rule); at most
//! 2 % of the mirror pixels unresolved and at least 95 % judged, so that a tracer cannot pass by
//! giving up. On the fence, wire grid, edge-on fins and the Stanford bunny at cube size 32 with
//! 1 and 2 CMOs, and on the fence and the edge-on fins at cube size 64 with one CMO.
//!
//! Negatives, each of which must fail the same assertions:
//! - the bounded frame with every record unresolved (a tracer that gives up: no wrong surface,
//!   no resolved pixel off the reference's triangle), and with just over 2 % more of its mirror
//!   pixels unresolved (this fails the unresolved bound alone);
//! - lists built on the CPU without the thin object's entries (bounds untouched: unsound), on
//!   every scene with one CMO at size 32, uploaded instead of the capture: the rays pass
//!   through the thin object and hit what lies behind it. The same lists with every entry kept
//!   must pass, so the failure is the dropped entries'.
//!
//! Logged only: the `exact` criterion (centre-sampled capture, verified hits) on the same
//! thin-geometry frames (measured at size 32: 68 to 95 % same triangle, 43 to 243
//! wrong-surface pixels). It is information, not a negative: a better centre capture may pass.
//!
//! Measured (64 x 48, sizes 32 and 64): mirror pixels 791 to 1111; unresolved 0 except the
//! bunny, 9 (0.8 %) with one CMO and 2 with two; judged 99.2 % of the mirror pixels on the
//! bunny, all of them elsewhere. Dropped thin entries: 54 to 262 wrong-surface pixels.

use crate::common;
use crate::quality;
use crate::stress;

use common::render::first_frame_of;
use common::{finish_gpu, gpu_context};
use cubetrace::Method;
use cubetrace::cpu::options::TraceCriterion;
use cubetrace::cpu::verify::triangle_corners;
use cubetrace::cubemap::bounds::{DEFAULT_DEPTH, TexelLists, capture_lists};
use cubetrace::metrics;
use cubetrace::reference::{self, Frame, Tracer};
use cubetrace::scene::Scene;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{GpuFrame, GpuRenderer, RECORD_UNRESOLVED};
use cubetrace::vk::options::{Fallback, ListSize, RenderOptions};
use cubetrace::vk::passes::lists::pack;

/// Largest unresolved share of the mirror pixels: 2.5x the largest measured (0.8 %, the bunny
/// with one CMO at size 32).
const MAX_UNRESOLVED: f64 = 0.02;
/// Smallest judged share of the mirror pixels (measured: 99.2 % or more; the rest are
/// unresolved).
const MIN_JUDGED: f64 = 0.95;

/// What the frame scored against the reference.
#[derive(Debug, Clone, Copy)]
struct Judged {
    /// Mirror pixels of the reference.
    mirror: usize,
    /// Resolved mirror pixels of both frames.
    judged: usize,
    /// Of those, on the reference's triangle.
    same: usize,
    /// Of those, on a wrong surface.
    wrong: usize,
    unresolved: usize,
}

impl Judged {
    fn same_share(&self) -> f64 {
        self.same as f64 / self.judged.max(1) as f64
    }
    fn line(&self) -> String {
        format!(
            "same {:.3} % of {} judged ({} mirror), wrong {}, unresolved {}",
            100.0 * self.same_share(),
            self.judged,
            self.mirror,
            self.wrong,
            self.unresolved
        )
    }
}

/// Why `j` fails the bounded targets, or `None` (module docs).
fn failure(j: &Judged) -> Option<String> {
    let mirror = j.mirror.max(1) as f64;
    if j.wrong > 0 {
        Some(format!("{} wrong-surface pixels", j.wrong))
    } else if j.same_share() < 0.999 {
        Some(format!("same triangle on {:.3} %", 100.0 * j.same_share()))
    } else if j.unresolved as f64 > MAX_UNRESOLVED * mirror {
        Some(format!("{} of {} unresolved", j.unresolved, j.mirror))
    } else if (j.judged as f64) < MIN_JUDGED * mirror {
        Some(format!("only {} of {} judged", j.judged, j.mirror))
    } else {
        None
    }
}

/// The method alone (`--fallback flag`), its lists at the cube size the scenes name.
fn options(method: Method, criterion: TraceCriterion) -> RenderOptions {
    RenderOptions {
        fallback: Fallback::Flag,
        list_size: ListSize::Cube,
        ..common::render::criterion_options(method, criterion)
    }
}

/// The frame of `method` under `criterion`, from the lists uploaded where `lists` is given.
fn render(
    ctx: &GpuContext,
    scene: &Scene,
    method: Method,
    criterion: TraceCriterion,
    lists: Option<&[TexelLists]>,
) -> GpuFrame {
    let camera = scene.cameras[0].clone();
    let options = options(method, criterion);
    let made = match lists {
        Some(l) => GpuRenderer::with_lists(ctx, scene, &camera, options, &pack(l).unwrap()),
        None => GpuRenderer::new(ctx, scene, &camera, options),
    };
    first_frame_of(ctx, made, &format!("{method:?} {criterion:?}")).0
}

fn judge(scene: &Scene, reference: &Frame, frame: &GpuFrame) -> Judged {
    let traced = frame.traced();
    let classes = metrics::classify(
        reference,
        &traced,
        &frame.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    );
    let ids = traced
        .triangle
        .clone()
        .unwrap_or_else(|| vec![u32::MAX; classes.len()]);
    let mut j = Judged {
        mirror: reference.mask.iter().filter(|&&m| m != 0).count(),
        judged: 0,
        same: 0,
        wrong: 0,
        unresolved: 0,
    };
    for (k, c) in classes.iter().enumerate() {
        match c.class {
            metrics::PixelClass::Unresolved => j.unresolved += 1,
            metrics::PixelClass::WrongSurface => {
                j.judged += 1;
                j.wrong += 1;
            }
            metrics::PixelClass::Correct => {
                j.judged += 1;
                j.same += usize::from(ids[k] == reference.triangle[k]);
            }
            _ => {}
        }
    }
    j
}

/// The scene's lists as the CPU builds them (`cubemap::bounds::capture_lists`), without the
/// entries of the mesh `drop` (its first-level name) where given.
fn cpu_lists(scene: &Scene, drop: Option<&str>) -> Vec<TexelLists> {
    let world = scene.world();
    let corners = triangle_corners(&world);
    let captured = world.captured_triangles();
    let range = drop.map(|name| {
        let objects: Vec<_> = world
            .objects
            .iter()
            .filter(|o| o.name.split('/').next() == Some(name))
            .collect();
        assert!(!objects.is_empty(), "no mesh {name}");
        let last = objects.last().unwrap();
        objects[0].first_triangle..last.first_triangle + last.triangle_count
    });
    scene
        .cmo_centres()
        .into_iter()
        .map(|c| {
            let mut l = capture_lists(&corners, &captured, c, scene.cmo.resolution, DEFAULT_DEPTH);
            if let Some(r) = &range {
                quality::drop_entries(&mut l, r);
            }
            l
        })
        .collect()
}

#[test]
fn bounded_frames_find_the_first_hit_on_thin_geometry() {
    let ctx = gpu_context();
    let mut exact_failures = 0;
    let mut exact_runs = 0;
    let mut runs = Vec::new();
    for name in ["fence", "wire-grid", "edge-on", "bunny"] {
        for cmos in [1, 2] {
            runs.push((name, 32, cmos));
        }
    }
    runs.push(("fence", 64, 1));
    runs.push(("edge-on", 64, 1));
    for (name, cube, cmos) in runs {
        let scene = match name {
            "bunny" => stress::bunny_scene(64, 48, cube, cmos),
            _ => stress::stress_scene(name, 64, 48, cube, cmos),
        };
        let at = format!("{name} N {cube} CMOs {cmos}");
        let tracer = Tracer::new(&scene);
        let reference = reference::render(&scene, &tracer, &scene.cameras[0], 1);
        for method in [Method::Compute, Method::Fragment] {
            let frame = render(&ctx, &scene, method, TraceCriterion::Bounded, None);
            let j = judge(&scene, &reference, &frame);
            eprintln!("{at} {}: bounded {}", method.name(), j.line());
            if let Some(e) = failure(&j) {
                panic!("{at} {}: {e}", method.name());
            }
            // Negative: the same frame given up on every mirror pixel.
            if cmos == 1 && method == Method::Compute {
                let mut give_up = frame.clone();
                for r in &mut give_up.records {
                    r.status = RECORD_UNRESOLVED;
                }
                let g = judge(&scene, &reference, &give_up);
                assert!(
                    failure(&g).is_some(),
                    "{at}: a frame that resolves nothing passed: {}",
                    g.line()
                );
                // Negative: the frame given up on just enough more pixels to exceed the bound
                // fails it, and on that bound alone.
                let mut quit = (MAX_UNRESOLVED * j.mirror as f64) as usize + 1;
                let mut some = frame.clone();
                for (k, r) in some.records.iter_mut().enumerate() {
                    if quit > 0
                        && frame.mask[k] != 0
                        && reference.mask[k] != 0
                        && r.status != RECORD_UNRESOLVED
                    {
                        r.status = RECORD_UNRESOLVED;
                        quit -= 1;
                    }
                }
                let g = judge(&scene, &reference, &some);
                let e = failure(&g);
                assert!(
                    e.as_ref().is_some_and(|e| e.contains("unresolved")),
                    "{at}: giving up on 2 % more: {e:?}: {}",
                    g.line()
                );
            }
        }
        if cmos == 1 && cube == 32 {
            // Negative: the thin object's entries dropped from the lists; the full CPU lists
            // uploaded the same way pass.
            let full = render(
                &ctx,
                &scene,
                Method::Compute,
                TraceCriterion::Bounded,
                Some(&cpu_lists(&scene, None)),
            );
            let j = judge(&scene, &reference, &full);
            eprintln!("{at} compute: CPU lists {}", j.line());
            if let Some(e) = failure(&j) {
                panic!("{at}: the CPU lists uploaded: {e}");
            }
            let dropped = render(
                &ctx,
                &scene,
                Method::Compute,
                TraceCriterion::Bounded,
                Some(&cpu_lists(&scene, Some(name))),
            );
            let j = judge(&scene, &reference, &dropped);
            eprintln!("{at} compute: {name} dropped {}", j.line());
            assert!(
                j.wrong > 0,
                "{at}: lists without the thin object judged sound: {}",
                j.line()
            );
        }
        if name == "bunny" || cube != 32 {
            // The dense mesh's triangles are larger than a texel here: the centre criterion
            // finds them too (tests/bounded/stress_capture.rs).
            continue;
        }
        let frame = render(&ctx, &scene, Method::Compute, TraceCriterion::Centre, None);
        let j = judge(&scene, &reference, &frame);
        eprintln!("{at} compute: exact {}", j.line());
        exact_runs += 1;
        exact_failures += usize::from(failure(&j).is_some());
    }
    // Information: the centre-sampled capture misses the thin geometry (measured: on every
    // thin scene at size 32).
    eprintln!("the centre criterion fails the bound on {exact_failures} of {exact_runs} runs");
    finish_gpu(ctx);
}

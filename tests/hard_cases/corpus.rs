//! The public real-scene corpus of `tests/scenes/`: meshes as their exporters wrote them
//! (Blender 2.67 to 2.90, Sweet Home 3D, Tinkercad, Maya; provenance, hashes and licences in
//! `tests/scenes/PROVENANCE.md`), built into scenes as a user would: a room, the camera in it, a
//! mirror with things around it.
//!
//! - Every scene loads (its exporters' quirks are warnings, never refusals) and every GPU method
//!   renders it: none is refused, the validation layer reports nothing, and each frame's mirror
//!   mask is the reference's (a few pixels of rasteriser edges aside).
//! - `bvh`, and `compute` and `fragment` with the bounded criterion (the default; the exact
//!   fallback takes what their lists leave), put no mirror pixel on a surface behind the
//!   reference's first reflected hit ([`judge`]), and leave none unresolved; `compute` renders
//!   every scene at the centre criterion too. `blender-mtl`'s hand is glossy (its MTL's `Ns`):
//!   rendered, not judged by hits. Negative: the `bvh` frame of a scene without the object its
//!   mirror shows most, judged against the reference of the whole scene, is behind on those
//!   pixels.
//!
//! CI renders at 40x30 with 32-texel cube faces; `cubetrace bench --scenes
//! tests/scenes/NAME/scene.toml` and `cubetrace render ... --compare` take them at full size.
//! A scene far from the world origin is judged in its anchor's coordinates
//! ([`cubetrace::ranges::anchor`], [`Scene::rebased`]): the GPU renders there anyway, and the
//! reference, which starts each reflected ray at an f32 point, is then as exact as the methods
//! (3.9 km out, its own rounding of those points, 1.2e-4, decides 0.1-0.2 % of the pixels).
use crate::common;
use common::render::first_frame;
use common::{finish_gpu, gpu_context};

use cubetrace::Method;
use cubetrace::cpu::options::TraceCriterion;
use cubetrace::reference::{self, Frame, Tracer};
use cubetrace::scene::Scene;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::RenderOptions;
use cubetrace::vk::frame::{Fallback, GpuFrame, RECORD_HIT, RECORD_UNRESOLVED};
use glam::Vec3;

/// The corpus scenes, each a folder of `tests/scenes/`.
const CORPUS: [&str; 10] = [
    "bunny",
    "living-room",
    "truck-garage",
    "robot-table",
    "mug",
    "cad-mm",
    "slivers",
    "blender-mtl",
    "far-offset",
    "facing",
];

/// Scene `name` at 40x30 with 32-texel cube faces, in its anchor's coordinates (module docs).
fn load(name: &str) -> Scene {
    let mut scene = common::corpus_scene(name);
    let c = &mut scene.cameras[0];
    (c.width, c.height) = (40, 30);
    scene.cmo.resolution = 32;
    scene.rebased(cubetrace::ranges::anchor(&scene))
}

fn options(method: Method, criterion: TraceCriterion) -> RenderOptions {
    RenderOptions {
        fallback: Fallback::Trace,
        ..common::render::criterion_options(method, criterion)
    }
}

fn render(ctx: &GpuContext, scene: &Scene, options: RenderOptions) -> GpuFrame {
    let what = format!("{}: {}", scene.name, options.method.name());
    first_frame(ctx, scene, &scene.cameras[0], options, &what).0
}

/// What [`judge`] counts over the mirror pixels both frames share.
#[derive(Debug, Default, PartialEq)]
struct Verdict {
    judged: usize,
    /// The method's hit lies behind the reference's first reflected hit, or it escaped where
    /// the reference hits something.
    behind: usize,
    /// The method's hit lies in front of the reference's, or it hits where the reference
    /// escapes.
    in_front: usize,
    unresolved: usize,
}

/// Judges `frame` against `reference` per mirror pixel, along the reflected ray from the
/// reference's mirror point `p`: with the reference's first reflected hit at distance `d` from
/// `p` and the method's at `d'` on another triangle, the method is *behind* where
/// `d' > d + tol` (or it escaped where the reference hits), *in front* where `d' < d - tol`; a
/// hit on the reference's own triangle is on its surface, neither. `tol` is 1e-4 of `d` plus 1e-6
/// of the scene's extent: far above f32 rounding of the points (1e-7 of their magnitude) and
/// of a tie between triangles that meet (a shared crease: the same point to rounding, another
/// triangle), far below what a missed object puts between the two (the object's distance to
/// what lies behind it: centimetres to metres here).
fn judge(scene: &Scene, reference: &Frame, frame: &GpuFrame) -> Verdict {
    let extent = scene.world().extent();
    let mut v = Verdict::default();
    for k in 0..frame.mask.len() {
        if frame.mask[k] == 0 || reference.mask[k] == 0 {
            continue;
        }
        v.judged += 1;
        let r = &frame.records[k];
        if r.status == RECORD_UNRESOLVED {
            v.unresolved += 1;
            continue;
        }
        let p = reference.surface_position[k];
        let (rh, hit) = (reference.hit_position[k], r.status == RECORD_HIT);
        match (rh.is_nan(), hit) {
            (true, false) => {}
            (true, true) => v.in_front += 1,
            (false, false) => v.behind += 1,
            // The same triangle is the same surface: a reflected direction a rounding apart
            // (a primary ray on a crease between two of the mirror's flat-shaded triangles)
            // moves a grazing hit along it.
            (false, true) if r.triangle == reference.triangle[k] => {}
            (false, true) => {
                let d = (rh - p).length();
                let d2 = (Vec3::from_array(r.point) - p).length();
                let tol = 1e-4 * d + 1e-6 * extent;
                if (d2 - d).abs() > tol {
                    eprintln!(
                        "pixel {k}: mirror point {p}, reference hit {rh} (triangle {}, at {d}), \
                         method's {:?} (triangle {}, at {d2})",
                        reference.triangle[k], r.point, r.triangle
                    );
                }
                v.behind += usize::from(d2 > d + tol);
                v.in_front += usize::from(d2 < d - tol);
            }
        }
    }
    v
}

/// Pixels whose mirror mask differs between the frame and the reference.
fn mask_differences(reference: &Frame, frame: &GpuFrame) -> usize {
    (0..frame.mask.len())
        .filter(|&k| (frame.mask[k] != 0) != (reference.mask[k] != 0))
        .count()
}

/// Every scene loads and every GPU method renders it at its defaults (the bounded criterion for
/// `compute` and `fragment`), and `compute` at the centre criterion too, with the reference's
/// mirror mask; `bvh` and bounded `compute` and `fragment` are never behind the reference's
/// first hit and leave nothing unresolved.
#[test]
fn every_method_renders_every_corpus_scene() {
    let ctx = gpu_context();
    for name in CORPUS {
        let scene = load(name);
        let camera = &scene.cameras[0];
        let tracer = Tracer::new(&scene);
        let reference = reference::render(&scene, &tracer, camera, 1);
        assert!(
            reference.mirror_pixels() >= 20,
            "{name}: the camera sees {} mirror pixels",
            reference.mirror_pixels()
        );
        let runs = Method::GPU
            .into_iter()
            .map(|m| (m, TraceCriterion::Bounded))
            .chain([(Method::Compute, TraceCriterion::Centre)]);
        let mut judged = Vec::new();
        for (method, criterion) in runs {
            let frame = render(&ctx, &scene, options(method, criterion));
            let masks = mask_differences(&reference, &frame);
            eprintln!(
                "{name} {} {criterion:?}: {} mirror pixels, {masks} mask differences",
                method.name(),
                frame.mirror_pixels()
            );
            assert!(
                masks <= 4,
                "{name} {} {criterion:?}: {masks}",
                method.name()
            );
            let exact = method == Method::Bvh
                || (method.traces_cubemaps() && criterion == TraceCriterion::Bounded);
            if exact {
                judged.push((method, frame));
            }
        }
        // A glossy reflector's ray is one lobe sample: no hit to judge (the glossy comparison
        // is the converged reference's PSNR, tests/cli.rs and tests/glossy/glossy_cone.rs).
        if !scene.glossy_reflectors().is_empty() {
            continue;
        }
        assert_eq!(judged.len(), 3, "{name}: bvh, compute and fragment");
        for (method, frame) in &judged {
            let v = judge(&scene, &reference, frame);
            eprintln!("{name} {}: {v:?}", method.name());
            assert!(v.judged + 4 >= reference.mirror_pixels(), "{name}: {v:?}");
            assert_eq!((v.behind, v.unresolved), (0, 0), "{name} {}", method.name());
        }
    }
    finish_gpu(ctx);
}

/// Negative of [`judge`]: on `living-room` and `robot-table`, the `bvh` frame of the scene
/// without the non-reflector mesh that the reference's mirror shows most is behind the
/// reference's first hit on most of the pixels that showed it.
#[test]
fn a_frame_without_a_shown_object_is_judged_behind() {
    let ctx = gpu_context();
    for name in ["living-room", "robot-table"] {
        let scene = load(name);
        let tracer = Tracer::new(&scene);
        let reference = reference::render(&scene, &tracer, &scene.cameras[0], 1);
        // The mesh whose triangles the reflected rays hit most (objects are mesh/part).
        let world = tracer.world.clone();
        let mut shown = vec![0usize; scene.meshes.len()];
        for k in 0..reference.mask.len() {
            if reference.mask[k] == 0 || reference.triangle[k] == u32::MAX {
                continue;
            }
            let object = &world.objects[reference.object_id[k] as usize];
            let mesh = object.name.split('/').next().unwrap();
            if let Some(m) = scene
                .meshes
                .iter()
                .position(|m| m.name == mesh && !m.reflector)
            {
                shown[m] += 1;
            }
        }
        let (most, &count) = shown.iter().enumerate().max_by_key(|(_, c)| **c).unwrap();
        let mut without = scene.clone();
        let removed = without.meshes.remove(most).name;
        let frame = render(&ctx, &without, options(Method::Bvh, TraceCriterion::Centre));
        let v = judge(&scene, &reference, &frame);
        eprintln!("{name} without `{removed}` ({count} pixels showed it): {v:?}");
        assert!(count >= 10, "{name}: `{removed}` shows on {count} pixels");
        assert!(v.behind * 2 >= count, "{name}: {v:?} of {count}");
        // The same judge passes the frame of the whole scene.
        let whole = render(&ctx, &scene, options(Method::Bvh, TraceCriterion::Centre));
        assert_eq!(judge(&scene, &reference, &whole).behind, 0, "{name}");
    }
    finish_gpu(ctx);
}

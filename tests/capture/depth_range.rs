//! Depth range and f32 precision (`cubetrace::ranges`): a scene spanning 1e-3 to 1e5 renders on
//! both GPU paths as the reference shows it, and a scene beyond what f32 can hold is refused with
//! its numbers.
//!
//! The span scene: a mirror sphere of radius 1 over a textured floor, a slab 1e-3 thick beside
//! it, a 2e-3 speck 1e-2 above the sphere, and a cube 1e5 behind the camera (its near face at
//! z = 1e5, 2e5 wide) that the mirror shows. Ranges with near = 1e-4 x far on a
//! `[near, far]` projection clip the whole near scene there: 0 mirror pixels.
use crate::common;
use common::{finish_gpu, gpu_context};

use std::process::Command;

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::cpu::options::TraceOptions;
use cubetrace::metrics::{self, ErrorReport, PixelClass};
use cubetrace::ranges::{FrameRanges, RangeError};
use cubetrace::reference::{self, Tracer};
use cubetrace::scene::shapes::{SceneBuilder, checker, cuboid, quad, uv_sphere};
use cubetrace::scene::{CmoPlacement, CmoSpec, Scene, SelfReflections, Transform, builtin};
use cubetrace::shading::Shading;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{
    Fallback, GpuFrame, GpuRenderer, PixelRecord, RECORD_ESCAPED, RECORD_HIT, RECORD_UNRESOLVED,
    RenderOptions,
};
use cubetrace::vk::methods::compute::STEP_CAP_ENV;
use glam::{Vec2, Vec3};

/// Distance of the far cube's centre from the origin (behind the camera, along +z).
const FAR: f32 = 1e5;

fn span_scene(far: f32) -> Scene {
    let centre = Vec3::new(0.0, 1.0, 0.0);
    let mut b = SceneBuilder::new(Scene {
        name: format!("span-{far:e}"),
        meshes: vec![],
        materials: vec![],
        textures: vec![],
        cameras: vec![Camera {
            name: "main".into(),
            eye: Vec3::new(0.0, 1.6, 4.0),
            target: centre,
            up: Vec3::Y,
            fov_y_deg: 30.0,
            width: 80,
            height: 60,
            jitter: glam::Vec2::ZERO,
        }],
        cmo: CmoSpec {
            placement: CmoPlacement::Explicit(vec![centre]),
            resolution: 128,
            lists: None,
        },
        background: Vec3::new(0.05, 0.05, 0.08),
        shading: Shading::default(),
        self_reflections: SelfReflections::Off,
        film: Default::default(),
        animation: Default::default(),
    });
    let floor = checker("floor", 64, 8, [200, 200, 190], [40, 60, 90]);
    let floor = b.material("floor", Vec3::ONE, Some(floor));
    let corner = Vec3::new(-6.0, 0.0, 6.0);
    let floor = quad(
        "floor",
        corner,
        Vec3::new(12.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -12.0),
        Vec2::splat(4.0),
        floor,
    );
    b.mesh("floor", vec![floor], Transform::default(), false);
    let m = b.material("mirror", Vec3::splat(0.8), None);
    let sphere = uv_sphere(1.0, 64, 32, m);
    b.mesh("mirror", vec![sphere], Transform::translation(centre), true);
    let box_of = |b: &mut SceneBuilder, name: &str, colour: Vec3, half: Vec3, at: Vec3| {
        let m = b.material(name, colour, None);
        let parts = cuboid(-half, half, false, [m; 6], 1.0);
        b.mesh(name, parts, Transform::translation(at), false);
    };
    let slab = Vec3::new(0.5e-3, 1.0, 0.6);
    box_of(
        &mut b,
        "slab",
        Vec3::new(0.9, 0.2, 0.6),
        slab,
        Vec3::new(1.6, 1.0, 0.8),
    );
    let speck = Vec3::splat(1e-3);
    let above = centre + Vec3::new(0.0, 1.01, 0.0);
    box_of(&mut b, "speck", Vec3::new(0.1, 0.9, 0.9), speck, above);
    // Its near face at z = far, 2 far wide: the mirror shows it around the camera's reflection.
    let far_half = Vec3::splat(far);
    let far_at = Vec3::new(0.0, 0.0, 2.0 * far);
    box_of(
        &mut b,
        "far-cube",
        Vec3::new(0.95, 0.6, 0.1),
        far_half,
        far_at,
    );
    b.scene
}

fn options(method: Method) -> RenderOptions {
    RenderOptions {
        method,
        trace: TraceOptions::default(),
        fallback: Fallback::Flag,
        ..RenderOptions::default()
    }
}

/// What [`check_span`] measured.
#[derive(Debug)]
struct Span {
    report: ErrorReport,
    mirror: usize,
    /// Mirror pixels whose record disagrees with the exact trace of the same ray.
    wrong_same_ray: usize,
    /// Reference mirror pixels whose reflected ray hits the far cube.
    far_reference: usize,
    /// Of those, the pixels the GPU got right.
    far_correct: usize,
}

/// The frame against the reference (`metrics::compare`): the same mirror pixels, at most 6%
/// unresolved (2.8% measured on both paths), and the far cube seen in the mirror where the
/// reference sees it (at least 100 pixels, 95% of them right). Wrong surfaces are judged as in
/// `tests/hard_cases.rs`, on each pixel's own ray traced exactly through the non-reflectors
/// (at most 1%; 0.16% measured): the reference drops hits nearer than `SELF_HIT_EPSILON` x
/// extent (0.4 here) on reflected rays, so `compare` counts the floor right under the sphere
/// as wrong (3.7% of the mirror pixels here, printed with the report).
fn check_span(
    scene: &Scene,
    reference: &reference::Frame,
    frame: &GpuFrame,
    t_hi: f32,
) -> Result<Span, String> {
    let traced = frame.traced();
    let args = (
        &frame.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    );
    let report = metrics::compare(reference, &traced, args.0, args.1, args.2);
    let classes = metrics::classify(reference, &traced, args.0, args.1, args.2);
    let on_far = |p: Vec3| p.z > 0.5 * FAR;
    let far_pixels: Vec<usize> = (0..classes.len())
        .filter(|&k| reference.mask[k] == 1 && on_far(reference.hit_position[k]))
        .collect();
    let far_correct = far_pixels
        .iter()
        .filter(|&&k| classes[k].class == PixelClass::Correct && on_far(traced.hit_position[k]))
        .count();
    let tracer = Tracer::new(scene);
    let texel = 2.0 / scene.cmo.resolution as f32;
    let mut wrong_same_ray = 0;
    for (k, rec) in frame.records.iter().enumerate() {
        if frame.mask[k] == 0 || rec.status == RECORD_UNRESOLVED {
            continue;
        }
        let (o, d) = (Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
        let cpu = tracer
            .nearest_where(o, d, None, |tri| !tracer.is_reflector(tri))
            .filter(|h| h.t * d.length() <= t_hi);
        let ok = match (rec.status, cpu) {
            (RECORD_ESCAPED, None) => true,
            (RECORD_HIT, Some(h)) => {
                let footprint = args
                    .1
                    .iter()
                    .map(|c| (h.position - *c).length())
                    .fold(f32::INFINITY, f32::min)
                    * texel;
                (Vec3::from_array(rec.point) - h.position).length() <= 2.0 * footprint
            }
            _ => false,
        };
        wrong_same_ray += usize::from(!ok);
    }
    let span = Span {
        report,
        mirror: frame.mirror_pixels(),
        wrong_same_ray,
        far_reference: far_pixels.len(),
        far_correct,
    };
    let r = &span.report;
    let ok = span.mirror == reference.mirror_pixels()
        && r.mask_mismatch <= 2
        && r.unresolved <= 0.06
        && span.wrong_same_ray * 100 <= span.mirror
        && span.far_reference >= 100
        && span.far_correct * 100 >= span.far_reference * 95;
    if ok {
        Ok(span)
    } else {
        Err(format!("{span:?}"))
    }
}

fn render_with(ctx: &GpuContext, scene: &Scene, method: Method, ranges: &FrameRanges) -> GpuFrame {
    let camera = &scene.cameras[0];
    let mut r = GpuRenderer::with_ranges(ctx, scene, camera, options(method), ranges)
        .unwrap_or_else(|e| panic!("{e}"));
    r.render(ctx).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn scene_spanning_1e_minus_3_to_1e5_matches_the_reference() {
    let ctx = gpu_context();
    let scene = span_scene(FAR);
    let camera = &scene.cameras[0];
    let ranges = FrameRanges::new(&scene, camera);
    eprintln!("{ranges:?}");
    ranges.check(&scene, true).expect("f32 holds this scene");
    // The near planes come from the geometry: the eye is 1.6 from the floor (near 0.73), the
    // CMO centre 1.0 from it (capture near 0.29); a near plane of 1e-4 x far would be 42.
    assert!(ranges.near > 0.5 && ranges.near < 1.5, "{ranges:?}");
    assert!(
        ranges.capture_near > 0.2 && ranges.capture_near < 0.3,
        "{ranges:?}"
    );
    let reference = reference::render(&scene, &Tracer::new(&scene), camera, 1);
    for method in [Method::Fragment, Method::Compute] {
        let mut r = GpuRenderer::new(&ctx, &scene, camera, options(method)).unwrap();
        let frame = r.render(&ctx).unwrap();
        let span = check_span(&scene, &reference, &frame, ranges.t_hi)
            .unwrap_or_else(|e| panic!("{method:?}: {e}"));
        eprintln!("{method:?}: {span:?}");
    }
    finish_gpu(ctx);
}

/// Negative tests of [`check_span`]: a near plane of 1e-4 x far (42 here) clips the near
/// scene (the check must fail); a ray length that stops short of the far cube (1e3) loses it
/// from the mirror (the check must fail again).
#[test]
fn old_near_plane_and_short_rays_fail_the_span_check() {
    let ctx = gpu_context();
    let scene = span_scene(FAR);
    let camera = &scene.cameras[0];
    let reference = reference::render(&scene, &Tracer::new(&scene), camera, 1);
    let ranges = FrameRanges::new(&scene, camera);
    let old = FrameRanges {
        near: 1e-4 * ranges.far,
        ..ranges.clone()
    };
    let frame = render_with(&ctx, &scene, Method::Fragment, &old);
    let err = check_span(&scene, &reference, &frame, old.t_hi).expect_err("old near plane");
    eprintln!("old near plane: {err}");
    assert_eq!(frame.mirror_pixels(), 0, "{err}");
    let short = FrameRanges {
        t_hi: 1e3,
        ..ranges.clone()
    };
    let frame = render_with(&ctx, &scene, Method::Fragment, &short);
    let err = check_span(&scene, &reference, &frame, short.t_hi).expect_err("short rays");
    eprintln!("short rays: {err}");
    // The same ranges as the renderer derives pass (the control of this negative test).
    let frame = render_with(&ctx, &scene, Method::Fragment, &ranges);
    check_span(&scene, &reference, &frame, ranges.t_hi).unwrap();
    finish_gpu(ctx);
}

/// sphere-room with every length moved by `d` (meshes, camera, CMO centres).
fn moved(mut scene: Scene, d: Vec3) -> Scene {
    for m in &mut scene.meshes {
        m.transform.translate += d;
    }
    for c in &mut scene.cameras {
        c.eye += d;
        c.target += d;
        (c.width, c.height) = (64, 48);
    }
    if let CmoPlacement::Explicit(c) = &mut scene.cmo.placement {
        c.iter_mut().for_each(|p| *p += d);
    }
    scene
}

/// Wrong-surface share of sphere-room moved by `d`, the fragment path forced through with the
/// derived ranges and no precision check, against the reference.
fn wrong_when_moved(ctx: &GpuContext, d: Vec3) -> f64 {
    let scene = moved(builtin::sphere_room(), d);
    let camera = &scene.cameras[0];
    let reference = reference::render(&scene, &Tracer::new(&scene), camera, 1);
    let ranges = FrameRanges::new(&scene, camera);
    let frame = render_with(ctx, &scene, Method::Fragment, &ranges);
    let args = (
        &frame.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    );
    metrics::compare(&reference, &frame.traced(), args.0, args.1, args.2).wrong_surface
}

/// sphere-room moved 1.24e5 from the origin: in world coordinates its mirror points lie up to
/// 1.257e5 from the origin and the nearest captured surface 1.2 from the CMO centre, a ratio
/// of 1.0e5 against 2^22 / 256 = 16384, beyond f32 (the range check on those coordinates
/// refuses it with the numbers). The renderer works relative to the scene's anchor
/// (`ranges::anchor`), where the same geometry lies within a few units of the origin: it is
/// accepted, and its frame is as close to the reference as the control's (moved 1.24e4,
/// within 1% wrong surface). Negative: forced through in world coordinates (no anchor, no
/// check) the frame is measurably worse (0.9% wrong surface against 0.15%, asserted twice the
/// anchored frame's), and moved ten times as far it is noise (32% measured, asserted over 10%).
/// The reference traces relative to the same anchor (`reference::Tracer::for_frames`).
#[test]
fn a_scene_far_from_the_origin_renders_relative_to_its_anchor() {
    let ctx = gpu_context();
    let d = Vec3::new(1e5, 3e4, -7e4);
    let scene = moved(builtin::sphere_room(), d);
    let camera = &scene.cameras[0];
    let world = FrameRanges::new(&scene, camera);
    let err = world
        .check(&scene, true)
        .expect_err("beyond f32 in world coordinates");
    let err = err.to_string();
    for needle in [
        "beyond f32 precision",
        "1.257e5",
        "16384",
        "N = 256",
        "room/y-",
    ] {
        assert!(err.contains(needle), "`{needle}` missing from: {err}");
    }
    let anchor = cubetrace::ranges::anchor(&scene);
    assert!((anchor - d).length() < 10.0, "{anchor}");
    let wrong_anchored = |scene: &Scene| {
        let camera = &scene.cameras[0];
        let reference = reference::render(scene, &Tracer::new(scene), camera, 1);
        let mut r = GpuRenderer::new(&ctx, scene, camera, options(Method::Fragment))
            .expect("accepted relative to its anchor");
        let frame = r.render(&ctx).unwrap();
        let (p, c) = (&frame.surface_position, scene.cmo_centres());
        metrics::compare(&reference, &frame.traced(), p, &c, scene.cmo.resolution).wrong_surface
    };
    let anchored = wrong_anchored(&scene);
    let forced = wrong_when_moved(&ctx, d);
    let far = wrong_when_moved(&ctx, d * 10.0);
    let control = wrong_anchored(&moved(builtin::sphere_room(), d / 10.0));
    eprintln!(
        "wrong surface: anchored {anchored}; forced in world coordinates: moved 1.24e6 {far}, \
         1.24e5 {forced}; control 1.24e4 {control}"
    );
    assert!(anchored < 0.01, "{anchored}");
    assert!(control < 0.01, "{control}");
    assert!(
        forced > 2.0 * anchored.max(control),
        "{forced} against {anchored}"
    );
    assert!(far > 0.10, "{far}");
    finish_gpu(ctx);
}

/// The bound scales with the cube size, and a scaled scene keeps its ratio: sphere-room at
/// scale 1e-3, 1 and 1e4 (as in `tests/hard_cases.rs`) passes, and so does the span scene;
/// moved 6000 from the origin (ratio 5000) it passes at N = 256 (limit 16384) and is refused at
/// N = 1024 (limit 4096); with its mirror scaled by 1e6 it is refused.
#[test]
fn precision_bound_scales_with_cube_size_not_with_scene_scale() {
    let check = |scene: &Scene| FrameRanges::new(scene, &scene.cameras[0]).check(scene, true);
    for s in [1e-3f32, 1.0, 1e4] {
        let mut scene = builtin::sphere_room();
        for m in &mut scene.meshes {
            m.transform.scale *= s;
            m.transform.translate *= s;
        }
        let c = &mut scene.cameras[0];
        (c.eye, c.target) = (c.eye * s, c.target * s);
        if let CmoPlacement::Explicit(c) = &mut scene.cmo.placement {
            c.iter_mut().for_each(|p| *p *= s);
        }
        check(&scene).unwrap_or_else(|e| panic!("scale {s}: {e}"));
    }
    check(&span_scene(FAR)).unwrap();
    let mut scene = moved(builtin::sphere_room(), Vec3::new(6000.0, 0.0, 0.0));
    check(&scene).unwrap();
    scene.cmo.resolution = 1024;
    assert!(matches!(check(&scene), Err(RangeError::Precision { .. })));
    // The issue's mirror scaled to 1e6 (it then encloses the room, whose floor is 1.2 from the
    // CMO centre): refused.
    let mut scene = builtin::sphere_room();
    let mirror = scene.meshes.iter_mut().find(|m| m.reflector).unwrap();
    mirror.transform.scale *= 1e6;
    assert!(matches!(check(&scene), Err(RangeError::Precision { .. })));
}

/// The CMO centres' checks refuse only a method that captures CMOs: with its CMO centre on the
/// room's floor (its nearest captured surface at distance 0), `sphere-room` is refused for
/// `compute` (naming the CMO and the surface) and renders with `bvh`, byte for byte the `bvh`
/// frame of the scene as built, which no CMO centre touches.
#[test]
fn cmo_checks_refuse_only_methods_that_capture() {
    let mut scene = builtin::sphere_room();
    let c = &mut scene.cameras[0];
    (c.width, c.height) = (32, 24);
    let built = scene.clone();
    scene.cmo.placement = CmoPlacement::Explicit(vec![Vec3::new(0.0, 0.0, 1.0)]);
    let ranges = FrameRanges::new(&scene, &scene.cameras[0]);
    let err = ranges
        .check(&scene, true)
        .expect_err("a centre on the floor");
    assert!(matches!(err, RangeError::Precision { cmo: 0, .. }), "{err}");
    ranges.check(&scene, false).unwrap();
    let ctx = gpu_context();
    let camera = &scene.cameras[0];
    let refused = match GpuRenderer::new(&ctx, &scene, camera, options(Method::Compute)) {
        Ok(_) => panic!("compute reads the CMO"),
        Err(e) => e.to_string(),
    };
    assert!(
        refused.contains("CMO 0") && refused.contains("move CMO 0's centre off it"),
        "{refused}"
    );
    let frame = |s: &Scene| {
        let mut r = GpuRenderer::new(&ctx, s, &s.cameras[0], options(Method::Bvh)).unwrap();
        r.render(&ctx).unwrap()
    };
    let (on_floor, as_built) = (frame(&scene), frame(&built));
    assert!(on_floor.mirror_pixels() > 50);
    assert_eq!(on_floor.colour, as_built.colour);
    finish_gpu(ctx);
}

/// A scene whose squared distances overflow f32 is refused by its extent.
#[test]
fn an_extent_beyond_f32_range_is_refused() {
    let scene = span_scene(1e19);
    let r = FrameRanges::new(&scene, &scene.cameras[0]);
    let err = r.check(&scene, true).expect_err("extent 1e19");
    let msg = err.to_string();
    assert!(matches!(err, RangeError::Extent { .. }), "{msg}");
    assert!(
        msg.contains("beyond f32 range") && msg.contains("e19"),
        "{msg}"
    );
    // Negative: the same scene at 1e17 passes.
    let scene = span_scene(1e17);
    FrameRanges::new(&scene, &scene.cameras[0])
        .check(&scene, true)
        .unwrap();
}

/// The near plane clips nothing the camera sees, however close the eye is to a surface: the eye
/// 1e-3 above the 2e-3 speck, looking down past it at the mirror 1e-2 below. The G-buffer's
/// mask and positions against the reference's primary hits. Negative: a near plane of 4e-3
/// clips the speck.
#[test]
fn eye_close_to_a_surface_clips_nothing() {
    let ctx = gpu_context();
    let mut scene = span_scene(FAR);
    let speck = Vec3::new(0.0, 2.01, 0.0);
    let c = &mut scene.cameras[0];
    c.eye = speck + Vec3::new(0.0, 2e-3, 0.0);
    c.target = Vec3::new(0.0, 1.0, 0.0);
    c.up = Vec3::Z;
    c.fov_y_deg = 90.0;
    let camera = scene.cameras[0].clone();
    let ranges = FrameRanges::new(&scene, &camera);
    assert!(ranges.near < 1e-3, "{ranges:?}");
    let reference = reference::render(&scene, &Tracer::new(&scene), &camera, 1);
    let on_speck = |p: Vec3| (p - speck).abs().max_element() <= 1.001e-3;
    let speck_pixels = |frame: &GpuFrame| -> usize {
        frame
            .surface_position
            .iter()
            .filter(|&&p| on_speck(p))
            .count()
    };
    let frame = render_with(&ctx, &scene, Method::Fragment, &ranges);
    let (mut mask_diff, mut pos_diff, mut covered) = (0, 0, 0);
    for k in 0..frame.mask.len() {
        mask_diff += usize::from(frame.mask[k] != reference.mask[k]);
        let (g, r) = (frame.surface_position[k], reference.surface_position[k]);
        if g.is_nan() != r.is_nan() {
            pos_diff += 1;
        } else if !g.is_nan() {
            covered += 1;
            let tol = 1e-3 * (r - camera.eye).length();
            pos_diff += usize::from((g - r).length() > tol);
        }
    }
    let reference_speck = reference
        .surface_position
        .iter()
        .filter(|&&p| on_speck(p))
        .count();
    eprintln!(
        "mask differences {mask_diff}, position differences {pos_diff} of {covered}; speck \
         pixels: reference {reference_speck}, GPU {}",
        speck_pixels(&frame)
    );
    assert!(frame.mirror_pixels() > 500 && reference_speck > 500);
    assert!(mask_diff <= 8 && pos_diff <= 16, "{mask_diff} {pos_diff}");
    assert!(speck_pixels(&frame).abs_diff(reference_speck) <= 16);
    let clipped = FrameRanges {
        near: 4e-3,
        ..ranges
    };
    let frame = render_with(&ctx, &scene, Method::Fragment, &clipped);
    eprintln!("near 4e-3: speck pixels {}", speck_pixels(&frame));
    assert!(speck_pixels(&frame) < reference_speck / 10);
    finish_gpu(ctx);
}

/// The eye exactly on the floor: the floor, in a plane through the eye, is culled (the
/// reference meets it at t = 0 only), so the near plane comes from the nearest other surface
/// (it was the tiny floor, the scene's extent times 2^-40); the G-buffer still matches the
/// reference's primary hits.
#[test]
fn eye_on_a_surface_falls_back_to_a_tiny_near_plane() {
    let ctx = gpu_context();
    let mut scene = span_scene(FAR);
    scene.cameras[0].eye = Vec3::new(0.0, 0.0, 3.0);
    let camera = scene.cameras[0].clone();
    let ranges = FrameRanges::new(&scene, &camera);
    let eye = ranges.eye.as_ref().expect("a nearest surface");
    assert!(
        !eye.object.starts_with("floor") && eye.distance > 0.0,
        "{ranges:?}"
    );
    assert!(ranges.near > 1e-3, "{ranges:?}");
    let reference = reference::render(&scene, &Tracer::new(&scene), &camera, 1);
    let mask_diff = |ranges: &FrameRanges| {
        let frame = render_with(&ctx, &scene, Method::Fragment, ranges);
        (0..frame.mask.len())
            .filter(|&k| frame.mask[k] != reference.mask[k])
            .count()
    };
    let diff = mask_diff(&ranges);
    eprintln!(
        "reference mirror pixels {}, mask differences {diff}",
        reference.mirror_pixels()
    );
    assert!(reference.mirror_pixels() > 500);
    assert!(diff <= 8, "{diff}");
    // Negative: a near plane beyond the mirror (5; it is 3.2 away) loses it.
    let beyond = FrameRanges {
        near: 5.0,
        ..ranges
    };
    assert!(mask_diff(&beyond) > 500);
    finish_gpu(ctx);
}

/// Through the binary: a mirror 1e6 from the origin on a ground that reaches back to the
/// origin (so no anchor brings its coordinates near: the scene's own size is 2e6) is refused
/// with the numbers, exit 1, no image.
#[test]
fn cli_refuses_a_scene_beyond_f32_precision() {
    let dir = tempfile::tempdir().unwrap();
    // An octahedron mirror of radius 1 around (1e6, 2, 0) and a ground quad from x = -1e6 to
    // 1e6 + 5 (in object space around x = 1e6: x from -2e6 to 5).
    let obj = "o mirror\nv 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
               f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
    let ground = "o ground\nv -2000000 0 -5\nv 5 0 -5\nv 5 0 5\nv -2000000 0 5\nf 1 3 2\nf 1 4 3\n";
    std::fs::write(dir.path().join("mirror.obj"), obj).unwrap();
    std::fs::write(dir.path().join("ground.obj"), ground).unwrap();
    let toml = r#"
name = "far-away"
background = [0.05, 0.05, 0.08]
self_reflections = false
[shading]
model = "unlit"
[[mesh]]
name = "mirror"
obj = "mirror.obj"
reflector = true
transform = { translate = [1000000, 2, 0] }
[[mesh]]
name = "ground"
obj = "ground.obj"
reflector = false
transform = { translate = [1000000, 0, 0] }
[[camera]]
name = "main"
eye = [1000000, 3, 5]
target = [1000000, 2, 0]
up = [0, 1, 0]
fov_y_deg = 50
resolution = [32, 24]
[cmo]
centres = [[1000000, 2, 0]]
resolution = 64
"#;
    std::fs::write(dir.path().join("scene.toml"), toml).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_cubetrace"))
        .args(["render", "scene.toml", "-o", "out.png"])
        .env("XDG_RUNTIME_DIR", "/tmp")
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stderr}");
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for needle in ["beyond f32 precision", "1.000e6", "ground", "N = 64"] {
        assert!(stderr.contains(needle), "`{needle}` missing: {stderr}");
    }
    assert!(!dir.path().join("out.png").exists());
}

/// Through the binary: an eye 1e-7 above a floor loaded from an OBJ (on the surface, to f32
/// rounding) is refused naming the floor's face by file and line and the distance to move;
/// exit 1, no image. Negative: the eye exactly in the floor's plane renders (the reference and
/// the passes both see the floor edge-on).
#[test]
fn cli_names_the_face_an_eye_lies_on() {
    let dir = tempfile::tempdir().unwrap();
    let floor = "# a floor\no floor\nv -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\nf 1 2 3 4\n";
    let mirror = "o mirror\nv 0 0.5 -2\nv 1 0.5 -2\nv 0 1.5 -2\nf 1 2 3\n";
    std::fs::write(dir.path().join("floor.obj"), floor).unwrap();
    std::fs::write(dir.path().join("mirror.obj"), mirror).unwrap();
    let scene = |y: &str| {
        format!(
            "name = \"on-floor\"\n[[mesh]]\nobj = \"floor.obj\"\n[[mesh]]\nobj = \"mirror.obj\"\n\
             reflector = true\n[[camera]]\neye = [0.5, {y}, 0.5]\ntarget = [0.5, -0.3, -3]\n\
             resolution = [16, 12]\n[cmo]\ncentres = [[0.3, 0.8, -1.5]]\nresolution = 16\n"
        )
    };
    let render = |y: &str| {
        std::fs::write(dir.path().join("scene.toml"), scene(y)).unwrap();
        Command::new(env!("CARGO_BIN_EXE_cubetrace"))
            .args(["render", "scene.toml", "--method", "bvh", "-o", "out.png"])
            .env("XDG_RUNTIME_DIR", "/tmp")
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    let out = render("1e-7");
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stderr}");
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    for needle in [
        "lies on a surface",
        "floor.obj:7",
        "Move it off the surface",
    ] {
        assert!(stderr.contains(needle), "`{needle}` missing: {stderr}");
    }
    assert!(!dir.path().join("out.png").exists());
    let out = render("0");
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("out.png").exists());
}

/// Where [`span_records_child`] writes the span scene's compute records (set by the parent).
const RECORDS_OUT_ENV: &str = "CUBETRACE_TEST_SPAN_RECORDS";

/// Child of [`compute_lane_layouts_agree_on_the_span_scene`] (run by it, in a process of its own
/// with `CUBETRACE_RAY_LANES` and `LP_NATIVE_VECTOR_WIDTH` set): renders the span scene (far
/// cube at `far`, from the env) with the compute method and writes its mirror mask and records.
#[test]
#[ignore = "run by compute_lane_layouts_agree_on_the_span_scene in a child process"]
fn span_records_child() {
    let out = std::env::var(RECORDS_OUT_ENV).expect("run by the parent test only");
    let far: f32 = std::env::var("CUBETRACE_TEST_SPAN_FAR")
        .expect("the far distance")
        .parse()
        .expect("a number");
    let ctx = gpu_context();
    let scene = span_scene(far);
    let camera = &scene.cameras[0];
    let mut r = GpuRenderer::new(&ctx, &scene, camera, options(Method::Compute)).unwrap();
    let frame = r.render(&ctx).unwrap();
    let (lo, hi) = frame.compute.as_ref().expect("compute stats").subgroup_size;
    let retraced = frame.compute.as_ref().expect("compute stats").retraced;
    std::fs::write(format!("{out}.subgroup"), format!("{lo} {hi} {retraced}")).unwrap();
    std::fs::write(format!("{out}.mask"), &frame.mask).unwrap();
    std::fs::write(
        &out,
        bytemuck::cast_slice::<PixelRecord, u8>(&frame.records),
    )
    .unwrap();
    finish_gpu(ctx);
}

/// A span-scene child's mask and records, the `(min, max)` subgroup size it ran with and the
/// rays it retraced.
type SpanRun = ((Vec<u8>, Vec<PixelRecord>), (u32, u32), u32);

/// The span scene's compute records with `lanes` lanes per ray (`CUBETRACE_RAY_LANES`) at
/// native vector width `bits` (lavapipe's subgroup size: bits / 32), far cube at `far`, and the
/// `(min, max)` subgroup size `compute_trace` ran with in the child and the rays it retraced
/// (its `ComputeStats`).
///
/// The child runs with `GALLIUM_OVERRIDE_CPU_CAPS=sse4.1`: at 128 bits Mesa 22.3's llvmpipe with
/// 128-bit vectors on a CPU with AVX2 / AVX-512 corrupts its heap ("double free or corruption",
/// in its own queue thread) on this scene and on the bowl and torus, for every method, the
/// envmap baseline included. Limited to AVX it ran on an Intel CI machine but still crashed on an
/// AMD EPYC one; limited to SSE4.1 it runs on both. Both widths run with that limit, and their
/// records are equal (spirv/README.md, "What lavapipe does").
fn span_records(lanes: &str, bits: u32, far: f32) -> SpanRun {
    span_records_capped(lanes, bits, far, None)
}

/// [`span_records`] with the first dispatch's step loop capped at `cap` steps
/// (`CUBETRACE_STEP_CAP`), as the driver's loop limit would cut it.
fn span_records_capped(lanes: &str, bits: u32, far: f32, cap: Option<u32>) -> SpanRun {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("records");
    let mut child = Command::new(std::env::current_exe().unwrap());
    // Both widths, so that only the subgroup size differs between them: limited to SSE4.1,
    // llvmpipe's SSE4.1 code rounds differently from its AVX2 code (196 of 2570 records differ).
    child.env("GALLIUM_OVERRIDE_CPU_CAPS", "sse4.1");
    let child_test = common::test_name(module_path!(), "span_records_child");
    if let Some(cap) = cap {
        child.env(STEP_CAP_ENV, cap.to_string());
    }
    let o = child
        .args(["--ignored", "--exact", &child_test, "--nocapture"])
        .env(RECORDS_OUT_ENV, &out)
        .env("CUBETRACE_TEST_SPAN_FAR", far.to_string())
        .env("CUBETRACE_RAY_LANES", lanes)
        .env("LP_NATIVE_VECTOR_WIDTH", bits.to_string())
        .env("XDG_RUNTIME_DIR", "/tmp")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "child failed:\n{text}");
    let mask = std::fs::read(format!("{}.mask", out.display())).unwrap();
    let bytes = std::fs::read(&out).unwrap();
    let ran: Vec<u32> = std::fs::read_to_string(format!("{}.subgroup", out.display()))
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    (
        (mask, bytemuck::pod_collect_to_vec(&bytes)),
        (ran[0], ran[1]),
        ran[2],
    )
}

/// Mirror pixels of `a` whose record differs from `b`'s (or whose mask does).
fn record_differences(a: &(Vec<u8>, Vec<PixelRecord>), b: &(Vec<u8>, Vec<PixelRecord>)) -> usize {
    assert_eq!(a.1.len(), b.1.len());
    (0..a.1.len())
        .filter(|&k| a.0[k] != b.0[k] || (a.0[k] == 1 && a.1[k] != b.1[k]))
        .count()
}

/// `main_lanes1` (1 lane per ray) and `main_wave` (1 ray per lane, the child tests spread over
/// the subgroup) give the same records as `main` (the thesis layout) on the span scene, at subgroup sizes 4 and 8 (each child reports the size `compute_trace` ran at,
/// checked against the one asked for), and the two sizes give the same records. Before `main_retrace`, lavapipe's loop limit (65535
/// iterations per invocation, spirv/README.md "Known defect") cut 1004 of its 2570 mirror rays
/// at 560 steps there (unresolved, `t_done` 0), where `main` needs up to 1581 steps but runs 8
/// times fewer loop iterations per step. Negative tests: a record changed as a cut ray would
/// be, and the records of the scene with the far cube moved, are told apart.
#[test]
fn compute_lane_layouts_agree_on_the_span_scene() {
    // Subgroup sizes 4 (with lavapipe's CPU caps limited to AVX: `span_records`) and 8.
    let mut by_width = Vec::new();
    let mut ran_at = Vec::new();
    for bits in [128, 256] {
        let (wide, wide_ran, wide_retraced) = span_records("32", bits, FAR);
        let (one, one_ran, one_retraced) = span_records("1", bits, FAR);
        let (wave, wave_ran, wave_retraced) = span_records("wave", bits, FAR);
        eprintln!(
            "width {bits}: retraced {wide_retraced} (main), {one_retraced} (main_lanes1), \
             {wave_retraced} (main_wave)"
        );
        // The child ran at the subgroup size asked for: every workgroup of the three layouts.
        assert_eq!(wide_ran, (bits / 32, bits / 32), "width {bits}");
        assert_eq!(one_ran, wide_ran, "width {bits}");
        assert_eq!(wave_ran, wide_ran, "width {bits}");
        ran_at.push(wide_ran);
        let mirror = wide.0.iter().filter(|&&m| m == 1).count();
        let unresolved = (0..wide.1.len())
            .filter(|&k| wide.0[k] == 1 && wide.1[k].status == RECORD_UNRESOLVED)
            .count();
        let cut = |r: &(Vec<u8>, Vec<PixelRecord>)| {
            (0..r.1.len())
                .filter(|&k| r.0[k] == 1 && r.1[k].cut != 0)
                .count()
        };
        eprintln!(
            "width {bits}: {mirror} mirror pixels, {unresolved} unresolved, cut: {} (main), {} \
             (main_lanes1), {} (main_wave)",
            cut(&wide),
            cut(&one),
            cut(&wave)
        );
        assert!(mirror > 2000 && unresolved * 100 <= mirror * 6);
        // The loop limit cuts `main` too on long enough traversals (an earlier kernel was cut on
        // 5 of these rays at S = 4); this one is not, so the sizes can be compared below.
        assert_eq!(cut(&wide), 0, "width {bits}");
        let d = record_differences(&one, &wide);
        assert_eq!(d, 0, "width {bits}: {d} of {mirror} records differ");
        let d = record_differences(&wave, &wide);
        assert_eq!(
            d, 0,
            "width {bits}: {d} of {mirror} records differ (main_wave)"
        );
        // No ray is cut here, so the retrace (the thesis layout over the cut queue) is made to
        // run by capping the first dispatch's step loop: hundreds of rays are then cut, and
        // the retrace must give every record the uncapped trace gives.
        for lanes in ["1", "wave"] {
            let (capped, _, retraced) = span_records_capped(lanes, bits, FAR, Some(2));
            eprintln!("width {bits}, {lanes}, 2 steps: {retraced} rays retraced");
            assert!(retraced >= 100, "{lanes}: {retraced} retraced");
            let d = record_differences(&capped, &wide);
            assert_eq!(d, 0, "width {bits}, {lanes}, capped: {d} records differ");
        }
        assert_eq!((wide_retraced, one_retraced, wave_retraced), (0, 0, 0));
        let k = (0..one.1.len())
            .find(|&k| one.0[k] == 1 && one.1[k].status != RECORD_UNRESOLVED)
            .unwrap();
        let mut perturbed = one.clone();
        perturbed.1[k].status = RECORD_UNRESOLVED;
        perturbed.1[k].cut = 1;
        assert_eq!(record_differences(&perturbed, &wide), 1);
        by_width.push(wide);
    }
    // Negative: the check above tells the sizes apart (a child that ignored
    // `LP_NATIVE_VECTOR_WIDTH` would report 8 at 128 bits and fail it).
    assert_ne!(ran_at[0], ran_at[1]);
    // And the sizes agree record for record.
    let d = record_differences(&by_width[0], &by_width[1]);
    assert_eq!(d, 0, "subgroup sizes 4 and 8: {d} records differ");
    let (moved, _, _) = span_records("32", 256, 0.5 * FAR);
    let (wide, _, _) = span_records("32", 256, FAR);
    let d = record_differences(&moved, &wide);
    assert!(d > 100, "moving the far cube changed {d} records");
}

//! Whole frames on the GPU (`GpuRenderer`): the fragment tracer against its CPU twin over the
//! same captured data, and the fragment tracer and the environment map against the exact
//! reference, on every built-in scene; and every mirror pixel's reflected ray (origin and
//! direction, both methods) against the CPU's own ray for that pixel. Needs a Vulkan driver
//! (CI: lavapipe); runs under the validation layer when installed and fails on any error it
//! reports.
mod common;
use common::render::{first_frame, sized_camera};
use common::{finish_gpu, gpu_context};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::check_layout;
use cubetrace::cpu::CmoTracer;
use cubetrace::cpu::fragment::{
    HitShading, PixelResult, envmap_fallback, envmap_pixel, trace_pixel_verified,
};
use cubetrace::cpu::options::TraceOptions;
use cubetrace::cpu::verify::triangle_corners;
use cubetrace::cubemap::pyramid::MipPyramid;
use cubetrace::metrics::{self, ErrorReport};
use cubetrace::reference::{self, Tracer};
use cubetrace::scene::{Scene, builtin};
use cubetrace::vk::GpuContext;
use cubetrace::vk::backend::shaders::{COMPOSITE, FRAGMENT_TRACE};
use cubetrace::vk::budget;
use cubetrace::vk::frame::{
    Fallback, FrameParams, GpuFrame, GpuRenderer, PixelRecord, RECORD_HIT, RECORD_UNRESOLVED,
    RenderOptions, capture_contents, scene_ranges,
};
use cubetrace::vk::passes::cmo::{CaptureContents, CmoData};
use glam::{DVec3, Vec3};

/// Frame size of these tests: big enough for about a thousand mirror pixels per scene, small
/// enough that the five scenes and their references take seconds on lavapipe.
const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;

fn camera(scene: &Scene) -> Camera {
    sized_camera(scene, (WIDTH, HEIGHT))
}

fn render(ctx: &GpuContext, scene: &Scene, options: RenderOptions) -> (GpuFrame, GpuRenderer) {
    first_frame(ctx, scene, &camera(scene), options, &scene.name)
}

fn options(method: Method, trace: TraceOptions) -> RenderOptions {
    RenderOptions {
        method,
        trace,
        // The twins model the tracing pass alone; the reflector check, which runs after it, is
        // judged in tests/frame/reflector_check.rs.
        reflector_check: false,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    }
}

#[test]
fn shared_structs_match_naga_layout() {
    let l = |name| FRAGMENT_TRACE.struct_layout(name).unwrap();
    check_layout!(
        FrameParams,
        l("FrameParams"),
        [
            eye,
            t_hi,
            background,
            width,
            flag_colour,
            height,
            fallback,
            check_below,
            tan_half,
            aspect,
            right,
            jitter_x,
            up,
            jitter_y,
            back,
            sample
        ]
    )
    .unwrap();
    check_layout!(
        PixelRecord,
        l("PixelRecord"),
        [
            origin, status, dir, cmo, point, riser, colour, face, x, y, texels, cells, traces, t,
            t_done, triangle, cut, fallback, bounces, checked
        ]
    )
    .unwrap();
    assert_eq!(
        COMPOSITE.struct_layout("PixelRecord"),
        Some(l("PixelRecord"))
    );
}

/// Per-pixel disagreements between the GPU records and a CPU twin given each record's ray:
/// status, deciding CMO, texel, riser flag and colour bits. Returns `(compared, disagreements)`.
fn twin_disagreements(
    frame: &GpuFrame,
    twin: impl Fn(Vec3, Vec3) -> PixelResult,
) -> (usize, usize) {
    let (mut compared, mut bad) = (0, 0);
    for (k, rec) in frame.records.iter().enumerate() {
        if frame.mask[k] == 0 {
            continue;
        }
        compared += 1;
        let r = twin(Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
        let t = r.texel;
        // Colours of verified hits are shaded at the hit (`hit_shade` and `Tracer::shade`,
        // within 2.4e-7 of each other: tests/tracer/gpu_verify.rs); others are the same bits.
        let colour_same = if r.triangle != u32::MAX {
            (r.colour - Vec3::from_array(rec.colour))
                .abs()
                .max_element()
                <= 1e-5
        } else {
            r.colour.to_array().map(f32::to_bits) == rec.colour.map(f32::to_bits)
        };
        let same = r.status == rec.status
            && r.cmo == rec.cmo
            && (t.face, t.x, t.y) == (rec.face, rec.x, rec.y)
            && u32::from(r.riser) == rec.riser
            && r.triangle == rec.triangle
            && r.point.to_array().map(f32::to_bits) == rec.point.map(f32::to_bits)
            && colour_same;
        if !same {
            bad += 1;
            if bad <= 3 {
                eprintln!("pixel {k}: GPU {rec:?}; CPU {r:?}");
            }
        }
    }
    (compared, bad)
}

/// The CPU twin over the data the GPU captured: tracers built from the read-back captures.
fn twins(ctx: &GpuContext, r: &GpuRenderer, opts: &TraceOptions) -> Vec<CmoTracer> {
    r.cmo()
        .read_back(ctx)
        .unwrap()
        .into_iter()
        .map(|c| CmoTracer::new(c, opts.params()))
        .collect()
}

/// The centre criterion on the GPU and on the CPU twin, over the same captured cube maps and
/// the same rays, agree on every mirror pixel of every built-in scene: status, deciding CMO,
/// texel and riser flag. (tests/tracer/gpu_twin.rs shows the tracers bit-identical on synthetic
/// data; this checks the frame around them: the captured data, the pyramid the GPU built, the ray
/// each pixel traces, and the ray length.) The bound is zero disagreements: lavapipe does not
/// contract multiply-adds, so the f32 arithmetic is the same.
#[test]
fn fragment_matches_cpu_twin_on_every_scene() {
    let ctx = gpu_context();
    for (name, _) in builtin::NAMES {
        let scene = builtin::by_name(name).unwrap();
        let (_, _, t_hi) = scene_ranges(&scene, &camera(&scene));
        let tracer = Tracer::new(&scene);
        let corners = triangle_corners(&scene.world());
        let shading = HitShading {
            scene: &scene,
            tracer: &tracer,
            corners: &corners,
        };
        for (accel, strict) in [(true, false), (false, false), (true, true)] {
            if (!accel || strict) && !["sphere-room", "torus"].contains(name) {
                continue; // the walk gives the same answers more slowly; strict on two scenes
            }
            let opts = TraceOptions {
                accel,
                strict,
                ..TraceOptions::centre()
            };
            let (frame, r) = render(&ctx, &scene, options(Method::Fragment, opts));
            let cmos = twins(&ctx, &r, &opts);
            if accel {
                // The pyramid the GPU built is the CPU's, bit for bit.
                let gpu_mip = r.cmo().read_mip(&ctx).unwrap();
                let cpu_mip: Vec<[f32; 2]> = cmos
                    .iter()
                    .flat_map(|c| MipPyramid::build(&c.cube).flatten())
                    .collect();
                assert!(
                    gpu_mip
                        .iter()
                        .map(|c| c.map(f32::to_bits))
                        .eq(cpu_mip.iter().map(|c| c.map(f32::to_bits))),
                    "{name}: GPU pyramid differs from the CPU's"
                );
            }
            let bg = scene.background;
            let (compared, bad) = twin_disagreements(&frame, |o, d| {
                trace_pixel_verified(&cmos, o, d, t_hi, &opts, bg, &shading)
            });
            eprintln!(
                "{name} (accel {accel}, strict {strict}): {bad} of {compared} mirror pixels differ from the CPU twin"
            );
            assert!(compared > 500, "{name}: only {compared} mirror pixels");
            assert_eq!(bad, 0, "{name}: GPU and CPU twin disagree");
        }
    }
    finish_gpu(ctx);
}

/// The environment map's twin: the same status, CMO, texel and colour bits on every mirror
/// pixel (the lookup is a face selection and two floors: no rounding to disagree on).
#[test]
fn envmap_matches_cpu_twin() {
    let ctx = gpu_context();
    for name in ["default", "bowl"] {
        let scene = builtin::by_name(name).unwrap();
        let opts = TraceOptions::centre();
        let (frame, r) = render(&ctx, &scene, options(Method::Envmap, opts));
        let cmos = twins(&ctx, &r, &opts);
        let bg = scene.background;
        let (compared, bad) = twin_disagreements(&frame, |o, d| envmap_pixel(&cmos, o, d, bg));
        eprintln!("{name} envmap: {bad} of {compared} mirror pixels differ from the CPU twin");
        assert!(compared > 500);
        assert_eq!(bad, 0, "{name}: envmap GPU and CPU twin disagree");
        // Negative: a twin looking up the other CMO (default has two) must disagree.
        if cmos.len() > 1 {
            let swapped: Vec<CmoTracer> = cmos.iter().rev().cloned().collect();
            let (_, bad) = twin_disagreements(&frame, |o, d| envmap_pixel(&swapped, o, d, bg));
            assert!(bad > compared / 10, "swapped CMOs: only {bad} differ");
        }
    }
    finish_gpu(ctx);
}

/// Negative: the same comparison with the twin given slightly different data (the CMO centre
/// moved by 1 mm, or a different continuity rule) must find disagreements.
#[test]
fn twin_comparison_detects_perturbed_data() {
    let ctx = gpu_context();
    let scene = builtin::sphere_room();
    let (_, _, t_hi) = scene_ranges(&scene, &camera(&scene));
    let opts = TraceOptions::centre();
    let (frame, r) = render(&ctx, &scene, options(Method::Fragment, opts));
    let bg = scene.background;
    let tracer = Tracer::new(&scene);
    let corners = triangle_corners(&scene.world());
    let shading = HitShading {
        scene: &scene,
        tracer: &tracer,
        corners: &corners,
    };
    let cmos = twins(&ctx, &r, &opts);
    let (compared, bad) = twin_disagreements(&frame, |o, d| {
        trace_pixel_verified(&cmos, o, d, t_hi, &opts, bg, &shading)
    });
    assert_eq!(
        bad, 0,
        "the unperturbed twin disagrees on {bad} of {compared}"
    );
    // A twin that reports the neighbouring triangle must disagree on (nearly) every hit.
    let (_, bad) = twin_disagreements(&frame, |o, d| {
        let mut p = trace_pixel_verified(&cmos, o, d, t_hi, &opts, bg, &shading);
        if p.triangle != u32::MAX {
            p.triangle ^= 1;
        }
        p
    });
    assert!(
        bad > compared / 2,
        "another triangle: only {bad} of {compared} differ"
    );
    let mut moved = twins(&ctx, &r, &opts);
    moved[0].cube.centre += Vec3::splat(1e-3);
    let (compared, bad) = twin_disagreements(&frame, |o, d| {
        trace_pixel_verified(&moved, o, d, t_hi, &opts, bg, &shading)
    });
    eprintln!("moved centre: {bad} of {compared} differ");
    assert!(
        bad > compared / 10,
        "moved centre: only {bad} of {compared}"
    );
    let strict = TraceOptions {
        continuity_k: 0.05,
        ..opts
    };
    let strict_cmos = twins(&ctx, &r, &strict);
    let (_, bad) = twin_disagreements(&frame, |o, d| {
        trace_pixel_verified(&strict_cmos, o, d, t_hi, &opts, bg, &shading)
    });
    eprintln!("strict continuity rule: {bad} of {compared} differ");
    assert!(bad > 0, "a different continuity rule changed nothing");
    finish_gpu(ctx);
}

/// Accuracy bounds per scene for the fragment tracer (centre criterion, acceleration on) at
/// 96x72 with the scene's own CMOs and cube size: `(max unresolved, max wrong surface, min PSNR
/// dB)`. Measured on lavapipe (Mesa 22.3.6):
///
/// | scene | unresolved | wrong surface | PSNR |
/// |---|---|---|---|
/// | default | 0.40% | 0.13% | 23.7 |
/// | sphere-room | 2.17% | 0.00% | 23.5 |
/// | teapot | 31.5% | 4.17% | 17.3 |
/// | torus | 0.48% | 5.62% | 21.3 |
/// | bowl | 0.19% | 0.00% | 24.8 |
///
/// Why these are not zero, and the bounds (measured value plus about a third, so that a
/// regression of a few pixels is caught but a driver's rounding is not):
/// - Unresolved: rays that pass behind an object as seen from every CMO (one CMO in
///   sphere-room: the space behind the box and the ball). The teapot has self-reflections on
///   and one CMO inside its body: its spout, handle and lid hide each other from that centre,
///   so a third of its rays start behind a part of the teapot the CMO sees (ALGORITHM.md; more
///   CMOs halve it, `--cmos 3`).
/// - Wrong surface: the torus and the teapot reflect themselves. The torus has
///   self-reflections off, so its inner ring is not captured and the reference's self-hits
///   cannot be found; the teapot captures only the parts facing its CMO.
/// - PSNR: the capture stores one colour per texel (256 per face side) where the reference
///   shades the exact hit point, and the curved mirrors minify the checkered and striped
///   textures, so texel-rate sampling aliases; the unresolved pixels' fallback adds to it.
fn fragment_bounds(name: &str) -> (f64, f64, f64) {
    match name {
        "default" => (0.006, 0.003, 22.0),
        "sphere-room" => (0.03, 0.003, 22.0),
        "teapot" => (0.40, 0.06, 16.0),
        "torus" => (0.008, 0.075, 20.0),
        "bowl" => (0.003, 0.003, 23.0),
        other => panic!("no bounds for scene {other}"),
    }
}

/// Least `(share correct, PSNR dB)` of the environment map per scene at 96x72, lower bounds
/// only (a better method passes): 80% of the measured share correct and the measured PSNR less
/// 1 dB. Measured on lavapipe (Mesa 22.3.6): default 0%, 14.46 dB; sphere-room 0.26%, 14.68
/// dB; teapot 0%, 13.26 dB; torus 0.09%, 15.90 dB; bowl 7.73%, 14.00 dB. Without parallax the
/// share correct is near zero but on the concave bowl, whose surroundings are far.
fn envmap_bounds(name: &str) -> (f64, f64) {
    match name {
        "default" => (0.0, 13.4),
        "sphere-room" => (0.002, 13.6),
        "teapot" => (0.0, 12.2),
        "torus" => (0.0007, 14.9),
        "bowl" => (0.061, 13.0),
        other => panic!("no bounds for scene {other}"),
    }
}

fn error_report(scene: &Scene, frame: &GpuFrame, reference: &reference::Frame) -> ErrorReport {
    metrics::compare(
        reference,
        &frame.traced(),
        &frame.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    )
}

fn within(r: &ErrorReport, (unresolved, wrong, psnr): (f64, f64, f64)) -> bool {
    r.unresolved <= unresolved && r.wrong_surface <= wrong && r.psnr_db >= psnr
}

#[test]
fn fragment_accuracy_against_reference_with_envmap_for_contrast() {
    let ctx = gpu_context();
    let mut failures = Vec::new();
    for (name, _) in builtin::NAMES {
        let scene = builtin::by_name(name).unwrap();
        let reference = reference::render(&scene, &Tracer::new(&scene), &camera(&scene), 1);
        let (frag, _) = render(
            &ctx,
            &scene,
            options(Method::Fragment, TraceOptions::centre()),
        );
        let (env, _) = render(
            &ctx,
            &scene,
            options(Method::Envmap, TraceOptions::centre()),
        );
        let f = error_report(&scene, &frag, &reference);
        let e = error_report(&scene, &env, &reference);
        for (m, r) in [("fragment", &f), ("envmap", &e)] {
            eprintln!(
                "{name:12} {m:9} mirror {:5}  unresolved {:6.2}%  wrong surface {:6.2}%  angle mean {:7.3} p95 {:7.3} deg  PSNR {:5.2} dB  mask mismatch {}",
                r.mirror_pixels,
                100.0 * r.unresolved,
                100.0 * r.wrong_surface,
                r.angular_mean_deg,
                r.angular_p95_deg,
                r.psnr_db,
                r.mask_mismatch
            );
        }
        // The rasterised mirror mask is the reference's (pixel centres, same projection) up to
        // pixels whose centre ray grazes the silhouette.
        assert!(f.mask_mismatch <= f.mirror_pixels / 100, "{name}: mask");
        assert!(
            within(&f, fragment_bounds(name)),
            "{name}: fragment {f:?} outside {:?}",
            fragment_bounds(name)
        );
        // The environment map (no parallax) is held to its own lower bounds ...
        let least = envmap_bounds(name);
        let got = common::quality(&e);
        if got.0 < least.0 || got.1 < least.1 {
            failures.push(format!("{name}: envmap {got:?} below {least:?}"));
        }
        // ... which its reflection black, and with its hit points moved by 0.5 m, fail.
        let traced = env.traced();
        let dim = metrics::compare(
            &reference,
            &common::blacked(&traced),
            &env.surface_position,
            &scene.cmo_centres(),
            scene.cmo.resolution,
        );
        let mut moved = traced.clone();
        for p in &mut moved.hit_position {
            *p += Vec3::splat(0.5);
        }
        let moved = metrics::compare(
            &reference,
            &moved,
            &env.surface_position,
            &scene.cmo_centres(),
            scene.cmo.resolution,
        );
        eprintln!(
            "{name:12} envmap: correct {:.2}%; black PSNR {:.2} dB; hit points moved: \
             correct {:.2}%",
            100.0 * got.0,
            dim.psnr_db,
            100.0 * common::quality(&moved).0
        );
        if dim.psnr_db >= least.1 || (least.0 > 0.0 && common::quality(&moved).0 >= least.0) {
            failures.push(format!("{name}: envmap negatives pass: {dim:?} {moved:?}"));
        }
        // Contrast: parallax is what the centre criterion adds; without it the environment map
        // hits the wrong surface on more pixels.
        assert!(e.wrong_surface > f.wrong_surface, "{name}: envmap {e:?}");
    }
    finish_gpu(ctx);
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Negative tests of the accuracy bounds: a frame that is wrong in a known way must fail them.
/// - Hit points moved by 3 texel footprints (more than the 2 of the wrong-surface rule).
/// - A coarse capture (8 texels per face side instead of the scene's 256).
#[test]
fn accuracy_bounds_reject_perturbed_frames() {
    let ctx = gpu_context();
    let scene = builtin::sphere_room();
    let bounds = fragment_bounds("sphere-room");
    let reference = reference::render(&scene, &Tracer::new(&scene), &camera(&scene), 1);
    let (mut frame, _) = render(
        &ctx,
        &scene,
        options(Method::Fragment, TraceOptions::centre()),
    );
    assert!(within(&error_report(&scene, &frame, &reference), bounds));
    let centre = scene.cmo_centres()[0];
    let texel_angle = 2.0 / scene.cmo.resolution as f32;
    for rec in &mut frame.records {
        if rec.status == RECORD_HIT {
            let p = Vec3::from_array(rec.point);
            let shift = 3.0 * texel_angle * (p - centre).length();
            rec.point = (p + Vec3::new(shift, 0.0, 0.0)).to_array();
        }
    }
    let moved = error_report(&scene, &frame, &reference);
    eprintln!("hit points moved: {moved:?}");
    assert!(!within(&moved, bounds));

    let mut coarse_scene = scene.clone();
    coarse_scene.cmo.resolution = 8;
    let (coarse, _) = render(
        &ctx,
        &coarse_scene,
        options(Method::Fragment, TraceOptions::centre()),
    );
    // Measured against the fine footprint, as the bounds are.
    let coarse = error_report(&scene, &coarse, &reference);
    eprintln!("8-texel capture: {coarse:?}");
    assert!(!within(&coarse, bounds));
    finish_gpu(ctx);
}

/// How the GPU's reflected rays compare with the CPU's own.
#[derive(Debug, Default)]
struct RayCheck {
    /// GPU mirror pixels compared (the CPU's primary ray hits a reflector there, and so does
    /// one of its four neighbours').
    compared: usize,
    /// GPU mirror pixels whose CPU primary ray hits no reflector (silhouette coverage).
    not_mirror_on_cpu: usize,
    /// Pixels whose origin or direction is off by more than [`RAY_TOL_PIXELS`].
    off: usize,
    /// Largest origin and direction errors, in pixel steps.
    worst_origin: f64,
    worst_dir: f64,
}

/// The CPU's own reflected ray at pixel `(i, j)`: `Camera::ray` through the pixel centre, the
/// reference's nearest hit, `reference::reflect` about its interpolated normal (or, with `flat`,
/// the triangle's face normal: the negative test). `None` where no reflector is hit.
fn cpu_reflected(
    tracer: &Tracer,
    cam: &Camera,
    (i, j): (i64, i64),
    flat: bool,
) -> Option<(DVec3, DVec3)> {
    if i < 0 || j < 0 || i >= cam.width as i64 || j >= cam.height as i64 {
        return None;
    }
    let (eye, d) = cam.ray(i as u32, j as u32);
    let hit = tracer
        .nearest(eye, d, None)
        .filter(|h| tracer.is_reflector(h.triangle))?;
    let n = if flat {
        let [a, b, c] = tracer.world.triangles[hit.triangle as usize]
            .map(|v| tracer.world.positions[v as usize]);
        (b - a).cross(c - a).normalize()
    } else {
        tracer.normal(&hit)
    };
    let dir = reference::reflect(d, n).normalize();
    Some((hit.position.as_dvec3(), dir.as_dvec3()))
}

/// The angle between two unit vectors, accurate near 0 (`acos` of an f32 dot is not).
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Every GPU mirror pixel's reflected ray (`PixelRecord::origin`, `dir`) against the CPU's own
/// ([`cpu_reflected`]; never the GPU's ray fed back). Errors are measured in pixel steps: the
/// change of the CPU's origin and direction to the nearest neighbouring pixel that also sees
/// the mirror, so one tolerance serves near and far, flat and curved mirrors. `offset` moves
/// the CPU's pixel (the negative test).
fn gpu_rays_against_cpu(
    scene: &Scene,
    frame: &GpuFrame,
    cam: &Camera,
    offset: (i64, i64),
    flat: bool,
) -> RayCheck {
    let tracer = Tracer::new(scene);
    let mut c = RayCheck::default();
    for j in 0..frame.height as i64 {
        for i in 0..frame.width as i64 {
            let k = (j * frame.width as i64 + i) as usize;
            if frame.mask[k] == 0 {
                continue;
            }
            let at = (i + offset.0, j + offset.1);
            let Some((o, d)) = cpu_reflected(&tracer, cam, at, flat) else {
                c.not_mirror_on_cpu += 1;
                continue;
            };
            let steps = [(1, 0), (-1, 0), (0, 1), (0, -1)]
                .into_iter()
                .filter_map(|(di, dj)| cpu_reflected(&tracer, cam, (at.0 + di, at.1 + dj), flat))
                .map(|(on, dn)| ((on - o).length(), angle(dn, d)))
                .filter(|&(so, sd)| so > 0.0 && sd > 0.0)
                .reduce(|a, b| (a.0.min(b.0), a.1.min(b.1)));
            let Some((step_o, step_d)) = steps else {
                c.not_mirror_on_cpu += 1;
                continue;
            };
            let rec = &frame.records[k];
            let go = Vec3::from_array(rec.origin).as_dvec3();
            let gd = Vec3::from_array(rec.dir).as_dvec3().normalize();
            let (eo, ed) = ((go - o).length() / step_o, angle(gd, d) / step_d);
            c.compared += 1;
            c.worst_origin = c.worst_origin.max(eo);
            c.worst_dir = c.worst_dir.max(ed);
            if !(eo <= RAY_TOL_PIXELS && ed <= RAY_TOL_PIXELS) {
                c.off += 1;
            }
        }
    }
    c
}

/// Tolerance of [`gpu_rays_against_cpu`], in pixel steps. The rasteriser places vertices on a
/// sub-pixel grid (Vulkan guarantees `subPixelPrecisionBits` >= 4, a 1/16 pixel step; lavapipe
/// has 8) and interpolates in f32, so the G-buffer's surface point and normal at a pixel
/// centre may sit up to a grid step off the CPU's; 0.1 covers 1/16. Measured on lavapipe over
/// the five built-in scenes, both methods: worst 0.0010 steps in origin and 0.013 in direction
/// (the teapot); a CPU pixel one to the right gives 1.2 to 8 steps and more, face normals
/// instead of interpolated ones 5 to 150 in direction.
const RAY_TOL_PIXELS: f64 = 0.1;

#[test]
fn gpu_reflected_rays_match_the_cpus_own() {
    let ctx = gpu_context();
    for name in ["default", "sphere-room", "bowl", "teapot", "torus"] {
        let scene = builtin::by_name(name).unwrap();
        for method in [Method::Fragment, Method::Compute] {
            let (frame, _) = render(&ctx, &scene, options(method, TraceOptions::centre()));
            let r = gpu_rays_against_cpu(&scene, &frame, &camera(&scene), (0, 0), false);
            eprintln!("{name} {method:?}: {r:?}");
            let mirror = frame.mask.iter().filter(|&&m| m != 0).count();
            // Silhouette pixels the rasteriser covers and the CPU ray misses: at most 2%
            // (measured: none).
            assert!(
                mirror > 500 && r.compared * 50 >= mirror * 49,
                "{name} {method:?}: {mirror} mirror pixels, {r:?}"
            );
            assert_eq!(r.off, 0, "{name} {method:?}: {r:?}");
        }
    }
    finish_gpu(ctx);
}

/// Negative tests of the ray comparison: the CPU ray of the pixel to the right, or reflected
/// about face normals instead of interpolated ones, is off almost everywhere.
#[test]
fn gpu_ray_comparison_rejects_a_shifted_pixel_and_face_normals() {
    let ctx = gpu_context();
    for name in ["sphere-room", "teapot"] {
        let scene = builtin::by_name(name).unwrap();
        let (frame, _) = render(
            &ctx,
            &scene,
            options(Method::Fragment, TraceOptions::centre()),
        );
        for (offset, flat) in [((1, 0), false), ((0, 0), true)] {
            let r = gpu_rays_against_cpu(&scene, &frame, &camera(&scene), offset, flat);
            assert!(
                r.compared > 500 && r.off * 10 > r.compared * 9,
                "{name}, offset {offset:?}, face normals {flat}: {r:?}"
            );
        }
    }
    finish_gpu(ctx);
}

/// Composite's environment-map fallback shades from the capture's triangle IDs
/// (`envmap_fallback` in `spirv/composite.wgsl`) as its CPU twin does
/// (`cpu::fragment::envmap_fallback`), on every unresolved mirror pixel of frames whose
/// capture holds no colour: the compute and fragment paths (centre criterion) and screen-space
/// reflections, whose unresolved pixels are many. Colours within 1e-5 per channel (the shading
/// of a hit agrees to 2.4e-7: tests/tracer/gpu_verify.rs). Negative: a twin reading IDs shifted
/// by one triangle disagrees.
#[test]
fn envmap_fallback_shades_from_triangle_ids_as_its_cpu_twin() {
    let ctx = gpu_context();
    for (name, method) in [
        ("sphere-room", Method::Compute),
        ("teapot", Method::Fragment),
        ("sphere-room", Method::Ssr),
    ] {
        let scene = builtin::by_name(name).unwrap();
        let opts = RenderOptions {
            fallback: Fallback::Envmap,
            ..options(method, TraceOptions::centre())
        };
        let (frame, r) = render(&ctx, &scene, opts);
        assert!(
            !r.cmo().contents().colour,
            "{name} {method:?} captured colour"
        );
        let tracer = Tracer::new(&scene);
        let corners = triangle_corners(&scene.world());
        let shading = HitShading {
            scene: &scene,
            tracer: &tracer,
            corners: &corners,
        };
        let cmos = twins(&ctx, &r, &opts.trace);
        let bg = scene.background;
        let compare = |cmos: &[CmoTracer]| {
            let (mut compared, mut bad, mut shaded) = (0, 0, 0);
            for (k, rec) in frame.records.iter().enumerate() {
                if frame.mask[k] == 0 || rec.status != RECORD_UNRESOLVED {
                    continue;
                }
                let (o, d) = (Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
                let cpu = envmap_fallback(cmos, o, d, bg, &shading);
                compared += 1;
                shaded += usize::from(cpu != bg);
                if (cpu - frame.colour[k]).abs().max_element() > 1e-5 {
                    bad += 1;
                    if bad <= 3 {
                        eprintln!("pixel {k}: GPU {} CPU {cpu}", frame.colour[k]);
                    }
                }
            }
            (compared, bad, shaded)
        };
        let (compared, bad, shaded) = compare(&cmos);
        eprintln!(
            "{name} {method:?}: {bad} of {compared} unresolved pixels differ ({shaded} shaded, not background)"
        );
        assert!(compared >= 10 && shaded * 2 > compared, "{name} {method:?}");
        assert_eq!(bad, 0, "{name} {method:?}");
        let mut shifted = cmos.clone();
        for id in &mut shifted[0].cube.triangle {
            if *id != u32::MAX {
                *id = (*id + 1) % corners.len() as u32;
            }
        }
        let (_, bad, _) = compare(&shifted);
        assert!(
            bad * 2 > compared,
            "shifted IDs: only {bad} of {compared} differ"
        );
    }
    finish_gpu(ctx);
}

/// At equal cube size the CMO data of an exact frame (compute, and fragment with the exact
/// criterion), with the default environment-map fallback, takes no more bytes than distance and
/// colour without IDs (`CaptureContents`' default) with the same pyramid. Negative: capturing both
/// colour and IDs takes more.
#[test]
fn exact_frames_take_no_more_cmo_memory_than_colour_and_distance() {
    let ctx = gpu_context();
    let scene = builtin::default();
    let centres = scene.cmo_centres();
    let size = scene.cmo.resolution;
    for method in [Method::Compute, Method::Fragment] {
        let opts = RenderOptions {
            fallback: Fallback::Envmap,
            ..options(method, TraceOptions::centre())
        };
        let (_, r) = render(&ctx, &scene, opts);
        let pyramid = method == Method::Fragment;
        let layout = |contents| {
            CmoData::with_contents(&ctx, &centres, size, false, pyramid, &opts.trace, contents)
                .unwrap()
                .bytes()
        };
        let before = layout(CaptureContents::default());
        let both = layout(CaptureContents {
            colour: true,
            triangle_ids: true,
        });
        let now = r.cmo().bytes();
        eprintln!("{method:?}: CMO bytes {now}, before verified hits {before}, with both {both}");
        assert!(now <= before, "{method:?}: {now} > {before}");
        assert!(both > before);
    }
    // The estimate the memory check uses says the same for the compute path, per texel.
    for s in [false, true] {
        assert!(
            budget::cmo_bytes_per_texel_with(
                s,
                capture_contents(Method::Compute, &TraceOptions::centre())
            ) < budget::cmo_bytes_per_texel(s)
        );
    }
    finish_gpu(ctx);
}

/// The environment-map fallback shades what the colour capture stored: over a CPU capture
/// (`cpu::capture::capture`, which keeps both the colour and the triangle ID of each texel), the
/// fallback looked up from the CMO centre along each texel's centre direction equals that
/// texel's captured colour within 1e-3 on all but a few texels (measured 0 of 6144 on
/// sphere-room and 7 of 6144 on bowl, bound 0.5%; the capture's hit is in f64, the fallback's in
/// f32, and those few were not looked into further). Negative: looking up one texel over gives
/// other colours on about a third of the texels.
#[test]
fn envmap_fallback_shades_what_the_colour_capture_stored() {
    for name in ["sphere-room", "bowl"] {
        let scene = builtin::by_name(name).unwrap();
        let tracer = Tracer::new(&scene);
        let corners = triangle_corners(&scene.world());
        let shading = HitShading {
            scene: &scene,
            tracer: &tracer,
            corners: &corners,
        };
        let centre = scene.cmo_centres()[0];
        let size = 32;
        let cube = cubetrace::cpu::capture::capture(&scene, &tracer, centre, size);
        let cmos = [CmoTracer::new(
            cube.clone(),
            TraceOptions::centre().params(),
        )];
        let bg = scene.background;
        let differ = |shift: u32| {
            (0..cube.distance.len())
                .filter(|&i| {
                    let t = cubetrace::cubemap::Texel::from_index(i, size);
                    let looked = cubetrace::cubemap::Texel {
                        x: (t.x + shift) % size,
                        ..t
                    };
                    let dir = cubetrace::cubemap::face::texel_centre_dir(looked, size).normalize();
                    let c = cube.colour[i];
                    let stored = if c[3] > 0.0 {
                        Vec3::new(c[0], c[1], c[2])
                    } else {
                        bg
                    };
                    (envmap_fallback(&cmos, centre, dir, bg, &shading) - stored)
                        .abs()
                        .max_element()
                        > 1e-3
                })
                .count()
        };
        let (same, shifted) = (differ(0), differ(1));
        eprintln!(
            "{name}: {same} of {} texels differ from the captured colour; one texel over {shifted}",
            cube.distance.len()
        );
        assert!(same * 200 <= cube.distance.len(), "{name}: {same}");
        assert!(shifted > 20 * same.max(1), "{name}: {shifted}");
    }
}

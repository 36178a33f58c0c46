//! The reflector check (`vk::passes::bvh::ReflectorCheck`, on by default, `--no-reflector-check`): after
//! the cubemap trace, each resolved mirror ray is traced exactly against the reflectors the CMOs
//! do not capture (or capture only where they face a centre), and a nearer hit replaces the
//! record's. Judged against the exact CPU reference at 96x72, on both cubemap paths with the
//! centre criterion (under the default, bounded, a reflector the capture takes is in the lists,
//! and is not checked: the teapot's frame builds no check):
//! - torus and teapot: same triangle as the reference on >= 99 % of the resolved mirror pixels
//!   with the check, and measurably fewer without it (the negative test);
//! - every record's hit triangle is met by the record's own ray (f64), and a perturbed triangle
//!   ID fails that test (its negative);
//! - `default` and `sphere-room` (one convex reflector each): the check does not exist, nothing
//!   is allocated and no pass runs;
//! - the bench reports the share of records the check changed and its pass's time, apart from
//!   the fallback's, and both are 0 with the check off.
//!
//! Runs under the validation layer when installed and fails on any error it reports.
use crate::common;
use common::render::first_frame;
use common::{finish_gpu, gpu_context, meets};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::metrics;
use cubetrace::reference::{self, Frame, Tracer};
use cubetrace::scene::Scene;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{
    Fallback, GpuFrame, RECORD_HIT, RECORD_UNRESOLVED, REFLECTOR_CHECK_PASS, RenderOptions,
};
use glam::Vec3;

const SIZE: (u32, u32) = (96, 72);
const PATHS: [Method; 2] = [Method::Compute, Method::Fragment];

fn load(name: &str) -> (Scene, Camera) {
    common::render::load_sized(name, SIZE)
}

/// One frame with the CLI's default fallback (`trace`) and the centre criterion; whether the
/// renderer built the check; the rays the check traced (`None` without it). The centre
/// criterion's CMOs miss what the check finds; the default's (bounded) lists carry the
/// teapot's own triangles, so there the check changes nothing (measured: 0 of 1032 pixels at
/// 96x72; torus 126 of 2295, as with the centre criterion).
fn render(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    method: Method,
    check: bool,
) -> (GpuFrame, Option<u32>) {
    let options = RenderOptions {
        method,
        trace: cubetrace::cpu::options::TraceOptions::centre(),
        fallback: Fallback::Trace,
        reflector_check: check,
        ..RenderOptions::default()
    };
    let (f, r) = first_frame(ctx, scene, camera, options, &scene.name);
    let rays = r.reflector_check().map(|c| {
        c.passes
            .queue
            .read_counter(ctx)
            .unwrap_or_else(|e| panic!("{e}"))
            .count
    });
    (f, rays)
}

fn same_triangle(scene: &Scene, refr: &Frame, frame: &GpuFrame) -> f64 {
    metrics::compare(
        refr,
        &frame.traced(),
        &frame.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    )
    .same_triangle
}

/// Hit records (mirror pixels) whose triangle, shifted by `shift` (0: as recorded), the record's
/// ray does not meet; and the number of hit records judged.
fn off_triangle(
    tracer: &Tracer,
    frame: &GpuFrame,
    shift: u32,
    only_checked: bool,
) -> (usize, usize) {
    let mut off = 0;
    let mut n = 0;
    for (k, r) in frame.records.iter().enumerate() {
        if frame.mask[k] == 0 || r.status != RECORD_HIT || (only_checked && r.checked == 0) {
            continue;
        }
        n += 1;
        let tri = r.triangle.wrapping_add(shift);
        if meets(
            tracer,
            Vec3::from_array(r.origin),
            Vec3::from_array(r.dir),
            tri,
        )
        .is_none()
        {
            off += 1;
        }
    }
    (off, n)
}

#[test]
fn reflector_check_finds_the_reflectors_the_cmos_miss() {
    let ctx = gpu_context();
    for name in ["torus", "teapot"] {
        let (scene, camera) = load(name);
        assert!(!scene.check_triangles(false).is_empty(), "{name}");
        let tracer = Tracer::new(&scene);
        let refr = reference::render(&scene, &tracer, &camera, 1);
        for method in PATHS {
            let (with, rays) = render(&ctx, &scene, &camera, method, true);
            let (without, none) = render(&ctx, &scene, &camera, method, false);
            assert_eq!(none, None, "{name} {method:?}: no check when turned off");
            let resolved = (0..with.records.len())
                .filter(|&k| with.mask[k] != 0 && with.records[k].status != RECORD_UNRESOLVED)
                .count();
            let checked = with.checked_pixels();
            let s_with = same_triangle(&scene, &refr, &with);
            let s_without = same_triangle(&scene, &refr, &without);
            eprintln!(
                "{name} {method:?}: same triangle {:.2} % with the check ({checked} of {} mirror \
                 pixels changed, {} rays), {:.2} % without",
                100.0 * s_with,
                with.mirror_pixels(),
                rays.unwrap_or(0),
                100.0 * s_without,
            );
            // The check traces what it must: the method's resolved mirror rays, before the
            // fallback (which finishes the unresolved ones; none changes after it).
            // (Every pixel is resolved in the end: the fallback finished the others.)
            assert_eq!(resolved, with.mirror_pixels(), "{name} {method:?}");
            // The pixels whose method hit the check found at the ray's own start went to the
            // fallback after it: they were resolved when the check ran.
            let start = with.start_hit_pixels();
            assert_eq!(
                rays.map(|n| n as usize),
                Some(with.mirror_pixels() - with.fallback_pixels() + start),
                "{name} {method:?}: one check ray per mirror pixel the method resolved"
            );
            if !with.pass_times.is_empty() {
                assert!(
                    with.pass_ns(REFLECTOR_CHECK_PASS) > 0.0,
                    "{name} {method:?}"
                );
                assert_eq!(
                    without.pass_ns(REFLECTOR_CHECK_PASS),
                    0.0,
                    "{name} {method:?}"
                );
            }
            assert!(checked > 0, "{name} {method:?}: the check changed nothing");
            assert_eq!(without.checked_pixels(), 0, "{name} {method:?}");
            for (k, r) in with.records.iter().enumerate() {
                if with.mask[k] != 0 && r.checked == 2 {
                    // Handed to the fallback, which found a hit away from the start.
                    assert_eq!(r.fallback, 1, "{name} {method:?} pixel {k}");
                    assert!(r.t > 1e-3, "{name} {method:?} pixel {k}: t {}", r.t);
                }
                if with.mask[k] != 0 && r.checked == 1 {
                    assert_eq!(r.status, RECORD_HIT, "{name} {method:?} pixel {k}");
                    assert_eq!(r.fallback, 0, "{name} {method:?} pixel {k}");
                    assert!(
                        tracer.is_reflector(r.triangle),
                        "{name} {method:?} pixel {k}"
                    );
                }
            }
            assert!(s_with >= 0.99, "{name} {method:?}: {s_with}");
            // The negative test: without the check the same triangle share is measurably lower.
            assert!(
                s_without < s_with - 0.01,
                "{name} {method:?}: {s_without} without, {s_with} with"
            );
            // No record names a triangle its ray does not meet; the check's own hits included.
            let (off, n) = off_triangle(&tracer, &with, 0, false);
            assert_eq!(
                off, 0,
                "{name} {method:?}: {off} of {n} hits off their triangle"
            );
            // Negative: the next triangle's ID is missed by (almost) every checked hit's ray.
            let (off, n) = off_triangle(&tracer, &with, 1, true);
            assert!(n > 0 && off * 2 > n, "{name} {method:?}: {off} of {n}");
        }
    }
    finish_gpu(ctx);
}

/// One convex reflector (`default`'s ellipsoid, `sphere-room`'s sphere) cannot see itself except
/// where interpolated normals send a ray below its face's plane: only the rays under
/// `Scene::check_below` are traced (the grazing ones near the outline), and there the check
/// finds the mirror the reference finds (no record names a triangle its ray misses; the same
/// triangle share is never below the one without the check).
#[test]
fn one_convex_reflector_checks_only_its_grazing_rays() {
    let ctx = gpu_context();
    for name in ["default", "sphere-room"] {
        let (scene, camera) = load(name);
        let below = scene.check_below();
        assert!(below > 0.0 && below < 0.2, "{name}: {below}");
        let tracer = Tracer::new(&scene);
        let refr = reference::render(&scene, &tracer, &camera, 1);
        for method in PATHS {
            let (with, rays) = render(&ctx, &scene, &camera, method, true);
            let (without, _) = render(&ctx, &scene, &camera, method, false);
            let rays = rays.expect("a check is built") as usize;
            let resolved = with.mirror_pixels() - with.fallback_pixels();
            assert!(
                rays > 0 && rays * 5 < resolved,
                "{name} {method:?}: {rays} of {resolved} rays checked"
            );
            let s_with = same_triangle(&scene, &refr, &with);
            let s_without = same_triangle(&scene, &refr, &without);
            eprintln!(
                "{name} {method:?}: {rays} of {resolved} rays checked, {} changed; same \
                 triangle {:.2} % with, {:.2} % without",
                with.checked_pixels(),
                100.0 * s_with,
                100.0 * s_without
            );
            assert!(s_with >= s_without, "{name} {method:?}");
            for (k, r) in with.records.iter().enumerate() {
                if with.mask[k] != 0 && r.checked != 0 {
                    assert!(tracer.is_reflector(r.triangle), "{name} {method:?} {k}");
                }
            }
            let (off, n) = off_triangle(&tracer, &with, 0, false);
            assert_eq!(
                off, 0,
                "{name} {method:?}: {off} of {n} hits off their triangle"
            );
        }
    }
    finish_gpu(ctx);
}

#[test]
fn reflector_check_selection_rule() {
    // The rule itself: the torus (one reflector, not convex) is checked whole.
    let (torus, _) = load("torus");
    let world = torus.world();
    let reflector = (0..world.triangles.len() as u32)
        .filter(|&t| world.objects[world.triangle_object[t as usize] as usize].reflector)
        .collect::<Vec<_>>();
    assert_eq!(torus.check_triangles(false), reflector);
    assert_eq!(
        torus.check_below(),
        2.0,
        "every ray of a non-convex reflector"
    );
    // One convex reflector: every triangle, the grazing rays only.
    let (sphere, _) = load("sphere-room");
    assert!(!sphere.check_triangles(false).is_empty());
    assert!(sphere.check_below() < 0.2);
    // Two reflectors, both convex: each can see the other, so both are checked.
    let (mut two, _) = load("sphere-room");
    let k = two
        .meshes
        .iter()
        .position(|m| !m.reflector && m.is_convex())
        .expect("a convex non-reflector mesh");
    two.meshes[k].reflector = true;
    let world = two.world();
    let reflectors = (0..world.triangles.len() as u32)
        .filter(|&t| world.objects[world.triangle_object[t as usize] as usize].reflector)
        .collect::<Vec<_>>();
    assert!(
        two.meshes
            .iter()
            .filter(|m| m.reflector)
            .all(|m| m.is_convex())
    );
    assert_eq!(two.check_triangles(false), reflectors);
    assert_eq!(two.check_below(), 2.0, "every ray: each can see the other");
    // Under the bounded criterion's lists a reflector the capture takes is in the lists: not
    // checked. The teapot sees itself (captured): nothing is checked; the torus's scene turns
    // its self-reflections off: checked whole, as under the centre criterion; and so is the
    // teapot with them off (the negative).
    let (mut teapot, _) = load("teapot");
    assert!(teapot.self_capture().iter().any(|&c| c));
    assert!(!teapot.check_triangles(false).is_empty());
    assert!(teapot.check_triangles(true).is_empty());
    assert_eq!(torus.check_triangles(true), reflector);
    teapot.self_reflections = cubetrace::scene::SelfReflections::Off;
    assert_eq!(teapot.check_triangles(true), teapot.check_triangles(false));
}

/// Under the bounded criterion (the default) a frame builds no reflector check where every
/// reflector is in the lists (teapot: it sees itself, so the capture takes it), and the frame
/// still shows the reference's triangle on every resolved mirror pixel; where a reflector is
/// left out of the capture (torus: self-reflections off) the check is built and finds hits.
#[test]
fn bounded_lists_with_the_reflector_need_no_check() {
    let ctx = gpu_context();
    let bounded = |scene: &Scene, camera: &Camera, method| {
        let options = RenderOptions {
            method,
            fallback: Fallback::Trace,
            ..RenderOptions::default()
        };
        assert!(options.bounded());
        first_frame(&ctx, scene, camera, options, &scene.name)
    };
    let (teapot, camera) = load("teapot");
    let tracer = Tracer::new(&teapot);
    let refr = reference::render(&teapot, &tracer, &camera, 1);
    for method in PATHS {
        let (f, r) = bounded(&teapot, &camera, method);
        assert!(r.reflector_check().is_none(), "teapot {method:?}");
        assert_eq!(f.pass_ns(REFLECTOR_CHECK_PASS), 0.0, "teapot {method:?}");
        let same = same_triangle(&teapot, &refr, &f);
        assert!(same >= 0.999, "teapot {method:?}: {same}");
        let (off, n) = off_triangle(&tracer, &f, 0, false);
        assert_eq!(
            off, 0,
            "teapot {method:?}: {off} of {n} hits off their triangle"
        );
    }
    // Negative: the torus's reflector is not captured, so its check is built and changes
    // pixels.
    let (torus, camera) = load("torus");
    let (f, r) = bounded(&torus, &camera, Method::Compute);
    assert!(r.reflector_check().is_some());
    assert!(f.checked_pixels() > 0);
    finish_gpu(ctx);
}

#[test]
fn bench_reports_the_check_apart_from_the_fallback() {
    use cubetrace::bench::{self, BenchConfig, Method};
    let ctx = gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let cfg = BenchConfig {
        scenes: vec!["torus".into()],
        methods: bench::method_grid(&[Method::Compute], true),
        width: 48,
        height: 36,
        frames: 1,
        warmup: 0,
        cube_size: Some(64),
        flip: false,
        heatmaps: false,
        floor: None,
        out: out.path().to_path_buf(),
        ..BenchConfig::default()
    };
    let on_report = bench::run(&ctx, &cfg, &indicatif::ProgressBar::hidden()).expect("bench");
    let off = bench::run(
        &ctx,
        &BenchConfig {
            reflector_check: false,
            ..cfg.clone()
        },
        &indicatif::ProgressBar::hidden(),
    )
    .expect("bench");
    let (on, off) = (&on_report.runs[0], &off.runs[0]);
    assert_eq!(on.kind, Method::Compute);
    assert!(on.checked_share > 0.0, "{on:?}");
    assert_eq!(off.checked_share, 0.0);
    assert_eq!(off.check_ns.median, 0.0);
    if !on.passes.is_empty() {
        assert!(on.check_ns.median > 0.0, "{on:?}");
        assert!(on.total_ns.median >= on.trace_ns.median + on.check_ns.median);
    }
    // The fallback's share is the unresolved rays', with or without the check.
    assert_eq!(on.fallback_share, off.fallback_share);
    assert!(
        on.error.same_triangle > off.error.same_triangle,
        "{on:?} {off:?}"
    );
    let md = bench::report::runs_table(&on_report);
    assert!(md.contains("| check % | check ms |"), "{md}");
    finish_gpu(ctx);
}

//! The compute path (`--method compute`, thesis alg. 3) on lavapipe:
//! - `hier32` GPU build against `Hier32::build` + `flatten`, bit for bit (any N, padding);
//! - the GPU-sized dispatch (ray count, indirect arguments, zero mirror pixels);
//! - per built-in scene at 96x72 (reduced cube sizes, some not a power of two): compute against
//!   fragment (same status, CMO, hit texel and riser on every mirror pixel), against the CPU
//!   twin `cpu::compute` over the GPU's own capture (every field bit for bit, counters included),
//!   and against the reference (the fragment path's accuracy);
//! - subgroup sizes 4, 8 and 16 (`LP_NATIVE_VECTOR_WIDTH` = 128, 256, 512, in child processes)
//!   give byte-identical EXR output in the three lane layouts (skipped, with the reason, on
//!   drivers other than lavapipe, which ignore that variable);
//! - the wave layout writes what the one-lane layout writes on every built-in scene.
//!
//! Every comparison has a negative test. Runs under the validation layer when installed and
//! fails on any validation error.
mod common;
use common::bits::cell_bits;
use common::render::first_frame;
use common::{distance_cube, finish_gpu, gpu_context};

use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::process::Command;

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::check_layout;
use cubetrace::cpu::compute::trace_alg3;
use cubetrace::cpu::multi::{MultiStatus, Verify, trace_cmos_verified_by};
use cubetrace::cpu::options::TraceOptions;
use cubetrace::cpu::verify::triangle_corners;
use cubetrace::cpu::{CmoTracer, TraceResult};
use cubetrace::cubemap::CubeMap;
use cubetrace::cubemap::face::Texel;
use cubetrace::cubemap::pyramid::Hier32;
use cubetrace::metrics::{self, ErrorReport};
use cubetrace::reference;
use cubetrace::scene::{self, CmoPlacement, Scene};
use cubetrace::vk::backend::shaders::{APPEND, COMPUTE_TRACE, DISPATCH_ARGS, HIER32};
use cubetrace::vk::frame::{
    Fallback, GpuFrame, GpuRenderer, PixelRecord, RenderOptions, scene_ranges,
};
use cubetrace::vk::methods::compute::{
    AppendedRay, DispatchArgs, DispatchParams, HierConfig, RAY_LANES_ENV, RayCounter, ray_lanes,
    workgroup_size,
};
use cubetrace::vk::passes::hier32::{Hier32Params, build_hier_gpu, hier32_len};
use cubetrace::vk::{ContextOptions, GpuContext};
use glam::Vec3;

const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;

/// Cube size per built-in scene: small to keep the suite fast, two of them not powers of two
/// (48: the root level is padded; 33: every level is).
fn compute_cube_size(name: &str) -> u32 {
    match name {
        "sphere-room" => 48,
        "torus" => 33,
        "bowl" => 128,
        _ => 64,
    }
}

/// [`gpu_context`] plus the subgroup size, which these tests depend on.
fn compute_context() -> GpuContext {
    let ctx = gpu_context();
    eprintln!("subgroup size {}", ctx.report().subgroup_size);
    ctx
}

fn compute_scene(name: &str, cube_size: u32) -> (Scene, Camera) {
    let (mut s, cam) = common::render::load_sized(name, (WIDTH, HEIGHT));
    s.cmo.resolution = cube_size;
    (s, cam)
}

fn compute_render(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    method: Method,
) -> (GpuFrame, Vec<CubeMap>) {
    let options = RenderOptions {
        method,
        trace: TraceOptions::centre(),
        fallback: Fallback::Flag,
        // The twins model the tracing pass alone; the reflector check, which runs after it, is
        // judged in tests/frame/reflector_check.rs.
        reflector_check: false,
        ..RenderOptions::default()
    };
    let (frame, r) = first_frame(ctx, scene, camera, options, &scene.name);
    let cubes = r.cmo().read_back(ctx).unwrap_or_else(|e| panic!("{e}"));
    (frame, cubes)
}

// ---------------------------------------------------------------------------------------------
// Layouts and the hierarchy pass.

#[test]
fn compute_struct_layouts_match_naga() {
    check_layout!(
        Hier32Params,
        HIER32.struct_layout("Hier32Params").unwrap(),
        [
            cmo_count,
            src_width,
            src_height,
            src_offset,
            dst_width,
            dst_height,
            dst_offset,
            hier_len,
            gx,
            gy,
            from_texels,
            texels_per_cmo
        ]
    )
    .unwrap();
    check_layout!(
        HierConfig,
        COMPUTE_TRACE.struct_layout("HierConfig").unwrap(),
        [root, hier_len, mode, step_cap, dims, shape]
    )
    .unwrap();
    for pass in [&APPEND, &COMPUTE_TRACE] {
        check_layout!(
            AppendedRay,
            pass.struct_layout("AppendedRay").unwrap(),
            [origin, pixel, dir, t_min, from_triangle, bounce, pad0, pad1]
        )
        .unwrap();
    }
    // A bounce round copies a BVH queue into the compute queue: the fields the trace reads lie
    // at `BvhRay`'s offsets (negative: `flags` is not `bounce`).
    use cubetrace::vk::passes::bvh::BvhRay;
    use std::mem::offset_of;
    assert_eq!(size_of::<AppendedRay>(), size_of::<BvhRay>());
    for (a, b) in [
        (offset_of!(AppendedRay, origin), offset_of!(BvhRay, origin)),
        (offset_of!(AppendedRay, pixel), offset_of!(BvhRay, pixel)),
        (offset_of!(AppendedRay, dir), offset_of!(BvhRay, dir)),
        (offset_of!(AppendedRay, t_min), offset_of!(BvhRay, t_min)),
        (
            offset_of!(AppendedRay, from_triangle),
            offset_of!(BvhRay, from_triangle),
        ),
        (offset_of!(AppendedRay, bounce), offset_of!(BvhRay, bounce)),
    ] {
        assert_eq!(a, b);
    }
    assert_ne!(offset_of!(AppendedRay, bounce), offset_of!(BvhRay, flags));
    check_layout!(
        RayCounter,
        DISPATCH_ARGS.struct_layout("RayCounter").unwrap(),
        [count, subgroup_max, subgroup_min_not, traced, cut]
    )
    .unwrap();
    check_layout!(
        DispatchParams,
        DISPATCH_ARGS.struct_layout("DispatchParams").unwrap(),
        [rays_per_group, cmo_count, size, retrace_rays_per_group]
    )
    .unwrap();
    check_layout!(
        DispatchArgs,
        DISPATCH_ARGS.struct_layout("DispatchArgs").unwrap(),
        [x, y, z]
    )
    .unwrap();
    check_layout!(
        PixelRecord,
        COMPUTE_TRACE.struct_layout("PixelRecord").unwrap(),
        [
            origin, status, dir, cmo, point, riser, colour, face, x, y, texels, cells, traces, t,
            t_done, triangle, cut, fallback, bounces, checked
        ]
    )
    .unwrap();
}

#[test]
fn hier32_gpu_matches_cpu_bit_for_bit() {
    let ctx = compute_context();
    for size in [1u32, 3, 4, 5, 32, 33, 48, 64, 100, 128, 256, 1000] {
        let a = distance_cube(size, u64::from(size), None);
        let b = distance_cube(size, u64::from(size) + 77, Some(size % 6));
        let cubes = vec![a, b];
        let gpu = build_hier_gpu(&ctx, &cubes).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(gpu.len(), 2);
        for (k, cube) in cubes.iter().enumerate() {
            let cpu = Hier32::build(cube).flatten();
            assert_eq!(cpu.len(), hier32_len(size));
            assert_eq!(
                cell_bits(&gpu[k]),
                cell_bits(&cpu),
                "N = {size}, CMO {k}: GPU hierarchy differs from the CPU's"
            );
        }
    }
    finish_gpu(ctx);
}

#[test]
fn hier32_comparison_detects_a_changed_texel() {
    let ctx = compute_context();
    for size in [33u32, 64] {
        let cube = distance_cube(size, 5, None);
        let gpu =
            build_hier_gpu(&ctx, std::slice::from_ref(&cube)).unwrap_or_else(|e| panic!("{e}"));
        // Lower one finite texel below every other: its cells' minimum changes on every level.
        let mut changed = cube.clone();
        let i = changed
            .distance
            .iter()
            .position(|d| d.is_finite())
            .expect("a finite texel");
        changed.distance[i] = 0.25;
        let cpu = Hier32::build(&changed).flatten();
        let diff = cell_bits(&gpu[0])
            .iter()
            .zip(cell_bits(&cpu))
            .filter(|(a, b)| **a != *b)
            .count();
        assert!(
            diff >= Hier32::build(&cube).levels.len() - 1,
            "N = {size}: only {diff} cells differ"
        );
    }
    finish_gpu(ctx);
}

// ---------------------------------------------------------------------------------------------
// Queue and dispatch.

#[test]
fn dispatch_is_sized_on_the_gpu_and_empty_without_mirror_pixels() {
    let ctx = compute_context();
    let (scene, camera) = compute_scene("default", 32);
    let options = RenderOptions {
        method: Method::Compute,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let mut r = GpuRenderer::new(&ctx, &scene, &camera, options).unwrap_or_else(|e| panic!("{e}"));
    let frame = r.render(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let stats = frame.compute.clone().expect("compute stats");
    let n = frame.mirror_pixels() as u32;
    assert!(n > 100, "{n} mirror pixels");
    assert_eq!(stats.rays, n, "one queued ray per mirror pixel");
    let args = r
        .compute_path()
        .expect("compute path")
        .read_dispatch_args(&ctx)
        .unwrap_or_else(|e| panic!("{e}"));
    let (lane_cap, _) = ray_lanes(&ctx, None).unwrap_or_else(|e| panic!("{e}"));
    let per_group = 256 / ctx.report().subgroup_size.min(32).min(lane_cap);
    assert_eq!(
        DispatchParams::for_lanes(ctx.report().subgroup_size, lane_cap).rays_per_group,
        per_group
    );
    assert_eq!(
        DispatchParams::for_subgroup_size(8).rays_per_group,
        DispatchParams::for_lanes(8, 32).rays_per_group
    );
    assert_eq!(DispatchParams::for_lanes(8, 1).rays_per_group, 256);
    assert_eq!(
        args,
        DispatchArgs {
            x: n.div_ceil(per_group),
            y: 1,
            z: 1
        }
    );
    let names: Vec<&str> = frame.pass_times.iter().map(|(n, _)| n.as_str()).collect();
    if ctx.report().timestamps_supported() {
        assert_eq!(
            names,
            [
                "capture",
                "hier32",
                "gbuffer",
                "append",
                "dispatch_args",
                "compute_trace",
                // The default scene's one convex reflector: its grazing rays are checked.
                "reflector_check",
                "composite"
            ]
        );
    }

    // Looking away from the mirror: no ray, an empty dispatch, every pixel composited.
    let mut away = camera.clone();
    away.target = away.eye + (away.eye - camera.target);
    let mut r = GpuRenderer::new(&ctx, &scene, &away, options).unwrap_or_else(|e| panic!("{e}"));
    let frame = r.render(&ctx).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(frame.mirror_pixels(), 0, "the camera still sees a mirror");
    assert_eq!(frame.compute.as_ref().map(|c| c.rays), Some(0));
    let args = r
        .compute_path()
        .expect("compute path")
        .read_dispatch_args(&ctx)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(args, DispatchArgs { x: 0, y: 1, z: 1 });
    assert!(frame.colour.iter().all(|c| c.is_finite()));
    finish_gpu(ctx);
}

// ---------------------------------------------------------------------------------------------
// Compute against fragment, CPU twin and reference.

/// `(status, cmo, face, x, y, riser, triangle)` of a record: what both exact paths must agree
/// on (the verified hit's triangle included).
fn decision(r: &PixelRecord) -> [u32; 7] {
    [r.status, r.cmo, r.face, r.x, r.y, r.riser, r.triangle]
}

/// Mirror pixels of `a` where `b` decided differently (or is not a mirror pixel).
fn decision_disagreements(a: &GpuFrame, b: &GpuFrame) -> Vec<usize> {
    (0..a.mask.len())
        .filter(|&k| {
            a.mask[k] != 0 && (b.mask[k] == 0 || decision(&a.records[k]) != decision(&b.records[k]))
        })
        .collect()
}

fn status_code(s: MultiStatus) -> u32 {
    match s {
        MultiStatus::Hit => 0,
        MultiStatus::Escaped => 1,
        MultiStatus::Unresolved => 2,
    }
}

/// Every field the compute path writes for one ray, as bits.
fn gpu_fields(r: &PixelRecord, stats: [u32; 4]) -> Vec<u32> {
    let mut v = decision(r).to_vec();
    v.extend([
        r.t.to_bits(),
        r.t_done.to_bits(),
        r.traces,
        r.texels,
        r.cells,
    ]);
    v.extend(r.point.iter().map(|p| p.to_bits()));
    v.extend(stats);
    v
}

/// The CPU twin's fields for the same ray (`cpu::compute` with `subgroup` lanes inside the
/// handoff of `cpu::multi`), in [`gpu_fields`]' order.
fn cpu_fields(
    tracers: &[CmoTracer],
    corners: &[[Vec3; 3]],
    r: &PixelRecord,
    t_hi: f32,
    subgroup: u32,
) -> Vec<u32> {
    let sums = Cell::new([0u32; 4]);
    let m = trace_cmos_verified_by(
        tracers,
        Vec3::from_array(r.origin),
        Vec3::from_array(r.dir),
        0.0,
        t_hi,
        Some(Verify { triangles: corners }),
        |tr, seg| {
            let res: TraceResult = trace_alg3(tr, std::slice::from_ref(seg), subgroup)[0];
            let c = res.counters;
            let s = sums.get();
            sums.set([
                s[0] + c.texels,
                s[1] + c.cells,
                s[2] + c.descents,
                s[3] + c.backtracks,
            ]);
            res
        },
    );
    let Texel { face, x, y } = m.result.texel;
    let mut v = vec![
        status_code(m.status),
        m.cmo,
        face,
        x,
        y,
        u32::from(m.result.riser),
        m.triangle,
        m.result.t.to_bits(),
        m.t_done.to_bits(),
        m.traces,
        m.result.counters.texels,
        m.result.counters.cells,
    ];
    v.extend(m.point.to_array().iter().map(|p| p.to_bits()));
    v.extend(sums.get());
    v
}

fn twin_disagreements(
    frame: &GpuFrame,
    cubes: &[CubeMap],
    corners: &[[Vec3; 3]],
    t_hi: f32,
    subgroup: u32,
) -> Vec<(usize, Vec<u32>, Vec<u32>)> {
    let params = TraceOptions::default().params();
    let tracers: Vec<CmoTracer> = cubes
        .iter()
        .map(|c| CmoTracer::new(c.clone(), params))
        .collect();
    let stats = frame.compute.as_ref().expect("compute stats");
    (0..frame.mask.len())
        .filter(|&k| frame.mask[k] != 0)
        .filter_map(|k| {
            let g = gpu_fields(&frame.records[k], stats.per_pixel[k]);
            let c = cpu_fields(&tracers, corners, &frame.records[k], t_hi, subgroup);
            (g != c).then_some((k, g, c))
        })
        .collect()
}

/// `a` is at least as accurate as `b`: no more unresolved or wrong-surface pixels, PSNR no lower.
fn as_accurate(a: &ErrorReport, b: &ErrorReport) -> bool {
    a.mirror_pixels == b.mirror_pixels
        && a.unresolved <= b.unresolved
        && a.wrong_surface <= b.wrong_surface
        && (a.psnr_db >= b.psnr_db || (a.psnr_db.is_nan() && b.psnr_db.is_nan()))
}

/// The error of `f` against the reference, printed (the figures the bounds were read from).
fn report(scene: &Scene, label: &str, refr: &reference::Frame, f: &GpuFrame) -> ErrorReport {
    let r = metrics::compare(
        refr,
        &f.traced(),
        &f.surface_position,
        &scene.cmo_centres(),
        scene.cmo.resolution,
    );
    eprintln!(
        "  {label:>8}: {} mirror px, unresolved {:.3}%, wrong surface {:.3}%, PSNR {:.2} dB",
        r.mirror_pixels,
        100.0 * r.unresolved,
        100.0 * r.wrong_surface,
        r.psnr_db
    );
    r
}

/// For every built-in scene: compute == fragment on every mirror pixel's decision, compute ==
/// CPU alg3 twin on every field, compute as accurate as fragment against the reference; and the
/// negative side of each comparison.
#[test]
fn compute_matches_fragment_cpu_twin_and_reference_on_every_scene() {
    let ctx = compute_context();
    let subgroup = ctx.report().subgroup_size;
    // Read by `wave_layout_matches_the_twin_on_every_scene`, which runs this test again.
    eprintln!("compute_trace entry: {}", ray_lanes(&ctx, None).unwrap().1);
    let mut total = 0usize;
    let mut envmap_worse = 0usize;
    for &(name, _) in scene::builtin::NAMES {
        let n = compute_cube_size(name);
        let (scene, camera) = compute_scene(name, n);
        let (compute, cubes) = compute_render(&ctx, &scene, &camera, Method::Compute);
        let (fragment, _) = compute_render(&ctx, &scene, &camera, Method::Fragment);
        let stats = compute.compute.as_ref().expect("compute stats");
        let mirror = compute.mirror_pixels();
        total += mirror;
        assert!(mirror > 50, "{name}: only {mirror} mirror pixels");
        assert_eq!(compute.mask, fragment.mask, "{name}: masks differ");
        assert_eq!(stats.rays as usize, mirror, "{name}: ray count");
        assert_eq!(
            stats.subgroup_size,
            (subgroup, subgroup),
            "{name}: subgroup size seen by the kernel"
        );

        // Compute against fragment: the same decision on every mirror pixel.
        let d = decision_disagreements(&compute, &fragment);
        let count = |f: &dyn Fn(&PixelRecord) -> bool| {
            (0..compute.mask.len())
                .filter(|&k| compute.mask[k] != 0 && f(&compute.records[k]))
                .count()
        };
        eprintln!(
            "{name} (N = {n}): {mirror} mirror pixels (hit {}, riser {}, escaped {}, unresolved {}, handoff {}), {} disagreements with fragment",
            count(&|r| r.status == 0),
            count(&|r| r.status == 0 && r.riser != 0),
            count(&|r| r.status == 1),
            count(&|r| r.status == 2),
            count(&|r| r.traces > 1),
            d.len()
        );
        assert!(
            d.is_empty(),
            "{name}: compute and fragment disagree on {} of {mirror} mirror pixels, e.g. pixel {}: {:?} vs {:?}",
            d.len(),
            d[0],
            decision(&compute.records[d[0]]),
            decision(&fragment.records[d[0]])
        );

        // Compute against the CPU twin of alg. 3 over the GPU's own capture: every field.
        let t_hi = scene_ranges(&scene, &camera).2;
        let corners = triangle_corners(&scene.world());
        let tw = twin_disagreements(&compute, &cubes, &corners, t_hi, subgroup);
        assert!(
            tw.is_empty(),
            "{name}: {} pixels differ from the CPU alg3 twin, e.g. {:?}",
            tw.len(),
            tw[0]
        );

        // Negative: move one decided texel of a hit pixel and the twin must notice.
        let k = (0..compute.mask.len())
            .find(|&k| compute.mask[k] != 0 && compute.records[k].status == 0)
            .expect("a hit pixel");
        let r = &compute.records[k];
        let mut changed = cubes.clone();
        let t = Texel {
            face: r.face,
            x: r.x,
            y: r.y,
        };
        let i = t.index(n);
        changed[r.cmo as usize].distance[i] *= 4.0;
        let tw = twin_disagreements(&compute, &changed, &corners, t_hi, subgroup);
        assert!(
            tw.iter().any(|(p, _, _)| *p == k),
            "{name}: the twin comparison missed a changed hit texel"
        );

        // Against the reference: the fragment path's accuracy or better. Negative: the
        // environment map (no parallax) fails that bound on the scenes with near objects.
        let tracer = reference::Tracer::new(&scene);
        let refr = reference::render(&scene, &tracer, &camera, 1);
        let rc = report(&scene, "compute", &refr, &compute);
        let rf = report(&scene, "fragment", &refr, &fragment);
        let (envmap, _) = compute_render(&ctx, &scene, &camera, Method::Envmap);
        let re = report(&scene, "envmap", &refr, &envmap);
        assert!(
            as_accurate(&rc, &rf),
            "{name}: compute {rc:?} less accurate than fragment {rf:?}"
        );
        if !as_accurate(&re, &rf) {
            envmap_worse += 1;
        }
    }
    eprintln!("{total} mirror pixels compared in all");
    assert_eq!(
        envmap_worse,
        scene::builtin::NAMES.len(),
        "the accuracy bound must reject the environment map on every scene"
    );
    finish_gpu(ctx);
}

/// The wave layout (`CUBETRACE_RAY_LANES=wave`) against fragment, the CPU twin (every field of
/// every record, counters included) and the reference on every built-in scene: the test above,
/// run again in a child process with the variable set (it is read when the renderer is made).
/// The child says which entry point it ran, so a child that ignored the variable fails here.
#[test]
fn wave_layout_matches_the_twin_on_every_scene() {
    let name = common::test_name(
        module_path!(),
        "compute_matches_fragment_cpu_twin_and_reference_on_every_scene",
    );
    let o = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", &name, "--nocapture"])
        .env(RAY_LANES_ENV, "wave")
        .env("XDG_RUNTIME_DIR", "/tmp")
        .output()
        .unwrap_or_else(|e| panic!("spawning the test binary: {e}"));
    let text = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "child failed:\n{text}");
    assert!(
        text.contains("compute_trace entry: main_wave"),
        "the child did not run main_wave:\n{text}"
    );
}

/// Odd configurations: tiny cubes (N <= 4: the texels are the root, no hierarchy buffer; N = 5:
/// one level), N = 17, and three or five CMOs placed automatically (more handoffs): compute ==
/// fragment on every decision and == the CPU twin on every field.
#[test]
fn compute_matches_with_tiny_cubes_and_several_cmos() {
    let ctx = compute_context();
    let subgroup = ctx.report().subgroup_size;
    for (name, n, cmos) in [
        ("default", 1u32, None),
        ("torus", 3, Some(3u32)),
        ("sphere-room", 4, None),
        ("bowl", 5, Some(5)),
        ("teapot", 17, Some(3)),
    ] {
        let (mut scene, camera) = compute_scene(name, n);
        if let Some(count) = cmos {
            scene.cmo.placement = CmoPlacement::Auto { count };
        }
        let (compute, cubes) = compute_render(&ctx, &scene, &camera, Method::Compute);
        let (fragment, _) = compute_render(&ctx, &scene, &camera, Method::Fragment);
        let mirror = compute.mirror_pixels();
        assert!(mirror > 50, "{name}: only {mirror} mirror pixels");
        let d = decision_disagreements(&compute, &fragment);
        let handoffs = (0..compute.mask.len())
            .filter(|&k| compute.mask[k] != 0 && compute.records[k].traces > 1)
            .count();
        eprintln!(
            "{name} (N = {n}, {} CMOs): {mirror} mirror pixels ({handoffs} with a handoff), {} disagreements with fragment",
            cubes.len(),
            d.len()
        );
        assert!(d.is_empty(), "{name}, N = {n}: {} disagreements", d.len());
        let t_hi = scene_ranges(&scene, &camera).2;
        let corners = triangle_corners(&scene.world());
        let tw = twin_disagreements(&compute, &cubes, &corners, t_hi, subgroup);
        assert!(
            tw.is_empty(),
            "{name}, N = {n}: {} pixels differ from the CPU twin, e.g. {:?}",
            tw.len(),
            tw[0]
        );
    }
    finish_gpu(ctx);
}

/// Negative test of the compute/fragment comparison: a fragment render from different CMO data
/// (another cube size) must disagree on many pixels.
#[test]
fn fragment_comparison_detects_other_cmo_data() {
    let ctx = compute_context();
    let (scene, camera) = compute_scene("default", 64);
    let (compute, _) = compute_render(&ctx, &scene, &camera, Method::Compute);
    let (scene32, _) = compute_scene("default", 32);
    let (fragment, _) = compute_render(&ctx, &scene32, &camera, Method::Fragment);
    let d = decision_disagreements(&compute, &fragment);
    eprintln!(
        "{} of {} mirror pixels disagree with N = 32",
        d.len(),
        compute.mirror_pixels()
    );
    assert!(d.len() * 4 > compute.mirror_pixels());
    finish_gpu(ctx);
}

/// The compute method refuses the approximate criteria (it implements the bounded and centre
/// ones only).
#[test]
fn compute_refuses_approximate_criteria() {
    let ctx = compute_context();
    let (scene, camera) = compute_scene("default", 16);
    let mut options = RenderOptions {
        method: Method::Compute,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    options.trace.criterion = cubetrace::cpu::options::TraceCriterion::Threshold;
    let err = GpuRenderer::new(&ctx, &scene, &camera, options).err();
    assert!(
        err.is_some_and(|e| e.to_string().contains("bounded and centre criteria")),
        "the threshold criterion was accepted"
    );
    finish_gpu(ctx);
}

/// The kernel carries no strict code (`--strict` is the fragment pass's): a renderer asked for
/// strict mode is refused with the flag named, and the same options without it are accepted (the
/// negative).
#[test]
fn compute_refuses_strict_mode() {
    let ctx = compute_context();
    let (scene, camera) = compute_scene("default", 16);
    let options = |strict: bool| RenderOptions {
        method: Method::Compute,
        trace: TraceOptions {
            strict,
            ..TraceOptions::centre()
        },
        ..RenderOptions::default()
    };
    let err = GpuRenderer::new(&ctx, &scene, &camera, options(true)).err();
    assert!(
        err.is_some_and(|e| e.to_string().contains("--strict")),
        "strict mode was accepted"
    );
    assert!(
        GpuRenderer::new(&ctx, &scene, &camera, options(false)).is_ok(),
        "the centre criterion without strict mode was refused"
    );
    finish_gpu(ctx);
}

// ---------------------------------------------------------------------------------------------
// Subgroup sizes, in child processes (the driver reads LP_NATIVE_VECTOR_WIDTH when it loads).
// Every child runs with `GALLIUM_OVERRIDE_CPU_CAPS=sse4.1`: at 128 bits on a CPU with AVX2 or
// AVX-512, Mesa 22.3's llvmpipe corrupts its own heap on some scenes and shaders (spirv/README.md,
// "Known defect"; this scene's capture shader set it off on an AVX-512 machine). Limited to
// SSE4.1 it runs at 128, 256 and 512 bits, with the same rounding at each, so the widths still
// differ only in the subgroup size.

struct ChildRun {
    subgroup: (u32, u32),
    exr: Vec<u8>,
}

fn run_child(
    width_bits: u32,
    lanes: &str,
    cube_size: u32,
    criterion: &str,
    out: &Path,
    validate: bool,
) -> ChildRun {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubetrace"));
    cmd.env("LP_NATIVE_VECTOR_WIDTH", width_bits.to_string())
        .env("GALLIUM_OVERRIDE_CPU_CAPS", "sse4.1")
        .env(RAY_LANES_ENV, lanes)
        .env("XDG_RUNTIME_DIR", "/tmp")
        .env_remove("RUST_LOG")
        .args([
            "-v",
            "render",
            "default",
            "--method",
            "compute",
            "--width",
            &WIDTH.to_string(),
            "--height",
            &HEIGHT.to_string(),
            "--cube-size",
            &cube_size.to_string(),
            "--fallback",
            "flag",
            "--criterion",
            criterion,
            "-o",
        ])
        .arg(out);
    if validate {
        cmd.arg("--validate");
    }
    let o = cmd
        .output()
        .unwrap_or_else(|e| panic!("spawning cubetrace: {e}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "child failed:\n{text}");
    let line = text
        .lines()
        .find(|l| l.contains("compute:") && l.contains("subgroup size"))
        .unwrap_or_else(|| panic!("no compute stats in the output:\n{text}"));
    eprintln!("LP_NATIVE_VECTOR_WIDTH={width_bits}: {line}");
    let after = |key: &str| -> u32 {
        let s = &line[line.find(key).unwrap_or_else(|| panic!("no `{key}`")) + key.len()..];
        let digits: String = s.chars().take_while(char::is_ascii_digit).collect();
        digits.parse().unwrap_or_else(|e| panic!("`{key}`: {e}"))
    };
    let exr = std::fs::read(out).unwrap_or_else(|e| panic!("{}: {e}", out.display()));
    ChildRun {
        subgroup: (after("(min "), after("subgroup size ")),
        exr,
    }
}

/// Whether the device the children will pick is lavapipe, the one driver that reads
/// `LP_NATIVE_VECTOR_WIDTH` (its `driverName` is `llvmpipe`); on any other the subgroup size
/// cannot be steered and the test is skipped with the reason.
fn steerable_subgroup_size(report: &cubetrace::vk::DeviceReport) -> bool {
    report.driver_name.as_deref() == Some("llvmpipe") || report.name.starts_with("llvmpipe")
}

#[test]
fn subgroup_sizes_4_8_16_give_identical_output() {
    let ctx = GpuContext::new(ContextOptions::for_tests()).unwrap_or_else(|e| panic!("{e}"));
    let (report, validate) = (ctx.report().clone(), ctx.validation_enabled());
    drop(ctx);
    if !steerable_subgroup_size(&report) {
        eprintln!(
            "skipped: the device is {} (driver {:?}), which ignores LP_NATIVE_VECTOR_WIDTH; \
             only lavapipe (llvmpipe) lets the test choose subgroup sizes 4, 8 and 16",
            report.name, report.driver_name
        );
        return;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gpu_compute");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    // The three entry points (thesis layout, lane cap 32; lane cap 1; the wave layout) at every
    // size, with both criteria that compute implements.
    for criterion in ["bounded", "centre"] {
        let mut runs = Vec::new();
        for lanes in ["32", "1", "wave"] {
            for (bits, size) in [(128u32, 4u32), (256, 8), (512, 16)] {
                let file = format!("sg{size}-lanes{lanes}-{criterion}.exr");
                let r = run_child(bits, lanes, 48, criterion, &dir.join(file), validate);
                assert_eq!(
                    r.subgroup,
                    (size, size),
                    "LP_NATIVE_VECTOR_WIDTH={bits}: the kernel ran with subgroup sizes {:?}",
                    r.subgroup
                );
                runs.push((size, lanes, r));
            }
        }
        for (size, lanes, r) in &runs[1..] {
            assert!(
                r.exr == runs[0].2.exr,
                "{criterion}: subgroup {size} with lane cap {lanes} differs from subgroup 4 \
                 with lane cap 32"
            );
        }
        // Negative: other CMO data gives another file (the centre criterion's: the bounded
        // image does not depend on the cube size, its lists taking 32 texels at both).
        if criterion == "centre" {
            let other = run_child(256, "32", 40, criterion, &dir.join("sg8-n40.exr"), validate);
            assert!(other.exr != runs[1].2.exr, "the EXR comparison is blind");
        }
    }
}

/// `cubetrace render SCENE --method compute --fallback flag ARGS` with
/// `CUBETRACE_RAY_LANES=lanes` (the native subgroup size), written to `out`: the EXR's bytes
/// (colour, hit position, triangle IDs, the unresolved flag).
fn render_with_lanes(
    scene: &str,
    lanes: &str,
    args: &[&str],
    out: &Path,
    validate: bool,
) -> Vec<u8> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubetrace"));
    cmd.env(RAY_LANES_ENV, lanes)
        .env("XDG_RUNTIME_DIR", "/tmp")
        .env_remove("RUST_LOG")
        .args([
            "render",
            scene,
            "--method",
            "compute",
            "--width",
            &WIDTH.to_string(),
        ])
        .args(["--height", &HEIGHT.to_string(), "--fallback", "flag"])
        .args(args)
        .arg("-o")
        .arg(out);
    if validate {
        cmd.arg("--validate");
    }
    let o = cmd
        .output()
        .unwrap_or_else(|e| panic!("spawning cubetrace: {e}"));
    let text = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{scene} with {lanes}:\n{text}");
    std::fs::read(out).unwrap_or_else(|e| panic!("{}: {e}", out.display()))
}

/// The wave layout (`main_wave`: one ray per lane, the subgroup's crossed children spread over
/// its lanes, the keys from `children_crossed`) writes the same EXR as `main_lanes1` on every
/// built-in scene and two corpus scenes with the default (`bounded`: the pick, every candidate
/// bit and the counters are in the records), and with the `centre` criterion on two of them.
/// Negative: the same scene at another cube size differs (the centre criterion's frame: the
/// bounded one does not depend on it).
#[test]
fn wave_layout_renders_what_the_one_lane_layout_renders() {
    let ctx = GpuContext::new(ContextOptions::for_tests()).unwrap_or_else(|e| panic!("{e}"));
    let validate = ctx.validation_enabled();
    drop(ctx);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gpu_compute_wave");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let scenes = env!("CARGO_MANIFEST_DIR").to_owned() + "/tests/scenes";
    let mut runs: Vec<(String, Vec<&str>)> = scene::builtin::NAMES
        .iter()
        .map(|&(name, _)| (name.to_owned(), vec!["--cube-size", "64"]))
        .collect();
    for corpus in ["mug", "robot-table"] {
        runs.push((
            format!("{scenes}/{corpus}/scene.toml"),
            vec!["--cube-size", "64"],
        ));
    }
    for name in ["default", "teapot"] {
        runs.push((
            name.to_owned(),
            vec!["--cube-size", "64", "--criterion", "centre"],
        ));
    }
    let mut teapot = Vec::new();
    for (k, (scene, args)) in runs.iter().enumerate() {
        let one = render_with_lanes(
            scene,
            "1",
            args,
            &dir.join(format!("{k}-one.exr")),
            validate,
        );
        let wave = render_with_lanes(
            scene,
            "wave",
            args,
            &dir.join(format!("{k}-wave.exr")),
            validate,
        );
        assert!(
            one == wave,
            "{scene} {args:?}: main_wave's EXR differs from main_lanes1's"
        );
        if scene == "teapot" && args.len() == 4 {
            teapot = wave;
        }
    }
    // With `--fallback flag` the unresolved channel is the cube maps' own: a coarser capture
    // leaves other pixels unresolved.
    let other = ["--cube-size", "48", "--criterion", "centre"];
    let moved = render_with_lanes("teapot", "wave", &other, &dir.join("moved.exr"), validate);
    assert!(
        !teapot.is_empty() && moved != teapot,
        "the EXR comparison is blind"
    );
}

/// `render --compute-layout` picks the entry point (stated under `-v`), over
/// `CUBETRACE_RAY_LANES`; without either, lavapipe runs `main_lanes1` (`main_lanes1_bounded`
/// with the default criterion). A method that has no layouts refuses the flag, naming it.
#[test]
fn compute_layout_flag_picks_the_entry_point() {
    let run = |args: &[&str], env: Option<&str>| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubetrace"));
        cmd.env("XDG_RUNTIME_DIR", "/tmp")
            .env_remove("RUST_LOG")
            .env_remove(RAY_LANES_ENV)
            .args(["-v", "render", "default", "--width", "16", "--height", "12"])
            .args(args);
        if let Some(v) = env {
            cmd.env(RAY_LANES_ENV, v);
        }
        let o = cmd
            .output()
            .unwrap_or_else(|e| panic!("spawning cubetrace: {e}"));
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gpu_compute_layout");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let out = dir.join("layout.png");
    let out = out.to_str().unwrap();
    for (args, env, entry) in [
        (vec!["--compute-layout", "wave"], None, "main_wave"),
        (vec!["--compute-layout", "thesis"], None, "main"),
        (
            vec!["--compute-layout", "one-lane"],
            Some("wave"),
            "main_lanes1",
        ),
        (vec!["--compute-layout", "wave"], Some("32"), "main_wave"),
        (vec![], None, "main_lanes1"),
        (vec![], Some("wave"), "main_wave"),
    ] {
        let mut a = vec!["--method", "compute", "--criterion", "centre", "-o", out];
        a.extend(args.iter().copied());
        let (ok, text) = run(&a, env);
        assert!(ok, "{args:?} {env:?}:\n{text}");
        assert!(
            text.contains(&format!("pipeline {entry} created")),
            "{args:?} {env:?}: not {entry}:\n{text}"
        );
    }
    // The default criterion's entries carry its name.
    let (ok, text) = run(&["--method", "compute", "-o", out], None);
    assert!(
        ok && text.contains("pipeline main_lanes1_bounded created"),
        "{text}"
    );
    let (ok, text) = run(
        &[
            "--method",
            "fragment",
            "--compute-layout",
            "wave",
            "-o",
            out,
        ],
        None,
    );
    assert!(!ok && text.contains("--compute-layout"), "{text}");
}

/// A layout other than 32, 1 or wave in `CUBETRACE_RAY_LANES` is refused with a clear error.
#[test]
fn bad_ray_lanes_is_a_clear_error() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gpu_compute");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let out = dir.join("bad-lanes.png");
    let _ = std::fs::remove_file(&out);
    let o = Command::new(env!("CARGO_BIN_EXE_cubetrace"))
        .env(RAY_LANES_ENV, "7")
        .env("XDG_RUNTIME_DIR", "/tmp")
        .args(["render", "default", "--method", "compute", "--width", "16"])
        .args(["--height", "12", "-o"])
        .arg(&out)
        .output()
        .unwrap_or_else(|e| panic!("spawning cubetrace: {e}"));
    let text = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "accepted a lane cap of 7");
    assert!(
        text.contains(RAY_LANES_ENV) && text.contains("expected 32, 1 or wave"),
        "{text}"
    );
    assert!(!out.exists(), "left an output behind");
}

/// The skip decision: lavapipe is steered, a real GPU is not (reports taken from this device's,
/// renamed).
#[test]
fn subgroup_size_test_skips_only_off_lavapipe() {
    let ctx = GpuContext::new(ContextOptions::for_tests()).unwrap_or_else(|e| panic!("{e}"));
    let mut report = ctx.report().clone();
    drop(ctx);
    report.name = "llvmpipe (LLVM 15.0.6, 256 bits)".into();
    report.driver_name = Some("llvmpipe".into());
    assert!(steerable_subgroup_size(&report));
    report.name = "NVIDIA GeForce RTX 4090".into();
    report.driver_name = Some("NVIDIA".into());
    assert!(!steerable_subgroup_size(&report));
}

/// The kernel's workgroup stays within `maxComputeWorkgroupSubgroups`: 128 invocations at
/// subgroup size 4 on lavapipe (whose limit is 32 subgroups), 256 otherwise, and the dispatch is
/// sized for it (reports taken from this device's, changed).
#[test]
fn workgroup_size_respects_the_subgroup_limit() {
    let ctx = GpuContext::new(ContextOptions::for_tests()).unwrap_or_else(|e| panic!("{e}"));
    let mut report = ctx.report().clone();
    drop(ctx);
    report.max_compute_workgroup_subgroups = Some(32);
    report.subgroup_size = 8;
    assert_eq!(workgroup_size(&report), 256);
    report.subgroup_size = 4;
    assert_eq!(workgroup_size(&report), 128);
    // Negative: a device that allows 64 subgroups keeps 256, one that does not say keeps 256.
    report.max_compute_workgroup_subgroups = Some(64);
    assert_eq!(workgroup_size(&report), 256);
    report.max_compute_workgroup_subgroups = None;
    assert_eq!(workgroup_size(&report), 256);
    assert_eq!(DispatchParams::for_group(128, 4, 1).rays_per_group, 128);
    assert_eq!(
        DispatchParams::for_group(128, 4, 1).retrace_rays_per_group,
        32
    );
    assert_eq!(DispatchParams::for_group(128, 4, 32).rays_per_group, 32);
    assert_eq!(
        DispatchParams::for_group(256, 8, 1),
        DispatchParams::for_lanes(8, 1)
    );
}

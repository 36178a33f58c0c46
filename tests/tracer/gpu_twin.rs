//! The GPU tracer (`spirv/shared/trace.wgsl`, run by the `trace_probe` pass) against its CPU twin
//! (`cpu::options::trace_ray`) on analytic scenes, ray by ray, on lavapipe under the validation
//! layer.
//!
//! Centre criterion (walk and mip march): status, CMO, texel, riser flag, counters, `t`,
//! `t_done` and the world point must be **bit-identical**. Approximate criteria: the same,
//! within the bound stated at `approximate_criteria_match_the_cpu`. Every comparison has a
//! negative twin that perturbs the GPU's input and must see disagreements.

use crate::common;
use common::analytic::{Aabb, enter_box, enter_sphere, exit_box, sphere_roots};
use common::{Rng, finish_gpu, gpu_context};

use common::trace_probe::{ProbeParams, ProbeRay, ProbeResult, trace_probe, trace_probe_entry};
use cubetrace::check_layout;
use cubetrace::cpu::multi::{MultiResult, MultiStatus};
use cubetrace::cpu::options::{TraceCriterion, TraceOptions, TraceSampling, trace_ray};
use cubetrace::cpu::{CmoTracer, Status};
use cubetrace::cubemap::CubeMap;
use cubetrace::vk::GpuContext;
use cubetrace::vk::backend::shaders::TRACE_PROBE;
use cubetrace::vk::passes::cmo::CmoData;
use cubetrace::vk::passes::cmo::{TraceConfig, exact_mip_only};
use glam::Vec3;

// ---------------------------------------------------------------------------------------------
// Analytic scenes.

#[derive(Clone, Copy)]
enum Scene {
    /// A box room with a floating box occluder (as in tests/tracer/cpu_trace.rs).
    BoxRoom,
    /// A spherical room with a sphere occluder.
    SphereRoom,
    /// Two spheres in the void (most directions see nothing: `+inf` distances).
    Void,
    /// Nothing captured: every distance `+inf` (cut radius 0, every ray escapes).
    Nothing,
}

const ROOM: Aabb = Aabb {
    lo: Vec3::new(-3.0, -2.0, -4.0),
    hi: Vec3::new(3.0, 2.5, 4.0),
};
const OCCLUDER: Aabb = Aabb {
    lo: Vec3::new(0.6, -0.7, 1.2),
    hi: Vec3::new(1.8, 0.5, 2.2),
};
const CENTRE: Vec3 = Vec3::new(0.3, -0.2, 0.4);
const CENTRE_B: Vec3 = Vec3::new(1.2, -0.1, 3.4);
const SPHERE_ROOM: (Vec3, f32) = (Vec3::new(0.1, 0.2, -0.1), 4.5);
const SPHERE_OCC: (Vec3, f32) = (Vec3::new(1.4, 0.3, 1.1), 0.7);
const SPHERE_FAR: (Vec3, f32) = (Vec3::new(-2.0, -1.0, -2.5), 1.2);
const T_HI: f32 = 20.0;

/// First hit along `o + t d` (unit `d`), `t > 0`; `+inf` when nothing.
fn scene_hit(scene: Scene, o: Vec3, d: Vec3) -> f32 {
    match scene {
        Scene::BoxRoom => exit_box(ROOM, o, d).min(enter_box(OCCLUDER, o, d)),
        Scene::SphereRoom => {
            let (_, far) = sphere_roots(SPHERE_ROOM.0, SPHERE_ROOM.1, o, d);
            far.min(enter_sphere(SPHERE_OCC.0, SPHERE_OCC.1, o, d))
        }
        Scene::Nothing => f32::INFINITY,
        Scene::Void => enter_sphere(SPHERE_OCC.0, SPHERE_OCC.1, o, d).min(enter_sphere(
            SPHERE_FAR.0,
            SPHERE_FAR.1,
            o,
            d,
        )),
    }
}

fn scene_name(scene: Scene) -> &'static str {
    match scene {
        Scene::BoxRoom => "box room",
        Scene::SphereRoom => "sphere room",
        Scene::Void => "void",
        Scene::Nothing => "nothing",
    }
}

fn twin_capture(scene: Scene, size: u32, centre: Vec3) -> CubeMap {
    let mut c = CubeMap::new(size, centre);
    c.fill(|_, dir| (scene_hit(scene, centre, dir), [0.0; 4]));
    c
}

// ---------------------------------------------------------------------------------------------
// Rays.

/// Rays through or near a CMO centre `c`, along its cube's edge and diagonal planes, parallel
/// to face planes, and crossing four faces.
fn special_rays(c: Vec3) -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::new();
    for d in [
        Vec3::X,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::ONE,
        Vec3::new(-1.0, 1.0, -1.0),
        Vec3::new(0.0, -1.0, 1.0),
    ] {
        let d = d.normalize();
        v.push((c, d));
        v.push((c - 1.5 * d, d));
        v.push((c - 1.5 * d + Vec3::new(1e-7, -1e-7, 0.0), d));
        v.push((c - 1.5 * d + Vec3::new(0.01, 0.0, -0.01), d));
    }
    for (o, d) in [
        (Vec3::new(0.5, 0.0, 0.5), Vec3::new(0.3, 0.4, 0.3)),
        (Vec3::new(-0.5, 0.0, 0.2), Vec3::new(0.2, 0.0, 1.0)),
        (Vec3::new(0.0, 0.2, -0.5), Vec3::new(0.0, 0.3, 1.0)),
        (Vec3::new(-2.5, 0.5, 0.5), Vec3::X),
        (Vec3::new(0.7, -1.0, 0.3), Vec3::Y),
        (Vec3::new(0.7, 0.7, -2.0), Vec3::Z),
        (Vec3::new(-2.0, -1.2, -0.2), Vec3::new(1.0, 0.6, 0.9)),
        (Vec3::new(2.5, 0.3, -3.0), Vec3::new(-1.0, 0.2, 1.2)),
        (Vec3::new(1.0, 1.0, 1.0), Vec3::new(-1.0, -1.0, -1.0)),
        (Vec3::new(-1.0, 1.0, 0.5), Vec3::new(1.0, -1.0, 0.0)),
    ] {
        v.push((c + o, d.normalize()));
    }
    v
}

/// A world ray `o + t d`, `t in [t_lo, t_hi]`.
#[derive(Clone, Copy, Debug)]
struct TwinRay {
    o: Vec3,
    d: Vec3,
    t_lo: f32,
    t_hi: f32,
}

/// `count` random rays from inside the room (outside the occluders) plus the special rays of
/// every centre in `centres` (those with `t in [0, T_HI]`, unit directions). Among the random
/// ones, by index: every 5th ends at `t_hi = 2` (escapes are possible in a closed room), every
/// 7th starts at `t_lo = 0.4`, every 3rd has a direction of length 2.5 and every 11th of 0.3.
fn twin_rays(seed: u64, count: usize, centres: &[Vec3]) -> Vec<TwinRay> {
    let mut rng = Rng(seed);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let o = Vec3::new(
            rng.range(-2.7, 2.7),
            rng.range(-1.7, 2.2),
            rng.range(-3.7, 3.7),
        );
        if o.cmpge(OCCLUDER.lo - 0.1).all() && o.cmple(OCCLUDER.hi + 0.1).all() {
            continue;
        }
        if (o - SPHERE_OCC.0).length() < SPHERE_OCC.1 + 0.1 {
            continue;
        }
        let i = out.len();
        let mut d = rng.unit();
        if i % 3 == 1 {
            d *= 2.5;
        } else if i % 11 == 6 {
            d *= 0.3;
        }
        let t_lo = if i % 7 == 4 { 0.4 } else { 0.0 };
        let t_hi = if i % 5 == 3 { 2.0 } else { T_HI };
        out.push(TwinRay { o, d, t_lo, t_hi });
    }
    for &c in centres {
        out.extend(special_rays(c).into_iter().map(|(o, d)| TwinRay {
            o,
            d,
            t_lo: 0.0,
            t_hi: T_HI,
        }));
    }
    out
}

fn probe_rays(rays: &[TwinRay]) -> Vec<ProbeRay> {
    rays.iter()
        .map(|r| ProbeRay {
            origin: r.o.to_array(),
            t_lo: r.t_lo,
            dir: r.d.to_array(),
            t_hi: r.t_hi,
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Comparison.

/// Disagreements between GPU and CPU, by kind.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
struct TwinDiff {
    /// Status, CMO, texel or riser flag differ.
    class: usize,
    /// Same class, different counters.
    counters: usize,
    /// Same class, `t`, `t_done` or point differ by more than the allowed ulps.
    value: usize,
    /// Largest ulp difference of `t`, `t_done` or a point coordinate on class-equal rays.
    max_ulps: u32,
}

impl TwinDiff {
    fn total(&self) -> usize {
        self.class + self.counters + self.value
    }
}

fn ulps(a: f32, b: f32) -> u32 {
    if a.to_bits() == b.to_bits() {
        return 0;
    }
    if !a.is_finite() || !b.is_finite() || a.signum() != b.signum() {
        return u32::MAX;
    }
    a.to_bits().abs_diff(b.to_bits())
}

fn expected_status(m: &MultiResult) -> u32 {
    match m.status {
        MultiStatus::Hit => 0,
        MultiStatus::Escaped => 1,
        MultiStatus::Unresolved => 2,
    }
}

/// Compares ray by ray; `max_ulps` is the bound allowed on `t`, `t_done` and the point.
fn compare(cpu: &[MultiResult], gpu: &[ProbeResult], max_ulps: u32, label: &str) -> TwinDiff {
    assert_eq!(cpu.len(), gpu.len());
    let mut d = TwinDiff::default();
    let mut shown = 0;
    for (i, (c, g)) in cpu.iter().zip(gpu).enumerate() {
        let tex = c.result.texel;
        let class_ok = expected_status(c) == g.status
            && c.cmo == g.cmo
            && (tex.face, tex.x, tex.y) == (g.face, g.x, g.y)
            && u32::from(c.result.riser) == g.riser;
        if !class_ok {
            d.class += 1;
        } else {
            let counters_ok = c.result.counters.texels == g.texels
                && c.result.counters.cells == g.cells
                && c.traces == g.traces;
            let u = [
                ulps(c.result.t, g.t),
                ulps(c.t_done, g.t_done),
                ulps(c.point.x, g.point[0]),
                ulps(c.point.y, g.point[1]),
                ulps(c.point.z, g.point[2]),
            ]
            .into_iter()
            .max()
            .unwrap_or(0);
            d.max_ulps = d.max_ulps.max(u);
            if !counters_ok {
                d.counters += 1;
            } else if u > max_ulps {
                d.value += 1;
            } else {
                continue;
            }
        }
        if shown < 3 {
            shown += 1;
            eprintln!("  {label}: ray {i}: cpu {c:?}\n    gpu {g:?}");
        }
    }
    d
}

fn cpu_trace(cmos: &[CmoTracer], rays: &[TwinRay], opts: &TraceOptions) -> Vec<MultiResult> {
    rays.iter()
        .map(|r| trace_ray(cmos, r.o, r.d, r.t_lo, r.t_hi, opts))
        .collect()
}

fn gpu_trace(ctx: &GpuContext, data: &CmoData, rays: &[TwinRay]) -> Vec<ProbeResult> {
    trace_probe(ctx, data, &probe_rays(rays)).unwrap_or_else(|e| panic!("{e}"))
}

fn exact(accel: bool) -> TraceOptions {
    TraceOptions {
        accel,
        ..TraceOptions::centre()
    }
}

/// CPU tracers for captures, with the options' parameters.
fn tracers(cubes: &[CubeMap], opts: &TraceOptions) -> Vec<CmoTracer> {
    cubes
        .iter()
        .map(|c| CmoTracer::new(c.clone(), opts.params()))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Tests.

#[test]
fn trace_structs_match_naga_layout() {
    let l = |n| TRACE_PROBE.struct_layout(n).expect("reflected");
    check_layout!(
        TraceConfig,
        l("TraceConfig"),
        [
            cmo_count,
            size,
            criterion,
            sampling,
            accel,
            steps,
            eps,
            continuity_k,
            mip_top,
            mip_len,
            strict,
            pad1,
            mip_levels
        ]
    )
    .unwrap_or_else(|e| panic!("{e}"));
    check_layout!(
        ProbeResult,
        l("TraceOut"),
        [
            status, cmo, face, x, y, riser, texels, cells, traces, t, t_done, pad0, point, pad1
        ]
    )
    .unwrap_or_else(|e| panic!("{e}"));
    check_layout!(ProbeRay, l("ProbeRay"), [origin, t_lo, dir, t_hi])
        .unwrap_or_else(|e| panic!("{e}"));
    check_layout!(ProbeParams, l("ProbeParams"), [count, pad0, pad1, pad2])
        .unwrap_or_else(|e| panic!("{e}"));
    // Group 1 is the shared tracer's: config, centres, distance, mip, and the `bounded`
    // criterion's gaps, which the pyramid march reads only for that criterion (naga counts a
    // binding any reachable function reads; the CMO data binds placeholders otherwise).
    let ep = TRACE_PROBE.entry_point("main").expect("main");
    let g1: Vec<_> = ep
        .bindings
        .iter()
        .filter(|b| b.group == 1)
        .map(|b| (b.binding, b.name))
        .collect();
    assert_eq!(
        g1,
        [
            (0, "trace_config"),
            (1, "cmo_centres"),
            (2, "cmo_distance"),
            (3, "cmo_mip"),
            (15, "cmo_gap"),
            (16, "cmo_gap_mip")
        ]
    );
}

#[test]
fn exact_criterion_matches_the_cpu_bit_for_bit() {
    let ctx = gpu_context();
    let mut total_rays = 0;
    let mut bad = 0;
    for (scene, size, count) in [
        (Scene::BoxRoom, 1u32, 300usize),
        (Scene::BoxRoom, 3, 500),
        (Scene::BoxRoom, 16, 1000),
        (Scene::BoxRoom, 32, 1000),
        (Scene::BoxRoom, 64, 600),
        (Scene::SphereRoom, 3, 400),
        (Scene::SphereRoom, 32, 1000),
        (Scene::Void, 16, 600),
        (Scene::Nothing, 3, 200),
    ] {
        let cubes = vec![twin_capture(scene, size, CENTRE)];
        let rays = twin_rays(u64::from(size) * 31 + count as u64, count, &[CENTRE]);
        let mut data =
            CmoData::upload(&ctx, &cubes, &exact(true)).unwrap_or_else(|e| panic!("{e}"));
        for accel in [false, true] {
            let opts = exact(accel);
            data.set_options(&ctx, &opts)
                .unwrap_or_else(|e| panic!("{e}"));
            let cpu = cpu_trace(&tracers(&cubes, &opts), &rays, &opts);
            let gpu = gpu_trace(&ctx, &data, &rays);
            let label = format!("{} size {size} accel {accel}", scene_name(scene));
            let d = compare(&cpu, &gpu, 0, &label);
            if accel {
                // `gpu_trace` took the specialised entry point (`main_exact_mip`); the generic
                // one must agree too.
                let generic = trace_probe_entry(&ctx, &data, &probe_rays(&rays), "main")
                    .unwrap_or_else(|e| panic!("{e}"));
                bad += compare(&cpu, &generic, 0, &format!("{label} generic entry")).total();
            }
            let hits = cpu.iter().filter(|m| m.status == MultiStatus::Hit).count();
            let behind = cpu
                .iter()
                .filter(|m| m.result.status == Status::Behind)
                .count();
            eprintln!(
                "{label}: {} rays ({hits} hits, {behind} behind): {d:?}",
                rays.len()
            );
            total_rays += rays.len();
            bad += d.total();
        }
    }
    // A strict continuity rule (k = 0.2): more steps are silhouettes, so more rays go behind.
    let strict = TraceOptions {
        continuity_k: 0.2,
        ..exact(true)
    };
    let cubes = vec![twin_capture(Scene::SphereRoom, 32, CENTRE)];
    let rays = twin_rays(555, 1000, &[CENTRE]);
    let data = CmoData::upload(&ctx, &cubes, &strict).unwrap_or_else(|e| panic!("{e}"));
    let cpu = cpu_trace(&tracers(&cubes, &strict), &rays, &strict);
    let gpu = gpu_trace(&ctx, &data, &rays);
    let d = compare(&cpu, &gpu, 0, "k = 0.2");
    // Negative: the CPU with the default k sees other risers and silhouettes.
    let loose = cpu_trace(&tracers(&cubes, &exact(true)), &rays, &exact(true));
    let d_loose = compare(&loose, &gpu, 0, "k = 0.2 vs default k");
    assert!(d_loose.class > 0, "{d_loose:?}");
    let risers = cpu.iter().filter(|m| m.result.riser).count();
    eprintln!(
        "sphere room size 32, k = 0.2: {} rays ({risers} riser hits): {d:?}",
        rays.len()
    );
    total_rays += rays.len();
    bad += d.total();

    eprintln!("exact, one CMO: {total_rays} rays, {bad} disagreements");
    assert_eq!(bad, 0);
    finish_gpu(ctx);
}

/// The bit-for-bit comparison would see a driver that contracts `a + t * d` into a fused
/// multiply-add (lavapipe does not: Mesa's gallivm lowers even an explicit WGSL `fma` to a
/// multiply and an add, so this cannot be shown on the GPU here): recomputing the CPU's hit
/// points with `mul_add` changes the bits of most of them.
#[test]
fn fused_multiply_add_would_be_caught() {
    let opts = exact(true);
    let cubes = vec![twin_capture(Scene::BoxRoom, 32, CENTRE)];
    let rays = twin_rays(31, 500, &[]);
    let cpu = cpu_trace(&tracers(&cubes, &opts), &rays, &opts);
    let mut hits = 0;
    let mut differ = 0;
    for (m, r) in cpu.iter().zip(&rays) {
        if m.status != MultiStatus::Hit {
            continue;
        }
        hits += 1;
        let (a, d) = (r.o - CENTRE, r.d);
        let t = m.result.t;
        let fused = Vec3::new(
            t.mul_add(d.x, a.x),
            t.mul_add(d.y, a.y),
            t.mul_add(d.z, a.z),
        );
        if fused.to_array().map(f32::to_bits) != m.result.point.to_array().map(f32::to_bits) {
            differ += 1;
        }
    }
    eprintln!("{differ} of {hits} hit points change bits when fused");
    assert!(differ * 4 > hits, "{differ} of {hits}");
}

/// Uploads `cubes` through the public buffer constructor, with the mip pyramid given by `mip`.
fn upload_with_mip(
    ctx: &GpuContext,
    cubes: &[CubeMap],
    mip: &[[f32; 2]],
    opts: &TraceOptions,
) -> CmoData {
    let make = || -> cubetrace::vk::VkResult<CmoData> {
        let data = CmoData::upload(ctx, cubes, opts)?;
        ctx.write_buffer(data.mip(), mip)?;
        Ok(data)
    };
    make().unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn exact_comparison_detects_perturbed_gpu_input() {
    let ctx = gpu_context();
    let size = 16;
    let cube = twin_capture(Scene::BoxRoom, size, CENTRE);
    let rays = twin_rays(99, 800, &[CENTRE]);
    for accel in [false, true] {
        let opts = exact(accel);
        let cpu = cpu_trace(&tracers(std::slice::from_ref(&cube), &opts), &rays, &opts);
        let label = format!("accel {accel}");

        // Unperturbed, for reference: no disagreement.
        let data = CmoData::upload(&ctx, std::slice::from_ref(&cube), &opts)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            compare(&cpu, &gpu_trace(&ctx, &data, &rays), 0, &label).total(),
            0
        );

        // One texel's distance: the texel the CPU hits most often, pushed 5% out.
        let mut counts = vec![0usize; cube.distance.len()];
        for m in cpu.iter().filter(|m| m.status == MultiStatus::Hit) {
            counts[m.result.texel.index(size)] += 1;
        }
        let (most, n_most) = counts
            .iter()
            .enumerate()
            .max_by_key(|&(_, n)| *n)
            .expect("texels");
        let mut bent = cube.clone();
        bent.distance[most] *= 1.05;
        let data = CmoData::upload(&ctx, &[bent], &opts).unwrap_or_else(|e| panic!("{e}"));
        let d = compare(&cpu, &gpu_trace(&ctx, &data, &rays), 0, &label);
        eprintln!("{label}: one texel ({n_most} CPU hits) 5% out: {d:?}");
        assert!(d.total() >= *n_most && *n_most > 0);

        // The centre moved by one ulp in x: only bits of t and the point change.
        let mut moved = cube.clone();
        moved.centre.x = f32::from_bits(moved.centre.x.to_bits() + 1);
        let data = CmoData::upload(&ctx, &[moved], &opts).unwrap_or_else(|e| panic!("{e}"));
        let d = compare(&cpu, &gpu_trace(&ctx, &data, &rays), 0, &label);
        eprintln!("{label}: centre x + 1 ulp: {d:?}");
        assert!(d.total() > 0);

        // A pyramid whose cells below the top claim every texel is far away: the march skips
        // real hits; the walk reads only the top level (for the cut radius), kept intact.
        let mut mip = cubetrace::cubemap::pyramid::MipPyramid::build(&cube).flatten();
        let below_top = mip.len() - 6;
        for c in mip[..below_top].iter_mut() {
            c[0] = 1e9;
        }
        let data = upload_with_mip(&ctx, std::slice::from_ref(&cube), &mip, &opts);
        let d = compare(&cpu, &gpu_trace(&ctx, &data, &rays), 0, &label);
        eprintln!("{label}: corrupted pyramid: {d:?}");
        if accel {
            assert!(d.class > 100, "{d:?}");
        } else {
            assert_eq!(d.total(), 0);
        }
    }
    finish_gpu(ctx);
}

#[test]
fn two_cmos_hand_off_like_the_cpu() {
    let ctx = gpu_context();
    let mut total_rays = 0;
    let mut bad = 0;
    for size in [16u32, 32] {
        let cubes = vec![
            twin_capture(Scene::BoxRoom, size, CENTRE),
            twin_capture(Scene::BoxRoom, size, CENTRE_B),
        ];
        let rays = twin_rays(7 + u64::from(size), 1500, &[CENTRE, CENTRE_B]);
        for accel in [false, true] {
            let opts = exact(accel);
            let data = CmoData::upload(&ctx, &cubes, &opts).unwrap_or_else(|e| panic!("{e}"));
            let cpu = cpu_trace(&tracers(&cubes, &opts), &rays, &opts);
            let gpu = gpu_trace(&ctx, &data, &rays);
            let label = format!("two CMOs size {size} accel {accel}");
            let d = compare(&cpu, &gpu, 0, &label);
            let by_b = cpu.iter().filter(|m| m.cmo == 1).count();
            let unresolved = cpu
                .iter()
                .filter(|m| m.status == MultiStatus::Unresolved)
                .count();
            eprintln!(
                "{label}: {} rays ({by_b} decided by B, {unresolved} unresolved): {d:?}",
                rays.len()
            );
            // The handoff is exercised: B decides rays that A could not see.
            assert!(by_b > 50, "{by_b}");
            total_rays += rays.len();
            bad += d.total();

            // Negative: B's centre moved by 1e-3 on the GPU only.
            let mut moved = cubes.clone();
            moved[1].centre += Vec3::new(1e-3, 0.0, 0.0);
            let data = CmoData::upload(&ctx, &moved, &opts).unwrap_or_else(|e| panic!("{e}"));
            let d = compare(&cpu, &gpu_trace(&ctx, &data, &rays), 0, &label);
            eprintln!("{label}: B's centre moved 1e-3: {d:?}");
            assert!(d.total() >= by_b / 2, "{d:?}");
        }
    }
    eprintln!("exact, two CMOs: {total_rays} rays, {bad} disagreements");
    assert_eq!(bad, 0);
    finish_gpu(ctx);
}

#[test]
fn approximate_criteria_match_the_cpu() {
    let ctx = gpu_context();
    let cubes = vec![twin_capture(Scene::BoxRoom, 32, CENTRE)];
    let rays = twin_rays(4242, 800, &[CENTRE]);
    let mut data =
        CmoData::upload(&ctx, &cubes, &TraceOptions::centre()).unwrap_or_else(|e| panic!("{e}"));
    let mut bad = 0;
    let mut total = 0;
    for criterion in [TraceCriterion::Threshold, TraceCriterion::SignChange] {
        for sampling in [
            TraceSampling::ConstantStep,
            TraceSampling::ConstantAngle,
            TraceSampling::PerTexel,
        ] {
            let opts = TraceOptions {
                criterion,
                sampling,
                steps: 300,
                eps: 0.05,
                ..TraceOptions::centre()
            };
            data.set_options(&ctx, &opts)
                .unwrap_or_else(|e| panic!("{e}"));
            let cpu = cpu_trace(&tracers(&cubes, &opts), &rays, &opts);
            let gpu = gpu_trace(&ctx, &data, &rays);
            let label = format!("{criterion:?}/{sampling:?}");
            let d = compare(&cpu, &gpu, 0, &label);
            let hits = cpu.iter().filter(|m| m.status == MultiStatus::Hit).count();
            eprintln!("{label}: {} rays ({hits} hits): {d:?}", rays.len());
            assert!(hits > rays.len() / 3, "{label}: {hits}");
            total += rays.len();
            bad += d.total();

            // Negative: a wider threshold (or another step count) on the GPU only.
            let other = TraceOptions {
                eps: 0.2,
                steps: 301,
                ..opts
            };
            data.set_options(&ctx, &other)
                .unwrap_or_else(|e| panic!("{e}"));
            let d = compare(&cpu, &gpu_trace(&ctx, &data, &rays), 0, &label);
            let sensitive =
                criterion == TraceCriterion::Threshold || sampling != TraceSampling::PerTexel;
            if sensitive {
                assert!(d.total() > 0, "{label}: perturbed options went unnoticed");
            }
        }
    }
    eprintln!("approximate criteria: {total} ray traces, {bad} disagreements");
    assert_eq!(bad, 0);
    finish_gpu(ctx);
}

/// The specialised entry point carries the centre criterion's mip march only: it is chosen for
/// those options alone, and refused for any other config (it would trace them wrongly).
#[test]
fn specialised_entry_only_for_the_exact_mip_march() {
    assert!(exact_mip_only(&TraceOptions::centre()));
    assert!(!exact_mip_only(&exact(false)));
    for criterion in [TraceCriterion::Threshold, TraceCriterion::SignChange] {
        let opts = TraceOptions {
            criterion,
            ..TraceOptions::centre()
        };
        assert!(!exact_mip_only(&opts));
    }
    let ctx = gpu_context();
    let cubes = vec![twin_capture(Scene::SphereRoom, 16, CENTRE)];
    let rays = twin_rays(77, 200, &[CENTRE]);
    let threshold = TraceOptions {
        criterion: TraceCriterion::Threshold,
        ..TraceOptions::centre()
    };
    let data = CmoData::upload(&ctx, &cubes, &threshold).unwrap_or_else(|e| panic!("{e}"));
    let err = trace_probe_entry(&ctx, &data, &probe_rays(&rays), "main_exact_mip")
        .expect_err("main_exact_mip with the threshold criterion must be refused");
    assert!(err.to_string().contains("main_exact_mip"), "{err}");
    // Both entries accept the exact mip march and agree with the CPU (and so with each other);
    // the threshold config through the generic entry differs from the exact CPU trace.
    let exact_data = CmoData::upload(&ctx, &cubes, &exact(true)).unwrap_or_else(|e| panic!("{e}"));
    let cpu = cpu_trace(&tracers(&cubes, &exact(true)), &rays, &exact(true));
    for entry in ["main", "main_exact_mip"] {
        let gpu = trace_probe_entry(&ctx, &exact_data, &probe_rays(&rays), entry)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(compare(&cpu, &gpu, 0, entry).total(), 0, "{entry}");
    }
    let gpu_threshold = trace_probe_entry(&ctx, &data, &probe_rays(&rays), "main")
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(compare(&cpu, &gpu_threshold, 0, "threshold vs exact").total() > 0);
    finish_gpu(ctx);
}

#[test]
fn trace_config_refuses_what_the_shader_caps_would_cut() {
    let ok = TraceConfig::new(2, 4096, &TraceOptions::centre()).expect("4096 is accepted");
    assert_eq!(ok.mip_top, 12);
    assert_eq!(ok.mip_levels[12][1..], [1, 1, 4096]);
    assert!(TraceConfig::new(1, 4097, &TraceOptions::centre()).is_err());
    assert!(TraceConfig::new(1, 0, &TraceOptions::centre()).is_err());
    let many = TraceOptions {
        steps: 65537,
        ..TraceOptions::centre()
    };
    assert!(TraceConfig::new(1, 16, &many).is_err());
    // N = 1: no pyramid; the cut radius comes from the texels.
    let one = TraceConfig::new(1, 1, &TraceOptions::centre()).expect("1 is accepted");
    assert_eq!((one.mip_top, one.mip_len), (0, 0));
}

//! Cone tracing on the cube maps: the pre-filtered colour chain
//! (`cone_prefilter` pass) against its CPU twin bit for bit, and the lookups of
//! `spirv/shared/cone.wgsl` (`cone_probe` pass) against `cubetrace::cpu::cone`. Each comparison
//! has a negative. Needs a Vulkan driver (lavapipe is enough); runs under the validation layer
//! when `CUBETRACE_VALIDATION=1` and fails on any validation error.
use crate::common;
use common::bits::compare_cells;
use common::{finish_gpu, gpu_context, psnr};

use cubetrace::check_layout;
use cubetrace::cpu::cone::{
    ConeCmo, cone_cube_colour4, cone_envmap_colour, cone_footprint_level, cone_prefilter,
};
use cubetrace::cubemap::CubeMap;
use cubetrace::cubemap::pyramid::mip_len;
use cubetrace::vk::backend::shaders::{CONE_PREFILTER, CONE_PROBE};
use cubetrace::vk::passes::cone::{
    ConePrefilterParams, ConeProbeParams, ConeQuery, WORKGROUP, prefilter_gpu, probe_gpu,
    upload_with_cone,
};
use glam::{Vec3, Vec4};

const BACKGROUND: Vec3 = Vec3::new(0.05, 0.05, 0.08);

/// Deterministic colours: about 1 texel in 9 empty (alpha 0, distance +inf), the rest random
/// colours in [0, 4) with distance 1.
fn colour_cube(size: u32, seed: u64) -> CubeMap {
    let mut c = CubeMap::new(size, Vec3::new(seed as f32, 0.0, 0.0));
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        s >> 33
    };
    c.fill(|_, _| {
        if next().is_multiple_of(9) {
            return (f32::INFINITY, [0.0; 4]);
        }
        let mut ch = || (next() >> 8) as f32 / (1u64 << 23) as f32 * 4.0;
        (1.0, [ch(), ch(), ch(), 1.0])
    });
    c
}

#[test]
fn param_structs_match_naga_layout() {
    let layout = CONE_PREFILTER
        .struct_layout("ConePrefilterParams")
        .expect("reflected");
    check_layout!(
        ConePrefilterParams,
        layout,
        [
            cmo_count,
            src_width,
            src_offset,
            dst_width,
            dst_offset,
            cone_len,
            from_texels,
            pad0,
            background,
            pad1
        ]
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let ep = CONE_PREFILTER
        .entry_point("main")
        .expect("entry point main");
    assert_eq!(ep.workgroup_size, [WORKGROUP, 1, 1]);
    let layout = CONE_PROBE.struct_layout("ConeQuery").expect("reflected");
    check_layout!(ConeQuery, layout, [dir, arg, k, mode, pad0, pad1])
        .unwrap_or_else(|e| panic!("{e}"));
    let layout = CONE_PROBE
        .struct_layout("ConeProbeParams")
        .expect("reflected");
    check_layout!(
        ConeProbeParams,
        layout,
        [count, pad0, pad1, pad2, background, pad3]
    )
    .unwrap_or_else(|e| panic!("{e}"));
}

/// The GPU chain equals the CPU's bit for bit: odd and even sizes, K = 1 and 2, empty texels.
/// Negative: one texel changed after the GPU build must be seen.
#[test]
fn gpu_prefilter_equals_cpu_bit_for_bit() {
    let ctx = gpu_context();
    for size in [2u32, 3, 5, 8, 17, 32] {
        let cubes = vec![colour_cube(size, u64::from(size)), colour_cube(size, 99)];
        let gpu = prefilter_gpu(&ctx, &cubes, BACKGROUND).unwrap_or_else(|e| panic!("{e}"));
        for (k, (g, cube)) in gpu.iter().zip(&cubes).enumerate() {
            let cpu = cone_prefilter(cube, BACKGROUND);
            assert_eq!(cpu.len(), mip_len(size));
            compare_cells(g, &cpu).unwrap_or_else(|e| panic!("N = {size}, CMO {k}: {e}"));
        }
        // Negatives: a texel brightened, an empty texel read as black instead of the
        // background, each in the last CMO.
        let mut brighter = cubes[1].clone();
        brighter.colour[0][0] += 1.0;
        compare_cells(&gpu[1], &cone_prefilter(&brighter, BACKGROUND))
            .expect_err("a changed texel must be detected");
        compare_cells(&gpu[1], &cone_prefilter(&cubes[1], Vec3::ZERO))
            .expect_err("the background of empty texels must be detected");
    }
    finish_gpu(ctx);
}

/// Directions covering every face, its edges and corners, and the face centres.
fn directions() -> Vec<Vec3> {
    let mut v = Vec::new();
    let steps = [-1.0f32, -0.93, -0.5, -0.11, 0.0, 0.2, 0.61, 0.97, 1.0];
    for &a in &steps {
        for &b in &steps {
            for major in 0..3 {
                for sign in [-1.0f32, 1.0] {
                    let mut d = [a, b, a];
                    d[major] = sign;
                    d[(major + 1) % 3] = a;
                    d[(major + 2) % 3] = b;
                    v.push(Vec3::from_array(d) * 1.7);
                }
            }
        }
    }
    v
}

/// `cone_cube_colour4` on the GPU equals the CPU's bit for bit over levels below 0, between
/// every pair of levels and above the top; the footprint level and the direction-only lookup
/// agree within the device's transcendental functions. Negatives: a level off by one eighth,
/// and the mirror image of the direction, must be seen.
#[test]
fn gpu_lookups_equal_cpu() {
    let ctx = gpu_context();
    for size in [5u32, 16] {
        let cubes = vec![colour_cube(size, 7), colour_cube(size, 8)];
        let data = upload_with_cone(&ctx, &cubes, BACKGROUND).unwrap_or_else(|e| panic!("{e}"));
        let chains: Vec<Vec<[f32; 4]>> = cubes
            .iter()
            .map(|c| cone_prefilter(c, BACKGROUND))
            .collect();
        let cmo = |k: usize| ConeCmo {
            cube: &cubes[k],
            chain: &chains[k],
            background: BACKGROUND,
        };
        let levels = [-1.0f32, 0.0, 0.3, 1.0, 1.5, 2.25, 3.0, 3.9, 4.0, 4.5, 9.0];
        let mut queries = Vec::new();
        for (i, dir) in directions().into_iter().enumerate() {
            let k = (i % 2) as u32;
            for &level in &levels {
                queries.push(ConeQuery {
                    dir: dir.to_array(),
                    arg: level,
                    k,
                    mode: 0,
                    ..Default::default()
                });
            }
            for (mode, arg) in [
                (1u32, 16.0f32),
                (1, 256.0),
                (1, 2000.0),
                (2, 0.1),
                (2, 0.01),
            ] {
                queries.push(ConeQuery {
                    dir: dir.to_array(),
                    arg,
                    k,
                    mode,
                    ..Default::default()
                });
            }
        }
        let gpu = probe_gpu(&ctx, &data, BACKGROUND, &queries).unwrap_or_else(|e| panic!("{e}"));
        let (mut exact, mut shifted, mut mirrored) = (0, 0, 0);
        for (q, g) in queries.iter().zip(&gpu) {
            let dir = Vec3::from_array(q.dir);
            let c = cmo(q.k as usize);
            let g = Vec4::from_array(*g);
            match q.mode {
                0 => {
                    let cpu = cone_cube_colour4(&c, dir, q.arg);
                    assert_eq!(
                        g.to_array().map(f32::to_bits),
                        cpu.to_array().map(f32::to_bits),
                        "N = {size}, {q:?}: GPU {g}, CPU {cpu}"
                    );
                    // Only where a level 1/8 higher is another mix of levels: not below
                    // level 0 (both read level 0) nor at the top.
                    if q.arg >= 0.0 && q.arg + 0.125 < c.top() as f32 {
                        exact += 1;
                        shifted += usize::from(cone_cube_colour4(&c, dir, q.arg + 0.125) != g);
                        mirrored += usize::from(cone_cube_colour4(&c, -dir, q.arg) != g);
                    }
                }
                1 => {
                    // Tolerance: the level comes from acos, tan and log2, which lavapipe
                    // computes to within a few ulp of the CPU's; a level that differs by 1e-5
                    // moves a trilinear colour in [0, 4) by at most 4e-5 per level step.
                    let cpu = cone_envmap_colour(&c, dir, q.arg);
                    assert!(
                        (g.truncate() - cpu).abs().max_element() < 1e-3,
                        "N = {size}, {q:?}: GPU {g}, CPU {cpu}"
                    );
                }
                _ => {
                    // Tolerance: two log2 of the device, 1e-5 relative each.
                    let cpu = cone_footprint_level(size, dir, q.arg);
                    assert!(
                        (g.x - cpu).abs() < 1e-4 * (1.0 + cpu.abs()),
                        "N = {size}, {q:?}: GPU {}, CPU {cpu}",
                        g.x
                    );
                }
            }
        }
        // The negatives: almost every lookup must change with a level 1/8 off and with the
        // mirror direction.
        assert!(shifted * 10 > exact * 9, "N = {size}: {shifted} of {exact}");
        assert!(
            mirrored * 10 > exact * 9,
            "N = {size}: {mirrored} of {exact}"
        );
    }
    finish_gpu(ctx);
}

// ---------------------------------------------------------------------------------------------
// The cone pass (fragment and compute) against its CPU twin, and the accuracy target.

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::cpu::cone::{ConeScene, cone_pixel};
use cubetrace::cubemap::pyramid::MipPyramid;
use cubetrace::scene::Scene;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{Fallback, GpuFrame, GpuRenderer, RenderOptions};

/// A built-in scene at `w x h` with CMOs of face size 64, every reflector at `power`.
fn glossy_scene(name: &str, power: Option<f32>, w: u32, h: u32) -> (Scene, Camera) {
    common::render::scene_at(name, 64, power, (w, h))
}

fn renderer(ctx: &GpuContext, scene: &Scene, cam: &Camera, method: Method) -> GpuRenderer {
    let options = RenderOptions {
        method,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    GpuRenderer::new(ctx, scene, cam, options).unwrap_or_else(|e| panic!("{e}"))
}

/// The CPU twin's colour of every mirror pixel of `before` (the frame without the cone pass),
/// the CMO data read back from `r`; `None` where the twin leaves the record.
#[allow(clippy::too_many_arguments)]
fn twin(
    ctx: &GpuContext,
    r: &GpuRenderer,
    scene: &Scene,
    cam: &Camera,
    before: &GpuFrame,
    power: f32,
    level_bias: f32,
    (occlusion, horizon): (bool, bool),
) -> Vec<Option<Vec3>> {
    // The CMOs the cone pass reads: its own under the bounded criterion (the default), the
    // method's under the centre one.
    let data = r.cone_cmo().unwrap_or_else(|| r.cmo());
    let cubes = data.read_back(ctx).unwrap_or_else(|e| panic!("{e}"));
    let cone: Vec<[f32; 4]> = ctx
        .read_buffer(data.cone().expect("a glossy frame has cmo_cone"))
        .unwrap_or_else(|e| panic!("{e}"));
    let len = mip_len(data.size());
    let chains: Vec<&[[f32; 4]]> = (0..cubes.len())
        .map(|k| &cone[k * len..(k + 1) * len])
        .collect();
    let cmos: Vec<ConeCmo> = cubes
        .iter()
        .zip(&chains)
        .map(|(c, ch)| ConeCmo {
            cube: c,
            chain: ch,
            background: scene.background,
        })
        .collect();
    let pyramids: Vec<Vec<[f32; 2]>> = cubes
        .iter()
        .map(|c| MipPyramid::build(c).flatten())
        .collect();
    let cs = ConeScene {
        cmos: &cmos,
        pyramids: &pyramids,
        eye: cam.eye,
        level_bias,
        occlusion,
        horizon,
    };
    (0..before.records.len())
        .map(|k| {
            if before.mask[k] == 0 {
                return None;
            }
            let rec = &before.records[k];
            cone_pixel(
                &cs,
                rec.status,
                Vec3::from_array(rec.origin),
                Vec3::from_array(rec.dir),
                Vec3::from_array(rec.point),
                Vec3::from_array(rec.colour),
                power,
            )
        })
        .collect()
}

/// Per-pixel differences of the GPU's colours from the twin's: (pixels compared, pixels more
/// than `tol` apart, the largest difference).
fn differences(gpu: &GpuFrame, cpu: &[Option<Vec3>], tol: f32) -> (usize, usize, f32) {
    let (mut n, mut over, mut max) = (0, 0, 0.0f32);
    for (k, c) in cpu.iter().enumerate() {
        if let Some(c) = c {
            let d = (Vec3::from_array(gpu.records[k].colour) - *c)
                .abs()
                .max_element();
            n += 1;
            over += usize::from(d > tol);
            max = max.max(d);
        }
    }
    (n, over, max)
}

/// Largest per-channel difference allowed between the GPU cone pass and its CPU twin, on every
/// glossy pixel. Measured on lavapipe (sphere-room, power 64, 373 glossy pixels): 4.8e-5 at
/// most, fragment and compute alike. The difference comes from the device's acos, tan and log2
/// (a few ulp off the CPU's) moving the level, hence the trilinear colour, continuously; 5x the
/// measured maximum leaves room for other ulps of those functions (another LLVM) while catching
/// a level off by 1/256 (measured: 29 pixels beyond 2.5e-4, max 8.3e-4). The level crossing an
/// integer the pyramid cap tests, or a hit on the seeing-CMO test's threshold, would jump the
/// colour (a power 0.1 % off jumps 2 pixels by 0.019), but a level a few ulp off lands within
/// those ulp of a threshold on about 1e-6 of the pixels: none here, so no pixel is exempt.
const CONE_TWIN_TOL: f32 = 2.5e-4;

/// The `cone` pass on the GPU against `cpu::cone::cone_pixel` over the records the frame had
/// before it, for fragment and compute: every glossy pixel within [`CONE_TWIN_TOL`] per channel.
/// Only the colour of glossy pixels may change. Negatives: the level 1/256 higher (within a
/// looser allowance, 1 % of the pixels beyond 1e-3 and none beyond 0.25) must fail the
/// tolerance; and the level one higher, the angle of power 4x, and the mirror image (the
/// record's exact colour) must differ beyond 1e-3 on more than 10 % of the pixels.
#[test]
fn cone_pass_equals_cpu_twin() {
    const POWER: f32 = 64.0;
    let ctx = gpu_context();
    let (scene, cam) = glossy_scene("sphere-room", Some(POWER), 48, 36);
    for method in [Method::Fragment, Method::Compute] {
        let mut r = renderer(&ctx, &scene, &cam, method);
        assert!(r.cone().is_some(), "{method}: a glossy frame cone traces");
        r.skip_cone(true);
        let before = r.render(&ctx).unwrap_or_else(|e| panic!("{e}"));
        r.skip_cone(false);
        let after = r.render(&ctx).unwrap_or_else(|e| panic!("{e}"));
        for k in 0..after.records.len() {
            if after.mask[k] == 0 {
                continue;
            }
            let (mut a, mut b) = (after.records[k], before.records[k]);
            a.colour = [0.0; 3];
            b.colour = [0.0; 3];
            assert_eq!(
                bytemuck::bytes_of(&a),
                bytemuck::bytes_of(&b),
                "{method}: pixel {k}: only the colour changes"
            );
        }
        let cpu = twin(&ctx, &r, &scene, &cam, &before, POWER, 0.0, (true, true));
        let (n, over, max) = differences(&after, &cpu, CONE_TWIN_TOL);
        eprintln!("{method}: {n} glossy pixels, {over} beyond {CONE_TWIN_TOL:e}, max {max:e}");
        assert!(n > 300, "{method}: {n} glossy pixels");
        assert_eq!(
            over, 0,
            "{method}: {over} of {n} beyond the tolerance, max {max}"
        );
        // Negative within a looser allowance (1 % of the pixels beyond 1e-3, none beyond
        // 0.25): the level 1/256 off.
        let nudged = twin(
            &ctx,
            &r,
            &scene,
            &cam,
            &before,
            POWER,
            1.0 / 256.0,
            (true, true),
        );
        let (n, over, max) = differences(&after, &nudged, CONE_TWIN_TOL);
        let (_, over_old, _) = differences(&after, &nudged, 1e-3);
        eprintln!("{method}: level + 1/256: {over} of {n} beyond {CONE_TWIN_TOL:e}, max {max:e}");
        assert!(
            over_old * 100 <= n && max <= 0.25,
            "negative level + 1/256: {over_old} of {n} beyond 1e-3, max {max}: not \
             within the looser allowance"
        );
        assert!(over > 0, "negative level + 1/256: within the tolerance");
        // Negatives far off.
        let biased = twin(&ctx, &r, &scene, &cam, &before, POWER, 1.0, (true, true));
        let wide = twin(
            &ctx,
            &r,
            &scene,
            &cam,
            &before,
            POWER / 4.0,
            0.0,
            (true, true),
        );
        let exact: Vec<Option<Vec3>> = cpu
            .iter()
            .zip(&before.records)
            .map(|(c, rec)| c.map(|_| Vec3::from_array(rec.colour)))
            .collect();
        for (name, wrong) in [
            ("level + 1", biased),
            ("power / 4", wide),
            ("mirror", exact),
        ] {
            let (n, over, _) = differences(&after, &wrong, 1e-3);
            assert!(over * 10 > n, "negative {name}: {over} of {n} beyond 1e-3");
        }
    }
    finish_gpu(ctx);
}

use cubetrace::cpu::options::{TraceCriterion, TraceOptions};
use cubetrace::film::{FilmSettings, PixelFilter};
use cubetrace::reference::{self, Tracer};
use cubetrace::render::{FrameRenderer, samples};

/// The reference's box-filtered frame at `spp` samples, as `render --spp` makes it.
fn reference_at(scene: &Scene, cam: &Camera, spp: u32) -> reference::Frame {
    let film = FilmSettings {
        spp,
        filter: PixelFilter::Box,
    };
    let t = Tracer::new(scene);
    samples::reference_frame(scene, &t, cam, 1, film, false).0
}

/// `--method bvh --spp spp`'s frame.
fn bvh_at(scene: &Scene, cam: &Camera, spp: u32) -> Vec<Vec3> {
    let n = spp.to_string();
    let args = common::render_args(&["x", "--method", "bvh", "--spp", &n]);
    let mut fr = FrameRenderer::new(&args, scene, cam).unwrap_or_else(|e| panic!("{e}"));
    let f = fr.render(scene, cam).unwrap_or_else(|e| panic!("{e}"));
    common::finish_renderer(fr);
    f.colour().to_vec()
}

/// PSNRs over the mirror pixels against the converged reference (1024 spp) of one built-in
/// scene made glossy at `power`, 48x36: (mirror, cone fragment, cone compute, bvh at 1, 2, 4,
/// 8 spp) (bvh where `with_bvh`).
fn accuracy(ctx: &GpuContext, name: &str, power: f32, with_bvh: bool) -> Vec<f64> {
    let (mirror, cam) = glossy_scene(name, None, 48, 36);
    let (glossy, _) = glossy_scene(name, Some(power), 48, 36);
    let truth = reference_at(&glossy, &cam, 1024);
    let db = |c: &[Vec3]| psnr(c, &truth.colour, &truth.mask);
    let mut out = vec![db(&renderer(ctx, &mirror, &cam, Method::Fragment)
        .render(ctx)
        .unwrap_or_else(|e| panic!("{e}"))
        .colour)];
    for method in [Method::Fragment, Method::Compute] {
        let f = renderer(ctx, &glossy, &cam, method)
            .render(ctx)
            .unwrap_or_else(|e| panic!("{e}"));
        out.push(db(&f.colour));
    }
    if with_bvh {
        for spp in [1, 2, 4, 8] {
            out.push(db(&bvh_at(&glossy, &cam, spp)));
        }
    }
    out
}

/// PSNRs over the mirror pixels against the converged reference (1024 spp) of one built-in
/// scene made glossy at `power`, 48x36: the mirror frame's, then (fragment, compute) of the cone
/// frame of each power of `lobes` (the scene's reflectors at that power, the truth unchanged).
fn cone_scores(ctx: &GpuContext, name: &str, power: f32, lobes: &[f32]) -> (f64, Vec<[f64; 2]>) {
    let (mirror, cam) = glossy_scene(name, None, 48, 36);
    let (glossy, _) = glossy_scene(name, Some(power), 48, 36);
    let truth = reference_at(&glossy, &cam, 1024);
    let db = |c: &[Vec3]| psnr(c, &truth.colour, &truth.mask);
    let frame = |s: &Scene, method| {
        renderer(ctx, s, &cam, method)
            .render(ctx)
            .unwrap_or_else(|e| panic!("{e}"))
            .colour
    };
    let m = db(&frame(&mirror, Method::Fragment));
    let cones = (lobes.iter())
        .map(|&p| {
            let (s, _) = glossy_scene(name, Some(p), 48, 36);
            [Method::Fragment, Method::Compute].map(|method| db(&frame(&s, method)))
        })
        .collect();
    (m, cones)
}

/// The target: cone tracing beats the mirror image against the converged reference (PSNR over
/// the mirror pixels, 1024 spp, 48x36), both paths, on three scene/power pairs. Measured
/// (fragment and compute agree to 0.01 dB): sphere-room power 64 mirror 17.84, cone 26.35
/// (gain 8.51); torus 16: 18.70, 26.15 (7.45); default 256: 18.19, 26.70 (8.51). The bound is
/// each measured gain less 0.5 dB: the frames and the reference are deterministic, so the
/// margin only absorbs another device's transcendental functions; a loss of half a dB fails.
/// Negatives, through the same check: the mirror image does not beat itself; the cone frame of
/// 4x the power (a lobe too narrow) fails on sphere-room (24.98 dB, gain 7.14) and on default
/// (power 1024 is the mirror cap: the mirror frame). Not on torus: there power 64 scores 26.61,
/// above the right lobe, as the lobe 4x too wide (power 64, 29.52 dB) does on default: the
/// cone is not the reference's lobe, and a wrong lobe does not always score lower.
#[test]
fn cone_beats_mirror() {
    let ctx = gpu_context();
    for (name, power, min_gain, narrow_fails) in [
        ("sphere-room", 64.0, 8.0, true),
        ("torus", 16.0, 6.95, false),
        ("default", 256.0, 8.0, true),
    ] {
        let (mirror, cones) = cone_scores(&ctx, name, power, &[power, 4.0 * power]);
        let ([fragment, compute], [narrow_f, narrow_c]) = (cones[0], cones[1]);
        eprintln!(
            "{name} power {power}: mirror {mirror:.2}, fragment {fragment:.2}, compute \
             {compute:.2}; power x4: fragment {narrow_f:.2}, compute {narrow_c:.2}"
        );
        for (path, db) in [("fragment", fragment), ("compute", compute)] {
            common::cone_gain(mirror, db, min_gain)
                .unwrap_or_else(|e| panic!("{name} {power} {path}: {e}"));
        }
        // Negatives.
        common::cone_gain(mirror, mirror, min_gain)
            .expect_err("negative: the mirror image beats itself");
        if narrow_fails {
            for (path, db) in [("fragment", narrow_f), ("compute", narrow_c)] {
                if common::cone_gain(mirror, db, min_gain).is_ok() {
                    panic!("negative {name} {path}: power x4 passes ({db:.2} dB)");
                }
            }
        }
    }
    finish_gpu(ctx);
}

/// The check of `bounded_cone_matches_the_centre_sampled_cone`: `bounded` at most `tol` dB
/// below `exact`.
fn within_db(exact: f64, bounded: f64, tol: f64) -> Result<(), String> {
    if bounded.is_finite() && bounded >= exact - tol {
        Ok(())
    } else {
        Err(format!(
            "{bounded:.2} dB against {exact:.2} dB: more than {tol} dB below"
        ))
    }
}

/// The bounded criterion cone-traces glossy reflectors (over CMOs of the cone pass's own,
/// captured as the centre-sampled criterion's at the cube size, whatever size the lists take):
/// on `sphere-room-glossy` (power 64) its frame's PSNR against the converged reference (1024
/// spp) is at most 0.5 dB below the centre-sampled criterion's, for `compute` and `fragment`
/// (measured: 2.1 dB above with both, on the mirror rays that the centre-sampled criterion
/// leaves to the environment-map fallback here). Negative: the mirror frame of the same scene,
/// also bounded, fails the same check (it shows no lobe).
#[test]
fn bounded_cone_matches_the_centre_sampled_cone() {
    let ctx = gpu_context();
    let (glossy, cam) = glossy_scene("sphere-room-glossy", None, 48, 36);
    let (mirror, _) = glossy_scene("sphere-room", None, 48, 36);
    assert!(!glossy.glossy_reflectors().is_empty());
    let truth = reference_at(&glossy, &cam, 1024);
    let db = |c: &[Vec3]| psnr(c, &truth.colour, &truth.mask);
    let frame = |s: &Scene, method, criterion| {
        let options = RenderOptions {
            method,
            trace: TraceOptions {
                criterion,
                ..TraceOptions::default()
            },
            fallback: Fallback::Envmap,
            ..RenderOptions::default()
        };
        GpuRenderer::new(&ctx, s, &cam, options)
            .unwrap_or_else(|e| panic!("{e}"))
            .render(&ctx)
            .unwrap_or_else(|e| panic!("{e}"))
            .colour
    };
    for method in [Method::Compute, Method::Fragment] {
        let exact = db(&frame(&glossy, method, TraceCriterion::Centre));
        let bounded = db(&frame(&glossy, method, TraceCriterion::Bounded));
        let flat = db(&frame(&mirror, method, TraceCriterion::Bounded));
        eprintln!(
            "{method}: centre-sampled {exact:.2} dB, bounded {bounded:.2} dB, bounded mirror \
             {flat:.2} dB"
        );
        within_db(exact, bounded, 0.5).unwrap_or_else(|e| panic!("{method}: {e}"));
        within_db(exact, flat, 0.5).expect_err("negative: the mirror frame passes");
    }
    finish_gpu(ctx);
}

/// The accuracy table, printed (run by hand: `cargo test --release --test glossy
/// accuracy_table -- --ignored --nocapture`; `CONE_SCENES` picks scenes, comma-separated).
#[test]
#[ignore = "minutes: the converged reference of 15 scene/power pairs"]
fn accuracy_table() {
    let ctx = gpu_context();
    let scenes = std::env::var("CONE_SCENES")
        .unwrap_or_else(|_| "default,sphere-room,teapot,torus,bowl".into());
    println!(
        "| scene | power | mirror | cone fragment | cone compute | bvh 1 | bvh 2 | bvh 4 | bvh 8 |"
    );
    for name in scenes.split(',') {
        for power in [16.0f32, 64.0, 256.0] {
            let p = accuracy(&ctx, name, power, true);
            let cells: Vec<String> = p.iter().map(|d| format!("{d:.2}")).collect();
            println!("| {name} | {power} | {} |", cells.join(" | "));
        }
    }
    finish_gpu(ctx);
}

/// What the occlusion cap and the below-the-surface darkening gain (run by hand, `--ignored
/// --nocapture`): the CPU twin over the fragment frame's records with each switched off, PSNR
/// over the mirror pixels against the converged reference, every built-in scene at power 64.
#[test]
#[ignore = "a minute: the converged reference of five scenes"]
fn occlusion_and_horizon_measured() {
    let ctx = gpu_context();
    println!("| scene | power | cone | no occlusion cap | no darkening |");
    for name in ["default", "sphere-room", "teapot", "torus", "bowl"] {
        for power in [16.0f32, 64.0] {
            let (scene, cam) = glossy_scene(name, Some(power), 48, 36);
            let truth = reference_at(&scene, &cam, 1024);
            let mut r = renderer(&ctx, &scene, &cam, Method::Fragment);
            r.skip_cone(true);
            let before = r.render(&ctx).unwrap_or_else(|e| panic!("{e}"));
            let db = |knobs| {
                let c = twin(&ctx, &r, &scene, &cam, &before, power, 0.0, knobs);
                let colour: Vec<Vec3> = (0..c.len())
                    .map(|k| c[k].unwrap_or(before.colour[k]))
                    .collect();
                psnr(&colour, &truth.colour, &truth.mask)
            };
            println!(
                "| {name} | {power} | {:.2} | {:.2} | {:.2} |",
                db((true, true)),
                db((false, true)),
                db((true, false))
            );
        }
    }
    finish_gpu(ctx);
}

/// At mirror roughness nothing of cone tracing exists: no cone stage, no `cmo_cone`, and
/// compute and ssr capture no colour, for no power and for power 1024 (`tests/glossy.rs` checks
/// that those frames are the mirror's, byte for byte). Negative: power 64 creates them.
#[test]
fn mirror_roughness_creates_nothing() {
    let ctx = gpu_context();
    for method in [Method::Fragment, Method::Compute, Method::Ssr] {
        for (power, glossy) in [(None, false), (Some(1024.0), false), (Some(64.0), true)] {
            let (scene, cam) = glossy_scene("sphere-room", power, 16, 12);
            let r = renderer(&ctx, &scene, &cam, method);
            // ssr reads the chain for its cone's remainder but runs its own cone pass.
            let cube_cone = glossy && method != Method::Ssr;
            assert_eq!(r.cone().is_some(), cube_cone, "{method} {power:?}");
            // The memory estimate counts what cone tracing allocates, and only then.
            let options = RenderOptions {
                method,
                fallback: Fallback::Envmap,
                ..RenderOptions::default()
            };
            let extra = cubetrace::vk::budget::cone_bytes(&scene, &options);
            assert_eq!(extra > 0, glossy, "{method} {power:?}");
            // The CMOs the cone pass reads (its own under the bounded criterion).
            let data = r.cone_cmo().unwrap_or_else(|| r.cmo());
            if let Some(c) = data.cone() {
                assert!(extra >= c.size(), "{method}: {extra} < {}", c.size());
            }
            assert_eq!(data.cone().is_some(), glossy, "{method} {power:?}");
            if method != Method::Fragment {
                assert_eq!(data.contents().colour, glossy, "{method} {power:?}");
            }
        }
    }
    finish_gpu(ctx);
}

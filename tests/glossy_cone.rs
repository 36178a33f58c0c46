//! Cone tracing on the cube maps (issue 24, item 4): the pre-filtered colour chain
//! (`cone_prefilter` pass) against its CPU twin bit for bit, and the lookups of
//! `spirv/shared/cone.wgsl` (`cone_probe` pass) against `cubetrace::cpu::cone`. Each comparison
//! has a negative. Needs a Vulkan driver (lavapipe is enough); runs under the validation layer
//! when `CUBETRACE_VALIDATION=1` and fails on any validation error.
mod common;
use common::{finish_gpu, gpu_context};

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

fn bits(cells: &[[f32; 4]]) -> Vec<[u32; 4]> {
    cells.iter().map(|c| c.map(f32::to_bits)).collect()
}

/// `Err` with the first differing cell when `gpu` and `cpu` differ in any bit.
fn compare_bits(gpu: &[[f32; 4]], cpu: &[[f32; 4]]) -> Result<(), String> {
    if gpu.len() != cpu.len() {
        return Err(format!("length: GPU {}, CPU {}", gpu.len(), cpu.len()));
    }
    match bits(gpu).iter().zip(bits(cpu)).position(|(g, c)| *g != c) {
        None => Ok(()),
        Some(i) => Err(format!("cell {i}: GPU {:?}, CPU {:?}", gpu[i], cpu[i])),
    }
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
            compare_bits(g, &cpu).unwrap_or_else(|e| panic!("N = {size}, CMO {k}: {e}"));
        }
        // Negatives: a texel brightened, an empty texel read as black instead of the
        // background, each in the last CMO.
        let mut brighter = cubes[1].clone();
        brighter.colour[0][0] += 1.0;
        compare_bits(&gpu[1], &cone_prefilter(&brighter, BACKGROUND))
            .expect_err("a changed texel must be detected");
        compare_bits(&gpu[1], &cone_prefilter(&cubes[1], Vec3::ZERO))
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

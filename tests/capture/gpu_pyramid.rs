//! The GPU `pyramid` pass against its CPU twin (`MipPyramid::build` + `flatten`), bit for bit,
//! for odd and even sizes, one and two CMOs, +inf texels and whole +inf faces; plus a brute-force
//! conservativeness check of the GPU cells. Needs a Vulkan driver (lavapipe is enough); runs
//! under the validation layer when installed and fails on any validation error.
use crate::common;
use common::bits::compare_cells;
use common::{distance_cube, finish_gpu, gpu_context};

use cubetrace::check_layout;
use cubetrace::cubemap::CubeMap;
use cubetrace::cubemap::face::FACE_COUNT;
use cubetrace::cubemap::pyramid::{MipPyramid, mip_flat_layout};
use cubetrace::vk::backend::shaders::PYRAMID;
use cubetrace::vk::passes::pyramid::{
    MAX_GROUPS_X, PyramidParams, WORKGROUP, build_mip_gpu, level_params, mip_len,
};

const SIZES: [u32; 8] = [1, 2, 3, 5, 16, 32, 33, 64];

/// The K = 1 and K = 2 scenes used for every size: one with scattered +inf texels, one with a
/// whole +inf face besides.
fn scenes(size: u32) -> Vec<Vec<CubeMap>> {
    let a = distance_cube(size, u64::from(size), None);
    let b = distance_cube(size, u64::from(size) + 1000, Some(size % 6));
    vec![vec![a.clone()], vec![a, b]]
}

#[test]
fn params_struct_matches_naga_layout() {
    let layout = PYRAMID.struct_layout("PyramidParams").expect("reflected");
    check_layout!(
        PyramidParams,
        layout,
        [
            cmo_count,
            src_width,
            src_offset,
            dst_width,
            dst_offset,
            mip_len,
            from_texels,
            texels_per_cmo
        ]
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let ep = PYRAMID.entry_point("main").expect("entry point main");
    assert_eq!(ep.workgroup_size, [WORKGROUP, 1, 1]);
}

#[test]
fn level_params_chain_levels_and_cover_every_cell() {
    for size in SIZES {
        let layout = mip_flat_layout(size);
        let levels = level_params(2, size, MAX_GROUPS_X);
        assert_eq!(levels.len(), layout.len());
        for (l, (p, groups)) in levels.iter().enumerate() {
            assert_eq!(p.from_texels, u32::from(l == 0));
            assert_eq!(p.src_width, if l == 0 { size } else { layout[l - 1].width });
            assert_eq!(p.dst_offset, layout[l].offset);
            assert_eq!(p.mip_len as usize, mip_len(size));
            let invocations = u64::from(groups[0]) * u64::from(groups[1]) * u64::from(WORKGROUP);
            let cells = 2 * u64::from(FACE_COUNT) * u64::from(p.dst_width).pow(2);
            assert!(invocations >= cells && invocations < cells + u64::from(WORKGROUP));
        }
    }
}

#[test]
fn gpu_pyramid_equals_cpu_bit_for_bit() {
    let ctx = gpu_context();
    for size in SIZES {
        for cubes in scenes(size) {
            let gpu = build_mip_gpu(&ctx, &cubes).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(gpu.len(), cubes.len());
            for (k, (g, cube)) in gpu.iter().zip(&cubes).enumerate() {
                let cpu = MipPyramid::build(cube).flatten();
                assert_eq!(cpu.len(), mip_len(size));
                compare_cells(g, &cpu).unwrap_or_else(|e| panic!("N = {size}, CMO {k}: {e}"));
            }
        }
    }
    finish_gpu(ctx);
}

/// Negative test: the bitwise comparison must notice one texel perturbed after the GPU build, in
/// the last CMO, at a texel that is the unique minimum of its top cell.
#[test]
fn comparison_detects_one_perturbed_texel() {
    let ctx = gpu_context();
    for size in [2u32, 5, 33] {
        let cubes = scenes(size).pop().expect("K = 2 scene");
        let gpu = build_mip_gpu(&ctx, &cubes).unwrap_or_else(|e| panic!("{e}"));
        let mut perturbed = cubes[1].clone();
        // Lower a finite texel below every other: every level above it changes its min.
        let i = perturbed
            .distance
            .iter()
            .position(|d| d.is_finite())
            .expect("a finite texel");
        perturbed.distance[i] = 0.25;
        let cpu = MipPyramid::build(&perturbed).flatten();
        let err = compare_cells(&gpu[1], &cpu).expect_err("a perturbed texel must be detected");
        assert!(err.contains("cell"), "{err}");
        // And the unperturbed CMO 0 still matches, so the failure is the perturbation's.
        compare_cells(&gpu[0], &MipPyramid::build(&cubes[0]).flatten())
            .unwrap_or_else(|e| panic!("{e}"));
    }
    finish_gpu(ctx);
}

/// Brute force on the GPU cells: each `[min, max]` is exactly the min and max of the texels under
/// it, so it contains every one of them (conservative) and is attained (tight).
#[test]
fn gpu_cells_bound_the_texels_below_them() {
    let ctx = gpu_context();
    for size in [2u32, 3, 5, 16] {
        let cubes = scenes(size).pop().expect("K = 2 scene");
        let gpu = build_mip_gpu(&ctx, &cubes).unwrap_or_else(|e| panic!("{e}"));
        for (cube, flat) in cubes.iter().zip(&gpu) {
            check_cells_against_texels(cube, flat).unwrap_or_else(|e| panic!("N = {size}: {e}"));
        }
        // Negative: a cell raised above its minimum texel is caught.
        let mut wrong = gpu[0].clone();
        wrong[0][0] += 1.0;
        assert!(check_cells_against_texels(&cubes[0], &wrong).is_err());
    }
    finish_gpu(ctx);
}

fn check_cells_against_texels(cube: &CubeMap, flat: &[[f32; 2]]) -> Result<(), String> {
    let n = cube.size;
    for (l, level) in mip_flat_layout(n).iter().enumerate() {
        let span = 2u32 << l;
        for face in 0..FACE_COUNT {
            for y in 0..level.height {
                for x in 0..level.width {
                    let cell =
                        flat[(level.offset + (face * level.height + y) * level.width + x) as usize];
                    let mut lo = f32::INFINITY;
                    let mut hi = f32::NEG_INFINITY;
                    for ty in y * span..((y + 1) * span).min(n) {
                        for tx in x * span..((x + 1) * span).min(n) {
                            let d = cube.distance[((face * n + ty) * n + tx) as usize];
                            if !(cell[0] <= d && d <= cell[1]) {
                                return Err(format!(
                                    "level {} face {face} ({x}, {y}): {cell:?} misses texel {d}",
                                    l + 1
                                ));
                            }
                            lo = lo.min(d);
                            hi = hi.max(d);
                        }
                    }
                    if cell != [lo, hi] {
                        return Err(format!(
                            "level {} face {face} ({x}, {y}): {cell:?} is not [{lo}, {hi}]",
                            l + 1
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

#[test]
fn mismatched_sizes_and_empty_input_are_refused() {
    let ctx = gpu_context();
    let cubes = [distance_cube(4, 1, None), distance_cube(5, 2, None)];
    let err = build_mip_gpu(&ctx, &cubes).expect_err("sizes differ");
    assert!(err.to_string().contains("face size"), "{err}");
    assert!(build_mip_gpu(&ctx, &[]).is_err());
    finish_gpu(ctx);
}

/// The recording API as a frame uses it: bindings made up front, the pass recorded into a
/// command buffer inside a timestamp scope named after the pass; too small buffers are refused.
#[test]
fn record_with_timestamps_and_refuse_small_buffers() {
    use ash::vk;
    use cubetrace::vk::passes::pyramid::Pyramid;
    use cubetrace::vk::{Buffer, Timestamps};
    use gpu_allocator::MemoryLocation;

    let ctx = gpu_context();
    let cube = distance_cube(9, 7, Some(2));
    let distance = ctx
        .create_buffer_init(
            "cmo_distance",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &cube.distance,
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let mip_bytes = (mip_len(9) * 8) as u64;
    let new_mip = |bytes: u64| {
        Buffer::new(
            ctx.device(),
            "cmo_mip",
            bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )
        .unwrap_or_else(|e| panic!("{e}"))
    };
    let pyramid = Pyramid::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let small = new_mip(mip_bytes - 8);
    let err = pyramid
        .bind(&ctx, &distance, &small, 1, 9)
        .err()
        .expect("mip buffer one cell short");
    assert!(err.to_string().contains("cmo_mip"), "{err}");
    assert!(pyramid.bind(&ctx, &distance, &small, 0, 9).is_err());

    let mip = new_mip(mip_bytes);
    let bindings = pyramid
        .bind(&ctx, &distance, &mip, 1, 9)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(bindings.levels(), mip_flat_layout(9).len());
    let mut timestamps = ctx
        .report()
        .timestamps_supported()
        .then(|| Timestamps::new(&ctx, 1).unwrap_or_else(|e| panic!("{e}")));
    ctx.submit_and_wait("frame", |rec| {
        if let Some(t) = &mut timestamps {
            t.reset(rec);
        }
        pyramid.record(rec, &bindings, timestamps.as_mut())
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let gpu: Vec<[f32; 2]> = ctx.read_buffer(&mip).unwrap_or_else(|e| panic!("{e}"));
    compare_cells(&gpu, &MipPyramid::build(&cube).flatten()).unwrap_or_else(|e| panic!("{e}"));
    if let Some(t) = &timestamps {
        let times = t.results().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(times.len(), 1);
        assert_eq!(times[0].0, "pyramid");
        assert!(times[0].1.is_finite() && times[0].1 >= 0.0);
    }
    drop((bindings, mip, small, distance, pyramid, timestamps));
    finish_gpu(ctx);
}

/// Dispatches spread over several rows of workgroups (forced by a row limit of 3 workgroups)
/// produce the same pyramid: the shader's `(x, y)` linearisation and bounds guard are right.
#[test]
fn multi_row_dispatch_equals_cpu() {
    use ash::vk;
    use cubetrace::vk::passes::pyramid::Pyramid;

    let ctx = gpu_context();
    let size = 17u32;
    let cubes = [
        distance_cube(size, 5, None),
        distance_cube(size, 6, Some(4)),
    ];
    // Level 1: 2 * 6 * 9 * 9 = 972 cells = 16 workgroups of 64 -> 3 x 6 (two idle workgroups).
    let (_, groups) = level_params(2, size, 3)[0];
    assert_eq!(groups, [3, 6, 1]);
    let distances: Vec<f32> = cubes.iter().flat_map(|c| c.distance.clone()).collect();
    let distance = ctx
        .create_buffer_init(
            "cmo_distance",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &distances,
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let len = mip_len(size);
    let mip = ctx
        .create_buffer_init(
            "cmo_mip",
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            &vec![[f32::NAN; 2]; 2 * len],
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let pyramid = Pyramid::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bindings = pyramid
        .bind_with_row_limit(&ctx, &distance, &mip, 2, size, 3)
        .unwrap_or_else(|e| panic!("{e}"));
    ctx.submit_and_wait("multi-row pyramid", |rec| {
        pyramid.record(rec, &bindings, None)
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let gpu: Vec<[f32; 2]> = ctx.read_buffer(&mip).unwrap_or_else(|e| panic!("{e}"));
    for (k, cube) in cubes.iter().enumerate() {
        compare_cells(
            &gpu[k * len..(k + 1) * len],
            &MipPyramid::build(cube).flatten(),
        )
        .unwrap_or_else(|e| panic!("CMO {k}: {e}"));
    }
    drop((bindings, mip, distance, pyramid));
    finish_gpu(ctx);
}

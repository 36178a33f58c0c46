//! Integration tests of the Vulkan backbone. They need a Vulkan driver (CI installs lavapipe) and
//! fail with the driver's install hint when none is present; they run under the Khronos
//! validation layer when it is installed and fail on any validation error. With
//! `CUBETRACE_VALIDATION=1` (as CI sets it) the layer and `spirv-val` are required: a missing one
//! fails the suite instead of being skipped.
mod common;
use common::{finish_gpu, gpu_context};

use ash::vk;
use common::selftest::{SelftestOut, SelftestParams, selftest_cpu, selftest_gpu};
use cubetrace::check_layout;
use cubetrace::vk::backend::instance::VALIDATION_ENV;
use cubetrace::vk::backend::shaders::{BindingKind, PASSES, SELFTEST, Stage, StructLayout};
use cubetrace::vk::{ContextOptions, GpuContext, Image, ImageDesc, Validation};

/// Deterministic input (no RNG): a simple LCG.
fn input(n: usize) -> Vec<u32> {
    let mut x = 12345u32;
    (0..n)
        .map(|_| {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            x >> 8
        })
        .collect()
}

#[test]
fn selftest_matches_cpu_and_validation_is_clean() {
    let ctx = gpu_context();
    let report = ctx.report().clone();
    assert!(report.subgroup_size >= 1, "{report}");
    // 1000 items: three full workgroups and a partial one, so the `count` guard is exercised.
    let data = input(1000);
    let params = SelftestParams {
        count: data.len() as u32,
        scale: 3,
        bias: [7, 0],
    };
    let (gpu, time) =
        selftest_gpu(&ctx, &data, params.scale, params.bias).unwrap_or_else(|e| panic!("{e}"));
    let cpu = selftest_cpu(&data, params);
    assert_eq!(gpu.len(), cpu.len());
    for (g, c) in gpu.iter().zip(&cpu) {
        assert_eq!((g.sum, g.odd), (c.sum, c.odd), "GPU {g:?} vs CPU {c:?}");
        assert_eq!(
            g.subgroup_size, report.subgroup_size,
            "shader subgroup size vs reported"
        );
        assert_eq!(
            g.subgroups,
            256 / report.subgroup_size,
            "subgroups per 256-invocation workgroup"
        );
    }
    // Negative check: a perturbed expectation must not match.
    let perturbed = selftest_cpu(
        &data,
        SelftestParams {
            bias: [8, 0],
            ..params
        },
    );
    assert!(gpu.iter().zip(&perturbed).any(|(g, c)| g.sum != c.sum));

    if report.timestamps_supported() {
        let (name, ns) = time.expect("timestamps are supported, so the pass is timed");
        assert_eq!(name, "selftest");
        assert!(ns >= 0.0 && ns.is_finite(), "{ns}");
    }
    finish_gpu(ctx);
}

#[test]
fn device_report_is_sane_and_printable() {
    let reports = GpuContext::list_devices(Validation::Off).unwrap_or_else(|e| panic!("{e}"));
    assert!(!reports.is_empty());
    for r in &reports {
        assert!(r.subgroup_size >= 1);
        let text = r.to_string();
        assert!(
            text.contains(&r.name) && text.contains("subgroups: size"),
            "{text}"
        );
    }
    assert!(
        reports.iter().any(|r| r.missing_requirement().is_none()),
        "no usable device"
    );
}

#[test]
fn bad_device_index_is_a_clear_error() {
    let opts = ContextOptions {
        device_index: Some(999),
        ..ContextOptions::default()
    };
    let err = GpuContext::new(opts)
        .err()
        .expect("device 999 does not exist");
    assert!(err.to_string().contains("999"), "{err}");
}

#[test]
fn reflection_lists_the_selftest_bindings() {
    assert!(PASSES.iter().any(|p| p.name == "selftest"));
    let ep = SELFTEST.entry_point("main").expect("entry point main");
    assert_eq!(ep.stage, Stage::Compute);
    assert_eq!(ep.workgroup_size, [256, 1, 1]);
    let kinds: Vec<_> = ep
        .bindings
        .iter()
        .map(|b| (b.name, b.group, b.binding, b.kind))
        .collect();
    assert_eq!(
        kinds,
        [
            ("params", 0, 0, BindingKind::UniformBuffer),
            (
                "input",
                0,
                1,
                BindingKind::StorageBuffer { read_only: true }
            ),
            (
                "output",
                0,
                2,
                BindingKind::StorageBuffer { read_only: false }
            ),
        ]
    );
    assert_eq!(SELFTEST.spirv.first(), Some(&0x0723_0203), "SPIR-V magic");
    assert_eq!(SELFTEST.spirv.get(1), Some(&0x0001_0300), "SPIR-V 1.3");
}

#[test]
fn shared_structs_match_naga_layout() {
    let params = SELFTEST.struct_layout("SelftestParams").expect("reflected");
    check_layout!(SelftestParams, params, [count, scale, bias]).unwrap_or_else(|e| panic!("{e}"));
    let out = SELFTEST.struct_layout("SelftestOut").expect("reflected");
    check_layout!(SelftestOut, out, [sum, odd, subgroup_size, subgroups])
        .unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn layout_checker_catches_wrong_offsets_and_sizes() {
    // A Rust struct where `bias` is not 8-aligned as WGSL's vec2<u32> is.
    #[repr(C)]
    struct Misaligned {
        count: u32,
        bias: [u32; 2],
        scale: u32,
    }
    let params: &StructLayout = SELFTEST.struct_layout("SelftestParams").expect("reflected");
    let err = check_layout!(Misaligned, params, [count, scale, bias]).expect_err("offsets differ");
    assert!(err.contains("`scale`") && err.contains("`bias`"), "{err}");
    // A missing field and a wrong size are reported too.
    #[repr(C)]
    struct Short {
        count: u32,
        scale: u32,
    }
    let err = check_layout!(Short, params, [count, scale]).expect_err("size and member differ");
    assert!(err.contains("size") && err.contains("`bias`"), "{err}");
}

#[test]
fn cube_image_roundtrip_through_staging() {
    let ctx = gpu_context();
    let size = 4u32;
    let usage = vk::ImageUsageFlags::SAMPLED
        | vk::ImageUsageFlags::STORAGE
        | vk::ImageUsageFlags::TRANSFER_DST
        | vk::ImageUsageFlags::TRANSFER_SRC;
    for format in [
        vk::Format::R32_SFLOAT,
        vk::Format::R32G32_SFLOAT,
        vk::Format::R32G32B32A32_SFLOAT,
    ] {
        let image = Image::new(
            ctx.device(),
            ImageDesc::cube("roundtrip cube", format, size, usage),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(image.layer_view(5).is_some() && image.layer_view(6).is_none());
        let n = image.desc().layer_bytes().expect("known format") as usize * 6 / 4;
        let texels: Vec<f32> = (0..n).map(|i| i as f32 * 0.5 - 3.0).collect();
        ctx.upload_image(
            &image,
            bytemuck::cast_slice(&texels),
            vk::ImageLayout::GENERAL,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let back = ctx
            .read_image(&image, vk::ImageLayout::GENERAL)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            bytemuck::cast_slice::<u8, f32>(&back),
            &texels[..],
            "{format:?}"
        );
    }
    finish_gpu(ctx);
}

/// Whether the suite must have its checking tools (`CUBETRACE_VALIDATION=1`, as CI sets it).
fn tools_required() -> bool {
    std::env::var(VALIDATION_ENV).as_deref() == Ok("1")
}

/// Every pass's SPIR-V passes `spirv-val` for Vulkan 1.3. When spirv-tools is not installed
/// this fails under `CUBETRACE_VALIDATION=1` and is skipped with a note otherwise (the
/// validation layer checks modules at pipeline creation anyway).
#[test]
fn every_pass_passes_spirv_val() {
    let dir = tempfile::tempdir().expect("temp dir");
    for pass in PASSES {
        let path = dir.path().join(format!("{}.spv", pass.name));
        std::fs::write(&path, bytemuck::cast_slice::<u32, u8>(pass.spirv)).expect("write .spv");
        let out = match std::process::Command::new("spirv-val")
            .arg("--target-env")
            .arg("vulkan1.3")
            .arg(&path)
            .output()
        {
            Ok(o) => o,
            Err(e) if tools_required() => panic!(
                "spirv-val not runnable ({e}) but {}=1 requires it; apt-get install spirv-tools",
                VALIDATION_ENV
            ),
            Err(e) => {
                return eprintln!(
                    "skipped: spirv-val not runnable ({e}); apt-get install spirv-tools"
                );
            }
        };
        assert!(
            out.status.success(),
            "{}: {}",
            pass.source_file,
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// Requiring the device's native subgroup size builds a pipeline without validation errors.
#[test]
fn compute_pipeline_with_required_subgroup_size() {
    use cubetrace::vk::{ComputeOptions, ComputePipeline};
    let ctx = gpu_context();
    let size = ctx.report().subgroup_size;
    let options = ComputeOptions {
        required_subgroup_size: Some(size),
    };
    let pipeline =
        ComputePipeline::new(&ctx, &SELFTEST, "main", options).unwrap_or_else(|e| panic!("{e}"));
    assert!(ComputePipeline::new(&ctx, &SELFTEST, "nope", ComputeOptions::default()).is_err());
    // A bind group missing a reflected binding is refused, naming the WGSL variable.
    let err = pipeline.bind_group(0, &[]).err().expect("bindings missing");
    assert!(err.to_string().contains("params"), "{err}");
    drop(pipeline);
    finish_gpu(ctx);
}

/// Runs one test of this binary in a child process with `env` set (`None`: removed); returns
/// whether it passed and its output.
fn run_self(test: &str, env: &[(&str, Option<&std::ffi::OsStr>)]) -> (bool, String) {
    let exe = std::env::current_exe().expect("the test binary's path");
    let mut cmd = std::process::Command::new(exe);
    cmd.args([test, "--exact", "--nocapture", "--test-threads=1"]);
    for (k, v) in env {
        match v {
            Some(v) => cmd.env(k, v),
            None => cmd.env_remove(k),
        };
    }
    let o = cmd.output().expect("running the test binary");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

/// `CUBETRACE_VALIDATION=1` makes a missing validation layer or `spirv-val` fail the tests that
/// use them; without it they proceed (the layer) or skip (spirv-val). Child processes hide the
/// layer (`VK_LAYER_PATH` at an empty folder) or the tool (`PATH` at an empty folder).
#[test]
fn validation_env_requires_the_layer_and_spirv_val() {
    let empty = tempfile::tempdir().expect("temp dir");
    let empty = Some(empty.path().as_os_str());
    let on = Some(std::ffi::OsStr::new("1"));
    let env = VALIDATION_ENV;
    let layer_test = "compute_pipeline_with_required_subgroup_size";
    let (ok, text) = run_self(layer_test, &[("VK_LAYER_PATH", empty), (env, on)]);
    assert!(
        !ok && text.contains("VK_LAYER_KHRONOS_validation"),
        "{text}"
    );
    let (ok, text) = run_self(layer_test, &[("VK_LAYER_PATH", empty), (env, None)]);
    assert!(ok, "without {env} a missing layer is not an error:\n{text}");
    let tool_test = "every_pass_passes_spirv_val";
    let (ok, text) = run_self(tool_test, &[("PATH", empty), (env, on)]);
    assert!(!ok && text.contains("spirv-val not runnable"), "{text}");
    let (ok, text) = run_self(tool_test, &[("PATH", empty), (env, None)]);
    assert!(ok && text.contains("skipped"), "{text}");
}

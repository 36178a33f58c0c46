//! The GPU tracer's data and the `trace_probe` pass.
//!
//! `spirv/shared/trace.wgsl` is the GPU twin of [`crate::cpu::options::trace_ray`]. It reads its
//! options and the CMO data from `@group(1)`, which every pass importing it binds the same way,
//! from a [`CmoData`] (its module docs list the bindings).
//!
//! The near-centre cut radius is computed on the GPU from the data, never passed in.
//!
//! The `trace_probe` pass (`spirv/trace_probe.wgsl`) traces a list of [`ProbeRay`]s and returns
//! one [`ProbeResult`] per ray: it is how the tests compare the GPU with the CPU twin.
use ash::vk;
use gpu_allocator::MemoryLocation;

use super::buffer::Buffer;
use super::cmo::CmoData;
use super::context::GpuContext;
use super::error::{VkError, VkResult};
use super::pipeline::{ComputeOptions, ComputePipeline, Resource};
use super::shaders::TRACE_PROBE;
use crate::cpu::options::{TraceCriterion, TraceOptions, TraceSampling};
use crate::cubemap::pyramid::mip_flat_layout;

/// Entries of [`TraceConfig::mip_levels`] (index 0 unused: level 0 is the texels).
pub const TRACE_MIP_MAX_LEVELS: usize = 16;

/// Largest face size the GPU tracer accepts (its per-face step cap, `MAX_FACE_STEPS` in
/// `spirv/shared/trace.wgsl`, is provably not reached up to here).
pub const TRACE_MAX_SIZE: u32 = 4096;

/// Most sample steps of constant-step / constant-angle sampling (`MAX_SAMPLE_STEPS`).
pub const TRACE_MAX_STEPS: u32 = 65536;

/// WGSL `TraceConfig` (uniform, `@group(1) @binding(0)`). Layout checked against naga's in
/// `tests/gpu_twin.rs`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TraceConfig {
    /// Number of CMOs K.
    pub cmo_count: u32,
    /// Face size N.
    pub size: u32,
    /// 0 exact, 1 threshold, 2 sign change.
    pub criterion: u32,
    /// 0 constant step, 1 constant angle, 2 per texel.
    pub sampling: u32,
    /// 0 per-texel walk, 1 mip march (exact criterion).
    pub accel: u32,
    /// Sample intervals of constant-step / constant-angle sampling.
    pub steps: u32,
    /// Threshold (world units).
    pub eps: f32,
    /// `k` of the continuity rule.
    pub continuity_k: f32,
    /// Pyramid levels above the texels (0 for N = 1).
    pub mip_top: u32,
    /// Cells per CMO in the mip buffer.
    pub mip_len: u32,
    /// 1: exact criterion with decisive patch hits only (`TraceOptions::strict`).
    pub strict: u32,
    /// Padding.
    pub pad1: u32,
    /// Level `l` in `1..=mip_top`: `[offset, width, height, span]` (offset in cells within a
    /// CMO's block, span in texels).
    pub mip_levels: [[u32; 4]; TRACE_MIP_MAX_LEVELS],
}

/// Total cells of one CMO's flattened 2x2 pyramid for face size `size` (`mip_len(N)`).
pub fn mip_len(size: u32) -> u32 {
    mip_flat_layout(size)
        .iter()
        .map(|l| 6 * l.width * l.height)
        .sum()
}

impl TraceConfig {
    /// The config for `cmo_count` CMOs of face size `size` traced with `opts`. Fails outside
    /// the ranges where the shader's loop caps are provably never reached (so that it gives the
    /// CPU twin's results): `size` in `1..=`[`TRACE_MAX_SIZE`], `opts.steps` at most
    /// [`TRACE_MAX_STEPS`].
    pub fn new(cmo_count: u32, size: u32, opts: &TraceOptions) -> VkResult<TraceConfig> {
        let err = |detail: String| VkError::Usage {
            what: "trace config".into(),
            detail,
        };
        if size == 0 || size > TRACE_MAX_SIZE {
            return Err(err(format!(
                "face size {size} is not in 1..={TRACE_MAX_SIZE}"
            )));
        }
        if opts.steps > TRACE_MAX_STEPS {
            return Err(err(format!(
                "{} sample steps, at most {TRACE_MAX_STEPS}",
                opts.steps
            )));
        }
        let layout = mip_flat_layout(size);
        let mut mip_levels = [[0u32; 4]; TRACE_MIP_MAX_LEVELS];
        for (i, l) in layout.iter().enumerate() {
            mip_levels[i + 1] = [l.offset, l.width, l.height, 1 << (i + 1)];
        }
        Ok(TraceConfig {
            cmo_count,
            size,
            criterion: match opts.criterion {
                TraceCriterion::Exact => 0,
                TraceCriterion::Threshold => 1,
                TraceCriterion::SignChange => 2,
            },
            sampling: match opts.sampling {
                TraceSampling::ConstantStep => 0,
                TraceSampling::ConstantAngle => 1,
                TraceSampling::PerTexel => 2,
            },
            accel: u32::from(opts.accel),
            steps: opts.steps,
            eps: opts.eps,
            continuity_k: opts.continuity_k,
            mip_top: layout.len() as u32,
            mip_len: mip_len(size),
            strict: u32::from(opts.strict),
            pad1: 0,
            mip_levels,
        })
    }
}

/// WGSL `ProbeRay`: the world ray `origin + t dir`, `t in [t_lo, t_hi]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ProbeRay {
    /// Ray origin (world).
    pub origin: [f32; 3],
    /// First parameter.
    pub t_lo: f32,
    /// Direction (world; `t` is in its units).
    pub dir: [f32; 3],
    /// Last parameter.
    pub t_hi: f32,
}

/// WGSL `ProbeParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ProbeParams {
    /// Number of rays.
    pub count: u32,
    /// Padding to 16 bytes.
    pub pad0: u32,
    /// Padding.
    pub pad1: u32,
    /// Padding.
    pub pad2: u32,
}

/// WGSL `TraceOut`: what one ray found (see `spirv/shared/trace.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ProbeResult {
    /// 0 hit, 1 escaped, 2 unresolved.
    pub status: u32,
    /// CMO that decided, `u32::MAX` when unresolved.
    pub cmo: u32,
    /// Face of the deciding texel (of the last single-CMO trace).
    pub face: u32,
    /// Its column.
    pub x: u32,
    /// Its row.
    pub y: u32,
    /// 1 for a hit on a riser.
    pub riser: u32,
    /// Texels tested by the last single-CMO trace.
    pub texels: u32,
    /// Pyramid cells tested by the last single-CMO trace.
    pub cells: u32,
    /// Single-CMO traces run.
    pub traces: u32,
    /// The last single-CMO trace's `t`.
    pub t: f32,
    /// Proven-empty prefix end.
    pub t_done: f32,
    /// Padding.
    pub pad0: u32,
    /// World point (hit, escape, or `origin + t_done dir` when unresolved).
    pub point: [f32; 3],
    /// Padding.
    pub pad1: u32,
}

/// Whether `opts` select the exact criterion's mip march without `--strict`, the only method the
/// specialised entry points carry (`fs_exact_mip` of `fragment_trace`, `main_exact_mip` of
/// `trace_probe`; WGSL `TRACE_EXACT_MIP`). Every other option set needs the generic entry point.
pub fn exact_mip_only(opts: &TraceOptions) -> bool {
    opts.criterion == TraceCriterion::Exact && opts.accel && !opts.strict
}

/// The same test on a built config (`criterion` exact, `accel` set and `strict` off, as
/// `trace_one` and `classify` decide).
fn config_exact_mip(config: &TraceConfig) -> bool {
    config.criterion == 0 && config.accel != 0 && config.strict == 0
}

/// Workgroup size of `trace_probe` (fixed by the WGSL, checked against reflection).
pub const PROBE_WORKGROUP: u32 = 64;

/// Traces `rays` on the GPU with the tracer of `spirv/shared/trace.wgsl` over `data`, through
/// the specialised entry point `main_exact_mip` when the config allows it (the production
/// path's code), else the generic `main`.
pub fn trace_probe(
    ctx: &GpuContext,
    data: &CmoData,
    rays: &[ProbeRay],
) -> VkResult<Vec<ProbeResult>> {
    let entry = if config_exact_mip(data.config()) {
        "main_exact_mip"
    } else {
        "main"
    };
    trace_probe_entry(ctx, data, rays, entry)
}

/// [`trace_probe`] through a named entry point of the pass: `main` (any options) or
/// `main_exact_mip` (only valid when [`exact_mip_only`] holds for the config's options).
pub fn trace_probe_entry(
    ctx: &GpuContext,
    data: &CmoData,
    rays: &[ProbeRay],
    entry: &str,
) -> VkResult<Vec<ProbeResult>> {
    if rays.is_empty() {
        return Ok(Vec::new());
    }
    if entry == "main_exact_mip" && !config_exact_mip(data.config()) {
        return Err(VkError::Usage {
            what: "trace_probe".into(),
            detail: "entry point main_exact_mip needs the exact criterion with accel".into(),
        });
    }
    let pipeline = ComputePipeline::new(ctx, &TRACE_PROBE, entry, ComputeOptions::default())?;
    if pipeline.entry.workgroup_size[0] != PROBE_WORKGROUP {
        return Err(VkError::Shader {
            pass: TRACE_PROBE.name.into(),
            detail: format!(
                "workgroup size {:?}, expected {PROBE_WORKGROUP}",
                pipeline.entry.workgroup_size
            ),
        });
    }
    let count = rays.len() as u32;
    let params = ProbeParams {
        count,
        ..ProbeParams::default()
    };
    let params_buf = ctx.create_buffer_init(
        "trace_probe params",
        vk::BufferUsageFlags::STORAGE_BUFFER,
        &[params],
    )?;
    let rays_buf = ctx.create_buffer_init(
        "trace_probe rays",
        vk::BufferUsageFlags::STORAGE_BUFFER,
        rays,
    )?;
    let out_buf = Buffer::new(
        ctx.device(),
        "trace_probe results",
        u64::from(count) * size_of::<ProbeResult>() as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )?;
    let set0 = pipeline.bind_group(
        0,
        &[
            (0, Resource::Buffer(&params_buf)),
            (1, Resource::Buffer(&rays_buf)),
            (2, Resource::Buffer(&out_buf)),
        ],
    )?;
    let set1 = pipeline.bind_group(1, &data.resources_for(&TRACE_PROBE, entry))?;
    let groups = count.div_ceil(PROBE_WORKGROUP);
    ctx.submit_and_wait(TRACE_PROBE.name, |rec| {
        rec.begin_label(TRACE_PROBE.name);
        pipeline.dispatch(rec, &[&set0, &set1], [groups, 1, 1]);
        rec.end_label();
        Ok(())
    })?;
    let mut out: Vec<ProbeResult> = ctx.read_buffer(&out_buf)?;
    out.truncate(rays.len());
    Ok(out)
}

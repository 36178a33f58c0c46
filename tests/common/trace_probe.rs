//! The `trace_probe` pass (`spirv/trace_probe.wgsl`), a test probe of the GPU tracer
//! (`spirv/shared/trace.wgsl`, the GPU twin of `cubetrace::cpu::options::trace_ray`): it traces
//! a list of [`ProbeRay`]s over a [`CmoData`] and returns one [`ProbeResult`] per ray, which is
//! how the tests compare the GPU with the CPU twin.
use ash::vk;
use gpu_allocator::MemoryLocation;

use cubetrace::vk::backend::buffer::Buffer;
use cubetrace::vk::backend::context::GpuContext;
use cubetrace::vk::backend::error::{VkError, VkResult};
use cubetrace::vk::backend::pipeline::{ComputeOptions, ComputePipeline, Resource};
use cubetrace::vk::backend::shaders::TRACE_PROBE;
use cubetrace::vk::passes::cmo::{CmoData, TraceConfig};

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

/// The same test on a built config (`criterion` centre, `accel` set and `strict` off, as
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
            detail: "entry point main_exact_mip needs the centre criterion with accel".into(),
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

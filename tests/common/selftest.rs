//! The `selftest` pass: a tiny compute shader exercising subgroup ballot and arithmetic, used to
//! check that the backbone (build script, reflection, pipelines, buffers, timestamps) works.
//! Its CPU twin is [`selftest_cpu`].
use ash::vk;
use gpu_allocator::MemoryLocation;

use cubetrace::vk::backend::buffer::Buffer;
use cubetrace::vk::backend::context::GpuContext;
use cubetrace::vk::backend::error::VkResult;
use cubetrace::vk::backend::pipeline::{ComputeOptions, ComputePipeline, Resource};
use cubetrace::vk::backend::shaders::SELFTEST;
use cubetrace::vk::backend::timestamps::{PassTime, Timestamps};

/// WGSL `SelftestParams` (uniform). Layout checked against naga's in the tests.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SelftestParams {
    pub count: u32,
    pub scale: u32,
    pub bias: [u32; 2],
}

/// WGSL `SelftestOut`, one per 256-invocation workgroup.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SelftestOut {
    /// Σ `input[i] * scale + bias.x` over the workgroup's valid items (wrapping u32).
    pub sum: u32,
    /// Number of odd inputs.
    pub odd: u32,
    /// `subgroup_size` builtin seen by the shader.
    pub subgroup_size: u32,
    /// Number of subgroups that ran in the workgroup.
    pub subgroups: u32,
}

/// Workgroup size of the pass (reflected, but fixed by the WGSL).
pub const WORKGROUP: u32 = 256;

/// CPU twin: per workgroup, `sum` and `odd` (subgroup fields left 0: they depend on the device).
pub fn selftest_cpu(input: &[u32], params: SelftestParams) -> Vec<SelftestOut> {
    input
        .chunks(WORKGROUP as usize)
        .map(|chunk| {
            let mut out = SelftestOut::default();
            for &x in chunk {
                out.sum = out
                    .sum
                    .wrapping_add(x.wrapping_mul(params.scale).wrapping_add(params.bias[0]));
                out.odd += x & 1;
            }
            out
        })
        .collect()
}

/// Runs the pass on the GPU. Returns the per-workgroup output and, when timestamps are supported,
/// the pass's `(name, ns)`.
pub fn selftest_gpu(
    ctx: &GpuContext,
    input: &[u32],
    scale: u32,
    bias: [u32; 2],
) -> VkResult<(Vec<SelftestOut>, Option<PassTime>)> {
    let params = SelftestParams {
        count: input.len() as u32,
        scale,
        bias,
    };
    let groups = (input.len() as u32).div_ceil(WORKGROUP).max(1);
    let pipeline = ComputePipeline::new(ctx, &SELFTEST, "main", ComputeOptions::default())?;
    let params_buf = ctx.create_buffer_init(
        "selftest params",
        vk::BufferUsageFlags::UNIFORM_BUFFER,
        &[params],
    )?;
    let input_buf = ctx.create_buffer_init(
        "selftest input",
        vk::BufferUsageFlags::STORAGE_BUFFER,
        input,
    )?;
    let output_buf = Buffer::new(
        ctx.device(),
        "selftest output",
        u64::from(groups) * size_of::<SelftestOut>() as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )?;
    let set = pipeline.bind_group(
        0,
        &[
            (0, Resource::Buffer(&params_buf)),
            (1, Resource::Buffer(&input_buf)),
            (2, Resource::Buffer(&output_buf)),
        ],
    )?;
    let mut timestamps = if ctx.report().timestamps_supported() {
        Some(Timestamps::new(ctx, 1)?)
    } else {
        None
    };
    ctx.submit_and_wait(SELFTEST.name, |rec| {
        let scope = match &mut timestamps {
            Some(t) => {
                t.reset(rec);
                Some(t.begin(rec, SELFTEST.name)?)
            }
            None => {
                rec.begin_label(SELFTEST.name);
                None
            }
        };
        pipeline.dispatch(rec, &[&set], [groups, 1, 1]);
        match (&mut timestamps, scope) {
            (Some(t), Some(s)) => t.end(rec, s),
            _ => rec.end_label(),
        }
        Ok(())
    })?;
    let out: Vec<SelftestOut> = ctx.read_buffer(&output_buf)?;
    let time = match &timestamps {
        Some(t) => t.results()?.into_iter().next(),
        None => None,
    };
    Ok((out, time))
}

//! The `hier32` pass: builds the alternating 4x8 / 8x4 `[min, max]` hierarchy of K CMOs on the
//! GPU (the compute path's acceleration structure, thesis alg. 3), one dispatch per level,
//! bit-identical to its CPU twin [`Hier32::build`] + [`Hier32::flatten`].
//!
//! Invariants:
//! - Inputs and outputs follow the fixed GPU layouts: `cmo_distance` holds K blocks of `6 N N`
//!   texels; `cmo_hier` holds K blocks of [`hier32_len`]`(N)` cells in the
//!   [`hier32_flat_layout`]`(N)` order. Every cell of every block is written; nothing else is.
//! - Level `l` reads level `l - 1` (level 1 reads the texels), with a compute-write ->
//!   compute-read barrier between levels recorded by [`Hier32Pass::record`]. The barriers around
//!   the pass belong to the caller.
//! - [`Hier32Bindings`] must outlive every submission that uses it, and the buffers it was made
//!   for must outlive it.
//! - `N <= 4` has no level above the texels: the pass records nothing.
use ash::vk;
use gpu_allocator::MemoryLocation;

use super::pyramid::reduce_on_gpu;
use crate::cubemap::CubeMap;
use crate::cubemap::face::FACE_COUNT;
pub use crate::cubemap::pyramid::{Hier32, hier32_flat_layout, hier32_len};
use crate::cubemap::pyramid::{hier32_group, hier32_layout};
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::pipeline::{
    BindGroup, ComputeOptions, ComputePipeline, MAX_GROUPS_X, Resource, dispatch_rows,
};
use crate::vk::backend::shaders::HIER32;
use crate::vk::backend::sync::{COMPUTE_READ, COMPUTE_WRITE};

/// WGSL `Hier32Params` (read-only storage buffer, one per level). Layout checked against naga's in the tests.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Hier32Params {
    pub cmo_count: u32,
    pub src_width: u32,
    pub src_height: u32,
    pub src_offset: u32,
    pub dst_width: u32,
    pub dst_height: u32,
    pub dst_offset: u32,
    pub hier_len: u32,
    pub gx: u32,
    pub gy: u32,
    pub from_texels: u32,
    pub texels_per_cmo: u32,
}

/// Workgroup size of the pass (fixed by the WGSL).
pub const WORKGROUP: u32 = 64;

/// `(params, groups)` of every level above the texels, finest first.
pub fn level_params(cmo_count: u32, size: u32) -> Vec<(Hier32Params, [u32; 3])> {
    let hier_len = hier32_len(size) as u32;
    let dims = hier32_layout(size);
    let mut src = (size, size, 0u32, true);
    hier32_flat_layout(size)
        .into_iter()
        .enumerate()
        .map(|(i, level)| {
            let (gx, gy) = hier32_group(i + 1);
            debug_assert_eq!(dims[i + 1], (level.width, level.height));
            let params = Hier32Params {
                cmo_count,
                src_width: src.0,
                src_height: src.1,
                src_offset: src.2,
                dst_width: level.width,
                dst_height: level.height,
                dst_offset: level.offset,
                hier_len,
                gx,
                gy,
                from_texels: u32::from(src.3),
                texels_per_cmo: FACE_COUNT * size * size,
            };
            src = (level.width, level.height, level.offset, false);
            let cells = cmo_count * FACE_COUNT * level.width * level.height;
            (params, dispatch_rows(cells, WORKGROUP, MAX_GROUPS_X))
        })
        .collect()
}

/// The pass's pipeline. Create once, record every frame.
pub struct Hier32Pass {
    pipeline: ComputePipeline,
    /// Whether it builds the gaps' hierarchy ([`Hier32Pass::gaps`]).
    gaps: bool,
}

/// Per-level parameters and descriptor sets for one `(distance, hier, K, N)`.
pub struct Hier32Bindings {
    sets: Vec<BindGroup>,
    _params: Vec<Buffer>,
    groups: Vec<[u32; 3]>,
}

impl Hier32Bindings {
    /// Number of dispatches [`Hier32Pass::record`] records.
    pub fn levels(&self) -> usize {
        self.sets.len()
    }
}

impl Hier32Pass {
    /// Builds the pipeline.
    pub fn new(ctx: &GpuContext) -> VkResult<Self> {
        let pipeline = ComputePipeline::new(ctx, &HIER32, "main", ComputeOptions::default())?;
        Ok(Hier32Pass {
            pipeline,
            gaps: false,
        })
    }

    /// Builds the pipeline of the `bounded` criterion's gap hierarchy (the `gaps` entry point):
    /// [`Hier32Pass::bind`]'s `distance` is then the texels' packed gaps (a word each,
    /// [`crate::cubemap::bounds::pack_gap`]) and `hier` gets a packed word per cell
    /// ([`crate::cubemap::pyramid::Hier32::over_cells`]).
    pub fn gaps(ctx: &GpuContext) -> VkResult<Self> {
        let pipeline = ComputePipeline::new(ctx, &HIER32, "gaps", ComputeOptions::default())?;
        Ok(Hier32Pass {
            pipeline,
            gaps: true,
        })
    }

    /// Parameters and descriptor sets reading `distance` (K blocks of `6 N N` f32) and writing
    /// `hier` (K blocks of `hier32_len(N)` `[f32; 2]`). Fails with [`VkError::Usage`] when K or
    /// N is 0, a buffer is too small, or an index would overflow u32.
    pub fn bind(
        &self,
        ctx: &GpuContext,
        distance: &Buffer,
        hier: &Buffer,
        cmo_count: u32,
        size: u32,
    ) -> VkResult<Hier32Bindings> {
        let usage = |detail: String| VkError::Usage {
            what: HIER32.name.into(),
            detail,
        };
        if cmo_count == 0 || size == 0 {
            return Err(usage(format!(
                "need at least one CMO and N >= 1 (got K = {cmo_count}, N = {size})"
            )));
        }
        let texels = u64::from(cmo_count) * u64::from(FACE_COUNT) * u64::from(size).pow(2);
        let cells = u64::from(cmo_count) * hier32_len(size) as u64;
        if texels > u64::from(u32::MAX) || cells > u64::from(u32::MAX) {
            return Err(usage(format!(
                "K = {cmo_count}, N = {size} overflows the shader's u32 indices"
            )));
        }
        let cell_bytes = if self.gaps { 4 } else { 8 };
        for (buf, need) in [(distance, texels * 4), (hier, cells * cell_bytes)] {
            if buf.size() < need {
                return Err(usage(format!(
                    "buffer `{}` has {} bytes, K = {cmo_count}, N = {size} needs {need}",
                    buf.name(),
                    buf.size()
                )));
            }
        }
        let mut b = Hier32Bindings {
            sets: Vec::new(),
            _params: Vec::new(),
            groups: Vec::new(),
        };
        for (l, (params, groups)) in level_params(cmo_count, size).into_iter().enumerate() {
            let mut buf = Buffer::new(
                ctx.device(),
                &format!("hier32 params level {}", l + 1),
                size_of::<Hier32Params>() as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::CpuToGpu,
            )?;
            buf.write(0, &[params])?;
            let first = if self.gaps { 3 } else { 1 };
            b.sets.push(self.pipeline.bind_group(
                0,
                &[
                    (0, Resource::Buffer(&buf)),
                    (first, Resource::Buffer(distance)),
                    (first + 1, Resource::Buffer(hier)),
                ],
            )?);
            b._params.push(buf);
            b.groups.push(groups);
        }
        Ok(b)
    }

    /// Records one dispatch per level with a barrier between levels (no label or timestamp:
    /// the caller scopes the pass).
    pub fn record(&self, rec: &Recorder<'_>, bindings: &Hier32Bindings) {
        for (i, (set, groups)) in bindings.sets.iter().zip(&bindings.groups).enumerate() {
            if i > 0 {
                rec.memory_barrier(COMPUTE_WRITE, COMPUTE_READ);
            }
            self.pipeline.dispatch(rec, &[set], *groups);
        }
    }
}

/// Test helper: uploads the distances of `cubes` (one face size), builds their hierarchy on the
/// GPU and reads it back, one `flatten()`-shaped vector per CMO (see
/// `super::pyramid::reduce_on_gpu`).
pub fn build_hier_gpu(ctx: &GpuContext, cubes: &[CubeMap]) -> VkResult<Vec<Vec<[f32; 2]>>> {
    reduce_on_gpu(
        ctx,
        cubes,
        HIER32.name,
        hier32_len,
        |distance, hier, count, size| {
            let pass = Hier32Pass::new(ctx)?;
            let bindings = pass.bind(ctx, distance, hier, count, size)?;
            ctx.submit_and_wait(HIER32.name, |rec| {
                pass.record(rec, &bindings);
                Ok(())
            })
        },
    )
}

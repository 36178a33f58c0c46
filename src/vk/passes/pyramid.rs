//! The `pyramid` pass: builds the 2x2 `[min, max]` distance pyramid of K CMOs on the GPU, one
//! dispatch per level, bit-identical to its CPU twin
//! [`MipPyramid::build`](crate::cubemap::pyramid::MipPyramid::build) +
//! [`flatten`](crate::cubemap::pyramid::MipPyramid::flatten).
//!
//! Invariants:
//! - Inputs and outputs follow the fixed GPU layouts: `cmo_distance` holds K blocks of `6 N N`
//!   texels; `cmo_mip` holds K blocks of [`mip_len`]`(N)` cells in the
//!   [`mip_flat_layout`]`(N)` order. Every cell of every block is written; nothing else is.
//! - Level `l` reads level `l - 1` (level 1 reads the texels). Consecutive levels are separated by
//!   a compute-write -> compute-read memory barrier recorded by [`Pyramid::record`]. The barriers
//!   *around* the pass (after the producer of `cmo_distance`, before the consumer of `cmo_mip`)
//!   belong to the caller, who knows those passes.
//! - Per-level parameters and descriptor sets live in a [`PyramidBindings`], created before
//!   recording; it must outlive every submission that uses it, and the two buffers it was made
//!   for must outlive it (descriptor sets hold their handles, not a borrow).
//! - `N = 1` has no level above the texels: the pass records nothing.
use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::cubemap::CubeMap;
use crate::cubemap::face::FACE_COUNT;
use crate::cubemap::pyramid::mip_flat_layout;
pub use crate::cubemap::pyramid::mip_len;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::pipeline::{
    BindGroup, ComputeOptions, ComputePipeline, Resource, dispatch_rows,
};
use crate::vk::backend::shaders::PYRAMID;
use crate::vk::backend::timestamps::Timestamps;

/// WGSL `PyramidParams` (read-only storage buffer, one per level). Layout checked against naga's in the tests.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PyramidParams {
    /// Number of CMOs K.
    pub cmo_count: u32,
    /// Cells per side of the source level (N for level 1).
    pub src_width: u32,
    /// First cell of the source level in a CMO's mip block (unused for level 1).
    pub src_offset: u32,
    /// Cells per side of the destination level.
    pub dst_width: u32,
    /// First cell of the destination level in a CMO's mip block.
    pub dst_offset: u32,
    /// Cells per CMO block of `cmo_mip`: `mip_len(N)`.
    pub mip_len: u32,
    /// 1 when the source is the texels (`cmo_distance`), else 0.
    pub from_texels: u32,
    /// Texels per CMO block of `cmo_distance`: `6 N N`.
    pub texels_per_cmo: u32,
}

/// Workgroup size of the pass (fixed by the WGSL; checked against reflection in the tests).
pub const WORKGROUP: u32 = 64;

/// Workgroups per dispatch row by default; larger levels spill into more rows.
pub use crate::vk::backend::pipeline::MAX_GROUPS_X;

/// `(params, groups)` of every level of the pyramid of K CMOs of face size `size`, finest first,
/// with at most `max_groups_x` (>= 1) workgroups per dispatch row.
pub fn level_params(
    cmo_count: u32,
    size: u32,
    max_groups_x: u32,
) -> Vec<(PyramidParams, [u32; 3])> {
    let mip_len = mip_len(size) as u32;
    let mut src = (size, 0u32, true);
    mip_flat_layout(size)
        .into_iter()
        .map(|level| {
            let params = PyramidParams {
                cmo_count,
                src_width: src.0,
                src_offset: src.1,
                dst_width: level.width,
                dst_offset: level.offset,
                mip_len,
                from_texels: u32::from(src.2),
                texels_per_cmo: FACE_COUNT * size * size,
            };
            src = (level.width, level.offset, false);
            let cells = cmo_count * FACE_COUNT * level.width * level.height;
            (params, dispatch_rows(cells, WORKGROUP, max_groups_x))
        })
        .collect()
}

/// The pass's pipeline. Create once, record every frame.
pub struct Pyramid {
    pipeline: ComputePipeline,
    /// Whether it builds the gaps' pyramid ([`Pyramid::gaps`]) rather than the distances'.
    gaps: bool,
}

/// Per-level parameters and descriptor sets for one `(distance, mip, K, N)`; see the module docs
/// for its lifetime rules.
pub struct PyramidBindings {
    /// Declared before `params` so the sets go first (not required by Vulkan, but tidy).
    sets: Vec<BindGroup>,
    params: Vec<Buffer>,
    groups: Vec<[u32; 3]>,
    cmo_count: u32,
    size: u32,
}

impl PyramidBindings {
    /// Number of CMOs these bindings were made for.
    pub fn cmo_count(&self) -> u32 {
        self.cmo_count
    }

    /// Face size N these bindings were made for.
    pub fn size(&self) -> u32 {
        self.size
    }

    /// Number of dispatches [`Pyramid::record`] records (levels above the texels).
    pub fn levels(&self) -> usize {
        self.sets.len()
    }
}

impl Pyramid {
    /// Builds the pipeline.
    pub fn new(ctx: &GpuContext) -> VkResult<Pyramid> {
        let pipeline = ComputePipeline::new(ctx, &PYRAMID, "main", ComputeOptions::default())?;
        Ok(Pyramid {
            pipeline,
            gaps: false,
        })
    }

    /// Builds the pipeline of the `bounded` criterion's gap pyramid (the `gaps` entry point):
    /// [`Pyramid::bind`]'s `distance` is then the texels' packed gaps (a word each,
    /// [`crate::cubemap::bounds::pack_gap`]) and `mip` gets a packed word per cell, the min of
    /// `g1` and the max of `g0` over each 2x2 block
    /// ([`crate::cubemap::pyramid::MipPyramid::over_cells`]).
    pub fn gaps(ctx: &GpuContext) -> VkResult<Pyramid> {
        let pipeline = ComputePipeline::new(ctx, &PYRAMID, "gaps", ComputeOptions::default())?;
        Ok(Pyramid {
            pipeline,
            gaps: true,
        })
    }

    /// Creates the per-level parameters and descriptor sets reading `distance` (K blocks of
    /// `6 N N` f32) and writing `mip` (K blocks of `mip_len(N)` `[f32; 2]`). Fails with
    /// [`VkError::Usage`] when K or N is 0, a buffer is too small, or an index would not fit
    /// in the shader's u32 arithmetic.
    pub fn bind(
        &self,
        ctx: &GpuContext,
        distance: &Buffer,
        mip: &Buffer,
        cmo_count: u32,
        size: u32,
    ) -> VkResult<PyramidBindings> {
        self.bind_with_row_limit(ctx, distance, mip, cmo_count, size, MAX_GROUPS_X)
    }

    /// [`Pyramid::bind`] with at most `max_groups_x` workgroups per dispatch row; the tests use a
    /// small limit to exercise multi-row dispatches without gigabyte buffers.
    pub fn bind_with_row_limit(
        &self,
        ctx: &GpuContext,
        distance: &Buffer,
        mip: &Buffer,
        cmo_count: u32,
        size: u32,
        max_groups_x: u32,
    ) -> VkResult<PyramidBindings> {
        let usage = |detail: String| VkError::Usage {
            what: PYRAMID.name.into(),
            detail,
        };
        if cmo_count == 0 || size == 0 {
            return Err(usage(format!(
                "need at least one CMO and N >= 1 (got K = {cmo_count}, N = {size})"
            )));
        }
        let texels = u64::from(cmo_count) * u64::from(FACE_COUNT) * u64::from(size).pow(2);
        let cells = u64::from(cmo_count) * mip_len(size) as u64;
        if texels > u64::from(u32::MAX) || cells > u64::from(u32::MAX) {
            return Err(usage(format!(
                "K = {cmo_count}, N = {size} overflows the shader's u32 indices"
            )));
        }
        let cell_bytes = if self.gaps { 4 } else { 8 };
        for (buf, need) in [(distance, texels * 4), (mip, cells * cell_bytes)] {
            if buf.size() < need {
                return Err(usage(format!(
                    "buffer `{}` has {} bytes, K = {cmo_count}, N = {size} needs {need}",
                    buf.name(),
                    buf.size()
                )));
            }
        }
        let mut bindings = PyramidBindings {
            sets: Vec::new(),
            params: Vec::new(),
            groups: Vec::new(),
            cmo_count,
            size,
        };
        for (l, (params, groups)) in level_params(cmo_count, size, max_groups_x)
            .into_iter()
            .enumerate()
        {
            // Host-visible: written once here, no staging submission per level.
            let mut buf = Buffer::new(
                ctx.device(),
                &format!("pyramid params level {}", l + 1),
                size_of::<PyramidParams>() as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::CpuToGpu,
            )?;
            buf.write(0, &[params])?;
            let first = if self.gaps { 3 } else { 1 };
            let set = self.pipeline.bind_group(
                0,
                &[
                    (0, Resource::Buffer(&buf)),
                    (first, Resource::Buffer(distance)),
                    (first + 1, Resource::Buffer(mip)),
                ],
            )?;
            bindings.sets.push(set);
            bindings.params.push(buf);
            bindings.groups.push(groups);
        }
        Ok(bindings)
    }

    /// Records the pass: one dispatch per level with a barrier between levels, inside the debug
    /// label `pyramid`, or inside a timestamp scope of that name when `timestamps` is given
    /// (its `reset` must already be recorded in this command buffer).
    pub fn record(
        &self,
        rec: &Recorder<'_>,
        bindings: &PyramidBindings,
        timestamps: Option<&mut Timestamps>,
    ) -> VkResult<()> {
        super::record_levels(
            rec,
            &self.pipeline,
            if self.gaps {
                "gap_pyramid"
            } else {
                PYRAMID.name
            },
            (&bindings.sets, &bindings.groups),
            timestamps,
        )
    }
}

/// Test and tool helper: uploads the distances of `cubes` (all of one face size), builds their
/// pyramid on the GPU and reads it back, one `flatten()`-shaped vector per CMO (see
/// `reduce_on_gpu`).
pub fn build_mip_gpu(ctx: &GpuContext, cubes: &[CubeMap]) -> VkResult<Vec<Vec<[f32; 2]>>> {
    reduce_on_gpu(
        ctx,
        cubes,
        PYRAMID.name,
        mip_len,
        |distance, mip, count, size| {
            let pyramid = Pyramid::new(ctx)?;
            let bindings = pyramid.bind(ctx, distance, mip, count, size)?;
            ctx.submit_and_wait(PYRAMID.name, |rec| pyramid.record(rec, &bindings, None))
        },
    )
}

/// Test and tool helper behind `build_mip_gpu` and `build_hier_gpu`: uploads the distances of
/// `cubes` (all of one face size), runs `record` to build `len(N)` `[min, max]` cells per CMO
/// from them into the output buffer, and reads it back, one vector per CMO. The output is first
/// filled with NaN, so a cell the pass fails to write cannot equal the CPU's by accident.
pub(crate) fn reduce_on_gpu(
    ctx: &GpuContext,
    cubes: &[CubeMap],
    pass: &str,
    len: fn(u32) -> usize,
    record: impl FnOnce(&Buffer, &Buffer, u32, u32) -> VkResult<()>,
) -> VkResult<Vec<Vec<[f32; 2]>>> {
    let usage = |detail: String| VkError::Usage {
        what: pass.into(),
        detail,
    };
    let Some(first) = cubes.first() else {
        return Err(usage("no cube maps given".into()));
    };
    let size = first.size;
    if let Some(c) = cubes.iter().find(|c| c.size != size) {
        return Err(usage(format!(
            "all CMOs must have one face size: {size} and {}",
            c.size
        )));
    }
    let len = len(size);
    if len == 0 {
        return Ok(vec![Vec::new(); cubes.len()]);
    }
    let cmo_count = u32::try_from(cubes.len()).map_err(|_| usage("too many CMOs".into()))?;
    let distances: Vec<f32> = cubes
        .iter()
        .flat_map(|c| c.distance.iter().copied())
        .collect();
    let distance = ctx.create_buffer_init(
        "cmo_distance",
        vk::BufferUsageFlags::STORAGE_BUFFER,
        &distances,
    )?;
    let out = ctx.create_buffer_init(
        &format!("{pass} output"),
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        &vec![[f32::NAN; 2]; len * cubes.len()],
    )?;
    record(&distance, &out, cmo_count, size)?;
    let cells: Vec<[f32; 2]> = ctx.read_buffer(&out)?;
    Ok(cells
        .chunks(len)
        .take(cubes.len())
        .map(<[[f32; 2]]>::to_vec)
        .collect())
}

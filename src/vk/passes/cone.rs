//! Cone tracing on the cube maps for glossy reflectors, the GPU side: the `cone_prefilter` pass,
//! which builds the pre-filtered colour chain `cmo_cone` of K CMOs one level per dispatch,
//! bit-identical to its CPU twin [`cone_prefilter`](crate::cpu::cone::cone_prefilter); and the
//! test helpers that run it and the lookups of `spirv/shared/cone.wgsl` (the `cone_probe` pass).
//!
//! Invariants (as the `pyramid` pass, [`super::pyramid`]):
//! - Level 1 reads the captured colour (`cmo_colour`, in `SHADER_READ_ONLY_OPTIMAL`), level
//!   `l > 1` level `l - 1` of `cmo_cone`; consecutive levels are separated by a compute-write ->
//!   compute-read barrier recorded here. The barriers around the pass (after the capture, before
//!   the consumers of `cmo_cone`) belong to the caller.
//! - [`ConePrefilterBindings`] must outlive every submission that uses it; the CMO data it was
//!   made for must outlive it.
//! - Only a glossy scene creates any of this ([`crate::vk::passes::cmo::CmoData::alloc_cone`]).
//!   `N = 1` has no level above the texels: the pass records nothing.
use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;

use crate::cpu::options::TraceOptions;
use crate::cubemap::CubeMap;
use crate::cubemap::face::FACE_COUNT;
use crate::cubemap::pyramid::{mip_flat_layout, mip_len};
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::pipeline::{
    BindGroup, ComputeOptions, ComputePipeline, MAX_GROUPS_X, Resource, dispatch_rows,
};
use crate::vk::backend::shaders::CONE_PREFILTER;
use crate::vk::backend::timestamps::Timestamps;
use crate::vk::passes::cmo::CmoData;

/// WGSL `ConePrefilterParams` (read-only storage buffer, one per level). Layout checked
/// against naga's in `tests/glossy/glossy_cone.rs`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ConePrefilterParams {
    /// Number of CMOs K.
    pub cmo_count: u32,
    /// Cells per side of the source level (N for level 1).
    pub src_width: u32,
    /// First cell of the source level in a CMO's block (unused for level 1).
    pub src_offset: u32,
    /// Cells per side of the destination level.
    pub dst_width: u32,
    /// First cell of the destination level in a CMO's block.
    pub dst_offset: u32,
    /// Cells per CMO block of `cmo_cone`: `mip_len(N)`.
    pub cone_len: u32,
    /// 1 when the source is the captured colour, else 0.
    pub from_texels: u32,
    /// Padding.
    pub pad0: u32,
    /// The colour an empty texel stands for.
    pub background: [f32; 3],
    /// Padding.
    pub pad1: u32,
}

/// Workgroup size of the prefilter pass (fixed by the WGSL; checked in the tests).
pub const WORKGROUP: u32 = 64;

/// `(params, groups)` of every level of the chain of K CMOs of face size `size`, finest first
/// (at most 65535 workgroups per dispatch row, as [`super::pyramid::level_params`]).
pub fn prefilter_params(
    cmo_count: u32,
    size: u32,
    background: Vec3,
) -> Vec<(ConePrefilterParams, [u32; 3])> {
    let cone_len = mip_len(size) as u32;
    let mut src = (size, 0u32, true);
    mip_flat_layout(size)
        .into_iter()
        .map(|level| {
            let params = ConePrefilterParams {
                cmo_count,
                src_width: src.0,
                src_offset: src.1,
                dst_width: level.width,
                dst_offset: level.offset,
                cone_len,
                from_texels: u32::from(src.2),
                pad0: 0,
                background: background.to_array(),
                pad1: 0,
            };
            src = (level.width, level.offset, false);
            let cells = cmo_count * FACE_COUNT * level.width * level.height;
            (params, dispatch_rows(cells, WORKGROUP, MAX_GROUPS_X))
        })
        .collect()
}

/// The prefilter pass's pipeline. Create once (glossy scenes only), record every frame.
pub struct ConePrefilter {
    pipeline: ComputePipeline,
}

/// Per-level parameters and descriptor sets of one [`CmoData`] (module docs for the lifetime).
pub struct ConePrefilterBindings {
    sets: Vec<BindGroup>,
    _params: Vec<Buffer>,
    groups: Vec<[u32; 3]>,
}

impl ConePrefilter {
    /// Builds the pipeline.
    pub fn new(ctx: &GpuContext) -> VkResult<ConePrefilter> {
        let pipeline =
            ComputePipeline::new(ctx, &CONE_PREFILTER, "main", ComputeOptions::default())?;
        Ok(ConePrefilter { pipeline })
    }

    /// The per-level bindings reading `data`'s colour and writing its `cmo_cone`, empty texels
    /// standing for `background`. Fails when `data` has no `cmo_cone` ([`CmoData::alloc_cone`]).
    pub fn bind(
        &self,
        ctx: &GpuContext,
        data: &CmoData,
        background: Vec3,
    ) -> VkResult<ConePrefilterBindings> {
        let Some(cone) = data.cone() else {
            return Err(VkError::Usage {
                what: CONE_PREFILTER.name.into(),
                detail: "the CMO data has no `cmo_cone` (CmoData::alloc_cone)".into(),
            });
        };
        let mut b = ConePrefilterBindings {
            sets: Vec::new(),
            _params: Vec::new(),
            groups: Vec::new(),
        };
        for (l, (params, groups)) in prefilter_params(data.count(), data.size(), background)
            .into_iter()
            .enumerate()
        {
            let mut buf = Buffer::new(
                ctx.device(),
                &format!("cone_prefilter params level {}", l + 1),
                size_of::<ConePrefilterParams>() as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::CpuToGpu,
            )?;
            buf.write(0, &[params])?;
            let set = self.pipeline.bind_group(
                0,
                &[
                    (0, Resource::Buffer(&buf)),
                    (
                        1,
                        Resource::Texture {
                            view: data.colour().array_view(),
                            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                        },
                    ),
                    (2, Resource::Buffer(cone)),
                ],
            )?;
            b.sets.push(set);
            b._params.push(buf);
            b.groups.push(groups);
        }
        Ok(b)
    }

    /// Records the pass: one dispatch per level with a barrier between levels, inside the debug
    /// label `cone_prefilter` or a timestamp scope of that name.
    pub fn record(
        &self,
        rec: &Recorder<'_>,
        bindings: &ConePrefilterBindings,
        timestamps: Option<&mut Timestamps>,
    ) -> VkResult<()> {
        super::record_levels(
            rec,
            &self.pipeline,
            CONE_PREFILTER.name,
            (&bindings.sets, &bindings.groups),
            timestamps,
        )
    }
}

/// Test and tool helper: uploads `cubes` (one face size) as [`CmoData::upload`] does, allocates
/// `cmo_cone` (first filled with NaN, so that a cell the pass fails to write cannot equal the
/// CPU's by accident) and runs the prefilter pass. Returns the data, ready for the lookups.
pub fn upload_with_cone(
    ctx: &GpuContext,
    cubes: &[CubeMap],
    background: Vec3,
) -> VkResult<CmoData> {
    // Rasterised cube maps: the centre criterion's data.
    let mut data = CmoData::upload(ctx, cubes, &TraceOptions::centre())?;
    data.alloc_cone(ctx)?;
    let cone = data.cone().expect("allocated");
    let nan = vec![[f32::NAN; 4]; (cone.size() / 16) as usize];
    ctx.write_buffer(cone, &nan)?;
    let pass = ConePrefilter::new(ctx)?;
    let bindings = pass.bind(ctx, &data, background)?;
    ctx.submit_and_wait(CONE_PREFILTER.name, |rec| pass.record(rec, &bindings, None))?;
    Ok(data)
}

/// Test helper: the chain of every CMO built on the GPU, one [`crate::cpu::cone::cone_prefilter`]
/// -shaped vector per CMO.
pub fn prefilter_gpu(
    ctx: &GpuContext,
    cubes: &[CubeMap],
    background: Vec3,
) -> VkResult<Vec<Vec<[f32; 4]>>> {
    let data = upload_with_cone(ctx, cubes, background)?;
    let len = mip_len(data.size());
    let cells: Vec<[f32; 4]> = ctx.read_buffer(data.cone().expect("allocated"))?;
    Ok((0..cubes.len())
        .map(|k| cells[k * len..(k + 1) * len].to_vec())
        .collect())
}

/// The tests' probe of the WGSL cone lookups (the `cone_probe` pass; `test-hooks` only).
#[cfg(feature = "test-hooks")]
mod probe {
    use super::*;
    use crate::vk::backend::shaders::CONE_PROBE;

    /// WGSL `ConeQuery` of the `cone_probe` pass.
    #[repr(C)]
    #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
    pub struct ConeQuery {
        /// CMO-local direction.
        pub dir: [f32; 3],
        /// Mode 0: the level; 1: the specular power; 2: tan of the half-angle.
        pub arg: f32,
        /// The CMO.
        pub k: u32,
        /// 0 `cone_cube_colour4`, 1 `cone_envmap_colour`, 2 `cone_footprint_level`.
        pub mode: u32,
        /// Padding.
        pub pad0: u32,
        /// Padding.
        pub pad1: u32,
    }

    /// WGSL `ConeProbeParams`.
    #[repr(C)]
    #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
    pub struct ConeProbeParams {
        /// Number of queries.
        pub count: u32,
        /// Padding.
        pub pad0: u32,
        /// Padding.
        pub pad1: u32,
        /// Padding.
        pub pad2: u32,
        /// The colour an empty texel stands for.
        pub background: [f32; 3],
        /// Padding.
        pub pad3: u32,
    }

    /// Test helper: evaluates `queries` with the WGSL lookups on `data` (made by
    /// [`upload_with_cone`]), one `vec4` per query.
    pub fn probe_gpu(
        ctx: &GpuContext,
        data: &CmoData,
        background: Vec3,
        queries: &[ConeQuery],
    ) -> VkResult<Vec<[f32; 4]>> {
        if queries.is_empty() {
            return Ok(Vec::new());
        }
        let pipeline = ComputePipeline::new(ctx, &CONE_PROBE, "main", ComputeOptions::default())?;
        let params = ConeProbeParams {
            count: queries.len() as u32,
            background: background.to_array(),
            ..Default::default()
        };
        let params_buf = ctx.create_buffer_init(
            "cone_probe params",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            std::slice::from_ref(&params),
        )?;
        let queries_buf = ctx.create_buffer_init(
            "cone_probe queries",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            queries,
        )?;
        let out = ctx.create_buffer_init(
            "cone_probe out",
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            &vec![[f32::NAN; 4]; queries.len()],
        )?;
        let set0 = pipeline.bind_group(
            0,
            &[
                (8, Resource::Buffer(&params_buf)),
                (9, Resource::Buffer(&queries_buf)),
                (10, Resource::Buffer(&out)),
            ],
        )?;
        let set1 = pipeline.bind_group(1, &data.resources_for(&CONE_PROBE, "main"))?;
        let groups = (queries.len() as u32).div_ceil(64);
        ctx.submit_and_wait(CONE_PROBE.name, |rec| {
            pipeline.dispatch(rec, &[&set0, &set1], [groups, 1, 1]);
            Ok(())
        })?;
        ctx.read_buffer(&out)
    }
}
#[cfg(feature = "test-hooks")]
pub use probe::{ConeProbeParams, ConeQuery, probe_gpu};

/// The cone stage of a glossy frame (fragment, compute): the 2x2 pyramid where the method has
/// none (compute: `cone_pyramid`, into a buffer of its own, with the CMO stages) and the `cone`
/// pass (after the trace, the reflector check and the fallback). The chain it reads is the
/// frame's `cone_prefilter` (`MethodSpec::glossy`). See `spirv/cone.wgsl` for what the
/// pass does; [`crate::cpu::cone::cone_pixel`] is its twin.
pub struct ConeStage {
    /// Compute's own pyramid: the pass, its bindings and its buffer (the sets hold the handle).
    pyramid: Option<(
        super::pyramid::Pyramid,
        super::pyramid::PyramidBindings,
        Buffer,
    )>,
    pipeline: ComputePipeline,
    sets: [BindGroup; 2],
    /// The glossy pixels (`glossy_pixels`), which `main` runs over.
    queue: super::pixel_queue::PixelQueue,
}

impl ConeStage {
    /// Creates the stage over `cmo` (which must have `cmo_colour` captured and `cmo_cone`
    /// allocated and filled by the frame's `cone_prefilter`). `own_pyramid`: build the 2x2
    /// pyramid here (the method builds none).
    pub fn new(
        ctx: &GpuContext,
        cmo: &CmoData,
        own_pyramid: bool,
        gbuffer: &super::gbuffer::Gbuffer,
        params: &Buffer,
        records: &Buffer,
    ) -> VkResult<ConeStage> {
        use crate::vk::backend::shaders::CONE;
        if cmo.cone().is_none() {
            return Err(VkError::Usage {
                what: CONE.name.into(),
                detail: "the CMO data has no `cmo_cone` (CmoData::alloc_cone)".into(),
            });
        }
        let pyramid = if own_pyramid {
            let cells = (u64::from(cmo.count()) * mip_len(cmo.size()) as u64).max(1);
            let buf = Buffer::new(
                ctx.device(),
                "cone pyramid",
                cells * 8,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?;
            let p = super::pyramid::Pyramid::new(ctx)?;
            let b = p.bind(ctx, cmo.distance(), &buf, cmo.count(), cmo.size())?;
            Some((p, b, buf))
        } else {
            None
        };
        let pipeline = ComputePipeline::new(ctx, &CONE, "main", ComputeOptions::default())?;
        let sampled = |img: &crate::vk::backend::image::Image| Resource::Texture {
            view: img.view(),
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        let queue = super::pixel_queue::PixelQueue::new(
            ctx,
            &CONE,
            "glossy_pixels",
            &[
                (0, sampled(&gbuffer.position)),
                (1, sampled(&gbuffer.normal)),
                (2, Resource::Buffer(params)),
            ],
            gbuffer.extent(),
        )?;
        let [q, h] = queue.resources();
        let set0 = pipeline.bind_group(
            0,
            &[
                (0, sampled(&gbuffer.position)),
                (1, sampled(&gbuffer.normal)),
                (2, Resource::Buffer(params)),
                (3, Resource::Buffer(records)),
                q,
                h,
            ],
        )?;
        let mut group1 = cmo.resources_for(&CONE, "main");
        if let Some((_, _, buf)) = &pyramid {
            for (b, r) in &mut group1 {
                if *b == 3 {
                    *r = Resource::Buffer(buf);
                }
            }
        }
        let set1 = pipeline.bind_group(1, &group1)?;
        Ok(ConeStage {
            pyramid,
            pipeline,
            sets: [set0, set1],
            queue,
        })
    }

    /// Whether the stage builds its own pyramid (compute), with the CMO stages.
    pub fn has_own_pyramid(&self) -> bool {
        self.pyramid.is_some()
    }

    /// Records the CMO part (after the capture): compute's own pyramid (the frame's scope
    /// `cone_pyramid`), with barriers around it; nothing for fragment.
    pub fn record_cmo_stage(&self, rec: &Recorder<'_>) -> VkResult<()> {
        use crate::vk::backend::sync::{SHADER_READ, SHADER_WRITE};
        if let Some((p, b, _)) = &self.pyramid {
            rec.memory_barrier(SHADER_WRITE, SHADER_READ);
            p.record(rec, b, None)?;
            rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        }
        Ok(())
    }

    /// Records the `cone` pass (after whatever last wrote the records): the glossy pixels
    /// queued (`glossy_pixels`), then `main` over them ([`super::pixel_queue`]).
    pub fn record(&self, rec: &Recorder<'_>) -> VkResult<()> {
        use crate::vk::backend::sync::{SHADER_WRITE, STORAGE_RW};
        rec.memory_barrier(SHADER_WRITE, STORAGE_RW);
        self.queue
            .record(rec, &self.pipeline, &[&self.sets[0], &self.sets[1]])
    }
}

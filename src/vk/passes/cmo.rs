//! The cubemap objects (CMOs) on the GPU: `@group(1)` of every tracing pass.
//!
//! | binding | WGSL name | contents | allocated |
//! |---|---|---|---|
//! | 0 | `trace_config` | [`TraceConfig`] (uniform) | always |
//! | 1 | `cmo_centres` | `vec4` per CMO (xyz centre) | always |
//! | 2 | `cmo_distance` | `6 N N` f32 per CMO, [`CubeMap`]'s layout, `+inf` where empty | always |
//! | 3 | `cmo_mip` | `mip_len(N)` `[min, max]` per CMO, `MipPyramid::flatten` | with a pyramid |
//! | 4 | `cmo_colour` | texture array, layer `6 k + face`: linear RGBA (alpha 0 where empty) | with [`CaptureContents::colour`]; else a 1x1-texel placeholder per layer |
//! | (none yet) | normal + mirror flag | `6 N N` RGBA per CMO | with self-reflections |
//! | 5 | `cmo_triangle` | `6 N N` u32 per CMO: global triangle index, `u32::MAX` where empty | with [`CaptureContents::triangle_ids`]; else a one-u32 placeholder (composite binds it; never read) |
//! | 6 to 9 | `cmo_list_head`, `_complete`, `_hi`, `_count` | `6 N N` u32 per CMO each: the words of `[head, complete_to, hi, count]` ([`super::lists`]) | with [`CmoData::alloc_lists`]; else one-word placeholders (`compute_trace` binds them; only its `_bounded` entry points read them) |
//! | 10 to 13 | `cmo_node_triangle`, `_lo`, `_hi`, `_next` | the lists' node pool, a u32 per node each ([`super::lists`]) | likewise |
//! | 15, 16 | `cmo_gap`, `cmo_gap_mip` | the lists' gaps, a packed word per texel (`6 N N` per CMO) and per cell of their pyramid (`mip_len(N)` per CMO, with a pyramid) ([`crate::cubemap::bounds::pack_gap`]) | with [`CmoData::alloc_lists`]; else one-word placeholders |
//! | 14 | `cmo_cone` | `mip_len(N)` vec4 per CMO: the pre-filtered colour chain ([`crate::cpu::cone`], `spirv/shared/cone.wgsl`) | with [`CmoData::alloc_cone`] (a glossy scene); else absent (only the cone passes use it) |
//!
//! The capture pass writes distance, colour and normals; the pyramid pass writes `cmo_mip`.
//! Colour is an image, not a buffer: it is only ever looked up per texel, and an image has no
//! `maxStorageBufferRange` (128 MiB on lavapipe, less than one 2048-texel RGBA32F capture).
//! Buffers larger than the device can bind are refused when bound ([`crate::vk::VkError::Limit`]).
//! Without a pyramid `cmo_mip` is a one-cell placeholder (a binding cannot be empty), and the
//! config says so: `mip_top = 0` makes the tracer read texels only.
//!
//! [`TraceConfig`] carries the tracer's options (`spirv/shared/trace.wgsl`, the GPU twin of
//! [`crate::cpu::options::trace_ray`]); the near-centre cut radius is computed on the GPU from
//! the data, never passed in.
use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;

use crate::cpu::options::{TraceCriterion, TraceOptions, TraceSampling};
use crate::cubemap::CubeMap;
use crate::cubemap::pyramid::{EMPTY_CELL, MipPyramid, mip_flat_layout};
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::image::{Image, ImageDesc};
use crate::vk::backend::pipeline::Resource;
use crate::vk::backend::shaders::Pass;
use crate::vk::backend::sync::{ALL_READS, SHADER_READ, TRANSFER_WRITE};

use super::lists::{self, PackedLists};

/// Binding of `cmo_cone` in `@group(1)` (`spirv/shared/cone.wgsl`).
pub const CONE_BINDING: u32 = 14;

/// Binding of `cmo_gap` in `@group(1)`, `cmo_gap_mip` the next (`spirv/shared/trace.wgsl`).
pub const GAP_BINDING: u32 = 15;

/// Entries of [`TraceConfig::mip_levels`] (index 0 unused: level 0 is the texels).
pub const TRACE_MIP_MAX_LEVELS: usize = 16;

/// Largest face size the GPU tracer accepts (its per-face step cap, `MAX_FACE_STEPS` in
/// `spirv/shared/trace.wgsl`, is provably not reached up to here).
pub const TRACE_MAX_SIZE: u32 = 4096;

/// Most sample steps of constant-step / constant-angle sampling (`MAX_SAMPLE_STEPS`).
pub const TRACE_MAX_STEPS: u32 = 65536;

/// WGSL `TraceConfig` (uniform, `@group(1) @binding(0)`). Layout checked against naga's in
/// `tests/tracer/gpu_twin.rs`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TraceConfig {
    /// Number of CMOs K.
    pub cmo_count: u32,
    /// Face size N.
    pub size: u32,
    /// 0 exact, 1 threshold, 2 sign change, 3 bounded.
    pub criterion: u32,
    /// 0 constant step, 1 constant angle, 2 per texel.
    pub sampling: u32,
    /// 0 per-texel walk, 1 mip march (centre criterion).
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
    /// 1: centre criterion with decisive patch hits only (`TraceOptions::strict`).
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
    /// [`TraceConfig::criterion`] of [`TraceCriterion::Bounded`] (WGSL `CRITERION_BOUNDED`).
    pub const CRITERION_BOUNDED: u32 = 3;

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
                TraceCriterion::Centre => 0,
                TraceCriterion::Threshold => 1,
                TraceCriterion::SignChange => 2,
                TraceCriterion::Bounded => Self::CRITERION_BOUNDED,
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

/// Whether `opts` select the centre criterion's mip march without `--strict`, the only method the
/// specialised entry points carry (`fs_exact_mip` of `fragment_trace`, `main_exact_mip` of
/// `trace_probe`; WGSL `TRACE_EXACT_MIP`). Every other option set needs the generic entry point.
pub fn exact_mip_only(opts: &TraceOptions) -> bool {
    opts.criterion == TraceCriterion::Centre && opts.accel && !opts.strict
}

/// What the capture stores per texel besides the distance (and, with self-reflections, the
/// normal). [`Default`] is the colour without IDs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CaptureContents {
    /// The shaded colour (16 B per texel): for methods that take a hit's colour from the texel
    /// (the environment map, the texel-colour tracers and the thesis's criteria).
    pub colour: bool,
    /// The global triangle index the texel's centre ray sees (4 B per texel, `u32::MAX` for
    /// none): for methods that verify hits against the triangles and shade at the hit.
    pub triangle_ids: bool,
}

impl Default for CaptureContents {
    fn default() -> Self {
        CaptureContents {
            colour: true,
            triangle_ids: false,
        }
    }
}

/// The GPU buffers of a scene's CMOs.
pub struct CmoData {
    count: u32,
    size: u32,
    centres: Vec<Vec3>,
    config: TraceConfig,
    config_buf: Buffer,
    centres_buf: Buffer,
    distance: Buffer,
    mip: Buffer,
    colour: Image,
    normal: Option<Buffer>,
    triangle: Option<Buffer>,
    /// `cmo_triangle` without triangle IDs: composite's environment-map fallback binds it, and
    /// a frame that captures no IDs (the environment-map method) never has an unresolved pixel.
    triangle_placeholder: Option<Buffer>,
    /// `cmo_cone` (binding 14): only for a glossy scene ([`CmoData::alloc_cone`]).
    cone: Option<Buffer>,
    contents: CaptureContents,
    /// The record and pool bindings, a word each ([`lists::RECORD_COLUMNS`],
    /// [`lists::NODE_COLUMNS`]; placeholders of one word until [`CmoData::alloc_lists`]), and
    /// the pool's capacity in nodes (0 for the placeholders).
    lists: [Buffer; 4],
    nodes: [Buffer; 4],
    pool_capacity: u64,
    /// The lists' gaps (bindings 15 and 16): a word per texel, and a word per cell of
    /// their pyramid where there is one; one-word placeholders without lists.
    gaps: [Buffer; 2],
}

/// Format of the colour capture: linear RGBA, f32 so that the CPU twins read the same bits.
pub const COLOUR_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// A device-local storage buffer that transfers can fill and read.
pub(super) fn storage(ctx: &GpuContext, name: &str, bytes: u64) -> VkResult<Buffer> {
    Buffer::new(
        ctx.device(),
        name,
        bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )
}

/// Four storage buffers of `words` u32 each, named `names` (the one-word bindings of the
/// The gap buffers: `texels` words and `cells` words of pyramid (at least one word each).
fn gap_buffers(ctx: &GpuContext, texels: u64, cells: u64) -> VkResult<[Buffer; 2]> {
    Ok([
        storage(ctx, "cmo_gap", texels.max(1) * 4)?,
        storage(ctx, "cmo_gap_mip", cells.max(1) * 4)?,
    ])
}

/// lists' records or pool, [`super::lists`]).
pub(super) fn column_buffers(
    ctx: &GpuContext,
    names: [&str; 4],
    words: u64,
) -> VkResult<[Buffer; 4]> {
    let [a, b, c, d] = names;
    let bytes = words.max(1) * lists::COLUMN_BYTES;
    Ok([
        storage(ctx, a, bytes)?,
        storage(ctx, b, bytes)?,
        storage(ctx, c, bytes)?,
        storage(ctx, d, bytes)?,
    ])
}

/// [`lists::check_range`] against the device's `maxStorageBufferRange` (`limit`), as a
/// [`VkError::Limit`].
pub(super) fn check_list_range(
    ctx: &GpuContext,
    texels: u64,
    nodes: u64,
    limit: u64,
) -> VkResult<()> {
    lists::check_range(texels, nodes, limit).map_err(|(what, limit)| VkError::Limit {
        device: ctx.report().name.clone(),
        what,
        limit,
    })
}

impl CmoData {
    /// Allocates (uninitialised) buffers for CMOs at `centres` with faces of `size` texels; the
    /// capture and pyramid passes fill them. Colour, no triangle IDs ([`CaptureContents`]'s
    /// default).
    pub fn new(
        ctx: &GpuContext,
        centres: &[Vec3],
        size: u32,
        self_reflections: bool,
        pyramid: bool,
        opts: &TraceOptions,
    ) -> VkResult<Self> {
        Self::with_contents(
            ctx,
            centres,
            size,
            self_reflections,
            pyramid,
            opts,
            CaptureContents::default(),
        )
    }

    /// [`Self::new`] with the per-texel contents chosen. Without colour, `cmo_colour` is a
    /// placeholder of one texel per layer (a binding cannot be missing), which the capture
    /// leaves readable and never writes; without colour the IDs are required (a capture of
    /// distances alone could not be shaded).
    pub fn with_contents(
        ctx: &GpuContext,
        centres: &[Vec3],
        size: u32,
        self_reflections: bool,
        pyramid: bool,
        opts: &TraceOptions,
        contents: CaptureContents,
    ) -> VkResult<Self> {
        if !contents.colour && !contents.triangle_ids {
            return Err(VkError::Usage {
                what: "CMO data".into(),
                detail: "neither colour nor triangle IDs captured: nothing to shade a hit with"
                    .into(),
            });
        }
        if centres.is_empty() || size == 0 {
            return Err(VkError::Usage {
                what: "CMO data".into(),
                detail: format!(
                    "{} CMOs of size {size}: need at least one CMO of size >= 1",
                    centres.len()
                ),
            });
        }
        let count = centres.len() as u32;
        let mut config = TraceConfig::new(count, size, opts)?;
        let texels = u64::from(count) * 6 * u64::from(size) * u64::from(size);
        let mip_cells = if pyramid {
            u64::from(count) * u64::from(config.mip_len)
        } else {
            config.mip_top = 0;
            1
        };
        let centres4: Vec<[f32; 4]> = centres.iter().map(|c| c.extend(0.0).to_array()).collect();
        let config_buf = ctx.create_buffer_init(
            "trace_config",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            std::slice::from_ref(&config),
        )?;
        Ok(CmoData {
            count,
            size,
            centres: centres.to_vec(),
            config,
            config_buf,
            centres_buf: ctx.create_buffer_init(
                "cmo_centres",
                vk::BufferUsageFlags::STORAGE_BUFFER,
                &centres4,
            )?,
            distance: storage(ctx, "cmo_distance", texels * 4)?,
            mip: storage(ctx, "cmo_mip", mip_cells.max(1) * 8)?,
            colour: Image::new(
                ctx.device(),
                ImageDesc {
                    name: "cmo_colour".into(),
                    format: COLOUR_FORMAT,
                    width: if contents.colour { size } else { 1 },
                    height: if contents.colour { size } else { 1 },
                    layers: 6 * count,
                    cube: false,
                    usage: vk::ImageUsageFlags::COLOR_ATTACHMENT
                        | vk::ImageUsageFlags::SAMPLED
                        | vk::ImageUsageFlags::TRANSFER_SRC
                        | vk::ImageUsageFlags::TRANSFER_DST,
                },
            )?,
            normal: if self_reflections {
                Some(storage(ctx, "cmo_normal", texels * 16)?)
            } else {
                None
            },
            triangle: if contents.triangle_ids {
                Some(storage(ctx, "cmo_triangle", texels * 4)?)
            } else {
                None
            },
            cone: None,
            triangle_placeholder: if contents.triangle_ids {
                None
            } else {
                Some(storage(ctx, "cmo_triangle placeholder", 4)?)
            },
            contents,
            lists: column_buffers(ctx, lists::RECORD_COLUMNS, 1)?,
            nodes: column_buffers(ctx, lists::NODE_COLUMNS, 1)?,
            pool_capacity: 0,
            gaps: gap_buffers(ctx, 1, 1)?,
        })
    }

    /// Allocates the `bounded` criterion's lists (uninitialised): a record per texel and a pool
    /// of `pool_capacity` nodes (at least 1: a binding cannot be empty), a binding per word.
    /// The GPU capture or [`CmoData::upload_lists`] fills them. Call before creating the passes
    /// that bind `@group(1)` (their bind groups name these buffers). Refused, before anything
    /// is allocated, where a binding would exceed the device's `maxStorageBufferRange`
    /// ([`lists::check_range`]).
    pub fn alloc_lists(&mut self, ctx: &GpuContext, pool_capacity: u64) -> VkResult<()> {
        let texels = u64::from(self.count) * 6 * u64::from(self.size) * u64::from(self.size);
        let capacity = pool_capacity.max(1);
        let limit = u64::from(ctx.report().max_storage_buffer_range);
        check_list_range(ctx, texels, capacity, limit)?;
        self.lists = column_buffers(ctx, lists::RECORD_COLUMNS, texels)?;
        self.nodes = column_buffers(ctx, lists::NODE_COLUMNS, capacity)?;
        self.pool_capacity = capacity;
        let cells = if self.config.mip_top > 0 {
            u64::from(self.count) * u64::from(self.config.mip_len)
        } else {
            1
        };
        self.gaps = gap_buffers(ctx, texels, cells)?;
        Ok(())
    }

    /// The lists' gaps: the texels' (binding 15) and their pyramid's (binding 16), a packed
    /// word per cell ([`crate::cubemap::bounds::pack_gap`]).
    pub fn gaps(&self) -> &[Buffer; 2] {
        &self.gaps
    }

    /// Allocates `cmo_cone` (binding 14, uninitialised), the pre-filtered colour chain of cone
    /// tracing that the `cone_prefilter` pass writes ([`crate::vk::passes::cone`]): `mip_len(N)`
    /// vec4 cells per CMO (one cell where N = 1, a binding cannot be empty). Only a glossy scene
    /// calls it; without it nothing new exists and binding 14 is not supplied. Refused past
    /// `maxStorageBufferRange`.
    pub fn alloc_cone(&mut self, ctx: &GpuContext) -> VkResult<()> {
        let cells = (u64::from(self.count) * u64::from(mip_len(self.size))).max(1);
        let bytes = cells * 16;
        let limit = u64::from(ctx.report().max_storage_buffer_range);
        if bytes > limit {
            return Err(VkError::Limit {
                device: ctx.report().name.clone(),
                what: format!(
                    "`cmo_cone` ({} CMOs of face size {}: {bytes} bytes of pre-filtered colour)",
                    self.count, self.size
                ),
                limit: format!("maxStorageBufferRange {limit} bytes"),
            });
        }
        self.cone = Some(storage(ctx, "cmo_cone", bytes)?);
        Ok(())
    }

    /// The pre-filtered colour chain (binding 14), where [`CmoData::alloc_cone`] made it.
    pub fn cone(&self) -> Option<&Buffer> {
        self.cone.as_ref()
    }

    /// Grows the `bounded` criterion's pool to `pool_capacity` nodes where it holds fewer (new
    /// buffers, uninitialised; a larger pool is kept: the capture reads its capacity from its
    /// params). Returns whether the pool's buffers are new: every bind group that names them
    /// must then be made again. Refused as [`CmoData::alloc_lists`] refuses.
    pub fn grow_pool(&mut self, ctx: &GpuContext, pool_capacity: u64) -> VkResult<bool> {
        let capacity = pool_capacity.max(1);
        if capacity <= self.pool_capacity {
            return Ok(false);
        }
        let texels = u64::from(self.count) * 6 * u64::from(self.size) * u64::from(self.size);
        let limit = u64::from(ctx.report().max_storage_buffer_range);
        check_list_range(ctx, texels, capacity, limit)?;
        self.nodes = column_buffers(ctx, lists::NODE_COLUMNS, capacity)?;
        log::debug!(
            "CMO list pool: {} -> {capacity} nodes (new buffers)",
            self.pool_capacity
        );
        self.pool_capacity = capacity;
        Ok(true)
    }

    /// Uploads lists in the GPU layout ([`lists::pack`] of one [`TexelLists`](crate::cubemap::bounds::TexelLists) per CMO, in CMO
    /// order, or built so): their `lo` into the distance buffer, the records and nodes into
    /// buffers allocated to fit ([`CmoData::alloc_lists`]). The pyramids are the pyramid
    /// passes' to build from the distances (or [`CmoData::upload`]'s on the CPU). Fails where
    /// the face size or the texel count is not the CMOs'.
    pub fn upload_lists(&mut self, ctx: &GpuContext, packed: &PackedLists) -> VkResult<()> {
        self.check_packed(packed)?;
        self.alloc_lists(ctx, packed.nodes.len() as u64)?;
        self.write_packed(ctx, packed)
    }

    /// [`CmoData::upload_lists`] into the lists already allocated, the pool grown where it
    /// holds fewer nodes ([`CmoData::grow_pool`]), in place of a capture: the buffers a
    /// capture writes, written whole but for the pool's nodes past `packed`'s, which no record
    /// names. Returns whether the pool's buffers are new (their bind groups must be made
    /// again).
    pub fn write_lists(&mut self, ctx: &GpuContext, packed: &PackedLists) -> VkResult<bool> {
        self.check_packed(packed)?;
        let grown = self.grow_pool(ctx, packed.nodes.len() as u64)?;
        self.write_packed(ctx, packed)?;
        Ok(grown)
    }

    /// Refuses `packed` where its face size or texel count is not the CMOs'.
    fn check_packed(&self, packed: &PackedLists) -> VkResult<()> {
        let texels = self.count as usize * 6 * self.size as usize * self.size as usize;
        if packed.size != self.size || packed.records.len() != texels || packed.lo.len() != texels {
            return Err(VkError::Usage {
                what: "CMO lists".into(),
                detail: format!(
                    "{} records of face size {} for {} CMOs of face size {} ({texels} texels)",
                    packed.records.len(),
                    packed.size,
                    self.count,
                    self.size
                ),
            });
        }
        Ok(())
    }

    /// Writes `packed` into the allocated lists (the pool holding its nodes).
    fn write_packed(&self, ctx: &GpuContext, packed: &PackedLists) -> VkResult<()> {
        ctx.write_buffer(&self.distance, &packed.lo)?;
        ctx.write_buffer(&self.gaps[0], &lists::packed_gaps(packed))?;
        for (b, c) in self.lists.iter().zip(lists::columns(&packed.records)) {
            ctx.write_buffer(b, &c)?;
        }
        for (b, c) in self.nodes.iter().zip(lists::columns(&packed.nodes)) {
            ctx.write_buffer(b, &c)?;
        }
        Ok(())
    }

    /// The records' bindings 6 to 9 ([`lists::RECORD_COLUMNS`]).
    pub fn lists(&self) -> &[Buffer; 4] {
        &self.lists
    }
    /// The pool's bindings 10 to 13 ([`lists::NODE_COLUMNS`]).
    pub fn nodes(&self) -> &[Buffer; 4] {
        &self.nodes
    }
    /// Nodes the pool holds (0: the placeholders, no lists allocated).
    pub fn pool_capacity(&self) -> u64 {
        self.pool_capacity
    }

    /// Records the contents of an empty capture without one: `+inf` distances, no triangle
    /// (`u32::MAX`), the colour image readable (its texels undefined: no method that reads
    /// colour goes without a capture). For data that passes bind but no capture fills.
    pub fn record_clear(&self, rec: &Recorder<'_>) {
        rec.fill_buffer(&self.distance, f32::INFINITY.to_bits());
        if let Some(t) = &self.triangle {
            rec.fill_buffer(t, u32::MAX);
        }
        rec.image_barrier(
            &self.colour,
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            TRANSFER_WRITE,
            SHADER_READ,
        );
        rec.memory_barrier(TRANSFER_WRITE, ALL_READS);
    }

    /// Uploads CPU captures (all of one face size), with their pyramids built on the CPU.
    pub fn upload(ctx: &GpuContext, cubes: &[CubeMap], opts: &TraceOptions) -> VkResult<Self> {
        let size = cubes.first().map_or(0, |c| c.size);
        if let Some(c) = cubes.iter().find(|c| c.size != size) {
            return Err(VkError::Usage {
                what: "CMO data".into(),
                detail: format!("CMOs of face sizes {size} and {} (all must match)", c.size),
            });
        }
        let centres: Vec<Vec3> = cubes.iter().map(|c| c.centre).collect();
        let data = CmoData::new(ctx, &centres, size, false, true, opts)?;
        let distance: Vec<f32> = cubes
            .iter()
            .flat_map(|c| c.distance.iter().copied())
            .collect();
        let colour: Vec<[f32; 4]> = cubes
            .iter()
            .flat_map(|c| c.colour.iter().copied())
            .collect();
        let mut mip: Vec<[f32; 2]> = cubes
            .iter()
            .flat_map(|c| MipPyramid::build(c).flatten())
            .collect();
        if mip.is_empty() {
            mip.push(EMPTY_CELL);
        }
        ctx.write_buffer(&data.distance, &distance)?;
        ctx.upload_image(
            &data.colour,
            bytemuck::cast_slice(&colour),
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        )?;
        ctx.write_buffer(&data.mip, &mip)?;
        Ok(data)
    }

    /// Replaces the tracer options (a new config uniform).
    pub fn set_options(&mut self, ctx: &GpuContext, opts: &TraceOptions) -> VkResult<()> {
        let mut config = TraceConfig::new(self.count, self.size, opts)?;
        config.mip_top = self.config.mip_top.min(config.mip_top);
        self.config_buf = ctx.create_buffer_init(
            "trace_config",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            std::slice::from_ref(&config),
        )?;
        self.config = config;
        Ok(())
    }

    /// Moves the CMOs to `centres` (as many as at creation): the centres' binding then holds
    /// what [`CmoData::with_contents`] for them would upload. The captures are stale until the
    /// capture runs again.
    pub fn set_centres(&mut self, ctx: &GpuContext, centres: &[Vec3]) -> VkResult<()> {
        if centres.len() != self.centres.len() {
            return Err(VkError::Usage {
                what: "CMO data".into(),
                detail: format!(
                    "{} centres for {} CMOs: the count is fixed at creation",
                    centres.len(),
                    self.centres.len()
                ),
            });
        }
        let centres4: Vec<[f32; 4]> = centres.iter().map(|c| c.extend(0.0).to_array()).collect();
        ctx.write_buffer(&self.centres_buf, &centres4)?;
        self.centres = centres.to_vec();
        Ok(())
    }

    /// The CMO centres.
    pub fn centres(&self) -> &[Vec3] {
        &self.centres
    }

    /// Number of CMOs.
    pub fn count(&self) -> u32 {
        self.count
    }
    /// Face size N.
    pub fn size(&self) -> u32 {
        self.size
    }
    /// The config in use.
    pub fn config(&self) -> &TraceConfig {
        &self.config
    }
    /// Distances (binding 2).
    pub fn distance(&self) -> &Buffer {
        &self.distance
    }
    /// Pyramid (binding 3).
    pub fn mip(&self) -> &Buffer {
        &self.mip
    }
    /// Colours (binding 4): layer `6 k + face` holds CMO `k`'s face.
    pub fn colour(&self) -> &Image {
        &self.colour
    }
    /// Normals and mirror flags (self-reflections only).
    pub fn normal(&self) -> Option<&Buffer> {
        self.normal.as_ref()
    }
    /// Triangle IDs ([`CaptureContents::triangle_ids`] only), [`CubeMap`]'s layout per CMO.
    pub fn triangle(&self) -> Option<&Buffer> {
        self.triangle.as_ref()
    }
    /// What the capture stores per texel.
    pub fn contents(&self) -> CaptureContents {
        self.contents
    }

    /// Bytes of GPU memory the CMO data takes.
    pub fn bytes(&self) -> u64 {
        let colour = self.colour.desc();
        [
            &self.config_buf,
            &self.centres_buf,
            &self.distance,
            &self.mip,
        ]
        .iter()
        .map(|b| b.size())
        .sum::<u64>()
            + self.normal.as_ref().map_or(0, |b| b.size())
            + self.triangle.as_ref().map_or(0, |b| b.size())
            + self.triangle_placeholder.as_ref().map_or(0, |b| b.size())
            + self.cone.as_ref().map_or(0, |b| b.size())
            + self
                .lists
                .iter()
                .chain(&self.nodes)
                .chain(&self.gaps)
                .map(Buffer::size)
                .sum::<u64>()
            + colour.layer_bytes().unwrap_or(0) * u64::from(colour.layers)
    }

    /// Every `@group(1)` resource by binding number (`cmo_triangle`: the placeholder where no
    /// IDs are captured).
    pub fn resources(&self) -> Vec<(u32, Resource<'_>)> {
        let mut r = vec![
            (0, Resource::Buffer(&self.config_buf)),
            (1, Resource::Buffer(&self.centres_buf)),
            (2, Resource::Buffer(&self.distance)),
            (3, Resource::Buffer(&self.mip)),
            (
                4,
                Resource::Texture {
                    view: self.colour.array_view(),
                    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                },
            ),
        ];
        if let Some(t) = self
            .triangle
            .as_ref()
            .or(self.triangle_placeholder.as_ref())
        {
            r.push((5, Resource::Buffer(t)));
        }
        for (i, b) in self.lists.iter().chain(&self.nodes).enumerate() {
            r.push((lists::FIRST_BINDING + i as u32, Resource::Buffer(b)));
        }
        if let Some(c) = &self.cone {
            r.push((CONE_BINDING, Resource::Buffer(c)));
        }
        r.push((GAP_BINDING, Resource::Buffer(&self.gaps[0])));
        r.push((GAP_BINDING + 1, Resource::Buffer(&self.gaps[1])));
        r
    }

    /// The `@group(1)` resources that entry point `entry` of `pass` uses (a bind group may not
    /// supply a binding its shader does not use).
    pub fn resources_for(&self, pass: &Pass, entry: &str) -> Vec<(u32, Resource<'_>)> {
        let used = pass.entry_point(entry).map_or(&[][..], |e| e.bindings);
        self.resources()
            .into_iter()
            .filter(|(b, _)| used.iter().any(|u| u.group == 1 && u.binding == *b))
            .collect()
    }

    /// Reads the captures back as CPU cube maps (for the CPU twins and the tests). Contents
    /// that were not captured stay as [`CubeMap::new`] leaves them.
    pub fn read_back(&self, ctx: &GpuContext) -> VkResult<Vec<CubeMap>> {
        let distance: Vec<f32> = ctx.read_buffer(&self.distance)?;
        let colour: Vec<[f32; 4]> = if self.contents.colour {
            let bytes = ctx.read_image(&self.colour, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)?;
            bytemuck::pod_collect_to_vec(&bytes)
        } else {
            Vec::new()
        };
        let triangle: Vec<u32> = match &self.triangle {
            Some(b) => ctx.read_buffer(b)?,
            None => Vec::new(),
        };
        let per = 6 * self.size as usize * self.size as usize;
        Ok(self
            .centres
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let mut cube = CubeMap::new(self.size, *c);
                cube.distance
                    .copy_from_slice(&distance[k * per..(k + 1) * per]);
                if self.contents.colour {
                    cube.colour.copy_from_slice(&colour[k * per..(k + 1) * per]);
                }
                if !triangle.is_empty() {
                    cube.triangle
                        .copy_from_slice(&triangle[k * per..(k + 1) * per]);
                }
                cube
            })
            .collect())
    }

    /// The pyramid as the GPU built it (`mip_len(N)` cells per CMO; empty without a pyramid).
    pub fn read_mip(&self, ctx: &GpuContext) -> VkResult<Vec<[f32; 2]>> {
        if self.config.mip_top == 0 {
            return Ok(Vec::new());
        }
        let mut mip: Vec<[f32; 2]> = ctx.read_buffer(&self.mip)?;
        mip.truncate(self.count as usize * self.config.mip_len as usize);
        Ok(mip)
    }
}

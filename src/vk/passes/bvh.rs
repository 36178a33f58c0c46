//! Exact GPU ray tracing over a compressed wide BVH (`--method bvh`, `--fallback trace`): the
//! reusable pass that traces any queue of rays into the frame's
//! [`PixelRecord`](crate::vk::frame::PixelRecord)s.
//!
//! | pass | reads | writes |
//! |---|---|---|
//! | `bvh_queue` (`append_mirror`) | G-buffer (+ its triangle IDs) | one [`BvhRay`] per mirror pixel, from t = 0 |
//! | `bvh_queue` (`append_unresolved`) | G-buffer, records | one [`BvhRay`] per unresolved mirror pixel, from t = 0 (why not from `t_done`: spirv/bvh_queue.wgsl) |
//! | `bvh_queue` (`append_check`) | G-buffer, records | one [`BvhRay`] per mirror pixel whose record is a hit or escaped, flagged [`RAY_CHECK`], from t = 0 ([`ReflectorCheck`]) |
//! | `bvh_queue` (`args`) | [`BvhCounter`] | the indirect dispatch of `bvh_trace` |
//! | `bvh_trace` | queue, CWBVH, scene | `records[ray.pixel]` |
//!
//! Contract of [`BvhTracer`] (what a producer of rays must do; the bounce rounds,
//! [`super::bounce`], reuse it with queues of their own: [`BvhTracer::queue_set`]):
//! - A queue is a [`BvhQueue`]: a buffer of [`BvhRay`] (capacity fixed at creation), a
//!   [`BvhCounter`] whose `count` the producer increments atomically (`atomicAdd`) for each ray
//!   it writes at that index, and an indirect dispatch. Record, in order:
//!   [`BvhQueue::record_clear`] (zeroes the counter), the producer's pass(es),
//!   [`BvhQueue::record_args`] (a barrier, then `bvh_queue::args` sizes the dispatch from the
//!   count on the GPU), [`BvhTracer::record_trace`] (a barrier, then the indirect dispatch).
//! - A ray carries its world origin, unit direction, the pixel whose record it writes, its start
//!   distance `t_min` (hits at `t < t_min` are not taken), the triangle it leaves
//!   (`from_triangle`, [`NO_TRIANGLE`] for none: the start rule below), its `bounce` (the
//!   reflections before it: the record's `bounces` is `bounce` + 1, and a ray with `bounce` > 0
//!   keeps the record's `fallback` and `checked` flags) and `flags` ([`RAY_FALLBACK`]: write only the result fields of the
//!   record and set its `fallback` flag; [`RAY_CHECK`]: the same with the `checked` flag, and
//!   only for a hit strictly nearer than the record's `t`, any hit when it escaped, on another
//!   triangle than the record's, else nothing; otherwise the whole record).
//! - Each pixel must appear at most once per queue (two rays of one pixel would race on its
//!   record). The tracer writes records only; colour composition is the composite pass's.
//! - Result: the nearest hit with `t > 0`, `t >= t_min`, under the start rule, over the
//!   scene's triangles (ties: the lower global triangle index); its point `origin + t dir`, the
//!   global triangle and the colour shaded there (`hit_shade`, the reference's shading: a
//!   reflector hit shows its own material); no hit is `RECORD_ESCAPED` (background colour,
//!   point at `t_hi`); a ray whose traversal loop reached its cap is `RECORD_UNRESOLVED` with
//!   `cut` = 1, counted in [`BvhCounter::cut`] (none seen on the built-in scenes).
//! - The start rule (spirv/shared/bvh.wgsl has the derivation): a ray ignores hits on
//!   `from_triangle` and on its neighbours (a corner at a bit-identical position) whose plane
//!   passes within `e = 2 |s_F(o)| + 2^-18 max|coordinates|` of the origin, `s_F(o)` the
//!   origin's distance from `from_triangle`'s plane, or within `r = e + 2 x_F(o)` with the hit
//!   within `r` of the origin too, `x_F(o)` how far it lies past the triangle's farthest edge
//!   line (0 inside): the GPU analogue of
//!   [`Tracer::nearest`](crate::reference::Tracer::nearest)'s rule, with the G-buffer's
//!   interpolated position for the reference's f32 hit point.
//!
//! The BVH is built on the CPU by `obvhs` ([`BvhData::build`]: PLOC, reinsertion, collapsed to
//! 8-wide nodes of 80 bytes, up to 3 triangles per leaf, no spatial splits) over the triangles
//! of [`GpuSceneData`] (the positions the G-buffer and the capture draw, so the start rule's
//! corner comparison is exact), and allocated only when a method or the fallback uses it.
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec3A};
use gpu_allocator::MemoryLocation;
use obvhs::aabb::Aabb;

use super::gbuffer::Gbuffer;
use super::scene_buffers::SceneBuffers;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::VkResult;
use crate::vk::backend::pipeline::{BindGroup, ComputeOptions, ComputePipeline, Resource};
use crate::vk::backend::shaders::{BVH_QUEUE, BVH_TRACE};
use crate::vk::backend::sync::{INDIRECT_READ, SHADER_WRITE, STORAGE_RW, TRANSFER_WRITE};

/// `BVH_NO_TRIANGLE`: no triangle (a ray that leaves none, a record without a hit).
pub const NO_TRIANGLE: u32 = u32::MAX;
/// `BVH_RAY_FALLBACK` in [`BvhRay::flags`].
pub const RAY_FALLBACK: u32 = 1;
/// `BVH_RAY_CHECK` in [`BvhRay::flags`]: the reflector check's ray ([`ReflectorCheck`]).
pub const RAY_CHECK: u32 = 2;
/// Rays per `bvh_trace` (and `bvh_queue` append) workgroup.
pub const GROUP_SIZE: u32 = 64;

/// WGSL `BvhRay` (spirv/shared/bvh_rays.wgsl): one queued ray.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhRay {
    pub origin: [f32; 3],
    /// `j * width + i`: the record the result goes to.
    pub pixel: u32,
    /// Unit direction.
    pub dir: [f32; 3],
    /// Hits at `t < t_min` are not taken.
    pub t_min: f32,
    /// The triangle the ray leaves (start rule), [`NO_TRIANGLE`] for none.
    pub from_triangle: u32,
    /// Reflections taken before this ray (the record gets `bounce` + 1 as its `bounces`).
    pub bounce: u32,
    /// [`RAY_FALLBACK`], [`RAY_CHECK`] or 0.
    pub flags: u32,
    pub pad0: u32,
}

/// WGSL `BvhCounter`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct BvhCounter {
    /// Rays appended.
    pub count: u32,
    /// Rays whose traversal reached the loop cap (left unresolved, `cut` = 1).
    pub cut: u32,
    pub pad0: u32,
    pub pad1: u32,
}

/// WGSL `BvhParams` (spirv/shared/bvh.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhParams {
    /// Nodes uploaded (0: an empty scene).
    pub node_count: u32,
    /// Length of an escaped ray (its record's point).
    pub t_hi: f32,
    pub pad0: u32,
    pub pad1: u32,
}

/// The CWBVH in the layout `bvh_trace` reads: 5 `vec4<u32>` per node (the bytes of obvhs's
/// `CwBvhNode`), 3 `vec4<f32>` per primitive slot (the corners; `.w` of the first is the bits of
/// the global triangle index).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BvhData {
    pub nodes: Vec<[u32; 4]>,
    pub tris: Vec<[f32; 4]>,
}

struct Tri([Vec3; 3]);

impl obvhs::Boundable for Tri {
    fn aabb(&self) -> Aabb {
        let [a, b, c] = self.0;
        Aabb::new(Vec3A::from(a.min(b).min(c)), Vec3A::from(a.max(b).max(c)))
    }
}

impl BvhData {
    /// Builds the CWBVH over every triangle of `data` (single-threaded and deterministic).
    pub fn build(data: &GpuSceneData) -> Self {
        let all: Vec<u32> = (0..(data.indices.len() / 3) as u32).collect();
        Self::build_subset(data, &all)
    }

    /// Builds the CWBVH over the triangles `ids` of `data` only (global indices, kept in the
    /// primitive slots: hits, records and shading name the scene's triangle); the reflector
    /// check's BVH ([`ReflectorCheck`]).
    pub fn build_subset(data: &GpuSceneData, ids: &[u32]) -> Self {
        let corner = |i: u32| Vec3::from_array(data.vertices[i as usize].position);
        let tris: Vec<Tri> = ids
            .iter()
            .map(|&k| {
                let t = &data.indices[3 * k as usize..3 * k as usize + 3];
                Tri([corner(t[0]), corner(t[1]), corner(t[2])])
            })
            .collect();
        if tris.is_empty() {
            return BvhData::default();
        }
        let mut time = std::time::Duration::ZERO;
        let start = std::time::Instant::now();
        let bvh = obvhs::cwbvh::builder::build_cwbvh(
            &tris,
            obvhs::BvhBuildParams::medium_build(),
            &mut time,
        );
        log::info!(
            "CWBVH: {} triangles, {} nodes, built in {:.2?} on the CPU",
            tris.len(),
            bvh.nodes.len(),
            start.elapsed()
        );
        let nodes = bvh
            .nodes
            .iter()
            .flat_map(|n| {
                let w: &[u32] = bytemuck::cast_slice(std::slice::from_ref(n));
                [
                    [w[0], w[1], w[2], w[3]],
                    [w[4], w[5], w[6], w[7]],
                    [w[8], w[9], w[10], w[11]],
                    [w[12], w[13], w[14], w[15]],
                    [w[16], w[17], w[18], w[19]],
                ]
            })
            .collect();
        let tris = bvh
            .primitive_indices
            .iter()
            .flat_map(|&k| {
                let [a, b, c] = tris[k as usize].0;
                [
                    [a.x, a.y, a.z, f32::from_bits(ids[k as usize])],
                    [b.x, b.y, b.z, 0.0],
                    [c.x, c.y, c.z, 0.0],
                ]
            })
            .collect();
        BvhData { nodes, tris }
    }

    /// Number of nodes.
    pub fn node_count(&self) -> u32 {
        (self.nodes.len() / 5) as u32
    }
}

/// What [`BvhTracer`]'s buffers hold of `bvh`: its nodes and triangles, or one zero entry for
/// an empty one (a zero-sized storage buffer cannot be bound).
fn bvh_contents(bvh: &BvhData) -> (&[[u32; 4]], &[[f32; 4]]) {
    let nodes: &[[u32; 4]] = if bvh.nodes.is_empty() {
        &[[0; 4]]
    } else {
        &bvh.nodes
    };
    let tris: &[[f32; 4]] = if bvh.tris.is_empty() {
        &[[0.0; 4]]
    } else {
        &bvh.tris
    };
    (nodes, tris)
}

/// `bvh_trace`'s BVH group (set 1): the nodes, the triangles and the params.
fn bvh_set(
    pipeline: &ComputePipeline,
    nodes: &Buffer,
    tris: &Buffer,
    params: &Buffer,
) -> VkResult<BindGroup> {
    pipeline.bind_group(
        1,
        &[
            (0, Resource::Buffer(nodes)),
            (1, Resource::Buffer(tris)),
            (2, Resource::Buffer(params)),
        ],
    )
}

/// Workgroups of a one-invocation-per-pixel `bvh_queue` append: `ceil(pixels / 64)` as
/// `x <= 65535` by `y`.
pub fn pixel_groups(width: u32, height: u32) -> [u32; 3] {
    let g = (u64::from(width) * u64::from(height)).div_ceil(u64::from(GROUP_SIZE));
    let x = g.clamp(1, 65535);
    [x as u32, g.div_ceil(x).max(1) as u32, 1]
}

/// A queue of [`BvhRay`]s with its counter and indirect dispatch (see the module docs).
pub struct BvhQueue {
    rays: Buffer,
    counter: Buffer,
    dispatch: Buffer,
    args: ComputePipeline,
    args_set: BindGroup,
}

impl BvhQueue {
    /// A queue for up to `capacity` rays.
    pub fn new(ctx: &GpuContext, capacity: u64) -> VkResult<Self> {
        let storage = |name: &str, bytes: u64, extra: vk::BufferUsageFlags| {
            Buffer::new(
                ctx.device(),
                name,
                bytes.max(16),
                vk::BufferUsageFlags::STORAGE_BUFFER | extra,
                MemoryLocation::GpuOnly,
            )
        };
        let rays = storage(
            "bvh ray queue",
            capacity * size_of::<BvhRay>() as u64,
            // TRANSFER_DST: a producer may also be the host (`GpuContext::write_buffer`).
            vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST,
        )?;
        let counter = storage(
            "bvh ray counter",
            size_of::<BvhCounter>() as u64,
            vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC,
        )?;
        let dispatch = storage(
            "bvh_trace dispatch",
            12,
            vk::BufferUsageFlags::INDIRECT_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        )?;
        let args = ComputePipeline::new(ctx, &BVH_QUEUE, "args", ComputeOptions::default())?;
        let args_set = args.bind_group(
            2,
            &[
                (0, Resource::Buffer(&counter)),
                (2, Resource::Buffer(&dispatch)),
            ],
        )?;
        Ok(BvhQueue {
            rays,
            counter,
            dispatch,
            args,
            args_set,
        })
    }

    /// The ray buffer (a producer binds it read-write).
    pub fn rays(&self) -> &Buffer {
        &self.rays
    }

    /// The counter (a producer binds it read-write).
    pub fn counter(&self) -> &Buffer {
        &self.counter
    }

    /// The indirect dispatch `args` writes (`bvh_trace`'s; a pass over the queue's rays with
    /// 64-wide workgroups may reuse it, as the bounce rounds do).
    pub fn dispatch(&self) -> &Buffer {
        &self.dispatch
    }

    /// Zeroes the counter (before the producers).
    pub fn record_clear(&self, rec: &Recorder<'_>) {
        rec.fill_buffer(&self.counter, 0);
        rec.memory_barrier(TRANSFER_WRITE, STORAGE_RW);
    }

    /// After the producers: sizes the indirect dispatch from the count.
    pub fn record_args(&self, rec: &Recorder<'_>) {
        rec.memory_barrier(SHADER_WRITE, STORAGE_RW);
        // Groups 0 and 1 of `args` are empty: only group 2 is bound, as the pipeline's set 2.
        self.args.dispatch(rec, &[&self.args_set], [1, 1, 1]);
    }

    /// The counter of the last frame.
    pub fn read_counter(&self, ctx: &GpuContext) -> VkResult<BvhCounter> {
        let c: Vec<BvhCounter> = ctx.read_buffer(&self.counter)?;
        Ok(c.first().copied().unwrap_or_default())
    }

    /// The rays of the last frame (tests): the first `count`.
    pub fn read_rays(&self, ctx: &GpuContext) -> VkResult<Vec<BvhRay>> {
        let n = self.read_counter(ctx)?.count as usize;
        let mut rays: Vec<BvhRay> = ctx.read_buffer(&self.rays)?;
        rays.truncate(n);
        Ok(rays)
    }
}

/// Which rays a [`BvhAppend`] queues.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AppendKind {
    /// Every mirror pixel's reflected ray from t = 0 (`append_mirror`: `--method bvh`).
    Mirror,
    /// Every mirror pixel whose record is unresolved, from t = 0 under the start rule
    /// (`append_unresolved`: `--fallback trace`).
    Unresolved,
    /// The same rays from their `t_done` (`append_unresolved_from_t_done`): misses hits before
    /// `t_done` that the cubemap's model does not see (spirv/bvh_queue.wgsl); for the tests.
    UnresolvedFromTDone,
    /// Every mirror pixel whose record is a hit or escaped, flagged [`RAY_CHECK`], from t = 0
    /// under the start rule (`append_check`: the reflector check, [`ReflectorCheck`]).
    Check,
}

/// A `bvh_queue` append pass over the frame's G-buffer (and records).
pub struct BvhAppend {
    pipeline: ComputePipeline,
    sets: [BindGroup; 3],
    groups: [u32; 3],
}

impl BvhAppend {
    /// `params` is the frame's `FrameParams` buffer, `records` its records.
    pub fn new(
        ctx: &GpuContext,
        kind: AppendKind,
        gbuffer: &Gbuffer,
        params: &Buffer,
        records: &Buffer,
        queue: &BvhQueue,
    ) -> VkResult<Self> {
        let entry = match kind {
            AppendKind::Mirror => "append_mirror",
            AppendKind::Unresolved => "append_unresolved",
            AppendKind::UnresolvedFromTDone => "append_unresolved_from_t_done",
            AppendKind::Check => "append_check",
        };
        let pipeline = ComputePipeline::new(ctx, &BVH_QUEUE, entry, ComputeOptions::default())?;
        let sampled = |img: &crate::vk::backend::image::Image| Resource::Texture {
            view: img.view(),
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        // The entry's own bindings: the mirror rays read the normal, the unresolved ones the
        // records, the check both.
        let frame = match kind {
            AppendKind::Mirror => vec![
                (0, sampled(&gbuffer.position)),
                (1, sampled(&gbuffer.normal)),
                (2, Resource::Buffer(params)),
                (8, sampled(&gbuffer.triangle)),
            ],
            AppendKind::Unresolved | AppendKind::UnresolvedFromTDone => vec![
                (0, sampled(&gbuffer.position)),
                (2, Resource::Buffer(params)),
                (3, Resource::Buffer(records)),
                (8, sampled(&gbuffer.triangle)),
            ],
            AppendKind::Check => vec![
                (0, sampled(&gbuffer.position)),
                (1, sampled(&gbuffer.normal)),
                (2, Resource::Buffer(params)),
                (3, Resource::Buffer(records)),
                (8, sampled(&gbuffer.triangle)),
            ],
        };
        let sets = [
            pipeline.bind_group(0, &frame)?,
            pipeline.bind_group(1, &[])?,
            pipeline.bind_group(
                2,
                &[
                    (0, Resource::Buffer(&queue.counter)),
                    (1, Resource::Buffer(&queue.rays)),
                ],
            )?,
        ];
        let (width, height) = gbuffer.extent();
        Ok(BvhAppend {
            pipeline,
            sets,
            groups: pixel_groups(width, height),
        })
    }

    /// Records the append (after the queue's clear and whatever wrote the records).
    pub fn record(&self, rec: &Recorder<'_>) {
        rec.memory_barrier(SHADER_WRITE, STORAGE_RW);
        let sets = [&self.sets[0], &self.sets[1], &self.sets[2]];
        self.pipeline.dispatch(rec, &sets, self.groups);
    }
}

/// An append per ray of a bounce round's queue into a [`BvhPasses`]' queue, for the rounds of
/// `--bounces` that a cubemap method traces ([`super::bounce`]): `append_unresolved_queued`
/// (the fallback's rays) or `append_check_queued` (the reflector check's), each ray of the
/// round leaving its own triangle and keeping its `bounce`.
pub struct QueuedAppend {
    pipeline: ComputePipeline,
    sets: [BindGroup; 2],
    /// Group 2 for each round queue the append reads (and the output queue).
    queue_sets: Vec<BindGroup>,
}

impl QueuedAppend {
    /// `check`: the reflector check's rays, else the fallback's; into `out`, reading the rays of
    /// one of `inputs` and their records in `records`.
    pub fn new(
        ctx: &GpuContext,
        check: bool,
        records: &Buffer,
        out: &BvhQueue,
        inputs: &[&BvhQueue],
    ) -> VkResult<Self> {
        let entry = if check {
            "append_check_queued"
        } else {
            "append_unresolved_queued"
        };
        let pipeline = ComputePipeline::new(ctx, &BVH_QUEUE, entry, ComputeOptions::default())?;
        let sets = [
            pipeline.bind_group(0, &[(3, Resource::Buffer(records))])?,
            pipeline.bind_group(1, &[])?,
        ];
        let queue_sets = (inputs.iter())
            .map(|q| {
                pipeline.bind_group(
                    2,
                    &[
                        (0, Resource::Buffer(&out.counter)),
                        (1, Resource::Buffer(&out.rays)),
                        (3, Resource::Buffer(&q.counter)),
                        (4, Resource::Buffer(&q.rays)),
                    ],
                )
            })
            .collect::<VkResult<Vec<_>>>()?;
        Ok(QueuedAppend {
            pipeline,
            sets,
            queue_sets,
        })
    }

    /// The append over `inputs[k]` of [`QueuedAppend::new`] (`input`, its dispatch sized by
    /// [`BvhQueue::record_args`]), after the output queue's clear and the records' writer.
    pub fn record(&self, rec: &Recorder<'_>, k: usize, input: &BvhQueue) -> VkResult<()> {
        rec.memory_barrier(SHADER_WRITE, STORAGE_RW);
        rec.memory_barrier(SHADER_WRITE, INDIRECT_READ);
        let sets = [&self.sets[0], &self.sets[1], &self.queue_sets[k]];
        self.pipeline
            .dispatch_indirect(rec, &sets, &input.dispatch, 0)
    }
}

/// The uploaded CWBVH and the `bvh_trace` pipeline, bound to one record buffer and one queue.
pub struct BvhTracer {
    node_count: u32,
    nodes: Buffer,
    tris: Buffer,
    params_buf: Buffer,
    pipeline: ComputePipeline,
    sets: [BindGroup; 4],
}

impl BvhTracer {
    /// Builds the BVH over `data`'s triangles, uploads it, and binds `bvh_trace` to `records`,
    /// `queue` and the scene. `t_hi` is the length of an escaped ray.
    pub fn new(
        ctx: &GpuContext,
        data: &GpuSceneData,
        scene: &SceneBuffers,
        records: &Buffer,
        queue: &BvhQueue,
        t_hi: f32,
    ) -> VkResult<Self> {
        let bvh = BvhData::build(data);
        Self::with_data(ctx, &bvh, scene, records, queue, t_hi)
    }

    /// [`BvhTracer::new`] over a given BVH (tests: a perturbed one must fail the comparisons).
    pub fn with_data(
        ctx: &GpuContext,
        bvh: &BvhData,
        scene: &SceneBuffers,
        records: &Buffer,
        queue: &BvhQueue,
        t_hi: f32,
    ) -> VkResult<Self> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let (nodes, tris) = bvh_contents(bvh);
        let nodes_buf = ctx.create_buffer_init("bvh nodes", usage, nodes)?;
        let tris_buf = ctx.create_buffer_init("bvh triangles", usage, tris)?;
        let params = BvhParams {
            node_count: bvh.node_count(),
            t_hi,
            ..BvhParams::default()
        };
        let params_buf =
            ctx.create_buffer_init("bvh params", usage, std::slice::from_ref(&params))?;
        let pipeline = ComputePipeline::new(ctx, &BVH_TRACE, "main", ComputeOptions::default())?;
        let sets = [
            pipeline.bind_group(0, &[(3, Resource::Buffer(records))])?,
            bvh_set(&pipeline, &nodes_buf, &tris_buf, &params_buf)?,
            pipeline.bind_group(
                2,
                &[
                    (0, Resource::Buffer(&queue.counter)),
                    (1, Resource::Buffer(&queue.rays)),
                ],
            )?,
            pipeline.bind_group(3, &scene.resources())?,
        ];
        Ok(BvhTracer {
            node_count: params.node_count,
            nodes: nodes_buf,
            tris: tris_buf,
            params_buf,
            pipeline,
            sets,
        })
    }

    /// Nodes of the uploaded BVH.
    pub fn node_count(&self) -> u32 {
        self.node_count
    }

    /// Uploads `bvh` (the scene's geometry moved) and the ray length `t_hi` into the tracer's
    /// buffers: the next trace is that of [`BvhTracer::with_data`] over them. A BVH that fits
    /// the buffers is written into them (the trace reads `node_count` nodes, never the buffer
    /// lengths); a larger one gets new buffers, and the tracer's BVH group is bound to them.
    /// The pipeline and the other groups stay.
    pub fn update(&mut self, ctx: &GpuContext, bvh: &BvhData, t_hi: f32) -> VkResult<()> {
        let (nodes, tris) = bvh_contents(bvh);
        let fits = |b: &Buffer, bytes: usize| bytes as u64 <= b.size();
        if fits(&self.nodes, size_of_val(nodes)) && fits(&self.tris, size_of_val(tris)) {
            ctx.write_buffer(&self.nodes, nodes)?;
            ctx.write_buffer(&self.tris, tris)?;
        } else {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            let nodes_buf = ctx.create_buffer_init("bvh nodes", usage, nodes)?;
            let tris_buf = ctx.create_buffer_init("bvh triangles", usage, tris)?;
            self.sets[1] = bvh_set(&self.pipeline, &nodes_buf, &tris_buf, &self.params_buf)?;
            log::debug!(
                "bvh_trace: the BVH outgrew its buffers ({} nodes): new buffers",
                bvh.node_count()
            );
            (self.nodes, self.tris) = (nodes_buf, tris_buf);
        }
        let params = BvhParams {
            node_count: bvh.node_count(),
            t_hi,
            ..BvhParams::default()
        };
        ctx.write_buffer(&self.params_buf, std::slice::from_ref(&params))?;
        self.node_count = params.node_count;
        Ok(())
    }

    /// The indirect dispatch over `queue` (after [`BvhQueue::record_args`]).
    pub fn record_trace(&self, rec: &Recorder<'_>, queue: &BvhQueue) -> VkResult<()> {
        self.record_trace_with(rec, queue, &self.sets[2])
    }

    /// The queue group (set 2) of `bvh_trace` for another queue than the one the tracer was
    /// made with: one BVH traces several queues (the bounce rounds, [`super::bounce`]).
    pub fn queue_set(&self, queue: &BvhQueue) -> VkResult<BindGroup> {
        self.pipeline.bind_group(
            2,
            &[
                (0, Resource::Buffer(&queue.counter)),
                (1, Resource::Buffer(&queue.rays)),
            ],
        )
    }

    /// [`BvhTracer::record_trace`] over `queue` bound as `queue_set` ([`BvhTracer::queue_set`]).
    pub fn record_trace_with(
        &self,
        rec: &Recorder<'_>,
        queue: &BvhQueue,
        queue_set: &BindGroup,
    ) -> VkResult<()> {
        rec.memory_barrier(SHADER_WRITE, INDIRECT_READ);
        let sets = [&self.sets[0], &self.sets[1], queue_set, &self.sets[3]];
        self.pipeline
            .dispatch_indirect(rec, &sets, &queue.dispatch, 0)
    }
}

/// One queue with one producer and the tracer: `--method bvh` ([`AppendKind::Mirror`]) or
/// `--fallback trace` ([`AppendKind::Unresolved`]) in a frame.
pub struct BvhPasses {
    pub queue: BvhQueue,
    pub append: BvhAppend,
    pub tracer: BvhTracer,
}

impl BvhPasses {
    /// Builds the BVH over `data` and the passes for the frame's G-buffer, `FrameParams` buffer
    /// `params` and `records`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        kind: AppendKind,
        data: &GpuSceneData,
        scene: &SceneBuffers,
        gbuffer: &Gbuffer,
        params: &Buffer,
        records: &Buffer,
        t_hi: f32,
    ) -> VkResult<Self> {
        let bvh = BvhData::build(data);
        Self::with_bvh(ctx, kind, &bvh, scene, gbuffer, params, records, t_hi)
    }

    /// [`BvhPasses::new`] over a given BVH.
    #[allow(clippy::too_many_arguments)]
    pub fn with_bvh(
        ctx: &GpuContext,
        kind: AppendKind,
        bvh: &BvhData,
        scene: &SceneBuffers,
        gbuffer: &Gbuffer,
        params: &Buffer,
        records: &Buffer,
        t_hi: f32,
    ) -> VkResult<Self> {
        let (w, h) = gbuffer.extent();
        let queue = BvhQueue::new(ctx, u64::from(w) * u64::from(h))?;
        let append = BvhAppend::new(ctx, kind, gbuffer, params, records, &queue)?;
        let tracer = BvhTracer::with_data(ctx, bvh, scene, records, &queue, t_hi)?;
        Ok(BvhPasses {
            queue,
            append,
            tracer,
        })
    }

    /// Rebuilds the BVH over `data` (the scene's geometry moved, its triangles the same) and
    /// uploads it with the ray length `t_hi` ([`BvhTracer::update`]).
    pub fn update(&mut self, ctx: &GpuContext, data: &GpuSceneData, t_hi: f32) -> VkResult<()> {
        self.tracer.update(ctx, &BvhData::build(data), t_hi)
    }

    /// Clear, append, size the dispatch (`bvh_queue`).
    pub fn record_queue(&self, rec: &Recorder<'_>) {
        self.queue.record_clear(rec);
        self.append.record(rec);
        self.queue.record_args(rec);
    }

    /// The trace (`bvh_trace`).
    pub fn record_trace(&self, rec: &Recorder<'_>) -> VkResult<()> {
        self.tracer.record_trace(rec, &self.queue)
    }
}

/// The reflector check (`--no-reflector-check` turns it off): after the cubemap trace (fragment
/// or compute) and before the fallback and the bounce rounds, every mirror pixel whose record
/// is a hit or escaped re-traces its ray ([`AppendKind::Check`], from t = 0 under the start
/// rule) against a second CWBVH over only the reflectors a mirror ray can reach
/// ([`crate::scene::Scene::check_triangles`]: every reflector when the scene has several, else
/// a non-convex one), with the global triangle indices. The CMOs do not capture those
/// reflectors, or only their parts that face a CMO centre, so a ray that should meet one passes
/// through it in the cubemap trace. A hit strictly nearer than the record's `t` (any hit when
/// it escaped), on another triangle, replaces the record's result (status, point, colour shaded
/// there, `t`, triangle) and sets its `checked` flag, keeping the method's counters, `t_done`
/// and `fallback` = 0; a miss leaves the record untouched. The bounce rounds then continue from
/// such a hit as from any reflector hit. Not built (nothing allocated) when no reflector
/// qualifies: one convex reflector (the sphere room).
pub struct ReflectorCheck {
    pub passes: BvhPasses,
}

impl ReflectorCheck {
    /// The check for `scene`'s reflectors ([`crate::scene::Scene::check_triangles`]), `None`
    /// when there are none.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        triangles: &[u32],
        data: &GpuSceneData,
        scene: &SceneBuffers,
        gbuffer: &Gbuffer,
        params: &Buffer,
        records: &Buffer,
        t_hi: f32,
    ) -> VkResult<Option<Self>> {
        if triangles.is_empty() {
            return Ok(None);
        }
        let bvh = BvhData::build_subset(data, triangles);
        let passes = BvhPasses::with_bvh(
            ctx,
            AppendKind::Check,
            &bvh,
            scene,
            gbuffer,
            params,
            records,
            t_hi,
        )?;
        Ok(Some(ReflectorCheck { passes }))
    }

    /// Rebuilds the reflectors' BVH over `data` (the scene's geometry moved; `triangles` as at
    /// creation) and uploads it with the ray length `t_hi` ([`BvhTracer::update`]).
    pub fn update(
        &mut self,
        ctx: &GpuContext,
        triangles: &[u32],
        data: &GpuSceneData,
        t_hi: f32,
    ) -> VkResult<()> {
        let bvh = BvhData::build_subset(data, triangles);
        self.passes.tracer.update(ctx, &bvh, t_hi)
    }

    /// Clear, append, size the dispatch, trace.
    pub fn record(&self, rec: &Recorder<'_>) -> VkResult<()> {
        self.passes.record_queue(rec);
        self.passes.record_trace(rec)
    }
}

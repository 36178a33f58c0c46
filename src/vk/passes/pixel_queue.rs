//! A queue of pixel indices for a compute pass whose work lies on a few pixels (the glossy cone
//! passes: [`super::cone::ConeStage`] and the SSR baseline's `ssr_cone`), the host side of
//! `spirv/shared/pixel_queue.wgsl`: the pass's selection entry point, one invocation per pixel,
//! pushes the pixels it keeps; `queue_args` sizes an indirect dispatch from their count; the
//! pass's `main` runs one invocation per queued pixel.
//!
//! Why: lavapipe runs the body of an `if` whatever its lanes take, so a pass dispatched over
//! every pixel with an early return runs its whole body for every subgroup
//! (`spirv/README.md`, "What lavapipe does"); the cube-map cone pass spent two thirds of its time
//! so on `sphere-room-glossy` (`benches/results/lavapipe-shaders.md`, "What was kept").
//!
//! Invariants: the queue holds a word per pixel of the frame; the head is zeroed in
//! [`PixelQueue::record`] before the selection, so every frame starts empty; `main`'s sets
//! bind [`PixelQueue::resources`] at the shader's bindings 9 and 10 of group 0.
use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::VkResult;
use crate::vk::backend::pipeline::{BindGroup, ComputeOptions, ComputePipeline, Resource};
use crate::vk::backend::shaders::Pass;
use crate::vk::backend::sync::{INDIRECT_READ, SHADER_WRITE, STORAGE_RW, TRANSFER_WRITE};

/// `@group(0)` bindings of the queue and its head in `spirv/shared/pixel_queue.wgsl`.
const QUEUE_BINDING: u32 = 9;
const HEAD_BINDING: u32 = 10;

/// Bytes of WGSL `PixelQueueHead`: a `VkDispatchIndirectCommand` and the count.
const HEAD_BYTES: u64 = 16;

/// The queue, its head and the two passes that fill it and size `main`'s dispatch.
pub struct PixelQueue {
    select: (ComputePipeline, BindGroup),
    args: (ComputePipeline, BindGroup),
    /// The selection's workgroups (one invocation per pixel).
    groups: [u32; 3],
    queue: Buffer,
    head: Buffer,
}

impl PixelQueue {
    /// The queue of a `width` x `height` frame for `pass`, whose entry point `select` (one
    /// invocation per pixel, in [`super::bvh::pixel_groups`]: workgroups of 64, the shader's
    /// `PIXEL_QUEUE_WG`, as `pixel_queue_pixel` indexes them) reads `resources` in group 0,
    /// besides the queue.
    pub fn new(
        ctx: &GpuContext,
        pass: &'static Pass,
        select: &str,
        resources: &[(u32, Resource<'_>)],
        (width, height): (u32, u32),
    ) -> VkResult<Self> {
        let pixels = u64::from(width) * u64::from(height);
        let name = |what: &str| format!("{} {what}", pass.name);
        let queue = Buffer::new(
            ctx.device(),
            &name("pixel queue"),
            pixels.max(1) * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
        )?;
        let head = Buffer::new(
            ctx.device(),
            &name("pixel queue head"),
            HEAD_BYTES,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::INDIRECT_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let select_pipeline = ComputePipeline::new(ctx, pass, select, ComputeOptions::default())?;
        let mut all = resources.to_vec();
        all.push((QUEUE_BINDING, Resource::Buffer(&queue)));
        all.push((HEAD_BINDING, Resource::Buffer(&head)));
        let select_set = select_pipeline.bind_group(0, &all)?;
        let args = ComputePipeline::new(ctx, pass, "queue_args", ComputeOptions::default())?;
        let args_set = args.bind_group(0, &[(HEAD_BINDING, Resource::Buffer(&head))])?;
        Ok(PixelQueue {
            select: (select_pipeline, select_set),
            args: (args, args_set),
            groups: super::bvh::pixel_groups(width, height),
            queue,
            head,
        })
    }

    /// The queue and its head, for `main`'s group 0.
    pub fn resources(&self) -> [(u32, Resource<'_>); 2] {
        [
            (QUEUE_BINDING, Resource::Buffer(&self.queue)),
            (HEAD_BINDING, Resource::Buffer(&self.head)),
        ]
    }

    /// Records the head's reset, the selection, `queue_args` and `main` (`pipeline` with
    /// `sets`) over the queue, with the barriers between them (the caller orders the whole
    /// after what wrote the selection's inputs).
    pub fn record(
        &self,
        rec: &Recorder<'_>,
        pipeline: &ComputePipeline,
        sets: &[&BindGroup],
    ) -> VkResult<()> {
        rec.fill_buffer(&self.head, 0);
        rec.memory_barrier(TRANSFER_WRITE, STORAGE_RW);
        self.select.0.dispatch(rec, &[&self.select.1], self.groups);
        rec.memory_barrier(SHADER_WRITE, STORAGE_RW);
        self.args.0.dispatch(rec, &[&self.args.1], [1, 1, 1]);
        rec.memory_barrier(SHADER_WRITE, INDIRECT_READ);
        pipeline.dispatch_indirect(rec, sets, &self.head, 0)
    }
}

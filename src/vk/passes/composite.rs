//! The `composite` pass: the final colour of every pixel from the G-buffer and the records; a
//! record left unresolved gets the frame's fallback (`FrameParams::fallback`), whose
//! environment-map lookup shades from the CMOs' triangle IDs and the scene.
use ash::vk;
use gpu_allocator::MemoryLocation;

use super::cmo::CmoData;
use super::gbuffer::Gbuffer;
use super::scene_buffers::SceneBuffers;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::VkResult;
use crate::vk::backend::pipeline::{BindGroup, ComputeOptions, ComputePipeline, Resource};
use crate::vk::backend::shaders::COMPOSITE;

/// The pass and the frame colour it writes (RGBA f32 per pixel, alpha 1 on mirror pixels).
pub struct Composite {
    pipeline: ComputePipeline,
    sets: [BindGroup; 3],
    colour: Buffer,
    pixels: u32,
}

impl Composite {
    /// The pass over `gbuffer`, the frame's `FrameParams` buffer `params` and `records`, with
    /// the CMO data and the scene for the environment-map fallback.
    pub fn new(
        ctx: &GpuContext,
        gbuffer: &Gbuffer,
        params: &Buffer,
        records: &Buffer,
        cmo: &CmoData,
        scene: &SceneBuffers,
    ) -> VkResult<Self> {
        let (width, height) = gbuffer.extent();
        let colour = Buffer::new(
            ctx.device(),
            "frame colour",
            u64::from(width) * u64::from(height) * 16,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let pipeline = ComputePipeline::new(ctx, &COMPOSITE, "main", ComputeOptions::default())?;
        let sets = [
            pipeline.bind_group(
                0,
                &[
                    (0, Resource::sampled(&gbuffer.position)),
                    (2, Resource::Buffer(params)),
                    (3, Resource::Buffer(records)),
                    (4, Resource::sampled(&gbuffer.colour)),
                    (5, Resource::Buffer(&colour)),
                ],
            )?,
            pipeline.bind_group(1, &cmo.resources_for(&COMPOSITE, "main"))?,
            // The scene, for the environment-map fallback's shading.
            pipeline.bind_group(2, &scene.resources())?,
        ];
        Ok(Composite {
            pipeline,
            sets,
            colour,
            pixels: width * height,
        })
    }

    /// The CMO group (set 1) over `cmo`'s buffers as they are now (the bounded capture's pool
    /// was allocated anew).
    pub fn rebind_cmo(&mut self, cmo: &CmoData) -> VkResult<()> {
        self.sets[1] = self
            .pipeline
            .bind_group(1, &cmo.resources_for(&COMPOSITE, "main"))?;
        Ok(())
    }

    /// The frame colour buffer.
    pub fn colour(&self) -> &Buffer {
        &self.colour
    }

    /// Records the pass (after a barrier from every pass that wrote the records).
    pub fn record(&self, rec: &Recorder<'_>) {
        let groups = self.pixels.div_ceil(64);
        let sets = [&self.sets[0], &self.sets[1], &self.sets[2]];
        self.pipeline.dispatch(rec, &sets, [groups, 1, 1]);
    }
}

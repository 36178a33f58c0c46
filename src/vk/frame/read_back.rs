//! Reading a rendered frame back from the device: colour, mask, positions and records, moved back
//! from the anchor's coordinates, and the passes' counters.

use ash::vk;
use glam::{Vec3, Vec4};

use super::{CmoCapture, GpuFrame, GpuRenderer, PixelRecord, RECORD_HIT};
use crate::vk::backend::context::GpuContext;
use crate::vk::backend::error::VkResult;
use crate::vk::backend::timestamps::PassTime;

impl GpuRenderer {
    /// Reads the frame back after [`GpuRenderer::render`]'s submission.
    pub(super) fn read_back(
        &self,
        ctx: &GpuContext,
        pass_times: Vec<PassTime>,
    ) -> VkResult<GpuFrame> {
        let colour: Vec<[f32; 4]> = ctx.read_buffer(self.composite.colour())?;
        let records: Vec<PixelRecord> = ctx.read_buffer(&self.records)?;
        let position = ctx.read_image(
            &self.gbuffer.position,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        )?;
        let position: &[[f32; 4]] = bytemuck::cast_slice(&position);
        let stats = self.method.read_stats(ctx)?;
        // With `--bounces 0` the BVH passes did not run.
        let bvh = match self.bvh_passes().filter(|_| self.options.bounces != 0) {
            Some(b) => Some(b.queue.read_counter(ctx)?),
            None => None,
        };
        let rounds = match &self.bounce {
            Some(b) => b.read_counts(ctx)?,
            None => Vec::new(),
        };
        let lists = match &self.capture {
            Some(CmoCapture::Lists(c)) => Some(c.read_counters(ctx)?),
            _ => None,
        };
        let n = (self.width * self.height) as usize;
        let mut records = records[..n].to_vec();
        let anchor = self.anchor;
        let world = |p: Vec3| (p.as_dvec3() + anchor.as_dvec3()).as_vec3();
        if anchor != Vec3::ZERO {
            for r in &mut records {
                r.origin = world(Vec3::from_array(r.origin)).to_array();
                if r.status == RECORD_HIT {
                    r.point = world(Vec3::from_array(r.point)).to_array();
                }
            }
        }
        Ok(GpuFrame {
            width: self.width,
            height: self.height,
            colour: colour[..n]
                .iter()
                .map(|c| Vec4::from_array(*c).truncate())
                .collect(),
            mask: colour[..n].iter().map(|c| u8::from(c[3] == 1.0)).collect(),
            surface_position: position[..n]
                .iter()
                .map(|p| {
                    let p = Vec4::from_array(*p);
                    if p.w < 0.0 {
                        Vec3::NAN
                    } else {
                        world(p.truncate())
                    }
                })
                .collect(),
            records,
            pass_times,
            bvh,
            lists,
            compute: stats.compute,
            rounds,
            search: stats.search,
            captured: false,
            lists_uploaded: false,
        })
    }
}

//! The stages a frame shares between methods: what a method needs but does not own.
pub mod bounce;
pub mod bvh;
pub mod capture;
pub mod capture_lists;
pub mod cmo;
pub mod composite;
pub mod cone;
pub mod gbuffer;
pub mod hier32;
pub mod lists;
pub mod pixel_queue;
pub mod pyramid;
pub mod records;
pub mod scene_buffers;

use crate::vk::backend::context::Recorder;
use crate::vk::backend::error::VkResult;
use crate::vk::backend::pipeline::{BindGroup, ComputePipeline};
use crate::vk::backend::sync::{COMPUTE_READ, COMPUTE_WRITE};
use crate::vk::backend::timestamps::Timestamps;

/// Records a level-by-level build (the CMO pyramid's, the cone pre-filter's): `pipeline`
/// dispatched once per level with that level's bind group and workgroup count, a barrier between
/// levels, inside the debug label `name`, or inside a timestamp scope of that name when
/// `timestamps` is given (its `reset` must already be recorded in this command buffer).
pub(crate) fn record_levels(
    rec: &Recorder<'_>,
    pipeline: &ComputePipeline,
    name: &str,
    levels: (&[BindGroup], &[[u32; 3]]),
    timestamps: Option<&mut Timestamps>,
) -> VkResult<()> {
    let (timestamps, scope) = match timestamps {
        Some(t) => {
            let s = t.begin(rec, name)?;
            (Some(t), Some(s))
        }
        None => {
            rec.begin_label(name);
            (None, None)
        }
    };
    for (i, (set, groups)) in levels.0.iter().zip(levels.1).enumerate() {
        if i > 0 {
            rec.memory_barrier(COMPUTE_WRITE, COMPUTE_READ);
        }
        pipeline.dispatch(rec, &[set], *groups);
    }
    match (timestamps, scope) {
        (Some(t), Some(s)) => t.end(rec, s),
        _ => rec.end_label(),
    }
    Ok(())
}

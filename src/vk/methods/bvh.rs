//! `--method bvh`: exact ray tracing of every mirror pixel's reflected ray over the scene's
//! CWBVH ([`crate::vk::passes::bvh`], which the trace fallback and the bounce rounds share):
//! `bvh_queue` (`append_mirror`) queues the rays, `bvh_trace` traces them. It reads no CMO, so
//! the frame runs no capture for it.
use crate::cpu::options::TraceOptions;
use crate::vk::backend::context::Recorder;
use crate::vk::backend::error::VkResult;
use crate::vk::backend::shaders::{BVH_QUEUE, BVH_TRACE, Pass};
use crate::vk::passes::bvh::{AppendKind, BvhPasses, BvhRay};
use crate::vk::passes::cmo::CaptureContents;

use super::technique::{FrameInputs, MethodSpec, Needs, Scope, Technique};

/// The BVH method.
pub struct Bvh;

impl MethodSpec for Bvh {
    fn trace_pass(&self) -> &'static Pass {
        &BVH_TRACE
    }

    /// No capture: the CMO data is the placeholder composite binds (triangle IDs, as its
    /// environment-map fallback reads them; never read, as no record stays unresolved but for a
    /// ray the loop cap cut).
    fn needs(&self, _trace: &TraceOptions) -> Needs {
        Needs {
            capture: false,
            contents: CaptureContents {
                colour: false,
                triangle_ids: true,
            },
            pyramid: false,
        }
    }

    /// The ray queue.
    fn bytes_per_pixel(&self) -> u64 {
        size_of::<BvhRay>() as u64
    }

    fn create(&self, i: &FrameInputs<'_>) -> VkResult<Box<dyn Technique>> {
        let passes = BvhPasses::new(
            i.ctx,
            AppendKind::Mirror,
            i.data,
            i.scene,
            i.gbuffer,
            i.params,
            i.records,
            i.t_hi,
        )?;
        Ok(Box::new(BvhMethod { passes }))
    }
}

/// The method's queue of mirror rays and the tracer.
pub struct BvhMethod {
    pub passes: BvhPasses,
}

impl Technique for BvhMethod {
    fn record(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        scope(BVH_QUEUE.name, &mut || {
            self.passes.record_queue(rec);
            Ok(())
        })?;
        scope(BVH_TRACE.name, &mut || self.passes.record_trace(rec))
    }

    fn bvh(&self) -> Option<&BvhPasses> {
        Some(&self.passes)
    }
}

//! `--method envmap`: one lookup of the nearest CMO's colour per mirror pixel, no parallax (the
//! baseline), in the deferred pass `envmap` ([`super::fragment::DeferredTrace`]). Its CPU twin
//! is in [`crate::cpu::fragment`].
use crate::cpu::options::TraceOptions;
use crate::vk::backend::error::VkResult;
use crate::vk::backend::shaders::{ENVMAP, Pass};
use crate::vk::passes::cmo::CaptureContents;

use super::fragment::DeferredTrace;
use super::technique::{FrameInputs, MethodSpec, Needs, Technique};

/// The environment-map method.
pub struct Envmap;

impl MethodSpec for Envmap {
    fn trace_pass(&self) -> &'static Pass {
        &ENVMAP
    }

    /// The colour only: a hit takes its texel's colour, and no record is left unresolved, so
    /// no fallback shades from triangle IDs.
    fn needs(&self, _trace: &TraceOptions) -> Needs {
        Needs {
            capture: true,
            contents: CaptureContents {
                colour: true,
                triangle_ids: false,
            },
            pyramid: false,
        }
    }

    fn bytes_per_pixel(&self) -> u64 {
        0
    }

    fn create(&self, inputs: &FrameInputs<'_>) -> VkResult<Box<dyn Technique>> {
        Ok(Box::new(DeferredTrace::new(
            inputs, &ENVMAP, "fs_main", false,
        )?))
    }
}

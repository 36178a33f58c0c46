//! `--method envmap`: one lookup of the nearest CMO's colour per mirror pixel, no parallax (the
//! baseline), in the deferred pass `envmap` ([`super::fragment::DeferredTrace`]). Its CPU twin
//! is in [`crate::cpu::fragment`].
//!
//! # How it works
//!
//! The environment-map baseline: one cube map lookup per mirror pixel, at the CMO nearest to the
//! mirror point, along the pixel's reflected direction, as if the scene were infinitely far away.
//! No parallax, no tracing: the `envmap` pass writes one `PixelRecord` per mirror pixel with the
//! captured colour and never leaves a pixel unresolved. Its capture stores colour (the exact
//! methods store triangle IDs instead) and it needs no pyramid.
//!
//! It is here for two reasons: it is what most real-time renderers do, and it is the least any
//! cubemap method can cost, so it bounds what tracing could ever gain on a driver.
//!
//! Invariants:
//! - The lookup uses the face and texel rules of `src/cubemap/face.rs` (`spirv/shared/cube.wgsl`).
//! - It names no triangle, so `--bounces N` other than 1 is refused and `same triangle` is `-`.
//!
//! The `envmap` fallback of the other methods (`--fallback envmap`) is a different, better lookup:
//! in the nearest CMO, the ray from its centre along the reflected direction is met (watertight)
//! with the triangle that texel captured, or else that texel's centre ray is, and shaded there
//! (`composite.wgsl`; twin `cpu::fragment::envmap_fallback`).
//!
//! Measured (lavapipe, 2 cores): 62 to 80 ns per mirror ray at 320x240, 0.15 to 0.23
//! times the reference's reflected ray; on the five built-in scenes at 160x120, 98.3 % of mirror
//! pixels on the wrong surface, mean angular error 14 degrees, PSNR 14.6 dB over mirror pixels
//! (`benches/results/lavapipe-bench.json`). On `default` at 640x480 (`render --compare`): every
//! mirror pixel wrong, 20.4 degrees mean, 14.5 dB.
use crate::cpu::options::TraceOptions;
use crate::vk::backend::error::VkResult;
use crate::vk::backend::shaders::{ENVMAP, Pass};
use crate::vk::passes::cmo::CaptureContents;

use super::fragment::DeferredTrace;
use super::technique::{FrameInputs, MethodSpec, Needs, Technique};

/// The environment-map method.
pub struct Envmap;

impl MethodSpec for Envmap {
    fn method(&self) -> crate::method::Method {
        crate::method::Method::Envmap
    }

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

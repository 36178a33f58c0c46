//! `--method fragment`: cubemap tracing in a deferred full-screen fragment pass (thesis alg. 1,
//! 2, 4), `fragment_trace`, over the G-buffer, the CMO data with its 2x2 pyramid and, for
//! verified hits, the scene. Its CPU twin is [`crate::cpu::fragment`].
//!
//! [`DeferredTrace`] is the pass shape it shares with the environment map
//! ([`super::envmap`]): one full-screen triangle whose fragments each write their pixel's
//! record, drawn over the reflectors' screen rectangle only.
use crate::cpu::options::TraceOptions;
use crate::vk::backend::context::Recorder;
use crate::vk::backend::error::VkResult;
use crate::vk::backend::graphics::{GraphicsDesc, GraphicsPipeline, RenderTarget};
use crate::vk::backend::pipeline::{BindGroup, Resource};
use crate::vk::backend::shaders::{FRAGMENT_TRACE, Pass};
use crate::vk::passes::cmo::{CaptureContents, exact_mip_only};

use super::technique::{FrameInputs, MethodSpec, Needs, Scope, Technique};

/// The fragment method.
pub struct Fragment;

impl MethodSpec for Fragment {
    fn trace_pass(&self) -> &'static Pass {
        &FRAGMENT_TRACE
    }

    /// Triangle IDs for verified hits (and the environment-map fallback); the colour only for
    /// the thesis's approximate criteria, which take a hit's colour from its texel.
    fn needs(&self, trace: &TraceOptions) -> Needs {
        Needs {
            capture: true,
            contents: CaptureContents {
                colour: trace.approx().is_some(),
                triangle_ids: true,
            },
            pyramid: true,
        }
    }

    fn bytes_per_pixel(&self) -> u64 {
        0
    }

    fn create(&self, inputs: &FrameInputs<'_>) -> VkResult<Box<dyn Technique>> {
        // The pass's specialised entry point where the options allow it.
        let entry = if exact_mip_only(&inputs.options.trace) {
            "fs_exact_mip"
        } else {
            "fs_main"
        };
        Ok(Box::new(DeferredTrace::new(
            inputs,
            &FRAGMENT_TRACE,
            entry,
            true,
        )?))
    }
}

/// A deferred full-screen fragment pass that writes one record per mirror pixel.
pub struct DeferredTrace {
    pass: &'static Pass,
    pipeline: GraphicsPipeline,
    sets: Vec<BindGroup>,
    width: u32,
    height: u32,
    /// The pixels the pass shades: the reflectors' screen rectangle (`None`: the whole frame).
    /// A CPU driver runs a fragment shader's code for a group of pixels even when none of them
    /// is a mirror pixel; outside the rectangle none is.
    mirror_rect: Option<[u32; 4]>,
}

impl DeferredTrace {
    /// The pass `pass` through entry point `entry`, bound to the G-buffer, the frame's params
    /// and records, the CMO data and, with `scene`, the scene (the pass's `SCENE_GROUP`).
    pub fn new(
        inputs: &FrameInputs<'_>,
        pass: &'static Pass,
        entry: &'static str,
        scene: bool,
    ) -> VkResult<Self> {
        let pipeline = GraphicsPipeline::new(
            inputs.ctx,
            pass,
            &GraphicsDesc {
                vertex: "vs_fullscreen",
                fragment: entry,
                colour_formats: Vec::new(),
                depth: None,
            },
        )?;
        let gbuffer = inputs.gbuffer;
        let mut sets = vec![
            pipeline.bind_group(
                0,
                &[
                    (0, Resource::sampled(&gbuffer.position)),
                    (1, Resource::sampled(&gbuffer.normal)),
                    (2, Resource::Buffer(inputs.params)),
                    (3, Resource::Buffer(inputs.records)),
                ],
            )?,
            pipeline.bind_group(1, &inputs.cmo.resources_for(pass, entry))?,
        ];
        if scene {
            sets.push(pipeline.bind_group(2, &inputs.scene.resources())?);
        }
        let (width, height) = gbuffer.extent();
        Ok(DeferredTrace {
            pass,
            pipeline,
            sets,
            width,
            height,
            mirror_rect: inputs.mirror_rect,
        })
    }
}

impl Technique for DeferredTrace {
    fn record(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        scope(self.pass.name, &mut || {
            let target = RenderTarget {
                width: self.width,
                height: self.height,
                colour: Vec::new(),
                depth: None,
            };
            let sets: Vec<&BindGroup> = self.sets.iter().collect();
            self.pipeline
                .draw_in(rec, &target, &sets, 3, 0, self.mirror_rect)
        })
    }
}

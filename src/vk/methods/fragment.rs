//! `--method fragment`: cubemap tracing in a deferred full-screen fragment pass (thesis alg. 1,
//! 2, 4), `fragment_trace`, over the G-buffer, the CMO data with its 2x2 pyramid and, for
//! verified hits, the scene. Its CPU twin is [`crate::cpu::fragment`].
//!
//! [`DeferredTrace`] is the pass shape it shares with the environment map
//! ([`super::envmap`]): one full-screen triangle whose fragments each write their pixel's
//! record, drawn over the reflectors' screen rectangle only.
//!
//! # How it works
//!
//! Cubemap tracing in a deferred fragment pass (thesis alg. 1, 2 and 4): `fragment_trace` runs once
//! per mirror pixel of the G-buffer, traces the pixel's reflected ray through the CMOs' distance
//! cube maps and writes one `PixelRecord`. Its CPU twin is `cpu::fragment` (the same loops in Rust);
//! the compute method makes the same decisions on every pixel through another traversal.
//!
//! Surface model (the centre criterion; `src/cpu/mod.rs` states it in full). Texel `i` of
//! a CMO is the piece of the sphere `|x| = D_i` around the CMO centre inside the texel's frustum.
//! Along the ray, the first texel that is not entirely in front of that profile decides: a hit, or
//! "went behind an occluder" where its neighbour's patch does not join it (a silhouette is never a
//! hit). A ray that went behind passes to the next CMO from where it was proven empty (the occlusion
//! handoff); when no CMO can see on, the pixel is unresolved and left to the `--fallback`, never
//! filled with a guessed hit. The 2x2 `[min, max]` pyramid (`pyramid` pass) lets the march skip
//! cells whole (`--no-accel` walks every texel: the same records, about 4x the cost).
//!
//! Verified hits. The capture stores per texel the ID of the triangle its centre ray sees. Where a
//! texel decides a hit, the ray is intersected (watertight, Woop et al. 2013) with the triangles of
//! the texel's 3x3 neighbourhood; the nearest intersection beyond the proven-empty prefix whose
//! direction from the CMO centre falls in the neighbourhood is the hit, on a real triangle, shaded
//! there as the reference shades (`spirv/shared/verify.wgsl`, `hit.wgsl`; rule and proof sketch in
//! `src/cpu/verify.rs`). None means "behind" at the ray's entry into that texel's cone, and the
//! handoff goes on: verification never reports a wrong hit, it can leave a pixel unresolved that a
//! colour lookup would have filled. It also saves memory: 8 instead of 20 bytes per texel.
//!
//! `--strict` counts a hit inside a texel only where the texel and its neighbours decide it. With
//! verified hits it removes a wrong hit only at cube size 3 (2 of 170 hard-case pixels, on a floor
//! behind a box no texel sees) and none elsewhere, at 1.5x to 7x the unresolved pixels; the
//! production entry point `fs_exact_mip` carries no strict code, the generic one does.
//!
//! `--criterion bounded` runs the entry point `fs_bounded`: per-texel sound bounds and
//! candidate lists (`cubemap::bounds`, uploaded by `vk::passes::lists`, their `lo` as the CMO
//! distance) instead of a centre-sampled capture; the hit is the nearest listed triangle the
//! ray meets where the list is complete (`spirv/shared/trace_bounded.wgsl`, CPU twin
//! `cpu::bounded`), the ray leaving its G-buffer triangle (the start rule). It marches the 2x2
//! pyramid of the texels' `lo` like the centre criterion (the march is shared, its
//! classification is not: `fs_exact_mip`/`fs_main`'s bindings stay free of the lists; CPU twin
//! `Traversal::Mip`); `--no-accel` and `--strict` do not apply to it.
//!
//! The thesis's approximate criteria (`--criterion threshold|sign-change`, `--sampling`,
//! `--steps`, `--eps`) are kept to measure against: they report "escaped" where no sample fires and
//! cannot name a triangle, so `--bounces` refuses them. In the bench (160x120, lavapipe)
//! they put 15 to 69 % of mirror pixels on the wrong surface against 0.01 % for the exact one.
//!
//! Invariants:
//! - GPU and twin agree bit for bit (status, CMO, texel, riser flag, colour) on synthetic rooms and
//!   on every mirror pixel of every built-in scene; the twin relies on the driver not fusing
//!   `a * b + c`.
//! - The pass is scissored to the reflectors' screen rectangle (`Camera::screen_rect` of the
//!   reflector vertices plus one pixel; the whole frame when a vertex is behind the eye): lavapipe
//!   runs every fragment of a draw through the shader's straight-line code.
//! - Where a texel's one distance misrepresents the surface across it (steeply seen surfaces, an
//!   outline inside the texel) a ray can cross the patch where it passes the real surface;
//!   verification turns those into hits on the triangle the ray meets, or into no hit.
//!
//! Measured (lavapipe, 2 cores, `benches/results/lavapipe-bench-320x240.json`):
//! 736 to 1155 ns per mirror ray at 320x240, 1.7 to 3.3 times the reference's reflected ray; the
//! 16x12 floor 0.018 to 0.028 of the full frame; 14 cells and under 2 texels per ray (the texel
//! walk: 116). Same triangle 99.98 to 100 % and PSNR over resolved mirror pixels 52 to 104 dB per
//! built-in scene. Why it is not cheaper on this driver is in `spirv/README.md`.
use crate::cpu::options::{TraceCriterion, TraceOptions};
use crate::vk::backend::context::GpuContext;
use crate::vk::backend::context::Recorder;
use crate::vk::backend::error::VkResult;
use crate::vk::backend::graphics::{GraphicsDesc, GraphicsPipeline, RenderTarget};
use crate::vk::backend::pipeline::{BindGroup, Resource};
use crate::vk::backend::shaders::{FRAGMENT_TRACE, Pass};
use crate::vk::passes::cmo::{CaptureContents, CmoData, exact_mip_only};

use super::technique::{CameraInputs, FrameInputs, Glossy, MethodSpec, Needs, Scope, Technique};

/// The fragment method.
pub struct Fragment;

impl MethodSpec for Fragment {
    fn method(&self) -> crate::method::Method {
        crate::method::Method::Fragment
    }

    fn trace_pass(&self) -> &'static Pass {
        &FRAGMENT_TRACE
    }
    /// On a glossy scene the frame cone traces the glossy pixels (`vk::passes::cone`), from
    /// the pre-filtered colour chain.
    fn glossy(&self) -> Glossy {
        Glossy::ConeStage
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
        } else if inputs.options.trace.criterion == TraceCriterion::Bounded {
            "fs_bounded"
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
    entry: &'static str,
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
        let mut frame = vec![
            (0, Resource::sampled(&gbuffer.position)),
            (1, Resource::sampled(&gbuffer.normal)),
            (2, Resource::Buffer(inputs.params)),
            (3, Resource::Buffer(inputs.records)),
        ];
        // The G-buffer's triangle IDs where the entry reads them (`fs_bounded`: the start rule).
        let used = pass.entry_point(entry).map_or(&[][..], |e| e.bindings);
        if used.iter().any(|b| b.group == 0 && b.binding == 8) {
            frame.push((8, Resource::sampled(&gbuffer.triangle)));
        }
        let mut sets = vec![
            pipeline.bind_group(0, &frame)?,
            pipeline.bind_group(1, &inputs.cmo.resources_for(pass, entry))?,
        ];
        if scene {
            sets.push(pipeline.bind_group(2, &inputs.scene.resources())?);
        }
        let (width, height) = gbuffer.extent();
        Ok(DeferredTrace {
            pass,
            entry,
            pipeline,
            sets,
            width,
            height,
            mirror_rect: inputs.mirror_rect,
        })
    }
}

impl Technique for DeferredTrace {
    fn set_camera(&mut self, inputs: &CameraInputs<'_>) -> VkResult<()> {
        self.mirror_rect = inputs.mirror_rect;
        Ok(())
    }

    /// The CMO group (set 1) over `cmo`'s buffers as they are now.
    fn rebind_cmo(&mut self, _ctx: &GpuContext, cmo: &CmoData) -> VkResult<()> {
        self.sets[1] = self
            .pipeline
            .bind_group(1, &cmo.resources_for(self.pass, self.entry))?;
        Ok(())
    }

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

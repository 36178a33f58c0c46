//! The interface between a frame and its method: [`MethodSpec`], what a method is before
//! anything is allocated (what it needs from the shared stages, its device memory, how to create
//! it), and [`Technique`], the method's allocated passes in a frame (how to record them, what
//! they report).
//!
//! Invariants every method keeps:
//! - It writes one [`PixelRecord`](crate::vk::passes::records::PixelRecord) per mirror pixel into
//!   the frame's record buffer ([`FrameInputs::records`]) and nothing else the frame shares; the
//!   composite pass, the reflector check, the fallback and the bounce rounds read those records.
//! - Each of its passes is recorded in a timestamp scope named after its WGSL file, in a fixed
//!   order, so that the harness's tables line up frame after frame.
//! - Everything it records reads only what the shared stages before it wrote: the capture, the
//!   CMO pyramid (when [`Needs::pyramid`]) and the G-buffer, made visible by the frame's barriers.
//! - Its rules (bounces, fallback, reflector check, criteria) are [`crate::Method`]'s, not its
//!   own: a method file holds the passes only.
use std::any::Any;

use crate::camera::Camera;
use crate::cpu::options::TraceOptions;
use crate::cpu::reflection_point::SearchStats;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::VkResult;
use crate::vk::backend::shaders::Pass;
use crate::vk::options::RenderOptions;
use crate::vk::passes::bvh::{BvhPasses, BvhQueue};
use crate::vk::passes::cmo::{CaptureContents, CmoData};
use crate::vk::passes::gbuffer::Gbuffer;
use crate::vk::passes::scene_buffers::SceneBuffers;

/// What a method needs from the frame's shared stages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Needs {
    /// Whether the `capture` pass runs. Without it the CMO data is a one-texel placeholder,
    /// initialised once, that only composite binds (its environment-map fallback, for a record
    /// the method left unresolved).
    pub capture: bool,
    /// What the capture stores per texel.
    pub contents: CaptureContents,
    /// Whether the 2x2 min/max pyramid of the CMO distances is built (`pyramid` pass).
    pub pyramid: bool,
}

/// Records one named pass: its timestamp scope (or its debug label without timestamps)
/// around `f`.
pub type Scope<'a> = dyn FnMut(&str, &mut dyn FnMut() -> VkResult<()>) -> VkResult<()> + 'a;

/// What the frame's shared stages give a method to create its passes from.
pub struct FrameInputs<'a> {
    pub ctx: &'a GpuContext,
    pub camera: &'a Camera,
    pub options: &'a RenderOptions,
    /// The G-buffer's near plane.
    pub near: f32,
    /// The length of an escaped ray.
    pub t_hi: f32,
    /// The scene as uploaded.
    pub data: &'a GpuSceneData,
    pub scene: &'a SceneBuffers,
    pub cmo: &'a CmoData,
    pub gbuffer: &'a Gbuffer,
    /// The frame's `FrameParams` buffer.
    pub params: &'a Buffer,
    /// The frame's per-pixel records: what the method writes.
    pub records: &'a Buffer,
    /// The reflectors' screen rectangle (`None`: the whole frame): no mirror pixel lies outside.
    pub mirror_rect: Option<[u32; 4]>,
}

/// A new camera for a method's passes ([`Technique::set_camera`]): of the frame size the passes
/// were created for, with the G-buffer's near plane and the reflectors' screen rectangle derived
/// from it as at creation ([`FrameInputs`]).
pub struct CameraInputs<'a> {
    pub ctx: &'a GpuContext,
    pub camera: &'a Camera,
    pub near: f32,
    pub data: &'a GpuSceneData,
    pub mirror_rect: Option<[u32; 4]>,
}

/// The scene's moved geometry for a method's passes ([`Technique::update_geometry`]): the
/// scene as uploaded now (the triangles, objects and materials of creation, other vertex
/// positions and normals) and the ray length derived from it.
pub struct GeometryInputs<'a> {
    pub ctx: &'a GpuContext,
    pub data: &'a GpuSceneData,
    /// The length of an escaped ray.
    pub t_hi: f32,
    /// Whether BVHs are rebuilt over `data` (false only in the tests' negative: a stale BVH).
    pub rebuild_bvh: bool,
}

/// Whether the uploaded scene has a glossy reflector (a reflector of specular power below the
/// mirror cap, [`crate::lobe::glossy`]): only then does a frame create anything for the lobe.
pub fn has_glossy_reflector(data: &GpuSceneData) -> bool {
    (data.objects.iter()).any(|o| {
        o.reflector & 1 != 0
            && o.specular_power >= 0.0
            && crate::lobe::glossy(Some(o.specular_power)).is_some()
    })
}

/// How a method renders a glossy reflector (one with a specular power below the mirror cap,
/// [`crate::lobe::glossy`]) on the GPU: what a frame of a glossy scene creates for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Glossy {
    /// The mirror direction only: nothing is created for the lobe.
    Mirror,
    /// The method's own passes read the pre-filtered CMO colour chain (`cmo_cone`,
    /// `spirv/shared/cone.wgsl`; ssr's remainder): the frame captures colour, allocates the
    /// chain and runs `cone_prefilter` after the capture.
    Chain,
    /// The chain, and the frame's cube-map cone stage after the trace
    /// (`vk::passes::cone::ConeStage`: fragment, compute).
    ConeStage,
}

impl Glossy {
    /// Whether the frame allocates and pre-filters the CMO colour chain (where the method
    /// captures at all, [`Needs::capture`]).
    pub fn reads_chain(self) -> bool {
        self != Glossy::Mirror
    }
}

/// What a method is before it is allocated: one per GPU method, in `super::spec`.
pub trait MethodSpec: Sync {
    /// The method it describes (the one place, in the method's own file, that names it).
    fn method(&self) -> crate::method::Method;

    /// The method's tracing pass: its timestamp scope in the harness's tables.
    fn trace_pass(&self) -> &'static Pass;

    /// What it needs from the shared stages, with tracer options `trace`.
    fn needs(&self, trace: &TraceOptions) -> Needs;

    /// Device bytes per frame pixel of the method's own buffers and images.
    fn bytes_per_pixel(&self) -> u64;

    /// Device bytes of the method's own per-CMO data for `cmos` CMOs of face size `size` (the
    /// compute path's hierarchy); none by default.
    fn cmo_bytes(&self, _cmos: u32, _size: u32) -> u64 {
        0
    }

    /// Device bytes the method adds to its per-CMO data where the CMOs hold the `bounded`
    /// criterion's lists (the compute path's hierarchy of their gaps); none by default.
    fn cmo_list_bytes(&self, _cmos: u32, _size: u32) -> u64 {
        0
    }

    /// How the method renders a glossy reflector on the GPU ([`Glossy`]); the mirror direction
    /// only by default.
    fn glossy(&self) -> Glossy {
        Glossy::Mirror
    }

    /// Refuses a device the method cannot run on, before anything is allocated.
    fn check_device(&self, _ctx: &GpuContext) -> VkResult<()> {
        Ok(())
    }

    /// Allocates the method's passes for one frame.
    fn create(&self, inputs: &FrameInputs<'_>) -> VkResult<Box<dyn Technique>>;
}

/// Per-frame statistics a method reports besides its records.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MethodStats {
    /// The compute path's ray count, subgroup sizes and per-ray counters.
    pub compute: Option<ComputeStats>,
    /// The reflection-point method's iteration counts.
    pub search: Option<SearchStats>,
}

/// Per-ray work of one frame, read back. Always recorded: the kernel keeps the counters anyway
/// (they are the CPU twin's) and writes 16 bytes per ray, which is lost in the noise of the
/// pass's time on lavapipe, so no option turns them off.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ComputeStats {
    /// Rays the trace took: the append pass queued them, and the rounds of `--bounces` theirs.
    pub rays: u32,
    /// `(min, max)` subgroup size `compute_trace` ran with (`(0, 0)` when no workgroup ran).
    pub subgroup_size: (u32, u32),
    /// Rays of the last dispatch (the last round of `--bounces`) that the driver's loop limit
    /// cut and the retrace traced again (`main_lanes1`, `main_wave`; 0 for the thesis layout).
    pub retraced: u32,
    /// Per pixel (meaningful on mirror pixels): texels tested, cells tested, descents,
    /// backtracks, summed over the ray's single-CMO traces.
    pub per_pixel: Vec<[u32; 4]>,
}

impl ComputeStats {
    /// Mean and max of each counter over the mirror pixels `mask` marks.
    pub fn summary(&self, mask: &[u8]) -> [(f64, u32); 4] {
        let mut out = [(0.0, 0u32); 4];
        let mut n = 0usize;
        for (c, _) in self.per_pixel.iter().zip(mask).filter(|(_, m)| **m != 0) {
            n += 1;
            for i in 0..4 {
                out[i].0 += f64::from(c[i]);
                out[i].1 = out[i].1.max(c[i]);
            }
        }
        for o in &mut out {
            o.0 /= n.max(1) as f64;
        }
        out
    }
}

/// A method's passes, allocated once for a frame size, recorded every frame. `Any`, so that
/// the renderer's typed accessors can hand a test the method's own type.
pub trait Technique: Any {
    /// Passes between the CMO stages and the G-buffer (the compute path's `hier32`); none by
    /// default.
    fn record_cmo_stage(&self, _rec: &Recorder<'_>, _scope: &mut Scope<'_>) -> VkResult<()> {
        Ok(())
    }

    /// Updates everything the method derived from the camera at creation (matrices, search
    /// start, scissor) for `inputs.camera`: the next frame must equal a frame of passes created
    /// for that camera, bit for bit (`crate::vk::frame::GpuRenderer::set_camera`). Nothing by
    /// default: for methods that read the camera only through the G-buffer and `FrameParams`.
    fn set_camera(&mut self, _inputs: &CameraInputs<'_>) -> VkResult<()> {
        Ok(())
    }

    /// Updates everything the method derived from the scene's geometry at creation (its BVH,
    /// the reflection-point method's closing triangles) for `inputs.data`, keeping its
    /// pipelines: after it and [`Technique::set_camera`], the next frame must equal a frame of
    /// passes created for that scene, bit for bit
    /// (`crate::vk::frame::GpuRenderer::update_geometry`). Nothing by default: for methods
    /// that read the geometry only through the scene buffers, the CMOs and the G-buffer.
    fn update_geometry(&mut self, _inputs: &GeometryInputs<'_>) -> VkResult<()> {
        Ok(())
    }

    /// Binds the method's passes to `cmo` again: its buffers were allocated anew (the bounded
    /// capture's pool grew, `crate::vk::frame::GpuRenderer::update_geometry`). Nothing by
    /// default: for methods that bind no CMO data.
    fn rebind_cmo(&mut self, _ctx: &GpuContext, _cmo: &CmoData) -> VkResult<()> {
        Ok(())
    }

    /// The method's passes after the G-buffer, each in its scope; they write the records.
    fn record(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()>;

    /// The statistics of the last frame; none by default.
    fn read_stats(&self, _ctx: &GpuContext) -> VkResult<MethodStats> {
        Ok(MethodStats::default())
    }

    /// The method's own BVH passes (`bvh`): the bounce rounds share its tracer and the frame
    /// reports its counter.
    fn bvh(&self) -> Option<&BvhPasses> {
        None
    }

    /// Whether the method traces the rounds of `--bounces` after its first
    /// ([`Technique::record_round`]); by default the BVH traces them.
    fn traces_rounds(&self) -> bool {
        false
    }

    /// Traces the rays of a round of `--bounces` (`queue`: `BvhRay`s, its dispatch sized) and
    /// writes their records, leaving unresolved the rays it cannot answer; the reflector check
    /// and the fallback follow ([`crate::vk::passes::bounce`]). Only where
    /// [`Technique::traces_rounds`].
    fn record_round(&self, _rec: &Recorder<'_>, _queue: &BvhQueue) -> VkResult<()> {
        Err(crate::vk::backend::error::VkError::Usage {
            what: "bounce round".into(),
            detail: "the method does not trace bounce rounds".into(),
        })
    }
}

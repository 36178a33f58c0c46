//! One frame on the GPU, recorded as a short list of named passes into one command buffer: the
//! shared stages around one method ([`super::methods`], a [`Technique`]).
//!
//! | pass | reads | writes |
//! |---|---|---|
//! | `capture` (where [`Needs::capture`](super::methods::Needs::capture): every method but `bvh`; the CMO stages run on the first frame and again only when their input changes, [`GpuRenderer::set_camera`], [`GpuRenderer::update_geometry`]) | scene | CMO distance, colour and/or triangle IDs (+ normal/mirror with self-reflections) |
//! | `capture` with `--criterion bounded` ([`super::passes::capture_lists`]: jobs, texels, resolve; or the lists built on the CPU and uploaded at creation, [`GpuRenderer::with_lists`]) | scene | CMO distance (`lo`), the per-texel records and node pool, a `u32` word per binding ([`super::passes::lists`]) |
//! | `pyramid` (where [`Needs::pyramid`](super::methods::Needs::pyramid): `fragment`) | CMO distance | CMO 2x2 min/max pyramid |
//! | the method's CMO stage: `hier32` (`compute`) | CMO distance | its 8x4/4x8 min/max hierarchy |
//! | `gbuffer` | scene | G-buffer colour, position + mirror mask, normal |
//! | the method's passes: `fragment_trace`, `envmap`, `append` + `dispatch_args` + `compute_trace`, `ssr_hiz` + `ssr`, `reflection_point_targets` + `reflection_point_search` + `reflection_point_raster`, or `bvh_queue` + `bvh_trace` | G-buffer, what the method reads | one [`PixelRecord`] per mirror pixel |
//! | `reflector_check` (where [`Method::has_reflector_check`]; off with `--no-reflector-check`) | G-buffer, records, reflectors' CWBVH, scene | resolved records whose ray meets a reflector nearer, traced exactly ([`ReflectorCheck`]) |
//! | `fallback` (`--fallback trace`, where [`Method::can_leave_unresolved`]) | G-buffer, records, CWBVH, scene | unresolved records finished by `bvh_queue` + `bvh_trace` |
//! | `bounce_append` (`--bounces N`, N != 1) | G-buffer, records, CWBVH, scene | N = 0: the mirrors' own material (instead of the method's passes and the two above); N >= 2: rounds 2..=N, each `bounce_append` + `bvh_queue` (`args`) + `bvh_trace` ([`super::passes::bounce`]) |
//! | `cone_prefilter` (a glossy scene, where [`MethodSpec::glossy`](super::methods::MethodSpec::glossy): `fragment`, `compute`, `ssr`; with the CMO stages; and `compute`'s own 2x2 pyramid, `cone_pyramid`) | CMO colour (+ distance) | the pre-filtered colour chain `cmo_cone` ([`super::passes::cone`]) |
//! | `cone` (likewise; after the fallback) | G-buffer, records, CMO data, `cmo_cone`, the pyramid | the glossy pixels' record colour, cone traced |
//! | `composite` | G-buffer, records, CMO triangle IDs + scene (environment-map fallback) | final colour ([`Composite`]) |
//!
//! Each pass name is its WGSL file, its debug label and its timestamp scope, so
//! [`GpuFrame::pass_times`] lines up with the benchmark tables. Everything a frame needs is
//! allocated once in [`GpuRenderer::new`]; [`GpuRenderer::render`] only records, submits and
//! reads back, so repeated renders (the harness) measure the passes, not allocation. A sequence
//! keeps the renderer: [`GpuRenderer::set_camera`] where the camera moves,
//! [`GpuRenderer::update_geometry`] where meshes or CMO centres move (the buffers derived from
//! the geometry rewritten, the pipelines kept; a BVH, closure or list pool that outgrows its
//! buffer gets a new one, bound in its place).
//!
//! Only what the options use is allocated: the method allocates its own passes
//! ([`MethodSpec::create`](super::methods::MethodSpec::create)) and says what it needs of the CMOs ([`MethodSpec::needs`](super::methods::MethodSpec::needs): their
//! contents, the pyramid; `bvh` none, so its CMO data is a one-texel placeholder that composite
//! binds and no capture runs); the trace fallback's BVH only for `--fallback trace`, the bounce
//! queues for N >= 2 only (one BVH shared with the method's or the fallback's); the reflector
//! check's BVH and queue only where [`crate::scene::Scene::check_triangles`] is not empty.
//!
//! # Files
//!
//! - `mod.rs`: the renderer's type ([`GpuRenderer`]), its accessors, and the names the harness
//!   reads (pass names, timestamp scopes);
//! - `gpu_frame.rs`: the frame read back ([`GpuFrame`]) and what the metrics read of it;
//! - `plan.rs`: the frame plan ([`FramePlan`]): which stages a frame allocates and at what
//!   sizes, decided once for creation and for the memory estimate;
//! - `create.rs`: the checks before anything is allocated, [`GpuRenderer::new`] and its variants
//!   for tests, and the helpers the updates share with creation;
//! - `stages.rs`: the shared stages around the method (the CMO stages, the cone stage, the
//!   reflector check, the fallback and the bounce rounds);
//! - `update.rs`: the camera, sample-key and geometry updates in place;
//! - `record.rs`: recording and submitting a frame ([`GpuRenderer::render`]);
//! - `read_back.rs`: reading the frame back;
//! - `hooks.rs`: the tests' hooks (`test-hooks` feature only).
//!
//! # What holds for every frame
//!
//! Invariants:
//! - The records are the contract between a method and the rest: every method writes the same
//!   `PixelRecord` layout (`spirv/shared/record.wgsl`), and the metrics, the composite and the EXR
//!   read nothing else of it.
//! - Every reflected ray starts on the reference's primary ray: the G-buffer meets the pixel
//!   centre's ray (`Camera::ray`'s operations, `spirv/shared/camera.wgsl`) with the rasterised
//!   triangle's plane, its barycentrics giving the normal. The rasteriser's own interpolation, from
//!   vertices snapped to its sub-pixel grid, had been 1e-6 off and sent grazing rays into the
//!   neighbouring facet (scene `default`: 44.2 -> 47.3 dB over mirror pixels).
//! - No pixel is left unresolved with `--fallback trace` (the default): the fallback queues the
//!   unresolved records' rays (`append_unresolved`: an atomic counter, a dispatch sized on the GPU)
//!   and the BVH tracer finishes them from the mirror under the start rule, not from the cubemap's
//!   `t_done`: that prefix is empty for the cubemap's model, not for the triangles. Started at
//!   `t_done`, 26 of 410 fallback rays at 96x72 missed the reference's hit, each before `t_done`.
//! - Memory is estimated (`vk::budget::estimate`) and refused before anything is allocated.
//!
//! The reflector check (fragment and compute; off with `--no-reflector-check`). The CMOs do not
//! capture the reflectors, or only their parts that face a CMO centre, so a mirror ray that should
//! meet a reflector (the torus or teapot in itself, one mirror in another) passes through it and
//! reports a real hit behind. After the tracing pass and before the fallback, the resolved rays
//! that can meet a reflector are traced again against a second CWBVH over the reflectors only; a
//! nearer hit replaces the record (`checked` = 1). A record whose hit is the ray's own start becomes
//! unresolved again (`checked` = 2) and the fallback traces it in full. Which rays
//! (`Scene::check_below`): all of them when the scene has several reflectors or a non-convex one;
//! with one convex reflector only those that leave below a face's plane,
//! `d . n < 2 sin(theta / 2) + 2^-10` with `theta` the largest angle between a face's normal and its
//! vertex normals (1 to 2 % of the rays of `default`). Measured on lavapipe (bench `--quick`,
//! 320x240, compute, without -> with): same triangle torus 94.5 -> 100 %, teapot 96.4 -> 99.99 %;
//! PSNR torus 24 -> 51 dB, teapot 25 -> 48 dB; cost 1 to 10 ms per frame on lavapipe. The CPU twins
//! model the tracing pass alone: twin tests compare records with the check off. Under the
//! bounded criterion a reflector that the capture takes is in the lists, with sound bounds, and
//! is not checked (`Scene::check_reflectors`): the mug and the glossy corpus scene, 3.6 and 5.4
//! ms of check on lavapipe, the 32 bounded EXRs the same without it.
//!
//! Self-reflections are decided per reflector (`self_reflections = "auto"`: exactly when it is not
//! convex, some vertex in front of some face's plane). A captured reflector is captured only where
//! it faces the CMO centre, so that it does not hide the scene from a CMO inside it. The built-in
//! torus and bowl pin it off: from their one CMO their captured inner sides hide the room (84 % and
//! 50 % of mirror pixels unresolved at 320x240 under auto, against 0.4 % and 0.3 % off).
//!
//! How the shared stages and the frame are checked (each comparison with a negative that must
//! fail):
//! - Capture against a CPU ray-cast capture of the same CMO (`cpu::capture::capture`):
//!   distances within 1e-4 relative and colours within 1e-3, except texels whose centre ray
//!   grazes a triangle edge (0 to 0.05 % measured, bound 1 %). Negative: a moved centre or
//!   swapped faces.
//! - G-buffer against the reference's primary hits (mask, position, colour per pixel); its start
//!   points within 9.3 f32 roundings of `|eye| + t` and 2.6e-5 rad of the reference's normal
//!   (negative: an eye moved by 1e-5 of the scene).
//! - Pyramid and hierarchy against their CPU builds, bit for bit, for sizes 1 to 64 and several
//!   CMOs.
//! - Hard cases: each mirror pixel's own reflected ray traced exactly through the scene; the record
//!   must agree (within two texel footprints, or the texel the model resolves, its triangle met by
//!   the ray in f64) or say unresolved. Zero wrong hits on the fragment and compute paths, both
//!   twins and `--strict`: scales 1e-3 and 1e4, cube sizes 32 and 2048, a reflector covering the
//!   frame or none of it, a CMO centre on the mirror or inside an object, slabs thinner than a
//!   texel, NaN and zero normals, grazing incidence, rays on shared edges and vertices, zero-area
//!   triangles. At cube sizes 1 to 3, 3 to 5 of 170 rays are verified on a floor no texel sees.
//! - Depth range: a scene spanning 1e-3 to 1e5 on both cubemap paths against the reference (the
//!   former near plane of 1e-4 x far left no mirror pixel). A resource the device cannot bind is
//!   refused with a message naming the buffer and the limit.
//! - Accuracy per built-in scene against the reference, with stated bounds on unresolved and
//!   wrong-surface shares and PSNR; frames perturbed in known ways must fail them.

mod create;
mod gpu_frame;
#[cfg(feature = "test-hooks")]
mod hooks;
pub mod plan;
mod read_back;
mod record;
mod stages;
mod update;

pub use super::passes::bounce::RoundCount;
pub use gpu_frame::{GpuFrame, shown_objects};
#[cfg(feature = "test-hooks")]
pub use hooks::live_allocations;
pub use plan::FramePlan;

use std::any::Any;

use glam::Vec3;

use super::backend::buffer::Buffer;
use super::backend::shaders::Pass;
use super::backend::timestamps::Timestamps;
use super::methods::compute::ComputePath;
use super::methods::reflection_point::ReflectionPointPasses;
use super::methods::ssr::SsrPasses;
use super::methods::{self, Technique};
use super::passes::bounce::BouncePasses;
use super::passes::bvh::{BvhPasses, ReflectorCheck};
use super::passes::capture::Capture;
use super::passes::capture_lists::CaptureLists;
use super::passes::cmo::{CaptureContents, CmoData};
use super::passes::composite::Composite;
use super::passes::cone::{ConePrefilter, ConePrefilterBindings, ConeStage};
use super::passes::gbuffer::Gbuffer;
use super::passes::pyramid::{Pyramid, PyramidBindings};
use super::passes::scene_buffers::SceneBuffers;
use crate::camera::Camera;
use crate::cpu::options::TraceOptions;
use crate::method::Method;
use crate::ranges::FrameRanges;
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;

pub use super::options::{ComputeLayout, Fallback, RenderOptions};
pub use super::passes::records::{
    FLAG_COLOUR, FrameParams, PixelRecord, RECORD_ESCAPED, RECORD_HIT, RECORD_UNRESOLVED,
};

/// The tracing pass of a GPU method (its timestamp scope in the harness's tables).
pub fn trace_pass(method: Method) -> &'static Pass {
    match methods::spec(method) {
        Some(spec) => spec.trace_pass(),
        None => unreachable!("the reference is no GPU method: GpuRenderer::new refuses it"),
    }
}

/// The tracing pass's name of a GPU method.
pub fn pass_name(method: Method) -> &'static str {
    trace_pass(method).name
}

/// What the capture writes for a frame of `method` with tracer options `trace`
/// ([`MethodSpec::needs`](super::methods::MethodSpec::needs): CMO memory holds only what is read, and the memory estimate,
/// `super::budget`, uses the same rule). The reference, no GPU method, would take the IDs.
pub fn capture_contents(method: Method, trace: &TraceOptions) -> CaptureContents {
    match methods::spec(method) {
        Some(spec) => spec.needs(trace).contents,
        None => CaptureContents {
            colour: false,
            triangle_ids: true,
        },
    }
}

/// The timestamp scope of [`Fallback::Trace`]'s passes (`bvh_queue`'s `append_unresolved` and
/// `args`, then `bvh_trace`), timed apart from the tracing pass.
pub const FALLBACK_PASS: &str = "fallback";

/// The timestamp scope of the reflector check ([`ReflectorCheck`]: `bvh_queue`'s
/// `append_check` and `args`, then `bvh_trace` over the reflectors' BVH).
pub const REFLECTOR_CHECK_PASS: &str = "reflector_check";

/// The pass name of the `--bounces` rounds after the first (its timestamp scope).
pub const BOUNCE_PASS: &str = crate::vk::backend::shaders::BOUNCE_APPEND.name;

/// Depth range and ray length for a scene seen by a camera: `(near, far, t_hi)` of
/// [`FrameRanges`] (the G-buffer's near plane, the scene's far extent from the eye, which is no
/// clip plane, and the ray length), without the precision check.
pub fn scene_ranges(scene: &Scene, camera: &Camera) -> (f32, f32, f32) {
    let r = FrameRanges::new(scene, camera);
    (r.near, r.far, r.t_hi)
}

/// Everything one scene + camera + options needs on the GPU, allocated once.
pub struct GpuRenderer {
    options: RenderOptions,
    background: Vec3,
    width: u32,
    height: u32,
    _scene: SceneBuffers,
    cmo: CmoData,
    /// The cone pass's own CMOs, where the `bounded` lists take a size of their own on a glossy
    /// scene (`CmoPlan::cone_size`): the colour capture fills them, the cone pass reads them.
    cone_cmo: Option<CmoData>,
    /// `None` where the method reads no CMO ([`Needs::capture`](super::methods::Needs::capture)): the CMO data is then a
    /// one-texel placeholder, initialised at creation.
    capture: Option<CmoCapture>,
    /// `--criterion bounded` on a glossy scene: the rasterised capture that fills the CMO colour
    /// the cone pass pre-filters (the lists' capture keeps none), recorded before the lists'
    /// capture, which then writes its own distances over this one's.
    colour_capture: Option<Box<Capture>>,
    pyramid: Vec<(Pyramid, PyramidBindings)>,
    /// The pre-filtered CMO colour chain (`cone_prefilter`), where the method reads it on a
    /// glossy scene ([`MethodSpec::glossy`](super::methods::MethodSpec::glossy)).
    cone_prefilter: Option<(ConePrefilter, ConePrefilterBindings)>,
    gbuffer: Gbuffer,
    method: Box<dyn Technique>,
    /// [`RenderOptions::reflector_check`] where the method and the scene need it.
    check: Option<ReflectorCheck>,
    /// [`Fallback::Trace`]'s passes, where the method can leave a record unresolved.
    fallback: Option<BvhPasses>,
    /// `bounces` != 1 ([`super::passes::bounce`]).
    bounce: Option<BouncePasses>,
    /// Cone tracing of the glossy pixels (fragment, compute; a scene with a glossy reflector
    /// only): [`super::passes::cone`].
    cone: Option<ConeStage>,
    /// The tests' frame without the `cone` pass (`skip_cone`, `test-hooks` only).
    cone_skipped: bool,
    composite: Composite,
    params: Buffer,
    records: Buffer,
    timestamps: Option<Timestamps>,
    /// The scene as uploaded: the reflectors' screen rectangle and the methods' camera state
    /// are derived from it again by [`GpuRenderer::set_camera`].
    data: GpuSceneData,
    /// The camera the passes are set for, and its ranges ([`FrameRanges`]; the jitter plays no
    /// part in them, so a camera that differs only there keeps them).
    local_camera: Camera,
    ranges: FrameRanges,
    /// The origin of the GPU's coordinates ([`crate::ranges::anchor`], fixed at creation): the
    /// scene, the cameras and the CMO centres are uploaded relative to it
    /// ([`Scene::rebased`]), and the positions read back are moved back by it. Zero for a scene
    /// near the world origin.
    anchor: Vec3,
    /// The camera as the caller gave it ([`GpuRenderer::camera`]); `local_camera` is it
    /// relative to `anchor`.
    camera: Camera,
    /// Whether the CMO data holds the capture of the current inputs (the scene and
    /// `ranges.capture_near`): [`GpuRenderer::render`] records the CMO stages only where not.
    cmo_valid: bool,
    /// The film's sample key in `FrameParams` ([`GpuRenderer::set_sample`]).
    sample: u32,
    /// [`Scene::check_triangles`] at creation: the reflector check's BVH is built over them.
    check_triangles: Vec<u32>,
    /// Whether the bounded criterion's lists were uploaded at creation
    /// ([`GpuRenderer::with_lists`]): the renderer has no capture of its own, and its geometry
    /// moves only with lists given ([`GpuRenderer::update_geometry_with_lists`]).
    lists_uploaded: bool,
    /// Whether the CMO data holds lists uploaded since the last frame: its CMO stages run
    /// without the lists' capture.
    lists_pending: bool,
    /// What creation allocated ([`FramePlan`], the plan the memory estimate counts).
    plan: FramePlan,
}

/// What an update leaves stale: the tests' negative (`update_geometry_leaving`, `test-hooks`
/// only); the renderer's own updates leave nothing.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StaleUpdate {
    /// The scene's vertex buffer.
    Vertices,
    /// Every BVH (the method's, the fallback's, the bounce rounds', the reflector check's).
    Bvh,
}

/// The pass that fills the CMO data: the rasterised capture, or (`--criterion bounded`) the
/// capture of the per-texel bounds and candidate lists.
enum CmoCapture {
    Raster(Box<Capture>),
    Lists(Box<CaptureLists>),
}

impl GpuRenderer {
    /// Makes the next frame run the CMO stages again (capture, pyramid, the method's CMO stage)
    /// though their inputs did not change: the bench times whole frames.
    pub fn invalidate_capture(&mut self) {
        self.cmo_valid = false;
    }

    /// Whether frames run a capture at all (not `bvh`, not uploaded lists).
    pub fn captures(&self) -> bool {
        self.capture.is_some()
    }

    /// Whether the bounded criterion's lists were uploaded at creation instead of captured
    /// ([`GpuRenderer::with_lists`], [`GpuRenderer::with_built_lists`]).
    pub fn lists_uploaded(&self) -> bool {
        self.lists_uploaded
    }

    /// The camera the passes are set for (as the caller gave it, in world coordinates).
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The cone stage, where the frame has one (a glossy scene, fragment or compute).
    pub fn cone(&self) -> Option<&ConeStage> {
        self.cone.as_ref()
    }

    /// The CMO data (for reading the captures back).
    pub fn cmo(&self) -> &CmoData {
        &self.cmo
    }

    /// The cone pass's own CMO data, where the plan has it (`CmoPlan::cone_size`).
    pub fn cone_cmo(&self) -> Option<&CmoData> {
        self.cone_cmo.as_ref()
    }

    /// The method's passes as type `T` (`None` for another method's).
    fn method_as<T: Technique>(&self) -> Option<&T> {
        let any: &dyn Any = self.method.as_ref();
        any.downcast_ref()
    }

    /// The compute path's passes (`--method compute` only).
    pub fn compute_path(&self) -> Option<&ComputePath> {
        self.method_as()
    }

    /// The screen-space method's passes (`--method ssr` only).
    pub fn ssr_passes(&self) -> Option<&SsrPasses> {
        self.method_as()
    }

    /// The reflection-point method's passes (`--method reflection-point` only).
    pub fn reflection_point_passes(&self) -> Option<&ReflectionPointPasses> {
        self.method_as()
    }

    /// The BVH passes (`--method bvh`'s or [`Fallback::Trace`]'s).
    pub fn bvh_passes(&self) -> Option<&BvhPasses> {
        self.method.bvh().or(self.fallback.as_ref())
    }

    /// The reflector check's passes, `None` where it does not run ([`ReflectorCheck`]).
    pub fn reflector_check(&self) -> Option<&ReflectorCheck> {
        self.check.as_ref()
    }

    /// The G-buffer (for reading it back in the tests).
    pub fn gbuffer(&self) -> &Gbuffer {
        &self.gbuffer
    }

    /// The plan the renderer was created by ([`FramePlan`]: what it allocated; a geometry
    /// update may grow the bounded capture's pool beyond its bound).
    pub fn plan(&self) -> &FramePlan {
        &self.plan
    }

    /// The options this renderer was built with.
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }
}

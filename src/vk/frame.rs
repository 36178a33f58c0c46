//! One frame on the GPU, recorded as a short list of named passes into one command buffer: the
//! shared stages around one method ([`super::methods`], a [`Technique`]).
//!
//! | pass | reads | writes |
//! |---|---|---|
//! | `capture` (where [`Needs::capture`]: every method but `bvh`; the CMO stages run on the first frame and again only when their input changes, [`GpuRenderer::set_camera`], [`GpuRenderer::update_geometry`]) | scene | CMO distance, colour and/or triangle IDs (+ normal/mirror with self-reflections) |
//! | `capture` with `--criterion bounded` ([`super::passes::capture_lists`]: jobs, texels, resolve; or the lists built on the CPU and uploaded at creation, [`GpuRenderer::with_lists`]) | scene | CMO distance (`lo`), the per-texel records and node pool, a `u32` word per binding ([`super::passes::lists`]) |
//! | `pyramid` (where [`Needs::pyramid`]: `fragment`) | CMO distance | CMO 2x2 min/max pyramid |
//! | the method's CMO stage: `hier32` (`compute`) | CMO distance | its 8x4/4x8 min/max hierarchy |
//! | `gbuffer` | scene | G-buffer colour, position + mirror mask, normal |
//! | the method's passes: `fragment_trace`, `envmap`, `append` + `dispatch_args` + `compute_trace`, `ssr_hiz` + `ssr`, `reflection_point_targets` + `reflection_point_search` + `reflection_point_raster`, or `bvh_queue` + `bvh_trace` | G-buffer, what the method reads | one [`PixelRecord`] per mirror pixel |
//! | `reflector_check` (where [`Method::has_reflector_check`]; off with `--no-reflector-check`) | G-buffer, records, reflectors' CWBVH, scene | resolved records whose ray meets a reflector nearer, traced exactly ([`ReflectorCheck`]) |
//! | `fallback` (`--fallback trace`, where [`Method::can_leave_unresolved`]) | G-buffer, records, CWBVH, scene | unresolved records finished by `bvh_queue` + `bvh_trace` |
//! | `bounce_append` (`--bounces N`, N != 1) | G-buffer, records, CWBVH, scene | N = 0: the mirrors' own material (instead of the method's passes and the two above); N >= 2: rounds 2..=N, each `bounce_append` + `bvh_queue` (`args`) + `bvh_trace` ([`super::passes::bounce`]) |
//! | `cone_prefilter` (a glossy scene, where [`MethodSpec::glossy`]: `fragment`, `compute`, `ssr`; with the CMO stages; and `compute`'s own 2x2 pyramid, `cone_pyramid`) | CMO colour (+ distance) | the pre-filtered colour chain `cmo_cone` ([`super::passes::cone`]) |
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
//! ([`MethodSpec::create`]) and says what it needs of the CMOs ([`MethodSpec::needs`]: their
//! contents, the pyramid; `bvh` none, so its CMO data is a one-texel placeholder that composite
//! binds and no capture runs); the trace fallback's BVH only for `--fallback trace`, the bounce
//! queues for N >= 2 only (one BVH shared with the method's or the fallback's); the reflector
//! check's BVH and queue only where [`crate::scene::Scene::check_triangles`] is not empty.
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
//! model the tracing pass alone: twin tests compare records with the check off.
//!
//! Self-reflections are decided per reflector (`self_reflections = "auto"`: exactly when it is not
//! convex, some vertex in front of some face's plane). A captured reflector is captured only where
//! it faces the CMO centre, so that it does not hide the scene from a CMO inside it. The built-in
//! torus and bowl pin it off: from their one CMO their captured inner sides hide the room (84 % and
//! 50 % of mirror pixels unresolved at 320x240 under auto, against 0.4 % and 0.3 % off).
//!
//! How the shared stages and the frame are checked (each comparison with a negative that must
//! fail):
//! - Capture against a CPU ray-cast capture of the same CMO (`reference::capture`): distances within
//!   1e-4 relative and colours within 1e-3, except texels whose centre ray grazes a triangle edge
//!   (0 to 0.05 % measured, bound 1 %). Negative: a moved centre or swapped faces.
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
use std::any::Any;
use std::borrow::Cow;

use ash::vk;
use glam::{Vec3, Vec4};
use gpu_allocator::MemoryLocation;

use super::backend::buffer::Buffer;
use super::backend::context::{GpuContext, Recorder};
use super::backend::error::{VkError, VkResult};
use super::backend::shaders::{BOUNCE_APPEND, CONE_PREFILTER, Pass};
use super::backend::sync::{ALL, SHADER_READ, SHADER_WRITE, TRANSFER_WRITE};
use super::backend::timestamps::{PassTime, Timestamps};
use super::methods::compute::{ComputePath, ComputeStats};
use super::methods::reflection_point::ReflectionPointPasses;
use super::methods::ssr::SsrPasses;
use super::methods::technique::{Glossy, has_glossy_reflector};
use super::methods::{self, FrameInputs, GeometryInputs, MethodSpec, Needs, Scope, Technique};
use super::passes::bounce::{BouncePasses, MAX_BOUNCES};
use super::passes::bvh::{AppendKind, BvhCounter, BvhPasses, ReflectorCheck};
use super::passes::capture::Capture;
use super::passes::capture_lists::{self, CaptureLists, ListCounters, ListTargets};
use super::passes::cmo::{CaptureContents, CmoData};
use super::passes::composite::Composite;
use super::passes::cone::{ConePrefilter, ConePrefilterBindings, ConeStage};
use super::passes::gbuffer::Gbuffer;
use super::passes::lists::PackedLists;
use super::passes::pyramid::{Pyramid, PyramidBindings};
use super::passes::scene_buffers::SceneBuffers;
use crate::camera::Camera;
use crate::cpu::options::{TraceCriterion, TraceOptions};
use crate::cpu::reflection_point::SearchStats;
use crate::cubemap::bounds::DEFAULT_DEPTH;
use crate::method::Method;
use crate::metrics::Traced;
use crate::ranges::FrameRanges;
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;

pub use super::options::{Fallback, RenderOptions};
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
/// ([`MethodSpec::needs`]: CMO memory holds only what is read, and the memory estimate,
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

/// A rendered frame read back from the GPU, row-major, row 0 at the top.
#[derive(Clone, Debug)]
pub struct GpuFrame {
    pub width: u32,
    pub height: u32,
    /// Final linear colour.
    pub colour: Vec<Vec3>,
    /// 1 on mirror pixels.
    pub mask: Vec<u8>,
    /// The point the camera sees (NaN where nothing).
    pub surface_position: Vec<Vec3>,
    /// Per pixel; meaningful where `mask` is 1.
    pub records: Vec<PixelRecord>,
    /// GPU time per pass, in recording order.
    pub pass_times: Vec<PassTime>,
    /// The BVH queue's counter: rays traced and rays cut by the loop cap ([`Method::Bvh`]:
    /// every mirror ray; [`Fallback::Trace`]: the fallback rays).
    pub bvh: Option<BvhCounter>,
    /// The lists' capture counters (`--criterion bounded`: nodes, what a full pool or job buffer
    /// dropped, walks capped; each dropped entry made its texel unknown from its `lo` on).
    pub lists: Option<ListCounters>,
    /// Ray count, subgroup size and per-ray counters ([`Method::Compute`] only).
    pub compute: Option<ComputeStats>,
    /// Iteration counts of the searches ([`Method::ReflectionPoint`] only).
    pub search: Option<SearchStats>,
    /// Whether this frame ran the CMO stages (capture, pyramid, the method's CMO stage): the
    /// first frame and the first after [`GpuRenderer::set_camera`] changed what the capture
    /// depends on or [`GpuRenderer::update_geometry`] moved the geometry; never for a method
    /// that captures nothing (`bvh`) or uploaded lists.
    pub captured: bool,
}

impl GpuFrame {
    /// The frame as the error metrics read it: hit points where the method hit something,
    /// resolved where it hit or escaped.
    pub fn traced(&self) -> Traced {
        let mirror = |k: usize| self.mask[k] != 0;
        Traced {
            width: self.width,
            height: self.height,
            colour: self.colour.clone(),
            mask: self.mask.clone(),
            hit_position: (0..self.records.len())
                .map(|k| {
                    let r = &self.records[k];
                    if mirror(k) && r.status == RECORD_HIT {
                        Vec3::from_array(r.point)
                    } else {
                        Vec3::NAN
                    }
                })
                .collect(),
            resolved: (0..self.records.len())
                .map(|k| u8::from(mirror(k) && self.records[k].status != RECORD_UNRESOLVED))
                .collect(),
            // Verified hits name their triangle; other methods leave `u32::MAX` everywhere.
            triangle: self
                .records
                .iter()
                .enumerate()
                .any(|(k, r)| mirror(k) && r.status == RECORD_HIT && r.triangle != u32::MAX)
                .then(|| {
                    (0..self.records.len())
                        .map(|k| {
                            let r = &self.records[k];
                            if mirror(k) && r.status == RECORD_HIT {
                                r.triangle
                            } else {
                                u32::MAX
                            }
                        })
                        .collect()
                }),
            fallback: self.bvh.is_some().then(|| {
                (0..self.records.len())
                    .map(|k| u8::from(mirror(k) && self.records[k].fallback != 0))
                    .collect()
            }),
            bounces: Some(
                (0..self.records.len())
                    .map(|k| {
                        if mirror(k) {
                            self.records[k].bounces
                        } else {
                            0
                        }
                    })
                    .collect(),
            ),
        }
    }

    /// Mirror pixels whose record the reflector check changed (0 without it).
    pub fn checked_pixels(&self) -> usize {
        (0..self.records.len())
            .filter(|&k| self.mask[k] != 0 && self.records[k].checked != 0)
            .count()
    }

    /// Mirror pixels whose method hit the reflector check found at the ray's own start and
    /// handed to the fallback (`checked` = 2).
    pub fn start_hit_pixels(&self) -> usize {
        (0..self.records.len())
            .filter(|&k| self.mask[k] != 0 && self.records[k].checked == 2)
            .count()
    }

    /// Mirror pixels the `trace` fallback finished (0 without it).
    pub fn fallback_pixels(&self) -> usize {
        (0..self.records.len())
            .filter(|&k| self.mask[k] != 0 && self.records[k].fallback != 0)
            .count()
    }

    /// Mirror pixels.
    pub fn mirror_pixels(&self) -> usize {
        self.mask.iter().filter(|&&m| m != 0).count()
    }

    /// GPU nanoseconds of the pass `name` (0 if it did not run).
    pub fn pass_ns(&self, name: &str) -> f64 {
        self.pass_times
            .iter()
            .filter(|(n, _)| n == name)
            .map(|(_, t)| t)
            .sum()
    }
}

/// Refuses what the method cannot do ([`Method::check_bounces`], [`Method::check_trace`]) and
/// the reference, which is no GPU method.
fn check_method(options: &RenderOptions) -> VkResult<&'static dyn MethodSpec> {
    let refuse = |what: &str, detail: String| {
        Err(VkError::Usage {
            what: what.into(),
            detail,
        })
    };
    let Some(spec) = methods::spec(options.method) else {
        return refuse(
            "method",
            "--method reference runs on the CPU (crate::reference), not in the GPU renderer".into(),
        );
    };
    if let Err(e) = options
        .method
        .check_bounces(options.bounces, MAX_BOUNCES, &options.trace)
    {
        return refuse("bounces", e);
    }
    if let Err(e) = options.method.check_trace(&options.trace) {
        return refuse("method", e);
    }
    Ok(spec)
}

/// [`FrameRanges::check`] for the method of `options`: the CMO centres' checks only where it
/// captures CMOs ([`Needs::capture`]).
fn check_ranges(ranges: &FrameRanges, scene: &Scene, options: &RenderOptions) -> VkResult<()> {
    let cmos = check_method(options)?.needs(&options.trace).capture;
    ranges.check(scene, cmos).map_err(|e| VkError::Usage {
        what: "depth range".into(),
        detail: e.to_string(),
    })
}

/// The frame's timestamp queries, where the device has them.
fn frame_timestamps(ctx: &GpuContext) -> VkResult<Option<Timestamps>> {
    if ctx.report().timestamps_supported() {
        Ok(Some(Timestamps::new(ctx, 14)?))
    } else {
        log::info!("no timestamp queries on this device: pass times are not measured");
        Ok(None)
    }
}

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
    /// `None` where the method reads no CMO ([`Needs::capture`]): the CMO data is then a
    /// one-texel placeholder, initialised at creation.
    capture: Option<CmoCapture>,
    /// `--criterion bounded` on a glossy scene: the rasterised capture that fills the CMO colour
    /// the cone pass pre-filters (the lists' capture keeps none), recorded before the lists'
    /// capture, which then writes its own distances over this one's.
    colour_capture: Option<Box<Capture>>,
    pyramid: Option<(Pyramid, PyramidBindings)>,
    /// The pre-filtered CMO colour chain (`cone_prefilter`), where the method reads it on a
    /// glossy scene ([`MethodSpec::glossy`]).
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
    /// ([`GpuRenderer::with_lists`]): they do not follow the geometry.
    lists_uploaded: bool,
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

/// What [`GpuRenderer::update_geometry`] writes (its `geometry_plan`): the scene as uploaded,
/// its ranges and CMO centres, and the bounded capture's views and capacities.
struct GeometryPlan {
    data: GpuSceneData,
    ranges: FrameRanges,
    centres: Vec<Vec3>,
    lists: Option<(Vec<(Vec3, bool)>, crate::cubemap::bounds::PoolBound)>,
}

/// The stages before the G-buffer that the CMOs need: their data, the capture and the
/// pyramid, as the method's [`Needs`] say.
struct CmoStages {
    cmo: CmoData,
    capture: Option<CmoCapture>,
    colour_capture: Option<Box<Capture>>,
    pyramid: Option<(Pyramid, PyramidBindings)>,
    cone_prefilter: Option<(ConePrefilter, ConePrefilterBindings)>,
}

/// The pass that fills the CMO data: the rasterised capture, or (`--criterion bounded`) the
/// capture of the per-texel bounds and candidate lists.
enum CmoCapture {
    Raster(Box<Capture>),
    Lists(Box<CaptureLists>),
}

impl CmoStages {
    /// `gpu`: the scene's data and its buffers. With `--criterion bounded` the capture is the
    /// lists' (`passes::capture_lists`: per-texel bounds and candidate lists, their `lo` as the
    /// distances, node pool sized by its CPU bound), or for tests the lists built on the CPU
    /// (`lists`), uploaded once.
    fn new(
        ctx: &GpuContext,
        scene: &Scene,
        gpu: (&GpuSceneData, &SceneBuffers),
        needs: &Needs,
        trace: &TraceOptions,
        capture_near: f32,
        lists: Option<&PackedLists>,
    ) -> VkResult<Self> {
        let centres = scene.cmo_centres();
        if !needs.capture {
            // One texel per face and no capture: composite binds the data, nothing reads it
            // but the environment-map fallback of a ray the BVH loop's cap cut.
            let cmo =
                CmoData::with_contents(ctx, &centres, 1, false, false, trace, needs.contents)?;
            ctx.submit_and_wait("cmo placeholder", |rec| {
                cmo.record_clear(rec);
                Ok(())
            })?;
            return Ok(CmoStages {
                cmo,
                capture: None,
                colour_capture: None,
                pyramid: None,
                cone_prefilter: None,
            });
        }
        let size = scene.cmo.resolution;
        let self_reflections = scene.captures_reflectors();
        let mut cmo = CmoData::with_contents(
            ctx,
            &centres,
            size,
            self_reflections,
            needs.pyramid,
            trace,
            needs.contents,
        )?;
        // The bounded criterion's lists keep no colour: where the frame reads it (the cone pass
        // of a glossy scene), a rasterised capture fills it first.
        let bounded = trace.criterion == TraceCriterion::Bounded;
        let raster = || {
            Capture::with_contents(
                ctx,
                gpu.1,
                &centres,
                size,
                self_reflections,
                capture_near,
                needs.contents,
            )
        };
        let colour_capture = if bounded && needs.contents.colour {
            let c = raster()?;
            if lists.is_some() {
                // The lists are uploaded once below: the colour is captured once, before.
                ctx.submit_and_wait("cmo colour", |rec| c.record(rec, &cmo, scene.background))?;
                None
            } else {
                Some(Box::new(c))
            }
        } else {
            None
        };
        let capture = if bounded {
            Self::list_capture(ctx, scene, gpu, &mut cmo, lists)?
        } else {
            Some(CmoCapture::Raster(Box::new(raster()?)))
        };
        let pyramid = pyramid_stage(ctx, &cmo, needs)?;
        Ok(CmoStages {
            cmo,
            capture,
            colour_capture,
            pyramid,
            cone_prefilter: None,
        })
    }

    /// `--criterion bounded`'s capture into `cmo` (see [`CmoStages::new`]); `None` where the
    /// lists were uploaded.
    fn list_capture(
        ctx: &GpuContext,
        scene: &Scene,
        (data, scene_buffers): (&GpuSceneData, &SceneBuffers),
        cmo: &mut CmoData,
        lists: Option<&PackedLists>,
    ) -> VkResult<Option<CmoCapture>> {
        if let Some(lists) = lists {
            ctx.submit_and_wait("cmo clear", |rec| {
                cmo.record_clear(rec);
                Ok(())
            })?;
            cmo.upload_lists(ctx, lists)?;
            return Ok(None);
        }
        let views = capture_lists::scene_views(scene);
        let capacity = capture_lists::capacity(data, &views, cmo.size());
        cmo.alloc_lists(ctx, capacity.nodes)?;
        let targets = ListTargets {
            distance: cmo.distance(),
            records: cmo.lists(),
            nodes: cmo.nodes(),
        };
        Ok(Some(CmoCapture::Lists(Box::new(CaptureLists::new(
            ctx,
            scene_buffers,
            cmo.size(),
            DEFAULT_DEPTH,
            &views,
            capacity,
            Some(targets),
        )?))))
    }
}

/// The pyramid pass over the CMO data's distances, where the method needs one.
fn pyramid_stage(
    ctx: &GpuContext,
    cmo: &CmoData,
    needs: &Needs,
) -> VkResult<Option<(Pyramid, PyramidBindings)>> {
    if !needs.pyramid {
        return Ok(None);
    }
    let p = Pyramid::new(ctx)?;
    let b = p.bind(ctx, cmo.distance(), cmo.mip(), cmo.count(), cmo.size())?;
    Ok(Some((p, b)))
}

/// Fragment's and compute's cone stage (`cone`: a glossy scene and one of them), after their
/// trace; `own_pyramid` where the method builds no 2x2 pyramid (compute).
fn cone_stage(
    ctx: &GpuContext,
    cone: bool,
    cmo: &CmoData,
    own_pyramid: bool,
    (gbuffer, params, records): (&Gbuffer, &Buffer, &Buffer),
) -> VkResult<Option<ConeStage>> {
    if !cone {
        return Ok(None);
    }
    ConeStage::new(ctx, cmo, own_pyramid, gbuffer, params, records).map(Some)
}

/// The `FrameParams` of a frame.
fn frame_params(scene: &Scene, camera: &Camera, options: &RenderOptions, t_hi: f32) -> FrameParams {
    let (right, up, back) = camera.basis();
    FrameParams {
        eye: camera.eye.to_array(),
        t_hi,
        background: scene.background.to_array(),
        width: camera.width,
        flag_colour: FLAG_COLOUR.to_array(),
        height: camera.height,
        fallback: match options.fallback {
            Fallback::Flag => 0,
            Fallback::Envmap => 1,
            Fallback::Background => 2,
            Fallback::Trace => 3,
            #[cfg(feature = "test-hooks")]
            Fallback::TraceFromTDone => 3,
        },
        check_below: scene.check_below(),
        tan_half: camera.tan_half_fov_y(),
        aspect: camera.aspect(),
        right: right.to_array(),
        up: up.to_array(),
        back: back.to_array(),
        jitter_x: camera.jitter.x,
        jitter_y: camera.jitter.y,
        ..FrameParams::default()
    }
}

/// The shared stages after the method's passes, where the options and the method use them.
struct AfterMethod {
    check: Option<ReflectorCheck>,
    fallback: Option<BvhPasses>,
    bounce: Option<BouncePasses>,
}

impl AfterMethod {
    /// `check_triangles`: [`Scene::check_triangles`], the reflector check's.
    fn new(i: &FrameInputs<'_>, check_triangles: &[u32], method: &dyn Technique) -> VkResult<Self> {
        let options = i.options;
        let fallback = fallback_passes(i)?;
        let check = if options.reflector_check && options.method.has_reflector_check() {
            ReflectorCheck::new(
                i.ctx,
                check_triangles,
                i.data,
                i.scene,
                i.gbuffer,
                i.params,
                i.records,
                i.t_hi,
            )?
        } else {
            None
        };
        let bounce = if options.bounces == 1 {
            None
        } else {
            // One BVH for the method's, the fallback's and the bounce rounds' rays.
            let shared = method.bvh().or(fallback.as_ref()).map(|b| &b.tracer);
            Some(BouncePasses::new(
                i.ctx,
                options.bounces,
                i.data,
                i.scene,
                i.gbuffer,
                i.params,
                i.records,
                shared,
                i.t_hi,
            )?)
        };
        Ok(AfterMethod {
            check,
            fallback,
            bounce,
        })
    }
}

/// [`Fallback::Trace`]'s BVH passes, where the method can leave a record unresolved
/// ([`Method::can_leave_unresolved`]).
fn fallback_passes(inputs: &FrameInputs<'_>) -> VkResult<Option<BvhPasses>> {
    let kind = match inputs.options.fallback {
        Fallback::Trace => AppendKind::Unresolved,
        #[cfg(feature = "test-hooks")]
        Fallback::TraceFromTDone => AppendKind::UnresolvedFromTDone,
        Fallback::Flag | Fallback::Envmap | Fallback::Background => return Ok(None),
    };
    if !inputs.options.method.can_leave_unresolved() {
        return Ok(None);
    }
    let i = inputs;
    BvhPasses::new(
        i.ctx, kind, i.data, i.scene, i.gbuffer, i.params, i.records, i.t_hi,
    )
    .map(Some)
}

impl GpuRenderer {
    /// Uploads the scene and creates every pass for `camera` (its width and height are the
    /// frame's). Depth ranges and ray length come from [`FrameRanges`]; a scene beyond f32
    /// precision is refused ([`FrameRanges::check`]).
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
    ) -> VkResult<Self> {
        let anchor = crate::ranges::anchor(scene);
        let (local, local_camera) = rebased(anchor, scene, camera);
        let ranges = FrameRanges::new(&local, &local_camera);
        check_ranges(&ranges, &local, &options)?;
        let mut r = Self::create(ctx, &local, &local_camera, options, &ranges, None)?;
        (r.anchor, r.camera) = (anchor, camera.clone());
        Ok(r)
    }

    /// [`GpuRenderer::new`] with the given ranges and no precision check, in world coordinates
    /// (no [`crate::ranges::anchor`]): for tests that show what other ranges do.
    pub fn with_ranges(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
        ranges: &FrameRanges,
    ) -> VkResult<Self> {
        Self::create(ctx, scene, camera, options, ranges, None)
    }

    /// [`GpuRenderer::new`] for `--criterion bounded` with the per-texel lists built on the
    /// CPU in the GPU layout (`vk::passes::lists::pack` of one
    /// [`TexelLists`](crate::cubemap::bounds::TexelLists) per CMO in [`Scene::cmo_centres`]
    /// order, of the scene's face size), uploaded instead of a capture
    /// ([`CmoData::upload_lists`]).
    pub fn with_lists(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
        lists: &PackedLists,
    ) -> VkResult<Self> {
        let ranges = FrameRanges::new(scene, camera);
        check_ranges(&ranges, scene, &options)?;
        Self::create(ctx, scene, camera, options, &ranges, Some(lists))
    }

    /// Points every pass at `camera` (the frame size of creation, else [`VkError::Usage`]): the
    /// frame params, the G-buffer's matrix and near plane, the reflectors' screen rectangle and
    /// the method's own camera state ([`Technique::set_camera`]). The next frame is bit for bit
    /// that of [`GpuRenderer::new`] for `scene` and `camera`; `scene` must be the one the
    /// renderer was created for, but for its cameras. The CMO stages run again only where their
    /// input changed: the capture's near plane ([`FrameRanges::capture_near`], which depends on
    /// the eye through its floor); [`GpuFrame::captured`] says whether a frame ran them.
    pub fn set_camera(&mut self, ctx: &GpuContext, scene: &Scene, camera: &Camera) -> VkResult<()> {
        self.set_camera_with(ctx, scene, camera, true)
    }

    /// [`GpuRenderer::set_camera`] that leaves the G-buffer's camera as it was: a wrong update,
    /// for the tests' negative only.
    #[cfg(feature = "test-hooks")]
    pub fn set_camera_skipping_gbuffer(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
    ) -> VkResult<()> {
        self.set_camera_with(ctx, scene, camera, false)
    }

    fn set_camera_with(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        gbuffer: bool,
    ) -> VkResult<()> {
        if (camera.width, camera.height) != (self.width, self.height) {
            return Err(VkError::Usage {
                what: "camera".into(),
                detail: format!(
                    "a {}x{} camera for a renderer of {}x{} frames: the frame size is fixed at \
                     creation",
                    camera.width, camera.height, self.width, self.height
                ),
            });
        }
        let unjittered = |c: &Camera| Camera {
            jitter: glam::Vec2::ZERO,
            ..c.clone()
        };
        let world_camera = camera;
        let camera = &camera.rebased(self.anchor);
        if unjittered(camera) != unjittered(&self.local_camera) {
            let (local, _) = rebased(self.anchor, scene, world_camera);
            let ranges = FrameRanges::new(&local, camera);
            check_ranges(&ranges, &local, &self.options)?;
            self.ranges = ranges;
        }
        // The frame params read the scene's background and reflector shape only, which the
        // anchor does not move.
        self.apply_camera(ctx, scene, camera, gbuffer)?;
        self.camera = world_camera.clone();
        Ok(())
    }

    /// The camera part of [`GpuRenderer::set_camera`] with `self.ranges` and `self.data` those
    /// of `scene` and `camera` already: the capture's near plane, the frame params, the
    /// G-buffer's camera (unless `gbuffer` is false, the tests' negative) and the method's.
    fn apply_camera(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        gbuffer: bool,
    ) -> VkResult<()> {
        let near = self.ranges.near;
        let capture_near = self.ranges.capture_near;
        let raster = match &mut self.capture {
            Some(CmoCapture::Raster(c)) => Some(&mut **c),
            _ => None,
        };
        for c in raster.into_iter().chain(self.colour_capture.as_deref_mut()) {
            if c.near().to_bits() != capture_near.to_bits() {
                c.set_near(ctx, capture_near)?;
                self.cmo_valid = false;
            }
        }
        ctx.write_buffer(
            &self.params,
            &[FrameParams {
                sample: self.sample,
                ..frame_params(scene, camera, &self.options, self.ranges.t_hi)
            }],
        )?;
        if gbuffer {
            self.gbuffer.set_camera(ctx, camera, near)?;
        }
        let inputs = methods::CameraInputs {
            ctx,
            camera,
            near,
            data: &self.data,
            mirror_rect: mirror_rect(&self.data, camera, near),
        };
        self.method.set_camera(&inputs)?;
        self.local_camera = camera.clone();
        Ok(())
    }

    /// Sets the film's sample key of the next frames ([`crate::lobe::sample_key`]): the lobe
    /// direction a glossy reflector's pixels take (`--method bvh`). A no-op where it is the key
    /// already (0 at creation).
    pub fn set_sample(&mut self, ctx: &GpuContext, scene: &Scene, key: u32) -> VkResult<()> {
        if key == self.sample {
            return Ok(());
        }
        self.sample = key;
        let params = frame_params(scene, &self.local_camera, &self.options, self.ranges.t_hi);
        ctx.write_buffer(
            &self.params,
            &[FrameParams {
                sample: key,
                ..params
            }],
        )
    }

    /// Points every pass at `scene` and `camera` where `scene` differs from the renderer's only
    /// in its geometry's placement (mesh transforms, CMO centres; the same triangles, objects,
    /// materials and CMO count): the scene buffers' vertices, the CMO centres and the capture's
    /// views (the bounded capture's capacities), every BVH (the method's, the fallback's, the
    /// bounce rounds', the reflector check's), the reflection-point closing triangles, the
    /// ranges and everything the camera update derives from them, each recomputed as
    /// [`GpuRenderer::new`] computes it; the pipelines stay. The next frame runs the CMO stages
    /// and is bit for bit that of [`GpuRenderer::new`] for `scene` and `camera`.
    ///
    /// `Ok(Some(why))` where it cannot (the frame size, the vertex count, the triangles, the
    /// objects' flags, the CMO count, self-reflections, the reflector check's triangles changed,
    /// or the bounded criterion's lists were uploaded at creation): nothing was changed, and the
    /// caller builds a new renderer. A bounded capture whose pool or job buffer the moved
    /// geometry outgrows gets larger ones, bound where the old ones were. An error where a new
    /// renderer would fail for the same reason (the depth range check, the device's limits).
    pub fn update_geometry(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
    ) -> VkResult<Option<String>> {
        self.update_geometry_with(ctx, scene, camera, None)
    }

    /// [`GpuRenderer::update_geometry`] that leaves `stale` as it was: a wrong update, for the
    /// tests' negative only.
    #[cfg(feature = "test-hooks")]
    pub fn update_geometry_leaving(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        stale: StaleUpdate,
    ) -> VkResult<Option<String>> {
        self.update_geometry_with(ctx, scene, camera, Some(stale))
    }

    /// [`GpuRenderer::update_geometry`] leaving `stale` as it was (`None`: the update itself;
    /// `Some` only through the tests' hooks).
    pub(crate) fn update_geometry_with(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        stale: Option<StaleUpdate>,
    ) -> VkResult<Option<String>> {
        let (local, local_camera) = rebased(self.anchor, scene, camera);
        match self.geometry_plan(&local, &local_camera)? {
            Ok(plan) => {
                self.write_geometry(ctx, &local, &local_camera, plan, stale)?;
                self.camera = camera.clone();
                Ok(None)
            }
            Err(why) => Ok(Some(why)),
        }
    }

    /// What [`GpuRenderer::update_geometry`] writes, derived from `scene` and `camera` as
    /// [`GpuRenderer::new`] derives it, or why it cannot be written in place. Changes nothing.
    fn geometry_plan(
        &self,
        scene: &Scene,
        camera: &Camera,
    ) -> VkResult<Result<GeometryPlan, String>> {
        if (camera.width, camera.height) != (self.width, self.height) {
            return Ok(Err("the frame size changed".into()));
        }
        if self.lists_uploaded {
            return Ok(Err(
                "the bounded capture's lists were uploaded at creation".into()
            ));
        }
        let ranges = FrameRanges::new(scene, camera);
        check_ranges(&ranges, scene, &self.options)?;
        let centres = scene.cmo_centres();
        if centres.is_empty() {
            return Err(VkError::Usage {
                what: "scene".into(),
                detail: "no CMO centres".into(),
            });
        }
        if centres.len() != self.cmo.count() as usize {
            return Ok(Err("the CMO count changed".into()));
        }
        if self.capture.is_some() && scene.captures_reflectors() != self.cmo.normal().is_some() {
            return Ok(Err(
                "self-reflections changed (the capture's targets)".into()
            ));
        }
        let data = GpuSceneData::new(scene);
        if let Some(why) = SceneBuffers::in_place_blocker(&self.data, &data) {
            return Ok(Err(why));
        }
        if scene.check_triangles() != self.check_triangles {
            return Ok(Err("the reflector check's triangles changed".into()));
        }
        let lists = match &self.capture {
            Some(CmoCapture::Lists(c)) => {
                let views = capture_lists::scene_views(scene);
                if let Some(why) = c.update_blocker(&views) {
                    return Ok(Err(why));
                }
                let capacity = capture_lists::capacity(&data, &views, self.cmo.size());
                Some((views, capacity))
            }
            _ => None,
        };
        Ok(Ok(GeometryPlan {
            data,
            ranges,
            centres,
            lists,
        }))
    }

    /// Writes `plan` ([`GpuRenderer::geometry_plan`]) into every pass, leaving `stale` as it
    /// was (the tests' negative), then the camera, and marks the capture stale.
    fn write_geometry(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        plan: GeometryPlan,
        stale: Option<StaleUpdate>,
    ) -> VkResult<()> {
        let GeometryPlan {
            data,
            ranges,
            centres,
            lists,
        } = plan;
        let t_hi = ranges.t_hi;
        if stale != Some(StaleUpdate::Vertices) {
            self._scene.write_geometry(ctx, &data)?;
        }
        self.cmo.set_centres(ctx, &centres)?;
        if let Some(c) = &mut self.colour_capture {
            c.set_views(ctx, &centres, ranges.capture_near)?;
        }
        match (&mut self.capture, lists) {
            (Some(CmoCapture::Raster(c)), _) => c.set_views(ctx, &centres, ranges.capture_near)?,
            (Some(CmoCapture::Lists(c)), Some((views, capacity))) => {
                // A pool too small for the moved geometry is allocated again, and rebound.
                let grown = self.cmo.grow_pool(ctx, capacity.nodes)?;
                let targets = ListTargets {
                    distance: self.cmo.distance(),
                    records: self.cmo.lists(),
                    nodes: self.cmo.nodes(),
                };
                c.update(ctx, &self._scene, &views, capacity, Some(targets))?;
                if grown {
                    self.method.rebind_cmo(ctx, &self.cmo)?;
                    self.composite.rebind_cmo(&self.cmo)?;
                }
            }
            _ => {}
        }
        let rebuild_bvh = stale != Some(StaleUpdate::Bvh);
        if rebuild_bvh {
            if let Some(f) = &mut self.fallback {
                f.update(ctx, &data, t_hi)?;
            }
            if let Some(c) = &mut self.check {
                c.update(ctx, &self.check_triangles, &data, t_hi)?;
            }
            if let Some(b) = &mut self.bounce {
                b.update(ctx, &data, t_hi)?;
            }
        }
        self.method.update_geometry(&GeometryInputs {
            ctx,
            data: &data,
            t_hi,
            rebuild_bvh,
        })?;
        self.data = data;
        self.ranges = ranges;
        self.cmo_valid = false;
        self.apply_camera(ctx, scene, camera, true)
    }

    /// Makes the next frame run the CMO stages again (capture, pyramid, the method's CMO stage)
    /// though their inputs did not change: the bench times whole frames.
    pub fn invalidate_capture(&mut self) {
        self.cmo_valid = false;
    }

    /// Whether frames run a capture at all (not `bvh`, not uploaded lists).
    pub fn captures(&self) -> bool {
        self.capture.is_some()
    }

    /// The camera the passes are set for (as the caller gave it, in world coordinates).
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    fn create(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
        ranges: &FrameRanges,
        lists: Option<&PackedLists>,
    ) -> VkResult<Self> {
        if scene.cmo_centres().is_empty() {
            return Err(VkError::Usage {
                what: "scene".into(),
                detail: "no CMO centres".into(),
            });
        }
        let spec = check_method(&options)?;
        spec.check_device(ctx)?;
        let mut needs = spec.needs(&options.trace);
        let data = GpuSceneData::new(scene);
        // The pre-filtered CMO colour chain, for a method that reads it, on a glossy scene only.
        let cone = spec.glossy().reads_chain() && needs.capture && has_glossy_reflector(&data);
        needs.contents.colour |= cone;
        let scene_buffers = SceneBuffers::new(ctx, &data)?;
        let mut stages = CmoStages::new(
            ctx,
            scene,
            (&data, &scene_buffers),
            &needs,
            &options.trace,
            ranges.capture_near,
            lists,
        )?;
        if cone {
            stages.cmo.alloc_cone(ctx)?;
            let p = ConePrefilter::new(ctx)?;
            let b = p.bind(ctx, &stages.cmo, scene.background)?;
            stages.cone_prefilter = Some((p, b));
        }
        let gbuffer = Gbuffer::new(ctx, &scene_buffers, camera, ranges.near)?;
        let params = ctx.create_buffer_init(
            "frame params",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &[frame_params(scene, camera, &options, ranges.t_hi)],
        )?;
        let records = Buffer::new(
            ctx.device(),
            "pixel records",
            u64::from(camera.width) * u64::from(camera.height) * size_of::<PixelRecord>() as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let inputs = FrameInputs {
            ctx,
            camera,
            options: &options,
            near: ranges.near,
            t_hi: ranges.t_hi,
            data: &data,
            scene: &scene_buffers,
            cmo: &stages.cmo,
            gbuffer: &gbuffer,
            params: &params,
            records: &records,
            mirror_rect: mirror_rect(&data, camera, ranges.near),
        };
        let method = methods::create(options.method, &inputs)?;
        let check_triangles = scene.check_triangles();
        let cone = cone_stage(
            ctx,
            cone && spec.glossy() == Glossy::ConeStage,
            &stages.cmo,
            !needs.pyramid,
            (&gbuffer, &params, &records),
        )?;
        let after = AfterMethod::new(&inputs, &check_triangles, method.as_ref())?;
        let composite = Composite::new(
            ctx,
            &gbuffer,
            &params,
            &records,
            &stages.cmo,
            &scene_buffers,
        )?;
        let timestamps = frame_timestamps(ctx)?;
        Ok(GpuRenderer {
            options,
            background: scene.background,
            width: camera.width,
            height: camera.height,
            _scene: scene_buffers,
            cmo: stages.cmo,
            capture: stages.capture,
            colour_capture: stages.colour_capture,
            pyramid: stages.pyramid,
            cone_prefilter: stages.cone_prefilter,
            gbuffer,
            method,
            check: after.check,
            fallback: after.fallback,
            bounce: after.bounce,
            cone,
            cone_skipped: false,
            composite,
            params,
            records,
            timestamps,
            data,
            local_camera: camera.clone(),
            ranges: ranges.clone(),
            anchor: Vec3::ZERO,
            camera: camera.clone(),
            cmo_valid: false,
            sample: 0,
            check_triangles,
            lists_uploaded: lists.is_some(),
        })
    }

    /// The cone stage, where the frame has one (a glossy scene, fragment or compute).
    pub fn cone(&self) -> Option<&ConeStage> {
        self.cone.as_ref()
    }

    /// Test hook: frames without (`true`) or with the `cone` pass, everything else the same
    /// (the records the pass reads, for its CPU twin `cpu::cone::cone_pixel`).
    #[cfg(feature = "test-hooks")]
    pub fn skip_cone(&mut self, skip: bool) {
        self.cone_skipped = skip;
    }

    /// The CMO data (for reading the captures back).
    pub fn cmo(&self) -> &CmoData {
        &self.cmo
    }

    /// The method's passes as type `T` (`None` for another method's).
    fn method_as<T: Technique>(&self) -> Option<&T> {
        let any: &dyn Any = self.method.as_ref();
        any.downcast_ref()
    }

    /// The compute path's passes ([`Method::Compute`] only).
    pub fn compute_path(&self) -> Option<&ComputePath> {
        self.method_as()
    }

    /// The screen-space method's passes ([`Method::Ssr`] only).
    pub fn ssr_passes(&self) -> Option<&SsrPasses> {
        self.method_as()
    }

    /// The reflection-point method's passes ([`Method::ReflectionPoint`] only).
    pub fn reflection_point_passes(&self) -> Option<&ReflectionPointPasses> {
        self.method_as()
    }

    /// The BVH passes ([`Method::Bvh`]'s or [`Fallback::Trace`]'s).
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

    /// The options this renderer was built with.
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// Records every pass, runs them and reads the frame back.
    pub fn render(&mut self, ctx: &GpuContext) -> VkResult<GpuFrame> {
        let mut ts = self.timestamps.take();
        let cmo_stages = !self.cmo_valid;
        let recorded = ctx.submit_and_wait("frame", |rec| {
            if let Some(t) = ts.as_mut() {
                t.reset(rec);
            }
            let mut scoped = |name: &str, f: &mut dyn FnMut() -> VkResult<()>| -> VkResult<()> {
                match ts.as_mut() {
                    Some(t) => {
                        let s = t.begin(rec, name)?;
                        let r = f();
                        t.end(rec, s);
                        r
                    }
                    None => {
                        rec.begin_label(name);
                        let r = f();
                        rec.end_label();
                        r
                    }
                }
            };
            self.record(rec, cmo_stages, &mut scoped)
        });
        let pass_times = match (&ts, &recorded) {
            (Some(t), Ok(())) => t.results()?,
            _ => Vec::new(),
        };
        self.timestamps = ts;
        recorded?;
        self.cmo_valid = true;
        let mut frame = self.read_back(ctx, pass_times)?;
        frame.captured = cmo_stages && self.capture.is_some();
        Ok(frame)
    }

    /// Records the frame's passes in the order of the module docs' table; the CMO stages
    /// (capture, pyramid, the method's CMO stage) only with `cmo_stages`.
    fn record(&self, rec: &Recorder<'_>, cmo_stages: bool, scope: &mut Scope<'_>) -> VkResult<()> {
        if cmo_stages {
            self.record_cmo_stages(rec, scope)?;
        }
        scope("gbuffer", &mut || self.gbuffer.record(rec, self.background))?;
        self.record_after_gbuffer(rec, scope)
    }

    /// The CMO stages of [`GpuRenderer::record`]: the capture, the pyramid and the method's CMO
    /// stage.
    fn record_cmo_stages(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        if let Some(c) = &self.colour_capture {
            scope("capture", &mut || {
                c.record(rec, &self.cmo, self.background)?;
                // The lists' capture writes its distances over this one's copy.
                rec.memory_barrier(TRANSFER_WRITE, ALL);
                Ok(())
            })?;
        }
        match &self.capture {
            Some(CmoCapture::Raster(c)) => {
                scope("capture", &mut || c.record(rec, &self.cmo, self.background))?;
            }
            Some(CmoCapture::Lists(c)) => scope("capture", &mut || c.record(rec))?,
            None => {}
        }
        if let Some((p, b)) = &self.cone_prefilter {
            scope(CONE_PREFILTER.name, &mut || p.record(rec, b, None))?;
            rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        }
        if let Some((p, b)) = &self.pyramid {
            scope("pyramid", &mut || p.record(rec, b, None))?;
            rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        }
        self.method.record_cmo_stage(rec, scope)?;
        if let Some(c) = self.cone.as_ref().filter(|c| c.has_own_pyramid()) {
            scope("cone_pyramid", &mut || c.record_cmo_stage(rec))?;
        }
        Ok(())
    }

    /// The second half of [`GpuRenderer::record`]: the method's passes, the checks and the
    /// composite.
    fn record_after_gbuffer(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        // `--bounces 0`: no ray is traced.
        if self.options.bounces != 0 {
            self.method.record(rec, scope)?;
            if let Some(c) = &self.check {
                scope(REFLECTOR_CHECK_PASS, &mut || c.record(rec))?;
            }
            if let Some(b) = &self.fallback {
                scope(FALLBACK_PASS, &mut || {
                    b.record_queue(rec);
                    b.record_trace(rec)
                })?;
            }
            if let Some(c) = self.cone.as_ref().filter(|_| !self.cone_skipped) {
                scope("cone", &mut || {
                    c.record(rec);
                    Ok(())
                })?;
            }
        }
        if let Some(b) = &self.bounce {
            let shared = self.bvh_passes().map(|p| &p.tracer);
            scope(BOUNCE_APPEND.name, &mut || {
                b.record_own_material(rec);
                b.record_rounds(rec, shared)
            })?;
        }
        rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        scope("composite", &mut || {
            self.composite.record(rec);
            Ok(())
        })
    }

    /// Reads the frame back after [`GpuRenderer::render`]'s submission.
    fn read_back(&self, ctx: &GpuContext, pass_times: Vec<PassTime>) -> VkResult<GpuFrame> {
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
            search: stats.search,
            captured: false,
        })
    }
}

/// `scene` and `camera` relative to `anchor` ([`Scene::rebased`]), borrowed as they are where
/// it is the world origin.
fn rebased<'a>(
    anchor: Vec3,
    scene: &'a Scene,
    camera: &'a Camera,
) -> (Cow<'a, Scene>, Cow<'a, Camera>) {
    if anchor == Vec3::ZERO {
        (Cow::Borrowed(scene), Cow::Borrowed(camera))
    } else {
        (
            Cow::Owned(scene.rebased(anchor)),
            Cow::Owned(camera.rebased(anchor)),
        )
    }
}

/// The reflectors' screen rectangle ([`Camera::screen_rect`]; `None`: the whole frame).
fn mirror_rect(data: &GpuSceneData, camera: &Camera, near: f32) -> Option<[u32; 4]> {
    camera.screen_rect(
        data.vertices
            .iter()
            .filter(|v| data.objects[v.object as usize].reflector != 0)
            .map(|v| Vec3::from_array(v.position)),
        near,
    )
}

/// The object a reflection-point frame shows at each pixel (its records' `face` on the mirror
/// pixels it covered; `None` elsewhere), for [`crate::metrics::same_object`].
pub fn shown_objects(frame: &GpuFrame) -> Vec<Option<u32>> {
    (0..frame.records.len())
        .map(|k| {
            let r = &frame.records[k];
            (frame.mask[k] != 0 && r.status == RECORD_HIT).then_some(r.face)
        })
        .collect()
}

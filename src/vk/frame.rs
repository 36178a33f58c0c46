//! One frame on the GPU, recorded as a short list of named passes into one command buffer:
//!
//! | pass | reads | writes |
//! |---|---|---|
//! | `capture` | scene | CMO distance, colour and/or triangle IDs (+ normal/mirror with self-reflections) |
//! | `pyramid` | CMO distance | CMO 2x2 min/max pyramid (fragment path only) |
//! | `hier32` | CMO distance | CMO 8x4/4x8 min/max hierarchy (compute path only) |
//! | `gbuffer` | scene | G-buffer colour, position + mirror mask, normal |
//! | `fragment_trace` or `envmap` | G-buffer, CMO data (+ scene: verified hits) | one record per mirror pixel |
//! | or `append`, `dispatch_args`, `compute_trace` | G-buffer, CMO data, hierarchy, scene | the same records ([`super::methods::compute`]) |
//! | or `ssr_hiz`, `ssr` | G-buffer, its min pyramid | the same records ([`super::methods::ssr`]) |
//! | or `reflection_point_search`, `reflection_point_raster` | scene, G-buffer | the same records ([`super::methods::reflection_point`]) |
//! | or `bvh_queue`, `bvh_trace` | G-buffer, CWBVH, scene | the same records, traced exactly ([`super::passes::bvh`]) |
//! | `reflector_check` (fragment, compute; off with `--no-reflector-check`) | G-buffer, records, reflectors' CWBVH, scene | resolved records whose ray meets a reflector nearer, traced exactly ([`super::passes::bvh::ReflectorCheck`]) |
//! | `fallback` (`--fallback trace`) | G-buffer, records, CWBVH, scene | unresolved records finished by `bvh_queue` + `bvh_trace` |
//! | `bounce_append` (`--bounces N`, N != 1) | G-buffer, records, CWBVH, scene | N = 0: the mirrors' own material (instead of the tracing passes); N >= 2: rounds 2..=N, each `bounce_append` + `bvh_queue` (`args`) + `bvh_trace` ([`super::passes::bounce`]) |
//! | `composite` | G-buffer, records, CMO triangle IDs + scene (environment-map fallback) | final colour |
//!
//! Each pass name is its WGSL file, its debug label and its timestamp scope, so
//! [`GpuFrame::pass_times`] lines up with the benchmark tables. Everything a frame needs is
//! allocated once in [`GpuRenderer::new`]; [`GpuRenderer::render`] only records, submits and
//! reads back, so repeated renders (the harness) measure the passes, not allocation.
//!
//! Only what the options use is allocated: no pyramid for the environment map, no normal/mirror
//! capture without self-reflections, the hierarchy and the ray queue for the compute path only,
//! the Hi-Z pyramid for `ssr` only (which uses the CMOs for its fallback alone), the search
//! textures, per-vertex buffer and virtual-object targets for `reflection-point` only (the
//! same); the CMOs' colour for the environment-map method and the approximate criteria only
//! (the fallback shades from the triangle IDs); the CWBVH for `bvh`, `--fallback trace` or
//! `--bounces N >= 2` only (one BVH for all of them; `bvh` captures its CMOs at one texel per
//! face, in its first frame only: only an `envmap` fallback would read them), the bounce queues
//! for N >= 2 only; the reflector check's BVH and queue for `fragment` and `compute` only, and
//! only where [`crate::scene::Scene::check_triangles`] is not empty.
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};
use gpu_allocator::MemoryLocation;

use super::backend::buffer::Buffer;
use super::backend::context::GpuContext;
use super::backend::error::{VkError, VkResult};
use super::backend::graphics::{GraphicsDesc, GraphicsPipeline, RenderTarget};
use super::backend::pipeline::{BindGroup, ComputeOptions, ComputePipeline, Resource};
use super::backend::shaders::{
    APPEND, BOUNCE_APPEND, BVH_QUEUE, BVH_TRACE, COMPOSITE, COMPUTE_TRACE, DISPATCH_ARGS, ENVMAP,
    FRAGMENT_TRACE, HIER32, Pass, REFLECTION_POINT_RASTER, REFLECTION_POINT_SEARCH, SSR, SSR_HIZ,
};
use super::backend::sync::{SHADER_READ, SHADER_WRITE};
use super::backend::timestamps::{PassTime, Timestamps};
use super::methods::compute::{ComputePath, ComputeStats};
use super::methods::reflection_point::ReflectionPointPasses;
use super::methods::ssr::SsrPasses;
use super::passes::bounce::{BouncePasses, MAX_BOUNCES};
use super::passes::bvh::{AppendKind, BvhCounter, BvhPasses, ReflectorCheck};
use super::passes::capture::Capture;
use super::passes::cmo::{CaptureContents, CmoData};
use super::passes::gbuffer::Gbuffer;
use super::passes::pyramid::{Pyramid, PyramidBindings};
use super::passes::scene_buffers::SceneBuffers;
use crate::camera::Camera;
use crate::cpu::options::TraceOptions;
use crate::cpu::reflection_point::{RpOptions, SearchStats};
use crate::cpu::ssr::SsrOptions;
use crate::method::Method;
use crate::metrics::Traced;
use crate::ranges::FrameRanges;
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;

/// The tracing pass of a GPU method (its timestamp scope in the harness's tables).
pub fn trace_pass(method: Method) -> &'static Pass {
    match method {
        Method::Fragment => &FRAGMENT_TRACE,
        Method::Envmap => &ENVMAP,
        Method::Compute => &COMPUTE_TRACE,
        Method::Ssr => &SSR,
        Method::ReflectionPoint => &REFLECTION_POINT_SEARCH,
        Method::Bvh => &BVH_TRACE,
        Method::Reference => {
            unreachable!("the reference is no GPU method: GpuRenderer::new refuses it")
        }
    }
}

/// The tracing pass's name of a GPU method.
pub fn pass_name(method: Method) -> &'static str {
    trace_pass(method).name
}

/// What fills a mirror pixel whose ray no CMO could resolve.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Fallback {
    /// A flag colour (magenta), to see where tracing gave up.
    Flag,
    /// The environment-map lookup of the nearest CMO, shaded from the triangle its texel
    /// captured (`composite.wgsl`, `cpu::fragment::envmap_fallback`).
    #[default]
    Envmap,
    /// The scene's background.
    Background,
    /// The rays are finished exactly by the BVH tracer: after the tracing pass, the `fallback`
    /// pass queues the unresolved records' rays and traces them from their start under the
    /// start rule ([`super::passes::bvh`]; not from `t_done`: see [`Fallback::TraceFromTDone`]); such
    /// records get `fallback` = 1 and keep the cubemap tracer's `t_done` and counters. A ray the BVH
    /// loop's cap cut (none seen) stays unresolved and shows the flag colour.
    Trace,
    /// [`Fallback::Trace`] with the rays started at their `t_done` instead of 0: misses the hits
    /// before `t_done` that the cubemap's model does not see (uncaptured reflectors, surfaces in
    /// front of their texel's patch; spirv/bvh_queue.wgsl). Not offered by the CLI; the tests
    /// show what it misses.
    TraceFromTDone,
}

/// Options of a GPU render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub method: Method,
    /// Tracer options (criterion, sampling, acceleration, steps); used by `Fragment`.
    pub trace: TraceOptions,
    pub fallback: Fallback,
    /// Options of `Ssr` (iteration cap, thickness).
    pub ssr: SsrOptions,
    /// Options of `ReflectionPoint` (iteration cap).
    pub reflection_point: RpOptions,
    /// Reflections per path, 0..=[`MAX_BOUNCES`] (the reference's `bounces`): the method traces
    /// the first, the BVH the rest ([`super::passes::bounce`]); 0 shows the mirrors' own material.
    /// `Compute`, `Fragment` (exact criterion) and `Bvh` only; the other methods take 1.
    pub bounces: u32,
    /// The reflector check after the `Fragment` and `Compute` trace ([`ReflectorCheck`]): on by
    /// default; ignored by the other methods and where the scene has no reflector to check.
    pub reflector_check: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            method: Method::Fragment,
            trace: TraceOptions::default(),
            fallback: Fallback::default(),
            ssr: SsrOptions::default(),
            reflection_point: RpOptions::default(),
            bounces: 1,
            reflector_check: true,
        }
    }
}

/// What the capture writes for a frame of `method` with tracer options `trace` (issue 10: CMO
/// memory must not grow; the memory estimate, `super::budget`, uses the same rule). Triangle IDs
/// for every method but the environment map: the fragment and compute passes verify hits with
/// them, and composite's environment-map fallback shades from them, whatever the method. The
/// colour only where a hit takes its texel's colour: the environment-map method and the
/// thesis's approximate criteria (fragment path). No fallback needs it.
pub fn capture_contents(method: Method, trace: &TraceOptions) -> CaptureContents {
    CaptureContents {
        colour: method == Method::Envmap
            || (method == Method::Fragment && trace.approx().is_some()),
        triangle_ids: method != Method::Envmap,
    }
}

/// The timestamp scope of [`Fallback::Trace`]'s passes (`bvh_queue`'s `append_unresolved` and
/// `args`, then `bvh_trace`), timed apart from the tracing pass.
pub const FALLBACK_PASS: &str = "fallback";

/// The timestamp scope of the reflector check ([`ReflectorCheck`]: `bvh_queue`'s
/// `append_check` and `args`, then `bvh_trace` over the reflectors' BVH).
pub const REFLECTOR_CHECK_PASS: &str = "reflector_check";

/// The flag colour of [`Fallback::Flag`] (linear magenta).
pub const FLAG_COLOUR: Vec3 = Vec3::new(1.0, 0.0, 1.0);

/// `FrameParams` in `spirv/shared/mirror.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FrameParams {
    pub eye: [f32; 3],
    pub t_hi: f32,
    pub background: [f32; 3],
    pub width: u32,
    pub flag_colour: [f32; 3],
    pub height: u32,
    pub fallback: u32,
    /// The reflector check traces the mirror rays `d` with `d . n < check_below`
    /// ([`Scene::check_below`]).
    pub check_below: f32,
    /// [`Camera::ray`]'s inputs: the mirror pixels' incoming direction is the reference's
    /// primary ray's (`camera_ray_dir` in `spirv/shared/camera.wgsl`).
    pub tan_half: f32,
    pub aspect: f32,
    pub right: [f32; 3],
    pub pad1: u32,
    pub up: [f32; 3],
    pub pad2: u32,
    pub back: [f32; 3],
    pub pad3: u32,
}

/// `PixelRecord` in `spirv/shared/mirror.wgsl`: what a method found for one mirror pixel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PixelRecord {
    pub origin: [f32; 3],
    /// [`RECORD_HIT`], [`RECORD_ESCAPED`] or [`RECORD_UNRESOLVED`].
    pub status: u32,
    pub dir: [f32; 3],
    pub cmo: u32,
    pub point: [f32; 3],
    pub riser: u32,
    pub colour: [f32; 3],
    pub face: u32,
    pub x: u32,
    pub y: u32,
    pub texels: u32,
    pub cells: u32,
    pub traces: u32,
    pub t: f32,
    pub t_done: f32,
    /// Verified hits (the exact criterion in the fragment and compute paths): the global
    /// triangle hit; `u32::MAX` otherwise and for methods that do not verify.
    pub triangle: u32,
    /// 1 where the compute path's step loop ended before the ray did (the driver's loop limit:
    /// spirv/README.md, "Known defect"); such a ray is unresolved. 0 elsewhere.
    pub cut: u32,
    /// 1 where [`Fallback::Trace`] finished the ray with the BVH tracer (`bvh_trace`); 0
    /// elsewhere (then `cut` = 1 means the BVH loop's cap cut it too).
    pub fallback: u32,
    /// Reflections the pixel's path took ([`RenderOptions::bounces`]; the reference's
    /// `Frame::bounces`): 1 from every method's own pass, more from the bounce rounds
    /// ([`super::passes::bounce`]), 0 with no bounce.
    pub bounces: u32,
    /// 1 where the reflector check ([`RenderOptions::reflector_check`],
    /// [`super::passes::bvh::ReflectorCheck`]) replaced the method's result with a nearer hit on a
    /// reflector (such a record's `fallback` stays 0: the check is not the fallback, and the
    /// fallback share does not count it); 2 where it found the method's hit at the ray's own
    /// start (the BVH start rule's triangles: a self-captured reflector's surface verified at
    /// t ~ 0) and made the pixel unresolved again, for the fallback to trace in full; 0 elsewhere.
    pub checked: u32,
}

pub use crate::cpu::fragment::{RECORD_ESCAPED, RECORD_HIT, RECORD_UNRESOLVED};

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
    /// Ray count, subgroup size and per-ray counters ([`Method::Compute`] only).
    pub compute: Option<ComputeStats>,
    /// Iteration counts of the searches ([`Method::ReflectionPoint`] only).
    pub search: Option<SearchStats>,
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
fn check_method(options: &RenderOptions) -> VkResult<()> {
    let refuse = |what: &str, detail: String| {
        Err(VkError::Usage {
            what: what.into(),
            detail,
        })
    };
    if !options.method.is_gpu() {
        return refuse(
            "method",
            "--method reference runs on the CPU (crate::reference), not in the GPU renderer".into(),
        );
    }
    if let Err(e) = options
        .method
        .check_bounces(options.bounces, MAX_BOUNCES, &options.trace)
    {
        return refuse("bounces", e);
    }
    if let Err(e) = options.method.check_trace(&options.trace) {
        return refuse("method", e);
    }
    Ok(())
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
    capture: Capture,
    pyramid: Option<(Pyramid, PyramidBindings)>,
    gbuffer: Gbuffer,
    /// The fragment pass of `Fragment` and `Envmap`.
    trace: Option<(GraphicsPipeline, Vec<BindGroup>)>,
    /// The pixels `trace` shades: the reflectors' screen rectangle ([`Camera::screen_rect`];
    /// `None`: the whole frame). A CPU driver runs a fragment shader's code for a group of
    /// pixels even when none of them is a mirror pixel; outside the rectangle none is.
    mirror_rect: Option<[u32; 4]>,
    /// The passes of `Compute`.
    compute: Option<ComputePath>,
    /// The passes of `Ssr`.
    ssr: Option<SsrPasses>,
    /// The passes of `ReflectionPoint`.
    rp: Option<ReflectionPointPasses>,
    /// The passes of `Bvh` (the method's) or of [`Fallback::Trace`].
    bvh: Option<BvhPasses>,
    /// `bounces` != 1 ([`super::passes::bounce`]).
    bounce: Option<BouncePasses>,
    /// [`RenderOptions::reflector_check`] where the method and the scene need it.
    check: Option<ReflectorCheck>,
    composite: ComputePipeline,
    composite_sets: [BindGroup; 3],
    _params: Buffer,
    records: Buffer,
    frame_colour: Buffer,
    timestamps: Option<Timestamps>,
    /// Frames rendered so far (`bvh` captures its unused 1-texel CMOs in the first only).
    frames: u64,
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
        let ranges = FrameRanges::new(scene, camera);
        ranges.check(scene).map_err(|e| VkError::Usage {
            what: "depth range".into(),
            detail: e.to_string(),
        })?;
        Self::with_ranges(ctx, scene, camera, options, &ranges)
    }

    /// [`GpuRenderer::new`] with the given ranges and no precision check: for tests that show
    /// what other ranges do.
    pub fn with_ranges(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
        ranges: &FrameRanges,
    ) -> VkResult<Self> {
        let usage = |what: &str, detail: String| VkError::Usage {
            what: what.into(),
            detail,
        };
        let centres = scene.cmo_centres();
        if centres.is_empty() {
            return Err(usage("scene", "no CMO centres".into()));
        }
        // `bvh` traces without the CMOs: one texel per face keeps the capture (and the envmap
        // fallback's binding) at no cost.
        let size = if options.method == Method::Bvh {
            1
        } else {
            scene.cmo.resolution
        };
        let t_hi = ranges.t_hi;
        let data = GpuSceneData::new(scene);
        let scene_buffers = SceneBuffers::new(ctx, &data)?;
        let mirror_rect = camera.screen_rect(
            data.vertices
                .iter()
                .filter(|v| data.objects[v.object as usize].reflector != 0)
                .map(|v| Vec3::from_array(v.position)),
            ranges.near,
        );
        let needs_pyramid = options.method == Method::Fragment;
        check_method(&options)?;
        if options.method == Method::Compute {
            super::methods::compute::check_device(ctx)?;
        }
        let contents = capture_contents(options.method, &options.trace);
        let cmo = CmoData::with_contents(
            ctx,
            &centres,
            size,
            scene.captures_reflectors(),
            needs_pyramid,
            &options.trace,
            contents,
        )?;
        let capture = Capture::with_contents(
            ctx,
            &scene_buffers,
            &centres,
            size,
            scene.captures_reflectors(),
            ranges.capture_near,
            contents,
        )?;
        let pyramid = if needs_pyramid {
            let p = Pyramid::new(ctx)?;
            let b = p.bind(ctx, cmo.distance(), cmo.mip(), centres.len() as u32, size)?;
            Some((p, b))
        } else {
            None
        };
        let gbuffer = Gbuffer::new(ctx, &scene_buffers, camera, ranges.near)?;
        let (width, height) = (camera.width, camera.height);
        let (right, up, back) = camera.basis();
        let params = FrameParams {
            eye: camera.eye.to_array(),
            t_hi,
            background: scene.background.to_array(),
            width,
            flag_colour: FLAG_COLOUR.to_array(),
            height,
            fallback: match options.fallback {
                Fallback::Flag => 0,
                Fallback::Envmap => 1,
                Fallback::Background => 2,
                Fallback::Trace | Fallback::TraceFromTDone => 3,
            },
            check_below: scene.check_below(),
            tan_half: camera.tan_half_fov_y(),
            aspect: camera.aspect(),
            right: right.to_array(),
            up: up.to_array(),
            back: back.to_array(),
            ..FrameParams::default()
        };
        let params_buf = ctx.create_buffer_init(
            "frame params",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            std::slice::from_ref(&params),
        )?;
        let pixels = u64::from(width) * u64::from(height);
        let storage = |name: &str, bytes: u64| {
            Buffer::new(
                ctx.device(),
                name,
                bytes,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )
        };
        let records = storage("pixel records", pixels * size_of::<PixelRecord>() as u64)?;
        let frame_colour = storage("frame colour", pixels * 16)?;
        let sampled = |img: &super::backend::image::Image| Resource::Texture {
            view: img.view(),
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        let mut ssr = None;
        let mut rp = None;
        // The BVH: the method's own rays, or the fallback's (a method that cannot leave a record
        // unresolved needs none: envmap, bvh itself).
        let bvh_kind = if options.method == Method::Bvh {
            Some(AppendKind::Mirror)
        } else if options.method == Method::Envmap {
            None
        } else if options.fallback == Fallback::Trace {
            Some(AppendKind::Unresolved)
        } else if options.fallback == Fallback::TraceFromTDone {
            Some(AppendKind::UnresolvedFromTDone)
        } else {
            None
        };
        let bvh = match bvh_kind {
            Some(kind) => Some(BvhPasses::new(
                ctx,
                kind,
                &data,
                &scene_buffers,
                &gbuffer,
                &params_buf,
                &records,
                t_hi,
            )?),
            None => None,
        };
        let check = if options.reflector_check
            && matches!(options.method, Method::Fragment | Method::Compute)
        {
            ReflectorCheck::new(
                ctx,
                &scene.check_triangles(),
                &data,
                &scene_buffers,
                &gbuffer,
                &params_buf,
                &records,
                t_hi,
            )?
        } else {
            None
        };
        let bounce = if options.bounces == 1 {
            None
        } else {
            Some(BouncePasses::new(
                ctx,
                options.bounces,
                &data,
                &scene_buffers,
                &gbuffer,
                &params_buf,
                &records,
                bvh.as_ref().map(|b| &b.tracer),
                t_hi,
            )?)
        };
        let (trace, compute) = if options.method == Method::Compute {
            let path = ComputePath::new(
                ctx,
                &cmo,
                &scene_buffers,
                &gbuffer,
                &params_buf,
                &records,
                (width, height),
            )?;
            (None, Some(path))
        } else if options.method == Method::Ssr {
            let view_proj = camera.view_proj(ranges.near);
            ssr = Some(SsrPasses::new(
                ctx,
                &gbuffer,
                view_proj,
                &params_buf,
                &records,
                &options.ssr,
            )?);
            (None, None)
        } else if options.method == Method::Bvh {
            (None, None)
        } else if options.method == Method::ReflectionPoint {
            rp = Some(ReflectionPointPasses::new(
                ctx,
                &data,
                &scene_buffers,
                &gbuffer,
                camera,
                ranges.near,
                &records,
                &options.reflection_point,
            )?);
            (None, None)
        } else {
            // The fragment pass's specialised entry point when the options allow it.
            let entry = if options.method == Method::Fragment
                && super::passes::cmo::exact_mip_only(&options.trace)
            {
                "fs_exact_mip"
            } else {
                "fs_main"
            };
            let trace = GraphicsPipeline::new(
                ctx,
                trace_pass(options.method),
                &GraphicsDesc {
                    vertex: "vs_fullscreen",
                    fragment: entry,
                    colour_formats: Vec::new(),
                    depth: None,
                },
            )?;
            let mut trace_sets = vec![
                trace.bind_group(
                    0,
                    &[
                        (0, sampled(&gbuffer.position)),
                        (1, sampled(&gbuffer.normal)),
                        (2, Resource::Buffer(&params_buf)),
                        (3, Resource::Buffer(&records)),
                    ],
                )?,
                trace.bind_group(1, &cmo.resources_for(trace_pass(options.method), entry))?,
            ];
            if options.method == Method::Fragment {
                // The scene, for verified hits (fragment_trace's SCENE_GROUP).
                trace_sets.push(trace.bind_group(2, &scene_buffers.resources())?);
            }
            (Some((trace, trace_sets)), None)
        };
        let composite = ComputePipeline::new(ctx, &COMPOSITE, "main", ComputeOptions::default())?;
        let composite_sets = [
            composite.bind_group(
                0,
                &[
                    (0, sampled(&gbuffer.position)),
                    (2, Resource::Buffer(&params_buf)),
                    (3, Resource::Buffer(&records)),
                    (4, sampled(&gbuffer.colour)),
                    (5, Resource::Buffer(&frame_colour)),
                ],
            )?,
            composite.bind_group(1, &cmo.resources_for(&COMPOSITE, "main"))?,
            // The scene, for the environment-map fallback's shading.
            composite.bind_group(2, &scene_buffers.resources())?,
        ];
        let timestamps = if ctx.report().timestamps_supported() {
            Some(Timestamps::new(ctx, 12)?)
        } else {
            log::info!("no timestamp queries on this device: pass times are not measured");
            None
        };
        Ok(GpuRenderer {
            options,
            background: scene.background,
            width,
            height,
            _scene: scene_buffers,
            cmo,
            capture,
            pyramid,
            gbuffer,
            trace,
            mirror_rect,
            compute,
            ssr,
            rp,
            bvh,
            bounce,
            check,
            composite,
            composite_sets,
            _params: params_buf,
            records,
            frame_colour,
            timestamps,
            frames: 0,
        })
    }

    /// The CMO data (for reading the captures back).
    pub fn cmo(&self) -> &CmoData {
        &self.cmo
    }

    /// The compute path's passes ([`Method::Compute`] only).
    pub fn compute_path(&self) -> Option<&ComputePath> {
        self.compute.as_ref()
    }

    /// The screen-space method's passes ([`Method::Ssr`] only).
    pub fn ssr_passes(&self) -> Option<&SsrPasses> {
        self.ssr.as_ref()
    }

    /// The reflection-point method's passes ([`Method::ReflectionPoint`] only).
    pub fn reflection_point_passes(&self) -> Option<&ReflectionPointPasses> {
        self.rp.as_ref()
    }

    /// The BVH passes ([`Method::Bvh`] or [`Fallback::Trace`]).
    pub fn bvh_passes(&self) -> Option<&BvhPasses> {
        self.bvh.as_ref()
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
            // `bvh` reads no CMO: its 1-texel capture runs once, to leave the images the
            // composite pass binds in their layout (it still rasterises the whole scene, which
            // would cost every frame as much as a real capture's draw).
            if self.options.method != Method::Bvh || self.frames == 0 {
                scoped("capture", &mut || {
                    self.capture.record(rec, &self.cmo, self.background)
                })?;
            }
            if let Some((p, b)) = &self.pyramid {
                scoped("pyramid", &mut || p.record(rec, b, None))?;
                rec.memory_barrier(SHADER_WRITE, SHADER_READ);
            }
            if let Some(c) = &self.compute {
                scoped(HIER32.name, &mut || {
                    c.record_hier(rec);
                    Ok(())
                })?;
                rec.memory_barrier(SHADER_WRITE, SHADER_READ);
            }
            scoped("gbuffer", &mut || self.gbuffer.record(rec, self.background))?;
            if let Some(s) = &self.ssr {
                scoped(SSR_HIZ.name, &mut || {
                    s.record_hiz(rec);
                    Ok(())
                })?;
                rec.memory_barrier(SHADER_WRITE, SHADER_READ);
                scoped(SSR.name, &mut || s.record_trace(rec))?;
            }
            if let Some(r) = &self.rp {
                scoped(REFLECTION_POINT_SEARCH.name, &mut || r.record_search(rec))?;
                scoped(REFLECTION_POINT_RASTER.name, &mut || r.record_raster(rec))?;
            }
            // `--bounces 0`: no ray is traced.
            let traced = self.options.bounces != 0;
            if let Some((trace, sets)) = self.trace.as_ref().filter(|_| traced) {
                scoped(pass_name(self.options.method), &mut || {
                    let target = RenderTarget {
                        width: self.width,
                        height: self.height,
                        colour: Vec::new(),
                        depth: None,
                    };
                    let sets: Vec<&BindGroup> = sets.iter().collect();
                    trace.draw_in(rec, &target, &sets, 3, 0, self.mirror_rect)
                })?;
            }
            if let Some(c) = self.compute.as_ref().filter(|_| traced) {
                scoped(APPEND.name, &mut || c.record_append(rec))?;
                scoped(DISPATCH_ARGS.name, &mut || {
                    c.record_dispatch_args(rec);
                    Ok(())
                })?;
                scoped(COMPUTE_TRACE.name, &mut || c.record_trace(rec))?;
            }
            if let Some(c) = self.check.as_ref().filter(|_| traced) {
                scoped(REFLECTOR_CHECK_PASS, &mut || c.record(rec))?;
            }
            if let Some(b) = self.bvh.as_ref().filter(|_| traced) {
                if self.options.method == Method::Bvh {
                    scoped(BVH_QUEUE.name, &mut || {
                        b.record_queue(rec);
                        Ok(())
                    })?;
                    scoped(BVH_TRACE.name, &mut || b.record_trace(rec))?;
                } else {
                    scoped(FALLBACK_PASS, &mut || {
                        b.record_queue(rec);
                        b.record_trace(rec)
                    })?;
                }
            }
            if let Some(b) = &self.bounce {
                scoped(BOUNCE_APPEND.name, &mut || {
                    b.record_own_material(rec);
                    b.record_rounds(rec, self.bvh.as_ref().map(|p| &p.tracer))
                })?;
            }
            rec.memory_barrier(SHADER_WRITE, SHADER_READ);
            scoped("composite", &mut || {
                let groups = (self.width * self.height).div_ceil(64);
                let sets: Vec<&BindGroup> = self.composite_sets.iter().collect();
                self.composite.dispatch(rec, &sets, [groups, 1, 1]);
                Ok(())
            })?;
            Ok(())
        });
        let pass_times = match (&ts, &recorded) {
            (Some(t), Ok(())) => t.results()?,
            _ => Vec::new(),
        };
        self.timestamps = ts;
        recorded?;
        self.frames += 1;
        let colour: Vec<[f32; 4]> = ctx.read_buffer(&self.frame_colour)?;
        let records: Vec<PixelRecord> = ctx.read_buffer(&self.records)?;
        let position = ctx.read_image(
            &self.gbuffer.position,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        )?;
        let position: &[[f32; 4]] = bytemuck::cast_slice(&position);
        let compute = match &self.compute {
            Some(c) => Some(c.read_stats(ctx)?),
            None => None,
        };
        // With `--bounces 0` the BVH passes did not run.
        let bvh = match self.bvh.as_ref().filter(|_| self.options.bounces != 0) {
            Some(b) => Some(b.queue.read_counter(ctx)?),
            None => None,
        };
        let search = match &self.rp {
            Some(r) => Some(r.read_stats(ctx)?),
            None => None,
        };
        let n = (self.width * self.height) as usize;
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
                    if p.w < 0.0 { Vec3::NAN } else { p.truncate() }
                })
                .collect(),
            records: records[..n].to_vec(),
            pass_times,
            bvh,
            compute,
            search,
        })
    }
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

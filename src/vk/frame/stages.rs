//! The shared stages [`GpuRenderer`](super::GpuRenderer)'s creation allocates around the method:
//! the CMO stages (data, capture, pyramid) before the G-buffer, the cone stage, and the reflector
//! check, fallback and bounce rounds after the method's passes.

use glam::Vec3;

use super::plan::{CapturePlan, CmoPlan, ConePlan, FramePlan};
use super::{CmoCapture, Fallback};
use crate::cpu::options::TraceOptions;
use crate::cubemap::bounds::{DEFAULT_DEPTH, PoolBound};
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::GpuContext;
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::methods::{FrameInputs, Needs, Technique};
use crate::vk::passes::bounce::{BouncePasses, RoundPasses};
use crate::vk::passes::bvh::{AppendKind, BvhPasses, ReflectorCheck};
use crate::vk::passes::capture::Capture;
use crate::vk::passes::capture_lists::{CaptureLists, ListTargets};
use crate::vk::passes::cmo::{CaptureContents, CmoData};
use crate::vk::passes::cone::{ConePrefilter, ConePrefilterBindings, ConeStage};
use crate::vk::passes::gbuffer::Gbuffer;
use crate::vk::passes::lists::PackedLists;
use crate::vk::passes::pyramid::{Pyramid, PyramidBindings};
use crate::vk::passes::scene_buffers::SceneBuffers;

/// The stages before the G-buffer that the CMOs need: their data, the capture and the
/// pyramid, as the method's [`Needs`] say.
pub(super) struct CmoStages {
    pub(super) cmo: CmoData,
    /// The cone pass's own CMOs ([`CmoPlan::cone_size`]), which `colour_capture` fills.
    pub(super) cone_cmo: Option<CmoData>,
    pub(super) capture: Option<CmoCapture>,
    pub(super) colour_capture: Option<Box<Capture>>,
    /// The distances' pyramid, then the lists' gaps' where the capture is listed.
    pub(super) pyramid: Vec<(Pyramid, PyramidBindings)>,
    pub(super) cone_prefilter: Option<(ConePrefilter, ConePrefilterBindings)>,
}

impl CmoStages {
    /// The CMO data and stages `plan` says ([`CmoPlan`]) for `scene` uploaded into
    /// `scene_buffers`. With `--criterion bounded` the capture is the lists'
    /// (`passes::capture_lists`: per-texel bounds and candidate lists, their `lo` as the
    /// distances, node pool sized by its CPU bound), or for tests the lists built on the CPU
    /// (`lists`, [`CapturePlan::Uploaded`]), uploaded once.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        ctx: &GpuContext,
        scene: &Scene,
        data: &GpuSceneData,
        scene_buffers: &SceneBuffers,
        plan: &CmoPlan,
        trace: &TraceOptions,
        capture_near: f32,
        lists: Option<&PackedLists>,
    ) -> VkResult<Self> {
        let centres = scene.cmo_centres();
        let needs = &plan.needs;
        let Some(capture) = &plan.capture else {
            return Self::placeholder(ctx, &centres, trace, needs.contents);
        };
        let (size, self_reflections) = (plan.size, plan.self_reflections);
        let mut cmo = CmoData::with_contents(
            ctx,
            &centres,
            size,
            self_reflections,
            needs.pyramid,
            trace,
            needs.contents,
        )?;
        let raster = |size, contents| {
            Capture::with_contents(
                ctx,
                data,
                scene_buffers,
                &centres,
                size,
                self_reflections,
                capture_near,
                contents,
            )
        };
        // The cone pass's own CMOs, distance and colour at the cube size, where the lists take
        // a size of their own.
        let colour_only = CaptureContents {
            colour: true,
            triangle_ids: false,
        };
        let cone_cmo = match plan.cone_size {
            Some(n) => Some(CmoData::with_contents(
                ctx,
                &centres,
                n,
                self_reflections,
                false,
                trace,
                colour_only,
            )?),
            None => None,
        };
        // The bounded criterion's lists keep no colour: where the frame reads it (the cone pass
        // of a glossy scene), a rasterised capture fills the cone pass's own CMOs, in the CMO
        // stages (with uploaded lists too: it follows the capture's near plane).
        let colour_capture = match (capture, &cone_cmo) {
            (CapturePlan::Lists { .. } | CapturePlan::Uploaded { .. }, Some(c)) => {
                Some(Box::new(raster(c.size(), colour_only)?))
            }
            _ => None,
        };
        let capture = match capture {
            CapturePlan::Raster => {
                Some(CmoCapture::Raster(Box::new(raster(size, needs.contents)?)))
            }
            CapturePlan::Lists {
                views, capacity, ..
            } => {
                log::info!(
                    "bounded criterion: lists of {size} texels per face side (cube size {}), a \
                     pool of {} nodes",
                    scene.cmo.resolution,
                    capacity.nodes
                );
                Some(Self::list_capture(
                    ctx,
                    scene_buffers,
                    &mut cmo,
                    views,
                    *capacity,
                )?)
            }
            CapturePlan::Uploaded { .. } => {
                Self::upload_lists(ctx, &mut cmo, lists)?;
                None
            }
        };
        let listed = matches!(capture, Some(CmoCapture::Lists(_)))
            || matches!(plan.capture, Some(CapturePlan::Uploaded { .. }));
        let pyramid = pyramid_stage(ctx, &cmo, needs, listed)?;
        Ok(CmoStages {
            cmo,
            cone_cmo,
            capture,
            colour_capture,
            pyramid,
            cone_prefilter: None,
        })
    }

    /// One texel per face and no capture: composite binds the data, nothing reads it but the
    /// environment-map fallback of a ray the BVH loop's cap cut.
    fn placeholder(
        ctx: &GpuContext,
        centres: &[Vec3],
        trace: &TraceOptions,
        contents: CaptureContents,
    ) -> VkResult<Self> {
        let cmo = CmoData::with_contents(ctx, centres, 1, false, false, trace, contents)?;
        ctx.submit_and_wait("cmo placeholder", |rec| {
            cmo.record_clear(rec);
            Ok(())
        })?;
        Ok(CmoStages {
            cmo,
            cone_cmo: None,
            capture: None,
            colour_capture: None,
            pyramid: Vec::new(),
            cone_prefilter: None,
        })
    }

    /// `--criterion bounded`'s capture into `cmo` (see [`CmoStages::new`]) over the plan's
    /// views, its node pool at the plan's bound.
    fn list_capture(
        ctx: &GpuContext,
        scene_buffers: &SceneBuffers,
        cmo: &mut CmoData,
        views: &[(Vec3, bool)],
        capacity: PoolBound,
    ) -> VkResult<CmoCapture> {
        cmo.alloc_lists(ctx, capacity.nodes)?;
        let targets = ListTargets::of(cmo);
        Ok(CmoCapture::Lists(Box::new(CaptureLists::new(
            ctx,
            scene_buffers,
            cmo.size(),
            DEFAULT_DEPTH,
            views,
            capacity,
            Some(targets),
        )?)))
    }

    /// The bounded criterion's lists built on the CPU, uploaded into `cmo` once
    /// ([`super::GpuRenderer::with_lists`]) instead of a capture.
    fn upload_lists(
        ctx: &GpuContext,
        cmo: &mut CmoData,
        lists: Option<&PackedLists>,
    ) -> VkResult<()> {
        let Some(lists) = lists else {
            return Err(VkError::Usage {
                what: "CMO lists".into(),
                detail: "planned as uploaded, but none were given".into(),
            });
        };
        ctx.submit_and_wait("cmo clear", |rec| {
            cmo.record_clear(rec);
            Ok(())
        })?;
        cmo.upload_lists(ctx, lists)
    }
}

/// The pyramid pass over the CMO data's distances, where the method needs one, and over the
/// lists' gaps where the capture made lists (`listed`).
fn pyramid_stage(
    ctx: &GpuContext,
    cmo: &CmoData,
    needs: &Needs,
    listed: bool,
) -> VkResult<Vec<(Pyramid, PyramidBindings)>> {
    if !needs.pyramid {
        return Ok(Vec::new());
    }
    let p = Pyramid::new(ctx)?;
    let b = p.bind(ctx, cmo.distance(), cmo.mip(), cmo.count(), cmo.size())?;
    let mut out = vec![(p, b)];
    if listed {
        let [texels, mip] = cmo.gaps();
        let g = Pyramid::gaps(ctx)?;
        let b = g.bind(ctx, texels, mip, cmo.count(), cmo.size())?;
        out.push((g, b));
    }
    Ok(out)
}

/// Fragment's and compute's cone stage, where the plan has one ([`ConePlan::stage`]: a glossy
/// scene and one of them), after their trace; with its own 2x2 pyramid where the method builds
/// none (compute, [`ConePlan::own_pyramid`]).
pub(super) fn cone_stage(
    ctx: &GpuContext,
    cone: Option<ConePlan>,
    cmo: &CmoData,
    (gbuffer, params, records): (&Gbuffer, &Buffer, &Buffer),
) -> VkResult<Option<ConeStage>> {
    let Some(cone) = cone.filter(|c| c.stage) else {
        return Ok(None);
    };
    ConeStage::new(ctx, cmo, cone.own_pyramid, gbuffer, params, records).map(Some)
}

/// The shared stages after the method's passes, where the options and the method use them.
pub(super) struct AfterMethod {
    pub(super) check: Option<ReflectorCheck>,
    pub(super) fallback: Option<BvhPasses>,
    pub(super) bounce: Option<BouncePasses>,
}

impl AfterMethod {
    /// `check_triangles`: [`Scene::check_triangles`], the reflector check's.
    pub(super) fn new(
        i: &FrameInputs<'_>,
        plan: &FramePlan,
        check_triangles: &[u32],
        method: &dyn Technique,
    ) -> VkResult<Self> {
        let fallback = if plan.fallback {
            fallback_passes(i)?
        } else {
            None
        };
        let check = if plan.reflector_check {
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
        let bounce = if !plan.bounce_passes() {
            None
        } else {
            let frame = round_passes(method, i.options.bvh_bounces, &check, &fallback);
            Some(BouncePasses::new(
                i.ctx,
                plan.bounces,
                i.data,
                i.scene,
                i.gbuffer,
                i.params,
                i.records,
                frame,
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

/// What the bounce rounds use of the frame's passes ([`RoundPasses`]), at creation and when
/// recording: one BVH for the method's, the fallback's and the rounds' rays (none for the rounds
/// where the method traces them, unless `bvh_bounces`), the reflector check and the fallback.
pub(super) fn round_passes<'a>(
    method: &'a dyn Technique,
    bvh_bounces: bool,
    check: &'a Option<ReflectorCheck>,
    fallback: &'a Option<BvhPasses>,
) -> RoundPasses<'a> {
    RoundPasses {
        shared: method.bvh().or(fallback.as_ref()).map(|b| &b.tracer),
        method: method.traces_rounds() && !bvh_bounces,
        check: check.as_ref().map(|c| &c.passes),
        fallback: fallback.as_ref(),
    }
}

/// [`Fallback::Trace`]'s BVH passes, where the plan has them ([`FramePlan::fallback`]: the method
/// can leave a record unresolved,
/// [`Method::can_leave_unresolved`](crate::method::Method::can_leave_unresolved)).
fn fallback_passes(inputs: &FrameInputs<'_>) -> VkResult<Option<BvhPasses>> {
    let kind = match inputs.options.fallback {
        Fallback::Trace => AppendKind::Unresolved,
        #[cfg(feature = "test-hooks")]
        Fallback::TraceFromTDone => AppendKind::UnresolvedFromTDone,
        Fallback::Flag | Fallback::Envmap | Fallback::Background => return Ok(None),
    };
    let i = inputs;
    BvhPasses::new(
        i.ctx, kind, i.data, i.scene, i.gbuffer, i.params, i.records, i.t_hi,
    )
    .map(Some)
}

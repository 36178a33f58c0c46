//! The shared stages [`GpuRenderer`]'s creation allocates around the method: the CMO stages (data,
//! capture, pyramid) before the G-buffer, the cone stage, and the reflector check, fallback and
//! bounce rounds after the method's passes.

use super::{CmoCapture, Fallback};
use crate::cpu::options::{TraceCriterion, TraceOptions};
use crate::cubemap::bounds::DEFAULT_DEPTH;
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::GpuContext;
use crate::vk::backend::error::VkResult;
use crate::vk::methods::{FrameInputs, Needs, Technique};
use crate::vk::passes::bounce::BouncePasses;
use crate::vk::passes::bvh::{AppendKind, BvhPasses, ReflectorCheck};
use crate::vk::passes::capture::Capture;
use crate::vk::passes::capture_lists;
use crate::vk::passes::capture_lists::{CaptureLists, ListTargets};
use crate::vk::passes::cmo::CmoData;
use crate::vk::passes::cone::{ConePrefilter, ConePrefilterBindings, ConeStage};
use crate::vk::passes::gbuffer::Gbuffer;
use crate::vk::passes::lists::PackedLists;
use crate::vk::passes::pyramid::{Pyramid, PyramidBindings};
use crate::vk::passes::scene_buffers::SceneBuffers;

/// The stages before the G-buffer that the CMOs need: their data, the capture and the
/// pyramid, as the method's [`Needs`] say.
pub(super) struct CmoStages {
    pub(super) cmo: CmoData,
    pub(super) capture: Option<CmoCapture>,
    pub(super) colour_capture: Option<Box<Capture>>,
    pub(super) pyramid: Option<(Pyramid, PyramidBindings)>,
    pub(super) cone_prefilter: Option<(ConePrefilter, ConePrefilterBindings)>,
}

impl CmoStages {
    /// `gpu`: the scene's data and its buffers. With `--criterion bounded` the capture is the
    /// lists' (`passes::capture_lists`: per-texel bounds and candidate lists, their `lo` as the
    /// distances, node pool sized by its CPU bound), or for tests the lists built on the CPU
    /// (`lists`), uploaded once.
    pub(super) fn new(
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
pub(super) fn cone_stage(
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
        check_triangles: &[u32],
        method: &dyn Technique,
    ) -> VkResult<Self> {
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

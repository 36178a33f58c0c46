//! The renderer's creation: the checks it makes first, [`GpuRenderer::new`], its variant on the
//! placement search's lists and two for tests, the one `create` that allocates every pass, and
//! the helpers the camera and geometry updates share with it (frame params, rebasing on the
//! anchor, the reflectors' screen rectangle).

use std::borrow::Cow;

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;

use super::plan::{CapturePlan, FramePlan};
use super::stages::{AfterMethod, CmoStages, cone_stage};
use super::{FLAG_COLOUR, Fallback, FrameParams, GpuRenderer, PixelRecord, RenderOptions};
use crate::camera::Camera;
use crate::cubemap::bounds::BuiltLists;
use crate::ranges::FrameRanges;
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::GpuContext;
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::timestamps::Timestamps;
use crate::vk::methods::{self, FrameInputs, MethodSpec};
use crate::vk::options::ListSize;
use crate::vk::passes::bounce::MAX_BOUNCES;
use crate::vk::passes::capture_lists::scene_triangles;
use crate::vk::passes::composite::Composite;
use crate::vk::passes::cone::ConePrefilter;
use crate::vk::passes::gbuffer::Gbuffer;
use crate::vk::passes::lists::{PackedLists, pack};
use crate::vk::passes::scene_buffers::SceneBuffers;

/// Refuses what the method cannot do ([`check_bounces`](crate::method::Method::check_bounces),
/// [`check_trace`](crate::method::Method::check_trace)) and
/// the reference, which is no GPU method.
pub(super) fn check_method(options: &RenderOptions) -> VkResult<&'static dyn MethodSpec> {
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
/// captures CMOs ([`Needs::capture`](crate::vk::methods::technique::Needs::capture)).
pub(super) fn check_ranges(
    ranges: &FrameRanges,
    scene: &Scene,
    options: &RenderOptions,
) -> VkResult<()> {
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
        Self::anchored(ctx, scene, camera, options, Lists::Captured)
    }

    /// [`GpuRenderer::new`] taking the bounded criterion's lists from `built` (the placement
    /// search's, [`crate::placement::Placement::lists`], built in the scene's coordinates
    /// relative to its anchor) instead of a capture, where the frame's capture would have their
    /// inputs ([`BuiltLists::same_inputs`]), and runs no capture pass. The frame is the
    /// captured one bit for bit where the capture cuts no list (`-v`: no walk capped, nothing
    /// dropped); where it would, the rays past the cut resolve here by the whole list, not by
    /// the next CMO or the fallback: the same triangles. Otherwise, or under another
    /// criterion, it is [`GpuRenderer::new`]'s.
    pub fn with_built_lists(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
        built: &BuiltLists,
    ) -> VkResult<Self> {
        Self::anchored(ctx, scene, camera, options, Lists::Built(built))
    }

    /// [`GpuRenderer::new`] with its lists from `lists`.
    fn anchored(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
        lists: Lists<'_>,
    ) -> VkResult<Self> {
        let anchor = crate::ranges::anchor(scene);
        let (local, local_camera) = rebased(anchor, scene, camera);
        let ranges = FrameRanges::new(&local, &local_camera);
        check_ranges(&ranges, &local, &options)?;
        let mut r = Self::create(ctx, &local, &local_camera, options, &ranges, lists)?;
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
        Self::create(ctx, scene, camera, options, ranges, Lists::Captured)
    }

    /// [`GpuRenderer::new`] for `--criterion bounded` with the per-texel lists built on the
    /// CPU in the GPU layout (`vk::passes::lists::pack` of one
    /// [`TexelLists`](crate::cubemap::bounds::TexelLists) per CMO in [`Scene::cmo_centres`]
    /// order, of the scene's face size), uploaded instead of a capture
    /// ([`CmoData::upload_lists`](crate::vk::passes::cmo::CmoData::upload_lists)).
    pub fn with_lists(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
        lists: &PackedLists,
    ) -> VkResult<Self> {
        let ranges = FrameRanges::new(scene, camera);
        check_ranges(&ranges, scene, &options)?;
        // The uploaded lists have the scene's face size.
        let options = RenderOptions {
            list_size: ListSize::Cube,
            ..options
        };
        Self::create(ctx, scene, camera, options, &ranges, Lists::Packed(lists))
    }

    fn create(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: RenderOptions,
        ranges: &FrameRanges,
        lists: Lists<'_>,
    ) -> VkResult<Self> {
        if scene.cmo_centres().is_empty() {
            return Err(VkError::Usage {
                what: "scene".into(),
                detail: "no CMO centres".into(),
            });
        }
        check_method(&options)?.check_device(ctx)?;
        let data = GpuSceneData::new(scene);
        // What the frame allocates: the one plan the memory estimate counts too.
        let mut plan = FramePlan::new(scene, &data, camera, &options);
        let packed = lists.packed(&plan, &data);
        let lists = packed.as_deref();
        if lists.is_some() {
            plan = plan.with_uploaded_lists();
        }
        let scene_buffers = SceneBuffers::new(ctx, &data)?;
        let mut stages = CmoStages::new(
            ctx,
            scene,
            &data,
            &scene_buffers,
            &plan.cmo,
            &options.trace,
            ranges.capture_near,
            lists,
        )?;
        // The pre-filtered CMO colour chain, for a method that reads it, on a glossy scene only.
        // On the cone pass's own CMOs where it has them.
        if plan.cone.is_some() {
            let cone_cmo = stages.cone_cmo.as_mut().unwrap_or(&mut stages.cmo);
            cone_cmo.alloc_cone(ctx)?;
            let p = ConePrefilter::new(ctx)?;
            let b = p.bind(ctx, cone_cmo, scene.background)?;
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
        let check_triangles = scene.check_triangles(options.bounded());
        let cone_cmo = stages.cone_cmo.as_ref().unwrap_or(&stages.cmo);
        let cone = cone_stage(ctx, plan.cone, cone_cmo, (&gbuffer, &params, &records))?;
        let after = AfterMethod::new(&inputs, &plan, &check_triangles, method.as_ref())?;
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
            cone_cmo: stages.cone_cmo,
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
            lists_pending: lists.is_some(),
            plan,
        })
    }
}

/// Where a new renderer's bounded lists come from.
#[derive(Clone, Copy)]
enum Lists<'a> {
    /// Its own capture (or no lists: another criterion).
    Captured,
    /// Uploaded, in the plan's face size ([`GpuRenderer::with_lists`]).
    Packed(&'a PackedLists),
    /// Uploaded where the capture has their inputs, else captured
    /// ([`GpuRenderer::with_built_lists`]).
    Built(&'a BuiltLists),
}

impl<'a> Lists<'a> {
    /// The lists to upload for `plan`, if any.
    fn packed(self, plan: &FramePlan, data: &GpuSceneData) -> Option<Cow<'a, PackedLists>> {
        match self {
            Lists::Captured => None,
            Lists::Packed(p) => Some(Cow::Borrowed(p)),
            Lists::Built(built) => planned_lists(plan, data, built).map(Cow::Owned),
        }
    }
}

/// `built` in the GPU layout where the planned capture is of lists with `built`'s inputs, else
/// `None` (the frame captures; `-v` says why).
fn planned_lists(plan: &FramePlan, data: &GpuSceneData, built: &BuiltLists) -> Option<PackedLists> {
    let Some(CapturePlan::Lists { views, .. }) = &plan.cmo.capture else {
        return None;
    };
    built_lists(plan.cmo.size, views, data, built)
}

/// `built` in the GPU layout where a capture of lists at face size `size` of `views` over
/// `data` has `built`'s inputs, else `None` (`-v` says why).
pub(super) fn built_lists(
    size: u32,
    views: &[(Vec3, bool)],
    data: &GpuSceneData,
    built: &BuiltLists,
) -> Option<PackedLists> {
    let same = built.same_inputs(size, views, |reflectors| scene_triangles(data, reflectors));
    let packed = same.and_then(|()| pack(&built.lists));
    match packed {
        Ok(p) => {
            log::info!(
                "bounded criterion: the placement search's lists ({} CMOs, {} texels per face \
                 side) uploaded, no capture pass",
                built.lists.len(),
                size
            );
            Some(p)
        }
        Err(why) => {
            log::info!("bounded criterion: the placement search's lists not taken ({why})");
            None
        }
    }
}

/// The `FrameParams` of a frame.
pub(super) fn frame_params(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    t_hi: f32,
) -> FrameParams {
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

/// `scene` and `camera` relative to `anchor` ([`Scene::rebased`]), borrowed as they are where
/// it is the world origin.
pub(super) fn rebased<'a>(
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
pub(super) fn mirror_rect(data: &GpuSceneData, camera: &Camera, near: f32) -> Option<[u32; 4]> {
    camera.screen_rect(
        data.vertices
            .iter()
            .filter(|v| data.objects[v.object as usize].reflector != 0)
            .map(|v| Vec3::from_array(v.position)),
        near,
    )
}

//! Updating a renderer in place: the camera ([`GpuRenderer::set_camera`]), the film's sample key,
//! and the geometry's placement ([`GpuRenderer::update_geometry`]).

use glam::Vec3;

use super::create::{built_lists, check_ranges, frame_params, mirror_rect, rebased};
use super::{CmoCapture, FrameParams, GpuRenderer, StaleUpdate};
use crate::camera::Camera;
use crate::cubemap::bounds::BuiltLists;
use crate::ranges::FrameRanges;
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::context::GpuContext;
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::methods;
use crate::vk::methods::GeometryInputs;
use crate::vk::passes::capture_lists;
use crate::vk::passes::capture_lists::ListTargets;
use crate::vk::passes::lists::PackedLists;
use crate::vk::passes::scene_buffers::SceneBuffers;

/// What [`GpuRenderer::update_geometry`] writes (its `geometry_plan`): the scene as uploaded,
/// its ranges and CMO centres, and the bounded capture's views and capacities.
struct GeometryPlan {
    data: GpuSceneData,
    ranges: FrameRanges,
    centres: Vec<Vec3>,
    lists: Option<(Vec<(Vec3, bool)>, crate::cubemap::bounds::PoolBound)>,
    /// The bounded lists given with the update, in the GPU layout, where taken: written in
    /// place of the capture.
    packed: Option<PackedLists>,
}

impl GpuRenderer {
    /// Points every pass at `camera` (the frame size of creation, else [`VkError::Usage`]): the
    /// frame params, the G-buffer's matrix and near plane, the reflectors' screen rectangle and
    /// the method's own camera state ([`Technique::set_camera`](crate::vk::methods::Technique::set_camera)). The next frame is bit for bit
    /// that of [`GpuRenderer::new`] for `scene` and `camera`; `scene` must be the one the
    /// renderer was created for, but for its cameras. The CMO stages run again only where their
    /// input changed: the capture's near plane ([`FrameRanges::capture_near`], which depends on
    /// the eye through its floor); [`GpuFrame::captured`](super::GpuFrame::captured) says whether a frame ran them.
    pub fn set_camera(&mut self, ctx: &GpuContext, scene: &Scene, camera: &Camera) -> VkResult<()> {
        self.set_camera_with(ctx, scene, camera, true)
    }

    pub(super) fn set_camera_with(
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
    /// or the bounded criterion's lists were uploaded at creation and none are given: see
    /// [`GpuRenderer::update_geometry_with_lists`]): nothing was changed, and the
    /// caller builds a new renderer. A bounded capture whose pool or job buffer the moved
    /// geometry outgrows gets larger ones, bound where the old ones were. An error where a new
    /// renderer would fail for the same reason (the depth range check, the device's limits).
    pub fn update_geometry(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
    ) -> VkResult<Option<String>> {
        self.update_geometry_with(ctx, scene, camera, None, None)
    }

    /// [`GpuRenderer::update_geometry`] taking the bounded criterion's lists from `built` (the
    /// placement search's for `scene`, [`crate::placement::Placement::lists`]) instead of a
    /// capture, where the capture would have their inputs bit for bit
    /// ([`BuiltLists::same_inputs`], as [`GpuRenderer::with_built_lists`] takes them): the next
    /// frame runs no capture pass and is the captured frame (where the capture cuts no list).
    /// Otherwise the frame captures, and a renderer made on uploaded lists, which has no
    /// capture, says why it cannot be updated.
    pub fn update_geometry_with_lists(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        built: &BuiltLists,
    ) -> VkResult<Option<String>> {
        self.update_geometry_with(ctx, scene, camera, None, Some(built))
    }

    /// [`GpuRenderer::update_geometry_with_lists`] (`built` where given) leaving `stale` as it
    /// was (`None`: the update itself; `Some` only through the tests' hooks).
    pub(crate) fn update_geometry_with(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        stale: Option<StaleUpdate>,
        built: Option<&BuiltLists>,
    ) -> VkResult<Option<String>> {
        let (local, local_camera) = rebased(self.anchor, scene, camera);
        match self.geometry_plan(&local, &local_camera, built)? {
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
        built: Option<&BuiltLists>,
    ) -> VkResult<Result<GeometryPlan, String>> {
        if (camera.width, camera.height) != (self.width, self.height) {
            return Ok(Err("the frame size changed".into()));
        }
        if self.lists_uploaded && built.is_none() {
            return Ok(Err(
                "the bounded capture's lists were uploaded at creation, and none were given".into(),
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
        if scene.check_triangles(self.options.bounded()) != self.check_triangles {
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
        let packed = match built {
            Some(b) if lists.is_some() || self.lists_uploaded => {
                let views = capture_lists::scene_views(scene);
                built_lists(self.cmo.size(), &views, &data, b)
            }
            _ => None,
        };
        if self.lists_uploaded && packed.is_none() {
            return Ok(Err(
                "the bounded capture's lists were uploaded at creation, and this frame's were not \
                 taken"
                    .into(),
            ));
        }
        Ok(Ok(GeometryPlan {
            data,
            ranges,
            centres,
            lists,
            packed,
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
            packed,
        } = plan;
        let t_hi = ranges.t_hi;
        if stale != Some(StaleUpdate::Vertices) {
            self._scene.write_geometry(ctx, &data)?;
        }
        self.cmo.set_centres(ctx, &centres)?;
        if let Some(c) = &mut self.cone_cmo {
            c.set_centres(ctx, &centres)?;
        }
        if let Some(c) = &mut self.colour_capture {
            c.set_views(ctx, &data, &centres, ranges.capture_near)?;
        }
        match (&mut self.capture, lists) {
            (Some(CmoCapture::Raster(c)), _) => {
                c.set_views(ctx, &data, &centres, ranges.capture_near)?
            }
            (Some(CmoCapture::Lists(c)), Some((views, capacity))) => {
                // A pool too small for the moved geometry is allocated again, and rebound.
                let mut grown = self.cmo.grow_pool(ctx, capacity.nodes)?;
                let targets = ListTargets::of(&self.cmo);
                // Updated with lists uploaded too: a frame that captures again
                // (`invalidate_capture`) captures these views.
                c.update(ctx, &self._scene, &views, capacity, Some(targets))?;
                if let Some(p) = &packed {
                    grown |= self.cmo.write_lists(ctx, p)?;
                }
                if grown {
                    self.method.rebind_cmo(ctx, &self.cmo)?;
                    self.composite.rebind_cmo(&self.cmo)?;
                }
            }
            (None, _) => {
                if let Some(p) = &packed
                    && self.cmo.write_lists(ctx, p)?
                {
                    self.method.rebind_cmo(ctx, &self.cmo)?;
                    self.composite.rebind_cmo(&self.cmo)?;
                }
            }
            _ => {}
        }
        self.lists_pending = packed.is_some();
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
}

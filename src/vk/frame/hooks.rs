//! The tests' hooks on the renderer (`test-hooks` feature only): wrong updates for the negatives,
//! frames without the cone pass, and the device's live allocations (for the memory estimate's
//! check).

use super::{GpuRenderer, StaleUpdate};
use crate::camera::Camera;
use crate::scene::Scene;
use crate::vk::backend::context::GpuContext;
use crate::vk::backend::error::VkResult;

impl GpuRenderer {
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
        self.update_geometry_with(ctx, scene, camera, Some(stale), None)
    }

    /// Test hook: frames without (`true`) or with the `cone` pass, everything else the same
    /// (the records the pass reads, for its CPU twin `cpu::cone::cone_pixel`).
    #[cfg(feature = "test-hooks")]
    pub fn skip_cone(&mut self, skip: bool) {
        self.cone_skipped = skip;
    }
}

/// The device's live allocations, each with its name and bytes (the allocator's report): what
/// the tests hold the memory estimate against. A renderer's are those that appear while it is
/// created and live.
pub fn live_allocations(ctx: &GpuContext) -> Vec<(String, u64)> {
    let report = ctx.device().allocator().generate_report();
    (report.allocations.into_iter())
        .map(|a| (a.name, a.size))
        .collect()
}

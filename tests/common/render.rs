//! One GPU frame as most suites make it: a renderer for a camera of the scene at a test size,
//! and its first frame.

use cubetrace::camera::Camera;
use cubetrace::scene::Scene;
use cubetrace::vk::frame::{GpuFrame, GpuRenderer, RenderOptions};
use cubetrace::vk::{GpuContext, VkResult};

/// `scene`'s first camera at `size` (width, height).
pub fn sized_camera(scene: &Scene, size: (u32, u32)) -> Camera {
    let mut c = scene.camera(None).unwrap().clone();
    (c.width, c.height) = size;
    c
}

/// The first frame of a renderer of `options` for `scene` seen from `camera`
/// ([`GpuRenderer::new`]), and the renderer; panics naming `what` where either fails.
pub fn first_frame(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    options: RenderOptions,
    what: &str,
) -> (GpuFrame, GpuRenderer) {
    first_frame_of(ctx, GpuRenderer::new(ctx, scene, camera, options), what)
}

/// The first frame of `made` (what [`GpuRenderer::new`] or one of its siblings returned), and
/// the renderer; panics naming `what` where either failed.
pub fn first_frame_of(
    ctx: &GpuContext,
    made: VkResult<GpuRenderer>,
    what: &str,
) -> (GpuFrame, GpuRenderer) {
    let mut r = made.unwrap_or_else(|e| panic!("{what}: {e}"));
    let f = r.render(ctx).unwrap_or_else(|e| panic!("{what}: {e}"));
    (f, r)
}

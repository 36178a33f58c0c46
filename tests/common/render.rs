//! One GPU frame as most suites make it: a renderer for a camera of the scene at a test size,
//! and its first frame.

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::cpu::options::{TraceCriterion, TraceOptions};
use cubetrace::scene::Scene;
use cubetrace::vk::frame::{GpuFrame, GpuRenderer, RECORD_UNRESOLVED, RenderOptions};
use cubetrace::vk::{GpuContext, VkResult};

/// The options of `method` under `criterion`, the others the library's defaults.
pub fn criterion_options(method: Method, criterion: TraceCriterion) -> RenderOptions {
    RenderOptions {
        method,
        trace: TraceOptions {
            criterion,
            ..TraceOptions::default()
        },
        ..RenderOptions::default()
    }
}

/// The mirror pixels of `frame` whose record is unresolved.
pub fn unresolved_pixels(frame: &GpuFrame) -> usize {
    (0..frame.records.len())
        .filter(|&k| frame.mask[k] != 0 && frame.records[k].status == RECORD_UNRESOLVED)
        .count()
}

/// `scene`'s first camera at `size` (width, height).
pub fn sized_camera(scene: &Scene, size: (u32, u32)) -> Camera {
    let mut c = scene.camera(None).unwrap().clone();
    (c.width, c.height) = size;
    c
}

/// Scene `name` (a built-in name or a file, as `scene::load` takes it) and its first camera at
/// `size`.
pub fn load_sized(name: &str, size: (u32, u32)) -> (Scene, Camera) {
    let s = cubetrace::scene::load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
    let camera = sized_camera(&s, size);
    (s, camera)
}

/// Scene `name` with CMO faces of `cube` texels and, where `power` is given, every reflector at
/// that specular power; its first camera at `size`, made its only camera.
pub fn scene_at(name: &str, cube: u32, power: Option<f32>, size: (u32, u32)) -> (Scene, Camera) {
    let (mut s, camera) = load_sized(name, size);
    s.cmo.resolution = cube;
    if let Some(p) = power {
        s.make_reflectors_glossy(p);
    }
    s.cameras = vec![camera.clone()];
    (s, camera)
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

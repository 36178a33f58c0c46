//! GPU memory of a render, estimated before anything is allocated, from the sizes that
//! [`super::frame::GpuRenderer::new`] and the objects it creates use. Pure arithmetic: no Vulkan
//! call. The scene's own buffers (vertices, indices, textures) are not counted: they are the
//! size of the scene's files, small against frames and CMOs at the sizes where a refusal matters.

use super::frame::{PixelRecord, RenderOptions, capture_contents};
use super::methods::compute::AppendedRay;
use crate::camera::Camera;
use crate::cpu::options::TraceOptions;
use crate::cubemap::pyramid::{hier32_len, mip_len};
use crate::method::Method;
use crate::scene::Scene;

/// Bytes per texel of one face of one CMO: f32 distances (`cmo_distance`), RGBA f32 colour
/// (`cmo_colour`), the capture pass's f32 distance target, and with self-reflections the
/// capture's normal target and `cmo_normal` (RGBA f32 each).
pub fn cmo_bytes_per_texel(self_reflections: bool) -> u64 {
    cmo_bytes_per_texel_with(
        self_reflections,
        super::passes::cmo::CaptureContents::default(),
    )
}

/// [`cmo_bytes_per_texel`] for the chosen capture contents: the colour (16 B) only where
/// captured, and with triangle IDs the capture's u32 target and `CmoData`'s ID buffer (4 B
/// each). IDs without colour take 8 B less per texel than colour without IDs.
pub fn cmo_bytes_per_texel_with(
    self_reflections: bool,
    contents: super::passes::cmo::CaptureContents,
) -> u64 {
    4 + 4
        + if contents.colour { 16 } else { 0 }
        + if contents.triangle_ids { 4 + 4 } else { 0 }
        + if self_reflections { 16 + 16 } else { 0 }
}

/// Bytes per frame pixel: the pixel records, the frame colour (RGBA f32), the G-buffer (colour,
/// position, normal: RGBA f32 each; triangle ID u32; depth f32), and for the compute path the
/// ray queue and the per-ray statistics; for ssr the Hi-Z pyramid; the BVH tracer's ray queue
/// for `bvh` and for every method that can leave a pixel unresolved (the `trace` fallback's
/// queue, counted whatever the fallback: an upper bound). The CWBVH itself is per triangle, like
/// the scene's buffers, and not counted.
pub fn frame_bytes_per_pixel(method: Method) -> u64 {
    let records = size_of::<PixelRecord>() as u64;
    let gbuffer = 3 * 16 + 4 + 4;
    let bvh_queue = size_of::<super::passes::bvh::BvhRay>() as u64;
    let method_bytes = match method {
        Method::Compute => size_of::<AppendedRay>() as u64 + 16 + bvh_queue,
        // The Hi-Z pyramid: f32 cells, about 4/3 per pixel over all levels (2 on a one-pixel-wide
        // frame; counted as 2), plus the ssr pass's parameters (per frame, negligible).
        Method::Ssr => 2 * 4 + bvh_queue,
        // The reflection-point method: the reflector's position and normal textures, the
        // virtual objects' colour and point (RGBA f32 each) and two f32 depth buffers, at search
        // scale 1 (T_P, T_N and their depth grow with the scale's square: not counted); its
        // per-vertex buffer is per scene vertex (small beside these, not counted).
        Method::ReflectionPoint => 4 * 16 + 2 * 4 + bvh_queue,
        Method::Fragment | Method::Bvh => bvh_queue,
        Method::Envmap | Method::Reference => 0,
    };
    records + 16 + gbuffer + method_bytes
}

/// What a render allocates on the device, in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceBytes {
    /// Per-pixel buffers and images of the frame.
    pub frame: u64,
    /// CMO data (distances, colours, capture targets, pyramid or hierarchy).
    pub cmo: u64,
}

impl DeviceBytes {
    pub fn total(&self) -> u64 {
        self.frame + self.cmo
    }
}

/// The device memory of one render of `width` x `height` pixels with `cmos` CMOs of
/// `cube_size` texels per face side, capturing what [`capture_contents`] says for `method` and
/// the tracer options `trace`.
pub fn device_bytes(
    width: u32,
    height: u32,
    method: Method,
    cmos: u32,
    cube_size: u32,
    self_reflections: bool,
    trace: &TraceOptions,
) -> DeviceBytes {
    let pixels = u64::from(width) * u64::from(height);
    // `bvh` captures one texel per face (`GpuRenderer`): nothing reads its CMOs.
    let cube_size = if method == Method::Bvh { 1 } else { cube_size };
    let face = u64::from(cube_size) * u64::from(cube_size);
    let texels = u64::from(cmos) * 6 * face;
    // [min, max] f32 pairs per cell.
    let acceleration = match method {
        Method::Fragment => u64::from(cmos) * mip_len(cube_size) as u64 * 8,
        Method::Compute => u64::from(cmos) * hier32_len(cube_size) as u64 * 8,
        Method::Envmap
        | Method::Ssr
        | Method::ReflectionPoint
        | Method::Bvh
        | Method::Reference => 0,
    };
    DeviceBytes {
        frame: pixels * frame_bytes_per_pixel(method),
        // The capture's depth target: one face at a time.
        cmo: texels * cmo_bytes_per_texel_with(self_reflections, capture_contents(method, trace))
            + face * 4
            + acceleration,
    }
}

/// The device bytes `--bounces N` adds to a render of `width` x `height` pixels: for N >= 2,
/// two queues of one [`BvhRay`](super::passes::bvh::BvhRay) per pixel (the rounds alternate between
/// them); nothing otherwise. The BVH is per triangle and not counted, as above.
pub fn bounce_bytes(width: u32, height: u32, bounces: u32) -> u64 {
    if bounces < 2 {
        return 0;
    }
    2 * u64::from(width) * u64::from(height) * size_of::<super::passes::bvh::BvhRay>() as u64
}

/// The device bytes the reflector check ([`super::passes::bvh::ReflectorCheck`]) adds to a render of
/// `width` x `height` pixels when it runs: one queue of one [`BvhRay`](super::passes::bvh::BvhRay) per
/// pixel; nothing otherwise. Its BVH is per triangle and not counted, as above.
pub fn reflector_check_bytes(width: u32, height: u32, runs: bool) -> u64 {
    if !runs {
        return 0;
    }
    u64::from(width) * u64::from(height) * size_of::<super::passes::bvh::BvhRay>() as u64
}

/// The device memory of one render of `scene` seen by `camera` with `options`: the CMOs, the
/// frame's buffers, the bounce queues and the reflector check's queue. The one estimate that
/// `render` and `bench` check before anything is allocated.
pub fn estimate(scene: &Scene, camera: &Camera, options: &RenderOptions) -> DeviceBytes {
    let (width, height) = (camera.width, camera.height);
    let base = device_bytes(
        width,
        height,
        options.method,
        scene.cmo_centres().len() as u32,
        scene.cmo.resolution,
        scene.captures_reflectors(),
        &options.trace,
    );
    let check = options.reflector_check
        && options.method.has_reflector_check()
        && !scene.check_triangles().is_empty();
    DeviceBytes {
        frame: base.frame
            + bounce_bytes(width, height, options.bounces)
            + reflector_check_bytes(width, height, check),
        ..base
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vk::passes::cmo::CaptureContents;

    #[test]
    fn bounce_queues_only_past_one_bounce() {
        assert_eq!(bounce_bytes(160, 120, 0), 0);
        assert_eq!(bounce_bytes(160, 120, 1), 0);
        assert_eq!(bounce_bytes(160, 120, 2), 2 * 160 * 120 * 48);
        assert_eq!(bounce_bytes(160, 120, 16), bounce_bytes(160, 120, 2));
    }

    #[test]
    fn triangle_ids_replace_colour_at_less_memory() {
        let with = |colour, triangle_ids| CaptureContents {
            colour,
            triangle_ids,
        };
        for s in [false, true] {
            let colour = cmo_bytes_per_texel_with(s, with(true, false));
            assert_eq!(colour, cmo_bytes_per_texel(s), "the default is today's");
            assert_eq!(cmo_bytes_per_texel_with(s, with(false, true)) + 8, colour);
            assert_eq!(cmo_bytes_per_texel_with(s, with(true, true)), colour + 8);
        }
    }

    #[test]
    fn sizes_grow_with_what_they_depend_on() {
        let exact = TraceOptions::default();
        let base = device_bytes(160, 120, Method::Fragment, 1, 256, false, &exact);
        // 6 * 256^2 texels of 16 bytes (distance and ID, each in the CMO and the capture's
        // target), plus the pyramid: about 6.3 MiB + 2.x MiB.
        assert!(base.cmo > 6 * 256 * 256 * 16, "{base:?}");
        assert!(base.cmo < 6 * 256 * 256 * 24, "{base:?}");
        assert!(base.frame >= 160 * 120 * (96 + 16 + 52), "{base:?}");
        // Negative: each input changes the estimate the way it should.
        let twice = device_bytes(160, 120, Method::Fragment, 2, 256, false, &exact);
        assert!(twice.cmo > 2 * base.cmo - 6 * 256 * 256);
        let big = device_bytes(320, 240, Method::Fragment, 1, 256, false, &exact);
        assert_eq!(big.frame, 4 * base.frame);
        let selfr = device_bytes(160, 120, Method::Fragment, 1, 256, true, &exact);
        assert!(selfr.cmo > base.cmo);
        let compute = device_bytes(160, 120, Method::Compute, 1, 256, false, &exact);
        assert!(compute.frame > base.frame);
        let envmap = device_bytes(160, 120, Method::Envmap, 1, 256, false, &exact);
        let threshold = TraceOptions {
            criterion: crate::cpu::options::TraceCriterion::Threshold,
            ..exact
        };
        let approx = device_bytes(160, 120, Method::Fragment, 1, 256, false, &threshold);
        assert!(envmap.cmo < approx.cmo && base.cmo < approx.cmo);
        assert_eq!(approx.cmo - base.cmo, 6 * 256 * 256 * 16, "the colour");
    }
}

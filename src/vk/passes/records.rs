//! The frame's records and parameters as the shaders declare them (`spirv/shared/mirror.wgsl`):
//! the one buffer every method writes and the shared stages after it read.
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

#[cfg(doc)]
use crate::{camera::Camera, scene::Scene};

/// The flag colour of [`Fallback::Flag`](crate::vk::options::Fallback::Flag) (linear magenta).
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
    /// [`Camera::jitter`] (pixels), x and y.
    pub jitter_x: f32,
    pub up: [f32; 3],
    pub jitter_y: f32,
    pub back: [f32; 3],
    /// The film's sample key ([`crate::lobe::sample_key`]) of the frame, for the glossy lobe's
    /// directions; 0 outside a film's sample loop ([`crate::vk::frame::GpuRenderer::set_sample`]).
    pub sample: u32,
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
    /// Verified hits (the centre criterion in the fragment and compute paths): the global
    /// triangle hit; `u32::MAX` otherwise and for methods that do not verify.
    pub triangle: u32,
    /// 1 where the compute path's step loop ended before the ray did (the driver's loop limit:
    /// spirv/README.md, "Known defect"); such a ray is unresolved. 0 elsewhere.
    pub cut: u32,
    /// 1 where [`Fallback::Trace`](crate::vk::options::Fallback::Trace) finished the ray with the BVH tracer (`bvh_trace`); 0
    /// elsewhere (then `cut` = 1 means the BVH loop's cap cut it too).
    pub fallback: u32,
    /// Reflections the pixel's path took ([`RenderOptions::bounces`](crate::vk::options::RenderOptions::bounces); the reference's
    /// `Frame::bounces`): 1 from every method's own pass, more from the bounce rounds
    /// ([`super::bounce`]), 0 with no bounce.
    pub bounces: u32,
    /// 1 where the reflector check ([`RenderOptions::reflector_check`](crate::vk::options::RenderOptions::reflector_check),
    /// [`super::bvh::ReflectorCheck`]) replaced the method's result with a nearer hit on a
    /// reflector (such a record's `fallback` stays 0: the check is not the fallback, and the
    /// fallback share does not count it); 2 where it found the method's hit at the ray's own
    /// start (the BVH start rule's triangles: a self-captured reflector's surface verified at
    /// t ~ 0) and made the pixel unresolved again, for the fallback to trace in full; 0 elsewhere.
    pub checked: u32,
}

pub use crate::cpu::fragment::{RECORD_ESCAPED, RECORD_HIT, RECORD_UNRESOLVED};

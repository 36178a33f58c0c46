//! The `gbuffer` pass: the camera's view of the scene (colour, world position with the mirror
//! mask, normal), the input of every tracing pass.
//!
//! Invariants:
//! - Pixel convention and projection are [`crate::camera::Camera`]'s (`view_proj`), so pixel
//!   `(i, j)` of the G-buffer is the CPU reference's pixel `(i, j)`. Depth is reversed (test
//!   `GREATER`, cleared to 0) with no far plane: D32_SFLOAT keeps f32's relative precision at
//!   every distance, and only geometry nearer than `near` is clipped
//!   ([`crate::ranges::FrameRanges`]).
//! - Position, normal and uv are those of the pixel-centre ray's hit ([`Camera::ray`], the
//!   reference's primary ray) on the rasterised triangle's plane, recomputed in the fragment
//!   shader: the rasteriser's own interpolation strays from that ray by its sub-pixel snapping,
//!   enough to turn a grazing reflected ray onto a neighbouring triangle.
//! - Images are left in `SHADER_READ_ONLY_OPTIMAL` after [`Gbuffer::record`]: `colour` (rgb
//!   shaded, a = 1 where covered), `position` (xyz world; w = 1 on a reflector, 0 elsewhere, -1
//!   where nothing is drawn), `normal` (xyz the interpolated vertex normal, unnormalised; w = 1
//!   where covered, but on a glossy reflector, where w = `-1 - p`, `p` its Phong specular power
//!   ([`crate::lobe`]): so a mirror's G-buffer is the same, bit for bit, whether or not the scene
//!   has glossy reflectors), `triangle` (R32_UINT: the global index of the triangle seen, in
//!   `WorldGeometry::triangles` order). Uncovered pixels hold the background with alpha 0,
//!   `(0, 0, 0, -1)`, zero and `u32::MAX`.
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};

use super::scene_buffers::SceneBuffers;
use crate::camera::Camera;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::VkResult;
use crate::vk::backend::graphics::{
    ColourTarget, DepthTest, GraphicsDesc, GraphicsPipeline, RenderTarget,
};
use crate::vk::backend::image::{Image, ImageDesc};
use crate::vk::backend::pipeline::{BindGroup, Resource};
use crate::vk::backend::shaders::GBUFFER;
use crate::vk::backend::sync::{COLOUR_WRITE, SHADER_READ};

/// `GbufferCamera` in `spirv/gbuffer.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GbufferCamera {
    pub view_proj: [[f32; 4]; 4],
    pub eye: [f32; 3],
    pub tan_half: f32,
    pub right: [f32; 3],
    pub aspect: f32,
    pub up: [f32; 3],
    pub width: f32,
    pub back: [f32; 3],
    pub height: f32,
    /// [`Camera::jitter`] (pixels).
    pub jitter: [f32; 2],
    pub pad: [f32; 2],
}

impl GbufferCamera {
    /// The pass's camera: `view_proj` for the rasteriser, and [`Camera::ray`]'s inputs for the
    /// primary hit that the fragment shader recomputes on the pixel-centre ray.
    pub fn new(camera: &Camera, near: f32) -> Self {
        let (right, up, back) = camera.basis();
        GbufferCamera {
            view_proj: camera.view_proj(near).to_cols_array_2d(),
            eye: camera.eye.to_array(),
            tan_half: camera.tan_half_fov_y(),
            right: right.to_array(),
            aspect: camera.aspect(),
            up: up.to_array(),
            width: camera.width as f32,
            back: back.to_array(),
            height: camera.height as f32,
            jitter: camera.jitter.to_array(),
            pad: [0.0; 2],
        }
    }
}

const FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
const TRIANGLE_FORMAT: vk::Format = vk::Format::R32_UINT;

/// The G-buffer pass for one camera.
pub struct Gbuffer {
    pipeline: GraphicsPipeline,
    scene_set: BindGroup,
    camera_set: BindGroup,
    _camera: Buffer,
    depth: Image,
    index_count: u32,
    /// Shaded colour (a = 1 where covered).
    pub colour: Image,
    /// World position, w = mirror mask.
    pub position: Image,
    /// Interpolated normal, w = 1 where covered (`-1 - p` on a glossy reflector of power `p`).
    pub normal: Image,
    /// Global triangle index (`u32::MAX` where nothing is drawn).
    pub triangle: Image,
}

impl Gbuffer {
    /// Prepares the pass. `near` is the camera's near plane (world units, along the view axis):
    /// the depth is reversed with no far plane ([`Camera::proj`]).
    pub fn new(
        ctx: &GpuContext,
        scene: &SceneBuffers,
        camera: &Camera,
        near: f32,
    ) -> VkResult<Self> {
        let pipeline = GraphicsPipeline::new(
            ctx,
            &GBUFFER,
            &GraphicsDesc {
                vertex: "vs_main",
                fragment: "fs_main",
                colour_formats: vec![FORMAT, FORMAT, FORMAT, TRIANGLE_FORMAT],
                depth: Some((vk::Format::D32_SFLOAT, DepthTest::Reversed)),
            },
        )?;
        let uniform = GbufferCamera::new(camera, near);
        let camera_buf = ctx.create_buffer_init(
            "gbuffer camera",
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            std::slice::from_ref(&uniform),
        )?;
        let scene_set = pipeline.bind_group(0, &scene.resources())?;
        let camera_set = pipeline.bind_group(1, &[(0, Resource::Buffer(&camera_buf))])?;
        let (w, h) = (camera.width, camera.height);
        let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT
            | vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_SRC;
        let dev = ctx.device();
        let image = |name: &str| Image::new(dev, ImageDesc::d2(name, FORMAT, w, h, usage));
        Ok(Gbuffer {
            colour: image("gbuffer colour")?,
            position: image("gbuffer position")?,
            normal: image("gbuffer normal")?,
            triangle: Image::new(
                dev,
                ImageDesc::d2("gbuffer triangle", TRIANGLE_FORMAT, w, h, usage),
            )?,
            depth: Image::new(
                dev,
                ImageDesc::d2(
                    "gbuffer depth",
                    vk::Format::D32_SFLOAT,
                    w,
                    h,
                    vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                ),
            )?,
            pipeline,
            scene_set,
            camera_set,
            _camera: camera_buf,
            index_count: scene.index_count,
        })
    }

    /// Points the pass at `camera` with near plane `near` (the size of the one it was created
    /// for): the next [`Gbuffer::record`] is that of a pass created for it.
    pub fn set_camera(&self, ctx: &GpuContext, camera: &Camera, near: f32) -> VkResult<()> {
        let uniform = GbufferCamera::new(camera, near);
        ctx.write_buffer(&self._camera, std::slice::from_ref(&uniform))
    }

    /// Image size `(width, height)`.
    pub fn extent(&self) -> (u32, u32) {
        (self.colour.desc().width, self.colour.desc().height)
    }

    /// Records the draw and leaves the images readable by shaders.
    pub fn record(&self, rec: &Recorder<'_>, background: Vec3) -> VkResult<()> {
        let images = [&self.colour, &self.position, &self.normal, &self.triangle];
        rec.prepare_render_targets(&images, Some(&self.depth), SHADER_READ);
        let clear = |v: Vec4| vk::ClearColorValue {
            float32: v.to_array(),
        };
        let clears = [
            clear(background.extend(0.0)),
            clear(Vec4::new(0.0, 0.0, 0.0, -1.0)),
            clear(Vec4::ZERO),
            vk::ClearColorValue {
                uint32: [u32::MAX; 4],
            },
        ];
        let (width, height) = self.extent();
        let target = RenderTarget {
            width,
            height,
            colour: images
                .iter()
                .zip(clears)
                .map(|(img, c)| ColourTarget {
                    view: img.view(),
                    clear: c,
                })
                .collect(),
            depth: Some(self.depth.view()),
        };
        self.pipeline.draw(
            rec,
            &target,
            &[&self.scene_set, &self.camera_set],
            self.index_count,
            0,
        )?;
        for img in images {
            rec.image_barrier(
                img,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                COLOUR_WRITE,
                SHADER_READ,
            );
        }
        Ok(())
    }
}

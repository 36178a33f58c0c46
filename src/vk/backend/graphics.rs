//! Graphics pipelines: one vertex and one fragment entry point of a pass, drawn with dynamic
//! rendering (no render pass or framebuffer objects).
//!
//! Invariants:
//! - No vertex input state: vertex shaders pull their data from storage buffers by
//!   `vertex_index` (and select per-draw data by `instance_index`), so the only interface between
//!   Rust and WGSL is the reflected bindings.
//! - Rasterisation is what the CPU reference assumes: triangle lists, no culling (the reference
//!   hits both sides of a triangle), fill mode, no depth bias. Depth, when present, is tested with
//!   writes ([`DepthTest`]), so the nearest surface along each pixel's ray wins.
//! - Viewport and scissor are dynamic; the viewport always covers the whole target: pixel
//!   `(i, j)` has its centre at `(i + 0.5, j + 0.5)`, row 0 at the top, as [`crate::camera`]
//!   defines. The scissor does too, unless a draw narrows it ([`GraphicsPipeline::draw_in`]).
//! - Attachments must be in `COLOR_ATTACHMENT_OPTIMAL` / `DEPTH_ATTACHMENT_OPTIMAL` when a draw is
//!   recorded; callers transition them (see [`crate::vk::Recorder::image_barrier`]).
use std::sync::Arc;

use ash::vk;

use super::context::{GpuContext, Recorder};
use super::device::Device;
use super::error::{VkError, VkResult, call_err};
use super::pipeline::{BindGroup, PipelineLayout, Resource, shader_module};
use super::shaders::{EntryPoint, Pass, Stage};

/// What [`GraphicsPipeline::new`] builds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GraphicsDesc {
    /// Vertex entry point.
    pub vertex: &'static str,
    /// Fragment entry point.
    pub fragment: &'static str,
    /// One format per `@location(i)` fragment output, in order.
    pub colour_formats: Vec<vk::Format>,
    /// Depth attachment format and test, or none.
    pub depth: Option<(vk::Format, DepthTest)>,
}

/// How depth is tested (always with writes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthTest {
    /// `GREATER`, cleared to 0: reversed depth (`z / w = near / distance` along the view axis),
    /// with f32 relative precision at every distance and no far plane.
    Reversed,
}

/// One colour attachment of a draw: the view and its clear value.
#[derive(Clone, Copy)]
pub struct ColourTarget {
    pub view: vk::ImageView,
    pub clear: vk::ClearColorValue,
}

/// The attachments of one draw, all `width x height`.
#[derive(Clone)]
pub struct RenderTarget {
    pub width: u32,
    pub height: u32,
    pub colour: Vec<ColourTarget>,
    /// Depth view, cleared for the pipeline's [`DepthTest`].
    pub depth: Option<vk::ImageView>,
}

/// A graphics pipeline for one vertex + fragment entry point pair of a pass.
pub struct GraphicsPipeline {
    pub pass: &'static Pass,
    raw: vk::Pipeline,
    colour_count: usize,
    depth: Option<DepthTest>,
    /// Dropped after `raw` (field order after `Drop::drop`).
    layout: PipelineLayout,
    device: Arc<Device>,
}

fn entry<'p>(pass: &'p Pass, name: &str, stage: Stage) -> VkResult<&'p EntryPoint> {
    pass.entry_point(name)
        .filter(|e| e.stage == stage)
        .ok_or_else(|| VkError::Shader {
            pass: pass.name.into(),
            detail: format!("no {stage:?} entry point `{name}`"),
        })
}

impl GraphicsPipeline {
    /// Builds the pipeline with descriptor set layouts reflected from both entry points.
    pub fn new(ctx: &GpuContext, pass: &'static Pass, desc: &GraphicsDesc) -> VkResult<Self> {
        let device = ctx.device();
        let vs = entry(pass, desc.vertex, Stage::Vertex)?;
        let fs = entry(pass, desc.fragment, Stage::Fragment)?;
        let layout = PipelineLayout::from_reflection(device, pass, &[vs, fs])?;
        let module = shader_module(device, pass)?;
        let names = [vs.name, fs.name].map(std::ffi::CString::new);
        let [Ok(vs_name), Ok(fs_name)] = names else {
            // SAFETY: the module is not used by any pipeline yet.
            unsafe { device.raw.destroy_shader_module(module, None) };
            return Err(VkError::Shader {
                pass: pass.name.into(),
                detail: "entry point name contains NUL".into(),
            });
        };
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(module)
                .name(&vs_name),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(module)
                .name(&fs_name),
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(desc.depth.is_some())
            .depth_write_enable(desc.depth.is_some())
            // Every depth-tested pass uses reversed depth (`DepthTest::Reversed`); without a
            // depth attachment the test is off and the op unused.
            .depth_compare_op(vk::CompareOp::GREATER);
        let blend_attachments: Vec<vk::PipelineColorBlendAttachmentState> = desc
            .colour_formats
            .iter()
            .map(|_| {
                vk::PipelineColorBlendAttachmentState::default()
                    .color_write_mask(vk::ColorComponentFlags::RGBA)
            })
            .collect();
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&desc.colour_formats)
            .depth_attachment_format(desc.depth.map_or(vk::Format::UNDEFINED, |d| d.0));
        let info = [vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout.raw)
            .push_next(&mut rendering)];
        // SAFETY: module, layout, entry names and every state struct are alive for the call; the
        // layout was reflected from this module; dynamic rendering is enabled on every device.
        let created = unsafe {
            device
                .raw
                .create_graphics_pipelines(vk::PipelineCache::null(), &info, None)
        };
        // SAFETY: pipeline creation is done with the module (success or not).
        unsafe { device.raw.destroy_shader_module(module, None) };
        let raw = created.map_err(|(_, e)| call_err("vkCreateGraphicsPipelines", pass.name)(e))?[0];
        device.set_name(raw, pass.name);
        Ok(GraphicsPipeline {
            pass,
            raw,
            colour_count: desc.colour_formats.len(),
            depth: desc.depth.map(|d| d.1),
            layout,
            device: device.clone(),
        })
    }

    /// Creates descriptor set `group` with `resources` given as `(binding, resource)`.
    pub fn bind_group(&self, group: u32, resources: &[(u32, Resource<'_>)]) -> VkResult<BindGroup> {
        BindGroup::new(&self.device, self.pass, &self.layout, group, resources)
    }

    /// Records one draw into `target`, which is cleared first: `vertex_count` vertices of one
    /// instance numbered `instance` (shaders select per-draw data by `instance_index`). `sets`
    /// must be consecutive groups starting at group 0.
    pub fn draw(
        &self,
        rec: &Recorder<'_>,
        target: &RenderTarget,
        sets: &[&BindGroup],
        vertex_count: u32,
        instance: u32,
    ) -> VkResult<()> {
        self.record(rec, target, sets, &[(vertex_count, instance)], None)
    }

    /// [`GraphicsPipeline::draw`] with several draws into the one target, in order, each
    /// `(vertex_count, instance)`: the target is cleared once (and only cleared where `draws` is
    /// empty).
    pub fn draws(
        &self,
        rec: &Recorder<'_>,
        target: &RenderTarget,
        sets: &[&BindGroup],
        draws: &[(u32, u32)],
    ) -> VkResult<()> {
        self.record(rec, target, sets, draws, None)
    }

    /// [`GraphicsPipeline::draw`] with the fragments limited to the pixel rectangle `scissor`
    /// (`[x0, y0, x1, y1)`, within the target; `None`: the whole target). The attachments are
    /// still cleared whole.
    pub fn draw_in(
        &self,
        rec: &Recorder<'_>,
        target: &RenderTarget,
        sets: &[&BindGroup],
        vertex_count: u32,
        instance: u32,
        scissor: Option<[u32; 4]>,
    ) -> VkResult<()> {
        self.record(rec, target, sets, &[(vertex_count, instance)], scissor)
    }

    fn record(
        &self,
        rec: &Recorder<'_>,
        target: &RenderTarget,
        sets: &[&BindGroup],
        draws: &[(u32, u32)],
        scissor: Option<[u32; 4]>,
    ) -> VkResult<()> {
        if target.colour.len() != self.colour_count
            || target.depth.is_some() != self.depth.is_some()
        {
            return Err(VkError::Usage {
                what: self.pass.name.into(),
                detail: format!(
                    "draw with {} colour attachments (depth: {}), pipeline has {} (depth: {})",
                    target.colour.len(),
                    target.depth.is_some(),
                    self.colour_count,
                    self.depth.is_some()
                ),
            });
        }
        let colour: Vec<vk::RenderingAttachmentInfo> = target
            .colour
            .iter()
            .map(|c| {
                vk::RenderingAttachmentInfo::default()
                    .image_view(c.view)
                    .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(vk::ClearValue { color: c.clear })
            })
            .collect();
        let depth = target.depth.map(|view| {
            vk::RenderingAttachmentInfo::default()
                .image_view(view)
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .clear_value(vk::ClearValue {
                    depth_stencil: vk::ClearDepthStencilValue {
                        // Reversed depth: cleared to the far end.
                        depth: 0.0,
                        stencil: 0,
                    },
                })
        });
        let area = vk::Rect2D {
            offset: vk::Offset2D { x: 0, y: 0 },
            extent: vk::Extent2D {
                width: target.width,
                height: target.height,
            },
        };
        let mut info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&colour);
        if let Some(d) = &depth {
            info = info.depth_attachment(d);
        }
        let dev = &self.device.raw;
        let cmd = rec.raw();
        let viewport = [vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: target.width as f32,
            height: target.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        }];
        let raw_sets: Vec<vk::DescriptorSet> = sets.iter().map(|s| s.raw()).collect();
        // SAFETY: `cmd` is recording outside a render pass; attachments are alive, in the layouts
        // named above (the caller's contract), and match the pipeline's formats.
        unsafe { dev.cmd_begin_rendering(cmd, &info) };
        // SAFETY: inside the rendering scope begun above; the pipeline is alive.
        unsafe { dev.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.raw) };
        // SAFETY: viewport and scissor are dynamic states of this pipeline.
        unsafe { dev.cmd_set_viewport(cmd, 0, &viewport) };
        let scissor = scissor.map_or(area, |[x0, y0, x1, y1]| {
            let (x1, y1) = (x1.min(target.width), y1.min(target.height));
            let (x0, y0) = (x0.min(x1), y0.min(y1));
            vk::Rect2D {
                offset: vk::Offset2D {
                    x: x0 as i32,
                    y: y0 as i32,
                },
                extent: vk::Extent2D {
                    width: x1 - x0,
                    height: y1 - y0,
                },
            }
        });
        // SAFETY: as above; the scissor lies within the render area.
        unsafe { dev.cmd_set_scissor(cmd, 0, &[scissor]) };
        if !raw_sets.is_empty() {
            // SAFETY: the sets were allocated with this pipeline's set layouts, in group order.
            unsafe {
                dev.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.layout.raw,
                    sets[0].group(),
                    &raw_sets,
                    &[],
                )
            };
        }
        for &(vertex_count, instance) in draws {
            // SAFETY: pipeline, dynamic state and sets are bound.
            unsafe { dev.cmd_draw(cmd, vertex_count, 1, 0, instance) };
        }
        // SAFETY: closes the rendering scope begun above.
        unsafe { dev.cmd_end_rendering(cmd) };
        Ok(())
    }
}

impl Drop for GraphicsPipeline {
    fn drop(&mut self) {
        // SAFETY: no submission using the pipeline is pending (submissions are waited on).
        unsafe { self.device.raw.destroy_pipeline(self.raw, None) };
    }
}

//! `--method reflection-point`: the reflection-point search with virtual objects of Estalella et
//! al. 2006, three named passes after the G-buffer:
//!
//! | pass | reads | writes |
//! |---|---|---|
//! | `reflection_point_targets` | scene | the reflectors alone from the camera, closed ([`crate::cpu::closure`]; T_P: position + mask, T_N: normal) |
//! | `reflection_point_search` | scene, T_P, T_N | one invocation per scene vertex: the local 3x3 search and the virtual vertex (the method's tracing pass, the one the bench and the cost model time) |
//! | `reflection_point_raster` | scene, virtual vertices, G-buffer | the virtual objects with depth, in the mirror pixels only (colour, original point); then one record per mirror pixel |
//!
//! The search is specified by its CPU twin [`crate::cpu::reflection_point`]; the shaders are
//! `spirv/reflection_point_search.wgsl` and `spirv/reflection_point_raster.wgsl`. Mirror pixels that no virtual object covers
//! get an unresolved record, filled by the frame's fallback in `composite` (the environment map
//! by default), and are counted as unresolved by the metrics.
//!
//! Invariants: every image and buffer here is fully rewritten every frame; the barriers inside
//! each pass are recorded here; the one between the G-buffer and `reflection_point_raster` (which reads its
//! mirror mask) and the one before `composite` belong to the caller
//! ([`crate::vk::frame::GpuRenderer`]).
//!
//! # How it works
//!
//! Reflection-point search with virtual objects, after Estalella, Martin, Drettakis and Tost, "A
//! GPU-driven Algorithm for Accurate Interactive Reflections on Curved Objects" (EGSR 2006). Passes
//! `reflection_point_search` and `reflection_point_raster`; the CPU twin of the search is
//! `cpu::reflection_point`.
//!
//! - Textures (section 4): the reflectors alone, from the camera, into T_P (world position + mask)
//!   and T_N (normal), at `--rp-scale` times the frame's size (default 1). Other objects are not
//!   drawn there, so they do not hide the reflector from the search.
//! - Search, one compute invocation per scene vertex (reflector vertices skipped): start at the
//!   projected centre of the reflectors' bounding box (off the reflector: the nearest reflector
//!   texel along the crosshair's arms); the first step tests the four crosshair neighbours, later
//!   steps all eight; move to the best `dot(N, B)` until the centre wins, or stop at
//!   `--rp-iterations` (default: the textures' width + height, so a walk can cross them; the
//!   vertex's triangles are then not drawn). A fixed cap of 256 gave up 19 % of `sphere-room`'s
//!   searches at `--rp-scale 8`.
//! - Region C (section 5.1): a vertex behind the plane of the texel found takes the inverse search
//!   from there, scoring the mirror image of the vertex in each texel's plane. The virtual vertex is
//!   the vertex mirrored in the final texel's plane; its depth in the virtual pass is the reflected
//!   path's length `|O - R| + |R - V|`, not its own (a hidden vertex's mirror image lies in front of
//!   the mirror and would hide the true reflections near the outline).
//! - Leaving the reflector: texels off it never win, so a search whose maximum lies beyond the
//!   outline stops on the outline. The paper's wider search frustum (5.2) and frame-to-frame
//!   coherence (5.3) are not implemented: reflection points off screen end on the frame's border.
//! - Closed versions (5.1, the paper's open/closed pair; `cpu::closure`): the search runs on a
//!   watertight version of every open reflector (boundary loops capped by a fan from their
//!   centroid); the mirror mask stays the open one; `--rp-open` searches the reflectors as they are.
//!   Where the mirror is the inside (the concave `bowl`), the cap is drawn behind every reflector
//!   surface, since a cap in front would make it a plane mirror (40 % -> 0 % of the reference's
//!   object). Limitation: an open reflector whose mirror is its inside can only be searched where
//!   the camera sees it.
//! - Virtual objects (`reflection_point_raster`): every non-reflector triangle at its virtual
//!   vertices, depth tested, drawn only where the mirror mask is set, shaded at the original vertex
//!   attributes; the record's hit point is the original surface point and `face` the object.
//!   Uncovered mirror pixels are unresolved. Reflectors are not reflected (no self-reflections).
//!   Several reflectors share one pair of textures and one virtual scene (the paper: one each).
//!
//! Invariants: GPU and twin agree on every vertex of every built-in scene exactly (status, texel,
//! steps) and to 1e-4 on the virtual vertex, also on closed search textures; a moved eye, a lower
//! cap or one turned normal shows. Every built-in reflector's closed version is watertight.
//!
//! Tessellation dependence. The method reflects vertices and joins them by straight edges: a coarse
//! object reflects as a polygon, a wall of two triangles barely at all. `--subdivide N` splits every
//! non-reflector triangle into four N times (same surfaces, same reference); `bench --scaling`
//! measures the curve (`scaling.md`, "tessellation"). The paper's measure, same object (of the
//! reference's mirror pixels showing a non-reflector object, the share where the method shows it),
//! at 160x120 on lavapipe:
//!
//! | scene | scale | subdivide 0 / 1 / 2 / 3 / 4: same object % |
//! |---|---:|---|
//! | sphere-room | 1 | 49.2 / 94.3 / 94.3 / 94.7 / 95.5 |
//! | sphere-room | 8 | 42.4 / 93.8 / 97.6 / 98.3 / 98.5 |
//! | bowl | 1 | 3.0 / 33.9 / 40.3 / 59.3 / 67.8 |
//! | torus | 1 | 5.9 / 10.5 / 10.9 / 14.4 / 18.8 |
//!
//! On the convex sphere, beyond one level the search texture's resolution bounds it (a reflection
//! point is a texel, and near the outline a texel spans a wide range of directions): the paper's
//! 98 % or more needs both a fine tessellation and a fine texture (192x144, `--subdivide 4 --rp-scale 8`:
//! 98.4 %, tested). A vertex with several reflection points gets one virtual vertex (the paper's
//! stated limitation) and the local search stops at the first maximum: the concave bowl and the
//! mixed torus stay far below (the torus's vertices are seen in both rings). PSNR hardly moves (15
//! to 18 dB): the floor's checkerboard reflects finer than a pixel, so a hit millimetres off flips a
//! check. Cost: steps grow with the texture's side (25 per vertex at scale 1, 192 at 8), time with
//! the vertex count (`reflection_point_search` 2.5 to 4.2 ms at 400 vertices, 2.3 to 3.5 s at 74k
//! and scale 8).
//!
//! Where it wins: a convex reflector and few, well-tessellated objects. It needs no per-pixel
//! tracing: 3.7 ms for search and rasterisation at 5k vertices on sphere-room at 160x120, against
//! 14 and 20 ms for the fragment and compute tracing passes. It loses on large flat objects, on
//! concave and mixed reflectors, on self-reflections, and near the outline. In the bench (160x120,
//! lavapipe) it leaves 62.5 % of the mirror pixels to the fallback as is and 23.8 %
//! subdivided twice, where 74 % are then on the wrong surface (`teapot`, `torus`, `bowl` show wrong
//! reflections where they showed the fallback).
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};
use gpu_allocator::MemoryLocation;

use crate::camera::Camera;
use crate::cpu::closure::{ClosureVertex, closing_triangles};
use crate::cpu::options::TraceOptions;
use crate::cpu::reflection_point::{RpOptions, RpVertex, SearchStats, SearchTextures, start_texel};
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::graphics::{
    ColourTarget, DepthTest, GraphicsDesc, GraphicsPipeline, RenderTarget,
};
use crate::vk::backend::image::{Image, ImageDesc};
use crate::vk::backend::pipeline::{
    BindGroup, ComputeOptions, ComputePipeline, MAX_GROUPS_X, Resource, dispatch_rows,
};
use crate::vk::backend::shaders::{Pass, REFLECTION_POINT_RASTER, REFLECTION_POINT_SEARCH};
use crate::vk::backend::sync::{COLOUR_WRITE, SHADER_READ, SHADER_WRITE};
use crate::vk::passes::cmo::CaptureContents;
use crate::vk::passes::gbuffer::Gbuffer;
use crate::vk::passes::scene_buffers::SceneBuffers;

use super::technique::{
    CameraInputs, FrameInputs, GeometryInputs, MethodSpec, MethodStats, Needs, Scope, Technique,
};

/// `RpParams` in `spirv/reflection_point_search.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct RpParams {
    pub view_proj: [[f32; 4]; 4],
    pub eye: [f32; 3],
    pub max_iterations: u32,
    pub start: [i32; 2],
    pub width: u32,
    pub height: u32,
    pub vertex_count: u32,
    /// The scene's index count: the reflector draw's vertices past it are closing ones.
    pub index_count: u32,
    pub pad1: u32,
    pub pad2: u32,
}

impl RpParams {
    /// The search's parameters for a frame of `width` x `height` pixels seen by `camera`
    /// (near plane `near`) over `data`, whose index buffer holds `index_count` indices. Refuses
    /// a search scale whose textures exceed the largest resolution.
    fn for_frame(
        data: &GpuSceneData,
        index_count: u32,
        camera: &Camera,
        near: f32,
        options: &RpOptions,
        (width, height): (u32, u32),
    ) -> VkResult<Self> {
        let scale = options.search_scale.max(1);
        let (sw, sh) = (width.saturating_mul(scale), height.saturating_mul(scale));
        crate::scene::check_resolution(sw, sh).map_err(|e| VkError::Usage {
            what: "reflection-point search scale".into(),
            detail: format!("{width}x{height} times {scale}: the search textures' {e}"),
        })?;
        let view_proj = camera.view_proj(near);
        Ok(RpParams {
            view_proj: view_proj.to_cols_array_2d(),
            eye: camera.eye.to_array(),
            max_iterations: options.iteration_cap(sw, sh),
            start: start_texel(data, view_proj, sw, sh),
            width: sw,
            height: sh,
            vertex_count: data.vertices.len() as u32,
            index_count,
            pad1: 0,
            pad2: 0,
        })
    }
}

/// `RpCamera` in `spirv/reflection_point_raster.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct RpCamera {
    pub view_proj: [[f32; 4]; 4],
    pub eye: [f32; 3],
    pub near: f32,
}

const FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// The closing triangles of open reflectors ([`crate::cpu::closure`]) as a buffer, and their
/// vertex count (the buffer holds one default vertex when there are none: a storage buffer
/// cannot be empty; the shader reads only the count).
fn closure_buffer(
    ctx: &GpuContext,
    data: &GpuSceneData,
    options: &RpOptions,
) -> VkResult<(Buffer, u32)> {
    let (closure, closure_vertices) = closure_contents(data, options);
    let buffer =
        ctx.create_buffer_init("rp closure", vk::BufferUsageFlags::STORAGE_BUFFER, &closure)?;
    Ok((buffer, closure_vertices))
}

/// What [`closure_buffer`] holds and its vertex count.
fn closure_contents(data: &GpuSceneData, options: &RpOptions) -> (Vec<ClosureVertex>, u32) {
    let mut closure = if options.close_reflectors {
        closing_triangles(data)
    } else {
        Vec::new()
    };
    let closure_vertices = closure.len() as u32;
    if closure.is_empty() {
        closure.push(ClosureVertex::default());
    }
    (closure, closure_vertices)
}

/// The reflector draw's group 1: the search params and the closing triangles.
fn reflector_set(
    reflector: &GraphicsPipeline,
    params: &Buffer,
    closure: &Buffer,
) -> VkResult<BindGroup> {
    reflector.bind_group(
        1,
        &[
            (0, Resource::Buffer(params)),
            (4, Resource::Buffer(closure)),
        ],
    )
}

/// The search textures T_P and T_N and their depth at the search size `search`, then the
/// virtual objects' colour, point and depth at the frame size `frame`.
fn images(ctx: &GpuContext, search: (u32, u32), frame: (u32, u32)) -> VkResult<[Image; 6]> {
    let dev = ctx.device();
    let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT
        | vk::ImageUsageFlags::SAMPLED
        | vk::ImageUsageFlags::TRANSFER_SRC;
    let image =
        |name: &str, (w, h): (u32, u32)| Image::new(dev, ImageDesc::d2(name, FORMAT, w, h, usage));
    let depth = |name: &str, (w, h): (u32, u32)| {
        Image::new(
            dev,
            ImageDesc::d2(
                name,
                vk::Format::D32_SFLOAT,
                w,
                h,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            ),
        )
    };
    Ok([
        image("rp reflector position", search)?,
        image("rp reflector normal", search)?,
        depth("rp reflector depth", search)?,
        image("rp virtual colour", frame)?,
        image("rp virtual point", frame)?,
        depth("rp virtual depth", frame)?,
    ])
}

/// The colour formats and depth test of both passes' draws.
fn draw_desc(vertex: &'static str, fragment: &'static str) -> GraphicsDesc {
    GraphicsDesc {
        vertex,
        fragment,
        colour_formats: vec![FORMAT; 2],
        depth: Some((vk::Format::D32_SFLOAT, DepthTest::Reversed)),
    }
}

/// `reflection_point_search`'s pipelines: the reflectors' draw into T_P / T_N, the per-vertex
/// search.
struct SearchPipelines {
    reflector: GraphicsPipeline,
    reflector_sets: [BindGroup; 2],
    search: ComputePipeline,
    search_sets: [BindGroup; 2],
}

impl SearchPipelines {
    fn new(
        ctx: &GpuContext,
        scene: &SceneBuffers,
        params: &Buffer,
        closure: &Buffer,
        position: &Image,
        normal: &Image,
        vertices: &Buffer,
    ) -> VkResult<Self> {
        let pass = &REFLECTION_POINT_SEARCH;
        let reflector =
            GraphicsPipeline::new(ctx, pass, &draw_desc("vs_reflector", "fs_reflector"))?;
        let reflector_sets = [
            reflector.bind_group(
                0,
                &scene.resources_for(pass, &["vs_reflector", "fs_reflector"]),
            )?,
            reflector_set(&reflector, params, closure)?,
        ];
        let search = ComputePipeline::new(ctx, pass, "search", ComputeOptions::default())?;
        let search_sets = [
            search.bind_group(0, &scene.resources_for(pass, &["search"]))?,
            search.bind_group(
                1,
                &[
                    (0, Resource::Buffer(params)),
                    (1, Resource::sampled(position)),
                    (2, Resource::sampled(normal)),
                    (3, Resource::Buffer(vertices)),
                ],
            )?,
        ];
        Ok(SearchPipelines {
            reflector,
            reflector_sets,
            search,
            search_sets,
        })
    }
}

/// `reflection_point_raster`'s pipelines: the virtual objects' draw, the records' resolve.
struct RasterPipelines {
    virtual_draw: GraphicsPipeline,
    virtual_sets: [BindGroup; 2],
    resolve: ComputePipeline,
    resolve_set: BindGroup,
}

impl RasterPipelines {
    /// `targets`: the virtual objects' colour and point.
    fn new(
        ctx: &GpuContext,
        scene: &SceneBuffers,
        camera: &Buffer,
        vertices: &Buffer,
        gbuffer: &Gbuffer,
        [virtual_colour, virtual_point]: [&Image; 2],
        records: &Buffer,
    ) -> VkResult<Self> {
        let pass = &REFLECTION_POINT_RASTER;
        let virtual_draw =
            GraphicsPipeline::new(ctx, pass, &draw_desc("vs_virtual", "fs_virtual"))?;
        let virtual_sets = [
            virtual_draw
                .bind_group(0, &scene.resources_for(pass, &["vs_virtual", "fs_virtual"]))?,
            virtual_draw.bind_group(
                1,
                &[
                    (0, Resource::Buffer(camera)),
                    (1, Resource::Buffer(vertices)),
                    (2, Resource::sampled(&gbuffer.position)),
                ],
            )?,
        ];
        let resolve = ComputePipeline::new(ctx, pass, "resolve", ComputeOptions::default())?;
        let resolve_set = resolve.bind_group(
            0,
            &[
                (8, Resource::Buffer(camera)),
                (9, Resource::sampled(&gbuffer.position)),
                (10, Resource::sampled(&gbuffer.normal)),
                (11, Resource::sampled(virtual_colour)),
                (12, Resource::sampled(virtual_point)),
                (13, Resource::Buffer(records)),
            ],
        )?;
        Ok(RasterPipelines {
            virtual_draw,
            virtual_sets,
            resolve,
            resolve_set,
        })
    }
}

/// The two passes of the reflection-point method for one scene and camera, allocated once.
pub struct ReflectionPointPasses {
    reflector: GraphicsPipeline,
    reflector_sets: [BindGroup; 2],
    search: ComputePipeline,
    search_sets: [BindGroup; 2],
    search_groups: [u32; 3],
    virtual_draw: GraphicsPipeline,
    virtual_sets: [BindGroup; 2],
    resolve: ComputePipeline,
    resolve_set: BindGroup,
    params_buf: Buffer,
    options: RpOptions,
    /// The closing triangles of open reflectors ([`crate::cpu::closure`]).
    closure: Buffer,
    closure_vertices: u32,
    camera_buf: Buffer,
    vertices: Buffer,
    /// T_P: world position, w = 1 on a reflector texel.
    pub position: Image,
    /// T_N: the interpolated normal (unnormalised), w = 1 on a reflector texel.
    pub normal: Image,
    reflector_depth: Image,
    virtual_colour: Image,
    virtual_point: Image,
    virtual_depth: Image,
    index_count: u32,
    vertex_count: usize,
    params: RpParams,
    width: u32,
    height: u32,
}

impl ReflectionPointPasses {
    /// Creates both passes; `records` is the frame's record buffer.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        data: &GpuSceneData,
        scene: &SceneBuffers,
        gbuffer: &Gbuffer,
        camera: &Camera,
        near: f32,
        records: &Buffer,
        options: &RpOptions,
    ) -> VkResult<Self> {
        let (width, height) = gbuffer.extent();
        let vertex_count = data.vertices.len();
        let params = RpParams::for_frame(
            data,
            scene.index_count,
            camera,
            near,
            options,
            (width, height),
        )?;
        let (sw, sh) = (params.width, params.height);
        let params_buf = ctx.create_buffer_init(
            "rp params",
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            std::slice::from_ref(&params),
        )?;
        let cam = RpCamera {
            view_proj: params.view_proj,
            eye: params.eye,
            near,
        };
        let camera_buf = ctx.create_buffer_init(
            "rp camera",
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            std::slice::from_ref(&cam),
        )?;
        let (closure_buf, closure_vertices) = closure_buffer(ctx, data, options)?;
        let vertices = Buffer::new(
            ctx.device(),
            "rp vertices",
            (vertex_count.max(1) * size_of::<RpVertex>()) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let [
            position,
            normal,
            reflector_depth,
            virtual_colour,
            virtual_point,
            virtual_depth,
        ] = images(ctx, (sw, sh), (width, height))?;
        let SearchPipelines {
            reflector,
            reflector_sets,
            search,
            search_sets,
        } = SearchPipelines::new(
            ctx,
            scene,
            &params_buf,
            &closure_buf,
            &position,
            &normal,
            &vertices,
        )?;
        let RasterPipelines {
            virtual_draw,
            virtual_sets,
            resolve,
            resolve_set,
        } = RasterPipelines::new(
            ctx,
            scene,
            &camera_buf,
            &vertices,
            gbuffer,
            [&virtual_colour, &virtual_point],
            records,
        )?;
        Ok(ReflectionPointPasses {
            reflector,
            reflector_sets,
            search,
            search_sets,
            search_groups: dispatch_rows(vertex_count as u32, 64, MAX_GROUPS_X),
            virtual_draw,
            virtual_sets,
            resolve,
            resolve_set,
            params_buf,
            options: *options,
            closure: closure_buf,
            closure_vertices,
            camera_buf,
            vertices,
            position,
            normal,
            reflector_depth,
            virtual_colour,
            virtual_point,
            virtual_depth,
            index_count: scene.index_count,
            vertex_count,
            params,
            width,
            height,
        })
    }

    fn draw_into(
        &self,
        rec: &Recorder<'_>,
        pipeline: &GraphicsPipeline,
        sets: &[BindGroup; 2],
        images: [&Image; 2],
        depth: &Image,
        vertex_count: u32,
    ) -> VkResult<()> {
        let (width, height) = (depth.desc().width, depth.desc().height);
        rec.prepare_render_targets(&images, Some(depth), SHADER_READ);
        let clear = |v: Vec4| vk::ClearColorValue {
            float32: v.to_array(),
        };
        let target = RenderTarget {
            width,
            height,
            colour: images
                .iter()
                .map(|img| ColourTarget {
                    view: img.view(),
                    clear: clear(Vec4::ZERO),
                })
                .collect(),
            depth: Some(depth.view()),
        };
        pipeline.draw(rec, &target, &[&sets[0], &sets[1]], vertex_count, 0)?;
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

    /// Records `reflection_point_targets`: the reflector textures T_P and T_N.
    pub fn record_targets(&self, rec: &Recorder<'_>) -> VkResult<()> {
        self.draw_into(
            rec,
            &self.reflector,
            &self.reflector_sets,
            [&self.position, &self.normal],
            &self.reflector_depth,
            self.index_count + self.closure_vertices,
        )
    }

    /// Records `reflection_point_search`: one search per scene vertex (after
    /// [`ReflectionPointPasses::record_targets`], whose barrier to the search `draw_into` records).
    pub fn record_search(&self, rec: &Recorder<'_>) -> VkResult<()> {
        let sets = [&self.search_sets[0], &self.search_sets[1]];
        self.search.dispatch(rec, &sets, self.search_groups);
        Ok(())
    }

    /// Records `reflection_point_raster`: the virtual objects in the mirror pixels, then the records.
    pub fn record_raster(&self, rec: &Recorder<'_>) -> VkResult<()> {
        rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        self.draw_into(
            rec,
            &self.virtual_draw,
            &self.virtual_sets,
            [&self.virtual_colour, &self.virtual_point],
            &self.virtual_depth,
            self.index_count,
        )?;
        let groups = (self.width * self.height).div_ceil(64);
        self.resolve
            .dispatch(rec, &[&self.resolve_set], [groups, 1, 1]);
        Ok(())
    }

    /// The per-vertex results of the last frame, one per scene vertex.
    pub fn read_vertices(&self, ctx: &GpuContext) -> VkResult<Vec<RpVertex>> {
        let mut v: Vec<RpVertex> = ctx.read_buffer(&self.vertices)?;
        v.truncate(self.vertex_count);
        Ok(v)
    }

    /// The search's textures T_P and T_N of the last frame, and its parameters.
    pub fn read_textures(&self, ctx: &GpuContext) -> VkResult<SearchTextures> {
        let read = |img: &Image| -> VkResult<Vec<Vec4>> {
            let bytes = ctx.read_image(img, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)?;
            let px: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
            Ok(px.iter().map(|p| Vec4::from_array(*p)).collect())
        };
        Ok(SearchTextures {
            width: self.params.width,
            height: self.params.height,
            position: read(&self.position)?,
            normal: read(&self.normal)?,
            eye: Vec3::from_array(self.params.eye),
            start: self.params.start,
            max_iterations: self.params.max_iterations,
        })
    }

    /// The iteration counts of the last frame.
    pub fn read_stats(&self, ctx: &GpuContext) -> VkResult<SearchStats> {
        Ok(SearchStats::of(&self.read_vertices(ctx)?))
    }
}

/// The timed name of the reflector textures' draw, which shares `reflection_point_search`'s
/// shaders: timed apart so that the search's time is the per-vertex dispatch alone.
pub const TARGETS_PASS: &str = "reflection_point_targets";

/// The reflection-point method.
pub struct ReflectionPoint;

impl MethodSpec for ReflectionPoint {
    fn method(&self) -> crate::method::Method {
        crate::method::Method::ReflectionPoint
    }

    fn trace_pass(&self) -> &'static Pass {
        &REFLECTION_POINT_SEARCH
    }

    /// The CMOs for the environment-map fallback alone: triangle IDs, no colour.
    fn needs(&self, _trace: &TraceOptions) -> Needs {
        Needs {
            capture: true,
            contents: CaptureContents {
                colour: false,
                triangle_ids: true,
            },
            pyramid: false,
        }
    }

    /// The reflector's position and normal textures, the virtual objects' colour and point
    /// (RGBA f32 each) and two f32 depth buffers, at search scale 1 (T_P, T_N and their depth
    /// grow with the scale's square: not counted); the per-vertex buffer is per scene vertex
    /// (small beside these, not counted).
    fn bytes_per_pixel(&self) -> u64 {
        4 * 16 + 2 * 4
    }

    fn create(&self, i: &FrameInputs<'_>) -> VkResult<Box<dyn Technique>> {
        Ok(Box::new(ReflectionPointPasses::new(
            i.ctx,
            i.data,
            i.scene,
            i.gbuffer,
            i.camera,
            i.near,
            i.records,
            &i.options.reflection_point,
        )?))
    }
}

impl Technique for ReflectionPointPasses {
    /// The search's and the raster's camera: `RpParams` (matrix, eye, start texel) and
    /// `RpCamera`, as [`ReflectionPointPasses::new`] derives them.
    fn set_camera(&mut self, i: &CameraInputs<'_>) -> VkResult<()> {
        let params = RpParams::for_frame(
            i.data,
            self.index_count,
            i.camera,
            i.near,
            &self.options,
            (self.width, self.height),
        )?;
        let cam = RpCamera {
            view_proj: params.view_proj,
            eye: params.eye,
            near: i.near,
        };
        i.ctx
            .write_buffer(&self.params_buf, std::slice::from_ref(&params))?;
        i.ctx
            .write_buffer(&self.camera_buf, std::slice::from_ref(&cam))?;
        self.params = params;
        Ok(())
    }

    /// The closing triangles of the moved reflectors, into their buffer where they fit (the
    /// draw reads `closure_vertices` of them), else into a new one bound in its place. The
    /// search's start texel follows in [`Technique::set_camera`], which reads the new data.
    fn update_geometry(&mut self, i: &GeometryInputs<'_>) -> VkResult<()> {
        let (closure, closure_vertices) = closure_contents(i.data, &self.options);
        if size_of_val(closure.as_slice()) as u64 <= self.closure.size() {
            i.ctx.write_buffer(&self.closure, &closure)?;
        } else {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            let buffer = i.ctx.create_buffer_init("rp closure", usage, &closure)?;
            self.reflector_sets[1] = reflector_set(&self.reflector, &self.params_buf, &buffer)?;
            self.closure = buffer;
        }
        self.closure_vertices = closure_vertices;
        Ok(())
    }

    fn record(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        scope(TARGETS_PASS, &mut || self.record_targets(rec))?;
        scope(REFLECTION_POINT_SEARCH.name, &mut || {
            self.record_search(rec)
        })?;
        scope(REFLECTION_POINT_RASTER.name, &mut || {
            self.record_raster(rec)
        })
    }

    fn read_stats(&self, ctx: &GpuContext) -> VkResult<MethodStats> {
        Ok(MethodStats {
            compute: None,
            search: Some(ReflectionPointPasses::read_stats(self, ctx)?),
        })
    }
}

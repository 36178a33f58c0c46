//! `--method ssr`: Hi-Z screen-space reflections (Uludag 2014), two passes after the G-buffer:
//!
//! | pass | reads | writes |
//! |---|---|---|
//! | `ssr_hiz` | G-buffer position | the min pyramid of the depth key, one dispatch per level |
//! | `ssr` | G-buffer, pyramid | one record per mirror pixel (hit pixel's colour and position, iterations) |
//!
//! The traversal and the pyramid are specified by their CPU twin [`crate::cpu::ssr`]; the
//! shaders are `spirv/ssr_hiz.wgsl`, `spirv/ssr.wgsl` and `spirv/shared/ssr.wgsl`. Unresolved
//! records (towards the camera, off screen, iteration cap, thickness) go to the frame's
//! fallback in `composite`, as for the CMO methods.
//!
//! Invariants: the pyramid buffer holds [`hiz_len`] f32 cells in the [`hiz_levels`] layout and is
//! fully rewritten every frame; consecutive levels are separated by a compute-write ->
//! compute-read barrier recorded here; the barriers before `ssr_hiz` (the G-buffer's) and between
//! `ssr_hiz` and `ssr` belong to the caller ([`crate::vk::frame::GpuRenderer`]).
//!
//! # How it works
//!
//! Hi-Z screen-space reflections, the peer method most engines ship, after Uludag, "Hi-Z
//! Screen-Space Cone-Traced Reflections" (GPU Pro 5, 2014), mirror part only. Passes `ssr_hiz` and
//! `ssr` (`spirv/ssr_hiz.wgsl`, `spirv/ssr.wgsl`, `spirv/shared/ssr.wgsl`); CPU twin `cpu::ssr`.
//!
//! - Hi-Z (section 4.4.1, Listing 4.3): per pixel the depth key `-1 / w` of the G-buffer's world
//!   position (affine in post-projective depth, so it interpolates linearly in screen space, and
//!   unlike `z / w` with our near plane it keeps f32 resolution at every distance), then levels of
//!   2x2 minima down to 1x1 (odd sizes: missing children skipped); one dispatch per level.
//! - Traversal (Listings 4.2, 4.5): the ray is `o + d t` in (pixel x, pixel y, depth key) with
//!   `d.z = 1`. It first leaves its own pixel; then each iteration moves it to the cell's minimum
//!   depth plane if it is in front of it; if that leaves the cell it stops at the cell boundary
//!   (plus 1/128 pixel) and goes up a level, else down a level; it hits when it goes down from
//!   level 0, and takes the colour and position of the G-buffer pixel it lands on.
//! - Unresolved (left to the `--fallback`): rays towards the camera or parallel to the screen (a
//!   min pyramid cannot trace them, section 4.6.7), rays that leave the screen, rays that reach
//!   `--ssr-iterations` (default 64) and, with `--ssr-thickness T` (world units along the view
//!   axis), hits more than T behind the surface they land on. The default has no thickness test,
//!   as the chapter's listing: every surface is infinitely thick, so a ray passing behind a thin
//!   object or a silhouette hits it. The record keeps the outcome (`face`) and the iteration count
//!   (`cells`).
//!
//! Invariants: the GPU's depth keys, pyramid and records equal the twin's bit for bit on every
//! mirror pixel of every built-in scene (outcome, hit pixel, iterations, final depth, colour,
//! point); a perturbed pyramid, cap or thickness shows. Rays reported off screen have their exact
//! hit off screen. A thin panel in front of a wall gives 19 false hits without a thickness test, 3
//! with 0.1 m (which leaves 53 pixels unresolved instead).
//!
//! What screen space cannot see, at 96x72: 58 to 98 % of a curved mirror's rays go towards the
//! camera (940 of 1489 mirror pixels in `default`, 1544 of 1578 in the concave `bowl`) and another
//! 0.4 to 22 % leave the frame, so 72 to 98 % of the mirror pixels are unresolved against 4.8 % for
//! the exact cubemap tracers. Of its hits on other surfaces, 78 to 91 % lie within two pixel
//! footprints of the exact hit; most of the rest are thickness failures.
//!
//! Measured with `cubetrace bench` at 160x120 (lavapipe, 2 cores; reports in `benches/results/`):
//! 210 ns per mirror pixel for `ssr` (plus 0.4 to 4 ms per frame for `ssr_hiz`), 84 % of mirror
//! pixels left to the fallback; with `--fallback trace` finishing those exactly, 9.7 % wrong surface
//! and 22.5 dB. It still pays the CMO capture (14 to 34 ms per frame at 160x120).
//!
//! Glossy reflectors (sections 4.4.1 to 4.4.5; created only when the scene has a reflector below
//! the mirror cap, so a mirror scene's frame is unchanged bit for bit): `ssr_visibility` (the max
//! pyramid and the pre-integrated visibility, one dispatch per level after `ssr_hiz`), `ssr_blur`
//! (the pre-convolved colour chain: level 0, then a horizontal and a vertical + 2x2 dispatch per
//! level) and `ssr_cone` (one compute dispatch after `ssr`, rewriting the record colour of
//! glossy pixels whose ray hit). Specified by their twin [`crate::cpu::ssr_cone`], which says
//! what they approximate. The remainder of the cone's weight is the pre-filtered cube map at the
//! lobe's roughness (`cone_envmap_colour`, `spirv/shared/cone.wgsl`: the CMO nearest to the
//! pixel, along the mirror direction), for which [`MethodSpec::glossy`] makes the frame
//! capture colour and run `cone_prefilter` on a glossy scene. Barriers: compute write -> read between
//! the per-level dispatches, read-write between the blur's steps (the scratch image is reused),
//! and storage read-write between `ssr` and `ssr_cone` (both touch the records).
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::Mat4;
use gpu_allocator::MemoryLocation;

use crate::cpu::options::TraceOptions;
use crate::cpu::ssr::{CROSS_EPSILON, HizLevel, MAX_LEVELS, SsrOptions, hiz_len, hiz_levels};
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::graphics::{GraphicsDesc, GraphicsPipeline, RenderTarget};
use crate::vk::backend::image::Image;
use crate::vk::backend::pipeline::{
    BindGroup, ComputeOptions, ComputePipeline, MAX_GROUPS_X, Resource, dispatch_rows,
};
use crate::vk::backend::shaders::{Pass, SSR, SSR_BLUR, SSR_CONE, SSR_HIZ, SSR_VISIBILITY};
use crate::vk::backend::sync::{
    COMPUTE_READ, COMPUTE_WRITE, SHADER_READ, SHADER_WRITE, STORAGE_RW,
};
use crate::vk::passes::cmo::{CaptureContents, CmoData};
use crate::vk::passes::gbuffer::Gbuffer;
use crate::vk::passes::pixel_queue::PixelQueue;

use super::technique::{
    CameraInputs, FrameInputs, Glossy, MethodSpec, Needs, Scope, Technique, has_glossy_reflector,
};

/// `SsrParams` in `spirv/shared/ssr.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct SsrParams {
    pub view_proj: [[f32; 4]; 4],
    /// Per level: first cell, width, height, 0.
    pub levels: [[u32; 4]; MAX_LEVELS],
    pub width: u32,
    pub height: u32,
    pub level_count: u32,
    pub max_iterations: u32,
    pub thickness: f32,
    pub thickness_on: u32,
    pub cross_epsilon: f32,
    pub pad0: u32,
}

impl SsrParams {
    /// The parameters of a `width x height` frame seen through `view_proj`.
    pub fn new(view_proj: Mat4, width: u32, height: u32, options: &SsrOptions) -> VkResult<Self> {
        let levels = hiz_levels(width, height);
        if levels.len() > MAX_LEVELS {
            return Err(VkError::Usage {
                what: SSR.name.into(),
                detail: format!(
                    "{width}x{height} needs {} pyramid levels, at most {MAX_LEVELS} are supported",
                    levels.len()
                ),
            });
        }
        let mut table = [[0u32; 4]; MAX_LEVELS];
        for (t, l) in table.iter_mut().zip(&levels) {
            *t = [l.offset, l.width, l.height, 0];
        }
        Ok(SsrParams {
            view_proj: view_proj.to_cols_array_2d(),
            levels: table,
            width,
            height,
            level_count: levels.len() as u32,
            max_iterations: options.max_iterations,
            thickness: options.thickness.unwrap_or(0.0),
            thickness_on: u32::from(options.thickness.is_some()),
            cross_epsilon: CROSS_EPSILON,
            pad0: 0,
        })
    }
}

/// `HizLevel` in `spirv/ssr_hiz.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct HizLevelParams {
    pub level: u32,
    pub pad0: u32,
    pub pad1: u32,
    pub pad2: u32,
}

/// `ConeLevel` in `spirv/shared/ssr_cone.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ConeLevelParams {
    pub level: u32,
    pub stage: u32,
    pub pad0: u32,
    pub pad1: u32,
    pub background: [f32; 4],
}

/// The two passes of the screen-space method for one frame size, allocated once.
pub struct SsrPasses {
    hiz: ComputePipeline,
    /// Per level: descriptor set, parameter buffer (kept alive for the set), dispatch size.
    hiz_levels: Vec<(BindGroup, Buffer, [u32; 3])>,
    trace: GraphicsPipeline,
    trace_set: BindGroup,
    params_buf: Buffer,
    /// What `params_buf` holds (its `view_proj` follows the camera).
    params: SsrParams,
    pyramid: Buffer,
    width: u32,
    height: u32,
    /// The glossy passes, only where the scene has a glossy reflector.
    cone: Option<ConePasses>,
}

/// The glossy passes' pyramids and chain, read back ([`ConePasses::read`]).
pub struct ConeBuffers {
    pub max: Vec<f32>,
    pub visibility: Vec<f32>,
    pub chain: Vec<[f32; 4]>,
}

/// One dispatch of a per-level pass: descriptor set, parameter buffer (kept alive for the set),
/// workgroups.
type LevelDispatch = (BindGroup, Buffer, [u32; 3]);

/// The workgroups of a dispatch over `cells` cells in workgroups of `wg`.
fn groups_for(cells: u32, wg: u32) -> [u32; 3] {
    dispatch_rows(cells, wg, MAX_GROUPS_X)
}

/// The glossy passes (sections 4.4.1 to 4.4.5): `ssr_visibility` (max pyramid and
/// pre-integrated visibility), `ssr_blur` (pre-convolved colour chain) and `ssr_cone` (the cone
/// tracing after `ssr`). CPU twin [`crate::cpu::ssr_cone`].
pub struct ConePasses {
    visibility: ComputePipeline,
    visibility_levels: Vec<LevelDispatch>,
    blur: ComputePipeline,
    /// Stage 0, then stages 1 and 2 per level from 1 on.
    blur_steps: Vec<LevelDispatch>,
    cone: ComputePipeline,
    cone_set: BindGroup,
    /// `@group(1)`: the CMOs, for the remainder's pre-filtered colour.
    cone_cmo_set: BindGroup,
    /// The pixels `main` cone traces (`cone_pixels`), which it runs over.
    cone_queue: PixelQueue,
    hiz_max: Buffer,
    visibility_buf: Buffer,
    chain: Buffer,
    _scratch: Buffer,
    cells: usize,
}

/// A compute pass's workgroup width (64 where the shader does not say).
fn workgroup_width(pass: &Pass) -> u32 {
    pass.entry_point("main")
        .map_or(64, |e| e.workgroup_size[0].max(1))
}

/// A G-buffer image as a sampled texture binding.
fn sampled(img: &Image) -> Resource<'_> {
    Resource::Texture {
        view: img.view(),
        layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
    }
}

/// A GPU-only storage buffer the glossy passes write and the tests read back.
fn cone_storage(ctx: &GpuContext, name: &str, bytes: u64) -> VkResult<Buffer> {
    Buffer::new(
        ctx.device(),
        name,
        bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )
}

/// The parameter buffer of one per-level dispatch: its level, stage and the scene's background.
fn cone_level_buf(
    ctx: &GpuContext,
    name: &str,
    level: u32,
    stage: u32,
    background: [f32; 3],
) -> VkResult<Buffer> {
    let mut buf = Buffer::new(
        ctx.device(),
        name,
        size_of::<ConeLevelParams>() as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::CpuToGpu,
    )?;
    let [r, g, b] = background;
    buf.write(
        0,
        &[ConeLevelParams {
            level,
            stage,
            background: [r, g, b, 1.0],
            ..ConeLevelParams::default()
        }],
    )?;
    Ok(buf)
}

/// What the glossy passes read and write besides their own parameters: the `ssr` pass's
/// parameters and min pyramid, and the glossy passes' max pyramid, visibility and colour chain
/// with its scratch.
struct ConeBindings<'a> {
    params_buf: &'a Buffer,
    pyramid: &'a Buffer,
    hiz_max: &'a Buffer,
    visibility_buf: &'a Buffer,
    chain: &'a Buffer,
    scratch: &'a Buffer,
}

impl ConePasses {
    #[allow(clippy::too_many_arguments)]
    fn new(
        ctx: &GpuContext,
        gbuffer: &Gbuffer,
        frame_params: &Buffer,
        records: &Buffer,
        params_buf: &Buffer,
        pyramid: &Buffer,
        cmo: &CmoData,
        background: [f32; 3],
        (width, height): (u32, u32),
    ) -> VkResult<Self> {
        if cmo.cone().is_none() {
            return Err(VkError::Usage {
                what: SSR_CONE.name.into(),
                detail: "the CMO data has no pre-filtered colour chain (MethodSpec::glossy)".into(),
            });
        }
        let cells = hiz_len(width, height);
        let hiz_max = cone_storage(ctx, "hiz max pyramid", cells as u64 * 4)?;
        let visibility_buf = cone_storage(ctx, "ssr visibility", cells as u64 * 4)?;
        let chain = cone_storage(ctx, "ssr colour chain", cells as u64 * 16)?;
        let scratch = cone_storage(ctx, "ssr blur scratch", u64::from(width * height) * 16)?;
        let bindings = ConeBindings {
            params_buf,
            pyramid,
            hiz_max: &hiz_max,
            visibility_buf: &visibility_buf,
            chain: &chain,
            scratch: &scratch,
        };
        let levels = hiz_levels(width, height);
        let visibility =
            ComputePipeline::new(ctx, &SSR_VISIBILITY, "main", ComputeOptions::default())?;
        let visibility_levels =
            Self::visibility_dispatches(ctx, &visibility, &levels, &bindings, background)?;
        let blur = ComputePipeline::new(ctx, &SSR_BLUR, "main", ComputeOptions::default())?;
        let blur_steps = Self::blur_dispatches(
            ctx,
            &blur,
            &levels,
            (width, height),
            gbuffer,
            &bindings,
            background,
        )?;
        let cone = ComputePipeline::new(ctx, &SSR_CONE, "main", ComputeOptions::default())?;
        let cone_queue = PixelQueue::new(
            ctx,
            &SSR_CONE,
            "cone_pixels",
            &[
                (0, sampled(&gbuffer.position)),
                (1, sampled(&gbuffer.normal)),
                (3, Resource::Buffer(records)),
                (8, Resource::Buffer(params_buf)),
            ],
            (width, height),
        )?;
        let [q, h] = cone_queue.resources();
        let cone_set = cone.bind_group(
            0,
            &[
                (0, sampled(&gbuffer.position)),
                (1, sampled(&gbuffer.normal)),
                (2, Resource::Buffer(frame_params)),
                (3, Resource::Buffer(records)),
                (4, Resource::Buffer(pyramid)),
                (5, Resource::Buffer(&hiz_max)),
                (6, Resource::Buffer(&visibility_buf)),
                (7, Resource::Buffer(&chain)),
                (8, Resource::Buffer(params_buf)),
                q,
                h,
            ],
        )?;
        let cone_cmo_set = cone.bind_group(1, &cmo.resources_for(&SSR_CONE, "main"))?;
        Ok(ConePasses {
            cone_cmo_set,
            visibility,
            visibility_levels,
            blur,
            blur_steps,
            cone,
            cone_set,
            cone_queue,
            hiz_max,
            visibility_buf,
            chain,
            _scratch: scratch,
            cells,
        })
    }

    /// `ssr_visibility`'s dispatches: one per pyramid level.
    fn visibility_dispatches(
        ctx: &GpuContext,
        visibility: &ComputePipeline,
        levels: &[HizLevel],
        bindings: &ConeBindings<'_>,
        background: [f32; 3],
    ) -> VkResult<Vec<LevelDispatch>> {
        let mut dispatches = Vec::new();
        for (l, level) in levels.iter().enumerate() {
            let buf = cone_level_buf(
                ctx,
                &format!("ssr visibility level {l}"),
                l as u32,
                0,
                background,
            )?;
            let set = visibility.bind_group(
                0,
                &[
                    (0, Resource::Buffer(bindings.params_buf)),
                    (1, Resource::Buffer(bindings.pyramid)),
                    (2, Resource::Buffer(bindings.hiz_max)),
                    (3, Resource::Buffer(bindings.visibility_buf)),
                    (4, Resource::Buffer(&buf)),
                ],
            )?;
            let groups = groups_for(level.width * level.height, workgroup_width(&SSR_VISIBILITY));
            dispatches.push((set, buf, groups));
        }
        Ok(dispatches)
    }

    /// `ssr_blur`'s dispatches: stage 0 over the full frame, then per level from 1 on stage 1
    /// (over the level above) and stage 2 (over the level).
    fn blur_dispatches(
        ctx: &GpuContext,
        blur: &ComputePipeline,
        levels: &[HizLevel],
        (width, height): (u32, u32),
        gbuffer: &Gbuffer,
        bindings: &ConeBindings<'_>,
        background: [f32; 3],
    ) -> VkResult<Vec<LevelDispatch>> {
        let mut steps = Vec::new();
        let mut step = |l: usize, stage: u32, cells: u32| -> VkResult<()> {
            let name = format!("ssr blur level {l} stage {stage}");
            let buf = cone_level_buf(ctx, &name, l as u32, stage, background)?;
            let set = blur.bind_group(
                0,
                &[
                    (0, Resource::Buffer(bindings.params_buf)),
                    (1, sampled(&gbuffer.colour)),
                    (2, Resource::Buffer(bindings.chain)),
                    (3, Resource::Buffer(bindings.scratch)),
                    (4, Resource::Buffer(&buf)),
                ],
            )?;
            steps.push((set, buf, groups_for(cells, workgroup_width(&SSR_BLUR))));
            Ok(())
        };
        step(0, 0, width * height)?;
        for l in 1..levels.len() {
            step(l, 1, levels[l - 1].width * levels[l - 1].height)?;
            step(l, 2, levels[l].width * levels[l].height)?;
        }
        Ok(steps)
    }

    /// `ssr_visibility`, level by level (after `ssr_hiz`).
    fn record_visibility(&self, rec: &Recorder<'_>) {
        for (i, (set, _, groups)) in self.visibility_levels.iter().enumerate() {
            if i > 0 {
                rec.memory_barrier(COMPUTE_WRITE, COMPUTE_READ);
            }
            self.visibility.dispatch(rec, &[set], *groups);
        }
    }

    /// `ssr_blur`, step by step (after the G-buffer). Each step reads what the one before
    /// wrote and overwrites what the one before that read (the scratch image): a read-write
    /// barrier between steps.
    fn record_blur(&self, rec: &Recorder<'_>) {
        for (i, (set, _, groups)) in self.blur_steps.iter().enumerate() {
            if i > 0 {
                rec.memory_barrier(STORAGE_RW, STORAGE_RW);
            }
            self.blur.dispatch(rec, &[set], *groups);
        }
    }

    /// `ssr_cone` (after `ssr`'s records): the pixels to cone trace queued (`cone_pixels`),
    /// then `main` over them ([`PixelQueue`]).
    fn record_cone(&self, rec: &Recorder<'_>) -> VkResult<()> {
        self.cone_queue
            .record(rec, &self.cone, &[&self.cone_set, &self.cone_cmo_set])
    }

    /// The max pyramid, the visibility pyramid and the colour chain as the GPU built them
    /// ([`hiz_len`] cells each, [`hiz_levels`] layout).
    pub fn read(&self, ctx: &GpuContext) -> VkResult<ConeBuffers> {
        let mut max: Vec<f32> = ctx.read_buffer(&self.hiz_max)?;
        let mut vis: Vec<f32> = ctx.read_buffer(&self.visibility_buf)?;
        let mut chain: Vec<[f32; 4]> = ctx.read_buffer(&self.chain)?;
        max.truncate(self.cells);
        vis.truncate(self.cells);
        chain.truncate(self.cells);
        Ok(ConeBuffers {
            max,
            visibility: vis,
            chain,
        })
    }
}

impl SsrPasses {
    /// Creates both passes over `gbuffer`, writing `records` (`frame_params` is the frame's
    /// `FrameParams` uniform).
    pub fn new(
        ctx: &GpuContext,
        gbuffer: &Gbuffer,
        view_proj: Mat4,
        frame_params: &Buffer,
        records: &Buffer,
        options: &SsrOptions,
        glossy: Option<(&CmoData, [f32; 3])>,
    ) -> VkResult<Self> {
        let (width, height) = gbuffer.extent();
        let params = SsrParams::new(view_proj, width, height, options)?;
        let params_buf = ctx.create_buffer_init(
            "ssr params",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            std::slice::from_ref(&params),
        )?;
        let pyramid = Buffer::new(
            ctx.device(),
            "hiz pyramid",
            hiz_len(width, height) as u64 * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let hiz = ComputePipeline::new(ctx, &SSR_HIZ, "main", ComputeOptions::default())?;
        let wg = workgroup_width(&SSR_HIZ);
        let mut levels = Vec::new();
        for (l, level) in hiz_levels(width, height).into_iter().enumerate() {
            let mut buf = Buffer::new(
                ctx.device(),
                &format!("hiz level {l}"),
                size_of::<HizLevelParams>() as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::CpuToGpu,
            )?;
            buf.write(
                0,
                &[HizLevelParams {
                    level: l as u32,
                    ..HizLevelParams::default()
                }],
            )?;
            let set = hiz.bind_group(
                0,
                &[
                    (0, sampled(&gbuffer.position)),
                    (1, Resource::Buffer(&params_buf)),
                    (2, Resource::Buffer(&pyramid)),
                    (3, Resource::Buffer(&buf)),
                ],
            )?;
            levels.push((set, buf, groups_for(level.width * level.height, wg)));
        }
        let trace = GraphicsPipeline::new(
            ctx,
            &SSR,
            &GraphicsDesc {
                vertex: "vs_fullscreen",
                fragment: "fs_main",
                colour_formats: Vec::new(),
                depth: None,
            },
        )?;
        let trace_set = trace.bind_group(
            0,
            &[
                (0, sampled(&gbuffer.position)),
                (1, sampled(&gbuffer.normal)),
                (2, Resource::Buffer(frame_params)),
                (3, Resource::Buffer(records)),
                (4, sampled(&gbuffer.colour)),
                (5, Resource::Buffer(&pyramid)),
                (6, Resource::Buffer(&params_buf)),
            ],
        )?;
        let cone = match glossy {
            Some((cmo, background)) => Some(ConePasses::new(
                ctx,
                gbuffer,
                frame_params,
                records,
                &params_buf,
                &pyramid,
                cmo,
                background,
                (width, height),
            )?),
            None => None,
        };
        Ok(SsrPasses {
            cone,
            hiz,
            hiz_levels: levels,
            trace,
            trace_set,
            params_buf,
            params,
            pyramid,
            width,
            height,
        })
    }

    /// Records the `ssr_hiz` pass: one dispatch per level, level 0 from the G-buffer.
    pub fn record_hiz(&self, rec: &Recorder<'_>) {
        for (i, (set, _, groups)) in self.hiz_levels.iter().enumerate() {
            if i > 0 {
                rec.memory_barrier(COMPUTE_WRITE, COMPUTE_READ);
            }
            self.hiz.dispatch(rec, &[set], *groups);
        }
    }

    /// Records the `ssr` pass (a full-screen draw without attachments).
    pub fn record_trace(&self, rec: &Recorder<'_>) -> VkResult<()> {
        let target = RenderTarget {
            width: self.width,
            height: self.height,
            colour: Vec::new(),
            depth: None,
        };
        self.trace.draw(rec, &target, &[&self.trace_set], 3, 0)
    }

    /// The glossy passes (`None` where the scene has no glossy reflector).
    pub fn cone_passes(&self) -> Option<&ConePasses> {
        self.cone.as_ref()
    }

    /// The pyramid as the GPU built it ([`hiz_len`] cells, [`hiz_levels`] layout).
    pub fn read_pyramid(&self, ctx: &GpuContext) -> VkResult<Vec<f32>> {
        let mut cells: Vec<f32> = ctx.read_buffer(&self.pyramid)?;
        cells.truncate(hiz_len(self.width, self.height));
        Ok(cells)
    }
}

/// The screen-space method.
pub struct Ssr;

impl MethodSpec for Ssr {
    fn method(&self) -> crate::method::Method {
        crate::method::Method::Ssr
    }

    fn trace_pass(&self) -> &'static Pass {
        &SSR
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

    /// The glossy passes' remainder reads the cube maps at the lobe's roughness.
    fn glossy(&self) -> Glossy {
        Glossy::Chain
    }

    /// The Hi-Z pyramid: f32 cells, about 4/3 per pixel over all levels (2 on a one-pixel-wide
    /// frame; counted as 2), plus the pass's parameters (per frame, negligible). Not counted:
    /// a glossy scene's passes (max pyramid, visibility, colour chain and blur scratch, about
    /// 48 bytes per pixel more), which this scene-independent figure cannot see. The CMO colour
    /// and pre-filtered chain a glossy scene adds are `budget::cone_bytes`'s.
    fn bytes_per_pixel(&self) -> u64 {
        2 * 4
    }

    fn create(&self, i: &FrameInputs<'_>) -> VkResult<Box<dyn Technique>> {
        Ok(Box::new(SsrPasses::new(
            i.ctx,
            i.gbuffer,
            i.camera.view_proj(i.near),
            i.params,
            i.records,
            &i.options.ssr,
            has_glossy_reflector(i.data).then_some((i.cmo, i.data.shading.background)),
        )?))
    }
}

impl Technique for SsrPasses {
    fn set_camera(&mut self, i: &CameraInputs<'_>) -> VkResult<()> {
        self.params.view_proj = i.camera.view_proj(i.near).to_cols_array_2d();
        i.ctx
            .write_buffer(&self.params_buf, std::slice::from_ref(&self.params))
    }

    fn record(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        scope(SSR_HIZ.name, &mut || {
            self.record_hiz(rec);
            Ok(())
        })?;
        if let Some(cone) = &self.cone {
            rec.memory_barrier(COMPUTE_WRITE, COMPUTE_READ);
            scope(SSR_VISIBILITY.name, &mut || {
                cone.record_visibility(rec);
                Ok(())
            })?;
            scope(SSR_BLUR.name, &mut || {
                cone.record_blur(rec);
                Ok(())
            })?;
        }
        rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        scope(SSR.name, &mut || self.record_trace(rec))?;
        if let Some(cone) = &self.cone {
            rec.memory_barrier(STORAGE_RW, STORAGE_RW);
            scope(SSR_CONE.name, &mut || cone.record_cone(rec))?;
        }
        Ok(())
    }
}

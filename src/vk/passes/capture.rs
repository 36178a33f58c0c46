//! The `capture` pass: rasterises each cubemap object's six faces (colour and distance, plus
//! normals and the mirror mask when the scene has self-reflections on) into [`CmoData`]: colour
//! straight into its colour image, distance (and normals) into the flat buffers the tracers read.
//!
//! Invariants:
//! - A layer of every capture image is one face (`layer = 6 k + face`, faces in Vulkan's order),
//!   so an image-to-buffer copy of all layers is [`crate::cubemap::CubeMap`]'s layout:
//!   CMO-major, then `(face * N + y) * N + x`.
//! - Distance is the f32 world distance to the CMO centre, `+inf` where nothing was drawn (the
//!   clear value); colour is linear RGBA with alpha 1 on surfaces and the background with alpha 0
//!   elsewhere, as [`crate::cpu::capture::capture`] (the CPU check of this pass) produces.
//! - Reflectors are drawn only with self-reflections on, and only then are the normal/mirror
//!   image and buffer allocated.
//! - With [`CaptureContents::triangle_ids`] the pass also writes each texel's global triangle
//!   index (`u32::MAX` where empty, the clear value) into the CMO's triangle buffer; without
//!   [`CaptureContents::colour`] it writes no colour (the CMO's colour image is a placeholder,
//!   left readable).
//! - Each face draws only its own triangles ([`face_triangles`]): those of the objects the
//!   capture shows (reflectors only with self-reflections on) that step 0 of the bounded
//!   capture ([`bounds::face_missed`]) does not prove outside the face, in global order, so the
//!   depth test breaks ties between them as a draw of every triangle does and the images are the
//!   same. The vertex shader reads the global triangle index from the face's list (vertex
//!   pulling: each draw from vertex 0, `instance_index` its entry of `capture_views`, which
//!   names its face and its part of the list; a draw with `firstVertex > 0` crashed lavapipe at
//!   128-bit vectors, `malloc(): invalid size`). On a dense mesh most triangles lie in one or
//!   two of the six faces, and lavapipe ran the vertex shader of every triangle for every face.
//! - A face's list is drawn in one draw or several, cut where triangles that may need clipping
//!   start or end ([`FaceLists::draws`]), in the list's order: the images are those of one draw.
//! - A triangle seen edge-on from its CMO centre (`spirv/shared/eye_plane.wgsl`) is culled: a
//!   compute pass (`spirv/capture_mark.wgsl`) marks it in the lists once per upload (creation,
//!   [`Capture::set_views`]), with the test and the operations the vertex shader ran on every
//!   vertex before, and the vertex shader sends a marked triangle's corners outside the clip
//!   volume. The vertex shader then reads one corner, not its triangle's three (truck-garage's
//!   capture about a quarter cheaper on lavapipe, `benches/results/lavapipe-capture.md`).
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::cmo::{CaptureContents, CmoData};
use super::scene_buffers::SceneBuffers;
use crate::cubemap::bounds;
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
use crate::vk::backend::shaders::{CAPTURE, CAPTURE_MARK};
use crate::vk::backend::sync::{
    ALL_READS, COLOUR_WRITE, DEPTH_WRITE, SHADER_READ, TRANSFER_READ, TRANSFER_WRITE,
};

/// One draw: part of one face of one CMO, as `capture_views[k]` in `spirv/capture.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CaptureView {
    pub centre: [f32; 3],
    pub face: u32,
    /// Near plane along the face axis (world units): nearer geometry is clipped.
    pub near: f32,
    /// 1: the reflectors are drawn (self-reflections on); 0: they are not ([`face_triangles`]).
    pub reflectors: u32,
    /// The draw's triangles: `capture_triangles[first..first + count]`, part of its face's list
    /// ([`face_triangles`]).
    pub first: u32,
    pub count: u32,
}

/// A run of a face's list that no corner of would clip ([`may_clip`]) is drawn on its own
/// (its own `vkCmdDraw`) only from this many triangles up; a shorter one joins the draw of the
/// triangles around it.
const CLEAN_RUN: usize = 64;

/// The faces' triangle lists and the draws that rasterise them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaceLists {
    /// Every view's list, concatenated.
    pub triangles: Vec<u32>,
    /// Per view, its list: `(first, count)` in `triangles`.
    pub spans: Vec<(u32, u32)>,
    /// The draws, `(view, first, count)`: each view's span cut into consecutive runs, in order
    /// (a view with an empty list has none).
    pub draws: Vec<(u32, u32, u32)>,
}

/// Per view (`6 k + face` of CMO k at `centres[k]`), the global indices of the triangles its
/// draws rasterise, in increasing order: those of captured objects (`GpuObject::captured`;
/// reflectors only where `reflectors`: [`super::capture_lists::scene_triangles`], the lists'
/// rule), less those [`bounds::face_missed`] proves outside the
/// face (all three corners outside one side plane of the face frustum, dilated, with a slack
/// far above the rounding: no texel centre of the face is in the triangle, so it makes no
/// fragment).
///
/// Each list is cut into draws where `may_clip` changes, runs of fewer than `CLEAN_RUN`
/// triangles that do not clip joining those around them. The draws of a face follow each
/// other in the list's order, so the depth test sees the triangles in the same order and the
/// images are those of one draw per face; `near` (the faces' near plane) only decides where
/// the cuts fall. Why: lavapipe's vertex stage (Mesa's `draw` module) sends a whole batch of
/// vertices through its slow path (the clipping stage) where one vertex of it lies outside the
/// clip volume; a face's list holds a few per cent of such triangles (across the face's edges),
/// spread over a third of its batches (`benches/results/lavapipe-capture.md`). truck-garage's
/// 6 faces take 340 draws.
pub fn face_triangles(
    data: &GpuSceneData,
    centres: &[Vec3],
    reflectors: bool,
    near: f32,
) -> FaceLists {
    use rayon::prelude::*;
    let (tris, shown) = super::capture_lists::scene_triangles(data, reflectors);
    // Per view: its list and its runs.
    type Runs = Vec<(u32, u32)>;
    let lists: Vec<(Vec<u32>, Runs)> = (0..6 * centres.len())
        .into_par_iter()
        .map(|view| {
            let (centre, face) = (centres[view / 6], (view % 6) as u32);
            let mut list = Vec::new();
            let mut clips = Vec::new();
            for (t, tri) in tris.iter().enumerate() {
                if !shown[t] {
                    continue;
                }
                let l = bounds::face_local(tri, centre, face);
                if !bounds::face_missed(&l) {
                    list.push(t as u32);
                    clips.push(may_clip(&l, near));
                }
            }
            (list, clean_runs(&clips))
        })
        .collect();
    let mut out = FaceLists {
        triangles: Vec::with_capacity(lists.iter().map(|l| l.0.len()).sum()),
        spans: Vec::with_capacity(lists.len()),
        draws: Vec::new(),
    };
    for (view, (list, runs)) in lists.into_iter().enumerate() {
        let first = out.triangles.len() as u32;
        out.spans.push((first, list.len() as u32));
        out.draws
            .extend(runs.into_iter().map(|(a, n)| (view as u32, first + a, n)));
        out.triangles.extend(list);
    }
    out
}

/// Whether the rasteriser may have to clip the triangle `l` (face-local, CMO-local) in a face
/// whose near plane is `near`: a corner on or behind the near plane or on or outside a side
/// plane of the face frustum (`|x|` or `|y|` at least `z`: on lavapipe these too take the slow
/// path, measured), each by a margin of 2^-10, or the edge-on cull (the vertex shader moves a
/// marked triangle's corners outside the clip volume), at four times its bound. Only where the
/// draws are cut depends on it.
fn may_clip(l: &[Vec3; 3], near: f32) -> bool {
    const IN: f32 = 1.0 - 1.0 / 1024.0;
    let out = |p: &Vec3| p.z <= near / IN || p.x.abs() >= IN * p.z || p.y.abs() >= IN * p.z;
    if l.iter().any(out) {
        return true;
    }
    let (offset, bound) = crate::camera::eye_plane_offset(Vec3::ZERO, l);
    offset <= 4.0 * bound
}

/// The draws of a list whose triangles clip where `clips` says: `(first, count)` runs, in order,
/// covering it, a run of fewer than [`CLEAN_RUN`] triangles that do not clip joined to the runs
/// around it.
fn clean_runs(clips: &[bool]) -> Vec<(u32, u32)> {
    let mut runs: Vec<(u32, u32)> = Vec::new();
    let mut clean_from = None;
    let mut start = 0;
    for i in 0..=clips.len() {
        let clean = i < clips.len() && !clips[i];
        match (clean, clean_from) {
            (true, None) => clean_from = Some(i),
            (false, Some(c)) => {
                if i - c >= CLEAN_RUN {
                    if c > start {
                        runs.push((start as u32, (c - start) as u32));
                    }
                    runs.push((c as u32, (i - c) as u32));
                    start = i;
                }
                clean_from = None;
            }
            _ => {}
        }
    }
    if clips.len() > start {
        runs.push((start as u32, (clips.len() - start) as u32));
    }
    runs
}

/// The capture pass for one scene: pipeline and targets.
pub struct Capture {
    pipeline: GraphicsPipeline,
    /// `capture_mark.wgsl`: marks the lists' edge-on triangles after each upload, and its
    /// scene set.
    mark: ComputePipeline,
    mark_scene: BindGroup,
    scene_set: BindGroup,
    view_set: BindGroup,
    views_buf: Buffer,
    /// What `views_buf` holds: one entry per draw ([`FaceLists::draws`]).
    views: Vec<CaptureView>,
    /// Per layer (view `6 k + face`), its draws as `GraphicsPipeline::draws` takes them:
    /// `(vertex count, instance)`, the instance its entry of `views`.
    layer_draws: Vec<Vec<(u32, u32)>>,
    /// Every face's triangles ([`face_triangles`]), at least one entry.
    triangles_buf: Buffer,
    distance: Image,
    normal: Option<Image>,
    triangle: Option<Image>,
    depth: Image,
    size: u32,
    contents: CaptureContents,
}

const DISTANCE_FORMAT: vk::Format = vk::Format::R32_SFLOAT;
const COLOUR_FORMAT: vk::Format = super::cmo::COLOUR_FORMAT;
const TRIANGLE_FORMAT: vk::Format = vk::Format::R32_UINT;

/// The capture pipeline for what is captured, and its fragment entry point.
fn capture_pipeline(
    ctx: &GpuContext,
    self_reflections: bool,
    contents: CaptureContents,
) -> VkResult<(GraphicsPipeline, &'static str)> {
    // Attachment order = the entry point's output locations: colour, distance, normal,
    // triangle, each only where captured.
    let mut formats = Vec::new();
    if contents.colour {
        formats.push(COLOUR_FORMAT);
    }
    formats.push(DISTANCE_FORMAT);
    if self_reflections {
        formats.push(COLOUR_FORMAT);
    }
    if contents.triangle_ids {
        formats.push(TRIANGLE_FORMAT);
    }
    let fragment = match (self_reflections, contents.colour, contents.triangle_ids) {
        (false, true, false) => "fs_main",
        (true, true, false) => "fs_self",
        (false, true, true) => "fs_main_ids",
        (true, true, true) => "fs_self_ids",
        (false, false, true) => "fs_ids_only",
        (true, false, true) => "fs_self_ids_only",
        (_, false, false) => {
            return Err(VkError::Usage {
                what: "capture".into(),
                detail: "neither colour nor triangle IDs captured".into(),
            });
        }
    };
    let pipeline = GraphicsPipeline::new(
        ctx,
        &CAPTURE,
        &GraphicsDesc {
            vertex: "vs_main",
            fragment,
            colour_formats: formats,
            depth: Some((vk::Format::D32_SFLOAT, DepthTest::Reversed)),
        },
    )?;
    Ok((pipeline, fragment))
}

impl Capture {
    /// Prepares the capture of CMOs at `centres` with faces of `size` texels, of the scene
    /// `data` uploaded into `scene`. Geometry nearer than `near` to a centre (along a face axis)
    /// is clipped. Captures colour, no triangle IDs ([`CaptureContents`]'s default).
    pub fn new(
        ctx: &GpuContext,
        data: &GpuSceneData,
        scene: &SceneBuffers,
        centres: &[Vec3],
        size: u32,
        self_reflections: bool,
        near: f32,
    ) -> VkResult<Self> {
        Self::with_contents(
            ctx,
            data,
            scene,
            centres,
            size,
            self_reflections,
            near,
            CaptureContents::default(),
        )
    }

    /// [`Self::new`] capturing `contents` (the [`CmoData`] it records into must have the same).
    #[allow(clippy::too_many_arguments)]
    pub fn with_contents(
        ctx: &GpuContext,
        data: &GpuSceneData,
        scene: &SceneBuffers,
        centres: &[Vec3],
        size: u32,
        self_reflections: bool,
        near: f32,
        contents: CaptureContents,
    ) -> VkResult<Self> {
        if centres.is_empty() || size == 0 {
            return Err(VkError::Usage {
                what: "capture".into(),
                detail: format!(
                    "{} CMOs of size {size}: need at least one CMO of size >= 1",
                    centres.len()
                ),
            });
        }
        let (pipeline, fragment) = capture_pipeline(ctx, self_reflections, contents)?;
        let lists = face_triangles(data, centres, self_reflections, near);
        log::debug!(
            "capture: {} triangle draws in {} draws over {} faces of a scene of {} triangles",
            lists.triangles.len(),
            lists.draws.len(),
            lists.spans.len(),
            data.indices.len() / 3
        );
        let (views, layer_draws) = draw_views(&lists, centres, near, self_reflections);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let views_buf = ctx.create_buffer_init("capture views", storage, &views)?;
        let triangles_buf = triangles_buffer(ctx, &lists.triangles)?;
        // Only the scene bindings the two entry points use (the IDs-only entry points shade
        // nothing, and a bind group may not supply a binding its shaders do not use).
        let scene_resources = scene.resources_for(&CAPTURE, &["vs_main", fragment]);
        let scene_set = pipeline.bind_group(0, &scene_resources)?;
        let view_set = view_set(&pipeline, &views_buf, &triangles_buf)?;
        let mark = ComputePipeline::new(ctx, &CAPTURE_MARK, "main", ComputeOptions::default())?;
        let mark_scene = mark.bind_group(0, &scene.resources_for(&CAPTURE_MARK, &["main"]))?;
        mark_edge_on(ctx, &mark, &mark_scene, &views_buf, &triangles_buf)?;
        let layers = 6 * centres.len() as u32;
        let target_usage =
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let layered = |name: &str, format| ImageDesc {
            name: name.into(),
            format,
            width: size,
            height: size,
            layers,
            cube: false,
            usage: target_usage,
        };
        let dev = ctx.device();
        let distance = Image::new(dev, layered("capture distance", DISTANCE_FORMAT))?;
        let normal = if self_reflections {
            Some(Image::new(dev, layered("capture normal", COLOUR_FORMAT))?)
        } else {
            None
        };
        let triangle = if contents.triangle_ids {
            Some(Image::new(
                dev,
                layered("capture triangle", TRIANGLE_FORMAT),
            )?)
        } else {
            None
        };
        let depth = Image::new(
            dev,
            ImageDesc::d2(
                "capture depth",
                vk::Format::D32_SFLOAT,
                size,
                size,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            ),
        )?;
        Ok(Capture {
            pipeline,
            mark,
            mark_scene,
            scene_set,
            view_set,
            views_buf,
            views,
            layer_draws,
            triangles_buf,
            distance,
            normal,
            triangle,
            depth,
            size,
            contents,
        })
    }

    /// The near plane every face clips at (world units along its axis).
    pub fn near(&self) -> f32 {
        self.views.first().map_or(0.0, |v| v.near)
    }

    /// Moves every face's near plane to `near` ([`crate::ranges::FrameRanges::capture_near`]):
    /// the next [`Capture::record`] is that of a capture created with it.
    pub fn set_near(&mut self, ctx: &GpuContext, near: f32) -> VkResult<()> {
        for v in &mut self.views {
            v.near = near;
        }
        ctx.write_buffer(&self.views_buf, &self.views)
    }

    /// Moves the CMOs to `centres` (as many as at creation) and every face's near plane to
    /// `near`, for the scene `data` (its vertices moved or not): the next [`Capture::record`] is
    /// that of a capture created with them (a mesh or a CMO moved,
    /// [`crate::vk::frame::GpuRenderer::update_geometry`]). The faces' triangle lists are made
    /// again, in a larger buffer (rebound) where they outgrow theirs.
    pub fn set_views(
        &mut self,
        ctx: &GpuContext,
        data: &GpuSceneData,
        centres: &[Vec3],
        near: f32,
    ) -> VkResult<()> {
        if 6 * centres.len() != self.layer_draws.len() {
            return Err(VkError::Usage {
                what: "capture".into(),
                detail: format!(
                    "{} centres for a capture of {} CMOs: the count is fixed at creation",
                    centres.len(),
                    self.layer_draws.len() / 6
                ),
            });
        }
        let reflectors = self.views.iter().any(|v| v.reflectors != 0);
        let lists = face_triangles(data, centres, reflectors, near);
        (self.views, self.layer_draws) = draw_views(&lists, centres, near, reflectors);
        let triangles = lists.triangles;
        let mut rebind = false;
        if size_of_val(triangles.as_slice()) as u64 > self.triangles_buf.size() {
            self.triangles_buf = triangles_buffer(ctx, &triangles)?;
            rebind = true;
        } else if !triangles.is_empty() {
            ctx.write_buffer(&self.triangles_buf, &triangles)?;
        }
        if size_of_val(self.views.as_slice()) as u64 > self.views_buf.size() {
            let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
            self.views_buf = ctx.create_buffer_init("capture views", storage, &self.views)?;
            rebind = true;
        } else {
            // The rest of the (larger) buffer holds views that start past every entry, so that
            // `capture_mark.wgsl`'s bisection never lands on a stale one.
            let room = (self.views_buf.size() / size_of::<CaptureView>() as u64) as usize;
            let mut all = self.views.clone();
            all.resize(
                room,
                CaptureView {
                    first: u32::MAX,
                    ..CaptureView::default()
                },
            );
            ctx.write_buffer(&self.views_buf, &all)?;
        }
        if rebind {
            self.view_set = view_set(&self.pipeline, &self.views_buf, &self.triangles_buf)?;
        }
        mark_edge_on(
            ctx,
            &self.mark,
            &self.mark_scene,
            &self.views_buf,
            &self.triangles_buf,
        )
    }

    /// Records the capture of every face of every CMO into `cmo`: colour straight into its
    /// colour image (left readable by shaders), distance (and normals) through this pass's
    /// images into its buffers, then a barrier that makes everything readable by any later
    /// pass. `background` fills the colour of empty texels (alpha 0).
    pub fn record(&self, rec: &Recorder<'_>, cmo: &CmoData, background: Vec3) -> VkResult<()> {
        let normal = match (&self.normal, cmo.normal()) {
            (None, _) => None,
            (Some(img), Some(b)) => Some((img, b)),
            (Some(_), None) => {
                return Err(VkError::Usage {
                    what: "capture".into(),
                    detail: "self-reflections on, but the CMO data has no normal buffer".into(),
                });
            }
        };
        if cmo.colour().desc().layers != self.distance.desc().layers {
            return Err(VkError::Usage {
                what: "capture".into(),
                detail: "the CMO data was made for another number of CMOs".into(),
            });
        }
        if cmo.contents() != self.contents {
            return Err(VkError::Usage {
                what: "capture".into(),
                detail: format!(
                    "the CMO data holds {:?}, the capture writes {:?}",
                    cmo.contents(),
                    self.contents
                ),
            });
        }
        let triangle = match (&self.triangle, cmo.triangle()) {
            (Some(img), Some(b)) => Some((img, b)),
            _ => None,
        };
        let bg = background.to_array();
        let mut images: Vec<&Image> = Vec::new();
        let mut clears = Vec::new();
        if self.contents.colour {
            images.push(cmo.colour());
            clears.push(vk::ClearColorValue {
                float32: [bg[0], bg[1], bg[2], 0.0],
            });
        }
        images.push(&self.distance);
        clears.push(vk::ClearColorValue {
            float32: [f32::INFINITY, 0.0, 0.0, 0.0],
        });
        if let Some((img, _)) = normal {
            images.push(img);
            clears.push(vk::ClearColorValue { float32: [0.0; 4] });
        }
        if let Some((img, _)) = triangle {
            images.push(img);
            clears.push(vk::ClearColorValue {
                uint32: [u32::MAX; 4],
            });
        }
        rec.prepare_render_targets(&images, Some(&self.depth), ALL_READS);
        let sets = [&self.scene_set, &self.view_set];
        for (layer, draws) in (0..self.distance.desc().layers).zip(&self.layer_draws) {
            let mut colour = Vec::with_capacity(images.len());
            for (img, clear) in images.iter().zip(clears.iter().copied()) {
                let view = img.layer_view(layer).ok_or_else(|| VkError::Usage {
                    what: img.desc().name.clone(),
                    detail: format!("no layer {layer}"),
                })?;
                colour.push(ColourTarget { view, clear });
            }
            let target = RenderTarget {
                width: self.size,
                height: self.size,
                colour,
                depth: Some(self.depth.view()),
            };
            if layer > 0 {
                // The depth image is cleared again for every face: order that after the last
                // face's depth writes.
                rec.memory_barrier(DEPTH_WRITE, DEPTH_WRITE);
            }
            // With nothing to draw this still clears the face.
            self.pipeline.draws(rec, &target, &sets, draws)?;
        }
        // The colour image (or, without colour, its placeholder, never written) ends readable.
        rec.image_barrier(
            cmo.colour(),
            if self.contents.colour {
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL
            } else {
                vk::ImageLayout::UNDEFINED
            },
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            COLOUR_WRITE,
            SHADER_READ,
        );
        let copies = [(&self.distance, cmo.distance())]
            .into_iter()
            .chain(normal)
            .chain(triangle);
        for (img, buf) in copies {
            rec.image_barrier(
                img,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                COLOUR_WRITE,
                TRANSFER_READ,
            );
            rec.copy_image_to_buffer(img, buf)?;
        }
        rec.memory_barrier(TRANSFER_WRITE, ALL_READS);
        Ok(())
    }
}

/// The `capture_views` of `lists`' draws (at least one entry: a buffer is never empty) and each
/// layer's draws, `(vertex count, instance)`.
fn draw_views(
    lists: &FaceLists,
    centres: &[Vec3],
    near: f32,
    reflectors: bool,
) -> (Vec<CaptureView>, Vec<Vec<(u32, u32)>>) {
    let view = |k: usize, first: u32, count: u32| CaptureView {
        centre: centres[k / 6].to_array(),
        face: (k % 6) as u32,
        near,
        reflectors: u32::from(reflectors),
        first,
        count,
    };
    let mut views = Vec::with_capacity(lists.draws.len().max(1));
    let mut layer_draws = vec![Vec::new(); lists.spans.len()];
    for &(k, first, count) in &lists.draws {
        layer_draws[k as usize].push((3 * count, views.len() as u32));
        views.push(view(k as usize, first, count));
    }
    if views.is_empty() {
        views.push(view(0, 0, 0));
    }
    (views, layer_draws)
}

/// The faces' triangle lists on the device (at least one entry: a buffer is never empty).
fn triangles_buffer(ctx: &GpuContext, triangles: &[u32]) -> VkResult<Buffer> {
    let one = [0u32];
    let data = if triangles.is_empty() {
        &one[..]
    } else {
        triangles
    };
    ctx.create_buffer_init(
        "capture face triangles",
        vk::BufferUsageFlags::STORAGE_BUFFER,
        data,
    )
}

/// Runs `capture_mark.wgsl` over the lists in `triangles` (the draws `views` cover them) and
/// waits: the lists' edge-on triangles marked for the vertex shader. Once per upload of the
/// lists (creation, [`Capture::set_views`]), not per frame.
fn mark_edge_on(
    ctx: &GpuContext,
    mark: &ComputePipeline,
    scene: &BindGroup,
    views: &Buffer,
    triangles: &Buffer,
) -> VkResult<()> {
    let set = mark.bind_group(
        1,
        &[
            (0, Resource::Buffer(views)),
            (1, Resource::Buffer(triangles)),
        ],
    )?;
    // A lane per entry, 64 per workgroup.
    let groups = dispatch_rows((triangles.size() / 4) as u32, 64, MAX_GROUPS_X);
    ctx.submit_and_wait("capture_mark", |rec| {
        mark.dispatch(rec, &[scene, &set], groups);
        Ok(())
    })
}

/// The `@group(1)` set: the views and the faces' triangle lists.
fn view_set(
    pipeline: &GraphicsPipeline,
    views: &Buffer,
    triangles: &Buffer,
) -> VkResult<BindGroup> {
    pipeline.bind_group(
        1,
        &[
            (0, Resource::Buffer(views)),
            (1, Resource::Buffer(triangles)),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::capture::capture_shaded;
    use crate::reference::Tracer;
    use crate::scene::builtin;

    const NEAR: f32 = 1e-3;

    /// The triangles the CPU capture `cube` sees in the face of view `k` that the view's list
    /// lacks.
    fn missing(lists: &FaceLists, cube: &crate::cubemap::CubeMap, k: usize) -> Vec<u32> {
        let (all, spans) = (&lists.triangles, &lists.spans);
        let (first, count) = spans[k];
        let list = &all[first as usize..(first + count) as usize];
        let n = (cube.size * cube.size) as usize;
        let face = k % 6;
        let mut seen: Vec<u32> = cube.triangle[face * n..(face + 1) * n]
            .iter()
            .copied()
            .filter(|&t| t != u32::MAX)
            .collect();
        seen.sort_unstable();
        seen.dedup();
        seen.into_iter()
            .filter(|t| list.binary_search(t).is_err())
            .collect()
    }

    /// Every triangle the CPU capture (ray cast from the centre through each texel centre) sees
    /// in a face is in that face's list, the lists are in global order, and they are shorter
    /// than a draw of every triangle per face. Negative: a list with one seen triangle taken
    /// out fails the same check.
    #[test]
    fn face_lists_keep_every_triangle_a_face_sees() {
        for scene in [
            builtin::sphere_room(),
            builtin::teapot(),
            builtin::default(),
        ] {
            let data = GpuSceneData::new(&scene);
            let tracer = Tracer::new(&scene);
            let reflectors = scene.captures_reflectors();
            let centres = scene.cmo_centres();
            let lists = face_triangles(&data, &centres, reflectors, NEAR);
            let triangles = data.indices.len() / 3;
            for (c, &centre) in centres.iter().enumerate() {
                let cube = capture_shaded(&scene, &tracer, centre, 32, false);
                for face in 0..6 {
                    let k = 6 * c + face;
                    assert!(
                        missing(&lists, &cube, k).is_empty(),
                        "view {k}: {:?}",
                        missing(&lists, &cube, k)
                    );
                    let (first, count) = lists.spans[k];
                    let list = &lists.triangles[first as usize..(first + count) as usize];
                    assert!(
                        list.windows(2).all(|w| w[0] < w[1]),
                        "view {k} out of order"
                    );
                }
                let drawn: u32 = lists.spans[6 * c..6 * c + 6].iter().map(|s| s.1).sum();
                assert!(
                    (drawn as usize) < 3 * triangles,
                    "{drawn} drawn of 6 x {triangles}"
                );
                // Negative: drop a triangle face 0 sees from its list.
                let mut cut = lists.clone();
                let (first, count) = cut.spans[6 * c];
                let seen = cube.triangle[..(32 * 32)]
                    .iter()
                    .find(|&&t| t != u32::MAX)
                    .copied();
                let seen = seen.expect("face 0 sees something");
                let list = &mut cut.triangles[first as usize..(first + count) as usize];
                let at = list.binary_search(&seen).unwrap();
                list[at..].rotate_left(1);
                cut.spans[6 * c].1 -= 1;
                assert_eq!(missing(&cut, &cube, 6 * c), vec![seen]);
            }
        }
    }

    /// The runs cover the list in order, a run of at least [`CLEAN_RUN`] triangles that do not
    /// clip is a draw of its own, and shorter ones stay with the triangles around them.
    /// Negative: one more clipping triangle inside a long clean run cuts it.
    #[test]
    fn clean_runs_cut_only_at_long_runs_that_do_not_clip() {
        let covers = |clips: &[bool], runs: &[(u32, u32)]| {
            let mut at = 0;
            for &(first, count) in runs {
                assert_eq!(first, at, "{runs:?}");
                assert!(count > 0, "{runs:?}");
                at += count;
            }
            assert_eq!(at as usize, clips.len(), "{runs:?}");
        };
        let n = CLEAN_RUN;
        let mut clips = vec![true; 3];
        clips.extend(vec![false; n]);
        clips.extend(vec![true; 2]);
        clips.extend(vec![false; n - 1]);
        clips.push(true);
        let runs = clean_runs(&clips);
        covers(&clips, &runs);
        let n = n as u32;
        assert_eq!(runs, vec![(0, 3), (3, n), (3 + n, n + 2)]);
        assert_eq!(clean_runs(&[]), vec![]);
        assert_eq!(clean_runs(&[false; 5]), vec![(0, 5)]);
        assert_eq!(clean_runs(&[true; 5]), vec![(0, 5)]);
        // Negative: a clipping triangle in the middle of the long clean run.
        let mut cut = clips.clone();
        cut[3 + n as usize / 2] = true;
        let runs = clean_runs(&cut);
        covers(&cut, &runs);
        assert_eq!(runs, vec![(0, 5 + 2 * n)]);
    }

    /// Every view's draws cover its list in order, and the built-ins give some face more than
    /// one draw (so that the GPU capture tests draw faces in several draws).
    #[test]
    fn face_draws_cover_each_list_in_order() {
        let mut split = 0;
        for scene in [
            builtin::sphere_room(),
            builtin::teapot(),
            builtin::default(),
        ] {
            let data = GpuSceneData::new(&scene);
            let centres = scene.cmo_centres();
            let lists = face_triangles(&data, &centres, scene.captures_reflectors(), NEAR);
            let mut d = lists.draws.iter().peekable();
            for (k, &(first, count)) in lists.spans.iter().enumerate() {
                let mut at = first;
                let mut n = 0;
                while let Some(&&(view, f, c)) = d.peek().filter(|x| x.0 == k as u32) {
                    assert_eq!((view, f), (k as u32, at));
                    at += c;
                    n += 1;
                    d.next();
                }
                assert_eq!(at, first + count, "view {k}");
                split += usize::from(n > 1);
            }
            assert!(d.next().is_none());
        }
        assert!(
            split > 0,
            "no face of the built-ins is drawn in several draws"
        );
    }

    /// Objects the capture does not show are in no list: without self-reflections no reflector
    /// triangle is drawn, with them the teapot's are.
    #[test]
    fn face_lists_follow_the_objects_the_capture_shows() {
        let scene = builtin::teapot();
        let data = GpuSceneData::new(&scene);
        let reflector = |t: u32| {
            let v = data.vertices[data.indices[3 * t as usize] as usize];
            data.objects[v.object as usize].reflector != 0
        };
        let centres = scene.cmo_centres();
        let off = face_triangles(&data, &centres, false, NEAR).triangles;
        assert!(!off.iter().any(|&t| reflector(t)));
        let on = face_triangles(&data, &centres, true, NEAR).triangles;
        assert!(on.iter().any(|&t| reflector(t)));
    }
}

//! The `hit_probe` pass (`spirv/hit_probe.wgsl`): the verified-hit building blocks run on given
//! inputs, so that the tests can compare them with their CPU twins.
//! - [`watertight_gpu`]: `wt_intersect` (`spirv/shared/watertight.wgsl`) per query; twin:
//!   [`cubetrace::cpu::watertight::intersect`], bit for bit.
//! - [`shade_gpu`]: `hit_shade` (`spirv/shared/hit.wgsl`) per (triangle, barycentrics); twin:
//!   [`cubetrace::reference::Tracer::shade`], within a stated tolerance.
//! - [`verify_gpu`]: `verify_hit` (`spirv/shared/verify.wgsl`) per query over one CMO's
//!   triangle IDs; twin: [`cubetrace::cpu::verify::verify_hit`] ([`verify_cpu`]), bit for bit.
use ash::vk;
use gpu_allocator::MemoryLocation;

use cubetrace::vk::backend::buffer::Buffer;
use cubetrace::vk::backend::context::GpuContext;
use cubetrace::vk::backend::error::VkResult;
use cubetrace::vk::backend::pipeline::{ComputeOptions, ComputePipeline, Resource};
use cubetrace::vk::backend::shaders::HIT_PROBE;
use cubetrace::vk::passes::scene_buffers::SceneBuffers;

/// WGSL `WatertightQuery`: a ray and a triangle. Layout checked against naga's in the tests.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WatertightQuery {
    pub org: [f32; 3],
    pub _pad0: u32,
    pub dir: [f32; 3],
    pub _pad1: u32,
    pub p0: [f32; 3],
    pub _pad2: u32,
    pub p1: [f32; 3],
    pub _pad3: u32,
    pub p2: [f32; 3],
    pub _pad4: u32,
}

/// WGSL `WatertightResult`: `hit` 1 or 0; `t` and `bary` are 0 on a miss.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WatertightResult {
    pub bary: [f32; 3],
    pub t: f32,
    pub hit: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// WGSL `ShadeQuery`: a global triangle index and the barycentric weights of its vertices 1
/// and 2 (as [`cubetrace::reference::Hit::bary`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadeQuery {
    pub bary: [f32; 2],
    pub triangle: u32,
    pub _pad: u32,
}

/// WGSL `VerifyQuery`: a ray `a + t d` with its proven-empty prefix `[.., t_done]` and end
/// `t_hi`, the CMO centre and face size, and the deciding texel `(face, x, y)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VerifyQuery {
    pub a: [f32; 3],
    pub t_done: f32,
    pub d: [f32; 3],
    pub t_hi: f32,
    pub centre: [f32; 3],
    pub size: u32,
    pub face: u32,
    pub x: u32,
    pub y: u32,
    pub _pad: u32,
}

/// WGSL `VerifyResult`: `hit` 1 or 0; the rest 0 (triangle `u32::MAX`) on no hit.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VerifyResult {
    pub bary: [f32; 3],
    pub t: f32,
    pub position: [f32; 3],
    pub triangle: u32,
    pub hit: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// What the CPU twin gives for a query over `ids` (one CMO, [`cubetrace::cubemap::CubeMap`]'s
/// layout) and the triangles' corners, in the GPU's result layout.
pub fn verify_cpu(q: &VerifyQuery, ids: &[u32], triangles: &[[glam::Vec3; 3]]) -> VerifyResult {
    use cubetrace::cpu::verify::{Neighbourhood, VerifyRay, verify_hit};
    use glam::Vec3;
    let texel = cubetrace::cubemap::Texel {
        face: q.face,
        x: q.x,
        y: q.y,
    };
    let nb = Neighbourhood::around(texel, q.size, ids);
    let ray = VerifyRay {
        a: Vec3::from_array(q.a),
        d: Vec3::from_array(q.d),
        t_done: q.t_done,
        t_hi: q.t_hi,
    };
    match verify_hit(ray, Vec3::from_array(q.centre), &nb, triangles) {
        Some(h) => VerifyResult {
            bary: h.bary,
            t: h.t,
            position: h.position.to_array(),
            triangle: h.triangle,
            hit: 1,
            ..VerifyResult::default()
        },
        None => VerifyResult {
            triangle: u32::MAX,
            ..VerifyResult::default()
        },
    }
}

impl WatertightQuery {
    pub fn new(org: glam::Vec3, dir: glam::Vec3, p: [glam::Vec3; 3]) -> Self {
        WatertightQuery {
            org: org.to_array(),
            dir: dir.to_array(),
            p0: p[0].to_array(),
            p1: p[1].to_array(),
            p2: p[2].to_array(),
            ..Self::default()
        }
    }
}

/// What the CPU twin gives for a query, in the GPU's result layout.
pub fn watertight_cpu(q: &WatertightQuery) -> WatertightResult {
    use glam::Vec3;
    let p = [q.p0, q.p1, q.p2].map(Vec3::from_array);
    match cubetrace::cpu::watertight::intersect(Vec3::from_array(q.org), Vec3::from_array(q.dir), p)
    {
        Some(h) => WatertightResult {
            bary: h.bary,
            t: h.t,
            hit: 1,
            ..WatertightResult::default()
        },
        None => WatertightResult::default(),
    }
}

const WORKGROUP: u32 = 64;

fn output(ctx: &GpuContext, name: &str, bytes: u64) -> VkResult<Buffer> {
    Buffer::new(
        ctx.device(),
        name,
        bytes.max(16),
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )
}

/// Runs `wt_intersect` on the GPU, one result per query.
pub fn watertight_gpu(
    ctx: &GpuContext,
    queries: &[WatertightQuery],
) -> VkResult<Vec<WatertightResult>> {
    if queries.is_empty() {
        return Ok(Vec::new());
    }
    let pipeline = ComputePipeline::new(
        ctx,
        &HIT_PROBE,
        "watertight_main",
        ComputeOptions::default(),
    )?;
    let input = ctx.create_buffer_init(
        "watertight queries",
        vk::BufferUsageFlags::STORAGE_BUFFER,
        queries,
    )?;
    let out = output(
        ctx,
        "watertight results",
        (queries.len() * size_of::<WatertightResult>()) as u64,
    )?;
    let set = pipeline.bind_group(
        1,
        &[(0, Resource::Buffer(&input)), (1, Resource::Buffer(&out))],
    )?;
    let groups = (queries.len() as u32).div_ceil(WORKGROUP);
    ctx.submit_and_wait(HIT_PROBE.name, |rec| {
        pipeline.dispatch(rec, &[&set], [groups, 1, 1]);
        Ok(())
    })?;
    let mut r: Vec<WatertightResult> = ctx.read_buffer(&out)?;
    r.truncate(queries.len());
    Ok(r)
}

/// Runs `hit_shade` on the GPU over `scene`, one linear RGB colour per query.
pub fn shade_gpu(
    ctx: &GpuContext,
    scene: &SceneBuffers,
    queries: &[ShadeQuery],
) -> VkResult<Vec<[f32; 3]>> {
    if queries.is_empty() {
        return Ok(Vec::new());
    }
    let pipeline = ComputePipeline::new(ctx, &HIT_PROBE, "shade_main", ComputeOptions::default())?;
    let scene_set = pipeline.bind_group(0, &scene.resources())?;
    let input = ctx.create_buffer_init(
        "shade queries",
        vk::BufferUsageFlags::STORAGE_BUFFER,
        queries,
    )?;
    let out = output(ctx, "shade results", (queries.len() * 16) as u64)?;
    let set = pipeline.bind_group(
        1,
        &[(2, Resource::Buffer(&input)), (3, Resource::Buffer(&out))],
    )?;
    let groups = (queries.len() as u32).div_ceil(WORKGROUP);
    ctx.submit_and_wait(HIT_PROBE.name, |rec| {
        pipeline.dispatch(rec, &[&scene_set, &set], [groups, 1, 1]);
        Ok(())
    })?;
    let r: Vec<[f32; 4]> = ctx.read_buffer(&out)?;
    Ok(r[..queries.len()]
        .iter()
        .map(|c| [c[0], c[1], c[2]])
        .collect())
}

/// Runs `verify_hit` on the GPU over `scene` and one CMO's triangle IDs, one result per query.
pub fn verify_gpu(
    ctx: &GpuContext,
    scene: &SceneBuffers,
    ids: &[u32],
    queries: &[VerifyQuery],
) -> VkResult<Vec<VerifyResult>> {
    if queries.is_empty() {
        return Ok(Vec::new());
    }
    let pipeline = ComputePipeline::new(ctx, &HIT_PROBE, "verify_main", ComputeOptions::default())?;
    // The rule reads positions only: bind the scene bindings the entry point uses.
    let used = pipeline.entry.bindings;
    let scene_resources: Vec<_> = scene
        .resources()
        .into_iter()
        .filter(|(b, _)| used.iter().any(|u| u.group == 0 && u.binding == *b))
        .collect();
    let scene_set = pipeline.bind_group(0, &scene_resources)?;
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
    let input = ctx.create_buffer_init("verify queries", storage, queries)?;
    let ids_buf = ctx.create_buffer_init("verify ids", storage, ids)?;
    let out = output(
        ctx,
        "verify results",
        (queries.len() * size_of::<VerifyResult>()) as u64,
    )?;
    let set = pipeline.bind_group(
        1,
        &[
            (4, Resource::Buffer(&input)),
            (5, Resource::Buffer(&ids_buf)),
            (6, Resource::Buffer(&out)),
        ],
    )?;
    let groups = (queries.len() as u32).div_ceil(WORKGROUP);
    ctx.submit_and_wait(HIT_PROBE.name, |rec| {
        pipeline.dispatch(rec, &[&scene_set, &set], [groups, 1, 1]);
        Ok(())
    })?;
    let mut r: Vec<VerifyResult> = ctx.read_buffer(&out)?;
    r.truncate(queries.len());
    Ok(r)
}

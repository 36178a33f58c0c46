//! The `capture_lists` passes of the `bounded` criterion: sound per-texel bounds and candidate
//! lists of every CMO, on the GPU (`spirv/capture_lists.wgsl`; CPU twin
//! [`crate::cubemap::bounds`], whose module docs derive the bounds).
//!
//! Invariants:
//! - Dispatches over every CMO at once: `faces` (one invocation per (triangle, CMO), each face
//!   in turn: step 0, [`bounds::face_missed`]; the pairs it keeps go to a queue), `jobs` (one
//!   invocation per queued pair: one job per 8x8 tile of its texel rect that is not wholly
//!   outside the triangle; a tile whose part of the rect holds at most 16 texels is a small job;
//!   a pair whose rect needs a clip is queued again for `jobs_hard`, which clips, so that the
//!   clips' code does not cost every pair),
//!   `texels` (a tile job 16 lanes of up to four texels each, a small job 2 lanes of up to
//!   eight; the fast paths per texel: a node per texel wholly inside the triangle, the texels
//!   they cannot decide queued for `clips`), `clips` (the four clips of
//!   each queued texel, a node where the triangle touches it), `resolve` (the `depth` smallest
//!   `(lo, triangle)` sorted at the head of each list, then the per-texel record and `lo`).
//!   `jobs`, `jobs_hard`, `texels` and `clips` are indirect dispatches sized on the GPU from the
//!   queues and the jobs (`job_args`, `hard_args`, `texel_args`, `clip_args`): on lavapipe an idle workgroup, or a
//!   branch no lane takes, still costs its instructions. Nodes are pushed onto each texel's
//!   linked list. [`CaptureLists::record`] clears the heads, overflows and counters first and
//!   records the barriers between the passes and one after (compute writes -> any shader read).
//! - Per texel, CMO-major, `(face N + y) N + x` (like [`CmoData`]'s
//!   distance): the record `[head, bits(complete_to), bits(hi), count_kept]`
//!   ([`TexelRecord`]); the first `count_kept` nodes from `head` ([`ListNode`]) are the
//!   texel's entries in order; `lo` in the distance buffer ([`ListTargets`]: the pass's own, or
//!   the caller's, e.g. the CMO distance, see [`CaptureLists::new`]). Records and nodes are
//!   stored a word per binding ([`super::lists`]: four `u32` bindings each, so no binding
//!   exceeds `maxStorageBufferRange` before the pool holds a quarter of the u32 index space
//!   at 128 MiB). Meanings: [`crate::cubemap::bounds::TexelLists`].
//! - Every binding is checked against the device's `maxStorageBufferRange` before anything is
//!   allocated ([`super::lists::check_range`] for records and pool, and the job buffer):
//!   what does not fit is refused naming its size and the limit.
//! - Capacities come from the CPU ([`capacity`], the same f32 rect as the GPU's, so the job
//!   buffer never fills on a conforming driver). A full job buffer (or a rect over 60000 tiles:
//!   a whole face beyond N = 1952) makes its whole face unknown (`complete_to = 0`); a full
//!   node pool lowers the texel's `complete_to` to the lost entry's `lo`; a full clip queue
//!   ([`bounds::PoolBound::clips`]) gives the texel the whole triangle's bounds (sound, looser;
//!   `clips_dropped`); a list walk capped at
//!   `walk_cap` node visits (lavapipe's loop limit) sets `complete_to = 0`. All three are counted ([`ListCounters`]).
//! - Which triangles: captured objects' (`GpuObject::captured`), reflectors only for a CMO with
//!   `reflectors` set (the capture's rule), with no facing cull.
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::cmo::{CmoData, column_buffers, storage};
use super::lists;
use super::scene_buffers::SceneBuffers;
use crate::cubemap::bounds::{self, PoolBound, TexelLists};
use crate::cubemap::face::FACE_COUNT;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::pipeline::{
    BindGroup, ComputeOptions, ComputePipeline, MAX_GROUPS_X, Resource,
};
use crate::vk::backend::shaders::CAPTURE_LISTS;
use crate::vk::backend::sync::{
    ALL, ALL_READS, COMPUTE_READ, COMPUTE_WRITE, INDIRECT_READ, TRANSFER_WRITE,
};
use crate::vk::backend::timestamps::{Scope, Timestamps};
use crate::vk::options::ListSize;

/// WGSL `ListsParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct ListsParams {
    pub size: u32,
    pub depth: u32,
    pub cmo_count: u32,
    pub triangle_count: u32,
    pub job_capacity: u32,
    pub node_capacity: u32,
    pub walk_cap: u32,
    pub row: u32,
    pub clip_capacity: u32,
    pub pair_capacity: u32,
}

impl ListsParams {
    /// The parameters with the job, node and clip-queue capacities of `capacity` (checked
    /// against the shader's u32 indices by the caller).
    fn with_capacity(self, capacity: PoolBound) -> Self {
        ListsParams {
            job_capacity: capacity.jobs as u32,
            node_capacity: capacity.nodes as u32,
            clip_capacity: capacity.clips.min(u64::from(u32::MAX / 2)) as u32,
            pair_capacity: capacity.pairs.min(u64::from(u32::MAX / 2)) as u32,
            ..self
        }
    }
}

/// WGSL `ListsView`: one CMO.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ListsView {
    pub centre: [f32; 3],
    /// 1: the CMO captures the reflectors (self-reflections on).
    pub reflectors: u32,
}

/// WGSL `ListsJob`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ListsJob {
    pub triangle: u32,
    pub cmo_face: u32,
    pub rect_x: u32,
    pub rect_y: u32,
    pub tile: u32,
    pub m: f32,
    pub e: f32,
    pub whole: u32,
}

/// WGSL `ListsNode`: one entry; `next` is the next node of the texel's list (`u32::MAX`: end).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct ListNode {
    pub triangle: u32,
    pub lo: u32,
    pub hi: u32,
    pub next: u32,
}

/// WGSL `ListsCounters`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct ListCounters {
    /// Jobs appended (may exceed the capacity: the excess was dropped).
    pub jobs: u32,
    pub jobs_dropped: u32,
    /// Nodes appended (may exceed the capacity).
    pub nodes: u32,
    pub nodes_dropped: u32,
    pub walks_capped: u32,
    pub tiles_capped: u32,
    /// Texels queued for the clips (may exceed the capacity), and those that did not fit (they
    /// got the whole triangle's bounds).
    pub clips: u32,
    pub clips_dropped: u32,
    /// Of the jobs kept: whole 8x8 tiles, and small ones (a tile's part of the rect of at most
    /// 16 texels, run several to a workgroup).
    pub tile_jobs: u32,
    pub small_jobs: u32,
    /// (Triangle, CMO face) pairs queued for `jobs` (may exceed the capacity), and those that
    /// did not fit (their face is unknown).
    pub pairs: u32,
    pub pairs_dropped: u32,
    /// Of the pairs: those whose rect needs a clip (`jobs_hard` takes them).
    pub hard_pairs: u32,
}

/// Per texel: `[head, bits(complete_to), bits(hi), count_kept]`.
pub type TexelRecord = [u32; 4];

/// The pass's own record and pool buffers' names, word by word ([`super::lists`]).
const RECORD_NAMES: [&str; 4] = [
    "capture_lists head",
    "capture_lists complete_to",
    "capture_lists hi",
    "capture_lists count",
];
const NODE_NAMES: [&str; 4] = [
    "capture_lists node triangle",
    "capture_lists node lo",
    "capture_lists node hi",
    "capture_lists node next",
];

/// End of a list.
pub const NIL: u32 = u32::MAX;
/// Node visits per texel in `resolve` before the walk gives up (lavapipe: 65535 back-edges per
/// invocation, shared by every loop).
pub const WALK_CAP: u32 = 60_000;
/// Largest `depth` accepted.
pub const MAX_DEPTH: u32 = 1024;
const WORKGROUP: u32 = 64;

/// The world triangles and per-triangle capture flags of a scene for one CMO (the shader's
/// rule: captured objects, reflectors only with `reflectors`).
pub fn scene_triangles(data: &GpuSceneData, reflectors: bool) -> (Vec<[Vec3; 3]>, Vec<bool>) {
    let mut tris = Vec::with_capacity(data.indices.len() / 3);
    let mut flags = Vec::with_capacity(data.indices.len() / 3);
    for t in data.indices.chunks_exact(3) {
        let v = |i: u32| Vec3::from_array(data.vertices[i as usize].position);
        tris.push([v(t[0]), v(t[1]), v(t[2])]);
        let o = &data.objects[data.vertices[t[0] as usize].object as usize];
        // `scene_is_reflector`: any bit of `reflector` (as the shader tests it).
        flags.push(o.captured != 0 && (reflectors || o.reflector == 0));
    }
    (tris, flags)
}

/// The capture views of a scene's CMOs: `(centre, reflectors)`, reflectors taken by every CMO
/// when some reflector of the scene sees itself (as the rasterised capture's views).
pub fn scene_views(scene: &crate::scene::Scene) -> Vec<(Vec3, bool)> {
    let reflectors = scene.captures_reflectors();
    scene
        .cmo_centres()
        .into_iter()
        .map(|c| (c, reflectors))
        .collect()
}

/// Job and node capacities of the capture of `cmos` (`(centre, reflectors)`) at face size
/// `size`: [`bounds::pool_bound`] summed over the CMOs.
pub fn capacity(data: &GpuSceneData, cmos: &[(Vec3, bool)], size: u32) -> PoolBound {
    capacity_at(data, cmos, &[size])[0]
}

/// [`capacity`] at each of `sizes`, each CMO's (triangle, face) pairs found once for them all.
fn capacity_at(data: &GpuSceneData, cmos: &[(Vec3, bool)], sizes: &[u32]) -> Vec<PoolBound> {
    let mut sums = vec![PoolBound::default(); sizes.len()];
    for &(centre, reflectors) in cmos {
        let (tris, flags) = scene_triangles(data, reflectors);
        let pairs = bounds::FacePairs::new(&tris, &flags, centre);
        for (sum, &size) in sums.iter_mut().zip(sizes) {
            *sum = *sum + pairs.bound(size);
        }
    }
    sums
}

/// The lists' face size for `cmos` of `data` as `choice` says (`cube_size`: the CMOs' face size
/// otherwise), and the node pool's bound at it ([`capacity`]). [`ListSize::Auto`] takes the first
/// of [`bounds::AUTO_LIST_MIN`], twice that, ... below `cube_size` whose bound holds at most
/// [`bounds::AUTO_LIST_LENGTH`] nodes per texel, else `cube_size` ([`bounds::auto_list_size`]). Why
/// short lists: halving the face size quarters the texels the capture classifies and resolves and
/// halves those a ray crosses, while each texel's list grows with the triangles its cone takes;
/// where lists grow long, more of them pass the capture's `depth` (the ray goes behind there) and
/// the trace walks them. On lavapipe (`benches/results/lavapipe-list-size.md`) 32 is the cheapest
/// frame on the built-in scenes, with no ray left to the fallback; the corpus's dense interiors
/// take 32 or 64, with a fallback share of at most 0.8 % (at 128, the rule of at most 8 nodes per
/// texel, their capture cost more than their shorter walks saved).
pub fn list_size(
    data: &GpuSceneData,
    cmos: &[(Vec3, bool)],
    cube_size: u32,
    choice: ListSize,
) -> (u32, PoolBound) {
    let size = match choice {
        ListSize::Fixed(n) => n,
        ListSize::Cube => cube_size,
        ListSize::Auto => {
            // Every size the rule may weigh, bounded at once (the pairs are most of the work).
            let sizes: Vec<u32> = std::iter::successors(Some(bounds::AUTO_LIST_MIN), |s| {
                Some(s * 2).filter(|&s| s < cube_size)
            })
            .filter(|&s| s < cube_size)
            .chain([cube_size])
            .collect();
            let known = capacity_at(data, cmos, &sizes);
            let bound_at = |size| {
                (sizes.iter().position(|&s| s == size))
                    .map_or_else(|| capacity(data, cmos, size), |i| known[i])
            };
            let texels = |size: u32| cmos.len() as u64 * 6 * u64::from(size) * u64::from(size);
            let size = bounds::auto_list_size(cube_size, cmos.len(), |size| {
                let nodes = bound_at(size).nodes;
                log::debug!(
                    "bounded lists at {size}: a bound of {nodes} nodes, {:.2} per texel",
                    nodes as f64 / texels(size).max(1) as f64
                );
                nodes
            });
            return (size, bound_at(size));
        }
    };
    (size, capacity(data, cmos, size))
}

/// Invocations per dispatch row of `jobs` and `resolve` (`ListsParams::row`).
const ROW: u32 = WORKGROUP * MAX_GROUPS_X;

/// Workgroups for `invocations` linearised as `gid.x + gid.y * ROW`.
fn linear_groups(invocations: u64) -> [u32; 3] {
    let groups = invocations.div_ceil(u64::from(WORKGROUP)).max(1);
    let x = groups.min(u64::from(MAX_GROUPS_X)) as u32;
    [x, invocations.div_ceil(u64::from(ROW)).max(1) as u32, 1]
}

/// The `ListsView` of each CMO `(centre, reflectors)`.
fn list_views(cmos: &[(Vec3, bool)]) -> Vec<ListsView> {
    cmos.iter()
        .map(|&(c, r)| ListsView {
            centre: c.to_array(),
            reflectors: u32::from(r),
        })
        .collect()
}

/// Every `@group(1)` resource of the passes by binding: the pass's own buffers (params, views,
/// jobs, heads, overflow, face overflow, counters; then the clip queue and its dispatch size)
/// and the targets.
fn group1_resources<'a>(own: [&'a Buffer; 9], out: ListTargets<'a>) -> Vec<(u32, Resource<'a>)> {
    let mut all: Vec<(u32, Resource<'a>)> = (0u32..)
        .zip(&own[..7])
        .map(|(i, b)| (i, Resource::Buffer(b)))
        .collect();
    all.push((7, Resource::Buffer(out.distance)));
    for (i, b) in out.records.iter().chain(out.nodes).enumerate() {
        all.push((8 + i as u32, Resource::Buffer(b)));
    }
    all.push((16, Resource::Buffer(own[7])));
    all.push((17, Resource::Buffer(own[8])));
    all.push((18, Resource::Buffer(out.gaps)));
    all
}

/// The `texels`, `clips`, `jobs` and `jobs_hard` dispatch sizes (four
/// `VkDispatchIndirectCommand`s).
fn args_buffer(ctx: &GpuContext) -> VkResult<Buffer> {
    Buffer::new(
        ctx.device(),
        "capture_lists dispatch args",
        48,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::INDIRECT_BUFFER,
        gpu_allocator::MemoryLocation::GpuOnly,
    )
}

/// Bytes of the clip queue for `capacity`: two u32 per queued texel, or per queued (triangle,
/// face) pair twice (the face queue uses the buffer first, from its front, and the pairs that
/// need a clip are queued again from its back); the buffer itself holds at least one entry.
pub fn clip_queue_bytes(capacity: PoolBound) -> u64 {
    capacity.clips.max(2 * capacity.pairs) * 8
}

/// The passes' pipelines, in recording order.
fn pipelines(ctx: &GpuContext) -> VkResult<[ComputePipeline; 10]> {
    let pipe = |e| ComputePipeline::new(ctx, &CAPTURE_LISTS, e, ComputeOptions::default());
    Ok([
        pipe("faces")?,
        pipe("job_args")?,
        pipe("jobs")?,
        pipe("hard_args")?,
        pipe("jobs_hard")?,
        pipe("texel_args")?,
        pipe("texels")?,
        pipe("clip_args")?,
        pipe("clips")?,
        pipe("resolve")?,
    ])
}

/// The `@group(1)` set of pass `p`: the resources of `all` its entry point uses.
fn group1_set(p: &ComputePipeline, all: &[(u32, Resource<'_>)]) -> VkResult<BindGroup> {
    let used = |b: u32| {
        p.entry
            .bindings
            .iter()
            .any(|u| u.group == 1 && u.binding == b)
    };
    let own: Vec<_> = all.iter().copied().filter(|(b, _)| used(*b)).collect();
    p.bind_group(1, &own)
}

/// `(K, texels, triangles)` of a [`CaptureLists::new`] call, or why it cannot run (bindings
/// over `range_limit` bytes: [`VkError::Limit`]).
#[allow(clippy::too_many_arguments)]
fn check_inputs(
    ctx: &GpuContext,
    range_limit: u64,
    scene: &SceneBuffers,
    size: u32,
    depth: u32,
    cmos: &[(Vec3, bool)],
    capacity: PoolBound,
    targets: Option<ListTargets<'_>>,
) -> VkResult<(u64, u64, u64)> {
    let usage = |detail: String| VkError::Usage {
        what: CAPTURE_LISTS.name.into(),
        detail,
    };
    let k = cmos.len() as u64;
    let texels = k * u64::from(FACE_COUNT) * u64::from(size) * u64::from(size);
    if k == 0 || size == 0 || size > 2048 || depth == 0 || depth > MAX_DEPTH {
        return Err(usage(format!(
            "{k} CMOs of size {size}, depth {depth}: need at least one CMO, 1 <= N <= 2048 \
             and 1 <= depth <= {MAX_DEPTH}"
        )));
    }
    let triangles = u64::from(scene.index_count / 3);
    if texels > u64::from(u32::MAX / 2)
        || triangles * 6 * k > u64::from(u32::MAX / 2)
        || capacity.jobs > u64::from(u32::MAX / 2)
        || capacity.nodes > u64::from(u32::MAX / 2)
    {
        return Err(usage(format!(
            "{k} CMOs of size {size}, {triangles} triangles, {} jobs, {} nodes overflow the \
             shader's u32 indices",
            capacity.jobs, capacity.nodes
        )));
    }
    super::cmo::check_list_range(ctx, texels, capacity.nodes.max(1), range_limit)?;
    let job_bytes = capacity.jobs.max(1) * size_of::<ListsJob>() as u64;
    if job_bytes > range_limit {
        return Err(VkError::Limit {
            device: ctx.report().name.clone(),
            what: format!(
                "the `--criterion bounded` capture's job buffer ({} jobs: {} MiB)",
                capacity.jobs,
                job_bytes >> 20
            ),
            limit: format!("maxStorageBufferRange = {} MiB", range_limit >> 20),
        });
    }
    if let Some(t) = targets {
        let words = lists::COLUMN_BYTES;
        let columns = t.records.iter().map(|b| (b, texels * words));
        let pool = t.nodes.iter().map(|b| (b, capacity.nodes * words));
        for (b, need) in [(t.distance, texels * 4)]
            .into_iter()
            .chain(columns)
            .chain(pool)
        {
            if b.size() < need {
                return Err(usage(format!(
                    "buffer `{}` has {} bytes, the capture needs {need}",
                    b.name(),
                    b.size()
                )));
            }
        }
    }
    Ok((k, texels, triangles))
}

/// The ten passes' pipelines, their bindings and buffers for one scene and CMO set.
pub struct CaptureLists {
    /// The passes in recording order (`pipelines`): `faces`, `job_args`, `jobs`, `hard_args`,
    /// `jobs_hard`, `texel_args`, `texels`, `clip_args`, `clips`, `resolve`; `sets` holds their `@group(0)`
    /// and `@group(1)` sets in the same order.
    passes: [ComputePipeline; 10],
    sets: [(BindGroup, BindGroup); 10],
    params_buf: Buffer,
    views_buf: Buffer,
    job_buf: Buffer,
    heads: Buffer,
    overflow: Buffer,
    face_overflow: Buffer,
    counters: Buffer,
    clip_buf: Buffer,
    args_buf: Buffer,
    /// Distance, records and nodes when the caller gave none ([`ListTargets`]).
    own: Option<OwnTargets>,
    params: ListsParams,
    /// What the views buffer holds.
    views: Vec<ListsView>,
    faces_groups: [u32; 3],
    resolve_groups: [u32; 3],
}

/// Where the capture writes its results: `lo` per texel (K blocks of `6 N N` f32, e.g. the
/// CMO distance buffer), the per-texel records and the node pool, a binding per word (e.g.
/// the CMO data's, [`super::cmo::CmoData::alloc_lists`]; [`super::lists`]).
#[derive(Clone, Copy)]
pub struct ListTargets<'a> {
    pub distance: &'a Buffer,
    /// `head`, `bits(complete_to)`, `bits(hi)`, `count_kept`: a u32 per texel each.
    pub records: &'a [Buffer; 4],
    /// `triangle`, `bits(lo)`, `bits(hi)`, `next`: a u32 per node each.
    pub nodes: &'a [Buffer; 4],
    /// The texels' gaps, a word per texel ([`bounds::pack_gap`]), laid out as `distance`.
    pub gaps: &'a Buffer,
}

impl<'a> ListTargets<'a> {
    /// The CMO data's own buffers (after [`CmoData::alloc_lists`]): its distances, records,
    /// pool and the texels' gaps.
    pub fn of(cmo: &'a CmoData) -> Self {
        ListTargets {
            distance: cmo.distance(),
            records: cmo.lists(),
            nodes: cmo.nodes(),
            gaps: &cmo.gaps()[0],
        }
    }
}

/// The result buffers a capture allocated itself (no [`ListTargets`] given).
struct OwnTargets {
    distance: Buffer,
    records: [Buffer; 4],
    nodes: [Buffer; 4],
    gaps: Buffer,
}

impl OwnTargets {
    fn targets(&self) -> ListTargets<'_> {
        ListTargets {
            distance: &self.distance,
            records: &self.records,
            nodes: &self.nodes,
            gaps: &self.gaps,
        }
    }
}

/// One readback: per CMO the lists as the CPU twin holds them, plus the counters.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuLists {
    pub cmos: Vec<TexelLists>,
    pub counters: ListCounters,
    /// The raw records (per texel, CMO-major).
    pub records: Vec<TexelRecord>,
    /// Per CMO, its texels' gaps as `resolve` packed them (the CPU's
    /// [`TexelLists::packed_gaps`]).
    pub gaps: Vec<Vec<u32>>,
}

impl CaptureLists {
    /// Prepares the capture of the CMOs `cmos` (`(centre, reflectors)`) of the scene in `scene`
    /// (`triangle_count` triangles, its index buffer in global order) at face size `size`,
    /// keeping `depth` entries per texel, with room for `capacity.jobs` jobs and
    /// `capacity.nodes` nodes (from [`capacity`]; a smaller pool is sound, see the module docs).
    /// `targets`: where the results go; `None` allocates them (read them with
    /// [`CaptureLists::read_back`]). Refused where a binding would exceed the device's
    /// `maxStorageBufferRange` (module docs).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        scene: &SceneBuffers,
        size: u32,
        depth: u32,
        cmos: &[(Vec3, bool)],
        capacity: PoolBound,
        targets: Option<ListTargets<'_>>,
    ) -> VkResult<Self> {
        let limit = u64::from(ctx.report().max_storage_buffer_range);
        Self::limited(ctx, scene, size, depth, cmos, capacity, targets, limit)
    }

    /// [`CaptureLists::new`] with the per-binding limit `range_limit` in bytes in place of the
    /// device's (tests: a lowered limit; one above the device's still fails when bound).
    #[cfg(feature = "test-hooks")]
    #[allow(clippy::too_many_arguments)]
    pub fn with_range_limit(
        ctx: &GpuContext,
        scene: &SceneBuffers,
        size: u32,
        depth: u32,
        cmos: &[(Vec3, bool)],
        capacity: PoolBound,
        targets: Option<ListTargets<'_>>,
        range_limit: u64,
    ) -> VkResult<Self> {
        Self::limited(
            ctx,
            scene,
            size,
            depth,
            cmos,
            capacity,
            targets,
            range_limit,
        )
    }

    /// [`CaptureLists::new`] under the per-binding limit `range_limit` in bytes.
    #[allow(clippy::too_many_arguments)]
    fn limited(
        ctx: &GpuContext,
        scene: &SceneBuffers,
        size: u32,
        depth: u32,
        cmos: &[(Vec3, bool)],
        capacity: PoolBound,
        targets: Option<ListTargets<'_>>,
        range_limit: u64,
    ) -> VkResult<Self> {
        let (k, texels, triangles) = check_inputs(
            ctx,
            range_limit,
            scene,
            size,
            depth,
            cmos,
            capacity,
            targets,
        )?;
        let params = ListsParams {
            size,
            depth,
            cmo_count: k as u32,
            triangle_count: triangles as u32,
            walk_cap: WALK_CAP,
            row: ROW,
            ..ListsParams::default().with_capacity(capacity)
        };
        let passes = pipelines(ctx)?;
        let views = list_views(cmos);
        let st = vk::BufferUsageFlags::STORAGE_BUFFER;
        let params_buf = ctx.create_buffer_init("capture_lists params", st, &[params])?;
        let views_buf = ctx.create_buffer_init("capture_lists views", st, &views)?;
        let job_buf = storage(ctx, "capture_lists jobs", capacity.jobs.max(1) * 32)?;
        let heads = storage(ctx, "capture_lists heads", texels * 4)?;
        let overflow = storage(ctx, "capture_lists overflow", texels * 4)?;
        let face_overflow = storage(ctx, "capture_lists face overflow", k * 6 * 4)?;
        let counters = storage(
            ctx,
            "capture_lists counters",
            size_of::<ListCounters>() as u64,
        )?;
        let clip_buf = storage(
            ctx,
            "capture_lists clips",
            clip_queue_bytes(capacity).max(8),
        )?;
        let args_buf = args_buffer(ctx)?;
        let own = match targets {
            Some(_) => None,
            None => Some(OwnTargets {
                distance: storage(ctx, "capture_lists distance", texels * 4)?,
                records: column_buffers(ctx, RECORD_NAMES, texels)?,
                nodes: column_buffers(ctx, NODE_NAMES, capacity.nodes)?,
                gaps: storage(ctx, "capture_lists gaps", texels * 4)?,
            }),
        };
        let out = targets
            .or(own.as_ref().map(OwnTargets::targets))
            .expect("one of the two");
        let all = group1_resources(
            [
                &params_buf,
                &views_buf,
                &job_buf,
                &heads,
                &overflow,
                &face_overflow,
                &counters,
                &clip_buf,
                &args_buf,
            ],
            out,
        );
        let sets_for = |p: &ComputePipeline| -> VkResult<(BindGroup, BindGroup)> {
            let scene_res = scene.resources_for(p.pass, &[p.entry.name]);
            Ok((p.bind_group(0, &scene_res)?, group1_set(p, &all)?))
        };
        let mut sets = Vec::with_capacity(passes.len());
        for p in &passes {
            sets.push(sets_for(p)?);
        }
        Ok(CaptureLists {
            passes,
            sets: sets.try_into().ok().expect("one set pair per pass"),
            params_buf,
            views_buf,
            job_buf,
            heads,
            overflow,
            face_overflow,
            counters,
            clip_buf,
            args_buf,
            own,
            params,
            views,
            faces_groups: linear_groups(triangles * k),
            resolve_groups: linear_groups(texels),
        })
    }

    /// Records the capture: the clears, then the passes in order (`faces`, `job_args`, `jobs`,
    /// `hard_args`, `jobs_hard`, `texel_args`, `texels`, `clip_args`, `clips`, `resolve`), with barriers between them and
    /// one after (compute writes -> every later read). The barrier before (after whatever last
    /// read the buffers) is `ALL -> TRANSFER_WRITE`, recorded here too.
    pub fn record(&self, rec: &Recorder<'_>) -> VkResult<()> {
        self.record_timed(rec, None)
    }

    /// [`CaptureLists::record`] with one timestamp scope per stage (`capture_lists.faces`,
    /// `capture_lists.jobs`, `capture_lists.texels`, `capture_lists.clips`,
    /// `capture_lists.resolve`; the clears go with `faces`, `job_args`, `hard_args` and
    /// `jobs_hard` with `jobs`, `clip_args`
    /// with `clips`; `texel_args`, one invocation, is in none).
    pub fn record_timed(
        &self,
        rec: &Recorder<'_>,
        mut ts: Option<&mut Timestamps>,
    ) -> VkResult<()> {
        let scope = |ts: &mut Option<&mut Timestamps>, name: &str| -> VkResult<_> {
            ts.as_deref_mut().map(|t| t.begin(rec, name)).transpose()
        };
        let end = |ts: &mut Option<&mut Timestamps>, s: Option<Scope>| {
            if let (Some(t), Some(s)) = (ts.as_deref_mut(), s) {
                t.end(rec, s);
            }
        };
        let s = scope(&mut ts, "capture_lists.faces")?;
        rec.memory_barrier(ALL, TRANSFER_WRITE);
        rec.fill_buffer(&self.heads, NIL);
        rec.fill_buffer(&self.overflow, f32::INFINITY.to_bits());
        rec.fill_buffer(&self.face_overflow, f32::INFINITY.to_bits());
        rec.fill_buffer(&self.counters, 0);
        rec.memory_barrier(TRANSFER_WRITE, COMPUTE_READ);
        let rw = (COMPUTE_READ.0, COMPUTE_READ.1 | COMPUTE_WRITE.1);
        let [
            faces,
            job_args,
            jobs,
            hard_args,
            jobs_hard,
            texel_args,
            texels,
            clip_args,
            clips,
            resolve,
        ] = &self.passes;
        let set = |i: usize| [&self.sets[i].0, &self.sets[i].1];
        faces.dispatch(rec, &set(0), self.faces_groups);
        end(&mut ts, s);
        rec.memory_barrier(COMPUTE_WRITE, rw);
        let s = scope(&mut ts, "capture_lists.jobs")?;
        job_args.dispatch(rec, &set(1), [1, 1, 1]);
        rec.memory_barrier(COMPUTE_WRITE, INDIRECT_READ);
        jobs.dispatch_indirect(rec, &set(2), &self.args_buf, 24)?;
        rec.memory_barrier(COMPUTE_WRITE, rw);
        hard_args.dispatch(rec, &set(3), [1, 1, 1]);
        rec.memory_barrier(COMPUTE_WRITE, INDIRECT_READ);
        jobs_hard.dispatch_indirect(rec, &set(4), &self.args_buf, 36)?;
        end(&mut ts, s);
        rec.memory_barrier(COMPUTE_WRITE, rw);
        texel_args.dispatch(rec, &set(5), [1, 1, 1]);
        rec.memory_barrier(COMPUTE_WRITE, INDIRECT_READ);
        let s = scope(&mut ts, "capture_lists.texels")?;
        texels.dispatch_indirect(rec, &set(6), &self.args_buf, 0)?;
        end(&mut ts, s);
        rec.memory_barrier(COMPUTE_WRITE, rw);
        let s = scope(&mut ts, "capture_lists.clips")?;
        clip_args.dispatch(rec, &set(7), [1, 1, 1]);
        rec.memory_barrier(COMPUTE_WRITE, INDIRECT_READ);
        clips.dispatch_indirect(rec, &set(8), &self.args_buf, 12)?;
        end(&mut ts, s);
        rec.memory_barrier(COMPUTE_WRITE, rw);
        let s = scope(&mut ts, "capture_lists.resolve")?;
        resolve.dispatch(rec, &set(9), self.resolve_groups);
        end(&mut ts, s);
        rec.memory_barrier(COMPUTE_WRITE, ALL_READS);
        Ok(())
    }

    /// Why the capture cannot take the CMOs `cmos` in place ([`CaptureLists::update`]), `None`
    /// where it can: as many CMOs as at creation, each with the same reflector flag.
    pub fn update_blocker(&self, cmos: &[(Vec3, bool)]) -> Option<String> {
        let same = |(c, v): (&(Vec3, bool), &ListsView)| u32::from(c.1) == v.reflectors;
        if cmos.len() != self.views.len() || !cmos.iter().zip(&self.views).all(same) {
            return Some("the bounded capture's CMO count or reflector flags changed".into());
        }
        None
    }

    /// Points the capture at the CMOs `cmos` (see [`CaptureLists::update_blocker`]) of the scene
    /// in `scene` (its triangles those of creation) with the capacities `capacity` (from
    /// [`capacity`] over the scene as it is now), writing into `targets` (or the pass's own for
    /// `None`; a caller's pool must hold `capacity.nodes` already): the next
    /// [`CaptureLists::record`] is that of a pass created with them. A job buffer (or own pool)
    /// too small for the new capacities is allocated again; larger ones are kept, as the passes
    /// read the capacities, not the buffer lengths. Refused as [`CaptureLists::new`] refuses.
    pub fn update(
        &mut self,
        ctx: &GpuContext,
        scene: &SceneBuffers,
        cmos: &[(Vec3, bool)],
        capacity: PoolBound,
        targets: Option<ListTargets<'_>>,
    ) -> VkResult<()> {
        if let Some(why) = self.update_blocker(cmos) {
            return Err(VkError::Usage {
                what: CAPTURE_LISTS.name.into(),
                detail: why,
            });
        }
        let (size, depth) = (self.params.size, self.params.depth);
        let limit = u64::from(ctx.report().max_storage_buffer_range);
        let nodes = capacity.nodes.max(1) * lists::COLUMN_BYTES;
        if let Some(own) = self.own.as_mut().filter(|o| nodes > o.nodes[0].size()) {
            super::cmo::check_list_range(ctx, 1, capacity.nodes.max(1), limit)?;
            own.nodes = column_buffers(ctx, NODE_NAMES, capacity.nodes)?;
        }
        let no_targets = || VkError::Usage {
            what: CAPTURE_LISTS.name.into(),
            detail: "no targets: the pass was created writing the caller's".into(),
        };
        let out = targets.or(self.own_targets()).ok_or_else(no_targets)?;
        check_inputs(ctx, limit, scene, size, depth, cmos, capacity, Some(out))?;
        if capacity.jobs.max(1) * 32 > self.job_buf.size() {
            self.job_buf = storage(ctx, "capture_lists jobs", capacity.jobs.max(1) * 32)?;
        }
        if clip_queue_bytes(capacity).max(8) > self.clip_buf.size() {
            self.clip_buf = storage(
                ctx,
                "capture_lists clips",
                clip_queue_bytes(capacity).max(8),
            )?;
        }
        let out = targets.or(self.own_targets()).ok_or_else(no_targets)?;
        let own = [
            &self.params_buf,
            &self.views_buf,
            &self.job_buf,
            &self.heads,
            &self.overflow,
            &self.face_overflow,
            &self.counters,
            &self.clip_buf,
            &self.args_buf,
        ];
        let all = group1_resources(own, out);
        let groups = self
            .passes
            .iter()
            .map(|p| group1_set(p, &all))
            .collect::<VkResult<Vec<_>>>()?;
        for (set, g) in self.sets.iter_mut().zip(groups) {
            set.1 = g;
        }
        self.views = list_views(cmos);
        self.params = self.params.with_capacity(capacity);
        ctx.write_buffer(&self.views_buf, &self.views)?;
        ctx.write_buffer(&self.params_buf, &[self.params])
    }

    /// Sets the resolve pass's cap on node visits per texel (tests: the capped path).
    #[cfg(feature = "test-hooks")]
    pub fn set_walk_cap(&mut self, ctx: &GpuContext, walk_cap: u32) -> VkResult<()> {
        self.params.walk_cap = walk_cap.min(WALK_CAP);
        ctx.write_buffer(&self.params_buf, &[self.params])
    }

    /// The result buffers this pass allocated (`None` when it writes the caller's
    /// [`ListTargets`]).
    pub fn own_targets(&self) -> Option<ListTargets<'_>> {
        self.own.as_ref().map(OwnTargets::targets)
    }

    /// The counters of the last capture (after a submission of [`CaptureLists::record`]).
    pub fn read_counters(&self, ctx: &GpuContext) -> VkResult<ListCounters> {
        let c: Vec<ListCounters> = ctx.read_buffer(&self.counters)?;
        Ok(c[0])
    }

    /// The counters ([`ListCounters`]).
    pub fn counters(&self) -> &Buffer {
        &self.counters
    }

    /// The parameters the pass runs with.
    pub fn params(&self) -> &ListsParams {
        &self.params
    }

    /// Reads everything back (after a submission of [`CaptureLists::record`]): per CMO the
    /// lists as [`TexelLists`] (entries from the first `count_kept` nodes of each list), from
    /// `targets`: those given to [`CaptureLists::new`], or `None` for this pass's own.
    pub fn read_back(
        &self,
        ctx: &GpuContext,
        targets: Option<ListTargets<'_>>,
    ) -> VkResult<GpuLists> {
        let out = targets
            .or(self.own_targets())
            .ok_or_else(|| VkError::Usage {
                what: CAPTURE_LISTS.name.into(),
                detail: "read_back needs the buffers the pass writes".into(),
            })?;
        let read = |b: &[Buffer; 4]| -> VkResult<Vec<[u32; 4]>> {
            let [a, b, c, d] = b;
            let cols = [
                ctx.read_buffer(a)?,
                ctx.read_buffer(b)?,
                ctx.read_buffer(c)?,
                ctx.read_buffer(d)?,
            ];
            Ok(lists::rows(&cols))
        };
        let records: Vec<TexelRecord> = read(out.records)?;
        let nodes: Vec<[u32; 4]> = read(out.nodes)?;
        let counters = self.read_counters(ctx)?;
        let dist: Vec<f32> = ctx.read_buffer(out.distance)?;
        let all_gaps: Vec<u32> = ctx.read_buffer(out.gaps)?;
        let n = self.params.size as usize;
        let per_cmo = 6 * n * n;
        let gaps = all_gaps.chunks(per_cmo).map(<[u32]>::to_vec).collect();
        let mut cmos = Vec::new();
        for c in 0..self.params.cmo_count as usize {
            let mut l = TexelLists {
                size: self.params.size,
                depth: self.params.depth,
                lo: dist[c * per_cmo..(c + 1) * per_cmo].to_vec(),
                hi: Vec::with_capacity(per_cmo),
                complete_to: Vec::with_capacity(per_cmo),
                offsets: vec![0],
                entries: Vec::new(),
            };
            for (i, r) in records[c * per_cmo..(c + 1) * per_cmo].iter().enumerate() {
                l.complete_to.push(f32::from_bits(r[1]));
                l.hi.push(f32::from_bits(r[2]));
                let entries =
                    lists::walk(&records, &nodes, c * per_cmo + i).map_err(|e| VkError::Usage {
                        what: CAPTURE_LISTS.name.into(),
                        detail: e,
                    })?;
                l.entries.extend(entries);
                l.offsets.push(l.entries.len() as u32);
            }
            cmos.push(l);
        }
        Ok(GpuLists {
            cmos,
            counters,
            records,
            gaps,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check_layout;

    #[test]
    fn layouts_match_the_shader() {
        let l = |n| CAPTURE_LISTS.struct_layout(n).unwrap();
        check_layout!(
            ListsParams,
            l("ListsParams"),
            [
                size,
                depth,
                cmo_count,
                triangle_count,
                job_capacity,
                node_capacity,
                walk_cap,
                row,
                clip_capacity,
                pair_capacity
            ]
        )
        .unwrap();
        check_layout!(ListsView, l("ListsView"), [centre, reflectors]).unwrap();
        check_layout!(
            ListsJob,
            l("ListsJob"),
            [triangle, cmo_face, rect_x, rect_y, tile, m, e, whole]
        )
        .unwrap();
        check_layout!(ListNode, l("ListsNode"), [triangle, lo, hi, next]).unwrap();
        // Negative: a field missing or another struct's layout.
        assert!(check_layout!(ListNode, l("ListsNode"), [triangle, lo, hi]).is_err());
        assert!(check_layout!(ListNode, l("ListsView"), [triangle, lo, hi, next]).is_err());
        check_layout!(
            ListCounters,
            l("ListsCounters"),
            [
                jobs,
                jobs_dropped,
                nodes,
                nodes_dropped,
                walks_capped,
                tiles_capped,
                clips,
                clips_dropped,
                tile_jobs,
                small_jobs,
                pairs,
                pairs_dropped,
                hard_pairs
            ]
        )
        .unwrap();
    }
}

//! `--bounces N` on the GPU: the reflections after the method's first, as a wavefront of rays
//! traced by the BVH kernel ([`super::bvh`]), so that a path reflects as the CPU reference's
//! `finish_path` does, bounce for bounce.
//!
//! | N | passes (after the method's, and the trace fallback if any) |
//! |---|---|
//! | 0 | `bounce_append` (`own_material`) instead of the method's: no ray is traced, every mirror pixel shows its own material (the G-buffer's colour), `bounces` = 0 |
//! | 1 | none: the method's records are final, `bounces` = 1 |
//! | ≥ 2 | round 2: `bounce_append` (`append_first`, per pixel), `args`, `bvh_trace`; round k ≥ 3: `bounce_append` (`append_next`, per ray of round k - 1, indirect), `args`, `bvh_trace` |
//!
//! The rule, per round k = 2..=N (all recorded in the frame's one command buffer; the CPU knows
//! N, the GPU the ray counts):
//! - A record of round k - 1 that is a hit on a reflector triangle appends the next reflected
//!   ray to round k's queue (an atomic counter): from the record's point, along
//!   `normalize(reflect(d, n))`, `n` the normalised interpolated vertex normal of the hit
//!   triangle at the hit (the reference's `Tracer::normal` and `reflect`), leaving that triangle
//!   under the BVH kernel's start rule (the reference's `Tracer::nearest` with `from`), from
//!   t = 0. Escaped, unresolved and non-reflector records are final.
//! - Round k's rays are traced by the BVH kernel, exactly, over an indirect dispatch sized on the
//!   GPU. The record of the pixel is overwritten with the new hit, so a record holds the final
//!   hit of the pixel's path, and `bounces` = k (the kernel writes the ray's `bounce` + 1).
//! - Rounds ≥ 2 are always the BVH's, whatever the method: a reflected ray off a curved mirror
//!   starts anywhere in the scene (no CMO centre is near it), so the cubemap paths would leave
//!   more of it unresolved than of the camera's rays, and the target is the reference's
//!   image bounce for bounce. Only round 1 (the camera's reflected rays, which the CMOs were
//!   placed for) is the method's.
//! - After round N, a hit on a reflector keeps the colour the kernel shaded there, the
//!   reflector's own material: the reference's rule after the last bounce.
//!
//! A round-1 hit needs its triangle for the next ray: `compute`, `fragment` with the exact
//! criterion (verified hits) and `bvh` name it; the other methods (and `fragment` with another
//! criterion) take `bounces` = 1 only. Two queues (each one ray per pixel at most) alternate
//! between the rounds; they and the BVH are allocated only for N ≥ 2, and the BVH is shared with
//! the frame's own BVH passes when it has them (`bvh`, `--fallback trace`).
//!
//! # Several reflections, as a wavefront
//!
//! Several reflections per path (`--bounces N`, 0 to 16, default 1), as a wavefront. The reference
//! reflects a path up to N times about the hit triangle's interpolated normal and shades a reflector
//! met after the last bounce with its own material; the GPU does the same. The method traces the
//! camera's reflected rays (round 1). For each round k = 2..=N, recorded in the frame's one command
//! buffer, `bounce_append` appends the next reflected ray of every record that hit a reflector
//! (from the hit point, about the normal interpolated there, leaving that triangle under the BVH
//! start rule) to a queue through an atomic counter, and `bvh_trace` traces the queue over an
//! indirect dispatch sized on the GPU. Entry points: `own_material` (N = 0), `append_first` (one
//! invocation per pixel) and `append_next` (one per ray of the previous round, dispatched with that
//! queue's own `bvh_trace` arguments).
//!
//! Invariants:
//! - A record keeps the final hit of its pixel's path and its `bounces` count (the EXR channel).
//! - Rounds >= 2 are always traced by the BVH, whatever the method: those rays start anywhere in
//!   the scene, far from the CMO centres placed for the camera's rays; the cubemap methods keep
//!   round 1. So the target is the reference's image, bounce for bounce.
//! - N = 0 traces nothing: mirror pixels show their own material (the G-buffer's colour).
//! - The two alternating queues and the BVH exist only for N >= 2 (the BVH shared with `bvh` or
//!   `--fallback trace`).
//! - Methods whose records name no triangle (`envmap`, `ssr`, `reflection-point`, and the
//!   approximate criteria) refuse N != 1 (`Method::check_bounces`).
//!
//! Checked against the reference per mirror pixel: the same final triangle, and there the colour
//! within 1e-3 and the same bounce count. `bvh` on the bowl seen from above its rim (N = 3, 1235 of
//! 2465 paths reflect 2 or 3 times at 64x48): 2465 of 2465; two facing flat mirrors (N = 1, 2, 5):
//! 2772 of 2772 each; N = 0: all but the silhouette's 4 of 698. The cubemap paths lose nothing to
//! the bounces beyond their own first round (bowl: same triangle 91.6 % at N = 3, 90.1 % at N = 1,
//! self-capture on). Negative: each frame against the reference of another N, and the second
//! mirror's normals turned by 0.5 degrees, fail. At 320x240 (`render --compare`, lavapipe):
//! teapot N = 3, `bvh`, `compute` and `fragment` 53.2 dB over mirror pixels; bowl N = 3 103.6 dB.
use ash::vk;

use super::bvh::{BvhQueue, BvhTracer, pixel_groups};
use super::gbuffer::Gbuffer;
use super::scene_buffers::SceneBuffers;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::VkResult;
use crate::vk::backend::pipeline::{BindGroup, ComputeOptions, ComputePipeline, Resource};
use crate::vk::backend::shaders::BOUNCE_APPEND;
use crate::vk::backend::sync::ALL;

/// The most reflections per path a render takes (`--bounces`): each costs a round of two small
/// dispatches and a trace; the reference stores the count in a `u8`.
pub const MAX_BOUNCES: u32 = 16;

/// The passes of `--bounces N` for one frame (see the module docs).
pub struct BouncePasses {
    bounces: u32,
    groups: [u32; 3],
    /// N = 0: `own_material` and its groups 0..=3 (1 and 2 empty for this entry).
    own: Option<(ComputePipeline, Vec<BindGroup>)>,
    /// N ≥ 2.
    rounds: Option<Rounds>,
}

struct Rounds {
    queues: [BvhQueue; 2],
    /// `append_first` into queue 0.
    first: ComputePipeline,
    first_sets: Vec<BindGroup>,
    /// `append_next` from queue `k` into queue `1 - k`: the queue groups (set 2) by `k`.
    next: ComputePipeline,
    next_frame: Vec<BindGroup>,
    next_queues: [BindGroup; 2],
    /// The tracer when the frame has none to share.
    tracer: Option<BvhTracer>,
    /// `bvh_trace`'s queue group (set 2) for each queue.
    trace_sets: [BindGroup; 2],
}

impl BouncePasses {
    /// The passes for `bounces` reflections over the frame's G-buffer, `FrameParams` buffer
    /// `params` and `records`; `shared` is the frame's own BVH tracer, if it has one (else, for
    /// N ≥ 2, the BVH is built here over `data`).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        bounces: u32,
        data: &GpuSceneData,
        scene: &SceneBuffers,
        gbuffer: &Gbuffer,
        params: &Buffer,
        records: &Buffer,
        shared: Option<&BvhTracer>,
        t_hi: f32,
    ) -> VkResult<Self> {
        let (width, height) = gbuffer.extent();
        let sampled = |img: &crate::vk::backend::image::Image| Resource::Texture {
            view: img.view(),
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        // Each entry's own bindings of group 0 (a binding an entry does not use is refused).
        let own_frame = [
            (0, sampled(&gbuffer.position)),
            (2, Resource::Buffer(params)),
            (3, Resource::Buffer(records)),
            (4, sampled(&gbuffer.colour)),
            (8, sampled(&gbuffer.triangle)),
        ];
        let first_frame = [
            (0, sampled(&gbuffer.position)),
            (2, Resource::Buffer(params)),
            (3, Resource::Buffer(records)),
        ];
        let next_frame_bindings = [(3, Resource::Buffer(records))];
        let pipeline = |entry: &str| {
            ComputePipeline::new(ctx, &BOUNCE_APPEND, entry, ComputeOptions::default())
        };
        let own = if bounces == 0 {
            let p = pipeline("own_material")?;
            let sets = vec![p.bind_group(0, &own_frame)?];
            Some((p, sets))
        } else {
            None
        };
        let rounds = if bounces >= 2 {
            let pixels = u64::from(width) * u64::from(height);
            let queues = [BvhQueue::new(ctx, pixels)?, BvhQueue::new(ctx, pixels)?];
            let first_queue = |p: &ComputePipeline, out: &BvhQueue| {
                p.bind_group(
                    2,
                    &[
                        (0, Resource::Buffer(out.counter())),
                        (1, Resource::Buffer(out.rays())),
                    ],
                )
            };
            let queue_group = |p: &ComputePipeline, out: &BvhQueue, inq: &BvhQueue| {
                p.bind_group(
                    2,
                    &[
                        (0, Resource::Buffer(out.counter())),
                        (1, Resource::Buffer(out.rays())),
                        (2, Resource::Buffer(inq.counter())),
                        (3, Resource::Buffer(inq.rays())),
                    ],
                )
            };
            let first = pipeline("append_first")?;
            let first_sets = vec![
                first.bind_group(0, &first_frame)?,
                first.bind_group(1, &[])?,
                first_queue(&first, &queues[0])?,
                first.bind_group(3, &scene.resources()[..3])?,
            ];
            let next = pipeline("append_next")?;
            let next_frame = vec![
                next.bind_group(0, &next_frame_bindings)?,
                next.bind_group(1, &[])?,
                next.bind_group(3, &scene.resources()[..3])?,
            ];
            let next_queues = [
                queue_group(&next, &queues[0], &queues[1])?,
                queue_group(&next, &queues[1], &queues[0])?,
            ];
            let sets_of = |t: &BvhTracer| -> VkResult<[BindGroup; 2]> {
                Ok([t.queue_set(&queues[0])?, t.queue_set(&queues[1])?])
            };
            let (tracer, trace_sets) = match shared {
                Some(t) => (None, sets_of(t)?),
                None => {
                    let t = BvhTracer::new(ctx, data, scene, records, &queues[0], t_hi)?;
                    let sets = sets_of(&t)?;
                    (Some(t), sets)
                }
            };
            Some(Rounds {
                queues,
                first,
                first_sets,
                next,
                next_frame,
                next_queues,
                tracer,
                trace_sets,
            })
        } else {
            None
        };
        Ok(BouncePasses {
            bounces,
            groups: pixel_groups(width, height),
            own,
            rounds,
        })
    }

    /// Rebuilds the rounds' own BVH (where the frame had none to share) over `data`, the
    /// scene's geometry moved, and uploads it with the ray length `t_hi`
    /// ([`BvhTracer::update`]); a shared tracer is its owner's to update.
    pub fn update(&mut self, ctx: &GpuContext, data: &GpuSceneData, t_hi: f32) -> VkResult<()> {
        match self.rounds.as_mut().and_then(|r| r.tracer.as_mut()) {
            Some(t) => t.update(ctx, &super::bvh::BvhData::build(data), t_hi),
            None => Ok(()),
        }
    }

    /// The reflections per path.
    pub fn bounces(&self) -> u32 {
        self.bounces
    }

    /// N = 0: records every mirror pixel's own material (instead of the method's passes).
    pub fn record_own_material(&self, rec: &Recorder<'_>) {
        if let Some((p, sets)) = &self.own {
            rec.memory_barrier(ALL, ALL);
            p.dispatch(rec, &[&sets[0]], self.groups);
        }
    }

    /// N ≥ 2: rounds 2..=N (after the method's passes, and the fallback's, have written the
    /// records). `shared` is the frame's BVH tracer, the one given to [`BouncePasses::new`].
    pub fn record_rounds(&self, rec: &Recorder<'_>, shared: Option<&BvhTracer>) -> VkResult<()> {
        let Some(r) = &self.rounds else {
            return Ok(());
        };
        let tracer = match (&r.tracer, shared) {
            (Some(t), _) | (None, Some(t)) => t,
            (None, None) => {
                return Err(crate::vk::backend::error::VkError::Usage {
                    what: "bounce rounds".into(),
                    detail: "no BVH tracer".into(),
                });
            }
        };
        for round in 2..=self.bounces {
            // Round k traces queue (k - 2) % 2, filled from round k - 1's records.
            let out = ((round - 2) % 2) as usize;
            let queue = &r.queues[out];
            // The queue's counter and rays were read by round k - 2's passes.
            rec.memory_barrier(ALL, ALL);
            queue.record_clear(rec);
            if round == 2 {
                let sets: Vec<&BindGroup> = r.first_sets.iter().collect();
                r.first.dispatch(rec, &sets, self.groups);
            } else {
                let inq = &r.queues[1 - out];
                let sets = [
                    &r.next_frame[0],
                    &r.next_frame[1],
                    &r.next_queues[out],
                    &r.next_frame[2],
                ];
                rec.memory_barrier(ALL, ALL);
                r.next.dispatch_indirect(rec, &sets, inq.dispatch(), 0)?;
            }
            queue.record_args(rec);
            tracer.record_trace_with(rec, queue, &r.trace_sets[out])?;
        }
        Ok(())
    }

    /// The queue of the last round's rays (tests: what it traced), N ≥ 2.
    pub fn last_queue(&self) -> Option<&BvhQueue> {
        let r = self.rounds.as_ref()?;
        Some(&r.queues[((self.bounces - 2) % 2) as usize])
    }
}

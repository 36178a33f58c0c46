//! `--bounces N` on the GPU: the reflections after the method's first, as a wavefront of rays,
//! traced by the method itself where it can (`compute`: the cube maps, then the reflector check
//! and the exact fallback over the same rays) and by the BVH kernel ([`super::bvh`]) otherwise,
//! so that a path reflects as the CPU reference's `finish_path` does, bounce for bounce.
//!
//! | N | passes (after the method's, and the trace fallback if any) |
//! |---|---|
//! | 0 | `bounce_append` (`own_material`) instead of the method's: no ray is traced, every mirror pixel shows its own material (the G-buffer's colour), `bounces` = 0 |
//! | 1 | none: the method's records are final, `bounces` = 1 |
//! | ≥ 2 | round 2: `bounce_append` (`append_first`, per pixel), `args`, the round's trace; round k ≥ 3: `bounce_append` (`append_next`, per ray of round k - 1, indirect), `args`, the round's trace |
//!
//! The round's trace: `bvh_trace` over the queue; or, where the method traces the rounds
//! (`Technique::traces_rounds`: `compute`), the queue copied into the method's own
//! (`ComputePath::record_round`: the layouts agree field for field), `dispatch_args` and
//! `compute_trace`, then the reflector check (`append_check_queued`, `bvh_trace` over the
//! reflectors' BVH) and the fallback (`append_unresolved_queued`, `bvh_trace`) over the same
//! rays, as after the method's own round.
//!
//! The rule, per round k = 2..=N (all recorded in the frame's one command buffer; the CPU knows
//! N, the GPU the ray counts):
//! - A record of round k - 1 that is a hit on a reflector triangle appends the next reflected
//!   ray to round k's queue (an atomic counter): from the record's point, along
//!   `normalize(reflect(d, n))`, `n` the normalised interpolated vertex normal of the hit
//!   triangle at the hit (the reference's `Tracer::normal` and `reflect`), leaving that triangle
//!   under the start rule (the reference's `Tracer::nearest` with `from`), from t = 0. Escaped,
//!   unresolved and non-reflector records are final.
//! - Round k's rays are traced over indirect dispatches sized on the GPU. The record of the
//!   pixel is overwritten with the new hit, so a record holds the final hit of the pixel's path,
//!   and `bounces` = k (the ray's `bounce` + 1). The pixel's `fallback` and `checked` flags stay
//!   set once a round set them, and the compute path adds a round's counters to the pixel's.
//! - With the cube maps, a later ray starts on a reflector, where no CMO centre need be: where
//!   the CMOs do not see what it meets, it is the fallback's, so the image is the BVH rounds'
//!   up to the criterion's own error (with `--criterion bounded`, none: the facing mirrors at
//!   N = 3 equal the reference, every later ray decided by a CMO). The placement search samples
//!   the later rays too (`crate::placement`).
//! - After round N, a hit on a reflector keeps the colour shaded there, the reflector's own
//!   material: the reference's rule after the last bounce.
//!
//! A round-1 hit needs its triangle for the next ray: `compute`, `fragment` with the exact
//! criterion (verified hits) and `bvh` name it; the other methods (and `fragment` with another
//! criterion) take `bounces` = 1 only. `fragment` draws its rays from the G-buffer, one per
//! pixel, so its later rounds are the BVH's. Two queues (each one ray per pixel at most)
//! alternate between the rounds; they are allocated only for N ≥ 2, and the BVH only where the
//! BVH traces the rounds (shared with the frame's own BVH passes when it has them: `bvh`,
//! `--fallback trace`).
//!
//! Invariants:
//! - A record keeps the final hit of its pixel's path and its `bounces` count (the EXR channel).
//! - N = 0 traces nothing: mirror pixels show their own material (the G-buffer's colour).
//! - Methods whose records name no triangle (`envmap`, `ssr`, `reflection-point`, and the
//!   approximate criteria) refuse N != 1 (`Method::check_bounces`).
//!
//! Checked against the reference per mirror pixel: the same final triangle, and there the colour
//! within 1e-3 and the same bounce count. `bvh` on the bowl seen from above its rim (N = 3, 1235 of
//! 2465 paths reflect 2 or 3 times at 64x48): 2465 of 2465; two facing flat mirrors (N = 1, 2, 5):
//! 2772 of 2772 each; N = 0: all but the silhouette's 4 of 698. The cubemap paths lose nothing to
//! the bounces beyond their own first round (bowl: same triangle 91.6 % at N = 3, 90.1 % at N = 1,
//! self-capture on). The compute path's later rounds from the cube maps
//! (`compute_traces_the_bounce_rounds_with_the_cube_maps`, facing mirrors, N = 3, three CMOs):
//! 922 of 1620 later rays decided by a CMO with the centre criterion (the first round: 71.5 %),
//! every one of 1615 with the bounded criterion, whose frame equals the reference's. Negative:
//! each frame against the reference of another N, and the second mirror's normals turned by 0.5
//! degrees, fail; `bvh` decides no ray with a CMO. At 320x240 (`render --compare`, lavapipe):
//! teapot N = 3, `bvh`, `compute` and `fragment` 53.2 dB over mirror pixels; bowl N = 3 103.6 dB.
use ash::vk;

use super::bvh::{BvhPasses, BvhQueue, BvhTracer, QueuedAppend, pixel_groups};
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
    /// The tracer when the frame has none to share (and the method does not trace the rounds).
    tracer: Option<BvhTracer>,
    /// `bvh_trace`'s queue group (set 2) for each queue (none where the method traces them).
    trace_sets: Option<[BindGroup; 2]>,
    /// Where the method traces the rounds (`Technique::traces_rounds`): the reflector check's
    /// and the fallback's appends over each round's queue, where the frame has them.
    method: Option<MethodRounds>,
    /// Per round k (index k - 2), two words: the rays queued, and of those the ones the fallback
    /// traced where the method traces the rounds ([`RoundCount`]); copied from the queues'
    /// counters.
    counts: Buffer,
}

/// What one round of `--bounces` traced ([`BouncePasses::read_counts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RoundCount {
    /// Rays queued (paths still reflecting).
    pub rays: u32,
    /// Whether the method traced them (its cube maps), else the BVH.
    pub method: bool,
    /// Of those, the ones the fallback traced (0 where the BVH traced all).
    pub fallback: u32,
}

/// A method's trace of a round's queue (`Technique::record_round`).
pub type RoundTrace<'a> = dyn Fn(&Recorder<'_>, &BvhQueue) -> VkResult<()> + 'a;

/// The passes after a method's trace of a round: [`QueuedAppend`]s into the reflector check's
/// and the fallback's queues, reading either round queue.
struct MethodRounds {
    check: Option<QueuedAppend>,
    fallback: Option<QueuedAppend>,
}

/// The frame's passes a bounce round may use besides its own: the method's BVH tracer to
/// share, or the method itself where it traces the rounds, and the reflector check and the
/// fallback that follow it.
#[derive(Clone, Copy)]
pub struct RoundPasses<'a> {
    pub shared: Option<&'a BvhTracer>,
    /// The method traces the rounds (`Technique::traces_rounds`).
    pub method: bool,
    pub check: Option<&'a BvhPasses>,
    pub fallback: Option<&'a BvhPasses>,
}

impl BouncePasses {
    /// The passes for `bounces` reflections over the frame's G-buffer, `FrameParams` buffer
    /// `params` and `records`; `frame.shared` is the frame's own BVH tracer, if it has one (else,
    /// for N ≥ 2, the BVH is built here over `data`, unless the method traces the rounds).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        bounces: u32,
        data: &GpuSceneData,
        scene: &SceneBuffers,
        gbuffer: &Gbuffer,
        params: &Buffer,
        records: &Buffer,
        frame: RoundPasses<'_>,
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
            let counts = Buffer::new(
                ctx.device(),
                "bounce round counts",
                u64::from(MAX_BOUNCES) * 8,
                vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC,
                gpu_allocator::MemoryLocation::GpuOnly,
            )?;
            let (tracer, trace_sets, method) =
                round_tracer(ctx, &queues, data, scene, records, frame, t_hi)?;
            Some(Rounds {
                queues,
                first,
                first_sets,
                next,
                next_frame,
                next_queues,
                tracer,
                trace_sets,
                method,
                counts,
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
    /// records). `frame` as given to [`BouncePasses::new`]; `method` records the method's trace
    /// of a round's queue where `frame.method` said so, the BVH tracer traces it otherwise.
    pub fn record_rounds(
        &self,
        rec: &Recorder<'_>,
        frame: RoundPasses<'_>,
        method: &RoundTrace<'_>,
    ) -> VkResult<()> {
        let Some(r) = &self.rounds else {
            return Ok(());
        };
        rec.fill_buffer(&r.counts, 0);
        // Where round k's counts go: its rays, then its fallback rays.
        let count_at =
            |round: u32, fallback: bool| u64::from(round - 2) * 8 + if fallback { 4 } else { 0 };
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
            rec.memory_barrier(ALL, ALL);
            rec.copy_buffer_to(queue.counter(), &r.counts, count_at(round, false), 4);
            match (&r.method, &r.trace_sets) {
                (Some(m), _) => {
                    Self::record_method_round(rec, m, frame, method, out, queue)?;
                    if let Some(f) = frame.fallback.filter(|_| m.fallback.is_some()) {
                        rec.memory_barrier(ALL, ALL);
                        rec.copy_buffer_to(f.queue.counter(), &r.counts, count_at(round, true), 4);
                    }
                }
                (None, Some(sets)) => {
                    let tracer = match (&r.tracer, frame.shared) {
                        (Some(t), _) | (None, Some(t)) => t,
                        (None, None) => return Err(no_tracer()),
                    };
                    tracer.record_trace_with(rec, queue, &sets[out])?;
                }
                (None, None) => return Err(no_tracer()),
            }
        }
        Ok(())
    }

    /// A round the method traces: its trace of `queue` (round queue `k`), then the reflector
    /// check and the fallback over the same rays, in the order of the method's own round.
    fn record_method_round(
        rec: &Recorder<'_>,
        m: &MethodRounds,
        frame: RoundPasses<'_>,
        method: &RoundTrace<'_>,
        k: usize,
        queue: &BvhQueue,
    ) -> VkResult<()> {
        method(rec, queue)?;
        for (append, passes) in [(&m.check, frame.check), (&m.fallback, frame.fallback)] {
            if let (Some(a), Some(p)) = (append, passes) {
                rec.memory_barrier(ALL, ALL);
                p.queue.record_clear(rec);
                a.record(rec, k, queue)?;
                p.queue.record_args(rec);
                p.record_trace(rec)?;
            }
        }
        Ok(())
    }

    /// What each round 2..=N traced in the last frame (empty for N < 2).
    pub fn read_counts(&self, ctx: &GpuContext) -> VkResult<Vec<RoundCount>> {
        let Some(r) = &self.rounds else {
            return Ok(Vec::new());
        };
        let counts: Vec<[u32; 2]> = ctx.read_buffer(&r.counts)?;
        Ok((counts.iter().take(self.bounces as usize - 1))
            .map(|&[rays, fallback]| RoundCount {
                rays,
                method: r.method.is_some(),
                fallback,
            })
            .collect())
    }

    /// The queue of the last round's rays (tests: what it traced), N ≥ 2.
    pub fn last_queue(&self) -> Option<&BvhQueue> {
        let r = self.rounds.as_ref()?;
        Some(&r.queues[((self.bounces - 2) % 2) as usize])
    }
}

/// What traces the rounds over `queues`: the method, with the reflector check's and the
/// fallback's appends (`frame.method`); else the frame's BVH tracer (`frame.shared`) or one built
/// here over `data`, with its queue groups.
#[allow(clippy::type_complexity)]
fn round_tracer(
    ctx: &GpuContext,
    queues: &[BvhQueue; 2],
    data: &GpuSceneData,
    scene: &SceneBuffers,
    records: &Buffer,
    frame: RoundPasses<'_>,
    t_hi: f32,
) -> VkResult<(
    Option<BvhTracer>,
    Option<[BindGroup; 2]>,
    Option<MethodRounds>,
)> {
    if frame.method {
        let ins = [&queues[0], &queues[1]];
        let append = |p: Option<&BvhPasses>, check: bool| {
            p.map(|p| QueuedAppend::new(ctx, check, records, &p.queue, &ins))
                .transpose()
        };
        let method = MethodRounds {
            check: append(frame.check, true)?,
            fallback: append(frame.fallback, false)?,
        };
        return Ok((None, None, Some(method)));
    }
    let sets_of = |t: &BvhTracer| -> VkResult<[BindGroup; 2]> {
        Ok([t.queue_set(&queues[0])?, t.queue_set(&queues[1])?])
    };
    Ok(match frame.shared {
        Some(t) => (None, Some(sets_of(t)?), None),
        None => {
            let t = BvhTracer::new(ctx, data, scene, records, &queues[0], t_hi)?;
            let sets = sets_of(&t)?;
            (Some(t), Some(sets), None)
        }
    })
}

fn no_tracer() -> crate::vk::backend::error::VkError {
    crate::vk::backend::error::VkError::Usage {
        what: "bounce rounds".into(),
        detail: "no BVH tracer".into(),
    }
}

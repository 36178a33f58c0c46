//! The compute path (thesis alg. 3, `--method compute`): four passes between the G-buffer and
//! the composite pass of a frame.
//!
//! | pass | reads | writes |
//! |---|---|---|
//! | `hier32` | CMO distance | `cmo_hier`: the 8x4/4x8 `[min, max]` hierarchy ([`crate::vk::passes::hier32`]) |
//! | `append` | G-buffer | ray queue + its atomic count (a fragment pass, one ray per mirror pixel) |
//! | `dispatch_args` | ray count, hierarchy | `VkDispatchIndirectCommand` (no CPU round trip), the CMOs' cut radii |
//! | `compute_trace` | queue, CMO data, `cmo_hier` | one [`PixelRecord`](crate::vk::frame::PixelRecord) per queued ray, per-ray counters |
//!
//! Invariants:
//! - The queued ray of a mirror pixel is `mirror_ray`'s (spirv/shared/mirror.wgsl), the ray the
//!   fragment path traces, so both paths trace bit-identical rays.
//! - `compute_trace` writes `records[pixel]` for exactly the queued pixels, i.e. the mirror pixels
//!   (`position.w == 1`, the composite pass's own test), and `ray_stats[pixel]` likewise.
//! - The surface model and the classification are the fragment path's centre criterion
//!   (`classify` in spirv/shared/trace.wgsl), or with `--criterion bounded` its bounded one
//!   (`classify_bounded_pick` in spirv/shared/trace_bounded.wgsl, through the `_bounded` twin of
//!   each entry point, [`bounded_entry`]; the queued ray carries its G-buffer triangle for the
//!   start rule), so [`GpuRenderer`](crate::vk::frame::GpuRenderer) refuses the approximate
//!   criteria for this method.
//! - Subgroup sizes 4..=128 (powers of two) are supported; the kernel's docs say how lanes map
//!   to rays and why no workgroup barrier is needed (there is none). Its workgroups have 256
//!   invocations, or 128 where 256 would exceed `maxComputeWorkgroupSubgroups`
//!   ([`workgroup_size`]).
//! - One `compute_trace` pipeline per renderer: with `main_lanes1`, its two dispatches (the
//!   1-lane layout, then the retrace of the rays it cut) differ in `hier_config.mode` only.
//! - The ray counter is zeroed (`vkCmdFillBuffer`) before `append` in every frame. One fragment
//!   per pixel (no multisampling), so the queue holds at most `width * height` rays.
//! - The dispatch is sized for the device's default subgroup size ([`DispatchParams`]); the
//!   kernel strides over the queue with the rays per workgroup it really has, so a device that
//!   picks another size still traces every ray.
//!
//! # How it works
//!
//! Cubemap tracing in a compute pass (thesis alg. 3), the default method. `append` (a full-screen
//! fragment pass) queues every mirror pixel's reflected ray through an atomic counter,
//! `dispatch_args` turns the count into an indirect dispatch on the GPU (zero rays: an empty
//! dispatch) and computes each CMO's near-centre cut radius once per frame, and `compute_trace`
//! walks the alternating 8x4/4x8 `[min, max]` hierarchy (`hier32`) depth first. It reuses the shared
//! tracer's `split_near_centre`, `faces_crossed`, `cell_interval`, `inflated`, `r_bounds` and
//! `classify`, so its decisions are the fragment method's on every pixel (tested: status, CMO,
//! texel and riser flag); its CPU twin is `cpu::compute`, equal bit for bit, counters included.
//!
//! Lanes. In the thesis layout (`main`) a ray owns `L = min(S, 32)` lanes of a subgroup of size S,
//! each testing `32 / L` children, the mask assembled from ballots; `S / L` rays share a subgroup.
//! `main_lanes1` gives each lane a whole ray (its 32 logical lanes in rounds, tested locally, and
//! only on the children whose frustum interval passes, `children_crossed`). `main_wave` also
//! gives each lane a whole ray, but the crossed children of all the subgroup's rays are tested
//! by whichever lanes are free: ceil(sum / S) rounds where `main_lanes1` takes as many as its
//! busiest lane needs. The renderer picks `main_lanes1` on CPU devices and `main_wave` elsewhere
//! ([`ray_lanes`]; `RenderOptions::compute_layout`, else `CUBETRACE_RAY_LANES`, overrides it): on
//! lavapipe every lane of a ray repeats the per-ray work and per-lane-indexed data is read lane
//! by lane, so the thesis layout cost 59.4 ms against 16.2 ms at S = 8 (sphere-room, 160x120).
//!
//! Invariants:
//! - No workgroup barrier: a ray's lanes are one subgroup's and exchange data only by ballots and
//!   xor shuffles, reached only in subgroup-uniform control flow (loops ending on `subgroupAny` or
//!   on a count derived from S; a finished ray runs them with empty ballots). A barrier inside the
//!   per-ray loops would be undefined behaviour that neither naga nor lavapipe catches.
//! - Workgroups of 256 invocations, or 128 where 256 would exceed `maxComputeWorkgroupSubgroups`
//!   (lavapipe at S = 4). The kernel assumes full subgroups.
//! - lavapipe ends every loop of an invocation after 65535 back-edges in all. A ray whose step loop
//!   ended before the ray did is flagged `cut` and its queue index appended to the cut queue;
//!   after a `main_lanes1` (or `main_wave`) dispatch, `retrace_size` sizes the retrace from the
//!   queue's length and the same pipeline runs again in mode 1 (`HierConfig::mode`), the thesis
//!   layout over the cut rays only, from scratch, so both layouts give the same records (the
//!   1e-3..1e5 span scene: 1004 of 2570 rays were cut by an earlier kernel; none by this one on
//!   any scene of the suite, so a test cuts them with [`STEP_CAP_ENV`]). The retrace used to cover every queued
//!   ray, reading its `cut` flag, and lavapipe ran the kernel's body once per subgroup for
//!   nothing: half of the pass's time on `default`.
//! - One call site per large function (`settle` holds the handoff with hit verification, the trace
//!   set-up and `enter_face`): lavapipe inlines every call, and pipeline creation grows with it
//!   (4.8-5.8 s before, 0.2-0.35 s after).
//!
//! Tested on lavapipe at S = 4, 8 and 16 (`LP_NATIVE_VECTOR_WIDTH` 128, 256, 512; at 128 with
//! `GALLIUM_OVERRIDE_CPU_CAPS=sse4.1`, which avoids a heap corruption of lavapipe's own on AVX2 CPUs),
//! the three layouts writing identical images; S = 32 and 64 only through the twin's emulated
//! ballots (the thesis layout) or not at all (the wave layout: no GPU has run it).
//!
//! Measured (lavapipe, 2 cores, 320x240, `bench --defaults-only`, medians of 5 frames; the
//! rows in `benches/results/lavapipe-shaders.md`): 1826 to 2820 ns per mirror ray on `default`,
//! `teapot` and `truck-garage`, 2.0 times the fragment method and 3.8 to 5.7 times `bvh`; 80 to 92
//! cells and 38 to 42 texels per ray against the fragment path's 14 and 2. Per subgroup of 8 rays
//! the outer loop (`settle`) turns 4 to 5 times and the step loop 8 to 13 times, and a CPU
//! driver runs every turn's whole body for all 8 rays. Lanes that take the next ray as soon as
//! theirs is done (persistent lanes) did not pay there, tried twice (`lavapipe-shaders.md`,
//! "What was tried and rejected"). Before the retrace was sized from its queue, the pass cost
//! 2.2 to 2.7 times as much, and the widths lavapipe offers were measured with that: compute /
//! fragment 2.7 to 2.9 at S = 4, 3.9 to 4.6 at 8, 5.7 to 7.3 at 16.

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use crate::vk::backend::buffer::Buffer;
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::{VkError, VkResult};
use crate::vk::backend::graphics::{GraphicsDesc, GraphicsPipeline, RenderTarget};
use crate::vk::backend::info::DeviceReport;
use crate::vk::backend::pipeline::{BindGroup, ComputeOptions, ComputePipeline, Resource};
use crate::vk::backend::shaders::{APPEND, COMPUTE_TRACE, DISPATCH_ARGS, HIER32, Pass};
use crate::vk::backend::sync::{
    ALL, INDIRECT_READ, SHADER_READ, SHADER_WRITE, STORAGE_RW, TRANSFER_WRITE,
};
use crate::vk::options::ComputeLayout;
use crate::vk::passes::bvh::BvhQueue;
use crate::vk::passes::cmo::{CaptureContents, CmoData, TraceConfig};
use crate::vk::passes::hier32::{Hier32Bindings, Hier32Pass};
use crate::vk::passes::scene_buffers::SceneBuffers;

pub use super::technique::ComputeStats;
use super::technique::{FrameInputs, Glossy, MethodSpec, MethodStats, Needs, Scope, Technique};

use crate::cpu::options::TraceOptions;
use crate::cubemap::pyramid::{
    HIER_MAX_LEVELS, hier32_flat_layout, hier32_group, hier32_layout, hier32_len,
};

/// WGSL `AppendedRay` (spirv/shared/compute_rays.wgsl): one queued mirror ray. Its fields lie
/// where a BVH queue's `BvhRay` has them (`t_min` unused here, `flags` a pad), so that a round of
/// `--bounces` copies its BVH queue into this one and the cubemap trace reads it as it is
/// (`vk::passes::bounce`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AppendedRay {
    pub origin: [f32; 3],
    /// `j * width + i`.
    pub pixel: u32,
    pub dir: [f32; 3],
    /// `BvhRay::t_min`'s place: 0, the trace starts at the origin.
    pub t_min: f32,
    /// The global triangle the ray leaves (the G-buffer's ID for a camera's reflected ray, the
    /// hit it reflects at for a later one; `u32::MAX` for none): the start rule.
    pub from_triangle: u32,
    /// Reflections taken before this ray: 0 for the camera's reflected rays, k - 1 in round k
    /// of `--bounces` (the record's `bounces` is this + 1).
    pub bounce: u32,
    pub pad0: u32,
    pub pad1: u32,
}

/// WGSL `RayCounter`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct RayCounter {
    /// Rays appended.
    pub count: u32,
    /// Largest subgroup size `compute_trace` ran with.
    pub subgroup_max: u32,
    /// `!min` subgroup size.
    pub subgroup_min_not: u32,
    /// Rays traced in the frame, the rounds of `--bounces` included.
    pub traced: u32,
    /// Rays of the last dispatch that the driver's loop limit cut (the retrace's queue length).
    pub cut: u32,
}

/// WGSL `DispatchArgs` (= `VkDispatchIndirectCommand`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct DispatchArgs {
    pub x: u32,
    pub y: u32,
    pub z: u32,
}

/// WGSL `DispatchParams` of `dispatch_args`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct DispatchParams {
    /// Rays per `compute_trace` workgroup at the device's subgroup size: `256 / min(S, 32)`.
    pub rays_per_group: u32,
    /// Number of CMOs K whose cut radii `dispatch_args` computes (0: none).
    pub cmo_count: u32,
    /// Face size N of the CMOs.
    pub size: u32,
    /// Rays per retrace workgroup (`main_lanes1` in mode 1: `256 / min(S, 32)`) with
    /// `lane_cap` 1; 0 otherwise (no retrace dispatch).
    pub retrace_rays_per_group: u32,
}

/// Environment variable that sets [`ray_lanes`]'s layout where the render options leave it:
/// `32` (the thesis layout, entry `main`), `1` (entry `main_lanes1`) or `wave` (entry
/// `main_wave`: one ray per lane, the rays' child tests spread over the subgroup's lanes).
/// Anything else is refused.
pub const RAY_LANES_ENV: &str = "CUBETRACE_RAY_LANES";

/// Environment variable that caps the step loop of `compute_trace`'s first dispatch (with
/// `main_lanes1` or `main_wave`) at that many steps, as the driver's loop limit would cut it, so
/// that the retrace runs: a test hook (no scene of the suite has a ray that lavapipe's loop
/// limit cuts). Unset: `MAX_STEPS`.
pub const STEP_CAP_ENV: &str = "CUBETRACE_STEP_CAP";

/// WGSL `MAX_STEPS` of `compute_trace`: the step loop's cap.
const MAX_STEPS: u32 = 0x8000_0000;

/// The first dispatch's step cap ([`STEP_CAP_ENV`]).
fn step_cap() -> VkResult<u32> {
    match std::env::var(STEP_CAP_ENV) {
        Ok(v) => match v.trim().parse::<u32>() {
            Ok(n) if n >= 1 => Ok(n.min(MAX_STEPS)),
            _ => Err(VkError::Usage {
                what: STEP_CAP_ENV.into(),
                detail: format!("`{v}`: expected a whole number of steps, at least 1"),
            }),
        },
        Err(_) => Ok(MAX_STEPS),
    }
}

/// The most lanes `compute_trace` gives one ray, and the entry point that does it, for
/// `requested` (the render options' layout), else [`RAY_LANES_ENV`], else the device's default:
/// [`ComputeLayout::OneLane`] (`main_lanes1`: S rays per subgroup, each lane running its ray's
/// children in rounds) on CPU devices, where every lane repeats the ray's per-ray work and
/// shuffles cost a lane's work each, so that this layout measured fastest
/// (`benches/results/lavapipe-shaders.md`, "What was kept"; `main_wave` took 1.5-2x its time);
/// [`ComputeLayout::Wave`] (`main_wave`) elsewhere, which the cost model puts at a quarter of the
/// thesis layout's work per ray at width 32 (`benches/results/lavapipe-model-dynamic.md`).
/// With one lane per ray the frame dispatches the same pipeline a second time in mode 1
/// ([`HierConfig::mode`]), which retraces with the thesis layout the rays whose step loop the
/// driver's loop limit cut (lavapipe: 65535 loop iterations per invocation; spirv/README.md,
/// "Known defect"), so every layout gives the same records. Where [`workgroup_size`] is 128, the
/// `_wg128` twin of the entry point.
pub fn ray_lanes(
    ctx: &GpuContext,
    requested: Option<ComputeLayout>,
) -> VkResult<(u32, &'static str)> {
    let layout = match (requested, std::env::var(RAY_LANES_ENV)) {
        (Some(layout), _) => layout,
        (None, Ok(v)) => match v.trim() {
            "32" => ComputeLayout::Thesis,
            "1" => ComputeLayout::OneLane,
            "wave" => ComputeLayout::Wave,
            other => {
                return Err(VkError::Usage {
                    what: RAY_LANES_ENV.into(),
                    detail: format!("`{other}`: expected 32, 1 or wave"),
                });
            }
        },
        (None, Err(_)) if ctx.report().device_type == vk::PhysicalDeviceType::CPU => {
            ComputeLayout::OneLane
        }
        (None, Err(_)) => ComputeLayout::Wave,
    };
    let small = workgroup_size(ctx.report()) == 128;
    Ok(match (layout, small) {
        (ComputeLayout::OneLane, false) => (1, "main_lanes1"),
        (ComputeLayout::OneLane, true) => (1, "main_lanes1_wg128"),
        (ComputeLayout::Wave, false) => (1, "main_wave"),
        (ComputeLayout::Wave, true) => (1, "main_wave_wg128"),
        (ComputeLayout::Thesis, false) => (32, "main"),
        (ComputeLayout::Thesis, true) => (32, "main_wg128"),
    })
}

/// The `bounded` criterion's twin of a `compute_trace` entry point of [`ray_lanes`] (the same
/// kernel classifying with the candidate lists: spirv/shared/trace_bounded.wgsl).
pub fn bounded_entry(entry: &'static str) -> &'static str {
    match entry {
        "main" => "main_bounded",
        "main_lanes1" => "main_lanes1_bounded",
        "main_wg128" => "main_wg128_bounded",
        "main_lanes1_wg128" => "main_lanes1_wg128_bounded",
        "main_wave" => "main_wave_bounded",
        "main_wave_wg128" => "main_wave_wg128_bounded",
        other => other,
    }
}

/// `compute_trace`'s workgroup size on a device: 256, or 128 where 256 invocations would be more
/// subgroups than `maxComputeWorkgroupSubgroups` allows (lavapipe at subgroup size 4: 64 against
/// 32). Not the cause of lavapipe's abort on the span scene at that size (spirv/README.md,
/// "Known defect").
pub fn workgroup_size(report: &DeviceReport) -> u32 {
    let subgroups = 256 / report.subgroup_size.max(1);
    match report.max_compute_workgroup_subgroups {
        Some(max) if subgroups > max => 128,
        _ => 256,
    }
}

impl DispatchParams {
    /// For a device whose compute shaders run with subgroups of `subgroup_size` lanes and the
    /// thesis layout (entry `main`; the kernel is correct with any value, this one launches no
    /// idle workgroup on that device).
    pub fn for_subgroup_size(subgroup_size: u32) -> Self {
        Self::for_lanes(subgroup_size, 32)
    }

    /// For subgroups of `subgroup_size` lanes and at most `lane_cap` lanes per ray
    /// ([`ray_lanes`]): `256 / min(S, 32, lane_cap)` rays per workgroup.
    pub fn for_lanes(subgroup_size: u32, lane_cap: u32) -> Self {
        Self::for_group(256, subgroup_size, lane_cap)
    }

    /// [`DispatchParams::for_lanes`] with workgroups of `group_size` invocations
    /// ([`workgroup_size`]): `group_size / min(S, 32, lane_cap)` rays per workgroup.
    pub fn for_group(group_size: u32, subgroup_size: u32, lane_cap: u32) -> Self {
        DispatchParams {
            rays_per_group: group_size / subgroup_size.clamp(4, 32).min(lane_cap.max(1)),
            retrace_rays_per_group: if lane_cap == 1 {
                group_size / subgroup_size.clamp(4, 32)
            } else {
                0
            },
            ..DispatchParams::default()
        }
    }

    /// With the cut radii of `cmo_count` CMOs of face size `size` to compute.
    pub fn with_cmos(self, cmo_count: u32, size: u32) -> Self {
        DispatchParams {
            cmo_count,
            size,
            ..self
        }
    }
}

/// WGSL `HierConfig` of `compute_trace`: the [`Hier32`](crate::cubemap::pyramid::Hier32)
/// layout for face size N.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct HierConfig {
    /// Root level index (0 when the texels are the root).
    pub root: u32,
    /// `hier32_len(N)`.
    pub hier_len: u32,
    /// `compute_trace`'s mode, read by `main_lanes1` and `main_wave`: 0 their first dispatch, 1
    /// the retrace (each binds its own copy, `ComputeBuffers::hier_configs`).
    pub mode: u32,
    /// The first dispatch's step loop cap (`step_cap`).
    pub step_cap: u32,
    /// Level l: `(offset in cells (l >= 1), width, height, 0)`.
    pub dims: [[u32; 4]; HIER_MAX_LEVELS],
    /// Level l: `(gx, gy, span x, span y)`.
    pub shape: [[u32; 4]; HIER_MAX_LEVELS],
}

impl HierConfig {
    /// The layout for face size `size`; fails where the hierarchy has more than
    /// [`HIER_MAX_LEVELS`] levels (N above 4096 is refused by `TraceConfig` anyway).
    pub fn new(size: u32) -> VkResult<Self> {
        let dims = hier32_layout(size);
        if dims.len() > HIER_MAX_LEVELS {
            return Err(VkError::Usage {
                what: COMPUTE_TRACE.name.into(),
                detail: format!("face size {size} needs {} hierarchy levels", dims.len()),
            });
        }
        let flat = hier32_flat_layout(size);
        let mut c = HierConfig {
            root: (dims.len() - 1) as u32,
            hier_len: hier32_len(size) as u32,
            mode: 0,
            step_cap: MAX_STEPS,
            ..HierConfig::default()
        };
        let mut span = (1u32, 1u32);
        for (l, &(w, h)) in dims.iter().enumerate() {
            let offset = if l == 0 { 0 } else { flat[l - 1].offset };
            let group = if l == 0 { (1, 1) } else { hier32_group(l) };
            span = (span.0 * group.0, span.1 * group.1);
            c.dims[l] = [offset, w, h, 0];
            c.shape[l] = [group.0, group.1, span.0, span.1];
        }
        Ok(c)
    }
}

/// Subgroup sizes the kernel supports.
pub const SUBGROUP_SIZES: std::ops::RangeInclusive<u32> = 4..=128;

/// Checks that the device can run the compute path: subgroup ballot, vote and shuffle in compute
/// shaders, and a supported subgroup size.
pub fn check_device(ctx: &GpuContext) -> VkResult<()> {
    let r = ctx.report();
    let need = vk::SubgroupFeatureFlags::BASIC
        | vk::SubgroupFeatureFlags::VOTE
        | vk::SubgroupFeatureFlags::BALLOT
        | vk::SubgroupFeatureFlags::SHUFFLE;
    let problem = if !r.subgroup_stages.contains(vk::ShaderStageFlags::COMPUTE) {
        Some("no subgroup operations in compute shaders".to_string())
    } else if !r.subgroup_ops.contains(need) {
        Some(format!(
            "subgroup operations {:?}, need basic, vote, ballot and shuffle",
            r.subgroup_ops
        ))
    } else if !SUBGROUP_SIZES.contains(&r.subgroup_size) || !r.subgroup_size.is_power_of_two() {
        Some(format!(
            "subgroup size {}, the kernel supports powers of two in {SUBGROUP_SIZES:?}",
            r.subgroup_size
        ))
    } else {
        None
    };
    match problem {
        Some(detail) => Err(VkError::Usage {
            what: format!("{} on {}", COMPUTE_TRACE.name, r.name),
            detail: format!("{detail} (use --method fragment)"),
        }),
        None => Ok(()),
    }
}

/// Whether `cmo` holds the `bounded` criterion's lists (its gaps then get a hierarchy).
fn bounded(cmo: &CmoData) -> bool {
    cmo.config().criterion == TraceConfig::CRITERION_BOUNDED
}

/// The compute path's buffers, each allocated once.
struct ComputeBuffers {
    hier: Buffer,
    /// The `bounded` criterion's gaps over the hierarchy (a packed word per cell,
    /// [`crate::cubemap::bounds::pack_gap`]); a one-word placeholder for the other criteria.
    gap_hier: Buffer,
    /// The hierarchy's layout with the mode of each dispatch of `main_lanes1` and `main_wave`:
    /// mode 0 with [`step_cap`], mode 1 (the retrace) with `MAX_STEPS`. The mode is not a
    /// binding of its own: with the `bounded` criterion's lists the compute stage would read 33
    /// storage buffers, past lavapipe's `maxPerStageDescriptorStorageBuffers` (32).
    hier_configs: [Buffer; 2],
    dispatch_params: Buffer,
    cut: Buffer,
    rays: Buffer,
    counter: Buffer,
    args: Buffer,
    retrace_args: Buffer,
    /// The cut queue (`cut_rays`): a queue index per ray the first dispatch cut, for the
    /// retrace; one word where there is no retrace (the thesis layout).
    cut_rays: Buffer,
    stats: Buffer,
}

impl ComputeBuffers {
    /// For `cmo`'s CMOs and a frame of `pixels` pixels; `lane_cap` as [`ray_lanes`] says.
    fn new(ctx: &GpuContext, cmo: &CmoData, pixels: u64, lane_cap: u32) -> VkResult<Self> {
        let size = cmo.size();
        let config = HierConfig {
            step_cap: step_cap()?,
            ..HierConfig::new(size)?
        };
        let retrace = HierConfig {
            mode: 1,
            ..HierConfig::new(size)?
        };
        let storage = |name: &str, bytes: u64, extra: vk::BufferUsageFlags| {
            Buffer::new(
                ctx.device(),
                name,
                bytes,
                vk::BufferUsageFlags::STORAGE_BUFFER | extra,
                MemoryLocation::GpuOnly,
            )
        };
        let cells = u64::from(cmo.count()) * hier32_len(size) as u64;
        let dispatch = DispatchParams::for_group(
            workgroup_size(ctx.report()),
            ctx.report().subgroup_size,
            lane_cap,
        )
        .with_cmos(cmo.count(), size);
        let transfer_src = vk::BufferUsageFlags::TRANSFER_SRC;
        let indirect = vk::BufferUsageFlags::INDIRECT_BUFFER;
        Ok(ComputeBuffers {
            hier: storage("cmo_hier", cells.max(1) * 8, transfer_src)?,
            gap_hier: storage(
                "cmo_gap_hier",
                if bounded(cmo) { cells.max(1) * 4 } else { 4 },
                transfer_src,
            )?,
            hier_configs: [
                ctx.create_buffer_init(
                    "hier_config",
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                    std::slice::from_ref(&config),
                )?,
                ctx.create_buffer_init(
                    "hier_config (retrace)",
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                    std::slice::from_ref(&retrace),
                )?,
            ],
            rays: storage(
                "ray queue",
                pixels * size_of::<AppendedRay>() as u64,
                // A bounce round copies its queue in (`ComputePath::record_round`).
                vk::BufferUsageFlags::TRANSFER_DST,
            )?,
            counter: storage(
                "ray counter",
                size_of::<RayCounter>() as u64,
                vk::BufferUsageFlags::TRANSFER_DST | transfer_src,
            )?,
            args: storage(
                "compute_trace dispatch",
                size_of::<DispatchArgs>() as u64,
                indirect | transfer_src,
            )?,
            retrace_args: storage(
                "retrace dispatch",
                size_of::<DispatchArgs>() as u64,
                indirect,
            )?,
            cut_rays: storage(
                "cut queue",
                if dispatch.retrace_rays_per_group != 0 {
                    pixels * 4
                } else {
                    4
                },
                vk::BufferUsageFlags::empty(),
            )?,
            stats: storage("ray stats", pixels * 16, transfer_src)?,
            cut: storage("cmo_cut", u64::from(cmo.count()) * 4, transfer_src)?,
            dispatch_params: ctx.create_buffer_init(
                "dispatch params",
                vk::BufferUsageFlags::STORAGE_BUFFER,
                &[dispatch],
            )?,
        })
    }
}

/// The `compute_trace` pipeline through `entry` and its groups: 0 (`params`, `records`), 1 (the
/// CMO data), 2 (the queue and the hierarchy, its config in mode 0), 3
/// (the scene, for verified hits: compute_trace's SCENE_GROUP).
struct TracePass {
    pipeline: ComputePipeline,
    sets: [BindGroup; 4],
    /// With `main_lanes1` and `main_wave`: group 2 of their retrace dispatch (the config in
    /// mode 1; its dispatch: `retrace_args`).
    retrace_set: Option<BindGroup>,
    /// The pipeline's entry point (its CMO group's bindings).
    entry: String,
}

impl TracePass {
    #[allow(clippy::too_many_arguments)]
    fn new(
        ctx: &GpuContext,
        entry: &str,
        lane_cap: u32,
        b: &ComputeBuffers,
        cmo: &CmoData,
        scene: &SceneBuffers,
        params: &Buffer,
        records: &Buffer,
    ) -> VkResult<Self> {
        // One pipeline (a CPU driver compiles it at creation: about 0.25 s on lavapipe); with
        // `main_lanes1` and `main_wave`, their two dispatches differ in `hier_config.mode` only.
        let compile_start = std::time::Instant::now();
        let trace = ComputePipeline::new(ctx, &COMPUTE_TRACE, entry, ComputeOptions::default())?;
        log::info!(
            "{}: pipeline {entry} created in {:.0} ms",
            COMPUTE_TRACE.name,
            compile_start.elapsed().as_secs_f64() * 1e3
        );
        let set2 = |config: &Buffer| {
            trace.bind_group(
                2,
                &[
                    (0, Resource::Buffer(&b.counter)),
                    (1, Resource::Buffer(&b.rays)),
                    (2, Resource::Buffer(config)),
                    (3, Resource::Buffer(&b.hier)),
                    (4, Resource::Buffer(&b.stats)),
                    (5, Resource::Buffer(&b.cut)),
                    (7, Resource::Buffer(&b.gap_hier)),
                    (8, Resource::Buffer(&b.cut_rays)),
                ],
            )
        };
        let sets = [
            trace.bind_group(
                0,
                &[
                    (2, Resource::Buffer(params)),
                    (3, Resource::Buffer(records)),
                ],
            )?,
            trace.bind_group(1, &cmo.resources_for(&COMPUTE_TRACE, entry))?,
            set2(&b.hier_configs[0])?,
            trace.bind_group(3, &scene.resources())?,
        ];
        let retrace_set = match lane_cap {
            1 => Some(set2(&b.hier_configs[1])?),
            _ => None,
        };
        Ok(TracePass {
            pipeline: trace,
            sets,
            retrace_set,
            entry: entry.to_string(),
        })
    }
}

/// The compute path's buffers and pipelines for one renderer.
pub struct ComputePath {
    width: u32,
    height: u32,
    hier_pass: Hier32Pass,
    hier_bindings: Hier32Bindings,
    /// The gaps' hierarchy (the `bounded` criterion).
    gap_pass: Option<(Hier32Pass, Hier32Bindings)>,
    append: GraphicsPipeline,
    append_set: BindGroup,
    dispatch_args: ComputePipeline,
    args_set: BindGroup,
    /// `retrace_size`: the retrace's workgroup count from the cut queue's length (with a
    /// retrace dispatch only).
    retrace_size: Option<(ComputePipeline, BindGroup)>,
    trace: TracePass,
    buffers: ComputeBuffers,
}

impl ComputePath {
    /// Allocates the hierarchy, the queue and the pipelines for the frame's inputs: its
    /// `FrameParams` uniform (`params`) and per-pixel record buffer (`records`), the scene (bound
    /// for verified hits: `cmo` must carry the triangle IDs), and the lane layout its options
    /// ask for ([`ray_lanes`]).
    pub fn new(i: &FrameInputs<'_>) -> VkResult<Self> {
        let (ctx, cmo, scene, gbuffer) = (i.ctx, i.cmo, i.scene, i.gbuffer);
        let (params, records, (width, height)) = (i.params, i.records, i.gbuffer.extent());
        check_device(ctx)?;
        if i.options.trace.strict {
            // The kernel carries no strict code (`spirv/compute_trace.wgsl`, `advance`), and
            // its twin would run it: refused as `--strict` is.
            return Err(VkError::Usage {
                what: COMPUTE_TRACE.name.to_string(),
                detail: "strict mode (--strict) applies only to --method fragment".to_string(),
            });
        }
        let (lane_cap, entry) = ray_lanes(ctx, i.options.compute_layout)?;
        let entry = if bounded(cmo) {
            bounded_entry(entry)
        } else {
            entry
        };
        let pixels = u64::from(width) * u64::from(height);
        let b = ComputeBuffers::new(ctx, cmo, pixels, lane_cap)?;
        let hier_pass = Hier32Pass::new(ctx)?;
        let hier_bindings =
            hier_pass.bind(ctx, cmo.distance(), &b.hier, cmo.count(), cmo.size())?;
        let gap_pass = if bounded(cmo) {
            let p = Hier32Pass::gaps(ctx)?;
            let bindings = p.bind(ctx, &cmo.gaps()[0], &b.gap_hier, cmo.count(), cmo.size())?;
            Some((p, bindings))
        } else {
            None
        };
        let append = GraphicsPipeline::new(
            ctx,
            &APPEND,
            &GraphicsDesc {
                vertex: "vs_fullscreen",
                fragment: "fs_main",
                colour_formats: Vec::new(),
                depth: None,
            },
        )?;
        let append_set = append.bind_group(
            0,
            &[
                (0, Resource::sampled(&gbuffer.position)),
                (1, Resource::sampled(&gbuffer.normal)),
                (2, Resource::Buffer(params)),
                (6, Resource::Buffer(&b.counter)),
                (7, Resource::Buffer(&b.rays)),
                (8, Resource::sampled(&gbuffer.triangle)),
            ],
        )?;
        let dispatch_args =
            ComputePipeline::new(ctx, &DISPATCH_ARGS, "main", ComputeOptions::default())?;
        let args_set = dispatch_args.bind_group(
            0,
            &[
                (0, Resource::Buffer(&b.counter)),
                (1, Resource::Buffer(&b.args)),
                (2, Resource::Buffer(&b.dispatch_params)),
                (3, Resource::Buffer(&b.cut)),
                (4, Resource::Buffer(&b.hier_configs[0])),
                (5, Resource::Buffer(&b.hier)),
                (6, Resource::Buffer(cmo.distance())),
            ],
        )?;
        let trace = TracePass::new(ctx, entry, lane_cap, &b, cmo, scene, params, records)?;
        let retrace_size = match trace.retrace_set {
            Some(_) => {
                let p = ComputePipeline::new(
                    ctx,
                    &DISPATCH_ARGS,
                    "retrace_size",
                    ComputeOptions::default(),
                )?;
                let set = p.bind_group(
                    0,
                    &[
                        (0, Resource::Buffer(&b.counter)),
                        (2, Resource::Buffer(&b.dispatch_params)),
                        (7, Resource::Buffer(&b.retrace_args)),
                    ],
                )?;
                Some((p, set))
            }
            None => None,
        };
        Ok(ComputePath {
            width,
            height,
            hier_pass,
            hier_bindings,
            gap_pass,
            append,
            append_set,
            dispatch_args,
            args_set,
            retrace_size,
            trace,
            buffers: b,
        })
    }

    /// `hier32`: the hierarchy from the captured distances (the caller orders it after the
    /// capture and before [`ComputePath::record_trace`]).
    pub fn record_hier(&self, rec: &Recorder<'_>) {
        self.hier_pass.record(rec, &self.hier_bindings);
        if let Some((p, b)) = &self.gap_pass {
            p.record(rec, b);
        }
    }

    /// `append`: zeroes the counter, then queues one ray per mirror pixel of the G-buffer.
    pub fn record_append(&self, rec: &Recorder<'_>) -> VkResult<()> {
        rec.fill_buffer(&self.buffers.counter, 0);
        rec.memory_barrier(TRANSFER_WRITE, STORAGE_RW);
        let target = RenderTarget {
            width: self.width,
            height: self.height,
            colour: Vec::new(),
            depth: None,
        };
        self.append.draw(rec, &target, &[&self.append_set], 3, 0)
    }

    /// `dispatch_args`: the workgroup count from the ray count (after a barrier from `append`).
    pub fn record_dispatch_args(&self, rec: &Recorder<'_>) {
        rec.memory_barrier(SHADER_WRITE, STORAGE_RW);
        self.dispatch_args
            .dispatch(rec, &[&self.args_set], [1, 1, 1]);
    }

    /// `compute_trace`: the indirect dispatch over the queue (after a barrier from
    /// `dispatch_args`; the hierarchy must already be visible); with `main_lanes1` or
    /// `main_wave`, then `retrace_size` and the retrace (mode 1) over the rays the
    /// first dispatch cut (their queue indices in the cut queue; none cut, an empty dispatch).
    pub fn record_trace(&self, rec: &Recorder<'_>) -> VkResult<()> {
        rec.memory_barrier(SHADER_WRITE, INDIRECT_READ);
        let t = &self.trace;
        let sets = [&t.sets[0], &t.sets[1], &t.sets[2], &t.sets[3]];
        t.pipeline
            .dispatch_indirect(rec, &sets, &self.buffers.args, 0)?;
        if let (Some(set2), Some((size, size_set))) = (&t.retrace_set, &self.retrace_size) {
            rec.memory_barrier(SHADER_WRITE, STORAGE_RW);
            size.dispatch(rec, &[size_set], [1, 1, 1]);
            rec.memory_barrier(SHADER_WRITE, INDIRECT_READ);
            t.pipeline.dispatch_indirect(
                rec,
                &[sets[0], sets[1], set2, sets[3]],
                &self.buffers.retrace_args,
                0,
            )?;
        }
        Ok(())
    }

    /// A round of `--bounces` (`vk::passes::bounce`): the round's BVH queue (`BvhRay`s, the
    /// fields the trace reads where `AppendedRay` has them) copied into the compute queue, its
    /// count into the counter's, then `dispatch_args` and `compute_trace` as for the camera's
    /// rays; the records take `bounce` + 1.
    pub fn record_round(&self, rec: &Recorder<'_>, queue: &BvhQueue) -> VkResult<()> {
        let b = &self.buffers;
        let bytes = queue.rays().size().min(b.rays.size());
        // The last trace read the compute queue; the round's append wrote its own. Only the
        // count is replaced: the subgroup sizes and the rays traced carry over the rounds.
        rec.memory_barrier(ALL, ALL);
        rec.copy_buffer(queue.counter(), &b.counter, 4);
        rec.copy_buffer(queue.rays(), &b.rays, bytes);
        rec.memory_barrier(TRANSFER_WRITE, STORAGE_RW);
        self.record_dispatch_args(rec);
        self.record_trace(rec)
    }

    /// The ray count, subgroup sizes and per-pixel counters of the last frame.
    pub fn read_stats(&self, ctx: &GpuContext) -> VkResult<ComputeStats> {
        let counter: Vec<RayCounter> = ctx.read_buffer(&self.buffers.counter)?;
        let c = counter.first().copied().unwrap_or_default();
        let mut per_pixel: Vec<[u32; 4]> = ctx.read_buffer(&self.buffers.stats)?;
        per_pixel.truncate((self.width * self.height) as usize);
        Ok(ComputeStats {
            rays: c.traced,
            subgroup_size: (!c.subgroup_min_not, c.subgroup_max),
            retraced: c.cut,
            per_pixel,
        })
    }

    /// The dispatch the GPU computed in the last frame (tests).
    pub fn read_dispatch_args(&self, ctx: &GpuContext) -> VkResult<DispatchArgs> {
        let a: Vec<DispatchArgs> = ctx.read_buffer(&self.buffers.args)?;
        Ok(a.first().copied().unwrap_or_default())
    }
}

/// The compute method.
pub struct Compute;

impl MethodSpec for Compute {
    fn method(&self) -> crate::method::Method {
        crate::method::Method::Compute
    }

    fn trace_pass(&self) -> &'static Pass {
        &COMPUTE_TRACE
    }
    /// On a glossy scene the frame cone traces the glossy pixels (`vk::passes::cone`), from
    /// the pre-filtered colour chain.
    fn glossy(&self) -> Glossy {
        Glossy::ConeStage
    }

    /// Triangle IDs (verified hits, the environment-map fallback), no colour, no pyramid: the
    /// hierarchy is the method's own ([`ComputePath`]).
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

    /// The ray queue and the per-ray statistics.
    fn bytes_per_pixel(&self) -> u64 {
        size_of::<AppendedRay>() as u64 + 16
    }

    /// The 8x4/4x8 hierarchy: `[min, max]` f32 pairs per cell.
    fn cmo_bytes(&self, cmos: u32, size: u32) -> u64 {
        u64::from(cmos) * hier32_len(size) as u64 * 8
    }

    /// The hierarchy of the lists' gaps: a packed word per cell.
    fn cmo_list_bytes(&self, cmos: u32, size: u32) -> u64 {
        u64::from(cmos) * hier32_len(size) as u64 * 4
    }

    fn check_device(&self, ctx: &GpuContext) -> VkResult<()> {
        check_device(ctx)
    }

    fn create(&self, i: &FrameInputs<'_>) -> VkResult<Box<dyn Technique>> {
        Ok(Box::new(ComputePath::new(i)?))
    }
}

impl Technique for ComputePath {
    /// The trace's CMO group (set 1) over `cmo`'s buffers as they are now (the hierarchy
    /// passes bind only the distances, which stay).
    fn rebind_cmo(&mut self, _ctx: &GpuContext, cmo: &CmoData) -> VkResult<()> {
        let t = &mut self.trace;
        t.sets[1] = t
            .pipeline
            .bind_group(1, &cmo.resources_for(&COMPUTE_TRACE, &t.entry))?;
        Ok(())
    }

    fn record_cmo_stage(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        scope(HIER32.name, &mut || {
            self.record_hier(rec);
            Ok(())
        })?;
        rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        Ok(())
    }

    fn record(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        scope(APPEND.name, &mut || self.record_append(rec))?;
        scope(DISPATCH_ARGS.name, &mut || {
            self.record_dispatch_args(rec);
            Ok(())
        })?;
        scope(COMPUTE_TRACE.name, &mut || self.record_trace(rec))
    }

    /// The rounds of `--bounces` are traced with the cube maps too ([`ComputePath::record_round`]).
    fn traces_rounds(&self) -> bool {
        true
    }

    fn record_round(&self, rec: &Recorder<'_>, queue: &BvhQueue) -> VkResult<()> {
        ComputePath::record_round(self, rec, queue)
    }

    fn read_stats(&self, ctx: &GpuContext) -> VkResult<MethodStats> {
        Ok(MethodStats {
            compute: Some(ComputePath::read_stats(self, ctx)?),
            search: None,
        })
    }
}

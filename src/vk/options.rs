//! The options of a GPU render: the method and what it may use.
use crate::cpu::options::{TraceCriterion, TraceOptions};
use crate::cpu::reflection_point::RpOptions;
use crate::cpu::ssr::SsrOptions;
use crate::method::Method;

/// What fills a mirror pixel whose ray no CMO could resolve.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Fallback {
    /// A flag colour (magenta), to see where tracing gave up.
    Flag,
    /// The environment-map lookup of the nearest CMO, shaded from the triangle its texel
    /// captured (`composite.wgsl`, `cpu::fragment::envmap_fallback`).
    Envmap,
    /// The scene's background.
    Background,
    /// The rays are finished exactly by the BVH tracer: after the tracing pass, the `fallback`
    /// pass queues the unresolved records' rays and traces them from their start under the
    /// start rule ([`crate::vk::passes::bvh`]; not from `t_done`, which misses hits: the tests'
    /// `Fallback::TraceFromTDone` shows them); such
    /// records get `fallback` = 1 and keep the cubemap tracer's `t_done` and counters. A ray the BVH
    /// loop's cap cut (none seen) stays unresolved and shows the flag colour. The default (of the
    /// CLI and the bench too).
    #[default]
    Trace,
    /// [`Fallback::Trace`] with the rays started at their `t_done` instead of 0: misses the hits
    /// before `t_done` that the cubemap's model does not see (uncaptured reflectors, surfaces in
    /// front of their texel's patch; spirv/bvh_queue.wgsl). Not offered by the CLI; the tests
    /// show what it misses (`test-hooks` only).
    #[cfg(feature = "test-hooks")]
    TraceFromTDone,
}

/// How the compute method lays rays over a subgroup's lanes (`compute_trace`'s entry points;
/// [`crate::vk::methods::compute::ray_lanes`]). Every layout writes the same records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ComputeLayout {
    /// Thesis alg. 3: min(S, 32) lanes per ray, one child per lane (`main`).
    Thesis,
    /// One lane per ray, testing its crossed children itself in rounds (`main_lanes1`).
    OneLane,
    /// One ray per lane, the crossed children of all the subgroup's rays tested by whichever
    /// lanes are free (`main_wave`).
    Wave,
}

impl ComputeLayout {
    /// The name the CLI, `CUBETRACE_RAY_LANES` and the bench's labels use.
    pub fn name(self) -> &'static str {
        match self {
            ComputeLayout::Thesis => "thesis",
            ComputeLayout::OneLane => "one-lane",
            ComputeLayout::Wave => "wave",
        }
    }
}

/// The face size of the `bounded` criterion's per-texel lists (`--list-size`). Every hit the
/// lists give is a listed triangle's exact intersection, the first along the ray whatever the
/// texels' size, and the exact fallback takes the rays they leave: the face size changes what
/// the capture and the trace cost and how many rays reach the fallback, not the image (but for
/// the last bits of a hit that one tracer finds and the other leaves; `lavapipe-list-size.md`
/// in `benches/results`). A glossy reflector's cone pass reads CMOs of its own at the cube size
/// (`CmoPlan::cone_size`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ListSize {
    /// The first of [`AUTO_LIST_MIN`], twice that, ... below the cube size whose lists stay
    /// short, at most [`AUTO_LIST_LENGTH`] nodes per texel by the node pool's bound, else the
    /// cube size ([`crate::vk::passes::capture_lists::list_size`]).
    #[default]
    Auto,
    /// The cube size (`--cube-size`, else the scene's).
    Cube,
    /// This many texels per face side.
    Fixed(u32),
}

/// [`ListSize::Auto`]'s smallest face size.
pub const AUTO_LIST_MIN: u32 = 32;
/// [`ListSize::Auto`]'s longest mean list: nodes of the pool's bound per texel (the help of
/// `--list-size` states it).
pub const AUTO_LIST_LENGTH: u64 = 8;

/// Options of a GPU render. [`RenderOptions::default`] is the one source of the defaults: the
/// CLI (`cubetrace render`) and the bench start from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub method: Method,
    /// Tracer options (criterion, sampling, acceleration, steps); used by `Fragment` and
    /// `Compute` (the criterion) alone.
    pub trace: TraceOptions,
    pub fallback: Fallback,
    /// Options of `Ssr` (iteration cap, thickness).
    pub ssr: SsrOptions,
    /// Options of `ReflectionPoint` (iteration cap).
    pub reflection_point: RpOptions,
    /// Reflections per path, 0..=[`MAX_BOUNCES`](crate::vk::passes::bounce::MAX_BOUNCES) (the
    /// reference's `bounces`): the method traces the first, and `Compute` the rest too (unless
    /// [`RenderOptions::bvh_bounces`]), the BVH otherwise ([`crate::vk::passes::bounce`]); 0 shows
    /// the mirrors' own material. `Compute`, `Fragment` (bounded or centre criterion) and `Bvh`
    /// only; the other methods take 1.
    pub bounces: u32,
    /// `Compute`: the BVH traces the reflections after the first (as for `Fragment`), not the
    /// cube maps (`--bvh-bounces`; for comparison).
    pub bvh_bounces: bool,
    /// The reflector check after the `Fragment` and `Compute` trace ([`ReflectorCheck`](crate::vk::passes::bvh::ReflectorCheck)): on by
    /// default; ignored by the other methods and where the scene has no reflector to check.
    pub reflector_check: bool,
    /// `Compute`'s lane layout; `None`: `CUBETRACE_RAY_LANES`, else the device's default
    /// ([`crate::vk::methods::compute::ray_lanes`]).
    pub compute_layout: Option<ComputeLayout>,
    /// The `bounded` criterion's lists' face size ([`ListSize`]); ignored by other criteria.
    pub list_size: ListSize,
}

impl RenderOptions {
    /// Whether the frame traces the bounded criterion's lists: a cube-map tracer with
    /// [`TraceCriterion::Bounded`] (the default criterion); the other methods ignore the
    /// criterion, so their frames are the same whatever it says.
    pub fn bounded(&self) -> bool {
        self.method.traces_cubemaps() && self.trace.criterion == TraceCriterion::Bounded
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            method: Method::DEFAULT,
            trace: TraceOptions::default(),
            fallback: Fallback::default(),
            ssr: SsrOptions::default(),
            reflection_point: RpOptions::default(),
            bounces: 1,
            bvh_bounces: false,
            reflector_check: true,
            compute_layout: None,
            list_size: ListSize::Auto,
        }
    }
}

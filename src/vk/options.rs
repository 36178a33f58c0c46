//! The options of a GPU render: the method and what it may use.
use crate::cpu::options::{TraceCriterion, TraceOptions};
use crate::cpu::reflection_point::RpOptions;
use crate::cpu::ssr::SsrOptions;
use crate::method::Method;
use crate::placement::Scoring;

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

pub use crate::cubemap::bounds::{AUTO_LIST_LENGTH, AUTO_LIST_MIN, ListSize};

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

    /// The placement search's judge for these frames: the bounded criterion's twin over lists
    /// of the frame's size where [`RenderOptions::bounded`], the centre criterion's otherwise.
    pub fn scoring(&self) -> Scoring {
        if self.bounded() {
            Scoring::Bounded(self.list_size)
        } else {
            Scoring::Centre
        }
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

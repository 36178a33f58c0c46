#![forbid(unsafe_code)]
//! The tracer and fallback options of `cubetrace render` ([`TraceArgs`]) and how they become the
//! renderer's [`RenderOptions`] and the scene's CMO overrides. The command line's value enums
//! mirror the library's option enums one to one (their doc comments are the `--help` text).

use clap::ValueEnum;

use crate::Method;
use crate::cpu::options::{TraceCriterion, TraceOptions, TraceSampling};
use crate::render::scene::SceneSetup;
use crate::vk::frame::{ComputeLayout, Fallback, RenderOptions};
use crate::vk::options::ListSize;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CriterionArg {
    /// Sound per-texel bounds and candidate lists (the default): the hit is the nearest listed
    /// triangle the ray meets where the list is complete, provably the first along the ray;
    /// the exact fallback takes the rest.
    Bounded,
    /// The centre-sampled capture's per-texel surface (sphere patches, continuity rule): a
    /// silhouette is never a hit, but geometry between texel centres is unseen, so a thin or
    /// distant surface can be missed (a surface behind the first hit shows; kept for study).
    Centre,
    /// The thesis's `|r - D| < eps` at samples.
    Threshold,
    /// The thesis's sign change of `r - D` between samples (fires at silhouettes too).
    SignChange,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ComputeLayoutArg {
    /// Thesis alg. 3: min(S, 32) lanes of a subgroup per ray, one child tested per lane.
    Thesis,
    /// One lane per ray, testing its ray's crossed children itself, one per round.
    OneLane,
    /// One ray per lane; the crossed children of all the subgroup's rays are tested by whichever
    /// lanes are free.
    Wave,
}

impl ComputeLayoutArg {
    pub fn layout(self) -> ComputeLayout {
        match self {
            ComputeLayoutArg::Thesis => ComputeLayout::Thesis,
            ComputeLayoutArg::OneLane => ComputeLayout::OneLane,
            ComputeLayoutArg::Wave => ComputeLayout::Wave,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SamplingArg {
    /// `--steps` + 1 samples evenly spaced along the ray.
    ConstantStep,
    /// `--steps` + 1 samples evenly spaced in angle (between the endpoint directions).
    ConstantAngle,
    /// One sample per crossed texel.
    PerTexel,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FallbackArg {
    /// Magenta: shows where tracing gave up.
    Flag,
    /// The environment-map lookup of the nearest CMO.
    Envmap,
    /// The scene's background colour.
    Background,
    /// Finish the rays exactly: the BVH tracer traces them from the mirror, as `--method bvh`
    /// does (the EXR's `fallback` channel marks them).
    Trace,
}

/// Parses `--list-size`: `auto`, `cube` or texels per face side (1 to 4096).
pub fn list_size(s: &str) -> std::result::Result<ListSize, String> {
    match s {
        "auto" => Ok(ListSize::Auto),
        "cube" => Ok(ListSize::Cube),
        _ => match s.parse::<u32>() {
            Ok(n @ 1..=4096) => Ok(ListSize::Fixed(n)),
            _ => Err(format!(
                "'{s}' is not a list size: `auto`, `cube` or texels per face side, 1 to 4096"
            )),
        },
    }
}

/// Parses a positive, finite distance (`--eps`, `--ssr-thickness`). Negative numbers reach this
/// parser (the argument allows them), so that `--eps -1` gets this message rather than clap's
/// "unexpected argument".
pub fn positive_finite(s: &str) -> std::result::Result<f32, String> {
    let v: f32 = s
        .parse()
        .map_err(|e| format!("'{s}' is not a number ({e})"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!(
            "{s} is not allowed: it must be a positive, finite distance in world units"
        ))
    }
}

/// Options of the cubemap tracer (`--method compute|fragment`; compute: the bounded and centre
/// criteria only).
#[derive(clap::Args)]
pub struct TraceArgs {
    /// fragment, compute: intersection criterion [default: bounded] (compute: bounded or
    /// centre).
    #[arg(long, value_enum)]
    pub criterion: Option<CriterionArg>,
    /// compute: how rays are laid over a subgroup's lanes; every layout gives the same image
    /// [default: one-lane on a CPU driver (lavapipe), wave on a GPU; the environment variable
    /// CUBETRACE_RAY_LANES (32, 1 or wave) sets it where this is not given].
    #[arg(long, value_enum)]
    pub compute_layout: Option<ComputeLayoutArg>,
    /// compute with --bounces N: the BVH traces the reflections after the first (as it does for
    /// fragment), instead of the cube maps; for comparison, the image is the same up to the
    /// criterion's own error.
    #[arg(long)]
    pub bvh_bounces: bool,
    /// fragment with --criterion threshold or sign-change: sample placement [default:
    /// per-texel].
    #[arg(long, value_enum)]
    pub sampling: Option<SamplingArg>,
    /// fragment, --criterion centre: turn off the min/max pyramid (walk every texel instead; same
    /// result).
    #[arg(long)]
    pub no_accel: bool,
    /// fragment, --criterion centre: count a hit inside a texel only where the texel data decides
    /// it (the ray gets behind the surface around the hit and no outline passes through the texel);
    /// elsewhere the ray is handed on, so more pixels end unresolved.
    ///
    /// What the tests show (tests/hard_cases.rs): with verified hits the default mode has no
    /// wrong hit or escape for the ray the GPU reflected on grazing rays, slabs thinner than a
    /// texel, outlines right behind the rays, scales 1e-3 and 1e4, cube sizes 32 and 2048 and
    /// the built-in scenes, and this mode none either; it removes wrong hits only at cube size 3
    /// (2 of 5, behind an object no texel sees) and elsewhere only adds unresolved pixels. It
    /// does not make surfaces the CMOs never captured (a reflector seeing itself) right: against
    /// the reference those pixels stay wrong, as without it (see `cubetrace bench`).
    #[arg(long)]
    pub strict: bool,
    /// fragment with --sampling constant-step or constant-angle: sample intervals along the ray
    /// [default: 400].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub steps: Option<u32>,
    /// fragment with --criterion threshold: the threshold, world units (positive) [default:
    /// 0.05].
    #[arg(long, allow_negative_numbers = true, value_parser = positive_finite)]
    pub eps: Option<f32>,
    /// Every GPU method but bvh: number of CMOs, spread along the reflectors' longest axis
    /// (overrides the scene's CMO centres); with `--placement auto`, the most the search may
    /// place.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(crate::scene::MAX_CMOS)))]
    pub cmos: Option<u32>,
    /// Every GPU method but bvh: how the CMO centres are chosen (overrides the scene's). `auto`
    /// (the default of a scene without `[cmo]` centres) samples the camera's reflected rays (with
    /// --bounces N, their later reflections off reflectors too). One CMO comes first, on the
    /// reflectors' axis or just in front of the mirror points in view (taken where the sample's
    /// rays test at most 3/4 of the texels there). Failing that, it adds CMOs where they leave
    /// the fewest unresolved, until at most 1 % of the sample is (judged by the frame's
    /// criterion: for bounded, its own lists, which resolve more), within a budget of --cmos N
    /// (else the scene's `[cmo]` count, else 8) CMOs and 512 MiB of them; it may also leave the
    /// reflectors out of the capture where that resolves more (the reflector check traces those
    /// rays exactly). Under the bounded criterion a still frame uploads the lists the search
    /// judged with instead of capturing (the same frame, without a capture pass). `axis` spreads
    /// --cmos N (default 1) along the reflectors' longest axis. `-v` logs the search: its time,
    /// the share it leaves, each centre.
    #[arg(long, value_enum)]
    pub placement: Option<crate::placement::PlacementChoice>,
    /// Every GPU method but bvh: texels per cube face side (overrides the scene's; 1 to 4096).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub cube_size: Option<u32>,
    /// fragment, compute with the bounded criterion (the default): texels per face side of the
    /// per-texel lists [default: auto]. The image does not depend on it (every hit is a listed
    /// triangle's exact intersection, and the exact fallback takes the rays the lists leave);
    /// the cost and the share of rays left to the fallback do. `auto` takes the smallest of 32,
    /// 64, 128, ... below the cube size whose lists hold at most 16 triangles per texel on
    /// average (by the capture's own bound), else the cube size, or, where the placement search
    /// found that one CMO meets its target only with shorter lists (at most 8), that size;
    /// `cube` the cube size; a number that size. A glossy reflector's cone pass reads a capture of its own at the cube size,
    /// as with the centre criterion. `-v` logs the size taken.
    #[arg(long, value_parser = list_size)]
    pub list_size: Option<ListSize>,
    /// compute, fragment, ssr, reflection-point: what fills mirror pixels the method left
    /// unresolved [default: trace]: `trace` finishes their rays exactly with the BVH tracer of
    /// `--method bvh` (the summary line counts them; see `--help` of `render`).
    #[arg(long, value_enum)]
    pub fallback: Option<FallbackArg>,
    /// fragment, compute: skip the reflector check (the exact trace, after the cubemap trace,
    /// of the reflectors the CMOs do not capture: the torus or teapot seen in itself).
    #[arg(long)]
    pub no_reflector_check: bool,
    /// ssr: iterations of the Hi-Z ray march before a ray is given up (unresolved) [default:
    /// 64].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub ssr_iterations: Option<u32>,
    /// ssr: thickness test, world units along the view axis: a hit farther than this behind the
    /// surface it lands on is unresolved. Default: none (the chapter's: every surface is
    /// infinitely thick, so a ray passing behind a thin object hits it).
    #[arg(long, allow_negative_numbers = true, value_parser = positive_finite)]
    pub ssr_thickness: Option<f32>,
    /// reflection-point: steps of one search (forward or inverse) before the vertex is given up
    /// (its triangles are then not drawn). Default: the search textures' width + height in texels.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub rp_iterations: Option<u32>,
    /// reflection-point: the search textures (the reflector's positions and normals) have this
    /// many times the frame's width and height [default: 1].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub rp_scale: Option<u32>,
    /// reflection-point: search on the reflectors as they are, not on the closed versions of
    /// open ones (the paper's open/closed pair).
    #[arg(long)]
    pub rp_open: bool,
}

impl TraceArgs {
    /// The renderer's options: what was given, the defaults (the library's) elsewhere.
    pub fn options(&self, method: Method) -> RenderOptions {
        let defaults = RenderOptions::default();
        let trace = TraceOptions::default();
        RenderOptions {
            method,
            trace: TraceOptions {
                criterion: self.criterion.map_or(trace.criterion, |c| match c {
                    CriterionArg::Centre => TraceCriterion::Centre,
                    CriterionArg::Threshold => TraceCriterion::Threshold,
                    CriterionArg::SignChange => TraceCriterion::SignChange,
                    CriterionArg::Bounded => TraceCriterion::Bounded,
                }),
                sampling: self.sampling.map_or(trace.sampling, |s| match s {
                    SamplingArg::ConstantStep => TraceSampling::ConstantStep,
                    SamplingArg::ConstantAngle => TraceSampling::ConstantAngle,
                    SamplingArg::PerTexel => TraceSampling::PerTexel,
                }),
                accel: !self.no_accel,
                strict: self.strict,
                steps: self.steps.unwrap_or(trace.steps),
                eps: self.eps.unwrap_or(trace.eps),
                ..trace
            },
            reflector_check: !self.no_reflector_check,
            compute_layout: self.compute_layout.map(ComputeLayoutArg::layout),
            list_size: self.list_size.unwrap_or(defaults.list_size),
            bvh_bounces: self.bvh_bounces,
            fallback: self.fallback.map_or(defaults.fallback, |f| match f {
                FallbackArg::Flag => Fallback::Flag,
                FallbackArg::Envmap => Fallback::Envmap,
                FallbackArg::Background => Fallback::Background,
                FallbackArg::Trace => Fallback::Trace,
            }),
            ssr: crate::cpu::ssr::SsrOptions {
                max_iterations: self.ssr_iterations.unwrap_or(defaults.ssr.max_iterations),
                thickness: self.ssr_thickness,
            },
            reflection_point: crate::cpu::reflection_point::RpOptions {
                max_iterations: self.rp_iterations,
                search_scale: self
                    .rp_scale
                    .unwrap_or(defaults.reflection_point.search_scale),
                close_reflectors: !self.rp_open,
            },
            ..defaults
        }
    }

    /// The method-specific options given on the command line, as typed
    /// ([`crate::method::METHOD_OPTIONS`] decides which methods read them).
    pub fn given(&self) -> Vec<&'static str> {
        [
            ("--criterion", self.criterion.is_some()),
            ("--sampling", self.sampling.is_some()),
            ("--compute-layout", self.compute_layout.is_some()),
            ("--bvh-bounces", self.bvh_bounces),
            ("--no-accel", self.no_accel),
            ("--strict", self.strict),
            ("--steps", self.steps.is_some()),
            ("--eps", self.eps.is_some()),
            ("--cmos", self.cmos.is_some()),
            ("--placement", self.placement.is_some()),
            ("--cube-size", self.cube_size.is_some()),
            ("--list-size", self.list_size.is_some()),
            ("--fallback", self.fallback.is_some()),
            ("--no-reflector-check", self.no_reflector_check),
            ("--ssr-iterations", self.ssr_iterations.is_some()),
            ("--ssr-thickness", self.ssr_thickness.is_some()),
            ("--rp-iterations", self.rp_iterations.is_some()),
            ("--rp-scale", self.rp_scale.is_some()),
            ("--rp-open", self.rp_open),
        ]
        .into_iter()
        .filter_map(|(flag, given)| given.then_some(flag))
        .collect()
    }

    /// The CMO overrides in the scene's set-up ([`SceneSetup`]: placement, count, face size).
    pub fn apply(&self, setup: &mut SceneSetup) {
        setup.placement = self.placement;
        setup.cmos = self.cmos;
        setup.cube_size = self.cube_size;
    }
}

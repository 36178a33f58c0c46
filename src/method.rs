#![forbid(unsafe_code)]
//! The one method type: every way of computing reflections that the renderer, the command line
//! and the harness know, with what each supports.
//!
//! [`Method`] is the command line's `--method` (a clap [`ValueEnum`]), the harness's method
//! column (its serde name is the CLI's) and the GPU renderer's choice. What a method is and
//! supports (its name, the options it reads, bounces, fallback, reflector check, tracer
//! options, glossy lobe, known limits) is written once, as data in the method's own file
//! ([`MethodInfo`], `src/method/<name>.rs`), and read through the methods of [`Method`], so
//! the CLI, the bench and the renderer cannot disagree. Nothing here touches the GPU: the
//! passes a method records live in `vk::methods`.
//!
//! # The registry and the variant rule
//!
//! This file is the registry: the enum, [`Method::ALL`] and [`Method::GPU`], the roles
//! generic code asks for ([`Method::DEFAULT`], [`Method::TRUTH`], [`Method::EXACT_GPU`],
//! [`Method::SCALING`]) and one line per method in [`Method::info`]. A variant (`Method::Ssr`)
//! is named only here and in that method's own files: those whose module path has a part equal
//! to its name (`method::ssr`, `vk::methods::ssr`, `model::methods::ssr`, `cpu::ssr`).
//! Everywhere else the code asks the method (`m.glossy()`, `m.known_limit()`,
//! `m.info().vertex_search`) or uses a role constant. Test modules (`#[cfg(test)]`), `tests/`
//! and `benches/` may name variants. `tests/layout.rs` lists every place that breaks the rule
//! and fails on any.
//!
//! Adding a method takes a variant, its place in [`Method::ALL`] (and [`Method::GPU`]) and its
//! line in [`Method::info`] here, and its file under `src/method/`; a GPU method also its file
//! under `src/vk/methods/` and a line in `vk::methods::SPECS`; a method the cost model replays
//! its file under `src/model/methods/` and a line in `model::methods::MODELS`.
use clap::ValueEnum;
use serde::Serialize;

use crate::cpu::options::{TraceCriterion, TraceOptions};

mod bvh;
mod compute;
mod envmap;
mod fragment;
mod reference;
mod reflection_point;
mod ssr;

/// How reflections are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Cubemap tracing in a compute pass on the GPU over the 8x4/4x8 hierarchy with subgroup
    /// ballots (thesis alg. 3; bounded or centre criterion). Glossy reflectors: cone traced on the
    /// cube maps' pre-filtered colour.
    Compute,
    /// Cubemap tracing in a deferred fragment pass on the GPU (thesis alg. 1, 2, 4). Glossy
    /// reflectors: cone traced on the cube maps' pre-filtered colour.
    Fragment,
    /// One cube map lookup per pixel on the GPU, no parallax (the baseline).
    Envmap,
    /// Hi-Z screen-space reflections on the GPU (Uludag 2014): a min pyramid of the G-buffer's
    /// depth and a hierarchical ray march; what leaves the screen goes to the fallback. Glossy
    /// reflectors: the chapter's screen-space cone tracing.
    Ssr,
    /// Reflection-point search with virtual objects on the GPU (Estalella et al. 2006): per
    /// vertex of the other objects, a local search over the reflector's position and normal
    /// textures; the virtual objects rasterised into the mirror; uncovered pixels get the fallback.
    ReflectionPoint,
    /// Exact ray tracing of the reflected rays on the GPU: a compute pass over a compressed wide
    /// BVH (obvhs), the same triangles and shading as the reference. Glossy reflectors: one lobe
    /// sample per film sample (Monte Carlo, `--spp`).
    Bvh,
    /// Exact CPU ray tracing against the scene's triangles: the ground truth.
    Reference,
}

/// Why a method refuses a setting: the CLI's words, for the user.
pub type Refusal = String;

/// What one method is and supports: written in the method's own file under `src/method/`
/// (`src/method/compute.rs`), read through [`Method::info`] and the methods of [`Method`].
#[derive(Clone, Copy, Debug)]
pub struct MethodInfo {
    /// The name on the command line, in file names and in the harness's tables.
    pub name: &'static str,
    /// Whether it runs on the GPU.
    pub gpu: bool,
    /// Whether it runs the cubemap tracer ([`Method::traces_cubemaps`]).
    pub traces_cubemaps: bool,
    /// Whether a cubemap tracer implements the approximate criteria (threshold, sign change);
    /// one that does not refuses them ([`Method::check_trace`]).
    pub approximate_criteria: bool,
    /// Whether it reads the CMOs' data for its own result ([`Method::reads_cmos`]).
    pub reads_cmos: bool,
    /// Whether it captures CMOs ([`Method::captures_cmos`]).
    pub captures_cmos: bool,
    /// Whether it can leave a mirror pixel unresolved ([`Method::can_leave_unresolved`]).
    pub can_leave_unresolved: bool,
    /// Whether its records name the triangle they hit ([`Method::names_hits`]).
    pub names_hits: NamesHits,
    /// What it makes of a glossy reflector's lobe.
    pub glossy: GlossyLobe,
    /// The likely cause, in the CLI's words, of many pixels left to the fallback that the
    /// method's nature explains ([`Method::known_limit`]).
    pub known_limit: Option<&'static str>,
    /// Whether its records hold a per-pixel outcome (`face`) and iteration count (`cells`)
    /// that `render -v` summarises.
    pub outcomes_in_records: bool,
    /// The method-specific flags it reads, each under the condition on the tracer options
    /// that [`METHOD_OPTIONS`] states (`--strict`: with the centre criterion).
    pub options: &'static [&'static str],
    /// Whether it searches a reflection point per vertex of the other objects: its quality
    /// depends on their tessellation (the bench adds a row with them subdivided), its search
    /// steps have a table of their own in the bench's report, and its cost is per vertex, not
    /// per ray (the bench's cost-per-ray table leaves it out).
    pub vertex_search: bool,
}

/// Whether a method's records name the triangle they hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NamesHits {
    /// Every hit is verified against its triangle.
    Always,
    /// With the bounded or centre criterion; not with the approximate ones (N = 0 bounces, the
    /// mirrors' own material, is open whatever the criterion).
    CentreOrBounded,
    /// No record names its triangle: one reflection only.
    Never,
}

/// What a method makes of a glossy reflector's lobe ([`crate::lobe`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GlossyLobe {
    /// Samples the lobe of every reflection (the reference).
    SampledEverywhere,
    /// Samples the lobe of the first reflection (Monte Carlo, `--spp`); later ones follow the
    /// mirror direction.
    SampledFirst,
    /// Cone traces the lobe on the cube maps' pre-filtered colour on the first reflection;
    /// later ones follow the mirror direction.
    ConeTracedFirst,
    /// Cone traces the lobe and traces one reflection only.
    ConeTracedOnly,
    /// Traces the mirror direction only: glossy reflectors show as perfect mirrors.
    MirrorOnly,
}

impl GlossyLobe {
    /// Whether the method renders the lobe by cone tracing (once per frame, not by samples).
    pub fn cone_traced(self) -> bool {
        matches!(
            self,
            GlossyLobe::ConeTracedFirst | GlossyLobe::ConeTracedOnly
        )
    }
}

impl Method {
    /// Every method, in the order the CLI and the harness list them.
    pub const ALL: [Method; 7] = [
        Method::Reference,
        Method::Envmap,
        Method::Fragment,
        Method::Compute,
        Method::Ssr,
        Method::ReflectionPoint,
        Method::Bvh,
    ];

    /// The GPU methods.
    pub const GPU: [Method; 6] = [
        Method::Envmap,
        Method::Fragment,
        Method::Compute,
        Method::Ssr,
        Method::ReflectionPoint,
        Method::Bvh,
    ];

    /// The method `render` and `bench` use when none is given, and the library's
    /// [`RenderOptions`](crate::vk::options::RenderOptions) default.
    pub const DEFAULT: Method = Method::Compute;

    /// The ground truth every figure is measured against (the exact CPU ray tracer).
    pub const TRUTH: Method = Method::Reference;

    /// The exact GPU tracer: the bench's baseline of cost and accuracy, the cost model's
    /// reference row, and the glossy bench's Monte Carlo ladder.
    pub const EXACT_GPU: Method = Method::Bvh;

    /// The method whose cost curves `bench --scaling` draws.
    pub const SCALING: Method = Method::Fragment;

    /// What the method is and supports, from its own file under `src/method/` (one line per
    /// method: the registry).
    pub fn info(self) -> &'static MethodInfo {
        match self {
            Method::Compute => &compute::INFO,
            Method::Fragment => &fragment::INFO,
            Method::Envmap => &envmap::INFO,
            Method::Ssr => &ssr::INFO,
            Method::ReflectionPoint => &reflection_point::INFO,
            Method::Bvh => &bvh::INFO,
            Method::Reference => &reference::INFO,
        }
    }

    /// The name on the command line, in file names and in the harness's tables.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The method named `name` (the CLI's spelling).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether the method runs on the GPU (every method but the reference).
    pub fn is_gpu(self) -> bool {
        self.info().gpu
    }

    /// Whether the method runs the cubemap tracer, so that the tracer options (criterion,
    /// sampling, acceleration, strict, steps, eps) matter.
    pub fn traces_cubemaps(self) -> bool {
        self.info().traces_cubemaps
    }

    /// Whether the method reads the CMOs' data for its own result (not only for an
    /// environment-map fallback): the cubemap tracers and the environment map.
    pub fn reads_cmos(self) -> bool {
        self.info().reads_cmos
    }

    /// Whether the method has lane layouts to choose from (`--compute-layout`: compute's
    /// `main`, `main_lanes1` and `main_wave`).
    pub fn has_lane_layouts(self) -> bool {
        reads(self, "--compute-layout")
    }

    /// Whether the method traces the reflections after the first with its own cube maps, so
    /// that `--bvh-bounces` (the BVH for them instead) is a comparison to run.
    pub fn traces_bounce_rounds(self) -> bool {
        reads(self, "--bvh-bounces")
    }

    /// Whether the method can leave a mirror pixel unresolved, so that `--fallback` matters.
    pub fn can_leave_unresolved(self) -> bool {
        self.info().can_leave_unresolved
    }

    /// Whether the reflector check (the exact trace of the reflectors the CMOs do not capture)
    /// applies to the method.
    pub fn has_reflector_check(self) -> bool {
        self.traces_cubemaps()
    }

    /// Whether the method's records name the triangle they hit (verified hits), so that further
    /// reflections can be traced from them: compute, bvh, the reference, and fragment with the
    /// bounded or centre criterion.
    pub fn names_hits(self, criterion: TraceCriterion) -> bool {
        match self.info().names_hits {
            NamesHits::Always => true,
            NamesHits::Never => false,
            NamesHits::CentreOrBounded => {
                matches!(criterion, TraceCriterion::Centre | TraceCriterion::Bounded)
            }
        }
    }

    /// What the method makes of a glossy reflector's lobe.
    pub fn glossy(self) -> GlossyLobe {
        self.info().glossy
    }

    /// Why the method, by its nature, leaves mirror pixels to the fallback: the likely cause
    /// that `render`'s fallback warning names (`None`: no known limit of the method).
    pub fn known_limit(self) -> Option<&'static str> {
        self.info().known_limit
    }

    /// Refuses a bounce count the method cannot trace: more than `max`, or other than 1 for a
    /// method whose records do not name the hit triangle (N = 0, the mirrors' own material, is
    /// open to fragment whatever its criterion).
    pub fn check_bounces(
        self,
        bounces: u32,
        max: u32,
        trace: &TraceOptions,
    ) -> Result<(), Refusal> {
        if bounces > max {
            return Err(format!("--bounces {bounces}: at most {max}"));
        }
        let by_criterion = self.info().names_hits == NamesHits::CentreOrBounded;
        let named = self.names_hits(trace.criterion) || (by_criterion && bounces == 0);
        if bounces != 1 && !named {
            let with = if by_criterion {
                format!(" with --criterion {}", criterion_name(trace.criterion))
            } else {
                String::new()
            };
            return Err(format!(
                "--bounces {bounces}: --method {}{with} does not name the triangle it hits, so it \
                 traces one reflection only (use compute, bvh, reference or fragment with the \
                 bounded or centre criterion)",
                self.name()
            ));
        }
        Ok(())
    }

    /// Whether the method captures CMOs (every GPU method but bvh), so that `--cmos` and
    /// `--cube-size` matter.
    pub fn captures_cmos(self) -> bool {
        self.info().captures_cmos
    }

    /// Refuses the first option of `given` (flags as typed, those of [`METHOD_OPTIONS`]) that
    /// this method with the tracer options `trace` does not read, then what
    /// [`Method::check_trace`] refuses. A flag not in the table is every method's.
    pub fn check_options(self, given: &[&str], trace: &TraceOptions) -> Result<(), Refusal> {
        for flag in given {
            if let Some(o) = method_option(flag)
                && !(o.applies)(self, trace)
            {
                return Err(o.refusal(self));
            }
        }
        self.check_trace(trace)
    }

    /// Refuses tracer options the method does not implement (a cubemap tracer without
    /// [`MethodInfo::approximate_criteria`]: the bounded and centre criteria only).
    pub fn check_trace(self, trace: &TraceOptions) -> Result<(), Refusal> {
        let info = self.info();
        if info.traces_cubemaps && !info.approximate_criteria && trace.approx().is_some() {
            return Err(format!(
                "--criterion {}: --method {self} implements the bounded and centre criteria only \
                 (use --method fragment for the approximate criteria)",
                criterion_name(trace.criterion)
            ));
        }
        Ok(())
    }
}

/// A command-line option that only some methods read (`render`'s and `bench`'s): the one table
/// from which both commands refuse an option the chosen method would ignore.
#[derive(Clone, Copy, Debug)]
pub struct MethodOption {
    /// The flag as typed: `--ssr-iterations`.
    pub flag: &'static str,
    /// Whether `method` with the tracer options `trace` reads the option.
    pub applies: fn(Method, &TraceOptions) -> bool,
    /// The condition on the tracer options, in the CLI's words, for the refusal (empty when
    /// the method alone decides): ` with --criterion threshold`.
    pub condition: &'static str,
    /// The methods that read it in the CLI's words where the list of their names would say
    /// less (`the GPU methods`); empty: the list of [`MethodOption::methods`].
    pub methods_text: &'static str,
    /// Why a method outside the list ignores it, for the refusal (` (it runs on the CPU)`);
    /// may be empty.
    pub why: &'static str,
}

/// The tracer options of every criterion and sampling (the defaults otherwise): the settings
/// over which [`MethodOption::methods`] asks whether a method can read an option.
fn every_trace_setting() -> impl Iterator<Item = TraceOptions> {
    use crate::cpu::options::TraceSampling;
    [
        TraceCriterion::Centre,
        TraceCriterion::Threshold,
        TraceCriterion::SignChange,
        TraceCriterion::Bounded,
    ]
    .into_iter()
    .flat_map(|criterion| {
        [
            TraceSampling::PerTexel,
            TraceSampling::ConstantStep,
            TraceSampling::ConstantAngle,
        ]
        .map(|sampling| TraceOptions {
            criterion,
            sampling,
            ..TraceOptions::default()
        })
    })
}

impl MethodOption {
    /// The methods that read the option under some tracer setting, in [`Method::ALL`] order.
    pub fn methods(&self) -> Vec<Method> {
        Method::ALL
            .into_iter()
            .filter(|&m| every_trace_setting().any(|t| (self.applies)(m, &t)))
            .collect()
    }

    /// `--ssr-iterations applies only to --method ssr`, `... to --method compute or fragment
    /// with ...`: the refusal of the option with a method that ignores it.
    pub fn refusal(&self, method: Method) -> Refusal {
        let flag = self.flag;
        if self.methods().contains(&method) {
            // The method reads it, but not under the tracer options given.
            return format!(
                "{flag} applies to --method {method} only{}: leave {flag} out or set that",
                self.condition
            );
        }
        let names: Vec<&str> = self.methods().iter().map(|m| m.name()).collect();
        let list = if !self.methods_text.is_empty() {
            self.methods_text.to_string()
        } else {
            match names.split_last() {
                Some((last, [])) => format!("--method {last}"),
                Some((last, rest)) => format!("--method {} or {last}", rest.join(", ")),
                None => "no method".into(),
            }
        };
        format!(
            "{flag} applies only to {list}{}, not to --method {method}{}: leave it out",
            self.condition, self.why
        )
    }
}

/// Whether `m` lists `flag` among its own options ([`MethodInfo::options`]).
fn reads(m: Method, flag: &str) -> bool {
    m.info().options.contains(&flag)
}

/// Every method-specific option of `render` and `bench`. Options every method reads
/// (`--width`, `--bounces`, `--subdivide`, ...) are not listed; `--bounces` has its own rule
/// ([`Method::check_bounces`]), and so has `--criterion` with compute ([`Method::check_trace`]).
pub const METHOD_OPTIONS: &[MethodOption] = &[
    MethodOption {
        flag: "--criterion",
        applies: |m, _| m.traces_cubemaps(),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--sampling",
        applies: |m, t| reads(m, "--sampling") && t.approx().is_some(),
        condition: " with --criterion threshold or sign-change",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--steps",
        applies: |m, t| {
            reads(m, "--steps")
                && t.approx().is_some()
                && t.sampling != crate::cpu::options::TraceSampling::PerTexel
        },
        condition: " with --criterion threshold or sign-change and --sampling constant-step or \
                    constant-angle",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--eps",
        applies: |m, t| reads(m, "--eps") && t.criterion == TraceCriterion::Threshold,
        condition: " with --criterion threshold",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--no-accel",
        applies: |m, t| reads(m, "--no-accel") && t.criterion == TraceCriterion::Centre,
        condition: " with --criterion centre",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--compute-layout",
        applies: |m, _| reads(m, "--compute-layout"),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--bvh-bounces",
        applies: |m, _| reads(m, "--bvh-bounces"),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--list-size",
        applies: |m, t| m.traces_cubemaps() && t.criterion == TraceCriterion::Bounded,
        condition: " with the bounded criterion (the default)",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--strict",
        applies: |m, t| reads(m, "--strict") && t.criterion == TraceCriterion::Centre,
        condition: " with --criterion centre",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--quick",
        applies: |m, _| reads(m, "--quick"),
        condition: " (its parameter grid)",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--cmos",
        applies: |m, _| m.captures_cmos(),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--placement",
        applies: |m, _| m.captures_cmos(),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--cube-size",
        applies: |m, _| m.captures_cmos(),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--fallback",
        applies: |m, _| m.can_leave_unresolved(),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--no-reflector-check",
        applies: |m, _| m.has_reflector_check(),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--ssr-iterations",
        applies: |m, _| reads(m, "--ssr-iterations"),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--ssr-thickness",
        applies: |m, _| reads(m, "--ssr-thickness"),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--rp-iterations",
        applies: |m, _| reads(m, "--rp-iterations"),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--rp-scale",
        applies: |m, _| reads(m, "--rp-scale"),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--rp-open",
        applies: |m, _| reads(m, "--rp-open"),
        condition: "",
        methods_text: "",
        why: "",
    },
    MethodOption {
        flag: "--compare",
        applies: |m, _| m.is_gpu(),
        condition: "",
        methods_text: "the GPU methods",
        why: " (it would compare the reference with itself)",
    },
    MethodOption {
        flag: "--compare-spp",
        applies: |m, _| m.is_gpu(),
        condition: "",
        methods_text: "the GPU methods (with --compare)",
        why: " (it sets --compare's converged reference)",
    },
    MethodOption {
        flag: "--device",
        applies: |m, _| m.is_gpu(),
        condition: "",
        methods_text: "the GPU methods",
        why: " (it runs on the CPU)",
    },
    MethodOption {
        flag: "--validate",
        applies: |m, _| m.is_gpu(),
        condition: "",
        methods_text: "the GPU methods",
        why: " (it runs on the CPU)",
    },
];

/// The entry of [`METHOD_OPTIONS`] for `flag`.
pub fn method_option(flag: &str) -> Option<&'static MethodOption> {
    METHOD_OPTIONS.iter().find(|o| o.flag == flag)
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The CLI's name of a criterion.
pub fn criterion_name(c: TraceCriterion) -> &'static str {
    match c {
        TraceCriterion::Centre => "centre",
        TraceCriterion::Threshold => "threshold",
        TraceCriterion::SignChange => "sign-change",
        TraceCriterion::Bounded => "bounded",
    }
}

/// The CLI's name of a sampling.
pub fn sampling_name(s: crate::cpu::options::TraceSampling) -> &'static str {
    use crate::cpu::options::TraceSampling;
    match s {
        TraceSampling::ConstantStep => "constant-step",
        TraceSampling::ConstantAngle => "constant-angle",
        TraceSampling::PerTexel => "per-texel",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_the_cli_names_and_round_trip() {
        for m in Method::ALL {
            let v = m.to_possible_value().expect("no method is skipped");
            assert_eq!(v.get_name(), m.name());
            assert_eq!(Method::from_name(m.name()), Some(m));
            assert_eq!(
                serde_json::to_string(&m).expect("serialises"),
                format!("\"{}\"", m.name())
            );
        }
        assert_eq!(Method::from_name("Compute"), None);
        assert_eq!(Method::GPU.len() + 1, Method::ALL.len());
        assert!(Method::GPU.iter().all(|m| m.is_gpu()));
    }

    /// The cases, then every option of the table against every method and tracer
    /// setting: refused exactly where its rule says the method ignores it.
    #[test]
    fn method_options_are_refused_where_ignored() {
        let centre = TraceOptions::centre();
        let e = Method::Compute
            .check_options(&["--ssr-iterations"], &centre)
            .unwrap_err();
        assert!(
            e.starts_with("--ssr-iterations applies only to --method ssr, not to --method compute"),
            "{e}"
        );
        for flag in ["--strict", "--no-accel", "--steps"] {
            let e = Method::Bvh.check_options(&[flag], &centre).unwrap_err();
            assert!(
                e.starts_with(flag) && e.contains("not to --method bvh"),
                "{e}"
            );
        }
        let e = Method::Reference
            .check_options(&["--compare"], &centre)
            .unwrap_err();
        assert!(e.contains("compare the reference with itself"), "{e}");
        for o in METHOD_OPTIONS {
            for m in Method::ALL {
                for t in every_trace_setting() {
                    if m.check_trace(&t).is_err() {
                        continue;
                    }
                    let refused = m.check_options(&[o.flag], &t).is_err();
                    assert_eq!(refused, !(o.applies)(m, &t), "{} {m} {t:?}", o.flag);
                }
            }
        }
        // The table against what the methods are known to read (written out, not derived).
        let fragment_compute = vec![Method::Fragment, Method::Compute];
        assert_eq!(
            method_option("--no-reflector-check").unwrap().methods(),
            fragment_compute
        );
        assert_eq!(
            method_option("--fallback").unwrap().methods(),
            [
                Method::Fragment,
                Method::Compute,
                Method::Ssr,
                Method::ReflectionPoint
            ]
        );
        assert_eq!(
            method_option("--strict").unwrap().methods(),
            [Method::Fragment]
        );
        assert!(
            !method_option("--cube-size")
                .unwrap()
                .methods()
                .contains(&Method::Bvh)
        );
        // Negative: each method keeps the options it reads, and flags outside the table pass.
        assert!(
            Method::Ssr
                .check_options(&["--ssr-iterations"], &centre)
                .is_ok()
        );
        assert!(
            Method::Fragment
                .check_options(&["--strict", "--no-accel"], &centre)
                .is_ok()
        );
        let threshold = TraceOptions {
            criterion: TraceCriterion::Threshold,
            ..centre
        };
        assert!(
            Method::Fragment
                .check_options(&["--eps", "--sampling"], &threshold)
                .is_ok()
        );
        assert!(
            Method::Bvh
                .check_options(&["--width", "--bounces"], &centre)
                .is_ok()
        );
        // With the method right but the tracer setting wrong, the message says which setting.
        let e = Method::Fragment
            .check_options(&["--eps"], &centre)
            .unwrap_err();
        assert!(e.contains("only with --criterion threshold"), "{e}");
    }

    #[test]
    fn bounce_rule() {
        let centre = TraceOptions::centre();
        let threshold = TraceOptions {
            criterion: TraceCriterion::Threshold,
            ..centre
        };
        for m in [
            Method::Compute,
            Method::Bvh,
            Method::Reference,
            Method::Fragment,
        ] {
            assert!(m.check_bounces(3, 16, &centre).is_ok(), "{m}");
        }
        for m in [Method::Envmap, Method::Ssr, Method::ReflectionPoint] {
            assert!(m.check_bounces(1, 16, &centre).is_ok(), "{m}");
            let e = m.check_bounces(2, 16, &centre).unwrap_err();
            assert!(e.contains(m.name()), "{e}");
        }
        assert!(Method::Fragment.check_bounces(2, 16, &threshold).is_err());
        assert!(Method::Fragment.check_bounces(0, 16, &threshold).is_ok());
        assert!(Method::Compute.check_bounces(17, 16, &centre).is_err());
    }

    #[test]
    fn bounded_criterion_rules() {
        let bounded = TraceOptions {
            criterion: TraceCriterion::Bounded,
            ..TraceOptions::default()
        };
        // Both cubemap tracers implement it and name their hits (so further bounces trace on).
        for m in [Method::Compute, Method::Fragment] {
            assert!(m.check_options(&["--criterion"], &bounded).is_ok(), "{m}");
            assert!(m.check_bounces(3, 16, &bounded).is_ok(), "{m}");
        }
        assert_eq!(criterion_name(TraceCriterion::Bounded), "bounded");
        // It is the default, so a bare `--strict` is refused (it asks for the centre criterion).
        assert_eq!(TraceOptions::default().criterion, TraceCriterion::Bounded);
        let e = Method::Fragment
            .check_options(&["--strict"], &TraceOptions::default())
            .unwrap_err();
        assert!(e.contains("--criterion centre"), "{e}");
        // The centre criterion's and the approximate criteria's options do not apply to it.
        for flag in ["--strict", "--no-accel", "--sampling", "--steps", "--eps"] {
            let e = Method::Fragment
                .check_options(&[flag], &bounded)
                .unwrap_err();
            assert!(e.starts_with(flag), "{e}");
        }
        // Negative: compute still refuses the approximate criteria.
        let threshold = TraceOptions {
            criterion: TraceCriterion::Threshold,
            ..bounded
        };
        let e = Method::Compute.check_trace(&threshold).unwrap_err();
        assert!(e.contains("bounded and centre"), "{e}");
    }
}

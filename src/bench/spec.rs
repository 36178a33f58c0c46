#![forbid(unsafe_code)]
//! The methods a bench runs: a [`Method`] with its tracer options ([`MethodSpec`]), its label,
//! its render options in a run, and the grids of settings ([`fragment_grid`], [`method_grid`]).

use crate::cpu::options::{TraceCriterion, TraceOptions, TraceSampling};
use crate::method::Method;
use crate::vk::frame::{ComputeLayout, RenderOptions};

/// One method with its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MethodSpec {
    pub kind: Method,
    /// Used when [`Method::traces_cubemaps`].
    pub trace: TraceOptions,
    /// The non-reflector objects split into four this many times for this run
    /// ([`crate::cpu::reflection_point::subdivide_non_reflectors`]): the same surfaces, so the
    /// same reference. Used for the reflection-point method, whose quality depends on it.
    pub subdivide: u32,
    /// compute's lane layout for this run (`None`: the device's default): the full grid sets
    /// the three side by side (`compute-thesis`, `compute-one-lane`, `compute-wave`).
    pub layout: Option<ComputeLayout>,
    /// [`RenderOptions::bvh_bounces`]: with `--bounces N`, the BVH traces the reflections after
    /// the first instead of the method's cube maps (`compute-bvh-bounces`; [`with_bvh_bounces`]).
    pub bvh_bounces: bool,
}

/// The subdivision of the second reflection-point row of the grid.
pub const RP_BENCH_SUBDIVIDE: u32 = 2;

impl MethodSpec {
    /// The method's default setting (for a cube-map tracer, the bounded criterion).
    pub fn plain(kind: Method) -> Self {
        MethodSpec {
            kind,
            trace: TraceOptions::default(),
            subdivide: 0,
            layout: None,
            bvh_bounces: false,
        }
    }

    /// The method with the centre-sampled criterion (its other options the defaults).
    pub fn centre(kind: Method) -> Self {
        MethodSpec {
            trace: TraceOptions::centre(),
            ..MethodSpec::plain(kind)
        }
    }

    /// The setting the cost model replays ([`crate::model`]): the centre criterion for a
    /// cube-map tracer (the bounded criterion's list walk is not modelled), else the default.
    pub fn modelled(kind: Method) -> Self {
        if kind.traces_cubemaps() {
            MethodSpec::centre(kind)
        } else {
            MethodSpec::plain(kind)
        }
    }

    /// The renderer's options of this method in a bench run, with the default fallback
    /// ([`Fallback::Trace`](crate::vk::options::Fallback::Trace), as the CLI's: PSNR and FLIP
    /// measure the image a user would see; the fallback's share is counted and timed apart).
    pub fn render_options(&self, bounces: u32, reflector_check: bool) -> RenderOptions {
        RenderOptions {
            method: self.kind,
            trace: self.trace,
            bounces,
            reflector_check,
            compute_layout: self.layout,
            bvh_bounces: self.bvh_bounces,
            ..RenderOptions::default()
        }
    }

    /// A short unique name, also used in file names: `compute` (the default, bounded),
    /// `compute-centre`, `fragment-bounded`, `fragment-centre-mip`,
    /// `fragment-threshold-step64`, `envmap`, ...
    pub fn label(&self) -> String {
        if self.bvh_bounces {
            let plain = MethodSpec {
                bvh_bounces: false,
                ..*self
            };
            return format!("{}-bvh-bounces", plain.label());
        }
        if let Some(layout) = self.layout {
            let plain = MethodSpec {
                layout: None,
                ..*self
            };
            return format!("{}-{}", plain.label(), layout.name());
        }
        if self.subdivide > 0 {
            let plain = MethodSpec {
                subdivide: 0,
                ..*self
            };
            return format!("{}-sub{}", plain.label(), self.subdivide);
        }
        // A cubemap tracer without the approximate criteria (compute) has two settings: the
        // bounded criterion (the default, named by the method alone) and the centre one.
        let info = self.kind.info();
        if info.traces_cubemaps
            && !info.approximate_criteria
            && self.trace.criterion == TraceCriterion::Centre
        {
            return format!("{}-centre", self.kind.name());
        }
        if !info.traces_cubemaps || !info.approximate_criteria {
            return self.kind.name().into();
        }
        let t = &self.trace;
        let sampling = match t.sampling {
            TraceSampling::PerTexel => "texel".to_string(),
            TraceSampling::ConstantStep => format!("step{}", t.steps),
            TraceSampling::ConstantAngle => format!("angle{}", t.steps),
        };
        match t.criterion {
            TraceCriterion::Centre => format!(
                "{}-centre-{}{}",
                self.kind.name(),
                if t.accel { "mip" } else { "walk" },
                if t.strict { "-strict" } else { "" }
            ),
            TraceCriterion::Threshold => format!("{}-threshold-{sampling}", self.kind.name()),
            TraceCriterion::SignChange => format!("{}-sign-{sampling}", self.kind.name()),
            TraceCriterion::Bounded => format!("{}-bounded", self.kind.name()),
        }
    }
}

/// The study grid of a tracing method beside its default (the bounded criterion, which
/// [`method_grid`] adds): the centre criterion with and without the min/max pyramid and in
/// strict mode, and the threshold and sign-change criteria with per-texel,
/// 64 and 256 constant steps, and 256 constant-angle steps (`eps` stays at its default, 0.05
/// world units: the built-in scenes are a few metres across).
pub fn fragment_grid(kind: Method) -> Vec<MethodSpec> {
    let base = MethodSpec::centre(kind).trace;
    let mut out = vec![
        TraceOptions {
            accel: true,
            ..base
        },
        TraceOptions {
            accel: false,
            ..base
        },
        TraceOptions {
            strict: true,
            ..base
        },
    ];
    for criterion in [TraceCriterion::Threshold, TraceCriterion::SignChange] {
        for (sampling, steps) in [
            (TraceSampling::PerTexel, base.steps),
            (TraceSampling::ConstantStep, 64),
            (TraceSampling::ConstantStep, 256),
            (TraceSampling::ConstantAngle, 256),
        ] {
            out.push(TraceOptions {
                criterion,
                sampling,
                steps,
                ..base
            });
        }
    }
    out.into_iter()
        .map(|trace| MethodSpec {
            kind,
            trace,
            ..MethodSpec::plain(kind)
        })
        .collect()
}

/// The full method list for the chosen kinds, in table order. A cube-map tracer runs its
/// default (the bounded criterion) first, then (unless `quick`) its lane layouts, then the
/// centre criterion (`quick`, or a tracer without the approximate criteria) or the whole
/// study grid ([`fragment_grid`]).
pub fn method_grid(kinds: &[Method], quick: bool) -> Vec<MethodSpec> {
    let mut out = Vec::new();
    for &kind in kinds {
        out.push(MethodSpec::plain(kind));
        if kind.traces_cubemaps() {
            // The lane layouts side by side (compute's three: the same records; `--quick` runs
            // the device's default alone).
            if kind.has_lane_layouts() && !quick {
                out.extend(
                    [
                        ComputeLayout::Thesis,
                        ComputeLayout::OneLane,
                        ComputeLayout::Wave,
                    ]
                    .map(|l| MethodSpec {
                        layout: Some(l),
                        ..MethodSpec::plain(kind)
                    }),
                );
            }
            // The centre-sampled criterion (and the approximate ones) beside the default.
            if quick || !kind.info().approximate_criteria {
                out.push(MethodSpec::centre(kind));
            } else {
                out.extend(fragment_grid(kind));
            }
        } else if kind.info().vertex_search {
            out.push(MethodSpec {
                subdivide: RP_BENCH_SUBDIVIDE,
                ..MethodSpec::plain(kind)
            });
        }
    }
    out
}

/// `specs` with, after each spec of a method that traces the later reflections with its cube
/// maps ([`Method::traces_bounce_rounds`]) in the device's default layout, the same spec with
/// the BVH tracing them ([`MethodSpec::bvh_bounces`]): the grid at `--bounces N > 1` sets the
/// two side by side.
pub fn with_bvh_bounces(specs: Vec<MethodSpec>) -> Vec<MethodSpec> {
    let mut out = Vec::new();
    for s in specs {
        out.push(s);
        if s.kind.traces_bounce_rounds() && s.layout.is_none() && !s.bvh_bounces {
            out.push(MethodSpec {
                bvh_bounces: true,
                ..s
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_unique_across_the_grid() {
        let grid = method_grid(&Method::ALL, false);
        let mut labels: Vec<String> = grid.iter().map(MethodSpec::label).collect();
        let n = labels.len();
        labels.sort();
        labels.dedup();
        assert_eq!(labels.len(), n, "{labels:?}");
        assert!(labels.contains(&"fragment-centre-mip".to_string()));
        assert!(labels.contains(&"fragment-bounded".to_string()));
        assert!(labels.contains(&"compute".to_string()));
        assert!(labels.contains(&"compute-centre".to_string()));
        assert_eq!(MethodSpec::plain(Method::Compute).label(), "compute");
        assert_eq!(
            MethodSpec::modelled(Method::Compute).label(),
            "compute-centre"
        );
        assert_eq!(MethodSpec::modelled(Method::Bvh).label(), "bvh");
        assert!(labels.contains(&"fragment-sign-angle256".to_string()));
        assert!(labels.contains(&"compute-wave".to_string()));
        assert!(labels.contains(&"compute-thesis".to_string()));
        // `--quick` runs compute in the device's layout only.
        let quick = method_grid(&[Method::Compute], true);
        assert!(quick.iter().all(|s| s.layout.is_none()), "{quick:?}");
        // Negative: two specs differing only in steps must get different labels.
        let a = fragment_grid(Method::Fragment)[4];
        assert_eq!(a.trace.criterion, TraceCriterion::Threshold);
        let mut b = a;
        b.trace.steps += 1;
        assert_ne!(a.label(), b.label());
    }

    #[test]
    fn method_names_round_trip() {
        for m in Method::ALL {
            assert_eq!(Method::from_name(m.name()), Some(m));
        }
        assert_eq!(Method::from_name("raytrace"), None);
    }
}

//! The tracer's method options, as the CLI exposes them and as both tracers read them: the CPU
//! twins here, the GPU tracer (`spirv/shared/trace.wgsl`) through
//! [`crate::vk::passes::cmo::TraceConfig`], built from the same [`TraceOptions`].
//!
//! Invariant: [`trace_ray`] is the CPU twin of the WGSL `trace_ray`: for the same CMOs (built
//! with [`TraceOptions::params`]) and the same options, the GPU must give the same status, CMO,
//! texel and riser flag, and (see `tests/tracer/gpu_twin.rs`) the same `t` and point bits.

use glam::Vec3;

use super::approx::{Criterion, Sampling, trace_sampled};
use super::multi::{MultiResult, Traversal, trace_cmos, trace_cmos_by};
use super::{CmoTracer, TraceParams};

/// Which intersection criterion decides a hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TraceCriterion {
    /// The default. Sound per-texel bounds and candidate lists ([`crate::cubemap::bounds`]): a
    /// hit is the nearest intersection with a listed triangle where the list is complete,
    /// provably the first along the ray. Not approximate: [`TraceOptions::approx`] is `None`.
    /// Its CPU twin is [`crate::cpu::bounded`], not [`trace_ray`].
    #[default]
    Bounded,
    /// The centre-sampled capture's per-texel sphere-patch model with the continuity rule
    /// ([`super`]): exact for the surface the texel centres saw, blind to geometry between
    /// them (a thin or distant triangle can hide behind a hit). Like the bounded criterion,
    /// unlike the approximate ones, it has a "behind" outcome and hence the several-CMO handoff.
    Centre,
    /// `|r - D| < eps` at samples ([`Criterion::Threshold`]).
    Threshold,
    /// `r - D` changes sign between samples ([`Criterion::SignChange`]).
    SignChange,
}

/// Sample placement of the approximate criteria (ignored by the others).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TraceSampling {
    /// `steps + 1` samples evenly spaced in `t`.
    ConstantStep,
    /// `steps + 1` samples evenly spaced between the endpoint directions.
    ConstantAngle,
    /// One sample per crossed texel.
    #[default]
    PerTexel,
}

/// Method options of the tracer (CPU and GPU).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceOptions {
    /// Intersection criterion. Default: [`TraceCriterion::Bounded`].
    pub criterion: TraceCriterion,
    /// Sampling of the approximate criteria. Default: [`TraceSampling::PerTexel`].
    pub sampling: TraceSampling,
    /// Centre criterion: march the 2x2 min/max pyramid ([`super::mip`]) instead of walking every
    /// texel ([`super::walk`]). Same results either way; default `true` (faster).
    pub accel: bool,
    /// Sample intervals of constant-step / constant-angle sampling (`steps + 1` samples;
    /// the GPU accepts at most 65536). Default 400.
    pub steps: u32,
    /// Threshold of [`TraceCriterion::Threshold`], world units. Default 0.05.
    pub eps: f32,
    /// `k` of the continuity rule ([`super::continuous`]). Default `tan(80 deg)`.
    pub continuity_k: f32,
    /// Centre criterion: count a patch hit only when the texel data decides it (see
    /// [`super`], "Decisive patch hits"); never a silent wrong hit, more unresolved pixels.
    /// Default `false`.
    pub strict: bool,
}

impl Default for TraceOptions {
    fn default() -> Self {
        TraceOptions {
            criterion: TraceCriterion::Bounded,
            sampling: TraceSampling::PerTexel,
            accel: true,
            steps: 400,
            eps: 0.05,
            continuity_k: TraceParams::default().continuity_k,
            strict: false,
        }
    }
}

impl TraceOptions {
    /// The centre criterion's options, the others the defaults (`--criterion centre`).
    pub fn centre() -> Self {
        TraceOptions {
            criterion: TraceCriterion::Centre,
            ..TraceOptions::default()
        }
    }

    /// The per-CMO parameters to build [`CmoTracer`]s with.
    pub fn params(&self) -> TraceParams {
        TraceParams {
            continuity_k: self.continuity_k,
            strict: self.strict,
        }
    }

    /// The CPU traversal of the centre criterion.
    pub fn traversal(&self) -> Traversal {
        if self.accel {
            Traversal::Mip
        } else {
            Traversal::Walk
        }
    }

    /// The approximate criterion and sampling, or `None` for the centre and bounded criteria.
    pub fn approx(&self) -> Option<(Criterion, Sampling)> {
        let criterion = match self.criterion {
            TraceCriterion::Centre | TraceCriterion::Bounded => return None,
            TraceCriterion::Threshold => Criterion::Threshold(self.eps),
            TraceCriterion::SignChange => Criterion::SignChange,
        };
        let sampling = match self.sampling {
            TraceSampling::ConstantStep => Sampling::ConstantStep(self.steps),
            TraceSampling::ConstantAngle => Sampling::ConstantAngle(self.steps),
            TraceSampling::PerTexel => Sampling::PerTexel,
        };
        Some((criterion, sampling))
    }
}

/// Traces the world ray `origin + t dir`, `t in [t_lo, t_hi]`, over the CMOs with the options:
/// the CPU twin of the WGSL `trace_ray`. The CMOs' own [`TraceParams`] are used (build them
/// with [`TraceOptions::params`]). Not for [`TraceCriterion::Bounded`], whose twin needs the
/// candidate lists ([`crate::cpu::bounded`]).
pub fn trace_ray(
    cmos: &[CmoTracer],
    origin: Vec3,
    dir: Vec3,
    t_lo: f32,
    t_hi: f32,
    opts: &TraceOptions,
) -> MultiResult {
    debug_assert!(
        opts.criterion != TraceCriterion::Bounded,
        "trace_ray is the centre and approximate criteria's twin; the bounded one is cpu::bounded"
    );
    match opts.approx() {
        None => trace_cmos(cmos, origin, dir, t_lo, t_hi, opts.traversal()),
        Some((crit, sampling)) => trace_cmos_by(cmos, origin, dir, t_lo, t_hi, |tr, seg| {
            trace_sampled(tr, seg, crit, sampling)
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_bounded_with_the_pyramid() {
        let o = TraceOptions::default();
        assert_eq!(o.criterion, TraceCriterion::Bounded);
        assert_eq!(o.approx(), None);
        assert_eq!(o.traversal(), Traversal::Mip);
        assert_eq!(o.params(), TraceParams::default());
        let walk = TraceOptions { accel: false, ..o };
        assert_eq!(walk.traversal(), Traversal::Walk);
    }

    #[test]
    fn approximate_options_map_to_the_cpu_criteria() {
        let o = TraceOptions {
            criterion: TraceCriterion::Threshold,
            sampling: TraceSampling::ConstantAngle,
            steps: 7,
            eps: 0.25,
            ..TraceOptions::default()
        };
        assert_eq!(
            o.approx(),
            Some((Criterion::Threshold(0.25), Sampling::ConstantAngle(7)))
        );
        let s = TraceOptions {
            criterion: TraceCriterion::SignChange,
            sampling: TraceSampling::ConstantStep,
            ..o
        };
        assert_eq!(
            s.approx(),
            Some((Criterion::SignChange, Sampling::ConstantStep(7)))
        );
    }
}

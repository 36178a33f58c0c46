#![forbid(unsafe_code)]
//! The one method type: every way of computing reflections that the renderer, the command line
//! and the harness know, with what each supports.
//!
//! [`Method`] is the command line's `--method` (a clap [`ValueEnum`]), the harness's method
//! column (its serde name is the CLI's) and the GPU renderer's choice. The rules that decide
//! what a method supports (bounces, fallback, reflector check, tracer options) are written here
//! once, as data and pure functions, so the CLI, the bench and the renderer cannot disagree.
//! Nothing here touches the GPU: the passes a method records live in `vk::methods`.
use clap::ValueEnum;
use serde::Serialize;

use crate::cpu::options::{TraceCriterion, TraceOptions};

/// How reflections are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Cubemap tracing in a compute pass on the GPU over the 8x4/4x8 hierarchy with subgroup
    /// ballots (thesis alg. 3; exact criterion).
    Compute,
    /// Cubemap tracing in a deferred fragment pass on the GPU (thesis alg. 1, 2, 4).
    Fragment,
    /// One cube map lookup per pixel on the GPU, no parallax (the baseline).
    Envmap,
    /// Hi-Z screen-space reflections on the GPU (Uludag 2014): a min pyramid of the G-buffer's
    /// depth and a hierarchical ray march; what leaves the screen goes to the fallback.
    Ssr,
    /// Reflection-point search with virtual objects on the GPU (Estalella et al. 2006): per
    /// vertex of the other objects, a local search over the reflector's position and normal
    /// textures; the virtual objects rasterised into the mirror; uncovered pixels get the fallback.
    ReflectionPoint,
    /// Exact ray tracing of the reflected rays on the GPU: a compute pass over a compressed wide
    /// BVH (obvhs), the same triangles and shading as the reference.
    Bvh,
    /// Exact CPU ray tracing against the scene's triangles: the ground truth.
    Reference,
}

/// Why a method refuses a setting: the CLI's words, for the user.
pub type Refusal = String;

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

    /// The name on the command line, in file names and in the harness's tables.
    pub fn name(self) -> &'static str {
        match self {
            Method::Reference => "reference",
            Method::Envmap => "envmap",
            Method::Fragment => "fragment",
            Method::Compute => "compute",
            Method::Ssr => "ssr",
            Method::ReflectionPoint => "reflection-point",
            Method::Bvh => "bvh",
        }
    }

    /// The method named `name` (the CLI's spelling).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether the method runs on the GPU (every method but the reference).
    pub fn is_gpu(self) -> bool {
        self != Method::Reference
    }

    /// Whether the method runs the cubemap tracer, so that the tracer options (criterion,
    /// sampling, acceleration, strict, steps, eps) matter.
    pub fn traces_cubemaps(self) -> bool {
        matches!(self, Method::Fragment | Method::Compute)
    }

    /// Whether the method reads the CMOs' data for its own result (not only for an
    /// environment-map fallback): the cubemap tracers and the environment map.
    pub fn reads_cmos(self) -> bool {
        matches!(self, Method::Fragment | Method::Compute | Method::Envmap)
    }

    /// Whether the method can leave a mirror pixel unresolved, so that `--fallback` matters.
    pub fn can_leave_unresolved(self) -> bool {
        !matches!(self, Method::Envmap | Method::Bvh | Method::Reference)
    }

    /// Whether the reflector check (the exact trace of the reflectors the CMOs do not capture)
    /// applies to the method.
    pub fn has_reflector_check(self) -> bool {
        self.traces_cubemaps()
    }

    /// Whether the method's records name the triangle they hit (verified hits), so that further
    /// reflections can be traced from them: compute, bvh, the reference, and fragment with the
    /// exact criterion.
    pub fn names_hits(self, criterion: TraceCriterion) -> bool {
        match self {
            Method::Compute | Method::Bvh | Method::Reference => true,
            Method::Fragment => criterion == TraceCriterion::Exact,
            Method::Envmap | Method::Ssr | Method::ReflectionPoint => false,
        }
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
        let named = self.names_hits(trace.criterion) || (self == Method::Fragment && bounces == 0);
        if bounces != 1 && !named {
            let with = if self == Method::Fragment {
                format!(" with --criterion {}", criterion_name(trace.criterion))
            } else {
                String::new()
            };
            return Err(format!(
                "--bounces {bounces}: --method {}{with} does not name the triangle it hits, so it \
                 traces one reflection only (use compute, bvh, reference or fragment with the \
                 exact criterion)",
                self.name()
            ));
        }
        Ok(())
    }

    /// Refuses tracer options the method does not implement (compute: the exact criterion only).
    pub fn check_trace(self, trace: &TraceOptions) -> Result<(), Refusal> {
        if self == Method::Compute && trace.criterion != TraceCriterion::Exact {
            return Err(format!(
                "--criterion {}: --method compute implements the exact criterion only (use \
                 --method fragment for the approximate criteria)",
                criterion_name(trace.criterion)
            ));
        }
        Ok(())
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The CLI's name of a criterion.
pub fn criterion_name(c: TraceCriterion) -> &'static str {
    match c {
        TraceCriterion::Exact => "exact",
        TraceCriterion::Threshold => "threshold",
        TraceCriterion::SignChange => "sign-change",
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

    #[test]
    fn bounce_rule() {
        let exact = TraceOptions::default();
        let threshold = TraceOptions {
            criterion: TraceCriterion::Threshold,
            ..exact
        };
        for m in [
            Method::Compute,
            Method::Bvh,
            Method::Reference,
            Method::Fragment,
        ] {
            assert!(m.check_bounces(3, 16, &exact).is_ok(), "{m}");
        }
        for m in [Method::Envmap, Method::Ssr, Method::ReflectionPoint] {
            assert!(m.check_bounces(1, 16, &exact).is_ok(), "{m}");
            let e = m.check_bounces(2, 16, &exact).unwrap_err();
            assert!(e.contains(m.name()), "{e}");
        }
        assert!(Method::Fragment.check_bounces(2, 16, &threshold).is_err());
        assert!(Method::Fragment.check_bounces(0, 16, &threshold).is_ok());
        assert!(Method::Compute.check_bounces(17, 16, &exact).is_err());
    }
}

//! `fragment`: cubemap tracing in a deferred fragment pass (thesis alg. 1, 2, 4), every
//! criterion.
use super::{GlossyLobe, MethodInfo, NamesHits};

pub(super) const INFO: MethodInfo = MethodInfo {
    name: "fragment",
    gpu: true,
    traces_cubemaps: true,
    approximate_criteria: true,
    reads_cmos: true,
    captures_cmos: true,
    can_leave_unresolved: true,
    names_hits: NamesHits::CentreOrBounded,
    glossy: GlossyLobe::ConeTracedFirst,
    known_limit: None,
    outcomes_in_records: false,
    options: &[
        "--sampling",
        "--steps",
        "--eps",
        "--no-accel",
        "--strict",
        "--quick",
    ],
    vertex_search: false,
};

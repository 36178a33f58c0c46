//! `reference`: exact CPU ray tracing, the ground truth.
use super::{GlossyLobe, MethodInfo, NamesHits};

pub(super) const INFO: MethodInfo = MethodInfo {
    name: "reference",
    gpu: false,
    traces_cubemaps: false,
    approximate_criteria: false,
    reads_cmos: false,
    captures_cmos: false,
    can_leave_unresolved: false,
    names_hits: NamesHits::Always,
    glossy: GlossyLobe::SampledEverywhere,
    known_limit: None,
    outcomes_in_records: false,
    options: &[],
    vertex_search: false,
};

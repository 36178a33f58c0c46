//! `bvh`: exact GPU ray tracing over a compressed wide BVH; captures no CMO.
use super::{GlossyLobe, MethodInfo, NamesHits};

pub(super) const INFO: MethodInfo = MethodInfo {
    name: "bvh",
    gpu: true,
    traces_cubemaps: false,
    approximate_criteria: false,
    reads_cmos: false,
    captures_cmos: false,
    can_leave_unresolved: false,
    names_hits: NamesHits::Always,
    glossy: GlossyLobe::SampledFirst,
    known_limit: None,
    outcomes_in_records: false,
    options: &[],
    vertex_search: false,
};

//! `compute`: cubemap tracing in a compute pass (thesis alg. 3); the bounded and centre criteria
//! only.
use super::{GlossyLobe, MethodInfo, NamesHits};

pub(super) const INFO: MethodInfo = MethodInfo {
    name: "compute",
    gpu: true,
    traces_cubemaps: true,
    approximate_criteria: false,
    reads_cmos: true,
    captures_cmos: true,
    can_leave_unresolved: true,
    names_hits: NamesHits::Always,
    glossy: GlossyLobe::ConeTracedFirst,
    known_limit: None,
    outcomes_in_records: false,
    options: &["--compute-layout", "--bvh-bounces", "--quick"],
    vertex_search: false,
};

//! `envmap`: one cube map lookup per pixel, no parallax (the baseline); never unresolved.
use super::{GlossyLobe, MethodInfo, NamesHits};

pub(super) const INFO: MethodInfo = MethodInfo {
    name: "envmap",
    gpu: true,
    traces_cubemaps: false,
    approximate_criteria: false,
    reads_cmos: true,
    captures_cmos: true,
    can_leave_unresolved: false,
    names_hits: NamesHits::Never,
    glossy: GlossyLobe::MirrorOnly,
    known_limit: None,
    outcomes_in_records: false,
    options: &[],
    vertex_search: false,
};

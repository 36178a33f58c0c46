//! `ssr`: Hi-Z screen-space reflections; what leaves the screen goes to the fallback.
use super::{GlossyLobe, MethodInfo, NamesHits};

pub(super) const INFO: MethodInfo = MethodInfo {
    name: "ssr",
    gpu: true,
    traces_cubemaps: false,
    approximate_criteria: false,
    reads_cmos: false,
    captures_cmos: true,
    can_leave_unresolved: true,
    names_hits: NamesHits::Never,
    glossy: GlossyLobe::ConeTracedOnly,
    known_limit: Some(
        "likely cause: the method's known limit: --method ssr finds only what \
                the frame shows, so rays that leave the screen, point towards the camera or pass \
                behind a visible surface go to the fallback (--method compute traces them)",
    ),
    outcomes_in_records: true,
    options: &["--ssr-iterations", "--ssr-thickness"],
    vertex_search: false,
};

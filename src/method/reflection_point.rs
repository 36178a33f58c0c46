//! `reflection-point`: reflection-point search with virtual objects; uncovered mirror pixels go
//! to the fallback.
use super::{GlossyLobe, MethodInfo, NamesHits};

pub(super) const INFO: MethodInfo = MethodInfo {
    name: "reflection-point",
    gpu: true,
    traces_cubemaps: false,
    approximate_criteria: false,
    reads_cmos: false,
    captures_cmos: true,
    can_leave_unresolved: true,
    names_hits: NamesHits::Never,
    glossy: GlossyLobe::MirrorOnly,
    known_limit: Some(
        "likely cause: the method's known limit: --method \
                reflection-point draws the reflections of the other objects' vertices, and mirror \
                pixels no reflected triangle covers go to the fallback (--subdivide N adds \
                vertices)",
    ),
    outcomes_in_records: false,
    options: &["--rp-iterations", "--rp-scale", "--rp-open"],
    vertex_search: true,
};

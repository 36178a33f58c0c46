//! CMO placement: the greedy search for CMO centres and the scene file's `[cmo] placement`
//! (`cmo_placement`), placement by default on corpus scenes and sequences
//! (`placement_default`), the search's shortcuts, which keep its result (`search_cost`), and its
//! sample of the later reflections of `--bounces N` (`bounces`), and the bounded criterion's
//! twin judging the search under the default criterion (`bounded_judge`), and one CMO in front of the
//! mirror points in view weighed against the axis one (`near_centre`).

mod common;

#[path = "placement/bounces.rs"]
mod bounces;
#[path = "placement/bounded_judge.rs"]
mod bounded_judge;
#[path = "placement/cmo_placement.rs"]
mod cmo_placement;
#[path = "placement/near_centre.rs"]
mod near_centre;
#[path = "placement/placement_default.rs"]
mod placement_default;
#[path = "placement/search_cost.rs"]
mod search_cost;

//! CMO placement: the greedy search for CMO centres and the scene file's `[cmo] placement`
//! (`cmo_placement`), and placement by default on corpus scenes and sequences
//! (`placement_default`).

mod common;

#[path = "placement/cmo_placement.rs"]
mod cmo_placement;
#[path = "placement/placement_default.rs"]
mod placement_default;

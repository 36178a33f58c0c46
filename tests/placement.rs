//! CMO placement: the greedy search for CMO centres and the scene file's `[cmo] placement`
//! (`cmo_placement`), placement by default on corpus scenes and sequences
//! (`placement_default`), the search's shortcuts, which keep its result (`search_cost`), and its
//! sample of the later reflections of `--bounces N` (`bounces`), and the bounded criterion's
//! twin judging the search under the default criterion (`bounded_judge`), and one CMO in front
//! of the mirror points in view weighed against the axis one (`near_centre`), and the search's
//! lists that a still frame uploads instead of capturing (`search_lists`).

mod common;

use cubetrace::scene::{self, CmoPlacement, Scene};

/// Corpus scene `name` at 96x72 with 128-texel faces, the size the placement tests render.
fn corpus(name: &str) -> Scene {
    let mut scene = common::corpus_scene(name);
    let c = &mut scene.cameras[0];
    (c.width, c.height) = (96, 72);
    scene.cmo.resolution = 128;
    scene
}

/// [`corpus`] with its CMOs left to the search (as a file without `[cmo]` centres).
fn corpus_searched(name: &str) -> Scene {
    let mut scene = corpus(name);
    scene.cmo.placement = CmoPlacement::Search {
        count: scene::DEFAULT_SEARCH_CMOS,
    };
    scene
}

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
#[path = "placement/search_lists.rs"]
mod search_lists;

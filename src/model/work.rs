//! Work counters: the code blocks of each method's shader that the model counts ([`Block`],
//! [`blocks`]), and what one ray ran of them (issue 25, item 1).
//!
//! (The recorder and the per-ray traces follow; see the module docs once built.)
#![forbid(unsafe_code)]

use crate::method::Method;

/// A code block of a method's shader that the model counts: a loop body or a call site.
///
/// The weight of a block (`model::weights`) is the SPIR-V instruction count of its
/// `functions`, callees included, EXCEPT a callee that another block of the same method names
/// (that one is counted by its own block, once per its own count). A name listed twice counts
/// twice (the block calls it twice per count).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// Short stable name, used in JSON ("lane_test", "advance", ...).
    pub name: &'static str,
    /// The WGSL file (under spirv/) and the WGSL functions whose instructions the block runs
    /// once per count (callees included by the weights).
    pub shader: &'static str,
    pub functions: &'static [&'static str],
}

const fn b(name: &'static str, shader: &'static str, functions: &'static [&'static str]) -> Block {
    Block {
        name,
        shader,
        functions,
    }
}

const COMPUTE: &str = "compute_trace.wgsl";
const FRAGMENT: &str = "fragment_trace.wgsl";
const BVH: &str = "bvh_trace.wgsl";
const SSR: &str = "ssr.wgsl";
const RP: &str = "reflection_point_search.wgsl";

/// compute_trace.wgsl (`trace_queued`): the step loop of alg. 3.
pub const COMPUTE_BLOCKS: &[Block] = &[
    // One turn of `settle`'s loop (the handoff / set-up / face entry it runs are blocks below).
    b("settle", COMPUTE, &["settle"]),
    // A single-CMO trace's set-up (`split_near_centre`).
    b("start_trace", COMPUTE, &["start_trace"]),
    // Entering a face: the face crossing (`faces_crossed` on a piece's first visit).
    b("enter_face", COMPUTE, &["enter_face"]),
    // The handoff after a single-CMO trace ended.
    b("handoff", COMPUTE, &["handoff"]),
    // Verification of a hit against the captured triangle IDs.
    b("verify", COMPUTE, &["verify_decision"]),
    // A node visit's set-up (the ray is testing: `need_mask`).
    b("visit", COMPUTE, &["node_ctx", "child_grid"]),
    // The 1-lane layout's exact pre-test of a node's children (`main_lanes1` only).
    b("children_crossed", COMPUTE, &["children_crossed"]),
    // One round of lane tests: each lane of a ray tests one child (with its ballot).
    b("lane_test", COMPUTE, &["lane_test"]),
    // The pick of the first candidate (min key over the ray's lanes, ballot of the holders).
    b("pick", COMPUTE, &["key_get", "ray_bits"]),
    // One traversal step: descend, backtrack, next face, or classify.
    b("advance", COMPUTE, &["advance"]),
    // The exact classification of a texel candidate (inside `advance` at level 1).
    b("classify", COMPUTE, &["classify"]),
    // Shading a hit for the record.
    b("shade", COMPUTE, &["hit_shade"]),
];

/// fragment_trace.wgsl (`fs_exact_mip`: `trace_ray_verified` over `trace_mip`).
pub const FRAGMENT_BLOCKS: &[Block] = &[
    // The pixel's mirror ray from the G-buffer (every invocation, helpers included).
    b("ray_setup", FRAGMENT, &["mirror_ray"]),
    // A single-CMO trace (pieces, faces crossed).
    b("cmo_trace", FRAGMENT, &["trace_mip"]),
    // The march's start on one face.
    b("face", FRAGMENT, &["mip_start"]),
    // One turn of the march (`mip_turn`'s own code).
    b("turn", FRAGMENT, &["mip_turn"]),
    // The 3x3 texel search (`locate` after a skip, `next_texel` after a texel).
    b("texel_search", FRAGMENT, &["texel_search"]),
    // One cell test of the pyramid (the inner loop).
    b(
        "cell_test",
        FRAGMENT,
        &["cell_interval", "inflated", "r_bounds", "mip_get"],
    ),
    // The exact classification of a texel.
    b("classify", FRAGMENT, &["classify_with"]),
    // Verification of a hit against the captured triangle IDs.
    b("verify", FRAGMENT, &["verify_decision"]),
    // Shading a hit for the record.
    b("shade", FRAGMENT, &["hit_shade"]),
];

/// bvh_trace.wgsl (`bvh_nearest` over the CWBVH).
pub const BVH_BLOCKS: &[Block] = &[
    // The ray's set-up (inverse direction, the start rule's tolerance).
    b("setup", BVH, &["bvh_inv_dir", "bvh_start_tolerance"]),
    // One turn of the traversal loop (`bvh_nearest`'s own code: pops, bookkeeping).
    b("iteration", BVH, &["bvh_nearest"]),
    // A node visit: the 8 children's box tests.
    b("node", BVH, &["bvh_node_hits"]),
    // A triangle test.
    b("triangle", BVH, &["wt_intersect"]),
    // The start rule on a nearer hit.
    b("start_rule", BVH, &["bvh_start_ignores"]),
    // Shading a hit for the record.
    b("shade", BVH, &["hit_shade"]),
];

/// ssr.wgsl (`ssr_trace`, the Hi-Z march).
pub const SSR_BLOCKS: &[Block] = &[
    // The pixel's mirror ray and the screen-space set-up.
    b("ray_setup", SSR, &["mirror_ray", "ssr_trace"]),
    // One iteration of the Hi-Z loop.
    b(
        "iteration",
        SSR,
        &["on_screen", "cell_of", "hiz_at", "cell_of"],
    ),
    // Crossing into the next cell (an iteration whose cell changed, and the first crossing).
    b("cross", SSR, &["cross_cell"]),
];

/// reflection_point_search.wgsl (`search`, one invocation per scene vertex).
pub const REFLECTION_POINT_BLOCKS: &[Block] = &[
    // The start texel (the crosshair search when `rp.start` is off the reflector).
    b("start", RP, &["rp_start"]),
    // One iteration of the local search (`rp_walk`'s own code).
    b("walk_step", RP, &["rp_walk"]),
    // One texel's score (5 on the first forward step, 9 after).
    b("score", RP, &["rp_score"]),
    // The virtual vertex (mirror in the final texel's plane).
    b("finish", RP, &["rp_mirror", "scene_normalize"]),
];

/// The blocks of one method (Method::Compute, Fragment, Bvh, Ssr, ReflectionPoint); empty for
/// the others (envmap, reference: nothing to replay).
pub fn blocks(method: Method) -> &'static [Block] {
    match method {
        Method::Compute => COMPUTE_BLOCKS,
        Method::Fragment => FRAGMENT_BLOCKS,
        Method::Bvh => BVH_BLOCKS,
        Method::Ssr => SSR_BLOCKS,
        Method::ReflectionPoint => REFLECTION_POINT_BLOCKS,
        Method::Envmap | Method::Reference => &[],
    }
}

/// The index of block `name` in `blocks(method)`.
pub fn block_index(method: Method, name: &str) -> Option<usize> {
    blocks(method).iter().position(|b| b.name == name)
}

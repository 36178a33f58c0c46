#![forbid(unsafe_code)]
//! bvh's model: `bvh_trace.wgsl`'s blocks; its loop nest and the CWBVH traversal's twin that
//! records a ray's work are in [`crate::model::bvh`].
use crate::method::Method;
use crate::model::blocks::{Block, b};
use crate::model::bvh::{BVH_PROGRAM, bvh_rays};
use crate::model::frame::Frame;
use crate::model::rays::{FrameWork, Iter, Recorded};
use crate::model::warps::{Assembly, Items};

use super::MethodModel;

/// What the cost model knows of bvh.
pub const MODEL: MethodModel = MethodModel {
    method: Method::Bvh,
    blocks: BVH_BLOCKS,
    program: Some(BVH_PROGRAM),
    assembly: Assembly::Queue,
    lavapipe_items: |_, _| Items::Groups(64),
    entry_point: |_| "main",
    layouts: &[],
    record,
};

fn record(frame: &Frame) -> anyhow::Result<Recorded> {
    let work = FrameWork::Tree {
        program: BVH_PROGRAM,
        rays: bvh_rays(frame).0,
        idle: Iter::default(),
    };
    Ok(Recorded::per_pixel(Method::Bvh, frame, work))
}

const BVH: &str = "bvh_trace.wgsl";

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

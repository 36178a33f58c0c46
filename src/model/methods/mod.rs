#![forbid(unsafe_code)]
//! What the cost model knows of each method it replays, one file per method ([`MethodModel`]):
//! its shader's blocks and loop nest, how a GPU and lavapipe group its invocations, the entry
//! point of its tracing pass, and how its CPU twin's work is recorded. A method without a file
//! here (envmap, the reference) traces nothing per ray and has no model.
use super::blocks::{Block, Stmt};
use super::frame::{ComputeLanes, Frame};
use super::rays::Recorded;
use super::warps::{Assembly, Items};
use crate::method::Method;

pub mod bvh;
pub mod compute;
pub mod fragment;
pub mod reflection_point;
pub mod ssr;

/// One method's model.
pub struct MethodModel {
    pub method: Method,
    /// The blocks of its shader that the model counts (index: a block's position).
    pub blocks: &'static [Block],
    /// The static loop nest of a tree-shaped method (`None`: compute, whose replay is its own).
    pub program: Option<&'static [Stmt]>,
    /// The warp assembly a GPU uses for it (module docs of [`super::warps`]).
    pub assembly: Assembly,
    /// How lavapipe hands its tracing pass to its threads at subgroup size `width`, `lanes`
    /// lanes per ray.
    pub lavapipe_items: fn(width: u32, lanes: u32) -> Items,
    /// The entry point of its tracing pass in a lane layout (`ComputeLanes::Auto`: its GPU
    /// default; only compute has others).
    pub entry_point: fn(ComputeLanes) -> &'static str,
    /// The layouts of its tracing pass beside its default (compute's `Thesis`, `main`, and
    /// `One`, `main_lanes1`), which the bench's GPU predictions set beside the default.
    pub layouts: &'static [ComputeLanes],
    /// Runs its CPU twin on every ray of a frame and keeps the work.
    pub record: fn(&Frame) -> anyhow::Result<Recorded>,
}

/// The methods the model replays, in table order.
pub const MODELS: [&MethodModel; 5] = [
    &compute::MODEL,
    &fragment::MODEL,
    &ssr::MODEL,
    &reflection_point::MODEL,
    &bvh::MODEL,
];

/// The model of `method` (`None`: it has none).
pub fn model(method: Method) -> Option<&'static MethodModel> {
    MODELS.into_iter().find(|m| m.method == method)
}

/// The blocks of one method; empty for a method without a model (envmap, reference: nothing
/// to replay).
pub fn blocks(method: Method) -> &'static [Block] {
    model(method).map_or(&[], |m| m.blocks)
}

/// The index of block `name` in `blocks(method)`.
pub fn block_index(method: Method, name: &str) -> Option<usize> {
    blocks(method).iter().position(|b| b.name == name)
}

/// The layouts of `method`'s tracing pass beside its default ([`MethodModel::layouts`]).
pub fn layouts(method: Method) -> &'static [ComputeLanes] {
    model(method).map_or(&[], |m| m.layouts)
}

/// The static loop nest of a tree-shaped method (not compute, whose replay is its own).
pub fn program(method: Method) -> Option<&'static [Stmt]> {
    model(method).and_then(|m| m.program)
}

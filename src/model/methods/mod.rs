#![forbid(unsafe_code)]
//! What the cost model knows of each method it replays, one file per method ([`MethodModel`]):
//! its shader's blocks and loop nest, how a GPU and lavapipe group its invocations, the entry
//! point of its tracing pass, and how its CPU twin's work is recorded. A method without a file
//! here (envmap, the reference) traces nothing per ray and has no model.
use serde::Serialize;

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
    /// The entry point of its tracing pass in a layout.
    pub entry_point: fn(Layout) -> &'static str,
    /// The layouts of its tracing pass beside its default ([`Layout`]: compute's `main` and
    /// `main_lanes1`), which the bench's GPU predictions set beside the default.
    pub layouts: &'static [Layout],
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
pub fn layouts(method: Method) -> &'static [Layout] {
    model(method).map_or(&[], |m| m.layouts)
}

/// A layout of a tracing pass over a warp's lanes. Only compute has more than its default.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Layout {
    /// The method's GPU default (compute: `main_wave`, one ray per lane, the warp's crossed
    /// children spread over its lanes).
    Default,
    /// compute's thesis layout, `main`: min(width, 32) lanes per ray, one child per lane.
    Thesis,
    /// compute's `main_lanes1`: one lane per ray, its children tested in rounds by that lane.
    OneLane,
}

impl Layout {
    /// How compute's replay lays the rays over lanes in this layout.
    pub fn compute_lanes(self) -> ComputeLanes {
        match self {
            Layout::Default => ComputeLanes::Auto,
            Layout::Thesis => ComputeLanes::Thesis,
            Layout::OneLane => ComputeLanes::One,
        }
    }

    /// The label of a table column: "" (the default), "thesis", "1 lane/ray".
    pub fn label(self) -> &'static str {
        match self {
            Layout::Default => "",
            Layout::Thesis => "thesis",
            Layout::OneLane => "1 lane/ray",
        }
    }
}

/// The static loop nest of a tree-shaped method (not compute, whose replay is its own).
pub fn program(method: Method) -> Option<&'static [Stmt]> {
    model(method).and_then(|m| m.program)
}

//! Dynamic block weights: SPIR-V instructions per count of a block as a warp runs them, beside
//! the static counts of [`super::weights`].
//!
//! # What changes against the static count
//! The static weight counts every instruction of a block's functions once: a loop body once,
//! both arms of every `if`, and code the driver removes. The dynamic weight walks each function's
//! structured control flow (its `OpLoopMerge` and `OpSelectionMerge` constructs) instead:
//! - **Loops per trip.** A loop whose trip count the code fixes (a counter from a constant start,
//!   stepped by a constant in the continue block, tested against a bound known where the block
//!   runs, with no other way out) counts its body that many times ([`LoopKind::Exact`]: e.g.
//!   `bvh_node_hits`' 8 children, `children_crossed`'s 8 columns, `faces_crossed`' 6 faces).
//!   A counted loop with another exit (a `break` or `return` inside: `enter_face`'s turns) and
//!   a loop with no such counter count once, as the static count does
//!   ([`LoopKind::Early`], [`LoopKind::Unknown`]): the twins do not log their trips. The loops
//!   whose trips the replay counts as blocks (a march's turns, a traversal's iterations) are
//!   such loops, their bodies' blocks excluded, so they stay once per count.
//! - **Dead code removed.** Constants of the method's entry point are carried into every call
//!   ([`Contexts`]: a parameter that all the live call sites pass the same constant is that
//!   constant), conditions that fold to a constant take one arm, and an instruction whose value
//!   folds to a constant, or whose result nothing uses, costs nothing: what inlining and constant
//!   propagation in the driver (NIR, LLVM) or `spirv-opt -O` remove. The entry point is the one
//!   the method's default dispatch runs ([`entry_point`]).
//! - **Arms** ([`Arms`]): an `if` whose condition does not fold costs both arms in
//!   [`Arms::Both`], which is lavapipe's execution (every arm under a mask) and a GPU warp whose
//!   lanes diverge; [`Arms::Cheaper`] takes the cheaper path through every such `if`, what a warp
//!   pays if all its lanes agree on the cheap side: a lower bound. The twins do not log which
//!   arm each lane takes inside a block, so the model gives the two ends. Where an arm is heavy
//!   and rare, it is a function named by a block of its own that the twins log: the texel
//!   classification's candidate arm (`classify_candidate`, the `decide` blocks of fragment and
//!   compute) runs at a trace's deciding texel only, and a warp issues it where one of its
//!   lanes decides (lavapipe mode: every turn the classification runs, as lavapipe masks it).
//! - **Register moves cost nothing.** naga passes structs through function-local variables:
//!   `var out = c; out.iv.t0 = b; return out;` is a whole-struct store, a field's access chain
//!   and store, and a whole-struct load, and a struct argument or result is composed and taken
//!   apart field by field (`clip_plane` counted 75 instructions, a few comparisons and a
//!   division of work). Every GPU compiler promotes such variables to registers (mem2reg and
//!   SROA in LLVM and NIR, `spirv-opt -O`'s local access chain conversion), after which the
//!   composites are register names. So a load, store or access chain of a function-local
//!   variable indexed by constants only, and `OpCompositeConstruct`, `OpCompositeExtract`,
//!   `OpCompositeInsert` and `OpCopyObject`, are walked (their values still fold) but not
//!   counted. Still counted: a local array indexed at run time (a lane operation on lavapipe,
//!   local memory on a GPU), `var<private>` globals, and every buffer, image and subgroup
//!   operation. Checked on lavapipe rows (the same held-out share as without; the results in
//!   `benches/results/lavapipe-model-dynamic.md`).
//!
//! # Where it stops
//! Only integer and boolean values fold (comparisons, logic, `+ - *`, selects); a value loaded
//! from memory never does. A loop counted per trip runs its bound even where a lane would leave
//! early through the header test of a shorter bound computed at run time (those loops are
//! [`LoopKind::Unknown`] and count once).
//!
//! The SPIR-V is read in `spirv` and walked in `eval`; this module gives the weights of a
//! method's blocks from them.
#![forbid(unsafe_code)]

use std::collections::{BTreeMap, BTreeSet};

use anyhow::{Context, Result, bail};

mod eval;
mod spirv;

pub use eval::{Ctx, Eval, LoopNote};
pub use spirv::{Arms, Cost, LoopKind, Module};

use super::frame::ComputeLanes;
use super::work::{Block, blocks};
use crate::method::Method;

/// The entry point a method's dispatch runs in `layout`: compute's `main` (the thesis layout),
/// `main_lanes1` or `main_wave`; fragment's `fs_exact_mip`; bvh's `main`; ssr's `fs_main`;
/// reflection-point's `search`.
pub fn entry_point(method: Method, layout: ComputeLanes) -> Option<&'static str> {
    super::methods::model(method).map(|m| (m.entry_point)(layout))
}

/// The known parameters of each function reached from an entry point: a parameter that every
/// live call site passes the same constant is that constant.
#[derive(Clone, Debug, Default)]
pub struct Contexts {
    pub by_function: BTreeMap<u32, Ctx>,
}

impl Contexts {
    /// Walks the module from `entry` (both arms of every unfolded `if`) and merges the calls.
    pub fn from_entry(m: &Module, entry: &str) -> Result<Contexts> {
        let id = m.id(entry)?;
        let mut e = Eval::new(m, BTreeSet::new(), Arms::Both);
        e.function(id, &Vec::new());
        let mut by_function: BTreeMap<u32, Ctx> = BTreeMap::new();
        for (callee, args) in e.calls {
            by_function
                .entry(callee)
                .and_modify(|c| {
                    for (a, b) in c.iter_mut().zip(&args) {
                        if *a != *b {
                            *a = None;
                        }
                    }
                })
                .or_insert(args);
        }
        Ok(Contexts { by_function })
    }
}

/// One block's dynamic weight and the loops counted in it.
#[derive(Clone, Debug)]
pub struct BlockWeight {
    pub cost: Cost,
    pub loops: Vec<LoopNote>,
}

/// The dynamic weights of `blocks` (one method's) under the constants of entry point `entry`,
/// index for index (the same callee rule as [`super::weights`]). A block function the entry
/// point never calls keeps no constants (its parameters unknown).
pub fn block_weights(blocks: &[Block], entry: &str, arms: Arms) -> Result<Vec<BlockWeight>> {
    let mut modules: BTreeMap<&str, (Module, Contexts)> = BTreeMap::new();
    let mut out = Vec::with_capacity(blocks.len());
    for b in blocks {
        if !modules.contains_key(b.shader) {
            let m = Module::of(b.shader)?;
            let ctx = Contexts::from_entry(&m, entry)
                .with_context(|| format!("entry point {entry} of {}", b.shader))?;
            modules.insert(b.shader, (m, ctx));
        }
        let (m, ctx) = &modules[b.shader];
        let mut excluded = BTreeSet::new();
        for x in blocks.iter().filter(|x| x.shader == b.shader) {
            for f in x.functions {
                excluded.insert(
                    m.id(f)
                        .with_context(|| format!("model block '{}'", x.name))?,
                );
            }
        }
        let mut cost = Cost::default();
        let mut loops = Vec::new();
        for f in b.functions {
            let id = m
                .id(f)
                .with_context(|| format!("model block '{}'", b.name))?;
            let mut ex = excluded.clone();
            ex.remove(&id);
            let mut e = Eval::new(m, ex, arms);
            let params = m.funcs.get(&id).map_or(0, |x| x.params.len());
            let known = ctx
                .by_function
                .get(&id)
                .cloned()
                .unwrap_or_else(|| vec![None; params]);
            cost = cost + e.function(id, &known);
            loops.extend(e.loops);
        }
        out.push(BlockWeight { cost, loops });
    }
    Ok(out)
}

/// Instructions per block of a method, counted dynamically (module docs), with `Arms::Both`
/// unless asked; `layout` picks compute's entry point.
pub fn weights(method: Method, layout: ComputeLanes, arms: Arms) -> Result<Vec<BlockWeight>> {
    let Some(entry) = entry_point(method, layout) else {
        bail!("model: --method {} has no blocks", method.name());
    };
    block_weights(blocks(method), entry, arms)
        .with_context(|| format!("--method {}", method.name()))
}

/// How a block's instructions are counted: [`Counting::Static`] ([`super::weights`]: every
/// instruction once) or [`Counting::Dynamic`] (this module: loops per trip, dead code
/// removed, both arms of an `if` that does not fold).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Counting {
    Static,
    Dynamic,
}

impl Counting {
    pub fn name(self) -> &'static str {
        match self {
            Counting::Static => "static",
            Counting::Dynamic => "dynamic",
        }
    }
}

/// [`super::weights::weights`] and [`super::weights::lane_weights`] under `counting`; `layout`
/// picks compute's entry point for the dynamic count (the static count does not depend on it).
pub fn weights_by(
    method: Method,
    counting: Counting,
    layout: ComputeLanes,
) -> Result<(Vec<f64>, Vec<f64>)> {
    match counting {
        Counting::Static => Ok((
            super::weights::weights(method)?,
            super::weights::lane_weights(method)?,
        )),
        Counting::Dynamic => {
            let w = weights(method, layout, Arms::Both)?;
            Ok((
                w.iter().map(|b| b.cost.all).collect(),
                w.iter().map(|b| b.cost.lane).collect(),
            ))
        }
    }
}

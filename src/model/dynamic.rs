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
//!   `bvh_node_hits`' 8 children, `children_crossed`'s 8 columns, `faces_crossed`' 6 faces and
//!   its 6 x 6 ranking). A counted loop with another exit (a `break` or `return` inside:
//!   `enter_face`'s turns) and a loop with no such counter count once, as the static count does
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
//!   arm each lane takes inside a block, so the model gives the two ends.
//!
//! # Where it stops
//! Only integer and boolean values fold (comparisons, logic, `+ - *`, selects); a value loaded
//! from memory never does. A loop counted per trip runs its bound even where a lane would leave
//! early through the header test of a shorter bound computed at run time (those loops are
//! [`LoopKind::Unknown`] and count once).
#![forbid(unsafe_code)]

use std::collections::{BTreeMap, BTreeSet};

use anyhow::{Context, Result, bail};

use super::weights::{
    OP_ACCESS_CHAIN, OP_ATOMICS, OP_CONSTANTS, OP_FUNCTION, OP_FUNCTION_CALL, OP_FUNCTION_END,
    OP_FUNCTION_PARAMETER, OP_IMAGE_ACCESS, OP_IN_BOUNDS_ACCESS_CHAIN, OP_LABEL, OP_LOAD,
    OP_LOOP_MERGE, OP_NAME, OP_SELECTION_MERGE, OP_STORE, OP_SUBGROUP, OP_TYPE_POINTER,
    OP_VARIABLE, SC_FUNCTION, SC_PRIVATE, checked_words, instructions, is_free, is_lane_memory,
    literal,
};
use super::work::{Block, blocks};
use crate::method::Method;

const OP_EXT_INST: u32 = 12;
const OP_CONSTANT_TRUE: u32 = 41;
const OP_CONSTANT_FALSE: u32 = 42;
const OP_CONSTANT: u32 = 43;
const OP_CONSTANT_NULL: u32 = 46;
const OP_COPY_OBJECT: u32 = 83;
const OP_IADD: u32 = 128;
const OP_ISUB: u32 = 130;
const OP_IMUL: u32 = 132;
const OP_LOGICAL_EQUAL: u32 = 164;
const OP_LOGICAL_NOT_EQUAL: u32 = 165;
const OP_LOGICAL_OR: u32 = 166;
const OP_LOGICAL_AND: u32 = 167;
const OP_LOGICAL_NOT: u32 = 168;
const OP_SELECT: u32 = 169;
const OP_IEQUAL: u32 = 170;
const OP_INOT_EQUAL: u32 = 171;
const OP_UGREATER_THAN: u32 = 172;
const OP_SGREATER_THAN: u32 = 173;
const OP_UGREATER_THAN_EQUAL: u32 = 174;
const OP_SGREATER_THAN_EQUAL: u32 = 175;
const OP_ULESS_THAN: u32 = 176;
const OP_SLESS_THAN: u32 = 177;
const OP_ULESS_THAN_EQUAL: u32 = 178;
const OP_SLESS_THAN_EQUAL: u32 = 179;
const OP_BITWISE_OR: u32 = 197;
const OP_BITWISE_AND: u32 = 199;
const OP_BRANCH: u32 = 249;
const OP_BRANCH_CONDITIONAL: u32 = 250;
const OP_SWITCH: u32 = 251;
const OP_KILL: u32 = 252;
const OP_RETURN: u32 = 253;
const OP_RETURN_VALUE: u32 = 254;
const OP_UNREACHABLE: u32 = 255;
const OP_TERMINATE_INVOCATION: u32 = 4416;

fn is_terminator(op: u32) -> bool {
    (OP_BRANCH..=OP_UNREACHABLE).contains(&op) || op == OP_TERMINATE_INVOCATION
}

/// Value instructions without side effects, whose result id is `operands[1]`: removable when
/// nothing uses the result.
fn is_pure(op: u32) -> bool {
    matches!(
        op,
        OP_EXT_INST | OP_LOAD | OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN
    ) || (79..=84).contains(&op)
        || (109..=124).contains(&op)
        || (126..=205).contains(&op)
}

/// How an `if` whose condition does not fold is counted (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Arms {
    /// Both arms: lavapipe, and a warp whose lanes diverge.
    Both,
    /// The cheaper path: a warp whose lanes agree on the cheap side (a lower bound).
    Cheaper,
}

/// How a loop inside a block is counted (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoopKind {
    /// A fixed trip count, no other exit.
    Exact(u64),
    /// A counted loop with another exit (a `break` or `return` inside) and this bound: once,
    /// as the static count does (the twins do not log its trips).
    Early(u64),
    /// No counter found: once.
    Unknown,
}

impl LoopKind {
    pub fn trips(self) -> u64 {
        match self {
            LoopKind::Exact(n) => n,
            LoopKind::Early(_) | LoopKind::Unknown => 1,
        }
    }
}

/// Instructions and, of those, lane operations ([`super::weights`] module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cost {
    pub all: f64,
    pub lane: f64,
}

impl std::ops::Add for Cost {
    type Output = Cost;
    fn add(self, o: Cost) -> Cost {
        Cost {
            all: self.all + o.all,
            lane: self.lane + o.lane,
        }
    }
}

impl std::ops::Mul<f64> for Cost {
    type Output = Cost;
    fn mul(self, k: f64) -> Cost {
        Cost {
            all: self.all * k,
            lane: self.lane * k,
        }
    }
}

#[derive(Clone, Debug)]
struct Inst {
    op: u32,
    operands: Vec<u32>,
    /// A lane operation.
    lane: bool,
    /// Removed as unused (its result feeds nothing).
    dead: bool,
}

#[derive(Clone, Debug, Default)]
struct BasicBlock {
    insts: Vec<Inst>,
    /// `(merge, continue)` of a loop header.
    loop_merge: Option<(u32, u32)>,
    selection_merge: Option<u32>,
    /// The terminator: opcode and operands.
    term: (u32, Vec<u32>),
}

#[derive(Clone, Debug, Default)]
struct Func {
    params: Vec<u32>,
    entry: u32,
    blocks: BTreeMap<u32, BasicBlock>,
    /// Function variables' constant initialisers.
    inits: BTreeMap<u32, u32>,
}

/// A pass's functions with their control flow, by WGSL name.
#[derive(Clone, Debug)]
pub struct Module {
    pub pass: String,
    funcs: BTreeMap<u32, Func>,
    names: BTreeMap<String, u32>,
    ids: BTreeMap<u32, String>,
    /// Integer and boolean constants (bools as 0 / 1).
    constants: BTreeMap<u32, u64>,
}

/// Lane-operation tracking while parsing (the same rules as [`super::weights`]).
#[derive(Default)]
struct LaneTrack {
    pointer_types: BTreeMap<u32, u32>,
    class_of: BTreeMap<u32, u32>,
    constant_ids: BTreeSet<u32>,
    dynamic: BTreeSet<u32>,
}

impl LaneTrack {
    fn see(&mut self, op: u32, o: &[u32]) {
        match op {
            OP_TYPE_POINTER if o.len() >= 2 => {
                self.pointer_types.insert(o[0], o[1]);
            }
            OP_VARIABLE if o.len() >= 3 => {
                self.class_of.insert(o[1], o[2]);
            }
            OP_FUNCTION_PARAMETER if o.len() >= 2 => {
                if let Some(&c) = self.pointer_types.get(&o[0]) {
                    self.class_of.insert(o[1], c);
                }
            }
            OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN if o.len() >= 3 => {
                if let Some(&c) = self.pointer_types.get(&o[0]) {
                    self.class_of.insert(o[1], c);
                }
                if o[3..].iter().any(|i| !self.constant_ids.contains(i))
                    || self.dynamic.contains(&o[2])
                {
                    self.dynamic.insert(o[1]);
                }
            }
            x if OP_CONSTANTS.contains(&x) && o.len() >= 2 => {
                self.constant_ids.insert(o[1]);
            }
            _ => {}
        }
    }

    fn is_lane(&self, op: u32, o: &[u32]) -> bool {
        let pointer = match op {
            OP_LOAD => o.get(2),
            OP_STORE => o.first(),
            x if OP_ATOMICS.contains(&x) => o.get(2),
            _ => None,
        };
        let per_lane = |p: &u32| {
            let class = self.class_of.get(p).copied().unwrap_or(0);
            is_lane_memory(class)
                || (matches!(class, SC_PRIVATE | SC_FUNCTION) && self.dynamic.contains(p))
        };
        pointer.is_some_and(per_lane)
            || OP_ATOMICS.contains(&op)
            || OP_IMAGE_ACCESS.contains(&op)
            || OP_SUBGROUP.contains(&op)
    }
}

impl Module {
    /// Reads `spirv/<shader>` from its checked debug-named copy ([`super::weights`]).
    pub fn of(shader: &str) -> Result<Module> {
        let (pass, words) = checked_words(shader)?;
        Self::parse(&pass, &words)
    }

    /// Parses a debug-named module.
    pub fn parse(pass: &str, words: &[u32]) -> Result<Module> {
        let mut ids = BTreeMap::new();
        let mut constants = BTreeMap::new();
        let mut funcs = BTreeMap::new();
        let mut lanes = LaneTrack::default();
        let mut cur: Option<(u32, Func)> = None;
        let mut block: Option<(u32, BasicBlock)> = None;
        for (op, o) in instructions(words).with_context(|| format!("spirv/{pass}.wgsl"))? {
            lanes.see(op, o);
            match op {
                OP_NAME if o.len() >= 2 => {
                    ids.insert(o[0], literal(&o[1..]));
                }
                OP_CONSTANT_TRUE if o.len() >= 2 => {
                    constants.insert(o[1], 1);
                }
                OP_CONSTANT_FALSE | OP_CONSTANT_NULL if o.len() >= 2 => {
                    constants.insert(o[1], 0);
                }
                OP_CONSTANT if o.len() >= 3 => {
                    constants.insert(o[1], u64::from(o[2]));
                }
                _ => {}
            }
            let Some((_, f)) = cur.as_mut() else {
                if op == OP_FUNCTION && o.len() >= 2 {
                    cur = Some((o[1], Func::default()));
                }
                continue;
            };
            match op {
                OP_FUNCTION_PARAMETER if o.len() >= 2 => f.params.push(o[1]),
                OP_FUNCTION_END => {
                    let (id, f) = cur.take().expect("inside a function");
                    funcs.insert(id, f);
                }
                OP_LABEL if !o.is_empty() => {
                    if f.blocks.is_empty() && block.is_none() {
                        f.entry = o[0];
                    }
                    block = Some((o[0], BasicBlock::default()));
                }
                OP_VARIABLE if o.len() >= 4 => {
                    f.inits.insert(o[1], o[3]);
                }
                OP_LOOP_MERGE if o.len() >= 2 => {
                    if let Some((_, b)) = block.as_mut() {
                        b.loop_merge = Some((o[0], o[1]));
                    }
                }
                OP_SELECTION_MERGE if !o.is_empty() => {
                    if let Some((_, b)) = block.as_mut() {
                        b.selection_merge = Some(o[0]);
                    }
                }
                x if is_terminator(x) => {
                    if let Some((label, mut b)) = block.take() {
                        b.term = (x, o.to_vec());
                        f.blocks.insert(label, b);
                    }
                }
                x if !is_free(x) => {
                    if let Some((_, b)) = block.as_mut() {
                        b.insts.push(Inst {
                            op: x,
                            operands: o.to_vec(),
                            lane: lanes.is_lane(x, o),
                            dead: false,
                        });
                    }
                }
                _ => {}
            }
        }
        for f in funcs.values_mut() {
            remove_unused(f);
        }
        let names = funcs
            .keys()
            .filter_map(|id| ids.get(id).map(|n| (n.clone(), *id)))
            .collect();
        Ok(Module {
            pass: pass.to_string(),
            funcs,
            names,
            ids,
            constants,
        })
    }

    /// The id of function `name`.
    pub fn id(&self, name: &str) -> Result<u32> {
        self.names.get(name).copied().with_context(|| {
            format!(
                "model dynamic weights: spirv/{}.wgsl has no function '{name}'",
                self.pass
            )
        })
    }

    fn name(&self, id: u32) -> &str {
        self.ids.get(&id).map_or("?", String::as_str)
    }
}

/// Marks pure instructions whose results nothing uses as dead, until none is left.
fn remove_unused(f: &mut Func) {
    loop {
        let mut uses: BTreeMap<u32, u32> = BTreeMap::new();
        for b in f.blocks.values() {
            for i in b.insts.iter().filter(|i| !i.dead) {
                let skip = if is_pure(i.op) { 2 } else { 0 };
                for w in i.operands.iter().skip(skip) {
                    *uses.entry(*w).or_default() += 1;
                }
            }
            for w in &b.term.1 {
                *uses.entry(*w).or_default() += 1;
            }
        }
        let mut changed = false;
        for b in f.blocks.values_mut() {
            for i in b.insts.iter_mut().filter(|i| !i.dead && is_pure(i.op)) {
                if i.operands.len() >= 2 && !uses.contains_key(&i.operands[1]) {
                    i.dead = true;
                    changed = true;
                }
            }
        }
        if !changed {
            return;
        }
    }
}

/// Folds an integer or boolean instruction whose operands are known.
fn fold(op: u32, o: &[u32], known: &BTreeMap<u32, u64>) -> Option<u64> {
    let k = |i: usize| o.get(i).and_then(|id| known.get(id)).copied();
    let s = |v: u64| v as u32 as i32;
    let b = |x: bool| u64::from(x);
    match op {
        OP_COPY_OBJECT | OP_LOGICAL_NOT => {
            let a = k(2)?;
            Some(if op == OP_LOGICAL_NOT { b(a == 0) } else { a })
        }
        OP_LOGICAL_AND => match (k(2), k(3)) {
            (Some(0), _) | (_, Some(0)) => Some(0),
            (Some(x), Some(y)) => Some(b(x != 0 && y != 0)),
            _ => None,
        },
        OP_LOGICAL_OR => match (k(2), k(3)) {
            (Some(x), _) | (_, Some(x)) if x != 0 => Some(1),
            (Some(_), Some(_)) => Some(0),
            _ => None,
        },
        OP_SELECT => {
            let c = k(2)?;
            k(if c != 0 { 3 } else { 4 })
        }
        _ => {
            let (x, y) = (k(2)?, k(3)?);
            Some(match op {
                OP_LOGICAL_EQUAL => b((x != 0) == (y != 0)),
                OP_LOGICAL_NOT_EQUAL => b((x != 0) != (y != 0)),
                OP_IEQUAL => b(x == y),
                OP_INOT_EQUAL => b(x != y),
                OP_UGREATER_THAN => b(x > y),
                OP_UGREATER_THAN_EQUAL => b(x >= y),
                OP_ULESS_THAN => b(x < y),
                OP_ULESS_THAN_EQUAL => b(x <= y),
                OP_SGREATER_THAN => b(s(x) > s(y)),
                OP_SGREATER_THAN_EQUAL => b(s(x) >= s(y)),
                OP_SLESS_THAN => b(s(x) < s(y)),
                OP_SLESS_THAN_EQUAL => b(s(x) <= s(y)),
                OP_IADD => u64::from((x as u32).wrapping_add(y as u32)),
                OP_ISUB => u64::from((x as u32).wrapping_sub(y as u32)),
                OP_IMUL => u64::from((x as u32).wrapping_mul(y as u32)),
                OP_BITWISE_AND => x & y,
                OP_BITWISE_OR => x | y,
                _ => return None,
            })
        }
    }
}

/// Known values of a function's parameters at a call site (None: not constant).
pub type Ctx = Vec<Option<u64>>;

/// One loop found while walking, for the report.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopNote {
    pub function: String,
    pub header: u32,
    pub kind: LoopKind,
}

/// A walk's end: the stop reached (a merge or continue target of an enclosing construct), or
/// None for a return.
type Path = (Cost, Option<u32>);

/// Evaluates functions' dynamic costs with callees in `excluded` left out.
pub struct Eval<'m> {
    m: &'m Module,
    excluded: BTreeSet<u32>,
    arms: Arms,
    memo: BTreeMap<(u32, Ctx), Cost>,
    /// Every call on a live path: callee and the known values of its arguments.
    pub calls: Vec<(u32, Ctx)>,
    pub loops: Vec<LoopNote>,
}

impl<'m> Eval<'m> {
    pub fn new(m: &'m Module, excluded: BTreeSet<u32>, arms: Arms) -> Eval<'m> {
        Eval {
            m,
            excluded,
            arms,
            memo: BTreeMap::new(),
            calls: Vec::new(),
            loops: Vec::new(),
        }
    }

    /// The cost of one call of function `id` with parameters `ctx`, callees included except the
    /// excluded ones.
    pub fn function(&mut self, id: u32, ctx: &Ctx) -> Cost {
        if let Some(c) = self.memo.get(&(id, ctx.clone())) {
            return *c;
        }
        let m = self.m;
        let Some(f) = m.funcs.get(&id) else {
            return Cost::default();
        };
        let mut known = m.constants.clone();
        for (p, v) in f.params.iter().zip(ctx) {
            if let Some(v) = v {
                known.insert(*p, *v);
            }
        }
        // Guards recursion (SPIR-V has none) with a provisional zero.
        self.memo.insert((id, ctx.clone()), Cost::default());
        let (cost, _) = self.walk(id, f, f.entry, &[], &mut known);
        self.memo.insert((id, ctx.clone()), cost);
        cost
    }

    /// The instructions of block `b` (calls expanded), folding what it can into `known`.
    fn block_insts(&mut self, b: &BasicBlock, known: &mut BTreeMap<u32, u64>) -> Cost {
        // The terminator (a branch or return) counts, as in the static count.
        let mut c = Cost {
            all: 1.0,
            lane: 0.0,
        };
        for i in &b.insts {
            if i.dead {
                continue;
            }
            if let Some(v) = fold(i.op, &i.operands, known) {
                known.insert(i.operands[1], v);
                continue;
            }
            c = c + Cost {
                all: 1.0,
                lane: f64::from(u8::from(i.lane)),
            };
            if i.op == OP_FUNCTION_CALL && i.operands.len() >= 3 {
                let callee = i.operands[2];
                let args: Ctx = i.operands[3..]
                    .iter()
                    .map(|a| known.get(a).copied())
                    .collect();
                self.calls.push((callee, args.clone()));
                if !self.excluded.contains(&callee) {
                    c = c + self.function(callee, &args);
                }
            }
        }
        c
    }

    /// Walks from block `b` until a stop, a return, or the end.
    fn walk(
        &mut self,
        fid: u32,
        f: &Func,
        mut b: u32,
        stops: &[u32],
        known: &mut BTreeMap<u32, u64>,
    ) -> Path {
        let mut total = Cost::default();
        loop {
            if stops.contains(&b) {
                return (total, Some(b));
            }
            let Some(blk) = f.blocks.get(&b) else {
                return (total, None);
            };
            if let Some((merge, cont)) = blk.loop_merge {
                let kind = trips(f, b, merge, cont, known);
                self.loops.push(LoopNote {
                    function: self.m.name(fid).to_string(),
                    header: b,
                    kind,
                });
                let trip = self.trip(fid, f, b, merge, cont, known);
                total = total + trip * kind.trips() as f64;
                b = merge;
                continue;
            }
            total = total + self.block_insts(blk, known);
            let (op, o) = (&blk.term.0, &blk.term.1);
            let targets: Vec<u32> = match *op {
                OP_BRANCH => {
                    b = o[0];
                    continue;
                }
                OP_BRANCH_CONDITIONAL => match known.get(&o[0]) {
                    Some(&v) => vec![if v != 0 { o[1] } else { o[2] }],
                    None => vec![o[1], o[2]],
                },
                OP_SWITCH => switch_targets(o, known),
                _ => return (total, None),
            };
            let (c, end) = self.arms(fid, f, &targets, blk.selection_merge, stops, known);
            return (total + c, end);
        }
    }

    /// The arms `targets` of a branch with selection merge `merge`, and what follows it.
    fn arms(
        &mut self,
        fid: u32,
        f: &Func,
        targets: &[u32],
        merge: Option<u32>,
        stops: &[u32],
        known: &mut BTreeMap<u32, u64>,
    ) -> Path {
        let mut inner: Vec<u32> = stops.to_vec();
        inner.extend(merge);
        let paths: Vec<Path> = targets
            .iter()
            .map(|t| self.walk(fid, f, *t, &inner, &mut known.clone()))
            .collect();
        let rest = match merge {
            Some(mg) if paths.iter().any(|p| p.1 == Some(mg)) => {
                Some(self.walk(fid, f, mg, stops, known))
            }
            _ => None,
        };
        let full = |p: &Path| match (merge, &rest) {
            (Some(mg), Some(r)) if p.1 == Some(mg) => (p.0 + r.0, r.1),
            _ => *p,
        };
        match self.arms {
            Arms::Both if paths.len() > 1 => {
                let sum = paths.iter().fold(Cost::default(), |a, p| a + p.0);
                let end = paths.iter().find_map(|p| full(p).1);
                let tail = rest.map_or(Cost::default(), |r| r.0);
                (sum + tail, end)
            }
            _ => paths
                .iter()
                .map(full)
                .min_by(|a, b| a.0.all.total_cmp(&b.0.all))
                .unwrap_or_default(),
        }
    }

    /// One trip of the loop at `header`: the header, the body up to the continue target or the
    /// merge, and the continue construct.
    fn trip(
        &mut self,
        fid: u32,
        f: &Func,
        header: u32,
        merge: u32,
        cont: u32,
        known: &mut BTreeMap<u32, u64>,
    ) -> Cost {
        let blk = &f.blocks[&header];
        let mut c = self.block_insts(blk, known);
        let targets: Vec<u32> = match blk.term.0 {
            OP_BRANCH => vec![blk.term.1[0]],
            OP_BRANCH_CONDITIONAL => blk.term.1[1..3].to_vec(),
            _ => Vec::new(),
        };
        let mut reached_cont = false;
        for t in targets.iter().filter(|t| **t != merge) {
            let (body, end) = self.walk(fid, f, *t, &[cont, merge], &mut known.clone());
            c = c + body;
            reached_cont |= end == Some(cont) || *t == cont;
        }
        if reached_cont && cont != header {
            let (tail, _) = self.walk(fid, f, cont, &[header, merge], &mut known.clone());
            c = c + tail;
        }
        c
    }
}

fn switch_targets(o: &[u32], known: &BTreeMap<u32, u64>) -> Vec<u32> {
    let cases: Vec<(u32, u32)> = o[2..].chunks_exact(2).map(|c| (c[0], c[1])).collect();
    if let Some(&v) = known.get(&o[0]) {
        let hit = cases.iter().find(|(lit, _)| u64::from(*lit) == v);
        return vec![hit.map_or(o[1], |c| c.1)];
    }
    let mut t: Vec<u32> = std::iter::once(o[1])
        .chain(cases.iter().map(|c| c.1))
        .collect();
    t.dedup();
    t
}

/// The blocks of the loop at `header` (reachable from it without passing its merge).
fn loop_blocks(f: &Func, header: u32, merge: u32) -> BTreeSet<u32> {
    let mut seen = BTreeSet::from([header]);
    let mut stack = vec![header];
    while let Some(b) = stack.pop() {
        let Some(blk) = f.blocks.get(&b) else {
            continue;
        };
        for t in successors(blk) {
            if t != merge && seen.insert(t) {
                stack.push(t);
            }
        }
    }
    seen
}

fn successors(b: &BasicBlock) -> Vec<u32> {
    let o = &b.term.1;
    match b.term.0 {
        OP_BRANCH => vec![o[0]],
        OP_BRANCH_CONDITIONAL => vec![o[1], o[2]],
        OP_SWITCH => std::iter::once(o[1])
            .chain(o[2..].chunks_exact(2).map(|c| c[1]))
            .collect(),
        _ => Vec::new(),
    }
}

/// The instruction defining `id` in `f`.
fn def(f: &Func, id: u32) -> Option<&Inst> {
    f.blocks
        .values()
        .flat_map(|b| &b.insts)
        .find(|i| is_pure(i.op) && i.operands.get(1) == Some(&id))
}

/// The function variable `id` loads, if it is a load.
fn loaded_var(f: &Func, id: u32) -> Option<u32> {
    def(f, id)
        .filter(|i| i.op == OP_LOAD)
        .map(|i| i.operands[2])
}

/// The trip count of the loop at `header` (module docs).
fn trips(f: &Func, header: u32, merge: u32, cont: u32, known: &BTreeMap<u32, u64>) -> LoopKind {
    let Some((var, test, exit)) = counter_test(f, header, merge) else {
        return LoopKind::Unknown;
    };
    let Some(step) = counter_step(f, var, cont, known) else {
        return LoopKind::Unknown;
    };
    let body = loop_blocks(f, header, merge);
    // The start: every store to the counter outside the continue block stores the same known
    // value, none inside the loop (else the initialiser, where there is no store).
    let mut starts = Vec::new();
    for (l, b) in &f.blocks {
        for i in b
            .insts
            .iter()
            .filter(|i| i.op == OP_STORE && i.operands[0] == var)
        {
            if *l == cont {
                continue;
            }
            if body.contains(l) {
                return LoopKind::Unknown;
            }
            starts.push(known.get(&i.operands[1]).copied());
        }
    }
    let init = f.inits.get(&var).and_then(|c| known.get(c)).copied();
    let start = match starts.first() {
        None => init,
        Some(first) if starts.iter().all(|s| s == first) => *first,
        Some(_) => None,
    };
    let Some(start) = start else {
        return LoopKind::Unknown;
    };
    let Some(n) = test.count(start, step, known) else {
        return LoopKind::Unknown;
    };
    let other_exit = body.iter().any(|l| {
        let b = &f.blocks[l];
        *l != exit
            && (successors(b).contains(&merge)
                || matches!(b.term.0, OP_RETURN | OP_RETURN_VALUE | OP_KILL))
    });
    if other_exit {
        LoopKind::Early(n)
    } else {
        LoopKind::Exact(n)
    }
}

/// A loop's test: `counter OP bound` keeps it running.
struct Test {
    op: u32,
    bound: u32,
}

impl Test {
    fn count(&self, start: u64, step: u64, known: &BTreeMap<u32, u64>) -> Option<u64> {
        let bound = *known.get(&self.bound)?;
        if step == 0 {
            return None;
        }
        let n = match self.op {
            OP_ULESS_THAN | OP_SLESS_THAN => bound.saturating_sub(start).div_ceil(step),
            OP_ULESS_THAN_EQUAL | OP_SLESS_THAN_EQUAL if bound >= start => {
                (bound - start) / step + 1
            }
            OP_ULESS_THAN_EQUAL | OP_SLESS_THAN_EQUAL => 0,
            _ => return None,
        };
        Some(n)
    }
}

/// The loop's counter variable, its test, and the block that leaves on it: the first
/// conditional branch after the header (through unconditional branches), one arm of which goes
/// to the merge (directly or through an empty block).
fn counter_test(f: &Func, header: u32, merge: u32) -> Option<(u32, Test, u32)> {
    let mut b = *successors(f.blocks.get(&header)?).first()?;
    for _ in 0..4 {
        let blk = f.blocks.get(&b)?;
        if blk.term.0 == OP_BRANCH {
            b = blk.term.1[0];
            continue;
        }
        if blk.term.0 != OP_BRANCH_CONDITIONAL {
            return None;
        }
        let o = &blk.term.1;
        let leaves = |t: u32| {
            t == merge
                || f.blocks.get(&t).is_some_and(|x| {
                    x.insts.is_empty() && x.term.0 == OP_BRANCH && x.term.1[0] == merge
                })
        };
        let (cond, exit) = match (leaves(o[1]), leaves(o[2])) {
            (false, true) => (o[0], if o[2] == merge { b } else { o[2] }),
            _ => return None,
        };
        let c = def(f, cond)?;
        let (x, y) = (*c.operands.get(2)?, *c.operands.get(3)?);
        let flipped = |op| match op {
            OP_UGREATER_THAN => Some(OP_ULESS_THAN),
            OP_SGREATER_THAN => Some(OP_SLESS_THAN),
            OP_UGREATER_THAN_EQUAL => Some(OP_ULESS_THAN_EQUAL),
            OP_SGREATER_THAN_EQUAL => Some(OP_SLESS_THAN_EQUAL),
            _ => None,
        };
        if let Some(v) = loaded_var(f, x) {
            return Some((v, Test { op: c.op, bound: y }, exit));
        }
        let v = loaded_var(f, y)?;
        return Some((
            v,
            Test {
                op: flipped(c.op)?,
                bound: x,
            },
            exit,
        ));
    }
    None
}

/// The constant step of `var` in the continue block: `var = var + step`.
fn counter_step(f: &Func, var: u32, cont: u32, known: &BTreeMap<u32, u64>) -> Option<u64> {
    let blk = f.blocks.get(&cont)?;
    let store = blk
        .insts
        .iter()
        .find(|i| i.op == OP_STORE && i.operands.first() == Some(&var))?;
    let add = def(f, *store.operands.get(1)?).filter(|i| i.op == OP_IADD)?;
    let (x, y) = (add.operands[2], add.operands[3]);
    match (loaded_var(f, x), loaded_var(f, y)) {
        (Some(v), _) if v == var => known.get(&y).copied(),
        (_, Some(v)) if v == var => known.get(&x).copied(),
        _ => None,
    }
}

/// The entry point a method's default dispatch runs: compute's `main_lanes1` for one lane per
/// ray, `main` for the thesis layout; fragment's `fs_exact_mip`; bvh's and compute's `main`;
/// ssr's `fs_main`; reflection-point's `search`.
pub fn entry_point(method: Method, one_lane: bool) -> Option<&'static str> {
    super::methods::model(method).map(|m| (m.entry_point)(one_lane))
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
/// unless asked; `one_lane` picks compute's entry point.
pub fn weights(method: Method, one_lane: bool, arms: Arms) -> Result<Vec<BlockWeight>> {
    let Some(entry) = entry_point(method, one_lane) else {
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

/// [`super::weights::weights`] and [`super::weights::lane_weights`] under `counting`; `one_lane` picks compute's entry point
/// for the dynamic count (`main_lanes1`, else `main`; the static count does not depend on it).
pub fn weights_by(
    method: Method,
    counting: Counting,
    one_lane: bool,
) -> Result<(Vec<f64>, Vec<f64>)> {
    match counting {
        Counting::Static => Ok((
            super::weights::weights(method)?,
            super::weights::lane_weights(method)?,
        )),
        Counting::Dynamic => {
            let w = weights(method, one_lane, Arms::Both)?;
            Ok((
                w.iter().map(|b| b.cost.all).collect(),
                w.iter().map(|b| b.cost.lane).collect(),
            ))
        }
    }
}

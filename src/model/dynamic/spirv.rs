#![forbid(unsafe_code)]
//! A pass's SPIR-V as the dynamic count walks it: its functions, their basic blocks and
//! instructions ([`Module`]), lane operations marked, dead values removed, and integer and
//! boolean instructions folded where their operands are known.
use std::collections::{BTreeMap, BTreeSet};

use anyhow::{Context, Result};

use crate::model::weights::{
    OP_ACCESS_CHAIN, OP_ATOMICS, OP_CONSTANTS, OP_FUNCTION, OP_FUNCTION_END, OP_FUNCTION_PARAMETER,
    OP_IMAGE_ACCESS, OP_IN_BOUNDS_ACCESS_CHAIN, OP_LABEL, OP_LOAD, OP_LOOP_MERGE, OP_NAME,
    OP_SELECTION_MERGE, OP_STORE, OP_SUBGROUP, OP_TYPE_POINTER, OP_VARIABLE, SC_FUNCTION,
    SC_PRIVATE, checked_words, instructions, is_free, is_lane_memory, literal,
};

pub(super) const OP_EXT_INST: u32 = 12;
pub(super) const OP_CONSTANT_TRUE: u32 = 41;
pub(super) const OP_CONSTANT_FALSE: u32 = 42;
pub(super) const OP_CONSTANT: u32 = 43;
pub(super) const OP_CONSTANT_NULL: u32 = 46;
pub(super) const OP_COPY_OBJECT: u32 = 83;
pub(super) const OP_IADD: u32 = 128;
pub(super) const OP_ISUB: u32 = 130;
pub(super) const OP_IMUL: u32 = 132;
pub(super) const OP_LOGICAL_EQUAL: u32 = 164;
pub(super) const OP_LOGICAL_NOT_EQUAL: u32 = 165;
pub(super) const OP_LOGICAL_OR: u32 = 166;
pub(super) const OP_LOGICAL_AND: u32 = 167;
pub(super) const OP_LOGICAL_NOT: u32 = 168;
pub(super) const OP_SELECT: u32 = 169;
pub(super) const OP_IEQUAL: u32 = 170;
pub(super) const OP_INOT_EQUAL: u32 = 171;
pub(super) const OP_UGREATER_THAN: u32 = 172;
pub(super) const OP_SGREATER_THAN: u32 = 173;
pub(super) const OP_UGREATER_THAN_EQUAL: u32 = 174;
pub(super) const OP_SGREATER_THAN_EQUAL: u32 = 175;
pub(super) const OP_ULESS_THAN: u32 = 176;
pub(super) const OP_SLESS_THAN: u32 = 177;
pub(super) const OP_ULESS_THAN_EQUAL: u32 = 178;
pub(super) const OP_SLESS_THAN_EQUAL: u32 = 179;
pub(super) const OP_BITWISE_OR: u32 = 197;
/// `OpCompositeConstruct` (`OpCompositeExtract`, `OpCompositeInsert` and `OpCopyObject` follow).
pub(super) const OP_COMPOSITE_CONSTRUCT: u32 = 80;
pub(super) const OP_BITWISE_AND: u32 = 199;
pub(super) const OP_BRANCH: u32 = 249;
pub(super) const OP_BRANCH_CONDITIONAL: u32 = 250;
pub(super) const OP_SWITCH: u32 = 251;
pub(super) const OP_KILL: u32 = 252;
pub(super) const OP_RETURN: u32 = 253;
pub(super) const OP_RETURN_VALUE: u32 = 254;
pub(super) const OP_UNREACHABLE: u32 = 255;
pub(super) const OP_TERMINATE_INVOCATION: u32 = 4416;

pub(super) fn is_terminator(op: u32) -> bool {
    (OP_BRANCH..=OP_UNREACHABLE).contains(&op) || op == OP_TERMINATE_INVOCATION
}

/// Value instructions without side effects, whose result id is `operands[1]`: removable when
/// nothing uses the result.
pub(super) fn is_pure(op: u32) -> bool {
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

/// Instructions and, of those, lane operations ([`crate::model::weights`] module docs).
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
pub(super) struct Inst {
    pub(super) op: u32,
    pub(super) operands: Vec<u32>,
    /// A lane operation.
    pub(super) lane: bool,
    /// Removed as unused (its result feeds nothing).
    pub(super) dead: bool,
    /// A register move ([`LaneTrack::register_move`]): walked (its values fold) but not counted.
    pub(super) free: bool,
}

#[derive(Clone, Debug, Default)]
pub(super) struct BasicBlock {
    pub(super) insts: Vec<Inst>,
    /// `(merge, continue)` of a loop header.
    pub(super) loop_merge: Option<(u32, u32)>,
    pub(super) selection_merge: Option<u32>,
    /// The terminator: opcode and operands.
    pub(super) term: (u32, Vec<u32>),
}

#[derive(Clone, Debug, Default)]
pub(super) struct Func {
    pub(super) params: Vec<u32>,
    pub(super) entry: u32,
    pub(super) blocks: BTreeMap<u32, BasicBlock>,
    /// Function variables' constant initialisers.
    pub(super) inits: BTreeMap<u32, u32>,
    /// The function's variables that are only stored to and loaded from, whole: no access
    /// chain, call or other instruction takes their address (naga's temporaries, e.g. the
    /// value of a short-circuit `a || b`), so a load reads the last store on the path walked.
    pub(super) scalar_vars: BTreeSet<u32>,
}

/// A pass's functions with their control flow, by WGSL name.
#[derive(Clone, Debug)]
pub struct Module {
    pub pass: String,
    pub(super) funcs: BTreeMap<u32, Func>,
    pub(super) names: BTreeMap<String, u32>,
    pub(super) ids: BTreeMap<u32, String>,
    /// Integer and boolean constants (bools as 0 / 1).
    pub(super) constants: BTreeMap<u32, u64>,
}

/// Lane-operation tracking while parsing (the same rules as [`crate::model::weights`]).
#[derive(Default)]
pub(super) struct LaneTrack {
    pub(super) pointer_types: BTreeMap<u32, u32>,
    pub(super) class_of: BTreeMap<u32, u32>,
    pub(super) constant_ids: BTreeSet<u32>,
    pub(super) dynamic: BTreeSet<u32>,
}

impl LaneTrack {
    pub(super) fn see(&mut self, op: u32, o: &[u32]) {
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

    /// Whether the instruction is a move that a GPU compiler's register promotion removes
    /// (module docs, "register moves"): a load, store or access chain of a function-local
    /// variable indexed by constants only (promoted to registers: mem2reg, SROA), or a
    /// composite construct, extract or insert or an object copy (register names).
    pub(super) fn register_move(&self, op: u32, o: &[u32]) -> bool {
        let pointer = match op {
            OP_LOAD => o.get(2),
            OP_STORE => o.first(),
            // The chain's result: dynamic where an index (or the base's) is a run-time value.
            OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN => o.get(1),
            OP_COMPOSITE_CONSTRUCT..=OP_COPY_OBJECT => return true,
            _ => return false,
        };
        pointer.is_some_and(|p| {
            let class = self.class_of.get(p).copied().unwrap_or(0);
            class == SC_FUNCTION && !self.dynamic.contains(p)
        })
    }

    pub(super) fn is_lane(&self, op: u32, o: &[u32]) -> bool {
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
    /// Reads `spirv/<shader>` from its checked debug-named copy ([`crate::model::weights`]).
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
                OP_VARIABLE if o.len() >= 2 => {
                    f.scalar_vars.insert(o[1]);
                    if o.len() >= 4 {
                        f.inits.insert(o[1], o[3]);
                    }
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
                            free: lanes.register_move(x, o),
                        });
                    }
                }
                _ => {}
            }
        }
        for f in funcs.values_mut() {
            remove_unused(f);
            keep_scalar_vars(f);
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

    pub(super) fn name(&self, id: u32) -> &str {
        self.ids.get(&id).map_or("?", String::as_str)
    }
}

/// Keeps in `f.scalar_vars` only the variables every use of which is the pointer of a whole
/// `OpStore` or `OpLoad`.
pub(super) fn keep_scalar_vars(f: &mut Func) {
    let mut escaped = BTreeSet::new();
    for b in f.blocks.values() {
        for i in &b.insts {
            for (k, w) in i.operands.iter().enumerate() {
                let pointer = (i.op == OP_STORE && k == 0) || (i.op == OP_LOAD && k == 2);
                if !pointer {
                    escaped.insert(*w);
                }
            }
        }
        escaped.extend(b.term.1.iter().copied());
    }
    f.scalar_vars.retain(|v| !escaped.contains(v));
}

/// Marks pure instructions whose results nothing uses as dead, until none is left.
pub(super) fn remove_unused(f: &mut Func) {
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
pub(super) fn fold(op: u32, o: &[u32], known: &BTreeMap<u32, u64>) -> Option<u64> {
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

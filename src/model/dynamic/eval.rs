#![forbid(unsafe_code)]
//! The walk of a function's structured control flow that gives its dynamic cost ([`Eval`]):
//! loops counted per trip where the code fixes their trips, calls followed with their known
//! arguments, one or both arms of an `if` that does not fold. A variable that is only stored to
//! and loaded from whole (`Func::scalar_vars`: naga's temporaries, such as the value of a
//! short-circuit `a || b`) carries a known value from its store to its loads along the path
//! walked, as a driver's promotion of variables to registers does: its value after an `if` is
//! the one every arm that reaches the merge agrees on, and a loop forgets the variables it stores.
use std::collections::{BTreeMap, BTreeSet};

use crate::model::weights::{OP_FUNCTION_CALL, OP_LOAD, OP_STORE};

use super::spirv::*;

/// Known values of a function's parameters at a call site (None: not constant).
pub type Ctx = Vec<Option<u64>>;

/// One loop found while walking, for the report.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopNote {
    pub function: String,
    pub header: u32,
    pub kind: LoopKind,
}

/// The key under which `known` holds a scalar variable's value (SPIR-V ids stay below 2^31).
const VAR_KEY: u32 = 1 << 31;

fn var_key(var: u32) -> u32 {
    var | VAR_KEY
}

/// A walk's end: the stop reached (a merge or continue target of an enclosing construct), or
/// None for a return.
pub(super) type Path = (Cost, Option<u32>);

/// Evaluates functions' dynamic costs with callees in `excluded` left out.
pub struct Eval<'m> {
    pub(super) m: &'m Module,
    pub(super) excluded: BTreeSet<u32>,
    pub(super) arms: Arms,
    pub(super) memo: BTreeMap<(u32, Ctx), Cost>,
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
        for (&var, init) in &f.inits {
            if let Some(&v) = f
                .scalar_vars
                .contains(&var)
                .then(|| m.constants.get(init))
                .flatten()
            {
                known.insert(var_key(var), v);
            }
        }
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
    pub(super) fn block_insts(
        &mut self,
        f: &Func,
        b: &BasicBlock,
        known: &mut BTreeMap<u32, u64>,
    ) -> Cost {
        // The terminator (a branch or return) counts, as in the static count.
        let mut c = Cost {
            all: 1.0,
            lane: 0.0,
        };
        for i in &b.insts {
            if i.dead {
                continue;
            }
            if i.op == OP_STORE && f.scalar_vars.contains(&i.operands[0]) {
                let key = var_key(i.operands[0]);
                match known.get(&i.operands[1]).copied() {
                    Some(v) => known.insert(key, v),
                    None => known.remove(&key),
                };
            }
            if i.op == OP_LOAD
                && let Some(&v) = f
                    .scalar_vars
                    .contains(&i.operands[2])
                    .then(|| known.get(&var_key(i.operands[2])))
                    .flatten()
            {
                known.insert(i.operands[1], v);
                continue;
            }
            if let Some(v) = fold(i.op, &i.operands, known) {
                known.insert(i.operands[1], v);
                continue;
            }
            if !i.free {
                c = c + Cost {
                    all: 1.0,
                    lane: f64::from(u8::from(i.lane)),
                };
            }
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
    pub(super) fn walk(
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
                // A variable the loop stores is unknown inside it and after it (the header's
                // stores, walked on `known` by `trip`, included).
                let body = loop_blocks(f, b, merge);
                forget_stored(f, &body, known);
                let kind = trips(f, b, merge, cont, known);
                self.loops.push(LoopNote {
                    function: self.m.name(fid).to_string(),
                    header: b,
                    kind,
                });
                let trip = self.trip(fid, f, b, merge, cont, known);
                forget_stored(f, &body, known);
                total = total + trip * kind.trips() as f64;
                b = merge;
                continue;
            }
            total = total + self.block_insts(f, blk, known);
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
    pub(super) fn arms(
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
        let mut paths: Vec<Path> = Vec::with_capacity(targets.len());
        let mut ends = Vec::with_capacity(targets.len());
        for t in targets {
            let mut k = known.clone();
            paths.push(self.walk(fid, f, *t, &inner, &mut k));
            ends.push(k);
        }
        // An arm that leaves for an enclosing construct's merge or continue target (a `break`)
        // carries its stores where this walk does not follow: forget the variables it changed.
        for (p, k) in paths.iter().zip(&ends) {
            if p.1.is_some() && p.1 != merge {
                forget_changed(known, k);
            }
        }
        let rest = match merge {
            Some(mg) if paths.iter().any(|p| p.1 == Some(mg)) => {
                let reaching: Vec<&BTreeMap<u32, u64>> = paths
                    .iter()
                    .zip(&ends)
                    .filter(|(p, _)| p.1 == Some(mg))
                    .map(|(_, k)| k)
                    .collect();
                merge_vars(known, &reaching);
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
    pub(super) fn trip(
        &mut self,
        fid: u32,
        f: &Func,
        header: u32,
        merge: u32,
        cont: u32,
        known: &mut BTreeMap<u32, u64>,
    ) -> Cost {
        let blk = &f.blocks[&header];
        let mut c = self.block_insts(f, blk, known);
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

/// The scalar variables' values where the arms `reaching` a merge meet: those they all agree on.
fn merge_vars(known: &mut BTreeMap<u32, u64>, reaching: &[&BTreeMap<u32, u64>]) {
    let keys: BTreeSet<u32> = known
        .range(VAR_KEY..)
        .map(|(k, _)| *k)
        .chain(
            reaching
                .iter()
                .flat_map(|k| k.range(VAR_KEY..).map(|(k, _)| *k)),
        )
        .collect();
    for key in keys {
        let first = reaching.first().and_then(|k| k.get(&key)).copied();
        match first {
            Some(v) if reaching.iter().all(|k| k.get(&key) == Some(&v)) => {
                known.insert(key, v);
            }
            _ => {
                known.remove(&key);
            }
        }
    }
}

/// Forgets the scalar variables whose value in `other` differs from `known`'s.
fn forget_changed(known: &mut BTreeMap<u32, u64>, other: &BTreeMap<u32, u64>) {
    let keys: BTreeSet<u32> = known
        .range(VAR_KEY..)
        .chain(other.range(VAR_KEY..))
        .filter(|(k, v)| known.get(k) != Some(v) || other.get(k) != Some(v))
        .map(|(k, _)| *k)
        .collect();
    for k in keys {
        known.remove(&k);
    }
}

/// Forgets the values of the scalar variables stored anywhere in `blocks` (a loop's).
fn forget_stored(f: &Func, blocks: &BTreeSet<u32>, known: &mut BTreeMap<u32, u64>) {
    for l in blocks {
        for i in f.blocks.get(l).map_or(&[][..], |b| &b.insts) {
            if i.op == OP_STORE && f.scalar_vars.contains(&i.operands[0]) {
                known.remove(&var_key(i.operands[0]));
            }
        }
    }
}

pub(super) fn switch_targets(o: &[u32], known: &BTreeMap<u32, u64>) -> Vec<u32> {
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
pub(super) fn loop_blocks(f: &Func, header: u32, merge: u32) -> BTreeSet<u32> {
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

pub(super) fn successors(b: &BasicBlock) -> Vec<u32> {
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
pub(super) fn def(f: &Func, id: u32) -> Option<&Inst> {
    f.blocks
        .values()
        .flat_map(|b| &b.insts)
        .find(|i| is_pure(i.op) && i.operands.get(1) == Some(&id))
}

/// The function variable `id` loads, if it is a load.
pub(super) fn loaded_var(f: &Func, id: u32) -> Option<u32> {
    def(f, id)
        .filter(|i| i.op == OP_LOAD)
        .map(|i| i.operands[2])
}

/// The trip count of the loop at `header` (module docs).
pub(super) fn trips(
    f: &Func,
    header: u32,
    merge: u32,
    cont: u32,
    known: &BTreeMap<u32, u64>,
) -> LoopKind {
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
pub(super) struct Test {
    pub(super) op: u32,
    pub(super) bound: u32,
}

impl Test {
    pub(super) fn count(&self, start: u64, step: u64, known: &BTreeMap<u32, u64>) -> Option<u64> {
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
pub(super) fn counter_test(f: &Func, header: u32, merge: u32) -> Option<(u32, Test, u32)> {
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
pub(super) fn counter_step(
    f: &Func,
    var: u32,
    cont: u32,
    known: &BTreeMap<u32, u64>,
) -> Option<u64> {
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

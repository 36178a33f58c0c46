//! The dynamic block weights (`model::dynamic`): loops per trip, constants of the entry point
//! carried into calls, dead arms removed; on hand-made modules with known counts, and on the
//! shipped shaders.

use crate::common::spirv_words::inst;
use std::collections::BTreeSet;

use cubetrace::method::Method;
use cubetrace::model::dynamic::{self, Arms, Contexts, Counting, Eval, LoopKind, Module};
use cubetrace::model::replay::ComputeLanes;
use cubetrace::model::weights::{self, ShaderFunctions};
use cubetrace::model::work::{COMPUTE_BLOCKS, blocks};

fn name(id: u32, s: &str) -> Vec<u32> {
    let mut bytes = s.as_bytes().to_vec();
    bytes.resize((bytes.len() / 4 + 1) * 4, 0);
    let mut o = vec![id];
    o.extend(
        bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])),
    );
    inst(5, &o)
}

/// What the hand-made module's loop tests its counter against.
#[derive(Clone, Copy)]
enum Bound {
    /// A constant (`%8`, whose value is given).
    Constant(u32),
    /// A value loaded from memory (no fixed trip count).
    Loaded,
}

/// A hand-made module:
/// - `f`: `for (var i = 0; i < bound; i++) { out = (i + 1) * (i + 1); }`, 13 instructions per
///   trip (header branch; load, compare, branch; the break's branch; add, multiply, store,
///   branch; load, add, store, branch) and 2 around it (entry branch, return);
/// - `g(flag)`: `if flag { out = (x * x) * x... }`: 7 instructions, 2 when `flag` is false;
/// - `entry`: calls `g(false)`; `entry2(p)`: calls `g(p)`.
fn module(bound: Bound) -> Vec<u32> {
    let mut w = vec![0x0723_0203, 0x0001_0300, 0, 100, 0];
    for (id, n) in [(10, "f"), (40, "g"), (50, "entry"), (60, "entry2")] {
        w.extend(name(id, n));
    }
    w.extend(inst(32, &[3, 7, 1])); // OpTypePointer Function %3
    w.extend(inst(32, &[4, 6, 1])); // OpTypePointer Private %4
    w.extend(inst(43, &[1, 6, 0])); // %6 = 0
    w.extend(inst(43, &[1, 7, 1])); // %7 = 1
    let b = match bound {
        Bound::Constant(n) => n,
        Bound::Loaded => 0,
    };
    w.extend(inst(43, &[1, 8, b])); // %8 = the bound
    w.extend(inst(42, &[5, 12])); // %12 = false
    w.extend(inst(59, &[4, 20, 6])); // %20: a private variable
    // f
    w.extend(inst(54, &[1, 10, 0, 9]));
    w.extend(inst(248, &[11]));
    w.extend(inst(59, &[3, 22, 7, 6])); // var i = 0
    w.extend(inst(249, &[13]));
    w.extend(inst(248, &[13])); // header
    w.extend(inst(246, &[14, 15, 0]));
    w.extend(inst(249, &[16]));
    w.extend(inst(248, &[16]));
    w.extend(inst(61, &[1, 23, 22])); // load i
    let bound_id = match bound {
        Bound::Constant(_) => 8,
        Bound::Loaded => 29,
    };
    if let Bound::Loaded = bound {
        w.extend(inst(61, &[1, 29, 20])); // the bound from memory
    }
    w.extend(inst(176, &[5, 24, 23, bound_id])); // i < bound
    w.extend(inst(247, &[17, 0]));
    w.extend(inst(250, &[24, 17, 18]));
    w.extend(inst(248, &[18]));
    w.extend(inst(249, &[14])); // break
    w.extend(inst(248, &[17]));
    w.extend(inst(128, &[1, 25, 23, 7]));
    w.extend(inst(132, &[1, 26, 25, 25]));
    w.extend(inst(62, &[20, 26]));
    w.extend(inst(249, &[15]));
    w.extend(inst(248, &[15])); // continue: i += 1
    w.extend(inst(61, &[1, 27, 22]));
    w.extend(inst(128, &[1, 28, 27, 7]));
    w.extend(inst(62, &[22, 28]));
    w.extend(inst(249, &[13]));
    w.extend(inst(248, &[14]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    // g(flag)
    w.extend(inst(54, &[1, 40, 0, 9]));
    w.extend(inst(55, &[5, 41]));
    w.extend(inst(248, &[42]));
    w.extend(inst(247, &[44, 0]));
    w.extend(inst(250, &[41, 43, 44]));
    w.extend(inst(248, &[43]));
    w.extend(inst(61, &[1, 45, 20]));
    w.extend(inst(132, &[1, 46, 45, 45]));
    w.extend(inst(132, &[1, 47, 46, 46]));
    w.extend(inst(62, &[20, 47]));
    w.extend(inst(249, &[44]));
    w.extend(inst(248, &[44]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    // entry: g(false); entry2(p): g(p)
    w.extend(inst(54, &[1, 50, 0, 9]));
    w.extend(inst(248, &[51]));
    w.extend(inst(57, &[1, 52, 40, 12]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    w.extend(inst(54, &[1, 60, 0, 9]));
    w.extend(inst(55, &[5, 61]));
    w.extend(inst(248, &[62]));
    w.extend(inst(57, &[1, 63, 40, 61]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    w
}

/// `name`'s dynamic count in `m` with the constants of `entry`, callees included.
fn dynamic_count(m: &Module, name: &str, entry: &str) -> (f64, Vec<LoopKind>) {
    let ctx = Contexts::from_entry(m, entry).unwrap();
    let id = m.id(name).unwrap();
    let mut e = Eval::new(m, BTreeSet::new(), Arms::Both);
    let known = ctx.by_function.get(&id).cloned().unwrap_or_default();
    let c = e.function(id, &known);
    (c.all, e.loops.iter().map(|l| l.kind).collect())
}

fn static_count(words: &[u32], name: &str) -> u64 {
    let f = ShaderFunctions::parse("hand", words).unwrap();
    f.expanded(name, &BTreeSet::new()).unwrap()
}

/// A loop with a fixed trip count counts its body per trip; the static count, once. Negatives:
/// another bound gives another count, and a bound loaded from memory counts the body once.
#[test]
fn a_counted_loop_costs_its_body_per_trip() {
    let words = module(Bound::Constant(8));
    let m = Module::parse("hand", &words).unwrap();
    assert_eq!(static_count(&words, "f"), 15);
    // Per trip 10: the counter's two loads and its store are register moves (`i` is a local).
    assert_eq!(
        dynamic_count(&m, "f", "entry"),
        (2.0 + 10.0 * 8.0, vec![LoopKind::Exact(8)])
    );
    let three = Module::parse("hand", &module(Bound::Constant(3))).unwrap();
    assert_eq!(dynamic_count(&three, "f", "entry").0, 2.0 + 10.0 * 3.0);
    let words = module(Bound::Loaded);
    let loaded = Module::parse("hand", &words).unwrap();
    let (n, loops) = dynamic_count(&loaded, "f", "entry");
    assert_eq!(loops, vec![LoopKind::Unknown]);
    // Once: the loaded bound adds its load (a private variable's: counted).
    assert_eq!(n, 2.0 + 11.0);
    assert_eq!(static_count(&words, "f"), 16);
}

/// A parameter every live call passes the same constant folds its branch: `g(false)` from
/// `entry` costs its branch and return only. Negative: from `entry2`, whose argument is not a
/// constant, both arms count, as in the static count.
#[test]
fn an_entry_points_constant_removes_the_dead_arm() {
    let words = module(Bound::Constant(8));
    let m = Module::parse("hand", &words).unwrap();
    assert_eq!(static_count(&words, "g"), 7);
    assert_eq!(dynamic_count(&m, "g", "entry").0, 2.0);
    assert_eq!(dynamic_count(&m, "g", "entry2").0, 7.0);
    // The entry point itself: its call, its return, and g's live part.
    assert_eq!(dynamic_count(&m, "entry", "entry").0, 2.0 + 2.0);
}

const MODELLED: [Method; 5] = [
    Method::Compute,
    Method::Fragment,
    Method::Ssr,
    Method::ReflectionPoint,
    Method::Bvh,
];

/// Every block of every modelled method has a positive dynamic weight and lane operations
/// below it, in each of compute's entry points.
#[test]
fn every_block_has_a_dynamic_weight() {
    for m in MODELLED {
        for layout in [ComputeLanes::Auto, ComputeLanes::Thesis, ComputeLanes::One] {
            let (w, lane) = dynamic::weights_by(m, Counting::Dynamic, layout).unwrap();
            assert_eq!(w.len(), blocks(m).len(), "{}", m.name());
            for (i, (x, l)) in w.iter().zip(&lane).enumerate() {
                let b = blocks(m)[i].name;
                assert!(*x > 0.0 && l <= x, "{} {b}: {x} {l}", m.name());
            }
        }
    }
}

/// bvh's node visit runs its 8-child loop 8 times: the dynamic weight is several times the
/// static one. Negative: the traversal's iteration block (no counted loop of its own) is not.
#[test]
fn the_bvh_node_counts_its_children_per_trip() {
    let st = weights::weights(Method::Bvh).unwrap();
    let dy = dynamic::weights(Method::Bvh, ComputeLanes::Auto, Arms::Both).unwrap();
    let index = |n: &str| {
        blocks(Method::Bvh)
            .iter()
            .position(|b| b.name == n)
            .unwrap()
    };
    let per_trip = |i: usize| {
        dy[i].loops.iter().any(|l| l.kind == LoopKind::Exact(8)) && dy[i].cost.all > 4.0 * st[i]
    };
    assert!(
        per_trip(index("node")),
        "{:?} {}",
        dy[index("node")],
        st[index("node")]
    );
    assert!(!per_trip(index("iteration")));
}

/// compute's `advance` calls the bounded classification only under the bounded entry points:
/// under `main_lanes1` that arm is dead and its instructions do not count. Negative: under
/// `main_lanes1_bounded` they do.
#[test]
fn the_bounded_arm_of_advance_is_dead_in_the_exact_entry_point() {
    let i = COMPUTE_BLOCKS
        .iter()
        .position(|b| b.name == "advance")
        .unwrap();
    let exact = dynamic::block_weights(COMPUTE_BLOCKS, "main_lanes1", Arms::Both).unwrap();
    let bounded =
        dynamic::block_weights(COMPUTE_BLOCKS, "main_lanes1_bounded", Arms::Both).unwrap();
    let f = ShaderFunctions::of("compute_trace.wgsl").unwrap();
    let pick = f
        .expanded("classify_bounded_pick", &BTreeSet::new())
        .unwrap() as f64;
    let (a, b) = (exact[i].cost.all, bounded[i].cost.all);
    assert!(a + 0.5 * pick < b, "exact {a}, bounded {b}, pick {pick}");
    assert!(b <= weights::weights(Method::Compute).unwrap()[i] * 1.01 + pick);
}

/// A hand-made module for the scalar variables (`Func::scalar_vars`), the shape of naga's
/// short-circuit temporaries:
/// - `h(flag)`: `var tmp; if flag { tmp = first } else { tmp = false }; if tmp { out = x * x *
///   x }`: entry branch 1, each arm's branch 1 (its store to the local `tmp` is a register
///   move), the branch 1 (the load of `tmp` too), the second `if`'s arm 5 (the private `out`'s
///   load, two multiplies, its store, branch), return 1;
/// - `entry3`: calls `h(false)`; `entry4(p)`: calls `h(p)`.
fn temporary_module(first: bool) -> Vec<u32> {
    let mut w = vec![0x0723_0203, 0x0001_0300, 0, 100, 0];
    for (id, n) in [(70, "h"), (90, "entry3"), (95, "entry4")] {
        w.extend(name(id, n));
    }
    w.extend(inst(32, &[74, 7, 5])); // OpTypePointer Function bool
    w.extend(inst(32, &[4, 6, 1])); // OpTypePointer Private %1
    w.extend(inst(41, &[5, 13])); // %13 = true
    w.extend(inst(42, &[5, 12])); // %12 = false
    w.extend(inst(59, &[4, 20, 6])); // %20: a private variable
    // h(flag)
    w.extend(inst(54, &[1, 70, 0, 9]));
    w.extend(inst(55, &[5, 71]));
    w.extend(inst(248, &[72]));
    w.extend(inst(59, &[74, 73, 7])); // var tmp
    w.extend(inst(247, &[76, 0]));
    w.extend(inst(250, &[71, 75, 77]));
    w.extend(inst(248, &[75]));
    w.extend(inst(62, &[73, if first { 13 } else { 12 }]));
    w.extend(inst(249, &[76]));
    w.extend(inst(248, &[77]));
    w.extend(inst(62, &[73, 12]));
    w.extend(inst(249, &[76]));
    w.extend(inst(248, &[76]));
    w.extend(inst(61, &[5, 78, 73])); // load tmp
    w.extend(inst(247, &[80, 0]));
    w.extend(inst(250, &[78, 79, 80]));
    w.extend(inst(248, &[79]));
    w.extend(inst(61, &[1, 81, 20]));
    w.extend(inst(132, &[1, 82, 81, 81]));
    w.extend(inst(132, &[1, 83, 82, 82]));
    w.extend(inst(62, &[20, 83]));
    w.extend(inst(249, &[80]));
    w.extend(inst(248, &[80]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    // entry3: h(false); entry4(p): h(p)
    w.extend(inst(54, &[1, 90, 0, 9]));
    w.extend(inst(248, &[91]));
    w.extend(inst(57, &[1, 92, 70, 12]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    w.extend(inst(54, &[1, 95, 0, 9]));
    w.extend(inst(55, &[5, 96]));
    w.extend(inst(248, &[97]));
    w.extend(inst(57, &[1, 98, 70, 96]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    w
}

/// A hand-made module for the register moves: `s(x)` builds a pair `(x, x)`, stores it in a
/// local, overwrites field 0 through an access chain, loads the pair back, takes field 0, squares
/// it and stores the square in a private variable; `idx` is true to index the field by `x` (a
/// run-time index) instead of the constant 0.
fn moves_module(idx: bool) -> Vec<u32> {
    let mut w = vec![0x0723_0203, 0x0001_0300, 0, 100, 0];
    w.extend(name(30, "s"));
    w.extend(inst(32, &[74, 7, 5])); // OpTypePointer Function %5
    w.extend(inst(32, &[4, 6, 1])); // OpTypePointer Private %1
    w.extend(inst(43, &[1, 6, 0])); // %6 = 0
    w.extend(inst(59, &[4, 20, 6])); // %20: a private variable
    w.extend(inst(54, &[1, 30, 0, 9]));
    w.extend(inst(55, &[5, 31])); // x
    w.extend(inst(248, &[32]));
    w.extend(inst(59, &[74, 33, 7])); // var pair
    w.extend(inst(80, &[5, 34, 31, 31])); // (x, x)
    w.extend(inst(62, &[33, 34]));
    w.extend(inst(65, &[74, 35, 33, if idx { 31 } else { 6 }])); // &pair[0] or &pair[x]
    w.extend(inst(62, &[35, 31]));
    w.extend(inst(61, &[5, 36, 33]));
    w.extend(inst(81, &[1, 37, 36, 0])); // .0
    w.extend(inst(132, &[1, 38, 37, 37]));
    w.extend(inst(62, &[20, 38]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    w
}

/// A struct passed through a local is register moves, which cost nothing: of `s`'s nine
/// counted instructions (the static count) the multiply, the private store and the return
/// remain. Negative: with the field indexed at run time the access chain and the store
/// through it count (a local array a GPU keeps in memory).
#[test]
fn register_moves_cost_nothing() {
    let words = moves_module(false);
    assert_eq!(static_count(&words, "s"), 9);
    let m = Module::parse("hand", &words).unwrap();
    assert_eq!(dynamic_count(&m, "s", "s").0, 3.0);
    let dynamic = Module::parse("hand", &moves_module(true)).unwrap();
    assert_eq!(dynamic_count(&dynamic, "s", "s").0, 5.0);
}

/// A temporary stored on the path walked carries its value to its load: `h(false)` stores
/// `false`, so the second `if` folds and its arm is dead (the driver's promotion of the
/// variable to a register does the same). Negatives: `h(p)` with the arms storing `true` and
/// `false` counts the second arm (the arms disagree at the merge); with both arms storing
/// `false` it is dead for any `p` (they agree).
#[test]
fn a_temporary_carries_its_stored_value_to_its_load() {
    let m = Module::parse("hand", &temporary_module(true)).unwrap();
    assert_eq!(dynamic_count(&m, "h", "entry3").0, 1.0 + 1.0 + 1.0 + 1.0);
    assert_eq!(
        dynamic_count(&m, "h", "entry4").0,
        1.0 + 1.0 * 2.0 + 1.0 + 5.0 + 1.0
    );
    let same = Module::parse("hand", &temporary_module(false)).unwrap();
    assert_eq!(
        dynamic_count(&same, "h", "entry4").0,
        1.0 + 1.0 * 2.0 + 1.0 + 1.0
    );
}

/// The production fragment entry point (`fs_exact_mip`) passes `strict_code = false` down to
/// `classify_candidate`, whose `!strict_code || strict == 0 || decisive_patch_hit(..)` naga
/// writes through temporaries: the `--strict` test is dead there and is not called on a live
/// path. Negative: under the generic `fs_main` (strict read from the config at run time) it is.
#[test]
fn the_strict_test_is_dead_in_the_production_fragment_entry() {
    let m = Module::of("fragment_trace.wgsl").unwrap();
    let strict = m.id("decisive_patch_hit").unwrap();
    let called = |entry: &str| {
        Contexts::from_entry(&m, entry)
            .unwrap()
            .by_function
            .contains_key(&strict)
    };
    assert!(!called("fs_exact_mip"));
    assert!(called("fs_main"));
}

/// A hand-made module for a temporary stored inside a loop, `k()`: `var tmp = false` (stored
/// before the loop); `loop { if x == 0 { break; } tmp = true; }` (when `store_in_loop`); then
/// `if tmp { out = (x * x) * x }` (those 4 instructions only when `arm`); `entry5` calls `k()`.
fn loop_module(arm: bool, store_in_loop: bool) -> Vec<u32> {
    let mut w = vec![0x0723_0203, 0x0001_0300, 0, 200, 0];
    for (id, n) in [(100, "k"), (120, "entry5")] {
        w.extend(name(id, n));
    }
    w.extend(inst(32, &[74, 7, 5])); // OpTypePointer Function bool
    w.extend(inst(32, &[4, 6, 1])); // OpTypePointer Private %1
    w.extend(inst(43, &[1, 6, 0])); // %6 = 0
    w.extend(inst(41, &[5, 13])); // %13 = true
    w.extend(inst(42, &[5, 12])); // %12 = false
    w.extend(inst(59, &[4, 20, 6])); // %20: a private variable
    w.extend(inst(54, &[1, 100, 0, 9]));
    w.extend(inst(248, &[101]));
    w.extend(inst(59, &[74, 102, 7])); // var tmp
    w.extend(inst(62, &[102, 12])); // tmp = false
    w.extend(inst(249, &[103]));
    w.extend(inst(248, &[103])); // header
    w.extend(inst(246, &[104, 105, 0]));
    w.extend(inst(249, &[106]));
    w.extend(inst(248, &[106]));
    w.extend(inst(61, &[1, 107, 20]));
    w.extend(inst(170, &[5, 108, 107, 6])); // x == 0
    w.extend(inst(247, &[109, 0]));
    w.extend(inst(250, &[108, 110, 109]));
    w.extend(inst(248, &[110]));
    w.extend(inst(249, &[104])); // break
    w.extend(inst(248, &[109]));
    if store_in_loop {
        w.extend(inst(62, &[102, 13])); // tmp = true
    }
    w.extend(inst(249, &[105]));
    w.extend(inst(248, &[105])); // continue
    w.extend(inst(249, &[103]));
    w.extend(inst(248, &[104])); // after the loop
    w.extend(inst(61, &[5, 111, 102])); // load tmp
    w.extend(inst(247, &[113, 0]));
    w.extend(inst(250, &[111, 112, 113]));
    w.extend(inst(248, &[112]));
    if arm {
        w.extend(inst(61, &[1, 114, 20]));
        w.extend(inst(132, &[1, 115, 114, 114]));
        w.extend(inst(132, &[1, 116, 115, 115]));
        w.extend(inst(62, &[20, 116]));
    }
    w.extend(inst(249, &[113]));
    w.extend(inst(248, &[113]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    w.extend(inst(54, &[1, 120, 0, 9]));
    w.extend(inst(248, &[121]));
    w.extend(inst(57, &[1, 122, 100]));
    w.extend(inst(253, &[]));
    w.extend(inst(56, &[]));
    w
}

/// A loop forgets the temporaries it stores: `tmp` is `false` before the loop and may be `true`
/// after it, so the `if tmp` after the loop counts its arm (its 4 instructions). Negative: with
/// no store in the loop, `tmp` is `false` after it and the arm is dead.
#[test]
fn a_loop_forgets_the_temporaries_it_stores() {
    let count = |arm: bool, store: bool| {
        let m = Module::parse("hand", &loop_module(arm, store)).unwrap();
        dynamic_count(&m, "k", "entry5").0
    };
    assert_eq!(count(true, true) - count(false, true), 4.0);
    assert_eq!(count(true, false) - count(false, false), 0.0);
}

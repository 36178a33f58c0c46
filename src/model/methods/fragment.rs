#![forbid(unsafe_code)]
//! fragment's model: `fragment_trace.wgsl`'s blocks and loop nest, and a ray's work in it.
use crate::cpu::{Status, Work};
use crate::method::Method;
use crate::model::blocks::{Block, Stmt, b};
use crate::model::frame::{Addr, Frame, MirrorRay, run_logged, verify_loads};
use crate::model::rays::{Exec, FrameWork, Iter, Recorded};
use crate::model::warps::{Assembly, Items, LAVAPIPE_TILE};

use super::MethodModel;

/// What the cost model knows of fragment.
pub const MODEL: MethodModel = MethodModel {
    method: Method::Fragment,
    blocks: FRAGMENT_BLOCKS,
    program: Some(FRAGMENT_PROGRAM),
    assembly: Assembly::Quads,
    lavapipe_items: |_, _| Items::Tiles(LAVAPIPE_TILE),
    entry_point: |_| "fs_exact_mip",
    layouts: &[],
    record,
};

fn record(frame: &Frame) -> anyhow::Result<Recorded> {
    let mut idle = Iter::default();
    idle.execs.push(Exec {
        block: F_RAY_SETUP,
        loads: Vec::new(),
    });
    let work = FrameWork::Tree {
        program: FRAGMENT_PROGRAM,
        rays: frame.rays.iter().map(|r| fragment_ray(frame, r)).collect(),
        idle,
    };
    Ok(Recorded::per_pixel(Method::Fragment, frame, work))
}

const FRAGMENT: &str = "fragment_trace.wgsl";

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
    // The 3x3 texel search (`locate` after a skip, `next_texel` after a texel), where the
    // texel tried first is not certified: the neighbourhood's 13 planes clipped once,
    // combined per candidate (its callees included).
    b("texel_search", FRAGMENT, &["texel_search_face"]),
    // One cell test of the pyramid (the inner loop).
    b(
        "cell_test",
        FRAGMENT,
        &["cell_interval_face", "inflated", "r_bounds_from", "mip_get"],
    ),
    // The exact classification of a texel: its distance and whether it is a candidate (not
    // entirely in front).
    b("classify", FRAGMENT, &["classify_with"]),
    // Verification of a hit against the captured triangle IDs.
    b("verify", FRAGMENT, &["verify_decision"]),
    // Shading a hit for the record.
    b("shade", FRAGMENT, &["hit_shade"]),
    // The texel tried first at a search and its certificate (`texel_certified_face`: one
    // interval on the face's constants), every search.
    b("texel_check", FRAGMENT, &["texel_certified_face"]),
    // A candidate texel's outcome (its hit or behind): the turn of a trace's deciding texel, so
    // a warp issues it only where one of its lanes decides.
    b("decide", FRAGMENT, &["classify_candidate"]),
];

/// Fragment's loops: the traces (rounds x CMOs, flattened), pieces, faces, turns of the march,
/// cell tests.
pub const L_TRACE: u16 = 0;
pub const L_PIECE: u16 = 1;
pub const L_FACE: u16 = 2;
pub const L_TURN: u16 = 3;
pub const L_CELL: u16 = 4;

/// fragment_trace.wgsl's nest (`trace_ray_verified` > `trace_mip` > `mip_turn`).
pub const FRAGMENT_PROGRAM: &[Stmt] = &[
    Stmt::Block(F_RAY_SETUP),
    Stmt::Loop(
        L_TRACE,
        &[
            Stmt::Block(F_CMO_TRACE),
            Stmt::Loop(
                L_PIECE,
                &[Stmt::Loop(
                    L_FACE,
                    &[
                        Stmt::Block(F_FACE),
                        Stmt::Loop(
                            L_TURN,
                            &[
                                Stmt::Block(F_TURN),
                                Stmt::Block(F_TEXEL_CHECK),
                                Stmt::Block(F_TEXEL_SEARCH),
                                Stmt::Loop(L_CELL, &[Stmt::Block(F_CELL_TEST)]),
                                Stmt::Block(F_CLASSIFY),
                                Stmt::Block(F_DECIDE),
                            ],
                        ),
                    ],
                )],
            ),
            Stmt::Block(F_VERIFY),
        ],
    ),
    Stmt::Block(F_SHADE),
];

// Indices into FRAGMENT_BLOCKS.
pub const F_RAY_SETUP: usize = 0;
pub const F_CMO_TRACE: usize = 1;
pub const F_FACE: usize = 2;
pub const F_TURN: usize = 3;
pub const F_TEXEL_SEARCH: usize = 4;
pub const F_CELL_TEST: usize = 5;
pub const F_CLASSIFY: usize = 6;
pub const F_VERIFY: usize = 7;
pub const F_SHADE: usize = 8;
pub const F_TEXEL_CHECK: usize = 9;
pub const F_DECIDE: usize = 10;

/// A fragment ray's work in fragment_trace.wgsl's loop nest ([`FRAGMENT_PROGRAM`]).
pub fn fragment_ray(frame: &Frame, ray: &MirrorRay) -> Iter {
    let addr = Addr {
        layout: frame.settings.layout,
    };
    let (logs, hit) = run_logged(frame, ray, |tr, seg, log| {
        crate::cpu::mip::trace_mip_logged(tr, seg, log)
    });
    let mut top = Iter::default();
    top.exec(F_RAY_SETUP, Vec::new());
    for t in &logs {
        let n = frame.cmos[t.k].cube.size;
        let k = t.k as u32;
        let trace = top.new_turn(L_TRACE);
        trace.exec(F_CMO_TRACE, Vec::new());
        let deciding = t.deciding();
        for (i, e) in t.events.iter().enumerate() {
            match *e {
                Work::Piece => {
                    trace.new_turn(L_PIECE);
                }
                Work::Face => {
                    trace
                        .last_turn(L_PIECE)
                        .new_turn(L_FACE)
                        .exec(F_FACE, Vec::new());
                }
                Work::Search { full, .. } => {
                    let turn = trace.last_turn(L_PIECE).last_turn(L_FACE).new_turn(L_TURN);
                    turn.exec(F_TURN, Vec::new());
                    turn.exec(F_TEXEL_CHECK, Vec::new());
                    if full {
                        turn.exec(F_TEXEL_SEARCH, Vec::new());
                    }
                }
                Work::Cell { level, face, x, y } => {
                    let turn = trace.last_turn(L_PIECE).last_turn(L_FACE).last_turn(L_TURN);
                    turn.new_turn(L_CELL)
                        .exec(F_CELL_TEST, vec![addr.mip(k, n, level, face, x, y)]);
                }
                Work::Classify(tex) => {
                    let turn = trace.last_turn(L_PIECE).last_turn(L_FACE).last_turn(L_TURN);
                    turn.exec(F_CLASSIFY, vec![addr.distance(k, n, tex)]);
                    if deciding == Some(i) {
                        turn.exec(F_DECIDE, Vec::new());
                    }
                }
                _ => {}
            }
        }
        if t.result.status == Status::Hit {
            trace.exec(F_VERIFY, verify_loads(frame, &addr, t.k, t.result.texel));
        }
    }
    if hit {
        top.exec(F_SHADE, Vec::new());
    }
    top
}

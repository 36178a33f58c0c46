#![forbid(unsafe_code)]
//! compute's model: `compute_trace.wgsl`'s blocks, and a ray's work as `trace_queued` runs it
//! (settle phases and subgroup-synchronous steps, replayed apart from the tree-shaped methods).
use crate::cpu::{Status, Work};
use crate::cubemap::face::Texel;
use crate::method::Method;
use crate::model::blocks::{Block, b};
use crate::model::frame::{Addr, ComputeLanes, Frame, MirrorRay, run_logged, verify_loads};
use crate::model::rays::{ComputeRay, FrameWork, Phase, Recorded, SettleTurn, Step, Visit};
use crate::model::warps::{Assembly, Items};

use super::MethodModel;

/// What the cost model knows of compute.
pub const MODEL: MethodModel = MethodModel {
    method: Method::Compute,
    blocks: COMPUTE_BLOCKS,
    program: None,
    assembly: Assembly::Queue,
    lavapipe_items: |width, lanes| Items::Groups(lavapipe_compute_group(width) / lanes.max(1)),
    // The GPU default is the wave layout (`vk::methods::compute::ray_lanes`).
    entry_point: |layout| match layout {
        ComputeLanes::Auto | ComputeLanes::Wave => "main_wave",
        ComputeLanes::Thesis => "main",
        ComputeLanes::One => "main_lanes1",
    },
    layouts: &[ComputeLanes::Thesis, ComputeLanes::One],
    record,
};

/// `compute_trace`'s workgroup size on lavapipe at subgroup size `width`: 256 invocations, or 128
/// where 256 would be more than the 32 subgroups lavapipe allows per workgroup
/// (`vk::methods::compute::workgroup_size`).
pub fn lavapipe_compute_group(width: u32) -> u32 {
    if 256 / width.max(1) > 32 { 128 } else { 256 }
}

fn record(frame: &Frame) -> anyhow::Result<Recorded> {
    let rays = frame.rays.iter().map(|r| compute_ray(frame, r)).collect();
    Ok(Recorded::per_pixel(
        Method::Compute,
        frame,
        FrameWork::Compute(rays),
    ))
}

const COMPUTE: &str = "compute_trace.wgsl";

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
    // The exact pre-test of a node's children with one ray per lane (`main_lanes1`, `main_wave`:
    // with the keys).
    b("children_crossed", COMPUTE, &["children_crossed"]),
    // One round of lane tests: each lane of a ray tests one child (with its ballot).
    b("lane_test", COMPUTE, &["lane_test", "test_ray"]),
    // The pick of the first candidate (min key over the ray's lanes, ballot of the holders).
    b("pick", COMPUTE, &["key_get", "ray_bits"]),
    // One traversal step: descend, backtrack, next face, or classify.
    b("advance", COMPUTE, &["advance"]),
    // The exact classification of a texel candidate (inside `advance` at level 1).
    b("classify", COMPUTE, &["classify_with"]),
    // Shading a hit for the record.
    b("shade", COMPUTE, &["hit_shade"]),
    // A piece's faces, found on its first visit inside `enter_face` (six frustum intervals and
    // their order): a block of its own, so that `enter_face`'s other calls do not carry it.
    b("faces_crossed", COMPUTE, &["faces_crossed"]),
    // A candidate texel's outcome (its hit or behind, inside `classify`): the step of a trace's
    // deciding texel, so a warp issues it only where one of its rays decides.
    b("decide", COMPUTE, &["classify_candidate"]),
    // The wave layout (`main_wave`): the prefix sums of a turn's crossed children, one round's
    // item fetched from its ray's lane (the node's `child_grid` too, which `visit` names), and
    // the round's candidate bits gathered back.
    b("wave_items", COMPUTE, &["wave_items"]),
    b("wave_item", COMPUTE, &["wave_item", "child_grid"]),
    b("wave_collect", COMPUTE, &["wave_collect"]),
    // The pick of the first candidate with one ray per lane (`main_lanes1`, `main_wave`), before
    // each step of a turn's run of steps that test no node.
    b("pick_one", COMPUTE, &["pick_one"]),
];

// Indices into COMPUTE_BLOCKS.
pub const C_SETTLE: usize = 0;
pub const C_START_TRACE: usize = 1;
pub const C_ENTER_FACE: usize = 2;
pub const C_HANDOFF: usize = 3;
pub const C_VERIFY: usize = 4;
pub const C_VISIT: usize = 5;
pub const C_CHILDREN_CROSSED: usize = 6;
pub const C_LANE_TEST: usize = 7;
pub const C_PICK: usize = 8;
pub const C_ADVANCE: usize = 9;
pub const C_CLASSIFY: usize = 10;
pub const C_SHADE: usize = 11;
pub const C_FACES_CROSSED: usize = 12;
pub const C_DECIDE: usize = 13;
pub const C_WAVE_ITEMS: usize = 14;
pub const C_WAVE_ITEM: usize = 15;
pub const C_WAVE_COLLECT: usize = 16;
pub const C_PICK_ONE: usize = 17;

/// A compute ray's work as `trace_queued` runs it (settle phases and steps).
pub fn compute_ray(frame: &Frame, ray: &MirrorRay) -> ComputeRay {
    let addr = Addr {
        layout: frame.settings.layout,
    };
    let (logs, hit) = run_logged(frame, ray, |tr, seg, log| {
        crate::cpu::compute::trace_alg3_logged(tr, std::slice::from_ref(seg), 32, log)[0]
    });
    let mut out = ComputeRay {
        hit,
        ..ComputeRay::default()
    };
    // The settle turns pending: the first trace's start.
    let mut settle = vec![SettleTurn {
        start: true,
        enter: true,
        faces: true,
        ..SettleTurn::default()
    }];
    for (i, t) in logs.iter().enumerate() {
        let tr = &frame.cmos[t.k];
        let n = tr.cube.size;
        let k = t.k as u32;
        out.texels += t.result.counters.texels;
        out.cells += t.result.counters.cells;
        let mut step = Step::default();
        let deciding = t.deciding();
        for (i, e) in t.events.iter().enumerate() {
            match *e {
                Work::Visit {
                    face,
                    level,
                    node,
                    group,
                    exists,
                    crossed,
                } => {
                    if !settle.is_empty() {
                        out.phases.push(Phase::Settle(std::mem::take(&mut settle)));
                    }
                    let mut loads = Vec::new();
                    for j in 0..32u32 {
                        if exists >> j & 1 == 0 {
                            continue;
                        }
                        let (cx, cy) = (
                            node.0 * group.0 + j % group.0,
                            node.1 * group.1 + j / group.0,
                        );
                        let a = if level == 1 {
                            addr.distance(k, n, Texel { face, x: cx, y: cy })
                        } else {
                            addr.hier(k, n, level - 1, face, cx, cy)
                        };
                        loads.push((j as u8, a));
                    }
                    step.visit = Some(Visit {
                        level,
                        children: group.0 * group.1,
                        loads,
                        crossed,
                    });
                }
                Work::Classify(tex) => {
                    step.classify = Some(addr.distance(k, n, tex));
                    step.decide = deciding == Some(i);
                }
                Work::Step { left_face, done: _ } => {
                    if !settle.is_empty() {
                        out.phases.push(Phase::Settle(std::mem::take(&mut settle)));
                    }
                    out.phases.push(Phase::Step(std::mem::take(&mut step)));
                    if left_face {
                        // `settle` enters the next face (and finds none left when `done`).
                        settle.push(SettleTurn {
                            enter: true,
                            ..SettleTurn::default()
                        });
                    }
                }
                _ => {}
            }
        }
        // The trace ended: the next settle turn hands off (verifying a hit), and starts the
        // next trace if there is one.
        let verify = if t.result.status == Status::Hit {
            verify_loads(frame, &addr, t.k, t.result.texel)
        } else {
            Vec::new()
        };
        let more = i + 1 < logs.len();
        settle.push(SettleTurn {
            handoff: true,
            verify,
            start: more,
            enter: more,
            faces: more,
        });
    }
    out.phases.push(Phase::Settle(settle));
    out
}

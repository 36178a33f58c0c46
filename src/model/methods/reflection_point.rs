#![forbid(unsafe_code)]
//! reflection-point's model: `reflection_point_search.wgsl`'s blocks and loop nest, and each
//! scene vertex's search in it.
use crate::cpu::Work;
use crate::method::Method;
use crate::model::blocks::{Block, Stmt, b};
use crate::model::frame::{Addr, BUF_RP, Frame};
use crate::model::rays::{FrameWork, Iter, Recorded};
use crate::model::warps::{Assembly, Items};
use glam::Vec3;

use super::MethodModel;

/// What the cost model knows of reflection-point.
pub const MODEL: MethodModel = MethodModel {
    method: Method::ReflectionPoint,
    blocks: REFLECTION_POINT_BLOCKS,
    program: Some(REFLECTION_POINT_PROGRAM),
    assembly: Assembly::Dispatch,
    lavapipe_items: |_, _| Items::Groups(64),
    entry_point: |_| "search",
    layouts: &[],
    record,
};

/// One invocation per scene vertex, in the dispatch's order; reflectors' vertices leave at once
/// (idle lanes).
fn record(frame: &Frame) -> anyhow::Result<Recorded> {
    let mut rays = Vec::new();
    let ray_at = reflection_point_vertices(frame)
        .into_iter()
        .map(|v| {
            v.map(|(it, _)| {
                rays.push(it);
                rays.len() - 1
            })
        })
        .collect();
    Ok(Recorded {
        method: Method::ReflectionPoint,
        settings: frame.settings.clone(),
        img: (0, 0),
        ray_at,
        work: FrameWork::Tree {
            program: REFLECTION_POINT_PROGRAM,
            rays,
            idle: Iter::default(),
        },
    })
}

const RP: &str = "reflection_point_search.wgsl";

/// reflection_point_search.wgsl (`search`, one invocation per scene vertex).
pub const REFLECTION_POINT_BLOCKS: &[Block] = &[
    // The start texel (`rp.start` tested; its crosshair search is `start_arms`).
    b("start", RP, &["rp_start"]),
    // One iteration of the local search (`rp_walk`'s own code).
    b("walk_step", RP, &["rp_walk"]),
    // One texel's score (5 on the first forward step, 9 after).
    b("score", RP, &["rp_score"]),
    // The virtual vertex (mirror in the final texel's plane).
    b("finish", RP, &["rp_virtual_vertex", "rp_found_normal"]),
    // One distance of the start texel's crosshair search (up to 4 arm texels read).
    b("start_arms", RP, &["rp_start_arms"]),
];

// Indices into REFLECTION_POINT_BLOCKS.
pub const R_START: usize = 0;
pub const R_WALK_STEP: usize = 1;
pub const R_SCORE: usize = 2;
pub const R_FINISH: usize = 3;
pub const R_START_ARMS: usize = 4;

/// The forward and inverse walks, the start's crosshair search.
pub const L_WALK: u16 = 30;
pub const L_WALK_INVERSE: u16 = 31;
pub const L_START: u16 = 32;

/// reflection_point_search.wgsl's nest (`search`: start and its crosshair search, forward
/// walk, inverse walk).
pub const REFLECTION_POINT_PROGRAM: &[Stmt] = &[
    Stmt::Block(R_START),
    Stmt::Loop(L_START, &[Stmt::Block(R_START_ARMS)]),
    Stmt::Loop(L_WALK, &[Stmt::Block(R_WALK_STEP), Stmt::Block(R_SCORE)]),
    Stmt::Loop(
        L_WALK_INVERSE,
        &[Stmt::Block(R_WALK_STEP), Stmt::Block(R_SCORE)],
    ),
    Stmt::Block(R_FINISH),
];

/// The reflection-point search of every scene vertex (`SearchTextures::search`) over T_P and
/// T_N drawn by the reference (the reflectors alone, from the camera; open reflectors' closing
/// triangles left out). Returns, per vertex in dispatch order, its work (None: a reflector's
/// vertex, which leaves at once).
pub fn reflection_point_vertices(
    frame: &Frame,
) -> Vec<Option<(Iter, crate::cpu::reflection_point::RpVertex)>> {
    use crate::cpu::reflection_point::{RpOptions, SearchTextures, start_texel};
    use glam::Vec4;
    let (w, h) = (frame.settings.width, frame.settings.height);
    let addr = Addr {
        layout: frame.settings.layout,
    };
    let tracer = &frame.tracer;
    let mut position = Vec::with_capacity((w * h) as usize);
    let mut normal = Vec::with_capacity((w * h) as usize);
    for j in 0..h {
        for i in 0..w {
            let (o, d) = frame.camera.ray(i, j);
            let hit = tracer.nearest_where(o, d, None, |t| tracer.is_reflector(t));
            position.push(hit.map_or(Vec4::ZERO, |x| x.position.extend(1.0)));
            normal.push(hit.map_or(Vec4::ZERO, |x| tracer.normal(&x).extend(0.0)));
        }
    }
    let vp = frame.camera.view_proj(frame.near);
    let tex = SearchTextures {
        width: w,
        height: h,
        position,
        normal,
        eye: frame.camera.eye,
        start: start_texel(&frame.data, vp, w, h),
        max_iterations: RpOptions::default().iteration_cap(w, h),
    };
    let data = &frame.data;
    data.vertices
        .iter()
        .map(|v| {
            if data.objects[v.object as usize].reflector != 0 {
                return None;
            }
            let mut log = Vec::new();
            let out = tex.search_logged(Vec3::from_array(v.position), &mut log);
            Some((walk_tree(&log, &tex, &addr), out))
        })
        .collect()
}

/// One vertex's search log as reflection_point_search.wgsl's loop nest.
fn walk_tree(
    log: &[Work],
    tex: &crate::cpu::reflection_point::SearchTextures,
    addr: &Addr,
) -> Iter {
    let (w, h) = (tex.width, tex.height);
    let mut top = Iter::default();
    top.exec(R_START, Vec::new());
    let mut walk = L_WALK;
    for e in log {
        match *e {
            Work::StartArms { d } => {
                // `rp_start_arms` reads T_P at the arms inside the frame, up to the first on
                // the reflector.
                let s = tex.start;
                let mut loads = Vec::new();
                for a in [[d, 0], [-d, 0], [0, d], [0, -d]] {
                    let (x, y) = (s[0] + a[0], s[1] + a[1]);
                    if x >= 0 && y >= 0 && x < w as i32 && y < h as i32 {
                        loads.push(addr.cell(BUF_RP, 0, 0, 16, 0, w, h, x as u32, y as u32));
                    }
                    if tex.on_reflector([x, y]) {
                        break;
                    }
                }
                top.new_turn(L_START).exec(R_START_ARMS, loads);
            }
            Work::Walk { inverse } => walk = if inverse { L_WALK_INVERSE } else { L_WALK },
            Work::WalkStep => top.new_turn(walk).exec(R_WALK_STEP, Vec::new()),
            Work::Score { x, y } => {
                // `rp_on_reflector` reads T_P inside the frame; a reflector texel's score
                // reads T_N too.
                let mut loads = Vec::new();
                if x >= 0 && y >= 0 && x < w as i32 && y < h as i32 {
                    let (xu, yu) = (x as u32, y as u32);
                    loads.push(addr.cell(BUF_RP, 0, 0, 16, 0, w, h, xu, yu));
                    if tex.on_reflector([x, y]) {
                        loads.push(addr.cell(BUF_RP, 1, 0, 16, 0, w, h, xu, yu));
                    }
                }
                top.last_turn(walk).exec(R_SCORE, loads);
            }
            _ => {}
        }
    }
    if top.run(L_WALK).is_some() {
        top.exec(R_FINISH, Vec::new());
    }
    top
}

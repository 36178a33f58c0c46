#![forbid(unsafe_code)]
//! ssr's model: `ssr.wgsl`'s blocks and loop nest, and a ray's Hi-Z march in it.
use crate::cpu::Work;
use crate::method::Method;
use crate::model::blocks::{Block, Stmt, b};
use crate::model::frame::{Addr, BUF_HIZ, Frame};
use crate::model::rays::{Exec, FrameWork, Iter, Recorded};
use crate::model::warps::{Assembly, Items, LAVAPIPE_TILE};

use super::MethodModel;

/// What the cost model knows of ssr.
pub const MODEL: MethodModel = MethodModel {
    method: Method::Ssr,
    blocks: SSR_BLOCKS,
    program: Some(SSR_PROGRAM),
    assembly: Assembly::Quads,
    lavapipe_items: |_, _| Items::Tiles(LAVAPIPE_TILE),
    entry_point: |_| "fs_main",
    layouts: &[],
    record,
};

fn record(frame: &Frame) -> anyhow::Result<Recorded> {
    let mut idle = Iter::default();
    idle.execs.push(Exec {
        block: S_RAY_SETUP,
        loads: Vec::new(),
    });
    let work = FrameWork::Tree {
        program: SSR_PROGRAM,
        rays: ssr_rays(frame).into_iter().map(|(it, _)| it).collect(),
        idle,
    };
    Ok(Recorded::per_pixel(Method::Ssr, frame, work))
}

const SSR: &str = "ssr.wgsl";

/// ssr.wgsl (`ssr_trace`, the Hi-Z march).
pub const SSR_BLOCKS: &[Block] = &[
    // The pixel's mirror ray and the screen-space set-up.
    b("ray_setup", SSR, &["mirror_ray", "ssr_trace"]),
    // One iteration of the Hi-Z loop.
    b(
        "iteration",
        SSR,
        &["on_screen", "cell_of", "hiz_at", "cell_of"],
    ),
    // Crossing into the next cell (an iteration whose cell changed, and the first crossing).
    b("cross", SSR, &["cross_cell"]),
];

// Indices into SSR_BLOCKS.
pub const S_RAY_SETUP: usize = 0;
pub const S_ITERATION: usize = 1;
pub const S_CROSS: usize = 2;

/// The Hi-Z loop.
pub const L_SSR: u16 = 20;

/// ssr.wgsl's nest (`ssr_trace`: the first crossing, then the Hi-Z loop).
pub const SSR_PROGRAM: &[Stmt] = &[
    Stmt::Block(S_RAY_SETUP),
    Stmt::Block(S_CROSS),
    Stmt::Loop(L_SSR, &[Stmt::Block(S_ITERATION), Stmt::Block(S_CROSS)]),
];

/// Every mirror ray's Hi-Z march (`cpu::ssr::trace`) over the pyramid of the frame's depth keys
/// (the reference's first surfaces), default `SsrOptions`.
pub fn ssr_rays(frame: &Frame) -> Vec<(Iter, crate::cpu::ssr::SsrResult)> {
    use crate::cpu::ssr;
    let (w, h) = (frame.settings.width, frame.settings.height);
    let addr = Addr {
        layout: frame.settings.layout,
    };
    let vp = frame.camera.view_proj(frame.near);
    let level0: Vec<f32> = frame
        .primary
        .iter()
        .map(|p| ssr::depth_key(&vp, *p))
        .collect();
    let cells = ssr::build_hiz(&level0, w, h);
    let levels = ssr::hiz_levels(w, h);
    let hiz = ssr::Hiz {
        width: w,
        height: h,
        view_proj: vp,
        cells: &cells,
        levels: levels.clone(),
    };
    let opts = ssr::SsrOptions::default();
    frame
        .rays
        .iter()
        .map(|r| {
            let mut log = Vec::new();
            let res = ssr::trace_logged(
                &hiz,
                &opts,
                [r.pixel.0, r.pixel.1],
                r.origin,
                r.dir,
                &mut log,
            );
            let mut top = Iter::default();
            top.exec(S_RAY_SETUP, Vec::new());
            for e in log {
                if let Work::Hiz { level, x, y, cross } = e {
                    if level < 0 {
                        top.exec(S_CROSS, Vec::new());
                        continue;
                    }
                    let l = levels[level as usize];
                    let (x, y) = (x.max(0) as u32, y.max(0) as u32);
                    let a = addr.cell(BUF_HIZ, 0, level as u32, 4, 0, l.width, l.height, x, y);
                    let turn = top.new_turn(L_SSR);
                    turn.exec(S_ITERATION, vec![a]);
                    if cross {
                        turn.exec(S_CROSS, Vec::new());
                    }
                }
            }
            (top, res)
        })
        .collect()
}

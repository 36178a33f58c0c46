//! Work counters: the code blocks of each method's shader that the model counts ([`Block`],
//! [`blocks`]), and what each ray ran of them, recorded from the CPU twins.
//!
//! # How it works
//! The twins report their work as they run through [`crate::cpu::WorkLog`] (the plain entry
//! points pass [`crate::cpu::NoLog`], which drops it: no result changes). This module turns one
//! ray's log into the shape the shader runs it in:
//! - fragment (and the tree-shaped methods): a tree of loop runs ([`Iter`], [`Run`]) over the
//!   shader's static loop nest ([`Stmt`], [`program`]), each turn holding the blocks it ran
//!   ([`Exec`]) with the byte addresses of the loads they made;
//! - ssr, reflection-point, bvh likewise ([`SSR_PROGRAM`], [`REFLECTION_POINT_PROGRAM`],
//!   `bvh::BVH_PROGRAM`; the CWBVH traversal's twin is [`super::bvh`], written for the model);
//! - compute: a sequence of [`Phase`]s, `settle` turns and traversal steps, since the shader's
//!   steps are subgroup-synchronous (every busy ray of a subgroup takes one step per turn of the
//!   hot loop, which the whole subgroup leaves when any ray has `settle` due).
//!
//! # What it assumes
//! - The rays: one per mirror pixel of the scene's first camera at the settings' image size,
//!   found by the reference tracer (as the harness's twins do), in row-major pixel order: the
//!   compute queue's order (the append pass writes the records in pixel order on the CPU here;
//!   a GPU's atomic append would interleave whole warps of the raster order).
//! - The CMOs: `cpu::capture::capture` at the scene's CMO centres, the centre criterion's trace
//!   options (the pyramid, verified hits): `--method compute / fragment --criterion centre`.
//! - Addresses ([`Addr`]): every buffer starts at its own aligned base (per CMO and level),
//!   so loads of different buffers never share a sector. [`TexelLayout::Linear`] is the GPU
//!   buffers' actual layout (row-major per face, faces in order: `texel_index`, the flattened
//!   hierarchies); [`TexelLayout::Tiled`] the alternative of 32-byte tiles (4x2 texels of 4
//!   bytes, 2x2 cells of 8).
//! - Loads counted: a lane test's bound (distance or hierarchy cell), a cell test's pyramid
//!   cell, a classified texel's distance, verification's 9 triangle IDs; a Hi-Z iteration's
//!   cell; a reflection-point score's T_P (and T_N on the reflector) texel, 16 bytes each; a
//!   BVH node's five 16-byte words, a triangle's three. Not counted: uniform
//!   and per-ray constant reads (config, CMO centres), the scene triangles verification and
//!   shading read, the G-buffer (one read per pixel, coalesced).
//!
//! # Where it stops
//! - The counts are the twins' (the GPU matches them field for field in tests/compute.rs,
//!   tests/fragment.rs); the block a count stands for is the shader's. Where the shader's loop
//!   shape differs from the twin's (the pyramid march's turns), the events are placed where the
//!   shader runs them.
//! - Only one setting per method is modelled (the centre criterion, pyramid, verified hits;
//!   SSR's and reflection-point's default options): not the bounded criterion, the default.
//! - SSR's Hi-Z pyramid and reflection-point's T_P / T_N are drawn by the reference tracer
//!   (first surfaces; the reflectors alone), not rasterised: pixel-edge differences from the
//!   GPU's G-buffer are not modelled; open reflectors' closing triangles are left out of T_P.
//! - Deterministic: one thread, vectors in order, no hash maps.
//!
//! # Where it lives
//! This module gathers, under the names the harness and the tests use, the model's rooms:
//! [`super::blocks`] (blocks and loop nests), [`super::rays`] (what a ray ran),
//! [`super::frame`] (the frame, its settings and addresses) and each method's own file under
//! [`super::methods`] (its blocks, loop nest and ray recording).
#![forbid(unsafe_code)]

pub use super::blocks::{Block, Stmt};
pub use super::frame::{
    Addr, BUF_BVH_NODES, BUF_BVH_TRIS, BUF_DISTANCE, BUF_HIER, BUF_HIZ, BUF_MIP, BUF_RP,
    BUF_TRIANGLE, ComputeLanes, Frame, MirrorRay, ModelSettings, TexelLayout, frame,
};
pub use super::methods::bvh::BVH_BLOCKS;
pub use super::methods::compute::{
    C_ADVANCE, C_CHILDREN_CROSSED, C_CLASSIFY, C_DECIDE, C_ENTER_FACE, C_FACES_CROSSED, C_HANDOFF,
    C_LANE_TEST, C_PICK, C_PICK_ONE, C_SETTLE, C_SHADE, C_START_TRACE, C_VERIFY, C_VISIT,
    C_WAVE_COLLECT, C_WAVE_ITEM, C_WAVE_ITEMS, COMPUTE_BLOCKS, compute_ray,
};
pub use super::methods::fragment::{
    F_CELL_TEST, F_CLASSIFY, F_CMO_TRACE, F_DECIDE, F_FACE, F_RAY_SETUP, F_SHADE, F_TEXEL_CHECK,
    F_TEXEL_SEARCH, F_TURN, F_VERIFY, FRAGMENT_BLOCKS, FRAGMENT_PROGRAM, L_CELL, L_FACE, L_PIECE,
    L_TRACE, L_TURN, fragment_ray,
};
pub use super::methods::reflection_point::{
    L_START, L_WALK, L_WALK_INVERSE, R_FINISH, R_SCORE, R_START, R_START_ARMS, R_WALK_STEP,
    REFLECTION_POINT_BLOCKS, REFLECTION_POINT_PROGRAM, reflection_point_vertices,
};
pub use super::methods::ssr::{
    L_SSR, S_CROSS, S_ITERATION, S_RAY_SETUP, SSR_BLOCKS, SSR_PROGRAM, ssr_rays,
};
pub use super::methods::{block_index, blocks, program};
pub use super::rays::{
    ComputeRay, Exec, FrameWork, Iter, Phase, Recorded, Run, SettleTurn, Step, Visit,
};

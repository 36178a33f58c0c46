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
//! - The CMOs: `reference::capture` at the scene's CMO centres, default trace options (the
//!   exact criterion, the pyramid, verified hits): the default `--method compute / fragment`.
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
//! - Only the default options are modelled (exact criterion, pyramid, verified hits; SSR's
//!   and reflection-point's default options).
//! - SSR's Hi-Z pyramid and reflection-point's T_P / T_N are drawn by the reference tracer
//!   (first surfaces; the reflectors alone), not rasterised: pixel-edge differences from the
//!   GPU's G-buffer are not modelled; open reflectors' closing triangles are left out of T_P.
//! - Deterministic: one thread, vectors in order, no hash maps.
#![forbid(unsafe_code)]

use std::cell::RefCell;

use anyhow::Context;
use glam::Vec3;
use serde::Serialize;

use crate::cpu::multi::{Verify, WorldRay, trace_world_ray};
use crate::cpu::verify::{Neighbourhood, triangle_corners};
use crate::cpu::{CmoTracer, Status, TraceParams, TraceResult, Work};
use crate::cubemap::face::Texel;
use crate::cubemap::pyramid::{hier32_flat_layout, mip_flat_layout};
use crate::scene::Scene;

use crate::method::Method;

/// How compute_trace lays a ray over lanes (`vk::methods::compute::ray_lanes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ComputeLanes {
    /// `main`: min(width, 32) lanes per ray (the thesis layout).
    Thesis,
    /// `main_lanes1`: one lane per ray (what CPU devices, lavapipe, run).
    One,
    /// `One` in lavapipe mode, `Thesis` in GPU mode (what `ray_lanes` picks).
    Auto,
}

/// The byte layout of texel and node addresses for the sector count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TexelLayout {
    /// The GPU buffers' actual layout: row-major per face, faces in order, CMOs in order.
    Linear,
    /// 4x2-texel tiles of 8 4-byte texels (one 32-byte sector per tile), tiles row-major.
    Tiled,
}

/// What the model needs of one frame beside the scene and method (the bench's settings).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelSettings {
    /// Cube map size N (texels per face side).
    pub cube: u32,
    /// Image size in pixels.
    pub width: u32,
    pub height: u32,
    /// compute_trace's lane layout.
    pub compute_lanes: ComputeLanes,
    /// Texel layout for the memory transactions.
    pub layout: TexelLayout,
}

impl ModelSettings {
    /// The defaults for a frame: `ComputeLanes::Auto`, `TexelLayout::Linear`.
    pub fn new(cube: u32, width: u32, height: u32) -> ModelSettings {
        ModelSettings {
            cube,
            width,
            height,
            compute_lanes: ComputeLanes::Auto,
            layout: TexelLayout::Linear,
        }
    }
}

/// A code block of a method's shader that the model counts: a loop body or a call site.
///
/// The weight of a block (`model::weights`) is the SPIR-V instruction count of its
/// `functions`, callees included, EXCEPT a callee that another block of the same method names
/// (that one is counted by its own block, once per its own count). A name listed twice counts
/// twice (the block calls it twice per count).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// Short stable name, used in JSON ("lane_test", "advance", ...).
    pub name: &'static str,
    /// The WGSL file (under spirv/) and the WGSL functions whose instructions the block runs
    /// once per count (callees included by the weights).
    pub shader: &'static str,
    pub functions: &'static [&'static str],
}

const fn b(name: &'static str, shader: &'static str, functions: &'static [&'static str]) -> Block {
    Block {
        name,
        shader,
        functions,
    }
}

const COMPUTE: &str = "compute_trace.wgsl";
const FRAGMENT: &str = "fragment_trace.wgsl";
const BVH: &str = "bvh_trace.wgsl";
const SSR: &str = "ssr.wgsl";
const RP: &str = "reflection_point_search.wgsl";

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
    // The 1-lane layout's exact pre-test of a node's children (`main_lanes1` only).
    b("children_crossed", COMPUTE, &["children_crossed"]),
    // One round of lane tests: each lane of a ray tests one child (with its ballot).
    b("lane_test", COMPUTE, &["lane_test"]),
    // The pick of the first candidate (min key over the ray's lanes, ballot of the holders).
    b("pick", COMPUTE, &["key_get", "ray_bits"]),
    // One traversal step: descend, backtrack, next face, or classify.
    b("advance", COMPUTE, &["advance"]),
    // The exact classification of a texel candidate (inside `advance` at level 1).
    b("classify", COMPUTE, &["classify"]),
    // Shading a hit for the record.
    b("shade", COMPUTE, &["hit_shade"]),
    // A piece's faces, found on its first visit inside `enter_face` (six frustum intervals and
    // their ranking): a block of its own, so that `enter_face`'s other calls do not carry it.
    b("faces_crossed", COMPUTE, &["faces_crossed"]),
];

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
    // The 3x3 texel search (`locate` after a skip, `next_texel` after a texel): the
    // neighbourhood's 13 planes clipped once, combined per candidate (its callees included).
    b("texel_search", FRAGMENT, &["texel_search"]),
    // One cell test of the pyramid (the inner loop).
    b(
        "cell_test",
        FRAGMENT,
        &["cell_interval", "inflated", "r_bounds", "mip_get"],
    ),
    // The exact classification of a texel.
    b("classify", FRAGMENT, &["classify_with"]),
    // Verification of a hit against the captured triangle IDs.
    b("verify", FRAGMENT, &["verify_decision"]),
    // Shading a hit for the record.
    b("shade", FRAGMENT, &["hit_shade"]),
];

/// bvh_trace.wgsl (`bvh_nearest` over the CWBVH).
pub const BVH_BLOCKS: &[Block] = &[
    // The ray's set-up (inverse direction, the start rule's tolerance).
    b("setup", BVH, &["bvh_inv_dir", "bvh_start_tolerance"]),
    // One turn of the traversal loop (`bvh_nearest`'s own code: pops, bookkeeping).
    b("iteration", BVH, &["bvh_nearest"]),
    // A node visit: the 8 children's box tests.
    b("node", BVH, &["bvh_node_hits"]),
    // A triangle test.
    b("triangle", BVH, &["wt_intersect"]),
    // The start rule on a nearer hit.
    b("start_rule", BVH, &["bvh_start_ignores"]),
    // Shading a hit for the record.
    b("shade", BVH, &["hit_shade"]),
];

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

/// reflection_point_search.wgsl (`search`, one invocation per scene vertex).
pub const REFLECTION_POINT_BLOCKS: &[Block] = &[
    // The start texel (`rp.start` tested; its crosshair search is `start_arms`).
    b("start", RP, &["rp_start"]),
    // One iteration of the local search (`rp_walk`'s own code).
    b("walk_step", RP, &["rp_walk"]),
    // One texel's score (5 on the first forward step, 9 after).
    b("score", RP, &["rp_score"]),
    // The virtual vertex (mirror in the final texel's plane).
    b("finish", RP, &["rp_mirror", "scene_normalize"]),
    // One distance of the start texel's crosshair search (up to 4 arm texels read).
    b("start_arms", RP, &["rp_start_arms"]),
];

/// The blocks of one method (Method::Compute, Fragment, Bvh, Ssr, ReflectionPoint); empty for
/// the others (envmap, reference: nothing to replay).
pub fn blocks(method: Method) -> &'static [Block] {
    match method {
        Method::Compute => COMPUTE_BLOCKS,
        Method::Fragment => FRAGMENT_BLOCKS,
        Method::Bvh => BVH_BLOCKS,
        Method::Ssr => SSR_BLOCKS,
        Method::ReflectionPoint => REFLECTION_POINT_BLOCKS,
        Method::Envmap | Method::Reference => &[],
    }
}

/// The index of block `name` in `blocks(method)`.
pub fn block_index(method: Method, name: &str) -> Option<usize> {
    blocks(method).iter().position(|b| b.name == name)
}

// ---------------------------------------------------------------------------------------------
// Static loop nests.

/// One statement of a shader's static loop nest: a block, or a loop (by id) with its body.
/// Every block sits in one place; a loop runs at most once per turn of its parent.
#[derive(Clone, Copy, Debug)]
pub enum Stmt {
    Block(usize),
    Loop(u16, &'static [Stmt]),
}

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
                                Stmt::Block(F_TEXEL_SEARCH),
                                Stmt::Loop(L_CELL, &[Stmt::Block(F_CELL_TEST)]),
                                Stmt::Block(F_CLASSIFY),
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

/// The static loop nest of a tree-shaped method (not compute, whose replay is its own).
pub fn program(method: Method) -> Option<&'static [Stmt]> {
    match method {
        Method::Fragment => Some(FRAGMENT_PROGRAM),
        _ => None,
    }
}

// ---------------------------------------------------------------------------------------------
// Per-ray work.

/// One execution of a block, with the byte addresses of its loads in program order (the i-th
/// load of every lane is one warp load).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Exec {
    pub block: usize,
    pub loads: Vec<u64>,
}

/// One turn of a loop (or a ray's whole run, at the top): the blocks it ran in order and the
/// nested loops it entered (each at most once).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Iter {
    pub execs: Vec<Exec>,
    pub loops: Vec<(u16, Run)>,
}

/// The turns one ray made of one loop.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Run {
    pub iters: Vec<Iter>,
}

impl Iter {
    fn exec(&mut self, block: usize, loads: Vec<u64>) {
        self.execs.push(Exec { block, loads });
    }

    /// The run of loop `id` in this turn (created empty on first use).
    pub fn run_mut(&mut self, id: u16) -> &mut Run {
        if let Some(i) = self.loops.iter().position(|(l, _)| *l == id) {
            return &mut self.loops[i].1;
        }
        self.loops.push((id, Run::default()));
        &mut self.loops.last_mut().expect("just pushed").1
    }

    /// The run of loop `id` in this turn, if the ray entered it.
    pub fn run(&self, id: u16) -> Option<&Run> {
        self.loops.iter().find(|(l, _)| *l == id).map(|(_, r)| r)
    }

    /// The last turn of loop `id` (a new one when there is none).
    fn last_turn(&mut self, id: u16) -> &mut Iter {
        let run = self.run_mut(id);
        if run.iters.is_empty() {
            run.iters.push(Iter::default());
        }
        run.iters.last_mut().expect("non-empty")
    }

    fn new_turn(&mut self, id: u16) -> &mut Iter {
        let run = self.run_mut(id);
        run.iters.push(Iter::default());
        run.iters.last_mut().expect("just pushed")
    }

    /// Executions of `block` in this turn and every nested one (a count for the tests).
    pub fn count(&self, block: usize) -> usize {
        let here = self.execs.iter().filter(|e| e.block == block).count();
        here + self
            .loops
            .iter()
            .flat_map(|(_, r)| &r.iters)
            .map(|i| i.count(block))
            .sum::<usize>()
    }
}

/// One phase of a compute ray: a call of `settle` (its turns), or one traversal step.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub enum Phase {
    Settle(Vec<SettleTurn>),
    Step(Step),
}

/// One turn of `settle`'s loop.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SettleTurn {
    /// A trace ended: `handoff` runs.
    pub handoff: bool,
    /// Its hit is verified: the 9 triangle-ID loads (empty: no verification).
    pub verify: Vec<u64>,
    /// A new single-CMO trace starts (`start_trace`).
    pub start: bool,
    /// A face is entered (`enter_face`).
    pub enter: bool,
    /// The entered piece is visited first: `enter_face` finds its faces (`faces_crossed`). Set
    /// on a trace's first entry (its first piece); a trace's second piece (a ray cut near the
    /// CMO's centre) is not logged by the twin and not counted.
    pub faces: bool,
}

/// One traversal step of the hot loop.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Step {
    /// The node visit, when the ray tests a node's children this step.
    pub visit: Option<Visit>,
    /// The classified texel's distance load (the step picked a texel).
    pub classify: Option<u64>,
}

/// A node visit: the children's bound loads by logical lane j (children that exist), and the
/// children that pass the interval test (the 1-lane layout tests only those, in increasing j).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Visit {
    /// Node level (1: its children are texels).
    pub level: u32,
    /// Children grid size (gx * gy): what `Counters::texels` / `cells` add.
    pub children: u32,
    pub loads: Vec<(u8, u64)>,
    pub crossed: u32,
}

/// A compute ray's work: its phases in order, whether it ends in a hit (shaded), and the
/// twin's own counters per single-CMO trace (for the sanity tests).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ComputeRay {
    pub phases: Vec<Phase>,
    pub hit: bool,
    pub texels: u32,
    pub cells: u32,
}

// ---------------------------------------------------------------------------------------------
// Addresses.

/// Buffers, for [`Addr`].
pub const BUF_DISTANCE: u64 = 1;
pub const BUF_HIER: u64 = 2;
pub const BUF_MIP: u64 = 3;
pub const BUF_TRIANGLE: u64 = 4;
pub const BUF_BVH_NODES: u64 = 5;
pub const BUF_BVH_TRIS: u64 = 6;
pub const BUF_HIZ: u64 = 7;
pub const BUF_RP: u64 = 8;

/// Byte addresses of texels and cells under a [`TexelLayout`].
#[derive(Clone, Copy, Debug)]
pub struct Addr {
    pub layout: TexelLayout,
}

impl Addr {
    /// Element (x, y) of `face` of a `w x h`-per-face level of `elem` bytes, buffer `buf`, CMO
    /// `k`, level `level`.
    #[allow(clippy::too_many_arguments)]
    pub fn cell(
        &self,
        buf: u64,
        k: u32,
        level: u32,
        elem: u64,
        face: u32,
        w: u32,
        h: u32,
        x: u32,
        y: u32,
    ) -> u64 {
        let base = ((buf * 256 + k as u64) * 64 + level as u64) << 36;
        let (face, w, h, x, y) = (face as u64, w as u64, h as u64, x as u64, y as u64);
        match self.layout {
            TexelLayout::Linear => base + ((face * h + y) * w + x) * elem,
            TexelLayout::Tiled => {
                let (tw, th) = if elem <= 4 { (4, 2) } else { (2, 2) };
                let (tx, ty) = (w.div_ceil(tw), h.div_ceil(th));
                let tile = tw * th * elem;
                base + face * tx * ty * tile
                    + ((y / th) * tx + x / tw) * tile
                    + ((y % th) * tw + x % tw) * elem
            }
        }
    }

    /// A texel's distance (4 bytes) of CMO k.
    pub fn distance(&self, k: u32, n: u32, t: Texel) -> u64 {
        self.cell(BUF_DISTANCE, k, 0, 4, t.face, n, n, t.x, t.y)
    }

    /// A texel's captured triangle ID (4 bytes) of CMO k.
    pub fn triangle(&self, k: u32, n: u32, t: Texel) -> u64 {
        self.cell(BUF_TRIANGLE, k, 0, 4, t.face, n, n, t.x, t.y)
    }

    /// Cell (x, y) of level `level` >= 1 of the 8x4/4x8 hierarchy (8 bytes).
    pub fn hier(&self, k: u32, n: u32, level: u32, face: u32, x: u32, y: u32) -> u64 {
        let l = hier32_flat_layout(n)[level as usize - 1];
        self.cell(BUF_HIER, k, level, 8, face, l.width, l.height, x, y)
    }

    /// Cell (x, y) of level `level` >= 1 of the 2x2 pyramid (8 bytes).
    pub fn mip(&self, k: u32, n: u32, level: u32, face: u32, x: u32, y: u32) -> u64 {
        let l = mip_flat_layout(n)[level as usize - 1];
        self.cell(BUF_MIP, k, level, 8, face, l.width, l.height, x, y)
    }
}

// ---------------------------------------------------------------------------------------------
// The frame.

/// A mirror pixel's reflected ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MirrorRay {
    pub pixel: (u32, u32),
    pub origin: Vec3,
    pub dir: Vec3,
    /// The mirror triangle it leaves.
    pub from: u32,
}

/// What the twins need of a scene: CMOs, the triangles' corners, the rays (row-major).
pub struct Frame {
    pub settings: ModelSettings,
    pub tracer: crate::reference::Tracer,
    pub data: crate::scene::gpu_data::GpuSceneData,
    pub camera: crate::camera::Camera,
    /// The camera's near plane (`vk::frame::scene_ranges`).
    pub near: f32,
    /// Per pixel (row-major): the first surface the camera sees there.
    pub primary: Vec<Option<Vec3>>,
    pub cmos: Vec<CmoTracer>,
    pub corners: Vec<[Vec3; 3]>,
    pub t_hi: f32,
    pub rays: Vec<MirrorRay>,
    /// Per pixel, row-major: the index of its ray in `rays` (None: not a mirror pixel).
    pub ray_at: Vec<Option<usize>>,
}

/// Sets up `scene`'s frame at `settings` (module docs, "What it assumes").
pub fn frame(scene: &Scene, settings: &ModelSettings) -> anyhow::Result<Frame> {
    use crate::reference::{Tracer, capture, reflect};
    let s = settings;
    if s.width == 0 || s.height == 0 || s.width > 4096 || s.height > 4096 {
        anyhow::bail!(
            "model: image size {}x{} is not in 1..=4096",
            s.width,
            s.height
        );
    }
    if !(1..=2048).contains(&s.cube) {
        anyhow::bail!("model: cube size {} is not in 1..=2048", s.cube);
    }
    let mut camera = scene
        .cameras
        .first()
        .context("model: the scene has no camera")?
        .clone();
    camera.width = s.width;
    camera.height = s.height;
    let tracer = Tracer::new(scene);
    let (near, _, t_hi) = crate::vk::frame::scene_ranges(scene, &camera);
    let mut rays = Vec::new();
    let mut ray_at = Vec::with_capacity((s.width * s.height) as usize);
    let mut primary = Vec::with_capacity((s.width * s.height) as usize);
    for j in 0..s.height {
        for i in 0..s.width {
            let (o, d) = camera.ray(i, j);
            let first = tracer.nearest(o, d, None);
            primary.push(first.map(|h| h.position));
            let hit = first.filter(|h| tracer.is_reflector(h.triangle));
            ray_at.push(hit.map(|h| {
                rays.push(MirrorRay {
                    pixel: (i, j),
                    origin: h.position,
                    dir: reflect(d, tracer.normal(&h)).normalize(),
                    from: h.triangle,
                });
                rays.len() - 1
            }));
        }
    }
    let cmos = scene
        .cmo_centres()
        .into_iter()
        .map(|c| CmoTracer::new(capture(scene, &tracer, c, s.cube), TraceParams::default()))
        .collect();
    Ok(Frame {
        settings: s.clone(),
        cmos,
        corners: triangle_corners(&tracer.world),
        data: crate::scene::gpu_data::GpuSceneData::new(scene),
        tracer,
        camera,
        near,
        primary,
        t_hi,
        rays,
        ray_at,
    })
}

/// One single-CMO trace's log: the CMO, the events, the result.
struct TraceLog {
    k: usize,
    events: Vec<Work>,
    result: TraceResult,
}

/// Runs `ray` through the CMOs with verified hits (`trace_world_ray`), each single-CMO trace by
/// `one` with its log; returns the logs and whether the ray ends in a hit.
fn run_logged(
    frame: &Frame,
    ray: &MirrorRay,
    one: impl Fn(&CmoTracer, &crate::cpu::Segment, &mut Vec<Work>) -> TraceResult,
) -> (Vec<TraceLog>, bool) {
    let logs = RefCell::new(Vec::new());
    let wr = WorldRay {
        origin: ray.origin,
        dir: ray.dir,
        from: crate::cpu::bounded::NO_TRIANGLE,
        t_lo: 0.0,
        t_hi: frame.t_hi,
    };
    let verify = Verify {
        triangles: &frame.corners,
    };
    let out = trace_world_ray(&frame.cmos, &wr, Some(verify), |tr, seg| {
        let k = frame
            .cmos
            .iter()
            .position(|c| std::ptr::eq(c, tr))
            .unwrap_or(0);
        let mut events = Vec::new();
        let result = one(tr, seg, &mut events);
        logs.borrow_mut().push(TraceLog { k, events, result });
        result
    });
    (
        logs.into_inner(),
        out.status == crate::cpu::multi::MultiStatus::Hit,
    )
}

/// The 9 triangle-ID loads of verifying a hit at `texel` of CMO k.
fn verify_loads(frame: &Frame, addr: &Addr, k: usize, texel: Texel) -> Vec<u64> {
    let tr = &frame.cmos[k];
    let n = tr.cube.size;
    let hood = Neighbourhood::around(texel, n, &tr.cube.triangle);
    hood.texels
        .iter()
        .map(|&t| addr.triangle(k as u32, n, t))
        .collect()
}

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
        for e in &t.events {
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
                Work::Search { .. } => {
                    let turn = trace.last_turn(L_PIECE).last_turn(L_FACE).new_turn(L_TURN);
                    turn.exec(F_TURN, Vec::new());
                    turn.exec(F_TEXEL_SEARCH, Vec::new());
                }
                Work::Cell { level, face, x, y } => {
                    let turn = trace.last_turn(L_PIECE).last_turn(L_FACE).last_turn(L_TURN);
                    turn.new_turn(L_CELL)
                        .exec(F_CELL_TEST, vec![addr.mip(k, n, level, face, x, y)]);
                }
                Work::Classify(tex) => {
                    let turn = trace.last_turn(L_PIECE).last_turn(L_FACE).last_turn(L_TURN);
                    turn.exec(F_CLASSIFY, vec![addr.distance(k, n, tex)]);
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
        for e in &t.events {
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
                Work::Classify(tex) => step.classify = Some(addr.distance(k, n, tex)),
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

// ---------------------------------------------------------------------------------------------
// SSR, reflection point, BVH.

// Indices into SSR_BLOCKS and REFLECTION_POINT_BLOCKS.
pub const S_RAY_SETUP: usize = 0;
pub const S_ITERATION: usize = 1;
pub const S_CROSS: usize = 2;
pub const R_START: usize = 0;
pub const R_WALK_STEP: usize = 1;
pub const R_SCORE: usize = 2;
pub const R_FINISH: usize = 3;
pub const R_START_ARMS: usize = 4;

/// The Hi-Z loop, the forward and inverse walks.
pub const L_SSR: u16 = 20;
pub const L_WALK: u16 = 30;
pub const L_WALK_INVERSE: u16 = 31;
pub const L_START: u16 = 32;

/// ssr.wgsl's nest (`ssr_trace`: the first crossing, then the Hi-Z loop).
pub const SSR_PROGRAM: &[Stmt] = &[
    Stmt::Block(S_RAY_SETUP),
    Stmt::Block(S_CROSS),
    Stmt::Loop(L_SSR, &[Stmt::Block(S_ITERATION), Stmt::Block(S_CROSS)]),
];

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

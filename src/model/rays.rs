#![forbid(unsafe_code)]
//! What each ray ran, as the model records it from the CPU twins: a tree of loop runs of
//! blocks ([`Iter`], [`Run`], [`Exec`]) for the tree-shaped methods, a sequence of phases
//! ([`ComputeRay`]) for compute; and one frame's recording for one method ([`Recorded`]).
use serde::Serialize;

use super::blocks::Stmt;
use super::frame::{Frame, ModelSettings};
use crate::method::Method;

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
    pub(super) fn exec(&mut self, block: usize, loads: Vec<u64>) {
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
    pub(super) fn last_turn(&mut self, id: u16) -> &mut Iter {
        let run = self.run_mut(id);
        if run.iters.is_empty() {
            run.iters.push(Iter::default());
        }
        run.iters.last_mut().expect("non-empty")
    }

    pub(super) fn new_turn(&mut self, id: u16) -> &mut Iter {
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
    /// The classified texel decides the trace (a hit or behind): `classify_candidate` runs.
    pub decide: bool,
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

/// One frame's recorded work for one method.
pub struct Recorded {
    pub method: Method,
    pub settings: ModelSettings,
    /// Image size and, per pixel (row-major), its ray.
    pub img: (u32, u32),
    pub ray_at: Vec<Option<usize>>,
    pub work: FrameWork,
}

/// Per-ray work: compute's phases, or a tree over a static loop nest.
pub enum FrameWork {
    Compute(Vec<ComputeRay>),
    Tree {
        program: &'static [Stmt],
        rays: Vec<Iter>,
        /// What a lane that is not a ray runs (a non-mirror pixel: the set-up).
        idle: Iter,
    },
}

impl Recorded {
    pub fn rays(&self) -> usize {
        match &self.work {
            FrameWork::Compute(r) => r.len(),
            FrameWork::Tree { rays, .. } => rays.len(),
        }
    }

    /// The recording of `work`, one ray per mirror pixel of `frame` (every method whose
    /// invocations are the frame's pixels).
    pub fn per_pixel(method: Method, frame: &Frame, work: FrameWork) -> Recorded {
        Recorded {
            method,
            settings: frame.settings.clone(),
            img: (frame.settings.width, frame.settings.height),
            ray_at: frame.ray_at.clone(),
            work,
        }
    }
}

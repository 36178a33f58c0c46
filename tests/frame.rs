//! What every GPU frame does whatever its method: the memory plan against what is allocated, the
//! EXR's per-pixel IDs, bounces, the reflector check after the cubemap trace, and scenes with
//! little in them.
//!
//! - `budget`: the memory estimate against the renderer's allocations (one frame plan);
//! - `aov`: the EXR's object and primitive IDs mean the same for `bvh` as for the reference;
//! - `gpu_bounce`: `--bounces N` on the GPU against the reference, bounce for bounce;
//! - `reflector_check`: the exact check of the reflectors the CMOs do not capture;
//! - `scene_sparse`: no mesh, no reflector, a reflector alone, on every GPU method;
//! - `vertex_colours`: an OBJ's vertex colours shade every pass as the reference.

mod common;

#[path = "frame/aov.rs"]
mod aov;
#[path = "frame/budget.rs"]
mod budget;
#[path = "frame/gpu_bounce.rs"]
mod gpu_bounce;
#[path = "frame/reflector_check.rs"]
mod reflector_check;
#[path = "frame/scene_sparse.rs"]
mod scene_sparse;
#[path = "frame/vertex_colours.rs"]
mod vertex_colours;

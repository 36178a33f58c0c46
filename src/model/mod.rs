//! The SIMT cost model: what the paths would cost on a 32- or 64-wide GPU.
//!
//! Work counters from the CPU twins ([`work`]; bvh's traversal twin in [`bvh`]) are grouped
//! into warps as a GPU forms them ([`warps`]) and replayed in lockstep ([`replay`]), in two
//! modes: a GPU issues a block when at least one lane needs it; lavapipe runs every block of a
//! loop body on every turn that any lane makes. The blocks are weighted by their instruction
//! counts in the compiled SPIR-V, counted two ways ([`dynamic::Counting`]): static ([`weights`]:
//! every instruction once) and dynamic ([`dynamic`]: loops with a fixed trip count per trip,
//! the entry point's constants carried into calls, dead code removed). The lavapipe mode's
//! prediction is checked against lavapipe's measured cost per ray on held-out scenes and
//! settings ([`validate`]), under either count.
//!
//! Entry point: [`replay::model_frame`] (scene, method, [`replay::ModelSettings`], warp width,
//! [`replay::Mode`]) gives a [`replay::ReplayStats`]: issued warp-steps per ray per block (index
//! = position in [`work::blocks`]), SIMD efficiency, 32-byte sectors per ray. To replay one
//! recording at several widths and modes: [`work::frame`], [`replay::record`], [`replay::replay`].
//!
//! Every figure it gives is a model: its assumptions are in the module docs of [`work`] (rays,
//! CMOs, addresses and the texel layout), [`warps`] (queue order, quad and tile order) and
//! [`replay`] (the two modes, what is not modelled). Deterministic: the same scene and settings
//! give the same numbers (one thread, no hash maps, a fixed-seed shuffle for the negative).
//!
//! Rooms: [`frame`] (the frame a replay runs on: settings, rays, CMOs, addresses), [`blocks`]
//! (a shader's counted blocks and loop nest), [`rays`] (what a ray ran, a frame's recording),
//! [`methods`] (one file per replayed method: its blocks, loop nest, warp assembly, entry point
//! and recording); [`work`] gathers them under the names the harness and the tests use.
#![forbid(unsafe_code)]

pub mod blocks;
pub mod bvh;
pub mod dynamic;
pub mod frame;
pub mod methods;
pub mod rays;
pub mod replay;
pub mod validate;
pub mod warps;
pub mod weights;
pub mod work;

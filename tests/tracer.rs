//! The cubemap tracers' shared core, which `compute` and `fragment` both run: the ray-level
//! traversal of captured cube maps, its CPU twins, and the GPU probes that hold the shaders to
//! them bit for bit. Frame-level checks of each path are in `tests/compute.rs` and
//! `tests/fragment.rs`.
//!
//! - `cpu_trace`: the CPU tracers (walk, mip march, alg. 3, approximate criteria, several CMOs)
//!   on analytic cube maps;
//! - `face_order`: the faces a trace marches, in order, on the GPU against the CPU;
//! - `gpu_twin`: the GPU tracer (`trace_probe` pass) against its CPU twin, ray by ray;
//! - `texel_search`: the 3x3 texel search against the nine-interval search it replaced;
//! - `verified_trace`: verified hits in the CPU tracer;
//! - `gpu_verify`: the watertight test and the shading at a hit on the GPU against their twins;
//! - `real_inputs_trace`: real inputs that once broke the tracer (a ground plane reaching 1e6, a
//!   reflector with inward normals).

mod common;

#[path = "tracer/cpu_trace.rs"]
mod cpu_trace;
#[path = "tracer/face_order.rs"]
mod face_order;
#[path = "tracer/gpu_twin.rs"]
mod gpu_twin;
#[path = "tracer/gpu_verify.rs"]
mod gpu_verify;
#[path = "tracer/real_inputs_trace.rs"]
mod real_inputs_trace;
#[path = "tracer/texel_search.rs"]
mod texel_search;
#[path = "tracer/verified_trace.rs"]
mod verified_trace;

//! The SIMT cost model (issue 25): what the paths would cost on a 32- or 64-wide GPU.
//!
//! Work counters from the CPU twins ([`work`]) are grouped into warps as a GPU forms them
//! ([`warps`]) and replayed in lockstep ([`replay`]), in two modes: a GPU issues a block when at
//! least one lane needs it; lavapipe runs every block of a loop body on every turn that any lane
//! makes. The blocks are weighted by their instruction counts in the compiled SPIR-V
//! ([`weights`]), and the lavapipe mode's prediction is checked against lavapipe's measured cost
//! per ray on held-out scenes and settings ([`validate`]).
#![forbid(unsafe_code)]

pub mod replay;
pub mod validate;
pub mod warps;
pub mod weights;
pub mod work;

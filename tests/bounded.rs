//! The `bounded` criterion (`--criterion bounded`, compute and fragment) from its CPU twin to the
//! frame, and the thin geometry it exists for.
//!
//! - `bounded_cpu`: the CPU twin (`cpu::bounded`) on lists sound by construction;
//! - `capture_lists`: the GPU list capture against its CPU twin, bit for bit;
//! - `bounded_gpu`: both GPU paths over uploaded lists against each other and the twin;
//! - `bounded_gaps`: the gaps the traversals skip through: sound on the CPU, the GPU's bit for
//!   bit;
//! - `bounded_frame`: the criterion end to end on stress scenes against the reference;
//! - `list_size`: the lists' face size changes the frame's cost, not its image;
//! - `stress_capture`: the stress scenes themselves, and the centre criterion missing their thin
//!   parts.

mod common;
#[allow(dead_code)]
#[path = "common/quality.rs"]
mod quality;
#[allow(dead_code)]
#[path = "common/stress.rs"]
mod stress;

#[path = "bounded/bounded_cpu.rs"]
mod bounded_cpu;
#[path = "bounded/bounded_frame.rs"]
mod bounded_frame;
#[path = "bounded/bounded_gaps.rs"]
mod bounded_gaps;
#[path = "bounded/bounded_gpu.rs"]
mod bounded_gpu;
#[path = "bounded/capture_lists.rs"]
mod capture_lists;
#[path = "bounded/list_size.rs"]
mod list_size;
#[path = "bounded/stress_capture.rs"]
mod stress_capture;

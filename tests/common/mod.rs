//! Shared by the test suites: a GPU context under the validation layer and the check that it
//! reported nothing; closed-form intersections for synthetic scenes ([`analytic`]).
// Each test crate compiles this module and uses only part of it.
#![allow(dead_code)]

pub mod analytic;

use cubetrace::vk::{ContextOptions, GpuContext};

/// A context with the Khronos validation layer when it is installed; a missing driver fails the
/// test with the driver's install hint.
pub fn gpu_context() -> GpuContext {
    let ctx = GpuContext::new(ContextOptions::for_tests()).unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "device: {}; validation layer: {}; debug utils: {}",
        ctx.report().name,
        if ctx.validation_enabled() {
            "on"
        } else {
            "not installed, off"
        },
        ctx.debug_utils_enabled()
    );
    ctx
}

/// Asserts that the validation layer reported no error, then drops the context and asserts
/// again (leaks are reported when the device is destroyed).
pub fn finish_gpu(ctx: GpuContext) {
    let log = ctx.validation_log();
    for w in log.warnings() {
        eprintln!("validation warning: {w}");
    }
    assert_eq!(
        ctx.validation_errors(),
        Vec::<String>::new(),
        "validation errors"
    );
    drop(ctx);
    assert_eq!(
        log.errors(),
        Vec::<String>::new(),
        "validation errors at destruction"
    );
}

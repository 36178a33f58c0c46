//! One file per GPU method, each a [`MethodSpec`] and a [`Technique`] ([`technique`] has the
//! interface and its invariants). Adding a method: its file here and one line in [`SPECS`].
pub mod bvh;
pub mod compute;
pub mod envmap;
pub mod fragment;
pub mod reflection_point;
pub mod ssr;
pub mod technique;

pub use technique::{
    CameraInputs, FrameInputs, GeometryInputs, MethodSpec, MethodStats, Needs, Scope, Technique,
};

use crate::method::Method;
use crate::vk::backend::error::{VkError, VkResult};

/// Every GPU method's description, one line per method (each names its method:
/// [`MethodSpec::method`]).
pub const SPECS: [&dyn MethodSpec; 6] = [
    &compute::Compute,
    &fragment::Fragment,
    &envmap::Envmap,
    &ssr::Ssr,
    &reflection_point::ReflectionPoint,
    &bvh::Bvh,
];

/// The description of a GPU method; `None` for the reference, which runs on the CPU.
pub fn spec(method: Method) -> Option<&'static dyn MethodSpec> {
    SPECS.into_iter().find(|s| s.method() == method)
}

/// Allocates `method`'s passes for a frame ([`MethodSpec::create`]).
pub fn create(method: Method, inputs: &FrameInputs<'_>) -> VkResult<Box<dyn Technique>> {
    match spec(method) {
        Some(s) => s.create(inputs),
        None => Err(VkError::Usage {
            what: "method".into(),
            detail: format!("--method {method} is no GPU method"),
        }),
    }
}

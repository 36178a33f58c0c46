//! One file per GPU method, each a [`MethodSpec`] and a [`Technique`] ([`technique`] has the
//! interface and its invariants). Adding a method: its file here and one line in [`spec`].
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

/// The description of a GPU method; `None` for the reference, which runs on the CPU.
pub fn spec(method: Method) -> Option<&'static dyn MethodSpec> {
    Some(match method {
        Method::Compute => &compute::Compute,
        Method::Fragment => &fragment::Fragment,
        Method::Envmap => &envmap::Envmap,
        Method::Ssr => &ssr::Ssr,
        Method::ReflectionPoint => &reflection_point::ReflectionPoint,
        Method::Bvh => &bvh::Bvh,
        Method::Reference => return None,
    })
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

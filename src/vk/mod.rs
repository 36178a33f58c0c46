//! Vulkan backend (ash): the only module tree of the crate that uses `unsafe`.
//!
//! Four layers, each importing only the ones before it:
//! - [`backend`]: Vulkan plumbing, one module per Vulkan object after kajiya and wgpu-hal
//!   (instance, device with the allocator, [`GpuContext`], buffer, image, the shader table that
//!   `build.rs` generates from `spirv/*.wgsl`, pipelines, timestamps, the probed
//!   [`DeviceReport`]). It knows no pass, method or scene.
//! - [`passes`]: the stages a frame shares between methods: the scene's buffers, the CMOs'
//!   data, capture and pyramid, the G-buffer, the records, the BVH tracer with its queues and
//!   the reflector check, the bounce rounds, composite.
//! - [`methods`]: one file per GPU method, each a [`methods::MethodSpec`] (what it needs from
//!   the shared stages, its device memory, how to create it) and a [`methods::Technique`] (its
//!   passes: how they are recorded, what they report); [`methods::spec`] is the registry.
//! - [`frame`]: [`frame::GpuRenderer`], the shared stages around one method; [`budget`], the
//!   one memory estimate, summed from the shared stages and the method's spec; [`options`],
//!   what a render is asked for.
//!
//! Invariants for the whole tree:
//! - Each `unsafe` block wraps one ash call (or a few on the same object) and states why it is
//!   sound in a `// SAFETY:` line. No `unwrap()` on anything the driver returns.
//! - Ownership encodes destruction order: resources hold `Arc<Device>`, the device holds
//!   `Arc<Instance>`. Nothing is destroyed while a child lives, and nothing leaks.
//! - Coordinates are Vulkan's native ones: naga is told not to flip y.
//! - Every pass has one name: its WGSL file stem, its debug label and its timestamp key; a
//!   method's passes are named after the method (`spirv/M*.wgsl`, `methods/M.rs`).
//! - No module imports one that imports it back: a method imports the shared stages and the
//!   interface ([`methods::technique`]), never the frame or another method but the one whose
//!   pass shape it shares (envmap: fragment's deferred pass).
pub mod backend;
pub mod budget;
pub mod frame;
pub mod methods;
pub mod options;
pub mod passes;

pub use backend::buffer::Buffer;
pub use backend::context::{ContextOptions, GpuContext, Recorder};
pub use backend::device::{Device, EnabledFeatures};
pub use backend::error::{VkError, VkResult};
pub use backend::graphics::{
    ColourTarget, DepthTest, GraphicsDesc, GraphicsPipeline, RenderTarget,
};
pub use backend::image::{Image, ImageDesc};
pub use backend::info::DeviceReport;
pub use backend::instance::{Validation, ValidationLog};
pub use backend::pipeline::{BindGroup, ComputeOptions, ComputePipeline, Resource};
pub use backend::shaders::Pass;
pub use backend::timestamps::{PassTime, Timestamps};

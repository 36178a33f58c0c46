//! Vulkan backend (ash): the only module tree of the crate that uses `unsafe`.
//!
//! One module per Vulkan object, after kajiya and wgpu-hal: [`instance`], [`device`] (with the
//! allocator), [`context`] ([`GpuContext`]), [`buffer`], [`image`], [`shaders`] (the table
//! `build.rs` generates from `spirv/*.wgsl`), [`pipeline`], [`timestamps`]; [`conv`] holds the
//! pure enum mappings and [`info`] the probed [`DeviceReport`].
//!
//! Invariants for the whole tree:
//! - Each `unsafe` block wraps one ash call (or a few on the same object) and states why it is
//!   sound in a `// SAFETY:` line. No `unwrap()` on anything the driver returns.
//! - Ownership encodes destruction order: resources hold `Arc<Device>`, the device holds
//!   `Arc<Instance>`. Nothing is destroyed while a child lives, and nothing leaks.
//! - Coordinates are Vulkan's native ones: naga is told not to flip y.
//! - Every pass has one name: its WGSL file stem, its debug label and its timestamp key.
pub mod backend;
pub mod budget;
pub mod frame;
pub mod methods;
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

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
pub mod bounce;
pub mod budget;
pub mod buffer;
pub mod bvh;
pub mod capture;
pub mod cmo;
pub mod compute;
pub mod context;
pub mod conv;
pub mod device;
pub mod error;
pub mod frame;
pub mod gbuffer;
pub mod graphics;
pub mod hier32;
pub mod hit_probe;
pub mod image;
pub mod info;
pub mod instance;
pub mod pipeline;
pub mod pyramid;
pub mod reflection_point;
pub mod scene_buffers;
pub mod selftest;
pub mod shaders;
pub mod ssr;
pub mod sync;
pub mod timestamps;
pub mod trace_probe;

pub use buffer::Buffer;
pub use context::{ContextOptions, GpuContext, Recorder};
pub use device::{Device, EnabledFeatures};
pub use error::{VkError, VkResult};
pub use graphics::{ColourTarget, DepthTest, GraphicsDesc, GraphicsPipeline, RenderTarget};
pub use image::{Image, ImageDesc};
pub use info::DeviceReport;
pub use instance::{Validation, ValidationLog};
pub use pipeline::{BindGroup, ComputeOptions, ComputePipeline, Resource};
pub use shaders::Pass;
pub use timestamps::{PassTime, Timestamps};

//! Vulkan plumbing: one module per Vulkan object, after kajiya and wgpu-hal. Nothing here knows
//! a pass, a method or a scene.
pub mod buffer;
pub mod context;
pub mod conv;
pub mod device;
pub mod error;
pub mod graphics;
pub mod image;
pub mod info;
pub mod instance;
pub mod pipeline;
pub mod shaders;
pub mod sync;
pub mod timestamps;

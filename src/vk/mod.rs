//! Vulkan backend.
pub mod shaders;

//! The passes every GPU method shares before it traces: the rasterised capture of the cube maps
//! and the G-buffer against the CPU, the min/max pyramid against its twin, and the depth ranges
//! and inputs that once made the rasterised passes wrong.
//!
//! - `gpu_raster`: `capture` and `gbuffer` against the CPU ray-cast capture and primary hits;
//! - `gpu_pyramid`: the `pyramid` pass against `MipPyramid::build`, bit for bit;
//! - `real_inputs_raster`: the eye in a surface's plane, a far vertex;
//! - `depth_range`: a scene spanning 1e-3 to 1e5 on both GPU paths, and one beyond f32 refused.

mod common;

#[path = "capture/depth_range.rs"]
mod depth_range;
#[path = "capture/gpu_pyramid.rs"]
mod gpu_pyramid;
#[path = "capture/gpu_raster.rs"]
mod gpu_raster;
#[path = "capture/real_inputs_raster.rs"]
mod real_inputs_raster;

//! The stages a frame shares between methods: what a method needs but does not own.
pub mod bounce;
pub mod bvh;
pub mod capture;
pub mod capture_lists;
pub mod cmo;
pub mod composite;
pub mod cone;
pub mod gbuffer;
pub mod hier32;
pub mod lists;
pub mod pyramid;
pub mod records;
pub mod scene_buffers;

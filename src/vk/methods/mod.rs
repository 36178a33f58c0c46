//! One file per GPU method.
pub mod compute;
pub mod reflection_point;
pub mod ssr;

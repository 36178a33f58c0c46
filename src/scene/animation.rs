//! Keyframed animation of a scene: the camera's and each mesh's keys, the frame rate and the
//! default frame range (the scene file's `[animation]`).
//!
//! (Skeleton: filled in by the animation work of issue 23.)

/// A scene's animation; the default is none (a still).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {}

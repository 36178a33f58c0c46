//! Many frames from one render: the film's sub-pixel samples and camera changes (`film`), the
//! scene file's `[film]` and `[animation]` and `render --frames` (`animation`), and one renderer
//! whose meshes move in place (`sequence_inplace`). Each frame is bit for bit the frame rendered
//! alone.

mod common;

#[path = "sequence/animation.rs"]
mod animation;
#[path = "sequence/film.rs"]
mod film;
#[path = "sequence/sequence_inplace.rs"]
mod sequence_inplace;

//! Scene input: the scene file, OBJ and MTL as users and exporters write them, what a file may
//! hold, export and load back, and the loader under fuzzed input.
//!
//! - `scene_input`: real-world OBJ/MTL quirks, scene file checks and set-up diagnostics;
//! - `scene_files`: export and load round trip; each class of bad input through the binary;
//! - `scene_limits`: the bounds a file's numbers must keep, and the CMO limit;
//! - `scene_export`: every built-in, exported and loaded back, renders byte-identically;
//! - `exporter_quirks`: what real exporters write that the loader once refused or read wrong;
//! - `exporter_habits`: more of them (MTL keyword case, 8-bit vertex colours, `s off`, mesh
//!   paths as users write them);
//! - `fuzz_scene`: a fixed-seed fuzz pass over the loader;
//! - `self_reflections`: the per-reflector `self_reflections` override and its `auto`.

mod common;

#[path = "scene/exporter_habits.rs"]
mod exporter_habits;
#[path = "scene/exporter_quirks.rs"]
mod exporter_quirks;
#[path = "scene/fuzz_scene.rs"]
mod fuzz_scene;
#[path = "scene/scene_export.rs"]
mod scene_export;
#[path = "scene/scene_files.rs"]
mod scene_files;
#[path = "scene/scene_input.rs"]
mod scene_input;
#[path = "scene/scene_limits.rs"]
mod scene_limits;
#[path = "scene/self_reflections.rs"]
mod self_reflections;

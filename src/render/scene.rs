#![forbid(unsafe_code)]
//! A run's scene prepared from a plain value ([`SceneSetup`]): loaded once, its CMO overrides
//! applied, the other objects subdivided, its camera chosen at the frame's size and checked,
//! and the CMO placement searched for that camera where the scene asks for a search and the run
//! captures CMOs ([`prepare`]). `cubetrace render` builds the value from its arguments, the bench
//! from its configuration; each phase's time is logged (info, `-v`: [`timed`]).

use std::time::Instant;

use anyhow::Result;

use crate::camera::Camera;
use crate::placement::{Placement, PlacementChoice, override_placement};
use crate::scene::{self, Scene};

/// What a run's scene is, as plain values.
#[derive(Clone, Debug, Default)]
pub struct SceneSetup {
    /// A built-in scene's name or a scene file's path.
    pub scene: String,
    /// The CMO placement over the scene's ([`override_placement`]).
    pub placement: Option<PlacementChoice>,
    /// The CMO count over the scene's ([`override_placement`]).
    pub cmos: Option<u32>,
    /// The CMO faces' size over the scene's.
    pub cube_size: Option<u32>,
    /// Times the non-reflector objects' triangles are split into four.
    pub subdivide: u32,
    /// The camera by name or index (`None`: the first).
    pub camera: Option<String>,
    /// The frame's width and height over the camera's ([`frame_size`]).
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// Whether a placement search the scene asks for runs now, for the camera (only where the
    /// run captures CMOs: otherwise nothing reads the placement).
    pub search: bool,
    /// The run's reflections per path, whose later reflections the placement search samples
    /// too ([`crate::placement::PlacementOptions::bounces`]; 0 and 1: the first reflected rays
    /// alone).
    pub bounces: u32,
    /// The frames' criterion, which judges the placement search's sample
    /// ([`crate::placement::PlacementOptions::scoring`]).
    pub scoring: crate::placement::Scoring,
    /// What names the frame size in a refusal (`--width/--height` on the command line).
    pub size_name: &'static str,
}

/// The frame size: the camera's, or the given width and height; one of them alone keeps the
/// camera's aspect ratio (the other side rounded, at least 1).
pub fn frame_size(camera: (u32, u32), width: Option<u32>, height: Option<u32>) -> (u32, u32) {
    let (w, h) = (f64::from(camera.0), f64::from(camera.1));
    let other = |given: u32, ratio: f64| ((f64::from(given) * ratio).round().max(1.0)) as u32;
    match (width, height) {
        (Some(x), Some(y)) => (x, y),
        (Some(x), None) => (x, other(x, h / w)),
        (None, Some(y)) => (other(y, w / h), y),
        (None, None) => camera,
    }
}

/// Runs one host phase and logs its name and time (info; `-v`), so that no phase's time is
/// credited to another.
pub fn timed<T>(phase: &str, f: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let out = f();
    log::info!("{phase}: {:.2?}", start.elapsed());
    out
}

/// The scene of `setup` with its overrides and subdivision, the chosen camera at the frame's
/// size (checked), and the placement search's result where one ran (module docs).
pub fn prepare(setup: &SceneSetup) -> Result<(Scene, Camera, Option<Placement>)> {
    let mut scene = timed("scene load", || scene::load(&setup.scene))?;
    override_placement(&mut scene, setup.placement, setup.cmos);
    if let Some(size) = setup.cube_size {
        scene.cmo.resolution = size;
    }
    if setup.subdivide > 0 {
        timed("subdivision", || {
            crate::cpu::reflection_point::subdivide_non_reflectors(&mut scene, setup.subdivide)
        });
    }
    let mut camera = scene.camera(setup.camera.as_deref())?.clone();
    (camera.width, camera.height) =
        frame_size((camera.width, camera.height), setup.width, setup.height);
    scene::check_resolution(camera.width, camera.height)
        .map_err(|e| anyhow::anyhow!("{}: {e}", setup.size_name))?;
    // Every frame needs the reflectors' convexity (`Scene::self_capture`, kept per mesh): found
    // first, so that the search's time is the search's.
    timed("reflector convexity", || {
        scene.self_capture();
    });
    let placement = if setup.search {
        timed("CMO placement", || {
            crate::placement::resolve(&mut scene, &camera, setup.bounces, setup.scoring)
        })
    } else {
        None
    };
    Ok((scene, camera, placement))
}

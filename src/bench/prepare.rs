#![forbid(unsafe_code)]
//! The bench's scenes prepared for a run (loaded, overridden, placed: [`prepare_scene_placed`])
//! and the grid's memory check before the runs ([`check_memory`], per scene
//! [`crate::render::checks::check_runs_memory`]).

use anyhow::Result;

use super::config::{BenchConfig, BenchPlacement};
use super::spec::MethodSpec;
use crate::camera::Camera;
use crate::memory;
use crate::placement::{PlacementChoice, Scoring};
use crate::render::scene::SceneSetup;
use crate::scene::Scene;

/// Loads a scene by name or path and applies the overrides of `cfg` and its frame size to its
/// first camera ([`crate::render::scene::prepare`]); a placement search samples the first
/// reflected rays alone (its callers follow one reflection per path), judged by the default
/// criterion.
pub fn prepare_scene(
    name: &str,
    width: u32,
    height: u32,
    cube_size: Option<u32>,
    cmos: Option<u32>,
) -> Result<(Scene, Camera)> {
    prepare_scene_judged(name, width, height, (cube_size, cmos), Scoring::default())
}

/// [`prepare_scene`] with a placement search judged by `scoring` (the criterion of the frames
/// the caller renders).
pub fn prepare_scene_judged(
    name: &str,
    width: u32,
    height: u32,
    (cube_size, cmos): (Option<u32>, Option<u32>),
    scoring: Scoring,
) -> Result<(Scene, Camera)> {
    let (scene, camera, _) = prepare_scene_placed(
        name,
        width,
        height,
        (cube_size, cmos),
        BenchPlacement::Scene,
        Some(scoring),
        1,
    )?;
    Ok((scene, camera))
}

/// [`prepare_scene`] with a placement of the bench's axis (`cube_size`, `cmos`: the overrides);
/// also the placement search's result where one ran. `search`: the criterion that judges a
/// placement search, `None` where none runs at all (no method of the grid captures CMOs: the
/// scene keeps its unresolved placement, which nothing reads). `bounces`: the run's reflections
/// per path, whose later reflections the search samples too.
pub fn prepare_scene_placed(
    name: &str,
    width: u32,
    height: u32,
    (cube_size, cmos): (Option<u32>, Option<u32>),
    placement: BenchPlacement,
    search: Option<Scoring>,
    bounces: u32,
) -> Result<(Scene, Camera, Option<crate::placement::Placement>)> {
    let choice = match placement {
        BenchPlacement::Scene => None,
        BenchPlacement::Axis => Some(PlacementChoice::Axis),
        BenchPlacement::Auto => Some(PlacementChoice::Auto),
    };
    // A placement search runs once, for this camera, not in every `cmo_centres` call.
    crate::render::scene::prepare(&SceneSetup {
        scene: name.to_string(),
        placement: choice,
        cmos,
        cube_size,
        width: Some(width),
        height: Some(height),
        search: search.is_some(),
        bounces,
        scoring: search.unwrap_or_default(),
        size_name: "frame size",
        ..SceneSetup::default()
    })
}

/// Refuses, before anything renders, a grid whose largest run would not fit in `limits`
/// ([`crate::memory`]): per scene, the reference frame (held through the scene's runs) beside the
/// largest GPU run's device data ([`crate::vk::budget::estimate`], the estimate `render` checks:
/// bounce queues and reflector check included) and its read-back and comparison. Runs that the
/// bounce rule skips ([`Method::check_bounces`](crate::method::Method::check_bounces)) are not
/// counted: they allocate nothing. The subdivided runs are estimated on the scene as loaded:
/// subdivision splits the non-reflector objects only, and the estimate depends on the frame, the
/// CMOs and the reflectors.
pub fn check_memory(
    cfg: &BenchConfig,
    prepared: &[(Scene, Camera)],
    limits: &memory::Limits,
) -> Result<()> {
    for (scene, camera) in prepared {
        let options = (cfg.methods.iter())
            .filter(|m| m.kind.is_gpu() && runs_at(m, cfg.bounces))
            .map(|m| m.render_options(cfg.bounces, cfg.reflector_check));
        crate::render::checks::check_runs_memory(scene, camera, options, limits)?;
    }
    Ok(())
}

/// Whether a GPU spec runs at `bounces`
/// ([`Method::check_bounces`](crate::method::Method::check_bounces)); the grid skips it otherwise.
pub(super) fn runs_at(spec: &MethodSpec, bounces: u32) -> bool {
    spec.kind
        .check_bounces(bounces, crate::vk::passes::bounce::MAX_BOUNCES, &spec.trace)
        .is_ok()
}

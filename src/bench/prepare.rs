#![forbid(unsafe_code)]
//! The bench's scenes prepared for a run (loaded, overridden, placed: [`prepare_scene_placed`])
//! and the checks around the runs: memory before ([`check_memory`]), validation after
//! ([`check_validation`]).

use anyhow::{Context, Result, bail};

use super::config::{BenchConfig, BenchPlacement};
use super::spec::MethodSpec;
use crate::camera::Camera;
use crate::memory;
use crate::output::Format;
use crate::placement::{PlacementChoice, override_placement};
use crate::scene::{self, Scene};
use crate::vk::GpuContext;

/// Loads a scene by name or path and applies the overrides of `cfg` and its frame size to its
/// first camera.
pub fn prepare_scene(
    name: &str,
    width: u32,
    height: u32,
    cube_size: Option<u32>,
    cmos: Option<u32>,
) -> Result<(Scene, Camera)> {
    let (scene, camera, _) = prepare_scene_placed(
        name,
        width,
        height,
        (cube_size, cmos),
        BenchPlacement::Scene,
        true,
    )?;
    Ok((scene, camera))
}

/// [`prepare_scene`] with a placement of the bench's axis (`cube_size`, `cmos`: the overrides);
/// also the placement search's result where one ran. `search`: whether a placement search runs
/// at all (not where no method of the grid captures CMOs: the scene keeps its unresolved
/// placement, which nothing reads).
pub fn prepare_scene_placed(
    name: &str,
    width: u32,
    height: u32,
    (cube_size, cmos): (Option<u32>, Option<u32>),
    placement: BenchPlacement,
    search: bool,
) -> Result<(Scene, Camera, Option<crate::placement::Placement>)> {
    let mut scene = scene::load(name)?;
    let choice = match placement {
        BenchPlacement::Scene => None,
        BenchPlacement::Axis => Some(PlacementChoice::Axis),
        BenchPlacement::Auto => Some(PlacementChoice::Auto),
    };
    override_placement(&mut scene, choice, cmos);
    if let Some(n) = cube_size {
        scene.cmo.resolution = n;
    }
    let mut camera = scene
        .cameras
        .first()
        .with_context(|| format!("scene '{name}' has no camera"))?
        .clone();
    camera.width = width;
    camera.height = height;
    // A placement search runs once, for this camera, not in every `cmo_centres` call.
    let searched = if search {
        crate::placement::resolve(&mut scene, &camera)
    } else {
        None
    };
    scene::check_resolution(width, height).map_err(|e| anyhow::anyhow!("frame size: {e}"))?;
    Ok((scene, camera, searched))
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
        let pixels = u64::from(camera.width) * u64::from(camera.height);
        let cmos = scene.cmo_centres().len() as u32;
        let device = cfg
            .methods
            .iter()
            .filter(|m| m.kind.is_gpu() && runs_at(m, cfg.bounces))
            .map(|m| {
                let options = m.render_options(cfg.bounces, cfg.reflector_check);
                crate::vk::budget::estimate(scene, camera, &options).total()
            })
            .max()
            .unwrap_or(0);
        let mut host = memory::reference_bytes(pixels, Format::Png)
            + memory::gpu_host_bytes(pixels, Format::Png, true);
        if limits.device_is_host {
            host += device;
        }
        let what = format!(
            "bench scene '{}' at {}x{} ({cmos} CMOs of {}^2 texels per face)",
            scene.name, camera.width, camera.height, scene.cmo.resolution
        );
        memory::check(&what, host, limits.host.clone())?;
        memory::check(&what, device, Some(limits.device.clone()))?;
    }
    Ok(())
}

/// Whether a GPU spec runs at `bounces` ([`Method::check_bounces`]); the grid skips it otherwise.
pub(super) fn runs_at(spec: &MethodSpec, bounces: u32) -> bool {
    spec.kind
        .check_bounces(bounces, crate::vk::passes::bounce::MAX_BOUNCES, &spec.trace)
        .is_ok()
}

/// Fails if the validation layer (when on) reported errors.
pub fn check_validation(ctx: &GpuContext) -> Result<()> {
    let errors = ctx.validation_errors();
    if !errors.is_empty() {
        bail!(
            "the validation layer reported errors:\n{}",
            errors.join("\n")
        );
    }
    Ok(())
}

#![forbid(unsafe_code)]
//! The checks around a render, the command's and the bench's alike: before anything renders, the
//! memory a frame needs ([`check_gpu_memory`], [`check_reference_memory`], the bench's
//! [`check_runs_memory`]: the one estimate of [`crate::vk::budget::estimate`] against
//! [`memory::Limits`]) and whether the device can bind the scene's textures
//! ([`check_textures`]); after, whether the validation layer reported errors
//! ([`check_validation`]).

use anyhow::{Result, bail};

use crate::camera::Camera;
use crate::memory;
use crate::output::Format;
use crate::scene::Scene;
use crate::vk::GpuContext;
use crate::vk::frame::RenderOptions;

/// Refuses a GPU render that would not fit: the host bytes (the read-back, the output and with
/// `compare` the reference; on a CPU device the device's bytes too) against `limits.host`, then
/// the device bytes of [`crate::vk::budget::estimate`] (CMOs, frame, bounce queues, reflector
/// check) against `limits.device`. `size` names the frame (`a WxH frame with --method M`),
/// `device` the device. The bench's runs are checked against the same estimate and limits
/// ([`check_runs_memory`]).
#[allow(clippy::too_many_arguments)]
pub fn check_gpu_memory(
    size: &str,
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    format: Format,
    compare: bool,
    device: &str,
    limits: &memory::Limits,
) -> Result<()> {
    let (estimate, items) = crate::vk::budget::estimate_with_items(scene, camera, options);
    let pixels = u64::from(camera.width) * u64::from(camera.height);
    let mut host = memory::gpu_host_bytes(pixels, format, compare);
    if limits.device_is_host {
        // A CPU device's memory is the machine's.
        host += estimate.total();
    }
    let gpu_size = format!(
        "{size} ({} CMOs of {}^2 texels per face: {} of GPU data)",
        scene.cmo_centres().len(),
        scene.cmo.resolution,
        memory::human(estimate.total())
    );
    let advice = memory::advice(&items);
    memory::check_with(&gpu_size, host, limits.host.clone(), &advice)?;
    memory::check_with(
        &format!(
            "{size} ({} of CMO data, {} per frame, {} of scene data) on {device}",
            memory::human(estimate.cmo),
            memory::human(estimate.frame),
            memory::human(estimate.scene),
        ),
        estimate.total(),
        Some(limits.device.clone()),
        &advice,
    )
}

/// Refuses a scene whose textures do not fit the one storage buffer that holds them all
/// (`maxStorageBufferRange` of the device, `limit` bytes), naming the largest textures.
pub fn check_textures(scene: &Scene, limit: u64, device: &str) -> Result<()> {
    let need = crate::vk::budget::texel_buffer_bytes(scene);
    if need <= limit {
        return Ok(());
    }
    let mut textures: Vec<_> = scene.textures.iter().collect();
    textures.sort_by_key(|t| std::cmp::Reverse(crate::vk::budget::texture_bytes(t)));
    let listed: Vec<String> = textures
        .iter()
        .take(3)
        .map(|t| {
            format!(
                "texture '{}' {}x{}: {}",
                t.name,
                t.width,
                t.height,
                memory::human(crate::vk::budget::texture_bytes(t))
            )
        })
        .collect();
    anyhow::bail!(
        "scene '{}': its textures take {} in one GPU buffer, more than {device} can bind \
         (maxStorageBufferRange = {}); the largest: {}; scale them down (each halving of a \
         texture's sides takes 3/4 off)",
        scene.name,
        memory::human(need),
        memory::human(limit),
        listed.join(", ")
    )
}

/// Refuses a reference render whose frame would not fit in the host memory available now.
/// `size` names the frame.
pub fn check_reference_memory(size: &str, camera: &Camera, format: Format) -> Result<()> {
    let pixels = u64::from(camera.width) * u64::from(camera.height);
    memory::check(
        size,
        memory::reference_bytes(pixels, format),
        memory::host_available()?,
    )
}

/// Refuses a scene of the bench whose largest run would not fit in `limits`: the reference frame
/// (held through the scene's runs) beside the largest device data of the GPU runs' `options`
/// ([`crate::vk::budget::estimate`]) and their read-back and comparison.
pub fn check_runs_memory(
    scene: &Scene,
    camera: &Camera,
    options: impl IntoIterator<Item = RenderOptions>,
    limits: &memory::Limits,
) -> Result<()> {
    let pixels = u64::from(camera.width) * u64::from(camera.height);
    let cmos = scene.cmo_centres().len() as u32;
    let device = (options.into_iter())
        .map(|o| crate::vk::budget::estimate(scene, camera, &o).total())
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
    memory::check(&what, device, Some(limits.device.clone()))
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

#![forbid(unsafe_code)]
//! [`FrameRenderer`]: the frames of one run (a `cubetrace render`, one frame or a sequence),
//! through one code path. It is opened from a plain [`RenderSetup`] ([`FrameRenderer::open`]:
//! the device, the checks of [`super::checks`], the pipelines and the scene buffers, once); each
//! frame ([`FrameRenderer::render`]) renders its samples ([`super::samples`], [`crate::film`])
//! and filters them, and [`RenderedFrame::write`] writes it (PNG or EXR, [`crate::output`]).
//!
//! Reuse ([`SceneChange`], from a comparison of the scene with the last frame's that allocates
//! nothing):
//! - only the camera changed: the GPU renderer is pointed at the new camera
//!   ([`GpuRenderer::set_camera`]) and keeps its capture unless the capture's near plane moved;
//! - the geometry's placement changed (mesh transforms, CMO centres of the same count): the GPU
//!   renderer is updated in place ([`GpuRenderer::update_geometry`]: vertices, BVHs, CMO
//!   centres, ranges; its pipelines and buffers stay) and captures again, or takes the
//!   placement search's lists of the frame where given and taken
//!   ([`FrameRenderer::render_with_lists`], [`GpuRenderer::update_geometry_with_lists`]);
//! - anything else changed (a mesh's triangles, a material, the frame size, ...), or the
//!   in-place update cannot take the new scene (it says why, logged at debug level): a new
//!   renderer is built on the same device.
//!
//! Either way the frame is bit for bit the frame rendered alone (`tests/sequence/film.rs`,
//! `tests/sequence/sequence_inplace.rs`). The samples of one frame share its capture: only the first
//! sample of a frame can capture. The reference rebuilds its tracer wherever the scene changed
//! but for its cameras.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Result;
use glam::Vec3;

use crate::Method;
use crate::camera::Camera;
use crate::cubemap::bounds::BuiltLists;
use crate::film::FilmSettings;
use crate::memory;
use crate::metrics::Traced;
use crate::output::{self, Format};
use crate::reference;
use crate::scene::{Scene, WorldGeometry};
use crate::vk::frame::{FramePlan, GpuFrame, GpuRenderer, RenderOptions, StaleUpdate};
use crate::vk::options::ListSize;
use crate::vk::{ContextOptions, GpuContext};

use super::checks;
use super::samples::{self, SampleFrame};

/// How a frame's scene differs from the one the renderer holds ([`FrameRenderer::render`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneChange {
    /// Nothing but the cameras.
    None,
    /// The geometry's placement only: mesh transforms and CMO centres (as many).
    Placement,
    /// Anything else, and what.
    Other(String),
}

/// What a frame did with the renderer before rendering.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RendererUse {
    /// The run's first frame: the renderer was built for it.
    New,
    /// Kept as it was, or pointed at another camera.
    Kept,
    /// The geometry updated in place ([`GpuRenderer::update_geometry`]; the reference has
    /// none: it rebuilds).
    UpdatedInPlace,
    /// A new renderer was built.
    Rebuilt,
}

/// One rendered frame: its samples filtered into the colour, the AOVs of the sample nearest the
/// pixel centre ([`crate::film`]).
#[derive(Clone, Debug)]
pub struct RenderedFrame {
    /// Whether any sample of the frame ran the capture (the CMO stages).
    pub captured: bool,
    /// Whether the frame's CMO stages ran on the placement search's lists, uploaded for it
    /// instead of a capture ([`FrameRenderer::render_with_lists`]).
    pub lists_uploaded: bool,
    /// What the frame did with the renderer.
    pub renderer: RendererUse,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// GPU methods: the AOV sample's frame, its `colour` the filtered one.
    pub gpu: Option<GpuFrame>,
    /// The reference: the AOV sample's frame, its `colour` the filtered one.
    pub reference: Option<reference::Frame>,
    /// Every sample, where the renderer keeps them (`--compare`); empty otherwise.
    pub samples: Vec<SampleFrame>,
    /// Wall time of the frame's samples (render, read back, filter).
    pub render_time: Duration,
    /// GPU time of all samples' passes, milliseconds (0 for the reference).
    pub gpu_ms: f64,
    world: Arc<WorldGeometry>,
}

impl RenderedFrame {
    /// The frame as the error metrics read it (GPU methods).
    pub fn traced(&self) -> Option<Traced> {
        self.gpu.as_ref().map(GpuFrame::traced)
    }

    /// The filtered linear colour.
    pub fn colour(&self) -> &[Vec3] {
        match (&self.gpu, &self.reference) {
            (Some(g), _) => &g.colour,
            (None, Some(r)) => &r.colour,
            (None, None) => &[],
        }
    }

    /// Mirror pixels of the AOV sample.
    pub fn mirror_pixels(&self) -> usize {
        match (&self.gpu, &self.reference) {
            (Some(g), _) => g.mirror_pixels(),
            (None, Some(r)) => r.mirror_pixels(),
            (None, None) => 0,
        }
    }

    /// Atomic write ([`crate::files`]), PNG or EXR as `format` says: the filtered colour; in
    /// EXR also the AOVs ([`crate::output`]'s channels).
    pub fn write(&self, path: &std::path::Path, format: Format) -> Result<()> {
        match (&self.gpu, &self.reference) {
            (Some(g), _) => {
                output::write_image(path, format, (self.width, self.height), &g.colour, || {
                    output::traced_channels(&g.traced(), &g.surface_position, &self.world)
                })
            }
            (None, Some(r)) => {
                output::write_image(path, format, (self.width, self.height), &r.colour, || {
                    output::frame_channels(r, &self.world)
                })
            }
            (None, None) => anyhow::bail!("no frame to write"),
        }
    }
}

/// What renders: a GPU renderer on its device, or the CPU reference's tracer.
enum Backend {
    Gpu {
        ctx: Box<GpuContext>,
        /// The renderer's options, its lists' face size resolved for its scene.
        options: RenderOptions,
        /// The lists' face size as the setup asked for it: resolved again for each scene whose
        /// geometry changed, as a frame alone resolves it (`auto` and the size a placement
        /// search took depend on the scene).
        requested: ListSize,
        renderer: Option<Box<GpuRenderer>>,
    },
    Reference {
        tracer: Box<reference::Tracer>,
    },
}

/// What a run renders with, as plain values: `cubetrace render` builds it from its arguments
/// (`app::render`), a caller of its own by hand. [`FrameRenderer::open`] checks it against the
/// scene and the device and builds the renderer.
#[derive(Clone, Copy, Debug)]
pub struct RenderSetup {
    pub method: Method,
    pub bounces: u32,
    pub film: FilmSettings,
    /// The output's format (its bytes count in the memory check).
    pub format: Format,
    /// Whether the frames are compared with the reference (`--compare`): its memory is counted,
    /// and at more than one sample every sample is kept ([`RenderedFrame::samples`]).
    pub compare: bool,
    /// GPU methods: the device to open and the renderer's options; `None` for the reference.
    pub gpu: Option<(ContextOptions, RenderOptions)>,
}

/// What a [`FrameRenderer`] is built from, checked ([`FrameRenderer::open`] checks a
/// [`RenderSetup`] and builds it).
pub struct FrameSetup {
    pub method: Method,
    pub bounces: u32,
    pub film: FilmSettings,
    /// Keep every sample of each frame ([`RenderedFrame::samples`], for `--compare`).
    pub keep_samples: bool,
    /// GPU methods: the device and the renderer's options; `None` for the reference.
    pub gpu: Option<(GpuContext, RenderOptions)>,
}

/// The renderer of a run's frames (module docs).
pub struct FrameRenderer {
    method: Method,
    bounces: u32,
    film: FilmSettings,
    keep_samples: bool,
    backend: Backend,
    /// The scene the backend holds, cameras removed, and its geometry (IDs for the EXR).
    scene: Scene,
    world: Arc<WorldGeometry>,
    size: (u32, u32),
    /// Whether the next frame is the first.
    first: bool,
    /// Renderers (or reference tracers) built after the first, and in-place geometry updates.
    rebuilds: u32,
    updates: u32,
    /// The tests' negative: what in-place updates leave stale.
    stale: Option<StaleUpdate>,
}

/// `scene` without its cameras: what the renderer keeps to compare the next frame's with.
fn scene_key(scene: &Scene) -> Scene {
    Scene {
        cameras: Vec::new(),
        ..scene.clone()
    }
}

/// How `new` differs from `old` (the renderer's scene), cameras aside: each field compared in
/// place, nothing allocated. Every field of [`Scene`] is named here, so that a new one must be
/// classified before this compiles.
pub fn classify(old: &Scene, new: &Scene) -> SceneChange {
    let Scene {
        name,
        meshes,
        materials,
        textures,
        cameras: _,
        cmo,
        background,
        shading,
        self_reflections,
        film,
        animation,
    } = new;
    let other = |what: &str| SceneChange::Other(format!("the scene's {what} changed"));
    if *name != old.name || *film != old.film || *animation != old.animation {
        return other("name, film or animation");
    }
    if *materials != old.materials || *textures != old.textures {
        return other("materials or textures");
    }
    if *background != old.background
        || *shading != old.shading
        || *self_reflections != old.self_reflections
    {
        return other("background, shading or self_reflections");
    }
    if meshes.len() != old.meshes.len() {
        return other("mesh count");
    }
    let mut placement = false;
    for (a, b) in old.meshes.iter().zip(meshes) {
        if a.name != b.name || a.reflector != b.reflector || a.parts != b.parts {
            return SceneChange::Other(format!("mesh '{}' changed besides its transform", b.name));
        }
        placement |= a.transform != b.transform;
    }
    use crate::scene::CmoPlacement as P;
    match (&old.cmo.placement, &cmo.placement) {
        _ if old.cmo.resolution != cmo.resolution => return other("CMO resolution"),
        // The lists' face size the placement search took (`auto`'s instead of its rule).
        _ if old.cmo.lists != cmo.lists => return other("bounded lists' face size"),
        (P::Explicit(a), P::Explicit(b)) if a.len() == b.len() => placement |= a != b,
        (P::Auto { count: a }, P::Auto { count: b })
        | (P::Search { count: a }, P::Search { count: b })
            if a == b => {}
        _ => return other("CMO placement"),
    }
    if placement {
        SceneChange::Placement
    } else {
        SceneChange::None
    }
}

impl FrameRenderer {
    /// Device and checks once (GPU methods: the device, the textures and the memory the frame
    /// needs ([`checks`]), then the GPU renderer and its pipelines; the reference: the host
    /// memory, then its BVH); nothing rendered yet.
    pub fn open(setup: &RenderSetup, scene: &Scene, camera: &Camera) -> Result<Self> {
        Self::open_with_lists(setup, scene, camera, None)
    }

    /// [`FrameRenderer::open`] whose first GPU renderer takes the bounded criterion's lists from
    /// `lists` where given (the placement search's: [`GpuRenderer::with_built_lists`], which
    /// captures where they are not the capture's). A later frame whose geometry moved takes the
    /// lists it comes with ([`FrameRenderer::render_with_lists`]), else captures.
    pub fn open_with_lists(
        setup: &RenderSetup,
        scene: &Scene,
        camera: &Camera,
        lists: Option<&BuiltLists>,
    ) -> Result<Self> {
        let size = format!(
            "a {}x{} frame with --method {}",
            camera.width, camera.height, setup.method
        );
        let gpu = match setup.gpu {
            Some((context, requested)) => {
                let ctx = GpuContext::new(context)?;
                let options = FramePlan::resolve_list_size(scene, camera, &requested);
                let report = ctx.report();
                checks::check_textures(
                    scene,
                    u64::from(report.max_storage_buffer_range),
                    &report.name,
                )?;
                let limits =
                    memory::Limits::of_device(ctx.device_local_heap_bytes(), ctx.device_is_cpu())?;
                checks::check_gpu_memory(
                    &size,
                    scene,
                    camera,
                    &options,
                    setup.format,
                    setup.compare,
                    &report.name,
                    &limits,
                )?;
                Some((ctx, requested, options))
            }
            None => {
                checks::check_reference_memory(&size, camera, setup.format)?;
                None
            }
        };
        let resolved = gpu.as_ref().map(|g| g.2);
        let frame_setup = FrameSetup {
            method: setup.method,
            bounces: setup.bounces,
            film: setup.film,
            keep_samples: setup.compare && setup.film.spp > 1,
            gpu: gpu.map(|(ctx, requested, _)| (ctx, requested)),
        };
        FrameRenderer::from_setup_with(frame_setup, scene, camera, lists, resolved)
    }

    /// The renderer of checked parts ([`FrameRenderer::open`] checks a [`RenderSetup`] and
    /// builds them): with a device, its GPU renderer and pipelines are built; without one, the
    /// reference's tracer. Nothing is rendered yet.
    pub fn from_setup(setup: FrameSetup, scene: &Scene, camera: &Camera) -> Result<Self> {
        Self::from_setup_with(setup, scene, camera, None, None)
    }

    /// [`FrameRenderer::from_setup`] with the lists of [`FrameRenderer::open_with_lists`], and
    /// the setup's options with their list size resolved for `scene` where known already
    /// ([`FramePlan::resolve_list_size`]).
    fn from_setup_with(
        setup: FrameSetup,
        scene: &Scene,
        camera: &Camera,
        lists: Option<&BuiltLists>,
        resolved: Option<RenderOptions>,
    ) -> Result<Self> {
        let start = Instant::now();
        let backend = match setup.gpu {
            Some((ctx, requested)) => {
                let options = resolved
                    .unwrap_or_else(|| FramePlan::resolve_list_size(scene, camera, &requested));
                let renderer = match lists {
                    Some(l) => GpuRenderer::with_built_lists(&ctx, scene, camera, options, l)?,
                    None => GpuRenderer::new(&ctx, scene, camera, options)?,
                };
                log::info!(
                    "GPU renderer (passes, pipelines, BVHs): {:.2?}",
                    start.elapsed()
                );
                Backend::Gpu {
                    ctx: Box::new(ctx),
                    options,
                    requested: requested.list_size,
                    renderer: Some(Box::new(renderer)),
                }
            }
            None => {
                let tracer = reference::Tracer::new(scene);
                log::info!(
                    "{}: {} triangles, BVH built in {:.2?}",
                    scene.name,
                    tracer.world.triangles.len(),
                    start.elapsed()
                );
                Backend::Reference {
                    tracer: Box::new(tracer),
                }
            }
        };
        Ok(FrameRenderer {
            method: setup.method,
            bounces: setup.bounces,
            film: setup.film,
            keep_samples: setup.keep_samples,
            backend,
            world: Arc::new(scene.world()),
            scene: scene_key(scene),
            size: (camera.width, camera.height),
            first: true,
            rebuilds: 0,
            updates: 0,
            stale: None,
        })
    }

    /// Renderers (or reference tracers) built after the first: frames whose scene changed
    /// beyond the geometry's placement, or that an in-place update could not take.
    pub fn rebuilds(&self) -> u32 {
        self.rebuilds
    }

    /// Frames whose geometry was updated in place ([`GpuRenderer::update_geometry`]).
    pub fn geometry_updates(&self) -> u32 {
        self.updates
    }

    /// Makes in-place updates leave `stale` as it was: a wrong update, for the tests' negative
    /// only.
    #[cfg(feature = "test-hooks")]
    pub fn leave_stale(&mut self, stale: Option<StaleUpdate>) {
        self.stale = stale;
    }

    /// The film every frame is rendered with.
    pub fn film(&self) -> FilmSettings {
        self.film
    }

    /// The GPU device (GPU methods).
    pub fn context(&self) -> Option<&GpuContext> {
        match &self.backend {
            Backend::Gpu { ctx, .. } => Some(ctx),
            Backend::Reference { .. } => None,
        }
    }

    /// Keeps every sample of the frames for `--compare` (set by [`FrameRenderer::open`] when
    /// `--compare` is given at more than one sample).
    pub fn keep_samples(&mut self, keep: bool) {
        self.keep_samples = keep;
    }

    /// Renders one frame (all its samples). Reuses the renderer and the capture where only the
    /// camera changed since the last frame (scene equal but for cameras); updates the GPU
    /// renderer's geometry in place where only the placement of meshes or CMOs changed, and
    /// rebuilds it (same device) where anything else did or the update cannot take the scene
    /// (module docs). The result is byte-identical to rendering that frame alone.
    pub fn render(&mut self, scene: &Scene, camera: &Camera) -> Result<RenderedFrame> {
        self.render_with_lists(scene, camera, None)
    }

    /// [`FrameRenderer::render`] where the GPU renderer, if its geometry is updated or it is
    /// rebuilt for this frame, takes the bounded criterion's lists from `lists` (the placement
    /// search's for `scene`: [`GpuRenderer::update_geometry_with_lists`],
    /// [`GpuRenderer::with_built_lists`]) instead of capturing them. Where the renderer is kept,
    /// its CMO data is that of `scene` already and `lists` is not read.
    pub fn render_with_lists(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        lists: Option<&BuiltLists>,
    ) -> Result<RenderedFrame> {
        let change = if (camera.width, camera.height) != self.size {
            SceneChange::Other("the frame size changed".into())
        } else {
            classify(&self.scene, scene)
        };
        let start = Instant::now();
        let used = self.prepare(&change, scene, camera, lists)?;
        self.first = false;
        match change {
            SceneChange::None => {}
            SceneChange::Placement => {
                // Only the placement differs: the parts and the rest are equal already.
                for (kept, m) in self.scene.meshes.iter_mut().zip(&scene.meshes) {
                    kept.transform = m.transform;
                }
                self.scene.cmo = scene.cmo.clone();
            }
            SceneChange::Other(_) => self.scene = scene_key(scene),
        }
        if used != RendererUse::Kept && used != RendererUse::New {
            self.world = Arc::new(scene.world());
        }
        self.size = (camera.width, camera.height);
        let frame = match &mut self.backend {
            Backend::Gpu { ctx, renderer, .. } => {
                let Some(r) = renderer.as_deref_mut() else {
                    anyhow::bail!("no GPU renderer");
                };
                samples::gpu_frame(ctx, r, scene, camera, self.film, self.keep_samples)?
            }
            Backend::Reference { tracer } => samples::reference_frame_samples(
                scene,
                tracer,
                camera,
                self.bounces,
                self.film,
                self.keep_samples,
            ),
        };
        let (gpu, reference, samples, filled, gpu_ms) = frame;
        let (captured, lists_uploaded) = (filled.captured, filled.uploaded);
        let (captures, uploaded) = match &self.backend {
            Backend::Gpu { renderer, .. } => {
                let r = renderer.as_deref();
                (
                    r.is_some_and(|r| r.captures()),
                    r.is_some_and(|r| r.lists_uploaded()),
                )
            }
            Backend::Reference { .. } => (false, false),
        };
        log::info!(
            "frame: {} sample(s) per pixel, {}{}",
            self.film.spp,
            match (captures, captured) {
                _ if lists_uploaded => "no capture (the lists were uploaded)",
                (false, _) if uploaded => "no capture (the uploaded lists reused)",
                (false, _) => "no capture (--method reads no cube map)",
                (true, true) => "captured",
                (true, false) => "capture reused",
            },
            match used {
                RendererUse::New | RendererUse::Kept => "",
                RendererUse::UpdatedInPlace => ", geometry updated in place",
                RendererUse::Rebuilt => ", renderer rebuilt",
            }
        );
        Ok(RenderedFrame {
            captured,
            lists_uploaded,
            renderer: used,
            width: camera.width,
            height: camera.height,
            spp: self.film.spp,
            gpu,
            reference,
            samples,
            render_time: start.elapsed(),
            gpu_ms,
            world: self.world.clone(),
        })
    }

    /// Readies the backend for a frame whose scene differs from the last by `change`: keeps
    /// it, updates the GPU renderer's geometry in place, or rebuilds it (module docs).
    fn prepare(
        &mut self,
        change: &SceneChange,
        scene: &Scene,
        camera: &Camera,
        lists: Option<&BuiltLists>,
    ) -> Result<RendererUse> {
        let why = match change {
            SceneChange::None if self.first => return Ok(RendererUse::New),
            SceneChange::None => return Ok(RendererUse::Kept),
            SceneChange::Placement => {
                "the geometry moved, and the reference has no in-place update"
            }
            SceneChange::Other(why) => why.as_str(),
        };
        match &mut self.backend {
            Backend::Gpu {
                ctx,
                options,
                requested,
                renderer,
            } => {
                let wanted = RenderOptions {
                    list_size: *requested,
                    ..*options
                };
                let t = Instant::now();
                let wanted = FramePlan::resolve_list_size(scene, camera, &wanted);
                log::debug!("lists' face size resolved: {:.2?}", t.elapsed());
                let same_size = wanted.list_size == options.list_size;
                if !same_size {
                    log::debug!(
                        "GPU renderer rebuilt: the bounded lists' face size changed ({:?} -> {:?})",
                        options.list_size,
                        wanted.list_size
                    );
                } else if let (SceneChange::Placement, Some(r)) = (change, renderer.as_deref_mut())
                {
                    let t = Instant::now();
                    let refused = r.update_geometry_with(ctx, scene, camera, self.stale, lists);
                    // A failed update may have left the renderer half written: drop it.
                    let refused = refused.inspect_err(|_| *renderer = None)?;
                    let Some(why) = refused else {
                        log::debug!(
                            "GPU renderer: geometry updated in place in {:.2?}",
                            t.elapsed()
                        );
                        self.updates += 1;
                        return Ok(RendererUse::UpdatedInPlace);
                    };
                    log::debug!("GPU renderer rebuilt: {why}");
                } else {
                    log::debug!("GPU renderer rebuilt: {why}");
                }
                // The old renderer's memory is freed before the new one's is allocated.
                *renderer = None;
                *options = wanted;
                let t = Instant::now();
                *renderer = Some(Box::new(match lists {
                    Some(l) => GpuRenderer::with_built_lists(ctx, scene, camera, *options, l)?,
                    None => GpuRenderer::new(ctx, scene, camera, *options)?,
                }));
                log::info!("GPU renderer (rebuilt): {:.2?}", t.elapsed());
            }
            Backend::Reference { tracer } => {
                log::debug!("reference BVH rebuilt: {why}");
                let t = Instant::now();
                **tracer = reference::Tracer::new(scene);
                log::info!("reference BVH (rebuilt): {:.2?}", t.elapsed());
            }
        }
        self.rebuilds += 1;
        Ok(RendererUse::Rebuilt)
    }

    /// The method frames are rendered with.
    pub fn method(&self) -> Method {
        self.method
    }
}

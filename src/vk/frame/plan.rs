//! The frame plan: which of the shared stages a frame allocates and at what sizes, decided once
//! from the scene, the camera and the options ([`FramePlan::new`]). [`GpuRenderer`]'s creation
//! allocates what the plan says, and the memory estimate ([`crate::vk::budget::estimate`])
//! counts the bytes of the same plan, so that the two cannot disagree on what exists.
//!
//! The plan holds decisions and sizes (pixels, CMO count and face size, what a texel holds,
//! the bounded capture's pool bound), not bytes: the bytes per thing are the budget's.
//!
//! [`GpuRenderer`]: super::GpuRenderer

use glam::Vec3;

use crate::camera::Camera;
use crate::cubemap::bounds::PoolBound;
use crate::method::Method;
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;
use crate::vk::methods::technique::{Glossy, has_glossy_reflector};
use crate::vk::methods::{self, MethodSpec, Needs};
use crate::vk::options::{Fallback, ListSize, RenderOptions};
use crate::vk::passes::capture_lists;
use crate::vk::passes::cmo::CaptureContents;

/// What one frame of a scene, a camera and render options allocates (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct FramePlan {
    /// The GPU method; the reference, no GPU method, plans the shared frame buffers only.
    pub method: Method,
    /// Frame size in pixels: the per-pixel buffers and images.
    pub width: u32,
    pub height: u32,
    /// The CMO data and the stages that fill it.
    pub cmo: CmoPlan,
    /// The cone tracing of a glossy scene, where the method reads the pre-filtered chain
    /// ([`Glossy::reads_chain`]) and captures.
    pub cone: Option<ConePlan>,
    /// [`Fallback::Trace`]'s BVH passes and ray queue: where the method can leave a record
    /// unresolved ([`Method::can_leave_unresolved`]).
    pub fallback: bool,
    /// The reflector check's passes and ray queue: the option on, a method that has it
    /// ([`Method::has_reflector_check`]) and a scene with triangles to check
    /// ([`Scene::check_triangles`]).
    pub reflector_check: bool,
    /// `--bounces N`: the bounce passes exist for N != 1, their two ray queues for N >= 2.
    pub bounces: u32,
}

/// The CMOs of a frame: their data and the capture that fills it.
#[derive(Clone, Debug, PartialEq)]
pub struct CmoPlan {
    /// Number of CMOs ([`Scene::cmo_centres`]).
    pub count: u32,
    /// Texels per face side: the scene's, or 1 for the placeholder of a method without a
    /// capture.
    pub size: u32,
    /// What the method needs of the CMOs ([`MethodSpec::needs`]) as the frame allocates it:
    /// the contents gain the colour where the cone chain pre-filters it.
    pub needs: Needs,
    /// The method's own contents, before the cone's colour.
    pub method_contents: CaptureContents,
    /// The capture's normal targets and `cmo_normal` ([`Scene::captures_reflectors`]).
    pub self_reflections: bool,
    /// The capture pass; `None` where the method reads no CMO (the placeholder).
    pub capture: Option<CapturePlan>,
    /// Texels per face side of the cone pass's own CMOs under the `bounded` criterion (a glossy
    /// scene): the rasterised capture's distance and colour at the cube size, what the
    /// centre-sampled criterion's cone pass reads, whatever size the lists take
    /// (`--list-size`); `None` where the cone pass reads the method's CMOs.
    pub cone_size: Option<u32>,
}

/// The pass that fills the CMO data.
#[derive(Clone, Debug, PartialEq)]
pub enum CapturePlan {
    /// The rasterised capture, with its layered targets and its one-face depth target.
    Raster,
    /// `--criterion bounded`: the lists' capture, its node pool and job buffer at the bound
    /// of the scene's triangles, and the rasterised capture before it where the frame reads
    /// the colour (`colour`: a glossy scene's cone chain), into the cone pass's own CMOs
    /// ([`CmoPlan::cone_size`]).
    Lists {
        views: Vec<(Vec3, bool)>,
        capacity: PoolBound,
        colour: bool,
    },
    /// `--criterion bounded` with the lists built on the CPU and uploaded at creation
    /// ([`super::GpuRenderer::with_lists`]): no capture pass is kept; the colour, where read,
    /// is captured once by a rasterised capture that is not kept either.
    Uploaded { colour: bool },
}

/// The cone tracing of a glossy scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConePlan {
    /// The cube-map cone pass (`fragment`, `compute`: [`Glossy::ConeStage`]); ssr reads the
    /// chain in its own pass.
    pub stage: bool,
    /// The cone pass's own 2x2 pyramid, where the method builds none (compute).
    pub own_pyramid: bool,
}

/// What a plan reads of the scene: counts and flags. [`FramePlan::new`] takes them from the
/// scene; the estimate for bare sizes ([`crate::vk::budget::device_bytes`]) gives them, so that
/// it plans by the same rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneFacts {
    /// Number of CMOs ([`Scene::cmo_centres`]).
    pub cmos: u32,
    /// Texels per CMO face side.
    pub cube_size: u32,
    /// [`Scene::captures_reflectors`].
    pub self_reflections: bool,
    /// A glossy reflector ([`has_glossy_reflector`]).
    pub glossy: bool,
    /// Triangles for the reflector check ([`Scene::check_triangles`] not empty).
    pub check_triangles: bool,
}

impl FramePlan {
    /// The plan of a frame of `scene` seen by `camera` with `options`, `data` the scene as
    /// uploaded ([`GpuSceneData::new`] of `scene`): the one function that decides what a
    /// frame allocates.
    pub fn new(
        scene: &Scene,
        data: &GpuSceneData,
        camera: &Camera,
        options: &RenderOptions,
    ) -> Self {
        Self::sized(scene, data, (camera.width, camera.height), options)
    }

    /// [`FramePlan::new`] for a frame of `width` x `height` pixels.
    pub fn sized(
        scene: &Scene,
        data: &GpuSceneData,
        (width, height): (u32, u32),
        options: &RenderOptions,
    ) -> Self {
        let facts = SceneFacts {
            cmos: scene.cmo_centres().len() as u32,
            cube_size: scene.cmo.resolution,
            self_reflections: scene.captures_reflectors(),
            glossy: has_glossy_reflector(data),
            check_triangles: !scene.check_triangles(options.bounded()).is_empty(),
        };
        // The bounded capture's views, face size and pool bound, computed only where it runs;
        // `auto` takes the placement search's size where it judged with shorter lists.
        let lists = |choice| {
            let choice = match (choice, scene.cmo.lists) {
                (ListSize::Auto, Some(n)) => ListSize::Fixed(n),
                (c, _) => c,
            };
            let views = capture_lists::scene_views(scene);
            let (size, capacity) = capture_lists::list_size(data, &views, facts.cube_size, choice);
            (views, size, capacity)
        };
        Self::from_facts(&facts, (width, height), options, lists)
    }

    /// `options` with [`ListSize::Auto`] resolved to the lists' face size the plan takes
    /// ([`ListSize::Fixed`]), so that the plans after it (the memory estimate's, the renderer's)
    /// do not search the sizes again; `options` where no lists are planned.
    pub fn resolve_list_size(
        scene: &Scene,
        camera: &Camera,
        options: &RenderOptions,
    ) -> RenderOptions {
        if !options.bounded() || options.list_size != ListSize::Auto {
            return *options;
        }
        let plan = Self::of(scene, camera, options);
        RenderOptions {
            list_size: ListSize::Fixed(plan.cmo.size),
            ..*options
        }
    }

    /// [`FramePlan::new`] building the scene's upload itself.
    pub fn of(scene: &Scene, camera: &Camera, options: &RenderOptions) -> Self {
        Self::new(scene, &GpuSceneData::new(scene), camera, options)
    }

    /// The plan of a frame of `width` x `height` pixels with `options` on a scene of which
    /// only `facts` are known; `lists` gives the bounded capture's views, its face size for a
    /// [`ListSize`] (`capture_lists::list_size`) and the pool bound at it, where it runs.
    pub fn from_facts(
        facts: &SceneFacts,
        (width, height): (u32, u32),
        options: &RenderOptions,
        lists: impl FnOnce(ListSize) -> (Vec<(Vec3, bool)>, u32, PoolBound),
    ) -> Self {
        let spec = methods::spec(options.method);
        let fallback_kind = match options.fallback {
            Fallback::Trace => true,
            #[cfg(feature = "test-hooks")]
            Fallback::TraceFromTDone => true,
            Fallback::Flag | Fallback::Envmap | Fallback::Background => false,
        };
        let mut cone = spec.and_then(|s| cone_plan(s, facts.glossy, options));
        let cmo = CmoPlan::new(facts, spec, cone.is_some(), options, lists);
        if let Some(c) = cone.as_mut().filter(|_| cmo.cone_size.is_some()) {
            // The method's pyramid, if any, is over the lists' CMOs.
            c.own_pyramid = true;
        }
        FramePlan {
            method: options.method,
            width,
            height,
            cmo,
            cone,
            fallback: fallback_kind && options.method.can_leave_unresolved(),
            reflector_check: options.reflector_check
                && options.method.has_reflector_check()
                && facts.check_triangles,
            bounces: options.bounces,
        }
    }

    /// The plan with the bounded criterion's lists uploaded instead of captured
    /// ([`super::GpuRenderer::with_lists`]); unchanged for another capture.
    pub fn with_uploaded_lists(mut self) -> Self {
        if let Some(CapturePlan::Lists { colour, .. }) = self.cmo.capture {
            self.cmo.capture = Some(CapturePlan::Uploaded { colour });
        }
        self
    }

    /// Frame pixels.
    pub fn pixels(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }

    /// Whether the bounce passes exist (`--bounces N`, N != 1).
    pub fn bounce_passes(&self) -> bool {
        self.bounces != 1
    }

    /// Whether the bounce rounds' two ray queues exist (`--bounces N`, N >= 2).
    pub fn bounce_queues(&self) -> bool {
        self.bounces >= 2
    }
}

impl CmoPlan {
    /// `cone`: the frame pre-filters the CMO colour ([`FramePlan::cone`]).
    fn new(
        facts: &SceneFacts,
        spec: Option<&'static dyn MethodSpec>,
        cone: bool,
        options: &RenderOptions,
        lists: impl FnOnce(ListSize) -> (Vec<(Vec3, bool)>, u32, PoolBound),
    ) -> Self {
        let Some(spec) = spec else {
            // The reference: no CMO on the GPU.
            let needs = Needs {
                capture: false,
                contents: super::capture_contents(options.method, &options.trace),
                pyramid: false,
            };
            return CmoPlan {
                count: 0,
                size: 1,
                method_contents: needs.contents,
                needs,
                self_reflections: false,
                capture: None,
                cone_size: None,
            };
        };
        let mut needs = spec.needs(&options.trace);
        let method_contents = needs.contents;
        needs.contents.colour |= cone;
        let placeholder = CmoPlan {
            count: facts.cmos,
            size: 1,
            needs,
            method_contents,
            self_reflections: false,
            capture: None,
            cone_size: None,
        };
        if !needs.capture {
            return placeholder;
        }
        let mut cone_size = None;
        let (capture, size) = if options.bounded() {
            let colour = needs.contents.colour;
            let (views, size, capacity) = lists(options.list_size);
            // A glossy reflector's cone pass reads CMOs of its own, captured as the centre-sampled
            // criterion's at the cube size (distance and colour): the lists' size and `lo` do
            // not change it.
            if cone {
                cone_size = Some(facts.cube_size);
            }
            let plan = CapturePlan::Lists {
                views,
                capacity,
                colour,
            };
            (plan, size)
        } else {
            (CapturePlan::Raster, facts.cube_size)
        };
        CmoPlan {
            size,
            cone_size,
            self_reflections: facts.self_reflections,
            capture: Some(capture),
            ..placeholder
        }
    }

    /// Whether a rasterised capture is created (kept or, for uploaded lists, run once): its
    /// layered targets and one-face depth target exist while the renderer is created.
    pub fn raster_capture(&self) -> bool {
        match &self.capture {
            Some(CapturePlan::Raster) => true,
            Some(CapturePlan::Lists { colour, .. } | CapturePlan::Uploaded { colour }) => *colour,
            None => false,
        }
    }

    /// The bounded criterion's per-texel records (`lo` is the CMO distance): captured or
    /// uploaded.
    pub fn lists(&self) -> bool {
        matches!(
            self.capture,
            Some(CapturePlan::Lists { .. } | CapturePlan::Uploaded { .. })
        )
    }

    /// Texels of all faces of all CMOs at the planned size.
    pub fn texels(&self) -> u64 {
        u64::from(self.count) * 6 * u64::from(self.size) * u64::from(self.size)
    }
}

/// The cone tracing of a frame of `spec`'s method (`glossy`: the scene has a glossy
/// reflector): a method that reads the chain and captures.
fn cone_plan(spec: &dyn MethodSpec, glossy: bool, options: &RenderOptions) -> Option<ConePlan> {
    let needs = spec.needs(&options.trace);
    let kind = spec.glossy();
    (kind.reads_chain() && needs.capture && glossy).then_some(ConePlan {
        stage: kind == Glossy::ConeStage,
        own_pyramid: !needs.pyramid,
    })
}

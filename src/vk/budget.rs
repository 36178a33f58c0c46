//! GPU memory of a render, estimated before anything is allocated: the bytes of the frame plan
//! ([`FramePlan`], the one decision of what a frame allocates, which
//! [`super::frame::GpuRenderer::new`] reads too), the shared stages' sizes here, each method's
//! from its [`MethodSpec`](super::methods::MethodSpec). Pure arithmetic: no Vulkan call. The scene's own buffers are counted too ([`scene_bytes`]: vertices, indices and the
//! textures' texels, which one 8192^2 texture makes 256 MiB), and [`largest_items`] names what
//! takes the most, so that a refusal can say what to shrink. The BVHs and the rasterised
//! capture's per-face triangle lists (`passes::capture::face_triangles`) are per triangle and not
//! counted.

use super::frame::plan::{CapturePlan, FramePlan, SceneFacts};
use super::methods;
use super::options::{Fallback, RenderOptions};
use super::passes::bvh::BvhRay;
use super::passes::capture_lists;
use super::passes::cmo::CaptureContents;
use super::passes::records::PixelRecord;
use crate::camera::Camera;
use crate::cpu::options::TraceOptions;
use crate::cubemap::pyramid::mip_len;
use crate::method::Method;
use crate::scene::Scene;
use crate::scene::gpu_data::GpuSceneData;

/// Bytes per texel of one face of one CMO: f32 distances (`cmo_distance`), RGBA f32 colour
/// (`cmo_colour`), the capture pass's f32 distance target, and with self-reflections the
/// capture's normal target and `cmo_normal` (RGBA f32 each).
pub fn cmo_bytes_per_texel(self_reflections: bool) -> u64 {
    cmo_bytes_per_texel_with(self_reflections, CaptureContents::default())
}

/// [`cmo_bytes_per_texel`] for the chosen capture contents: the colour (16 B) only where
/// captured, and with triangle IDs the capture's u32 target and `CmoData`'s ID buffer (4 B
/// each). IDs without colour take 8 B less per texel than colour without IDs.
pub fn cmo_bytes_per_texel_with(self_reflections: bool, contents: CaptureContents) -> u64 {
    cmo_data_bytes_per_texel(self_reflections, contents)
        + raster_target_bytes_per_texel(self_reflections, contents)
}

/// Bytes per texel of the CMO data itself: the f32 distance, the RGBA f32 colour where
/// captured, the u32 triangle ID where captured, the RGBA f32 normal with self-reflections.
fn cmo_data_bytes_per_texel(self_reflections: bool, contents: CaptureContents) -> u64 {
    4 + if contents.colour { 16 } else { 0 }
        + if contents.triangle_ids { 4 } else { 0 }
        + if self_reflections { 16 } else { 0 }
}

/// Bytes per texel of the rasterised capture's layered targets (the colour is rendered into the
/// CMO data's image): the f32 distance, the u32 ID where captured, the RGBA f32 normal with
/// self-reflections. The bounded criterion's lists' capture has none of them.
fn raster_target_bytes_per_texel(self_reflections: bool, contents: CaptureContents) -> u64 {
    4 + if contents.triangle_ids { 4 } else { 0 } + if self_reflections { 16 } else { 0 }
}

/// Bytes per frame pixel: the pixel records, the frame colour (RGBA f32), the G-buffer (colour,
/// position, normal: RGBA f32 each; triangle ID u32; depth f32), the method's own
/// ([`MethodSpec::bytes_per_pixel`](super::methods::MethodSpec::bytes_per_pixel)), and the trace fallback's ray queue for every method that
/// can leave a pixel unresolved (counted whatever the fallback: an upper bound). The CWBVH
/// itself is per triangle, like the scene's buffers, and not counted. The reference allocates
/// no frame on the GPU but is counted as one without a method's own bytes.
pub fn frame_bytes_per_pixel(method: Method) -> u64 {
    let fallback_queue = if method.can_leave_unresolved() {
        size_of::<BvhRay>() as u64
    } else {
        0
    };
    shared_bytes_per_pixel(method) + fallback_queue
}

/// [`frame_bytes_per_pixel`] without the fallback's queue: the records, the frame colour, the
/// G-buffer and the method's own.
fn shared_bytes_per_pixel(method: Method) -> u64 {
    let records = size_of::<PixelRecord>() as u64;
    let gbuffer = 3 * 16 + 4 + 4;
    let own = methods::spec(method).map_or(0, |s| s.bytes_per_pixel());
    records + 16 + gbuffer + own
}

/// What a render allocates on the device, in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceBytes {
    /// Per-pixel buffers and images of the frame.
    pub frame: u64,
    /// CMO data (distances, colours, capture targets, pyramid or hierarchy).
    pub cmo: u64,
    /// The scene's buffers ([`scene_bytes`]; 0 from [`device_bytes`], which has no scene).
    pub scene: u64,
}

impl DeviceBytes {
    pub fn total(&self) -> u64 {
        self.frame + self.cmo + self.scene
    }
}

/// Bytes of one texture's texels on the device (RGBA8).
pub fn texture_bytes(texture: &crate::shading::Texture) -> u64 {
    4 * u64::from(texture.width) * u64::from(texture.height)
}

/// The scene's buffers on the device ([`crate::scene::gpu_data::GpuSceneData`]): one vertex
/// record per position, three indices per triangle, the textures' texels (one buffer for all of
/// them) and the small per-object and per-material tables.
pub fn scene_bytes(scene: &Scene) -> u64 {
    use crate::scene::gpu_data::{GpuMaterial, GpuObject, GpuTexture, GpuVertex};
    let parts = scene.meshes.iter().flat_map(|m| &m.parts);
    let (vertices, triangles) = parts.fold((0u64, 0u64), |(v, t), p| {
        (v + p.positions.len() as u64, t + p.triangles.len() as u64)
    });
    let objects = scene
        .meshes
        .iter()
        .map(|m| m.parts.len() as u64)
        .sum::<u64>();
    vertices * size_of::<GpuVertex>() as u64
        + triangles * 12
        + texel_buffer_bytes(scene)
        + objects * size_of::<GpuObject>() as u64
        + scene.materials.len() as u64 * size_of::<GpuMaterial>() as u64
        + scene.textures.len() as u64 * size_of::<GpuTexture>() as u64
}

/// The one buffer that holds every texture's texels (at least one texel: buffers cannot be
/// empty); the device binds it whole, so it must fit `maxStorageBufferRange`.
pub fn texel_buffer_bytes(scene: &Scene) -> u64 {
    scene.textures.iter().map(texture_bytes).sum::<u64>().max(4)
}

/// What the render's device memory goes to, largest first: each texture (`texture 'floor'
/// 8192x8192`), the CMO data, the frame's buffers and the scene's geometry, with their bytes
/// (parts of [`estimate`]); items under 1 KiB are left out.
pub fn largest_items(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
) -> Vec<(String, u64)> {
    estimate_with_items(scene, camera, options).1
}

/// [`estimate`] and [`largest_items`] of one frame plan (a plan of the bounded criterion bounds
/// its lists' pool over every triangle: planned once, not once each).
pub fn estimate_with_items(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
) -> (DeviceBytes, Vec<(String, u64)>) {
    let plan = FramePlan::of(scene, camera, options);
    let e = DeviceBytes {
        scene: scene_bytes(scene),
        ..plan_bytes(&plan)
    };
    let textures: u64 = scene.textures.iter().map(texture_bytes).sum();
    let mut items: Vec<(String, u64)> = scene
        .textures
        .iter()
        .map(|t| {
            (
                format!("texture '{}' {}x{}", t.name, t.width, t.height),
                texture_bytes(t),
            )
        })
        .collect();
    let triangles: usize = scene
        .meshes
        .iter()
        .flat_map(|m| &m.parts)
        .map(|p| p.triangles.len())
        .sum();
    let cmos = scene.cmo_centres().len();
    let cmo = if plan.cmo.lists() && plan.cmo.size != scene.cmo.resolution {
        format!(
            "CMO data ({cmos} CMOs, their lists of {}^2 texels per face: --list-size)",
            plan.cmo.size
        )
    } else {
        format!(
            "CMO data ({cmos} CMOs of {}^2 texels per face)",
            scene.cmo.resolution
        )
    };
    items.extend([
        (cmo, e.cmo),
        (
            format!(
                "frame buffers ({}x{}, --method {})",
                camera.width, camera.height, options.method
            ),
            e.frame,
        ),
        (
            format!("scene geometry ({triangles} triangles)"),
            e.scene.saturating_sub(textures),
        ),
    ]);
    items.retain(|(_, b)| *b >= 1024);
    items.sort_by_key(|item| std::cmp::Reverse(item.1));
    (e, items)
}

/// The device memory of one render of `width` x `height` pixels with `cmos` CMOs of
/// `cube_size` texels per face side, capturing what the method needs
/// ([`MethodSpec::needs`](super::methods::MethodSpec::needs)) with the tracer options `trace`: the bytes of the frame plan
/// ([`FramePlan::from_facts`]) of a scene without glossy reflectors or triangles to check, one
/// bounce, and the trace fallback's queue for every method that can leave a pixel unresolved
/// (whatever the fallback: an upper bound). With the `bounded` criterion it counts the lists'
/// records but not their pool (see [`lists_bytes`]). The reference, which allocates no CMO on the
/// GPU, counts none.
pub fn device_bytes(
    width: u32,
    height: u32,
    method: Method,
    cmos: u32,
    cube_size: u32,
    self_reflections: bool,
    trace: &TraceOptions,
) -> DeviceBytes {
    let facts = SceneFacts {
        cmos,
        cube_size,
        self_reflections,
        glossy: false,
        check_triangles: false,
    };
    let options = RenderOptions {
        method,
        trace: *trace,
        fallback: Fallback::Trace,
        bounces: 1,
        ..RenderOptions::default()
    };
    // The lists at the cube size (an upper bound), without their pool.
    let no_pool = |_| (Vec::new(), cube_size, Default::default());
    plan_bytes(&FramePlan::from_facts(
        &facts,
        (width, height),
        &options,
        no_pool,
    ))
}

/// Bytes of the `bounded` criterion's lists ([`super::passes::lists`]) for `cmos` CMOs of
/// `cube_size` texels per face side with a node pool of `pool_capacity` nodes: 16 B per texel
/// record and 16 B per node, each a u32 word in four bindings (so each binding takes 4 B per
/// texel or node against `maxStorageBufferRange`, [`super::passes::lists::check_range`]; `lo`
/// is the CMO distance, counted with the CMO data). The pool's
/// capacity comes from the capture (the sum over triangles and faces of the texels each may
/// touch), which [`device_bytes`] does not know: it counts the records only
/// (`pool_capacity` 0); [`estimate`], which has the scene, adds the pool
/// ([`list_capture_bytes`]).
pub fn lists_bytes(cmos: u32, cube_size: u32, pool_capacity: u64) -> u64 {
    super::passes::lists::lists_bytes(cmos, cube_size, pool_capacity)
}

/// The device bytes of a frame plan, without the scene's buffers (`scene` 0; [`estimate`] adds
/// them): the frame's per-pixel buffers and queues, and the CMOs with the stages that fill and
/// pre-filter them.
pub fn plan_bytes(plan: &FramePlan) -> DeviceBytes {
    let (width, height) = (plan.width, plan.height);
    let fallback_queue = if plan.fallback {
        plan.pixels() * size_of::<BvhRay>() as u64
    } else {
        0
    };
    DeviceBytes {
        frame: plan.pixels() * shared_bytes_per_pixel(plan.method)
            + fallback_queue
            + bounce_bytes(width, height, plan.bounces)
            + reflector_check_bytes(width, height, plan.reflector_check),
        cmo: plan_cmo_bytes(plan),
        scene: 0,
    }
}

/// The CMO bytes of a plan: without a capture, the one-texel placeholder (distance, triangle ID
/// and a colour texel per face); with one, the data, the rasterised capture's targets where it
/// is created (its depth target one face at a time), the pyramid where the method needs one,
/// the method's own per-CMO data, the `bounded` criterion's lists and their capture
/// ([`list_capture_bytes_of`]), and the cone's chain and pyramid ([`cone_bytes_of`], less the
/// colour, counted with the data).
fn plan_cmo_bytes(plan: &FramePlan) -> u64 {
    let Some(spec) = methods::spec(plan.method) else {
        return 0;
    };
    let cmo = &plan.cmo;
    if cmo.capture.is_none() {
        return u64::from(cmo.count) * 6 * (4 + 4 + 16);
    }
    let (count, size) = (cmo.count, cmo.size);
    let face = u64::from(size) * u64::from(size);
    let contents = cmo.needs.contents;
    let raster = if cmo.raster_capture() && cmo.cone_size.is_none() {
        cmo.texels() * raster_target_bytes_per_texel(cmo.self_reflections, contents) + face * 4
    } else {
        0
    };
    // [min, max] f32 pairs per cell.
    let pyramid = if cmo.needs.pyramid {
        u64::from(count) * mip_len(size) as u64 * 8
    } else {
        0
    };
    // The records, and the gaps: a word per texel, and per cell of their pyramid where the
    // method builds one.
    let lists = if cmo.lists() {
        let gap_cells = cmo.texels() + pyramid / 8;
        lists_bytes(count, size, 0) + gap_cells * 4 + spec.cmo_list_bytes(count, size)
    } else {
        0
    };
    cmo.texels() * cmo_data_bytes_per_texel(cmo.self_reflections, contents)
        + raster
        + pyramid
        + spec.cmo_bytes(count, size)
        + lists
        + list_capture_bytes_of(plan)
        + cone_chain_bytes(plan)
        + cone_cmo_bytes(plan)
}

/// The cone pass's own CMOs, where the plan has them ([`super::frame::plan::CmoPlan::cone_size`]):
/// their data (distance, colour) and their rasterised capture's targets.
fn cone_cmo_bytes(plan: &FramePlan) -> u64 {
    let cmo = &plan.cmo;
    cmo.cone_size.map_or(0, |n| {
        let face = u64::from(n) * u64::from(n);
        let texels = u64::from(cmo.count) * 6 * face;
        let colour = CaptureContents {
            colour: true,
            triangle_ids: false,
        };
        texels
            * (cmo_data_bytes_per_texel(cmo.self_reflections, colour)
                + raster_target_bytes_per_texel(cmo.self_reflections, colour))
            + face * 4
    })
}

/// The device bytes `--bounces N` adds to a render of `width` x `height` pixels: for N >= 2,
/// two queues of one [`BvhRay`] per pixel (the rounds alternate between
/// them); nothing otherwise. The BVH is per triangle and not counted, as above.
pub fn bounce_bytes(width: u32, height: u32, bounces: u32) -> u64 {
    if bounces < 2 {
        return 0;
    }
    2 * u64::from(width) * u64::from(height) * size_of::<BvhRay>() as u64
}

/// The device bytes the reflector check ([`ReflectorCheck`](super::passes::bvh::ReflectorCheck)) adds to a render of
/// `width` x `height` pixels when it runs: one queue of one [`BvhRay`] per
/// pixel; nothing otherwise. Its BVH is per triangle and not counted, as above.
pub fn reflector_check_bytes(width: u32, height: u32, runs: bool) -> u64 {
    if !runs {
        return 0;
    }
    u64::from(width) * u64::from(height) * size_of::<BvhRay>() as u64
}

/// The device memory of one render of `scene` seen by `camera` with `options`: the bytes of its
/// frame plan ([`FramePlan::of`], [`plan_bytes`]: the CMOs, the frame's buffers, the bounce
/// queues, the reflector check's queue) and the scene's buffers ([`scene_bytes`]). The one
/// estimate that `render` and `bench` check before anything is allocated.
pub fn estimate(scene: &Scene, camera: &Camera, options: &RenderOptions) -> DeviceBytes {
    DeviceBytes {
        scene: scene_bytes(scene),
        ..plan_bytes(&FramePlan::of(scene, camera, options))
    }
}

/// What cone tracing adds for a glossy scene, as [`super::frame::GpuRenderer::new`] allocates it
/// ([`cone_bytes_of`] of the scene's plan).
pub fn cone_bytes(scene: &Scene, options: &RenderOptions) -> u64 {
    cone_bytes_of(&FramePlan::sized(
        scene,
        &GpuSceneData::new(scene),
        (0, 0),
        options,
    ))
}

/// What cone tracing adds to a plan ([`FramePlan::cone`]: a method that reads the pre-filtered
/// chain, [`super::methods::MethodSpec::glossy`]: `fragment`, `compute`, `ssr`, on a glossy
/// scene): the chain (`mip_len(N)` RGBA f32 per CMO), the CMO colour where the method itself
/// captures none, and for the cube-map cone pass ([`super::passes::cone`]: `fragment`,
/// `compute`) the 2x2 pyramid where the method builds none (compute), or the pass's own CMOs
/// where it has them (the `bounded` lists at a size of their own); 0 otherwise. ssr's
/// screen-space chains are in neither (its `bytes_per_pixel`).
pub fn cone_bytes_of(plan: &FramePlan) -> u64 {
    let colour = if plan.cone.is_some() && !plan.cmo.method_contents.colour {
        plan.cmo.texels() * 16
    } else {
        0
    };
    cone_chain_bytes(plan) + colour + cone_cmo_bytes(plan)
}

/// The cone's chain and own pyramid in a plan ([`cone_bytes_of`] without the CMO colour, which
/// the CMO data counts).
fn cone_chain_bytes(plan: &FramePlan) -> u64 {
    let Some(cone) = plan.cone else {
        return 0;
    };
    let size = plan.cmo.cone_size.unwrap_or(plan.cmo.size);
    let cells = u64::from(plan.cmo.count) * mip_len(size) as u64;
    let pyramid = if cone.stage && cone.own_pyramid {
        cells * 8
    } else {
        0
    };
    cells * 16 + pyramid
}

/// What the `bounded` criterion's capture adds to [`device_bytes`] for `scene` (which knows
/// the triangles): [`list_capture_bytes_of`] of the scene's plan.
pub fn list_capture_bytes(scene: &Scene, options: &RenderOptions) -> u64 {
    let data = GpuSceneData::new(scene);
    list_capture_bytes_of(&FramePlan::sized(scene, &data, (0, 0), options))
}

/// What the `bounded` criterion's capture adds to a plan: the node pool at the capacity the
/// frame allocates (the CPU bound of [`capture_lists::capacity`], the texels each triangle can
/// touch), its job buffer and clip queue, and the per-texel heads and overflow words; 0 for other criteria,
/// methods that run no capture, and lists uploaded instead of captured.
pub fn list_capture_bytes_of(plan: &FramePlan) -> u64 {
    let Some(CapturePlan::Lists {
        views, capacity, ..
    }) = &plan.cmo.capture
    else {
        return 0;
    };
    let size = plan.cmo.size;
    let texels = views.len() as u64 * 6 * u64::from(size) * u64::from(size);
    lists_bytes(0, size, capacity.nodes)
        + capacity.jobs * size_of::<capture_lists::ListsJob>() as u64
        + capture_lists::clip_queue_bytes(*capacity)
        + texels * 8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default render options with the centre criterion (the default is bounded).
    fn centre_options() -> RenderOptions {
        RenderOptions {
            trace: TraceOptions::centre(),
            ..RenderOptions::default()
        }
    }
    use crate::vk::options::{AUTO_LIST_LENGTH, AUTO_LIST_MIN, ListSize};

    /// A texture counts with its texels and is named first when it is the largest item.
    #[test]
    fn textures_count_and_are_named() {
        let mut scene = crate::scene::builtin::by_name("default").unwrap();
        let mut camera = scene.cameras[0].clone();
        (camera.width, camera.height) = (64, 48);
        let options = RenderOptions {
            method: Method::Compute,
            ..RenderOptions::default()
        };
        let before = estimate(&scene, &camera, &options);
        assert!(before.scene > 0, "{before:?}");
        let big = crate::shading::Texture {
            name: "huge".into(),
            width: 8192,
            height: 8192,
            rgba8: Vec::new(),
        };
        scene.textures.push(big);
        let after = estimate(&scene, &camera, &options);
        assert!(after.total() - before.total() >= 256 << 20, "{after:?}");
        let items = largest_items(&scene, &camera, &options);
        assert_eq!(items[0], ("texture 'huge' 8192x8192".into(), 256 << 20));
        // The estimate planned with the items is the estimate; negative: the one before.
        let (with_items, _) = estimate_with_items(&scene, &camera, &options);
        assert_eq!(with_items, after);
        assert_ne!(with_items, before);
        // Negative: without the texture, the largest item is something else.
        scene.textures.pop();
        let items = largest_items(&scene, &camera, &options);
        assert!(!items[0].0.contains("huge"), "{items:?}");
    }

    #[test]
    fn bounce_queues_only_past_one_bounce() {
        assert_eq!(bounce_bytes(160, 120, 0), 0);
        assert_eq!(bounce_bytes(160, 120, 1), 0);
        assert_eq!(bounce_bytes(160, 120, 2), 2 * 160 * 120 * 48);
        assert_eq!(bounce_bytes(160, 120, 16), bounce_bytes(160, 120, 2));
    }

    #[test]
    fn triangle_ids_replace_colour_at_less_memory() {
        let with = |colour, triangle_ids| CaptureContents {
            colour,
            triangle_ids,
        };
        for s in [false, true] {
            let colour = cmo_bytes_per_texel_with(s, with(true, false));
            let default = "the default contents are the colour without IDs";
            assert_eq!(colour, cmo_bytes_per_texel(s), "{default}");
            assert_eq!(cmo_bytes_per_texel_with(s, with(false, true)) + 8, colour);
            assert_eq!(cmo_bytes_per_texel_with(s, with(true, true)), colour + 8);
        }
    }

    #[test]
    fn sizes_grow_with_what_they_depend_on() {
        let exact = TraceOptions::centre();
        let base = device_bytes(160, 120, Method::Fragment, 1, 256, false, &exact);
        // 6 * 256^2 texels of 16 bytes (distance and ID, each in the CMO and the capture's
        // target), plus the pyramid: about 6.3 MiB + 2.x MiB.
        assert!(base.cmo > 6 * 256 * 256 * 16, "{base:?}");
        assert!(base.cmo < 6 * 256 * 256 * 24, "{base:?}");
        assert!(base.frame >= 160 * 120 * (96 + 16 + 52), "{base:?}");
        // Negative: each input changes the estimate the way it should.
        let twice = device_bytes(160, 120, Method::Fragment, 2, 256, false, &exact);
        assert!(twice.cmo > 2 * base.cmo - 6 * 256 * 256);
        let big = device_bytes(320, 240, Method::Fragment, 1, 256, false, &exact);
        assert_eq!(big.frame, 4 * base.frame);
        let selfr = device_bytes(160, 120, Method::Fragment, 1, 256, true, &exact);
        assert!(selfr.cmo > base.cmo);
        let compute = device_bytes(160, 120, Method::Compute, 1, 256, false, &exact);
        assert!(compute.frame > base.frame);
        let envmap = device_bytes(160, 120, Method::Envmap, 1, 256, false, &exact);
        let threshold = TraceOptions {
            criterion: crate::cpu::options::TraceCriterion::Threshold,
            ..exact
        };
        let approx = device_bytes(160, 120, Method::Fragment, 1, 256, false, &threshold);
        assert!(envmap.cmo < approx.cmo && base.cmo < approx.cmo);
        assert_eq!(approx.cmo - base.cmo, 6 * 256 * 256 * 16, "the colour");
        let bounded = TraceOptions {
            criterion: crate::cpu::options::TraceCriterion::Bounded,
            ..exact
        };
        // The lists' records (16 B per texel) and gaps (4 B per texel, and per cell of the
        // method's hierarchy of them) replace the rasterised capture's targets (the f32
        // distance and u32 ID per texel, the depth of one face), which the lists' capture does
        // not create.
        let texels = 2 * 6 * 256 * 256;
        let mip = 2 * mip_len(256) as u64 * 4;
        let hier = 2 * crate::cubemap::pyramid::hier32_len(256) as u64 * 4;
        for (m, gap_levels) in [(Method::Fragment, mip), (Method::Compute, hier)] {
            let b = device_bytes(160, 120, m, 2, 256, false, &bounded);
            let e = device_bytes(160, 120, m, 2, 256, false, &exact);
            assert_eq!(
                b.cmo - e.cmo,
                texels * 20 + gap_levels - (texels * 8 + 256 * 256 * 4),
                "{m}: the lists' records and gaps for the raster targets"
            );
        }
    }

    #[test]
    fn the_bounded_estimate_counts_the_node_pool() {
        let scene = crate::scene::builtin::by_name("default").unwrap();
        let mut camera = scene.cameras[0].clone();
        (camera.width, camera.height) = (64, 48);
        let exact = RenderOptions {
            method: Method::Compute,
            trace: TraceOptions::centre(),
            ..RenderOptions::default()
        };
        // The lists at the cube size, where the pool below is bounded.
        let bounded = RenderOptions {
            trace: TraceOptions {
                criterion: crate::cpu::options::TraceCriterion::Bounded,
                ..TraceOptions::default()
            },
            list_size: ListSize::Cube,
            ..exact
        };
        let views = capture_lists::scene_views(&scene);
        let cap = capture_lists::capacity(&GpuSceneData::new(&scene), &views, scene.cmo.resolution);
        assert!(cap.nodes > 0, "{cap:?}");
        let pool = list_capture_bytes(&scene, &bounded);
        assert!(pool >= cap.nodes * 16, "{pool} < {} nodes", cap.nodes);
        let grown = estimate(&scene, &camera, &bounded).total();
        assert!(grown >= estimate(&scene, &camera, &exact).total() + pool);
        // Negative: the centre criterion has no pool, nor does a method without a capture.
        assert_eq!(list_capture_bytes(&scene, &exact), 0);
        let bvh = RenderOptions {
            method: Method::Bvh,
            ..bounded
        };
        assert_eq!(list_capture_bytes(&scene, &bvh), 0);
    }

    /// The bounded criterion creates a rasterised capture (and its targets) only where the
    /// frame reads the CMO colour, a glossy scene's cone chain: the plan says so and the
    /// estimate counts it only then.
    #[test]
    fn bounded_raster_targets_only_on_a_glossy_scene() {
        let bounded = RenderOptions {
            method: Method::Compute,
            trace: TraceOptions {
                criterion: crate::cpu::options::TraceCriterion::Bounded,
                ..TraceOptions::default()
            },
            ..RenderOptions::default()
        };
        let mut scene = crate::scene::builtin::by_name("sphere-room").unwrap();
        let mut camera = scene.cameras[0].clone();
        (camera.width, camera.height) = (64, 48);
        let plain = FramePlan::of(&scene, &camera, &bounded);
        assert!(
            !plain.cmo.raster_capture() && plain.cone.is_none(),
            "{plain:?}"
        );
        // The same plan with the colour capture: its targets, and nothing else, on top.
        let mut with = plain.clone();
        let Some(CapturePlan::Lists { colour, .. }) = &mut with.cmo.capture else {
            panic!("a bounded capture: {with:?}");
        };
        *colour = true;
        let size = u64::from(plain.cmo.size);
        let targets = plain.cmo.texels() * (4 + 4) + size * size * 4;
        assert_eq!(
            plan_bytes(&with).cmo,
            plan_bytes(&plain).cmo + targets,
            "the capture's f32 distance and u32 ID per texel, one face's depth"
        );
        scene.make_reflectors_glossy(64.0);
        let glossy = FramePlan::of(&scene, &camera, &bounded);
        assert!(
            glossy.cmo.raster_capture() && glossy.cone.is_some(),
            "{glossy:?}"
        );
        let e = estimate(&scene, &camera, &bounded);
        assert!(e.cmo >= plan_bytes(&plain).cmo + targets, "{e:?}");
        // Negative: the centre criterion's raster capture is no colour capture of the lists.
        let exact = FramePlan::of(&scene, &camera, &centre_options());
        assert!(
            exact.cmo.raster_capture() && !exact.cmo.lists(),
            "{exact:?}"
        );
    }

    /// `--list-size auto` takes the smallest face size from 32 whose pool bound holds at most
    /// 16 nodes per texel, below the cube size, or the placement search's size where it set
    /// one; the cube size where the frame reads the colour (a glossy scene), or where the user
    /// fixes it; the resolved options keep it.
    #[test]
    fn bounded_lists_take_the_smallest_short_size() {
        let bounded = |list_size| RenderOptions {
            method: Method::Compute,
            trace: TraceOptions {
                criterion: crate::cpu::options::TraceCriterion::Bounded,
                ..TraceOptions::default()
            },
            list_size,
            ..RenderOptions::default()
        };
        let mut scene = crate::scene::builtin::by_name("default").unwrap();
        let mut camera = scene.cameras[0].clone();
        (camera.width, camera.height) = (64, 48);
        let size = |scene: &Scene, choice| FramePlan::of(scene, &camera, &bounded(choice)).cmo.size;
        let cube = scene.cmo.resolution;
        assert_eq!(cube, 256);
        assert_eq!(size(&scene, ListSize::Auto), AUTO_LIST_MIN);
        assert_eq!(size(&scene, ListSize::Cube), cube);
        assert_eq!(size(&scene, ListSize::Fixed(48)), 48);
        let resolved = FramePlan::resolve_list_size(&scene, &camera, &bounded(ListSize::Auto));
        assert_eq!(resolved.list_size, ListSize::Fixed(AUTO_LIST_MIN));
        // Other criteria keep their options (and their cube size).
        let exact = centre_options();
        assert_eq!(FramePlan::resolve_list_size(&scene, &camera, &exact), exact);
        // The placement search's size replaces the rule's, and only the rule's.
        let mut placed = scene.clone();
        placed.cmo.lists = Some(64);
        assert_eq!(size(&placed, ListSize::Auto), 64);
        assert_eq!(size(&placed, ListSize::Cube), cube);
        assert_eq!(size(&placed, ListSize::Fixed(48)), 48);
        // The rule: at 32 the bound's mean list exceeds 16 once the walls and floor are split
        // 256 ways; the size taken is the first where it holds, above 32.
        let data = |s: &Scene| GpuSceneData::new(s);
        let mean = |s: &Scene, n: u32| {
            let views = capture_lists::scene_views(s);
            let b = capture_lists::capacity(&data(s), &views, n);
            b.nodes as f64 / (views.len() as f64 * 6.0 * f64::from(n * n))
        };
        assert!(mean(&scene, 32) <= AUTO_LIST_LENGTH as f64);
        let mut dense = scene.clone();
        crate::cpu::reflection_point::subdivide_non_reflectors(&mut dense, 4);
        let taken = size(&dense, ListSize::Auto);
        assert!(taken > AUTO_LIST_MIN && taken < cube, "{taken}");
        assert!(mean(&dense, taken / 2) > AUTO_LIST_LENGTH as f64);
        assert!(mean(&dense, taken) <= AUTO_LIST_LENGTH as f64);
        // A glossy scene's cone pass reads CMOs of its own at the cube size, and the estimate
        // counts them; the lists keep their size.
        let plain = estimate(&scene, &camera, &bounded(ListSize::Auto)).cmo;
        scene.make_reflectors_glossy(64.0);
        let glossy = FramePlan::of(&scene, &camera, &bounded(ListSize::Auto));
        assert_eq!(
            (glossy.cmo.size, glossy.cmo.cone_size),
            (AUTO_LIST_MIN, Some(cube))
        );
        let cone_cmo = u64::from(cube * cube) * 6 * glossy.cmo.count as u64 * (4 + 16 + 4);
        assert!(estimate(&scene, &camera, &bounded(ListSize::Auto)).cmo >= plain + cone_cmo);
        // Negative: the centre criterion's cone pass reads the method's own CMOs.
        let exact = FramePlan::of(&scene, &camera, &centre_options());
        assert_eq!(exact.cmo.cone_size, None);
    }

    /// The scene-less estimate is the bytes of a plan by the same rules: one bounce, the
    /// fallback queue where the method can leave a pixel unresolved, no reflector check (with
    /// the centre criterion: the bounded lists' size and pool depend on the scene).
    #[test]
    fn device_bytes_is_a_plan_of_the_same_rules() {
        let scene = crate::scene::builtin::by_name("default").unwrap();
        let mut camera = scene.cameras[0].clone();
        (camera.width, camera.height) = (32, 24);
        let options = RenderOptions {
            reflector_check: false,
            ..centre_options()
        };
        let cmos = scene.cmo_centres().len() as u32;
        let bare = device_bytes(
            32,
            24,
            options.method,
            cmos,
            scene.cmo.resolution,
            scene.captures_reflectors(),
            &options.trace,
        );
        let e = estimate(&scene, &camera, &options);
        assert_eq!((bare.frame, bare.cmo), (e.frame, e.cmo));
        // Negative: the reflector check's queue is in the scene's plan only.
        let checked = estimate(&scene, &camera, &centre_options());
        assert_eq!(checked.frame, e.frame + reflector_check_bytes(32, 24, true));
    }

    #[test]
    fn lists_take_16_bytes_per_texel_and_per_node() {
        assert_eq!(lists_bytes(1, 2, 0), 6 * 4 * 16);
        assert_eq!(lists_bytes(3, 2, 100) - lists_bytes(3, 2, 0), 1600);
        // Negative: more CMOs or a bigger face cost more.
        assert!(lists_bytes(2, 2, 0) > lists_bytes(1, 2, 0));
        assert!(lists_bytes(1, 3, 0) > lists_bytes(1, 2, 0));
    }
}

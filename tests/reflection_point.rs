//! `--method reflection-point` (Estalella et al. 2006): the GPU search against its CPU twin
//! (`cpu::reflection_point`) for every vertex of every built-in scene, and the method against
//! the exact reference: the same surface on the mirror pixels of `sphere-room` as its objects are
//! subdivided (the paper's claim for a convex closed reflector), the concave and mixed
//! reflectors' limitation, and the error per built-in scene.
//!
//! The twin reads what the GPU read: the reflector textures T_P and T_N and the search's
//! parameters, read back after the frame, and the scene's vertices.
mod common;
use common::render::{first_frame, sized_camera, unresolved_pixels};
use common::{finish_gpu, gpu_context};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::cpu::reflection_point::{
    RpOptions, RpVertex, SearchStats, SearchTextures, Status, subdivide_non_reflectors,
};
use cubetrace::metrics;
use cubetrace::reference::{self, Frame, Tracer};
use cubetrace::scene::gpu_data::GpuSceneData;
use cubetrace::scene::{Scene, builtin};
use cubetrace::vk::GpuContext;
use cubetrace::vk::backend::shaders::{REFLECTION_POINT_RASTER, REFLECTION_POINT_SEARCH};
use cubetrace::vk::frame::shown_objects;
use cubetrace::vk::frame::{Fallback, GpuFrame, GpuRenderer, RenderOptions};
use cubetrace::vk::methods::reflection_point::{RpCamera, RpParams};
use glam::Vec3;

const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;

struct Rendered {
    frame: GpuFrame,
    vertices: Vec<RpVertex>,
    textures: SearchTextures,
    camera: Camera,
}

fn render(ctx: &GpuContext, scene: &Scene, size: (u32, u32)) -> Rendered {
    render_with(ctx, scene, size, RpOptions::default())
}

fn render_with(ctx: &GpuContext, scene: &Scene, size: (u32, u32), rp: RpOptions) -> Rendered {
    let camera = sized_camera(scene, size);
    let options = RenderOptions {
        method: Method::ReflectionPoint,
        fallback: Fallback::Envmap,
        reflection_point: rp,
        ..RenderOptions::default()
    };
    let (frame, r) = first_frame(ctx, scene, &camera, options, &scene.name);
    let passes = r
        .reflection_point_passes()
        .expect("reflection-point passes");
    Rendered {
        vertices: passes.read_vertices(ctx).unwrap(),
        textures: passes.read_textures(ctx).unwrap(),
        frame,
        camera,
    }
}

/// Vertices where the GPU and the twin differ: status, texel and step counts must be equal;
/// the virtual vertex and the path length within `1e-4` relative (the GPU's `sqrt` and division
/// need not round as Rust's).
fn disagreements(gpu: &[RpVertex], cpu: &[RpVertex]) -> Vec<String> {
    assert_eq!(gpu.len(), cpu.len());
    let close = |a: Vec3, b: Vec3| (a - b).length() <= 1e-4 * (1.0 + a.length().max(b.length()));
    gpu.iter()
        .zip(cpu)
        .enumerate()
        .filter(|(_, (g, c))| {
            g.status != c.status
                || g.texel != c.texel
                || g.iterations != c.iterations
                || g.inverse_iterations != c.inverse_iterations
                || ((g.status == Status::Found as u32 || g.status == Status::Hidden as u32)
                    && (!close(Vec3::from_array(g.position), Vec3::from_array(c.position))
                        || (g.path - c.path).abs() > 1e-4 * (1.0 + c.path)))
        })
        .map(|(k, (g, c))| format!("vertex {k}: gpu {g:?} cpu {c:?}"))
        .collect()
}

#[test]
fn shared_structs_match_naga_layout() {
    cubetrace::check_layout!(
        RpParams,
        REFLECTION_POINT_SEARCH.struct_layout("RpParams").unwrap(),
        [
            view_proj,
            eye,
            max_iterations,
            start,
            width,
            height,
            vertex_count,
            index_count,
            pad1,
            pad2
        ]
    )
    .unwrap();
    for pass in [&REFLECTION_POINT_SEARCH, &REFLECTION_POINT_RASTER] {
        cubetrace::check_layout!(
            RpVertex,
            pass.struct_layout("RpVertex").unwrap(),
            [
                position,
                status,
                texel,
                iterations,
                inverse_iterations,
                path,
                pad0,
                pad1,
                pad2
            ]
        )
        .unwrap();
    }
    cubetrace::check_layout!(
        cubetrace::cpu::closure::ClosureVertex,
        REFLECTION_POINT_SEARCH
            .struct_layout("RpClosureVertex")
            .unwrap(),
        [position, object, normal, behind]
    )
    .unwrap();
    cubetrace::check_layout!(
        RpCamera,
        REFLECTION_POINT_RASTER.struct_layout("RpCamera").unwrap(),
        [view_proj, eye, near]
    )
    .unwrap();
}

#[test]
fn gpu_search_matches_cpu_twin_on_every_builtin_scene() {
    let ctx = gpu_context();
    for (name, _) in builtin::NAMES {
        let scene = builtin::by_name(name).unwrap();
        let r = render(&ctx, &scene, (WIDTH, HEIGHT));
        let data = GpuSceneData::new(&scene);
        let cpu = r.textures.search_all(&data);
        let bad = disagreements(&r.vertices, &cpu);
        let stats = SearchStats::with_outline(&r.vertices, &r.textures);
        eprintln!("{name}: {stats:?}");
        assert!(stats.searched > 50, "{name}: {stats:?}");
        assert!(
            bad.is_empty(),
            "{name}: {} of {} vertices differ, first: {:?}",
            bad.len(),
            cpu.len(),
            &bad[..bad.len().min(3)]
        );
        assert_eq!(r.frame.search, Some(SearchStats::of(&cpu)), "{name}");
    }
    finish_gpu(ctx);
}

#[test]
fn twin_comparison_detects_perturbed_inputs() {
    let ctx = gpu_context();
    let scene = builtin::by_name("sphere-room").unwrap();
    let r = render(&ctx, &scene, (WIDTH, HEIGHT));
    let data = GpuSceneData::new(&scene);
    assert!(disagreements(&r.vertices, &r.textures.search_all(&data)).is_empty());
    // The eye moved by 5 cm: other texels, other step counts.
    let mut moved = r.textures.clone();
    moved.eye += Vec3::new(0.05, 0.0, 0.0);
    let n = disagreements(&r.vertices, &moved.search_all(&data)).len();
    assert!(n > 50, "moved eye: {n} disagreements");
    // A lower cap.
    let mut capped = r.textures.clone();
    capped.max_iterations = 3;
    let n = disagreements(&r.vertices, &capped.search_all(&data)).len();
    assert!(n > 50, "lower cap: {n} disagreements");
    // One reflector texel's normal turned: the vertices whose search passed it differ.
    let mut turned = r.textures.clone();
    let k = r
        .vertices
        .iter()
        .find(|v| v.status == Status::Found as u32)
        .map(|v| (v.texel[1] as u32 * turned.width + v.texel[0] as u32) as usize)
        .unwrap();
    turned.normal[k] = -turned.normal[k];
    let n = disagreements(&r.vertices, &turned.search_all(&data)).len();
    assert!(n >= 1, "turned normal: {n} disagreements");
    finish_gpu(ctx);
}

/// [`metrics::same_object`] of a reflection-point frame: (pixels, share, interior pixels,
/// interior share).
fn same_surface(scene: &Scene, reference: &Frame, frame: &GpuFrame) -> (usize, f64, usize, f64) {
    let reflector: Vec<bool> = scene.world().objects.iter().map(|o| o.reflector).collect();
    let s = metrics::same_object(reference, &reflector, &shown_objects(frame));
    (s.pixels, s.share, s.interior_pixels, s.interior_share)
}

/// The paper's claim for a convex closed reflector, on `sphere-room` at 192x144: with the
/// objects subdivided 4 times (4^4 triangles each) and the search textures at 8x the frame, the
/// reflection shows the reference's surface on >= 98% of the mirror pixels that show a
/// non-reflector object. What keeps the rest from it, measured: every pixel is covered (no cap,
/// no unresolved pixel left); the wrong ones lie on an edge between two objects in the
/// reflection (the room's corners, the objects' outlines), mostly displaced by one pixel, and
/// over half of them within two pixels of the mirror's outline, where one pixel spans a wide
/// range of reflected directions. The reflection point is a texel, so the texture's resolution
/// bounds how well those edges sit: subdivided 3 times, 95.1% at scale 1, 96.4% at 2, 97.3% at
/// 4, 97.8% at 8; subdivided 4 times at scale 4, 97.4%. Unsubdivided, the room's walls (two
/// triangles each) reflect as straight-edged polygons (41%).
#[test]
fn sphere_room_same_surface_when_tessellated() {
    let ctx = gpu_context();
    let size = (2 * WIDTH, 2 * HEIGHT);
    let mut results = Vec::new();
    // (subdivision, search scale, iteration cap)
    let runs = [(0, 1, None), (3, 4, None), (4, 8, None), (4, 8, Some(256))];
    for (level, scale, cap) in runs {
        let mut scene = builtin::by_name("sphere-room").unwrap();
        subdivide_non_reflectors(&mut scene, level);
        let rp = RpOptions {
            search_scale: scale,
            max_iterations: cap,
            ..RpOptions::default()
        };
        let r = render_with(&ctx, &scene, size, rp);
        let reference = reference::render(&scene, &Tracer::new(&scene), &r.camera, 1);
        let (total, share, interior, interior_share) = same_surface(&scene, &reference, &r.frame);
        let stats = r.frame.search.unwrap();
        eprintln!(
            "sphere-room subdivided {level}, search scale {scale}, cap {cap:?}: {} triangles, same \
             surface on {:.2}% of {total} pixels, {:.2}% of {interior} interior ones; {} of {} \
             searches capped",
            scene.world().triangles.len(),
            100.0 * share,
            100.0 * interior_share,
            stats.capped,
            stats.searched,
        );
        // Negative: the same records shifted by 3 pixels to the right.
        let mut shifted = r.frame.clone();
        let w = size.0 as usize;
        for k in 0..shifted.records.len() {
            shifted.records[k] = r.frame.records[k - (k % w).min(3)];
        }
        let (_, shifted_share, _, shifted_interior) = same_surface(&scene, &reference, &shifted);
        assert!(
            level == 0
                || cap.is_some()
                || (shifted_share < share - 0.05 && shifted_interior < interior_share - 0.03),
            "shifted: {shifted_share} {shifted_interior}"
        );
        results.push((share, interior_share, stats.capped));
    }
    finish_gpu(ctx);
    // Lower bounds only: the unsubdivided share (41%, walls as straight-edged polygons) is
    // printed, not pinned, so a method that does better there passes.
    assert!(
        results[1].0 >= 0.97 && results[1].1 >= 0.98,
        "subdivided 3 times, scale 4: {:?}",
        results[1]
    );
    assert!(
        results[2].0 >= 0.98 && results[2].2 == 0,
        "subdivided 4 times, scale 8: {:?}",
        results[2]
    );
    // The former fixed cap of 256 steps gives up searches at scale 8 and loses pixels the
    // default cap (which follows the textures' size) keeps.
    assert!(
        results[3].2 > 1000 && results[3].0 < results[2].0,
        "cap 256 at scale 8: {:?}",
        results[3]
    );
}

/// Least `(share correct, PSNR dB)` per scene and subdivision level at 96x72, lower bounds
/// only (a method that does better passes): 80% of the measured share correct and the measured
/// PSNR less 1 dB (teapot level 2: see there). Measured on lavapipe (Mesa 22.3.6), levels 0 and 2: default 1.07%, 14.60 dB
/// and 2.55%, 15.33 dB; sphere-room 1.05%, 14.96 dB and 2.63%, 15.00 dB; teapot 0.78%, 12.81 dB
/// and 0.29%, 11.14 dB; torus 0%, 15.93 dB and 0.04%, 15.13 dB; bowl 0.51%, 13.66 dB and
/// 0.25%, 13.84 dB. The share correct is small because the metric's wrong surface allows two
/// CMO texel footprints and a reflection point is a search texel; `same object` (below) is
/// this method's measure.
fn rp_bounds(name: &str, level: u32) -> (f64, f64) {
    match (name, level) {
        ("default", 0) => (0.0085, 13.6),
        ("default", 2) => (0.020, 14.3),
        ("sphere-room", 0) => (0.0084, 13.9),
        ("sphere-room", 2) => (0.021, 14.0),
        ("teapot", 0) => (0.0062, 11.8),
        // Less 0.34 dB only: its reflection black measures 10.56 dB.
        ("teapot", 2) => (0.0023, 10.8),
        ("torus", 0) => (0.0, 14.9),
        ("torus", 2) => (0.0003, 14.1),
        ("bowl", 0) => (0.0040, 12.6),
        ("bowl", 2) => (0.0020, 12.8),
        other => panic!("no bounds for {other:?}"),
    }
}

/// The error against the reference on every built-in scene, unsubdivided and subdivided twice
/// (printed), held to per-scene lower bounds ([`rp_bounds`]). The concave and
/// mixed reflectors' limitation (a vertex with several reflection points gets one virtual
/// vertex, so the `bowl` and `torus` stay further from the reference than the convex
/// `sphere-room`) shows in their bounds, not in a pin that a better method would fail.
#[test]
fn error_against_the_reference_per_builtin_scene() {
    let ctx = gpu_context();
    let mut failures = Vec::new();
    for (name, _) in builtin::NAMES {
        for level in [0, 2] {
            let mut scene = builtin::by_name(name).unwrap();
            subdivide_non_reflectors(&mut scene, level);
            let r = render(&ctx, &scene, (WIDTH, HEIGHT));
            let reference = reference::render(&scene, &Tracer::new(&scene), &r.camera, 1);
            let traced = r.frame.traced();
            let report = metrics::compare(
                &reference,
                &traced,
                &r.frame.surface_position,
                &scene.cmo_centres(),
                scene.cmo.resolution,
            );
            let flip = cubetrace::bench::flip_mean(&reference, &traced);
            let (total, share, _, interior) = same_surface(&scene, &reference, &r.frame);
            let mirror = r.frame.mirror_pixels() as f64;
            let unresolved = unresolved_pixels(&r.frame) as f64 / mirror;
            let stats = r.frame.search.unwrap();
            eprintln!(
                "{name} subdivided {level}: unresolved {:.1}%, wrong surface {:.1}%, PSNR {:.2} dB, \
                 FLIP {flip:?}, same object {:.1}% of {total} ({:.1}% interior), steps mean {:.1} max {}, hidden {} of {}",
                100.0 * report.unresolved,
                100.0 * report.wrong_surface,
                report.psnr_db,
                100.0 * share,
                100.0 * interior,
                stats.mean_iterations,
                stats.max_iterations,
                stats.hidden,
                stats.searched
            );
            assert!((report.unresolved - unresolved).abs() < 0.02, "{name}");
            let least = rp_bounds(name, level);
            let got = common::quality(&report);
            eprintln!("{name} subdivided {level}: correct {:.2}%", 100.0 * got.0);
            if got.0 < least.0 || got.1 < least.1 {
                failures.push(format!("{name} {level}: {got:?} below {least:?}"));
            }
            // Negative: the reflection black falls below the PSNR bound.
            let dim = metrics::compare(
                &reference,
                &common::blacked(&traced),
                &r.frame.surface_position,
                &scene.cmo_centres(),
                scene.cmo.resolution,
            );
            eprintln!("{name} {level}: black PSNR {:.2} dB", dim.psnr_db);
            if dim.psnr_db >= least.1 {
                failures.push(format!("{name} {level}: black passes: {}", dim.psnr_db));
            }
            if level == 2 && (*name == "default" || *name == "sphere-room") {
                assert!(share > 0.85, "{name}: {share}");
            }
            // Negative: hit points moved by 0.5 m are wrong surfaces.
            let mut moved = traced.clone();
            for p in &mut moved.hit_position {
                *p += Vec3::splat(0.5);
            }
            let bad = metrics::compare(
                &reference,
                &moved,
                &r.frame.surface_position,
                &scene.cmo_centres(),
                scene.cmo.resolution,
            );
            assert!(
                bad.unresolved + bad.wrong_surface > 0.999,
                "{name}: {bad:?}"
            );
            if least.0 > 0.0 && common::quality(&bad).0 >= least.0 {
                failures.push(format!("{name} {level}: moved hit points pass: {bad:?}"));
            }
        }
    }
    finish_gpu(ctx);
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A search scale whose textures would exceed the largest image side is refused with a message
/// naming it, before anything is rendered; the same frame at a smaller scale renders.
#[test]
fn oversized_search_textures_are_refused() {
    let ctx = gpu_context();
    let scene = builtin::by_name("sphere-room").unwrap();
    let camera = sized_camera(&scene, (3000, 20));
    let options = |search_scale| RenderOptions {
        method: Method::ReflectionPoint,
        reflection_point: RpOptions {
            search_scale,
            ..RpOptions::default()
        },
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let err = GpuRenderer::new(&ctx, &scene, &camera, options(8))
        .err()
        .expect("scale 8 at 3000 pixels refused")
        .to_string();
    assert!(
        err.contains("search scale") && err.contains("24000"),
        "{err}"
    );
    assert!(GpuRenderer::new(&ctx, &scene, &camera, options(5)).is_ok());
    finish_gpu(ctx);
}

/// `cubetrace bench --scaling`'s tessellation curve (here its first three levels, on a small
/// frame): one point per scene and level, each against the reference, written to the JSON, the
/// Markdown and the two plots. The points must measure the subdivided scenes: on `sphere-room` the
/// uncovered share falls and the reference's object share rises to the level the tessellation
/// test finds, and above the coarse level's, which a curve that ignored the subdivision (or
/// measured another frame) would not show.
#[test]
fn tessellation_curve_in_the_scaling_report() {
    use cubetrace::bench::scaling::{self, ScalingConfig};
    let ctx = gpu_context();
    let out = tempfile::tempdir().expect("temp dir");
    let cfg = ScalingConfig {
        method: cubetrace::bench::MethodSpec::plain(cubetrace::bench::Method::Fragment),
        axes: Vec::new(),
        max_cube: 32,
        width: WIDTH,
        height: HEIGHT,
        frames: 1,
        warmup: 0,
        out: out.path().to_path_buf(),
        tessellation_series: vec![("sphere-room".into(), 1), ("bowl".into(), 1)],
        tessellation_levels: 2,
    };
    let report = scaling::run(&ctx, &cfg, &indicatif::ProgressBar::hidden()).expect("scaling");
    finish_gpu(ctx);
    let curve = &report.tessellation;
    assert_eq!(curve.len(), 6);
    let point = |scene: &str, level: u32| {
        curve
            .iter()
            .find(|p| p.scene == scene && p.subdivide == level)
            .unwrap()
    };
    for p in curve {
        eprintln!(
            "{} subdivided {}: {} triangles, unresolved {:.1}%, wrong surface {:.1}%, same object \
             {:.1}%, PSNR {:.2} dB, reflection_point_search {:.2} ms",
            p.scene,
            p.subdivide,
            p.triangles,
            100.0 * p.error.unresolved,
            100.0 * p.error.wrong_surface,
            100.0 * p.same_object.share,
            p.error.psnr_db,
            p.rp_search_ns.median * 1e-6
        );
        assert!(
            p.error.psnr_db.is_finite() && p.search.searched > 0,
            "{p:?}"
        );
        assert!(p.rp_search_ns.median > 0.0 && p.rp_raster_ns.median > 0.0);
    }
    // Each level splits the n non-reflector triangles into four: +3n, then +12n.
    for scene in ["sphere-room", "bowl"] {
        let t: Vec<usize> = (0..3).map(|l| point(scene, l).triangles).collect();
        assert!(
            t[1] > t[0] && t[2] - t[1] == 4 * (t[1] - t[0]),
            "{scene}: {t:?}"
        );
    }
    let (coarse, fine) = (point("sphere-room", 0), point("sphere-room", 2));
    // Subdividing is what resolves the sphere's reflection; the coarse level's error and the
    // bowl's (concave: one virtual vertex per vertex) are printed above, not pinned.
    assert!(fine.error.unresolved < 0.01 && fine.error.unresolved < coarse.error.unresolved);
    assert!(fine.same_object.share > 0.85 && fine.same_object.share > coarse.same_object.share);
    scaling::write(&report, out.path()).expect("write");
    let md = std::fs::read_to_string(out.path().join("scaling.md")).unwrap();
    assert!(md.contains("## Reflection-point: tessellation curve"));
    assert_eq!(md.matches("| sphere-room | 1 |").count(), 3, "{md}");
    let json = std::fs::read_to_string(out.path().join("scaling.json")).unwrap();
    assert!(json.contains("\"tessellation\"") && json.contains("\"same_object\""));
    for svg in ["scaling-tessellation.svg", "scaling-tessellation-psnr.svg"] {
        let doc = std::fs::read_to_string(out.path().join(svg)).unwrap();
        assert!(doc.contains("bowl x1"), "{svg}");
    }
}

/// `sphere-room` with the mirror sphere opened at both poles (the triangles of `rings` rings
/// removed at each), its axis turned towards the camera: the camera sees the inside through the
/// near hole and the room through both.
fn open_sphere_room(rings: u32) -> Scene {
    let mut scene = builtin::by_name("sphere-room").unwrap();
    let mesh = scene.meshes.iter_mut().find(|m| m.reflector).unwrap();
    let part = &mut mesh.parts[0];
    // `uv_sphere(1.0, 64, 32)`: ring r spans polar angles r and r + 1 (of 32) times pi.
    let ring = |t: &[u32; 3]| {
        let y = t.iter().map(|&i| part.positions[i as usize].y).sum::<f32>() / 3.0;
        (y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI * 32.0) as u32
    };
    let kept: Vec<[u32; 3]> = part
        .triangles
        .iter()
        .filter(|t| (rings..32 - rings).contains(&ring(t)))
        .copied()
        .collect();
    part.triangles = kept;
    // The eye (0, 1.8, 3.6) sees the centre (0, 1.2, 0) 9.46 degrees from above.
    mesh.transform.rotate_deg = Vec3::new(90.0 - 9.46, 0.0, 0.0);
    scene.name = "open-sphere-room".into();
    scene
}

/// The closed version in the search (the paper's open/closed pair). On a sphere opened at both
/// poles (its mirror outside), the caps enter the search textures with their own depth where the
/// camera sees through the holes, fewer searches stop on an outline, and the reflection shows the
/// reference's object more often; the mirror pixels stay the open reflector's. On the concave
/// `bowl` (its mirror inside) the cap goes behind and the cup covers it: the search textures are
/// exactly those of the open bowl.
#[test]
fn closed_version_in_the_search() {
    let ctx = gpu_context();
    let size = (2 * WIDTH, 2 * HEIGHT);
    // Texels where the open reflector shows and the closed textures differ from it.
    let changed = |a: &SearchTextures, b: &SearchTextures| {
        (0..a.position.len())
            .filter(|&k| a.position[k].w == 1.0)
            .filter(|&k| a.position[k] != b.position[k] || a.normal[k] != b.normal[k])
            .count()
    };
    let count = |t: &SearchTextures| t.position.iter().filter(|p| p.w == 1.0).count();
    let outline = |r: &Rendered| SearchStats::with_outline(&r.vertices, &r.textures).on_outline;
    let mut shares = Vec::new();
    for scene in [open_sphere_room(6), builtin::by_name("bowl").unwrap()] {
        let data = GpuSceneData::new(&scene);
        let closure = cubetrace::cpu::closure::closing_triangles(&data);
        let run = |close_reflectors| {
            let rp = RpOptions {
                close_reflectors,
                ..RpOptions::default()
            };
            render_with(&ctx, &scene, size, rp)
        };
        let (open, closed) = (run(false), run(true));
        assert_eq!(
            open.frame.mask, closed.frame.mask,
            "the stencil is the open reflector"
        );
        let reference = reference::render(&scene, &Tracer::new(&scene), &open.camera, 1);
        let (_, open_share, _, _) = same_surface(&scene, &reference, &open.frame);
        let (_, closed_share, _, _) = same_surface(&scene, &reference, &closed.frame);
        let added = count(&closed.textures) as i64 - count(&open.textures) as i64;
        let differ = changed(&open.textures, &closed.textures);
        eprintln!(
            "{}: {} closing triangles; {} reflector texels open, {added} added and {differ} \
             changed by the caps; same object {:.1}% open, {:.1}% closed; searches ending on the \
             outline {} open, {} closed",
            scene.name,
            closure.len() / 3,
            count(&open.textures),
            100.0 * open_share,
            100.0 * closed_share,
            outline(&open),
            outline(&closed)
        );
        // The twin searches the closed textures as the GPU did.
        let cpu = closed.textures.search_all(&data);
        assert!(disagreements(&closed.vertices, &cpu).is_empty());
        if scene.name == "bowl" {
            assert_eq!(closure.len(), 64 * 3);
            assert_eq!((added, differ), (0, 0));
            assert_eq!(closed.vertices, open.vertices);
            // Negative: one texel of the open reflector changed is seen.
            let mut moved = closed.textures.clone();
            let k = (0..moved.position.len())
                .find(|&k| open.textures.position[k].w == 1.0)
                .unwrap();
            moved.normal[k].x += 0.01;
            assert_eq!(changed(&open.textures, &moved), 1);
        } else {
            assert_eq!(closure.len(), 2 * 64 * 3, "two caps of 64 triangles");
            assert!(added > 500 && differ > 500, "{added} {differ}");
            assert!(outline(&closed) < outline(&open) / 4);
            assert!(closed_share > open_share + 0.03);
        }
        shares.push((scene.name.clone(), open_share, closed_share));
    }
    eprintln!("{shares:?}");
    finish_gpu(ctx);
}

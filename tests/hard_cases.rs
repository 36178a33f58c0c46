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
//!   (the footprint of [`cubetrace::metrics`]) of the CPU hit, or, failing that, when it names
//!   the same texel and surface ([`same_texel_surface`]), and a *wrong hit* otherwise (also
//!   when the CPU ray escapes). Why the second test: the per-texel model is exact only to the
//!   texel it resolves. On a surface seen at an angle `psi` from its normal a texel's patch lies
//!   up to `D tan(psi) / N` off the true surface radially (2.8 footprints at the continuity
//!   limit, 80 degrees), and a ray crossing it obliquely turns that into a longer 3-D offset
//!   (teapot: 0.074 m against a 0.072 m tolerance, in the reference's own texel). A hit on an
//!   occluder or on the surface behind it is still wrong: their distances differ by more than
//!   the continuous band plus its margin;
//! - `ESCAPED` is correct when the CPU ray escapes or hits farther than the scene's ray length,
//!   wrong otherwise;
//! - `UNRESOLVED` is always allowed (the method said it does not know).
//!
//! For the exact criterion in strict mode (`TraceOptions::strict`) every case asserts zero wrong
//! hits and a minimum share of correct ones ([`MIN_CORRECT`]: "unresolved" everywhere fails);
//! the default mode's wrong hits are counted where a case shows them. Judging on the same ray keeps
//! rasterisation differences at the mirror's silhouette (where the reflected direction of the
//! G-buffer and of the reference's primary ray differ most) out of the count.
mod common;
use common::{finish_gpu, gpu_context};

use cubetrace::cpu::options::TraceOptions;
use cubetrace::cpu::{TraceParams, continuous};
use cubetrace::cubemap::Texel;
use cubetrace::cubemap::face::{dir_to_texel, face_st_to_dir, neighbour_across, texel_centre_dir};
use cubetrace::reference::Tracer;
use cubetrace::scene::shapes::{cuboid, uv_sphere};
use cubetrace::scene::{
    CmoPlacement, Material, MeshInstance, Scene, SelfReflections, Transform, builtin,
};
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{
    Fallback, GpuFrame, GpuMethod, GpuRenderer, RECORD_ESCAPED, RECORD_HIT, RECORD_UNRESOLVED,
    RenderOptions, scene_ranges,
};
use glam::Vec3;

/// Texel footprints a hit may be off (as `metrics::WRONG_SURFACE_FOOTPRINTS`): the texel the hit
/// falls in plus one neighbour.
const TOL_FOOTPRINTS: f32 = cubetrace::metrics::WRONG_SURFACE_FOOTPRINTS;

/// Per-frame verdict counts over mirror pixels.
#[derive(Debug, Default, Clone, PartialEq)]
struct Verdicts {
    /// Pixel indices of the wrong results (for [`explain`]).
    wrong_pixels: Vec<usize>,
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
    render_keep(ctx, scene, size, trace).0
}

fn render_keep(
    ctx: &GpuContext,
    scene: &Scene,
    size: (u32, u32),
    trace: TraceOptions,
) -> (GpuFrame, GpuRenderer) {
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
            ..RenderOptions::default()
        },
    )
    .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
    let f = r
        .render(ctx)
        .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
    (f, r)
}

/// Judges every mirror pixel of `frame` on its own ray (see the module docs). `shift` moves
/// every GPU hit point (for the negative test).
fn judge(scene: &Scene, frame: &GpuFrame, shift: Vec3) -> Verdicts {
    assert!(!scene.captures_reflectors(), "the judge skips reflectors");
    let tracer = Tracer::new(scene);
    let centres = scene.cmo_centres();
    let texel = 2.0 / scene.cmo.resolution as f32;
    let camera = &scene.cameras[0];
    let (_, _, t_hi) = scene_ranges(scene, camera);
    let mut v = Verdicts::default();
    for (k, rec) in frame.records.iter().enumerate() {
        if frame.mask[k] == 0 {
            continue;
        }
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
                    v.wrong_escapes += 1;
                    v.wrong_pixels.push(k);
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
                        || same_texel_surface(
                            scene,
                            &tracer,
                            centres[rec.cmo as usize],
                            p,
                            h.position,
                        )
                });
                if ok {
                    v.hits_ok += 1
                } else {
                    v.wrong_hits += 1;
                    v.wrong_pixels.push(k);
                }
            }
            s => panic!("unknown record status {s}"),
        }
    }
    v
}

/// The texel-level criterion of the judge (module docs): as seen from the deciding CMO's centre
/// `c`, the GPU hit `p` lies in the texel of the reference hit `h` or in one of its four side
/// neighbours, and both `|p - c|` and `|h - c|` lie within the depth band of that texel: the
/// `[min, max]` of the distances sampled at its centre and at the centres of its side
/// neighbours that are continuous with it ([`continuous`], default `k`). The samples are
/// reference rays through texel centres, what the capture stores.
fn same_texel_surface(scene: &Scene, tracer: &Tracer, c: Vec3, p: Vec3, h: Vec3) -> bool {
    let n = scene.cmo.resolution;
    let sample = |t: Texel| {
        let dir = texel_centre_dir(t, n).normalize();
        tracer
            .nearest_where(c, dir, None, |tri| !tracer.is_reflector(tri))
            .map_or(f32::INFINITY, |hit| hit.t)
    };
    let t_ref = dir_to_texel(h - c, n);
    let t_p = dir_to_texel(p - c, n);
    let neighbours = [0, 1, 2, 3].map(|s| neighbour_across(t_ref, s, n));
    if t_p != t_ref && !neighbours.contains(&t_p) {
        return false;
    }
    let d_ref = sample(t_ref);
    let k = TraceParams::default().continuity_k;
    let (mut lo, mut hi) = (d_ref, d_ref);
    for nb in neighbours {
        let d = sample(nb);
        let chord =
            (texel_centre_dir(t_ref, n).normalize() - texel_centre_dir(nb, n).normalize()).length();
        if continuous(d, d_ref, chord, k) {
            lo = lo.min(d);
            hi = hi.max(d);
        }
    }
    // The samples bound the surface between texel centres only up to a kink inside the texel
    // (a concave corner lies beyond its neighbours' samples): one footprint of margin. A
    // silhouette's step is over k = 5.7 footprints, so the margin admits no other surface.
    let margin = d_ref * 2.0 / n as f32;
    let in_band = |x: Vec3| (lo - margin..=hi + margin).contains(&(x - c).length());
    in_band(p) && in_band(h)
}

/// Prints, for the first `max` wrong pixels of `v`, what decided them: the ray, the reference
/// hit, the GPU record, the deciding texel's distance and its four neighbours', and the true
/// distances (reference rays from the CMO centre) over a 5x5 grid inside the deciding texel.
fn explain(
    ctx: &GpuContext,
    scene: &Scene,
    frame: &GpuFrame,
    r: &GpuRenderer,
    v: &Verdicts,
    max: usize,
) {
    let tracer = Tracer::new(scene);
    let cubes = r.cmo().read_back(ctx).unwrap_or_else(|e| panic!("{e}"));
    for &k in v.wrong_pixels.iter().take(max) {
        let rec = &frame.records[k];
        let (o, d) = (Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
        let cpu = tracer.nearest_where(o, d, None, |tri| !tracer.is_reflector(tri));
        eprintln!(
            "pixel {k} ({}, {}): ray {o} + t {d}; reference {:?}",
            k as u32 % frame.width,
            k as u32 / frame.width,
            cpu.map(|h| (h.t, h.position))
        );
        eprintln!("  GPU {rec:?}");
        if rec.status != RECORD_HIT {
            continue;
        }
        let cube = &cubes[rec.cmo as usize];
        let n = cube.size;
        let tex = Texel {
            face: rec.face,
            x: rec.x,
            y: rec.y,
        };
        let c = cube.centre;
        let p = Vec3::from_array(rec.point);
        let neigh: Vec<f32> = (0..4)
            .map(|s| cube.distance_at(neighbour_across(tex, s, n)))
            .collect();
        eprintln!(
            "  texel {tex:?}: D {} (x-1, x+1, y-1, y+1: {neigh:?}); |p - c| {}; ref |h - c| {:?}",
            cube.distance_at(tex),
            (p - c).length(),
            cpu.map(|h| (h.position - c).length())
        );
        let mut grid = String::new();
        for j in 0..5 {
            for i in 0..5 {
                let s = (tex.x as f32 + (i as f32 + 0.5) / 5.0) / n as f32;
                let t = (tex.y as f32 + (j as f32 + 0.5) / 5.0) / n as f32;
                let dir = face_st_to_dir(tex.face, s, t).normalize();
                let h = tracer.nearest_where(c, dir, None, |tri| !tracer.is_reflector(tri));
                grid += &format!(" {:.4}", h.map_or(f32::INFINITY, |h| h.t));
            }
            grid += "\n";
        }
        eprint!("  true D over the texel (5x5, rows of increasing y):\n{grid}");
        // The ray's distance from the centre where it is in the deciding texel.
        eprintln!(
            "  ray r at t {}: {}; ray at the reference hit's direction",
            rec.t,
            (o + rec.t * d - c).length()
        );
    }
}

/// The exact criterion in strict mode (`TraceOptions::strict`): the mode that promises no
/// silent wrong hit, which every case here asserts. The default mode's wrong hits are counted
/// where a case shows them (grazing, thin slab, teapot and torus).
fn exact() -> TraceOptions {
    TraceOptions {
        strict: true,
        ..TraceOptions::default()
    }
}

/// The exact criterion as `cubetrace render` runs it by default.
fn exact_default() -> TraceOptions {
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

/// The least share of a case's mirror pixels judged correct (a hit or an escape the CPU
/// confirms) wherever a case asserts no wrong result: a tracer answering "unresolved" everywhere
/// has no wrong result and must still fail. Strict mode leaves undecided the rays that cross a
/// depth jump of the CMO inside a texel (silhouettes, thin objects) and those no CMO sees;
/// measured 0.898 (thin slab, 609 of 678) to 0.975 (mirror filling the frame) over the cases
/// below at their sizes, so 0.85 is about 5 points under the lowest.
const MIN_CORRECT: f64 = 0.85;

/// Grazing incidence: strict mode leaves the tile's 1 cm front side undecided by design (see
/// `grazing_incidence_on_the_mirror`), 144 of 768 pixels: measured 0.8125 correct.
const MIN_CORRECT_GRAZING: f64 = 0.75;

/// `Err` naming what failed when `v` has a wrong result, no mirror pixel, or under `min` of its
/// mirror pixels correct.
fn check_no_wrong(v: &Verdicts, min: f64) -> Result<(), String> {
    let correct = v.hits_ok + v.escapes_ok;
    if v.mirror == 0 {
        Err("no mirror pixels".into())
    } else if v.wrong() > 0 {
        Err(format!("{} silent wrong results", v.wrong()))
    } else if (correct as f64) < min * v.mirror as f64 {
        Err(format!(
            "only {correct} of {} mirror pixels correct (at least {min} required)",
            v.mirror
        ))
    } else {
        Ok(())
    }
}

fn assert_no_wrong(name: &str, v: &Verdicts, min: f64) {
    eprintln!("{name}: {v:?}");
    if let Err(e) = check_no_wrong(v, min) {
        panic!("{name}: {e}: {v:?}");
    }
}

#[test]
fn judge_catches_moved_hits() {
    // Negative test of the judge itself: the same frame with every hit moved by 0.5 m has wrong
    // hits; unmoved it has none.
    let ctx = gpu_context();
    let scene = builtin::sphere_room();
    let frame = render(&ctx, &scene, (48, 36), exact());
    let ok = judge(&scene, &frame, Vec3::ZERO);
    assert_no_wrong("sphere-room", &ok, MIN_CORRECT);
    let moved = judge(&scene, &frame, Vec3::new(0.0, 0.5, 0.0));
    assert!(moved.wrong_hits > ok.hits_ok / 2, "{moved:?}");
    assert!(check_no_wrong(&moved, MIN_CORRECT).is_err());
    // Negative test of the minimum share: the same frame answering "unresolved" everywhere has
    // no wrong result, and fails.
    let mut unresolved = frame;
    for r in &mut unresolved.records {
        r.status = RECORD_UNRESOLVED;
    }
    let none = judge(&scene, &unresolved, Vec3::ZERO);
    assert_eq!(
        (none.wrong(), none.unresolved),
        (0, none.mirror),
        "{none:?}"
    );
    let err = check_no_wrong(&none, MIN_CORRECT).expect_err("an all-unresolved frame passed");
    assert!(err.contains("correct"), "{err}");
    finish_gpu(ctx);
}

#[test]
fn exact_has_no_wrong_hits_in_the_builtin_scenes() {
    let ctx = gpu_context();
    for name in ["default", "sphere-room", "bowl"] {
        exact_scene_no_wrong(&ctx, name);
    }
    finish_gpu(ctx);
}

/// Diagnosis of the former findings here (64x48, self-reflections off; before the decisive
/// patch-hit rule of `cpu::classify` and the judge's texel criterion), per pixel:
/// - teapot (19, 24): a floor texel seen at about 75 degrees from its normal (D 4.670, its
///   y-neighbours 4.467 and 4.894): the patch hit lies 0.074 m along the ray past the true floor
///   (4.597, inside the same texel), 1.03 times the 2-footprint tolerance. Right texel, right
///   surface: a judge artefact, fixed by its texel criterion.
/// - teapot (41, 27): same texel as the reference hit, at the floor-wall corner: the true
///   distance (4.5018) lies 6 mm beyond the largest neighbour sample (4.4960), a kink inside
///   the texel; 0.080 m off in 3D. Judge artefact (the band's one-footprint margin).
/// - teapot (45, 24): a box top seen at 86 degrees: both y-neighbours are discontinuous
///   (4.101 beyond the edge, 1.796 nearer), the patch (2.0065) sticks out 3 mm above the box
///   top and the ray, descending at 2.8 degrees, hit it 0.064 m early. Tracer: undecided in strict mode.
/// - torus (47, 34): a texel at an object's silhouette (y-1 neighbour 4.000, the wall); the
///   object covers the texel but recedes to 1.81 at its y-1 edge, the ray passes in front of it
///   and on to the wall (5.33) yet crossed the patch at 1.777 in the silhouette quadrant.
///   Tracer: undecided in strict mode.
#[test]
fn exact_has_no_wrong_hits_in_the_teapot_and_torus() {
    let ctx = gpu_context();
    exact_scene_no_wrong(&ctx, "teapot");
    exact_scene_no_wrong(&ctx, "torus");
    finish_gpu(ctx);
}

fn exact_scene_no_wrong(ctx: &GpuContext, name: &str) {
    {
        let mut scene = builtin::by_name(name).expect("listed");
        // The judge compares against non-reflector geometry, as the capture sees it.
        scene.self_reflections = SelfReflections::Off;
        let (frame, r) = render_keep(ctx, &scene, (64, 48), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
        explain(ctx, &scene, &frame, &r, &v, 8);
        let default = judge(
            &scene,
            &render(ctx, &scene, (64, 48), exact_default()),
            Vec3::ZERO,
        );
        eprintln!("{name}: strict {v:?}; default mode {default:?}");
        assert_no_wrong(name, &v, MIN_CORRECT);
    }
}

#[test]
fn cube_sizes_1_2_3_32() {
    cube_sizes(&[1, 2, 3, 32]);
}

#[test]
fn cube_size_2048() {
    // Former bug: the colour capture (402 MB at N = 2048) was a storage buffer, over lavapipe's
    // maxStorageBufferRange (128 MiB). It is an image now; buffers over the limit (two CMOs at
    // 2048: 201 MB of distances) are refused with `VkError::Limit` when bound.
    cube_sizes(&[2048]);
}

/// The least share correct at cube sizes under 4: with verified hits, a hit needs the triangle
/// among the IDs of the deciding texel's 3x3 neighbourhood, and at N = 1 a face holds one ID
/// (six for the whole room), so most rays end unresolved rather than on a triangle they miss
/// (measured 75 of 170 at N = 1).
const MIN_CORRECT_TINY_CUBE: f64 = 0.4;

fn cube_sizes(sizes: &[u32]) {
    let ctx = gpu_context();
    for &n in sizes {
        let mut scene = builtin::sphere_room();
        scene.cmo.resolution = n;
        let frame = render(&ctx, &scene, (32, 24), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
        let min = if n < 4 {
            MIN_CORRECT_TINY_CUBE
        } else {
            MIN_CORRECT
        };
        assert_no_wrong(&format!("N = {n}"), &v, min);
    }
    finish_gpu(ctx);
}

#[test]
fn scenes_at_scale_1e_minus_3_and_1e4() {
    let ctx = gpu_context();
    let base = judge(
        &builtin::sphere_room(),
        &render(&ctx, &builtin::sphere_room(), (48, 36), exact()),
        Vec3::ZERO,
    );
    for s in [1e-3, 1e4] {
        let scene = scaled(builtin::sphere_room(), s);
        let frame = render(&ctx, &scene, (48, 36), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
        assert_no_wrong(&scene.name, &v, MIN_CORRECT);
        // The same picture: the same mirror pixels, and the unresolved count within 1% of the
        // mirror pixels of the unscaled scene's (f32 rounding moves a few boundary rays).
        assert_eq!(v.mirror, base.mirror, "{v:?} vs {base:?}");
        assert!(
            v.unresolved.abs_diff(base.unresolved) <= base.mirror / 100 + 1,
            "{v:?} vs {base:?}"
        );
    }
    finish_gpu(ctx);
}

#[test]
fn reflector_covering_the_whole_frame_and_none_of_it() {
    let ctx = gpu_context();
    // Camera 1.3 radii from the mirror sphere's centre, looking at it with a narrow field.
    let mut full = builtin::sphere_room();
    let c = Vec3::new(0.0, 1.2, 0.0);
    full.cameras[0].eye = c + Vec3::new(0.0, 0.0, 1.3);
    full.cameras[0].target = c;
    full.cameras[0].fov_y_deg = 30.0;
    let frame = render(&ctx, &full, (40, 30), exact());
    assert_eq!(frame.mirror_pixels(), 40 * 30, "the mirror fills the frame");
    assert_no_wrong("full", &judge(&full, &frame, Vec3::ZERO), MIN_CORRECT);
    // Looking away from the mirror: no mirror pixel, no record claims anything.
    let mut none = builtin::sphere_room();
    none.cameras[0].target = none.cameras[0].eye + Vec3::new(0.0, 0.0, 1.0);
    let frame = render(&ctx, &none, (40, 30), exact());
    assert_eq!(frame.mirror_pixels(), 0);
    assert!(frame.colour.iter().all(|c| c.is_finite()));
    finish_gpu(ctx);
}

#[test]
fn cmo_centre_on_the_reflector_surface_or_inside_an_object() {
    let ctx = gpu_context();
    let mirror_centre = Vec3::new(0.0, 1.2, 0.0);
    // On the sphere's surface, on the side facing the camera: as good as the usual centre.
    let mut scene = builtin::sphere_room();
    let centre = mirror_centre + Vec3::new(0.0, 0.0, 1.0);
    scene.cmo.placement = CmoPlacement::Explicit(vec![centre]);
    let v = judge(&scene, &render(&ctx, &scene, (48, 36), exact()), Vec3::ZERO);
    assert_no_wrong("on the reflector", &v, MIN_CORRECT);
    // Inside the orange box (centre (1.5, 0.3, 0.6), side 0.6) the CMO sees only the box's
    // inside, which no reflected ray reaches: the one right answer is "unresolved" everywhere
    // (no minimum share can hold; every pixel's verdict is asserted instead).
    scene.cmo.placement = CmoPlacement::Explicit(vec![Vec3::new(1.5, 0.3, 0.6)]);
    let v = judge(&scene, &render(&ctx, &scene, (48, 36), exact()), Vec3::ZERO);
    eprintln!("inside the orange box: {v:?}");
    assert!(v.mirror > 0 && v.unresolved == v.mirror, "{v:?}");
    finish_gpu(ctx);
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
fn objects_thinner_than_a_texel() {
    // Former finding (2 wrong hits of 678 for the 1 mm slab): both rays passed 1.8 and 1.9 mm
    // beside the slab's edge (z = 1.0018, 1.0019) through a texel whose centre sees the slab
    // (D 1.702 and 1.874) but whose x-1 neighbour sees the wall behind (5.313, 2.490): the patch
    // was hit in its silhouette quadrant, the reference goes on to the wall. The decisive rule of strict
    // mode (`cpu::classify`) leaves a hit in a quadrant with a discontinuous neighbour undecided.
    // At N = 64 a texel at 1.3 m from the centre is about 4 cm wide: 1 mm and 0.1 mm slabs.
    let ctx = gpu_context();
    for t in [1e-3, 1e-4] {
        let mut scene = with_slab(t);
        scene.cmo.resolution = 64;
        let (frame, r) = render_keep(&ctx, &scene, (64, 48), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
        explain(&ctx, &scene, &frame, &r, &v, 8);
        let default = judge(
            &scene,
            &render(&ctx, &scene, (64, 48), exact_default()),
            Vec3::ZERO,
        );
        eprintln!("slab {t}: default mode {default:?}");
        assert_no_wrong(&format!("slab {t}"), &v, MIN_CORRECT);
    }
    finish_gpu(ctx);
}

#[test]
fn degenerate_nan_and_zero_normals_in_the_mirror_mesh() {
    // A mirror sphere whose normals are partly NaN, zero or not unit: no NaN may reach the
    // image, and no pixel may claim a wrong hit.
    let ctx = gpu_context();
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
    assert_no_wrong("bad normals", &v, MIN_CORRECT);
    finish_gpu(ctx);
}

#[test]
fn grazing_incidence_on_the_mirror() {
    // Former finding (144 of 768 wrong hits): the wrong pixels were the tile's 1 cm high front
    // side (z = 2), whose reflected rays go down at 1.5 degrees onto the room floor (reference
    // hit 0.33 m away, |h - c| 2.384). The CMO (0.5 m up) sees the floor at 77 degrees from its
    // normal: one texel spans D 2.132..2.189 (centre 2.158, y-neighbours 2.093 and 2.227), so
    // its patch sticks up to 7 mm above the floor on its far half; the ray, 6 mm above the
    // floor there, hit it 0.23 m early (2 footprints: 0.037 m). The decisive rule needs the ray
    // to reach the quadrant's largest half-way distance (2.193) inside the texel: it does not,
    // so in strict mode these pixels are undecided (unresolved: one CMO), not wrong.
    // A mirror floor tile seen at 88 to 89.5 degrees from its normal: reflections almost
    // tangent to the mirror.
    let ctx = gpu_context();
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
    let (frame, r) = render_keep(&ctx, &scene, (48, 36), exact());
    let v = judge(&scene, &frame, Vec3::ZERO);
    explain(&ctx, &scene, &frame, &r, &v, 12);
    // Before verified hits, the default mode's patch hits on the tile's front side (see above)
    // were wrong (144 of 768 measured). Verified, they end on the triangle the ray meets or
    // unresolved: no wrong hit (measured 672 right, 96 unresolved).
    let default = judge(
        &scene,
        &render(&ctx, &scene, (48, 36), exact_default()),
        Vec3::ZERO,
    );
    eprintln!("grazing: strict {v:?}; default mode {default:?}");
    assert!(v.mirror > 100, "{v:?}");
    assert_no_wrong("grazing, default mode", &default, MIN_CORRECT_GRAZING);
    assert_no_wrong("grazing", &v, MIN_CORRECT_GRAZING);
    finish_gpu(ctx);
}

#[test]
fn silhouette_right_behind_the_ray_is_not_a_hit() {
    // A tall thin column in front of the far wall, seen by the CMO: reflected rays that pass
    // just beside it cross a depth jump (column -> wall) in the distance profile. The exact
    // criterion's continuity rule must classify those as "behind" or pass, never as hits on
    // the column; the judge counts any hit off the true surface.
    let ctx = gpu_context();
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
    assert_no_wrong(
        "near column",
        &judge(&scene, &frame, Vec3::ZERO),
        MIN_CORRECT,
    );
    finish_gpu(ctx);
}

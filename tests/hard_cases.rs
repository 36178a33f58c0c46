//! Hard cases for the whole GPU frame (`GpuRenderer`), scene by scene. The ray-level cases
//! (rays through or within 1e-6 of a CMO centre, along cube edges, through corners, crossing
//! four faces, parallel to face and cell planes, origins on boundaries) are in
//! `tests/tracer/cpu_trace.rs` (CPU) and `tests/tracer/gpu_twin.rs` (`special_rays`: the GPU
//! matches the CPU bit for bit on them); this file adds what only a frame shows.
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
//! Verified hits name their triangle, and a hit is also wrong when the ray does not meet that
//! triangle ([`meets`], f64) or meets it but the reference's triangle is another, met earlier
//! (not a tie on a shared edge or vertex).
//!
//! Every case runs on both tracers of the centre criterion (the fragment pass and the compute
//! kernel) and on each one's CPU twin over the captures read back from the GPU
//! ([`judge_paths`]) in the default mode, and on the fragment pass in strict mode
//! (`TraceOptions::strict`, `--strict`), and asserts zero wrong hits and a minimum share of
//! correct ones ([`MIN_CORRECT`]: "unresolved" everywhere fails) for each of the five runs.
//! Judging on the same ray keeps rasterisation differences at the mirror's silhouette (where the
//! reflected direction of the G-buffer and of the reference's primary ray differ most) out of
//! the count.
//!
//! # Strict mode with verified hits
//! Wrong hits over the whole suite, default -> strict, identical on the four runs of each case
//! (measured with strict mode on all four; the suite keeps one)
//! (mirror pixels; unresolved pixels default -> strict in brackets): none in either mode in every
//! case at cube size 4 or more (`default` 659 [3 -> 18], `sphere-room` 678 [16 -> 56], `bowl`
//! 698 [2 -> 14], `teapot` 463 [6 -> 40], `torus` 1020 [6 -> 64], N = 32 170 [7 -> 13], N =
//! 2048 170 [5 -> 12], scales 1e-3 and 1e4 382 [8 -> 22, 23], CMO on the reflector 382
//! [2 -> 19], the mirror filling the frame 1200 [0 -> 30], bad normals 382 [8 -> 24], grazing
//! 768 [96 -> 144], slabs of 1 and 0.1 mm 678 [37 -> 70], near column 1389 [44 -> 109]). At cube
//! sizes 1 to 3 both modes hit the floor behind the orange box, which no texel centre sees
//! (`cpu::verify`, "What can still be missed"): N = 1 3 -> 3, N = 2 5 -> 5, N = 3 5 -> 3. That
//! last is the one case where strict mode removes wrong hits
//! (`strict_mode_removes_unseen_occluder_hits_at_cube_size_3`), so it stays; everywhere else it
//! only adds unresolved pixels.
//!
//! This crate also holds, each in its module of `tests/hard_cases/`: `corpus` (the real-scene
//! corpus of `tests/scenes/` on every GPU method), `fuzz_inputs` (fixed-seed fuzzing of extreme
//! and malformed scene inputs through the binary, every method) and `start_rule` (a reflected
//! ray from a G-buffer point interpolated past a crease).
mod common;
#[path = "common/fuzz_cases.rs"]
mod fuzz_cases;

#[path = "hard_cases/corpus.rs"]
mod corpus;
#[path = "hard_cases/fuzz_inputs.rs"]
mod fuzz_inputs;
#[path = "hard_cases/start_rule.rs"]
mod start_rule;

use common::render::{first_frame, sized_camera};
use common::{finish_gpu, gpu_context, meets};

use common::hit_probe::{VerifyQuery, VerifyResult, verify_cpu, verify_gpu};
use cubetrace::Method;
use cubetrace::cpu::multi::{MultiStatus, Traversal, Verify, trace_cmos_verified};
use cubetrace::cpu::options::TraceOptions;
use cubetrace::cpu::verify::triangle_corners;
use cubetrace::cpu::{CmoTracer, TraceParams, continuous};
use cubetrace::cubemap::face::{dir_to_texel, face_st_to_dir, neighbour_across, texel_centre_dir};
use cubetrace::cubemap::{CubeMap, Texel};
use cubetrace::reference::Tracer;
use cubetrace::scene::gpu_data::GpuSceneData;
use cubetrace::scene::shapes::{cuboid, quad, uv_sphere};
use cubetrace::scene::{
    CmoPlacement, Material, MeshInstance, MeshPart, Scene, SelfReflections, Transform,
    WorldGeometry, builtin,
};
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{
    Fallback, GpuFrame, GpuRenderer, RECORD_ESCAPED, RECORD_HIT, RECORD_UNRESOLVED, RenderOptions,
    scene_ranges,
};
use cubetrace::vk::passes::scene_buffers::SceneBuffers;
use glam::{Vec2, Vec3};

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
    /// Hits whose point is off the reference hit (the point judge of the module docs).
    wrong_hits: usize,
    wrong_escapes: usize,
    /// Hits on no triangle, or on a triangle the ray does not meet ([`meets`]).
    off_triangle: usize,
    /// Hits on a triangle the ray meets that is not the reference's, nor met at the same `t`
    /// (a tie on a shared edge or vertex).
    other_triangle: usize,
}

impl Verdicts {
    /// Mirror pixels with any wrong verdict (each counted once).
    fn wrong(&self) -> usize {
        self.wrong_pixels.len()
    }
}

/// The fragment path's frame.
fn render(ctx: &GpuContext, scene: &Scene, size: (u32, u32), trace: TraceOptions) -> GpuFrame {
    render_with(ctx, scene, size, trace, Method::Fragment).0
}

fn render_with(
    ctx: &GpuContext,
    scene: &Scene,
    size: (u32, u32),
    trace: TraceOptions,
    method: Method,
) -> (GpuFrame, GpuRenderer) {
    let options = RenderOptions {
        method,
        trace,
        fallback: Fallback::Flag,
        // The judge follows the cubemap trace's model (the non-reflector triangles); the
        // reflector check, which adds hits on the reflectors, is judged against the whole
        // reference in tests/frame/reflector_check.rs.
        reflector_check: false,
        ..RenderOptions::default()
    };
    first_frame(ctx, scene, &sized_camera(scene, size), options, &scene.name)
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
                let met = meets(&tracer, o, d, rec.triangle);
                let off = met.is_none();
                let other = match (cpu, met) {
                    (Some(h), Some(t)) => {
                        h.triangle != rec.triangle
                            && (t - f64::from(h.t)).abs() > 1e-5 * (1.0 + f64::from(h.t))
                    }
                    _ => false,
                };
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
                v.wrong_hits += usize::from(!ok);
                v.off_triangle += usize::from(off);
                v.other_triangle += usize::from(other);
                if ok && !off && !other {
                    v.hits_ok += 1
                } else {
                    v.wrong_pixels.push(k);
                }
            }
            s => panic!("unknown record status {s}"),
        }
    }
    v
}

/// The two tracers of the centre criterion whose hard cases this file runs.
const PATHS: [Method; 2] = [Method::Fragment, Method::Compute];

/// The CPU twin of `frame` (rendered by `r` with `method`): the same rays traced by
/// [`trace_cmos_verified`] over the captures read back from the GPU, with the traversal of the
/// method's twin (`Mip` for the fragment pass, `Alg3(8)` for the compute kernel); status, CMO,
/// point and triangle replaced in a copy of the frame.
fn twin_frame(
    ctx: &GpuContext,
    scene: &Scene,
    frame: &GpuFrame,
    r: &GpuRenderer,
    method: Method,
) -> GpuFrame {
    let cubes = r.cmo().read_back(ctx).unwrap_or_else(|e| panic!("{e}"));
    twin_frame_over(scene, frame, cubes, &r.options().trace, method)
}

/// [`twin_frame`] over the given captures.
fn twin_frame_over(
    scene: &Scene,
    frame: &GpuFrame,
    cubes: Vec<CubeMap>,
    opts: &TraceOptions,
    method: Method,
) -> GpuFrame {
    let cmos: Vec<CmoTracer> = cubes
        .into_iter()
        .map(|c| CmoTracer::new(c, opts.params()))
        .collect();
    let corners = triangle_corners(&scene.world());
    let mut camera = scene.cameras[0].clone();
    (camera.width, camera.height) = (frame.width, frame.height);
    let (_, _, t_hi) = scene_ranges(scene, &camera);
    let how = match method {
        Method::Compute => Traversal::Alg3(8),
        _ => Traversal::Mip,
    };
    let verify = Some(Verify {
        triangles: &corners,
    });
    let mut out = frame.clone();
    for (k, rec) in out.records.iter_mut().enumerate() {
        if frame.mask[k] == 0 {
            continue;
        }
        let (o, d) = (Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
        let m = trace_cmos_verified(&cmos, o, d, 0.0, t_hi, how, verify);
        rec.status = match m.status {
            MultiStatus::Hit => RECORD_HIT,
            MultiStatus::Escaped => RECORD_ESCAPED,
            MultiStatus::Unresolved => RECORD_UNRESOLVED,
        };
        rec.cmo = m.cmo;
        rec.point = m.point.to_array();
        rec.triangle = m.triangle;
        (rec.face, rec.x, rec.y) = (m.result.texel.face, m.result.texel.x, m.result.texel.y);
    }
    out
}

/// Judges `scene` at `size` on both tracers ([`PATHS`]), on the GPU and on each one's CPU twin,
/// with `trace`: one `(label, verdicts)` per run.
fn judge_paths(
    ctx: &GpuContext,
    scene: &Scene,
    size: (u32, u32),
    trace: TraceOptions,
) -> Vec<(String, Verdicts)> {
    judge_runs(ctx, scene, size, trace, &PATHS, true)
}

/// [`judge_paths`] on the given tracers, with or without their CPU twins.
fn judge_runs(
    ctx: &GpuContext,
    scene: &Scene,
    size: (u32, u32),
    trace: TraceOptions,
    paths: &[Method],
    twins: bool,
) -> Vec<(String, Verdicts)> {
    let mut out = Vec::new();
    for &method in paths {
        let (frame, r) = render_with(ctx, scene, size, trace, method);
        let gpu = judge(scene, &frame, Vec3::ZERO);
        explain(ctx, scene, &frame, &r, &gpu, 4);
        let m = cubetrace::vk::frame::pass_name(method);
        out.push((format!("{} {m} GPU", scene.name), gpu));
        if twins {
            let twin = judge(
                scene,
                &twin_frame(ctx, scene, &frame, &r, method),
                Vec3::ZERO,
            );
            out.push((format!("{} {m} CPU twin", scene.name), twin));
        }
    }
    out
}

/// Asserts [`check_no_wrong`] with `min` on both tracers and their CPU twins (default options)
/// and on the fragment path in strict mode, and prints the counts.
fn assert_no_wrong_anywhere(ctx: &GpuContext, scene: &Scene, size: (u32, u32), min: f64) {
    assert_no_wrong_anywhere_but_unseen(ctx, scene, size, min, 0);
}

fn assert_no_wrong_anywhere_but_unseen(
    ctx: &GpuContext,
    scene: &Scene,
    size: (u32, u32),
    min: f64,
    unseen: usize,
) {
    assert_no_wrong_in_both_modes(ctx, scene, size, [min, min], unseen);
}

/// The assertions of [`assert_no_wrong_anywhere`] with `unseen` hits behind an unseen occluder
/// allowed ([`check_no_wrong_but_unseen`]) and the minimum share correct given per mode
/// (`[default, strict]`).
fn assert_no_wrong_in_both_modes(
    ctx: &GpuContext,
    scene: &Scene,
    size: (u32, u32),
    [min, min_strict]: [f64; 2],
    unseen: usize,
) {
    let default = judge_paths(ctx, scene, size, exact());
    // Strict mode on the fragment path's GPU run only: it gave the same counts on all four runs
    // of every case (module docs), and its twins are checked in tests/fragment.rs.
    let strict = judge_runs(ctx, scene, size, strict(), &[Method::Fragment], false);
    for ((name, d), (_, s)) in default.iter().zip(&strict) {
        eprintln!(
            "{name}: default wrong {} (point {}, off {}, other {}) unresolved {} of {}; strict wrong {} (point {}, off {}, other {}) unresolved {}",
            d.wrong(),
            d.wrong_hits,
            d.off_triangle,
            d.other_triangle,
            d.unresolved,
            d.mirror,
            s.wrong(),
            s.wrong_hits,
            s.off_triangle,
            s.other_triangle,
            s.unresolved
        );
    }
    for (name, v) in &default {
        assert_no_wrong_but_unseen(name, v, min, unseen);
    }
    for (name, v) in &strict {
        assert_no_wrong_but_unseen(&format!("{name}, strict"), v, min_strict, unseen);
    }
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

/// The centre criterion as `cubetrace render --criterion centre` runs it (verified hits).
fn exact() -> TraceOptions {
    TraceOptions::centre()
}

/// The centre criterion in strict mode (`TraceOptions::strict`, `--strict`): a patch hit counts
/// only where the texel and its neighbours decide it.
fn strict() -> TraceOptions {
    TraceOptions {
        strict: true,
        ..TraceOptions::centre()
    }
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
/// has no wrong result and must still fail. Strict mode, the lower of the two, leaves undecided
/// the rays that cross a depth jump of the CMO inside a texel (silhouettes, thin objects) and
/// those no CMO sees; measured 0.898 (thin slab, 609 of 678) to 0.975 (mirror filling the frame)
/// over the cases below at their sizes, so 0.85 is about 5 points under the lowest.
const MIN_CORRECT: f64 = 0.85;

/// Grazing incidence: strict mode leaves the tile's 1 cm front side undecided by design (see
/// `grazing_incidence_on_the_mirror`), 144 of 768 pixels: measured 0.8125 correct (the default
/// mode 0.875).
const MIN_CORRECT_GRAZING: f64 = 0.75;

/// `Err` naming what failed when `v` has a wrong result, no mirror pixel, or under `min` of its
/// mirror pixels correct.
fn check_no_wrong(v: &Verdicts, min: f64) -> Result<(), String> {
    check_no_wrong_but_unseen(v, min, 0)
}

/// [`check_no_wrong`] allowing up to `unseen` hits on a triangle the ray meets behind one that
/// no texel centre of the capture saw (`other_triangle`; `cpu::verify`, "What can still be
/// missed"), and nothing else wrong.
fn check_no_wrong_but_unseen(v: &Verdicts, min: f64, unseen: usize) -> Result<(), String> {
    let correct = v.hits_ok + v.escapes_ok;
    let other_only = v.wrong_hits == 0 && v.wrong_escapes == 0 && v.off_triangle == 0;
    if v.mirror == 0 {
        Err("no mirror pixels".into())
    } else if v.wrong() > 0 && !(other_only && v.other_triangle <= unseen) {
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
    assert_no_wrong_but_unseen(name, v, min, 0);
}

fn assert_no_wrong_but_unseen(name: &str, v: &Verdicts, min: f64, unseen: usize) {
    eprintln!("{name}: {v:?}");
    if let Err(e) = check_no_wrong_but_unseen(v, min, unseen) {
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
    let frame_copy = frame.clone();
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
    // Negative test of the triangle checks: the same hits named on the neighbouring triangle
    // (same points, so the point judge passes them) are off their triangle or not the
    // reference's.
    let mut other = frame_copy;
    for r in &mut other.records {
        if r.status == RECORD_HIT {
            r.triangle ^= 1;
        }
    }
    let other = judge(&scene, &other, Vec3::ZERO);
    assert!(
        other.off_triangle + other.other_triangle > ok.hits_ok / 2,
        "{other:?}"
    );
    assert!(check_no_wrong(&other, MIN_CORRECT).is_err());
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
        assert_no_wrong_anywhere(ctx, &scene, (64, 48), MIN_CORRECT);
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

/// Hits allowed on a surface behind one the capture never saw, at cube sizes under 4: at N = 1
/// the +X face holds one ID (the floor), so rays that pass through the orange box (which no
/// texel centre sees) are verified on the floor behind it: 3 (N = 1), 5 (N = 2, 3) of 170 mirror
/// pixels in the default mode, 3, 5, 3 in strict mode. On a triangle the ray meets, never off it.
const UNSEEN_TINY_CUBE: usize = 5;

fn cube_sizes(sizes: &[u32]) {
    let ctx = gpu_context();
    for &n in sizes {
        let mut scene = builtin::sphere_room();
        scene.cmo.resolution = n;
        scene.name = format!("N = {n}");
        let (min, unseen) = if n < 4 {
            (MIN_CORRECT_TINY_CUBE, UNSEEN_TINY_CUBE)
        } else {
            (MIN_CORRECT, 0)
        };
        assert_no_wrong_anywhere_but_unseen(&ctx, &scene, (32, 24), min, unseen);
    }
    finish_gpu(ctx);
}

/// The one case of the suite where strict mode removes wrong hits that the
/// verified default mode reports (module docs). At cube size 3 the capture never sees the orange
/// box, and rays through it are verified on the floor behind it (on a triangle they meet, but not
/// the first). Strict mode leaves two of the five undecided (unresolved) and reports no wrong hit
/// the default mode does not. It does not remove that kind of wrong hit in general: at cube size
/// 2 it removes none (the negative test of the comparison).
#[test]
fn strict_mode_removes_unseen_occluder_hits_at_cube_size_3() {
    let ctx = gpu_context();
    for (n, removes) in [(3, true), (2, false)] {
        let mut scene = builtin::sphere_room();
        scene.cmo.resolution = n;
        scene.name = format!("N = {n}");
        let default = judge_paths(&ctx, &scene, (32, 24), exact());
        // Strict mode is the fragment pass's (`--strict`; the compute kernel carries no strict
        // code and refuses it).
        let strict = judge_runs(&ctx, &scene, (32, 24), strict(), &[Method::Fragment], true);
        assert_eq!(strict.len(), 2, "the fragment pass and its twin");
        // Every wrong hit of either mode is on a triangle the ray meets, behind the box.
        for (name, v) in default.iter().chain(&strict) {
            assert_eq!(v.wrong(), v.other_triangle, "{name}: {v:?}");
            assert_eq!((v.wrong_hits, v.off_triangle), (0, 0), "{name}: {v:?}");
        }
        for (name, s) in &strict {
            let d = &default
                .iter()
                .find(|(n, _)| n == name)
                .expect("each strict run has its default run")
                .1;
            eprintln!(
                "{name}: default wrong pixels {:?}, strict {:?}",
                d.wrong_pixels, s.wrong_pixels
            );
            assert!(
                s.wrong_pixels.iter().all(|k| d.wrong_pixels.contains(k)),
                "{name}: strict mode adds wrong hits"
            );
            assert_eq!(
                s.wrong() < d.wrong(),
                removes,
                "{name}: default {} wrong, strict {}",
                d.wrong(),
                s.wrong()
            );
        }
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
        assert_no_wrong_anywhere(&ctx, &scene, (48, 36), MIN_CORRECT);
        let frame = render(&ctx, &scene, (48, 36), exact());
        let v = judge(&scene, &frame, Vec3::ZERO);
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
    full.name = "full".into();
    assert_no_wrong_anywhere(&ctx, &full, (40, 30), MIN_CORRECT);
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
    scene.name = "on the reflector".into();
    assert_no_wrong_anywhere(&ctx, &scene, (48, 36), MIN_CORRECT);
    // Inside the orange box (centre (1.5, 0.3, 0.6), side 0.6) the CMO sees only the box's
    // inside, which no reflected ray reaches: the one right answer is "unresolved" everywhere
    // (no minimum share can hold; every pixel's verdict is asserted instead).
    scene.cmo.placement = CmoPlacement::Explicit(vec![Vec3::new(1.5, 0.3, 0.6)]);
    for (name, v) in judge_paths(&ctx, &scene, (48, 36), exact()) {
        eprintln!("inside the orange box, {name}: {v:?}");
        assert!(v.mirror > 0 && v.unresolved == v.mirror, "{name}: {v:?}");
    }
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
        specular_power: None,
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
        scene.name = format!("slab {t}");
        assert_no_wrong_anywhere(&ctx, &scene, (64, 48), MIN_CORRECT);
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
    scene.name = "bad normals".into();
    assert_no_wrong_anywhere(&ctx, &scene, (48, 36), MIN_CORRECT);
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
        specular_power: None,
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
    // Before verified hits, the default mode's patch hits on the tile's front side (see above)
    // were wrong (144 of 768 measured). Verified, they end on the triangle the ray meets or
    // unresolved: no wrong hit (measured 672 right, 96 unresolved).
    scene.name = "grazing".into();
    assert!(render(&ctx, &scene, (48, 36), exact()).mirror_pixels() > 100);
    assert_no_wrong_anywhere(&ctx, &scene, (48, 36), MIN_CORRECT_GRAZING);
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
        specular_power: None,
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
    scene.name = "near column".into();
    assert_no_wrong_anywhere(&ctx, &scene, (96, 72), MIN_CORRECT);
    finish_gpu(ctx);
}

/// The scene of the geometric hard cases. A flat mirror at z = -1 (two
/// triangles, facing +z) seen head on by a camera at (0, 1.2, 2.5) looking along -z, in
/// sphere-room's room without its objects. The reflected rays diverge from the camera's mirror
/// image (0, 1.2, -4.5) and come back past the camera (not an object) onto:
/// - `panel`: a 2.2 m square at z = 3.5 facing the mirror, of 8 triangles around its centre
///   vertex (0, 1.2, 3.5), sharing pairwise the edges on x = 0, on y = 1.2 and the diagonals.
///   With an odd frame size the centre pixel row and column look at the mirror along the planes
///   y = 1.2 and x = 0, so their reflected rays run in those planes up to f32 rounding: they land
///   on the shared edges, and the centre pixel's on the shared vertex.
/// - `fin`: a zero-thickness quad in the plane y = 1.2 between the camera and the panel: the
///   centre row's reflected rays run in its plane (parallel to it); the CMO, 0.3 m below the
///   plane, sees it from below.
/// - `degenerate`: zero-area triangles (three collinear vertices; two equal ones) across the
///   rays' way, which no capture stores.
/// - the room's walls: two triangles per wall, each spanning thousands of texels.
fn hard_geometry() -> Scene {
    let mut scene = builtin::sphere_room();
    scene.name = "hard geometry".into();
    scene.meshes.retain(|m| m.name == "room");
    let mat = |scene: &mut Scene, name: &str, diffuse: Vec3| {
        scene.materials.push(Material {
            name: name.into(),
            diffuse,
            texture: None,
            specular_power: None,
        });
        scene.materials.len() as u32 - 1
    };
    let mirror = mat(&mut scene, "mirror", Vec3::splat(0.8));
    let panel = mat(&mut scene, "panel", Vec3::new(0.9, 0.5, 0.1));
    let fin = mat(&mut scene, "fin", Vec3::new(0.1, 0.7, 0.9));
    let degenerate = mat(&mut scene, "degenerate", Vec3::new(0.9, 0.1, 0.1));
    let mesh = |name: &str, parts: Vec<MeshPart>, reflector: bool| MeshInstance {
        name: name.into(),
        parts,
        transform: Transform::default(),
        reflector,
    };
    let flat =
        |name: &str, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, n: Vec3, m: u32| MeshPart {
            name: name.into(),
            normals: vec![n; positions.len()],
            uvs: Vec::new(),
            colours: Vec::new(),
            positions,
            triangles,
            material: m,
            source: None,
        };
    scene.meshes.push(mesh(
        "mirror",
        vec![quad(
            "mirror",
            Vec3::new(-1.5, 0.2, -1.0),
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec2::ONE,
            mirror,
        )],
        true,
    ));
    // The panel: centre vertex 0, then the ring of its 8 boundary points counter-clockwise from
    // the middle of its right side (corners and side midpoints).
    let (c, h) = (Vec3::new(0.0, 1.2, 3.5), 1.1);
    let ring = [
        (h, 0.0),
        (h, h),
        (0.0, h),
        (-h, h),
        (-h, 0.0),
        (-h, -h),
        (0.0, -h),
        (h, -h),
    ]
    .map(|(x, y)| c + Vec3::new(x, y, 0.0));
    let positions: Vec<Vec3> = std::iter::once(c).chain(ring).collect();
    let triangles = (0..8).map(|k| [0, 1 + k, 1 + (k + 1) % 8]).collect();
    scene.meshes.push(mesh(
        "panel",
        vec![flat("panel", positions, triangles, Vec3::NEG_Z, panel)],
        false,
    ));
    scene.meshes.push(mesh(
        "fin",
        vec![quad(
            "fin",
            Vec3::new(-1.0, 1.2, 2.7),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.6),
            Vec2::ONE,
            fin,
        )],
        false,
    ));
    scene.meshes.push(mesh(
        "degenerate",
        vec![flat(
            "degenerate",
            vec![
                Vec3::new(-0.8, 0.6, 3.0),
                Vec3::new(0.8, 0.6, 3.0),
                Vec3::new(0.0, 0.6, 3.0),
                Vec3::new(-0.5, 1.8, 3.0),
                Vec3::new(0.5, 1.9, 3.0),
            ],
            vec![[0, 1, 2], [3, 3, 4]],
            Vec3::NEG_Z,
            degenerate,
        )],
        false,
    ));
    scene.cmo.placement = CmoPlacement::Explicit(vec![Vec3::new(0.0, 0.9, 0.5)]);
    scene.cmo.resolution = 64;
    scene.cameras[0].eye = Vec3::new(0.0, 1.2, 2.5);
    scene.cameras[0].target = Vec3::new(0.0, 1.2, -1.0);
    scene.cameras[0].fov_y_deg = 40.0;
    scene
}

/// The global triangle indices of mesh `mesh` (every part).
fn triangles_of(world: &WorldGeometry, mesh: &str) -> Vec<u32> {
    world
        .objects
        .iter()
        .filter(|o| o.name.starts_with(&format!("{mesh}/")))
        .flat_map(|o| o.first_triangle..o.first_triangle + o.triangle_count)
        .collect()
}

/// What a frame of [`hard_geometry`] shows of each case (mirror pixels only).
#[derive(Debug, Default, PartialEq)]
struct CaseCounts {
    /// Hits on a room triangle that the capture stores in at least 1000 texels.
    large_hits: usize,
    /// Reference hits on the panel within 1e-5 m of a shared edge (x = 0, y = 1.2, the
    /// diagonals), and how many of those pixels the method left unresolved or did not hit.
    edge_rays: usize,
    edge_not_hit: usize,
    /// Reference hits on the panel within 1e-5 m of its centre vertex.
    vertex_rays: usize,
    /// Rays within 1e-5 m of the fin's plane where they pass over the fin (parallel to it),
    /// and how many of those reported a hit on the fin.
    parallel_rays: usize,
    parallel_on_fin: usize,
    /// Records naming a degenerate triangle.
    degenerate_named: usize,
}

fn case_counts(scene: &Scene, frame: &GpuFrame, ids: &[u32]) -> CaseCounts {
    let tracer = Tracer::new(scene);
    let world = &tracer.world;
    let panel = triangles_of(world, "panel");
    let fin = triangles_of(world, "fin");
    let degenerate = triangles_of(world, "degenerate");
    let room = triangles_of(world, "room");
    let texels = |t: u32| ids.iter().filter(|&&i| i == t).count();
    let large: Vec<u32> = room.into_iter().filter(|&t| texels(t) >= 1000).collect();
    let mut c = CaseCounts::default();
    for (k, rec) in frame.records.iter().enumerate() {
        if frame.mask[k] == 0 {
            continue;
        }
        let (o, d) = (Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
        let hit = rec.status == RECORD_HIT;
        c.large_hits += usize::from(hit && large.contains(&rec.triangle));
        c.degenerate_named += usize::from(degenerate.contains(&rec.triangle));
        if let Some(h) = tracer.nearest_where(o, d, None, |t| !tracer.is_reflector(t))
            && panel.contains(&h.triangle)
        {
            let (x, y) = (f64::from(h.position.x), f64::from(h.position.y) - 1.2);
            let edge = x.abs().min(y.abs()).min((x - y).abs()).min((x + y).abs());
            if edge < 1e-5 {
                c.edge_rays += 1;
                c.edge_not_hit += usize::from(!hit);
            }
            c.vertex_rays += usize::from(x.abs().max(y.abs()) < 1e-5);
        }
        // Where the ray is over the fin (x in [-1, 1], z in [2.7, 3.3]), its height.
        if d.z > 0.0 {
            let over = (0..=10).all(|j| {
                let t = (2.7 + 0.06 * j as f32 - o.z) / d.z;
                let p = o + t * d;
                (-1.0..=1.0).contains(&p.x) && (p.y - 1.2).abs() < 1e-5
            });
            if over {
                c.parallel_rays += 1;
                c.parallel_on_fin += usize::from(hit && fin.contains(&rec.triangle));
            }
        }
    }
    c
}

/// Large triangles spanning many texels, hits on a shared edge and a shared
/// vertex, rays parallel to a triangle's plane, degenerate triangles in the scene and in the
/// ID buffer ([`hard_geometry`]), on both tracers and their CPU twins, in both modes: no hit
/// on a triangle the ray misses, no hit on another surface than the reference's, and a minimum
/// share of correct pixels ([`assert_no_wrong_anywhere`]); then per case that the frame does
/// show it, and what the method did there.
#[test]
fn large_triangles_shared_edges_parallel_rays_and_degenerate_triangles() {
    let ctx = gpu_context();
    let scene = hard_geometry();
    let size = (41, 31);
    // Strict mode leaves the rays that cross the panel's, the fin's and the room's outlines
    // inside a texel undecided: measured 756 of 925 correct (default 885).
    assert_no_wrong_in_both_modes(&ctx, &scene, size, [MIN_CORRECT, 0.75], 0);
    let world = scene.world();
    let degenerate = triangles_of(&world, "degenerate");
    for method in PATHS {
        let (frame, r) = render_with(&ctx, &scene, size, exact(), method);
        let cubes = r.cmo().read_back(&ctx).unwrap_or_else(|e| panic!("{e}"));
        let ids = &cubes[0].triangle;
        // The capture never stores a zero-area triangle.
        assert!(degenerate.iter().all(|t| !ids.contains(t)));
        let c = case_counts(&scene, &frame, ids);
        eprintln!("{} {method:?}: {c:?}", scene.name);
        assert!(c.large_hits > 100, "{c:?}");
        assert!(c.edge_rays >= 20 && c.vertex_rays >= 1, "{c:?}");
        // Watertight: no ray through a shared edge falls through the crack.
        assert_eq!(c.edge_not_hit, 0, "{c:?}");
        assert!(c.parallel_rays >= 5, "{c:?}");
        assert_eq!((c.parallel_on_fin, c.degenerate_named), (0, 0), "{c:?}");
        // Negative tests of the case checks: edge pixels left unresolved, and records naming
        // the fin or a degenerate triangle, are seen.
        let mut bad = frame.clone();
        for rec in &mut bad.records {
            if rec.status == RECORD_HIT {
                rec.status = RECORD_UNRESOLVED;
            }
        }
        assert_eq!(case_counts(&scene, &bad, ids).edge_not_hit, c.edge_rays);
        let fin = triangles_of(&world, "fin");
        let mut named = frame.clone();
        for rec in &mut named.records {
            rec.triangle = if rec.triangle == u32::MAX {
                degenerate[0]
            } else {
                fin[0]
            };
        }
        let n = case_counts(&scene, &named, ids);
        assert!(
            n.parallel_on_fin == n.parallel_rays && n.degenerate_named > 0,
            "{n:?}"
        );
        // A degenerate triangle in the ID buffer (which the capture never writes): every texel
        // of the panel and the fin names it instead. The CPU twin over those IDs reports no hit
        // on it, and none on a triangle the ray misses; the pixels it took from the panel go
        // unresolved or to the triangles left around them.
        let mut injected = cubes.clone();
        let panel = triangles_of(&world, "panel");
        for id in &mut injected[0].triangle {
            if panel.contains(id) || fin.contains(id) {
                *id = degenerate[0];
            }
        }
        let twin = twin_frame_over(&scene, &frame, injected, &exact(), method);
        let v = judge(&scene, &twin, Vec3::ZERO);
        eprintln!("degenerate IDs, {method:?} CPU twin: {v:?}");
        assert_eq!((v.off_triangle, v.wrong()), (0, 0), "{v:?}");
        assert_eq!(case_counts(&scene, &twin, ids).degenerate_named, 0);
        assert!(v.unresolved > judge(&scene, &frame, Vec3::ZERO).unresolved);
    }
    finish_gpu(ctx);
}

/// The degenerate triangle in the ID buffer on the GPU: the capture never
/// writes one (asserted in `large_triangles_shared_edges_parallel_rays_and_degenerate_triangles`),
/// so the IDs are injected and the GPU's verification (`shared/verify.wgsl`, the rule the
/// fragment and compute passes run, through the `hit_probe` pass) is run on [`hard_geometry`]'s
/// mirror rays, decided at the texel of their reference hit: with every panel texel naming a
/// degenerate triangle, the GPU equals the CPU twin bit for bit and no hit names it.
#[test]
fn degenerate_triangle_ids_in_the_gpu_verification() {
    let ctx = gpu_context();
    let scene = hard_geometry();
    let tracer = Tracer::new(&scene);
    let world = &tracer.world;
    let (panel, degenerate) = (
        triangles_of(world, "panel"),
        triangles_of(world, "degenerate"),
    );
    let (frame, r) = render_with(&ctx, &scene, (41, 31), exact(), Method::Fragment);
    let cube = &r.cmo().read_back(&ctx).unwrap_or_else(|e| panic!("{e}"))[0];
    let (n, centre) = (cube.size, cube.centre);
    let mut queries = Vec::new();
    for (k, rec) in frame.records.iter().enumerate() {
        let (o, d) = (Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
        let Some(h) = (frame.mask[k] != 0)
            .then(|| tracer.nearest_where(o, d, None, |t| !tracer.is_reflector(t)))
            .flatten()
        else {
            continue;
        };
        let texel = dir_to_texel(h.position - centre, n);
        queries.push(VerifyQuery {
            a: rec.origin,
            t_done: 0.0,
            d: rec.dir,
            t_hi: 1e3,
            centre: centre.to_array(),
            size: n,
            face: texel.face,
            x: texel.x,
            y: texel.y,
            _pad: 0,
        });
    }
    let corners = triangle_corners(world);
    let buffers = SceneBuffers::new(&ctx, &GpuSceneData::new(&scene)).unwrap();
    let injected: Vec<u32> = cube
        .triangle
        .iter()
        .enumerate()
        .map(|(i, &id)| {
            if panel.contains(&id) {
                degenerate[i % degenerate.len()]
            } else {
                id
            }
        })
        .collect();
    let gpu = verify_gpu(&ctx, &buffers, &injected, &queries).unwrap();
    let cpu: Vec<VerifyResult> = queries
        .iter()
        .map(|q| verify_cpu(q, &injected, &corners))
        .collect();
    let on_degenerate = gpu
        .iter()
        .filter(|v| v.hit == 1 && degenerate.contains(&v.triangle))
        .count();
    let hits = gpu.iter().filter(|v| v.hit == 1).count();
    // Negative: with the captured IDs, the panel's rays verify on the panel.
    let captured = verify_gpu(&ctx, &buffers, &cube.triangle, &queries).unwrap();
    let on_panel = |res: &[VerifyResult]| {
        res.iter()
            .filter(|v| v.hit == 1 && panel.contains(&v.triangle))
            .count()
    };
    eprintln!(
        "{} queries: {hits} verified with degenerate IDs ({on_degenerate} on them), on the panel {} (captured IDs {})",
        queries.len(),
        on_panel(&gpu),
        on_panel(&captured)
    );
    assert!(injected.iter().any(|id| degenerate.contains(id)));
    assert_eq!(gpu, cpu, "GPU and CPU verification differ");
    assert_eq!(on_degenerate, 0);
    assert!(hits > queries.len() / 2, "{hits} of {}", queries.len());
    assert!(on_panel(&captured) > 100 && on_panel(&gpu) < on_panel(&captured) / 10);
    finish_gpu(ctx);
}

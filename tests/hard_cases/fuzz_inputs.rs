//! Fixed-seed fuzzing of extreme and malformed scene inputs: every method must agree with the
//! reference or refuse, and refuse only what it must.
//!
//! The generator (`tests/common/fuzz_cases.rs`, drawn by proptest from a fixed seed) writes
//! small scene folders (scene.toml, OBJ, MTL), one [`Category`] each, every category in every
//! pass: extreme but legal coordinates (a vertex at 1e13 to 1e18, one huge triangle with a
//! vertex at 1e4 to 1e12, triangles of edge 1e-7, the scene moved 1e3 to 1e7 away, kilometres
//! in the first draw, or scaled by 1e-6 to 1e6, a reflector scaled by 1e-22), a vertex beyond
//! the 2^60 extent limit, flipped `vn` normals on the reflector and on the other meshes, the eye
//! exactly in a wall's, the floor's or a box face's plane (looking at the mirror or at a target
//! up to 1e7 away), a CMO centre in a triangle's plane, no reflector, no mesh at all; what
//! exporters write: sliver triangles of aspect 1e4 to 1e12 near the mirror, faces (the mirror's
//! too) as n-gons of 5 to 40 corners with extra corners on their edges, off them by a rounding
//! or repeated; a camera `up` within 1e-8 to 1e-5 radians of the view (or 1e-3 to 1e-2, which
//! fixes the roll); and ordinary scenes. Rooms, boxes, the mirror (a sphere or a square) and the
//! camera are drawn around these.
//!
//! Each case is rendered by the `cubetrace` binary with every method of [`Method::ALL`] at
//! 24x16 (`render SCENE --method M -o M.exr -v`; what a user runs, so a refusal anywhere in the
//! command counts), two at a time, and each run is judged:
//! - **a refusal** ([`judge_refusal`]): exit status 1, no panic, an `error:` line, no output
//!   file left, and the case allows one: its category names what the message must mention
//!   (the OBJ file and line of a vertex beyond the limit, `extent` or `2^60`; `precision`,
//!   `f32` for a scaled scene, or for one moved past 2^21, where the input's own rounding
//!   breaks its 1/8 grid, or so far that a mesh is under 2^-20 of its coordinates across, which
//!   the loader refuses; `CMO` for a centre on a surface; `scale` or the mirror's name for a
//!   vanishing one; `mesh` or `triangle` for an empty scene). The GPU must be right where it
//!   can be: an eye in a plane, far vertices, inward normals, slivers, collinear n-gons, a
//!   scene moved less far (the GPU works relative to its centre: kilometres out, and up to
//!   some 4e5 for the smallest box), an `up` 1e-3 from the view, and ordinary scenes may not
//!   be refused.
//! - **a required refusal** ([`judge_required_refusal`]): an `up` within rounding of the view
//!   fixes no camera, so every run, the reference's too, must refuse it as the scene loads, as
//!   above, naming all of the case's `refuse` words: `camera[0].up`, its scene.toml line and the
//!   angle (`degrees from the view direction`). A frame is a failure there, however good.
//! - **a frame** against the reference's ([`judge_frame`]; the reference is the same binary's
//!   `--method reference`, the EXR channels read back into [`metrics::classify`]'s types):
//!   - every method: the primary visibility matches: the mirror masks differ on at most
//!     [`edge_allowance`] pixels of the union of the masks, and the pixels that are no mirror
//!     in either frame differ in colour (more than [`COLOUR_TOL`] in a channel) on at most
//!     `edge_allowance` of them; a frame with no mirror pixel where the reference has some
//!     fails, whatever the allowance;
//!   - exact methods (compute, fragment, bvh): also the same surface on the mirror pixels of
//!     both: at most `edge_allowance` of them unresolved or on the wrong surface
//!     ([`metrics::PixelClass::WrongSurface`]: the hit more than two texel footprints from
//!     the reference's);
//!   - approximate methods (envmap, ssr, reflection-point) are not held to the reference's
//!     surfaces (envmap is wrong on 98 % of them by design);
//!   - but flipping the reflector's `vn` normals does not change the reflection (`d - 2 (d.n)
//!     n` is the same for `-n`), so in flipped-reflector cases every GPU method's frame must
//!     equal its frame of the twin scene with the normals the right way round ([`judge_twin`]:
//!     mask, colour, unresolved and the trace fallback's pixels, the same allowance on mirror
//!     pixels). This sees what the fallback hides: a tracer that gives up on every inward
//!     normal and leaves the BVH to finish the frame.
//! - **the work is bounded**: compute's texels per ray (its `-v` line), mean over rays, at most
//!   [`TEXELS_PER_TEXEL_SIDE`] times the cube size per CMO (a walk across a face takes one per
//!   texel; a huge triangle with a vertex 1e10 out once made it 1071 at cube size 32; the
//!   bounded criterion's walk past captured surfaces takes up to 5.8 times, 93 texels at cube
//!   size 16 with a vertex 1e16 out, where the centre criterion stayed under 4); a run that takes
//!   [`HANG`] is killed and fails (a watchdog for hangs, not a speed check).
//! - **nothing passes in silence** where the category says so: a vanishing reflector must be
//!   named (`mirror` or `scale`) in some message of each run;
//! - **no false alarm** ([`judge_quiet`]): no warning or error of a collinear-n-gon case's runs
//!   may speak of a self-crossing polygon or of degenerate triangles (the collinear and repeated
//!   corners are left out before triangulation; a run that took the outline for a crossing one
//!   and fanned it would still draw the right quad, so the frame alone cannot see it), nor one
//!   of a sliver case's of degenerate triangles (a sliver has an area in f32; dropped, it would
//!   be missed by no pixel's comparison).
//!
//! The judges are plain functions of frames and messages:
//! `judges_reject_bad_frames_and_bad_refusals` shows each rejects what it must (a perturbed
//! frame, a wrong reference, an empty frame, a changed twin, a panic, a message naming nothing,
//! a left file, a frame where a refusal is required, a refusal that lacks the field or its
//! line, a false warning, a runaway counter, a hung process). The pass prints every case with
//! its category and draws, reports every failing one, then fails.
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use crate::fuzz_cases;

use cubetrace::Method;
use cubetrace::camera::MIN_UP_SINE;
use cubetrace::metrics::{self, PixelClass, Traced};
use cubetrace::reference::{Frame, NO_ID};
use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use fuzz_cases::{Case, Category, aspect, categories, generate, up_sine};
use glam::Vec3;
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

const SEED: [u8; 16] = *b"cubetrace-fuzz-i";
/// One case per category, then [`AGAIN`] (once each): the pass's cost is ~7 renders per case,
/// fragment's and compute's pipeline builds most of it (a refused case costs little, a
/// flipped-reflector case twice as much as another: its twin).
const CASES: usize = 18 + AGAIN.len();
/// The categories drawn a second time: the rendering draw of near-parallel-up, far-translation
/// at 1e4 to 1e7 (past the kilometres of the first), beyond-limit in the reflector's other
/// triangle. Ordinary, eye-on-plane (on any plane, after the front wall) and flipped-reflector
/// were drawn twice before the slivers, n-gons and `up` vectors came; they are drawn once so
/// that the pass keeps its time.
const AGAIN: [Category; 3] = [
    Category::NearParallelUp,
    Category::FarTranslation,
    Category::BeyondLimit,
];
/// A colour difference (linear, per channel, clamped to [0, 1]) that counts.
const COLOUR_TOL: f32 = 0.02;
/// Compute's mean texels per ray may be at most this times the cube size per CMO: a ray of the
/// bounded criterion (the default) walks on past captured surfaces to its proven hit, across
/// at most four faces (a half great circle), at most two texels per texel side of each (the
/// diagonal and the cells' rounding).
const TEXELS_PER_TEXEL_SIDE: f64 = 8.0;
/// A run that takes this long hangs.
const HANG: Duration = Duration::from_secs(300);

/// Pixels of a set of `n` that may differ at edges: rasterisation against the reference's ray
/// at a silhouette, a grazing reflection. Two plus 2 %.
pub fn edge_allowance(n: usize) -> usize {
    2 + n / 50
}

/// The cases of the pass, from the fixed seed.
fn cases(count: usize) -> Vec<Case> {
    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::from_seed(RngAlgorithm::XorShift, &SEED),
    );
    let words = proptest::collection::vec(any::<u32>(), 256);
    let order = categories();
    let again = AGAIN;
    let mut seen = BTreeMap::new();
    (0..count)
        .map(|i| {
            let category = if i < order.len() {
                order[i]
            } else {
                again[(i - order.len()) % again.len()]
            };
            let w = words.new_tree(&mut runner).expect("draws").current();
            let occurrence = seen.entry(category).or_insert(0);
            *occurrence += 1;
            generate(i, category, *occurrence - 1, w)
        })
        .collect()
}

/// How a run of the binary ended.
#[derive(Clone, Debug, Default)]
pub struct Run {
    pub code: Option<i32>,
    pub stderr: String,
    pub timed_out: bool,
    /// The output file exists after the run.
    pub output: bool,
    pub seconds: f64,
}

/// Runs `cmd` with its output in `log` (stdout and stderr together) and kills it after `limit`.
fn run_with_watchdog(mut cmd: Command, log: &Path, limit: Duration) -> Run {
    let file = std::fs::File::create(log).unwrap();
    cmd.stdout(file.try_clone().unwrap())
        .stderr(file)
        .stdin(Stdio::null());
    let start = Instant::now();
    let mut child = cmd.spawn().expect("the binary starts");
    let (code, timed_out) = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break (status.code(), false);
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break (None, true);
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Run {
        code,
        stderr: String::from_utf8_lossy(&std::fs::read(log).unwrap_or_default()).into_owned(),
        timed_out,
        output: false,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// `cubetrace render DIR/scene.toml --method M -o DIR/M.exr -v`.
fn render(dir: &Path, method: Method) -> Run {
    let out = dir.join(format!("{method}.exr"));
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubetrace"));
    cmd.arg("render")
        .arg(dir.join("scene.toml"))
        .args(["--method", method.name(), "-v", "-o"])
        .arg(&out)
        .env("XDG_RUNTIME_DIR", "/tmp")
        .env_remove("RUST_LOG");
    let mut run = run_with_watchdog(cmd, &dir.join(format!("{method}.log")), HANG);
    run.output = out.exists();
    run
}

/// The `error:` lines of a run.
fn errors(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.starts_with("error:")).collect()
}

/// Judges a run that did not write a frame: a clean refusal that the case allows, naming one of
/// its `anchors` (none: the case must render).
pub fn judge_refusal(run: &Run, anchors: &[String]) -> Result<(), String> {
    if run.timed_out {
        return Err(format!("killed after {:.0} s (a hang)", run.seconds));
    }
    let first = errors(&run.stderr).first().map(|s| s.to_string());
    let first = first.unwrap_or_default();
    if run.stderr.contains("panicked") || run.code != Some(1) {
        let tail: String = run
            .stderr
            .lines()
            .rev()
            .take(3)
            .collect::<Vec<_>>()
            .join(" | ");
        return Err(format!(
            "exit status {:?}, not a clean refusal: {tail}",
            run.code
        ));
    }
    if first.is_empty() {
        return Err("refused without an `error:` line".into());
    }
    if run.output {
        return Err(format!("refused but left its output file: {first}"));
    }
    if anchors.is_empty() {
        return Err(format!("refused an input it must render: {first}"));
    }
    if !anchors.iter().any(|a| first.contains(a.as_str())) {
        return Err(format!("the refusal names none of {anchors:?}: {first}"));
    }
    Ok(())
}

/// Judges a run of an input that must be refused: a refusal as [`judge_refusal`] judges it,
/// whose first `error:` line names every one of `names` (a frame, however good, fails).
pub fn judge_required_refusal(run: &Run, names: &[String]) -> Result<(), String> {
    if !run.timed_out && run.code == Some(0) {
        return Err(format!(
            "rendered an input it must refuse (naming {names:?})"
        ));
    }
    judge_refusal(run, names)?;
    let first = errors(&run.stderr)[0];
    let missing: Vec<&String> = names
        .iter()
        .filter(|w| !first.contains(w.as_str()))
        .collect();
    if !missing.is_empty() {
        return Err(format!("the refusal does not name {missing:?}: {first}"));
    }
    Ok(())
}

/// Judges that no warning or error of a run names one of `words` (a false alarm).
pub fn judge_quiet(stderr: &str, words: &[String]) -> Result<(), String> {
    let alarm = stderr
        .lines()
        .filter(|l| l.contains("WARN") || l.starts_with("error:"))
        .find(|l| words.iter().any(|w| l.contains(w.as_str())));
    match alarm {
        Some(l) => Err(format!("a false alarm (it names one of {words:?}): {l}")),
        None => Ok(()),
    }
}

/// Compute's mean texels per ray, from its `-v` line (`per ray mean/max: texels M/X`).
pub fn texels_per_ray(stderr: &str) -> Option<f64> {
    let line = stderr
        .lines()
        .find(|l| l.contains("compute:") && l.contains("texels "))?;
    let rest = &line[line.find("texels ")? + "texels ".len()..];
    rest.split('/').next()?.trim().parse().ok()
}

/// Judges compute's work per ray against its bound.
pub fn judge_counter(stderr: &str, cube: u32, cmos: usize) -> Result<(), String> {
    let bound = TEXELS_PER_TEXEL_SIDE * f64::from(cube) * cmos.max(1) as f64;
    match texels_per_ray(stderr) {
        None => Err("no texels-per-ray line in compute's -v output".into()),
        Some(t) if t <= bound => Ok(()),
        Some(t) => Err(format!(
            "{t:.1} texels per ray, over the bound {bound:.0} ({TEXELS_PER_TEXEL_SIDE} x cube size {cube} x {cmos} CMOs)"
        )),
    }
}

/// Every channel of an EXR as f32 (u32 channels converted, `u32::MAX` kept apart as NaN-free
/// [`NO_ID`] by [`ids`]).
fn channels(path: &Path) -> Result<BTreeMap<String, FlatSamples>, String> {
    let image =
        read_all_flat_layers_from_file(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = BTreeMap::new();
    for layer in image.layer_data {
        for ch in layer.channel_data.list {
            out.insert(ch.name.to_string(), ch.sample_data);
        }
    }
    Ok(out)
}

fn f32s(c: &BTreeMap<String, FlatSamples>, name: &str) -> Result<Vec<f32>, String> {
    match c.get(name) {
        Some(FlatSamples::F32(v)) => Ok(v.clone()),
        Some(FlatSamples::F16(v)) => Ok(v.iter().map(|x| x.to_f32()).collect()),
        Some(FlatSamples::U32(v)) => Ok(v.iter().map(|&x| x as f32).collect()),
        None => Err(format!("no channel {name}")),
    }
}

/// One id per triangle from `object_id` and `primitive_id` (`NO_ID` where none): the same
/// numbering in the reference's and a GPU frame's EXR.
fn ids(c: &BTreeMap<String, FlatSamples>) -> Option<Vec<u32>> {
    match (c.get("object_id"), c.get("primitive_id")) {
        (Some(FlatSamples::U32(o)), Some(FlatSamples::U32(p))) => Some(
            o.iter()
                .zip(p)
                .map(|(&o, &p)| {
                    if o == NO_ID || p == NO_ID {
                        NO_ID
                    } else {
                        o.wrapping_mul(1 << 20).wrapping_add(p)
                    }
                })
                .collect(),
        ),
        _ => None,
    }
}

fn vec3s(c: &BTreeMap<String, FlatSamples>, p: &str) -> Result<Vec<Vec3>, String> {
    let (x, y, z) = (
        f32s(c, &format!("{p}.X"))?,
        f32s(c, &format!("{p}.Y"))?,
        f32s(c, &format!("{p}.Z"))?,
    );
    Ok((0..x.len()).map(|k| Vec3::new(x[k], y[k], z[k])).collect())
}

/// A frame read back from an EXR of the binary: the reference's [`Frame`] (with its shown hits
/// as `hit_position`, as `--compare` reads it), or a GPU method's [`Traced`] with its primary
/// hits.
#[derive(Clone)]
pub struct Exr {
    pub frame: Frame,
    pub traced: Traced,
    pub surface: Vec<Vec3>,
}

pub fn read_exr(path: &Path) -> Result<Exr, String> {
    let c = channels(path)?;
    let (r, g, b) = (f32s(&c, "R")?, f32s(&c, "G")?, f32s(&c, "B")?);
    let n = r.len();
    let (w, h) = (24u32, (n / 24) as u32);
    if n == 0 || n % 24 != 0 {
        return Err(format!("{}: {n} pixels, not 24 wide", path.display()));
    }
    let colour: Vec<Vec3> = (0..n).map(|k| Vec3::new(r[k], g[k], b[k])).collect();
    let mask: Vec<u8> = f32s(&c, "mask")?
        .iter()
        .map(|&m| u8::from(m > 0.5))
        .collect();
    let hit = vec3s(&c, "hit")?;
    let surface = vec3s(&c, "P")?;
    let unresolved = c
        .get("unresolved")
        .map(|_| f32s(&c, "unresolved"))
        .transpose()?
        .unwrap_or_else(|| vec![0.0; n]);
    let triangle = ids(&c);
    let fallback = c
        .get("fallback")
        .map(|_| f32s(&c, "fallback"))
        .transpose()?
        .map(|f| f.iter().map(|&x| u8::from(x > 0.5)).collect());
    let mut frame = Frame::new(w, h);
    frame.colour = colour.clone();
    frame.mask = mask.clone();
    frame.surface_position = surface.clone();
    frame.hit_position = hit.clone();
    frame.triangle = triangle.clone().unwrap_or_else(|| vec![NO_ID; n]);
    let traced = Traced {
        width: w,
        height: h,
        colour,
        resolved: (0..n)
            .map(|k| u8::from(mask[k] != 0 && unresolved[k] < 0.5))
            .collect(),
        mask,
        hit_position: hit,
        triangle,
        fallback,
        bounces: None,
    };
    Ok(Exr {
        frame,
        traced,
        surface,
    })
}

/// Whether two colours differ by more than [`COLOUR_TOL`] in a channel (NaN differs).
fn differ(a: Vec3, b: Vec3) -> bool {
    // glam's clamp and max drop NaN: test it first.
    let d = (a.clamp(Vec3::ZERO, Vec3::ONE) - b.clamp(Vec3::ZERO, Vec3::ONE)).abs();
    a.is_nan() || b.is_nan() || d.max_element() > COLOUR_TOL
}

/// Whether the method must hit the reference's surfaces.
pub fn exact(m: Method) -> bool {
    matches!(
        m,
        Method::Compute | Method::Fragment | Method::Bvh | Method::Reference
    )
}

/// Judges a frame of `method` against the reference (see the module docs).
pub fn judge_frame(
    method: Method,
    reference: &Frame,
    traced: &Traced,
    mirror_point: &[Vec3],
    centres: &[Vec3],
    cube: u32,
) -> Result<(), String> {
    if (reference.width, reference.height) != (traced.width, traced.height) {
        return Err("a frame of another size".into());
    }
    let n = reference.mask.len();
    let (rm, tm) = (
        reference.mirror_pixels(),
        traced.mask.iter().filter(|&&m| m != 0).count(),
    );
    if rm > 0 && tm == 0 {
        return Err(format!("no mirror pixel where the reference has {rm}"));
    }
    let union = (0..n)
        .filter(|&k| reference.mask[k] != 0 || traced.mask[k] != 0)
        .count();
    let mask = (0..n)
        .filter(|&k| reference.mask[k] != traced.mask[k])
        .count();
    if mask > edge_allowance(union) {
        return Err(format!(
            "the mirror masks differ on {mask} pixels ({rm} in the reference, {tm} here; allowed {})",
            edge_allowance(union)
        ));
    }
    let plain: Vec<usize> = (0..n)
        .filter(|&k| reference.mask[k] == 0 && traced.mask[k] == 0)
        .collect();
    let off = plain
        .iter()
        .filter(|&&k| differ(reference.colour[k], traced.colour[k]))
        .count();
    if off > edge_allowance(plain.len()) {
        return Err(format!(
            "{off} of {} pixels off the mirror differ in colour (allowed {})",
            plain.len(),
            edge_allowance(plain.len())
        ));
    }
    if !exact(method) {
        return Ok(());
    }
    let classes = metrics::classify(reference, traced, mirror_point, centres, cube);
    let both = classes
        .iter()
        .filter(|p| {
            !matches!(
                p.class,
                PixelClass::NotMirror | PixelClass::MaskMissed | PixelClass::MaskExtra
            )
        })
        .count();
    let wrong = classes
        .iter()
        .filter(|p| p.class == PixelClass::WrongSurface)
        .count();
    let unresolved = classes
        .iter()
        .filter(|p| p.class == PixelClass::Unresolved)
        .count();
    if wrong + unresolved > edge_allowance(both) {
        return Err(format!(
            "of {both} mirror pixels, {wrong} on the wrong surface and {unresolved} unresolved (allowed {})",
            edge_allowance(both)
        ));
    }
    Ok(())
}

/// Judges a method's frame of a flipped-reflector case against its frame of the twin scene.
pub fn judge_twin(flipped: &Traced, twin: &Traced) -> Result<(), String> {
    let n = twin.mask.len();
    if flipped.mask.len() != n {
        return Err("a frame of another size".into());
    }
    let mirror: Vec<usize> = (0..n)
        .filter(|&k| twin.mask[k] != 0 || flipped.mask[k] != 0)
        .collect();
    let fallback = |t: &Traced, k: usize| t.fallback.as_ref().map_or(0, |f| f[k]);
    let changed = mirror
        .iter()
        .filter(|&&k| {
            twin.mask[k] != flipped.mask[k]
                || twin.resolved[k] != flipped.resolved[k]
                || fallback(twin, k) != fallback(flipped, k)
                || differ(twin.colour[k], flipped.colour[k])
        })
        .count();
    if changed > edge_allowance(mirror.len()) {
        return Err(format!(
            "flipping the reflector's vn changed {changed} of {} mirror pixels (allowed {})",
            mirror.len(),
            edge_allowance(mirror.len())
        ));
    }
    Ok(())
}

/// One render to do: a case (or its twin) and a method.
#[derive(Clone, Copy)]
struct Job {
    case: usize,
    twin: bool,
    method: Method,
}

/// The jobs of the pass, the costliest (pipeline builds) first so that the workers finish
/// together.
fn jobs(cases: &[Case]) -> Vec<Job> {
    let order = [
        Method::Fragment,
        Method::Compute,
        Method::ReflectionPoint,
        Method::Envmap,
        Method::Ssr,
        Method::Bvh,
        Method::Reference,
    ];
    assert_eq!(order.len(), Method::ALL.len());
    let mut out = Vec::new();
    for method in order {
        for (i, c) in cases.iter().enumerate() {
            out.push(Job {
                case: i,
                twin: false,
                method,
            });
            if c.twin.is_some() && method.is_gpu() {
                out.push(Job {
                    case: i,
                    twin: true,
                    method,
                });
            }
        }
    }
    out
}

fn case_dir(root: &Path, c: &Case, twin: bool) -> PathBuf {
    root.join(format!(
        "case{:02}{}",
        c.index,
        if twin { "-twin" } else { "" }
    ))
}

/// Renders every job on `workers` threads: the runs by job index.
fn render_all(root: &Path, cases: &[Case], jobs: &[Job], workers: usize) -> Vec<Run> {
    let next = AtomicUsize::new(0);
    let runs = Mutex::new(vec![Run::default(); jobs.len()]);
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| {
                loop {
                    let j = next.fetch_add(1, Ordering::SeqCst);
                    let Some(job) = jobs.get(j) else { break };
                    let run = render(&case_dir(root, &cases[job.case], job.twin), job.method);
                    runs.lock().unwrap()[j] = run;
                }
            });
        }
    });
    runs.into_inner().unwrap()
}

/// Judges one case's runs (`runs[method]`, `twins[method]`): its failures.
fn judge_case(
    dir: &Path,
    c: &Case,
    runs: &BTreeMap<&str, &Run>,
    twins: &BTreeMap<&str, &Run>,
) -> Vec<String> {
    let mut out = Vec::new();
    let reference = runs["reference"];
    let refr = if reference.code == Some(0) && reference.output {
        match read_exr(&dir.join("reference.exr")) {
            Ok(e) => Some(e.frame),
            Err(e) => {
                out.push(format!("reference: unreadable output: {e}"));
                None
            }
        }
    } else {
        None
    };
    for m in Method::ALL {
        let run = runs[m.name()];
        let verdict = (|| {
            if !c.notice.is_empty()
                && run.code.is_some()
                && !c.notice.iter().any(|w| {
                    run.stderr
                        .lines()
                        .filter(|l| l.contains("WARN") || l.starts_with("error:"))
                        .any(|l| l.contains(w.as_str()))
                })
            {
                return Err(format!("no warning or error names any of {:?}", c.notice));
            }
            judge_quiet(&run.stderr, &c.quiet)?;
            if !c.refuse.is_empty() {
                return judge_required_refusal(run, &c.refuse);
            }
            if run.code != Some(0) || run.timed_out {
                return judge_refusal(run, &c.anchors);
            }
            if !run.output {
                return Err("exit status 0 but no output file".into());
            }
            let Some(refr) = &refr else {
                if m == Method::Reference {
                    return Ok(());
                }
                return Err("renders a case the reference refused".into());
            };
            if m == Method::Compute {
                judge_counter(&run.stderr, c.cube, c.centres.len())?;
            }
            let e = read_exr(&dir.join(format!("{m}.exr")))?;
            judge_frame(m, refr, &e.traced, &e.surface, &c.centres, c.cube)?;
            if let Some(t) = twins.get(m.name()) {
                if run.code == Some(0) && t.code == Some(0) {
                    let tw = read_exr(
                        &case_dir(dir.parent().unwrap(), c, true).join(format!("{m}.exr")),
                    )?;
                    judge_twin(&e.traced, &tw.traced)?;
                } else if t.code != run.code {
                    return Err(format!(
                        "the twin scene ends with {:?}, this one {:?}",
                        t.code, run.code
                    ));
                }
            }
            Ok(())
        })();
        if let Err(e) = verdict {
            out.push(format!("--method {m} ({:.1} s): {e}", run.seconds));
        }
    }
    out
}

#[test]
fn every_method_agrees_with_the_reference_or_refuses() {
    // `CUBETRACE_FUZZ_CASES=2,16` runs those cases only; `CUBETRACE_FUZZ_DIR=DIR` writes them
    // (scenes, EXRs, logs) into DIR and keeps them.
    let only: Option<Vec<usize>> = std::env::var("CUBETRACE_FUZZ_CASES")
        .ok()
        .map(|v| v.split(',').filter_map(|x| x.trim().parse().ok()).collect());
    let cases: Vec<Case> = cases(CASES)
        .into_iter()
        .filter(|c| only.as_ref().is_none_or(|o| o.contains(&c.index)))
        .collect();
    let temp = tempfile::tempdir().expect("temp dir");
    let keep = std::env::var_os("CUBETRACE_FUZZ_DIR").map(PathBuf::from);
    let root = keep.as_deref().unwrap_or(temp.path());
    for c in &cases {
        c.write(&case_dir(root, c, false), false);
        if c.twin.is_some() {
            c.write(&case_dir(root, c, true), true);
        }
    }
    let jobs = jobs(&cases);
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 4);
    let start = Instant::now();
    let runs = render_all(root, &cases, &jobs, workers);
    let mut failures: BTreeMap<Category, Vec<String>> = BTreeMap::new();
    let mut failed_cases = 0;
    for (i, c) in cases.iter().enumerate() {
        let pick = |twin: bool| -> BTreeMap<&str, &Run> {
            jobs.iter()
                .zip(&runs)
                .filter(|(j, _)| j.case == i && j.twin == twin)
                .map(|(j, r)| (j.method.name(), r))
                .collect()
        };
        let f = judge_case(&case_dir(root, c, false), c, &pick(false), &pick(true));
        let secs: f64 = jobs
            .iter()
            .zip(&runs)
            .filter(|(j, _)| j.case == i)
            .map(|(_, r)| r.seconds)
            .sum();
        println!(
            "{} ({secs:.1} s of renders): {}",
            c.label(),
            if f.is_empty() {
                "ok".to_string()
            } else {
                format!("{} failures", f.len())
            }
        );
        for e in &f {
            println!("    {e}");
        }
        if !f.is_empty() {
            failed_cases += 1;
            failures
                .entry(c.category)
                .or_default()
                .extend(f.iter().map(|e| format!("{}: {e}", c.label())));
        }
    }
    println!(
        "{} cases, {} renders on {workers} workers in {:.1} s",
        cases.len(),
        jobs.len(),
        start.elapsed().as_secs_f64()
    );
    let report: Vec<String> = failures
        .iter()
        .map(|(k, v)| format!("{}:\n  {}", k.name(), v.join("\n  ")))
        .collect();
    assert!(
        failures.is_empty(),
        "{failed_cases} of {} cases fail:\n{}",
        cases.len(),
        report.join("\n")
    );
}

/// The pass draws every category, the same cases every time (a fixed seed), and different
/// draws for different cases.
#[test]
fn the_generator_covers_every_category_deterministically() {
    let a = cases(CASES);
    let b = cases(CASES);
    for k in categories() {
        assert!(a.iter().any(|c| c.category == k), "{k:?}");
    }
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.toml(), y.toml());
        assert_eq!(x.objs, y.objs);
    }
    let tomls: std::collections::BTreeSet<String> = a.iter().map(|c| c.toml()).collect();
    assert_eq!(tomls.len(), a.len(), "every case differs");
    // Inward normals come with their twin (the eye in the front wall's plane and a vertex past
    // 1e13 are the first draws of their categories).
    assert!(a.iter().any(|c| c.twin.is_some()));
    let of = |k: Category| a.iter().filter(move |c| c.category == k);
    // Slivers: at least two per case, of aspect 1e4 to 1e12 as f32 holds their corners.
    for c in of(Category::Sliver) {
        let slivers: Vec<f64> = obj_faces(c, "sliver.obj")
            .into_iter()
            .map(|f| aspect([f[0], f[1], f[2]]))
            .filter(|&x| x > 100.0)
            .collect();
        assert!(
            slivers.len() >= 2 && slivers.iter().all(|x| (0.5e4..2e12).contains(x)),
            "{}: {slivers:?}",
            c.label()
        );
    }
    // N-gons: every face of the room and boxes (and the first case's mirror) of 5 to 40
    // corners, some of them repeated.
    for c in of(Category::CollinearNgon) {
        let mut files = vec!["room.obj", "boxes.obj"];
        if c.index == of(Category::CollinearNgon).next().unwrap().index {
            files.push("mirror.obj");
        }
        let mut repeated = 0;
        for file in files {
            let faces = obj_faces(c, file);
            assert!(
                faces.len() >= 6 || (file == "mirror.obj" && faces.len() == 1),
                "{}: {file}",
                c.label()
            );
            for f in faces {
                assert!((5..=40).contains(&f.len()), "{}: {file}", c.label());
                repeated += (0..f.len())
                    .filter(|&k| f[k] == f[(k + 1) % f.len()])
                    .count();
            }
        }
        assert!(repeated > 0, "{}", c.label());
    }
    // Up vectors: a refused one within rounding of the view, a rendered one well off it.
    let ups: Vec<&Case> = of(Category::NearParallelUp).collect();
    assert!(ups.iter().any(|c| !c.refuse.is_empty()) && ups.iter().any(|c| c.refuse.is_empty()));
    for c in ups {
        let sine = up_sine(c);
        if c.refuse.is_empty() {
            assert!((5.0 * MIN_UP_SINE..0.02).contains(&sine), "{}", c.label());
        } else {
            assert!(sine < MIN_UP_SINE / 5.0, "{}", c.label());
            assert!(c.refuse.iter().any(|w| w.starts_with("scene.toml:")));
        }
    }
    // A room kilometres out, which must render.
    assert!(of(Category::FarTranslation).any(|c| {
        let t = c.meshes[0].translate.abs().max_element();
        (1e3..=1e4).contains(&t) && c.anchors.is_empty()
    }));
}

/// The faces of a case's OBJ file, as their corners' positions.
fn obj_faces(c: &Case, file: &str) -> Vec<Vec<Vec3>> {
    let text = &c.objs.iter().find(|(n, _)| n == file).expect(file).1;
    let mut v = Vec::new();
    let mut faces = Vec::new();
    for l in text.lines() {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.first() {
            Some(&"v") => v.push(Vec3::new(
                w[1].parse().unwrap(),
                w[2].parse().unwrap(),
                w[3].parse().unwrap(),
            )),
            Some(&"f") => faces.push(
                w[1..]
                    .iter()
                    .map(|c| v[c.split('/').next().unwrap().parse::<usize>().unwrap() - 1])
                    .collect(),
            ),
            _ => {}
        }
    }
    faces
}

/// Negatives: each judge rejects what it must, on frames of a real render (an ordinary case's
/// reference and bvh frames) perturbed, and on synthetic runs. The wrong reference is the
/// tiny-triangles case's: another room, mirror and camera.
#[test]
fn judges_reject_bad_frames_and_bad_refusals() {
    let all = cases(CASES);
    let ordinary: Vec<&Case> = [Category::Ordinary, Category::TinyTriangles]
        .iter()
        .map(|&k| all.iter().find(|c| c.category == k).expect("drawn"))
        .collect();
    let root = tempfile::tempdir().expect("temp dir");
    let mut frames = Vec::new();
    for c in ordinary.iter().take(2) {
        let dir = case_dir(root.path(), c, false);
        c.write(&dir, false);
        for m in [Method::Reference, Method::Bvh] {
            let run = render(&dir, m);
            assert_eq!(run.code, Some(0), "{}: {}", c.label(), run.stderr);
        }
        let r = read_exr(&dir.join("reference.exr")).unwrap();
        let t = read_exr(&dir.join("bvh.exr")).unwrap();
        frames.push((c, r, t));
    }
    let (c, r, t) = &frames[0];
    let judge = |m: Method, refr: &Frame, tr: &Traced| {
        judge_frame(m, refr, tr, &t.surface, &c.centres, c.cube)
    };
    assert!(
        r.frame.mirror_pixels() > 10,
        "the mirror is in view: {}",
        c.label()
    );
    // Positive controls: the real frame passes, so does the reference against itself.
    judge(Method::Bvh, &r.frame, &t.traced).unwrap();
    judge(Method::Reference, &r.frame, &r.traced).unwrap();

    let mirror: Vec<usize> = (0..t.traced.mask.len())
        .filter(|&k| t.traced.mask[k] != 0)
        .collect();
    // Hits moved a metre on a third of the mirror: wrong surfaces for an exact method.
    let mut moved = t.traced.clone();
    for &k in mirror.iter().step_by(3) {
        moved.hit_position[k] += Vec3::splat(1.0);
        if moved.hit_position[k].is_nan() {
            moved.hit_position[k] = Vec3::ONE;
        }
    }
    let e = judge(Method::Bvh, &r.frame, &moved).unwrap_err();
    assert!(e.contains("wrong surface"), "{e}");
    // ...which an approximate method is not held to.
    judge(Method::Envmap, &r.frame, &moved).unwrap();
    // A third of the mirror unresolved.
    let mut unresolved = t.traced.clone();
    for &k in mirror.iter().step_by(3) {
        unresolved.resolved[k] = 0;
    }
    assert!(
        judge(Method::Compute, &r.frame, &unresolved)
            .unwrap_err()
            .contains("unresolved")
    );
    // No mirror at all (the eye-in-a-wall frame), for every method.
    let mut empty = t.traced.clone();
    empty.mask.fill(0);
    for m in Method::ALL {
        assert!(
            judge(m, &r.frame, &empty)
                .unwrap_err()
                .contains("no mirror pixel"),
            "{m}"
        );
    }
    // Half the mirror lost: a mask mismatch beyond the edges.
    let mut half = t.traced.clone();
    for &k in mirror.iter().step_by(2) {
        half.mask[k] = 0;
    }
    assert!(
        judge(Method::Ssr, &r.frame, &half)
            .unwrap_err()
            .contains("masks differ")
    );
    // The background where the room was (the far-vertex frame), off the mirror.
    let mut blank = t.traced.clone();
    for k in 0..blank.mask.len() {
        if blank.mask[k] == 0 {
            blank.colour[k] = Vec3::new(0.05, 0.05, 0.08);
        }
    }
    assert!(
        judge(Method::Envmap, &r.frame, &blank)
            .unwrap_err()
            .contains("differ in colour")
    );
    // A wrong reference: the other case's.
    let (_, r2, _) = &frames[1];
    assert!(judge(Method::Bvh, &r2.frame, &t.traced).is_err());
    assert!(judge(Method::ReflectionPoint, &r2.frame, &t.traced).is_err());
    // The twin judge: equal frames pass, a third of the mirror recoloured does not.
    judge_twin(&t.traced, &t.traced).unwrap();
    let mut recoloured = t.traced.clone();
    for &k in mirror.iter().step_by(3) {
        recoloured.colour[k] = Vec3::ONE - recoloured.colour[k];
    }
    assert!(
        judge_twin(&recoloured, &t.traced)
            .unwrap_err()
            .contains("changed")
    );
    // ...nor the same colours with a third of the mirror finished by the fallback.
    let mut fell_back = t.traced.clone();
    let mut flags = vec![0u8; fell_back.mask.len()];
    for &k in mirror.iter().step_by(3) {
        flags[k] = 1;
    }
    fell_back.fallback = Some(flags);
    assert!(judge_twin(&fell_back, &t.traced).is_err());
    // A NaN colour differs from every colour.
    assert!(differ(Vec3::new(f32::NAN, 0.5, 0.5), Vec3::splat(0.5)));
    assert!(!differ(Vec3::splat(0.5), Vec3::splat(0.51)));

    // Refusals.
    let anchors = vec!["mirror.obj:7".to_string(), "extent".to_string()];
    let clean = Run {
        code: Some(1),
        stderr: "[WARN  x] something\nerror: ./mirror.obj:7: vertex 1e30 is beyond 2^60\n".into(),
        ..Run::default()
    };
    judge_refusal(&clean, &anchors).unwrap();
    let vague = Run {
        stderr: "error: scene.toml:12: mesh[1].obj: mirror.obj holds no triangles\n".into(),
        ..clean.clone()
    };
    assert!(
        judge_refusal(&vague, &anchors)
            .unwrap_err()
            .contains("names none")
    );
    assert!(
        judge_refusal(&clean, &[])
            .unwrap_err()
            .contains("must render")
    );
    let panic = Run {
        code: Some(101),
        stderr: "thread 'main' panicked at src/x.rs:1:1:\nindex out of bounds\n".into(),
        ..Run::default()
    };
    assert!(
        judge_refusal(&panic, &anchors)
            .unwrap_err()
            .contains("not a clean refusal")
    );
    let left = Run {
        output: true,
        ..clean.clone()
    };
    assert!(
        judge_refusal(&left, &anchors)
            .unwrap_err()
            .contains("left its output")
    );
    let silent = Run {
        code: Some(1),
        stderr: "Error: internal\n".into(),
        ..Run::default()
    };
    assert!(judge_refusal(&silent, &anchors).is_err());

    // A required refusal (an `up` along the view): the loader's message passes; a frame, a
    // refusal without the field, at another line or from a later stage do not.
    let names: Vec<String> = [
        "scene.toml:27",
        "camera[0].up",
        "degrees from the view direction",
    ]
    .map(String::from)
    .to_vec();
    let up = Run {
        code: Some(1),
        stderr: "error: /tmp/c/scene.toml:27: camera[0].up: eye, target and up must span a \
                 view: up [0.1, 0.2, -0.97] lies 5.730e-4 degrees from the view direction \
                 [0.1, 0.2, -0.97] (the sine 1.0e-5 is below 1e-4)\n"
            .into(),
        ..Run::default()
    };
    judge_required_refusal(&up, &names).unwrap();
    let rendered = Run {
        code: Some(0),
        output: true,
        ..Run::default()
    };
    assert!(
        judge_required_refusal(&rendered, &names)
            .unwrap_err()
            .contains("must refuse")
    );
    let field = Run {
        stderr: up.stderr.replace("camera[0].up", "camera[0]"),
        ..up.clone()
    };
    assert!(
        judge_required_refusal(&field, &names)
            .unwrap_err()
            .contains("\"camera[0].up\"")
    );
    let line = Run {
        stderr: up.stderr.replace("scene.toml:27", "scene.toml:26"),
        ..up.clone()
    };
    assert!(
        judge_required_refusal(&line, &names)
            .unwrap_err()
            .contains("scene.toml:27")
    );
    let later = Run {
        stderr: "error: depth range: scene `x` is beyond f32 precision\n".into(),
        ..up.clone()
    };
    assert!(
        judge_required_refusal(&later, &names)
            .unwrap_err()
            .contains("names none")
    );
    assert!(judge_required_refusal(&panic, &names).is_err());

    // A false alarm on a legal n-gon: a warning naming a self-crossing polygon fails, other
    // warnings and lines do not.
    let quiet: Vec<String> = ["cross themselves", "degenerate"]
        .map(String::from)
        .to_vec();
    judge_quiet(
        "[WARN  cubetrace::scene] room.obj: a texture is missing\n[INFO  x] 0 degenerate\n",
        &quiet,
    )
    .unwrap();
    assert!(
        judge_quiet(
            "[WARN  cubetrace::scene::report] room.obj: polygons that cross themselves fanned \
             from their first corner (line 9)\n",
            &quiet
        )
        .unwrap_err()
        .contains("false alarm")
    );

    // The work counter: a huge triangle's walk at cube size 32 against an ordinary ray.
    let line = |t: &str| {
        format!(
            "[INFO  cubetrace::app::render] compute: 47 rays, subgroup size 8 (min 8), per ray mean/max: texels {t}, cells 46.3/64\n"
        )
    };
    judge_counter(&line("36.1/64"), 32, 1).unwrap();
    assert!(
        judge_counter(&line("1071.0/1888"), 32, 1)
            .unwrap_err()
            .contains("over the bound")
    );
    assert!(judge_counter("no such line", 32, 1).is_err());

    // The watchdog kills a process that does not end.
    let mut sleep = Command::new("sleep");
    sleep.arg("60");
    let run = run_with_watchdog(
        sleep,
        &root.path().join("sleep.log"),
        Duration::from_millis(300),
    );
    assert!(run.timed_out && run.seconds < 30.0, "{run:?}");
    assert!(judge_refusal(&run, &anchors).unwrap_err().contains("hang"));
}

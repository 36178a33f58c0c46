//! Shared by the test suites: a GPU context under the validation layer and the check that it
//! reported nothing; closed-form intersections for synthetic scenes ([`analytic`]); values as
//! bits for bit-for-bit comparisons ([`bits`]); one GPU frame of a scene ([`render`]); the built
//! binary run in a folder ([`binary`]).
//!
//! The suites are one crate per method (`tests/compute.rs`, `fragment`, which holds `envmap`,
//! `ssr`, `reflection_point`, `bvh`, `reference`) and one per shared concern (`tracer`,
//! `capture`, `bounded`, `frame`, `hard_cases`, `scene`, `placement`, `sequence`, `glossy`,
//! `bench`, `cli`, `model`, `vk_backbone`, `layout`, `records`). Crate `NAME` is `tests/NAME.rs`;
//! the files it gathers are its modules in `tests/NAME/`, and its doc says what each holds. A
//! helper two crates need lives here, once.
// Each test crate compiles this module and uses only part of it.
#![allow(dead_code)]

pub mod analytic;
pub mod binary;
pub mod bits;
pub mod hit_probe;
pub mod render;
pub mod selftest;
pub mod spirv_words;
pub mod trace_probe;

use cubetrace::vk::{ContextOptions, GpuContext};
use glam::Vec3;

/// The name under which the test harness lists test `name` of the module whose `module_path!()`
/// is `module_path`: the module path without the crate's name, as `--exact` takes it.
pub fn test_name(module_path: &str, name: &str) -> String {
    match module_path.split_once("::") {
        Some((_, module)) => format!("{module}::{name}"),
        None => name.to_string(),
    }
}

/// `render`'s arguments parsed from `line` (what follows `cubetrace render`), as the command
/// line parses them.
pub fn render_args(line: &[&str]) -> cubetrace::app::render::RenderArgs {
    use clap::Parser;
    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        render: cubetrace::app::render::RenderArgs,
    }
    let mut all = vec!["cubetrace"];
    all.extend_from_slice(line);
    Cli::parse_from(all).render
}

/// A context with the Khronos validation layer when it is installed; a missing driver fails the
/// test with the driver's install hint.
pub fn gpu_context() -> GpuContext {
    let ctx = GpuContext::new(ContextOptions::for_tests()).unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "device: {}; validation layer: {}; debug utils: {}",
        ctx.report().name,
        if ctx.validation_enabled() {
            "on"
        } else {
            "not installed, off"
        },
        ctx.debug_utils_enabled()
    );
    ctx
}

/// Asserts that the validation layer reported no error, then drops the context and asserts
/// again (leaks are reported when the device is destroyed).
pub fn finish_gpu(ctx: GpuContext) {
    let log = ctx.validation_log();
    for w in log.warnings() {
        eprintln!("validation warning: {w}");
    }
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

/// Asserts that the GPU context `fr` created for itself reported no validation error, then
/// drops the renderer and asserts again (leaks are reported when the device is destroyed).
/// Panics when `fr` has no GPU context: call it for GPU methods only.
pub fn finish_renderer(fr: cubetrace::render::FrameRenderer) {
    let ctx = fr.context().expect("a GPU method's renderer has a context");
    let log = ctx.validation_log();
    assert_eq!(
        ctx.validation_errors(),
        Vec::<String>::new(),
        "validation errors of the renderer's context"
    );
    drop(fr);
    assert_eq!(
        log.errors(),
        Vec::<String>::new(),
        "validation errors at the renderer's destruction"
    );
}

/// What the per-scene accuracy bounds judge, both lower bounds (a method that does better
/// passes): the share of mirror pixels that are correct (`1 - error`: in both masks, resolved,
/// on the reference's surface) and the PSNR over mirror pixels.
pub fn quality(r: &cubetrace::metrics::ErrorReport) -> (f64, f64) {
    (1.0 - r.error, r.psnr_db)
}

/// `traced` with its mirror pixels black: the PSNR bounds' negative. (Half brightness is no
/// negative: it moved these PSNRs by 0.1 to 1 dB, some upwards, the error being dominated by
/// wrong surfaces.)
pub fn blacked(traced: &cubetrace::metrics::Traced) -> cubetrace::metrics::Traced {
    let mut black = traced.clone();
    for (c, _) in black
        .colour
        .iter_mut()
        .zip(&traced.mask)
        .filter(|(_, m)| **m != 0)
    {
        *c = glam::Vec3::ZERO;
    }
    black
}

/// splitmix64 with a fixed seed: deterministic test inputs (no entropy).
pub struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
    pub fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

/// A cube map of `size` at the origin with deterministic distances in [0.5, 64.5) (from
/// `seed`): about 1 texel in 11 is +inf, and face `inf_face` (if any) is +inf entirely.
pub fn distance_cube(size: u32, seed: u64, inf_face: Option<u32>) -> cubetrace::cubemap::CubeMap {
    let mut c = cubetrace::cubemap::CubeMap::new(size, Vec3::ZERO);
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    c.fill(|t, _| {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let d = if Some(t.face) == inf_face || (s >> 33).is_multiple_of(11) {
            f32::INFINITY
        } else {
            0.5 + (s >> 40) as f32 / (1u64 << 24) as f32 * 64.0
        };
        (d, [0.0; 4])
    });
    c
}

/// Where the ray `o + t d` meets global triangle `tri`, in f64 (Möller-Trumbore, the
/// reference's test) with the barycentric bounds widened by `1e-6` (the f32 rounding of the
/// data the GPU and the CPU twin read): `None` for a triangle the ray misses, a degenerate one
/// (`det = 0`: zero area, or the ray in its plane) and `u32::MAX`.
pub fn meets(tracer: &cubetrace::reference::Tracer, o: Vec3, d: Vec3, tri: u32) -> Option<f64> {
    const TOL: f64 = 1e-6;
    let t = tracer.world.triangles.get(tri as usize)?;
    let [a, b, c] = t.map(|i| tracer.world.positions[i as usize].as_dvec3());
    let (o, d): (glam::DVec3, glam::DVec3) = (o.as_dvec3(), d.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= -TOL && v >= -TOL && u + v <= 1.0 + TOL && t > 0.0).then_some(t)
}

/// Writes built-in scene `name` into `dir` as `scene export` does; the scene file's path.
pub fn export_to(name: &str, dir: &std::path::Path) -> std::path::PathBuf {
    let scene = cubetrace::scene::builtin::by_name(name).unwrap();
    cubetrace::scene::export::export(&scene, dir).unwrap()
}

/// Corpus scene `name` as its file loads (`tests/scenes/NAME/scene.toml`).
pub fn corpus_scene(name: &str) -> cubetrace::scene::Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/scenes")
        .join(name)
        .join("scene.toml");
    cubetrace::scene::load_scene_file(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// PSNR (dB) of `got` against `truth` over the pixels of `mask`, linear RGB clamped to [0, 1]
/// (`metrics::psnr_over`), over more than 50 pixels.
pub fn psnr(got: &[Vec3], truth: &[Vec3], mask: &[u8]) -> f64 {
    let n = mask.iter().filter(|&&m| m != 0).count();
    assert!(n > 50, "{n} mirror pixels");
    cubetrace::metrics::psnr_over(got, truth, mask)
}

/// The glossy accuracy checks' predicate: the cone frame's PSNR `cone` is more than `min_gain`
/// dB above the mirror frame's `mirror`.
pub fn cone_gain(mirror: f64, cone: f64, min_gain: f64) -> Result<(), String> {
    if cone.is_finite() && cone > mirror + min_gain {
        Ok(())
    } else {
        Err(format!(
            "cone {cone:.2} dB, mirror {mirror:.2} dB: gain {:.2} <= {min_gain}",
            cone - mirror
        ))
    }
}

/// The placement search's default options judged by the centre criterion's twin
/// (`Scoring::Centre`): the checks of the search's steps, which that criterion scores, and of
/// the share it reaches with them.
pub fn centre_judged() -> cubetrace::placement::PlacementOptions {
    cubetrace::placement::PlacementOptions {
        scoring: cubetrace::placement::Scoring::Centre,
        ..cubetrace::placement::PlacementOptions::default()
    }
}

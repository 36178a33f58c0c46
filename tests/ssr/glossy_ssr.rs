//! `--method ssr` on glossy reflectors, the Hi-Z chapter's cone tracing
//! (`cpu::ssr_cone`, `spirv/ssr_visibility.wgsl`, `ssr_blur.wgsl`, `ssr_cone.wgsl`).
//!
//! - Only a scene with a glossy reflector creates the glossy passes (and the CMO colour capture
//!   and pre-filtered chain of the remainder); at the mirror cap (and
//!   without a glossy reflector) the frame is the mirror's, bit for bit. Negative: power 64
//!   changes it.
//! - GPU against the CPU twin on every built-in scene made glossy: the max pyramid, the
//!   visibility pyramid and the colour chain bit for bit; each glossy hit's cone colour within
//!   `CONE_TOLERANCE` (the device's tan, acos, exp2 and log2 are not Rust's). The twin reads
//!   what the GPU read: the G-buffer, and each record's hit pixel and final depth key (the trace
//!   itself is `tests/ssr.rs`'s). Negatives: a perturbed depth, colour texel or power shows.
//! - Hard cases: a cone wider than the screen (power 0), rays towards the camera (left to the
//!   fallback, which traces the mirror direction: their records are the mirror's), hits at the
//!   screen edge, power 1023 (closer to the mirror than power 64), a thin object in front of a
//!   far wall.
//! - Accuracy: cone ssr beats mirror ssr in PSNR against the reference (32x24, 256 spp) by
//!   bounds derived from measurement. Negatives: mirror ssr, and a lobe 4x too wide, fail the
//!   same check. The claim repeated at 48x36 against 1024 spp is ignored by default (minutes).
use crate::common;
use crate::with_thin_panel;
use common::bits::frame_bits;
use common::render::{first_frame, load_sized};
use common::{finish_gpu, gpu_context};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::cpu::cone::{self, ConeCmo};
use cubetrace::cpu::ssr::{self, Outcome};
use cubetrace::cpu::ssr_cone::{self, ConeInputs};
use cubetrace::cubemap::CubeMap;
use cubetrace::cubemap::pyramid::mip_len;
use cubetrace::film::{FilmSettings, PixelFilter};
use cubetrace::lobe;
use cubetrace::reference::Tracer;
use cubetrace::scene::{Scene, builtin};
use cubetrace::vk::GpuContext;
use cubetrace::vk::backend::shaders::{SSR_BLUR, SSR_VISIBILITY};
use cubetrace::vk::frame::{
    Fallback, GpuFrame, GpuRenderer, RECORD_HIT, RenderOptions, scene_ranges,
};
use cubetrace::vk::methods::ssr::ConeLevelParams;
use glam::{Mat4, Vec3, Vec4};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;

/// The tolerance of a cone colour (per channel, linear RGB): the device's `tan`, `acos`,
/// `exp2` and `log2` differ from Rust's by a few ulp, which moves the circles' radii and levels
/// by about 1e-6 relative; the trilinear colour is continuous in both, but the visibility and
/// Hi-Z cell is taken at `floor(level)` and under the circle's centre, so a radius on a level
/// or cell boundary may pick another cell (or end the walk one circle earlier): such a pixel
/// differs by up to a sample's share of the colour. At most `CONE_OUTLIERS` of the cones may
/// exceed `CONE_TOLERANCE`, none `CONE_OUTLIER_TOLERANCE`. Measured at 64x48 on the built-in
/// scenes: worst ordinary difference 1.4e-4, 1 outlier of 114 cones at 0.032.
const CONE_TOLERANCE: f32 = 1e-3;
const CONE_OUTLIERS: f64 = 0.02;
const CONE_OUTLIER_TOLERANCE: f32 = 0.1;

fn glossy(scene: &Scene, power: f32) -> Scene {
    let mut s = scene.clone();
    s.make_reflectors_glossy(power);
    s
}

/// One ssr frame with what the twin reads.
struct Rendered {
    frame: GpuFrame,
    /// G-buffer colour (rgba) and normal w per pixel.
    colour: Vec<Vec4>,
    normal_w: Vec<f32>,
    pyramid: Vec<f32>,
    /// The glossy passes' buffers (`None`: not created).
    cone: Option<(Vec<f32>, Vec<f32>, Vec<Vec4>)>,
    view_proj: Mat4,
    camera: Camera,
    background: Vec3,
    /// The CMOs' captures and pre-filtered chains (glossy scenes: the remainder's lookup).
    cubes: Vec<CubeMap>,
    cone_chains: Vec<Vec<[f32; 4]>>,
}

fn render(ctx: &GpuContext, scene: &Scene, camera: &Camera) -> Rendered {
    let options = RenderOptions {
        method: Method::Ssr,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let (frame, r) = first_frame(ctx, scene, camera, options, &scene.name);
    let n = frame.colour.len();
    let read = |img| {
        let bytes = ctx
            .read_image(img, ash::vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)
            .unwrap();
        let texels: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        texels[..n]
            .iter()
            .map(|c| Vec4::from_array(*c))
            .collect::<Vec<_>>()
    };
    let colour = read(&r.gbuffer().colour);
    let normal_w = read(&r.gbuffer().normal).iter().map(|n| n.w).collect();
    let passes = r.ssr_passes().expect("ssr passes");
    let pyramid = passes.read_pyramid(ctx).unwrap();
    let cone = passes.cone_passes().map(|c| {
        let b = c.read(ctx).unwrap();
        let chain = b.chain.into_iter().map(Vec4::from_array).collect();
        (b.max, b.visibility, chain)
    });
    let (near, _, _) = scene_ranges(scene, camera);
    let (cubes, cone_chains) = match r.cmo().cone() {
        Some(buf) => {
            let cubes = r.cmo().read_back(ctx).unwrap();
            let all: Vec<[f32; 4]> = ctx.read_buffer(buf).unwrap();
            let per = mip_len(cubes[0].size);
            let chains = (0..cubes.len())
                .map(|k| all[k * per..(k + 1) * per].to_vec())
                .collect();
            (cubes, chains)
        }
        None => (Vec::new(), Vec::new()),
    };
    Rendered {
        cubes,
        cone_chains,
        frame,
        colour,
        normal_w,
        pyramid,
        cone,
        view_proj: camera.view_proj(near),
        camera: camera.clone(),
        background: scene.background,
    }
}

/// The frame's outputs as bits: colour, mask, the mirror pixels' records.
fn bits(f: &GpuFrame) -> Vec<u32> {
    frame_bits(f, false)
}

#[test]
fn shared_structs_match_naga_layout() {
    let l = SSR_VISIBILITY.struct_layout("ConeLevel").unwrap();
    cubetrace::check_layout!(ConeLevelParams, l, [level, stage, pad0, pad1, background]).unwrap();
    assert_eq!(SSR_BLUR.struct_layout("ConeLevel"), Some(l));
}

#[test]
fn mirror_cap_keeps_the_mirrors_frame_and_creates_no_glossy_pass() {
    let ctx = gpu_context();
    let (mirror, cam) = load_sized("sphere-room", (32, 24));
    let mirror_frame = render(&ctx, &mirror, &cam);
    assert!(mirror_frame.cone.is_none());
    for power in [lobe::MIRROR_POWER, 5000.0] {
        let capped = render(&ctx, &glossy(&mirror, power), &cam);
        assert!(capped.cone.is_none(), "power {power}");
        assert!(
            bits(&mirror_frame.frame) == bits(&capped.frame),
            "power {power}"
        );
    }
    // Negative: power 64 creates the passes and changes the frame.
    let g = render(&ctx, &glossy(&mirror, 64.0), &cam);
    assert!(g.cone.is_some());
    assert!(bits(&mirror_frame.frame) != bits(&g.frame));
    finish_gpu(ctx);
}

/// The twin's inputs over the CPU-built buffers.
struct Twin {
    hiz: Vec<f32>,
    max: Vec<f32>,
    vis: Vec<f32>,
    chain: Vec<Vec4>,
}

fn twin(r: &Rendered) -> Twin {
    let (w, h) = (r.frame.width, r.frame.height);
    let level0: Vec<f32> = (0..r.frame.mask.len())
        .map(|k| {
            let p = r.frame.surface_position[k];
            ssr::depth_key(&r.view_proj, (!p.is_nan()).then_some(p))
        })
        .collect();
    let hiz = ssr::build_hiz(&level0, w, h);
    let (max, vis) = ssr_cone::build_visibility(&hiz, w, h);
    let chain =
        ssr_cone::build_colour_chain(&ssr_cone::chain_level0(&r.colour, r.background), w, h);
    Twin {
        hiz,
        max,
        vis,
        chain,
    }
}

fn differing<T: PartialEq>(a: &[T], b: &[T]) -> usize {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).filter(|(x, y)| x != y).count()
}

/// Per glossy hit pixel (not replaced by the reflector check): `(pixel, power, GPU colour, twin
/// cone)`.
fn cones(r: &Rendered, t: &Twin, power_shift: f32) -> Vec<(usize, f32, Vec3, ssr_cone::Cone)> {
    let (w, h) = (r.frame.width, r.frame.height);
    let inputs = ConeInputs {
        width: w,
        height: h,
        levels: ssr::hiz_levels(w, h),
        hiz: &t.hiz,
        hiz_max: &t.max,
        visibility: &t.vis,
        chain: &t.chain,
        tan_half: r.camera.tan_half_fov_y(),
    };
    let mut out = Vec::new();
    for (k, rec) in r.frame.records.iter().enumerate() {
        let nw = r.normal_w[k];
        if r.frame.mask[k] == 0 || nw > -1.0 || rec.status != RECORD_HIT || rec.checked != 0 {
            continue;
        }
        let power = (-1.0 - nw) + power_shift;
        let pixel = [k as u32 % w, k as u32 / w];
        let remainder = remainder(r, rec.origin.into(), rec.dir.into(), power);
        if let Some(c) =
            ssr_cone::cone_colour(&inputs, pixel, power, [rec.x, rec.y], rec.t, remainder)
        {
            out.push((k, power, Vec3::from_array(rec.colour), c));
        }
    }
    out
}

/// The remainder's colour as the GPU looks it up: `cone_envmap_colour` of the CMO nearest to
/// `origin` (the first on ties) along `dir`.
fn remainder(r: &Rendered, origin: Vec3, dir: Vec3, power: f32) -> Vec3 {
    let mut best = 0;
    for (k, c) in r.cubes.iter().enumerate() {
        if (origin - c.centre).length_squared() < (origin - r.cubes[best].centre).length_squared() {
            best = k;
        }
    }
    let cmo = ConeCmo {
        cube: &r.cubes[best],
        chain: &r.cone_chains[best],
        background: r.background,
    };
    cone::cone_envmap_colour(&cmo, dir, power)
}

fn worst(c: &[(usize, f32, Vec3, ssr_cone::Cone)]) -> f32 {
    c.iter()
        .map(|(_, _, gpu, cpu)| (*gpu - cpu.colour).abs().max_element())
        .fold(0.0, f32::max)
}

/// The twin check: at most `CONE_OUTLIERS` of the cones beyond `CONE_TOLERANCE`, none beyond
/// `CONE_OUTLIER_TOLERANCE`, and at least one cone.
fn within_tolerance(c: &[(usize, f32, Vec3, ssr_cone::Cone)]) -> Result<(), String> {
    let bad = (c.iter())
        .filter(|(_, _, gpu, cpu)| (*gpu - cpu.colour).abs().max_element() > CONE_TOLERANCE)
        .count();
    let w = worst(c);
    if !c.is_empty() && bad as f64 <= CONE_OUTLIERS * c.len() as f64 && w <= CONE_OUTLIER_TOLERANCE
    {
        Ok(())
    } else {
        Err(format!(
            "{bad} of {} cones beyond {CONE_TOLERANCE}, worst {w:e}",
            c.len()
        ))
    }
}

#[test]
fn gpu_matches_cpu_twin_on_every_builtin_scene() {
    let ctx = gpu_context();
    for (name, _) in builtin::NAMES {
        for power in [0.0, 64.0] {
            let (s, cam) = load_sized(name, (WIDTH, HEIGHT));
            let r = render(&ctx, &glossy(&s, power), &cam);
            let (max, vis, chain) = r.cone.as_ref().expect("glossy passes");
            let t = twin(&r);
            assert_eq!(r.pyramid, t.hiz, "{name}: min pyramid");
            assert_eq!(differing(max, &t.max), 0, "{name}: max pyramid");
            assert_eq!(differing(vis, &t.vis), 0, "{name}: visibility");
            assert_eq!(differing(chain, &t.chain), 0, "{name}: colour chain");
            let c = cones(&r, &t, 0.0);
            let bad = (c.iter())
                .filter(|(_, _, gpu, cpu)| (*gpu - cpu.colour).abs().max_element() > CONE_TOLERANCE)
                .count();
            eprintln!(
                "{name} power {power}: {} glossy hits, {bad} beyond {CONE_TOLERANCE}, worst cone difference {:e}, mean weight {:.3}, mean circles {:.2}",
                c.len(),
                worst(&c),
                c.iter().map(|x| x.3.weight).sum::<f32>() / c.len().max(1) as f32,
                c.iter().map(|x| x.3.samples as f32).sum::<f32>() / c.len().max(1) as f32,
            );
            within_tolerance(&c).unwrap_or_else(|e| panic!("{name} power {power}: {e}"));
            // Negatives. A depth one key step nearer at one pixel changes the max pyramid or
            // the visibility; a colour texel changes the chain; another power (+64) the cones.
            let k = c[0].0;
            let mut level0 = t.hiz[..(WIDTH * HEIGHT) as usize].to_vec();
            level0[k] *= 1.5;
            let (max2, vis2) =
                ssr_cone::build_visibility(&ssr::build_hiz(&level0, WIDTH, HEIGHT), WIDTH, HEIGHT);
            assert!(differing(max, &max2) + differing(vis, &vis2) > 0, "{name}");
            let mut colours = r.colour.clone();
            colours[k] += Vec4::new(0.5, 0.0, 0.0, 0.0);
            let chain2 = ssr_cone::build_colour_chain(
                &ssr_cone::chain_level0(&colours, r.background),
                WIDTH,
                HEIGHT,
            );
            assert!(differing(chain, &chain2) > 0, "{name}");
            let shifted = cones(&r, &t, 64.0);
            let e = within_tolerance(&shifted)
                .expect_err(&format!("negative {name} power {power}: power + 64 passes"));
            eprintln!("{name} power {power}, negative power + 64: {e}");
        }
    }
    finish_gpu(ctx);
}

/// Mean over the pixels of `pick` of the largest channel difference between two frames.
fn mean_difference(a: &GpuFrame, b: &GpuFrame, pick: &[usize]) -> f32 {
    let sum: f32 = (pick.iter())
        .map(|&k| (a.colour[k] - b.colour[k]).abs().max_element())
        .sum();
    sum / pick.len().max(1) as f32
}

#[test]
fn hard_cases() {
    let ctx = gpu_context();
    let mut edge_hits = 0;
    for name in ["default", "sphere-room", "torus"] {
        let (s, cam) = load_sized(name, (WIDTH, HEIGHT));
        let mirror = render(&ctx, &s, &cam);
        let g64 = render(&ctx, &glossy(&s, 64.0), &cam);
        let (w, h) = (WIDTH, HEIGHT);
        let hits: Vec<usize> = (0..g64.frame.mask.len())
            .filter(|&k| g64.frame.mask[k] != 0 && g64.frame.records[k].status == RECORD_HIT)
            .collect();
        // Rays towards the camera (and every other ray ssr leaves unresolved) are not cone
        // traced: their records are the mirror's, and the fallback traces the mirror direction.
        let mut towards = 0;
        for k in 0..g64.frame.mask.len() {
            let rec = &g64.frame.records[k];
            if g64.frame.mask[k] == 0 || rec.status == RECORD_HIT {
                continue;
            }
            towards += usize::from(rec.face == Outcome::TowardsCamera as u32);
            assert_eq!(
                bytemuck::bytes_of(rec),
                bytemuck::bytes_of(&mirror.frame.records[k]),
                "{name}: unresolved pixel {k}"
            );
        }
        assert!(towards > 0, "{name}: no ray towards the camera");
        // Negative: the hits' colours do change.
        assert!(
            mean_difference(&g64.frame, &mirror.frame, &hits) > 1e-3,
            "{name}"
        );
        // Power 1023, just below the cap: a narrow cone (3.0 degrees), closer to the mirror
        // than power 64. Not equal: the 7 circles step back by 2 r = 0.105 of the remaining
        // length each, so they reach back to half the ray (0.95 .. 0.49 of it), and the cap's
        // jump to the mirror at 1024 is the chapter's.
        let g1023 = render(&ctx, &glossy(&s, 1023.0), &cam);
        let near = mean_difference(&g1023.frame, &mirror.frame, &hits);
        let far = mean_difference(&g64.frame, &mirror.frame, &hits);
        eprintln!(
            "{name}: mean difference from the mirror at power 1023 {near:.4}, at 64 {far:.4}"
        );
        assert!(near < far, "{name}: {near} {far}");
        // Power 0: a cone of 75.9 degrees, wider than the screen; the circles' levels clamp to
        // the top level and the colours stay finite and within the twin's tolerance (above).
        let g0 = render(&ctx, &glossy(&s, 0.0), &cam);
        let t0 = twin(&g0);
        let c0 = cones(&g0, &t0, 0.0);
        assert!(!c0.is_empty());
        for (k, _, gpu, cpu) in &c0 {
            assert!(
                gpu.is_finite() && cpu.weight >= 0.0 && cpu.weight <= 1.0,
                "{name} {k}"
            );
        }
        assert!(
            c0.iter().any(|c| c.3.samples < ssr_cone::CONE_SAMPLES),
            "{name}"
        );
        // Hits at the screen edge: the twin agrees there too (cells and taps clamp).
        let t64 = twin(&g64);
        for (k, _, gpu, cpu) in cones(&g64, &t64, 0.0) {
            let rec = &g64.frame.records[k];
            if rec.x == 0 || rec.y == 0 || rec.x == w - 1 || rec.y == h - 1 {
                edge_hits += 1;
                assert!((gpu - cpu.colour).abs().max_element() <= CONE_OUTLIER_TOLERANCE);
            }
        }
    }
    eprintln!("hits on the screen edge: {edge_hits}");
    assert!(edge_hits > 0, "no hit on the screen edge");
    finish_gpu(ctx);
}

/// PSNR (dB) of `got` against `truth` over the pixels of `mask`, linear RGB clamped to [0, 1]
/// (`metrics::psnr_over`).
fn psnr(got: &[Vec3], truth: &[Vec3], mask: &[u8]) -> f64 {
    // At most 120 dB (an MSE floor of 1e-12), also over no pixel.
    cubetrace::metrics::psnr_over(got, truth, mask).min(120.0)
}

/// An ssr frame (envmap fallback) of `scene`.
fn ssr_frame(ctx: &GpuContext, scene: &Scene, cam: &Camera) -> GpuFrame {
    let options = RenderOptions {
        method: Method::Ssr,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let mut r = GpuRenderer::new(ctx, scene, cam, options).unwrap_or_else(|e| panic!("{e}"));
    r.render(ctx).unwrap_or_else(|e| panic!("{e}"))
}

/// PSNRs over the mirror pixels against the reference at `spp` (box filter) of `name` made
/// glossy at `power`, at `size`: mirror ssr's (the scene traced as the mirror), then cone ssr's
/// with the reflectors at each power of `lobes` (the truth unchanged).
fn ssr_scores(
    ctx: &GpuContext,
    name: &str,
    power: f32,
    size: (u32, u32),
    spp: u32,
    lobes: &[f32],
) -> (f64, Vec<f64>) {
    let (s, cam) = load_sized(name, size);
    let g = glossy(&s, power);
    let film = FilmSettings {
        spp,
        filter: PixelFilter::Box,
    };
    let truth =
        cubetrace::render::samples::reference_frame(&g, &Tracer::new(&g), &cam, 1, film, false).0;
    let db = |f: &GpuFrame| psnr(&f.colour, &truth.colour, &truth.mask);
    let mirror = db(&ssr_frame(ctx, &s, &cam));
    let cones = (lobes.iter())
        .map(|&p| db(&ssr_frame(ctx, &glossy(&s, p), &cam)))
        .collect();
    (mirror, cones)
}

/// Cone ssr beats mirror ssr against the reference (PSNR over the mirror pixels, 256 spp, box
/// filter), 32x24, power 64. Measured: sphere-room mirror 16.81, cone 18.73 (gain 1.92); torus
/// 17.62, 20.15 (2.53); default 16.95, 18.37 (1.42). Every built-in scene gains at every power
/// of 16, 64, 256 at this size, but bowl only 0.2 dB: these three gain the most. The bound is
/// each measured gain less 0.2 dB: the frames and the reference are deterministic, so the
/// margin only absorbs another device's transcendental functions. Negatives, through the same
/// check: the mirror ssr frame does not beat itself, and on torus the lobe of power 16 (4x too
/// wide, 17.84 dB, gain 0.22) fails. (Other wrong lobes are no negative at this size: torus at
/// power 256 scores 19.89, sphere-room at 256 18.57, within a few tenths of the right lobe.)
#[test]
fn cone_ssr_beats_mirror_ssr_small() {
    let ctx = gpu_context();
    for (name, min_gain, wide_fails) in [
        ("sphere-room", 1.7, false),
        ("torus", 2.3, true),
        ("default", 1.2, false),
    ] {
        let power = 64.0;
        let (mirror, cones) = ssr_scores(&ctx, name, power, (32, 24), 256, &[power, power / 4.0]);
        let (cone, wide) = (cones[0], cones[1]);
        eprintln!(
            "{name} power {power}, 32x24: mirror ssr {mirror:.2} dB, cone ssr {cone:.2}, \
             power / 4 {wide:.2}"
        );
        common::cone_gain(mirror, cone, min_gain).unwrap_or_else(|e| panic!("{name}: {e}"));
        // Negatives.
        common::cone_gain(mirror, mirror, min_gain).expect_err("negative: mirror ssr beats itself");
        if wide_fails && common::cone_gain(mirror, wide, min_gain).is_ok() {
            panic!("negative {name}: power / 4 passes ({wide:.2} dB)");
        }
    }
    finish_gpu(ctx);
}

/// `cone_ssr_beats_mirror_ssr_small`'s claim repeated at 48x36 against the converged
/// reference (1024 spp; `GLOSSY_SSR_SPP` overrides): at power 64 cone ssr beats mirror ssr on
/// sphere-room, torus and default by more than 1.3 dB (measured: 1.70, 1.86, 1.56). Prints the
/// table of every built-in scene at powers 16, 64, 256, which asserts nothing more: cone ssr
/// does not gain everywhere (torus at power 16 loses 0.34 dB, bowl gains under 0.1). Slow
/// (the reference): `cargo test --release --test ssr -- --ignored psnr --nocapture`.
#[test]
#[ignore = "a minute: repeats cone_ssr_beats_mirror_ssr_small at 48x36 against 1024-spp references"]
fn psnr_against_the_converged_reference() {
    let ctx = gpu_context();
    let spp: u32 = std::env::var("GLOSSY_SSR_SPP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1024);
    println!("| scene | power | mirror ssr (dB) | cone ssr (dB) |");
    println!("|---|---|---|---|");
    let mut failed = Vec::new();
    for (name, _) in builtin::NAMES {
        for power in [16.0, 64.0, 256.0] {
            let (a, b) = ssr_scores(&ctx, name, power, (48, 36), spp, &[power]);
            let b = b[0];
            println!("| {name} | {power} | {a:.2} | {b:.2} |");
            let checked = power == 64.0 && ["sphere-room", "torus", "default"].contains(name);
            if let (true, Err(e)) = (checked, common::cone_gain(a, b, 1.3)) {
                failed.push(format!("{name} {power}: {e}"));
            }
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
    finish_gpu(ctx);
}

#[test]
fn thin_object_in_front_of_a_far_wall() {
    // A min/max pyramid knows a pixel's nearest depth only: at level 0 the panel's max is its
    // front, so a cone sphere behind the panel counts as fully inside it (weight 1), as the
    // chapter's infinitely thick surfaces; coarser cells span panel to wall. The twin agrees
    // there too, and the panel shows in the glossy reflection.
    let ctx = gpu_context();
    let s = with_thin_panel();
    let mut cam = s.camera(None).unwrap().clone();
    (cam.width, cam.height) = (WIDTH, HEIGHT);
    let g = render(&ctx, &glossy(&s, 64.0), &cam);
    let (max, vis, chain) = g.cone.as_ref().expect("glossy passes");
    let t = twin(&g);
    assert_eq!(differing(max, &t.max), 0);
    assert_eq!(differing(vis, &t.vis), 0);
    assert_eq!(differing(chain, &t.chain), 0);
    let c = cones(&g, &t, 0.0);
    within_tolerance(&c).unwrap_or_else(|e| panic!("{e}"));
    // Negative: without the panel the glossy reflections differ.
    let plain = render(&ctx, &glossy(&builtin::sphere_room(), 64.0), &cam);
    let hits: Vec<usize> = c.iter().map(|x| x.0).collect();
    assert!(mean_difference(&g.frame, &plain.frame, &hits) > 1e-3);
    finish_gpu(ctx);
}

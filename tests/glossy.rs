//! Glossy reflectors: the specular power, the Monte Carlo reference and
//! `--method bvh`'s lobe.
//! - The mirror cap: a reflector of specular power 1024 or more renders the mirror's frame bit for
//!   bit with every method (the reference too). Negative: power 64 changes the reference's and
//!   `bvh`'s frames. The methods that cannot sample the lobe render the glossy scene as the
//!   mirror, and warn (`glossy::method_warning`).
//! - Scene input: MTL `Ns` is honoured only where the scene file says `specular_power = "mtl"`,
//!   a number overrides it, 1024 and above is a mirror; bad values (a negative or non-finite
//!   power, an unknown word, a power on a non-reflector, a missing MTL `Ns`) are
//!   errors naming the file, the line and the field. The built-in glossy scene exports and loads
//!   back to the same content. Negatives: another power is another content.
//! - The reference's Monte Carlo integral is deterministic (runs, thread counts) and its error
//!   against a converged image (1024 spp) falls with spp. Negatives: another sample key changes
//!   the frame; a wrong lobe (power 4x, or none: the mirror) stays far from the truth.
//! - `bvh` draws the reference's directions (same hits at one sample) and its frame converges to
//!   the converged reference; a wrong exponent (4x) does not.
//!
//! This crate also holds, each in its module of `tests/glossy/`: `glossy_cone` (cone tracing on the
//! cube maps: the pre-filtered chain and the cone lookups against their CPU twins).
mod common;

#[path = "glossy/glossy_cone.rs"]
mod glossy_cone;

use common::bits::{frame_bits, vec3_bits};
use common::render::first_frame;
use common::render_args as args;
use common::{finish_gpu, gpu_context, psnr};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::film::{FilmSettings, PixelFilter};
use cubetrace::lobe;
use cubetrace::reference::{self, Tracer};
use cubetrace::render::{FrameRenderer, glossy, samples};
use cubetrace::scene::{self, Scene, builtin};
use cubetrace::vk::frame::{Fallback, GpuFrame, RenderOptions};
use glam::Vec3;

const WIDTH: u32 = 32;
const HEIGHT: u32 = 24;

/// A built-in scene at 32x24 with small CMOs, and its camera.
fn small(name: &str) -> (Scene, Camera) {
    common::render::scene_at(name, 32, None, (WIDTH, HEIGHT))
}

/// The scene with every reflector's material at specular power `power`.
/// `sphere-room-glossy` at 32x24, its camera narrowed onto the sphere (which then fills most of
/// the frame, so that the lobe spans pixels).
fn glossy_close() -> (Scene, Camera) {
    let (mut s, mut cam) = small("sphere-room-glossy");
    cam.target = Vec3::new(0.0, 1.2, 0.0);
    cam.fov_y_deg = 30.0;
    s.cameras = vec![cam.clone()];
    (s, cam)
}

fn with_power(scene: &Scene, power: Option<f32>) -> Scene {
    let mut s = scene.clone();
    let reflected: Vec<u32> = (s.meshes.iter())
        .filter(|m| m.reflector)
        .flat_map(|m| m.parts.iter().map(|p| p.material))
        .collect();
    for m in reflected {
        s.materials[m as usize].specular_power = power;
    }
    s
}

fn reference_bits(f: &reference::Frame) -> Vec<u32> {
    let mut out = vec3_bits(&f.colour);
    out.extend(vec3_bits(&f.hit_position));
    out.extend(&f.triangle);
    out.extend(f.mask.iter().map(|&m| u32::from(m)));
    out
}

fn gpu_frame(
    scene: &Scene,
    camera: &Camera,
    method: Method,
    ctx: &cubetrace::vk::GpuContext,
) -> GpuFrame {
    let options = RenderOptions {
        method,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    first_frame(ctx, scene, camera, options, &method.to_string()).0
}

/// The reference's filtered frame at `spp` samples (box filter), as `render --spp` makes it.
fn reference_at(scene: &Scene, tracer: &Tracer, camera: &Camera, spp: u32) -> reference::Frame {
    let film = FilmSettings {
        spp,
        filter: PixelFilter::Box,
    };
    samples::reference_frame(scene, tracer, camera, 1, film, false).0
}

/// At and above the cap every method renders the mirror's frame, bit for bit; the reference too.
/// Negative: power 64 changes the reference's, `bvh`'s and the cone-traced `fragment` and
/// `compute` frames. The other methods render the glossy scene exactly as the mirror (they trace
/// the mirror direction), and say so.
#[test]
fn mirror_cap_is_the_mirrors_frame_for_every_method() {
    let (mirror, cam) = small("sphere-room");
    let capped = with_power(&mirror, Some(lobe::MIRROR_POWER));
    let far = with_power(&mirror, Some(5000.0));
    let glossy = with_power(&mirror, Some(64.0));
    let t = Tracer::new(&mirror);
    let want = reference_bits(&reference::render(&mirror, &t, &cam, 1));
    for s in [&capped, &far] {
        assert!(want == reference_bits(&reference::render(s, &Tracer::new(s), &cam, 1)));
    }
    let g = reference::render(&glossy, &Tracer::new(&glossy), &cam, 1);
    assert!(want != reference_bits(&g), "negative: power 64 is glossy");

    let ctx = gpu_context();
    for method in Method::ALL.into_iter().filter(|m| m.is_gpu()) {
        let mirror_bits = frame_bits(&gpu_frame(&mirror, &cam, method, &ctx), true);
        let at_cap = frame_bits(&gpu_frame(&capped, &cam, method, &ctx), true);
        assert!(mirror_bits == at_cap, "{method}: the cap changed the frame");
        let on_glossy = frame_bits(&gpu_frame(&glossy, &cam, method, &ctx), true);
        let warning = glossy::method_warning(&glossy, method, 1);
        assert_eq!(glossy::method_warning(&mirror, method, 1), None, "{method}");
        if matches!(method, Method::Fragment | Method::Compute) {
            // Cone traced (tests/glossy/glossy_cone.rs): another frame, no warning.
            assert!(
                mirror_bits != on_glossy,
                "negative: {method} cone traces the lobe"
            );
            assert_eq!(warning, None);
            let over = glossy::method_warning(&glossy, method, 2).unwrap_or_default();
            assert!(over.contains("--bounces 2"), "{over}");
        } else if method == Method::Ssr {
            // ssr cone traces the lobe (tests/ssr/glossy_ssr.rs).
            assert!(mirror_bits != on_glossy, "negative: ssr renders the lobe");
            assert_eq!(warning, None);
        } else if method == Method::Bvh {
            assert!(mirror_bits != on_glossy, "negative: bvh samples the lobe");
            assert_eq!(warning, None);
            let over = glossy::method_warning(&glossy, method, 2).unwrap_or_default();
            assert!(over.contains("--bounces 2"), "{over}");
        } else {
            // Traced as a mirror: the same frame, and a warning naming the method.
            assert!(
                mirror_bits == on_glossy,
                "{method}: the glossy scene is traced as the mirror"
            );
            let w = warning.unwrap_or_default();
            assert!(
                w.contains(&format!("--method {method}")) && w.contains("mirror direction only"),
                "{w}"
            );
        }
    }
    assert_eq!(glossy::method_warning(&glossy, Method::Reference, 3), None);
    finish_gpu(ctx);
}

const OBJ: &str = "mtllib m.mtl\nusemtl shiny\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3 4\n";

/// A scene file around a reflector `quad.obj` whose MTL is `mtl`, with `mesh` lines added to its
/// `[[mesh]]`; the loaded scene or the error's text.
fn load_with(mtl: &str, mesh: &str) -> Result<Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("quad.obj"), OBJ).unwrap();
    std::fs::write(dir.path().join("m.mtl"), mtl).unwrap();
    let toml = format!(
        "name = \"g\"\n\n[[mesh]]\nobj = \"quad.obj\"\n{mesh}\n\n[[camera]]\neye = [0, 2, 3]\ntarget = [0, 0, 0]\nresolution = [32, 24]\n"
    );
    std::fs::write(dir.path().join("scene.toml"), toml).unwrap();
    scene::load_scene_file(&dir.path().join("scene.toml")).map_err(|e| e.to_string())
}

fn power_of(s: &Scene) -> Option<f32> {
    s.materials[s.meshes[0].parts[0].material as usize].specular_power
}

/// MTL `Ns` and the scene file's `specular_power`, and their errors.
#[test]
fn specular_power_from_mtl_and_scene_file() {
    let ns = "newmtl shiny\nKd 0.8 0.8 0.8\nNs 250\n";
    let ok = |mtl: &str, mesh: &str| load_with(mtl, mesh).unwrap_or_else(|e| panic!("{e}"));
    // An exporter's default Ns leaves a mirror a mirror.
    assert_eq!(power_of(&ok(ns, "reflector = true")), None);
    assert_eq!(
        power_of(&ok(ns, "reflector = true\nspecular_power = \"mtl\"")),
        Some(250.0)
    );
    assert_eq!(
        power_of(&ok(ns, "reflector = true\nspecular_power = 32")),
        Some(32.0)
    );
    assert_eq!(
        power_of(&ok(ns, "reflector = true\nspecular_power = 0")),
        Some(0.0)
    );
    // The cap: a mirror.
    assert_eq!(
        power_of(&ok(ns, "reflector = true\nspecular_power = 1024")),
        None
    );
    let high = "newmtl shiny\nNs 2000\n";
    assert_eq!(
        power_of(&ok(high, "reflector = true\nspecular_power = \"mtl\"")),
        None
    );
    // No Ns: a mirror.
    let plain = "newmtl shiny\nKd 0.8 0.8 0.8\n";
    assert_eq!(
        power_of(&ok(plain, "reflector = true\nspecular_power = \"mtl\"")),
        None
    );
    // A non-reflector has none, whatever its MTL says.
    assert_eq!(power_of(&ok(ns, "")), None);

    // Errors name the file, the line and the field (the mesh's line 5 holds the power).
    for (mesh, why) in [
        (
            "reflector = true\nspecular_power = -1",
            "-1 is not a specular power",
        ),
        (
            "reflector = true\nspecular_power = nan",
            "NaN is not a specular power",
        ),
        (
            "reflector = true\nspecular_power = inf",
            "inf is not a specular power",
        ),
        (
            "reflector = true\nspecular_power = \"shiny\"",
            "'shiny' is not a number",
        ),
        ("specular_power = 8", "only a reflector"),
    ] {
        let e = load_with(ns, mesh).expect_err(mesh);
        let line = if mesh.starts_with("reflector") { 6 } else { 5 };
        assert!(
            e.contains(&format!("scene.toml:{line}"))
                && e.contains("mesh[0].specular_power")
                && e.contains(why),
            "{mesh}: {e}"
        );
    }
    // Exporters' odd `Ns` values load: Blender 2.79's negative one is taken as 0, a value
    // that is not one finite number is ignored (the reflector stays a mirror).
    let mtl_mesh = "reflector = true\nspecular_power = \"mtl\"";
    assert_eq!(
        power_of(&ok("newmtl shiny\n\nNs -1.960784\n", mtl_mesh)),
        Some(0.0)
    );
    for mtl in [
        "newmtl shiny\nNs\n",
        "newmtl shiny\nNs 1 2\n",
        "newmtl shiny\nNs nan\n",
        "newmtl shiny\nNs x\n",
    ] {
        assert_eq!(power_of(&ok(mtl, mtl_mesh)), None, "{mtl}");
    }
    // Negative: a good power loads.
    assert!(load_with("newmtl shiny\nNs 3\n", "reflector = true").is_ok());
}

/// The built-in glossy scene exports and loads back to the same content, its power included
/// (through `Ns` and `specular_power = "mtl"`). Negative: another power is another content.
#[test]
fn glossy_builtin_exports_and_loads_back() {
    let s = builtin::by_name("sphere-room-glossy").expect("built-in");
    assert!(builtin::all().any(|(n, _)| *n == "sphere-room-glossy"));
    assert!(
        !builtin::NAMES
            .iter()
            .any(|(n, _)| *n == "sphere-room-glossy")
    );
    assert_eq!(s.glossy_reflectors(), vec!["mirror-sphere"]);
    let dir = tempfile::tempdir().unwrap();
    let path = scene::export::export(&s, dir.path()).unwrap_or_else(|e| panic!("{e}"));
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("specular_power = \"mtl\""), "{text}");
    let back = scene::load_scene_file(&path).unwrap_or_else(|e| panic!("{e}"));
    s.compare_content(&back).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.glossy_reflectors(), vec!["mirror-sphere"]);
    let other = with_power(&back, Some(65.0));
    assert!(s.compare_content(&other).is_err(), "negative: power 65");
    let mirror = with_power(&back, None);
    assert!(s.compare_content(&mirror).is_err(), "negative: the mirror");
}

/// The Monte Carlo reference: deterministic, and its error against the converged image (1024
/// spp) falls with spp (printed: the table of the README). Negatives: another sample key, a
/// lobe of 4x the power and the mirror stay away from the truth.
#[test]
fn reference_lobe_is_deterministic_and_converges() {
    let (s, cam) = glossy_close();
    let t = Tracer::new(&s);
    let a = reference_at(&s, &t, &cam, 4);
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| reference_at(&s, &t, &cam, 4));
    assert!(reference_bits(&a) == reference_bits(&b), "thread counts");
    assert!(
        reference_bits(&a) == reference_bits(&reference_at(&s, &t, &cam, 4)),
        "runs"
    );
    let bar = indicatif::ProgressBar::hidden();
    let k0 = reference::render_sample(&s, &t, &cam, 1, lobe::sample_key(1, 0), &bar);
    let k1 = reference::render_sample(&s, &t, &cam, 1, lobe::sample_key(1, 0) + 1, &bar);
    assert!(
        reference_bits(&k0) != reference_bits(&k1),
        "negative: the key counts"
    );
    assert!(reference_bits(&k0) == reference_bits(&reference_at(&s, &t, &cam, 1)));

    let truth = reference_at(&s, &t, &cam, 1024);
    let mask = &truth.mask;
    let mut table = Vec::new();
    for spp in [1u32, 4, 16, 64, 256] {
        table.push((
            spp,
            psnr(&reference_at(&s, &t, &cam, spp).colour, &truth.colour, mask),
        ));
    }
    eprintln!(
        "reference, sphere-room-glossy 32x24 (close), PSNR over mirror pixels against 1024 spp:"
    );
    for (spp, db) in &table {
        eprintln!("  spp {spp:4}: {db:.2} dB");
    }
    // Each 4x the samples: about 6 dB for an unbiased estimator; at least 3.5 here.
    for w in table.windows(2) {
        assert!(w[1].1 > w[0].1 + 3.5, "{table:?}");
    }
    // A wrong lobe stops gaining: its bias stays.
    let (at64, at256) = (table[3].1, table[4].1);
    let mut wrongs = Vec::new();
    for (what, wrong) in [
        (
            "power 256",
            with_power(&s, Some(4.0 * builtin::GLOSSY_POWER)),
        ),
        (
            "power 16",
            with_power(&s, Some(0.25 * builtin::GLOSSY_POWER)),
        ),
        ("the mirror", with_power(&s, None)),
    ] {
        let t = Tracer::new(&wrong);
        let db = |spp| {
            psnr(
                &reference_at(&wrong, &t, &cam, spp).colour,
                &truth.colour,
                mask,
            )
        };
        let (db64, db256) = (db(64), db(256));
        eprintln!("  negative, {what}: {db64:.2} dB at 64 spp, {db256:.2} dB at 256");
        wrongs.push((what, db64, db256));
    }
    for (what, db64, db256) in wrongs {
        assert!(db256 < at256 - 3.0, "{what}: {db256} against {at256}");
        assert!(
            db256 - db64 < 0.5 * (at256 - at64),
            "{what}: {db64} to {db256}"
        );
    }
}

/// `bvh` takes the reference's directions (one sample: the same hit and colour on nearly every
/// glossy pixel; another key: not) and converges to the converged reference as spp grows; the
/// lobe of 4x the power does not.
#[test]
fn bvh_converges_to_the_reference() {
    let (s, cam) = glossy_close();
    let t = Tracer::new(&s);
    let bvh = |scene: &Scene, spp: u32| {
        let n = spp.to_string();
        let line = ["sphere-room-glossy", "--method", "bvh", "--spp", &n];
        let mut fr =
            FrameRenderer::new(&args(&line), scene, &cam).unwrap_or_else(|e| panic!("{e}"));
        let f = fr.render(scene, &cam).unwrap_or_else(|e| panic!("{e}"));
        common::finish_renderer(fr);
        f
    };
    // One sample: the directions are the reference's.
    let one = bvh(&s, 1);
    let g = one.gpu.as_ref().expect("a GPU frame");
    let same = |r: &reference::Frame| {
        let (mut n, mut agree) = (0, 0);
        for k in 0..r.mask.len() {
            if r.mask[k] == 0 || g.mask[k] == 0 {
                continue;
            }
            n += 1;
            let p = Vec3::from_array(g.records[k].point);
            let close = (g.colour[k] - r.colour[k]).abs().max_element() < 1e-3;
            let hit = match r.hit_position[k] {
                h if h.is_nan() => g.records[k].triangle == u32::MAX,
                h => (h - p).length() < 1e-3,
            };
            agree += usize::from(close && hit);
        }
        (agree, n)
    };
    let bar = indicatif::ProgressBar::hidden();
    let r1 = reference::render_sample(&s, &t, &cam, 1, lobe::sample_key(1, 0), &bar);
    let (agree, n) = same(&r1);
    eprintln!("bvh at 1 spp: {agree} of {n} glossy pixels as the reference's sample");
    assert!(n > 50 && agree * 100 >= n * 97, "{agree} of {n}");
    let other = reference::render_sample(&s, &t, &cam, 1, lobe::sample_key(1, 0) + 7, &bar);
    let (agree, n) = same(&other);
    assert!(
        agree * 100 < n * 60,
        "negative: another key agrees on {agree} of {n}"
    );

    let truth = reference_at(&s, &t, &cam, 1024);
    let mut table = Vec::new();
    for spp in [1u32, 4, 16, 64, 256] {
        let f = bvh(&s, spp);
        table.push((spp, psnr(f.colour(), &truth.colour, &truth.mask)));
        if spp == 16 {
            // The same estimate as the reference's at 16 spp, up to rounding.
            let r = reference_at(&s, &t, &cam, 16);
            let db = psnr(f.colour(), &r.colour, &truth.mask);
            assert!(db > 50.0, "bvh against the reference at 16 spp: {db} dB");
        }
    }
    let wrong = with_power(&s, Some(4.0 * builtin::GLOSSY_POWER));
    let (w64, w256) = (
        psnr(bvh(&wrong, 64).colour(), &truth.colour, &truth.mask),
        psnr(bvh(&wrong, 256).colour(), &truth.colour, &truth.mask),
    );
    eprintln!("bvh, sphere-room-glossy 32x24 (close), PSNR against the reference at 1024 spp:");
    for (spp, db) in &table {
        eprintln!("  spp {spp:4}: {db:.2} dB");
    }
    eprintln!("  negative, power 256: {w64:.2} dB at 64 spp, {w256:.2} dB at 256");
    for w in table.windows(2) {
        assert!(w[1].1 > w[0].1 + 3.5, "{table:?}");
    }
    // The wrong lobe: below, and it stops gaining.
    let (at64, at256) = (table[3].1, table[4].1);
    assert!(w256 < at256 - 3.0, "{w256} against {at256}");
    assert!(w256 - w64 < 0.5 * (at256 - at64), "{w64} to {w256}");
}

//! `cubetrace scene export` round trip, judged by rendering: every built-in scene, exported and
//! loaded back, renders byte-identically to the built-in itself, with the reference and with
//! `--method compute` (every pixel's colour bits, mask and surface point, every mirror pixel's
//! record). The
//! negatives perturb one exported value (a transform by 1%, a light intensity by one ulp) and the
//! comparison must fail.
use crate::common;
use common::render::first_frame;
use common::{export_to, finish_gpu, gpu_context};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::reference::{self, Tracer};
use cubetrace::scene::{self, Scene, builtin};
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{Fallback, RenderOptions};

const WIDTH: u32 = 40;
const HEIGHT: u32 = 30;

/// The scene's first camera at the test's size, with a small cube to keep the GPU passes quick.
fn small(mut scene: Scene) -> (Scene, Camera) {
    scene.cmo.resolution = 32;
    let mut cam = scene.cameras[0].clone();
    cam.width = WIDTH;
    cam.height = HEIGHT;
    (scene, cam)
}

/// Everything a reference frame holds, as bits (NaN-safe): colour, mask, points, IDs.
fn reference_bits(scene: &Scene, cam: &Camera) -> Vec<u32> {
    let f = reference::render(scene, &Tracer::new(scene), cam, 1);
    let mut out = Vec::new();
    for v in f
        .colour
        .iter()
        .chain(&f.surface_position)
        .chain(&f.hit_position)
        .chain(&f.last_position)
    {
        out.extend(v.to_array().map(f32::to_bits));
    }
    out.extend(f.mask.iter().map(|&m| u32::from(m)));
    out.extend(f.bounces.iter().map(|&m| u32::from(m)));
    out.extend_from_slice(&f.object_id);
    out.extend_from_slice(&f.primitive_id);
    out.extend_from_slice(&f.triangle);
    out.extend_from_slice(&f.last_triangle);
    out
}

/// Everything a `--method compute` frame holds but its timings, as bytes.
fn compute_bytes(ctx: &GpuContext, scene: &Scene, cam: &Camera) -> Vec<u8> {
    let options = RenderOptions {
        method: Method::Compute,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let (f, _) = first_frame(ctx, scene, cam, options, &scene.name);
    let mut out = Vec::new();
    out.extend_from_slice(bytemuck::cast_slice(&f.colour));
    out.extend_from_slice(&f.mask);
    out.extend_from_slice(bytemuck::cast_slice(&f.surface_position));
    // A record is meaningful on mirror pixels only (elsewhere the buffer holds what it held).
    for (r, &m) in f.records.iter().zip(&f.mask) {
        if m != 0 {
            out.extend_from_slice(bytemuck::bytes_of(r));
        }
    }
    out
}

/// Index of the first differing element and the number of differing elements (the longer
/// length, when the lengths differ: the mirror pixels' records differ in number).
fn differences<T: PartialEq>(a: &[T], b: &[T]) -> Option<(usize, usize)> {
    if a.len() != b.len() {
        return Some((a.len().min(b.len()), a.len().max(b.len())));
    }
    let n = a.iter().zip(b).filter(|(x, y)| x != y).count();
    (n > 0).then(|| (a.iter().zip(b).position(|(x, y)| x != y).unwrap(), n))
}

#[test]
fn every_builtin_export_renders_byte_identically() {
    let ctx = gpu_context();
    for (name, _) in builtin::NAMES {
        let dir = tempfile::tempdir().unwrap();
        let path = export_to(name, dir.path());
        let (original, cam) = small(builtin::by_name(name).unwrap());
        let (loaded, _) = small(scene::load_scene_file(&path).unwrap());
        let d = differences(
            &reference_bits(&original, &cam),
            &reference_bits(&loaded, &cam),
        );
        assert_eq!(d, None, "{name}: reference (first, count)");
        let d = differences(
            &compute_bytes(&ctx, &original, &cam),
            &compute_bytes(&ctx, &loaded, &cam),
        );
        assert_eq!(d, None, "{name}: --method compute (first byte, count)");
    }
    finish_gpu(ctx);
}

/// The negatives: one exported value perturbed in `scene.toml` (the comparisons above must see
/// it) for both renderers.
#[test]
fn a_perturbed_export_renders_differently() {
    let ctx = gpu_context();
    let dir = tempfile::tempdir().unwrap();
    let path = export_to("teapot", dir.path());
    let text = std::fs::read_to_string(&path).unwrap();
    let (original, cam) = small(builtin::by_name("teapot").unwrap());
    let reference_original = reference_bits(&original, &cam);
    let compute_original = compute_bytes(&ctx, &original, &cam);
    // The teapot's translation by 1% of its size, then the light's intensity by one ulp.
    let next_up = f32::from_bits(0.65f32.to_bits() + 1);
    for (from, to) in [
        (
            "translate = [0.0, 0.63, 0.0]",
            "translate = [0.0, 0.64, 0.0]",
        ),
        (
            "light_intensity = 0.65",
            &*format!("light_intensity = {next_up}"),
        ),
    ] {
        let edited = text.replacen(from, to, 1);
        assert_ne!(text, edited, "{from} not found in the export");
        std::fs::write(&path, &edited).unwrap();
        let (loaded, _) = small(scene::load_scene_file(&path).unwrap());
        assert!(
            differences(&reference_original, &reference_bits(&loaded, &cam)).is_some(),
            "reference: {to} must change the frame"
        );
        assert!(
            differences(&compute_original, &compute_bytes(&ctx, &loaded, &cam)).is_some(),
            "--method compute: {to} must change the frame"
        );
    }
    finish_gpu(ctx);
}

/// Vertex colours survive the round trip: `sphere-room` with one part of its orange box
/// coloured per vertex (the other parts of that mesh then white, the loader's all-or-none rule
/// per file) renders byte-identically once exported and loaded back, and the loaded part holds
/// the same colours. Negative: the export of the scene without its colours renders otherwise.
#[test]
fn vertex_colours_survive_the_export() {
    let (mut coloured, cam) = small(builtin::by_name("sphere-room").unwrap());
    let plain = coloured.clone();
    let mesh = (coloured.meshes.iter_mut())
        .find(|m| m.name == "orange-box")
        .unwrap();
    let part = &mut mesh.parts[0];
    part.colours = (part.positions.iter())
        .map(|p| (p.abs() * 3.0).fract())
        .collect();
    let want = part.colours.clone();
    let dir = tempfile::tempdir().unwrap();
    let path = cubetrace::scene::export::export(&coloured, dir.path()).unwrap();
    let (loaded, _) = small(scene::load_scene_file(&path).unwrap());
    let box_parts = |s: &Scene| s.meshes.iter().find(|m| m.name == "orange-box").cloned();
    assert_eq!(box_parts(&loaded).unwrap().parts[0].colours, want);
    let bits = reference_bits(&coloured, &cam);
    assert_eq!(differences(&bits, &reference_bits(&loaded, &cam)), None);
    assert!(differences(&bits, &reference_bits(&plain, &cam)).is_some());
}

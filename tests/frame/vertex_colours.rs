//! Vertex colours (an OBJ's `v x y z r g b`) multiply the material's colour the same way in
//! every pass that shades: the G-buffer, the capture, the verified hits and the reference.

use crate::common;
use common::render::{criterion_options, first_frame, sized_camera};
use common::{finish_gpu, gpu_context, psnr};

use cubetrace::Method;
use cubetrace::cpu::options::TraceCriterion;
use cubetrace::reference::{self, Tracer};
use cubetrace::scene::{self, Scene};
use glam::Vec3;

/// `sphere-room` with its orange box coloured per vertex: each corner's colour its place in the
/// box (the mesh's bounding box mapped to the unit cube).
fn coloured_room() -> Scene {
    let mut s = scene::builtin::sphere_room();
    let mesh = (s.meshes.iter_mut())
        .find(|m| m.name == "orange-box")
        .expect("sphere-room's orange box");
    let points = mesh.parts.iter().flat_map(|p| p.positions.iter().copied());
    let (lo, hi) = points.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    });
    for part in &mut mesh.parts {
        part.colours = part
            .positions
            .iter()
            .map(|&p| (p - lo) / (hi - lo))
            .collect();
    }
    s
}

/// Every GPU method that resolves hits (compute and fragment with both criteria, bvh) shows
/// the coloured box in the mirror as the reference does (the same colours up to the
/// interpolation's rounding: over 60 dB on mirror pixels), and the box itself in the G-buffer's
/// colour. Negative: the reference of the box without its colours is another image (under
/// 30 dB against the coloured one), so the colours reach the frame.
#[test]
fn vertex_colours_shade_every_pass_as_the_reference() {
    let s = coloured_room();
    let cam = sized_camera(&s, (64, 48));
    let refr = reference::render(&s, &Tracer::new(&s), &cam, 1);
    let mut plain = s.clone();
    for m in &mut plain.meshes {
        m.parts.iter_mut().for_each(|p| p.colours.clear());
    }
    let white = reference::render(&plain, &Tracer::new(&plain), &cam, 1);
    let all = vec![1u8; refr.mask.len()];
    let frame_db = psnr(&white.colour, &refr.colour, &all);
    assert!(
        frame_db < 30.0,
        "the colours are not in the frame: {frame_db:.1} dB"
    );
    let ctx = gpu_context();
    let runs = [
        (Method::Compute, TraceCriterion::Centre),
        (Method::Compute, TraceCriterion::Bounded),
        (Method::Fragment, TraceCriterion::Centre),
        (Method::Bvh, TraceCriterion::Centre),
    ];
    for (method, criterion) in runs {
        let what = format!("{method:?} {criterion:?}");
        let options = criterion_options(method, criterion);
        let (frame, r) = first_frame(&ctx, &s, &cam, options, &what);
        let traced = frame.traced();
        let mirror = psnr(&traced.colour, &refr.colour, &refr.mask);
        assert!(mirror > 60.0, "{what}: {mirror:.1} dB over mirror pixels");
        let whole = psnr(&traced.colour, &refr.colour, &all);
        assert!(whole > 40.0, "{what}: {whole:.1} dB over the frame");
        drop(r);
    }
    finish_gpu(ctx);
}

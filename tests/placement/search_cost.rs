//! The placement search's shortcuts keep its result: `placement::search` and
//! `placement::search_exhaustive` (the captures over every triangle, every ray of every
//! candidate counted at each step) give the same `Placement` on every built-in still scene and
//! every corpus scene, with the reflectors captured and left out; and a capture over a tracer
//! that holds only the triangles it can show (`Tracer::keeping`) is the full tracer's, bit for
//! bit.

use crate::common;

use cubetrace::cpu::capture::capture_shaded;
use cubetrace::placement;
use cubetrace::reference::Tracer;
use cubetrace::scene::{self, Scene, SelfReflections};
use glam::Vec3;

const BUILT_INS: &[&str] = &["default", "teapot", "torus", "sphere-room", "bowl"];
const CORPUS: &[&str] = &[
    "blender-mtl",
    "bunny",
    "cad-mm",
    "facing",
    "far-offset",
    "living-room",
    "mug",
    "robot-table",
    "slivers",
    "truck-garage",
];

/// Every scene of the check at 160x120, as loaded and, where it captures its reflectors, with
/// them left out (the variant the search tries first).
fn scenes() -> Vec<Scene> {
    let loaded = (BUILT_INS.iter())
        .map(|n| scene::builtin::by_name(n).unwrap_or_else(|| panic!("{n}")))
        .chain(CORPUS.iter().map(|n| common::corpus_scene(n)));
    let mut out = Vec::new();
    for mut s in loaded {
        let c = &mut s.cameras[0];
        (c.width, c.height) = (160, 120);
        if s.captures_reflectors() {
            let mut off = s.clone();
            off.self_reflections = SelfReflections::Off;
            off.name.push_str(" (reflectors left out)");
            out.push(off);
        }
        out.push(s);
    }
    out
}

#[test]
fn the_shortcuts_keep_the_placement() {
    let opts = common::centre_judged();
    for s in scenes() {
        let cams = &s.cameras[..1];
        let fast = placement::search(&s, cams, scene::DEFAULT_SEARCH_CMOS, &opts);
        let slow = placement::search_exhaustive(&s, cams, scene::DEFAULT_SEARCH_CMOS, &opts);
        assert!(fast.rays > 0, "{}: no mirror pixel in view", s.name);
        assert_eq!(fast, slow, "{}", s.name);
    }
}

/// The captures of the search's kind (32-texel faces) and a finer one, shaded, from points
/// across each scene's box: the same texels with the tracer of the shown triangles.
#[test]
fn a_capture_over_the_shown_triangles_is_the_full_one() {
    for name in ["teapot", "bowl", "default"] {
        let mut s = scene::builtin::by_name(name).unwrap();
        s.self_reflections = SelfReflections::Off;
        let tracer = Tracer::new(&s);
        let world = &tracer.world;
        let shown = |g: u32| world.objects[world.triangle_object[g as usize] as usize].captured;
        let hidden = (0..world.triangles.len() as u32)
            .filter(|&g| !shown(g))
            .count();
        assert!(hidden > 0, "{name}: every triangle is captured");
        let kept = tracer.keeping(shown);
        let (lo, hi) = world.bounds(|_| true);
        for f in [0.2, 0.5, 0.8] {
            let c = lo + (hi - lo) * Vec3::new(f, 0.5 * f + 0.25, 1.0 - f);
            for size in [32, 48] {
                let full = capture_shaded(&s, &tracer, c, size, true);
                let fast = capture_shaded(&s, &kept, c, size, true);
                let texel = |i: usize, cube: &cubetrace::cubemap::CubeMap| {
                    let c = cube.colour[i].map(f32::to_bits);
                    (cube.triangle[i], cube.distance[i].to_bits(), c)
                };
                let differ = (0..full.distance.len())
                    .filter(|&i| texel(i, &full) != texel(i, &fast))
                    .count();
                assert_eq!(differ, 0, "{name}: texels differ at {c}, faces of {size}");
            }
        }
    }
}

/// `Tracer::split` answers as the tracers it stands for: its first tracer as `Tracer::new` over
/// every triangle, its second as `Tracer::keeping` of the captured ones, hit for hit (every
/// field, bit for bit) on rays from points across each scene's box and on reflected rays that
/// leave a hit (the start rule). Negative: the kept triangles' tracer alone misses hits the
/// whole one finds, so the rest's BVH is queried.
#[test]
fn the_split_tracer_answers_as_the_whole_one() {
    let bits = |h: Option<cubetrace::reference::Hit>| {
        h.map(|h| {
            let p = h.position.to_array().map(f32::to_bits);
            let b = h.bary.to_array().map(f32::to_bits);
            (h.t.to_bits(), p, h.triangle, b, h.error.to_bits())
        })
    };
    for name in ["teapot", "bowl", "default"] {
        let mut s = scene::builtin::by_name(name).unwrap();
        s.self_reflections = SelfReflections::Off;
        let whole = Tracer::new(&s);
        let world = s.world();
        let shown = world.captured_triangles();
        let (full, kept) = Tracer::split(world.clone(), |g| shown[g as usize]);
        let kept = kept.unwrap_or_else(|| panic!("{name}: nothing left out"));
        let keeping = whole.keeping(|g| shown[g as usize]);
        let (lo, hi) = world.bounds(|_| true);
        let (mut rays, mut differ) = (0, 0);
        for i in 0..400u32 {
            let f = |k: u32| ((i * k) % 97) as f32 / 97.0;
            let o = lo + (hi - lo) * Vec3::new(f(13), f(29), f(53));
            let d = Vec3::new(f(7) - 0.5, f(11) - 0.5, f(17) - 0.5).normalize();
            let first = whole.nearest(o, d, None);
            assert_eq!(
                bits(full.nearest(o, d, None)),
                bits(first),
                "{name} ray {i}"
            );
            assert_eq!(
                bits(kept.nearest(o, d, None)),
                bits(keeping.nearest(o, d, None))
            );
            rays += 1;
            differ += usize::from(bits(kept.nearest(o, d, None)) != bits(first));
            // The ray reflected at its hit, leaving it.
            if let Some(h) = first {
                let r = cubetrace::reference::reflect(d, whole.normal(&h)).normalize();
                let a = whole.nearest(h.position, r, Some(&h));
                assert_eq!(
                    bits(full.nearest(h.position, r, Some(&h))),
                    bits(a),
                    "{name} {i}"
                );
            }
        }
        eprintln!("{name}: {rays} rays, {differ} where the kept triangles alone answer otherwise");
        assert!(differ > 0, "{name}: the rest's BVH was never needed");
    }
}

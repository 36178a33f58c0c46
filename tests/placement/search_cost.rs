//! The placement search's shortcuts keep its result: `placement::search` and
//! `placement::search_exhaustive` (the captures over every triangle, every ray of every
//! candidate counted at each step) give the same `Placement` on every built-in still scene and
//! every corpus scene, with the reflectors captured and left out; and a capture over a tracer
//! that holds only the triangles it can show (`Tracer::keeping`) is the full tracer's, bit for
//! bit.

use crate::common;

use cubetrace::cpu::capture::capture_shaded;
use cubetrace::placement::{self, PlacementOptions};
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
    let opts = PlacementOptions::default();
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

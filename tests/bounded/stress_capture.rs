//! Thin and small geometry around a mirror (the stress scenes of
//! `tests/common/stress.rs`, and the Stanford bunny of `tests/scenes/bunny/`), judged by the
//! quality harness of `tests/common/quality.rs` against the exact reference, per mirror pixel.
//!
//! - `stress_scenes_put_thin_geometry_in_the_mirror`: each scene is what it claims (a few
//!   thousand triangles; many reflected rays meet its thin part first) and the harness judges
//!   the reference itself perfect, and the ideal f32 twin (the watertight test over every
//!   triangle in CMO-local f32: what `bounded` must equal) within the targets. Negative: the
//!   reference without the thin part is judged behind on every pixel whose first hit was thin.
//! - `exact_capture_misses_thin_geometry`: the `exact` criterion (centre-sampled capture,
//!   verified hits) reports hits behind the first hit: the centre-sampled capture fails the
//!   bounded criterion's target.
//!   Asserted on the five thin scenes (fence, wire grid, chain link, foliage, edge-on fins) at
//!   every size and CMO count, and on the relief at 16; the relief at 64 and the bunny are
//!   logged (the exact capture finds their first hits there, or misses 1 to 6).
//! - `bounded_capture_finds_the_first_hit`: the `bounded` criterion's CPU twin: no hit behind
//!   the first beyond the tolerance, no hit in front, the same triangle on >= 99.9 % of
//!   resolved pixels, at most 8 % of the judged pixels unresolved and at least 90 % of the
//!   mirror pixels judged (`first_hit_failure`), at cube sizes 16 and 64 with 1 to 3 CMOs on
//!   every scene and 256 with one CMO on the fence, the wire grid and the edge-on fins.
//!   Negatives: lists without the thin part's entries are judged behind; a tracer that
//!   gives up on every ray (never behind, never in front), and the bounded twin giving up on
//!   just over 8 % more rays, fail the unresolved bound.
//! - `drop_entries_drops_only_the_named_triangles`: the bounded negative's perturbation.
//! - `stress_scenes_export_and_load_back` (ignored; `STRESS_EXPORT_DIR=dir`): writes every
//!   stress scene as a scene file (`scene export`'s format) for the CLI and the GPU checks, and
//!   checks that each loads back to the same scene.
//!
//! Run with `--nocapture` for the per-run table (behind count, same triangle %, unresolved %).
//!
//! Measured (64 x 48, about 800 to 1100 mirror pixels a scene), pixels behind the first hit at
//! N = 16 | N = 64 for 1, 2, 3 CMOs:
//!
//! | scene | exact | `bounded` (list depth 64): behind, unresolved; triangles/ray at 64 |
//! | --- | --- | --- |
//! | fence | 63 73 70 \| 37 66 63; 16 at N = 256 | 0, 0 %; 25 |
//! | wire-grid | 54 54 54 \| 54 54 54; 20 at N = 256 | 0, 0 %; 28 |
//! | chain-link | 44 46 47 \| 20 35 40 | 0, 0 %; 12 |
//! | foliage | 26 32 31 \| 11 14 19 | 0, 0 %; 4 |
//! | relief | 45 51 58 \| 0 0 1 | 0, 0 %; 2 |
//! | edge-on | 255 170 259 \| 251 119 259; 232 at N = 256 | 0, 0 %; 2 |
//! | bunny (3674 triangles) | 0 1 6 \| 0 0 0 | 0, 1.3 to 3.9 % at 16 and 0 at 64; 6 |
//!
//! `bounded` had the same triangle on 100 % of resolved pixels in every run; the exact
//! criterion 67 to 100 %.

use crate::quality;
use crate::stress;

use quality::{
    Bench, Found, Quality, Verdict, bounded_cmos, bounded_ray, bounded_twin, captured_flags,
    drop_entries, exact_twin, reference_twin, watertight_twin,
};
use stress::{STRESS, bunny_scene, stress_scene};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;

/// Every scene by name with the name of its thin mesh.
fn scenes() -> Vec<(&'static str, &'static str)> {
    let mut v: Vec<_> = STRESS.iter().map(|&s| (s, s)).collect();
    v.push(("bunny", "bunny"));
    v
}

fn bench(name: &str, cube: u32, cmos: u32) -> Bench {
    let scene = if name == "bunny" {
        bunny_scene(WIDTH, HEIGHT, cube, cmos)
    } else {
        stress_scene(name, WIDTH, HEIGHT, cube, cmos)
    };
    Bench::new(scene)
}

#[test]
fn stress_scenes_put_thin_geometry_in_the_mirror() {
    for (name, thin) in scenes() {
        let b = bench(name, 16, 1);
        let triangles = b.tracer.world.triangles.len();
        let range = b.mesh_triangles(thin);
        let judged: Vec<_> = b
            .probes
            .iter()
            .filter(|p| {
                p.reference
                    .is_none_or(|h| !b.tracer.is_reflector(h.triangle))
            })
            .collect();
        let on_thin = judged
            .iter()
            .filter(|p| p.reference.is_some_and(|h| range.contains(&h.triangle)))
            .count();
        let all = b.judge(&reference_twin(&b, |_| true));
        let without = b.judge(&reference_twin(&b, |t| !range.contains(&t)));
        let f32s = b.judge(&watertight_twin(&b, b.centres[0]));
        eprintln!(
            "{name:10}: {triangles} triangles ({} thin), {} mirror pixels, {on_thin} of {} \
             judged first meet the thin part\n  reference  : {}\n  without it : {}\n  ideal f32  : {}",
            range.len(),
            b.probes.len(),
            judged.len(),
            all.line(),
            without.line(),
            f32s.line()
        );
        assert!(triangles <= 5000, "{name}: {triangles} triangles");
        // What `bounded` captures: everything but the convex mirror (not self-captured).
        let mirror = b.mesh_triangles("mirror");
        let captured = captured_flags(&b);
        for (t, &c) in captured.iter().enumerate() {
            assert_eq!(c, !mirror.contains(&(t as u32)), "{name}: triangle {t}");
        }
        assert!(
            b.probes.len() >= 600,
            "{name}: {} mirror pixels",
            b.probes.len()
        );
        assert!(
            on_thin * 50 >= judged.len(),
            "{name}: only {on_thin} of {} reflected rays meet the thin part first",
            judged.len()
        );
        // The harness on the reference itself: nothing wrong.
        assert_eq!(
            (all.behind, all.in_front, all.tie, all.unresolved),
            (0, 0, 0, 0),
            "{name}: the reference judged against itself"
        );
        assert_eq!(all.same, all.judged(), "{name}");
        // The targets hold for f32 arithmetic: the watertight test over every triangle.
        assert_eq!(
            (f32s.behind, f32s.in_front),
            (0, 0),
            "{name}: the ideal f32 twin"
        );
        assert!(f32s.same_share() >= 0.999, "{name}: ideal f32 twin");
        // Negative: without the thin part, every pixel whose first hit was thin is behind.
        assert!(
            without.behind >= on_thin && without.behind > 0,
            "{name}: without the thin part {} behind, {on_thin} first hits were thin",
            without.behind
        );
    }
}

/// `(scene, cube size, CMOs)` runs of the bounded and centre checks: sizes 16 and 64 with 1 to
/// 3 CMOs on every scene, and 256 with one CMO on the fence, the wire grid and the edge-on fins.
fn runs() -> Vec<(&'static str, &'static str, u32, u32)> {
    let mut v = Vec::new();
    for (name, thin) in scenes() {
        for cube in [16, 64] {
            for cmos in 1..=3 {
                v.push((name, thin, cube, cmos));
            }
        }
    }
    for name in ["fence", "wire-grid", "edge-on"] {
        v.push((name, name, 256, 1));
    }
    v
}

fn log(name: &str, cube: u32, cmos: u32, what: &str, q: &Quality) {
    eprintln!("{name:10} N {cube:4} CMOs {cmos} {what:8}: {}", q.line());
}

#[test]
fn exact_capture_misses_thin_geometry() {
    let mut failing = 0;
    let runs = runs();
    for &(name, _, cube, cmos) in &runs {
        let b = bench(name, cube, cmos);
        let q = b.judge(&exact_twin(&b, cube));
        log(name, cube, cmos, "exact", &q);
        if q.behind > 0 {
            failing += 1;
        }
        // Negative: the centre-sampled capture must fail the `bounded` target where the
        // geometry is thinner than a texel (the relief at 64 and the bunny are logged only:
        // the exact capture resolves them, or misses 1 to 6 pixels).
        if name != "bunny" && (name != "relief" || cube == 16) {
            assert!(
                q.behind > 0,
                "{name} N {cube} CMOs {cmos}: the centre criterion found every first hit"
            );
        }
    }
    eprintln!(
        "exact: hits behind the first in {failing} of {} runs",
        runs.len()
    );
}

/// Largest unresolved share of the judged pixels that `bounded` may leave. Measured: 0 on every
/// stress scene at every size and CMO count; on the bunny 3.9 %, 1.9 %, 1.3 % at N = 16 with
/// 1, 2, 3 CMOs and 0 at 64. Twice the largest measured, so that a tracer that gives up on
/// rays (which is never behind, never in front and never on a wrong triangle) fails.
const MAX_UNRESOLVED: f64 = 0.08;

/// Why `q` fails the `bounded` targets, or `None`: no hit behind the first, none in front,
/// the same triangle on >= 99.9 % of the resolved pixels, at most [`MAX_UNRESOLVED`] of the
/// judged pixels unresolved, and at least 90 % of the mirror pixels judged (measured: 99.4 %
/// to 99.5 %: the rest see the mirror first, and are not judged).
fn first_hit_failure(q: &Quality) -> Option<String> {
    if q.behind > 0 {
        Some(format!("{} hits behind the first hit", q.behind))
    } else if q.in_front > 0 {
        Some(format!("{} hits in front of the first hit", q.in_front))
    } else if q.same_share() < 0.999 {
        Some(format!(
            "same triangle on {:.3} % of resolved pixels",
            100.0 * q.same_share()
        ))
    } else if q.unresolved_share() > MAX_UNRESOLVED {
        Some(format!(
            "{:.2} % of judged pixels unresolved",
            100.0 * q.unresolved_share()
        ))
    } else if q.judged() * 10 < q.mirror * 9 {
        Some(format!(
            "{} of {} mirror pixels judged",
            q.judged(),
            q.mirror
        ))
    } else {
        None
    }
}

#[test]
fn bounded_capture_finds_the_first_hit() {
    for &(name, thin, cube, cmos) in &runs() {
        let b = bench(name, cube, cmos);
        let twin = bounded_twin(&b, cube, &|_| {}).expect("the bounded twin");
        let q = b.judge(&twin);
        log(name, cube, cmos, "bounded", &q);
        // The cost of the capture, per probe ray (the last CMO's trace): texels classified
        // and candidate triangles intersected.
        let cmos_b = bounded_cmos(&b, cube, &|_| {});
        let (mut texels, mut triangles) = (0u64, 0u64);
        for p in &b.probes {
            let c = bounded_ray(&b, &cmos_b, p).result.counters;
            texels += u64::from(c.texels);
            triangles += u64::from(c.triangles);
        }
        let n = b.probes.len().max(1) as f64;
        eprintln!(
            "{name:10} N {cube:4} CMOs {cmos} bounded : texels/ray {:.1}, triangles/ray {:.1}",
            texels as f64 / n,
            triangles as f64 / n
        );
        let at = format!("{name} N {cube} CMOs {cmos}");
        if let Some(e) = first_hit_failure(&q) {
            panic!("{at}: {e}");
        }
        // Negative: a tracer that gives up on every ray is neither behind nor in front and
        // has no resolved pixel to be wrong on; the unresolved bound must fail it.
        if cmos == 1 {
            let give_up: quality::Twin = Box::new(|_| Found::Unresolved);
            let give_up = b.judge(&give_up);
            assert!(
                first_hit_failure(&give_up).is_some(),
                "{at}: a tracer that resolves nothing passed: {}",
                give_up.line()
            );
            // Negative: the bounded twin giving up on just enough more rays to exceed the
            // bound fails it, and on that bound alone.
            let quit = (MAX_UNRESOLVED * q.judged() as f64) as usize + 1;
            let key = |p: &quality::Probe| p.origin.to_array().map(f32::to_bits);
            let quitting: std::collections::HashSet<[u32; 3]> = b
                .probes
                .iter()
                .filter(|p| {
                    p.reference
                        .is_none_or(|h| !b.tracer.is_reflector(h.triangle))
                })
                .filter(|p| twin(p) != Found::Unresolved)
                .take(quit)
                .map(key)
                .collect();
            let some: quality::Twin = Box::new(|p| {
                if quitting.contains(&key(p)) {
                    Found::Unresolved
                } else {
                    twin(p)
                }
            });
            let g = b.judge(&some);
            let e = first_hit_failure(&g);
            assert!(
                e.as_ref().is_some_and(|e| e.contains("unresolved")),
                "{at}: giving up on {quit} more rays: {e:?}: {}",
                g.line()
            );
        }
        // Negative: lists without the thin part's entries (bounds untouched) are unsound,
        // and the harness sees it.
        if cmos == 1 && cube == 64 {
            let range = b.mesh_triangles(thin);
            let bad = bounded_twin(&b, cube, &|l| drop_entries(l, &range)).expect("switched on");
            let q = b.judge(&bad);
            log(name, cube, cmos, "dropped", &q);
            assert!(
                q.behind > 0,
                "{at}: lists without the thin part judged sound"
            );
        }
    }
}

#[test]
fn drop_entries_drops_only_the_named_triangles() {
    use cubetrace::cubemap::bounds::{Entry, TexelLists};
    let e = |triangle, lo| Entry {
        triangle,
        lo,
        hi: lo + 1.0,
    };
    // Size 1: six texels, with 2, 0, 3, 1, 0, 1 entries.
    let lists = TexelLists {
        size: 1,
        depth: 4,
        lo: vec![0.0; 6],
        hi: vec![9.0; 6],
        complete_to: vec![f32::INFINITY; 6],
        offsets: vec![0, 2, 2, 5, 6, 6, 7],
        entries: vec![
            e(7, 1.0),
            e(3, 2.0),
            e(3, 0.5),
            e(4, 0.6),
            e(9, 0.7),
            e(4, 1.0),
            e(1, 1.0),
        ],
    };
    let mut cut = lists.clone();
    drop_entries(&mut cut, &(3..5));
    assert_eq!(cut.offsets, vec![0, 1, 1, 2, 2, 2, 3]);
    let kept: Vec<u32> = cut.entries.iter().map(|e| e.triangle).collect();
    assert_eq!(kept, vec![7, 9, 1]);
    assert_eq!(
        (cut.lo, cut.hi, cut.complete_to),
        (
            lists.lo.clone(),
            lists.hi.clone(),
            lists.complete_to.clone()
        )
    );
    // Negative: an empty range drops nothing.
    let mut same = lists.clone();
    drop_entries(&mut same, &(3..3));
    assert_eq!(same, lists);
}

#[test]
#[ignore = "writes files: STRESS_EXPORT_DIR=dir cargo test --test bounded -- --ignored export"]
fn stress_scenes_export_and_load_back() {
    let dir = std::env::var("STRESS_EXPORT_DIR").expect("STRESS_EXPORT_DIR");
    for &name in STRESS {
        let scene = stress_scene(name, WIDTH, HEIGHT, 64, 1);
        let path = cubetrace::scene::export::export(&scene, &std::path::Path::new(&dir).join(name))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let back = cubetrace::scene::load(path.to_str().expect("UTF-8 path"))
            .unwrap_or_else(|e| panic!("{e}"));
        scene
            .compare_content(&back)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        eprintln!("{name}: {}", path.display());
    }
}

/// The tolerance separates a tie (another triangle at the reference's distance, to f32 data)
/// from a hit behind: a wrong triangle half the tolerance away is a tie, twice it away behind
/// (or in front); and the tolerance is tiny against the gaps a missed thin object leaves.
#[test]
fn tolerance_separates_ties_from_hits_behind() {
    let b = bench("fence", 16, 1);
    let mut checked = 0;
    let mut largest: f64 = 0.0;
    for p in &b.probes {
        let Some(h) = p.reference.filter(|h| !b.tracer.is_reflector(h.triangle)) else {
            continue;
        };
        let other = h.triangle ^ 1;
        let tol = b.tolerance(p, &h, other, h.position);
        largest = largest.max(tol);
        let at = |k: f64| Found::Hit {
            triangle: other,
            point: h.position + p.dir * (k * tol) as f32,
        };
        // Moving the point changes R and the tolerance by a few ulps only: 0.5 and 2 are far
        // from the boundary.
        assert_eq!(b.verdict(p, at(0.5)), Verdict::Tie);
        assert_eq!(b.verdict(p, at(-0.5)), Verdict::Tie);
        assert!(matches!(b.verdict(p, at(2.0)), Verdict::Behind(_)));
        assert_eq!(b.verdict(p, at(-2.0)), Verdict::InFront);
        // The same triangle is never wrong, however far.
        let same = Found::Hit {
            triangle: h.triangle,
            point: h.position + p.dir,
        };
        assert_eq!(b.verdict(p, same), Verdict::Same);
        checked += 1;
    }
    eprintln!("{checked} probes, largest tolerance {largest:.3e}");
    assert!(checked > 500);
    assert!(
        largest < 1e-4,
        "tolerance {largest}: too lax to see thin geometry"
    );
}

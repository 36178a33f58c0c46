//! Verified hits in the CPU tracer (`cpu::multi::trace_cmos_verified`): every reported
//! hit lies on a triangle that the ray intersects, the hit triangle is the reference's on nearly
//! every resolved ray, and the traversals agree bit for bit with verification on.

use crate::common;

use common::Rng;
use cubetrace::cpu::capture::capture;
use cubetrace::cpu::multi::{MultiResult, MultiStatus, Traversal, Verify, trace_cmos_verified};
use cubetrace::cpu::verify::{NO_TRIANGLE, triangle_corners};
use cubetrace::cpu::watertight::intersect;
use cubetrace::cpu::{CmoTracer, TraceParams};
use cubetrace::reference::{Tracer, reflect};
use cubetrace::scene::builtin;
use glam::Vec3;

const SIZE: u32 = 64;
const RAYS: usize = 1500;

/// Mirror rays of `scene`: camera rays around the view direction that hit a reflector, reflected
/// there (origin, unit direction).
fn mirror_rays(scene: &cubetrace::scene::Scene, tracer: &Tracer, seed: u64) -> Vec<(Vec3, Vec3)> {
    let cam = &scene.cameras[0];
    let fwd = (cam.target - cam.eye).normalize();
    let mut rng = Rng(seed);
    let mut out = Vec::new();
    for _ in 0..RAYS * 50 {
        if out.len() == RAYS {
            break;
        }
        let d = (fwd + 0.6 * rng.unit()).normalize();
        let Some(h) = tracer.nearest(cam.eye, d, None) else {
            continue;
        };
        if !tracer.is_reflector(h.triangle) {
            continue;
        }
        out.push((h.position, reflect(d, tracer.normal(&h)).normalize()));
    }
    out
}

struct Setup {
    tracer: Tracer,
    cmos: Vec<CmoTracer>,
    corners: Vec<[Vec3; 3]>,
    rays: Vec<(Vec3, Vec3)>,
    t_hi: f32,
}

fn setup(name: &str) -> Setup {
    let scene = builtin::by_name(name).unwrap();
    let tracer = Tracer::new(&scene);
    let world = scene.world();
    let (lo, hi) = world.bounds(|_| true);
    let cmos = scene
        .cmo_centres()
        .into_iter()
        .map(|c| CmoTracer::new(capture(&scene, &tracer, c, SIZE), TraceParams::default()))
        .collect();
    let rays = mirror_rays(&scene, &tracer, 7);
    assert!(
        rays.len() > RAYS / 2,
        "{name}: only {} mirror rays",
        rays.len()
    );
    Setup {
        tracer,
        cmos,
        corners: triangle_corners(&world),
        rays,
        t_hi: 4.0 * (hi - lo).length(),
    }
}

fn trace(s: &Setup, cmos: &[CmoTracer], o: Vec3, d: Vec3, how: Traversal) -> MultiResult {
    let v = Verify {
        triangles: &s.corners,
    };
    trace_cmos_verified(cmos, o, d, 0.0, s.t_hi, how, Some(v))
}

/// What the traversals must agree on (their counters differ by design).
fn decision(r: &MultiResult) -> (MultiStatus, u32, u32, [u32; 3], [u32; 3], u32) {
    let b = |v: Vec3| v.to_array().map(f32::to_bits);
    let t = r.result.texel;
    (
        r.status,
        r.cmo,
        r.triangle,
        b(r.point),
        [t.face, t.x, t.y],
        r.t_done.to_bits(),
    )
}

/// Whether the ray meets triangle `tri` at (nearly) `point`.
fn meets(s: &Setup, o: Vec3, d: Vec3, tri: u32, point: Vec3) -> bool {
    let Some(&corners) = s.corners.get(tri as usize) else {
        return false;
    };
    intersect(o, d, corners).is_some_and(|h| (o + d * h.t - point).length() <= 1e-4 * (1.0 + h.t))
}

#[test]
fn verified_hits_lie_on_intersected_triangles_and_match_the_reference() {
    for name in ["sphere-room", "teapot", "torus"] {
        let s = setup(name);
        let (mut hits, mut same, mut unresolved, mut perturbed_meets) = (0, 0, 0, 0);
        let (mut counted, mut before) = (0, 0);
        for &(o, d) in &s.rays {
            let r = trace(&s, &s.cmos, o, d, Traversal::Mip);
            let plain = trace_cmos_verified(&s.cmos, o, d, 0.0, s.t_hi, Traversal::Mip, None);
            if plain.status == MultiStatus::Unresolved {
                before += 1;
            }
            for how in [Traversal::Walk, Traversal::Alg3(8)] {
                assert_eq!(
                    decision(&r),
                    decision(&trace(&s, &s.cmos, o, d, how)),
                    "{name}: {how:?}"
                );
            }
            match r.status {
                MultiStatus::Hit => {
                    hits += 1;
                    assert_ne!(r.triangle, NO_TRIANGLE, "{name}: hit without a triangle");
                    assert!(
                        meets(&s, o, d, r.triangle, r.point),
                        "{name}: hit on triangle {} that the ray {o} {d} does not meet",
                        r.triangle
                    );
                    // Negative: the same check rejects a neighbouring triangle id.
                    if meets(&s, o, d, r.triangle ^ 1, r.point) {
                        perturbed_meets += 1;
                    }
                    // Same triangle among hits whose reference hit is not a reflector (the
                    // capture leaves reflectors out, so those the CMOs cannot see).
                    let reference = s.tracer.nearest_accepting(o, d, None, |h| h.t > 1e-4);
                    if let Some(h) = reference.filter(|h| !s.tracer.is_reflector(h.triangle)) {
                        counted += 1;
                        if h.triangle == r.triangle {
                            same += 1;
                        }
                    }
                }
                MultiStatus::Unresolved => unresolved += 1,
                MultiStatus::Escaped => assert_eq!(r.triangle, NO_TRIANGLE),
            }
        }
        let same_share = same as f64 / counted.max(1) as f64;
        eprintln!(
            "{name}: {} rays, {hits} verified hits, same triangle {:.2} % of {counted}, \
             unresolved {unresolved} (unverified {before}), perturbed id also met {perturbed_meets}",
            s.rays.len(),
            100.0 * same_share
        );
        assert!(hits > s.rays.len() / 2, "{name}: too few hits");
        assert!(
            perturbed_meets < hits / 20,
            "{name}: the meets check is too lax"
        );
        assert!(same_share >= 0.97, "{name}: same triangle {same_share}");
    }
}

/// Negative: with the captured IDs shifted, verification rejects most decisions (the ray does
/// not meet those triangles in the neighbourhood), and still no hit is off its triangle.
#[test]
fn shifted_ids_are_rejected_not_reported() {
    let s = setup("sphere-room");
    let bad: Vec<CmoTracer> = s
        .cmos
        .iter()
        .map(|c| {
            let mut cube = c.cube.clone();
            let n = s.corners.len() as u32;
            for id in &mut cube.triangle {
                if *id != NO_TRIANGLE {
                    *id = (*id + n / 2) % n;
                }
            }
            CmoTracer::new(cube, TraceParams::default())
        })
        .collect();
    let (mut good_hits, mut bad_hits) = (0, 0);
    for &(o, d) in &s.rays {
        if trace(&s, &s.cmos, o, d, Traversal::Mip).status == MultiStatus::Hit {
            good_hits += 1;
        }
        let r = trace(&s, &bad, o, d, Traversal::Mip);
        if r.status == MultiStatus::Hit {
            bad_hits += 1;
            assert!(meets(&s, o, d, r.triangle, r.point));
        }
    }
    eprintln!("hits with the captured IDs {good_hits}, with shifted IDs {bad_hits}");
    assert!(
        bad_hits * 10 < good_hits,
        "shifted IDs still verified {bad_hits} of {good_hits}"
    );
}

//! The `bounded` criterion's CPU twin (`cpu::bounded`) on lists that are sound by
//! construction (every triangle in every texel, trivial bounds): it must give the brute-force
//! first hit in every traversal, pass through a triangle the lists lack (the negative), go
//! behind where a list is incomplete, and honour the start rule.
use cubetrace::cpu::bounded::NO_TRIANGLE;
use cubetrace::cpu::multi::{MultiStatus, Traversal, WorldRay, trace_one, trace_world_ray};
use cubetrace::cpu::watertight::intersect;
use cubetrace::cpu::{CmoTracer, Segment};
use cubetrace::cpu::{Status, TraceParams};
use cubetrace::cubemap::bounds::Entry;
use cubetrace::cubemap::bounds::TexelLists;
use glam::Vec3;

const N: u32 = 4;

/// Lists that hold every triangle in every texel with trivial bounds (`lo = 0`, `hi = inf`):
/// sound by construction, so the tracer must find the brute-force first hit.
fn everything(tris: &[[Vec3; 3]], drop: Option<u32>) -> TexelLists {
    let texels = (6 * N * N) as usize;
    let mut offsets = vec![0u32];
    let mut entries = Vec::new();
    for _ in 0..texels {
        for k in 0..tris.len() as u32 {
            if drop != Some(k) {
                entries.push(Entry {
                    triangle: k,
                    lo: 0.0,
                    hi: f32::INFINITY,
                });
            }
        }
        offsets.push(entries.len() as u32);
    }
    TexelLists {
        size: N,
        depth: tris.len() as u32,
        lo: vec![0.0; texels],
        hi: vec![f32::INFINITY; texels],
        complete_to: vec![f32::INFINITY; texels],
        offsets,
        entries,
    }
}

/// A few random triangles and rays (a fixed LCG).
fn soup() -> (Vec<[Vec3; 3]>, Vec<(Vec3, Vec3)>) {
    let mut s = 0x2545_f491_u32;
    let mut f = move || {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (s >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
    };
    let mut v = || Vec3::new(f(), f(), f()) * 4.0;
    let tris = (0..60)
        .map(|_| {
            let c = v();
            [c + v() * 0.5, c + v() * 0.5, c + v() * 0.5]
        })
        .collect();
    let rays = (0..300).map(|_| (v() * 0.2, v().normalize())).collect();
    (tris, rays)
}

fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> Option<(u32, f32)> {
    let mut best: Option<(u32, f32)> = None;
    for (k, t) in tris.iter().enumerate() {
        if let Some(h) = intersect(o, d, *t)
            && h.t <= 100.0
            && best.is_none_or(|b| h.t < b.1)
        {
            best = Some((k as u32, h.t));
        }
    }
    best
}

fn trace(tr: &CmoTracer, o: Vec3, d: Vec3, how: Traversal) -> (MultiStatus, u32, f32) {
    let ray = WorldRay {
        origin: o,
        dir: d,
        from: NO_TRIANGLE,
        t_lo: 0.0,
        t_hi: 100.0,
    };
    let m = trace_world_ray(std::slice::from_ref(tr), &ray, None, |tr, s| {
        trace_one(tr, s, how)
    });
    (m.status, m.triangle, m.result.t)
}

#[test]
fn sound_lists_give_the_first_hit_in_every_traversal() {
    let (tris, rays) = soup();
    let tr = CmoTracer::bounded(
        Vec3::ZERO,
        everything(&tris, None),
        tris.clone(),
        TraceParams::default(),
    );
    let mut hits = 0;
    for &(o, d) in &rays {
        let want = brute(&tris, o, d);
        for how in [Traversal::Walk, Traversal::Mip, Traversal::Alg3(8)] {
            let got = trace(&tr, o, d, how);
            match want {
                Some((k, t)) => assert_eq!(got, (MultiStatus::Hit, k, t), "{o} {d} {how:?}"),
                None => assert_eq!(got.0, MultiStatus::Escaped, "{o} {d} {how:?}"),
            }
        }
        hits += want.is_some() as u32;
    }
    assert!(hits > 30, "only {hits} rays hit: the test would say little");
}

#[test]
fn a_missing_candidate_is_passed_through() {
    // Negative of the test above: drop the first hit's triangle from the lists, and the
    // tracer reports a farther triangle or none. (A texel's candidates may hit before the
    // texel's own interval, so dropping it from one texel only is caught by the texels
    // after it: the lists of this test hold everything everywhere.)
    let (tris, rays) = soup();
    let (o, d, k) = rays
        .iter()
        .find_map(|&(o, d)| brute(&tris, o, d).map(|(k, _)| (o, d, k)))
        .expect("a ray that hits");
    let lists = everything(&tris, Some(k));
    let tr = CmoTracer::bounded(Vec3::ZERO, lists, tris.clone(), TraceParams::default());
    let got = trace(&tr, o, d, Traversal::Walk);
    assert!(got.1 != k, "{got:?}");
}

#[test]
fn beyond_complete_to_the_ray_goes_behind() {
    let (tris, rays) = soup();
    let mut lists = everything(&tris, None);
    lists.complete_to.iter_mut().for_each(|c| *c = 0.5);
    let tr = CmoTracer::bounded(Vec3::ZERO, lists, tris.clone(), TraceParams::default());
    for &(o, d) in &rays {
        let seg = Segment {
            a: o,
            d,
            t_lo: 0.0,
            t_hi: 100.0,
            from: NO_TRIANGLE,
        };
        let r = trace_one(&tr, &seg, Traversal::Walk);
        // Every hit lies within r < 0.5, and every ray that leaves that ball goes behind
        // where it does.
        match r.status {
            Status::Hit => assert!(r.point.length() < 0.5 + 1e-5, "{r:?}"),
            Status::Behind => {
                assert!((r.point.length() - 0.5).abs() < 1e-4 || r.t == 0.0, "{r:?}")
            }
            Status::Escaped => panic!("escaped past complete_to: {r:?}"),
        }
    }
}

#[test]
fn the_start_rule_ignores_the_triangle_left() {
    let tri = [
        Vec3::new(-1.0, -1.0, 2.0),
        Vec3::new(1.0, -1.0, 2.0),
        Vec3::new(0.0, 1.0, 2.0),
    ];
    let tris = vec![tri];
    let tr = CmoTracer::bounded(
        Vec3::ZERO,
        everything(&tris, None),
        tris.clone(),
        TraceParams::default(),
    );
    // A ray starting on the triangle (at a point rounded off its plane) and leaving it
    // towards the centre: without the start rule it meets its own triangle at t ~ 0.
    let o = Vec3::new(0.1, 0.0, 2.000_000_3);
    let d = Vec3::new(0.0, 0.0, -1.0);
    let mut ray = WorldRay {
        origin: o,
        dir: d,
        from: NO_TRIANGLE,
        t_lo: 0.0,
        t_hi: 100.0,
    };
    let run = |ray: &WorldRay| {
        trace_world_ray(std::slice::from_ref(&tr), ray, None, |tr, s| {
            trace_one(tr, s, Traversal::Walk)
        })
    };
    assert_eq!(run(&ray).status, MultiStatus::Hit);
    ray.from = 0;
    assert_eq!(run(&ray).status, MultiStatus::Escaped);
}

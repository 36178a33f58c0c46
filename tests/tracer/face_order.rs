//! The faces a single-CMO trace marches, in order (`faces_crossed` and `face_order` of
//! `spirv/shared/trace.wgsl`, through the `trace_probe` pass's `main_faces` and
//! `main_face_order`), against the CPU's (`cpu::faces_crossed`, `cpu::face_order`), bit for bit
//! on lavapipe under the validation layer: the shaders' sorting network on every tuple of six
//! entry t over four values (ties and faces not crossed included), and the whole list on
//! segments along the cube's edge and diagonal planes, through its corners and at random.
//! Each comparison has a negative: the same GPU lists against a CPU that breaks ties the other
//! way, or that traces another segment, must disagree.

use crate::common;
use common::trace_probe::{ProbeRay, ProbeResult, trace_probe_entry};
use common::{Rng, distance_cube, finish_gpu, gpu_context};

use cubetrace::cpu::{FaceList, Segment, face_order, faces_crossed};
use cubetrace::cubemap::frustum::Interval;
use cubetrace::vk::passes::cmo::CmoData;
use glam::Vec3;

/// A face list as the probe packs it: the count, then the faces and the bits of their entry t,
/// in order (only the first `count` entries are the list's).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Packed {
    faces: Vec<u32>,
    t0: Vec<u32>,
}

fn unpack(r: &ProbeResult) -> Packed {
    let n = r.status as usize;
    let t0 = [r.face, r.x, r.y, r.riser, r.texels, r.cells];
    Packed {
        faces: (0..n).map(|i| (r.cmo >> (3 * i)) & 7).collect(),
        t0: t0[..n.min(6)].to_vec(),
    }
}

fn packed(fl: &FaceList) -> Packed {
    let n = fl.count as usize;
    Packed {
        faces: fl.face[..n].to_vec(),
        t0: fl.iv[..n].iter().map(|iv| iv.t0.to_bits()).collect(),
    }
}

/// The intervals whose entries are `t0` (crossed up to `t0 + 1`; `+inf`: not crossed).
fn intervals(t0: [f32; 6]) -> [Interval; 6] {
    t0.map(|t| {
        if t.is_finite() {
            Interval {
                t0: t,
                t1: t + 1.0,
                ..Interval::EMPTY
            }
        } else {
            Interval::EMPTY
        }
    })
}

/// The CPU's order of `t0` with ties broken by the higher face index first: the faces
/// relabelled `f -> 5 - f`, ordered, and mapped back.
fn order_ties_reversed(t0: [f32; 6]) -> FaceList {
    let mut rev = t0;
    rev.reverse();
    let mut fl = face_order(&intervals(rev));
    for f in &mut fl.face[..fl.count as usize] {
        *f = 5 - *f;
    }
    fl
}

#[test]
fn the_sorting_network_orders_every_key_tuple_as_the_cpu() {
    const VALUES: [f32; 4] = [0.0, 1.0, 2.0, f32::INFINITY];
    let tuples: Vec<[f32; 6]> = (0..4usize.pow(6))
        .map(|mut i| {
            std::array::from_fn(|_| {
                let v = VALUES[i % 4];
                i /= 4;
                v
            })
        })
        .collect();
    let rays: Vec<ProbeRay> = tuples
        .iter()
        .map(|t| ProbeRay {
            origin: [t[0], t[1], t[2]],
            t_lo: t[3],
            dir: [t[4], t[5], 0.0],
            t_hi: 0.0,
        })
        .collect();
    let ctx = gpu_context();
    let data = CmoData::upload(
        &ctx,
        &[distance_cube(2, 1, None)],
        &cubetrace::cpu::options::TraceOptions::centre(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let gpu =
        trace_probe_entry(&ctx, &data, &rays, "main_face_order").unwrap_or_else(|e| panic!("{e}"));
    let mut bad = 0;
    let mut reversed_bad = 0;
    for (t, g) in tuples.iter().zip(&gpu) {
        let g = unpack(g);
        if g != packed(&face_order(&intervals(*t))) {
            bad += 1;
            if bad < 5 {
                eprintln!("{t:?}: gpu {g:?}, cpu {:?}", face_order(&intervals(*t)));
            }
        }
        reversed_bad += usize::from(g != packed(&order_ties_reversed(*t)));
    }
    eprintln!(
        "{} key tuples: {bad} disagree with the CPU, {reversed_bad} with ties reversed",
        tuples.len()
    );
    assert_eq!(bad, 0);
    // Negative: a tie rule the other way round is seen (every tuple with a tie between two
    // crossed faces, which is most of them).
    assert!(reversed_bad > 1000, "{reversed_bad}");
    drop(data);
    finish_gpu(ctx);
}

/// CMO-local segments `(a, d, t_lo, t_hi)`: through the cube's corners and along its edge and
/// diagonal planes (where faces meet and the tie rule decides), parallel to face planes, from
/// the centre, and random ones with `t_lo` below and above 0 and infinite `t_hi`.
fn segments() -> Vec<(Vec3, Vec3, f32, f32)> {
    let mut out = Vec::new();
    let dirs = [
        Vec3::X,
        Vec3::NEG_Z,
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 1.0),
        Vec3::ONE,
        Vec3::new(-1.0, 1.0, -1.0),
        Vec3::new(0.3, 0.7, -0.2),
        Vec3::new(-2.0, 0.5, 0.5),
    ];
    let points = [
        Vec3::ZERO,
        Vec3::ONE,
        Vec3::new(-1.0, 1.0, 1.0),
        Vec3::new(0.5, 0.5, -0.25),
        Vec3::new(0.5, -0.5, 0.125),
        Vec3::new(0.25, 0.75, 0.75),
        Vec3::new(-0.75, 0.1, -0.75),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, -3.0, 0.5),
    ];
    for &a in &points {
        for &d in &dirs {
            for (lo, hi) in [(0.0, 4.0), (-2.0, 2.0), (0.0, f32::INFINITY), (0.5, 0.5)] {
                out.push((a, d, lo, hi));
                out.push((a - d, d, lo, hi));
                out.push((a, -2.5 * d, lo, hi));
            }
        }
    }
    let mut rng = Rng(77);
    for i in 0..3000 {
        let a = Vec3::new(
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        );
        let d = rng.unit() * rng.range(0.2, 3.0);
        let lo = rng.range(-2.0, 2.0);
        let hi = if i % 5 == 0 {
            f32::INFINITY
        } else {
            lo + rng.range(0.0, 4.0)
        };
        out.push((a, d, lo, hi));
    }
    out
}

#[test]
fn faces_crossed_match_the_cpu_bit_for_bit() {
    let segs = segments();
    let rays: Vec<ProbeRay> = segs
        .iter()
        .map(|&(a, d, lo, hi)| ProbeRay {
            origin: a.to_array(),
            t_lo: lo,
            dir: d.to_array(),
            t_hi: hi,
        })
        .collect();
    let ctx = gpu_context();
    let mut bad = 0;
    let mut perturbed_bad = 0;
    let mut crossed = [0usize; 7];
    for size in [1u32, 7, 64] {
        let data = CmoData::upload(
            &ctx,
            &[distance_cube(size, 3, None)],
            &cubetrace::cpu::options::TraceOptions::centre(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let gpu =
            trace_probe_entry(&ctx, &data, &rays, "main_faces").unwrap_or_else(|e| panic!("{e}"));
        for (&(a, d, lo, hi), g) in segs.iter().zip(&gpu) {
            let seg = |d: Vec3| Segment {
                a,
                d,
                t_lo: lo,
                t_hi: hi,
                from: u32::MAX,
            };
            let cpu = faces_crossed(&seg(d), lo, hi, size);
            let g = unpack(g);
            crossed[cpu.count as usize] += 1;
            if g != packed(&cpu) {
                bad += 1;
                if bad < 5 {
                    eprintln!("a {a} d {d} [{lo}, {hi}] size {size}: gpu {g:?}, cpu {cpu:?}");
                }
            }
            // Negative: the CPU's list of the segment with the direction doubled (every entry
            // t but 0, t_lo and infinities halves).
            perturbed_bad += usize::from(g != packed(&faces_crossed(&seg(2.0 * d), lo, hi, size)));
        }
        drop(data);
    }
    eprintln!(
        "{} segments x 3 sizes (faces crossed 0..=6: {crossed:?}): {bad} disagree with the CPU, \
         {perturbed_bad} with the perturbed CPU",
        segs.len()
    );
    assert_eq!(bad, 0);
    assert!(crossed[3] + crossed[4] > 0, "{crossed:?}");
    assert!(perturbed_bad > segs.len(), "{perturbed_bad}");
    finish_gpu(ctx);
}

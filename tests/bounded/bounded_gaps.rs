//! The `bounded` criterion's gaps: the widest range of distances between a texel's entries
//! where no surface in the texel's cone lies, which the traversals skip through
//! (`cubemap::bounds::texel_gap`, `cpu::bounded` step 1).
//! - **Sound on the CPU:** over random triangle soups captured by the CPU twin, every traversal
//!   (walk, 2x2 pyramid, 8x4/4x8 hierarchy) gives a hit on the brute-force first triangle and an
//!   escape only where nothing is hit; the gaps are used (the counters differ from a trace
//!   without them). Negative: gaps widened to everything make rays pass through surfaces.
//! - **Entries the ray is beyond** (`hi < rmin` over the texel, `cpu::bounded` step 4) are
//!   passed over without a triangle test: the first hit kept, fewer candidates tested than with
//!   every entry's `hi` raised to infinity. Negative: every `hi` lowered below its `lo` makes
//!   rays pass through surfaces.
//! - **The GPU's `resolve`** writes, bit for bit, the packed gaps the CPU computes from the very
//!   lists the GPU kept. Negative: one entry's `hi` raised changes that texel's gap.
//! - **The gap pyramids** (`pyramid` and `hier32` passes, `gaps` entry points) equal
//!   `MipPyramid::over_cells` and `Hier32::over_cells`, bit for bit. Negative: one texel
//!   perturbed.
use crate::common::{finish_gpu, gpu_context};

use cubetrace::cpu::bounded::NO_TRIANGLE;
use cubetrace::cpu::multi::{MultiStatus, Traversal, WorldRay, trace_one, trace_world_ray};
use cubetrace::cpu::watertight::intersect;
use cubetrace::cpu::{CmoTracer, Counters, TraceParams};
use cubetrace::cubemap::bounds::{capture_lists, pack_gap, unpack_gap};
use cubetrace::cubemap::pyramid::{Hier32, MipPyramid};
use cubetrace::scene::builtin;
use cubetrace::scene::gpu_data::GpuSceneData;
use cubetrace::vk::GpuContext;
use cubetrace::vk::passes::capture_lists::{CaptureLists, capacity, scene_views};
use cubetrace::vk::passes::hier32::Hier32Pass;
use cubetrace::vk::passes::pyramid::Pyramid;
use cubetrace::vk::passes::scene_buffers::SceneBuffers;
use glam::Vec3;

const N: u32 = 16;

/// Layered random triangles around the origin (a fixed LCG): small ones near the centre in
/// front of larger ones farther out, so rays pass behind the near layer and in front of the far.
fn soup(seed: u32) -> (Vec<[Vec3; 3]>, Vec<(Vec3, Vec3)>) {
    let mut s = seed;
    let mut f = move || {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (s >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
    };
    let mut tris = Vec::new();
    for (count, radius, size) in [(40, 1.5f32, 0.5f32), (40, 4.0, 1.5)] {
        for _ in 0..count {
            let c = Vec3::new(f(), f(), f()).normalize_or(Vec3::X) * radius;
            let mut v = || c + Vec3::new(f(), f(), f()) * size;
            tris.push([v(), v(), v()]);
        }
    }
    let rays = (0..400)
        .map(|_| {
            let o = Vec3::new(f(), f(), f()) * 0.3;
            (o, Vec3::new(f(), f(), f()).normalize_or(Vec3::Y))
        })
        .collect();
    (tris, rays)
}

/// The nearest triangle the ray meets over `t in [0, 100]` (brute force).
fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> Option<(u32, f32)> {
    tris.iter()
        .enumerate()
        .filter_map(|(k, t)| intersect(o, d, *t).map(|h| (k as u32, h.t)))
        .filter(|&(_, t)| (0.0..=100.0).contains(&t))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Rays whose outcome contradicts the brute-force first hit (a hit on another triangle, not
/// within rounding of the first's `t`, or an escape past a hit), and the traversal's counters
/// summed over the rays.
fn wrong(
    tr: &CmoTracer,
    tris: &[[Vec3; 3]],
    rays: &[(Vec3, Vec3)],
    how: Traversal,
) -> (usize, Counters) {
    let mut bad = 0;
    let work = std::cell::Cell::new(Counters::default());
    for &(o, d) in rays {
        let ray = WorldRay {
            origin: o,
            dir: d,
            from: NO_TRIANGLE,
            t_lo: 0.0,
            t_hi: 100.0,
        };
        let m = trace_world_ray(std::slice::from_ref(tr), &ray, None, |tr, s| {
            let r = trace_one(tr, s, how);
            let mut w = work.get();
            w.texels += r.counters.texels;
            w.cells += r.counters.cells;
            w.walks += r.counters.walks;
            w.triangles += r.counters.triangles;
            work.set(w);
            r
        });
        let first = brute(tris, o, d);
        let ok = match (m.status, first) {
            (MultiStatus::Hit, Some((k, t))) => {
                m.triangle == k || (m.result.t - t).abs() <= 1e-4 * t.max(1.0)
            }
            (MultiStatus::Hit, None) => false,
            (MultiStatus::Escaped, hit) => hit.is_none(),
            (MultiStatus::Unresolved, _) => true,
        };
        bad += usize::from(!ok);
    }
    (bad, work.get())
}

/// Every traversal over the CPU twin's lists gives the first hit with the gaps, uses them, and
/// goes wrong with gaps widened to all distances.
#[test]
fn gap_skips_keep_the_first_hit() {
    let traversals = [Traversal::Walk, Traversal::Mip, Traversal::Alg3(8)];
    let mut used = [false; 3];
    for seed in [0x2545_f491_u32, 7, 1234] {
        let (tris, rays) = soup(seed);
        let captured = vec![true; tris.len()];
        let lists = capture_lists(&tris, &captured, Vec3::ZERO, N, 64);
        let params = TraceParams::default();
        let tr = CmoTracer::bounded(Vec3::ZERO, lists.clone(), tris.clone(), params);
        let gaps = lists.gaps();
        let real = gaps
            .iter()
            .filter(|[g1, g0]| g1 > g0 && g1.is_finite())
            .count();
        assert!(real > 100, "seed {seed}: {real} texels with a finite gap");
        // The same tracer with no gap anywhere (`[0, 0]`: nothing lies strictly inside).
        let mut closed = tr.clone();
        // Every distance a gap ([inf, 0]): the negative.
        let mut open = tr.clone();
        for (t, cells) in [(&mut closed, [0.0, 0.0]), (&mut open, [f32::INFINITY, 0.0])] {
            let b = t.bounded.as_mut().unwrap();
            b.gaps = MipPyramid::over_cells(N, vec![cells; gaps.len()]);
            b.gap_hier = Hier32::over_cells(N, vec![cells; gaps.len()]);
        }
        for (i, how) in traversals.into_iter().enumerate() {
            let (bad, work) = wrong(&tr, &tris, &rays, how);
            let (_, without) = wrong(&closed, &tris, &rays, how);
            let (opened, _) = wrong(&open, &tris, &rays, how);
            eprintln!(
                "seed {seed} {how:?}: {bad} wrong; work {work:?} against {without:?} without gaps; \
                 {opened} wrong with every distance a gap"
            );
            assert_eq!(bad, 0, "seed {seed} {how:?}: a gap skip lost the first hit");
            used[i] |= work != without;
            assert!(
                opened > 20,
                "seed {seed} {how:?}: widened gaps went unnoticed ({opened})"
            );
        }
    }
    assert_eq!(used, [true; 3], "the gaps changed no traversal's work");
}

/// Every traversal passes over the entries the ray is beyond, keeps the first hit doing so, and
/// goes wrong where every entry claims to be nearer than it is.
#[test]
fn entries_the_ray_is_beyond_are_passed_over() {
    for seed in [0x2545_f491_u32, 7, 1234] {
        let (tris, rays) = soup(seed);
        let captured = vec![true; tris.len()];
        let lists = capture_lists(&tris, &captured, Vec3::ZERO, N, 64);
        let tr = CmoTracer::bounded(Vec3::ZERO, lists, tris.clone(), TraceParams::default());
        let with_hi = |hi: f32| {
            let mut t = tr.clone();
            for e in &mut t.bounded.as_mut().unwrap().lists.entries {
                e.hi = hi;
            }
            t
        };
        // Nothing is beyond a ray; everything is (the negative).
        let (raised, lowered) = (with_hi(f32::INFINITY), with_hi(f32::NEG_INFINITY));
        for how in [Traversal::Walk, Traversal::Mip, Traversal::Alg3(8)] {
            let (bad, work) = wrong(&tr, &tris, &rays, how);
            let (bad_raised, all) = wrong(&raised, &tris, &rays, how);
            let (passed_through, _) = wrong(&lowered, &tris, &rays, how);
            eprintln!(
                "seed {seed} {how:?}: {bad} wrong, {} candidates tested; {bad_raised} wrong, {} \
                 tested with no entry passed over; {passed_through} wrong with every entry passed \
                 over",
                work.triangles, all.triangles
            );
            assert_eq!(
                bad + bad_raised,
                0,
                "seed {seed} {how:?}: the first hit was lost"
            );
            assert!(
                work.triangles < all.triangles,
                "seed {seed} {how:?}: no entry was passed over"
            );
            assert!(
                passed_through > 20,
                "seed {seed} {how:?}: entries passed over wrongly went unnoticed"
            );
        }
    }
}

/// Packing rounds each end inwards: the unpacked gap lies inside the exact one, within 2^-7.
#[test]
fn packing_narrows_the_gap() {
    let mut s = 99u32;
    let mut f = move || {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        f32::from_bits(s >> 2) // non-negative floats of every exponent; all but normal ones skipped
    };
    let mut checked = 0;
    for _ in 0..100_000 {
        let (a, b) = (f(), f());
        if !(a.is_normal() && b.is_normal()) {
            continue;
        }
        let [g1, g0] = unpack_gap(pack_gap([a, b]));
        assert!(g1 <= a && g0 >= b, "[{a}, {b}] packed to [{g1}, {g0}]");
        assert!(a - g1 <= a / 128.0 && g0 - b <= b / 128.0 + f32::from_bits(1 << 16));
        checked += 1;
    }
    assert!(checked > 50_000);
    assert_eq!(
        unpack_gap(pack_gap([f32::INFINITY, 0.0])),
        [f32::INFINITY, 0.0]
    );
    // Negative: a gap widened by the packing would fail the first assertion.
    let [g1, _] = unpack_gap(pack_gap([1.0 + 1.0 / 256.0 + 1e-6, 0.0]));
    assert!(g1 < 1.0 + 1.0 / 256.0 + 1e-6);
}

/// The GPU's `resolve` writes the gaps of the lists it kept, and the gap pyramids are the CPU's.
#[test]
fn the_gpu_gaps_are_the_twins() {
    let ctx = gpu_context();
    let scene = builtin::by_name("sphere-room").unwrap();
    let data = GpuSceneData::new(&scene);
    let views = scene_views(&scene);
    let size = 32;
    let buffers = SceneBuffers::new(&ctx, &data).unwrap();
    let cap = capacity(&data, &views, size);
    let pass = CaptureLists::new(&ctx, &buffers, size, 64, &views, cap, None).unwrap();
    ctx.submit_and_wait("capture_lists", |rec| pass.record(rec))
        .unwrap();
    let gpu = pass.read_back(&ctx, None).unwrap();
    let mut real = 0;
    for (k, lists) in gpu.cmos.iter().enumerate() {
        assert_eq!(gpu.gaps[k], lists.packed_gaps(), "CMO {k}: resolve's gaps");
        real += lists
            .gaps()
            .iter()
            .filter(|[g1, g0]| g1 > g0 && g1.is_finite())
            .count();
        // Negative: the first entry of a texel with a later one, its `hi` raised past the next
        // entry's `lo`, changes that texel's gap.
        let i = (0..lists.lo.len())
            .find(|&i| {
                let e = &lists.entries[lists.offsets[i] as usize..lists.offsets[i + 1] as usize];
                e.len() >= 2 && e[1].lo > e[0].hi
            })
            .expect("a texel with two separate entries");
        let mut bad = lists.clone();
        let j = bad.offsets[i] as usize;
        bad.entries[j].hi = bad.entries[j + 1].lo;
        assert_ne!(bad.packed_gaps()[i], gpu.gaps[k][i], "CMO {k} texel {i}");
    }
    assert!(real > 100, "{real} texels with a finite gap");
    check_pyramids(&ctx, &gpu.gaps, size);
    drop(pass);
    drop(buffers);
    finish_gpu(ctx);
}

/// The `pyramid` and `hier32` passes' `gaps` entry points over `gaps` (per CMO, packed) against
/// the CPU's pyramids, bit for bit; a perturbed texel changes the CPU's.
fn check_pyramids(ctx: &GpuContext, gaps: &[Vec<u32>], size: u32) {
    let k = gaps.len() as u32;
    let flat: Vec<u32> = gaps.concat();
    let st = ash::vk::BufferUsageFlags::STORAGE_BUFFER;
    let src = ctx.create_buffer_init("gaps", st, &flat).unwrap();
    let cpu = |g: &[u32]| {
        let cells: Vec<[f32; 2]> = g.iter().map(|&w| unpack_gap(w)).collect();
        let pack = |l: Vec<[f32; 2]>| l.into_iter().map(pack_gap).collect::<Vec<u32>>();
        (
            pack(MipPyramid::over_cells(size, cells.clone()).flatten()),
            pack(Hier32::over_cells(size, cells).flatten()),
        )
    };
    let mip_len = cpu(&gaps[0]).0.len();
    let hier_len = cpu(&gaps[0]).1.len();
    let out = |len: usize| {
        ctx.create_buffer_init(
            "gap levels",
            st | ash::vk::BufferUsageFlags::TRANSFER_SRC,
            &vec![u32::MAX; len * k as usize],
        )
        .unwrap()
    };
    let (mip, hier) = (out(mip_len), out(hier_len));
    let p = Pyramid::gaps(ctx).unwrap();
    let pb = p.bind(ctx, &src, &mip, k, size).unwrap();
    let h = Hier32Pass::gaps(ctx).unwrap();
    let hb = h.bind(ctx, &src, &hier, k, size).unwrap();
    ctx.submit_and_wait("gap pyramids", |rec| {
        p.record(rec, &pb, None)?;
        h.record(rec, &hb);
        Ok(())
    })
    .unwrap();
    let got_mip: Vec<u32> = ctx.read_buffer(&mip).unwrap();
    let got_hier: Vec<u32> = ctx.read_buffer(&hier).unwrap();
    for (c, g) in gaps.iter().enumerate() {
        let (want_mip, want_hier) = cpu(g);
        let c0 = c * mip_len;
        assert_eq!(
            got_mip[c0..c0 + mip_len],
            want_mip[..],
            "CMO {c}: gap pyramid"
        );
        let h0 = c * hier_len;
        assert_eq!(
            got_hier[h0..h0 + hier_len],
            want_hier[..],
            "CMO {c}: gap hierarchy"
        );
        // Negative: one texel's near end pushed to +inf closes the gap of every cell above it.
        let i = g
            .iter()
            .position(|&w| {
                let [g1, g0] = unpack_gap(w);
                g1 > g0 && g1.is_finite()
            })
            .unwrap();
        let mut bad = g.clone();
        bad[i] = pack_gap([unpack_gap(g[i])[0], f32::INFINITY]);
        let (bad_mip, bad_hier) = cpu(&bad);
        assert_ne!(
            got_mip[c0..c0 + mip_len],
            bad_mip[..],
            "CMO {c}: pyramid negative"
        );
        assert_ne!(
            got_hier[h0..h0 + hier_len],
            bad_hier[..],
            "CMO {c}: hierarchy negative"
        );
    }
}

//! The `capture_lists` passes against their CPU twin (`cubemap::bounds::capture_lists`):
//! - tiny scenes (a thin and an edge-on triangle; one crossing behind the centre and one through
//!   the near box, two CMOs, one capturing the reflectors) and a built-in scene at N = 16 and
//!   32: per texel the same entries (ids in order, `lo`/`hi` bits equal), the same `complete_to`,
//!   texel `lo` (the distance buffer) and `hi`, nothing dropped;
//! - tiny node pools, job buffers and list walks: what the GPU keeps is the CPU's, and `complete_to` is at
//!   most every entry the GPU lost; the loss is counted;
//! - a per-binding range limit lowered below the pool as one `vec4` binding: the split layout
//!   still matches bit for bit; a perturbed device node is detected; a lower limit is refused;
//! - the capture's cost on a built-in scene at N = 64 and 256 (printed, not asserted).
//!
//! Every comparison has a negative (one CPU value perturbed by one ulp, one `complete_to`
//! raised: the check fails). Runs under the validation layer when installed.
use crate::common;
use common::{finish_gpu, gpu_context};

use std::time::Instant;

use cubetrace::cubemap::bounds::{
    PoolBound, TexelLists, capture_lists, face_local, face_rect, texel_centre_unit,
};
use cubetrace::cubemap::face::face_coord;
use cubetrace::cubemap::texel_cone::{TexelCone, edges, texel_cone, tile_outside};
use cubetrace::scene::gpu_data::{GpuMaterial, GpuObject, GpuSceneData, GpuVertex};
use cubetrace::vk::GpuContext;
use cubetrace::vk::backend::timestamps::Timestamps;
use cubetrace::vk::passes::capture_lists::{CaptureLists, GpuLists, capacity, scene_triangles};
use cubetrace::vk::passes::scene_buffers::SceneBuffers;
use glam::{DVec3, Vec3};

/// A scene of `objects` (triangles, reflector flag), every object captured.
fn tiny_scene(objects: &[(&[[Vec3; 3]], bool)]) -> GpuSceneData {
    let mut d = GpuSceneData {
        materials: vec![GpuMaterial::default()],
        srgb_to_linear: vec![0.0; 256],
        texels: vec![0],
        textures: vec![Default::default()],
        ..Default::default()
    };
    for (o, (tris, reflector)) in objects.iter().enumerate() {
        d.objects.push(GpuObject {
            material: 0,
            reflector: u32::from(*reflector),
            captured: 1,
            specular_power: -1.0,
            vertex_colours: 0,
        });
        for t in tris.iter() {
            for v in t {
                d.indices.push(d.vertices.len() as u32);
                d.vertices.push(GpuVertex {
                    position: v.to_array(),
                    object: o as u32,
                    ..Default::default()
                });
            }
        }
    }
    d.capture_index_count = d.indices.len() as u32;
    d
}

/// Runs the passes once; returns the readback and the wall time of the submission.
fn run(
    ctx: &GpuContext,
    data: &GpuSceneData,
    cmos: &[(Vec3, bool)],
    size: u32,
    depth: u32,
    cap: PoolBound,
) -> (GpuLists, f64) {
    let scene = SceneBuffers::new(ctx, data).unwrap();
    let lists = CaptureLists::new(ctx, &scene, size, depth, cmos, cap, None).unwrap();
    let t0 = Instant::now();
    ctx.submit_and_wait("capture_lists", |rec| lists.record(rec))
        .unwrap();
    let secs = t0.elapsed().as_secs_f64();
    (lists.read_back(ctx, None).unwrap(), secs)
}

/// The CPU twin's lists of every CMO.
fn cpu_lists(data: &GpuSceneData, cmos: &[(Vec3, bool)], size: u32, depth: u32) -> Vec<TexelLists> {
    cmos.iter()
        .map(|&(centre, reflectors)| {
            let (tris, flags) = scene_triangles(data, reflectors);
            capture_lists(&tris, &flags, centre, size, depth)
        })
        .collect()
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Bit-for-bit equality of the GPU's and the CPU's lists; `Err` names the first difference.
fn compare(gpu: &TexelLists, cpu: &TexelLists) -> Result<(), String> {
    for i in 0..cpu.lo.len() {
        let (a, b) = (
            &gpu.entries[gpu.offsets[i] as usize..gpu.offsets[i + 1] as usize],
            &cpu.entries[cpu.offsets[i] as usize..cpu.offsets[i + 1] as usize],
        );
        let key = |e: &[cubetrace::cubemap::bounds::Entry]| {
            e.iter()
                .map(|e| (e.triangle, e.lo.to_bits(), e.hi.to_bits()))
                .collect::<Vec<_>>()
        };
        if key(a) != key(b) {
            return Err(format!("texel {i}: GPU entries {a:?}, CPU {b:?}"));
        }
        for (what, g, c) in [
            ("lo", gpu.lo[i], cpu.lo[i]),
            ("hi", gpu.hi[i], cpu.hi[i]),
            ("complete_to", gpu.complete_to[i], cpu.complete_to[i]),
        ] {
            if g.to_bits() != c.to_bits() {
                return Err(format!("texel {i}: {what} GPU {g}, CPU {c}"));
            }
        }
    }
    if bits(&gpu.lo) != bits(&cpu.lo) {
        return Err("lo differs".into());
    }
    Ok(())
}

/// Compares every CMO, with the negatives on the first CMO holding an entry.
fn compare_all(gpu: &GpuLists, cpu: &[TexelLists]) {
    assert_eq!(gpu.cmos.len(), cpu.len());
    for (k, (g, c)) in gpu.cmos.iter().zip(cpu).enumerate() {
        compare(g, c).unwrap_or_else(|e| panic!("CMO {k}: {e}"));
    }
    let c = cpu
        .iter()
        .find(|c| !c.entries.is_empty())
        .expect("some entry");
    let g = &gpu.cmos[cpu.iter().position(|x| std::ptr::eq(x, c)).unwrap()];
    let mut bad = c.clone();
    bad.entries[0].lo = f32::from_bits(bad.entries[0].lo.to_bits() + 1);
    assert!(compare(g, &bad).is_err(), "negative: a perturbed lo");
    let mut bad = c.clone();
    let last = bad.entries.len() - 1;
    bad.entries[last].hi = f32::from_bits(bad.entries[last].hi.to_bits() + 1);
    assert!(compare(g, &bad).is_err(), "negative: a perturbed hi");
    let mut bad = c.clone();
    let i = bad.offsets.windows(2).position(|w| w[1] > w[0]).unwrap();
    bad.complete_to[i] = 0.0;
    assert!(
        compare(g, &bad).is_err(),
        "negative: a perturbed complete_to"
    );
}

fn full_capacity(data: &GpuSceneData, cmos: &[(Vec3, bool)], size: u32) -> PoolBound {
    capacity(data, cmos, size)
}

fn assert_nothing_dropped(g: &GpuLists) {
    let c = g.counters;
    assert_eq!(
        (
            c.jobs_dropped,
            c.nodes_dropped,
            c.walks_capped,
            c.tiles_capped,
            c.pairs_dropped
        ),
        (0, 0, 0, 0, 0),
        "{c:?}"
    );
}

fn small_triangles() -> Vec<[Vec3; 3]> {
    let c = Vec3::new(0.25, -0.5, 0.75);
    vec![
        // Ordinary.
        [
            Vec3::new(2.0, 0.3, 0.1),
            Vec3::new(2.2, 1.1, -0.4),
            Vec3::new(1.9, -0.2, 0.9),
        ],
        // Thin: a sliver between texel centres.
        [
            Vec3::new(-1.0, 2.0, -0.3),
            Vec3::new(1.0, 2.1, 0.4),
            Vec3::new(0.0, 2.05, 0.05001),
        ],
        // Edge-on: the centre in its plane (spanned by two directions from the centre).
        [
            c + Vec3::new(1.0, 1.0, 0.0),
            c + Vec3::new(2.0, 2.0, 1.0),
            c + Vec3::new(1.5, 1.5, -1.0),
        ],
        // A face edge: spans +Z and +X.
        [
            Vec3::new(1.5, 0.0, 1.4),
            Vec3::new(1.2, 0.4, 1.6),
            Vec3::new(1.8, -0.3, 1.7),
        ],
    ]
}

#[test]
fn gpu_matches_the_cpu_twin_on_tiny_scenes() {
    let ctx = gpu_context();
    // Scene A: thin, edge-on, face edges.
    let a = small_triangles();
    let data = tiny_scene(&[(&a, false)]);
    let cmos = [(Vec3::new(0.25, -0.5, 0.75), false)];
    for (size, depth) in [(8, 16), (16, 2)] {
        let (g, _) = run(
            &ctx,
            &data,
            &cmos,
            size,
            depth,
            full_capacity(&data, &cmos, size),
        );
        assert_nothing_dropped(&g);
        compare_all(&g, &cpu_lists(&data, &cmos, size, depth));
    }
    // Bad inputs are refused with the reason.
    let scene = SceneBuffers::new(&ctx, &data).unwrap();
    let cap = full_capacity(&data, &cmos, 8);
    for (size, depth, k) in [(8, 0, 1), (0, 16, 1), (8, 16, 0)] {
        let e = CaptureLists::new(&ctx, &scene, size, depth, &cmos[..k], cap, None)
            .err()
            .unwrap_or_else(|| panic!("N = {size}, depth {depth}, {k} CMOs accepted"));
        assert!(e.to_string().contains("depth"), "{e}");
    }
    assert!(CaptureLists::new(&ctx, &scene, 8, 16, &cmos, cap, None).is_ok());
    drop(scene);
    // Scene B: a triangle crossing behind the centre, one through the near box, a reflector
    // (captured only by the second CMO).
    let behind = [
        [
            Vec3::new(-3.0, -1.0, -3.0),
            Vec3::new(3.0, -1.0, -3.0),
            Vec3::new(0.0, -1.2, 4.0),
        ],
        [
            Vec3::new(-1.0, 1e-6, -1.0),
            Vec3::new(1.0, 1e-6, -1.0),
            Vec3::new(0.0, 1e-6, 1.0),
        ],
    ];
    let mirror = [[
        Vec3::new(0.5, 0.5, 2.0),
        Vec3::new(-0.5, 0.5, 2.0),
        Vec3::new(0.0, -0.5, 2.0),
    ]];
    let data = tiny_scene(&[(&behind, false), (&a, false), (&mirror, true)]);
    let cmos = [(Vec3::ZERO, false), (Vec3::new(0.1, 0.2, 0.3), true)];
    let size = 16;
    let (g, _) = run(
        &ctx,
        &data,
        &cmos,
        size,
        16,
        full_capacity(&data, &cmos, size),
    );
    assert_nothing_dropped(&g);
    let cpu = cpu_lists(&data, &cmos, size, 16);
    compare_all(&g, &cpu);
    // The reflector (triangle 6) is in CMO 1's lists only.
    let has = |l: &TexelLists, t: u32| l.entries.iter().any(|e| e.triangle == t);
    assert!(!has(&g.cmos[0], 6) && has(&g.cmos[1], 6));
    // The near-box triangle (1) is in every texel of CMO 0.
    assert!((0..6 * size * size).all(|i| {
        let l = &g.cmos[0];
        l.entries[l.offsets[i as usize] as usize..l.offsets[i as usize + 1] as usize]
            .iter()
            .any(|e| e.triangle == 1)
            || l.complete_to[i as usize] < f32::INFINITY
    }));
    finish_gpu(ctx);
}

fn builtin(name: &str) -> (GpuSceneData, Vec<(Vec3, bool)>) {
    let s = cubetrace::scene::load(name).unwrap();
    let world = s.world();
    let (lo, hi) = world.bounds(|o| o.reflector);
    let c = (lo + hi) * 0.5;
    let data = GpuSceneData::new(&s);
    (
        data,
        vec![(c, false), (c + Vec3::new(0.01, 0.02, -0.03), true)],
    )
}

#[test]
fn gpu_matches_the_cpu_twin_on_a_builtin_scene() {
    let ctx = gpu_context();
    let (data, cmos) = builtin("sphere-room");
    for size in [16, 32] {
        let cap = full_capacity(&data, &cmos, size);
        let (g, secs) = run(&ctx, &data, &cmos, size, 16, cap);
        eprintln!(
            "sphere-room N = {size}: {cap:?}, {:?}, {secs:.3} s",
            g.counters
        );
        assert_nothing_dropped(&g);
        assert!(u64::from(g.counters.nodes) <= cap.nodes);
        compare_all(&g, &cpu_lists(&data, &cmos, size, 16));
        // `resolve` places four entries per scan of a list: texels of more than eight entries
        // were compared, and texels whose list runs past the depth (nothing dropped, so a finite
        // `complete_to` there is the smallest entry left, `rest`).
        let c = &g.cmos[0];
        let count = |i: usize| c.offsets[i + 1] - c.offsets[i];
        assert!((0..c.lo.len()).any(|i| count(i) > 8));
        assert!((0..c.lo.len()).any(|i| count(i) == 16 && c.complete_to[i].is_finite()));
    }
    finish_gpu(ctx);
}

/// Real exported geometry (public meshes of the corpus: slivers and 128-gons, a scan, CAD
/// plates, Blender's export, a room 3.9 km out) at the CMOs each scene file places: GPU and
/// twin equal bit for bit, with `compare_all`'s negatives.
#[test]
fn gpu_matches_the_cpu_twin_on_corpus_scenes() {
    let ctx = gpu_context();
    let (mut longest, mut scanned, mut hard) = (0, false, false);
    for name in ["slivers", "bunny", "cad-mm", "blender-mtl", "far-offset"] {
        let s = common::corpus_scene(name);
        let data = GpuSceneData::new(&s);
        let cmos = cubetrace::vk::passes::capture_lists::scene_views(&s);
        let size = 32;
        let cap = full_capacity(&data, &cmos, size);
        let (g, secs) = run(&ctx, &data, &cmos, size, 16, cap);
        eprintln!("{name} N = {size}: {cap:?}, {:?}, {secs:.3} s", g.counters);
        assert_nothing_dropped(&g);
        // Step 0 keeps the same (triangle, face) pairs on the GPU as on the CPU, and both kinds
        // of job ran (tile jobs and small ones), so the bit-for-bit match below covers both;
        // so do both kinds of pair (`jobs`, `jobs_hard`), over the scenes.
        let c = g.counters;
        assert_eq!(u64::from(c.pairs), cap.pairs, "{name}");
        assert!(c.tile_jobs > 0 && c.small_jobs > 0, "{name}: {c:?}");
        assert_eq!(c.tile_jobs + c.small_jobs, c.jobs, "{name}");
        // `jobs` took the pairs whose rect needs no clip, `jobs_hard` the others.
        hard |= c.hard_pairs > 0;
        assert!(c.hard_pairs < c.pairs, "{name}: {c:?}");
        compare_all(&g, &cpu_lists(&data, &cmos, size, 16));
        // `resolve` scans lists of up to RESOLVE_LONG (32) nodes and merge-sorts longer ones:
        // both kinds were compared.
        let full = cpu_lists(&data, &cmos, size, u32::MAX);
        let lens = full
            .iter()
            .flat_map(|c| c.offsets.windows(2).map(|w| w[1] - w[0]));
        longest = longest.max(lens.clone().max().unwrap_or(0));
        scanned |= lens.clone().any(|n| (9..=32).contains(&n));
    }
    assert!(
        longest > 32 && scanned && hard,
        "{longest}, {scanned}, {hard}"
    );
    finish_gpu(ctx);
}

/// Under a per-binding limit (`maxStorageBufferRange`, lowered) that the pool as one `vec4`
/// binding would exceed, the capture runs (each record and pool word its own binding) and
/// matches the CPU twin bit for bit; a node perturbed in the device's pool is detected, and a
/// limit one word lower is refused, naming the size and the limit.
#[test]
fn a_lowered_range_limit_splits_the_lists_and_matches() {
    use cubetrace::vk::VkError;
    let ctx = gpu_context();
    let (data, cmos) = builtin("sphere-room");
    let size = 32;
    let scene = SceneBuffers::new(&ctx, &data).unwrap();
    let cap = full_capacity(&data, &cmos, size);
    let texels = cmos.len() as u64 * 6 * u64::from(size * size);
    let limit = 4 * texels.max(cap.nodes);
    // The layout before: a node of 16 B (and a record of 16 B) in one binding.
    assert!(
        16 * cap.nodes > limit && 16 * texels > limit,
        "{cap:?}, {limit}"
    );
    let lists =
        CaptureLists::with_range_limit(&ctx, &scene, size, 16, &cmos, cap, None, limit).unwrap();
    ctx.submit_and_wait("capture_lists", |rec| lists.record(rec))
        .unwrap();
    let g = lists.read_back(&ctx, None).unwrap();
    eprintln!("range limit {limit} B: {cap:?}, {:?}", g.counters);
    assert_nothing_dropped(&g);
    let cpu = cpu_lists(&data, &cmos, size, 16);
    compare_all(&g, &cpu);
    // Negative: one kept node's `lo` one ulp up in the device's pool (its `lo` word binding).
    let own = lists.own_targets().unwrap();
    let mut lo: Vec<u32> = ctx.read_buffer(&own.nodes[1]).unwrap();
    let (k, r) = g
        .records
        .iter()
        .enumerate()
        .find(|(_, r)| r[3] > 0)
        .expect("some texel holds an entry");
    lo[r[0] as usize] += 1;
    ctx.write_buffer(&own.nodes[1], &lo).unwrap();
    let bad = lists.read_back(&ctx, None).unwrap();
    let per = 6 * (size * size) as usize;
    let err = compare(&bad.cmos[k / per], &cpu[k / per]).unwrap_err();
    eprintln!("perturbed node detected: {err}");
    drop(lists);
    // A limit a word below the largest binding is refused before anything is allocated.
    let Err(e) =
        CaptureLists::with_range_limit(&ctx, &scene, size, 16, &cmos, cap, None, limit - 4)
    else {
        panic!("a limit below the largest binding was accepted");
    };
    let text = e.to_string();
    eprintln!("{text}");
    assert!(matches!(e, VkError::Limit { .. }), "{text}");
    assert!(text.contains("maxStorageBufferRange"), "{text}");
    assert!(
        text.contains(&format!("{}", texels.max(cap.nodes))),
        "{text}"
    );
    drop(scene);
    finish_gpu(ctx);
}

/// The small triangles seen from one CMO at N = 16: scene, CMOs, size, full capacity, and the
/// CPU twin's full lists (no depth limit).
fn tiny_case() -> (
    GpuSceneData,
    [(Vec3, bool); 1],
    u32,
    PoolBound,
    Vec<TexelLists>,
) {
    let data = tiny_scene(&[(&small_triangles(), false)]);
    let cmos = [(Vec3::new(0.25, -0.5, 0.75), false)];
    let size = 16;
    let cap = full_capacity(&data, &cmos, size);
    let full = cpu_lists(&data, &cmos, size, u32::MAX);
    (data, cmos, size, cap, full)
}

/// `Err` where the GPU's `lo` of texel `i` is above the full lists' (unsound).
fn lo_not_above(gpu: &TexelLists, full: &TexelLists, i: usize) -> Result<(), String> {
    if gpu.lo[i] > full.lo[i] {
        return Err(format!(
            "texel {i}: lo {} above the CPU's {}",
            gpu.lo[i], full.lo[i]
        ));
    }
    Ok(())
}

/// What the GPU kept is the CPU's (full lists) and `complete_to` bounds what it lost; `Err`
/// names the first texel where not.
fn check_sound(gpu: &TexelLists, full: &TexelLists) -> Result<(), String> {
    for i in 0..full.lo.len() {
        let kept = &gpu.entries[gpu.offsets[i] as usize..gpu.offsets[i + 1] as usize];
        let all = &full.entries[full.offsets[i] as usize..full.offsets[i + 1] as usize];
        for e in kept {
            if !all
                .iter()
                .any(|f| f.triangle == e.triangle && f.lo.to_bits() == e.lo.to_bits())
            {
                return Err(format!("texel {i}: kept {e:?} is not the CPU's"));
            }
        }
        for f in all {
            if !kept.iter().any(|e| e.triangle == f.triangle) && gpu.complete_to[i] > f.lo {
                return Err(format!(
                    "texel {i}: lost {f:?} below complete_to {}",
                    gpu.complete_to[i]
                ));
            }
        }
        lo_not_above(gpu, full, i)?;
    }
    Ok(())
}

#[test]
fn tiny_pools_stay_sound() {
    let ctx = gpu_context();
    let (data, cmos, size, cap, full) = tiny_case();
    for (what, tiny) in [
        (
            "nodes",
            PoolBound {
                nodes: cap.nodes / 3,
                ..cap
            },
        ),
        (
            "jobs",
            PoolBound {
                jobs: cap.jobs / 2,
                ..cap
            },
        ),
        (
            "faces",
            PoolBound {
                pairs: cap.pairs / 2,
                ..cap
            },
        ),
    ] {
        let (g, _) = run(&ctx, &data, &cmos, size, 16, tiny);
        eprintln!("tiny {what}: {:?}", g.counters);
        match what {
            "nodes" => assert!(g.counters.nodes_dropped > 0),
            "jobs" => assert!(g.counters.jobs_dropped > 0),
            _ => assert!(g.counters.pairs_dropped > 0),
        }
        check_sound(&g.cmos[0], &full[0]).unwrap();
        // Negative: a texel that lost an entry with complete_to raised to +inf.
        let i = (0..full[0].lo.len())
            .find(|&i| {
                g.cmos[0].offsets[i + 1] - g.cmos[0].offsets[i]
                    < full[0].offsets[i + 1] - full[0].offsets[i]
            })
            .expect("some texel lost an entry");
        let mut bad = g.cmos[0].clone();
        bad.complete_to[i] = f32::INFINITY;
        assert!(check_sound(&bad, &full[0]).is_err());
    }
    finish_gpu(ctx);
}

/// Every entry of the CPU's full lists is kept with bounds at least as wide (or lies beyond
/// `complete_to`), and `lo` is no higher; the GPU may hold more entries. `Err` names the first
/// texel where not.
fn check_looser(gpu: &TexelLists, full: &TexelLists) -> Result<(), String> {
    for i in 0..full.lo.len() {
        let kept = &gpu.entries[gpu.offsets[i] as usize..gpu.offsets[i + 1] as usize];
        let all = &full.entries[full.offsets[i] as usize..full.offsets[i + 1] as usize];
        for f in all {
            let covered = kept
                .iter()
                .any(|e| e.triangle == f.triangle && e.lo <= f.lo && e.hi >= f.hi);
            if !covered && gpu.complete_to[i] > f.lo {
                return Err(format!("texel {i}: {f:?} lost or narrowed"));
            }
        }
        lo_not_above(gpu, full, i)?;
    }
    Ok(())
}

/// A clip queue of 3 entries: the texels that did not fit take their triangle's whole bounds
/// (wider, sound) and are counted.
#[test]
fn a_full_clip_queue_stays_sound() {
    let ctx = gpu_context();
    let (data, cmos, size, cap, full) = tiny_case();
    let (g, _) = run(&ctx, &data, &cmos, size, 16, PoolBound { clips: 3, ..cap });
    eprintln!("tiny clip queue: {:?}", g.counters);
    assert!(g.counters.clips > 3 && g.counters.clips_dropped == g.counters.clips - 3);
    check_looser(&g.cmos[0], &full[0]).unwrap();
    // The full queue's texels differ from the twin's, and narrowing one breaks the check.
    assert!(compare(&g.cmos[0], &full[0]).is_err());
    let (i, k) = (0..full[0].lo.len())
        .find_map(|i| {
            let (a, b) = (
                g.cmos[0].offsets[i] as usize,
                g.cmos[0].offsets[i + 1] as usize,
            );
            let all =
                &full[0].entries[full[0].offsets[i] as usize..full[0].offsets[i + 1] as usize];
            (a..b)
                .find(|&k| {
                    all.iter().any(|f| {
                        let e = g.cmos[0].entries[k];
                        f.triangle == e.triangle && f.lo > e.lo
                    })
                })
                .map(|k| (i, k))
        })
        .expect("some texel took the whole triangle's bounds");
    let mut bad = g.cmos[0].clone();
    let f = full[0].entries[full[0].offsets[i] as usize..full[0].offsets[i + 1] as usize]
        .iter()
        .find(|f| f.triangle == bad.entries[k].triangle)
        .copied()
        .unwrap();
    bad.entries[k].lo = f.lo * 1.01 + 1e-3;
    assert!(check_looser(&bad, &full[0]).is_err());
    finish_gpu(ctx);
}

/// A walk cap of 2 node visits on a built-in scene (the scans cut), and of 100 on a corpus
/// scene whose lists of 33 to 100 nodes the merge sort takes (cut at half the cap): the capped
/// texels are unknown from 0 (sound) and counted.
#[test]
fn capped_walks_stay_sound() {
    let ctx = gpu_context();
    let scenes = [(builtin("sphere-room"), 16, 2), (corpus("cad-mm"), 32, 100)];
    for ((data, cmos), size, walk_cap) in scenes {
        let scene = SceneBuffers::new(&ctx, &data).unwrap();
        let cap = full_capacity(&data, &cmos[..1], size);
        let mut lists = CaptureLists::new(&ctx, &scene, size, 16, &cmos[..1], cap, None).unwrap();
        lists.set_walk_cap(&ctx, walk_cap).unwrap();
        ctx.submit_and_wait("capture_lists", |rec| lists.record(rec))
            .unwrap();
        let g = lists.read_back(&ctx, None).unwrap();
        eprintln!("walk cap {walk_cap}: {:?}", g.counters);
        assert!(g.counters.walks_capped > 0);
        let full = cpu_lists(&data, &cmos[..1], size, u32::MAX);
        check_sound(&g.cmos[0], &full[0]).unwrap();
        let zeros = g.cmos[0].complete_to.iter().filter(|&&c| c == 0.0).count();
        assert_eq!(zeros, g.counters.walks_capped as usize);
        if walk_cap == 100 {
            // A list the scans would not cut (at most 100 nodes) was cut in the merge.
            let len = |i: usize| full[0].offsets[i + 1] - full[0].offsets[i];
            let merged = (0..full[0].lo.len())
                .any(|i| g.cmos[0].complete_to[i] == 0.0 && (33..=100).contains(&len(i)));
            assert!(merged);
        }
        // Negative: the capped texels' complete_to back at +inf.
        let mut bad = g.cmos[0].clone();
        for c in bad.complete_to.iter_mut().filter(|c| **c == 0.0) {
            *c = f32::INFINITY;
        }
        assert!(check_sound(&bad, &full[0]).is_err());
        drop(lists);
        drop(scene);
    }
    finish_gpu(ctx);
}

fn corpus(name: &str) -> (GpuSceneData, Vec<(Vec3, bool)>) {
    let s = common::corpus_scene(name);
    let cmos = cubetrace::vk::passes::capture_lists::scene_views(&s);
    (GpuSceneData::new(&s), cmos)
}

#[test]
fn capture_cost_on_a_builtin_scene() {
    let ctx = gpu_context();
    // Another scene (a built-in name or a scene file) through CUBETRACE_COST_SCENE, another
    // depth through CUBETRACE_COST_DEPTH (the frame's is 256) and other face sizes through
    // CUBETRACE_COST_SIZES (`64,128`), to time the passes with `--nocapture`.
    let name = std::env::var("CUBETRACE_COST_SCENE").unwrap_or("sphere-room".into());
    let (data, cmos) = builtin(&name);
    let scene = SceneBuffers::new(&ctx, &data).unwrap();
    let sizes: Vec<u32> = std::env::var("CUBETRACE_COST_SIZES")
        .map(|s| s.split(',').map(|n| n.parse().unwrap()).collect())
        .unwrap_or(vec![64, 256]);
    for size in sizes {
        let t0 = Instant::now();
        let cap = full_capacity(&data, &cmos[..1], size);
        let cpu_bound = t0.elapsed().as_secs_f64();
        let depth: u32 = std::env::var("CUBETRACE_COST_DEPTH")
            .map(|d| d.parse().unwrap())
            .unwrap_or(16);
        let lists = CaptureLists::new(&ctx, &scene, size, depth, &cmos[..1], cap, None).unwrap();
        // Twice: the first run includes the driver's compilation at the first dispatch.
        for run in 0..2 {
            let mut ts = Timestamps::new(&ctx, 5).unwrap();
            let t0 = Instant::now();
            ctx.submit_and_wait("capture_lists", |rec| {
                ts.reset(rec);
                lists.record_timed(rec, Some(&mut ts))
            })
            .unwrap();
            let wall = t0.elapsed().as_secs_f64();
            let times: Vec<String> = ts
                .results()
                .unwrap()
                .iter()
                .map(|(n, ns)| format!("{n} {:.1} ms", ns / 1e6))
                .collect();
            eprintln!(
                "COST {name}, 1 CMO, N = {size}, run {run}: {wall:.3} s wall; {}; pool \
                 bound on the CPU {cpu_bound:.3} s",
                times.join(", ")
            );
        }
        let g = lists.read_back(&ctx, None).unwrap();
        eprintln!("COST N = {size}: {cap:?}; {:?}", g.counters);
        assert_nothing_dropped(&g);
    }
    drop(scene);
    finish_gpu(ctx);
}

// The capture's fast paths (`cubetrace::cubemap::texel_cone`) on the CPU: f64 samples of random
// triangles against what each path promises.

const CONE_SIZE: u32 = 16;
/// The +Z face (face-local = CMO-local there).
const CONE_FACE: u32 = 4;

fn rng(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// Distance (f64) along direction `d` from the centre to the triangle, `None` on a miss.
fn hit(l: &[Vec3; 3], d: DVec3) -> Option<f64> {
    let [a, b, c] = l.map(|v| v.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    let (s, q) = (-a, (-a).cross(e1));
    let (u, v) = (s.dot(p) / det, d.dot(q) / det);
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then(|| t * d.length())
}

/// The triangle's distances over a 5x5 grid of directions in texel `(x, y)` (unwidened,
/// edges included): `None` where a direction misses.
fn samples(l: &[Vec3; 3], x: u32, y: u32) -> Vec<Option<f64>> {
    let f = |k: u32, i: u32| -1.0 + (2.0 * k as f64 + i as f64 / 2.0) / CONE_SIZE as f64;
    let mut out = Vec::new();
    for j in 0..=4 {
        for i in 0..=4 {
            out.push(hit(l, DVec3::new(f(x, i), f(y, j), 1.0)));
        }
    }
    out
}

/// Random triangles in front of the +Z face, large and small, with their rect's margin
/// and error budget.
fn cases() -> Vec<([Vec3; 3], f32, f32)> {
    let mut s = 7u64;
    let mut out = Vec::new();
    while out.len() < 300 {
        let z = 0.5 + 3.0 * rng(&mut s);
        let spread = if out.len() % 2 == 0 { 2.0 } else { 0.3 };
        let mut v = || {
            let zz = z * (0.7 + 0.6 * rng(&mut s));
            let x = (rng(&mut s) * 2.0 - 1.0) * spread * zz;
            let y = (rng(&mut s) * 2.0 - 1.0) * spread * zz;
            Vec3::new(x as f32, y as f32, zz as f32)
        };
        let tri = [v(), v(), v()];
        if let Some(r) = face_rect(&tri, Vec3::ZERO, CONE_FACE, CONE_SIZE).filter(|r| !r.whole) {
            out.push((face_local(&tri, Vec3::ZERO, CONE_FACE), r.m, r.e));
        }
    }
    out
}

fn planes(x: u32, y: u32, m: f32) -> [f32; 4] {
    [
        face_coord(x, CONE_SIZE) - m,
        face_coord(x + 1, CONE_SIZE) + m,
        face_coord(y, CONE_SIZE) - m,
        face_coord(y + 1, CONE_SIZE) + m,
    ]
}

/// Violations of the fast paths' promises over every texel of every case, with `lo` and
/// `hi` scaled by `scale` and the triangle the tests see shifted by `shift` (the samples are
/// always of the true triangle); also how many texels each path took.
fn violations(scale: (f64, f64), shift: Vec3) -> (usize, [usize; 3]) {
    let (mut bad, mut taken) = (0, [0; 3]);
    for (l, m, e) in cases() {
        let seen = l.map(|v| v + shift);
        let g = edges(&seen);
        for y in 0..CONE_SIZE {
            for x in 0..CONE_SIZE {
                let s = samples(&l, x, y);
                let w = texel_centre_unit(x, y, CONE_SIZE);
                match texel_cone(&seen, planes(x, y, m), w, e) {
                    TexelCone::Outside => {
                        taken[0] += 1;
                        bad += s.iter().filter(|d| d.is_some()).count();
                    }
                    TexelCone::Inside(lo, hi) => {
                        taken[1] += 1;
                        let (lo, hi) = (lo as f64 * scale.0, hi as f64 * scale.1);
                        let out = |d: &Option<f64>| d.is_none_or(|d| d < lo || d > hi);
                        bad += s.iter().filter(|d| out(d)).count();
                    }
                    TexelCone::Clip => taken[2] += 1,
                }
                if tile_outside(&g, [x, x], [y, y], CONE_SIZE, m) {
                    bad += s.iter().filter(|d| d.is_some()).count();
                }
            }
        }
    }
    (bad, taken)
}

#[test]
fn fast_paths_keep_their_promises() {
    let (bad, taken) = violations((1.0, 1.0), Vec3::ZERO);
    assert_eq!(bad, 0, "paths taken (outside, inside, clip): {taken:?}");
    // Every path is exercised, the fast ones on most texels.
    assert!(taken.iter().all(|&n| n > 1000), "{taken:?}");
    assert!(taken[2] * 4 < taken[0] + taken[1], "{taken:?}");
}

#[test]
fn a_perturbed_bound_or_triangle_breaks_them() {
    // `hi` 0.1 % short, `lo` 1 % long (it is below the nearest point by the cone's
    // obliquity, up to 0.4 % at N = 16), a triangle moved by a tenth of a texel.
    assert!(violations((1.0, 0.999), Vec3::ZERO).0 > 0);
    assert!(violations((1.01, 1.0), Vec3::ZERO).0 > 0);
    assert!(violations((1.0, 1.0), Vec3::new(0.0125, 0.0, 0.0)).0 > 0);
}

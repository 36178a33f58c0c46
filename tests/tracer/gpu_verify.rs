//! The verified-hit building blocks on the GPU against their CPU twins (`hit_probe` pass):
//! the watertight ray-triangle test (`spirv/shared/watertight.wgsl` = `cpu::watertight`) bit for
//! bit on hard inputs, and shading at a (triangle, barycentrics) point (`spirv/shared/hit.wgsl`
//! = `reference::Tracer::shade`) over every built-in scene. Needs a Vulkan driver (CI:
//! lavapipe); fails on any validation error.
use crate::common;
use common::{finish_gpu, gpu_context};

use common::hit_probe::{
    ShadeQuery, VerifyQuery, VerifyResult, WatertightQuery, WatertightResult, shade_gpu,
    verify_cpu, verify_gpu, watertight_cpu, watertight_gpu,
};
use cubetrace::check_layout;
use cubetrace::cpu::capture::capture;
use cubetrace::cpu::verify::triangle_corners;
use cubetrace::cubemap::face::dir_to_texel;
use cubetrace::reference::{Hit, Tracer};
use cubetrace::scene::builtin;
use cubetrace::scene::gpu_data::GpuSceneData;
use cubetrace::vk::backend::shaders::HIT_PROBE;
use cubetrace::vk::passes::scene_buffers::SceneBuffers;
use glam::{Vec2, Vec3};

/// Deterministic xorshift in [0, 1).
struct Rng(u32);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
    fn vec(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * scale
    }
}

/// A fan of 8 triangles around a shared vertex in a tilted plane.
fn fan() -> Vec<[Vec3; 3]> {
    let centre = Vec3::new(0.3, -0.2, 4.0);
    let ring: Vec<Vec3> = (0..8)
        .map(|k| {
            let a = k as f32 * std::f32::consts::TAU / 8.0 + 0.1;
            centre + Vec3::new(a.cos() * 1.7, a.sin() * 1.3, a.cos() * 0.6 - a.sin() * 0.3)
        })
        .collect();
    (0..8)
        .map(|k| [centre, ring[k], ring[(k + 1) % 8]])
        .collect()
}

/// A 4 x 4 grid of unit squares at z = 3, two triangles each (diagonals alternating): edges
/// and vertices at exactly representable points.
fn grid() -> Vec<[Vec3; 3]> {
    let p = |x: i32, y: i32| Vec3::new(x as f32 - 2.0, y as f32 - 2.0, 3.0);
    let mut t = Vec::new();
    for y in 0..4 {
        for x in 0..4 {
            let (a, b, c, d) = (p(x, y), p(x + 1, y), p(x + 1, y + 1), p(x, y + 1));
            if (x + y) % 2 == 0 {
                t.push([a, b, c]);
                t.push([a, c, d]);
            } else {
                t.push([a, b, d]);
                t.push([b, c, d]);
            }
        }
    }
    t
}

/// Rays (origin, direction) aimed at points on the shared (interior) edges of `mesh`, and at
/// its vertices shared by three or more triangles (the fan's centre, the grid's inner
/// vertices). A ray aimed there passes through the inside of the mesh even after `aim - o`
/// rounds, so a watertight test must find at least one triangle.
fn edge_rays(mesh: &[[Vec3; 3]]) -> Vec<(Vec3, Vec3)> {
    let origins = [
        Vec3::ZERO,
        Vec3::new(0.7, 0.4, -1.0),
        Vec3::new(-2.0, 1.5, 0.5),
        Vec3::new(0.25, -0.5, 0.0),
    ];
    let has = |t: &[Vec3; 3], p: Vec3| t.contains(&p);
    let shared = |a: Vec3, b: Vec3| mesh.iter().filter(|u| has(u, a) && has(u, b)).count() == 2;
    // Interior vertex: every edge at it is shared by two triangles.
    let interior = |a: Vec3| {
        mesh.iter()
            .filter(|u| has(u, a))
            .all(|u| u.iter().all(|&b| b == a || shared(a, b)))
    };
    let mut aims = Vec::new();
    for t in mesh {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if shared(a, b) {
                aims.extend((1..8).map(|s| a.lerp(b, s as f32 / 8.0)));
            }
            if interior(a) && !aims.contains(&a) {
                aims.push(a);
            }
        }
    }
    aims.iter()
        .flat_map(|&aim| origins.map(|o| (o, aim - o)))
        .collect()
}

/// Every (ray, triangle) pair of the hard cases, plus random ones.
fn hard_queries() -> (Vec<WatertightQuery>, usize) {
    let mut q = Vec::new();
    // Meshes with shared edges and vertices: every edge ray against every triangle.
    for mesh in [fan(), grid()] {
        for (o, d) in edge_rays(&mesh) {
            for t in &mesh {
                q.push(WatertightQuery::new(o, d, *t));
            }
        }
    }
    let mesh_queries = q.len();
    let tri = [
        Vec3::new(-1.0, -1.0, 5.0),
        Vec3::new(1.0, -1.0, 5.0),
        Vec3::new(0.0, 1.0, 5.0),
    ];
    // Parallel to the plane: in it and off it, along each axis of the plane.
    for (o, d) in [
        (Vec3::new(-5.0, 0.0, 5.0), Vec3::X),
        (Vec3::new(-5.0, 0.0, 4.0), Vec3::X),
        (Vec3::new(0.0, -5.0, 5.0), Vec3::Y),
        (Vec3::new(0.0, -5.0, 5.5), Vec3::new(0.0, 1.0, 0.0)),
        (Vec3::new(-5.0, -5.0, 5.0), Vec3::new(1.0, 1.0, 0.0)),
    ] {
        q.push(WatertightQuery::new(o, d, tri));
    }
    // Degenerate triangles: a segment, a point, a sliver, with rays straight through them.
    let seg = [
        Vec3::new(-1.0, 0.0, 5.0),
        Vec3::new(1.0, 0.0, 5.0),
        Vec3::new(0.0, 0.0, 5.0),
    ];
    let point = [Vec3::new(0.0, 0.0, 5.0); 3];
    let sliver = [
        Vec3::new(-1.0, 0.0, 5.0),
        Vec3::new(1.0, 0.0, 5.0),
        Vec3::new(0.0, 1e-7, 5.0),
    ];
    for t in [seg, point, sliver] {
        for o in [
            Vec3::ZERO,
            Vec3::new(0.3, 0.0, 0.0),
            Vec3::new(0.0, 0.5, 1.0),
        ] {
            q.push(WatertightQuery::new(o, Vec3::new(0.0, 0.0, 5.0) - o, t));
        }
    }
    // A zero direction, and rays from behind / away.
    q.push(WatertightQuery::new(Vec3::ZERO, Vec3::ZERO, tri));
    q.push(WatertightQuery::new(Vec3::ZERO, -Vec3::Z, tri));
    // Random rays against random triangles, and against triangles around their aim point.
    let mut r = Rng(0x9e37_79b9);
    for _ in 0..4000 {
        let p = [r.vec(8.0), r.vec(8.0), r.vec(8.0)];
        let o = r.vec(16.0);
        let aim = p[0] * 0.3 + p[1] * 0.3 + p[2] * 0.4 + r.vec(2.0);
        q.push(WatertightQuery::new(o, aim - o, p));
    }
    (q, mesh_queries)
}

fn bits(r: &WatertightResult) -> (u32, u32, [u32; 3]) {
    (r.hit, r.t.to_bits(), r.bary.map(f32::to_bits))
}

#[test]
fn probe_structs_match_naga_layout() {
    let l = |name| HIT_PROBE.struct_layout(name).unwrap();
    check_layout!(
        WatertightQuery,
        l("WatertightQuery"),
        [org, _pad0, dir, _pad1, p0, _pad2, p1, _pad3, p2, _pad4]
    )
    .unwrap();
    check_layout!(
        WatertightResult,
        l("WatertightResult"),
        [bary, t, hit, _pad0, _pad1, _pad2]
    )
    .unwrap();
    check_layout!(ShadeQuery, l("ShadeQuery"), [bary, triangle, _pad]).unwrap();
    check_layout!(
        VerifyQuery,
        l("VerifyQuery"),
        [a, t_done, d, t_hi, centre, size, face, x, y, _pad]
    )
    .unwrap();
    check_layout!(
        VerifyResult,
        l("VerifyResult"),
        [bary, t, position, triangle, hit, _pad0, _pad1, _pad2]
    )
    .unwrap();
}

#[test]
fn watertight_gpu_equals_cpu_bit_for_bit() {
    let ctx = gpu_context();
    let (queries, mesh_queries) = hard_queries();
    let gpu = watertight_gpu(&ctx, &queries).unwrap();
    let cpu: Vec<_> = queries.iter().map(watertight_cpu).collect();
    let differ: Vec<usize> = (0..queries.len())
        .filter(|&i| bits(&gpu[i]) != bits(&cpu[i]))
        .collect();
    let hits = cpu.iter().filter(|r| r.hit == 1).count();
    eprintln!(
        "{} queries, {hits} hits; {} differ",
        queries.len(),
        differ.len()
    );
    assert!(
        differ.is_empty(),
        "GPU and CPU differ on {} queries, first: {:?}",
        differ.len(),
        differ
            .iter()
            .take(5)
            .map(|&i| (queries[i], gpu[i], cpu[i]))
            .collect::<Vec<_>>()
    );
    assert!(hits > 1000 && hits < queries.len() - 1000, "{hits}");
    // Watertight on the GPU too: every edge ray finds at least one triangle of its mesh, and
    // some find two (exactly on an edge).
    let (mut lost, mut both) = (0, 0);
    for mesh in [fan(), grid()] {
        let n = mesh.len();
        let q: Vec<_> = edge_rays(&mesh)
            .into_iter()
            .flat_map(|(o, d)| mesh.iter().map(move |t| WatertightQuery::new(o, d, *t)))
            .collect();
        let r = watertight_gpu(&ctx, &q).unwrap();
        let lost_at = |all: &[WatertightResult], chunk: &[WatertightResult]| {
            (chunk.as_ptr() as usize - all.as_ptr() as usize) / size_of::<WatertightResult>()
        };
        for ray in r.chunks(n) {
            let k = ray.iter().filter(|h| h.hit == 1).count();
            if k == 0 {
                lost += 1;
                eprintln!("lost: {:?}", q[lost_at(&r, ray)]);
            }
            both += usize::from(k > 1);
        }
    }
    assert_eq!(
        lost, 0,
        "a ray through a shared edge or vertex found no triangle"
    );
    assert!(both > 0);
    assert!(mesh_queries > 1000);
    // Parallel rays and zero-area triangles never hit (the 5 + 6 queries after the meshes');
    // the sliver (area 1e-7, next) is hit on its long edge; a zero direction and a ray away
    // from the triangle (after it) miss.
    let special = &gpu[mesh_queries..mesh_queries + 16];
    assert!(special[..11].iter().all(|r| r.hit == 0), "{special:?}");
    assert!(special[11..14].iter().all(|r| r.hit == 1), "{special:?}");
    assert!(special[14..].iter().all(|r| r.hit == 0), "{special:?}");
    // Negative: the CPU on slightly moved origins (1e-4) no longer matches the GPU.
    let moved: Vec<_> = queries
        .iter()
        .map(|q| {
            let mut q = *q;
            q.org[0] += 1e-4;
            watertight_cpu(&q)
        })
        .collect();
    let differ = (0..queries.len())
        .filter(|&i| bits(&gpu[i]) != bits(&moved[i]))
        .count();
    assert!(differ > 1000, "moved origins: only {differ} differ");
    finish_gpu(ctx);
}

/// Per-channel tolerance between `hit_shade` and `Tracer::shade`: the same arithmetic on the
/// same data, apart from the interpolated normal being normalised twice on the GPU (once as
/// `Tracer::normal` does, once inside `scene_shade`), which moves a channel (at most ~1) by an
/// f32 ulp or two. Measured: at most 2.4e-7 (2 ulps at 1) over every built-in scene; the bound
/// is 8 ulps at 1, four times that.
const SHADE_TOL: f32 = 8.0 * f32::EPSILON;

#[test]
fn shading_at_a_hit_matches_the_reference_on_every_scene() {
    let ctx = gpu_context();
    let mut r = Rng(0x1234_5678);
    for &(name, _) in builtin::NAMES {
        let scene = builtin::by_name(name).unwrap();
        let tracer = Tracer::new(&scene);
        let data = GpuSceneData::new(&scene);
        let buffers = SceneBuffers::new(&ctx, &data).unwrap();
        let n = tracer.world.triangles.len() as u32;
        // Up to ~1500 triangles spread over the scene, each at its corners, an edge midpoint,
        // its centroid and a random point.
        let stride = (n / 1500).max(1);
        let mut queries = Vec::new();
        for tri in (0..n).step_by(stride as usize) {
            let (a, b) = (r.next(), r.next());
            let (a, b) = if a + b > 1.0 {
                (1.0 - a, 1.0 - b)
            } else {
                (a, b)
            };
            for bary in [
                [0.0, 0.0],
                [1.0, 0.0],
                [0.0, 1.0],
                [0.5, 0.5],
                [1.0 / 3.0, 1.0 / 3.0],
                [a, b],
            ] {
                queries.push(ShadeQuery {
                    bary,
                    triangle: tri,
                    _pad: 0,
                });
            }
        }
        let cpu: Vec<Vec3> = queries
            .iter()
            .map(|q| {
                let hit = Hit {
                    t: 0.0,
                    position: Vec3::ZERO,
                    triangle: q.triangle,
                    bary: Vec2::from_array(q.bary),
                    error: 0.0,
                };
                tracer.shade(&scene, &hit)
            })
            .collect();
        let diff = |gpu: &[[f32; 3]]| -> (f32, usize) {
            let d: Vec<f32> = gpu
                .iter()
                .zip(&cpu)
                .map(|(g, c)| (Vec3::from_array(*g) - *c).abs().max_element())
                .collect();
            (
                d.iter().copied().fold(0.0, f32::max),
                d.iter().filter(|&&x| x > SHADE_TOL).count(),
            )
        };
        let gpu = shade_gpu(&ctx, &buffers, &queries).unwrap();
        let (max, over) = diff(&gpu);
        eprintln!(
            "{name}: {} samples on {} of {n} triangles, max channel difference {max:e}",
            queries.len(),
            queries.len() / 6
        );
        assert_eq!(
            over, 0,
            "{name}: {over} samples off by more than {SHADE_TOL} (max {max})"
        );
        assert!(
            cpu.iter().any(|c| c.max_element() > 0.1),
            "{name}: not all black"
        );
        // Negative: the neighbouring triangle's shading, and swapped barycentrics, do not match.
        let next: Vec<ShadeQuery> = queries
            .iter()
            .map(|q| ShadeQuery {
                triangle: (q.triangle + 1) % n,
                ..*q
            })
            .collect();
        let (_, over) = diff(&shade_gpu(&ctx, &buffers, &next).unwrap());
        assert!(
            over > queries.len() / 20,
            "{name}: next triangle: only {over} differ"
        );
        let swapped: Vec<ShadeQuery> = queries
            .iter()
            .map(|q| ShadeQuery {
                bary: [q.bary[1], q.bary[0]],
                ..*q
            })
            .collect();
        let (_, over) = diff(&shade_gpu(&ctx, &buffers, &swapped).unwrap());
        assert!(over > 0, "{name}: swapped barycentrics must show");
    }
    finish_gpu(ctx);
}

fn verify_bits(r: &VerifyResult) -> (u32, u32, u32, [u32; 3], [u32; 3]) {
    (
        r.hit,
        r.triangle,
        r.t.to_bits(),
        r.position.map(f32::to_bits),
        r.bary.map(f32::to_bits),
    )
}

/// The verified-hit rule on the GPU (`shared/verify.wgsl`) equals `cpu::verify::verify_hit` bit
/// for bit over the CPU capture's triangle IDs: rays from around the CMO centre, decided at the
/// texel of their exact hit (mostly verified hits), at a texel four away (mostly none), and with
/// the prefix proven empty past the hit (none). Where the ray's exact nearest non-reflector hit
/// is captured, the verified hit is on that triangle for nearly every ray.
#[test]
fn verified_hits_gpu_equal_cpu_bit_for_bit() {
    let ctx = gpu_context();
    let size = 32;
    let mut r = Rng(0x0bad_cafe);
    for name in ["sphere-room", "teapot", "torus"] {
        let scene = builtin::by_name(name).unwrap();
        let tracer = Tracer::new(&scene);
        let centre = scene.cmo_centres()[0];
        let cube = capture(&scene, &tracer, centre, size);
        let ids = cube.triangle.clone();
        let triangles = triangle_corners(&tracer.world);
        let buffers = SceneBuffers::new(&ctx, &GpuSceneData::new(&scene)).unwrap();
        let reach = 0.25 * cube.min_distance();
        let mut queries = Vec::new();
        let mut truth = Vec::new();
        for _ in 0..3000 {
            let a = centre + r.vec(2.0 * reach);
            let d = r.vec(2.0).normalize_or_zero();
            let Some(h) =
                tracer.nearest_accepting(a, d, None, |h| !tracer.is_reflector(h.triangle))
            else {
                continue;
            };
            let texel = dir_to_texel(h.position - centre, size);
            let q = VerifyQuery {
                a: a.to_array(),
                t_done: 0.0,
                d: d.to_array(),
                t_hi: 1e6,
                centre: centre.to_array(),
                size,
                face: texel.face,
                x: texel.x,
                y: texel.y,
                _pad: 0,
            };
            queries.push(q);
            truth.push(h.triangle);
            queries.push(VerifyQuery {
                x: (texel.x + 4) % size,
                ..q
            });
            queries.push(VerifyQuery {
                t_done: h.t * 1.01 + 1e-3,
                ..q
            });
        }
        let gpu = verify_gpu(&ctx, &buffers, &ids, &queries).unwrap();
        let cpu: Vec<_> = queries
            .iter()
            .map(|q| verify_cpu(q, &ids, &triangles))
            .collect();
        let differ = (0..queries.len())
            .filter(|&i| verify_bits(&gpu[i]) != verify_bits(&cpu[i]))
            .count();
        let at_hit: Vec<&VerifyResult> = cpu.iter().step_by(3).collect();
        let verified = at_hit.iter().filter(|v| v.hit == 1).count();
        let same = at_hit
            .iter()
            .zip(&truth)
            .filter(|(v, t)| v.hit == 1 && v.triangle == **t)
            .count();
        let captured = at_hit
            .iter()
            .zip(&truth)
            .filter(|(_, t)| ids.contains(t))
            .count();
        let past = cpu.iter().skip(2).step_by(3).filter(|v| v.hit == 1).count();
        eprintln!(
            "{name}: {} queries, {differ} differ; at the hit texel {verified} of {} verified, {same} on the exact triangle ({captured} exact triangles captured); {past} hits past the prefix",
            queries.len(),
            at_hit.len()
        );
        assert_eq!(differ, 0, "{name}");
        assert!(at_hit.len() > 1000, "{name}");
        // Past the prefix the nearest hit lies in the part proven empty, so few rays still
        // verify (a farther triangle of the texel; the loop below checks each is past
        // `t_done`). Measured on sphere-room: 37 against 2982 with no prefix; the bound is a
        // tenth, so a prefix that were ignored (as many as `verified`) fails it.
        assert!(past * 10 <= verified, "{name}: {past} hits past the prefix");
        assert!(
            same as f64 >= 0.95 * captured as f64,
            "{name}: {same} of {captured}"
        );
        assert!(verified >= same);
        // Every verified hit lies on a triangle the ray meets: the watertight test agrees.
        for (q, v) in queries.iter().zip(&cpu).filter(|(_, v)| v.hit == 1) {
            let w = watertight_cpu(&WatertightQuery::new(
                Vec3::from_array(q.a),
                Vec3::from_array(q.d),
                triangles[v.triangle as usize],
            ));
            assert!(w.hit == 1 && w.t == v.t && w.t >= q.t_done, "{name}");
        }
        // Negative: shifted IDs change the CPU's answers, so the comparison fails.
        let shifted: Vec<u32> = ids
            .iter()
            .map(|&i| {
                if i == u32::MAX {
                    i
                } else {
                    (i + 1) % triangles.len() as u32
                }
            })
            .collect();
        let differ = (0..queries.len())
            .filter(|&i| {
                verify_bits(&gpu[i]) != verify_bits(&verify_cpu(&queries[i], &shifted, &triangles))
            })
            .count();
        assert!(
            differ > queries.len() / 10,
            "{name}: shifted IDs: only {differ} differ"
        );
    }
    finish_gpu(ctx);
}

//! The `bounded` criterion on the GPU: both GPU paths (`--method fragment`,
//! `fs_bounded`; `--method compute`, the `_bounded` entry points) over per-texel lists built on
//! the CPU and uploaded (`GpuRenderer::with_lists`), against each other and against the CPU
//! twin (`cpu::bounded` through its multi-CMO layer, the pyramid march) per mirror pixel:
//! status, CMO, texel, t and point bits, triangle, and the fragment path's counters. With one and two CMOs, with a self-capturing reflector (the start
//! rule: each ray's own triangle is in the lists), and with a perturbed list (the true first
//! triangle dropped), which must change the hits. Runs under the validation layer when
//! installed and fails on any error it reports.
use crate::common;
use common::render::{sized_camera, unresolved_pixels};
use common::{finish_gpu, gpu_context};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::cpu::CmoTracer;
use cubetrace::cpu::bounded::{NO_TRIANGLE, WALK_BUDGET};
use cubetrace::cpu::multi::{
    MultiResult, MultiStatus, Traversal, WorldRay, trace_one, trace_world_ray,
};
use cubetrace::cpu::options::{TraceCriterion, TraceOptions};
use cubetrace::cpu::verify::triangle_corners;
use cubetrace::cubemap::bounds::{Entry, TexelLists};
use cubetrace::cubemap::face::{Texel, to_face_local};
use cubetrace::scene::{Scene, SelfReflections, builtin};
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{
    Fallback, GpuFrame, GpuRenderer, PixelRecord, RECORD_ESCAPED, RECORD_HIT, RECORD_UNRESOLVED,
    RenderOptions, scene_ranges,
};
use cubetrace::vk::passes::lists::{NO_NODE, PackedLists, pack};
use glam::{DVec3, Vec3};

const WIDTH: u32 = 40;
const HEIGHT: u32 = 30;
const SIZE: u32 = 16;
const DEPTH: u32 = 16;

fn camera(scene: &Scene) -> Camera {
    sized_camera(scene, (WIDTH, HEIGHT))
}

fn scene(name: &str, self_reflections: Option<SelfReflections>) -> Scene {
    let mut s = builtin::by_name(name).unwrap();
    s.cmo.resolution = SIZE;
    if let Some(sr) = self_reflections {
        s.self_reflections = sr;
    }
    s
}

fn bounded() -> TraceOptions {
    TraceOptions {
        criterion: TraceCriterion::Bounded,
        ..TraceOptions::default()
    }
}

fn options(method: Method) -> RenderOptions {
    RenderOptions {
        method,
        trace: bounded(),
        // The twin models the tracing pass alone.
        reflector_check: false,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    }
}

/// Clips a face-local polygon to `a . p + b >= 0` (Sutherland-Hodgman), f64.
fn clip(poly: &[DVec3], keep: impl Fn(DVec3) -> f64) -> Vec<DVec3> {
    let mut out = Vec::new();
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (fp, fq) = (keep(p), keep(q));
        if fp >= 0.0 {
            out.push(p);
        }
        if (fp >= 0.0) != (fq >= 0.0) {
            out.push(p + (q - p) * (fp / (fp - fq)));
        }
    }
    out
}

/// The texel rectangle `[x0 - m, x1 + m] x [y0 - m, y1 + m]` (face units) clip of `poly`.
fn clip_rect(poly: &[DVec3], u0: f64, u1: f64, v0: f64, v1: f64) -> Vec<DVec3> {
    let p = clip(poly, |p| p.x - u0 * p.z);
    let p = clip(&p, |p| u1 * p.z - p.x);
    let p = clip(&p, |p| p.y - v0 * p.z);
    clip(&p, |p| v1 * p.z - p.y)
}

/// Sound lists of one CMO, by the design's steps in f64 with a generous error budget
/// (`1e-5` of the coordinates' magnitude): every captured triangle, every face, every texel its
/// dilated frustum meets, `lo` / `hi` from the clipped polygon's vertices.
fn build_lists(
    tris: &[[Vec3; 3]],
    captured: &[bool],
    centre: Vec3,
    size: u32,
    depth: u32,
) -> TexelLists {
    let n = size as usize;
    let nf = f64::from(size);
    let mut lists: Vec<Vec<Entry>> = vec![Vec::new(); 6 * n * n];
    for (t, tri) in tris.iter().enumerate() {
        if !captured[t] {
            continue;
        }
        for face in 0..6u32 {
            let l = tri.map(|v| to_face_local(face, v - centre).as_dvec3());
            let r = l
                .iter()
                .chain(tri.map(|v| v.as_dvec3()).iter())
                .chain([centre.as_dvec3()].iter())
                .map(|v| v.abs().max_element())
                .fold(0.0, f64::max);
            let e = 1e-5 * r;
            let k = 1.0 + 1.0 / 1024.0;
            let p = clip_rect(&l, -k, k, -k, k);
            if p.is_empty() {
                continue;
            }
            let zmin = p.iter().map(|q| q.z).fold(f64::INFINITY, f64::min);
            let m = if zmin <= 4.0 * e {
                2.0
            } else {
                1e-6 + 4.0 * e / zmin
            };
            let cell = |u: f64| (((u + 1.0) * nf / 2.0).floor().clamp(0.0, nf - 1.0)) as usize;
            let (mut ua, mut ub, mut va, mut vb) = (1.0f64, -1.0f64, 1.0f64, -1.0f64);
            for q in &p {
                let (u, v) = (q.x / q.z, q.y / q.z);
                (ua, ub, va, vb) = (ua.min(u), ub.max(u), va.min(v), vb.max(v));
            }
            let (x0, x1) = (cell(ua - m), cell(ub + m));
            let (y0, y1) = (cell(va - m), cell(vb + m));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let c = |i: usize| 2.0 * i as f64 / nf - 1.0;
                    let q = clip_rect(&p, c(x) - m, c(x + 1) + m, c(y) - m, c(y + 1) + m);
                    if q.is_empty() {
                        continue;
                    }
                    let w = DVec3::new(c(x) + 1.0 / nf, c(y) + 1.0 / nf, 1.0).normalize();
                    let lo = q.iter().map(|p| p.dot(w)).fold(f64::INFINITY, f64::min) - e;
                    let hi = q.iter().map(|p| p.length()).fold(0.0, f64::max) + e;
                    let texel = Texel {
                        face,
                        x: x as u32,
                        y: y as u32,
                    };
                    lists[texel.index(size)].push(Entry {
                        triangle: t as u32,
                        lo: (lo.max(0.0) as f32).next_down().max(0.0),
                        hi: (hi as f32).next_up(),
                    });
                }
            }
        }
    }
    resolve(lists, size, depth)
}

/// Sorts, keeps `depth` entries per texel and sets the texel bounds (bounds.rs module docs).
fn resolve(mut lists: Vec<Vec<Entry>>, size: u32, depth: u32) -> TexelLists {
    let mut out = TexelLists {
        size,
        depth,
        lo: Vec::new(),
        hi: Vec::new(),
        complete_to: Vec::new(),
        offsets: vec![0],
        entries: Vec::new(),
    };
    for l in &mut lists {
        l.sort_by(|a, b| a.lo.total_cmp(&b.lo).then(a.triangle.cmp(&b.triangle)));
        let complete_to = l.get(depth as usize).map_or(f32::INFINITY, |e| e.lo);
        l.truncate(depth as usize);
        let first = l.first().map_or(f32::INFINITY, |e| e.lo);
        let hi = if complete_to.is_finite() {
            f32::INFINITY
        } else {
            l.iter().map(|e| e.hi).fold(f32::NEG_INFINITY, f32::max)
        };
        out.lo.push(first.min(complete_to));
        out.hi.push(hi);
        out.complete_to.push(complete_to);
        out.entries.extend_from_slice(l);
        out.offsets.push(out.entries.len() as u32);
    }
    out
}

/// Every CMO's lists for the scene.
fn scene_lists(scene: &Scene, depth: u32) -> Vec<TexelLists> {
    let world = scene.world();
    let tris = cubetrace::cpu::verify::triangle_corners(&world);
    let captured = world.captured_triangles();
    scene
        .cmo_centres()
        .into_iter()
        .map(|c| build_lists(&tris, &captured, c, scene.cmo.resolution, depth))
        .collect()
}

/// The frame and each pixel's G-buffer triangle (the triangle its mirror ray leaves).
fn render_from(
    ctx: &GpuContext,
    scene: &Scene,
    method: Method,
    lists: &[TexelLists],
) -> (GpuFrame, Vec<u32>) {
    render_packed(ctx, scene, method, &pack(lists).unwrap())
}

/// `render_from` of lists in the GPU layout.
fn render_packed(
    ctx: &GpuContext,
    scene: &Scene,
    method: Method,
    lists: &PackedLists,
) -> (GpuFrame, Vec<u32>) {
    let mut r = GpuRenderer::with_lists(ctx, scene, &camera(scene), options(method), lists)
        .unwrap_or_else(|e| panic!("{} {method}: {e}", scene.name));
    let f = r
        .render(ctx)
        .unwrap_or_else(|e| panic!("{} {method}: {e}", scene.name));
    let bytes = ctx
        .read_image(
            &r.gbuffer().triangle,
            ash::vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        )
        .unwrap();
    (f, bytemuck::pod_collect_to_vec(&bytes))
}

/// What the paths and the twin must agree on per pixel: status, CMO, texel, t and point bits,
/// triangle.
type Decision = (u32, u32, [u32; 3], u32, [u32; 3], u32);

fn decision(rec: &PixelRecord) -> Decision {
    (
        rec.status,
        rec.cmo,
        [rec.face, rec.x, rec.y],
        rec.t.to_bits(),
        rec.point.map(f32::to_bits),
        rec.triangle,
    )
}

fn hits(f: &GpuFrame) -> usize {
    (0..f.records.len())
        .filter(|&k| f.mask[k] != 0 && f.records[k].status == RECORD_HIT)
        .count()
}

/// The CPU twin of the frame's ray of each pixel: `cpu::bounded` CMOs over the same lists,
/// through `cpu::multi::trace_world_ray` (the pyramid march, `Traversal::Mip`, as
/// `fs_bounded`), the ray leaving the pixel's G-buffer triangle (`None`: no start triangle, the
/// negative).
struct Twin {
    cmos: Vec<CmoTracer>,
    t_hi: f32,
}

/// A record's counters: texels classified, cells tested (of the last single-CMO trace),
/// single-CMO traces run.
type Work = [u32; 3];

impl Twin {
    fn new(scene: &Scene, lists: &[TexelLists]) -> Twin {
        let corners = triangle_corners(&scene.world());
        let cmos = scene
            .cmo_centres()
            .into_iter()
            .zip(lists)
            .map(|(c, l)| CmoTracer::bounded(c, l.clone(), corners.clone(), bounded().params()))
            .collect();
        Twin {
            cmos,
            t_hi: scene_ranges(scene, &camera(scene)).2,
        }
    }

    fn trace(&self, rec: &PixelRecord, from: u32, how: Traversal) -> MultiResult {
        let ray = WorldRay {
            origin: Vec3::from_array(rec.origin),
            dir: Vec3::from_array(rec.dir),
            from,
            t_lo: 0.0,
            t_hi: self.t_hi,
        };
        trace_world_ray(&self.cmos, &ray, None, |tr, s| trace_one(tr, s, how))
    }

    fn decision(&self, rec: &PixelRecord, from: u32) -> Decision {
        let m = self.trace(rec, from, Traversal::Mip);
        let status = match m.status {
            MultiStatus::Hit => RECORD_HIT,
            MultiStatus::Escaped => RECORD_ESCAPED,
            MultiStatus::Unresolved => RECORD_UNRESOLVED,
        };
        let t = m.result.texel;
        (
            status,
            m.cmo,
            [t.face, t.x, t.y],
            m.result.t.to_bits(),
            m.point.to_array().map(f32::to_bits),
            m.triangle,
        )
    }

    /// Mirror pixels where the frame differs from the twin (with the start rule where
    /// `start_rule`), and the mirror pixels compared.
    fn differences(&self, f: &GpuFrame, from: &[u32], start_rule: bool) -> (usize, usize) {
        let (mut bad, mut compared) = (0, 0);
        for (k, rec) in f.records.iter().enumerate() {
            if f.mask[k] == 0 {
                continue;
            }
            compared += 1;
            let from = if start_rule { from[k] } else { NO_TRIANGLE };
            let want = self.decision(rec, from);
            if decision(rec) != want {
                bad += 1;
                if bad <= 3 {
                    eprintln!("pixel {k}: GPU {rec:?}; CPU {want:?}");
                }
            }
        }
        (bad, compared)
    }

    /// Mirror pixels whose counters (`Work`) differ from the twin's traced with `how`, the
    /// start rule on.
    fn work_differences(&self, f: &GpuFrame, from: &[u32], how: Traversal) -> usize {
        let mut bad = 0;
        for (k, rec) in f.records.iter().enumerate() {
            if f.mask[k] == 0 {
                continue;
            }
            let m = self.trace(rec, from[k], how);
            let c = m.result.counters;
            let want: Work = [c.texels, c.cells, m.traces];
            let got: Work = [rec.texels, rec.cells, rec.traces];
            if got != want {
                bad += 1;
                if bad <= 3 && how == Traversal::Mip {
                    eprintln!("pixel {k}: GPU counters {got:?}; CPU {want:?}");
                }
            }
        }
        bad
    }
}

/// Both GPU paths against the CPU twin on every mirror pixel, bit for bit (status, CMO,
/// texel, t and point bits, triangle), with one CMO (sphere-room), two (default) and a
/// self-capturing reflector (sphere-room, self-reflections on: each ray's own triangle is in
/// the lists of the texel it starts in, the start rule keeps it off it); most mirror pixels
/// hit. The fragment path's counters (texels, cells, traces) equal the twin's pyramid march's
/// (`Traversal::Mip`). Negatives: the twin without the start rule differs on the
/// self-capturing scene, the twin over lists with one hit triangle dropped differs from the
/// frame of the full lists, and the twin's walk (`Traversal::Walk`, what `fs_bounded` did
/// before it marched the pyramid) has other counters on most pixels.
#[test]
fn gpu_paths_match_the_cpu_twin() {
    let ctx = gpu_context();
    for (name, sr) in [
        ("sphere-room", None),
        ("default", None),
        ("sphere-room", Some(SelfReflections::On)),
    ] {
        let s = scene(name, sr);
        let lists = scene_lists(&s, DEPTH);
        let twin = Twin::new(&s, &lists);
        for method in [Method::Fragment, Method::Compute] {
            let (f, from) = render_from(&ctx, &s, method, &lists);
            let (bad, compared) = twin.differences(&f, &from, true);
            eprintln!(
                "{name} (self {sr:?}, {} CMOs) {method}: {bad} of {compared} mirror pixels differ from the twin; {} hits",
                lists.len(),
                hits(&f)
            );
            assert!(compared > 50, "{name}: {compared} mirror pixels");
            assert!(hits(&f) > compared * 3 / 4, "{name}: {} hits", hits(&f));
            assert_eq!(bad, 0, "{name} {method}: GPU and CPU twin differ");
            if method == Method::Fragment {
                // `fs_bounded` marches the pyramid: the twin's counters, and not the walk's.
                let work = twin.work_differences(&f, &from, Traversal::Mip);
                let walk = twin.work_differences(&f, &from, Traversal::Walk);
                eprintln!(
                    "  counters: {work} pixels differ from the twin's pyramid march, {walk} from its walk"
                );
                assert_eq!(
                    work, 0,
                    "{name}: the counters differ from the pyramid march's"
                );
                assert!(
                    walk > compared / 2,
                    "{name}: the counters do not tell the march from the walk ({walk})"
                );
            }
            if sr.is_some() {
                let (off, _) = twin.differences(&f, &from, false);
                eprintln!("  without the start rule the twin differs on {off} pixels");
                assert!(off > 0, "{name}: the start rule was not exercised");
            }
        }
    }
    // Negative: the twin over lists without one pixel's hit triangle.
    let s = scene("sphere-room", None);
    let lists = scene_lists(&s, DEPTH);
    let (f, from) = render_from(&ctx, &s, Method::Fragment, &lists);
    let k = (0..f.records.len())
        .find(|&k| f.mask[k] != 0 && f.records[k].status == RECORD_HIT)
        .unwrap();
    let perturbed = Twin::new(&s, &without(&lists, f.records[k].triangle));
    let (bad, _) = perturbed.differences(&f, &from, true);
    eprintln!(
        "twin without triangle {}: {bad} pixels differ",
        f.records[k].triangle
    );
    assert!(bad > 0, "the comparison missed a dropped triangle");
    finish_gpu(ctx);
}

/// The walk budget: on the teapot capturing itself (its CMO inside it sees its inside, so a
/// ray leaving the surface runs behind it), with every entry's `hi` raised to `+inf` (still
/// sound, and no texel then has a gap to skip through, so such a ray walks a list at every
/// texel), rays that walk more than [`WALK_BUDGET`] lists end unresolved at the next one's
/// entry, on both GPU paths as on the twin, bit for bit. Negative: the twin without the budget
/// differs on those rays.
#[test]
fn the_walk_budget_ends_rays_as_the_twin_does() {
    let ctx = gpu_context();
    let mut s = scene("teapot", Some(SelfReflections::On));
    s.cmo.resolution = 64;
    let mut lists = scene_lists(&s, DEPTH);
    for l in &mut lists {
        for e in &mut l.entries {
            e.hi = f32::INFINITY;
        }
        for (i, h) in l.hi.iter_mut().enumerate() {
            if l.offsets[i] < l.offsets[i + 1] {
                *h = f32::INFINITY;
            }
        }
    }
    let twin = Twin::new(&s, &lists);
    let mut unlimited = Twin::new(&s, &lists);
    for tr in &mut unlimited.cmos {
        tr.bounded.as_mut().unwrap().walk_budget = u32::MAX;
    }
    for method in [Method::Fragment, Method::Compute] {
        let (f, from) = render_from(&ctx, &s, method, &lists);
        let (bad, compared) = twin.differences(&f, &from, true);
        let spent = unresolved_pixels(&f);
        let (off, _) = unlimited.differences(&f, &from, true);
        eprintln!(
            "{method}: {spent} of {compared} rays unresolved; {bad} differ from the twin, {off} from the twin without the budget"
        );
        assert_eq!(bad, 0, "{method}: GPU and CPU twin differ");
        assert!(
            off > compared / 20 && off <= spent,
            "{method}: the budget ended {off} rays ({spent} unresolved)"
        );
    }
    finish_gpu(ctx);
}

/// Whether each triangle is in the lists (what the CMOs capture).
fn captured(scene: &Scene) -> Vec<bool> {
    scene.world().captured_triangles()
}

/// Wrong decisions against the f64 reference (`Tracer::nearest_accepting` over the listed
/// triangles, the ray's own triangle and hits within 1e-3 of the start left out): a hit that is
/// not the first (neither the reference's triangle nor at its t within 1e-4 relative: a tie at
/// a shared edge), or an escape where the reference hits before the ray's end. Unresolved is
/// no error (the lists could not tell). Returns (wrong, hits, unresolved).
fn not_first(scene: &Scene, frame: &GpuFrame, from: &[u32]) -> (usize, usize, usize) {
    let tracer = cubetrace::reference::Tracer::new(scene);
    let captured = captured(scene);
    let (mut wrong, mut hits, mut unresolved) = (0, 0, 0);
    for (k, rec) in frame.records.iter().enumerate() {
        if frame.mask[k] == 0 || rec.status == RECORD_UNRESOLVED {
            unresolved += usize::from(frame.mask[k] != 0);
            continue;
        }
        let (o, d) = (Vec3::from_array(rec.origin), Vec3::from_array(rec.dir));
        let first = tracer.nearest_accepting(o, d, None, |h| {
            captured[h.triangle as usize] && h.triangle != from[k] && h.t > 1e-3
        });
        let ok = if rec.status == RECORD_HIT {
            hits += 1;
            first.is_some_and(|h| {
                h.triangle == rec.triangle || (h.t - rec.t).abs() <= 1e-4 * (1.0 + h.t)
            })
        } else {
            first.is_none_or(|h| h.t > rec.t)
        };
        if !ok {
            wrong += 1;
            if wrong <= 3 {
                eprintln!("pixel {k}: GPU {rec:?}; reference {first:?}");
            }
        }
    }
    (wrong, hits, unresolved)
}

/// `lists` without triangle `tri` anywhere (its texels' bounds left as they were: still sound
/// for what remains).
fn without(lists: &[TexelLists], tri: u32) -> Vec<TexelLists> {
    lists
        .iter()
        .map(|l| {
            let mut out = TexelLists {
                offsets: vec![0],
                entries: Vec::new(),
                ..l.clone()
            };
            for i in 0..l.lo.len() {
                let t = Texel::from_index(i, l.size);
                out.entries
                    .extend(l.entries_at(t).iter().filter(|e| e.triangle != tri));
                out.offsets.push(out.entries.len() as u32);
            }
            out
        })
        .collect()
}

/// Every GPU hit is the first along its ray among the listed triangles (the reference's), with
/// one and two CMOs, and with a self-capturing reflector (the start rule keeps each ray off its
/// own triangle, which is in the lists); more than 100 hits and at most about twice the
/// measured share of mirror pixels unresolved. Negatives: the frame with every record
/// unresolved fails, and so does the frame with just enough more records unresolved to exceed
/// the bound, on that bound alone (giving up is never a hit behind);
/// with the hit triangle of one pixel dropped from the lists, that pixel's decision changes and
/// the check flags it (a hit behind the first, or an escape through it).
#[test]
fn hits_are_first_and_a_dropped_triangle_shows() {
    let ctx = gpu_context();
    // The largest unresolved share of the mirror pixels, about twice the measured: sphere-room
    // 5 of 260 (1.9 %), default 3 of 256 (1.2 %), sphere-room self-capturing 44 of 260 (17 %).
    for (name, sr, max_unresolved) in [
        ("sphere-room", None, 0.04),
        ("default", None, 0.04),
        ("sphere-room", Some(SelfReflections::On), 0.35),
    ] {
        let s = scene(name, sr);
        let lists = scene_lists(&s, DEPTH);
        for method in [Method::Fragment, Method::Compute] {
            let (f, from) = render_from(&ctx, &s, method, &lists);
            let (wrong, hits, unresolved) = not_first(&s, &f, &from);
            let mirror = f.mask.iter().filter(|&&m| m != 0).count();
            eprintln!(
                "{name} (self {sr:?}) {method}: {wrong} wrong, {hits} hits, {unresolved} \
                 unresolved of {mirror} mirror pixels"
            );
            let judge = |(wrong, hits, unresolved): (usize, usize, usize)| {
                if wrong > 0 {
                    Some(format!("{wrong} hits behind the first"))
                } else if hits <= 100 {
                    Some(format!("{hits} hits"))
                } else if unresolved as f64 > max_unresolved * mirror as f64 {
                    Some(format!("{unresolved} of {mirror} unresolved"))
                } else {
                    None
                }
            };
            if let Some(e) = judge((wrong, hits, unresolved)) {
                panic!("{name} (self {sr:?}) {method}: {e}");
            }
            // Negative: the frame given up on every pixel (never a hit behind) fails.
            let mut give_up = f.clone();
            for r in &mut give_up.records {
                r.status = RECORD_UNRESOLVED;
            }
            assert!(
                judge(not_first(&s, &give_up, &from)).is_some(),
                "{name} {method}: a frame that resolves nothing passed"
            );
            // Negative: given up on just enough more pixels to exceed the bound, it fails on
            // that bound alone.
            let mut quit = (max_unresolved * mirror as f64) as usize + 1;
            let mut some = f.clone();
            for (k, r) in some.records.iter_mut().enumerate() {
                if quit > 0 && f.mask[k] != 0 && r.status != RECORD_UNRESOLVED {
                    r.status = RECORD_UNRESOLVED;
                    quit -= 1;
                }
            }
            let e = judge(not_first(&s, &some, &from));
            assert!(
                e.as_ref().is_some_and(|e| e.contains("unresolved")),
                "{name} (self {sr:?}) {method}: giving up on more pixels: {e:?}"
            );
            if sr.is_some() {
                // The start rule: some ray leaves a triangle that a texel it crosses lists.
                let own = (0..f.records.len())
                    .filter(|&k| f.mask[k] != 0 && from[k] != u32::MAX)
                    .filter(|&k| {
                        let rec = &f.records[k];
                        // The texel of CMO 0 the ray starts in.
                        let dir = Vec3::from_array(rec.origin) - s.cmo_centres()[0];
                        let texel = cubetrace::cubemap::face::dir_to_texel(dir, SIZE);
                        lists[0]
                            .entries_at(texel)
                            .iter()
                            .any(|e| e.triangle == from[k])
                    })
                    .count();
                eprintln!("  {own} rays start on a triangle their first texel lists");
                assert!(own > 50, "{name}: the start rule was not exercised ({own})");
            }
        }
    }
    // Negative: drop one pixel's hit triangle.
    let s = scene("sphere-room", None);
    let lists = scene_lists(&s, DEPTH);
    let (f, from) = render_from(&ctx, &s, Method::Fragment, &lists);
    let k = (0..f.records.len())
        .find(|&k| f.mask[k] != 0 && f.records[k].status == RECORD_HIT)
        .unwrap();
    let tri = f.records[k].triangle;
    let perturbed = without(&lists, tri);
    for method in [Method::Fragment, Method::Compute] {
        let (g, _) = render_from(&ctx, &s, method, &perturbed);
        assert_ne!(
            decision(&g.records[k]),
            decision(&f.records[k]),
            "{method}: dropping triangle {tri} left pixel {k} as it was"
        );
        let (wrong, hits, _) = not_first(&s, &g, &from);
        eprintln!("triangle {tri} dropped, {method}: {wrong} wrong ({hits} hits)");
        assert!(
            wrong >= 1,
            "{method}: the check missed the dropped triangle"
        );
    }
    finish_gpu(ctx);
}

/// The fragment path's back-edge cap (lavapipe ends every loop after 65535 back-edges): every
/// texel of a 128^2 CMO lists the same 1024 entries (lo 0, so the pyramid skips nothing; one
/// triangle the mirror rays do not meet, shared in one chain), so each texel crossed reads all
/// of them and long rays reach the
/// cap; they end unresolved with `cut` = 1, and no record claims a hit or an escape it did not
/// finish. Negative: with 8 entries per texel no ray reaches it: every ray escapes, or ends
/// unresolved at the walk budget.
#[test]
fn the_fragment_march_stops_at_its_back_edge_cap() {
    const CAP_SIZE: u32 = 128;
    let ctx = gpu_context();
    let mut s = scene("sphere-room", None);
    s.cmo.resolution = CAP_SIZE;
    let world = s.world();
    // A reflector's triangle: not captured, so no mirror ray of the convex sphere meets it
    // but at its own start (which the start rule skips).
    let mirror = (0..world.triangle_object.len())
        .find(|&t| world.objects[world.triangle_object[t] as usize].reflector)
        .unwrap() as u32;
    let texels = 6 * CAP_SIZE as usize * CAP_SIZE as usize;
    let chain = |count: u32| PackedLists {
        size: CAP_SIZE,
        lo: vec![0.0; texels],
        records: vec![[0, f32::INFINITY.to_bits(), f32::INFINITY.to_bits(), count]; texels],
        nodes: (0..count)
            .map(|i| {
                let next = if i + 1 < count { i + 1 } else { NO_NODE };
                [mirror, 0.0f32.to_bits(), f32::INFINITY.to_bits(), next]
            })
            .collect(),
    };
    let (f, _) = render_packed(&ctx, &s, Method::Fragment, &chain(1024));
    let mirror_pixels = f.mask.iter().filter(|&&m| m != 0).count();
    let cut: Vec<&PixelRecord> = (0..f.records.len())
        .filter(|&k| f.mask[k] != 0 && f.records[k].cut != 0)
        .map(|k| &f.records[k])
        .collect();
    let most = (0..f.records.len())
        .filter(|&k| f.mask[k] != 0)
        .map(|k| f.records[k].texels)
        .max();
    let statuses: Vec<u32> = (0..4)
        .map(|st| {
            (0..f.records.len())
                .filter(|&k| f.mask[k] != 0 && f.records[k].status == st)
                .count() as u32
        })
        .collect();
    eprintln!(
        "1024 entries per texel: {} of {mirror_pixels} rays cut (most texels {most:?}, statuses {statuses:?})",
        cut.len()
    );
    assert!(!cut.is_empty(), "no ray reached the cap");
    assert!(
        cut.iter().all(|r| r.status == RECORD_UNRESOLVED),
        "a cut ray was decided"
    );
    let (g, _) = render_packed(&ctx, &s, Method::Fragment, &chain(8));
    let mirror: Vec<&PixelRecord> = (0..g.records.len())
        .filter(|&k| g.mask[k] != 0)
        .map(|k| &g.records[k])
        .collect();
    // Every texel walks its list here (lo 0), so a ray crossing more than the walk budget's
    // texels ends unresolved there (for the fallback), not cut.
    let escaped = mirror.iter().filter(|r| r.status == RECORD_ESCAPED).count();
    let spent = mirror
        .iter()
        .filter(|r| r.status == RECORD_UNRESOLVED && r.texels > WALK_BUDGET)
        .count();
    eprintln!(
        "8 entries per texel: {escaped} of {mirror_pixels} rays escaped, {spent} spent the walk budget"
    );
    assert!(mirror.iter().all(|r| r.cut == 0), "a ray was cut");
    assert!(escaped > 0 && spent > 0);
    assert_eq!(escaped + spent, mirror_pixels);
    finish_gpu(ctx);
}

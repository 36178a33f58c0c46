//! The capture-quality harness: judges a CPU tracer twin against the exact
//! reference ([`cubetrace::reference::Tracer`]) on every mirror pixel of a scene.
//!
//! Per mirror pixel of the scene's first camera, the reference gives the reflected ray (origin
//! at the mirror hit, unit direction about the interpolated normal, as `reference::finish_path`)
//! and its first hit under the reference's start rule (`Tracer::nearest` with the mirror hit as
//! `from`). A tracer under test ([`Twin`]: one function from a ray to a [`Found`]) traces the
//! same ray over `[0, t_hi]` (`t_hi` the production ray length, `vk::frame::scene_ranges`).
//! Pixels whose reference hit is a reflector are not judged: the CMOs do not hold a convex
//! mirror, the GPU's reflector check traces those rays exactly ([`Quality::reflector_first`]).
//!
//! What [`Quality`] counts over the judged pixels:
//! - **behind**: a resolved pixel on a wrong surface *behind* the reference's first hit: a hit on
//!   another triangle with `t' - t > tol`, or an escape where the reference hits something
//!   (infinitely behind). This is what a capture that misses thin geometry produces: the ray
//!   passes through the missed object and hits the wall behind it.
//! - **in front**: a hit on another triangle with `t - t' > tol`, or a hit where the reference
//!   escapes (a tracer can only do this by a wrong capture or a wrong start rule).
//! - **same triangle** among resolved pixels (both escaped counts as same), and **unresolved**.
//!
//! # The tolerance
//! `t` and `t'` are distances along the same unit ray from the same f32 origin `o`, computed in
//! f64 from f32 points: `t = (p - o) . d` for the reference's point `p` and `t' = (p' - o) . d`
//! for the twin's `p'`. Then `|t - t_exact| <= |p - p_exact| <= Hit::error` (the reference's own
//! bound, module docs of `reference`: a few f32 ulps of `|p|`, widened for grazing hits). The
//! twin's point comes from f32 data in CMO-local coordinates: the origin and the corners minus
//! the centre round to within half an ulp of `R = max |.|_inf` over `o`, the CMO centres and the
//! points, and its watertight test and `c + (a + t d)` add a few more ulps of `R`: a position
//! error of at most `E = 2^-20 R` (16 half-ulps, the capture's error budget in design22), which
//! moves a hit on a plane with unit normal `n'` by `E / |d . n'|` along the ray (we floor
//! `|d . n'|` at `2^-10`). Hence `tol = Hit::error + 2^-20 R / max(|d . n'|, 2^-10)` plus the
//! f64 rounding of the two dot products (`2^-50 R`, absorbed by the margin). Two triangles
//! closer than `tol` along the ray are the same surface to f32 data (a shared edge, coplanar
//! pieces): neither behind nor in front. A missed thin object puts the twin's hit a wall away
//! (0.1 to 3 units here; `tol` is some 1e-6): [`Quality::min_behind`] shows the gap.
use cubetrace::cpu::capture::capture;
use cubetrace::cpu::multi::{MultiResult, MultiStatus, Traversal, Verify, trace_cmos_verified};
use cubetrace::cpu::verify::triangle_corners;
use cubetrace::cpu::watertight::intersect;
use cubetrace::cpu::{CmoTracer, TraceParams};
use cubetrace::cubemap::bounds::TexelLists;
use cubetrace::reference::{Hit, Tracer, reflect};
use cubetrace::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// What a twin found for one ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Found {
    /// A hit on a global triangle at a world point.
    Hit { triangle: u32, point: Vec3 },
    /// The ray left the scene.
    Escaped,
    /// No CMO could decide.
    Unresolved,
}

/// A tracer under test: a probe's world ray `origin + t dir` (`dir` unit, `t in [0, t_hi]`,
/// leaving the mirror hit `from`: its triangle is the start rule's) to what it found. Plugging
/// a tracer in is writing one of these (see [`exact_twin`]).
pub type Twin<'a> = Box<dyn Fn(&Probe) -> Found + Sync + 'a>;

/// One mirror pixel's reflected ray and the reference's first hit along it.
#[derive(Debug, Clone, Copy)]
pub struct Probe {
    /// The mirror hit the ray leaves (`origin` is its position).
    pub from: Hit,
    pub origin: Vec3,
    pub dir: Vec3,
    pub reference: Option<Hit>,
}

/// A scene prepared for judging: the reference tracer, the triangles' corners, the CMO centres,
/// the ray length and every mirror pixel's [`Probe`].
pub struct Bench {
    pub scene: Scene,
    pub tracer: Tracer,
    pub corners: Vec<[Vec3; 3]>,
    pub centres: Vec<Vec3>,
    pub t_hi: f32,
    pub probes: Vec<Probe>,
}

impl Bench {
    pub fn new(scene: Scene) -> Bench {
        let tracer = Tracer::new(&scene);
        let camera = scene.cameras[0].clone();
        let (_, _, t_hi) = cubetrace::vk::frame::scene_ranges(&scene, &camera);
        let n = (camera.width * camera.height) as usize;
        let probes = (0..n)
            .into_par_iter()
            .filter_map(|k| {
                let (i, j) = ((k as u32) % camera.width, (k as u32) / camera.width);
                let (o, d) = camera.ray(i, j);
                let h = tracer.nearest(o, d, None)?;
                if !tracer.is_reflector(h.triangle) {
                    return None;
                }
                let dir = reflect(d, tracer.normal(&h)).normalize();
                Some(Probe {
                    from: h,
                    origin: h.position,
                    dir,
                    reference: tracer.nearest(h.position, dir, Some(&h)),
                })
            })
            .collect();
        Bench {
            corners: triangle_corners(&tracer.world),
            centres: scene.cmo_centres(),
            scene,
            tracer,
            t_hi,
            probes,
        }
    }

    /// Global triangle range of the mesh named `name` (all its parts).
    pub fn mesh_triangles(&self, name: &str) -> std::ops::Range<u32> {
        let objects: Vec<_> = self
            .tracer
            .world
            .objects
            .iter()
            .filter(|o| o.name.split('/').next() == Some(name))
            .collect();
        assert!(!objects.is_empty(), "no mesh {name}");
        let first = objects[0].first_triangle;
        let last = objects
            .last()
            .map_or(first, |o| o.first_triangle + o.triangle_count);
        first..last
    }

    /// The judging tolerance of a twin's hit on `triangle` at `point` against the reference's
    /// `reference` (module docs).
    pub fn tolerance(&self, p: &Probe, reference: &Hit, triangle: u32, point: Vec3) -> f64 {
        let inf = |v: Vec3| v.abs().max_element() as f64;
        let r = self.centres.iter().map(|&c| inf(c)).fold(
            inf(p.origin).max(inf(point)).max(inf(reference.position)),
            f64::max,
        );
        let cos = self
            .corners
            .get(triangle as usize)
            .map_or(1.0, |&[a, b, c]| {
                let n = (b - a)
                    .as_dvec3()
                    .cross((c - a).as_dvec3())
                    .normalize_or_zero();
                n.dot(p.dir.as_dvec3()).abs()
            });
        reference.error + 2f64.powi(-20) * r / cos.max(2f64.powi(-10))
    }

    /// Judges `twin` on every mirror pixel.
    pub fn judge(&self, twin: &Twin) -> Quality {
        let verdicts: Vec<Verdict> = self
            .probes
            .par_iter()
            .map(|p| self.verdict(p, twin(p)))
            .collect();
        let mut q = Quality {
            mirror: self.probes.len(),
            min_behind: f64::INFINITY,
            ..Quality::default()
        };
        for v in verdicts {
            match v {
                Verdict::ReflectorFirst => q.reflector_first += 1,
                Verdict::Unresolved => q.unresolved += 1,
                Verdict::Same => q.same += 1,
                Verdict::Tie => q.tie += 1,
                Verdict::Behind(gap) => {
                    q.behind += 1;
                    q.min_behind = q.min_behind.min(gap);
                }
                Verdict::InFront => q.in_front += 1,
            }
        }
        q
    }

    /// How one pixel is judged (module docs).
    pub fn verdict(&self, p: &Probe, found: Found) -> Verdict {
        let along = |x: Vec3| (x.as_dvec3() - p.origin.as_dvec3()).dot(p.dir.as_dvec3());
        if let Some(h) = &p.reference
            && self.tracer.is_reflector(h.triangle)
        {
            return Verdict::ReflectorFirst;
        }
        match (found, &p.reference) {
            (Found::Unresolved, _) => Verdict::Unresolved,
            (Found::Escaped, None) => Verdict::Same,
            (Found::Escaped, Some(_)) => Verdict::Behind(f64::INFINITY),
            (Found::Hit { .. }, None) => Verdict::InFront,
            (Found::Hit { triangle, point }, Some(h)) => {
                if triangle == h.triangle {
                    return Verdict::Same;
                }
                let gap = along(point) - along(h.position);
                let tol = self.tolerance(p, h, triangle, point);
                if gap > tol {
                    Verdict::Behind(gap)
                } else if gap < -tol {
                    Verdict::InFront
                } else {
                    Verdict::Tie
                }
            }
        }
    }
}

/// One pixel's judgement ([`Bench::verdict`]); `Behind` holds the gap `t' - t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    ReflectorFirst,
    Unresolved,
    Same,
    Tie,
    Behind(f64),
    InFront,
}

/// What [`Bench::judge`] counted (module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Quality {
    /// Mirror pixels.
    pub mirror: usize,
    /// Of those, not judged: the reference's first hit is a reflector.
    pub reflector_first: usize,
    /// Judged and unresolved.
    pub unresolved: usize,
    /// Resolved on the reference's triangle (or both escaped).
    pub same: usize,
    /// Resolved on another triangle within the tolerance of the reference's hit.
    pub tie: usize,
    /// Resolved on a wrong surface behind the reference's first hit (or escaped past it).
    pub behind: usize,
    /// Resolved on a wrong surface in front of it (or a hit where the reference escapes).
    pub in_front: usize,
    /// The smallest gap `t' - t` among the behind pixels (`inf` for escapes or none).
    pub min_behind: f64,
}

impl Quality {
    pub fn judged(&self) -> usize {
        self.mirror - self.reflector_first
    }
    pub fn resolved(&self) -> usize {
        self.judged() - self.unresolved
    }
    /// Same-triangle share of the resolved pixels (1 when none is resolved).
    pub fn same_share(&self) -> f64 {
        if self.resolved() == 0 {
            1.0
        } else {
            self.same as f64 / self.resolved() as f64
        }
    }
    /// Unresolved share of the judged pixels.
    pub fn unresolved_share(&self) -> f64 {
        self.unresolved as f64 / self.judged().max(1) as f64
    }
    /// One line for the test log.
    pub fn line(&self) -> String {
        format!(
            "mirror {:5} judged {:5} | behind {:4} (min gap {:.3e}) in front {:3} | same {:6.2} % \
             tie {:3} | unresolved {:6.2} %",
            self.mirror,
            self.judged(),
            self.behind,
            self.min_behind,
            self.in_front,
            100.0 * self.same_share(),
            self.tie,
            100.0 * self.unresolved_share()
        )
    }
}

/// The reference itself as a twin, among the triangles `keep` accepts (the harness's own
/// controls: with every triangle it must judge perfect; without the thin geometry it must see
/// hits behind).
pub fn reference_twin<'a>(bench: &'a Bench, keep: impl Fn(u32) -> bool + Sync + 'a) -> Twin<'a> {
    Box::new(move |p| {
        match bench
            .tracer
            .nearest_where(p.origin, p.dir, Some(&p.from), &keep)
        {
            Some(h) => Found::Hit {
                triangle: h.triangle,
                point: h.position,
            },
            None => Found::Escaped,
        }
    })
}

/// The ideal f32 twin of a CMO at `centre`: every captured triangle tested with the
/// watertight test (`cpu::watertight::intersect`, what `bounded` runs on its candidates) in
/// CMO-local coordinates (the origin and the corners minus the centre, in f32), the nearest
/// `t > 0` kept (ties: the lower triangle), the point `centre + (a + t d)`. What `bounded`
/// must equal when its lists hold every triangle the ray meets; the harness's check that its
/// tolerance and the targets hold for f32 arithmetic, not only for the reference's f64.
/// Reflectors are left out (the scenes' mirror is convex: `bounded` holds it only when the CMO
/// captures reflectors).
pub fn watertight_twin(bench: &Bench, centre: Vec3) -> Twin<'_> {
    let local: Vec<(u32, [Vec3; 3])> = bench
        .corners
        .iter()
        .enumerate()
        .filter(|&(k, _)| !bench.tracer.is_reflector(k as u32))
        .map(|(k, c)| (k as u32, c.map(|v| v - centre)))
        .collect();
    Box::new(move |p| {
        let a = p.origin - centre;
        let mut best: Option<(f32, u32)> = None;
        for &(k, tri) in &local {
            let Some(h) = intersect(a, p.dir, tri) else {
                continue;
            };
            if h.t <= bench.t_hi && best.is_none_or(|(t, _)| h.t < t) {
                best = Some((h.t, k));
            }
        }
        match best {
            Some((t, triangle)) => Found::Hit {
                triangle,
                point: centre + (a + t * p.dir),
            },
            None => Found::Escaped,
        }
    })
}

/// The `exact` criterion's CPU twin (what `--method fragment` and `--method compute` run by
/// default): centre-sampled captures (`cpu::capture::capture`, one per CMO centre, face size
/// `size`), traced with the pyramid and every hit verified (`cpu::multi::trace_cmos_verified`).
pub fn exact_twin(bench: &Bench, size: u32) -> Twin<'_> {
    let cmos: Vec<CmoTracer> = bench
        .centres
        .iter()
        .map(|&c| {
            CmoTracer::new(
                capture(&bench.scene, &bench.tracer, c, size),
                TraceParams::default(),
            )
        })
        .collect();
    Box::new(move |p| {
        let verify = Verify {
            triangles: &bench.corners,
        };
        let (o, d, t_hi) = (p.origin, p.dir, bench.t_hi);
        found(&trace_cmos_verified(
            &cmos,
            o,
            d,
            0.0,
            t_hi,
            Traversal::Mip,
            Some(verify),
        ))
    })
}

/// The `bounded` criterion's CPU twin (`--criterion bounded`): the CMOs' lists from
/// `cubemap::bounds::capture_lists`, traced by `cpu::bounded` over the 2x2 pyramid, the ray
/// leaving the mirror triangle (the start rule). `perturb` edits each CMO's lists before tracing
/// (the tests' negative drops the thin geometry's entries, [`drop_entries`]); the identity for
/// the real check.
pub fn bounded_twin<'a>(
    bench: &'a Bench,
    size: u32,
    perturb: &dyn Fn(&mut TexelLists),
) -> Option<Twin<'a>> {
    let cmos = bounded_cmos(bench, size, perturb);
    Some(Box::new(move |p| found(&bounded_ray(bench, &cmos, p))))
}

/// The CMOs of [`bounded_twin`].
pub fn bounded_cmos(bench: &Bench, size: u32, perturb: &dyn Fn(&mut TexelLists)) -> Vec<CmoTracer> {
    let captured = captured_flags(bench);
    bench
        .centres
        .iter()
        .map(|&c| {
            let mut lists = cubetrace::cubemap::bounds::capture_lists(
                &bench.corners,
                &captured,
                c,
                size,
                cubetrace::cubemap::bounds::DEFAULT_DEPTH,
            );
            perturb(&mut lists);
            CmoTracer::bounded(c, lists, bench.corners.clone(), TraceParams::default())
        })
        .collect()
}

/// One probe's ray traced by [`bounded_twin`].
pub fn bounded_ray(bench: &Bench, cmos: &[CmoTracer], p: &Probe) -> MultiResult {
    let ray = cubetrace::cpu::multi::WorldRay {
        origin: p.origin,
        dir: p.dir,
        from: p.from.triangle,
        t_lo: 0.0,
        t_hi: bench.t_hi,
    };
    cubetrace::cpu::multi::trace_world_ray(cmos, &ray, None, |tr, s| {
        cubetrace::cpu::multi::trace_one(tr, s, Traversal::Mip)
    })
}

/// Per global triangle, whether the capture takes it (design22, "Which triangles": every
/// triangle of a captured object; a reflector's only when it captures itself).
pub fn captured_flags(bench: &Bench) -> Vec<bool> {
    bench.tracer.world.captured_triangles()
}

/// A multi-CMO result as the harness reads it.
pub fn found(r: &MultiResult) -> Found {
    match r.status {
        MultiStatus::Hit => Found::Hit {
            triangle: r.triangle,
            point: r.point,
        },
        MultiStatus::Escaped => Found::Escaped,
        MultiStatus::Unresolved => Found::Unresolved,
    }
}

/// Drops every entry of the triangles in `drop` from the lists, leaving each texel's `lo`,
/// `hi` and `complete_to` as they were (the lists then claim to be complete without them: an
/// unsound capture the harness must catch).
pub fn drop_entries(lists: &mut TexelLists, drop: &std::ops::Range<u32>) {
    let mut entries = Vec::with_capacity(lists.entries.len());
    let mut offsets = vec![0u32];
    for t in 0..lists.offsets.len() - 1 {
        let (a, b) = (lists.offsets[t] as usize, lists.offsets[t + 1] as usize);
        entries.extend(
            lists.entries[a..b]
                .iter()
                .filter(|e| !drop.contains(&e.triangle)),
        );
        offsets.push(entries.len() as u32);
    }
    lists.entries = entries;
    lists.offsets = offsets;
}

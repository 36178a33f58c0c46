#![forbid(unsafe_code)]
//! The exact CPU reference renderer: the ground truth every accuracy figure is measured against.
//!
//! Per pixel, one primary ray through the pixel centre ([`Camera::ray`], Vulkan's convention).
//! On a reflector, the ray reflects about the interpolated vertex normal (normalised, not
//! flipped: exactly what the rasteriser interpolates) and is traced again, up to `bounces`
//! reflections. Reflectors count as hits, so self-reflections are included. The first
//! non-reflector hit is shaded ([`crate::shading`]), a ray that leaves the scene takes the
//! background, and a reflector met after the last bounce is shaded with its own material.
//!
//! Nearest hits come from a BVH built by the `obvhs` crate: it builds with glam types directly
//! (no conversion to nalgebra, which `bvh` and `parry3d` would need), is deterministic when
//! built single-threaded (as here), and lets us supply the triangle test, so the test runs in
//! f64 (Möller–Trumbore) and ties are broken by the lower triangle index. A reflected ray
//! ignores the triangle it starts on (instead of a distance bias), plus hits closer than
//! [`SELF_HIT_EPSILON`] times the scene's extent, which only neighbouring triangles sharing the
//! start point's edge can produce.
//!
//! Rendering is parallel over rows with `rayon`; every pixel is computed independently, so the
//! output is the same bits for the same scene whatever the thread count.

use glam::{DVec3, Vec2, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::ray::{Ray, RayHit};
use rayon::prelude::*;

use crate::camera::Camera;
use crate::scene::{Scene, WorldGeometry};
use crate::shading::albedo;

/// Hits nearer than this fraction of the scene's extent are ignored on reflected rays.
pub const SELF_HIT_EPSILON: f32 = 1e-6;

/// "No object / no primitive" in [`Frame`] ids.
pub const NO_ID: u32 = u32::MAX;

/// The per-pixel result of a render, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Linear RGB.
    pub colour: Vec<Vec3>,
    /// 1 where the primary ray hits a reflector.
    pub mask: Vec<u8>,
    /// World-space point hit by the primary ray (NaN where it leaves the scene).
    pub surface_position: Vec<Vec3>,
    /// World-space point hit by the first reflected ray (NaN where there is none).
    pub hit_position: Vec<Vec3>,
    /// Object hit by the first reflected ray ([`NO_ID`] where none).
    pub object_id: Vec<u32>,
    /// Triangle (within its object) hit by the first reflected ray ([`NO_ID`] where none).
    pub primitive_id: Vec<u32>,
    /// Number of reflections the pixel's path took.
    pub bounces: Vec<u8>,
}

impl Frame {
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Frame {
            width,
            height,
            colour: vec![Vec3::ZERO; n],
            mask: vec![0; n],
            surface_position: vec![Vec3::NAN; n],
            hit_position: vec![Vec3::NAN; n],
            object_id: vec![NO_ID; n],
            primitive_id: vec![NO_ID; n],
            bounces: vec![0; n],
        }
    }

    pub fn index(&self, i: u32, j: u32) -> usize {
        (j * self.width + i) as usize
    }

    pub fn mirror_pixels(&self) -> usize {
        self.mask.iter().filter(|&&m| m != 0).count()
    }

    /// Stores pixel `k`'s path.
    fn set_path(&mut self, k: usize, tracer: &Tracer, p: PathResult) {
        self.colour[k] = p.colour;
        self.mask[k] = p.mirror as u8;
        self.surface_position[k] = p.surface.unwrap_or(Vec3::NAN);
        self.bounces[k] = p.bounces;
        if let Some(h) = p.first_reflected {
            self.hit_position[k] = h.position;
            let (o, prim) = tracer.ids(h.triangle);
            self.object_id[k] = o;
            self.primitive_id[k] = prim;
        }
    }
}

/// A nearest hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub position: Vec3,
    /// Global triangle index in [`WorldGeometry::triangles`].
    pub triangle: u32,
    /// Barycentric weights of vertices 1 and 2.
    pub bary: Vec2,
}

/// A scene prepared for ray queries.
pub struct Tracer {
    pub world: WorldGeometry,
    bvh: Bvh2,
    /// Triangles in BVH order.
    tris: Vec<[Vec3; 3]>,
    /// BVH order -> global triangle index.
    order: Vec<u32>,
    self_hit: f32,
}

struct Tri<'a>(&'a [Vec3; 3]);

impl obvhs::Boundable for Tri<'_> {
    fn aabb(&self) -> Aabb {
        let [a, b, c] = *self.0;
        Aabb::new(Vec3A::from(a.min(b).min(c)), Vec3A::from(a.max(b).max(c)))
    }
}

/// f64 Möller–Trumbore; returns `(t, b1, b2)` with edges included.
fn intersect(o: DVec3, d: DVec3, tri: &[Vec3; 3]) -> Option<(f64, f64, f64)> {
    let [a, b, c] = tri.map(|v| v.as_dvec3());
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(q) * inv, u, v))
}

impl Tracer {
    pub fn new(scene: &Scene) -> Self {
        Self::from_world(scene.world())
    }

    pub fn from_world(world: WorldGeometry) -> Self {
        let tris_in: Vec<[Vec3; 3]> = world
            .triangles
            .iter()
            .map(|t| t.map(|i| world.positions[i as usize]))
            .collect();
        let prims: Vec<Tri> = tris_in.iter().map(Tri).collect();
        let bvh = if prims.is_empty() {
            Bvh2::default()
        } else {
            let mut t = std::time::Duration::ZERO;
            obvhs::bvh2::builder::build_bvh2(&prims, obvhs::BvhBuildParams::medium_build(), &mut t)
        };
        let order = bvh.primitive_indices.clone();
        let tris = order.iter().map(|&i| tris_in[i as usize]).collect();
        let self_hit = SELF_HIT_EPSILON * world.extent();
        Tracer {
            world,
            bvh,
            tris,
            order,
            self_hit,
        }
    }

    /// The nearest hit along `origin + t dir`, `t > 0`, ignoring triangle `skip` (and, when
    /// `skip` is set, hits closer than the self-hit distance).
    pub fn nearest(&self, origin: Vec3, dir: Vec3, skip: Option<u32>) -> Option<Hit> {
        self.nearest_where(origin, dir, skip, |_| true)
    }

    /// [`Tracer::nearest`] among the triangles (global indices) that `accept` keeps.
    pub fn nearest_where(
        &self,
        origin: Vec3,
        dir: Vec3,
        skip: Option<u32>,
        accept: impl Fn(u32) -> bool,
    ) -> Option<Hit> {
        self.nearest_accepting(origin, dir, skip, |h| accept(h.triangle))
    }

    /// [`Tracer::nearest`] among the hits that `accept` keeps: a rejected hit is passed through,
    /// as a discarded fragment lets the next surface show.
    pub fn nearest_accepting(
        &self,
        origin: Vec3,
        dir: Vec3,
        skip: Option<u32>,
        accept: impl Fn(&Hit) -> bool,
    ) -> Option<Hit> {
        if self.tris.is_empty() {
            return None;
        }
        let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
        let t_min = if skip.is_some() {
            self.self_hit as f64
        } else {
            0.0
        };
        let mut best: Option<(f64, u32, f64, f64)> = None;
        let ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), 0.0, f32::INFINITY);
        let mut hit = RayHit::none();
        let candidate = |t: f64, triangle: u32, u: f64, v: f64| Hit {
            t: t as f32,
            position: (o + d * t).as_vec3(),
            triangle,
            bary: Vec2::new(u as f32, v as f32),
        };
        self.bvh.ray_traverse(ray, &mut hit, |_, k| {
            let global = self.order[k];
            if Some(global) == skip {
                return f32::INFINITY;
            }
            match intersect(o, d, &self.tris[k]) {
                Some((t, u, v)) if t > t_min && accept(&candidate(t, global, u, v)) => {
                    let better = match best {
                        None => true,
                        Some((bt, bg, _, _)) => t < bt || (t == bt && global < bg),
                    };
                    if better {
                        best = Some((t, global, u, v));
                    }
                    // Round up so that node culling never drops an equally near triangle.
                    let tf = t as f32;
                    if (tf as f64) < t { tf.next_up() } else { tf }
                }
                _ => f32::INFINITY,
            }
        });
        best.map(|(t, triangle, u, v)| candidate(t, triangle, u, v))
    }

    /// Interpolated, normalised vertex normal at a hit (the rasteriser's shading normal).
    pub fn normal(&self, hit: &Hit) -> Vec3 {
        let [a, b, c] =
            self.world.triangles[hit.triangle as usize].map(|i| self.world.normals[i as usize]);
        let (u, v) = (hit.bary.x, hit.bary.y);
        (a * (1.0 - u - v) + b * u + c * v).normalize_or_zero()
    }

    pub fn uv(&self, hit: &Hit) -> Vec2 {
        let [a, b, c] =
            self.world.triangles[hit.triangle as usize].map(|i| self.world.uvs[i as usize]);
        let (u, v) = (hit.bary.x, hit.bary.y);
        a * (1.0 - u - v) + b * u + c * v
    }

    /// Object id and primitive id (within the object) of a global triangle index.
    pub fn ids(&self, triangle: u32) -> (u32, u32) {
        let o = self.world.triangle_object[triangle as usize];
        (o, triangle - self.world.objects[o as usize].first_triangle)
    }

    pub fn is_reflector(&self, triangle: u32) -> bool {
        self.world.objects[self.world.triangle_object[triangle as usize] as usize].reflector
    }

    /// The view-independent shaded colour at a hit.
    pub fn shade(&self, scene: &Scene, hit: &Hit) -> Vec3 {
        let object =
            &self.world.objects[self.world.triangle_object[hit.triangle as usize] as usize];
        let material = &scene.materials[object.material as usize];
        scene.shading.shade(
            albedo(material, &scene.textures, self.uv(hit)),
            self.normal(hit),
        )
    }
}

/// The mirror direction of `d` about the unit normal `n`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// One pixel's path.
#[derive(Clone, Copy, Debug)]
pub struct PathResult {
    pub colour: Vec3,
    pub surface: Option<Vec3>,
    pub mirror: bool,
    pub first_reflected: Option<Hit>,
    pub bounces: u8,
}

/// Traces one path from `origin` along `dir` with up to `max_bounces` reflections.
pub fn trace_path(
    scene: &Scene,
    tracer: &Tracer,
    origin: Vec3,
    dir: Vec3,
    max_bounces: u32,
) -> PathResult {
    finish_path(
        scene,
        tracer,
        dir,
        tracer.nearest(origin, dir, None),
        max_bounces,
    )
}

/// The rest of [`trace_path`] once the primary ray (along `dir`) has found `first`: the
/// reflections off mirrors and the shading at the end. Split out so that the harness can time
/// the reflected rays on their own ([`render_phased`]).
pub fn finish_path(
    scene: &Scene,
    tracer: &Tracer,
    dir: Vec3,
    first: Option<Hit>,
    max_bounces: u32,
) -> PathResult {
    let mut out = PathResult {
        colour: scene.background,
        surface: None,
        mirror: false,
        first_reflected: None,
        bounces: 0,
    };
    let Some(mut hit) = first else {
        return out;
    };
    out.surface = Some(hit.position);
    out.mirror = tracer.is_reflector(hit.triangle);
    let mut d = dir;
    let mut bounce = 0u32;
    while tracer.is_reflector(hit.triangle) && bounce < max_bounces {
        d = reflect(d, tracer.normal(&hit)).normalize();
        bounce += 1;
        out.bounces = bounce as u8;
        let Some(next) = tracer.nearest(hit.position, d, Some(hit.triangle)) else {
            out.colour = scene.background;
            return out;
        };
        if bounce == 1 {
            out.first_reflected = Some(next);
        }
        hit = next;
    }
    out.colour = tracer.shade(scene, &hit);
    out
}

/// Renders `camera`'s view of `scene` with up to `bounces` reflections per path.
pub fn render(scene: &Scene, tracer: &Tracer, camera: &Camera, bounces: u32) -> Frame {
    render_with_progress(
        scene,
        tracer,
        camera,
        bounces,
        &indicatif::ProgressBar::hidden(),
    )
}

/// [`render`], advancing `progress` by one per finished row.
pub fn render_with_progress(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
    bounces: u32,
    progress: &indicatif::ProgressBar,
) -> Frame {
    let mut frame = Frame::new(camera.width, camera.height);
    let w = camera.width as usize;
    progress.set_length(camera.height as u64);
    let rows: Vec<Vec<PathResult>> = (0..camera.height)
        .into_par_iter()
        .map(|j| {
            let row = (0..camera.width)
                .map(|i| {
                    let (o, d) = camera.ray(i, j);
                    trace_path(scene, tracer, o, d, bounces)
                })
                .collect();
            progress.inc(1);
            row
        })
        .collect();
    progress.finish_and_clear();
    for (j, row) in rows.into_iter().enumerate() {
        for (i, p) in row.into_iter().enumerate() {
            frame.set_path(j * w + i, tracer, p);
        }
    }
    frame
}

/// Wall-clock times of the two phases of [`render_phased`], nanoseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    /// Primary rays of every pixel, and the shading of the pixels that are not mirrors.
    pub primary_ns: f64,
    /// The mirror pixels' reflected rays: each traced to its hit (and on, up to the bounces)
    /// and shaded there. This is the work the GPU tracing passes do.
    pub reflected_ns: f64,
    /// Mirror pixels, i.e. first reflected rays.
    pub reflected_rays: usize,
}

/// [`render`] in two timed phases: first every primary ray (and the shading of non-mirror
/// pixels), then the reflected rays of the mirror pixels, each phase parallel over pixels.
/// The frame is the same bits as [`render`]'s (tested); only the order of work differs.
pub fn render_phased(
    scene: &Scene,
    tracer: &Tracer,
    camera: &Camera,
    bounces: u32,
) -> (Frame, PhaseTimes) {
    let w = camera.width as usize;
    let n = w * camera.height as usize;
    let start = std::time::Instant::now();
    let primary: Vec<(Vec3, Option<Hit>, Option<PathResult>)> = (0..n)
        .into_par_iter()
        .map(|k| {
            let (o, d) = camera.ray((k % w) as u32, (k / w) as u32);
            let hit = tracer.nearest(o, d, None);
            let done = match hit {
                Some(h) if tracer.is_reflector(h.triangle) => None,
                _ => Some(finish_path(scene, tracer, d, hit, bounces)),
            };
            (d, hit, done)
        })
        .collect();
    let primary_ns = start.elapsed().as_secs_f64() * 1e9;
    let start = std::time::Instant::now();
    let paths: Vec<PathResult> = primary
        .into_par_iter()
        .map(|(d, hit, done)| done.unwrap_or_else(|| finish_path(scene, tracer, d, hit, bounces)))
        .collect();
    let reflected_ns = start.elapsed().as_secs_f64() * 1e9;
    let mut frame = Frame::new(camera.width, camera.height);
    for (k, p) in paths.into_iter().enumerate() {
        frame.set_path(k, tracer, p);
    }
    let reflected_rays = frame.mirror_pixels();
    (
        frame,
        PhaseTimes {
            primary_ns,
            reflected_ns,
            reflected_rays,
        },
    )
}

/// The CPU capture of one cubemap object: for every texel, a ray from `centre` through the
/// texel centre ([`crate::cubemap::face::texel_centre_dir`]); the distance to the nearest surface
/// (`+inf` where none) and its shaded colour (alpha 1; the background with alpha 0 where none).
/// Reflectors are left out unless the scene has self-reflections on, and then kept only where
/// they face the centre (normal towards it), as in the GPU capture (`spirv/capture.wgsl`).
/// This is what a rasterised capture computes at texel centres, so it checks the GPU capture.
pub fn capture(scene: &Scene, tracer: &Tracer, centre: Vec3, size: u32) -> crate::cubemap::CubeMap {
    let mut cube = crate::cubemap::CubeMap::new(size, centre);
    let n = cube.distance.len();
    let texels: Vec<(f32, [f32; 4])> = (0..n)
        .into_par_iter()
        .map(|i| {
            let t = crate::cubemap::Texel::from_index(i, size);
            let dir = crate::cubemap::face::texel_centre_dir(t, size).normalize();
            let hit = tracer.nearest_accepting(centre, dir, None, |h| {
                !tracer.is_reflector(h.triangle)
                    || (scene.self_reflections && tracer.normal(h).dot(h.position - centre) <= 0.0)
            });
            match hit {
                Some(h) => {
                    let c = tracer.shade(scene, &h);
                    ((h.position - centre).length(), [c.x, c.y, c.z, 1.0])
                }
                None => {
                    let b = scene.background;
                    (f32::INFINITY, [b.x, b.y, b.z, 0.0])
                }
            }
        })
        .collect();
    for (i, (d, c)) in texels.into_iter().enumerate() {
        cube.distance[i] = d;
        cube.colour[i] = c;
    }
    cube
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The phased render (the harness's timing of the reflected rays) is the same frame as the
    /// plain one, bit for bit, bounces included; a different bounce count is not.
    #[test]
    fn phased_render_is_the_plain_render() {
        let scene = crate::scene::builtin::by_name("teapot").expect("built-in");
        let mut camera = scene.cameras[0].clone();
        (camera.width, camera.height) = (48, 36);
        let tracer = Tracer::new(&scene);
        for bounces in [0, 1, 3] {
            let plain = render(&scene, &tracer, &camera, bounces);
            let (phased, times) = render_phased(&scene, &tracer, &camera, bounces);
            assert!(plain.mirror_pixels() > 100);
            assert_eq!(times.reflected_rays, plain.mirror_pixels());
            assert!(
                plain.colour == phased.colour
                    && plain.bounces == phased.bounces
                    && plain.primitive_id == phased.primitive_id,
                "bounces {bounces}"
            );
            // NaN positions compare unequal: compare their bits.
            let bits = |v: &[Vec3]| {
                v.iter()
                    .map(|p| p.to_array().map(f32::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&plain.hit_position), bits(&phased.hit_position));
            assert_eq!(plain.mask, phased.mask);
        }
        let one = render(&scene, &tracer, &camera, 1);
        let three = render_phased(&scene, &tracer, &camera, 3).0;
        assert_ne!(
            one.colour, three.colour,
            "negative: the bounce count must show"
        );
    }
}

//! CPU twin of the reflection-point search (`spirv/reflection_point_search.wgsl`, Estalella et al. 2006,
//! sections 4 and 5.1): the same loop over the same textures (read back from the GPU), with the
//! same arithmetic, so that the GPU's per-vertex results can be checked one by one.
//!
//! The search, per vertex `V` of a non-reflector object, over T_P (world position, w = 1 on a
//! reflector texel) and T_N (normal) rendered from the camera at eye `O`:
//! - Start: the texel of the projected centre of the reflectors' bounding box ([`start_texel`]);
//!   if that texel is off the reflector, the nearest reflector texel along the four arms of the
//!   crosshair through it.
//! - Each step scores the centre texel and its neighbours by `dot(N, B)`, `B` the bisector of
//!   `O - P` and `V - P` (unit vectors): the four crosshair neighbours on the first step, all
//!   eight afterwards (fixed order: rows top to bottom, left to right; a neighbour must score
//!   strictly higher to win, so the centre wins ties). It moves to the best until the centre wins,
//!   or stops at the iteration cap ([`Status::Cap`]). Texels off the reflector never win: when
//!   the maximum lies beyond the reflector's outline, the search stops on the outline.
//! - Region C (hidden vertex): if `V` is behind the plane `(R, N)` of the texel found, the inverse
//!   search runs from there, scoring the bisector of `O - P` and `V' - P`, `V'` the mirror image
//!   of `V` in the texel's plane (the paper's Fig. 4 right, with a mirror in the plane; the
//!   printed Eq. 1 is that image turned 180 degrees about `N`, which stays behind the plane).
//! - The virtual vertex is `V` mirrored in the plane `(R, N)` of the final texel, for both cases.
use bytemuck::{Pod, Zeroable};
use std::collections::HashMap;

use glam::{Mat4, Vec3, Vec4};

use crate::scene::gpu_data::GpuSceneData;
use crate::scene::{MeshPart, Scene};
use crate::shading::{srgb_decode, srgb_encode};

/// Options of the reflection-point method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RpOptions {
    /// Steps of one search (forward, and inverse) before it is given up (the vertex then has no
    /// virtual vertex and its triangles are not drawn). `None`: the search textures' width + height
    /// ([`RpOptions::iteration_cap`]).
    pub max_iterations: Option<u32>,
    /// T_P and T_N have `search_scale` times the frame's width and height (same projection):
    /// the reflection point is found to a texel, and near the outline of a curved reflector a
    /// texel spans a wide range of reflected directions.
    pub search_scale: u32,
    /// Search on the closed version of open reflectors ([`crate::cpu::closure`], the paper's
    /// open/closed pair); `false`: on the reflectors as they are.
    pub close_reflectors: bool,
}

/// The default [`RpOptions::search_scale`].
pub const DEFAULT_SEARCH_SCALE: u32 = 1;

impl Default for RpOptions {
    fn default() -> Self {
        RpOptions {
            max_iterations: None,
            search_scale: DEFAULT_SEARCH_SCALE,
            close_reflectors: true,
        }
    }
}

impl RpOptions {
    /// The iteration cap for search textures of `width` x `height` texels: the explicit one, or
    /// `width + height`. A step moves one texel along either axis or both, so a walk that heads
    /// for its maximum reaches any texel within the larger side, and one that turns once (along
    /// one axis, then the other) within the sum. The steps grow with the search scale, so a
    /// fixed cap cuts the searches of larger textures: 256 gave up 19% of `sphere-room`'s
    /// vertices at scale 8, 192x144 (at most 357 steps were needed there).
    pub fn iteration_cap(&self, width: u32, height: u32) -> u32 {
        self.max_iterations
            .unwrap_or(width.saturating_add(height).max(1))
    }
}

/// What the search did for one vertex (`RP_*` in `spirv/reflection_point_search.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Status {
    /// A reflector's own vertex: not searched.
    Reflector = 0,
    /// Found in front of the reflection point's plane (region A).
    Found = 1,
    /// Behind it (region C): the inverse search gave the virtual vertex.
    Hidden = 2,
    /// A search reached the iteration cap: no virtual vertex.
    Cap = 3,
    /// No reflector texel on the crosshair through the start: no virtual vertex.
    NoReflector = 4,
}

/// `RpVertex` in `spirv/reflection_point_search.wgsl`: the result for one scene vertex.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RpVertex {
    /// The virtual vertex (meaningful for [`Status::Found`] and [`Status::Hidden`]).
    pub position: [f32; 3],
    /// A [`Status`] as u32.
    pub status: u32,
    /// The reflection point's texel.
    pub texel: [i32; 2],
    /// Steps of the forward search.
    pub iterations: u32,
    /// Steps of the inverse search (0 when it did not run).
    pub inverse_iterations: u32,
    /// The reflected path's length `|O - R| + |R - V|` (the virtual vertex's depth).
    pub path: f32,
    pub pad0: u32,
    pub pad1: u32,
    pub pad2: u32,
}

/// The search's inputs for one frame.
#[derive(Clone, Debug)]
pub struct SearchTextures {
    pub width: u32,
    pub height: u32,
    /// T_P, row-major, row 0 at the top: world position, w = 1 on a reflector texel.
    pub position: Vec<Vec4>,
    /// T_N: the interpolated normal (unnormalised).
    pub normal: Vec<Vec4>,
    pub eye: Vec3,
    pub start: [i32; 2],
    pub max_iterations: u32,
}

/// Score of a texel off the reflector (below any dot product of unit vectors).
const OFF: f32 = -4.0;

fn dot(a: Vec3, b: Vec3) -> f32 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// `scene_normalize` of `spirv/shared/scene.wgsl`.
fn normalize(n: Vec3) -> Vec3 {
    let l2 = dot(n, n);
    if l2 > 0.0 {
        let r = 1.0 / l2.sqrt();
        return n * r;
    }
    Vec3::ZERO
}

/// `v` mirrored in the plane through `r` with unit normal `n`.
pub fn mirror(v: Vec3, r: Vec3, n: Vec3) -> Vec3 {
    v - n * (2.0 * dot(v - r, n))
}

struct Walk {
    texel: [i32; 2],
    iterations: u32,
    capped: bool,
}

impl SearchTextures {
    fn index(&self, t: [i32; 2]) -> Option<usize> {
        let inside =
            t[0] >= 0 && t[1] >= 0 && t[0] < self.width as i32 && t[1] < self.height as i32;
        inside.then(|| (t[1] as u32 * self.width + t[0] as u32) as usize)
    }

    /// Whether texel `t` shows a reflector.
    pub fn on_reflector(&self, t: [i32; 2]) -> bool {
        self.index(t).is_some_and(|k| self.position[k].w == 1.0)
    }

    /// Position and unit normal of reflector texel `t`.
    pub fn surface(&self, t: [i32; 2]) -> (Vec3, Vec3) {
        let k = self.index(t).expect("texel inside the frame");
        (
            self.position[k].truncate(),
            normalize(self.normal[k].truncate()),
        )
    }

    /// `dot(N, B)` at texel `t` for vertex `v` (`inverse`: `v` is the virtual vertex).
    pub fn score(&self, t: [i32; 2], v: Vec3, inverse: bool) -> f32 {
        if !self.on_reflector(t) {
            return OFF;
        }
        let (p, n) = self.surface(t);
        let q = if inverse { mirror(v, p, n) } else { v };
        let b = normalize(normalize(self.eye - p) + normalize(q - p));
        dot(n, b)
    }

    fn walk<L: super::WorkLog + ?Sized>(
        &self,
        start: [i32; 2],
        v: Vec3,
        inverse: bool,
        first_crosshair: bool,
        log: &mut L,
    ) -> Walk {
        let mut c = start;
        let mut it = 0;
        log.log(super::Work::Walk { inverse });
        loop {
            if it >= self.max_iterations {
                return Walk {
                    texel: c,
                    iterations: it,
                    capped: true,
                };
            }
            it += 1;
            log.log(super::Work::WalkStep);
            log.log(super::Work::Score { x: c[0], y: c[1] });
            let mut best = c;
            let mut best_score = self.score(c, v, inverse);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let cross = dx == 0 || dy == 0;
                    if (dx == 0 && dy == 0) || (first_crosshair && it == 1 && !cross) {
                        continue;
                    }
                    let t = [c[0] + dx, c[1] + dy];
                    log.log(super::Work::Score { x: t[0], y: t[1] });
                    let s = self.score(t, v, inverse);
                    if s > best_score {
                        best = t;
                        best_score = s;
                    }
                }
            }
            if best == c {
                return Walk {
                    texel: c,
                    iterations: it,
                    capped: false,
                };
            }
            c = best;
        }
    }

    /// The first texel of every search: `start` if on the reflector, else the nearest reflector
    /// texel along the crosshair's arms (right, left, down, up at each distance).
    pub fn first_texel(&self) -> Option<[i32; 2]> {
        self.first_texel_logged(&mut super::NoLog)
    }

    /// [`SearchTextures::first_texel`], reporting each distance of the crosshair it tries to
    /// `log` (the shader's `rp_start_arms` calls).
    fn first_texel_logged<L: super::WorkLog + ?Sized>(&self, log: &mut L) -> Option<[i32; 2]> {
        let s = self.start;
        if self.on_reflector(s) {
            return Some(s);
        }
        let reach = self.width.max(self.height) as i32;
        (1..=reach).find_map(|d| {
            log.log(super::Work::StartArms { d });
            [[d, 0], [-d, 0], [0, d], [0, -d]]
                .into_iter()
                .map(|a| [s[0] + a[0], s[1] + a[1]])
                .find(|&t| self.on_reflector(t))
        })
    }

    /// The search for one vertex at `v` (a non-reflector's).
    pub fn search(&self, v: Vec3) -> RpVertex {
        self.search_logged(v, &mut super::NoLog)
    }

    /// [`SearchTextures::search`], reporting its walks, their iterations and the texels scored
    /// to `log`.
    pub fn search_logged<L: super::WorkLog + ?Sized>(&self, v: Vec3, log: &mut L) -> RpVertex {
        let mut out = RpVertex {
            texel: [-1, -1],
            ..RpVertex::default()
        };
        let Some(start) = self.first_texel_logged(log) else {
            out.status = Status::NoReflector as u32;
            return out;
        };
        let fwd = self.walk(start, v, false, true, log);
        out.iterations = fwd.iterations;
        let mut t = fwd.texel;
        let mut capped = fwd.capped;
        out.status = Status::Found as u32;
        let (mut p, mut n) = self.surface(t);
        if !capped && dot(v - p, n) < 0.0 {
            let inv = self.walk(t, v, true, false, log);
            out.inverse_iterations = inv.iterations;
            t = inv.texel;
            capped = inv.capped;
            out.status = Status::Hidden as u32;
            (p, n) = self.surface(t);
        }
        if capped {
            out.status = Status::Cap as u32;
        }
        out.texel = t;
        out.position = mirror(v, p, n).to_array();
        out.path = (self.eye - p).length() + (v - p).length();
        out
    }

    /// The search for every vertex of `data`, as the GPU's `search` entry point.
    pub fn search_all(&self, data: &GpuSceneData) -> Vec<RpVertex> {
        data.vertices
            .iter()
            .map(|v| {
                if data.objects[v.object as usize].reflector != 0 {
                    RpVertex {
                        texel: [-1, -1],
                        ..RpVertex::default()
                    }
                } else {
                    self.search(Vec3::from_array(v.position))
                }
            })
            .collect()
    }
}

/// The start texel: the centre of the reflectors' bounding box projected through `view_proj`,
/// clamped to the frame (the frame's centre if the box centre is behind the eye or there is no
/// reflector).
pub fn start_texel(data: &GpuSceneData, view_proj: Mat4, width: u32, height: u32) -> [i32; 2] {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for v in &data.vertices {
        if data.objects[v.object as usize].reflector != 0 {
            lo = lo.min(Vec3::from_array(v.position));
            hi = hi.max(Vec3::from_array(v.position));
        }
    }
    let centre = [width as i32 / 2, height as i32 / 2];
    if lo.x > hi.x {
        return centre;
    }
    let c = view_proj * ((lo + hi) * 0.5).extend(1.0);
    if c.w <= 0.0 {
        return centre;
    }
    let ndc = c.truncate() / c.w;
    let px = ((ndc.x * 0.5 + 0.5) * width as f32).floor();
    let py = ((ndc.y * 0.5 + 0.5) * height as f32).floor();
    [
        px.clamp(0.0, width as f32 - 1.0) as i32,
        py.clamp(0.0, height as f32 - 1.0) as i32,
    ]
}

/// Iteration counts of one frame's searches (the paper's Table 1), over the searched vertices.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SearchStats {
    /// Vertices searched (non-reflector vertices with a reflector on screen).
    pub searched: usize,
    /// Mean and maximum steps per vertex, forward + inverse.
    pub mean_iterations: f64,
    pub max_iterations: u32,
    /// Vertices found behind the plane of their reflection point (region C).
    pub hidden: usize,
    /// Vertices whose search reached the cap.
    pub capped: usize,
    /// Vertices whose reflection point lies on the reflector's outline in the textures (the
    /// search would have left the reflector).
    pub on_outline: usize,
}

impl SearchStats {
    /// The statistics of one frame's per-vertex results.
    pub fn of(vertices: &[RpVertex]) -> SearchStats {
        let mut s = SearchStats::default();
        let mut sum = 0u64;
        for v in vertices {
            if v.status == Status::Reflector as u32 || v.status == Status::NoReflector as u32 {
                continue;
            }
            let it = v.iterations + v.inverse_iterations;
            s.searched += 1;
            sum += u64::from(it);
            s.max_iterations = s.max_iterations.max(it);
            s.hidden += usize::from(v.status == Status::Hidden as u32);
            s.capped += usize::from(v.status == Status::Cap as u32);
        }
        s.mean_iterations = sum as f64 / s.searched.max(1) as f64;
        s
    }

    /// [`SearchStats::of`], with the outline count from the textures.
    pub fn with_outline(vertices: &[RpVertex], tex: &SearchTextures) -> SearchStats {
        let mut s = SearchStats::of(vertices);
        s.on_outline = vertices
            .iter()
            .filter(|v| v.status == Status::Found as u32 || v.status == Status::Hidden as u32)
            .filter(|v| {
                let [x, y] = v.texel;
                (-1..=1).any(|dy| (-1..=1).any(|dx| !tex.on_reflector([x + dx, y + dy])))
            })
            .count();
        s
    }
}

/// Splits every triangle of every non-reflector mesh into four at its edge midpoints, `levels`
/// times (positions, normals and texture coordinates interpolated linearly, the normal then
/// normalised; shared edges share their midpoint, so no crack opens). The surfaces do not change,
/// only the vertex density: the method reflects vertices, so this is its quality knob (the
/// paper's scene loader subdivides long triangles for the same reason).
pub fn subdivide_non_reflectors(scene: &mut Scene, levels: u32) {
    for mesh in scene.meshes.iter_mut().filter(|m| !m.reflector) {
        for part in &mut mesh.parts {
            for _ in 0..levels {
                subdivide_part(part);
            }
        }
    }
}

fn subdivide_part(part: &mut MeshPart) {
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
    let has_uv = part.uvs.len() == part.positions.len();
    let has_colour = part.colours.len() == part.positions.len();
    let mut mid = |part: &mut MeshPart, a: u32, b: u32| -> u32 {
        let key = (a.min(b), a.max(b));
        *midpoints.entry(key).or_insert_with(|| {
            let (i, j) = (a as usize, b as usize);
            part.positions
                .push((part.positions[i] + part.positions[j]) * 0.5);
            part.normals
                .push((part.normals[i] + part.normals[j]).normalize_or_zero());
            if has_uv {
                part.uvs.push((part.uvs[i] + part.uvs[j]) * 0.5);
            }
            if has_colour {
                // The colours are sRGB-encoded: the midpoint is the linear colours' mean.
                let (a, b) = (part.colours[i].to_array(), part.colours[j].to_array());
                let mid = |k: usize| srgb_encode((srgb_decode(a[k]) + srgb_decode(b[k])) * 0.5);
                part.colours.push(Vec3::new(mid(0), mid(1), mid(2)));
            }
            part.positions.len() as u32 - 1
        })
    };
    let old = std::mem::take(&mut part.triangles);
    for [a, b, c] in old {
        let (ab, bc, ca) = (mid(part, a, b), mid(part, b, c), mid(part, c, a));
        part.triangles
            .extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Subdividing keeps a part's colours: a new vertex's sRGB-encoded colour decodes to the
    /// mean of its edge's linear colours (0 and 1 stay exact). Negative: the mean of the encoded
    /// values, which the midpoint would be without decoding, is another colour.
    #[test]
    fn subdivision_averages_vertex_colours_in_linear_light() {
        let mut part = MeshPart {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z; 3],
            colours: vec![
                Vec3::new(1.0, 0.0, 0.2),
                Vec3::new(0.0, 1.0, 0.9),
                Vec3::ONE,
            ],
            triangles: vec![[0, 1, 2]],
            ..MeshPart::default()
        };
        subdivide_part(&mut part);
        assert_eq!(part.colours.len(), part.positions.len());
        let (a, b, ab) = (part.colours[0], part.colours[1], part.colours[3]);
        let linear = |c: Vec3| Vec3::from_array(c.to_array().map(srgb_decode));
        let mean = (linear(a) + linear(b)) * 0.5;
        assert!((linear(ab) - mean).abs().max_element() < 1e-6, "{ab}");
        assert_eq!([srgb_encode(0.0), srgb_encode(1.0)], [0.0, 1.0]);
        assert!((linear((a + b) * 0.5) - mean).abs().max_element() > 0.05);
    }

    /// A sphere of radius 1 at the origin seen from `eye` on +z, as textures of an orthographic
    /// view (each texel the sphere's point above it), enough to check the search's geometry.
    fn sphere_textures(size: u32, eye: Vec3) -> SearchTextures {
        let mut position = Vec::new();
        let mut normal = Vec::new();
        for j in 0..size {
            for i in 0..size {
                let x = (i as f32 + 0.5) / size as f32 * 2.4 - 1.2;
                let y = 1.2 - (j as f32 + 0.5) / size as f32 * 2.4;
                let r2 = x * x + y * y;
                if r2 < 1.0 {
                    let p = Vec3::new(x, y, (1.0 - r2).sqrt());
                    position.push(p.extend(1.0));
                    normal.push(p.extend(1.0));
                } else {
                    position.push(Vec4::ZERO);
                    normal.push(Vec4::ZERO);
                }
            }
        }
        SearchTextures {
            width: size,
            height: size,
            position,
            normal,
            eye,
            start: [size as i32 / 2, size as i32 / 2],
            max_iterations: RpOptions::default().iteration_cap(size, size),
        }
    }

    /// The texel found is the discrete maximum of `dot(N, B)` over the reflector (the sphere is
    /// convex: one maximum), and the virtual vertex lies beyond the reflection point on the line
    /// from the eye through it, at the vertex's distance from it; another vertex, another point.
    #[test]
    fn search_finds_the_best_texel_on_a_sphere() {
        let eye = Vec3::new(0.0, 0.0, 6.0);
        let tex = sphere_textures(96, eye);
        let v = Vec3::new(2.0, 1.0, 1.5);
        let r = tex.search(v);
        assert_eq!(r.status, Status::Found as u32);
        let best = (0..96)
            .flat_map(|j| (0..96).map(move |i| [i, j]))
            .filter(|&t| tex.on_reflector(t))
            .max_by(|&a, &b| tex.score(a, v, false).total_cmp(&tex.score(b, v, false)))
            .unwrap();
        assert_eq!(r.texel, best);
        assert!(tex.score(r.texel, v, false) > 0.9999);
        let (p, _) = tex.surface(r.texel);
        let virt = Vec3::from_array(r.position);
        assert!(((virt - p).length() - (v - p).length()).abs() < 1e-4);
        assert!(
            (virt - p).dot(p - eye) > 0.0,
            "virtual vertex {virt} behind the surface"
        );
        let off_line = (virt - eye)
            .normalize()
            .cross((p - eye).normalize())
            .length();
        assert!(off_line < 0.02, "virtual vertex on the eye ray: {off_line}");
        // Negative: another vertex, another reflection point.
        let r2 = tex.search(Vec3::new(-2.0, 1.0, 1.5));
        assert_ne!(r2.texel, r.texel);
    }

    /// A vertex behind the sphere (region C) takes the inverse search; the cap stops a search.
    #[test]
    fn hidden_vertices_and_the_cap() {
        let eye = Vec3::new(0.0, 0.0, 6.0);
        let mut tex = sphere_textures(64, eye);
        let r = tex.search(Vec3::new(0.3, 0.2, -3.0));
        assert_eq!(r.status, Status::Hidden as u32);
        assert!(r.inverse_iterations > 0);
        tex.max_iterations = 2;
        let far = tex.search(Vec3::new(3.0, 3.0, 0.5));
        assert_eq!(far.status, Status::Cap as u32);
        assert_eq!(far.iterations, 2);
    }
}

#![forbid(unsafe_code)]
//! Cone tracing on the cube maps for glossy reflectors: the pre-filtered colour chain of every CMO
//! face and the lookups that read it. CPU twin of `spirv/cone_prefilter.wgsl` (the chain, bit for
//! bit) and of `spirv/shared/cone.wgsl` (the lookups, operation for operation).
//!
//! # The chain
//! Level 0 is the captured colour itself (`cmo_colour`, [`CubeMap::colour`]); levels `1..=L`
//! (`L = `[`mip_flat_layout`]`(N).len()`, the last level one cell per face) live in one flat
//! buffer per CMO in the [`mip_flat_layout`] order, the layout of the distance pyramid
//! (`cmo_mip`), with `vec4` cells. A cell of level `l` is the **box average** of the (up to) 2x2
//! cells of level `l - 1` below it, summed in row-major order `(0,0), (1,0), (0,1), (1,1)` (the
//! children that exist: an odd level's last row/column has 1 or 2) and scaled by `1/count`
//! (1, 1/2 or 1/4: exact). A texel that captured nothing (alpha 0) counts as the background
//! colour: the direction sees the background there. The cell's alpha is the fraction of the
//! texels below it that captured a surface (level 0: 1 or 0).
//!
//! # The lookups
//! - [`cone_cube_colour`]: trilinear colour of CMO `k` along `dir` at a fractional level:
//!   bilinear within the face at the two integer levels around it (texel centres at
//!   `s N / 2^l - 1/2`, clamped to the face: **no filtering across a face seam**, a face's
//!   border cells repeat instead; at coarse levels, where one cell is a large part of the face,
//!   the colour therefore jumps at the seams), then linear between the two levels. Below level 0
//!   it reads level 0 bilinearly; above `L` it reads level `L` (one colour per face).
//! - [`cone_footprint_level`]: the level whose cell width matches a cone of half-angle
//!   `atan(tan_half)` around `dir` seen from the CMO centre: the cone's diameter on the face
//!   plane (`|major| = 1`) is `2 tan_half r^(3/2)`, `r = |dir| / |major|` (the plane's area per
//!   solid angle is `r^3`, so an isotropic footprint scales its width by `r^(3/2)`: texels near
//!   a face's corner cover less angle), and a level-`l` cell is `2^(l + 1) / N` wide, so
//!   `level = log2(tan_half N) + 3/4 log2(r^2)`.
//! - [`cone_envmap_colour`]: the direction-only lookup (for an escaped axis, and for
//!   screen-space remainders): the cone of a lobe of power `power` seen from the CMO centre as
//!   if the scene were infinitely far, [`cone_footprint_level`] at `tan(`[`cone_half_angle`]`)`.
//!
//! # The cone pass ([`cone_pixel`], `spirv/cone.wgsl`): what it approximates
//! - **One axis ray**: the cone is not traced; what the lobe sees is taken to lie around the
//!   axis hit, at its distance.
//! - **A footprint from the CMO's viewpoint**: the chain holds what the CMO centre sees, so the
//!   footprint is the cone's cross-section at the hit seen from the CMO that sees the hit
//!   ([`cone_seeing_cmo`]; none: the exact colour stays).
//! - **The box pre-filter**: 2x2 boxes per level, trilinear between levels, not the lobe's
//!   cos^n weights; no filtering across a face seam.
//! - **Occlusion**: where the 2x2 min/max pyramid shows a surface in front of the hit's
//!   distance minus the cone's radius inside the footprint, the level is capped at the coarsest
//!   level without one ([`cone_visible_level`]); that surface, seen from the CMO, need not be in
//!   the cone. Measured (`tests/glossy/glossy_cone.rs`, `occlusion_and_horizon_measured`): the cap
//!   and the below-the-surface darkening each move PSNR by less than 0.5 dB either way.
//! - **Below the surface**: the part of the cone below the reflector's plane is absorbed, as the
//!   reference's samples are: the colour is scaled by `1 - clamp((theta - beta) / (2 theta), 0,
//!   1/2)`, `beta` the axis's elevation.
//! - An escaped axis reads the direction-only lookup (the scene as infinitely far).
//!
//! Arithmetic: f32, in the WGSL's order; the product of an interpolation goes through no fused
//! multiply-add (as `prod` in `spirv/shared/frustum.wgsl`). The chain and
//! [`cone_cube_colour`] are bit-identical on lavapipe; the level of [`cone_footprint_level`]
//! uses `log2` (and [`cone_envmap_colour`] `acos`, `tan`), which the device computes its own way.

use glam::{Vec3, Vec4};

use crate::cubemap::CubeMap;
use crate::cubemap::face::{FACE_COUNT, select_face, to_face_local};
use crate::cubemap::pyramid::{FlatLevel, mip_flat_layout, mip_len};
use crate::lobe::cone_half_angle;

/// A texel of the captured colour as the chain sees it: `(rgb, 1)` where the texel captured a
/// surface (alpha > 0), `(background, 0)` where it captured nothing.
pub fn cone_texel(colour: [f32; 4], background: Vec3) -> Vec4 {
    if colour[3] > 0.0 {
        Vec4::new(colour[0], colour[1], colour[2], 1.0)
    } else {
        background.extend(0.0)
    }
}

/// The pre-filtered chain of one CMO (levels `1..=L`, [`mip_flat_layout`] order, `mip_len(N)`
/// cells; empty for `N = 1`): what the GPU `cone_prefilter` pass writes for that CMO.
pub fn cone_prefilter(cube: &CubeMap, background: Vec3) -> Vec<[f32; 4]> {
    let size = cube.size;
    let mut out = vec![[0.0f32; 4]; mip_len(size)];
    let mut src: Option<FlatLevel> = None;
    for level in mip_flat_layout(size) {
        let sw = src.map_or(size, |s| s.width);
        let w = level.width;
        for face in 0..FACE_COUNT {
            for y in 0..w {
                for x in 0..w {
                    let get = |cx: u32, cy: u32| -> Vec4 {
                        let local = ((face * sw + cy) * sw + cx) as usize;
                        match src {
                            None => cone_texel(cube.colour[local], background),
                            Some(s) => Vec4::from_array(out[s.offset as usize + local]),
                        }
                    };
                    let (sx, sy) = (2 * x, 2 * y);
                    let mut sum = get(sx, sy);
                    let mut count = 1u32;
                    if sx + 1 < sw {
                        sum += get(sx + 1, sy);
                        count += 1;
                    }
                    if sy + 1 < sw {
                        sum += get(sx, sy + 1);
                        count += 1;
                        if sx + 1 < sw {
                            sum += get(sx + 1, sy + 1);
                            count += 1;
                        }
                    }
                    let weight = match count {
                        4 => 0.25,
                        2 => 0.5,
                        _ => 1.0,
                    };
                    let local = ((face * w + y) * w + x) as usize;
                    out[level.offset as usize + local] = (sum * weight).to_array();
                }
            }
        }
        src = Some(level);
    }
    out
}

/// One CMO as the lookups read it: its capture (level 0), its chain ([`cone_prefilter`]) and
/// the background an empty texel stands for.
#[derive(Clone, Copy, Debug)]
pub struct ConeCmo<'a> {
    /// The capture: size and colour (level 0).
    pub cube: &'a CubeMap,
    /// Levels `1..=L`, [`cone_prefilter`]'s output (or the GPU's, read back).
    pub chain: &'a [[f32; 4]],
    /// The scene's background colour.
    pub background: Vec3,
}

impl ConeCmo<'_> {
    /// Levels above the texels, `L`.
    pub fn top(&self) -> u32 {
        mip_flat_layout(self.cube.size).len() as u32
    }
}

/// First cell and width of level `l >= 1` of the chain of face size `size` (WGSL
/// `cone_level_at`; the sum of the levels below, as [`mip_flat_layout`]).
pub fn cone_level_at(size: u32, l: u32) -> (u32, u32) {
    let mut offset = 0u32;
    let mut w = size;
    for _ in 1..l {
        w = w.div_ceil(2);
        offset += FACE_COUNT * w * w;
    }
    (offset, w.div_ceil(2))
}

/// Cell `(x, y)` of `face` at integer level `l` (0: the texels, background where empty).
fn cone_cell(cmo: &ConeCmo<'_>, l: u32, face: u32, x: u32, y: u32) -> Vec4 {
    let size = cmo.cube.size;
    if l == 0 {
        let i = ((face * size + y) * size + x) as usize;
        return cone_texel(cmo.cube.colour[i], cmo.background);
    }
    let (offset, w) = cone_level_at(size, l);
    Vec4::from_array(cmo.chain[(offset + (face * w + y) * w + x) as usize])
}

/// One coordinate of the bilinear lookup at a level `w` cells wide: the lower cell, the upper
/// cell and the weight of the upper, for the face coordinate `s` in `[0, 1]` (`scale = N / 2^l`
/// cells per unit of `s`, exact), clamped to the face.
fn cone_axis(s: f32, scale: f32, w: u32) -> (u32, u32, f32) {
    let last = (w - 1) as f32;
    let p = s * scale - 0.5;
    let p = if p < 0.0 {
        0.0
    } else if p > last {
        last
    } else {
        p
    };
    let f = p.floor();
    let x0 = f as u32;
    (x0, (x0 + 1).min(w - 1), p - f)
}

/// `a + (b - a) f`, the product rounded on its own.
fn cone_lerp(a: Vec4, b: Vec4, f: f32) -> Vec4 {
    a + (b - a) * f
}

/// Bilinear colour (with the alpha: coverage) at integer level `l` at face coordinates `(s, t)`.
pub fn cone_level_colour(cmo: &ConeCmo<'_>, l: u32, face: u32, s: f32, t: f32) -> Vec4 {
    let size = cmo.cube.size;
    let w = if l == 0 {
        size
    } else {
        cone_level_at(size, l).1
    };
    let scale = size as f32 / (1u32 << l) as f32;
    let (x0, x1, fx) = cone_axis(s, scale, w);
    let (y0, y1, fy) = cone_axis(t, scale, w);
    let top = cone_lerp(
        cone_cell(cmo, l, face, x0, y0),
        cone_cell(cmo, l, face, x1, y0),
        fx,
    );
    let bottom = cone_lerp(
        cone_cell(cmo, l, face, x0, y1),
        cone_cell(cmo, l, face, x1, y1),
        fx,
    );
    cone_lerp(top, bottom, fy)
}

/// The face and face coordinates `(s, t)` in `[0, 1]` of a direction
/// ([`crate::cubemap::face::dir_to_face_st`], written out as the WGSL does).
fn cone_face_st(dir: Vec3) -> (u32, f32, f32) {
    crate::cubemap::face::dir_to_face_st(dir)
}

/// Trilinear colour and coverage of the CMO along `dir` (CMO-local, any length) at the
/// fractional level `level` (see the module docs).
pub fn cone_cube_colour4(cmo: &ConeCmo<'_>, dir: Vec3, level: f32) -> Vec4 {
    let (face, s, t) = cone_face_st(dir);
    let top = cmo.top();
    let level = if level > 0.0 { level } else { 0.0 };
    let f0 = level.floor();
    if f0 >= top as f32 {
        return cone_level_colour(cmo, top, face, s, t);
    }
    let l0 = f0 as u32;
    let fl = level - f0;
    let a = cone_level_colour(cmo, l0, face, s, t);
    if fl > 0.0 {
        let b = cone_level_colour(cmo, l0 + 1, face, s, t);
        return cone_lerp(a, b, fl);
    }
    a
}

/// [`cone_cube_colour4`]'s colour.
pub fn cone_cube_colour(cmo: &ConeCmo<'_>, dir: Vec3, level: f32) -> Vec3 {
    cone_cube_colour4(cmo, dir, level).truncate()
}

/// The chain level whose cell width on the face matches a cone of half-angle `atan(tan_half)`
/// around `dir` seen from the CMO centre, for face size `size` (module docs). `-inf` for a
/// cone of angle 0 (the lookups clamp it to level 0).
pub fn cone_footprint_level(size: u32, dir: Vec3, tan_half: f32) -> f32 {
    let l = to_face_local(select_face(dir), dir);
    let r2 = (l.x * l.x + l.y * l.y + l.z * l.z) / (l.z * l.z);
    (tan_half * size as f32).log2() + 0.75 * r2.log2()
}

/// The direction-only lookup: the colour the lobe of power `power` around `dir` gathers from
/// the CMO, the scene seen as infinitely far (module docs). A mirror power reads level 0.
pub fn cone_envmap_colour(cmo: &ConeCmo<'_>, dir: Vec3, power: f32) -> Vec3 {
    let tan_half = cone_half_angle(power).tan();
    let level = cone_footprint_level(cmo.cube.size, dir, tan_half);
    cone_cube_colour(cmo, dir, level)
}

/// What the cone pass reads besides a pixel's record: every CMO ([`ConeCmo`]), its 2x2
/// `[min, max]` pyramid (`MipPyramid::flatten`, the layout of `cmo_mip`), the camera's eye.
#[derive(Clone, Copy, Debug)]
pub struct ConeScene<'a> {
    /// The CMOs, in order.
    pub cmos: &'a [ConeCmo<'a>],
    /// Their pyramids, `MipPyramid::build(cube).flatten()` each.
    pub pyramids: &'a [Vec<[f32; 2]>],
    /// The camera's eye (the mirror pixels' incoming rays start there).
    pub eye: Vec3,
    /// Added to every footprint level: 0 is the pass; the tests' negative uses another.
    pub level_bias: f32,
    /// The pyramid's occlusion cap (the pass: `true`; `false` measures what it gains).
    pub occlusion: bool,
    /// The below-the-surface darkening (the pass: `true`; `false` measures what it gains).
    pub horizon: bool,
}

/// A record's status as the cone pass reads it (`RECORD_HIT`, `RECORD_ESCAPED`; anything else
/// is left alone).
pub const STATUS_HIT: u32 = 0;
/// See [`STATUS_HIT`].
pub const STATUS_ESCAPED: u32 = 1;

/// glam's `length`, as WGSL `length_glam`.
fn length(v: Vec3) -> f32 {
    (v.x * v.x + v.y * v.y + v.z * v.z).sqrt()
}

/// The CMO that sees `p` (`spirv/cone.wgsl`'s header): the nearest centre whose texel towards
/// `p` holds a finite distance of at least `|p - C| (1 - 4 / N)`.
pub fn cone_seeing_cmo(scene: &ConeScene<'_>, p: Vec3) -> Option<usize> {
    let mut best = None;
    let mut best_d = f32::INFINITY;
    for (k, c) in scene.cmos.iter().enumerate() {
        let size = c.cube.size;
        let keep = 1.0 - 4.0 / size as f32;
        let u = p - c.cube.centre;
        let dist = length(u);
        if dist > 0.0 && dist < best_d {
            let t = crate::cubemap::face::dir_to_texel(u, size);
            let d = c.cube.distance[t.index(size)];
            if d.is_finite() && d >= dist * keep {
                best = Some(k);
                best_d = dist;
            }
        }
    }
    best
}

/// The level of the axis hit, capped by the pyramid (`cone_visible_level` in `spirv/cone.wgsl`).
pub fn cone_visible_level(
    scene: &ConeScene<'_>,
    k: usize,
    u: Vec3,
    dist: f32,
    rho: f32,
    level: f32,
) -> f32 {
    let cmo = &scene.cmos[k];
    let size = cmo.cube.size;
    let top = cmo.top();
    let mut lv = level;
    if lv <= 0.0 {
        return lv;
    }
    let c = lv.ceil();
    let mut l = if c < top as f32 { c as u32 } else { top };
    let texel = crate::cubemap::face::dir_to_texel(u, size);
    let front = dist - rho;
    while l > 0 {
        let (offset, w) = cone_level_at(size, l);
        let i = offset + (texel.face * w + (texel.y >> l)) * w + (texel.x >> l);
        if scene.pyramids[k][i as usize][0] >= front {
            break;
        }
        lv = lv.min((l - 1) as f32);
        l -= 1;
    }
    lv
}

/// `a + (b - a) clamp(level, 0, 1)`.
pub fn cone_blend(a: Vec3, b: Vec3, level: f32) -> Vec3 {
    // `clamp_rust` in WGSL: the same branches as `f32::clamp`.
    let w = level.clamp(0.0, 1.0);
    a + (b - a) * w
}

/// The fraction of the cone of half-angle `theta` around the unit axis `r` kept above the
/// reflector's plane, `d` the unit camera ray (`spirv/cone.wgsl`'s header).
pub fn cone_above(d: Vec3, r: Vec3, theta: f32) -> f32 {
    let c2 = (1.0 - (d.x * r.x + d.y * r.y + d.z * r.z)) * 0.5;
    let beta = c2.max(0.0).sqrt().asin();
    let f = (theta - beta) / (2.0 * theta);
    let f = f.clamp(0.0, 0.5);
    1.0 - f
}

/// The cone pass for one glossy pixel of specular power `power` (< 1024) and its record
/// (status, the axis ray's origin and unit direction, the hit point, the exact colour): the new
/// colour, or `None` where the pass leaves the record alone (unresolved). CPU twin of
/// `spirv/cone.wgsl`'s `main`.
pub fn cone_pixel(
    scene: &ConeScene<'_>,
    status: u32,
    origin: Vec3,
    dir: Vec3,
    point: Vec3,
    colour: Vec3,
    power: f32,
) -> Option<Vec3> {
    let theta = cone_half_angle(power);
    let tan_t = theta.tan();
    let out = match status {
        STATUS_HIT => match cone_seeing_cmo(scene, point) {
            Some(k) => {
                let cmo = &scene.cmos[k];
                let u = point - cmo.cube.centre;
                let dist = length(u);
                let rho = length(point - origin) * tan_t;
                let level = cone_footprint_level(cmo.cube.size, u, rho / dist) + scene.level_bias;
                let lv = if scene.occlusion {
                    cone_visible_level(scene, k, u, dist, rho, level)
                } else {
                    level
                };
                cone_blend(colour, cone_cube_colour(cmo, u, lv), lv)
            }
            None => colour,
        },
        STATUS_ESCAPED => {
            let mut k = 0;
            let mut best = f32::INFINITY;
            for (j, c) in scene.cmos.iter().enumerate() {
                let v = origin - c.cube.centre;
                let d = v.dot(v);
                if d < best {
                    (k, best) = (j, d);
                }
            }
            let cmo = &scene.cmos[k];
            let level = cone_footprint_level(cmo.cube.size, dir, tan_t) + scene.level_bias;
            cone_blend(colour, cone_cube_colour(cmo, dir, level), level)
        }
        _ => return None,
    };
    if !scene.horizon {
        return Some(out);
    }
    let d = origin - scene.eye;
    let d = d * (1.0 / length(d));
    Some(out * cone_above(d, dir, theta))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(size: u32) -> CubeMap {
        let mut c = CubeMap::new(size, Vec3::ZERO);
        let mut i = 0u32;
        c.fill(|_, _| {
            i += 1;
            let a = if i.is_multiple_of(7) { 0.0 } else { 1.0 };
            (1.0, [(i % 5) as f32, (i % 3) as f32 * 0.5, 0.25, a])
        });
        c
    }

    #[test]
    fn level_at_matches_flat_layout() {
        for size in [1u32, 2, 3, 5, 16, 33] {
            for (i, l) in mip_flat_layout(size).iter().enumerate() {
                assert_eq!(cone_level_at(size, i as u32 + 1), (l.offset, l.width));
            }
        }
    }

    /// The top level is the mean of the face (power-of-two N: every level averages 4 equal
    /// weights), background for the empty texels.
    #[test]
    fn top_level_is_the_face_mean() {
        let bg = Vec3::new(0.5, 0.25, 2.0);
        let c = cube(8);
        let chain = cone_prefilter(&c, bg);
        let top = *mip_flat_layout(8).last().expect("levels");
        for face in 0..FACE_COUNT {
            let n = 64usize;
            let mean: Vec4 = c.colour[face as usize * n..(face as usize + 1) * n]
                .iter()
                .map(|&t| cone_texel(t, bg))
                .sum::<Vec4>()
                / n as f32;
            let got = Vec4::from_array(chain[(top.offset + face) as usize]);
            assert!((got - mean).abs().max_element() < 1e-5, "{got} vs {mean}");
        }
        // Negative: without the background substitution the mean differs.
        let mut dark = c.clone();
        for t in &mut dark.colour {
            t[3] = 1.0;
        }
        assert_ne!(cone_prefilter(&dark, bg), chain);
    }

    #[test]
    fn level_zero_at_a_texel_centre_is_the_texel() {
        let bg = Vec3::ZERO;
        let c = cube(4);
        let chain = cone_prefilter(&c, bg);
        let cmo = ConeCmo {
            cube: &c,
            chain: &chain,
            background: bg,
        };
        // +Z face (4), texel (1, 2): centre s = 3/8, t = 5/8; dir = (2s - 1, -(2t - 1), 1).
        let dir = Vec3::new(-0.25, -0.25, 1.0);
        let i = ((4 * 4 + 2) * 4 + 1) as usize;
        assert_eq!(
            cone_cube_colour4(&cmo, dir, 0.0),
            cone_texel(c.colour[i], bg)
        );
        assert_ne!(
            cone_cube_colour4(&cmo, dir, 0.5),
            cone_texel(c.colour[i], bg)
        );
    }
}

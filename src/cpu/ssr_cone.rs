//! The glossy part of Hi-Z screen-space reflections (Uludag 2014, GPU Pro 5, sections 4.4.1 to
//! 4.4.5): the CPU twin of `spirv/ssr_visibility.wgsl` ([`build_visibility`]: the max pyramid and
//! the pre-integrated visibility), `spirv/ssr_blur.wgsl` ([`build_colour_chain`]: the
//! pre-convolved colour chain) and `spirv/ssr_cone.wgsl` ([`cone_colour`]: the cone tracing after
//! [`super::ssr::trace`]). The same loops with the same f32 operations in the same order, so that
//! the pyramids and the chain compare bit for bit; the cone's colour depends on the device's
//! `tan`, `acos`, `exp2` and `log2` (`tests/ssr/glossy_ssr.rs` states the tolerance).
//!
//! Every buffer has the min pyramid's levels ([`super::ssr::hiz_levels`]).
//!
//! What it approximates (the chapter's own approximations, kept):
//! - The lobe is a cone of half-angle [`crate::lobe::cone_half_angle`] (Eq. 4.1, xi = 0.244),
//!   and the cone is its screen-space isosceles triangle from the ray's start to the hit pixel,
//!   integrated at [`CONE_SAMPLES`] in-radius circles, not over its area.
//! - Visibility is a per-cell scalar: the fraction of each cell's depth slab that lies empty in
//!   front of its children, not a per-direction transmittance. The weight of a circle is that
//!   visibility times a linear ramp of its sphere through the cell's [min, max] depth.
//! - Colour is the G-buffer's shaded colour, blurred per level; what screen space does not show
//!   (behind objects, off screen) is missing, and the rest of the cone's weight (the remainder)
//!   comes from the cube maps at the same roughness ([`super::cone::cone_envmap_colour`]: the
//!   nearest CMO, direction only, no parallax).
//! - Only rays `ssr` hit are cone traced; the rest go to the fallback, which traces the mirror
//!   direction, so an unresolved glossy pixel shows a mirror reflection.
use glam::{Vec2, Vec3, Vec4};

use super::ssr::{HizLevel, hiz_len, hiz_levels};

/// In-radius circles per cone at most (Listing 4.7's loop).
pub const CONE_SAMPLES: u32 = 7;

/// The listing's Gaussian (Listing 4.6, Figure 4.22), centre last: taps at offsets +-3, +-2, +-1,
/// 0. As printed they sum to 0.998.
pub const GAUSSIAN: [f32; 4] = [0.001, 0.028, 0.233, 0.474];

/// The view depth standing in for "nothing drawn" (`SSR_CONE_FAR`).
pub const FAR: f32 = f32::MAX;

/// The view depth of depth key `q` (`ssr_cone_depth`): `-1 / q`, [`FAR`] for an empty key.
pub fn depth(q: f32) -> f32 {
    if q == 0.0 { FAR } else { -1.0 / q }
}

/// `child_fraction` of `spirv/ssr_visibility.wgsl`.
fn child_fraction(child_min: f32, w_min: f32, w_max: f32) -> f32 {
    // `!(a > b)`: a NaN depth counts as a flat cell, as on the GPU.
    if w_max.partial_cmp(&w_min) != Some(std::cmp::Ordering::Greater) {
        return 1.0;
    }
    (depth(child_min) - w_min) / (w_max - w_min)
}

/// The max pyramid and the pre-integrated visibility over the min pyramid `min_cells`
/// ([`super::ssr::build_hiz`]'s output): `(max, visibility)`, each [`hiz_len`] cells.
pub fn build_visibility(min_cells: &[f32], width: u32, height: u32) -> (Vec<f32>, Vec<f32>) {
    let levels = hiz_levels(width, height);
    let n0 = (width * height) as usize;
    let mut max = vec![0.0f32; hiz_len(width, height)];
    let mut vis = vec![0.0f32; max.len()];
    max[..n0].copy_from_slice(&min_cells[..n0]);
    vis[..n0].fill(1.0);
    for pair in levels.windows(2) {
        let (src, dst) = (pair[0], pair[1]);
        for y in 0..dst.height {
            for x in 0..dst.width {
                let at = |sx: u32, sy: u32| (src.offset + sy * src.width + sx) as usize;
                let (sx, sy) = (2 * x, 2 * y);
                let mut m = max[at(sx, sy)];
                if sx + 1 < src.width {
                    m = m.max(max[at(sx + 1, sy)]);
                }
                if sy + 1 < src.height {
                    m = m.max(max[at(sx, sy + 1)]);
                    if sx + 1 < src.width {
                        m = m.max(max[at(sx + 1, sy + 1)]);
                    }
                }
                let k = (dst.offset + y * dst.width + x) as usize;
                max[k] = m;
                let (w_min, w_max) = (depth(min_cells[k]), depth(m));
                let child = |c: usize| child_fraction(min_cells[c], w_min, w_max) * vis[c];
                let mut sum = child(at(sx, sy));
                let mut n = 1.0f32;
                if sx + 1 < src.width {
                    sum += child(at(sx + 1, sy));
                    n += 1.0;
                }
                if sy + 1 < src.height {
                    sum += child(at(sx, sy + 1));
                    n += 1.0;
                    if sx + 1 < src.width {
                        sum += child(at(sx + 1, sy + 1));
                        n += 1.0;
                    }
                }
                vis[k] = sum / n;
            }
        }
    }
    (max, vis)
}

/// Level 0 of the colour chain from the G-buffer's colour texels (alpha 0: nothing drawn,
/// which shows `background`), alpha 1.
pub fn chain_level0(gbuffer_colour: &[Vec4], background: Vec3) -> Vec<Vec4> {
    (gbuffer_colour.iter())
        .map(|c| {
            let rgb = if c.w > 0.0 { c.truncate() } else { background };
            rgb.extend(1.0)
        })
        .collect()
}

fn tap(i: i32, n: u32) -> u32 {
    i.clamp(0, n as i32 - 1) as u32
}

/// The 7 taps `at(-3) .. at(3)` weighted, summed in the shader's order.
fn blur7(at: impl Fn(i32) -> Vec4) -> Vec4 {
    let g = GAUSSIAN;
    let mut c = at(-3) * g[0];
    c += at(-2) * g[1];
    c += at(-1) * g[2];
    c += at(0) * g[3];
    c += at(1) * g[2];
    c += at(2) * g[1];
    c += at(3) * g[0];
    c
}

/// The pre-convolved colour chain over `level0` ([`chain_level0`]), every level as
/// [`hiz_levels`] lays them out: per level, the horizontal blur of the level above into a
/// scratch image of its size, then per cell the mean of the vertical blurs of the scratch at
/// the (up to) 2 x 2 texels below it.
pub fn build_colour_chain(level0: &[Vec4], width: u32, height: u32) -> Vec<Vec4> {
    let levels = hiz_levels(width, height);
    let mut chain = vec![Vec4::ZERO; hiz_len(width, height)];
    chain[..level0.len()].copy_from_slice(level0);
    let mut scratch = vec![Vec4::ZERO; level0.len()];
    for pair in levels.windows(2) {
        let (src, dst): (HizLevel, HizLevel) = (pair[0], pair[1]);
        for y in 0..src.height {
            for x in 0..src.width {
                let row = src.offset + y * src.width;
                scratch[(y * src.width + x) as usize] =
                    blur7(|k| chain[(row + tap(x as i32 + k, src.width)) as usize]);
            }
        }
        let column = |x: u32, y: u32| {
            blur7(|k| scratch[(tap(y as i32 + k, src.height) * src.width + x) as usize])
        };
        for y in 0..dst.height {
            for x in 0..dst.width {
                let (sx, sy) = (2 * x, 2 * y);
                let mut sum = column(sx, sy);
                let mut n = 1.0f32;
                if sx + 1 < src.width {
                    sum += column(sx + 1, sy);
                    n += 1.0;
                }
                if sy + 1 < src.height {
                    sum += column(sx, sy + 1);
                    n += 1.0;
                    if sx + 1 < src.width {
                        sum += column(sx + 1, sy + 1);
                        n += 1.0;
                    }
                }
                chain[(dst.offset + y * dst.width + x) as usize] = sum / n;
            }
        }
    }
    chain
}

/// What the cone pass reads besides the pixel's own data.
pub struct ConeInputs<'a> {
    pub width: u32,
    pub height: u32,
    pub levels: Vec<HizLevel>,
    /// The min pyramid ([`super::ssr::build_hiz`]).
    pub hiz: &'a [f32],
    /// The max pyramid and the visibility ([`build_visibility`]).
    pub hiz_max: &'a [f32],
    pub visibility: &'a [f32],
    /// The colour chain ([`build_colour_chain`]).
    pub chain: &'a [Vec4],
    /// `tan(fov_y / 2)` of the camera.
    pub tan_half: f32,
}

/// What [`cone_colour`] found for one glossy pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// The accumulated colour plus the remainder.
    pub colour: Vec3,
    /// The weight the circles accumulated (the remainder is `1 - weight`).
    pub weight: f32,
    /// Circles sampled.
    pub samples: u32,
}

impl ConeInputs<'_> {
    fn index(&self, level: u32, cell: [u32; 2]) -> usize {
        let l = self.levels[level as usize];
        (l.offset + cell[1] * l.width + cell[0]) as usize
    }

    fn cell_at(&self, p: Vec2, level: u32) -> [u32; 2] {
        let l = self.levels[level as usize];
        let size = (1u32 << level) as f32;
        let c =
            (p.clamp(Vec2::ZERO, Vec2::new(self.width as f32, self.height as f32)) / size).floor();
        [
            (c.x as u32).min(l.width - 1),
            (c.y as u32).min(l.height - 1),
        ]
    }

    fn chain_bilinear(&self, level: u32, p: Vec2) -> Vec3 {
        let l = self.levels[level as usize];
        let size = (1u32 << level) as f32;
        let c = p / size - 0.5;
        let c0 = c.floor();
        let f = c - c0;
        let x0 = c0.x.clamp(0.0, (l.width - 1) as f32) as u32;
        let x1 = (c0.x + 1.0).clamp(0.0, (l.width - 1) as f32) as u32;
        let y0 = c0.y.clamp(0.0, (l.height - 1) as f32) as u32;
        let y1 = (c0.y + 1.0).clamp(0.0, (l.height - 1) as f32) as u32;
        let at = |x: u32, y: u32| self.chain[(l.offset + y * l.width + x) as usize].truncate();
        let top = at(x0, y0) * (1.0 - f.x) + at(x1, y0) * f.x;
        let bottom = at(x0, y1) * (1.0 - f.x) + at(x1, y1) * f.x;
        top * (1.0 - f.y) + bottom * f.y
    }
}

/// The cone traced from glossy pixel `pixel` (specular power `power`) whose ray `ssr` traced to
/// `hit` with final depth key `t` ([`super::ssr::SsrResult`]); `remainder` is the colour blended
/// in for the weight the circles leave (`1 - weight`): on the GPU the pre-filtered cube map at
/// the lobe's roughness, [`super::cone::cone_envmap_colour`] of the CMO nearest to the pixel
/// along the mirror direction.
pub fn cone_colour(
    inp: &ConeInputs<'_>,
    pixel: [u32; 2],
    power: f32,
    hit: [u32; 2],
    t: f32,
    remainder: Vec3,
) -> Option<Cone> {
    let tan_theta = crate::lobe::cone_half_angle(power).tan();
    let p1 = Vec2::new(pixel[0] as f32, pixel[1] as f32) + 0.5;
    let q1 = inp.hiz[(pixel[1] * inp.width + pixel[0]) as usize];
    let p2 = Vec2::new(hit[0] as f32, hit[1] as f32) + 0.5;
    let q2 = t;
    let delta = p2 - p1;
    let len = (delta.x * delta.x + delta.y * delta.y).sqrt();
    if len.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let unit = delta / len;
    let footprint = (2.0 * inp.tan_half) / inp.height as f32;
    let count = inp.levels.len() as u32;
    let top_level = (count - 1) as f32;
    let mut adjacent = len;
    let mut colour = Vec3::ZERO;
    let mut weight = 0.0f32;
    let mut samples = 0;
    for _ in 0..CONE_SAMPLES {
        samples += 1;
        let opposite = 2.0 * tan_theta * adjacent;
        let radius = opposite
            * ((opposite * opposite + 4.0 * adjacent * adjacent).sqrt() - opposite)
            / (4.0 * adjacent);
        let along = adjacent - radius;
        let p = p1 + unit * along;
        let q = q1 + (q2 - q1) * (along / len);
        let m = radius.log2().clamp(0.0, top_level);
        let level = m.floor() as u32;
        let upper = (level + 1).min(count - 1);
        let blend = m - m.floor();
        let c = inp.chain_bilinear(level, p) * (1.0 - blend) + inp.chain_bilinear(upper, p) * blend;
        let k = inp.index(level, inp.cell_at(p, level));
        let (w_min, w_max) = (depth(inp.hiz[k]), depth(inp.hiz_max[k]));
        let w = depth(q);
        let sphere = radius * w * footprint;
        let (a, b) = (w - sphere, w + sphere);
        let span = (b - a) + (w_max - w_min);
        let mut meets = if w >= w_min { 1.0 } else { 0.0 };
        if span > 0.0 {
            meets = ((b - w_min) / span).clamp(0.0, 1.0);
        }
        let take = (inp.visibility[k] * meets).min(1.0 - weight);
        colour += c * take;
        weight += take;
        if weight >= 1.0 {
            break;
        }
        adjacent -= 2.0 * radius;
        if adjacent.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            break;
        }
    }
    Some(Cone {
        colour: colour + remainder * (1.0 - weight),
        weight,
        samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::ssr::build_hiz;

    #[test]
    fn visibility_is_at_most_the_mean_of_the_finer_level() {
        // A 4 x 4 depth field: a slope, a step and an empty pixel.
        let level0: Vec<f32> = (0..16)
            .map(|k| {
                if k == 5 {
                    0.0
                } else {
                    -1.0 / (2.0 + (k % 4) as f32 + (k / 8) as f32 * 3.0)
                }
            })
            .collect();
        let min = build_hiz(&level0, 4, 4);
        let (max, vis) = build_visibility(&min, 4, 4);
        let levels = hiz_levels(4, 4);
        for pair in levels.windows(2) {
            let (src, dst) = (pair[0], pair[1]);
            for y in 0..dst.height {
                for x in 0..dst.width {
                    let k = (dst.offset + y * dst.width + x) as usize;
                    let kids: Vec<usize> = [(0, 0), (1, 0), (0, 1), (1, 1)]
                        .iter()
                        .map(|(i, j)| (src.offset + (2 * y + j) * src.width + 2 * x + i) as usize)
                        .collect();
                    let mean = kids.iter().map(|&c| vis[c]).sum::<f32>() / 4.0;
                    assert!(
                        vis[k] <= mean + 1e-6 && vis[k] >= 0.0,
                        "{k}: {} > {mean}",
                        vis[k]
                    );
                    assert!(max[k] >= min[k]);
                    assert_eq!(
                        max[k],
                        kids.iter().map(|&c| max[c]).fold(f32::MIN, f32::max)
                    );
                }
            }
        }
        // A flat field passes visibility 1 on; the slope loses some.
        let flat = build_hiz(&[-0.5f32; 16], 4, 4);
        assert!(build_visibility(&flat, 4, 4).1.iter().all(|&v| v == 1.0));
        assert!(vis[16] < 1.0);
        // Negative: another depth at a child changes its parent's visibility.
        let mut other = level0.clone();
        other[2] = -1.0 / 9.0;
        let (_, vis2) = build_visibility(&build_hiz(&other, 4, 4), 4, 4);
        assert_ne!(vis2[17], vis[17]);
    }

    #[test]
    fn colour_chain_keeps_a_flat_colour_and_blurs_an_edge() {
        let flat = vec![Vec4::new(0.5, 0.25, 1.0, 1.0); 8 * 6];
        let chain = build_colour_chain(&flat, 8, 6);
        let l1 = hiz_levels(8, 6)[1];
        // Each level keeps 0.998^2 of a flat colour (the printed weights).
        let c = chain[l1.offset as usize];
        assert!((c.x - 0.5 * 0.998 * 0.998).abs() < 1e-6, "{c}");
        // An edge: level 1 mixes the two sides near it.
        let edge: Vec<Vec4> = (0..64)
            .map(|k| if k % 8 < 4 { Vec4::ZERO } else { Vec4::ONE })
            .collect();
        let chain = build_colour_chain(&edge, 8, 8);
        let l1 = hiz_levels(8, 8)[1];
        let row: Vec<f32> = (0..4).map(|x| chain[(l1.offset + x) as usize].x).collect();
        assert!(
            row[0] < 0.01 && row[1] > 0.01 && row[1] < 0.5 && row[2] > 0.5 && row[3] > 0.99,
            "{row:?}"
        );
    }

    #[test]
    fn cone_of_a_wall_facing_the_camera_takes_its_colour() {
        // 16 x 16, a wall at view depth 4 coloured by column; glossy pixel (2, 8) (a one-pixel
        // object at view depth 3.5) hits (12, 8).
        let (w, h) = (16, 16);
        let mut level0 = vec![-0.25f32; 256];
        level0[8 * 16 + 2] = -1.0 / 3.5;
        let min = build_hiz(&level0, w, h);
        let (max, vis) = build_visibility(&min, w, h);
        let colours: Vec<Vec4> = (0..256)
            .map(|k| Vec4::new((k % 16) as f32 / 16.0, 0.0, 0.0, 1.0))
            .collect();
        let chain = build_colour_chain(&colours, w, h);
        let inp = ConeInputs {
            width: w,
            height: h,
            levels: hiz_levels(w, h),
            hiz: &min,
            hiz_max: &max,
            visibility: &vis,
            chain: &chain,
            tan_half: 0.5,
        };
        let remainder = Vec3::new(0.0, 1.0, 0.0);
        let sharp = cone_colour(&inp, [2, 8], 1000.0, [12, 8], -0.25, remainder).unwrap();
        // A narrow cone's circles are small and near the hit, where the ray meets the wall.
        assert!(sharp.weight > 0.2 && sharp.weight <= 1.0, "{sharp:?}");
        let red = sharp.colour.x / sharp.weight;
        assert!((red - 11.5 / 16.0).abs() < 0.1, "{sharp:?}");
        assert_eq!(sharp.colour.y, 1.0 - sharp.weight);
        // A wide cone samples coarser levels: another colour.
        let wide = cone_colour(&inp, [2, 8], 2.0, [12, 8], -0.25, remainder).unwrap();
        assert!(wide.colour != sharp.colour, "{wide:?}");
        // Negative: a ray that ends in front of the wall (view depth 3.6) meets less of it.
        let front = cone_colour(&inp, [2, 8], 1000.0, [12, 8], -1.0 / 3.6, remainder).unwrap();
        assert!(front.weight < sharp.weight, "{front:?} {sharp:?}");
    }
}

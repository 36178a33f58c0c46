//! Hi-Z screen-space reflections (Uludag 2014, GPU Pro 5, "Hi-Z Screen-Space Cone-Traced
//! Reflections"), mirror rays only: the CPU twin of `spirv/ssr_hiz.wgsl` and `spirv/ssr.wgsl`, the
//! same loops with the same f32 arithmetic in the same order, so that the GPU's records can be
//! checked pixel by pixel (`tests/ssr.rs`).
//!
//! - [`build_hiz`]: the min pyramid of the depth key (`spirv/shared/ssr.wgsl`: `q = -1 / w`, an
//!   affine function of the post-projective depth, nearer = smaller, 0 where nothing was drawn),
//!   levels `ceil(W / 2^l) x ceil(H / 2^l)` down to 1 x 1 ([`hiz_levels`]).
//! - [`trace`]: the chapter's traversal (Listing 4.2 / 4.5): from the mirror pixel, cross into the
//!   next level-0 cell; then per iteration, move the ray to the cell's minimum depth plane if it
//!   is in front of it; if that leaves the cell, stop at the cell boundary instead and go up a
//!   level (a free step), else go down a level (a blocked step); the ray hits when it goes down
//!   from level 0. An explicit iteration cap bounds the loop.
//!
//! What it cannot trace, and reports as unresolved ([`Outcome`]): rays towards the camera or
//! parallel to the screen (a min pyramid only traces rays going away, section 4.6.7), rays that
//! leave the screen, rays that run out of iterations, and (with a thickness) hits too far behind
//! the surface they land on. Without a thickness (the chapter's Listing 4.5, the default) any
//! pixel the ray passes behind is a hit: the chapter's thin-object and silhouette failures.
use glam::{Mat4, Vec2, Vec3, Vec4};

/// Options of the screen-space method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SsrOptions {
    /// Loop iterations before a ray is given up (unresolved).
    pub max_iterations: u32,
    /// Thickness test: `Some(t)` makes a hit more than `t` world units (along the view axis)
    /// behind the surface it lands on unresolved. `None` (the chapter's Listing 4.5): every
    /// surface is infinitely thick.
    pub thickness: Option<f32>,
}

impl Default for SsrOptions {
    fn default() -> Self {
        SsrOptions {
            max_iterations: DEFAULT_MAX_ITERATIONS,
            thickness: None,
        }
    }
}

/// The default iteration cap: the chapter reports tens of iterations per ray; a ray that needs
/// more than this is given up.
pub const DEFAULT_MAX_ITERATIONS: u32 = 64;

/// Pixels a ray is pushed past a cell boundary so that it lands in the next cell (the chapter's
/// `HIZ_CROSS_EPSILON`).
pub const CROSS_EPSILON: f32 = 1.0 / 128.0;

/// Clamp before float-to-int conversions (as `spirv/ssr.wgsl`).
const CLAMP: f32 = 16_777_216.0;

/// The most levels the GPU's parameter block holds (frames up to 2^15 pixels wide).
pub const MAX_LEVELS: usize = 16;

/// What became of a ray; the GPU writes it in the record's `face` field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Outcome {
    Hit = 0,
    /// Towards the camera or parallel to the screen.
    TowardsCamera = 1,
    /// Left the screen (or reached infinite depth).
    OffScreen = 2,
    /// Ran out of iterations.
    Iterations = 3,
    /// The hit lies more than the thickness behind the surface.
    Thickness = 4,
    /// Landed where nothing was drawn.
    NoSurface = 5,
}

impl Outcome {
    pub const ALL: [Outcome; 6] = [
        Outcome::Hit,
        Outcome::TowardsCamera,
        Outcome::OffScreen,
        Outcome::Iterations,
        Outcome::Thickness,
        Outcome::NoSurface,
    ];

    /// The outcome with GPU code `code`.
    pub fn from_code(code: u32) -> Option<Outcome> {
        Self::ALL.into_iter().find(|o| *o as u32 == code)
    }

    pub fn name(self) -> &'static str {
        match self {
            Outcome::Hit => "hit",
            Outcome::TowardsCamera => "towards camera",
            Outcome::OffScreen => "off screen",
            Outcome::Iterations => "iteration cap",
            Outcome::Thickness => "thickness",
            Outcome::NoSurface => "no surface",
        }
    }
}

/// One level of the pyramid: first cell, width, height.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HizLevel {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
}

/// The levels of a `width x height` frame's pyramid, finest (the frame) first, down to 1 x 1.
pub fn hiz_levels(width: u32, height: u32) -> Vec<HizLevel> {
    let mut out = Vec::new();
    let mut offset = 0;
    let mut l = 0;
    loop {
        let (w, h) = (
            width.div_ceil(1 << l).max(1),
            height.div_ceil(1 << l).max(1),
        );
        out.push(HizLevel {
            offset,
            width: w,
            height: h,
        });
        offset += w * h;
        if w == 1 && h == 1 {
            return out;
        }
        l += 1;
    }
}

/// Cells of all levels together.
pub fn hiz_len(width: u32, height: u32) -> usize {
    hiz_levels(width, height)
        .iter()
        .map(|l| (l.width * l.height) as usize)
        .sum()
}

/// `m * (p, w)` in glam's (and `ssr_clip`'s) order.
pub fn clip(m: &Mat4, p: Vec3, w: f32) -> Vec4 {
    ((m.x_axis * p.x + m.y_axis * p.y) + m.z_axis * p.z) + m.w_axis * w
}

/// The depth key of a world position (`None`: nothing drawn there): `-1 / w`.
pub fn depth_key(view_proj: &Mat4, position: Option<Vec3>) -> f32 {
    match position {
        Some(p) => -1.0 / clip(view_proj, p, 1.0).w,
        None => 0.0,
    }
}

/// The min pyramid over `level0` (`width * height` depth keys, row-major), every level
/// concatenated as [`hiz_levels`] lays them out.
pub fn build_hiz(level0: &[f32], width: u32, height: u32) -> Vec<f32> {
    let levels = hiz_levels(width, height);
    let mut out = vec![0.0f32; hiz_len(width, height)];
    out[..level0.len()].copy_from_slice(level0);
    for pair in levels.windows(2) {
        let (src, dst) = (pair[0], pair[1]);
        for y in 0..dst.height {
            for x in 0..dst.width {
                let at = |sx: u32, sy: u32| out[(src.offset + sy * src.width + sx) as usize];
                let (sx, sy) = (2 * x, 2 * y);
                let mut m = at(sx, sy);
                if sx + 1 < src.width {
                    m = m.min(at(sx + 1, sy));
                }
                if sy + 1 < src.height {
                    m = m.min(at(sx, sy + 1));
                    if sx + 1 < src.width {
                        m = m.min(at(sx + 1, sy + 1));
                    }
                }
                out[(dst.offset + y * dst.width + x) as usize] = m;
            }
        }
    }
    out
}

/// A built pyramid with what the traversal needs.
pub struct Hiz<'a> {
    pub width: u32,
    pub height: u32,
    pub view_proj: Mat4,
    /// All levels, as [`build_hiz`] returns them.
    pub cells: &'a [f32],
    pub levels: Vec<HizLevel>,
}

/// What [`trace`] found for one mirror pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SsrResult {
    pub outcome: Outcome,
    /// The pixel the ray landed on (hit) or stopped in; components are clamped to +-2^24.
    pub pixel: [i32; 2],
    pub iterations: u32,
    /// The ray's depth key at the end.
    pub t: f32,
}

impl Hiz<'_> {
    fn at(&self, level: i32, cell: [i32; 2]) -> f32 {
        let l = self.levels[level as usize];
        self.cells[(l.offset + cell[1] as u32 * l.width + cell[0] as u32) as usize]
    }

    fn on_screen(&self, ray: Vec3) -> bool {
        ray.x >= 0.0
            && ray.x < self.width as f32
            && ray.y >= 0.0
            && ray.y < self.height as f32
            && ray.z < 0.0
    }
}

fn cell_of(p: Vec2, level: i32) -> [i32; 2] {
    let size = (1u32 << level) as f32;
    let c = (p.clamp(Vec2::splat(-CLAMP), Vec2::splat(CLAMP)) / size).floor();
    [c.x as i32, c.y as i32]
}

/// The chapter's `intersectCellBoundary`.
fn cross_cell(o: Vec3, d: Vec3, cell: [i32; 2], level: i32, step: Vec2, offset: Vec2) -> Vec3 {
    let size = (1u32 << level) as f32;
    let boundary = (Vec2::new(cell[0] as f32, cell[1] as f32) + step) * size + offset;
    let tx = if d.x != 0.0 {
        (boundary.x - o.x) / d.x
    } else {
        f32::MAX
    };
    let ty = if d.y != 0.0 {
        (boundary.y - o.y) / d.y
    } else {
        f32::MAX
    };
    o + d * tx.min(ty)
}

/// Traces the reflected ray `origin + s dir` (world) of mirror pixel `pixel` through `ssr_hiz`.
pub fn trace(
    hiz: &Hiz<'_>,
    options: &SsrOptions,
    pixel: [u32; 2],
    origin: Vec3,
    dir: Vec3,
) -> SsrResult {
    trace_logged(hiz, options, pixel, origin, dir, &mut super::NoLog)
}

/// [`trace`], reporting each iteration's Hi-Z read and crossing to `log` ([`super::Work::Hiz`]).
pub fn trace_logged<L: super::WorkLog + ?Sized>(
    hiz: &Hiz<'_>,
    options: &SsrOptions,
    pixel: [u32; 2],
    origin: Vec3,
    dir: Vec3,
    log: &mut L,
) -> SsrResult {
    let (w, h) = (hiz.width as f32, hiz.height as f32);
    let c0 = clip(&hiz.view_proj, origin, 1.0);
    let c1 = clip(&hiz.view_proj, dir, 0.0);
    let v = Vec3::new(
        (0.5 * w) * (c1.x * c0.w - c0.x * c1.w),
        (0.5 * h) * (c1.y * c0.w - c0.y * c1.w),
        c1.w,
    );
    let here = [pixel[0] as i32, pixel[1] as i32];
    let result = |outcome, pixel, iterations, t| SsrResult {
        outcome,
        pixel,
        iterations,
        t,
    };
    // `v.z > 0` is false for NaN too: such a ray is not traced either.
    if v.z.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return result(Outcome::TowardsCamera, here, 0, hiz.at(0, here));
    }
    let p = Vec3::new(
        pixel[0] as f32 + 0.5,
        pixel[1] as f32 + 0.5,
        hiz.at(0, here),
    );
    let d = v / v.z;
    let o = p - d * p.z;
    let step = Vec2::new(
        if d.x >= 0.0 { 1.0 } else { 0.0 },
        if d.y >= 0.0 { 1.0 } else { 0.0 },
    );
    let offset = Vec2::new(
        if d.x >= 0.0 { 1.0 } else { -1.0 },
        if d.y >= 0.0 { 1.0 } else { -1.0 },
    ) * CROSS_EPSILON;
    let max_level = hiz.levels.len() as i32 - 1;
    let mut ray = cross_cell(o, d, here, 0, step, offset);
    log.log(super::Work::Hiz {
        level: -1,
        x: here[0],
        y: here[1],
        cross: true,
    });
    let mut level = 0i32;
    let mut iterations = 0u32;
    while level >= 0 && iterations < options.max_iterations {
        if !hiz.on_screen(ray) {
            break;
        }
        let old_cell = cell_of(ray.truncate(), level);
        let min_z = hiz.at(level, old_cell);
        let mut next = o + d * ray.z.max(min_z);
        let cross = cell_of(next.truncate(), level) != old_cell;
        log.log(super::Work::Hiz {
            level,
            x: old_cell[0],
            y: old_cell[1],
            cross,
        });
        if cross {
            next = cross_cell(o, d, old_cell, level, step, offset);
            level = max_level.min(level + 2);
        }
        ray = next;
        level -= 1;
        iterations += 1;
    }
    let last = cell_of(ray.truncate(), 0);
    if !hiz.on_screen(ray) {
        return result(Outcome::OffScreen, last, iterations, ray.z);
    }
    if level >= 0 {
        return result(Outcome::Iterations, last, iterations, ray.z);
    }
    let surface = hiz.at(0, last);
    if surface == 0.0 {
        return result(Outcome::NoSurface, last, iterations, ray.z);
    }
    if let Some(thickness) = options.thickness
        && (-1.0 / ray.z) - (-1.0 / surface) > thickness
    {
        return result(Outcome::Thickness, last, iterations, ray.z);
    }
    result(Outcome::Hit, last, iterations, ray.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_reach_one_cell() {
        let l = hiz_levels(160, 120);
        assert_eq!(l.len(), 9);
        assert_eq!((l[1].width, l[1].height, l[1].offset), (80, 60, 19200));
        assert_eq!((l[8].width, l[8].height), (1, 1));
        assert_eq!(hiz_levels(1, 1).len(), 1);
        assert_eq!(hiz_levels(5, 1).len(), 4);
    }

    #[test]
    fn pyramid_takes_the_min_of_existing_children() {
        // 3 x 3: the right column and bottom row have no partner.
        let level0 = [-5.0, -1.0, -7.0, -2.0, -3.0, -4.0, -9.0, -1.0, 0.0];
        let h = build_hiz(&level0, 3, 3);
        assert_eq!(&h[9..13], &[-5.0, -7.0, -9.0, 0.0]);
        assert_eq!(h[13], -9.0);
        // Negative: a perturbed texel changes its parent.
        let mut p = level0;
        p[4] = -6.0;
        assert_ne!(build_hiz(&p, 3, 3)[9], -5.0);
    }

    /// A camera at the origin looking down -z at a wall `z = -5` filling the frame.
    fn wall() -> (Mat4, Vec<f32>) {
        let camera = crate::camera::Camera {
            name: "wall".into(),
            eye: Vec3::ZERO,
            target: Vec3::new(0.0, 0.0, -1.0),
            up: Vec3::Y,
            fov_y_deg: 60.0,
            width: 64,
            height: 48,
            jitter: glam::Vec2::ZERO,
        };
        let vp = camera.view_proj(0.01);
        let level0 = (0..64u32 * 48)
            .map(|k| {
                let (i, j) = (k % 64, k / 64);
                let (o, d) = camera.ray(i, j);
                depth_key(&vp, Some(o + d * (-5.0 - o.z) / d.z))
            })
            .collect();
        (vp, level0)
    }

    #[test]
    fn ray_to_a_wall_lands_on_the_pixel_of_the_analytic_hit() {
        let (vp, mut level0) = wall();
        let origin = Vec3::new(-0.4, 0.1, -2.0);
        let project = |p: Vec3| {
            let c = vp * p.extend(1.0);
            [
                ((c.x / c.w + 1.0) * 32.0).floor() as i32,
                ((c.y / c.w + 1.0) * 24.0).floor() as i32,
            ]
        };
        let pixel = project(origin).map(|c| c as u32);
        // The ray starts on what its pixel shows (as a mirror pixel does): a one-pixel object.
        level0[(pixel[1] * 64 + pixel[0]) as usize] = depth_key(&vp, Some(origin));
        let cells = build_hiz(&level0, 64, 48);
        let hiz = Hiz {
            width: 64,
            height: 48,
            view_proj: vp,
            cells: &cells,
            levels: hiz_levels(64, 48),
        };
        for dir in [
            Vec3::new(0.3, 0.1, -1.0),
            Vec3::new(-0.2, -0.25, -1.0),
            Vec3::new(0.05, 0.0, -1.0),
        ] {
            let dir = dir.normalize();
            let exact = origin + dir * ((-5.0 - origin.z) / dir.z);
            let r = trace(&hiz, &SsrOptions::default(), pixel, origin, dir);
            assert_eq!(r.outcome, Outcome::Hit, "{dir}: {r:?}");
            let want = project(exact);
            assert!(
                (r.pixel[0] - want[0]).abs() <= 1 && (r.pixel[1] - want[1]).abs() <= 1,
                "{dir}: {r:?}, analytic pixel {want:?}"
            );
            assert!(r.iterations > 0 && r.iterations < 40, "{r:?}");
            // Negative: a wall one unit nearer (every key changed) moves the hit.
            let nearer: Vec<f32> = level0.iter().map(|q| q * 5.0 / 4.0).collect();
            let cells = build_hiz(&nearer, 64, 48);
            let moved = trace(
                &Hiz {
                    cells: &cells,
                    levels: hiz_levels(64, 48),
                    ..hiz
                },
                &SsrOptions::default(),
                pixel,
                origin,
                dir,
            );
            assert_ne!(moved.pixel, r.pixel, "{dir}");
        }
        // Leaving the frame sideways, and coming back towards the camera.
        let r = trace(
            &hiz,
            &SsrOptions::default(),
            pixel,
            origin,
            Vec3::new(1.0, 0.0, -0.2).normalize(),
        );
        assert_eq!(r.outcome, Outcome::OffScreen, "{r:?}");
        let r = trace(
            &hiz,
            &SsrOptions::default(),
            pixel,
            origin,
            Vec3::new(0.1, 0.0, 1.0).normalize(),
        );
        assert_eq!((r.outcome, r.iterations), (Outcome::TowardsCamera, 0));
        // An iteration cap of 1 gives up.
        let capped = SsrOptions {
            max_iterations: 1,
            thickness: None,
        };
        let r = trace(
            &hiz,
            &capped,
            pixel,
            origin,
            Vec3::new(0.3, 0.1, -1.0).normalize(),
        );
        assert_eq!(r.outcome, Outcome::Iterations);
    }

    #[test]
    fn gpu_outcome_codes_round_trip() {
        for o in Outcome::ALL {
            assert_eq!(Outcome::from_code(o as u32), Some(o));
        }
        assert_eq!(Outcome::from_code(6), None);
    }
}

#![forbid(unsafe_code)]
//! The pinhole camera and its pixel convention.
//!
//! The convention is Vulkan's, so that the CPU reference and the rasteriser agree pixel for
//! pixel:
//! - Pixel `(i, j)` has its centre at `(i + 0.5, j + 0.5)` in framebuffer coordinates; `j = 0` is
//!   the top row of the image.
//! - Normalised device coordinates: `x_ndc = 2 (i + 0.5) / W - 1`, `y_ndc = 2 (j + 0.5) / H - 1`,
//!   so `y_ndc = -1` is the top of the image (Vulkan's y points down). Depth is reversed and has
//!   no far plane: `z_ndc = near / z_view` runs from 1 at the near plane towards 0 at infinity, so
//!   a D32_SFLOAT depth buffer keeps f32's relative precision at every distance.
//! - The view is right-handed, looking down `-z` in camera space, with `up` towards the top of
//!   the image. [`Camera::view_proj`] is the matrix a vertex shader uses; [`Camera::ray`] is the
//!   primary ray through a pixel centre. A test checks that the two agree.
//! - Sub-pixel samples ([`crate::film`]): [`Camera::jitter`] moves the sample of every pixel by
//!   the same offset from its centre, in pixels (`x` right, `y` down). [`Camera::ray`] goes
//!   through `(i + 0.5 + jitter.x, j + 0.5 + jitter.y)` and [`Camera::proj`] shifts the image by
//!   `-jitter`, so that the rasteriser's pixel centre sees that point. At `jitter = 0` every
//!   float operation is the one without jitter (an added `+0.0` and no extra matrix product), so
//!   one sample per pixel is bit for bit the frame without samples.

use glam::{Mat4, Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: String,
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
    pub width: u32,
    pub height: u32,
    /// The sample's offset from each pixel's centre, in pixels (`x` right, `y` down; within
    /// `(-0.5, 0.5)` for samples inside the pixel): [`Vec2::ZERO`], the pixel centre, but while a
    /// frame of several samples per pixel renders one of them ([`crate::film`]).
    pub jitter: Vec2,
}

impl Camera {
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// World-to-camera matrix (right-handed, looking down -z).
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// Camera-to-clip matrix for Vulkan: reversed depth with an infinite far plane
    /// (`z_ndc = near / distance along the view axis`: 1 at `near`, towards 0 far away; test
    /// `GREATER`, clear to 0), y of NDC pointing down.
    pub fn proj(&self, near: f32) -> Mat4 {
        // glam's Vulkan projection: NDC z in [0, 1], NDC y pointing down (camera up maps to -y).
        let p = glam::camera::rh::proj::vulkan::perspective_infinite_reverse(
            self.fov_y_deg.to_radians(),
            self.aspect(),
            near,
        );
        if self.jitter == Vec2::ZERO {
            return p;
        }
        // The point the ray through `centre + jitter` meets lands on the pixel centre: NDC moves
        // by `-2 jitter / size` (clip space by that times `w`).
        let dx = -2.0 * self.jitter.x / self.width as f32;
        let dy = -2.0 * self.jitter.y / self.height as f32;
        // Clip x' = x + dx w, y' = y + dy w: each column gains (dx, dy) times its w entry.
        let d = glam::Vec4::new(dx, dy, 0.0, 0.0);
        Mat4::from_cols(
            p.x_axis + d * p.x_axis.w,
            p.y_axis + d * p.y_axis.w,
            p.z_axis + d * p.z_axis.w,
            p.w_axis + d * p.w_axis.w,
        )
    }

    pub fn view_proj(&self, near: f32) -> Mat4 {
        self.proj(near) * self.view()
    }

    /// Cosine of the angle between the view axis and the ray through a corner of the frame:
    /// every point the camera sees at distance `d` from the eye lies at least `d` times this
    /// far along the view axis.
    pub fn corner_cos(&self) -> f32 {
        let tan = (0.5 * self.fov_y_deg.to_radians()).tan();
        let corner = tan * (1.0 + self.aspect() * self.aspect()).sqrt();
        1.0 / (1.0 + corner * corner).sqrt()
    }

    /// The camera in coordinates relative to `anchor` ([`crate::scene::Scene::rebased`]): its
    /// eye and target moved, each subtraction in f64 rounded once.
    pub fn rebased(&self, anchor: Vec3) -> Camera {
        let local = |p: Vec3| (p.as_dvec3() - anchor.as_dvec3()).as_vec3();
        Camera {
            eye: local(self.eye),
            target: local(self.target),
            ..self.clone()
        }
    }

    /// Why `eye`, `target` and `up` fix no camera, with the numbers; `None` where they do. The
    /// camera's roll is the direction of `up` across the view: where `up` lies within
    /// [`MIN_UP_SINE`] of the view direction, f32 rounding decides it, and the G-buffer's view
    /// matrix and [`Camera::basis`] (two computations of one roll) can disagree by a whole
    /// turn of the image about the view axis.
    pub fn view_error(&self) -> Option<String> {
        let view = (self.target - self.eye).as_dvec3();
        let up = self.up.as_dvec3();
        if view.length_squared() == 0.0 {
            return Some(format!("eye and target are the same point {}", self.eye));
        }
        if up.length_squared() == 0.0 {
            return Some("up is zero".into());
        }
        let sine = view.normalize().cross(up.normalize()).length();
        (sine < MIN_UP_SINE).then(|| {
            format!(
                "up {} lies {:.3e} degrees from the view direction {} (the sine {sine:.3e} is \
                 below {MIN_UP_SINE:e}): f32 cannot fix the camera's roll there; choose an up \
                 vector across the view (for a view straight down, up = [0, 0, -1])",
                self.up,
                sine.asin().to_degrees(),
                view.normalize().as_vec3(),
            )
        })
    }

    /// The orthonormal camera basis `(right, up, back)`: the view looks along `-back`.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let back = (self.eye - self.target).normalize();
        let right = self.up.cross(back).normalize();
        let up = back.cross(right);
        (right, up, back)
    }

    /// A pixel rectangle `[x0, x1) x [y0, y1)` that holds every pixel whose centre sees one of
    /// the triangles with corners among `points` (world positions): their projections' bounding
    /// box, widened by a pixel for the rasteriser's sub-pixel snapping and clamped to the frame.
    /// `None` when it cannot be bounded that way: a point on or behind the eye's plane (a
    /// triangle that crosses it projects to no bounded box), or one that is not finite.
    pub fn screen_rect(
        &self,
        points: impl IntoIterator<Item = Vec3>,
        near: f32,
    ) -> Option<[u32; 4]> {
        let vp = self.view_proj(near);
        let (w, h) = (self.width as f32, self.height as f32);
        let mut lo = glam::Vec2::splat(f32::INFINITY);
        let mut hi = glam::Vec2::splat(f32::NEG_INFINITY);
        for p in points {
            let c = vp * p.extend(1.0);
            if !c.is_finite() || c.w <= 0.0 {
                return None;
            }
            let px = glam::Vec2::new((c.x / c.w + 1.0) * 0.5 * w, (c.y / c.w + 1.0) * 0.5 * h);
            lo = lo.min(px);
            hi = hi.max(px);
        }
        if lo.x > hi.x {
            return Some([0, 0, 0, 0]);
        }
        let clamp = |v: f32, n: f32| v.clamp(0.0, n) as u32;
        Some([
            clamp((lo.x - 1.0).floor(), w),
            clamp((lo.y - 1.0).floor(), h),
            clamp((hi.x + 1.0).ceil(), w),
            clamp((hi.y + 1.0).ceil(), h),
        ])
    }

    /// `tan(fov_y / 2)`, as [`Camera::ray`] computes it.
    pub fn tan_half_fov_y(&self) -> f32 {
        (0.5 * self.fov_y_deg.to_radians()).tan()
    }

    /// The primary ray through pixel `(i, j)`'s sample, its centre moved by [`Camera::jitter`]:
    /// origin and unit direction. `camera_ray_dir` in `spirv/shared/camera.wgsl` repeats it
    /// operation for operation.
    pub fn ray(&self, i: u32, j: u32) -> (Vec3, Vec3) {
        let (right, up, back) = self.basis();
        let tan = self.tan_half_fov_y();
        let x_ndc = 2.0 * (i as f32 + 0.5 + self.jitter.x) / self.width as f32 - 1.0;
        let y_ndc = 2.0 * (j as f32 + 0.5 + self.jitter.y) / self.height as f32 - 1.0;
        let x = x_ndc * tan * self.aspect();
        let y = -y_ndc * tan;
        let dir = (right * x + up * y - back).normalize();
        (self.eye, dir)
    }
}

/// The smallest sine of the angle between `up` and the view direction that fixes a camera's
/// roll ([`Camera::view_error`]): 1e-4 (0.0057 degrees). Below it the basis vector `right =
/// up x back` is a difference of nearly equal f32 products, whose rounding (some 2^-24 of the
/// vectors' scale) turns it by up to 2^-24 / sine: 6e-4 radians at the bound, under a pixel of a
/// 50 degree, 1000-pixel frame, and a whole turn where `up` is the view direction rounded.
pub const MIN_UP_SINE: f64 = 1e-4;

/// `EYE_PLANE_BOUND` of `spirv/shared/eye_plane.wgsl`: 2^-21.
pub const EYE_PLANE_BOUND: f64 = 1.0 / (1u64 << 21) as f64;

/// How far the plane of triangle `tri` passes from the viewpoint `p` (an eye or a CMO centre),
/// in the terms of `eye_plane_holds` (`spirv/shared/eye_plane.wgsl`), computed in f64:
/// `(offset, bound)`, `offset = |(p - o) . n|` (the distance of `p` from the plane) and
/// `bound = EYE_PLANE_BOUND (|p| + |o| + |p - o|)`, with `o` the vertex nearest `p` and `n` the
/// plane's unit normal, [`plane_normal`]. The GPU culls the triangle (seen edge-on) where
/// `offset <= bound` in f32; the two differ by some 2^-22 of `bound`'s scale (half the bound)
/// on a well-shaped triangle. A triangle without a plane (its corners on one line in f64)
/// gives a NaN offset: never edge-on, and it covers no pixel.
pub fn eye_plane_offset(p: Vec3, tri: &[Vec3; 3]) -> (f64, f64) {
    let p = p.as_dvec3();
    let v = tri.map(|v| v.as_dvec3());
    let d = v.map(|v| (v - p).length());
    let k = if d[1] < d[0] && d[1] <= d[2] {
        1
    } else if d[2] < d[0] && d[2] < d[1] {
        2
    } else {
        0
    };
    let o = v[k];
    let s = p - o;
    let offset = plane_normal(&v).map_or(f64::NAN, |n| s.dot(n).abs());
    (
        offset,
        EYE_PLANE_BOUND * (p.length() + o.length() + s.length()),
    )
}

/// The unit normal of a triangle's plane, well conditioned: the cross product of its two
/// longest edges, each made unit first (so that no product overflows at any coordinate the
/// scene may hold), then normalised. Never divided by the sine of a small angle, so a sliver
/// (corners nearly on one line) gets a normal whose error is that of its rounding, not one
/// scaled up by the sliver's aspect. `None` where the corners lie on one line (or coincide).
/// `spirv/shared/eye_plane.wgsl` repeats it in f32, edge for edge.
pub fn plane_normal(v: &[glam::DVec3; 3]) -> Option<glam::DVec3> {
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let l = e.map(|e| e.length());
    // The shortest edge is left out (the first of equals).
    let short = if l[0] <= l[1] && l[0] <= l[2] {
        0
    } else if l[1] <= l[2] {
        1
    } else {
        2
    };
    let (a, b) = (e[(short + 1) % 3], e[(short + 2) % 3]);
    let m = (a / a.length()).cross(b / b.length());
    let len = m.length();
    (len > 0.0 && len.is_finite()).then(|| m / len)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            name: "t".into(),
            eye: Vec3::new(1.0, 2.0, 5.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_y_deg: 50.0,
            width: 64,
            height: 48,
            jitter: glam::Vec2::ZERO,
        }
    }

    /// The rectangle holds the pixels whose centre ray meets a point of the set, including the
    /// frame's corners; a point behind the eye gives none; an empty set an empty rectangle.
    #[test]
    fn screen_rect_holds_the_points_pixels() {
        let c = cam();
        let near = 0.1;
        let pts: Vec<Vec3> = [(3, 5), (40, 7), (20, 31), (63, 47), (0, 0)]
            .iter()
            .map(|&(i, j)| {
                let (o, d) = c.ray(i, j);
                o + d * 4.0
            })
            .collect();
        let r = c.screen_rect(pts.iter().copied(), near).unwrap();
        assert_eq!(r, [0, 0, 64, 48]);
        let r = c.screen_rect(pts[..3].iter().copied(), near).unwrap();
        for &(i, j) in &[(3u32, 5u32), (40, 7), (20, 31)] {
            assert!(
                i >= r[0] && i < r[2] && j >= r[1] && j < r[3],
                "{i},{j} outside {r:?}"
            );
        }
        assert!(r[0] <= 3 && r[2] <= 43 && r[1] <= 5 && r[3] <= 34, "{r:?}");
        // Negative: the rectangle of the first two points misses the third's pixel.
        let r2 = c.screen_rect(pts[..2].iter().copied(), near).unwrap();
        assert!(r2[3] <= 31, "{r2:?}");
        let (_, _, back) = c.basis();
        assert_eq!(c.screen_rect([c.eye + back], near), None);
        assert_eq!(c.screen_rect([], near), Some([0, 0, 0, 0]));
    }

    /// A point on the ray through a pixel centre projects back to that pixel centre, at the
    /// reversed depth `near / z_view`, from 3 to 3e7 units away.
    #[test]
    fn ray_and_projection_agree() {
        let c = cam();
        let near = 0.1;
        let vp = c.view_proj(near);
        let (_, _, back) = c.basis();
        for &(i, j) in &[(0, 0), (63, 0), (0, 47), (63, 47), (20, 31)] {
            let (o, d) = c.ray(i, j);
            for t in [3.0, 3e3, 3e7] {
                let p = vp.project_point3(o + d * t);
                let px = (p.x + 1.0) * 0.5 * c.width as f32;
                let py = (p.y + 1.0) * 0.5 * c.height as f32;
                assert!((px - (i as f32 + 0.5)).abs() < 1e-3, "x {px} for pixel {i}");
                assert!((py - (j as f32 + 0.5)).abs() < 1e-3, "y {py} for pixel {j}");
                let z_view = (d * t).dot(-back);
                assert!(
                    (p.z - near / z_view).abs() <= 1e-5 * p.z,
                    "depth {} at {t}",
                    p.z
                );
            }
        }
    }

    /// With a jitter, the ray through the pixel's moved sample projects (jittered `view_proj`)
    /// back to the pixel centre: the rasteriser's centre sees the sample's ray. Negative: the
    /// unjittered projection puts it `jitter` pixels away. A zero jitter changes no bit.
    #[test]
    fn jittered_ray_and_projection_agree() {
        let near = 0.1;
        for jitter in [glam::Vec2::new(0.3, -0.2), glam::Vec2::new(-0.45, 0.4)] {
            let c = Camera { jitter, ..cam() };
            let plain = cam();
            let vp = c.view_proj(near);
            for &(i, j) in &[(0, 0), (63, 47), (20, 31)] {
                let (o, d) = c.ray(i, j);
                let px = |m: Mat4| {
                    let p = m.project_point3(o + d * 30.0);
                    glam::Vec2::new(
                        (p.x + 1.0) * 0.5 * c.width as f32,
                        (p.y + 1.0) * 0.5 * c.height as f32,
                    )
                };
                let centre = glam::Vec2::new(i as f32 + 0.5, j as f32 + 0.5);
                assert!(
                    (px(vp) - centre).abs().max_element() < 1e-3,
                    "{jitter} {i},{j}"
                );
                let off = px(plain.view_proj(near)) - centre;
                assert!(
                    (off - jitter).abs().max_element() < 1e-3,
                    "{off} vs {jitter}"
                );
            }
        }
        let zero = Camera {
            jitter: glam::Vec2::ZERO,
            ..cam()
        };
        let a = zero.view_proj(near).to_cols_array().map(f32::to_bits);
        let b = cam().view_proj(near).to_cols_array().map(f32::to_bits);
        assert_eq!(a, b);
        assert_eq!(zero.ray(5, 7), cam().ray(5, 7));
    }

    /// The frame's corner direction makes the angle `corner_cos` with the view axis; no pixel's
    /// ray a larger one. Negative: a narrower field of view gives a larger cosine.
    #[test]
    fn corner_cosine() {
        let c = cam();
        let (right, up, back) = c.basis();
        let tan = (0.5 * c.fov_y_deg.to_radians()).tan();
        let corner = (right * tan * c.aspect() + up * tan - back).normalize();
        let cos = corner.dot(-back);
        assert!(
            (cos - c.corner_cos()).abs() < 1e-6,
            "{cos} vs {}",
            c.corner_cos()
        );
        for (i, j) in [(0, 0), (63, 0), (31, 0), (0, 23), (63, 47), (10, 40)] {
            assert!(c.ray(i, j).1.dot(-back) >= c.corner_cos());
        }
        let narrow = Camera {
            fov_y_deg: 20.0,
            ..cam()
        };
        assert!(narrow.corner_cos() > c.corner_cos() + 0.05);
    }

    /// An `up` within rounding of the view direction is refused with its numbers, whichever
    /// way it leans; one 1e-3 radians off (a view nearly straight down with `up = y`) is not,
    /// nor are the test camera's. Negative: exactly along the view, refused too.
    #[test]
    fn up_along_the_view_is_refused() {
        let c = cam();
        assert_eq!(c.view_error(), None);
        let view = (c.target - c.eye).normalize();
        let across = view.any_orthonormal_vector();
        for (tilt, refused) in [(1e-6f32, true), (5e-5, true), (2e-4, false), (1e-3, false)] {
            for sign in [1.0f32, -1.0] {
                let up = (sign * view + tilt * across).normalize();
                let e = Camera { up, ..cam() }.view_error();
                assert_eq!(e.is_some(), refused, "tilt {tilt}, sign {sign}: {e:?}");
                if let Some(e) = e {
                    assert!(e.contains("degrees from the view direction") && e.contains("e-"));
                }
            }
        }
        assert!(Camera { up: view, ..cam() }.view_error().is_some());
        assert!(
            Camera {
                up: Vec3::ZERO,
                ..cam()
            }
            .view_error()
            .is_some()
        );
        let same = Camera {
            target: cam().eye,
            ..cam()
        };
        assert!(same.view_error().is_some());
    }

    /// The top row looks up, the left column looks left.
    #[test]
    fn orientation() {
        let c = cam();
        let (right, up, _) = c.basis();
        let (_, top) = c.ray(32, 0);
        let (_, bottom) = c.ray(32, 47);
        assert!(top.dot(up) > bottom.dot(up));
        let (_, left) = c.ray(0, 24);
        let (_, rightmost) = c.ray(63, 24);
        assert!(left.dot(right) < rightmost.dot(right));
    }
}

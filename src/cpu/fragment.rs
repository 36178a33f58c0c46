//! CPU twins of the per-pixel passes `fragment_trace` and `envmap` (`spirv/fragment_trace.wgsl`,
//! `spirv/envmap.wgsl`): what one mirror pixel's record holds, given its reflected ray.
//!
//! Both read the same data as the shaders: the captured cube maps (read back from the GPU) and
//! the ray a pixel traces (`origin + t dir`, `t` in `[0, t_hi]`, `dir` unit length). A record's
//! status is [`RECORD_HIT`], [`RECORD_ESCAPED`] or [`RECORD_UNRESOLVED`], as in
//! `spirv/shared/mirror.wgsl`.

use glam::Vec3;

use super::CmoTracer;
use super::multi::{MultiStatus, Verify, trace_cmos_verified};
use super::options::{TraceOptions, trace_ray};
use super::watertight::intersect;
use crate::cubemap::Texel;
use crate::cubemap::face::{dir_to_texel, texel_centre_dir};

/// The ray hit a captured surface.
pub const RECORD_HIT: u32 = 0;
/// The ray left the scene (background).
pub const RECORD_ESCAPED: u32 = 1;
/// No CMO could decide; the composite pass fills the pixel with the fallback.
pub const RECORD_UNRESOLVED: u32 = 2;

/// What a method found for one mirror pixel (the comparable part of a GPU record).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelResult {
    /// [`RECORD_HIT`], [`RECORD_ESCAPED`] or [`RECORD_UNRESOLVED`].
    pub status: u32,
    /// The deciding CMO (`u32::MAX` when unresolved).
    pub cmo: u32,
    /// The deciding texel.
    pub texel: Texel,
    /// A hit on the riser between two texel patches.
    pub riser: bool,
    /// World hit point (see the shaders for escaped and unresolved rays).
    pub point: Vec3,
    /// Linear colour: the deciding texel's captured colour on a hit, else the background.
    pub colour: Vec3,
    /// Verified hits: the global triangle hit (`u32::MAX` otherwise).
    pub triangle: u32,
}

/// `fragment_trace` for one pixel with a texel-colour criterion: [`trace_ray`] over the CMOs,
/// coloured by the hit texel (what the GPU runs for the approximate criteria; the exact
/// criterion is [`trace_pixel_verified`]).
pub fn trace_pixel(
    cmos: &[CmoTracer],
    origin: Vec3,
    dir: Vec3,
    t_hi: f32,
    opts: &TraceOptions,
    background: Vec3,
) -> PixelResult {
    let r = trace_ray(cmos, origin, dir, 0.0, t_hi, opts);
    let status = match r.status {
        MultiStatus::Hit => RECORD_HIT,
        MultiStatus::Escaped => RECORD_ESCAPED,
        MultiStatus::Unresolved => RECORD_UNRESOLVED,
    };
    let texel = r.result.texel;
    let colour = if status == RECORD_HIT {
        let c = cmos[r.cmo as usize].cube.colour[texel.index(cmos[r.cmo as usize].cube.size)];
        Vec3::new(c[0], c[1], c[2])
    } else {
        background
    };
    PixelResult {
        status,
        cmo: r.cmo,
        texel,
        riser: r.result.riser,
        point: r.point,
        colour,
        triangle: u32::MAX,
    }
}

/// What the verified twin needs besides the CMOs: the scene and its tracer (for the shading at
/// a hit, `Tracer::shade`, whose WGSL twin is `hit_shade`) and the corners of every triangle
/// ([`super::verify::triangle_corners`]).
pub struct HitShading<'a> {
    pub scene: &'a crate::scene::Scene,
    pub tracer: &'a crate::reference::Tracer,
    pub corners: &'a [[Vec3; 3]],
}

/// `fragment_trace` for one pixel as the GPU runs it: with the centre criterion every hit is
/// verified ([`trace_cmos_verified`]) and shaded at the verified point; the approximate
/// criteria are [`trace_pixel`]. Also the compute path's twin (with `opts` giving the
/// traversal: every traversal decides alike).
pub fn trace_pixel_verified(
    cmos: &[CmoTracer],
    origin: Vec3,
    dir: Vec3,
    t_hi: f32,
    opts: &TraceOptions,
    background: Vec3,
    shading: &HitShading,
) -> PixelResult {
    if opts.approx().is_some() {
        return trace_pixel(cmos, origin, dir, t_hi, opts, background);
    }
    let verify = Verify {
        triangles: shading.corners,
    };
    let r = trace_cmos_verified(cmos, origin, dir, 0.0, t_hi, opts.traversal(), Some(verify));
    let (status, colour) = match r.status {
        MultiStatus::Hit => {
            let hit = crate::reference::Hit {
                t: r.result.t,
                position: r.point,
                triangle: r.triangle,
                bary: glam::Vec2::new(r.bary[1], r.bary[2]),
                error: 0.0,
            };
            (RECORD_HIT, shading.tracer.shade(shading.scene, &hit))
        }
        MultiStatus::Escaped => (RECORD_ESCAPED, background),
        MultiStatus::Unresolved => (RECORD_UNRESOLVED, background),
    };
    PixelResult {
        status,
        cmo: r.cmo,
        texel: r.result.texel,
        riser: r.result.riser,
        point: r.point,
        colour,
        triangle: r.triangle,
    }
}

/// The CMO whose centre is nearest to `p` (the first on ties), as `nearest_cmo` in WGSL.
pub fn nearest_cmo(cmos: &[CmoTracer], p: Vec3) -> usize {
    let mut best = (0, f32::INFINITY);
    for (k, c) in cmos.iter().enumerate() {
        let v = p - c.cube.centre;
        let d = v.dot(v);
        if d < best.1 {
            best = (k, d);
        }
    }
    best.0
}

/// `composite`'s environment-map fallback for an unresolved pixel's ray (`envmap_fallback` in
/// `spirv/composite.wgsl`): in CMO `k` nearest to `origin`, the triangle that the texel in
/// direction `dir` captured, met (watertight, [`super::watertight::intersect`]) by the ray from
/// the CMO centre along `dir`, or failing that along the texel's centre direction (which the
/// capture saw it along), and shaded there as the reference shades ([`HitShading`]); the
/// background where the texel captured nothing or both rays miss. No captured colour is read.
pub fn envmap_fallback(
    cmos: &[CmoTracer],
    origin: Vec3,
    dir: Vec3,
    background: Vec3,
    shading: &HitShading,
) -> Vec3 {
    let cube = &cmos[nearest_cmo(cmos, origin)].cube;
    let texel = dir_to_texel(dir, cube.size);
    let id = cube
        .triangle
        .get(texel.index(cube.size))
        .copied()
        .unwrap_or(super::verify::NO_TRIANGLE);
    let Some(&corners) = shading.corners.get(id as usize) else {
        return background;
    };
    let hit = intersect(cube.centre, dir, corners)
        .or_else(|| intersect(cube.centre, texel_centre_dir(texel, cube.size), corners));
    let Some(h) = hit else {
        return background;
    };
    let hit = crate::reference::Hit {
        t: h.t,
        position: cube.centre + dir * h.t,
        triangle: id,
        bary: glam::Vec2::new(h.bary[1], h.bary[2]),
        error: 0.0,
    };
    shading.tracer.shade(shading.scene, &hit)
}

/// `envmap` for one pixel: the texel of the nearest CMO in the ray's direction, no parallax.
/// A texel that captured nothing is escaped (the background).
pub fn envmap_pixel(cmos: &[CmoTracer], origin: Vec3, dir: Vec3, background: Vec3) -> PixelResult {
    let k = nearest_cmo(cmos, origin);
    let cube = &cmos[k].cube;
    let texel = dir_to_texel(dir, cube.size);
    let d = cube.distance_at(texel);
    let c = cube.colour[texel.index(cube.size)];
    let hit = d.is_finite();
    PixelResult {
        status: if hit { RECORD_HIT } else { RECORD_ESCAPED },
        cmo: k as u32,
        texel,
        riser: false,
        point: if hit {
            cube.centre + dir * d
        } else {
            Vec3::NAN
        },
        colour: if hit {
            Vec3::new(c[0], c[1], c[2])
        } else {
            background
        },
        triangle: u32::MAX,
    }
}

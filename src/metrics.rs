#![forbid(unsafe_code)]
//! Error of a traced reflection against the exact reference, over **mirror pixels**: the pixels
//! that are mirror pixels in either frame (the union of the two masks), so that a frame that
//! lost its mirror, or shows one where the reference has none, cannot look perfect.
//!
//! - **mask mismatch**: a mirror pixel of only one of the two frames (the method's rasterisation
//!   missed it, or drew a mirror where the reference has none). It is an error: the pixel shows
//!   the wrong thing. Counted both ways ([`ErrorReport::mask_missed`],
//!   [`ErrorReport::mask_extra`]).
//! - **unresolved**: the tracer could not decide (no CMO saw the ray's surface) and a fallback
//!   filled the pixel.
//! - **wrong surface**: a resolved pixel whose hit point lies farther from the reference's than
//!   `WRONG_SURFACE_FOOTPRINTS` texel footprints, or that hit something where the reference's ray
//!   left the scene (or the reverse). A texel footprint at a point is its distance from the
//!   nearest CMO centre times `2 / N`, the angular size of a texel at the centre of a face of
//!   `N` texels (texels are smaller towards the face corners, so this is an upper bound).
//! - **error**: the share of mirror pixels that are not correct: mask mismatch + unresolved +
//!   wrong surface.
//! - **angular error**: the angle between the traced and the reference hit points as seen from
//!   the mirror point, over pixels where both hit something; NaN where there is no such pixel.
//! - **PSNR**: on linear RGB clamped to [0, 1], over mirror pixels (NaN when neither frame has
//!   any), over the whole frame, and over the **resolved** mirror pixels (mirror pixels of both
//!   frames that the tracer resolved; NaN when there are none): the image quality of what the
//!   tracer claims, apart from what the fallback filled.
//!   A colour against a Monte Carlo truth (a glossy frame) has only the first, over the truth's
//!   mirror pixels ([`psnr_over`]).
//! - **same triangle**: where the traced frame carries the triangle of each hit
//!   ([`Traced::triangle`]), the share of resolved mirror pixels whose hit triangle (global
//!   index, `u32::MAX` where the ray left the scene) is the reference's
//!   ([`Frame::triangle`]); NaN for frames without triangle IDs or without resolved pixels.

use glam::{DVec3, Vec3};

use crate::reference::{Frame, NO_ID};

/// How many texel footprints a hit may be off before it counts as the wrong surface. Two
/// footprints allow for the texel the hit falls in plus one neighbour: the exact per-texel
/// surface model is exact only to the texel it resolves.
pub const WRONG_SURFACE_FOOTPRINTS: f32 = 2.0;

/// What a traced method produced per pixel, row-major like [`Frame`].
#[derive(Clone, Debug)]
pub struct Traced {
    pub width: u32,
    pub height: u32,
    pub colour: Vec<Vec3>,
    /// 1 on mirror pixels.
    pub mask: Vec<u8>,
    /// World-space reflected hit point; NaN where the ray left the scene or was unresolved.
    pub hit_position: Vec<Vec3>,
    /// 1 where the tracer resolved the pixel (a hit, or provably leaving the scene).
    pub resolved: Vec<u8>,
    /// Global triangle index of the traced hit (`u32::MAX` where none), for tracers that know
    /// it; `None` for those that do not.
    pub triangle: Option<Vec<u32>>,
    /// 1 where the `trace` fallback (the BVH tracer) finished the pixel's ray; `None` for frames
    /// rendered without it.
    pub fallback: Option<Vec<u8>>,
    /// Reflections each pixel's path took (0 off the mirrors), for tracers that count them
    /// (the GPU frames' records); `None` for those that do not.
    pub bounces: Option<Vec<u32>>,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ErrorReport {
    /// Mirror pixels of either frame (the union of the two masks): the denominator of every
    /// fraction below.
    pub mirror_pixels: usize,
    /// Share of mirror pixels that are not correct: mask mismatch, unresolved or wrong surface.
    pub error: f64,
    /// Share of mirror pixels that are mirror pixels of one frame only.
    pub mask_mismatch_fraction: f64,
    pub unresolved: f64,
    pub wrong_surface: f64,
    /// NaN where no pixel has both hits.
    pub angular_mean_deg: f64,
    /// NaN where no pixel has both hits.
    pub angular_p95_deg: f64,
    /// PSNR over mirror pixels; infinite when they are identical, NaN when there are none.
    pub psnr_db: f64,
    /// PSNR over the whole frame; infinite when it is identical.
    pub psnr_frame_db: f64,
    /// PSNR over the resolved mirror pixels (mirror pixels of both frames, resolved by the
    /// tracer); NaN when there are none.
    pub psnr_resolved_db: f64,
    /// Share of resolved mirror pixels whose hit triangle is the reference's; NaN when the
    /// traced frame has no triangle IDs or there is no resolved mirror pixel.
    pub same_triangle: f64,
    /// Pixels where the masks of the two disagree: `mask_missed + mask_extra`.
    pub mask_mismatch: usize,
    /// Mirror pixels of the reference that are not mirror pixels of the traced frame.
    pub mask_missed: usize,
    /// Mirror pixels of the traced frame that are not mirror pixels of the reference.
    pub mask_extra: usize,
}

impl ErrorReport {
    /// The report of the reference against itself: no error, infinite PSNR.
    pub fn exact(mirror_pixels: usize) -> Self {
        ErrorReport {
            mirror_pixels,
            angular_mean_deg: if mirror_pixels == 0 { f64::NAN } else { 0.0 },
            angular_p95_deg: if mirror_pixels == 0 { f64::NAN } else { 0.0 },
            psnr_db: if mirror_pixels == 0 {
                f64::NAN
            } else {
                f64::INFINITY
            },
            psnr_frame_db: f64::INFINITY,
            psnr_resolved_db: if mirror_pixels == 0 {
                f64::NAN
            } else {
                f64::INFINITY
            },
            same_triangle: if mirror_pixels == 0 { f64::NAN } else { 1.0 },
            ..ErrorReport::default()
        }
    }
}

/// What one pixel of a traced frame is, against the reference ([`classify`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelClass {
    /// A mirror pixel of neither frame: not counted.
    NotMirror,
    /// A mirror pixel of the reference that the traced frame's rasterisation missed: a mask
    /// mismatch, an error.
    MaskMissed,
    /// A mirror pixel of the traced frame where the reference has none: a mask mismatch, an
    /// error.
    MaskExtra,
    /// The tracer could not decide; a fallback filled the pixel.
    Unresolved,
    /// Resolved, and (within [`WRONG_SURFACE_FOOTPRINTS`] footprints) the reference's surface,
    /// or both left the scene.
    Correct,
    /// Resolved, but another surface than the reference's, or a hit where the reference left
    /// the scene, or the reverse.
    WrongSurface,
}

/// The per-pixel verdict behind [`ErrorReport`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelError {
    pub class: PixelClass,
    /// Angle between the traced and reference hit points seen from the mirror point, degrees;
    /// `None` unless both hit something away from the mirror point.
    pub angle_deg: Option<f64>,
}

/// Classifies every pixel of `traced` against `reference` (same arguments as [`compare`]),
/// row-major. [`compare`] is this, summed up.
pub fn classify(
    reference: &Frame,
    traced: &Traced,
    mirror_point: &[Vec3],
    cmo_centres: &[Vec3],
    cube_size: u32,
) -> Vec<PixelError> {
    assert_eq!(
        (reference.width, reference.height),
        (traced.width, traced.height),
        "frames of different sizes"
    );
    let texel_angle = 2.0 / cube_size.max(1) as f32;
    let footprint = |p: Vec3| {
        cmo_centres
            .iter()
            .map(|c| (p - *c).length())
            .fold(f32::INFINITY, f32::min)
            * texel_angle
    };
    let verdict = |class| PixelError {
        class,
        angle_deg: None,
    };
    (0..reference.mask.len())
        .map(|k| {
            if reference.mask[k] == 0 {
                return verdict(if traced.mask[k] == 0 {
                    PixelClass::NotMirror
                } else {
                    PixelClass::MaskExtra
                });
            }
            if traced.mask[k] == 0 {
                return verdict(PixelClass::MaskMissed);
            }
            if traced.resolved[k] == 0 {
                return verdict(PixelClass::Unresolved);
            }
            let (rh, th) = (reference.hit_position[k], traced.hit_position[k]);
            match (rh.is_nan(), th.is_nan()) {
                (true, true) => verdict(PixelClass::Correct),
                (false, false) => {
                    // A hit on the mirror point itself (an approximate criterion firing at
                    // the ray's start) has no direction: no angle, the distance still counts.
                    // In f64 with atan2: acos of an f32 cosine cannot resolve angles below
                    // about 0.03 degrees (1 - cos is then under one f32 ulp of 1).
                    let p = mirror_point[k].as_dvec3();
                    let (a, b) = (rh.as_dvec3() - p, th.as_dvec3() - p);
                    let angle_deg = (a != DVec3::ZERO && b != DVec3::ZERO)
                        .then(|| a.cross(b).length().atan2(a.dot(b)).to_degrees());
                    PixelError {
                        class: if (rh - th).length() > WRONG_SURFACE_FOOTPRINTS * footprint(rh) {
                            PixelClass::WrongSurface
                        } else {
                            PixelClass::Correct
                        },
                        angle_deg,
                    }
                }
                _ => verdict(PixelClass::WrongSurface),
            }
        })
        .collect()
}

/// The squared error of one pixel's linear RGB, each clamped to [0, 1], in f64 ([`psnr`] sums
/// them).
fn squared_error(a: Vec3, b: Vec3) -> f64 {
    (a.clamp(Vec3::ZERO, Vec3::ONE) - b.clamp(Vec3::ZERO, Vec3::ONE))
        .as_dvec3()
        .length_squared()
}

/// PSNR of a summed squared error over `n` RGB pixels: infinite for no error, NaN for no pixel.
fn psnr(squared_error: f64, n: usize) -> f64 {
    if n == 0 {
        return f64::NAN;
    }
    let mse = squared_error / (3.0 * n as f64);
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    }
}

/// PSNR (dB) of `got` against `truth` over the pixels where `mask` is set, linear RGB clamped
/// to [0, 1]: infinite where equal, NaN over no pixel.
pub fn psnr_over(got: &[Vec3], truth: &[Vec3], mask: &[u8]) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for k in 0..truth.len() {
        if mask[k] == 0 {
            continue;
        }
        let d = got[k].clamp(Vec3::ZERO, Vec3::ONE) - truth[k].clamp(Vec3::ZERO, Vec3::ONE);
        sum += f64::from(d.length_squared()) / 3.0;
        n += 1;
    }
    if n == 0 {
        return f64::NAN;
    }
    if sum == 0.0 {
        return f64::INFINITY;
    }
    10.0 * (n as f64 / sum).log10()
}

/// Compares `traced` with `reference` over the mirror pixels of either (see the module docs).
/// `mirror_point` gives the primary hit on the mirror per pixel, `cmo_centres` and `cube_size`
/// define the texel footprint.
pub fn compare(
    reference: &Frame,
    traced: &Traced,
    mirror_point: &[Vec3],
    cmo_centres: &[Vec3],
    cube_size: u32,
) -> ErrorReport {
    let pixels = classify(reference, traced, mirror_point, cmo_centres, cube_size);
    let mut r = ErrorReport::default();
    let (mut unresolved, mut wrong, mut se, mut se_frame) = (0usize, 0usize, 0f64, 0f64);
    let mut angles = Vec::new();
    let (mut resolved, mut se_resolved, mut same) = (0usize, 0f64, 0usize);
    if let Some(ids) = &traced.triangle {
        assert_eq!(ids.len(), traced.mask.len(), "one triangle ID per pixel");
    }
    for (k, p) in pixels.iter().enumerate() {
        let d = squared_error(reference.colour[k], traced.colour[k]);
        se_frame += d;
        if p.class == PixelClass::NotMirror {
            continue;
        }
        r.mirror_pixels += 1;
        se += d;
        match p.class {
            PixelClass::MaskMissed => r.mask_missed += 1,
            PixelClass::MaskExtra => r.mask_extra += 1,
            PixelClass::Unresolved => unresolved += 1,
            PixelClass::WrongSurface => wrong += 1,
            PixelClass::Correct | PixelClass::NotMirror => {}
        }
        if matches!(p.class, PixelClass::Correct | PixelClass::WrongSurface) {
            resolved += 1;
            se_resolved += d;
            if let Some(ids) = &traced.triangle {
                same += usize::from(ids[k] == reference.triangle[k]);
            }
        }
        angles.extend(p.angle_deg);
    }
    r.mask_mismatch = r.mask_missed + r.mask_extra;
    let n = r.mirror_pixels.max(1) as f64;
    r.unresolved = unresolved as f64 / n;
    r.wrong_surface = wrong as f64 / n;
    r.mask_mismatch_fraction = r.mask_mismatch as f64 / n;
    r.error = (r.mask_mismatch + unresolved + wrong) as f64 / n;
    r.psnr_db = psnr(se, r.mirror_pixels);
    r.psnr_frame_db = psnr(se_frame, pixels.len());
    r.psnr_resolved_db = psnr(se_resolved, resolved);
    r.same_triangle = if traced.triangle.is_some() && resolved > 0 {
        same as f64 / resolved as f64
    } else {
        f64::NAN
    };
    if angles.is_empty() {
        r.angular_mean_deg = f64::NAN;
        r.angular_p95_deg = f64::NAN;
    } else {
        r.angular_mean_deg = angles.iter().sum::<f64>() / angles.len() as f64;
        angles.sort_by(f64::total_cmp);
        r.angular_p95_deg = angles[((angles.len() - 1) as f64 * 0.95).round() as usize];
    }
    r
}

/// Compares `colour` (with its mirror `mask` and, per pixel, whether its tracer `resolved` it;
/// `None`: every pixel) with `truth`, the converged frame of a scene with a glossy reflector.
/// There a reflected ray's hit is one sample of the lobe, so hits are not compared: the figures
/// are those of the colours and the masks, over the mirror pixels of either frame as
/// [`compare`] counts them (mask mismatch, unresolved, PSNR over them and over the frame), and
/// every hit figure (wrong surface, the overall error share, angles, PSNR over resolved pixels,
/// same triangle) is NaN: not measured.
pub fn compare_colour(
    truth: &Frame,
    colour: &[Vec3],
    mask: &[u8],
    resolved: Option<&[u8]>,
) -> ErrorReport {
    let mut r = ErrorReport {
        error: f64::NAN,
        wrong_surface: f64::NAN,
        angular_mean_deg: f64::NAN,
        angular_p95_deg: f64::NAN,
        psnr_resolved_db: f64::NAN,
        same_triangle: f64::NAN,
        ..ErrorReport::default()
    };
    let (mut unresolved, mut se, mut se_frame) = (0usize, 0f64, 0f64);
    for k in 0..truth.colour.len() {
        let d = squared_error(truth.colour[k], colour[k]);
        se_frame += d;
        let (t, g) = (truth.mask[k] != 0, mask[k] != 0);
        if !t && !g {
            continue;
        }
        r.mirror_pixels += 1;
        se += d;
        match (t, g) {
            (true, false) => r.mask_missed += 1,
            (false, true) => r.mask_extra += 1,
            _ => unresolved += usize::from(resolved.is_some_and(|v| v[k] == 0)),
        }
    }
    r.mask_mismatch = r.mask_missed + r.mask_extra;
    let n = r.mirror_pixels.max(1) as f64;
    r.mask_mismatch_fraction = r.mask_mismatch as f64 / n;
    r.unresolved = unresolved as f64 / n;
    r.psnr_db = psnr(se, r.mirror_pixels);
    r.psnr_frame_db = psnr(se_frame, truth.colour.len());
    r
}

/// Wrong surfaces off the reflectors (the verified-hit target's measure): of the reference's
/// mirror pixels whose reflected ray hits a non-reflector object, the share that `pixels` (the
/// verdicts of [`classify`]) calls [`PixelClass::WrongSurface`]. A reflector seeing itself is
/// left out: what it shows is its own reflection, which the CMOs capture only where it faces
/// their centre. NaN when no such pixel exists. `reflector[o]` says whether object `o` is a
/// reflector.
pub fn wrong_surface_off_reflector(
    reference: &Frame,
    reflector: &[bool],
    pixels: &[PixelError],
) -> f64 {
    let (mut total, mut wrong) = (0usize, 0usize);
    for (k, p) in pixels.iter().enumerate().take(reference.mask.len()) {
        let o = reference.object_id[k];
        if reference.mask[k] == 0 || o == NO_ID || reflector.get(o as usize).is_none_or(|&r| r) {
            continue;
        }
        total += 1;
        wrong += usize::from(p.class == PixelClass::WrongSurface);
    }
    if total == 0 {
        f64::NAN
    } else {
        wrong as f64 / total as f64
    }
}

/// The reflection-point method's accuracy measure (the paper's claim for a convex closed
/// reflector): of the reference's mirror pixels whose reflected ray hits a non-reflector object,
/// how many show that same object. `shown[k]` is the object a method shows at pixel `k` (`None`:
/// no object, or not a mirror pixel of the method). "Interior" pixels are those whose 3x3
/// neighbourhood in the reference is all mirror pixels hitting that same object: not on an edge
/// between two surfaces in the reflection, nor at the mirror's outline.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SameObject {
    /// Mirror pixels of the reference that show a non-reflector object.
    pub pixels: usize,
    /// Share of them where the method shows the same object (NaN when there are none).
    pub share: f64,
    pub interior_pixels: usize,
    /// The same share over the interior ones (NaN when there are none).
    pub interior_share: f64,
}

/// [`SameObject`] of `shown` against `reference`; `reflector[o]` says whether object `o` is a
/// reflector.
pub fn same_object(reference: &Frame, reflector: &[bool], shown: &[Option<u32>]) -> SameObject {
    let (w, h) = (reference.width as i64, reference.height as i64);
    let shows = |k: usize, o: u32| reference.mask[k] != 0 && reference.object_id[k] == o;
    let (mut total, mut same, mut interior, mut interior_same) = (0usize, 0usize, 0usize, 0usize);
    for (k, &shown) in shown.iter().enumerate().take(reference.mask.len()) {
        let o = reference.object_id[k];
        if reference.mask[k] == 0 || o == NO_ID || reflector.get(o as usize).is_none_or(|&r| r) {
            continue;
        }
        let ok = shown == Some(o);
        let (x, y) = (k as i64 % w, k as i64 / w);
        let inner = (-1..=1).all(|dy| {
            (-1..=1).all(|dx| {
                let (xx, yy) = (x + dx, y + dy);
                xx >= 0 && yy >= 0 && xx < w && yy < h && shows((yy * w + xx) as usize, o)
            })
        });
        total += 1;
        same += usize::from(ok);
        interior += usize::from(inner);
        interior_same += usize::from(inner && ok);
    }
    let share = |n: usize, d: usize| {
        if d == 0 {
            f64::NAN
        } else {
            n as f64 / d as f64
        }
    };
    SameObject {
        pixels: total,
        share: share(same, total),
        interior_pixels: interior,
        interior_share: share(interior_same, interior),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair() -> (Frame, Traced, Vec<Vec3>) {
        let mut f = Frame::new(4, 1);
        f.mask = vec![1, 1, 1, 0];
        f.hit_position = vec![
            Vec3::new(0.0, 0.0, -10.0),
            Vec3::new(1.0, 0.0, -10.0),
            Vec3::NAN,
            Vec3::NAN,
        ];
        f.colour = vec![Vec3::splat(0.5); 4];
        let t = Traced {
            width: 4,
            height: 1,
            colour: f.colour.clone(),
            mask: f.mask.clone(),
            hit_position: f.hit_position.clone(),
            resolved: vec![1; 4],
            triangle: Some(f.triangle.clone()),
            fallback: None,
            bounces: None,
        };
        (f, t, vec![Vec3::ZERO; 4])
    }

    #[test]
    fn identical_is_perfect() {
        let (f, t, m) = pair();
        let r = compare(&f, &t, &m, &[Vec3::ZERO], 64);
        assert_eq!(r.mirror_pixels, 3);
        assert_eq!((r.unresolved, r.wrong_surface), (0.0, 0.0));
        assert_eq!(r.angular_mean_deg, 0.0);
        assert!(r.psnr_db.is_infinite());
        assert!(r.psnr_frame_db.is_infinite());
        assert_eq!((r.mask_mismatch, r.error), (0, 0.0));
        assert_eq!(r, ErrorReport::exact(3));
    }

    /// A glossy scene's comparison by colour: identical frames are perfect and leave every hit
    /// figure unmeasured (NaN), even with hits that disagree. Negatives: a changed colour, a
    /// mirror pixel of one frame only and an unresolved pixel each show.
    #[test]
    fn colour_comparison_leaves_hits_out() {
        let (f, t, _) = pair();
        let r = compare_colour(&f, &t.colour, &t.mask, Some(&t.resolved));
        assert_eq!(
            (r.mirror_pixels, r.mask_mismatch, r.unresolved),
            (3, 0, 0.0)
        );
        assert!(r.psnr_db.is_infinite() && r.psnr_frame_db.is_infinite());
        for hit in [
            r.wrong_surface,
            r.error,
            r.angular_mean_deg,
            r.same_triangle,
        ] {
            assert!(hit.is_nan());
        }
        let mut colour = t.colour.clone();
        colour[1] = Vec3::splat(0.6);
        let changed = compare_colour(&f, &colour, &t.mask, None);
        assert!(changed.psnr_db.is_finite() && changed.psnr_db > 20.0);
        let mut mask = t.mask.clone();
        mask[3] = 1;
        let extra = compare_colour(&f, &t.colour, &mask, None);
        assert_eq!((extra.mirror_pixels, extra.mask_extra), (4, 1));
        let mut resolved = t.resolved.clone();
        resolved[2] = 0;
        let open = compare_colour(&f, &t.colour, &t.mask, Some(&resolved));
        assert_eq!(open.unresolved, 1.0 / 3.0);
        // Without the tracer's verdicts every pixel counts as resolved.
        assert_eq!(compare_colour(&f, &t.colour, &t.mask, None).unresolved, 0.0);
    }

    /// Wrong surfaces count only where the reference shows a non-reflector object: a wrong hit
    /// where the reference sees the mirror itself is left out, one on the room is counted.
    #[test]
    fn wrong_surface_off_reflector_leaves_self_reflections_out() {
        let (mut f, t, m) = pair();
        // Object 0 is the mirror, object 1 the room: pixel 0 sees the mirror, 1 and 2 the room.
        f.object_id = vec![0, 1, 1, NO_ID];
        let reflector = [true, false];
        let exact = classify(&f, &t, &m, &[Vec3::ZERO], 64);
        assert_eq!(wrong_surface_off_reflector(&f, &reflector, &exact), 0.0);
        // Negative: move the traced hits of pixels 0 and 1 far off: only pixel 1 counts.
        let mut moved = t.clone();
        moved.hit_position[0] = Vec3::new(50.0, 0.0, -10.0);
        moved.hit_position[1] = Vec3::new(-50.0, 0.0, -10.0);
        let wrong = classify(&f, &moved, &m, &[Vec3::ZERO], 64);
        assert_eq!(wrong[0].class, PixelClass::WrongSurface);
        assert_eq!(wrong[1].class, PixelClass::WrongSurface);
        assert_eq!(wrong_surface_off_reflector(&f, &reflector, &wrong), 0.5);
        // No pixel on a non-reflector: undefined.
        assert!(wrong_surface_off_reflector(&f, &[true, true], &wrong).is_nan());
    }

    /// A larger pair: a 16 x 8 frame whose left half is a mirror with varied hits and colours.
    fn big_pair() -> (Frame, Traced, Vec<Vec3>) {
        let (w, h) = (16u32, 8u32);
        let n = (w * h) as usize;
        let mut f = Frame::new(w, h);
        for k in 0..n {
            let (i, j) = (k as u32 % w, k as u32 / w);
            f.mask[k] = u8::from(i < w / 2);
            f.colour[k] = Vec3::new(i as f32 / w as f32, j as f32 / h as f32, 0.3);
            if f.mask[k] != 0 {
                f.hit_position[k] = Vec3::new(i as f32, j as f32, -10.0);
            }
        }
        let t = Traced {
            width: w,
            height: h,
            colour: f.colour.clone(),
            mask: f.mask.clone(),
            hit_position: f.hit_position.clone(),
            resolved: f.mask.clone(),
            triangle: None,
            fallback: None,
            bounces: None,
        };
        (f, t, vec![Vec3::ZERO; n])
    }

    fn report_of(f: &Frame, t: &Traced, m: &[Vec3]) -> ErrorReport {
        compare(f, t, m, &[Vec3::ZERO], 64)
    }

    /// The frames that used to pass as perfect: each must show as errors.
    #[test]
    fn blank_noise_and_mirrorless_frames_are_errors() {
        let (f, t, m) = big_pair();
        let good = report_of(&f, &t, &m);
        assert_eq!((good.error, good.mirror_pixels), (0.0, 64));
        assert!(good.psnr_db.is_infinite() && good.psnr_frame_db.is_infinite());

        // A frame without a mirror pixel (the method drew no mirror) and otherwise the right
        // colours: every mirror pixel of the reference is a mask mismatch.
        let mut none = t.clone();
        none.mask.fill(0);
        none.resolved.fill(0);
        none.hit_position.fill(Vec3::NAN);
        let r = report_of(&f, &none, &m);
        assert_eq!((r.mask_missed, r.mask_extra, r.mirror_pixels), (64, 0, 64));
        assert_eq!((r.error, r.mask_mismatch_fraction), (1.0, 1.0));
        assert!(r.angular_mean_deg.is_nan(), "no angle to measure, not 0");

        // A blank (black) frame.
        let mut blank = none.clone();
        blank.colour.fill(Vec3::ZERO);
        let r = report_of(&f, &blank, &m);
        assert_eq!(r.error, 1.0);
        assert!(r.psnr_db < 15.0 && r.psnr_frame_db < 15.0, "{r:?}");

        // Pure noise: random mask, colours and hits.
        let mut noise = t.clone();
        let mut x = 0x2545_f491u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as f32 / u32::MAX as f32
        };
        for k in 0..noise.mask.len() {
            noise.mask[k] = u8::from(next() < 0.5);
            noise.resolved[k] = noise.mask[k];
            noise.colour[k] = Vec3::new(next(), next(), next());
            noise.hit_position[k] = Vec3::new(next(), next(), next()) * 100.0;
        }
        let r = report_of(&f, &noise, &m);
        assert!(r.mask_missed > 0 && r.mask_extra > 0, "{r:?}");
        assert!(
            r.mirror_pixels > 64,
            "the union counts the method's mirror too: {r:?}"
        );
        assert!(r.error > 0.9, "{r:?}");
        assert!(r.psnr_db < 15.0 && r.psnr_frame_db < 15.0, "{r:?}");

        // A mirror where the reference has none, everything else right.
        let mut extra = t.clone();
        extra.mask[w_index(12, 3)] = 1;
        extra.resolved[w_index(12, 3)] = 1;
        let r = report_of(&f, &extra, &m);
        assert_eq!((r.mask_missed, r.mask_extra, r.mirror_pixels), (0, 1, 65));
        assert!((r.error - 1.0 / 65.0).abs() < 1e-12);

        // Neither frame has a mirror pixel: no mirror figure to give (NaN), not "perfect".
        let mut f0 = f.clone();
        f0.mask.fill(0);
        let r = report_of(&f0, &none, &m);
        assert_eq!((r.mirror_pixels, r.error), (0, 0.0));
        assert!(r.psnr_db.is_nan() && r.psnr_frame_db.is_infinite());
    }

    fn w_index(i: usize, j: usize) -> usize {
        j * 16 + i
    }

    #[test]
    fn whole_frame_psnr_sees_outside_the_mirror() {
        let (f, mut t, m) = big_pair();
        // Change a pixel outside the mirror: the mirror figures stay perfect, the frame's not.
        t.colour[w_index(12, 3)] = Vec3::ONE;
        let r = report_of(&f, &t, &m);
        assert!(r.psnr_db.is_infinite());
        assert!(
            r.psnr_frame_db.is_finite() && r.psnr_frame_db > 20.0,
            "{r:?}"
        );
        // Negative: the same change inside the mirror lowers both.
        let (f, mut t, m) = big_pair();
        t.colour[w_index(3, 3)] = Vec3::ONE;
        let r = report_of(&f, &t, &m);
        assert!(
            r.psnr_db.is_finite() && r.psnr_frame_db.is_finite(),
            "{r:?}"
        );
        assert!(r.psnr_db < r.psnr_frame_db);
    }

    #[test]
    fn perturbations_are_counted() {
        let (f, mut t, m) = pair();
        // 10 units from the centre, N = 64: a footprint is 0.3125; move one hit by 1.0.
        t.hit_position[0].x += 1.0;
        // A hit where the reference left the scene.
        t.hit_position[2] = Vec3::ONE;
        t.resolved[1] = 0;
        t.colour[0] = Vec3::splat(0.6);
        let r = compare(&f, &t, &m, &[Vec3::ZERO], 64);
        assert!((r.wrong_surface - 2.0 / 3.0).abs() < 1e-12);
        assert!((r.unresolved - 1.0 / 3.0).abs() < 1e-12);
        assert!(r.angular_mean_deg > 5.0);
        assert!((r.psnr_db - 10.0 * (1.0f64 / (0.03 / 9.0)).log10()).abs() < 1e-3);
        // Within the footprint: not wrong.
        let (f, mut t, m) = pair();
        t.hit_position[0].x += 0.5;
        let r = compare(&f, &t, &m, &[Vec3::ZERO], 64);
        assert_eq!(r.wrong_surface, 0.0);
    }

    #[test]
    fn small_angles_are_resolved() {
        // A hit 1e-4 degrees off as seen from the mirror point, 10 units away: f32 acos would
        // report 0 or about 0.03 degrees.
        let (f, mut t, m) = pair();
        let a = 1e-4f32.to_radians();
        t.hit_position[0] = Vec3::new(10.0 * a.sin(), 0.0, -10.0 * a.cos());
        let e = classify(&f, &t, &m, &[Vec3::ZERO], 64)[0];
        let got = e.angle_deg.unwrap();
        assert!((got - 1e-4).abs() < 1e-6, "{got}");
    }

    #[test]
    fn classify_names_each_pixel() {
        let (f, mut t, m) = pair();
        let ok = classify(&f, &t, &m, &[Vec3::ZERO], 64);
        let classes: Vec<_> = ok.iter().map(|p| p.class).collect();
        use PixelClass::*;
        assert_eq!(classes, [Correct, Correct, Correct, NotMirror]);
        assert_eq!(ok[0].angle_deg, Some(0.0));
        assert_eq!(ok[2].angle_deg, None);
        t.hit_position[0].x += 1.0;
        t.resolved[1] = 0;
        t.hit_position[2] = Vec3::ONE;
        t.mask[3] = 1;
        let bad = classify(&f, &t, &m, &[Vec3::ZERO], 64);
        let classes: Vec<_> = bad.iter().map(|p| p.class).collect();
        assert_eq!(classes, [WrongSurface, Unresolved, WrongSurface, MaskExtra]);
        assert!(bad[0].angle_deg.is_some_and(|a| a > 5.0));
        // A hit on the mirror point: wrong, and no angle (not NaN).
        let mut t = pair().1;
        t.hit_position[1] = m[1];
        let e = classify(&f, &t, &m, &[Vec3::ZERO], 64)[1];
        assert_eq!((e.class, e.angle_deg), (WrongSurface, None));
        let mut t = pair().1;
        t.mask[0] = 0;
        assert_eq!(classify(&f, &t, &m, &[Vec3::ZERO], 64)[0].class, MaskMissed);
    }

    /// A 16 x 8 pair whose reference carries triangle IDs; the traced frame's IDs are set per
    /// test.
    fn pair_with_ids() -> (Frame, Traced, Vec<Vec3>) {
        let (mut f, t, m) = big_pair();
        for k in 0..f.mask.len() {
            if f.mask[k] != 0 {
                f.triangle[k] = k as u32 * 7;
            }
        }
        (f, t, m)
    }

    #[test]
    fn same_triangle_and_resolved_psnr() {
        let (f, mut t, m) = pair_with_ids();
        // Without triangle IDs there is no figure, not 0 or 100 %.
        let r = report_of(&f, &t, &m);
        assert!(r.same_triangle.is_nan(), "{r:?}");
        assert!(r.psnr_resolved_db.is_infinite());
        t.triangle = Some(f.triangle.clone());
        let r = report_of(&f, &t, &m);
        assert_eq!(r.same_triangle, 1.0);
        // Negative: shifted IDs (every hit one triangle off) are 0 % the same.
        let mut shifted = t.clone();
        shifted.triangle = Some(
            f.triangle
                .iter()
                .map(|&i| if i == u32::MAX { i } else { i + 1 })
                .collect(),
        );
        assert_eq!(report_of(&f, &shifted, &m).same_triangle, 0.0);
        // Four wrong triangles, one unresolved pixel (left out of both figures) with a wrong
        // colour, one wrong colour on a resolved pixel.
        let mut four = t.clone();
        let ids = four.triangle.as_mut().unwrap();
        for k in [w_index(0, 0), w_index(1, 0), w_index(2, 0), w_index(3, 0)] {
            ids[k] = 3;
        }
        four.resolved[w_index(5, 5)] = 0;
        four.colour[w_index(5, 5)] = Vec3::ONE;
        let r = report_of(&f, &four, &m);
        assert!((r.same_triangle - 59.0 / 63.0).abs() < 1e-12, "{r:?}");
        assert!(
            r.psnr_resolved_db.is_infinite(),
            "the unresolved pixel is left out"
        );
        assert!(r.psnr_db.is_finite(), "but counts over all mirror pixels");
        four.colour[w_index(6, 5)] = Vec3::ONE;
        let r = report_of(&f, &four, &m);
        assert!(
            r.psnr_resolved_db.is_finite() && r.psnr_resolved_db > r.psnr_db,
            "{r:?}"
        );
        // Nothing resolved: no figure.
        let mut none = t.clone();
        none.resolved.fill(0);
        let r = report_of(&f, &none, &m);
        assert!(
            r.same_triangle.is_nan() && r.psnr_resolved_db.is_nan(),
            "{r:?}"
        );
    }

    #[test]
    fn psnr_over_the_mask_only() {
        let truth = vec![Vec3::splat(0.5); 4];
        let mut got = truth.clone();
        got[3] = Vec3::ONE; // outside the mask
        let mask = [1, 1, 1, 0];
        assert_eq!(psnr_over(&got, &truth, &mask), f64::INFINITY);
        // Negative: inside the mask, 0.1 off on one pixel of three: MSE 0.01 / 3.
        got[0] = Vec3::splat(0.6);
        let db = psnr_over(&got, &truth, &mask);
        assert!((db - 10.0 * (300.0f64).log10()).abs() < 1e-4, "{db}");
        assert!(psnr_over(&got, &truth, &[0; 4]).is_nan());
    }
}

#![forbid(unsafe_code)]
//! Error of a traced reflection against the exact reference, over mirror pixels.
//!
//! - **unresolved**: the tracer could not decide (no CMO saw the ray's surface) and a fallback
//!   filled the pixel.
//! - **wrong surface**: a resolved pixel whose hit point lies farther from the reference's than
//!   `WRONG_SURFACE_FOOTPRINTS` texel footprints, or that hit something where the reference's ray
//!   left the scene (or the reverse). A texel footprint at a point is its distance from the
//!   nearest CMO centre times `2 / N`, the angular size of a texel at the centre of a face of
//!   `N` texels (texels are smaller towards the face corners, so this is an upper bound).
//! - **angular error**: the angle between the traced and the reference hit points as seen from
//!   the mirror point, over pixels where both hit something.
//! - **PSNR**: over mirror pixels, on linear RGB clamped to [0, 1].

use glam::{DVec3, Vec3};

use crate::reference::Frame;

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
}

#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ErrorReport {
    pub mirror_pixels: usize,
    pub unresolved: f64,
    pub wrong_surface: f64,
    pub angular_mean_deg: f64,
    pub angular_p95_deg: f64,
    pub psnr_db: f64,
    /// Pixels where the masks of the two disagree (rasterisation edge differences).
    pub mask_mismatch: usize,
}

/// What one pixel of a traced frame is, against the reference ([`classify`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelClass {
    /// Not a mirror pixel of the reference: not counted.
    NotMirror,
    /// A mirror pixel of the reference that the traced frame's rasterisation missed: counted as
    /// a mirror pixel (its colour enters the PSNR) but neither unresolved nor wrong.
    MaskMissed,
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
                return verdict(PixelClass::NotMirror);
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

/// Compares `traced` with `reference` over the reference's mirror pixels. `mirror_point` gives
/// the primary hit on the mirror per pixel, `cmo_centres` and `cube_size` define the texel
/// footprint.
pub fn compare(
    reference: &Frame,
    traced: &Traced,
    mirror_point: &[Vec3],
    cmo_centres: &[Vec3],
    cube_size: u32,
) -> ErrorReport {
    let pixels = classify(reference, traced, mirror_point, cmo_centres, cube_size);
    let mut r = ErrorReport::default();
    let (mut unresolved, mut wrong, mut se) = (0usize, 0usize, 0f64);
    let mut angles = Vec::new();
    for (k, p) in pixels.iter().enumerate() {
        if reference.mask[k] != traced.mask[k] {
            r.mask_mismatch += 1;
        }
        if p.class == PixelClass::NotMirror {
            continue;
        }
        r.mirror_pixels += 1;
        let d = (reference.colour[k].clamp(Vec3::ZERO, Vec3::ONE)
            - traced.colour[k].clamp(Vec3::ZERO, Vec3::ONE))
        .as_dvec3();
        se += d.length_squared();
        match p.class {
            PixelClass::Unresolved => unresolved += 1,
            PixelClass::WrongSurface => wrong += 1,
            _ => {}
        }
        angles.extend(p.angle_deg);
    }
    let n = r.mirror_pixels.max(1) as f64;
    r.unresolved = unresolved as f64 / n;
    r.wrong_surface = wrong as f64 / n;
    let mse = se / (3.0 * n);
    r.psnr_db = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    };
    if !angles.is_empty() {
        r.angular_mean_deg = angles.iter().sum::<f64>() / angles.len() as f64;
        angles.sort_by(f64::total_cmp);
        r.angular_p95_deg = angles[((angles.len() - 1) as f64 * 0.95).round() as usize];
    }
    r
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
        assert_eq!(classes, [WrongSurface, Unresolved, WrongSurface, NotMirror]);
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
}

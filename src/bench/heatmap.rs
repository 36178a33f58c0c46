#![forbid(unsafe_code)]
//! Per-run error heat maps (8-bit RGB PNG, same size as the frame).
//!
//! Colour key:
//! - outside the reflector: the reference image, darkened to a quarter and grey;
//! - correct pixels: the angular error of the hit point on a logarithmic ramp from black
//!   (<= [`ANGLE_LO_DEG`]) through blue, green and yellow to red (>= [`ANGLE_HI_DEG`]);
//!   pixels where both rays left the scene are black;
//! - wrong surface: white; unresolved: magenta; mirror pixels the method's rasterisation missed:
//!   cyan; mirror pixels of the method where the reference has none: pink.

use std::path::Path;

use anyhow::Result;

use crate::metrics::{PixelClass, PixelError};
use crate::output::write_atomic;
use crate::reference::Frame;
use crate::shading::linear_to_srgb;

/// Angular errors at or below this are black.
pub const ANGLE_LO_DEG: f64 = 0.01;
/// Angular errors at or above this are red.
pub const ANGLE_HI_DEG: f64 = 10.0;

/// A mirror pixel of the reference that the method's rasterisation missed.
pub const MASK_MISSED: [u8; 3] = [0, 255, 255];
/// A mirror pixel of the method where the reference has none.
pub const MASK_EXTRA: [u8; 3] = [255, 128, 192];

/// The ramp colour of an angular error.
pub fn ramp(angle_deg: f64) -> [u8; 3] {
    let x = ((angle_deg.max(ANGLE_LO_DEG).log10() - ANGLE_LO_DEG.log10())
        / (ANGLE_HI_DEG.log10() - ANGLE_LO_DEG.log10()))
    .clamp(0.0, 1.0);
    // Black -> blue -> green -> yellow -> red, in four equal pieces.
    let stops: [[f64; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [0.0, 0.2, 1.0],
        [0.0, 0.9, 0.2],
        [1.0, 0.9, 0.0],
        [1.0, 0.0, 0.0],
    ];
    let f = x * 4.0;
    let i = (f.floor() as usize).min(3);
    let w = f - i as f64;
    let c = |k: usize| ((stops[i][k] * (1.0 - w) + stops[i + 1][k] * w) * 255.0).round() as u8;
    [c(0), c(1), c(2)]
}

/// The heat map's pixels, RGB8 row-major.
pub fn pixels(reference: &Frame, errors: &[PixelError]) -> Vec<u8> {
    errors
        .iter()
        .zip(&reference.colour)
        .flat_map(|(e, c)| match e.class {
            PixelClass::NotMirror => {
                let g = linear_to_srgb((c.x + c.y + c.z) / 3.0) / 4;
                [g, g, g]
            }
            PixelClass::MaskMissed => MASK_MISSED,
            PixelClass::MaskExtra => MASK_EXTRA,
            PixelClass::Unresolved => [255, 0, 255],
            PixelClass::WrongSurface => [255, 255, 255],
            PixelClass::Correct => e.angle_deg.map_or([0, 0, 0], ramp),
        })
        .collect()
}

/// Writes the heat map of one run to `path` (atomically).
pub fn write(path: &Path, reference: &Frame, errors: &[PixelError]) -> Result<()> {
    let rgb = pixels(reference, errors);
    let mut png = Vec::new();
    image::write_buffer_with_format(
        &mut std::io::Cursor::new(&mut png),
        &rgb,
        reference.width,
        reference.height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )?;
    write_atomic(path, &png)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_ends_and_order() {
        assert_eq!(ramp(0.0), [0, 0, 0]);
        assert_eq!(ramp(ANGLE_LO_DEG), [0, 0, 0]);
        assert_eq!(ramp(ANGLE_HI_DEG), [255, 0, 0]);
        assert_eq!(ramp(1e6), [255, 0, 0]);
        // Negative: something in between is neither end.
        let mid = ramp(0.3);
        assert_ne!(mid, [0, 0, 0]);
        assert_ne!(mid, [255, 0, 0]);
    }

    #[test]
    fn classes_have_their_colours() {
        let mut f = Frame::new(5, 1);
        f.mask = vec![1, 1, 0, 1, 0];
        let e = |class, angle_deg| PixelError { class, angle_deg };
        let errs = [
            e(PixelClass::Unresolved, None),
            e(PixelClass::WrongSurface, Some(3.0)),
            e(PixelClass::NotMirror, None),
            e(PixelClass::MaskMissed, None),
            e(PixelClass::MaskExtra, None),
        ];
        let p = pixels(&f, &errs);
        assert_eq!(&p[0..3], &[255, 0, 255]);
        assert_eq!(&p[3..6], &[255, 255, 255]);
        assert_ne!(&p[6..9], &[255, 255, 255]);
        assert_eq!(&p[9..12], &MASK_MISSED);
        assert_eq!(&p[12..15], &MASK_EXTRA);
        // Negative: the two mask colours differ from each other and from every other class.
        for c in [MASK_MISSED, MASK_EXTRA] {
            assert!(![[255, 0, 255], [255, 255, 255], [0, 0, 0]].contains(&c));
        }
        assert_ne!(MASK_MISSED, MASK_EXTRA);
    }
}

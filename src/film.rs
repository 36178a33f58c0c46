#![forbid(unsafe_code)]
//! The film: where a frame's samples sit inside each pixel and how they are filtered into the
//! pixel's value (`--spp`, `--filter`, the scene file's `[film]`).
//!
//! - **Samples.** A frame of `spp` samples per pixel is rendered `spp` times, each time with every
//!   pixel's sample at the same offset from its centre ([`crate::camera::Camera::jitter`]): one
//!   G-buffer raster and one trace per sample, one capture for the frame. The offsets
//!   ([`sample_offsets`]) are stratified and fixed (no seed, no clock): the pixel is cut into
//!   `nx x ny = spp` strata (`nx` the largest divisor of `spp` not above its square root) and
//!   stratum `(sx, sy)` holds its sample at `((sx + (sy + 1/2) / ny) / nx, (sy + (sx + 1/2) / nx)
//!   / ny)` of the pixel: each stratum one sample, and no two samples share a column or a row
//!   (Kensler's correlated multi-jitter without the shuffle), so edges of any slope get `spp`
//!   levels. One sample per pixel sits at the centre: `--spp 1` is the frame without samples,
//!   bit for bit.
//! - **Reconstruction** ([`Film`]), in linear f64, before the sRGB conversion and the EXR:
//!   [`PixelFilter::Box`] averages each pixel's own samples; [`PixelFilter::Gaussian`] is pbrt's
//!   Gaussian filter (radius 1.5 pixels, sigma 0.5: `g(d) = max(0, G(d) - G(1.5))` per axis,
//!   `G` the normal density), each sample splatted into the pixels within the radius and every
//!   pixel normalised by the sum of the weights it received.
//! - **AOVs** (mask, positions, hits, IDs, bounces, unresolved, fallback): a pixel's AOVs at
//!   `spp > 1` are those of one sample, the one nearest the pixel centre ([`aov_sample`]; the
//!   first of the nearest in sample order), never a blend: an ID names a triangle the pixel
//!   really shows. At one sample that is the only one.

use glam::{DVec3, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// The pixel reconstruction filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PixelFilter {
    /// Every sample of a pixel weighs the same; a sample counts for its own pixel only.
    #[default]
    Box,
    /// pbrt's Gaussian: a truncated Gaussian over a radius beyond the pixel.
    Gaussian,
}

/// Samples per pixel and their filter: the scene file's `[film]`, overridden by `--spp` and
/// `--filter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilmSettings {
    /// Samples per pixel, at least 1. 1 is one sample at each pixel centre, the frame without a
    /// film.
    pub spp: u32,
    pub filter: PixelFilter,
}

impl Default for FilmSettings {
    fn default() -> Self {
        FilmSettings {
            spp: 1,
            filter: PixelFilter::Box,
        }
    }
}

/// The most samples per pixel `--spp` and `[film] spp` take.
pub const MAX_SPP: u32 = 1024;

/// pbrt's Gaussian filter: radius (pixels) and standard deviation.
pub const GAUSSIAN_RADIUS: f64 = 1.5;
pub const GAUSSIAN_SIGMA: f64 = 0.5;

impl FilmSettings {
    /// The sample offsets of a frame ([`sample_offsets`]).
    pub fn offsets(&self) -> Vec<Vec2> {
        sample_offsets(self.spp)
    }
}

/// The strata `(nx, ny)` of `spp` samples: `nx` the largest divisor of `spp` with `nx^2 <= spp`.
pub fn strata(spp: u32) -> (u32, u32) {
    let spp = spp.max(1);
    let nx = (1..=spp)
        .take_while(|d| d * d <= spp)
        .filter(|d| spp.is_multiple_of(*d))
        .last()
        .unwrap_or(1);
    (nx, spp / nx)
}

/// The offsets from the pixel centre (pixels, in `(-1/2, 1/2)`) of the `spp` samples, in the
/// order they are rendered (module docs). `spp` 0 counts as 1.
pub fn sample_offsets(spp: u32) -> Vec<Vec2> {
    let (nx, ny) = strata(spp);
    let (fx, fy) = (f64::from(nx), f64::from(ny));
    let mut out = Vec::with_capacity((nx * ny) as usize);
    for sy in 0..ny {
        for sx in 0..nx {
            let x = (f64::from(sx) + (f64::from(sy) + 0.5) / fy) / fx;
            let y = (f64::from(sy) + (f64::from(sx) + 0.5) / fx) / fy;
            out.push(Vec2::new((x - 0.5) as f32, (y - 0.5) as f32));
        }
    }
    out
}

/// The sample whose AOVs a pixel keeps: the one nearest the pixel centre, the first of those.
pub fn aov_sample(offsets: &[Vec2]) -> usize {
    let mut best = 0;
    for (k, o) in offsets.iter().enumerate() {
        if o.length_squared() < offsets[best].length_squared() {
            best = k;
        }
    }
    best
}

/// pbrt's `Gaussian(x, 0, sigma)`: the normal density.
fn gaussian(x: f64, sigma: f64) -> f64 {
    (-x * x / (2.0 * sigma * sigma)).exp() / (2.0 * std::f64::consts::PI * sigma * sigma).sqrt()
}

impl PixelFilter {
    /// Radius of the filter's support, pixels.
    pub fn radius(self) -> f64 {
        match self {
            PixelFilter::Box => 0.5,
            PixelFilter::Gaussian => GAUSSIAN_RADIUS,
        }
    }

    /// The filter's weight of a sample `(dx, dy)` pixels from a pixel centre.
    pub fn weight(self, dx: f64, dy: f64) -> f64 {
        match self {
            // Half-open, so a sample exactly between two pixels counts once.
            PixelFilter::Box => {
                let inside = |d: f64| (-0.5..0.5).contains(&d);
                if inside(dx) && inside(dy) { 1.0 } else { 0.0 }
            }
            PixelFilter::Gaussian => {
                let g = |d: f64| {
                    if d.abs() >= GAUSSIAN_RADIUS {
                        0.0
                    } else {
                        (gaussian(d, GAUSSIAN_SIGMA) - gaussian(GAUSSIAN_RADIUS, GAUSSIAN_SIGMA))
                            .max(0.0)
                    }
                };
                g(dx) * g(dy)
            }
        }
    }
}

/// The weighted sums of a frame's samples ([`Film::add`]) and their reconstruction
/// ([`Film::resolve`]), in f64, in sample order (so the same samples give the same bits).
#[derive(Clone, Debug)]
pub struct Film {
    width: u32,
    height: u32,
    filter: PixelFilter,
    sum: Vec<DVec3>,
    weight: Vec<f64>,
    samples: u32,
}

impl Film {
    pub fn new(width: u32, height: u32, filter: PixelFilter) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            filter,
            sum: vec![DVec3::ZERO; n],
            weight: vec![0.0; n],
            samples: 0,
        }
    }

    /// Samples added so far.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Adds one sample of every pixel, each at `offset` from its pixel's centre: `colour` is the
    /// frame rendered with that jitter (row-major, row 0 at the top).
    pub fn add(&mut self, offset: Vec2, colour: &[Vec3]) {
        let (w, h) = (self.width as i64, self.height as i64);
        assert_eq!(
            colour.len(),
            self.sum.len(),
            "a sample of another frame size"
        );
        self.samples += 1;
        let o = offset.as_dvec2();
        // The neighbour offsets with a weight, and the weight (the same for every pixel).
        let reach = self.filter.radius().ceil() as i64 + 1;
        let mut taps = Vec::new();
        for dj in -reach..=reach {
            for di in -reach..=reach {
                // The sample of pixel (i, j) seen from pixel (i + di, j + dj)'s centre.
                let wgt = self.filter.weight(o.x - di as f64, o.y - dj as f64);
                if wgt > 0.0 {
                    taps.push((di, dj, wgt));
                }
            }
        }
        for j in 0..h {
            for i in 0..w {
                let c = colour[(j * w + i) as usize].as_dvec3();
                for &(di, dj, wgt) in &taps {
                    let (x, y) = (i + di, j + dj);
                    if x >= 0 && y >= 0 && x < w && y < h {
                        let k = (y * w + x) as usize;
                        self.sum[k] += c * wgt;
                        self.weight[k] += wgt;
                    }
                }
            }
        }
    }

    /// The reconstructed frame: each pixel's weighted sum over its weight (black where no
    /// sample reached it).
    pub fn resolve(&self) -> Vec<Vec3> {
        self.sum
            .iter()
            .zip(&self.weight)
            .map(|(s, &w)| {
                if w > 0.0 {
                    (*s / w).as_vec3()
                } else {
                    Vec3::ZERO
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One sample sits at the centre; every stratum holds one sample, in `(-1/2, 1/2)`, and no
    /// two share a column or a row. Negative: a grid of stratum centres shares columns.
    #[test]
    fn offsets_are_stratified() {
        assert_eq!(sample_offsets(1), vec![Vec2::ZERO]);
        for spp in [2u32, 3, 4, 6, 8, 9, 16, 25, 64] {
            let o = sample_offsets(spp);
            assert_eq!(o.len(), spp as usize);
            let (nx, ny) = strata(spp);
            assert_eq!(nx * ny, spp);
            let mut strata_hit = vec![0; spp as usize];
            for p in &o {
                assert!(p.x > -0.5 && p.x < 0.5 && p.y > -0.5 && p.y < 0.5, "{p}");
                let sx = ((p.x + 0.5) * nx as f32).floor() as u32;
                let sy = ((p.y + 0.5) * ny as f32).floor() as u32;
                strata_hit[(sy * nx + sx) as usize] += 1;
            }
            assert!(strata_hit.iter().all(|&c| c == 1), "{spp}: {strata_hit:?}");
            let distinct = |v: Vec<f32>| {
                let mut v = v;
                v.sort_by(f32::total_cmp);
                v.windows(2).all(|w| w[1] - w[0] > 0.5 / spp as f32)
            };
            assert!(distinct(o.iter().map(|p| p.x).collect()), "{spp} x");
            assert!(distinct(o.iter().map(|p| p.y).collect()), "{spp} y");
        }
        // Negative: the stratum centres of a 4x4 grid repeat their columns.
        let grid: Vec<f32> = (0..16)
            .map(|k| ((k % 4) as f32 + 0.5) / 4.0 - 0.5)
            .collect();
        let mut g = grid.clone();
        g.sort_by(f32::total_cmp);
        assert!(g.windows(2).any(|w| w[1] - w[0] < 1e-6));
        // Deterministic: the same every call.
        assert_eq!(sample_offsets(16), sample_offsets(16));
    }

    /// The AOV sample is the one nearest the centre; at one sample, the only one.
    #[test]
    fn aov_sample_is_nearest_the_centre() {
        assert_eq!(aov_sample(&sample_offsets(1)), 0);
        let o = sample_offsets(9);
        let k = aov_sample(&o);
        assert_eq!(
            o[k],
            Vec2::ZERO,
            "the centre stratum of 3x3 holds the centre"
        );
        let o = [
            Vec2::new(0.4, 0.0),
            Vec2::new(0.1, -0.1),
            Vec2::new(-0.1, 0.1),
        ];
        assert_eq!(aov_sample(&o), 1);
    }

    /// pbrt's Gaussian at radius 1.5, sigma 0.5, computed here from its formula: at the centre,
    /// at 1 pixel, zero from the radius on; separable. Negative: sigma 1 gives other weights.
    #[test]
    fn gaussian_weights_are_pbrts() {
        let pdf = |x: f64, s: f64| {
            (-x * x / (2.0 * s * s)).exp() / (2.0 * std::f64::consts::PI).sqrt() / s
        };
        let g = |x: f64| (pdf(x, 0.5) - pdf(1.5, 0.5)).max(0.0);
        let f = PixelFilter::Gaussian;
        for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.3, -0.7), (1.2, 1.4)] {
            let want = g(dx) * g(dy);
            assert!((f.weight(dx, dy) - want).abs() < 1e-12, "{dx},{dy}");
        }
        assert_eq!(f.weight(1.5, 0.0), 0.0);
        assert_eq!(f.weight(0.0, -1.6), 0.0);
        let wrong = (pdf(1.0, 1.0) - pdf(1.5, 1.0)) * (pdf(0.0, 1.0) - pdf(1.5, 1.0));
        assert!((f.weight(1.0, 0.0) - wrong).abs() > 1e-3);
    }

    /// Normalised: a constant frame resolves to that constant in every pixel, the borders too
    /// (fewer samples reach them), for both filters and several sample counts. Negative: the
    /// raw weighted sums (no division) are not the constant.
    #[test]
    fn filters_normalise() {
        let (w, h) = (7, 5);
        let c = Vec3::new(0.25, 0.5, 2.0);
        for filter in [PixelFilter::Box, PixelFilter::Gaussian] {
            for spp in [1, 4, 6, 16] {
                let mut film = Film::new(w, h, filter);
                for o in sample_offsets(spp) {
                    film.add(o, &vec![c; (w * h) as usize]);
                }
                for p in film.resolve() {
                    assert!((p - c).abs().max_element() < 1e-6, "{filter:?} {spp}: {p}");
                }
                if (filter, spp) != (PixelFilter::Box, 1) {
                    let raw = film.sum[0].as_vec3();
                    assert!((raw - c).abs().max_element() > 1e-3, "{filter:?} {spp}");
                }
            }
        }
    }

    /// The box filter of N samples is each pixel's mean of its N samples, computed here on its
    /// own; the Gaussian blends neighbours (a single bright pixel spreads). Negative: the mean
    /// of another sample set differs.
    #[test]
    fn box_is_the_mean_and_gaussian_spreads() {
        let (w, h) = (4u32, 3u32);
        let n = (w * h) as usize;
        let offsets = sample_offsets(4);
        let frames: Vec<Vec<Vec3>> = (0..4)
            .map(|s| {
                (0..n)
                    .map(|k| Vec3::splat((k * 7 + s * 3) as f32 % 5.0))
                    .collect()
            })
            .collect();
        let mut film = Film::new(w, h, PixelFilter::Box);
        for (o, f) in offsets.iter().zip(&frames) {
            film.add(*o, f);
        }
        let got = film.resolve();
        for k in 0..n {
            let mean = frames.iter().map(|f| f[k]).sum::<Vec3>() / 4.0;
            assert!((got[k] - mean).abs().max_element() < 1e-6, "pixel {k}");
        }
        let other: Vec3 = frames[..3].iter().map(|f| f[5]).sum::<Vec3>() / 3.0;
        assert!((got[5] - other).abs().max_element() > 1e-3);
        let mut spot = vec![Vec3::ZERO; n];
        spot[5] = Vec3::ONE;
        let mut g = Film::new(w, h, PixelFilter::Gaussian);
        g.add(Vec2::ZERO, &spot);
        let r = g.resolve();
        assert!(r[4].x > 0.0 && r[6].x > 0.0 && r[1].x > 0.0 && r[5].x < 1.0);
        let mut b = Film::new(w, h, PixelFilter::Box);
        b.add(Vec2::ZERO, &spot);
        assert_eq!(b.resolve()[4], Vec3::ZERO);
    }
}

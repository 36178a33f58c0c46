#![forbid(unsafe_code)]
//! The film: where a frame's samples sit inside each pixel and how they are filtered into the
//! pixel's value (`--spp`, `--filter`, the scene file's `[film]`).
//!
//! (Skeleton: the sample pattern and the reconstruction are filled in by the anti-aliasing
//! work of issue 23.)

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
    /// Samples per pixel, at least 1. 1 is today's frame, one sample at each pixel centre.
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

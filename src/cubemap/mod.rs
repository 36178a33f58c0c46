#![forbid(unsafe_code)]
//! Cube maps as plain data, their face mapping, cell frusta and distance hierarchies (no GPU).
//!
//! Invariants:
//! - Face order, `(s, t)` and texel addressing: [`face`] (Vulkan's cube map face selection).
//! - `distance` holds f32 **world distances from the CMO centre** (not depth-buffer depth), one
//!   per texel, `+inf` where nothing was captured. Index `(face * N + y) * N + x`.
//! - [`frustum`] gives the `t` interval of a ray segment in a cell's frustum; [`pyramid`] the
//!   `[min, max]` hierarchies (2x2 mips and the alternating 8x4/4x8 one).

pub mod bounds;
pub mod face;
pub mod frustum;
pub mod pyramid;
pub mod texel_cone;

use glam::Vec3;

pub use face::Texel;

/// One cubemap object's capture: distance (and colour) per texel of six `N x N` faces.
#[derive(Debug, Clone, PartialEq)]
pub struct CubeMap {
    /// Face size N in texels (any N >= 1).
    pub size: u32,
    /// CMO centre in world coordinates.
    pub centre: Vec3,
    /// `6 N N` world distances from `centre`, face-major, row-major; `+inf` where empty.
    pub distance: Vec<f32>,
    /// `6 N N` linear RGBA colours, same layout.
    pub colour: Vec<[f32; 4]>,
    /// `6 N N` global triangle indices (the triangle each texel's centre ray sees), same
    /// layout; `u32::MAX` where empty or not captured.
    pub triangle: Vec<u32>,
}

impl CubeMap {
    /// An empty cube map (every distance `+inf`, colour transparent black).
    pub fn new(size: u32, centre: Vec3) -> CubeMap {
        assert!(size >= 1, "cube size must be at least 1");
        let n = 6 * size as usize * size as usize;
        CubeMap {
            size,
            centre,
            distance: vec![f32::INFINITY; n],
            colour: vec![[0.0; 4]; n],
            triangle: vec![u32::MAX; n],
        }
    }

    /// Fills every texel from a function of the texel and its centre direction (CMO-local,
    /// normalised): returns `(distance, colour)`. Used by tests and synthetic captures.
    pub fn fill(&mut self, mut f: impl FnMut(Texel, Vec3) -> (f32, [f32; 4])) {
        for i in 0..self.distance.len() {
            let t = Texel::from_index(i, self.size);
            let dir = face::texel_centre_dir(t, self.size).normalize();
            let (d, c) = f(t, dir);
            self.distance[i] = d;
            self.colour[i] = c;
        }
    }

    /// Distance stored for a texel.
    pub fn distance_at(&self, t: Texel) -> f32 {
        self.distance[t.index(self.size)]
    }

    /// Smallest stored distance (`+inf` if none).
    pub fn min_distance(&self) -> f32 {
        self.distance.iter().copied().fold(f32::INFINITY, f32::min)
    }
}

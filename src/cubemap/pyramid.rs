//! `[min, max]` distance hierarchies per face.
//!
//! Both hierarchies are a list of levels; level 0 is the texels themselves (`min = max = D`,
//! `+inf` texels are `[+inf, +inf]`), and a cell of level `l` covers a `gx x gy` block of level
//! `l - 1` cells. Blocks reaching past the edge of the lower level are padded with empty cells
//! (`min = +inf`, `max = -inf`), so any N works and every cell is conservative by construction
//! (it is the exact min/max over the texels it covers, see the tests).
//!
//! Storage per level: `6 * width * height` entries `[min, max]`, face-major, row-major (row 0 at
//! `t = 0`), like the texels.
//!
//! - [`MipPyramid`] (fragment path, thesis alg. 2/4): `gx = gy = 2` at every level, until one
//!   cell covers the face.
//! - [`Hier32`] (compute path, thesis alg. 3, ALGORITHM.md "The 32-cell hierarchy"): built bottom
//!   up with blocks of **4 wide x 8 high** (level 1 from texels), then **8 wide x 4 high**
//!   (level 2), alternating, until a level has at most 32 cells per face; that level is the
//!   root. For N = 1024: 256x128 cells of 4x8 texels, 32x32 of 32x32, 8x4 of 128x256 (root).
//!   Seen from the top, a cell's children are 4x8 below an 8x4-block level and 8x4 below a
//!   4x8-block level, i.e. 32 children per cell, child `j` at `(j % gx, j / gx)`. For N <= 4 the
//!   texels themselves are the root.

use super::CubeMap;
use super::face::FACE_COUNT;
use super::frustum::CellRect;

/// An empty cell: no texel below it.
pub const EMPTY_CELL: [f32; 2] = [f32::INFINITY, f32::NEG_INFINITY];

/// One level of a hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct MinMaxLevel {
    /// Cells per row.
    pub width: u32,
    /// Cells per column.
    pub height: u32,
    /// Block of lower-level cells per cell (`(1, 1)` at level 0).
    pub group: (u32, u32),
    /// Texels per cell along x and y (`span.0 = product of the gx below`).
    pub span: (u32, u32),
    /// `6 * width * height` cells `[min, max]`.
    pub cells: Vec<[f32; 2]>,
}

impl MinMaxLevel {
    /// `[min, max]` of cell `(x, y)` on `face`.
    pub fn get(&self, face: u32, x: u32, y: u32) -> [f32; 2] {
        self.cells[((face * self.height + y) * self.width + x) as usize]
    }

    /// The texels a cell covers, clamped to the face (empty for padding cells).
    pub fn rect(&self, face: u32, x: u32, y: u32, size: u32) -> CellRect {
        CellRect {
            face,
            x0: (x * self.span.0).min(size),
            x1: ((x + 1) * self.span.0).min(size),
            y0: (y * self.span.1).min(size),
            y1: ((y + 1) * self.span.1).min(size),
            size,
        }
    }
}

fn texel_level(cube: &CubeMap) -> MinMaxLevel {
    MinMaxLevel {
        width: cube.size,
        height: cube.size,
        group: (1, 1),
        span: (1, 1),
        cells: cube.distance.iter().map(|&d| [d, d]).collect(),
    }
}

/// The texel level of `cells` given as pairs (`6 N N`, the texels' order).
fn cell_level(size: u32, cells: Vec<[f32; 2]>) -> MinMaxLevel {
    assert_eq!(cells.len(), (FACE_COUNT * size * size) as usize);
    MinMaxLevel {
        width: size,
        height: size,
        group: (1, 1),
        span: (1, 1),
        cells,
    }
}

/// Reduces `lower` by blocks of `gx x gy`; out-of-range children are empty.
fn reduce(lower: &MinMaxLevel, gx: u32, gy: u32) -> MinMaxLevel {
    let width = lower.width.div_ceil(gx);
    let height = lower.height.div_ceil(gy);
    let mut cells = vec![EMPTY_CELL; (FACE_COUNT * width * height) as usize];
    for face in 0..FACE_COUNT {
        for y in 0..height {
            for x in 0..width {
                let mut mm = EMPTY_CELL;
                for cy in y * gy..(y + 1) * gy {
                    for cx in x * gx..(x + 1) * gx {
                        if cx < lower.width && cy < lower.height {
                            let c = lower.get(face, cx, cy);
                            mm[0] = mm[0].min(c[0]);
                            mm[1] = mm[1].max(c[1]);
                        }
                    }
                }
                cells[((face * height + y) * width + x) as usize] = mm;
            }
        }
    }
    MinMaxLevel {
        width,
        height,
        group: (gx, gy),
        span: (lower.span.0 * gx, lower.span.1 * gy),
        cells,
    }
}

/// The 2x2 `[min, max]` mip pyramid: `levels[0]` texels, `levels.last()` one cell per face.
#[derive(Debug, Clone, PartialEq)]
pub struct MipPyramid {
    /// Face size N.
    pub size: u32,
    /// Levels, finest first.
    pub levels: Vec<MinMaxLevel>,
}

impl MipPyramid {
    /// Builds the pyramid from a capture.
    pub fn build(cube: &CubeMap) -> MipPyramid {
        MipPyramid::from_texels(cube.size, texel_level(cube))
    }

    /// The pyramid over texel cells given as `[x, y]` pairs (`6 N N`, the texels' order):
    /// each level keeps the min of `x` and the max of `y` over its 2x2 block (the bounded
    /// criterion's gaps, [`crate::cubemap::bounds::TexelLists::gaps`], are such pairs).
    pub fn over_cells(size: u32, cells: Vec<[f32; 2]>) -> MipPyramid {
        MipPyramid::from_texels(size, cell_level(size, cells))
    }

    fn from_texels(size: u32, texels: MinMaxLevel) -> MipPyramid {
        let mut levels = vec![texels];
        while levels.last().is_some_and(|l| l.width > 1 || l.height > 1) {
            let next = reduce(levels.last().expect("non-empty"), 2, 2);
            levels.push(next);
        }
        MipPyramid { size, levels }
    }
}

/// Where one level of a flattened hierarchy lives in a GPU buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FlatLevel {
    /// First cell of the level (in cells, not bytes).
    pub offset: u32,
    /// Cells per row.
    pub width: u32,
    /// Cells per column.
    pub height: u32,
}

/// The GPU buffer layout of a 2x2 mip pyramid for face size `size`: levels 1.. (level 0, the
/// texels, is the distance buffer itself), each `6 * width * height` cells `[min, max]`,
/// face-major and row-major, concatenated finest first. Level `l` is `ceil(N / 2^l)` wide.
pub fn mip_flat_layout(size: u32) -> Vec<FlatLevel> {
    let mut out = Vec::new();
    let (mut w, mut h, mut offset) = (size, size, 0u32);
    while w > 1 || h > 1 {
        w = w.div_ceil(2);
        h = h.div_ceil(2);
        out.push(FlatLevel {
            offset,
            width: w,
            height: h,
        });
        offset += FACE_COUNT * w * h;
    }
    out
}

/// Cells per CMO in the flattened 2x2 pyramid of face size `size`: the length of
/// [`MipPyramid::flatten`] and the stride of CMO blocks in the GPU buffer `cmo_mip`
/// (0 for `size == 1`, whose only level is the texels).
pub fn mip_len(size: u32) -> usize {
    mip_flat_layout(size)
        .last()
        .map_or(0, |l| (l.offset + FACE_COUNT * l.width * l.height) as usize)
}

impl MipPyramid {
    /// Levels 1.. concatenated in the [`mip_flat_layout`] order: what the GPU pyramid pass
    /// writes and the fragment tracer reads.
    pub fn flatten(&self) -> Vec<[f32; 2]> {
        self.levels[1..]
            .iter()
            .flat_map(|l| l.cells.iter().copied())
            .collect()
    }
}

/// Maximum number of levels of a [`Hier32`] (N = 2048 needs 5; texels included).
pub const HIER_MAX_LEVELS: usize = 8;

/// The alternating 4x8 / 8x4 hierarchy (see module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Hier32 {
    /// Face size N.
    pub size: u32,
    /// Levels, texels first; the last one (the root) has at most 32 cells per face.
    pub levels: Vec<MinMaxLevel>,
}

/// Block shape used to build level `l >= 1` of a [`Hier32`] from level `l - 1`: 4 wide x 8 high
/// for odd `l`, 8 x 4 for even `l`.
pub fn hier32_group(level: usize) -> (u32, u32) {
    if !level.is_multiple_of(2) {
        (4, 8)
    } else {
        (8, 4)
    }
}

/// `(width, height)` per level of the [`Hier32`] of a face of size `size`, texels first.
pub fn hier32_layout(size: u32) -> Vec<(u32, u32)> {
    let mut dims = vec![(size, size)];
    while let Some(&(w, h)) = dims.last() {
        if w * h <= 32 {
            break;
        }
        let (gx, gy) = hier32_group(dims.len());
        dims.push((w.div_ceil(gx), h.div_ceil(gy)));
    }
    dims
}

impl Hier32 {
    /// Builds the hierarchy from a capture.
    pub fn build(cube: &CubeMap) -> Hier32 {
        Hier32::from_texels(cube.size, texel_level(cube))
    }

    /// The hierarchy over texel cells given as `[x, y]` pairs, as
    /// [`MipPyramid::over_cells`]: a cell keeps the min of `x` and the max of `y`.
    pub fn over_cells(size: u32, cells: Vec<[f32; 2]>) -> Hier32 {
        Hier32::from_texels(size, cell_level(size, cells))
    }

    fn from_texels(size: u32, texels: MinMaxLevel) -> Hier32 {
        let layout = hier32_layout(size);
        assert!(
            layout.len() <= HIER_MAX_LEVELS,
            "cube size too large for the hierarchy"
        );
        let mut levels = vec![texels];
        for l in 1..layout.len() {
            let (gx, gy) = hier32_group(l);
            let next = reduce(&levels[l - 1], gx, gy);
            levels.push(next);
        }
        Hier32 { size, levels }
    }

    /// Index of the root level.
    pub fn root(&self) -> usize {
        self.levels.len() - 1
    }

    /// Levels 1.. concatenated in the [`hier32_flat_layout`] order: what the GPU `hier32` pass
    /// writes and the compute tracer reads.
    pub fn flatten(&self) -> Vec<[f32; 2]> {
        self.levels[1..]
            .iter()
            .flat_map(|l| l.cells.iter().copied())
            .collect()
    }
}

/// The GPU buffer layout of a [`Hier32`] for face size `size`: levels 1.. (level 0, the texels,
/// is the distance buffer itself) with the [`hier32_layout`] dimensions, each `6 * width *
/// height` cells `[min, max]`, face-major and row-major, concatenated finest first. Empty for
/// `size <= 4` (the texels are the root).
pub fn hier32_flat_layout(size: u32) -> Vec<FlatLevel> {
    let mut offset = 0u32;
    hier32_layout(size)
        .into_iter()
        .skip(1)
        .map(|(width, height)| {
            let l = FlatLevel {
                offset,
                width,
                height,
            };
            offset += FACE_COUNT * width * height;
            l
        })
        .collect()
}

/// Cells per CMO in the flattened [`Hier32`] of face size `size`: the length of
/// [`Hier32::flatten`] and the stride of CMO blocks in the GPU buffer `cmo_hier` (0 for
/// `size <= 4`).
pub fn hier32_len(size: u32) -> usize {
    hier32_flat_layout(size)
        .last()
        .map_or(0, |l| (l.offset + FACE_COUNT * l.width * l.height) as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn cube(size: u32, seed: u64) -> CubeMap {
        let mut c = CubeMap::new(size, Vec3::ZERO);
        let mut s = seed;
        c.fill(|_, _| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let v = (s >> 40) as f32 / 1024.0;
            (
                if (s >> 20).is_multiple_of(13) {
                    f32::INFINITY
                } else {
                    v
                },
                [0.0; 4],
            )
        });
        c
    }

    fn brute(cube: &CubeMap, r: &CellRect) -> [f32; 2] {
        let mut mm = EMPTY_CELL;
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let d = cube.distance[((r.face * cube.size + y) * cube.size + x) as usize];
                mm = [mm[0].min(d), mm[1].max(d)];
            }
        }
        mm
    }

    fn check(cube: &CubeMap, levels: &[MinMaxLevel]) {
        for l in levels {
            for f in 0..6 {
                for y in 0..l.height {
                    for x in 0..l.width {
                        assert_eq!(l.get(f, x, y), brute(cube, &l.rect(f, x, y, cube.size)));
                    }
                }
            }
        }
    }

    #[test]
    fn every_cell_matches_brute_force() {
        for size in [1u32, 2, 3, 5, 8, 16, 32, 33, 64] {
            let c = cube(size, size as u64);
            check(&c, &MipPyramid::build(&c).levels);
            let h = Hier32::build(&c);
            check(&c, &h.levels);
            let root = &h.levels[h.root()];
            assert!(root.width * root.height <= 32);
        }
    }

    #[test]
    fn brute_force_check_detects_a_wrong_cell() {
        let c = cube(16, 3);
        let mut h = Hier32::build(&c);
        h.levels[1].cells[5][0] -= 1.0;
        let r = std::panic::catch_unwind(|| check(&c, &h.levels));
        assert!(r.is_err());
    }

    #[test]
    fn layouts() {
        let sizes = hier32_layout;
        assert_eq!(
            sizes(1024),
            vec![(1024, 1024), (256, 128), (32, 32), (8, 4)]
        );
        assert_eq!(
            sizes(2048),
            vec![(2048, 2048), (512, 256), (64, 64), (16, 8), (2, 2)]
        );
        assert_eq!(sizes(32), vec![(32, 32), (8, 4)]);
        assert_eq!(sizes(4), vec![(4, 4)]);
        assert_eq!(sizes(1), vec![(1, 1)]);
        let c = CubeMap::new(128, Vec3::ZERO);
        let h = Hier32::build(&c);
        assert_eq!(
            h.levels.iter().map(|l| l.span).collect::<Vec<_>>(),
            vec![(1, 1), (4, 8), (32, 32)]
        );
        let m = MipPyramid::build(&CubeMap::new(3, Vec3::ZERO));
        assert_eq!(
            m.levels.iter().map(|l| l.width).collect::<Vec<_>>(),
            vec![3, 2, 1]
        );
    }
}

#[cfg(test)]
mod flat_tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn flat_layout_matches_levels() {
        for size in [1u32, 2, 3, 5, 16, 33] {
            let mut cube = CubeMap::new(size, Vec3::ZERO);
            cube.fill(|t, _| ((t.index(size) % 7) as f32 + 1.0, [0.0; 4]));
            let p = MipPyramid::build(&cube);
            let layout = mip_flat_layout(size);
            assert_eq!(layout.len(), p.levels.len() - 1);
            let flat = p.flatten();
            assert_eq!(flat.len(), mip_len(size));
            for (l, fl) in layout.iter().enumerate() {
                let level = &p.levels[l + 1];
                assert_eq!((fl.width, fl.height), (level.width, level.height));
                for face in 0..FACE_COUNT {
                    for y in 0..fl.height {
                        for x in 0..fl.width {
                            let i = fl.offset + (face * fl.height + y) * fl.width + x;
                            assert_eq!(flat[i as usize], level.get(face, x, y));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn hier32_flat_layout_matches_levels() {
        for size in [1u32, 4, 5, 32, 33, 100, 128] {
            let mut cube = CubeMap::new(size, Vec3::ZERO);
            cube.fill(|t, _| ((t.index(size) % 7) as f32 + 1.0, [0.0; 4]));
            let h = Hier32::build(&cube);
            let layout = hier32_flat_layout(size);
            assert_eq!(layout.len(), h.levels.len() - 1);
            let flat = h.flatten();
            assert_eq!(flat.len(), hier32_len(size));
            for (l, fl) in layout.iter().enumerate() {
                let level = &h.levels[l + 1];
                assert_eq!((fl.width, fl.height), (level.width, level.height));
                for face in 0..FACE_COUNT {
                    for y in 0..fl.height {
                        for x in 0..fl.width {
                            let i = fl.offset + (face * fl.height + y) * fl.width + x;
                            assert_eq!(flat[i as usize], level.get(face, x, y));
                        }
                    }
                }
            }
        }
    }
}

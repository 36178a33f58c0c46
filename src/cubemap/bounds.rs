//! Sound per-texel bounds and candidate lists (issue 22): what a CMO holds for the `bounded`
//! criterion ([`crate::cpu::bounded`]).
//!
//! A texel's frustum is the cone of directions through its square on the face. For every
//! triangle that touches that cone (dilated, see the capture), the texel keeps an entry
//! `(triangle, lo, hi)`: `lo` a lower and `hi` an upper bound of the distance from the CMO centre
//! over the part of the triangle inside the cone. Per texel:
//! - `entries`: the `depth` entries with the smallest `(lo, triangle)`, in that order;
//! - `complete_to`: every triangle touching the texel whose entry was dropped (list deeper than
//!   `depth`, or the GPU's node pool full) has `lo >= complete_to`; `+inf` when none was dropped;
//! - `lo`: `min(first entry's lo, complete_to)` (`+inf` for an empty texel): no surface point in
//!   the cone is nearer. This is what the CMO's distance (and so its pyramids) holds.
//! - `hi`: the largest kept `hi` when nothing was dropped, `+inf` when something was, `-inf`
//!   for an empty texel.

use super::face::Texel;

/// Entries kept per texel by default.
pub const DEFAULT_DEPTH: u32 = 16;

/// One candidate of a texel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    /// Global triangle index ([`crate::scene::WorldGeometry::triangles`] order).
    pub triangle: u32,
    /// Lower bound of the triangle's distance from the centre inside the texel's cone.
    pub lo: f32,
    /// Upper bound of the same.
    pub hi: f32,
}

/// One CMO's per-texel bounds and candidate lists (module docs). Texel order: [`Texel::index`].
#[derive(Debug, Clone, PartialEq)]
pub struct TexelLists {
    /// Face size N.
    pub size: u32,
    /// Entries kept per texel.
    pub depth: u32,
    /// Per texel: lower bound over everything in the cone.
    pub lo: Vec<f32>,
    /// Per texel: upper bound over what the list holds (`+inf` when incomplete).
    pub hi: Vec<f32>,
    /// Per texel: the distance from which the list may be incomplete.
    pub complete_to: Vec<f32>,
    /// Per texel `i`, its entries are `entries[offsets[i]..offsets[i + 1]]`.
    pub offsets: Vec<u32>,
    /// The kept entries, texel by texel, each texel's sorted by `(lo, triangle)`.
    pub entries: Vec<Entry>,
}

impl TexelLists {
    /// The kept entries of a texel.
    pub fn entries_at(&self, t: Texel) -> &[Entry] {
        let i = t.index(self.size);
        &self.entries[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// `(lo, hi, complete_to)` of a texel.
    pub fn bounds_at(&self, t: Texel) -> (f32, f32, f32) {
        let i = t.index(self.size);
        (self.lo[i], self.hi[i], self.complete_to[i])
    }
}

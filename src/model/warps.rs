//! Warps as a GPU forms them: which rays (or pixels) share a warp.
//!
//! # Assumptions (vendors document none of this)
//! - **Queue order** (compute, bvh): a warp holds consecutive queue entries (the 32x8 dispatch
//!   of compute_trace takes `rays_per_group` consecutive rays per workgroup, subgroup after
//!   subgroup). The queue is the mirror pixels in row-major order ([`super::work::frame`]): the
//!   order the CPU twins use; a GPU's append pass writes a warp's rays together but the warps
//!   in any order, which this model does not see.
//! - **Quads** (fragment): the full-screen pass shades 2x2 quads; quads are taken in 8x4-pixel
//!   tiles, tiles row-major over the image, quads row-major within a tile, and `width / 4`
//!   consecutive quads form a warp. A quad's pixel outside the image is a helper lane; a pixel
//!   that is not a mirror is a real lane that leaves after `mirror_ray`.
//! - **Random** (the negative of the tests): the queue shuffled by a fixed-seed generator, so
//!   that a warp's rays are unrelated; a deliberately wrong assembly.
//!
//! # Where it stops
//! On a GPU, warp scheduling, occupancy and the order in which warps run are not modelled: only
//! which lanes run in lockstep. On lavapipe, which thread runs which warps is ([`Items`],
//! [`warp_items`]: its workgroups and rasteriser bins).
#![forbid(unsafe_code)]

/// One lane of a warp.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lane {
    /// Ray `i` of the frame's queue.
    Ray(usize),
    /// A pixel that runs the set-up and leaves (not a mirror pixel).
    Idle,
    /// A helper lane (outside the image): issued, never active.
    Helper,
    /// No invocation (the last warp's tail).
    Empty,
}

/// How lanes are assembled into warps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Assembly {
    /// Consecutive queue entries (compute, bvh).
    Queue,
    /// 2x2 quads in 8x4 tiles (fragment and the other full-screen passes).
    Quads,
    /// The queue shuffled with this seed (a wrong assembly, for the negative).
    Random(u64),
    /// Consecutive invocations of a 1-D dispatch, those without work idle (reflection-point:
    /// one invocation per scene vertex; reflectors' vertices leave at once).
    Dispatch,
}

/// The widths the model replays: lavapipe's subgroup sizes (4, 8, 16) and the GPUs' (32, 64).
pub const WIDTHS: [u32; 5] = [4, 8, 16, 32, 64];

/// `rays` queue entries in warps of `width` lanes, in queue order.
pub fn queue_warps(rays: usize, width: u32) -> Vec<Vec<Lane>> {
    let order: Vec<usize> = (0..rays).collect();
    chunk(&order, width)
}

/// `rays` queue entries in warps of `width` lanes after a fixed-seed shuffle.
pub fn random_warps(rays: usize, width: u32, seed: u64) -> Vec<Vec<Lane>> {
    let mut order: Vec<usize> = (0..rays).collect();
    let mut s = seed ^ 0x9e37_79b9_7f4a_7c15;
    for i in (1..order.len()).rev() {
        // xorshift64*: deterministic on every machine.
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        let r = s.wrapping_mul(0x2545_f491_4f6c_dd1d);
        order.swap(i, (r % (i as u64 + 1)) as usize);
    }
    chunk(&order, width)
}

fn chunk(order: &[usize], width: u32) -> Vec<Vec<Lane>> {
    order
        .chunks(width.max(1) as usize)
        .map(|c| {
            let mut w: Vec<Lane> = c.iter().map(|&i| Lane::Ray(i)).collect();
            w.resize(width as usize, Lane::Empty);
            w
        })
        .collect()
}

/// The quads of a `w x h` image in the order of the module docs, each with its top-left pixel.
fn quads(w: u32, h: u32, ray_at: &[Option<usize>]) -> Vec<((u32, u32), [Lane; 4])> {
    let lane = |x: u32, y: u32| {
        if x >= w || y >= h {
            Lane::Helper
        } else {
            ray_at[(y * w + x) as usize].map_or(Lane::Idle, Lane::Ray)
        }
    };
    let mut quads = Vec::new();
    for ty in 0..h.div_ceil(4) {
        for tx in 0..w.div_ceil(8) {
            for qy in 0..2 {
                for qx in 0..4 {
                    let (x, y) = (tx * 8 + qx * 2, ty * 4 + qy * 2);
                    if x >= w || y >= h {
                        continue;
                    }
                    quads.push((
                        (x, y),
                        [
                            lane(x, y),
                            lane(x + 1, y),
                            lane(x, y + 1),
                            lane(x + 1, y + 1),
                        ],
                    ));
                }
            }
        }
    }
    quads
}

/// The pixels of a `w x h` image in warps of `width` (>= 4) lanes of 2x2 quads (module docs);
/// `ray_at[y * w + x]` is the pixel's ray, if it is a mirror pixel.
pub fn quad_warps(w: u32, h: u32, ray_at: &[Option<usize>], width: u32) -> Vec<Vec<Lane>> {
    let per = (width / 4).max(1) as usize;
    quads(w, h, ray_at)
        .chunks(per)
        .map(|c| {
            let mut v: Vec<Lane> = c.iter().flat_map(|(_, q)| *q).collect();
            v.resize(width as usize, Lane::Empty);
            v
        })
        .collect()
}

/// How lavapipe hands a pass's work to its threads (one per CPU): each thread takes the next
/// item when it is free, in order (llvmpipe's compute thread pool takes workgroups in dispatch
/// order; its rasteriser's threads take the scene's 64x64 bins in row-major order). A thread
/// runs an item's warps one after another.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Items {
    /// Workgroups of this many queue entries (a compute dispatch).
    Groups(u32),
    /// Square screen tiles of this many pixels a side (a fragment pass).
    Tiles(u32),
}

impl Items {
    /// The item's size: entries per group, or a tile's side in pixels (at least 1).
    pub fn size(self) -> u32 {
        let (Items::Groups(n) | Items::Tiles(n)) = self;
        n.max(1)
    }
}

/// The side of llvmpipe's rasteriser bins (`TILE_SIZE` in Mesa's lp_limits.h).
pub const LAVAPIPE_TILE: u32 = 64;

/// For each warp of [`warps`] (same arguments), the lavapipe work item it belongs to: its index
/// in the order the threads take them. Quads go to the tile that holds their warp's first quad,
/// queue and dispatch entries to consecutive groups (an `Items` of the other kind is read as
/// its number: a tile side, or entries per group).
pub fn warp_items(
    assembly: Assembly,
    rays: usize,
    img: (u32, u32),
    ray_at: &[Option<usize>],
    width: u32,
    items: Items,
) -> Vec<usize> {
    let per = width.max(1) as usize;
    let entries = match assembly {
        Assembly::Queue | Assembly::Random(_) => rays,
        Assembly::Dispatch => ray_at.len(),
        Assembly::Quads => {
            let (w, h) = img;
            let t = items.size();
            let across = w.div_ceil(t) as usize;
            return quads(w, h, ray_at)
                .chunks((width / 4).max(1) as usize)
                .map(|c| {
                    let (x, y) = c[0].0;
                    (y / t) as usize * across + (x / t) as usize
                })
                .collect();
        }
    };
    let group = items.size() as usize;
    (0..entries.div_ceil(per))
        .map(|k| k * per / group)
        .collect()
}

/// The warps of `assembly` for a frame of `rays` rays (`ray_at` and the image size for quads).
pub fn warps(
    assembly: Assembly,
    rays: usize,
    img: (u32, u32),
    ray_at: &[Option<usize>],
    width: u32,
) -> Vec<Vec<Lane>> {
    match assembly {
        Assembly::Queue => queue_warps(rays, width),
        Assembly::Random(seed) => random_warps(rays, width, seed),
        Assembly::Quads => quad_warps(img.0, img.1, ray_at, width),
        Assembly::Dispatch => ray_at
            .chunks(width.max(1) as usize)
            .map(|c| {
                let mut w: Vec<Lane> = c.iter().map(|r| r.map_or(Lane::Idle, Lane::Ray)).collect();
                w.resize(width as usize, Lane::Empty);
                w
            })
            .collect(),
    }
}

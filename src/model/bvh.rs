//! The model's CPU twin of bvh_trace's traversal (`bvh_nearest`, spirv/shared/bvh.wgsl) over
//! the CWBVH the GPU path builds ([`BvhData`]): the same loop (one triangle or one node or one
//! pop per turn), the same conservative box test, the watertight triangle test
//! ([`crate::cpu::watertight`]) and the start rule, written for the work log: each turn's
//! blocks and the node and triangle addresses it reads (80-byte nodes, 48-byte triangle slots,
//! in the buffers' order).
//!
//! How it is checked (tests/model.rs): ray for ray against the GPU's `bvh_trace` on the same
//! rays over the same BVH (hit distance bit for bit, triangle, nodes visited, triangles tested,
//! the cut flag), and against the reference's nearest hit under its start rule.
#![forbid(unsafe_code)]

use glam::Vec3;

use super::frame::{BUF_BVH_NODES, BUF_BVH_TRIS, Frame};
use super::rays::Iter;
use crate::cpu::watertight::intersect;
use crate::vk::passes::bvh::BvhData;

/// bvh_trace's loop cap and stack depth, and the slab padding (spirv/shared/bvh.wgsl).
const MAX_ITERATIONS: u32 = 7000;
const STACK: usize = 32;
const PAD: f32 = 9.536_743e-7;

// Indices into `methods::bvh::BVH_BLOCKS`.
pub const B_SETUP: usize = 0;
pub const B_ITERATION: usize = 1;
pub const B_NODE: usize = 2;
pub const B_TRIANGLE: usize = 3;
pub const B_START_RULE: usize = 4;
pub const B_SHADE: usize = 5;

/// The traversal loop's id.
pub const L_ITER: u16 = 10;

/// bvh_trace.wgsl's nest.
pub const BVH_PROGRAM: &[super::blocks::Stmt] = {
    use super::blocks::Stmt::{Block, Loop};
    &[
        Block(B_SETUP),
        Loop(
            L_ITER,
            &[
                Block(B_ITERATION),
                Block(B_TRIANGLE),
                Block(B_START_RULE),
                Block(B_NODE),
            ],
        ),
        Block(B_SHADE),
    ]
};

/// The nearest hit and the counters of one ray.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhOut {
    pub hit: Option<(f32, u32)>,
    pub nodes: u32,
    pub tests: u32,
    pub cut: bool,
}

fn node_base(n: u32) -> u64 {
    (BUF_BVH_NODES << 44) + n as u64 * 80
}

fn tri_base(k: u32) -> u64 {
    (BUF_BVH_TRIS << 44) + k as u64 * 48
}

fn inv_dir(d: Vec3) -> Vec3 {
    let f = |x: f32| {
        if x.abs() < 1e-30 {
            if x.is_sign_negative() {
                -1.267_650_6e30
            } else {
                1.267_650_6e30
            }
        } else {
            1.0 / x
        }
    };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}

fn byte8(lo: u32, hi: u32, i: u32) -> u32 {
    ((if i >= 4 { hi } else { lo }) >> ((i & 3) * 8)) & 0xff
}

/// `bvh_node_hits`.
fn node_hits(b: &BvhData, n: u32, o: Vec3, inv: Vec3, oct: u32, t_lo: f32, t_best: f32) -> u32 {
    let w = |i: u32| b.nodes[(5 * n + i) as usize];
    let (w0, w1, wx, wy, wz) = (w(0), w(1), w(2), w(3), w(4));
    let p = Vec3::new(
        f32::from_bits(w0[0]),
        f32::from_bits(w0[1]),
        f32::from_bits(w0[2]),
    );
    let e = |s: u32| f32::from_bits(((w0[3] >> s) & 0xff) << 23);
    let ext = Vec3::new(e(0), e(8), e(16));
    let sd = ext * inv;
    let so = (p - o) * inv;
    let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
    let mut mask = 0u32;
    for i in 0..8 {
        let cmeta = byte8(w1[2], w1[3], i);
        if cmeta == 0 {
            continue;
        }
        let ws = [wx, wy, wz];
        let (mut tn, mut tf) = ([0f32; 3], [0f32; 3]);
        for a in 0..3 {
            let lo = byte8(ws[a][0], ws[a][1], i) as f32;
            let hi = byte8(ws[a][2], ws[a][3], i) as f32;
            let (qn, qf) = if neg[a] { (hi, lo) } else { (lo, hi) };
            let (an, af) = (qn * sd[a], qf * sd[a]);
            tn[a] = an + so[a] - (an.abs() + so[a].abs()) * PAD;
            tf[a] = af + so[a] + (af.abs() + so[a].abs()) * PAD;
        }
        let t0 = tn[0].max(tn[1]).max(tn[2].max(t_lo));
        let t1 = tf[0].min(tf[1]).min(tf[2].min(t_best));
        if t0 <= t1 {
            let inner = (cmeta & (cmeta << 1) & 0x10) != 0;
            let index = (cmeta ^ if inner { oct } else { 0 }) & 0x1f;
            mask |= ((cmeta >> 5) & 7) << index;
        }
    }
    mask
}

fn plane_distance(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let n = (b - a).cross(c - a);
    let l = n.length();
    // Not positive, or NaN: no plane.
    if l.is_nan() || l <= 0.0 {
        return f32::INFINITY;
    }
    (p - a).dot(n).abs() / l
}

fn same(a: Vec3, b: Vec3) -> bool {
    a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)
}

/// The start rule (`bvh_start_ignores`) for a ray leaving `f` (its triangle `from`) at `o`.
fn start_ignores(
    o: Vec3,
    from: u32,
    f: [Vec3; 3],
    (e, r): (f32, f32),
    tri: u32,
    t: [Vec3; 3],
    dist: f32,
) -> bool {
    let plane = plane_distance(o, t[0], t[1], t[2]);
    tri == from
        || (f.iter().any(|&x| t.iter().any(|&y| same(x, y)))
            && crate::cpu::bounded::start_ignores_neighbour(plane, e, r, dist))
}

/// What the traversal keeps of its ray: the origin, the direction and its reciprocal, the
/// octant that orders a node's children, the lower bound on `t`, the triangle it leaves (with
/// its corners) and the start rule's tolerance and reach there (`bvh_start_tolerance`,
/// `bvh_start_reach`).
struct Ray {
    o: Vec3,
    d: Vec3,
    inv: Vec3,
    oct: u32,
    t_lo: f32,
    from: Option<(u32, [Vec3; 3])>,
    e: Option<(f32, f32)>,
}

impl Ray {
    fn new(o: Vec3, d: Vec3, t_min: f32, from: Option<(u32, [Vec3; 3])>) -> Ray {
        let e = from.map(|(_, f)| {
            let e = crate::cpu::bounded::start_tolerance(o, f);
            (e, crate::cpu::bounded::start_reach(o, f, e))
        });
        let inv = inv_dir(d);
        let oct = (if inv.x < 0.0 { 0 } else { 4 })
            | (if inv.y < 0.0 { 0 } else { 2 })
            | (if inv.z < 0.0 { 0 } else { 1 });
        Ray {
            o,
            d,
            inv,
            oct,
            t_lo: t_min.max(0.0),
            from,
            e,
        }
    }
}

/// One triangle turn of the traversal: the triangle in slot `k` against the ray, logged into
/// `it`. A hit at `t >= t_lo`, nearer than `best` (or as near with a lower ID) and not ignored
/// by the start rule becomes `best`, and `t_best` its `t` padded by `PAD`.
fn triangle_turn(
    b: &BvhData,
    ray: &Ray,
    k: u32,
    best: &mut Option<(f32, u32)>,
    t_best: &mut f32,
    out: &mut BvhOut,
    it: &mut Iter,
) {
    let corner = |i: u32| {
        let v = b.tris[(3 * k + i) as usize];
        Vec3::new(v[0], v[1], v[2])
    };
    let t = [corner(0), corner(1), corner(2)];
    let tri = b.tris[(3 * k) as usize][3].to_bits();
    out.tests += 1;
    let base = tri_base(k);
    it.execs.push(super::rays::Exec {
        block: B_TRIANGLE,
        loads: vec![base, base + 16, base + 32],
    });
    if let Some(h) = intersect(ray.o, ray.d, t)
        && h.t >= ray.t_lo
        && best.is_none_or(|(bt, btri)| h.t < bt || (h.t == bt && tri < btri))
    {
        let ignored = match (ray.from, ray.e) {
            (Some((f, fc)), Some(e)) if e.0 >= 0.0 => {
                it.execs.push(super::rays::Exec {
                    block: B_START_RULE,
                    loads: Vec::new(),
                });
                start_ignores(ray.o, f, fc, e, tri, t, h.t * ray.d.length())
            }
            _ => false,
        };
        if !ignored {
            *best = Some((h.t, tri));
            *t_best = h.t + h.t * PAD;
        }
    }
}

/// `bvh_nearest` for `o + t d`, t >= t_min, leaving triangle `from` (corners `from_corners`),
/// logging each turn into `top`'s traversal loop.
pub fn nearest(
    b: &BvhData,
    o: Vec3,
    d: Vec3,
    t_min: f32,
    from: Option<(u32, [Vec3; 3])>,
    top: &mut Iter,
) -> BvhOut {
    let mut out = BvhOut::default();
    top.execs.push(super::rays::Exec {
        block: B_SETUP,
        loads: Vec::new(),
    });
    if b.nodes.is_empty() {
        return out;
    }
    let ray = Ray::new(o, d, t_min, from);
    let mut t_best = f32::INFINITY;
    let mut best: Option<(f32, u32)> = None;
    let mut stack = [(0u32, 0u32); STACK];
    let mut sp = 0usize;
    let mut nodes = (0u32, 0x8000_0000u32);
    let mut prims = (0u32, 0u32);
    let run = top.run_mut(L_ITER);
    for _ in 0..MAX_ITERATIONS {
        let mut it = Iter::default();
        it.execs.push(super::rays::Exec {
            block: B_ITERATION,
            loads: Vec::new(),
        });
        if prims.1 != 0 {
            let j = 31 - prims.1.leading_zeros();
            prims.1 &= !(1 << j);
            let k = prims.0 + j;
            triangle_turn(b, &ray, k, &mut best, &mut t_best, &mut out, &mut it);
            run.iters.push(it);
            continue;
        }
        if nodes.1 & 0xff00_0000 != 0 {
            let group = nodes;
            let bit = 31 - group.1.leading_zeros();
            nodes.1 &= !(1 << bit);
            if nodes.1 & 0xff00_0000 != 0 {
                if sp >= STACK {
                    out.cut = true;
                    run.iters.push(it);
                    return BvhOut { hit: None, ..out };
                }
                stack[sp] = nodes;
                sp += 1;
            }
            let slot = (bit - 24) ^ ray.oct;
            let n = group.0 + (group.1 & !(u32::MAX << slot)).count_ones();
            out.nodes += 1;
            let mask = node_hits(b, n, o, ray.inv, ray.oct, ray.t_lo, t_best);
            let base = node_base(n);
            it.execs.push(super::rays::Exec {
                block: B_NODE,
                loads: (0..5).map(|i| base + 16 * i).collect(),
            });
            let (w0, w1) = (b.nodes[(5 * n) as usize], b.nodes[(5 * n + 1) as usize]);
            nodes = (w1[0], (mask & 0xff00_0000) | (w0[3] >> 24));
            prims = (w1[1], mask & 0x00ff_ffff);
            run.iters.push(it);
            continue;
        }
        run.iters.push(it);
        if sp == 0 {
            out.hit = best;
            if best.is_some() {
                top.execs.push(super::rays::Exec {
                    block: B_SHADE,
                    loads: Vec::new(),
                });
            }
            return out;
        }
        sp -= 1;
        nodes = stack[sp];
    }
    out.cut = true;
    out
}

/// Every mirror ray traced over the frame's CWBVH (`model::bvh::nearest`), leaving its mirror
/// triangle; returns the work and the traversal's results.
pub fn bvh_rays(frame: &Frame) -> (Vec<Iter>, Vec<BvhOut>) {
    let bvh = crate::vk::passes::bvh::BvhData::build(&frame.data);
    frame
        .rays
        .iter()
        .map(|r| {
            let mut top = Iter::default();
            let from = Some((r.from, frame.corners[r.from as usize]));
            let out = nearest(&bvh, r.origin, r.dir, 0.0, from, &mut top);
            (top, out)
        })
        .unzip()
}

//! The closed version of a reflector for the reflection-point search (Estalella et al. 2006,
//! section 5.1: "an open/closed reflector pair"): the search runs on a watertight object that
//! contains the open reflector, the stencil (here the G-buffer's mirror mask) on the open one.
//!
//! [`closing_triangles`] closes every reflector generally: its positions are welded (within
//! [`WELD_RELATIVE`] of its bounding box's diagonal, so that seams of duplicated vertices, e.g. a
//! UV sphere's, are not taken for holes), its boundary edges (used by one triangle) are chained
//! into loops, and each loop is capped by a fan from the loop's centroid, wound against the loop
//! so that the closed surface keeps the reflector's orientation. The cap's normal is its
//! triangle's geometric normal, on the side the reflector's own normals take relative to its
//! winding. A closed reflector (sphere, ellipsoid, torus) gets no triangle; the built-in `bowl`
//! gets one cap of 64 triangles over its rim, the teapot caps over its 64 open edges.
//!
//! Where the caps go in the search textures depends on which side of the closed object the
//! mirror is. Normals pointing out of the enclosed volume (a convex-ish reflector with holes):
//! the caps are drawn with their own depth, the paper's closed reflector, so that a search
//! crosses a hole instead of stopping at its edge or on the inside seen through it. Normals
//! pointing into it (a concave mirror seen from its open side, the `bowl`): a cap in front would
//! hide the mirror and make it a plane (measured: the bowl's share of the reference's object fell
//! from 40% to 0%), so the caps are drawn behind every reflector surface ([`ClosureVertex::behind`])
//! and fill only texels where the camera sees none of it. For a cup-shaped reflector such as the
//! bowl that is never: a line through its rim's disc meets the cup, so from any viewpoint the cup
//! covers its cap and the search is unchanged.
use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::scene::gpu_data::GpuSceneData;

/// Positions closer than this times the reflector's bounding-box diagonal are one vertex.
pub const WELD_RELATIVE: f32 = 1e-5;

/// `RpClosureVertex` in `spirv/reflection_point_search.wgsl`: one vertex of a closing triangle (a triangle
/// list, three per triangle).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ClosureVertex {
    pub position: [f32; 3],
    /// The reflector's object index.
    pub object: u32,
    pub normal: [f32; 3],
    /// 1: drawn behind every reflector surface in the search textures (a cap on the mirror's
    /// side, see the module docs); 0: with its own depth.
    pub behind: u32,
}

/// Welded vertex ids of the reflector `object`'s triangles (degenerate ones dropped), with the
/// welded positions.
fn welded(data: &GpuSceneData, object: u32) -> (Vec<[u32; 3]>, Vec<Vec3>) {
    let tris: Vec<[u32; 3]> = data
        .indices
        .chunks_exact(3)
        .filter(|t| data.vertices[t[0] as usize].object == object)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let pos = |i: u32| Vec3::from_array(data.vertices[i as usize].position);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &i in tris.iter().flatten() {
        lo = lo.min(pos(i));
        hi = hi.max(pos(i));
    }
    let eps = (WELD_RELATIVE * (hi - lo).length()).max(f32::MIN_POSITIVE);
    let cell = |p: Vec3| ((p - lo) / eps).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<u32>> = HashMap::new();
    let mut points: Vec<Vec3> = Vec::new();
    let mut id: HashMap<u32, u32> = HashMap::new();
    let mut weld = |i: u32| -> u32 {
        if let Some(&w) = id.get(&i) {
            return w;
        }
        let p = pos(i);
        let c = cell(p);
        let mut found = None;
        'search: for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let key = c + glam::IVec3::new(dx, dy, dz);
                    for &w in grid.get(&key).into_iter().flatten() {
                        if (points[w as usize] - p).length() <= eps {
                            found = Some(w);
                            break 'search;
                        }
                    }
                }
            }
        }
        let w = found.unwrap_or_else(|| {
            points.push(p);
            let w = points.len() as u32 - 1;
            grid.entry(c).or_default().push(w);
            w
        });
        id.insert(i, w);
        w
    };
    let out = tris
        .iter()
        .map(|t| [weld(t[0]), weld(t[1]), weld(t[2])])
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
        .collect();
    (out, points)
}

/// The boundary edges of a welded triangle list: directed as their one triangle winds them, in
/// triangle order.
pub fn boundary_edges(triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let mut count: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .filter(|&(a, b)| count[&(a.min(b), a.max(b))] == 1)
        .collect()
}

/// Boundary edges chained into loops (each a list of directed edges, in order).
fn loops(edges: &[(u32, u32)]) -> Vec<Vec<(u32, u32)>> {
    let mut from: HashMap<u32, Vec<usize>> = HashMap::new();
    for (k, &(a, _)) in edges.iter().enumerate() {
        from.entry(a).or_default().push(k);
    }
    let mut used = vec![false; edges.len()];
    let mut out = Vec::new();
    for first in 0..edges.len() {
        if used[first] {
            continue;
        }
        let mut chain = Vec::new();
        let mut k = first;
        loop {
            used[k] = true;
            chain.push(edges[k]);
            let next = from
                .get(&edges[k].1)
                .and_then(|ks| ks.iter().copied().find(|&j| !used[j]));
            match next {
                Some(j) => k = j,
                None => break,
            }
        }
        out.push(chain);
    }
    out
}

/// The triangles that close every reflector of `data` (none for a closed one).
pub fn closing_triangles(data: &GpuSceneData) -> Vec<ClosureVertex> {
    let mut out = Vec::new();
    for (object, info) in data.objects.iter().enumerate() {
        if info.reflector == 0 {
            continue;
        }
        let object = object as u32;
        let (tris, points) = welded(data, object);
        let edges = boundary_edges(&tris);
        if edges.is_empty() {
            continue;
        }
        // Which side of the winding the reflector's normals take.
        let side: f32 = data
            .indices
            .chunks_exact(3)
            .filter(|t| data.vertices[t[0] as usize].object == object)
            .map(|t| {
                let v = |k: usize| data.vertices[t[k] as usize];
                let p = |k: usize| Vec3::from_array(v(k).position);
                let n = (0..3).map(|k| Vec3::from_array(v(k).normal)).sum::<Vec3>();
                (p(1) - p(0)).cross(p(2) - p(0)).dot(n)
            })
            .sum();
        let side = if side < 0.0 { -1.0 } else { 1.0 };
        let first = out.len();
        // The closed object's signed volume, with its winding.
        let mut volume = tris
            .iter()
            .map(|t| {
                let p = |k: usize| points[t[k] as usize];
                p(0).dot(p(1).cross(p(2)))
            })
            .sum::<f32>();
        for chain in loops(&edges) {
            let centre =
                chain.iter().map(|&(a, _)| points[a as usize]).sum::<Vec3>() / chain.len() as f32;
            for &(a, b) in &chain {
                let (pa, pb) = (points[a as usize], points[b as usize]);
                let normal = side * (pb - centre).cross(pa - centre).normalize_or_zero();
                volume += centre.dot(pb.cross(pa));
                for p in [centre, pb, pa] {
                    out.push(ClosureVertex {
                        position: p.to_array(),
                        object,
                        normal: normal.to_array(),
                        behind: 0,
                    });
                }
            }
        }
        // Normals into the enclosed volume: the mirror is the inside of the closed object.
        if volume * side < 0.0 {
            for v in &mut out[first..] {
                v.behind = 1;
            }
        }
    }
    out
}

/// Boundary edges of reflector `object` with the closing triangles of `closure` added (both
/// welded together): empty when the closed version is watertight.
pub fn open_edges_after_closing(
    data: &GpuSceneData,
    object: u32,
    closure: &[ClosureVertex],
) -> Vec<(u32, u32)> {
    let mut merged = data.clone();
    let closing = closure.iter().filter(|v| v.object == object);
    for v in closing {
        merged.indices.push(merged.vertices.len() as u32);
        merged.vertices.push(crate::scene::gpu_data::GpuVertex {
            position: v.position,
            object,
            normal: v.normal,
            ..Default::default()
        });
    }
    let (tris, _) = welded(&merged, object);
    boundary_edges(&tris)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin;

    fn reflectors(data: &GpuSceneData) -> Vec<u32> {
        (0..data.objects.len() as u32)
            .filter(|&o| data.objects[o as usize].reflector != 0)
            .collect()
    }

    /// Every built-in reflector's closed version is watertight; the closed ones get no triangle,
    /// the bowl one cap over its rim of 64 segments, the teapot caps over its 64 open edges. The
    /// closed bowl keeps the bowl's orientation: its normals point into the volume it encloses,
    /// so the cap's point away from the open side (-z), and its cap goes behind; the teapot's
    /// mirror is its outside, so its caps keep their depth.
    #[test]
    fn builtin_reflectors_close_watertight() {
        for (name, _) in builtin::NAMES {
            let data = GpuSceneData::new(&builtin::by_name(name).unwrap());
            let closure = closing_triangles(&data);
            for o in reflectors(&data) {
                let (tris, _) = welded(&data, o);
                let open = boundary_edges(&tris).len();
                let left = open_edges_after_closing(&data, o, &closure);
                eprintln!(
                    "{name}: object {o}: {open} boundary edges, {} closing triangles",
                    closure.iter().filter(|v| v.object == o).count() / 3
                );
                assert!(left.is_empty(), "{name}: {} edges left open", left.len());
                if *name == "bowl" {
                    assert_eq!(open, 64);
                } else {
                    assert_eq!(open, if *name == "teapot" { 64 } else { 0 }, "{name}");
                }
            }
            if *name == "bowl" {
                assert_eq!(closure.len(), 64 * 3);
                assert!(closure.iter().all(|v| v.normal[2] < -0.999));
                assert!(
                    closure.iter().all(|v| v.behind == 1),
                    "the bowl's mirror is inside"
                );
            } else if *name == "teapot" {
                assert!(
                    closure.iter().all(|v| v.behind == 0),
                    "the teapot's mirror is outside"
                );
            } else if *name != "teapot" {
                assert!(closure.is_empty(), "{name}");
            }
        }
    }

    /// Negative: a sphere with one triangle taken out has a hole of three edges, which the
    /// closure caps; the closure without one of its triangles leaves edges open.
    #[test]
    fn a_hole_is_found_and_capped() {
        let scene = builtin::by_name("sphere-room").unwrap();
        let mut data = GpuSceneData::new(&scene);
        let o = reflectors(&data)[0];
        let k = data
            .indices
            .chunks_exact(3)
            .position(|t| data.vertices[t[0] as usize].object == o)
            .unwrap()
            + 100;
        data.indices.drain(3 * k..3 * k + 3);
        let (tris, _) = welded(&data, o);
        assert_eq!(boundary_edges(&tris).len(), 3);
        let closure = closing_triangles(&data);
        assert_eq!(closure.len(), 3 * 3);
        assert!(open_edges_after_closing(&data, o, &closure).is_empty());
        assert!(!open_edges_after_closing(&data, o, &closure[3..]).is_empty());
        // The cap lies in the removed triangle's place: its normal along the sphere's.
        let n = Vec3::from_array(closure[0].normal);
        let p = Vec3::from_array(closure[0].position) - Vec3::new(0.0, 1.2, 0.0);
        assert!(n.dot(p.normalize()) > 0.99, "{n} at {p}");
        assert!(closure.iter().all(|v| v.behind == 0));
    }
}

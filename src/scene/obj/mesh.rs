//! `tobj`'s models made into mesh parts: polygons triangulated, then the hygiene rules
//! (degenerate triangles dropped, missing normals computed over welded positions).

use std::collections::HashMap;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::obj_pass::{ObjPass, PartInfo};
use super::polygon::triangulate;
use super::tobj_failed;
use crate::scene::report::{LoadReport, WarningKind};
use crate::scene::{MeshPart, SceneError};

/// One part as `tobj` built it, its polygons triangulated.
pub(super) struct RawPart {
    /// Index into [`ObjPass::parts`].
    pub(super) part: usize,
    pub(super) material_id: Option<usize>,
    positions: Vec<Vec3>,
    uvs: Vec<Vec2>,
    normals: Vec<Vec3>,
    /// Empty, or one sRGB-encoded colour per position ([`ObjPass::colours`]).
    colours: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// The source line of each triangle's polygon.
    lines: Vec<u32>,
    /// The smoothing group of each triangle's polygon ([`ObjPass::face_groups`]).
    groups: Vec<u32>,
}

/// The items of `v` at `kept`; an empty `v` (texture coordinates or normals absent) stays empty.
fn pick<T: Copy>(v: &[T], kept: &[usize]) -> Vec<T> {
    if v.is_empty() {
        Vec::new()
    } else {
        kept.iter().map(|&i| v[i]).collect()
    }
}

/// Triangulates the polygons of `tobj`'s models (see [`triangulate`]); one that crosses itself
/// is fanned from its first corner with a warning naming its source line. Models without faces
/// are left out.
pub(super) fn triangulate_models(
    obj: &ObjPass,
    models: Vec<tobj::Model>,
    path: &Path,
    report: &mut LoadReport,
) -> Result<Vec<RawPart>, SceneError> {
    let mismatch = || tobj_failed(path, tobj::LoadError::GenericFailure);
    let mut parts = obj.parts.iter().enumerate().filter(|(_, p)| p.faces > 0);
    let mut lines = obj.face_lines.iter().zip(&obj.face_groups);
    let mut out = Vec::new();
    for model in models {
        let m = model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let (part, info) = parts.next().ok_or_else(mismatch)?;
        // `tobj` leaves `face_arities` empty when every face is a triangle.
        let arities = if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities
        };
        if arities.len() != info.faces
            || arities.iter().map(|&n| n as usize).sum::<usize>() != m.indices.len()
        {
            return Err(mismatch());
        }
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        if m.indices.iter().any(|&i| i as usize >= positions.len()) {
            return Err(mismatch());
        }
        let mut triangles = Vec::with_capacity(m.indices.len());
        let mut tri_lines: Vec<u32> = Vec::with_capacity(m.indices.len());
        let mut tri_groups: Vec<u32> = Vec::with_capacity(m.indices.len());
        let mut start = 0;
        for &n in &arities {
            let face = &m.indices[start..start + n as usize];
            start += n as usize;
            let (&line, &group) = lines.next().ok_or_else(mismatch)?;
            let points: Vec<Vec3> = face.iter().map(|&i| positions[i as usize]).collect();
            let tris = triangulate(&points).unwrap_or_else(|reason| {
                report.warn(
                    WarningKind::SelfCrossingPolygon,
                    path,
                    Some(line),
                    format!(
                        "polygons that cross themselves fanned from their first corner, as \
                         tobj and Blender do (the fan may cover area outside the outline): \
                         {}",
                        reason.split(" (").next().unwrap_or(&reason)
                    ),
                );
                (1..n as usize - 1).map(|i| [0, i, i + 1]).collect()
            });
            tri_lines.extend(std::iter::repeat_n(line as u32, tris.len()));
            tri_groups.extend(std::iter::repeat_n(group, tris.len()));
            triangles.extend(tris.into_iter().map(|t| t.map(|k| face[k])));
        }
        let uvs: Vec<Vec2> = m
            .texcoords
            .chunks_exact(2)
            .map(|t| Vec2::new(t[0], t[1]))
            .collect();
        let normals: Vec<Vec3> = m
            .normals
            .chunks_exact(3)
            .map(|n| Vec3::new(n[0], n[1], n[2]))
            .collect();
        let colours: Vec<Vec3> = (m.vertex_color.chunks_exact(3))
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        let expect = |len: usize, wanted: bool| len == if wanted { positions.len() } else { 0 };
        if !expect(uvs.len(), info.any_vt)
            || !expect(normals.len(), info.any_vn)
            || !expect(colours.len(), obj.colours)
        {
            return Err(mismatch());
        }
        // Keep only the vertices the triangles use, numbered in the order they first use them
        // (for fanned polygons, tobj's own order; ear clipping may leave a repeated corner out).
        let mut new_index = vec![u32::MAX; positions.len()];
        let mut kept: Vec<usize> = Vec::with_capacity(positions.len());
        for t in &mut triangles {
            for i in t.iter_mut() {
                let slot = &mut new_index[*i as usize];
                if *slot == u32::MAX {
                    *slot = kept.len() as u32;
                    kept.push(*i as usize);
                }
                *i = *slot;
            }
        }
        out.push(RawPart {
            part,
            material_id: m.material_id,
            positions: pick(&positions, &kept),
            uvs: pick(&uvs, &kept),
            normals: pick(&normals, &kept),
            colours: pick(&colours, &kept),
            triangles,
            lines: tri_lines,
            groups: tri_groups,
        });
    }
    if parts.next().is_some() {
        return Err(mismatch());
    }
    Ok(out)
}

/// Turns a triangulated part into a [`MeshPart`], applying the hygiene rules. Returns the part
/// and the number of degenerate triangles dropped.
pub(super) fn finish_part(
    info: &PartInfo,
    raw: RawPart,
    material: u32,
    path: &Path,
    report: &mut LoadReport,
) -> (MeshPart, usize) {
    if info.any_vt {
        for &line in &info.faces_without_vt {
            report.warn(
                WarningKind::MissingTexcoords,
                path,
                Some(line),
                format!(
                    "face without texture coordinates in textured part '{}': its corners get uv (0, 0)",
                    info.name
                ),
            );
        }
    }
    let mut triangles = Vec::with_capacity(raw.triangles.len());
    let mut lines = Vec::with_capacity(raw.triangles.len());
    let mut groups = Vec::with_capacity(raw.triangles.len());
    let mut dropped = 0;
    for ((&t, &line), &group) in raw.triangles.iter().zip(&raw.lines).zip(&raw.groups) {
        // In f64: f32 overflows for sides over ~1e19 and underflows under ~1e-19, both of
        // which a valid vertex may give (coordinates reach 2^60).
        let [a, b, c] = t.map(|i| raw.positions[i as usize].as_dvec3());
        let area2 = (b - a).cross(c - a).length_squared();
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area2 == 0.0 || !area2.is_finite() {
            dropped += 1;
        } else {
            triangles.push(t);
            lines.push(line);
            groups.push(group);
        }
    }
    let mut v = Vertices {
        positions: raw.positions,
        uvs: raw.uvs,
        normals: raw.normals,
        colours: raw.colours,
    };
    // Corners without a normal have the zero one here, replaced by the computed normal below.
    let computed = v.normals.is_empty() || v.normals.contains(&Vec3::ZERO);
    let one_group = groups.iter().all(|&g| g != 0 && g == groups[0]);
    let vertex_groups = if computed && !one_group {
        split_by_group(&mut v, &mut triangles, &groups)
    } else {
        Vec::new()
    };
    let normals = part_normals(&v.positions, &v.normals, &triangles, &vertex_groups);
    (
        MeshPart {
            name: info.name.clone(),
            positions: v.positions,
            normals,
            uvs: v.uvs,
            // All white multiplies by one: the part is left without colours (the export writes
            // white for the parts of a file with colours elsewhere).
            colours: if v.colours.iter().all(|&c| c == Vec3::ONE) {
                Vec::new()
            } else {
                v.colours
            },
            triangles,
            material,
            source: Some(crate::scene::PartSource {
                file: path.to_path_buf(),
                lines,
            }),
        },
        dropped,
    )
}

/// The per-vertex data of a part (`uvs`, `normals` and `colours` empty where it has none).
struct Vertices {
    positions: Vec<Vec3>,
    uvs: Vec<Vec2>,
    normals: Vec<Vec3>,
    colours: Vec<Vec3>,
}

/// Gives each smoothing group its own copies of the vertices it shares with other groups, and
/// each triangle of group 0 (`s off`) its own three vertices, renumbering `triangles`; returns
/// the weld key of each vertex for [`smooth_normals`] (the group, or one key per flat
/// triangle), so that normals are smoothed within a group only and flat faces get their own.
fn split_by_group(v: &mut Vertices, triangles: &mut [[u32; 3]], groups: &[u32]) -> Vec<u64> {
    let mut new_index: HashMap<(u32, u64), u32> = HashMap::new();
    let mut kept: Vec<usize> = Vec::new();
    let mut keys: Vec<u64> = Vec::new();
    for (k, (t, &g)) in triangles.iter_mut().zip(groups).enumerate() {
        let key = if g == 0 {
            (1 << 32) | k as u64
        } else {
            u64::from(g)
        };
        for i in t.iter_mut() {
            let next = kept.len() as u32;
            let slot = *new_index.entry((*i, key)).or_insert(next);
            if slot == next {
                kept.push(*i as usize);
                keys.push(key);
            }
            *i = slot;
        }
    }
    v.positions = pick(&v.positions, &kept);
    v.uvs = pick(&v.uvs, &kept);
    v.normals = pick(&v.normals, &kept);
    v.colours = pick(&v.colours, &kept);
    keys
}

/// The normals of a part: those of the file (`given`; empty where it has none, zero at the
/// corners without one) made unit length, the others computed ([`smooth_normals`], welded
/// within `weld_keys`).
fn part_normals(
    positions: &[Vec3],
    given: &[Vec3],
    triangles: &[[u32; 3]],
    weld_keys: &[u64],
) -> Vec<Vec3> {
    // Normals already of unit length (to f32 precision) are kept bit for bit; others are
    // normalised in f32, or in f64 where their squared length leaves f32's normal range (a
    // `vn 1e30 0 0` gave the zero vector, a `vn 1e-30 0 0` was taken for a missing normal).
    let unit = |n: Vec3| {
        let l2 = n.length_squared();
        if (l2 - 1.0).abs() < 1e-6 {
            n
        } else if l2.is_normal() {
            n.normalize()
        } else {
            n.as_dvec3().normalize().as_vec3()
        }
    };
    if given.is_empty() {
        smooth_normals(positions, triangles, weld_keys)
    } else if given.contains(&Vec3::ZERO) {
        let smooth = smooth_normals(positions, triangles, weld_keys);
        given
            .iter()
            .zip(smooth)
            .map(|(&n, s)| if n == Vec3::ZERO { s } else { unit(n) })
            .collect()
    } else {
        given.iter().map(|&n| unit(n)).collect()
    }
}

/// Area-weighted vertex normals over welded positions: vertices at bit-identical positions
/// with the same weld key (`weld_keys[i]`; all the same where it is empty) share one.
pub fn smooth_normals(positions: &[Vec3], triangles: &[[u32; 3]], weld_keys: &[u64]) -> Vec<Vec3> {
    let key = |i: usize, p: Vec3| {
        let bits = p
            .to_array()
            .map(|c| if c == 0.0 { 0u32 } else { c.to_bits() });
        (bits, weld_keys.get(i).copied().unwrap_or(0))
    };
    let mut weld: HashMap<([u32; 3], u64), usize> = HashMap::new();
    let rep: Vec<usize> = positions
        .iter()
        .enumerate()
        .map(|(i, &p)| *weld.entry(key(i, p)).or_insert(i))
        .collect();
    // Summed in f32 (the normals of every mesh so far), and in f64 for the vertices where f32
    // overflows or underflows (sides over ~1e19 or under ~1e-19: coordinates reach 2^60).
    let mut sum = vec![Vec3::ZERO; positions.len()];
    let mut wide = vec![glam::DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        let [a, b, c] = [a, b, c].map(Vec3::as_dvec3);
        let w = (b - a).cross(c - a);
        for &i in t {
            sum[rep[i as usize]] += n;
            wide[rep[i as usize]] += w;
        }
    }
    rep.iter()
        .map(|&r| {
            sum[r]
                .try_normalize()
                .or_else(|| wide[r].try_normalize().map(|n| n.as_vec3()))
                .unwrap_or(Vec3::Y)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::obj::parse_obj_str;

    #[test]
    fn welding_makes_seams_smooth() {
        // Two triangles folded along a shared edge, the edge's positions repeated (a seam).
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        let n = smooth_normals(&positions, &[[0, 1, 2], [3, 5, 4]], &[]);
        // The seam vertices 1 and 3 (and 2 and 4) get the same, blended normal.
        assert_eq!(n[1], n[3]);
        assert_eq!(n[2], n[4]);
        assert!(n[1] != n[0], "the seam normal blends both faces");
    }

    #[test]
    fn hygiene_drops_degenerates_and_fills_normals() {
        // A quad split in two, plus a triangle with a repeated index and one of zero area.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n\
                    f 1 2 3\nf 1 3 4\nf 1 1 2\nf 1 2 5\n";
        let (parts, dropped) = parse_obj_str(text, Path::new("q.obj")).unwrap();
        assert_eq!(dropped, 2);
        assert_eq!(parts[0].triangles.len(), 2);
        for n in &parts[0].normals[..4] {
            assert!((*n - Vec3::Z).length() < 1e-6, "{n}");
        }
        // Zero-length normals in the file are replaced, valid ones kept.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn 0 0 1\nvn 0 0 2\nf 1//1 2//2 3//3\n";
        let (parts, _) = parse_obj_str(text, Path::new("n.obj")).unwrap();
        assert!(
            parts[0]
                .normals
                .iter()
                .all(|n| (*n - Vec3::Z).length() < 1e-6)
        );
    }
}

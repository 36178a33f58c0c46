//! World-space geometry: every mesh part of a scene, transformed and concatenated.

use glam::{DVec3, Vec2, Vec3};

use super::Scene;
use crate::shading::srgb_decode;

/// One mesh part in world space.
#[derive(Clone, Debug)]
pub struct ObjectInfo {
    /// `"mesh name/part name"`.
    pub name: String,
    pub material: u32,
    pub reflector: bool,
    /// Whether the cubemap capture draws it: a non-reflector, or a reflector that sees itself
    /// ([`Scene::self_capture`]).
    pub captured: bool,
    /// A reflector whose front, the side a reflected ray can come from, is against its vertex
    /// normals ([`Scene::front_turned`]: they point into its closed mesh, seen from outside),
    /// for the capture's "faces the centre" test. False otherwise.
    pub normals_inward: bool,
    /// A glossy reflector's Phong specular power (below [`crate::lobe::MIRROR_POWER`]); `None`
    /// on a mirror and on every non-reflector.
    pub specular_power: Option<f32>,
    /// Its part has vertex colours ([`WorldGeometry::colours`]), which multiply its
    /// material's colour.
    pub vertex_colours: bool,
    /// Range of this object's triangles in [`WorldGeometry::triangles`].
    pub first_triangle: u32,
    pub triangle_count: u32,
}

/// "No object / no primitive / no triangle" in every ID of a frame or an EXR.
pub const NO_ID: u32 = u32::MAX;

/// All triangles of a scene in world space, in a flat layout a GPU buffer can take as is.
///
/// The one numbering of the IDs every method writes ([`WorldGeometry::ids`]): a *global
/// triangle* is an index into `triangles` (what the GPU scene data and the reference's BVH
/// name); an *object id* is an index into `objects`, in scene order (meshes, then their parts);
/// a *primitive id* is the triangle's index within its object (its part's triangle list as
/// loaded).
#[derive(Clone, Debug, Default)]
pub struct WorldGeometry {
    pub positions: Vec<Vec3>,
    /// Unit normals (object normals through the inverse transpose, renormalised).
    pub normals: Vec<Vec3>,
    /// One per vertex; zero where a part has no texture coordinates.
    pub uvs: Vec<Vec2>,
    /// Empty where no part has vertex colours; else one linear RGB colour per vertex (the
    /// part's sRGB colours decoded), white where a part has none (read only for an object with [`ObjectInfo::vertex_colours`]).
    pub colours: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Object id of each triangle.
    pub triangle_object: Vec<u32>,
    pub objects: Vec<ObjectInfo>,
}

impl WorldGeometry {
    /// Per triangle, whether the cubemap capture draws it (its object's
    /// [`ObjectInfo::captured`]).
    pub fn captured_triangles(&self) -> Vec<bool> {
        (self.triangle_object.iter())
            .map(|&o| self.objects[o as usize].captured)
            .collect()
    }

    pub(super) fn build(scene: &Scene) -> Self {
        let mut w = WorldGeometry::default();
        let self_capture = scene.self_capture();
        let coloured = (scene.meshes.iter()).any(|m| m.parts.iter().any(|p| !p.colours.is_empty()));
        for (mesh, &self_capture) in scene.meshes.iter().zip(&self_capture) {
            let normals_inward = scene.front_turned(mesh);
            let m = mesh.transform.matrix();
            let nm = mesh.transform.normal_matrix();
            for part in &mesh.parts {
                let base = w.positions.len() as u32;
                let object = w.objects.len() as u32;
                w.positions
                    .extend(part.positions.iter().map(|&p| m.transform_point3(p)));
                w.normals
                    .extend(part.normals.iter().map(|&n| (nm * n).normalize_or_zero()));
                if part.uvs.len() == part.positions.len() {
                    w.uvs.extend_from_slice(&part.uvs);
                } else {
                    w.uvs
                        .extend(std::iter::repeat_n(Vec2::ZERO, part.positions.len()));
                }
                let vertex_colours =
                    part.colours.len() == part.positions.len() && !part.colours.is_empty();
                if coloured && vertex_colours {
                    let linear = |c: &Vec3| Vec3::from_array(c.to_array().map(srgb_decode));
                    w.colours.extend(part.colours.iter().map(linear));
                } else if coloured {
                    w.colours
                        .extend(std::iter::repeat_n(Vec3::ONE, part.positions.len()));
                }
                w.objects.push(ObjectInfo {
                    name: format!("{}/{}", mesh.name, part.name),
                    material: part.material,
                    reflector: mesh.reflector,
                    captured: !mesh.reflector || self_capture,
                    normals_inward,
                    specular_power: if mesh.reflector {
                        crate::lobe::glossy(scene.materials[part.material as usize].specular_power)
                    } else {
                        None
                    },
                    vertex_colours,
                    first_triangle: w.triangles.len() as u32,
                    triangle_count: part.triangles.len() as u32,
                });
                w.triangles
                    .extend(part.triangles.iter().map(|t| t.map(|i| i + base)));
                w.triangle_object
                    .extend(std::iter::repeat_n(object, part.triangles.len()));
            }
        }
        w
    }

    /// The object id and primitive id of global triangle `triangle` (see the type docs);
    /// `(NO_ID, NO_ID)` for [`NO_ID`] or any index that names no triangle of this scene.
    pub fn ids(&self, triangle: u32) -> (u32, u32) {
        match self.triangle_object.get(triangle as usize) {
            Some(&o) => (o, triangle - self.objects[o as usize].first_triangle),
            None => (NO_ID, NO_ID),
        }
    }

    /// [`Scene::axis_centres`](super::Scene::axis_centres) of the scene flattened into this.
    pub fn axis_centres(&self, count: u32) -> Vec<Vec3> {
        let (lo, hi) = self.reflector_bounds();
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            Vec3::X
        } else if ext.y >= ext.z {
            Vec3::Y
        } else {
            Vec3::Z
        };
        let n = count.max(1);
        let centre = 0.5 * (lo + hi);
        (0..n)
            .map(|i| {
                let f = (i as f32 + 0.5) / n as f32 - 0.5;
                centre + axis * (ext.dot(axis) * f)
            })
            .collect()
    }

    /// Bounding box of the reflectors; of the whole scene where it has none.
    pub fn reflector_bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.bounds(|o| o.reflector);
        if lo.x > hi.x {
            self.bounds(|_| true)
        } else {
            (lo, hi)
        }
    }

    /// Bounding box of the objects selected by `keep` (empty: `lo > hi`).
    pub fn bounds(&self, keep: impl Fn(&ObjectInfo) -> bool) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for (t, &o) in self.triangles.iter().zip(&self.triangle_object) {
            if keep(&self.objects[o as usize]) {
                for &i in t {
                    lo = lo.min(self.positions[i as usize]);
                    hi = hi.max(self.positions[i as usize]);
                }
            }
        }
        (lo, hi)
    }

    /// Length of the diagonal of the whole scene's bounding box (0 for an empty scene).
    pub fn extent(&self) -> f32 {
        let (lo, hi) = self.bounds(|_| true);
        if lo.x > hi.x { 0.0 } else { (hi - lo).length() }
    }

    /// The nearest triangle of the objects selected by `keep` to `point`: its exact distance
    /// (f64, closest point on the triangle) and its object id; `None` when none is selected.
    /// Objects whose bounding box lies farther than the best distance so far are skipped.
    pub fn nearest_triangle(
        &self,
        point: Vec3,
        keep: impl Fn(&ObjectInfo) -> bool,
    ) -> Option<(f64, u32)> {
        let p = point.as_dvec3();
        let mut objects: Vec<(f64, u32)> = Vec::new();
        for (id, o) in self.objects.iter().enumerate() {
            if !keep(o) || o.triangle_count == 0 {
                continue;
            }
            let tris = self.object_triangles(o);
            let mut lo = DVec3::INFINITY;
            let mut hi = DVec3::NEG_INFINITY;
            for t in tris {
                for &i in t {
                    let v = self.positions[i as usize].as_dvec3();
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            let box_distance = (lo - p).max(p - hi).max(DVec3::ZERO).length();
            objects.push((box_distance, id as u32));
        }
        objects.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut best: Option<(f64, u32)> = None;
        for (box_distance, id) in objects {
            if best.is_some_and(|(d, _)| box_distance > d) {
                break;
            }
            for t in self.object_triangles(&self.objects[id as usize]) {
                let [a, b, c] = t.map(|i| self.positions[i as usize].as_dvec3());
                let d = (closest_point_on_triangle(p, a, b, c) - p).length();
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, id));
                }
            }
        }
        best
    }

    fn object_triangles(&self, o: &ObjectInfo) -> &[[u32; 3]] {
        let first = o.first_triangle as usize;
        &self.triangles[first..first + o.triangle_count as usize]
    }
}

/// The point of triangle `abc` nearest to `p` (Ericson, *Real-Time Collision Detection*,
/// 5.1.5: Voronoi regions of the vertices, then the edges, then the face). Degenerate
/// triangles fall into a vertex or edge region.
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // Collinear corners not caught above (a zero-area triangle): nearest of its edges.
        return [(a, b), (b, c), (c, a)]
            .into_iter()
            .map(|(s, e)| {
                let d = e - s;
                let l = d.length_squared();
                let t = if l > 0.0 {
                    ((p - s).dot(d) / l).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                s + d * t
            })
            .min_by(|x, y| {
                (*x - p)
                    .length_squared()
                    .total_cmp(&(*y - p).length_squared())
            })
            .unwrap_or(a);
    }
    let (v, w) = (vb / denom, vc / denom);
    a + ab * v + ac * w
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against brute force over a fine barycentric grid of the triangle: never farther, and
    /// within the grid's spacing. Negative: the centroid, another point of the triangle, fails.
    #[test]
    fn closest_point_matches_a_dense_sampling() {
        let (a, b, c) = (
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.1, 0.0),
            DVec3::new(0.3, 1.5, 0.4),
        );
        let n = 200;
        for p in [
            DVec3::new(0.5, 0.5, 1.0),
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(3.0, 0.0, 0.2),
            DVec3::new(1.0, -1.0, -0.5),
            DVec3::new(0.0, 3.0, 0.0),
            DVec3::new(1.5, 1.5, 0.0),
            DVec3::new(-1.0, 0.7, 0.3),
        ] {
            let q = closest_point_on_triangle(p, a, b, c);
            let mut brute = f64::INFINITY;
            for i in 0..=n {
                for j in 0..=n - i {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    brute = brute.min((a + (b - a) * u + (c - a) * v - p).length());
                }
            }
            let passes = |q: DVec3| {
                let d = (q - p).length();
                d <= brute + 1e-12 && brute - d < 0.02
            };
            assert!(passes(q), "{p}: {q} vs brute {brute}");
            // Negative: another point of the triangle (its centroid) fails the check.
            assert!(!passes((a + b + c) / 3.0), "{p}");
        }
    }

    #[test]
    fn degenerate_triangles_give_the_nearest_edge_point() {
        let (a, b) = (DVec3::ZERO, DVec3::X);
        let q = closest_point_on_triangle(DVec3::new(0.5, 1.0, 0.0), a, b, b * 0.5);
        assert!((q - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-12, "{q}");
        let q = closest_point_on_triangle(DVec3::new(3.0, 1.0, 0.0), a, a, a);
        assert_eq!(q, a);
    }
}

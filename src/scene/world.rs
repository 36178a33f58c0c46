//! World-space geometry: every mesh part of a scene, transformed and concatenated.

use glam::{Vec2, Vec3};

use super::Scene;

/// One mesh part in world space.
#[derive(Clone, Debug)]
pub struct ObjectInfo {
    /// `"mesh name/part name"`.
    pub name: String,
    pub material: u32,
    pub reflector: bool,
    /// Range of this object's triangles in [`WorldGeometry::triangles`].
    pub first_triangle: u32,
    pub triangle_count: u32,
}

/// All triangles of a scene in world space, in a flat layout a GPU buffer can take as is.
///
/// Object ids are indices into `objects`, in scene order (meshes, then their parts). A
/// primitive id is the triangle's index *within its object*.
#[derive(Clone, Debug, Default)]
pub struct WorldGeometry {
    pub positions: Vec<Vec3>,
    /// Unit normals (object normals through the inverse transpose, renormalised).
    pub normals: Vec<Vec3>,
    /// One per vertex; zero where a part has no texture coordinates.
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
    /// Object id of each triangle.
    pub triangle_object: Vec<u32>,
    pub objects: Vec<ObjectInfo>,
}

impl WorldGeometry {
    pub(super) fn build(scene: &Scene) -> Self {
        let mut w = WorldGeometry::default();
        for mesh in &scene.meshes {
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
                w.objects.push(ObjectInfo {
                    name: format!("{}/{}", mesh.name, part.name),
                    material: part.material,
                    reflector: mesh.reflector,
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
}

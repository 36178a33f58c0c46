//! Whether a reflector can see itself.
//!
//! A reflected ray leaves a mirror on the side its normal points to. If every vertex of the
//! mesh lies on or behind the plane of every face (behind: against the face's normal), no face
//! has any part of the mesh in front of it, so no ray leaving the mesh can meet the mesh again:
//! it needs no self-capture. A closed convex mesh with outward normals passes; so does a flat
//! mirror. A torus, a bowl's concave side or a teapot's spout facing its body fail.

use glam::{DVec3, Vec3};

/// Relative tolerance of the plane test: a vertex counts as on a face's plane within this
/// fraction of the mesh's largest coordinate magnitude (f32 positions carry about 6e-8 of it;
/// tessellated analytic surfaces are exact to far less than this).
const RELATIVE_TOLERANCE: f64 = 1e-5;

/// Whether no face of the mesh (`positions`, `normals` one per position, `triangles`) can see
/// another: every vertex lies on or behind every face's plane, within a tolerance of
/// [`RELATIVE_TOLERANCE`] times the largest coordinate magnitude. A face's front is the side of
/// its geometric normal that agrees with its vertex normals (the side a mirror reflects to), so
/// the winding order does not matter. Degenerate faces (no area) are skipped; a mesh without a
/// face is convex.
pub fn is_convex(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    let points: Vec<DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
    let magnitude = points
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0f64, f64::max);
    let tolerance = RELATIVE_TOLERANCE * magnitude.max(f64::MIN_POSITIVE);
    triangles.iter().all(|t| {
        let [a, b, c] = t.map(|i| points[i as usize]);
        let cross = (b - a).cross(c - a);
        let Some(mut n) = cross.try_normalize() else {
            return true;
        };
        let shading: DVec3 = t.iter().map(|&i| normals[i as usize].as_dvec3()).sum();
        if n.dot(shading) < 0.0 {
            n = -n;
        }
        points.iter().all(|&p| n.dot(p - a) <= tolerance)
    })
}

/// The largest angle, in radians, between a face's geometric normal (oriented as in
/// [`is_convex`]: towards its vertex normals) and one of its vertex normals, over the faces of
/// the mesh (degenerate faces and zero normals skipped; 0 for a mesh without a face). Every
/// interpolated normal of a face lies within this angle of the face's normal: a normalised
/// convex combination of unit vectors inside a cone stays inside it.
pub fn max_normal_deviation(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
            let mut n = (b - a).cross(c - a).try_normalize()?;
            let vertex: Vec<DVec3> = t
                .iter()
                .filter_map(|&i| normals[i as usize].as_dvec3().try_normalize())
                .collect();
            if n.dot(vertex.iter().sum::<DVec3>()) < 0.0 {
                n = -n;
            }
            vertex
                .iter()
                .map(|v| n.dot(*v).clamp(-1.0, 1.0).acos())
                .reduce(f64::max)
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes;

    fn convex(part: &crate::scene::MeshPart) -> bool {
        is_convex(&part.positions, &part.normals, &part.triangles)
    }

    /// A flat quad with its face normal has no deviation; tilting one vertex normal by a known
    /// angle shows exactly that angle.
    #[test]
    fn normal_deviation_of_a_flat_quad() {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let triangles = [[0, 1, 2], [0, 2, 3]];
        let flat = vec![Vec3::Z; 4];
        assert_eq!(max_normal_deviation(&positions, &flat, &triangles), 0.0);
        let mut tilted = flat.clone();
        let angle = 0.1f32;
        tilted[2] = Vec3::new(angle.sin(), 0.0, angle.cos());
        let d = max_normal_deviation(&positions, &tilted, &triangles);
        assert!((d - f64::from(angle)).abs() < 1e-6, "{d}");
        // Winding does not matter.
        let reversed = [[0, 2, 1], [0, 3, 2]];
        assert!((max_normal_deviation(&positions, &tilted, &reversed) - d).abs() < 1e-12);
    }

    #[test]
    fn flat_quad_is_convex_and_folded_one_is_not() {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let normals = vec![Vec3::Z; 4];
        let triangles = vec![[0, 1, 2], [0, 2, 3]];
        assert!(is_convex(&positions, &normals, &triangles));
        // Fold the second triangle up towards the first's front: it now faces it.
        let mut folded = positions.clone();
        folded[3].z = 0.5;
        assert!(!is_convex(&folded, &normals, &triangles));
        // Folded away (behind): still convex.
        folded[3].z = -0.5;
        assert!(is_convex(&folded, &normals, &triangles));
    }

    #[test]
    fn winding_does_not_matter_normals_do() {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.3, 0.3, 0.5)];
        let up = vec![Vec3::Z; 4];
        // One face, and a vertex above it, with either winding: the vertex is in front.
        for t in [[0u32, 1, 2], [0, 2, 1]] {
            assert!(!is_convex(&positions, &up, &[t]));
            let down = vec![-Vec3::Z; 4];
            assert!(is_convex(&positions, &down, &[t]));
        }
    }

    #[test]
    fn analytic_meshes() {
        let sphere = shapes::uv_sphere(0.7, 48, 24, 0);
        assert!(convex(&sphere));
        // An ellipsoid: the sphere scaled per axis, normals through the inverse transpose.
        let scale = Vec3::new(1.0, 0.5, 1.6);
        let ellipsoid = crate::scene::MeshPart {
            positions: sphere.positions.iter().map(|&p| p * scale).collect(),
            normals: sphere
                .normals
                .iter()
                .map(|&n| (n / scale).normalize())
                .collect(),
            ..sphere.clone()
        };
        assert!(convex(&ellipsoid));
        // Far from the origin: the tolerance follows the coordinates' magnitude.
        let far = crate::scene::MeshPart {
            positions: ellipsoid
                .positions
                .iter()
                .map(|&p| p + Vec3::new(300.0, -200.0, 150.0))
                .collect(),
            ..ellipsoid.clone()
        };
        assert!(convex(&far));
        let cube = shapes::cuboid(
            Vec3::splat(-0.5),
            Vec3::new(0.5, 1.0, 2.0),
            false,
            [0; 6],
            1.0,
        );
        let mut all = crate::scene::MeshPart::default();
        for part in &cube {
            let base = all.positions.len() as u32;
            all.positions.extend(&part.positions);
            all.normals.extend(&part.normals);
            all.triangles
                .extend(part.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        assert!(convex(&all));
        // The same box turned inside out (a room): every face sees the others.
        let room = shapes::cuboid(Vec3::splat(-0.5), Vec3::splat(0.5), true, [0; 6], 1.0);
        let mut inside = crate::scene::MeshPart::default();
        for part in &room {
            let base = inside.positions.len() as u32;
            inside.positions.extend(&part.positions);
            inside.normals.extend(&part.normals);
            inside
                .triangles
                .extend(part.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        assert!(!convex(&inside));
        // Negatives: a sphere with one vertex pushed out (a bump), or in (a dent).
        for factor in [1.05, 0.95] {
            let mut bumped = sphere.clone();
            let k = bumped.positions.len() / 2 + 5;
            bumped.positions[k] *= factor;
            assert!(!convex(&bumped), "factor {factor}");
        }
        assert!(!convex(&shapes::torus(1.0, 0.35, 96, 32, 0)));
        assert!(!convex(&shapes::bowl(2.0, 50.0, 64, 24, 0)));
        assert!(!convex(&crate::scene::builtin::teapot_part(0)));
    }
}

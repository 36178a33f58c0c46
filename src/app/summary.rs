#![forbid(unsafe_code)]
//! What `render` says about a GPU frame beyond the image: how many mirror pixels the method
//! resolved itself and how many the fallback filled, and a warning naming the likely cause when
//! the fallback did much of the work.
//!
//! With `--fallback trace` (the default) no mirror pixel is left unresolved: the BVH finishes
//! every ray the method gave up, so "0 unresolved" alone would hide a misplaced CMO or inward
//! normals. The summary line therefore counts the fallback's pixels with their share of the
//! mirror pixels, and [`fallback_warning`] warns when the method left more than
//! [`WARN_SHARE`] of them to the fallback (finished by it, or left unresolved and filled by the
//! flag, environment map or background).
//!
//! The threshold, 10 %: on the built-in scenes the cubemap tracers (compute, fragment) hand
//! 0.4 to 2.5 % of their mirror pixels to the fallback (bench at 160x120), except the teapot
//! (31.6 %: its spout and handle seen in the body, the reflector check's start hits); a
//! misplaced CMO or inward normals raise it to 30-100 %. ssr (71-98 %) and reflection-point
//! (36-88 %) are above it on every built-in scene: that is their known limit, and the warning
//! says so.

use glam::{DVec3, Vec3};

use crate::Method;
use crate::metrics::Traced;
use crate::scene::Scene;
use crate::vk::frame::GpuFrame;

/// Share of the mirror pixels above which [`fallback_warning`] warns (see the module docs).
pub const WARN_SHARE: f64 = 0.10;

/// What the method left to the fallback on one frame's mirror pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FallbackCount {
    pub mirror: usize,
    /// Finished by `--fallback trace` (the BVH).
    pub traced: usize,
    /// Still unresolved (filled by another fallback, or cut by the BVH's loop cap).
    pub unresolved: usize,
    /// Of `traced`: handed over by the reflector check, which found the method's hit at the
    /// ray's own start (a reflector seeing itself).
    pub start_hits: usize,
}

impl FallbackCount {
    pub fn of(frame: &GpuFrame, traced: &Traced) -> Self {
        let unresolved = traced
            .mask
            .iter()
            .zip(&traced.resolved)
            .filter(|(m, r)| **m != 0 && **r == 0)
            .count();
        FallbackCount {
            mirror: frame.mirror_pixels(),
            traced: frame.fallback_pixels(),
            unresolved,
            start_hits: frame.start_hit_pixels(),
        }
    }

    /// The mirror pixels the method did not resolve itself: traced by the fallback or left
    /// unresolved.
    pub fn left(&self) -> usize {
        self.traced + self.unresolved
    }

    /// [`FallbackCount::left`] as a share of the mirror pixels (0 without mirror pixels).
    pub fn share(&self) -> f64 {
        self.left() as f64 / self.mirror.max(1) as f64
    }
}

/// A percentage of `part` in `whole`, one decimal.
fn percent(part: usize, whole: usize) -> String {
    format!("{:.1}%", 100.0 * part as f64 / whole.max(1) as f64)
}

/// The counts of the summary line: `N mirror pixels, F finished by the fallback (x.x%), U
/// unresolved`; the fallback part only for methods that can leave a pixel to it.
pub fn counts(method: Method, c: &FallbackCount) -> String {
    if !method.can_leave_unresolved() {
        return format!("{} mirror pixels, {} unresolved", c.mirror, c.unresolved);
    }
    format!(
        "{} mirror pixels, {} finished by the fallback ({}), {} unresolved",
        c.mirror,
        c.traced,
        percent(c.traced, c.mirror),
        c.unresolved
    )
}

/// The warning when the method left more than [`WARN_SHARE`] of the mirror pixels to the
/// fallback, naming the likely cause; `None` below it.
pub fn fallback_warning(method: Method, scene: &Scene, c: &FallbackCount) -> Option<String> {
    if !method.can_leave_unresolved() || c.share() <= WARN_SHARE {
        return None;
    }
    let head = format!(
        "--method {method} resolved only {} of {} mirror pixels itself: the fallback {} {} ({}, \
         more than the {:.0}% this warning allows)",
        c.mirror - c.left(),
        c.mirror,
        if c.unresolved > 0 {
            "filled or left unresolved"
        } else {
            "finished"
        },
        c.left(),
        percent(c.left(), c.mirror),
        100.0 * WARN_SHARE
    );
    let inward = inward_reflectors(scene);
    let cause = if !inward.is_empty() {
        format!(
            "likely cause: the vertex normals of reflector {} point inward (as some exporters \
             write them); flip them (negate the OBJ's `vn` lines) or export with outward normals",
            inward.join(", ")
        )
    } else {
        match method {
            Method::Ssr => "likely cause: the method's known limit: --method ssr finds only what \
                the frame shows, so rays that leave the screen, point towards the camera or pass \
                behind a visible surface go to the fallback (--method compute traces them)"
                .into(),
            Method::ReflectionPoint => "likely cause: the method's known limit: --method \
                reflection-point draws the reflections of the other objects' vertices, and mirror \
                pixels no reflected triangle covers go to the fallback (--subdivide N adds \
                vertices)"
                .into(),
            _ if c.start_hits * 2 > c.left() => format!(
                "likely cause: the reflector sees itself ({} of these rays meet the mirror they \
                 leave, which the CMOs do not capture: the reflector check hands them to the \
                 fallback)",
                c.start_hits
            ),
            _ => "likely causes: the CMOs do not see what these rays hit: a CMO centre placed \
                  away from the reflector or behind other geometry, or too few CMOs for its \
                  extent (try [cmo] placement = \"auto\" in the scene file, or --cmos N); or the \
                  reflector's normals facing inward"
                .into(),
        }
    };
    Some(format!("{head}; {cause}"))
}

/// The reflectors whose vertex normals point into the solid they bound: closed meshes (every
/// edge of the welded positions shared by exactly two triangles) whose volume, each triangle
/// oriented by its vertex normals, is negative. Open meshes (a flat mirror, a bowl, whose
/// concave side a mirror may well face) are never named.
pub fn inward_reflectors(scene: &Scene) -> Vec<String> {
    scene
        .meshes
        .iter()
        .filter(|m| m.reflector)
        .filter(|m| {
            let matrix = m.transform.matrix();
            let normal = m.transform.normal_matrix();
            let mut positions = Vec::new();
            let mut normals = Vec::new();
            let mut triangles = Vec::new();
            for part in &m.parts {
                let base = positions.len() as u32;
                positions.extend(part.positions.iter().map(|&p| matrix.transform_point3(p)));
                normals.extend(part.normals.iter().map(|&n| normal * n));
                triangles.extend(part.triangles.iter().map(|t| t.map(|i| i + base)));
            }
            normals_point_inward(&positions, &normals, &triangles)
        })
        .map(|m| format!("'{}'", m.name))
        .collect()
}

/// Whether a closed mesh's vertex normals point inward (see [`inward_reflectors`]); false for
/// an open mesh or one without volume.
pub fn normals_point_inward(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    if triangles.is_empty() || !is_closed(positions, triangles) {
        return false;
    }
    let centre = positions.iter().map(|p| p.as_dvec3()).sum::<DVec3>() / positions.len() as f64;
    let volume: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3() - centre);
            let cross = (b - a).cross(c - a);
            let shading: DVec3 = t.iter().map(|&i| normals[i as usize].as_dvec3()).sum();
            let side = if cross.dot(shading) < 0.0 { -1.0 } else { 1.0 };
            side * a.dot(b.cross(c))
        })
        .sum();
    volume < 0.0
}

/// Whether every edge of the mesh, its vertices welded by position (to 1e-6 of the largest
/// coordinate magnitude: exporters write a seam's vertices twice, a rounding apart), has
/// exactly two triangles.
fn is_closed(positions: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    use std::collections::HashMap;
    let magnitude = positions
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0f32, f32::max);
    let grid = f64::from(magnitude.max(f32::MIN_POSITIVE)) * 1e-6;
    let mut weld: HashMap<[i64; 3], u32> = HashMap::new();
    let ids: Vec<u32> = positions
        .iter()
        .map(|p| {
            let next = weld.len() as u32;
            let key = p.as_dvec3().to_array().map(|c| (c / grid).round() as i64);
            *weld.entry(key).or_insert(next)
        })
        .collect();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * triangles.len());
    for t in triangles {
        let v = t.map(|i| ids[i as usize]);
        for (a, b) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
            if a == b {
                continue;
            }
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    !edges.is_empty() && edges.values().all(|&n| n == 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed octahedron with outward normals is not named; the same with negated normals is;
    /// an open half (a bowl-like cap) with either is not.
    #[test]
    fn inward_normals_of_closed_meshes_only() {
        let positions = vec![
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ];
        let outward = positions.clone();
        let inward: Vec<Vec3> = positions.iter().map(|&p| -p).collect();
        let mut triangles = Vec::new();
        for &(x, y) in &[(0, 2), (2, 1), (1, 3), (3, 0)] {
            triangles.push([x, y, 4]);
            triangles.push([y, x, 5]);
        }
        assert!(!normals_point_inward(&positions, &outward, &triangles));
        assert!(normals_point_inward(&positions, &inward, &triangles));
        // The winding does not matter: the normals decide.
        let reversed: Vec<[u32; 3]> = triangles.iter().map(|t| [t[0], t[2], t[1]]).collect();
        assert!(normals_point_inward(&positions, &inward, &reversed));
        assert!(!normals_point_inward(&positions, &outward, &reversed));
        // Negative: open (the top half only), neither orientation is named.
        let top: Vec<[u32; 3]> = triangles.iter().copied().filter(|t| t[2] == 4).collect();
        assert!(!normals_point_inward(&positions, &inward, &top));
        assert!(!normals_point_inward(&positions, &outward, &top));
    }

    #[test]
    fn the_warning_needs_the_threshold_and_names_the_cause() {
        let scene = crate::scene::builtin::by_name("default").unwrap();
        let count = |left: usize| FallbackCount {
            mirror: 1000,
            traced: left,
            unresolved: 0,
            start_hits: 0,
        };
        let at = (WARN_SHARE * 1000.0) as usize;
        assert!(fallback_warning(Method::Compute, &scene, &count(at)).is_none());
        let w = fallback_warning(Method::Compute, &scene, &count(at + 1)).unwrap();
        assert!(w.contains("CMO") && w.contains("--cmos"), "{w}");
        let w = fallback_warning(Method::Ssr, &scene, &count(800)).unwrap();
        assert!(
            w.contains("known limit") && w.contains("--method ssr"),
            "{w}"
        );
        // Negative: methods that cannot leave a pixel to the fallback never warn.
        assert!(fallback_warning(Method::Bvh, &scene, &count(1000)).is_none());
        assert!(
            counts(Method::Compute, &count(320)).contains("320 finished by the fallback (32.0%)")
        );
    }
}

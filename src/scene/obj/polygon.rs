//! A polygon split into triangles: convex ones fanned, others ear-clipped in the plane of their
//! Newell normal, after the corners that do not turn are left out ([`triangulate`]).

use glam::{DVec2, Vec3};

/// Splits a polygon into triangles, as index triples into `points`, all wound as the polygon.
/// Convex polygons are fanned from their first corner; others are ear-clipped in the plane of
/// their Newell normal. Errs (with the reason) on a polygon that no triangulation covers
/// exactly: a self-intersecting one.
pub(crate) fn triangulate(points: &[Vec3]) -> Result<Vec<[usize; 3]>, String> {
    if points.len() <= 3 {
        return triangulate_turning(points);
    }
    // Corners on the line of their neighbours (CAD and Blender n-gons hold them) would make
    // triangles of aspect up to 1e16; the polygon is the same without them.
    let kept = turning_corners(points);
    if kept.len() < 3 {
        return Ok(Vec::new());
    }
    let sub: Vec<Vec3> = kept.iter().map(|&i| points[i]).collect();
    Ok(triangulate_turning(&sub)?
        .into_iter()
        .map(|t| t.map(|k| kept[k]))
        .collect())
}

/// A corner whose two edges make an angle with sine at most this with one line adds no area
/// that f32 keeps to its polygon: [`turning_corners`] leaves it out.
const COLLINEAR_SINE: f64 = 1e-5;

/// The corners of a polygon that turn, in order: each corner whose edges to its kept
/// neighbours lie on one line within [`COLLINEAR_SINE`] (a point on an edge, a repeated
/// corner, a zero-area spike) is left out, again until none is (or fewer than 3 are kept). The
/// surface moves by at most that sine times the edges' length, far below a pixel.
fn turning_corners(points: &[Vec3]) -> Vec<usize> {
    let mut kept: Vec<usize> = (0..points.len()).collect();
    let mut i = 0;
    let mut since_removal = 0;
    while kept.len() >= 3 && since_removal < kept.len() {
        let n = kept.len();
        let [a, b, c] = [(i + n - 1) % n, i, (i + 1) % n].map(|k| points[kept[k]].as_dvec3());
        let (e1, e2) = (b - a, c - b);
        if e1.cross(e2).length() <= COLLINEAR_SINE * e1.length() * e2.length() {
            kept.remove(i);
            since_removal = 0;
            i = i.checked_sub(1).unwrap_or(kept.len().saturating_sub(1));
        } else {
            since_removal += 1;
            i = (i + 1) % n;
        }
    }
    kept
}

/// [`triangulate`] of a polygon whose corners all turn (or of at most 3 corners).
fn triangulate_turning(points: &[Vec3]) -> Result<Vec<[usize; 3]>, String> {
    let n = points.len();
    let fan = || (1..n.saturating_sub(1)).map(|i| [0, i, i + 1]).collect();
    if n <= 3 {
        return Ok(fan());
    }
    let p64: Vec<[f64; 3]> = points.iter().map(|p| p.as_dvec3().to_array()).collect();
    let mut flat: Vec<[f64; 2]> = Vec::with_capacity(n);
    if !earcut::utils3d::project3d_to_2d(&p64, n, &mut flat) {
        // No plane: either every corner is on one line (the fan's triangles have no area and
        // are dropped as degenerate), or the polygon crosses itself so that its halves cancel.
        let spread = (1..n - 1).any(|i| {
            let [a, b, c] = [0, i, i + 1].map(|k| points[k].as_dvec3());
            (b - a).cross(c - a).length_squared() > 0.0
        });
        return if spread {
            Err(format!(
                "the polygon of {n} vertices crosses itself (its signed area is zero)"
            ))
        } else {
            Ok(fan())
        };
    }
    let q: Vec<DVec2> = flat.iter().map(|&p| DVec2::from_array(p)).collect();
    let signed = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - a);
    let area: f64 = (1..n - 1).map(|i| signed(q[0], q[i], q[i + 1])).sum();
    let s = if area < 0.0 { -1.0 } else { 1.0 };
    // Convex: every corner turns the same way, and the turns add up to one full turn.
    let mut turning = 0.0;
    let mut convex = true;
    for i in 0..n {
        let (a, b, c) = (q[i], q[(i + 1) % n], q[(i + 2) % n]);
        let (e1, e2) = (b - a, c - b);
        let cross = s * e1.perp_dot(e2);
        if cross < 0.0 {
            convex = false;
            break;
        }
        turning += cross.atan2(e1.dot(e2));
    }
    if convex && (turning - std::f64::consts::TAU).abs() < 1e-6 {
        return Ok(fan());
    }
    let mut idx: Vec<u32> = Vec::new();
    earcut::Earcut::new().earcut(flat.iter().copied(), &[] as &[u32], &mut idx);
    let mut out = Vec::with_capacity(idx.len() / 3);
    let mut covered = 0.0;
    for t in idx.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|k| k as usize);
        let tri_area = signed(q[a], q[b], q[c]);
        covered += tri_area.abs();
        out.push(if tri_area * s < 0.0 {
            [a, c, b]
        } else {
            [a, b, c]
        });
    }
    let tolerance = 1e-6 * area.abs().max(covered).max(f64::MIN_POSITIVE);
    if (covered - area.abs()).abs() > tolerance {
        return Err(format!(
            "the polygon of {n} vertices crosses itself (its triangles cover {covered:.6e}, \
             its signed area is {area:.6e})"
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Area of the triangles, and whether each is wound like the polygon (normal along +z for
    /// the counter-clockwise test polygons in the xy plane).
    fn cover(points: &[Vec3], tris: &[[usize; 3]]) -> (f32, bool) {
        let mut area = 0.0;
        let mut wound = true;
        for t in tris {
            let [a, b, c] = t.map(|k| points[k]);
            let n = (b - a).cross(c - a);
            area += 0.5 * n.length();
            wound &= n.z >= 0.0;
        }
        (area, wound)
    }

    /// The largest ratio of a triangle's longest edge to its height on that edge.
    fn worst_aspect(points: &[Vec3], tris: &[[usize; 3]]) -> f64 {
        tris.iter()
            .map(|t| {
                let [a, b, c] = t.map(|k| points[k].as_dvec3());
                let long = (b - a).length().max((c - b).length()).max((a - c).length());
                let area2 = (b - a).cross(c - a).length();
                long * long / area2
            })
            .fold(0.0, f64::max)
    }

    /// An L-shaped n-gon as CAD exporters write them: corners on its edges, nearly collinear
    /// (off the line by f32 rounding of printed decimals) and one repeated. Those corners are
    /// left out before ear clipping: the triangles cover the L's area with no sliver. Negative:
    /// a convex polygon with such a corner, fanned as written, makes a triangle of aspect
    /// above 1e7.
    #[test]
    fn collinear_corners_are_left_out_before_ear_clipping() {
        let l: Vec<Vec3> = [
            (0., 0.),
            (0.7, 0.0),
            (1.3, 1e-7),
            (2., 0.),
            (2., 0.4),
            (2., 1.),
            (1., 1.),
            (1., 1.),
            (1., 1.5),
            (1., 2.),
            (0.5, 2.),
            (0., 2.),
            (0., 0.9),
        ]
        .map(|(x, y)| Vec3::new(x, y, 0.0))
        .to_vec();
        for shift in 0..l.len() {
            let mut p = l.clone();
            p.rotate_left(shift);
            let tris = triangulate(&p).unwrap();
            let (area, wound) = cover(&p, &tris);
            assert!((area - 3.0).abs() < 1e-5, "shift {shift}: area {area}");
            assert!(wound, "shift {shift}");
            assert_eq!(tris.len(), 4, "shift {shift}: {tris:?}");
            let aspect = worst_aspect(&p, &tris);
            assert!(aspect < 10.0, "shift {shift}: aspect {aspect}");
        }
        let kept = turning_corners(&l);
        assert_eq!(kept, vec![0, 3, 5, 7, 9, 11], "{kept:?}");
        // A convex quad with a corner on its first edge, off the line by 1e-7 (convex, so
        // fanned from corner 0).
        let quad: Vec<Vec3> = [(0., 0.), (1., 0.), (2., 1e-7), (2., 1.), (0., 1.)]
            .map(|(x, y)| Vec3::new(x, y, 0.0))
            .to_vec();
        let tris = triangulate(&quad).unwrap();
        assert_eq!(tris.len(), 2);
        assert!(worst_aspect(&quad, &tris) < 10.0);
        let as_written = triangulate_turning(&quad).unwrap();
        let w = worst_aspect(&quad, &as_written);
        assert!(w > 1e7, "{w} {as_written:?}");
        // All corners on one line: no triangle.
        let line: Vec<Vec3> = (0..5).map(|k| Vec3::new(k as f32, 0.0, 0.0)).collect();
        assert!(triangulate(&line).unwrap().is_empty());
        // A sliver triangle as written is kept: it is geometry.
        let sliver = [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1e-6, 0.0)];
        assert_eq!(triangulate(&sliver).unwrap(), vec![[0, 1, 2]]);
    }

    #[test]
    fn triangulate_concave_and_convex() {
        // An L shape (area 3), its reflex corner at index 4: a fan from corner 0 would cover
        // area outside it.
        let l: Vec<Vec3> = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)]
            .map(|(x, y)| Vec3::new(x, y, 0.0))
            .to_vec();
        for shift in 0..l.len() {
            let mut p = l.clone();
            p.rotate_left(shift);
            let tris = triangulate(&p).unwrap();
            assert_eq!(tris.len(), 4);
            let (area, wound) = cover(&p, &tris);
            assert!((area - 3.0).abs() < 1e-5, "shift {shift}: area {area}");
            assert!(wound, "shift {shift}: a triangle is flipped");
        }
        // Negative: the fan of the L from its corner 2 covers more than the L.
        let mut p = l.clone();
        p.rotate_left(2);
        let fan: Vec<[usize; 3]> = (1..5).map(|i| [0, i, i + 1]).collect();
        assert!((cover(&p, &fan).0 - 3.0).abs() > 0.1);
        // Convex polygons are fanned from corner 0 (the same triangles as tobj).
        let hex: Vec<Vec3> = (0..6)
            .map(|k| {
                let a = k as f32 * std::f32::consts::TAU / 6.0;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert_eq!(
            triangulate(&hex).unwrap(),
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]
        );
        // Clockwise input stays clockwise.
        let mut cw = l.clone();
        cw.reverse();
        let tris = triangulate(&cw).unwrap();
        assert!(tris.iter().all(|t| {
            let [a, b, c] = t.map(|k| cw[k]);
            (b - a).cross(c - a).z <= 0.0
        }));
    }

    #[test]
    fn triangulate_refuses_self_intersecting() {
        // A bow tie with unequal lobes, and a pentagram (which winds twice).
        let bow: Vec<Vec3> = [(0., 0.), (2., 1.), (2., 0.), (0., 2.)]
            .map(|(x, y)| Vec3::new(x, y, 0.0))
            .to_vec();
        assert!(triangulate(&bow).is_err());
        let star: Vec<Vec3> = (0..5)
            .map(|k| {
                let a = (2 * k) as f32 * std::f32::consts::TAU / 5.0;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert!(triangulate(&star).is_err());
        // A symmetric bow tie: its signed area is zero.
        let sym: Vec<Vec3> = [(0., 0.), (1., 1.), (1., 0.), (0., 1.)]
            .map(|(x, y)| Vec3::new(x, y, 0.0))
            .to_vec();
        assert!(triangulate(&sym).is_err());
        // Collinear corners are not an error: their triangles are dropped as degenerate.
        let line: Vec<Vec3> = (0..4).map(|k| Vec3::new(k as f32, 0.0, 0.0)).collect();
        assert!(triangulate(&line).is_ok());
    }
}

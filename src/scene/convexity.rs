//! Whether a reflector can see itself.
//!
//! A reflected ray leaves a mirror on the side its normal points to. If every vertex of the
//! mesh lies on or behind the plane of every face (behind: against the face's normal), no face
//! has any part of the mesh in front of it, so no ray leaving the mesh can meet the mesh again:
//! it needs no self-capture. A closed convex mesh with outward normals passes; so does a flat
//! mirror. A torus, a bowl's concave side or a teapot's spout facing its body fail.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Relative tolerance of the plane test: a vertex counts as on a face's plane within this
/// fraction of the mesh's largest coordinate magnitude (f32 positions carry about 6e-8 of it;
/// tessellated analytic surfaces are exact to far less than this).
const RELATIVE_TOLERANCE: f64 = 1e-5;

/// Whether no face of the mesh (`positions`, `normals` one per position, `triangles`) can see
/// another: every vertex lies on or behind every face's plane, within a tolerance of
/// `RELATIVE_TOLERANCE` times the largest coordinate magnitude. A face's front is the side of
/// its geometric normal that agrees with its vertex normals (the side a mirror reflects to), so
/// the winding order does not matter ([`is_convex_front`] turns it round). Degenerate faces (no area) are skipped; a mesh without a
/// face is convex.
pub fn is_convex(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    analyse(positions, normals, triangles).0
}

/// [`is_convex`] with every face's front turned round where `turned` (a mesh whose normals
/// point into it, [`normals_inward`], seen from outside: its front is its outside).
pub fn is_convex_front(
    positions: &[Vec3],
    normals: &[Vec3],
    triangles: &[[u32; 3]],
    turned: bool,
) -> bool {
    let (as_is, _, turned_round) = analyse(positions, normals, triangles);
    if turned { turned_round } else { as_is }
}

/// [`analyse`]'s answer: `(is_convex, normals_inward, is_convex_front turned)`.
type Analysis = (bool, bool, bool);

/// `(is_convex, normals_inward, is_convex with the fronts turned round)`, kept per mesh
/// content: a scene asks this of each reflector several times per frame (every
/// `Scene::world`, the reflector check's bound). The last is only computed for a mesh whose
/// normals point inward (else it is the first).
fn analyse(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> Analysis {
    let key = content_key(positions, normals, triangles);
    if let Some(&(_, answer)) = lock_memo().iter().find(|(k, _)| *k == key) {
        return answer;
    }
    let as_is = faces_see_nothing(positions, normals, triangles, true, false);
    let inward = test_inward(positions, normals, triangles);
    let turned = if inward {
        faces_see_nothing(positions, normals, triangles, true, true)
    } else {
        as_is
    };
    let answer = (as_is, inward, turned);
    let mut memo = lock_memo();
    if memo.len() >= MEMO_ENTRIES {
        memo.remove(0);
    }
    memo.push((key, answer));
    answer
}

/// Meshes whose [`is_convex`] answer is kept (the oldest is dropped first).
const MEMO_ENTRIES: usize = 64;

/// [`is_convex`]'s answers by [`content_key`].
static MEMO: std::sync::Mutex<Vec<(u128, Analysis)>> = std::sync::Mutex::new(Vec::new());

fn lock_memo() -> std::sync::MutexGuard<'static, Vec<(u128, Analysis)>> {
    // A panic elsewhere while holding the lock leaves a valid list (push / remove only).
    MEMO.lock().unwrap_or_else(|e| e.into_inner())
}

/// The 128-bit XXH3 hash of the mesh's bits (positions, normals, triangles, each list after its
/// length), streamed as three byte slices: the key of [`MEMO`]. A scene asks for it several
/// times per frame and per placement search, so it must cost little beside the mesh's own
/// transform (two SipHashes fed one coordinate at a time were the largest item in a profile of
/// blender-mtl's search).
fn content_key(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> u128 {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    for list in [positions, normals] {
        h.update(&(list.len() as u64).to_le_bytes());
        h.update(bytemuck::cast_slice(list));
    }
    h.update(&(triangles.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(triangles));
    h.digest128()
}

/// Whether the vertex normals of a closed mesh point into it (common in exported files): the
/// mesh is closed (every edge, its ends welded by position as `weld` does, belongs to
/// exactly two faces) and the volume its faces enclose,
/// each face turned to the side its vertex normals agree with (as [`is_convex`] turns it), is
/// negative. A mirror reflects on the side the ray comes from, whatever its normals say, and a
/// camera outside a closed mesh sees only its outside: `Scene::front_turned` then takes the
/// outside as a reflector's front (for [`is_convex_front`] and the capture's "faces the
/// centre"), unless a camera lies inside ([`encloses`]: a mirror room). False for an open mesh
/// (a bowl, a flat mirror), whose normals alone say which side is the mirror, and for a mesh
/// without a face.
pub fn normals_inward(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    analyse(positions, normals, triangles).1
}

/// [`normals_inward`] without the memo.
fn test_inward(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    let id = weld(positions);
    let mut edges: std::collections::HashMap<(u32, u32), u32> = Default::default();
    let mut volume = 0.0f64;
    for t in triangles {
        let [i, j, k] = t.map(|v| id[v as usize]);
        if i == j || j == k || k == i {
            continue;
        }
        for (u, v) in [(i, j), (j, k), (k, i)] {
            *edges.entry((u.min(v), u.max(v))).or_insert(0) += 1;
        }
        let [a, b, c] = t.map(|v| positions[v as usize].as_dvec3());
        let cross = (b - a).cross(c - a);
        let shading: DVec3 = t.iter().map(|&v| normals[v as usize].as_dvec3()).sum();
        let sign = if cross.dot(shading) < 0.0 { -1.0 } else { 1.0 };
        volume += sign * a.dot(cross);
    }
    !edges.is_empty() && edges.values().all(|&n| n == 2) && volume < 0.0
}

/// Whether `point` lies inside the closed mesh: an odd number of its triangles cross a ray
/// from `point` in a fixed direction that no axis-aligned or diagonal face contains (f64
/// Möller–Trumbore, `t > 0`).
pub fn encloses(positions: &[Vec3], triangles: &[[u32; 3]], point: Vec3) -> bool {
    let o = point.as_dvec3();
    let d = DVec3::new(0.577_215_664_9, 0.618_033_988_7, 0.532_088_886_2).normalize();
    let crossings = triangles
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
            let (e1, e2) = (b - a, c - a);
            let p = d.cross(e2);
            let det = e1.dot(p);
            if det == 0.0 {
                return false;
            }
            let s = o - a;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = d.dot(q) / det;
            let t = e2.dot(q) / det;
            u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0
        })
        .count();
    crossings % 2 == 1
}

/// f32 rounding steps of the largest coordinate within which [`weld`] joins positions, however
/// small the mesh is against its distance from the origin.
const WELD_ULPS: f64 = 8.0;

/// One id per position, equal for positions within [`RELATIVE_TOLERANCE`] of the mesh's extent
/// (or [`WELD_ULPS`] rounding steps of its largest coordinate, if more) of each other (per
/// coordinate; the first such position names the group): a UV sphere's seam and poles, whose
/// copies differ by rounding, become one vertex. The extent, not the distance from the origin,
/// sets the scale: a sphere moved 1e5 away must not weld into a few points.
fn weld(positions: &[Vec3]) -> Vec<u32> {
    let points: Vec<DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
    let magnitude = points
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0f64, f64::max);
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let extent = (hi - lo).max_element().max(0.0);
    let g = (RELATIVE_TOLERANCE * extent)
        .max(WELD_ULPS * f64::from(f32::EPSILON) * magnitude)
        .max(f64::MIN_POSITIVE);
    let cell = |p: DVec3| (p / g).floor().as_i64vec3();
    let mut grid: std::collections::HashMap<glam::I64Vec3, Vec<u32>> = Default::default();
    let mut id = Vec::with_capacity(points.len());
    for (k, &p) in points.iter().enumerate() {
        let c = cell(p);
        let mut found = None;
        'search: for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let key = c + glam::I64Vec3::new(dx, dy, dz);
                    for &q in grid.get(&key).map(Vec::as_slice).unwrap_or(&[]) {
                        if (points[q as usize] - p).abs().max_element() <= g {
                            found = Some(id[q as usize]);
                            break 'search;
                        }
                    }
                }
            }
        }
        match found {
            Some(i) => id.push(i),
            None => {
                id.push(k as u32);
                grid.entry(c).or_default().push(k as u32);
            }
        }
    }
    id
}

/// The test itself; with `tree` false, every face against every vertex (the definition, which the
/// tests compare the tree with).
fn faces_see_nothing(
    positions: &[Vec3],
    normals: &[Vec3],
    triangles: &[[u32; 3]],
    tree: bool,
    inward: bool,
) -> bool {
    let points: Vec<DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
    let magnitude = points
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0f64, f64::max);
    let tolerance = RELATIVE_TOLERANCE * magnitude.max(f64::MIN_POSITIVE);
    let tree = tree.then(|| {
        let normals: Vec<DVec3> = normals.iter().map(|n| n.as_dvec3()).collect();
        PointTree::new(&points, &normals, magnitude)
    });
    let bar = progress_bar(triangles.len());
    let face_sees_nothing = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| points[i as usize]);
        let cross = (b - a).cross(c - a);
        let Some(mut n) = cross.try_normalize() else {
            return true;
        };
        let shading: DVec3 = t.iter().map(|&i| normals[i as usize].as_dvec3()).sum();
        // The front: the side the vertex normals agree with, the other where they point inward.
        if (n.dot(shading) < 0.0) != inward {
            n = -n;
        }
        match &tree {
            Some(tree) => tree.all_behind(n, a, tolerance),
            None => points.iter().all(|&p| n.dot(p - a) <= tolerance),
        }
    };
    let convex = triangles.par_chunks(PROGRESS_CHUNK).all(|chunk| {
        let all = chunk.iter().all(face_sees_nothing);
        bar.inc(chunk.len() as u64);
        all
    });
    bar.finish_and_clear();
    convex
}

/// Faces from which [`is_convex`] shows its progress (on a terminal; hidden elsewhere): a
/// finely tessellated convex mesh costs about a second per 100k faces on one core (each face
/// visits the tree's leaves near its plane: O(sqrt(vertices)) of them on a smooth surface).
pub const PROGRESS_FACES: usize = 100_000;

/// Faces per step of the progress bar.
const PROGRESS_CHUNK: usize = 4096;

/// The progress bar of a test of `faces` faces: hidden under [`PROGRESS_FACES`].
fn progress_bar(faces: usize) -> indicatif::ProgressBar {
    if faces < PROGRESS_FACES {
        return indicatif::ProgressBar::hidden();
    }
    indicatif::ProgressBar::new(faces as u64).with_style(
        indicatif::ProgressStyle::with_template(
            "reflector convexity {bar:40} {pos}/{len} faces {elapsed}",
        )
        .expect("the template is valid"),
    )
}

/// Points in a bounding-box tree, for [`is_convex`]'s question "is every point on or behind this
/// plane?" without testing every point against every face (O(faces x vertices): minutes for a
/// 100k-triangle convex mesh, whose faces all pass). The answer is exactly the point-by-point
/// one: a box is passed over only where its farthest corner is behind the plane by more than
/// the rounding of the two computations ([`PointTree::MARGIN`]); everything else is decided by
/// `n.dot(p - a) <= tolerance` point by point.
///
/// Each node has two boxes, and the lower reach of the two decides: its axis-aligned box and a
/// box in a frame whose first axis is its points' mean vertex normal. On a smooth surface a
/// patch's box along its own normal is as thin as the patch is curved, so a face's plane passes
/// over every patch but the few next to it: O(log n) nodes per face. With axis-aligned boxes
/// alone a patch of side s near the face's plane reaches s above it, and every patch within
/// sqrt(2 s r) of the face had to be opened: O(sqrt(n)) points per face, O(n^1.5) in all (24 s
/// of the 2M-triangle sphere).
struct PointTree {
    /// The points, reordered so that every node's are contiguous.
    points: Vec<DVec3>,
    /// Their vertex normals, in the same order (for the nodes' frames only).
    normals: Vec<DVec3>,
    /// Nodes; node 0 is the root, a node's children are `first_child` and `first_child + 1`.
    nodes: Vec<TreeNode>,
    /// `MARGIN` times the largest coordinate magnitude.
    margin: f64,
}

struct TreeNode {
    centre: DVec3,
    half: DVec3,
    /// The oriented box: orthonormal axes (the first the mean normal), the points' middle
    /// along them (in world space) and the half extents along each.
    axes: [DVec3; 3],
    frame_centre: DVec3,
    frame_half: DVec3,
    /// The node's points: `points[start..end]`.
    start: usize,
    end: usize,
    /// 0 for a leaf (the root is node 0, no one's child).
    first_child: usize,
}

impl TreeNode {
    const EMPTY: TreeNode = TreeNode {
        centre: DVec3::ZERO,
        half: DVec3::ZERO,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        frame_centre: DVec3::ZERO,
        frame_half: DVec3::ZERO,
        start: 0,
        end: 0,
        first_child: 0,
    };
}

impl PointTree {
    /// Points per leaf.
    const LEAF: usize = 16;
    /// Relative margin for skipping a box: f64 dot products of vectors within twice the largest
    /// magnitude err by under 1e-15 of it, so 1e-12 leaves a wide berth.
    const MARGIN: f64 = 1e-12;

    fn new(points: &[DVec3], normals: &[DVec3], magnitude: f64) -> Self {
        let mut tree = PointTree {
            points: points.to_vec(),
            normals: normals.to_vec(),
            nodes: Vec::new(),
            margin: Self::MARGIN * magnitude,
        };
        if !points.is_empty() {
            tree.nodes.push(TreeNode::EMPTY);
            tree.build(0, 0, points.len());
        }
        tree
    }

    /// Fills node `slot` with `points[start..end]` and builds its subtree (children in pairs).
    fn build(&mut self, slot: usize, start: usize, end: usize) {
        let (lo, hi) = self.points[start..end]
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        let (axes, frame_centre, frame_half) = self.oriented_box(start, end);
        let mut node = TreeNode {
            centre: (lo + hi) * 0.5,
            half: (hi - lo) * 0.5,
            axes,
            frame_centre,
            frame_half,
            start,
            end,
            first_child: 0,
        };
        if end - start > Self::LEAF {
            let extent = hi - lo;
            let axis = if extent.x >= extent.y && extent.x >= extent.z {
                0
            } else if extent.y >= extent.z {
                1
            } else {
                2
            };
            let mid = start + (end - start) / 2;
            // Points and normals move together: sort their indices, then apply.
            let mut order: Vec<usize> = (start..end).collect();
            let points = &self.points;
            order.select_nth_unstable_by(mid - start, |&p, &q| {
                points[p][axis].total_cmp(&points[q][axis])
            });
            let moved: Vec<(DVec3, DVec3)> = order
                .iter()
                .map(|&k| (self.points[k], self.normals[k]))
                .collect();
            for (k, (p, n)) in moved.into_iter().enumerate() {
                self.points[start + k] = p;
                self.normals[start + k] = n;
            }
            node.first_child = self.nodes.len();
            self.nodes.push(TreeNode::EMPTY);
            self.nodes.push(TreeNode::EMPTY);
            self.build(node.first_child, start, mid);
            self.build(node.first_child + 1, mid, end);
        }
        self.nodes[slot] = node;
    }

    /// The oriented box of `points[start..end]`: the mean of their normals as the first axis
    /// (the world's axes where the normals cancel out or are not numbers), the points' middle
    /// and half extents along the axes.
    fn oriented_box(&self, start: usize, end: usize) -> ([DVec3; 3], DVec3, DVec3) {
        let mean: DVec3 = self.normals[start..end].iter().sum();
        let axes = match mean.try_normalize() {
            Some(m) => {
                let (u, v) = m.any_orthonormal_pair();
                [m, u, v]
            }
            None => [DVec3::X, DVec3::Y, DVec3::Z],
        };
        let (lo, hi) = self.points[start..end].iter().fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY),
            |(lo, hi), &p| {
                let q = DVec3::new(axes[0].dot(p), axes[1].dot(p), axes[2].dot(p));
                (lo.min(q), hi.max(q))
            },
        );
        let mid = (lo + hi) * 0.5;
        let centre = axes[0] * mid.x + axes[1] * mid.y + axes[2] * mid.z;
        (axes, centre, (hi - lo) * 0.5)
    }

    /// Whether every point `p` has `n.dot(p - a) <= tolerance`.
    fn all_behind(&self, n: DVec3, a: DVec3, tolerance: f64) -> bool {
        self.behind_counting(n, a, tolerance, true).0
    }

    /// [`PointTree::all_behind`], and how many points it tested one by one; `oriented` false
    /// uses the axis-aligned boxes alone (the tests' comparison).
    fn behind_counting(&self, n: DVec3, a: DVec3, tolerance: f64, oriented: bool) -> (bool, usize) {
        let mut tested = 0;
        if self.nodes.is_empty() {
            return (true, tested);
        }
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i];
            // Each box's farthest point along n: its centre plus the half extents' reach.
            let aligned = n.dot(node.centre - a) + n.abs().dot(node.half);
            let reach = if oriented {
                let along = DVec3::new(
                    n.dot(node.axes[0]).abs(),
                    n.dot(node.axes[1]).abs(),
                    n.dot(node.axes[2]).abs(),
                );
                aligned.min(n.dot(node.frame_centre - a) + along.dot(node.frame_half))
            } else {
                aligned
            };
            if reach + self.margin <= tolerance {
                continue;
            }
            if node.first_child == 0 {
                tested += node.end - node.start;
                if !self.points[node.start..node.end]
                    .iter()
                    .all(|&p| n.dot(p - a) <= tolerance)
                {
                    return (false, tested);
                }
            } else {
                stack.push(node.first_child);
                stack.push(node.first_child + 1);
            }
        }
        (true, tested)
    }
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

    #[test]
    fn the_memo_key_tells_every_bit_of_the_mesh() {
        let p = vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 0.5, 0.0), Vec3::Z];
        let n = vec![Vec3::Y; 3];
        let t = vec![[0u32, 1, 2]];
        let key = content_key(&p, &n, &t);
        assert_eq!(key, content_key(&p.clone(), &n.clone(), &t.clone()));
        // One bit of a position, a normal or an index; a zero's sign; an element moved from one
        // list to the next (the lengths are hashed too).
        let mut q = p.clone();
        q[1].x = f32::from_bits(q[1].x.to_bits() ^ 1);
        let mut m = n.clone();
        m[2].y += f32::EPSILON;
        let mut z = p.clone();
        z[1].z = -0.0;
        let others = [
            content_key(&q, &n, &t),
            content_key(&p, &m, &t),
            content_key(&p, &n, &[[0, 2, 1]]),
            content_key(&z, &n, &t),
            content_key(
                &p[..2],
                &[p[2]].iter().chain(&n).copied().collect::<Vec<_>>(),
                &t,
            ),
        ];
        for (i, k) in others.iter().enumerate() {
            assert_ne!(*k, key, "change {i}");
        }
    }

    fn convex(part: &crate::scene::MeshPart) -> bool {
        is_convex(&part.positions, &part.normals, &part.triangles)
    }

    /// The corners of the unit square in the z = 0 plane, counter-clockwise from the origin.
    fn unit_quad() -> Vec<Vec3> {
        vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    /// A flat quad with its face normal has no deviation; tilting one vertex normal by a known
    /// angle shows exactly that angle.
    #[test]
    fn normal_deviation_of_a_flat_quad() {
        let positions = unit_quad();
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
        let positions = unit_quad();
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

    /// The tree gives the point-by-point answer: on convex and non-convex meshes, and on a
    /// sphere whose one vertex is moved out along its normal by amounts around the tolerance
    /// (just inside it the mesh is convex, just outside it is not), at two offsets from the
    /// origin.
    #[test]
    fn tree_agrees_with_the_point_by_point_test() {
        let check = |m: &crate::scene::MeshPart| {
            let fast = convex(m);
            let slow = faces_see_nothing(&m.positions, &m.normals, &m.triangles, false, false);
            assert_eq!(fast, slow);
            fast
        };
        let sphere = shapes::uv_sphere(1.0, 96, 48, 0);
        assert!(check(&sphere));
        assert!(!check(&shapes::torus(1.0, 0.35, 48, 16, 0)));
        assert!(!check(&shapes::bowl(2.0, 50.0, 32, 12, 0)));
        let k = sphere.positions.len() / 2 + 7;
        let mut verdicts = Vec::new();
        for offset in [Vec3::ZERO, Vec3::new(40.0, -25.0, 10.0)] {
            let moved: Vec<Vec3> = sphere.positions.iter().map(|&p| p + offset).collect();
            let magnitude = moved
                .iter()
                .map(|p| p.abs().max_element())
                .fold(0.0f32, f32::max);
            let tolerance = RELATIVE_TOLERANCE as f32 * magnitude;
            // Pushed out by multiples of the tolerance: the small pushes stay within it, the
            // large ones put the vertex in front of its neighbours' faces.
            for push in [0.0, 0.5, 1.0, 2.0, 8.0, 64.0, 512.0] {
                let mut m = sphere.clone();
                m.positions = moved.clone();
                m.positions[k] += sphere.normals[k] * (push * tolerance);
                verdicts.push(check(&m));
            }
        }
        // Both verdicts occur: the list spans the threshold.
        assert!(
            verdicts.contains(&true) && verdicts.contains(&false),
            "{verdicts:?}"
        );
    }

    /// Points tested one by one per face of a convex sphere, at two tessellations 16 times
    /// apart in vertices: with the oriented boxes about the same (O(log n) nodes per face;
    /// measured 52 -> 76); with axis-aligned boxes alone (the negative) about sqrt(16) = 4
    /// times more (measured 113 -> 539).
    #[test]
    fn tests_per_face_stay_flat_as_the_sphere_gets_finer() {
        let per_face = |m: &crate::scene::MeshPart, oriented: bool| {
            let points: Vec<DVec3> = m.positions.iter().map(|p| p.as_dvec3()).collect();
            let normals: Vec<DVec3> = m.normals.iter().map(|n| n.as_dvec3()).collect();
            let tree = PointTree::new(&points, &normals, 1.0);
            let mut tested = 0;
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| points[i as usize]);
                let Some(mut n) = (b - a).cross(c - a).try_normalize() else {
                    continue;
                };
                if n.dot(normals[t[0] as usize]) < 0.0 {
                    n = -n;
                }
                let (behind, k) = tree.behind_counting(n, a, RELATIVE_TOLERANCE, oriented);
                assert!(behind, "the sphere is convex");
                tested += k;
            }
            tested as f64 / m.triangles.len() as f64
        };
        let coarse = shapes::uv_sphere(1.0, 64, 32, 0);
        let fine = shapes::uv_sphere(1.0, 256, 128, 0);
        let (oc, of) = (per_face(&coarse, true), per_face(&fine, true));
        let (ac, af) = (per_face(&coarse, false), per_face(&fine, false));
        eprintln!("points per face: oriented {oc:.1} -> {of:.1}, axis-aligned {ac:.1} -> {af:.1}");
        assert!(of < 2.0 * oc, "oriented: {oc} -> {of}");
        // Negative: the axis-aligned boxes alone grow with the tessellation.
        assert!(af > 3.0 * ac, "axis-aligned: {ac} -> {af}");
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

    /// A closed mesh whose vertex normals point inward (as some exporters write them) is told apart
    /// from one whose normals point outward, and stays convex (the outside is its front); an open
    /// mesh (the bowl) is never "inward", either way round, and stays non-convex with its mirror
    /// side's normals. Negatives: the outward sphere, the bowl with its normals negated.
    #[test]
    fn inward_normals_of_a_closed_mesh() {
        let sphere = shapes::uv_sphere(1.0, 32, 16, 0);
        let mut flipped = sphere.clone();
        for n in &mut flipped.normals {
            *n = -*n;
        }
        assert!(!normals_inward(
            &sphere.positions,
            &sphere.normals,
            &sphere.triangles
        ));
        assert!(normals_inward(
            &flipped.positions,
            &flipped.normals,
            &flipped.triangles
        ));
        assert!(convex(&sphere) && !convex(&flipped));
        let front = |m: &crate::scene::MeshPart| {
            is_convex_front(&m.positions, &m.normals, &m.triangles, true)
        };
        assert!(front(&flipped));
        assert!(encloses(
            &sphere.positions,
            &sphere.triangles,
            Vec3::new(0.1, 0.2, 0.3)
        ));
        assert!(!encloses(
            &sphere.positions,
            &sphere.triangles,
            Vec3::new(0.1, 2.0, 0.3)
        ));
        // Without the orientation, the flipped sphere's faces would all see each other.
        assert!(!faces_see_nothing(
            &flipped.positions,
            &flipped.normals,
            &flipped.triangles,
            false,
            false
        ));
        let bowl = shapes::bowl(2.0, 50.0, 32, 12, 0);
        let mut back = bowl.clone();
        for n in &mut back.normals {
            *n = -*n;
        }
        assert!(!normals_inward(
            &bowl.positions,
            &bowl.normals,
            &bowl.triangles
        ));
        assert!(!normals_inward(
            &back.positions,
            &back.normals,
            &back.triangles
        ));
        assert!(!convex(&bowl));
    }
}

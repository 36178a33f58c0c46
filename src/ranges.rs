#![forbid(unsafe_code)]
//! Depth ranges and ray length of a GPU frame, derived from the geometry the camera and the
//! CMOs see, and the check that f32 can hold the scene ([`FrameRanges::check`]).
//!
//! - **G-buffer**: reversed depth with no far plane ([`crate::camera::Camera::proj`]), so a
//!   D32_SFLOAT buffer keeps f32's relative precision (2^-24) at every distance and only the near
//!   plane clips. It is half the distance from the eye to the nearest triangle, times the cosine
//!   of the frame's corner angle: nothing the camera can see is clipped, whatever the scene's
//!   far extent.
//! - **Capture**: the same reversed depth along each face axis; its near plane is half the
//!   distance from the CMO centres to the nearest captured triangle over `sqrt 3` (a point at
//!   distance `d` from a centre lies at least `d / sqrt 3` along the axis of the face that sees
//!   it).
//! - **Ray length** `t_hi`: the scene's bounding-box diagonal, 1% to spare (a ray starting
//!   inside the box has left it by then).
//!
//! Where nothing bounds a near plane (the eye or a CMO centre on a triangle) it is the scene's
//! far extent (at least 1) times 2^-100: the near plane and the depth `near / z` stay normal f32
//! at every distance, and no geometry is clipped. (It was the far extent times 2^-40, which
//! with a vertex at 1e13 put the near plane 9 units out and clipped the whole room; the
//! triangles that touch the eye lie in planes through it, which the passes cull:
//! `spirv/shared/eye_plane.wgsl`.)
//!
//! # Viewpoints in a surface's plane
//! A triangle whose plane holds the eye (or a CMO centre) is seen edge-on: the reference meets
//! it at `t = 0` only and never shows it. The rasteriser sees it through rounded vertices whose
//! plane misses the eye by a rounding error and, seen from there, drew it over half the frame
//! (the built-in `default` camera lies in the front wall's plane: 0 mirror pixels for a target
//! at z = -2e4). The G-buffer and capture passes cull such triangles
//! (`spirv/shared/eye_plane.wgsl`). The bound is on the distance from the plane itself, through
//! a well-conditioned normal ([`crate::camera::plane_normal`]): a sliver triangle, whose
//! corners nearly share a line, is culled only where its plane really passes within rounding
//! of the viewpoint, and then covers about a pixel in the reference too. A viewpoint within
//! that bound of a triangle itself (on the surface, to rounding) but off its plane in f64 sees
//! it over half the frame in the reference where the passes cull it: no pass in f32 can
//! render that, so it is refused ([`RangeError::EdgeOn`], naming the triangle and the distance
//! to move). A CMO centre in the plane of a surface it captures is refused too (the precision
//! check, its nearest surface at distance ~0): the CMO cannot capture that surface, and mirror
//! rays may still meet it. Both CMO checks refuse only a method that captures CMOs.
//!
//! # What f32 cannot hold
//! A scene far from the world origin is rendered relative to its [`anchor`] (the GPU frame and
//! the reference alike), so `X` below is measured from there: what is left is a scene too
//! large for its own detail. Reflected rays start at G-buffer positions and CMO-local
//! coordinates are `x - c`, both in f32 coordinates, rounded to `|x| 2^-24`. A texel of a face of `N` texels spans `2 d / N` at
//! distance `d` from its centre; the smallest such footprint is at the nearest captured surface,
//! `d_min`. With mirror points and CMO centres up to `X` from the world origin, the rounding must
//! stay below 1/8 of that footprint: `X 2^-24 <= (2 d_min / N) / 8`, i.e.
//! `X / d_min <= 2^22 / N` (16384 at N = 256). Measured on sphere-room (N = 256, `d_min` = 1.2,
//! 64x48) moved away from the origin: at `X / d_min` = 1.05e4 (1/13 of a footprint) 0.15% of the
//! mirror pixels hit the wrong surface; at 1.05e5 (3/4 of a footprint) 0.9%; at 2.1e5 2.8%, at
//! 4.2e5 5.8%, and at 1.05e6 32%: the image turns to noise. (Before the G-buffer recomputed its
//! start points on the pixel-centre ray, 1.05e5 was already 26%: the rasteriser's interpolated
//! positions are coarser than f32 rounding.) [`FrameRanges::check`] refuses such a scene with
//! the numbers (`tests/capture/depth_range.rs`). Distances are squared in f32 by the tracer: an
//! extent over 2^60 is refused too.
use glam::Vec3;

use crate::camera::Camera;
use crate::scene::{ObjectInfo, Scene, WorldGeometry, closest_point_on_triangle};

/// How many times its bounding box's diagonal a scene's centre must lie from the world origin
/// on an axis for the GPU to work relative to it there ([`anchor`]): 8.
pub const ANCHOR_RATIO: f32 = 8.0;

/// The origin of the GPU's coordinates ([`Scene::rebased`]): on each axis, the centre of the
/// scene's bounding box where it lies more than [`ANCHOR_RATIO`] times the box's diagonal from
/// the world origin, else 0 (every scene near the origin, the built-ins among them, is uploaded
/// as it is). Every coordinate on such an axis then lies within 1/16 of the anchor's, so each
/// `x - anchor` is exact in f32 (Sterbenz): the GPU sees the reference's geometry, eye and CMO
/// centres where they are, in coordinates whose rounding is that of the scene's size instead
/// of its distance from the origin. A room 3.9 km out (the corpus's `far-offset`) otherwise put
/// 0.3-0.7 % of `bvh`'s mirror pixels on another surface than the reference's: the reflected
/// rays started a rounding of 3900 (1.2e-4) off the mirror. The reference traces its frames
/// relative to the same anchor (`reference::Tracer`), for the same reason.
pub fn anchor(scene: &Scene) -> Vec3 {
    anchor_of(&scene.world())
}

/// [`anchor`] of a scene's world geometry.
pub fn anchor_of(world: &WorldGeometry) -> Vec3 {
    let (lo, hi) = world.bounds(|_| true);
    if lo.x > hi.x {
        return Vec3::ZERO;
    }
    let diagonal = (hi - lo).length();
    let centre = 0.5 * lo + 0.5 * hi;
    Vec3::select(
        centre.abs().cmpgt(Vec3::splat(ANCHOR_RATIO * diagonal)),
        centre,
        Vec3::ZERO,
    )
}

/// `X / d_min` may be at most `PRECISION_BUDGET / N` (module docs): `2^22`.
pub const PRECISION_BUDGET: f64 = (1u64 << 22) as f64;

/// Largest scene extent whose squared distances (up to `(4 extent)^2`) stay finite in f32.
pub const MAX_EXTENT: f64 = (1u64 << 60) as f64;

/// Fraction of the far extent (at least 1) below which no near plane goes (module docs): 2^-100.
const NEAR_FLOOR: f32 = 1.0 / (1u128 << 100) as f32;

/// The nearest triangle to a point: distance, object name.
#[derive(Clone, Debug, PartialEq)]
pub struct Clearance {
    pub distance: f32,
    pub object: String,
}

/// Depth ranges and ray length of one frame, and what they were derived from.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRanges {
    /// G-buffer near plane along the view axis (world units); there is no far plane.
    pub near: f32,
    /// Capture near plane along a face axis (world units).
    pub capture_near: f32,
    /// The farthest corner of the scene's bounding box from the eye (or its diagonal, if
    /// larger), 1% to spare: not a clip plane, the scale of the scene.
    pub far: f32,
    /// Length of every reflected ray (world units).
    pub t_hi: f32,
    /// Nearest triangle to the eye.
    pub eye: Option<Clearance>,
    /// Nearest captured triangle to a CMO centre, and that centre's index.
    pub cmo: Option<(usize, Clearance)>,
    /// Largest distance of a reflector vertex or a CMO centre from the world origin.
    pub coordinates: f32,
    /// Texels per face side.
    pub cube_size: u32,
    /// A triangle whose plane passes within rounding of the eye or a CMO centre, but not
    /// exactly through it, where the reference sees it (`edge_on`).
    pub edge_on: Option<EdgeOn>,
}

/// A viewpoint (the eye, a CMO centre) that f32 cannot place on either side of a triangle's
/// plane (`edge_on`).
#[derive(Clone, Debug, PartialEq)]
pub struct EdgeOn {
    /// `the eye of camera `NAME`` or `CMO k's centre`.
    pub viewpoint: String,
    /// Whether the viewpoint is a CMO centre (only a method that captures CMOs is refused).
    pub cmo: bool,
    pub object: String,
    /// The triangle's index within its object (its primitive id) and its corners.
    pub primitive: u32,
    pub corners: [Vec3; 3],
    /// `file:line` of the triangle's face where it was loaded from a file.
    pub source: Option<String>,
    /// Distance of the viewpoint from the triangle's plane (f64).
    pub distance: f64,
    /// Distance below which the GPU passes treat the viewpoint as in the plane.
    pub bound: f64,
}

/// [`crate::camera::eye_plane_offset`] of `p` and `tri` as the pass computes it: in world
/// coordinates (the G-buffer, whose view matrix rounds to the coordinates' scale), or with
/// `local` relative to `p` (the capture, whose CMO-local coordinates `v - p` round to their own
/// scale; `spirv/capture.wgsl`).
fn plane_offset(p: Vec3, tri: &[Vec3; 3], local: bool) -> (f64, f64) {
    if local {
        crate::camera::eye_plane_offset(Vec3::ZERO, &tri.map(|v| v - p))
    } else {
        crate::camera::eye_plane_offset(p, tri)
    }
}

/// [`WorldGeometry::nearest_triangle`] as the G-buffer sees it from the eye `p`: where that
/// triangle touches `p` (nearer than the edge-on test's scale), the nearest one not culled as
/// edge-on (within a quarter of the bound of `spirv/shared/eye_plane.wgsl`, which the f32 test
/// surely culls) instead. An eye in a wall's plane then keeps a near plane from what is drawn.
/// (A CMO centre takes every captured triangle: one in a surface's plane is refused.)
fn nearest_seen(
    world: &WorldGeometry,
    p: Vec3,
    keep: &dyn Fn(&ObjectInfo) -> bool,
) -> Option<(f64, u32)> {
    let first = world.nearest_triangle(p, keep)?;
    if first.0 > crate::camera::EYE_PLANE_BOUND * (f64::from(p.length()) + 1.0) {
        return Some(first);
    }
    let pd = p.as_dvec3();
    let mut best: Option<(f64, u32)> = None;
    for (t, &o) in world.triangles.iter().zip(&world.triangle_object) {
        if !keep(&world.objects[o as usize]) {
            continue;
        }
        let tri = t.map(|i| world.positions[i as usize]);
        let [a, b, c] = tri.map(|v| v.as_dvec3());
        let d = (closest_point_on_triangle(pd, a, b, c) - pd).length();
        if best.is_some_and(|(bd, _)| d >= bd) {
            continue;
        }
        let (offset, bound) = plane_offset(p, &tri, false);
        if offset.is_nan() || offset > 0.25 * bound {
            best = Some((d, o));
        }
    }
    best
}

/// The first triangle (of the objects `keep` keeps) whose plane passes so near `p` that the
/// GPU passes may cull it as seen edge-on (`spirv/shared/eye_plane.wgsl`, twice its bound for
/// the f32 test's own error, some 2^-22 of the scale), while the reference, whose f64 primary
/// test puts `p` off the plane, sees it over a wide angle: `p` lies within that culling
/// distance of the triangle itself (the viewpoint on the surface, to rounding) and, where
/// `towards` is given (the eye's frame corners), on a side some ray of the frame heads to.
/// Exactly in the plane, every ray meets it at `t = 0` and the reference sees nothing: no
/// conflict. A triangle farther away whose plane passes that near `p` covers, in the reference
/// as on the GPU, at most about a pixel along the line it projects to: the passes may cull it.
/// Returns the distance from the plane, the culling distance, the object and the triangle's
/// index in `world.triangles`.
fn edge_on(
    world: &WorldGeometry,
    p: Vec3,
    keep: &dyn Fn(&ObjectInfo) -> bool,
    towards: &[Vec3],
    local: bool,
) -> Option<(f64, f64, String, usize)> {
    let pd = p.as_dvec3();
    for (i, (t, &o)) in world
        .triangles
        .iter()
        .zip(&world.triangle_object)
        .enumerate()
    {
        let object = &world.objects[o as usize];
        if !keep(object) {
            continue;
        }
        let tri = t.map(|i| world.positions[i as usize]);
        let (offset, bound) = plane_offset(p, &tri, local);
        if offset.is_nan() || offset > 2.0 * bound {
            continue;
        }
        // The reference's numerator of `t` (`reference::intersect`, the same operations).
        let [a, b, c] = tri.map(|v| v.as_dvec3());
        let (e1, e2, s) = (b - a, c - a, pd - a);
        let side = e2.dot(s.cross(e1));
        let n = e1.cross(e2);
        if side == 0.0 || n.length() == 0.0 {
            continue;
        }
        let cull = 2.0 * bound;
        let near = (closest_point_on_triangle(pd, a, b, c) - pd).length() <= cull;
        let seen = towards.is_empty() || towards.iter().any(|d| d.as_dvec3().dot(n) * side < 0.0);
        if near && seen {
            return Some((side.abs() / n.length(), cull, object.name.clone(), i));
        }
    }
    None
}

/// The scene cannot be rendered in f32 (see the module docs).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RangeError {
    #[error(
        "scene `{scene}` is beyond f32 precision: mirror points and CMO centres lie up to \
         {coordinates:.3e} from the world origin, but the nearest surface CMO {cmo} captures \
         (`{object}`) is {distance:.3e} from its centre; their ratio {ratio:.3e} exceeds 2^22 / \
         N = {limit:.0} for cube size N = {cube_size} (coordinates round to {rounding:.1e}, \
         over 1/8 of the smallest texel footprint, {footprint:.1e}). {}",
        precision_advice(*cmo, f64::from(*distance), f64::from(*coordinates), *limit)
    )]
    Precision {
        scene: String,
        coordinates: f32,
        cmo: usize,
        object: String,
        distance: f32,
        ratio: f64,
        limit: f64,
        cube_size: u32,
        rounding: f64,
        footprint: f64,
    },
    #[error(
        "scene `{scene}`: {viewpoint} lies on a surface: {distance:.3e} from {triangle}, \
         nearer than f32 can tell from its plane ({bound:.3e}); no pass in f32 can see that \
         surface as the reference does. Move it off the surface by at least {bound:.3e} (or \
         exactly onto its plane)"
    )]
    EdgeOn {
        scene: String,
        viewpoint: String,
        /// `triangle K of `OBJECT` (face at FILE:LINE) (corners A, B, C)`.
        triangle: String,
        distance: f64,
        bound: f64,
    },
    #[error(
        "scene `{scene}` is beyond f32 range: its extent {extent:.3e} exceeds 2^60 = \
         {max:.3e} (the tracer squares distances in f32)"
    )]
    Extent {
        scene: String,
        extent: f64,
        max: f64,
    },
}

/// What a user can change to pass the precision check: the CMO centre off a surface it lies on
/// (to rounding), else the scene's place, the centre's distance or the cube size.
fn precision_advice(cmo: usize, distance: f64, coordinates: f64, limit: f64) -> String {
    if distance <= f64::from(f32::EPSILON) * coordinates.max(1.0) {
        format!(
            "The centre lies on that surface: move CMO {cmo}'s centre off it (at least {:.1e} \
             away at this cube size), or render with --method bvh, which reads no CMO",
            coordinates / limit
        )
    } else {
        "Move the scene nearer the world origin, the CMO centres farther from that surface, or \
         use a smaller --cube-size"
            .into()
    }
}

impl FrameRanges {
    /// Derives the ranges of `scene` seen by `camera` (no check: see [`FrameRanges::check`]).
    pub fn new(scene: &Scene, camera: &Camera) -> FrameRanges {
        let world = scene.world();
        let (lo, hi) = world.bounds(|_| true);
        let empty = lo.x > hi.x;
        let diagonal = if empty {
            1.0
        } else {
            (hi - lo).length().max(f32::MIN_POSITIVE)
        };
        let mut far = 0.0f32;
        if !empty {
            for i in 0..8 {
                let c = Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                far = far.max((c - camera.eye).length());
            }
        }
        let far = 1.01 * far.max(diagonal);
        let floor = far.max(1.0) * NEAR_FLOOR;
        let named = |(d, id): (f64, u32)| Clearance {
            distance: d as f32,
            object: world.objects[id as usize].name.clone(),
        };
        let eye = nearest_seen(&world, camera.eye, &|_| true).map(named);
        let near = eye.as_ref().map_or(floor, |c| {
            (0.5 * c.distance * camera.corner_cos()).max(floor)
        });
        let captured = |o: &crate::scene::ObjectInfo| o.captured;
        let centres = scene.cmo_centres();
        let cmo = centres
            .iter()
            .enumerate()
            // Every captured triangle, those in a plane through the centre too: the CMO cannot
            // capture a surface it lies in, which mirror rays may still meet, so a centre on
            // one is refused by the precision check (distance ~0), unlike the eye, which sees
            // nothing of that surface in the reference either.
            .filter_map(|(k, &c)| world.nearest_triangle(c, captured).map(|n| (k, named(n))))
            .min_by(|a, b| a.1.distance.total_cmp(&b.1.distance));
        let capture_near = cmo
            .as_ref()
            .map_or(floor, |(_, c)| (0.5 * c.distance / 3f32.sqrt()).max(floor));
        let mut coordinates = centres.iter().map(|c| c.length()).fold(0.0f32, f32::max);
        for (t, &o) in world.triangles.iter().zip(&world.triangle_object) {
            if world.objects[o as usize].reflector {
                for &i in t {
                    coordinates = coordinates.max(world.positions[i as usize].length());
                }
            }
        }
        let corners = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(i, j)| {
            camera
                .ray(i * (camera.width - 1), j * (camera.height - 1))
                .1
        });
        let all = |_: &ObjectInfo| true;
        let edge_on = edge_on(&world, camera.eye, &all, &corners, false)
            .map(|e| (format!("the eye of camera `{}`", camera.name), false, e))
            .or_else(|| {
                centres.iter().enumerate().find_map(|(k, &c)| {
                    edge_on(&world, c, &captured, &[], true)
                        .map(|e| (format!("CMO {k}'s centre"), true, e))
                })
            })
            .map(|(viewpoint, cmo, (distance, bound, object, i))| {
                let k = world.triangle_object[i] as usize;
                let o = &world.objects[k];
                let primitive = i as u32 - o.first_triangle;
                let part = scene.meshes.iter().flat_map(|m| &m.parts).nth(k);
                EdgeOn {
                    viewpoint,
                    cmo,
                    object,
                    source: part.and_then(|p| p.source_line(primitive as usize)),
                    primitive,
                    corners: world.triangles[i].map(|v| world.positions[v as usize]),
                    distance,
                    bound,
                }
            });
        FrameRanges {
            edge_on,
            near,
            capture_near,
            far,
            t_hi: 1.01 * diagonal,
            eye,
            cmo,
            coordinates,
            cube_size: scene.cmo.resolution,
        }
    }

    /// Refuses a scene f32 cannot hold (module docs), naming its extent and the numbers. The
    /// checks of the CMO centres (their precision, a centre on a surface) apply only where
    /// `cmos`: to a method that captures CMOs; `bvh` and the reference never read them.
    pub fn check(&self, scene: &Scene, cmos: bool) -> Result<(), RangeError> {
        let extent = f64::from(self.far).max(f64::from(self.coordinates));
        // NaN is refused too.
        if extent.is_nan() || extent > MAX_EXTENT {
            return Err(RangeError::Extent {
                scene: scene.name.clone(),
                extent,
                max: MAX_EXTENT,
            });
        }
        if let Some((k, c)) = self.cmo.as_ref().filter(|_| cmos) {
            let n = f64::from(self.cube_size.max(1));
            let limit = PRECISION_BUDGET / n;
            let distance = f64::from(c.distance);
            let coordinates = f64::from(self.coordinates);
            let ratio = coordinates / distance;
            if ratio.is_nan() || ratio > limit {
                return Err(RangeError::Precision {
                    scene: scene.name.clone(),
                    coordinates: self.coordinates,
                    cmo: *k,
                    object: c.object.clone(),
                    distance: c.distance,
                    ratio,
                    limit,
                    cube_size: self.cube_size,
                    rounding: coordinates * f64::from(f32::EPSILON) / 2.0,
                    footprint: 2.0 * distance / n,
                });
            }
        }
        if let Some(e) = self.edge_on.as_ref().filter(|e| cmos || !e.cmo) {
            let [a, b, c] = e.corners;
            return Err(RangeError::EdgeOn {
                scene: scene.name.clone(),
                viewpoint: e.viewpoint.clone(),
                triangle: format!(
                    "triangle {} of `{}`{} (corners {a}, {b}, {c})",
                    e.primitive,
                    e.object,
                    e.source
                        .as_ref()
                        .map_or(String::new(), |s| format!(" (face at {s})"))
                ),
                distance: e.distance,
                bound: e.bound,
            });
        }
        Ok(())
    }
}

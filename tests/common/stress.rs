//! Stress scenes for the capture: geometry thinner or smaller than a texel at every
//! tested cube size, around a mirror sphere, so that the reflected rays meet it. Built in code,
//! deterministically (the [`Rng`](super::Rng) with fixed seeds), small enough for CPU tests:
//! at most about 4000 triangles each.
//!
//! Every scene shares one frame: a mirror sphere of radius 0.5 at the origin (the CMO centres
//! lie inside it, so its own capture is empty: the sphere is convex, `self_reflections` auto
//! leaves it out), a camera 1.6 from it along +z, a closed backdrop box from -2 to 2 (so a ray
//! that misses the thin geometry hits a wall *behind* it, which is how a missed thin object
//! shows as a wrong hit behind the first one), and the scene's thin geometry in between.
//!
//! A texel of a cube of size N spans about `1.57 D / N` at distance `D` from its centre: 0.1 at
//! N = 16, 0.025 at 64, 0.006 at 256, 0.0015 at 1024 for `D = 1`. The thin parts below are
//! 0.002 to 0.004 across (sub-texel up to N = 512 or more); the fins' planes pass 1e-3 from
//! the centre, so from there they are slivers of about 1e-3 rad.
//!
//! | name | what | triangles (thin part) |
//! | --- | --- | --- |
//! | `fence` | 120 vertical poles, 0.004 square, on a circle of radius 1 | 960 |
//! | `wire-grid` | a cage of wires 0.003 square, 10 per direction on each face of a cube of half-size 0.9 | 960 |
//! | `chain-link` | a cylinder (radius 1.1) of diamond mesh: 2 x 60 helical ribbons 0.004 wide facing the axis | 2880 |
//! | `foliage` | 900 small quads (0.015 to 0.05 a side) at random positions and orientations | 1800 |
//! | `relief` | two height fields (floor below the sphere, a wall behind the camera), 28 x 28 cells of 0.1, spiky heights | 3136 |
//! | `edge-on` | 240 fins whose planes pass 1e-3 from the sphere centre (seen edge-on from there) | 240 |

use cubetrace::camera::Camera;
use cubetrace::scene::shapes::{self, SceneBuilder};
use cubetrace::scene::{CmoPlacement, CmoSpec, MeshPart, Scene, SelfReflections, Transform};
use cubetrace::shading::Shading;
use glam::{Vec2, Vec3};

use crate::common::Rng;

/// The stress scenes by name (table in the module docs).
pub const STRESS: &[&str] = &[
    "fence",
    "wire-grid",
    "chain-link",
    "foliage",
    "relief",
    "edge-on",
];

/// Radius of the mirror sphere (at the origin).
pub const MIRROR_RADIUS: f32 = 0.5;

/// CMO centres for 1 to 3 CMOs: inside the mirror sphere, spread along x.
pub fn centres(count: u32) -> Vec<Vec3> {
    match count {
        1 => vec![Vec3::ZERO],
        2 => vec![Vec3::new(-0.2, 0.0, 0.0), Vec3::new(0.2, 0.0, 0.0)],
        3 => vec![
            Vec3::ZERO,
            Vec3::new(-0.25, 0.05, 0.0),
            Vec3::new(0.25, -0.05, 0.0),
        ],
        _ => panic!("1 to 3 CMOs"),
    }
}

/// A stress scene by name, with a `width x height` camera, cube size `cube` and `cmos` CMOs
/// ([`centres`]).
pub fn stress_scene(name: &str, width: u32, height: u32, cube: u32, cmos: u32) -> Scene {
    let mut b = frame(name, width, height, cube, cmos);
    let m = b.material("thin", Vec3::new(0.9, 0.75, 0.2), None);
    let part = match name {
        "fence" => fence(m),
        "wire-grid" => wire_grid(m),
        "chain-link" => chain_link(m),
        "foliage" => foliage(m),
        "relief" => relief(m),
        "edge-on" => edge_on(m),
        _ => panic!("no stress scene {name}"),
    };
    b.mesh(name, vec![part], Transform::default(), false);
    b.scene
}

/// The shared frame: camera, backdrop box, mirror sphere (module docs).
pub fn frame(name: &str, width: u32, height: u32, cube: u32, cmos: u32) -> SceneBuilder {
    let mut b = SceneBuilder::new(Scene {
        name: name.into(),
        meshes: vec![],
        materials: vec![],
        textures: vec![],
        cameras: vec![Camera {
            name: "main".into(),
            eye: Vec3::new(0.0, 0.25, 1.6),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_deg: 45.0,
            width,
            height,
            jitter: glam::Vec2::ZERO,
        }],
        cmo: CmoSpec {
            placement: CmoPlacement::Explicit(centres(cmos)),
            resolution: cube,
            lists: None,
        },
        background: Vec3::new(0.05, 0.05, 0.08),
        shading: Shading::default(),
        self_reflections: SelfReflections::Auto,
        film: Default::default(),
        animation: Default::default(),
    });
    let walls = [
        Vec3::new(0.7, 0.2, 0.2),
        Vec3::new(0.2, 0.6, 0.25),
        Vec3::new(0.6, 0.6, 0.6),
        Vec3::new(0.85, 0.85, 0.8),
        Vec3::new(0.25, 0.3, 0.75),
        Vec3::new(0.5, 0.3, 0.6),
    ]
    .map(|c| b.material("wall", c, None));
    let room = shapes::cuboid(Vec3::splat(-2.0), Vec3::splat(2.0), true, walls, 1.0);
    b.mesh("backdrop", room, Transform::default(), false);
    let mirror = b.material("mirror", Vec3::splat(0.8), None);
    b.mesh(
        "mirror",
        vec![shapes::uv_sphere(MIRROR_RADIUS, 32, 16, mirror)],
        Transform::default(),
        true,
    );
    b
}

/// A triangle soup with flat normals, built face by face.
struct Soup(MeshPart);

impl Soup {
    fn new(name: &str, material: u32) -> Self {
        Soup(MeshPart {
            name: name.into(),
            material,
            ..MeshPart::default()
        })
    }

    /// A planar polygon (3 or 4 corners, fanned), with its flat normal.
    fn face(&mut self, corners: &[Vec3]) {
        let n = (corners[1] - corners[0])
            .cross(corners[2] - corners[0])
            .normalize();
        let base = self.0.positions.len() as u32;
        for &c in corners {
            self.0.positions.push(c);
            self.0.normals.push(n);
            self.0.uvs.push(Vec2::ZERO);
        }
        for k in 1..corners.len() as u32 - 1 {
            self.0.triangles.push([base, base + k, base + k + 1]);
        }
    }

    /// A square-section rod of side `w` from `p` to `q` (its four sides; 8 triangles).
    fn rod(&mut self, p: Vec3, q: Vec3, w: f32) {
        let axis = (q - p).normalize();
        let helper = if axis.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
        let a = axis.cross(helper).normalize() * (0.5 * w);
        let b = axis.cross(a).normalize() * (0.5 * w);
        let ring = [a + b, -a + b, -a - b, a - b];
        for k in 0..4 {
            let (r0, r1) = (ring[k], ring[(k + 1) % 4]);
            self.face(&[p + r0, p + r1, q + r1, q + r0]);
        }
    }
}

/// 120 vertical poles, 0.004 square, on a circle of radius 1 about the sphere.
fn fence(m: u32) -> MeshPart {
    let mut s = Soup::new("fence", m);
    for k in 0..120 {
        let a = std::f32::consts::TAU * (k as f32 + 0.25) / 120.0;
        let x = Vec3::new(a.cos(), 0.0, a.sin());
        s.rod(x - 0.9 * Vec3::Y, x + 0.9 * Vec3::Y, 0.004);
    }
    s.0
}

/// A cage: on each face of a cube of half-size 0.9 about the sphere, 10 wires each way
/// (0.003 square), the front face's wires too (the camera looks through them).
fn wire_grid(m: u32) -> MeshPart {
    let mut s = Soup::new("wire-grid", m);
    let h = 0.9;
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [-h, h] {
            for k in 0..10 {
                let c = -h + 2.0 * h * (k as f32 + 0.5) / 10.0;
                for (along, across) in [(u, v), (v, u)] {
                    let mut p = Vec3::ZERO;
                    p[axis] = side;
                    p[across] = c;
                    let (mut a, mut b) = (p, p);
                    a[along] = -h;
                    b[along] = h;
                    s.rod(a, b, 0.003);
                }
            }
        }
    }
    s.0
}

/// A cylinder (radius 1.1, y in [-0.9, 0.9]) of diamond mesh: 60 helices each way at about
/// 45 degrees (diamonds some 0.1 across), each of 12 ribbon pieces 0.004 wide, facing the axis.
fn chain_link(m: u32) -> MeshPart {
    let mut s = Soup::new("chain-link", m);
    let (r, y0, y1, pieces) = (1.1f32, -0.9f32, 0.9f32, 12);
    let at = |a: f32, y: f32| Vec3::new(r * a.cos(), y, r * a.sin());
    for k in 0..60 {
        for turn in [1.0f32, -1.0] {
            let a0 = std::f32::consts::TAU * k as f32 / 60.0;
            for j in 0..pieces {
                let (f0, f1) = (j as f32 / pieces as f32, (j + 1) as f32 / pieces as f32);
                let (p, q) = (
                    at(a0 + turn * 1.6 * f0, y0 + (y1 - y0) * f0),
                    at(a0 + turn * 1.6 * f1, y0 + (y1 - y0) * f1),
                );
                // Ribbon across the piece, in the cylinder's tangent plane.
                let radial = (0.5 * (p + q)) * Vec3::new(1.0, 0.0, 1.0);
                let w = (q - p).cross(radial).normalize() * 0.002;
                s.face(&[p - w, q - w, q + w, p + w]);
            }
        }
    }
    s.0
}

/// 900 small quads, 0.015 to 0.05 a side, at random positions 0.7 to 1.5 from the centre and
/// random orientations (alpha-less foliage cards).
fn foliage(m: u32) -> MeshPart {
    let mut s = Soup::new("foliage", m);
    let mut rng = Rng(0x5eed_f011);
    for _ in 0..900 {
        let c = rng.unit() * rng.range(0.7, 1.5);
        let u = rng.unit();
        let v = u.cross(rng.unit()).normalize();
        let (a, b) = (rng.range(0.015, 0.05), rng.range(0.015, 0.05));
        let (u, v) = (u * (0.5 * a), v * (0.5 * b));
        s.face(&[c - u - v, c + u - v, c + u + v, c - u + v]);
    }
    s.0
}

/// Two spiky height fields of 28 x 28 cells of 0.1: a floor at y = -0.7 below the sphere and a
/// wall at z = 1.9 behind the camera, facing it, heights random in [0, 0.06] per vertex.
fn relief(m: u32) -> MeshPart {
    let mut s = Soup::new("relief", m);
    let mut rng = Rng(0x5eed_4e11);
    let n = 28usize;
    for wall in [false, true] {
        let h: Vec<f32> = (0..(n + 1) * (n + 1))
            .map(|_| rng.range(0.0, 0.06))
            .collect();
        let at = |i: usize, j: usize| {
            let (a, b) = (-1.4 + 0.1 * i as f32, -1.4 + 0.1 * j as f32);
            let e = h[j * (n + 1) + i];
            if wall {
                Vec3::new(a, b, 1.9 - e)
            } else {
                Vec3::new(a, -0.7 + e, b)
            }
        };
        for j in 0..n {
            for i in 0..n {
                let (p00, p10, p01, p11) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                // Facing the sphere: +y for the floor, -z for the wall (same winding).
                s.face(&[p00, p01, p11]);
                s.face(&[p00, p11, p10]);
            }
        }
    }
    s.0
}

/// 240 fins whose planes pass 1e-3 from the sphere centre: each spans radii 0.7 to 1.4 along a
/// random direction and 0.3 across it, in a plane through that direction.
fn edge_on(m: u32) -> MeshPart {
    let mut s = Soup::new("edge-on", m);
    let mut rng = Rng(0x5eed_ed9e);
    for _ in 0..240 {
        let u = rng.unit();
        let w = u.cross(rng.unit()).normalize();
        let n = u.cross(w).normalize() * 1e-3;
        s.face(&[n + 0.7 * u, n + 1.4 * u, n + 1.05 * u + 0.3 * w]);
    }
    s.0
}

/// The dense real mesh's scene file (the Stanford bunny beside a mirror sphere):
/// `tests/scenes/bunny/scene.toml`, provenance in `tests/scenes/PROVENANCE.md`.
pub fn bunny_scene(width: u32, height: u32, cube: u32, cmos: u32) -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/scenes/bunny/scene.toml");
    let mut scene = cubetrace::scene::load(path).unwrap_or_else(|e| panic!("{e}"));
    scene.cameras[0].width = width;
    scene.cameras[0].height = height;
    scene.cmo = CmoSpec {
        placement: CmoPlacement::Explicit(centres(cmos)),
        resolution: cube,
        lists: None,
    };
    scene
}

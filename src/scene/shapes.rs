//! Procedural meshes and textures for the built-in scenes and the tests.
//!
//! Curved shapes carry their analytic normals, so a tessellated sphere's interpolated normal at
//! a point `p` on a triangle is exactly the direction from the centre to `p` (the normalised
//! barycentric blend of `(v_i - c) / r` is `(p - c) / |p - c|`). The sphere test relies on this.

use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

use super::{Material, MeshInstance, MeshPart, Scene, Texture, Transform};

/// Adds materials and meshes to a scene under construction.
pub struct SceneBuilder {
    pub scene: Scene,
}

impl SceneBuilder {
    pub fn new(scene: Scene) -> Self {
        Self { scene }
    }

    /// Adds a material (and its texture, if any) and returns its index.
    pub fn material(&mut self, name: &str, diffuse: Vec3, texture: Option<Texture>) -> u32 {
        let texture = texture.map(|t| {
            self.scene.textures.push(t);
            (self.scene.textures.len() - 1) as u32
        });
        self.scene.materials.push(Material {
            name: name.into(),
            diffuse,
            texture,
            specular_power: None,
        });
        (self.scene.materials.len() - 1) as u32
    }

    pub fn mesh(
        &mut self,
        name: &str,
        parts: Vec<MeshPart>,
        transform: Transform,
        reflector: bool,
    ) {
        self.scene.meshes.push(MeshInstance {
            name: name.into(),
            parts,
            transform,
            reflector,
        });
    }
}

fn part(name: &str, material: u32) -> MeshPart {
    MeshPart {
        name: name.into(),
        material,
        ..MeshPart::default()
    }
}

/// A UV sphere about the origin with `segments` around and `rings` from pole to pole.
pub fn uv_sphere(radius: f32, segments: u32, rings: u32, material: u32) -> MeshPart {
    let mut p = part("sphere", material);
    for r in 0..=rings {
        let theta = PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = TAU * s as f32 / segments as f32;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            );
            p.positions.push(n * radius);
            p.normals.push(n);
            p.uvs.push(Vec2::new(
                s as f32 / segments as f32,
                1.0 - r as f32 / rings as f32,
            ));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (
                r * row + s,
                r * row + s + 1,
                (r + 1) * row + s,
                (r + 1) * row + s + 1,
            );
            // Skip the zero-area triangles at the poles.
            if r != 0 {
                p.triangles.push([a, c, b]);
            }
            if r != rings - 1 {
                p.triangles.push([b, c, d]);
            }
        }
    }
    p
}

/// A torus about the y axis: ring radius `major`, tube radius `minor`.
pub fn torus(major: f32, minor: f32, segments: u32, sides: u32, material: u32) -> MeshPart {
    let mut p = part("torus", material);
    for s in 0..=segments {
        let phi = TAU * s as f32 / segments as f32;
        let ring = Vec3::new(phi.cos(), 0.0, -phi.sin());
        for k in 0..=sides {
            let psi = TAU * k as f32 / sides as f32;
            let n = ring * psi.cos() + Vec3::Y * psi.sin();
            p.positions.push(ring * major + n * minor);
            p.normals.push(n);
            p.uvs.push(Vec2::new(
                s as f32 / segments as f32,
                k as f32 / sides as f32,
            ));
        }
    }
    let row = sides + 1;
    for s in 0..segments {
        for k in 0..sides {
            let (a, b, c, d) = (
                s * row + k,
                s * row + k + 1,
                (s + 1) * row + k,
                (s + 1) * row + k + 1,
            );
            p.triangles.push([a, c, d]);
            p.triangles.push([a, d, b]);
        }
    }
    p
}

/// A concave spherical cap (a bowl) about the origin, opening towards +z: the points of the
/// sphere of `radius` within `half_angle_deg` of the -z pole. Normals point *inwards* (towards
/// the centre), so the mirror side is the inside.
pub fn bowl(
    radius: f32,
    half_angle_deg: f32,
    segments: u32,
    rings: u32,
    material: u32,
) -> MeshPart {
    let mut p = part("bowl", material);
    let max_theta = half_angle_deg.to_radians();
    for r in 0..=rings {
        let theta = max_theta * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = TAU * s as f32 / segments as f32;
            let out = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                -theta.cos(),
            );
            p.positions.push(out * radius);
            p.normals.push(-out);
            p.uvs.push(Vec2::new(
                s as f32 / segments as f32,
                r as f32 / rings as f32,
            ));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (
                r * row + s,
                r * row + s + 1,
                (r + 1) * row + s,
                (r + 1) * row + s + 1,
            );
            // Wound to face inwards, like the normals.
            if r != 0 {
                p.triangles.push([a, c, b]);
            }
            p.triangles.push([b, c, d]);
        }
    }
    p
}

/// A flat quad `corner + a*u + b*v`, `a, b` in [0, 1], facing `u x v`, with texture
/// coordinates `(a, b) * uv_scale`.
pub fn quad(name: &str, corner: Vec3, u: Vec3, v: Vec3, uv_scale: Vec2, material: u32) -> MeshPart {
    let mut p = part(name, material);
    let n = u.cross(v).normalize();
    for (a, b) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
        p.positions.push(corner + u * a + v * b);
        p.normals.push(n);
        p.uvs.push(Vec2::new(a, b) * uv_scale);
    }
    p.triangles = vec![[0, 1, 2], [0, 2, 3]];
    p
}

/// An axis-aligned box from `lo` to `hi`. `inward` turns the faces (and normals) inside, for a
/// room. `materials` are for the faces -x, +x, -y (floor), +y (ceiling), -z, +z. Texture
/// coordinates repeat once per `uv_period` world units.
pub fn cuboid(
    lo: Vec3,
    hi: Vec3,
    inward: bool,
    materials: [u32; 6],
    uv_period: f32,
) -> Vec<MeshPart> {
    let e = hi - lo;
    // For each face: a corner and two edges whose cross product points outwards.
    let faces = [
        ("x-", lo, Vec3::new(0.0, 0.0, e.z), Vec3::new(0.0, e.y, 0.0)),
        (
            "x+",
            Vec3::new(hi.x, lo.y, hi.z),
            Vec3::new(0.0, 0.0, -e.z),
            Vec3::new(0.0, e.y, 0.0),
        ),
        ("y-", lo, Vec3::new(e.x, 0.0, 0.0), Vec3::new(0.0, 0.0, e.z)),
        (
            "y+",
            Vec3::new(lo.x, hi.y, hi.z),
            Vec3::new(e.x, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -e.z),
        ),
        (
            "z-",
            Vec3::new(hi.x, lo.y, lo.z),
            Vec3::new(-e.x, 0.0, 0.0),
            Vec3::new(0.0, e.y, 0.0),
        ),
        (
            "z+",
            Vec3::new(lo.x, lo.y, hi.z),
            Vec3::new(e.x, 0.0, 0.0),
            Vec3::new(0.0, e.y, 0.0),
        ),
    ];
    faces
        .iter()
        .zip(materials)
        .map(|(&(name, corner, u, v), m)| {
            let scale = Vec2::new(u.length(), v.length()) / uv_period;
            let mut q = quad(name, corner, u, v, scale, m);
            if inward {
                // Turn the face inside, keeping its texture orientation.
                q.normals.iter_mut().for_each(|n| *n = -*n);
                q.triangles.iter_mut().for_each(|t| t.swap(1, 2));
            }
            q
        })
        .collect()
}

/// A checkerboard texture of `n x n` squares.
pub fn checker(name: &str, size: u32, n: u32, a: [u8; 3], b: [u8; 3]) -> Texture {
    let mut rgba8 = Vec::with_capacity((size * size * 4) as usize);
    for y in 0..size {
        for x in 0..size {
            let c = if ((x * n / size) + (y * n / size)).is_multiple_of(2) {
                a
            } else {
                b
            };
            rgba8.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
    }
    Texture {
        name: name.into(),
        width: size,
        height: size,
        rgba8,
    }
}

/// Horizontal stripes with a smooth gradient across each stripe, so a reflection's distortion
/// and any tracing error are easy to see.
pub fn stripes(name: &str, size: u32, n: u32, a: [u8; 3], b: [u8; 3]) -> Texture {
    let mut rgba8 = Vec::with_capacity((size * size * 4) as usize);
    for y in 0..size {
        for x in 0..size {
            let band = (y * n / size) % 2;
            let g = x as f32 / size as f32;
            let base = if band == 0 { a } else { b };
            let c = base.map(|v| (v as f32 * (0.6 + 0.4 * g)) as u8);
            rgba8.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
    }
    Texture {
        name: name.into(),
        width: size,
        height: size,
        rgba8,
    }
}

//! The built-in scenes. Each is defined here in code; `cubetrace scene export NAME DIR` writes
//! one out as TOML + OBJ/MTL/PNG, and that export loads back to the same scene.
//!
//! All share one room (8 x 4 x 8 m, coloured walls, a checkered floor, a striped back wall), so
//! that reflections show parallax against near objects and far walls alike.

use glam::Vec3;

use super::shapes::{self, SceneBuilder};
use super::{CmoPlacement, CmoSpec, MeshPart, Scene, SelfReflections, Transform};
use crate::camera::Camera;
use crate::shading::Shading;

/// The built-in still scenes with a one-line description, in listing order: what the bench's
/// grid and the tests run over. The animated ones ([`ANIMATED`]) come after them.
pub const NAMES: &[(&str, &str)] = &[
    (
        "default",
        "a mirror ellipsoid in the room with objects around it, two CMOs",
    ),
    (
        "sphere-room",
        "a mirror sphere in a textured room, with objects close to it (parallax)",
    ),
    (
        "teapot",
        "the Utah teapot as the mirror, with objects around it; self-reflections on",
    ),
    (
        "torus",
        "a tilted mirror torus: mixed curvature, with a hole to see through",
    ),
    (
        "bowl",
        "a concave mirror (spherical bowl) with objects in front of it",
    ),
];

/// The built-in animated scenes (`render --frames`, `bench --sequence`), each a still scene of
/// [`NAMES`] set in motion, with a one-line description.
pub const ANIMATED: &[(&str, &str)] = &[(
    "sphere-room-orbit",
    "sphere-room with its camera orbiting the sphere: 24 frames at 24 fps (render --frames)",
)];

/// The built-in scenes with glossy reflectors ([`crate::lobe`]), each a still scene of [`NAMES`]
/// with its mirror made glossy, with a one-line description. Apart from [`NAMES`]: the tests and
/// the bench grid that loop over every still scene measure mirrors, and most methods trace a
/// glossy reflector as a mirror (with a warning).
pub const GLOSSY: &[(&str, &str)] = &[(
    "sphere-room-glossy",
    "sphere-room with a glossy sphere (Phong specular power 64): cone traced by fragment, compute and ssr, sampled by bvh and reference",
)];

/// The specular power of `sphere-room-glossy`'s sphere: a moderate lobe (the Hi-Z chapter's cone
/// of Eq. 4.1 with xi = 0.244 is about 12 degrees wide).
pub const GLOSSY_POWER: f32 = 64.0;

/// Every built-in scene, still, animated and glossy ([`NAMES`], [`ANIMATED`], then [`GLOSSY`]),
/// in listing order.
pub fn all() -> impl Iterator<Item = &'static (&'static str, &'static str)> {
    NAMES.iter().chain(ANIMATED).chain(GLOSSY)
}

/// The Utah teapot (Martin Newell, 1975, public domain); provenance in `assets/README.md`.
pub const TEAPOT_OBJ: &str = include_str!("assets/teapot.obj");

pub fn by_name(name: &str) -> Option<Scene> {
    Some(match name {
        "default" => default(),
        "sphere-room" => sphere_room(),
        "sphere-room-orbit" => sphere_room_orbit(),
        "sphere-room-glossy" => sphere_room_glossy(),
        "teapot" => teapot(),
        "torus" => torus(),
        "bowl" => bowl(),
        _ => return None,
    })
}

fn empty(name: &str, camera: Camera, cmo: CmoPlacement) -> SceneBuilder {
    SceneBuilder::new(Scene {
        name: name.into(),
        meshes: vec![],
        materials: vec![],
        textures: vec![],
        cameras: vec![camera],
        cmo: CmoSpec {
            placement: cmo,
            resolution: 256,
            lists: None,
        },
        background: Vec3::new(0.05, 0.05, 0.08),
        shading: Shading::default(),
        self_reflections: SelfReflections::Auto,
        film: Default::default(),
        animation: Default::default(),
    })
}

fn camera(eye: Vec3, target: Vec3, fov_y_deg: f32) -> Camera {
    Camera {
        name: "main".into(),
        eye,
        target,
        up: Vec3::Y,
        fov_y_deg,
        width: 640,
        height: 480,
        jitter: glam::Vec2::ZERO,
    }
}

/// The shared room, from (-4, 0, -4) to (4, 4, 4), faces pointing inwards.
fn room(b: &mut SceneBuilder) {
    let floor = b.material(
        "floor",
        Vec3::ONE,
        Some(shapes::checker(
            "floor",
            64,
            8,
            [200, 200, 190],
            [40, 60, 90],
        )),
    );
    let back = b.material(
        "back-wall",
        Vec3::ONE,
        Some(shapes::stripes(
            "stripes",
            64,
            8,
            [230, 180, 60],
            [60, 120, 200],
        )),
    );
    let left = b.material("left-wall", Vec3::new(0.7, 0.15, 0.12), None);
    let right = b.material("right-wall", Vec3::new(0.15, 0.6, 0.2), None);
    let ceiling = b.material("ceiling", Vec3::new(0.85, 0.85, 0.8), None);
    let front = b.material("front-wall", Vec3::new(0.25, 0.3, 0.75), None);
    let walls = shapes::cuboid(
        Vec3::new(-4.0, 0.0, -4.0),
        Vec3::new(4.0, 4.0, 4.0),
        true,
        [left, right, floor, ceiling, back, front],
        1.0,
    );
    b.mesh("room", walls, Transform::default(), false);
}

/// A box of the given material and size, resting at `at` (its bottom centre).
fn block(b: &mut SceneBuilder, name: &str, colour: Vec3, at: Vec3, size: Vec3) {
    let m = b.material(name, colour, None);
    let parts = shapes::cuboid(-0.5 * size, 0.5 * size, false, [m; 6], 1.0);
    let t = Transform::translation(at + Vec3::new(0.0, 0.5 * size.y, 0.0));
    b.mesh(name, parts, t, false);
}

fn ball(b: &mut SceneBuilder, name: &str, colour: Vec3, centre: Vec3, radius: f32) {
    let m = b.material(name, colour, None);
    b.mesh(
        name,
        vec![shapes::uv_sphere(radius, 24, 12, m)],
        Transform::translation(centre),
        false,
    );
}

fn mirror_material(b: &mut SceneBuilder) -> u32 {
    // The albedo is what the mirror shows once its bounces are used up.
    b.material("mirror", Vec3::splat(0.8), None)
}

pub fn sphere_room() -> Scene {
    let centre = Vec3::new(0.0, 1.2, 0.0);
    let mut b = empty(
        "sphere-room",
        camera(Vec3::new(0.0, 1.8, 3.6), Vec3::new(0.0, 1.1, 0.0), 50.0),
        CmoPlacement::Explicit(vec![centre]),
    );
    room(&mut b);
    let m = mirror_material(&mut b);
    b.mesh(
        "mirror-sphere",
        vec![shapes::uv_sphere(1.0, 64, 32, m)],
        Transform::translation(centre),
        true,
    );
    block(
        &mut b,
        "orange-box",
        Vec3::new(0.9, 0.45, 0.1),
        Vec3::new(1.5, 0.0, 0.6),
        Vec3::splat(0.6),
    );
    ball(
        &mut b,
        "yellow-ball",
        Vec3::new(0.9, 0.85, 0.2),
        Vec3::new(-1.4, 0.35, 0.8),
        0.35,
    );
    block(
        &mut b,
        "column",
        Vec3::new(0.6, 0.3, 0.7),
        Vec3::new(-0.9, 0.0, -1.5),
        Vec3::new(0.4, 2.2, 0.4),
    );
    b.scene
}

/// `sphere-room` with its sphere glossy: a material of its own, of specular power
/// [`GLOSSY_POWER`].
pub fn sphere_room_glossy() -> Scene {
    let mut scene = sphere_room();
    scene.name = "sphere-room-glossy".into();
    scene.make_reflectors_glossy(GLOSSY_POWER);
    scene
}

/// `sphere-room` with its camera on a circle around the sphere's vertical axis, one turn in 24
/// frames (frames 1 to 24 at 24 fps; one key per frame from time 0 to 1 s, so every frame is a
/// key and lies on the circle). Only the camera moves: the capture can be reused.
pub fn sphere_room_orbit() -> Scene {
    use super::animation::{CameraKey, CameraTrack};
    let mut scene = sphere_room();
    scene.name = "sphere-room-orbit".into();
    let (eye, target) = (scene.cameras[0].eye, scene.cameras[0].target);
    let radius = Vec3::new(eye.x - target.x, 0.0, eye.z - target.z).length();
    let keys = (0..=24)
        .map(|k| {
            let angle = std::f32::consts::TAU * k as f32 / 24.0;
            CameraKey {
                time: f64::from(k) / 24.0,
                eye: Some(Vec3::new(
                    target.x + radius * angle.sin(),
                    eye.y,
                    target.z + radius * angle.cos(),
                )),
                ..CameraKey::default()
            }
        })
        .collect();
    scene.animation.fps = 24.0;
    scene.animation.frames = Some([1, 24]);
    scene.animation.cameras = vec![CameraTrack { camera: 0, keys }];
    scene
}

/// The teapot's triangles, welded and with smooth normals, in its own units (about 32 wide).
pub fn teapot_part(material: u32) -> MeshPart {
    let (parts, _) = super::obj::parse_obj_str(TEAPOT_OBJ, std::path::Path::new("teapot.obj"))
        .expect("the embedded teapot OBJ is valid");
    let mut part = parts.into_iter().next().expect("teapot has one part");
    part.name = "teapot".into();
    part.material = material;
    part
}

pub fn teapot() -> Scene {
    let mut b = empty(
        "teapot",
        camera(Vec3::new(0.6, 1.7, 3.6), Vec3::new(0.0, 0.6, 0.0), 45.0),
        CmoPlacement::Auto { count: 1 },
    );
    room(&mut b);
    let m = mirror_material(&mut b);
    b.mesh(
        "teapot",
        vec![teapot_part(m)],
        Transform {
            translate: Vec3::new(0.0, 0.63, 0.0),
            rotate_deg: Vec3::new(0.0, 20.0, 0.0),
            scale: Vec3::splat(0.08),
        },
        true,
    );
    block(
        &mut b,
        "red-box",
        Vec3::new(0.8, 0.1, 0.1),
        Vec3::new(1.8, 0.0, 0.3),
        Vec3::splat(0.5),
    );
    ball(
        &mut b,
        "blue-ball",
        Vec3::new(0.2, 0.35, 0.9),
        Vec3::new(-1.7, 0.4, 0.5),
        0.4,
    );
    block(
        &mut b,
        "green-box",
        Vec3::new(0.2, 0.7, 0.3),
        Vec3::new(0.2, 0.0, -1.6),
        Vec3::new(0.7, 1.0, 0.3),
    );
    b.scene
}

pub fn torus() -> Scene {
    let mut b = empty(
        "torus",
        camera(Vec3::new(0.0, 2.0, 3.8), Vec3::new(0.0, 1.3, 0.0), 45.0),
        CmoPlacement::Auto { count: 1 },
    );
    room(&mut b);
    let m = mirror_material(&mut b);
    b.mesh(
        "mirror-torus",
        vec![shapes::torus(1.0, 0.35, 96, 32, m)],
        Transform {
            translate: Vec3::new(0.0, 1.3, 0.0),
            rotate_deg: Vec3::new(65.0, 0.0, 10.0),
            scale: Vec3::ONE,
        },
        true,
    );
    // Not convex, so auto would capture the torus (and its wrong-surface share drops from 5.6 %
    // to 1.8 % at 320x240, cube 256), but its one CMO sits in the hole, where the captured
    // inner side of the tube hides the room: 84 % of mirror pixels end unresolved (0.4 % off).
    b.scene.self_reflections = SelfReflections::Off;
    ball(
        &mut b,
        "magenta-ball",
        Vec3::new(0.8, 0.2, 0.7),
        Vec3::new(1.4, 0.45, 0.9),
        0.3,
    );
    block(
        &mut b,
        "teal-box",
        Vec3::new(0.1, 0.6, 0.6),
        Vec3::new(-1.3, 0.0, -0.8),
        Vec3::new(0.5, 0.9, 0.5),
    );
    b.scene
}

pub fn bowl() -> Scene {
    let mut b = empty(
        "bowl",
        camera(Vec3::new(0.4, 1.9, 3.4), Vec3::new(0.0, 1.5, -2.0), 50.0),
        CmoPlacement::Explicit(vec![Vec3::new(0.0, 1.6, -1.3)]),
    );
    room(&mut b);
    let m = mirror_material(&mut b);
    b.mesh(
        "mirror-bowl",
        vec![shapes::bowl(2.0, 50.0, 64, 24, m)],
        Transform::translation(Vec3::new(0.0, 1.6, -0.4)),
        true,
    );
    // Concave, so auto would capture the bowl, but from its CMO in front of the mirror the
    // captured bowl hides what lies behind the centre: 50 % of mirror pixels end unresolved at
    // 320x240 (0.3 % in error with it off, where a ray rarely meets the bowl again).
    b.scene.self_reflections = SelfReflections::Off;
    ball(
        &mut b,
        "orange-ball",
        Vec3::new(0.95, 0.5, 0.1),
        Vec3::new(0.5, 1.0, 0.2),
        0.25,
    );
    block(
        &mut b,
        "white-box",
        Vec3::new(0.85, 0.85, 0.85),
        Vec3::new(-0.7, 0.0, 0.6),
        Vec3::splat(0.5),
    );
    b.scene
}

pub fn default() -> Scene {
    let mut b = empty(
        "default",
        camera(Vec3::new(0.3, 1.9, 4.0), Vec3::new(0.0, 1.0, 0.0), 50.0),
        CmoPlacement::Auto { count: 2 },
    );
    room(&mut b);
    let m = mirror_material(&mut b);
    // A non-uniformly scaled sphere: an ellipsoid, so normals go through the inverse transpose.
    b.mesh(
        "mirror-ellipsoid",
        vec![shapes::uv_sphere(1.0, 64, 32, m)],
        Transform {
            translate: Vec3::new(0.0, 1.0, 0.0),
            rotate_deg: Vec3::new(0.0, 15.0, 0.0),
            scale: Vec3::new(1.6, 0.8, 0.9),
        },
        true,
    );
    block(
        &mut b,
        "orange-box",
        Vec3::new(0.9, 0.45, 0.1),
        Vec3::new(1.2, 0.0, 1.2),
        Vec3::splat(0.45),
    );
    ball(
        &mut b,
        "yellow-ball",
        Vec3::new(0.9, 0.85, 0.2),
        Vec3::new(-1.5, 0.3, 1.0),
        0.3,
    );
    block(
        &mut b,
        "column",
        Vec3::new(0.6, 0.3, 0.7),
        Vec3::new(0.4, 0.0, -1.6),
        Vec3::new(0.4, 2.2, 0.4),
    );
    b.scene
}

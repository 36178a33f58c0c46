//! Scenes with little in them, on every GPU method against the reference:
//! - no `[[mesh]]` at all: every method renders the background (an empty vertex buffer would
//!   fail with "buffer `scene vertices` (4 bytes) is smaller than `scene_vertices` needs (48
//!   bytes)");
//! - meshes but no reflector, and a reflector alone: every method gives the reference's frame.
//!
//! Colours are compared bit for bit on every pixel; the negative renders the reference with
//! another background, and the same comparison must fail. Runs under the validation layer when
//! installed and fails on any validation error.
use crate::common;
use common::render::first_frame;
use common::{finish_gpu, gpu_context};

use cubetrace::Method;
use cubetrace::camera::Camera;
use cubetrace::reference::{self, Tracer};
use cubetrace::scene::{CmoPlacement, CmoSpec, MeshInstance, Scene, SelfReflections, Transform};
use cubetrace::scene::{Material, shapes};
use cubetrace::shading::Shading;
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::{Fallback, RenderOptions};
use glam::Vec3;

/// A scene with the given meshes (material 0 grey), one camera looking at the origin.
fn scene(meshes: Vec<MeshInstance>) -> Scene {
    Scene {
        name: "sparse".into(),
        meshes,
        materials: vec![Material {
            name: "grey".into(),
            diffuse: Vec3::splat(0.6),
            texture: None,
            specular_power: None,
        }],
        textures: vec![],
        cameras: vec![Camera {
            name: "main".into(),
            eye: Vec3::new(0.3, 1.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_deg: 50.0,
            width: 24,
            height: 18,
            jitter: glam::Vec2::ZERO,
        }],
        cmo: CmoSpec {
            placement: CmoPlacement::Auto { count: 1 },
            resolution: 16,
            lists: None,
        },
        background: Vec3::new(0.2, 0.3, 0.4),
        shading: Shading::default(),
        self_reflections: SelfReflections::Auto,
        film: Default::default(),
        animation: Default::default(),
    }
}

fn mesh(name: &str, reflector: bool, at: Vec3) -> MeshInstance {
    MeshInstance {
        name: name.into(),
        parts: vec![shapes::uv_sphere(0.6, 12, 6, 0)],
        transform: Transform::translation(at),
        reflector,
    }
}

fn colour_bits(colour: &[Vec3]) -> Vec<[u32; 3]> {
    colour
        .iter()
        .map(|c| c.to_array().map(f32::to_bits))
        .collect()
}

fn reference_colour(scene: &Scene) -> Vec<[u32; 3]> {
    let f = reference::render(scene, &Tracer::new(scene), &scene.cameras[0], 1);
    colour_bits(&f.colour)
}

fn gpu_colour(ctx: &GpuContext, scene: &Scene, method: Method) -> Vec<[u32; 3]> {
    let options = RenderOptions {
        method,
        fallback: Fallback::Envmap,
        ..RenderOptions::default()
    };
    let what = format!("--method {}", method.name());
    let (f, _) = first_frame(ctx, scene, &scene.cameras[0], options, &what);
    colour_bits(&f.colour)
}

/// Pixels whose colours differ by more than `tolerance` in a channel (0: whose bits differ).
fn differing(a: &[[u32; 3]], b: &[[u32; 3]], tolerance: f32) -> usize {
    let unlike = |x: &[u32; 3], y: &[u32; 3]| {
        (0..3).any(|c| {
            let (p, q) = (f32::from_bits(x[c]), f32::from_bits(y[c]));
            x[c] != y[c] && ((p - q).abs() > tolerance || p.is_nan() || q.is_nan())
        })
    };
    a.iter().zip(b).filter(|(x, y)| unlike(x, y)).count()
}

#[test]
fn sparse_scenes_render_as_the_reference_on_every_gpu_method() {
    let ctx = gpu_context();
    // Where the camera sees a lit mesh, the rasteriser's interpolated normals shade it a few
    // ulps off the reference's (2^-17 at most here): those scenes compare within 2^-16.
    let near = 1.0 / 65536.0;
    let cases = [
        ("no mesh", scene(vec![]), &Method::GPU[..], 0.0),
        (
            "no reflector",
            scene(vec![mesh("ball", false, Vec3::ZERO)]),
            &[Method::Compute, Method::Bvh][..],
            near,
        ),
        (
            "a reflector alone",
            scene(vec![mesh("mirror", true, Vec3::ZERO)]),
            &[Method::Compute, Method::Bvh][..],
            near,
        ),
    ];
    for (what, s, methods, tolerance) in &cases {
        let want = reference_colour(s);
        for &m in *methods {
            let got = gpu_colour(&ctx, s, m);
            assert_eq!(
                differing(&want, &got, *tolerance),
                0,
                "{what}, --method {}: pixels unlike the reference",
                m.name()
            );
        }
    }
    finish_gpu(ctx);
}

/// The negatives: the reference with another background (by 0.01 in blue) differs from the
/// GPU's empty frame on every pixel, and from the frame of a ball by more than the tolerance.
#[test]
fn sparse_negative_another_background_differs() {
    let ctx = gpu_context();
    let s = scene(vec![]);
    let got = gpu_colour(&ctx, &s, Method::Compute);
    let mut other = s.clone();
    other.background = Vec3::new(0.2, 0.3, 0.41);
    assert_eq!(differing(&reference_colour(&other), &got, 0.0), got.len());
    let mut ball = scene(vec![mesh("ball", false, Vec3::ZERO)]);
    let got = gpu_colour(&ctx, &ball, Method::Compute);
    ball.background = Vec3::new(0.2, 0.3, 0.41);
    assert!(differing(&reference_colour(&ball), &got, 1.0 / 65536.0) > 0);
    finish_gpu(ctx);
}

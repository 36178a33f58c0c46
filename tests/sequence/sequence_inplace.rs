//! One renderer for many frames where meshes move. A `FrameRenderer` over a
//! scene whose meshes move (a ball that rises and grows, the mirror sphere that slides with its
//! CMO, a second reflector, so that the reflector check runs) updates the GPU renderer's
//! geometry in place (`GpuRenderer::update_geometry`), builds no second renderer, and gives each
//! frame bit for bit as that frame rendered alone, for every GPU method (and the bounded
//! criterion's capture, the bounce rounds' own BVH). Negatives: an update that leaves the
//! vertex buffer or the BVHs stale gives other frames; frames of different times differ. A
//! topology change falls back to a new renderer, still bit for bit the frame alone. The scene
//! comparison (`render::classify`) is checked on its own, each case with its negative.

use clap::Parser;
use cubetrace::app::render::RenderArgs;
use cubetrace::camera::Camera;
use cubetrace::render::{FrameRenderer, RenderedFrame, SceneChange, classify};
use cubetrace::scene::animation::{MeshKey, MeshTrack};
use cubetrace::scene::{CmoPlacement, Scene, builtin, shapes};
use cubetrace::vk::frame::{RECORD_HIT, StaleUpdate};
use glam::Vec3;

const WIDTH: u32 = 32;
const HEIGHT: u32 = 24;

fn args(line: &[&str]) -> RenderArgs {
    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        render: RenderArgs,
    }
    let mut all = vec!["cubetrace", "moving"];
    all.extend_from_slice(line);
    Cli::parse_from(all).render
}

fn mesh(scene: &Scene, name: &str) -> usize {
    scene.meshes.iter().position(|m| m.name == name).unwrap()
}

/// `sphere-room` in motion, frames 0 to 2 at 4 fps, two samples per pixel: the yellow ball rises,
/// moves and grows; the mirror sphere slides, its CMO with it (automatic placement); the orange
/// box is a second reflector, so the reflector check traces every mirror ray.
fn moving_scene() -> Scene {
    let mut s = builtin::sphere_room();
    s.name = "moving".into();
    s.cmo.resolution = 32;
    s.cmo.placement = CmoPlacement::Auto { count: 1 };
    s.film.spp = 2;
    let boxed = mesh(&s, "orange-box");
    s.meshes[boxed].reflector = true;
    s.animation.fps = 4.0;
    s.animation.frames = Some([0, 2]);
    let ball = mesh(&s, "yellow-ball");
    let sphere = mesh(&s, "mirror-sphere");
    let key = |time, translate, scale| MeshKey {
        time,
        translate: Some(translate),
        scale,
        ..MeshKey::default()
    };
    s.animation.meshes = vec![
        MeshTrack {
            mesh: ball,
            keys: vec![
                key(0.0, Vec3::new(-1.4, 0.35, 0.8), None),
                key(0.5, Vec3::new(-0.6, 1.5, 1.3), Some(Vec3::splat(1.6))),
            ],
        },
        MeshTrack {
            mesh: sphere,
            keys: vec![
                key(0.0, Vec3::new(0.0, 1.2, 0.0), None),
                key(0.5, Vec3::new(0.3, 1.1, -0.2), None),
            ],
        },
    ];
    s
}

fn camera(scene: &Scene) -> Camera {
    let mut cam = scene.camera(None).unwrap().clone();
    cam.width = WIDTH;
    cam.height = HEIGHT;
    cam
}

/// Everything of a frame the outputs read, as bits: the filtered colour, the mask, the primary
/// positions and the hit records of mirror pixels.
fn bits(f: &RenderedFrame) -> Vec<u32> {
    let mut out: Vec<u32> = f
        .colour()
        .iter()
        .flat_map(|c| c.to_array().map(f32::to_bits))
        .collect();
    let g = f.gpu.as_ref().unwrap();
    out.extend(g.mask.iter().map(|&m| u32::from(m)));
    out.extend(
        g.surface_position
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits)),
    );
    for (k, r) in g.records.iter().enumerate() {
        if g.mask[k] != 0 {
            out.extend([r.status, r.triangle]);
            if r.status == RECORD_HIT {
                out.extend(r.point.map(f32::to_bits));
            }
        }
    }
    out
}

/// The frames `frames` of `scene` through one `FrameRenderer` (leaving `stale` stale in its
/// updates), and the renderer.
fn sequence(
    line: &[&str],
    scene: &Scene,
    frames: &[Scene],
    stale: Option<StaleUpdate>,
) -> (Vec<RenderedFrame>, FrameRenderer) {
    let cam = camera(scene);
    let mut fr =
        FrameRenderer::new(&args(line), &frames[0], &cam).unwrap_or_else(|e| panic!("{e}"));
    fr.leave_stale(stale);
    let out = frames
        .iter()
        .map(|f| fr.render(f, &cam).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    let errors = fr.context().unwrap().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    (out, fr)
}

/// The frame of `scene` rendered by a renderer of its own.
fn alone(line: &[&str], scene: &Scene) -> RenderedFrame {
    let cam = camera(scene);
    let mut fr = FrameRenderer::new(&args(line), scene, &cam).unwrap_or_else(|e| panic!("{e}"));
    fr.render(scene, &cam).unwrap_or_else(|e| panic!("{e}"))
}

/// The moving scene's frames 0 to 2 in one renderer: updated in place twice, never rebuilt, each
/// frame captured (methods that capture) and bit for bit the frame alone; frames differ.
fn in_place_equals_alone(line: &[&str]) {
    let scene = moving_scene();
    let frames: Vec<Scene> = (0..=2).map(|f| scene.at_frame(f)).collect();
    let (seq, fr) = sequence(line, &scene, &frames, None);
    assert_eq!(fr.rebuilds(), 0, "{line:?}: a renderer was built again");
    assert_eq!(fr.geometry_updates(), 2, "{line:?}");
    let captures = !line.contains(&"bvh");
    for (k, f) in seq.iter().enumerate().skip(1) {
        assert_eq!(f.captured, captures, "{line:?}: frame {k}");
        assert!(
            bits(f) == bits(&alone(line, &frames[k])),
            "{line:?}: frame {k} of the sequence differs from the frame alone"
        );
    }
    // Negative: the frames are not one image (the comparison can fail).
    assert!(bits(&seq[1]) != bits(&seq[2]), "{line:?}: frames 1 and 2");
    assert!(bits(&seq[0]) != bits(&seq[1]), "{line:?}: frames 0 and 1");
}

#[test]
fn compute_updates_in_place() {
    in_place_equals_alone(&["--method", "compute"]);
}

#[test]
fn fragment_updates_in_place() {
    in_place_equals_alone(&["--method", "fragment"]);
}

#[test]
fn bvh_updates_in_place() {
    in_place_equals_alone(&["--method", "bvh"]);
}

#[test]
fn envmap_updates_in_place() {
    in_place_equals_alone(&["--method", "envmap"]);
}

#[test]
fn ssr_updates_in_place() {
    in_place_equals_alone(&["--method", "ssr"]);
}

#[test]
fn reflection_point_updates_in_place() {
    in_place_equals_alone(&["--method", "reflection-point"]);
}

/// The bounded criterion's capture (its views and pool capacities follow the geometry), and the
/// bounce rounds' own BVH (no method or fallback BVH to share).
#[test]
fn bounded_capture_and_bounce_rounds_update_in_place() {
    in_place_equals_alone(&["--method", "fragment", "--criterion", "bounded"]);
    in_place_equals_alone(&[
        "--method",
        "compute",
        "--fallback",
        "envmap",
        "--bounces",
        "2",
    ]);
}

/// Negatives: an update that leaves the vertex buffer stale (compute), or the BVHs (bvh), gives
/// frames other than the frames alone.
#[test]
fn a_stale_update_is_caught() {
    let scene = moving_scene();
    let frames: Vec<Scene> = (0..=2).map(|f| scene.at_frame(f)).collect();
    for (line, stale) in [
        (&["--method", "compute"], StaleUpdate::Vertices),
        (&["--method", "bvh"], StaleUpdate::Bvh),
    ] {
        let (seq, fr) = sequence(line, &scene, &frames, Some(stale));
        assert_eq!(fr.geometry_updates(), 2);
        let differs = (1..=2).any(|k| bits(&seq[k]) != bits(&alone(line, &frames[k])));
        assert!(differs, "{line:?}: leaving {stale:?} stale went unnoticed");
    }
}

/// A mesh whose triangles change (the ball at another tessellation in frame 2): the update
/// refuses, a new renderer is built, and the frame is still the frame alone.
#[test]
fn a_topology_change_rebuilds() {
    let line = ["--method", "compute"];
    let scene = moving_scene();
    let mut frames: Vec<Scene> = (0..=2).map(|f| scene.at_frame(f)).collect();
    let ball = mesh(&scene, "yellow-ball");
    let material = frames[2].meshes[ball].parts[0].material;
    frames[2].meshes[ball].parts = vec![shapes::uv_sphere(0.35, 16, 8, material)];
    let (seq, fr) = sequence(&line, &scene, &frames, None);
    assert_eq!((fr.geometry_updates(), fr.rebuilds()), (1, 1));
    assert!(seq[2].captured);
    assert!(bits(&seq[2]) == bits(&alone(&line, &frames[2])));
    // Negative: the frame at the old tessellation is another image.
    assert!(bits(&seq[2]) != bits(&alone(&line, &scene.at_frame(2))));
}

/// [`bits`] and the trace's counters (texels, cells, descents, backtracks) of the mirror pixels:
/// the work that the lists' face size decides where the bounded criterion's image does not move.
fn bits_and_work(f: &RenderedFrame) -> (Vec<u32>, Vec<[u32; 4]>) {
    let g = f.gpu.as_ref().unwrap();
    let work = (g.compute.as_ref()).map_or_else(Vec::new, |c| {
        (c.per_pixel.iter().zip(&g.mask))
            .filter(|(_, m)| **m != 0)
            .map(|(w, _)| *w)
            .collect()
    });
    (bits(f), work)
}

/// The lists' face size is resolved for each frame's scene, as for the frame alone: frame 1 with
/// the face size a placement search took (8, where frame 0 resolved `auto`) is rebuilt at that
/// size and is the frame alone, its trace's work included. Negative: frame 1 at `auto`'s size
/// traces other work.
#[test]
fn a_face_size_a_search_took_is_the_frame_alone() {
    let line = ["--method", "compute"];
    let scene = moving_scene();
    let mut frames: Vec<Scene> = (0..=1).map(|f| scene.at_frame(f)).collect();
    frames[1].cmo.lists = Some(8);
    let (seq, fr) = sequence(&line, &scene, &frames, None);
    assert_eq!(fr.rebuilds(), 1);
    let got = bits_and_work(&seq[1]);
    assert!(!got.1.is_empty());
    assert!(got == bits_and_work(&alone(&line, &frames[1])));
    assert!(got != bits_and_work(&alone(&line, &scene.at_frame(1))));
}

/// `classify`: cameras alone are no change; transforms and CMO centres are the placement;
/// triangles, reflector flags, materials, CMO counts or resolutions, or the lists' face size a
/// placement search took are something else.
#[test]
fn the_scene_comparison_classifies() {
    let scene = moving_scene();
    let f0 = scene.at_frame(0);
    assert_eq!(classify(&f0, &f0.clone()), SceneChange::None);
    let mut cam = f0.clone();
    cam.cameras[0].eye += Vec3::X;
    assert_eq!(classify(&f0, &cam), SceneChange::None);
    assert_eq!(classify(&f0, &scene.at_frame(1)), SceneChange::Placement);
    let explicit = |c: Vec<Vec3>| {
        let mut s = f0.clone();
        s.cmo.placement = CmoPlacement::Explicit(c);
        s
    };
    let one = explicit(vec![Vec3::Y]);
    assert_eq!(classify(&one, &explicit(vec![Vec3::Y])), SceneChange::None);
    assert_eq!(
        classify(&one, &explicit(vec![Vec3::X])),
        SceneChange::Placement
    );
    let other = |s: &Scene| matches!(classify(&f0, s), SceneChange::Other(_));
    assert!(other(&explicit(vec![Vec3::Y, Vec3::X])));
    assert!(other(&one));
    let mut s = f0.clone();
    s.cmo.resolution += 1;
    assert!(other(&s));
    let mut s = f0.clone();
    s.cmo.lists = Some(64);
    assert!(other(&s));
    let mut s = f0.clone();
    s.meshes[0].parts[0].positions[0] += Vec3::X;
    assert!(other(&s));
    let mut s = f0.clone();
    s.meshes[0].reflector = !s.meshes[0].reflector;
    assert!(other(&s));
    let mut s = f0.clone();
    s.materials[0].diffuse += Vec3::splat(0.1);
    assert!(other(&s));
    let mut s = f0.clone();
    s.meshes.pop();
    assert!(other(&s));
    // Negative: the placement check sees a transform change (not reported as none).
    let mut s = f0.clone();
    s.meshes[0].transform.rotate_deg.y += 1.0;
    assert_eq!(classify(&f0, &s), SceneChange::Placement);
}

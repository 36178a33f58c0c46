//! Animated scenes and sequences: the scene file's `[film]` and `[animation]`
//! (errors naming the file, line and field; export round trips), and `render --frames` through
//! the real binary on tiny frames: a frame of a sequence is byte-identical to the same frame
//! rendered alone, `--skip-existing` leaves existing files alone, bad `--frames` are refused.
//! Each check has its negative.

use crate::common::binary::{Outcome, run};
use std::path::{Path, PathBuf};

use cubetrace::film::PixelFilter;
use cubetrace::scene::animation::{CameraKey, CameraTrack, MeshKey, MeshTrack};
use cubetrace::scene::{self, builtin, export};
use glam::Vec3;

fn ok(o: &Outcome) {
    assert_eq!(
        o.code,
        Some(0),
        "stdout: {}\nstderr: {}",
        o.stdout,
        o.stderr
    );
}

/// `sphere-room` with an animated mesh (the yellow ball rises and grows), spp 2 Gaussian.
fn moving_scene() -> scene::Scene {
    let mut s = builtin::sphere_room();
    s.name = "moving-ball".into();
    let ball = s
        .meshes
        .iter()
        .position(|m| m.name == "yellow-ball")
        .unwrap();
    s.film.spp = 2;
    s.film.filter = PixelFilter::Gaussian;
    s.animation.fps = 4.0;
    s.animation.frames = Some([0, 2]);
    s.animation.meshes.push(MeshTrack {
        mesh: ball,
        keys: vec![
            MeshKey {
                time: 0.0,
                translate: Some(Vec3::new(-1.4, 0.35, 0.8)),
                ..MeshKey::default()
            },
            MeshKey {
                time: 0.5,
                translate: Some(Vec3::new(-1.0, 1.2, 0.9)),
                scale: Some(Vec3::new(1.5, 1.2, 1.5)),
                ..MeshKey::default()
            },
        ],
    });
    s
}

/// `Scene::at_frame`: a still comes back unchanged; keys move only the fields they set.
#[test]
fn a_still_scene_is_unchanged_and_keys_move_only_their_fields() {
    let still = builtin::sphere_room();
    assert_eq!(still.at_frame(17), still);
    let mut scene = still.clone();
    scene.animation.fps = 10.0;
    scene.animation.cameras.push(CameraTrack {
        camera: 0,
        keys: vec![
            CameraKey {
                time: 0.0,
                eye: Some(Vec3::new(0.0, 1.0, 4.0)),
                ..Default::default()
            },
            CameraKey {
                time: 1.0,
                eye: Some(Vec3::new(2.0, 1.0, 4.0)),
                fov_y_deg: Some(30.0),
                ..Default::default()
            },
        ],
    });
    scene.animation.meshes.push(MeshTrack {
        mesh: 1,
        keys: vec![MeshKey {
            time: 0.5,
            translate: Some(Vec3::new(0.0, 2.0, 0.0)),
            ..Default::default()
        }],
    });
    let f5 = scene.at_frame(5);
    assert_eq!(f5.cameras[0].eye, Vec3::new(1.0, 1.0, 4.0));
    assert_eq!(f5.cameras[0].target, still.cameras[0].target);
    // fov has one key: held at every time.
    assert_eq!(f5.cameras[0].fov_y_deg, 30.0);
    assert_eq!(f5.meshes[1].transform.translate, Vec3::new(0.0, 2.0, 0.0));
    assert_eq!(
        f5.meshes[1].transform.scale,
        still.meshes[1].transform.scale
    );
    assert_eq!(f5.meshes[0], still.meshes[0]);
    // Negative: another frame is another camera.
    assert_ne!(scene.at_frame(6).cameras[0].eye, f5.cameras[0].eye);
    assert_eq!(scene.at_frame(10).cameras[0].eye, Vec3::new(2.0, 1.0, 4.0));
}

#[test]
fn film_and_animation_round_trip_through_export() {
    let dir = tempfile::tempdir().unwrap();
    let original = moving_scene();
    let path = export::export(&original, dir.path()).unwrap();
    let loaded = scene::load_scene_file(&path).unwrap();
    original.compare_content(&loaded).unwrap();
    assert_eq!(loaded.film, original.film);
    assert_eq!(loaded.animation, original.animation);
    // Every frame of the export is the original's frame.
    for f in 0..3 {
        original
            .at_frame(f)
            .compare_content(&loaded.at_frame(f))
            .unwrap();
    }
    // Negatives: a key's time and the filter edited in the file are seen.
    let text = std::fs::read_to_string(&path).unwrap();
    for (from, to) in [("time = 0.5", "time = 0.75"), ("\"gaussian\"", "\"box\"")] {
        let edited = text.replacen(from, to, 1);
        assert_ne!(edited, text, "{from} not in the export");
        std::fs::write(&path, &edited).unwrap();
        let changed = scene::load_scene_file(&path).unwrap();
        assert!(original.compare_content(&changed).is_err(), "{to}");
    }
    // The spline's name round trips too.
    let mut spline = moving_scene();
    spline.animation.interpolation = scene::animation::Interpolation::CatmullRom;
    let spline_path = export::export(&spline, &dir.path().join("spline")).unwrap();
    let text = std::fs::read_to_string(&spline_path).unwrap();
    assert!(text.contains("interpolation = \"catmull-rom\""), "{text}");
    let loaded = scene::load_scene_file(&spline_path).unwrap();
    assert_eq!(loaded.animation, spline.animation);
    // A still scene's export has neither section.
    let still = export::export(&builtin::sphere_room(), &dir.path().join("still")).unwrap();
    let text = std::fs::read_to_string(still).unwrap();
    assert!(
        !text.contains("[film]") && !text.contains("[animation]"),
        "{text}"
    );
}

/// The orbit's frames: on the circle, frame 0 is `sphere-room`'s own camera, only the eye moves.
#[test]
fn the_orbit_moves_only_the_camera_eye() {
    let still = builtin::sphere_room();
    let orbit = builtin::by_name("sphere-room-orbit").unwrap();
    assert_eq!(orbit.default_frames(), Some([1, 24]));
    assert_eq!(orbit.at_frame(0).cameras, still.cameras);
    let c6 = &orbit.at_frame(6).cameras[0];
    assert!(
        (c6.eye - Vec3::new(3.6, 1.8, 0.0)).length() < 1e-5,
        "{}",
        c6.eye
    );
    assert_eq!(c6.target, still.cameras[0].target);
    assert_eq!(orbit.at_frame(6).meshes, still.meshes);
    assert_ne!(orbit.at_frame(7).cameras, orbit.at_frame(6).cameras);
}

/// A scene file with `extra` appended, next to an exported `sphere-room`.
fn scene_with(dir: &Path, extra: &str) -> PathBuf {
    let path = export::export(&builtin::sphere_room(), dir).unwrap();
    let mut text = std::fs::read_to_string(&path).unwrap();
    text.push_str(extra);
    std::fs::write(&path, text).unwrap();
    path
}

/// The 1-based line of the first occurrence of `needle` in the file.
fn line_of(path: &Path, needle: &str) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    text[..text.find(needle).unwrap()].matches('\n').count() + 1
}

const GOOD: &str = r#"
[film]
spp = 4
filter = "gaussian"

[animation]
fps = 24
frames = [1, 12]
interpolation = "linear"

[[animation.camera]]
camera = "main"
[[animation.camera.key]]
time = 0.0
eye = [0, 1.8, 3.6]
[[animation.camera.key]]
time = 0.5
eye = [3.6, 1.8, 0]
fov_y_deg = 40

[[animation.mesh]]
mesh = "mirror-sphere"
[[animation.mesh.key]]
time = 0.25
translate = [0, 1.5, 0]
"#;

#[test]
fn a_good_animation_loads() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_with(dir.path(), GOOD);
    let s = scene::load_scene_file(&path).unwrap();
    assert_eq!(s.film.spp, 4);
    assert_eq!(s.film.filter, PixelFilter::Gaussian);
    assert_eq!(s.default_frames(), Some([1, 12]));
    // Frame 6 is 0.25 s: halfway between the camera keys, the mesh key's own value.
    let f6 = s.at_frame(6);
    assert_eq!(f6.cameras[0].eye, Vec3::new(1.8, 1.8, 1.8));
    assert_eq!(f6.cameras[0].fov_y_deg, 40.0);
    let sphere = s
        .meshes
        .iter()
        .position(|m| m.name == "mirror-sphere")
        .unwrap();
    assert_eq!(
        f6.meshes[sphere].transform.translate,
        Vec3::new(0.0, 1.5, 0.0)
    );
}

/// Each broken form of [`GOOD`]: the error names the file, the line of `at` and the field.
#[test]
fn bad_animations_are_refused_naming_line_and_field() {
    let cases: &[(&str, &str, &str, &str, &str)] = &[
        // (replace, with, line of, field, reason)
        (
            "time = 0.5",
            "time = 0.0",
            "time = 0.0\neye = [3.6",
            "animation.camera[0].key[1].time",
            "not after the previous key",
        ),
        (
            "time = 0.5\n",
            "",
            "[[animation.camera.key]]\neye = [3.6",
            "animation.camera[0].key[1].time",
            "missing",
        ),
        (
            "\"linear\"",
            "\"cubic\"",
            "interpolation",
            "animation.interpolation",
            "'cubic' is not one of \"linear\", \"catmull-rom\"",
        ),
        (
            "camera = \"main\"",
            "camera = \"side\"",
            "camera = \"side\"",
            "animation.camera[0].camera",
            "no [[camera]] named 'side'",
        ),
        (
            "mesh = \"mirror-sphere\"",
            "mesh = \"ghost\"",
            "mesh = \"ghost\"",
            "animation.mesh[0].mesh",
            "no [[mesh]] named 'ghost'",
        ),
        (
            "frames = [1, 12]",
            "frames = [12, 1]",
            "frames = [12, 1]",
            "animation.frames",
            "not a range",
        ),
        (
            "fps = 24",
            "fps = 0",
            "fps = 0",
            "animation.fps",
            "out of range",
        ),
        ("spp = 4", "spp = 0", "spp = 0", "film.spp", "out of range"),
        (
            "\"gaussian\"",
            "\"tent\"",
            "filter",
            "film.filter",
            "'tent' is not one of",
        ),
        (
            "fov_y_deg = 40",
            "fov_y_deg = 190",
            "fov_y_deg = 190",
            "animation.camera[0].key[1].fov_y_deg",
            "(0, 180)",
        ),
    ];
    for &(from, to, at, field, reason) in cases {
        let dir = tempfile::tempdir().unwrap();
        let edited = GOOD.replacen(from, to, 1);
        assert_ne!(edited, GOOD, "{from}");
        let path = scene_with(dir.path(), &edited);
        let e = scene::load_scene_file(&path).unwrap_err().to_string();
        let line = line_of(&path, at);
        let place = format!("{}:{line}: {field}: ", path.display());
        assert!(
            e.starts_with(&place),
            "{from} -> {to}: '{e}' does not start with '{place}'"
        );
        assert!(e.contains(reason), "{from} -> {to}: '{e}' lacks '{reason}'");
    }
    // Unknown fields: the parser's message, with the line.
    for (from, to, name) in [
        ("fps = 24", "fps = 24\nspeed = 2", "speed"),
        (
            "translate = [0, 1.5, 0]",
            "translate = [0, 1.5, 0]\nwobble = 1",
            "wobble",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let path = scene_with(dir.path(), &GOOD.replacen(from, to, 1));
        let e = scene::load_scene_file(&path).unwrap_err().to_string();
        assert!(
            e.contains(&path.display().to_string()) && e.contains(name),
            "{e}"
        );
        assert!(e.contains(&format!("line {}", line_of(&path, name))), "{e}");
    }
}

/// The sequence through the binary at 32x24: frames 1..3 of the orbit in one run are
/// byte-identical to each frame rendered alone, frame 0 to `sphere-room` rendered as a still;
/// another frame's file differs.
#[test]
fn sequence_frames_equal_frames_rendered_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let size = ["--width", "32", "--height", "24"];
    let with = |extra: &[&str]| -> Vec<String> {
        size.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    let go = |scene: &str, extra: &[&str]| {
        let mut a = vec!["render".to_string(), scene.to_string()];
        a.extend(with(extra));
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = run(&a, d);
        ok(&o);
        o
    };
    let o = go(
        "sphere-room-orbit",
        &["--frames", "0..3", "-o", "seq/f-##.png"],
    );
    assert!(o.stdout.contains("4 frames rendered"), "{}", o.stdout);
    for f in 0..=3 {
        go(
            "sphere-room-orbit",
            &["--frames", &f.to_string(), "-o", &format!("alone-{f}.png")],
        );
        let a = std::fs::read(d.join(format!("seq/f-{f:02}.png"))).unwrap();
        let b = std::fs::read(d.join(format!("alone-{f}.png"))).unwrap();
        assert!(
            a == b,
            "frame {f}: the sequence's file differs from the frame alone"
        );
    }
    go("sphere-room", &["-o", "still.png"]);
    let still = std::fs::read(d.join("still.png")).unwrap();
    assert_eq!(std::fs::read(d.join("seq/f-00.png")).unwrap(), still);
    // Negative: another frame is another image.
    assert_ne!(std::fs::read(d.join("seq/f-01.png")).unwrap(), still);
    assert_ne!(
        std::fs::read(d.join("seq/f-01.png")).unwrap(),
        std::fs::read(d.join("seq/f-02.png")).unwrap()
    );
}

/// A moving mesh: frames of one run equal frames alone, and differ from each other.
#[test]
fn a_moving_mesh_sequence_equals_frames_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let path = export::export(&moving_scene(), &d.join("scene")).unwrap();
    let p = path.to_str().unwrap();
    let size = ["--width", "32", "--height", "24", "--method", "compute"];
    let mut args = vec!["render", p, "-o", "m.png"];
    args.extend(size);
    // The scene's own range (0..2), several frames without '#': m-0000.png ...
    ok(&run(&args, d));
    for f in 0..=2 {
        let fs = f.to_string();
        let name = format!("alone-{f}.png");
        let mut a = vec!["render", p, "--frames", &fs, "-o", &name];
        a.extend(size);
        ok(&run(&a, d));
        let seq = std::fs::read(d.join(format!("m-{f:04}.png"))).unwrap();
        assert!(seq == std::fs::read(d.join(&name)).unwrap(), "frame {f}");
    }
    assert_ne!(
        std::fs::read(d.join("m-0000.png")).unwrap(),
        std::fs::read(d.join("m-0002.png")).unwrap()
    );
}

/// `--skip-existing` renders only the missing frames and leaves an existing file as it is;
/// without it the file is replaced (the negative).
#[test]
fn skip_existing_leaves_existing_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("f-0002.png"), b"not a png").unwrap();
    let args = [
        "render",
        "sphere-room-orbit",
        "--width",
        "16",
        "--height",
        "12",
        "--frames",
        "1..3",
        "-o",
        "f-####.png",
    ];
    let mut skip = args.to_vec();
    skip.push("--skip-existing");
    let o = run(&skip, d);
    ok(&o);
    assert!(
        o.stdout.contains("2 frames rendered, 1 skipped"),
        "{}",
        o.stdout
    );
    assert_eq!(std::fs::read(d.join("f-0002.png")).unwrap(), b"not a png");
    assert!(d.join("f-0001.png").is_file() && d.join("f-0003.png").is_file());
    ok(&run(&args, d));
    assert_ne!(std::fs::read(d.join("f-0002.png")).unwrap(), b"not a png");
    // A still keeps its name and is skipped too; without the file it renders (the negative).
    std::fs::write(d.join("still.png"), b"kept").unwrap();
    let still = [
        "render",
        "sphere-room",
        "--width",
        "16",
        "--height",
        "12",
        "-o",
        "still.png",
        "--skip-existing",
    ];
    let o = run(&still, d);
    ok(&o);
    assert!(o.stdout.contains("skipped"), "{}", o.stdout);
    assert_eq!(std::fs::read(d.join("still.png")).unwrap(), b"kept");
    std::fs::remove_file(d.join("still.png")).unwrap();
    ok(&run(&still, d));
    assert_ne!(std::fs::read(d.join("still.png")).unwrap(), b"kept");
}

/// Bad `--frames` are refused before anything renders: exit 1, one clear message, no file.
#[test]
fn bad_frames_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (bad, says) in [
        ("5..1", "ends before it starts"),
        ("1..", "needs an end"),
        ("a", "'a' is not a frame number"),
        ("1..4:0", "must be 1 or more"),
    ] {
        let o = run(
            &[
                "render",
                "sphere-room-orbit",
                "--frames",
                bad,
                "-o",
                "x-#.png",
            ],
            d,
        );
        assert_eq!(o.code, Some(1), "{bad}: {}", o.stderr);
        assert!(
            o.stderr.contains("--frames") && o.stderr.contains(says),
            "{bad}: {}",
            o.stderr
        );
        assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
    }
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 0);
    // Negative: a good list renders.
    ok(&run(
        &[
            "render",
            "sphere-room-orbit",
            "--width",
            "8",
            "--height",
            "6",
            "--frames",
            "2",
            "-o",
            "x-#.png",
        ],
        d,
    ));
    assert!(d.join("x-2.png").is_file());
}

/// `interpolation = "catmull-rom"`: the camera follows the spline (an analytic Hermite value),
/// meshes stay linear, and an overshooting field of view is clamped.
#[test]
fn catmull_rom_moves_the_camera_and_leaves_meshes_linear() {
    let mut scene = builtin::sphere_room();
    let mesh_keys = [(0.0, 0.0), (1.0, 1.0), (2.0, 0.0)].map(|(t, y)| MeshKey {
        time: t,
        translate: Some(Vec3::new(0.0, y, 0.0)),
        ..MeshKey::default()
    });
    let cam_keys = [(0.0, 0.0), (1.0, 1.0), (2.0, 0.0)].map(|(t, x)| CameraKey {
        time: t,
        eye: Some(Vec3::new(x, 1.0, 4.0)),
        fov_y_deg: Some([10.0, 170.0, 179.9][t as usize]),
        ..CameraKey::default()
    });
    scene.animation = cubetrace::scene::animation::Animation {
        fps: 1.0,
        frames: Some([0, 2]),
        interpolation: cubetrace::scene::animation::Interpolation::Linear,
        cameras: vec![CameraTrack {
            camera: 0,
            keys: cam_keys.to_vec(),
        }],
        meshes: vec![MeshTrack {
            mesh: 0,
            keys: mesh_keys.to_vec(),
        }],
    };
    let at = |s: &scene::Scene, time: f64| {
        let mut a = s.animation.clone();
        a.fps = 1.0 / time;
        let f = a.apply(s, 1);
        (
            f.cameras[0].eye.x,
            f.cameras[0].fov_y_deg,
            f.meshes[0].transform.translate.y,
        )
    };
    let (x_lin, _, y_lin) = at(&scene, 0.5);
    scene.animation.interpolation = cubetrace::scene::animation::Interpolation::CatmullRom;
    let (x_cr, fov_cr, y_cr) = at(&scene, 0.5);
    assert!((x_lin - 0.5).abs() < 1e-6, "{x_lin}");
    // Tangents 1 at t = 0 (one-sided) and 0 at t = 1 ((0 - 0) / 2): the Hermite value at
    // s = 1/2 is 0.5 + 0.125 = 0.625.
    assert!((x_cr - 0.625).abs() < 1e-5, "{x_cr}");
    assert_eq!(y_cr, y_lin, "meshes stay linear");
    // The fov spline overshoots 180 between the last two keys (at t = 1.5, tangents
    // (179.9 - 10) / 2 and 9.9: 0.5 * 170 + 0.125 * 84.95 + 0.5 * 179.9 - 0.125 * 9.9 = 184.3;
    // linear gives 174.95); the path clamps it to a valid camera.
    let (_, fov_over, _) = at(&scene, 1.5);
    assert_eq!(fov_over, 180.0 - cubetrace::scene::animation::MIN_FOV_DEG);
    assert!(fov_cr > 10.0 && fov_cr < 170.0, "{fov_cr}");
}

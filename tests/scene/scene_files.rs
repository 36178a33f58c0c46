//! Scene export and load round trip, and one test per class of bad input through the real
//! binary: each must give one clear message naming the file (and line or field), a non-zero
//! exit, no panic, and no output file.

use crate::common::binary::run;
use crate::common::export_to;
use std::path::Path;
use std::process::Command;

use cubetrace::cpu::verify::triangle_corners;
use cubetrace::reference::{self, Tracer};
use cubetrace::scene::{self, builtin};
use glam::Vec3;

#[test]
fn every_builtin_round_trips_through_export() {
    for (name, _) in builtin::NAMES {
        let dir = tempfile::tempdir().unwrap();
        let path = export_to(name, dir.path());
        let loaded = scene::load_scene_file(&path).unwrap();
        let original = builtin::by_name(name).unwrap();
        original
            .compare_content(&loaded)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn exported_scene_renders_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let path = export_to("sphere-room", dir.path());
    let loaded = scene::load_scene_file(&path).unwrap();
    let original = builtin::by_name("sphere-room").unwrap();
    let mut cam = original.cameras[0].clone();
    cam.width = 64;
    cam.height = 48;
    let a = reference::render(&original, &Tracer::new(&original), &cam, 1);
    let b = reference::render(&loaded, &Tracer::new(&loaded), &cam, 1);
    assert_eq!(a.colour, b.colour);
    assert_eq!(a.object_id, b.object_id);
}

#[test]
fn round_trip_negative_edited_export_differs() {
    let dir = tempfile::tempdir().unwrap();
    let path = export_to("sphere-room", dir.path());
    let original = builtin::by_name("sphere-room").unwrap();

    // A changed transform.
    let text = std::fs::read_to_string(&path).unwrap();
    let edited = text.replacen(
        "translate = [0.0, 0.0, 0.0]",
        "translate = [0.001, 0.0, 0.0]",
        1,
    );
    assert_ne!(text, edited);
    std::fs::write(&path, &edited).unwrap();
    let e = scene::load_scene_file(&path).map(|s| original.compare_content(&s));
    assert!(
        matches!(e, Ok(Err(_))),
        "a moved mesh must not compare equal"
    );
    std::fs::write(&path, &text).unwrap();

    // One vertex of the mirror moved in its OBJ.
    let obj = dir.path().join("mirror-sphere.obj");
    let text = std::fs::read_to_string(&obj).unwrap();
    // (The 200th vertex: some pole vertices are in no triangle, and editing those changes
    // nothing.)
    let line = text
        .lines()
        .filter(|l| l.starts_with("v "))
        .nth(200)
        .unwrap()
        .to_string();
    std::fs::write(&obj, text.replacen(&line, "v 0.001 1 0", 1)).unwrap();
    let loaded = scene::load_scene_file(&path).unwrap();
    assert!(original.compare_content(&loaded).is_err());
}

// ---- Bad input through the binary ----

/// Renders `scene` to `out.png` in `dir`; asserts a clean failure whose message contains every
/// one of `needles`, and that no image (nor temporary file) was left behind.
fn expect_failure(dir: &Path, scene: &str, extra: &[&str], needles: &[&str]) {
    let mut args = vec!["render", scene, "-o", "out.png"];
    args.extend_from_slice(extra);
    let o = run(&args, dir);
    assert_eq!(o.code, Some(1), "exit status; stderr: {}", o.stderr);
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
    assert_eq!(
        o.stderr.lines().filter(|l| l.starts_with("error:")).count(),
        1,
        "one error message: {}",
        o.stderr
    );
    for n in needles {
        assert!(o.stderr.contains(n), "expected '{n}' in: {}", o.stderr);
    }
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| {
            n.ends_with(".png") && n != "floor.png" && n != "stripes.png" || n.ends_with(".tmp")
        })
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// An exported scene to break in various ways.
fn exported() -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    export_to("sphere-room", dir.path());
    let toml = std::fs::read_to_string(dir.path().join("scene.toml")).unwrap();
    (dir, toml)
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn error_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    expect_failure(
        dir.path(),
        "nowhere/scene.toml",
        &[],
        &["nowhere/scene.toml", "cannot read"],
    );
    // A mesh that refers to a missing OBJ.
    let (dir, toml) = exported();
    std::fs::remove_file(dir.path().join("room.obj")).unwrap();
    std::fs::write(dir.path().join("scene.toml"), toml).unwrap();
    expect_failure(dir.path(), "./scene.toml", &[], &["room.obj"]);
}

#[test]
fn error_malformed_toml() {
    let (dir, toml) = exported();
    let broken = format!("{toml}\n[camera\n");
    let line = broken.lines().count();
    std::fs::write(dir.path().join("scene.toml"), broken).unwrap();
    expect_failure(
        dir.path(),
        "./scene.toml",
        &[],
        &["scene.toml", &format!("line {line}")],
    );
}

#[test]
fn error_unknown_field() {
    let (dir, toml) = exported();
    let broken = toml.replacen("reflector = ", "reflektor = true\nreflector = ", 1);
    let line = line_of(&broken, "reflektor");
    std::fs::write(dir.path().join("scene.toml"), broken).unwrap();
    expect_failure(
        dir.path(),
        "./scene.toml",
        &[],
        &[
            "scene.toml",
            "unknown field `reflektor`",
            &format!("line {line}"),
        ],
    );
}

#[test]
fn error_malformed_obj() {
    let (dir, _) = exported();
    let obj = dir.path().join("orange-box.obj");
    let text = std::fs::read_to_string(&obj).unwrap();
    let bad = text.replacen("\nv ", "\nv 1 2\nv ", 1);
    let line = line_of(&bad, "v 1 2");
    std::fs::write(&obj, bad).unwrap();
    expect_failure(
        dir.path(),
        "./scene.toml",
        &[],
        &[&format!("orange-box.obj:{line}"), "needs 3 numbers"],
    );
    // A face that points past the vertices.
    let bad = text.replacen("\nf ", "\nf 1 2 99999\nf ", 1);
    let line = line_of(&bad, "f 1 2 99999");
    std::fs::write(&obj, bad).unwrap();
    expect_failure(
        dir.path(),
        "./scene.toml",
        &[],
        &[&format!("orange-box.obj:{line}"), "99999"],
    );
}

#[test]
fn error_nan_in_obj() {
    let (dir, _) = exported();
    let obj = dir.path().join("column.obj");
    let text = std::fs::read_to_string(&obj).unwrap();
    let bad = text.replacen("\nvn ", "\nv 0 NaN 1\nvn ", 1);
    let line = line_of(&bad, "v 0 NaN 1");
    std::fs::write(&obj, bad).unwrap();
    expect_failure(
        dir.path(),
        "./scene.toml",
        &[],
        &[&format!("column.obj:{line}"), "non-finite"],
    );
}

/// A missing texture is a warning naming the MTL, the material and the file, and the frame
/// renders with the material's `Kd`. Negative: with the texture there, no such warning.
#[test]
fn a_missing_texture_warns_and_renders() {
    let (dir, _) = exported();
    let args = ["render", "./scene.toml", "-o", "out.png", "--method", "bvh"];
    let o = run(&args, dir.path());
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(!o.stderr.contains("not found"), "{}", o.stderr);
    std::fs::remove_file(dir.path().join("stripes.png")).unwrap();
    std::fs::remove_file(dir.path().join("out.png")).unwrap();
    let o = run(&args, dir.path());
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let warning = o
        .stderr
        .lines()
        .find(|l| l.contains("stripes.png"))
        .unwrap_or_else(|| panic!("no warning: {}", o.stderr));
    assert!(
        warning.contains("materials.mtl") && warning.contains("back-wall"),
        "{warning}"
    );
    assert!(dir.path().join("out.png").is_file());
}

#[test]
fn error_nan_in_transform() {
    let (dir, toml) = exported();
    let broken = toml.replacen(
        "translate = [0.0, 1.2, 0.0]",
        "translate = [0.0, nan, 0.0]",
        1,
    );
    assert_ne!(toml, broken);
    let line = line_of(&broken, "translate = [0.0, nan");
    std::fs::write(dir.path().join("scene.toml"), &broken).unwrap();
    expect_failure(
        dir.path(),
        "./scene.toml",
        &[],
        &[
            &format!("scene.toml:{line}"),
            "mesh[1].transform.translate",
            "NaN",
        ],
    );
}

#[test]
fn error_zero_or_absurd_resolution() {
    let dir = tempfile::tempdir().unwrap();
    expect_failure(
        dir.path(),
        "default",
        &["--width", "0"],
        &["--width/--height", "width 0"],
    );
    expect_failure(
        dir.path(),
        "default",
        &["--width", "64", "--height", "100000"],
        &["height 100000"],
    );
    // Alone, --height keeps the camera's 4:3 aspect: the width it implies is out of range too.
    expect_failure(
        dir.path(),
        "default",
        &["--height", "100000"],
        &["width 133333"],
    );
    let (dir, toml) = exported();
    let broken = toml.replacen("resolution = [640, 480]", "resolution = [0, 480]", 1);
    assert_ne!(toml, broken);
    let line = line_of(&broken, "resolution = [0, 480]");
    std::fs::write(dir.path().join("scene.toml"), broken).unwrap();
    expect_failure(
        dir.path(),
        "./scene.toml",
        &[],
        &[
            &format!("scene.toml:{line}"),
            "camera[0].resolution",
            "width 0",
        ],
    );
}

#[test]
fn error_unknown_scene_name() {
    let dir = tempfile::tempdir().unwrap();
    expect_failure(
        dir.path(),
        "no-such-scene",
        &[],
        &["unknown scene 'no-such-scene'", "sphere-room"],
    );
    let o = run(&["scene", "export", "no-such-scene", "x"], dir.path());
    assert_eq!(o.code, Some(1));
    assert!(o.stderr.contains("unknown scene"), "{}", o.stderr);
    assert!(!dir.path().join("x").exists());
}

#[test]
fn error_a_mesh_file_given_as_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("panel.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    // With or without a folder, any case of the extension: the message says what a scene is.
    for scene in ["panel.obj", "./panel.obj", "Panel.OBJ"] {
        expect_failure(
            dir.path(),
            scene,
            &[],
            &[
                scene,
                "a scene is a .toml file",
                "[[mesh]]",
                "cubetrace scene export",
            ],
        );
    }
    // Negative: a scene file that names the same OBJ renders past the loader (to its own error:
    // it has no reflector), so the message above is the extension's, not the file's content's.
    std::fs::write(
        dir.path().join("panel.toml"),
        "[[mesh]]\nobj = \"panel.obj\"\n[[camera]]\neye = [0, 0, 3]\ntarget = [0, 0, 0]\n",
    )
    .unwrap();
    let o = run(&["render", "panel.toml", "-o", "out.png"], dir.path());
    assert!(
        !o.stderr.contains("a scene is a .toml file"),
        "{}",
        o.stderr
    );
}

#[test]
fn error_bad_output_extension() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["render", "default", "-o", "x.jpg"], dir.path());
    assert_eq!(o.code, Some(1));
    assert!(o.stderr.contains("x.jpg"), "{}", o.stderr);
    assert!(!dir.path().join("x.jpg").exists());
}

#[test]
fn cli_render_exr_and_default_path() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_cubetrace"))
        .args(["render", "--width", "64", "--height", "48"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    // The default method is the compute path.
    assert!(stdout.contains("out/default-compute.png"), "{stdout}");
    let img = image::open(dir.path().join("out/default-compute.png")).unwrap();
    assert_eq!((img.width(), img.height()), (64, 48));

    let o = run(
        &[
            "render",
            "torus",
            "--method",
            "reference",
            "--width",
            "32",
            "--height",
            "24",
            "-o",
            "t.exr",
        ],
        dir.path(),
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let exr = exr::prelude::read_all_flat_layers_from_file(dir.path().join("t.exr")).unwrap();
    let names: Vec<String> = exr.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    for n in [
        "R",
        "G",
        "B",
        "mask",
        "hit.X",
        "hit.Y",
        "hit.Z",
        "object_id",
        "primitive_id",
        "bounces",
    ] {
        assert!(names.iter().any(|x| x == n), "{n} missing from {names:?}");
    }
}

/// The GPU methods' EXR carries the traced hit position and the unresolved mask.
#[test]
fn cli_render_fragment_exr_channels() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &[
            "render", "bowl", "--method", "fragment", "--width", "32", "--height", "24", "-o",
            "b.exr",
        ],
        dir.path(),
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let exr = exr::prelude::read_all_flat_layers_from_file(dir.path().join("b.exr")).unwrap();
    let list = &exr.layer_data[0].channel_data.list;
    let channel = |n: &str| {
        list.iter()
            .find(|c| c.name.to_string() == n)
            .unwrap_or_else(|| panic!("{n} missing"))
    };
    for n in [
        "R",
        "G",
        "B",
        "mask",
        "P.X",
        "hit.X",
        "hit.Y",
        "hit.Z",
        "unresolved",
    ] {
        channel(n);
    }
    // Some mirror pixels have a finite traced hit.
    let mask = channel("mask");
    let hit = channel("hit.X");
    let hits = (0..32 * 24)
        .filter(|&i| {
            mask.sample_data.value_by_flat_index(i).to_f32() == 1.0
                && hit.sample_data.value_by_flat_index(i).to_f32().is_finite()
        })
        .count();
    assert!(hits > 10, "{hits} traced hits");
    // The verified hit's triangle (object, and primitive within it): present exactly where a
    // hit is, and the hit point lies on it (a neighbouring index does not fit: the check can
    // fail).
    let prim = channel("primitive_id");
    let object = channel("object_id");
    let world = builtin::by_name("bowl").unwrap().world();
    let corners = triangle_corners(&world);
    let at = |c: &exr::prelude::AnyChannel<exr::prelude::FlatSamples>, i: usize| {
        c.sample_data.value_by_flat_index(i).to_f32()
    };
    let on = |tri: u32, p: Vec3| {
        corners.get(tri as usize).is_some_and(|&[a, b, c]| {
            let n = (b - a).cross(c - a);
            let inside = [(a, b), (b, c), (c, a)]
                .iter()
                .all(|&(u, v)| (v - u).cross(p - u).dot(n) >= -1e-4 * n.length_squared());
            inside && (p - a).dot(n.normalize()).abs() < 1e-3
        })
    };
    let (mut on_tri, mut on_other) = (0, 0);
    let id = |c: &exr::prelude::AnyChannel<exr::prelude::FlatSamples>, i: usize| match c
        .sample_data
        .value_by_flat_index(i)
    {
        exr::prelude::Sample::U32(v) => v,
        s => panic!("{} is {s:?}, not u32", c.name),
    };
    for i in 0..32 * 24 {
        let (o, id) = (id(object, i), id(prim, i));
        let p = Vec3::new(at(hit, i), at(channel("hit.Y"), i), at(channel("hit.Z"), i));
        let is_hit = at(mask, i) == 1.0 && p.x.is_finite();
        assert_eq!(id != u32::MAX, is_hit, "pixel {i}: id {id}, hit {p}");
        assert_eq!(o != u32::MAX, is_hit, "pixel {i}: object {o}, hit {p}");
        if is_hit {
            let tri = world.objects[o as usize].first_triangle + id;
            on_tri += usize::from(on(tri, p));
            on_other += usize::from(on(tri ^ 1, p));
        }
    }
    assert_eq!(on_tri, hits, "hits off their primitive_id's triangle");
    assert!(
        on_other < hits / 2,
        "{on_other} of {hits} also on the neighbouring triangle"
    );
    // Methods that do not verify write no triangle IDs.
    let o = run(
        &[
            "render", "bowl", "--method", "envmap", "--width", "32", "--height", "24", "-o",
            "e.exr",
        ],
        dir.path(),
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let exr = exr::prelude::read_all_flat_layers_from_file(dir.path().join("e.exr")).unwrap();
    let list = &exr.layer_data[0].channel_data.list;
    assert!(list.iter().all(|c| !c.name.to_string().ends_with("_id")));
}

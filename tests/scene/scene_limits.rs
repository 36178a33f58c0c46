//! What a scene file may hold (coordinates, transforms, colours, angles and points within the
//! bounds f32 and the renderer can carry; names used once): each refusal names the file, the line
//! and the field with the numbers, and each has a negative (the nearest accepted value loads).
//! Also the one CMO limit of the file and `--cmos`, and `scene export --force` over another
//! scene's export.

use std::path::{Path, PathBuf};
use std::process::Command;

use cubetrace::scene::{self, MAX_CMOS, Scene, export};

const MIRROR_OBJ: &str = "v -1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
const CAMERA: &str = "[[camera]]\neye = [0, 0.5, 3]\ntarget = [0, 0.5, 0]\nresolution = [8, 8]\n";

/// Writes `scene.toml` in `dir`: `head` TOML (line 1), the mirror's `[[mesh]]` (`obj` as
/// `mirror.obj`, with `mirror` on line 5), `tail`, then an unnamed camera. `box.obj` (a
/// triangle) is there for `tail`'s meshes.
fn write(dir: &Path, obj: &str, head: &str, mirror: &str, tail: &str) -> PathBuf {
    std::fs::write(dir.join("mirror.obj"), obj).unwrap();
    std::fs::write(dir.join("box.obj"), MIRROR_OBJ).unwrap();
    let toml = format!(
        "{head}\n[[mesh]]\nobj = \"mirror.obj\"\nreflector = true\n{mirror}\n{tail}\n{CAMERA}"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    path
}

fn load(obj: &str, head: &str, mirror: &str, tail: &str) -> Result<Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), obj, head, mirror, tail);
    scene::load_scene_file(&path).map_err(|e| e.to_string())
}

/// Asserts that the scene is refused with every one of `needles` in the message.
fn refused(obj: &str, head: &str, mirror: &str, tail: &str, needles: &[&str]) {
    let e = load(obj, head, mirror, tail).expect_err("must be refused");
    for n in needles {
        assert!(e.contains(n), "expected '{n}' in: {e}");
    }
}

fn accepted(obj: &str, head: &str, mirror: &str, tail: &str) -> Scene {
    load(obj, head, mirror, tail).unwrap_or_else(|e| panic!("must load: {e}"))
}

fn triangles(s: &Scene, mesh: usize) -> usize {
    s.meshes[mesh].parts.iter().map(|p| p.triangles.len()).sum()
}

#[test]
fn a_vertex_beyond_2_to_60_is_named_by_line() {
    // Case 7: 1e30 is finite in f32, but its triangle's area overflowed and the reflector
    // "held no triangles".
    for far in ["1e30", "-2e18"] {
        let obj = format!("v -1 0 0\nv 1 0 0\nv 0 1 {far}\nf 1 2 3\n");
        refused(&obj, "", "", "", &["mirror.obj:3", far, "2^60"]);
    }
    // Negatives: 1e18 (under 2^60 = 1.15e18) loads, its triangle kept (f32 overflowed there
    // too); so does a tiny one of 1e-20 sides scaled up, which f32 took for zero area.
    for (far, mirror) in [("1e18", ""), ("1e-20", "transform = { scale = 1e20 }")] {
        let obj = format!("v 0 0 0\nv {far} 0 0\nv 0 {far} 0\nf 1 2 3\n");
        let s = accepted(&obj, "", mirror, "");
        assert_eq!(triangles(&s, 0), 1, "{far}");
    }
}

#[test]
fn a_transform_that_collapses_or_overflows_a_mesh_is_refused() {
    // Case 9: scale 1e-20 made the mirror vanish without a word.
    let t = |scale: &str| format!("transform = {{ scale = {scale}, translate = [0, 0.5, 0] }}");
    refused(
        MIRROR_OBJ,
        "",
        &t("1e-20"),
        "",
        &["scene.toml:5", "mesh[0].transform.scale", "1e-20", "2^-21"],
    );
    refused(
        MIRROR_OBJ,
        "",
        &t("[1e-20, 1e-20, 1]"),
        "",
        &["mesh[0].transform.scale"],
    );
    refused(
        MIRROR_OBJ,
        "",
        &t("1e19"),
        "",
        &["mesh[0].transform.scale", "1e19", "2^60"],
    );
    // Negatives: 1e-3 across at 3 from the origin is 2^-10 of it; a flat scale leaves the
    // mesh its other sides; 1e17 stays below 2^60.
    for scale in ["1e-3", "[1, 1e-20, 1]", "1e17"] {
        accepted(MIRROR_OBJ, "", &t(scale), "");
    }
    // A translation past 2^60 names itself.
    refused(
        MIRROR_OBJ,
        "",
        "transform = { translate = [2e18, 0, 0] }",
        "",
        &["mesh[0].transform.translate", "2^60"],
    );
}

#[test]
fn colours_and_light_must_be_non_negative_and_at_most_65504() {
    for (head, field, line) in [
        ("background = [-5, 1e30, 0]", "background", 1),
        ("background = [0, 1e30, 0]", "background", 1),
        (
            "[shading]\nlight_intensity = -1",
            "shading.light_intensity",
            2,
        ),
        (
            "[shading]\nlight_intensity = 7e4",
            "shading.light_intensity",
            2,
        ),
    ] {
        let at = format!("scene.toml:{line}");
        refused(MIRROR_OBJ, head, "", "", &[field, "65504", &at]);
    }
    for head in [
        "background = [0, 65504, 0.5]",
        "[shading]\nlight_intensity = 0",
        "[shading]\nlight_intensity = 3",
    ] {
        accepted(MIRROR_OBJ, head, "", "");
    }
    // MTL Kd, by line; negative: Kd 0.5.
    let dir = tempfile::tempdir().unwrap();
    let obj = format!("mtllib m.mtl\nusemtl a\n{MIRROR_OBJ}");
    for (kd, ok) in [("-0.5", false), ("1e5", false), ("0.5", true)] {
        std::fs::write(dir.path().join("m.mtl"), format!("newmtl a\nKd {kd}\n")).unwrap();
        let r = scene::load_scene_file(&write(dir.path(), &obj, "", "", ""));
        match (r, ok) {
            (Err(e), false) => assert!(e.to_string().contains("m.mtl:2"), "{e}"),
            (Ok(_), true) => {}
            (r, _) => panic!("Kd {kd}: {:?}", r.map(|_| ())),
        }
    }
}

#[test]
fn angles_and_points_have_bounds() {
    refused(
        MIRROR_OBJ,
        "",
        "transform = { rotate_deg = [0, 400, 0] }",
        "",
        &["rotate_deg", "400", "[-360, 360]"],
    );
    accepted(
        MIRROR_OBJ,
        "",
        "transform = { rotate_deg = [0, -360, 0] }",
        "",
    );
    refused(
        MIRROR_OBJ,
        "",
        "",
        "[cmo]\ncentres = [[0, 0, 3e18]]",
        &["cmo.centres[0]", "2^60"],
    );
    accepted(MIRROR_OBJ, "", "", "[cmo]\ncentres = [[0, 0, 3e3]]");
}

#[test]
fn duplicate_names_are_refused_naming_both_entries() {
    let other = "[[mesh]]\nobj = \"box.obj\"\n";
    // Mesh names, both given: the two entries by field and line.
    refused(
        MIRROR_OBJ,
        "",
        "name = \"a\"",
        &format!("{other}name = \"a\""),
        &[
            "'a'",
            "mesh[0].name (",
            "scene.toml:5",
            "mesh[1].name (",
            "scene.toml:8",
        ],
    );
    // A given name against one derived from an OBJ's stem.
    refused(
        MIRROR_OBJ,
        "",
        "name = \"box\"",
        other,
        &["'box'", "mesh[1].name (derived from its file name)"],
    );
    // Negatives: distinct names load; the same OBJ twice without names is numbered.
    let s = accepted(
        MIRROR_OBJ,
        "",
        "name = \"a\"",
        &format!("{other}name = \"b\""),
    );
    assert_eq!((&*s.meshes[0].name, &*s.meshes[1].name), ("a", "b"));
    let s = accepted(MIRROR_OBJ, "", "", &format!("{other}{other}{other}"));
    let names: Vec<&str> = s.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["mirror", "box", "box-2", "box-3"]);
    // Camera names.
    let cam = |name: &str| format!("{CAMERA}name = \"{name}\"\n");
    refused(
        MIRROR_OBJ,
        "",
        "",
        &format!("{}{}", cam("main"), cam("main")),
        &["'main'", "camera[0].name (", "camera[1].name ("],
    );
    // (The tail's camera is camera[0]; the fixed one after it, unnamed, is camera1.)
    refused(
        MIRROR_OBJ,
        "",
        "",
        &cam("camera1"),
        &["'camera1'", "camera[1].name"],
    );
    accepted(MIRROR_OBJ, "", "", &cam("side"));
}

#[test]
fn cmo_count_has_one_limit_in_files_and_on_the_command_line() {
    let count = |n: u32| format!("[cmo]\ncount = {n}");
    refused(
        MIRROR_OBJ,
        "",
        "",
        &count(MAX_CMOS + 1),
        &["cmo.count", &format!("1 to {MAX_CMOS}")],
    );
    accepted(MIRROR_OBJ, "", "", &count(MAX_CMOS));
    let centres = |n: u32| {
        let list: Vec<&str> = (0..n).map(|_| "[0, 0.5, 1]").collect();
        format!("[cmo]\ncentres = [{}]", list.join(", "))
    };
    refused(
        MIRROR_OBJ,
        "",
        "",
        &centres(MAX_CMOS + 1),
        &["cmo.centres", "at most"],
    );
    accepted(MIRROR_OBJ, "", "", &centres(MAX_CMOS));
    // The CLI: MAX_CMOS + 1 refused by the parser, MAX_CMOS renders (the reference, tiny).
    let dir = tempfile::tempdir().unwrap();
    let cli = |n: u32| {
        Command::new(env!("CARGO_BIN_EXE_cubetrace"))
            .args(["render", "default", "--method", "compute", "--width", "4"])
            .args(["--height", "3", "--cube-size", "8", "-o", "x.png"])
            .args(["--cmos", &n.to_string()])
            .current_dir(dir.path())
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .output()
            .unwrap()
    };
    let o = cli(MAX_CMOS + 1);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(&format!("1..={MAX_CMOS}")), "{err}");
    let o = cli(MAX_CMOS);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The files of `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn export_cli(name: &str, dir: &Path, force: bool) -> std::process::Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cubetrace"));
    c.args(["scene", "export", name]).arg(dir);
    if force {
        c.arg("--force");
    }
    c.output().unwrap()
}

#[test]
fn export_force_leaves_exactly_the_new_export_and_the_users_files() {
    let root = tempfile::tempdir().unwrap();
    // What a clean export of `default` holds.
    let clean = root.path().join("clean");
    assert!(export_cli("default", &clean, false).status.success());
    let mut want = listing(&clean);

    let dir = root.path().join("d");
    assert!(export_cli("teapot", &dir, false).status.success());
    // The user's files: a note, and a copy of an exported OBJ that no scene.toml names.
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    std::fs::copy(dir.join("teapot.obj"), dir.join("my-teapot.obj")).unwrap();
    // Negative: without --force the earlier export stays as it was.
    let o = export_cli("default", &dir, false);
    assert_eq!(o.status.code(), Some(1));
    assert!(dir.join("teapot.obj").exists());
    let o = export_cli("default", &dir, true);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    want.extend(["my-teapot.obj".to_string(), "notes.txt".to_string()]);
    want.sort();
    assert_eq!(listing(&dir), want);
    // The export loads, and is the built-in.
    let loaded = scene::load_scene_file(&dir.join("scene.toml")).unwrap();
    scene::builtin::default().compare_content(&loaded).unwrap();

    // Negative: a scene.toml not written by an export is no export; --force overwrites it
    // and removes nothing.
    let own = root.path().join("own");
    assert!(export_cli("teapot", &own, false).status.success());
    let toml = std::fs::read_to_string(own.join("scene.toml")).unwrap();
    std::fs::write(own.join("scene.toml"), toml.replacen(export::MARK, "me", 1)).unwrap();
    assert!(export::exported_files(&own).is_empty());
    let before = listing(&own);
    assert!(export_cli("default", &own, true).status.success());
    let after = listing(&own);
    assert!(
        before.iter().all(|f| after.contains(f)),
        "{before:?} {after:?}"
    );
    assert!(after.contains(&"teapot.obj".to_string()));
}

//! What real exporters write that the loader once refused or read wrong: line ends of classic
//! Mac OS, names in Latin-1, NaN as Microsoft's C runtime prints it, a binary file named as an
//! OBJ, file names in quotes or in another letter case, a texture whose extension lies. Each
//! accepted form is checked for what it loads as and its warning, each refusal for the file
//! and line it names; each has its negative.

use std::path::{Path, PathBuf};

use cubetrace::scene::{self, LoadReport, Scene, WarningKind};
use glam::Vec3;

const MIRROR_OBJ: &str = "v -1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
const CAMERA: &str = "[[camera]]\neye = [0, 0.5, 3]\ntarget = [0, 0.5, 0]\nresolution = [8, 8]\n";
/// A textured unit quad at z = -1 with material `tex` of `lib.mtl`.
const QUAD_OBJ: &str = "mtllib lib.mtl\nv 0 0 -1\nv 1 0 -1\nv 1 1 -1\nv 0 1 -1\n\
                        vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl tex\nf 1/1 2/2 3/3 4/4\n";

/// Writes `files` (name, bytes) into `dir`, a triangle mirror and a scene file placing the
/// mirror and `mesh.obj`; returns the scene file's path.
fn write(dir: &Path, files: &[(&str, &[u8])]) -> PathBuf {
    for (name, bytes) in files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
    std::fs::write(dir.join("mirror.obj"), MIRROR_OBJ).unwrap();
    let toml = format!(
        "[[mesh]]\nobj = \"mirror.obj\"\nreflector = true\n\n\
         [[mesh]]\nobj = \"mesh.obj\"\n\n{CAMERA}"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    path
}

fn load(files: &[(&str, &[u8])]) -> Result<(Scene, LoadReport), String> {
    let dir = tempfile::tempdir().unwrap();
    scene::load_scene_file_report(&write(dir.path(), files)).map_err(|e| e.to_string())
}

fn load_ok(files: &[(&str, &[u8])]) -> (Scene, LoadReport) {
    load(files).unwrap_or_else(|e| panic!("load failed: {e}"))
}

/// Triangles of the test mesh (mesh 1).
fn triangles(scene: &Scene) -> usize {
    scene.meshes[1]
        .parts
        .iter()
        .map(|p| p.triangles.len())
        .sum()
}

/// The diffuse colour and texture of the test mesh's first part.
fn material(scene: &Scene) -> (Vec3, Option<u32>) {
    let m = &scene.materials[scene.meshes[1].parts[0].material as usize];
    (m.diffuse, m.texture)
}

#[test]
fn classic_mac_line_ends_load_as_lines() {
    let mtl = b"newmtl tex\rKd 0.1 0.2 0.3\r";
    let obj = QUAD_OBJ.replace('\n', "\r");
    let (scene, report) = load_ok(&[("mesh.obj", obj.as_bytes()), ("lib.mtl", mtl)]);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(triangles(&scene), 2);
    assert_eq!(material(&scene).0, Vec3::new(0.1, 0.2, 0.3));
    // Line numbers count a lone CR, a CRLF and an LF alike.
    let bad = b"v 0 0 0\rv 1 0 0\r\nv 0 1 0\nf 1 2 x\r";
    let e = load(&[("mesh.obj", bad)]).unwrap_err();
    assert!(e.contains("mesh.obj:4") && e.contains("'x'"), "{e}");
}

#[test]
fn latin1_names_load_with_a_warning_naming_the_line() {
    // A Windows exporter's names in Latin-1, in the OBJ and the MTL alike: "Café".
    let obj = b"mtllib lib.mtl\no Caf\xE9\nv 0 0 -1\nv 1 0 -1\nv 0 1 -1\nusemtl Caf\xE9\nf 1 2 3\n";
    let mtl = b"# r\xE9sum\xE9\nnewmtl Caf\xE9\nKd 0.1 0.2 0.3\n";
    let (scene, report) = load_ok(&[("mesh.obj", obj), ("lib.mtl", mtl)]);
    assert_eq!(material(&scene).0, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(scene.meshes[1].parts[0].name, "Café");
    assert_eq!(report.count(WarningKind::Latin1Text), 3);
    let lines: Vec<_> = report
        .warnings
        .iter()
        .filter(|w| w.kind == WarningKind::Latin1Text)
        .map(|w| (w.path.file_name().unwrap().to_owned(), w.lines.clone()))
        .collect();
    assert_eq!(
        lines,
        [("mesh.obj".into(), vec![2, 6]), ("lib.mtl".into(), vec![2])]
    );
    // Negative: the same names in UTF-8, and a Latin-1 comment, warn about nothing.
    let obj: String = obj.iter().map(|&b| char::from(b)).collect();
    let mtl = "# r\u{e9}sum\u{e9}\nnewmtl Caf\u{e9}\nKd 0.1 0.2 0.3\n";
    let (scene, report) = load_ok(&[("mesh.obj", obj.as_bytes()), ("lib.mtl", mtl.as_bytes())]);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(material(&scene).0, Vec3::new(0.1, 0.2, 0.3));
}

#[test]
fn a_binary_file_is_refused_naming_its_line() {
    let e = load(&[("mesh.obj", b"solid x\n\x00\x01\x02\x03\n")]).unwrap_err();
    assert!(
        e.contains("mesh.obj:2") && e.contains("binary file") && e.contains("column 1"),
        "{e}"
    );
    // In an MTL too.
    let e = load(&[
        ("mesh.obj", QUAD_OBJ.as_bytes()),
        ("lib.mtl", b"newmtl tex\nKd 1 1 1\x00\n"),
    ])
    .unwrap_err();
    assert!(e.contains("lib.mtl:2") && e.contains("column 9"), "{e}");
}

#[test]
fn msvc_nan_is_refused_not_read_as_a_comment() {
    for (text, shown) in [
        ("v 0 0 -1\nv 1 0 -1\nv 0 1 1.#QNAN0\nf 1 2 3\n", "1.#QNAN0"),
        (
            "v 0 0 -1\nv 1 0 -1\nv 0 1 -1.#IND00\nf 1 2 3\n",
            "-1.#IND00",
        ),
        ("v 0 0 -1\nv 1 0 -1\nv 0 1 1.#inf\nf 1 2 3\n", "1.#inf"),
    ] {
        let e = load(&[("mesh.obj", text.as_bytes())]).unwrap_err();
        assert!(
            e.contains("mesh.obj:3") && e.contains(&format!("'{shown}'")),
            "{e}"
        );
    }
    // Negative: a comment right after a number is a comment.
    let (scene, _) = load_ok(&[(
        "mesh.obj",
        b"v 0 0 -1\nv 1 0 -1.#INDEX 2\nv 0 1 -1#INF\nf 1 2 3\n",
    )]);
    assert_eq!(triangles(&scene), 1);
}

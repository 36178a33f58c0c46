//! Real-world OBJ/MTL input, scene file checks and set-up diagnostics. Each accepted oddity is checked for what it loads as, and for the warning that
//! counts it; each refusal for the file and line it names.

use std::path::{Path, PathBuf};
use std::process::Command;

use cubetrace::scene::{self, LoadReport, Scene, WarningKind};
use glam::{Vec2, Vec3};

const MIRROR_OBJ: &str = "v -1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
const CAMERA: &str = "[[camera]]\neye = [0, 0.5, 3]\ntarget = [0, 0.5, 0]\nresolution = [8, 8]\n";

/// Writes `scene.toml` with the given meshes (file name, OBJ bytes, reflector) and `extra`
/// TOML (before the meshes), plus `lib.mtl` when `mtl` is given. Returns the TOML path.
fn write_scene(
    dir: &Path,
    extra: &str,
    meshes: &[(&str, &[u8], bool)],
    mtl: Option<&[u8]>,
    tail: &str,
) -> PathBuf {
    let mut toml = format!("{extra}\n");
    for (file, obj, reflector) in meshes {
        std::fs::write(dir.join(file), obj).unwrap();
        toml += &format!("[[mesh]]\nobj = \"{file}\"\nreflector = {reflector}\n\n");
    }
    if let Some(m) = mtl {
        std::fs::write(dir.join("lib.mtl"), m).unwrap();
    }
    toml += CAMERA;
    toml += tail;
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    path
}

/// A scene with a triangle mirror and `obj` as a second, non-reflecting mesh (`mesh.obj`).
fn scene_with(dir: &Path, obj: &[u8], mtl: Option<&[u8]>) -> PathBuf {
    write_scene(
        dir,
        "",
        &[
            ("mirror.obj", MIRROR_OBJ.as_bytes(), true),
            ("mesh.obj", obj, false),
        ],
        mtl,
        "",
    )
}

fn load(obj: &[u8], mtl: Option<&[u8]>) -> Result<(Scene, LoadReport), String> {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_with(dir.path(), obj, mtl);
    scene::load_scene_file_report(&path).map_err(|e| e.to_string())
}

fn load_ok(obj: &[u8], mtl: Option<&[u8]>) -> (Scene, LoadReport) {
    load(obj, mtl).unwrap_or_else(|e| panic!("load failed: {e}"))
}

/// Total area of mesh 1 (the test mesh).
fn area(scene: &Scene) -> f32 {
    scene.meshes[1]
        .parts
        .iter()
        .flat_map(|p| {
            p.triangles.iter().map(|t| {
                let [a, b, c] = t.map(|i| p.positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
        })
        .sum()
}

fn diffuse(scene: &Scene) -> Vec3 {
    let p = &scene.meshes[1].parts[0];
    scene.materials[p.material as usize].diffuse
}

const QUAD: &str = "v 0 0 -1\nv 1 0 -1\nv 1 1 -1\nv 0 1 -1\n";
const QUAD_OBJ: &str =
    "mtllib lib.mtl\nv 0 0 -1\nv 1 0 -1\nv 1 1 -1\nv 0 1 -1\nusemtl grey\nf 1 2 3 4\n";

// ---- Item 4: OBJ ----

#[test]
fn two_vertex_faces_are_skipped_with_one_counted_warning() {
    // As in the pybullet samurai monastery OBJ: 201 two-vertex faces among real ones.
    let mut obj = String::from(QUAD);
    obj += "f 1 2 3 4\n";
    for k in 0..201 {
        obj += &format!("f {} {}\n", 1 + k % 4, 1 + (k + 1) % 4);
    }
    obj += "f 1\nf\n";
    let (scene, report) = load_ok(obj.as_bytes(), None);
    assert_eq!(report.count(WarningKind::ShortFace), 203);
    let w: Vec<_> = report
        .warnings
        .iter()
        .filter(|w| w.kind == WarningKind::ShortFace)
        .collect();
    assert_eq!(w.len(), 1, "one merged warning");
    assert_eq!(w[0].lines[..3], [6, 7, 8]);
    assert!(w[0].to_string().contains("mesh.obj"), "{}", w[0]);
    assert!((area(&scene) - 1.0).abs() < 1e-6);
    // Negative: a clean file has no such warning.
    let (_, report) = load_ok(format!("{QUAD}f 1 2 3 4\n").as_bytes(), None);
    assert_eq!(report.count(WarningKind::ShortFace), 0);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
}

#[test]
fn line_and_point_elements_are_skipped_never_filled() {
    let obj = format!("{QUAD}f 1 2 3\nl 1 2 3 4 1\nl 2 4\np 1 2\n");
    let (scene, report) = load_ok(obj.as_bytes(), None);
    assert_eq!(report.count(WarningKind::LineElement), 2);
    assert_eq!(report.count(WarningKind::PointElement), 1);
    // Only the triangle: the closed line 1-2-3-4 is not a polygon.
    assert!((area(&scene) - 0.5).abs() < 1e-6, "{}", area(&scene));
    let tris: usize = scene.meshes[1]
        .parts
        .iter()
        .map(|p| p.triangles.len())
        .sum();
    assert_eq!(tris, 1);
}

#[test]
fn concave_polygons_are_ear_clipped() {
    // An L (area 3) starting at a corner from which a fan leaves the polygon.
    let obj = "v 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\nv 2 0 0\nf 1 2 3 4 5 6\n";
    let (scene, _) = load_ok(obj.as_bytes(), None);
    assert!((area(&scene) - 3.0).abs() < 1e-5, "area {}", area(&scene));
    // Every triangle lies in the L: its centroid is not in the notch [1, 2] x [1, 2], and it
    // faces +z like the polygon.
    let p = &scene.meshes[1].parts[0];
    for t in &p.triangles {
        let [a, b, c] = t.map(|i| p.positions[i as usize]);
        let m = (a + b + c) / 3.0;
        assert!(!(m.x > 1.0 && m.y > 1.0), "triangle {t:?} in the notch");
        assert!((b - a).cross(c - a).z > 0.0);
    }
    // The same corners in an order that crosses itself load as their fan from the first
    // corner (as tobj and Blender do), with a warning naming the line.
    let bad =
        "v 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\nv 2 0 0\nf 1 2 3 4 5 6\nf 1 4 2 5 3 6\n";
    let (scene, report) = load_ok(bad.as_bytes(), None);
    assert_eq!(report.count(WarningKind::SelfCrossingPolygon), 1);
    let w = report
        .warnings
        .iter()
        .find(|w| w.kind == WarningKind::SelfCrossingPolygon)
        .unwrap();
    assert_eq!(w.lines, vec![8]);
    assert!(w.detail.contains("crosses itself"), "{}", w.detail);
    let p = &scene.meshes[1].parts[0];
    let fan: Vec<[u32; 3]> = [[0u32, 3, 1], [0, 1, 4], [0, 4, 2], [0, 2, 5]].to_vec();
    let last: Vec<[u32; 3]> = p.triangles[p.triangles.len() - 4..]
        .iter()
        .map(|t| t.map(|i| p.positions[i as usize]))
        .map(|c| {
            let corner = |v: Vec3| {
                let all = [(2., 1.), (1., 1.), (1., 2.), (0., 2.), (0., 0.), (2., 0.)];
                all.iter()
                    .position(|&(x, y)| v == Vec3::new(x, y, 0.0))
                    .unwrap() as u32
            };
            c.map(corner)
        })
        .collect();
    assert_eq!(last, fan);
}

/// A 2x1 RGBA PNG, red then green.
fn write_png(path: &Path) {
    let img = image::RgbaImage::from_raw(2, 1, vec![255, 0, 0, 255, 0, 255, 0, 255]).unwrap();
    img.save(path).unwrap();
}

#[test]
fn a_face_without_vt_keeps_the_mesh_texture() {
    let dir = tempfile::tempdir().unwrap();
    write_png(&dir.path().join("tex.png"));
    let obj = format!(
        "mtllib lib.mtl\n{QUAD}v 2 0 -1\nvt 0.25 0.5\nvt 0.75 0.5\nvt 0.75 1\nvt 0.25 1\n\
         usemtl tex\nf 1/1 2/2 3/3 4/4\nf 2 5 3\n"
    );
    let path = scene_with(
        dir.path(),
        obj.as_bytes(),
        Some(b"newmtl tex\nKd 1 1 1\nmap_Kd tex.png\n"),
    );
    let (scene, report) = scene::load_scene_file_report(&path).unwrap();
    let p = &scene.meshes[1].parts[0];
    assert_eq!(p.triangles.len(), 3);
    assert_eq!(p.uvs.len(), p.positions.len(), "the part keeps its uvs");
    assert!(scene.materials[p.material as usize].texture.is_some());
    // The textured face's corners keep their vt; the other face's corners get (0, 0).
    let uv_at = |pos: Vec3| {
        let k = p.positions.iter().position(|&q| q == pos).unwrap();
        p.uvs[k]
    };
    assert_eq!(uv_at(Vec3::new(0.0, 0.0, -1.0)), Vec2::new(0.25, 0.5));
    assert_eq!(uv_at(Vec3::new(0.0, 1.0, -1.0)), Vec2::new(0.25, 1.0));
    assert_eq!(uv_at(Vec3::new(2.0, 0.0, -1.0)), Vec2::ZERO);
    assert_eq!(report.count(WarningKind::MissingTexcoords), 1);
    assert_eq!(report.warnings[0].lines, [13]);
    // Negative: with vt on both faces there is no warning.
    let all = obj.replace("f 2 5 3", "f 2/2 5/2 3/3");
    let path = scene_with(dir.path(), all.as_bytes(), None);
    let (_, report) = scene::load_scene_file_report(&path).unwrap();
    assert_eq!(report.count(WarningKind::MissingTexcoords), 0);
}

#[test]
fn byte_order_marks_are_skipped() {
    let bom = |s: &str| [b"\xEF\xBB\xBF".as_slice(), s.as_bytes()].concat();
    let (scene, report) = load_ok(&bom(QUAD_OBJ), Some(&bom("newmtl grey\nKd 0.1 0.2 0.3\n")));
    // Were a mark read as part of `mtllib` or `newmtl`, the material would be missing.
    assert_eq!(diffuse(&scene), Vec3::new(0.1, 0.2, 0.3));
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    // Negative: a mark inside the file is not skipped (here it spoils a keyword).
    let mid = QUAD_OBJ.replace("usemtl", "\u{FEFF}usemtl");
    let (scene, _) = load_ok(mid.as_bytes(), Some(b"newmtl grey\nKd 0.1 0.2 0.3\n"));
    assert_eq!(diffuse(&scene), Vec3::splat(0.8));
}

#[test]
fn latin1_in_comments_is_fine_elsewhere_read_as_latin1_naming_the_line() {
    let obj = [
        b"# caf\xE9 cr\xE8me\n".as_slice(),
        QUAD_OBJ.as_bytes(),
        b"# \xFF\n",
    ]
    .concat();
    let mtl = b"# r\xE9sum\xE9\nnewmtl grey # gr\xEDs\nKd 0.5\n";
    let (scene, report) = load_ok(&obj, Some(mtl));
    assert_eq!(diffuse(&scene), Vec3::splat(0.5));
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    // Outside a comment: read as Latin-1 (Windows exporters' names), a warning naming the file
    // and the line.
    let bad = QUAD_OBJ
        .replace("usemtl grey", "usemtl gr\u{1}y")
        .into_bytes();
    let bad: Vec<u8> = bad.iter().map(|&b| if b == 1 { 0xE9 } else { b }).collect();
    let (_, report) = load_ok(&bad, Some(b"newmtl grey\nKd 0.5\n"));
    let w = &report.warnings[0];
    assert_eq!((w.kind, &w.lines[..]), (WarningKind::Latin1Text, &[6][..]));
    assert!(w.to_string().contains("mesh.obj"), "{w}");
    assert!(report.warnings[1].to_string().contains("'gr\u{e9}y'"));
    let (_, report) = load_ok(
        QUAD_OBJ.as_bytes(),
        Some(b"newmtl grey\nKd 0.5\nnewmtl caf\xE9\n"),
    );
    let w = &report.warnings[0];
    assert_eq!((w.kind, &w.lines[..]), (WarningKind::Latin1Text, &[3][..]));
    assert!(w.to_string().contains("lib.mtl"), "{w}");
}

#[test]
fn undefined_materials_warn_by_name() {
    let obj = QUAD_OBJ.replace("usemtl grey", "usemtl nothere");
    let (scene, report) = load_ok(obj.as_bytes(), Some(b"newmtl grey\nKd 0.5\n"));
    assert_eq!(report.count(WarningKind::UndefinedMaterial), 1);
    let w = report.warnings[0].to_string();
    assert!(w.contains("'nothere'") && w.contains("line 6"), "{w}");
    assert_eq!(diffuse(&scene), Vec3::splat(0.8), "the default material");
    // usemtl without any mtllib.
    let obj = QUAD_OBJ.replace("mtllib lib.mtl\n", "");
    let (_, report) = load_ok(obj.as_bytes(), None);
    assert_eq!(report.count(WarningKind::NoMaterialLibrary), 1);
    let w = report.warnings[0].to_string();
    assert!(w.contains("'grey'") && w.contains("without mtllib"), "{w}");
    // Negative: a defined material gives no warning and its colour.
    let (scene, report) = load_ok(QUAD_OBJ.as_bytes(), Some(b"newmtl grey\nKd 0.5\n"));
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(diffuse(&scene), Vec3::splat(0.5));
}

/// `Kd 0.5` and short `Ka`, `Ks`, `Ke` panic inside tobj when it reads the raw MTL (this test
/// failed with "the loader panicked" then); tobj now reads the loader's checked copy.
#[test]
fn mtl_single_value_colours_load() {
    for key in ["Kd", "Ka", "Ks", "Ke"] {
        for values in ["0.5", "0.5 0.25"] {
            let mtl = format!("newmtl grey\nKd 0.25 0.5 0.75\n{key} {values}\n");
            let r = std::panic::catch_unwind(|| load(QUAD_OBJ.as_bytes(), Some(mtl.as_bytes())));
            let r = r.unwrap_or_else(|_| panic!("{key} {values}: the loader panicked"));
            match (key, values) {
                ("Kd", "0.5") => assert_eq!(diffuse(&r.unwrap().0), Vec3::splat(0.5)),
                ("Kd", _) => {
                    let e = r.unwrap_err();
                    assert!(e.contains("lib.mtl:3") && e.contains("found 2"), "{e}");
                }
                _ => assert_eq!(diffuse(&r.unwrap().0), Vec3::new(0.25, 0.5, 0.75)),
            }
        }
    }
}

#[test]
fn tabs_after_keywords_parse() {
    let obj = "mtllib\tlib.mtl\nv\t0 0 -1\nv 1\t0\t-1\nv\t1 1 -1\nusemtl\tgrey\nf\t1\t2\t3\n";
    let (scene, report) = load_ok(obj.as_bytes(), Some(b"newmtl\tgrey\nKd\t0.1\t0.2\t0.3\n"));
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(diffuse(&scene), Vec3::new(0.1, 0.2, 0.3));
    assert!((area(&scene) - 0.5).abs() < 1e-6);
}

#[test]
fn mtl_errors_name_the_line() {
    let cases: [(&[u8], &str, &str); 5] = [
        (
            b"newmtl grey\n\nKd 0.1 x 0.3\n",
            "lib.mtl:3",
            "not a number",
        ),
        (b"newmtl grey\nKd 0.1 nan 0.3\n", "lib.mtl:2", "non-finite"),
        (
            b"newmtl grey\nKd 0.1 -0.01 0.3\n",
            "lib.mtl:2",
            "outside [0",
        ),
        (b"newmtl grey\nKd\n", "lib.mtl:2", "needs 1 numbers"),
        (b"newmtl\n", "lib.mtl:1", "needs a material name"),
    ];
    for (mtl, place, what) in cases {
        let e = load(QUAD_OBJ.as_bytes(), Some(mtl)).unwrap_err();
        assert!(e.contains(place) && e.contains(what), "{e}");
    }
}

/// Material statements real files get slightly wrong load with a warning naming the line:
/// a `Kd` before any `newmtl` is ignored, an RGBA `Kd` drops its alpha, float noise below 0
/// is 0, an empty `usemtl` gives the default material and an empty `mtllib` is ignored.
/// Negatives: a `Kd` clearly below 0 and one of five numbers stay errors naming the line.
#[test]
fn lenient_material_statements_load_with_warnings() {
    let mtl = b"Kd 0.1 0.2 0.3\nnewmtl grey\nKd 0.5 -0.000001 0.25 1.0\n";
    let (scene, report) = load_ok(QUAD_OBJ.as_bytes(), Some(mtl));
    assert_eq!(diffuse(&scene), Vec3::new(0.5, 0.0, 0.25));
    assert_eq!(report.count(WarningKind::LenientMaterial), 3);
    let lines: Vec<&[usize]> = report.warnings.iter().map(|w| &w.lines[..]).collect();
    assert_eq!(lines, [&[1][..], &[3], &[3]]);
    let obj = format!("mtllib\nmtllib lib.mtl\n{QUAD}usemtl\nf 1 2 3 4\n");
    let (scene, report) = load_ok(obj.as_bytes(), Some(b"newmtl grey\nKd 0.1 0.2 0.3\n"));
    assert_eq!(diffuse(&scene), Vec3::splat(0.8), "the default material");
    assert_eq!(report.count(WarningKind::LenientMaterial), 2);
    assert_eq!(report.count(WarningKind::UndefinedMaterial), 0);
    for (mtl, what) in [
        (&b"newmtl grey\nKd 0.5 -0.01 0.25\n"[..], "outside [0"),
        (b"newmtl grey\nKd 0.5 0.1 0.25 1 1\n", "found 5"),
    ] {
        let e = load(QUAD_OBJ.as_bytes(), Some(mtl)).unwrap_err();
        assert!(e.contains("lib.mtl:2") && e.contains(what), "{e}");
    }
}

/// Exporters' material files as they come: a missing texture (an absolute path from another
/// machine), a missing material library and a texture that does not decode are warnings that
/// name the file and line, and the material keeps its `Kd` (grey without a library); a Windows
/// path and a JPEG texture load; Blender's negative `Ns` loads. Negative: the same texture
/// named correctly is used.
#[test]
fn exporters_material_files_load_with_warnings() {
    let quad = |mtl_name: &str| {
        format!("mtllib {mtl_name}\n{QUAD}vt 0 0\nusemtl wood\nf 1/1 2/1 3/1 4/1\n")
    };
    let textured = |dir: &Path, map: &str| {
        let mtl = format!("newmtl wood\nNs -1.960784\nKd 0.5 0.25 0.125\nmap_Kd {map}\n");
        let path = scene_with(dir, quad("lib.mtl").as_bytes(), Some(mtl.as_bytes()));
        scene::load_scene_file_report(&path).unwrap_or_else(|e| panic!("{map}: {e}"))
    };
    let material = |s: &Scene| s.materials[s.meshes[1].parts[0].material as usize].clone();
    let lines = |r: &LoadReport| {
        let w: Vec<String> = r.warnings.iter().map(|w| w.to_string()).collect();
        w.join("\n")
    };
    // Missing: a warning naming the MTL, its line 4 and the file; Kd kept, no texture.
    let dir = tempfile::tempdir().unwrap();
    let (scene, report) = textured(dir.path(), "E:\\textures\\wood.jpg");
    let m = material(&scene);
    assert_eq!((m.texture, m.diffuse), (None, Vec3::new(0.5, 0.25, 0.125)));
    assert_eq!(report.count(WarningKind::MissingTexture), 1);
    let text = lines(&report);
    assert!(
        text.contains("lib.mtl") && text.contains("line 4") && text.contains("wood.jpg"),
        "{text}"
    );
    assert_eq!(report.count(WarningKind::SpecularPower), 1);
    // The same Windows path with the file beside the MTL, as a JPEG: loaded.
    let img = image::RgbImage::from_fn(4, 2, |x, _| image::Rgb([60 * x as u8, 128, 255]));
    img.save(dir.path().join("wood.jpg")).unwrap();
    let (scene, report) = textured(dir.path(), "E:\\textures\\wood.jpg");
    let t = &scene.textures[material(&scene).texture.expect("the JPEG loads") as usize];
    assert_eq!((t.width, t.height), (4, 2));
    assert_eq!(report.count(WarningKind::MissingTexture), 0);
    let (scene, _) = textured(dir.path(), "sub\\..\\wood.jpg");
    assert!(material(&scene).texture.is_some());
    // A texture that does not decode: a warning, Kd kept.
    std::fs::write(dir.path().join("bad.png"), b"not a png").unwrap();
    let (scene, report) = textured(dir.path(), "bad.png");
    assert_eq!(material(&scene).texture, None);
    assert!(lines(&report).contains("bad.png"), "{report:?}");
    // A missing library: a warning naming the OBJ and its line 1; the faces are grey.
    let dir = tempfile::tempdir().unwrap();
    let path = scene_with(dir.path(), quad("gone.mtl").as_bytes(), None);
    let (scene, report) = scene::load_scene_file_report(&path).unwrap();
    assert_eq!(report.count(WarningKind::MissingMaterialLibrary), 1);
    let text = lines(&report);
    assert!(
        text.contains("mesh.obj") && text.contains("line 1") && text.contains("gone.mtl"),
        "{text}"
    );
    assert_eq!(material(&scene).diffuse, Vec3::splat(0.8));
}

#[test]
fn map_kd_options_are_skipped() {
    let dir = tempfile::tempdir().unwrap();
    write_png(&dir.path().join("tex.png"));
    let obj = format!("mtllib lib.mtl\n{QUAD}vt 0 0\nusemtl tex\nf 1/1 2/1 3/1\n");
    let path = scene_with(
        dir.path(),
        obj.as_bytes(),
        Some(b"newmtl tex\nmap_Kd -s 2 2 1 -clamp on -bm 0.5 tex.png\n"),
    );
    let (scene, report) = scene::load_scene_file_report(&path).unwrap();
    let m = &scene.materials[scene.meshes[1].parts[0].material as usize];
    let t = &scene.textures[m.texture.unwrap() as usize];
    assert_eq!((t.width, t.height), (2, 1));
    assert_eq!(report.count(WarningKind::IgnoredMapOptions), 1);
}

#[test]
fn oversized_inputs_are_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_with(dir.path(), QUAD.as_bytes(), None);
    // A sparse file: no disk space is used, and the loader must not read it.
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(dir.path().join("mesh.obj"))
        .unwrap();
    f.set_len(scene::MAX_INPUT_BYTES + 1).unwrap();
    let e = scene::load_scene_file(&path).unwrap_err().to_string();
    assert!(e.contains("mesh.obj") && e.contains("more than"), "{e}");
    // Negative: at the limit's side of small, the same file loads.
    f.set_len(QUAD.len() as u64).unwrap();
    scene::load_scene_file(&path).unwrap();
}

// ---- Item 5: scene files ----

/// A scene file with one mirror and a quad, `extra` prepended, `tail` appended.
fn scene_toml(extra: &str, tail: &str) -> Result<(Scene, LoadReport), String> {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(
        dir.path(),
        extra,
        &[
            ("mirror.obj", MIRROR_OBJ.as_bytes(), true),
            ("quad.obj", format!("{QUAD}f 1 2 3 4\n").as_bytes(), false),
        ],
        None,
        tail,
    );
    scene::load_scene_file_report(&path).map_err(|e| e.to_string())
}

/// A camera whose `up` lies within rounding of its view direction is refused, naming the
/// field and the angle; a view 1e-3 radians from `up` loads (negative).
#[test]
fn an_up_along_the_view_is_refused_with_its_numbers() {
    let e = scene_toml("", "up = [0, 1e-6, -1]\n").unwrap_err();
    assert!(
        e.contains("camera[0].up") && e.contains("degrees from the view direction"),
        "{e}"
    );
    let e = scene_toml("", "up = [0, 0, 1]\n").unwrap_err();
    assert!(e.contains("camera[0].up"), "{e}");
    scene_toml("", "up = [0, 1e-3, -1]\n").unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn arrays_with_extra_or_missing_items_are_refused() {
    scene_toml("", "").expect("the base scene loads");
    let cases = [
        ("background = [0, 0, 0, 0]", "", 1),
        ("[shading]\nlight_direction = [0, 1, 0, 1]", "", 2),
        ("", "[cmo]\ncentres = [[0, 0.5, 0, 1]]", 15),
        ("", "[cmo]\ncentres = [[0, 0.5]]", 15),
        ("background = [0, 0]", "", 1),
    ];
    for (extra, tail, line) in cases {
        let e = scene_toml(extra, tail).unwrap_err();
        assert!(e.contains(&format!("line {line}")), "{extra}{tail}: {e}");
        assert!(e.contains("exactly 3"), "{extra}{tail}: {e}");
    }
    // Fields of meshes and cameras.
    for (from, to) in [
        (
            "reflector = true\n",
            "reflector = true\ntransform = { translate = [0, 0, 0, 0] }\n",
        ),
        (
            "reflector = true\n",
            "reflector = true\ntransform = { rotate_deg = [0, 0, 0, 9] }\n",
        ),
        (
            "reflector = true\n",
            "reflector = true\ntransform = { scale = [1, 1, 1, 1] }\n",
        ),
        (
            "reflector = true\n",
            "reflector = true\ntransform = { scale = [1, 1] }\n",
        ),
        ("eye = [0, 0.5, 3]", "eye = [0, 0.5, 3, 1]"),
        ("target = [0, 0.5, 0]", "target = [0, 0.5, 0, 0]"),
        ("resolution = [8, 8]", "resolution = [8, 8, 8]"),
        (
            "resolution = [8, 8]",
            "resolution = [8, 8]\nup = [0, 1, 0, 0]",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let path = write_scene(
            dir.path(),
            "",
            &[("m.obj", MIRROR_OBJ.as_bytes(), true)],
            None,
            "",
        );
        let text = std::fs::read_to_string(&path).unwrap();
        let edited = text.replacen(from, to, 1);
        assert_ne!(text, edited);
        std::fs::write(&path, &edited).unwrap();
        let e = scene::load_scene_file(&path).unwrap_err().to_string();
        let line = edited
            .lines()
            .position(|l| l.contains(to.lines().last().unwrap()))
            .unwrap()
            + 1;
        assert!(
            e.contains("scene.toml") && e.contains(&format!("line {line}")),
            "{to}: {e}"
        );
        assert!(
            e.contains("exactly") || e.contains("array of 3"),
            "{to}: {e}"
        );
    }
}

#[test]
fn ambient_outside_0_1_is_refused() {
    for a in ["0", "0.35", "1"] {
        scene_toml(&format!("[shading]\nambient = {a}"), "").unwrap();
    }
    for a in ["-0.1", "1.5", "100"] {
        let e = scene_toml(&format!("[shading]\nambient = {a}"), "").unwrap_err();
        assert!(
            e.contains("scene.toml:2") && e.contains("shading.ambient") && e.contains("[0, 1]"),
            "{e}"
        );
    }
}

#[test]
fn an_empty_reflector_is_an_error() {
    for empty in [
        "# nothing\n".to_string(),
        format!("{QUAD}f 1 2\nf 3 4\nl 1 2 3\n"),
        format!("{QUAD}f 1 1 2\n"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let path = write_scene(
            dir.path(),
            "",
            &[
                ("mirror.obj", empty.as_bytes(), true),
                ("quad.obj", format!("{QUAD}f 1 2 3\n").as_bytes(), false),
            ],
            None,
            "",
        );
        let e = scene::load_scene_file(&path).unwrap_err().to_string();
        assert!(
            e.contains("scene.toml:")
                && e.contains("mesh[0].obj")
                && e.contains("invisible mirror"),
            "{e}"
        );
        // Not a reflector: a warning only.
        let text = std::fs::read_to_string(&path).unwrap().replacen(
            "reflector = true",
            "reflector = false",
            1,
        );
        std::fs::write(&path, text).unwrap();
        let (_, report) = scene::load_scene_file_report(&path).unwrap();
        assert_eq!(report.count(WarningKind::EmptyMesh), 1);
    }
}

// ---- Item 5: diagnostics ----

/// A closed axis-aligned box from `lo` to `hi`.
fn box_obj(lo: Vec3, hi: Vec3) -> String {
    let mut s = String::new();
    for k in 0..8 {
        let p = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        s += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    s + "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n"
}

fn diagnose_scene(
    meshes: &[(&str, &[u8], bool)],
    tail: &str,
) -> (tempfile::TempDir, PathBuf, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(dir.path(), "", meshes, None, tail);
    let scene = scene::load_scene_file(&path).unwrap();
    let problems = cubetrace::placement::diagnose(&scene);
    (dir, path, problems)
}

#[test]
fn diagnose_is_quiet_on_the_builtins() {
    for (name, _) in cubetrace::scene::builtin::NAMES {
        let s = cubetrace::scene::builtin::by_name(name).unwrap();
        assert_eq!(
            cubetrace::placement::diagnose(&s),
            Vec::<String>::new(),
            "{name}"
        );
    }
}

#[test]
fn diagnose_a_cmo_centre_that_sees_no_reflector() {
    let walls = box_obj(Vec3::new(2.0, 0.0, -1.0), Vec3::new(4.0, 2.0, 1.0));
    let meshes: [(&str, &[u8], bool); 2] = [
        ("mirror.obj", MIRROR_OBJ.as_bytes(), true),
        ("box.obj", walls.as_bytes(), false),
    ];
    // The centre inside the closed box.
    let (_, _, p) = diagnose_scene(&meshes, "[cmo]\ncentres = [[0, 0.3, 0], [3, 1, 0]]\n");
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(
        p[0].contains("CMO 1")
            && p[0].contains("sees none of the reflectors")
            && p[0].contains("box"),
        "{}",
        p[0]
    );
    // Without the lines of sight (centres a search judged on sampled rays), the same scene
    // gives no problem.
    let (_dir, path, _) = diagnose_scene(&meshes, "[cmo]\ncentres = [[0, 0.3, 0], [3, 1, 0]]\n");
    let scene = scene::load_scene_file(&path).unwrap();
    assert!(cubetrace::placement::diagnose_with(&scene, false).is_empty());
    // Negative: the centre outside the box, beside it, sees the mirror.
    let (_, _, p) = diagnose_scene(&meshes, "[cmo]\ncentres = [[0, 0.3, 0], [1.5, 1, 0]]\n");
    assert!(p.is_empty(), "{p:?}");
}

#[test]
fn diagnose_every_mesh_a_reflector_and_no_reflector() {
    let other = box_obj(Vec3::new(2.0, 0.0, -1.0), Vec3::new(4.0, 2.0, 1.0));
    let (_, _, p) = diagnose_scene(
        &[
            ("mirror.obj", MIRROR_OBJ.as_bytes(), true),
            ("b.obj", other.as_bytes(), true),
            ("empty.obj", b"# no triangles\n", false),
        ],
        "",
    );
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(
        p[0].contains("every mesh is a reflector") && p[0].contains("background"),
        "{}",
        p[0]
    );
    let (_, _, p) = diagnose_scene(
        &[
            ("mirror.obj", MIRROR_OBJ.as_bytes(), false),
            ("b.obj", other.as_bytes(), false),
        ],
        "",
    );
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(p[0].contains("no reflector"), "{}", p[0]);
    // Negative: one of each.
    let (_, _, p) = diagnose_scene(
        &[
            ("mirror.obj", MIRROR_OBJ.as_bytes(), true),
            ("b.obj", other.as_bytes(), false),
        ],
        "",
    );
    assert!(p.is_empty(), "{p:?}");
}

#[test]
fn cli_render_prints_the_diagnosis() {
    let walls = box_obj(Vec3::new(2.0, 0.0, -1.0), Vec3::new(4.0, 2.0, 1.0));
    let (dir, _, p) = diagnose_scene(
        &[
            ("mirror.obj", MIRROR_OBJ.as_bytes(), true),
            ("box.obj", walls.as_bytes(), false),
        ],
        "[cmo]\ncentres = [[3, 1, 0]]\n",
    );
    assert_eq!(p.len(), 1);
    let out = Command::new(env!("CARGO_BIN_EXE_cubetrace"))
        .args([
            "render",
            "./scene.toml",
            "--method",
            "reference",
            "-o",
            "out.png",
        ])
        .current_dir(dir.path())
        .env("XDG_RUNTIME_DIR", "/tmp")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("sees none of the reflectors"), "{stderr}");
}

#[test]
fn cli_render_shows_load_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let obj = format!("{QUAD}f 1 2 3 4\nf 1 2\n");
    scene_with(dir.path(), obj.as_bytes(), None);
    let out = Command::new(env!("CARGO_BIN_EXE_cubetrace"))
        .args([
            "render",
            "./scene.toml",
            "--method",
            "reference",
            "-o",
            "out.png",
        ])
        .current_dir(dir.path())
        .env("XDG_RUNTIME_DIR", "/tmp")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("mesh.obj: face (f) with fewer than 3 vertices skipped (line 6)"),
        "{stderr}"
    );
}

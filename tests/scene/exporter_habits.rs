//! What real exporters and users write that the loader once read wrong without a word, or
//! refused: MTL keywords in another letter case, a `map_Kd` with no file or an option it does
//! not know, files in UTF-16, vertex colours as 8-bit numbers, faces under `s off` without
//! normals, and mesh paths in a scene file as a Windows user or a shell user writes them. Each
//! has its negative.

use super::exporter_quirks::{QUAD_OBJ, load, load_ok, material, png, write_placing};
use crate::common::binary::{run, run_env};
use cubetrace::scene::{self, Scene, WarningKind};
use glam::Vec3;

/// MTL keywords in capitals or lower case (`KD`, `MAP_KD`, `map_kd`, `NEWMTL`) are read as
/// Blender's and three.js's readers read them; they were skipped, leaving the material grey and
/// untextured without a warning. Negative: a keyword that is no MTL keyword in any case is
/// still skipped.
#[test]
fn mtl_keywords_in_any_letter_case_are_read() {
    let red = png([255, 0, 0]);
    for mtl in [
        "NEWMTL tex\nKD 0.1 0.2 0.3\nMAP_KD tex.png\n",
        "newmtl tex\nkd 0.1 0.2 0.3\nmap_kd tex.png\nns 10\n",
    ] {
        let (scene, report) = load_ok(&[
            ("mesh.obj", QUAD_OBJ.as_bytes()),
            ("lib.mtl", mtl.as_bytes()),
            ("tex.png", &red),
        ]);
        assert!(report.warnings.is_empty(), "{mtl}: {:?}", report.warnings);
        let (diffuse, texture) = material(&scene);
        assert_eq!(diffuse, Vec3::new(0.1, 0.2, 0.3), "{mtl}");
        assert!(texture.is_some(), "{mtl}");
    }
    let (scene, _) = load_ok(&[
        ("mesh.obj", QUAD_OBJ.as_bytes()),
        ("lib.mtl", b"newmtl tex\nKx 0.1 0.2 0.3\nmap_Kx tex.png\n"),
        ("tex.png", &red),
    ]);
    assert_eq!(material(&scene), (Vec3::splat(0.8), None));
}

/// A `map_Kd` without a file name (exporters write one for a material whose texture slot is
/// empty) is ignored with a warning naming the line; it refused the whole scene. An option the
/// loader does not know, with a word of its own (`-colorspace sRGB`), no longer hides the file
/// after it. Negative: with that file missing, the warning names what was looked for.
#[test]
fn map_kd_without_a_file_or_with_an_unknown_option_loads() {
    let red = png([255, 0, 0]);
    let files = |mtl: &'static str, tex: &'static str| {
        [
            ("mesh.obj", QUAD_OBJ.as_bytes()),
            ("lib.mtl", mtl.as_bytes()),
            (tex, red.as_slice()),
        ]
    };
    let (scene, report) = load_ok(&files("newmtl tex\nKd 0.5 0.5 0.5\nmap_Kd\n", "tex.png"));
    assert_eq!(material(&scene), (Vec3::splat(0.5), None));
    assert_eq!(report.count(WarningKind::LenientMaterial), 1);
    let w = report.warnings[0].to_string();
    assert!(w.contains("lib.mtl") && w.contains("line 3"), "{w}");

    let unknown = "newmtl tex\nmap_Kd -colorspace sRGB -bm 0.5 tex.png\n";
    let (scene, report) = load_ok(&files(unknown, "tex.png"));
    assert!(material(&scene).1.is_some());
    assert_eq!(report.count(WarningKind::IgnoredMapOptions), 1);
    assert_eq!(report.count(WarningKind::MissingTexture), 0);
    let (scene, report) = load_ok(&files(unknown, "other.png"));
    assert_eq!(material(&scene).1, None);
    assert_eq!(report.count(WarningKind::MissingTexture), 1);
    let w = report
        .warnings
        .iter()
        .find(|w| w.kind == WarningKind::MissingTexture)
        .unwrap()
        .to_string();
    assert!(w.contains("tex.png") && w.contains("line 2"), "{w}");
}

/// `text` as UTF-16, little- or big-endian, with its byte order mark unless `bom` is false.
fn utf16(text: &str, little: bool, bom: bool) -> Vec<u8> {
    let mut out = Vec::new();
    for u in bom.then_some(0xFEFF).into_iter().chain(text.encode_utf16()) {
        out.extend(if little {
            u.to_le_bytes()
        } else {
            u.to_be_bytes()
        });
    }
    out
}

/// OBJ and MTL files saved as UTF-16 with a byte order mark (Windows Notepad's "Unicode",
/// PowerShell 5's `>` and `Out-File`) load as the text they hold; they were refused as binary
/// files. Negative: UTF-16 without the mark is still refused as binary, naming the file.
#[test]
fn utf16_files_with_a_byte_order_mark_load() {
    let obj = "mtllib lib.mtl\r\nv 0 0 -1\r\nv 1 0 -1\r\nv 1 1 -1\r\nusemtl Caf\u{e9}\r\n\
               f 1 2 3\r\n";
    let mtl = "newmtl Caf\u{e9}\r\nKd 0.1 0.2 0.3\r\n";
    for little in [true, false] {
        let (scene, report) = load_ok(&[
            ("mesh.obj", &utf16(obj, little, true)),
            ("lib.mtl", &utf16(mtl, little, true)),
        ]);
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        assert_eq!(material(&scene).0, Vec3::new(0.1, 0.2, 0.3));
        let m = &scene.materials[scene.meshes[1].parts[0].material as usize];
        assert_eq!(m.name, "Caf\u{e9}");
    }
    let e = load(&[("mesh.obj", &utf16(obj, true, false))]).unwrap_err();
    assert!(e.contains("mesh.obj:1") && e.contains("binary file"), "{e}");
}

/// The colours of `mesh.obj`'s first part.
fn colours(scene: &Scene) -> Vec<Vec3> {
    scene.meshes[1].parts[0].colours.clone()
}

/// Vertex colours written as whole numbers from 0 to 255 (as MeshLab reads them, and some
/// point-cloud tools write them) are 8-bit values: divided by 255, with a warning naming the
/// first line. They were read as floats and rendered white. Negatives: colours from 0 to 1,
/// and floats above 1 (Blender's bright colours), are kept as written without a warning; a
/// component that decodes beyond 65504 is refused naming its line (it made the colour
/// infinite), also where another vertex's component is a whole number to 255.
#[test]
fn eight_bit_vertex_colours_are_divided_by_255() {
    let tri = |c: [&str; 3]| {
        format!(
            "v 0 0 -1 {0}\nv 1 0 -1 {1}\nv 0 1 -1 {2}\nf 1 2 3\n",
            c[0], c[1], c[2]
        )
    };
    let bytes = tri(["255 128 0", "0 0 0", "51.000000 102 255"]);
    let (scene, report) = load_ok(&[("mesh.obj", bytes.as_bytes())]);
    let want = [
        Vec3::new(1.0, 128.0 / 255.0, 0.0),
        Vec3::ZERO,
        Vec3::new(0.2, 0.4, 1.0),
    ];
    let got = colours(&scene);
    assert_eq!(got.len(), 3);
    for (g, w) in got.iter().zip(want) {
        assert!((*g - w).abs().max_element() < 1e-6, "{got:?}");
    }
    assert_eq!(report.count(WarningKind::VertexColours), 1);
    assert_eq!(report.warnings[0].lines, [1]);

    for floats in [
        ["1 0.5 0", "0 0 0", "0.2 0.4 1"],
        ["1.5 0.5 0", "0 0 0", "0.2 0.4 2"],
    ] {
        let bytes = tri(floats);
        let (scene, report) = load_ok(&[("mesh.obj", bytes.as_bytes())]);
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        let x: f32 = floats[0].split(' ').next().unwrap().parse().unwrap();
        assert_eq!(colours(&scene)[0], Vec3::new(x, 0.5, 0.0));
    }

    for (c, shown) in [
        (["1 0 0", "0 1 1e30", "0 0 1"], "1e30"),
        (["0.5 0 0", "0 200 0", "0 0 1"], "200"),
    ] {
        let e = load(&[("mesh.obj", tri(c).as_bytes())]).unwrap_err();
        assert!(
            e.contains("mesh.obj:2") && e.contains(&format!("component {shown} ")),
            "{e}"
        );
    }
}

/// Each triangle's unit face normal, and the normals at its corners, of the test mesh.
fn corner_normals(scene: &Scene) -> Vec<(Vec3, [Vec3; 3])> {
    let mut out = Vec::new();
    for p in &scene.meshes[1].parts {
        for t in &p.triangles {
            let [a, b, c] = t.map(|i| p.positions[i as usize]);
            let face = (b - a).cross(c - a).normalize();
            out.push((face, t.map(|i| p.normals[i as usize])));
        }
    }
    out
}

/// Faces under `s off` (or `s 0`) without normals are flat, as the exporter meant: Blender with
/// normals off, and SketchUp, write them for hard-edged models. They were smoothed with their
/// neighbours (a cube shaded like a ball). Faces of different smoothing groups meet at a hard
/// edge. Negatives: faces of one group are smoothed across their shared edge, and normals the
/// file gives are kept under `s off`.
#[test]
fn faces_under_s_off_without_normals_are_flat() {
    // Two quads folded at a right angle along the edge x = 1 (vertices 2 and 3).
    let fold = |s1: &str, s2: &str| {
        format!(
            "v 0 0 -1\nv 1 0 -1\nv 1 1 -1\nv 0 1 -1\nv 1 0 -2\nv 1 1 -2\n\
             s {s1}\nf 1 2 3 4\ns {s2}\nf 2 5 6 3\n"
        )
    };
    let flat = |scene: &Scene| {
        corner_normals(scene)
            .iter()
            .all(|(face, corners)| corners.iter().all(|n| (*n - *face).length() < 1e-6))
    };
    for (s1, s2) in [("off", "off"), ("0", "0"), ("1", "2"), ("off", "1")] {
        let (scene, report) = load_ok(&[("mesh.obj", fold(s1, s2).as_bytes())]);
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        assert_eq!(corner_normals(&scene).len(), 4);
        assert!(
            flat(&scene),
            "s {s1} / s {s2}: {:?}",
            corner_normals(&scene)
        );
    }
    // One group: the shared edge's normal is the blend of both faces.
    let (scene, _) = load_ok(&[("mesh.obj", fold("1", "1").as_bytes())]);
    assert!(!flat(&scene));
    let p = &scene.meshes[1].parts[0];
    let edge = p
        .positions
        .iter()
        .position(|&q| q == Vec3::new(1.0, 0.0, -1.0));
    let n = p.normals[edge.unwrap()];
    assert!(n.x > 0.1 && n.z > 0.1 && n.y.abs() < 1e-6, "{n}");
    // Normals in the file are kept under `s off`.
    let given = "v 0 0 -1\nv 1 0 -1\nv 0 1 -1\nvn 0.6 0 0.8\ns off\nf 1//1 2//1 3//1\n";
    let (scene, _) = load_ok(&[("mesh.obj", given.as_bytes())]);
    let n = &scene.meshes[1].parts[0].normals;
    assert!(n.iter().all(|&n| n == Vec3::new(0.6, 0.0, 0.8)), "{n:?}");
}

/// A mesh path in a scene file as a Windows user writes it (`Models\Mesh.OBJ` for
/// `models/mesh.obj`) or from the home folder (`~/...`) loads; the OBJ's miscased library is
/// found when the scene is named from its own folder (the folder of `scene.toml` is the empty
/// path there, which the case-blind search could not list). A missing mesh is refused naming
/// the scene file's line and field. Negative: a name no file has in any case warns, naming it.
#[test]
fn mesh_paths_as_users_write_them_load() {
    let dir = tempfile::tempdir().unwrap();
    let obj = QUAD_OBJ.replace("mtllib lib.mtl", "mtllib LIB.MTL");
    let files: [(&str, &[u8]); 2] = [
        ("models/mesh.obj", obj.as_bytes()),
        ("models/lib.mtl", b"newmtl tex\nKd 0.1 0.2 0.3\n"),
    ];
    let path = write_placing(dir.path(), &files, "Models\\Mesh.OBJ");
    let (scene, report) = scene::load_scene_file_report(&path).unwrap();
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(material(&scene).0, Vec3::new(0.1, 0.2, 0.3));

    write_placing(dir.path(), &files, "~/models/mesh.obj");
    let home = dir.path().to_str().unwrap();
    let args = [
        "render",
        "scene.toml",
        "--method",
        "reference",
        "-o",
        "x.png",
    ];
    let o = run_env(&args, dir.path(), &[("HOME", home)]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(!o.stderr.contains("WARN"), "{}", o.stderr);

    // The scene named from its folder: the OBJ's folder is the empty path.
    let beside = |mtllib: &str| QUAD_OBJ.replace("mtllib lib.mtl", mtllib);
    let obj = beside("mtllib LIB.MTL");
    let root: [(&str, &[u8]); 2] = [("mesh.obj", obj.as_bytes()), ("lib.mtl", files[1].1)];
    write_placing(dir.path(), &root, "mesh.obj");
    let o = run(&args, dir.path());
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(!o.stderr.contains("WARN"), "{}", o.stderr);
    std::fs::write(dir.path().join("mesh.obj"), beside("mtllib LIBS.MTL")).unwrap();
    let o = run(&args, dir.path());
    assert!(o.stderr.contains("'LIBS.MTL' not found"), "{}", o.stderr);

    let path = write_placing(dir.path(), &files, "Models\\Gone.obj");
    let e = scene::load_scene_file_report(&path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("scene.toml:6") && e.contains("mesh[1].obj") && e.contains("Gone.obj"),
        "{e}"
    );
}

/// A normal with a NaN component (some CAD exporters write one for a face without area) loads
/// with a warning naming its line, and the corners that name it get the normal computed from
/// the faces; a `vt`'s third component, which nothing reads, may be anything. Negatives: a NaN
/// position is still refused naming its line, and so is a normal that is not a number.
#[test]
fn nan_normals_are_computed_and_unread_texture_components_ignored() {
    let obj = "v 0 0 -1\nv 1 0 -1\nv 0 1 -1\nvt 0 0 nan\nvt 1 0 0\nvt 0 1 0\n\
               vn nan nan nan\nvn 0 0 1\nf 1/1/1 2/2/2 3/3/2\n";
    let (scene, report) = load_ok(&[("mesh.obj", obj.as_bytes())]);
    assert_eq!(report.count(WarningKind::NonFiniteNormal), 1);
    let w = (report.warnings.iter())
        .find(|w| w.kind == WarningKind::NonFiniteNormal)
        .unwrap();
    assert_eq!(w.lines, vec![7]);
    let normals = &scene.meshes[1].parts[0].normals;
    assert!(!normals.is_empty());
    for n in normals {
        assert!((*n - Vec3::Z).length() < 1e-6, "{n}");
    }
    let nan_position = "v 0 0 -1\nv 1 nan -1\nv 0 1 -1\nf 1 2 3\n";
    let e = load(&[("mesh.obj", nan_position.as_bytes())]).unwrap_err();
    assert!(e.contains("mesh.obj:2") && e.contains("non-finite"), "{e}");
    let word = "v 0 0 -1\nv 1 0 -1\nv 0 1 -1\nvn x 0 1\nf 1//1 2//1 3//1\n";
    let e = load(&[("mesh.obj", word.as_bytes())]).unwrap_err();
    assert!(
        e.contains("mesh.obj:4") && e.contains("not a number"),
        "{e}"
    );
}

/// A `Kd` above 1 (8-bit values, `Kd 255 128 0`, render white) loads as written, with a warning
/// naming its line and the value. Negative: a `Kd` within 0 to 1 has none.
#[test]
fn a_kd_above_one_is_named() {
    let line_of_kd = |mtl: &str| {
        let (scene, report) = load_ok(&[
            ("mesh.obj", QUAD_OBJ.as_bytes()),
            ("lib.mtl", mtl.as_bytes()),
        ]);
        let w = (report.warnings.iter())
            .find(|w| w.kind == WarningKind::LenientMaterial && w.detail.contains("above 1"));
        (
            material(&scene).0,
            w.map(|w| (w.lines.clone(), w.detail.clone())),
        )
    };
    let (kd, w) = line_of_kd("newmtl tex\nKd 255 128 0\n");
    assert_eq!(kd, Vec3::new(255.0, 128.0, 0.0));
    let (lines, detail) = w.expect("a warning");
    assert_eq!(lines, vec![2]);
    assert!(
        detail.contains("255") && detail.contains("'tex'"),
        "{detail}"
    );
    let (kd, w) = line_of_kd("newmtl tex\nKd 1 0.5 0\n");
    assert_eq!((kd, w), (Vec3::new(1.0, 0.5, 0.0), None));
}

/// A texture named URL-encoded (`my%20tex.png`, as tools that write file URLs leave it) is found
/// under its decoded name. Negatives: with no such file it is a missing texture, and a name
/// whose `%` starts no escape is looked for as written.
#[test]
fn url_encoded_texture_names_are_decoded() {
    let red = png([255, 0, 0]);
    let mtl = "newmtl tex\nmap_Kd my%20tex.png\n";
    let quad = ("mesh.obj", QUAD_OBJ.as_bytes());
    let (scene, report) = load_ok(&[quad, ("lib.mtl", mtl.as_bytes()), ("my tex.png", &red)]);
    assert!(material(&scene).1.is_some(), "{:?}", report.warnings);
    assert_eq!(report.count(WarningKind::MissingTexture), 0);
    let (scene, report) = load_ok(&[quad, ("lib.mtl", mtl.as_bytes())]);
    assert!(material(&scene).1.is_none());
    assert_eq!(report.count(WarningKind::MissingTexture), 1);
    let literal = "newmtl tex\nmap_Kd 100%.png\n";
    let (scene, _) = load_ok(&[quad, ("lib.mtl", literal.as_bytes()), ("100%.png", &red)]);
    assert!(material(&scene).1.is_some());
}

/// A whole scene exported as one OBJ (Blender's default): a mirror ball, a floor and a box as
/// objects `o`, the ball's material `Chrome`, the others' `Wall`.
const WHOLE_SCENE_OBJ: &str = "mtllib lib.mtl\n\
    o Ball\nv -1 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl Chrome\nf 1 2 3\nf 1 4 2\nf 2 4 3\n\
    o Floor\nv -3 -1 -3\nv 3 -1 -3\nv 3 -1 3\nv -3 -1 3\nusemtl Wall\nf 5 6 7 8\n\
    o Box\nv 2 0 -2\nv 3 0 -2\nv 3 1 -2\nusemtl Wall\nf 9 10 11\n";
const WHOLE_SCENE_MTL: &str = "newmtl Chrome\nKd 0.9 0.9 0.9\nnewmtl Wall\nKd 0.5 0.4 0.3\n";

/// [`WHOLE_SCENE_OBJ`] in a scene file whose mesh has `reflector` (a TOML value, or `None`
/// for none) and `extra` after the camera; the loaded scene or the error's message.
fn whole_scene(reflector: Option<&str>, extra: &str) -> Result<Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("all.obj"), WHOLE_SCENE_OBJ).unwrap();
    std::fs::write(dir.path().join("lib.mtl"), WHOLE_SCENE_MTL).unwrap();
    let line = reflector.map_or_else(String::new, |r| format!("reflector = {r}\n"));
    let toml = format!(
        "[[mesh]]\nname = \"all\"\nobj = \"all.obj\"\n{line}\n[[camera]]\neye = [0, 0.5, 4]\n\
         target = [0, 0, 0]\nresolution = [8, 8]\n{extra}"
    );
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    scene::load_scene_file(&path).map_err(|e| e.to_string())
}

/// The scene's meshes as (name, reflector, part names, triangles).
fn meshes(scene: &Scene) -> Vec<(String, bool, Vec<String>, usize)> {
    (scene.meshes.iter())
        .map(|m| {
            let parts = m.parts.iter().map(|p| p.name.clone()).collect();
            let triangles = m.parts.iter().map(|p| p.triangles.len()).sum();
            (m.name.clone(), m.reflector, parts, triangles)
        })
        .collect()
}

/// `reflector = ["Ball"]` makes the OBJ's object `Ball` the mirror and keeps its other objects
/// as a mesh `all-rest` in the same place; a material's name (`["Chrome"]`) picks the same
/// parts. Negatives: `true` makes the whole OBJ a mirror, no `reflector` none of it; a name that
/// is in the file as neither is refused with the names there are, as is an empty list.
#[test]
fn a_mirror_named_among_the_objects_of_one_obj() {
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let want = vec![
        ("all".to_string(), true, names(&["Ball"]), 3),
        ("all-rest".to_string(), false, names(&["Floor", "Box"]), 3),
    ];
    for name in ["Ball", "Chrome"] {
        let scene = whole_scene(Some(&format!("[\"{name}\"]")), "").unwrap();
        assert_eq!(meshes(&scene), want, "{name}");
        assert_eq!(scene.meshes[0].transform, scene.meshes[1].transform);
    }
    let both = whole_scene(Some("[\"Ball\", \"Floor\"]"), "").unwrap();
    assert_eq!(meshes(&both)[0].2, ["Ball", "Floor"]);
    assert_eq!(meshes(&both)[1].2, ["Box"]);
    // `true`: the whole file a mirror; no `reflector`: none of it.
    let whole = whole_scene(Some("true"), "").unwrap();
    assert_eq!(meshes(&whole).len(), 1);
    assert!(meshes(&whole)[0].1);
    let none = whole_scene(None, "").unwrap();
    assert_eq!(meshes(&none).len(), 1);
    assert!(!meshes(&none)[0].1);
    // Refusals name the field and the names the file has.
    let e = whole_scene(Some("[\"Bal\"]"), "").unwrap_err();
    for needle in [
        "mesh[0].reflector",
        "'Bal'",
        "'Ball'",
        "'Floor'",
        "'Chrome'",
        "'Wall'",
    ] {
        assert!(e.contains(needle), "{needle} in: {e}");
    }
    let e = whole_scene(Some("[]"), "").unwrap_err();
    assert!(
        e.contains("mesh[0].reflector") && e.contains("'Ball'"),
        "{e}"
    );
}

/// A split mesh moves as one: an animation track of `all` moves `all-rest` too. Negative: a
/// second track of `all-rest` is refused as animating it twice.
#[test]
fn a_split_mesh_is_animated_as_one() {
    let track = "[animation]\nfps = 24\n[[animation.mesh]]\nmesh = \"all\"\n\
                 [[animation.mesh.key]]\ntime = 0.0\ntranslate = [0, 1, 0]\n";
    let scene = whole_scene(Some("[\"Ball\"]"), track).unwrap();
    let mut moved: Vec<usize> = scene.animation.meshes.iter().map(|t| t.mesh).collect();
    moved.sort_unstable();
    assert_eq!(moved, [0, 1]);
    let twice = format!(
        "{track}[[animation.mesh]]\nmesh = \"all-rest\"\n[[animation.mesh.key]]\ntime = 0.0\n\
         translate = [0, 2, 0]\n"
    );
    let e = whole_scene(Some("[\"Ball\"]"), &twice).unwrap_err();
    assert!(e.contains("'all-rest' is animated twice"), "{e}");
}

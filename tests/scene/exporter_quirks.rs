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
pub(super) const QUAD_OBJ: &str = "mtllib lib.mtl\nv 0 0 -1\nv 1 0 -1\nv 1 1 -1\nv 0 1 -1\n\
                        vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl tex\nf 1/1 2/2 3/3 4/4\n";

/// Writes `files` (name, bytes) into `dir`, a triangle mirror and a scene file placing the
/// mirror and `obj` (a path as the scene file writes it, in TOML literal quotes); returns the
/// scene file's path.
pub(super) fn write_placing(dir: &Path, files: &[(&str, &[u8])], obj: &str) -> PathBuf {
    for (name, bytes) in files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
    std::fs::write(dir.join("mirror.obj"), MIRROR_OBJ).unwrap();
    let toml = format!(
        "[[mesh]]\nobj = \"mirror.obj\"\nreflector = true\n\n\
         [[mesh]]\nobj = '{obj}'\n\n{CAMERA}"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    path
}

/// [`write_placing`] of `mesh.obj`.
fn write(dir: &Path, files: &[(&str, &[u8])]) -> PathBuf {
    write_placing(dir, files, "mesh.obj")
}

pub(super) fn load(files: &[(&str, &[u8])]) -> Result<(Scene, LoadReport), String> {
    let dir = tempfile::tempdir().unwrap();
    scene::load_scene_file_report(&write(dir.path(), files)).map_err(|e| e.to_string())
}

pub(super) fn load_ok(files: &[(&str, &[u8])]) -> (Scene, LoadReport) {
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
pub(super) fn material(scene: &Scene) -> (Vec3, Option<u32>) {
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

/// A 4 x 4 DDS texture of one DXT1 (BC1) block, pure red, byte for byte as Pillow 13.0.0
/// writes it (`Image.new("RGB", (4, 4), "red").save(f, pixel_format="DXT1")`).
fn dds_dxt1_red() -> Vec<u8> {
    let words = |d: &mut Vec<u8>, w: &[u32]| w.iter().for_each(|v| d.extend(v.to_le_bytes()));
    let mut d = b"DDS ".to_vec();
    words(&mut d, &[124, 0x81007, 4, 4, 28, 0, 0]);
    words(&mut d, &[0; 11]);
    words(&mut d, &[32, 4]);
    d.extend(b"DXT1");
    words(&mut d, &[24, 0, 0, 0, 0, 0x1000, 0, 0, 0, 0]);
    d.extend([0x00, 0xF8, 0x00, 0xF8, 0, 0, 0, 0]);
    d
}

/// The first texel of the test mesh's texture, if it has one.
fn first_texel(scene: &Scene) -> Option<[u8; 4]> {
    let t = &scene.textures[material(scene).1? as usize];
    Some(t.rgba8[..4].try_into().unwrap())
}

/// A PNG of one pixel of `rgb`.
pub(super) fn png(rgb: [u8; 3]) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbImage::from_pixel(1, 1, image::Rgb(rgb))
        .write_to(&mut out, image::ImageFormat::Png)
        .unwrap();
    out.into_inner()
}

#[test]
fn quoted_and_miscased_file_names_are_found() {
    let red = png([255, 0, 0]);
    for (mtllib, map_kd, texture) in [
        ("\"my lib.mtl\"", "\"my tex.png\"", "my tex.png"),
        ("My Lib.MTL", "Textures\\Tex.PNG", "textures/tex.png"),
        ("C:\\Export\\MY LIB.mtl", "E:\\maps\\TEX.png", "tex.png"),
    ] {
        let obj = QUAD_OBJ.replace("mtllib lib.mtl", &format!("mtllib {mtllib}"));
        let mtl = format!("newmtl tex\nKd 1 1 1\nmap_Kd {map_kd}\n");
        let (scene, report) = load_ok(&[
            ("mesh.obj", obj.as_bytes()),
            ("my lib.mtl", mtl.as_bytes()),
            (texture, &red),
        ]);
        assert!(
            report.warnings.is_empty(),
            "{mtllib}: {:?}",
            report.warnings
        );
        assert_eq!(first_texel(&scene), Some([255, 0, 0, 255]), "{map_kd}");
    }
    // Negative: a name that no file has in any case is missing, with the warning naming it.
    let obj = QUAD_OBJ.replace("mtllib lib.mtl", "mtllib \"my lib.mtl\"");
    let mtl = b"newmtl tex\nKd 1 1 1\nmap_Kd Texture.png\n";
    let (scene, report) = load_ok(&[
        ("mesh.obj", obj.as_bytes()),
        ("my lib.mtl", mtl),
        ("tex.png", &red),
    ]);
    assert_eq!(report.count(WarningKind::MissingTexture), 1);
    assert!(report.warnings[0].to_string().contains("'Texture.png'"));
    assert_eq!(first_texel(&scene), None);
}

#[test]
fn textures_are_decoded_by_their_content() {
    let mtl = |file: &str| format!("newmtl tex\nKd 1 1 1\nmap_Kd {file}\n");
    // A JPEG named .png; a DXT1 DDS (game exports).
    let mut jpeg = std::io::Cursor::new(Vec::new());
    image::RgbImage::from_pixel(8, 8, image::Rgb([0, 0, 255]))
        .write_to(&mut jpeg, image::ImageFormat::Jpeg)
        .unwrap();
    let dds = dds_dxt1_red();
    for (file, bytes, texel) in [
        ("tex.png", jpeg.get_ref().as_slice(), [0, 0, 254, 255]),
        ("tex.dds", &dds, [255, 0, 0, 255]),
    ] {
        let (scene, report) = load_ok(&[
            ("mesh.obj", QUAD_OBJ.as_bytes()),
            ("lib.mtl", mtl(file).as_bytes()),
            (file, bytes),
        ]);
        assert!(report.warnings.is_empty(), "{file}: {:?}", report.warnings);
        let got = first_texel(&scene).unwrap();
        let near = got.iter().zip(texel).all(|(&a, b)| a.abs_diff(b) <= 2);
        assert!(near, "{file}: {got:?}");
    }
    // Negative: bytes of no image format under a .png name warn, naming the texture.
    let (scene, report) = load_ok(&[
        ("mesh.obj", QUAD_OBJ.as_bytes()),
        ("lib.mtl", mtl("tex.png").as_bytes()),
        ("tex.png", b"not an image"),
    ]);
    assert_eq!(report.count(WarningKind::MissingTexture), 1);
    assert!(report.warnings[0].to_string().contains("tex.png"));
    assert_eq!(first_texel(&scene), None);
}

/// The colours of `mesh.obj`'s first part.
fn colours(scene: &Scene) -> Vec<Vec3> {
    scene.meshes[1].parts[0].colours.clone()
}

#[test]
fn vertex_colours_and_untextured_parts_are_named_in_warnings() {
    // MeshLab, Open3D, trimesh and Blender write vertex colours: kept, one per vertex, in the
    // order of first use (the loader renumbers the vertices the triangles use).
    let all = "v 0 0 -1 1 0 0\nv 1 0 -1 0 1 0\nv 0 1 -1 0 0 1\nv 1 1 -1 0.5 0.5 0.5\n\
               f 1 2 3\nf 2 4 3\n";
    let (scene, report) = load_ok(&[("mesh.obj", all.as_bytes())]);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let want = [Vec3::X, Vec3::Y, Vec3::Z, Vec3::splat(0.5)];
    assert_eq!(colours(&scene), want);
    // They are sRGB-encoded, as Blender writes them (its 0.5 linear as 0.7353): the world holds
    // them decoded, and white for the mirror's vertices (before the mesh's).
    let world = scene.world();
    assert_eq!(
        world.colours[..4],
        [Vec3::ONE, Vec3::ONE, Vec3::ONE, Vec3::X]
    );
    assert!(
        (world.colours[6] - Vec3::splat(0.214_041))
            .abs()
            .max_element()
            < 1e-5
    );
    // Negative: where some `v` have none, none is kept, and the warning names the others.
    let obj = "v 0 0 -1 1 0 0\nv 1 0 -1 0 1 0\nv 0 1 -1 0 0 1\nv 1 1 -1\nf 1 2 3\nf 2 4 3\n";
    let (scene, report) = load_ok(&[("mesh.obj", obj.as_bytes())]);
    assert_eq!(triangles(&scene), 2);
    assert!(colours(&scene).is_empty());
    assert_eq!(report.count(WarningKind::VertexColours), 1);
    assert_eq!(report.warnings[0].lines, [4]);
    // A textured material on faces without `vt` (Blender's export with UVs off).
    let red = png([255, 0, 0]);
    let untextured = "mtllib lib.mtl\nv 0 0 -1\nv 1 0 -1\nv 0 1 -1\nusemtl tex\nf 1 2 3\n";
    let mtl = b"newmtl tex\nmap_Kd tex.png\n";
    let files = |obj: &'static str| {
        [
            ("mesh.obj", obj.as_bytes()),
            ("lib.mtl", mtl),
            ("tex.png", &red),
        ]
    };
    let (_, report) = load_ok(&files(untextured));
    assert_eq!(report.count(WarningKind::TextureWithoutTexcoords), 1);
    let w = report.warnings[0].to_string();
    assert!(w.contains("material 'tex'") && w.contains("line 5"), "{w}");
    // Negatives: a `v x y z w` and faces with texture coordinates warn about nothing.
    let (_, report) = load_ok(&[("mesh.obj", b"v 0 0 -1 1\nv 1 0 -1 1\nv 0 1 -1 1\nf 1 2 3\n")]);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let (_, report) = load_ok(&files(QUAD_OBJ));
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
}

#[test]
fn continued_lines_join_and_later_lines_keep_their_numbers() {
    // The OBJ format's `\` continues a statement on the next line.
    let obj = b"v 0 0 -1\nv 1 0 \\\n -1\nv 1 1 -1\r\nv 0 1 -1\nf 1 2 \\\n\t3 \\  \n 4\nf 1 2 x\n";
    let e = load(&[("mesh.obj", obj)]).unwrap_err();
    assert!(e.contains("mesh.obj:9") && e.contains("'x'"), "{e}");
    let (scene, report) = load_ok(&[("mesh.obj", &obj[..obj.len() - 8])]);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(triangles(&scene), 2);
    let p = &scene.meshes[1].parts[0];
    assert_eq!(
        p.source_line(0).unwrap(),
        format!("{}:6", p.source.as_ref().unwrap().file.display())
    );
    // Negative: a `\` in a comment continues nothing (an exporter's Windows path).
    let obj = b"# C:\\models\\\nv 0 0 -1\nv 1 0 -1\nv 0 1 -1 # \\\nf 1 2 3\n";
    let (scene, _) = load_ok(&[("mesh.obj", obj)]);
    assert_eq!(triangles(&scene), 1);
}

/// A material with a texture and no `Kd` shows the texture as it is (Blender's and three.js's
/// importers read it so; a `Kd` beside it multiplies it, as the MTL format says). Negatives:
/// with the texture missing, the material is the default grey; with `Kd 0.5`, half.
#[test]
fn a_texture_without_kd_is_shown_as_it_is() {
    let red = png([255, 0, 0]);
    let files = |mtl: &'static [u8], tex: &'static str| {
        load_ok(&[
            ("mesh.obj", QUAD_OBJ.as_bytes()),
            ("lib.mtl", mtl),
            (tex, &red),
        ])
        .0
    };
    let plain = files(b"newmtl tex\nmap_Kd tex.png\n", "tex.png");
    assert_eq!(material(&plain).0, Vec3::ONE);
    assert!(material(&plain).1.is_some());
    let missing = files(b"newmtl tex\nmap_Kd tex.png\n", "other.png");
    assert_eq!(material(&missing), (Vec3::splat(0.8), None));
    let half = files(b"newmtl tex\nKd 0.5 0.5 0.5\nmap_Kd tex.png\n", "tex.png");
    assert_eq!(material(&half).0, Vec3::splat(0.5));
}

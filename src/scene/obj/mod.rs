//! OBJ/MTL loading and mesh hygiene.
//!
//! `tobj` parses the OBJ and MTL files, but never the bytes on disk. Our line-by-line pass reads
//! them first: it holds the line numbers, so its errors and warnings name the line, and it
//! writes a normalised copy that is the only text `tobj` sees. That copy holds nothing `tobj`
//! could panic or be wrong on: only `v x y z`, `vt u v`, `vn x y z`, `f` with absolute 1-based
//! indices already checked against the counts, `o`/`g` names, and `mtllib`/`usemtl`/`newmtl`
//! lines; an MTL holds only `newmtl`, `Kd r g b`, `map_Kd file` and `Ns n` (so `tobj` never
//! meets a short `Kd`, `Ka`, `Ks` or `Ke`, which it panicked on). Numbers are passed on as the
//! tokens of the file, already parsed as finite `f32` by the same `str::parse` that `tobj` uses.
//! `tobj` (with `single_index`, without `triangulate`) then builds the parts and materials,
//! and our code triangulates each polygon from `tobj`'s `face_arities`, naming the polygon's
//! source line on failure.
//!
//! What the loader accepts:
//! - UTF-8 text, with or without a byte order mark (or UTF-16 with one, as Windows Notepad
//!   and PowerShell 5 write it), LF, CRLF or CR (classic Mac OS) line ends,
//!   spaces or tabs; a line ending in `\` is continued on the next (errors name its first).
//!   Comments (`#` to the end of the line) may hold any bytes; a line whose text outside its
//!   comment is not UTF-8 is read as Latin-1 (Windows exporters' names), with a warning naming
//!   it. A NUL byte (a binary file: FBX, STL, `.blend`) is an error naming the line and column,
//!   and so is a NaN or infinity as Microsoft's C runtime printed them (`1.#QNAN0`,
//!   `-1.#IND00`), which would otherwise read as a number and a comment.
//! - `v`, `vt`, `vn`, `f`, `o`, `g`, `s`, `usemtl`, `mtllib`; other statements (curves, ...)
//!   are ignored. A `w` after `v x y z` is ignored. Vertex colours (`v x y z r g b`, which
//!   MeshLab, Open3D, trimesh and Blender write, sRGB-encoded) multiply the material's colour
//!   ([`crate::scene::MeshPart::colours`]) where every `v` of the file has one; where only
//!   some have one, none is kept, with a warning naming the lines without. A part whose
//!   colours are all white is left without them. Colours that are all whole numbers from 0
//!   to 255, some above 1, are 8-bit values, divided by 255 with a warning naming the first
//!   line above 1; otherwise a component that decodes from sRGB above 65504 is an error
//!   naming its line. A `vt` with one value gets v = 0. `l` and `p` elements and faces with
//!   fewer than 3 vertices are skipped with a warning that counts them and names their lines.
//! - Smoothing groups (`s`) decide the normals the loader computes (below): faces after
//!   `s off` or `s 0` are flat, faces of a group `s N` are smoothed with that group's faces
//!   only, and faces before any `s` are one group. Normals the file gives are kept.
//! - Polygons: convex ones are fanned from their first vertex (the triangles `tobj`'s own
//!   `triangulate` makes); others are ear-clipped (`earcut`) in the plane of their Newell
//!   normal; a polygon whose triangles do not cover exactly its area (self-intersecting) is
//!   fanned from its first corner, as `tobj` and Blender do, with a warning naming the line.
//!   Corners on the line of their neighbours are left out first (CAD and Blender n-gons hold
//!   them; ear clipping them made triangles of aspect up to 1e16).
//! - A part without texture coordinates whose material has a texture is coloured by the texel
//!   at uv (0, 0), with a warning naming it and its `usemtl` line.
//! - Texture coordinates and normals per face corner: a face without `vt` in a part whose other
//!   faces have them gets uv (0, 0) at its corners (with a warning), a corner without `vn` gets
//!   the computed normal. (`tobj` drops a part's texture coordinates or normals when some
//!   corners lack them, so such corners refer to a `vt 0 0` or `vn 0 0 0` the normalised copy
//!   puts first.)
//! - An undefined material, or `usemtl` in a file without `mtllib`, is a warning naming it;
//!   the faces get the default material (grey 0.8). (The normalised copy declares such names in
//!   one more, empty-bodied library so that `tobj` splits parts at every change of name, as the
//!   file does.)
//! - MTL: `newmtl`, `Kd` (1 value = grey, or 3; it multiplies `map_Kd`; without it a textured
//!   material shows its texture as it is, a plain one is grey 0.8), `map_Kd` (options such as
//!   `-s` are skipped with a warning; where the words after those it knows name no file, the
//!   shorter tails of the line are tried; without a file name it is ignored with a warning;
//!   any format the `image` crate reads, told by the file's first bytes, else its extension:
//!   PNG, JPEG, BMP, TGA, GIF, TIFF, WebP, PNM, DDS) and `Ns` (the Phong
//!   specular power; a reflector uses it only where its scene file says
//!   `specular_power = "mtl"`: a value below 0, as Blender 2.79 writes, is taken as 0, and one
//!   that is not a number is ignored, each with a warning); other statements are ignored.
//!   These keywords are read in any letter case (`KD`, `map_kd`), as Blender and three.js
//!   read them.
//!   Slips real files make are warnings naming the line: a `Kd` of four numbers (RGBA) drops
//!   the alpha, a `Kd` component within 1e-3 below 0 is 0, a `Kd`, `Ns` or `map_Kd` before any
//!   `newmtl` is ignored; in the OBJ, an empty `usemtl` gives the default material and an
//!   empty `mtllib` is ignored. Errors name the MTL file and line.
//! - Files named by `mtllib` and `map_Kd` are looked for as written (in double quotes or
//!   not), then with Windows separators read as `/`, then by their file name alone beside the
//!   naming file (an exporter's absolute `E:\...` path), then these two with letter case
//!   ignored ([`find_beside`]: a Windows export's `Wood.JPG` for `wood.jpg`). One that is
//!   still missing, or a texture that cannot be decoded, is a warning naming the file and
//!   line: the material keeps its `Kd` (a missing library's materials are grey).
//!
//! Every error names the file and the line: numbers that do not parse or are not finite (NaN,
//! inf; but a normal's is a warning, the normal computed from the faces), a vertex coordinate
//! beyond 2^60 ([`MAX_COORDINATE`](crate::scene::MAX_COORDINATE): scale a mesh in its
//! transform instead), a `Kd` outside `[0, 65504]`
//! ([`MAX_COLOUR`](crate::scene::MAX_COLOUR)), face indices out of range. Errors are found in this
//! order: the OBJ pass, the MTL passes, then polygons (so of a bad index and a self-intersecting
//! polygon, the index is named even when it comes later in the file).
//!
//! Hygiene on load, per part:
//! - missing normals are computed: bit-identical positions are welded first (the teapot repeats
//!   263 positions along its patch seams), then area-weighted face normals are summed per welded
//!   vertex; zero-length normals in the file are replaced the same way. Where a part's faces
//!   are in several smoothing groups, or some under `s off`, each group gets its own copies of
//!   the vertices it shares and is welded on its own, and each flat triangle gets its own three
//!   vertices with its face normal;
//! - degenerate triangles (a repeated index, or zero area) are dropped and counted in a warning.

mod lexer;
mod mesh;
mod mtl;
mod obj_pass;
mod polygon;

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::Vec3;

use self::lexer::read_input;
use self::mesh::{finish_part, triangulate_models};
use self::mtl::{load_materials, read_libraries};
use self::obj_pass::{ObjPass, Statement, normalised_obj, validate_obj};
use super::report::{LoadReport, WarningKind};
use super::{Material, MeshPart, SceneError, Texture};

/// Largest OBJ or MTL file accepted, in bytes. Everything the loader holds grows at most in
/// proportion to the file (a polygon corner needs at least two bytes), so this bounds memory.
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// The parts, materials and textures of one OBJ file. Part material indices point into
/// `materials`, texture indices into `textures`.
pub(crate) struct LoadedObj {
    pub parts: Vec<MeshPart>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
}

/// The file a material library or texture statement names, as exporters write it, relative to
/// `dir` (the folder of the file that names it), tried in this order: the name as written
/// (without a pair of double quotes around it); with Windows separators (`\`) read as `/`; the
/// file name alone in `dir` (an absolute path from the exporter's machine, such as
/// `E:\textures\wood.jpg`); then each of the last two with its letter case ignored (a Windows
/// export on a case-sensitive file system: `Wood.JPG` for `wood.jpg`); last, where the name
/// holds a `%`, all of these with it URL-decoded (`my%20tex.png` for `my tex.png`, as tools that
/// write file URLs leave it). `None` where none exists.
pub(crate) fn find_beside(dir: &Path, name: &str) -> Option<PathBuf> {
    find_as_written(dir, name).or_else(|| {
        let decoded = percent_encoding::percent_decode_str(name)
            .decode_utf8()
            .ok()?;
        (decoded != name).then(|| find_as_written(dir, &decoded))?
    })
}

/// [`find_beside`] without the URL decoding.
fn find_as_written(dir: &Path, name: &str) -> Option<PathBuf> {
    let name = name
        .strip_prefix('"')
        .and_then(|n| n.strip_suffix('"'))
        .unwrap_or(name);
    let written = dir.join(name);
    if written.is_file() {
        return Some(written);
    }
    let slashed = name.replace('\\', "/");
    let as_path = dir.join(&slashed);
    if as_path.is_file() {
        return Some(as_path);
    }
    let file = slashed.rsplit('/').next().filter(|f| !f.is_empty())?;
    let alone = dir.join(file);
    if alone.is_file() {
        return Some(alone);
    }
    any_case(dir, &slashed).or_else(|| any_case(dir, file))
}

/// The file at `relative` (`/`-separated) below `dir`, each name that is missing as written
/// matched with its letter case ignored (the first in sorted order where several differ only
/// in case); `None` where there is none.
fn any_case(dir: &Path, relative: &str) -> Option<PathBuf> {
    let mut at = dir.to_path_buf();
    for name in relative.split('/').filter(|n| !n.is_empty() && *n != ".") {
        let exact = at.join(name);
        if name == ".." || exact.exists() {
            at = exact;
            continue;
        }
        let wanted = name.to_lowercase();
        // An empty folder (a file named without one) is the working directory.
        let listed = if at.as_os_str().is_empty() {
            Path::new(".")
        } else {
            &at
        };
        let mut matches: Vec<PathBuf> = std::fs::read_dir(listed)
            .ok()?
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().to_lowercase() == wanted)
            .map(|e| e.path())
            .collect();
        matches.sort();
        at = matches.into_iter().next()?;
    }
    at.is_file().then_some(at)
}

/// Parses the normalised OBJ with `tobj`. `mtl_texts[k]` is the normalised text of library `k`
/// (`mtllib k`); a last library declares every `usemtl` name the others lack (see the module
/// docs). Returns the models and the materials of all libraries, in order.
fn parse_with_tobj(
    obj: &ObjPass,
    mtl_texts: &[String],
    path: &Path,
) -> Result<(Vec<tobj::Model>, Vec<tobj::Material>), SceneError> {
    let mut defined: HashSet<&str> = HashSet::new();
    let mut undefined = String::new();
    for text in mtl_texts {
        defined.extend(text.lines().filter_map(|l| l.strip_prefix("newmtl ")));
    }
    for s in &obj.statements {
        if let Statement::UseMtl(name) = s
            && defined.insert(name)
        {
            writeln!(undefined, "newmtl {name}").expect("writing to a String");
        }
    }
    let libraries: Vec<&str> = mtl_texts
        .iter()
        .map(String::as_str)
        .chain([undefined.as_str()])
        .collect();
    let text = normalised_obj(obj, libraries.len());
    let (models, materials) = tobj::load_obj_buf(&mut text.as_bytes(), &load_options(), |p| {
        let library = p
            .to_str()
            .and_then(|k| k.parse::<usize>().ok())
            .and_then(|k| libraries.get(k));
        match library {
            Some(text) => tobj::load_mtl_buf(&mut text.as_bytes()),
            None => Err(tobj::LoadError::OpenFileFailed),
        }
    })
    .map_err(|e| tobj_failed(path, e))?;
    let materials = materials.map_err(|e| tobj_failed(path, e))?;
    Ok((models, materials))
}

/// An error from `tobj` on the normalised text: a gap in the validation pass, not the file.
pub(super) fn tobj_failed(path: &Path, e: tobj::LoadError) -> SceneError {
    SceneError::Mtl {
        path: path.to_path_buf(),
        reason: format!("tobj refused the checked file ({e}); please report this as a bug"),
    }
}

// Other tobj features add fields to `LoadOptions`; keep their defaults whatever is enabled.
#[allow(clippy::needless_update)]
pub(super) fn load_options() -> tobj::LoadOptions {
    tobj::LoadOptions {
        single_index: true,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    }
}

/// Parses OBJ text without materials (used for the embedded teapot). Every part gets
/// material 0; hygiene is applied. Returns the parts and the number of degenerate triangles
/// dropped.
pub(crate) fn parse_obj_str(text: &str, path: &Path) -> Result<(Vec<MeshPart>, usize), SceneError> {
    let mut report = LoadReport::default();
    let obj = validate_obj(text.as_bytes(), path, &mut report)?;
    let (models, _) = parse_with_tobj(&obj, &[], path)?;
    let mut dropped = 0;
    let mut parts = Vec::new();
    for raw in triangulate_models(&obj, models, path, &mut report)? {
        let (part, d) = finish_part(&obj.parts[raw.part], raw, 0, path, &mut report);
        dropped += d;
        if !part.triangles.is_empty() {
            parts.push(part);
        }
    }
    Ok((parts, dropped))
}

/// Loads an OBJ file with its MTL materials and `map_Kd` textures; warnings go to `report`.
pub(crate) fn load_obj_file(path: &Path, report: &mut LoadReport) -> Result<LoadedObj, SceneError> {
    let bytes = read_input(path, report)?;
    let obj = validate_obj(&bytes, path, report)?;
    let (mtl_texts, origin) = read_libraries(&obj, report)?;
    let (models, materials) = parse_with_tobj(&obj, &mtl_texts, path)?;
    let raw_parts = triangulate_models(&obj, models, path, report)?;

    let mut out = LoadedObj {
        parts: Vec::new(),
        materials: Vec::new(),
        textures: Vec::new(),
    };
    // tobj's materials past those of the libraries declare undefined names.
    let defined = origin.len();
    if materials.len() < defined {
        return Err(tobj_failed(path, tobj::LoadError::GenericFailure));
    }
    load_materials(&materials, &origin, &mut out, report);

    let mut dropped = 0;
    let mut default_material = None;
    for raw in raw_parts {
        let info = &obj.parts[raw.part];
        let found = raw.material_id.filter(|&id| id < defined);
        // An empty `usemtl` was warned about where it stands.
        let named = info
            .material
            .as_ref()
            .filter(|(n, _)| n != obj_pass::NO_MATERIAL);
        if let (None, Some((name, line))) = (found, named) {
            warn_undefined_material(&obj, name, *line, path, report);
        }
        let material = match found {
            Some(id) => id as u32,
            None => *default_material.get_or_insert_with(|| {
                out.materials.push(Material {
                    name: "default".into(),
                    diffuse: Vec3::splat(0.8),
                    texture: None,
                    specular_power: None,
                });
                (out.materials.len() - 1) as u32
            }),
        };
        let (p, d) = finish_part(info, raw, material, path, report);
        dropped += d;
        let m = &out.materials[material as usize];
        if m.texture.is_some() && !info.any_vt && !p.triangles.is_empty() {
            report.warn(
                WarningKind::TextureWithoutTexcoords,
                path,
                info.material.as_ref().map(|(_, line)| *line),
                format!(
                    "part '{}' has no texture coordinates (vt) for the texture of material \
                     '{}': its texel at uv (0, 0) colours the whole part",
                    p.name, m.name
                ),
            );
        }
        if !p.triangles.is_empty() {
            out.parts.push(p);
        }
    }
    report.warn_count(
        WarningKind::DegenerateTriangles,
        path,
        dropped,
        "degenerate triangles (a repeated vertex or zero area) dropped",
    );
    Ok(out)
}

/// The warning for a part whose `usemtl` (at `line`) names no defined material.
fn warn_undefined_material(
    obj: &ObjPass,
    name: &str,
    line: usize,
    path: &Path,
    report: &mut LoadReport,
) {
    if obj.libraries.is_empty() {
        report.warn(
            WarningKind::NoMaterialLibrary,
            path,
            Some(line),
            format!("usemtl '{name}' in a file without mtllib: the default material is used"),
        );
    } else {
        report.warn(
            WarningKind::UndefinedMaterial,
            path,
            Some(line),
            format!(
                "material '{name}' is not defined in {}: the default material is used",
                obj.libraries
                    .iter()
                    .map(|(p, _)| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_names_the_line() {
        let p = Path::new("x.obj");
        let scan = |t: &str| parse_obj_str(t, p).map(|_| ());
        let e = scan("v 0 0 0\nv 1 0 nan\n").unwrap_err().to_string();
        assert!(e.contains("x.obj:2"), "{e}");
        let e = scan("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.obj:4"), "{e}");
        assert!(scan("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -1\n").is_ok());
    }
}

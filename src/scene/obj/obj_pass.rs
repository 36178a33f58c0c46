//! The validation pass over an OBJ file ([`validate_obj`]) and the normalised text it writes for
//! `tobj` ([`normalised_obj`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::find_beside;
use super::lexer::{
    Corner, corner, keyword, numbers, obj_err, text_lines, within_coordinate_bound,
};
use crate::scene::report::{LoadReport, WarningKind};
use crate::scene::{MAX_COLOUR, SceneError};
use crate::shading::srgb_decode;

/// One OBJ statement the validation pass keeps, in file order, as the tokens `tobj` will read.
pub(super) enum Statement<'a> {
    /// `v x y z`, with the vertex colour `r g b` where the line has one.
    Position([&'a str; 3], Option<[&'a str; 3]>),
    Texcoord([&'a str; 2]),
    Normal([&'a str; 3]),
    /// `o` or `g` (the keyword) with its name (empty: unnamed).
    Name(&'a str, &'a str),
    UseMtl(&'a str),
    /// A polygon of at least 3 corners; `part` indexes [`ObjPass::parts`].
    Face {
        corners: Vec<Corner>,
        part: usize,
    },
}

/// The faces between two `o`/`g`/`usemtl` changes, as the validation pass sees them. The
/// parts that hold faces are, in order, the `tobj` models that hold faces.
pub(super) struct PartInfo {
    pub(super) name: String,
    /// `usemtl` name and line.
    pub(super) material: Option<(String, usize)>,
    pub(super) faces: usize,
    /// Lines of faces without texture coordinates.
    pub(super) faces_without_vt: Vec<usize>,
    pub(super) any_vt: bool,
    pub(super) any_vn: bool,
    /// Some corner lacks a `vt` (a `vn`).
    corner_without_vt: bool,
    corner_without_vn: bool,
}

impl PartInfo {
    fn new(name: String, material: Option<(String, usize)>) -> Self {
        Self {
            name,
            material,
            faces: 0,
            faces_without_vt: Vec::new(),
            any_vt: false,
            any_vn: false,
            corner_without_vt: false,
            corner_without_vn: false,
        }
    }
}

/// An OBJ file checked line by line, ready to be written out for `tobj`.
pub(super) struct ObjPass<'a> {
    pub(super) statements: Vec<Statement<'a>>,
    pub(super) parts: Vec<PartInfo>,
    /// The source line of each face, in file order (the order `tobj` keeps).
    pub(super) face_lines: Vec<usize>,
    /// The smoothing group of each face, in file order ([`SMOOTH`] before any `s`, 0 after
    /// `s off` or `s 0`).
    pub(super) face_groups: Vec<u32>,
    /// The smoothing group that faces get now.
    group: u32,
    /// Material libraries and the line naming each (first mention).
    pub(super) libraries: Vec<(PathBuf, usize)>,
    /// Every `v` has a colour (`v x y z r g b`, as MeshLab, Open3D, trimesh and Blender write
    /// them): `tobj` reads them into the parts' vertex colours. Where only some have one, none
    /// is kept (with a warning naming the lines without).
    pub(super) colours: bool,
    /// The colours are 8-bit (every component a whole number from 0 to 255, some above 1, as
    /// some point-cloud and photogrammetry tools write them): divided by 255 for `tobj`.
    pub(super) colours_8bit: bool,
}

/// What the vertex colours of a file hold, gathered line by line ([`ColourScan::check`]).
#[derive(Default)]
struct ColourScan {
    /// The first line with a component above 1.
    above_one: Option<usize>,
    /// The first line with a component that is not a whole number from 0 to 255.
    not_8bit: Option<usize>,
    /// The first component that decodes (as sRGB) above [`MAX_COLOUR`], with its line: of
    /// those that are not whole numbers up to 255, and of those that are (an error unless the
    /// file's colours are 8-bit).
    too_bright: [Option<(usize, String)>; 2],
}

impl ColourScan {
    /// Notes what the colour of a `v` at `line` holds.
    fn check(&mut self, rgb: [&str; 3], line: usize) {
        for a in rgb {
            let x: f32 = a.parse().unwrap_or(f32::NAN);
            let byte = (0.0..=255.0).contains(&x) && x.fract() == 0.0;
            if x > 1.0 {
                self.above_one.get_or_insert(line);
            }
            if !byte {
                self.not_8bit.get_or_insert(line);
            }
            if srgb_decode(x) > MAX_COLOUR {
                self.too_bright[usize::from(byte)].get_or_insert((line, a.to_string()));
            }
        }
    }

    /// Whether the colours (every `v` has one) are 8-bit (see [`ObjPass::colours_8bit`]),
    /// with a warning naming the first line above 1; an error naming the line of a component
    /// that decodes above [`MAX_COLOUR`] as an sRGB-encoded float.
    fn finish(&self, path: &Path, report: &mut LoadReport) -> Result<bool, SceneError> {
        let Some(first) = self.above_one else {
            return Ok(false);
        };
        let eight_bit = self.not_8bit.is_none();
        let kinds = if eight_bit { 1 } else { 2 };
        let bright = self.too_bright[..kinds]
            .iter()
            .flatten()
            .min_by_key(|b| b.0);
        if let Some((line, a)) = bright {
            return Err(obj_err(
                path,
                *line,
                format!(
                    "vertex colour component {a} is brighter than {MAX_COLOUR} once decoded \
                     from sRGB (colours are from 0 to 1, or all whole numbers from 0 to 255)"
                ),
            ));
        }
        if eight_bit {
            report.warn(
                WarningKind::VertexColours,
                path,
                Some(first),
                "vertex colours (v x y z r g b) are whole numbers from 0 to 255: read as 8-bit \
                 values (divided by 255)",
            );
        }
        Ok(eight_bit)
    }
}

const UNNAMED: &str = "unnamed_object";

/// The smoothing group of faces before any `s` statement: smooth, as one group.
pub(super) const SMOOTH: u32 = u32::MAX;

/// The group an `s` statement starts: 0 (flat) for `off` or `0`, else its number (`s on` and
/// words that are not numbers smooth, as [`SMOOTH`]).
fn smoothing_group(args: &str) -> u32 {
    if args.eq_ignore_ascii_case("off") {
        return 0;
    }
    args.parse::<u32>().unwrap_or(SMOOTH)
}

/// The material name an empty `usemtl` stands for: one no MTL defines (a control character),
/// so that its faces get the default material as an undefined name's do, without that warning.
pub(super) const NO_MATERIAL: &str = "\u{1}default";

/// The validation pass over an OBJ file (see the module docs).
pub(super) fn validate_obj<'a>(
    bytes: &'a [u8],
    path: &Path,
    report: &mut LoadReport,
) -> Result<ObjPass<'a>, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut obj = ObjPass {
        statements: Vec::new(),
        parts: vec![PartInfo::new(UNNAMED.into(), None)],
        face_lines: Vec::new(),
        face_groups: Vec::new(),
        group: SMOOTH,
        libraries: Vec::new(),
        colours: false,
        colours_8bit: false,
    };
    let mut counts = [0usize; 3];
    let mut scan = ColourScan::default();
    // Lines of the `v` without a colour.
    let mut plain: Vec<usize> = Vec::new();
    for (line, text) in text_lines(bytes, path)? {
        let Some((key, args)) = keyword(text) else {
            continue;
        };
        match key {
            "v" => {
                let v = numbers(args, 3, "vertex position (v)", path, line)?;
                within_coordinate_bound(&v[..3], path, line)?;
                let colour = (v.len() >= 6).then(|| [v[3], v[4], v[5]]);
                match colour {
                    Some(rgb) => scan.check(rgb, line),
                    None => plain.push(line),
                }
                obj.statements
                    .push(Statement::Position([v[0], v[1], v[2]], colour));
                counts[0] += 1;
            }
            "vt" => {
                // u and v only: the optional w is never read, whatever it holds.
                let v = numbers(
                    first_words(args, 2),
                    1,
                    "texture coordinate (vt)",
                    path,
                    line,
                )?;
                obj.statements.push(Statement::Texcoord([
                    v[0],
                    v.get(1).copied().unwrap_or("0"),
                ]));
                counts[1] += 1;
            }
            "vn" => {
                let v = normal(args, path, line, report)?;
                obj.statements.push(Statement::Normal(v));
                counts[2] += 1;
            }
            "f" => obj.face(args, counts, path, line, report)?,
            "l" => report.warn(
                WarningKind::LineElement,
                path,
                Some(line),
                "line element (l) skipped",
            ),
            "p" => report.warn(
                WarningKind::PointElement,
                path,
                Some(line),
                "point element (p) skipped",
            ),
            "o" | "g" => obj.name_part(key, args),
            "s" => obj.group = smoothing_group(args),
            "usemtl" => obj.use_material(args, line, path, report),
            "mtllib" => obj.add_libraries(args, dir, path, line, report)?,
            _ => {}
        }
    }
    obj.colours = counts[0] > 0 && plain.is_empty();
    obj.colours_8bit = obj.colours && scan.finish(path, report)?;
    if !obj.colours && plain.len() < counts[0] {
        for line in plain {
            report.warn(
                WarningKind::VertexColours,
                path,
                Some(line),
                "vertex without a colour where others have one (v x y z r g b): every vertex \
                 colour of the file ignored",
            );
        }
    }
    Ok(obj)
}

impl<'a> ObjPass<'a> {
    /// The part that statements go to now: the last one (there is always one).
    fn current(&mut self) -> &mut PartInfo {
        let last = self.parts.len() - 1;
        &mut self.parts[last]
    }

    /// An `f` statement; fewer than 3 corners are skipped with a warning. `counts`: the `v`,
    /// `vt` and `vn` statements so far, which relative indices count back from.
    fn face(
        &mut self,
        args: &str,
        counts: [usize; 3],
        path: &Path,
        line: usize,
        report: &mut LoadReport,
    ) -> Result<(), SceneError> {
        let words: Vec<&str> = args.split_whitespace().collect();
        if words.len() < 3 {
            report.warn(
                WarningKind::ShortFace,
                path,
                Some(line),
                "face (f) with fewer than 3 vertices skipped",
            );
            return Ok(());
        }
        let corners = words
            .iter()
            .map(|a| corner(a, counts, path, line))
            .collect::<Result<Vec<_>, _>>()?;
        let part = self.parts.len() - 1;
        let info = self.current();
        info.faces += 1;
        if corners.iter().all(|c| c.1.is_none()) {
            info.faces_without_vt.push(line);
        } else {
            info.any_vt = true;
        }
        info.corner_without_vt |= corners.iter().any(|c| c.1.is_none());
        info.corner_without_vn |= corners.iter().any(|c| c.2.is_none());
        info.any_vn |= corners.iter().any(|c| c.2.is_some());
        self.face_lines.push(line);
        self.face_groups.push(self.group);
        self.statements.push(Statement::Face { corners, part });
        Ok(())
    }

    /// An `o` or `g` statement: names the current part while it has no faces, else starts a
    /// new part with the same material.
    fn name_part(&mut self, key: &'a str, args: &'a str) {
        let name = if args.is_empty() { UNNAMED } else { args };
        let current = self.current();
        if current.faces == 0 {
            current.name = name.into();
        } else {
            let material = current.material.clone();
            self.parts.push(PartInfo::new(name.into(), material));
        }
        self.statements.push(Statement::Name(key, args));
    }

    /// A `usemtl` statement: a material change starts a new part (unless the current one has
    /// no faces yet).
    fn use_material(&mut self, args: &'a str, line: usize, path: &Path, report: &mut LoadReport) {
        let args = if args.is_empty() {
            report.warn(
                WarningKind::LenientMaterial,
                path,
                Some(line),
                "usemtl without a name: the faces after it get the default material",
            );
            NO_MATERIAL
        } else {
            args
        };
        let current = self.current();
        if current.material.as_ref().map(|m| m.0.as_str()) != Some(args) {
            let material = Some((args.to_string(), line));
            if current.faces == 0 {
                current.material = material;
            } else {
                let name = current.name.clone();
                self.parts.push(PartInfo::new(name, material));
            }
        }
        self.statements.push(Statement::UseMtl(args));
    }

    /// An `mtllib` statement: each library it names (relative to `dir`, [`find_beside`]) is
    /// kept once, with the line that first names it; a missing one is a warning.
    fn add_libraries(
        &mut self,
        args: &str,
        dir: &Path,
        path: &Path,
        line: usize,
        report: &mut LoadReport,
    ) -> Result<(), SceneError> {
        if args.is_empty() {
            report.warn(
                WarningKind::LenientMaterial,
                path,
                Some(line),
                "mtllib without a file name ignored",
            );
            return Ok(());
        }
        // One name with spaces, or several names.
        let files: Vec<&str> = if find_beside(dir, args).is_some() {
            vec![args]
        } else {
            args.split_whitespace().collect()
        };
        for f in files {
            let Some(mtl) = find_beside(dir, f) else {
                report.warn(
                    WarningKind::MissingMaterialLibrary,
                    path,
                    Some(line),
                    format!(
                        "material library '{}' not found: its materials are grey",
                        dir.join(f).display()
                    ),
                );
                continue;
            };
            if !self.libraries.iter().any(|(p, _)| *p == mtl) {
                self.libraries.push((mtl, line));
            }
        }
        Ok(())
    }
}

/// Writes the normalised OBJ text `tobj` reads: `mtllib 0` to `mtllib {libraries - 1}` first
/// (so every `usemtl` finds its library loaded), then the `vt 0 0` and `vn 0 0 0` that corners
/// without them refer to in parts that have them, then every kept statement, faces with
/// absolute 1-based indices.
pub(super) fn normalised_obj(obj: &ObjPass, libraries: usize) -> String {
    let mut out = String::new();
    for k in 0..libraries {
        writeln!(out, "mtllib {k}").expect("writing to a String");
    }
    let need_vt = obj.parts.iter().any(|p| p.any_vt && p.corner_without_vt);
    let need_vn = obj.parts.iter().any(|p| p.any_vn && p.corner_without_vn);
    if need_vt {
        out.push_str("vt 0 0\n");
    }
    if need_vn {
        out.push_str("vn 0 0 0\n");
    }
    // 1-based index of a texture coordinate or normal: after the placeholder when there is one.
    let (vt_base, vn_base) = (1 + need_vt as u32, 1 + need_vn as u32);
    for s in &obj.statements {
        let w = match s {
            Statement::Position([x, y, z], Some(rgb)) if obj.colours_8bit => {
                let [r, g, b] = rgb.map(|a| a.parse::<f32>().unwrap_or(0.0) / 255.0);
                writeln!(out, "v {x} {y} {z} {r} {g} {b}")
            }
            Statement::Position([x, y, z], Some([r, g, b])) if obj.colours => {
                writeln!(out, "v {x} {y} {z} {r} {g} {b}")
            }
            Statement::Position([x, y, z], _) => writeln!(out, "v {x} {y} {z}"),
            Statement::Texcoord([u, v]) => writeln!(out, "vt {u} {v}"),
            Statement::Normal([x, y, z]) => writeln!(out, "vn {x} {y} {z}"),
            Statement::Name(key, name) => writeln!(out, "{key} {name}"),
            Statement::UseMtl(name) => writeln!(out, "usemtl {name}"),
            Statement::Face { corners, part } => {
                let info = &obj.parts[*part];
                out.push('f');
                for &(v, vt, vn) in corners {
                    write!(out, " {}", v + 1).expect("writing to a String");
                    let vt = vt.map(|t| t + vt_base).or(info.any_vt.then_some(1));
                    let vn = vn.map(|n| n + vn_base).or(info.any_vn.then_some(1));
                    match (vt, vn) {
                        (None, None) => {}
                        (Some(t), None) => write!(out, "/{t}").expect("writing to a String"),
                        (None, Some(n)) => write!(out, "//{n}").expect("writing to a String"),
                        (Some(t), Some(n)) => write!(out, "/{t}/{n}").expect("writing to a String"),
                    }
                }
                out.push('\n');
                Ok(())
            }
        };
        w.expect("writing to a String");
    }
    out
}

/// The first `n` words of `args` (all of it where it has fewer), as a slice of it.
fn first_words(args: &str, n: usize) -> &str {
    let end = (args.split_whitespace().take(n).last()).map_or(0, |w| {
        w.as_ptr() as usize - args.as_ptr() as usize + w.len()
    });
    &args[..end]
}

/// A `vn` statement's three components. One that parses to a NaN or an infinity (written
/// `nan`, `inf`, `-inf`) makes the normal zero, which the mesh replaces by one computed
/// from the faces ([`super::mesh`]), with a warning naming the line; text that is not a number
/// is an error naming the line, as everywhere.
fn normal<'a>(
    args: &'a str,
    path: &Path,
    line: usize,
    report: &mut LoadReport,
) -> Result<[&'a str; 3], SceneError> {
    let parsed: Vec<Option<f32>> = (args.split_whitespace().take(3))
        .map(|a| a.parse::<f32>().ok())
        .collect();
    let all_numbers = parsed.len() == 3 && parsed.iter().all(Option::is_some);
    if all_numbers && parsed.iter().flatten().any(|x| !x.is_finite()) {
        report.warn(
            WarningKind::NonFiniteNormal,
            path,
            Some(line),
            "normal (vn) with a NaN or infinite component: computed from the faces",
        );
        return Ok(["0", "0", "0"]);
    }
    let v = numbers(first_words(args, 3), 3, "normal (vn)", path, line)?;
    Ok([v[0], v[1], v[2]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::obj::{load_options, parse_obj_str};
    use glam::Vec2;

    /// What tobj is given: plain statements, absolute indices, placeholders first for corners
    /// without `vt` in a textured part; nothing of `l`, `p`, `s`, comments, tabs or a BOM.
    #[test]
    fn normalised_obj_is_plain() {
        let raw = b"\xEF\xBB\xBFv\t0 0 0 1 # caf\xE9\r\nv 1 0 0 0.5 0.5 0.5\r\nv 0 1 0\nvt 0.5\n\
                    s off\nl 1 2\np 1\nf 1 2\no\t a\tb \nf -3/-1 -2 -1\ng\nf 1 2 3\n";
        let mut report = LoadReport::default();
        let obj = validate_obj(raw, Path::new("n.obj"), &mut report).unwrap();
        assert_eq!(
            normalised_obj(&obj, 1),
            "mtllib 0\nvt 0 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0\no a\tb\n\
             f 1/2 2/1 3/1\ng \nf 1 2 3\n"
        );
        assert_eq!(obj.face_lines, vec![10, 12]);
        // Negative: without the placeholder, tobj drops the part's texture coordinates.
        let partial = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0\nf 1/1 2 3\n";
        let (models, _) = tobj::load_obj_buf(&mut partial.as_bytes(), &load_options(), |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .unwrap();
        assert_ne!(models[0].mesh.texcoords.len(), 2 * 3);
        let (parts, _) = parse_obj_str(partial, Path::new("p.obj")).unwrap();
        assert_eq!(
            parts[0].uvs,
            vec![Vec2::new(0.5, 0.0), Vec2::ZERO, Vec2::ZERO]
        );
    }
}

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
//! - UTF-8 text, with or without a byte order mark, LF or CRLF line ends, spaces or tabs.
//!   Comments (`#` to the end of the line) may hold any bytes (Latin-1 ones included); a byte
//!   that is not UTF-8 outside a comment is an error naming the line and column.
//! - `v`, `vt`, `vn`, `f`, `o`, `g`, `usemtl`, `mtllib`; other statements (`s`, curves, ...)
//!   are ignored. Extra values after `v x y z` (a `w`, vertex colours) are ignored, a `vt` with
//!   one value gets v = 0. `l` and `p` elements and faces with fewer than 3 vertices are
//!   skipped with a warning that counts them and names their lines.
//! - Polygons: convex ones are fanned from their first vertex (the triangles `tobj`'s own
//!   `triangulate` makes); others are ear-clipped (`earcut`) in the plane of their Newell
//!   normal; a polygon whose triangles do not cover exactly its area (self-intersecting) is
//!   fanned from its first corner, as `tobj` and Blender do, with a warning naming the line.
//!   Corners on the line of their neighbours are left out first (CAD and Blender n-gons hold
//!   them; ear clipping them made triangles of aspect up to 1e16).
//! - Texture coordinates and normals per face corner: a face without `vt` in a part whose other
//!   faces have them gets uv (0, 0) at its corners (with a warning), a corner without `vn` gets
//!   the computed normal. (`tobj` drops a part's texture coordinates or normals when some
//!   corners lack them, so such corners refer to a `vt 0 0` or `vn 0 0 0` the normalised copy
//!   puts first.)
//! - An undefined material, or `usemtl` in a file without `mtllib`, is a warning naming it;
//!   the faces get the default material (grey 0.8). (The normalised copy declares such names in
//!   one more, empty-bodied library so that `tobj` splits parts at every change of name, as the
//!   file does.)
//! - MTL: `newmtl`, `Kd` (1 value = grey, or 3), `map_Kd` (options such as `-s` are skipped
//!   with a warning; any format the `image` crate reads: PNG, JPEG, BMP, TGA, GIF, TIFF, WebP,
//!   PNM) and `Ns` (the Phong specular power; a reflector uses it only where its scene file says
//!   `specular_power = "mtl"`: a value below 0, as Blender 2.79 writes, is taken as 0, and one
//!   that is not a number is ignored, each with a warning); other statements are ignored.
//!   Errors name the MTL file and line.
//! - Files named by `mtllib` and `map_Kd` are looked for as written, then with Windows
//!   separators read as `/`, then by their file name alone beside the naming file
//!   ([`find_beside`]: an exporter's absolute `E:\...` path). One that is still missing, or a
//!   texture that cannot be decoded, is a warning naming the file and line: the material keeps
//!   its `Kd` (a missing library's materials are grey).
//!
//! Every error names the file and the line: numbers that do not parse or are not finite (NaN,
//! inf), a vertex coordinate beyond 2^60 ([`MAX_COORDINATE`]: scale a mesh in its transform
//! instead), a `Kd` outside `[0, 65504]` ([`MAX_COLOUR`]), face indices out of range. Errors
//! are found in
//! this order: the OBJ pass, the MTL passes, then polygons (so of a bad index and a
//! self-intersecting polygon, the index is named even when it comes later in the file).
//!
//! Hygiene on load, per part:
//! - missing normals are computed: bit-identical positions are welded first (the teapot repeats
//!   263 positions along its patch seams), then area-weighted face normals are summed per welded
//!   vertex; zero-length normals in the file are replaced the same way;
//! - degenerate triangles (a repeated index, or zero area) are dropped and counted in a warning.

use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::{DVec2, Vec2, Vec3};

use super::report::{LoadReport, WarningKind};
use super::{MAX_COLOUR, MAX_COORDINATE, Material, MeshPart, SceneError, Texture};

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

fn obj_err(path: &Path, line: usize, reason: impl Into<String>) -> SceneError {
    SceneError::Obj {
        path: path.to_path_buf(),
        line,
        reason: reason.into(),
    }
}

/// Reads an OBJ or MTL file, refusing files over [`MAX_INPUT_BYTES`].
fn read_input(path: &Path) -> Result<Vec<u8>, SceneError> {
    let len = std::fs::metadata(path)
        .map_err(|e| SceneError::io(path, e))?
        .len();
    if len > MAX_INPUT_BYTES {
        return Err(SceneError::Mtl {
            path: path.to_path_buf(),
            reason: format!(
                "the file has {len} bytes, more than the {MAX_INPUT_BYTES} this loader accepts"
            ),
        });
    }
    std::fs::read(path).map_err(|e| SceneError::io(path, e))
}

/// Splits a file into numbered lines (from 1) without their comments. Skips a UTF-8 byte
/// order mark; a line's comment may hold any bytes, the rest must be UTF-8.
fn text_lines<'a>(bytes: &'a [u8], path: &Path) -> Result<Vec<(usize, &'a str)>, SceneError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut out = Vec::new();
    for (k, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = k + 1;
        let code = match raw.iter().position(|&b| b == b'#') {
            Some(h) => &raw[..h],
            None => raw,
        };
        let text = std::str::from_utf8(code).map_err(|e| {
            let at = e.valid_up_to();
            obj_err(
                path,
                line,
                format!(
                    "byte 0x{:02X} at column {} is not UTF-8 (save the file as UTF-8)",
                    code[at],
                    at + 1
                ),
            )
        })?;
        out.push((line, text));
    }
    Ok(out)
}

/// Splits a line into its keyword and the rest, both trimmed (`None` for a blank line).
fn keyword(text: &str) -> Option<(&str, &str)> {
    let t = text.trim();
    if t.is_empty() {
        return None;
    }
    let end = t.find(char::is_whitespace).unwrap_or(t.len());
    Some((&t[..end], t[end..].trim()))
}

/// Checks the numbers of a statement (at least `min`, all finite as `f32`) and returns their
/// tokens, which parse to the same values wherever `str::parse::<f32>` reads them (`tobj`).
fn numbers<'a>(
    args: &'a str,
    min: usize,
    what: &str,
    path: &Path,
    line: usize,
) -> Result<Vec<&'a str>, SceneError> {
    let words: Vec<&str> = args.split_whitespace().collect();
    if words.len() < min {
        return Err(obj_err(
            path,
            line,
            format!(
                "{what} needs {min} numbers, found {}: '{}'",
                words.len(),
                args
            ),
        ));
    }
    words
        .into_iter()
        .map(|a| match a.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(a),
            Ok(_) => Err(obj_err(
                path,
                line,
                format!("{what} has a non-finite value '{a}'"),
            )),
            Err(_) => Err(obj_err(
                path,
                line,
                format!("{what}: '{a}' is not a number"),
            )),
        })
        .collect()
}

/// Refuses a vertex position with a coordinate beyond [`MAX_COORDINATE`] (tokens already
/// parsed as finite `f32` by [`numbers`]), naming the line and the bound.
fn within_coordinate_bound(v: &[&str], path: &Path, line: usize) -> Result<(), SceneError> {
    for (axis, a) in ["x", "y", "z"].iter().zip(v) {
        let x: f32 = a.parse().unwrap_or(f32::INFINITY);
        if x.abs() > MAX_COORDINATE {
            return Err(obj_err(
                path,
                line,
                format!(
                    "vertex position (v) has {axis} = {a}, beyond the {MAX_COORDINATE:e} (2^60) \
                     a coordinate may reach (the tracer squares distances in f32); \
                     scale the mesh in its [mesh.transform] instead"
                ),
            ));
        }
    }
    Ok(())
}

/// One face corner: 0-based position, texture coordinate and normal indices.
type Corner = (u32, Option<u32>, Option<u32>);

/// Resolves one face corner (`v`, `v/vt`, `v//vn` or `v/vt/vn`; negative indices count back).
fn corner(a: &str, counts: [usize; 3], path: &Path, line: usize) -> Result<Corner, SceneError> {
    let fields: Vec<&str> = a.split('/').collect();
    if fields.len() > 3 || fields[0].is_empty() {
        return Err(obj_err(path, line, format!("malformed face vertex '{a}'")));
    }
    let mut out = [None; 3];
    for (slot, f) in fields.iter().enumerate() {
        if f.is_empty() {
            continue;
        }
        let what = ["position", "texture coordinate", "normal"][slot];
        let count = counts[slot] as i64;
        let i: i64 = f
            .parse()
            .map_err(|_| obj_err(path, line, format!("malformed face vertex '{a}'")))?;
        let resolved = if i < 0 {
            count.saturating_add(i) + 1
        } else {
            i
        };
        if i == 0 || resolved < 1 || resolved > count {
            return Err(obj_err(
                path,
                line,
                format!("face refers to {what} {i}, but only {count} are defined so far"),
            ));
        }
        out[slot] = Some((resolved - 1) as u32);
    }
    Ok((out[0].expect("checked non-empty"), out[1], out[2]))
}

/// Splits a polygon into triangles, as index triples into `points`, all wound as the polygon.
/// Convex polygons are fanned from their first corner; others are ear-clipped in the plane of
/// their Newell normal. Errs (with the reason) on a polygon that no triangulation covers
/// exactly: a self-intersecting one.
pub(crate) fn triangulate(points: &[Vec3]) -> Result<Vec<[usize; 3]>, String> {
    if points.len() <= 3 {
        return triangulate_turning(points);
    }
    // Corners on the line of their neighbours (CAD and Blender n-gons hold them) would make
    // triangles of aspect up to 1e16; the polygon is the same without them.
    let kept = turning_corners(points);
    if kept.len() < 3 {
        return Ok(Vec::new());
    }
    let sub: Vec<Vec3> = kept.iter().map(|&i| points[i]).collect();
    Ok(triangulate_turning(&sub)?
        .into_iter()
        .map(|t| t.map(|k| kept[k]))
        .collect())
}

/// A corner whose two edges make an angle with sine at most this with one line adds no area
/// that f32 keeps to its polygon: [`turning_corners`] leaves it out.
const COLLINEAR_SINE: f64 = 1e-5;

/// The corners of a polygon that turn, in order: each corner whose edges to its kept
/// neighbours lie on one line within [`COLLINEAR_SINE`] (a point on an edge, a repeated
/// corner, a zero-area spike) is left out, again until none is (or fewer than 3 are kept). The
/// surface moves by at most that sine times the edges' length, far below a pixel.
fn turning_corners(points: &[Vec3]) -> Vec<usize> {
    let mut kept: Vec<usize> = (0..points.len()).collect();
    let mut i = 0;
    let mut since_removal = 0;
    while kept.len() >= 3 && since_removal < kept.len() {
        let n = kept.len();
        let [a, b, c] = [(i + n - 1) % n, i, (i + 1) % n].map(|k| points[kept[k]].as_dvec3());
        let (e1, e2) = (b - a, c - b);
        if e1.cross(e2).length() <= COLLINEAR_SINE * e1.length() * e2.length() {
            kept.remove(i);
            since_removal = 0;
            i = i.checked_sub(1).unwrap_or(kept.len().saturating_sub(1));
        } else {
            since_removal += 1;
            i = (i + 1) % n;
        }
    }
    kept
}

/// [`triangulate`] of a polygon whose corners all turn (or of at most 3 corners).
fn triangulate_turning(points: &[Vec3]) -> Result<Vec<[usize; 3]>, String> {
    let n = points.len();
    let fan = || (1..n.saturating_sub(1)).map(|i| [0, i, i + 1]).collect();
    if n <= 3 {
        return Ok(fan());
    }
    let p64: Vec<[f64; 3]> = points.iter().map(|p| p.as_dvec3().to_array()).collect();
    let mut flat: Vec<[f64; 2]> = Vec::with_capacity(n);
    if !earcut::utils3d::project3d_to_2d(&p64, n, &mut flat) {
        // No plane: either every corner is on one line (the fan's triangles have no area and
        // are dropped as degenerate), or the polygon crosses itself so that its halves cancel.
        let spread = (1..n - 1).any(|i| {
            let [a, b, c] = [0, i, i + 1].map(|k| points[k].as_dvec3());
            (b - a).cross(c - a).length_squared() > 0.0
        });
        return if spread {
            Err(format!(
                "the polygon of {n} vertices crosses itself (its signed area is zero)"
            ))
        } else {
            Ok(fan())
        };
    }
    let q: Vec<DVec2> = flat.iter().map(|&p| DVec2::from_array(p)).collect();
    let signed = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - a);
    let area: f64 = (1..n - 1).map(|i| signed(q[0], q[i], q[i + 1])).sum();
    let s = if area < 0.0 { -1.0 } else { 1.0 };
    // Convex: every corner turns the same way, and the turns add up to one full turn.
    let mut turning = 0.0;
    let mut convex = true;
    for i in 0..n {
        let (a, b, c) = (q[i], q[(i + 1) % n], q[(i + 2) % n]);
        let (e1, e2) = (b - a, c - b);
        let cross = s * e1.perp_dot(e2);
        if cross < 0.0 {
            convex = false;
            break;
        }
        turning += cross.atan2(e1.dot(e2));
    }
    if convex && (turning - std::f64::consts::TAU).abs() < 1e-6 {
        return Ok(fan());
    }
    let mut idx: Vec<u32> = Vec::new();
    earcut::Earcut::new().earcut(flat.iter().copied(), &[] as &[u32], &mut idx);
    let mut out = Vec::with_capacity(idx.len() / 3);
    let mut covered = 0.0;
    for t in idx.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|k| k as usize);
        let tri_area = signed(q[a], q[b], q[c]);
        covered += tri_area.abs();
        out.push(if tri_area * s < 0.0 {
            [a, c, b]
        } else {
            [a, b, c]
        });
    }
    let tolerance = 1e-6 * area.abs().max(covered).max(f64::MIN_POSITIVE);
    if (covered - area.abs()).abs() > tolerance {
        return Err(format!(
            "the polygon of {n} vertices crosses itself (its triangles cover {covered:.6e}, \
             its signed area is {area:.6e})"
        ));
    }
    Ok(out)
}

/// One OBJ statement the validation pass keeps, in file order, as the tokens `tobj` will read.
enum Statement<'a> {
    Position([&'a str; 3]),
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
struct PartInfo {
    name: String,
    /// `usemtl` name and line.
    material: Option<(String, usize)>,
    faces: usize,
    /// Lines of faces without texture coordinates.
    faces_without_vt: Vec<usize>,
    any_vt: bool,
    any_vn: bool,
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
struct ObjPass<'a> {
    statements: Vec<Statement<'a>>,
    parts: Vec<PartInfo>,
    /// The source line of each face, in file order (the order `tobj` keeps).
    face_lines: Vec<usize>,
    /// Material libraries and the line naming each (first mention).
    libraries: Vec<(PathBuf, usize)>,
}

const UNNAMED: &str = "unnamed_object";

/// The validation pass over an OBJ file (see the module docs).
fn validate_obj<'a>(
    bytes: &'a [u8],
    path: &Path,
    report: &mut LoadReport,
) -> Result<ObjPass<'a>, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut obj = ObjPass {
        statements: Vec::new(),
        parts: vec![PartInfo::new(UNNAMED.into(), None)],
        face_lines: Vec::new(),
        libraries: Vec::new(),
    };
    let mut counts = [0usize; 3];
    for (line, text) in text_lines(bytes, path)? {
        let Some((key, args)) = keyword(text) else {
            continue;
        };
        match key {
            "v" => {
                let v = numbers(args, 3, "vertex position (v)", path, line)?;
                within_coordinate_bound(&v[..3], path, line)?;
                obj.statements.push(Statement::Position([v[0], v[1], v[2]]));
                counts[0] += 1;
            }
            "vt" => {
                let v = numbers(args, 1, "texture coordinate (vt)", path, line)?;
                obj.statements.push(Statement::Texcoord([
                    v[0],
                    v.get(1).copied().unwrap_or("0"),
                ]));
                counts[1] += 1;
            }
            "vn" => {
                let v = numbers(args, 3, "normal (vn)", path, line)?;
                obj.statements.push(Statement::Normal([v[0], v[1], v[2]]));
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
            "usemtl" => obj.use_material(args, path, line)?,
            "mtllib" => obj.add_libraries(args, dir, path, line, report)?,
            _ => {}
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
    fn use_material(&mut self, args: &'a str, path: &Path, line: usize) -> Result<(), SceneError> {
        if args.is_empty() {
            return Err(obj_err(path, line, "usemtl needs a material name"));
        }
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
        Ok(())
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
            return Err(obj_err(path, line, "mtllib needs a file name"));
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

/// The file a material library or texture statement names, as exporters write it, relative to
/// `dir` (the folder of the file that names it): the name as written, with Windows separators
/// (`\`) read as `/`; failing that (an absolute path from the exporter's machine, such as
/// `E:\textures\wood.jpg`), the file name alone in `dir`. `None` where neither exists.
pub(crate) fn find_beside(dir: &Path, name: &str) -> Option<PathBuf> {
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
    alone.is_file().then_some(alone)
}

/// Writes the normalised OBJ text `tobj` reads: `mtllib 0` to `mtllib {libraries - 1}` first
/// (so every `usemtl` finds its library loaded), then the `vt 0 0` and `vn 0 0 0` that corners
/// without them refer to in parts that have them, then every kept statement, faces with
/// absolute 1-based indices.
fn normalised_obj(obj: &ObjPass, libraries: usize) -> String {
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
            Statement::Position([x, y, z]) => writeln!(out, "v {x} {y} {z}"),
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

/// One `newmtl` of an MTL file, checked.
struct MtlEntry<'a> {
    name: &'a str,
    line: usize,
    /// `Kd` as three tokens (a single grey value repeated).
    diffuse: Option<[&'a str; 3]>,
    /// `map_Kd` file name (relative to the MTL file), options removed.
    map: Option<String>,
    /// `Ns` (the Phong specular power), checked: one finite number, at least 0.
    shininess: Option<&'a str>,
}

/// `map_Kd` options and how many arguments each takes (`-o`, `-s`, `-t`: 1 to 3 numbers).
fn map_option_arguments(option: &str) -> Option<(usize, usize)> {
    Some(match option {
        "-blendu" | "-blendv" | "-cc" | "-clamp" | "-bm" | "-boost" | "-imfchan" | "-texres"
        | "-type" => (1, 1),
        "-mm" => (2, 2),
        "-o" | "-s" | "-t" => (1, 3),
        _ => return None,
    })
}

/// The validation pass over an MTL file: its entries, for the normalised MTL text and the
/// duplicate check.
fn validate_mtl<'a>(
    bytes: &'a [u8],
    path: &Path,
    report: &mut LoadReport,
) -> Result<Vec<MtlEntry<'a>>, SceneError> {
    let mut out: Vec<MtlEntry> = Vec::new();
    for (line, text) in text_lines(bytes, path)? {
        let Some((key, args)) = keyword(text) else {
            continue;
        };
        if key == "newmtl" {
            if args.is_empty() {
                return Err(obj_err(path, line, "newmtl needs a material name"));
            }
            out.push(MtlEntry {
                name: args,
                line,
                diffuse: None,
                map: None,
                shininess: None,
            });
            continue;
        }
        if key != "Kd" && key != "map_Kd" && key != "Ns" {
            continue;
        }
        let Some(current) = out.last_mut() else {
            return Err(obj_err(path, line, format!("{key} before any newmtl")));
        };
        if key == "Ns" {
            current.shininess = specular_exponent(args, current.name, path, line, report);
        } else if key == "Kd" {
            let first = args.split_whitespace().next().unwrap_or("");
            if first == "spectral" || first == "xyz" {
                report.warn(
                    WarningKind::UnsupportedColour,
                    path,
                    Some(line),
                    format!(
                        "'Kd {first}' is not supported: material '{}' keeps grey 0.8",
                        current.name
                    ),
                );
                continue;
            }
            let v = numbers(args, 1, "diffuse colour (Kd)", path, line)?;
            if let Some(a) = v.iter().find(|a| {
                let x: f32 = a.parse().unwrap_or(f32::NAN);
                !(0.0..=MAX_COLOUR).contains(&x)
            }) {
                return Err(obj_err(
                    path,
                    line,
                    format!("diffuse colour (Kd) has {a}, outside [0, {MAX_COLOUR}] (linear RGB)"),
                ));
            }
            current.diffuse = Some(match v[..] {
                [g] => [g; 3],
                [r, g, b] => [r, g, b],
                _ => {
                    return Err(obj_err(
                        path,
                        line,
                        format!(
                            "diffuse colour (Kd) takes 1 number (grey) or 3 (r g b), found {}",
                            v.len()
                        ),
                    ));
                }
            });
        } else {
            current.map = map_kd_file(args, current.name, path, line, report)?;
        }
    }
    Ok(out)
}

/// A `map_Kd` statement's texture file ([`find_beside`]), relative to the MTL's folder, its
/// options skipped with a warning; a missing file is a warning and `None` (the material keeps
/// its `Kd`).
fn map_kd_file(
    args: &str,
    material: &str,
    path: &Path,
    line: usize,
    report: &mut LoadReport,
) -> Result<Option<String>, SceneError> {
    let words: Vec<&str> = args.split_whitespace().collect();
    let mut k = 0;
    let mut options = false;
    while k + 1 < words.len() && words[k].starts_with('-') {
        options = true;
        let (min, max) = map_option_arguments(words[k]).unwrap_or((0, 0));
        k += 1;
        let mut taken = 0;
        while taken < max && k + 1 < words.len() {
            let w = words[k];
            let is_arg = taken < min || w.parse::<f64>().is_ok();
            if !is_arg {
                break;
            }
            k += 1;
            taken += 1;
        }
    }
    if options {
        report.warn(
            WarningKind::IgnoredMapOptions,
            path,
            Some(line),
            "map_Kd options ignored",
        );
    }
    let file = words[k.min(words.len())..].join(" ");
    if file.is_empty() {
        return Err(obj_err(path, line, "map_Kd needs a file name"));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    Ok(match find_beside(dir, &file) {
        Some(found) => Some(
            found
                .strip_prefix(dir)
                .map_or(found.clone(), Path::to_path_buf)
                .to_string_lossy()
                .into_owned(),
        ),
        None => {
            report.warn(
                WarningKind::MissingTexture,
                path,
                Some(line),
                format!(
                    "texture '{file}' of material '{}' not found beside {}: the \
                     material uses its Kd",
                    material,
                    path.display()
                ),
            );
            None
        }
    })
}

/// An MTL `Ns` statement's value (a Phong specular power, which a reflector reads only where
/// its scene file says `specular_power = "mtl"`): one finite number, at least 0. Exporters
/// write others (Blender 2.79: `Ns -1.960784`), so a value below 0 is taken as 0 and one that
/// is not a number is ignored, each with a warning naming the line; neither refuses the file.
fn specular_exponent<'a>(
    args: &'a str,
    material: &str,
    path: &Path,
    line: usize,
    report: &mut LoadReport,
) -> Option<&'a str> {
    let mut words = args.split_whitespace();
    let value = match (words.next(), words.next()) {
        (Some(a), None) => a
            .parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .map(|x| (a, x)),
        _ => None,
    };
    match value {
        Some((a, x)) if x >= 0.0 => Some(a),
        Some((a, _)) => {
            report.warn(
                WarningKind::SpecularPower,
                path,
                Some(line),
                format!(
                    "material '{material}': specular power (Ns) {a} is below 0, taken as 0 \
                     (read only by a reflector with specular_power = \"mtl\")"
                ),
            );
            Some("0")
        }
        None => {
            report.warn(
                WarningKind::SpecularPower,
                path,
                Some(line),
                format!(
                    "material '{material}': specular power (Ns) '{args}' is not one finite \
                     number, ignored"
                ),
            );
            None
        }
    }
}

/// The normalised MTL text `tobj` reads for checked entries.
fn normalised_mtl(entries: &[MtlEntry]) -> String {
    let mut out = String::new();
    for m in entries {
        writeln!(out, "newmtl {}", m.name).expect("writing to a String");
        if let Some([r, g, b]) = m.diffuse {
            writeln!(out, "Kd {r} {g} {b}").expect("writing to a String");
        }
        if let Some(file) = &m.map {
            writeln!(out, "map_Kd {file}").expect("writing to a String");
        }
        if let Some(ns) = m.shininess {
            writeln!(out, "Ns {ns}").expect("writing to a String");
        }
    }
    out
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
fn tobj_failed(path: &Path, e: tobj::LoadError) -> SceneError {
    SceneError::Mtl {
        path: path.to_path_buf(),
        reason: format!("tobj refused the checked file ({e}); please report this as a bug"),
    }
}

// Other tobj features add fields to `LoadOptions`; keep their defaults whatever is enabled.
#[allow(clippy::needless_update)]
fn load_options() -> tobj::LoadOptions {
    tobj::LoadOptions {
        single_index: true,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    }
}

/// One part as `tobj` built it, its polygons triangulated.
struct RawPart {
    /// Index into [`ObjPass::parts`].
    part: usize,
    material_id: Option<usize>,
    positions: Vec<Vec3>,
    uvs: Vec<Vec2>,
    normals: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// The source line of each triangle's polygon.
    lines: Vec<u32>,
}

/// The items of `v` at `kept`; an empty `v` (texture coordinates or normals absent) stays empty.
fn pick<T: Copy>(v: &[T], kept: &[usize]) -> Vec<T> {
    if v.is_empty() {
        Vec::new()
    } else {
        kept.iter().map(|&i| v[i]).collect()
    }
}

/// Triangulates the polygons of `tobj`'s models (see [`triangulate`]); one that crosses itself
/// is fanned from its first corner with a warning naming its source line. Models without faces
/// are left out.
fn triangulate_models(
    obj: &ObjPass,
    models: Vec<tobj::Model>,
    path: &Path,
    report: &mut LoadReport,
) -> Result<Vec<RawPart>, SceneError> {
    let mismatch = || tobj_failed(path, tobj::LoadError::GenericFailure);
    let mut parts = obj.parts.iter().enumerate().filter(|(_, p)| p.faces > 0);
    let mut lines = obj.face_lines.iter();
    let mut out = Vec::new();
    for model in models {
        let m = model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let (part, info) = parts.next().ok_or_else(mismatch)?;
        // `tobj` leaves `face_arities` empty when every face is a triangle.
        let arities = if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities
        };
        if arities.len() != info.faces
            || arities.iter().map(|&n| n as usize).sum::<usize>() != m.indices.len()
        {
            return Err(mismatch());
        }
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        if m.indices.iter().any(|&i| i as usize >= positions.len()) {
            return Err(mismatch());
        }
        let mut triangles = Vec::with_capacity(m.indices.len());
        let mut tri_lines: Vec<u32> = Vec::with_capacity(m.indices.len());
        let mut start = 0;
        for &n in &arities {
            let face = &m.indices[start..start + n as usize];
            start += n as usize;
            let line = *lines.next().ok_or_else(mismatch)?;
            let points: Vec<Vec3> = face.iter().map(|&i| positions[i as usize]).collect();
            let tris = triangulate(&points).unwrap_or_else(|reason| {
                report.warn(
                    WarningKind::SelfCrossingPolygon,
                    path,
                    Some(line),
                    format!(
                        "polygons that cross themselves fanned from their first corner, as \
                         tobj and Blender do (the fan may cover area outside the outline): \
                         {}",
                        reason.split(" (").next().unwrap_or(&reason)
                    ),
                );
                (1..n as usize - 1).map(|i| [0, i, i + 1]).collect()
            });
            tri_lines.extend(std::iter::repeat_n(line as u32, tris.len()));
            triangles.extend(tris.into_iter().map(|t| t.map(|k| face[k])));
        }
        let uvs: Vec<Vec2> = m
            .texcoords
            .chunks_exact(2)
            .map(|t| Vec2::new(t[0], t[1]))
            .collect();
        let normals: Vec<Vec3> = m
            .normals
            .chunks_exact(3)
            .map(|n| Vec3::new(n[0], n[1], n[2]))
            .collect();
        let expect = |len: usize, wanted: bool| len == if wanted { positions.len() } else { 0 };
        if !expect(uvs.len(), info.any_vt) || !expect(normals.len(), info.any_vn) {
            return Err(mismatch());
        }
        // Keep only the vertices the triangles use, numbered in the order they first use them
        // (for fanned polygons, tobj's own order; ear clipping may leave a repeated corner out).
        let mut new_index = vec![u32::MAX; positions.len()];
        let mut kept: Vec<usize> = Vec::with_capacity(positions.len());
        for t in &mut triangles {
            for i in t.iter_mut() {
                let slot = &mut new_index[*i as usize];
                if *slot == u32::MAX {
                    *slot = kept.len() as u32;
                    kept.push(*i as usize);
                }
                *i = *slot;
            }
        }
        out.push(RawPart {
            part,
            material_id: m.material_id,
            positions: pick(&positions, &kept),
            uvs: pick(&uvs, &kept),
            normals: pick(&normals, &kept),
            triangles,
            lines: tri_lines,
        });
    }
    if parts.next().is_some() {
        return Err(mismatch());
    }
    Ok(out)
}

/// Turns a triangulated part into a [`MeshPart`], applying the hygiene rules. Returns the part
/// and the number of degenerate triangles dropped.
fn finish_part(
    info: &PartInfo,
    raw: RawPart,
    material: u32,
    path: &Path,
    report: &mut LoadReport,
) -> (MeshPart, usize) {
    if info.any_vt {
        for &line in &info.faces_without_vt {
            report.warn(
                WarningKind::MissingTexcoords,
                path,
                Some(line),
                format!(
                    "face without texture coordinates in textured part '{}': its corners get uv (0, 0)",
                    info.name
                ),
            );
        }
    }
    let positions = raw.positions;
    let mut triangles = Vec::with_capacity(raw.triangles.len());
    let mut lines = Vec::with_capacity(raw.triangles.len());
    let mut dropped = 0;
    for (&t, &line) in raw.triangles.iter().zip(&raw.lines) {
        // In f64: f32 overflows for sides over ~1e19 and underflows under ~1e-19, both of
        // which a valid vertex may give (coordinates reach 2^60).
        let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
        let area2 = (b - a).cross(c - a).length_squared();
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area2 == 0.0 || !area2.is_finite() {
            dropped += 1;
        } else {
            triangles.push(t);
            lines.push(line);
        }
    }
    // Corners without a normal have the zero one here, replaced by the computed normal below.
    let given = raw.normals;
    // Normals already of unit length (to f32 precision) are kept bit for bit; others are
    // normalised in f32, or in f64 where their squared length leaves f32's normal range (a
    // `vn 1e30 0 0` gave the zero vector, a `vn 1e-30 0 0` was taken for a missing normal).
    let unit = |n: Vec3| {
        let l2 = n.length_squared();
        if (l2 - 1.0).abs() < 1e-6 {
            n
        } else if l2.is_normal() {
            n.normalize()
        } else {
            n.as_dvec3().normalize().as_vec3()
        }
    };
    let normals = if given.is_empty() {
        smooth_normals(&positions, &triangles)
    } else if given.contains(&Vec3::ZERO) {
        let smooth = smooth_normals(&positions, &triangles);
        given
            .iter()
            .zip(smooth)
            .map(|(&n, s)| if n == Vec3::ZERO { s } else { unit(n) })
            .collect()
    } else {
        given.iter().map(|&n| unit(n)).collect()
    };
    (
        MeshPart {
            name: info.name.clone(),
            positions,
            normals,
            uvs: raw.uvs,
            triangles,
            material,
            source: Some(super::PartSource {
                file: path.to_path_buf(),
                lines,
            }),
        },
        dropped,
    )
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
    let bytes = read_input(path)?;
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
        if let (None, Some((name, line))) = (found, &info.material) {
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

/// Each material library of `obj` read, checked and normalised for `tobj`; with the MTL file of
/// each of tobj's materials, in order. A material defined again is warned about (the later one
/// is used).
fn read_libraries<'a>(
    obj: &'a ObjPass,
    report: &mut LoadReport,
) -> Result<(Vec<String>, Vec<&'a Path>), SceneError> {
    let mut mtl_texts = Vec::with_capacity(obj.libraries.len());
    let mut origin: Vec<&Path> = Vec::new();
    let mut previous: HashMap<String, (PathBuf, usize)> = HashMap::new();
    for (mtl_path, _) in &obj.libraries {
        let bytes = read_input(mtl_path)?;
        let entries = validate_mtl(&bytes, mtl_path, report)?;
        for m in &entries {
            origin.push(mtl_path);
            if let Some((first, first_line)) = previous.get(m.name) {
                report.warn(
                    WarningKind::DuplicateMaterial,
                    mtl_path,
                    Some(m.line),
                    format!(
                        "material '{}' is defined again (first at {}:{first_line}); the later one is used",
                        m.name,
                        first.display()
                    ),
                );
            }
            previous.insert(m.name.to_string(), (mtl_path.clone(), m.line));
        }
        mtl_texts.push(normalised_mtl(&entries));
    }
    Ok((mtl_texts, origin))
}

/// tobj's materials (`origin[k]`: the MTL file of material k) into `out`, each `map_Kd` texture
/// loaded once (relative to its MTL file).
fn load_materials(
    materials: &[tobj::Material],
    origin: &[&Path],
    out: &mut LoadedObj,
    report: &mut LoadReport,
) {
    let mut texture_ids: HashMap<PathBuf, u32> = HashMap::new();
    for (m, mtl_path) in materials.iter().zip(origin) {
        let texture = match &m.diffuse_texture {
            None => None,
            Some(t) => {
                let tex_path = mtl_path.parent().unwrap_or(Path::new(".")).join(t);
                if let Some(&id) = texture_ids.get(&tex_path) {
                    Some(id)
                } else {
                    match load_texture(&tex_path) {
                        Ok(tex) => {
                            out.textures.push(tex);
                            let id = (out.textures.len() - 1) as u32;
                            texture_ids.insert(tex_path, id);
                            Some(id)
                        }
                        Err(reason) => {
                            report.warn(
                                WarningKind::MissingTexture,
                                mtl_path,
                                None,
                                format!(
                                    "material '{}': texture {} cannot be loaded ({reason}): \
                                     the material uses its Kd",
                                    m.name,
                                    tex_path.display()
                                ),
                            );
                            None
                        }
                    }
                }
            }
        };
        out.materials.push(Material {
            name: m.name.clone(),
            diffuse: m.diffuse.map_or(Vec3::splat(0.8), Vec3::from_array),
            texture,
            // As read; the scene file decides whether a reflector honours it (`merge`).
            specular_power: m.shininess,
        });
    }
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

fn load_texture(path: &Path) -> Result<Texture, String> {
    let img = image::open(path).map_err(|e| e.to_string())?.to_rgba8();
    Ok(Texture {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "texture".into()),
        width: img.width(),
        height: img.height(),
        rgba8: img.into_raw(),
    })
}

/// Area-weighted vertex normals over welded (bit-identical) positions.
pub fn smooth_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let key = |p: Vec3| {
        p.to_array()
            .map(|c| if c == 0.0 { 0u32 } else { c.to_bits() })
    };
    let mut weld: HashMap<[u32; 3], usize> = HashMap::new();
    let rep: Vec<usize> = positions
        .iter()
        .enumerate()
        .map(|(i, &p)| *weld.entry(key(p)).or_insert(i))
        .collect();
    // Summed in f32 (the normals of every mesh so far), and in f64 for the vertices where f32
    // overflows or underflows (sides over ~1e19 or under ~1e-19: coordinates reach 2^60).
    let mut sum = vec![Vec3::ZERO; positions.len()];
    let mut wide = vec![glam::DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        let [a, b, c] = [a, b, c].map(Vec3::as_dvec3);
        let w = (b - a).cross(c - a);
        for &i in t {
            sum[rep[i as usize]] += n;
            wide[rep[i as usize]] += w;
        }
    }
    rep.iter()
        .map(|&r| {
            sum[r]
                .try_normalize()
                .or_else(|| wide[r].try_normalize().map(|n| n.as_vec3()))
                .unwrap_or(Vec3::Y)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welding_makes_seams_smooth() {
        // Two triangles folded along a shared edge, the edge's positions repeated (a seam).
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        let n = smooth_normals(&positions, &[[0, 1, 2], [3, 5, 4]]);
        // The seam vertices 1 and 3 (and 2 and 4) get the same, blended normal.
        assert_eq!(n[1], n[3]);
        assert_eq!(n[2], n[4]);
        assert!(n[1] != n[0], "the seam normal blends both faces");
    }

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

    /// tobj panics on a one-value `Kd` and on short `Ka`, `Ks`, `Ke` (a missing value
    /// unwrapped); the normalised MTL it reads instead loads, `Kd 0.5` as grey.
    #[test]
    fn tobj_reads_only_normalised_mtl() {
        for raw in ["Kd 0.5", "Ka 1", "Ks 0 0", "Ke 0"] {
            let text = format!("newmtl g\n{raw}\n");
            let panicked = std::panic::catch_unwind(|| tobj::load_mtl_buf(&mut text.as_bytes()));
            assert!(panicked.is_err(), "tobj no longer panics on '{raw}'");
            let mut report = LoadReport::default();
            let entries = validate_mtl(text.as_bytes(), Path::new("g.mtl"), &mut report).unwrap();
            let clean = normalised_mtl(&entries);
            let (mats, _) = tobj::load_mtl_buf(&mut clean.as_bytes()).unwrap();
            let kd = if raw == "Kd 0.5" {
                Some([0.5; 3])
            } else {
                None
            };
            assert_eq!(
                (mats[0].name.as_str(), mats[0].diffuse),
                ("g", kd),
                "{clean}"
            );
        }
    }

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

    #[test]
    fn hygiene_drops_degenerates_and_fills_normals() {
        // A quad split in two, plus a triangle with a repeated index and one of zero area.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n\
                    f 1 2 3\nf 1 3 4\nf 1 1 2\nf 1 2 5\n";
        let (parts, dropped) = parse_obj_str(text, Path::new("q.obj")).unwrap();
        assert_eq!(dropped, 2);
        assert_eq!(parts[0].triangles.len(), 2);
        for n in &parts[0].normals[..4] {
            assert!((*n - Vec3::Z).length() < 1e-6, "{n}");
        }
        // Zero-length normals in the file are replaced, valid ones kept.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn 0 0 1\nvn 0 0 2\nf 1//1 2//2 3//3\n";
        let (parts, _) = parse_obj_str(text, Path::new("n.obj")).unwrap();
        assert!(
            parts[0]
                .normals
                .iter()
                .all(|n| (*n - Vec3::Z).length() < 1e-6)
        );
    }

    /// Area of the triangles, and whether each is wound like the polygon (normal along +z for
    /// the counter-clockwise test polygons in the xy plane).
    fn cover(points: &[Vec3], tris: &[[usize; 3]]) -> (f32, bool) {
        let mut area = 0.0;
        let mut wound = true;
        for t in tris {
            let [a, b, c] = t.map(|k| points[k]);
            let n = (b - a).cross(c - a);
            area += 0.5 * n.length();
            wound &= n.z >= 0.0;
        }
        (area, wound)
    }

    /// The largest ratio of a triangle's longest edge to its height on that edge.
    fn worst_aspect(points: &[Vec3], tris: &[[usize; 3]]) -> f64 {
        tris.iter()
            .map(|t| {
                let [a, b, c] = t.map(|k| points[k].as_dvec3());
                let long = (b - a).length().max((c - b).length()).max((a - c).length());
                let area2 = (b - a).cross(c - a).length();
                long * long / area2
            })
            .fold(0.0, f64::max)
    }

    /// An L-shaped n-gon as CAD exporters write them: corners on its edges, nearly collinear
    /// (off the line by f32 rounding of printed decimals) and one repeated. Those corners are
    /// left out before ear clipping: the triangles cover the L's area with no sliver. Negative:
    /// a convex polygon with such a corner, fanned as written, makes a triangle of aspect
    /// above 1e7.
    #[test]
    fn collinear_corners_are_left_out_before_ear_clipping() {
        let l: Vec<Vec3> = [
            (0., 0.),
            (0.7, 0.0),
            (1.3, 1e-7),
            (2., 0.),
            (2., 0.4),
            (2., 1.),
            (1., 1.),
            (1., 1.),
            (1., 1.5),
            (1., 2.),
            (0.5, 2.),
            (0., 2.),
            (0., 0.9),
        ]
        .map(|(x, y)| Vec3::new(x, y, 0.0))
        .to_vec();
        for shift in 0..l.len() {
            let mut p = l.clone();
            p.rotate_left(shift);
            let tris = triangulate(&p).unwrap();
            let (area, wound) = cover(&p, &tris);
            assert!((area - 3.0).abs() < 1e-5, "shift {shift}: area {area}");
            assert!(wound, "shift {shift}");
            assert_eq!(tris.len(), 4, "shift {shift}: {tris:?}");
            let aspect = worst_aspect(&p, &tris);
            assert!(aspect < 10.0, "shift {shift}: aspect {aspect}");
        }
        let kept = turning_corners(&l);
        assert_eq!(kept, vec![0, 3, 5, 7, 9, 11], "{kept:?}");
        // A convex quad with a corner on its first edge, off the line by 1e-7 (convex, so
        // fanned from corner 0).
        let quad: Vec<Vec3> = [(0., 0.), (1., 0.), (2., 1e-7), (2., 1.), (0., 1.)]
            .map(|(x, y)| Vec3::new(x, y, 0.0))
            .to_vec();
        let tris = triangulate(&quad).unwrap();
        assert_eq!(tris.len(), 2);
        assert!(worst_aspect(&quad, &tris) < 10.0);
        let as_written = triangulate_turning(&quad).unwrap();
        let w = worst_aspect(&quad, &as_written);
        assert!(w > 1e7, "{w} {as_written:?}");
        // All corners on one line: no triangle.
        let line: Vec<Vec3> = (0..5).map(|k| Vec3::new(k as f32, 0.0, 0.0)).collect();
        assert!(triangulate(&line).unwrap().is_empty());
        // A sliver triangle as written is kept: it is geometry.
        let sliver = [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1e-6, 0.0)];
        assert_eq!(triangulate(&sliver).unwrap(), vec![[0, 1, 2]]);
    }

    #[test]
    fn triangulate_concave_and_convex() {
        // An L shape (area 3), its reflex corner at index 4: a fan from corner 0 would cover
        // area outside it.
        let l: Vec<Vec3> = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)]
            .map(|(x, y)| Vec3::new(x, y, 0.0))
            .to_vec();
        for shift in 0..l.len() {
            let mut p = l.clone();
            p.rotate_left(shift);
            let tris = triangulate(&p).unwrap();
            assert_eq!(tris.len(), 4);
            let (area, wound) = cover(&p, &tris);
            assert!((area - 3.0).abs() < 1e-5, "shift {shift}: area {area}");
            assert!(wound, "shift {shift}: a triangle is flipped");
        }
        // Negative: the fan of the L from its corner 2 covers more than the L.
        let mut p = l.clone();
        p.rotate_left(2);
        let fan: Vec<[usize; 3]> = (1..5).map(|i| [0, i, i + 1]).collect();
        assert!((cover(&p, &fan).0 - 3.0).abs() > 0.1);
        // Convex polygons are fanned from corner 0 (the same triangles as tobj).
        let hex: Vec<Vec3> = (0..6)
            .map(|k| {
                let a = k as f32 * std::f32::consts::TAU / 6.0;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert_eq!(
            triangulate(&hex).unwrap(),
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]
        );
        // Clockwise input stays clockwise.
        let mut cw = l.clone();
        cw.reverse();
        let tris = triangulate(&cw).unwrap();
        assert!(tris.iter().all(|t| {
            let [a, b, c] = t.map(|k| cw[k]);
            (b - a).cross(c - a).z <= 0.0
        }));
    }

    #[test]
    fn triangulate_refuses_self_intersecting() {
        // A bow tie with unequal lobes, and a pentagram (which winds twice).
        let bow: Vec<Vec3> = [(0., 0.), (2., 1.), (2., 0.), (0., 2.)]
            .map(|(x, y)| Vec3::new(x, y, 0.0))
            .to_vec();
        assert!(triangulate(&bow).is_err());
        let star: Vec<Vec3> = (0..5)
            .map(|k| {
                let a = (2 * k) as f32 * std::f32::consts::TAU / 5.0;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert!(triangulate(&star).is_err());
        // A symmetric bow tie: its signed area is zero.
        let sym: Vec<Vec3> = [(0., 0.), (1., 1.), (1., 0.), (0., 1.)]
            .map(|(x, y)| Vec3::new(x, y, 0.0))
            .to_vec();
        assert!(triangulate(&sym).is_err());
        // Collinear corners are not an error: their triangles are dropped as degenerate.
        let line: Vec<Vec3> = (0..4).map(|k| Vec3::new(k as f32, 0.0, 0.0)).collect();
        assert!(triangulate(&line).is_ok());
    }
}

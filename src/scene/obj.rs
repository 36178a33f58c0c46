//! OBJ/MTL loading and mesh hygiene.
//!
//! The parser is our own (it replaced `tobj`, which panics on `Kd 0.5`, fans concave polygons,
//! drops a whole part's texture coordinates when one face lacks them, splits `mtllib` and
//! `usemtl` on spaces only and reports no line numbers). What it accepts:
//! - UTF-8 text, with or without a byte order mark, LF or CRLF line ends, spaces or tabs.
//!   Comments (`#` to the end of the line) may hold any bytes (Latin-1 ones included); a byte
//!   that is not UTF-8 outside a comment is an error naming the line and column.
//! - `v`, `vt`, `vn`, `f`, `o`, `g`, `usemtl`, `mtllib`; other statements (`s`, curves, ...)
//!   are ignored. `l` and `p` elements and faces with fewer than 3 vertices are skipped with a
//!   warning that counts them and names their lines.
//! - Polygons: convex ones are fanned from their first vertex; others are ear-clipped
//!   (`earcut`) in the plane of their Newell normal, and a polygon whose triangles do not
//!   cover exactly its area (self-intersecting) is refused, naming the line.
//! - Texture coordinates and normals per face corner: a face without `vt` in a part whose other
//!   faces have them gets uv (0, 0) at its corners (with a warning), a corner without `vn` gets
//!   the computed normal.
//! - An undefined material, or `usemtl` in a file without `mtllib`, is a warning naming it;
//!   the faces get the default material (grey 0.8).
//! - MTL: `newmtl`, `Kd` (1 value = grey, or 3) and `map_Kd` (options such as `-s` are skipped
//!   with a warning); other statements are ignored. Errors name the MTL file and line.
//!
//! Every error names the file and the line: numbers that do not parse or are not finite (NaN,
//! inf), face indices out of range, a missing material library or texture.
//!
//! Hygiene on load, per part:
//! - missing normals are computed: bit-identical positions are welded first (the teapot repeats
//!   263 positions along its patch seams), then area-weighted face normals are summed per welded
//!   vertex; zero-length normals in the file are replaced the same way;
//! - degenerate triangles (a repeated index, or zero area) are dropped and counted in a warning.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DVec2, Vec2, Vec3};

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

/// Parses the numbers of a statement: at least `min`, all finite.
fn numbers(
    args: &str,
    min: usize,
    what: &str,
    path: &Path,
    line: usize,
) -> Result<Vec<f32>, SceneError> {
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
        .iter()
        .map(|a| match a.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(x),
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

/// A part being built: the faces between two `o`/`g`/`usemtl` changes.
struct PartBuilder {
    name: String,
    /// `usemtl` name and line.
    material: Option<(String, usize)>,
    corners: Vec<Corner>,
    index_of: HashMap<Corner, u32>,
    triangles: Vec<[u32; 3]>,
    /// Lines of faces without texture coordinates.
    faces_without_vt: Vec<usize>,
    any_vt: bool,
    any_vn: bool,
}

impl PartBuilder {
    fn new(name: String, material: Option<(String, usize)>) -> Self {
        Self {
            name,
            material,
            corners: Vec::new(),
            index_of: HashMap::new(),
            triangles: Vec::new(),
            faces_without_vt: Vec::new(),
            any_vt: false,
            any_vn: false,
        }
    }

    fn vertex(&mut self, c: Corner) -> u32 {
        *self.index_of.entry(c).or_insert_with(|| {
            self.corners.push(c);
            (self.corners.len() - 1) as u32
        })
    }
}

/// An OBJ file parsed, before its materials are resolved.
struct ParsedObj {
    parts: Vec<PartBuilder>,
    /// Material libraries and the line naming each (first mention).
    libraries: Vec<(PathBuf, usize)>,
    positions: Vec<Vec3>,
    texcoords: Vec<Vec2>,
    normals: Vec<Vec3>,
}

const UNNAMED: &str = "unnamed_object";

fn parse_obj(bytes: &[u8], path: &Path, report: &mut LoadReport) -> Result<ParsedObj, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut obj = ParsedObj {
        parts: Vec::new(),
        libraries: Vec::new(),
        positions: Vec::new(),
        texcoords: Vec::new(),
        normals: Vec::new(),
    };
    let mut part = PartBuilder::new(UNNAMED.into(), None);
    for (line, text) in text_lines(bytes, path)? {
        let Some((key, args)) = keyword(text) else {
            continue;
        };
        match key {
            "v" => {
                let v = numbers(args, 3, "vertex position (v)", path, line)?;
                obj.positions.push(Vec3::new(v[0], v[1], v[2]));
            }
            "vt" => {
                let v = numbers(args, 1, "texture coordinate (vt)", path, line)?;
                obj.texcoords
                    .push(Vec2::new(v[0], v.get(1).copied().unwrap_or(0.0)));
            }
            "vn" => {
                let v = numbers(args, 3, "normal (vn)", path, line)?;
                obj.normals.push(Vec3::new(v[0], v[1], v[2]));
            }
            "f" => {
                let words: Vec<&str> = args.split_whitespace().collect();
                if words.len() < 3 {
                    report.warn(
                        WarningKind::ShortFace,
                        path,
                        Some(line),
                        "face (f) with fewer than 3 vertices skipped",
                    );
                    continue;
                }
                let counts = [obj.positions.len(), obj.texcoords.len(), obj.normals.len()];
                let corners = words
                    .iter()
                    .map(|a| corner(a, counts, path, line))
                    .collect::<Result<Vec<_>, _>>()?;
                let points: Vec<Vec3> = corners
                    .iter()
                    .map(|c| obj.positions[c.0 as usize])
                    .collect();
                let triangles = triangulate(&points).map_err(|r| obj_err(path, line, r))?;
                if corners.iter().all(|c| c.1.is_none()) {
                    part.faces_without_vt.push(line);
                } else {
                    part.any_vt = true;
                }
                part.any_vn |= corners.iter().any(|c| c.2.is_some());
                for t in triangles {
                    let t = t.map(|k| part.vertex(corners[k]));
                    part.triangles.push(t);
                }
            }
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
            "o" | "g" => {
                let name = if args.is_empty() { UNNAMED } else { args };
                let material = part.material.clone();
                let done = std::mem::replace(&mut part, PartBuilder::new(name.into(), material));
                if !done.triangles.is_empty() {
                    obj.parts.push(done);
                }
            }
            "usemtl" => {
                if args.is_empty() {
                    return Err(obj_err(path, line, "usemtl needs a material name"));
                }
                if part.material.as_ref().map(|m| m.0.as_str()) != Some(args) {
                    let name = part.name.clone();
                    let material = Some((args.to_string(), line));
                    let done = std::mem::replace(&mut part, PartBuilder::new(name, material));
                    if !done.triangles.is_empty() {
                        obj.parts.push(done);
                    }
                }
            }
            "mtllib" => {
                if args.is_empty() {
                    return Err(obj_err(path, line, "mtllib needs a file name"));
                }
                // One name with spaces, or several names.
                let files: Vec<&str> = if dir.join(args).is_file() {
                    vec![args]
                } else {
                    args.split_whitespace().collect()
                };
                for f in files {
                    let mtl = dir.join(f);
                    if !mtl.is_file() {
                        return Err(obj_err(
                            path,
                            line,
                            format!("material library '{}' not found", mtl.display()),
                        ));
                    }
                    if !obj.libraries.iter().any(|(p, _)| *p == mtl) {
                        obj.libraries.push((mtl, line));
                    }
                }
            }
            _ => {}
        }
    }
    if !part.triangles.is_empty() {
        obj.parts.push(part);
    }
    Ok(obj)
}

/// One `newmtl` of an MTL file.
struct MtlEntry {
    name: String,
    line: usize,
    diffuse: Vec3,
    /// `map_Kd` file name (relative to the MTL file) and its line.
    map: Option<(String, usize)>,
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

fn parse_mtl(
    bytes: &[u8],
    path: &Path,
    report: &mut LoadReport,
) -> Result<Vec<MtlEntry>, SceneError> {
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
                name: args.to_string(),
                line,
                diffuse: Vec3::splat(0.8),
                map: None,
            });
            continue;
        }
        if key != "Kd" && key != "map_Kd" {
            continue;
        }
        let Some(current) = out.last_mut() else {
            return Err(obj_err(path, line, format!("{key} before any newmtl")));
        };
        if key == "Kd" {
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
            current.diffuse = match v[..] {
                [g] => Vec3::splat(g),
                [r, g, b] => Vec3::new(r, g, b),
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
            };
        } else {
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
            current.map = Some((file, line));
        }
    }
    Ok(out)
}

/// Turns a parsed part into a [`MeshPart`], applying the hygiene rules. Returns the part and
/// the number of degenerate triangles dropped.
fn finish_part(
    obj: &ParsedObj,
    part: &PartBuilder,
    material: u32,
    path: &Path,
    report: &mut LoadReport,
) -> (MeshPart, usize) {
    let positions: Vec<Vec3> = part
        .corners
        .iter()
        .map(|c| obj.positions[c.0 as usize])
        .collect();
    let uvs: Vec<Vec2> = if part.any_vt {
        for &line in &part.faces_without_vt {
            report.warn(
                WarningKind::MissingTexcoords,
                path,
                Some(line),
                format!(
                    "face without texture coordinates in textured part '{}': its corners get uv (0, 0)",
                    part.name
                ),
            );
        }
        part.corners
            .iter()
            .map(|c| c.1.map_or(Vec2::ZERO, |t| obj.texcoords[t as usize]))
            .collect()
    } else {
        Vec::new()
    };
    let mut triangles = Vec::with_capacity(part.triangles.len());
    let mut dropped = 0;
    for &t in &part.triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let area2 = (b - a).cross(c - a).length_squared();
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area2 == 0.0 || !area2.is_finite() {
            dropped += 1;
        } else {
            triangles.push(t);
        }
    }
    // Corners without a normal get a zero one here, replaced by the computed normal below.
    let given: Vec<Vec3> = if part.any_vn {
        part.corners
            .iter()
            .map(|c| c.2.map_or(Vec3::ZERO, |n| obj.normals[n as usize]))
            .collect()
    } else {
        Vec::new()
    };
    // Normals already of unit length (to f32 precision) are kept bit for bit.
    let unit = |n: Vec3| {
        if (n.length_squared() - 1.0).abs() < 1e-6 {
            n
        } else {
            n.normalize()
        }
    };
    let normals = if given.is_empty() {
        smooth_normals(&positions, &triangles)
    } else if given.iter().any(|n| n.length_squared() == 0.0) {
        let smooth = smooth_normals(&positions, &triangles);
        given
            .iter()
            .zip(smooth)
            .map(|(&n, s)| {
                if n.length_squared() == 0.0 {
                    s
                } else {
                    unit(n)
                }
            })
            .collect()
    } else {
        given.iter().map(|&n| unit(n)).collect()
    };
    (
        MeshPart {
            name: part.name.clone(),
            positions,
            normals,
            uvs,
            triangles,
            material,
        },
        dropped,
    )
}

/// Parses OBJ text without materials (used for the embedded teapot). Every part gets
/// material 0; hygiene is applied. Returns the parts and the number of degenerate triangles
/// dropped.
pub(crate) fn parse_obj_str(text: &str, path: &Path) -> Result<(Vec<MeshPart>, usize), SceneError> {
    let mut report = LoadReport::default();
    let obj = parse_obj(text.as_bytes(), path, &mut report)?;
    let mut dropped = 0;
    let parts = obj
        .parts
        .iter()
        .map(|p| {
            let (part, d) = finish_part(&obj, p, 0, path, &mut report);
            dropped += d;
            part
        })
        .filter(|p| !p.triangles.is_empty())
        .collect();
    Ok((parts, dropped))
}

/// Loads an OBJ file with its MTL materials and `map_Kd` textures; warnings go to `report`.
pub(crate) fn load_obj_file(path: &Path, report: &mut LoadReport) -> Result<LoadedObj, SceneError> {
    let bytes = read_input(path)?;
    let obj = parse_obj(&bytes, path, report)?;

    let mut out = LoadedObj {
        parts: Vec::new(),
        materials: Vec::new(),
        textures: Vec::new(),
    };
    // Material name -> index in `out.materials`; a later definition replaces an earlier one.
    let mut by_name: HashMap<String, (u32, PathBuf, usize)> = HashMap::new();
    let mut texture_ids: HashMap<PathBuf, u32> = HashMap::new();
    for (mtl_path, _) in &obj.libraries {
        let bytes = read_input(mtl_path)?;
        for m in parse_mtl(&bytes, mtl_path, report)? {
            let texture = match &m.map {
                None => None,
                Some((t, _)) => {
                    let tex_path = mtl_path.parent().unwrap_or(Path::new(".")).join(t);
                    if let Some(&id) = texture_ids.get(&tex_path) {
                        Some(id)
                    } else {
                        let tex =
                            load_texture(&tex_path).map_err(|reason| SceneError::Texture {
                                mtl: mtl_path.clone(),
                                material: m.name.clone(),
                                texture: tex_path.clone(),
                                reason,
                            })?;
                        out.textures.push(tex);
                        let id = (out.textures.len() - 1) as u32;
                        texture_ids.insert(tex_path, id);
                        Some(id)
                    }
                }
            };
            out.materials.push(Material {
                name: m.name.clone(),
                diffuse: m.diffuse,
                texture,
            });
            let id = (out.materials.len() - 1) as u32;
            if let Some((_, first, first_line)) =
                by_name.insert(m.name.clone(), (id, mtl_path.clone(), m.line))
            {
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
        }
    }

    let mut dropped = 0;
    let mut default_material = None;
    for part in &obj.parts {
        let found = match &part.material {
            None => None,
            Some((name, line)) => {
                let found = by_name.get(name).map(|m| m.0);
                if found.is_none() {
                    if obj.libraries.is_empty() {
                        report.warn(
                            WarningKind::NoMaterialLibrary,
                            path,
                            Some(*line),
                            format!(
                                "usemtl '{name}' in a file without mtllib: the default material is used"
                            ),
                        );
                    } else {
                        report.warn(
                            WarningKind::UndefinedMaterial,
                            path,
                            Some(*line),
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
                found
            }
        };
        let material = match found {
            Some(id) => id,
            None => *default_material.get_or_insert_with(|| {
                out.materials.push(Material {
                    name: "default".into(),
                    diffuse: Vec3::splat(0.8),
                    texture: None,
                });
                (out.materials.len() - 1) as u32
            }),
        };
        let (p, d) = finish_part(&obj, part, material, path, report);
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
    let mut sum = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            sum[rep[i as usize]] += n;
        }
    }
    rep.iter()
        .map(|&r| sum[r].try_normalize().unwrap_or(Vec3::Y))
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
        // Convex polygons are fanned from corner 0, as before (the same triangles as tobj).
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

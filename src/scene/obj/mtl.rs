//! MTL files: the validation pass ([`validate_mtl`]) and the normalised text it writes for
//! `tobj`, the libraries of an OBJ file read in order, and `tobj`'s materials with their
//! `map_Kd` textures.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::lexer::{keyword, numbers, obj_err, read_input, text_lines};
use super::obj_pass::ObjPass;
use super::{LoadedObj, find_beside};
use crate::scene::report::{LoadReport, WarningKind};
use crate::scene::{MAX_COLOUR, Material, SceneError, Texture};

/// How far below 0 a `Kd` component may lie and be taken as 0 (an exporter's float noise);
/// below that it is an error.
const KD_NOISE: f32 = 1e-3;

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
        let Some((written, args)) = keyword(text) else {
            continue;
        };
        // Keywords in any letter case (`KD`, `map_kd`), as Blender's and three.js's readers
        // take them; messages name them in the MTL format's case.
        let Some(key) = ["newmtl", "Kd", "map_Kd", "Ns"]
            .into_iter()
            .find(|k| k.eq_ignore_ascii_case(written))
        else {
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
        let Some(current) = out.last_mut() else {
            report.warn(
                WarningKind::LenientMaterial,
                path,
                Some(line),
                format!("{key} before any newmtl ignored"),
            );
            continue;
        };
        if key == "Ns" {
            current.shininess = specular_exponent(args, current.name, path, line, report);
        } else if key == "Kd" {
            if let Some(kd) = diffuse_colour(args, current.name, path, line, report)? {
                current.diffuse = Some(kd);
            }
        } else {
            current.map = map_kd_file(args, current.name, path, line, report);
        }
    }
    Ok(out)
}

/// A `Kd` statement's colour (one grey or r g b), for material `name`; `None` for a colour form
/// that is not supported (`spectral`, `xyz`: the default stays, with a warning). Leniencies
/// (RGBA, float noise below 0, values above 1) are warnings naming the line; a value outside
/// `[0, MAX_COLOUR]` or another count is an error naming it.
fn diffuse_colour<'a>(
    args: &'a str,
    name: &str,
    path: &Path,
    line: usize,
    report: &mut LoadReport,
) -> Result<Option<[&'a str; 3]>, SceneError> {
    let first = args.split_whitespace().next().unwrap_or("");
    if first == "spectral" || first == "xyz" {
        report.warn(
            WarningKind::UnsupportedColour,
            path,
            Some(line),
            format!("'Kd {first}' is not supported: material '{name}' keeps grey 0.8"),
        );
        return Ok(None);
    }
    let mut v = numbers(args, 1, "diffuse colour (Kd)", path, line)?;
    if v.len() == 4 {
        report.warn(
            WarningKind::LenientMaterial,
            path,
            Some(line),
            format!("Kd of four numbers (RGBA): material '{name}' drops the alpha"),
        );
        v.truncate(3);
    }
    for a in &mut v {
        // Float noise below 0 (an exporter's -0.000001) is 0.
        let x: f32 = a.parse().unwrap_or(f32::NAN);
        if (-KD_NOISE..0.0).contains(&x) {
            report.warn(
                WarningKind::LenientMaterial,
                path,
                Some(line),
                format!("Kd of {a} taken as 0 (material '{name}')"),
            );
            *a = "0";
        }
    }
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
    // Above 1 a surface sends back more light than reaches it: kept (light sources and
    // HDR set-ups write them), but named, since 8-bit values (`Kd 255 128 0`) render white.
    if let Some(a) = v.iter().find(|a| a.parse::<f32>().is_ok_and(|x| x > 1.0)) {
        report.warn(
            WarningKind::LenientMaterial,
            path,
            Some(line),
            format!(
                "Kd of {a}, above 1: material '{name}' sends back more light than reaches it \
                 (MTL colours run from 0 to 1; 8-bit values need dividing by 255)"
            ),
        );
    }
    Ok(Some(match v[..] {
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
    }))
}

/// A `map_Kd` statement's texture file ([`find_beside`]), relative to the MTL's folder, its
/// options skipped with a warning; a missing file is a warning and `None` (the material keeps
/// its `Kd`), and so is a `map_Kd` without a file name. Where the words after the options that
/// [`map_option_arguments`] knows name no file, the shorter tails of the line are tried (an
/// option it does not know, such as `-colorspace sRGB`, takes words of its own).
fn map_kd_file(
    args: &str,
    material: &str,
    path: &Path,
    line: usize,
    report: &mut LoadReport,
) -> Option<String> {
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
        report.warn(
            WarningKind::LenientMaterial,
            path,
            Some(line),
            format!("map_Kd without a file name ignored (material '{material}')"),
        );
        return None;
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let tails = (k + 1..words.len())
        .filter(|_| options)
        .map(|j| words[j..].join(" "));
    let Some(found) = std::iter::once(file.clone())
        .chain(tails)
        .find_map(|f| find_beside(dir, &f))
    else {
        report.warn(
            WarningKind::MissingTexture,
            path,
            Some(line),
            format!(
                "texture '{file}' of material '{material}' not found beside {}: the material \
                 uses its Kd",
                path.display()
            ),
        );
        return None;
    };
    Some(
        found
            .strip_prefix(dir)
            .map_or(found.clone(), Path::to_path_buf)
            .to_string_lossy()
            .into_owned(),
    )
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

/// Each material library of `obj` read, checked and normalised for `tobj`; with the MTL file of
/// each of tobj's materials, in order. A material defined again is warned about (the later one
/// is used).
pub(super) fn read_libraries<'a>(
    obj: &'a ObjPass,
    report: &mut LoadReport,
) -> Result<(Vec<String>, Vec<&'a Path>), SceneError> {
    let mut mtl_texts = Vec::with_capacity(obj.libraries.len());
    let mut origin: Vec<&Path> = Vec::new();
    let mut previous: HashMap<String, (PathBuf, usize)> = HashMap::new();
    for (mtl_path, _) in &obj.libraries {
        let bytes = read_input(mtl_path, report)?;
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
pub(super) fn load_materials(
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
            // Without `Kd`, a texture shows as it is (as Blender's and three.js's importers
            // read it), a plain material is the default grey.
            diffuse: m.diffuse.map_or(
                if texture.is_some() {
                    Vec3::ONE
                } else {
                    Vec3::splat(0.8)
                },
                Vec3::from_array,
            ),
            texture,
            // As read; the scene file decides whether a reflector honours it (`merge`).
            specular_power: m.shininess,
        });
    }
}

/// Decodes a texture, its format told by its first bytes (exporters and downloads name JPEG
/// files `.png` and the like), else by its extension.
fn load_texture(path: &Path) -> Result<Texture, String> {
    let img = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| e.to_string())?
        .decode()
        .map_err(|e| e.to_string())?
        .to_rgba8();
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

#[cfg(test)]
mod tests {
    use super::*;

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
}

//! OBJ/MTL loading (through `tobj`) and mesh hygiene.
//!
//! Before `tobj` parses a file, a line scanner checks what `tobj` would not report by line:
//! numbers that do not parse or are not finite (NaN, inf), face indices out of range, and a
//! missing `mtllib`. Every such error names the file and the line.
//!
//! Hygiene on load, per part:
//! - missing normals are computed: bit-identical positions are welded first (the teapot repeats
//!   263 positions along its patch seams), then area-weighted face normals are summed per welded
//!   vertex; zero-length normals in the file are replaced the same way;
//! - degenerate triangles (a repeated index, or zero area) are dropped and counted in the log.

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::{Material, MeshPart, SceneError, Texture};

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

/// Checks numbers, face indices and `mtllib` references line by line (see the module docs).
fn scan(text: &str, path: &Path) -> Result<(), SceneError> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let body = raw.split('#').next().unwrap_or("").trim();
        let mut words = body.split_whitespace();
        let Some(key) = words.next() else { continue };
        let args: Vec<&str> = words.collect();
        let numbers = |min: usize, what: &str| -> Result<(), SceneError> {
            if args.len() < min {
                return Err(obj_err(
                    path,
                    line,
                    format!("{what} needs {min} numbers, found {}: '{raw}'", args.len()),
                ));
            }
            for a in &args {
                match a.parse::<f32>() {
                    Ok(x) if x.is_finite() => {}
                    Ok(_) => {
                        return Err(obj_err(
                            path,
                            line,
                            format!("{what} has a non-finite value '{a}'"),
                        ));
                    }
                    Err(_) => {
                        return Err(obj_err(
                            path,
                            line,
                            format!("{what}: '{a}' is not a number"),
                        ));
                    }
                }
            }
            Ok(())
        };
        match key {
            "v" => {
                numbers(3, "vertex position (v)")?;
                nv += 1;
            }
            "vt" => {
                numbers(1, "texture coordinate (vt)")?;
                nvt += 1;
            }
            "vn" => {
                numbers(3, "normal (vn)")?;
                nvn += 1;
            }
            "f" => {
                if args.len() < 3 {
                    return Err(obj_err(path, line, "a face (f) needs at least 3 vertices"));
                }
                for a in &args {
                    let fields: Vec<&str> = a.split('/').collect();
                    if fields.len() > 3 || fields[0].is_empty() {
                        return Err(obj_err(path, line, format!("malformed face vertex '{a}'")));
                    }
                    for (slot, (f, count, what)) in fields
                        .iter()
                        .zip([
                            (nv, "position"),
                            (nvt, "texture coordinate"),
                            (nvn, "normal"),
                        ])
                        .map(|(f, (c, w))| (f, c, w))
                        .enumerate()
                    {
                        if f.is_empty() && slot > 0 {
                            continue;
                        }
                        let i: i64 = f.parse().map_err(|_| {
                            obj_err(path, line, format!("malformed face vertex '{a}'"))
                        })?;
                        let resolved = if i < 0 { count + i + 1 } else { i };
                        if i == 0 || resolved < 1 || resolved > count {
                            return Err(obj_err(
                                path,
                                line,
                                format!(
                                    "face refers to {what} {i}, but only {count} are defined so far"
                                ),
                            ));
                        }
                    }
                }
            }
            "mtllib" => {
                for a in &args {
                    let mtl = path.parent().unwrap_or(Path::new(".")).join(a);
                    if !mtl.is_file() {
                        return Err(obj_err(
                            path,
                            line,
                            format!("material library '{}' not found", mtl.display()),
                        ));
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

// Other tobj features add fields to `LoadOptions`; keep their defaults whatever is enabled.
#[allow(clippy::needless_update)]
fn load_options() -> tobj::LoadOptions {
    tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    }
}

/// Parses OBJ text without materials (used for the embedded teapot). Every part gets
/// material 0; hygiene is applied.
pub(crate) fn parse_obj_str(text: &str, path: &Path) -> Result<(Vec<MeshPart>, usize), SceneError> {
    scan(text, path)?;
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &load_options(), |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| SceneError::Mtl {
        path: path.to_path_buf(),
        reason: format!("OBJ parse error: {e}"),
    })?;
    let mut dropped = 0;
    let parts = models
        .into_iter()
        .map(|m| {
            let (p, d) = part_from_model(&m, 0);
            dropped += d;
            p
        })
        .filter(|p| !p.triangles.is_empty())
        .collect();
    Ok((parts, dropped))
}

/// Loads an OBJ file with its MTL materials and `map_Kd` textures.
pub(crate) fn load_obj_file(path: &Path) -> Result<LoadedObj, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(path, e))?;
    scan(&text, path)?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    // Remember which MTL file each material came from, for error messages and texture paths.
    let origins: RefCell<Vec<(PathBuf, Vec<String>)>> = RefCell::new(Vec::new());
    let mtl_error: RefCell<Option<SceneError>> = RefCell::new(None);
    let (models, materials) = tobj::load_obj_buf(&mut text.as_bytes(), &load_options(), |p| {
        let mtl = dir.join(p);
        let parsed = std::fs::File::open(&mtl)
            .map_err(|e| SceneError::io(&mtl, e))
            .and_then(|f| {
                tobj::load_mtl_buf(&mut std::io::BufReader::new(f)).map_err(|e| SceneError::Mtl {
                    path: mtl.clone(),
                    reason: format!("malformed material library: {e}"),
                })
            });
        match parsed {
            Ok((mats, map)) => {
                origins
                    .borrow_mut()
                    .push((mtl.clone(), mats.iter().map(|m| m.name.clone()).collect()));
                Ok((mats, map))
            }
            Err(e) => {
                mtl_error.borrow_mut().get_or_insert(e);
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    })
    .map_err(|e| SceneError::Mtl {
        path: path.to_path_buf(),
        reason: format!("OBJ parse error: {e}"),
    })?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let materials = materials.map_err(|e| SceneError::Mtl {
        path: path.to_path_buf(),
        reason: format!("material library: {e}"),
    })?;
    let origins = origins.into_inner();
    let origin_of = |name: &str| -> PathBuf {
        origins
            .iter()
            .find(|(_, names)| names.iter().any(|n| n == name))
            .map(|(p, _)| p.clone())
            .unwrap_or_else(|| path.to_path_buf())
    };

    let mut out = LoadedObj {
        parts: Vec::new(),
        materials: Vec::new(),
        textures: Vec::new(),
    };
    let mut texture_ids: HashMap<PathBuf, u32> = HashMap::new();
    for m in &materials {
        let mtl_path = origin_of(&m.name);
        let texture = match &m.diffuse_texture {
            None => None,
            Some(t) => {
                let tex_path = mtl_path.parent().unwrap_or(Path::new(".")).join(t);
                if let Some(&id) = texture_ids.get(&tex_path) {
                    Some(id)
                } else {
                    let tex = load_texture(&tex_path).map_err(|reason| SceneError::Texture {
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
        let kd = m.diffuse.unwrap_or([0.8; 3]);
        if kd.iter().any(|c| !c.is_finite()) {
            return Err(SceneError::Mtl {
                path: mtl_path,
                reason: format!("material '{}': Kd is not finite", m.name),
            });
        }
        out.materials.push(Material {
            name: m.name.clone(),
            diffuse: Vec3::from_array(kd),
            texture,
        });
    }
    let mut dropped = 0;
    let mut default_material = None;
    for model in &models {
        let material = match model.mesh.material_id {
            Some(id) if id < out.materials.len() => id as u32,
            _ => *default_material.get_or_insert_with(|| {
                out.materials.push(Material {
                    name: "default".into(),
                    diffuse: Vec3::splat(0.8),
                    texture: None,
                });
                (out.materials.len() - 1) as u32
            }),
        };
        let (part, d) = part_from_model(model, material);
        dropped += d;
        if !part.triangles.is_empty() {
            out.parts.push(part);
        }
    }
    if dropped > 0 {
        log::warn!("{}: dropped {dropped} degenerate triangles", path.display());
    }
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

/// Converts one `tobj` model, applying the hygiene rules. Returns the part and the number of
/// degenerate triangles dropped.
fn part_from_model(model: &tobj::Model, material: u32) -> (MeshPart, usize) {
    let m = &model.mesh;
    let positions: Vec<Vec3> = m
        .positions
        .chunks_exact(3)
        .map(|p| Vec3::new(p[0], p[1], p[2]))
        .collect();
    let uvs: Vec<Vec2> = if m.texcoords.len() == 2 * positions.len() {
        m.texcoords
            .chunks_exact(2)
            .map(|t| Vec2::new(t[0], t[1]))
            .collect()
    } else {
        Vec::new()
    };
    let mut triangles = Vec::with_capacity(m.indices.len() / 3);
    let mut dropped = 0;
    for t in m.indices.chunks_exact(3) {
        let t = [t[0], t[1], t[2]];
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let area2 = (b - a).cross(c - a).length_squared();
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area2 == 0.0 || !area2.is_finite() {
            dropped += 1;
        } else {
            triangles.push(t);
        }
    }
    let given: Vec<Vec3> = if m.normals.len() == 3 * positions.len() {
        m.normals
            .chunks_exact(3)
            .map(|n| Vec3::new(n[0], n[1], n[2]))
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
            name: model.name.clone(),
            positions,
            normals,
            uvs,
            triangles,
            material,
        },
        dropped,
    )
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
        let e = scan("v 0 0 0\nv 1 0 nan\n", p).unwrap_err().to_string();
        assert!(e.contains("x.obj:2"), "{e}");
        let e = scan("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.obj:4"), "{e}");
        assert!(scan("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -1\n", p).is_ok());
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
}

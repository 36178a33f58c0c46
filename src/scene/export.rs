//! Writes a scene out as `scene.toml` plus one OBJ per mesh, one MTL and PNG textures. Floats
//! are written in Rust's shortest round-trip form, so loading the export gives back the same
//! numbers bit for bit (tests/scene/scene_export.rs renders every built-in and its export and finds
//! the frames byte-identical).
//!
//! Each file is written atomically (a temporary file renamed into place), `scene.toml` last, so
//! an interrupted export leaves no `scene.toml` naming a file not yet written. Every text file
//! starts with a comment holding [`MARK`]; [`exported_files`] finds an earlier export's files by
//! it, so that `scene export --force` can remove them and nothing else.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use toml::Spanned;

use super::animation::Animation;
use super::file::{
    AnimationFile, CameraFile, CameraKeyFile, CameraTrackFile, CmoFile, FilmFile, MeshFile,
    MeshKeyFile, MeshTrackFile, ReflectorFile, ScaleFile, SceneFile, SelfReflectionsFile,
    ShadingFile, ShadingModel, SpecularPowerFile, TransformFile,
};
use super::{CmoPlacement, CmoSpec, MeshInstance, Scene, SelfReflections};
use crate::camera::Camera;
use crate::files::{safe_file_stem as safe, write_atomic};
use crate::shading::Shading;

/// In the first line of every text file an export writes (`scene.toml`, the OBJs, the MTL).
pub const MARK: &str = "cubetrace scene export";

fn sp<T>(v: T) -> Spanned<T> {
    Spanned::new(0..0, v)
}

/// Unique, file-safe names for a list.
fn unique(names: impl Iterator<Item = String>) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for n in names {
        let base = safe(&n);
        let mut name = base.clone();
        let mut k = 2;
        while out.contains(&name) {
            name = format!("{base}-{k}");
            k += 1;
        }
        out.push(name);
    }
    out
}

/// Exports `scene` into `dir` (created if needed). Returns the path of the TOML file.
pub fn export(scene: &Scene, dir: &Path) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
    let tex_names = write_textures(scene, dir)?;
    let mat_names = write_materials(scene, dir, &tex_names)?;
    let mesh_names = unique(scene.meshes.iter().map(|m| m.name.clone()));
    let mut meshes = Vec::new();
    for (mesh, name) in scene.meshes.iter().zip(&mesh_names) {
        let file = format!("{name}.obj");
        write_atomic(&dir.join(&file), obj_text(mesh, &mat_names)?.as_bytes())?;
        meshes.push(mesh_file(scene, mesh, file));
    }
    let file = SceneFile {
        name: Some(scene.name.clone()),
        background: sp(scene.background.to_array()),
        self_reflections: Some(sp(match scene.self_reflections {
            SelfReflections::Auto => SelfReflectionsFile::Word("auto".into()),
            SelfReflections::On => SelfReflectionsFile::Bool(true),
            SelfReflections::Off => SelfReflectionsFile::Bool(false),
        })),
        shading: shading_file(scene.shading),
        meshes,
        cameras: scene.cameras.iter().map(camera_file).collect(),
        cmo: Some(cmo_file(&scene.cmo)),
        film: film_file(scene),
        animation: animation_file(scene),
    };
    let toml_text = format!(
        "# cubetrace scene '{}', written by `{MARK}`.\n{}",
        scene.name,
        toml::to_string(&file)?
    );
    let path = dir.join("scene.toml");
    write_atomic(&path, toml_text.as_bytes())?;
    Ok(path)
}

/// Writes each texture as `NAME.png`; returns the names, in texture order.
fn write_textures(scene: &Scene, dir: &Path) -> anyhow::Result<Vec<String>> {
    let tex_names = unique(scene.textures.iter().map(|t| t.name.clone()));
    for (t, name) in scene.textures.iter().zip(&tex_names) {
        let mut png = Vec::new();
        image::write_buffer_with_format(
            &mut std::io::Cursor::new(&mut png),
            &t.rgba8,
            t.width,
            t.height,
            image::ExtendedColorType::Rgba8,
            image::ImageFormat::Png,
        )?;
        write_atomic(&dir.join(format!("{name}.png")), &png)?;
    }
    Ok(tex_names)
}

/// Writes `materials.mtl`; returns the material names, in material order.
fn write_materials(scene: &Scene, dir: &Path, tex_names: &[String]) -> anyhow::Result<Vec<String>> {
    let mat_names = unique(scene.materials.iter().map(|m| m.name.clone()));
    let mut mtl = format!("# Written by {MARK}. Kd is linear RGB.\n");
    for (m, name) in scene.materials.iter().zip(&mat_names) {
        let d = m.diffuse;
        writeln!(mtl, "\nnewmtl {name}\nKd {} {} {}", d.x, d.y, d.z)?;
        if let Some(t) = m.texture {
            writeln!(mtl, "map_Kd {}.png", tex_names[t as usize])?;
        }
        if let Some(p) = crate::lobe::glossy(m.specular_power) {
            writeln!(mtl, "Ns {p}")?;
        }
    }
    write_atomic(&dir.join("materials.mtl"), mtl.as_bytes())?;
    Ok(mat_names)
}

/// A mesh as OBJ text in object space, one `o` per part.
fn obj_text(mesh: &MeshInstance, mat_names: &[String]) -> Result<String, std::fmt::Error> {
    let mut obj = format!("# Written by {MARK} (object space).\nmtllib materials.mtl\n");
    let mut base = 1;
    // Vertex colours are all or none per file (the loader's rule): white where a part has none.
    let coloured = mesh.parts.iter().any(|p| !p.colours.is_empty());
    for part in &mesh.parts {
        writeln!(obj, "o {}", safe(&part.name))?;
        writeln!(obj, "usemtl {}", mat_names[part.material as usize])?;
        for (k, p) in part.positions.iter().enumerate() {
            write!(obj, "v {} {} {}", p.x, p.y, p.z)?;
            if coloured {
                let c = part.colours.get(k).copied().unwrap_or(glam::Vec3::ONE);
                write!(obj, " {} {} {}", c.x, c.y, c.z)?;
            }
            writeln!(obj)?;
        }
        for n in &part.normals {
            writeln!(obj, "vn {} {} {}", n.x, n.y, n.z)?;
        }
        for t in &part.uvs {
            writeln!(obj, "vt {} {}", t.x, t.y)?;
        }
        for tri in &part.triangles {
            obj.push('f');
            for &i in tri {
                let i = i as usize + base;
                if part.uvs.is_empty() {
                    write!(obj, " {i}//{i}")?;
                } else {
                    write!(obj, " {i}/{i}/{i}")?;
                }
            }
            obj.push('\n');
        }
        base += part.positions.len();
    }
    Ok(obj)
}

/// The `[[mesh]]` entry of a mesh written to `file`: a glossy reflector (a part whose material
/// has a specular power below the mirror cap) takes its powers from the MTL's `Ns`.
fn mesh_file(scene: &Scene, mesh: &MeshInstance, file: String) -> MeshFile {
    let t = &mesh.transform;
    let glossy = mesh.reflector
        && (mesh.parts.iter()).any(|p| {
            crate::lobe::glossy(scene.materials[p.material as usize].specular_power).is_some()
        });
    MeshFile {
        name: Some(sp(mesh.name.clone())),
        obj: sp(PathBuf::from(file)),
        reflector: sp(ReflectorFile::Whole(mesh.reflector)),
        specular_power: glossy.then(|| sp(SpecularPowerFile::Word("mtl".into()))),
        transform: TransformFile {
            translate: sp(t.translate.to_array()),
            rotate_deg: sp(t.rotate_deg.to_array()),
            scale: sp(if t.scale.x == t.scale.y && t.scale.y == t.scale.z {
                ScaleFile::Uniform(t.scale.x)
            } else {
                ScaleFile::PerAxis(t.scale.to_array())
            }),
        },
    }
}

fn shading_file(shading: Shading) -> ShadingFile {
    match shading {
        Shading::Unlit => ShadingFile {
            model: ShadingModel::Unlit,
            ..ShadingFile::default()
        },
        Shading::Lambert {
            ambient,
            light_direction,
            light_intensity,
        } => ShadingFile {
            model: ShadingModel::Lambert,
            ambient: Some(sp(ambient)),
            light_direction: Some(sp(light_direction.to_array())),
            light_intensity: Some(sp(light_intensity)),
        },
    }
}

fn camera_file(c: &Camera) -> CameraFile {
    CameraFile {
        name: Some(sp(c.name.clone())),
        eye: sp(c.eye.to_array()),
        target: sp(c.target.to_array()),
        up: sp(c.up.to_array()),
        fov_y_deg: sp(c.fov_y_deg),
        resolution: sp([c.width, c.height]),
    }
}

/// `[film]`, left out when it is the default (one sample, box filter).
fn film_file(scene: &Scene) -> Option<FilmFile> {
    let film = scene.film;
    (film != crate::film::FilmSettings::default()).then(|| FilmFile {
        spp: Some(sp(film.spp)),
        filter: Some(sp(match film.filter {
            crate::film::PixelFilter::Box => "box".to_string(),
            crate::film::PixelFilter::Gaussian => "gaussian".to_string(),
        })),
    })
}

/// `[animation]`, left out when it is the default (a still); cameras and meshes by name.
fn animation_file(scene: &Scene) -> Option<AnimationFile> {
    let a = &scene.animation;
    if *a == Animation::default() {
        return None;
    }
    let arr = |v: Option<glam::Vec3>| v.map(|v| sp(v.to_array()));
    let cameras = (a.cameras.iter())
        .map(|t| {
            sp(CameraTrackFile {
                camera: Some(sp(scene.cameras[t.camera].name.clone())),
                keys: (t.keys.iter())
                    .map(|k| {
                        sp(CameraKeyFile {
                            time: Some(sp(k.time)),
                            eye: arr(k.eye),
                            target: arr(k.target),
                            up: arr(k.up),
                            fov_y_deg: k.fov_y_deg.map(sp),
                        })
                    })
                    .collect(),
            })
        })
        .collect();
    let meshes = (a.meshes.iter())
        .map(|t| {
            sp(MeshTrackFile {
                mesh: sp(scene.meshes[t.mesh].name.clone()),
                keys: (t.keys.iter())
                    .map(|k| {
                        sp(MeshKeyFile {
                            time: Some(sp(k.time)),
                            translate: arr(k.translate),
                            rotate_deg: arr(k.rotate_deg),
                            scale: k.scale.map(|s| sp(ScaleFile::PerAxis(s.to_array()))),
                        })
                    })
                    .collect(),
            })
        })
        .collect();
    Some(AnimationFile {
        fps: Some(sp(a.fps)),
        frames: a.frames.map(sp),
        interpolation: Some(sp(a.interpolation.name().to_string())),
        cameras,
        meshes,
    })
}

fn cmo_file(cmo: &CmoSpec) -> CmoFile {
    let (centres, count, placement) = match &cmo.placement {
        CmoPlacement::Explicit(c) => (
            Some(sp(c.iter().map(|v| v.to_array()).collect())),
            None,
            None,
        ),
        CmoPlacement::Auto { count } => (None, Some(sp(*count)), Some(sp("axis".to_string()))),
        CmoPlacement::Search { count } => (None, Some(sp(*count)), Some(sp("auto".to_string()))),
    };
    CmoFile {
        centres,
        count,
        placement,
        resolution: sp(cmo.resolution),
    }
}

/// The files of the export in `dir`: its `scene.toml` when that file's first line holds
/// [`MARK`], the OBJ files that `scene.toml` names and the MTL files those name (each a plain
/// file name in `dir` whose first line holds [`MARK`]), and the textures those MTL files name
/// (plain names in `dir`). Empty when `dir` holds no `scene.toml` written by an export. Files
/// that do not exist are left out.
pub fn exported_files(dir: &Path) -> Vec<PathBuf> {
    let toml_path = dir.join("scene.toml");
    if !marked(&toml_path) {
        return Vec::new();
    }
    let mut out = vec![toml_path.clone()];
    let table: toml::Table = std::fs::read_to_string(&toml_path)
        .ok()
        .and_then(|t| t.parse().ok())
        .unwrap_or_default();
    let objs = table
        .get("mesh")
        .and_then(|m| m.as_array())
        .into_iter()
        .flatten()
        .filter_map(|m| m.get("obj")?.as_str());
    for obj in objs {
        let Some(obj) = push_marked(&mut out, dir, obj) else {
            continue;
        };
        for mtl in statements(&obj, "mtllib") {
            let Some(mtl) = push_marked(&mut out, dir, &mtl) else {
                continue;
            };
            for texture in statements(&mtl, "map_Kd") {
                if let Some(name) = plain(&texture) {
                    let path = dir.join(name);
                    if path.is_file() && !out.contains(&path) {
                        out.push(path);
                    }
                }
            }
        }
    }
    out
}

/// `name` when it is a plain file name (no folder, not `.` or `..`).
fn plain(name: &str) -> Option<&str> {
    let mut c = Path::new(name).components();
    match (c.next(), c.next()) {
        (Some(std::path::Component::Normal(_)), None) => Some(name),
        _ => None,
    }
}

/// Whether the file's first line holds [`MARK`].
fn marked(path: &Path) -> bool {
    use std::io::{BufRead as _, Read as _};
    let Ok(f) = std::fs::File::open(path) else {
        return false;
    };
    let mut line = String::new();
    let mut reader = std::io::BufReader::new(f).take(4096);
    reader.read_line(&mut line).is_ok() && line.starts_with('#') && line.contains(MARK)
}

/// Adds `dir/name` to `out` when `name` is plain and the file is [`marked`]; returns its path.
fn push_marked(out: &mut Vec<PathBuf>, dir: &Path, name: &str) -> Option<PathBuf> {
    let path = dir.join(plain(name)?);
    if !marked(&path) {
        return None;
    }
    if !out.contains(&path) {
        out.push(path.clone());
    }
    Some(path)
}

/// The arguments of each `keyword ARG` line of a text file (the names an export writes have no
/// spaces).
fn statements(path: &Path, keyword: &str) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines()
        .filter_map(|l| {
            let mut w = l.split_whitespace();
            (w.next() == Some(keyword)).then(|| w.last().map(str::to_string))?
        })
        .collect()
}

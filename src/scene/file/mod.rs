//! The TOML scene file.
//!
//! ```toml
//! name = "my-scene"
//! background = [0.05, 0.05, 0.08]   # linear RGB of rays that leave the scene
//! self_reflections = "auto"         # reflectors see themselves (costs mask + normal cubemaps):
//!                                   # "auto" (default: the reflectors that are not convex), true, false
//!
//! [shading]
//! model = "lambert"                 # or "unlit"
//! ambient = 0.35
//! light_direction = [0.3, 0.9, 0.4] # towards the light; normalised on load
//! light_intensity = 0.65
//!
//! [[mesh]]
//! name = "sphere"
//! obj = "sphere.obj"                # relative to this file, absolute, or from ~/
//! reflector = true                 # the whole OBJ; or the names of its objects, groups or
//!                                   # materials that are mirrors: ["Ball", "Chrome"] (the
//!                                   # other parts become a mesh "<name>-rest", moved with it)
//! specular_power = 64               # optional, reflectors only: glossy (Phong power, 0 up;
//!                                   # 1024 and above a mirror), or "mtl" for the MTL's Ns;
//!                                   # without it a mirror, whatever the MTL's Ns
//! transform = { translate = [0, 1.2, 0], rotate_deg = [0, 0, 0], scale = 1.0 }  # or scale = [x, y, z]
//!
//! [[camera]]
//! name = "main"
//! eye = [0, 1.8, 3.6]
//! target = [0, 1.1, 0]
//! up = [0, 1, 0]
//! fov_y_deg = 50
//! resolution = [640, 480]
//!
//! [cmo]                             # optional
//! centres = [[0, 1.2, 0]]           # or: count = 2 (at most 2 CMOs, placed by the search);
//!                                   # without centres, placement = "auto" (the default)
//!                                   # searches for centres that leave at most 1 % of a sample
//!                                   # of reflected rays unresolved, up to count CMOs (default
//!                                   # 8); placement = "axis" spreads count (default 1) along
//!                                   # the reflectors' longest axis
//! resolution = 256                  # texels per cube face side (default 256)
//!
//! [film]                            # optional; --spp and --filter override it
//! spp = 16                          # samples per pixel, 1 to 1024 (default 1)
//! filter = "box"                    # or "gaussian" (default "box")
//!
//! [animation]                       # optional; without it the scene is a still
//! fps = 24                          # frame f is at time f / fps seconds (default 24)
//! frames = [1, 48]                  # default range of `render` without --frames (inclusive;
//!                                   # default [1, 1] where there are keys)
//! interpolation = "linear"          # or "catmull-rom" (camera paths; default "linear")
//!
//! [[animation.camera]]
//! camera = "main"                   # a [[camera]]'s name (default: the first camera)
//! [[animation.camera.key]]
//! time = 0.0                        # seconds; keys in strictly increasing time
//! eye = [0, 1.8, 3.6]               # any of eye, target, up, fov_y_deg (at least one)
//! [[animation.camera.key]]
//! time = 2.0
//! eye = [3.6, 1.8, 0]
//! fov_y_deg = 40
//!
//! [[animation.mesh]]
//! mesh = "sphere"                   # a [[mesh]]'s name
//! [[animation.mesh.key]]
//! time = 0.5
//! translate = [0, 1.5, 0]           # any of translate, rotate_deg, scale (at least one)
//! ```
//!
//! Animation: each field of a camera or mesh is animated by the keys that set it (see
//! `cubetrace::scene::animation`): at a key's time it is the key's value, between two keys it is
//! interpolated linearly (or along a Catmull-Rom spline for cameras), outside them it holds the nearest key's value, and a field no key sets
//! keeps the `[[camera]]`'s or `[[mesh]]`'s value. A camera or mesh is animated by one track at
//! most; a track needs a key, each key a `time` (keys out of order, a missing time, an unknown
//! interpolation name or an unknown camera or mesh are errors naming the line and the field).
//!
//! Unknown fields are errors. Every value is checked and an error names the file, the line and
//! the field:
//! - numbers finite, arrays of exactly the stated length;
//! - colours (`background`, MTL `Kd`) and `light_intensity` in `[0, 65504]`
//!   ([`super::MAX_COLOUR`]), `ambient` in `[0, 1]`, `light_direction` not zero;
//! - points (`eye`, `target`, `translate`, `cmo.centres`, OBJ vertices) within `±2^60`
//!   ([`super::MAX_COORDINATE`]); `rotate_deg` in `[-360, 360]`; `scale`
//!   non-zero; `fov_y_deg` in `(0, 180)`; image sides 1 to 16384, `cmo.resolution` 1 to 4096,
//!   1 to 16 CMOs ([`super::MAX_CMOS`]);
//! - each mesh after its transform within `±2^60` and at least `2^-21` of the largest
//!   coordinate that meets it across ([`MIN_RELATIVE_SIZE`](super::MIN_RELATIVE_SIZE));
//! - mesh and camera names unique (a mesh's name defaults to its OBJ's stem; the same OBJ placed
//!   twice without names gives `ball`, `ball-2`).
//!
//! A reflector whose OBJ holds no triangles is an error (it would be an invisible mirror), as is
//! a `reflector` name that names no object, group (`o`, `g`) or material (`usemtl`) of its OBJ.
//!
//! The file's form (the tables as serde reads and writes them, and the readers of exact-length
//! arrays) is in `form`, the `[animation]` table's check in `animation_table`; this module
//! checks the other values and loads the meshes into a [`Scene`].

mod animation_table;
mod form;

use std::path::{Path, PathBuf};

use glam::Vec3;
use toml::Spanned;

use super::limits;
use super::obj::{LoadedObj, find_beside, load_obj_file};
use super::report::{LoadReport, WarningKind};
use super::source::Source;
use super::{
    CmoPlacement, CmoSpec, DEFAULT_SEARCH_CMOS, MAX_CMOS, MAX_COLOUR, MAX_COORDINATE,
    MAX_CUBE_SIZE, MAX_IMAGE_SIDE, MeshInstance, MeshPart, Scene, SceneError, SelfReflections,
    Transform,
};
use crate::camera::Camera;
use crate::shading::Shading;
use animation_table::animation;
pub(crate) use form::{
    AnimationFile, CameraFile, CameraKeyFile, CameraTrackFile, CmoFile, FilmFile, MeshFile,
    MeshKeyFile, MeshTrackFile, ReflectorFile, ScaleFile, SceneFile, SelfReflectionsFile,
    ShadingFile, ShadingModel, SpecularPowerFile, TransformFile,
};

/// How a reflector of the scene file is glossy (its `specular_power`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Gloss {
    /// No `specular_power`: a perfect mirror, whatever its MTL's `Ns` says (exporters write an
    /// `Ns` for every material: Blender 250 or 323.99 by default).
    Mirror,
    /// `specular_power = N`: every part of the mesh has this power.
    Power(f32),
    /// `specular_power = "mtl"`: each part has its MTL material's `Ns` (a mirror without one).
    Mtl,
}

/// Checks an image size: both sides in `1..=MAX_IMAGE_SIDE`.
pub fn check_resolution(width: u32, height: u32) -> Result<(), String> {
    for (what, v) in [("width", width), ("height", height)] {
        if v == 0 || v > MAX_IMAGE_SIDE {
            return Err(format!(
                "{what} {v} is out of range (1 to {MAX_IMAGE_SIDE} pixels)"
            ));
        }
    }
    Ok(())
}

/// Loads a scene file and everything it refers to. Warnings go to the log (see
/// [`load_scene_file_report`]).
pub fn load_scene_file(path: &Path) -> Result<Scene, SceneError> {
    let (scene, report) = load_scene_file_report(path)?;
    report.log();
    Ok(scene)
}

/// Loads a scene file and everything it refers to, and returns the warnings: input that was
/// accepted, but not as written (skipped elements, undefined materials, ...). The first error
/// is reported, checking in this order: background, shading, self-reflections, meshes, cameras,
/// CMOs, then the names and the meshes' sizes (`limits`).
pub fn load_scene_file_report(path: &Path) -> Result<(Scene, LoadReport), SceneError> {
    let mut report = LoadReport::default();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(path, e))?;
    let file: SceneFile = toml::from_str(&text).map_err(|e| SceneError::Toml {
        path: path.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    })?;
    let src = Source { path, text: &text };
    let dir = path.parent().unwrap_or(Path::new("."));

    let mut scene = Scene {
        name: file.name.clone().unwrap_or_else(|| {
            path.file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scene".into())
        }),
        meshes: Vec::new(),
        materials: Vec::new(),
        textures: Vec::new(),
        cameras: Vec::new(),
        cmo: CmoSpec {
            placement: CmoPlacement::Search {
                count: DEFAULT_SEARCH_CMOS,
            },
            resolution: 256,
            lists: None,
        },
        background: src.colour(&file.background, "background")?,
        shading: shading(&src, &file.shading)?,
        self_reflections: self_reflections(&src, file.self_reflections.as_ref())?,
        film: Default::default(),
        animation: Default::default(),
    };

    // The file's mesh each of the scene's comes from, and the meshes split in two (a mirror's,
    // its other parts').
    let mut origin = Vec::new();
    let mut split = Vec::new();
    for (i, m) in file.meshes.iter().enumerate() {
        let n = load_mesh(&src, dir, i, m, &mut scene, &mut report)?;
        if n == 2 {
            split.push((origin.len(), origin.len() + 1));
        }
        origin.extend(std::iter::repeat_n(i, n));
    }
    if scene.meshes.is_empty() {
        report.warn(WarningKind::NoMeshes, path, None, "the scene has no meshes");
    }

    for (i, c) in file.cameras.iter().enumerate() {
        scene.cameras.push(camera(&src, i, c)?);
    }
    if scene.cameras.is_empty() {
        return Err(SceneError::Invalid {
            file: path.display().to_string(),
            field: "camera".into(),
            reason: "at least one [[camera]] is required".into(),
        });
    }

    if let Some(cmo) = &file.cmo {
        scene.cmo = cmo_spec(&src, cmo)?;
    }
    let given = |n: &Option<Spanned<String>>| n.as_ref().map(|n| n.span());
    // A split mesh's other parts take a name derived from the given one.
    let rest = |k: &usize| split.iter().any(|s| s.1 == *k);
    let meshes: Vec<_> = (origin.iter().enumerate())
        .map(|(k, &i)| given(&file.meshes[i].name).filter(|_| !rest(&k)))
        .collect();
    let cameras: Vec<_> = file.cameras.iter().map(|c| given(&c.name)).collect();
    limits::check_names(&src, &meshes, &cameras, &mut scene)?;
    let transforms: Vec<_> = (origin.iter().map(|&i| &file.meshes[i]))
        .map(|m| (m.transform.scale.span(), m.transform.translate.span()))
        .collect();
    limits::check_mesh_sizes(&src, &transforms, &scene)?;
    if let Some(f) = &file.film {
        scene.film = film(&src, f)?;
    }
    if let Some(a) = &file.animation {
        scene.animation = animation(&src, a, &scene, &split)?;
    }
    Ok((scene, report))
}

fn self_reflections(
    src: &Source,
    value: Option<&Spanned<SelfReflectionsFile>>,
) -> Result<SelfReflections, SceneError> {
    let Some(v) = value else {
        return Ok(SelfReflections::Auto);
    };
    match v.get_ref() {
        SelfReflectionsFile::Bool(true) => Ok(SelfReflections::On),
        SelfReflectionsFile::Bool(false) => Ok(SelfReflections::Off),
        SelfReflectionsFile::Word(w) if w == "auto" => Ok(SelfReflections::Auto),
        SelfReflectionsFile::Word(w) => Err(src.invalid(
            v,
            "self_reflections",
            format!("'{w}' is not one of true, false or \"auto\""),
        )),
    }
}

/// Mesh `i` of the file: its transform, its OBJ (relative to the scene file's folder `dir`),
/// merged into `scene`.
fn load_mesh(
    src: &Source,
    dir: &Path,
    i: usize,
    m: &MeshFile,
    scene: &mut Scene,
    report: &mut LoadReport,
) -> Result<usize, SceneError> {
    let t = &m.transform;
    let scale = match *t.scale.get_ref() {
        ScaleFile::Uniform(s) => Vec3::splat(s),
        ScaleFile::PerAxis(s) => Vec3::from_array(s),
    };
    let field = format!("mesh[{i}].transform.scale");
    if !scale.is_finite() || scale.cmpeq(Vec3::ZERO).any() {
        return Err(src.invalid(&t.scale, &field, "scale must be finite and non-zero"));
    }
    let rotate_deg = src.finite(&t.rotate_deg, &format!("mesh[{i}].transform.rotate_deg"))?;
    if let Some(c) = (0..3).find(|&c| rotate_deg[c].abs() > 360.0) {
        return Err(src.invalid(
            &t.rotate_deg,
            &format!("mesh[{i}].transform.rotate_deg"),
            format!(
                "component {c} is {} (angles lie in [-360, 360] degrees)",
                rotate_deg[c]
            ),
        ));
    }
    let transform = Transform {
        translate: src.point(&t.translate, &format!("mesh[{i}].transform.translate"))?,
        rotate_deg,
        scale,
    };
    let obj_path = mesh_file(dir, m.obj.get_ref()).ok_or_else(|| {
        src.invalid(
            &m.obj,
            &format!("mesh[{i}].obj"),
            format!(
                "{} not found (paths are relative to the scene file's folder)",
                dir.join(m.obj.get_ref()).display()
            ),
        )
    })?;
    let loaded = load_obj_file(&obj_path, report)?;
    let name = m
        .name
        .as_ref()
        .map(|n| n.get_ref().clone())
        .unwrap_or_else(|| {
            obj_path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| format!("mesh{i}"))
        });
    if loaded.parts.is_empty() {
        if is_reflector(m) {
            return Err(src.invalid(
                &m.obj,
                &format!("mesh[{i}].obj"),
                format!(
                    "{} holds no triangles, so reflector '{name}' would be an invisible mirror",
                    obj_path.display()
                ),
            ));
        }
        report.warn(
            WarningKind::EmptyMesh,
            &obj_path,
            None,
            format!("mesh '{name}' holds no triangles"),
        );
    }
    let gloss = gloss(src, i, m)?;
    let mirror = mirror_parts(src, i, m, &obj_path, &loaded)?;
    if mirror.iter().all(|&b| b == mirror[0]) {
        merge(scene, name, loaded, transform, is_reflector(m), gloss);
        return Ok(1);
    }
    // Some parts are mirrors and some not: two meshes, the mirrors under the mesh's name.
    let (mut mirrors, mut rest) = (Vec::new(), Vec::new());
    for (part, is_mirror) in loaded.parts.into_iter().zip(mirror) {
        if is_mirror {
            mirrors.push(part);
        } else {
            rest.push(part);
        }
    }
    let half = |parts| LoadedObj {
        parts,
        materials: loaded.materials.clone(),
        textures: loaded.textures.clone(),
    };
    let rest_name = format!("{name}{REST_SUFFIX}");
    merge(scene, name, half(mirrors), transform, true, gloss);
    merge(scene, rest_name, half(rest), transform, false, gloss);
    Ok(2)
}

/// The name of the other parts' mesh where a mesh's `reflector` lists some of its parts.
const REST_SUFFIX: &str = "-rest";

/// Whether mesh `m` has a mirror: `reflector = true`, or a list of names.
fn is_reflector(m: &MeshFile) -> bool {
    match m.reflector.get_ref() {
        ReflectorFile::Whole(b) => *b,
        ReflectorFile::Parts(names) => !names.is_empty(),
    }
}

/// Which of `loaded`'s parts (mesh `i`'s OBJ at `obj_path`) are mirrors: all or none for
/// `reflector = true` or `false`; for a list of names, those whose OBJ object or group (`o`,
/// `g`) or material (`usemtl`) it names. A name that names no part, and an empty list, are
/// refused with the names there are.
fn mirror_parts(
    src: &Source,
    i: usize,
    m: &MeshFile,
    obj_path: &Path,
    loaded: &LoadedObj,
) -> Result<Vec<bool>, SceneError> {
    let names = match m.reflector.get_ref() {
        ReflectorFile::Whole(b) => return Ok(vec![*b; loaded.parts.len().max(1)]),
        ReflectorFile::Parts(names) => names,
    };
    let field = format!("mesh[{i}].reflector");
    let material = |p: &MeshPart| loaded.materials.get(p.material as usize).map(|m| &m.name);
    let named = |p: &MeshPart, n: &String| p.name == *n || material(p) == Some(n);
    let listed = || {
        let mut parts: Vec<&str> = loaded.parts.iter().map(|p| p.name.as_str()).collect();
        parts.dedup();
        let mut materials: Vec<&str> = (loaded.parts.iter())
            .filter_map(|p| material(p).map(String::as_str))
            .collect();
        materials.sort_unstable();
        materials.dedup();
        format!(
            "{} has objects or groups {} and materials {}",
            obj_path.display(),
            quoted(&parts),
            quoted(&materials)
        )
    };
    if names.is_empty() {
        return Err(src.invalid(
            &m.reflector,
            &field,
            format!(
                "an empty list names no mirror (false, true, or names: {})",
                listed()
            ),
        ));
    }
    if let Some(n) = names
        .iter()
        .find(|n| !loaded.parts.iter().any(|p| named(p, n)))
    {
        return Err(src.invalid(
            &m.reflector,
            &field,
            format!(
                "'{n}' names no object, group or material of the OBJ: {}",
                listed()
            ),
        ));
    }
    Ok((loaded.parts.iter())
        .map(|p| names.iter().any(|n| named(p, n)))
        .collect())
}

/// `names` quoted and joined, or "none".
fn quoted(names: &[&str]) -> String {
    if names.is_empty() {
        return "none".into();
    }
    let q: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
    q.join(", ")
}

/// The OBJ file a mesh's `obj` names, relative to the scene file's folder `dir`: as written
/// (a leading `~` read as the home folder, `$HOME`, as a shell reads it), then as
/// [`find_beside`] looks for an exporter's file names (Windows separators, another letter
/// case, the file name alone). `None` where none exists.
fn mesh_file(dir: &Path, written: &Path) -> Option<PathBuf> {
    let home = std::env::var_os("HOME").filter(|h| !h.is_empty());
    let written = match (written.strip_prefix("~"), home) {
        (Ok(rest), Some(home)) => Path::new(&home).join(rest),
        _ => written.to_path_buf(),
    };
    let path = dir.join(&written);
    if path.is_file() {
        return Some(path);
    }
    find_beside(dir, &written.to_string_lossy())
}

/// Mesh `i`'s `specular_power`: on a reflector only; a finite number at least 0, or `"mtl"`.
fn gloss(src: &Source, i: usize, m: &MeshFile) -> Result<Gloss, SceneError> {
    let Some(v) = &m.specular_power else {
        return Ok(Gloss::Mirror);
    };
    let field = format!("mesh[{i}].specular_power");
    if !is_reflector(m) {
        return Err(src.invalid(
            v,
            &field,
            "only a reflector has a specular power (add reflector = true, or remove it)",
        ));
    }
    match v.get_ref() {
        SpecularPowerFile::Number(p) if p.is_finite() && *p >= 0.0 => Ok(Gloss::Power(*p)),
        SpecularPowerFile::Number(p) => Err(src.invalid(
            v,
            &field,
            format!(
                "{p} is not a specular power (a finite number, at least 0; {} and above is a \
                 mirror)",
                crate::lobe::MIRROR_POWER
            ),
        )),
        SpecularPowerFile::Word(w) if w == "mtl" => Ok(Gloss::Mtl),
        SpecularPowerFile::Word(w) => Err(src.invalid(
            v,
            &field,
            format!("'{w}' is not a number or \"mtl\" (the MTL materials' Ns)"),
        )),
    }
}

/// Camera `i` of the file.
fn camera(src: &Source, i: usize, c: &CameraFile) -> Result<Camera, SceneError> {
    let f = |s: &str| format!("camera[{i}].{s}");
    let eye = src.point(&c.eye, &f("eye"))?;
    let target = src.point(&c.target, &f("target"))?;
    let up = src.finite(&c.up, &f("up"))?;
    let fov_y_deg = src.scalar(&c.fov_y_deg, &f("fov_y_deg"))?;
    if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
        return Err(src.invalid(&c.fov_y_deg, &f("fov_y_deg"), "must be in (0, 180) degrees"));
    }
    let [width, height] = *c.resolution.get_ref();
    check_resolution(width, height)
        .map_err(|reason| src.invalid(&c.resolution, &f("resolution"), reason))?;
    let camera = Camera {
        name: c
            .name
            .as_ref()
            .map_or_else(|| format!("camera{i}"), |n| n.get_ref().clone()),
        eye,
        target,
        up,
        fov_y_deg,
        width,
        height,
        jitter: glam::Vec2::ZERO,
    };
    match camera.view_error() {
        Some(why) => Err(src.invalid(
            &c.up,
            &f("up"),
            format!("eye, target and up must span a view: {why}"),
        )),
        None => Ok(camera),
    }
}

/// The `[cmo]` table: face size, then centres or count (and how a count is placed).
fn cmo_spec(src: &Source, cmo: &CmoFile) -> Result<CmoSpec, SceneError> {
    let res = *cmo.resolution.get_ref();
    if res == 0 || res > MAX_CUBE_SIZE {
        return Err(src.invalid(
            &cmo.resolution,
            "cmo.resolution",
            format!("{res} is out of range (1 to {MAX_CUBE_SIZE} texels)"),
        ));
    }
    let placement = match (&cmo.centres, &cmo.count) {
        (Some(_), Some(c)) => {
            return Err(src.invalid(c, "cmo", "give either centres or count, not both"));
        }
        (Some(centres), None) => CmoPlacement::Explicit(cmo_centres(src, centres)?),
        (None, count) => {
            let n = match count {
                Some(count) => {
                    let n = *count.get_ref();
                    if n == 0 || n > MAX_CMOS {
                        return Err(src.invalid(
                            count,
                            "cmo.count",
                            format!("{n} is out of range (1 to {MAX_CMOS} CMOs)"),
                        ));
                    }
                    Some(n)
                }
                None => None,
            };
            match cmo.placement.as_ref().map(|p| (p, p.get_ref().as_str())) {
                Some((_, "axis")) => CmoPlacement::Auto {
                    count: n.unwrap_or(1),
                },
                None | Some((_, "auto")) => CmoPlacement::Search {
                    count: n.unwrap_or(DEFAULT_SEARCH_CMOS),
                },
                Some((p, other)) => {
                    return Err(src.invalid(
                        p,
                        "cmo.placement",
                        format!("'{other}' is not one of \"axis\" or \"auto\""),
                    ));
                }
            }
        }
    };
    if let (Some(p), Some(_)) = (&cmo.placement, &cmo.centres) {
        return Err(src.invalid(
            p,
            "cmo.placement",
            "applies to count, not to explicit centres",
        ));
    }
    Ok(CmoSpec {
        placement,
        resolution: res,
        lists: None,
    })
}

/// `cmo.centres`: at least one, every coordinate finite.
fn cmo_centres(src: &Source, centres: &Spanned<Vec<[f32; 3]>>) -> Result<Vec<Vec3>, SceneError> {
    let mut out = Vec::new();
    for (k, c) in centres.get_ref().iter().enumerate() {
        let v = Vec3::from_array(*c);
        if !v.is_finite() {
            return Err(src.invalid(
                centres,
                &format!("cmo.centres[{k}]"),
                "numbers must be finite",
            ));
        }
        if v.abs().max_element() > MAX_COORDINATE {
            return Err(src.invalid(
                centres,
                &format!("cmo.centres[{k}]"),
                format!("{v} lies beyond the {MAX_COORDINATE:e} (2^60) a coordinate may reach"),
            ));
        }
        out.push(v);
    }
    if out.is_empty() {
        return Err(src.invalid(centres, "cmo.centres", "needs at least one centre"));
    }
    if out.len() > MAX_CMOS as usize {
        return Err(src.invalid(
            centres,
            "cmo.centres",
            format!("{} centres, at most {MAX_CMOS} CMOs", out.len()),
        ));
    }
    Ok(out)
}

fn shading(src: &Source, s: &ShadingFile) -> Result<Shading, SceneError> {
    Ok(match s.model {
        ShadingModel::Unlit => Shading::Unlit,
        ShadingModel::Lambert => {
            let Shading::Lambert {
                ambient,
                light_direction,
                light_intensity,
            } = Shading::default()
            else {
                unreachable!("the default shading is Lambert")
            };
            let ambient = match &s.ambient {
                Some(a) => {
                    let v = src.scalar(a, "shading.ambient")?;
                    if !(0.0..=1.0).contains(&v) {
                        return Err(src.invalid(
                            a,
                            "shading.ambient",
                            format!("{v} is outside [0, 1] (the share of the albedo lit by ambient light)"),
                        ));
                    }
                    v
                }
                None => ambient,
            };
            let light_intensity = match &s.light_intensity {
                Some(a) => {
                    let v = src.scalar(a, "shading.light_intensity")?;
                    if !(0.0..=MAX_COLOUR).contains(&v) {
                        return Err(src.invalid(
                            a,
                            "shading.light_intensity",
                            format!(
                                "{v} is outside [0, {MAX_COLOUR}] (the light's share of the albedo)"
                            ),
                        ));
                    }
                    v
                }
                None => light_intensity,
            };
            let light_direction = match &s.light_direction {
                Some(d) => src
                    .finite(d, "shading.light_direction")?
                    .try_normalize()
                    .ok_or_else(|| src.invalid(d, "shading.light_direction", "must not be zero"))?,
                None => light_direction,
            };
            Shading::Lambert {
                ambient,
                light_direction,
                light_intensity,
            }
        }
    })
}

/// Appends an OBJ's parts to the scene, reusing identical materials and textures already there.
fn merge(
    scene: &mut Scene,
    name: String,
    loaded: super::obj::LoadedObj,
    transform: Transform,
    reflector: bool,
    gloss: Gloss,
) {
    let texture_map: Vec<u32> = loaded
        .textures
        .into_iter()
        .map(|t| match scene.textures.iter().position(|x| *x == t) {
            Some(i) => i as u32,
            None => {
                scene.textures.push(t);
                (scene.textures.len() - 1) as u32
            }
        })
        .collect();
    let material_map: Vec<u32> = loaded
        .materials
        .into_iter()
        .map(|mut m| {
            m.texture = m.texture.map(|t| texture_map[t as usize]);
            // Glossiness is a reflector's, and a mirror is `None` ([`crate::lobe::glossy`]).
            m.specular_power = match (reflector, gloss) {
                (false, _) | (true, Gloss::Mirror) => None,
                (true, Gloss::Power(p)) => crate::lobe::glossy(Some(p)),
                (true, Gloss::Mtl) => crate::lobe::glossy(m.specular_power),
            };
            match scene.materials.iter().position(|x| *x == m) {
                Some(i) => i as u32,
                None => {
                    scene.materials.push(m);
                    (scene.materials.len() - 1) as u32
                }
            }
        })
        .collect();
    let parts = loaded
        .parts
        .into_iter()
        .map(|mut p| {
            p.material = material_map[p.material as usize];
            p
        })
        .collect();
    scene.meshes.push(MeshInstance {
        name,
        parts,
        transform,
        reflector,
    });
}

/// `[film]`: `spp` in 1 to [`crate::film::MAX_SPP`], `filter` one of the pixel filters' names.
fn film(src: &Source, f: &FilmFile) -> Result<crate::film::FilmSettings, SceneError> {
    use crate::film::{FilmSettings, MAX_SPP, PixelFilter};
    let mut out = FilmSettings::default();
    if let Some(spp) = &f.spp {
        let n = *spp.get_ref();
        if n == 0 || n > MAX_SPP {
            return Err(src.invalid(
                spp,
                "film.spp",
                format!("{n} is out of range (1 to {MAX_SPP} samples per pixel)"),
            ));
        }
        out.spp = n;
    }
    if let Some(filter) = &f.filter {
        out.filter = match filter.get_ref().as_str() {
            "box" => PixelFilter::Box,
            "gaussian" => PixelFilter::Gaussian,
            other => {
                return Err(src.invalid(
                    filter,
                    "film.filter",
                    format!("'{other}' is not one of \"box\" or \"gaussian\""),
                ));
            }
        };
    }
    Ok(out)
}

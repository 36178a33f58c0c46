//! Checks of a loaded scene file as a whole, after its meshes, cameras and CMOs are read:
//! - names: a `[[mesh]]` or `[[camera]]` name given twice is an error naming both entries
//!   (`--camera NAME` and the messages could not tell them apart). A name given once may not
//!   repeat a name derived for another entry either. Meshes without `name` take their OBJ's
//!   stem; when two such meshes share one (the same OBJ placed twice), the later ones get `-2`,
//!   `-3`, ... as `scene export` names its files.
//! - mesh sizes: each mesh, after its transform, must lie within [`MAX_COORDINATE`] and span at
//!   least [`MIN_RELATIVE_SIZE`] of the largest coordinate that meets it (its own farthest
//!   vertex, a camera's eye, a CMO centre given in the file); otherwise f32 cannot hold it and
//!   it would vanish or collapse without a word. The error names the transform and the numbers.

use glam::Vec3;
use toml::Spanned;

use super::file::{SceneFile, Source, TransformFile};
use super::{CmoPlacement, MAX_COORDINATE, MIN_RELATIVE_SIZE, MeshInstance, Scene, SceneError};

/// One entry's name: the name, whether the file gave it, and the entry's field and location.
struct Named<'a> {
    name: String,
    given: Option<&'a Spanned<String>>,
    field: String,
}

/// The name checks of the module docs, for meshes then cameras; renames derived mesh names
/// that repeat.
pub(super) fn check_names(
    src: &Source,
    file: &SceneFile,
    scene: &mut Scene,
) -> Result<(), SceneError> {
    let meshes: Vec<Named> = scene
        .meshes
        .iter()
        .zip(&file.meshes)
        .enumerate()
        .map(|(i, (m, f))| Named {
            name: m.name.clone(),
            given: f.name.as_ref(),
            field: format!("mesh[{i}].name"),
        })
        .collect();
    for (i, name) in unique_names(src, &meshes)?.into_iter().enumerate() {
        scene.meshes[i].name = name;
    }
    let cameras: Vec<Named> = scene
        .cameras
        .iter()
        .zip(&file.cameras)
        .enumerate()
        .map(|(i, (c, f))| Named {
            name: c.name.clone(),
            given: f.name.as_ref(),
            field: format!("camera[{i}].name"),
        })
        .collect();
    unique_names(src, &cameras)?;
    Ok(())
}

/// Refuses a repeated name where either entry gave it; returns the names with derived repeats
/// numbered.
fn unique_names(src: &Source, entries: &[Named]) -> Result<Vec<String>, SceneError> {
    for (j, b) in entries.iter().enumerate() {
        let Some(a) = entries[..j].iter().find(|a| a.name == b.name) else {
            continue;
        };
        let Some(at) = b.given.or(a.given) else {
            continue;
        };
        let place = |e: &Named| match e.given {
            Some(g) => format!("{} ({})", e.field, src.at(g)),
            None => format!("{} (derived from its file name)", e.field),
        };
        return Err(src.invalid(
            at,
            &b.field,
            format!(
                "'{}' names both {} and {}; names must be unique",
                b.name,
                place(a),
                place(b)
            ),
        ));
    }
    // Only derived names repeat now: number the later ones, avoiding every name in the file.
    let mut out: Vec<String> = Vec::new();
    for e in entries {
        let mut name = e.name.clone();
        let mut k = 2;
        while out.contains(&name) || (name != e.name && entries.iter().any(|x| x.name == name)) {
            name = format!("{}-{k}", e.name);
            k += 1;
        }
        out.push(name);
    }
    Ok(out)
}

/// Largest coordinate magnitude of a point (f32 rounds each coordinate to `2^-24` of it).
fn magnitude(p: Vec3) -> f32 {
    p.abs().max_element()
}

/// The mesh size checks of the module docs.
pub(super) fn check_mesh_sizes(
    src: &Source,
    file: &SceneFile,
    scene: &Scene,
) -> Result<(), SceneError> {
    let mut viewpoints = scene
        .cameras
        .iter()
        .map(|c| magnitude(c.eye))
        .fold(0.0f32, f32::max);
    if let CmoPlacement::Explicit(centres) = &scene.cmo.placement {
        viewpoints = centres
            .iter()
            .map(|&c| magnitude(c))
            .fold(viewpoints, f32::max);
    }
    for (i, (mesh, f)) in scene.meshes.iter().zip(&file.meshes).enumerate() {
        check_mesh_size(src, i, mesh, &f.transform, viewpoints)?;
    }
    Ok(())
}

/// One mesh against the bounds; `viewpoints`: the largest coordinate of the cameras' eyes and
/// the file's CMO centres.
fn check_mesh_size(
    src: &Source,
    i: usize,
    mesh: &MeshInstance,
    t: &TransformFile,
    viewpoints: f32,
) -> Result<(), SceneError> {
    let m = mesh.transform.matrix();
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let (mut olo, mut ohi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for part in &mesh.parts {
        for &k in part.triangles.iter().flatten() {
            let p = part.positions[k as usize];
            let w = m.transform_point3(p);
            (olo, ohi) = (olo.min(p), ohi.max(p));
            (lo, hi) = (lo.min(w), hi.max(w));
        }
    }
    if lo.x > hi.x {
        return Ok(()); // no triangle (a non-reflector may be empty, with a warning)
    }
    // Name the scale unless the file left it at its default (then the translation).
    let (span, field) = if t.scale.span().end > 0 || t.translate.span().end == 0 {
        (t.scale.span(), format!("mesh[{i}].transform.scale"))
    } else {
        (t.translate.span(), format!("mesh[{i}].transform.translate"))
    };
    let at = Spanned::new(span, ());
    let tr = &mesh.transform;
    let what = format!(
        "mesh '{}' (its OBJ {:.3e} across; scale {}, translate {})",
        mesh.name,
        (ohi - olo).length(),
        if tr.scale.x == tr.scale.y && tr.scale.y == tr.scale.z {
            format!("{:e}", tr.scale.x)
        } else {
            format!("[{:e}, {:e}, {:e}]", tr.scale.x, tr.scale.y, tr.scale.z)
        },
        tr.translate
    );
    let reach = magnitude(lo).max(magnitude(hi));
    if !(reach <= MAX_COORDINATE) {
        return Err(src.invalid(
            &at,
            &field,
            format!(
                "{what} reaches {reach:.3e} in world space, beyond the {MAX_COORDINATE:.3e} (2^60) \
                 a coordinate may reach (the tracer squares distances in f32)"
            ),
        ));
    }
    let size = (hi - lo).length();
    let scale = reach.max(viewpoints);
    let least = scale * MIN_RELATIVE_SIZE;
    if !(size >= least) {
        return Err(src.invalid(
            &at,
            &field,
            format!(
                "{what} is {size:.3e} across in world space, below 2^-21 of {scale:.3e} (the \
                 largest coordinate of the mesh, the cameras' eyes and the CMO centres): f32 \
                 rounds coordinates there to {:.1e}, so the mesh would collapse. It must be at \
                 least {least:.3e} across",
                scale * f32::EPSILON * 0.5
            ),
        ));
    }
    Ok(())
}

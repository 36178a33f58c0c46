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

use super::source::Source;
use super::{CmoPlacement, MAX_COORDINATE, MIN_RELATIVE_SIZE, MeshInstance, Scene, SceneError};

/// A byte range of the scene file (0..0: a default the file does not state).
type Span = std::ops::Range<usize>;

/// One entry's name: the name, where the file gave it (`None`: derived), and the entry's field.
struct Named {
    name: String,
    given: Option<Span>,
    field: String,
}

/// The name checks of the module docs, for meshes then cameras; renames derived mesh names
/// that repeat. `meshes` and `cameras`: where the file gave each entry's name.
pub(super) fn check_names(
    src: &Source,
    meshes: &[Option<Span>],
    cameras: &[Option<Span>],
    scene: &mut Scene,
) -> Result<(), SceneError> {
    let named = |names: Vec<String>, given: &[Option<Span>], what: &str| -> Vec<Named> {
        names
            .into_iter()
            .zip(given)
            .enumerate()
            .map(|(i, (name, given))| Named {
                name,
                given: given.clone(),
                field: format!("{what}[{i}].name"),
            })
            .collect()
    };
    let names = scene.meshes.iter().map(|m| m.name.clone()).collect();
    for (i, name) in unique_names(src, &named(names, meshes, "mesh"))?
        .into_iter()
        .enumerate()
    {
        scene.meshes[i].name = name;
    }
    let names = scene.cameras.iter().map(|c| c.name.clone()).collect();
    unique_names(src, &named(names, cameras, "camera"))?;
    Ok(())
}

/// Refuses a repeated name where either entry gave it; returns the names with derived repeats
/// numbered.
fn unique_names(src: &Source, entries: &[Named]) -> Result<Vec<String>, SceneError> {
    for (j, b) in entries.iter().enumerate() {
        let Some(a) = entries[..j].iter().find(|a| a.name == b.name) else {
            continue;
        };
        let Some(at) = b.given.clone().or(a.given.clone()) else {
            continue;
        };
        let at = Spanned::new(at, ());
        let place = |e: &Named| match &e.given {
            Some(g) => format!("{} ({})", e.field, src.at(&Spanned::new(g.clone(), ()))),
            None => format!("{} (derived from its file name)", e.field),
        };
        return Err(src.invalid(
            &at,
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

/// The mesh size checks of the module docs; `transforms`: the spans of each mesh's `scale` and
/// `translate`.
pub(super) fn check_mesh_sizes(
    src: &Source,
    transforms: &[(Span, Span)],
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
    for (i, (mesh, spans)) in scene.meshes.iter().zip(transforms).enumerate() {
        check_mesh_size(src, i, mesh, spans, viewpoints)?;
    }
    Ok(())
}

/// One mesh against the bounds; `viewpoints`: the largest coordinate of the cameras' eyes and
/// the file's CMO centres.
fn check_mesh_size(
    src: &Source,
    i: usize,
    mesh: &MeshInstance,
    (scale, translate): &(Span, Span),
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
    let (span, field) = if scale.end > 0 || translate.end == 0 {
        (scale.clone(), format!("mesh[{i}].transform.scale"))
    } else {
        (translate.clone(), format!("mesh[{i}].transform.translate"))
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
    if !reach.is_finite() || reach > MAX_COORDINATE {
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
    if size.is_nan() || size < least {
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

//! Scene set-ups that load fine but cannot give a useful mirror image, found before rendering
//! so that the user is told why, instead of getting an image that silently shows the background
//! or the fallback.

use glam::Vec3;

use crate::reference::Tracer;
use crate::scene::Scene;

/// How many points of the reflectors each CMO centre looks at.
const SAMPLES: usize = 512;

/// What is wrong with a scene's set-up, one message per problem (empty when nothing is):
/// - no reflector at all: there is nothing to trace;
/// - every mesh (with triangles) a reflector: the cubemaps capture no surroundings (with self-reflections, only
///   mirror surfaces that face the centre), so every reflected ray that leaves the mirrors shows
///   the background colour;
/// - a CMO centre that sees none of the reflectors (each line of sight from the centre to a
///   sample of reflector vertices and triangle centres is blocked by other geometry): its
///   cubemap shows the blocking surfaces, every reflected ray starts behind them, and the mirror
///   pixels it serves end unresolved (filled by the fallback).
pub fn diagnose(scene: &Scene) -> Vec<String> {
    diagnose_with(scene, true)
}

/// [`diagnose`], the CMO centres' lines of sight checked only where `sight`. A placement search
/// that sampled rays judged its centres by the rays they resolve (and the render warns where
/// many are left), so its centres need no such check: on a large scene the check's BVH of the
/// other geometry costs tens of milliseconds.
pub fn diagnose_with(scene: &Scene, sight: bool) -> Vec<String> {
    let mut out = Vec::new();
    // Meshes without triangles (an empty OBJ) neither reflect nor get reflected.
    let meshes: Vec<_> = scene
        .meshes
        .iter()
        .filter(|m| m.parts.iter().any(|p| !p.triangles.is_empty()))
        .collect();
    let reflectors = meshes.iter().filter(|m| m.reflector).count();
    if meshes.is_empty() {
        return out;
    }
    if reflectors == 0 {
        out.push(format!(
            "scene '{}' has no reflector (no mesh has reflector = true, or names its mirror \
             objects: reflector = [\"Ball\"]): there is no mirror to trace",
            scene.name
        ));
        return out;
    }
    if reflectors == meshes.len() {
        let captured = if scene.captures_reflectors() {
            "only the mirror surfaces that face a CMO centre"
        } else {
            "nothing (reflectors that cannot see themselves are left out of the capture)"
        };
        out.push(format!(
            "scene '{}': every mesh is a reflector, so the cubemaps capture {captured}; every \
             reflected ray that leaves the mirrors shows the background colour. Add \
             non-reflecting geometry (a floor, a room) for the mirrors to reflect",
            scene.name
        ));
    }

    if !sight {
        return out;
    }
    // Only the other geometry can block a line of sight: its BVH alone (a reflector of
    // millions of triangles is no blocker, and its BVH cost seconds here before the render).
    let others = Scene {
        name: scene.name.clone(),
        meshes: scene
            .meshes
            .iter()
            .filter(|m| !m.reflector)
            .cloned()
            .collect(),
        materials: scene.materials.clone(),
        textures: Vec::new(),
        cameras: scene.cameras.clone(),
        cmo: scene.cmo.clone(),
        background: scene.background,
        shading: scene.shading,
        self_reflections: scene.self_reflections,
        film: scene.film,
        animation: scene.animation.clone(),
    };
    let tracer = Tracer::new(&others);
    let world = &tracer.world;
    let samples = reflector_samples(scene);
    for (k, centre) in scene.cmo_centres().into_iter().enumerate() {
        let mut blocker = None;
        let sees = samples.iter().any(|&p| {
            let d = p - centre;
            let dist = d.length();
            if dist == 0.0 || !dist.is_finite() {
                return true;
            }
            match tracer.nearest(centre, d / dist, None) {
                Some(h) if h.t < dist * (1.0 - 1e-4) => {
                    blocker.get_or_insert(h.triangle);
                    false
                }
                _ => true,
            }
        });
        if !sees {
            let by = blocker
                .map(|t| {
                    let (object, _) = world.ids(t);
                    format!(" ('{}' is in the way)", world.objects[object as usize].name)
                })
                .unwrap_or_default();
            out.push(format!(
                "scene '{}': CMO {k} at ({}, {}, {}) sees none of the reflectors{by}: its cubemap \
                 shows what blocks its view, every reflected ray starts behind that, and the mirror \
                 pixels it serves end unresolved (filled by the fallback). Move the centre next to \
                 or inside the reflector",
                scene.name, centre.x, centre.y, centre.z
            ));
        }
    }
    out
}

/// About [`SAMPLES`] points of the reflectors, in world space: of the list of each reflector
/// triangle's corners and centre (in the scene's triangle order: meshes, then parts), every
/// k-th, k chosen to give at most [`SAMPLES`].
fn reflector_samples(scene: &Scene) -> Vec<Vec3> {
    let reflectors: Vec<_> = scene.meshes.iter().filter(|m| m.reflector).collect();
    let total: usize = reflectors
        .iter()
        .flat_map(|m| &m.parts)
        .map(|p| 4 * p.triangles.len())
        .sum();
    let step = total.div_ceil(SAMPLES).max(1);
    let mut out = Vec::new();
    let mut index = 0usize;
    for mesh in reflectors {
        let matrix = mesh.transform.matrix();
        for part in &mesh.parts {
            let n = 4 * part.triangles.len();
            // The list's indices in this part that are multiples of `step`.
            let mut k = (index.div_ceil(step) * step) - index;
            while k < n {
                let t = part.triangles[k / 4];
                let [a, b, c] = t.map(|i| matrix.transform_point3(part.positions[i as usize]));
                out.push([a, b, c, (a + b + c) / 3.0][k % 4]);
                k += step;
            }
            index += n;
        }
    }
    out
}

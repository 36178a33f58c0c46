#![forbid(unsafe_code)]
//! Scenes: what surrounds a reflector, how it is shaded, and where it is seen from.
//!
//! Conventions (every other module relies on them):
//! - World space is right-handed, y up, units are arbitrary but consistent (the built-ins use
//!   metres).
//! - A [`Scene`] keeps meshes in *object space* with a [`Transform`] each, exactly as a scene
//!   file states them; [`Scene::world`] flattens them into world-space triangles.
//! - Colours are linear RGB. MTL `Kd` values are read as linear; `map_Kd` textures are sRGB
//!   encoded 8-bit images, decoded to linear before filtering (as an `*_SRGB` Vulkan format does).
//! - Texture coordinates follow OBJ: `u` to the right, `v` up. Image row 0 is the top, so a
//!   texel is looked up at `(u, 1 - v)`.
//! - Normals are never flipped towards the viewer: a mirror reflects about its interpolated vertex
//!   normal as stored, which is what the rasteriser will interpolate too.

pub mod animation;
pub mod builtin;
pub mod convexity;
mod error;
pub mod export;
mod file;
pub mod gpu_data;
mod limits;
mod obj;
mod report;
pub mod shapes;
mod source;
mod world;

pub use error::SceneError;
pub use file::{check_resolution, load_scene_file, load_scene_file_report};
pub use obj::MAX_INPUT_BYTES;
pub use report::{LoadReport, LoadWarning, WarningKind};
pub use world::{NO_ID, ObjectInfo, WorldGeometry, closest_point_on_triangle};

use glam::{EulerRot, Mat3, Mat4, Quat, Vec2, Vec3};
use std::path::Path;

use crate::camera::Camera;
use crate::shading::Shading;
// Materials and textures are shading data; the scene holds them under its own name too.
pub use crate::shading::{Material, Texture};

/// Largest accepted image side, in pixels. Larger requests are rejected as absurd: a single
/// 16384² frame already needs several GiB for the per-pixel outputs.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// Largest accepted cubemap face size (texels per side).
pub const MAX_CUBE_SIZE: u32 = 4096;

/// Most CMOs a scene may have (`[cmo] count`, the number of `[cmo] centres`, `render --cmos`).
/// The GPU code is proven for this many: the compute path's step cap `MAX_STEPS` in
/// `spirv/compute_trace.wgsl` holds `MAX_ROUNDS * 16` traces of a ray, and `6 * 16 = 96`
/// cube faces stay within the 256 image array layers every Vulkan device offers.
pub const MAX_CMOS: u32 = 16;

/// CMOs the placement search may use where the scene gives no `count` (a scene file without
/// `[cmo]` centres): [`CmoPlacement::Search`]'s default budget.
pub const DEFAULT_SEARCH_CMOS: u32 = 8;

/// Largest magnitude of a coordinate a scene may hold, 2^60 (about 1.15e18): a vertex in an
/// OBJ file (object space), a mesh's vertex after its transform (world space), a camera's
/// `eye` and `target`, a CMO centre. The tracer squares distances in f32, and `(4 * 2^60)^2` is
/// still finite; `cubetrace::ranges::MAX_EXTENT` refuses a larger frame with the same bound.
pub const MAX_COORDINATE: f32 = (1u64 << 60) as f32;

/// Largest linear colour value a scene may hold: 65504, the largest half float (an EXR viewer
/// or a 16-bit float pipeline can hold every colour a scene gives). `background`, MTL `Kd` and
/// `light_intensity` lie in `[0, MAX_COLOUR]`.
pub const MAX_COLOUR: f32 = 65504.0;

/// A mesh must span, in world space, at least `2^-21` of the largest coordinate that meets it:
/// its own farthest vertex from the origin, a camera's eye, a CMO centre. Coordinates round to
/// `2^-24` of their magnitude in f32, so above the bound that rounding stays within 1/8 of the
/// mesh's size (the share `cubetrace::ranges` allows of a texel's footprint); a smaller mesh
/// collapses (`scale = 1e-20` turns the teapot into a point) and is refused, naming its
/// transform. (How well a mirror is resolved against the CMOs is `ranges`' finer check.)
pub const MIN_RELATIVE_SIZE: f32 = 1.0 / (1u32 << 21) as f32;

/// A complete scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub name: String,
    pub meshes: Vec<MeshInstance>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub cameras: Vec<Camera>,
    pub cmo: CmoSpec,
    /// Colour of rays that leave the scene (linear RGB).
    pub background: Vec3,
    pub shading: Shading,
    /// Whether reflectors see themselves: decided per reflector by default
    /// ([`SelfReflections::Auto`], see [`Scene::self_capture`]). A reflector without
    /// self-capture is left out of the cubemap capture; when no reflector has it, the capture
    /// allocates no mirror mask or normal cubemaps.
    pub self_reflections: SelfReflections,
    /// Samples per pixel and pixel filter (the scene file's `[film]`).
    pub film: crate::film::FilmSettings,
    /// Keyframes, frame rate and default frame range (the scene file's `[animation]`).
    pub animation: animation::Animation,
}

/// The scene file's `self_reflections`: `"auto"` (the default), `true` or `false`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SelfReflections {
    /// A reflector captures itself exactly when it can see itself: when it is not convex
    /// ([`convexity::is_convex`] on its world-space triangles, all parts together).
    #[default]
    Auto,
    /// Every reflector captures itself.
    On,
    /// No reflector captures itself.
    Off,
}

impl Scene {
    /// Per mesh of [`Scene::meshes`]: whether the cubemap capture draws it as a reflector that
    /// sees itself (false for every non-reflector).
    pub fn self_capture(&self) -> Vec<bool> {
        self.meshes
            .iter()
            .map(|mesh| {
                mesh.reflector
                    && match self.self_reflections {
                        SelfReflections::On => true,
                        SelfReflections::Off => false,
                        SelfReflections::Auto => {
                            let (positions, normals, triangles) = mesh.world_mesh();
                            let turned = self.front_turned(mesh);
                            !convexity::is_convex_front(&positions, &normals, &triangles, turned)
                        }
                    }
            })
            .collect()
    }

    /// Per mesh of [`Scene::meshes`]: whether the GPU's reflector check
    /// (`RenderOptions::reflector_check` in `cubetrace::vk::frame`) traces its triangles exactly after
    /// the cubemap trace: every reflector, since a mirror ray can meet a reflector (another one,
    /// or itself: a non-convex one anywhere, a convex one where the ray leaves below its face,
    /// [`Scene::check_below`]), whatever the capture draws: the reference traces every triangle.
    /// But where the frame traces the bounded criterion's lists (`lists`), a reflector that the
    /// capture takes ([`Scene::self_capture`]) is in them with sound bounds, so the trace meets it
    /// first where it is first, as every other captured triangle: only the others are checked.
    pub fn check_reflectors(&self, lists: bool) -> Vec<bool> {
        let captured = if lists {
            self.self_capture()
        } else {
            vec![false; self.meshes.len()]
        };
        (self.meshes.iter().zip(captured))
            .map(|(mesh, captured)| mesh.reflector && !captured)
            .collect()
    }

    /// Which mirror rays the reflector check traces: those whose direction `d` has
    /// `d . n < check_below` with `n` the pixel's normalised interpolated normal. 2 (every unit
    /// ray) when the scene has several reflectors or a non-convex one. With one convex reflector
    /// (every vertex on or behind every face's plane, [`convexity::is_convex`]) a ray that leaves
    /// a face on the front of its plane (`d . n_face >= 0`) never meets the mesh again, and
    /// `d . n_face < 0` implies `d . n < 2 sin(theta / 2)`, `theta` the largest angle between a
    /// face's normal and its vertex normals ([`convexity::max_normal_deviation`]; the interpolated
    /// normal lies within it): only the rays below that bound, plus a 2^-10 slack for the
    /// rounding of the G-buffer's normal and of the convexity test's tolerance, are traced (the
    /// grazing ones near the outline, which interpolated normals send into the mirror).
    pub fn check_below(&self) -> f32 {
        let reflectors: Vec<&MeshInstance> = self.meshes.iter().filter(|m| m.reflector).collect();
        let [one] = reflectors.as_slice() else {
            return 2.0;
        };
        let (positions, normals, triangles) = one.world_mesh();
        // A front against the normals (`front_turned`): the bound holds for the outward normal,
        // and the G-buffer's is the other one, so every ray is traced.
        let turned = self.front_turned(one);
        if turned || !convexity::is_convex_front(&positions, &normals, &triangles, turned) {
            return 2.0;
        }
        let theta = convexity::max_normal_deviation(&positions, &normals, &triangles);
        (2.0 * (0.5 * theta).sin() + 1.0 / 1024.0) as f32
    }

    /// The global triangle indices (in [`WorldGeometry`] order: meshes, then their parts) of the
    /// meshes [`Scene::check_reflectors`] selects for `lists`; empty when none is.
    pub fn check_triangles(&self, lists: bool) -> Vec<u32> {
        let mut triangles = Vec::new();
        let mut first = 0u32;
        for (mesh, check) in self.meshes.iter().zip(self.check_reflectors(lists)) {
            for part in &mesh.parts {
                let n = part.triangles.len() as u32;
                if check {
                    triangles.extend(first..first + n);
                }
                first += n;
            }
        }
        triangles
    }

    /// The names of the glossy reflectors: reflector meshes with a part whose material has a
    /// specular power below the mirror cap ([`crate::lobe::glossy`]). What decides, on the scene
    /// side, whether a frame creates anything for the lobe (the uploaded data's twin:
    /// `vk::methods::technique::has_glossy_reflector`).
    pub fn glossy_reflectors(&self) -> Vec<&str> {
        (self.meshes.iter())
            .filter(|m| {
                m.reflector
                    && (m.parts.iter()).any(|p| {
                        crate::lobe::glossy(self.materials[p.material as usize].specular_power)
                            .is_some()
                    })
            })
            .map(|m| m.name.as_str())
            .collect()
    }

    /// Makes every reflector glossy with Phong specular power `power` (a mirror again at or above
    /// [`crate::lobe::MIRROR_POWER`]): each material a reflector's parts use is copied once, with
    /// the power, and the parts take the copy, so that a material a non-reflector shares keeps
    /// its own (none). The harness's roughness rows and the glossy built-in scene use it.
    pub fn make_reflectors_glossy(&mut self, power: f32) {
        let mut copies: Vec<(u32, u32)> = Vec::new();
        for m in 0..self.meshes.len() {
            if !self.meshes[m].reflector {
                continue;
            }
            for k in 0..self.meshes[m].parts.len() {
                let old = self.meshes[m].parts[k].material;
                let new = match copies.iter().find(|(o, _)| *o == old) {
                    Some(&(_, n)) => n,
                    None => {
                        let mut material = self.materials[old as usize].clone();
                        material.name = format!("{}-glossy", material.name);
                        material.specular_power = Some(power);
                        self.materials.push(material);
                        let n = self.materials.len() as u32 - 1;
                        copies.push((old, n));
                        n
                    }
                };
                self.meshes[m].parts[k].material = new;
            }
        }
    }

    /// Whether some reflector captures itself: then the capture records the mirror mask and
    /// normals.
    pub fn captures_reflectors(&self) -> bool {
        self.self_capture().into_iter().any(|c| c)
    }

    /// Whether a reflector's front, the side a reflected ray can come from, is against its
    /// vertex normals: they point into its closed mesh ([`convexity::normals_inward`], common
    /// in exported files) and no camera of the scene lies inside it ([`convexity::encloses`];
    /// a mirror room seen from inside keeps its normals). The reference, which reflects on
    /// either side, needs no such rule; the capture's self test, the convexity test and the
    /// reflection-point search use it.
    pub fn front_turned(&self, mesh: &MeshInstance) -> bool {
        if !mesh.reflector || !mesh.normals_inward() {
            return false;
        }
        let (positions, _, triangles) = mesh.world_mesh();
        !self
            .cameras
            .iter()
            .any(|c| convexity::encloses(&positions, &triangles, c.eye))
    }
}

impl MeshInstance {
    /// [`convexity::is_convex`] of all its parts together, in world space.
    pub fn is_convex(&self) -> bool {
        let (positions, normals, triangles) = self.world_mesh();
        convexity::is_convex(&positions, &normals, &triangles)
    }

    /// [`convexity::normals_inward`] of all its parts together, in world space: a closed mesh
    /// whose vertex normals point into it.
    pub fn normals_inward(&self) -> bool {
        let (positions, normals, triangles) = self.world_mesh();
        convexity::normals_inward(&positions, &normals, &triangles)
    }

    /// All its parts together in world space: positions, unit normals (one per position) and
    /// triangles.
    fn world_mesh(&self) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
        let m = self.transform.matrix();
        let nm = self.transform.normal_matrix();
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut triangles = Vec::new();
        for part in &self.parts {
            let base = positions.len() as u32;
            positions.extend(part.positions.iter().map(|&p| m.transform_point3(p)));
            normals.extend(part.normals.iter().map(|&n| (nm * n).normalize_or_zero()));
            triangles.extend(part.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        (positions, normals, triangles)
    }
}

/// One mesh of a scene file: an OBJ file placed by a transform.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshInstance {
    pub name: String,
    /// One part per OBJ object/material group, in object space.
    pub parts: Vec<MeshPart>,
    pub transform: Transform,
    pub reflector: bool,
}

/// An indexed triangle list with one material, in object space.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MeshPart {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// One unit normal per position.
    pub normals: Vec<Vec3>,
    /// Empty, or one texture coordinate per position.
    pub uvs: Vec<Vec2>,
    /// Empty, or one colour per position as an OBJ's `v x y z r g b` holds it: sRGB-encoded,
    /// as Blender writes it (and MeshLab and Open3D store 8-bit colours), decoded to linear
    /// RGB in the world ([`crate::scene::WorldGeometry::colours`]), where it multiplies the
    /// material's colour.
    pub colours: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Where the triangles come from, for messages: `None` for built-in geometry.
    pub source: Option<PartSource>,
}

/// The file a loaded [`MeshPart`] comes from and the line of each triangle's face in it.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct PartSource {
    pub file: std::path::PathBuf,
    /// One per triangle of the part, as loaded (empty after an edit that changed them).
    pub lines: Vec<u32>,
}

impl MeshPart {
    /// `file:line` of triangle `k`'s face, where the part was loaded from a file and its
    /// triangles are still those loaded.
    pub fn source_line(&self, k: usize) -> Option<String> {
        let s = self.source.as_ref()?;
        let line = s
            .lines
            .get(k)
            .filter(|_| s.lines.len() == self.triangles.len())?;
        Some(format!("{}:{line}", s.file.display()))
    }
}

/// Object-to-world placement: scale, then rotate (Euler X, then Y, then Z, in degrees), then
/// translate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub translate: Vec3,
    pub rotate_deg: Vec3,
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self {
            translate: Vec3::ZERO,
            rotate_deg: Vec3::ZERO,
            scale: Vec3::ONE,
        }
    }
}

impl Transform {
    pub fn translation(t: Vec3) -> Self {
        Self {
            translate: t,
            ..Self::default()
        }
    }

    pub fn matrix(&self) -> Mat4 {
        let r = self.rotate_deg * (std::f32::consts::PI / 180.0);
        // Intrinsic order as documented: rotate about X first, then Y, then Z (R = Rz Ry Rx).
        let rot = Quat::from_euler(EulerRot::ZYX, r.z, r.y, r.x);
        Mat4::from_scale_rotation_translation(self.scale, rot, self.translate)
    }

    /// The matrix that maps object-space normals to world space (inverse transpose).
    pub fn normal_matrix(&self) -> Mat3 {
        Mat3::from_mat4(self.matrix()).inverse().transpose()
    }
}

/// Where the cubemap objects (CMOs) go, and their face size.
#[derive(Clone, Debug, PartialEq)]
pub struct CmoSpec {
    pub placement: CmoPlacement,
    /// Texels per cube face side.
    pub resolution: u32,
    /// The bounded lists' face size that `--list-size auto` takes instead of its rule: set by
    /// the placement search where it judged its centres with shorter lists
    /// ([`crate::placement::Placement::list_size`]); `None` in a scene file.
    pub lists: Option<u32>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum CmoPlacement {
    /// Centres given in world space.
    Explicit(Vec<Vec3>),
    /// `count` centres spread along the longest axis of the reflectors' bounding box.
    Auto { count: u32 },
    /// Up to `count` centres chosen for the cameras by the search in `cubetrace::placement`
    /// (`[cmo] placement = "auto"`, and the default of a scene file without `[cmo]` centres:
    /// up to [`DEFAULT_SEARCH_CMOS`]). `render`, sequences and the bench resolve it once for the
    /// cameras they render (`placement::resolve_for`); unresolved, [`Scene::cmo_centres`] gives
    /// one CMO on the axis placement.
    Search { count: u32 },
}

impl Scene {
    /// The scene in coordinates relative to `anchor` (`crate::ranges::anchor`), for the GPU:
    /// every mesh baked into its world placement (its world positions, as [`Scene::world`]
    /// rounds them, minus `anchor`, rounded once more; identity transforms), and the cameras'
    /// points and explicit CMO centres moved alike; no animation (the GPU renders one frame of
    /// it). Where `anchor` lies within a factor 2 of every coordinate on each axis (a scene far
    /// from the world origin, [`crate::ranges`]), each subtraction is exact: the same geometry
    /// as the reference's, in coordinates f32 resolves finely.
    pub fn rebased(&self, anchor: Vec3) -> Scene {
        let a = anchor.as_dvec3();
        let local = |p: Vec3| (p.as_dvec3() - a).as_vec3();
        let mut s = Scene {
            animation: Default::default(),
            ..self.clone()
        };
        for mesh in &mut s.meshes {
            let m = mesh.transform.matrix();
            let nm = mesh.transform.normal_matrix();
            for part in &mut mesh.parts {
                for p in &mut part.positions {
                    *p = local(m.transform_point3(*p));
                }
                for n in &mut part.normals {
                    *n = (nm * *n).normalize_or_zero();
                }
            }
            mesh.transform = Transform::default();
        }
        for c in &mut s.cameras {
            *c = c.rebased(anchor);
        }
        if let CmoPlacement::Explicit(centres) = &mut s.cmo.placement {
            centres.iter_mut().for_each(|c| *c = local(*c));
        }
        s
    }

    /// Flattens all meshes into world space (see [`WorldGeometry`]).
    pub fn world(&self) -> WorldGeometry {
        WorldGeometry::build(self)
    }

    /// The CMO centres in world space. A [`CmoPlacement::Search`] not yet resolved for a camera
    /// (`cubetrace::placement::resolve`, which `render` and the bench run first) gives the axis
    /// placement of one CMO: the scene is data and runs no search itself.
    pub fn cmo_centres(&self) -> Vec<Vec3> {
        match &self.cmo.placement {
            CmoPlacement::Explicit(c) => c.clone(),
            CmoPlacement::Auto { count } => self.axis_centres(*count),
            CmoPlacement::Search { .. } => self.axis_centres(1),
        }
    }

    /// `count` centres spread along the longest axis of the reflectors' bounding box (of the
    /// whole scene without reflectors): [`CmoPlacement::Auto`].
    pub fn axis_centres(&self, count: u32) -> Vec<Vec3> {
        self.world().axis_centres(count)
    }

    /// Picks a camera by name or index (`None`: the first).
    pub fn camera(&self, which: Option<&str>) -> Result<&Camera, SceneError> {
        let Some(which) = which else {
            return self.cameras.first().ok_or_else(|| SceneError::Invalid {
                file: self.name.clone(),
                field: "camera".into(),
                reason: "the scene has no camera".into(),
            });
        };
        if let Ok(i) = which.parse::<usize>()
            && let Some(c) = self.cameras.get(i)
        {
            return Ok(c);
        }
        self.cameras
            .iter()
            .find(|c| c.name == which)
            .ok_or_else(|| SceneError::Invalid {
                file: self.name.clone(),
                field: "camera".into(),
                reason: format!(
                    "no camera named or numbered '{which}' (cameras: {})",
                    self.cameras
                        .iter()
                        .enumerate()
                        .map(|(i, c)| format!("{i}: {}", c.name))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            })
    }

    /// Compares two scenes by content: geometry, resolved materials and textures, cameras, CMOs,
    /// background and shading. Material and texture *order* and names of files do not matter.
    /// Returns the first difference found.
    pub fn compare_content(&self, other: &Scene) -> Result<(), String> {
        macro_rules! same {
            ($a:expr, $b:expr, $what:expr) => {
                if $a != $b {
                    return Err(format!("{}: {:?} != {:?}", $what, $a, $b));
                }
            };
        }
        same!(self.meshes.len(), other.meshes.len(), "mesh count");
        for (i, (a, b)) in self.meshes.iter().zip(&other.meshes).enumerate() {
            same!(a.transform, b.transform, format!("mesh[{i}].transform"));
            same!(a.reflector, b.reflector, format!("mesh[{i}].reflector"));
            same!(
                a.parts.len(),
                b.parts.len(),
                format!("mesh[{i}] part count")
            );
            for (j, (p, q)) in a.parts.iter().zip(&b.parts).enumerate() {
                let w = format!("mesh[{i}].part[{j}]");
                // Compare the triangle soup: vertex order and unused vertices do not matter.
                same!(
                    p.triangles.len(),
                    q.triangles.len(),
                    format!("{w} triangle count")
                );
                for (k, (s, t)) in p.triangles.iter().zip(&q.triangles).enumerate() {
                    for c in 0..3 {
                        let (i, j) = (s[c] as usize, t[c] as usize);
                        let w = format!("{w}.triangle[{k}] corner {c}");
                        same!(p.positions[i], q.positions[j], format!("{w} position"));
                        same!(p.normals[i], q.normals[j], format!("{w} normal"));
                        same!(p.uvs.get(i), q.uvs.get(j), format!("{w} uv"));
                        same!(p.colours.get(i), q.colours.get(j), format!("{w} colour"));
                    }
                }
                let (ma, mb) = (
                    &self.materials[p.material as usize],
                    &other.materials[q.material as usize],
                );
                same!(ma.diffuse, mb.diffuse, format!("{w} material diffuse"));
                if a.reflector {
                    same!(
                        crate::lobe::glossy(ma.specular_power),
                        crate::lobe::glossy(mb.specular_power),
                        format!("{w} material specular power")
                    );
                }
                let ta = ma.texture.map(|t| &self.textures[t as usize]);
                let tb = mb.texture.map(|t| &other.textures[t as usize]);
                match (ta, tb) {
                    (None, None) => {}
                    (Some(x), Some(y)) => {
                        same!(
                            (x.width, x.height),
                            (y.width, y.height),
                            format!("{w} texture size")
                        );
                        if x.rgba8 != y.rgba8 {
                            return Err(format!("{w} texture pixels differ"));
                        }
                    }
                    _ => return Err(format!("{w}: texture present on one side only")),
                }
            }
        }
        same!(self.cameras, other.cameras, "cameras");
        same!(self.cmo, other.cmo, "cmo");
        same!(self.background, other.background, "background");
        same!(self.shading, other.shading, "shading");
        same!(
            self.self_reflections,
            other.self_reflections,
            "self_reflections"
        );
        same!(self.film, other.film, "film");
        same!(self.animation, other.animation, "animation");
        Ok(())
    }
}

/// File extensions of meshes and their materials, which a scene file names but which are not one.
const MESH_EXTENSIONS: [&str; 10] = [
    "obj", "mtl", "gltf", "glb", "fbx", "ply", "stl", "dae", "blend", "usd",
];

/// Loads a scene given a built-in name or a path to a `.toml` scene file.
pub fn load(name_or_path: &str) -> Result<Scene, SceneError> {
    let path = Path::new(name_or_path);
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if ext.is_some_and(|e| MESH_EXTENSIONS.contains(&e.as_str())) {
        return Err(SceneError::NotASceneFile {
            path: path.to_path_buf(),
        });
    }
    let looks_like_path = name_or_path.ends_with(".toml")
        || name_or_path.contains('/')
        || name_or_path.contains(std::path::MAIN_SEPARATOR);
    if looks_like_path {
        return load_scene_file(path);
    }
    builtin::by_name(name_or_path).ok_or_else(|| SceneError::UnknownScene {
        name: name_or_path.to_string(),
        known: builtin::all().map(|(n, _)| n.to_string()).collect(),
    })
}

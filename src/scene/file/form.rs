#![forbid(unsafe_code)]
//! The scene file's form: the TOML tables as serde reads and writes them ([`SceneFile`] and its
//! parts, every value with its span for messages), and the readers that refuse arrays of the
//! wrong length, the `[animation]` table's included. What the values may be is checked on load
//! (`super`, `animation_table`).

use std::path::PathBuf;

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};
use toml::Spanned;

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneFile {
    pub name: Option<String>,
    #[serde(default = "default_background", deserialize_with = "exact")]
    pub background: Spanned<[f32; 3]>,
    pub self_reflections: Option<Spanned<SelfReflectionsFile>>,
    #[serde(default)]
    pub shading: ShadingFile,
    #[serde(rename = "mesh", default)]
    pub meshes: Vec<MeshFile>,
    #[serde(rename = "camera", default)]
    pub cameras: Vec<CameraFile>,
    pub cmo: Option<CmoFile>,
    pub film: Option<FilmFile>,
    pub animation: Option<AnimationFile>,
}

/// `self_reflections`: a TOML boolean, or the string `"auto"` (checked on load).
#[derive(Debug, Deserialize, Serialize, Clone, PartialEq, Eq)]
#[serde(untagged)]
pub(crate) enum SelfReflectionsFile {
    Bool(bool),
    Word(String),
}

fn default_background() -> Spanned<[f32; 3]> {
    Spanned::new(0..0, [0.0; 3])
}

#[derive(Debug, Deserialize, Serialize, Clone, Copy, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub(crate) enum ShadingModel {
    Unlit,
    #[default]
    Lambert,
}

#[derive(Debug, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct ShadingFile {
    #[serde(default)]
    pub model: ShadingModel,
    pub ambient: Option<Spanned<f32>>,
    #[serde(default, deserialize_with = "exact_opt")]
    pub light_direction: Option<Spanned<[f32; 3]>>,
    pub light_intensity: Option<Spanned<f32>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MeshFile {
    pub name: Option<Spanned<String>>,
    pub obj: Spanned<PathBuf>,
    /// `true` (the whole OBJ is a mirror), `false`, or the names of the OBJ's objects, groups or
    /// materials that are (checked on load).
    #[serde(default = "not_reflector")]
    pub reflector: Spanned<ReflectorFile>,
    /// A reflector's glossiness (see [`Gloss`](super::Gloss)): a Phong specular power, or `"mtl"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specular_power: Option<Spanned<SpecularPowerFile>>,
    #[serde(default)]
    pub transform: TransformFile,
}

/// `reflector`: a TOML boolean, or a list of names.
#[derive(Debug, Serialize, Clone, PartialEq)]
#[serde(untagged)]
pub(crate) enum ReflectorFile {
    Whole(bool),
    Parts(Vec<String>),
}

/// Read by hand, so that a wrong value's message says what `reflector` takes (an untagged
/// enum's names only itself).
impl<'de> Deserialize<'de> for ReflectorFile {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Reflector;
        impl<'de> serde::de::Visitor<'de> for Reflector {
            type Value = ReflectorFile;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("true, false, or a list of the OBJ's object, group or material names")
            }
            fn visit_bool<E: serde::de::Error>(self, b: bool) -> Result<Self::Value, E> {
                Ok(ReflectorFile::Whole(b))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<Self::Value, A::Error> {
                let mut names = Vec::new();
                while let Some(name) = seq.next_element::<String>()? {
                    names.push(name);
                }
                Ok(ReflectorFile::Parts(names))
            }
        }
        d.deserialize_any(Reflector)
    }
}

fn not_reflector() -> Spanned<ReflectorFile> {
    Spanned::new(0..0, ReflectorFile::Whole(false))
}

/// `specular_power`: a TOML number, or the string `"mtl"` (checked on load).
#[derive(Debug, Deserialize, Serialize, Clone, PartialEq)]
#[serde(untagged)]
pub(crate) enum SpecularPowerFile {
    Number(f32),
    Word(String),
}

#[derive(Debug, Deserialize, Serialize, Clone, Copy)]
#[serde(untagged)]
pub(crate) enum ScaleFile {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TransformFile {
    #[serde(default = "zero3", deserialize_with = "exact")]
    pub translate: Spanned<[f32; 3]>,
    #[serde(default = "zero3", deserialize_with = "exact")]
    pub rotate_deg: Spanned<[f32; 3]>,
    #[serde(default = "one", deserialize_with = "scale_value")]
    pub scale: Spanned<ScaleFile>,
}

fn zero3() -> Spanned<[f32; 3]> {
    Spanned::new(0..0, [0.0; 3])
}
fn one() -> Spanned<ScaleFile> {
    Spanned::new(0..0, ScaleFile::Uniform(1.0))
}

impl Default for TransformFile {
    fn default() -> Self {
        Self {
            translate: zero3(),
            rotate_deg: zero3(),
            scale: one(),
        }
    }
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraFile {
    pub name: Option<Spanned<String>>,
    #[serde(deserialize_with = "exact")]
    pub eye: Spanned<[f32; 3]>,
    #[serde(deserialize_with = "exact")]
    pub target: Spanned<[f32; 3]>,
    #[serde(default = "up", deserialize_with = "exact")]
    pub up: Spanned<[f32; 3]>,
    #[serde(default = "fov")]
    pub fov_y_deg: Spanned<f32>,
    #[serde(deserialize_with = "exact")]
    pub resolution: Spanned<[u32; 2]>,
}

fn up() -> Spanned<[f32; 3]> {
    Spanned::new(0..0, [0.0, 1.0, 0.0])
}
fn fov() -> Spanned<f32> {
    Spanned::new(0..0, 50.0)
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CmoFile {
    #[serde(default, deserialize_with = "exact_list_opt")]
    pub centres: Option<Spanned<Vec<[f32; 3]>>>,
    pub count: Option<Spanned<u32>>,
    /// With `count`: `"axis"` (the default: along the reflectors' longest axis) or `"auto"`
    /// (searched for the camera by `cubetrace::placement`).
    pub placement: Option<Spanned<String>>,
    #[serde(default = "cube_res")]
    pub resolution: Spanned<u32>,
}

/// `[film]`: samples per pixel and the pixel filter.
#[derive(Debug, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct FilmFile {
    pub spp: Option<Spanned<u32>>,
    pub filter: Option<Spanned<String>>,
}

fn cube_res() -> Spanned<u32> {
    Spanned::new(0..0, 256)
}

/// `items` as an array of exactly `N` (serde's own array impl does not refuse extra items).
fn exact_array<T, const N: usize, E: serde::de::Error>(items: Vec<T>) -> Result<[T; N], E> {
    let n = items.len();
    items.try_into().map_err(|_| {
        E::custom(format!(
            "expected an array of exactly {N} numbers, found {n}"
        ))
    })
}

fn exact<'de, D, T, const N: usize>(d: D) -> Result<Spanned<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let v = Spanned::<Vec<T>>::deserialize(d)?;
    let span = v.span();
    Ok(Spanned::new(span, exact_array(v.into_inner())?))
}

fn exact_opt<'de, D, T, const N: usize>(d: D) -> Result<Option<Spanned<[T; N]>>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    exact(d).map(Some)
}

/// `cmo.centres`: a list of arrays of exactly `N`.
type SpannedList<T, const N: usize> = Option<Spanned<Vec<[T; N]>>>;

fn exact_list_opt<'de, D, T, const N: usize>(d: D) -> Result<SpannedList<T, N>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let v = Spanned::<Vec<Vec<T>>>::deserialize(d)?;
    let span = v.span();
    let items = v
        .into_inner()
        .into_iter()
        .map(exact_array)
        .collect::<Result<Vec<_>, D::Error>>()?;
    Ok(Some(Spanned::new(span, items)))
}

/// `scale`: one number, or an array of exactly 3.
fn scale_value<'de, D: Deserializer<'de>>(d: D) -> Result<Spanned<ScaleFile>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Raw {
        Uniform(f32),
        PerAxis(Vec<f32>),
    }
    let v = Spanned::<Raw>::deserialize(d)
        .map_err(|_| D::Error::custom("scale must be a number or an array of 3 numbers"))?;
    let span = v.span();
    Ok(Spanned::new(
        span,
        match v.into_inner() {
            Raw::Uniform(s) => ScaleFile::Uniform(s),
            Raw::PerAxis(s) => ScaleFile::PerAxis(exact_array(s)?),
        },
    ))
}

fn scale_opt<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Spanned<ScaleFile>>, D::Error> {
    scale_value(d).map(Some)
}

/// `[animation]`: frame rate, default range, interpolation and the tracks.
#[derive(Debug, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct AnimationFile {
    pub fps: Option<Spanned<f64>>,
    #[serde(default, deserialize_with = "exact_opt")]
    pub frames: Option<Spanned<[i64; 2]>>,
    pub interpolation: Option<Spanned<String>>,
    #[serde(rename = "camera", default, skip_serializing_if = "Vec::is_empty")]
    pub cameras: Vec<Spanned<CameraTrackFile>>,
    #[serde(rename = "mesh", default, skip_serializing_if = "Vec::is_empty")]
    pub meshes: Vec<Spanned<MeshTrackFile>>,
}

/// `[[animation.camera]]`: the keys of one camera (by name; default the first).
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraTrackFile {
    pub camera: Option<Spanned<String>>,
    #[serde(rename = "key", default)]
    pub keys: Vec<Spanned<CameraKeyFile>>,
}

#[derive(Debug, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraKeyFile {
    pub time: Option<Spanned<f64>>,
    #[serde(default, deserialize_with = "exact_opt")]
    pub eye: Option<Spanned<[f32; 3]>>,
    #[serde(default, deserialize_with = "exact_opt")]
    pub target: Option<Spanned<[f32; 3]>>,
    #[serde(default, deserialize_with = "exact_opt")]
    pub up: Option<Spanned<[f32; 3]>>,
    pub fov_y_deg: Option<Spanned<f32>>,
}

/// `[[animation.mesh]]`: the transform keys of one mesh (by name).
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MeshTrackFile {
    pub mesh: Spanned<String>,
    #[serde(rename = "key", default)]
    pub keys: Vec<Spanned<MeshKeyFile>>,
}

#[derive(Debug, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct MeshKeyFile {
    pub time: Option<Spanned<f64>>,
    #[serde(default, deserialize_with = "exact_opt")]
    pub translate: Option<Spanned<[f32; 3]>>,
    #[serde(default, deserialize_with = "exact_opt")]
    pub rotate_deg: Option<Spanned<[f32; 3]>>,
    #[serde(default, deserialize_with = "scale_opt")]
    pub scale: Option<Spanned<ScaleFile>>,
}

#![forbid(unsafe_code)]
//! Image output: 8-bit sRGB PNG and 32-bit float EXR, always written atomically
//! ([`crate::files`]), so that an error never leaves a half-written file behind.
//!
//! EXR channels, with one meaning on every method (the reference, [`frame_channels`], and every
//! GPU method, [`traced_channels`]):
//! - `R`, `G`, `B` (f32): linear colour.
//! - `mask` (f32): 1 on mirror pixels (the primary ray hits a reflector).
//! - `P.X`, `P.Y`, `P.Z` (f32): world position seen by the primary ray (NaN where none).
//! - `hit.X`, `hit.Y`, `hit.Z` (f32): on mirror pixels, the hit whose colour the pixel shows:
//!   its path's last hit, which is the first reflected hit for one bounce (the default) and the
//!   mirror itself for `--bounces 0` (what a GPU record holds, [`Frame::shown_hit`]); NaN where
//!   the path left the scene, off the mirrors, and where a GPU method left the pixel unresolved.
//! - `object_id`, `primitive_id` (u32): the triangle of that same hit in the scene's one
//!   numbering ([`crate::scene::WorldGeometry::ids`]): `object_id` is the index of the object
//!   (a mesh part, in scene order: meshes, then their parts), `primitive_id` the triangle's
//!   index within that object's triangle list as loaded; 4294967295 where there is no hit. GPU
//!   records name a global triangle (an index into the scene's whole triangle list, the GPU
//!   scene data's order); the writer maps it to these IDs. GPU methods that do not name the
//!   triangle they hit (no centre criterion) write neither channel.
//! - `bounces` (u32): the reflections the pixel's path took.
//! - GPU frames only: `unresolved` (f32, 1 on mirror pixels no CMO could decide) and, with the
//!   BVH tracer (`bvh`, `--fallback trace`), `fallback` (f32, 1 where the BVH finished the ray
//!   of a pixel the method left unresolved; `unresolved` is then 0 there).
//!
//! At several samples per pixel (`--spp N`, [`crate::film`]) `R`, `G`, `B` are the filtered
//! colour; every other channel is that of one sample, the one nearest the pixel centre
//! ([`crate::film::aov_sample`]), never a blend: `object_id` names a triangle the pixel shows.

use std::path::Path;

use anyhow::{Context, Result, bail};
use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, Image, WritableImage};
use glam::Vec3;

use crate::metrics::Traced;
use crate::reference::Frame;
use crate::scene::WorldGeometry;
use crate::shading::linear_to_srgb;

// The atomic writes live in the leaf module `files` (the scene export uses them too); they stay
// reachable here, where the image writers' callers look for them.
pub use crate::files::{MAX_STEM, safe_file_stem, write_atomic, write_atomic_with};

/// The nearest folder of `path`'s ancestors that exists (`.` for a relative path with none).
fn existing_ancestor(path: &Path) -> &Path {
    let mut dir = path;
    while !dir.as_os_str().is_empty() {
        if std::fs::symlink_metadata(dir).is_ok() {
            return dir;
        }
        match dir.parent() {
            Some(p) => dir = p,
            None => break,
        }
    }
    Path::new(".")
}

/// Checks, before any work, that files can be written into the folder `dir` (created later if
/// needed): its nearest existing ancestor must be a folder in which a file can be created (an
/// empty file is created and removed at once).
pub fn check_folder(dir: &Path) -> Result<()> {
    let base = existing_ancestor(dir);
    if !base.is_dir() {
        bail!(
            "cannot write into {}: {} is not a folder",
            dir.display(),
            base.display()
        );
    }
    // A file of our own, created and removed at once (the OS error says why, if it cannot be).
    let probe = base.join(format!(
        ".cubetrace-check-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos())
    ));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .map_err(|e| {
            anyhow::anyhow!(
                "cannot write into {}: cannot create a file in {}: {e}",
                dir.display(),
                base.display(),
            )
        })?;
    std::fs::remove_file(&probe)
        .with_context(|| format!("cannot remove the test file {}", probe.display()))?;
    Ok(())
}

/// Checks an output image path before the render: a known extension ([`Format`]), not a
/// folder, and a folder it can be written into ([`check_folder`]).
pub fn check_output(path: &Path) -> Result<Format> {
    let format = Format::from_path(path)?;
    if path.is_dir() {
        bail!("output {}: is a folder", path.display());
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    check_folder(dir).with_context(|| format!("output {}", path.display()))?;
    Ok(format)
}

/// The image formats the CLI writes, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Exr,
}

impl Format {
    pub fn from_path(path: &Path) -> Result<Self> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("png") => Ok(Format::Png),
            Some("exr") => Ok(Format::Exr),
            _ => bail!(
                "output {}: unsupported extension (use .png or .exr)",
                path.display()
            ),
        }
    }
}

/// Encodes linear colours as an 8-bit sRGB PNG.
pub fn png_bytes(width: u32, height: u32, colour: &[Vec3]) -> Result<Vec<u8>> {
    let rgb: Vec<u8> = colour
        .iter()
        .flat_map(|c| c.to_array().map(linear_to_srgb))
        .collect();
    let mut png = Vec::new();
    image::write_buffer_with_format(
        &mut std::io::Cursor::new(&mut png),
        &rgb,
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )?;
    Ok(png)
}

/// One named EXR channel.
pub enum Channel {
    F32(Vec<f32>),
    U32(Vec<u32>),
}

/// Writes a multi-channel 32-bit EXR atomically.
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    channels: Vec<(&str, Channel)>,
) -> Result<()> {
    let list = channels
        .into_iter()
        .map(|(name, c)| {
            let samples = match c {
                Channel::F32(v) => FlatSamples::F32(v),
                Channel::U32(v) => FlatSamples::U32(v),
            };
            AnyChannel::new(name, samples)
        })
        .collect();
    let image = Image::from_channels((width as usize, height as usize), AnyChannels::sort(list));
    // The encoder needs `Write + Seek`; encode into memory, then write atomically.
    let mut buf = std::io::Cursor::new(Vec::new());
    image
        .write()
        .non_parallel()
        .to_buffered(&mut buf)
        .with_context(|| format!("cannot encode {}", path.display()))?;
    write_atomic(path, buf.get_ref())
}

/// The `object_id` and `primitive_id` channels of a list of global triangles, in `world`'s
/// numbering (see the module docs).
fn id_channels(world: &WorldGeometry, triangles: &[u32]) -> [(&'static str, Channel); 2] {
    let (objects, primitives) = triangles.iter().map(|&t| world.ids(t)).unzip();
    [
        ("object_id", Channel::U32(objects)),
        ("primitive_id", Channel::U32(primitives)),
    ]
}

/// The EXR channels of a reference frame of the scene whose geometry is `world` (see the module
/// docs).
pub fn frame_channels(frame: &Frame, world: &WorldGeometry) -> Vec<(&'static str, Channel)> {
    let n = frame.colour.len();
    let f = |g: &dyn Fn(usize) -> f32| Channel::F32((0..n).map(g).collect());
    let (hits, triangles): (Vec<Vec3>, Vec<u32>) = (0..n).map(|k| frame.shown_hit(k)).unzip();
    let mut channels = vec![
        ("R", f(&|k| frame.colour[k].x)),
        ("G", f(&|k| frame.colour[k].y)),
        ("B", f(&|k| frame.colour[k].z)),
        ("mask", f(&|k| frame.mask[k] as f32)),
        ("P.X", f(&|k| frame.surface_position[k].x)),
        ("P.Y", f(&|k| frame.surface_position[k].y)),
        ("P.Z", f(&|k| frame.surface_position[k].z)),
        ("hit.X", f(&|k| hits[k].x)),
        ("hit.Y", f(&|k| hits[k].y)),
        ("hit.Z", f(&|k| hits[k].z)),
    ];
    channels.extend(id_channels(world, &triangles));
    channels.push((
        "bounces",
        Channel::U32(frame.bounces.iter().map(|&b| b as u32).collect()),
    ));
    channels
}

/// The EXR channels of a traced (GPU) frame of the scene whose geometry is `world`, with the
/// primary hits `surface_position` (see the module docs).
pub fn traced_channels(
    traced: &Traced,
    surface_position: &[Vec3],
    world: &WorldGeometry,
) -> Vec<(&'static str, Channel)> {
    let n = traced.colour.len();
    let f = |g: &dyn Fn(usize) -> f32| Channel::F32((0..n).map(g).collect());
    let mut channels = vec![
        ("R", f(&|k| traced.colour[k].x)),
        ("G", f(&|k| traced.colour[k].y)),
        ("B", f(&|k| traced.colour[k].z)),
        ("mask", f(&|k| traced.mask[k] as f32)),
        ("P.X", f(&|k| surface_position[k].x)),
        ("P.Y", f(&|k| surface_position[k].y)),
        ("P.Z", f(&|k| surface_position[k].z)),
        ("hit.X", f(&|k| traced.hit_position[k].x)),
        ("hit.Y", f(&|k| traced.hit_position[k].y)),
        ("hit.Z", f(&|k| traced.hit_position[k].z)),
        (
            "unresolved",
            f(&|k| u8::from(traced.mask[k] != 0 && traced.resolved[k] == 0) as f32),
        ),
    ];
    if let Some(triangles) = &traced.triangle {
        channels.extend(id_channels(world, triangles));
    }
    if let Some(fb) = &traced.fallback {
        channels.push(("fallback", f(&|k| f32::from(fb[k]))));
    }
    if let Some(b) = &traced.bounces {
        channels.push(("bounces", Channel::U32(b.clone())));
    }
    channels
}

/// Writes `colour` as an 8-bit sRGB PNG, or as an EXR of the channels `exr` gives (asked for
/// only then), atomically: the one writer of every frame.
pub fn write_image<'a>(
    path: &Path,
    format: Format,
    (width, height): (u32, u32),
    colour: &[Vec3],
    exr: impl FnOnce() -> Vec<(&'a str, Channel)>,
) -> Result<()> {
    match format {
        Format::Png => write_atomic(path, &png_bytes(width, height, colour)?),
        Format::Exr => write_exr(path, width, height, exr()),
    }
}

/// Writes a traced (GPU) frame of the scene whose geometry is `world` as PNG or EXR, chosen by
/// the extension of `path` ([`traced_channels`]).
#[cfg(any(test, feature = "test-hooks"))]
pub fn write_traced(
    path: &Path,
    traced: &Traced,
    surface_position: &[Vec3],
    world: &WorldGeometry,
) -> Result<()> {
    write_image(
        path,
        Format::from_path(path)?,
        (traced.width, traced.height),
        &traced.colour,
        || traced_channels(traced, surface_position, world),
    )
}

/// Writes a reference frame of the scene whose geometry is `world` as PNG or EXR, chosen by the
/// extension of `path` ([`frame_channels`]).
#[cfg(any(test, feature = "test-hooks"))]
pub fn write_frame(path: &Path, frame: &Frame, world: &WorldGeometry) -> Result<()> {
    write_image(
        path,
        Format::from_path(path)?,
        (frame.width, frame.height),
        &frame.colour,
        || frame_channels(frame, world),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect()
    }

    #[test]
    fn output_checks() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        assert!(check_output(&file.join("x.png")).is_err());
        assert!(check_output(&file.join("a/b/x.png")).is_err());
        assert!(check_output(dir.path()).is_err());
        assert!(check_folder(&file).is_err());
        // Negative: a file in an existing or a new folder passes, and the check leaves nothing.
        assert_eq!(
            check_output(&dir.path().join("x.exr")).unwrap(),
            Format::Exr
        );
        assert_eq!(
            check_output(&dir.path().join("new/x.png")).unwrap(),
            Format::Png
        );
        check_folder(&dir.path().join("new/deeper")).unwrap();
        assert_eq!(entries(dir.path()), vec!["file".to_string()]);
    }

    /// Two objects of 2 and 3 triangles: global triangle 3 is object 1's primitive 1.
    fn two_objects() -> WorldGeometry {
        let object = |first_triangle, triangle_count| crate::scene::ObjectInfo {
            name: "o".into(),
            material: 0,
            reflector: false,
            captured: true,
            normals_inward: false,
            specular_power: None,
            vertex_colours: false,
            first_triangle,
            triangle_count,
        };
        WorldGeometry {
            triangles: vec![[0, 0, 0]; 5],
            triangle_object: vec![0, 0, 1, 1, 1],
            objects: vec![object(0, 2), object(2, 3)],
            ..WorldGeometry::default()
        }
    }

    fn u32_channel(path: &Path, name: &str) -> Vec<u32> {
        let img = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
        let ch = &img.layer_data[0].channel_data.list;
        let c = ch.iter().find(|c| c.name.to_string() == name).unwrap();
        (0..c.sample_data.len())
            .map(|k| c.sample_data.value_by_flat_index(k).to_u32())
            .collect()
    }

    #[test]
    fn exr_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        let mut f = Frame::new(3, 2);
        f.colour[4] = Vec3::new(0.25, 2.5, -1.0);
        // A mirror pixel showing global triangle 3, and one that is no mirror (its last hit is
        // the primary hit, which names no reflected hit).
        f.mask[1] = 1;
        f.last_triangle[1] = 3;
        f.last_triangle[2] = 4;
        write_frame(&path, &f, &two_objects()).unwrap();
        let img = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
        let ch = &img.layer_data[0].channel_data.list;
        let g = ch.iter().find(|c| c.name.to_string() == "G").unwrap();
        assert_eq!(g.sample_data.value_by_flat_index(4).to_f32(), 2.5);
        let none = u32::MAX;
        assert_eq!(
            u32_channel(&path, "object_id"),
            [none, 1, none, none, none, none]
        );
        assert_eq!(
            u32_channel(&path, "primitive_id"),
            [none, 1, none, none, none, none]
        );
    }

    /// A GPU frame's global triangles are written in the same numbering as the reference's.
    #[test]
    fn traced_ids_are_mapped_to_object_and_primitive() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        let n = 4;
        let mut traced = Traced {
            width: 2,
            height: 2,
            colour: vec![Vec3::ZERO; n],
            mask: vec![1; n],
            hit_position: vec![Vec3::NAN; n],
            resolved: vec![1; n],
            triangle: Some(vec![0, 2, 4, u32::MAX]),
            fallback: None,
            bounces: None,
        };
        let world = two_objects();
        write_traced(&path, &traced, &[Vec3::ZERO; 4], &world).unwrap();
        assert_eq!(u32_channel(&path, "object_id"), [0, 1, 1, u32::MAX]);
        assert_eq!(u32_channel(&path, "primitive_id"), [0, 0, 2, u32::MAX]);
        // Negative: a frame that names no triangles writes no ID channel.
        traced.triangle = None;
        write_traced(&path, &traced, &[Vec3::ZERO; 4], &world).unwrap();
        let img = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
        let names: Vec<String> = img.layer_data[0]
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert!(!names.iter().any(|c| c.ends_with("_id")), "{names:?}");
    }
}

#![forbid(unsafe_code)]
//! Image output: 8-bit sRGB PNG and 32-bit float EXR, always written atomically (a temporary
//! file in the destination folder, then a rename), so that an error never leaves a half-written
//! file behind.
//!
//! EXR channels of a [`Frame`]: `R`, `G`, `B` (linear colour, f32), `mask` (f32, 1 on reflector
//! pixels), `P.X`, `P.Y`, `P.Z` (world position seen by the primary ray), `hit.X`, `hit.Y`, `hit.Z` (world position of the first reflected hit, f32, NaN where
//! none), `object_id`, `primitive_id` (u32, 4294967295 where none) and `bounces` (u32).

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, bail};
use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, Image, WritableImage};
use glam::Vec3;

use crate::metrics::Traced;
use crate::reference::Frame;
use crate::shading::linear_to_srgb;

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |w| {
        w.write_all(bytes)?;
        Ok(())
    })
}

/// Like [`write_atomic`], with a writer callback. The temporary file is removed if `write`
/// fails.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<&std::fs::File>) -> Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut builder = tempfile::Builder::new();
    builder.prefix(".cubetrace-").suffix(".tmp");
    // A temporary file is private (0600); the finished file gets the usual 0644 (less the
    // umask), as a plain create would.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o644));
    let tmp = builder
        .tempfile_in(dir)
        .with_context(|| format!("cannot create a temporary file in {}", dir.display()))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file());
        write(&mut w).with_context(|| format!("cannot write {}", path.display()))?;
        w.flush()
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    tmp.persist(path)
        .with_context(|| format!("cannot move the finished file to {}", path.display()))?;
    Ok(())
}

/// The longest file name part [`safe_file_stem`] returns, in bytes (file systems allow 255).
pub const MAX_STEM: usize = 64;

/// A file name part made from `name` (a scene or mesh name, which comes from a file and may hold
/// anything): ASCII letters, digits, `-` and `_` are kept, every other character becomes `_`,
/// so no `/`, `..`, control character or leading `-` can steer or break a path; at most
/// [`MAX_STEM`] bytes; `unnamed` for an empty name.
pub fn safe_file_stem(name: &str) -> String {
    let s: String = name
        .chars()
        .take(MAX_STEM)
        .enumerate()
        .map(|(i, c)| {
            if c.is_ascii_alphanumeric() || c == '_' || (c == '-' && i > 0) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() { "unnamed".into() } else { s }
}

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

/// The EXR channels of a reference frame (see the module docs).
pub fn frame_channels(frame: &Frame) -> Vec<(&'static str, Channel)> {
    let f = |g: &dyn Fn(usize) -> f32| Channel::F32((0..frame.colour.len()).map(g).collect());
    vec![
        ("R", f(&|k| frame.colour[k].x)),
        ("G", f(&|k| frame.colour[k].y)),
        ("B", f(&|k| frame.colour[k].z)),
        ("mask", f(&|k| frame.mask[k] as f32)),
        ("P.X", f(&|k| frame.surface_position[k].x)),
        ("P.Y", f(&|k| frame.surface_position[k].y)),
        ("P.Z", f(&|k| frame.surface_position[k].z)),
        ("hit.X", f(&|k| frame.hit_position[k].x)),
        ("hit.Y", f(&|k| frame.hit_position[k].y)),
        ("hit.Z", f(&|k| frame.hit_position[k].z)),
        ("object_id", Channel::U32(frame.object_id.clone())),
        ("primitive_id", Channel::U32(frame.primitive_id.clone())),
        (
            "bounces",
            Channel::U32(frame.bounces.iter().map(|&b| b as u32).collect()),
        ),
    ]
}

/// Writes a traced (GPU) frame as PNG or EXR, chosen by the extension of `path`. EXR channels:
/// `R`, `G`, `B`, `mask`, `P.X/Y/Z` (`surface_position`), `hit.X/Y/Z` (NaN where the ray left
/// the scene or was unresolved), `unresolved` (1 on mirror pixels no CMO could decide) and, for
/// methods that verify their hits (the tracers with the exact criterion), `primitive_id` (u32:
/// the global triangle of the traced hit, 4294967295 where none, as the reference's), and with
/// the BVH tracer (`bvh`, `--fallback trace`) `fallback` (1 where the BVH finished the ray of a
/// pixel the method left unresolved; `unresolved` is then 0 there), and where the frame counts
/// them `bounces` (u32: the reflections the pixel's path took, as the reference's).
pub fn write_traced(path: &Path, traced: &Traced, surface_position: &[Vec3]) -> Result<()> {
    match Format::from_path(path)? {
        Format::Png => write_atomic(
            path,
            &png_bytes(traced.width, traced.height, &traced.colour)?,
        ),
        Format::Exr => {
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
            if let Some(ids) = &traced.triangle {
                channels.push(("primitive_id", Channel::U32(ids.clone())));
            }
            if let Some(fb) = &traced.fallback {
                channels.push(("fallback", f(&|k| f32::from(fb[k]))));
            }
            if let Some(b) = &traced.bounces {
                channels.push(("bounces", Channel::U32(b.clone())));
            }
            write_exr(path, traced.width, traced.height, channels)
        }
    }
}

/// Writes a frame as PNG or EXR, chosen by the extension of `path`.
pub fn write_frame(path: &Path, frame: &Frame) -> Result<()> {
    match Format::from_path(path)? {
        Format::Png => write_atomic(path, &png_bytes(frame.width, frame.height, &frame.colour)?),
        Format::Exr => write_exr(path, frame.width, frame.height, frame_channels(frame)),
    }
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
    fn file_stems_are_safe() {
        assert_eq!(safe_file_stem("sphere-room_2"), "sphere-room_2");
        assert_eq!(safe_file_stem("../a/b"), "___a_b");
        assert_eq!(safe_file_stem(".."), "__");
        assert_eq!(safe_file_stem("-rf"), "_rf");
        assert_eq!(safe_file_stem("a\u{0}\tb\u{7f}é"), "a__b__");
        assert_eq!(safe_file_stem(""), "unnamed");
        assert_eq!(safe_file_stem(&"x".repeat(300)).len(), MAX_STEM);
        // Negative: a name with a separator is not kept as it is.
        assert_ne!(safe_file_stem("a/b"), "a/b");
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

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.png");
        let r = write_atomic_with(&path, |w| {
            w.write_all(b"half")?;
            anyhow::bail!("disk on fire")
        });
        assert!(r.is_err());
        assert!(entries(dir.path()).is_empty(), "{:?}", entries(dir.path()));
        // Negative: the same call without the failure does leave the file.
        write_atomic(&path, b"whole").unwrap();
        assert_eq!(entries(dir.path()), vec!["x.png".to_string()]);
        assert_eq!(std::fs::read(&path).unwrap(), b"whole");
    }

    /// The finished file has the mode a plain create gives (not the temporary file's 0600).
    #[cfg(unix)]
    #[test]
    fn written_file_has_the_usual_mode() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain");
        std::fs::write(&plain, b"x").unwrap();
        let atomic = dir.path().join("atomic.png");
        write_atomic(&atomic, b"x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&atomic), mode(&plain));
    }

    #[test]
    fn exr_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        let mut f = Frame::new(3, 2);
        f.colour[4] = Vec3::new(0.25, 2.5, -1.0);
        f.object_id[1] = 7;
        write_frame(&path, &f).unwrap();
        let img = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
        let ch = &img.layer_data[0].channel_data.list;
        let g = ch.iter().find(|c| c.name.to_string() == "G").unwrap();
        assert_eq!(g.sample_data.value_by_flat_index(4).to_f32(), 2.5);
        let o = ch
            .iter()
            .find(|c| c.name.to_string() == "object_id")
            .unwrap();
        assert_eq!(o.sample_data.value_by_flat_index(1).to_u32(), 7);
        assert_eq!(o.sample_data.value_by_flat_index(0).to_u32(), u32::MAX);
    }
}

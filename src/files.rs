#![forbid(unsafe_code)]
//! Files written atomically (a temporary file in the destination folder, then a rename), so that
//! an error never leaves a half-written file behind, and file names made safe from names that
//! come from input files. A leaf module: the image writers ([`crate::output`]), the scene export
//! and the harness's reports all write through it.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};

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
}

#![forbid(unsafe_code)]
//! `cubetrace scene export`: a built-in scene written out as TOML + OBJ/MTL/PNG. An earlier
//! export (a `scene.toml` in the folder) is kept unless `--force`, which replaces it: the
//! folder then holds the new export's files, the earlier export's files that the new one does
//! not write are removed (those `scene::export::exported_files` recognises: its `scene.toml`,
//! and the OBJ, MTL and PNG files named from there that an export wrote), and every other file
//! is left alone. A name that is not a built-in scene gets the command to run instead.

use std::path::Path;

use anyhow::{Context, Result};

use crate::scene;

/// `cubetrace scene export NAME DIR [--force]`.
pub fn export(name: &str, dir: &Path, force: bool) -> Result<()> {
    let s = scene::builtin::by_name(name).ok_or_else(|| export_suggestion(name))?;
    let toml = dir.join("scene.toml");
    if !force && std::fs::symlink_metadata(&toml).is_ok() {
        anyhow::bail!(
            "{} already exists; pass --force to replace that export (its files are removed, other files kept), or choose another folder",
            toml.display()
        );
    }
    // An earlier export's files, found before the new export overwrites its MTL.
    let earlier = if force {
        scene::export::exported_files(dir)
    } else {
        Vec::new()
    };
    let path = scene::export::export(&s, dir)
        .with_context(|| format!("exporting scene '{name}' to {}", dir.display()))?;
    let written = scene::export::exported_files(dir);
    let stale: Vec<_> = earlier.iter().filter(|f| !written.contains(f)).collect();
    for f in &stale {
        match std::fs::remove_file(f) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => anyhow::bail!(
                "wrote {}, but cannot remove {}, a file of the earlier export: {e}",
                path.display(),
                f.display()
            ),
        }
    }
    if stale.is_empty() {
        println!("wrote {}", path.display());
    } else {
        println!(
            "wrote {} (and removed {} files of the earlier export)",
            path.display(),
            stale.len()
        );
    }
    Ok(())
}

/// The error of `scene export NAME` for a name that is not a built-in scene: what to run instead.
fn export_suggestion(name: &str) -> anyhow::Error {
    let known: Vec<&str> = scene::builtin::all().map(|(n, _)| *n).collect();
    if name.ends_with(".toml") || Path::new(name).is_file() {
        anyhow::anyhow!(
            "scene export: '{name}' is a scene file, not a built-in scene; `scene export` writes a built-in scene out \
             ({}). A scene file renders as it is: `cubetrace render {name}`",
            known.join(", ")
        )
    } else {
        anyhow::anyhow!(
            "scene export: unknown scene '{name}'; the built-in scenes are {} (`cubetrace scenes` describes them). \
             For example: `cubetrace scene export {} my-scene/`, then `cubetrace render my-scene/scene.toml`",
            known.join(", "),
            known.first().copied().unwrap_or("default")
        )
    }
}

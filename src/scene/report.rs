//! Warnings gathered while a scene loads: input that is accepted, but not as written.
//!
//! Repeated warnings of one kind and file are merged into one, with a count and the first few
//! line numbers, so that a file with 201 two-vertex faces gives one line of log, not 201.

use std::fmt;
use std::path::{Path, PathBuf};

/// How many line numbers a merged warning keeps.
const LINES_KEPT: usize = 8;

/// What a [`LoadWarning`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WarningKind {
    /// An OBJ face with fewer than 3 vertices, skipped.
    ShortFace,
    /// An OBJ line element (`l`), skipped.
    LineElement,
    /// An OBJ point element (`p`), skipped.
    PointElement,
    /// Faces without texture coordinates in a part whose other faces have them.
    MissingTexcoords,
    /// `usemtl` names a material no material library defines.
    UndefinedMaterial,
    /// `usemtl` in an OBJ that loads no material library.
    NoMaterialLibrary,
    /// A material defined twice; the later definition is used.
    DuplicateMaterial,
    /// An MTL colour form that is not supported (`spectral`, `xyz`); the default is used.
    UnsupportedColour,
    /// `map_Kd` options (`-s`, `-o`, ...), which are ignored.
    IgnoredMapOptions,
    /// An MTL `Ns` below 0 (Blender writes them), taken as 0, or one that is not a number,
    /// ignored.
    SpecularPower,
    /// A `map_Kd` texture that is missing or cannot be decoded; the material keeps its `Kd`.
    MissingTexture,
    /// An `mtllib` that names no file; its materials are undefined (grey).
    MissingMaterialLibrary,
    /// An OBJ polygon that crosses itself, fanned from its first corner.
    SelfCrossingPolygon,
    /// Triangles with a repeated vertex or zero area, dropped.
    DegenerateTriangles,
    /// A mesh whose OBJ holds no triangles.
    EmptyMesh,
    /// A scene with no meshes.
    NoMeshes,
    /// OBJ or MTL text (outside comments) that is not UTF-8, read as Latin-1.
    Latin1Text,
    /// OBJ vertex colours (`v x y z r g b`) on only some of a file's vertices: all ignored; or
    /// all whole numbers from 0 to 255: read as 8-bit values.
    VertexColours,
    /// A part without texture coordinates whose material has a texture.
    TextureWithoutTexcoords,
    /// A material statement read leniently: a `Kd` of four numbers (RGBA: the alpha dropped)
    /// or with float noise below 0 (taken as 0), `Kd`/`Ns`/`map_Kd` before any `newmtl`
    /// (ignored), a `usemtl` without a name (the default material), an `mtllib` or a `map_Kd`
    /// without one (ignored), a `Kd` above 1 (kept).
    LenientMaterial,
    /// An OBJ normal (`vn`) with a NaN or infinite component (some CAD exporters write one
    /// for a face without area): the corners that name it get a normal computed from the faces.
    NonFiniteNormal,
}

/// One (merged) warning.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoadWarning {
    pub kind: WarningKind,
    /// The file it is about.
    pub path: PathBuf,
    /// What happened, without the file, count and lines.
    pub detail: String,
    /// How many times it happened.
    pub count: usize,
    /// The first few lines where it happened (empty when not about lines).
    pub lines: Vec<usize>,
}

impl fmt::Display for LoadWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.detail)?;
        if self.count > 1 {
            write!(f, " ({} times", self.count)?;
        } else if !self.lines.is_empty() {
            write!(f, " (")?;
        }
        if !self.lines.is_empty() {
            let lines: Vec<String> = self.lines.iter().map(|l| l.to_string()).collect();
            let sep = if self.count > 1 { ", " } else { "" };
            let word = if self.lines.len() > 1 {
                "lines"
            } else {
                "line"
            };
            write!(f, "{sep}{word} {}", lines.join(", "))?;
            if self.count > self.lines.len() {
                write!(f, ", ...")?;
            }
        }
        if self.count > 1 || !self.lines.is_empty() {
            write!(f, ")")?;
        }
        Ok(())
    }
}

/// The warnings of one scene load, in the order they first happened.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadReport {
    pub warnings: Vec<LoadWarning>,
}

impl LoadReport {
    /// Adds one occurrence, merging it into an earlier warning of the same kind, file and detail.
    pub(crate) fn warn(
        &mut self,
        kind: WarningKind,
        path: &Path,
        line: Option<usize>,
        detail: impl Into<String>,
    ) {
        let detail = detail.into();
        let w = match self
            .warnings
            .iter_mut()
            .find(|w| w.kind == kind && w.path == path && w.detail == detail)
        {
            Some(w) => {
                w.count += 1;
                w
            }
            None => {
                self.warnings.push(LoadWarning {
                    kind,
                    path: path.to_path_buf(),
                    detail,
                    count: 1,
                    lines: Vec::new(),
                });
                self.warnings.last_mut().expect("just pushed")
            }
        };
        if let Some(l) = line
            && w.lines.len() < LINES_KEPT
        {
            w.lines.push(l);
        }
    }

    /// Adds `count` occurrences at once (no lines).
    pub(crate) fn warn_count(
        &mut self,
        kind: WarningKind,
        path: &Path,
        count: usize,
        detail: impl Into<String>,
    ) {
        if count == 0 {
            return;
        }
        self.warn(kind, path, None, detail);
        if let Some(w) = self.warnings.last_mut() {
            w.count += count - 1;
        }
    }

    /// The total count of warnings of `kind`.
    pub fn count(&self, kind: WarningKind) -> usize {
        self.warnings
            .iter()
            .filter(|w| w.kind == kind)
            .map(|w| w.count)
            .sum()
    }

    /// Sends every warning to the log at warn level.
    pub fn log(&self) {
        for w in &self.warnings {
            log::warn!("{w}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merges_and_counts() {
        let mut r = LoadReport::default();
        let p = Path::new("a.obj");
        for l in 1..=10 {
            r.warn(WarningKind::ShortFace, p, Some(l), "face skipped");
        }
        r.warn(WarningKind::LineElement, p, Some(3), "line skipped");
        assert_eq!(r.warnings.len(), 2);
        assert_eq!(r.count(WarningKind::ShortFace), 10);
        assert_eq!(r.count(WarningKind::PointElement), 0);
        let s = r.warnings[0].to_string();
        assert_eq!(
            s,
            "a.obj: face skipped (10 times, lines 1, 2, 3, 4, 5, 6, 7, 8, ...)"
        );
        assert_eq!(r.warnings[1].to_string(), "a.obj: line skipped (line 3)");
        r.warn_count(WarningKind::DegenerateTriangles, p, 4, "dropped");
        assert_eq!(r.count(WarningKind::DegenerateTriangles), 4);
        assert_eq!(r.warnings[2].to_string(), "a.obj: dropped (4 times)");
    }
}

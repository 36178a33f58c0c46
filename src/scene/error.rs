use std::path::PathBuf;

/// Everything that can be wrong with a scene. Each message names the file and, where known, the
/// line and the field.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The I/O error is part of the message, not a `source()`: a chain printer (`{:#}`) would
    /// print it twice.
    #[error("cannot read {}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// Malformed TOML or an unknown field; `message` is the parser's, with line and column.
    #[error("{}: {message}", path.display())]
    Toml { path: PathBuf, message: String },
    #[error("{file}: {field}: {reason}")]
    Invalid {
        file: String,
        field: String,
        reason: String,
    },
    #[error("{}:{line}: {reason}", path.display())]
    Obj {
        path: PathBuf,
        line: usize,
        reason: String,
    },
    #[error("{}: {reason}", path.display())]
    Mtl { path: PathBuf, reason: String },
    #[error("unknown scene '{name}'; built-in scenes: {} (or give a path to a .toml scene file)", known.join(", "))]
    UnknownScene { name: String, known: Vec<String> },
    /// A mesh (OBJ, MTL, glTF, ...) given where a scene file goes.
    #[error(
        "{}: a scene is a .toml file, and this is a mesh file; write a scene file that names it \
         (`[[mesh]]` with `obj = \"{}\"` and `reflector = true` on the mirror, a `[[camera]]` with \
         `eye`, `target` and `fov_y_deg`); `cubetrace scene export default DIR` writes one to start \
         from",
        path.display(),
        path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned())
    )]
    NotASceneFile { path: PathBuf },
}

impl SceneError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SceneError::Io {
            path: path.into(),
            error: source,
        }
    }
}

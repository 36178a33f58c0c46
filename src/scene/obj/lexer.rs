//! The line-by-line reading both passes share: the file read within [`MAX_INPUT_BYTES`], its
//! lines without comments, a statement's keyword, numbers and face corners, each error naming
//! the file and line.

use std::path::Path;

use super::MAX_INPUT_BYTES;
use crate::scene::{MAX_COORDINATE, SceneError};

pub(super) fn obj_err(path: &Path, line: usize, reason: impl Into<String>) -> SceneError {
    SceneError::Obj {
        path: path.to_path_buf(),
        line,
        reason: reason.into(),
    }
}

/// Reads an OBJ or MTL file, refusing files over [`MAX_INPUT_BYTES`].
pub(super) fn read_input(path: &Path) -> Result<Vec<u8>, SceneError> {
    let len = std::fs::metadata(path)
        .map_err(|e| SceneError::io(path, e))?
        .len();
    if len > MAX_INPUT_BYTES {
        return Err(SceneError::Mtl {
            path: path.to_path_buf(),
            reason: format!(
                "the file has {len} bytes, more than the {MAX_INPUT_BYTES} this loader accepts"
            ),
        });
    }
    std::fs::read(path).map_err(|e| SceneError::io(path, e))
}

/// Splits a file into numbered lines (from 1) without their comments. Skips a UTF-8 byte
/// order mark; a line's comment may hold any bytes, the rest must be UTF-8.
pub(super) fn text_lines<'a>(
    bytes: &'a [u8],
    path: &Path,
) -> Result<Vec<(usize, &'a str)>, SceneError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut out = Vec::new();
    for (k, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = k + 1;
        let code = match raw.iter().position(|&b| b == b'#') {
            Some(h) => &raw[..h],
            None => raw,
        };
        let text = std::str::from_utf8(code).map_err(|e| {
            let at = e.valid_up_to();
            obj_err(
                path,
                line,
                format!(
                    "byte 0x{:02X} at column {} is not UTF-8 (save the file as UTF-8)",
                    code[at],
                    at + 1
                ),
            )
        })?;
        out.push((line, text));
    }
    Ok(out)
}

/// Splits a line into its keyword and the rest, both trimmed (`None` for a blank line).
pub(super) fn keyword(text: &str) -> Option<(&str, &str)> {
    let t = text.trim();
    if t.is_empty() {
        return None;
    }
    let end = t.find(char::is_whitespace).unwrap_or(t.len());
    Some((&t[..end], t[end..].trim()))
}

/// Checks the numbers of a statement (at least `min`, all finite as `f32`) and returns their
/// tokens, which parse to the same values wherever `str::parse::<f32>` reads them (`tobj`).
pub(super) fn numbers<'a>(
    args: &'a str,
    min: usize,
    what: &str,
    path: &Path,
    line: usize,
) -> Result<Vec<&'a str>, SceneError> {
    let words: Vec<&str> = args.split_whitespace().collect();
    if words.len() < min {
        return Err(obj_err(
            path,
            line,
            format!(
                "{what} needs {min} numbers, found {}: '{}'",
                words.len(),
                args
            ),
        ));
    }
    words
        .into_iter()
        .map(|a| match a.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(a),
            Ok(_) => Err(obj_err(
                path,
                line,
                format!("{what} has a non-finite value '{a}'"),
            )),
            Err(_) => Err(obj_err(
                path,
                line,
                format!("{what}: '{a}' is not a number"),
            )),
        })
        .collect()
}

/// Refuses a vertex position with a coordinate beyond [`MAX_COORDINATE`] (tokens already
/// parsed as finite `f32` by [`numbers`]), naming the line and the bound.
pub(super) fn within_coordinate_bound(
    v: &[&str],
    path: &Path,
    line: usize,
) -> Result<(), SceneError> {
    for (axis, a) in ["x", "y", "z"].iter().zip(v) {
        let x: f32 = a.parse().unwrap_or(f32::INFINITY);
        if x.abs() > MAX_COORDINATE {
            return Err(obj_err(
                path,
                line,
                format!(
                    "vertex position (v) has {axis} = {a}, beyond the {MAX_COORDINATE:e} (2^60) \
                     a coordinate may reach (the tracer squares distances in f32); \
                     scale the mesh in its [mesh.transform] instead"
                ),
            ));
        }
    }
    Ok(())
}

/// One face corner: 0-based position, texture coordinate and normal indices.
pub(super) type Corner = (u32, Option<u32>, Option<u32>);

/// Resolves one face corner (`v`, `v/vt`, `v//vn` or `v/vt/vn`; negative indices count back).
pub(super) fn corner(
    a: &str,
    counts: [usize; 3],
    path: &Path,
    line: usize,
) -> Result<Corner, SceneError> {
    let fields: Vec<&str> = a.split('/').collect();
    if fields.len() > 3 || fields[0].is_empty() {
        return Err(obj_err(path, line, format!("malformed face vertex '{a}'")));
    }
    let mut out = [None; 3];
    for (slot, f) in fields.iter().enumerate() {
        if f.is_empty() {
            continue;
        }
        let what = ["position", "texture coordinate", "normal"][slot];
        let count = counts[slot] as i64;
        let i: i64 = f
            .parse()
            .map_err(|_| obj_err(path, line, format!("malformed face vertex '{a}'")))?;
        let resolved = if i < 0 {
            count.saturating_add(i) + 1
        } else {
            i
        };
        if i == 0 || resolved < 1 || resolved > count {
            return Err(obj_err(
                path,
                line,
                format!("face refers to {what} {i}, but only {count} are defined so far"),
            ));
        }
        out[slot] = Some((resolved - 1) as u32);
    }
    Ok((out[0].expect("checked non-empty"), out[1], out[2]))
}

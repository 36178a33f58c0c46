//! The line-by-line reading both passes share: the file read within [`MAX_INPUT_BYTES`], its
//! lines without comments, a statement's keyword, numbers and face corners, each error naming
//! the file and line.

use std::path::Path;

use super::MAX_INPUT_BYTES;
use crate::scene::report::{LoadReport, WarningKind};
use crate::scene::{MAX_COORDINATE, SceneError};

pub(super) fn obj_err(path: &Path, line: usize, reason: impl Into<String>) -> SceneError {
    SceneError::Obj {
        path: path.to_path_buf(),
        line,
        reason: reason.into(),
    }
}

/// Reads an OBJ or MTL file, refusing files over [`MAX_INPUT_BYTES`] and binary files (a NUL
/// byte: an FBX, binary STL, `.blend` or glTF named where an OBJ was meant); UTF-16 text with
/// its byte order mark is read as text ([`utf16_as_utf8`]). A line whose text before its
/// comment is not UTF-8 is read as Latin-1 (ISO 8859-1, which Windows exporters write names
/// in), with a warning naming it; the bytes returned are then UTF-8 outside comments, with the
/// lines that a `\` continues joined ([`join_continued_lines`]).
pub(super) fn read_input(path: &Path, report: &mut LoadReport) -> Result<Vec<u8>, SceneError> {
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
    let bytes = utf16_as_utf8(std::fs::read(path).map_err(|e| SceneError::io(path, e))?);
    if let Some((line, raw)) = split_lines(&bytes)
        .enumerate()
        .find(|(_, l)| l.contains(&0))
    {
        let column = raw.iter().position(|&b| b == 0).expect("found") + 1;
        return Err(obj_err(
            path,
            line + 1,
            format!(
                "byte 0x00 at column {column}: a binary file, not OBJ or MTL text \
                 (export the model as Wavefront OBJ)"
            ),
        ));
    }
    Ok(join_continued_lines(latin1_as_utf8(bytes, path, report)))
}

/// `bytes` written as UTF-8 where they are UTF-16 text that starts with its byte order mark
/// (little- or big-endian: what Windows Notepad saves as "Unicode" and PowerShell 5's `>` and
/// `Out-File` write), without the mark; other bytes, and UTF-16 that does not decode, come
/// back unchanged (its NUL bytes then refuse it as binary).
fn utf16_as_utf8(bytes: Vec<u8>) -> Vec<u8> {
    let unit: fn([u8; 2]) -> u16 = match bytes.get(..2) {
        Some([0xFF, 0xFE]) => u16::from_le_bytes,
        Some([0xFE, 0xFF]) => u16::from_be_bytes,
        _ => return bytes,
    };
    if !bytes.len().is_multiple_of(2) {
        return bytes;
    }
    let units: Vec<u16> = bytes[2..]
        .chunks_exact(2)
        .map(|c| unit([c[0], c[1]]))
        .collect();
    match String::from_utf16(&units) {
        Ok(text) => text.into_bytes(),
        Err(_) => bytes,
    }
}

/// `bytes` with the text before each line's comment that is not UTF-8 read as Latin-1 (each
/// byte the code point of its value) and written as UTF-8, one warning naming those lines;
/// every line end becomes `\n`. UTF-8 files come back unchanged.
fn latin1_as_utf8(bytes: Vec<u8>, path: &Path, report: &mut LoadReport) -> Vec<u8> {
    if std::str::from_utf8(&bytes).is_ok() {
        return bytes;
    }
    let mut out = Vec::with_capacity(bytes.len() + bytes.len() / 8);
    for (k, raw) in split_lines(&bytes).enumerate() {
        if k > 0 {
            out.push(b'\n');
        }
        let h = raw.iter().position(|&b| b == b'#').unwrap_or(raw.len());
        let (code, comment) = raw.split_at(h);
        if std::str::from_utf8(code).is_ok() {
            out.extend_from_slice(raw);
            continue;
        }
        report.warn(
            WarningKind::Latin1Text,
            path,
            Some(k + 1),
            "text that is not UTF-8, read as Latin-1 (ISO 8859-1)",
        );
        let text: String = code.iter().map(|&b| char::from(b)).collect();
        out.extend_from_slice(text.as_bytes());
        out.extend_from_slice(comment);
    }
    out
}

/// `bytes` with each line that ends in `\` before its comment (the OBJ format's line
/// continuation) joined with the next, and an empty line left after the joined one so that
/// the later lines keep their numbers (errors in a joined line name its first line); every
/// line end becomes `\n`. Files without continuations come back unchanged.
fn join_continued_lines(bytes: Vec<u8>) -> Vec<u8> {
    fn code(line: &[u8]) -> &[u8] {
        let h = line.iter().position(|&b| b == b'#').unwrap_or(line.len());
        line[..h].trim_ascii_end()
    }
    if !split_lines(&bytes).any(|l| code(l).ends_with(b"\\")) {
        return bytes;
    }
    let mut out = Vec::with_capacity(bytes.len());
    let mut joined = 0;
    for (k, raw) in split_lines(&bytes).enumerate() {
        if k > 0 && joined == 0 {
            out.push(b'\n');
        }
        let text = code(raw);
        if let Some(head) = text.strip_suffix(b"\\") {
            out.extend_from_slice(head);
            out.push(b' ');
            joined += 1;
        } else {
            out.extend_from_slice(raw);
            out.extend(std::iter::repeat_n(b'\n', joined));
            joined = 0;
        }
    }
    out
}

/// The lines of a file without their ends: a line ends at LF, CRLF or a lone CR (as classic
/// Mac OS programs wrote them).
fn split_lines(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut rest = Some(bytes);
    std::iter::from_fn(move || {
        let r = rest?;
        let Some(end) = r.iter().position(|&b| b == b'\n' || b == b'\r') else {
            rest = None;
            return Some(r);
        };
        let crlf = r[end] == b'\r' && r.get(end + 1) == Some(&b'\n');
        rest = Some(&r[end + 1 + usize::from(crlf)..]);
        Some(&r[..end])
    })
}

/// How Microsoft's C runtime before 2015 printed NaN and infinity (`1.#QNAN0`, `-1.#IND00`,
/// `1.#INF00`): a digit and `.`, then `#`, one of these and digits. Read as a comment, they
/// would be the number before the `#`.
const MSVC_NON_FINITE: [&[u8]; 4] = [b"QNAN", b"SNAN", b"IND", b"INF"];

/// The error for an MSVC-printed NaN or infinity at `h` (the line's first `#`), if it is one.
fn msvc_non_finite(raw: &[u8], h: usize, path: &Path, line: usize) -> Option<SceneError> {
    let after = &raw[h + 1..];
    let end = after
        .iter()
        .position(|b| b.is_ascii_whitespace())
        .map_or(raw.len(), |i| h + 1 + i);
    let word = &raw[h + 1..end];
    let printed = raw[..h].ends_with(b".")
        && raw[..h - 1].last().is_some_and(u8::is_ascii_digit)
        && MSVC_NON_FINITE.iter().any(|m| {
            word.len() >= m.len()
                && word[..m.len()].eq_ignore_ascii_case(m)
                && word[m.len()..].iter().all(u8::is_ascii_digit)
        });
    if !printed {
        return None;
    }
    let start = raw[..h]
        .iter()
        .rposition(|b| b.is_ascii_whitespace())
        .map_or(0, |i| i + 1);
    Some(obj_err(
        path,
        line,
        format!(
            "'{}' is how Microsoft's C runtime prints NaN or infinity: not a finite number",
            String::from_utf8_lossy(&raw[start..end])
        ),
    ))
}

/// Splits a file into numbered lines (from 1, [`split_lines`]) without their comments. Skips a
/// UTF-8 byte order mark; a line's comment may hold any bytes, the rest must be UTF-8 (as
/// [`read_input`] returns it). A `#` right after a number that starts an MSVC NaN or infinity
/// (`1.#QNAN0`) is an error naming the line, not a comment.
pub(super) fn text_lines<'a>(
    bytes: &'a [u8],
    path: &Path,
) -> Result<Vec<(usize, &'a str)>, SceneError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut out = Vec::new();
    for (k, raw) in split_lines(bytes).enumerate() {
        let line = k + 1;
        let code = match raw.iter().position(|&b| b == b'#') {
            Some(h) => {
                if let Some(e) = msvc_non_finite(raw, h, path, line) {
                    return Err(e);
                }
                &raw[..h]
            }
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

#![forbid(unsafe_code)]
//! The sequence flags of `cubetrace render` and the pure parts of a sequence: `--frames`
//! parsing and the output names (`#` padding, Blender's rules, the default names). The loop
//! that renders them is [`super::sequence`]; its module docs give the rules.

use std::path::{Path, PathBuf};

use crate::output;
use crate::scene::animation::MAX_FRAME;

/// The sequence flags of `cubetrace render`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct SequenceArgs {
    /// Frames to render, in Blender's forms, comma separated: `10`, `1..240`, `1,3,5`,
    /// `1..10,20`, and a step per range: `1..240:2` (1, 3, 5, ...). Each frame is rendered once,
    /// in increasing order. Default: the scene's `[animation] frames`, else one still frame.
    /// Several frames go to `-o` with its last `#` run replaced by the zero-padded frame number
    /// (`-o out/orbit-####.png`; no `#`: `-####` is added before the extension); without `-o`:
    /// out/SCENE-METHOD-####.png.
    #[arg(long, value_name = "LIST")]
    pub frames: Option<String>,
    /// Skip the frames whose output file exists (resume an interrupted sequence; files are
    /// written atomically, so an existing one is whole).
    #[arg(long)]
    pub skip_existing: bool,
}

/// Parses `--frames` (see the module docs): the frames, sorted, each once.
pub fn parse_frames(text: &str) -> std::result::Result<Vec<i64>, String> {
    let number = |s: &str, what: &str| -> std::result::Result<i64, String> {
        let s = s.trim();
        let n: i64 = s.parse().map_err(|_| {
            if s.is_empty() {
                format!("'{text}': a range needs {what}")
            } else {
                format!("'{s}' is not a frame number")
            }
        })?;
        if !(0..=MAX_FRAME).contains(&n) {
            return Err(format!("frame {n} is out of range (0 to {MAX_FRAME})"));
        }
        Ok(n)
    };
    let mut frames = Vec::new();
    for item in text.split(',') {
        let item = item.trim();
        if item.is_empty() {
            return Err(format!(
                "'{text}': an empty item (frames are separated by single commas)"
            ));
        }
        let Some((first, rest)) = item.split_once("..") else {
            if item.contains(':') {
                return Err(format!("'{item}': a step belongs to a range (1..240:2)"));
            }
            frames.push(number(item, "a start")?);
            continue;
        };
        let (last, step) = match rest.split_once(':') {
            Some((last, step)) => {
                let step: i64 = step
                    .trim()
                    .parse()
                    .map_err(|_| format!("'{item}': the step '{step}' is not a whole number"))?;
                if step < 1 {
                    return Err(format!(
                        "'{item}': the step is {step}; it must be 1 or more"
                    ));
                }
                (last, step)
            }
            None => (rest, 1),
        };
        let first = number(first, "a start (first..last)")?;
        let last = number(last, "an end (first..last)")?;
        if last < first {
            return Err(format!("'{item}': the range ends before it starts"));
        }
        frames.extend((first..=last).step_by(step as usize));
    }
    frames.sort_unstable();
    frames.dedup();
    Ok(frames)
}

/// `pattern` with its last run of `#` replaced by `frame`, zero-padded to the run's length;
/// unchanged without `#`.
pub fn frame_path(pattern: &Path, frame: i64) -> PathBuf {
    let text = pattern.to_string_lossy();
    let Some(end) = text.rfind('#') else {
        return pattern.to_path_buf();
    };
    let start = text[..end].trim_end_matches('#').len();
    let width = end + 1 - start;
    PathBuf::from(format!(
        "{}{frame:0width$}{}",
        &text[..start],
        &text[end + 1..]
    ))
}

/// The output pattern of a run: `-o` as given (with `-####` added before the extension when
/// several frames share it without a `#`), else `out/SCENE-METHOD-####.png` for a sequence or
/// `out/SCENE-METHOD.png` for a still.
pub fn output_pattern(
    output: Option<&Path>,
    scene: &str,
    method: crate::Method,
    sequence: bool,
    frames: usize,
) -> PathBuf {
    let Some(o) = output else {
        let stem = output::safe_file_stem(scene);
        let name = if sequence {
            format!("{stem}-{method}-####.png")
        } else {
            format!("{stem}-{method}.png")
        };
        return PathBuf::from("out").join(name);
    };
    if frames < 2 || o.to_string_lossy().contains('#') {
        return o.to_path_buf();
    }
    let stem = o.file_stem().map(|s| s.to_string_lossy().into_owned());
    let name = match (stem, o.extension()) {
        (Some(stem), Some(ext)) => format!("{stem}-####.{}", ext.to_string_lossy()),
        (Some(stem), None) => format!("{stem}-####"),
        _ => "####".to_string(),
    };
    o.with_file_name(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_take_blenders_forms() {
        assert_eq!(parse_frames("10"), Ok(vec![10]));
        assert_eq!(parse_frames("1..4"), Ok(vec![1, 2, 3, 4]));
        assert_eq!(parse_frames("1,3,5"), Ok(vec![1, 3, 5]));
        assert_eq!(parse_frames("7, 1..3 ,2"), Ok(vec![1, 2, 3, 7]));
        assert_eq!(parse_frames("1..9:3"), Ok(vec![1, 4, 7]));
        assert_eq!(parse_frames("0..0"), Ok(vec![0]));
        // Negatives: each refused with a message naming the problem.
        for (bad, says) in [
            ("5..1", "ends before it starts"),
            ("1..", "needs an end"),
            ("..4", "needs a start"),
            ("a", "'a' is not a frame number"),
            ("1..9:0", "must be 1 or more"),
            ("1..9:x", "not a whole number"),
            ("1,,2", "empty item"),
            ("", "empty item"),
            ("4:2", "a step belongs to a range"),
            ("-3", "out of range"),
            ("1..2000000", "out of range"),
        ] {
            let e = parse_frames(bad).expect_err(bad);
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn hashes_pad_the_frame_number() {
        let p = |s: &str, f| frame_path(Path::new(s), f).display().to_string();
        assert_eq!(p("out/orbit-####.png", 7), "out/orbit-0007.png");
        assert_eq!(p("out/orbit-#.png", 12), "out/orbit-12.png");
        assert_eq!(p("out/orbit-##.png", 12345), "out/orbit-12345.png");
        // Only the last run is the frame.
        assert_eq!(p("out/v##/f-###.exr", 3), "out/v##/f-003.exr");
        assert_eq!(p("out/still.png", 3), "out/still.png");
        // Negative: different frames give different names.
        assert_ne!(p("o-####.png", 1), p("o-####.png", 2));
    }

    #[test]
    fn output_patterns_follow_blender() {
        use crate::Method::Compute;
        let o = |out: Option<&str>, seq, n| {
            output_pattern(out.map(Path::new), "orbit", Compute, seq, n)
                .display()
                .to_string()
        };
        assert_eq!(o(None, true, 24), "out/orbit-compute-####.png");
        assert_eq!(o(None, false, 1), "out/orbit-compute.png");
        assert_eq!(o(Some("a/f.exr"), true, 24), "a/f-####.exr");
        assert_eq!(o(Some("a/f-##.png"), true, 24), "a/f-##.png");
        assert_eq!(o(Some("a/f.png"), true, 1), "a/f.png");
    }
}

#![forbid(unsafe_code)]
//! `cubetrace render --frames`: a sequence of frames of an animated scene in one run.
//!
//! - Frames ([`parse_frames`]): Blender's forms, comma separated: `10`, `1..240`, `1,3,5`,
//!   mixtures (`1..10,20,40..50`), and a step per range, `1..240:2` (every second frame from 1:
//!   1, 3, 5, ...). Frame numbers are 0 to [`MAX_FRAME`]; the frames are rendered once each, in
//!   increasing order. Without `--frames` an animated scene renders its `[animation] frames`
//!   range; a still scene renders one frame, as before.
//! - Names ([`output_pattern`], [`frame_path`]): the last run of `#` in `-o` becomes the frame
//!   number, zero-padded to the run's length (`-o out/orbit-####.png`: `out/orbit-0007.png`;
//!   wider numbers keep all their digits). Several frames and no `#`: `-####` is added before the
//!   extension, as Blender does. Without `-o`: `out/SCENE-METHOD-####.png` for a sequence (an
//!   animated scene or `--frames` given), `out/SCENE-METHOD.png` for a still.
//! - `--skip-existing` resumes: a frame whose file exists is skipped. Every file is written
//!   atomically (a temporary file renamed into place), so a killed run leaves whole frames only.
//! - A progress bar (frames and samples, with an ETA; drawn only on a terminal) and a summary
//!   line: frames rendered and skipped, wall time, frames per minute, the output pattern.
//! - Each frame is the scene at that frame ([`crate::scene::Scene::at_frame`]) seen by the
//!   chosen camera at the frame's time; one renderer serves every frame of the run, and a frame
//!   within a sequence is byte-identical to the same frame rendered alone.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result};

use super::render::{self, RenderArgs};
use crate::camera::Camera;
use crate::output::{self, Format};
use crate::scene::{self, Scene, animation::MAX_FRAME};

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

/// `cubetrace render`: a still scene without `--frames` is today's single frame
/// ([`render::render`]); otherwise the sequence of the module docs.
pub fn render(args: RenderArgs) -> Result<()> {
    let given = match &args.sequence.frames {
        Some(text) => Some(parse_frames(text).map_err(|e| anyhow::anyhow!("--frames: {e}"))?),
        None => None,
    };
    if given.is_none() && !args.sequence.skip_existing {
        // The still path keeps today's behaviour (and loads the scene itself).
        let probe = scene::load(&args.scene)?;
        if probe.default_frames().is_none() {
            return render::render(args);
        }
    }
    run_sequence(args, given)
}

/// One frame of the run: the scene and camera at that frame and where it goes.
struct FrameJob {
    frame: i64,
    path: PathBuf,
}

/// The sequence: scene once, frames and names checked before anything renders, then the loop.
fn run_sequence(args: RenderArgs, given: Option<Vec<i64>>) -> Result<()> {
    let start = Instant::now();
    args.check_method()?;
    let base = load_base(&args)?;
    let frames = match given {
        Some(f) => f,
        None => match base.default_frames() {
            Some([first, last]) => (first..=last).collect(),
            None => vec![1],
        },
    };
    let pattern = output_pattern(
        args.output.as_deref(),
        &base.name,
        args.method,
        true,
        frames.len(),
    );
    let mine = select(&frames);
    let jobs: Vec<FrameJob> = (mine.iter())
        .map(|&frame| FrameJob {
            frame,
            path: frame_path(&pattern, frame),
        })
        .collect();
    let format = check_paths(&pattern, &jobs)?;
    let (done, todo): (Vec<&FrameJob>, Vec<&FrameJob>) = jobs
        .iter()
        .partition(|j| args.sequence.skip_existing && std::fs::symlink_metadata(&j.path).is_ok());
    for j in &done {
        log::info!("frame {}: {} exists, skipped", j.frame, j.path.display());
    }
    let skipped = done.len();
    let spp = u64::from(base.film.spp.max(1));
    let bar = progress_bar(todo.len() as u64 * spp);
    let mut renderer: Option<FrameRenderer> = None;
    for job in &todo {
        let (scene, camera) = frame_scene(&args, &base, job.frame)?;
        bar.set_message(format!("frame {}", job.frame));
        let r = match &mut renderer {
            Some(r) => r,
            None => renderer.insert(FrameRenderer::new(&args, &scene, &camera)?),
        };
        let frame = r
            .render(&scene, &camera)
            .with_context(|| format!("frame {}", job.frame))?;
        frame.write(&job.path, format)?;
        log::info!(
            "frame {}: capture {}",
            job.frame,
            if frame.captured { "ran" } else { "reused" }
        );
        bar.suspend(|| println!("{}", frame.summary(&job.path)));
        bar.inc(spp);
    }
    bar.finish_and_clear();
    let wall = start.elapsed();
    let rendered = todo.len();
    let per_minute = if wall.as_secs_f64() > 0.0 {
        rendered as f64 * 60.0 / wall.as_secs_f64()
    } else {
        0.0
    };
    println!(
        "sequence: {rendered} frames rendered, {skipped} skipped (exist), of {} in this run, in \
         {:.2?} ({per_minute:.1} frames per minute), {}",
        jobs.len(),
        wall,
        pattern.display()
    );
    Ok(())
}

/// The frames this task renders. (Stub until the shard selection lands: every frame.)
fn select(frames: &[i64]) -> Vec<i64> {
    frames.to_vec()
}

/// The output checks of every frame before any renders: format and folder (of the first
/// frame's path, which shares them with the rest) and the names' lengths (the longest).
fn check_paths(pattern: &Path, jobs: &[FrameJob]) -> Result<Format> {
    let Some(first) = jobs.first() else {
        return output::check_output(pattern);
    };
    let format = output::check_output(&first.path)?;
    render::check_file_name(&first.path)?;
    if let Some(longest) = jobs.iter().max_by_key(|j| j.path.as_os_str().len()) {
        render::check_file_name(&longest.path)?;
    }
    Ok(format)
}

/// The scene with the command line's overrides (CMOs, subdivision), before any frame.
fn load_base(args: &RenderArgs) -> Result<Scene> {
    let mut scene = render::timed("scene load", || scene::load(&args.scene))?;
    args.trace.apply(&mut scene);
    if args.subdivide > 0 {
        render::timed("subdivision", || {
            crate::cpu::reflection_point::subdivide_non_reflectors(&mut scene, args.subdivide)
        });
    }
    // The camera exists and the frame size is good before anything renders.
    let camera = scene.camera(args.camera.as_deref())?;
    let (w, h) = render::frame_size((camera.width, camera.height), args.width, args.height);
    scene::check_resolution(w, h).map_err(|e| anyhow::anyhow!("--width/--height: {e}"))?;
    for problem in crate::placement::diagnose(&scene) {
        log::warn!("{problem}");
    }
    Ok(scene)
}

/// The scene at `frame` and its camera (the chosen one, at the command's frame size), with a
/// CMO placement search resolved for that camera.
fn frame_scene(args: &RenderArgs, base: &Scene, frame: i64) -> Result<(Scene, Camera)> {
    let mut scene = base.at_frame(frame);
    let mut camera = scene.camera(args.camera.as_deref())?.clone();
    (camera.width, camera.height) =
        render::frame_size((camera.width, camera.height), args.width, args.height);
    let view = camera.target - camera.eye;
    if view.length_squared() == 0.0 || view.cross(camera.up).length_squared() == 0.0 {
        anyhow::bail!(
            "frame {frame}: camera '{}': eye, target and up do not span a view there (eye = \
             target, or up along the view); check the scene's [animation] camera keys",
            camera.name
        );
    }
    crate::placement::resolve(&mut scene, &camera);
    Ok((scene, camera))
}

/// A progress bar over the run's samples (frames x spp), with an ETA; drawn on a terminal only.
fn progress_bar(samples: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(samples).with_style(
        indicatif::ProgressStyle::with_template(
            "{msg} {bar:40} {pos}/{len} samples, {elapsed} elapsed, ETA {eta}",
        )
        .expect("the template is valid"),
    );
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar
}

// ---- Stub of the film work's `FrameRenderer` (design §6), replaced when it lands. ----

/// Renders the frames of a run: one device for every frame; a GPU renderer per frame.
struct FrameRenderer {
    options: crate::vk::frame::RenderOptions,
    bounces: u32,
    ctx: Option<crate::vk::GpuContext>,
}

struct RenderedFrame {
    captured: bool,
    colour: Colour,
    width: u32,
    height: u32,
    mirror_pixels: usize,
}

enum Colour {
    Gpu(
        Box<crate::metrics::Traced>,
        Vec<glam::Vec3>,
        scene::WorldGeometry,
    ),
    Reference(Box<crate::reference::Frame>, scene::WorldGeometry),
}

impl FrameRenderer {
    fn new(args: &RenderArgs, _scene: &Scene, _camera: &Camera) -> Result<Self> {
        let ctx = if args.method.is_gpu() {
            Some(args.gpu.context()?)
        } else {
            None
        };
        Ok(FrameRenderer {
            options: render::gpu_options(args)?,
            bounces: args.bounces,
            ctx,
        })
    }

    fn render(&mut self, scene: &Scene, camera: &Camera) -> Result<RenderedFrame> {
        let Some(ctx) = &self.ctx else {
            let tracer = crate::reference::Tracer::new(scene);
            let frame = crate::reference::render(scene, &tracer, camera, self.bounces);
            return Ok(RenderedFrame {
                captured: true,
                width: frame.width,
                height: frame.height,
                mirror_pixels: frame.mirror_pixels(),
                colour: Colour::Reference(Box::new(frame), tracer.world),
            });
        };
        let mut r = crate::vk::frame::GpuRenderer::new(ctx, scene, camera, self.options)?;
        let frame = r.render(ctx)?;
        let traced = frame.traced();
        Ok(RenderedFrame {
            captured: true,
            width: frame.width,
            height: frame.height,
            mirror_pixels: traced.mask.iter().filter(|&&m| m != 0).count(),
            colour: Colour::Gpu(Box::new(traced), frame.surface_position, scene.world()),
        })
    }
}

impl RenderedFrame {
    fn write(&self, path: &Path, _format: Format) -> Result<()> {
        match &self.colour {
            Colour::Gpu(traced, positions, world) => {
                output::write_traced(path, traced, positions, world)
            }
            Colour::Reference(frame, world) => output::write_frame(path, frame, world),
        }
    }

    fn summary(&self, path: &Path) -> String {
        format!(
            "wrote {} ({}x{}, {} mirror pixels)",
            path.display(),
            self.width,
            self.height,
            self.mirror_pixels
        )
    }
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

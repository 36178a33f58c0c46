#![forbid(unsafe_code)]
//! `cubetrace render --frames`: a sequence of frames of an animated scene in one run.
//!
//! - Frames ([`super::frames::parse_frames`]): Blender's forms, comma separated: `10`,
//!   `1..240`, `1,3,5`, mixtures (`1..10,20,40..50`), and a step per range, `1..240:2` (every
//!   second frame from 1: 1, 3, 5, ...). Frame numbers are 0 to
//!   [`crate::scene::animation::MAX_FRAME`]; the frames are rendered once each, in increasing
//!   order. Without `--frames` a scene with `[animation]` renders its default range
//!   ([`Scene::default_frames`]); a still scene renders its one frame through
//!   [`render::render`].
//! - Names ([`super::frames::output_pattern`], [`super::frames::frame_path`]): the last run of
//!   `#` in `-o` becomes the frame number, zero-padded to the run's length
//!   (`-o out/orbit-####.png`: `out/orbit-0007.png`; wider numbers keep all their digits).
//!   Several frames and no `#`: `-####` is added before the extension, as Blender does.
//!   Without `-o`: `out/SCENE-METHOD-####.png` for a sequence (an animated scene or `--frames`
//!   given), `out/SCENE-METHOD.png` for a still.
//! - `--skip-existing` resumes: a frame whose file exists is skipped. Every file is written
//!   atomically (a temporary file renamed into place), so a killed run leaves whole frames only.
//! - `--shard I/N` or a scheduler's array index ([`super::shard`]) picks this run's contiguous
//!   chunk of the frames; the names come from the whole list, so every chunk names alike.
//! - A progress bar (samples of the frames, with an ETA; drawn only on a terminal) and a summary
//!   line: frames rendered and skipped, wall time, frames per minute, the output pattern.
//! - Each frame is the scene at that frame ([`Scene::at_frame`]) seen by the chosen camera at
//!   the frame's time, rendered by one [`FrameRenderer`] for the whole run (the capture is
//!   reused where only the camera moved; where a placement search ran for the frame, its bounded
//!   lists are uploaded instead of captured); a frame within a sequence is byte-identical to the
//!   same frame rendered alone (`tests/sequence/animation.rs`). `-v` logs how each frame filled
//!   its CMO data.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context as _, Result};

use super::frames::{frame_path, output_pattern, parse_frames};
use super::render::{self, RenderArgs};
use super::shard;
use crate::camera::Camera;
use crate::cubemap::bounds::BuiltLists;
use crate::output::{self, Format};
use crate::render::{self as engine, FrameRenderer, RenderedFrame};
use crate::scene::{self, Scene};

/// `cubetrace render`: a still scene without `--frames` is one frame, rendered by
/// [`render::render`]; otherwise the sequence of the module docs.
pub fn render(args: RenderArgs) -> Result<()> {
    let given = match &args.sequence.frames {
        Some(text) => Some(parse_frames(text).map_err(|e| anyhow::anyhow!("--frames: {e}"))?),
        None => None,
    };
    if given.is_none() && !animated(&args.scene) {
        // A still is one frame. An explicit shard is checked and only the shard whose chunk
        // holds that frame renders it; a scheduler's environment alone does not split a still
        // (one rendered inside an array job renders whole).
        if args.shard.shard.is_some() || args.shard.shard_count.is_some() {
            let shard = args.shard.resolve()?;
            if shard::select(&[1], shard.as_ref()).is_empty() {
                println!(
                    "a still scene is one frame, and it is not in this shard's chunk: nothing to render"
                );
                return Ok(());
            }
        }
        // The still path is the single-frame render (which loads the scene itself).
        if args.sequence.skip_existing {
            let path = match &args.output {
                Some(o) => o.clone(),
                None => {
                    let name = scene::load(&args.scene)?.name;
                    output_pattern(None, &name, args.method, false, 1)
                }
            };
            if std::fs::symlink_metadata(&path).is_ok() {
                println!("{} exists: skipped (--skip-existing)", path.display());
                return Ok(());
            }
        }
        return render::render(args);
    }
    run_sequence(args, given)
}

/// Whether `scene` (a built-in name or a scene file) has `[animation]`, read without loading
/// its meshes; false where it cannot be read (the still path reports why).
fn animated(scene: &str) -> bool {
    if let Some(s) = scene::builtin::by_name(scene) {
        return s.default_frames().is_some();
    }
    std::fs::read_to_string(scene)
        .ok()
        .and_then(|text| text.parse::<toml::Table>().ok())
        .is_some_and(|t| t.contains_key("animation"))
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
    let shard = args.shard.resolve()?;
    let mine = shard::select(&frames, shard.as_ref());
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
    let spp = u64::from(render::film_settings(&args, &base).spp.max(1));
    let bar = progress_bar(todo.len() as u64 * spp);
    let mut renderer: Option<FrameRenderer> = None;
    let mut placement = SequencePlacement::new(&args, &base, &frames)?;
    for job in &todo {
        let (scene, camera, lists) = frame_scene(&args, &base, job.frame, &mut placement)?;
        let lists = lists.as_deref();
        bar.set_message(format!("frame {}", job.frame));
        let r = match &mut renderer {
            Some(r) => r,
            None => {
                let setup = render::render_setup(&args, &scene)?;
                renderer.insert(FrameRenderer::open_with_lists(
                    &setup, &scene, &camera, lists,
                )?)
            }
        };
        let frame = r
            .render_with_lists(&scene, &camera, lists)
            .with_context(|| format!("frame {}", job.frame))?;
        frame.write(&job.path, format)?;
        log::info!("frame {}: {}", job.frame, cmo_fill(&frame));
        bar.suspend(|| println!("{}", summary(&frame, &job.path, job.frame)));
        if args.compare {
            let lines = render::compare_with_reference(&args, &scene, &camera, r.film(), &frame);
            bar.suspend(|| {
                for line in lines {
                    println!("frame {}: {line}", job.frame);
                }
            });
        }
        bar.inc(spp);
    }
    bar.finish_and_clear();
    if let Some(ctx) = renderer.as_ref().and_then(|r| r.context()) {
        engine::check_validation(ctx)?;
    }
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

/// The scene with the command line's overrides (CMOs, subdivision), before any frame; its
/// camera and frame size checked ([`engine::scene::prepare`], no placement search: the sequence
/// searches per frame).
fn load_base(args: &RenderArgs) -> Result<Scene> {
    let (scene, _, _) = engine::scene::prepare(&render::scene_setup(args, false))?;
    for problem in crate::placement::diagnose(&scene) {
        log::warn!("{problem}");
    }
    if let Some(warning) = engine::glossy::method_warning(&scene, args.method, args.bounces) {
        log::warn!("{warning}");
    }
    Ok(scene)
}

/// The sequence's CMO placement ([`crate::placement`]), searched once where only the camera
/// moves: for the cameras of a few frames spread over the whole sequence (not this run's shard
/// of it, so that every shard places alike), and again only on a frame whose mesh transforms
/// differ from the frame it was last searched for (then for that frame's camera).
struct SequencePlacement {
    /// The chosen camera at up to [`SAMPLED_FRAMES`] frames of the sequence.
    cameras: Vec<Camera>,
    /// The mesh transforms of the last search, and what it set in the scene.
    last: Option<(Vec<crate::scene::Transform>, SearchResult)>,
}

/// What a placement search sets in the scene ([`crate::placement::resolve_for`]): the centres,
/// the self-reflections and the lists' face size.
type SearchResult = (scene::CmoPlacement, scene::SelfReflections, Option<u32>);

/// Frames whose cameras the placement of a sequence samples.
const SAMPLED_FRAMES: usize = 4;

impl SequencePlacement {
    fn new(args: &RenderArgs, base: &Scene, frames: &[i64]) -> Result<Self> {
        let searched = args.method.captures_cmos()
            && matches!(base.cmo.placement, scene::CmoPlacement::Search { .. });
        let mut cameras = Vec::new();
        if searched && base.animation.meshes.is_empty() {
            let n = frames.len().clamp(1, SAMPLED_FRAMES);
            for k in 0..n {
                let frame = frames[k * (frames.len() - 1) / (n - 1).max(1)];
                cameras.push(frame_camera(args, &base.at_frame(frame), frame)?);
            }
        }
        Ok(SequencePlacement {
            cameras,
            last: None,
        })
    }

    /// Sets `scene`'s CMO placement at this frame: the last search's where the meshes stand
    /// where they stood then, else a new search. Returns a new search's bounded lists
    /// ([`crate::placement::Placement::lists`]), which the frame uploads instead of capturing;
    /// where the last search's placement is kept, the renderer keeps its CMO data.
    fn apply(
        &mut self,
        args: &RenderArgs,
        scene: &mut Scene,
        camera: &Camera,
    ) -> Option<Arc<BuiltLists>> {
        if !args.method.captures_cmos()
            || !matches!(scene.cmo.placement, scene::CmoPlacement::Search { .. })
        {
            return None;
        }
        let key: Vec<crate::scene::Transform> = scene.meshes.iter().map(|m| m.transform).collect();
        if let Some((k, set)) = &self.last
            && *k == key
        {
            (scene.cmo.placement, scene.self_reflections) = (set.0.clone(), set.1);
            scene.cmo.lists = set.2;
            return None;
        }
        let cameras = if self.cameras.is_empty() {
            std::slice::from_ref(camera)
        } else {
            &self.cameras[..]
        };
        let p = crate::placement::resolve_for(
            scene,
            cameras,
            args.bounces,
            args.trace.options(args.method).scoring(),
        );
        if let Some(p) = &p {
            render::log_placement(p);
        }
        let set = (
            scene.cmo.placement.clone(),
            scene.self_reflections,
            scene.cmo.lists,
        );
        self.last = Some((key, set));
        p.and_then(|p| p.lists)
    }
}

/// The chosen camera of `scene` (the sequence's scene at `frame`) at the command's frame size.
fn frame_camera(args: &RenderArgs, scene: &Scene, frame: i64) -> Result<Camera> {
    let mut camera = scene.camera(args.camera.as_deref())?.clone();
    (camera.width, camera.height) =
        engine::scene::frame_size((camera.width, camera.height), args.width, args.height);
    if let Some(why) = camera.view_error() {
        anyhow::bail!(
            "frame {frame}: camera '{}': eye, target and up do not span a view there: {why}; \
             check the scene's [animation] camera keys",
            camera.name
        );
    }
    Ok(camera)
}

/// The scene at `frame` and its camera (the chosen one, at the command's frame size), with the
/// sequence's CMO placement ([`SequencePlacement`]) and the lists of a search run for it.
fn frame_scene(
    args: &RenderArgs,
    base: &Scene,
    frame: i64,
    placement: &mut SequencePlacement,
) -> Result<(Scene, Camera, Option<Arc<BuiltLists>>)> {
    let mut scene = base.at_frame(frame);
    let camera = frame_camera(args, &scene, frame)?;
    let lists = placement.apply(args, &mut scene, &camera);
    Ok((scene, camera, lists))
}

/// How `frame` filled its CMO data: "capture ran", "lists uploaded" (the placement search's,
/// no capture) or "capture reused".
fn cmo_fill(frame: &RenderedFrame) -> &'static str {
    match (frame.captured, frame.lists_uploaded) {
        (true, _) => "capture ran",
        (false, true) => "lists uploaded",
        (false, false) => "capture reused",
    }
}

/// The `wrote ...` line of one frame of a sequence.
fn summary(frame: &RenderedFrame, path: &Path, number: i64) -> String {
    format!(
        "wrote {} (frame {number}, {}x{}, {} sample(s), {} mirror pixels, {}) in {:.2?}{}",
        path.display(),
        frame.width,
        frame.height,
        frame.spp,
        frame.mirror_pixels(),
        cmo_fill(frame),
        frame.render_time,
        if frame.gpu.is_some() {
            format!(" ({:.2} ms GPU)", frame.gpu_ms)
        } else {
            String::new()
        }
    )
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

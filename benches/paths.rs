//! `cargo bench --bench paths`: wall time per frame of the rendering paths, per built-in scene,
//! printed as a Markdown table.
//!
//! For now this measures the **exact CPU reference path only** (`reference::render`, one bounce,
//! the ground truth every other path is compared with). The GPU paths (capture -> pyramid ->
//! trace) will join through `cubetrace bench`, which times each pass with GPU timestamps; this
//! harness stays dependency-free (`std::time::Instant`, no criterion) and small enough to finish
//! in seconds.
//!
//! Method: per scene the BVH is built once (not timed), one warm-up frame is rendered, then
//! `FRAMES` frames are timed one by one. The table gives the median, min and max wall time per
//! frame and the median nanoseconds per mirror pixel (pixels whose primary ray hits a reflector;
//! every pixel is still traced, so this is a cost per useful pixel, not per traced ray). The
//! renderer is parallel over rows (rayon), so figures depend on the machine's core count and
//! load; compare them only on one machine.
#![forbid(unsafe_code)]

use std::time::{Duration, Instant};

use cubetrace::reference::{Tracer, render};
use cubetrace::scene::builtin;

/// Frame size: small, so the whole run takes seconds even on two shared cores.
const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;
/// Timed frames per scene under `cargo bench`, after one warm-up frame.
const FRAMES: usize = 21;
/// Reflections per path, as `cubetrace render`'s default.
const BOUNCES: u32 = 1;

fn median(sorted: &[Duration]) -> Duration {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        (sorted[n / 2 - 1] + sorted[n / 2]) / 2
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() {
    // `cargo bench` passes `--bench` (and a filter, if given); a filter selects scenes by name.
    // Without `--bench` (`cargo test --all-targets` runs this binary as a test) one timed frame
    // per scene is enough to show that the harness works.
    let args: Vec<String> = std::env::args().skip(1).collect();
    let filter = args.iter().find(|a| !a.starts_with("--"));
    let frames = if args.iter().any(|a| a == "--bench") {
        FRAMES
    } else {
        1
    };
    println!(
        "Reference path (exact CPU ray tracing), {WIDTH}x{HEIGHT}, {BOUNCES} bounce(s), \
         {frames} frame(s) after 1 warm-up, {} rayon threads\n",
        rayon::current_num_threads()
    );
    println!(
        "| scene | path | mirror px | median ms/frame | min ms | max ms | median ns/mirror px |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|");
    for (name, _) in builtin::NAMES {
        if filter.is_some_and(|f| !name.contains(f.as_str())) {
            continue;
        }
        let Some(scene) = builtin::by_name(name) else {
            eprintln!("built-in scene `{name}` is listed but not defined; skipped");
            continue;
        };
        let Some(camera) = scene.cameras.first() else {
            eprintln!("scene `{name}` has no camera; skipped");
            continue;
        };
        let mut camera = camera.clone();
        camera.width = WIDTH;
        camera.height = HEIGHT;
        let tracer = Tracer::new(&scene);
        let warm = render(&scene, &tracer, &camera, BOUNCES);
        let mirror = warm.mirror_pixels();
        let mut times: Vec<Duration> = (0..frames)
            .map(|_| {
                let start = Instant::now();
                let frame = render(&scene, &tracer, &camera, BOUNCES);
                let dt = start.elapsed();
                // Keep the frame observable so the render cannot be optimised away.
                std::hint::black_box(&frame);
                dt
            })
            .collect();
        times.sort();
        let med = median(&times);
        let per_mirror = if mirror > 0 {
            format!("{:.0}", med.as_secs_f64() * 1e9 / mirror as f64)
        } else {
            "n/a".into()
        };
        println!(
            "| {name} | reference | {mirror} | {:.2} | {:.2} | {:.2} | {per_mirror} |",
            ms(med),
            ms(times[0]),
            ms(times[times.len() - 1]),
        );
    }
}

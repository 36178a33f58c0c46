#![forbid(unsafe_code)]
//! `cubetrace bench --scaling`: cost of one GPU method (default: `fragment`, centre criterion with
//! the pyramid) against one quantity at a time, everything else at its default:
//!
//! | axis | scene | values (default) |
//! |---|---|---|
//! | cube face size | `sphere-room` | 32, 64, ..., 1024 (`--max-cube`, up to 4096) |
//! | screen size | `sphere-room` | 80x60, 160x120, 320x240, 640x480 |
//! | number of CMOs | `default` | 1, 2, 4, 8 (automatic placement) |
//! | scene triangles | `sphere-room` plus one extra UV sphere beside the mirror | 8, 32, 128, 512 segments |
//!
//! On the triangle axis the cubemap paths (the chosen method, and `compute` where that is
//! another) stand beside `bvh`, exact GPU ray tracing: its trace cost grows with the triangles
//! (a BVH's depth), theirs should not.
//!
//! Output: `scaling.json`, `scaling.md` and one `scaling-AXIS.svg` per axis (GPU ms per pass
//! against the quantity, log-log). No error figures for the chosen method: this measures cost.
//!
//! The triangle axis has a second part, the **tessellation curve** of the reflection-point
//! method ([`TessellationPoint`]): it reflects vertices, so its error depends on how finely the
//! other objects are tessellated. Per series (by default [`TESSELLATION_SERIES`]: a built-in
//! scene and a search scale), the non-reflector objects are subdivided 0 to
//! [`TESSELLATION_LEVELS`] times
//! ([`crate::cpu::reflection_point::subdivide_non_reflectors`]: the same surfaces, so the
//! unsubdivided scene's reference serves every level) and the frame is measured against the exact
//! reference: unresolved and wrong-surface shares, the share of the reference's object
//! ([`metrics::same_object`], the paper's claim), PSNR, and the cost of its two passes. The
//! convex `sphere-room` beside the concave `bowl` and the mixed `torus` shows the limitation of
//! one reflection point per vertex. Output: the second table of `scaling.md`, `tessellation` in
//! `scaling.json`, `scaling-tessellation.svg` (error shares) and
//! `scaling-tessellation-psnr.svg`.
//!
//! Invariant: the tracing pass reads only the CMO data, so its cost can depend on the cube size,
//! the screen and the CMO count, but not on the triangle count; the capture pass rasterises the
//! scene and does depend on it. The triangle axis shows whether that holds.

use std::path::{Path, PathBuf};

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use super::plot;
use super::{
    Counters, DeviceInfo, MethodSpec, PassStats, Stats, frame_stats, git_commit, pass_stats,
    prepare_scene_judged, run_gpu, run_gpu_with, run_reference,
};
use crate::cpu::reflection_point::{RpOptions, SearchStats, subdivide_non_reflectors};
use crate::method::Method;
use crate::metrics::{self, ErrorReport, SameObject};
use crate::output::write_atomic;
use crate::placement::Scoring;
use crate::scene::shapes::uv_sphere;
use crate::scene::{Material, MeshInstance, Scene, Transform};
use crate::vk::GpuContext;
use crate::vk::frame::shown_objects;
use crate::vk::frame::{Fallback, RenderOptions, pass_name};
use crate::vk::methods::reflection_point::TARGETS_PASS;

/// Which quantity a point varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Axis {
    CubeSize,
    Screen,
    Cmos,
    Triangles,
}

impl Axis {
    pub const ALL: [Axis; 4] = [Axis::CubeSize, Axis::Screen, Axis::Cmos, Axis::Triangles];

    pub fn name(self) -> &'static str {
        match self {
            Axis::CubeSize => "cube-size",
            Axis::Screen => "screen",
            Axis::Cmos => "cmos",
            Axis::Triangles => "triangles",
        }
    }

    fn x_desc(self) -> &'static str {
        match self {
            Axis::CubeSize => "texels per cube face side",
            Axis::Screen => "pixels in the frame",
            Axis::Cmos => "number of CMOs",
            Axis::Triangles => "triangles in the scene",
        }
    }
}

/// Options of the scaling run.
#[derive(Clone, Debug)]
pub struct ScalingConfig {
    pub method: MethodSpec,
    pub axes: Vec<Axis>,
    /// Largest cube face size on the cube axis (powers of two from 32).
    pub max_cube: u32,
    /// Frame size on the axes other than the screen.
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub warmup: u32,
    pub out: PathBuf,
    /// The reflection-point tessellation curve's series, (scene, search scale); none: no curve.
    pub tessellation_series: Vec<(String, u32)>,
    /// The curve's subdivision levels: 0 to this.
    pub tessellation_levels: u32,
}

/// One measured point.
#[derive(Clone, Debug, Serialize)]
pub struct ScalingPoint {
    pub axis: Axis,
    /// The method's label ([`MethodSpec::label`]).
    pub method: String,
    /// The quantity varied (texels, pixels, CMOs or triangles).
    pub x: f64,
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub cube_size: u32,
    pub cmos: u32,
    pub triangles: usize,
    pub mirror_pixels: usize,
    pub passes: Vec<PassStats>,
    pub trace_ns: Stats,
    pub trace_ns_per_mirror_px: f64,
    pub counters: Counters,
    pub cmo_bytes: u64,
}

/// The tessellation curve's series: (built-in scene, search scale). `sphere-room` at scale 8
/// is where the paper's claim is met (`tests/reflection_point.rs`).
pub const TESSELLATION_SERIES: [(&str, u32); 4] = [
    ("sphere-room", 1),
    ("sphere-room", 8),
    ("bowl", 1),
    ("torus", 1),
];

/// The triangle axis's extra spheres: [`tessellated_scene`] of these many segments (also the
/// cost model's triangle axis, `bench --model`).
pub const TRIANGLE_SEGMENTS: [u32; 4] = [8, 32, 128, 512];

/// The tessellation curve's subdivision levels: 0 to this.
pub const TESSELLATION_LEVELS: u32 = 4;

/// One point of the reflection-point method's tessellation curve.
#[derive(Clone, Debug, Serialize)]
pub struct TessellationPoint {
    pub scene: String,
    /// Times the non-reflector objects were split into four.
    pub subdivide: u32,
    pub search_scale: u32,
    pub triangles: usize,
    pub width: u32,
    pub height: u32,
    pub mirror_pixels: usize,
    /// Against the unsubdivided scene's reference.
    pub error: ErrorReport,
    pub same_object: SameObject,
    /// The reflector textures' draw (`reflection_point_targets`), the per-vertex search and the
    /// virtual objects' raster.
    pub rp_targets_ns: Stats,
    pub rp_search_ns: Stats,
    pub rp_raster_ns: Stats,
    pub search: SearchStats,
}

#[derive(Clone, Debug, Serialize)]
pub struct ScalingReport {
    pub device: DeviceInfo,
    pub git_commit: Option<String>,
    pub method: String,
    pub frames: u32,
    pub warmup: u32,
    pub points: Vec<ScalingPoint>,
    /// The reflection-point method's tessellation curve (with the triangle axis).
    pub tessellation: Vec<TessellationPoint>,
}

/// `sphere-room` with one extra diffuse UV sphere of `segments` x `segments / 2` quads beside
/// the mirror, in its view: a scene whose triangle count is set by one number.
pub fn tessellated_scene(segments: u32) -> Result<Scene> {
    let mut scene = crate::scene::builtin::by_name("sphere-room")
        .ok_or_else(|| anyhow::anyhow!("built-in scene sphere-room is missing"))?;
    let material = scene.materials.len() as u32;
    scene.materials.push(Material {
        name: "tessellated".into(),
        diffuse: Vec3::new(0.3, 0.7, 0.9),
        texture: None,
        specular_power: None,
    });
    scene.meshes.push(MeshInstance {
        name: "tessellated-ball".into(),
        parts: vec![uv_sphere(0.45, segments, (segments / 2).max(2), material)],
        transform: Transform::translation(Vec3::new(1.6, 1.6, -0.6)),
        reflector: false,
    });
    scene.name = format!("sphere-room+ball{segments}");
    Ok(scene)
}

/// One point to measure: `(x, scene, width, height)`.
type PlanPoint = (f64, Scene, u32, u32);

/// The points of one axis.
fn plan(axis: Axis, cfg: &ScalingConfig) -> Result<Vec<PlanPoint>> {
    let (w, h) = (cfg.width, cfg.height);
    let mut out = Vec::new();
    match axis {
        Axis::CubeSize => {
            let mut n = 32;
            while n <= cfg.max_cube {
                let (s, _) =
                    prepare_scene_judged("sphere-room", w, h, (Some(n), None), Scoring::Centre)?;
                out.push((f64::from(n), s, w, h));
                n *= 2;
            }
        }
        Axis::Screen => {
            for (sw, sh) in [(80, 60), (160, 120), (320, 240), (640, 480)] {
                let (s, _) =
                    prepare_scene_judged("sphere-room", sw, sh, (None, None), Scoring::Centre)?;
                out.push((f64::from(sw * sh), s, sw, sh));
            }
        }
        Axis::Cmos => {
            for k in [1, 2, 4, 8] {
                let (s, _) =
                    prepare_scene_judged("default", w, h, (None, Some(k)), Scoring::Centre)?;
                out.push((f64::from(k), s, w, h));
            }
        }
        Axis::Triangles => {
            for seg in TRIANGLE_SEGMENTS {
                let s = tessellated_scene(seg)?;
                let t = s.world().triangles.len();
                out.push((t as f64, s, w, h));
            }
        }
    }
    Ok(out)
}

/// Runs the chosen axes.
pub fn run(
    ctx: &GpuContext,
    cfg: &ScalingConfig,
    bar: &indicatif::ProgressBar,
) -> Result<ScalingReport> {
    let gpu = cfg
        .method
        .kind
        .is_gpu()
        .then_some(cfg.method.kind)
        .ok_or_else(|| anyhow::anyhow!("--scaling measures a GPU method, not the reference"))?;
    let plans: Vec<(Axis, Vec<PlanPoint>)> = cfg
        .axes
        .iter()
        .map(|&a| Ok((a, plan(a, cfg)?)))
        .collect::<Result<_>>()?;
    let curve_points =
        cfg.tessellation_series.len() as u64 * u64::from(cfg.tessellation_levels + 1);
    bar.set_length(plans.iter().map(|(_, p)| p.len() as u64).sum::<u64>() + curve_points);
    let mut points = Vec::new();
    for (axis, plan) in plans {
        // The triangle axis also runs the default method (compute) and the exact GPU tracer
        // (bvh), each once, in the setting the model replays (the model reads this axis).
        let mut methods = vec![(cfg.method, gpu)];
        if axis == Axis::Triangles {
            for kind in [super::Method::DEFAULT, super::Method::EXACT_GPU] {
                let spec = MethodSpec::modelled(kind);
                if let (Some(g), true) = (
                    kind.is_gpu().then_some(kind),
                    methods.iter().all(|(m, _)| *m != spec),
                ) {
                    methods.push((spec, g));
                }
            }
        }
        bar.inc_length((plan.len() * (methods.len() - 1)) as u64);
        for (x, scene, width, height) in plan {
            for &(spec, gpu) in &methods {
                bar.set_message(format!("{}: {x} {}", axis.name(), spec.label()));
                let mut camera = scene.cameras[0].clone();
                camera.width = width;
                camera.height = height;
                let g = run_gpu(
                    ctx, &scene, &camera, gpu, spec.trace, cfg.warmup, cfg.frames,
                )?;
                let mirror = g.frame.mirror_pixels();
                let trace_ns = frame_stats(&g.pass_ns, Some(pass_name(gpu)));
                points.push(ScalingPoint {
                    axis,
                    method: spec.label(),
                    x,
                    scene: scene.name.clone(),
                    width,
                    height,
                    cube_size: scene.cmo.resolution,
                    cmos: scene.cmo_centres().len() as u32,
                    triangles: scene.world().triangles.len(),
                    mirror_pixels: mirror,
                    passes: pass_stats(&g.pass_ns),
                    trace_ns,
                    trace_ns_per_mirror_px: trace_ns.median / mirror.max(1) as f64,
                    counters: Counters::of(&g.frame),
                    cmo_bytes: g.cmo_bytes,
                });
                bar.inc(1);
                super::check_validation(ctx)?;
            }
        }
    }
    let tessellation = tessellation_curve(ctx, cfg, bar)?;
    Ok(ScalingReport {
        device: DeviceInfo::of(ctx),
        git_commit: git_commit(),
        method: cfg.method.label(),
        frames: cfg.frames,
        warmup: cfg.warmup,
        points,
        tessellation,
    })
}

/// The reflection-point method's error against the reference as the other objects are
/// subdivided: every series of [`ScalingConfig::tessellation_series`], levels 0 to
/// [`ScalingConfig::tessellation_levels`].
fn tessellation_curve(
    ctx: &GpuContext,
    cfg: &ScalingConfig,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<TessellationPoint>> {
    let mut out = Vec::new();
    let mut reference: Option<(String, crate::reference::Frame)> = None;
    // The method whose quality depends on the other objects' tessellation (reflection-point).
    let tessellated = (Method::ALL.into_iter())
        .find(|m| m.info().vertex_search)
        .expect("a method searches per vertex");
    for (name, scale) in &cfg.tessellation_series {
        let (name, scale) = (name.as_str(), *scale);
        let (scene, camera) =
            prepare_scene_judged(name, cfg.width, cfg.height, (None, None), Scoring::Centre)?;
        if reference.as_ref().is_none_or(|(n, _)| n != name) {
            bar.set_message(format!("tessellation: {name} reference"));
            reference = Some((name.to_string(), run_reference(&scene, &camera, 0, 1).frame));
        }
        let refr = &reference.as_ref().expect("set above").1;
        let centres = scene.cmo_centres();
        let reflector: Vec<bool> = scene.world().objects.iter().map(|o| o.reflector).collect();
        for level in 0..=cfg.tessellation_levels {
            bar.set_message(format!("tessellation: {name} x{scale} subdivided {level}"));
            let mut sub = scene.clone();
            subdivide_non_reflectors(&mut sub, level);
            let options = RenderOptions {
                method: tessellated,
                fallback: Fallback::Envmap,
                reflection_point: RpOptions {
                    search_scale: scale,
                    ..RpOptions::default()
                },
                ..RenderOptions::default()
            };
            let g = run_gpu_with(ctx, &sub, &camera, options, cfg.warmup, cfg.frames)?;
            let traced = g.frame.traced();
            let error = metrics::compare(
                refr,
                &traced,
                &g.frame.surface_position,
                &centres,
                scene.cmo.resolution,
            );
            out.push(TessellationPoint {
                scene: name.to_string(),
                subdivide: level,
                search_scale: scale,
                triangles: sub.world().triangles.len(),
                width: cfg.width,
                height: cfg.height,
                mirror_pixels: g.frame.mirror_pixels(),
                error,
                same_object: metrics::same_object(refr, &reflector, &shown_objects(&g.frame)),
                rp_targets_ns: frame_stats(&g.pass_ns, Some(TARGETS_PASS)),
                rp_search_ns: frame_stats(&g.pass_ns, Some("reflection_point_search")),
                rp_raster_ns: frame_stats(&g.pass_ns, Some("reflection_point_raster")),
                search: g.frame.search.unwrap_or_default(),
            });
            bar.inc(1);
            super::check_validation(ctx)?;
        }
    }
    Ok(out)
}

/// The Markdown table of the tessellation curve.
pub fn tessellation_table(points: &[TessellationPoint]) -> String {
    use std::fmt::Write as _;
    let mut s = String::from(
        "| scene | search scale | subdivide | triangles | frame | mirror px | unresolved % | wrong surface % | same object % | same object, interior % | angle mean deg | PSNR dB | reflection_point_targets ms | reflection_point_search ms | reflection_point_raster ms | steps mean / max |\n\
         |---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for p in points {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {}x{} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {:.2} | {:.3} | {:.3} | {:.3} | {:.1} / {} |",
            p.scene,
            p.search_scale,
            p.subdivide,
            p.triangles,
            p.width,
            p.height,
            p.mirror_pixels,
            100.0 * p.error.unresolved,
            100.0 * p.error.wrong_surface,
            100.0 * p.same_object.share,
            100.0 * p.same_object.interior_share,
            p.error.angular_mean_deg,
            p.error.psnr_db,
            p.rp_targets_ns.median * 1e-6,
            p.rp_search_ns.median * 1e-6,
            p.rp_raster_ns.median * 1e-6,
            p.search.mean_iterations,
            p.search.max_iterations,
        );
    }
    s
}

/// The tessellation curve's plots: error shares, and PSNR, against the triangle count; one line
/// per series and figure.
fn tessellation_plots(points: &[TessellationPoint]) -> Result<[String; 2]> {
    let mut series: Vec<(String, u32)> = Vec::new();
    for p in points {
        if !series.contains(&(p.scene.clone(), p.search_scale)) {
            series.push((p.scene.clone(), p.search_scale));
        }
    }
    let line =
        |(scene, scale): &(String, u32), what: &str, f: &dyn Fn(&TessellationPoint) -> f64| {
            let v = points
                .iter()
                .filter(|p| p.scene == *scene && p.search_scale == *scale)
                .map(|p| (p.triangles as f64, f(p)))
                .collect();
            (format!("{scene} x{scale} {what}"), v)
        };
    let mut shares = Vec::new();
    let mut psnr = Vec::new();
    for s in &series {
        shares.push(line(s, "wrong surface %", &|p| {
            100.0 * p.error.wrong_surface
        }));
        shares.push(line(s, "not the reference's object %", &|p| {
            100.0 * (1.0 - p.same_object.share)
        }));
        psnr.push(line(s, "PSNR dB", &|p| p.error.psnr_db));
    }
    Ok([
        plot::lines(
            "reflection-point: error against the reference as the other objects are subdivided",
            "triangles in the scene",
            "% of mirror pixels (of those showing an object, for the object share)",
            &shares,
        )?,
        plot::lines(
            "reflection-point: PSNR of the mirror pixels as the other objects are subdivided",
            "triangles in the scene",
            "PSNR dB (mirror pixels)",
            &psnr,
        )?,
    ])
}

/// The Markdown table of a scaling report.
pub fn table(report: &ScalingReport) -> String {
    use std::fmt::Write as _;
    let mut s = String::from(
        "| axis | x | method | scene | frame | cube | CMOs | triangles | mirror px | capture ms | pyramid ms | trace ms | ns/mirror px | cells/ray | texels/ray | CMO MiB |\n\
         |---|---:|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for p in &report.points {
        let pass = |name: &str| {
            p.passes
                .iter()
                .find(|q| q.pass == name)
                .map_or("-".into(), |q| format!("{:.3}", q.ns.median * 1e-6))
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {}x{} | {} | {} | {} | {} | {} | {} | {:.3} | {:.0} | {:.1} | {:.1} | {:.2} |",
            p.axis.name(),
            p.x,
            p.method,
            p.scene,
            p.width,
            p.height,
            p.cube_size,
            p.cmos,
            p.triangles,
            p.mirror_pixels,
            pass("capture"),
            pass("pyramid"),
            p.trace_ns.median * 1e-6,
            p.trace_ns_per_mirror_px,
            p.counters.cells,
            p.counters.texels,
            p.cmo_bytes as f64 / (1024.0 * 1024.0),
        );
    }
    s
}

/// Writes `scaling.json`, `scaling.md` and one SVG per axis into `dir`; returns the paths.
pub fn write(report: &ScalingReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut paths = Vec::new();
    let json = dir.join("scaling.json");
    write_atomic(&json, serde_json::to_string_pretty(report)?.as_bytes())?;
    paths.push(json);
    let md = dir.join("scaling.md");
    let mut doc = format!(
        "# cubetrace bench --scaling\n\nDevice: {}; commit {}; method {}; {} timed frames after {} warm-up.\n\n{}",
        report.device.describe(),
        report.git_commit.as_deref().unwrap_or("unknown"),
        report.method,
        report.frames,
        report.warmup,
        table(report)
    );
    if !report.tessellation.is_empty() {
        doc.push_str(&format!(
            "\n## Reflection-point: tessellation curve\n\nThe non-reflector objects subdivided 0 to {} times, against the unsubdivided scene's reference (same surfaces). Same object: of the reference's mirror pixels that show a non-reflector object, the share showing that object (interior: away from edges between objects and the mirror's outline).\n\n{}",
            report.tessellation.iter().map(|p| p.subdivide).max().unwrap_or(0),
            tessellation_table(&report.tessellation)
        ));
    }
    write_atomic(&md, doc.as_bytes())?;
    paths.push(md);
    for axis in Axis::ALL {
        let pts: Vec<&ScalingPoint> = report.points.iter().filter(|p| p.axis == axis).collect();
        if pts.is_empty() {
            continue;
        }
        // One series per (method, pass); the method is named where the axis has several.
        let mut names: Vec<(String, String)> = Vec::new();
        for p in &pts {
            for q in &p.passes {
                let key = (p.method.clone(), q.pass.clone());
                if !names.contains(&key) {
                    names.push(key);
                }
            }
        }
        let several = pts.iter().any(|p| p.method != pts[0].method);
        let series: Vec<(String, Vec<(f64, f64)>)> = names
            .into_iter()
            .map(|(m, n)| {
                let v = pts
                    .iter()
                    .filter(|p| p.method == m)
                    .filter_map(|p| {
                        let q = p.passes.iter().find(|q| q.pass == n)?;
                        Some((p.x, q.ns.median * 1e-6))
                    })
                    .collect();
                let name = if several {
                    format!("{m} {n} (ms)")
                } else {
                    format!("{n} (ms)")
                };
                (name, v)
            })
            .collect();
        let svg = plot::lines(
            &format!(
                "{}: GPU time per pass against {}",
                report.method,
                axis.name()
            ),
            axis.x_desc(),
            "GPU ms per frame (median)",
            &series,
        )?;
        let path = dir.join(format!("scaling-{}.svg", axis.name()));
        write_atomic(&path, svg.as_bytes())?;
        paths.push(path);
    }
    if !report.tessellation.is_empty() {
        let [shares, psnr] = tessellation_plots(&report.tessellation)?;
        for (name, svg) in [
            ("scaling-tessellation.svg", shares),
            ("scaling-tessellation-psnr.svg", psnr),
        ] {
            let path = dir.join(name);
            write_atomic(&path, svg.as_bytes())?;
            paths.push(path);
        }
    }
    Ok(paths)
}

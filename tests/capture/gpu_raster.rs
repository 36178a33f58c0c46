//! The rasterising passes against the CPU: `capture` against the CPU ray-cast capture
//! (`cpu::capture::capture`), `gbuffer` against the reference's primary hits. Needs a Vulkan driver
//! (CI: lavapipe); runs under the validation layer when installed and fails on any error.
use crate::common;
use common::{finish_gpu, gpu_context};

use ash::vk;
use cubetrace::camera::Camera;
use cubetrace::check_layout;
use cubetrace::cpu::options::TraceOptions;
use cubetrace::cubemap::CubeMap;
use cubetrace::cubemap::Texel;
use cubetrace::cubemap::face::texel_centre_dir;
use cubetrace::ranges::FrameRanges;
use cubetrace::reference::{self, Tracer};
use cubetrace::scene::WorldGeometry;
use cubetrace::scene::gpu_data::{
    GpuMaterial, GpuObject, GpuSceneData, GpuShading, GpuTexture, GpuVertex,
};
use cubetrace::scene::shapes::uv_sphere;
use cubetrace::scene::{MeshInstance, Scene, SelfReflections, Transform, builtin};
use cubetrace::vk::GpuContext;
use cubetrace::vk::backend::shaders::{CAPTURE, GBUFFER};
use cubetrace::vk::passes::capture::{Capture, CaptureView, face_triangles};
use cubetrace::vk::passes::cmo::{CaptureContents, CmoData};
use cubetrace::vk::passes::gbuffer::{Gbuffer, GbufferCamera};
use cubetrace::vk::passes::scene_buffers::SceneBuffers;
use glam::{Vec3, Vec4};

/// Captures the scene's CMOs on the GPU and reads them back: colour and triangle IDs.
fn gpu_capture(ctx: &GpuContext, scene: &Scene, centres: &[Vec3], size: u32) -> Vec<CubeMap> {
    let both = CaptureContents {
        colour: true,
        triangle_ids: true,
    };
    gpu_capture_with(ctx, scene, centres, size, both).0
}

/// [`gpu_capture`] of the chosen contents; also returns the CMO data's bytes.
fn gpu_capture_with(
    ctx: &GpuContext,
    scene: &Scene,
    centres: &[Vec3],
    size: u32,
    contents: CaptureContents,
) -> (Vec<CubeMap>, u64) {
    let data = GpuSceneData::new(scene);
    let buffers = SceneBuffers::new(ctx, &data).unwrap();
    let near = 1e-5 * scene.world().extent();
    let cap = Capture::with_contents(
        ctx,
        &data,
        &buffers,
        centres,
        size,
        scene.captures_reflectors(),
        near,
        contents,
    )
    .unwrap();
    record_capture(ctx, &cap, scene, centres, size, contents)
}

/// Records `cap` (of `centres`, faces of `size`, capturing `contents`) into new CMO data and
/// reads it back; also returns the CMO data's bytes.
fn record_capture(
    ctx: &GpuContext,
    cap: &Capture,
    scene: &Scene,
    centres: &[Vec3],
    size: u32,
    contents: CaptureContents,
) -> (Vec<CubeMap>, u64) {
    let cmo = CmoData::with_contents(
        ctx,
        centres,
        size,
        scene.captures_reflectors(),
        false,
        &TraceOptions::default(),
        contents,
    )
    .unwrap();
    ctx.submit_and_wait("capture", |rec| cap.record(rec, &cmo, scene.background))
        .unwrap();
    (cmo.read_back(ctx).unwrap(), cmo.bytes())
}

/// Texels whose triangle IDs differ.
fn id_mismatches(gpu: &CubeMap, cpu: &CubeMap) -> usize {
    gpu.triangle
        .iter()
        .zip(&cpu.triangle)
        .filter(|(g, c)| g != c)
        .count()
}

/// Angle (radians, seen from the CMO centre) between a texel's centre ray and the nearest edge
/// of triangle `tri`: how closely the ray grazes it.
fn edge_angle(world: &WorldGeometry, centre: Vec3, dir: Vec3, tri: u32) -> f64 {
    let c = centre.as_dvec3();
    let u = dir.as_dvec3().normalize();
    let p = world.triangles[tri as usize].map(|i| world.positions[i as usize].as_dvec3() - c);
    let mut best = f64::INFINITY;
    for k in 0..3 {
        let (a, b) = (p[k], p[(k + 1) % 3]);
        // The point of segment ab nearest to the ray's line, by a fine search on the segment
        // (robust, and the tests' meshes are small).
        for s in 0..=256 {
            let x = a.lerp(b, s as f64 / 256.0);
            let along = x.dot(u);
            if along > 0.0 {
                best = best.min((x - u * along).length().atan2(along));
            }
        }
    }
    best
}

/// Angle within which a texel's centre ray counts as grazing a triangle edge: there the
/// rasteriser's tie rule (and its sub-texel vertex snapping) and the CPU's f64 test may see
/// different triangles. A 1/256 of a texel (a texel spans about 2/N rad at a face centre): far
/// above round-off, far below a texel; the 1/256-step edge search above is finer than that on
/// the test scenes' small triangles near the CMOs.
fn id_graze_rad(size: u32) -> f64 {
    2.0 / size as f64 / 256.0
}

/// ID mismatches where the centre ray does not graze an edge of either triangle.
fn unexplained_id_mismatches(
    gpu: &CubeMap,
    cpu: &CubeMap,
    world: &WorldGeometry,
) -> Vec<(usize, u32, u32, f64)> {
    let mut out = Vec::new();
    for i in 0..gpu.triangle.len() {
        let (g, c) = (gpu.triangle[i], cpu.triangle[i]);
        if g == c {
            continue;
        }
        let dir = texel_centre_dir(Texel::from_index(i, cpu.size), cpu.size);
        let angle = [g, c]
            .into_iter()
            .filter(|&t| (t as usize) < world.triangles.len())
            .map(|t| edge_angle(world, cpu.centre, dir, t))
            .fold(f64::INFINITY, f64::min);
        if angle > id_graze_rad(cpu.size) {
            out.push((i, g, c, angle));
        }
    }
    out
}

/// Texels where GPU and CPU captures disagree: distance off by more than `rel` relative, or
/// colour off by more than `colour_tol`, or one empty and the other not.
fn capture_mismatches(gpu: &CubeMap, cpu: &CubeMap, rel: f32, colour_tol: f32) -> usize {
    gpu.distance
        .iter()
        .zip(&cpu.distance)
        .zip(gpu.colour.iter().zip(&cpu.colour))
        .filter(|((g, c), (gc, cc))| {
            let dist_bad = if g.is_finite() && c.is_finite() {
                (*g - *c).abs() > rel * c.abs()
            } else {
                g.is_finite() != c.is_finite()
            };
            let col_bad = (0..4).any(|i| (gc[i] - cc[i]).abs() > colour_tol);
            dist_bad || col_bad
        })
        .count()
}

/// Relative distance tolerance: the rasteriser interpolates the world position at the texel
/// centre (perspective-correct) where the CPU intersects the texel ray with the triangle in f64
/// and rounds; both are the same point up to a few f32 ulps of the coordinates, i.e. ~1e-6
/// relative. 1e-4 leaves room for interpolation round-off across large triangles (room walls).
const CAPTURE_DISTANCE_REL: f32 = 1e-4;
/// Colour tolerance (linear units): the shading is the same arithmetic, but the interpolated
/// uv and normal differ from the CPU's barycentrics by round-off; textures are sampled bilinearly,
/// so a uv off by 1e-6 changes the colour by far less than 1e-3.
const CAPTURE_COLOUR_TOL: f32 = 1e-3;
/// Share of texels allowed to differ: texels whose centre ray passes within round-off of a
/// triangle edge, where rasterisation's tie rule and the CPU's f64 test may pick different
/// triangles (a silhouette: different distance; a shared edge: the same). Measured on
/// sphere-room at 16 and 32: under 0.3%; the bound is 1%.
const CAPTURE_MISMATCH_SHARE: f64 = 0.01;
/// Share of texels whose triangle IDs may differ, all of them at texels whose centre ray grazes
/// an edge (checked one by one by [`unexplained_id_mismatches`]): shared edges, where the two
/// triangles give the same distance, and silhouettes. Measured: sphere-room 0.26% at N = 16
/// (4 texels), 0.11% at 32 (7), teapot 0% at 16; the bound is 1%, as for the distances.
const CAPTURE_ID_MISMATCH_SHARE: f64 = 0.01;

#[test]
fn shared_structs_match_naga_layout() {
    let l = |name| CAPTURE.struct_layout(name).unwrap();
    check_layout!(
        GpuVertex,
        l("GpuVertex"),
        [position, object, normal, colour_r, uv, colour_gb]
    )
    .unwrap();
    check_layout!(
        GpuObject,
        l("GpuObject"),
        [
            material,
            reflector,
            captured,
            specular_power,
            vertex_colours
        ]
    )
    .unwrap();
    check_layout!(GpuMaterial, l("GpuMaterial"), [diffuse, texture]).unwrap();
    check_layout!(GpuTexture, l("GpuTexture"), [offset, width, height, _pad]).unwrap();
    check_layout!(
        GpuShading,
        l("GpuShading"),
        [
            model,
            ambient,
            light_intensity,
            _pad,
            light_direction,
            _pad2,
            background,
            _pad3
        ]
    )
    .unwrap();
    check_layout!(
        CaptureView,
        l("CaptureView"),
        [centre, face, near, reflectors, first, count]
    )
    .unwrap();
    check_layout!(
        GbufferCamera,
        GBUFFER.struct_layout("GbufferCamera").unwrap(),
        [
            view_proj, eye, tan_half, right, aspect, up, width, back, height, jitter, pad
        ]
    )
    .unwrap();
}

/// The torus scene with a second reflector, a convex sphere: under `self_reflections = auto`
/// the capture draws the torus (it sees itself) and culls the sphere.
fn torus_and_sphere() -> Scene {
    let mut scene = builtin::torus();
    scene.self_reflections = SelfReflections::Auto;
    let material = scene.meshes[1].parts[0].material;
    scene.meshes.push(MeshInstance {
        name: "mirror-sphere".into(),
        // Inside the torus's hole, clear of the tube and of the CMO centre.
        parts: vec![uv_sphere(0.15, 24, 12, material)],
        transform: Transform::translation(Vec3::new(0.25, 1.5, 0.25)),
        reflector: true,
    });
    assert_eq!(
        scene.self_capture().iter().filter(|&&c| c).count(),
        1,
        "the torus only"
    );
    scene
}

/// Negative for the per-reflector choice: a GPU capture that draws every reflector (one switch
/// for all reflectors, on) differs from the CPU capture of the same scene under auto.
#[test]
fn capture_comparison_fails_when_every_reflector_is_drawn() {
    let ctx = gpu_context();
    let scene = torus_and_sphere();
    let centres = scene.cmo_centres();
    let tracer = Tracer::new(&scene);
    let mut on = scene.clone();
    on.self_reflections = SelfReflections::On;
    let gpu = gpu_capture(&ctx, &on, &centres, 16);
    let cpu = cubetrace::cpu::capture::capture(&scene, &tracer, centres[0], 16);
    let bad = capture_mismatches(&gpu[0], &cpu, CAPTURE_DISTANCE_REL, CAPTURE_COLOUR_TOL);
    let share = bad as f64 / cpu.distance.len() as f64;
    eprintln!(
        "sphere drawn on the GPU only: {bad} texels differ ({:.3}%)",
        100.0 * share
    );
    assert!(share > CAPTURE_MISMATCH_SHARE, "{share}");
    finish_gpu(ctx);
}

#[test]
fn capture_matches_cpu_ray_cast_capture() {
    let ctx = gpu_context();
    let cases = [
        ("sphere-room", builtin::sphere_room(), 16u32),
        ("sphere-room", builtin::sphere_room(), 32),
        ("teapot", builtin::teapot(), 16),
        ("torus+sphere", torus_and_sphere(), 16),
    ];
    for (name, scene, size) in cases {
        let centres = scene.cmo_centres();
        let tracer = Tracer::new(&scene);
        let gpu = gpu_capture(&ctx, &scene, &centres, size);
        for (k, g) in gpu.iter().enumerate() {
            let cpu = cubetrace::cpu::capture::capture(&scene, &tracer, centres[k], size);
            let bad = capture_mismatches(g, &cpu, CAPTURE_DISTANCE_REL, CAPTURE_COLOUR_TOL);
            let share = bad as f64 / cpu.distance.len() as f64;
            eprintln!(
                "{name} N={size} CMO {k}: {bad} of {} texels differ ({:.3}%)",
                cpu.distance.len(),
                100.0 * share
            );
            assert!(
                share <= CAPTURE_MISMATCH_SHARE,
                "{name} N={size} CMO {k}: {share}"
            );
            let ids = id_mismatches(g, &cpu);
            let id_share = ids as f64 / cpu.triangle.len() as f64;
            let unexplained = unexplained_id_mismatches(g, &cpu, &tracer.world);
            eprintln!(
                "{name} N={size} CMO {k}: triangle IDs differ on {ids} texels ({:.3}%), {} not at a grazed edge",
                100.0 * id_share,
                unexplained.len()
            );
            assert!(
                id_share <= CAPTURE_ID_MISMATCH_SHARE,
                "{name} N={size} CMO {k}: {id_share}"
            );
            assert!(
                unexplained.is_empty(),
                "{name} N={size} CMO {k}: IDs differ away from edges: {:?}",
                &unexplained[..unexplained.len().min(10)]
            );
            assert!(g.triangle.iter().filter(|&&t| t != u32::MAX).count() > cpu.triangle.len() / 2);
            // Sanity: the capture is not empty.
            assert!(g.distance.iter().filter(|d| d.is_finite()).count() > cpu.distance.len() / 2);
        }
    }
    finish_gpu(ctx);
}

#[test]
fn capture_comparison_fails_for_a_moved_centre_or_face_swap() {
    let ctx = gpu_context();
    let scene = builtin::sphere_room();
    let size = 16;
    let centre = scene.cmo_centres()[0];
    let tracer = Tracer::new(&scene);
    let cpu = cubetrace::cpu::capture::capture(&scene, &tracer, centre, size);
    let total = cpu.distance.len() as f64;
    // Moved by 2 cm along each axis: every wall's distance along a fixed direction changes by
    // far more than the tolerance (a move parallel to a plane would leave that plane's
    // distances unchanged, so the move is diagonal).
    let moved = gpu_capture(&ctx, &scene, &[centre + Vec3::splat(0.02)], size);
    let bad = capture_mismatches(&moved[0], &cpu, CAPTURE_DISTANCE_REL, CAPTURE_COLOUR_TOL);
    assert!(
        bad as f64 / total > 0.5,
        "moved centre: only {bad} texels differ"
    );
    // Faces swapped (+X data where +Y belongs): the face mapping must matter. (+X and -X would
    // not do: the room is nearly symmetric under a half turn about the vertical axis.)
    let mut swapped = gpu_capture(&ctx, &scene, &[centre], size).remove(0);
    let n = (size * size) as usize;
    let (a, b) = swapped.distance.split_at_mut(2 * n);
    a[..n].swap_with_slice(&mut b[..n]);
    let bad = capture_mismatches(&swapped, &cpu, CAPTURE_DISTANCE_REL, f32::INFINITY);
    assert!(
        bad as f64 / total > 0.1,
        "swapped faces: only {bad} texels differ"
    );
    // Triangle IDs: the right capture passes; shifted IDs (every triangle one off) and the
    // swapped faces' IDs fail both the share and the edge check.
    let right = gpu_capture(&ctx, &scene, &[centre], size).remove(0);
    assert!(id_mismatches(&right, &cpu) as f64 / total <= CAPTURE_ID_MISMATCH_SHARE);
    let mut shifted = right.clone();
    for t in shifted.triangle.iter_mut().filter(|t| **t != u32::MAX) {
        *t += 1;
    }
    let bad = id_mismatches(&shifted, &cpu);
    assert!(bad as f64 / total > 0.5, "shifted IDs: only {bad} differ");
    let unexplained = unexplained_id_mismatches(&shifted, &cpu, &tracer.world).len();
    assert!(
        unexplained as f64 / total > 0.5,
        "shifted IDs: only {unexplained} away from edges"
    );
    let mut swapped = right;
    let (a, b) = swapped.triangle.split_at_mut(2 * n);
    a[..n].swap_with_slice(&mut b[..n]);
    assert!(id_mismatches(&swapped, &cpu) as f64 / total > 0.1);
    finish_gpu(ctx);
}

/// Without colour the capture writes the same distances and IDs, and the CMO data is smaller
/// than with colour alone (the u32 ID replaces the RGBA f32 colour). IDs-only, colour-only and
/// both, with and without self-reflections.
#[test]
fn capture_without_colour_keeps_ids_and_saves_memory() {
    let ctx = gpu_context();
    for name in ["sphere-room", "teapot"] {
        let scene = builtin::by_name(name).unwrap();
        let centres = scene.cmo_centres();
        let size = 16;
        let with = |colour, triangle_ids| {
            gpu_capture_with(
                &ctx,
                &scene,
                &centres,
                size,
                CaptureContents {
                    colour,
                    triangle_ids,
                },
            )
        };
        let (both, both_bytes) = with(true, true);
        let (ids, ids_bytes) = with(false, true);
        let (colour, colour_bytes) = with(true, false);
        for k in 0..centres.len() {
            assert_eq!(ids[k].triangle, both[k].triangle, "{name}");
            let bits = |c: &CubeMap| c.distance.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&ids[k]), bits(&both[k]), "{name}");
            assert_eq!(colour[k].colour, both[k].colour, "{name}");
            // Not captured: left as CubeMap::new leaves them.
            assert!(colour[k].triangle.iter().all(|&t| t == u32::MAX));
            assert!(ids[k].colour.iter().all(|&c| c == [0.0; 4]));
        }
        let texels = 6 * u64::from(size * size) * centres.len() as u64;
        // Colour only keeps a one-u32 placeholder for the IDs (composite binds them).
        assert_eq!(both_bytes + 4, colour_bytes + 4 * texels, "{name}");
        // 4 B of ID per texel instead of 16 B of colour; the placeholder keeps one RGBA texel
        // per layer.
        let layers = 6 * centres.len() as u64;
        assert_eq!(
            ids_bytes + 12 * texels + 4,
            colour_bytes + 16 * layers,
            "{name}: ids only {ids_bytes} B, colour only {colour_bytes} B"
        );
        assert!(ids_bytes < colour_bytes);
    }
    // A capture without colour or IDs is refused, not run.
    let scene = builtin::sphere_room();
    let data = GpuSceneData::new(&scene);
    let buffers = SceneBuffers::new(&ctx, &data).unwrap();
    let none = CaptureContents {
        colour: false,
        triangle_ids: false,
    };
    let centres = scene.cmo_centres();
    assert!(Capture::with_contents(&ctx, &data, &buffers, &centres, 8, false, 1e-4, none).is_err());
    assert!(
        CmoData::with_contents(
            &ctx,
            &centres,
            8,
            false,
            false,
            &TraceOptions::default(),
            none
        )
        .is_err()
    );
    finish_gpu(ctx);
}

/// Moving a capture's CMO (`Capture::set_views`) makes its faces' triangle lists again: moved
/// from outside the room (few triangles per face, a small list buffer) to the scene's own
/// centre (walls in every face: the lists outgrow the buffer, which is made again and rebound),
/// it captures what a capture created there does, bit for bit. Negative: the capture before the
/// move differs.
#[test]
fn moved_capture_makes_its_face_lists_again() {
    let ctx = gpu_context();
    let scene = builtin::sphere_room();
    let data = GpuSceneData::new(&scene);
    let buffers = SceneBuffers::new(&ctx, &data).unwrap();
    let both = CaptureContents {
        colour: true,
        triangle_ids: true,
    };
    let near = 1e-5 * scene.world().extent();
    let inside = scene.cmo_centres()[0];
    let outside = inside + Vec3::new(0.0, 0.0, 4.0 * scene.world().extent());
    let size = 16;
    let run = |cap: &Capture| {
        let c = record_capture(&ctx, cap, &scene, &[inside], size, both)
            .0
            .remove(0);
        let bits: Vec<u32> = c.distance.iter().map(|d| d.to_bits()).collect();
        (bits, c.triangle)
    };
    let new = |c: Vec3| {
        Capture::with_contents(&ctx, &data, &buffers, &[c], size, false, near, both).unwrap()
    };
    let mut moved = new(outside);
    let before = run(&moved);
    let small = face_triangles(&data, &[outside], false, near).triangles;
    let large = face_triangles(&data, &[inside], false, near).triangles;
    assert!(
        large.len() > small.len(),
        "{} !> {}",
        large.len(),
        small.len()
    );
    moved.set_views(&ctx, &data, &[inside], near).unwrap();
    let after = run(&moved);
    let fresh = run(&new(inside));
    assert!(
        fresh.1.iter().any(|&t| t != u32::MAX),
        "the capture saw nothing"
    );
    assert_eq!(after, fresh);
    assert_ne!(before, fresh, "the comparison is blind");
    finish_gpu(ctx);
}

fn read_rgba32f(ctx: &GpuContext, img: &cubetrace::vk::Image) -> Vec<Vec4> {
    let bytes = ctx
        .read_image(img, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)
        .unwrap();
    bytemuck::cast_slice::<u8, [f32; 4]>(&bytes)
        .iter()
        .map(|v| Vec4::from_array(*v))
        .collect()
}

/// The G-buffer of `scene`'s first camera at `width` x `height`, rendered (with the scene's
/// buffers, which it reads).
fn gbuffer_of(
    ctx: &GpuContext,
    scene: &Scene,
    width: u32,
    height: u32,
) -> (Camera, SceneBuffers, Gbuffer) {
    let mut camera = scene.camera(None).unwrap().clone();
    camera.width = width;
    camera.height = height;
    let near = FrameRanges::new(scene, &camera).near;
    let buffers = SceneBuffers::new(ctx, &GpuSceneData::new(scene)).unwrap();
    let gb = Gbuffer::new(ctx, &buffers, &camera, near).unwrap();
    ctx.submit_and_wait("gbuffer", |rec| gb.record(rec, scene.background))
        .unwrap();
    (camera, buffers, gb)
}

#[test]
fn gbuffer_matches_reference_primary_hits() {
    let ctx = gpu_context();
    for name in ["sphere-room", "torus"] {
        let scene = builtin::by_name(name).unwrap();
        let extent = scene.world().extent();
        let (camera, _buffers, gb) = gbuffer_of(&ctx, &scene, 64, 48);
        let position = read_rgba32f(&ctx, &gb.position);
        let colour = read_rgba32f(&ctx, &gb.colour);
        let tracer = Tracer::new(&scene);
        let frame = reference::render(&scene, &tracer, &camera, 0);
        let (mut mask_diff, mut pos_bad, mut col_bad, mut covered) = (0, 0, 0, 0);
        for k in 0..position.len() {
            let gpu_mirror = position[k].w == 1.0;
            if gpu_mirror != (frame.mask[k] == 1) {
                mask_diff += 1;
            }
            let p = frame.surface_position[k];
            let gpu_covered = colour[k].w == 1.0;
            if p.is_nan() || !gpu_covered {
                if p.is_nan() == gpu_covered {
                    pos_bad += 1;
                }
                continue;
            }
            covered += 1;
            if (position[k].truncate() - p).length() > 1e-4 * extent {
                pos_bad += 1;
            }
            // With 0 bounces the reference shades mirrors with their own material, as the
            // G-buffer does.
            if (colour[k].truncate() - frame.colour[k]).abs().max_element() > 1e-3 {
                col_bad += 1;
            }
        }
        let n = position.len();
        eprintln!(
            "{name}: mask differs on {mask_diff}, position on {pos_bad}, colour on {col_bad} of {n} pixels ({covered} covered)"
        );
        // Pixels whose centre ray grazes a triangle edge may see a different triangle; at
        // 64x48 that is a handful of silhouette pixels. Bound: 1% of the frame.
        let bound = n / 100;
        assert!(mask_diff <= bound && pos_bad <= bound && col_bad <= bound);
        assert!(covered > n / 2);
    }
    finish_gpu(ctx);
}

fn read_u32(ctx: &GpuContext, img: &cubetrace::vk::Image) -> Vec<u32> {
    let bytes = ctx
        .read_image(img, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)
        .unwrap();
    bytemuck::cast_slice::<u8, u32>(&bytes).to_vec()
}

/// How far the G-buffer's start points and normals lie from the reference's primary hits, over
/// the pixels whose triangle both agree on: the largest position error in units of f32's
/// epsilon times `|eye| + t` (the scale of the rounding in `eye + d t`), the largest angle
/// between the normals (radians), and the number of pixels compared.
struct StartError {
    position_eps: f64,
    normal_rad: f64,
    compared: usize,
}

fn start_error(
    tracer: &Tracer,
    camera: &Camera,
    triangle: &[u32],
    position: &[Vec4],
    normal: &[Vec4],
) -> StartError {
    let mut out = StartError {
        position_eps: 0.0,
        normal_rad: 0.0,
        compared: 0,
    };
    for j in 0..camera.height {
        for i in 0..camera.width {
            let k = (j * camera.width + i) as usize;
            let (o, d) = camera.ray(i, j);
            let Some(hit) = tracer.nearest(o, d, None) else {
                continue;
            };
            if hit.triangle != triangle[k] {
                continue;
            }
            out.compared += 1;
            let scale = (o.length() + hit.t) as f64 * f32::EPSILON as f64;
            let e = (position[k].truncate() - hit.position).length() as f64 / scale;
            out.position_eps = out.position_eps.max(e);
            // The angle from the cross product's length, in f64 (an f32 `acos` near 1 resolves
            // no better than 5e-4).
            let n = normal[k].truncate().as_dvec3().normalize_or_zero();
            let r = tracer.normal(&hit).as_dvec3();
            let angle = n.cross(r).length().atan2(n.dot(r));
            out.normal_rad = out.normal_rad.max(angle);
        }
    }
    out
}

/// The G-buffer starts every reflected ray on the reference's primary ray: its position is the
/// pixel-centre ray's hit on the rasterised triangle, to a few f32 roundings, and its normal is
/// interpolated with that hit's barycentrics. The rasteriser's own interpolation strays by its
/// sub-pixel snapping, which turned a grazing reflected ray of the default scene onto a
/// neighbouring triangle. Negative: against a reference camera whose eye moved by 1e-5 of the
/// scene's size, the same comparison fails.
#[test]
fn gbuffer_starts_on_the_reference_ray() {
    let ctx = gpu_context();
    for name in ["default", "teapot", "torus"] {
        let scene = builtin::by_name(name).unwrap();
        let (camera, _buffers, gb) = gbuffer_of(&ctx, &scene, 80, 60);
        let position = read_rgba32f(&ctx, &gb.position);
        let normal = read_rgba32f(&ctx, &gb.normal);
        let triangle = read_u32(&ctx, &gb.triangle);
        let tracer = Tracer::new(&scene);
        let e = start_error(&tracer, &camera, &triangle, &position, &normal);
        eprintln!(
            "{name}: {} pixels, position within {:.2} eps (|eye| + t), normal within {:.2e} rad",
            e.compared, e.position_eps, e.normal_rad
        );
        assert!(e.compared > (camera.width * camera.height / 4) as usize);
        assert!(e.position_eps <= 16.0, "{name}: {:.2} eps", e.position_eps);
        assert!(e.normal_rad <= 1e-4, "{name}: {:.2e} rad", e.normal_rad);

        let mut moved = camera.clone();
        moved.eye += Vec3::X * (1e-5 * scene.world().extent());
        let e = start_error(&tracer, &moved, &triangle, &position, &normal);
        eprintln!("{name}, eye moved: {:.2} eps", e.position_eps);
        assert!(e.position_eps > 16.0, "{name}: {:.2} eps", e.position_eps);
    }
    finish_gpu(ctx);
}

#![forbid(unsafe_code)]
//! The frame the model replays: its settings ([`ModelSettings`]), the scene's rays, CMOs and
//! triangles ([`Frame`], [`frame`]), the byte addresses of the buffers' loads ([`Addr`]), and
//! the logged run of a ray through the CMOs that the cubemap tracers' records start from.
use std::cell::RefCell;

use anyhow::Context;
use glam::Vec3;
use serde::Serialize;

use crate::cpu::multi::{Verify, WorldRay, trace_world_ray};
use crate::cpu::verify::{Neighbourhood, triangle_corners};
use crate::cpu::{CmoTracer, Status, TraceParams, TraceResult, Work};
use crate::cubemap::face::Texel;
use crate::cubemap::pyramid::{hier32_flat_layout, mip_flat_layout};
use crate::scene::Scene;

/// How compute_trace lays a ray over lanes (`vk::methods::compute::ray_lanes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ComputeLanes {
    /// `main`: min(width, 32) lanes per ray (the thesis layout).
    Thesis,
    /// `main_lanes1`: one lane per ray (what CPU devices, lavapipe, run).
    One,
    /// `main_wave`: one ray per lane, the warp's crossed children spread over its lanes.
    Wave,
    /// `One` in lavapipe mode, `Wave` in GPU mode (what `ray_lanes` picks); as a method's
    /// layout in the GPU predictions, its default.
    Auto,
}

impl ComputeLanes {
    /// The label of a table column: "" (the default), "thesis", "1 lane/ray", "wave".
    pub fn label(self) -> &'static str {
        match self {
            ComputeLanes::Auto => "",
            ComputeLanes::Thesis => "thesis",
            ComputeLanes::One => "1 lane/ray",
            ComputeLanes::Wave => "wave",
        }
    }
}

/// The byte layout of texel and node addresses for the sector count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TexelLayout {
    /// The GPU buffers' actual layout: row-major per face, faces in order, CMOs in order.
    Linear,
    /// 4x2-texel tiles of 8 4-byte texels (one 32-byte sector per tile), tiles row-major.
    Tiled,
}

/// What the model needs of one frame beside the scene and method (the bench's settings).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelSettings {
    /// Cube map size N (texels per face side).
    pub cube: u32,
    /// Image size in pixels.
    pub width: u32,
    pub height: u32,
    /// compute_trace's lane layout.
    pub compute_lanes: ComputeLanes,
    /// Texel layout for the memory transactions.
    pub layout: TexelLayout,
}

impl ModelSettings {
    /// The defaults for a frame: `ComputeLanes::Auto`, `TexelLayout::Linear`.
    pub fn new(cube: u32, width: u32, height: u32) -> ModelSettings {
        ModelSettings {
            cube,
            width,
            height,
            compute_lanes: ComputeLanes::Auto,
            layout: TexelLayout::Linear,
        }
    }
}

/// Buffers, for [`Addr`].
pub const BUF_DISTANCE: u64 = 1;
pub const BUF_HIER: u64 = 2;
pub const BUF_MIP: u64 = 3;
pub const BUF_TRIANGLE: u64 = 4;
pub const BUF_BVH_NODES: u64 = 5;
pub const BUF_BVH_TRIS: u64 = 6;
pub const BUF_HIZ: u64 = 7;
pub const BUF_RP: u64 = 8;

/// Byte addresses of texels and cells under a [`TexelLayout`].
#[derive(Clone, Copy, Debug)]
pub struct Addr {
    pub layout: TexelLayout,
}

impl Addr {
    /// Element (x, y) of `face` of a `w x h`-per-face level of `elem` bytes, buffer `buf`, CMO
    /// `k`, level `level`.
    #[allow(clippy::too_many_arguments)]
    pub fn cell(
        &self,
        buf: u64,
        k: u32,
        level: u32,
        elem: u64,
        face: u32,
        w: u32,
        h: u32,
        x: u32,
        y: u32,
    ) -> u64 {
        let base = ((buf * 256 + k as u64) * 64 + level as u64) << 36;
        let (face, w, h, x, y) = (face as u64, w as u64, h as u64, x as u64, y as u64);
        match self.layout {
            TexelLayout::Linear => base + ((face * h + y) * w + x) * elem,
            TexelLayout::Tiled => {
                let (tw, th) = if elem <= 4 { (4, 2) } else { (2, 2) };
                let (tx, ty) = (w.div_ceil(tw), h.div_ceil(th));
                let tile = tw * th * elem;
                base + face * tx * ty * tile
                    + ((y / th) * tx + x / tw) * tile
                    + ((y % th) * tw + x % tw) * elem
            }
        }
    }

    /// A texel's distance (4 bytes) of CMO k.
    pub fn distance(&self, k: u32, n: u32, t: Texel) -> u64 {
        self.cell(BUF_DISTANCE, k, 0, 4, t.face, n, n, t.x, t.y)
    }

    /// A texel's captured triangle ID (4 bytes) of CMO k.
    pub fn triangle(&self, k: u32, n: u32, t: Texel) -> u64 {
        self.cell(BUF_TRIANGLE, k, 0, 4, t.face, n, n, t.x, t.y)
    }

    /// Cell (x, y) of level `level` >= 1 of the 8x4/4x8 hierarchy (8 bytes).
    pub fn hier(&self, k: u32, n: u32, level: u32, face: u32, x: u32, y: u32) -> u64 {
        let l = hier32_flat_layout(n)[level as usize - 1];
        self.cell(BUF_HIER, k, level, 8, face, l.width, l.height, x, y)
    }

    /// Cell (x, y) of level `level` >= 1 of the 2x2 pyramid (8 bytes).
    pub fn mip(&self, k: u32, n: u32, level: u32, face: u32, x: u32, y: u32) -> u64 {
        let l = mip_flat_layout(n)[level as usize - 1];
        self.cell(BUF_MIP, k, level, 8, face, l.width, l.height, x, y)
    }
}

/// A mirror pixel's reflected ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MirrorRay {
    pub pixel: (u32, u32),
    pub origin: Vec3,
    pub dir: Vec3,
    /// The mirror triangle it leaves.
    pub from: u32,
}

/// What the twins need of a scene: CMOs, the triangles' corners, the rays (row-major).
pub struct Frame {
    pub settings: ModelSettings,
    pub tracer: crate::reference::Tracer,
    pub data: crate::scene::gpu_data::GpuSceneData,
    pub camera: crate::camera::Camera,
    /// The camera's near plane (`vk::frame::scene_ranges`).
    pub near: f32,
    /// Per pixel (row-major): the first surface the camera sees there.
    pub primary: Vec<Option<Vec3>>,
    pub cmos: Vec<CmoTracer>,
    pub corners: Vec<[Vec3; 3]>,
    pub t_hi: f32,
    pub rays: Vec<MirrorRay>,
    /// Per pixel, row-major: the index of its ray in `rays` (None: not a mirror pixel).
    pub ray_at: Vec<Option<usize>>,
}

/// Sets up `scene`'s frame at `settings` (module docs, "What it assumes").
pub fn frame(scene: &Scene, settings: &ModelSettings) -> anyhow::Result<Frame> {
    use crate::cpu::capture::capture;
    use crate::reference::{Tracer, reflect};
    let s = settings;
    if s.width == 0 || s.height == 0 || s.width > 4096 || s.height > 4096 {
        anyhow::bail!(
            "model: image size {}x{} is not in 1..=4096",
            s.width,
            s.height
        );
    }
    if !(1..=2048).contains(&s.cube) {
        anyhow::bail!("model: cube size {} is not in 1..=2048", s.cube);
    }
    let mut camera = scene
        .cameras
        .first()
        .context("model: the scene has no camera")?
        .clone();
    camera.width = s.width;
    camera.height = s.height;
    let tracer = Tracer::new(scene);
    let (near, _, t_hi) = crate::vk::frame::scene_ranges(scene, &camera);
    let mut rays = Vec::new();
    let mut ray_at = Vec::with_capacity((s.width * s.height) as usize);
    let mut primary = Vec::with_capacity((s.width * s.height) as usize);
    for j in 0..s.height {
        for i in 0..s.width {
            let (o, d) = camera.ray(i, j);
            let first = tracer.nearest(o, d, None);
            primary.push(first.map(|h| h.position));
            let hit = first.filter(|h| tracer.is_reflector(h.triangle));
            ray_at.push(hit.map(|h| {
                rays.push(MirrorRay {
                    pixel: (i, j),
                    origin: h.position,
                    dir: reflect(d, tracer.normal(&h)).normalize(),
                    from: h.triangle,
                });
                rays.len() - 1
            }));
        }
    }
    let cmos = scene
        .cmo_centres()
        .into_iter()
        .map(|c| CmoTracer::new(capture(scene, &tracer, c, s.cube), TraceParams::default()))
        .collect();
    Ok(Frame {
        settings: s.clone(),
        cmos,
        corners: triangle_corners(&tracer.world),
        data: crate::scene::gpu_data::GpuSceneData::new(scene),
        tracer,
        camera,
        near,
        primary,
        t_hi,
        rays,
        ray_at,
    })
}

/// One single-CMO trace's log: the CMO, the events, the result.
pub(super) struct TraceLog {
    pub(super) k: usize,
    pub(super) events: Vec<Work>,
    pub(super) result: TraceResult,
}

impl TraceLog {
    /// The index in `events` of the texel classification that decided the trace (its last one,
    /// where the trace ends in a hit or behind): where `classify_candidate` runs.
    pub(super) fn deciding(&self) -> Option<usize> {
        if !matches!(self.result.status, Status::Hit | Status::Behind) {
            return None;
        }
        self.events
            .iter()
            .rposition(|e| matches!(e, Work::Classify(_)))
    }
}

/// Runs `ray` through the CMOs with verified hits (`trace_world_ray`), each single-CMO trace by
/// `one` with its log; returns the logs and whether the ray ends in a hit.
pub(super) fn run_logged(
    frame: &Frame,
    ray: &MirrorRay,
    one: impl Fn(&CmoTracer, &crate::cpu::Segment, &mut Vec<Work>) -> TraceResult,
) -> (Vec<TraceLog>, bool) {
    let logs = RefCell::new(Vec::new());
    let wr = WorldRay {
        origin: ray.origin,
        dir: ray.dir,
        from: crate::cpu::bounded::NO_TRIANGLE,
        t_lo: 0.0,
        t_hi: frame.t_hi,
    };
    let verify = Verify {
        triangles: &frame.corners,
    };
    let out = trace_world_ray(&frame.cmos, &wr, Some(verify), |tr, seg| {
        let k = frame
            .cmos
            .iter()
            .position(|c| std::ptr::eq(c, tr))
            .unwrap_or(0);
        let mut events = Vec::new();
        let result = one(tr, seg, &mut events);
        logs.borrow_mut().push(TraceLog { k, events, result });
        result
    });
    (
        logs.into_inner(),
        out.status == crate::cpu::multi::MultiStatus::Hit,
    )
}

/// The 9 triangle-ID loads of verifying a hit at `texel` of CMO k.
pub(super) fn verify_loads(frame: &Frame, addr: &Addr, k: usize, texel: Texel) -> Vec<u64> {
    let tr = &frame.cmos[k];
    let n = tr.cube.size;
    let hood = Neighbourhood::around(texel, n, &tr.cube.triangle);
    hood.texels
        .iter()
        .map(|&t| addr.triangle(k as u32, n, t))
        .collect()
}

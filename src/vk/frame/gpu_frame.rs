//! The frame read back from the GPU ([`GpuFrame`]) and what the metrics and tests read of it.

use glam::Vec3;

use super::{PixelRecord, RECORD_HIT, RECORD_UNRESOLVED};
use crate::cpu::reflection_point::SearchStats;
use crate::metrics::Traced;
use crate::vk::backend::timestamps::PassTime;
use crate::vk::methods::compute::ComputeStats;
use crate::vk::passes::bounce::RoundCount;
use crate::vk::passes::bvh::BvhCounter;
use crate::vk::passes::capture_lists::ListCounters;

/// A rendered frame read back from the GPU, row-major, row 0 at the top.
#[derive(Clone, Debug)]
pub struct GpuFrame {
    pub width: u32,
    pub height: u32,
    /// Final linear colour.
    pub colour: Vec<Vec3>,
    /// 1 on mirror pixels.
    pub mask: Vec<u8>,
    /// The point the camera sees (NaN where nothing).
    pub surface_position: Vec<Vec3>,
    /// Per pixel; meaningful where `mask` is 1.
    pub records: Vec<PixelRecord>,
    /// GPU time per pass, in recording order.
    pub pass_times: Vec<PassTime>,
    /// The BVH queue's counter: rays traced and rays cut by the loop cap (`--method bvh`:
    /// every mirror ray; [`Fallback::Trace`](crate::vk::options::Fallback::Trace): the fallback
    /// rays, of the last round where `compute` traces the rounds of `--bounces`).
    pub bvh: Option<BvhCounter>,
    /// The lists' capture counters (`--criterion bounded`: nodes, what a full pool or job buffer
    /// dropped, walks capped; each dropped entry made its texel unknown from its `lo` on).
    pub lists: Option<ListCounters>,
    /// Ray count, subgroup size and per-ray counters (`--method compute` only).
    pub compute: Option<ComputeStats>,
    /// What each round 2..=N of `--bounces N` traced (empty for N < 2).
    pub rounds: Vec<RoundCount>,
    /// Iteration counts of the searches (`--method reflection-point`
    /// only).
    pub search: Option<SearchStats>,
    /// Whether this frame ran the CMO stages (capture, pyramid, the method's CMO stage): the
    /// first frame and the first after [`GpuRenderer::set_camera`](super::GpuRenderer::set_camera) changed what the capture
    /// depends on or [`GpuRenderer::update_geometry`](super::GpuRenderer::update_geometry) moved the geometry; never for a method
    /// that captures nothing (`bvh`) or uploaded lists.
    pub captured: bool,
    /// Whether this frame's CMO stages ran on bounded lists uploaded since the last frame
    /// ([`GpuRenderer::with_built_lists`](super::GpuRenderer::with_built_lists),
    /// [`GpuRenderer::update_geometry_with_lists`](super::GpuRenderer::update_geometry_with_lists))
    /// instead of the lists' capture.
    pub lists_uploaded: bool,
}

impl GpuFrame {
    /// The frame as the error metrics read it: hit points where the method hit something,
    /// resolved where it hit or escaped.
    pub fn traced(&self) -> Traced {
        let mirror = |k: usize| self.mask[k] != 0;
        Traced {
            width: self.width,
            height: self.height,
            colour: self.colour.clone(),
            mask: self.mask.clone(),
            hit_position: (0..self.records.len())
                .map(|k| {
                    let r = &self.records[k];
                    if mirror(k) && r.status == RECORD_HIT {
                        Vec3::from_array(r.point)
                    } else {
                        Vec3::NAN
                    }
                })
                .collect(),
            resolved: (0..self.records.len())
                .map(|k| u8::from(mirror(k) && self.records[k].status != RECORD_UNRESOLVED))
                .collect(),
            // Verified hits name their triangle; other methods leave `u32::MAX` everywhere.
            triangle: self
                .records
                .iter()
                .enumerate()
                .any(|(k, r)| mirror(k) && r.status == RECORD_HIT && r.triangle != u32::MAX)
                .then(|| {
                    (0..self.records.len())
                        .map(|k| {
                            let r = &self.records[k];
                            if mirror(k) && r.status == RECORD_HIT {
                                r.triangle
                            } else {
                                u32::MAX
                            }
                        })
                        .collect()
                }),
            fallback: self.bvh.is_some().then(|| {
                (0..self.records.len())
                    .map(|k| u8::from(mirror(k) && self.records[k].fallback != 0))
                    .collect()
            }),
            bounces: Some(
                (0..self.records.len())
                    .map(|k| {
                        if mirror(k) {
                            self.records[k].bounces
                        } else {
                            0
                        }
                    })
                    .collect(),
            ),
        }
    }

    /// Mirror pixels whose record the reflector check changed (0 without it).
    pub fn checked_pixels(&self) -> usize {
        (0..self.records.len())
            .filter(|&k| self.mask[k] != 0 && self.records[k].checked != 0)
            .count()
    }

    /// Mirror pixels whose method hit the reflector check found at the ray's own start and
    /// handed to the fallback (`checked` = 2).
    pub fn start_hit_pixels(&self) -> usize {
        (0..self.records.len())
            .filter(|&k| self.mask[k] != 0 && self.records[k].checked == 2)
            .count()
    }

    /// Mirror pixels the `trace` fallback finished (0 without it).
    pub fn fallback_pixels(&self) -> usize {
        (0..self.records.len())
            .filter(|&k| self.mask[k] != 0 && self.records[k].fallback != 0)
            .count()
    }

    /// Mirror pixels.
    pub fn mirror_pixels(&self) -> usize {
        self.mask.iter().filter(|&&m| m != 0).count()
    }

    /// GPU nanoseconds of the pass `name` (0 if it did not run).
    pub fn pass_ns(&self, name: &str) -> f64 {
        self.pass_times
            .iter()
            .filter(|(n, _)| n == name)
            .map(|(_, t)| t)
            .sum()
    }
}

/// The object a reflection-point frame shows at each pixel (its records' `face` on the mirror
/// pixels it covered; `None` elsewhere), for [`crate::metrics::same_object`].
pub fn shown_objects(frame: &GpuFrame) -> Vec<Option<u32>> {
    (0..frame.records.len())
        .map(|k| {
            let r = &frame.records[k];
            (frame.mask[k] != 0 && r.status == RECORD_HIT).then_some(r.face)
        })
        .collect()
}

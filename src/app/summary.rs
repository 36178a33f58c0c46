#![forbid(unsafe_code)]
//! What `render` says about a GPU frame beyond the image: how many mirror pixels the method
//! resolved itself and how many the fallback filled, and a warning naming the likely cause when
//! the fallback did much of the work.
//!
//! With `--fallback trace` (the default) no mirror pixel is left unresolved: the BVH finishes
//! every ray the method gave up, so "0 unresolved" alone would hide a misplaced CMO. The summary line therefore counts the fallback's pixels with their share of the
//! mirror pixels, and [`fallback_warning`] warns when the method left more than
//! [`WARN_SHARE`] of them to the fallback (finished by it, or left unresolved and filled by the
//! flag, environment map or background).
//!
//! The threshold, 10 %: on the built-in scenes the cubemap tracers (compute, fragment) hand
//! 0.4 to 2.5 % of their mirror pixels to the fallback (bench at 160x120), except the teapot
//! (31.6 %: its spout and handle seen in the body, the reflector check's start hits); a
//! misplaced CMO raises it to 30-100 % (as inward reflector normals did before closed
//! reflectors seen from outside had their front turned, `Scene::front_turned`). ssr (71-98 %) and reflection-point
//! (36-88 %) are above it on every built-in scene: that is their known limit, and the warning
//! says so.

use crate::Method;
use crate::metrics::Traced;
use crate::placement::Placement;
use crate::scene::Scene;
use crate::vk::frame::GpuFrame;

/// Share of the mirror pixels above which [`fallback_warning`] warns (see the module docs).
pub const WARN_SHARE: f64 = 0.10;

/// What the method left to the fallback on one frame's mirror pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FallbackCount {
    pub mirror: usize,
    /// Finished by `--fallback trace` (the BVH).
    pub traced: usize,
    /// Still unresolved (filled by another fallback, or cut by the BVH's loop cap).
    pub unresolved: usize,
    /// Of `traced`: handed over by the reflector check, which found the method's hit at the
    /// ray's own start (a reflector seeing itself).
    pub start_hits: usize,
}

impl FallbackCount {
    pub fn of(frame: &GpuFrame, traced: &Traced) -> Self {
        let unresolved = traced
            .mask
            .iter()
            .zip(&traced.resolved)
            .filter(|(m, r)| **m != 0 && **r == 0)
            .count();
        FallbackCount {
            mirror: frame.mirror_pixels(),
            traced: frame.fallback_pixels(),
            unresolved,
            start_hits: frame.start_hit_pixels(),
        }
    }

    /// The mirror pixels the method did not resolve itself: traced by the fallback or left
    /// unresolved.
    pub fn left(&self) -> usize {
        self.traced + self.unresolved
    }

    /// [`FallbackCount::left`] as a share of the mirror pixels (0 without mirror pixels).
    pub fn share(&self) -> f64 {
        self.left() as f64 / self.mirror.max(1) as f64
    }
}

/// A percentage of `part` in `whole`, one decimal.
fn percent(part: usize, whole: usize) -> String {
    format!("{:.1}%", 100.0 * part as f64 / whole.max(1) as f64)
}

/// The counts of the summary line: `N mirror pixels, F finished by the fallback (x.x%), U
/// unresolved`; the fallback part only for methods that can leave a pixel to it.
pub fn counts(method: Method, c: &FallbackCount) -> String {
    if !method.can_leave_unresolved() {
        return format!("{} mirror pixels, {} unresolved", c.mirror, c.unresolved);
    }
    format!(
        "{} mirror pixels, {} finished by the fallback ({}), {} unresolved",
        c.mirror,
        c.traced,
        percent(c.traced, c.mirror),
        c.unresolved
    )
}

/// The warning when the method left more than [`WARN_SHARE`] of the mirror pixels to the
/// fallback, naming the likely cause; `None` below it.
pub fn fallback_warning(
    method: Method,
    scene: &Scene,
    c: &FallbackCount,
    placement: Option<&Placement>,
) -> Option<String> {
    if !method.can_leave_unresolved() || c.share() <= WARN_SHARE {
        return None;
    }
    let head = format!(
        "--method {method} resolved only {} of {} mirror pixels itself: the fallback {} {} ({}, \
         more than the {:.0}% this warning allows)",
        c.mirror - c.left(),
        c.mirror,
        if c.unresolved > 0 {
            "filled or left unresolved"
        } else {
            "finished"
        },
        c.left(),
        percent(c.left(), c.mirror),
        100.0 * WARN_SHARE
    );
    let inward = inward_reflectors(scene);
    let cause = if !inward.is_empty() {
        format!(
            "likely cause: the vertex normals of reflector {} point into it and a camera lies \
             inside it, so its inside is taken as the mirror (a mirror room); if it is seen from \
             outside, move the camera out or flip its normals (negate the OBJ's `vn` lines)",
            inward.join(", ")
        )
    } else {
        match method.known_limit() {
            Some(limit) => limit.into(),
            None if c.start_hits * 2 > c.left() => format!(
                "likely cause: the reflector sees itself ({} of these rays meet the mirror they \
                 leave, which the CMOs do not capture: the reflector check hands them to the \
                 fallback)",
                c.start_hits
            ),
            None => match placement {
                Some(p) => placement_cause(p),
                None => "likely causes: the CMOs do not see what these rays hit: a CMO centre \
                         placed away from the reflector or behind other geometry, or too few \
                         CMOs for its extent (leave out [cmo] centres, or give --placement \
                         auto, to let the placement search choose them); or an \
                         open reflector's vertex normals facing away from the side it is seen \
                         from"
                    .into(),
            },
        }
    };
    Some(format!("{head}; {cause}"))
}

/// What the placement search could not do, from its sample: how much of it the chosen CMOs
/// left unresolved, and what those rays meet.
fn placement_cause(p: &Placement) -> String {
    let what = p.left.cause().unwrap_or_else(|| {
        "these rays pass behind surfaces that no candidate centre sees around, or meet \
         triangles smaller than a texel (a larger --cube-size verifies more of them)"
            .into()
    });
    format!(
        "likely cause: the CMO placement search left {:.1}% of its {} sampled rays unresolved \
         with {} CMOs (its budget: the scene's [cmo] count, else {}, within {} MiB of CMOs): {what}",
        100.0 * p.share(),
        p.rays,
        p.centres.len(),
        crate::scene::DEFAULT_SEARCH_CMOS,
        crate::placement::MAX_CMO_BYTES >> 20,
    )
}

/// The reflectors whose vertex normals point into the closed mesh they bound
/// ([`MeshInstance::normals_inward`](crate::scene::MeshInstance::normals_inward)) and whose
/// front was not turned round for it ([`Scene::front_turned`]): a camera lies inside, so the
/// inside is taken as the mirror (a mirror room). Where that is wrong, these normals are the
/// likely cause; a closed reflector seen from outside is turned and never named.
pub fn inward_reflectors(scene: &Scene) -> Vec<String> {
    scene
        .meshes
        .iter()
        .filter(|m| m.reflector && m.normals_inward() && !scene.front_turned(m))
        .map(|m| format!("'{}'", m.name))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_warning_needs_the_threshold_and_names_the_cause() {
        let scene = crate::scene::builtin::by_name("default").unwrap();
        let count = |left: usize| FallbackCount {
            mirror: 1000,
            traced: left,
            unresolved: 0,
            start_hits: 0,
        };
        let at = (WARN_SHARE * 1000.0) as usize;
        assert!(fallback_warning(Method::Compute, &scene, &count(at), None).is_none());
        let w = fallback_warning(Method::Compute, &scene, &count(at + 1), None).unwrap();
        assert!(w.contains("CMO") && w.contains("placement"), "{w}");
        // After a placement search: what it could not do, from what its unresolved rays meet.
        let mut p = crate::placement::Placement {
            centres: vec![glam::Vec3::ZERO; 8],
            unresolved: vec![0.3, 0.2],
            axis_unresolved: 0.4,
            rays: 500,
            later_rays: 0,
            left: crate::placement::Unresolved {
                own_reflector: 80,
                other_reflector: 0,
                elsewhere: 20,
            },
            time: std::time::Duration::ZERO,
            self_capture_off: false,
            judge: crate::placement::Scoring::Centre,
            near: None,
            list_size: None,
            lists: None,
        };
        let w = fallback_warning(Method::Compute, &scene, &count(300), Some(&p)).unwrap();
        assert!(
            w.contains("20.0% of its 500 sampled rays unresolved with 8 CMOs")
                && w.contains("80% of the rays the CMO placement left unresolved meet the reflector they leave"),
            "{w}"
        );
        // Negative: rays that meet other surfaces are not blamed on the reflector.
        p.left = crate::placement::Unresolved {
            own_reflector: 10,
            other_reflector: 10,
            elsewhere: 80,
        };
        let w = fallback_warning(Method::Compute, &scene, &count(300), Some(&p)).unwrap();
        assert!(
            !w.contains("meet the reflector") && w.contains("behind surfaces"),
            "{w}"
        );
        let w = fallback_warning(Method::Ssr, &scene, &count(800), None).unwrap();
        assert!(
            w.contains("known limit") && w.contains("--method ssr"),
            "{w}"
        );
        // Negative: methods that cannot leave a pixel to the fallback never warn.
        assert!(fallback_warning(Method::Bvh, &scene, &count(1000), None).is_none());
        assert!(
            counts(Method::Compute, &count(320)).contains("320 finished by the fallback (32.0%)")
        );
    }
}

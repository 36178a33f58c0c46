#![forbid(unsafe_code)]
//! What the commands say about glossy reflectors ([`crate::lobe`]): which meshes are glossy, and
//! the warning for a method that cannot sample their lobe.

use crate::method::Method;
use crate::scene::Scene;

/// What `method` makes of the scene's glossy reflectors where it cannot sample their lobe: a
/// warning naming the method and the reflectors (`None` where the scene has none, or the method
/// handles every reflection's lobe: the reference, `bvh` with at most one bounce, `fragment`
/// and `compute` (which cone trace it on the cube maps, [`crate::cpu::cone`]) with at most one
/// bounce, and `ssr`, which cone traces it (`cpu::ssr_cone`) and traces one reflection only).
pub fn method_warning(scene: &Scene, method: Method, bounces: u32) -> Option<String> {
    let names = scene.glossy_reflectors();
    if names.is_empty() {
        return None;
    }
    let names = names.join(", ");
    match method {
        Method::Reference => None,
        Method::Bvh if bounces <= 1 => None,
        // One reflection only: `--bounces` above 1 is refused for ssr.
        Method::Ssr => None,
        Method::Fragment | Method::Compute if bounces <= 1 => None,
        m @ (Method::Fragment | Method::Compute) => Some(format!(
            "--method {m} cone traces the glossy reflectors ({names}) on the first reflection \
             only: with --bounces {bounces} the later reflections follow the mirror direction \
             (--method reference samples every one)"
        )),
        Method::Bvh => Some(format!(
            "--method bvh samples the lobe of the glossy reflectors ({names}) on the first \
             reflection only: with --bounces {bounces} the later reflections follow the mirror \
             direction (--method reference samples every one)"
        )),
        m => Some(format!(
            "--method {m} cannot render glossy reflections yet: it traces the mirror direction \
             only, so the glossy reflectors ({names}) show as perfect mirrors (--method bvh and \
             --method reference sample their lobe)"
        )),
    }
}

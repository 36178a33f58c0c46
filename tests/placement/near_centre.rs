//! One CMO in front of the mirror points in view (`placement::NearChoice`), weighed against one on
//! the reflectors' axis by the texels and cells the pyramid march's twin tests per ray: between
//! the corpus's facing mirrors the axis centre sits above the bunny, between the mirrors, and the
//! rays that leave the left mirror sweep its cube map; a centre just in front of that mirror sees
//! them leave it nearly straight on. The GPU check counts what `compute` tests per ray with each.

use crate::common;

use common::render::first_frame;
use common::{finish_gpu, gpu_context};
use cubetrace::Method;
use cubetrace::placement::{self, NEAR_WALK, NearChoice, Placement, Scoring};
use cubetrace::scene::{self, CmoPlacement, Scene};
use cubetrace::vk::GpuContext;
use cubetrace::vk::frame::RenderOptions;

use crate::corpus_searched as corpus;

/// The default criterion's search on corpus scene `name`: the scene as placed, and the search.
fn searched(name: &str) -> (Scene, Placement) {
    let mut scene = corpus(name);
    let cams = scene.cameras.clone();
    let p = placement::resolve_for(&mut scene, &cams, 1, Scoring::default()).unwrap();
    (scene, p)
}

/// Between the facing mirrors the centre in front of the left mirror (the one in view, at x =
/// -0.7, facing +x) replaces the axis centre: its rays test at most [`NEAR_WALK`] of the axis
/// centre's texels and cells. The negatives: the slivers scene (a mirror among sliver
/// triangles) has a centre in front too, whose rays test about as much as the axis centre's,
/// and keeps the axis; the built-in sphere's reflected rays leave every way, so it has no
/// centre in front to weigh.
#[test]
fn the_centre_in_front_replaces_the_axis_where_its_rays_walk_clearly_less() {
    let (_, p) = searched("facing");
    let n: NearChoice = p.near.expect("facing: no centre in front was weighed");
    eprintln!("facing: {n:?}");
    assert!(n.taken() && n.walk <= NEAR_WALK * n.axis_walk, "{n:?}");
    assert_eq!(p.centres, vec![n.centre]);
    assert!(
        n.centre.x > -0.7 && n.centre.x < -0.5,
        "not in front of the left mirror: {n:?}"
    );
    assert!(p.share() <= placement::TARGET_SHARE);

    let (slivers, p) = searched("slivers");
    let n = p.near.expect("slivers: no centre in front was weighed");
    eprintln!("slivers: {n:?}");
    assert!(!n.taken() && n.walk > NEAR_WALK * n.axis_walk, "{n:?}");
    assert_eq!(p.centres, slivers.axis_centres(1));

    let mut sphere = scene::builtin::by_name("default").unwrap();
    sphere.cmo.placement = CmoPlacement::Search { count: 8 };
    let cams = sphere.cameras.clone();
    let p = placement::resolve_for(&mut sphere, &cams, 1, Scoring::default()).unwrap();
    assert!(p.near.is_none(), "{:?}", p.near);
}

/// Texels and cells `compute` (the default criterion) tests per mirror pixel with `centre`, and
/// the share of mirror pixels left to the fallback.
fn gpu_walk(ctx: &GpuContext, scene: &Scene, centre: glam::Vec3) -> (f64, f64) {
    let mut scene = scene.clone();
    scene.cmo.placement = CmoPlacement::Explicit(vec![centre]);
    let options = RenderOptions {
        method: Method::Compute,
        ..RenderOptions::default()
    };
    let (frame, _) = first_frame(ctx, &scene, &scene.cameras[0], options, &scene.name);
    let stats = frame.compute.as_ref().expect("compute's counters");
    let s = stats.summary(&frame.mask);
    let mirror = frame.mask.iter().filter(|&&m| m != 0).count();
    let fallback = frame.fallback_pixels() as f64 / mirror.max(1) as f64;
    (s[0].0 + s[1].0, fallback)
}

/// On the GPU the chosen centre's rays test far fewer texels and cells than the axis centre's
/// (facing, both with the reflectors left out as the search decided, both leaving at most 2 %
/// to the fallback); the negative is the slivers scene's centre in front, which the search did not
/// take: there the two differ by less.
#[test]
fn the_gpu_walks_less_from_the_centre_in_front() {
    let ctx = gpu_context();
    let (facing, p) = searched("facing");
    let axis = facing.axis_centres(1)[0];
    let (near, near_fallback) = gpu_walk(&ctx, &facing, p.centres[0]);
    let (along, axis_fallback) = gpu_walk(&ctx, &facing, axis);
    eprintln!(
        "facing: {near:.1} texels and cells per ray in front ({:.2}% fallback), {along:.1} on \
         the axis ({:.2}%)",
        100.0 * near_fallback,
        100.0 * axis_fallback
    );
    assert!(near_fallback <= 0.02 && axis_fallback <= 0.02);
    assert!(near <= 0.8 * along, "{near:.1} against {along:.1}");

    let (slivers, p) = searched("slivers");
    let n = p.near.expect("slivers: no centre in front was weighed");
    let (near, _) = gpu_walk(&ctx, &slivers, n.centre);
    let (along, _) = gpu_walk(&ctx, &slivers, p.centres[0]);
    eprintln!("slivers: {near:.1} texels and cells per ray in front, {along:.1} on the axis");
    assert!(
        near > 0.8 * along,
        "the slivers' centre in front walks clearly less too ({near:.1} against {along:.1}): the \
         check tells nothing apart"
    );
    finish_gpu(ctx);
}

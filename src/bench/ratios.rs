#![forbid(unsafe_code)]
//! Per scene, the default settings' costs per ray side by side ([`SceneRatios`]).

use serde::Serialize;

use super::results::RunResult;
use super::spec::MethodSpec;
use crate::method::Method;

/// Per scene, the cost per ray of each method and the ratios the project tracks.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SceneRatios {
    pub scene: String,
    /// ns per ray of each method's default setting (`None` where not run).
    pub reference_ns_per_ray: Option<f64>,
    pub envmap_ns_per_ray: Option<f64>,
    pub fragment_ns_per_ray: Option<f64>,
    pub compute_ns_per_ray: Option<f64>,
    pub ssr_ns_per_ray: Option<f64>,
    pub bvh_ns_per_ray: Option<f64>,
    /// The compute path's cost per ray over the BVH tracer's (above 1: the BVH is cheaper).
    pub compute_over_bvh: Option<f64>,
    pub fragment_over_reference: Option<f64>,
    pub compute_over_reference: Option<f64>,
    pub compute_over_fragment: Option<f64>,
    /// Tracing pass at the small frame over the full frame
    /// ([`FloorRun::ratio`](super::FloorRun::ratio)).
    pub fragment_floor: Option<f64>,
    pub compute_floor: Option<f64>,
}

impl SceneRatios {
    /// The ratios of every scene of `runs`, in first-appearance order. The methods are the
    /// default settings: `reference`, `envmap`, `fragment-exact-mip` and `compute`.
    pub fn of(runs: &[RunResult]) -> Vec<SceneRatios> {
        let mut scenes: Vec<&str> = Vec::new();
        for r in runs {
            if !scenes.contains(&r.scene.as_str()) {
                scenes.push(&r.scene);
            }
        }
        let default_label = |kind: Method| MethodSpec::plain(kind).label();
        scenes
            .into_iter()
            .map(|scene| {
                let run = |kind: Method| {
                    let label = default_label(kind);
                    runs.iter().find(|r| r.scene == scene && r.method == label)
                };
                let per_ray = |kind| run(kind).map(|r| r.ns_per_ray);
                let ratio = |a: Option<f64>, b: Option<f64>| Some(a? / b?);
                let floor = |kind| run(kind).and_then(|r| r.floor).map(|f| f.ratio);
                let (refr, fragment, compute) = (
                    per_ray(Method::Reference),
                    per_ray(Method::Fragment),
                    per_ray(Method::Compute),
                );
                SceneRatios {
                    scene: scene.to_string(),
                    reference_ns_per_ray: refr,
                    envmap_ns_per_ray: per_ray(Method::Envmap),
                    fragment_ns_per_ray: fragment,
                    compute_ns_per_ray: compute,
                    ssr_ns_per_ray: per_ray(Method::Ssr),
                    bvh_ns_per_ray: per_ray(Method::Bvh),
                    compute_over_bvh: ratio(compute, per_ray(Method::Bvh)),
                    fragment_over_reference: ratio(fragment, refr),
                    compute_over_reference: ratio(compute, refr),
                    compute_over_fragment: ratio(compute, fragment),
                    fragment_floor: floor(Method::Fragment),
                    compute_floor: floor(Method::Compute),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::results::FloorRun;
    use crate::bench::stats::Stats;

    fn run(scene: &str, kind: Method, ns: f64, rays: usize, floor: Option<f64>) -> RunResult {
        RunResult {
            width: 160,
            height: 120,
            cube_size: 256,
            cmos: 1,
            triangles: 1,
            mirror_pixels: rays,
            rays,
            frames: 1,
            trace_ns: Stats {
                median: ns,
                min: ns,
                max: ns,
            },
            trace_ns_per_mirror_px: ns / rays as f64,
            ns_per_ray: ns / rays as f64,
            floor: floor.map(|ratio| FloorRun {
                width: 16,
                height: 12,
                rays: 1,
                trace_ns: Stats::default(),
                ratio,
            }),
            ..RunResult::unmeasured(scene, MethodSpec::plain(kind).label(), kind)
        }
    }

    #[test]
    fn scene_ratios_pair_the_default_settings_per_scene() {
        let mut strict = run("a", Method::Fragment, 1.0, 100, None);
        strict.method = "fragment-exact-mip-strict".into();
        let runs = vec![
            run("a", Method::Reference, 1000.0, 100, None),
            strict,
            run("a", Method::Fragment, 4000.0, 100, Some(0.5)),
            run("a", Method::Compute, 2000.0, 50, Some(0.1)),
            run("b", Method::Compute, 1.0, 1, None),
        ];
        let r = SceneRatios::of(&runs);
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].scene, "a");
        assert_eq!(r[0].reference_ns_per_ray, Some(10.0));
        assert_eq!(r[0].fragment_ns_per_ray, Some(40.0), "not the strict run");
        assert_eq!(
            r[0].compute_ns_per_ray,
            Some(40.0),
            "per the method's own rays"
        );
        assert_eq!(r[0].fragment_over_reference, Some(4.0));
        assert_eq!(r[0].compute_over_reference, Some(4.0));
        assert_eq!(r[0].compute_over_fragment, Some(1.0));
        assert_eq!(
            (r[0].fragment_floor, r[0].compute_floor),
            (Some(0.5), Some(0.1))
        );
        // Scene b ran no reference and no fragment: no ratio is made up.
        assert_eq!(r[1].compute_ns_per_ray, Some(1.0));
        assert_eq!(r[1].compute_over_reference, None);
        assert_eq!(r[1].compute_over_fragment, None);
    }
}

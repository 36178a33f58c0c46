#![forbid(unsafe_code)]
//! Per scene, the default settings' costs per ray side by side ([`SceneRatios`]).
//!
//! The report is keyed by method: which methods have a column and which ratios are tracked
//! follow from the registry ([`Method::ALL`], [`Method::TRUTH`], [`Method::DEFAULT`],
//! [`Method::EXACT_GPU`]) and what each method is ([`Method::traces_cubemaps`], its
//! [`vertex_search`](crate::method::MethodInfo::vertex_search)), so no method is named here.

use serde::Serialize;

use super::results::RunResult;
use super::spec::MethodSpec;
use crate::method::Method;

/// One method's cost per ray on one scene ([`SceneRatios::methods`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MethodCost {
    pub method: Method,
    /// ns per ray of the method's default setting (`None`: not run).
    pub ns_per_ray: Option<f64>,
    /// Tracing pass at the small frame over the full frame
    /// ([`FloorRun::ratio`](super::FloorRun::ratio); `None`: no floor run).
    pub floor: Option<f64>,
}

/// One tracked ratio of costs per ray: `method`'s over `over`'s ([`SceneRatios::ratios`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CostRatio {
    pub method: Method,
    pub over: Method,
    /// `None` where either method did not run.
    pub ratio: Option<f64>,
}

/// Per scene, the cost per ray of each method and the ratios the project tracks.
///
/// In `bench.json`: `{"scene": "default", "methods": [{"method": "reference", "ns_per_ray":
/// 1134.0, "floor": null}, ...], "ratios": [{"method": "fragment", "over": "reference",
/// "ratio": 3.26}, ...]}`, the entries in the order of [`SceneRatios::columns`] and
/// [`SceneRatios::pairs`] (the columns of the bench's cost-per-ray table).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SceneRatios {
    pub scene: String,
    /// Each method of [`SceneRatios::columns`], in that order.
    pub methods: Vec<MethodCost>,
    /// Each pair of [`SceneRatios::pairs`], in that order.
    pub ratios: Vec<CostRatio>,
}

impl SceneRatios {
    /// The methods with a cost per ray, in [`Method::ALL`]'s order: all but those whose tracing
    /// pass is a search per vertex of the other objects
    /// ([`vertex_search`](crate::method::MethodInfo::vertex_search)), whose cost is not per ray.
    pub fn columns() -> Vec<Method> {
        Method::ALL
            .into_iter()
            .filter(|m| !m.info().vertex_search)
            .collect()
    }

    /// The methods whose floor (small frame over full frame) the table shows: the cube-map
    /// tracers, whose fixed per-pass cost is what the floor exposes.
    pub fn floor_columns() -> Vec<Method> {
        Self::columns()
            .into_iter()
            .filter(|m| m.traces_cubemaps())
            .collect()
    }

    /// The ratios tracked, `(method, over)`: each cube-map tracer over the truth
    /// ([`Method::TRUTH`]), each over the cube-map tracers listed before it, and the default
    /// method ([`Method::DEFAULT`]) over the exact GPU tracer ([`Method::EXACT_GPU`]).
    pub fn pairs() -> Vec<(Method, Method)> {
        let tracers: Vec<Method> = Self::floor_columns();
        let mut out: Vec<(Method, Method)> = tracers.iter().map(|&m| (m, Method::TRUTH)).collect();
        for (k, &m) in tracers.iter().enumerate() {
            out.extend(tracers[..k].iter().map(|&before| (m, before)));
        }
        out.push((Method::DEFAULT, Method::EXACT_GPU));
        out
    }

    /// The ratios of every scene of `runs`, in first-appearance order, from each method's
    /// default setting ([`MethodSpec::plain`]).
    pub fn of(runs: &[RunResult]) -> Vec<SceneRatios> {
        let mut scenes: Vec<&str> = Vec::new();
        for r in runs {
            if !scenes.contains(&r.scene.as_str()) {
                scenes.push(&r.scene);
            }
        }
        let (columns, pairs) = (Self::columns(), Self::pairs());
        scenes
            .into_iter()
            .map(|scene| {
                let run = |kind: Method| {
                    let label = MethodSpec::plain(kind).label();
                    runs.iter().find(|r| r.scene == scene && r.method == label)
                };
                let per_ray = |kind| run(kind).map(|r| r.ns_per_ray);
                SceneRatios {
                    scene: scene.to_string(),
                    methods: columns
                        .iter()
                        .map(|&method| MethodCost {
                            method,
                            ns_per_ray: per_ray(method),
                            floor: run(method).and_then(|r| r.floor).map(|f| f.ratio),
                        })
                        .collect(),
                    ratios: pairs
                        .iter()
                        .map(|&(method, over)| CostRatio {
                            method,
                            over,
                            ratio: per_ray(method).zip(per_ray(over)).map(|(a, b)| a / b),
                        })
                        .collect(),
                }
            })
            .collect()
    }

    /// `method`'s cost (`None`: not a column).
    pub fn method(&self, method: Method) -> Option<&MethodCost> {
        self.methods.iter().find(|c| c.method == method)
    }

    /// ns per ray of `method` (`None`: not run, or not a column).
    pub fn ns_per_ray(&self, method: Method) -> Option<f64> {
        self.method(method).and_then(|c| c.ns_per_ray)
    }

    /// The floor of `method` (`None`: no floor run, or not a column).
    pub fn floor(&self, method: Method) -> Option<f64> {
        self.method(method).and_then(|c| c.floor)
    }

    /// The ratio of `method`'s cost per ray over `over`'s (`None`: either did not run, or the
    /// pair is not tracked).
    pub fn ratio(&self, method: Method, over: Method) -> Option<f64> {
        self.ratios
            .iter()
            .find(|r| (r.method, r.over) == (method, over))
            .and_then(|r| r.ratio)
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
        strict.method = "fragment-centre-mip-strict".into();
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
        assert_eq!(r[0].ns_per_ray(Method::Reference), Some(10.0));
        assert_eq!(
            r[0].ns_per_ray(Method::Fragment),
            Some(40.0),
            "not the strict run"
        );
        assert_eq!(
            r[0].ns_per_ray(Method::Compute),
            Some(40.0),
            "per the method's own rays"
        );
        assert_eq!(r[0].ratio(Method::Fragment, Method::Reference), Some(4.0));
        assert_eq!(r[0].ratio(Method::Compute, Method::Reference), Some(4.0));
        assert_eq!(r[0].ratio(Method::Compute, Method::Fragment), Some(1.0));
        assert_eq!(
            (r[0].floor(Method::Fragment), r[0].floor(Method::Compute)),
            (Some(0.5), Some(0.1))
        );
        // Scene b ran no reference and no fragment: no ratio is made up.
        assert_eq!(r[1].ns_per_ray(Method::Compute), Some(1.0));
        assert_eq!(r[1].ratio(Method::Compute, Method::Reference), None);
        assert_eq!(r[1].ratio(Method::Compute, Method::Fragment), None);
        // Every scene has every column and pair, in the table's order.
        for s in &r {
            let methods: Vec<Method> = s.methods.iter().map(|c| c.method).collect();
            assert_eq!(methods, SceneRatios::columns());
            let pairs: Vec<(Method, Method)> =
                s.ratios.iter().map(|p| (p.method, p.over)).collect();
            assert_eq!(pairs, SceneRatios::pairs());
        }
    }

    #[test]
    fn the_columns_and_pairs_follow_the_registry() {
        assert_eq!(
            SceneRatios::columns(),
            [
                Method::Reference,
                Method::Envmap,
                Method::Fragment,
                Method::Compute,
                Method::Ssr,
                Method::Bvh
            ]
        );
        assert_eq!(
            SceneRatios::floor_columns(),
            [Method::Fragment, Method::Compute]
        );
        assert_eq!(
            SceneRatios::pairs(),
            [
                (Method::Fragment, Method::Reference),
                (Method::Compute, Method::Reference),
                (Method::Compute, Method::Fragment),
                (Method::Compute, Method::Bvh)
            ]
        );
    }
}

#![forbid(unsafe_code)]
//! SVG plots (plotters' SVG backend: text is SVG `<text>`, so no font files or system libraries
//! are needed).
//!
//! - [`scatter`]: speed against error, one point per method (pooled over the scenes of a run),
//!   both axes logarithmic, with the Pareto front (no other point is both cheaper and more
//!   accurate) drawn as a red staircase and its points filled.
//! - [`lines`]: the scaling curves, one line per series, both axes logarithmic.

use anyhow::{Result, anyhow};
use plotters::prelude::*;

/// One point of the scatter plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub label: String,
    /// Cost, e.g. ns per mirror pixel (> 0).
    pub cost: f64,
    /// Error, e.g. a fraction in percent (>= 0; drawn at the floor when below it).
    pub error: f64,
}

/// Indices of the Pareto-optimal points (minimising both cost and error), by increasing cost.
/// A point is dropped when another is at most as costly and at most as wrong, and better in
/// one of the two; of exact duplicates the first is kept.
pub fn pareto_front(points: &[Point]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].cost.is_finite() && points[i].error.is_finite())
        .collect();
    order.sort_by(|&a, &b| {
        points[a]
            .cost
            .total_cmp(&points[b].cost)
            .then(points[a].error.total_cmp(&points[b].error))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].error < best {
            best = points[i].error;
            front.push(i);
        }
    }
    front
}

fn range_log(values: impl Iterator<Item = f64>, floor: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .map(|v| v.max(floor))
        .fold((f64::INFINITY, 0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo > hi {
        return (floor, floor * 10.0);
    }
    (lo / 2.0, hi * 2.0)
}

fn err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("plot: {e}")
}

/// The speed-against-error scatter plot as an SVG document. Errors below `floor` are drawn at
/// `floor` (a log axis has no zero). With `pareto`, the Pareto front is drawn and its points
/// filled (meaningful only when the points compete on the same data, e.g. methods pooled over
/// the same scenes).
pub fn scatter(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    points: &[Point],
    floor: f64,
    pareto: bool,
) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (960, 640)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (x0, x1) = range_log(points.iter().map(|p| p.cost), 1e-3);
        let (y0, y1) = range_log(points.iter().map(|p| p.error), floor);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()
            .map_err(err)?;
        let front = if pareto {
            pareto_front(points)
        } else {
            Vec::new()
        };
        let at = |p: &Point| (p.cost, p.error.max(floor));
        if pareto {
            chart
                .draw_series(LineSeries::new(
                    staircase(&front.iter().map(|&i| at(&points[i])).collect::<Vec<_>>()),
                    RED.stroke_width(2),
                ))
                .map_err(err)?
                .label("Pareto front")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
        }
        chart
            .draw_series(points.iter().enumerate().map(|(i, p)| {
                let style = if front.contains(&i) {
                    RED.filled()
                } else {
                    BLUE.stroke_width(1)
                };
                Circle::new(at(p), 5, style)
            }))
            .map_err(err)?;
        chart
            .draw_series(points.iter().map(|p| {
                Text::new(
                    format!(" {}", p.label),
                    at(p),
                    ("sans-serif", 12).into_font(),
                )
            }))
            .map_err(err)?;
        if pareto {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerLeft)
                .border_style(BLACK)
                .background_style(WHITE.mix(0.8))
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// The front as a staircase: from each point right to the next point's cost, then down.
fn staircase(front: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for (k, &(x, y)) in front.iter().enumerate() {
        out.push((x, y));
        if let Some(&(nx, _)) = front.get(k + 1) {
            out.push((nx, y));
        }
    }
    out
}

/// Line plot with logarithmic axes: `series` is `(name, points)`; non-positive values are
/// left out.
pub fn lines(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let pts = || {
            series
                .iter()
                .flat_map(|(_, p)| p.iter().copied())
                .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        };
        let (x0, x1) = range_log(pts().map(|p| p.0), 1e-9);
        let (y0, y1) = range_log(pts().map(|p| p.1), 1e-9);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(72)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()
            .map_err(err)?;
        for (k, (name, p)) in series.iter().enumerate() {
            let colour = Palette99::pick(k).to_rgba();
            let p: Vec<(f64, f64)> = p
                .iter()
                .copied()
                .filter(|(x, y)| *x > 0.0 && *y > 0.0)
                .collect();
            chart
                .draw_series(LineSeries::new(p.clone(), colour.stroke_width(2)))
                .map_err(err)?
                .label(name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(p.into_iter().map(|q| Circle::new(q, 3, colour.filled())))
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(label: &str, cost: f64, error: f64) -> Point {
        Point {
            label: label.into(),
            cost,
            error,
        }
    }

    #[test]
    fn pareto_front_drops_dominated_points() {
        let pts = [
            p("cheap-bad", 1.0, 50.0),
            p("dominated", 5.0, 60.0),
            p("mid", 10.0, 5.0),
            p("dear-good", 100.0, 0.1),
            p("dear-bad", 200.0, 1.0),
            p("tie-cost-worse", 10.0, 7.0),
        ];
        assert_eq!(pareto_front(&pts), vec![0, 2, 3]);
        // Negative: make the dominated point cheaper than the cheapest and it joins the front.
        let mut pts = pts;
        pts[1].cost = 0.5;
        assert_eq!(pareto_front(&pts), vec![1, 0, 2, 3]);
    }

    #[test]
    fn scatter_is_an_svg_with_labels() {
        let pts = [p("a-method", 1.0, 10.0), p("b-method", 5.0, 0.0)];
        let svg = scatter("t", "x", "y", &pts, 0.01, true).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..40.min(svg.len())]);
        assert!(svg.contains("a-method") && svg.contains("b-method"));
        assert!(svg.contains("Pareto front"));
    }
}

#![forbid(unsafe_code)]
//! SVG plots (plotters' SVG backend: text is SVG `<text>`, so no font files or system libraries
//! are needed).
//!
//! - [`scatter`]: speed against error, one point per method (pooled over the scenes of a run),
//!   both axes logarithmic, with the Pareto front (no other point is both cheaper and more
//!   accurate) drawn as a red staircase and its points filled.
//! - [`lines`]: the scaling curves, one line per series, both axes logarithmic.
//! - [`panels`]: panels side by side (x logarithmic, y linear, one y range), each with lines and
//!   labelled points: `bench --glossy`'s PSNR against cost, one panel per roughness.

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
            legend(&mut chart, SeriesLabelPosition::LowerLeft)?;
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
            legend_line(&mut chart, name, colour, p, 3)?;
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A series' line with its legend entry, and a dot of `radius` at each point.
fn legend_line<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    label: &str,
    colour: RGBAColor,
    pts: Vec<(f64, f64)>,
    radius: u32,
) -> Result<()>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    chart
        .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
        .map_err(err)?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
    chart
        .draw_series(
            pts.into_iter()
                .map(|q| Circle::new(q, radius, colour.filled())),
        )
        .map_err(err)?;
    Ok(())
}

/// The chart's legend at `position`, boxed on a translucent white.
fn legend<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    position: SeriesLabelPosition,
) -> Result<()>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    chart
        .configure_series_labels()
        .position(position)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(err)
}

/// A line of a [`panels`] plot (`series` picks its colour).
#[derive(Clone, Debug, PartialEq)]
pub struct PanelLine {
    pub label: String,
    pub series: usize,
    pub points: Vec<(f64, f64)>,
}

/// A labelled point of a [`panels`] plot, in its series' colour; hollow unless `filled`.
#[derive(Clone, Debug, PartialEq)]
pub struct PanelPoint {
    pub label: String,
    pub series: usize,
    pub x: f64,
    pub y: f64,
    pub filled: bool,
}

/// One panel of a [`panels`] plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    pub title: String,
    pub lines: Vec<PanelLine>,
    pub points: Vec<PanelPoint>,
}

/// Panels side by side, x logarithmic and y linear, one y range for all (so that panels
/// compare): each panel's lines (with a legend) and labelled points. Points with a
/// non-positive x or a non-finite coordinate are left out.
pub fn panels(title: &str, x_desc: &str, y_desc: &str, panels: &[Panel]) -> Result<String> {
    let ok = |(x, y): (f64, f64)| x > 0.0 && x.is_finite() && y.is_finite();
    let all = || {
        panels.iter().flat_map(|p| {
            (p.lines.iter().flat_map(|l| l.points.iter().copied()))
                .chain(p.points.iter().map(|q| (q.x, q.y)))
                .filter(|&q| ok(q))
        })
    };
    let (x0, x1) = range_log(all().map(|q| q.0), 1e-9);
    let (lo, hi) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
        (lo.min(q.1), hi.max(q.1))
    });
    let (y0, y1) = if lo <= hi {
        (lo - 2.0, hi + 2.0)
    } else {
        (0.0, 1.0)
    };
    let mut svg = String::new();
    {
        let n = panels.len().max(1);
        let root = SVGBackend::with_string(&mut svg, (480 * n as u32, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
        for (area, panel) in root.split_evenly((1, n)).iter().zip(panels) {
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, ("sans-serif", 16))
                .margin(12)
                .x_label_area_size(44)
                .y_label_area_size(56)
                .build_cartesian_2d((x0..x1).log_scale(), y0..y1)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .y_desc(y_desc)
                .draw()
                .map_err(err)?;
            for line in &panel.lines {
                let colour = Palette99::pick(line.series).to_rgba();
                let pts: Vec<(f64, f64)> = line.points.iter().copied().filter(|&q| ok(q)).collect();
                legend_line(&mut chart, &line.label, colour, pts, 2)?;
            }
            for q in panel.points.iter().filter(|q| ok((q.x, q.y))) {
                let colour = Palette99::pick(q.series).to_rgba();
                let style = if q.filled {
                    colour.filled()
                } else {
                    colour.stroke_width(2)
                };
                chart
                    .draw_series([Circle::new((q.x, q.y), 5, style)])
                    .map_err(err)?;
                chart
                    .draw_series([Text::new(
                        format!(" {}", q.label),
                        (q.x, q.y),
                        ("sans-serif", 11).into_font(),
                    )])
                    .map_err(err)?;
            }
            legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        }
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
    fn panels_draw_every_panel_line_and_point() {
        let panel = |t: &str, y: f64| Panel {
            title: t.into(),
            lines: vec![PanelLine {
                label: "ladder".into(),
                series: 0,
                points: vec![(1.0, y), (2.0, y + 3.0)],
            }],
            points: vec![PanelPoint {
                label: format!("point-{t}"),
                series: 1,
                x: 1.5,
                y,
                filled: true,
            }],
        };
        let svg = panels("T", "x", "y", &[panel("p16", 20.0), panel("p64", 30.0)]).unwrap();
        assert!(svg.starts_with("<svg"));
        for needle in ["p16", "p64", "point-p16", "point-p64", "ladder"] {
            assert!(svg.contains(needle), "{needle}");
        }
        // Negative: a point at x = 0 (no log position) is left out, its label too.
        let mut p = panel("p16", 20.0);
        p.points[0].x = 0.0;
        let svg = panels("T", "x", "y", &[p]).unwrap();
        assert!(!svg.contains("point-p16"));
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

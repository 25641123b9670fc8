//! The speed–accuracy chart: fit time against the cost above the best found, per panel, with
//! the Pareto front.

use super::speed::{SpeedRow, pareto};

/// The speed–accuracy chart in time, x = fit time (log) in every panel: the solvers on
/// Torrance–Sparrow (D3) and every model with its best solver (lowest cost, then, within 1e-6
/// relative, the fastest), y = the cost above the best any run found, relative (log, floored
/// at 1e-10 so the best shows); and, where the file carries its truth, the solvers on the
/// true model with y = the largest relative parameter error. Colour = method, marker =
/// model, a direct label on every point, and the Pareto front (non-dominated points) ringed
/// and joined by a step line.
#[derive(Clone, Debug)]
pub struct SpeedChart {
    /// Title.
    pub title: String,
    /// Panels, left to right.
    pub panels: Vec<SpeedPanel>,
}

/// One panel of [`SpeedChart`].
#[derive(Clone, Debug)]
pub struct SpeedPanel {
    /// Title.
    pub title: String,
    /// What y is.
    pub y_label: String,
    /// The points.
    pub points: Vec<SpeedPoint>,
}

/// One point of [`SpeedChart`].
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedPoint {
    /// Method name.
    pub method: String,
    /// Model label.
    pub model: String,
    /// Fit time (s).
    pub seconds: f64,
    /// y: the relative cost above the best found (or the parameter error), floored at
    /// [`COST_FLOOR`].
    pub excess: f64,
    /// On the panel's Pareto front.
    pub front: bool,
}

/// Floor of the relative cost excess on the speed chart's log axis.
pub const COST_FLOOR: f64 = 1e-10;

/// [`SpeedChart`] of the study's rows.
pub fn speed_chart(title: &str, rows: &[SpeedRow]) -> SpeedChart {
    let best = rows.iter().map(|r| r.cost).fold(f64::INFINITY, f64::min);
    let point = |r: &SpeedRow| SpeedPoint {
        method: r.method.clone(),
        model: r.model.clone(),
        seconds: r.seconds.max(1e-6),
        excess: ((r.cost - best) / best.abs().max(1e-300)).max(COST_FLOOR),
        front: false,
    };
    let ts = "torrance-sparrow (d3)";
    let solvers: Vec<SpeedPoint> = rows.iter().filter(|r| r.model == ts).map(point).collect();
    let mut models: Vec<SpeedPoint> = Vec::new();
    for r in rows {
        let p = point(r);
        match models.iter_mut().find(|q| q.model == p.model) {
            // Lower cost wins; within 1e-6 relative the costs are equal and the faster wins.
            Some(q)
                if p.excess < q.excess - 1e-6 * (1.0 + q.excess)
                    || ((p.excess - q.excess).abs() <= 1e-6 * (1.0 + q.excess)
                        && p.seconds < q.seconds) =>
            {
                *q = p
            }
            Some(_) => {}
            None => models.push(p),
        }
    }
    let with_front = |mut pts: Vec<SpeedPoint>| {
        let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p.seconds, p.excess)).collect();
        for i in pareto(&xy) {
            pts[i].front = true;
        }
        pts
    };
    let cost_axis = "relative cost above the best found (log)".to_string();
    let mut panels = vec![
        SpeedPanel {
            title: format!("solvers on {ts}"),
            y_label: cost_axis.clone(),
            points: with_front(solvers),
        },
        SpeedPanel {
            title: "models, each with its best solver".into(),
            y_label: cost_axis,
            points: with_front(models),
        },
    ];
    let truth: Vec<SpeedPoint> = rows
        .iter()
        .filter_map(|r| {
            Some(SpeedPoint {
                excess: r.param_error?.max(COST_FLOOR),
                ..point(r)
            })
        })
        .collect();
    if let Some(first) = truth.first() {
        panels.push(SpeedPanel {
            title: format!("solvers on the true model, {}", first.model),
            y_label: "largest relative parameter error (log)".into(),
            points: with_front(truth),
        });
    }
    SpeedChart {
        title: title.to_string(),
        panels,
    }
}

/// The colour of a method in the studies' charts (Okabe & Ito's colour-blind-safe palette,
/// its yellow darkened to read on white; grey for a peer outside
/// [`Method::ALL`](crate::fit::lsq::Method::ALL)).
pub fn method_colour(name: &str) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match name {
        "lm" => RGBColor(0, 114, 178),
        "gn" => RGBColor(213, 94, 0),
        "nm" => RGBColor(0, 158, 115),
        "argmin-lbfgs" => RGBColor(204, 121, 167),
        "argmin-trust-region" => RGBColor(230, 159, 0),
        "argmin-gauss-newton" => RGBColor(86, 180, 233),
        "argmin-nm" => RGBColor(0, 0, 0),
        "argmin-pso" => RGBColor(140, 110, 30),
        _ => RGBColor(120, 120, 120),
    }
}

impl SpeedChart {
    /// Rows and columns of the panels: two to a row, so that the chart is at most 1,200 px
    /// wide and its text is read at full size in the report.
    fn grid(panels: usize) -> (usize, usize) {
        (panels.div_ceil(2).max(1), panels.clamp(1, 2))
    }
}

impl crate::plot::Chart for SpeedChart {
    fn size(&self) -> (u32, u32) {
        let (rows, cols) = Self::grid(self.panels.len());
        (600 * cols as u32, 30 + 460 * rows as u32)
    }

    fn draw<DB: plotters::prelude::DrawingBackend>(
        &self,
        root: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    ) -> anyhow::Result<()> {
        use plotters::prelude::*;
        root.fill(&WHITE).map_err(crate::plot::err)?;
        let root = root
            .titled(&self.title, ("sans-serif", 18))
            .map_err(crate::plot::err)?;
        let (rows, cols) = Self::grid(self.panels.len());
        let areas = root.split_evenly((rows, cols));
        let models: Vec<&str> = {
            let mut v: Vec<&str> = self
                .panels
                .iter()
                .flat_map(|p| p.points.iter().map(|q| q.model.as_str()))
                .collect();
            v.dedup();
            v.sort();
            v.dedup();
            v
        };
        // An odd number of panels leaves a cell free: how to read the chart goes there.
        if let Some(area) = areas.get(self.panels.len()) {
            draw_guide(area)?;
        }
        for (panel, area) in self.panels.iter().zip(&areas) {
            if panel.points.is_empty() {
                continue;
            }
            draw_panel(panel, area, &models)?;
        }
        Ok(())
    }
}

/// A panel's plotting area: log fit time against log cost excess.
type Panel<'a, DB> = plotters::prelude::ChartContext<
    'a,
    DB,
    plotters::prelude::Cartesian2d<
        plotters::coord::combinators::LogCoord<f64>,
        plotters::coord::combinators::LogCoord<f64>,
    >,
>;

/// How to read the chart, in the cell an odd number of panels leaves free.
fn draw_guide<DB: plotters::prelude::DrawingBackend>(
    area: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let lines = [
        "How to read it",
        "Each point is one fit with the whole pipeline (global",
        "initialisation, a subsample, then every sample), timed in",
        "this run. Colour: the method; marker: the model.",
        "Ringed and joined by the step line: the Pareto front.",
        "argmin's solvers run on the same problem under brdfit's",
        "iteration and evaluation limits; the table says why each",
        "one stopped.",
    ];
    for (k, line) in lines.iter().enumerate() {
        let size = if k == 0 { 15.0 } else { 13.0 };
        area.draw(&Text::new(
            line.to_string(),
            (40, 60 + 22 * k as i32 + if k > 0 { 8 } else { 0 }),
            ("sans-serif", size).into_font(),
        ))
        .map_err(crate::plot::err)?;
    }
    Ok(())
}

/// One panel (its points not empty): axes, the floor, the Pareto front's step line, the
/// markers (shape by the model's place in `models`) and the labels.
fn draw_panel<DB: plotters::prelude::DrawingBackend>(
    panel: &SpeedPanel,
    area: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    models: &[&str],
) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let pts = &panel.points;
    let (x0, x1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.seconds), b.max(p.seconds))
    });
    let y0 = pts.iter().map(|p| p.excess).fold(f64::INFINITY, f64::min);
    let y1 = pts.iter().map(|p| p.excess).fold(y0 * 10.0, f64::max);
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x0 / 2.0..x1 * 6.0).log_scale(),
            (y0 / 3.0..y1 * 30.0).log_scale(),
        )
        .map_err(crate::plot::err)?;
    // Points at the floor (the best run, and any within COST_FLOOR of it) are drawn
    // on it: a dashed line marks it and the axis title says so.
    let floored = pts.iter().any(|p| p.excess <= COST_FLOOR);
    let x_desc = if floored {
        format!(
            "fit time (s, log); dashed: the floor {COST_FLOOR:.0e}, points on it are at or below it"
        )
    } else {
        "fit time (s, log)".to_string()
    };
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(panel.y_label.as_str())
        .x_label_formatter(&|v| crate::plot::log_tick(*v))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 13))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(crate::plot::err)?;
    if floored {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x0 / 2.0, COST_FLOOR), (x1 * 6.0, COST_FLOOR)],
                6,
                4,
                RGBColor(120, 120, 120).stroke_width(1),
            ))
            .map_err(crate::plot::err)?;
    }
    // The Pareto front as a step line: right along a point's cost, then down.
    let mut front: Vec<&SpeedPoint> = pts.iter().filter(|p| p.front).collect();
    front.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    let mut steps = Vec::new();
    for (k, p) in front.iter().enumerate() {
        steps.push((p.seconds, p.excess));
        if let Some(q) = front.get(k + 1) {
            steps.push((q.seconds, p.excess));
        }
    }
    chart
        .draw_series(LineSeries::new(steps, BLACK.mix(0.6).stroke_width(1)))
        .map_err(crate::plot::err)?;
    // Markers first, their boxes kept free of labels; then the labels.
    let mut placed = draw_markers(&mut chart, pts, models)?;
    draw_labels(area, &chart, pts, &mut placed)
}

/// Each point's marker (colour by method, shape by the model's place in `models`), the front
/// ringed; the boxes the markers take, to keep free of labels.
fn draw_markers<DB: plotters::prelude::DrawingBackend>(
    chart: &mut Panel<'_, DB>,
    pts: &[SpeedPoint],
    models: &[&str],
) -> anyhow::Result<Vec<(i32, i32, i32, i32)>> {
    use plotters::prelude::*;
    let mut placed = Vec::new();
    for p in pts {
        let c = method_colour(&p.method);
        let at = (p.seconds, p.excess);
        let style = c.filled();
        let hollow = c.stroke_width(2);
        match models.iter().position(|m| *m == p.model).unwrap_or(0) % 6 {
            0 => chart.draw_series(std::iter::once(Circle::new(at, 5, style))),
            1 => chart.draw_series(std::iter::once(TriangleMarker::new(at, 7, style))),
            2 => chart.draw_series(std::iter::once(Cross::new(at, 5, hollow))),
            3 => chart.draw_series(std::iter::once(
                EmptyElement::at(at) + Rectangle::new([(-4, -4), (4, 4)], style),
            )),
            4 => chart.draw_series(std::iter::once(Circle::new(at, 5, hollow))),
            _ => chart.draw_series(std::iter::once(
                EmptyElement::at(at) + Rectangle::new([(-4, -4), (4, 4)], hollow),
            )),
        }
        .map_err(crate::plot::err)?;
        if p.front {
            chart
                .draw_series(std::iter::once(Circle::new(at, 10, BLACK.stroke_width(1))))
                .map_err(crate::plot::err)?;
        }
        let (px, py) = chart.backend_coord(&at);
        placed.push((px - 10, py - 10, px + 10, py + 10));
    }
    Ok(placed)
}

/// A direct label on every point, placed clear of `placed` (joined to its point by a leader
/// line when moved off it), on a white box.
fn draw_labels<DB: plotters::prelude::DrawingBackend>(
    area: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    chart: &Panel<'_, DB>,
    pts: &[SpeedPoint],
    placed: &mut Vec<(i32, i32, i32, i32)>,
) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let bounds = (xr.start, yr.start, xr.end, yr.end);
    let base = area.get_base_pixel();
    // The left panel holds one model: name the method only.
    let one_model = pts.iter().all(|p| p.model == pts[0].model);
    for p in pts {
        let c = method_colour(&p.method);
        let label = if one_model {
            p.method.clone()
        } else {
            format!("{} ({})", p.model, p.method)
        };
        let (px, py) = chart.backend_coord(&(p.seconds, p.excess));
        let h = 15;
        let (lx, ly) = crate::plot::place_label(
            placed,
            (px, py),
            (7 * label.chars().count() as i32, h),
            bounds,
        );
        if crate::plot::needs_leader(py, ly, h) {
            let end = if lx > px {
                lx
            } else {
                lx + 7 * label.chars().count() as i32
            };
            area.draw(&PathElement::new(
                vec![
                    (px - base.0, py - base.1),
                    (end - base.0, ly + h / 2 - base.1),
                ],
                c.mix(0.5).stroke_width(1),
            ))
            .map_err(crate::plot::err)?;
        }
        // On a white box, so no gridline or step line runs through the text.
        let w = area
            .estimate_text_size(&label, &("sans-serif", 12).into_text_style(area))
            .map_or(7 * label.chars().count() as i32, |(w, _)| w as i32 + 2);
        area.draw(&Rectangle::new(
            [
                (lx - base.0 - 2, ly - base.1 - 1),
                (lx - base.0 + w, ly - base.1 + h - 1),
            ],
            WHITE.mix(0.9).filled(),
        ))
        .map_err(crate::plot::err)?;
        area.draw(&Text::new(
            label,
            (lx - base.0, ly - base.1),
            ("sans-serif", 12).into_font().color(&c),
        ))
        .map_err(crate::plot::err)?;
    }
    Ok(())
}

//! The trade-off chart of a case: image error against fit + render time, one point per
//! model.

use super::{CaseResult, Metric, ModelRow, ThresholdJson};

/// Image error against fit + render time, one labelled point per model, the chosen one
/// ringed, the threshold as a line: speed against accuracy in the image.
pub(super) struct TradeoffChart {
    pub(super) case: CaseResult,
    pub(super) threshold: ThresholdJson,
}

impl crate::plot::Chart for TradeoffChart {
    fn size(&self) -> (u32, u32) {
        (800, 500)
    }

    fn draw<DB: plotters::prelude::DrawingBackend>(
        &self,
        root: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    ) -> anyhow::Result<()> {
        use plotters::prelude::*;
        let metric = Metric::from_key(&self.threshold.metric).unwrap_or(Metric::FlipP99);
        root.fill(&WHITE).map_err(crate::plot::err)?;
        let pts = self.points(metric);
        let (mut x0, mut x1) = (f64::INFINITY, 0.0f64);
        let mut y1 = self.threshold.value;
        for &(x, y, _) in &pts {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y1 = y1.max(y);
        }
        let lx1 = x1 * 2.2;
        // At least a decade, so the log axis has labelled ticks.
        let lx0 = (x0 / 1.4).min(lx1 / 12.0);
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!(
                    "{} lit: image error against fit + render time (verdict: {})",
                    self.case.case,
                    self.case.verdict.name()
                ),
                ("sans-serif", 18),
            )
            .margin(14)
            .x_label_area_size(46)
            .y_label_area_size(64)
            // Room below 0, so a point with no error is not on the axis and its label fits
            // on its own line.
            .build_cartesian_2d((lx0..lx1).log_scale(), -0.06 * y1..y1 * 1.12)
            .map_err(crate::plot::err)?;
        chart
            .configure_mesh()
            .x_desc("fit + render time (s, log scale)")
            .y_desc(metric.key())
            // Enough ticks that 1-2-5 values inside the decade are labelled, not only 0.1.
            .x_labels(30)
            .x_label_formatter(&|v| crate::plot::log_tick(*v))
            .y_label_formatter(&|v| {
                if *v < -1e-12 {
                    String::new()
                } else {
                    crate::plot::tick(*v)
                }
            })
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(crate::plot::err)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(lx0, self.threshold.value), (lx1, self.threshold.value)],
                RGBColor(200, 0, 0).stroke_width(1),
            )))
            .map_err(crate::plot::err)?;
        let th_at = (lx0 * 1.05, self.threshold.value + 0.02 * y1);
        chart
            .draw_series(std::iter::once(Text::new(
                format!("threshold {}", self.threshold.value),
                th_at,
                ("sans-serif", 13).into_font().color(&RGBColor(200, 0, 0)),
            )))
            .map_err(crate::plot::err)?;
        // Points first, then direct labels placed greedily so none overlaps another, nor the
        // threshold line and its label.
        let (xr, _) = chart.plotting_area().get_pixel_range();
        let (tx, ty) = chart.backend_coord(&th_at);
        let (_, line_y) = chart.backend_coord(&(lx0, self.threshold.value));
        let mut placed: Vec<(i32, i32, i32, i32)> = vec![
            (tx, ty, tx + 110, ty + 16),
            (xr.start, line_y - 1, xr.end, line_y + 1),
        ];
        self.draw_points(&mut chart, &pts, &mut placed)?;
        self.draw_labels(root, &chart, &pts, &mut placed)
    }
}

/// The chart's plotting area: log time against linear error.
type Tradeoff<'a, DB> = plotters::prelude::ChartContext<
    'a,
    DB,
    plotters::prelude::Cartesian2d<
        plotters::coord::combinators::LogCoord<f64>,
        plotters::coord::types::RangedCoordf64,
    >,
>;

impl TradeoffChart {
    /// One point per model: (fit + render time, error under `metric`, row).
    fn points(&self, metric: Metric) -> Vec<(f64, f64, &ModelRow)> {
        self.case
            .models
            .iter()
            .map(|m| {
                (
                    (m.fit_seconds + m.render_seconds).max(1e-4),
                    m.error(metric),
                    m,
                )
            })
            .collect()
    }

    /// A point's colour: green within the threshold, grey above it.
    fn colour_of(&self, y: f64) -> plotters::style::RGBColor {
        use plotters::style::RGBColor;
        if y <= self.threshold.value {
            RGBColor(0, 120, 60)
        } else {
            RGBColor(60, 60, 60)
        }
    }

    /// Every point (and the chosen one's ring), each kept free of labels in `placed`.
    fn draw_points<DB: plotters::prelude::DrawingBackend>(
        &self,
        chart: &mut Tradeoff<'_, DB>,
        pts: &[(f64, f64, &ModelRow)],
        placed: &mut Vec<(i32, i32, i32, i32)>,
    ) -> anyhow::Result<()> {
        use plotters::prelude::*;
        for &(x, y, m) in pts {
            let chosen = self.case.chosen.as_deref() == Some(&m.model);
            chart
                .draw_series(std::iter::once(Circle::new(
                    (x, y),
                    4,
                    self.colour_of(y).filled(),
                )))
                .map_err(crate::plot::err)?;
            let r = if chosen {
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (x, y),
                        9,
                        RGBColor(200, 0, 0).stroke_width(2),
                    )))
                    .map_err(crate::plot::err)?;
                10
            } else {
                5
            };
            let (px, py) = chart.backend_coord(&(x, y));
            placed.push((px - r, py - r, px + r, py + r));
        }
        Ok(())
    }

    /// The points' labels, lowest error first (the chosen model's and its neighbours' nearest
    /// their points); a label moved off its point's line is joined to it by a leader line.
    fn draw_labels<DB: plotters::prelude::DrawingBackend>(
        &self,
        root: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
        chart: &Tradeoff<'_, DB>,
        pts: &[(f64, f64, &ModelRow)],
        placed: &mut Vec<(i32, i32, i32, i32)>,
    ) -> anyhow::Result<()> {
        use plotters::prelude::*;
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let mut order: Vec<usize> = (0..pts.len()).collect();
        order.sort_by(|&a, &b| pts[a].1.total_cmp(&pts[b].1));
        for k in order {
            let (x, y, m) = pts[k];
            let chosen = self.case.chosen.as_deref() == Some(&m.model);
            let colour = self.colour_of(y);
            let label = format!("{}{}", m.model, if chosen { " (chosen)" } else { "" });
            let (px, py) = chart.backend_coord(&(x, y));
            let h = 16;
            let w = 7 * label.chars().count() as i32;
            let (left, top) = crate::plot::place_label(
                placed,
                (px + 2, py),
                (w, h),
                (xr.start, yr.start, xr.end, yr.end),
            );
            if crate::plot::needs_leader(py, top, h) {
                let end = if left > px { left } else { left + w };
                root.draw(&PathElement::new(
                    vec![(px, py), (end, top + h / 2)],
                    colour.mix(0.6).stroke_width(1),
                ))
                .map_err(crate::plot::err)?;
            }
            root.draw(&Text::new(
                label,
                (left, top),
                ("sans-serif", 13).into_font().color(&colour),
            ))
            .map_err(crate::plot::err)?;
        }
        Ok(())
    }
}

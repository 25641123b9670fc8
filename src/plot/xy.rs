//! The generic x–y chart (residual, albedo and study charts).

use super::series::{PALETTE, draw_legend, draw_line, draw_series};
use super::{Chart, LobeSeries, err, tick};
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Generic x–y chart with several series (lines or markers), for residual, albedo and study
/// charts.
#[derive(Clone, Debug)]
pub struct XyChart {
    /// Title.
    pub title: String,
    /// X axis label with unit.
    pub x_label: String,
    /// Y axis label with unit.
    pub y_label: String,
    /// Series: label, points, markers.
    pub series: Vec<LobeSeries>,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Optional horizontal reference line (value, label).
    pub hline: Option<(f64, String)>,
}

pub(super) fn range_of(vals: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { (1e-3, 1.0) } else { (0.0, 1.0) };
    }
    if log {
        (lo / 1.5, hi * 1.5)
    } else {
        // A curve flat to within 2 % of its size (a Lambertian albedo with quadrature noise
        // of 1e-6) is drawn flat: the span is widened to 2 % around its middle, so the ticks
        // do not resolve the noise.
        let least = 0.02 * hi.abs().max(lo.abs());
        if hi - lo < least {
            let mid = 0.5 * (lo + hi);
            (lo, hi) = (mid - 0.5 * least, mid + 0.5 * least);
        }
        let pad = 0.05 * (hi - lo).max(1e-12);
        (lo - pad, hi + pad)
    }
}

impl Chart for XyChart {
    fn size(&self) -> (u32, u32) {
        (760, 480)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(err)?;
        let all = || self.series.iter().flat_map(|s| s.points.iter());
        let (x0, x1) = range_of(all().map(|p| p.0), self.log_x);
        let (mut y0, mut y1) = range_of(all().map(|p| p.1), self.log_y);
        if let Some((h, _)) = &self.hline {
            y0 = y0.min(*h);
            y1 = y1.max(*h * 1.05);
        }
        let tx = |v: f64| if self.log_x { v.log10() } else { v };
        let ty = |v: f64| if self.log_y { v.log10() } else { v };
        // Headroom above the data for the legend, so it never covers a point or a curve: the
        // legend's rows (about 21 px each) out of the plotting area's ~380 px.
        let (top, _) = self.legend_headroom(ty(y0), ty(y1));
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(64)
            .build_cartesian_2d(tx(x0)..tx(x1), ty(y0)..top)
            .map_err(err)?;
        let xl = if self.log_x {
            format!("log₁₀ {}", self.x_label)
        } else {
            self.x_label.clone()
        };
        let yl = if self.log_y {
            format!("log₁₀ {}", self.y_label)
        } else {
            self.y_label.clone()
        };
        chart
            .configure_mesh()
            .x_desc(xl)
            .y_desc(yl)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 13))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(err)?;
        if let Some((h, label)) = &self.hline {
            chart
                .draw_series(LineSeries::new(
                    vec![(tx(x0), ty(*h)), (tx(x1), ty(*h))],
                    BLACK,
                ))
                .map_err(err)?
                .label(label.clone())
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
        }
        // A series with an empty label continues the line before it: same colour and stroke,
        // no legend entry (the upper line of a 10–90 % band). Lines take the palette and
        // strokes in turn; markers are measured samples, in one colour.
        let mut k = 0;
        for s in &self.series {
            let xy: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .filter(|p| (!self.log_x || p.0 > 0.0) && (!self.log_y || p.1 > 0.0))
                .map(|p| (tx(p.0), ty(p.1)))
                .collect();
            if s.label.is_empty() && k > 0 {
                draw_line(&mut chart, xy, k - 1, PALETTE[(k - 1) % PALETTE.len()])?;
                continue;
            }
            draw_series(
                &mut chart,
                xy,
                &s.label,
                s.markers,
                3,
                (k, PALETTE[k % PALETTE.len()]),
            )?;
            if !s.markers {
                k += 1;
            }
        }
        // The legend sits in the headroom above the data, at the right.
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        Ok(())
    }
}

impl XyChart {
    /// Rows of the legend: one per labelled series and the reference line.
    pub fn legend_rows(&self) -> usize {
        self.series.iter().filter(|s| !s.label.is_empty()).count()
            + usize::from(self.hline.is_some())
    }

    /// The top of the y axis (in axis units, log₁₀ on a log axis) that leaves the data
    /// (from `lo` to `hi`) the lower part of the plot and the legend the band above it, and
    /// that band's share of the height: 21 px per legend row plus 14 out of about 380 px,
    /// at most half.
    pub fn legend_headroom(&self, lo: f64, hi: f64) -> (f64, f64) {
        let share = ((21 * self.legend_rows() + 14) as f64 / 380.0).min(0.5);
        (lo + (hi - lo) / (1.0 - share), share)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_curve_is_not_magnified() {
        // Albedo 0.5 with 1e-6 of quadrature noise: the axis spans at least 2 % of 0.5.
        let (lo, hi) = range_of([0.5, 0.5 + 1e-6, 0.5 - 1e-6].into_iter(), false);
        assert!(hi - lo >= 0.01 && lo < 0.5 && hi > 0.5, "{lo} {hi}");
        // A curve that varies keeps its own span plus 5 % either side.
        let (lo, hi) = range_of([0.2, 0.6].into_iter(), false);
        assert!(
            (lo - 0.18).abs() < 1e-12 && (hi - 0.62).abs() < 1e-12,
            "{lo} {hi}"
        );
    }
}

//! How series are stroked and labelled on an x–y chart: the measured colour, the models'
//! palette and line styles, lines, markers and the legend box.

use super::err;
use anyhow::Result;
use plotters::prelude::*;

pub(super) type XyContext<'a, DB> = ChartContext<
    'a,
    DB,
    plotters::coord::cartesian::Cartesian2d<
        plotters::coord::types::RangedCoordf64,
        plotters::coord::types::RangedCoordf64,
    >,
>;

/// The colour of measured samples in every chart (markers), so "measured" reads the same
/// everywhere; models take `PALETTE` in turn.
pub const MEASURED: RGBColor = RGBColor(0, 0, 0);

/// How the `k`-th model curve of a chart is stroked: (width, dash length, gap) in pixels, a gap
/// of 0 meaning solid. The first curve is solid, the next dashed (drawn over it), then
/// dotted, so a curve lying on another (MERL aluminium's Torrance–Sparrow under its GGX–Smith)
/// still shows as the dashes on the line beneath.
pub fn line_style(k: usize) -> (u32, u32, u32) {
    match k % 4 {
        0 => (2, 0, 0),
        1 => (2, 10, 6),
        2 => (2, 2, 4),
        _ => (2, 14, 4),
    }
}

/// A line of `xy` in `color`, stroked as [`line_style`]`(k)`.
pub(super) fn draw_line<'a, 'b, DB: DrawingBackend + 'a>(
    chart: &'b mut XyContext<'a, DB>,
    xy: Vec<(f64, f64)>,
    k: usize,
    color: RGBColor,
) -> Result<&'b mut plotters::chart::SeriesAnno<'a, DB>> {
    let (width, dash, gap) = line_style(k);
    let style = color.stroke_width(width);
    if gap == 0 {
        chart.draw_series(LineSeries::new(xy, style)).map_err(err)
    } else {
        chart
            .draw_series(DashedLineSeries::new(xy, dash, gap, style))
            .map_err(err)
    }
}

/// One labelled series: markers of `radius` pixels in [`MEASURED`], or a line in `color`
/// stroked as the `k`-th model ([`line_style`]).
pub(super) fn draw_series<'a, DB: DrawingBackend + 'a>(
    chart: &mut XyContext<'a, DB>,
    xy: Vec<(f64, f64)>,
    label: &str,
    markers: bool,
    radius: u32,
    (k, color): (usize, RGBColor),
) -> Result<()> {
    if markers {
        let color = MEASURED;
        // Dense clouds are drawn translucent and small, so their density stays readable.
        let (radius, alpha) = if xy.len() > 2000 {
            (2, 0.15)
        } else {
            (radius, 1.0)
        };
        chart
            .draw_series(
                xy.iter()
                    .map(|p| Circle::new(*p, radius, color.mix(alpha).filled())),
            )
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| Circle::new((x + 9, y), 3, color.filled()));
    } else {
        let (width, dash, gap) = line_style(k);
        draw_line(chart, xy, k, color)?
            .label(label)
            .legend(move |(x, y)| {
                let (dash, gap) = if gap == 0 { (30, 0) } else { (dash, gap) };
                plotters::element::DashedPathElement::new(
                    vec![(x, y), (x + 24, y)],
                    dash,
                    gap,
                    color.stroke_width(width),
                )
            });
    }
    Ok(())
}

/// The legend box.
pub(super) fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut XyContext<'a, DB>,
    pos: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(pos)
        .label_font(("sans-serif", 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(err)
}

pub(super) const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 90, 181),
    RGBColor(220, 50, 32),
    RGBColor(0, 140, 70),
    RGBColor(150, 60, 170),
    RGBColor(230, 140, 0),
    RGBColor(90, 90, 90),
];

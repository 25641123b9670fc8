//! Polar reflection distributions in the plane of incidence (Blinn 1977, Figures 5 and 6):
//! the curves, the in-plane samples, and the lobe chart that draws them.

use super::series::{PALETTE, draw_legend, draw_series};
use super::{Chart, err};
use crate::data::Dataset;
use crate::model::{Distribution, Geometry, Model, ModelKind};
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::f64::consts::PI;

/// What the radius of a lobe plot shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LobeQuantity {
    /// Blinn's reflected intensity for a unit light, i = π f_r cosθi.
    #[default]
    Intensity,
    /// The BRDF f_r (1/sr).
    Brdf,
}

impl LobeQuantity {
    fn of(self, f: f64, cos_i: f64) -> f64 {
        match self {
            LobeQuantity::Intensity => PI * f * cos_i,
            LobeQuantity::Brdf => f,
        }
    }

    fn label(self) -> &'static str {
        match self {
            LobeQuantity::Intensity => "reflected intensity i = π f_r cosθi (unit light)",
            LobeQuantity::Brdf => "f_r (1/sr)",
        }
    }
}

/// A model's curve in the plane of incidence at θi (degrees): (signed θo in degrees, value),
/// with θo < 0 on the mirror side (φo = φi + 180°) and θo > 0 on the light's side.
pub fn lobe_curve(model: &Model, theta_i_deg: f64, q: LobeQuantity) -> Vec<(f64, f64)> {
    let ti = theta_i_deg.to_radians();
    (-359..=359)
        .map(|k| {
            let s = k as f64 * 0.25;
            let phi = if s < 0.0 { PI } else { 0.0 };
            let g = Geometry::from_angles(ti, 0.0, s.abs().to_radians(), phi);
            (s, q.of(model.brdf(&g), ti.cos()))
        })
        .collect()
}

/// How near a sample must lie to a lobe panel's plane to be drawn in it (degrees): its θi
/// within `theta_i` of the panel's, its azimuth within `azimuth` of the plane of incidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InPlane {
    /// Largest |θi − panel θi|.
    pub theta_i: f64,
    /// Largest azimuth from φi (light side) or φi + 180° (mirror side).
    pub azimuth: f64,
}

impl InPlane {
    /// Both tolerances `deg`.
    pub fn both(deg: f64) -> InPlane {
        InPlane {
            theta_i: deg,
            azimuth: deg,
        }
    }

    /// What the legend says about the samples drawn: "θi ± 0.5°, azimuth ± 1°" (the
    /// azimuth from the plane of incidence).
    pub fn describe(&self) -> String {
        format!(
            "θi ± {}°, azimuth ± {}°",
            crate::model::significant(self.theta_i, 3),
            crate::model::significant(self.azimuth, 3)
        )
    }
}

/// The measured samples of channel `c` in the plane of incidence at θi: θi within
/// `tol.theta_i`, and φo = φi (light side, θo > 0) or φo = φi + 180° (mirror side, θo < 0)
/// within `tol.azimuth`.
pub fn in_plane_samples(
    ds: &Dataset,
    c: usize,
    theta_i_deg: f64,
    tol: InPlane,
    q: LobeQuantity,
) -> Vec<(f64, f64)> {
    let vals = ds.brdf_values(c);
    let tol_deg = tol.azimuth;
    let mut out: Vec<(f64, f64)> = (0..ds.len())
        .filter_map(|k| {
            let a = ds.angles(k);
            if (a[0].to_degrees() - theta_i_deg).abs() > tol.theta_i || !vals[k].is_finite() {
                return None;
            }
            let d = (a[3] - a[1]).to_degrees().rem_euclid(360.0);
            let to = a[2].to_degrees();
            let side = if d.min(360.0 - d) <= tol_deg {
                1.0
            } else if (d - 180.0).abs() <= tol_deg {
                -1.0
            } else {
                return None;
            };
            Some((side * to, q.of(vals[k], a[0].cos())))
        })
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    out
}

/// The maximum of a curve: (signed θo, value).
pub fn curve_max(points: &[(f64, f64)]) -> (f64, f64) {
    points.iter().copied().fold(
        (0.0, f64::NEG_INFINITY),
        |a, b| if b.1 > a.1 { b } else { a },
    )
}

/// One series of a lobe plot.
#[derive(Clone, Debug)]
pub struct LobeSeries {
    /// Legend label.
    pub label: String,
    /// Points (signed θo in degrees, value).
    pub points: Vec<(f64, f64)>,
    /// Markers (measured samples) instead of a line.
    pub markers: bool,
}

/// One polar panel: the incidence angle and its series.
#[derive(Clone, Debug)]
pub struct LobePanel {
    /// Panel title.
    pub title: String,
    /// Incidence angle in degrees (for the incoming ray and the mirror direction).
    pub theta_i_deg: f64,
    /// Series.
    pub series: Vec<LobeSeries>,
}

/// Polar reflection-distribution chart: panels side by side.
#[derive(Clone, Debug)]
pub struct LobeChart {
    /// Chart title.
    pub title: String,
    /// Panels.
    pub panels: Vec<LobePanel>,
    /// What the radius shows.
    pub quantity: LobeQuantity,
    /// Log radius (4 decades below the maximum), for measured data with sharp peaks.
    pub log: bool,
    /// One radial scale for every panel (the largest value of all), so panels compare by
    /// size (Blinn's Figures 5 and 6); else each panel has its own, shown on its axes.
    pub shared_scale: bool,
}

impl LobeChart {
    /// Pixel size of the rendered chart.
    pub fn size_px(&self) -> (u32, u32) {
        self.size()
    }

    /// Decades of a log radius between the outer circle and the centre.
    pub const LOG_DECADES: f64 = 4.0;

    /// The radius drawn for a value, given the largest value `vmax` in the chart. On a log
    /// radius a value below the floor `vmax`·10⁻⁴ is drawn at the centre ([`LobeChart::floor`]).
    pub fn radius(&self, v: f64, vmax: f64) -> f64 {
        if self.log {
            ((v / vmax).max(1e-300).log10() + Self::LOG_DECADES).max(0.0) / Self::LOG_DECADES
        } else {
            v / vmax
        }
    }

    /// The value at the centre: the floor of a log radius (`vmax`·10⁻⁴), 0 on a linear one.
    pub fn floor(&self, vmax: f64) -> f64 {
        self.value_at(0.0, vmax)
    }

    /// The largest value in a panel: its outer circle, unless the chart has a
    /// [`LobeChart::shared_scale`] (then [`LobeChart::vmax_of`]).
    pub fn vmax(panel: &LobePanel) -> f64 {
        panel
            .series
            .iter()
            .flat_map(|s| &s.points)
            .map(|p| p.1)
            .filter(|v| v.is_finite())
            .fold(1e-300, f64::max)
    }

    /// The outer circle's value of a panel: its own largest value, or with a shared scale the
    /// largest value of every panel.
    pub fn vmax_of(&self, panel: &LobePanel) -> f64 {
        if self.shared_scale {
            self.panels.iter().map(Self::vmax).fold(1e-300, f64::max)
        } else {
            Self::vmax(panel)
        }
    }

    /// The value at drawn radius `r` (inverse of [`LobeChart::radius`]), for axis labels: on a
    /// log radius the centre is the floor, 4 decades below `vmax`, not 0.
    pub fn value_at(&self, r: f64, vmax: f64) -> f64 {
        if self.log {
            vmax * 10f64.powf(Self::LOG_DECADES * (r.max(0.0) - 1.0))
        } else {
            r * vmax
        }
    }

    /// The axis label at signed radius `r` (the x axis runs from −1 to 1): the value there,
    /// 3 significant digits (in e-notation below 0.001 or from 100,000 on).
    pub fn tick_label(&self, r: f64, vmax: f64) -> String {
        let v = self.value_at(r.abs(), vmax);
        let a = v.abs();
        if a == 0.0 || (1e-3..1e5).contains(&a) {
            crate::model::significant(v, 3)
        } else {
            let s = format!("{v:.2e}");
            match s.split_once('e') {
                Some((m, e)) if m.contains('.') => {
                    format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
                }
                _ => s,
            }
        }
    }
}

/// Most legend entries drawn inside a lobe panel (the incoming ray, the curves, the samples);
/// more (every model of a `fit --model all` file) go in two columns below the panel, where
/// they cover no lobe.
const LEGEND_INSIDE: usize = 6;

/// Height of one legend row below a panel, in pixels.
const LEGEND_ROW: u32 = 19;

impl LobeChart {
    /// Rows of the legend below the panels (0 where every legend fits inside its panel).
    fn legend_rows(&self) -> u32 {
        self.panels
            .iter()
            .map(|p| p.series.len() + 1)
            .filter(|&n| n > LEGEND_INSIDE)
            .map(|n| n.div_ceil(2) as u32)
            .max()
            .unwrap_or(0)
    }
}

/// Draw a panel's legend in two columns on `area` (below the panel): the incoming ray at
/// θi, then each series with the glyph [`draw_series`] gives it.
fn legend_below<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &LobePanel,
) -> Result<()> {
    // Down the first column, then the second.
    let col = area.dim_in_pixel().0 as i32 / 2;
    let rows = (panel.series.len() + 1).div_ceil(2);
    let at = |i: usize| {
        (
            14 + col * (i / rows) as i32,
            8 + (LEGEND_ROW as i32) * (i % rows) as i32,
        )
    };
    let text =
        |s: &str, (x, y): (i32, i32)| Text::new(s.to_string(), (x + 32, y - 7), ("sans-serif", 13));
    let (x, y) = at(0);
    area.draw(&PathElement::new(
        vec![(x, y), (x + 24, y)],
        BLACK.stroke_width(2),
    ))
    .map_err(err)?;
    area.draw(&text(
        &format!("incoming ray, θi = {}°", panel.theta_i_deg),
        (x, y),
    ))
    .map_err(err)?;
    let mut k = 0;
    for (i, s) in panel.series.iter().enumerate() {
        let (x, y) = at(i + 1);
        if s.markers {
            area.draw(&Circle::new(
                (x + 9, y),
                3,
                super::series::MEASURED.filled(),
            ))
            .map_err(err)?;
        } else {
            let (width, dash, gap) = super::series::line_style(k);
            let (dash, gap) = if gap == 0 { (30, 0) } else { (dash, gap) };
            let color = PALETTE[k % PALETTE.len()];
            area.draw(&plotters::element::DashedPathElement::new(
                vec![(x, y), (x + 24, y)],
                dash,
                gap,
                color.stroke_width(width),
            ))
            .map_err(err)?;
            k += 1;
        }
        area.draw(&text(&s.label, (x, y))).map_err(err)?;
    }
    Ok(())
}

impl Chart for LobeChart {
    fn size(&self) -> (u32, u32) {
        let legend = match self.legend_rows() {
            0 => 0,
            n => n * LEGEND_ROW + 8,
        };
        (560 * self.panels.len().max(1) as u32, 440 + legend)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(&self.title, ("sans-serif", 20)).map_err(err)?;
        let areas = root.split_evenly((1, self.panels.len().max(1)));
        for (panel, area) in self.panels.iter().zip(&areas) {
            let vmax = self.vmax_of(panel);
            let same = if self.shared_scale && self.panels.len() > 1 {
                "; one scale for all panels"
            } else {
                ""
            };
            let unit = if self.log {
                format!(
                    "radius: {} on a log scale, 4 decades to the outer circle{same}",
                    self.quantity.label()
                )
            } else {
                format!(
                    "radius: {} (axes in its units{same})",
                    self.quantity.label()
                )
            };
            // On a log radius, measured values below the floor are drawn at the centre: the
            // footer's second line says how many.
            let floor = self.floor(vmax);
            let pinned: usize = panel
                .series
                .iter()
                .filter(|s| s.markers && self.log)
                .map(|s| {
                    s.points
                        .iter()
                        .filter(|p| p.1.is_finite() && p.1 < floor)
                        .count()
                })
                .sum();
            let (area, foot) = area.split_vertically(area.dim_in_pixel().1.saturating_sub(40));
            let below = match self.legend_rows() {
                0 => 0,
                n => n * LEGEND_ROW + 8,
            };
            let (area, legend) = area.split_vertically(area.dim_in_pixel().1.saturating_sub(below));
            foot.draw(&Text::new(unit.clone(), (14, 4), ("sans-serif", 13)))
                .map_err(err)?;
            if pinned > 0 {
                foot.draw(&Text::new(
                    format!(
                        "{pinned} measured values below {} (the centre) are drawn at the centre",
                        self.tick_label(0.0, vmax)
                    ),
                    (14, 21),
                    ("sans-serif", 13),
                ))
                .map_err(err)?;
            }
            let mut chart = ChartBuilder::on(&area)
                .caption(&panel.title, ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(58)
                .build_cartesian_2d(-1.1f64..1.1f64, 0f64..1.1f64)
                .map_err(err)?;
            let label = |r: f64| self.tick_label(r, vmax);
            chart
                .configure_mesh()
                .disable_mesh()
                // Ticks at half radii only (±1, ±½, 0; 0, ½, 1), on the rings: the values of a
                // log radius are long, and at every fifth of the radius they ran together.
                .x_labels(5)
                .y_labels(3)
                .x_label_formatter(&|v| label(*v))
                .y_label_formatter(&|v| label(*v))
                .x_desc("relative to the normal (mirror side ←, light side →)")
                .y_desc("along the normal")
                .label_style(("sans-serif", 13))
                .axis_desc_style(("sans-serif", 12))
                .draw()
                .map_err(err)?;
            // Polar grid: circles at quarter radii and the surface line.
            for k in 1..=4 {
                let r = k as f64 / 4.0;
                chart
                    .draw_series(LineSeries::new(
                        (0..=90).map(|d| {
                            let a = (d as f64 * 2.0 - 90.0).to_radians();
                            (r * a.sin(), r * a.cos())
                        }),
                        RGBColor(220, 220, 220),
                    ))
                    .map_err(err)?;
            }
            let ti = panel.theta_i_deg.to_radians();
            // Incoming ray from the right, and the mirror direction on the left (dashed).
            chart
                .draw_series(LineSeries::new(
                    vec![(1.05 * ti.sin(), 1.05 * ti.cos()), (0.0, 0.0)],
                    BLACK.stroke_width(2),
                ))
                .map_err(err)?
                .label(format!("incoming ray, θi = {}°", panel.theta_i_deg))
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], BLACK.stroke_width(2))
                });
            let dash: Vec<(f64, f64)> = (0..10)
                .flat_map(|k| {
                    let a = k as f64 / 10.0 * 1.05;
                    [
                        (-a * ti.sin(), a * ti.cos()),
                        (-(a + 0.05) * ti.sin(), (a + 0.05) * ti.cos()),
                    ]
                })
                .collect();
            for seg in dash.chunks(2) {
                chart
                    .draw_series(LineSeries::new(seg.to_vec(), RGBColor(120, 120, 120)))
                    .map_err(err)?;
            }
            let mut k = 0;
            for s in &panel.series {
                let xy: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .filter(|p| p.1.is_finite())
                    .map(|&(t, v)| {
                        let r = self.radius(v, vmax);
                        let a = t.to_radians();
                        (r * a.sin(), r * a.cos())
                    })
                    .collect();
                draw_series(
                    &mut chart,
                    xy,
                    &s.label,
                    s.markers,
                    2,
                    (k, PALETTE[k % PALETTE.len()]),
                )?;
                if !s.markers {
                    k += 1;
                }
            }
            if below == 0 {
                draw_legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
            } else {
                legend_below(&legend, panel)?;
            }
        }
        Ok(())
    }
}

/// The two models of Blinn's Figures 5 and 6: Phong in Blinn's form, (N·H)^c1 with his
/// "typical" c1 = 50, and Torrance–Sparrow (D3) with the same half-angle β (c3 = c3(β)) on
/// Blinn's magnesium oxide optics (n 1.8, ps .667, pd .333). Phong's ps is chosen so the two
/// specular peaks match at normal incidence (ps_phong = ps F0).
pub fn blinn_figure_models() -> (Model, Model) {
    let c1 = 50.0;
    // β with cos^c1 β = ½.
    let beta = (0.5f64).powf(1.0 / c1).acos();
    let c3 = Distribution::D3.param_from_beta(beta);
    let ts = Model::new(
        ModelKind::TorranceSparrow,
        Distribution::D3,
        &[1.8, c3, 0.667, 0.333],
    )
    .expect("valid constants");
    (crate::model::equal_beta_phong(&ts), ts)
}

/// Blinn's Figure 5 (θi = 30°) or 6 (θi = 70°) as a chart: Phong and Torrance–Sparrow side by side.
pub fn blinn_figure(theta_i_deg: f64, number: u32) -> LobeChart {
    let (phong, ts) = blinn_figure_models();
    let panel = |title: String, m: &Model| LobePanel {
        title,
        theta_i_deg,
        series: vec![LobeSeries {
            label: format!("{m}"),
            points: lobe_curve(m, theta_i_deg, LobeQuantity::Intensity),
            markers: false,
        }],
    };
    LobeChart {
        title: format!(
            "Figure {number}: Phong and Torrance–Sparrow reflection distributions, incident light at {theta_i_deg}° (equal β)"
        ),
        // Each panel is titled with the label its legend gives the model.
        panels: vec![
            panel(
                format!(
                    "Phong model in Blinn's form (N·H)^c1: {}",
                    phong.kind.label(phong.dist)
                ),
                &phong,
            ),
            panel(
                format!("Torrance–Sparrow model: {}", ts.kind.label(ts.dist)),
                &ts,
            ),
        ],
        quantity: LobeQuantity::Intensity,
        log: false,
        shared_scale: true,
    }
}

/// A lobe chart with one panel per incidence angle: each model's curve, and, when data are
/// given, the in-plane samples of channel `c` within `tol` of the panel's plane (the legend
/// states the tolerance and the count).
pub fn lobe_chart(
    title: &str,
    models: &[(String, Model)],
    data: Option<(&Dataset, usize)>,
    thetas: &[f64],
    q: LobeQuantity,
    log: bool,
    tol: InPlane,
) -> LobeChart {
    let panels = thetas
        .iter()
        .map(|&t| {
            let mut series: Vec<LobeSeries> = models
                .iter()
                .map(|(label, m)| LobeSeries {
                    label: label.clone(),
                    points: lobe_curve(m, t, q),
                    markers: false,
                })
                .collect();
            if let Some((ds, c)) = data {
                let points = in_plane_samples(ds, c, t, tol, q);
                series.push(LobeSeries {
                    label: if points.is_empty() {
                        format!("no measured sample within {}", tol.describe())
                    } else {
                        format!("measured ({}), {}", points.len(), tol.describe())
                    },
                    points,
                    markers: true,
                });
            }
            LobePanel {
                title: format!("θi = {t}°"),
                theta_i_deg: t,
                series,
            }
        })
        .collect();
    LobeChart {
        title: title.to_string(),
        panels,
        quantity: q,
        log,
        shared_scale: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lobe_curve_of_lambert_is_a_semicircle_of_radius_pd_cos() {
        let m = Model::new(ModelKind::Lambert, Distribution::D3, &[0.6]).unwrap();
        for (_, v) in lobe_curve(&m, 30.0, LobeQuantity::Intensity) {
            assert!((v - 0.6 * 30f64.to_radians().cos()).abs() < 1e-12);
        }
    }
}

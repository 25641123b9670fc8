//! Charts: polar reflection distributions in the plane of incidence (Blinn 1977, Figures 5
//! and 6), residual, slice and albedo plots, and the study charts. Each chart is computed as
//! plain data first (tested on its own), then drawn with plotters to SVG and PNG with the
//! embedded DejaVu Sans font, so the same input gives the same bytes on every machine.

use crate::data::Dataset;
use crate::model::{Distribution, Geometry, Model, ModelKind};
use crate::output::write_bytes_atomic;
use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

/// Register the embedded font with plotters (once per process).
pub fn register_font_once() {
    register_font();
}

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font shipped with the crate.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A chart that can draw itself on any plotters backend.
pub trait Chart {
    /// Pixel size (width, height).
    fn size(&self) -> (u32, u32);
    /// Draw on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>;
}

/// A drawing error as an `anyhow::Error` (for `map_err` in every chart's `draw`).
pub(crate) fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("drawing failed: {e:?}")
}

/// Render `chart` to `base.svg` and `base.png` (written atomically); returns both paths.
pub fn save(chart: &impl Chart, base: &Path) -> Result<(PathBuf, PathBuf)> {
    register_font();
    let (w, h) = chart.size();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        chart.draw(&root)?;
        root.present().map_err(err)?;
    }
    let mut px = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut px, (w, h)).into_drawing_area();
        chart.draw(&root)?;
        root.present().map_err(err)?;
    }
    let svg = svg_text_to_paths(&svg);
    let svg_path = base.with_extension("svg");
    let png_path = base.with_extension("png");
    write_bytes_atomic(&svg_path, svg.as_bytes())?;
    write_bytes_atomic(&png_path, &encode_png(w, h, &px)?)?;
    Ok((svg_path, png_path))
}

/// Replace every `<text>` element plotters writes with a `<path>` of the embedded font's
/// glyph outlines, so an SVG looks the same on every machine without the font installed.
/// Handles what plotters emits: `x`, `y`, `dy` in em or ex, `text-anchor`, `font-size`,
/// `fill`, `opacity` and `transform`.
pub fn svg_text_to_paths(svg: &str) -> String {
    use ab_glyph::{Font, FontRef, OutlineCurve};
    let Ok(font) = FontRef::try_from_slice(FONT) else {
        return svg.to_string();
    };
    let upem = font.units_per_em().unwrap_or(2048.0);
    let attr = |tag: &str, name: &str| -> Option<String> {
        let key = format!(" {name}=\"");
        let i = tag.find(&key)? + key.len();
        Some(tag[i..i + tag[i..].find('"')?].to_string())
    };
    let mut out = String::with_capacity(svg.len());
    let mut rest = svg;
    while let Some(i) = rest.find("<text") {
        out.push_str(&rest[..i]);
        let Some(open_end) = rest[i..].find('>').map(|e| i + e + 1) else {
            break;
        };
        let Some(close) = rest[open_end..].find("</text>").map(|e| open_end + e) else {
            break;
        };
        let tag = &rest[i..open_end];
        let content = rest[open_end..close]
            .trim()
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&apos;", "'")
            .replace("&amp;", "&");
        rest = &rest[close + "</text>".len()..];
        let num = |n: &str, d: f32| {
            attr(tag, n)
                .and_then(|v| v.parse::<f32>().ok())
                .unwrap_or(d)
        };
        let size = num("font-size", 12.0);
        let k = size / upem;
        let dy = attr(tag, "dy").map_or(0.0, |v| {
            if let Some(e) = v.strip_suffix("em") {
                e.parse::<f32>().unwrap_or(0.0) * size
            } else if let Some(e) = v.strip_suffix("ex") {
                // DejaVu Sans' x-height is 0.545 em.
                e.parse::<f32>().unwrap_or(0.0) * 0.545 * size
            } else {
                v.parse().unwrap_or(0.0)
            }
        });
        let ids: Vec<_> = content.chars().map(|c| font.glyph_id(c)).collect();
        let mut advance = Vec::with_capacity(ids.len());
        let mut pen = 0.0;
        for (j, &id) in ids.iter().enumerate() {
            if j > 0 {
                pen += font.kern_unscaled(ids[j - 1], id);
            }
            advance.push(pen);
            pen += font.h_advance_unscaled(id);
        }
        let width = pen * k;
        let x0 = num("x", 0.0)
            - match attr(tag, "text-anchor").as_deref() {
                Some("middle") => width / 2.0,
                Some("end") => width,
                _ => 0.0,
            };
        let base = num("y", 0.0) + dy;
        let mut d = String::new();
        let pt = |p: ab_glyph::Point, ox: f32| (x0 + (ox + p.x) * k, base - p.y * k);
        let mut last = None;
        for (j, &id) in ids.iter().enumerate() {
            let Some(outline) = font.outline(id) else {
                continue;
            };
            let ox = advance[j];
            for c in &outline.curves {
                let (start, seg) = match c {
                    OutlineCurve::Line(a, b) => {
                        let (bx, by) = pt(*b, ox);
                        (*a, format!("L{bx:.2} {by:.2}"))
                    }
                    OutlineCurve::Quad(a, b, c) => {
                        let ((bx, by), (cx, cy)) = (pt(*b, ox), pt(*c, ox));
                        (*a, format!("Q{bx:.2} {by:.2} {cx:.2} {cy:.2}"))
                    }
                    OutlineCurve::Cubic(a, b, c, e) => {
                        let ((bx, by), (cx, cy), (ex, ey)) = (pt(*b, ox), pt(*c, ox), pt(*e, ox));
                        (
                            *a,
                            format!("C{bx:.2} {by:.2} {cx:.2} {cy:.2} {ex:.2} {ey:.2}"),
                        )
                    }
                };
                let s = pt(start, ox);
                if last != Some((j, start.x.to_bits(), start.y.to_bits())) {
                    d.push_str(&format!("M{:.2} {:.2}", s.0, s.1));
                }
                d.push_str(&seg);
                let end = match c {
                    OutlineCurve::Line(_, b) => *b,
                    OutlineCurve::Quad(_, _, c) => *c,
                    OutlineCurve::Cubic(_, _, _, e) => *e,
                };
                last = Some((j, end.x.to_bits(), end.y.to_bits()));
            }
        }
        let fill = attr(tag, "fill").unwrap_or_else(|| "#000000".into());
        let opacity = attr(tag, "opacity").unwrap_or_else(|| "1".into());
        let transform = attr(tag, "transform")
            .map(|t| format!(" transform=\"{t}\""))
            .unwrap_or_default();
        out.push_str(&format!(
            "<path d=\"{d}\" fill=\"{fill}\" opacity=\"{opacity}\"{transform}><title>{}</title></path>",
            content.replace('&', "&amp;").replace('<', "&lt;")
        ));
    }
    out.push_str(rest);
    out
}

/// An axis tick label: at most 6 significant digits, no trailing zeros, no "-0" (so the
/// ticks read 10, 20, 0.25 rather than 10.0, 20.0, 0.250).
pub fn tick(v: f64) -> String {
    let s = crate::model::significant(v, 6);
    if s == "-0" { "0".into() } else { s }
}

/// A tick label on a logarithmic axis: the value where its mantissa is 1, 2 or 5 (plotters
/// puts a tick at every 1…9 × 10^k when an axis spans little more than a decade, and their
/// labels run into each other), else nothing.
pub fn log_tick(v: f64) -> String {
    if !(v > 0.0) {
        return String::new();
    }
    let m = v / 10f64.powf(v.log10().floor());
    if [1.0, 2.0, 5.0, 10.0]
        .iter()
        .any(|t| (m - t).abs() < 1e-6 * t)
    {
        crate::model::significant(v, 2)
    } else {
        String::new()
    }
}

/// Place a label of `w`×`h` pixels beside the point (px, py), inside `bounds` (left, top,
/// right, bottom: the plotting area) and overlapping no box in `placed`: the first free spot
/// of right, then left of the point, on its line, then one line up, one down, two up, …
/// (up to 12 lines away); where none is free, right of the point on its line. Records the box
/// and returns its top-left corner; a caller draws a leader line when the label left the
/// point's line ([`needs_leader`]).
pub fn place_label(
    placed: &mut Vec<(i32, i32, i32, i32)>,
    (px, py): (i32, i32),
    (w, h): (i32, i32),
    (bl, bt, br, bb): (i32, i32, i32, i32),
) -> (i32, i32) {
    let free = |l: i32, t: i32| {
        l >= bl
            && l + w <= br
            && t >= bt
            && t + h <= bb
            && !placed
                .iter()
                .any(|&(a, b, c, d)| l < c && l + w > a && t < d && t + h > b)
    };
    let base = py - h / 2;
    let spot = (0..25)
        .map(|k| if k % 2 == 1 { -(k + 1) / 2 } else { k / 2 })
        .flat_map(|line| [(px + 10, base + line * h), (px - 10 - w, base + line * h)])
        .find(|&(l, t)| free(l, t))
        .unwrap_or((
            (px + 10).min(br - w).max(bl),
            base.clamp(bt, (bb - h).max(bt)),
        ));
    placed.push((spot.0, spot.1, spot.0 + w, spot.1 + h));
    spot
}

/// Whether a label placed at `top` (height `h`) left the line of the point at `py`, so that
/// a leader line should join them.
pub fn needs_leader(py: i32, top: i32, h: i32) -> bool {
    (top + h / 2 - py).abs() > h / 2 + 1
}

/// PNG bytes of an 8-bit RGB buffer.
pub fn encode_png(w: u32, h: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| anyhow!("PNG encoding failed: {e}"))?;
    Ok(out)
}

type XyContext<'a, DB> = ChartContext<
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
fn draw_line<'a, 'b, DB: DrawingBackend + 'a>(
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
fn draw_series<'a, DB: DrawingBackend + 'a>(
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
fn draw_legend<'a, DB: DrawingBackend + 'a>(
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

const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 90, 181),
    RGBColor(220, 50, 32),
    RGBColor(0, 140, 70),
    RGBColor(150, 60, 170),
    RGBColor(230, 140, 0),
    RGBColor(90, 90, 90),
];

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

impl Chart for LobeChart {
    fn size(&self) -> (u32, u32) {
        (560 * self.panels.len().max(1) as u32, 440)
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
            draw_legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
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

/// Directional albedo ρ(θi) = ∫ f_r cosθo dω_o at θi in degrees
/// ([`crate::model::albedo::directional_albedo`]).
pub fn albedo(model: &Model, theta_i_deg: f64) -> f64 {
    crate::model::albedo::directional_albedo(model, theta_i_deg.to_radians())
}

/// Rings (equal projected solid angle) and relative-azimuth sectors (over the full circle,
/// each sample counted at ±Δφ) of the cells [`measured_albedo`] integrates over.
pub const ALBEDO_CELLS: (usize, usize) = (6, 16);

/// Largest relative difference between the two quadratures of [`measured_albedo`] (sectors
/// as they are, and turned by half a sector) for an estimate to be given.
pub const ALBEDO_AGREEMENT: f64 = 0.05;

/// Directional albedo estimated from the samples themselves, at each incidence angle the
/// sampling allows. The samples within ±2.5° of θi = 0°, 5°, …, 85° are sorted into cells of
/// equal projected solid angle over the outgoing hemisphere: 6 rings with sin²θo = k/6 × 16
/// sectors of relative azimuth, each sample counted at +Δφ and −Δφ (isotropy). Then
/// ρ(θi) ≈ (π / cells) Σ_cells f̄_cell, f̄_cell the mean over the cell's four sub-rings (equal
/// projected solid angle) of their samples' mean f_r, so that a sampling denser in part of a
/// ring (1° steps in θo, or uniform in solid angle) does not weigh that part more.
///
/// A value is given only where the sampling resolves the integrand: every cell holds two
/// samples or more, no sample outweighs all the others of its cell together, and the
/// quadrature with the sectors turned by half a sector agrees within [`ALBEDO_AGREEMENT`].
/// A narrow highlight caught by one column of a coarse grid (MERL's 15° azimuth steps) stands
/// in for far more than its area, and the turned sectors split it differently, so such a θi
/// gets none; nor does a file sampled in the plane of incidence alone. Returns (θi in
/// degrees, ρ).
pub fn measured_albedo(ds: &Dataset, c: usize) -> Vec<(f64, f64)> {
    let vals = ds.brdf_values(c);
    let mut out = Vec::new();
    for k in 0..18 {
        let centre = 5.0 * k as f64;
        // (sin²θo, Δφ in [0, π], f_r) of the samples at this θi.
        let samples: Vec<(f64, f64, f64)> = vals
            .iter()
            .enumerate()
            .filter_map(|(j, v)| {
                let [ti, pi, to, po] = ds.angles(j);
                if !v.is_finite() || (ti.to_degrees() - centre).abs() > 2.5 || to >= 0.5 * PI {
                    return None;
                }
                let dphi = (po - pi).rem_euclid(2.0 * PI);
                let dphi = if dphi > PI { 2.0 * PI - dphi } else { dphi };
                Some((to.sin().powi(2), dphi, *v))
            })
            .collect();
        if let (Some(a), Some(b)) = (
            cell_quadrature(&samples, 0.0),
            cell_quadrature(&samples, 0.5),
        ) && (a - b).abs() <= ALBEDO_AGREEMENT * a.abs()
        {
            out.push((centre, a));
        }
    }
    out
}

/// The cell quadrature of [`measured_albedo`] with the sectors turned by `shift` sectors;
/// `None` where a cell is not resolved.
fn cell_quadrature(samples: &[(f64, f64, f64)], shift: f64) -> Option<f64> {
    const SUB: usize = 4;
    let (rings, sectors) = ALBEDO_CELLS;
    let cells = rings * sectors;
    let mut sum = vec![0.0; cells * SUB];
    let mut count = vec![0usize; cells * SUB];
    let mut peak = vec![0.0f64; cells];
    let width = 2.0 * PI / sectors as f64;
    for &(u, dphi, v) in samples {
        let fine = ((u * (rings * SUB) as f64) as usize).min(rings * SUB - 1);
        let (ring, sub) = (fine / SUB, fine % SUB);
        // At Δφ = 0 or π the two are one direction: count it once.
        let both = [dphi, 2.0 * PI - dphi];
        let phis = if dphi == 0.0 || dphi == PI {
            &both[..1]
        } else {
            &both[..]
        };
        for &phi in phis {
            let sector = ((phi / width + shift).floor() as usize) % sectors;
            let cell = ring * sectors + sector;
            sum[cell * SUB + sub] += v;
            count[cell * SUB + sub] += 1;
            peak[cell] = peak[cell].max(v);
        }
    }
    let mut rho = 0.0;
    for cell in 0..cells {
        let subs = cell * SUB..(cell + 1) * SUB;
        let n: usize = count[subs.clone()].iter().sum();
        let raw: f64 = sum[subs.clone()].iter().sum();
        if n < 2 || 2.0 * peak[cell] > raw {
            return None;
        }
        let means: Vec<f64> = subs
            .filter(|&i| count[i] > 0)
            .map(|i| sum[i] / count[i] as f64)
            .collect();
        rho += means.iter().sum::<f64>() / means.len() as f64;
    }
    Some(PI / cells as f64 * rho)
}

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

fn range_of(vals: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
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

/// Albedo chart of a model: ρ(θi) for θi = 0…85°, with the energy limit ρ = 1 marked.
pub fn albedo_chart(
    label: &str,
    model: &Model,
    measured: &[(f64, f64)],
) -> (XyChart, Vec<(f64, f64)>) {
    let pts: Vec<(f64, f64)> = (0..=17)
        .map(|k| (5.0 * k as f64, albedo(model, 5.0 * k as f64)))
        .collect();
    let mut series = vec![LobeSeries {
        label: format!("{model}"),
        points: pts.clone(),
        markers: false,
    }];
    if !measured.is_empty() {
        series.push(LobeSeries {
            label: "estimated from the samples (cell quadrature)".into(),
            points: measured.to_vec(),
            markers: true,
        });
    }
    let chart = XyChart {
        title: format!("Directional albedo of {label}"),
        x_label: "incidence angle θi (degrees)".into(),
        y_label: "directional albedo ρ(θi) = ∫ f_r cosθo dω".into(),
        series,
        log_x: false,
        log_y: false,
        hline: None,
    };
    // The axis follows the curves; the energy limit is drawn only where it is near enough to
    // be read against them (a curve at 0.02–0.3 would otherwise lie on the bottom edge).
    let top = pts.iter().chain(measured).map(|p| p.1).fold(0.0, f64::max);
    let chart = if top > 0.7 {
        XyChart {
            hline: Some((1.0, "energy limit ρ = 1".into())),
            ..chart
        }
    } else {
        XyChart {
            title: format!("{} (energy limit ρ = 1 far above)", chart.title),
            ..chart
        }
    };
    (chart, pts)
}

/// Residuals of a model on channel `c`: (θh, θd, θi in degrees, residual of the loss).
pub fn residual_points(ds: &Dataset, c: usize, model: &Model, log_loss: bool) -> Vec<[f64; 4]> {
    let vals = ds.brdf_values(c);
    (0..ds.len())
        .filter(|&k| vals[k].is_finite())
        .filter_map(|k| {
            let a = ds.angles(k);
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            if !g.visible() {
                return None;
            }
            let f = model.brdf(&g);
            let r = if log_loss {
                (g.nl * f).ln_1p() - (g.nl * vals[k]).ln_1p()
            } else {
                f - vals[k]
            };
            let hd = crate::data::merl::std_to_half_diff(a);
            Some([hd[0].to_degrees(), hd[2].to_degrees(), a[0].to_degrees(), r])
        })
        .collect()
}

/// Residual charts against θh, θd and θi.
pub fn residual_charts(label: &str, pts: &[[f64; 4]]) -> Vec<(String, XyChart)> {
    ["θh", "θd", "θi"]
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let file = ["residual-theta-h", "residual-theta-d", "residual-theta-i"][k];
            let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p[k], p[3])).collect();
            let q = binned_quantiles(&xy, 30);
            let line = |label: &str, f: fn(&[f64; 4]) -> f64| LobeSeries {
                label: label.into(),
                points: q.iter().map(|b| (b[0], f(b))).collect(),
                markers: false,
            };
            (
                file.to_string(),
                XyChart {
                    title: format!("Residuals of {label} against {name}"),
                    x_label: format!("{name} (degrees)"),
                    y_label: "residual r (loss units)".into(),
                    series: vec![
                        LobeSeries {
                            label: format!("samples ({})", xy.len()),
                            points: xy,
                            markers: true,
                        },
                        line("binned median", |b| b[2]),
                        line("10 % and 90 % of each bin", |b| b[1]),
                        line("", |b| b[3]),
                    ],
                    log_x: false,
                    log_y: false,
                    hline: Some((0.0, "r = 0".into())),
                },
            )
        })
        .collect()
}

/// Quantiles of y in `bins` equal-width bins of x: (bin centre, 10 %, 50 %, 90 %) for each bin
/// holding at least 5 finite points (nearest-rank quantiles).
pub fn binned_quantiles(xy: &[(f64, f64)], bins: usize) -> Vec<[f64; 4]> {
    let finite: Vec<(f64, f64)> = xy
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    let (lo, hi) = finite
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    if finite.is_empty() || bins == 0 || hi <= lo {
        return Vec::new();
    }
    let width = (hi - lo) / bins as f64;
    let mut groups = vec![Vec::new(); bins];
    for (x, y) in finite {
        groups[(((x - lo) / width) as usize).min(bins - 1)].push(y);
    }
    let q = |v: &[f64], p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    groups
        .iter_mut()
        .enumerate()
        .filter(|(_, g)| g.len() >= 5)
        .map(|(i, g)| {
            g.sort_by(f64::total_cmp);
            [
                lo + (i as f64 + 0.5) * width,
                q(g, 0.1),
                q(g, 0.5),
                q(g, 0.9),
            ]
        })
        .collect()
}

/// θh × θd image (BRDF Explorer's image slice) of data and model side by side: `n`×`n` bins
/// over [0°, 90°)², each bin the mean log10 f_r of its samples (data) or the model at the bin
/// centre with φd = 90° (fit); NaN where a bin has no sample.
pub fn slice_grids(ds: &Dataset, c: usize, model: &Model, n: usize) -> (Vec<f64>, Vec<f64>) {
    let vals = ds.brdf_values(c);
    let mut sum = vec![0.0; n * n];
    let mut cnt = vec![0usize; n * n];
    for k in 0..ds.len() {
        if !(vals[k] > 0.0) {
            continue;
        }
        let hd = crate::data::merl::std_to_half_diff(ds.angles(k));
        let i = ((hd[0] / (0.5 * PI)) * n as f64) as usize;
        let j = ((hd[2] / (0.5 * PI)) * n as f64) as usize;
        if i < n && j < n {
            sum[i * n + j] += vals[k].log10();
            cnt[i * n + j] += 1;
        }
    }
    let data: Vec<f64> = sum
        .iter()
        .zip(&cnt)
        .map(|(s, c)| if *c > 0 { s / *c as f64 } else { f64::NAN })
        .collect();
    let fit: Vec<f64> = (0..n * n)
        .map(|ij| {
            let (i, j) = (ij / n, ij % n);
            let th = (i as f64 + 0.5) / n as f64 * 0.5 * PI;
            let td = (j as f64 + 0.5) / n as f64 * 0.5 * PI;
            let a = crate::data::merl::half_diff_to_std(th, 0.0, td, 0.5 * PI);
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            let f = model.brdf(&g);
            if g.visible() && f > 0.0 {
                f.log10()
            } else {
                f64::NAN
            }
        })
        .collect();
    (data, fit)
}

/// Two images side by side with a shared colour scale.
#[derive(Clone, Debug)]
pub struct SliceChart {
    /// Title.
    pub title: String,
    /// Grid size.
    pub n: usize,
    /// Left image (data) and right image (fit), row-major, indexed `[θh][θd]`.
    pub images: [Vec<f64>; 2],
}

fn colormap(t: f64) -> RGBColor {
    // A perceptually ordered dark-blue → yellow ramp (piecewise linear, viridis-like).
    const STOPS: [(f64, [f64; 3]); 5] = [
        (0.0, [68.0, 1.0, 84.0]),
        (0.25, [59.0, 82.0, 139.0]),
        (0.5, [33.0, 145.0, 140.0]),
        (0.75, [94.0, 201.0, 98.0]),
        (1.0, [253.0, 231.0, 37.0]),
    ];
    let t = t.clamp(0.0, 1.0);
    let k = STOPS.iter().position(|s| s.0 >= t).unwrap_or(4).max(1);
    let (a, b) = (STOPS[k - 1], STOPS[k]);
    let u = (t - a.0) / (b.0 - a.0);
    let c = |i: usize| (a.1[i] + u * (b.1[i] - a.1[i])).round() as u8;
    RGBColor(c(0), c(1), c(2))
}

impl Chart for SliceChart {
    fn size(&self) -> (u32, u32) {
        (900, 470)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(&self.title, ("sans-serif", 18)).map_err(err)?;
        let (lo, hi) = range_of(self.images.iter().flatten().copied(), false);
        let areas = root.split_evenly((1, 2));
        for (k, area) in areas.iter().enumerate() {
            let mut chart = ChartBuilder::on(area)
                .caption(
                    if k == 0 {
                        "data: mean log₁₀ f_r per bin"
                    } else {
                        "fit: log₁₀ f_r at φd = 90°"
                    },
                    ("sans-serif", 14),
                )
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(44)
                .build_cartesian_2d(0f64..90f64, 0f64..90f64)
                .map_err(err)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc("θd (degrees)")
                .y_desc("θh (degrees)")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(err)?;
            let n = self.n;
            let step = 90.0 / n as f64;
            chart
                .draw_series((0..n * n).map(|ij| {
                    let (i, j) = (ij / n, ij % n);
                    let v = self.images[k][ij];
                    let color = if v.is_finite() {
                        colormap((v - lo) / (hi - lo).max(1e-12))
                    } else {
                        RGBColor(200, 200, 200)
                    };
                    Rectangle::new(
                        [
                            (j as f64 * step, i as f64 * step),
                            ((j + 1) as f64 * step, (i + 1) as f64 * step),
                        ],
                        color.filled(),
                    )
                }))
                .map_err(err)?;
        }
        root.draw(&Text::new(
            format!("colour: log₁₀ f_r from {lo:.2} (dark) to {hi:.2} (yellow); grey = no sample"),
            (20, 440),
            ("sans-serif", 12),
        ))
        .map_err(err)?;
        Ok(())
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

    #[test]
    fn lambert_albedo_is_pd() {
        for pd in [0.2, 0.5, 0.9] {
            let m = Model::new(ModelKind::Lambert, Distribution::D3, &[pd]).unwrap();
            for ti in [0.0, 30.0, 75.0] {
                assert!(
                    (albedo(&m, ti) - pd).abs() < 1e-3,
                    "pd {pd} θi {ti}: {}",
                    albedo(&m, ti)
                );
            }
        }
    }

    #[test]
    fn lobe_curve_of_lambert_is_a_semicircle_of_radius_pd_cos() {
        let m = Model::new(ModelKind::Lambert, Distribution::D3, &[0.6]).unwrap();
        for (_, v) in lobe_curve(&m, 30.0, LobeQuantity::Intensity) {
            assert!((v - 0.6 * 30f64.to_radians().cos()).abs() < 1e-12);
        }
    }

    #[test]
    fn colormap_ends() {
        assert_eq!(colormap(0.0), RGBColor(68, 1, 84));
        assert_eq!(colormap(1.0), RGBColor(253, 231, 37));
    }
}

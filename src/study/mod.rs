//! Studies: where each method is fast, accurate, or fails.
//!
//! - [`speed_accuracy`]: every method × model on one data set — fit time and work against final
//!   cost and, with a known truth, parameter error; the Pareto front of time against cost.
//! - [`stability`]: for each method, the share of seeded random starts that reach the global
//!   minimum, with and without the global initialisation, across noise levels and sampling
//!   patterns of synthetic data drawn from the data set's own Torrance–Sparrow fit (or its
//!   known truth).

use crate::data::Dataset;
use crate::fit::lsq::Method;
use crate::fit::{self, FitOptions};
use crate::model::{Distribution, Model, ModelKind};
use crate::plot::{LobeSeries, XyChart};
use crate::simulate::{Grid, simulate};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::fmt::Write;
use std::sync::atomic::AtomicUsize;

/// The model a synthetic file was made from, from its `truth:` comment (written by
/// `brdfit simulate`), if any.
pub fn parse_truth(ds: &Dataset) -> Option<Model> {
    let line = ds
        .meta
        .comments
        .iter()
        .find_map(|c| c.strip_prefix("truth:"))?;
    let mut words = line.split_whitespace();
    let kind = ModelKind::parse(words.next()?)?;
    let mut dist = Distribution::D3;
    let mut set = Vec::new();
    for w in words {
        if let Some(d) = w.strip_prefix('(').and_then(|d| d.strip_suffix(')')) {
            dist = Distribution::parse(d)?;
        } else if let Some((k, v)) = w.split_once('=') {
            set.push((k.to_string(), v.parse().ok()?));
        }
    }
    Model::from_named(kind, dist, &set).ok()
}

/// One row of the speed–accuracy table.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpeedRow {
    /// Method name ([`Method::name`], or scipy).
    pub method: String,
    /// Model label.
    pub model: String,
    /// Wall time of the fit (median of `repeats`).
    pub seconds: f64,
    /// Residual evaluations: evaluations × samples (deterministic work measure).
    pub work: f64,
    /// Final cost.
    pub cost: f64,
    /// Largest relative parameter error against the truth (same model only).
    pub param_error: Option<f64>,
    /// Why the solver stopped (its own words), so a stall or a step out of the bounds shows.
    #[serde(default)]
    pub termination: String,
}

/// The models of the speed–accuracy study: every model with one lobe and one shape parameter
/// (Lambert has nothing to converge to; Torrance–Sparrow with ABC and ggx-smith-2, the
/// two-shape models, are left out so the study compares the solvers on the problems it always
/// has).
pub fn study_models() -> Vec<(ModelKind, Distribution)> {
    crate::model::catalogue()
        .into_iter()
        .filter(|(k, d)| {
            k.params(*d)
                .iter()
                .filter(|s| s.role == crate::model::Role::Shape)
                .count()
                == 1
        })
        .collect()
}

/// Run every method × model on channel 0 of `ds` (median time of `repeats` runs).
pub fn speed_accuracy(ds: &Dataset, truth: Option<&Model>, repeats: usize) -> Vec<SpeedRow> {
    speed_accuracy_with_progress(ds, truth, repeats, &|_, _, _| {})
}

/// [`speed_accuracy`], calling `progress(done, total, what)` before each method × model
/// (`what` names them), every [`fit::TICK`] while it runs (`what` then counts its passes over the
/// data so far: on a full MERL table one argmin Nelder–Mead run takes 15 s) and once at the
/// end (`done == total`).
pub fn speed_accuracy_with_progress(
    ds: &Dataset,
    truth: Option<&Model>,
    repeats: usize,
    progress: &(dyn Fn(usize, usize, &str) + Sync),
) -> Vec<SpeedRow> {
    // A solver that runs once shows its budget on the solvers' comparison model,
    // Torrance–Sparrow (D3), alone: it is no model's best.
    let runs: Vec<(Method, (ModelKind, Distribution))> = Method::ALL
        .into_iter()
        .flat_map(|method| study_models().into_iter().map(move |m| (method, m)))
        .filter(|&(method, m)| {
            !runs_once(method) || m == (ModelKind::TorranceSparrow, Distribution::D3)
        })
        .collect();
    let mut rows = Vec::new();
    for (i, &(method, (kind, dist))) in runs.iter().enumerate() {
        let what = format!("{} on {}", method.name(), kind.label(dist));
        progress(i, runs.len(), &what);
        let watch = std::sync::Arc::new(AtomicUsize::new(0));
        let mut o = FitOptions::new(kind);
        o.watch = Some(watch.clone());
        o.dist = dist;
        o.method = method;
        o.profile = false;
        // A swarm runs once, from the start: the grid's candidates would each cost it its
        // whole budget again.
        o.local_only = runs_once(method);
        if runs_once(method) {
            o.limits.max_eval = ONCE_EVALUATIONS;
        }
        let mut times = Vec::new();
        let mut last = None;
        let tick = |k: usize| progress(i, runs.len(), &format!("{what}: {k} evaluations"));
        fit::ticking(&watch, &tick, || {
            for _ in 0..repeats.max(1) {
                match fit::fit(ds, &o) {
                    Ok(mut f) => {
                        let f = f.remove(0);
                        times.push(f.seconds);
                        last = Some(f);
                    }
                    Err(_) => break,
                }
            }
        });
        let Some(f) = last else { continue };
        times.sort_by(f64::total_cmp);
        let param_error = truth.filter(|t| t.kind == kind && t.dist == dist).map(|t| {
            let m = f.model_for(0);
            t.params()
                .iter()
                .zip(m.params())
                .map(|(a, b)| ((a - b) / a).abs())
                .fold(0.0, f64::max)
        });
        rows.push(SpeedRow {
            method: method.name().into(),
            model: f.label(),
            seconds: times[times.len() / 2],
            work: (f.evaluations * f.samples_used) as f64,
            cost: f.cost,
            param_error,
            termination: f.termination.clone(),
        });
    }
    progress(runs.len(), runs.len(), "done");
    rows
}

/// Solvers that cannot converge within their evaluation budget (argmin's particle swarm:
/// 40 particles spend it long before the swarm contracts, "evaluation limit reached" on every
/// file). The studies run them once from the start (the swarm explores its box itself) instead
/// of once per candidate of the global initialisation, on Torrance–Sparrow (D3) only with
/// [`ONCE_EVALUATIONS`], and the stability study gives them [`ONCE_STARTS`] starts: their
/// budget shows they stop short either way, at a fraction of the cost.
pub fn runs_once(method: Method) -> bool {
    method == Method::ArgminPso
}

/// The evaluation budget of a [`runs_once`] solver in the speed–accuracy study (25 rounds of
/// argmin's 40-particle swarm): enough to show that it stops above the minimum the others
/// reach.
pub const ONCE_EVALUATIONS: usize = 1000;

/// Random starts per configuration for a [`runs_once`] solver in the stability study.
pub const ONCE_STARTS: usize = 1;

/// Indices of the rows on the Pareto front of (x, y): no other row is at least as good in
/// both and better in one. Values of y within 1e-6 relative count as equal (fits that end at
/// the same minimum differ in the last digits), so the faster of two such points dominates.
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let no_worse = |a: f64, b: f64| a <= b + 1e-6 * b.abs();
    let better = |a: f64, b: f64| a < b - 1e-6 * b.abs();
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| {
            let p = points[i];
            !points.iter().enumerate().any(|(j, q)| {
                j != i && q.0 <= p.0 && no_worse(q.1, p.1) && (q.0 < p.0 || better(q.1, p.1))
            })
        })
        .collect();
    idx.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0));
    idx
}

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
/// its yellow darkened to read on white; grey for a peer outside [`Method::ALL`]).
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
        let colour = method_colour;
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
        }
        for (panel, area) in self.panels.iter().zip(&areas) {
            let pts = &panel.points;
            if pts.is_empty() {
                continue;
            }
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
            let mut placed = Vec::new();
            for p in pts {
                let c = colour(&p.method);
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
            let (xr, yr) = chart.plotting_area().get_pixel_range();
            let bounds = (xr.start, yr.start, xr.end, yr.end);
            let base = area.get_base_pixel();
            // The left panel holds one model: name the method only.
            let one_model = pts.iter().all(|p| p.model == pts[0].model);
            for p in pts {
                let c = colour(&p.method);
                let label = if one_model {
                    p.method.clone()
                } else {
                    format!("{} ({})", p.model, p.method)
                };
                let (px, py) = chart.backend_coord(&(p.seconds, p.excess));
                let h = 15;
                let (lx, ly) = crate::plot::place_label(
                    &mut placed,
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
        }
        Ok(())
    }
}

/// Markdown and CSV tables of the speed–accuracy study; times only when `with_times`.
pub fn speed_tables(rows: &[SpeedRow], with_times: bool) -> (String, String) {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "| method | model |{} work (evaluations × samples) | cost | max rel. parameter error | stopped because |",
        if with_times { " time (s) |" } else { "" }
    );
    let _ = writeln!(
        md,
        "|---|---|{}---:|---:|---:|---|",
        if with_times { "---:|" } else { "" }
    );
    let mut csv = csv::Writer::from_writer(Vec::new());
    let mut head = vec!["method", "model"];
    if with_times {
        head.push("seconds");
    }
    head.extend(["work", "cost", "param_error", "termination"]);
    let _ = csv.write_record(&head);
    for r in rows {
        let pe = r.param_error.map_or("".to_string(), |e| format!("{e:.3e}"));
        let t = if with_times {
            format!(" {:.5} |", r.seconds)
        } else {
            String::new()
        };
        let _ = writeln!(
            md,
            "| {} | {} |{t} {:.0} | {:.6e} | {} | {} |",
            r.method,
            r.model,
            r.work,
            r.cost,
            pe,
            r.termination.replace('|', "/")
        );
        let mut rec = vec![r.method.clone(), r.model.clone()];
        if with_times {
            rec.push(r.seconds.to_string());
        }
        rec.extend([
            r.work.to_string(),
            r.cost.to_string(),
            pe,
            r.termination.clone(),
        ]);
        let _ = csv.write_record(&rec);
    }
    let csv = csv
        .into_inner()
        .map(|b| String::from_utf8_lossy(&b).into_owned())
        .unwrap_or_default();
    (md, csv)
}

/// A sampling pattern of the stability study.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Pattern {
    /// Light and eye over the whole hemisphere.
    Hemisphere,
    /// The plane of incidence only, θi = 10…80°.
    Plane,
    /// θi, θo ≤ 45° only.
    Near,
    /// θi, θo ≥ 70° only (grazing).
    Grazing,
}

impl Pattern {
    /// All patterns.
    pub const ALL: [Pattern; 4] = [
        Pattern::Hemisphere,
        Pattern::Plane,
        Pattern::Near,
        Pattern::Grazing,
    ];

    /// Name.
    pub fn name(self) -> &'static str {
        match self {
            Pattern::Hemisphere => "hemisphere",
            Pattern::Plane => "plane of incidence",
            Pattern::Near => "θ ≤ 45°",
            Pattern::Grazing => "grazing θ ≥ 70°",
        }
    }

    /// About `n` sample directions of the pattern (seeded).
    pub fn directions(self, n: usize, seed: u64) -> Vec<[f64; 4]> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut draw = |lo: f64, hi: f64| -> Vec<[f64; 4]> {
            (0..n)
                .map(|_| {
                    let ci: f64 = rng.random_range(hi.to_radians().cos()..=lo.to_radians().cos());
                    let co: f64 = rng.random_range(hi.to_radians().cos()..=lo.to_radians().cos());
                    [
                        ci.acos(),
                        0.0,
                        co.acos(),
                        rng.random_range(0.0..std::f64::consts::TAU),
                    ]
                })
                .collect()
        };
        match self {
            Pattern::Hemisphere => draw(0.0, 88.0),
            Pattern::Near => draw(0.0, 45.0),
            Pattern::Grazing => draw(70.0, 88.0),
            Pattern::Plane => {
                Grid::Plane((1..=8).map(|k| 10.0 * k as f64).collect()).directions(seed)
            }
        }
    }
}

/// One cell of the stability table.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StabilityRow {
    /// Relative noise σ.
    pub noise: f64,
    /// Sampling pattern.
    pub pattern: Pattern,
    /// Method.
    pub method: Method,
    /// Global initialisation on.
    pub global: bool,
    /// Starts that reached the global minimum.
    pub hits: usize,
    /// Starts run.
    pub starts: usize,
    /// Starts that ended in an error or a non-finite cost.
    pub failures: usize,
    /// Starts that converged (a tolerance test stopped them) at a higher cost: a wrong basin.
    pub wrong_basin: usize,
    /// Starts stopped by an iteration, evaluation or damping limit at a higher cost.
    pub stalled: usize,
    /// Starts that ended on a bound of the admissible box at a higher cost.
    pub at_bound: usize,
}

/// One column of a configuration: method, global initialisation, and each start's final
/// cost with how it ended.
type Run = (Method, bool, Vec<(f64, Outcome)>);

/// How one start of the stability study ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    Reached,
    WrongBasin,
    Stalled,
    AtBound,
    NonFinite,
}

/// Run the stability study around `reference`: for each noise level and pattern, about
/// `samples` synthetic samples, then `starts` seeded random starts per method with and without the global
/// initialisation. The global minimum of a configuration is the lowest cost any run found;
/// a run reaches it when its cost is within 1e-6 relative (Nelder–Mead's own tolerance) or,
/// for noise-free data whose minimum is 0, within 1e-12 per sample.
pub fn stability(reference: &Model, starts: usize, samples: usize, seed: u64) -> Vec<StabilityRow> {
    stability_with_progress(reference, starts, samples, seed, &|| {})
}

/// The noise levels of the stability study.
const STABILITY_NOISES: [f64; 4] = [0.0, 0.01, 0.05, 0.20];

/// The configurations of the stability study: each noise level × each sampling pattern.
pub const STABILITY_CONFIGURATIONS: usize = STABILITY_NOISES.len() * Pattern::ALL.len();

/// [`stability`], calling `progress` after each of the [`STABILITY_CONFIGURATIONS`]
/// configurations.
///
/// A fit with the global initialisation refines the grid's candidates and the start and keeps
/// the lowest cost (the grid's on a tie: its candidates come first). The candidates do not
/// depend on the start, so on at most [`fit::problem::SUBSAMPLE_ROWS`] samples (no subsample
/// in between) the grid's best is fitted once per configuration and method, and each start's
/// global end is the better of it and that start's local end: the same table for a fifth of
/// the fits (with 16 starts).
pub fn stability_with_progress(
    reference: &Model,
    starts: usize,
    samples: usize,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Vec<StabilityRow> {
    stability_runs(reference, starts, samples, seed, progress, true)
}

/// [`stability_with_progress`]; `share` false fits every global start on its own (to check
/// that sharing the grid's fit changes nothing).
fn stability_runs(
    reference: &Model,
    starts: usize,
    samples: usize,
    seed: u64,
    progress: &(dyn Fn() + Sync),
    share: bool,
) -> Vec<StabilityRow> {
    let noises = STABILITY_NOISES;
    let configs: Vec<(f64, Pattern)> = noises
        .iter()
        .flat_map(|&n| Pattern::ALL.iter().map(move |&p| (n, p)))
        .collect();
    configs
        .par_iter()
        .enumerate()
        .flat_map(|(ci, &(noise, pattern))| {
            let dirs = pattern.directions(samples.max(10), seed + ci as u64);
            let ds = simulate(reference, &dirs, noise, seed + 100 + ci as u64);
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 1000 + ci as u64);
            // Random starts from the model's declared ranges (any model, not only
            // Torrance–Sparrow).
            let specs = reference.specs();
            let start_points: Vec<Vec<(String, f64)>> = (0..starts)
                .map(|_| {
                    specs
                        .iter()
                        .map(|s| (s.name.to_string(), s.random_value(&mut rng)))
                        .collect()
                })
                .collect();
            let mut runs: Vec<Run> = Vec::new();
            for method in Method::ALL {
                let starts = if runs_once(method) {
                    starts.min(ONCE_STARTS)
                } else {
                    starts
                };
                let fit_one = |global: bool, start: Option<&Vec<(String, f64)>>| {
                    let mut o = FitOptions::new(reference.kind);
                    o.dist = reference.dist;
                    o.method = method;
                    o.local_only = !global;
                    o.start = start.cloned().unwrap_or_default();
                    o.profile = false;
                    match fit::fit(&ds, &o) {
                        Ok(f) if f[0].cost.is_finite() => {
                            let f = &f[0];
                            let how = if !f.at_bound.is_empty()
                                || f.termination.contains("left the bounds")
                            {
                                Outcome::AtBound
                            } else if f.termination.contains("limit") {
                                Outcome::Stalled
                            } else {
                                Outcome::WrongBasin
                            };
                            (f.cost, how)
                        }
                        _ => (f64::INFINITY, Outcome::NonFinite),
                    }
                };
                let local: Vec<(f64, Outcome)> = start_points[..starts]
                    .iter()
                    .map(|s| fit_one(false, Some(s)))
                    .collect();
                let global: Vec<(f64, Outcome)> =
                    if share && ds.len() <= fit::problem::SUBSAMPLE_ROWS {
                        let grid = fit_one(true, None);
                        local
                            .iter()
                            .map(|l| if l.0 < grid.0 { *l } else { grid })
                            .collect()
                    } else {
                        start_points[..starts]
                            .iter()
                            .map(|s| fit_one(true, Some(s)))
                            .collect()
                    };
                runs.push((method, true, global));
                runs.push((method, false, local));
            }
            let best = runs
                .iter()
                .flat_map(|r| r.2.iter().map(|e| e.0))
                .fold(f64::INFINITY, f64::min);
            progress();
            // Within 1e-6 relative, or (noise-free data, cost ≈ 0) within an absolute 1e-12
            // per sample of the best.
            let tol = 1e-6 * best.abs() + 1e-12 * ds.len() as f64;
            runs.into_iter()
                .map(|(method, global, ends)| {
                    let outcome = |e: &(f64, Outcome)| {
                        if e.1 != Outcome::NonFinite && e.0 - best <= tol {
                            Outcome::Reached
                        } else {
                            e.1
                        }
                    };
                    let count = |o: Outcome| ends.iter().filter(|e| outcome(e) == o).count();
                    StabilityRow {
                        noise,
                        pattern,
                        method,
                        global,
                        hits: count(Outcome::Reached),
                        starts: ends.len(),
                        failures: count(Outcome::NonFinite),
                        wrong_basin: count(Outcome::WrongBasin),
                        stalled: count(Outcome::Stalled),
                        at_bound: count(Outcome::AtBound),
                    }
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The stability heatmap: one row per configuration (noise × sampling pattern), one column
/// per method ([`Method::ALL`]), in two panels: with the global initialisation, and from the
/// random start alone. Each cell is coloured by the share of starts reaching the global
/// minimum and labelled `hits/starts` with the failures by kind (b wrong basin, s stalled,
/// ⊥ at or out of a bound, ∞ non-finite).
#[derive(Clone, Debug)]
pub struct StabilityHeatmap {
    /// Title.
    pub title: String,
    /// Row labels, top to bottom.
    pub rows: Vec<String>,
    /// The methods of the columns, left to right.
    pub cols: Vec<Method>,
    /// Panels, top to bottom: (title, global initialisation on, cells row-major).
    pub panels: Vec<(String, bool, Vec<HeatCell>)>,
}

/// One heatmap cell: hits, starts and its label.
pub type HeatCell = (usize, usize, String);

/// The configurations of the study's rows, in their first-seen order.
fn configurations(rows: &[StabilityRow]) -> Vec<(f64, Pattern)> {
    let mut configs: Vec<(f64, Pattern)> = Vec::new();
    for r in rows {
        if !configs.contains(&(r.noise, r.pattern)) {
            configs.push((r.noise, r.pattern));
        }
    }
    configs
}

/// The row of one configuration, method and initialisation, if the study ran it.
fn stability_row(
    rows: &[StabilityRow],
    (noise, pattern): (f64, Pattern),
    method: Method,
    global: bool,
) -> Option<&StabilityRow> {
    rows.iter().find(|r| {
        r.noise == noise && r.pattern == pattern && r.method == method && r.global == global
    })
}

/// [`StabilityHeatmap`] of the study's rows.
pub fn stability_chart(title: &str, rows: &[StabilityRow]) -> StabilityHeatmap {
    let configs = configurations(rows);
    let panel = |global: bool| {
        let mut cells = Vec::new();
        for &config in &configs {
            for m in Method::ALL {
                cells.push(stability_row(rows, config, m, global).map_or(
                    (0, 0, "–".into()),
                    |r| {
                        let mut why = Vec::new();
                        for (n, mark) in [
                            (r.wrong_basin, "b"),
                            (r.stalled, "s"),
                            (r.at_bound, "⊥"),
                            (r.failures, "∞"),
                        ] {
                            if n > 0 {
                                why.push(format!("{n}{mark}"));
                            }
                        }
                        (
                            r.hits,
                            r.starts,
                            format!("{}/{} {}", r.hits, r.starts, why.join(" ")),
                        )
                    },
                ));
            }
        }
        cells
    };
    StabilityHeatmap {
        title: title.to_string(),
        rows: configs
            .iter()
            .enumerate()
            .map(|(k, (n, p))| format!("{}. {:.0} % noise, {}", k + 1, n * 100.0, p.name()))
            .collect(),
        cols: Method::ALL.to_vec(),
        panels: vec![
            (
                "with the global initialisation (grid, then the local method)".into(),
                true,
                panel(true),
            ),
            ("from the random start alone".into(), false, panel(false)),
        ],
    }
}

/// Geometry of the heatmap: left margin, top of the first panel, cell width and height, and
/// the height of a panel's heading.
const HEAT: (i32, i32, i32, i32, i32) = (240, 60, 118, 26, 74);

impl crate::plot::Chart for StabilityHeatmap {
    fn size(&self) -> (u32, u32) {
        let (left, top, cw, ch, head) = HEAT;
        let panel = head + ch * self.rows.len() as i32;
        (
            (left + cw * self.cols.len() as i32 + 12) as u32,
            (top + panel * self.panels.len() as i32 + 8) as u32,
        )
    }

    fn draw<DB: plotters::prelude::DrawingBackend>(
        &self,
        root: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    ) -> anyhow::Result<()> {
        use plotters::prelude::*;
        root.fill(&WHITE).map_err(crate::plot::err)?;
        let (left, top, cw, ch, head) = HEAT;
        let font = |size: f64| ("sans-serif", size).into_font();
        let text = |s: &str, at: (i32, i32), size: f64| {
            root.draw(&Text::new(s.to_string(), at, font(size)))
                .map_err(crate::plot::err)
        };
        text(&self.title, (12, 10), 18.0)?;
        text(
            "cell: starts reaching the global minimum / starts; failures: b wrong basin, s stalled, ⊥ at or out of a bound, ∞ non-finite",
            (12, 36),
            12.0,
        )?;
        for (p, (title, _, cells)) in self.panels.iter().enumerate() {
            let y0 = top + p as i32 * (head + ch * self.rows.len() as i32);
            text(title, (12, y0 + 14), 15.0)?;
            // Two-line column heads: whose solver, then which.
            for (c, m) in self.cols.iter().enumerate() {
                let (who, what) = match m.name().strip_prefix("argmin-") {
                    Some(rest) => ("argmin", rest),
                    None => ("brdfit", m.name()),
                };
                let x = left + c as i32 * cw + 6;
                text(who, (x, y0 + 38), 12.0)?;
                text(what, (x, y0 + 53), 13.0)?;
            }
            for (r, label) in self.rows.iter().enumerate() {
                let y = y0 + head + r as i32 * ch;
                text(label, (12, y + 6), 13.0)?;
                for c in 0..self.cols.len() {
                    let (hits, starts, label) = &cells[r * self.cols.len() + c];
                    let share = if *starts > 0 {
                        *hits as f64 / *starts as f64
                    } else {
                        0.0
                    };
                    // Red (none) through yellow to green (all).
                    let colour = RGBColor(
                        (255.0 * (1.0 - share).clamp(0.0, 1.0).sqrt()) as u8,
                        (200.0 * share.sqrt()) as u8 + 40,
                        90,
                    );
                    let x = left + c as i32 * cw;
                    root.draw(&Rectangle::new(
                        [(x, y), (x + cw - 2, y + ch - 2)],
                        colour.mix(0.55).filled(),
                    ))
                    .map_err(crate::plot::err)?;
                    text(label, (x + 5, y + 6), 13.0)?;
                }
            }
        }
        Ok(())
    }
}

/// What a cell of the Markdown stability table holds.
pub const STABILITY_CELLS: &str = "Each cell: starts reaching the global minimum with the global initialisation · from the random start alone. argmin's particle swarm, which spends its evaluation budget before it converges, runs one start per configuration.";

/// Markdown and CSV tables of the stability study: one Markdown row per configuration, one
/// column per method, each cell the hits with the global initialisation · from the random
/// start alone; one CSV row per configuration, method and initialisation.
pub fn stability_tables(rows: &[StabilityRow]) -> (String, String) {
    let mut md = String::from("| # | noise | sampling |");
    for m in Method::ALL {
        let _ = write!(md, " {} |", m.name());
    }
    md.push_str("\n|---:|---:|---|");
    md.push_str(&"---:|".repeat(Method::ALL.len()));
    md.push('\n');
    let mut csv = String::from(
        "config,noise,pattern,method,global_init,hits,starts,failures,wrong_basin,stalled,at_bound\n",
    );
    let configs = configurations(rows);
    for r in rows {
        let k = configs
            .iter()
            .position(|c| *c == (r.noise, r.pattern))
            .unwrap_or(0)
            + 1;
        let _ = writeln!(
            csv,
            "{k},{},{},{},{},{},{},{},{},{},{}",
            r.noise,
            r.pattern.name(),
            r.method.name(),
            r.global,
            r.hits,
            r.starts,
            r.failures,
            r.wrong_basin,
            r.stalled,
            r.at_bound
        );
    }
    for (k, &config) in configs.iter().enumerate() {
        let cell = |g: bool, m: Method| {
            stability_row(rows, config, m, g)
                .map_or("–".into(), |r| format!("{}/{}", r.hits, r.starts))
        };
        let _ = write!(
            md,
            "| {} | {:.0} % | {} |",
            k + 1,
            config.0 * 100.0,
            config.1.name()
        );
        for m in Method::ALL {
            let _ = write!(md, " {} · {} |", cell(true, m), cell(false, m));
        }
        md.push('\n');
    }
    (md, csv)
}

/// Run the scipy peer script (`../shared/peers/scipy_fit.py` or any script with its
/// interface) on channel 0 of `ds` with Python `python`; `None` when it cannot run.
pub fn scipy_peer(ds: &Dataset, python: &str, script: &std::path::Path) -> Option<SpeedRow> {
    if !script.is_file() {
        return None;
    }
    let dir = std::env::temp_dir().join(format!("brdfit-peer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).ok()?;
    let csv = dir.join("data.csv");
    let one = ds
        .select(&crate::data::ChannelSelect::Index(0))
        .ok()?
        .into_brdf();
    let mut one = one;
    one.channels[0].name = String::new();
    crate::data::write_csv(&one, &csv).ok()?;
    let out = std::process::Command::new(python)
        .arg(script)
        .arg(&csv)
        .args(["--loss", "log", "--repeat", "3"])
        .output()
        .ok();
    let _ = std::fs::remove_dir_all(&dir);
    let out = out?;
    if !out.status.success() {
        return None;
    }
    let v: serde_json::Value = serde_json::from_slice(out.stdout.trim_ascii()).ok()?;
    Some(SpeedRow {
        method: "scipy".into(),
        model: "torrance-sparrow (d3)".into(),
        seconds: v["seconds"].as_f64()?,
        work: v["nfev"].as_f64()? * v["samples"].as_f64()?,
        cost: v["cost"].as_f64()?,
        param_error: None,
        termination: v["message"].as_str().unwrap_or("").to_string(),
    })
}

/// One row of the render study.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RenderRow {
    /// `uniform` or `adaptive`.
    pub mode: String,
    /// Samples per axis (uniform) or threshold (adaptive).
    pub setting: f64,
    /// Primary rays per pixel, averaged over the scenes.
    pub rays_per_pixel: f64,
    /// All rays (primary and shadow) per pixel, averaged over the scenes.
    pub all_rays_per_pixel: f64,
    /// Render time summed over the scenes.
    pub seconds: f64,
    /// RMSE on linear values against the 16×16-supersampled reference, averaged over scenes.
    pub rmse: f64,
}

/// Image error against time and rays per pixel, uniform against adaptive anti-aliasing, on the
/// Figure 7 scenes (Blinn's aluminium and MgO, front and edge lit, Torrance–Sparrow) at
/// `res`×`res`, against a 16×16-supersampled reference of each.
pub fn render_study(res: u32) -> Vec<RenderRow> {
    render_study_with_progress(res, &|_, _, _| {})
}

/// [`render_study`] with progress as [`render_study_scenes_with_progress`] gives it.
pub fn render_study_with_progress(
    res: u32,
    progress: &(dyn Fn(usize, usize, &str) + Sync),
) -> Vec<RenderRow> {
    use crate::render::scene;
    let scenes: Vec<crate::render::Scene> = [Model::blinn_aluminium(), Model::blinn_mgo()]
        .iter()
        .flat_map(|m| {
            [scene::Lighting::Front, scene::Lighting::Edge].map(|l| scene::fig7_scene(*m, l, res))
        })
        .collect();
    render_study_scenes_with_progress(&scenes, progress)
}

/// [`render_study`] on any scenes (each at its own resolution).
pub fn render_study_scenes(scenes: &[crate::render::Scene]) -> Vec<RenderRow> {
    render_study_scenes_with_progress(scenes, &|_, _, _| {})
}

/// The anti-aliasing settings the render study compares: uniform n×n for n = 1…6, and
/// Whitted's adaptive corner sampling (4 levels) at six thresholds.
fn render_study_settings() -> Vec<(String, f64, crate::render::AntiAlias)> {
    use crate::render::AntiAlias;
    let mut settings: Vec<(String, f64, AntiAlias)> = (1..=6)
        .map(|n| ("uniform".to_string(), n as f64, AntiAlias::Uniform(n)))
        .collect();
    for th in [0.2, 0.1, 0.05, 0.02, 0.01, 0.005] {
        settings.push((
            "adaptive".into(),
            th,
            AntiAlias::Adaptive {
                threshold: th,
                max_level: 4,
                block: 1,
                jitter: false,
            },
        ));
    }
    settings
}

/// [`render_study_scenes`], calling `progress(done, total, what)` as each image row is
/// rendered and once at the end (`done == total`); `what` names the render under way, e.g.
/// `adaptive 0.05, scene 2 of 4`. A row counts its samples per pixel (256 for the reference,
/// n² for uniform n×n, 2 for adaptive: what its rays cost), so a bar's estimate of the time
/// left holds through the references (about 70 % of the time). A study at 1024 × 1024
/// renders for minutes.
pub fn render_study_scenes_with_progress(
    scenes: &[crate::render::Scene],
    progress: &(dyn Fn(usize, usize, &str) + Sync),
) -> Vec<RenderRow> {
    use crate::render::{self, AntiAlias};
    let settings = render_study_settings();
    let weight = |aa: AntiAlias| match aa {
        AntiAlias::Uniform(n) | AntiAlias::Stratified(n) => (n * n) as usize,
        AntiAlias::None => 1,
        AntiAlias::Adaptive { .. } => 2,
    };
    let rows: usize = scenes.iter().map(|s| s.camera.height as usize).sum();
    let per_row =
        weight(AntiAlias::Uniform(16)) + settings.iter().map(|s| weight(s.2)).sum::<usize>();
    let total = rows * per_row;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let with = |k: usize, s: &render::Scene, aa: AntiAlias, what: &str| {
        let what = format!("{what}, scene {} of {}", k + 1, scenes.len());
        progress(
            done.load(std::sync::atomic::Ordering::Relaxed),
            total,
            &what,
        );
        let mut s = s.clone();
        s.antialias = aa;
        let w = weight(aa);
        let t = std::time::Instant::now();
        let img = s.render(&|| {
            let d = done.fetch_add(w, std::sync::atomic::Ordering::Relaxed) + w;
            progress(d, total, &what);
        });
        (img, t.elapsed().as_secs_f64())
    };
    let refs: Vec<render::Image> = scenes
        .iter()
        .enumerate()
        .map(|(k, s)| with(k, s, AntiAlias::Uniform(16), "16×16 reference").0)
        .collect();
    let px = |s: &render::Scene| (s.camera.width as f64) * (s.camera.height as f64);
    let out = settings
        .into_iter()
        .map(|(mode, setting, aa)| {
            let what = match aa {
                AntiAlias::Uniform(n) => format!("uniform {n}×{n}"),
                _ => format!("{mode} {setting}"),
            };
            let (mut rays, mut all, mut secs, mut err) = (0.0, 0.0, 0.0, 0.0);
            for (k, (s, r)) in scenes.iter().zip(&refs).enumerate() {
                let (img, t) = with(k, s, aa, &what);
                rays += img.rays[0] as f64 / px(s);
                all += img.total_rays() as f64 / px(s);
                secs += t;
                err += render::rmse(&img, r);
            }
            let k = scenes.len() as f64;
            RenderRow {
                mode,
                setting,
                rays_per_pixel: rays / k,
                all_rays_per_pixel: all / k,
                seconds: secs,
                rmse: err / k,
            }
        })
        .collect();
    progress(total, total, "done");
    out
}

/// Chart of the render study: RMSE against primary rays per pixel (or time).
pub fn render_chart(title: &str, rows: &[RenderRow], by_time: bool) -> XyChart {
    let series = ["uniform", "adaptive"]
        .iter()
        .map(|m| LobeSeries {
            label: if *m == "uniform" {
                "uniform n×n supersampling".into()
            } else {
                "Whitted adaptive corner sampling".into()
            },
            points: rows
                .iter()
                .filter(|r| r.mode == *m)
                .map(|r| (if by_time { r.seconds } else { r.rays_per_pixel }, r.rmse))
                .collect(),
            markers: false,
        })
        .collect();
    XyChart {
        title: title.to_string(),
        x_label: if by_time {
            "render time, 4 scenes (s)".into()
        } else {
            "primary rays per pixel".into()
        },
        y_label: "RMSE against 16×16 reference (linear)".into(),
        series,
        log_x: true,
        log_y: true,
        hline: None,
    }
}

/// Markdown and CSV tables of the render study; times only when `with_times`.
pub fn render_tables(rows: &[RenderRow], with_times: bool) -> (String, String) {
    let mut md = format!(
        "| mode | setting | primary rays/pixel | all rays/pixel |{} RMSE |\n|---|---:|---:|---:|{}---:|\n",
        if with_times { " time (s) |" } else { "" },
        if with_times { "---:|" } else { "" }
    );
    let mut csv = format!(
        "mode,setting,rays_per_pixel,all_rays_per_pixel,{}rmse\n",
        if with_times { "seconds," } else { "" }
    );
    for r in rows {
        let t = if with_times {
            format!(" {:.3} |", r.seconds)
        } else {
            String::new()
        };
        let _ = writeln!(
            md,
            "| {} | {} | {:.3} | {:.3} |{t} {:.3e} |",
            r.mode, r.setting, r.rays_per_pixel, r.all_rays_per_pixel, r.rmse
        );
        let t = if with_times {
            format!("{},", r.seconds)
        } else {
            String::new()
        };
        let _ = writeln!(
            csv,
            "{},{},{},{},{t}{}",
            r.mode, r.setting, r.rays_per_pixel, r.all_rays_per_pixel, r.rmse
        );
    }
    (md, csv)
}

/// The cheapest uniform and adaptive settings reaching `target` RMSE: (uniform rays/pixel,
/// adaptive rays/pixel).
pub fn rays_at_error(rows: &[RenderRow], target: f64) -> (Option<f64>, Option<f64>) {
    let best = |m: &str| {
        rows.iter()
            .filter(|r| r.mode == m && r.rmse <= target)
            .map(|r| r.rays_per_pixel)
            .fold(None, |a: Option<f64>, b| Some(a.map_or(b, |a| a.min(b))))
    };
    (best("uniform"), best("adaptive"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_by_hand() {
        let pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (2.0, 3.0)];
        // (3, 4) is dominated by (2, 3); the duplicate (2, 3) points are both kept.
        assert_eq!(pareto(&pts), vec![0, 1, 4, 3]);
    }

    /// The stability table with the grid's fit shared across starts equals the table with
    /// every global start fitted on its own (each a whole `fit` with the start and the grid),
    /// and the starts were not all alike (some global starts end better than their local run).
    #[test]
    fn sharing_the_grid_across_starts_changes_no_cell() {
        let reference = Model::blinn_mgo();
        let shared = stability_runs(&reference, 3, 300, 5, &|| {}, true);
        let own = stability_runs(&reference, 3, 300, 5, &|| {}, false);
        assert_eq!(shared, own);
        let hits = |g: bool| -> usize {
            shared
                .iter()
                .filter(|r| r.global == g)
                .map(|r| r.hits)
                .sum()
        };
        assert!(
            hits(true) > hits(false),
            "{} vs {}",
            hits(true),
            hits(false)
        );
    }
}

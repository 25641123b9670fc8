//! The speed–accuracy study: every method × model on one data set, fit time and work against
//! final cost (and parameter error against a known truth), its tables, and a scipy peer.

use crate::data::Dataset;
use crate::fit::lsq::Method;
use crate::fit::{self, FitOptions};
use crate::model::{Distribution, Model, ModelKind};
use std::fmt::Write;
use std::sync::atomic::AtomicUsize;

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
        // The solvers are compared on the least-squares problem, as scipy solves it: the
        // energy constraint's second solve is no solver's work.
        o.conserve = false;
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

/// Run a scipy peer script (the one `brdfit study --peer-script` names, or any script with
/// its interface) on channel 0 of `ds` with Python `python`; `None` when it cannot run.
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_by_hand() {
        let pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (2.0, 3.0)];
        // (3, 4) is dominated by (2, 3); the duplicate (2, 3) points are both kept.
        assert_eq!(pareto(&pts), vec![0, 1, 4, 3]);
    }
}

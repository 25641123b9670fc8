//! A data set's fits: the model comparison, the fitted parameters with their uncertainty, and
//! the row of the report's opening summary.

use super::doc::{Doc, rel};
use super::progress::step_at;
use super::{DataSet, REPORT_VERIFY, fit_json, ts_index};
use crate::fit::{self, FitOptions, FitResult};
use crate::support::output::write_bytes_atomic;
use anyhow::{Context, Result};
use rayon::prelude::*;
use serde_json::{Value, json};
use std::path::Path;
use std::time::Instant;

/// One row of the report's opening summary: data set, channel, recommended model with its
/// parameters ± standard error, verification, short flags, and what each Figure 7 scene needs.
pub(super) fn summary_row(
    set: &DataSet,
    channel: &str,
    fits: &[FitResult],
    rec: usize,
    needs: &[String],
) -> Vec<String> {
    let f = &fits[rec];
    let params: Vec<String> = f
        .params
        .iter()
        .zip(&f.stderr)
        .map(|((n, v), e)| {
            if e.is_finite() && *e > 0.0 && *e <= 10.0 * v.abs() {
                format!(
                    "{n} {} ± {}",
                    crate::model::readable(*v),
                    crate::model::readable(*e)
                )
            } else {
                format!("{n} {}", crate::model::readable(*v))
            }
        })
        .collect();
    let verified = fits
        .iter()
        .filter(|f| f.verification.as_ref().is_some_and(|v| v.verified))
        .count();
    let mut flags = f.flags();
    let unusable = fits.iter().filter(|f| !f.usable()).count();
    if unusable > 0 {
        flags.push(format!("not usable: {unusable} of {} fits", fits.len()));
    }
    vec![
        set.name.clone(),
        channel.trim_start_matches("the ").to_string(),
        if f.usable() {
            f.label()
        } else {
            "none usable".into()
        },
        params.join(", "),
        format!("{verified}/{} fits", fits.len()),
        flags.join(", "),
        needs.first().cloned().unwrap_or_default(),
        needs.get(1).cloned().unwrap_or_default(),
    ]
}

/// Fit every model (verified), rank them and write the comparison; returns the fits, the
/// index shown as recommended (Torrance–Sparrow when none is usable) and its label.
pub(super) fn model_comparison(
    doc: &mut Doc,
    set: &DataSet,
    file: &Path,
    tm: &mut serde_json::Map<String, Value>,
) -> Result<(Vec<FitResult>, usize, Option<String>)> {
    let (ds, name) = (&set.ds, &set.name);
    // Every model in parallel (each fit is deterministic, so the order of work is free); a
    // step as each ends (a full MERL table's take about 30 s together).
    // Every fit counts its passes over the data in one watch, shown as it grows.
    let t = Instant::now();
    let models = fit::all_models();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let watch = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let share = || done.load(std::sync::atomic::Ordering::Relaxed) as f64 / models.len() as f64;
    let tick = |k: usize| step_at(set, 1, share(), &format!("fitting: {k} evaluations in all"));
    let fits: Vec<FitResult> = fit::ticking(&watch, &tick, || {
        models
            .par_iter()
            .map(|&(k, d)| {
                let mut o = FitOptions::new(k);
                o.dist = d;
                o.verify = REPORT_VERIFY;
                o.watch = Some(watch.clone());
                let f = fit::fit(ds, &o).map(|mut v| v.remove(0));
                done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                step_at(set, 1, share(), &format!("fitting: {} done", k.label(d)));
                f
            })
            .collect::<std::result::Result<_, _>>()
    })
    .with_context(|| format!("fitting {}", file.display()))?;
    // timings.json: the step's wall time like every other entry, and each model's own clock
    // (the models run in parallel, so these add up to more than the wall time).
    tm.insert("fits".into(), json!(t.elapsed().as_secs_f64()));
    tm.insert(
        "fit_seconds_per_model".into(),
        Value::Object(fits.iter().map(|f| (f.label(), json!(f.seconds))).collect()),
    );
    let (order, rec) = fit::rank(&fits);
    doc.h(3, "Model comparison", &format!("{name}-models"));
    let best_bic = fits[order[0]].bic;
    let rows: Vec<Vec<String>> = order
        .iter()
        .map(|&i| {
            let f = &fits[i];
            vec![
                f.label(),
                f.n_free.to_string(),
                format!("{:.6e}", f.cost),
                format!("{:.1}", f.aic),
                format!("{:.1}", f.bic),
                if f.usable() {
                    format!("{:.1}", f.bic - best_bic)
                } else {
                    "—".into()
                },
                if Some(i) == rec {
                    "← simplest the data support".into()
                } else if !f.usable() {
                    format!("not usable: {}", f.unusable.join("; "))
                } else {
                    String::new()
                },
            ]
        })
        .collect();
    doc.table(&["model", "k", "cost", "AIC", "BIC", "ΔBIC", ""], &rows);
    doc.p(&format!(
    "Every fit was checked by {REPORT_VERIFY} seeded random starts (`brdfit fit --verify {REPORT_VERIFY}`): {}.",
    if fits.iter().all(|f| f.verification.as_ref().is_some_and(|v| v.verified)) {
        "none ended lower than the fit shown".to_string()
    } else {
        "a fit that one of them beats is marked not usable".to_string()
    }
));
    let recommended = rec.map(|r| fits[r].label());
    let rec = match rec {
        Some(r) => {
            doc.p(&format!(
                "Recommended: {} — the model with the fewest parameters within 2 BIC of the best.",
                fits[r].label()
            ));
            r
        }
        None => {
            doc.p("No fit is usable, so no model is recommended; the Torrance–Sparrow fit is shown below for inspection only.");
            ts_index(&fits)
        }
    };

    Ok((fits, rec, recommended))
}

/// Parameters of Torrance–Sparrow (D3) and of the recommended model, with the fit's JSON.
pub(super) fn parameters(
    doc: &mut Doc,
    set: &DataSet,
    fits: &[FitResult],
    ts_i: usize,
    rec: usize,
) -> Result<()> {
    let (name, root, dir) = (&set.name, set.root, &set.name);
    doc.h(3, "Parameters", &format!("{name}-params"));
    let mut shown = vec![ts_i];
    if rec != ts_i {
        shown.push(rec);
    }
    for &i in &shown {
        let f = &fits[i];
        let rows: Vec<Vec<String>> = f
            .params
            .iter()
            .zip(&f.stderr)
            .map(|((n, v), s)| {
                let range = f
                    .ranges
                    .iter()
                    .find(|r| r.0 == *n)
                    .map_or(String::new(), |r| fit::interval_text(r.1, r.2));
                vec![
                    n.clone(),
                    crate::model::readable(*v),
                    if s.is_finite() && (*s <= 10.0 * v.abs() || *v == 0.0) {
                        format!("{s:.3e}")
                    } else {
                        "not determined".into()
                    },
                    range,
                ]
            })
            .collect();
        doc.p(&format!(
            "{} (log loss, {} samples, termination: {}):",
            f.label(),
            f.samples_used,
            f.termination
        ));
        doc.table(
            &[
                "parameter",
                "value",
                "std. error",
                &interval_head(f.interval_level),
            ],
            &rows,
        );
        for w in &f.warnings {
            doc.p(&format!("⚠ {w}"));
        }
        for why in &f.unusable {
            doc.p(&format!("✗ Not usable: {why}"));
        }
    }
    // The recommended model's fit first (what a reader takes elsewhere), then Torrance–Sparrow.
    for &i in shown.iter().rev() {
        let f = &fits[i];
        let file = if i == ts_i {
            "fit-torrance-sparrow.json".to_string()
        } else {
            format!("fit-{}.json", f.label().replace(" (", "-").replace(')', ""))
        };
        let fit_path = root.join(dir).join(file);
        write_bytes_atomic(
            &fit_path,
            (serde_json::to_string_pretty(&fit_json(f))? + "\n").as_bytes(),
        )?;
        let what = if i == rec && f.usable() {
            format!("{} fit (the recommended model) as JSON", f.label())
        } else {
            format!("{} fit as JSON", f.label())
        };
        doc.link(
            &rel(&fit_path, root),
            &format!("{what} (input to brdfit render, plot and export)"),
        );
    }

    Ok(())
}

/// The heading of a parameter table's interval column at confidence `level` (0: a fit file
/// of an earlier version, whose column held the values within 1 % of the minimum cost).
fn interval_head(level: f64) -> String {
    if level > 0.0 {
        format!(
            "{} % confidence interval (profile likelihood)",
            crate::model::readable(100.0 * level)
        )
    } else {
        "range within 1 % of the minimum cost".into()
    }
}

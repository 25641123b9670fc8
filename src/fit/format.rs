//! Ranking fits of one channel and the terminal tables.

use super::options::Weighting;
use super::result::FitResult;
use super::stats::{WALD_FACTOR, wald_mismatch};
use crate::model::{Distribution, ModelKind, readable};

/// The models compared by `--model all`: (kind, distribution), simplest first.
pub fn all_models() -> Vec<(ModelKind, Distribution)> {
    crate::model::catalogue()
}

/// Rank fits of one channel by BIC, usable fits first (a fit marked not usable is never
/// recommended); returns the order and the index of the recommended model: the usable one with
/// the fewest free parameters within 2 BIC of the best usable one (`None` if none is usable).
pub fn rank(fits: &[FitResult]) -> (Vec<usize>, Option<usize>) {
    let mut order: Vec<usize> = (0..fits.len()).collect();
    order.sort_by(|&a, &b| {
        (!fits[a].usable())
            .cmp(&!fits[b].usable())
            .then(fits[a].bic.total_cmp(&fits[b].bic))
    });
    let usable: Vec<usize> = order
        .iter()
        .copied()
        .filter(|&i| fits[i].usable())
        .collect();
    let rec = usable.first().and_then(|&b| {
        let best = fits[b].bic;
        usable
            .iter()
            .copied()
            .filter(|&i| fits[i].bic <= best + 2.0)
            .min_by(|&a, &b| {
                fits[a]
                    .n_free
                    .cmp(&fits[b].n_free)
                    .then(fits[a].bic.total_cmp(&fits[b].bic))
            })
    });
    (order, rec)
}

/// The terminal table of one fit.
pub fn format_fit(f: &FitResult) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} on channel {}: {} loss, {} ({} samples)",
        f.label(),
        f.channel,
        f.loss.name(),
        f.method.name(),
        f.samples_used
    );
    let level = if f.interval_level > 0.0 {
        format!("{} % interval", readable(100.0 * f.interval_level))
    } else {
        "within 1 % of the minimum cost".into()
    };
    let _ = writeln!(
        s,
        "  {:<8} {:>14}  {:<26} {:>14}",
        "param", "value", level, "std. error"
    );
    // The t of the intervals, to compare value ± t·se with them (WALD_FACTOR).
    let dof = f.samples_used.saturating_sub(f.n_free).max(1) as f64;
    let t = (f.interval_level > 0.0).then(|| super::t_quantile(f.interval_level, dof));
    let mut contradicted = false;
    for (((n, v), se), free) in f.params.iter().zip(&f.stderr).zip(&f.free) {
        let value = readable(*v);
        if *free {
            let range = f.ranges.iter().find(|r| r.0 == *n);
            let flag = match (range, t) {
                (Some(r), Some(t)) => {
                    wald_mismatch(*v, *se, (r.1, r.2), t).is_some_and(|x| x > WALD_FACTOR)
                }
                _ => false,
            };
            contradicted |= flag;
            let se = if se.is_finite() && (*se <= 10.0 * v.abs() || *v == 0.0) {
                format!("{se:.3e}{}", if flag { " !" } else { "" })
            } else {
                "not determined".into()
            };
            let iv = range.map_or(String::new(), |r| interval_text(r.1, r.2));
            let _ = writeln!(s, "  {n:<8} {value:>14}  {iv:<26} {se:>14}");
        } else {
            let _ = writeln!(s, "  {n:<8} {value:>14} {:>14}", "(fixed)");
        }
    }
    if contradicted {
        let _ = writeln!(
            s,
            "  ! the standard error contradicts the interval (value ± t·se is over {WALD_FACTOR}× off \
             on a side): use the interval"
        );
    }
    // Weighted samples: the cost and rmse are the weighted ones, and say so.
    let w = match (f.weighted, f.weights) {
        (false, _) => "",
        (true, Weighting::File) => " (weighted: the file's weight column)",
        (true, Weighting::SolidAngle) => " (weighted: solid angle)",
    };
    let _ = writeln!(
        s,
        "  cost {:.6e}  rmse {:.4e}{w}  iterations {}  evaluations {}  {:.3} s",
        f.cost, f.rmse, f.iterations, f.evaluations, f.seconds
    );
    let _ = writeln!(s, "  termination: {}", f.termination);
    for w in &f.warnings {
        let _ = writeln!(s, "  warning: {w}");
    }
    if let Some(v) = &f.verification {
        let _ = writeln!(
            s,
            "  verification: {} random starts, best cost {:.6e}{}: {}",
            v.starts,
            v.best_cost,
            if v.robust.is_empty() {
                String::new()
            } else {
                format!(
                    " (of the {} loss the fit minimised, not the cost above)",
                    v.robust
                )
            },
            if v.verified {
                "none ended lower"
            } else {
                "one ended lower"
            }
        );
    }
    for why in &f.unusable {
        let _ = writeln!(s, "  NOT USABLE: {why}");
    }
    s
}

/// An interval as `[lo, hi]`, an open end as −∞ or ∞.
pub fn interval_text(lo: f64, hi: f64) -> String {
    let end = |v: f64| {
        if v == f64::NEG_INFINITY {
            "−∞".to_string()
        } else if v == f64::INFINITY {
            "∞".to_string()
        } else {
            readable(v)
        }
    };
    format!("[{}, {}]", end(lo), end(hi))
}

/// One model's fits to the channels of a file as one table, a row per channel: the
/// parameters (4 significant digits), cost, rmse and short flags (`bound:NAME`,
/// `weak:NAME` for a parameter only weakly determined, `NOT USABLE`). `format_fit` gives the
/// full detail of one channel.
pub fn format_channels(fits: &[FitResult]) -> String {
    use std::fmt::Write;
    let Some(first) = fits.first() else {
        return String::new();
    };
    let names = first.model.param_names(first.dist);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} loss, {}, {} channels ({} samples each)",
        first.label(),
        first.loss.name(),
        first.method.name(),
        fits.len(),
        first.samples_used
    );
    let _ = write!(s, "  {:<10}", "channel");
    for n in &names {
        let _ = write!(s, " {n:>10}");
    }
    let _ = writeln!(s, " {:>12} {:>10}  flags", "cost", "rmse");
    for f in fits {
        let _ = write!(s, "  {:<10}", f.channel);
        for (_, v) in f.params.iter().take(names.len()) {
            let _ = write!(s, " {:>10}", crate::model::readable(*v));
        }
        let mut flags = f.flags();
        if let Some(v) = &f.verification {
            flags.push(if v.verified {
                format!("verified({})", v.starts)
            } else {
                format!("NOT-VERIFIED({})", v.starts)
            });
        }
        if !f.usable() {
            flags.push("NOT USABLE".into());
        }
        let _ = writeln!(
            s,
            " {:>12.6e} {:>10.4e}  {}",
            f.cost,
            f.rmse,
            flags.join(" ")
        );
    }
    for f in fits.iter().filter(|f| !f.usable()) {
        let _ = writeln!(s, "  not usable, {}: {}", f.channel, f.unusable.join("; "));
    }
    s
}

/// One line of a channel's BIC ranking: each model with its ΔBIC from the best usable fit,
/// best first, the recommended one marked `←`, fits not usable last as `not usable`.
pub fn format_ranking_line(fits: &[FitResult]) -> String {
    let (order, rec) = rank(fits);
    let best = order.first().map_or(0.0, |&i| fits[i].bic);
    order
        .iter()
        .map(|&i| {
            let f = &fits[i];
            if !f.usable() {
                format!("{} not usable", f.label())
            } else if Some(i) == rec {
                format!("{} {:+.1} ←", f.label(), f.bic - best)
            } else {
                format!("{} {:+.1}", f.label(), f.bic - best)
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The model-comparison table of one channel.
pub fn format_ranking(fits: &[FitResult]) -> String {
    use std::fmt::Write;
    let (order, rec) = rank(fits);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "  {:<26} {:>3} {:>13} {:>12} {:>12} {:>9}",
        "model", "k", "cost", "AIC", "BIC", "ΔBIC"
    );
    let best = fits[order[0]].bic;
    for &i in &order {
        let f = &fits[i];
        let mark = if Some(i) == rec {
            "  ← simplest the data support".to_string()
        } else if !f.usable() {
            format!("  not usable: {}", f.unusable.join("; "))
        } else {
            String::new()
        };
        let dbic = if f.usable() {
            format!("{:>9.1}", f.bic - best)
        } else {
            format!("{:>9}", "—")
        };
        let _ = writeln!(
            s,
            "  {:<26} {:>3} {:>13.6e} {:>12.1} {:>12.1} {dbic}{mark}",
            f.label(),
            f.n_free,
            f.cost,
            f.aic,
            f.bic,
        );
    }
    if rec.is_none() {
        let _ = writeln!(s, "  no fit is usable, so no model is recommended");
    }
    s
}

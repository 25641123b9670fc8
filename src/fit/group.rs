//! One fit of one channel, or a joint fit of several, through the stages in order.

use super::checks::certify;
use super::conserve;
use super::lsq::{self, Robust};
use super::options::{FitError, FitOptions, fit_error};
use super::physical;
use super::problem::BrdfProblem;
use super::result::{FitResult, UNCONVERGED};
use super::setup::Layout;
use super::setup::{ChannelRows, check_data, layout, problem};
use super::solve::Search;
use super::solve::{self, search};
use super::stats::{reported, uncertainty};
use crate::model::readable;
use crate::support::setting::Setting;
use std::time::Instant;

/// One fit of one channel, or a joint fit of several, through the stages in order (see the
/// module documentation of [`crate::fit`](mod@crate::fit)).
pub(super) fn fit_group(
    chans: Vec<ChannelRows>,
    opts: &FitOptions,
    geometry_seconds: f64,
) -> Result<FitResult, FitError> {
    let t0 = Instant::now();
    let channel_names: Vec<String> = chans.iter().map(|c| c.name.clone()).collect();
    let channel_label = channel_names.join(",");
    let lay = layout(&channel_names, opts);
    check_data(&chans, &lay, opts, &channel_label)?;
    let m: usize = chans.iter().map(|c| c.rows.len()).sum();
    let weighted = chans.iter().any(|c| c.rows.weighted());
    // The largest θi the data reach (degrees), for the note of a fit held by energy
    // conservation beyond it.
    let measured_deg = chans
        .iter()
        .flat_map(|c| c.rows.nl.iter())
        .fold(1.0f64, |a, &b| a.min(b))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees();
    let nfree = lay.transforms.len();
    let full = problem(chans, &lay, opts);
    let mut found = search(&full, &lay, opts);
    if !found.sol.cost.is_finite() {
        return Err(fit_error(
            format!("channel {channel_label}: the fit found no point with a finite cost"),
            "check the data for extreme values, or give a start point",
        )
        .with(Setting::Start));
    }
    // The same f_r in canonical order (ggx-smith-2: alpha1 ≤ alpha2), before any statistic
    // (the normal equations cached at the solution are in the old order: made again).
    let x = solve::canonical(&full, &found.sol.x);
    if x != found.sol.x {
        found.sol.x = x;
        found.sol.normal = None;
    }
    let solve_seconds = t0.elapsed().as_secs_f64();
    // Statistics in natural parameters, on the declared (not the robust) loss.
    let cost = if found.robust == Robust::None {
        found.sol.cost
    } else {
        lsq::cost(&full, &found.sol.x, Robust::None).unwrap_or(f64::INFINITY)
    };
    let theta: Vec<f64> = (0..nfree)
        .map(|k| full.transforms[k].apply(found.sol.x[k]).0)
        .collect();
    let mut warnings = Vec::new();
    if full
        .models(&found.sol.x)
        .iter()
        .any(|m| m.canonical() != *m)
    {
        warnings.push(
            "the lobes end out of order (alpha1 > alpha2) and a held parameter keeps them from \
             being swapped: hold the other lobe's parameters instead (--fix)"
                .to_string(),
        );
    }
    if !found.sol.converged {
        warnings.push(format!("{UNCONVERGED}: {}", found.sol.termination));
    }
    let mut checks = certify(&full, &mut found, &lay, &theta, opts);
    let (mut theta, mut cost) = (theta, cost);
    let mut stat_opts = std::borrow::Cow::Borrowed(opts);
    if opts.conserve
        && let Some(held) = hold_energy(&full, &mut found, &lay, opts, measured_deg)
    {
        theta = (0..nfree)
            .map(|k| full.transforms[k].apply(found.sol.x[k]).0)
            .collect();
        cost = held.0;
        checks.kkt_violation = held.1.0;
        checks
            .unusable
            .retain(|w| !w.starts_with(super::checks::FIRST_ORDER));
        checks.unusable.extend(held.1.1);
        warnings.push(held.2);
        // The profiles refit the unconstrained problem, whose minimum lies elsewhere.
        stat_opts.to_mut().profile = false;
    }
    let u = uncertainty(
        &full,
        &found.sol,
        &theta,
        cost,
        &lay,
        &stat_opts,
        &mut warnings,
    );
    let (params, stderr, free, correlation) = reported(&lay, &theta, &u);
    let rss = 2.0 * cost;
    let mf = m as f64;
    let kf = nfree as f64;
    let loglike_term = mf * (rss / mf).max(1e-300).ln();
    let mut result = FitResult {
        model: opts.kind,
        dist: opts.dist,
        loss: opts.loss,
        method: opts.method,
        channel: channel_label,
        weights: opts.weights,
        weighted,
        params,
        stderr,
        correlation,
        free,
        cost,
        rmse: (rss / mf).sqrt(),
        samples_used: m,
        iterations: found.iterations,
        evaluations: found.evaluations,
        termination: found.sol.termination,
        // Set below, once the physical check is done.
        seconds: 0.0,
        geometry_seconds,
        solve_seconds,
        statistics_seconds: 0.0,
        warnings,
        bic: loglike_term + kf * mf.ln(),
        aic: loglike_term + 2.0 * kf,
        n_free: nfree,
        ranges: u.ranges,
        interval_level: super::stats::INTERVAL_LEVEL,
        at_bound: u.at_bound,
        kkt_violation: checks.kkt_violation,
        verification: checks.verification,
        unusable: checks.unusable,
    };
    // Only physical fits in use (pd ≤ 1, albedo ≤ 1, no lobe held down by F ≈ 0).
    let unphysical = physical::problems(&result);
    result.unusable.extend(unphysical);
    let fit_seconds = t0.elapsed().as_secs_f64();
    result.seconds = geometry_seconds + fit_seconds;
    result.statistics_seconds = fit_seconds - solve_seconds;
    Ok(result)
}

/// Energy conservation as a constraint ([`conserve`]): where the least-squares minimum of
/// `found` reflects more light than arrives at some θi, `found` becomes the best fit that does
/// not. Returns the declared loss's cost there, the first-order conditions of the constrained
/// problem, and the note; `None` (and `found` untouched) where the minimum conserves energy or
/// no constrained fit could be made.
fn hold_energy(
    full: &BrdfProblem,
    found: &mut Search,
    lay: &Layout,
    opts: &FitOptions,
    measured_deg: f64,
) -> Option<(f64, (f64, Option<String>), String)> {
    let models = full.models(&found.sol.x);
    // Most fits are clearly physical: the coarse screen spares them the fine quadrature.
    if models.iter().all(physical::clearly_below_one) {
        return None;
    }
    let limits = solve::polish_limits(full, opts);
    let before = found.sol.cost;
    let worst = models.iter().map(crate::model::albedo::max_albedo).fold(
        (0.0, f64::NEG_INFINITY),
        |a, b| if b.1 > a.1 { b } else { a },
    );
    let held = conserve::constrain(
        full,
        &found.sol.x,
        &lay.names,
        physical::ALBEDO_MARGIN,
        found.robust,
        &limits,
    )?;
    let cost = lsq::cost(full, &held.x, Robust::None)?;
    found.iterations += held.iterations;
    found.evaluations += held.evaluations;
    found.sol.x = held.x;
    found.sol.cost = held.cost;
    found.sol.normal = None;
    let angles: Vec<String> = held.angles_deg.iter().map(|t| format!("{t}°")).collect();
    let beyond = if held.angles_deg.iter().all(|&t| t > measured_deg + 0.5) {
        format!(
            " (beyond the data, which reach θi = {}°)",
            crate::model::significant(measured_deg, 3)
        )
    } else {
        String::new()
    };
    let note = format!(
        "{}: its least-squares minimum reflects {} of the light at θi = {}°; held to 1 at θi = \
         {}{beyond}, the cost rises by {} % ({} → {})",
        conserve::HELD,
        readable(worst.1),
        worst.0,
        angles.join(", "),
        readable(100.0 * (held.cost / before - 1.0)),
        readable(before),
        readable(held.cost),
    );
    Some((cost, held.kkt, note))
}

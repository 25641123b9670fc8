//! Running fits of one model: every channel on its own or jointly, timed.

use super::group::fit_group;
use super::options::{FitError, FitOptions, fit_error};
use super::result::FitResult;
use super::setup::{ChannelRows, channel_rows};
use crate::data::Dataset;
use std::time::Instant;

/// Fit `opts.kind` to every channel of `ds` (or jointly with `opts.shared`).
pub fn fit(ds: &Dataset, opts: &FitOptions) -> Result<Vec<FitResult>, FitError> {
    // Each channel's geometry pass is timed with its fit. On a thread of rayon's pool (called
    // from outside it, the work is handed to the pool once): each parallel stage then wakes
    // the other core only, instead of putting this thread to sleep and waking it again.
    rayon::scope(|_| fit_with(ds, opts, |c| timed_rows(ds, c, opts), &|_, _| {}))
}

/// [`fit`] with each channel's rows (and their geometry seconds) from `timed`; `step(c, true)`
/// as the fit of channel `c` starts and `step(c, false)` as it ends (`None`: the joint fit of
/// every channel).
pub(super) fn fit_with(
    ds: &Dataset,
    opts: &FitOptions,
    timed: impl Fn(usize) -> (ChannelRows, f64),
    step: &dyn Fn(Option<usize>, bool),
) -> Result<Vec<FitResult>, FitError> {
    let names = opts.kind.param_names(opts.dist);
    for (k, v) in opts.fix.iter().chain(&opts.start) {
        let Some(spec) = opts.kind.params(opts.dist).iter().find(|s| s.name == k) else {
            return Err(fit_error(
                format!("model {} has no parameter {k}", opts.kind),
                format!("its parameters are {}", names.join(", ")),
            ));
        };
        let bounds = spec.bounds_text();
        if !spec.admits(*v) {
            return Err(fit_error(
                format!("{k} = {v} is outside its bounds ({bounds})"),
                format!("choose a value with {bounds}"),
            ));
        }
    }
    for s in &opts.shared {
        if !names.contains(&s.as_str()) {
            return Err(fit_error(
                format!(
                    "shared parameter {s}: model {} has no parameter {s}",
                    opts.kind
                ),
                format!("its parameters are {}", names.join(", ")),
            ));
        }
    }
    if opts.shared.is_empty() || ds.channels.len() == 1 {
        (0..ds.channels.len())
            .map(|c| {
                step(Some(c), true);
                let (rows, t) = timed(c);
                let f = if super::seed::seeded(opts) {
                    super::seed::fit_seeded(vec![rows], opts, t)
                } else {
                    fit_group(vec![rows], opts, t)
                };
                step(Some(c), false);
                f
            })
            .collect()
    } else {
        step(None, true);
        let (chans, times): (Vec<ChannelRows>, Vec<f64>) =
            (0..ds.channels.len()).map(timed).unzip();
        let f = if super::seed::seeded(opts) {
            super::seed::fit_seeded(chans, opts, times.iter().sum())
        } else {
            fit_group(chans, opts, times.iter().sum())
        };
        step(None, false);
        Ok(vec![f?])
    }
}

/// Channel `c`'s rows for `opts` and the seconds their geometry pass took.
pub(super) fn timed_rows(ds: &Dataset, c: usize, opts: &FitOptions) -> (ChannelRows, f64) {
    let t = Instant::now();
    let rows = channel_rows(ds, c, opts);
    (rows, t.elapsed().as_secs_f64())
}

/// [`fit`] run `repeat` times in this process (for benchmarks): the results of the first run
/// with `seconds` and each stage's seconds the median of its own column over the runs
/// (every run gives the same parameters; only the clock differs).
pub fn fit_timed(
    ds: &Dataset,
    opts: &FitOptions,
    repeat: usize,
) -> Result<Vec<FitResult>, FitError> {
    let runs = (0..repeat.max(1))
        .map(|_| fit(ds, opts))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(median_times(runs))
}

/// The first of several runs of the same fits, with `seconds` and each stage's seconds the
/// median of its own column over the runs.
pub(super) fn median_times(mut runs: Vec<Vec<FitResult>>) -> Vec<FitResult> {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let seconds: Vec<[f64; 4]> = (0..runs[0].len())
        .map(|i| {
            let col = |g: fn(&FitResult) -> f64| median(runs.iter().map(|r| g(&r[i])).collect());
            [
                col(|f| f.seconds),
                col(|f| f.geometry_seconds),
                col(|f| f.solve_seconds),
                col(|f| f.statistics_seconds),
            ]
        })
        .collect();
    let mut fits = runs.swap_remove(0);
    for (f, [s, g, v, t]) in fits.iter_mut().zip(seconds) {
        (f.seconds, f.geometry_seconds) = (s, g);
        (f.solve_seconds, f.statistics_seconds) = (v, t);
    }
    fits
}

//! The report's progress: each stage and step of a file's section told to the progress hook,
//! or on stderr.

use super::{DataSet, ReportOptions, STAGE_WEIGHTS};

/// Progress units per [`STAGE_WEIGHTS`] unit, so that the steps inside a stage (each study
/// fit, each `choose` candidate) move the bar and its estimate of the time left.
pub(super) const UNITS: u64 = 100;

/// Announce stage `k` ([`STAGE_WEIGHTS`]) of file `f` of `n`.
pub(super) fn stage(opts: &ReportOptions, f: usize, n: usize, k: usize, what: &str) {
    stage_at(opts, f, n, k, 0.0, what);
}

/// [`stage`] with the share `part` (0–1) of stage `k` done.
pub(super) fn stage_at(opts: &ReportOptions, f: usize, n: usize, k: usize, part: f64, what: &str) {
    let per: u64 = STAGE_WEIGHTS.iter().map(|s| s.1).sum();
    let start = f as u64 * per + STAGE_WEIGHTS[..k].iter().map(|s| s.1).sum::<u64>();
    let within = (part.clamp(0.0, 1.0) * (STAGE_WEIGHTS[k].1 * UNITS) as f64) as u64;
    say(
        opts,
        start * UNITS + within,
        (n as u64 * per + 1) * UNITS,
        what,
    );
}

/// A step inside stage `k` of a file's section, e.g. one study.
pub(super) fn step(set: &DataSet, k: usize, what: &str) {
    step_at(set, k, 0.0, what);
}

/// [`step`] with the share `part` (0–1) of stage `k` done; only to a progress hook (the
/// messages on stderr name the stages and the studies, not each step).
pub(super) fn step_at(set: &DataSet, k: usize, part: f64, what: &str) {
    if set.opts.progress.is_some() {
        stage_at(
            set.opts,
            set.place.0,
            set.place.1,
            k,
            part,
            &format!("{}: {what}", set.name),
        );
    }
}

/// What runs now: to the progress hook, else on stderr when verbose.
pub(super) fn say(opts: &ReportOptions, done: u64, total: u64, m: &str) {
    match &opts.progress {
        Some(p) => (p.0)(done, total, m),
        None if opts.verbose => eprintln!("report: {m}"),
        None => {}
    }
}

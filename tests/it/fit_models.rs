//! `fit --model all`'s path (`fit::fit_models`: the models in parallel, the geometry computed
//! once) against the plain path, one `fit::fit` per model: every result the same to the bit
//! but for the clock; and the physical check's albedos, computed in parallel, against the
//! quadrature at each angle on this thread.

use crate::common::load;
use brdfit::fit::{self, FitOptions, FitResult};
use brdfit::model::albedo::{ALBEDO_THETA_I_DEG, albedos, directional_albedo};

/// A fit without its timings (the only fields allowed to differ between two runs).
fn untimed(mut f: FitResult) -> FitResult {
    f.seconds = 0.0;
    f.geometry_seconds = 0.0;
    f.solve_seconds = 0.0;
    f.statistics_seconds = 0.0;
    f
}

/// Every model of `fit --model all`, as the command sets them up.
fn all_models() -> Vec<FitOptions> {
    fit::all_models()
        .into_iter()
        .map(|(kind, dist)| {
            let mut o = FitOptions::new(kind);
            o.dist = dist;
            o
        })
        .collect()
}

#[test]
fn every_model_at_once_equals_one_at_a_time() {
    // Three channels (RGB), so the shared geometry is per channel; and one loss apart (the
    // linear loss), so two geometries are computed: one shared (copied into each fit), one
    // used by the linear entry alone (moved into its fit).
    let ds = load("tests/data/vch_golden_yellow_rgb.csv");
    let mut opts = all_models();
    let mut linear = opts[3].clone();
    linear.loss = brdfit::fit::problem::Loss::Linear;
    opts.push(linear);
    let (together, wall) = fit::fit_models(&ds, &opts, 1).unwrap();
    assert!(wall > 0.0);
    assert_eq!(together.len(), opts.len());
    for (o, fits) in opts.iter().zip(together) {
        let alone = fit::fit(&ds, o).unwrap();
        assert_eq!(fits.len(), 3);
        for (a, b) in alone.into_iter().zip(fits) {
            let label = format!("{} {} {:?}", a.label(), a.channel, a.loss);
            assert_eq!(untimed(a), untimed(b), "{label}");
        }
    }
}

/// The progress hook of `fit --model all` (its bar on a terminal): a start and an end for
/// each channel's fit of each model in every run, the fit named while it runs (the model and
/// its channel), the work done never falling and ending at the total, and the fits the same
/// as without a hook. A joint fit (shared parameters) is one step for every channel.
#[test]
fn progress_names_each_fit_while_it_runs_and_ends_at_the_total() {
    use std::sync::Mutex;
    let ds = load("tests/data/vch_golden_yellow_rgb.csv");
    let mut opts = all_models();
    let mut joint = opts[3].clone();
    joint.shared = vec!["n".to_string()];
    opts.push(joint);
    let calls: Mutex<Vec<(u64, u64, String)>> = Mutex::new(Vec::new());
    let hook = |done: u64, total: u64, running: &str| {
        calls
            .lock()
            .unwrap()
            .push((done, total, running.to_string()));
    };
    let repeat = 2;
    let (with, _) = fit::fit_models_with_progress(&ds, &opts, repeat, &hook).unwrap();
    let (without, _) = fit::fit_models(&ds, &opts, 1).unwrap();
    for (a, b) in with
        .into_iter()
        .flatten()
        .zip(without.into_iter().flatten())
    {
        assert_eq!(untimed(a), untimed(b));
    }
    // Every 0.25 s while the fits run, a tick counts the passes over the data so far: the
    // work done as the last step left it, the count growing.
    let (ticks, calls): (Vec<_>, Vec<_>) = calls
        .into_inner()
        .unwrap()
        .into_iter()
        .partition(|c| c.2.ends_with(" evaluations in all"));
    let counts: Vec<usize> = ticks
        .iter()
        .map(|t| {
            let words = t.2.trim_end_matches(" evaluations in all");
            words.rsplit(' ').next().unwrap().parse().unwrap()
        })
        .collect();
    assert!(counts.windows(2).all(|w| w[0] <= w[1]), "{ticks:?}");
    assert!(counts.iter().all(|&k| k > 0), "{ticks:?}");
    // 9 models × 3 channels, and the joint fit once, in each of the two runs; a start and an end each.
    assert_eq!(calls.len(), 2 * repeat * (opts.len() - 1) * 3 + 2 * repeat);
    let total = calls[0].1;
    assert!(calls.iter().all(|c| c.1 == total));
    assert!(calls.windows(2).all(|w| w[0].0 <= w[1].0), "work done fell");
    assert_eq!(calls.last().unwrap().0, total);
    assert_eq!(calls.last().unwrap().2, "", "nothing runs at the end");
    // Each fit of one channel is named, with its channel, from its start to its end.
    let named = |s: &str| {
        calls
            .iter()
            .filter(|c| c.2.split(", ").any(|r| r == s))
            .count()
    };
    for label in [
        "ggx-smith-2 (r)",
        "torrance-sparrow (abc) (g)",
        "lambert (b)",
    ] {
        assert!(
            named(label) >= repeat,
            "{label} named {} times",
            named(label)
        );
    }
    // The joint fit is named without a channel (the per-channel fits of the same model with
    // one).
    let joint = opts.last().unwrap();
    let joint = joint.kind.label(joint.dist);
    assert!(named(&joint) >= repeat, "{joint}");
}

#[test]
fn an_error_is_the_first_in_the_order_given() {
    let ds = load("data/blinn-mgo.csv");
    let mut opts = all_models();
    // The third option holds a parameter its model does not have.
    opts[2].fix = vec![("c3".to_string(), 0.5)];
    let err = fit::fit_models(&ds, &opts, 1).unwrap_err();
    assert_eq!(err, fit::fit(&ds, &opts[2]).unwrap_err());
}

#[test]
fn albedos_in_parallel_equal_each_angle_alone() {
    let f = &fit::fit(&load("data/blinn-aluminium.csv"), &all_models()[5]).unwrap()[0];
    let m = f.model_for(0);
    let got = albedos(&m);
    assert_eq!(got.len(), ALBEDO_THETA_I_DEG.len());
    for (&(t, a), &want_t) in got.iter().zip(&ALBEDO_THETA_I_DEG) {
        assert_eq!(t, want_t);
        assert_eq!(
            a.to_bits(),
            directional_albedo(&m, t.to_radians()).to_bits()
        );
    }
}

/// `ticking` calls its tick from another thread while the work runs, with the count's value
/// (the work here waits for the first tick, so the test does not depend on the clock), and
/// stops: after a panic in the work too, which it passes on.
#[test]
fn ticking_reports_the_count_while_work_runs_and_stops_after_a_panic() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::mpsc;
    let count = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<usize>();
    let tx = std::sync::Mutex::new(tx);
    let tick = |k: usize| {
        let _ = tx.lock().unwrap().send(k);
    };
    let out = fit::ticking(&count, &tick, || {
        count.store(7, Ordering::Relaxed);
        rx.recv_timeout(std::time::Duration::from_secs(60))
            .expect("a tick within a minute")
    });
    assert_eq!(out, 7);
    // No tick after the return (the ticker is joined before it: every tick sent by then is
    // drained here), none in twice the tick's period.
    while rx.try_recv().is_ok() {}
    std::thread::sleep(2 * fit::TICK);
    assert!(rx.try_recv().is_err(), "a tick after ticking returned");
    // Work that panics: the panic comes back out, the ticker stopped (no hang).
    let quiet = AtomicUsize::new(0);
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        fit::ticking(&quiet, &|_| {}, || -> usize { panic!("work failed") })
    }));
    assert!(r.is_err());
}

/// A fit's watch counts every pass over the data: a local fit without profiles or
/// verification on fewer than 2,000 samples per channel (no subsample, so no check of the
/// start's cost on every sample) makes exactly the evaluations its results report (the
/// statistics reuse the solver's last normal equations), every channel adding to one watch;
/// a default fit on 10,000 samples at least as many.
#[test]
fn the_watch_counts_every_pass_over_the_data() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let small = load("data/cayman.astm");
    let mut o = FitOptions::new(brdfit::model::ModelKind::TorranceSparrow);
    o.local_only = true;
    o.profile = false;
    let watch = Arc::new(AtomicUsize::new(0));
    o.watch = Some(watch.clone());
    let fits = fit::fit(&small, &o).unwrap();
    let reported: usize = fits.iter().map(|f| f.evaluations).sum();
    assert!(reported > 3 * fits.len(), "{reported}");
    assert_eq!(watch.load(Ordering::Relaxed), reported);
    let ds = load("data/blinn-mgo.csv");
    let mut d = FitOptions::new(brdfit::model::ModelKind::TorranceSparrow);
    let all = Arc::new(AtomicUsize::new(0));
    d.watch = Some(all.clone());
    d.verify = 2;
    let g = fit::fit(&ds, &d).unwrap().remove(0);
    assert!(all.load(Ordering::Relaxed) >= g.evaluations);
}

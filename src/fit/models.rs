//! Several models fitted to one data set at once (`fit --model all`), in parallel, each
//! channel's geometry computed once for the fits that share it, with progress.

use super::options::{FitError, FitOptions};
use super::progress::{ticking, with_count};
use super::result::FitResult;
use super::run::{fit_with, median_times, timed_rows};
use super::setup::ChannelRows;
use crate::data::Dataset;
use crate::model::{Distribution, ModelKind};
use std::sync::atomic::AtomicUsize;
use std::time::Instant;

/// Several fits of one dataset, e.g. `fit --model all`: each entry of `opts` as
/// [`fit`](crate::fit::fit) gives it (the same results), with the models fitted in parallel and
/// each channel's geometry computed once for all the fits that share its loss, `--max-theta` and
/// weighting (its time is counted in each fit's `geometry_seconds`). Run `repeat` times
/// (benchmarks), it returns the first run's fits with their median times, as
/// [`fit_timed`](crate::fit::fit_timed) does, and the median wall time of one run of them all
/// (geometry included). The first error in `opts` order, if any.
pub fn fit_models(
    ds: &Dataset,
    opts: &[FitOptions],
    repeat: usize,
) -> Result<(Vec<Vec<FitResult>>, f64), FitError> {
    fit_models_with_progress(ds, opts, repeat, &|_, _, _| {})
}

/// [`fit_models`], calling `progress(done, total, running)` as each channel's fit of a model starts
/// and ends: `done` of `total` units of work (each fit weighs `work_weight`, its relative cost, so
/// a bar's estimate of the time left holds while one dear fit runs for seconds: a full MERL table's
/// ggx-smith-2), `running` the fits under way, e.g. `ggx-smith-2 (r), torrance-sparrow (abc) (g)`,
/// and every [`TICK`](crate::fit::TICK) while fits run, with the passes over the data so far (`… ·
/// 1234 evaluations in all`). The fits count in a watch of their own: a `watch` set in `opts` is
/// not used.
pub fn fit_models_with_progress(
    ds: &Dataset,
    opts: &[FitOptions],
    repeat: usize,
    progress: &(dyn Fn(u64, u64, &str) + Sync),
) -> Result<(Vec<Vec<FitResult>>, f64), FitError> {
    let nch = ds.channels.len() as u64;
    let total = repeat.max(1) as u64 * nch * opts.iter().map(work_weight).sum::<u64>();
    let done = std::sync::atomic::AtomicU64::new(0);
    let running: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    // The hook of one entry's fits (see `fit_with`): the fit named in `running` while it runs,
    // its weight added when it ends.
    let step = |o: &FitOptions, c: Option<usize>, started: bool| {
        let label = match c {
            Some(c) if nch > 1 => format!("{} ({})", o.kind.label(o.dist), ds.channel_label(c)),
            _ => o.kind.label(o.dist),
        };
        let mut run = running.lock().expect("no progress hook panics");
        let now = if started {
            run.push(label);
            done.load(std::sync::atomic::Ordering::Relaxed)
        } else {
            if let Some(at) = run.iter().position(|r| *r == label) {
                run.remove(at);
            }
            let units = work_weight(o) * if c.is_some() { 1 } else { nch };
            done.fetch_add(units, std::sync::atomic::Ordering::Relaxed) + units
        };
        progress(now, total, &run.join(", "));
    };
    // Every fit counts its passes over the data in one watch, shown beside the fits running
    // every [`TICK`](crate::fit::TICK): the message moves while one dear fit runs for seconds.
    let watch = std::sync::Arc::new(AtomicUsize::new(0));
    let owned: Vec<FitOptions> = opts
        .iter()
        .map(|o| FitOptions {
            watch: Some(watch.clone()),
            ..o.clone()
        })
        .collect();
    let opts = &owned[..];
    let tick = |k: usize| {
        let run = running.lock().expect("no progress hook panics");
        let now = done.load(std::sync::atomic::Ordering::Relaxed);
        progress(now, total, &with_count(&run.join(", "), k));
    };
    let mut runs: Vec<Vec<Vec<FitResult>>> = vec![Vec::new(); opts.len()];
    let mut walls = Vec::new();
    ticking(&watch, &tick, || {
        fit_runs(ds, opts, repeat, &step, &mut runs, &mut walls)
    })?;
    walls.sort_by(f64::total_cmp);
    let fits = runs.into_iter().map(median_times).collect();
    Ok((fits, walls[walls.len() / 2]))
}

/// The options of each model of `kinds` (its model and distribution set), the rest from
/// `base`: with several models (`fit --model all`), `fix`, `start` and `shared` keep only the
/// parameters that model has; with one they stay whole, so that a name the model lacks is an
/// error of its fit.
pub fn options_per_model(
    base: &FitOptions,
    kinds: &[(ModelKind, Distribution)],
) -> Vec<FitOptions> {
    kinds
        .iter()
        .map(|&(kind, dist)| {
            let names = kind.param_names(dist);
            let has = |k: &str| kinds.len() == 1 || names.contains(&k);
            let keep = |v: &[(String, f64)]| -> Vec<(String, f64)> {
                v.iter().filter(|(k, _)| has(k)).cloned().collect()
            };
            FitOptions {
                kind,
                dist,
                fix: keep(&base.fix),
                start: keep(&base.start),
                shared: base.shared.iter().filter(|s| has(s)).cloned().collect(),
                ..base.clone()
            }
        })
        .collect()
}

/// The runs of [`fit_models_with_progress`]: each run's fits appended to `runs` (one list per
/// entry of `opts`) and its wall time to `walls`; `step` as each channel's fit starts and ends.
fn fit_runs(
    ds: &Dataset,
    opts: &[FitOptions],
    repeat: usize,
    step: &(dyn Fn(&FitOptions, Option<usize>, bool) + Sync),
    runs: &mut [Vec<Vec<FitResult>>],
    walls: &mut Vec<f64>,
) -> Result<(), FitError> {
    let key = |o: &FitOptions| (o.loss, o.max_theta_deg.map(f64::to_bits), o.weights);
    for _ in 0..repeat.max(1) {
        let t = Instant::now();
        // Each distinct geometry once per channel: (its key, each channel's rows and time). On a
        // thread of rayon's pool, as in [`fit`](crate::fit::fit): each parallel stage of the
        // geometry pass then wakes the other core only, not this thread as well.
        let mut shared: Vec<(_, Vec<(ChannelRows, f64)>)> = rayon::scope(|_| {
            let mut shared: Vec<(_, Vec<(ChannelRows, f64)>)> = Vec::new();
            for o in opts {
                if !shared.iter().any(|(k, _)| *k == key(o)) {
                    let rows = (0..ds.channels.len())
                        .map(|c| timed_rows(ds, c, o))
                        .collect();
                    shared.push((key(o), rows));
                }
            }
            shared
        });
        // A geometry only one entry uses is moved into its fit, not copied (a million rows:
        // 56 MB copied and faulted in for nothing).
        let alone: Vec<std::sync::Mutex<Option<ChannelGeometries>>> = opts
            .iter()
            .map(|o| {
                let users = opts.iter().filter(|p| key(p) == key(o)).count();
                let rows = (users == 1).then(|| {
                    let at = shared.iter().position(|(k, _)| *k == key(o));
                    shared
                        .swap_remove(at.expect("every geometry computed above"))
                        .1
                });
                std::sync::Mutex::new(rows)
            })
            .collect();
        // Longest first, each model taken by the next free thread as it finishes one (a
        // FIFO scope: the calling thread runs the first, a thief takes the oldest left), so
        // no core idles at the end behind the dearest fit.
        let mut order: Vec<usize> = (0..opts.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(work_weight(&opts[i])));
        let slots: Vec<std::sync::Mutex<Option<FitsOrError>>> =
            opts.iter().map(|_| std::sync::Mutex::new(None)).collect();
        rayon::scope_fifo(|s| {
            for &i in &order {
                let (o, slot, shared, alone) = (&opts[i], &slots[i], &shared, &alone[i]);
                s.spawn_fifo(move |_| {
                    let own = alone.lock().expect("no fit panics").take();
                    let f = match own {
                        Some(rows) => {
                            // Each channel's rows are asked for once.
                            let rows: Vec<std::cell::Cell<Option<(ChannelRows, f64)>>> =
                                rows.into_iter().map(|r| Some(r).into()).collect();
                            fit_with(
                                ds,
                                o,
                                |c| rows[c].take().expect("each channel taken once"),
                                &|c, started| step(o, c, started),
                            )
                        }
                        None => {
                            let (_, rows) = shared
                                .iter()
                                .find(|(k, _)| *k == key(o))
                                .expect("every geometry computed above");
                            fit_with(ds, o, |c| rows[c].clone(), &|c, started| {
                                step(o, c, started)
                            })
                        }
                    };
                    *slot.lock().expect("no fit panics") = Some(f);
                });
            }
        });
        let fits: Vec<FitsOrError> = slots
            .into_iter()
            .map(|m| {
                m.into_inner()
                    .expect("no fit panics")
                    .expect("every fit ran")
            })
            .collect();
        walls.push(t.elapsed().as_secs_f64());
        for (run, f) in runs.iter_mut().zip(fits) {
            run.push(f?);
        }
    }
    Ok(())
}

/// Each channel's rows and the seconds of their geometry pass.
type ChannelGeometries = Vec<(ChannelRows, f64)>;

/// One entry's fits of [`fit_models`], or its error.
type FitsOrError = Result<Vec<FitResult>, FitError>;

/// The relative cost of a fit of `o` on real data, larger is dearer: [`fit_models`] starts
/// the dearest first and counts a fit's progress in these units. Seconds per channel of a full
/// MERL table (steel, 1,096,216 rows, `fit --model all` on a 2-core machine: lambert
/// 0.18, phong 0.35, blinn-phong 0.31, Torrance–Sparrow d3 0.85, d2 1.3, d1 1.5, abc 2.1,
/// ggx-smith 0.78, ggx-smith-2 4.1–12.6) over lambert's, rounded, with the order measured on
/// MERL alumina-oxide's 16,512 rows where the two differ (phong and blinn-phong dearer than
/// d3 and ggx-smith there).
pub(crate) fn work_weight(o: &FitOptions) -> u64 {
    match (o.kind, o.dist) {
        (ModelKind::TabulatedNdf, _) => 60,
        (ModelKind::GgxSmith2, _) => 40,
        (ModelKind::TorranceSparrow, Distribution::Abc) => 12,
        (ModelKind::TorranceSparrow, Distribution::D1) => 8,
        (ModelKind::TorranceSparrow, Distribution::D2) => 7,
        (ModelKind::Phong | ModelKind::BlinnPhong, _) => 4,
        (ModelKind::TorranceSparrow, Distribution::D3) => 3,
        (ModelKind::GgxSmith, _) => 2,
        (ModelKind::Lambert, _) => 1,
    }
}

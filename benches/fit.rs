//! Torrance–Sparrow fits of synthetic Blinn MgO data (hemisphere, 1 % noise, log loss) at
//! 10k, 100k and 1M samples (the 1M fit also without the range profiling); and every method,
//! brdfit's and argmin's, on the same 10k and 100k inputs (no profiling), side by side; and
//! every model on a bundled real file and on 10k and 1M samples of its own fit, and all nine
//! together as `fit --model all` runs them.
//!
//! Run: `cargo bench --bench fit`. The side-by-side comparison with scipy is
//! `benches/compare_scipy.sh`.

use brdfit::fit::{self, FitOptions, Method};
use brdfit::model::{Model, ModelKind};
use brdfit::simulate::{Grid, simulate};
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn bench(c: &mut Criterion) {
    // The allocator set as the `brdfit` binary sets it, so the figures are the binary's (the
    // first group runs first).
    brdfit::keep_freed_memory();
    let mut g = c.benchmark_group("fit_ts_mgo_log");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    for n in [10_000usize, 100_000, 1_000_000] {
        let ds = simulate(
            &Model::blinn_mgo(),
            &Grid::Hemisphere(n).directions(1),
            0.01,
            1,
        );
        let opts = FitOptions::new(ModelKind::TorranceSparrow);
        g.bench_function(format!("{n}"), |b| b.iter(|| fit::fit(&ds, &opts).unwrap()));
        if n == 1_000_000 {
            let mut o = opts.clone();
            o.profile = false;
            g.bench_function(format!("{n}_no_profile"), |b| {
                b.iter(|| fit::fit(&ds, &o).unwrap())
            });
        }
    }
    g.finish();
}

/// brdfit's methods against argmin's on the same problem: the whole pipeline (global
/// initialisation, subsample, every sample) with each as the local method.
fn methods(c: &mut Criterion) {
    let mut g = c.benchmark_group("fit_ts_mgo_methods");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    for n in [10_000usize, 100_000] {
        let ds = simulate(
            &Model::blinn_mgo(),
            &Grid::Hemisphere(n).directions(1),
            0.01,
            1,
        );
        for m in Method::ALL {
            let mut o = FitOptions::new(ModelKind::TorranceSparrow);
            o.method = m;
            o.profile = false;
            g.bench_function(format!("{}/{n}", m.name()), |b| {
                b.iter(|| fit::fit(&ds, &o).unwrap())
            });
        }
    }
    g.finish();
}

/// Every model (each Torrance–Sparrow distribution separately), default pipeline and log loss:
/// on the bundled MERL alumina-oxide table (green, 16,512 samples), then on 10k and 1M
/// synthetic samples drawn from that model's own fit (hemisphere, 1 % noise); `--model all`
/// on that table and on MERL aluminium's blue channel.
fn models(c: &mut Criterion) {
    let full = brdfit::load(
        std::path::Path::new("data/merl-alumina-oxide.csv"),
        &brdfit::LoadOptions::default(),
    )
    .expect("data/merl-alumina-oxide.csv (run from the checkout)");
    let (real, _) = brdfit::data::representative_channel(&full).expect("a channel");
    let mut g = c.benchmark_group("fit_models");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    for (kind, dist) in brdfit::model::catalogue() {
        let mut o = FitOptions::new(kind);
        o.dist = dist;
        o.profile = false;
        let name = fit::fit(&real, &o).unwrap()[0].label().replace(' ', "");
        g.bench_function(format!("{name}/merl-alumina-oxide"), |b| {
            b.iter(|| fit::fit(&real, &o).unwrap())
        });
        let truth = fit::fit(&real, &o).unwrap()[0].model_for(0);
        for n in [10_000usize, 1_000_000] {
            let ds = simulate(&truth, &Grid::Hemisphere(n).directions(1), 0.01, 1);
            g.bench_function(format!("{name}/{n}"), |b| {
                b.iter(|| fit::fit(&ds, &o).unwrap())
            });
        }
    }
    // `fit --model all` as the command runs it (ranges profiled): nine models in parallel,
    // the geometry computed once.
    let all: Vec<FitOptions> = fit::all_models()
        .into_iter()
        .map(|(kind, dist)| {
            let mut o = FitOptions::new(kind);
            o.dist = dist;
            o
        })
        .collect();
    g.bench_function("all/merl-alumina-oxide", |b| {
        b.iter(|| fit::fit_models(&real, &all, 1).unwrap())
    });
    // The slowest bundled channel for `--model all`: a metal's fits take the most steps.
    let metal = brdfit::load(
        std::path::Path::new("data/merl-aluminium.csv"),
        &brdfit::LoadOptions::default(),
    )
    .expect("data/merl-aluminium.csv (run from the checkout)")
    .select(&brdfit::data::ChannelSelect::Index(2))
    .expect("a blue channel");
    g.bench_function("all/merl-aluminium-b", |b| {
        b.iter(|| fit::fit_models(&metal, &all, 1).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench, methods, models);
criterion_main!(benches);

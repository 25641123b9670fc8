//! Coverage of the confidence intervals a fit reports: on data simulated from a known
//! Torrance–Sparrow (Blinn's MgO: n 1.8, c3 0.35, ps 0.667, pd 0.333) with Gaussian noise in
//! the fitted (log) loss, each parameter's 95 % profile-likelihood interval holds the truth in
//! 95 ± 3 % of 400 seeds, at 10, 100 and 10,000 samples (measured figures in
//! docs/validation.md).
//!
//! The noise is 1 % of the log loss's target (0.01) at 100 and 10,000 samples, 0.1 % at 10,
//! whose ten samples lie in the plane of incidence across the lobe: with ten random samples
//! over the hemisphere (1 % or 0.1 % noise) the four parameters are barely determined, the
//! intervals of n and c3 reach a bound (open: c3 in every seed) and the coverage is above the
//! level (measured, 0.1 % noise: n 99.5 %, c3 and ps 99.75 %, pd 96.75 %). The stated level is
//! met where the data determine the parameters.

use brdfit::data::{Dataset, Quantity};
use brdfit::fit::{FitOptions, fit};
use brdfit::model::{Distribution, Model, ModelKind};
use rand::SeedableRng;
use rand_distr::{Distribution as _, Normal};
use rayon::prelude::*;

/// Noise of the log loss's target ln(1 + cosθi f_r) for `n` samples (see the module
/// documentation).
fn sigma(n: usize) -> f64 {
    if n <= 10 { 0.001 } else { 0.01 }
}

/// The truth: Blinn's MgO.
fn truth() -> Model {
    Model::new(
        ModelKind::TorranceSparrow,
        Distribution::D3,
        &[1.8, 0.35, 0.667, 0.333],
    )
    .unwrap()
}

/// The ten configurations of the smallest design: in the plane of incidence at θi = 30° and
/// 60°, the mirror direction, 10° either side of it, and two off the lobe (a goniometer's
/// first scan: random directions over the hemisphere rarely meet a lobe, and ten of them
/// leave n and c3 undetermined, their intervals open).
fn ten() -> Vec<[f64; 4]> {
    let mut out = Vec::new();
    for (ti, off) in [(30.0f64, [0.0, 75.0]), (60.0, [20.0, 85.0])] {
        for to in [ti - 10.0, ti, ti + 10.0].into_iter().chain(off) {
            out.push([ti.to_radians(), 0.0, to.to_radians(), std::f64::consts::PI]);
        }
    }
    out
}

/// `n` samples (ten: [`ten`]; more: seeded random configurations, the same for every seed of
/// a size), the noise of seed `seed`: y = ln(1 + cosθi f) + σε, written as f_r =
/// (e^y − 1)/cosθi.
fn data(n: usize, seed: u64) -> Dataset {
    let m = truth();
    let dirs = if n == 10 {
        ten()
    } else {
        brdfit::simulate::Grid::Hemisphere(n).directions(7)
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma(n)).unwrap();
    let mut ds = Dataset::new(Quantity::Brdf, vec![("y".into(), None)]);
    for a in dirs {
        let g = brdfit::model::Geometry::from_angles(a[0], a[1], a[2], a[3]);
        let ci = a[0].cos();
        let y = (ci * m.brdf(&g)).ln_1p() + noise.sample(&mut rng);
        ds.push(a, &[y.exp_m1() / ci]);
    }
    ds
}

/// For each parameter, the share of `seeds` seeds whose 95 % interval holds the truth, and
/// the share whose interval is open on a side.
fn coverage(n: usize, seeds: u64) -> Vec<(String, f64, f64)> {
    let t = truth();
    let names = t.param_names();
    let hits: Vec<Vec<(bool, bool)>> = (0..seeds)
        .into_par_iter()
        .map(|s| {
            let f = fit(
                &data(n, 1000 + s),
                &FitOptions::new(ModelKind::TorranceSparrow),
            )
            .unwrap()
            .remove(0);
            assert_eq!(f.interval_level, 0.95);
            names
                .iter()
                .zip(t.params())
                .map(|(name, v)| {
                    let r = f.ranges.iter().find(|r| r.0 == *name);
                    (
                        r.is_some_and(|r| r.1 <= *v && *v <= r.2),
                        r.is_none_or(|r| !(r.1.is_finite() && r.2.is_finite())),
                    )
                })
                .collect()
        })
        .collect();
    names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let c = hits.iter().filter(|h| h[k].0).count();
            let open = hits.iter().filter(|h| h[k].1).count();
            let n = seeds as f64;
            (name.to_string(), c as f64 / n, open as f64 / n)
        })
        .collect()
}

fn check(n: usize) {
    let cov = coverage(n, 400);
    println!("{n} samples (parameter, coverage, share open): {cov:?}");
    for (name, c, _) in &cov {
        assert!((0.92..=0.98).contains(c), "{n} samples, {name}: {c}");
    }
}

#[test]
fn ten_samples_cover_95_percent() {
    check(10);
}

#[test]
fn hundred_samples_cover_95_percent() {
    check(100);
}

#[test]
fn ten_thousand_samples_cover_95_percent() {
    check(10_000);
}

/// The fit JSON holds `intervals` and `interval_level` 0.95; a fit file of an earlier version,
/// whose `ranges` held the values within 1 % of the minimum cost, is still read, its ranges
/// kept and its level 0 (so no one reads them as 95 % intervals).
#[test]
fn fit_files_old_and_new_read_back() {
    let f = fit(&data(100, 1), &FitOptions::new(ModelKind::TorranceSparrow))
        .unwrap()
        .remove(0);
    let v = f.to_json();
    assert_eq!(v["interval_level"], 0.95);
    assert!(
        v["intervals"]["c3"].is_array() && v.get("ranges").is_none(),
        "{v}"
    );
    assert_eq!(brdfit::FitResult::from_json(&v).unwrap(), f);
    let mut old = v.as_object().unwrap().clone();
    old.remove("interval_level");
    let iv = old.remove("intervals").unwrap();
    old.insert("ranges".into(), iv);
    let back = brdfit::FitResult::from_json(&serde_json::Value::Object(old)).unwrap();
    assert_eq!(back.interval_level, 0.0);
    assert_eq!(back.ranges, f.ranges);
    assert!(brdfit::fit::format_fit(&back).contains("within 1 % of the minimum cost"));
}

//! `fit --model all`'s path (`fit::fit_models`: the models in parallel, the geometry computed
//! once) against the plain path, one `fit::fit` per model: every result the same to the bit
//! but for the clock; and the physical check's albedos, computed in parallel, against the
//! quadrature at each angle on this thread.

mod common;

use brdfit::fit::{self, FitOptions, FitResult};
use brdfit::model::albedo::{ALBEDO_THETA_I_DEG, albedos, directional_albedo};
use common::load;

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

//! Fits that do not depend on the data's scale: Blinn's MgO (`data/blinn-mgo.csv`, made from
//! n 1.8, c3 0.35, ps 0.667, pd 0.333 with 1 % noise) multiplied by factors from 1e-12 to 1e6.
//! The reference is the same fit at scale 1: under the linear loss, scaling the data by s
//! scales the loss by s² and ps, pd by s, so every shape parameter, warning and relative error
//! must come back unchanged (a property of the problem, not of brdfit's output).

use crate::common::load;
use brdfit::data::Dataset;
use brdfit::fit::{self, FitOptions, FitResult, Loss};
use brdfit::model::ModelKind;

fn scaled(s: f64) -> Dataset {
    let mut ds = load("data/blinn-mgo.csv");
    for v in ds.channels[0].values.iter_mut() {
        *v *= s;
    }
    ds
}

fn fit_at(s: f64, o: &FitOptions) -> FitResult {
    fit::fit(&scaled(s), o).unwrap().remove(0)
}

fn close(got: f64, want: f64, rel: f64) -> bool {
    (got - want).abs() <= rel * want.abs()
}

#[test]
fn linear_loss_fits_scale_with_the_data() {
    // Energy conservation is off: scaled by 1e6 the data describe a material reflecting 10⁶
    // times the light that arrives, which the fit would rightly hold at albedo 1.
    let mut o = FitOptions::new(ModelKind::TorranceSparrow);
    o.loss = Loss::Linear;
    o.conserve = false;
    let unit = fit_at(1.0, &o);
    for s in [1e-12, 1e-6, 1e6] {
        let f = fit_at(s, &o);
        for (k, (name, want)) in unit.params.iter().enumerate() {
            let factor = if name == "ps" || name == "pd" { s } else { 1.0 };
            let got = f.params[k].1;
            assert!(
                close(got, want * factor, 1e-6),
                "{s:e} {name}: {got} vs {want}"
            );
            let (se, se1) = (f.stderr[k], unit.stderr[k]);
            assert!(
                close(se, se1 * factor, 1e-5),
                "{s:e} {name} se: {se} vs {se1}"
            );
            let (_, lo, hi) = &f.ranges[k];
            let (_, lo1, hi1) = &unit.ranges[k];
            // The interval ends are found by bisection to 1 % of their distance from the value.
            let width = (hi1 - lo1) * factor;
            assert!(
                (lo - lo1 * factor).abs() <= 0.02 * width
                    && (hi - hi1 * factor).abs() <= 0.02 * width,
                "{s:e} {name}: [{lo}, {hi}] vs [{lo1}, {hi1}]"
            );
        }
        assert!(
            close(f.cost, unit.cost * s * s, 1e-6),
            "{s:e}: cost {}",
            f.cost
        );
        assert_eq!(f.warnings, unit.warnings, "{s:e}");
        if s < 1.0 {
            assert_eq!(f.unusable, unit.unusable, "{s:e}");
        }
    }
}

#[test]
fn log_loss_fit_finds_its_minimum_at_any_small_scale() {
    // Scaled by 1e-12 the fit ended at n = 3001 (the solver's scaling froze n). The log loss
    // ln(1 + cosθi f) is linear in f below about 1e-6, so from there down every scale has the
    // same minimum (to the loss's curvature, 1e-9 relative at 1e-9); the truth is n 1.8.
    let o = FitOptions::new(ModelKind::TorranceSparrow);
    let reference = fit_at(1e-9, &o);
    assert!(close(reference.get("n").unwrap(), 1.8, 0.01));
    for s in [1e-12, 1e-15] {
        let f = fit_at(s, &o);
        for (k, (name, want)) in reference.params.iter().enumerate() {
            let factor = if name == "ps" || name == "pd" {
                s / 1e-9
            } else {
                1.0
            };
            let got = f.params[k].1;
            assert!(
                close(got, want * factor, 1e-6),
                "{s:e} {name}: {got} vs {want}"
            );
        }
        assert!(
            f.usable() && f.warnings.is_empty(),
            "{s:e}: {:?} {:?}",
            f.warnings,
            f.unusable
        );
    }
}

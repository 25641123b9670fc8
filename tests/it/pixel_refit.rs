//! `choose`'s refit on what the pixel shows ("fit where it is judged"): on each
//! Figure 7 case, the scene-weighted fit's pixel cost, worked out here from the sRGB transfer
//! function and the pixel counts, is never above the same model's global fit's.

use brdfit::choose::{RENDER_COST_ORDER, exposure, fig7_cases, refit_on_pixels, scene_samples};
use brdfit::data::Dataset;
use brdfit::fit::{self, FitOptions};
use brdfit::model::{Geometry, Model};
use rayon::prelude::*;

/// The display value of linear radiance `x`: clipped smoothly at 1 (the soft minimum
/// −δ ln(e^(−x/δ) + e^(−1/δ)), δ = 0.02, by log-sum-exp) and sRGB encoded (IEC 61966-2-1).
fn display(x: f64) -> f64 {
    let d = 0.02;
    let (a, b) = (-x / d, -1.0 / d);
    let m = a.max(b);
    let c = -d * (m + ((a - m).exp() + (b - m).exp()).ln());
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// ½ Σ (pixel count) (display(e cosθi f_model) − display(e cosθi f_data))² over the samples.
fn pixel_cost(ds: &Dataset, e: f64, m: &Model) -> f64 {
    let w = ds.weights.as_ref().unwrap();
    (0..ds.len())
        .map(|k| {
            let a = ds.angles(k);
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            let c = a[0].cos();
            let r = display(e * c * m.brdf(&g)) - display(e * c * ds.channels[0].values[k]);
            0.5 * w[k] * r * r
        })
        .sum()
}

#[test]
fn display_matches_srgb_by_hand() {
    // 0.5 lies 25 δ below the clip: sRGB(0.5) = 1.055 · 0.5^(1/2.4) − 0.055 = 0.735357.
    assert!((display(0.5) - 0.735_357).abs() < 1e-6, "{}", display(0.5));
    assert!((display(0.001) - 0.012_92).abs() < 1e-9);
    // Far above the clip the display is 1; at x = 1 the soft minimum is 1 − δ ln 2.
    assert!((display(5.0) - 1.0).abs() < 1e-12);
    let c: f64 = 1.0 - 0.02 * 2f64.ln();
    assert!((display(1.0) - (1.055 * c.powf(1.0 / 2.4) - 0.055)).abs() < 1e-12);
}

/// Blinn's MgO data (data/blinn-mgo.csv), both Figure 7 cases at 256², every candidate of
/// `choose`: the refit's pixel cost ≤ the global fit's (relative 1e-9).
#[test]
fn scene_weighted_fit_is_never_worse_than_the_global_fit_in_pixels() {
    let ds = crate::common::load("data/blinn-mgo.csv");
    let truth = Model::blinn_mgo();
    let globals: Vec<Model> = RENDER_COST_ORDER
        .par_iter()
        .map(|&(kind, dist)| {
            let mut o = FitOptions::new(kind);
            o.dist = dist;
            o.profile = false;
            fit::fit(&ds, &o).unwrap().remove(0).model_for(0)
        })
        .collect();
    let mut failures = Vec::new();
    for case in fig7_cases(256) {
        let (samples, _, _) = scene_samples(&case.scene, 0, &|g| truth.brdf(g));
        let e = exposure(&case.scene);
        let rows: Vec<(String, f64, f64)> = RENDER_COST_ORDER
            .par_iter()
            .zip(&globals)
            .map(|(&(kind, dist), global)| {
                let mut o = FitOptions::new(kind);
                o.dist = dist;
                o.profile = false;
                let log_fit = fit::fit(&samples, &o).unwrap().remove(0);
                let r = refit_on_pixels(&samples, log_fit, global, e, 0, None);
                (
                    kind.label(dist),
                    pixel_cost(&samples, e, &r.model_for(0)),
                    pixel_cost(&samples, e, global),
                )
            })
            .collect();
        for (label, scene, global) in rows {
            println!(
                "{} {label}: pixel cost {scene:.6e} scene-weighted, {global:.6e} global",
                case.name
            );
            if scene > global * (1.0 + 1e-9) {
                failures.push(format!("{} {label}: {scene} > {global}", case.name));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

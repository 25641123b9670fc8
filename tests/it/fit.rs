//! Fitting: round trips on synthetic data with known truth, global minimum from any start,
//! the chain rule of the transformed problem, model selection, real data, and error cases.

use crate::common::load;
use brdfit::data::{ChannelSelect, Dataset, Quantity};
use brdfit::fit::lsq::{self, Problem, Robust};
use brdfit::fit::problem::{BrdfProblem, Loss, Row, Rows, Slot, Transform};
use brdfit::fit::{self, FitOptions, FitResult};
use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use brdfit::simulate::{Grid, simulate};
use rand::{Rng, SeedableRng};

fn ts() -> FitOptions {
    FitOptions::new(ModelKind::TorranceSparrow)
}

fn within(got: f64, want: f64, rel: f64) -> bool {
    (got - want).abs() <= rel * want.abs()
}

#[test]
fn recovers_blinn_mgo() {
    let f = &fit::fit(&load("data/blinn-mgo.csv"), &ts()).unwrap()[0];
    for (name, want) in [("n", 1.8), ("c3", 0.35), ("ps", 0.667), ("pd", 0.333)] {
        let got = f.get(name).unwrap();
        assert!(within(got, want, 0.02), "{name}: {got} vs {want}");
    }
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    assert_eq!(f.samples_used, 10000);
}

#[test]
fn recovers_blinn_aluminium_with_an_honest_range_for_n() {
    let f = &fit::fit(&load("data/blinn-aluminium.csv"), &ts()).unwrap()[0];
    for (name, want) in [("c3", 0.5), ("ps", 0.4), ("pd", 0.6)] {
        let got = f.get(name).unwrap();
        assert!(within(got, want, 0.02), "{name}: {got} vs {want}");
    }
    // n's 95 % interval holds what the profile says, by refits with n held (independent of
    // the profile's walk): just outside each end the cost rises above S (1 + t²/(m − p)),
    // halfway in it does not. (The file's noise is multiplicative, v(1 + σε), not the log
    // loss's own: its interval, [181, 193.5], misses the truth 200; docs/fitting.md.)
    let (_, lo, hi) = f
        .ranges
        .iter()
        .find(|r| r.0 == "n")
        .expect("an interval for n")
        .clone();
    let n = f.get("n").unwrap();
    assert!(lo < n && n < hi, "[{lo}, {hi}] around {n}");
    let dof = (f.samples_used - f.n_free) as f64;
    let t = fit::t_quantile(0.95, dof);
    let limit = f.cost * (1.0 + t * t / dof);
    let held = |v: f64| {
        let mut o = ts();
        o.profile = false;
        o.fix = vec![("n".into(), v)];
        fit::fit(&load("data/blinn-aluminium.csv"), &o).unwrap()[0].cost
    };
    assert!(held(lo - 0.05 * (n - lo)) > limit && held(0.5 * (lo + n)) <= limit);
    assert!(held(hi + 0.05 * (hi - n)) > limit && held(0.5 * (hi + n)) <= limit);
}

#[test]
fn recovers_blinn_phong_exponent() {
    let truth = Model::new(ModelKind::BlinnPhong, Distribution::D3, &[40.0, 0.5, 0.3]).unwrap();
    let ds = simulate(&truth, &Grid::Hemisphere(10_000).directions(7), 0.01, 7);
    let f = &fit::fit(&ds, &FitOptions::new(ModelKind::BlinnPhong)).unwrap()[0];
    assert!(
        within(f.get("c1").unwrap(), 40.0, 0.02),
        "c1 = {}",
        f.get("c1").unwrap()
    );
    assert!(within(f.get("ps").unwrap(), 0.5, 0.02) && within(f.get("pd").unwrap(), 0.3, 0.02));
}

fn random_start(rng: &mut rand_chacha::ChaCha8Rng) -> Vec<(String, f64)> {
    vec![
        ("n".into(), 10f64.powf(rng.random_range(0.02..2.7))),
        ("c3".into(), rng.random_range(0.02..0.99)),
        ("ps".into(), rng.random_range(0.0..2.0)),
        ("pd".into(), rng.random_range(0.0..1.0)),
    ]
}

#[test]
fn forty_random_starts_all_reach_the_global_minimum() {
    for file in ["data/blinn-mgo.csv", "data/blinn-aluminium.csv"] {
        let ds = load(file);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(40);
        let starts: Vec<_> = (0..40).map(|_| random_start(&mut rng)).collect();
        let run = |local_only: bool| -> Vec<f64> {
            starts
                .iter()
                .map(|s| {
                    let mut o = ts();
                    o.start = s.clone();
                    o.local_only = local_only;
                    o.profile = false;
                    fit::fit(&ds, &o)
                        .map(|f| f[0].cost)
                        .unwrap_or(f64::INFINITY)
                })
                .collect()
        };
        let global = run(false);
        let local = run(true);
        let best = global
            .iter()
            .chain(&local)
            .cloned()
            .fold(f64::INFINITY, f64::min);
        let hits = |c: &[f64]| c.iter().filter(|&&x| (x - best) / best < 1e-9).count();
        println!(
            "{file}: global minimum reached from {}/40 starts with the global initialisation, {}/40 with --local-only",
            hits(&global),
            hits(&local)
        );
        assert_eq!(hits(&global), 40, "{file}: {global:?}");
    }
}

#[test]
fn plateau_start_does_not_strand_the_fit() {
    // The peers' failure: started at n = 200 on ceramic data, unbounded solvers run n to 1e8.
    let mut o = ts();
    o.start = vec![
        ("n".into(), 200.0),
        ("c3".into(), 0.5),
        ("ps".into(), 0.5),
        ("pd".into(), 0.5),
    ];
    let f = &fit::fit(&load("data/blinn-mgo.csv"), &o).unwrap()[0];
    assert!(within(f.get("n").unwrap(), 1.8, 0.02));
}

/// A layout row for the four Torrance–Sparrow parameters (the other slots unused).
fn slots(first: [Slot; 4]) -> [Slot; brdfit::model::MAX_PARAMS] {
    let mut s = [Slot::Fixed(0.0); brdfit::model::MAX_PARAMS];
    s[..4].copy_from_slice(&first);
    s
}

/// A small two-channel problem, shared n and c3, to check the transformed chain rule.
fn small_problem(loss: Loss) -> BrdfProblem {
    let mut rows = Vec::new();
    let mut starts = vec![0];
    let truth = [Model::blinn_mgo(), Model::blinn_aluminium()];
    for m in &truth {
        for a in Grid::Hemisphere(200).directions(3) {
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            let f = m.brdf(&g) * 1.1;
            rows.push(Row {
                g,
                cos_i: g.nl,
                target: loss.target(f, g.nl),
                sw: 1.3,
            });
        }
        starts.push(rows.len());
    }
    BrdfProblem {
        template: Model::blinn_mgo(),
        rows: std::sync::Arc::new(Rows::from(rows)),
        starts,
        layout: vec![
            slots([Slot::Free(0), Slot::Free(1), Slot::Free(2), Slot::Free(3)]),
            slots([
                Slot::Free(0),
                Slot::Free(1),
                Slot::Free(4),
                Slot::Fixed(0.6),
            ]),
        ],
        transforms: {
            let sp = ModelKind::TorranceSparrow.params(Distribution::D3);
            vec![
                Transform::of(&sp[0]),
                Transform::of(&sp[1]),
                Transform::of(&sp[2]),
                Transform::of(&sp[3]),
                Transform::of(&sp[2]),
            ]
        },
        loss,
        watch: None,
    }
}

#[test]
fn transformed_gradient_matches_finite_differences() {
    for loss in [Loss::Log, Loss::Linear] {
        let p = small_problem(loss);
        let x = [0.3, -0.4, 0.8, 0.6, 0.7];
        let prep = p.prepare(&x).unwrap();
        let mut row = vec![0.0; 5];
        for i in (0..p.n_residuals()).step_by(7) {
            p.residual_grad(&prep, i, &mut row);
            for k in 0..5 {
                let h = 1e-6;
                let (mut up, mut dn) = (x.to_vec(), x.to_vec());
                up[k] += h;
                dn[k] -= h;
                let fd = (p.residual(&p.prepare(&up).unwrap(), i)
                    - p.residual(&p.prepare(&dn).unwrap(), i))
                    / (2.0 * h);
                assert!(
                    (fd - row[k]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "{loss:?} row {i} var {k}: {} vs {fd}",
                    row[k]
                );
            }
        }
        // Solving the small problem from a poor start reaches cost with the known values.
        let s = lsq::levenberg_marquardt(
            &p,
            &[0.0, 0.0, 0.5, 0.5, 0.5],
            Robust::None,
            &Default::default(),
        );
        assert!(s.cost.is_finite());
    }
}

#[test]
fn transforms_invert_and_respect_bounds() {
    let sp = ModelKind::TorranceSparrow.params(Distribution::D3);
    let c1 = ModelKind::Phong.params(Distribution::D3)[0];
    for (spec, vals) in [
        (sp[0], vec![1.01, 1.8, 200.0, 3e6]),
        (sp[1], vec![0.001, 0.35, 0.9, 1.0]),
        (c1, vec![0.5, 40.0, 3000.0, 2e6]),
        (sp[2], vec![0.0, 0.4, 7.0, 9000.0]),
    ] {
        let t = Transform::of(&spec);
        for v in vals {
            let back = t.apply(t.invert(v)).0;
            assert!(
                (back - v).abs() < 1e-9 * (1.0 + v),
                "{} {v} -> {back}",
                spec.name
            );
            // dθ/du never vanishes inside the box (the square transform's did at 0).
            assert!(t.apply(t.invert(v)).1 > 0.0, "{} {v}", spec.name);
        }
        let (lo, hi) = t.bounds();
        assert!(t.apply(lo).0 >= spec.lo * (1.0 - 1e-12), "{}", spec.name);
        assert!(t.apply(hi).0 <= spec.hi * (1.0 + 1e-12), "{}", spec.name);
        // The box spans each parameter's whole admissible range.
        assert!(
            (t.apply(lo).0 - spec.lo).abs() <= 1e-9 * (1.0 + spec.lo),
            "{}",
            spec.name
        );
    }
    // n > 1 by construction.
    let t = Transform::of(&sp[0]);
    assert!(t.apply(t.bounds().0).0 > 1.0);
}

/// Data from Torrance–Sparrow with a small pd (0.004): from a start with pd exactly at its
/// bound 0, the local method must leave the bound (the square transform pd = u² could not:
/// its derivative vanishes at u = 0), end at pd ≈ 0.004, and report no parameter at a bound.
#[test]
fn a_parameter_at_its_bound_leaves_it_when_the_gradient_points_inward() {
    let truth = Model::new(
        ModelKind::TorranceSparrow,
        Distribution::D3,
        &[2.3, 0.05, 3.0, 0.004],
    )
    .unwrap();
    let ds = simulate(&truth, &Grid::Hemisphere(3000).directions(1), 0.01, 1);
    let mut o = ts();
    o.local_only = true;
    o.start = vec![
        ("n".into(), 2.0),
        ("c3".into(), 0.06),
        ("ps".into(), 2.0),
        ("pd".into(), 0.0),
    ];
    let f = fit::fit(&ds, &o).unwrap().remove(0);
    assert!(
        within(f.get("pd").unwrap(), 0.004, 0.05),
        "pd = {}",
        f.get("pd").unwrap()
    );
    assert!(f.at_bound.is_empty(), "{:?}", f.at_bound);
    assert!(f.kkt_violation < 1e-6, "{}", f.kkt_violation);
}

/// Data that want a negative diffuse term (specular lobe minus a constant, linear loss): the
/// fit ends with pd on its lower bound, reports it in `at_bound`, and satisfies the KKT
/// conditions there (its gradient points out of the box); the optimum of ps and c3 with pd
/// held at 0 is the same point.
#[test]
fn an_active_bound_is_reported_and_satisfies_the_kkt_conditions() {
    let spec = Model::new(
        ModelKind::TorranceSparrow,
        Distribution::D3,
        &[1.8, 0.2, 1.0, 0.0],
    )
    .unwrap();
    let mut ds = Dataset::new(Quantity::Brdf, vec![("v".into(), None)]);
    let sim = simulate(&spec, &Grid::Hemisphere(2000).directions(3), 0.0, 3);
    for k in 0..sim.len() {
        let v = sim.channels[0].values[k] - 0.02;
        if v > 0.0 {
            ds.push(sim.angles(k), &[v]);
        }
    }
    let mut o = ts();
    o.loss = Loss::Linear;
    let f = fit::fit(&ds, &o).unwrap().remove(0);
    assert_eq!(f.get("pd"), Some(0.0), "{}", fit::format_fit(&f));
    assert_eq!(f.at_bound, vec![("pd".to_string(), "lower".to_string())]);
    assert!(f.kkt_violation < 1e-6, "{}", f.kkt_violation);
    assert!(f.usable(), "{:?}", f.unusable);
    // Independent check: with pd held at 0 the fit reaches the same cost.
    let mut held = o.clone();
    held.fix = vec![("pd".into(), 0.0)];
    let g = fit::fit(&ds, &held).unwrap().remove(0);
    assert!(within(f.cost, g.cost, 1e-9), "{} vs {}", f.cost, g.cost);
}

#[test]
fn model_comparison_picks_the_simplest_supported_model() {
    // Lambertian data: lambert is recommended.
    let lam = Model::new(ModelKind::Lambert, Distribution::D3, &[0.5]).unwrap();
    let ds = simulate(&lam, &Grid::Hemisphere(3000).directions(5), 0.01, 5);
    let fits: Vec<FitResult> = fit::all_models()
        .into_iter()
        .map(|(k, d)| {
            let mut o = FitOptions::new(k);
            o.dist = d;
            o.profile = false;
            fit::fit(&ds, &o).unwrap().remove(0)
        })
        .collect();
    let (_, rec) = fit::rank(&fits);
    let rec = rec.expect("a usable fit");
    assert_eq!(
        fits[rec].model,
        ModelKind::Lambert,
        "{}",
        fit::format_ranking(&fits)
    );
    // Blinn's MgO data: torrance-sparrow d3 (the truth) ranks first.
    let ds = load("data/blinn-mgo.csv");
    let fits: Vec<FitResult> = fit::all_models()
        .into_iter()
        .map(|(k, d)| {
            let mut o = FitOptions::new(k);
            o.dist = d;
            o.profile = false;
            fit::fit(&ds, &o).unwrap().remove(0)
        })
        .collect();
    let (order, rec) = fit::rank(&fits);
    assert_eq!(
        (fits[order[0]].model, fits[order[0]].dist),
        (ModelKind::TorranceSparrow, Distribution::D3)
    );
    assert_eq!(
        fits[rec.expect("a usable fit")].model,
        ModelKind::TorranceSparrow
    );
    // A fit marked not usable is never recommended, even with the best BIC.
    let mut marked = fits.clone();
    marked[order[0]].unusable = vec!["test".into()];
    let (order2, rec2) = fit::rank(&marked);
    assert_ne!(rec2, Some(order[0]));
    assert_eq!(*order2.last().unwrap(), order[0]);
}

/// The certificate catches a fit in a wrong basin: from a start on the Fresnel plateau
/// (n = 1e6) the local method alone ends far above the minimum on Cornell cayman at 460 nm;
/// 16 random starts find lower, the fit is marked not usable (n is absurd too) and the JSON
/// says `verified: false`. The default pipeline on the same samples verifies.
#[test]
fn verification_marks_a_fit_in_a_wrong_basin_not_usable() {
    let ds = load("data/cayman.astm")
        .select(&ChannelSelect::parse("460nm"))
        .unwrap();
    let mut o = ts();
    o.profile = false;
    o.verify = 16;
    let good = fit::fit(&ds, &o).unwrap().remove(0);
    assert!(good.usable(), "{:?}", good.unusable);
    let v = good.verification.as_ref().unwrap();
    assert!(v.verified && v.starts == 16 && v.best_cost >= good.cost * (1.0 - 1e-6));
    let mut bad = o.clone();
    bad.local_only = true;
    bad.start = vec![
        ("n".into(), 1e6),
        ("c3".into(), 0.3),
        ("ps".into(), 1.0),
        ("pd".into(), 0.1),
    ];
    let f = fit::fit(&ds, &bad).unwrap().remove(0);
    assert!(f.cost > 2.0 * good.cost, "{} vs {}", f.cost, good.cost);
    let v = f.verification.as_ref().unwrap();
    assert!(!v.verified && v.best_cost < f.cost, "{v:?}");
    assert!(!f.usable());
    assert!(
        f.unusable.iter().any(|w| w.starts_with("verification")),
        "{:?}",
        f.unusable
    );
    assert_eq!(f.to_json()["verified"], serde_json::json!(false));
    assert!(!f.to_json()["unusable"].as_array().unwrap().is_empty());
    // Readable numbers: no warning or reason carries a run of more than 12 digits.
    for w in f.warnings.iter().chain(&f.unusable) {
        let run = w
            .split(|c: char| !c.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(run <= 12, "{w}");
    }
    let text = fit::format_fit(&f);
    assert!(text.contains("NOT USABLE"), "{text}");
}

#[test]
fn json_has_the_documented_schema() {
    let f = &fit::fit(&load("data/blinn-mgo.csv"), &ts()).unwrap()[0];
    let v = f.to_json();
    for key in [
        "model",
        "distribution",
        "loss",
        "channel",
        "params",
        "stderr",
        "correlation",
        "cost",
        "rmse",
        "samples_used",
        "iterations",
        "evaluations",
        "termination",
        "seconds",
        "warnings",
        "intervals",
        "interval_level",
        "at_bound",
        "kkt_violation",
        "unusable",
        "aic",
        "bic",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert!(v.get("verified").is_none(), "no --verify, no certificate");
    let names: Vec<&String> = v["params"].as_object().unwrap().keys().collect();
    assert_eq!(names, ["n", "c3", "ps", "pd"]);
    let c = v["correlation"].as_array().unwrap();
    assert_eq!(c.len(), 4);
    assert!((c[1][1].as_f64().unwrap() - 1.0).abs() < 1e-12);
    // cost is ½ Σ r² with the log loss, recomputed here independently of the fitter.
    let ds = load("data/blinn-mgo.csv");
    let m = f.model_for(0);
    let mut c2 = 0.0;
    for k in 0..ds.len() {
        let a = ds.angles(k);
        let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
        let ci = a[0].cos();
        c2 += 0.5 * ((ci * m.brdf(&g)).ln_1p() - (ci * ds.channels[0].values[k]).ln_1p()).powi(2);
    }
    assert!((c2 - f.cost).abs() < 1e-9 * c2, "{c2} vs {}", f.cost);
    let back = FitResult::from_json(&v).unwrap();
    assert_eq!(back.model_for(0), m);
    // Written and read back equal: every field, the certificate included.
    assert_eq!(&back, f);
    let mut o = ts();
    o.verify = 4;
    let g = fit::fit(&ds, &o).unwrap().remove(0);
    let text = serde_json::to_string_pretty(&g).unwrap();
    assert!(text.contains("\"verified\": true") && text.contains("\"verify_starts\": 4"));
    let back: FitResult = serde_json::from_str(&text).unwrap();
    assert_eq!(back, g);
    // A fit JSON of the earlier layout (standard errors as an object) still reads.
    let old = serde_json::json!({"model": "torrance-sparrow", "distribution": "d3",
        "params": {"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333},
        "stderr": {"n": 0.1, "c3": 0.01, "ps": 0.01, "pd": 0.01}, "cost": 1.0});
    assert_eq!(
        FitResult::from_json(&old).unwrap().model_for(0),
        Model::blinn_mgo()
    );
}

#[test]
fn options_are_honoured() {
    let ds = load("data/blinn-mgo.csv");
    // --fix holds a parameter; --max-theta drops samples.
    let mut o = ts();
    o.fix = vec![("n".into(), 1.5)];
    o.max_theta_deg = Some(60.0);
    let f = &fit::fit(&ds, &o).unwrap()[0];
    assert_eq!(f.get("n"), Some(1.5));
    assert!(!f.free[0] && f.stderr[0] == 0.0);
    let expect = (0..ds.len())
        .filter(|&k| ds.theta_i[k] <= 60f64.to_radians() && ds.theta_o[k] <= 60f64.to_radians())
        .count();
    assert_eq!(f.samples_used, expect);
    // Weights: doubling every weight leaves the parameters unchanged and doubles the cost.
    let mut w = ds.clone();
    w.weights = Some(vec![2.0; ds.len()]);
    let a = &fit::fit(&ds, &ts()).unwrap()[0];
    let b = &fit::fit(&w, &ts()).unwrap()[0];
    assert!(within(b.cost, 2.0 * a.cost, 1e-6));
    assert!(within(b.get("c3").unwrap(), a.get("c3").unwrap(), 1e-6));
    // Linear loss and robust losses run and recover the truth on clean-ish data.
    for (loss, robust) in [
        (Loss::Linear, None),
        (Loss::Log, Some(fit::RobustKind::Huber)),
        (Loss::Log, Some(fit::RobustKind::Cauchy)),
    ] {
        let mut o = ts();
        o.loss = loss;
        o.robust = robust;
        o.profile = false;
        let f = &fit::fit(&ds, &o).unwrap()[0];
        assert!(
            within(f.get("c3").unwrap(), 0.35, 0.03),
            "{loss:?} {robust:?}: {}",
            f.get("c3").unwrap()
        );
    }
    // Gauss–Newton and Nelder–Mead reach the same minimum as LM on this data.
    for m in [lsq::Method::GaussNewton, lsq::Method::NelderMead] {
        let mut o = ts();
        o.method = m;
        o.profile = false;
        let f = &fit::fit(&ds, &o).unwrap()[0];
        assert!(
            within(f.cost, a.cost, 1e-6),
            "{m:?}: {} vs {}",
            f.cost,
            a.cost
        );
    }
}

#[test]
fn rgb_channels_separately_and_shared() {
    let ds = load("data/merl-alumina-oxide.csv");
    let mut o = ts();
    o.profile = false;
    let each = fit::fit(&ds, &o).unwrap();
    assert_eq!(each.len(), 3);
    o.shared = vec!["n".into(), "c3".into()];
    let joint = fit::fit(&ds, &o).unwrap();
    assert_eq!(joint.len(), 1);
    let names: Vec<&str> = joint[0].params.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        ["n", "c3", "ps_r", "pd_r", "ps_g", "pd_g", "ps_b", "pd_b"]
    );
    // The joint fit has fewer freedoms, so its cost is at least the sum of the separate ones.
    let sum: f64 = each.iter().map(|f| f.cost).sum();
    assert!(
        joint[0].cost >= sum * (1.0 - 1e-9),
        "{} < {sum}",
        joint[0].cost
    );
    assert!(joint[0].cost <= sum * 1.5);
}

/// Lobe plausibility: in the plane of incidence at θi = 30°, the fitted lobe peaks near the
/// mirror direction, and pd/π is within a factor 2 of the data's median more than 15° from the
/// mirror direction (the specular peaks here are a few degrees wide). Returns pd/π ÷ level.
fn plausible(ds: &Dataset, f: &FitResult, c: usize, what: &str) -> f64 {
    let m = f.model_for(c);
    let ti = 30f64.to_radians();
    let peak = (0..90)
        .map(|d| {
            (
                d as f64,
                m.brdf(&Geometry::from_angles(
                    ti,
                    0.0,
                    (d as f64).to_radians(),
                    std::f64::consts::PI,
                )),
            )
        })
        .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    assert!(
        (peak.0 - 30.0).abs() <= 6.0,
        "{what}: lobe peaks at θo = {}°",
        peak.0
    );
    let vals = ds.brdf_values(c);
    let mut off: Vec<f64> = (0..ds.len())
        .filter(|&k| {
            let a = ds.angles(k);
            let r = brdfit::model::direction(a[0], a[1] + std::f64::consts::PI);
            let e = brdfit::model::direction(a[2], a[3]);
            let cosang = r[0] * e[0] + r[1] * e[1] + r[2] * e[2];
            cosang < 15f64.to_radians().cos() && vals[k].is_finite() && a[0] < 1.2 && a[2] < 1.2
        })
        .map(|k| vals[k])
        .collect();
    off.sort_by(f64::total_cmp);
    let level = off[off.len() / 2];
    let pd = f.get("pd").unwrap() / std::f64::consts::PI;
    println!(
        "{what}: pd/π = {pd:.5}, off-peak level {level:.5}, ratio {:.2}",
        pd / level
    );
    pd / level
}

#[test]
fn real_data_fits_are_plausible() {
    // (file, metallic): for the metallic samples the log loss barely weighs the dim off-peak
    // region, so pd sits well above the off-peak level; the 95 % interval the fit reports
    // must hold on every sample (checked by refits with pd held, independent of the profile).
    let files = [
        ("data/cayman.astm", false),
        ("data/merl-aluminium.csv", true),
        ("data/merl-alumina-oxide.csv", false),
        ("tests/data/acryl_blue.astm", false),
        ("tests/data/garnet_red.astm", false),
        ("tests/data/krylon_blue.astm", false),
        ("tests/data/mystique.brdf", true),
    ];
    for (file, metallic) in files {
        let mut ds = load(file);
        if ds.channels.len() > 3 {
            ds = ds.select(&ChannelSelect::CieY).unwrap();
        }
        let fits = fit::fit(&ds, &ts()).unwrap_or_else(|e| panic!("{file}: {e}"));
        for (c, f) in fits.iter().enumerate() {
            let what = format!("{file} channel {}", f.channel);
            assert!(
                f.cost.is_finite() && f.params.iter().all(|(_, v)| v.is_finite()),
                "{what}"
            );
            let ratio = plausible(&ds, f, c, &what);
            if metallic && ratio > 2.0 {
                let (_, lo, _) = f
                    .ranges
                    .iter()
                    .find(|r| r.0 == "pd")
                    .cloned()
                    .expect("pd range");
                let pd = f.get("pd").unwrap();
                // The interval's level: S (1 + t²/(m − p)).
                let dof = (f.samples_used - f.n_free) as f64;
                let t = fit::t_quantile(0.95, dof);
                let rise = 1.0 + t * t / dof;
                let one = ds.select(&ChannelSelect::Index(c)).unwrap();
                let held = |v: f64| {
                    let mut o = ts();
                    o.profile = false;
                    o.fix = vec![("pd".into(), v)];
                    fit::fit(&one, &o).unwrap()[0].cost
                };
                assert!(lo < pd, "{what}: range starts at {lo} above pd {pd}");
                let below_at = lo - 0.3 * (pd - lo);
                let (below, inside) = (held(below_at), held(0.5 * (lo + pd)));
                assert!(
                    below > rise * f.cost && inside <= rise * f.cost,
                    "{what}: pd interval starts at {lo}; held at {}: {below}, at {}: {inside}, limit {}",
                    below_at,
                    0.5 * (lo + pd),
                    rise * f.cost
                );
            } else {
                assert!(
                    (0.5..=2.0).contains(&ratio),
                    "{what}: pd/π is {ratio:.2} × the off-peak level"
                );
            }
        }
    }
}

#[test]
fn impossible_fits_are_errors_not_panics() {
    let one = |f: f64| {
        let mut ds = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
        for k in 0..50 {
            ds.push([0.5, 0.0, 0.02 * k as f64, 3.0], &[f]);
        }
        ds
    };
    // All at one incidence angle, n free.
    let e = fit::fit(&one(0.3), &ts()).unwrap_err();
    assert!(
        e.message.contains("θi = 28.65°")
            && e.setting == Some(brdfit::support::setting::Setting::Hold("n".into())),
        "{e}"
    );
    // ... is fine with n held.
    let mut o = ts();
    o.fix = vec![("n".into(), 1.5)];
    assert!(fit::fit(&one(0.3), &o).is_ok());
    // All zeros.
    let e = fit::fit(&one(0.0), &FitOptions::new(ModelKind::Phong)).unwrap_err();
    assert!(e.message.contains("every value is zero"), "{e}");
    // Fewer samples than parameters.
    let mut ds = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
    ds.push([0.5, 0.0, 0.5, 3.0], &[0.2]);
    ds.push([0.2, 0.0, 0.5, 3.0], &[0.2]);
    let e = fit::fit(&ds, &ts()).unwrap_err();
    assert!(
        e.message.contains("2 usable samples for 4 free parameters"),
        "{e}"
    );
    // A fixed parameter outside its bounds.
    let mut o = ts();
    o.fix = vec![("c3".into(), 2.0)];
    let e = fit::fit(&load("data/blinn-mgo.csv"), &o).unwrap_err();
    assert!(e.message.contains("c3 = 2 is outside its bounds"), "{e}");
    // An unknown parameter name.
    let mut o = FitOptions::new(ModelKind::Phong);
    o.fix = vec![("n".into(), 2.0)];
    assert!(fit::fit(&load("data/blinn-mgo.csv"), &o).is_err());
}

/// Every parameter held: no panic, and the reported cost is ½ Σ r² of the log loss computed
/// here sample by sample with the library's `ln_1p` (an independent path from the lane kernel).
#[test]
fn all_parameters_fixed_reports_the_cost_at_them() {
    let ds = load("data/blinn-mgo.csv");
    let mut o = ts();
    o.fix = vec![
        ("n".into(), 1.7),
        ("c3".into(), 0.3),
        ("ps".into(), 0.6),
        ("pd".into(), 0.4),
    ];
    let f = &fit::fit(&ds, &o).unwrap()[0];
    let m = Model::new(
        ModelKind::TorranceSparrow,
        Distribution::D3,
        &[1.7, 0.3, 0.6, 0.4],
    )
    .unwrap();
    let mut want = 0.0;
    for k in 0..ds.len() {
        let a = ds.angles(k);
        let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
        let r = (g.nl * m.brdf(&g)).ln_1p() - (g.nl * ds.channels[0].values[k]).ln_1p();
        want += 0.5 * r * r;
    }
    assert!(within(f.cost, want, 1e-12), "{} vs {want}", f.cost);
    assert!(f.stderr.iter().all(|s| *s == 0.0));
}

/// `fit_timed` (the `--repeat` of benchmarks) returns the same fit as one run: only the clock
/// is a median.
#[test]
fn repeated_fits_give_the_same_result() {
    let ds = load("data/blinn-mgo.csv");
    let mut o = ts();
    o.profile = false;
    let one = fit::fit(&ds, &o).unwrap().remove(0);
    let rep = fit::fit_timed(&ds, &o, 3).unwrap().remove(0);
    assert_eq!(one.params, rep.params);
    assert_eq!(one.cost, rep.cost);
    assert!(rep.seconds > 0.0 && rep.geometry_seconds <= rep.seconds);
    // One run's clock is its three stages (geometry, solve, statistics), each a real part;
    // with --repeat each is the median of its own column, each within the run's range.
    let stages = one.geometry_seconds + one.solve_seconds + one.statistics_seconds;
    assert!(
        (stages - one.seconds).abs() <= 1e-12 * one.seconds,
        "{stages} s in stages, {} s in all",
        one.seconds
    );
    for f in [&one, &rep] {
        assert!(f.geometry_seconds > 0.0 && f.solve_seconds > 0.0 && f.statistics_seconds > 0.0);
        assert!(f.solve_seconds < f.seconds && f.statistics_seconds < f.seconds);
    }
}

/// argmin's solvers run on the same problem as brdfit's (the in-Rust peers): on Blinn's MgO
/// every local one reaches the minimum Levenberg–Marquardt finds, and the swarm comes close
/// but is reported as stopped by its limit.
#[test]
fn argmin_methods_reach_the_minimum_on_blinn_mgo() {
    let ds = load("data/blinn-mgo.csv");
    let lm = fit::fit(&ds, &ts()).unwrap().remove(0);
    for method in lsq::Method::ALL.into_iter().filter(|m| m.is_argmin()) {
        let mut o = ts();
        o.method = method;
        let f = fit::fit(&ds, &o).unwrap().remove(0);
        assert_eq!(f.method, method);
        assert_eq!(
            serde_json::to_value(&f).unwrap()["method"],
            method.name(),
            "the JSON names the method"
        );
        let excess = (f.cost - lm.cost) / lm.cost;
        if method == lsq::Method::ArgminPso {
            assert!(excess < 0.05, "{method:?}: {excess}");
        } else {
            assert!(excess.abs() < 1e-6, "{method:?}: {} vs {}", f.cost, lm.cost);
        }
        // argmin's trust region has no convergence test and the swarm none that the
        // evaluation limit lets it reach: both say they stopped before converging.
        let stopped = f
            .warnings
            .iter()
            .any(|w| w.contains("stopped before converging"));
        let runs_to_a_limit = matches!(
            method,
            lsq::Method::ArgminTrustRegion | lsq::Method::ArgminPso
        );
        assert_eq!(stopped, runs_to_a_limit, "{method:?}: {:?}", f.warnings);
    }
}

/// Where an unconstrained argmin solver steps out of the admissible box (Blinn's aluminium:
/// from a start with ps near its bound 0, L-BFGS's line search tries ps < 0), the fit says
/// so, names the parameter, and is not shown as converged.
#[test]
fn an_argmin_step_out_of_the_box_is_reported() {
    let mut o = ts();
    o.method = lsq::Method::ArgminLbfgs;
    o.local_only = true;
    o.start = [("n", 1.2), ("c3", 0.3), ("ps", 1e-4), ("pd", 0.3)]
        .map(|(k, v)| (k.to_string(), v))
        .to_vec();
    let f = fit::fit(&load("data/blinn-aluminium.csv"), &o)
        .unwrap()
        .remove(0);
    assert!(
        f.termination.contains("left the bounds: ps = -"),
        "{}",
        f.termination
    );
    assert!(
        f.warnings
            .iter()
            .any(|w| w.contains("stopped before converging")),
        "{:?}",
        f.warnings
    );
    // The result is the best admissible point it evaluated.
    assert!(f.get("ps").unwrap() >= 0.0 && f.cost.is_finite());
    let lm = fit::fit(&load("data/blinn-aluminium.csv"), &ts())
        .unwrap()
        .remove(0);
    assert!(f.cost > lm.cost * 1.01, "{} vs {}", f.cost, lm.cost);
}

/// With a robust loss the certificate's best cost is in that loss (Σ ρ(r), here below the
/// declared ½ Σ r² of `cost`), and says so in the JSON and the printed fit.
#[test]
fn a_robust_certificate_names_its_loss() {
    let mut o = ts();
    o.robust = Some(fit::RobustKind::Huber);
    o.verify = 4;
    let f = fit::fit(&load("data/blinn-mgo.csv"), &o).unwrap().remove(0);
    let v = f.verification.as_ref().unwrap();
    assert_eq!(v.robust, "huber");
    // Huber's ρ(r) ≤ ½ r², so the robust minimum lies below the declared cost.
    assert!(v.best_cost <= f.cost, "{} vs {}", v.best_cost, f.cost);
    let json = serde_json::to_value(&f).unwrap();
    assert_eq!(json["verify_loss"], "huber");
    let back: FitResult = serde_json::from_value(json).unwrap();
    assert_eq!(back.verification.unwrap().robust, "huber");
    let plain = fit::fit(&load("data/blinn-mgo.csv"), &{
        let mut o = ts();
        o.verify = 2;
        o
    })
    .unwrap()
    .remove(0);
    assert!(
        serde_json::to_value(&plain)
            .unwrap()
            .get("verify_loss")
            .is_none()
    );
}

/// The polish stops at the data's resolution ([`fit::RESOLUTION`]): on a metal, whose
/// weakly determined index n makes the last steps crawl, every model's parameters end within
/// 0.01 standard errors of a polish run to ftol = 1e-14 (resolution 0), the cost within
/// 1e-8 of its cost, in fewer evaluations in all.
#[test]
fn the_polish_ends_at_the_data_resolution_within_a_hundredth_of_a_standard_error() {
    let ds = load("data/merl-aluminium.csv")
        .select(&ChannelSelect::Index(1))
        .unwrap();
    let (mut evals, mut evals_full) = (0, 0);
    for &kind in ModelKind::ALL {
        for &dist in kind.distributions() {
            let mut o = FitOptions::new(kind);
            o.dist = dist;
            o.profile = false;
            let f = &fit::fit(&ds, &o).unwrap()[0];
            o.resolution = 0.0;
            let full = &fit::fit(&ds, &o).unwrap()[0];
            let what = kind.label(dist);
            assert!(
                (f.cost - full.cost).abs() <= 1e-8 * full.cost,
                "{what}: {} vs {}",
                f.cost,
                full.cost
            );
            for (i, (name, v)) in full.params.iter().enumerate() {
                let se = full.stderr[i];
                let got = f.get(name).unwrap();
                assert!(
                    (got - v).abs() <= 0.01 * se,
                    "{what} {name}: {got} vs {v} ± {se}"
                );
            }
            evals += f.evaluations;
            evals_full += full.evaluations;
        }
    }
    assert!(evals < evals_full, "{evals} vs {evals_full}");
}

/// A fit stopped by its iteration limit says so in the flags of the compact table
/// (`unconverged`), not only in its warnings; a converged one does not.
#[test]
fn an_unconverged_fit_is_flagged() {
    let ds = load("data/blinn-mgo.csv");
    let done = &fit::fit(&ds, &ts()).unwrap()[0];
    assert!(
        !done.flags().contains(&"unconverged".to_string()),
        "{:?}",
        done.flags()
    );
    let mut o = ts();
    o.limits.max_iter = 1;
    o.profile = false;
    let cut = &fit::fit(&ds, &o).unwrap()[0];
    assert!(
        cut.warnings.iter().any(|w| w.contains("before converging")),
        "{:?}",
        cut.warnings
    );
    assert_eq!(cut.flags()[0], "unconverged", "{:?}", cut.flags());
}

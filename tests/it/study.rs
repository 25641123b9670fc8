//! Studies: the tables and charts hold what the runs produced.

use brdfit::data::{self, LoadOptions};
use brdfit::fit::lsq::Method;
use brdfit::model::Model;
use brdfit::study;

#[test]
fn speed_accuracy_covers_every_method_and_model() {
    let ds = data::load(
        std::path::Path::new("data/blinn-mgo.csv"),
        &LoadOptions::default(),
    )
    .unwrap();
    let truth = study::parse_truth(&ds).expect("the synthetic file carries its truth");
    assert_eq!(truth, Model::blinn_mgo());
    let rows = study::speed_accuracy(&ds, Some(&truth), 1);
    // Every method × every model with a lobe, except a solver that runs once (argmin's
    // swarm), which runs on torrance-sparrow (d3) alone.
    let models = study::study_models().len();
    let once = Method::ALL.iter().filter(|m| study::runs_once(**m)).count();
    let expected = (Method::ALL.len() - once) * models + once;
    assert_eq!(rows.len(), expected);
    for r in &rows {
        let m = Method::ALL.iter().find(|m| m.name() == r.method).unwrap();
        assert!(
            !study::runs_once(*m) || r.model == "torrance-sparrow (d3)",
            "{}",
            r.method
        );
    }
    // The true model family fits best, and its parameters are recovered (1 % noise).
    let best = rows
        .iter()
        .min_by(|a, b| a.cost.total_cmp(&b.cost))
        .unwrap();
    assert_eq!(best.model, "torrance-sparrow (d3)");
    // Every solver that converges recovers them within 2 %; the swarm, on its budget of one run,
    // stops above the minimum the others reach (the study's finding).
    for r in rows.iter().filter(|r| r.model == "torrance-sparrow (d3)") {
        let m = Method::ALL.iter().find(|m| m.name() == r.method).unwrap();
        if study::runs_once(*m) {
            assert!(
                r.cost > best.cost,
                "{}: {} ≤ {}",
                r.method,
                r.cost,
                best.cost
            );
        } else {
            assert!(
                r.param_error.unwrap() < 0.02,
                "{}: {:?}",
                r.method,
                r.param_error
            );
        }
    }
    // On the real rows: no point beats a front point in both time and cost.
    let chart = study::speed_chart("t", &rows);
    // With the truth in the file a third panel shows the parameter error of each solver.
    assert_eq!(chart.panels.len(), 3);
    assert_eq!(chart.panels[2].points.len(), Method::ALL.len());
    for p in &chart.panels[2].points {
        let r = rows
            .iter()
            .find(|r| r.method == p.method && r.model == p.model)
            .unwrap();
        assert_eq!(p.excess, r.param_error.unwrap().max(study::COST_FLOOR));
    }
    for panel in &chart.panels {
        let pts = &panel.points;
        for p in pts.iter().filter(|p| p.front) {
            assert!(
                !pts.iter()
                    .any(|q| q.seconds < p.seconds && q.excess < p.excess)
            );
        }
    }
    // On rows whose answer is known: gn reaches the same cost as lm but slower, so it is
    // dominated and off the front; nm is faster but worse, so it is on it.
    let row = |method: &str, model: &str, seconds: f64, cost: f64| study::SpeedRow {
        method: method.into(),
        model: model.into(),
        seconds,
        work: 0.0,
        cost,
        param_error: None,
        termination: String::new(),
    };
    let known = vec![
        row("lm", "torrance-sparrow (d3)", 0.01, 1.0),
        row("gn", "torrance-sparrow (d3)", 0.02, 1.0),
        row("nm", "torrance-sparrow (d3)", 0.005, 2.0),
        row("lm", "phong", 0.001, 5.0),
        row("nm", "phong", 0.003, 4.0),
    ];
    let chart = study::speed_chart("known", &known);
    assert_eq!(chart.panels.len(), 2, "no truth, no parameter-error panel");
    let front = |panel: usize| -> Vec<String> {
        chart.panels[panel]
            .points
            .iter()
            .filter(|p| p.front)
            .map(|p| format!("{} {}", p.method, p.model))
            .collect()
    };
    assert_eq!(
        front(0),
        ["lm torrance-sparrow (d3)", "nm torrance-sparrow (d3)"]
    );
    // Each model with its best solver: TS by lm (cost 1), Phong by nm (cost 4); both on the
    // front (Phong is faster, TS lower).
    let best: Vec<(String, String)> = chart.panels[1]
        .points
        .iter()
        .map(|p| (p.model.clone(), p.method.clone()))
        .collect();
    assert_eq!(
        best,
        [
            ("torrance-sparrow (d3)".into(), "lm".into()),
            ("phong".into(), "nm".into())
        ]
    );
    assert_eq!(front(1).len(), 2);
    // The best point sits on the floor of the log axis; the others at their relative excess.
    assert_eq!(chart.panels[0].points[0].excess, study::COST_FLOOR);
    assert!((chart.panels[0].points[2].excess - 1.0).abs() < 1e-12);
    let dir = tempfile::tempdir().unwrap();
    brdfit::plot::save(&chart, &dir.path().join("speed")).unwrap();
    let (md, csv) = study::speed_tables(&rows, false);
    assert_eq!(md.lines().count(), 2 + expected);
    assert_eq!(csv.lines().count(), 1 + expected);
    assert!(!csv.contains("seconds"));
}

#[test]
fn stability_counts_starts_per_configuration() {
    let rows = study::stability(&Model::blinn_mgo(), 2, 1500, 3);
    let methods = Method::ALL.len();
    assert_eq!(rows.len(), 16 * 2 * methods);
    // The rows are serde values: written and read back equal.
    let text = serde_json::to_string(&rows).unwrap();
    let back: Vec<study::StabilityRow> = serde_json::from_str(&text).unwrap();
    assert_eq!(back, rows);
    // Two starts per configuration; one for a solver that runs once (argmin's swarm).
    assert!(rows.iter().all(|r| {
        let want = if study::runs_once(r.method) {
            study::ONCE_STARTS
        } else {
            2
        };
        r.starts == want && r.hits <= want
    }));
    // With the global initialisation LM reaches the minimum on the full hemisphere at 1 % noise.
    let r = rows
        .iter()
        .find(|r| {
            r.noise == 0.01
                && r.pattern == study::Pattern::Hemisphere
                && r.method == Method::Lm
                && r.global
        })
        .unwrap();
    assert_eq!(r.hits, 2);
    let (md, csv) = study::stability_tables(&rows);
    assert_eq!(md.lines().count(), 18);
    assert_eq!(csv.lines().count(), 1 + 16 * 2 * methods);
    // Every start ends one way: reached, wrong basin, stalled, at a bound or non-finite.
    assert!(
        rows.iter()
            .all(|r| r.hits + r.wrong_basin + r.stalled + r.at_bound + r.failures == r.starts)
    );
    // Each heatmap cell is the count the CSV gives for its configuration and column, in the
    // panel of its initialisation; and the Markdown cell gives both.
    let chart = study::stability_chart("t", &rows);
    assert_eq!((chart.rows.len(), chart.cols.len()), (16, methods));
    assert_eq!(chart.panels.len(), 2);
    let mut n = 0;
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let config: usize = f[0].parse().unwrap();
        let col = chart.cols.iter().position(|m| m.name() == f[3]).unwrap();
        let panel = chart
            .panels
            .iter()
            .find(|p| p.1.to_string() == f[4])
            .unwrap();
        let cell = &panel.2[(config - 1) * methods + col];
        assert_eq!(
            (cell.0.to_string(), cell.1.to_string()),
            (f[5].into(), f[6].into()),
            "{line}"
        );
        assert!(cell.2.starts_with(&format!("{}/{}", f[5], f[6])));
        let md_row: Vec<&str> = md.lines().nth(1 + config).unwrap().split('|').collect();
        let both: Vec<&str> = md_row[4 + col].trim().split(" · ").collect();
        let k = if f[4] == "true" { 0 } else { 1 };
        assert_eq!(both[k], format!("{}/{}", f[5], f[6]), "{line}");
        n += 1;
    }
    assert_eq!(n, 16 * 2 * methods);
    let dir = tempfile::tempdir().unwrap();
    brdfit::plot::save(&chart, &dir.path().join("h")).unwrap();
}

/// The Pareto front: dominated points are off it, and a slower point whose y equals a faster
/// one's to 1e-6 relative (the same minimum) is dominated.
#[test]
fn pareto_front_of_known_points() {
    let pts = [
        (1.0, 1.0),
        (2.0, 1.0 - 1e-9),
        (0.5, 3.0),
        (3.0, 0.5),
        (4.0, 0.6),
    ];
    assert_eq!(study::pareto(&pts), [2, 0, 3]);
}

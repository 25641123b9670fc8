//! `fit --residuals OUT.csv`: every sample a fit used with its model value and residual. The
//! checks are independent of the writer: ½ Σ weight · residual² against the cost the fit
//! reports in its JSON, the model column against `Model::brdf` built from the JSON's
//! parameters, the residual against the loss's formula applied to the file's two value
//! columns, and a fit whose answer is worked by hand (a weighted mean).

use super::cli::{brdfit, expect_error};
use crate::common::write;
use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use std::collections::BTreeMap;
use std::path::Path;

/// The CSV's rows as column name → text.
fn read_rows(p: &Path) -> Vec<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(p).unwrap();
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_reader(text.as_bytes());
    let head: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            head.iter()
                .cloned()
                .zip(rec.iter().map(str::to_string))
                .collect()
        })
        .collect()
}

fn num(row: &BTreeMap<String, String>, k: &str) -> f64 {
    row[k].parse().unwrap_or_else(|_| panic!("{k}: {}", row[k]))
}

/// The model of one fit object of a fit JSON, built from its `params` by name (a joint fit's
/// per-channel names carry `_<channel>`).
fn model_of(fit: &serde_json::Value, channel: &str) -> Model {
    let kind = ModelKind::parse(fit["model"].as_str().unwrap()).unwrap();
    let dist = Distribution::parse(fit["distribution"].as_str().unwrap()).unwrap();
    let suffix = format!("_{channel}");
    let set: Vec<(String, f64)> = fit["params"]
        .as_object()
        .unwrap()
        .iter()
        .filter_map(|(k, v)| {
            let name = k.strip_suffix(&suffix).unwrap_or(k);
            kind.param_names(dist)
                .contains(&name)
                .then(|| (name.to_string(), v.as_f64().unwrap()))
        })
        .collect();
    Model::from_named(kind, dist, &set).unwrap()
}

/// The f_r of `m` at a row's angles (degrees in the file).
fn brdf_at(m: &Model, row: &BTreeMap<String, String>) -> f64 {
    let a =
        ["theta_i_deg", "phi_i_deg", "theta_o_deg", "phi_o_deg"].map(|k| num(row, k).to_radians());
    m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]))
}

/// Check the rows of one fit: their count is the fit's samples, ½ Σ w r² its cost, the model
/// column `Model::brdf` of its parameters and the residual the loss's formula.
fn check_fit(fit: &serde_json::Value, rows: &[&BTreeMap<String, String>]) {
    let label = format!("{} {}", fit["model"], fit["channel"]);
    assert_eq!(
        rows.len() as u64,
        fit["samples_used"].as_u64().unwrap(),
        "{label}: rows"
    );
    let log = fit["loss"] == "log";
    let mut s = 0.0;
    for r in rows {
        let m = model_of(fit, &r["channel"]);
        let (f, v, res, w) = (
            num(r, "model_brdf"),
            num(r, "measured_brdf"),
            num(r, "residual"),
            num(r, "weight"),
        );
        let want = brdf_at(&m, r);
        // The file's angles are rounded to 1e-11°: on a sharp peak f moves in its 12th digit.
        assert!(
            (f - want).abs() <= 1e-9 * want.abs().max(1e-3),
            "{label}: {f} vs {want}"
        );
        let ci = num(r, "theta_i_deg").to_radians().cos();
        let by_hand = if log {
            (ci * f).ln_1p() - (ci * v).ln_1p()
        } else {
            f - v
        };
        assert!(
            (res - by_hand).abs() < 1e-12,
            "{label}: residual {res} vs {by_hand}"
        );
        s += w * res * res;
    }
    // The fit's cost comes from its own vectorised kernels, the rows from `Model::brdf`: in
    // the linear loss on MERL alumina-oxide's peak (f_r in the hundreds) they part in the 9th
    // digit (2.9e-9), elsewhere in the 12th or beyond.
    let cost = fit["cost"].as_f64().unwrap();
    assert!(
        (s - 2.0 * cost).abs() <= 1e-8 * (2.0 * cost),
        "{label}: Σ w r² = {s}, 2 cost = {}",
        2.0 * cost
    );
}

/// Blinn's MgO, one fit in the log loss: every sample is a row, and the rows hold the fit.
#[test]
fn residuals_of_one_fit_sum_to_twice_its_cost() {
    let dir = tempfile::tempdir().unwrap();
    let (json, res) = (dir.path().join("f.json"), dir.path().join("r.csv"));
    let out = brdfit(&[
        "fit",
        "data/blinn-mgo.csv",
        "--json",
        json.to_str().unwrap(),
        "--residuals",
        res.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains(&format!("wrote {}", res.display())), "{err}");
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = read_rows(&res);
    assert!(!rows[0].contains_key("model"), "one model: no model column");
    // The measured column is the data file's value (f_r) at the same angles, in file order.
    let data = crate::common::load("data/blinn-mgo.csv");
    assert_eq!(rows.len(), data.len());
    for (k, r) in rows.iter().enumerate().step_by(97) {
        assert_eq!(num(r, "measured_brdf"), data.channels[0].values[k]);
        let a = data.angles(k);
        assert!((num(r, "theta_o_deg") - a[2].to_degrees()).abs() < 1e-9);
    }
    check_fit(&fit, &rows.iter().collect::<Vec<_>>());
}

/// `--model all` on three channels, weighted by solid angle, linear loss, beyond 70° dropped:
/// a `model` column, and each (model, channel) group holds its own fit. A joint fit of the
/// three channels (`--shared`) holds its cost over all three.
#[test]
fn residuals_of_every_model_and_a_joint_fit() {
    let dir = tempfile::tempdir().unwrap();
    let (json, res) = (dir.path().join("f.json"), dir.path().join("r.csv"));
    let args = |extra: &[&str]| {
        let mut v = vec![
            "fit",
            "data/merl-alumina-oxide.csv",
            "--weights",
            "solid-angle",
            "--loss",
            "linear",
            "--max-theta",
            "70",
            "--json",
            json.to_str().unwrap(),
            "--residuals",
            res.to_str().unwrap(),
        ];
        v.extend_from_slice(extra);
        let out = brdfit(&v);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let fits: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        (fits, read_rows(&res))
    };
    let (fits, rows) = args(&["--model", "all"]);
    let fits = fits["fits"].as_array().unwrap().clone();
    assert!(fits.len() >= 18, "{} fits", fits.len());
    assert!(
        rows.iter()
            .all(|r| num(r, "theta_i_deg") <= 70.0 && num(r, "theta_o_deg") <= 70.0)
    );
    assert!(rows.iter().any(|r| num(r, "weight") != 1.0));
    let mut labels: Vec<&str> = rows.iter().map(|r| r["model"].as_str()).collect();
    labels.dedup();
    assert_eq!(labels.len(), fits.len() / 3, "{labels:?}");
    for f in &fits {
        let kind = ModelKind::parse(f["model"].as_str().unwrap()).unwrap();
        let dist = Distribution::parse(f["distribution"].as_str().unwrap()).unwrap();
        let label = kind.label(dist);
        let group: Vec<_> = rows
            .iter()
            .filter(|r| r["model"] == label && r["channel"] == f["channel"].as_str().unwrap())
            .collect();
        check_fit(f, &group);
    }
    // The joint fit: channel "r,g,b", per-channel ps and pd, one cost.
    let (fit, rows) = args(&["--shared", "n,c3"]);
    assert_eq!(fit["channel"], "r,g,b");
    let mut channels: Vec<&str> = rows.iter().map(|r| r["channel"].as_str()).collect();
    channels.dedup();
    assert_eq!(channels, ["r", "g", "b"]);
    check_fit(&fit, &rows.iter().collect::<Vec<_>>());
}

/// A fit worked by hand: Lambert (f = pd/π) in the linear loss on four samples weighted 1, 1,
/// 1, 3 is their weighted mean, (0.1 + 0.2 + 0.3 + 3·0.4)/6 = 0.3, so the residuals are 0.2,
/// 0.1, 0 and −0.1; a sample beyond --max-theta and a missing value are not rows.
#[test]
fn residuals_of_a_fit_worked_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let data = write(
        dir.path(),
        "d.csv",
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf,weight\n\
          10,0,20,180,0.1,1\n\
          20,0,30,90,0.2,1\n\
          30,0,10,0,0.3,1\n\
          40,0,50,200,0.4,3\n\
          75,0,10,180,5,1\n\
          15,0,15,180,,1\n",
    );
    let res = dir.path().join("r.csv");
    let out = brdfit(&[
        "fit",
        data.to_str().unwrap(),
        "--model",
        "lambert",
        "--loss",
        "linear",
        "--max-theta",
        "60",
        "--residuals",
        res.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = read_rows(&res);
    let got: Vec<[f64; 4]> = rows
        .iter()
        .map(|r| ["measured_brdf", "model_brdf", "residual", "weight"].map(|k| num(r, k)))
        .collect();
    let want = [
        [0.1, 0.3, 0.2, 1.0],
        [0.2, 0.3, 0.1, 1.0],
        [0.3, 0.3, 0.0, 1.0],
        [0.4, 0.3, -0.1, 3.0],
    ];
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (g, w) in got.iter().zip(&want) {
        for (a, b) in g.iter().zip(w) {
            assert!((a - b).abs() < 1e-6, "{g:?} vs {w:?}");
        }
    }
    assert_eq!(rows[3]["theta_i_deg"], "40");
    assert_eq!(rows[3]["phi_o_deg"], "200");
}

/// The output rule: an input as output is refused before any fit (the input unchanged), an
/// existing file is replaced, several data files are refused with the fix.
#[test]
fn residuals_output_rules() {
    let dir = tempfile::tempdir().unwrap();
    let src = std::fs::read(crate::common::root().join("data/blinn-mgo.csv")).unwrap();
    let data = write(dir.path(), "d.csv", &src);
    expect_error(
        &[
            "fit",
            data.to_str().unwrap(),
            "--residuals",
            data.to_str().unwrap(),
        ],
        &["d.csv"],
    );
    assert_eq!(std::fs::read(&data).unwrap(), src);
    let res = write(dir.path(), "r.csv", b"old");
    let out = brdfit(&[
        "fit",
        data.to_str().unwrap(),
        "--residuals",
        res.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    assert!(
        std::fs::read_to_string(&res)
            .unwrap()
            .contains("measured_brdf")
    );
    expect_error(
        &[
            "fit",
            data.to_str().unwrap(),
            "data/blinn-aluminium.csv",
            "--residuals",
            res.to_str().unwrap(),
        ],
        &["2 data files", "fix: fit each file on its own"],
    );
    expect_error(
        &[
            "fit",
            data.to_str().unwrap(),
            "--json",
            res.to_str().unwrap(),
            "--residuals",
            res.to_str().unwrap(),
        ],
        &["also the --json output"],
    );
}

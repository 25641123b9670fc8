//! `eval --fit FIT.json`: the fitted model evaluated at a CSV's directions. Checked against
//! `eval` with the same parameters typed on the command line, against values worked by hand
//! (Lambert's pd/π) and `Model::brdf` for a fit file written by hand, and the refusal of a
//! file of several fits that names the choices and the flag that picks each.

use super::cli::{brdfit, expect_error};
use crate::common::{fit_object, write};
use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use std::path::Path;

/// The data lines of an eval output (the `#` comment names where the model came from).
fn values(out: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(out)
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(str::to_string)
        .collect()
}

/// The brdf column of an eval output.
fn brdf(out: &[u8]) -> Vec<f64> {
    values(out)[1..]
        .iter()
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect()
}

fn directions(dir: &Path) -> std::path::PathBuf {
    write(
        dir,
        "dirs.csv",
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n30,0,30,180\n70,0,60,180\n10,40,80,100\n45,0,45,0\n",
    )
}

/// A fit of Blinn's MgO written by `fit --json`, evaluated from the file and with its
/// parameters given by hand (`--set`, each value as the JSON holds it): the same table.
#[test]
fn eval_of_a_fit_file_equals_eval_of_its_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("f.json");
    let dirs = directions(dir.path());
    assert!(
        brdfit(&[
            "fit",
            "data/blinn-mgo.csv",
            "--json",
            json.to_str().unwrap()
        ])
        .status
        .success()
    );
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let set: Vec<String> = fit["params"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| format!("{k}={}", v.as_f64().unwrap()))
        .collect();
    let by_hand = brdfit(&[
        "eval",
        "--model",
        "torrance-sparrow",
        "--set",
        &set.join(","),
        dirs.to_str().unwrap(),
    ]);
    let from_file = brdfit(&[
        "eval",
        "--fit",
        json.to_str().unwrap(),
        dirs.to_str().unwrap(),
    ]);
    assert!(
        from_file.status.success(),
        "{}",
        String::from_utf8_lossy(&from_file.stderr)
    );
    assert_eq!(values(&from_file.stdout), values(&by_hand.stdout));
    assert_eq!(values(&from_file.stdout).len(), 5);
    // The comment says where the model came from.
    assert!(String::from_utf8_lossy(&from_file.stdout).contains("(from "));
    // -o writes the same table, announced; the fit file as output is refused.
    let out = dir.path().join("out.csv");
    let o = brdfit(&[
        "eval",
        "--fit",
        json.to_str().unwrap(),
        dirs.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("wrote"));
    assert_eq!(
        values(&std::fs::read(&out).unwrap()),
        values(&by_hand.stdout)
    );
    let before = std::fs::read(&json).unwrap();
    expect_error(
        &[
            "eval",
            "--fit",
            json.to_str().unwrap(),
            dirs.to_str().unwrap(),
            "-o",
            json.to_str().unwrap(),
        ],
        &["f.json"],
    );
    assert_eq!(std::fs::read(&json).unwrap(), before);
    // --set beside --fit is a usage error: the parameters come from one place.
    let e = brdfit(&[
        "eval",
        "--fit",
        json.to_str().unwrap(),
        "--set",
        "n=2",
        dirs.to_str().unwrap(),
    ]);
    assert_eq!(e.status.code(), Some(2));
}

/// A file of several fits written by hand (Lambert and Phong of channels r and g): refused
/// without --model, then without --channel, each listing the choices with their flags; with
/// both, Lambert g gives pd/π at every direction (pd 0.5: 0.5/π = 0.159154943…) and Phong r
/// what `Model::brdf` gives for its parameters.
#[test]
fn eval_picks_one_fit_of_several_or_names_the_flags() {
    let dir = tempfile::tempdir().unwrap();
    let dirs = directions(dir.path());
    let lam = |c: &str, pd: f64| {
        fit_object("lambert", "d3", c, &format!(r#"{{"pd": {pd}}}"#), "")
            .replace("\"n_free\": 4", "\"n_free\": 1")
    };
    let phong = |c: &str| {
        fit_object("phong", "d3", c, r#"{"c1": 20, "ps": 0.3, "pd": 0.4}"#, "")
            .replace("\"n_free\": 4", "\"n_free\": 3")
    };
    let body = format!(
        r#"{{"fits": [{}, {}, {}, {}]}}"#,
        lam("r", 0.3),
        lam("g", 0.5),
        phong("r"),
        phong("g")
    );
    let f = write(dir.path(), "several.json", body.as_bytes());
    let (fs, ds) = (f.to_str().unwrap(), dirs.to_str().unwrap());
    expect_error(
        &["eval", "--fit", fs, ds],
        &["2 models", "--model lambert | --model phong"],
    );
    expect_error(
        &["eval", "--fit", fs, "--model", "lambert", ds],
        &["2 channels", "--channel r | --channel g"],
    );
    // --channel alone still leaves two models.
    expect_error(
        &["eval", "--fit", fs, "--channel", "g", ds],
        &["--model lambert"],
    );
    let out = brdfit(&[
        "eval",
        "--fit",
        fs,
        "--model",
        "lambert",
        "--channel",
        "g",
        ds,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for v in brdf(&out.stdout) {
        assert!((v - 0.159_154_943_091_895_35).abs() < 1e-15, "{v}");
    }
    let out = brdfit(&[
        "eval",
        "--fit",
        fs,
        "--model",
        "phong",
        "--channel",
        "r",
        ds,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m = Model::new(ModelKind::Phong, Distribution::D3, &[20.0, 0.3, 0.4]).unwrap();
    let dirs_deg = [
        [30.0, 0.0, 30.0, 180.0],
        [70.0, 0.0, 60.0, 180.0],
        [10.0, 40.0, 80.0, 100.0],
        [45.0, 0.0, 45.0, 0.0],
    ];
    for (v, a) in brdf(&out.stdout).iter().zip(dirs_deg) {
        let a = a.map(|x: f64| x.to_radians());
        let want = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        assert!((v - want).abs() <= 1e-12 * want, "{v} vs {want}");
    }
    // A model the file does not hold: the library's message names what it holds.
    expect_error(
        &[
            "eval",
            "--fit",
            fs,
            "--model",
            "ggx-smith",
            "--channel",
            "r",
            ds,
        ],
        &["lambert"],
    );
}

//! `fit` on the command line and the files it writes: repeats and verification, the README's
//! tour, every consumer reading fit files strictly, using the recommended model or the one
//! asked, refusing another channel's fit; the polish, its flags, nothing written on failure.

use super::cli::{brdfit, expect_error, expect_usage_error};
use crate::common::{fit_object, write};
use std::path::Path;
use std::process::Command;

/// `fit --repeat N` fits N times in one process and reports the median time; the fit itself
/// is identical to a single run (same parameters and cost to the last bit), and N is bounded.
#[test]
fn fit_repeat_gives_the_same_fit() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one.json");
    let many = dir.path().join("many.json");
    let f = "data/blinn-mgo.csv";
    assert!(
        brdfit(&["fit", f, "--json", one.to_str().unwrap()])
            .status
            .success()
    );
    let out = brdfit(&["fit", f, "--repeat", "3", "--json", many.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (a, b) = (read(&one), read(&many));
    assert_eq!(a["params"], b["params"]);
    assert_eq!(a["cost"], b["cost"]);
    assert!(b["seconds"].as_f64().unwrap() > 0.0);
    // The geometry pass is part of the fit's time (each the median of its own column).
    for v in [&a, &b] {
        let (t, g) = (
            v["seconds"].as_f64().unwrap(),
            v["geometry_seconds"].as_f64().unwrap(),
        );
        assert!(g > 0.0 && g < t, "geometry {g} s of {t} s");
    }
    assert_eq!(brdfit(&["fit", f, "--repeat", "0"]).status.code(), Some(2));
}

/// `fit --verify K` runs the certificate and writes it to the JSON with the bound report; the
/// three real cases reach their minima from the command line (costs from the best of 8 bounded
/// multi-start fits by an independent program, scipy's least_squares: tests/data/REFERENCES.md).
#[test]
fn fit_verify_writes_the_certificate_and_real_cases_reach_their_minima() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("data/cayman.astm", "550nm", "torrance-sparrow", 0.0597),
        (
            "tests/data/merl-chrome.csv",
            "g",
            "torrance-sparrow",
            7.46105,
        ),
        (
            "tests/data/colodur_napoli_4f_rgb.csv",
            "g",
            "blinn-phong",
            2.0266,
        ),
    ];
    for (k, (file, channel, model, best)) in cases.iter().enumerate() {
        let json = dir.path().join(format!("fit{k}.json"));
        let out = brdfit(&[
            "fit",
            file,
            "--channel",
            channel,
            "--model",
            model,
            "--verify",
            "8",
            "--json",
            json.to_str().unwrap(),
        ]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains("verification: 8 random starts"), "{text}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(v["verified"], serde_json::json!(true), "{file}");
        assert_eq!(v["verify_starts"], serde_json::json!(8));
        assert_eq!(v["unusable"], serde_json::json!([]));
        assert!(v["at_bound"].is_object());
        let cost = v["cost"].as_f64().unwrap();
        // The independent minimum is known to 3–6 digits.
        assert!(cost <= best * 1.001, "{file}: cost {cost}, minimum {best}");
    }
}

/// A library error is printed once, says what to change in its own words, and the command line
/// adds the flag that changes it.
#[test]
fn errors_print_once_with_the_flag() {
    let out = brdfit(&[
        "fit",
        "data/cayman.astm",
        "--channel",
        "550nm",
        "--max-theta",
        "1",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.matches("error:").count(), 1, "{err}");
    assert!(err.contains("0 usable samples"), "{err}");
    assert!(err.contains("on the command line: --max-theta"), "{err}");
}

/// The README's tour, run twice in a row in an empty folder: every command succeeds both
/// times (an existing output is replaced), every command that writes says `wrote PATH`, and
/// a folder made for the outputs is named (`created DIR/`) the first time only.
#[test]
fn readme_tour_runs_twice() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let tour = readme.split("## A short tour").nth(1).unwrap();
    let block = tour
        .split("```sh")
        .nth(1)
        .unwrap()
        .split("```")
        .next()
        .unwrap();
    let commands: Vec<Vec<String>> = block
        .lines()
        .filter_map(|l| {
            l.split('#')
                .next()
                .unwrap()
                .trim()
                .strip_prefix("cargo run --release --")
        })
        .map(|rest| {
            rest.split_whitespace()
                .map(|a| match a.strip_prefix("data/") {
                    Some(f) => root.join("data").join(f).display().to_string(),
                    None => a.to_string(),
                })
                .collect()
        })
        .collect();
    assert!(commands.len() >= 6, "{commands:?}");
    let dir = tempfile::tempdir().unwrap();
    for round in 0..2 {
        let mut created = 0;
        for args in &commands {
            let o = Command::new(env!("CARGO_BIN_EXE_brdfit"))
                .args(args)
                .current_dir(dir.path())
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(o.status.success(), "round {round}: {args:?}: {err}");
            let writes = args.iter().any(|a| a == "-o" || a == "--json");
            let prints_to_stdout = args[0] == "export" && !args.iter().any(|a| a == "-o");
            if writes && !prints_to_stdout {
                assert!(
                    err.contains("wrote "),
                    "round {round}: {args:?} says nothing of its files: {err}"
                );
                for line in err.lines().filter_map(|l| l.strip_prefix("wrote ")) {
                    let p = dir.path().join(line.split(" (").next().unwrap());
                    assert!(
                        p.exists(),
                        "{args:?} says it wrote {line}, which is missing"
                    );
                }
            }
            // A folder made for the outputs is named once, when it is made.
            for line in err.lines().filter_map(|l| l.strip_prefix("created ")) {
                assert!(
                    line.ends_with('/') && dir.path().join(line).is_dir(),
                    "{args:?}: {line}"
                );
                created += 1;
            }
        }
        // The first pass makes the tour's folders (fig7, choose, …); the second finds them.
        assert_eq!(
            created > 0,
            round == 0,
            "round {round}: {created} folders named"
        );
    }
}

/// One name for a file's single unnamed channel everywhere: the quantity's column (`brdf`),
/// in the summary, the fit table and the fit JSON.
#[test]
fn single_channel_has_one_name() {
    let o = brdfit(&["info", "data/blinn-mgo.csv"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("channels:    1 (brdf)"));
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("f.json");
    let o = brdfit(&[
        "fit",
        "data/blinn-mgo.csv",
        "--json",
        json.to_str().unwrap(),
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("on channel brdf"), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["channel"], "brdf");
    assert!(!out.contains("(single)") && !out.contains("channel value"));
}

/// A fit file of many channels (cayman, 31 wavelengths) draws one lobe, the data's channel,
/// and says so; the legend no longer lists 31 fits over the plot.
#[test]
fn lobe_of_a_many_channel_fit_draws_the_data_channel() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("cay.json");
    let o = brdfit(&[
        "fit",
        "data/cayman.astm",
        "-q",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let base = dir.path().join("lobe");
    let o = brdfit(&[
        "plot",
        "lobe",
        "--fit",
        json.to_str().unwrap(),
        "--data",
        "data/cayman.astm",
        "--channel",
        "550nm",
        "-o",
        base.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    // The channel was asked for, so nothing was chosen for the user.
    assert!(!err.contains("note:"), "{err}");
    let svg = std::fs::read_to_string(base.with_extension("svg")).unwrap();
    assert!(svg.contains("fit (550nm)"));
    assert!(!svg.contains("fit (400nm)") && !svg.contains("fit (560nm)"));
}

const MGO: &str = r#"{"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333}"#;

/// Every hand-edited fit file is refused by every consumer with the key named and
/// the fix (exit 1, never a panic); the unedited file is accepted.
#[test]
fn fit_files_are_read_strictly_by_every_consumer() {
    let dir = tempfile::tempdir().unwrap();
    let ts =
        |params: &str, extra: &str| fit_object("torrance-sparrow", "d3", "brdf", params, extra);
    let ggx = |params: &str| fit_object("ggx-smith", "d3", "brdf", params, "");
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "pd_neg",
            ts(r#"{"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": -1}"#, ""),
            vec!["params.pd = -1", "pd ≥ 0"],
        ),
        (
            "n_half",
            ts(r#"{"n": 0.5, "c3": 0.35, "ps": 0.667, "pd": 0.333}"#, ""),
            vec!["params.n = 0.5", "1 < n ≤ 1e7"],
        ),
        (
            "c3_neg",
            ts(r#"{"n": 1.8, "c3": -0.3, "ps": 0.667, "pd": 0.333}"#, ""),
            vec!["params.c3 = -0.3", "0 < c3 ≤ 1"],
        ),
        (
            "ps_neg",
            ts(r#"{"n": 1.8, "c3": 0.35, "ps": -0.5, "pd": 0.333}"#, ""),
            vec!["params.ps = -0.5", "ps ≥ 0"],
        ),
        (
            "alpha5",
            ggx(r#"{"alpha": 5, "n": 1.5, "ps": 0.5, "pd": 0.3}"#),
            vec!["params.alpha = 5", "alpha ≤ 1"],
        ),
        (
            "params_empty",
            ts("{}", ""),
            vec!["parameter 'n'", "is missing", "add \"n\""],
        ),
        (
            "missing",
            ts(r#"{"n": 1.8, "ps": 0.667, "pd": 0.333}"#, ""),
            vec!["parameter 'c3'", "is missing"],
        ),
        (
            "dist",
            fit_object("torrance-sparrow", "d7", "brdf", MGO, ""),
            vec!["key 'distribution'", "d7", "d1, d2, d3, abc"],
        ),
        (
            "param_unknown",
            ts(
                r#"{"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333, "q": 2}"#,
                "",
            ),
            vec!["unknown parameter 'q'", "remove it"],
        ),
        (
            "key_unknown",
            ts(MGO, r#", "colour": "red""#),
            vec!["unknown key 'colour'", "remove it"],
        ),
        (
            "dup",
            ts(
                r#"{"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333, "n": 9}"#,
                "",
            ),
            vec!["duplicate key 'n'", "line 2", "keep one"],
        ),
        (
            "nan",
            ts(r#"{"n": 1.8, "c3": null, "ps": 0.667, "pd": 0.333}"#, ""),
            vec!["params.c3 is null", "not a finite number"],
        ),
        (
            "unusable",
            ts(MGO, r#", "unusable": ["KKT check failed"]"#),
            vec!["marked not usable: KKT check failed", "--allow-unusable"],
        ),
        (
            "unverified",
            ts(
                MGO,
                r#", "verified": false, "verify_starts": 8, "verify_best_cost": 0.5"#,
            ),
            vec!["verified: false", "--allow-unusable"],
        ),
        (
            "pd_above_1",
            ts(r#"{"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 1.5}"#, ""),
            vec!["pd = 1.5 > 1", "--allow-unusable"],
        ),
        (
            "fits_empty",
            r#"{"fits": []}"#.into(),
            vec!["'fits' is an empty list"],
        ),
        (
            "not_object",
            "[1, 2]".into(),
            vec!["is a list, not an object"],
        ),
        (
            "model",
            fit_object("torrance-sparow", "d3", "brdf", MGO, ""),
            vec!["unknown model 'torrance-sparow'", "ggx-smith"],
        ),
    ];
    let good = write(dir.path(), "good.json", ts(MGO, "").as_bytes());
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    // Commands that write a folder get their own name: a file output may not name a folder.
    let folder = dir.path().join("folder");
    let od = folder.to_str().unwrap();
    let consumers = |f: &str| -> Vec<Vec<String>> {
        let v = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        vec![
            v(&["export", f, "--to", "mitsuba"]),
            v(&["export", f, "--to", "merl", "-o", &format!("{o}.binary")]),
            v(&["plot", "lobe", "--fit", f, "-o", o]),
            v(&[
                "plot",
                "residuals",
                "--fit",
                f,
                "data/blinn-mgo.csv",
                "-o",
                od,
            ]),
            v(&["plot", "slice", "--fit", f, "data/blinn-mgo.csv", "-o", o]),
            v(&["plot", "albedo", "--fit", f, "-o", o]),
            v(&["render", "fig7", "--mgo", f, "--res", "8", "-o", od]),
            v(&[
                "inverse",
                "no-such.png",
                "--row",
                "1",
                "--light",
                "0,0,1",
                "--fit",
                f,
                "-o",
                o,
            ]),
        ]
    };
    for (name, body, fragments) in &cases {
        let f = write(dir.path(), &format!("{name}.json"), body.as_bytes());
        let f = f.to_str().unwrap();
        for args in consumers(f) {
            let a: Vec<&str> = args.iter().map(String::as_str).collect();
            if a[0] == "inverse" {
                // The image is read first; the fit's errors are the same function's.
                continue;
            }
            let mut frags = vec![f, "fix:"];
            frags.extend(fragments.iter().copied());
            expect_error(&a, &frags);
        }
    }
    // The unedited file is used by every consumer that needs no image.
    for args in consumers(good.to_str().unwrap()) {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        if a[0] == "inverse" {
            continue;
        }
        let r = brdfit(&a);
        assert!(
            r.status.success(),
            "{a:?}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
    }
    // --allow-unusable takes a fit marked not usable, and says so.
    let f = dir.path().join("unusable.json");
    let r = brdfit(&[
        "export",
        f.to_str().unwrap(),
        "--to",
        "mitsuba",
        "--allow-unusable",
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(err.contains("although it is marked not usable"), "{err}");
}

/// A `--model all` file gives every consumer its recommended model (said on
/// stderr), not the first fit; `--model` picks another.
#[test]
fn consumers_use_the_recommended_model_or_the_one_asked() {
    let dir = tempfile::tempdir().unwrap();
    // Lambert first, ggx-smith recommended (lowest BIC by far), torrance-sparrow between.
    let lambert =
        fit_object("lambert", "d3", "cie-y", r#"{"pd": 0.25}"#, "").replace("-5000.0", "-100.0");
    let ggx = fit_object(
        "ggx-smith",
        "d3",
        "cie-y",
        r#"{"alpha": 0.2, "n": 1.5, "ps": 0.5, "pd": 0.25}"#,
        "",
    );
    let ts = fit_object(
        "torrance-sparrow",
        "d3",
        "cie-y",
        r#"{"n": 1.5, "c3": 0.2, "ps": 0.5, "pd": 0.25}"#,
        "",
    )
    .replace("-5000.0", "-4000.0");
    let f = write(
        dir.path(),
        "all.json",
        format!(r#"{{"fits": [{lambert}, {ggx}, {ts}]}}"#).as_bytes(),
    );
    let f = f.to_str().unwrap();
    let r = brdfit(&["export", f, "--to", "mitsuba"]);
    let (out, err) = (
        String::from_utf8_lossy(&r.stdout),
        String::from_utf8_lossy(&r.stderr),
    );
    assert!(r.status.success(), "{err}");
    assert!(
        err.contains("using the recommended model ggx-smith"),
        "{err}"
    );
    assert!(
        out.contains("ggx-smith") && out.contains("roughconductor"),
        "{out}"
    );
    let r = brdfit(&["export", f, "--to", "mitsuba", "--model", "lambert"]);
    let out = String::from_utf8_lossy(&r.stdout);
    assert!(
        out.contains("type=\"diffuse\"") && !out.contains("roughconductor"),
        "{out}"
    );
    assert!(!String::from_utf8_lossy(&r.stderr).contains("recommended"));
    expect_error(
        &["export", f, "--to", "mitsuba", "--model", "phong"],
        &[
            "no fit of model phong",
            "lambert, ggx-smith, torrance-sparrow (d3)",
            "fix:",
        ],
    );
    // fig7 takes the file's torrance-sparrow fit.
    let r = brdfit(&[
        "render",
        "fig7",
        "--mgo",
        f,
        "--res",
        "8",
        "-o",
        dir.path().join("f7").to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    // ... and says so, since the file holds other models.
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("using the file's torrance-sparrow fit (it also holds lambert, ggx-smith)"),
        "{err}"
    );
    // plot lobe: --model without --set picks from the file.
    let r = brdfit(&[
        "plot",
        "lobe",
        "--fit",
        f,
        "--model",
        "lambert",
        "-o",
        dir.path().join("l").to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let svg = std::fs::read_to_string(dir.path().join("l.svg")).unwrap();
    assert!(svg.contains("lambert fit (cie-y)") && !svg.contains("ggx-smith"));
}

/// A CIE-Y fit is not compared with 400 nm data: refused with the fix, and
/// with --channel cie-y the charts carry the channel in their title.
#[test]
fn a_fit_of_another_channel_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(
        dir.path(),
        "y.json",
        fit_object(
            "ggx-smith",
            "d3",
            "y",
            r#"{"alpha": 0.2, "n": 1.5, "ps": 0.5, "pd": 0.25}"#,
            "",
        )
        .as_bytes(),
    );
    let f = f.to_str().unwrap();
    let o = dir.path().join("o");
    for cmd in ["residuals", "slice"] {
        // Without --channel the data's channel is the fit's (CIE Y), said on stderr. (Each
        // its own output: residuals writes a folder, which slice's file output may not name.)
        let own = dir.path().join(cmd);
        let r = brdfit(&[
            "plot",
            cmd,
            "--fit",
            f,
            "tests/data/garnet_red.astm",
            "-o",
            own.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{err}");
        assert!(err.contains("using channel cie-y, the fit's"), "{err}");
        // Another channel named is refused with the fix.
        expect_error(
            &[
                "plot",
                cmd,
                "--fit",
                f,
                "tests/data/garnet_red.astm",
                "--channel",
                "400nm",
                "-o",
                o.to_str().unwrap(),
            ],
            &[
                "fit is of channel y",
                "data's channel is 400nm",
                "fix: load the fit's channel with --channel cie-y",
            ],
        );
    }
    expect_error(
        &[
            "plot",
            "lobe",
            "--fit",
            f,
            "--data",
            "tests/data/garnet_red.astm",
            "--channel",
            "400nm",
            "-o",
            o.to_str().unwrap(),
        ],
        &["fit is of channel y", "--channel cie-y"],
    );
    let r = brdfit(&[
        "plot",
        "slice",
        "--fit",
        f,
        "tests/data/garnet_red.astm",
        "--channel",
        "cie-y",
        "-o",
        o.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let svg = std::fs::read_to_string(o.with_extension("svg")).unwrap();
    assert!(svg.contains("channel y"), "the title names the channel");
}

/// Command-line safety: `fit x.csv --json x.csv` refuses before fitting (nothing
/// printed); a multi-channel `--model all` prints the BIC ranking and the verification result
/// without --verbose; the note after --json counts models and channels; --summary has one
/// column per parameter, holding the values the fit JSON holds.
#[test]
fn fit_command_polish() {
    let dir = tempfile::tempdir().unwrap();
    let x = dir.path().join("x.csv");
    std::fs::copy("data/blinn-mgo.csv", &x).unwrap();
    let before = std::fs::read(&x).unwrap();
    let o = brdfit(&["fit", x.to_str().unwrap(), "--json", x.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("would overwrite an input"));
    assert_eq!(std::fs::read(&x).unwrap(), before);

    let json = dir.path().join("all.json");
    let summary = dir.path().join("s.csv");
    let o = brdfit(&[
        "fit",
        "tests/data/rgl-isotropic-paper_white_rgb.csv",
        "--model",
        "all",
        "--verify",
        "2",
        "--json",
        json.to_str().unwrap(),
        "--summary",
        summary.to_str().unwrap(),
    ]);
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(o.status.success(), "{err}");
    assert!(out.contains("BIC ranking per channel"), "{out}");
    for c in ["r", "g", "b"] {
        let line = out
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{c} ")) && l.contains('←'))
            .unwrap_or_else(|| panic!("no ranking line of channel {c}:\n{out}"));
        let n = brdfit::model::catalogue().len();
        assert_eq!(
            line.matches(", ").count(),
            n - 1,
            "{n} models ranked: {line}"
        );
    }
    assert!(
        out.contains("verified(2)") || out.contains("NOT-VERIFIED(2)"),
        "{out}"
    );
    assert!(
        err.contains(&format!(
            "holds {} models of channels r, g, b",
            brdfit::model::catalogue().len()
        )),
        "{err}"
    );
    // --summary: a column per parameter, each value the JSON's.
    let fits = brdfit::fit::read_fit_file(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let text = std::fs::read_to_string(&summary).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    for p in ["pd", "c1", "ps", "n", "c2", "c3", "alpha"] {
        assert!(head.contains(&p), "no column {p}: {head:?}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3 * brdfit::model::catalogue().len());
    // Every parameter of every model has a column.
    let names: Vec<&str> = brdfit::model::catalogue()
        .into_iter()
        .flat_map(|(k, d)| k.param_names(d))
        .collect();
    for f in &fits {
        let row = rows
            .iter()
            .find(|r| r[1] == f.channel && r[2] == f.label())
            .unwrap();
        for (n, v) in &f.params {
            let col = head.iter().position(|h| h == n).unwrap();
            assert_eq!(row[col].parse::<f64>().unwrap(), *v, "{n}");
        }
        // A parameter column is empty exactly where the model has no such parameter.
        for n in &names {
            let col = head.iter().position(|h| h == n).unwrap();
            assert_eq!(row[col].is_empty(), f.get(n).is_none(), "{n}: {row:?}");
        }
        // Each interval's ends are the JSON's, and the row says whether it is recommended.
        for (n, lo, hi) in &f.ranges {
            let at = |k: String| row[head.iter().position(|h| *h == k).unwrap()];
            assert_eq!(at(format!("{n}_lo")).parse::<f64>().unwrap(), *lo, "{n}");
            assert_eq!(at(format!("{n}_hi")).parse::<f64>().unwrap(), *hi, "{n}");
        }
        let col = head.iter().position(|h| *h == "recommended").unwrap();
        // The recommended label of this channel: the ranking line's part marked ←.
        let line = out
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{} ", f.channel)) && l.contains('←'))
            .unwrap();
        let part = line
            .trim_start()
            .strip_prefix(f.channel.as_str())
            .unwrap()
            .split(", ")
            .find(|p| p.ends_with('←'))
            .unwrap();
        let label = part.trim().rsplit_once(" +").unwrap().0;
        assert_eq!(row[col] == "true", label == f.label(), "{}", f.label());
    }
    let recommended = rows.iter().filter(|r| r.contains(&"true")).count();
    assert_eq!(recommended, 3, "one recommendation a channel");
}

/// A file with several torrance-sparrow distributions: `--model torrance-sparrow` takes d3 and
/// says which it took and how to choose another; `--distribution d1` takes d1, silently.
#[test]
fn a_distribution_taken_for_the_user_is_said() {
    let dir = tempfile::tempdir().unwrap();
    let d1 = fit_object(
        "torrance-sparrow",
        "d1",
        "brdf",
        r#"{"n": 1.8, "c1": 20, "ps": 0.667, "pd": 0.333}"#,
        "",
    );
    let d3 = fit_object("torrance-sparrow", "d3", "brdf", MGO, "");
    let f = dir.path().join("ts.json");
    std::fs::write(&f, format!(r#"{{"fits": [{d1}, {d3}]}}"#)).unwrap();
    let f = f.to_str().unwrap();
    let out = dir.path().join("o");
    let out = out.to_str().unwrap();
    let r = brdfit(&[
        "render",
        "fig7",
        "--mgo",
        f,
        "--model",
        "torrance-sparrow",
        "--res",
        "8",
        "-o",
        out,
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(
        err.contains("using torrance-sparrow (d3) of the file's torrance-sparrow fits (d1, d3)")
            && err.contains("--distribution"),
        "{err}"
    );
    let r = brdfit(&[
        "render",
        "fig7",
        "--mgo",
        f,
        "--model",
        "torrance-sparrow",
        "--distribution",
        "d1",
        "--res",
        "8",
        "-o",
        out,
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(!err.contains("using torrance-sparrow"), "{err}");
    // A scene whose material takes the file: the note names the scene and the material, and
    // --quiet keeps it off stderr.
    let scene = dir.path().join("s.toml");
    std::fs::write(
        &scene,
        "[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 30.0\nwidth = 8\nheight = 8\n\
         [[lights]]\nkind = \"directional\"\ndirection = [0.0, 0.0, 1.0]\nintensity = 3.0\n\
         [materials.m]\nfit = \"ts.json\"\nfit_model = \"torrance-sparrow\"\n\
         [[objects]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n",
    )
    .unwrap();
    let img = dir.path().join("s.png");
    let args = [
        "render",
        scene.to_str().unwrap(),
        "-o",
        img.to_str().unwrap(),
    ];
    let r = brdfit(&args);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(
        err.contains("s.toml: material m: ") && err.contains("using torrance-sparrow (d3)"),
        "{err}"
    );
    let r = brdfit(&[&args[..], &["--quiet"]].concat());
    assert!(r.status.success());
    assert!(!String::from_utf8_lossy(&r.stderr).contains("note"));
}

/// A fit that fails (a channel the file lacks) writes no JSON or summary: an empty `fits` list
/// would only fail its consumer later.
#[test]
fn a_failed_fit_writes_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("g.json");
    let sum = dir.path().join("s.csv");
    let r = brdfit(&[
        "fit",
        "tests/data/vch_golden_yellow_rgb.csv",
        "--channel",
        "green",
        "--json",
        json.to_str().unwrap(),
        "--summary",
        sum.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no channel named 'green'") && err.contains("fix:"),
        "{err}"
    );
    assert!(!err.contains("wrote"), "{err}");
    assert!(!json.exists() && !sum.exists());
}

/// `fit --weights solid-angle` is the same fit as `--weights file` on a copy of the data whose
/// `weight` column holds those weights (a second path through the loader), and differs from
/// the unweighted fit; the weights themselves are checked by hand in tests/it/truth.rs. The fit
/// JSON records `weights` and `weighted`, and the table labels a weighted cost and rmse.
#[test]
fn fit_solid_angle_weights_equal_a_weight_column() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("grid.csv");
    let o = brdfit(&[
        "simulate",
        "--model",
        "torrance-sparrow",
        "--set",
        "n=1.5,c3=0.2,ps=0.5,pd=0.3",
        "--grid",
        "goniometer",
        "--noise",
        "0.05",
        "--seed",
        "3",
        "-o",
        data.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ds = brdfit::data::load(&data, &brdfit::data::LoadOptions::default()).unwrap();
    let w = brdfit::fit::solid_angle_weights(&ds);
    let text = std::fs::read_to_string(&data).unwrap();
    let mut out = String::new();
    let mut k = 0;
    for line in text.lines() {
        if line.starts_with('#') {
            out += line;
        } else if line.starts_with("theta") {
            out += &format!("{line},weight");
        } else {
            out += &format!("{line},{}", w[k]);
            k += 1;
        }
        out.push('\n');
    }
    assert_eq!(k, w.len());
    let weighted = dir.path().join("weighted.csv");
    std::fs::write(&weighted, out).unwrap();
    let n = |file: &Path, how: &str| {
        let json = dir.path().join(format!("{how}.json"));
        let o = brdfit(&[
            "fit",
            file.to_str().unwrap(),
            "--weights",
            how,
            "--json",
            json.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(
            String::from_utf8_lossy(&o.stderr).contains(&format!("wrote {}", json.display())),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        // The fit file records the weighting, and both it and the table say when the cost
        // and rmse are weighted ones.
        let stdout = String::from_utf8_lossy(&o.stdout).to_string();
        let weighted = v["weighted"].as_bool().unwrap();
        assert_eq!(v["weights"], serde_json::json!(how), "{v}");
        assert_eq!(stdout.contains("(weighted: "), weighted, "{stdout}");
        let back = brdfit::fit::FitResult::from_json(&v).unwrap();
        assert_eq!(back.weighted, weighted);
        (v["params"]["n"].as_f64().unwrap(), weighted, stdout)
    };
    let ((solid, w1, t1), (column, w2, t2), (plain, w3, _)) = (
        n(&data, "solid-angle"),
        n(&weighted, "file"),
        n(&data, "file"),
    );
    assert!(w1 && w2 && !w3);
    assert!(t1.contains("(weighted: solid angle)"), "{t1}");
    assert!(t2.contains("(weighted: the file's weight column)"), "{t2}");
    assert!(
        (solid - column).abs() < 1e-6 * column,
        "{solid} vs {column}"
    );
    assert!((solid - plain).abs() > 1e-4 * plain, "{solid} vs {plain}");
}

/// `--resolution`: the default stops the polish of a metal's fit at the data's resolution,
/// 0 runs it to the relative tolerance 1e-14 (a lower or equal cost, more evaluations), and a
/// value that is not a fraction is a usage error naming the fix.
#[test]
fn resolution_flag_sets_where_the_polish_stops() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| -> serde_json::Value {
        let json = dir.path().join("f.json");
        let mut args = vec![
            "fit",
            "data/merl-aluminium.csv",
            "--channel",
            "g",
            "-q",
            "--json",
            json.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let out = brdfit(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        v
    };
    let default = run(&[]);
    let full = run(&["--resolution", "0"]);
    let term = |v: &serde_json::Value| v["termination"].as_str().unwrap().to_string();
    assert!(term(&default).contains("resolution"), "{}", term(&default));
    assert!(!term(&full).contains("resolution"), "{}", term(&full));
    let cost = |v: &serde_json::Value| v["cost"].as_f64().unwrap();
    assert!(
        cost(&full) <= cost(&default) && cost(&default) - cost(&full) <= 1e-8 * cost(&full),
        "{} vs {}",
        cost(&default),
        cost(&full)
    );
    let evals = |v: &serde_json::Value| v["evaluations"].as_u64().unwrap();
    assert!(
        evals(&default) < evals(&full),
        "{} vs {}",
        evals(&default),
        evals(&full)
    );
    // The flag's default is the library's.
    assert_eq!(brdfit::fit::RESOLUTION, 1e-6);
    let help = String::from_utf8_lossy(&brdfit(&["fit", "--help"]).stdout).to_string();
    assert!(help.contains("[default: 1e-6]"), "{help}");
    for bad in ["-1", "2", "nan", "x"] {
        expect_usage_error(
            &["fit", "data/merl-aluminium.csv", "--resolution", bad],
            &["--resolution", "fix: e.g. --resolution 1e-6"],
        );
    }
}

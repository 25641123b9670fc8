//! The command line: bad input gives a message that names the file, line and fix, and exit
//! code 1 (never a panic, 101); usage errors exit 2; the commands work end to end.


use crate::common::{fit_object, write};
use std::path::Path;
use std::process::{Command, Output};

fn brdfit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run brdfit")
}

fn expect_error(args: &[&str], fragments: &[&str]) {
    let out = brdfit(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{args:?}: exit code; stderr: {err}"
    );
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    for f in fragments {
        assert!(err.contains(f), "{args:?}: stderr lacks '{f}':\n{err}");
    }
}

fn expect_usage_error(args: &[&str], fragments: &[&str]) {
    let out = brdfit(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{args:?}: exit code; stderr: {err}"
    );
    for f in fragments {
        assert!(err.contains(f), "{args:?}: stderr lacks '{f}':\n{err}");
    }
}

const H: &str = "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n";

#[test]
fn bad_csv_inputs_name_file_line_and_fix() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "empty.csv",
            String::new(),
            vec!["empty.csv", "the file is empty", "fix:"],
        ),
        (
            "header.csv",
            H.to_string(),
            vec!["header.csv", "no samples", "fix:"],
        ),
        (
            "noangle.csv",
            "theta_i_deg,phi_i_deg,theta_o_deg,brdf\n1,0,1,0.1\n".into(),
            vec!["noangle.csv:1", "missing angle column(s): phi_o_deg"],
        ),
        (
            "unitless.csv",
            "theta_i,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n1,0,1,0,0.1\n".into(),
            vec![
                "unitless.csv:1",
                "angle columns need a unit: rename theta_i to theta_i_deg or theta_i_rad",
            ],
        ),
        (
            "nan.csv",
            format!("{H}10,0,10,180,0.1\n10,0,20,180,NaN\n"),
            vec!["nan.csv:3", "NaN", "leave the field empty"],
        ),
        (
            "inf.csv",
            format!("{H}10,0,10,180,inf\n"),
            vec!["inf.csv:2", "inf", "fix:"],
        ),
        (
            "text.csv",
            format!("{H}10,0,10,180,0.1\n10,0,abc,180,0.2\n"),
            vec!["text.csv:3", "'abc' is not a number"],
        ),
        (
            "theta.csv",
            format!("{H}95,0,10,180,0.1\n"),
            vec!["theta.csv:2", "outside [0°, 90°]", "_deg or _rad"],
        ),
        (
            "theta_rad.csv",
            "theta_i_rad,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n30,0,10,180,0.1\n".into(),
            vec!["theta_rad.csv:2", "outside [0°, 90°]"],
        ),
        (
            "phi.csv",
            format!("{H}10,0,10,400,0.1\n"),
            vec!["phi.csv:2", "outside [−360°, 360°]"],
        ),
        (
            "semi.csv",
            "theta_i_deg;phi_i_deg;theta_o_deg;phi_o_deg;brdf\n10;0;10;180;0,1\n".into(),
            vec!["semi.csv:1", "separated by ';'", "'.' decimals"],
        ),
        (
            "fields.csv",
            format!("{H}10,0,10,180\n"),
            vec!["fields.csv:2", "4 fields but the header has 5"],
        ),
        (
            "novalue.csv",
            "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n1,0,1,0\n".into(),
            vec!["no value column"],
        ),
        (
            "unknown.csv",
            "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,reflectance\n1,0,1,0,1\n".into(),
            vec!["unknown column 'reflectance'", "brdf_cos or rfactor"],
        ),
        (
            "mixed.csv",
            "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf_r,rfactor_g\n1,0,1,0,1,1\n".into(),
            vec!["mix quantities"],
        ),
    ];
    for (name, body, frags) in &cases {
        let p = write(d, name, body.as_bytes());
        expect_error(&["info", p.to_str().unwrap()], frags);
    }
    let p = write(
        d,
        "neg.csv",
        format!("{H}10,0,10,180,-0.1\n10,0,20,180,0.1\n").as_bytes(),
    );
    expect_error(
        &["info", "--negative", "error", p.to_str().unwrap()],
        &["neg.csv:2", "negative value -0.1", "--negative mask"],
    );
    let ok = brdfit(&["info", p.to_str().unwrap()]);
    assert!(ok.status.success());
    assert!(String::from_utf8_lossy(&ok.stdout).contains("negatives:   1 (masked as missing)"));
    let ok = brdfit(&["info", "--negative", "clamp", p.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&ok.stdout).contains("negatives:   1 (clamped to 0)"));
}

/// Radians under `_deg` headers Blinn's MgO samples rewritten with their
/// angles in radians but the columns still named `_deg` get a warning that names the mix-up and
/// the fix, from `info`, `fit` and the report's loader; `--trust-units` silences it; the real
/// file (degrees, θ up to 80°) and the same values under `_rad` get none.
#[test]
fn radians_under_degree_headers_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let ds = crate::common::load("data/blinn-mgo.csv");
    let mut deg = String::from(H);
    let mut rad = String::from("theta_i_rad,phi_i_rad,theta_o_rad,phi_o_rad,brdf\n");
    for k in 0..ds.len() {
        let row = format!(
            "{},{},{},{},{}\n",
            ds.theta_i[k], ds.phi_i[k], ds.theta_o[k], ds.phi_o[k], ds.channels[0].values[k]
        );
        deg.push_str(&row);
        rad.push_str(&row);
    }
    let mixed = write(dir.path(), "mixed.csv", deg.as_bytes());
    let honest = write(dir.path(), "honest.csv", rad.as_bytes());
    for cmd in ["info", "fit"] {
        let out = brdfit(&[cmd, mixed.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{cmd}: {err}");
        for f in [
            "mixed.csv",
            "look like radians",
            "theta_i_rad",
            "--trust-units",
        ] {
            assert!(err.contains(f), "{cmd}: stderr lacks '{f}':\n{err}");
        }
        let out = brdfit(&[cmd, "--trust-units", mixed.to_str().unwrap()]);
        assert!(!String::from_utf8_lossy(&out.stderr).contains("radians"));
        for quiet in [honest.to_str().unwrap(), "data/blinn-mgo.csv"] {
            let out = brdfit(&[cmd, quiet]);
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(
                out.status.success() && !err.contains("radians"),
                "{quiet}: {err}"
            );
        }
    }
}

#[test]
fn bad_files_of_other_kinds() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // MERL: truncated, wrong dimensions, all cells negative, header only.
    let mut good = Vec::new();
    for x in [90i32, 90, 180] {
        good.extend(x.to_le_bytes());
    }
    let hdr = good.clone();
    good.extend(std::iter::repeat_n((-1.0f64).to_le_bytes(), 3 * 90 * 90 * 180).flatten());
    let p = write(d, "neg.binary", &good);
    expect_error(
        &["info", p.to_str().unwrap()],
        &["neg.binary", "every cell is negative"],
    );
    let p = write(d, "trunc.binary", &good[..good.len() / 2]);
    expect_error(
        &["info", p.to_str().unwrap()],
        &["trunc.binary", "truncated"],
    );
    let p = write(d, "short.binary", &hdr[..8]);
    expect_error(
        &["info", p.to_str().unwrap()],
        &["short.binary", "shorter than the 12-byte"],
    );
    let mut dims = good.clone();
    dims[..4].copy_from_slice(&i32::MAX.to_le_bytes());
    let p = write(d, "dims.binary", &dims);
    expect_error(
        &["info", p.to_str().unwrap()],
        &["dims.binary", "not 90×90×180"],
    );
    // ASTM truncated (NUM_POINTS disagrees), and a Cornell record cut short.
    let astm =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("data/cayman.astm"))
            .unwrap();
    let cut: String = astm.lines().take(500).collect::<Vec<_>>().join("\n");
    let p = write(d, "cut.astm", cut.as_bytes());
    expect_error(
        &["info", p.to_str().unwrap()],
        &["cut.astm:20", "NUM_POINTS says 1439", "truncated"],
    );
    let p = write(d, "cut.brdf", b"2\n500 600\n0.1 0 0.2 3.1 0.5\n");
    expect_error(
        &["info", p.to_str().unwrap()],
        &["cut.brdf:3", "ends after 1 of 2 values"],
    );
    // gzip, unknown format, a directory, a missing path.
    let p = write(d, "x.csv.gz", &[0x1f, 0x8b, 8, 0, 0, 0]);
    expect_error(&["info", p.to_str().unwrap()], &["gzip", "gunzip"]);
    let p = write(d, "x.dat", b"hello world\n");
    expect_error(
        &["info", p.to_str().unwrap()],
        &["x.dat", "unknown file format", "--format"],
    );
    expect_error(&["info", d.to_str().unwrap()], &["is a directory"]);
    expect_error(
        &["info", "/nonexistent/file.csv"],
        &["/nonexistent/file.csv", "does not exist"],
    );
}

#[test]
fn usage_errors_exit_2() {
    // A closed choice spelt wrong: exit 2, the message once, the nearest valid value.
    for (args, near) in [
        (
            &["fit", "data/blinn-mgo.csv", "--model", "torrance-sparow"][..],
            "'torrance-sparrow'",
        ),
        (
            &["fit", "data/blinn-mgo.csv", "--loss", "linar"][..],
            "'linear'",
        ),
        (
            &["eval", "--model", "blin-phong", "x.csv"][..],
            "'blinn-phong'",
        ),
        (
            &["info", "data/cayman.astm", "--negative", "clmp"][..],
            "'clamp'",
        ),
    ] {
        let out = brdfit(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(
            err.matches("error:").count(),
            1,
            "{args:?} printed twice: {err}"
        );
        assert!(
            err.contains(&format!("a similar value exists: {near}")),
            "{args:?}: {err}"
        );
    }
    assert_eq!(brdfit(&["info"]).status.code(), Some(2));
    assert_eq!(brdfit(&["frobnicate"]).status.code(), Some(2));
    // A count out of its stated range is refused with the range (exit 2), never clamped.
    for (args, range) in [
        (&["report", "--render-res", "5000"][..], "16..=4096"),
        (&["report", "--stability-starts", "0"][..], "1..=100"),
        (&["fit", "data/blinn-mgo.csv", "--jobs", "0"][..], "1..=64"),
        (&["study", "render", "--res", "4"][..], "8..=2048"),
    ] {
        let out = brdfit(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(range), "{args:?}: {err}");
    }
    assert_eq!(brdfit(&["--version"]).status.code(), Some(0));
    expect_error(
        &[
            "simulate",
            "--model",
            "phong",
            "--set",
            "c1=10",
            "-o",
            "/tmp/x.csv",
        ],
        &["needs parameter ps", "--set ps=VALUE"],
    );
    expect_error(
        &[
            "simulate",
            "--model",
            "torrance-sparrow",
            "--set",
            "n=1.5,c3=1.5,ps=1,pd=1",
            "-o",
            "/tmp/x.csv",
        ],
        &["c3 = 1.5 is out of bounds"],
    );
}

#[test]
fn eval_simulate_convert_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let dirs = write(
        d,
        "dirs.csv",
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n0,0,0,0\n60,0,60,180\n",
    );
    let out = d.join("eval.csv");
    let o = brdfit(&[
        "eval",
        "--model",
        "torrance-sparrow",
        "--set",
        "n=1.8,c3=0.35,ps=0.667,pd=0.333",
        dirs.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    // Normal incidence and view: (pd + ps F0)/π with F0 = (0.8/2.8)², by hand.
    let want = (0.333 + 0.667 * (0.8f64 / 2.8).powi(2)) / std::f64::consts::PI;
    assert!((rows[0][4] - want).abs() < 1e-12);
    // Mirror direction at 60°: N·H = 1 so D = 1; E·H = cos 60° = 0.5; G = 1 (2·1·0.5/0.5 = 2 > 1);
    // F(1.8, 0.5) by hand from the compact formula: g = √(1.8² − 0.75) = 1.57797…
    let g = (1.8f64 * 1.8 - 0.75).sqrt();
    let f = 0.5
        * ((g - 0.5) / (g + 0.5)).powi(2)
        * (1.0 + ((0.5 * (g + 0.5) - 1.0) / (0.5 * (g - 0.5) + 1.0)).powi(2));
    let want = 0.333 / std::f64::consts::PI + 0.667 * f / (std::f64::consts::PI * 0.25);
    assert!(
        (rows[1][4] - want).abs() < 1e-12,
        "{} vs {want}",
        rows[1][4]
    );

    // An f_r that overflows is refused and nothing is written (it wrote "inf"); a parameter
    // given twice is refused (the last one won silently).
    let bad = d.join("overflow.csv");
    // At the 85° mirror f_r = ps F/(π cos² 85°) ≈ 25 ps: infinite for ps = 1.7e308.
    let grazing = write(
        d,
        "grazing.csv",
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n85,0,85,180\n",
    );
    for (set, fragment) in [
        (
            "n=1.8,c3=0.35,ps=1.7e308,pd=0.3",
            "gives f_r = inf at direction 1",
        ),
        (
            "n=1.8,c3=0.35,ps=0.5,pd=0.3,pd=0.4",
            "gives pd twice (pd=0.3 and pd=0.4)",
        ),
    ] {
        expect_error(
            &[
                "eval",
                "--model",
                "torrance-sparrow",
                "--set",
                set,
                grazing.to_str().unwrap(),
                "-o",
                bad.to_str().unwrap(),
            ],
            &[fragment, "fix:"],
        );
        assert!(!bad.exists(), "{set}: wrote {}", bad.display());
    }

    // simulate is deterministic for a seed and differs between seeds.
    let s = |seed: &str, name: &str| {
        let p = d.join(name);
        let o = brdfit(&[
            "simulate",
            "--model",
            "blinn-phong",
            "--set",
            "c1=20,ps=0.5,pd=0.3",
            "--grid",
            "hemisphere:500",
            "--noise",
            "0.05",
            "--seed",
            seed,
            "-o",
            p.to_str().unwrap(),
        ]);
        assert!(o.status.success());
        std::fs::read(p).unwrap()
    };
    assert_eq!(s("3", "a.csv"), s("3", "b.csv"));
    assert_ne!(s("3", "a2.csv"), s("4", "c.csv"));
    let o = brdfit(&[
        "simulate",
        "--model",
        "lambert",
        "--set",
        "pd=0.5",
        "--grid",
        "plane:30,70",
        "-o",
        d.join("p.csv").to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let info =
        String::from_utf8_lossy(&brdfit(&["info", d.join("p.csv").to_str().unwrap()]).stdout)
            .to_string();
    assert!(
        info.contains("samples:     358") && info.contains("θi values:   30, 70°"),
        "{info}"
    );

    // convert: ASTM -> CSV (CIE Y) -> MERL -> info
    let csv = d.join("cay.csv");
    assert!(
        brdfit(&[
            "convert",
            "data/cayman.astm",
            "--channel",
            "cie-y",
            "-o",
            csv.to_str().unwrap()
        ])
        .status
        .success()
    );
    let merl = d.join("cay.binary");
    let o = brdfit(&[
        "convert",
        csv.to_str().unwrap(),
        "-o",
        merl.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let info =
        String::from_utf8_lossy(&brdfit(&["info", merl.to_str().unwrap()]).stdout).to_string();
    assert!(
        info.contains("format:      merl") && info.contains("channels:    3 (r, g, b)"),
        "{info}"
    );
    expect_error(
        &[
            "convert",
            csv.to_str().unwrap(),
            "-o",
            csv.to_str().unwrap(),
        ],
        &["overwrite an input"],
    );
    expect_error(
        &[
            "convert",
            "data/cayman.astm",
            "-o",
            d.join("x.binary").to_str().unwrap(),
        ],
        &["MERL holds r, g, b", "--channel"],
    );
}

#[test]
fn closed_pipe_is_not_an_error() {
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(["info", "data/cayman.astm"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.code() == Some(0),
        "{:?} {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn fit_command_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("fit.json");
    let o = brdfit(&[
        "fit",
        "data/blinn-mgo.csv",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("torrance-sparrow (d3)") && out.contains("std. error"),
        "{out}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let n = v["params"]["n"].as_f64().unwrap();
    assert!((n - 1.8).abs() < 0.036, "n = {n}");
    // An existing output is replaced (one rule for every command), and the command says so.
    let o = brdfit(&[
        "fit",
        "data/blinn-mgo.csv",
        "--model",
        "all",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains(&format!("wrote {}", json.display())),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("model comparison") && out.contains("← simplest the data support"),
        "{out}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(
        v["fits"].as_array().unwrap().len(),
        brdfit::model::catalogue().len()
    );
    expect_error(
        &["fit", "data/blinn-mgo.csv", "--fix", "c3=2"],
        &[
            "--fix c3=2 is outside the range a fit can return",
            "0 < c3 ≤ 1",
            "fix:",
        ],
    );
    expect_usage_error(
        &["fit", "data/blinn-mgo.csv", "--method", "bfgs"],
        &[
            "invalid value 'bfgs'",
            "possible values: lm, gn, nm, argmin-lbfgs",
        ],
    );
}

/// Every fit `fit --model all` writes can be read back, including one at a bound: on Blinn's
/// aluminium TS-d1 and d2 drive n to its upper bound 1e7, which rounding used to write as
/// 1e7 + 1e-8, a value the reader refuses ("outside the range a fit can return").
#[test]
fn every_fit_written_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("al.json");
    let o = brdfit(&[
        "fit",
        "data/blinn-aluminium.csv",
        "--model",
        "all",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&json).unwrap();
    let fits = brdfit::fit::read_fit_file(&text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(fits.len(), brdfit::model::catalogue().len());
    let r7 = dir.path().join("r7");
    let o = brdfit(&[
        "render",
        "fig7",
        "--aluminium",
        json.to_str().unwrap(),
        "--res",
        "16",
        "-o",
        r7.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // --distribution without --model takes that distribution's model, not the recommended one
    // (this d1 fit has n at its bound, so it is marked not usable).
    let glsl = dir.path().join("d1.brdf");
    let o = brdfit(&[
        "export",
        json.to_str().unwrap(),
        "--to",
        "brdf-explorer",
        "--distribution",
        "d1",
        "--allow-unusable",
        "-o",
        glsl.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&glsl).unwrap();
    assert!(
        text.contains("float c1 ") && text.contains("pow(NdotH, c1)"),
        "{text}"
    );
    assert!(
        String::from_utf8_lossy(&o.stderr)
            .contains("--distribution d1 is a torrance-sparrow option"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn export_completions_and_batch() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("fit.json");
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
    let o = brdfit(&["export", json.to_str().unwrap(), "--to", "mitsuba"]);
    // Mitsuba has no Torrance–Sparrow: a ggx-smith refit, its error stated.
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && out.contains("blendbsdf") && out.contains("refitted:"),
        "{out}"
    );
    let merl = dir.path().join("x.binary");
    assert!(
        brdfit(&[
            "export",
            json.to_str().unwrap(),
            "--to",
            "merl",
            "-o",
            merl.to_str().unwrap()
        ])
        .status
        .success()
    );
    let info =
        String::from_utf8_lossy(&brdfit(&["info", merl.to_str().unwrap()]).stdout).to_string();
    assert!(info.contains("format:      merl"), "{info}");
    expect_usage_error(
        &["export", json.to_str().unwrap(), "--to", "obj"],
        &["invalid value 'obj'", "mitsuba"],
    );
    let o = brdfit(&["completions", "bash"]);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains("_brdfit"));
    // Batch: two files, one summary row each.
    let sum = dir.path().join("sum.csv");
    let o = brdfit(&[
        "fit",
        "data/blinn-mgo.csv",
        "data/blinn-aluminium.csv",
        "--jobs",
        "2",
        "--summary",
        sum.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = std::fs::read_to_string(&sum).unwrap();
    assert_eq!(s.lines().count(), 3);
    assert!(s.contains("blinn-mgo.csv") && s.contains("blinn-aluminium.csv"));
    // A batch with a bad file reports it, still fits the others, and exits 1.
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "theta_i,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n1,0,1,0,1\n",
    )
    .unwrap();
    let o = brdfit(&[
        "fit",
        "data/blinn-mgo.csv",
        bad.to_str().unwrap(),
        "--summary",
        sum.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("angle columns need a unit"));
    assert_eq!(std::fs::read_to_string(&sum).unwrap().lines().count(), 2);
    // A file name with a comma and a quote survives the summary CSV (read back with a CSV
    // reader, every row has the header's fields and the name as written).
    let odd = dir.path().join("we,ird \"name\".csv");
    std::fs::copy("data/blinn-mgo.csv", &odd).unwrap();
    let o = brdfit(&[
        "fit",
        odd.to_str().unwrap(),
        "--summary",
        sum.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut r = csv::Reader::from_path(&sum).unwrap();
    let width = r.headers().unwrap().len();
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].len(), width);
    assert_eq!(&rows[0][0], odd.to_str().unwrap());
}

#[test]
fn inverse_command_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(
        dir.path(),
        "s.toml",
        br#"
ambient = 0.1
[camera]
eye = [0.0, 0.0, 400.0]
target = [0.0, 0.0, 0.0]
fov = 0.35
width = 121
height = 121
[antialias]
mode = "none"
[[lights]]
kind = "directional"
direction = [0.45, 0.2, 1.0]
intensity = 3.14159265358979
[materials.white]
model = "lambert"
params = { pd = 1.0 }
[[objects]]
kind = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "white"
"#,
    );
    let img = dir.path().join("s.png");
    let o = brdfit(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        img.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("profile");
    let o = brdfit(&[
        "inverse",
        dir.path().join("s.exr").to_str().unwrap(),
        "--row",
        "60",
        "--light",
        "0.45,0.2,1",
        "--ca",
        "0.1",
        "--cd",
        "1",
        "--pixel-size",
        "0.0202",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(dir.path().join("profile.csv")).unwrap();
    assert_eq!(csv.lines().count(), 122);
    // The centre pixel sees the sphere's top: normal (0, 1) in (u, z).
    let mid: Vec<&str> = csv.lines().nth(61).unwrap().split(',').collect();
    let (nu, nz): (f64, f64) = (mid[8].parse().unwrap(), mid[9].parse().unwrap());
    assert!(nu.abs() < 0.02 && nz > 0.999, "{nu} {nz}");
    assert!(dir.path().join("profile.png").exists() && dir.path().join("profile.svg").exists());
    expect_error(
        &[
            "inverse",
            dir.path().join("s.exr").to_str().unwrap(),
            "--light",
            "0,0,1",
            "--cd",
            "1",
            "-o",
            out.to_str().unwrap(),
        ],
        &["no line given", "--row"],
    );
    // Cd = 0 (the shading would divide by it) and a zero light are refused with the fix.
    let exr = dir.path().join("s.exr");
    for (light, cd, fragment) in [
        ("0.45,0.2,1", "0", "Cd = 0 must be a finite number > 0"),
        ("0,0,0", "1", "0,0,0 is not a direction"),
    ] {
        let args = [
            "inverse",
            exr.to_str().unwrap(),
            "--row",
            "60",
            "--light",
            light,
            "--cd",
            cd,
            "-o",
            out.to_str().unwrap(),
        ];
        expect_error(&args, &[fragment, "fix:"]);
    }
}

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
    }
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

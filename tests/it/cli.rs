//! The command line: bad input gives a message that names the file, line and fix, and exit
//! code 1 (never a panic, 101); usage errors exit 2; the commands work end to end.

use crate::common::write;
use std::path::Path;
use std::process::{Command, Output};

pub(crate) fn brdfit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run brdfit")
}

pub(crate) fn expect_error(args: &[&str], fragments: &[&str]) {
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

pub(crate) fn expect_usage_error(args: &[&str], fragments: &[&str]) {
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
        (&["report", "--render-res", "5000"][..], "16..=2048"),
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
    // Cayman's 1,439 samples fill at most 1,439 of MERL's 1,458,000 cells: the rest are
    // empty, and convert says so (how many, and that renderers read them as missing).
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning:") && err.contains("of the table's 1458000 cells"),
        "{err}"
    );
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

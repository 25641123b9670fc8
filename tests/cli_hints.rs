//! Hand-written scene files and fix hints, as a new user meets them: a scene's `params` are
//! read with the bounds fit files are read with, every error names the file, line and key
//! with the fix, and every fix works when followed (each test runs the command the hint
//! gives). `-o NAME.EXT` with an extension the command does not write is refused.

mod common;

use common::{fit_object, write};
use std::path::Path;
use std::process::{Command, Output};

fn brdfit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run brdfit")
}

/// Runs `args`, expecting success; returns stderr.
fn ok(args: &[&str]) -> String {
    let o = brdfit(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?} failed: {err}");
    err
}

/// Runs `args`, expecting exit code 1 and each of `fragments` on stderr; returns stderr.
fn fails(args: &[&str], fragments: &[&str]) -> String {
    let o = brdfit(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{args:?}: stderr: {err}");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    for f in fragments {
        assert!(err.contains(f), "{args:?}: stderr lacks '{f}':\n{err}");
    }
    err
}

/// The word after `after` in `text` (the channel a fix names), without trailing punctuation.
fn word_after<'a>(text: &'a str, after: &str) -> &'a str {
    let rest = &text[text
        .find(after)
        .unwrap_or_else(|| panic!("no '{after}' in {text}"))
        + after.len()..];
    rest.split_whitespace()
        .next()
        .unwrap()
        .trim_end_matches([',', ';', ')'])
}

/// A small scene whose one material is `model` with `params` (on line 15).
fn scene(model: &str, params: &str) -> String {
    format!(
        "[camera]\neye = [0.0, 1.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\nwidth = 8\nheight = 6\n\n[[lights]]\nkind = \"point\"\nposition = [3.0, 6.0, 5.0]\nintensity = 90.0\n\n[materials.m]\nmodel = \"{model}\"\nparams = {params}\n\n[[objects]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n"
    )
}

/// A scene's `params` are refused outside the bounds a fit file's are read with (c1 ≤ 1e8,
/// n > 1: the fit-file loader now refuses n = 1 too), and refused with the scene's file, line
/// and key and the fix, not the output's name (ps = 1e300 overflowed the image); the fix
/// followed renders. Before: c1 = 1e300 and n = 1 rendered, and ps = 1e300 named out.exr.
#[test]
fn scene_params_are_checked_with_the_fit_files_bounds() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = scene("phong", "{ c1 = 1, ps = 0.5, pd = 0.5 }");
    let line = 1 + text.lines().position(|l| l.starts_with("params")).unwrap();
    assert_eq!(line, 15);
    let out = d.join("out.png");
    let o = out.to_str().unwrap();
    let cases = [
        (
            "phong",
            "{ c1 = 1e300, ps = 0.5, pd = 0.5 }",
            vec![
                "`params.c1` = 1e300",
                "0 < c1 ≤ 1e8",
                "fix: write a value with",
            ],
            "{ c1 = 1e8, ps = 0.5, pd = 0.5 }",
        ),
        (
            "torrance-sparrow",
            "{ n = 1, c3 = 0.3, ps = 0.5, pd = 0.5 }",
            vec!["`params.n` = 1 ", "1 < n ≤ 1e7"],
            "{ n = 1.5, c3 = 0.3, ps = 0.5, pd = 0.5 }",
        ),
        (
            "phong",
            "{ c1 = 10, ps = 1e300, pd = 0.5 }",
            vec!["`params` give a directional albedo", "fix: lower ps or pd"],
            "{ c1 = 10, ps = 0.5, pd = 0.5 }",
        ),
        (
            "phong",
            "{ c1 = 10, ps = 0.5, pd = 0.5, q = 1 }",
            vec!["`params.q`", "fix: remove q; phong takes c1, ps, pd"],
            "{ c1 = 10, ps = 0.5, pd = 0.5 }",
        ),
        (
            "phong",
            "{ c1 = 10, ps = 0.5 }",
            vec!["needs parameter pd", "fix: add pd to params"],
            "{ c1 = 10, ps = 0.5, pd = 0.5 }",
        ),
    ];
    for (k, (model, bad, want, fixed)) in cases.iter().enumerate() {
        let path = write(d, &format!("bad{k}.toml"), scene(model, bad).as_bytes());
        let at = format!("{}:{line}: material m: ", path.display());
        let mut frags = vec![at.as_str()];
        frags.extend(want);
        let err = fails(&["render", path.to_str().unwrap(), "-o", o], &frags);
        assert!(!err.contains("out.exr") && !out.exists(), "{err}");
        let good = write(d, &format!("good{k}.toml"), scene(model, fixed).as_bytes());
        ok(&["render", good.to_str().unwrap(), "-o", o]);
        std::fs::remove_file(&out).unwrap();
    }
    // The fit-file loader, with the same helper, refuses n = 1 as well.
    let fit = write(
        d,
        "n1.json",
        fit_object(
            "torrance-sparrow",
            "d3",
            "brdf",
            r#"{"n": 1.0, "c3": 0.35, "ps": 0.667, "pd": 0.333}"#,
            "",
        )
        .as_bytes(),
    );
    fails(
        &[
            "plot",
            "lobe",
            "--fit",
            fit.to_str().unwrap(),
            "-o",
            d.join("l").to_str().unwrap(),
        ],
        &["params.n = 1", "1 < n ≤ 1e7"],
    );
}

/// Colour fits to BRDF Explorer: the fix names a channel the file holds (a spectral file's
/// has no `g`), and the export with it works.
#[test]
fn brdf_explorer_hint_names_a_channel_the_file_holds() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (data, name) in [
        ("tests/data/acryl_blue.astm", "spectral"),
        ("data/merl-aluminium.csv", "rgb"),
    ] {
        let json = d.join(format!("{name}.json"));
        let j = json.to_str().unwrap();
        ok(&["fit", data, "--model", "torrance-sparrow", "--json", j]);
        let out = d.join(format!("{name}.brdf"));
        let o = out.to_str().unwrap();
        let err = fails(
            &["export", j, "--to", "brdf-explorer", "-o", o],
            &["fix: export one channel with --channel "],
        );
        let ch = word_after(&err, "--channel ").to_string();
        ok(&[
            "export",
            j,
            "--to",
            "brdf-explorer",
            "-o",
            o,
            "--channel",
            &ch,
        ]);
        assert!(out.exists(), "{name}: --channel {ch}");
    }
}

/// `plot lobe` of an RGB fit against one-channel data: the fix (fit this data) works, where
/// `--channel r` failed on the data.
#[test]
fn plot_lobe_channel_mismatch_hint_works() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rgb = d.join("rgb.json");
    ok(&[
        "fit",
        "data/merl-aluminium.csv",
        "--model",
        "torrance-sparrow",
        "--json",
        rgb.to_str().unwrap(),
    ]);
    let base = d.join("lobe");
    let b = base.to_str().unwrap();
    let err = fails(
        &[
            "plot",
            "lobe",
            "--fit",
            rgb.to_str().unwrap(),
            "--data",
            "data/blinn-mgo.csv",
            "-o",
            b,
        ],
        &["fix: fit this data and use that fit: brdfit fit DATA"],
    );
    assert!(!err.contains("--channel r"), "{err}");
    // The hint followed: DATA is the data file, OUT a new fit file.
    let hint = err.split("brdfit fit DATA").nth(1).unwrap();
    let flags: Vec<&str> = hint
        .split(" --json")
        .next()
        .unwrap()
        .split_whitespace()
        .collect();
    let own = d.join("own.json");
    let mut args = vec!["fit", "data/blinn-mgo.csv"];
    args.extend(&flags);
    args.extend(["--json", own.to_str().unwrap()]);
    ok(&args);
    ok(&[
        "plot",
        "lobe",
        "--fit",
        own.to_str().unwrap(),
        "--data",
        "data/blinn-mgo.csv",
        "-o",
        b,
    ]);
}

/// `render fig7`: "needs a torrance-sparrow fit" only where the file holds none (and then
/// fitting one works); a Torrance–Sparrow fit of several channels gets the pick's own fix
/// (--channel), which works.
#[test]
fn fig7_says_what_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("fig7");
    let o = out.to_str().unwrap();
    let spectral = d.join("spectral.json");
    let s = spectral.to_str().unwrap();
    ok(&[
        "fit",
        "tests/data/acryl_blue.astm",
        "--model",
        "torrance-sparrow",
        "--json",
        s,
    ]);
    let err = fails(
        &["render", "fig7", "--aluminium", s, "--res", "8", "-o", o],
        &["fix: pick one with --channel"],
    );
    assert!(!err.contains("needs a torrance-sparrow fit"), "{err}");
    ok(&[
        "render",
        "fig7",
        "--aluminium",
        s,
        "--res",
        "8",
        "-o",
        o,
        "--channel",
        "550nm",
    ]);
    let ggx = d.join("ggx.json");
    ok(&[
        "fit",
        "data/blinn-mgo.csv",
        "--model",
        "ggx-smith",
        "--json",
        ggx.to_str().unwrap(),
    ]);
    fails(
        &[
            "render",
            "fig7",
            "--aluminium",
            ggx.to_str().unwrap(),
            "--res",
            "8",
            "-o",
            o,
        ],
        &[
            "holds no torrance-sparrow fit (it holds ggx-smith)",
            "fix: fit one: brdfit fit DATA --model torrance-sparrow --json OUT",
        ],
    );
    let ts = d.join("ts.json");
    ok(&[
        "fit",
        "data/blinn-mgo.csv",
        "--model",
        "torrance-sparrow",
        "--json",
        ts.to_str().unwrap(),
    ]);
    ok(&[
        "render",
        "fig7",
        "--aluminium",
        ts.to_str().unwrap(),
        "--res",
        "8",
        "-o",
        o,
    ]);
}

/// A fit file's unknown distribution: the fix lists every distribution, abc too, and each
/// one it lists is one `fit --distribution` takes.
#[test]
fn unknown_distribution_fix_lists_abc() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fit = write(
        d,
        "d9.json",
        fit_object(
            "torrance-sparrow",
            "d9",
            "brdf",
            r#"{"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333}"#,
            "",
        )
        .as_bytes(),
    );
    let err = fails(
        &[
            "plot",
            "lobe",
            "--fit",
            fit.to_str().unwrap(),
            "-o",
            d.join("l").to_str().unwrap(),
        ],
        &["fix: write one of d1, d2, d3, abc"],
    );
    let listed = word_after(&err, "write one of ");
    assert_eq!(listed, "d1");
    for dist in ["d1", "d2", "d3", "abc"] {
        let j = d.join(format!("{dist}.json"));
        ok(&[
            "fit",
            "data/blinn-mgo.csv",
            "--model",
            "torrance-sparrow",
            "--distribution",
            dist,
            "--json",
            j.to_str().unwrap(),
        ]);
    }
}

/// `-o x.jpg`: refused with the fix by every command that writes images (render a scene,
/// plot, inverse), nothing written; the fix followed writes what it says.
#[test]
fn output_with_an_extension_not_written_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc = write(
        d,
        "s.toml",
        scene("phong", "{ c1 = 10, ps = 0.5, pd = 0.5 }").as_bytes(),
    );
    let jpg = d.join("x.jpg");
    let j = jpg.to_str().unwrap();
    let png = d.join("x.png");
    let err = fails(
        &["render", sc.to_str().unwrap(), "-o", j],
        &[
            "this command writes png and exr files, not .jpg",
            "fix: give -o ",
        ],
    );
    assert!(!png.exists() && !jpg.exists() && !d.join("x.exr").exists());
    let fixed = word_after(&err, "fix: give -o ");
    assert_eq!(Path::new(fixed), png.as_path());
    let wrote = ok(&["render", sc.to_str().unwrap(), "-o", fixed]);
    assert!(
        wrote.contains(&format!("wrote {}", png.display())),
        "{wrote}"
    );
    let err = fails(
        &[
            "plot",
            "lobe",
            "--model",
            "phong",
            "--set",
            "c1=10,ps=0.5,pd=0.5",
            "-o",
            j,
        ],
        &["this command writes svg and png files, not .jpg"],
    );
    assert!(!d.join("x.svg").exists());
    let fixed = word_after(&err, "fix: give -o ").to_string();
    let wrote = ok(&[
        "plot",
        "lobe",
        "--model",
        "phong",
        "--set",
        "c1=10,ps=0.5,pd=0.5",
        "-o",
        &fixed,
    ]);
    assert!(
        wrote.contains(&format!("wrote {}", d.join("x.svg").display())),
        "{wrote}"
    );
}

//! Hand-written scene files and fix hints, as a new user meets them: a scene's `params` are
//! read with the bounds fit files are read with, every error names the file, line and key
//! with the fix, and every fix works when followed (each test runs the command the hint
//! gives). `-o NAME.EXT` with an extension the command does not write is refused.

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

/// `fit --fix` outside the fitter's box (c1 ≤ 1e8, Phong 1975's exponent as brdfit bounds
/// it) is refused at the flag with the box and the fix, and no JSON is written; before, the
/// fit ran and wrote a JSON that reading then refused. The fix followed writes a JSON that
/// reads back (`export`). With `--model all` the models that have c1 are checked too.
#[test]
fn fix_outside_the_fit_box_is_refused_at_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("p.json");
    let j = json.to_str().unwrap();
    let data = "data/blinn-mgo.csv";
    let err = fails(
        &[
            "fit", data, "--model", "phong", "--fix", "c1=1e9", "--json", j,
        ],
        &[
            "--fix c1=1e9 ",
            "0 < c1 ≤ 1e8",
            "fix: give --fix c1=VALUE with",
        ],
    );
    assert!(!json.exists(), "{err}");
    fails(
        &[
            "fit", data, "--model", "all", "--fix", "c1=1e9", "--json", j,
        ],
        &["0 < c1 ≤ 1e8"],
    );
    assert!(!json.exists());
    // n's box is 1 < n ≤ 1e7: n = 1 (F ≡ 0) is refused as well.
    fails(
        &["fit", data, "--fix", "n=1", "--json", j],
        &["--fix n=1 ", "1 < n ≤ 1e7"],
    );
    ok(&[
        "fit", data, "--model", "phong", "--fix", "c1=1e8", "--json", j,
    ]);
    ok(&["export", j, "--to", "mitsuba"]);
    // The same file edited by hand to c1 = 1e300 is refused on reading, the value written
    // back as 1e300 (it was printed with all 301 digits).
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let fit = if v.get("fits").is_some() {
        &mut v["fits"][0]
    } else {
        &mut v
    };
    fit["params"]["c1"] = serde_json::Value::from(1e300);
    let edited = dir.path().join("edited.json");
    std::fs::write(&edited, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    let err = fails(
        &["export", edited.to_str().unwrap(), "--to", "mitsuba"],
        &["params.c1 = 1e300 is outside the range a fit can return"],
    );
    assert!(!err.contains("10000000000"), "{err}");
}

/// `render fig7 -o x.jpg` made a folder named x.jpg; fig7 writes a folder, so a name with an
/// extension (not an existing folder) or an existing file is refused with the fix and nothing
/// is written; the fix followed writes the contact sheet in the folder it names.
#[test]
fn fig7_output_with_an_extension_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let jpg = d.join("x.jpg");
    let err = fails(
        &["render", "fig7", "--res", "8", "-o", jpg.to_str().unwrap()],
        &[
            "render fig7 writes a folder",
            "not a .jpg file",
            "fix: give a folder name",
        ],
    );
    assert!(!jpg.exists(), "{err}");
    let fixed = word_after(&err, "e.g. -o ");
    assert_eq!(Path::new(fixed), d.join("x").as_path());
    let wrote = ok(&["render", "fig7", "--res", "8", "-o", fixed]);
    let sheet = d.join("x").join("fig7.png");
    assert!(
        wrote.contains(&format!("wrote {}", sheet.display())),
        "{wrote}"
    );
    assert!(sheet.is_file());
    // An existing file is no folder.
    let file = write(d, "taken", b"not a folder");
    let err = fails(
        &["render", "fig7", "--res", "8", "-o", file.to_str().unwrap()],
        &["is a file", "fix: give a folder"],
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"not a folder");
    // Its fix, followed, works: it names a folder that is not the file itself.
    let fixed = word_after(&err, "e.g. -o ");
    assert_ne!(Path::new(fixed), file.as_path(), "{err}");
    ok(&["render", "fig7", "--res", "8", "-o", fixed]);
    assert!(Path::new(fixed).join("fig7.png").is_file(), "{err}");
    // So does the fix for a name with an extension whose stem is an existing file.
    let jpg = d.join("taken.jpg");
    let err = fails(
        &["render", "fig7", "--res", "8", "-o", jpg.to_str().unwrap()],
        &["not a .jpg file", "fix: give a folder name"],
    );
    let fixed = word_after(&err, "e.g. -o ");
    assert_ne!(Path::new(fixed), file.as_path(), "{err}");
    ok(&["render", "fig7", "--res", "8", "-o", fixed]);
    // An existing folder with a dot in its name is a folder.
    let dotted = d.join("run.v2");
    std::fs::create_dir(&dotted).unwrap();
    ok(&[
        "render",
        "fig7",
        "--res",
        "8",
        "-o",
        dotted.to_str().unwrap(),
    ]);
    assert!(dotted.join("fig7.png").is_file());
}

/// Every scene error names FILE:LINE and the key, not only those in `params`: the camera,
/// lights, objects, antialias and material keys, a value of the wrong type, a missing key (the
/// line of the table that lacks it). The lines are counted by hand in [`scene`]'s text.
#[test]
fn every_scene_error_names_its_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out.png");
    let base = scene("phong", "{ c1 = 10, ps = 0.5, pd = 0.5 }");
    let cases: [(&str, &str, usize, &str); 13] = [
        ("fov = 40.0", "fov = 240.0", 4, "`camera.fov` = 240"),
        (
            "fov = 40.0",
            "fov = \"x\"",
            4,
            "`fov = \"x\"`: invalid type",
        ),
        ("width = 8", "width = 0", 5, "`camera.width` = 0"),
        (
            "target = [0.0, 0.0, 0.0]",
            "target = [0.0, 1.0, 4.0]",
            3,
            "`camera.target`",
        ),
        (
            "intensity = 90.0",
            "intensity = -1.0",
            11,
            "light 1 (point): `intensity`",
        ),
        (
            "position = [3.0, 6.0, 5.0]",
            "size = 1.0",
            10,
            "unknown field `size`",
        ),
        (
            "position = [3.0, 6.0, 5.0]\n",
            "",
            8,
            "light 1 (point) needs `position`",
        ),
        (
            "model = \"phong\"",
            "model = \"phong\"\nks = 2.0",
            15,
            "`materials.m.ks` = 2",
        ),
        (
            "model = \"phong\"",
            "model = \"fong\"",
            14,
            "unknown model 'fong'",
        ),
        (
            "kind = \"sphere\"",
            "kind = \"cube\"",
            18,
            "object 1 (cube): unknown kind",
        ),
        (
            "radius = 1.0",
            "radius = -1.0",
            20,
            "object 1 (sphere): `radius` = -1",
        ),
        (
            "material = \"m\"",
            "material = \"q\"",
            21,
            "uses material 'q'",
        ),
        (
            "material = \"m\"\n",
            "material = \"m\"\n\n[antialias]\nmode = \"fuzzy\"\n",
            24,
            "`antialias.mode` 'fuzzy'",
        ),
    ];
    for (k, (from, to, line, key)) in cases.iter().enumerate() {
        assert_eq!(base.matches(from).count(), 1, "{from}");
        let text = base.replace(from, to);
        let path = write(d, &format!("s{k}.toml"), text.as_bytes());
        let at = format!("{}:{line}: ", path.display());
        let err = fails(
            &[
                "render",
                path.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ],
            &[at.as_str(), key, "fix: "],
        );
        assert!(!out.exists(), "{err}");
    }
}

/// A `params` material whose directional albedo is above 1 by more than fit's margin
/// (physical.rs's ALBEDO_MARGIN, 1e-3) renders with a warning naming the file, line, material,
/// albedo, θi and the fix; at or under it, no warning. Lambert's directional albedo is pd at
/// every θi (∫ pd/π cos θo dω = pd), so pd = 1.5 warns with 1.5 and pd = 1.0005 does not.
#[test]
fn scene_albedo_above_one_warns() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out.png");
    let o = out.to_str().unwrap();
    let bright = write(
        d,
        "bright.toml",
        scene("lambert", "{ pd = 1.5 }").as_bytes(),
    );
    let err = ok(&["render", bright.to_str().unwrap(), "-o", o]);
    let at = format!("warning: {}:15: material m: ", bright.display());
    for want in [
        at.as_str(),
        "directional albedo of 1.5 at θi = ",
        "reflects more light than it receives",
        "fix: lower ps or pd",
    ] {
        assert!(err.contains(want), "lacks '{want}':\n{err}");
    }
    assert!(out.exists());
    // --quiet keeps warnings.
    let err = ok(&["--quiet", "render", bright.to_str().unwrap(), "-o", o]);
    assert!(err.contains(&at), "{err}");
    for pd in ["1.0005", "0.5"] {
        let p = write(
            d,
            "near.toml",
            scene("lambert", &format!("{{ pd = {pd} }}")).as_bytes(),
        );
        let err = ok(&["render", p.to_str().unwrap(), "-o", o]);
        assert!(!err.contains("warning"), "pd = {pd}: {err}");
    }
}

/// `--fix q=1` (no such parameter) and `--start c3=5` (outside c3's bounds) were reported
/// against the data file ("data/blinn-mgo.csv: model torrance-sparrow has no parameter q"),
/// though the data are fine: they name the command line and the flag, and the fix followed fits.
#[test]
fn fix_and_start_errors_name_the_command_line() {
    let data = "data/blinn-mgo.csv";
    let err = fails(
        &["fit", data, "--fix", "q=1"],
        &[
            "on the command line: --fix q=1",
            "no parameter q",
            "n, c3, ps, pd",
        ],
    );
    assert!(!err.contains("blinn-mgo.csv"), "{err}");
    let err = fails(
        &["fit", data, "--model", "all", "--start", "q=1"],
        &["on the command line: --start q=1", "none of the models"],
    );
    assert!(!err.contains("blinn-mgo.csv"), "{err}");
    let err = fails(
        &["fit", data, "--start", "c3=5"],
        &[
            "on the command line: --start c3=5 is outside its bounds",
            "0 < c3 ≤ 1",
            "fix: give --start c3=VALUE",
        ],
    );
    assert!(!err.contains("blinn-mgo.csv"), "{err}");
    ok(&["fit", data, "--start", "c3=0.5"]);
}

/// `-o DIR` naming an existing folder, for a command that writes files named by -o (a scene's
/// render, a plot, `inverse`): refused with the fix, where it used to write DIR.png and
/// DIR.exr (DIR.svg, DIR.csv, …) beside the folder; nothing is written; the fix followed
/// writes inside the folder.
#[test]
fn an_existing_folder_as_a_file_output_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc = write(d, "s.toml", scene("lambert", "{ pd = 0.5 }").as_bytes());
    let out = d.join("renders");
    std::fs::create_dir(&out).unwrap();
    let o = out.to_str().unwrap();
    let err = fails(
        &["render", sc.to_str().unwrap(), "-o", o],
        &[
            "is a folder",
            "writes png and exr files",
            "fix: give a file name",
        ],
    );
    for ext in ["png", "exr"] {
        assert!(!out.with_extension(ext).exists(), "{err}");
    }
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0, "{err}");
    let fixed = word_after(&err, "e.g. -o ");
    assert_eq!(Path::new(fixed).parent(), Some(out.as_path()), "{err}");
    let wrote = ok(&["render", sc.to_str().unwrap(), "-o", fixed]);
    assert!(wrote.contains(&format!("wrote {fixed}")), "{wrote}");
    assert!(Path::new(fixed).is_file());
    let exr = Path::new(fixed).with_extension("exr");
    // A plot likewise.
    let fit = d.join("f.json");
    ok(&[
        "fit",
        "data/blinn-mgo.csv",
        "--model",
        "phong",
        "--json",
        fit.to_str().unwrap(),
    ]);
    let lobe = |o: &str| {
        vec![
            "plot".to_string(),
            "lobe".into(),
            "--fit".into(),
            fit.to_str().unwrap().into(),
            "--data".into(),
            "data/blinn-mgo.csv".into(),
            "-o".into(),
            o.into(),
        ]
    };
    let args = lobe(o);
    let err = fails(
        &args.iter().map(String::as_str).collect::<Vec<_>>(),
        &["is a folder", "writes svg and png files"],
    );
    for ext in ["svg", "png"] {
        assert!(!out.with_extension(ext).exists(), "{err}");
    }
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 2, "{err}");
    let fixed = word_after(&err, "e.g. -o ").to_string();
    assert_eq!(Path::new(&fixed).parent(), Some(out.as_path()), "{err}");
    let args = lobe(&fixed);
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(Path::new(&fixed).with_extension("png").is_file());
    // And `inverse` (three files from one base), on the render's own EXR.
    let inverse = |o: &str| {
        let e = exr.to_str().unwrap();
        [
            "inverse", e, "--row", "3", "--light", "0,0,1", "--cd", "1", "-o", o,
        ]
        .map(String::from)
    };
    let before = std::fs::read_dir(&out).unwrap().count();
    let err = fails(
        &inverse(o).iter().map(String::as_str).collect::<Vec<_>>(),
        &[
            "is a folder",
            "writes csv, svg and png files",
            "fix: give a file name",
        ],
    );
    for ext in ["csv", "svg", "png"] {
        assert!(!out.with_extension(ext).exists(), "{err}");
    }
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), before, "{err}");
    let fixed = word_after(&err, "e.g. -o ").to_string();
    assert_eq!(Path::new(&fixed).parent(), Some(out.as_path()), "{err}");
    ok(&inverse(&fixed)
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>());
    assert!(Path::new(&fixed).with_extension("csv").is_file());
    // A foreign extension: the three files it would write, listed.
    let jpg = d.join("x.jpg");
    let x = |e: &str| d.join(format!("x.{e}")).display().to_string();
    let want = format!("it writes {}, {} and {}", x("csv"), x("svg"), x("png"));
    fails(
        &inverse(jpg.to_str().unwrap())
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
        &[
            "this command writes csv, svg and png files, not .jpg",
            &want,
        ],
    );
}

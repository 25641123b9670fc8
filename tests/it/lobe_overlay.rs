//! `plot lobe --fit ALL.json`: every usable model of a `fit --model all` file in one polar
//! chart (Blinn 1977, Figures 5–6), one legend entry per model; a fit that cannot have been
//! made from the data drawn with it is refused, one of other values drawn with a warning.

use super::cli::{brdfit, expect_error};
use crate::common::{fit_object, write};

/// How often `needle` occurs in `hay`.
fn count(hay: &str, needle: &str) -> usize {
    hay.matches(needle).count()
}

/// A file of three models written by hand (ggx-smith recommended by its BIC), one of a fourth
/// marked not usable: three curves per panel, each named once in its panel's legend, the
/// recommended one so labelled; the unusable one only with --allow-unusable; --model draws one.
#[test]
fn every_usable_model_of_a_file_is_drawn() {
    let dir = tempfile::tempdir().unwrap();
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
    let phong = fit_object(
        "phong",
        "d3",
        "cie-y",
        r#"{"c1": 20, "ps": 0.3, "pd": 0.4}"#,
        r#", "unusable": ["a reason"]"#,
    );
    let f = write(
        dir.path(),
        "all.json",
        format!(r#"{{"fits": [{lambert}, {ggx}, {ts}, {phong}]}}"#).as_bytes(),
    );
    let o = dir.path().join("lobe");
    let plot = |extra: &[&str]| {
        let mut a = vec![
            "plot",
            "lobe",
            "--fit",
            f.to_str().unwrap(),
            "-o",
            o.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        let r = brdfit(&a);
        let err = String::from_utf8_lossy(&r.stderr).to_string();
        assert!(r.status.success(), "{err}");
        (
            std::fs::read_to_string(o.with_extension("svg")).unwrap(),
            err,
        )
    };
    let (svg, err) = plot(&[]);
    // Two panels (30° and 70°): each label once in each.
    assert_eq!(
        count(&svg, "ggx-smith fit (cie-y), recommended"),
        2,
        "{err}"
    );
    assert_eq!(count(&svg, "lambert fit (cie-y)"), 2);
    assert_eq!(count(&svg, "torrance-sparrow (d3) fit (cie-y)"), 2);
    assert_eq!(count(&svg, "phong fit"), 0);
    assert!(err.contains("drawing the file's 3 usable models"), "{err}");
    assert!(err.contains("not usable: phong"), "{err}");
    let (svg, _) = plot(&["--allow-unusable"]);
    assert_eq!(count(&svg, "phong fit (cie-y), not usable"), 2);
    let (svg, _) = plot(&["--model", "torrance-sparrow"]);
    assert_eq!(count(&svg, "torrance-sparrow (d3) fit (cie-y)"), 2);
    assert_eq!(count(&svg, "lambert fit"), 0);
    assert_eq!(count(&svg, "ggx-smith fit"), 0);
}

/// `fit --model all` of Blinn's MgO plotted over its data: one legend entry per model of the
/// file in each panel, below the panels where the chart grows for them (the PNG taller than
/// the 440 pixels of a chart with its legend inside).
#[test]
fn a_model_all_fit_over_its_data() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("all.json");
    let r = brdfit(&[
        "fit",
        "data/blinn-mgo.csv",
        "--model",
        "all",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(r.status.success());
    let fits: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let fits = fits["fits"].as_array().unwrap();
    let o = dir.path().join("lobe");
    let r = brdfit(&[
        "plot",
        "lobe",
        "--fit",
        json.to_str().unwrap(),
        "--data",
        "data/blinn-mgo.csv",
        "-o",
        o.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    let svg = std::fs::read_to_string(o.with_extension("svg")).unwrap();
    let mut drawn = 0;
    for f in fits {
        let kind = brdfit::ModelKind::parse(f["model"].as_str().unwrap()).unwrap();
        let dist = brdfit::Distribution::parse(f["distribution"].as_str().unwrap()).unwrap();
        let label = format!("{} fit", kind.label(dist));
        let usable = f["unusable"].as_array().is_none_or(|u| u.is_empty());
        // Each legend entry is its text's <title> ("phong fit" also ends "blinn-phong fit").
        let n = count(&svg, &format!("<title>{label},")) + count(&svg, &format!("<title>{label}<"));
        if usable {
            assert_eq!(n, 2, "{label}: {n}\n{err}");
            drawn += 1;
        }
    }
    assert!(drawn >= 5, "{drawn} models drawn");
    let png = image_height(&std::fs::read(o.with_extension("png")).unwrap());
    assert!(png > 440, "{png}");
}

/// The height of a PNG from its IHDR chunk (bytes 20–23).
fn image_height(png: &[u8]) -> u32 {
    u32::from_be_bytes([png[20], png[21], png[22], png[23]])
}

/// A fit of Blinn's MgO drawn over Blinn's aluminium (the same 10,000 directions, other
/// values): drawn with a warning naming its cost on these data (a fit file whose parameters
/// were edited looks the same, and is a model to draw); a fit that used more samples than the
/// data have is refused; a fit of the same data with --max-theta (fewer samples) is drawn.
#[test]
fn a_fit_of_other_data_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("mgo.json");
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
    let o = dir.path().join("lobe");
    let (j, os) = (json.to_str().unwrap(), o.to_str().unwrap());
    // Other values at the same angles (or edited parameters): drawn, with a warning.
    let out = brdfit(&[
        "plot",
        "lobe",
        "--fit",
        j,
        "--data",
        "data/blinn-aluminium.csv",
        "-o",
        os,
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning:") && err.contains("its cost on these data's 10000"),
        "{err}"
    );
    assert!(o.with_extension("svg").exists());
    std::fs::remove_file(o.with_extension("svg")).unwrap();
    let big = write(
        dir.path(),
        "big.json",
        fit_object(
            "torrance-sparrow",
            "d3",
            "brdf",
            r#"{"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333}"#,
            "",
        )
        .replace("\"samples_used\": 1000", "\"samples_used\": 20000")
        .as_bytes(),
    );
    expect_error(
        &[
            "plot",
            "lobe",
            "--fit",
            big.to_str().unwrap(),
            "--data",
            "data/blinn-mgo.csv",
            "-o",
            os,
        ],
        &["used 20000 samples", "have 10000 usable"],
    );
    let cut = dir.path().join("cut.json");
    assert!(
        brdfit(&[
            "fit",
            "data/blinn-mgo.csv",
            "--max-theta",
            "60",
            "--json",
            cut.to_str().unwrap()
        ])
        .status
        .success()
    );
    let r = brdfit(&[
        "plot",
        "lobe",
        "--fit",
        cut.to_str().unwrap(),
        "--data",
        "data/blinn-mgo.csv",
        "-o",
        os,
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}

//! Exports: tabulated formats load back and agree with the model; text formats carry the
//! fitted values with the documented mapping.

use brdfit::data::{self, LoadOptions};
use brdfit::export;
use brdfit::fit::Colour;
use brdfit::model::{Distribution, Geometry, MaterialKind, Model, ModelKind};

#[test]
fn merl_and_csv_exports_load_back_equal_to_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let m = Model::blinn_mgo();
    let p = dir.path().join("mgo.binary");
    data::merl::write_merl(&export::merl_dataset(&Colour::grey(&m)), &p).unwrap();
    let ds = data::load(&p, &LoadOptions::default()).unwrap();
    assert!(ds.len() > 500_000);
    for k in (0..ds.len()).step_by(101) {
        let a = ds.angles(k);
        let f = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        for c in 0..3 {
            assert!((ds.channels[c].values[k] - f).abs() <= 1e-12 * (1.0 + f));
        }
    }
    let p = dir.path().join("mgo.csv");
    data::write_csv(&export::grid_dataset(&Colour::grey(&m)), &p).unwrap();
    let ds = data::load(&p, &LoadOptions::default()).unwrap();
    assert_eq!(ds.len(), 18 * 18 * 24);
    for k in (0..ds.len()).step_by(37) {
        let a = ds.angles(k);
        let f = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        assert!((ds.channels[0].values[k] - f).abs() <= 1e-9 * (1.0 + f));
    }
}

#[test]
fn text_exports_carry_the_mapping() {
    let mgo = Model::blinn_mgo();
    // Mitsuba has no Torrance–Sparrow: the export is a ggx-smith refit, its error stated.
    let x = export::mitsuba(&Colour::grey(&mgo), "mgo").unwrap();
    assert!(x.contains("blendbsdf") && x.contains("refitted:") && x.contains("by a median"));
    // The refit's error statistics read in order: median ≤ 95th percentile ≤ largest (they
    // were printed at different precisions, so a 0.01 % median showed above a "0.0 %" p95).
    let stats: Vec<f64> = x
        .split("by a median ")
        .nth(1)
        .unwrap()
        .split(" %")
        .take(3)
        .map(|t| t.rsplit(' ').next().unwrap().parse::<f64>().unwrap())
        .collect();
    assert!(
        stats[0] <= stats[1] && stats[1] <= stats[2],
        "{stats:?}: {x}"
    );
    assert_eq!(x.matches("<bsdf").count(), x.matches("</bsdf>").count());
    let al = Model::blinn_aluminium();
    assert!(export::pbrt(&Colour::grey(&al)).contains("\"conductor\" \"float roughness\" [ 0.5 ]"));
    let p = export::pbrt(&Colour::grey(&mgo));
    assert!(p.contains("coateddiffuse") && p.contains("\"float eta\" [ 1.8 ]"));
    assert!(p.contains("Smith masking"));
    // Each export names the lobe its GGX replaces (an ABC fit used to be described as D3).
    assert!(p.contains("D3 with peak 1"), "{p}");
    let abc = Model::new(
        ModelKind::TorranceSparrow,
        Distribution::Abc,
        &[1.5, 400.0, 0.8, 0.3, 0.2],
    )
    .unwrap();
    let p = export::pbrt(&Colour::grey(&abc));
    assert!(p.contains("ABC lobe") && p.contains("c = 0.8") && p.contains("heavier tail"));
    assert!(!p.contains("D3"), "{p}");
    let ph = Model::new(ModelKind::Phong, Distribution::D3, &[20.0, 0.5, 0.1]).unwrap();
    let p = export::pbrt(&Colour::grey(&ph));
    assert!(p.contains("cosine power") && !p.contains("D3"), "{p}");
    let b = export::brdf_explorer(&Colour::grey(&mgo)).unwrap();
    assert!(
        b.starts_with("analytic")
            && b.contains("float c3 0.001 1 0.35")
            && b.contains("float n 1 20 1.8")
    );
    assert!(b.contains("::begin shader") && b.contains("::end shader"));
    // Beckmann-matched α of a cosine power: √(2/(c1+2)).
    let bp = Model::new(ModelKind::BlinnPhong, Distribution::D3, &[98.0, 0.5, 0.5]).unwrap();
    // The mapping is a serde value (tagged by material type), read back equal.
    let mat = bp.material();
    let text = serde_json::to_string(&mat).unwrap();
    assert!(text.contains("\"type\":\"plastic\""), "{text}");
    assert_eq!(
        serde_json::from_str::<brdfit::model::Material>(&text).unwrap(),
        mat
    );
    match bp.material().kind {
        MaterialKind::Plastic { alpha, .. } => {
            assert!((alpha - (2.0f64 / 100.0).sqrt()).abs() < 1e-15)
        }
        other => panic!("{other:?}"),
    }
}

/// A Python that imports Mitsuba 3: `BRDFIT_PYTHON`, else `python3`. None (with a visible
/// message) when there is none, unless `BRDFIT_REQUIRE_MITSUBA=1` (set by `.ci/run`) makes its
/// absence a failure.
fn mitsuba_python() -> Option<String> {
    let py = std::env::var("BRDFIT_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = std::process::Command::new(&py)
        .args(["-c", "import mitsuba; mitsuba.set_variant('scalar_rgb')"])
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        return Some(py);
    }
    if std::env::var("BRDFIT_REQUIRE_MITSUBA").as_deref() == Ok("1") {
        panic!("BRDFIT_REQUIRE_MITSUBA=1 but {py} cannot import mitsuba (pip install mitsuba)");
    }
    eprintln!(
        "SKIPPED: {py} cannot import mitsuba; the Mitsuba export test did not run (pip install mitsuba, or set BRDFIT_PYTHON)"
    );
    None
}

fn brdfit(args: &[&str]) -> std::process::Output {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// The last column of each data row of a CSV (skipping `#` comments and the header), or all
/// columns with `all`.
fn csv_rows(p: &std::path::Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect()
}

/// Each exact Mitsuba export loads in Mitsuba 3 and its f_r (bsdf.eval /
/// cos θo) equals `brdfit eval` of the fitted parameters at 300 directions, to float32
/// precision: a grey ggx-smith with 2 ps > 1 (Mitsuba refuses such an `<rgb>`), a Lambert, and
/// an RGB ggx-smith (per-channel ps, pd, one lobe). A Torrance–Sparrow fit is exported as a
/// ggx-smith refit: Mitsuba evaluates the refit exactly, and its median difference from the
/// Torrance–Sparrow model is the one the file states.
#[test]
fn mitsuba_loads_each_export_and_evaluates_the_fitted_f_r() {
    let Some(py) = mitsuba_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 300 directions, θ up to 85°, spread by a fixed low-discrepancy sequence.
    let mut dirs = String::from("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n");
    let frac = |x: f64| x - x.floor();
    for k in 0..300 {
        let k = k as f64;
        let (ti, to, po) = (
            85.0 * frac(0.5 + k * 0.618_033_988_75),
            85.0 * frac(0.5 + k * 0.754_877_666_2),
            360.0 * frac(0.5 + k * 0.569_840_290_9),
        );
        dirs += &format!("{ti},0,{to},{po}\n");
    }
    let dirs_p = d.join("dirs.csv");
    std::fs::write(&dirs_p, dirs).unwrap();
    let fit = |name: &str, body: &str| {
        let p = d.join(name);
        std::fs::write(&p, body).unwrap();
        p
    };
    let obj = |model: &str, channel: &str, params: &str| {
        format!(
            r#"{{"model": "{model}", "distribution": "d3", "loss": "log", "method": "lm", "channel": "{channel}", "params": {params}, "cost": 1, "rmse": 0.01, "samples_used": 100, "bic": 1, "aic": 1, "n_free": 4}}"#
        )
    };
    let eval = |model: &str, set: &str| -> Vec<f64> {
        let out = d.join("eval.csv");
        brdfit(&[
            "eval",
            "--model",
            model,
            "--set",
            set,
            dirs_p.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        csv_rows(&out).iter().map(|r| *r.last().unwrap()).collect()
    };
    let mitsuba = |f: &std::path::Path| -> (Vec<[f64; 3]>, String) {
        let xml = f.with_extension("xml");
        brdfit(&[
            "export",
            f.to_str().unwrap(),
            "--to",
            "mitsuba",
            "-o",
            xml.to_str().unwrap(),
        ]);
        let out = d.join("mitsuba.csv");
        let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/mitsuba_eval.py");
        let o = std::process::Command::new(&py)
            .args([
                script,
                xml.to_str().unwrap(),
                dirs_p.to_str().unwrap(),
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "Mitsuba refused {}: {}",
            xml.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let rows = csv_rows(&out).iter().map(|r| [r[0], r[1], r[2]]).collect();
        (rows, std::fs::read_to_string(&xml).unwrap())
    };
    let worst = |got: &[[f64; 3]], want: &[[f64; 3]]| -> f64 {
        assert_eq!(got.len(), want.len());
        let mut w: f64 = 0.0;
        for (g, e) in got.iter().zip(want) {
            for c in 0..3 {
                w = w.max((g[c] - e[c]).abs() / e[c].abs().max(1e-3));
            }
        }
        w
    };
    let grey = |v: Vec<f64>| -> Vec<[f64; 3]> { v.into_iter().map(|x| [x; 3]).collect() };

    // Grey ggx-smith, ps = 2.918 (Blinn's MgO fitted as ggx-smith): 2 ps = 5.8 > 1.
    let p =
        "alpha=0.3597960670815164,n=1.0790503179889979,ps=2.918172701073896,pd=0.34839607675890433";
    let f = fit(
        "ggx.json",
        &obj(
            "ggx-smith",
            "brdf",
            r#"{"alpha": 0.3597960670815164, "n": 1.0790503179889979, "ps": 2.918172701073896, "pd": 0.34839607675890433}"#,
        ),
    );
    let (got, xml) = mitsuba(&f);
    assert!(
        xml.contains("5.836345402147792") && xml.contains("(exact)"),
        "{xml}"
    );
    let e = worst(&got, &grey(eval("ggx-smith", p)));
    eprintln!("ggx-smith grey: largest relative difference {e:.2e}");
    assert!(e < 2e-5, "{e}");

    // Lambert.
    let f = fit("lambert.json", &obj("lambert", "brdf", r#"{"pd": 0.7}"#));
    let (got, _) = mitsuba(&f);
    let e = worst(&got, &grey(eval("lambert", "pd=0.7")));
    assert!(e < 2e-6, "{e}");

    // RGB ggx-smith: one lobe, per-channel ps and pd (written as an unbounded sRGB texture).
    let chans = [("r", 1.2, 0.6), ("g", 0.8, 0.3), ("b", 0.1, 0.05)];
    let fits: Vec<String> = chans
        .iter()
        .map(|(c, ps, pd)| {
            obj(
                "ggx-smith",
                c,
                &format!(r#"{{"alpha": 0.2, "n": 1.5, "ps": {ps}, "pd": {pd}}}"#),
            )
        })
        .collect();
    let f = fit("rgb.json", &format!(r#"{{"fits": [{}]}}"#, fits.join(",")));
    let (got, xml) = mitsuba(&f);
    assert!(
        xml.contains("unbounded") && !xml.contains("compromise"),
        "{xml}"
    );
    let per: Vec<Vec<f64>> = chans
        .iter()
        .map(|(_, ps, pd)| eval("ggx-smith", &format!("alpha=0.2,n=1.5,ps={ps},pd={pd}")))
        .collect();
    let want: Vec<[f64; 3]> = (0..300)
        .map(|k| [per[0][k], per[1][k], per[2][k]])
        .collect();
    let e = worst(&got, &want);
    eprintln!("ggx-smith rgb: largest relative difference {e:.2e}");
    assert!(e < 2e-5, "{e}");

    // ggx-smith-2, grey: a sharp and a broad lobe (3 ps1 = 3.6 > 1), nested blendbsdfs.
    let p = "alpha1=0.03,ps1=1.2,alpha2=0.4,ps2=0.5,n=1.6,pd=0.15";
    let f = fit(
        "ggx2.json",
        &obj(
            "ggx-smith-2",
            "brdf",
            r#"{"alpha1": 0.03, "ps1": 1.2, "alpha2": 0.4, "ps2": 0.5, "n": 1.6, "pd": 0.15}"#,
        ),
    );
    let (got, xml) = mitsuba(&f);
    assert!(xml.contains("(exact)"), "{xml}");
    let e = worst(&got, &grey(eval("ggx-smith-2", p)));
    eprintln!("ggx-smith-2 grey: largest relative difference {e:.2e}");
    assert!(e < 2e-5, "{e}");

    // ggx-smith-2, RGB: one pair of lobes, per-channel ps1, ps2 and pd.
    let chans2 = [
        ("r", 0.5, 0.3, 0.15),
        ("g", 0.7, 0.3, 0.3),
        ("b", 0.2, 0.4, 0.05),
    ];
    let fits: Vec<String> = chans2
        .iter()
        .map(|(c, ps1, ps2, pd)| {
            obj(
                "ggx-smith-2",
                c,
                &format!(
                    r#"{{"alpha1": 0.05, "ps1": {ps1}, "alpha2": 0.3, "ps2": {ps2}, "n": 1.5, "pd": {pd}}}"#
                ),
            )
        })
        .collect();
    let f = fit("rgb2.json", &format!(r#"{{"fits": [{}]}}"#, fits.join(",")));
    let (got, xml) = mitsuba(&f);
    assert!(
        xml.contains("unbounded") && !xml.contains("compromise"),
        "{xml}"
    );
    let per: Vec<Vec<f64>> = chans2
        .iter()
        .map(|(_, ps1, ps2, pd)| {
            eval(
                "ggx-smith-2",
                &format!("alpha1=0.05,ps1={ps1},alpha2=0.3,ps2={ps2},n=1.5,pd={pd}"),
            )
        })
        .collect();
    let want: Vec<[f64; 3]> = (0..300)
        .map(|k| [per[0][k], per[1][k], per[2][k]])
        .collect();
    let e = worst(&got, &want);
    eprintln!("ggx-smith-2 rgb: largest relative difference {e:.2e}");
    assert!(e < 2e-5, "{e}");

    // Torrance–Sparrow (Blinn's MgO): the refit loads, and its stated median error is the one
    // Mitsuba's values show against the Torrance–Sparrow model.
    let f = fit(
        "ts.json",
        &obj(
            "torrance-sparrow",
            "brdf",
            r#"{"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333}"#,
        ),
    );
    let (got, xml) = mitsuba(&f);
    assert!(xml.contains("refitted:"), "{xml}");
    let ts = eval("torrance-sparrow", "n=1.8,c3=0.35,ps=0.667,pd=0.333");
    let mut rel: Vec<f64> = got
        .iter()
        .zip(&ts)
        .map(|(g, t)| (g[1] - t).abs() / t)
        .collect();
    rel.sort_by(f64::total_cmp);
    let median = 100.0 * rel[rel.len() / 2];
    let stated: f64 = xml
        .split("by a median ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap();
    eprintln!("torrance-sparrow refit: median {median:.2} % at 300 directions, stated {stated} %");
    assert!(median < 15.0, "the refit is close: {median} %");
    assert!(
        (median - stated).abs() < 0.5 * stated.max(1.0),
        "measured {median} %, stated {stated} %"
    );
}

/// Spectral fits become colour through CIE 1931: a flat spectrum is grey (white = a flat
/// spectrum), and a spectrum bright only from 600 nm on is red (r well above g and b).
#[test]
fn spectral_fits_export_as_colour() {
    use brdfit::fit::{Want, pick, read_fit_file};
    let file = |pd: &dyn Fn(f64) -> f64| {
        let fits: Vec<String> = (0..31)
            .map(|k| {
                let l = 400.0 + 10.0 * k as f64;
                format!(
                    r#"{{"model": "lambert", "channel": "{l}nm", "params": {{"pd": {}}}, "cost": 1, "rmse": 1, "samples_used": 1, "bic": 1, "aic": 1, "n_free": 1}}"#,
                    pd(l)
                )
            })
            .collect();
        let fits = read_fit_file(&format!(r#"{{"fits": [{}]}}"#, fits.join(","))).unwrap();
        pick(&fits, &Want::default()).unwrap().colour().unwrap()
    };
    let flat = file(&|_| 0.4);
    for v in flat.pd {
        assert!((v - 0.4).abs() < 1e-12, "{:?}", flat.pd);
    }
    assert!(flat.notes[0].contains("CIE 1931"), "{:?}", flat.notes);
    let red = file(&|l| if l >= 600.0 { 0.8 } else { 0.05 });
    assert!(
        red.pd[0] > 0.5 && red.pd[1] < 0.3 && red.pd[2] < 0.15,
        "{:?}",
        red.pd
    );
    // Light at 500–520 nm lies outside the sRGB gamut (its linear red is negative, CIE 1931):
    // red is clamped to 0, and a note says so.
    let green = file(&|l| {
        if (500.0..=520.0).contains(&l) {
            0.8
        } else {
            0.0
        }
    });
    assert!(green.pd[0] == 0.0 && green.pd[1] > 0.0, "{:?}", green.pd);
    assert!(
        green
            .notes
            .iter()
            .any(|n| n.contains("outside the sRGB gamut: pd") && n.contains("clamped to 0")),
        "{:?}",
        green.notes
    );
    assert!(
        !flat.notes.iter().any(|n| n.contains("gamut")),
        "{:?}",
        flat.notes
    );
}

/// The Mitsuba refit states its error and warns where it is not faithful (95th percentile
/// above 10 %): Phong's lobe about the mirror direction R is not a half-vector lobe, while
/// Blinn's D3 is GGX's shape. A channel without a diffuse part (pd 0) is measured on what it
/// shows, not on a lobe tail 10⁻⁹ of its peak (that read 600 %).
#[test]
fn mitsuba_refit_warns_where_it_is_not_faithful() {
    let p95 = |x: &str| -> f64 {
        let t = x.split("95th percentile ").nth(1).unwrap();
        t.split(' ').next().unwrap().parse().unwrap()
    };
    let phong = Model::new(ModelKind::Phong, Distribution::D3, &[20.0, 0.5, 0.1]).unwrap();
    let x = export::mitsuba(&Colour::grey(&phong), "p").unwrap();
    assert!(
        p95(&x) > 10.0 && x.contains("warning: the refit is more than 10 % off"),
        "{x}"
    );
    // data/cayman.astm's colour fit (31 wavelengths): a sharp D3 lobe of index 1.05 whose red
    // pd is clamped to 0 (outside the sRGB gamut).
    let cayman = Model::new(
        ModelKind::TorranceSparrow,
        Distribution::D3,
        &[1.05, 0.0051, 1.79, 0.037],
    )
    .unwrap();
    let mut c = Colour::grey(&cayman);
    c.pd = [0.0, 0.037, 0.059];
    c.ps = [1.73, 1.79, 1.84];
    let x = export::mitsuba(&c, "m").unwrap();
    assert!(p95(&x) < 10.0 && !x.contains("warning"), "{x}");
}

/// An RGB fit whose channels' lobes differ (VCH golden yellow, ggx-smith per channel: n from
/// 1.3 to 10) becomes one colour material under the green channel's lobe. Each channel's ps
/// and pd are refitted under that lobe, so every channel stays near its own model: median
/// relative f_r error on a 5°/15° grid below 25 %. (Keeping blue's own ps with green's index
/// made blue's mirror value 75 times its own model's.)
#[test]
fn a_colour_compromise_keeps_each_channel_near_its_own_model() {
    let ds = data::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/vch_golden_yellow_rgb.csv"),
        &LoadOptions::default(),
    )
    .unwrap();
    let fits = brdfit::fit::fit(&ds, &brdfit::FitOptions::new(ModelKind::GgxSmith)).unwrap();
    assert_eq!(fits.len(), 3);
    let picked = brdfit::fit::pick(&fits, &brdfit::fit::Want::default()).unwrap();
    let colour: Colour = picked.colour().unwrap();
    assert!(!colour.exact, "the channels' lobes differ: a compromise");
    // Its Mitsuba XML: no comment holds `--` (XML 1.0 §2.5 forbids it; Python's parsers
    // refuse the file), and the heading does not call the compromise exact.
    let xml = brdfit::export::mitsuba(&colour, "m").unwrap();
    let mut rest = xml.as_str();
    while let Some(a) = rest.find("<!--") {
        let body = &rest[a + 4..];
        let b = body.find("-->").expect("a closed comment");
        assert!(!body[..b].contains("--"), "{}", &body[..b]);
        rest = &body[b + 3..];
    }
    assert!(
        xml.contains("compromise") && !xml.contains("(exact)"),
        "{xml}"
    );
    for (c, f) in fits.iter().enumerate() {
        let own = f.model_for(0);
        let shared = colour.channel_model(c);
        let mut rel = Vec::new();
        for ti in [15.0f64, 35.0, 55.0, 75.0] {
            for to in (0..=16).map(|k| f64::from(k) * 5.0) {
                for dp in (0..=12).map(|k| f64::from(k) * 15.0) {
                    let g = Geometry::from_angles(
                        ti.to_radians(),
                        0.0,
                        to.to_radians(),
                        (180.0 - dp).to_radians(),
                    );
                    let (a, b) = (shared.brdf(&g), own.brdf(&g));
                    rel.push(((a - b) / b).abs());
                }
            }
        }
        rel.sort_by(f64::total_cmp);
        let median = rel[rel.len() / 2];
        assert!(median < 0.25, "channel {c}: median relative error {median}");
    }
}

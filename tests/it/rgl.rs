//! RGL `.bsdf` export: Mitsuba 3's `measured` plugin loads what `brdfit export --to rgl-bsdf`
//! writes and evaluates it as `brdfit eval` evaluates the fitted model.

use super::export::{brdfit, csv_rows, mitsuba_python};
use brdfit::model::tabulated_ndf::ggx_table;

/// A tabulated-NDF material (a GGX α = 0.25 table with a shoulder added, so no analytic model
/// has it) and an RGB ggx-smith, each exported with `--to rgl-bsdf` and evaluated by Mitsuba 3
/// (`measured`, scalar_rgb) at 400 directions with θi, θo ≤ 80° and 2 ≤ θh: the median
/// relative difference from `brdfit eval` is below 1 % on every channel, the 90th percentile
/// below 5 % (the file is a table: bilinear on a 64 × 64 grid of microfacet normals, linear
/// between incidence angles 2° apart).
#[test]
fn mitsuba_evaluates_the_rgl_export_as_brdfit_does() {
    let Some(py) = mitsuba_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut dirs = String::from("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n");
    let frac = |x: f64| x - x.floor();
    for k in 0..400 {
        let k = k as f64;
        let (ti, pi, to, po) = (
            80.0 * frac(0.5 + k * 0.618_033_988_75),
            360.0 * frac(0.5 + k * 0.414_213_562_4),
            80.0 * frac(0.5 + k * 0.754_877_666_2),
            360.0 * frac(0.5 + k * 0.569_840_290_9),
        );
        dirs += &format!("{ti},{pi},{to},{po}\n");
    }
    let dirs_p = d.join("dirs.csv");
    std::fs::write(&dirs_p, dirs).unwrap();
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
    let mitsuba = |name: &str, json: &str| -> Vec<[f64; 3]> {
        let f = d.join(format!("{name}.json"));
        std::fs::write(&f, json).unwrap();
        let bsdf = d.join(format!("{name}.bsdf"));
        let o = brdfit(&[
            "export",
            f.to_str().unwrap(),
            "--to",
            "rgl-bsdf",
            "-o",
            bsdf.to_str().unwrap(),
        ]);
        assert!(String::from_utf8_lossy(&o.stderr).contains("wrote "));
        let out = d.join("mitsuba.csv");
        let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/mitsuba_eval.py");
        let o = std::process::Command::new(&py)
            .args([
                script,
                bsdf.to_str().unwrap(),
                dirs_p.to_str().unwrap(),
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "Mitsuba refused {}: {}",
            bsdf.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        csv_rows(&out).iter().map(|r| [r[0], r[1], r[2]]).collect()
    };
    // Relative differences where θh ≥ 2° (the first θm cells are 0.02°, 0.09°, … wide and the
    // mirror peak of a sharp lobe falls between incidence angles), per channel: (median, p90).
    let compare = |label: &str, got: &[[f64; 3]], want: &[[f64; 3]]| {
        let rows = csv_rows(&dirs_p);
        for c in 0..3 {
            let mut rel: Vec<f64> = got
                .iter()
                .zip(want)
                .zip(&rows)
                .filter(|(_, r)| {
                    let g = brdfit::Geometry::from_angles(
                        r[0].to_radians(),
                        r[1].to_radians(),
                        r[2].to_radians(),
                        r[3].to_radians(),
                    );
                    g.nh.acos().to_degrees() >= 2.0
                })
                .map(|((g, w), _)| (g[c] / w[c] - 1.0).abs())
                .collect();
            rel.sort_by(f64::total_cmp);
            let (med, p90) = (rel[rel.len() / 2], rel[rel.len() * 9 / 10]);
            eprintln!(
                "{label} channel {c}: {} directions, median {med:.4}, p90 {p90:.4}",
                rel.len()
            );
            assert!(
                med < 0.01 && p90 < 0.05,
                "{label} channel {c}: median {med}, p90 {p90}"
            );
        }
    };

    // Grey tabulated-ndf.
    let mut t = ggx_table(0.25);
    for (k, v) in t.iter_mut().enumerate() {
        *v += 0.02 * (-((k as f64 - 12.0) / 3.0).powi(2)).exp();
    }
    let names: Vec<String> = (1..=32).map(|k| format!("t{k}")).collect();
    let mut set: Vec<String> = names
        .iter()
        .zip(&t)
        .map(|(n, v)| format!("{n}={v}"))
        .collect();
    set.extend(["n=1.6".into(), "ps=0.9".into(), "pd=0.3".into()]);
    let json: Vec<String> = set
        .iter()
        .map(|kv| {
            let (k, v) = kv.split_once('=').unwrap();
            format!(r#""{k}": {v}"#)
        })
        .collect();
    let got = mitsuba(
        "tab",
        &obj("tabulated-ndf", "brdf", &format!("{{{}}}", json.join(", "))),
    );
    let want: Vec<[f64; 3]> = eval("tabulated-ndf", &set.join(","))
        .into_iter()
        .map(|v| [v; 3])
        .collect();
    compare("tabulated-ndf", &got, &want);

    // RGB ggx-smith, per-channel ps and pd.
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
    let got = mitsuba("rgb", &format!(r#"{{"fits": [{}]}}"#, fits.join(",")));
    let per: Vec<Vec<f64>> = chans
        .iter()
        .map(|(_, ps, pd)| eval("ggx-smith", &format!("alpha=0.2,n=1.5,ps={ps},pd={pd}")))
        .collect();
    let want: Vec<[f64; 3]> = (0..400)
        .map(|k| [per[0][k], per[1][k], per[2][k]])
        .collect();
    compare("ggx-smith rgb", &got, &want);
}

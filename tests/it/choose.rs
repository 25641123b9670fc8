//! `brdfit choose`: the measurement as a material, scene-weighted samples, image metrics
//! against NVIDIA's ꟻLIP, and the choices Blinn's Figure 7 predicts.

use brdfit::choose::{self, ChooseOptions, fig7_cases};
use brdfit::model::{Distribution, Model, ModelKind};
use brdfit::render::compare;
use brdfit::render::measured::{Dims, Tabulated};
use brdfit::simulate::Grid;
use glam::DVec3;
use std::sync::Arc;

/// ꟻLIP p99 of `b` against `a` over `mask`.
fn flip_p99(a: &brdfit::render::Image, b: &brdfit::render::Image, mask: &[bool]) -> f64 {
    let map = compare::flip(
        &brdfit::render::to_srgb8(a),
        &brdfit::render::to_srgb8(b),
        a.width,
        a.height,
    );
    compare::summarise(&map, mask, 0.05).p99
}

/// A data set simulated densely from Blinn's MgO, resampled with a *wrong* fill model
/// (Lambert), renders within a small error of the model itself: the resampling and lookup
/// carry the measurement, not the fill. Stated in the README: front lit ꟻLIP p99 ≤ 0.02 and
/// RMSE ≤ 0.002; edge lit ≤ 0.06 and ≤ 0.03, because the crescent reaches θ > 88°, where the
/// simulated hemisphere has no sample and the (wrong) fill shows; with the right fill edge lit
/// is ≤ 0.01.
#[test]
fn dense_simulated_measurement_renders_as_its_model() {
    let truth = Model::blinn_mgo();
    let ds = brdfit::simulate(&truth, &Grid::Hemisphere(200_000).directions(3), 0.0, 3);
    let wrong = Model::new(ModelKind::Lambert, Distribution::D3, &[0.333]).unwrap();
    let table = Arc::new(Tabulated::resample(&ds, Dims::for_samples(ds.len()), wrong));
    assert!(table.fill_share() < 0.2, "fill {}", table.fill_share());
    for case in fig7_cases(256) {
        let mut model = case.scene.clone();
        model.materials[0].model = truth;
        let mut measured = model.clone();
        measured.materials[0].measured = Some(table.clone());
        let (a, b) = (model.render(&|| {}), measured.render(&|| {}));
        let (_, mask) = model.lit_configurations(0);
        let f = flip_p99(&a, &b, &mask);
        let rmse = compare::rmse(&a.pixels, &b.pixels, &mask);
        // Stated in the README: ꟻLIP p99 ≤ 0.02 and RMSE ≤ 0.01 of linear radiance.
        let (p99, rms) = if case.name == "front" {
            (0.02, 0.002)
        } else {
            (0.06, 0.03)
        };
        assert!(f <= p99, "{}: ꟻLIP p99 {f}", case.name);
        assert!(rmse <= rms, "{}: RMSE {rmse}", case.name);
        let right = Arc::new(Tabulated::resample(&ds, table.dims, truth));
        let mut exact = model.clone();
        exact.materials[0].measured = Some(right);
        let e = exact.render(&|| {});
        let fe = flip_p99(&a, &e, &mask);
        assert!(fe <= 0.01, "{}: right fill, ꟻLIP p99 {fe}", case.name);
        // The wrong fill alone is far off: the test can fail.
        let mut fill = model.clone();
        fill.materials[0].model = wrong;
        let c = fill.render(&|| {});
        let g = flip_p99(&a, &c, &mask);
        assert!(g > 0.1, "{}: the fill model alone gives {g}", case.name);
    }
}

/// A scene lit from the eye (a point light at the camera) shows only configurations with
/// L = E: θi = θo and φo − φi = 0, worked by hand from the geometry.
#[test]
fn eye_lit_scene_samples_have_light_equal_to_eye() {
    let mut case = fig7_cases(64).remove(0);
    case.scene.lights = vec![brdfit::render::Light::Point {
        position: case.scene.camera.eye,
        intensity: DVec3::splat(10.0),
    }];
    let (configs, mask) = case.scene.lit_configurations(0);
    assert!(configs.len() > 1000, "{} lit pixels", configs.len());
    assert_eq!(configs.len(), mask.iter().filter(|&&m| m).count());
    for c in &configs {
        assert!((c[0] - c[1]).abs() < 1e-9, "θi {} θo {}", c[0], c[1]);
        assert!(c[2].abs() < 1e-6 || c[0] < 1e-6, "Δφ {}", c[2]);
    }
    // The binned sample set keeps that: every sample has L = E, weights sum to the pixels.
    let m = Model::blinn_mgo();
    let (ds, _, lit) = choose::scene_samples(&case.scene, 0, &|g| m.brdf(g));
    assert_eq!(lit, configs.len());
    let w: f64 = ds.weights.as_ref().unwrap().iter().sum();
    assert_eq!(w as usize, lit);
    for k in 0..ds.len() {
        assert!((ds.theta_i[k] - ds.theta_o[k]).abs() < 1e-9);
        assert!(ds.phi_o[k].abs() < 1e-6);
    }
}

/// Blinn's sphere front lit at 512² has more 1° configurations than
/// `MAX_FINE_CONFIGURATIONS`, so they are binned to 2°: fewer bins, weights still summing to
/// the lit pixels, and the weighted sum of each bin's value at its mean configuration equal,
/// to 1e-3, to the sum of f_r cosθi over every lit pixel's own configuration (computed here
/// pixel by pixel from `lit_configurations`, for Blinn's MgO and for a sharper lobe, c3 0.1).
#[test]
fn coarsened_scene_samples_keep_the_pixel_sum() {
    let case = fig7_cases(512).remove(0);
    assert_eq!(case.name, "front");
    let (configs, _) = case.scene.lit_configurations(0);
    let sharp = Model::new(
        ModelKind::TorranceSparrow,
        Distribution::D3,
        &[1.8, 0.1, 0.667, 0.333],
    )
    .unwrap();
    for m in [Model::blinn_mgo(), sharp] {
        let (ds, _, lit) = choose::scene_samples(&case.scene, 0, &|g| m.brdf(g));
        assert_eq!(lit, configs.len());
        assert!(
            ds.len() <= choose::MAX_FINE_CONFIGURATIONS && ds.len() * 10 < lit,
            "{} bins for {lit} pixels",
            ds.len()
        );
        let w = ds.weights.as_ref().unwrap();
        assert_eq!(w.iter().sum::<f64>() as usize, lit);
        let binned: f64 = (0..ds.len())
            .map(|k| w[k] * ds.channels[0].values[k] * ds.theta_i[k].cos())
            .sum();
        let direct: f64 = configs
            .iter()
            .map(|c| {
                let g = brdfit::model::Geometry::from_angles(c[0], 0.0, c[1], c[2]);
                m.brdf(&g) * c[0].cos()
            })
            .sum();
        let rel = (binned / direct - 1.0).abs();
        assert!(rel < 1e-3, "binned {binned} direct {direct} ({rel:e})");
    }
}

/// ΔE_ITP over a mask: on the mask each pixel's `delta_e_itp` of its two colours, 0 elsewhere;
/// so its summary over the mask equals the whole map's.
#[test]
fn masked_delta_e_itp_is_the_map_on_the_mask() {
    let case = fig7_cases(64).remove(1);
    let a = case.scene.render(&|| {});
    let mut s = case.scene.clone();
    s.materials[0].model = Model::blinn_aluminium();
    let b = s.render(&|| {});
    let (_, mask) = case.scene.lit_configurations(0);
    assert!(mask.iter().any(|&m| m) && mask.iter().any(|&m| !m));
    let masked = compare::delta_e_itp_masked(&a.pixels, &b.pixels, &mask);
    for i in 0..mask.len() {
        let want = if mask[i] {
            compare::delta_e_itp(a.pixels[i].map(f64::from), b.pixels[i].map(f64::from)) as f32
        } else {
            0.0
        };
        assert_eq!(masked[i], want, "pixel {i}");
    }
    let full = compare::delta_e_itp_map(&a.pixels, &b.pixels);
    assert_eq!(
        compare::summarise(&masked, &mask, 1.0),
        compare::summarise(&full, &mask, 1.0)
    );
    assert!(masked.iter().any(|&e| e > 1.0), "the images differ");
}

/// ΔE_ITP of images: identical images give 0, swapping reference and test gives the same map.
#[test]
fn delta_e_itp_is_zero_for_equal_and_symmetric() {
    let cases = fig7_cases(64);
    let a = cases[0].scene.render(&|| {});
    let mut s = cases[0].scene.clone();
    s.materials[0].model = Model::blinn_aluminium();
    let b = s.render(&|| {});
    assert!(
        compare::delta_e_itp_map(&a.pixels, &a.pixels)
            .iter()
            .all(|&e| e == 0.0)
    );
    let ab = compare::delta_e_itp_map(&a.pixels, &b.pixels);
    let ba = compare::delta_e_itp_map(&b.pixels, &a.pixels);
    assert_eq!(ab, ba);
    assert!(ab.iter().any(|&e| e > 1.0), "the images differ");
}

/// LDR-ꟻLIP against NVIDIA's flip-evaluator 1.7 (PyPI) on three stored image pairs; the
/// reference values and how they were made are in tests/data/flip/.
#[test]
fn flip_matches_nvidia_flip_evaluator() {
    let dir = crate::common::root().join("tests/data/flip");
    let text = std::fs::read_to_string(dir.join("reference.csv")).unwrap();
    let mut n = 0;
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let read = |s: &str| {
            let img = image::open(dir.join(format!("{}-{s}.png", f[0])))
                .unwrap()
                .to_rgb8();
            (img.width(), img.height(), img.into_raw())
        };
        let ((w, h, r), (_, _, t)) = (read("ref"), read("test"));
        let map = compare::flip(&r, &t, w, h);
        let s = compare::summarise(&map, &[], 0.05);
        let max = map.iter().cloned().fold(0.0f32, f32::max) as f64;
        let want: Vec<f64> = f[1..].iter().map(|v| v.parse().unwrap()).collect();
        for (got, want, what) in [
            (s.mean, want[0], "mean"),
            (s.p99, want[1], "p99"),
            (max, want[2], "max"),
        ] {
            assert!(
                (got - want).abs() <= 2e-3,
                "{} {what}: brdfit {got}, flip-evaluator {want}",
                f[0]
            );
        }
        n += 1;
    }
    assert_eq!(n, 3);
}

pub(crate) fn choose_file(file: &str) -> brdfit::choose::ChooseResult {
    let ds = crate::common::load(file);
    let ds = brdfit::data::representative_channel(&ds).unwrap().0;
    choose::choose(&ds, &fig7_cases(512), &ChooseOptions::default(), &|_| {})
        .unwrap()
        .0
}

pub(crate) fn chosen(r: &brdfit::choose::ChooseResult, case: &str) -> (Option<String>, String) {
    let c = r.cases.iter().find(|c| c.case == case).unwrap();
    (c.chosen.clone(), c.closest.clone())
}

/// Blinn 1977, Figure 7, on his MgO: front lit a Phong-type model is enough; edge lit it is
/// not, and Torrance–Sparrow is.
#[test]
fn blinn_mgo_front_needs_phong_edge_needs_torrance_sparrow() {
    let r = choose_file("data/blinn-mgo.csv");
    assert_eq!(r.cases[0].reference, "measured");
    let (front, _) = chosen(&r, "front");
    assert!(
        matches!(front.as_deref(), Some("phong") | Some("blinn-phong")),
        "front: {front:?}"
    );
    let (edge, _) = chosen(&r, "edge");
    assert!(
        edge.as_deref()
            .is_some_and(|m| m.starts_with("torrance-sparrow")),
        "edge: {edge:?}"
    );
    // The README states these verdicts.
    for (case, got) in [("front", &front), ("edge", &edge)] {
        let named = crate::readme::verdict_name(got.clone());
        assert_eq!(
            named,
            crate::readme::readme_verdict("blinn-mgo", case),
            "{case}"
        );
    }
    // Phong and Blinn–Phong are over the threshold edge lit.
    let e = r.cases.iter().find(|c| c.case == "edge").unwrap();
    for m in e.models.iter().filter(|m| m.model.contains("phong")) {
        assert!(m.flip_p99 > 0.05, "{} {}", m.model, m.flip_p99);
    }
}

/// Lambertian data: every scene needs lambert.
#[test]
fn lambertian_data_needs_lambert_everywhere() {
    let m = Model::new(ModelKind::Lambert, Distribution::D3, &[0.5]).unwrap();
    let ds = brdfit::simulate(&m, &Grid::Hemisphere(10_000).directions(5), 0.01, 5);
    let r = choose::choose(&ds, &fig7_cases(512), &ChooseOptions::default(), &|_| {})
        .unwrap()
        .0;
    for c in &r.cases {
        assert_eq!(c.chosen.as_deref(), Some("lambert"), "{}", c.case);
    }
}

/// MERL alumina-oxide (bundled, green channel), stated in the README: front lit no model of
/// the catalogue is within the threshold (the measured rim darkens at grazing view, which no
/// model does), the closest being a Torrance–Sparrow lobe (D3 or ABC), its GGX twins or the
/// tabulated-NDF model (front lit it is the closest); edge lit none either; neither case is `chosen` (the reference's own error is stated).
#[test]
fn merl_alumina_oxide_choices() {
    let r = choose_file("data/merl-alumina-oxide.csv");
    let (front, closest) = chosen(&r, "front");
    assert_eq!(front, None);
    assert!(
        [
            "torrance-sparrow-d3",
            "torrance-sparrow-abc",
            "ggx-smith",
            "ggx-smith-2",
            "tabulated-ndf"
        ]
        .contains(&closest.as_str()),
        "{closest}"
    );
    // The grid stops at θi = 80°: the reference's own error (the extrapolation fold) says so.
    for c in &r.cases {
        assert_ne!(c.verdict, choose::Verdict::Chosen, "{}", c.case);
        assert!(c.reference_error.is_some() && !c.reason.is_empty());
    }
    let (edge, closest) = chosen(&r, "edge");
    assert_eq!(edge, None);
    assert!(
        [
            "torrance-sparrow-d3",
            "torrance-sparrow-abc",
            "ggx-smith",
            "ggx-smith-2",
            "tabulated-ndf"
        ]
        .contains(&closest.as_str()),
        "{closest}"
    );
    // The README states these verdicts.
    for case in ["front", "edge"] {
        let named = crate::readme::verdict_name(chosen(&r, case).0);
        assert_eq!(
            named,
            crate::readme::readme_verdict("merl-alumina-oxide", case),
            "{case}"
        );
    }
}

/// `choose.json` has the documented keys, `metric` names an error key of the rows, and the
/// renders are where the README documents them.
#[test]
fn choose_cli_writes_the_documented_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ch");
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args([
            "choose",
            "data/blinn-mgo.csv",
            "--res",
            "96",
            "--verify",
            "0",
            "-o",
        ])
        .arg(&out)
        .current_dir(crate::common::root())
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let stderr = String::from_utf8_lossy(&st.stderr);
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("choose.json")).unwrap()).unwrap();
    let metric = v["threshold"]["metric"].as_str().unwrap();
    assert_eq!(metric, "flip_p99");
    assert_eq!(v["threshold"]["value"], 0.05);
    let cases = v["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 2);
    for c in cases {
        let name = c["case"].as_str().unwrap();
        assert!(c["reference"].is_string() && c.get("chosen").is_some());
        assert!(out.join(name).join("measured.exr").exists());
        assert!(out.join(name).join("measured.png").exists());
        for m in c["models"].as_array().unwrap() {
            for key in [
                "model",
                "distribution",
                "params",
                "global_params",
                "bic",
                "flip_mean",
                "flip_p99",
                "delta_e_itp_mean",
                "delta_e_itp_p99",
                "rmse",
                "fit_seconds",
                "render_seconds",
            ] {
                assert!(m.get(key).is_some(), "{key} missing");
            }
            assert!(m[metric].is_f64());
            let model = m["model"].as_str().unwrap();
            for ext in ["exr", "png"] {
                let p = out.join(name).join(format!("{model}.{ext}"));
                assert!(p.exists(), "{}", p.display());
                assert!(stderr.contains(&format!("wrote {}", p.display())));
            }
        }
    }
    assert!(out.join("front/torrance-sparrow-d3.png").exists());
    // A bad threshold is a usage error naming the fix.
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args([
            "choose",
            "data/blinn-mgo.csv",
            "--threshold",
            "flip=0.1",
            "-o",
        ])
        .arg(&out)
        .current_dir(crate::common::root())
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("flip_p99"));
}

/// The contact sheet's ꟻLIP colour bar ends at the models' median ꟻLIP p99, rounded up to two
/// significant digits (worked by hand): of 0.005, 0.062, 0.114, 0.119, 0.472, 0.474, 0.644
/// the median is 0.119 → 0.12; of seven models near 0.03 (the maps that were black on a
/// fixed 0–1 scale) it is 0.0305 → 0.031; of two, the upper one; the scale stays in [0.01, 1].
#[test]
fn flip_map_scale_follows_the_data() {
    use brdfit::choose::flip_scale;
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    let edge = [0.644, 0.474, 0.472, 0.005, 0.062, 0.119, 0.114];
    assert!(close(flip_scale(&edge), 0.12), "{}", flip_scale(&edge));
    let near = [0.028, 0.031, 0.0305, 0.029, 0.033, 0.027, 0.034];
    assert!(close(flip_scale(&near), 0.031), "{}", flip_scale(&near));
    assert!(close(flip_scale(&[0.0337, 0.02]), 0.034));
    assert!(close(flip_scale(&[0.0999]), 0.1));
    assert!(close(flip_scale(&[0.004]), 0.01));
    assert!(close(flip_scale(&[1.7, 2.0]), 1.0));
    assert!(close(flip_scale(&[]), 0.01));
    assert!(close(flip_scale(&[f64::NAN, 0.2]), 0.2));
}

/// A misspelt threshold metric is a usage error, exit code 2, as a misspelt `--model` is,
/// and the message names the nearest metric.
#[test]
fn misspelt_threshold_metric_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args([
            "choose",
            "data/blinn-mgo.csv",
            "--threshold",
            "flip_p98=0.05",
            "-o",
        ])
        .arg(dir.path().join("out"))
        .current_dir(crate::common::root())
        .output()
        .unwrap();
    assert_eq!(st.status.code(), Some(2));
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(
        err.contains("flip_p98") && err.contains("--threshold flip_p99=0.05"),
        "{err}"
    );
    // Nothing was written.
    assert!(!dir.path().join("out").exists());
}

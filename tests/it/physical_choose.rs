//! `choose` uses only physical fits, and judges whichever of a model's two fits (scene-weighted,
//! global) renders closer: two cases (Blinn's MgO edge lit, MERL steel edge lit).

use brdfit::choose::{self, ChooseOptions, FitUsed, fig7_cases};
use brdfit::data::nbrdf::Nbrdf;
use brdfit::data::{Dataset, Quantity};

fn get(p: &[(String, f64)], k: &str) -> Option<f64> {
    p.iter().find(|(n, _)| n == k).map(|x| x.1)
}

/// The hand rules: pd > 1, or the index at its lower bound (1.0001) with ps above 1000.
fn plainly_unphysical(p: &[(String, f64)]) -> bool {
    get(p, "pd").is_some_and(|pd| pd > 1.0)
        || (get(p, "n").is_some_and(|n| n <= 1.0002) && get(p, "ps").is_some_and(|ps| ps > 1e3))
}

/// Every row: a plainly unphysical fit is marked; the judged fit is the usable one, or the one
/// rendering closer; the row's error is the judged fit's; the chosen model is usable.
fn check(r: &choose::ChooseResult) -> usize {
    let mut marked = 0;
    for c in &r.cases {
        for m in &c.models {
            if plainly_unphysical(&m.params) {
                assert!(
                    !m.unusable.is_empty(),
                    "{} {}: {:?}",
                    c.case,
                    m.model,
                    m.params
                );
                marked += 1;
            }
            if plainly_unphysical(&m.global_params) {
                assert!(
                    !m.global_unusable.is_empty(),
                    "{} {} global",
                    c.case,
                    m.model
                );
                marked += 1;
            }
            let (su, gu) = (m.unusable.is_empty(), m.global_unusable.is_empty());
            let want = match (su, gu) {
                (true, false) => FitUsed::SceneWeighted,
                (false, true) => FitUsed::Global,
                _ if m.global_flip_p99 < m.scene_flip_p99 => FitUsed::Global,
                _ => FitUsed::SceneWeighted,
            };
            assert_eq!(m.used, want, "{} {}", c.case, m.model);
            let p99 = match m.used {
                FitUsed::SceneWeighted => m.scene_flip_p99,
                FitUsed::Global => m.global_flip_p99,
            };
            assert_eq!(m.flip_p99, p99);
            assert_eq!(m.usable, if m.used == FitUsed::Global { gu } else { su });
        }
        if let Some(chosen) = &c.chosen {
            let m = c.models.iter().find(|m| &m.model == chosen).unwrap();
            assert!(m.usable && m.flip_p99 <= 0.05, "{}: {chosen}", c.case);
            let p = match m.used {
                FitUsed::SceneWeighted => &m.params,
                FitUsed::Global => &m.global_params,
            };
            assert!(!plainly_unphysical(p), "{}: chosen {chosen} {p:?}", c.case);
        }
    }
    marked
}

fn opts() -> ChooseOptions {
    ChooseOptions {
        verify: 0,
        ..Default::default()
    }
}

/// Blinn's MgO: edge lit, the simple models' scene-weighted fits reach pd > 1 (lambert
/// pd 5.65, blinn-phong pd 3.34 at 512²) and are marked; Torrance–Sparrow is chosen. On the
/// way, the progress lines (a bar's steps) are as many as `progress_steps` says, one per
/// candidate's global fit among them, and one per cross-validation fold: the 10,000 samples
/// are scattered (no θi or azimuth slices), so two folds, without the even and the odd
/// samples.
#[test]
fn blinn_mgo_edge_lit_marks_albedo_above_one() {
    let ds = crate::common::load("data/blinn-mgo.csv");
    let lines = std::sync::Mutex::new(Vec::new());
    let cases = fig7_cases(128);
    let (r, _) = choose::choose(&ds, &cases, &opts(), &|l| {
        lines.lock().unwrap().push(l.to_string())
    })
    .unwrap();
    let lines = lines.into_inner().unwrap();
    assert_eq!(lines.len(), choose::progress_steps(&ds, &cases, &opts()));
    let folds: Vec<&String> = lines
        .iter()
        .filter(|l| l.starts_with("cross-validation fold refitted and rebuilt"))
        .collect();
    assert_eq!(folds.len(), 2, "{lines:#?}");
    assert!(folds.iter().any(|l| l.contains("(even)")), "{folds:?}");
    assert!(folds.iter().any(|l| l.contains("(odd)")), "{folds:?}");
    let table = lines
        .iter()
        .filter(|l| l.starts_with("resampled table rebuilt"));
    assert_eq!(table.count(), 1, "{lines:#?}");
    for (kind, dist) in opts().candidates {
        let global = format!("{}: global fit in ", kind.label(dist));
        let n = lines.iter().filter(|l| l.starts_with(&global)).count();
        assert_eq!(n, 1, "{global}: {lines:#?}");
    }
    let marked = check(&r);
    let edge = r.cases.iter().find(|c| c.case == "edge").unwrap();
    let lambert = edge.models.iter().find(|m| m.model == "lambert").unwrap();
    assert!(
        get(&lambert.params, "pd").unwrap() > 1.0,
        "{:?}",
        lambert.params
    );
    assert!(lambert.unusable.iter().any(|w| w.contains("> 1")));
    assert!(marked >= 2, "{marked} marked");
    assert_eq!(edge.chosen.as_deref(), Some("torrance-sparrow-d3"));
}

/// MERL steel (green, the goniometer grid of its network): edge lit, the GGX fit with n at its
/// bound and ps ≈ 1e4 is never what is chosen.
#[test]
fn merl_steel_never_chooses_a_lobe_held_down_by_fresnel() {
    let net = Nbrdf::load(
        &crate::common::root().join("tests/data/nbrdf/weights-merl8.json"),
        "merl/steel",
    )
    .unwrap();
    let rgb = brdfit::simulate::simulate_nbrdf(
        &net,
        &brdfit::simulate::Grid::Goniometer.directions(0),
        false,
    );
    let mut ds = Dataset::new(Quantity::Brdf, vec![("g".into(), None)]);
    for k in 0..rgb.len() {
        ds.push(rgb.angles(k), &[rgb.channels[1].values[k]]);
    }
    let (r, _) = choose::choose(&ds, &fig7_cases(128), &opts(), &|_| {}).unwrap();
    check(&r);
}

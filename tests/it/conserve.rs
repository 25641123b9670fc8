//! Energy conservation as a constraint of the fit (`fit::conserve`): on RGL satin rosaline,
//! whose least-squares minima of every microfacet model reflect more light than arrives at
//! θi = 85° (beyond the data, which stop at 80°), the fits are held to an albedo of 1, usable,
//! and the recommendation is the best of them; their albedo is checked by an independent
//! quadrature (the midpoint rule of `ggx.rs`, not `model::albedo`).

use crate::common::load;
use crate::ggx::midpoint_albedo;
use brdfit::fit::conserve::HELD;
use brdfit::fit::{FitOptions, fit, fit_models, rank};
use brdfit::model::{Distribution, ModelKind};

/// The independent albedo of channel `c` of `f` at `deg`, on a grid fine enough for the
/// sharpest lobe here (GGX α ≈ 0.04: cells of 5e-4 rad in θo, 2e-3 rad in φo).
fn albedo(f: &brdfit::FitResult, c: usize, deg: f64) -> f64 {
    midpoint_albedo(&f.model_for(c), deg.to_radians(), 3000, 3000)
}

/// `fit --model all --verify 8` on satin's green channel: every fit is usable (none is
/// rejected for an albedo above 1 at θi = 85°, beyond the measured 0–80°), so no fit beats the
/// recommendation by more than 10 BIC for a reason outside the measured range, and the
/// recommendation is a microfacet model, not phong (the unconstrained ranking recommended
/// phong, 29,000 BIC behind GGX–Smith-2). Each held fit's albedo is at most 1 (+0.2 % for
/// the midpoint rule's error) at 85° and at normal incidence by the independent quadrature,
/// and holding it cost something (its cost is above the unconstrained fit's).
#[test]
fn satin_recommendation_is_the_best_physical_fit() {
    let ds = load("tests/data/satin_rosaline_rgb.csv")
        .select(&brdfit::ChannelSelect::Name("g".into()))
        .unwrap();
    let opts: Vec<FitOptions> = brdfit::fit::all_models()
        .into_iter()
        .map(|(kind, dist)| {
            let mut o = FitOptions::new(kind);
            o.dist = dist;
            o.verify = 8;
            o
        })
        .collect();
    let (fits, _) = fit_models(&ds, &opts, 1).unwrap();
    let fits: Vec<brdfit::FitResult> = fits.into_iter().map(|mut v| v.remove(0)).collect();
    let (_, rec) = rank(&fits);
    let rec = &fits[rec.expect("a recommendation")];
    for f in &fits {
        assert!(f.usable(), "{}: {:?}", f.label(), f.unusable);
        assert!(f.bic >= rec.bic - 10.0 || f.usable());
    }
    assert!(
        !matches!(rec.model, ModelKind::Phong | ModelKind::Lambert),
        "{}",
        rec.label()
    );
    let mut held = 0;
    for f in fits
        .iter()
        .filter(|f| f.warnings.iter().any(|w| w.starts_with(HELD)))
    {
        for deg in [0.0, 85.0] {
            let a = albedo(f, 0, deg);
            assert!(a <= 1.002, "{} θi {deg}: {a}", f.label());
        }
        held += 1;
    }
    assert!(held >= 5, "{held} fits held");
    // The held GGX–Smith-2 fit against the unconstrained one: dearer, and the unconstrained
    // one reflects more than it receives at 85° by the same independent quadrature.
    let mut free = FitOptions::new(ModelKind::GgxSmith2);
    free.conserve = false;
    let free = &fit(&ds, &free).unwrap()[0];
    let held = fits
        .iter()
        .find(|f| f.model == ModelKind::GgxSmith2)
        .unwrap();
    assert!(albedo(free, 0, 85.0) > 1.05, "{}", albedo(free, 0, 85.0));
    assert!(held.cost > free.cost, "{} {}", held.cost, free.cost);
}

/// The fixes the messages name are accepted: `fit --model ggx-smith` (the Mitsuba export's
/// advice), `--fix n=1.5` (the low-index rule's) and `--max-theta 75` all give usable fits on
/// every channel of satin, each held at an albedo of at most 1 by the independent quadrature.
#[test]
fn the_fixes_messages_suggest_are_usable() {
    let ds = load("tests/data/satin_rosaline_rgb.csv");
    let plain = FitOptions::new(ModelKind::GgxSmith);
    let mut fixed = FitOptions::new(ModelKind::GgxSmith);
    fixed.fix = vec![("n".into(), 1.5)];
    let mut cut = FitOptions::new(ModelKind::TorranceSparrow);
    cut.dist = Distribution::D3;
    cut.max_theta_deg = Some(75.0);
    for o in [plain, fixed, cut] {
        for f in fit(&ds, &o).unwrap() {
            assert!(f.usable(), "{} {}: {:?}", f.label(), f.channel, f.unusable);
            let a = albedo(&f, 0, 85.0);
            assert!(a <= 1.002, "{} {}: {a}", f.label(), f.channel);
        }
    }
}
